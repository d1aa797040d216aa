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
//! | ρs        | `rho_s` | yes         | [0, ∞) | 0.3     |
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
//! ≤ 1, and [`Model::conserves_energy`](brdfkit_core::Model::conserves_energy) is false; ρd + 1.076 ρs ≤ 1 suffices (the
//! tests measure the albedo over θo ≤ 89° and n ∈ [1, 10⁴]).
//!
//! [`BlinnPhong`] is the Phong family's shared model [`CosineLobeModel`] with the lobe
//! [`BlinnPhongLobe`].

use crate::cosine_lobe::{AlbedoLobe, Cosine, CosineLobeModel, LobeKind, normalised_cos_pow_dn};
use crate::params::DiffuseSpecular;
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
///
/// Built by [`CosineLobeModel::new`] and its `with_*` steps, which also hold the
/// parameter vector, the JSON contract and the evaluation paths.
pub type BlinnPhong = CosineLobeModel<BlinnPhongLobe>;

/// The lobe of [`BlinnPhong`]: (n+8)/(8π) cosⁿθh about the half vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlinnPhongLobe;

impl LobeKind for BlinnPhongLobe {
    const NAME: &'static str = "blinn-phong";
    const TYPE: &'static str = "BlinnPhong";
    const PARAMS: DiffuseSpecular = DiffuseSpecular::albedos(0.5, 0.3);
    const DEFAULT_N: f64 = 50.0;
    const DIFFUSE_SCALE: f64 = FRAC_1_PI;
    const COSINE: Cosine = Cosine::Half;
    /// h is symmetric in wi and wo.
    const RECIPROCAL: bool = true;
    /// False: with the (n+8)/(8π) factor the albedo reaches ≈ 1.075 ρs (module doc).
    const CONSERVES_ENERGY: bool = false;

    /// (n+8)/(8π) · cⁿ.
    #[inline(always)]
    fn lobe_dn(n: f64, c: f64, _cos_i: f64) -> (f64, f64) {
        normalised_cos_pow_dn(8.0, c, n)
    }
}

impl AlbedoLobe for BlinnPhongLobe {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::*;
    use brdfkit_core::Rgb;

    fn model() -> BlinnPhong {
        BlinnPhong::new(Rgb::new(0.2, 0.4, 0.6), Rgb::new(0.5, 0.3, 0.1), 60.0).unwrap()
    }

    #[test]
    fn value_matches_the_angle_formula() {
        // Independent truth: cos θh = (cos θi + cos θo) / |wi + wo| with
        // |wi + wo|² = 2 + 2 (cos θi cos θo + sin θi sin θo cos(φi − φo)).
        let m = model();
        assert_matches_angle_formula(&m, 9, 500, 1.5, 1e-12, |ti, pi, to, po| {
            let dot = ti.cos() * to.cos() + ti.sin() * to.sin() * (pi - po).cos();
            let ch = (ti.cos() + to.cos()) / (2.0 + 2.0 * dot).sqrt();
            m.rho_d() / PI + m.rho_s() * (68.0 / (8.0 * PI) * ch.powf(60.0))
        });
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
}
