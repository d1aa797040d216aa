//! Microfacet normal distributions D(h) and their derivatives with respect to the
//! roughness, isotropic (αx = αy) and anisotropic.
//!
//! Both are normalised so that the projected microfacet area is the macro-surface area,
//! ∫ D(h) cos θh dωh = 1 (the tests integrate it), and are 0 for h.z ≤ 0. The tangent x
//! of the local frame carries αx, the binormal y carries αy.
//!
//! - Beckmann (P. Beckmann and A. Spizzichino, *The Scattering of Electromagnetic Waves
//!   from Rough Surfaces*, 1963; anisotropic form as in B. Walter et al., "Microfacet
//!   Models for Refraction through Rough Surfaces", EGSR 2007, eq. 25, and E. Heitz,
//!   "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs", JCGT
//!   3(2), 2014, eq. 85):
//!   D(h) = exp(−(hx²/αx² + hy²/αy²)/hz²) / (π αx αy hz⁴).
//! - GGX / Trowbridge-Reitz (T. S. Trowbridge and K. P. Reitz, JOSA 65(5), 1975;
//!   Walter et al. 2007 eq. 33; Heitz 2014 eq. 86):
//!   D(h) = 1 / (π αx αy (hx²/αx² + hy²/αy² + hz²)²).
//!
//! `h` need not be exactly unit length: round-off in its normalisation changes D by the
//! same relative amount.

use std::f64::consts::FRAC_1_PI;

/// The microfacet distribution family.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Distribution {
    /// Beckmann: Gaussian slopes.
    Beckmann,
    /// GGX / Trowbridge-Reitz: long-tailed slopes.
    Ggx,
}

/// D(h) and its partial derivatives with respect to αx and αy.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DGrad {
    /// D(h).
    pub d: f64,
    /// ∂D/∂αx.
    pub d_ax: f64,
    /// ∂D/∂αy.
    pub d_ay: f64,
}

impl DGrad {
    /// ∂D/∂α of the isotropic distribution (αx = αy = α): the sum of the partials.
    #[inline(always)]
    pub fn d_alpha(&self) -> f64 {
        self.d_ax + self.d_ay
    }
}

/// Beckmann D(h) with ∂D/∂αx, ∂D/∂αy.
///
/// With e = (hx²/αx² + hy²/αy²)/hz²: ∂D/∂αx = D (2hx²/(αx³ hz²) − 1/αx), likewise y.
///
/// When exp(−e) underflows to 0 the value and derivatives are exactly 0: the prefactor
/// 1/hz⁴ alone could overflow for a half vector within 1e-77 of the horizon, and 0 ×
/// ∞ would be NaN; the true value there is below 1e-300.
#[inline(always)]
pub fn beckmann_grad(hx: f64, hy: f64, hz: f64, ax: f64, ay: f64) -> DGrad {
    if hz <= 0.0 {
        return DGrad::default();
    }
    let hz2 = hz * hz;
    let (ux, uy) = (hx * hx / (ax * ax), hy * hy / (ay * ay));
    let ex = (-(ux + uy) / hz2).exp();
    if ex == 0.0 {
        return DGrad::default();
    }
    let d = ex * FRAC_1_PI / (ax * ay * hz2 * hz2);
    DGrad {
        d,
        d_ax: d * (2.0 * ux / hz2 - 1.0) / ax,
        d_ay: d * (2.0 * uy / hz2 - 1.0) / ay,
    }
}

/// GGX D(h) with ∂D/∂αx, ∂D/∂αy.
///
/// With s = hx²/αx² + hy²/αy² + hz²: ∂D/∂αx = D (4hx²/(αx² s) − 1)/αx, likewise y.
/// D is bounded, since s ≥ min(1, 1/max(αx, αy)²) on the unit hemisphere: every term
/// stays finite for α in [1e-6, 100] (the models' domain).
#[inline(always)]
pub fn ggx_grad(hx: f64, hy: f64, hz: f64, ax: f64, ay: f64) -> DGrad {
    if hz <= 0.0 {
        return DGrad::default();
    }
    let (ux, uy) = (hx * hx / (ax * ax), hy * hy / (ay * ay));
    let s = ux + uy + hz * hz;
    let d = FRAC_1_PI / (ax * ay * s * s);
    DGrad {
        d,
        d_ax: d * (4.0 * ux / s - 1.0) / ax,
        d_ay: d * (4.0 * uy / s - 1.0) / ay,
    }
}

impl Distribution {
    /// D(h).
    #[inline(always)]
    pub fn d(self, hx: f64, hy: f64, hz: f64, ax: f64, ay: f64) -> f64 {
        self.d_grad(hx, hy, hz, ax, ay).d
    }

    /// D(h) with its derivatives with respect to αx and αy.
    #[inline(always)]
    pub fn d_grad(self, hx: f64, hy: f64, hz: f64, ax: f64, ay: f64) -> DGrad {
        match self {
            Distribution::Beckmann => beckmann_grad(hx, hy, hz, ax, ay),
            Distribution::Ggx => ggx_grad(hx, hy, hz, ax, ay),
        }
    }
}

crate::named_choice!(Distribution, "distribution", {
    Beckmann => "beckmann",
    Ggx => "ggx",
});

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scattering::test_quad::integrate_h;
    use std::f64::consts::PI;

    /// ∫ D(h) cos θh dωh over the upper hemisphere.
    pub(crate) fn normalisation(dist: Distribution, ax: f64, ay: f64) -> f64 {
        integrate_h(&|h| dist.d(h[0], h[1], h[2], ax, ay) * h[2], ax, ay, None)
    }

    #[test]
    fn distributions_are_normalised() {
        let mut worst: f64 = 0.0;
        for dist in [Distribution::Beckmann, Distribution::Ggx] {
            for &(ax, ay) in &[
                (0.01, 0.01),
                (0.05, 0.05),
                (0.2, 0.2),
                (0.5, 0.5),
                (1.0, 1.0),
                (0.05, 0.5),
                (0.5, 0.05),
                (0.01, 1.0),
            ] {
                let n = normalisation(dist, ax, ay);
                // Both are densities of slopes over the whole plane, which maps onto the
                // upper hemisphere: 1 is exact for both.
                worst = worst.max((n - 1.0).abs());
                assert!((n - 1.0).abs() < 1e-4, "{dist:?} ({ax},{ay}): {n}");
            }
        }
        eprintln!("max |∫D cos − 1| = {worst:e}");
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let hs = [
            (0.0, 0.0, 1.0),
            (0.1, 0.05, 0.99373),
            (0.3, -0.4, 0.866),
            (-0.6, 0.5, 0.6245),
        ];
        for dist in [Distribution::Beckmann, Distribution::Ggx] {
            for &(ax, ay) in &[(0.1, 0.1), (0.3, 0.7), (1.0, 0.05)] {
                for &(hx, hy, hz) in &hs {
                    let g = dist.d_grad(hx, hy, hz, ax, ay);
                    let hh = 1e-6;
                    let fx = (dist.d(hx, hy, hz, ax + hh * ax, ay)
                        - dist.d(hx, hy, hz, ax - hh * ax, ay))
                        / (2.0 * hh * ax);
                    let fy = (dist.d(hx, hy, hz, ax, ay + hh * ay)
                        - dist.d(hx, hy, hz, ax, ay - hh * ay))
                        / (2.0 * hh * ay);
                    let tol = |a: f64, b: f64| 1e-6 * a.abs().max(b.abs()) + 1e-9 * g.d;
                    assert!(
                        (g.d_ax - fx).abs() <= tol(g.d_ax, fx),
                        "{dist:?} ∂αx {} {fx}",
                        g.d_ax
                    );
                    assert!(
                        (g.d_ay - fy).abs() <= tol(g.d_ay, fy),
                        "{dist:?} ∂αy {} {fy}",
                        g.d_ay
                    );
                }
            }
        }
    }

    #[test]
    fn closed_forms_and_support() {
        let a: f64 = 0.3;
        // Isotropic GGX in its usual form α² / (π (cos²θ (α² − 1) + 1)²).
        let t: f64 = 0.4;
        let (s, c) = t.sin_cos();
        let iso = a * a / (PI * (c * c * (a * a - 1.0) + 1.0).powi(2));
        assert!((Distribution::Ggx.d(s, 0.0, c, a, a) - iso).abs() < 1e-14 * iso);
        let beck = (-(t.tan() / a).powi(2)).exp() / (PI * a * a * c.powi(4));
        assert!((Distribution::Beckmann.d(0.0, s, c, a, a) - beck).abs() < 1e-14 * beck);
        for dist in [Distribution::Beckmann, Distribution::Ggx] {
            assert_eq!(dist.d(0.5, 0.0, 0.0, a, a), 0.0);
            assert_eq!(dist.d(0.5, 0.0, -0.3, a, a), 0.0);
            assert_eq!(dist.d_grad(0.5, 0.0, -0.3, a, a), DGrad::default());
        }
    }

    #[test]
    fn tiny_roughness_stays_finite_at_the_peak() {
        for dist in [Distribution::Beckmann, Distribution::Ggx] {
            let g = dist.d_grad(0.0, 0.0, 1.0, 1e-6, 1e-6);
            assert!((g.d - 1.0 / (PI * 1e-12)).abs() < 1e-3 * g.d);
            assert!(g.d.is_finite() && g.d_ax.is_finite() && g.d_ay.is_finite());
            // Just off the peak and grazing half vectors.
            for h in [(1e-7, 0.0, 1.0), (1.0, 1e-3, 1e-17), (0.7, 0.7, 1e-90)] {
                let g = dist.d_grad(h.0, h.1, h.2, 1e-6, 2.0);
                assert!(
                    g.d.is_finite() && g.d_ax.is_finite() && g.d_ay.is_finite(),
                    "{h:?} {g:?}"
                );
            }
        }
    }
}
