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
    /// `self` widened to `f64` (exact).
    fn wide(self) -> f64;
    /// eˣ for x ≤ 0 ([`exp`], in `f64` lanes whatever the precision).
    #[inline(always)]
    fn exp(self) -> Self {
        Self::of(exp(self.wide()))
    }
    /// erf(x) for x ≥ 0 ([`erf`], in `f64` lanes whatever the precision).
    #[inline(always)]
    fn erf(self) -> Self {
        Self::of(erf(self.wide()))
    }
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
            #[inline(always)]
            fn wide(self) -> f64 {
                self as f64
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

/// eˣ without a library call and without branches, so a loop of it vectorises (the
/// libm's `exp` is a scalar call in every lane); within 2 ulp of `f64::exp` (tested).
///
/// The textbook reduction (as fdlibm's `e_exp.c`, Sun Microsystems 1993): x = k ln 2 + r
/// with k = round(x/ln 2), taken by adding and subtracting 1.5·2⁵² (round to nearest,
/// no conversion instruction: k is read from the sum's low bits), r = (x − k ln2_hi) −
/// k ln2_lo in two parts (k ln2_hi is exact), e^r by its Taylor series to r¹³ (|r| ≤
/// 0.35: truncation below 5e-18 relative), and 2ᵏ as two powers of two built from their
/// exponent bits, so a result in the subnormal range is rounded once. x is clamped to
/// [−746, 709.78]: below, e⁻⁷⁴⁶ rounds to 0 as every smaller value does; the callers
/// (Beckmann's D and Smith Λ, [`erf`]) pass x ≤ 0. NaN gives e⁻⁷⁴⁶ = 0.
#[inline(always)]
pub(crate) fn exp(x: f64) -> f64 {
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    /// 1/13!, 1/12!, …, 1/2!, 1, 1: e^r = Σ rⁿ/n! by Horner's rule.
    const TAYLOR: [f64; 14] = [
        1.0 / 6_227_020_800.0,
        1.0 / 479_001_600.0,
        1.0 / 39_916_800.0,
        1.0 / 3_628_800.0,
        1.0 / 362_880.0,
        1.0 / 40_320.0,
        1.0 / 5_040.0,
        1.0 / 720.0,
        1.0 / 120.0,
        1.0 / 24.0,
        1.0 / 6.0,
        0.5,
        1.0,
        1.0,
    ];
    let x = max(x, -746.0);
    let x = if x < 709.78 { x } else { 709.78 };
    let shifted = x * std::f64::consts::LOG2_E + SHIFT;
    let kf = shifted - SHIFT;
    let k = (shifted.to_bits() as i64).wrapping_sub(SHIFT.to_bits() as i64);
    let r = (x - kf * LN2_HI) - kf * LN2_LO;
    let mut p = TAYLOR[0];
    for c in &TAYLOR[1..] {
        p = c + r * p;
    }
    // k ∈ [−1077, 1024]: each half of it is a normal power of two.
    let k1 = k >> 1;
    let pow2 = |e: i64| f64::from_bits(((e + 1023) as u64) << 52);
    p * pow2(k1) * pow2(k - k1)
}

/// erf(x) for x ≥ 0 without a library call and without branches, so a loop of it
/// vectorises; within 2 ulp of the libm's `erf` (tested). Negative x are not handled.
///
/// fdlibm's `s_erf.c` (Sun Microsystems 1993, as the `libm` crate carries it): a rational
/// function P(w)/Q(w) on four ranges, here with each range's coefficients picked by a
/// select (the shorter ones padded with zeros, which leave Horner's rule exact):
/// - x < 0.84375: erf = x + x P/Q, w = x²;
/// - x < 1.25: erf = erx + P/Q, w = x − 1;
/// - x < 1/0.35 and x < 6 (two coefficient sets): erf = 1 − e^(−x² − 0.5625 + P/Q)/x,
///   w = 1/x²; fdlibm splits −x² exactly into two exponentials for erfc's relative
///   accuracy, which erf = 1 − erfc (erfc < 0.08 here) does not need: one exponential,
///   off by ≤ 3 ulp of erfc, is below 0.03 ulp of erf;
/// - x ≥ 6 (and ∞): 1.
#[inline(always)]
pub(crate) fn erf(x: f64) -> f64 {
    // fdlibm's constants, by their bits.
    const ERX: f64 = f64::from_bits(0x3feb_0ac1_6000_0000);
    /// The bits of the coefficients: row j < 8 holds numerator coefficient j, row
    /// 8 + j denominator coefficient j + 1 (Q = 1 + w (d₁ + …)), each row across the
    /// four ranges.
    const COEF: [[u64; 4]; 16] = [
        [
            0x3fc06eba8214db68,
            0xbf6359b8bef77538,
            0xbf843412600d6435,
            0xbf84341239e86f4a,
        ],
        [
            0xbfd4cd7d691cb913,
            0x3fda8d00ad92b34d,
            0xbfe63416e4ba7360,
            0xbfe993ba70c285de,
        ],
        [
            0xbf9d2a51dbd7194f,
            0xbfd7d240fbb8c3f1,
            0xc0251e0441b0e726,
            0xc031c209555f995a,
        ],
        [
            0xbf77a291236668e4,
            0x3fd45fca805120e4,
            0xc04f300ae4cba38d,
            0xc064145d43c5ed98,
        ],
        [
            0xbef8ead6120016ac,
            0xbfbc63983d3e28ec,
            0xc0644cb184282266,
            0xc083ec881375f228,
        ],
        [
            0,
            0x3fa22a36599795eb,
            0xc067135cebccabb2,
            0xc09004616a2e5992,
        ],
        [
            0,
            0xbf61bf380a96073f,
            0xc054526557e4d2f2,
            0xc07e384e9bdc383f,
        ],
        [0, 0, 0xc023a0efc69ac25c, 0],
        [
            0x3fd97779cddadc09,
            0x3fbb3e6618eee323,
            0x4033a6b9bd707687,
            0x403e568b261d5190,
        ],
        [
            0x3fb0a54c5536ceba,
            0x3fe14af092eb6f33,
            0x4061350c526ae721,
            0x40745cae221b9f0a,
        ],
        [
            0x3f74d022c4d36b0f,
            0x3fb2635cd99fe9a7,
            0x407b290dd58a1a71,
            0x409802eb189d5118,
        ],
        [
            0x3f215dc9221c1a10,
            0x3fc02660e763351f,
            0x40842b1921ec2868,
            0x40a8ffb7688c246a,
        ],
        [
            0xbed09c4342a26120,
            0x3f8bedc26b51dd1c,
            0x407ad02157700314,
            0x40a3f219cedf3be6,
        ],
        [
            0,
            0x3f888b545735151d,
            0x405b28a3ee48ae2c,
            0x407da874e79fe763,
        ],
        [0, 0, 0x401a47ef8e484a93, 0xc03670e242712d62],
        [0, 0, 0xbfaeeff2ee749a62, 0],
    ];
    // fdlibm's range ends by their high words: 0.84375, 1.25, 1/0.35, 6.
    let (small, mid) = (x < 0.84375, x < 1.25);
    let near = x < f64::from_bits(0x4006_db6d_0000_0000);
    // Row j's coefficient for x's range, j a constant: every table entry is an
    // immediate. With j a loop variable the selects between table entries became one
    // load from a selected address, whose bounds LLVM cannot identify, and a loop of
    // erf stayed scalar.
    macro_rules! pick {
        ($j:expr) => {
            select(
                small,
                const { f64::from_bits(COEF[$j][0]) },
                select(
                    mid,
                    const { f64::from_bits(COEF[$j][1]) },
                    select(
                        near,
                        const { f64::from_bits(COEF[$j][2]) },
                        const { f64::from_bits(COEF[$j][3]) },
                    ),
                ),
            )
        };
    }
    let x2 = x * x;
    let w = select(small, x2, select(mid, x - 1.0, 1.0 / x2));
    let (mut p, mut q) = (pick!(7), pick!(15));
    // Horner's rule from row 6 down to row 0, written out (see `pick`).
    macro_rules! horner {
        ($($j:literal)*) => {$(
            p = pick!($j) + w * p;
            q = pick!(8 + $j) + w * q;
        )*};
    }
    horner!(6 5 4 3 2 1 0);
    let pq = p / (1.0 + w * q);
    let tail = 1.0 - exp(-x2 - 0.5625 + pq) / x;
    let v = select(small, x + x * pq, select(mid, ERX + pq, tail));
    select(x < 6.0, v, 1.0)
}

pub(crate) use brdfkit_core::lanes::{Run, dispatch};
mod pow;
pub(crate) use pow::{ln_sum, one_plus, pow, pow_ln};

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

    /// Units in the last place between two non-negative numbers (0 for equal bits).
    fn ulps(a: f64, b: f64) -> u64 {
        a.to_bits().abs_diff(b.to_bits())
    }

    /// A sweep of [lo, hi] with n + 1 points, plus each given point and its neighbours.
    fn sweep(lo: f64, hi: f64, n: usize, points: &[f64]) -> Vec<f64> {
        let mut v: Vec<f64> = (0..=n)
            .map(|i| lo + (hi - lo) * i as f64 / n as f64)
            .collect();
        for &p in points {
            v.extend([
                p,
                f64::from_bits(p.to_bits() - 1),
                f64::from_bits(p.to_bits() + 1),
            ]);
        }
        v
    }

    #[test]
    fn exp_is_within_two_ulp_of_the_libm_s() {
        let ln2 = std::f64::consts::LN_2;
        let mut xs = sweep(-746.0, 709.78, 400_000, &[0.5 * ln2, 1.5 * ln2, 1.0, 700.0]);
        // Near 0 on both sides, the subnormal results, the end of the normal range.
        xs.extend((1..=2000).flat_map(|i| {
            let t = 10f64.powf(-300.0 + 0.15 * i as f64);
            [t, -t]
        }));
        xs.extend(sweep(-745.2, -707.0, 20_000, &[-708.4, -744.4, -745.13]));
        let mut worst = 0;
        for x in xs {
            let (got, want) = (exp(x), x.exp());
            let u = ulps(got, want);
            assert!(u <= 2, "exp({x:e}) = {got:e}, libm {want:e}: {u} ulp");
            worst = worst.max(u);
        }
        eprintln!("exp: at most {worst} ulp from the libm's");
        assert_eq!(exp(0.0), 1.0);
        for x in [-746.0, -1e4, f64::NEG_INFINITY, f64::NAN] {
            assert_eq!(exp(x), 0.0, "{x}");
        }
        assert!(exp(709.78).is_finite());
        assert_eq!(<f32 as Real>::exp(-1.0), (-1f64).exp() as f32);
    }

    #[test]
    fn erf_is_within_two_ulp_of_the_libm_s() {
        let ends = [0.84375, 1.25, f64::from_bits(0x4006_db6d_0000_0000), 6.0];
        let mut xs = sweep(0.0, 8.0, 400_000, &ends);
        xs.extend((1..=600).map(|i| 10f64.powf(-310.0 + 0.5 * i as f64)));
        let mut worst = 0;
        for x in xs {
            let (got, want) = (erf(x), libm::erf(x));
            let u = ulps(got, want);
            assert!(u <= 2, "erf({x:e}) = {got:e}, libm {want:e}: {u} ulp");
            worst = worst.max(u);
        }
        eprintln!("erf: at most {worst} ulp from the libm's");
        assert_eq!(erf(0.0), 0.0);
        assert_eq!(erf(f64::INFINITY), 1.0);
        assert_eq!(<f32 as Real>::erf(0.5), libm::erf(0.5) as f32);
    }
}
