//! `oren-nayar`: diffuse reflection from a rough surface of V-shaped Lambertian facets,
//! the qualitative model.
//!
//! f_r(wi, wo) = ρd/π · (A + B · max(0, cos(φi − φo)) · sin α · tan β)
//!
//! A = 1 − 0.5 σ²/(σ² + 0.33),  B = 0.45 σ²/(σ² + 0.09),
//! α = max(θi, θo),  β = min(θi, θo),
//!
//! with σ the standard deviation of the facet slope angle in radians. M. Oren and
//! S. K. Nayar, "Generalization of Lambert's Reflectance Model", SIGGRAPH 1994 (the
//! qualitative model, without the interreflection term).
//!
//! | parameter | JSON    | per channel | domain   | default |
//! |-----------|---------|-------------|----------|---------|
//! | ρd        | `rho_d` | yes         | [0, 1]   | 0.5     |
//! | σ         | `sigma` | no          | [0, π/2] | 0.3     |
//!
//! σ = 0 is exactly Lambert (A = 1, B = 0). σ is capped at π/2: a standard deviation
//! of slope angles beyond 90° describes no surface.
//!
//! No trigonometry is evaluated: since sin α sin β = sin θi sin θo,
//! cos(φi − φo) sin θi sin θo = wi.x wo.x + wi.y wo.y and cos β = max(cos θi, cos θo),
//!
//! max(0, cos(φi − φo)) sin α tan β = max(0, wi.x wo.x + wi.y wo.y) / max(wi.z, wo.z),
//!
//! which avoids the overflow of tan β at β → 90° and the undefined azimuth at the
//! normal. The term genuinely diverges when both directions graze the horizon; the
//! denominator is floored at [`MIN_COS`] (see there).
//!
//! Reciprocal. Energy: the directional albedo is exactly ρd · A at normal incidence and
//! rises monotonically towards ρd (A + B/2) as θo → 90° (there max(wi.z, wo.z) = wi.z
//! and ∫ max(0, wi.x wo.x + wi.y wo.y) dωi = π/2). A + B/2 exceeds 1 for
//! 0 < σ < 0.326 (σ² < 0.02925/0.275), by at most 1.52 % at σ ≈ 0.199: the
//! qualitative model adds a little energy at grazing angles (measured: albedo 1.0144 ρd
//! at σ = 0.2, θo = 89°). So ρd ≤ 1 is not enough and [`Model::conserves_energy`] is
//! false; ρd ≤ 1/1.0152 = 0.985 suffices.

use crate::json;
use crate::pair::eval_above_horizon;
use crate::params::{RHO_DOMAIN, channel, check_count, check_rgb};
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::{Brdf, Columns, GeomSlice, Model, ModelError, ParamSpec, Rgb, Vec3};
use serde_json::{Value, json};
use std::f64::consts::{FRAC_1_PI, FRAC_PI_2};

/// The domain of σ (radians).
pub const SIGMA_DOMAIN: Domain = Domain::closed(0.0, FRAC_PI_2);

/// Floor of max(cos θi, cos θo) in the sin α tan β term.
///
/// tan β diverges when both directions approach the horizon. Directions above it only
/// by round-off (z = 6e-17 for `spherical(π/2, φ)`, or subnormal) would give an
/// infinite value; the floor caps the term at 1e12 and changes nothing unless both
/// directions are within 1e-12 rad of the horizon.
pub const MIN_COS: f64 = 1e-12;

/// A, B and their derivatives with respect to σ.
///
/// With s = σ²: dA/dσ = −0.33 σ/(s + 0.33)², dB/dσ = 0.081 σ/(s + 0.09)².
#[inline]
pub fn coefficients(sigma: f64) -> (f64, f64, f64, f64) {
    let s = sigma * sigma;
    let a = 1.0 - 0.5 * s / (s + 0.33);
    let b = 0.45 * s / (s + 0.09);
    let da = -0.33 * sigma / ((s + 0.33) * (s + 0.33));
    let db = 0.081 * sigma / ((s + 0.09) * (s + 0.09));
    (a, b, da, db)
}

/// The Oren-Nayar qualitative model.
#[derive(Debug, Clone, PartialEq)]
pub struct OrenNayar {
    rho_d: Rgb,
    sigma: f64,
}

impl Default for OrenNayar {
    fn default() -> Self {
        OrenNayar {
            rho_d: Rgb::splat(0.5),
            sigma: 0.3,
        }
    }
}

/// The number of parameters: ρd (3), σ.
const NP: usize = 4;

/// max(0, cos(φi − φo)) sin α tan β from the coordinates (module doc).
#[inline(always)]
fn angular(ix: f64, iy: f64, iz: f64, ox: f64, oy: f64, oz: f64) -> f64 {
    (ix * ox + iy * oy).max(0.0) / iz.max(oz).max(MIN_COS)
}

impl OrenNayar {
    /// ρd per channel in [0, 1], σ in [0, π/2] radians.
    pub fn new(rho_d: Rgb, sigma: f64) -> Result<Self, ModelError> {
        OrenNayar::default().with_rho_d(rho_d)?.with_sigma(sigma)
    }

    /// Sets ρd (each channel in [0, 1]).
    pub fn with_rho_d(mut self, rho_d: Rgb) -> Result<Self, ModelError> {
        self.rho_d = check_rgb("rho_d", rho_d, RHO_DOMAIN)?;
        Ok(self)
    }

    /// Sets σ ∈ [0, π/2] (radians).
    pub fn with_sigma(mut self, sigma: f64) -> Result<Self, ModelError> {
        self.sigma = check_param("sigma", sigma, SIGMA_DOMAIN)?;
        Ok(self)
    }

    /// The albedo parameter ρd.
    pub fn rho_d(&self) -> Rgb {
        self.rho_d
    }

    /// The facet slope deviation σ (radians).
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        const M: &str = "oren-nayar";
        let o = json::params_object(params, M)?;
        json::deny_unknown(&o, &["rho_d", "sigma"], M)?;
        let d = OrenNayar::default();
        OrenNayar::new(
            json::rgb_or(&o, "rho_d", d.rho_d.r(), M)?,
            json::number_or(&o, "sigma", d.sigma, M)?,
        )
    }
}

impl Brdf for OrenNayar {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let (a, b, _, _) = coefficients(self.sigma);
        let t = angular(wi.x, wi.y, wi.z, wo.x, wo.y, wo.z);
        self.rho_d * ((a + b * t) * FRAC_1_PI)
    }
}

model_name!(OrenNayar, "oren-nayar");

impl Model for OrenNayar {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let d = OrenNayar::default();
        let mut v = ParamSpec::per_channel("rho_d", RHO_DOMAIN, d.rho_d.r()).to_vec();
        v.push(ParamSpec::shared("sigma", SIGMA_DOMAIN, d.sigma));
        v
    }

    fn params(&self) -> Vec<f64> {
        let mut v = self.rho_d.0.to_vec();
        v.push(self.sigma);
        v
    }

    fn num_params(&self) -> usize {
        NP
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        check_count(NP, p.len())?;
        *self = OrenNayar::new(Rgb::new(p[0], p[1], p[2]), p[3])?;
        Ok(())
    }

    /// ∂f/∂ρd = (A + B t)/π in its channel, ∂f/∂σ = ρd (A′ + B′ t)/π, with t the
    /// angular term and A′, B′ from [`coefficients`].
    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb {
        grad[..NP].fill(Rgb::ZERO);
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let (a, b, da, db) = coefficients(self.sigma);
        let t = angular(wi.x, wi.y, wi.z, wo.x, wo.y, wo.z);
        let v = (a + b * t) * FRAC_1_PI;
        for (c, gc) in grad[..3].iter_mut().enumerate() {
            *gc = channel(c, v);
        }
        grad[3] = self.rho_d * ((da + db * t) * FRAC_1_PI);
        self.rho_d * v
    }

    /// The two directions (no half vector).
    fn geometry_columns(&self) -> Columns {
        Columns::DIRS
    }

    fn eval_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb]) {
        let (a, b, _, _) = coefficients(self.sigma);
        eval_above_horizon(g, out, |[ix, iy, iz], [ox, oy, oz]| {
            let t = angular(ix, iy, iz, ox, oy, oz);
            self.rho_d * ((a + b * t) * FRAC_1_PI)
        });
    }

    fn eval_grad_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: &mut [Rgb]) {
        let n = g.len();
        let out = &mut out[..n];
        let [[ix, iy, iz], [ox, oy, oz]] = g.dirs();
        let (g_rho, g_sigma) = grad[..NP * n].split_at_mut(3 * n);
        let (a, b, da, db) = coefficients(self.sigma);
        for k in 0..n {
            if iz[k] > 0.0 && oz[k] > 0.0 {
                let t = angular(ix[k], iy[k], iz[k], ox[k], oy[k], oz[k]);
                let v = (a + b * t) * FRAC_1_PI;
                out[k] = self.rho_d * v;
                for c in 0..3 {
                    g_rho[c * n + k] = channel(c, v);
                }
                g_sigma[k] = self.rho_d * ((da + db * t) * FRAC_1_PI);
            } else {
                out[k] = Rgb::ZERO;
                for c in 0..3 {
                    g_rho[c * n + k] = Rgb::ZERO;
                }
                g_sigma[k] = Rgb::ZERO;
            }
        }
    }

    fn to_json(&self) -> Value {
        json!({"model": "oren-nayar", "params": {
            "rho_d": json::rgb_value(self.rho_d),
            "sigma": self.sigma,
        }})
    }

    /// False: the albedo reaches ρd (A + B/2), up to 1.0152 ρd, near grazing.
    fn conserves_energy(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lambert::Lambert;
    use crate::testing::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn model() -> OrenNayar {
        OrenNayar::new(Rgb::new(0.2, 0.5, 0.9), 0.4).unwrap()
    }

    #[test]
    fn value_matches_the_trigonometric_formula() {
        // Independent truth: the paper's formula with angles, α, β and tan β.
        let m = model();
        let (a, b, _, _) = coefficients(0.4);
        assert_matches_angle_formula(&m, 10, 1000, 1.55, 1e-12, |ti, pi, to, po| {
            let (al, be) = (ti.max(to), ti.min(to));
            let t = (pi - po).cos().max(0.0) * al.sin() * be.tan();
            m.rho_d() / PI * (a + b * t)
        });
    }

    #[test]
    fn coefficients_match_the_paper() {
        let (a, b, _, _) = coefficients(0.0);
        assert_eq!((a, b), (1.0, 0.0));
        let s: f64 = 0.3 * 0.3;
        let (a, b, _, _) = coefficients(0.3);
        assert!((a - (1.0 - s / (2.0 * (s + 0.33)))).abs() < 1e-15);
        assert!((b - 0.45 * s / (s + 0.09)).abs() < 1e-15);
    }

    #[test]
    fn sigma_zero_is_lambert() {
        let m = OrenNayar::new(Rgb::new(0.2, 0.5, 0.9), 0.0).unwrap();
        let l = Lambert::new(Rgb::new(0.2, 0.5, 0.9)).unwrap();
        for (wi, wo) in random_pairs(4, 500).iter().chain(&hard_case_pairs()) {
            assert_eq!(m.eval(wi, wo), l.eval(wi, wo));
        }
    }

    #[test]
    fn builder_and_set_params_validate() {
        let e = OrenNayar::new(Rgb::splat(0.5), 2.0).unwrap_err();
        assert!(e.to_string().contains("`sigma`"), "{e}");
        assert!(e.to_string().contains("[0, 1.57"), "{e}");
        assert!(OrenNayar::new(Rgb::new(0.5, 0.5, -0.5), 0.2).is_err());
        let mut m = model();
        assert!(m.set_params(&[0.1, 0.1, 0.1, -0.1]).is_err());
        assert!(m.set_params(&[0.1, 0.1, 0.1]).is_err());
        assert_eq!(m, model());
        let names: Vec<_> = m.param_specs().into_iter().map(|s| s.name).collect();
        assert_eq!(names, ["rho_d.r", "rho_d.g", "rho_d.b", "sigma"]);
        assert!(m.is_reciprocal() && !m.conserves_energy());
    }

    #[test]
    fn json_round_trip_and_errors() {
        let m = model();
        assert_json_round_trip(&m);
        assert_eq!(
            crate::default_model("oren-nayar").unwrap().params(),
            vec![0.5, 0.5, 0.5, 0.3]
        );
        let e = crate::from_json_str(r#"{"model":"oren-nayar","params":{"roughness":0.1}}"#)
            .unwrap_err();
        assert!(e.to_string().contains("`roughness`"), "{e}");
        let e = crate::from_json_str(r#"{"model":"oren-nayar","params":{"sigma":[0.1,0.1,0.1]}}"#)
            .unwrap_err();
        assert!(e.to_string().contains("`sigma`"), "{e}");
    }

    #[test]
    fn shared_checks() {
        assert_shared_checks(&model(), 14);
    }

    #[test]
    fn hard_cases_stay_finite() {
        for sigma in [0.0, 1e-6, 0.3, FRAC_PI_2] {
            for rho in [0.0, 0.5, 1.0] {
                let m = OrenNayar::new(Rgb::splat(rho), sigma).unwrap();
                assert_finite_everywhere(&m, &hard_case_pairs());
                assert_paths_agree(&m, &hard_case_pairs(), 0.0);
                assert_zero_below_horizon(&m);
            }
        }
        // Both directions above the horizon by a subnormal: the term is capped by MIN_COS.
        let m = OrenNayar::new(Rgb::splat(1.0), FRAC_PI_2).unwrap();
        let w = Vec3::new(1.0, 0.0, 1e-310);
        let mut g = vec![Rgb::ZERO; 4];
        let f = m.eval_grad(&w, &w, &mut g);
        assert!(f.is_finite() && g.iter().all(Rgb::is_finite), "{f:?} {g:?}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn gradient_matches_finite_differences(
            rho in 0.01f64..0.99, sigma in 0.001f64..1.5, seed in any::<u64>()
        ) {
            let m = OrenNayar::new(Rgb::new(rho, 0.5, 0.9 * rho), sigma).unwrap();
            assert_gradient_paths_reciprocity(&m, seed);
        }
    }
}
