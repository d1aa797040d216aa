//! Branch-free f32 `atan2` and `asin` for the batch evaluation (`batch.rs`): glibc's
//! are calls the compiler cannot vectorise, and they were a fifth of the f64 path's time.
//!
//! They are the polynomials of Dr.Jit (`drjit/math.h`), hence of Mitsuba 3's LLVM kernel,
//! with every branch a select so a loop over lanes vectorises:
//! - `atan2(y, x)`: atan(q)/q ≈ P(q²), P a degree-6 minimax fit on [1e-4, 1] (W. Jakob,
//!   2016, as in Dr.Jit), at q = min(|x|,|y|)/max(|x|,|y|) ∈ [0, 1], then the octant
//!   restored: π/2 − t where |y| > |x|, π − t where x < 0, −t where y < 0; 0 at the
//!   origin (Dr.Jit's choice, and so Mitsuba's; glibc's `atan2(−0, −0)` is −π).
//! - `asin(x)`: Cephes' `asinf` (S. L. Moshier, Cephes Math Library), as in Dr.Jit:
//!   |x| ≤ ½, x + x·z·P(z), z = x², P of degree 4; above ½,
//!   asin(x) = π/2 − 2 asin(√((1 − x)/2)).
//!
//! Error bounds, measured against f64 `std` over dense grids (tests below), match what
//! Dr.Jit states for them: [`ATAN2_MAX_ABS_ERR`] absolute for `atan2` on the whole
//! plane (Dr.Jit: 5.96e-7), [`ASIN_MAX_REL_ERR`] relative for `asin` on [−1, 1]
//! (Dr.Jit: 2.28e-7, 2 ulp).

use std::f32::consts::{FRAC_PI_2, PI};

/// The largest |atan2_f32(y, x) − atan2(y, x)| the tests allow (radians).
pub const ATAN2_MAX_ABS_ERR: f64 = 7.0e-7;
/// The largest |asin_f32(x) − asin(x)| / |asin(x)| the tests allow.
pub const ASIN_MAX_REL_ERR: f64 = 3.0e-7;

/// atan2(y, x) in [−π, π], 0 at the origin; error within [`ATAN2_MAX_ABS_ERR`].
#[inline(always)]
pub fn atan2_f32(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let q = if hi > 0.0 { lo / hi } else { 0.0 };
    let z = q * q;
    let p = ((((((7.861_379_4e-3 * z - 3.700_652_6e-2) * z + 8.386_312e-2) * z - 1.348_670_9e-1)
        * z
        + 1.988_134_2e-1)
        * z
        - 3.332_649_8e-1)
        * z
        + 9.999_993_4e-1)
        * q;
    let t = if ay > ax { FRAC_PI_2 - p } else { p };
    let t = if x < 0.0 { PI - t } else { t };
    if y < 0.0 { -t } else { t }
}

/// asin(x) for x in [−1, 1] (NaN outside); relative error within [`ASIN_MAX_REL_ERR`].
#[inline(always)]
pub fn asin_f32(x: f32) -> f32 {
    let a = x.abs();
    let big = a > 0.5;
    let z = if big { 0.5 * (1.0 - a) } else { a * a };
    let r = if big { z.sqrt() } else { a };
    let p = ((((4.216_32e-2 * z + 2.418_131e-2) * z + 4.547_002_6e-2) * z + 7.495_300_3e-2) * z
        + 1.666_675_2e-1)
        * z;
    let s = r + r * p;
    let v = if big { FRAC_PI_2 - 2.0 * s } else { s };
    if x < 0.0 { -v } else { v }
}

/// f64 `atan2` with Dr.Jit's (and so Mitsuba's) conventions where its result depends on
/// the sign of a zero: 0 at the origin, and y = −0 taken as +0 (π, not −π, for x < 0).
/// The f64 path's φ ([`crate::RglBsdf`]'s `eval`) uses it so both paths and Mitsuba
/// agree at θ = 0 and on the x axis.
#[inline]
pub fn atan2_drjit(y: f64, x: f64) -> f64 {
    if x == 0.0 && y == 0.0 {
        0.0
    } else if y == 0.0 {
        0.0f64.atan2(x)
    } else {
        y.atan2(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_is_within_its_bound_on_the_plane() {
        let mut worst = 0.0f64;
        let n = 1000;
        for i in 0..=n {
            for j in 0..=n {
                // Both signs, magnitudes from 1e-6 to 1e3, and exact zeros.
                for (sx, sy) in [(1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)] {
                    let x = sx
                        * if i == 0 {
                            0.0
                        } else {
                            10f64.powf(-6.0 + 9.0 * i as f64 / n as f64)
                        };
                    let y = sy
                        * if j == 0 {
                            0.0
                        } else {
                            10f64.powf(-6.0 + 9.0 * j as f64 / n as f64)
                        };
                    let (xf, yf) = (x as f32, y as f32);
                    let truth = atan2_drjit(f64::from(yf), f64::from(xf));
                    let got = f64::from(atan2_f32(yf, xf));
                    if xf == 0.0 && yf == 0.0 {
                        assert_eq!(got, 0.0, "Dr.Jit's atan2 at the origin");
                        continue;
                    }
                    worst = worst.max((got - truth).abs());
                }
            }
        }
        assert!(worst <= ATAN2_MAX_ABS_ERR, "atan2 error {worst:e}");
        assert!(worst > 0.0, "the grid must exercise the rounding");
    }

    #[test]
    fn atan2_on_the_axes_and_diagonals() {
        for (y, x, want) in [
            (0.0f32, 1.0f32, 0.0f64),
            (1.0, 0.0, std::f64::consts::FRAC_PI_2),
            (-1.0, 0.0, -std::f64::consts::FRAC_PI_2),
            (0.0, -1.0, std::f64::consts::PI),
            (-0.0, -1.0, std::f64::consts::PI),
            (-0.0, -0.0, 0.0),
            (1.0, 1.0, std::f64::consts::FRAC_PI_4),
            (-1.0, -1.0, -3.0 * std::f64::consts::FRAC_PI_4),
        ] {
            let got = f64::from(atan2_f32(y, x));
            assert_eq!(atan2_drjit(f64::from(y), f64::from(x)), want);
            assert!(
                (got - want).abs() <= ATAN2_MAX_ABS_ERR,
                "atan2({y}, {x}) = {got}"
            );
        }
    }

    #[test]
    fn asin_is_within_its_bound_on_minus_one_to_one() {
        let mut worst = 0.0f64;
        let n = 2_000_000;
        for i in 0..=n {
            let xf = (-1.0 + 2.0 * i as f64 / n as f64) as f32;
            let truth = f64::from(xf).asin();
            let got = f64::from(asin_f32(xf));
            if truth == 0.0 {
                assert_eq!(got, 0.0);
                continue;
            }
            worst = worst.max(((got - truth) / truth).abs());
        }
        // Tiny arguments, where asin(x) ≈ x.
        for e in -30..0 {
            let xf = 10f32.powi(e);
            let truth = f64::from(xf).asin();
            worst = worst.max(((f64::from(asin_f32(xf)) - truth) / truth).abs());
        }
        assert!(worst <= ASIN_MAX_REL_ERR, "asin error {worst:e}");
        assert!(worst > 0.0);
        assert!(asin_f32(1.5).is_nan());
    }
}
