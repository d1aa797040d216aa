//! xⁿ and ln x without library calls and without branches, so that a loop of them
//! vectorises: the cosine lobes' power (Lafortune, the Phong family), which as the libm's
//! `pow` is a scalar call in every lane.
//!
//! xⁿ = e^(n ln x) with ln x in two parts (hi + lo, about 2⁻⁶³ relative) and the product
//! n ln x in two parts too, as fdlibm's `e_pow.c` (Sun Microsystems 1993) does: the
//! exponential's argument is as large as 745 in magnitude, so a 1-ulp error in ln x
//! alone would cost up to 745 ulp of xⁿ. Within 4 ulp of `f64::powf` (tested: 3 ulp
//! where |n ln x| ≤ 400, i.e. xⁿ > 10⁻¹⁷⁴; 1 ulp on subnormal results), the error
//! growing with |n ln x| through the rounding of the series' tail and [`exp`]'s 2 ulp.

use super::{exp, select};

/// ln x in two parts (hi, lo), hi + lo = ln x to about 2⁻⁶³ relative, for x > 0
/// (subnormals included); finite for every x (callers select the result away where
/// x ≤ 0 or x is not finite).
///
/// The reduction of fdlibm's `e_pow.c`: x = 2ᵏ m with m ∈ [√3/2, √3), and a pivot
/// b = 1.5 for m ∈ [√(3/2), √3), else 1, so that s = (m − b)/(m + b) has |s| ≤ 0.102;
/// then ln x = k ln 2 + ln b + 2 atanh s, 2 atanh s = 2s + 2s³ Σⱼ s²ʲ/(2j + 3).
/// m − b is exact (Sterbenz); s is taken in two parts s_h + s_l with s_h cut to 21
/// significant bits, so s_h (m + b) is exact and s_l = (m − b − s_h (m + b))/(m + b),
/// with m + b = t_h + t_l split the same way. The series stops after s¹⁷: the next term
/// is below 2⁻⁶³ of 2s. ln 2 and ln 1.5 are taken in two parts whose high parts have
/// 32 significant bits, so k ln 2_hi + ln b_hi and the sum with 2 s_h lose nothing.
#[inline(always)]
pub(crate) fn ln2parts(x: f64) -> (f64, f64) {
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    const LN1_5_HI: f64 = f64::from_bits(0x3fd9_f323_ec80_0000);
    const LN1_5_LO: f64 = f64::from_bits(0x3def_cc25_f95b_46bb);
    const SQRT_1_5: f64 = f64::from_bits(0x3ff3_988e_1409_212e);
    const SQRT_3: f64 = f64::from_bits(0x3ffb_b67a_e858_4caa);
    /// 2⁵⁴: scales a subnormal x to a normal one.
    const TWO54: f64 = 18_014_398_509_481_984.0;
    let sub = x < f64::MIN_POSITIVE;
    let xs = select(sub, x * TWO54, x);
    let bits = xs.to_bits();
    // The biased exponent as a double, by its bits (no integer conversion, which
    // baseline and AVX2 vectors lack): 2⁵² + e − (2⁵² + 1023).
    let e =
        f64::from_bits(0x4330_0000_0000_0000 | ((bits >> 52) & 0x7ff)) - 4_503_599_627_371_519.0;
    let m = f64::from_bits((bits & 0x000f_ffff_ffff_ffff) | 0x3ff0_0000_0000_0000);
    let high = m >= SQRT_3;
    let m = select(high, 0.5 * m, m);
    let k = e + select(high, 1.0, 0.0) - select(sub, 54.0, 0.0);
    // m < √3 here: the pivot 1.5 serves [√(3/2), √3).
    let mid = m >= SQRT_1_5;
    let b = select(mid, 1.5, 1.0);
    let u = m - b;
    let t = m + b;
    let t_h = cut(t);
    let t_l = m - (t_h - b);
    let s = u / t;
    let s_h = cut(s);
    let s_l = ((u - s_h * t_h) - s_h * t_l) / t;
    let z = s * s;
    // Σⱼ s²ʲ/(2j + 3) for j < 8 by Horner's rule (the divisions fold to constants).
    let mut p = 0.0;
    for j in (0..8u32).rev() {
        p = 1.0 / f64::from(2 * j + 3) + z * p;
    }
    // The series at the rounded s, plus its derivative 2s²/(1 − s²) ≈ 2z times
    // s's rounding error (s_h − s) + s_l, which the cube would otherwise triple.
    let tail = 2.0 * s * z * p + 2.0 * z * ((s_h - s) + s_l);
    let a = k * LN2_HI + select(mid, LN1_5_HI, 0.0);
    let bb = 2.0 * s_h;
    // |a| ≥ |bb| or a = 0 (module doc of the ranges), so this sum's error is exact.
    let hi = a + bb;
    let err = (a - hi) + bb;
    let lo = err + (k * LN2_LO + select(mid, LN1_5_LO, 0.0) + (2.0 * s_l + tail));
    let h = hi + lo;
    (h, lo - (h - hi))
}

/// `x` with its 32 low bits cleared: 21 significant bits, so products with another
/// such number are exact.
#[inline(always)]
fn cut(x: f64) -> f64 {
    f64::from_bits(x.to_bits() & 0xffff_ffff_0000_0000)
}

/// Veltkamp's split of `a` into two 26-bit halves a₁ + a₂ = a (Dekker 1971).
#[inline(always)]
fn split(a: f64) -> (f64, f64) {
    let c = 134_217_729.0 * a;
    let a1 = c - (c - a);
    (a1, a - a1)
}

/// (xⁿ, ln x) for x ≥ 0 and n ≥ 0, both 0 where x ≤ 0 or x is NaN (a lobe's clamp
/// max(0, c)ⁿ, and 0⁰ = 0, the limit as n → 0⁺); within 4 ulp of `f64::powf` (tested),
/// with ln x to 1 ulp, for the n-derivative xⁿ ln x.
///
/// y = n (ln_hi + ln_lo) = y_hi + y_lo by Dekker's exact product of n and ln_hi, and
/// xⁿ = e^y_hi (1 + y_lo) with [`exp`] (|y_lo| < 2⁻⁴², so the first-order term is
/// exact to 2⁻⁸⁴). Where n ln_hi overflows the split (n > 10³⁰⁰), y_lo is dropped:
/// |y_hi| is then beyond the exponential's range, or 0 at x = 1.
#[inline(always)]
pub(crate) fn pow_ln(x: f64, n: f64) -> (f64, f64) {
    let (hi, lo) = ln2parts(x);
    let y = n * hi;
    let ((n1, n2), (h1, h2)) = (split(n), split(hi));
    let y_lo = (((n1 * h1 - y) + n1 * h2 + n2 * h1) + n2 * h2) + n * lo;
    let y_lo = select(y_lo.abs() < 1.0, y_lo, 0.0);
    let e = exp(y);
    let p = e + e * y_lo;
    let pos = x > 0.0;
    (select(pos, p, 0.0), select(pos, hi + lo, 0.0))
}

/// ln(u + c) for u > 0 given with a small correction c (|c| ≤ half an ulp of u, the
/// rounding error of a sum that produced u), to about 1 ulp; finite for every u (callers
/// select the result away where u ≤ 0). ln(u + c) = ln u + c/u − …, and the omitted
/// c²/(2u²) is below 2⁻¹⁰⁶ relative to ln u's scale; ln u in two parts ([`ln2parts`]).
#[inline(always)]
pub(crate) fn ln_sum(u: f64, c: f64) -> f64 {
    let (hi, lo) = ln2parts(u);
    hi + (lo + c / u)
}

/// 1 + x and its rounding error c = x − ((1 + x) − 1), exact for |x| ≤ 1 (Dekker's
/// Fast2Sum): the argument of [`ln_sum`] for ln(1 + x).
#[inline(always)]
pub(crate) fn one_plus(x: f64) -> (f64, f64) {
    let u = 1.0 + x;
    (u, x - (u - 1.0))
}

/// ln(1 + x) for x ∈ [−1, 1] by [`one_plus`] and [`ln_sum`], as the callers compose it
/// (tested: within 1 ulp of `f64::ln_1p` on (−0.5, 0]).
#[cfg(test)]
fn ln_1p(x: f64) -> f64 {
    let (u, c) = one_plus(x);
    ln_sum(u, c)
}

/// xⁿ of [`pow_ln`].
#[inline(always)]
pub(crate) fn pow(x: f64, n: f64) -> f64 {
    pow_ln(x, n).0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Units in the last place between two non-negative numbers.
    fn ulps(a: f64, b: f64) -> u64 {
        a.to_bits().abs_diff(b.to_bits())
    }

    /// Bases over (0, 1.2]: a uniform sweep, a geometric one down to the subnormals,
    /// the neighbours of 1 and of the reduction's range ends.
    fn bases() -> Vec<f64> {
        let mut v: Vec<f64> = (1..=20_000).map(|i| i as f64 / 20_000.0 * 1.2).collect();
        v.extend((0..2_000).map(|i| 10f64.powf(-323.0 + 0.1615 * i as f64)));
        for p in [
            1.0,
            0.5,
            0.25,
            0.866,
            0.6124,
            0.8660254037844386,
            0.6123724356957945,
        ] {
            let b = f64::to_bits(p);
            v.extend((0..200).flat_map(|d| [f64::from_bits(b - d), f64::from_bits(b + d)]));
        }
        v.extend((1..=1_000).map(|i| 1.0 - i as f64 * 1e-7));
        v.push(f64::MIN_POSITIVE);
        v.push(5e-324);
        v
    }

    #[test]
    fn pow_is_within_four_ulp_of_the_libm_s() {
        let ns: Vec<f64> = [0.0, 1e-9, 0.01, 0.5, 1.0, 2.0, 3.7, 20.0, 63.5, 100.0]
            .into_iter()
            .chain((0..60).map(|i| 10f64.powf(-3.0 + 0.15 * i as f64)))
            .chain([1e7, 1e12, 1e300])
            .collect();
        let (mut worst, mut worst_sub) = (0, 0);
        for &x in &bases() {
            for &n in &ns {
                let (got, want) = (pow(x, n), x.powf(n));
                if want > 1e300 {
                    // Bases above 1 by round-off with a huge n: e^709.78, not ∞.
                    assert!(got.is_finite() && got > 1e300, "{x:e}^{n:e} = {got:e}");
                    continue;
                }
                let u = ulps(got, want);
                if want < f64::MIN_POSITIVE {
                    worst_sub = worst_sub.max(u);
                    assert!(u <= 1, "{x:e}^{n:e} = {got:e}, libm {want:e}: {u} ulp");
                } else {
                    worst = worst.max(u);
                    // The error grows with |n ln x| (module doc): 3 ulp up to 400.
                    let bound = if (n * x.ln()).abs() <= 400.0 { 3 } else { 4 };
                    assert!(u <= bound, "{x:e}^{n:e} = {got:e}, libm {want:e}: {u} ulp");
                }
            }
        }
        eprintln!("pow: at most {worst} ulp from the libm's ({worst_sub} on subnormal results)");
    }

    #[test]
    fn ln_1p_and_ln_are_within_one_ulp_of_the_libm_s() {
        // ln_1p over (−0.5, 0] (Ashikhmin-Shirley's −(hx² + hy²) below ½): uniform,
        // geometric towards 0 and the neighbours of −0.5 and of 0.
        let mut xs: Vec<f64> = (0..100_000).map(|i| -0.5 * i as f64 / 100_000.0).collect();
        xs.extend((0..3_000).map(|i| -(10f64.powf(-320.0 + 0.1066 * i as f64))));
        let b = f64::to_bits(-0.5);
        xs.extend((0..200).map(|d| f64::from_bits(b - d)));
        xs.extend((1..=1_000).map(|i| -(i as f64) * f64::EPSILON));
        let mut worst = 0;
        for &x in &xs {
            let (got, want) = (ln_1p(x), x.ln_1p());
            let u = ulps(got.abs(), want.abs());
            // Both are ≤ 0 here: their magnitudes' bits compare.
            assert!(u <= 1, "ln_1p({x:e}) = {got:e}, libm {want:e}: {u} ulp");
            worst = worst.max(u);
        }
        eprintln!("ln_1p: at most {worst} ulp from the libm's");
        assert_eq!(ln_1p(0.0), 0.0);
        // ln over (0, 1] through ln_sum(u, 0) (cos θh above the horizon).
        let mut worst = 0;
        for &x in &bases() {
            let (got, want) = (ln_sum(x, 0.0), x.ln());
            let u = ulps(got.abs(), want.abs());
            assert!(u <= 1, "ln {x:e} = {got:e}, libm {want:e}: {u} ulp");
            worst = worst.max(u);
        }
        eprintln!("ln: at most {worst} ulp from the libm's");
    }

    /// The exponent at which xⁿ spans the whole normal range, for bases across (0, 1):
    /// the exponential's argument near −708 and its error amplified the most.
    #[test]
    fn pow_near_underflow_and_across_exponents() {
        let mut worst = 0;
        for i in 1..4_000 {
            let x = i as f64 / 4_000.0;
            for t in [-1.0, -10.0, -100.0, -700.0, -707.5, -708.39, -720.0, -744.0] {
                let n = t / x.ln();
                let (got, want) = (pow(x, n), x.powf(n));
                let u = ulps(got, want);
                assert!(u <= 3, "{x:e}^{n:e} = {got:e}, libm {want:e}: {u} ulp");
                worst = worst.max(u);
            }
        }
        eprintln!("pow near underflow: at most {worst} ulp");
    }

    #[test]
    fn ln_is_within_one_ulp_and_the_conventions_hold() {
        for &x in &bases() {
            let (_, l) = pow_ln(x, 1.0);
            assert!(
                ulps(l.abs(), x.ln().abs()) <= 1,
                "ln {x:e} = {l:e} vs {:e}",
                x.ln()
            );
        }
        assert_eq!(pow_ln(1.0, 1e300), (1.0, 0.0));
        assert_eq!(pow(1.0, 0.0), 1.0);
        assert_eq!(pow(0.3, 0.0), 1.0);
        assert_eq!(pow(0.5, 2.0), 0.25);
        for x in [0.0, -0.0, -0.5, f64::NAN, f64::NEG_INFINITY] {
            assert_eq!(pow_ln(x, 0.0), (0.0, 0.0), "{x}");
            assert_eq!(pow_ln(x, 3.0), (0.0, 0.0), "{x}");
        }
        assert_eq!(pow(0.5, 1e300), 0.0);
        assert_eq!(pow(5e-324, 1.0), 5e-324);
        let (p, l) = pow_ln(5e-324, 0.0);
        assert!(p == 1.0 && (l - (5e-324f64).ln()).abs() < 1e-13);
        assert!(pow(1.0 + f64::EPSILON, 1e300).is_finite());
    }
}
