//! Loss functions: a per-cell transform t of the BRDF value, compared in weighted
//! root-mean-square over the valid cells.
//!
//! For cell k with measured value f̂ₖ, model value fₖ, cos θi = cₖ and weight wₖ, the
//! loss of one channel is
//!
//! ```text
//! L = sqrt( Σₖ wₖ (t(fₖ, cₖ) − t(f̂ₖ, cₖ))² / Σₖ wₖ )
//! ```
//!
//! and the overall loss is the root of the mean of the three channels' squares. The
//! transforms:
//!
//! | loss     | t(f, c)          | source                                              |
//! |----------|------------------|-----------------------------------------------------|
//! | `l2`     | f                | plain least squares on the BRDF value              |
//! | `cosine` | f · c            | Ngan, Durand & Matusik, EGSR 2005 (cosine-weighted) |
//! | `cbrt`   | ∛(f · c)         | perceptual (CIE L* is a cube root of luminance)     |
//! | `log`    | ln(1 + f · c)    | Löw, Kronander, Ynnerman & Unger, ACM TOG 2012      |
//!
//! The weight is the cell's measure of (wi, wo) pairs ([`Weighting::SolidAngle`]) or 1
//! ([`Weighting::Uniform`]).
//!
//! # The cube root's infinite slope at 0
//! d∛x/dx = 1 / (3 x^(2/3)) is infinite at x = 0, which a model that is exactly 0 in a
//! cell (a mirror-sharp lobe far from its peak, or a below-horizon direction) reaches.
//! The Jacobian uses the slope at max(|x|, [`CBRT_FLOOR`]) instead: finite, and equal to
//! the true slope wherever |f · c| ≥ 1e-12 sr⁻¹ (eight orders below the dimmest
//! measured MERL value). The value itself is never altered.

use brdfkit_core::lanes::{Run, dispatch};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Below this |f · c| (1/sr) the cube root's slope is taken at the floor; see the
/// module doc.
pub const CBRT_FLOOR: f64 = 1e-12;

/// ∛[`CBRT_FLOOR`].
const CBRT_FLOOR_CBRT: f64 = 1e-4;

/// ∛x for finite x, to within 2 ulp, without a library call.
///
/// The standard `f64::cbrt` is a software routine (measured ≈ 30 ns a call here, a
/// quarter of a normal-equation pass on a MERL table; this one ≈ 6 ns in a loop, and
/// a fraction of that in [`cbrt_all`]'s vectorised loop).
/// It takes the classic bit-level first guess — the exponent divided by three through
/// the integer representation, with Kahan's bias constant, ≈ 3 % off — and three
/// Halley steps t ← t (t³ + 2a)/(2t³ + a), which converge cubically (relative error
/// 3e-2 → 3e-5 → 3e-14 → round-off). Zero and subnormal inputs (|x| < 2⁻¹⁰²², where
/// the guess is poor), NaN and ∞ take `f64::cbrt`. Accuracy: within 2 ulp of
/// `f64::cbrt` (tested from 1e-300 to 1e300).
#[inline]
pub fn cbrt(x: f64) -> f64 {
    if !cbrt_fast_domain(x) {
        // 0, subnormals, NaN, ∞.
        return x.cbrt();
    }
    cbrt_normal(x)
}

/// Whether [`cbrt_normal`] applies: |x| normal and finite.
#[inline(always)]
fn cbrt_fast_domain(x: f64) -> bool {
    let a = x.abs();
    (f64::MIN_POSITIVE..f64::INFINITY).contains(&a)
}

/// [`cbrt`]'s guess and Halley steps, without the branch (garbage outside
/// [`cbrt_fast_domain`]): integer and IEEE operations only, so a loop of it vectorises
/// and gives the same bits in every lane.
#[inline(always)]
fn cbrt_normal(x: f64) -> f64 {
    let a = x.abs();
    let mut t = f64::from_bits(a.to_bits() / 3 + 0x2A9F_7893_782D_A1CE);
    for _ in 0..3 {
        let t3 = t * t * t;
        t *= (t3 + 2.0 * a) / (2.0 * t3 + a);
    }
    t.copysign(x)
}

/// [`cbrt`] of every element in place, the same bits, vectorised.
///
/// The branch of [`cbrt`] becomes a blend: the loop ([`brdfkit_core::lanes`]) keeps
/// an input outside the fast domain as it is (its root would be garbage; for ±0 the
/// input is the root) and counts the others (subnormal, NaN, ∞), which a scalar pass
/// then gives `f64::cbrt` only when there is one; the root of an input in the domain
/// is itself normal and finite, so that pass finds exactly the kept inputs. The u64
/// division by 3 of the guess is a multiply-high, which the vector units do.
pub fn cbrt_all(x: &mut [f64]) {
    struct Roots<'a>(&'a mut [f64], usize);
    impl Run for Roots<'_> {
        #[inline(always)]
        fn run(&mut self) {
            let mut odd = 0;
            for v in self.0.iter_mut() {
                let r = cbrt_normal(*v);
                let fast = cbrt_fast_domain(*v);
                odd += usize::from(!fast && *v != 0.0);
                *v = if fast { r } else { *v };
            }
            self.1 = odd;
        }
    }
    let mut roots = Roots(x, 0);
    dispatch(&mut roots);
    if roots.1 > 0 {
        for v in x.iter_mut().filter(|v| !cbrt_fast_domain(**v)) {
            *v = v.cbrt();
        }
    }
}

/// Σₖ wₖ rₖ² as eight interleaved partial sums (cell k into sum k mod 8) added
/// pairwise at the end: a fixed order, hence the same bits with any vector width and
/// any thread count, without the serial chain of additions (one add's latency a cell)
/// of a running sum.
pub fn weighted_sq_sum(w: &[f64], r: &[f64]) -> f64 {
    let (w, r) = (&w[..r.len()], r);
    let (wc, wt) = w.as_chunks::<8>();
    let (rc, rt) = r.as_chunks::<8>();
    let mut p = [0.0f64; 8];
    for (w8, r8) in wc.iter().zip(rc) {
        for j in 0..8 {
            p[j] += w8[j] * r8[j] * r8[j];
        }
    }
    for (j, (w, r)) in wt.iter().zip(rt).enumerate() {
        p[j] += w * r * r;
    }
    Lanes8(p).total()
}

/// The eight interleaved partial sums of [`weighted_sq_sum`] fed one term at a time,
/// for a pass that meets a run's terms one by one (the report's bands): term k of the
/// run goes to lane k mod 8, and [`Lanes8::total`] adds the lanes in the same pairwise
/// order, so the sum has the same bits as `weighted_sq_sum` over the run.
#[derive(Clone, Copy, Debug, Default)]
pub struct Lanes8([f64; 8]);

impl Lanes8 {
    /// Adds term `x` at position `k` of its run.
    #[inline]
    pub fn add(&mut self, k: usize, x: f64) {
        self.0[k & 7] += x;
    }

    /// The lanes added pairwise.
    #[inline]
    pub fn total(&self) -> f64 {
        let p = &self.0;
        ((p[0] + p[1]) + (p[2] + p[3])) + ((p[4] + p[5]) + (p[6] + p[7]))
    }
}

/// One channel's cells as [`own_loss_sums`] reads them, all of one length: the
/// weights w, the model's values f, the measured values f̂, cos θi, and the measured
/// cube roots ∛(f̂ cos θi) ([`Loss::transform_all`] of [`Loss::Cbrt`]).
#[derive(Clone, Copy, Debug)]
pub struct OwnLossCells<'a> {
    /// Weights.
    pub w: &'a [f64],
    /// The model's values.
    pub model: &'a [f64],
    /// The measured values.
    pub measured: &'a [f64],
    /// cos θi.
    pub cos_i: &'a [f64],
    /// ∛(f̂ cos θi).
    pub roots: &'a [f64],
}

/// Buffers of [`own_loss_sums`], grown to the run's length on use.
#[derive(Clone, Debug, Default)]
pub struct OwnLossScratch {
    /// w r² of each loss and cell.
    terms: [Vec<f64>; 4],
    /// The cosine residuals x − x̂ (x = f cos θi), when kept.
    pub cosine: Vec<f64>,
    /// The log residuals ln(1 + (x − x̂)/(1 + x̂)), when kept.
    pub log: Vec<f64>,
}

/// Σ w r² of brdfkit's four own losses (l2, cosine, cbrt, log, in [`Loss::ALL`]'s
/// order) of one channel's cells, each with the bits of [`weighted_sq_sum`] over that
/// loss's residuals as [`Loss::transform`] forms them: r = f − f̂, x − x̂ with
/// x = f cos θi, ∛x − ∛x̂, and ln(1 + (x − x̂)/(1 + x̂)) (= ln(1 + x) − ln(1 + x̂), one
/// logarithm, accurate when the two are close).
///
/// One loop computes the four terms w r² of a cell (with [`cbrt_all`]'s and
/// [`ln_1p_all`]'s branch-free arithmetic, in vector lanes, [`brdfkit_core::lanes`]),
/// and a second adds them into [`weighted_sq_sum`]'s eight interleaved sums, in its
/// order: two passes over the run where one per loss, per transform and per sum took
/// nine. A model value whose cube root is outside the fast domain (0 excepted:
/// subnormal, NaN, ∞) gets `f64::cbrt`, as in [`cbrt_all`]. With `keep`, the cosine
/// and log residuals are left in [`OwnLossScratch::cosine`] and
/// [`OwnLossScratch::log`] (the published metrics reuse them).
pub fn own_loss_sums(cells: OwnLossCells<'_>, sc: &mut OwnLossScratch, keep: bool) -> [f64; 4] {
    let n = cells.w.len();
    for v in sc.terms.iter_mut() {
        v.resize(n, 0.0);
    }
    let odd = if keep {
        sc.cosine.resize(n, 0.0);
        sc.log.resize(n, 0.0);
        let mut run = OwnTerms::<true> {
            cells,
            terms: &mut sc.terms,
            res: [&mut sc.cosine, &mut sc.log],
            odd: 0,
        };
        dispatch(&mut run);
        run.odd
    } else {
        let mut run = OwnTerms::<false> {
            cells,
            terms: &mut sc.terms,
            res: [&mut [], &mut []],
            odd: 0,
        };
        dispatch(&mut run);
        run.odd
    };
    if odd > 0 {
        for (k, t) in sc.terms[2].iter_mut().enumerate() {
            let x = cells.model[k] * cells.cos_i[k];
            if !cbrt_fast_domain(x) {
                let r = cbrt(x) - cells.roots[k];
                *t = cells.w[k] * r * r;
            }
        }
    }
    let mut sums = [Lanes8::default(); 4];
    dispatch(&mut LaneSums {
        terms: &sc.terms,
        sums: &mut sums,
    });
    sums.map(|s| s.total())
}

/// The first loop of [`own_loss_sums`]; `KEEP`: the residuals kept.
struct OwnTerms<'a, const KEEP: bool> {
    cells: OwnLossCells<'a>,
    terms: &'a mut [Vec<f64>; 4],
    res: [&'a mut [f64]; 2],
    /// Cells whose model cube root is outside the fast domain (and not 0).
    odd: usize,
}

impl<const KEEP: bool> Run for OwnTerms<'_, KEEP> {
    #[inline(always)]
    fn run(&mut self) {
        let c = self.cells;
        let n = c.w.len();
        let (w, f, fm, ci, rt) = (
            c.w,
            &c.model[..n],
            &c.measured[..n],
            &c.cos_i[..n],
            &c.roots[..n],
        );
        let [t0, t1, t2, t3] = self.terms.each_mut().map(|t| &mut t[..n]);
        let mut odd = 0;
        for k in 0..n {
            let r0 = f[k] - fm[k];
            let (x, xt) = (f[k] * ci[k], fm[k] * ci[k]);
            let r1 = x - xt;
            let fast = cbrt_fast_domain(x);
            odd += usize::from(!fast && x != 0.0);
            let r2 = if fast { cbrt_normal(x) } else { x } - rt[k];
            let r3 = ln_1p((x - xt) / (1.0 + xt));
            t0[k] = w[k] * r0 * r0;
            t1[k] = w[k] * r1 * r1;
            t2[k] = w[k] * r2 * r2;
            t3[k] = w[k] * r3 * r3;
            if KEEP {
                self.res[0][k] = r1;
                self.res[1][k] = r3;
            }
        }
        self.odd = odd;
    }
}

/// The second loop of [`own_loss_sums`]: term k of each column into lane k mod 8
/// ([`weighted_sq_sum`]'s order).
struct LaneSums<'a> {
    terms: &'a [Vec<f64>; 4],
    sums: &'a mut [Lanes8; 4],
}

impl Run for LaneSums<'_> {
    #[inline(always)]
    fn run(&mut self) {
        for (t, s) in self.terms.iter().zip(self.sums.iter_mut()) {
            let (blocks, tail) = t.as_chunks::<8>();
            let mut p = [0.0f64; 8];
            for b in blocks {
                for j in 0..8 {
                    p[j] += b[j];
                }
            }
            for (j, x) in tail.iter().enumerate() {
                p[j] += x;
            }
            *s = Lanes8(p);
        }
    }
}

/// ln(1 + x), within 1 ulp of the correctly rounded value, without a library call and
/// without branches, so that a loop of it vectorises ([`ln_1p_all`]).
///
/// The algorithm of FreeBSD's `s_log1p.c` (Sun Microsystems' fdlibm, 1993; as musl
/// carries it): 1 + x = 2ᵏ (1 + f) with √2/2 ≤ 1 + f < √2, a correction
/// c ≈ ln(1 + x) − ln(fl(1 + x)) for the rounding of 1 + x, then
/// ln(1 + f) = f − f²/2 + s (f²/2 + R(s²)) with s = f/(2 + f) and R the fdlibm
/// minimax polynomial (|error| < 2⁻⁵⁸·⁴⁵), and k ln 2 in two parts. x close enough to
/// 0 (√2/2 − 1 ≤ x < √2 − 1) takes k = 0, f = x, c = 0 directly. Each of fdlibm's
/// branches is a select here: |x| < 2⁻⁵³ gives x, NaN and +∞ give x, −1 gives −∞,
/// below −1 NaN. The libm `ln_1p` is a scalar call in every lane of a loop; this one
/// vectorises. Within 2 ulp of `f64::ln_1p` (tested).
#[inline(always)]
pub fn ln_1p(x: f64) -> f64 {
    // fdlibm's constants, by their bits: ln 2 in two parts, and Lg1 … Lg7.
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    const LG: [f64; 7] = [
        f64::from_bits(0x3fe5_5555_5555_5593),
        f64::from_bits(0x3fd9_9999_9997_fa04),
        f64::from_bits(0x3fd2_4924_9422_9359),
        f64::from_bits(0x3fcc_71c5_1d8e_78af),
        f64::from_bits(0x3fc7_4664_96cb_03de),
        f64::from_bits(0x3fc3_9a09_d078_c69f),
        f64::from_bits(0x3fc2_f112_df3e_5244),
    ];
    let hx = (x.to_bits() >> 32) as u32;
    // 1 + x near 1: no reduction (fdlibm's k = 0 case).
    let near = (hx < 0x3fda_827a || hx >> 31 != 0) && hx <= 0xbfd2_bec4;
    // The reduction of u = fl(1 + x) into [√2/2, √2).
    let u = 1.0 + x;
    let ub = u.to_bits();
    let hu = ((ub >> 32) as u32).wrapping_add(0x3ff0_0000 - 0x3fe6_a09e);
    let k = (hu >> 20) as i32 - 0x3ff;
    let c = if k >= 2 { 1.0 - (u - x) } else { x - (u - 1.0) } / u;
    let c = if k < 54 { c } else { 0.0 };
    let ur =
        f64::from_bits(((((hu & 0x000f_ffff) + 0x3fe6_a09e) as u64) << 32) | (ub & 0xffff_ffff));
    let (f, c, dk) = if near {
        (x, 0.0, 0.0)
    } else {
        (ur - 1.0, c, k as f64)
    };
    let hfsq = 0.5 * f * f;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG[1] + w * (LG[3] + w * LG[5]));
    let t2 = z * (LG[0] + w * (LG[2] + w * (LG[4] + w * LG[6])));
    let r = s * (hfsq + (t2 + t1)) + (dk * LN2_LO + c) - hfsq + f + dk * LN2_HI;
    // fdlibm's early returns.
    let r = if (hx << 1) < (0x3ca0_0000 << 1) || (hx >= 0x7ff0_0000 && hx >> 31 == 0) {
        x
    } else {
        r
    };
    if x > -1.0 {
        r
    } else if x == -1.0 {
        f64::NEG_INFINITY
    } else if x.is_nan() {
        x
    } else {
        f64::NAN
    }
}

/// [`ln_1p`] of every element in place (the same bits), vectorised
/// ([`brdfkit_core::lanes`]).
pub fn ln_1p_all(x: &mut [f64]) {
    struct Logs<'a>(&'a mut [f64]);
    impl Run for Logs<'_> {
        #[inline(always)]
        fn run(&mut self) {
            for v in self.0.iter_mut() {
                *v = ln_1p(*v);
            }
        }
    }
    dispatch(&mut Logs(x));
}

/// The comparison a fit minimises.
///
/// The first four are brdfkit's own; the last four are the published fitting metrics
/// (see [`Loss::PUBLISHED`] and `docs/fitting.md`, "Published metrics"): each is one
/// of the transforms t above with a per-cell weight factor g(θi, θo) multiplying the
/// cell's measure, so every one is a weighted least-squares problem
/// Σ w g (t(f) − t(f̂))², fitted by the same solvers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Loss {
    /// t = f.
    L2,
    /// t = f cos θi (Ngan et al. 2005's transform, without their cutoff).
    Cosine,
    /// t = ∛(f cos θi); the default.
    #[default]
    Cbrt,
    /// t = ln(1 + f cos θi) (Löw et al. 2012's transform, brdfkit's weighting); also
    /// the BBM benchmark's `standardLog`, accepted as `bbm-log`.
    Log,
    /// Ngan, Durand & Matusik 2005: t = f cos θi, cells with θi or θo > 80° dropped.
    Ngan,
    /// Löw, Kronander, Ynnerman & Unger 2012, E1: t = f cos θi over dωi dθo.
    #[serde(alias = "low_e1")]
    LowE1,
    /// Löw et al. 2012, E2: t = ln(1 + f cos θi) over dωi dθo.
    #[serde(alias = "low_e2")]
    LowE2,
    /// Bieron & Peers 2020: t = ln(1 + f cos θi), weighted by cos θo.
    #[serde(alias = "bieron_log")]
    BieronLog,
}

/// θi and θo limit of Ngan et al. 2005 (they drop measurements beyond 80°).
pub const NGAN_THETA_MAX_DEG: f64 = 80.0;

/// Floor of sin θo in the Löw et al. weight 1 / sin θo: sin 0.5°, half the finest
/// angular step of a 90 × 90 × 180 MERL grid (so a cell's weight never exceeds that of
/// a cell half a step away from θo = 0).
pub const LOW_SIN_FLOOR: f64 = 0.008_726_535_498_373_935;

impl Loss {
    /// brdfkit's own losses, in record order (the four of every [`LossReport`]'s first
    /// block).
    pub const ALL: [Loss; 4] = [Loss::L2, Loss::Cosine, Loss::Cbrt, Loss::Log];

    /// The published metrics: a transform and a weight factor on the cell measure.
    ///
    /// | metric | t(f, cos θi) | g(θi, θo) | source |
    /// |--------|--------------|-----------|--------|
    /// | `ngan` | f cos θi | 1 if θi, θo ≤ 80°, else 0 | Ngan, Durand & Matusik, "Experimental Analysis of BRDF Models", EGSR 2005, §4 |
    /// | `low-e1` | f cos θi | 1 / sin θo | Löw, Kronander, Ynnerman & Unger, "BRDF Models for Accurate and Efficient Rendering of Glossy Surfaces", ACM TOG 31(1), 2012, §6 (E1) |
    /// | `low-e2` | ln(1 + f cos θi) | 1 / sin θo | the same, E2 |
    /// | `bieron-log` | ln(1 + f cos θi) | cos θo | Bieron & Peers, "An Adaptive BRDF Fitting Metric", CGF 39(4), 2020 |
    ///
    /// The cell measure w is that of dωi dωo (sin θi sin θo dθi dφi dθo dφo). Löw et al.
    /// sample (θi, φi, θo) uniformly with φo fixed (their metric is an integral over
    /// dωi dθo), so their weight is w / sin θo; sin θo is floored at [`LOW_SIN_FLOOR`]
    /// (a cell with θo = 0 has an integrable but infinite density). Bieron & Peers sample
    /// both hemispheres and weight by cos θo (the foreshortening of the viewer). The
    /// transcriptions follow the BBM benchmark's `include/loss/cosine_weighted_{l2,log}.h`
    /// (`nganL2_error`, `lowL2_error`, `lowLog_error`, `bieronLog_error`); the reading is
    /// argued in `docs/fitting.md`.
    ///
    /// In record order.
    pub const PUBLISHED: [Loss; 4] = [Loss::Ngan, Loss::LowE1, Loss::LowE2, Loss::BieronLog];

    /// Every loss: [`ALL`](Self::ALL) then [`PUBLISHED`](Self::PUBLISHED).
    pub const EVERY: [Loss; 8] = [
        Loss::L2,
        Loss::Cosine,
        Loss::Cbrt,
        Loss::Log,
        Loss::Ngan,
        Loss::LowE1,
        Loss::LowE2,
        Loss::BieronLog,
    ];

    /// The name used on the command line and in records.
    pub fn name(&self) -> &'static str {
        match self {
            Loss::L2 => "l2",
            Loss::Cosine => "cosine",
            Loss::Cbrt => "cbrt",
            Loss::Log => "log",
            Loss::Ngan => "ngan",
            Loss::LowE1 => "low-e1",
            Loss::LowE2 => "low-e2",
            Loss::BieronLog => "bieron-log",
        }
    }

    /// The name with underscores for dashes (`low_e1`: how a Python keyword or key
    /// spells it), accepted wherever the name is.
    pub fn underscored(&self) -> &'static str {
        match self {
            Loss::LowE1 => "low_e1",
            Loss::LowE2 => "low_e2",
            Loss::BieronLog => "bieron_log",
            l => l.name(),
        }
    }

    /// The transform of a published metric's residual: the brdfkit loss whose t it
    /// uses (`self` for brdfkit's own).
    #[inline]
    pub fn base(&self) -> Loss {
        match self {
            Loss::Ngan | Loss::LowE1 => Loss::Cosine,
            Loss::LowE2 | Loss::BieronLog => Loss::Log,
            l => *l,
        }
    }

    /// True when the loss multiplies the cell measure by a factor g(θi, θo) ≠ 1.
    #[inline]
    pub fn has_cell_factor(&self) -> bool {
        self.base() != *self
    }

    /// The weight factor g of a cell with direction cosines `cos_i`, `cos_o` (see
    /// [`Loss::PUBLISHED`]); 1 for brdfkit's own losses.
    #[inline]
    pub fn cell_factor(&self, cos_i: f64, cos_o: f64) -> f64 {
        match self {
            Loss::Ngan => {
                let c = NGAN_THETA_MAX_DEG.to_radians().cos();
                if cos_i >= c && cos_o >= c { 1.0 } else { 0.0 }
            }
            Loss::LowE1 | Loss::LowE2 => {
                let s = (1.0 - cos_o * cos_o).max(0.0).sqrt();
                1.0 / s.max(LOW_SIN_FLOOR)
            }
            Loss::BieronLog => cos_o.max(0.0),
            _ => 1.0,
        }
    }

    /// t(f, c).
    #[inline]
    pub fn transform(&self, f: f64, cos_i: f64) -> f64 {
        match self.base() {
            Loss::L2 => f,
            Loss::Cosine => f * cos_i,
            Loss::Cbrt => cbrt(f * cos_i),
            _ => ln_1p(f * cos_i),
        }
    }

    /// t(f, c) and ∂t/∂f (with the cube-root guard of the module doc).
    #[inline]
    pub fn transform_deriv(&self, f: f64, cos_i: f64) -> (f64, f64) {
        match self.base() {
            Loss::L2 => (f, 1.0),
            Loss::Cosine => (f * cos_i, cos_i),
            Loss::Cbrt => {
                let x = f * cos_i;
                let t = cbrt(x);
                // 1/(3 x^(2/3)) = 1/(3 t²), with |x| floored (see CBRT_FLOOR).
                let tf = if x.abs() >= CBRT_FLOOR {
                    t
                } else {
                    CBRT_FLOOR_CBRT
                };
                (t, cos_i / (3.0 * tf * tf))
            }
            _ => {
                let x = f * cos_i;
                // A model is ≥ 0, so 1 + x ≥ 1; no pole.
                (ln_1p(x), cos_i / (1.0 + x))
            }
        }
    }

    /// t(f, c) of every cell, the bits of [`transform`](Self::transform), with the cube
    /// roots and logarithms vectorised ([`cbrt_all`], [`ln_1p_all`]): `t` holds f on entry and t(f, c) on return.
    pub fn transform_all(&self, cos_i: &[f64], t: &mut [f64]) {
        let cos_i = &cos_i[..t.len()];
        match self.base() {
            Loss::L2 => {}
            Loss::Cosine => mul_assign(t, cos_i),
            Loss::Cbrt => {
                mul_assign(t, cos_i);
                cbrt_all(t);
            }
            _ => {
                mul_assign(t, cos_i);
                ln_1p_all(t);
            }
        }
    }

    /// [`transform_deriv`](Self::transform_deriv) of every cell, the same bits: `t`
    /// holds f on entry and t(f, c) on return, `d` receives ∂t/∂f.
    #[inline(always)]
    pub fn transform_deriv_all(&self, cos_i: &[f64], t: &mut [f64], d: &mut [f64]) {
        let n = t.len();
        let (cos_i, d) = (&cos_i[..n], &mut d[..n]);
        match self.base() {
            Loss::L2 => d.fill(1.0),
            Loss::Cosine => {
                mul_assign(t, cos_i);
                d.copy_from_slice(cos_i);
            }
            Loss::Cbrt => {
                // x = f c kept in d for the floor's test, then replaced by the slope.
                mul_assign(t, cos_i);
                d.copy_from_slice(t);
                cbrt_all(t);
                for k in 0..n {
                    let tf = if d[k].abs() >= CBRT_FLOOR {
                        t[k]
                    } else {
                        CBRT_FLOOR_CBRT
                    };
                    d[k] = cos_i[k] / (3.0 * tf * tf);
                }
            }
            _ => {
                for k in 0..n {
                    t[k] *= cos_i[k];
                    d[k] = cos_i[k] / (1.0 + t[k]);
                }
                ln_1p_all(t);
            }
        }
    }
}

/// `a[k] ← a[k] · b[k]`.
#[inline]
fn mul_assign(a: &mut [f64], b: &[f64]) {
    for (x, y) in a.iter_mut().zip(b) {
        *x *= y;
    }
}

impl fmt::Display for Loss {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A loss name is accepted with dashes or underscores (`low-e1`, `low_e1`: the
/// second is how Python spells a key), and printed with dashes ([`Loss::name`]).
impl FromStr for Loss {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let name = s.replace('_', "-");
        // BBM's `standardLog` is brdfkit's `log` (see `docs/fitting.md`).
        if name == "bbm-log" {
            return Ok(Loss::Log);
        }
        Loss::EVERY
            .into_iter()
            .find(|l| l.name() == name)
            .ok_or_else(|| {
                format!(
                    "unknown loss `{s}` (known: {}, bbm-log)",
                    Loss::EVERY.map(|l| l.name()).join(", ")
                )
            })
    }
}

/// The robust function of a fit: how a residual's square enters the cost.
///
/// With the per-cell residual e = t(f, c) − t(f̂, c) (in the units of the loss's
/// transform t) and the cell's weight factor s² = w / (n_ch Σ w), a fit minimises
///
/// ```text
/// F = ½ Σ s² ρ(e²)
/// ```
///
/// with ρ(z) = z for [`RobustKind::None`] (ordinary least squares) and, for a scale c > 0,
///
/// | kind | ρ(z) | ρ'(z) (the IRLS weight) | source |
/// |------|------|--------------------------|--------|
/// | `huber` | z for z ≤ c², 2c√z − c² above | 1, then c/√z | P. J. Huber, "Robust Estimation of a Location Parameter", Ann. Math. Statist. 35(1), 1964 |
/// | `cauchy` | c² ln(1 + z/c²) | 1/(1 + z/c²) | Triggs, McLauchlan, Hartley & Fitzgibbon, "Bundle Adjustment — A Modern Synthesis", 2000, §4.3 |
///
/// Both equal z to first order for |e| ≪ c; Huber grows linearly in |e| beyond c (a
/// bounded influence ψ = ρ' e = c sign e), Cauchy logarithmically (ψ → 0: a gross
/// outlier's pull vanishes). How they enter the solvers is in [`crate::problem`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum RobustKind {
    /// ρ(z) = z: ordinary (weighted) least squares. The default.
    #[default]
    None,
    /// Huber's ρ: quadratic within c, linear beyond.
    Huber,
    /// The Cauchy (Lorentzian) ρ: c² ln(1 + z/c²).
    Cauchy,
}

impl RobustKind {
    /// Every kind.
    pub const ALL: [RobustKind; 3] = [RobustKind::None, RobustKind::Huber, RobustKind::Cauchy];

    /// The name on the command line and in records.
    pub fn name(&self) -> &'static str {
        match self {
            RobustKind::None => "none",
            RobustKind::Huber => "huber",
            RobustKind::Cauchy => "cauchy",
        }
    }

    /// The tuning constant k of the automatic scale c = k · σ̂ (σ̂ a robust estimate of
    /// the residuals' standard deviation): the constants that give 95 % asymptotic
    /// efficiency under Gaussian residuals (Huber: 1.345; Cauchy: 2.385; P. W. Holland
    /// & R. E. Welsch, "Robust regression using iteratively reweighted least-squares",
    /// Commun. Statist. A6(9), 1977). 0 for `None`.
    pub fn tuning(&self) -> f64 {
        match self {
            RobustKind::None => 0.0,
            RobustKind::Huber => 1.345,
            RobustKind::Cauchy => 2.385,
        }
    }
}

impl fmt::Display for RobustKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for RobustKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        RobustKind::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| format!("unknown robust loss `{s}` (known: none, huber, cauchy)"))
    }
}

/// A robust function with its scale c (in the units of the residual e; see
/// [`RobustKind`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Robust {
    /// Which ρ.
    pub kind: RobustKind,
    /// c > 0.
    pub scale: f64,
}

impl Robust {
    /// (ρ(z), ρ'(z)) at z = e² ≥ 0 (see [`RobustKind`] for the formulas).
    #[inline]
    pub fn rho(&self, z: f64) -> (f64, f64) {
        let c = self.scale;
        let c2 = c * c;
        match self.kind {
            RobustKind::None => (z, 1.0),
            RobustKind::Huber => {
                if z <= c2 {
                    (z, 1.0)
                } else {
                    let a = z.sqrt();
                    (2.0 * c * a - c2, c / a)
                }
            }
            RobustKind::Cauchy => {
                let q = z / c2;
                (c2 * q.ln_1p(), 1.0 / (1.0 + q))
            }
        }
    }
}

/// The weight of a cell in the loss.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Weighting {
    /// The cell's measure of (wi, wo) pairs (its bin's solid-angle product): the loss
    /// is then a Riemann sum of the integral over pairs of directions, independent of
    /// the grid's non-uniform θh spacing. The default.
    #[default]
    SolidAngle,
    /// Every cell counts the same (the table's own sampling density: dense near the
    /// specular peak, where MERL's θh spacing is fine).
    Uniform,
}

impl Weighting {
    /// The name used on the command line and in records.
    pub fn name(&self) -> &'static str {
        match self {
            Weighting::SolidAngle => "solid-angle",
            Weighting::Uniform => "uniform",
        }
    }
}

impl FromStr for Weighting {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "solid-angle" => Ok(Weighting::SolidAngle),
            "uniform" => Ok(Weighting::Uniform),
            _ => Err(format!(
                "unknown weighting `{s}` (known: solid-angle, uniform)"
            )),
        }
    }
}

/// Which losses a fit's loss report computes ([`crate::FitConfig::report_losses`],
/// `--losses`). brdfkit's own four (l2, cosine, cbrt, log) always; the four published
/// metrics ([`Loss::PUBLISHED`]) when asked, or when one of them is the optimised
/// loss. A score always computes all eight ([`crate::score()`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum LossSet {
    /// brdfkit's own four (the command line's default).
    Own,
    /// All eight (the library's default).
    #[default]
    All,
}

impl LossSet {
    /// Every set.
    pub const ALL: [LossSet; 2] = [LossSet::Own, LossSet::All];

    /// The name on the command line and in configs.
    pub fn name(&self) -> &'static str {
        match self {
            LossSet::Own => "own",
            LossSet::All => "all",
        }
    }
}

impl FromStr for LossSet {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "own" => Ok(LossSet::Own),
            "all" => Ok(LossSet::All),
            _ => Err(format!("unknown loss set `{s}` (known: own, all)")),
        }
    }
}

/// One loss's weighted RMS per channel and overall.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct ChannelLoss {
    /// Red, green, blue.
    pub channels: [f64; 3],
    /// sqrt of the mean of the channels' squares.
    pub overall: f64,
}

/// Every loss of a model against a cell set (see [`crate::evaluate_losses`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LossReport {
    /// Plain squared error.
    pub l2: ChannelLoss,
    /// Squared error of f·cos θi.
    pub cosine: ChannelLoss,
    /// Squared error of ∛(f·cos θi) (the default loss).
    pub cbrt: ChannelLoss,
    /// Squared error of ln(1 + f·cos θi).
    pub log: ChannelLoss,
    /// Ngan et al. 2005 (`ngan`; over the cells with θi, θo ≤ 80°). The published
    /// metrics are NaN when not computed ([`LossSet::Own`]; absent from the JSON, and
    /// NaN when read from a record without them: see [`LossReport::has`]).
    #[serde(
        default = "ChannelLoss::unset",
        skip_serializing_if = "ChannelLoss::is_unset"
    )]
    pub ngan: ChannelLoss,
    /// Löw et al. 2012, E1 (`low-e1`).
    #[serde(
        default = "ChannelLoss::unset",
        skip_serializing_if = "ChannelLoss::is_unset",
        rename = "low-e1",
        alias = "low_e1"
    )]
    pub low_e1: ChannelLoss,
    /// Löw et al. 2012, E2 (`low-e2`).
    #[serde(
        default = "ChannelLoss::unset",
        skip_serializing_if = "ChannelLoss::is_unset",
        rename = "low-e2",
        alias = "low_e2"
    )]
    pub low_e2: ChannelLoss,
    /// Bieron & Peers 2020 (`bieron-log`).
    #[serde(
        default = "ChannelLoss::unset",
        skip_serializing_if = "ChannelLoss::is_unset",
        rename = "bieron-log",
        alias = "bieron_log"
    )]
    pub bieron_log: ChannelLoss,
    /// Number of cells the losses were taken over.
    pub cells: usize,
}

impl ChannelLoss {
    /// A loss not computed: NaN everywhere.
    pub fn unset() -> ChannelLoss {
        ChannelLoss {
            channels: [f64::NAN; 3],
            overall: f64::NAN,
        }
    }

    /// Whether this is [`unset`](Self::unset) (a NaN overall).
    pub fn is_unset(&self) -> bool {
        self.overall.is_nan()
    }
}

impl LossReport {
    /// Whether the report has `loss` (the published metrics only when computed).
    pub fn has(&self, loss: Loss) -> bool {
        !self.get(loss).is_unset()
    }

    /// The entry of one loss (NaN for a published metric not computed).
    pub fn get(&self, loss: Loss) -> &ChannelLoss {
        match loss {
            Loss::L2 => &self.l2,
            Loss::Cosine => &self.cosine,
            Loss::Cbrt => &self.cbrt,
            Loss::Log => &self.log,
            Loss::Ngan => &self.ngan,
            Loss::LowE1 => &self.low_e1,
            Loss::LowE2 => &self.low_e2,
            Loss::BieronLog => &self.bieron_log,
        }
    }

    /// From Σ w r² per loss and channel and Σ w, for brdfkit's own losses
    /// ([`Loss::ALL`]) and the published ones ([`Loss::PUBLISHED`], each with its own
    /// Σ w g).
    pub fn from_sums(
        sums: [[f64; 3]; 4],
        wsum: f64,
        published: ([[f64; 3]; 4], [f64; 4]),
        cells: usize,
    ) -> Self {
        Self::from_own_sums(sums, wsum, Some(published), cells)
    }

    /// [`from_sums`](Self::from_sums) with the published metrics optional (`None`:
    /// not computed, [`ChannelLoss::unset`]).
    pub fn from_own_sums(
        sums: [[f64; 3]; 4],
        wsum: f64,
        published: Option<([[f64; 3]; 4], [f64; 4])>,
        cells: usize,
    ) -> Self {
        let mk = |s: [f64; 3], wsum: f64| {
            let ch = s.map(|v| if wsum > 0.0 { (v / wsum).sqrt() } else { 0.0 });
            let overall = ((ch[0] * ch[0] + ch[1] * ch[1] + ch[2] * ch[2]) / 3.0).sqrt();
            ChannelLoss {
                channels: ch,
                overall,
            }
        };
        let p = |l: usize| published.map_or(ChannelLoss::unset(), |(ps, pw)| mk(ps[l], pw[l]));
        LossReport {
            l2: mk(sums[0], wsum),
            cosine: mk(sums[1], wsum),
            cbrt: mk(sums[2], wsum),
            log: mk(sums[3], wsum),
            ngan: p(0),
            low_e1: p(1),
            low_e2: p(2),
            bieron_log: p(3),
            cells,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One vocabulary: a loss is printed with dashes everywhere (its name, the record's
    /// `loss`, the keys of `losses_full`) and read in either spelling.
    #[test]
    fn loss_names_print_one_way_and_read_both() {
        for l in Loss::EVERY {
            assert_eq!(l.name().parse::<Loss>(), Ok(l));
            assert_eq!(l.underscored().parse::<Loss>(), Ok(l));
            assert_eq!(l.underscored(), l.name().replace('-', "_"));
            let json = serde_json::to_value(l).unwrap();
            assert_eq!(json, l.name());
            let snake: Loss = serde_json::from_value(l.underscored().into()).unwrap();
            assert_eq!(snake, l);
        }
        let r = LossReport::from_sums([[1.0; 3]; 4], 1.0, ([[1.0; 3]; 4], [1.0; 4]), 1);
        let v = serde_json::to_value(r).unwrap();
        let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        for l in Loss::EVERY {
            assert!(keys.contains(&l.name()), "{keys:?}");
            assert_eq!(v[l.name()]["overall"], r.get(l).overall);
        }
        // Records written before the keys were spelt with dashes still read.
        let mut old = v.clone();
        let o = old.as_object_mut().unwrap();
        for l in Loss::PUBLISHED {
            let x = o.remove(l.name()).unwrap();
            o.insert(l.underscored().into(), x);
        }
        assert_eq!(serde_json::from_value::<LossReport>(old).unwrap(), r);
        assert!("low_e3".parse::<Loss>().is_err());
    }

    #[test]
    fn derivatives_match_finite_differences() {
        for loss in Loss::EVERY {
            for &(f, c) in &[(0.3, 0.8), (12.0, 0.1), (1e-3, 0.99)] {
                let (t, d) = loss.transform_deriv(f, c);
                assert_eq!(t, loss.transform(f, c));
                let h = 1e-6 * f;
                let fd = (loss.transform(f + h, c) - loss.transform(f - h, c)) / (2.0 * h);
                assert!((fd - d).abs() <= 1e-7 * d.abs(), "{loss}: {fd} vs {d}");
            }
        }
    }

    #[test]
    fn fast_cbrt_is_accurate() {
        let mut worst = 0.0f64;
        let mut x = 1e-300;
        while x < 1e300 {
            for y in [x, -x, x * 1.37, x * 2.9] {
                let a = cbrt(y);
                let b = y.cbrt();
                worst = worst.max(((a - b) / b).abs());
                // The cube of the result gives y back to round-off.
                assert!(((a * a * a - y) / y).abs() < 1e-15, "{y}");
            }
            x *= 7.3;
        }
        assert!(worst <= 4.5e-16, "{worst:e}");
        assert_eq!(cbrt(0.0), 0.0);
        assert_eq!(cbrt(-8.0), -2.0);
        assert_eq!(cbrt(1e-310), 1e-310f64.cbrt());
        assert!(cbrt(f64::NAN).is_nan());
    }

    /// The slice forms give the scalar forms' bits, element by element, on values that
    /// take every path: normal (both signs, every magnitude), zero, subnormal, NaN, ∞,
    /// and x = f cos θi beside the slope's floor.
    #[test]
    fn slice_transforms_are_the_scalar_ones_bit_for_bit() {
        let mut xs = vec![
            0.0,
            -0.0,
            1e-310,
            -4e-320,
            f64::NAN,
            f64::INFINITY,
            -f64::INFINITY,
        ];
        xs.extend([
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::MAX,
            1e-12,
            0.999e-12,
        ]);
        let mut x = 1e-300;
        while x < 1e300 {
            xs.extend([x, -x, x * 1.37, x * 2.9]);
            x *= 1.9;
        }
        // Odd lengths and every offset: the vector loops' remainders.
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(p, q)| p.to_bits() == q.to_bits())
        };
        let mut v = xs.clone();
        cbrt_all(&mut v);
        let scalar: Vec<f64> = xs.iter().map(|&x| cbrt(x)).collect();
        assert!(same(&v, &scalar));
        let cos: Vec<f64> = (0..xs.len())
            .map(|k| [1.0, 0.5, 1e-3, 0.0][k % 4])
            .collect();
        let f: Vec<f64> = xs.iter().map(|x| x.abs()).collect();
        for loss in Loss::EVERY {
            for s in [0, 1, 3] {
                let (f, c) = (&f[s..], &cos[s..]);
                let mut t = f.to_vec();
                loss.transform_all(c, &mut t);
                let t1: Vec<f64> = f
                    .iter()
                    .zip(c)
                    .map(|(&f, &c)| loss.transform(f, c))
                    .collect();
                assert!(same(&t, &t1), "{loss}");
                let (mut t, mut d) = (f.to_vec(), vec![0.0; f.len()]);
                loss.transform_deriv_all(c, &mut t, &mut d);
                let (t2, d2): (Vec<f64>, Vec<f64>) = f
                    .iter()
                    .zip(c)
                    .map(|(&f, &c)| loss.transform_deriv(f, c))
                    .unzip();
                assert!(same(&t, &t2) && same(&d, &d2), "{loss} slopes");
            }
        }
    }

    /// [`ln_1p`] against the libm's: within 2 ulp (each is within 1 of the true value;
    /// 2 is reached beside fdlibm's branch point −0.2929) from −1 + 2⁻⁵³ to 1e300, on tiny and
    /// subnormal arguments, on both sides of fdlibm's branch points, and the special
    /// values.
    #[test]
    fn ln_1p_is_within_two_ulp_of_the_libm_s() {
        let ulp = |y: f64| {
            (y.next_up() - y)
                .abs()
                .max(f64::MIN_POSITIVE * f64::EPSILON)
        };
        let mut xs = vec![0.0, -0.0, 1e-310, -1e-310, 1e-17, -1e-17, 1e-300];
        for b in [0x3fda_827a_u64, 0xbfd2_bec4, 0x3ca0_0000, 0xbca0_0000] {
            let x = f64::from_bits(b << 32);
            xs.extend([x, x.next_up(), x.next_down()]);
        }
        let mut x = 1e-300;
        while x < 1e300 {
            xs.extend([x, x * 1.37, x * 2.9]);
            x *= 1.7;
        }
        let mut y = (-1.0f64).next_up();
        while y < -1e-300 {
            xs.push(y);
            y *= 0.93;
        }
        for &x in &xs {
            let (a, b) = (ln_1p(x), x.ln_1p());
            let e = ((a - b) / ulp(b)).abs();
            assert!(e <= 2.0, "ln_1p({x:e}) = {a:e}, libm {b:e}: {e} ulp");
        }
        assert_eq!(ln_1p(-1.0), f64::NEG_INFINITY);
        assert!(ln_1p(-1.5).is_nan() && ln_1p(f64::NAN).is_nan());
        assert_eq!(ln_1p(f64::INFINITY), f64::INFINITY);
        assert_eq!(ln_1p(1e-310).to_bits(), 1e-310f64.to_bits());
        let mut v = xs.clone();
        ln_1p_all(&mut v);
        assert!(
            v.iter()
                .zip(&xs)
                .all(|(a, &x)| a.to_bits() == ln_1p(x).to_bits() || a.is_nan())
        );
    }

    /// The interleaved sum is Σ w r² (to round-off, against the running sum), on
    /// every length around the eight lanes.
    #[test]
    fn weighted_sq_sum_is_the_sum() {
        for n in [0, 1, 7, 8, 9, 17, 1000] {
            let w: Vec<f64> = (0..n).map(|k| 1.0 + (k % 5) as f64).collect();
            let r: Vec<f64> = (0..n).map(|k| (k as f64 * 0.37).sin()).collect();
            let exact: f64 = w.iter().zip(&r).map(|(w, r)| w * r * r).sum();
            let s = weighted_sq_sum(&w, &r);
            assert!(
                (s - exact).abs() <= 1e-13 * exact.abs(),
                "{n}: {s} vs {exact}"
            );
        }
        assert_eq!(weighted_sq_sum(&[2.0; 9], &[3.0; 9]), 162.0);
        // Term by term through the lanes: the same bits.
        let (w, r): (Vec<f64>, Vec<f64>) = (0..37)
            .map(|k| (0.1 + k as f64 / 7.0, (k as f64).sin()))
            .unzip();
        let mut lanes = Lanes8::default();
        for k in 0..r.len() {
            lanes.add(k, w[k] * r[k] * r[k]);
        }
        assert_eq!(lanes.total().to_bits(), weighted_sq_sum(&w, &r).to_bits());
    }

    /// The fused sums of the four own losses are, bit for bit, `weighted_sq_sum` over
    /// each loss's residuals formed one by one as the report formed them, on runs of
    /// every length around the eight lanes, with model values that are 0, subnormal,
    /// huge, ∞ and NaN (the cube root's slow path), and the kept residuals are those
    /// residuals.
    #[test]
    fn own_loss_sums_are_the_per_loss_sums() {
        let bits = |v: [f64; 4]| v.map(f64::to_bits);
        let mut sc = OwnLossScratch::default();
        for n in [0, 1, 7, 8, 9, 31, 255, 256, 257, 2048, 2049] {
            let w: Vec<f64> = (0..n).map(|k| 0.5 + (k % 7) as f64 * 0.31).collect();
            let ci: Vec<f64> = (0..n).map(|k| (k as f64 * 0.013).cos().abs()).collect();
            let fm: Vec<f64> = (0..n)
                .map(|k| 0.01 + (k as f64 * 0.7).sin().abs())
                .collect();
            for odd in [
                None,
                Some(0.0),
                Some(1e-310),
                Some(f64::INFINITY),
                Some(f64::NAN),
            ] {
                let f: Vec<f64> = (0..n)
                    .map(|k| match odd {
                        Some(x) if k % 5 == 2 => x,
                        _ => fm[k] * (1.0 + 0.1 * (k as f64).cos()),
                    })
                    .collect();
                let mut rt = fm.clone();
                Loss::Cbrt.transform_all(&ci, &mut rt);
                let per = |loss: Loss| -> Vec<f64> {
                    (0..n)
                        .map(|k| loss.transform(f[k], ci[k]) - loss.transform(fm[k], ci[k]))
                        .collect()
                };
                let xt: Vec<f64> = (0..n).map(|k| fm[k] * ci[k]).collect();
                let lg: Vec<f64> = (0..n)
                    .map(|k| ln_1p((f[k] * ci[k] - xt[k]) / (1.0 + xt[k])))
                    .collect();
                let want = [
                    weighted_sq_sum(&w, &per(Loss::L2)),
                    weighted_sq_sum(&w, &per(Loss::Cosine)),
                    weighted_sq_sum(&w, &per(Loss::Cbrt)),
                    weighted_sq_sum(&w, &lg),
                ];
                let cells = OwnLossCells {
                    w: &w,
                    model: &f,
                    measured: &fm,
                    cos_i: &ci,
                    roots: &rt,
                };
                for keep in [false, true] {
                    let got = own_loss_sums(cells, &mut sc, keep);
                    assert_eq!(bits(got), bits(want), "n {n}, {odd:?}, keep {keep}");
                }
                let same = |a: &[f64], b: &[f64]| {
                    a.iter()
                        .zip(b)
                        .all(|(p, q)| p.to_bits() == q.to_bits() || p.is_nan() && q.is_nan())
                };
                assert!(same(&sc.cosine[..n], &per(Loss::Cosine)) && same(&sc.log[..n], &lg));
            }
        }
    }

    #[test]
    fn cbrt_slope_is_finite_at_zero() {
        let (t, d) = Loss::Cbrt.transform_deriv(0.0, 0.5);
        assert_eq!(t, 0.0);
        assert!(d.is_finite() && d > 0.0);
        let (_, d) = Loss::Cbrt.transform_deriv(0.0, 0.0);
        assert_eq!(d, 0.0);
    }

    #[test]
    fn robust_rho_matches_its_formulas_and_derivative() {
        for kind in RobustKind::ALL {
            let r = Robust { kind, scale: 0.3 };
            for &e in &[0.0, 1e-3, 0.1, 0.29, 0.31, 1.0, 30.0] {
                let z = e * e;
                let (v, d) = r.rho(z);
                // Near 0 every ρ is z to first order.
                if e <= 0.1 {
                    assert!((v - z).abs() <= 0.06 * z + 1e-300, "{kind} {e}: {v}");
                }
                // ρ is concave with ρ(0) = 0, so ρ(z) ≥ z ρ'(z), and ρ' ∈ (0, 1].
                assert!(
                    d > 0.0 && d <= 1.0 && v >= z * d * (1.0 - 1e-15),
                    "{kind} {e}"
                );
                if z > 0.0 {
                    let h = 1e-6 * z;
                    let fd = (r.rho(z + h).0 - r.rho(z - h).0) / (2.0 * h);
                    assert!((fd - d).abs() <= 1e-7, "{kind} at {e}: {fd} vs {d}");
                }
            }
        }
        // Closed forms at a point beyond the scale.
        let (h, hd) = Robust {
            kind: RobustKind::Huber,
            scale: 0.5,
        }
        .rho(4.0);
        assert_eq!((h, hd), (2.0 * 0.5 * 2.0 - 0.25, 0.25));
        let (c, cd) = Robust {
            kind: RobustKind::Cauchy,
            scale: 0.5,
        }
        .rho(4.0);
        assert!((c - 0.25 * 17f64.ln()).abs() < 1e-15 && (cd - 1.0 / 17.0).abs() < 1e-15);
        for k in RobustKind::ALL {
            assert_eq!(k.name().parse::<RobustKind>().unwrap(), k);
        }
        assert!("Huber".parse::<RobustKind>().is_err());
    }

    #[test]
    fn names_parse() {
        for l in Loss::ALL {
            assert_eq!(l.name().parse::<Loss>().unwrap(), l);
        }
        assert!("L2".parse::<Loss>().is_err());
        assert_eq!(Loss::default(), Loss::Cbrt);
        assert_eq!(serde_json::to_string(&Loss::Cosine).unwrap(), "\"cosine\"");
    }
}
