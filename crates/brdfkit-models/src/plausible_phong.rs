//! `plausible-phong`: the energy-normalised, reciprocal Phong BRDF.
//!
//! f_r(wi, wo) = ρd/π + ρs · (n+2)/(2π) · cosⁿθr
//!
//! with θr the angle between wo and the mirror direction of wi,
//! cos θr = wi.z wo.z − wi.x wo.x − wi.y wo.y (symmetric in wi and wo), clamped at 0.
//! The factor (n+2)/(2π) normalises the lobe: ∫ (n+2)/(2π) cosⁿθ cos θ dω = 1 over the
//! hemisphere about the normal. R. R. Lewis, "Making Shaders More Physically
//! Plausible", Computer Graphics Forum 13(2), 1994; E. P. Lafortune and Y. D. Willems,
//! "Using the Modified Phong Reflectance Model for Physically Based Rendering",
//! KU Leuven report CW197, 1994.
//!
//! | parameter | JSON    | per channel | domain | default |
//! |-----------|---------|-------------|--------|---------|
//! | ρd        | `rho_d` | yes         | [0, 1] | 0.5     |
//! | ρs        | `rho_s` | yes         | [0, 1] | 0.3     |
//! | n         | `n`     | no          | [0, ∞) | 20      |
//!
//! Reciprocal. Energy: the lobe's directional albedo is largest for wo along the normal,
//! where it is exactly ρs, so the albedo is ≤ ρd + ρs ≤ 1 per channel whenever
//! ρd + ρs ≤ 1 (the tests measure this over θo ≤ 89° and n ∈ [1, 10⁴]). The builder does
//! not enforce ρd + ρs ≤ 1: a fit may pass through such values.

use crate::json;
use crate::phong::{N_DOMAIN, channel, check_count, check_rgb, cos_pow, cos_pow_dn};
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::{Brdf, GeomSlice, Model, ModelError, ParamSpec, Rgb, Vec3};
use serde_json::{Value, json};
use std::f64::consts::{FRAC_1_PI, PI};

/// The domain of ρd and ρs.
pub const RHO_DOMAIN: Domain = Domain::closed(0.0, 1.0);

/// The modified (physically plausible) Phong BRDF.
#[derive(Debug, Clone, PartialEq)]
pub struct PlausiblePhong {
    rho_d: Rgb,
    rho_s: Rgb,
    n: f64,
}

impl Default for PlausiblePhong {
    fn default() -> Self {
        PlausiblePhong {
            rho_d: Rgb::splat(0.5),
            rho_s: Rgb::splat(0.3),
            n: 20.0,
        }
    }
}

/// The number of parameters: ρd (3), ρs (3), n.
const NP: usize = 7;

impl PlausiblePhong {
    /// ρd, ρs per channel in [0, 1], n in [0, ∞).
    pub fn new(rho_d: Rgb, rho_s: Rgb, n: f64) -> Result<Self, ModelError> {
        PlausiblePhong::default()
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

    /// The specular albedo ρs (the lobe's albedo at normal incidence).
    pub fn rho_s(&self) -> Rgb {
        self.rho_s
    }

    /// The exponent n.
    pub fn n(&self) -> f64 {
        self.n
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        const M: &str = "plausible-phong";
        let o = json::params_object(params, M)?;
        json::deny_unknown(&o, &["rho_d", "rho_s", "n"], M)?;
        let d = PlausiblePhong::default();
        PlausiblePhong::new(
            json::rgb_or(&o, "rho_d", d.rho_d.r(), M)?,
            json::rgb_or(&o, "rho_s", d.rho_s.r(), M)?,
            json::number_or(&o, "n", d.n, M)?,
        )
    }

    /// The lobe normalisation (n+2)/(2π).
    #[inline(always)]
    fn norm(&self) -> f64 {
        (self.n + 2.0) / (2.0 * PI)
    }

    /// f for one pair; the single kernel of `eval` and `eval_batch`.
    #[inline(always)]
    fn kernel(&self, ix: f64, iy: f64, iz: f64, ox: f64, oy: f64, oz: f64) -> Rgb {
        if iz <= 0.0 || oz <= 0.0 {
            return Rgb::ZERO;
        }
        let c = iz * oz - ix * ox - iy * oy;
        let s = self.norm() * cos_pow(c, self.n);
        self.rho_d * FRAC_1_PI + self.rho_s * s
    }

    /// f, ∂f/∂ρd (any channel), ∂f/∂ρs (any channel), ∂f/∂n; the single kernel of
    /// `eval_grad` and `eval_grad_batch`.
    #[inline(always)]
    fn kernel_grad(
        &self,
        ix: f64,
        iy: f64,
        iz: f64,
        ox: f64,
        oy: f64,
        oz: f64,
    ) -> (Rgb, f64, f64, Rgb) {
        if iz <= 0.0 || oz <= 0.0 {
            return (Rgb::ZERO, 0.0, 0.0, Rgb::ZERO);
        }
        let c = iz * oz - ix * ox - iy * oy;
        let (p, dp) = cos_pow_dn(c, self.n);
        let s = self.norm() * p;
        // ∂/∂n [(n+2)/(2π) cⁿ] = cⁿ/(2π) + (n+2)/(2π) cⁿ ln c.
        let ds_dn = p / (2.0 * PI) + self.norm() * dp;
        (
            self.rho_d * FRAC_1_PI + self.rho_s * s,
            FRAC_1_PI,
            s,
            self.rho_s * ds_dn,
        )
    }
}

impl Brdf for PlausiblePhong {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        self.kernel(wi.x, wi.y, wi.z, wo.x, wo.y, wo.z)
    }
}

impl Model for PlausiblePhong {
    fn name(&self) -> &'static str {
        "plausible-phong"
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let d = PlausiblePhong::default();
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
        *self = PlausiblePhong::new(Rgb::new(p[0], p[1], p[2]), Rgb::new(p[3], p[4], p[5]), p[6])?;
        Ok(())
    }

    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb {
        let (f, dd, ds, dn) = self.kernel_grad(wi.x, wi.y, wi.z, wo.x, wo.y, wo.z);
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
        let (ix, iy, iz) = (&g.wi_x[..n], &g.wi_y[..n], &g.wi_z[..n]);
        let (ox, oy, oz) = (&g.wo_x[..n], &g.wo_y[..n], &g.wo_z[..n]);
        for k in 0..n {
            out[k] = self.kernel(ix[k], iy[k], iz[k], ox[k], oy[k], oz[k]);
        }
    }

    fn eval_grad_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: &mut [Rgb]) {
        let n = g.len();
        let out = &mut out[..n];
        let (ix, iy, iz) = (&g.wi_x[..n], &g.wi_y[..n], &g.wi_z[..n]);
        let (ox, oy, oz) = (&g.wo_x[..n], &g.wo_y[..n], &g.wo_z[..n]);
        let (g_d, rest) = grad[..NP * n].split_at_mut(3 * n);
        let (g_s, g_n) = rest.split_at_mut(3 * n);
        for k in 0..n {
            let (f, dd, ds, dn) = self.kernel_grad(ix[k], iy[k], iz[k], ox[k], oy[k], oz[k]);
            out[k] = f;
            for c in 0..3 {
                g_d[c * n + k] = channel(c, dd);
                g_s[c * n + k] = channel(c, ds);
            }
            g_n[k] = dn;
        }
    }

    fn to_json(&self) -> Value {
        json!({"model": "plausible-phong", "params": {
            "rho_d": json::rgb_value(self.rho_d),
            "rho_s": json::rgb_value(self.rho_s),
            "n": self.n,
        }})
    }

    fn clone_box(&self) -> Box<dyn Model> {
        Box::new(self.clone())
    }

    /// Directional albedo ≤ ρd + ρs per channel, so ≤ 1 when ρd + ρs ≤ 1.
    fn conserves_energy(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::*;
    use brdfkit_core::direction::spherical;
    use proptest::prelude::*;

    fn model() -> PlausiblePhong {
        PlausiblePhong::new(Rgb::new(0.2, 0.4, 0.6), Rgb::new(0.5, 0.3, 0.1), 35.0).unwrap()
    }

    #[test]
    fn value_matches_the_angle_formula() {
        let m = model();
        let mut r = SplitMix64(8);
        for _ in 0..500 {
            let (ti, pi, to, po) = (
                r.uniform(0.0, 1.5),
                r.uniform(-3.0, 3.0),
                r.uniform(0.0, 1.5),
                r.uniform(-3.0, 3.0),
            );
            let cr = ti.cos() * to.cos() - ti.sin() * to.sin() * (pi - po).cos();
            let lobe = if cr > 0.0 { cr.powf(35.0) } else { 0.0 };
            let f = m.eval(&spherical(ti, pi), &spherical(to, po));
            for c in 0..3 {
                let want = m.rho_d()[c] / PI + m.rho_s()[c] * 37.0 / (2.0 * PI) * lobe;
                assert!((f[c] - want).abs() <= 1e-12 * want, "{} vs {want}", f[c]);
            }
        }
    }

    #[test]
    fn builder_and_set_params_validate() {
        let e = PlausiblePhong::new(Rgb::splat(0.1), Rgb::new(0.1, 0.2, 1.5), 5.0).unwrap_err();
        assert!(
            e.to_string().contains("`rho_s.b`") && e.to_string().contains("[0, 1]"),
            "{e}"
        );
        assert!(model().with_rho_d(Rgb::splat(-0.1)).is_err());
        assert!(model().with_n(-0.5).is_err());
        let mut m = model();
        assert!(m.set_params(&[0.1, 0.1, 0.1, 0.1, 0.1, 2.0, 3.0]).is_err());
        assert!(m.set_params(&[0.1; 8]).is_err());
        assert_eq!(m, model());
        let names: Vec<_> = m.param_specs().into_iter().map(|s| s.name).collect();
        assert_eq!(
            names,
            [
                "rho_d.r", "rho_d.g", "rho_d.b", "rho_s.r", "rho_s.g", "rho_s.b", "n"
            ]
        );
        assert!(m.is_reciprocal() && m.conserves_energy());
    }

    #[test]
    fn json_round_trip_and_errors() {
        let m = model();
        let back = crate::from_json(&m.to_json()).unwrap();
        assert_eq!(back.params(), m.params());
        assert_eq!(
            crate::default_model("plausible-phong").unwrap().params(),
            PlausiblePhong::default().params()
        );
        let e = crate::from_json_str(r#"{"model":"plausible-phong","params":{"rho_s":[0.1,0.2]}}"#)
            .unwrap_err();
        assert!(e.to_string().contains("`rho_s`"), "{e}");
        let e =
            crate::from_json_str(r#"{"model":"plausible-phong","params":{"ks":0.1}}"#).unwrap_err();
        assert!(e.to_string().contains("`ks`"), "{e}");
    }

    #[test]
    fn shared_checks() {
        let m = model();
        let pairs = random_pairs(12, 300);
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
                let m = PlausiblePhong::new(Rgb::splat(d), Rgb::splat(s), n).unwrap();
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
            let m = PlausiblePhong::new(Rgb::new(d, 0.5, 0.3 * d), Rgb::new(0.2, s, 0.9 * s), n).unwrap();
            let pairs = random_pairs(seed, 12);
            assert_gradient_matches_fd(&m, &pairs, 1e-6, 1e-6);
            assert_paths_agree(&m, &pairs, 0.0);
            assert_reciprocal(&m, &pairs, 1e-12);
        }
    }
}
