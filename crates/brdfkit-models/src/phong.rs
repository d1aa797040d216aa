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
//! [`Model::is_reciprocal`](brdfkit_core::Model::is_reciprocal) and
//! [`Model::conserves_energy`](brdfkit_core::Model::conserves_energy) are both false.
//!
//! [`Phong`] is the Phong family's shared model [`CosineLobeModel`] (builder, parameter
//! vector, JSON, evaluation paths) with the lobe [`PhongLobe`]. This module also
//! re-exports the family's cosine power ([`cos_pow`], [`cos_pow_dn`]) and the
//! per-channel parameter check.

pub use crate::cosine_lobe::{N_DOMAIN, cos_pow, cos_pow_dn};
pub use crate::params::{channel, check_count, check_rgb};

use crate::cosine_lobe::{Cosine, CosineLobeModel, LobeKind};
use crate::params::DiffuseSpecular;
use brdfkit_core::model::Domain;
use brdfkit_core::{ModelError, Rgb};

/// The domain of kd and ks: non-negative, unbounded (the model promises nothing).
pub const K_DOMAIN: Domain = Domain::at_least(0.0);

/// Floor of the incident cosine in the 1/cos θi factor.
///
/// The original model diverges like 1/cos θi at grazing incidence. A direction above
/// the horizon only by round-off (`spherical(π/2, φ)` has z = 6e-17; a hand-made one
/// can be subnormal) would give an infinite value and gradient; the floor caps the
/// factor at 1e12 and changes nothing for θi more than 1e-12 rad from the horizon.
pub const MIN_COS_I: f64 = 1e-12;

/// The original Phong BRDF kd + ks cosⁿθr / cos θi.
///
/// Built by [`CosineLobeModel::new`] and its `with_*` steps, which also hold the
/// parameter vector, the JSON contract and the evaluation paths.
pub type Phong = CosineLobeModel<PhongLobe>;

/// The lobe of [`Phong`]: cosⁿθr / cos θi about the mirror direction, with kd a BRDF
/// value (not an albedo, so no 1/π).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhongLobe;

impl LobeKind for PhongLobe {
    const NAME: &'static str = "phong";
    const TYPE: &'static str = "Phong";
    const PARAMS: DiffuseSpecular = DiffuseSpecular {
        names: ("k_d", "k_s"),
        domain: K_DOMAIN,
        s_domain: K_DOMAIN,
        defaults: (0.15, 0.3),
    };
    const DEFAULT_N: f64 = 20.0;
    const DIFFUSE_SCALE: f64 = 1.0;
    const COSINE: Cosine = Cosine::Mirror;
    /// f(wi, wo) − f(wo, wi) = ks cosⁿθr (1/cos θi − 1/cos θo) ≠ 0.
    const RECIPROCAL: bool = false;
    /// The reflected fraction grows like 1/cos θi at grazing incidence.
    const CONSERVES_ENERGY: bool = false;

    /// (cⁿ / cos θi, cⁿ ln c / cos θi).
    #[inline(always)]
    fn lobe_dn(n: f64, c: f64, cos_i: f64) -> (f64, f64) {
        let inv = 1.0 / cos_i.max(MIN_COS_I);
        let (p, dp) = cos_pow_dn(c, n);
        (p / cos_i.max(MIN_COS_I), dp * inv)
    }
}

impl Phong {
    /// Sets kd (each channel in [0, ∞)).
    pub fn with_k_d(self, k_d: Rgb) -> Result<Self, ModelError> {
        self.with_diffuse(k_d)
    }

    /// Sets ks (each channel in [0, ∞)).
    pub fn with_k_s(self, k_s: Rgb) -> Result<Self, ModelError> {
        self.with_specular(k_s)
    }

    /// The diffuse coefficient kd (a BRDF value, not an albedo).
    pub fn k_d(&self) -> Rgb {
        self.diffuse()
    }

    /// The specular coefficient ks.
    pub fn k_s(&self) -> Rgb {
        self.specular()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::*;
    use brdfkit_core::direction::spherical;
    use brdfkit_core::{Brdf, Model, Vec3};

    fn model() -> Phong {
        Phong::new(Rgb::new(0.05, 0.1, 0.2), Rgb::new(0.3, 0.2, 0.1), 12.0).unwrap()
    }

    #[test]
    fn value_matches_the_angle_formula() {
        let m = model();
        assert_matches_angle_formula(&m, 7, 500, 1.5, 1e-12, |ti, pi, to, po| {
            let lobe = mirror_lobe_from_angles(ti, pi, to, po, 12.0);
            m.k_d() + m.k_s() * (lobe / ti.cos())
        });
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
    fn k_names_set_and_get_k_d_and_k_s() {
        let (d, s) = (Rgb::new(0.1, 2.0, 30.0), Rgb::new(4.0, 0.5, 0.6));
        let m = model().with_k_d(d).unwrap().with_k_s(s).unwrap();
        assert_eq!((m.k_d(), m.k_s(), m.n()), (d, s, 12.0));
        let e = m.clone().with_k_s(Rgb::new(0.1, -0.2, 0.1)).unwrap_err();
        assert!(
            e.to_string().contains("`k_s.g`") && e.to_string().contains("[0, inf)"),
            "{e}"
        );
        assert!(m.with_k_d(Rgb::splat(f64::INFINITY)).is_err());
    }

    #[test]
    fn grazing_incidence_is_capped() {
        // A subnormal incident cosine: the 1/cos θi factor is capped by MIN_COS_I.
        let wi = Vec3::new(-1.0, 0.0, 1e-310);
        let wo = Vec3::new(1.0, 0.0, 1e-310);
        let m = Phong::new(Rgb::splat(0.1), Rgb::splat(1.0), 0.0).unwrap();
        let mut g = vec![Rgb::ZERO; 7];
        let f = m.eval_grad(&wi, &wo, &mut g);
        assert!(f.is_finite() && g.iter().all(Rgb::is_finite), "{f:?} {g:?}");
        assert_eq!(f.r(), 0.1 + 1.0 / MIN_COS_I);
    }
}
