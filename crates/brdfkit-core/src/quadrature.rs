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
/// [`directional_albedo`] takes an n_phi-point rule for every arc, and n_phi grows
/// like 16/cos θ near grazing (thousands of nodes): Newton's iteration over the
/// three-term recurrence costs O(n²) a rule, more than the integral itself for a cheap
/// BRDF, and the same few orders (powers of two) come back for every direction. The
/// rules are the function's own values (the same bits). Rules above 2¹⁶ nodes (a
/// direction within 0.02° of the horizon) are not kept.
fn gauss_legendre_shared(n: usize) -> Rule {
    static RULES: OnceLock<Mutex<HashMap<usize, Rule>>> = OnceLock::new();
    const KEPT_MAX: usize = 1 << 16;
    let rules = RULES.get_or_init(|| Mutex::new(HashMap::new()));
    // A poisoned lock only means another thread panicked while inserting: compute.
    if let Some(r) = rules.lock().ok().and_then(|m| m.get(&n).cloned()) {
        return r;
    }
    let r = Arc::new(gauss_legendre(n));
    if n <= KEPT_MAX
        && let Ok(mut m) = rules.lock()
    {
        m.entry(n).or_insert_with(|| r.clone());
    }
    r
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

/// Directional albedo a(wo) = ∫ f(wi, wo) cos θi dωi over the upper hemisphere.
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
pub fn directional_albedo(brdf: &dyn Brdf, wo: &Vec3, q: &AlbedoQuadrature) -> Rgb {
    if wo.z <= 0.0 {
        return Rgb::ZERO;
    }
    let pole = match q.pole {
        Pole::Mirror => Vec3::new(-wo.x, -wo.y, wo.z),
        Pole::Retro => *wo,
        Pole::Normal => Vec3::new(0.0, 0.0, 1.0),
    };
    let (t, b) = frame_around(&pole);
    let amp = t.z.hypot(b.z);
    let phi0 = b.z.atan2(t.z);
    let theta_p = pole.z.clamp(-1.0, 1.0).acos();
    let half_pi = std::f64::consts::FRAC_PI_2;
    let u_near = half_pi - theta_p;
    let u_far = half_pi + theta_p;
    let mut edges: Vec<f64> = q.edges.iter().copied().filter(|&u| u < u_far).collect();
    edges.push(u_far);
    if u_near > 0.0 && !edges.contains(&u_near) {
        edges.push(u_near);
    }
    edges.sort_by(f64::total_cmp);

    let g_rule = gauss_legendre_shared(q.order);
    let (gx, gw) = (&g_rule.0, &g_rule.1);
    let n_arc = q.n_phi.max(2);
    let a_rule = gauss_legendre_shared(n_arc);
    let (ax, aw) = (&a_rule.0, &a_rule.1);
    let dphi = 2.0 * std::f64::consts::PI / q.n_phi as f64;
    // The whole rings (u < u_near) all sample the same azimuths φ0 + (m + ½) Δφ: their
    // in-plane directions cos φ t + sin φ b are computed once, not once a ring (a
    // sin_cos a node was a third of a cheap BRDF's integral). The same bits: each node
    // is still su · (cos φ t + sin φ b) + cu · p, in that order.
    let ring_dirs: Vec<Vec3> = (0..q.n_phi)
        .map(|m| {
            let (sp, cp) = (phi0 + (m as f64 + 0.5) * dphi).sin_cos();
            cp * t + sp * b
        })
        .collect();
    let ring = |u: f64| -> Rgb {
        let (su, cu) = u.sin_cos();
        let node = |d: &Vec3| -> Rgb {
            let wi = su * d + cu * pole;
            // Round-off can put a node at an arc end a hair below the horizon.
            if wi.z <= 0.0 {
                Rgb::ZERO
            } else {
                brdf.eval(&wi, wo) * wi.z
            }
        };
        let at = |phi: f64| -> Rgb {
            let (sp, cp) = phi.sin_cos();
            node(&(cp * t + sp * b))
        };
        // cos(φ − φ0) > c on the visible part of the ring.
        let c = if su * amp > 0.0 {
            -cu * pole.z / (su * amp)
        } else if cu * pole.z > 0.0 {
            f64::NEG_INFINITY
        } else {
            f64::INFINITY
        };
        if c <= -1.0 {
            let mut s = Rgb::ZERO;
            for d in &ring_dirs {
                s += node(d);
            }
            s * dphi
        } else if c >= 1.0 {
            Rgb::ZERO
        } else {
            let half = c.acos();
            let mut s = Rgb::ZERO;
            for (x, w) in ax.iter().zip(aw) {
                s += at(phi0 + half * x) * *w;
            }
            s * half
        }
    };
    let mut sum = Rgb::ZERO;
    for seg in edges.windows(2) {
        let (a, c) = (seg[0], seg[1]);
        if c <= a {
            continue;
        }
        // Past u_near and before u_far the arc half-width grows like a square root, so
        // those segments take the smoothstep substitution u = a + (c − a)(3s² − 2s³),
        // whose vanishing end derivatives turn √ into a smooth function of s.
        let smooth = a == u_near || c == u_far;
        for (x, w) in gx.iter().zip(gw) {
            let s01 = 0.5 * (x + 1.0);
            let (u, du) = if smooth {
                let u = a + (c - a) * s01 * s01 * (3.0 - 2.0 * s01);
                (u, (c - a) * 6.0 * s01 * (1.0 - s01) * 0.5)
            } else {
                (a + (c - a) * s01, 0.5 * (c - a))
            };
            sum += ring(u) * (w * du * u.sin());
        }
    }
    sum
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
