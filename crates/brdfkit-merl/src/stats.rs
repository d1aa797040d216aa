//! Table statistics for the command line: coverage, value ranges and directional albedo.

use crate::grid::Dims;
use crate::lookup::Lookup;
use crate::table::{MerlTable, SCALES};
use brdfkit_core::Rgb;
use brdfkit_core::direction::spherical;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Minimum, median and maximum of one channel over the valid cells (physical units).
/// The median of an even count is the mean of the two middle values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelStats {
    /// Minimum.
    pub min: f64,
    /// Median.
    pub median: f64,
    /// Maximum.
    pub max: f64,
}

/// Directional albedo a(θo) = ∫ f(wi, wo) cos θi dωi at one outgoing angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlbedoSample {
    /// Polar angle of wo (radians); its azimuth is 0.
    pub theta_o: f64,
    /// The albedo, `None` when every quadrature node fell on missing cells.
    pub albedo: Option<Rgb>,
    /// Fraction of the quadrature's cosine weight whose lookups were missing (filled
    /// with the cosine-weighted mean of the others; see [`MerlTable::albedo`]).
    pub missing_weight: f64,
}

/// Quadrature over the incident hemisphere for [`MerlTable::albedo`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Quadrature {
    /// Gauss–Legendre nodes in μ = cos θi over (0, 1).
    pub n_mu: usize,
    /// Equally spaced (midpoint) nodes in φi over [0, 2π).
    pub n_phi: usize,
    /// How the table is read at each node.
    pub lookup: Lookup,
}

impl Default for Quadrature {
    /// 32 × 64 nodes (2,048 lookups per θo), interpolated lookups.
    fn default() -> Self {
        Quadrature {
            n_mu: 32,
            n_phi: 64,
            lookup: Lookup::Interpolated,
        }
    }
}

/// Summary of a table.
#[derive(Clone, Debug, PartialEq)]
pub struct TableStats {
    /// The grid.
    pub dims: Dims,
    /// Cells of the grid.
    pub cells: usize,
    /// Valid (non-missing) cells.
    pub valid: usize,
    /// valid / cells.
    pub valid_fraction: f64,
    /// Per channel (R, G, B); `None` when no cell is valid.
    pub channels: Option<[ChannelStats; 3]>,
    /// Albedo at θo = 0°, 15°, 30°, 45°, 60°, 75°, 85°.
    pub albedo: Vec<AlbedoSample>,
}

/// The outgoing angles (degrees) of [`TableStats::albedo`].
pub const ALBEDO_ANGLES_DEG: [f64; 7] = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0];

/// Gauss–Legendre nodes and weights on (0, 1): core's rule on (−1, 1)
/// ([`brdfkit_core::quadrature::gauss_legendre`]) mapped by x → (x + 1)/2, weights
/// halved. Exact for polynomials of degree < 2n.
pub fn gauss_legendre_01(n: usize) -> Vec<(f64, f64)> {
    let (x, w) = brdfkit_core::quadrature::gauss_legendre(n);
    x.iter()
        .zip(&w)
        .map(|(x, w)| (0.5 * (x + 1.0), 0.5 * w))
        .collect()
}

impl MerlTable {
    /// Directional albedo a(θo) = ∫_H f(wi, wo) cos θi dωi, wo at polar angle θo and
    /// azimuth 0.
    ///
    /// Quadrature: with μ = cos θi, dωi = dμ dφi, so a = ∫₀^{2π} ∫₀¹ f μ dμ dφi;
    /// Gauss–Legendre in μ (nodes strictly inside (0, 1), so no node is at grazing) and
    /// the midpoint rule in φi, which is spectrally accurate for a smooth periodic
    /// integrand. On a Lambertian table (f = ρ/π in every valid cell) the rule is exact:
    /// it integrates μ exactly and the φ sum is exact for constants; the tests demand
    /// |a − ρ| ≤ 1e-12 (the issue asks 1e-3). On real tables the accuracy is set by the
    /// table's resolution near the specular peak, not by the rule.
    ///
    /// Missing cells: a node whose lookup is missing is left out and the sum is
    /// rescaled by (total weight) / (weight of valid nodes), weights being the
    /// quadrature weight times μ. That is, missing nodes take the cosine-weighted mean
    /// of the valid ones, rather than zero (which would bias grazing-heavy tables low).
    /// The fraction of weight that was missing is reported.
    pub fn albedo(&self, theta_o: f64, q: &Quadrature) -> AlbedoSample {
        let wo = spherical(theta_o, 0.0);
        let gl = gauss_legendre_01(q.n_mu);
        let dphi = 2.0 * PI / q.n_phi as f64;
        let (acc, w_valid, w_total) = gl
            .par_iter()
            .map(|&(mu, wmu)| {
                // μ ∈ (0, 1) so 1 − μ² > 0; the clamp only guards the sqrt against
                // a rounding below zero.
                let sin = (1.0 - mu * mu).max(0.0).sqrt();
                let mut acc = Rgb::ZERO;
                let (mut wv, mut wt) = (0.0, 0.0);
                for m in 0..q.n_phi {
                    let phi = (m as f64 + 0.5) * dphi;
                    let wi = brdfkit_core::Vec3::new(sin * phi.cos(), sin * phi.sin(), mu);
                    let w = wmu * mu * dphi;
                    wt += w;
                    if let Some(f) = self.lookup(q.lookup, &wi, &wo) {
                        acc += f * w;
                        wv += w;
                    }
                }
                (acc, wv, wt)
            })
            .reduce(
                || (Rgb::ZERO, 0.0, 0.0),
                |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2),
            );
        AlbedoSample {
            theta_o,
            albedo: (w_valid > 0.0).then(|| acc * (w_total / w_valid)),
            missing_weight: if w_total > 0.0 {
                1.0 - w_valid / w_total
            } else {
                1.0
            },
        }
    }

    /// Minimum, median and maximum per channel over the valid cells.
    pub fn channel_stats(&self) -> Option<[ChannelStats; 3]> {
        if self.n_valid == 0 {
            return None;
        }
        let n = self.cells();
        let one = |c: usize| {
            let plane = &self.raw[c * n..(c + 1) * n];
            let mut v: Vec<f64> = plane
                .iter()
                .zip(&self.valid)
                .filter(|(_, ok)| **ok)
                .map(|(&x, _)| x * SCALES[c])
                .collect();
            let len = v.len();
            let (lo, &mut mid, _) = v.select_nth_unstable_by(len / 2, f64::total_cmp);
            let median = if len % 2 == 1 {
                mid
            } else {
                // The lower middle value is the largest of the lower part.
                let below = lo.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                0.5 * (below + mid)
            };
            let min = v.iter().copied().fold(f64::INFINITY, f64::min);
            let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            ChannelStats { min, median, max }
        };
        Some([one(0), one(1), one(2)])
    }

    /// Dims, coverage, per-channel ranges and the albedo at [`ALBEDO_ANGLES_DEG`] with
    /// the default [`Quadrature`].
    pub fn stats(&self) -> TableStats {
        let q = Quadrature::default();
        TableStats {
            dims: self.dims,
            cells: self.cells(),
            valid: self.n_valid,
            valid_fraction: self.valid_fraction(),
            channels: self.channel_stats(),
            albedo: ALBEDO_ANGLES_DEG
                .iter()
                .map(|d| self.albedo(d.to_radians(), &q))
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        for n in [1usize, 2, 5, 16, 32] {
            let gl = gauss_legendre_01(n);
            assert_eq!(gl.len(), n);
            for deg in 0..(2 * n) {
                let s: f64 = gl.iter().map(|(x, w)| w * x.powi(deg as i32)).sum();
                let exact = 1.0 / (deg as f64 + 1.0);
                assert!((s - exact).abs() < 1e-14, "n {n} deg {deg}: {s} vs {exact}");
            }
            assert!(gl.iter().all(|&(x, _)| x > 0.0 && x < 1.0));
        }
    }
}
