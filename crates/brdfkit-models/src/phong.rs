//! `phong`: the original Phong reflection model written as a BRDF — kept to show its
//! faults, not to be fitted to real data.
//!
//! f_r(wi, wo) = kd + ks · cosⁿθr / cos θi
//!
//! with θr the angle between wo and the mirror direction of wi, r = (−wi.x, −wi.y, wi.z),
//! so cos θr = r·wo = wi.z wo.z − wi.x wo.x − wi.y wo.y, clamped at 0. This is Phong's
//! shading formula I = kd cos θi + ks cosⁿθr divided by the incident cosine (B. T. Phong,
//! "Illumination for Computer Generated Pictures", CACM 18(6), 1975; the BRDF form as in
//! Lewis 1994, "Making Shaders More Physically Plausible").
//!
//! | parameter | JSON  | per channel | domain  | default |
//! |-----------|-------|-------------|---------|---------|
//! | kd        | `k_d` | yes         | [0, ∞)  | 0.15    |
//! | ks        | `k_s` | yes         | [0, ∞)  | 0.3     |
//! | n         | `n`   | no          | [0, ∞)  | 20      |
//!
//! Faults (asserted by the tests): it is **not reciprocal** — f(wi, wo) − f(wo, wi) =
//! ks cosⁿθr (1/cos θi − 1/cos θo) — and it **does not conserve energy**: the light
//! reflected from an incident direction, ∫ f(wi, wo) cos θo dωo, grows like 1/cos θi
//! towards grazing incidence for any ks > 0, whatever kd and ks are. Hence
//! [`Model::is_reciprocal`] and [`Model::conserves_energy`] are both false.
//!
//! This module also holds the cosine-power lobe shared by the Phong family
//! ([`cos_pow`], [`cos_pow_dn`]) and the per-channel parameter check.

use crate::json;
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::{Brdf, GeomSlice, Model, ModelError, ParamSpec, Rgb, Vec3};
use serde_json::{Value, json};

/// The domain of kd and ks: non-negative, unbounded (the model promises nothing).
pub const K_DOMAIN: Domain = Domain::at_least(0.0);
/// The domain of a cosine-power exponent.
pub const N_DOMAIN: Domain = Domain::at_least(0.0);

/// Floor of the incident cosine in the 1/cos θi factor.
///
/// The original model diverges like 1/cos θi at grazing incidence. A direction above
/// the horizon only by round-off (`spherical(π/2, φ)` has z = 6e-17; a hand-made one
/// can be subnormal) would give an infinite value and gradient; the floor caps the
/// factor at 1e12 and changes nothing for θi more than 1e-12 rad from the horizon.
pub const MIN_COS_I: f64 = 1e-12;

/// cⁿ on the open lobe c > 0, and 0 elsewhere.
///
/// The clamp at c ≤ 0 is the lobe's definition (max(0, cos)ⁿ). At c = 0 with n = 0 this
/// gives 0, not IEEE's pow(0, 0) = 1: 0 is the limit of 0ⁿ as n → 0⁺, so the value stays
/// continuous in n, and the lobe boundary has measure zero for every integral.
#[inline(always)]
pub fn cos_pow(c: f64, n: f64) -> f64 {
    if c > 0.0 { c.powf(n) } else { 0.0 }
}

/// (cⁿ, ∂cⁿ/∂n = cⁿ ln c), both 0 for c ≤ 0 (see [`cos_pow`]).
///
/// No clamp is needed for finiteness: for c > 0 the smallest double gives
/// ln c ≥ −745, and cⁿ ≤ 1 for c ≤ 1 (cosines exceed 1 only by round-off). At c = 0 the
/// derivative is the limit of cⁿ ln c as c → 0⁺, which is 0 for n > 0.
#[inline(always)]
pub fn cos_pow_dn(c: f64, n: f64) -> (f64, f64) {
    if c > 0.0 {
        let p = c.powf(n);
        (p, p * c.ln())
    } else {
        (0.0, 0.0)
    }
}

/// Checks every channel of a per-channel parameter, naming `name.r`, `name.g` or
/// `name.b` in the error.
pub fn check_rgb(name: &str, v: Rgb, domain: Domain) -> Result<Rgb, ModelError> {
    for (c, ch) in ["r", "g", "b"].iter().enumerate() {
        check_param(&format!("{name}.{ch}"), v[c], domain)?;
    }
    Ok(v)
}

/// An error unless `got` parameters were given where `expected` are needed.
pub fn check_count(expected: usize, got: usize) -> Result<(), ModelError> {
    if expected == got {
        Ok(())
    } else {
        Err(ModelError::ParamCount { expected, got })
    }
}

/// An [`Rgb`] with `v` in channel `c` and 0 elsewhere: the gradient of f with respect to
/// a per-channel parameter only touches its own channel.
#[inline(always)]
pub fn channel(c: usize, v: f64) -> Rgb {
    let mut r = Rgb::ZERO;
    r[c] = v;
    r
}

/// The original Phong BRDF kd + ks cosⁿθr / cos θi.
#[derive(Debug, Clone, PartialEq)]
pub struct Phong {
    k_d: Rgb,
    k_s: Rgb,
    n: f64,
}

impl Default for Phong {
    fn default() -> Self {
        Phong {
            k_d: Rgb::splat(0.15),
            k_s: Rgb::splat(0.3),
            n: 20.0,
        }
    }
}

/// The number of parameters: kd (3), ks (3), n.
const NP: usize = 7;

impl Phong {
    /// A Phong BRDF; kd and ks per channel in [0, ∞), n in [0, ∞).
    pub fn new(k_d: Rgb, k_s: Rgb, n: f64) -> Result<Self, ModelError> {
        Phong::default().with_k_d(k_d)?.with_k_s(k_s)?.with_n(n)
    }

    /// Sets kd (each channel in [0, ∞)).
    pub fn with_k_d(mut self, k_d: Rgb) -> Result<Self, ModelError> {
        self.k_d = check_rgb("k_d", k_d, K_DOMAIN)?;
        Ok(self)
    }

    /// Sets ks (each channel in [0, ∞)).
    pub fn with_k_s(mut self, k_s: Rgb) -> Result<Self, ModelError> {
        self.k_s = check_rgb("k_s", k_s, K_DOMAIN)?;
        Ok(self)
    }

    /// Sets the exponent n ∈ [0, ∞).
    pub fn with_n(mut self, n: f64) -> Result<Self, ModelError> {
        self.n = check_param("n", n, N_DOMAIN)?;
        Ok(self)
    }

    /// The diffuse coefficient kd (a BRDF value, not an albedo).
    pub fn k_d(&self) -> Rgb {
        self.k_d
    }

    /// The specular coefficient ks.
    pub fn k_s(&self) -> Rgb {
        self.k_s
    }

    /// The exponent n.
    pub fn n(&self) -> f64 {
        self.n
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        let o = json::params_object(params, "phong")?;
        json::deny_unknown(&o, &["k_d", "k_s", "n"], "phong")?;
        let d = Phong::default();
        Phong::new(
            json::rgb_or(&o, "k_d", d.k_d.r(), "phong")?,
            json::rgb_or(&o, "k_s", d.k_s.r(), "phong")?,
            json::number_or(&o, "n", d.n, "phong")?,
        )
    }

    /// f for one pair given as coordinates; the single kernel of `eval` and `eval_batch`.
    #[inline(always)]
    fn kernel(&self, ix: f64, iy: f64, iz: f64, ox: f64, oy: f64, oz: f64) -> Rgb {
        if iz <= 0.0 || oz <= 0.0 {
            return Rgb::ZERO;
        }
        let c = iz * oz - ix * ox - iy * oy;
        let s = cos_pow(c, self.n) / iz.max(MIN_COS_I);
        self.k_d + self.k_s * s
    }

    /// f and the partials, the single kernel of `eval_grad` and `eval_grad_batch`:
    /// ∂f/∂kd = 1 and ∂f/∂ks = cⁿ/cos θi (each in its own channel),
    /// ∂f/∂n = ks cⁿ ln c / cos θi (every channel).
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
        let inv = 1.0 / iz.max(MIN_COS_I);
        let (p, dp) = cos_pow_dn(c, self.n);
        let s = p / iz.max(MIN_COS_I);
        (self.k_d + self.k_s * s, 1.0, s, self.k_s * (dp * inv))
    }
}

impl Brdf for Phong {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        self.kernel(wi.x, wi.y, wi.z, wo.x, wo.y, wo.z)
    }
}

impl Model for Phong {
    fn name(&self) -> &'static str {
        "phong"
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let d = Phong::default();
        let mut v = ParamSpec::per_channel("k_d", K_DOMAIN, d.k_d.r()).to_vec();
        v.extend(ParamSpec::per_channel("k_s", K_DOMAIN, d.k_s.r()));
        v.push(ParamSpec::shared("n", N_DOMAIN, d.n));
        v
    }

    fn params(&self) -> Vec<f64> {
        let mut v = self.k_d.0.to_vec();
        v.extend(self.k_s.0);
        v.push(self.n);
        v
    }

    fn num_params(&self) -> usize {
        NP
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        check_count(NP, p.len())?;
        *self = Phong::new(Rgb::new(p[0], p[1], p[2]), Rgb::new(p[3], p[4], p[5]), p[6])?;
        Ok(())
    }

    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb {
        let (f, dkd, dks, dn) = self.kernel_grad(wi.x, wi.y, wi.z, wo.x, wo.y, wo.z);
        for c in 0..3 {
            grad[c] = channel(c, dkd);
            grad[3 + c] = channel(c, dks);
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
        let (g_kd, rest) = grad[..NP * n].split_at_mut(3 * n);
        let (g_ks, g_n) = rest.split_at_mut(3 * n);
        for k in 0..n {
            let (f, dkd, dks, dn) = self.kernel_grad(ix[k], iy[k], iz[k], ox[k], oy[k], oz[k]);
            out[k] = f;
            for c in 0..3 {
                g_kd[c * n + k] = channel(c, dkd);
                g_ks[c * n + k] = channel(c, dks);
            }
            g_n[k] = dn;
        }
    }

    fn to_json(&self) -> Value {
        json!({"model": "phong", "params": {
            "k_d": json::rgb_value(self.k_d),
            "k_s": json::rgb_value(self.k_s),
            "n": self.n,
        }})
    }

    fn clone_box(&self) -> Box<dyn Model> {
        Box::new(self.clone())
    }

    /// f(wi, wo) − f(wo, wi) = ks cosⁿθr (1/cos θi − 1/cos θo) ≠ 0.
    fn is_reciprocal(&self) -> bool {
        false
    }

    /// The reflected fraction grows like 1/cos θi at grazing incidence.
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

    fn model() -> Phong {
        Phong::new(Rgb::new(0.05, 0.1, 0.2), Rgb::new(0.3, 0.2, 0.1), 12.0).unwrap()
    }

    #[test]
    fn value_matches_the_angle_formula() {
        // Independent truth: cos θr from the spherical angles,
        // cos θr = cos θi cos θo − sin θi sin θo cos(φi − φo).
        let m = model();
        let mut r = SplitMix64(7);
        for _ in 0..500 {
            let (ti, pi, to, po) = (
                r.uniform(0.0, 1.5),
                r.uniform(-3.0, 3.0),
                r.uniform(0.0, 1.5),
                r.uniform(-3.0, 3.0),
            );
            let cr = ti.cos() * to.cos() - ti.sin() * to.sin() * (pi - po).cos();
            let lobe = if cr > 0.0 { cr.powf(12.0) } else { 0.0 };
            let f = m.eval(&spherical(ti, pi), &spherical(to, po));
            for c in 0..3 {
                let want = m.k_d()[c] + m.k_s()[c] * lobe / ti.cos();
                assert!((f[c] - want).abs() <= 1e-12 * want, "{} vs {want}", f[c]);
            }
        }
    }

    #[test]
    fn cos_pow_conventions() {
        assert_eq!(cos_pow(0.0, 0.0), 0.0, "0⁰ is the limit from n > 0");
        assert_eq!(cos_pow(-0.5, 0.0), 0.0);
        assert_eq!(cos_pow(0.5, 0.0), 1.0);
        assert_eq!(cos_pow(0.5, 2.0), 0.25);
        assert_eq!(cos_pow_dn(0.0, 0.0), (0.0, 0.0));
        let (p, d) = cos_pow_dn(0.5, 3.0);
        assert_eq!(p, 0.125);
        assert!((d - 0.125 * 0.5f64.ln()).abs() < 1e-16);
        let (p, d) = cos_pow_dn(5e-324, 0.0);
        assert!(p == 1.0 && d.is_finite() && d < -744.0);
    }

    #[test]
    fn is_not_reciprocal() {
        let m = model();
        assert!(!m.is_reciprocal() && !m.conserves_energy());
        // f(wi, wo) − f(wo, wi) = ks cosⁿθr (1/cos θi − 1/cos θo), exactly.
        let (wi, wo) = (spherical(1.2, 0.0), spherical(0.9, 3.0));
        let d = m.eval(&wi, &wo) - m.eval(&wo, &wi);
        let cr = wi.z * wo.z - wi.x * wo.x - wi.y * wo.y;
        let want = m.k_s() * (cr.powf(12.0) * (1.0 / wi.z - 1.0 / wo.z));
        for c in 0..3 {
            assert!(
                (d[c] - want[c]).abs() < 1e-12 * want[c].abs(),
                "{d:?} {want:?}"
            );
            assert!(want[c].abs() > 0.05);
        }
        let e = max_reciprocity_error(&m, &random_pairs(3, 2000));
        eprintln!("phong: max relative reciprocity error over 2000 random pairs: {e:.3}");
        assert!(e > 0.5, "relative reciprocity error only {e}");
    }

    #[test]
    fn builder_and_set_params_validate() {
        let e = Phong::new(Rgb::splat(0.1), Rgb::new(0.1, -0.2, 0.1), 5.0).unwrap_err();
        assert!(e.to_string().contains("`k_s.g`"), "{e}");
        assert!(e.to_string().contains("[0, inf)"), "{e}");
        let e = model().with_n(f64::NAN).unwrap_err();
        assert!(e.to_string().contains("`n`"), "{e}");
        assert!(model().with_n(-1.0).is_err());
        assert!(model().with_k_d(Rgb::splat(f64::INFINITY)).is_err());
        let mut m = model();
        assert!(m.set_params(&[0.1, 0.1, 0.1, 0.1, 0.1, 0.1, -3.0]).is_err());
        assert!(m.set_params(&[0.1; 6]).is_err());
        assert_eq!(
            m,
            model(),
            "a rejected set_params leaves the model unchanged"
        );
        m.set_params(&[0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 7.0]).unwrap();
        assert_eq!(m.params(), vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 7.0]);
        let names: Vec<_> = m.param_specs().into_iter().map(|s| s.name).collect();
        assert_eq!(
            names,
            ["k_d.r", "k_d.g", "k_d.b", "k_s.r", "k_s.g", "k_s.b", "n"]
        );
    }

    #[test]
    fn json_round_trip_and_errors() {
        let m = model();
        let back = crate::from_json(&m.to_json()).unwrap();
        assert_eq!(back.params(), m.params());
        assert_eq!(back.name(), "phong");
        let d = crate::default_model("phong").unwrap();
        assert_eq!(d.params(), Phong::default().params());
        let p = crate::from_json_str(r#"{"model":"phong","params":{"k_d":0.2,"n":3}}"#).unwrap();
        assert_eq!(p.params(), vec![0.2, 0.2, 0.2, 0.3, 0.3, 0.3, 3.0]);
        let e = crate::from_json_str(r#"{"model":"phong","params":{"kd":0.2}}"#).unwrap_err();
        assert!(e.to_string().contains("`kd`"), "{e}");
        let e = crate::from_json_str(r#"{"model":"phong","params":{"n":"x"}}"#).unwrap_err();
        assert!(e.to_string().contains("`n`"), "{e}");
        let e = crate::from_json_str(r#"{"model":"phong","params":{"n":-2}}"#).unwrap_err();
        assert!(matches!(e, ModelError::OutOfDomain { .. }), "{e}");
    }

    #[test]
    fn shared_checks() {
        let m = model();
        let pairs = random_pairs(11, 300);
        assert_paths_agree(&m, &pairs, 0.0);
        assert_paths_agree(&m, &hard_case_pairs(), 0.0);
        assert_paths_agree(&m, &dense_grid_pairs(12, 6), 0.0);
        assert_nonnegative(&m, &dense_grid_pairs(40, 16));
        assert_zero_below_horizon(&m);
        assert_gradient_matches_fd(&m, &pairs, 1e-6, 1e-6);
    }

    #[test]
    fn hard_cases_stay_finite() {
        for n in [0.0, 1.0, 1e3, 1e6] {
            for (kd, ks) in [(0.0, 0.0), (0.3, 1.0), (1e3, 1e3)] {
                let m = Phong::new(Rgb::splat(kd), Rgb::splat(ks), n).unwrap();
                assert_finite_everywhere(&m, &hard_case_pairs());
                assert_paths_agree(&m, &hard_case_pairs(), 0.0);
                assert_zero_below_horizon(&m);
            }
        }
        // A subnormal incident cosine: the 1/cos θi factor is capped by MIN_COS_I.
        let wi = Vec3::new(-1.0, 0.0, 1e-310);
        let wo = Vec3::new(1.0, 0.0, 1e-310);
        let m = Phong::new(Rgb::splat(0.1), Rgb::splat(1.0), 0.0).unwrap();
        let mut g = vec![Rgb::ZERO; 7];
        let f = m.eval_grad(&wi, &wo, &mut g);
        assert!(f.is_finite() && g.iter().all(Rgb::is_finite), "{f:?} {g:?}");
        assert_eq!(f.r(), 0.1 + 1.0 / MIN_COS_I);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn gradient_matches_finite_differences(
            kd in 0.01f64..2.0, ks in 0.01f64..2.0, n in 0.5f64..300.0, seed in any::<u64>()
        ) {
            let m = Phong::new(Rgb::new(kd, 0.5 * kd, 0.1), Rgb::new(ks, 0.3, 0.7 * ks), n).unwrap();
            let pairs = random_pairs(seed, 12);
            assert_gradient_matches_fd(&m, &pairs, 1e-6, 1e-6);
            assert_paths_agree(&m, &pairs, 0.0);
        }
    }
}
