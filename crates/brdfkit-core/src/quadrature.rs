//! Numerical integration over the hemisphere: Gauss-Legendre rules and the
//! directional albedo of any [`Brdf`].
//!
//! The directional albedo (directional-hemispherical reflectance) of a BRDF for
//! outgoing direction wo is a(wo) = ∫_{H²} f(wi, wo) cosθi dωi. Energy conservation
//! demands a ≤ 1 for every wo (and, by reciprocity, for every wi).
//!
//! Sharp lobes (exponents to 10⁴, roughness to 0.01) defeat a uniform grid, so the
//! integral is taken in polar coordinates (u, φ) about a *pole* placed at the lobe
//! (the mirror direction of wo for specular lobes), with u split into geometrically
//! graded segments, each integrated by Gauss-Legendre, and φ over the visible part of
//! each ring only (see [`directional_albedo`]), so the horizon never cuts through a
//! quadrature panel. A Lambertian albedo comes out exact to round-off at every outgoing
//! angle, grazing included (see the tests).

use crate::{Brdf, Rgb, Vec3};
use std::collections::HashMap;
use std::ops::{AddAssign, Mul};
use std::sync::{Arc, Mutex, OnceLock};

/// Nodes and weights of the n-point Gauss-Legendre rule on [−1, 1].
///
/// Nodes are the roots of the Legendre polynomial P_n, found by Newton's method from
/// the Chebyshev-like guess cos(π (k − 1/4) / (n + 1/2)); weights are
/// 2 / ((1 − x²) P_n'(x)²) (Abramowitz & Stegun 25.4.29).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n > 0, "a quadrature rule needs at least one node");
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let m = n.div_ceil(2);
    for k in 0..m {
        let mut z = (std::f64::consts::PI * (k as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            // P_n(z) and P_n'(z) by the three-term recurrence.
            let (mut p0, mut p1) = (1.0, z);
            for j in 2..=n {
                let p2 = ((2 * j - 1) as f64 * z * p1 - (j - 1) as f64 * p0) / j as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 1 { z } else { p1 };
            let pm = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (z * pn - pm) / (z * z - 1.0);
            if n == 1 {
                dp = 1.0;
            }
            let dz = pn / dp;
            z -= dz;
            if dz.abs() < 1e-16 {
                break;
            }
        }
        x[k] = -z;
        x[n - 1 - k] = z;
        let wk = 2.0 / ((1.0 - z * z) * dp * dp);
        w[k] = wk;
        w[n - 1 - k] = wk;
    }
    (x, w)
}

/// A Gauss-Legendre rule: nodes and weights.
type Rule = Arc<(Vec<f64>, Vec<f64>)>;

/// [`gauss_legendre`]`(n)`, computed once per n in the process and shared after.
///
/// [`albedo_by_rings`] takes an n_phi-point rule for every arc, and n_phi grows like
/// 16/cos θ near grazing (thousands of nodes): Newton's iteration over the three-term
/// recurrence costs O(n²) a rule, more than the integral itself for a cheap BRDF, and
/// the same few orders (powers of two) come back for every direction. The rules are
/// the function's own values (the same bits). Each n has its own cell: a thread that
/// needs a rule another is computing waits for it instead of computing it too (a
/// report's albedo integrals start together and ask for the same few rules), and the
/// map's lock is held only to find the cell. Rules above 2¹⁶ nodes (a direction within
/// 0.02° of the horizon) are not kept.
fn gauss_legendre_shared(n: usize) -> Rule {
    static RULES: OnceLock<Mutex<HashMap<usize, Arc<OnceLock<Rule>>>>> = OnceLock::new();
    const KEPT_MAX: usize = 1 << 16;
    let rules = RULES.get_or_init(|| Mutex::new(HashMap::new()));
    // A poisoned lock only means another thread panicked while inserting: compute.
    let cell = (n <= KEPT_MAX)
        .then(|| {
            rules
                .lock()
                .ok()
                .map(|mut m| m.entry(n).or_default().clone())
        })
        .flatten();
    match cell {
        Some(c) => c.get_or_init(|| Arc::new(gauss_legendre(n))).clone(),
        None => Arc::new(gauss_legendre(n)),
    }
}

/// Where the polar coordinates of the albedo quadrature are centred.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pole {
    /// The mirror direction of wo: specular lobes (the default).
    Mirror,
    /// wo itself: retro-reflective lobes.
    Retro,
    /// The surface normal: diffuse or normal-peaked integrands.
    Normal,
}

/// Resolution of the directional-albedo quadrature.
#[derive(Debug, Clone)]
pub struct AlbedoQuadrature {
    /// Centre of the polar coordinates.
    pub pole: Pole,
    /// Edges of the graded segments in u (angle from the pole), from 0 to π.
    pub edges: Vec<f64>,
    /// Gauss-Legendre order per segment.
    pub order: usize,
    /// Trapezoid points in φ.
    pub n_phi: usize,
}

impl Default for AlbedoQuadrature {
    fn default() -> Self {
        AlbedoQuadrature {
            pole: Pole::Mirror,
            edges: vec![
                0.0,
                1e-5,
                1e-4,
                1e-3,
                3e-3,
                1e-2,
                3e-2,
                0.1,
                0.3,
                0.7,
                1.2,
                1.8,
                2.5,
                std::f64::consts::PI,
            ],
            order: 24,
            n_phi: 256,
        }
    }
}

impl AlbedoQuadrature {
    /// A finer rule (8x the work of the default), for convergence checks.
    pub fn fine() -> Self {
        AlbedoQuadrature {
            order: 48,
            n_phi: 1024,
            ..Self::default()
        }
    }

    /// The same rule about another pole.
    pub fn with_pole(mut self, pole: Pole) -> Self {
        self.pole = pole;
        self
    }
}

/// Orthonormal frame (t, b, n) around the unit vector n.
pub fn frame_around(n: &Vec3) -> (Vec3, Vec3) {
    // Duff et al., "Building an Orthonormal Basis, Revisited" (JCGT 2017): branchless
    // apart from the sign, and stable for every n.
    let sign = 1.0f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bb = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (t, bb)
}

/// Directional albedo a(wo) = ∫ f(wi, wo) cos θi dωi over the upper hemisphere, by the
/// rule `q` ([`albedo_by_rings`], one [`Brdf::eval`] a node above the horizon).
pub fn directional_albedo(brdf: &dyn Brdf, wo: &Vec3, q: &AlbedoQuadrature) -> Rgb {
    albedo_by_rings(wo, q, |nodes: &[Vec3], out: &mut [Rgb]| {
        for (wi, f) in nodes.iter().zip(out) {
            // A node below the horizon adds nothing: not evaluated.
            *f = if wi.z <= 0.0 {
                Rgb::ZERO
            } else {
                brdf.eval(wi, wo)
            };
        }
    })
}

/// What a node of the albedo quadrature contributes: a value that adds and scales
/// channel by channel like [`Rgb`] (so each channel's sum is the same whatever else
/// the integrand carries, e.g. a measured table's validity indicator beside its value).
pub trait Integrand: Copy + AddAssign + Mul<f64, Output = Self> {
    /// The contribution of a node below the horizon.
    const ZERO: Self;
}

impl Integrand for Rgb {
    const ZERO: Self = Rgb::ZERO;
}

/// The directional albedo a(wo) = ∫ f(wi, wo) cos θi dωi of an integrand given a ring
/// of nodes at a time: `eval(nodes, out)` puts f at `nodes[k]` into `out[k]` (a node at
/// or below the horizon is given too, and its value ignored), so a caller with a batch
/// path (a model's vectorised kernels, a table's batch lookups) evaluates a whole ring
/// at once, and every caller gets the same sums in the same order.
///
/// In polar coordinates (u, φ) about the pole p (frame t, b, p), wi.z =
/// sin u · A cos(φ − φ0) + cos u · p.z with A = |(t.z, b.z)|, φ0 = atan2(b.z, t.z). For
/// each u the visible part of the ring is therefore either the whole circle (u below
/// u_near = π/2 − θp, integrated by the trapezoid rule, spectrally accurate for periodic
/// integrands), an arc |φ − φ0| < acos(−cos u p.z / (sin u A)) (integrated by
/// Gauss-Legendre; the integrand vanishes linearly at the arc ends), or nothing (u beyond
/// u_far = π/2 + θp). u_near and u_far join the graded segment edges in u, so every
/// piece of both integrals is smooth and the rule converges fast even for narrow lobes
/// cut by the horizon. An outgoing direction at or below the horizon has albedo 0.
pub fn albedo_by_rings<V: Integrand>(
    wo: &Vec3,
    q: &AlbedoQuadrature,
    mut eval: impl FnMut(&[Vec3], &mut [V]),
) -> V {
    if wo.z <= 0.0 {
        return V::ZERO;
    }
    let frame = Frame::new(wo, q.pole);
    let g_rule = gauss_legendre_shared(q.order);
    let a_rule = gauss_legendre_shared(q.n_phi.max(2));
    let dphi = 2.0 * std::f64::consts::PI / q.n_phi as f64;
    // The whole rings (u < u_near) all sample the same azimuths φ0 + (m + ½) Δφ: their
    // in-plane directions cos φ t + sin φ b are computed once, not once a ring (a
    // sin_cos a node was a third of a cheap BRDF's integral).
    let ring_dirs: Vec<Vec3> = (0..q.n_phi)
        .map(|m| {
            let (sp, cp) = (frame.phi0 + (m as f64 + 0.5) * dphi).sin_cos();
            cp * frame.t + sp * frame.b
        })
        .collect();
    let width = q.n_phi.max(a_rule.0.len());
    let mut nodes: Vec<Vec3> = Vec::with_capacity(width);
    let mut vals: Vec<V> = vec![V::ZERO; width];
    let mut angles: Vec<(f64, f64)> = Vec::with_capacity(width);
    let mut ring = |u: f64| -> V {
        let (su, cu) = u.sin_cos();
        let (weights, scale): (&[f64], f64) = match frame.visible(su, cu) {
            Visible::None => return V::ZERO,
            Visible::Whole => {
                nodes.clear();
                nodes.extend(ring_dirs.iter().map(|d| su * d + cu * frame.pole));
                (&[], dphi)
            }
            Visible::Arc(half) => {
                arc_angles(frame.phi0, half, &a_rule.0, &mut angles);
                nodes.clear();
                nodes.extend(
                    angles
                        .iter()
                        .map(|&(sp, cp)| su * (cp * frame.t + sp * frame.b) + cu * frame.pole),
                );
                (&a_rule.1, half)
            }
        };
        let v = &mut vals[..nodes.len()];
        eval(&nodes, v);
        ring_sum(&nodes, v, weights) * scale
    };
    let mut sum = V::ZERO;
    for (u, w) in frame.u_nodes(&q.edges, &g_rule) {
        sum += ring(u) * w;
    }
    sum
}

/// Σ f cos θi over a ring's nodes, each times its weight (`weights` empty: the
/// trapezoid rule's equal weights, applied by the caller); 0 where round-off put a node
/// at an arc end a hair below the horizon.
fn ring_sum<V: Integrand>(nodes: &[Vec3], vals: &[V], weights: &[f64]) -> V {
    let node = |wi: &Vec3, f: &V| if wi.z <= 0.0 { V::ZERO } else { *f * wi.z };
    let mut s = V::ZERO;
    if weights.is_empty() {
        for (wi, f) in nodes.iter().zip(vals) {
            s += node(wi, f);
        }
    } else {
        for ((wi, f), w) in nodes.iter().zip(vals).zip(weights) {
            s += node(wi, f) * *w;
        }
    }
    s
}

/// (sin φ, cos φ) at the arc's nodes φ = φ0 + half · x, x the Gauss-Legendre nodes `ax`.
///
/// The nodes are symmetric (x at n − 1 − k is −x at k, as [`gauss_legendre`] builds
/// them), so with φ0 = 0 (a direction at φ = 0 about the mirror pole: every albedo of a
/// report) the upper half of the arc is the lower half negated, φ = −φ' exactly, and
/// its sines and cosines are (−sin φ', cos φ'): sine is odd and cosine even to the bit
/// (libm reduces |φ| and sets the sign; a test compares them). Half the `sin_cos`
/// calls, which were most of an arc node's cost.
fn arc_angles(phi0: f64, half: f64, ax: &[f64], out: &mut Vec<(f64, f64)>) {
    out.clear();
    let n = ax.len();
    // With φ0 = 0, 0 + half · x is half · x (x is never −0: a rule of odd order has its
    // middle node at +0, which this computes directly).
    let direct = if phi0 == 0.0 { n.div_ceil(2) } else { n };
    out.extend(ax[..direct].iter().map(|x| (phi0 + half * x).sin_cos()));
    for k in direct..n {
        let (s, c) = out[n - 1 - k];
        out.push((-s, c));
    }
}

/// The pole's frame: the pole p, its tangents t and b, A = |(t.z, b.z)| and
/// φ0 = atan2(b.z, t.z), with wi.z = sin u · A cos(φ − φ0) + cos u · p.z on a ring.
struct Frame {
    pole: Vec3,
    t: Vec3,
    b: Vec3,
    amp: f64,
    phi0: f64,
}

/// The visible part of a ring.
enum Visible {
    /// The whole circle: the trapezoid rule.
    Whole,
    /// Nothing (the ring lies below the horizon).
    None,
    /// |φ − φ0| < the half-width: Gauss-Legendre over the arc.
    Arc(f64),
}

impl Frame {
    fn new(wo: &Vec3, pole: Pole) -> Frame {
        let pole = match pole {
            Pole::Mirror => Vec3::new(-wo.x, -wo.y, wo.z),
            Pole::Retro => *wo,
            Pole::Normal => Vec3::new(0.0, 0.0, 1.0),
        };
        let (t, b) = frame_around(&pole);
        Frame {
            pole,
            t,
            b,
            amp: t.z.hypot(b.z),
            phi0: b.z.atan2(t.z),
        }
    }

    /// Where cos(φ − φ0) > c, c = −cos u p.z / (sin u A), on the ring at u.
    fn visible(&self, su: f64, cu: f64) -> Visible {
        let c = if su * self.amp > 0.0 {
            -cu * self.pole.z / (su * self.amp)
        } else if cu * self.pole.z > 0.0 {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        };
        if c <= -1.0 {
            Visible::Whole
        } else if c >= 1.0 {
            Visible::None
        } else {
            Visible::Arc(c.acos())
        }
    }

    /// The rings' angles u and weights (the Gauss-Legendre weight times du and sin u)
    /// over the graded segments `edges`, joined by u_near = π/2 − θp and
    /// u_far = π/2 + θp.
    fn u_nodes(&self, edges: &[f64], g_rule: &Rule) -> Vec<(f64, f64)> {
        // The clamp keeps acos defined for a pole a rounding past ±1.
        let theta_p = self.pole.z.clamp(-1.0, 1.0).acos();
        let half_pi = std::f64::consts::FRAC_PI_2;
        let (u_near, u_far) = (half_pi - theta_p, half_pi + theta_p);
        let mut edges: Vec<f64> = edges.iter().copied().filter(|&u| u < u_far).collect();
        edges.push(u_far);
        if u_near > 0.0 && !edges.contains(&u_near) {
            edges.push(u_near);
        }
        edges.sort_by(f64::total_cmp);
        let mut out = Vec::new();
        for seg in edges.windows(2) {
            let (a, c) = (seg[0], seg[1]);
            if c <= a {
                continue;
            }
            // Past u_near and before u_far the arc half-width grows like a square root,
            // so those segments take the smoothstep substitution u = a + (c − a)(3s² −
            // 2s³), whose vanishing end derivatives turn √ into a smooth function of s.
            let smooth = a == u_near || c == u_far;
            for (x, w) in g_rule.0.iter().zip(&g_rule.1) {
                let s01 = 0.5 * (x + 1.0);
                let (u, du) = if smooth {
                    let u = a + (c - a) * s01 * s01 * (3.0 - 2.0 * s01);
                    (u, (c - a) * 6.0 * s01 * (1.0 - s01) * 0.5)
                } else {
                    (a + (c - a) * s01, 0.5 * (c - a))
                };
                out.push((u, w * du * u.sin()));
            }
        }
        out
    }
}

/// The directional albedo to a requested accuracy, with its error estimate.
///
/// Doubles the Gauss order and the azimuth count of `start` until two successive
/// estimates agree to `rel_tol` (relative to the largest channel, absolute below 1e-12),
/// at most 5 doublings. Returns the finer estimate and the last difference, which bounds
/// the error when the rule converges monotonically. Needed for lobes that grazing
/// incidence squeezes: at θo, a microfacet lobe of roughness α is only about
/// 2 α cos θo wide across the plane of incidence, far below a fixed azimuth spacing.
pub fn directional_albedo_converged(
    brdf: &dyn Brdf,
    wo: &Vec3,
    start: &AlbedoQuadrature,
    rel_tol: f64,
) -> (Rgb, f64) {
    let mut q = start.clone();
    let mut prev = directional_albedo(brdf, wo, &q);
    let mut diff = f64::INFINITY;
    for _ in 0..5 {
        q.order *= 2;
        q.n_phi *= 2;
        let next = directional_albedo(brdf, wo, &q);
        diff = (next - prev).map(f64::abs).max_channel();
        prev = next;
        if diff <= rel_tol * prev.max_channel().abs().max(1e-12) {
            break;
        }
    }
    (prev, diff)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::direction::spherical;

    struct Constant(f64);
    impl Brdf for Constant {
        fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
            if wi.z <= 0.0 || wo.z <= 0.0 {
                Rgb::ZERO
            } else {
                Rgb::splat(self.0)
            }
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in 1..=12 {
            let (x, w) = gauss_legendre(n);
            // Exact for degree 2n − 1: ∫ x^d dx over [−1, 1] = 2/(d+1) for even d.
            for d in 0..(2 * n) {
                let q: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(d as i32)).sum();
                let exact = if d % 2 == 0 {
                    2.0 / (d as f64 + 1.0)
                } else {
                    0.0
                };
                assert!((q - exact).abs() < 1e-13, "n={n} d={d}: {q} vs {exact}");
            }
        }
    }

    #[test]
    fn lambert_albedo_is_rho_for_every_pole() {
        // Exact to round-off for every pole, grazing included.
        let f = Constant(0.8 / std::f64::consts::PI);
        for pole in [Pole::Mirror, Pole::Retro, Pole::Normal] {
            for &t in &[
                0.0,
                0.5,
                1.2,
                1.55,
                1.5706,
                std::f64::consts::FRAC_PI_2 - 1e-6,
            ] {
                let wo = spherical(t, 0.3);
                let q = AlbedoQuadrature::default().with_pole(pole);
                let err = (directional_albedo(&f, &wo, &q).r() - 0.8).abs();
                let fine = AlbedoQuadrature::fine().with_pole(pole);
                let err_fine = (directional_albedo(&f, &wo, &fine).r() - 0.8).abs();
                let (tol, tol_fine) = (1e-12, 1e-12);
                assert!(err < tol, "pole {pole:?} θo={t}: error {err:e}");
                assert!(
                    err_fine < tol_fine,
                    "fine, pole {pole:?} θo={t}: error {err_fine:e}"
                );
            }
        }
    }

    /// The mirrored half of an arc about φ0 = 0 is, to the bit, what `sin_cos` of the
    /// node's own angle gives (odd and even rules, narrow and wide arcs).
    #[test]
    fn mirrored_arc_angles_are_the_direct_ones_to_the_bit() {
        let mut out = Vec::new();
        for n in [2, 3, 16, 17, 255, 1024] {
            let (ax, _) = gauss_legendre(n);
            for half in [1e-3, 0.3, 1.0, 2.5, std::f64::consts::PI] {
                arc_angles(0.0, half, &ax, &mut out);
                for (x, &(s, c)) in ax.iter().zip(&out) {
                    let (ds, dc) = (0.0 + half * x).sin_cos();
                    assert_eq!((s.to_bits(), c.to_bits()), (ds.to_bits(), dc.to_bits()));
                }
            }
        }
    }

    /// A ring-at-a-time integrand sees every node, and a node at or below the horizon
    /// adds nothing whatever value it is given.
    #[test]
    fn nodes_below_the_horizon_are_ignored() {
        let wo = spherical(1.2, 0.4);
        let q = AlbedoQuadrature::default();
        let honest = albedo_by_rings(&wo, &q, |n: &[Vec3], out: &mut [Rgb]| {
            for (wi, f) in n.iter().zip(out) {
                *f = if wi.z > 0.0 {
                    Rgb::splat(0.5)
                } else {
                    Rgb::ZERO
                };
            }
        });
        let noisy = albedo_by_rings(&wo, &q, |n: &[Vec3], out: &mut [Rgb]| {
            for (wi, f) in n.iter().zip(out) {
                *f = if wi.z > 0.0 {
                    Rgb::splat(0.5)
                } else {
                    Rgb::splat(1e300)
                };
            }
        });
        assert_eq!(honest.0.map(f64::to_bits), noisy.0.map(f64::to_bits));
        assert!((honest.r() - 0.5 * std::f64::consts::PI).abs() < 1e-9);
    }

    #[test]
    fn zero_below_the_horizon() {
        let f = Constant(1.0);
        let wo = Vec3::new(0.6, 0.8, 0.0);
        assert_eq!(
            directional_albedo(&f, &wo, &AlbedoQuadrature::default()),
            Rgb::ZERO
        );
    }

    /// A narrow normalised lobe about the mirror direction: (n+2)/(2π) cosⁿθr. Its
    /// albedo is ∫ (n+2)/(2π) cosⁿθr cosθi dωi, which must agree between the default
    /// and the fine rule, and stay below 1, even at grazing where the horizon cuts it.
    struct PhongLobe(f64);
    impl Brdf for PhongLobe {
        fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
            if wi.z <= 0.0 || wo.z <= 0.0 {
                return Rgb::ZERO;
            }
            let r = Vec3::new(-wi.x, -wi.y, wi.z);
            let c = r.dot(wo).max(0.0);
            Rgb::splat((self.0 + 2.0) / (2.0 * std::f64::consts::PI) * c.powf(self.0))
        }
    }

    #[test]
    fn narrow_lobes_cut_by_the_horizon_converge() {
        for &n in &[10.0, 1e3, 1e4] {
            for &t in &[0.0, 1.0, 1.5, 1.553, 1.569] {
                let wo = spherical(t, 0.0);
                let a = directional_albedo(&PhongLobe(n), &wo, &AlbedoQuadrature::default()).r();
                let f = directional_albedo(&PhongLobe(n), &wo, &AlbedoQuadrature::fine()).r();
                assert!((a - f).abs() < 1e-6, "n={n} θo={t}: default {a} fine {f}");
                assert!(f <= 1.0 + 1e-9, "n={n} θo={t}: {f}");
                if t == 0.0 {
                    // At normal incidence the lobe is whole: ∫ = 1 exactly.
                    assert!((f - 1.0).abs() < 1e-9, "n={n}: {f}");
                }
            }
        }
    }

    /// A microfacet-like lobe in the half vector, exp(−tan²θh/α²)/(π α² cos⁴θh) (the
    /// Beckmann D) over 4 cosθi cosθo: squeezed across the plane of incidence at grazing.
    struct HalfLobe(f64);
    impl Brdf for HalfLobe {
        fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
            if wi.z <= 0.0 || wo.z <= 0.0 {
                return Rgb::ZERO;
            }
            let h = (wi + wo).normalize();
            let c2 = h.z * h.z;
            let t2 = (1.0 - c2) / c2;
            let a2 = self.0 * self.0;
            let d = (-t2 / a2).exp() / (std::f64::consts::PI * a2 * c2 * c2);
            Rgb::splat(d / (4.0 * wi.z * wo.z))
        }
    }

    #[test]
    fn converged_albedo_resolves_squeezed_grazing_lobes() {
        let wo = spherical(89f64.to_radians(), 0.3);
        let (a, err) =
            directional_albedo_converged(&HalfLobe(0.01), &wo, &AlbedoQuadrature::default(), 1e-6);
        assert!(err <= 1e-6 * a.r(), "not converged: {err:e}");
        let reference = AlbedoQuadrature {
            order: 96,
            n_phi: 8192,
            ..AlbedoQuadrature::default()
        };
        let r = directional_albedo(&HalfLobe(0.01), &wo, &reference).r();
        assert!((a.r() - r).abs() < 2e-6 * r, "{} vs {r}", a.r());
    }

    #[test]
    fn frame_is_orthonormal() {
        for n in [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.0, 0.0, -1.0),
            spherical(1.0, 2.0),
            spherical(3.0, -1.0),
        ] {
            let (t, b) = frame_around(&n);
            assert!((t.norm() - 1.0).abs() < 1e-14 && (b.norm() - 1.0).abs() < 1e-14);
            assert!(t.dot(&b).abs() < 1e-14 && t.dot(&n).abs() < 1e-14);
            assert!(b.dot(&n).abs() < 1e-14);
        }
    }
}
