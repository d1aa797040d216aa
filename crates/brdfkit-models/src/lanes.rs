//! Branch-free loops over structure-of-arrays geometry, written once for `f32` and `f64`
//! and compiled for the widest vector instructions the processor has.
//!
//! A model's fast kernel is a `#[inline(always)]` function of one pair written against
//! [`Real`] (no branches: a condition becomes a [`select`], so the loop that calls it
//! vectorises), and a loop over slices implementing [`Run`]. [`dispatch`]
//! ([`brdfkit_core::lanes`], shared with the fitter's loss kernels) runs that loop in a
//! copy compiled for AVX-512 or AVX2 + FMA when the processor has them, chosen at run
//! time (`is_x86_feature_detected!`): the crate itself is compiled for baseline x86-64
//! (SSE2: 2 `f64` or 4 `f32` lanes). Rust never contracts `a * b + c` into a fused
//! multiply-add, so every copy computes the same bits as the baseline loop and as the
//! scalar call of the same kernel (tested), which is what keeps a model's `eval` and its
//! batch paths identical.

use brdfkit_core::geometry::Component;
use std::ops::Sub;

/// The arithmetic a lane kernel may use: brdfkit-core's [`Component`] (the IEEE
/// operations that vectorise, no `exp`, no `erf`, no library calls, with 0, 1 and the
/// square root) and subtraction, with the constants and choices of the kernels.
pub(crate) trait Real: Component + Sub<Output = Self> {
    const HALF: Self;
    const TWO: Self;
    /// The smallest positive normal number: a floor for denominators that are exactly 0
    /// only where their numerator is 0 too.
    const TINY: Self;
    /// Whether a kernel may take sin²θ as 1 − cos²θ (reading only z) rather than from
    /// the x and y components: true where the precision's own round-off exceeds what a
    /// direction's length error costs (f32).
    const SIN2_FROM_Z: bool;
    /// Whether the Cook-Torrance conductor kernel works from the directions' squares and
    /// folds its quotients into one division (`cook_torrance_ggx::conductor_value`):
    /// f64. f32 keeps the half-vector form: its given h and cos θd carry less round-off
    /// than float32 directions near wi = −wo, and its denominators' product could
    /// overflow.
    const FOLD_DIVISIONS: bool;
    /// `x` rounded to this precision.
    fn of(x: f64) -> Self;
}

macro_rules! real {
    ($t:ident, $sin2_from_z:literal, $fold_divisions:literal) => {
        impl Real for $t {
            const SIN2_FROM_Z: bool = $sin2_from_z;
            const FOLD_DIVISIONS: bool = $fold_divisions;
            const HALF: Self = 0.5;
            const TWO: Self = 2.0;
            const TINY: Self = $t::MIN_POSITIVE;
            #[inline(always)]
            fn of(x: f64) -> Self {
                x as $t
            }
        }
    };
}
real!(f64, false, true);
real!(f32, true, false);

/// `c ? a : b`, written so that LLVM emits a blend rather than a branch.
#[inline(always)]
pub(crate) fn select<T: Real>(c: bool, a: T, b: T) -> T {
    if c { a } else { b }
}

/// The larger of `a` and `b` (`b` when either is NaN: callers pass a finite floor as `b`).
#[inline(always)]
pub(crate) fn max<T: Real>(a: T, b: T) -> T {
    if a > b { a } else { b }
}

/// `x` clamped into [0, 1] (NaN gives 0).
#[inline(always)]
pub(crate) fn clamp01<T: Real>(x: T) -> T {
    let lo = max(x, T::ZERO);
    if lo < T::ONE { lo } else { T::ONE }
}

pub(crate) use brdfkit_core::lanes::{Run, dispatch};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn helpers() {
        assert_eq!(clamp01(1.5f64), 1.0);
        assert_eq!(clamp01(-0.0f64), 0.0);
        assert_eq!(clamp01(f64::NAN), 0.0);
        assert_eq!(clamp01(0.25f32), 0.25);
        assert_eq!(max(f32::NAN, 1.0), 1.0);
        assert_eq!(select(true, 1.0f64, 2.0), 1.0);
        assert_eq!(<f32 as Real>::of(0.1), 0.1f32);
    }
}
