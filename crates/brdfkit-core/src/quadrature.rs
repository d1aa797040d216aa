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
//! graded segments, each integrated by Gauss-Legendre, and φ by the trapezoid rule
//! (spectrally accurate for periodic integrands). For each φ the u integral ends
//! exactly at the horizon, so smooth integrands converge spectrally: a Lambertian
//! albedo comes out exact to round-off for poles up to ~70° from the normal; with the
//! pole within a degree or two of the horizon the φ integrand turns sharp and the
//! error rises to 2e-5 (default rule) or 1e-7 ([`AlbedoQuadrature::fine`]), as the
//! tests measure.

use crate::{Brdf, Rgb, Vec3};

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
            order: 16,
            n_phi: 128,
        }
    }
}

impl AlbedoQuadrature {
    /// A finer rule (4x the work of the default), for convergence checks.
    pub fn fine() -> Self {
        AlbedoQuadrature {
            order: 32,
            n_phi: 256,
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
/// For each azimuth φ about the pole, u runs from 0 to the horizon crossing
/// u_max(φ) = atan2(p.z, −(cosφ t.z + sinφ b.z)), the root in (0, π) of wi.z = 0,
/// so no Gauss segment straddles the horizon. An outgoing direction at or below the
/// horizon has albedo 0.
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
    let (gx, gw) = gauss_legendre(q.order);
    let dphi = 2.0 * std::f64::consts::PI / q.n_phi as f64;
    let mut sum = Rgb::ZERO;
    let mut edges = Vec::with_capacity(q.edges.len() + 1);
    for m in 0..q.n_phi {
        let phi = (m as f64 + 0.5) * dphi;
        let (sp, cp) = phi.sin_cos();
        let a = cp * t.z + sp * b.z;
        let u_max = pole.z.atan2(-a);
        edges.clear();
        edges.extend(q.edges.iter().copied().filter(|&u| u < u_max));
        edges.push(u_max);
        let dir = cp * t + sp * b;
        let mut ring = Rgb::ZERO;
        for seg in edges.windows(2) {
            let half = 0.5 * (seg[1] - seg[0]);
            let mid = 0.5 * (seg[1] + seg[0]);
            for (x, w) in gx.iter().zip(&gw) {
                let u = mid + half * x;
                let (su, cu) = u.sin_cos();
                let wi = su * dir + cu * pole;
                // Round-off can put the last node a hair below the horizon.
                if wi.z <= 0.0 {
                    continue;
                }
                ring += brdf.eval(&wi, wo) * (wi.z * w * half * su);
            }
        }
        sum += ring;
    }
    sum * dphi
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
        // Exact to round-off wherever the pole is well above the horizon; with the pole
        // within 1.2° of the horizon the φ integrand turns sharp and the default rule
        // gives 2e-5 (fine rule: 1e-7), as measured here.
        let f = Constant(0.8 / std::f64::consts::PI);
        for pole in [Pole::Mirror, Pole::Retro, Pole::Normal] {
            for &t in &[0.0, 0.5, 1.2, 1.55] {
                let wo = spherical(t, 0.3);
                let q = AlbedoQuadrature::default().with_pole(pole);
                let err = (directional_albedo(&f, &wo, &q).r() - 0.8).abs();
                let fine = AlbedoQuadrature::fine().with_pole(pole);
                let err_fine = (directional_albedo(&f, &wo, &fine).r() - 0.8).abs();
                let (tol, tol_fine) = if t > 1.5 && pole != Pole::Normal {
                    (5e-5, 5e-7)
                } else {
                    (1e-12, 1e-12)
                };
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
