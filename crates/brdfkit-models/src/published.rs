//! Published parameterisations: the model forms in which fitting papers published
//! their parameters, each an exact mapping onto a brdfkit model, so published
//! parameters load and score as they are.
//!
//! | JSON name | paper's form | brdfkit model | mapping |
//! |-----------|--------------|---------------|---------|
//! | `ngan-cook-torrance` | ρd/π + ks · D_B(h) G_V F_S(cos θd) / (π cos θi cos θo) | `cook-torrance`, `beckmann`, `v-cavity`, `schlick` | ρd = ρd, ρs = (4/π) ks, α = m, f0 = F0 |
//! | `ngan-ward` | ρd/π + ks · exp(−tan²θh/α²) / (4π α² √(cos θi cos θo)) | `ward`, normalisation `ward` | ρd = ρd, ρs = ks, α = α |
//! | `low-cook-torrance` | ρd/π + ks · D_CT(h) G_V F_η(cos θd) / (π cos θi cos θo) | `cook-torrance`, `beckmann`, `v-cavity`, `dielectric` | ρd = ρd, ρs = 4 ks, α = m, η = η |
//!
//! with D_B(h) = exp(−tan²θh/m²)/(π m² cos⁴θh) the normalised Beckmann distribution,
//! D_CT = π D_B the unnormalised one of Cook & Torrance 1982 (their eq. for D, without
//! the 1/π), G_V = min(1, 2 cos θh cos θo/(wo·h), 2 cos θh cos θi/(wi·h)) the V-cavity
//! masking of Cook & Torrance 1982, F_S = F0 + (1 − F0)(1 − cos θd)⁵ (Schlick 1994) and
//! F_η the unpolarised dielectric Fresnel reflectance of index η (Cook & Torrance 1982,
//! eq. 9: ½ (g−c)²/(g+c)² [1 + (c(g+c)−1)²/(c(g−c)+1)²], g² = η² + c² − 1).
//!
//! brdfkit's `cook-torrance` is ρd/π + ρs D_B G F / (4 cos θi cos θo) (Walter et al.
//! 2007, eq. 20), so Ngan's 1/π in place of 1/4 is ρs = (4/π) ks and Löw's
//! D_CT/π = D_B with 1/(cos θi cos θo) in place of 1/(4 …) is ρs = 4 ks.
//!
//! Sources of the forms: A. Ngan, F. Durand, W. Matusik, "Experimental Analysis of BRDF
//! Models", EGSR 2005 (§3 and the supplemental material of fitted parameters); J. Löw,
//! J. Kronander, A. Ynnerman, J. Unger, "BRDF Models for Accurate and Efficient
//! Rendering of Glossy Surfaces", ACM TOG 31(1), 2012 (supplemental fits); R. L. Cook,
//! K. E. Torrance, "A Reflectance Model for Computer Graphics", ACM TOG 1(1), 1982. The
//! exact forms (normalisation constants, the 1/π of the diffuse term) are those of the
//! BRDF Model Benchmark's transcriptions of the published fits (`bsdfbenchmark/bbm`,
//! `include/bsdfmodel/ngan.h`, `low.h`, `cooktorrance.h`, `ward.h`, `lambertian.h`),
//! which it uses to load the published parameter files; `data-measured/published/`
//! holds those parameters.
//!
//! The JSON parameters are the papers' names, every one required: `rho_d` (Lambertian
//! albedo, per channel), `k_s` (specular scale, per channel), and `m` + `f0` (per
//! channel), `alpha`, or `m` + `eta` (one real index).

use crate::cook_torrance::{CookTorrance, Fresnel};
use crate::json;
use crate::ward::{Normalization, Ward};
use brdfkit_core::scattering::{Distribution, Masking};
use brdfkit_core::{Model, ModelError, Rgb};
use serde_json::{Map, Value};
use std::f64::consts::PI;

/// The JSON names of the published parameterisations (each builds the brdfkit model of
/// its mapping; see the module table).
pub const PUBLISHED_NAMES: &[&str] = &["ngan-cook-torrance", "ngan-ward", "low-cook-torrance"];

/// Ngan et al. 2005's Cook-Torrance (Beckmann m, V-cavity, Schlick F0, the 1/π
/// normalisation) as brdfkit's `cook-torrance`: ρs = (4/π) ks.
pub fn ngan_cook_torrance(
    rho_d: Rgb,
    k_s: Rgb,
    f0: Rgb,
    m: f64,
) -> Result<CookTorrance, ModelError> {
    beckmann_v_cavity(Fresnel::Schlick { f0 }, rho_d, k_s * (4.0 / PI), m)
}

/// brdfkit's `cook-torrance` with Beckmann's distribution and V-cavity masking, as both
/// published Cook-Torrance parameterisations have them.
fn beckmann_v_cavity(
    fresnel: Fresnel,
    rho_d: Rgb,
    rho_s: Rgb,
    m: f64,
) -> Result<CookTorrance, ModelError> {
    CookTorrance::new()
        .with_distribution(Distribution::Beckmann)
        .with_masking(Masking::VCavity)
        .with_fresnel(fresnel)?
        .with_rho_d(rho_d)?
        .with_rho_s(rho_s)?
        .with_alpha(m)
}

/// Ngan et al. 2005's Ward (Ward 1992's normalisation, isotropic) as brdfkit's `ward`
/// with `normalization: ward`: the parameters map one to one.
pub fn ngan_ward(rho_d: Rgb, k_s: Rgb, alpha: f64) -> Result<Ward, ModelError> {
    Ward::new()
        .with_normalization(Normalization::Ward)
        .with_rho_d(rho_d)?
        .with_rho_s(k_s)?
        .with_alpha(alpha)
}

/// Löw et al. 2012's Cook-Torrance (Cook & Torrance 1982 as published: unnormalised
/// Beckmann, V-cavity, dielectric Fresnel of index η, 1/π) as brdfkit's
/// `cook-torrance`: ρs = 4 ks.
pub fn low_cook_torrance(
    rho_d: Rgb,
    k_s: Rgb,
    eta: f64,
    m: f64,
) -> Result<CookTorrance, ModelError> {
    beckmann_v_cavity(Fresnel::Dielectric { eta }, rho_d, k_s * 4.0, m)
}

/// A required entry of a published parameter set.
fn need<'a>(o: &'a Map<String, Value>, key: &str, model: &str) -> Result<&'a Value, ModelError> {
    o.get(key).ok_or_else(|| {
        ModelError::Invalid(format!(
            "`{model}` needs `{key}` (a published parameter set has no defaults)"
        ))
    })
}

/// A required per-channel entry.
fn need_rgb(o: &Map<String, Value>, key: &str, model: &str) -> Result<Rgb, ModelError> {
    need(o, key, model)?;
    json::rgb_or(o, key, 0.0, model)
}

/// A required scalar entry.
fn need_number(o: &Map<String, Value>, key: &str, model: &str) -> Result<f64, ModelError> {
    need(o, key, model)?;
    json::number_or(o, key, 0.0, model)
}

/// Builds the brdfkit model of a published parameterisation from its `params` (see
/// the module doc); `None` when `name` is not one of [`PUBLISHED_NAMES`].
pub fn from_params_json(name: &str, params: &Value) -> Option<Result<Box<dyn Model>, ModelError>> {
    let keys: &[&str] = match name {
        "ngan-cook-torrance" => &["rho_d", "k_s", "f0", "m"],
        "ngan-ward" => &["rho_d", "k_s", "alpha"],
        "low-cook-torrance" => &["rho_d", "k_s", "eta", "m"],
        _ => return None,
    };
    let build = || -> Result<Box<dyn Model>, ModelError> {
        let o = json::params_object(params, name)?;
        json::deny_unknown(&o, keys, name)?;
        let rho_d = need_rgb(&o, "rho_d", name)?;
        let k_s = need_rgb(&o, "k_s", name)?;
        Ok(match name {
            "ngan-cook-torrance" => Box::new(ngan_cook_torrance(
                rho_d,
                k_s,
                need_rgb(&o, "f0", name)?,
                need_number(&o, "m", name)?,
            )?),
            "ngan-ward" => Box::new(ngan_ward(rho_d, k_s, need_number(&o, "alpha", name)?)?),
            _ => Box::new(low_cook_torrance(
                rho_d,
                k_s,
                need_number(&o, "eta", name)?,
                need_number(&o, "m", name)?,
            )?),
        })
    };
    Some(build())
}

#[cfg(test)]
mod tests {
    //! Each mapping against the paper's formula, transcribed here independently in
    //! angles (no brdfkit scattering code).
    use super::*;
    use crate::testing::assert_matches_angle_formula;

    /// (cos θi, cos θo, cos θh, cos θd) of a direction pair in angles.
    fn angles(ti: f64, pi: f64, to: f64, po: f64) -> (f64, f64, f64, f64) {
        let wi = [ti.sin() * pi.cos(), ti.sin() * pi.sin(), ti.cos()];
        let wo = [to.sin() * po.cos(), to.sin() * po.sin(), to.cos()];
        let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let l = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        let h = [s[0] / l, s[1] / l, s[2] / l];
        let cd = wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2];
        (wi[2], wo[2], h[2], cd)
    }

    /// Cook & Torrance 1982's G (their eq. for the V-groove geometric attenuation).
    fn g_ct(ci: f64, co: f64, ch: f64, cd: f64) -> f64 {
        1f64.min(2.0 * ch * co / cd).min(2.0 * ch * ci / cd)
    }

    /// exp(−tan²θh/m²)/(m² cos⁴θh): Cook & Torrance's D, without 1/π.
    fn d_unnormalised(ch: f64, m: f64) -> f64 {
        let t2 = (1.0 - ch * ch) / (ch * ch);
        (-t2 / (m * m)).exp() / (m * m * ch.powi(4))
    }

    /// ρd/π + ks · spec per channel.
    fn lambert_plus(rd: Rgb, ks: Rgb, spec: f64) -> Rgb {
        Rgb::new(
            rd[0] / PI + ks[0] * spec,
            rd[1] / PI + ks[1] * spec,
            rd[2] / PI + ks[2] * spec,
        )
    }

    #[test]
    fn ngan_cook_torrance_matches_the_papers_formula() {
        let (rd, ks, f0, m) = (
            Rgb::new(0.0886, 0.0602, 0.0299),
            Rgb::new(0.118, 0.0698, 0.0371),
            Rgb::new(0.203, 0.203, 0.203),
            0.0367,
        );
        let model = ngan_cook_torrance(rd, ks, f0, m).unwrap();
        assert_matches_angle_formula(&model, 8, 400, 1.5, 1e-11, |ti, pi, to, po| {
            let (ci, co, ch, cd) = angles(ti, pi, to, po);
            let d = d_unnormalised(ch, m) / PI;
            let one = |c: usize| {
                let f = f0[c] + (1.0 - f0[c]) * (1.0 - cd).powi(5);
                rd[c] / PI + ks[c] * d * g_ct(ci, co, ch, cd) * f / (PI * ci * co)
            };
            Rgb::new(one(0), one(1), one(2))
        });
    }

    #[test]
    fn low_cook_torrance_matches_the_papers_formula() {
        let (rd, ks, eta, m) = (
            Rgb::new(0.1063, 0.0816, 0.0557),
            Rgb::new(0.05872, 0.04367, 0.05223),
            1.46492,
            0.08,
        );
        let model = low_cook_torrance(rd, ks, eta, m).unwrap();
        assert_matches_angle_formula(&model, 8, 400, 1.5, 1e-11, |ti, pi, to, po| {
            let (ci, co, ch, cd) = angles(ti, pi, to, po);
            // Cook & Torrance 1982, eq. 9.
            let c = cd;
            let g = (eta * eta + c * c - 1.0).sqrt();
            let f = 0.5
                * ((g - c) / (g + c)).powi(2)
                * (1.0 + ((c * (g + c) - 1.0) / (c * (g - c) + 1.0)).powi(2));
            let spec = d_unnormalised(ch, m) * g_ct(ci, co, ch, cd) * f / (PI * ci * co);
            lambert_plus(rd, ks, spec)
        });
    }

    #[test]
    fn ngan_ward_matches_the_papers_formula() {
        let (rd, ks, a) = (
            Rgb::new(0.0851, 0.0586, 0.0294),
            Rgb::new(0.0484, 0.0274, 0.0135),
            0.1,
        );
        let model = ngan_ward(rd, ks, a).unwrap();
        assert_matches_angle_formula(&model, 8, 400, 1.5, 1e-11, |ti, pi, to, po| {
            let (ci, co, ch, _) = angles(ti, pi, to, po);
            let t2 = (1.0 - ch * ch) / (ch * ch);
            let spec = (-t2 / (a * a)).exp() / (4.0 * PI * a * a * (ci * co).sqrt());
            lambert_plus(rd, ks, spec)
        });
    }

    #[test]
    fn json_names_build_the_mapped_models_and_need_every_parameter() {
        let v: Value = serde_json::json!({
            "rho_d": [0.1, 0.2, 0.3], "k_s": [0.05, 0.04, 0.03], "f0": 0.2, "m": 0.1
        });
        let m = from_params_json("ngan-cook-torrance", &v).unwrap().unwrap();
        let direct = ngan_cook_torrance(
            Rgb::new(0.1, 0.2, 0.3),
            Rgb::new(0.05, 0.04, 0.03),
            Rgb::splat(0.2),
            0.1,
        )
        .unwrap();
        assert_eq!(m.to_json(), direct.to_json());
        let rho_s = m.to_json()["params"]["rho_s"].clone();
        assert!((rho_s[0].as_f64().unwrap() - 0.2 / PI).abs() < 1e-15);
        let missing = serde_json::json!({"rho_d": 0.1, "k_s": 0.1, "m": 0.1});
        let e = from_params_json("ngan-cook-torrance", &missing)
            .unwrap()
            .err()
            .unwrap();
        assert!(e.to_string().contains("`f0`"), "{e}");
        let extra = serde_json::json!({"rho_d": 0.1, "k_s": 0.1, "alpha": 0.1, "x": 1});
        assert!(from_params_json("ngan-ward", &extra).unwrap().is_err());
        assert!(from_params_json("cook-torrance", &v).is_none());
        let low = serde_json::json!({"rho_d": 0.1, "k_s": 0.02, "eta": 1.5, "m": 0.2});
        let l = from_params_json("low-cook-torrance", &low)
            .unwrap()
            .unwrap();
        assert!((l.to_json()["params"]["rho_s"][0].as_f64().unwrap() - 0.08).abs() < 1e-15);
    }
}
