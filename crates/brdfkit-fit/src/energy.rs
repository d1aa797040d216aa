//! Energy conservation as a fit option: the directional albedo a_c(ωi) ≤ a_max.
//!
//! The directional albedo of channel c is
//!
//! ```text
//! a_c(ωi) = ∫_{H²} f_c(ωi, ωo) cos θo dωo
//! ```
//!
//! (the fraction of light from ωi reflected anywhere; energy conservation is a_c ≤ 1 for
//! every ωi; E. P. Lafortune, Y. D. Willems, "Using the modified Phong reflectance model
//! for physically based rendering", 1994, §2). A bound on a raw parameter (ρs ≤ 1) is not
//! this: with a Fresnel factor or a normalised lobe ρs may exceed 1 while a stays below 1,
//! and conversely.
//!
//! **Quadrature.** A fixed set of incidence directions (θi ∈ {0, 30, 50, 65, 75, 85}°,
//! φi ∈ {0, 90°}: the latter for anisotropic lobes) and, per direction, a fixed rule
//! over the half vector h: ωo = 2 (ωi·h) h − ωi, dωo = 4 (ωi·h) dωh (the Jacobian of the
//! half-vector map, K. E. Torrance, E. M. Sparrow 1967; Walter et al. 2007 eq. 14), with
//! θh = (π/2) t³ on a midpoint rule in t (dense near the mirror direction, where a sharp
//! lobe's mass is; the first node is at θh ≈ 6e-6 rad) and φh uniform. Pairs with
//! ωi·h ≤ 0 or ωo below the horizon are left out (the map is one-to-one on the rest).
//! Exact for a Lambertian term to 1e-4; a lobe narrower than the node spacing near the
//! peak (GGX α below ≈ 1e-3) is under-resolved.
//!
//! **How it enters the fit: a penalty residual block.** For every quadrature direction j
//! and active channel c, r_cj = √λ · max(0, a_cj − a_max), added to the least-squares
//! residuals; its Jacobian row is √λ Σ_q w_q ∂f_c/∂x_p · dx_p/du (from
//! [`Model::eval_grad`]), zero where the constraint is inactive. A quadratic penalty
//! keeps the problem smooth (one-sided, C¹), needs no change to the solvers, and acts only
//! where the albedo exceeds the bound; a projection would need a feasible point of a
//! nonlinear set after every step. λ = [`PENALTY_WEIGHT`] × the targets' mean square, so
//! the residual violation at the optimum is ~ the loss gradient over λ (measured ≤ 1e-4,
//! reported in the record as the largest albedo).

use brdfkit_core::{Model, Rgb, Vec3};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

/// The penalty's weight relative to the targets' weighted mean square.
pub const PENALTY_WEIGHT: f64 = 1e4;

/// Incidence elevations of the constraint, degrees.
const THETA_I_DEG: [f64; 6] = [0.0, 30.0, 50.0, 65.0, 75.0, 85.0];
/// Nodes in t (θh = (π/2) t³) and in φh.
const NT: usize = 64;
const NPHI: usize = 16;

/// One quadrature node: the outgoing direction and its weight w = cos θo · 4 (ωi·h) ·
/// sin θh · dθh · dφh.
#[derive(Debug, Clone, Copy)]
struct Node {
    wo: Vec3,
    w: f64,
}

/// The fixed quadrature of the albedo over a set of incidence directions.
#[derive(Debug, Clone)]
pub struct AlbedoQuadrature {
    dirs: Vec<(Vec3, Vec<Node>)>,
}

impl Default for AlbedoQuadrature {
    fn default() -> Self {
        Self::new()
    }
}

impl AlbedoQuadrature {
    /// The quadrature of the module doc.
    pub fn new() -> Self {
        use std::f64::consts::{FRAC_PI_2, PI};
        let mut dirs = Vec::new();
        for &td in &THETA_I_DEG {
            let phis: &[f64] = if td == 0.0 { &[0.0] } else { &[0.0, FRAC_PI_2] };
            for &pi in phis {
                let ti = td.to_radians();
                let wi = Vec3::new(ti.sin() * pi.cos(), ti.sin() * pi.sin(), ti.cos());
                let mut nodes = Vec::with_capacity(NT * NPHI);
                for a in 0..NT {
                    let t = (a as f64 + 0.5) / NT as f64;
                    let th = FRAC_PI_2 * t * t * t;
                    let dth = FRAC_PI_2 * 3.0 * t * t / NT as f64;
                    for b in 0..NPHI {
                        let ph = 2.0 * PI * (b as f64 + 0.5) / NPHI as f64;
                        let h = Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
                        let ih = wi.dot(&h);
                        if ih <= 0.0 {
                            continue;
                        }
                        let wo = 2.0 * ih * h - wi;
                        if wo.z <= 0.0 {
                            continue;
                        }
                        let w = wo.z * 4.0 * ih * th.sin() * dth * (2.0 * PI / NPHI as f64);
                        nodes.push(Node { wo, w });
                    }
                }
                dirs.push((wi, nodes));
            }
        }
        AlbedoQuadrature { dirs }
    }

    /// Number of incidence directions.
    pub fn len(&self) -> usize {
        self.dirs.len()
    }

    /// True when there is no direction (never, for [`AlbedoQuadrature::new`]).
    pub fn is_empty(&self) -> bool {
        self.dirs.is_empty()
    }

    /// The albedo per channel at every incidence direction.
    pub fn albedos(&self, m: &dyn Model) -> Vec<Rgb> {
        self.dirs
            .par_iter()
            .map(|(wi, nodes)| {
                let mut a = Rgb::ZERO;
                for n in nodes {
                    let f = m.eval(wi, &n.wo);
                    for c in 0..3 {
                        a[c] += n.w * f[c];
                    }
                }
                a
            })
            .collect()
    }

    /// The largest albedo over the directions and channels.
    pub fn max_albedo(&self, m: &dyn Model) -> f64 {
        self.albedos(m).iter().flat_map(|a| a.0).fold(0.0, f64::max)
    }

    /// The albedo and its gradient with respect to every model parameter, per
    /// direction: (a, ∂a/∂x_p).
    fn albedos_grad(&self, m: &dyn Model) -> Vec<(Rgb, Vec<Rgb>)> {
        let np = m.num_params();
        self.dirs
            .par_iter()
            .map(|(wi, nodes)| {
                let mut a = Rgb::ZERO;
                let mut ga = vec![Rgb::ZERO; np];
                let mut g = vec![Rgb::ZERO; np];
                for n in nodes {
                    let f = m.eval_grad(wi, &n.wo, &mut g);
                    for c in 0..3 {
                        a[c] += n.w * f[c];
                    }
                    for (acc, gp) in ga.iter_mut().zip(&g) {
                        for c in 0..3 {
                            acc[c] += n.w * gp[c];
                        }
                    }
                }
                (a, ga)
            })
            .collect()
    }
}

/// The albedo penalty of a fit: the quadrature, the bound and the weight λ.
#[derive(Debug, Clone)]
pub struct AlbedoPenalty {
    /// The quadrature.
    pub quad: AlbedoQuadrature,
    /// The bound a_max.
    pub max: f64,
    /// λ (in the units of the cost).
    pub lambda: f64,
}

impl AlbedoPenalty {
    /// The penalty's share of the cost, ½ Σ r², at a model.
    pub fn cost(&self, m: &dyn Model, channels: &[usize]) -> f64 {
        let mut s = 0.0;
        for a in self.quad.albedos(m) {
            for &c in channels {
                let v = (a[c] - self.max).max(0.0);
                s += v * v;
            }
        }
        0.5 * self.lambda * s
    }

    /// Adds the penalty's JᵀJ, Jᵀr and cost to `jtj`, `jtr` and returns its cost, at a
    /// model whose free parameters are `free` with dx/du `dx`.
    pub fn add_normal_eq(
        &self,
        m: &dyn Model,
        free: &[usize],
        dx: &[f64],
        channels: &[usize],
        jtj: &mut DMatrix<f64>,
        jtr: &mut DVector<f64>,
    ) -> f64 {
        let sl = self.lambda.sqrt();
        let mut cost = 0.0;
        let mut row = vec![0.0; free.len()];
        for (a, ga) in self.quad.albedos_grad(m) {
            for &c in channels {
                let v = a[c] - self.max;
                if v <= 0.0 {
                    continue;
                }
                let r = sl * v;
                cost += 0.5 * r * r;
                for (q, &p) in free.iter().enumerate() {
                    row[q] = sl * ga[p][c] * dx[q];
                }
                for i in 0..row.len() {
                    jtr[i] += row[i] * r;
                    for j in 0..row.len() {
                        jtj[(i, j)] += row[i] * row[j];
                    }
                }
            }
        }
        cost
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambert_albedo_is_rho_d() {
        let m = brdfkit_models::from_json_str(
            r#"{"model":"lambert","params":{"rho_d":[1.0,0.5,0.25]}}"#,
        )
        .unwrap();
        let q = AlbedoQuadrature::new();
        for a in q.albedos(m.as_ref()) {
            assert!((a[0] - 1.0).abs() < 2e-3, "{a:?}");
            assert!((a[1] - 0.5).abs() < 1e-3, "{a:?}");
        }
    }

    #[test]
    fn penalty_gradient_matches_differences() {
        let m = brdfkit_models::from_json_str(
            r#"{"model":"cook-torrance","params":{"rho_d":[0.9,0.9,0.9],"rho_s":[4.0,2.0,2.0],"alpha":0.3}}"#,
        )
        .unwrap();
        let pen = AlbedoPenalty {
            quad: AlbedoQuadrature::new(),
            max: 1.0,
            lambda: 1.0,
        };
        let free: Vec<usize> = (0..m.num_params()).filter(|&p| p < 7).collect();
        let dx = vec![1.0; free.len()];
        let n = free.len();
        let mut jtj = DMatrix::zeros(n, n);
        let mut jtr = DVector::zeros(n);
        let c0 = pen.add_normal_eq(m.as_ref(), &free, &dx, &[0, 1, 2], &mut jtj, &mut jtr);
        assert!(c0 > 0.0);
        assert!((c0 - pen.cost(m.as_ref(), &[0, 1, 2])).abs() < 1e-12 * c0.max(1.0));
        let x0 = m.params();
        for (q, &p) in free.iter().enumerate() {
            let h = 1e-6;
            let at = |d: f64| {
                let mut mm = m.clone_box();
                let mut x = x0.clone();
                x[p] += d;
                mm.set_params(&x).unwrap();
                pen.cost(mm.as_ref(), &[0, 1, 2])
            };
            let fd = (at(h) - at(-h)) / (2.0 * h);
            assert!(
                (fd - jtr[q]).abs() <= 1e-5 * fd.abs().max(1e-3),
                "param {p}: {fd} vs {}",
                jtr[q]
            );
        }
    }
}
