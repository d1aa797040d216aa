//! The branch-free kernel of `cook-torrance` with Smith masking and GGX or Beckmann (its
//! exact Λ), in `f64` (the value of every evaluation path of those configurations, and
//! the gradient with Fresnel `none` or `schlick`) and `f32`
//! ([`Model::eval_batch_f32`](brdfkit_core::Model::eval_batch_f32)). The distribution
//! enters only through D and S(v) below; the masking, Fresnel, gradient and loops are
//! one code for both.
//!
//! With s = hx²/αx² + hy²/αy² + hz² and, per direction v, S(v) = √(vz² + αx² vx² + αy² vy²)
//! (= vz √(1 + α² tan²θv); isotropic: √(vz² + α²(vx² + vy²))). Written with vx² + vy²
//! rather than 1 − vz², S scales with v, so V below equals G/(4 cos θi cos θo) also for
//! directions a few ulp off unit length (e.g. read from float32 data), as the textbook
//! form does. The float32 kernel uses 1 − vz² for the isotropic lobe instead: it reads
//! four columns fewer, and its inputs' length error (≤ 6e-8) stays below its round-off.
//!
//! - GGX (Walter et al. 2007, eq. 33; anisotropic: Heitz 2014, eq. 85):
//!   D = 1/(π αx αy s²);
//! - GGX's Smith Λ(v) = (S(v)/vz − 1)/2 (Heitz 2014, eq. 86), so the whole
//!   V = G/(4 cos θi cos θo) is, without any division by a cosine,
//!   separable G1(wi)G1(wo):        V = 1/((zi + Si)(zo + So)),
//!   height-correlated 1/(1 + Λi + Λo): V = 1/(2 (zo Si + zi So));
//! - F at c = cos θd: Schlick f0 + (1 − f0)(1 − c)⁵; the conductor (Möller 1988, as
//!   [`conductor`](brdfkit_core::scattering::fresnel::conductor)) folded into one
//!   division, F = (Rs + Rp)/2 = Rs t3/(t3 + t4) = (t1 − t2) t3/((t1 + t2)(t3 + t4));
//!   the dielectric (Born & Wolf) as F = (r∥² + r⊥²)/2 over one common denominator;
//! - Beckmann (Walter et al. 2007, eq. 25; Heitz 2014, eq. 85), with u = hx²/αx² +
//!   hy²/αy²: D = exp(−u/hz²)/(π αx αy hz⁴), and with a = vz/t(v), t(v) = √(αx² vx² +
//!   αy² vy²) its exact Smith Λ = (erf(a) − 1)/2 + exp(−a²)/(2a√π) (Heitz 2014, eq. 85)
//!   gives S(v) = vz (1 + 2Λ(v)) = vz erf(a) + t exp(−a²)/√π, the same role as GGX's
//!   S(v) = vz (1 + 2Λ(v)), so V takes the two forms above unchanged. S is a sum of two
//!   positive terms (the difference erf(a) − 1 of Λ never formed), finite at grazing
//!   (t/√π at vz = 0), and vz on the normal (t = 0, a = ∞). `exp` and `erf` are the
//!   branch-free [`lanes::exp`](crate::lanes::exp) and [`lanes::erf`](crate::lanes::erf),
//!   in f64 lanes in both precisions;
//! - f_r = ρd/π + ρs D V F, and exactly 0 unless cos θi > 0 and cos θo > 0.
//!
//! The GGX conductor in `f64` is evaluated from the directions' squares with one division
//! for D·V and all three channels' F (`conductor_value`: eight square roots and two
//! divisions per pair, against nine and seven in the form above); in `f32` as above.
//! The same function serves one pair (`eval`) and the loops over a batch, so all paths
//! give the same bits.

use super::{CookTorrance, Fresnel, Shape};
use crate::lanes::{Real, Run, clamp01, dispatch, max, select};
use crate::pair::PairGeom;
use brdfkit_core::geometry::half_and_cos_d;
use brdfkit_core::scattering::{BeckmannG1, Distribution, Masking};
use brdfkit_core::{DirPairs, GeomSlice, GeomSliceOf, Rgb};
use std::f64::consts::{FRAC_1_PI, FRAC_2_SQRT_PI};

const F_NONE: u8 = 0;
const F_SCHLICK: u8 = 1;
const F_CONDUCTOR: u8 = 2;
const F_DIELECTRIC: u8 = 3;

/// The `match` from a runtime [`Config`] to `job.go::<A, C, F, B>()` over the listed
/// arms, each for GGX (B = false) and Beckmann (B = true).
macro_rules! config_arms {
    ($cfg:expr, $job:expr, $why:literal; $($a:literal, $c:literal, $f:ident;)*) => {
        match ($cfg.aniso, $cfg.correlated, $cfg.fresnel, $cfg.beckmann) {
            $(
                ($a, $c, $f, false) => $job.go::<$a, $c, $f, false>(),
                ($a, $c, $f, true) => $job.go::<$a, $c, $f, true>(),
            )*
            _ => unreachable!($why),
        }
    };
}

/// Per-call constants of the kernel, computed in `f64` and rounded once.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Consts<T> {
    inv_ax2: T,
    inv_ay2: T,
    ax2: T,
    ay2: T,
    /// αx, αy and their inverses (gradient only).
    ax: T,
    ay: T,
    inv_ax: T,
    inv_ay: T,
    d_norm: T,
    diff: [T; 3],
    spec: [T; 3],
    /// ρs/(π αx αy) per channel: ρs times D's normalisation, the specular numerator of
    /// [`conductor_value`].
    spec_d: [T; 3],
    /// Schlick: f0. Conductor: η² − k². Dielectric: η in `[0]`.
    fa: [T; 3],
    /// Conductor: 4η²k². Dielectric: 1/η² in `[0]`.
    fb: [T; 3],
}

/// The structural choices the kernel is compiled for.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) struct Config {
    aniso: bool,
    correlated: bool,
    fresnel: u8,
    /// Beckmann with its exact Λ, else GGX.
    beckmann: bool,
}

impl CookTorrance {
    /// The kernel's configuration, or `None` when the model has no branch-free kernel
    /// (the V-cavity, a `min` of quotients, and Walter's rational Beckmann G1, a
    /// different Λ): those use the per-pair code.
    pub(super) fn kernel_config(&self) -> Option<Config> {
        let beckmann = match (self.distribution, self.beckmann_g1) {
            (Distribution::Ggx, _) => false,
            (Distribution::Beckmann, BeckmannG1::Exact) => true,
            (Distribution::Beckmann, BeckmannG1::Rational) => return None,
        };
        let correlated = match self.masking {
            Masking::SmithSeparable => false,
            Masking::SmithCorrelated => true,
            Masking::VCavity => return None,
        };
        let fresnel = match self.fresnel {
            Fresnel::None => F_NONE,
            Fresnel::Schlick { .. } => F_SCHLICK,
            Fresnel::Conductor { .. } => F_CONDUCTOR,
            Fresnel::Dielectric { .. } => F_DIELECTRIC,
        };
        Some(Config {
            aniso: matches!(self.alpha, Shape::Anisotropic(..)),
            correlated,
            fresnel,
            beckmann,
        })
    }

    /// The configuration of the branch-free gradient kernel: a kernel configuration
    /// with Fresnel `none` or `schlick` (polynomial derivatives; the default model, and
    /// the usual fit). The conductor and dielectric keep the per-pair gradient code
    /// (`conductor_grad`, `dielectric_grad`, whose guards branch).
    pub(super) fn kernel_grad_config(&self) -> Option<Config> {
        self.kernel_config()
            .filter(|c| c.fresnel == F_NONE || c.fresnel == F_SCHLICK)
    }

    pub(super) fn kernel_consts<T: Real>(&self) -> Consts<T> {
        let (ax, ay) = self.alpha.xy();
        let (mut fa, mut fb) = ([0.0; 3], [0.0; 3]);
        match self.fresnel {
            Fresnel::None => {}
            Fresnel::Schlick { f0 } => fa = f0.0,
            Fresnel::Conductor { eta, k } => {
                for c in 0..3 {
                    fa[c] = eta[c] * eta[c] - k[c] * k[c];
                    fb[c] = 4.0 * eta[c] * eta[c] * k[c] * k[c];
                }
            }
            Fresnel::Dielectric { eta } => {
                fa[0] = eta;
                fb[0] = 1.0 / (eta * eta);
            }
        }
        let r = |v: [f64; 3]| v.map(T::of);
        Consts {
            inv_ax2: T::of(1.0 / (ax * ax)),
            inv_ay2: T::of(1.0 / (ay * ay)),
            ax2: T::of(ax * ax),
            ay2: T::of(ay * ay),
            ax: T::of(ax),
            ay: T::of(ay),
            inv_ax: T::of(1.0 / ax),
            inv_ay: T::of(1.0 / ay),
            d_norm: T::of(FRAC_1_PI / (ax * ay)),
            diff: r(self.rho_d.0.map(|v| v * FRAC_1_PI)),
            spec: r(self.rho_s.0),
            spec_d: r(self.rho_s.0.map(|v| v * (FRAC_1_PI / (ax * ay)))),
            fa: r(fa),
            fb: r(fb),
        }
    }
}

/// F at cos θd = `cd` per channel (module doc).
#[inline(always)]
fn fresnel<T: Real, const F: u8>(k: &Consts<T>, cd: T) -> [T; 3] {
    let c = clamp01(cd);
    match F {
        F_SCHLICK => {
            let m = T::ONE - c;
            let m2 = m * m;
            let w = m2 * m2 * m;
            k.fa.map(|f0| f0 + (T::ONE - f0) * w)
        }
        F_CONDUCTOR => {
            let c2 = c * c;
            let s2 = T::ONE - c2;
            let s4 = s2 * s2;
            std::array::from_fn(|ch| {
                let t = k.fa[ch] - s2;
                let p = (t * t + k.fb[ch]).sqrt();
                // (p + t)/2 = a² ≥ 0 exactly; round-off can make it a hair negative.
                let a = max(T::HALF * (p + t), T::ZERO).sqrt();
                let t1 = p + c2;
                let t2 = T::TWO * c * a;
                let t3 = p * c2 + s4;
                let t4 = t2 * s2;
                // (t1 + t2)(t3 + t4) = 0 only at c = 0 with p = 0 (k = 0, η = 1: no
                // interface), where the numerator is 0 as well and F = 0 is the limit.
                (t1 - t2) * t3 / max((t1 + t2) * (t3 + t4), T::TINY)
            })
        }
        F_DIELECTRIC => {
            let eta = k.fa[0];
            let sin2_t = (T::ONE - c * c) * k.fb[0];
            let ct = max(T::ONE - sin2_t, T::ZERO).sqrt();
            let (a, b) = (eta * c - ct, eta * c + ct);
            let (p, q) = (c - eta * ct, c + eta * ct);
            let (b2, q2) = (b * b, q * q);
            // b = q = 0 only at c = 0 with η = 1, where total internal reflection
            // (sin²θt = 1) selects F = 1 below.
            let f = T::HALF * (a * a * q2 + p * p * b2) / max(b2 * q2, T::TINY);
            [select(sin2_t >= T::ONE, T::ONE, f); 3]
        }
        _ => [T::ONE; 3],
    }
}

/// sin²θ of a direction as the isotropic lobe takes it (module doc): vx² + vy² in f64,
/// 1 − vz² in f32.
#[inline(always)]
fn sin2<T: Real>(v: [T; 3]) -> T {
    if T::SIN2_FROM_Z {
        T::ONE - v[2] * v[2]
    } else {
        v[0] * v[0] + v[1] * v[1]
    }
}

/// The specular factor DV = D·V of a pair and what its gradient reuses: `s` is GGX's s
/// (module doc) or Beckmann's hz², `si`, `so` are S(wi), S(wo), and `ri`, `ro` (Beckmann
/// only) exp(−a²)/(√π t) of each direction, so that ∂S/∂αx = αx vx² r.
#[derive(Clone, Copy)]
struct Lobe<T> {
    hx2: T,
    hy2: T,
    s: T,
    si: T,
    so: T,
    ri: T,
    ro: T,
    dv: T,
}

/// The masking's denominator: V = 1/vden (module doc), from zi, zo and S(wi), S(wo).
#[inline(always)]
fn vden<T: Real, const C: bool>(zi: T, zo: T, si: T, so: T) -> T {
    if C {
        T::TWO * (zo * si + zi * so)
    } else {
        (zi + si) * (zo + so)
    }
}

/// hx², hy², s, the lobe's denominator L = s² vden (so D·V = d_norm/L, module doc),
/// S(wi) and S(wo) of one pair; `h` is the half vector or, for
/// [`conductor_value`], wi + wo.
#[inline(always)]
fn lobe_den<T: Real, const A: bool, const C: bool>(
    k: &Consts<T>,
    wi: [T; 3],
    wo: [T; 3],
    h: [T; 3],
) -> (T, T, T, T, T, T) {
    let (zi, zo) = (wi[2], wo[2]);
    let (hx2, hy2, hz2) = (h[0] * h[0], h[1] * h[1], h[2] * h[2]);
    let (s, si, so) = if A {
        (
            hx2 * k.inv_ax2 + hy2 * k.inv_ay2 + hz2,
            (zi * zi + k.ax2 * wi[0] * wi[0] + k.ay2 * wi[1] * wi[1]).sqrt(),
            (zo * zo + k.ax2 * wo[0] * wo[0] + k.ay2 * wo[1] * wo[1]).sqrt(),
        )
    } else {
        (
            (hx2 + hy2) * k.inv_ax2 + hz2,
            (zi * zi + k.ax2 * sin2::<T>(wi)).sqrt(),
            (zo * zo + k.ax2 * sin2::<T>(wo)).sqrt(),
        )
    };
    (hx2, hy2, s, s * s * vden::<T, C>(zi, zo, si, so), si, so)
}

/// D·V of one pair (module doc), GGX or (`B`) Beckmann, shared by the value and the
/// gradient kernels so both give the same bits.
///
/// Beckmann's is 0 where exp(−u/hz²) underflows, as
/// [`beckmann_grad`](brdfkit_core::scattering::microfacet::beckmann_grad) (1/hz⁴ alone
/// could overflow there). Where it does not, hz² > u/746 ≥ 1.3e-7 over the roughness
/// domain, so hz⁴ stays normal.
#[inline(always)]
fn lobe<T: Real, const A: bool, const C: bool, const B: bool>(
    k: &Consts<T>,
    wi: [T; 3],
    wo: [T; 3],
    h: [T; 3],
) -> Lobe<T> {
    if B {
        let (hx2, hy2, hz2) = (h[0] * h[0], h[1] * h[1], h[2] * h[2]);
        let u = if A {
            hx2 * k.inv_ax2 + hy2 * k.inv_ay2
        } else {
            (hx2 + hy2) * k.inv_ax2
        };
        let ed = (T::ZERO - u / hz2).exp();
        let (si, ri) = beckmann_s::<T, A>(k, wi);
        let (so, ro) = beckmann_s::<T, A>(k, wo);
        let l = hz2 * hz2 * vden::<T, C>(wi[2], wo[2], si, so);
        let dv = select(ed > T::ZERO, k.d_norm * ed / l, T::ZERO);
        return Lobe {
            hx2,
            hy2,
            s: hz2,
            si,
            so,
            ri,
            ro,
            dv,
        };
    }
    let (hx2, hy2, s, l, si, so) = lobe_den::<T, A, C>(k, wi, wo, h);
    // D·V in one division; s² ≤ 1e24 and vden ≤ 4e4 over the roughness domain, so the
    // product stays finite even in f32.
    let dv = k.d_norm / l;
    Lobe {
        hx2,
        hy2,
        s,
        si,
        so,
        ri: T::ZERO,
        ro: T::ZERO,
        dv,
    }
}

/// Beckmann's S(v) = vz erf(a) + t exp(−a²)/√π (module doc) and r = exp(−a²)/(√π t)
/// (r = 0 on the normal, where vx = vy = 0 and the derivative is 0).
#[inline(always)]
fn beckmann_s<T: Real, const A: bool>(k: &Consts<T>, v: [T; 3]) -> (T, T) {
    let t2 = if A {
        k.ax2 * v[0] * v[0] + k.ay2 * v[1] * v[1]
    } else {
        k.ax2 * sin2::<T>(v)
    };
    let t = t2.sqrt();
    // a = ∞ on the normal: exp(−∞) = 0, erf(∞) = 1, S = vz.
    let a = v[2] / t;
    let e = (T::ZERO - a * a).exp() * T::of(0.5 * FRAC_2_SQRT_PI);
    (v[2] * a.erf() + t * e, e / max(t, T::TINY))
}

/// ∂S(v)/∂α for `num` = αx vx² (or α sin²θv) of a direction with S(v) = `s` and
/// Beckmann's `r` (module doc): GGX num/S, Beckmann num·r.
#[inline(always)]
fn ds<T: Real, const B: bool>(num: T, s: T, r: T) -> T {
    if B { num * r } else { num / s }
}

/// The factor c of ∂ln D/∂αx = (c ux − s)/(αx s) (isotropic: (c u − 2s)/(α s)): 4 with
/// GGX's s, 2 with Beckmann's s = hz².
#[inline(always)]
fn d_coef<T: Real, const B: bool>() -> T {
    if B { T::TWO } else { T::TWO + T::TWO }
}

/// f_r of one pair (module doc).
#[inline(always)]
pub(super) fn value<T: Real, const A: bool, const C: bool, const F: u8, const B: bool>(
    k: &Consts<T>,
    wi: [T; 3],
    wo: [T; 3],
    h: [T; 3],
    cd: T,
) -> [T; 3] {
    let (zi, zo) = (wi[2], wo[2]);
    // Below the horizon exactly 0 (a select, so the loop has no branch).
    let up = zi > T::ZERO && zo > T::ZERO;
    if F == F_CONDUCTOR && T::FOLD_DIVISIONS && !B {
        return conductor_value::<T, A, C>(k, wi, wo, up);
    }
    let Lobe { dv, .. } = lobe::<T, A, C, B>(k, wi, wo, h);
    let f = fresnel::<T, F>(k, cd);
    std::array::from_fn(|c| select(up, k.diff[c] + k.spec[c] * dv * f[c], T::ZERO))
}

/// f_r of one pair with the conductor's F in `f64`, from the directions alone (the
/// caller's half vector and cos θd are not used). The f64 loop is bound by the divider
/// and square-root unit (docs/performance.md, "Raw directions in f64"), and this form
/// needs neither |wi + wo| nor cos θd itself, only their squares, and folds the
/// quotients of D·V and of the three channels' F into one division:
///
/// - with s = wi + wo (not normalised) and n² = s·s, h = s/n, so the lobe's s of the
///   module doc is s̃/n² with s̃ the same sum taken on s, and cos²θd = (wi·h)² =
///   (wi·s)²/n²: one reciprocal of n² serves both. (wi·s is formed from the components
///   of s, not as 1 + wi·wo, which cancels near wi = −wo.)
/// - Möller's t2 = 2 c a (a² = (p + t)/2) is √(2 c² (p + t)), so c is never needed.
/// - ρs D V F_c = (ρs/π αx αy) n_c q_c′ / (u² vden q_r q_g q_b), with n_c/q_c the
///   channel's F and q_c′ the product of the other two denominators.
///
/// Eight square roots and two divisions per pair, where the half-vector form has nine
/// and seven. Every f64 path (`eval`, the geometry batches, raw directions) comes here,
/// so they all give the same bits.
#[inline(always)]
fn conductor_value<T: Real, const A: bool, const C: bool>(
    k: &Consts<T>,
    wi: [T; 3],
    wo: [T; 3],
    up: bool,
) -> [T; 3] {
    let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
    let n2 = s[0] * s[0] + s[1] * s[1] + s[2] * s[2];
    let ws = wi[0] * s[0] + wi[1] * s[1] + wi[2] * s[2];
    // Where n² is 0 or below the normal range (|wi + wo| < 1e-154: wi = −wo, or
    // grazing pairs that close) the half vector is the normal, as in
    // `half_and_cos_d`: s(h) = 1, cos θd = wi_z.
    let ok = n2 >= T::TINY;
    let r = T::ONE / n2;
    let (_, _, st, _, si, so) = lobe_den::<T, A, C>(k, wi, wo, s);
    let u = select(ok, st * r, T::ONE);
    // vden again rather than from `lobe_den` (which would return it instead of s² vden):
    // the same arithmetic, but that form compiled to a loop 10 % slower here
    // (benches/raw.rs, alternated builds, 2026-11-25).
    let vden = vden::<T, C>(wi[2], wo[2], si, so);
    // Round-off can take (wi·s)²/n² a hair past 1, as it can wi·h.
    let c2 = clamp01(select(ok, ws * ws * r, wi[2] * wi[2]));
    let s2 = T::ONE - c2;
    let s4 = s2 * s2;
    let [(nr, qr), (ng, qg), (nb, qb)]: [(T, T); 3] = std::array::from_fn(|ch| {
        let t = k.fa[ch] - s2;
        let p = (t * t + k.fb[ch]).sqrt();
        // p + t = 2a² ≥ 0 exactly; round-off can make it a hair negative.
        let t2 = (T::TWO * c2 * max(p + t, T::ZERO)).sqrt();
        let t1 = p + c2;
        let t3 = p * c2 + s4;
        let t4 = t2 * s2;
        // q = 0 only at c = 0 with p = 0 (k = 0, η = 1: no interface), where the
        // numerator is 0 as well and F = 0 is the limit; the floor keeps the product
        // of the denominators nonzero. Over the parameter domain (α in [1e-6, 100],
        // η and k ≤ 1000) u = s(h) lies in [1e-4, 1e12], vden ≤ 1e4 and q ≤ 5e12, so
        // the product stays below 1e67; it nears 0 only as vden does, with both
        // directions at grazing, where D·V overflows in any form.
        ((t1 - t2) * t3, max((t1 + t2) * (t3 + t4), T::of(1e-30)))
    });
    let rr = T::ONE / (u * u * vden * (qr * qg * qb));
    let m = [nr * (qg * qb), ng * (qr * qb), nb * (qr * qg)];
    std::array::from_fn(|c| select(up, k.diff[c] + k.spec_d[c] * m[c] * rr, T::ZERO))
}

/// Largest parameter count of the gradient kernel: 3 ρd + 3 ρs + 2 α + 3 f0.
pub(super) const GRAD_P: usize = 11;

/// Pairs per block of the batch gradient loop (`LoopGrad64`): its planes, 11 × 64
/// values, stay in the first-level cache.
const GRAD_BLOCK: usize = 64;

/// f_r of one pair and its gradient, F ∈ {none, Schlick}; `g[p][c]` = ∂f_c/∂param_p in
/// the model's parameter order (ρd, ρs, α or αx αy, f0), the first
/// `6 + (1 or 2) + (0 or 3)` entries written.
///
/// With DV = D·V the specular factor of the module doc, ∂f_c/∂ρs_c = DV F_c, ∂f_c/∂f0_c =
/// ρs_c DV (1 − (1 − c)⁵), and for the roughness, ux = hx²/αx² (isotropic α:
/// u = (hx² + hy²)/α²),
/// - GGX: ∂ln DV/∂αx = (4 ux − s)/(αx s) − ∂ln vden/∂αx (isotropic:
///   (4 u − 2 s)/(α s) − ∂ln vden/∂α), with ∂S(v)/∂αx = αx vx²/S(v) (isotropic:
///   α sin²θv/S(v));
/// - Beckmann: ∂ln D/∂αx = (2 ux/hz² − 1)/αx (isotropic: (2 u/hz² − 2)/α), the same
///   form with 2 for 4 and hz² for s; and ∂S(v)/∂αx = αx vx² exp(−a²)/(√π t) (∂S/∂t =
///   exp(−a²)/√π, the erf terms cancelling; isotropic: α sin²θv exp(−a²)/(√π t));
///
/// so that
/// separable:  ∂ln vden = ∂Si/(zi + Si) + ∂So/(zo + So),
/// correlated: ∂ln vden = (zo ∂Si + zi ∂So)/(zo Si + zi So).
#[inline(always)]
pub(super) fn value_grad<T: Real, const A: bool, const C: bool, const F: u8, const B: bool>(
    k: &Consts<T>,
    wi: [T; 3],
    wo: [T; 3],
    h: [T; 3],
    cd: T,
    g: &mut [[T; 3]; GRAD_P],
) -> [T; 3] {
    let (zi, zo) = (wi[2], wo[2]);
    let up = zi > T::ZERO && zo > T::ZERO;
    let z = T::ZERO;
    let l = lobe::<T, A, C, B>(k, wi, wo, h);
    let Lobe {
        hx2,
        hy2,
        s,
        si,
        so,
        ri,
        ro,
        dv,
    } = l;
    let (dln_x, dln_y) = if A {
        let (ux, uy) = (hx2 * k.inv_ax2, hy2 * k.inv_ay2);
        let c = d_coef::<T, B>();
        let dx = (c * ux - s) * k.inv_ax / s
            - dln_vden::<T, C>(
                [zi, zo, si, so],
                ds::<T, B>(k.ax * wi[0] * wi[0], si, ri),
                ds::<T, B>(k.ax * wo[0] * wo[0], so, ro),
            );
        let dy = (c * uy - s) * k.inv_ay / s
            - dln_vden::<T, C>(
                [zi, zo, si, so],
                ds::<T, B>(k.ay * wi[1] * wi[1], si, ri),
                ds::<T, B>(k.ay * wo[1] * wo[1], so, ro),
            );
        (dx, dy)
    } else {
        (dln_alpha_iso::<T, C, B>(k, wi, wo, &l), z)
    };
    let f = fresnel::<T, F>(k, cd);
    let w_comp = if F == F_SCHLICK {
        let m = T::ONE - clamp01(cd);
        let m2 = m * m;
        T::ONE - m2 * m2 * m
    } else {
        z
    };
    let inv_pi = T::of(FRAC_1_PI);
    for c in 0..3 {
        let mut dd = [z; 3];
        dd[c] = select(up, inv_pi, z);
        g[c] = dd;
        let mut ds = [z; 3];
        ds[c] = select(up, dv * f[c], z);
        g[3 + c] = ds;
    }
    let spec_f: [T; 3] = std::array::from_fn(|c| k.spec[c] * f[c] * dv);
    g[6] = spec_f.map(|x| select(up, x * dln_x, z));
    let mut p = 7;
    if A {
        g[7] = spec_f.map(|x| select(up, x * dln_y, z));
        p = 8;
    }
    if F == F_SCHLICK {
        for c in 0..3 {
            let mut d0 = [z; 3];
            d0[c] = select(up, k.spec[c] * dv * w_comp, z);
            g[p + c] = d0;
        }
    }
    std::array::from_fn(|c| select(up, k.diff[c] + k.spec[c] * dv * f[c], z))
}

/// ∂ln vden/∂α for a direction-dependent ∂S (`zs` = [zi, zo, Si, So]; `dsi`, `dso`
/// are ∂Si/∂α, ∂So/∂α), in the two forms of [`value_grad`]'s doc.
#[inline(always)]
fn dln_vden<T: Real, const C: bool>(zs: [T; 4], dsi: T, dso: T) -> T {
    let [zi, zo, si, so] = zs;
    if C {
        (zo * dsi + zi * dso) / (zo * si + zi * so)
    } else {
        dsi / (zi + si) + dso / (zo + so)
    }
}

/// ∂ln(D·V)/∂α of the isotropic lobe `l` of (wi, wo) ([`value_grad`]'s doc).
#[inline(always)]
fn dln_alpha_iso<T: Real, const C: bool, const B: bool>(
    k: &Consts<T>,
    wi: [T; 3],
    wo: [T; 3],
    l: &Lobe<T>,
) -> T {
    let Lobe { s, si, so, .. } = *l;
    let u = (l.hx2 + l.hy2) * k.inv_ax2;
    (d_coef::<T, B>() * u - T::TWO * s) * k.inv_ax / s
        - dln_vden::<T, C>(
            [wi[2], wo[2], si, so],
            ds::<T, B>(k.ax * sin2::<T>(wi), si, l.ri),
            ds::<T, B>(k.ax * sin2::<T>(wo), so, l.ro),
        )
}

/// Isotropic GGX D·V of one pair above the horizon and ∂ln(D·V)/∂α, in `f64`: the
/// lobe and log-derivative of this kernel, for the models that share it (`gltf-pbr`
/// and its extensions' core and clear coat). `[wi, wo, h]` with h the unit half
/// vector; `correlated` picks the height-correlated Smith V, else the separable one.
#[inline(always)]
pub(crate) fn ggx_iso_dv(alpha: f64, correlated: bool, [wi, wo, h]: [[f64; 3]; 3]) -> (f64, f64) {
    let k = Consts::isotropic(alpha);
    if correlated {
        let l = lobe::<f64, false, true, false>(&k, wi, wo, h);
        (l.dv, dln_alpha_iso::<f64, true, false>(&k, wi, wo, &l))
    } else {
        let l = lobe::<f64, false, false, false>(&k, wi, wo, h);
        (l.dv, dln_alpha_iso::<f64, false, false>(&k, wi, wo, &l))
    }
}

impl Consts<f64> {
    /// The constants of an isotropic lobe of roughness α (as
    /// [`CookTorrance::kernel_consts`] sets them), and none of the colour's.
    fn isotropic(alpha: f64) -> Self {
        let z = [0.0; 3];
        Consts {
            inv_ax2: 1.0 / (alpha * alpha),
            inv_ay2: 1.0 / (alpha * alpha),
            ax2: alpha * alpha,
            ay2: alpha * alpha,
            ax: alpha,
            ay: alpha,
            inv_ax: 1.0 / alpha,
            inv_ay: 1.0 / alpha,
            d_norm: FRAC_1_PI / (alpha * alpha),
            diff: z,
            spec: z,
            spec_d: z,
            fa: z,
            fb: z,
        }
    }
}

/// Calls `job.go` with `cfg` as constants, for the configurations of
/// [`CookTorrance::kernel_grad_config`].
pub(super) fn with_grad_config<J: Job>(cfg: Config, job: J) {
    config_arms!(cfg, job, "kernel_grad_config only admits none and Schlick";
        false, false, F_NONE; false, false, F_SCHLICK; false, true, F_NONE; false, true, F_SCHLICK;
        true, false, F_NONE; true, false, F_SCHLICK; true, true, F_NONE; true, true, F_SCHLICK;
    );
}

/// A batch's values and parameter-major gradient in `f64`.
pub(super) struct BatchGrad64<'a, 'g> {
    pub k: &'a Consts<f64>,
    pub g: &'a GeomSlice<'g>,
    pub out: &'a mut [Rgb],
    pub grad: &'a mut [Rgb],
    pub np: usize,
}

struct LoopGrad64<'a, 'g, const A: bool, const C: bool, const F: u8, const B: bool>(
    BatchGrad64<'a, 'g>,
);

impl<const A: bool, const C: bool, const F: u8, const B: bool> Run
    for LoopGrad64<'_, '_, A, C, F, B>
{
    /// Block by block: the block's ten input columns are copied into arrays of
    /// [`GRAD_BLOCK`] pairs, the pair loop runs over the whole arrays (a constant trip
    /// count, every access in bounds by type and to a local array, so LLVM needs neither
    /// bounds nor alias checks and vectorises it), writing values and each parameter's
    /// plane into local arrays (one per channel), which are then interleaved into the
    /// caller's `Rgb`s (the parameter count is a constant of the configuration, so those
    /// copies unroll). A last block
    /// shorter than [`GRAD_BLOCK`] computes its unused lanes from the previous block's
    /// leftovers and drops them. The loop this replaces (session 12) stored a whole
    /// `Rgb` per pair and parameter into its block, a 24-byte `memcpy` call (LLVM:
    /// "call instruction cannot be vectorized"), and ran scalar.
    #[inline(always)]
    fn run(&mut self) {
        let b = &mut self.0;
        let n = b.g.len();
        // ρd, ρs, α or (αx, αy), and f0 with Schlick ([`CookTorrance::kernel_grad_config`]).
        let np = 7 + usize::from(A) + if F == F_SCHLICK { 3 } else { 0 };
        debug_assert_eq!(np, b.np);
        // A local copy: the stores of the loop cannot be to it.
        let k = *b.k;
        let columns = b.g.columns();
        let mut cols = [[0.0; GRAD_BLOCK]; 10];
        // Values and gradient one plane per channel: every store is of one `f64` (a
        // store of a whole `Rgb` into an array indexed by the pair was a 24-byte
        // `memcpy` call, which kept the loop scalar).
        let mut vals = [[0.0; GRAD_BLOCK]; 3];
        let mut block = [[[0.0; GRAD_BLOCK]; 3]; GRAD_P];
        for s in (0..n).step_by(GRAD_BLOCK) {
            let len = GRAD_BLOCK.min(n - s);
            for (dst, src) in cols.iter_mut().zip(columns) {
                dst[..len].copy_from_slice(&src[s..s + len]);
            }
            for i in 0..GRAD_BLOCK {
                let c = |j: usize| cols[j][i];
                // Per pair, so it can live in registers.
                let mut gk = [[0.0; 3]; GRAD_P];
                let v = value_grad::<f64, A, C, F, B>(
                    &k,
                    [c(0), c(1), c(2)],
                    [c(3), c(4), c(5)],
                    [c(6), c(7), c(8)],
                    c(9),
                    &mut gk,
                );
                for ch in 0..3 {
                    vals[ch][i] = v[ch];
                    for p in 0..np {
                        block[p][ch][i] = gk[p][ch];
                    }
                }
            }
            interleave(&mut b.out[s..s + len], &vals);
            for (p, plane) in block.iter().enumerate().take(np) {
                interleave(&mut b.grad[p * n + s..p * n + s + len], plane);
            }
        }
    }
}

/// `dst[i] = Rgb([planes[0][i], planes[1][i], planes[2][i]])` for each `i < dst.len()`.
#[inline(always)]
fn interleave(dst: &mut [Rgb], planes: &[[f64; GRAD_BLOCK]; 3]) {
    let [r, g, b] = planes;
    for (d, ((r, g), b)) in dst.iter_mut().zip(r.iter().zip(g).zip(b)) {
        *d = Rgb([*r, *g, *b]);
    }
}

impl Job for BatchGrad64<'_, '_> {
    fn go<const A: bool, const C: bool, const F: u8, const B: bool>(self) {
        dispatch(&mut LoopGrad64::<A, C, F, B>(self));
    }
}

/// Work that needs the configuration as compile-time constants.
pub(super) trait Job {
    fn go<const A: bool, const C: bool, const F: u8, const B: bool>(self);
}

/// Calls `job.go` with `cfg` as constants.
pub(super) fn with_config<J: Job>(cfg: Config, job: J) {
    config_arms!(cfg, job, "kernel_config only builds known Fresnel kinds";
        false, false, F_NONE; false, false, F_SCHLICK; false, false, F_CONDUCTOR; false, false, F_DIELECTRIC;
        false, true, F_NONE; false, true, F_SCHLICK; false, true, F_CONDUCTOR; false, true, F_DIELECTRIC;
        true, false, F_NONE; true, false, F_SCHLICK; true, false, F_CONDUCTOR; true, false, F_DIELECTRIC;
        true, true, F_NONE; true, true, F_SCHLICK; true, true, F_CONDUCTOR; true, true, F_DIELECTRIC;
    );
}

/// One pair in `f64`: the value, and with `grad` (only under
/// [`with_grad_config`]) the gradient (`grad.len()` = the model's parameter count).
pub(super) struct Pair<'a> {
    pub k: &'a Consts<f64>,
    pub p: PairGeom,
    pub out: &'a mut Rgb,
    pub grad: Option<&'a mut [Rgb]>,
}

impl Job for Pair<'_> {
    fn go<const A: bool, const C: bool, const F: u8, const B: bool>(self) {
        let Pair { k, p, out, grad } = self;
        let PairGeom {
            wi,
            wo,
            h,
            cos_d: cd,
        } = p;
        *out = Rgb(match grad {
            None => value::<f64, A, C, F, B>(k, wi, wo, h, cd),
            Some(grad) => {
                let mut g = [[0.0; 3]; GRAD_P];
                let v = value_grad::<f64, A, C, F, B>(k, wi, wo, h, cd, &mut g);
                for (d, s) in grad.iter_mut().zip(g) {
                    *d = Rgb(s);
                }
                v
            }
        });
    }
}

/// Where a batch's values go: [`Rgb`]s (`f64`), one plane per channel (`f32`) or
/// `[r, g, b]` rows (either precision).
pub(crate) trait Sink<T> {
    /// Pairs the sink can take.
    fn len(&self) -> usize;
    /// Stores pair `i` (`i < len()`).
    fn put(&mut self, i: usize, v: [T; 3]);
}

impl Sink<f64> for &mut [Rgb] {
    #[inline(always)]
    fn len(&self) -> usize {
        <[Rgb]>::len(self)
    }
    #[inline(always)]
    fn put(&mut self, i: usize, v: [f64; 3]) {
        self[i] = Rgb(v);
    }
}

impl Sink<f32> for [&mut [f32]; 3] {
    #[inline(always)]
    fn len(&self) -> usize {
        self[0].len().min(self[1].len()).min(self[2].len())
    }
    #[inline(always)]
    fn put(&mut self, i: usize, v: [f32; 3]) {
        self[0][i] = v[0];
        self[1][i] = v[1];
        self[2][i] = v[2];
    }
}

impl<T: Real> Sink<T> for &mut [[T; 3]] {
    #[inline(always)]
    fn len(&self) -> usize {
        <[[T; 3]]>::len(self)
    }
    #[inline(always)]
    fn put(&mut self, i: usize, v: [T; 3]) {
        self[i] = v;
    }
}

/// The values of a batch, in precision `T`, into `out`.
pub(super) struct Batch<'a, 'g, T, O> {
    pub k: &'a Consts<T>,
    pub g: &'a GeomSliceOf<'g, T>,
    pub out: O,
    /// Run the baseline copy instead of the dispatched one (tests).
    pub baseline: bool,
}

struct Loop<'a, 'g, T, O, const A: bool, const C: bool, const F: u8, const B: bool>(
    Batch<'a, 'g, T, O>,
);

impl<T: Real, O: Sink<T>, const A: bool, const C: bool, const F: u8, const B: bool> Run
    for Loop<'_, '_, T, O, A, C, F, B>
{
    #[inline(always)]
    fn run(&mut self) {
        let b = &mut self.0;
        let n = b.g.len().min(b.out.len());
        let g = b.g.sub(0..n);
        // A local copy: the loop's stores cannot be to it, so its loads are
        // loop-invariant (read through `b.k`, LLVM could not bound them and the loop
        // stayed scalar).
        let k = *b.k;
        for i in 0..n {
            let v = value::<T, A, C, F, B>(
                &k,
                [g.wi_x[i], g.wi_y[i], g.wi_z[i]],
                [g.wo_x[i], g.wo_y[i], g.wo_z[i]],
                [g.h_x[i], g.h_y[i], g.h_z[i]],
                g.cos_d[i],
            );
            b.out.put(i, v);
        }
    }
}

impl<T: Real, O: Sink<T>> Job for Batch<'_, '_, T, O> {
    fn go<const A: bool, const C: bool, const F: u8, const B: bool>(self) {
        let baseline = self.baseline;
        let mut l = Loop::<T, O, A, C, F, B>(self);
        if baseline {
            l.run();
        } else {
            dispatch(&mut l);
        }
    }
}

/// The values of pairs given as raw directions, in precision `T`, into `out`: the half
/// vector and cos θd computed in the loop ([`half_and_cos_d`], the bits of
/// `GeometryBatch::push` in `f64`), so reading the directions, the arithmetic and
/// writing f_r overlap in one pass instead of three (`brdfkit_models::raw`).
pub(crate) struct DirsBatch<'a, 'd, T, O> {
    pub k: &'a Consts<T>,
    pub dirs: DirPairs<'d, T>,
    pub out: O,
}

struct DirsLoop<'a, 'd, T, O, const A: bool, const C: bool, const F: u8, const B: bool>(
    DirsBatch<'a, 'd, T, O>,
);

impl<
    T: Real + brdfkit_core::geometry::Component,
    O: Sink<T>,
    const A: bool,
    const C: bool,
    const F: u8,
    const B: bool,
> Run for DirsLoop<'_, '_, T, O, A, C, F, B>
{
    #[inline(always)]
    fn run(&mut self) {
        let b = &mut self.0;
        let n = b.dirs.len().min(b.out.len());
        // A local copy, as in `Loop`.
        let k = *b.k;
        // One loop per layout, each over slices cut to n (no bounds checks inside).
        match b.dirs.sub(0..n) {
            DirPairs::Split(wi, wo) => {
                for i in 0..n {
                    let (h, cd) = half_and_cos_d(wi[i], wo[i]);
                    b.out
                        .put(i, value::<T, A, C, F, B>(&k, wi[i], wo[i], h, cd));
                }
            }
            DirPairs::Rows(rows) => {
                for (i, r) in rows.iter().enumerate() {
                    let (wi, wo) = ([r[0], r[1], r[2]], [r[3], r[4], r[5]]);
                    let (h, cd) = half_and_cos_d(wi, wo);
                    b.out.put(i, value::<T, A, C, F, B>(&k, wi, wo, h, cd));
                }
            }
        }
    }
}

impl<T: Real + brdfkit_core::geometry::Component, O: Sink<T>> Job for DirsBatch<'_, '_, T, O> {
    fn go<const A: bool, const C: bool, const F: u8, const B: bool>(self) {
        dispatch(&mut DirsLoop::<T, O, A, C, F, B>(self));
    }
}

impl CookTorrance {
    /// f_r of raw direction pairs through the kernel, fused with the half vector
    /// ([`DirsBatch`]); false (nothing written) when the configuration has no kernel.
    pub(crate) fn kernel_dirs<T: Real + brdfkit_core::geometry::Component, O: Sink<T>>(
        &self,
        dirs: DirPairs<'_, T>,
        out: O,
    ) -> bool {
        let Some(cfg) = self.kernel_config() else {
            return false;
        };
        let k = self.kernel_consts::<T>();
        with_config(cfg, DirsBatch { k: &k, dirs, out });
        true
    }
}
