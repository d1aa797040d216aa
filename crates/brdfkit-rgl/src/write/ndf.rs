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

use std::f64::consts::PI;

/// θ of the format's u coordinate: θ = (π/2) u² (`measured.cpp`'s `u2theta`).
#[inline]
pub(crate) fn u2theta(u: f64) -> f64 {
    u * u * (PI / 2.0)
}

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
    let mut d = Ndf {
        values: vec![1.0 / PI; n],
    };
    let mut report = PowerIteration {
        iterations: 0,
        change: 0.0,
    };
    if retro.iter().all(|&r| r <= 0.0) {
        return (d, report);
    }
    let thetas: Vec<f64> = (0..n).map(|k| u2theta(k as f64 / (n - 1) as f64)).collect();
    while report.iterations < MAX_ITER {
        let mut next = Ndf {
            values: thetas
                .iter()
                .zip(retro)
                .map(|(&th, &r)| r.max(0.0) * th.cos().max(0.0) * d.sigma(th))
                .collect(),
        };
        next.normalise();
        report.change = next
            .values
            .iter()
            .zip(&d.values)
            .map(|(a, b)| (a - b).abs() / a.abs().max(1e-300))
            .filter(|c| c.is_finite())
            .fold(0.0, f64::max);
        d = next;
        report.iterations += 1;
        if report.change < TOL {
            break;
        }
    }
    let max = d.values.iter().copied().fold(0.0, f64::max);
    d.values.iter_mut().for_each(|v| *v = v.max(floor * max));
    (d, report)
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
}
