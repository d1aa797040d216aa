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
//!
//! [`PlausiblePhong`] is the Phong family's shared model [`CosineLobeModel`] with the lobe
//! [`PlausiblePhongLobe`].

use crate::cosine_lobe::{AlbedoLobe, Cosine, CosineLobeModel, LobeKind, cos_pow, cos_pow_dn};
use crate::params::DiffuseSpecular;
use std::f64::consts::{FRAC_1_PI, PI};

/// The domain of ρd and ρs.
pub use crate::params::RHO_DOMAIN;

/// The modified (physically plausible) Phong BRDF.
///
/// Built by [`CosineLobeModel::new`] and its `with_*` steps, which also hold the
/// parameter vector, the JSON contract and the evaluation paths.
pub type PlausiblePhong = CosineLobeModel<PlausiblePhongLobe>;

/// The lobe of [`PlausiblePhong`]: (n+2)/(2π) cosⁿθr about the mirror direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlausiblePhongLobe;

/// The lobe normalisation (n+2)/(2π).
#[inline(always)]
fn norm(n: f64) -> f64 {
    (n + 2.0) / (2.0 * PI)
}

impl LobeKind for PlausiblePhongLobe {
    const NAME: &'static str = "plausible-phong";
    const TYPE: &'static str = "PlausiblePhong";
    const PARAMS: DiffuseSpecular = DiffuseSpecular::albedos(0.5, 0.3);
    const DEFAULT_N: f64 = 20.0;
    const DIFFUSE_SCALE: f64 = FRAC_1_PI;
    const COSINE: Cosine = Cosine::Mirror;
    const RECIPROCAL: bool = true;
    /// Directional albedo ≤ ρd + ρs per channel, so ≤ 1 when ρd + ρs ≤ 1.
    const CONSERVES_ENERGY: bool = true;

    #[inline(always)]
    fn lobe(n: f64, c: f64, _cos_i: f64) -> f64 {
        norm(n) * cos_pow(c, n)
    }

    #[inline(always)]
    fn lobe_dn(n: f64, c: f64, _cos_i: f64) -> (f64, f64) {
        let (p, dp) = cos_pow_dn(c, n);
        // ∂/∂n [(n+2)/(2π) cⁿ] = cⁿ/(2π) + (n+2)/(2π) cⁿ ln c.
        (norm(n) * p, p / (2.0 * PI) + norm(n) * dp)
    }
}

impl AlbedoLobe for PlausiblePhongLobe {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::*;
    use brdfkit_core::direction::spherical;
    use brdfkit_core::{Brdf, Model, Rgb};
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
