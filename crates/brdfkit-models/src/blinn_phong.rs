//! `blinn-phong`: a diffuse term plus a normalised Blinn half-vector lobe.
//!
//! f_r(wi, wo) = ρd/π + ρs · (n+8)/(8π) · cosⁿθh
//!
//! with h = (wi + wo)/|wi + wo| and cos θh = h.z (positive whenever both directions are
//! above the horizon). J. F. Blinn, "Models of Light Reflection for Computer Synthesized
//! Pictures", SIGGRAPH 1977; the (n+8)/(8π) normalisation as in T. Akenine-Möller,
//! E. Haines, N. Hoffman, *Real-Time Rendering*, 3rd ed. (2008), §7.6.
//!
//! | parameter | JSON    | per channel | domain | default |
//! |-----------|---------|-------------|--------|---------|
//! | ρd        | `rho_d` | yes         | [0, 1] | 0.5     |
//! | ρs        | `rho_s` | yes         | [0, 1] | 0.3     |
//! | n         | `n`     | no          | [0, ∞) | 50      |
//!
//! Reciprocal (h is symmetric in wi and wo).
//!
//! Energy: (n+8)/(8π) is an approximation. The exact factor that makes the lobe's
//! albedo 1 at normal incidence (wo = normal, so θh = θi/2) is
//! K(n) = (n+2)(n+4) / (8π (2^(−n/2) + n)) (F. Giesen, "Derivation of Phong and
//! Blinn-Phong BRDF normalization factors", 2009; [`exact_normalisation`]), and
//! (n+8)/(8π) / K(n) = (n+8)(n + 2^(−n/2)) / ((n+2)(n+4)) exceeds 1 for every n ≥ 1,
//! by up to 7.5 % near n = 9. So ρd + ρs ≤ 1 does **not** keep the directional albedo
//! ≤ 1, and [`Model::conserves_energy`] is false; ρd + 1.076 ρs ≤ 1 suffices (the
//! tests measure the albedo over θo ≤ 89° and n ∈ [1, 10⁴]).

use crate::json;
use crate::phong::{N_DOMAIN, channel, check_count, check_rgb, cos_pow, cos_pow_dn};
use crate::plausible_phong::RHO_DOMAIN;
use brdfkit_core::geometry::half_vector;
use brdfkit_core::model::check_param;
use brdfkit_core::{Brdf, GeomSlice, Model, ModelError, ParamSpec, Rgb, Vec3};
use serde_json::{Value, json};
use std::f64::consts::{FRAC_1_PI, PI};

/// The exact normalisation K(n) = (n+2)(n+4) / (8π (2^(−n/2) + n)) of the lobe
/// K cosⁿθh: its directional albedo at normal incidence is exactly 1.
///
/// From ∫ cosⁿ(θi/2) cos θi dωi = 8π (n + 2^(−n/2)) / ((n+2)(n+4)) over the hemisphere
/// (substitute u = cos(θi/2)).
pub fn exact_normalisation(n: f64) -> f64 {
    (n + 2.0) * (n + 4.0) / (8.0 * PI * ((-0.5 * n).exp2() + n))
}

/// A Lambertian term plus a Blinn-Phong lobe with the Real-Time Rendering normalisation.
#[derive(Debug, Clone, PartialEq)]
pub struct BlinnPhong {
    rho_d: Rgb,
    rho_s: Rgb,
    n: f64,
}

impl Default for BlinnPhong {
    fn default() -> Self {
        BlinnPhong {
            rho_d: Rgb::splat(0.5),
            rho_s: Rgb::splat(0.3),
            n: 50.0,
        }
    }
}

/// The number of parameters: ρd (3), ρs (3), n.
const NP: usize = 7;

impl BlinnPhong {
    /// ρd, ρs per channel in [0, 1], n in [0, ∞).
    pub fn new(rho_d: Rgb, rho_s: Rgb, n: f64) -> Result<Self, ModelError> {
        BlinnPhong::default()
            .with_rho_d(rho_d)?
            .with_rho_s(rho_s)?
            .with_n(n)
    }

    /// Sets ρd (each channel in [0, 1]).
    pub fn with_rho_d(mut self, rho_d: Rgb) -> Result<Self, ModelError> {
        self.rho_d = check_rgb("rho_d", rho_d, RHO_DOMAIN)?;
        Ok(self)
    }

    /// Sets ρs (each channel in [0, 1]).
    pub fn with_rho_s(mut self, rho_s: Rgb) -> Result<Self, ModelError> {
        self.rho_s = check_rgb("rho_s", rho_s, RHO_DOMAIN)?;
        Ok(self)
    }

    /// Sets the exponent n ∈ [0, ∞).
    pub fn with_n(mut self, n: f64) -> Result<Self, ModelError> {
        self.n = check_param("n", n, N_DOMAIN)?;
        Ok(self)
    }

    /// The diffuse albedo ρd.
    pub fn rho_d(&self) -> Rgb {
        self.rho_d
    }

    /// The specular coefficient ρs.
    pub fn rho_s(&self) -> Rgb {
        self.rho_s
    }

    /// The exponent n.
    pub fn n(&self) -> f64 {
        self.n
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        const M: &str = "blinn-phong";
        let o = json::params_object(params, M)?;
        json::deny_unknown(&o, &["rho_d", "rho_s", "n"], M)?;
        let d = BlinnPhong::default();
        BlinnPhong::new(
            json::rgb_or(&o, "rho_d", d.rho_d.r(), M)?,
            json::rgb_or(&o, "rho_s", d.rho_s.r(), M)?,
            json::number_or(&o, "n", d.n, M)?,
        )
    }

    /// The normalisation (n+8)/(8π).
    #[inline(always)]
    fn norm(&self) -> f64 {
        (self.n + 8.0) / (8.0 * PI)
    }

    /// f from cos θi, cos θo and cos θh; the single kernel of `eval` and `eval_batch`.
    #[inline(always)]
    fn kernel(&self, iz: f64, oz: f64, hz: f64) -> Rgb {
        if iz <= 0.0 || oz <= 0.0 {
            return Rgb::ZERO;
        }
        let s = self.norm() * cos_pow(hz, self.n);
        self.rho_d * FRAC_1_PI + self.rho_s * s
    }

    /// f, ∂f/∂ρd (any channel), ∂f/∂ρs (any channel), ∂f/∂n.
    #[inline(always)]
    fn kernel_grad(&self, iz: f64, oz: f64, hz: f64) -> (Rgb, f64, f64, Rgb) {
        if iz <= 0.0 || oz <= 0.0 {
            return (Rgb::ZERO, 0.0, 0.0, Rgb::ZERO);
        }
        let (p, dp) = cos_pow_dn(hz, self.n);
        let s = self.norm() * p;
        // ∂/∂n [(n+8)/(8π) cⁿ] = cⁿ/(8π) + (n+8)/(8π) cⁿ ln c.
        let ds_dn = p / (8.0 * PI) + self.norm() * dp;
        (
            self.rho_d * FRAC_1_PI + self.rho_s * s,
            FRAC_1_PI,
            s,
            self.rho_s * ds_dn,
        )
    }
}

impl Brdf for BlinnPhong {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        // The same half vector as `GeometryBatch::push`, so both paths agree exactly.
        self.kernel(wi.z, wo.z, half_vector(wi, wo).z)
    }
}

impl Model for BlinnPhong {
    fn name(&self) -> &'static str {
        "blinn-phong"
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let d = BlinnPhong::default();
        let mut v = ParamSpec::per_channel("rho_d", RHO_DOMAIN, d.rho_d.r()).to_vec();
        v.extend(ParamSpec::per_channel("rho_s", RHO_DOMAIN, d.rho_s.r()));
        v.push(ParamSpec::shared("n", N_DOMAIN, d.n));
        v
    }

    fn params(&self) -> Vec<f64> {
        let mut v = self.rho_d.0.to_vec();
        v.extend(self.rho_s.0);
        v.push(self.n);
        v
    }

    fn num_params(&self) -> usize {
        NP
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        check_count(NP, p.len())?;
        *self = BlinnPhong::new(Rgb::new(p[0], p[1], p[2]), Rgb::new(p[3], p[4], p[5]), p[6])?;
        Ok(())
    }

    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb {
        let hz = if wi.z > 0.0 && wo.z > 0.0 {
            half_vector(wi, wo).z
        } else {
            0.0
        };
        let (f, dd, ds, dn) = self.kernel_grad(wi.z, wo.z, hz);
        for c in 0..3 {
            grad[c] = channel(c, dd);
            grad[3 + c] = channel(c, ds);
        }
        grad[6] = dn;
        f
    }

    fn eval_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb]) {
        let n = g.len();
        let out = &mut out[..n];
        let (iz, oz, hz) = (&g.wi_z[..n], &g.wo_z[..n], &g.h_z[..n]);
        for k in 0..n {
            out[k] = self.kernel(iz[k], oz[k], hz[k]);
        }
    }

    fn eval_grad_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: &mut [Rgb]) {
        let n = g.len();
        let out = &mut out[..n];
        let (iz, oz, hz) = (&g.wi_z[..n], &g.wo_z[..n], &g.h_z[..n]);
        let (g_d, rest) = grad[..NP * n].split_at_mut(3 * n);
        let (g_s, g_n) = rest.split_at_mut(3 * n);
        for k in 0..n {
            let (f, dd, ds, dn) = self.kernel_grad(iz[k], oz[k], hz[k]);
            out[k] = f;
            for c in 0..3 {
                g_d[c * n + k] = channel(c, dd);
                g_s[c * n + k] = channel(c, ds);
            }
            g_n[k] = dn;
        }
    }

    fn to_json(&self) -> Value {
        json!({"model": "blinn-phong", "params": {
            "rho_d": json::rgb_value(self.rho_d),
            "rho_s": json::rgb_value(self.rho_s),
            "n": self.n,
        }})
    }

    fn clone_box(&self) -> Box<dyn Model> {
        Box::new(self.clone())
    }

    /// False: with the (n+8)/(8π) factor the albedo reaches ≈ 1.075 ρs (module doc).
    fn conserves_energy(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::*;
    use brdfkit_core::direction::spherical;
    use proptest::prelude::*;

    fn model() -> BlinnPhong {
        BlinnPhong::new(Rgb::new(0.2, 0.4, 0.6), Rgb::new(0.5, 0.3, 0.1), 60.0).unwrap()
    }

    #[test]
    fn value_matches_the_angle_formula() {
        // Independent truth: cos θh = (cos θi + cos θo) / |wi + wo| with
        // |wi + wo|² = 2 + 2 (cos θi cos θo + sin θi sin θo cos(φi − φo)).
        let m = model();
        let mut r = SplitMix64(9);
        for _ in 0..500 {
            let (ti, pi, to, po) = (
                r.uniform(0.0, 1.5),
                r.uniform(-3.0, 3.0),
                r.uniform(0.0, 1.5),
                r.uniform(-3.0, 3.0),
            );
            let dot = ti.cos() * to.cos() + ti.sin() * to.sin() * (pi - po).cos();
            let ch = (ti.cos() + to.cos()) / (2.0 + 2.0 * dot).sqrt();
            let f = m.eval(&spherical(ti, pi), &spherical(to, po));
            for c in 0..3 {
                let want = m.rho_d()[c] / PI + m.rho_s()[c] * 68.0 / (8.0 * PI) * ch.powf(60.0);
                assert!((f[c] - want).abs() <= 1e-12 * want, "{} vs {want}", f[c]);
            }
        }
    }

    #[test]
    fn exact_normalisation_closed_form() {
        // K(n) = (n+2)(n+4)/(8π(2^(−n/2) + n)); at n = 0 the lobe is constant over the
        // hemisphere and K = 1/π, like Lambert; large n approaches (n+8)/(8π) from below.
        assert!((exact_normalisation(0.0) - 1.0 / PI).abs() < 1e-15);
        assert!((exact_normalisation(2.0) - 24.0 / (8.0 * PI * 2.5)).abs() < 1e-15);
        let n = 1e6;
        let r = (n + 8.0) / (8.0 * PI) / exact_normalisation(n);
        assert!(r > 1.0 && r - 1.0 < 2.1 / n, "{r}");
    }

    #[test]
    fn builder_and_set_params_validate() {
        let e = BlinnPhong::new(Rgb::new(0.1, 2.0, 0.1), Rgb::splat(0.1), 5.0).unwrap_err();
        assert!(e.to_string().contains("`rho_d.g`"), "{e}");
        assert!(model().with_n(f64::INFINITY).is_err());
        let mut m = model();
        assert!(m.set_params(&[0.1, 0.1, 0.1, 0.1, 0.1, 0.1, -3.0]).is_err());
        assert_eq!(m, model());
        assert!(m.is_reciprocal() && !m.conserves_energy());
    }

    #[test]
    fn json_round_trip_and_errors() {
        let m = model();
        let back = crate::from_json(&m.to_json()).unwrap();
        assert_eq!(back.params(), m.params());
        assert_eq!(
            crate::default_model("blinn-phong").unwrap().params(),
            BlinnPhong::default().params()
        );
        let e =
            crate::from_json_str(r#"{"model":"blinn-phong","params":{"n":1,"m":2}}"#).unwrap_err();
        assert!(e.to_string().contains("`m`"), "{e}");
    }

    #[test]
    fn shared_checks() {
        let m = model();
        let pairs = random_pairs(13, 300);
        assert_paths_agree(&m, &pairs, 0.0);
        assert_paths_agree(&m, &hard_case_pairs(), 0.0);
        assert_reciprocal(&m, &pairs, 1e-12);
        assert_reciprocal(&m, &hard_case_pairs(), 1e-12);
        assert_reciprocal(&m, &dense_grid_pairs(20, 8), 1e-12);
        assert_nonnegative(&m, &dense_grid_pairs(40, 16));
        assert_zero_below_horizon(&m);
        assert_gradient_matches_fd(&m, &pairs, 1e-6, 1e-6);
    }

    #[test]
    fn hard_cases_stay_finite() {
        for n in [0.0, 1.0, 1e3, 1e6] {
            for (d, s) in [(0.0, 0.0), (0.3, 0.7), (1.0, 1.0)] {
                let m = BlinnPhong::new(Rgb::splat(d), Rgb::splat(s), n).unwrap();
                assert_finite_everywhere(&m, &hard_case_pairs());
                assert_paths_agree(&m, &hard_case_pairs(), 0.0);
                assert_zero_below_horizon(&m);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn gradient_matches_finite_differences(
            d in 0.01f64..0.99, s in 0.01f64..0.99, n in 0.5f64..1000.0, seed in any::<u64>()
        ) {
            let m = BlinnPhong::new(Rgb::new(d, 0.5, 0.3 * d), Rgb::new(0.2, s, 0.9 * s), n).unwrap();
            let pairs = random_pairs(seed, 12);
            assert_gradient_matches_fd(&m, &pairs, 1e-6, 1e-6);
            assert_paths_agree(&m, &pairs, 0.0);
            assert_reciprocal(&m, &pairs, 1e-12);
        }
    }
}
