//! Scattering math shared by the microfacet models: small pure functions in the spirit
//! of pbrt-v4's `util/scattering.h`, each with the derivatives a fitter needs.
//!
//! - [`fresnel`]: Schlick, exact dielectric and exact conductor Fresnel reflectance,
//!   with ∂/∂f0, ∂/∂η, ∂/∂k;
//! - [`microfacet`]: the Beckmann and GGX normal distributions D(h), isotropic and
//!   anisotropic, with ∂D/∂αx, ∂D/∂αy;
//! - [`masking`]: Smith Λ and G1 (GGX; Beckmann exact with erf, or Walter et al.'s
//!   rational approximation), the separable and height-correlated Smith G and the
//!   V-cavity G, with their α derivatives.
//!
//! Vectors are `[f64; 3]` or separate components in the local frame (z = normal, x =
//! the tangent that carries αx), so the functions inline into structure-of-arrays
//! loops. Formulas and sources are in each module; `docs/models.md` (section
//! "Scattering math") collects them.

pub mod fresnel;
pub mod masking;
pub mod microfacet;

pub use fresnel::{
    ConductorFresnel, conductor, conductor_grad, dielectric, dielectric_grad, schlick,
};
pub use masking::{AlphaGrad, BeckmannG1, Masking, Smith, smith_g1, smith_lambda};
pub use microfacet::{DGrad, Distribution};

/// Quadrature over the hemisphere of microfacet normals, for the tests of this module.
#[cfg(test)]
pub(crate) mod test_quad {
    use crate::quadrature::gauss_legendre;
    use std::f64::consts::{FRAC_PI_2, PI};

    /// ∫ f(h) dωh over the upper hemisphere, for lobes of roughness (ax, ay) about the
    /// normal.
    ///
    /// θh: geometrically graded segments from α_min/64 up to π/2 (24-point
    /// Gauss-Legendre each), plus a break where wo·h = 0 when `cut` is given (the kink
    /// of χ⁺ and max(0, ·)). φ: per quadrant, segments graded towards the axis of the
    /// larger α, where the φ marginal of an anisotropic lobe peaks with width
    /// ~α_min/α_max (64-point Gauss-Legendre each).
    pub(crate) fn integrate_h(
        f: &dyn Fn([f64; 3]) -> f64,
        ax: f64,
        ay: f64,
        cut: Option<[f64; 3]>,
    ) -> f64 {
        let (gx, gw) = gauss_legendre(24);
        let (px, pw) = gauss_legendre(64);
        let amin = ax.min(ay);
        let mut edges = vec![0.0];
        let mut e = amin / 64.0;
        while e < FRAC_PI_2 {
            edges.push(e);
            e *= 2.0;
        }
        edges.push(FRAC_PI_2);
        let mut phi_edges = vec![0.0];
        let mut p = (amin / ax.max(ay)).max(1e-6);
        while p < FRAC_PI_2 {
            phi_edges.push(p);
            p *= 4.0;
        }
        phi_edges.push(FRAC_PI_2);
        let mut sum = 0.0;
        let mut th_edges = Vec::with_capacity(edges.len() + 1);
        for quad in 0..4 {
            for pe in phi_edges.windows(2) {
                let (pm, ph) = (0.5 * (pe[0] + pe[1]), 0.5 * (pe[1] - pe[0]));
                for (x, w) in px.iter().zip(&pw) {
                    let base = pm + ph * x;
                    let local = if ax <= ay { FRAC_PI_2 - base } else { base };
                    let phi = match quad {
                        0 => local,
                        1 => PI - local,
                        2 => PI + local,
                        _ => 2.0 * PI - local,
                    };
                    let (sp, cp) = phi.sin_cos();
                    th_edges.clear();
                    th_edges.extend_from_slice(&edges);
                    if let Some(wo) = cut {
                        // wo·h = sinθ (cp wo.x + sp wo.y) + cosθ wo.z = 0.
                        let a = cp * wo[0] + sp * wo[1];
                        if a < 0.0 {
                            let t = wo[2].atan2(-a);
                            if t > 0.0 && t < FRAC_PI_2 {
                                th_edges.push(t);
                                th_edges.sort_by(|a, b| a.total_cmp(b));
                            }
                        }
                    }
                    let mut ring = 0.0;
                    for s in th_edges.windows(2) {
                        let (m, h) = (0.5 * (s[0] + s[1]), 0.5 * (s[1] - s[0]));
                        for (u, v) in gx.iter().zip(&gw) {
                            let t = m + h * u;
                            let (st, ct) = t.sin_cos();
                            ring += v * h * f([st * cp, st * sp, ct]) * st;
                        }
                    }
                    sum += w * ph * ring;
                }
            }
        }
        sum
    }
}
