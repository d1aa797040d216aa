//! `gltf-pbr`: the glTF 2.0 metallic-roughness material, the model of Blender's
//! Principled BSDF, three.js, Unreal and Unity, as the glTF 2.0 specification writes it
//! (Khronos, *glTF 2.0 Specification*, Appendix B "BRDF Implementation", B.2-B.3):
//!
//! ```text
//! material        = mix(dielectric_brdf, metal_brdf, metallic)
//! metal_brdf      = conductor_fresnel(f0 = baseColor, bsdf = specular_brdf(α = roughness²))
//! dielectric_brdf = fresnel_mix(ior = 1.5, base = diffuse_brdf(baseColor),
//!                               layer = specular_brdf(α = roughness²))
//! ```
//!
//! With c = |V·H| = cos θd, w = (1 − c)⁵ (Schlick), the dielectric's
//! F = 0.04 + 0.96 w (f0 = ((1 − 1.5)/(1 + 1.5))² = 0.04), specular_brdf = D·V and
//! diffuse_brdf = baseColor/π, the mix expands per channel to
//!
//! f_r = (1 − m) · 0.96 (1 − w) · baseColor/π + D·V · (f0 + (1 − f0) w),
//! f0 = mix(0.04, baseColor, m) = 0.04 (1 − m) + m · baseColor
//!
//! (B.3.5's `f0 = mix(vec3(0.04), baseColor, metallic)` form, identical to the mix).
//!
//! - D: GGX / Trowbridge-Reitz (B.3.2; Walter et al. 2007 eq. 33),
//!   D = α² / (π ((N·H)² (α² − 1) + 1)²), computed as 1/(π α² s²) with
//!   s = (hx² + hy²)/α² + hz²;
//! - V = G/(4 |N·L| |N·V|) with S(v) = √(vz² + α² (vx² + vy²)):
//!   `smith-correlated` (the default; height-correlated Smith, Heitz 2014 eq. 99, the
//!   form of the Khronos glTF Sample Renderer, three.js and Filament)
//!   V = 1/(2 (zo Si + zi So)), or `smith-separable` (B.3.2's G = G1(L) G1(V) as the
//!   specification's text writes it) V = 1/((zi + Si)(zo + So));
//! - exactly 0 unless cos θi > 0 and cos θo > 0.
//!
//! | parameter | JSON | per channel | domain | default |
//! |-----------|------|-------------|--------|---------|
//! | baseColor | `base_color` | yes | [0, 1] | 0.5 |
//! | metallic | `metallic` | no | [0, 1] | 0.5 |
//! | roughness | `roughness` | no | [1e-3, 1] | 0.5 |
//! | masking | `masking` | structural | `smith-correlated`, `smith-separable` | `smith-correlated` |
//!
//! The domains are the format's own (`metallicFactor`, `roughnessFactor` and
//! `baseColorFactor` are in [0, 1] in glTF), except roughness ≥ 1e-3: α = roughness² ≥
//! 1e-6, the smallest α of `cook-torrance`, where D is still finite (roughness 0 is a
//! perfect mirror, a delta no table can be fitted to). The fit's logit reparameterisation
//! keeps every parameter inside its domain, so a fitted model is always a valid glTF
//! material.
//!
//! **Reciprocal** (F at V·H = L·H, D and both V forms symmetric). **Energy: not
//! conserved** ([`Model::conserves_energy`] is false): `fresnel_mix` weights the diffuse
//! base by 1 − F(V·H) pair by pair rather than by what the coating lets through, so at
//! grazing incidence a white dielectric reflects more than it receives. Measured
//! (tests, default quadrature): with baseColor 1, metallic 0, roughness 0.05 the
//! directional albedo is 1.00 at θ = 0, 1.09 at 69° and 1.64 at 86° (roughness 0.5:
//! 1.03 at 69°, 1.12 at 86°); a metal (metallic 1) stays ≤ 1. This is the format's
//! model, kept as written: a fit reproduces what glTF viewers render.

use crate::cook_torrance::ggx_iso_dv;
use crate::json;
use crate::pair::PairGeom;
use crate::params::{above_horizon, channel, check_count, check_rgb};
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::scattering::Masking;
use brdfkit_core::scattering::fresnel::schlick_weight;
use brdfkit_core::{Model, ModelError, ParamSpec, Rgb};
use serde_json::{Value, json};
use std::f64::consts::FRAC_1_PI;

/// The domain of the base colour (every channel) and of `metallic`.
pub const UNIT_DOMAIN: Domain = Domain::closed(0.0, 1.0);
/// The domain of `roughness`: α = roughness² ≥ 1e-6 (module doc).
pub const ROUGHNESS_DOMAIN: Domain = Domain::closed(1e-3, 1.0);
/// The dielectric's normal-incidence reflectance, ((1 − 1.5)/(1 + 1.5))² (B.3.4).
pub const DIELECTRIC_F0: f64 = 0.04;

const M: &str = "gltf-pbr";
const DEFAULTS: (f64, f64, f64) = (0.5, 0.5, 0.5);

/// The glTF 2.0 metallic-roughness BRDF (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct GltfPbr {
    base_color: Rgb,
    metallic: f64,
    roughness: f64,
    masking: Masking,
}

impl Default for GltfPbr {
    fn default() -> Self {
        GltfPbr {
            base_color: Rgb::splat(DEFAULTS.0),
            metallic: DEFAULTS.1,
            roughness: DEFAULTS.2,
            masking: Masking::SmithCorrelated,
        }
    }
}

impl GltfPbr {
    /// A material with the given factors and the default (height-correlated) masking.
    pub fn new(base_color: Rgb, metallic: f64, roughness: f64) -> Result<Self, ModelError> {
        GltfPbr {
            base_color: check_rgb("base_color", base_color, UNIT_DOMAIN)?,
            metallic: check_param("metallic", metallic, UNIT_DOMAIN)?,
            roughness: check_param("roughness", roughness, ROUGHNESS_DOMAIN)?,
            masking: Masking::SmithCorrelated,
        }
        .with_masking(Masking::SmithCorrelated)
    }

    /// Sets the masking: `smith-correlated` or `smith-separable` (the V-cavity is not a
    /// glTF form and is refused).
    pub fn with_masking(mut self, m: Masking) -> Result<Self, ModelError> {
        if m == Masking::VCavity {
            return Err(ModelError::Invalid(
                "`masking` of `gltf-pbr` must be smith-correlated or smith-separable".into(),
            ));
        }
        self.masking = m;
        Ok(self)
    }

    /// `baseColorFactor` (RGB).
    pub fn base_color(&self) -> Rgb {
        self.base_color
    }
    /// `metallicFactor`.
    pub fn metallic(&self) -> f64 {
        self.metallic
    }
    /// `roughnessFactor` (α = roughness²).
    pub fn roughness(&self) -> f64 {
        self.roughness
    }
    /// The masking form.
    pub fn masking(&self) -> Masking {
        self.masking
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        let o = json::params_object(params, M)?;
        json::deny_unknown(&o, &["base_color", "metallic", "roughness", "masking"], M)?;
        GltfPbr::new(
            json::rgb_or(&o, "base_color", DEFAULTS.0, M)?,
            json::number_or(&o, "metallic", DEFAULTS.1, M)?,
            json::number_or(&o, "roughness", DEFAULTS.2, M)?,
        )?
        .with_masking(json::choice_or(&o, "masking", Masking::SmithCorrelated, M)?)
    }

    /// f_r of one pair and, with `grad`, its gradient in the order
    /// base_color.{r,g,b}, metallic, roughness.
    #[inline(always)]
    fn kernel(&self, p: PairGeom, grad: Option<&mut [Rgb; 5]>) -> Rgb {
        let PairGeom { wi, wo, h, .. } = p;
        let Some(grad) = above_horizon(&wi, &wo, grad) else {
            return Rgb::ZERO;
        };
        let cd = p.cos_d;
        // Without `grad` the inlined derivative is dead code, and the compiler drops it.
        let (dv, d_r) = ggx_dv(self.roughness, self.masking, [wi, wo, h]);
        let w = schlick_weight(cd);
        let m = self.metallic;
        let diff_k = (1.0 - m) * (1.0 - DIELECTRIC_F0) * (1.0 - w) * FRAC_1_PI;
        let bc = self.base_color;
        let f0 = bc.0.map(|b| DIELECTRIC_F0 * (1.0 - m) + m * b);
        let f: [f64; 3] = std::array::from_fn(|k| f0[k] + (1.0 - f0[k]) * w);
        let out = Rgb(std::array::from_fn(|k| diff_k * bc[k] + dv * f[k]));
        if let Some(g) = grad {
            for (k, gk) in g[..3].iter_mut().enumerate() {
                *gk = channel(k, diff_k + dv * m * (1.0 - w));
            }
            g[3] = Rgb(std::array::from_fn(|k| {
                -(1.0 - DIELECTRIC_F0) * (1.0 - w) * FRAC_1_PI * bc[k]
                    + dv * (1.0 - w) * (bc[k] - DIELECTRIC_F0)
            }));
            g[4] = Rgb(std::array::from_fn(|k| dv * f[k] * d_r));
        }
        out
    }
}

/// glTF's GGX D·V (Appendix B: D with α = roughness², V the height-correlated or
/// separable Smith term of `masking`) of `[wi, wo, h]` (h the half vector), and
/// ∂ln(D·V)/∂roughness = 2 roughness ∂ln(D·V)/∂α: `cook-torrance`'s GGX lobe
/// ([`ggx_iso_dv`]), the one kernel of the core model and of [`crate::gltf_pbr_ext`]'s
/// core and clear coat. Both directions must be above the horizon (the callers return
/// 0 below it).
#[inline(always)]
pub(crate) fn ggx_dv(roughness: f64, masking: Masking, dirs: [[f64; 3]; 3]) -> (f64, f64) {
    let correlated = masking == Masking::SmithCorrelated;
    let (dv, dln_a) = ggx_iso_dv(roughness * roughness, correlated, dirs);
    (dv, dln_a * 2.0 * roughness)
}

crate::pair::pair_kernel_brdf!(GltfPbr);

model_name!(GltfPbr, M);

impl Model for GltfPbr {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let mut v = ParamSpec::per_channel("base_color", UNIT_DOMAIN, DEFAULTS.0).to_vec();
        v.push(ParamSpec::shared("metallic", UNIT_DOMAIN, DEFAULTS.1));
        v.push(ParamSpec::shared("roughness", ROUGHNESS_DOMAIN, DEFAULTS.2));
        v
    }

    fn params(&self) -> Vec<f64> {
        let b = self.base_color.0;
        vec![b[0], b[1], b[2], self.metallic, self.roughness]
    }

    fn num_params(&self) -> usize {
        5
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        check_count(5, p.len())?;
        *self = GltfPbr::new(Rgb::new(p[0], p[1], p[2]), p[3], p[4])?.with_masking(self.masking)?;
        Ok(())
    }

    crate::pair::pair_kernel_evals!(5);

    fn to_json(&self) -> Value {
        json!({"model": M, "params": {
            "base_color": json::rgb_value(self.base_color),
            "metallic": self.metallic,
            "roughness": self.roughness,
            "masking": self.masking.name(),
        }})
    }

    /// False: a white dielectric exceeds albedo 1 at grazing incidence (module doc).
    fn conserves_energy(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::*;
    use brdfkit_core::Brdf;
    use brdfkit_core::direction::spherical;
    use brdfkit_core::quadrature::{AlbedoQuadrature, directional_albedo};
    use std::f64::consts::PI;

    fn model(masking: Masking) -> GltfPbr {
        GltfPbr::new(Rgb::new(0.8, 0.4, 0.1), 0.3, 0.45)
            .unwrap()
            .with_masking(masking)
            .unwrap()
    }

    /// The specification's functions transcribed term by term, in angles (independent of
    /// the kernel's algebra): B.3.2's D and G1, B.3.4's mixes.
    fn spec_formula(m: &GltfPbr, ti: f64, pi: f64, to: f64, po: f64) -> Rgb {
        let l = spherical(ti, pi);
        let v = spherical(to, po);
        let hs = l + v;
        let h = hs / hs.norm();
        let (nl, nv, nh, vh) = (l.z, v.z, h.z, v.dot(&h).abs());
        let a = m.roughness * m.roughness;
        let a2 = a * a;
        let d = a2 / (PI * (nh * nh * (a2 - 1.0) + 1.0).powi(2));
        let vis = match m.masking {
            Masking::SmithSeparable => {
                let g1 = |x: f64| 2.0 * x / (x + (a2 + (1.0 - a2) * x * x).sqrt());
                g1(nl) * g1(nv) / (4.0 * nl * nv)
            }
            _ => {
                0.5 / (nl * (nv * nv * (1.0 - a2) + a2).sqrt()
                    + nv * (nl * nl * (1.0 - a2) + a2).sqrt())
            }
        };
        let spec = d * vis;
        let fr = 0.04 + 0.96 * (1.0 - vh).powi(5);
        Rgb(std::array::from_fn(|k| {
            let bc = m.base_color[k];
            let metal = spec * (bc + (1.0 - bc) * (1.0 - vh).powi(5));
            let diel = (1.0 - fr) * bc / PI + fr * spec;
            (1.0 - m.metallic) * diel + m.metallic * metal
        }))
    }

    #[test]
    fn matches_the_specification_formulas() {
        for masking in [Masking::SmithCorrelated, Masking::SmithSeparable] {
            let m = model(masking);
            assert_matches_angle_formula(&m, 7, 400, 1.5, 1e-12, |a, b, c, d| {
                spec_formula(&m, a, b, c, d)
            });
        }
    }

    /// Math once (issue 25): at metallic 1 the model is `cook-torrance` with GGX,
    /// ρd = 0, ρs = 1, α = roughness² and Schlick's f0 = base colour, through the same
    /// lobe code, so the values agree to the bit; the roughness derivative is
    /// cook-torrance's α derivative × 2 roughness (one product apart).
    #[test]
    fn metallic_one_is_cook_torrance_ggx_to_the_bit() {
        for masking in [Masking::SmithCorrelated, Masking::SmithSeparable] {
            for r in [0.05, 0.3, 0.8] {
                let metal = GltfPbr::new(Rgb::new(0.9, 0.6, 0.2), 1.0, r)
                    .unwrap()
                    .with_masking(masking)
                    .unwrap();
                let ct = crate::from_json_str(&format!(
                    r#"{{"model": "cook-torrance", "params": {{"rho_d": 0, "rho_s": 1,
                        "alpha": {}, "masking": "{}",
                        "fresnel": {{"schlick": {{"f0": [0.9, 0.6, 0.2]}}}}}}}}"#,
                    r * r,
                    masking.name()
                ))
                .unwrap();
                let ia = ct.param_specs().iter().position(|p| p.name == "alpha");
                let ia = ia.expect("cook-torrance has alpha");
                let (mut g1, mut g2) = ([Rgb::ZERO; 5], vec![Rgb::ZERO; ct.num_params()]);
                for (wi, wo) in random_pairs(5, 400) {
                    let (a, b) = (metal.eval(&wi, &wo), ct.eval(&wi, &wo));
                    assert_eq!(a, b, "{masking:?} r {r}: {wi:?} {wo:?}");
                    metal.eval_grad(&wi, &wo, &mut g1);
                    ct.eval_grad(&wi, &wo, &mut g2);
                    for k in 0..3 {
                        let want = g2[ia][k] * 2.0 * r;
                        let tol = 1e-14 * want.abs() + 1e-300;
                        assert!((g1[4][k] - want).abs() <= tol, "{} {want}", g1[4][k]);
                    }
                }
            }
        }
    }

    #[test]
    fn shared_checks_both_maskings_and_hard_shapes() {
        let pairs = random_pairs(11, 300);
        for masking in [Masking::SmithCorrelated, Masking::SmithSeparable] {
            let m = model(masking);
            assert_paths_agree(&m, &pairs, 0.0);
            assert_reciprocal(&m, &pairs, 1e-12);
            assert_reciprocal(&m, &dense_grid_pairs(20, 8), 1e-12);
            // At grazing back-scatter pairs cos θd = wi·h (or wo·h) is a cancellation
            // and loses ~1e-11 relative to round-off, as in cook-torrance.
            assert_reciprocal(&m, &hard_case_pairs(), 1e-10);
            assert_zero_below_horizon(&m);
            assert_gradient_matches_fd(&m, &pairs, 1e-6, 1e-6);
            for r in [1e-3, 0.05, 1.0] {
                for met in [0.0, 1.0] {
                    let m = GltfPbr::new(Rgb::new(1.0, 0.0, 0.5), met, r)
                        .unwrap()
                        .with_masking(masking)
                        .unwrap();
                    assert_finite_everywhere(&m, &hard_case_pairs());
                    assert_paths_agree(&m, &hard_case_pairs(), 0.0);
                    assert_nonnegative(&m, &dense_grid_pairs(16, 6));
                }
            }
        }
    }

    #[test]
    fn a_white_dielectric_gains_energy_at_grazing_and_a_metal_does_not() {
        let q = AlbedoQuadrature::default();
        let albedo = |met: f64, r: f64, t: f64| {
            let m = GltfPbr::new(Rgb::splat(1.0), met, r).unwrap();
            directional_albedo(&m, &spherical(t, 0.0), &q)[0]
        };
        // The figures of the module doc.
        assert!((albedo(0.0, 0.05, 0.0) - 1.0).abs() < 0.005);
        assert!((albedo(0.0, 0.05, 1.2) - 1.09).abs() < 0.005);
        assert!((albedo(0.0, 0.05, 1.5) - 1.64).abs() < 0.005);
        assert!((albedo(0.0, 0.5, 1.2) - 1.03).abs() < 0.005);
        assert!((albedo(0.0, 0.5, 1.5) - 1.12).abs() < 0.005);
        for r in [0.05, 0.2, 0.5, 1.0] {
            for t in [0.0, 0.6, 1.2, 1.5] {
                assert!(albedo(1.0, r, t) <= 1.0, "metal r {r} θ {t}");
            }
        }
        assert!(!GltfPbr::default().conserves_energy());
    }

    #[test]
    fn domains_and_json() {
        assert!(GltfPbr::new(Rgb::splat(0.5), 1.2, 0.5).is_err());
        assert!(GltfPbr::new(Rgb::splat(0.5), 0.5, 0.0).is_err());
        assert!(GltfPbr::new(Rgb::new(0.5, 1.1, 0.5), 0.5, 0.5).is_err());
        let m = model(Masking::SmithSeparable);
        assert_json_round_trip(&m);
        let e = crate::from_json_str(r#"{"model":"gltf-pbr","params":{"masking":"v-cavity"}}"#)
            .unwrap_err();
        assert!(e.to_string().contains("smith-correlated"), "{e}");
        assert!(crate::from_json_str(r#"{"model":"gltf-pbr","params":{"alpha":0.5}}"#).is_err());
        let mut m = model(Masking::SmithSeparable);
        assert!(m.set_params(&[0.1, 0.2, 0.3, 0.5, 2.0]).is_err());
        assert_eq!(m, model(Masking::SmithSeparable));
        m.set_params(&[0.1, 0.2, 0.3, 0.5, 0.2]).unwrap();
        assert_eq!(
            m.masking(),
            Masking::SmithSeparable,
            "set_params keeps the masking"
        );
    }
}
