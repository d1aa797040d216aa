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

use crate::cosine_lobe::{AlbedoLobe, Cosine, CosineLobeModel, LobeKind, normalised_cos_pow_dn};
use crate::params::DiffuseSpecular;
use std::f64::consts::FRAC_1_PI;

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

impl LobeKind for PlausiblePhongLobe {
    const NAME: &'static str = "plausible-phong";
    const TYPE: &'static str = "PlausiblePhong";
    const PARAMS: DiffuseSpecular = DiffuseSpecular::bounded_albedos(0.5, 0.3);
    const DEFAULT_N: f64 = 20.0;
    const DIFFUSE_SCALE: f64 = FRAC_1_PI;
    const COSINE: Cosine = Cosine::Mirror;
    const RECIPROCAL: bool = true;
    /// Directional albedo ≤ ρd + ρs per channel, so ≤ 1 when ρd + ρs ≤ 1.
    const CONSERVES_ENERGY: bool = true;

    /// (n+2)/(2π) · cⁿ.
    #[inline(always)]
    fn lobe_dn(n: f64, c: f64, _cos_i: f64) -> (f64, f64) {
        normalised_cos_pow_dn(2.0, c, n)
    }
}

impl AlbedoLobe for PlausiblePhongLobe {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::*;
    use brdfkit_core::Rgb;
    use std::f64::consts::PI;

    fn model() -> PlausiblePhong {
        PlausiblePhong::new(Rgb::new(0.2, 0.4, 0.6), Rgb::new(0.5, 0.3, 0.1), 35.0).unwrap()
    }

    #[test]
    fn value_matches_the_angle_formula() {
        let m = model();
        assert_matches_angle_formula(&m, 8, 500, 1.5, 1e-12, |ti, pi, to, po| {
            let lobe = mirror_lobe_from_angles(ti, pi, to, po, 35.0);
            m.rho_d() / PI + m.rho_s() * (37.0 / (2.0 * PI) * lobe)
        });
    }
}
