//! The microfacet normal distribution of an arbitrary isotropic source, recovered from
//! its retro-reflection by the power-iteration method of Dupuy, Heitz, Iehl, Poulin,
//! Ostromoukhov, "Extracting Microfacet-based BRDF Parameters from Arbitrary Materials
//! with Power Iterations", Computer Graphics Forum 34(4) (EGSR 2015), §4; and the
//! projected area σ that goes with it.
//!
//! In the microfacet model f(ω, ω) = F D(ω) G₁(ω) / (4 cos²θ), and Smith's masking is
//! G₁(ω) = cos θ / σ(ω) with the projected area σ(ω) = ∫ D(m) ⟨ω, m⟩₊ dm (both paper's
//! eq. 3–5). So D(ω) = (4/F) · f(ω, ω) · cos θ · σ(ω): D is the positive eigenvector of
//! the linear operator D ↦ f(ω, ω) cos θ ∫ D(m) ⟨ω, m⟩₊ dm, whose eigenvalue absorbs
//! the unknown Fresnel factor. Power iteration finds it; each step is normalised to
//! ∫ D(m) cos θm dm = 1 (the NDF's projected-area normalisation, so σ(normal) = 1).
//!
//! Everything is isotropic: D depends on θ only, tabulated at nodes uniform in the
//! format's coordinate u = √(2θ/π) (Dupuy & Jakob 2018, §4) and linear in u between
//! them — exactly what the reader's bilinear interpolant of the `ndf` table evaluates.

use crate::bsdf::{u2phi, u2theta};
use brdfkit_core::Vec3;
use brdfkit_core::direction::spherical;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Quadrature points over u ∈ [0, 1] for σ and the normalisation (midpoint rule; D is
/// piecewise linear in u with at most a few hundred pieces, so this is exact to ~1e-6).
const QUAD: usize = 2048;

/// Iterations of the power method at most, and the relative change (max over the
/// nodes) at which it stops.
const MAX_ITER: usize = 200;
const TOL: f64 = 1e-7;

/// An isotropic NDF tabulated at nodes uniform in u = √(2θ/π).
#[derive(Clone, Debug)]
pub(crate) struct Ndf {
    pub values: Vec<f64>,
}

/// ∫₀^{2π} max(0, a + b cos φ) dφ for b ≥ 0: the azimuthal integral of ⟨ω, m⟩₊ with
/// a = cos θ cos θm, b = sin θ sin θm. Where a + b cos φ changes sign, at
/// φ₀ = acos(−a/b), it is 2(a φ₀ + b sin φ₀).
fn azimuthal(a: f64, b: f64) -> f64 {
    if a >= b {
        2.0 * PI * a
    } else if a <= -b {
        0.0
    } else {
        let phi0 = (-a / b).acos();
        2.0 * (a * phi0 + b * phi0.sin())
    }
}

impl Ndf {
    /// D at u, linear between the nodes.
    pub fn eval_u(&self, u: f64) -> f64 {
        let n = self.values.len();
        let s = u.clamp(0.0, 1.0) * (n - 1) as f64;
        let i = (s as usize).min(n - 2);
        let t = s - i as f64;
        self.values[i] * (1.0 - t) + self.values[i + 1] * t
    }

    /// ∫ over the hemisphere of D(m) · g(θm) dm, in u: dm = sin θm · π u du dφ.
    fn integrate(&self, g: impl Fn(f64) -> f64) -> f64 {
        let du = 1.0 / QUAD as f64;
        (0..QUAD)
            .map(|k| {
                let u = (k as f64 + 0.5) * du;
                let th = u2theta(u);
                self.eval_u(u) * th.sin() * PI * u * g(th)
            })
            .sum::<f64>()
            * du
    }

    /// The projected area σ(θ) = ∫ D(m) ⟨ω, m⟩₊ dm of a direction at elevation θ
    /// (Dupuy et al. 2015, eq. 4), with the azimuth integrated in closed form.
    pub fn sigma(&self, theta: f64) -> f64 {
        let (s, c) = theta.sin_cos();
        self.integrate(|tm| azimuthal(c * tm.cos(), s * tm.sin()))
    }

    /// Scales D to ∫ D(m) cos θm dm = 1.
    fn normalise(&mut self) {
        let total = self.integrate(|tm| 2.0 * PI * tm.cos());
        self.values.iter_mut().for_each(|v| *v /= total);
    }
}

/// What the power iteration did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PowerIteration {
    /// Steps taken.
    pub iterations: usize,
    /// Largest relative change of a node in the last step.
    pub change: f64,
}

/// The NDF of a source whose retro-reflection luminance at the node elevations
/// θ_k = u2theta(k / (n − 1)) is `retro` (negative values count as 0), by power
/// iteration from the uniform D = 1/π. A source black in retro-reflection keeps the
/// uniform D (0 iterations). Values are then floored at `floor` × their maximum so the
/// tables built on D stay invertible (a zero D would zero the VNDF's rows and divide
/// the stored values by 0).
pub(crate) fn power_iteration(retro: &[f64], floor: f64) -> (Ndf, PowerIteration) {
    let n = retro.len();
    let d = Ndf {
        values: vec![1.0 / PI; n],
    };
    if retro.iter().all(|&r| r <= 0.0) {
        let report = PowerIteration {
            iterations: 0,
            change: 0.0,
        };
        return (d, report);
    }
    let thetas: Vec<f64> = (0..n).map(|k| u2theta(k as f64 / (n - 1) as f64)).collect();
    let (values, report) = iterate(d.values, floor, |prev| {
        let d = Ndf {
            values: prev.to_vec(),
        };
        let mut next = Ndf {
            values: thetas
                .iter()
                .zip(retro)
                .map(|(&th, &r)| r.max(0.0) * th.cos().max(0.0) * d.sigma(th))
                .collect(),
        };
        next.normalise();
        next.values
    });
    (Ndf { values }, report)
}

/// The power method's loop, for the 1-D and the 2-D NDF: `step` maps D (node values) to
/// the next, normalised D, from `start`, until no node changes by [`TOL`] relative or
/// after [`MAX_ITER`] steps; then every node is floored at `floor` × the maximum.
fn iterate(
    start: Vec<f64>,
    floor: f64,
    mut step: impl FnMut(&[f64]) -> Vec<f64>,
) -> (Vec<f64>, PowerIteration) {
    let mut d = start;
    let mut report = PowerIteration {
        iterations: 0,
        change: 0.0,
    };
    while report.iterations < MAX_ITER {
        let next = step(&d);
        report.change = relative_change(&next, &d);
        d = next;
        report.iterations += 1;
        if report.change < TOL {
            break;
        }
    }
    let max = d.iter().copied().fold(0.0, f64::max);
    d.iter_mut().for_each(|v| *v = v.max(floor * max));
    (d, report)
}

/// An NDF of an anisotropic source on `rows` × `cols` nodes: rows uniform in the half
/// vector's absolute azimuth u_φ = (φ + π)/2π over [0, 1] (the first and the last row are
/// both φ = ±π), columns uniform in u_θ = √(2θ/π); bilinear between them, as the reader
/// interpolates an anisotropic file's `ndf` (and `sigma`) table (`measured.cpp`: u_m's
/// φ is absolute when the file has more than two φi slices).
#[derive(Clone, Debug)]
pub(crate) struct Ndf2 {
    pub rows: usize,
    pub cols: usize,
    /// Row-major: `values[row * cols + col]`.
    pub values: Vec<f64>,
}

/// The σ grid of the 2-D iteration (u_φ rows × u_θ columns): σ is an integral of D
/// against a clamped cosine, smooth even where D is sharp, so the iteration evaluates it
/// on this moderate grid and interpolates it to the NDF's nodes.
const SIGMA_ROWS: usize = 33;
const SIGMA_COLS: usize = 64;

/// Azimuths of the 2-D quadrature (midpoints of a uniform partition of [−π, π)).
const QUAD_PHI: usize = 64;

impl Ndf2 {
    /// D at grid coordinates u = (u_θ, u_φ), bilinear between the nodes.
    pub fn eval(&self, u: [f64; 2]) -> f64 {
        let at = |x: f64, n: usize| {
            let s = x.clamp(0.0, 1.0) * (n - 1) as f64;
            let i = (s as usize).min(n - 2);
            (i, s - i as f64)
        };
        let ((c, tc), (r, tr)) = (at(u[0], self.cols), at(u[1], self.rows));
        let v = |r: usize, c: usize| self.values[r * self.cols + c];
        let row = |r: usize| v(r, c) * (1.0 - tc) + v(r, c + 1) * tc;
        row(r) * (1.0 - tr) + row(r + 1) * tr
    }

    /// The grid coordinates (u_θ, u_φ) of node `k`.
    fn node(&self, k: usize) -> [f64; 2] {
        let (r, c) = (k / self.cols, k % self.cols);
        [
            c as f64 / (self.cols - 1) as f64,
            r as f64 / (self.rows - 1) as f64,
        ]
    }
}

/// Quadrature over the hemisphere of half vectors in (u_θ, φ): midpoints, dm =
/// sin θ · πu du · dφ. u_θ has three points per interval of a `cols`-node grid, so
/// each point lies inside one linear piece of D.
struct Quad {
    u: Vec<[f64; 2]>,
    m: Vec<Vec3>,
    dm: Vec<f64>,
}

impl Quad {
    fn new(cols: usize) -> Quad {
        let nt = 3 * (cols - 1);
        let (du, dphi) = (1.0 / nt as f64, 2.0 * PI / QUAD_PHI as f64);
        let mut q = Quad {
            u: Vec::with_capacity(nt * QUAD_PHI),
            m: Vec::with_capacity(nt * QUAD_PHI),
            dm: Vec::with_capacity(nt * QUAD_PHI),
        };
        for j in 0..QUAD_PHI {
            let phi = -PI + (j as f64 + 0.5) * dphi;
            for i in 0..nt {
                let u = (i as f64 + 0.5) * du;
                let th = u2theta(u);
                q.u.push([u, (phi + PI) / (2.0 * PI)]);
                q.m.push(spherical(th, phi));
                q.dm.push(th.sin() * PI * u * du * dphi);
            }
        }
        q
    }

    /// D · dm at the points.
    fn weights(&self, d: &Ndf2) -> Vec<f64> {
        self.u
            .iter()
            .zip(&self.dm)
            .map(|(&u, &w)| d.eval(u) * w)
            .collect()
    }

    /// σ(ω) = ∫ D(m) ⟨ω, m⟩₊ dm (Dupuy et al. 2015, eq. 4; Heitz 2014, "Understanding
    /// the Masking-Shadowing Function": the projected area, for any D, anisotropic
    /// included) at `rows` × `cols` nodes, from the point weights `wd` = D · dm. No
    /// closed form in φ here: D depends on the half vector's azimuth.
    fn sigma(&self, wd: &[f64], rows: usize, cols: usize) -> Ndf2 {
        let mut grid = Ndf2 {
            rows,
            cols,
            values: vec![0.0; rows * cols],
        };
        let dirs: Vec<Vec3> = (0..rows * cols)
            .map(|k| {
                let u = grid.node(k);
                spherical(u2theta(u[0]), u2phi(u[1]))
            })
            .collect();
        grid.values = dirs
            .par_iter()
            .map(|w| {
                self.m
                    .iter()
                    .zip(wd)
                    .map(|(m, &x)| x * w.dot(m).max(0.0))
                    .sum()
            })
            .collect();
        grid
    }

    /// ∫ D(m) cos θm dm.
    fn projected(&self, d: &Ndf2) -> f64 {
        self.weights(d)
            .iter()
            .zip(&self.m)
            .map(|(x, m)| x * m.z)
            .sum()
    }
}

/// The 2-D counterpart of [`power_iteration`] for an anisotropic source: its
/// retro-reflection luminance `retro` at the nodes of a `rows` × `cols` grid ([`Ndf2`]:
/// rows over the absolute u_φ, columns over u_θ), iterated from D = 1/π by
/// D(ω) ← f(ω, ω) cos θ σ(ω), σ(ω) = ∫ D(m) ⟨ω, m⟩₊ dm (Dupuy et al. 2015, §4, whose
/// derivation holds for an anisotropic D: nothing in f(ω, ω) = F D(ω) G₁(ω)/(4 cos²θ),
/// G₁ = cos θ / σ(ω), assumes isotropy), each step normalised to ∫ D cos θm dm = 1.
/// σ is evaluated on the moderate [`SIGMA_ROWS`] × [`SIGMA_COLS`] grid and interpolated
/// to the nodes (it is smooth where D is not); D stays at the full resolution. Stops as
/// the 1-D iteration; floored at `floor` × the maximum. Returns D and its σ on the same
/// `rows` × `cols` grid (the `sigma` table).
pub(crate) fn power_iteration_2d(
    retro: &[f64],
    rows: usize,
    cols: usize,
    floor: f64,
) -> (Ndf2, Ndf2, PowerIteration) {
    let quad = Quad::new(cols);
    let uniform = vec![1.0 / PI; rows * cols];
    let grid = |values: Vec<f64>| Ndf2 { rows, cols, values };
    let (values, report) = if retro.iter().any(|&r| r > 0.0) {
        iterate(uniform, floor, |prev| {
            let d = grid(prev.to_vec());
            let sigma = quad.sigma(&quad.weights(&d), SIGMA_ROWS, SIGMA_COLS);
            let mut next = grid(
                (0..rows * cols)
                    .map(|k| {
                        let u = d.node(k);
                        retro[k].max(0.0) * u2theta(u[0]).cos().max(0.0) * sigma.eval(u)
                    })
                    .collect(),
            );
            let total = quad.projected(&next);
            next.values.iter_mut().for_each(|v| *v /= total);
            next.values
        })
    } else {
        let report = PowerIteration {
            iterations: 0,
            change: 0.0,
        };
        (uniform, report)
    };
    let d = grid(values);
    let sigma = quad.sigma(&quad.weights(&d), rows, cols);
    (d, sigma, report)
}

/// The largest relative change of a node between two steps.
fn relative_change(next: &[f64], prev: &[f64]) -> f64 {
    next.iter()
        .zip(prev)
        .map(|(a, b)| (a - b).abs() / a.abs().max(1e-300))
        .filter(|c| c.is_finite())
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Beckmann D (normalised so ∫ D cos θ dm = 1) at θ.
    fn beckmann(alpha: f64, th: f64) -> f64 {
        let t2 = th.tan().powi(2);
        let c4 = th.cos().powi(4);
        (-t2 / (alpha * alpha)).exp() / (PI * alpha * alpha * c4)
    }

    /// Smith's Λ for Beckmann.
    fn beckmann_sigma(alpha: f64, th: f64) -> f64 {
        if th < 1e-9 {
            return 1.0;
        }
        let a = 1.0 / (alpha * th.tan());
        let lambda = ((-a * a).exp() / (a * PI.sqrt()) - libm_erfc(a)) / 2.0;
        th.cos() * (1.0 + lambda)
    }

    /// erfc by its continued-fraction-free rational approximation (Abramowitz & Stegun
    /// 7.1.26, |error| < 1.5e-7): enough for a 1e-4 check.
    fn libm_erfc(x: f64) -> f64 {
        let t = 1.0 / (1.0 + 0.3275911 * x);
        let poly = t
            * (0.254829592
                + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
        poly * (-x * x).exp()
    }

    fn tabulated(alpha: f64, n: usize) -> Ndf {
        Ndf {
            values: (0..n)
                .map(|k| {
                    let th = u2theta(k as f64 / (n - 1) as f64);
                    if th >= PI / 2.0 - 1e-9 {
                        0.0
                    } else {
                        beckmann(alpha, th)
                    }
                })
                .collect(),
        }
    }

    /// σ against Smith's closed form for Beckmann (σ = cos θ (1 + Λ)), and the
    /// normalisation ∫ D cos = 1 of a tabulated Beckmann.
    #[test]
    fn sigma_matches_smith_for_beckmann() {
        let d = tabulated(0.5, 512);
        let total = d.integrate(|tm| 2.0 * PI * tm.cos());
        assert!((total - 1.0).abs() < 2e-3, "∫ D cos = {total}");
        for deg in [0.0f64, 20.0, 45.0, 70.0, 85.0] {
            let th = deg.to_radians();
            let (ours, want) = (d.sigma(th) / total, beckmann_sigma(0.5, th));
            assert!(
                (ours - want).abs() < 3e-3 * want,
                "σ({deg}°) = {ours}, Smith {want}"
            );
        }
    }

    /// The azimuthal integral against a brute-force sum.
    #[test]
    fn azimuthal_closed_form() {
        for (a, b) in [(0.5, 0.2), (0.1, 0.7), (-0.3, 0.5), (-0.6, 0.5), (0.0, 1.0)] {
            let n = 200_000;
            let brute: f64 = (0..n)
                .map(|k| {
                    let phi = (k as f64 + 0.5) * 2.0 * PI / n as f64;
                    (a + b * phi.cos()).max(0.0)
                })
                .sum::<f64>()
                * 2.0
                * PI
                / n as f64;
            assert!((azimuthal(a, b) - brute).abs() < 1e-8, "{a} {b}");
        }
    }

    /// A Cook-Torrance-like retro-reflection f(ω, ω) = D(ω) G₁(ω) / (4 cos²θ) built from
    /// a Beckmann D gives that D back (up to the discretisation), as Dupuy et al. 2015
    /// show for microfacet BRDFs.
    #[test]
    fn power_iteration_recovers_beckmann() {
        let n = 128;
        let alpha = 0.3;
        let retro: Vec<f64> = (0..n)
            .map(|k| {
                let th = u2theta(k as f64 / (n - 1) as f64).min(PI / 2.0 - 1e-3);
                let g1 = th.cos() / beckmann_sigma(alpha, th);
                0.7 * beckmann(alpha, th) * g1 / (4.0 * th.cos().powi(2))
            })
            .collect();
        let (d, rep) = power_iteration(&retro, 0.0);
        assert!(rep.change < TOL, "{rep:?}");
        for k in (0..n).step_by(8) {
            let th = u2theta(k as f64 / (n - 1) as f64);
            let want = beckmann(alpha, th);
            if th > 1.2 {
                break;
            }
            let got = d.values[k];
            assert!(
                (got - want).abs() < 1e-2 * want + 1e-6,
                "θ = {th}: D {got}, Beckmann {want}"
            );
        }
    }

    /// Anisotropic Beckmann D (Heitz 2014, "Understanding the Masking-Shadowing
    /// Function": the isotropic form with 1/α² → cos²φ/αx² + sin²φ/αy², normalised by
    /// π αx αy), ∫ D cos θ dm = 1.
    fn beckmann_aniso(ax: f64, ay: f64, th: f64, phi: f64) -> f64 {
        let e = th.tan().powi(2) * ((phi.cos() / ax).powi(2) + (phi.sin() / ay).powi(2));
        (-e).exp() / (PI * ax * ay * th.cos().powi(4))
    }

    /// The retro-reflection F D G₁ / (4 cos²θ) of an anisotropic Beckmann surface at
    /// the nodes of a `rows` × `cols` grid, with Smith's σ = cos θ (1 + Λ) for the
    /// projected roughness α(φ) = √(cos²φ αx² + sin²φ αy²) (Heitz 2014, its anisotropic
    /// Smith masking).
    fn retro_aniso(ax: f64, ay: f64, rows: usize, cols: usize) -> Vec<f64> {
        (0..rows * cols)
            .map(|k| {
                let (r, c) = (k / cols, k % cols);
                let th = u2theta(c as f64 / (cols - 1) as f64).min(PI / 2.0 - 1e-3);
                let phi = u2phi(r as f64 / (rows - 1) as f64);
                let a = ((phi.cos() * ax).powi(2) + (phi.sin() * ay).powi(2)).sqrt();
                let g1 = th.cos() / beckmann_sigma(a, th);
                0.7 * beckmann_aniso(ax, ay, th, phi) * g1 / (4.0 * th.cos().powi(2))
            })
            .collect()
    }

    /// The 2-D iteration on an anisotropic Beckmann retro-reflection (αx = 0.3, αy =
    /// 0.15) gives that D back within 2 % (+1e-6) wherever θ < 1.2, and its σ table is
    /// Smith's closed form within 1.5 % (measured: 5.4e-4 and 0.75 %).
    #[test]
    fn power_iteration_2d_recovers_anisotropic_beckmann() {
        let (rows, cols, ax, ay) = (65, 128, 0.3, 0.15);
        let (d, sigma, rep) = power_iteration_2d(&retro_aniso(ax, ay, rows, cols), rows, cols, 0.0);
        assert!(rep.change < TOL, "{rep:?}");
        let (mut worst_d, mut worst_s) = (0.0f64, 0.0f64);
        for k in 0..rows * cols {
            let u = d.node(k);
            let (th, phi) = (u2theta(u[0]), u2phi(u[1]));
            if th < 1.2 {
                let want = beckmann_aniso(ax, ay, th, phi);
                let err = (d.values[k] - want).abs() / (want + 1e-6 / 2e-2);
                worst_d = worst_d.max(err);
            }
            let a = ((phi.cos() * ax).powi(2) + (phi.sin() * ay).powi(2)).sqrt();
            let want = beckmann_sigma(a, th.min(PI / 2.0 - 1e-3));
            worst_s = worst_s.max((sigma.values[k] - want).abs() / want);
        }
        eprintln!("2-D Beckmann: D within {worst_d:.2e}, σ within {worst_s:.2e} ({rep:?})");
        assert!(worst_d < 2e-2, "D off by {worst_d}");
        assert!(worst_s < 1.5e-2, "σ off by {worst_s}");
    }

    /// On an isotropic retro-reflection the 2-D iteration gives every row of D equal to
    /// the 1-D iteration's D (within 0.5 %: the two integrate σ differently).
    #[test]
    fn power_iteration_2d_reduces_to_1d_when_isotropic() {
        let (rows, cols, alpha) = (17, 128, 0.3);
        let retro_1d: Vec<f64> = retro_aniso(alpha, alpha, 2, cols)[..cols].to_vec();
        let retro: Vec<f64> = (0..rows).flat_map(|_| retro_1d.iter().copied()).collect();
        let (d1, _) = power_iteration(&retro_1d, 0.0);
        let (d2, _, _) = power_iteration_2d(&retro, rows, cols, 0.0);
        let peak = d1.values.iter().copied().fold(0.0, f64::max);
        let worst = (0..rows * cols)
            .map(|k| {
                (d2.values[k] - d1.values[k % cols]).abs() / (d1.values[k % cols] + 1e-6 * peak)
            })
            .fold(0.0, f64::max);
        eprintln!("2-D vs 1-D on an isotropic retro-reflection: within {worst:.2e}");
        assert!(worst < 5e-3, "rows differ from the 1-D D by {worst}");
    }
}
