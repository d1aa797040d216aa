//! Lookups: the reference nearest-bin lookup and multilinear interpolation.

use crate::grid::Dims;
use crate::table::{MerlTable, SCALES, raw_valid};
use brdfkit_core::{HalfDiff, Rgb, Vec3, to_half_diff};
use rayon::prelude::*;

/// Pairs per two-phase run of [`MerlTable::lookup_batch`].
pub const BATCH_RUN: usize = 256;

/// How a table is read between its cells.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Lookup {
    /// The cell whose bin holds the angles: the reference `lookup_brdf_val`.
    #[default]
    Nearest,
    /// Multilinear interpolation in continuous index coordinates.
    Interpolated,
}

/// Strictly above the horizon and finite. The table has no samples for z ≤ 0, and a
/// non-finite direction has no bin (its angles would be NaN).
#[inline]
fn usable(w: &Vec3) -> bool {
    w.z > 0.0 && w.x.is_finite() && w.y.is_finite() && w.z.is_finite()
}

/// Interpolation stencil along θh or θd: lower node, upper node, fraction.
///
/// The nodes are the cells' angles (coordinate i for cell i). Past the last node
/// (coordinates in [n − 1, n], i.e. up to π/2, and beyond for pairs below the
/// horizon) there is no node to interpolate towards: the last one is held, as the
/// nearest lookup's clamp does. A NaN coordinate (which [`usable`] keeps out) goes to
/// node 0 rather than indexing out of range.
#[inline]
fn clamped_axis(x: f64, n: usize) -> (usize, usize, f64) {
    if x.is_nan() || x <= 0.0 {
        return (0, 0, 0.0);
    }
    let last = n - 1;
    if x >= last as f64 {
        return (last, last, 0.0);
    }
    let lo = x.floor();
    (lo as usize, lo as usize + 1, x - lo)
}

/// Interpolation stencil along φd, which wraps: node n is node 0 (φd = π is φd = 0 by
/// reciprocity), so the last cell interpolates towards the first.
#[inline]
fn wrapped_axis(x: f64, n: usize) -> (usize, usize, f64) {
    let nf = n as f64;
    // Coordinates from `phi_d_coord` are already in [0, n]; `rem_euclid` (an fmod
    // call) is only needed for angles given from outside [−π, π].
    let x = if (0.0..=nf).contains(&x) {
        x
    } else {
        x.rem_euclid(nf)
    };
    if x.is_nan() {
        return (0, 0, 0.0);
    }
    let lo = x.floor();
    // rem_euclid can round a tiny negative value up to exactly n.
    let k = (lo as usize) % n;
    (k, (k + 1) % n, x - lo)
}

impl MerlTable {
    /// The reference lookup: the value of the cell whose bin holds the pair's
    /// Rusinkiewicz angles ([`to_half_diff`], then [`Dims::bin_index`]), bit-identical
    /// to `lookup_brdf_val` of `BRDFRead.cpp`. `None` when either direction is at or
    /// below the horizon (z ≤ 0) or not finite, or the cell is missing.
    pub fn nearest(&self, wi: &Vec3, wo: &Vec3) -> Option<Rgb> {
        if !(usable(wi) && usable(wo)) {
            return None;
        }
        self.nearest_half_diff(&to_half_diff(wi, wo))
    }

    /// Nearest lookup by Rusinkiewicz angles (no horizon test: angles carry none).
    #[inline]
    pub fn nearest_half_diff(&self, c: &HalfDiff) -> Option<Rgb> {
        self.get_flat(self.dims.bin_index(c))
    }

    /// Multilinear interpolation at the pair's continuous index coordinates
    /// ([`Dims::coords`]); see [`interpolate_coords`](Self::interpolate_coords). `None`
    /// when either direction is at or below the horizon or not finite, or no cell of the
    /// stencil with a positive weight holds a sample.
    pub fn interpolated(&self, wi: &Vec3, wo: &Vec3) -> Option<Rgb> {
        if !(usable(wi) && usable(wo)) {
            return None;
        }
        self.interpolated_half_diff(&to_half_diff(wi, wo))
    }

    /// Interpolation by Rusinkiewicz angles (no horizon test).
    #[inline]
    pub fn interpolated_half_diff(&self, c: &HalfDiff) -> Option<Rgb> {
        self.interpolate_coords(self.dims.coords(c))
    }

    /// Multilinear interpolation at continuous index coordinates (u, v, w), in physical
    /// units.
    ///
    /// Cell (i, j, k) is the node at (i, j, k). With fractions (tu, tv, tw) the corner
    /// weights are the products of (1 − t) and t along each axis; θh and θd hold their
    /// last node past it, φd wraps (node nφd is node 0). Missing corners are left out
    /// and the weights of the others renormalised: f = Σ wₘ fₘ / Σ wₘ over valid
    /// corners. `None` when that sum is zero (every corner with a positive weight is
    /// missing).
    pub fn interpolate_coords(&self, coords: [f64; 3]) -> Option<Rgb> {
        self.interpolate_raw(coords)
            .map(|r| Rgb::new(r[0] * SCALES[0], r[1] * SCALES[1], r[2] * SCALES[2]))
    }

    /// [`interpolate_coords`](Self::interpolate_coords) in raw units (the scale is
    /// linear, so interpolating raw values and scaling is the same function).
    pub fn interpolate_raw(&self, coords: [f64; 3]) -> Option<[f64; 3]> {
        let d: Dims = self.dims;
        let (i0, i1, tu) = clamped_axis(coords[0], d.theta_h());
        let (j0, j1, tv) = clamped_axis(coords[1], d.theta_d());
        let (k0, k1, tw) = wrapped_axis(coords[2], d.phi_d());
        let n = d.cells();
        let mut acc = [0.0f64; 3];
        let mut wsum = 0.0;
        for (i, wu) in [(i0, 1.0 - tu), (i1, tu)] {
            if wu == 0.0 {
                continue;
            }
            for (j, wv) in [(j0, 1.0 - tv), (j1, tv)] {
                if wv == 0.0 {
                    continue;
                }
                let row = d.index(i, j, 0);
                for (k, ww) in [(k0, 1.0 - tw), (k1, tw)] {
                    let w = wu * wv * ww;
                    let idx = row + k;
                    // Validity from the raw signs, as in `get_flat` (no mask load).
                    let (r, g, b) = (self.raw[idx], self.raw[n + idx], self.raw[2 * n + idx]);
                    if w == 0.0 || !raw_valid(r, g, b) {
                        continue;
                    }
                    acc[0] += w * r;
                    acc[1] += w * g;
                    acc[2] += w * b;
                    wsum += w;
                }
            }
        }
        if wsum > 0.0 {
            Some([acc[0] / wsum, acc[1] / wsum, acc[2] / wsum])
        } else {
            None
        }
    }

    /// [`nearest`](Self::nearest) or [`interpolated`](Self::interpolated).
    #[inline]
    pub fn lookup(&self, mode: Lookup, wi: &Vec3, wo: &Vec3) -> Option<Rgb> {
        match mode {
            Lookup::Nearest => self.nearest(wi, wo),
            Lookup::Interpolated => self.interpolated(wi, wo),
        }
    }

    /// Lookups of many pairs, in parallel (rayon); result k belongs to `pairs[k]`, equal
    /// to [`lookup`](Self::lookup) of that pair.
    ///
    /// Each task works on runs of [`BATCH_RUN`] pairs in two phases: first the angles and
    /// cell coordinates of the whole run (pure arithmetic), then the table reads. A
    /// random read into a 35 MB table is a cache miss; interleaved with the ~130 ns of
    /// trigonometry per pair, each miss would be waited for alone, while a run of reads
    /// back to back lets the processor overlap them.
    pub fn lookup_batch(&self, mode: Lookup, pairs: &[(Vec3, Vec3)]) -> Vec<Option<Rgb>> {
        let mut out = vec![None; pairs.len()];
        out.par_chunks_mut(BATCH_RUN)
            .zip(pairs.par_chunks(BATCH_RUN))
            .with_min_len(4)
            .for_each(|(out, pairs)| match mode {
                Lookup::Nearest => {
                    let mut idx = [usize::MAX; BATCH_RUN];
                    for ((wi, wo), x) in pairs.iter().zip(idx.iter_mut()) {
                        if usable(wi) && usable(wo) {
                            *x = self.dims.bin_index(&to_half_diff(wi, wo));
                        }
                    }
                    for (o, &x) in out.iter_mut().zip(idx.iter()) {
                        if x != usize::MAX {
                            *o = self.get_flat(x);
                        }
                    }
                }
                Lookup::Interpolated => {
                    // NaN marks a pair with no lookup (below the horizon, not finite).
                    let mut coords = [[f64::NAN; 3]; BATCH_RUN];
                    for ((wi, wo), c) in pairs.iter().zip(coords.iter_mut()) {
                        if usable(wi) && usable(wo) {
                            *c = self.dims.coords(&to_half_diff(wi, wo));
                        }
                    }
                    for (o, c) in out.iter_mut().zip(coords.iter()) {
                        if !c[0].is_nan() {
                            *o = self.interpolate_coords(*c);
                        }
                    }
                }
            });
        out
    }

    /// [`lookup_batch`](Self::lookup_batch) with [`Lookup::Nearest`].
    pub fn nearest_batch(&self, pairs: &[(Vec3, Vec3)]) -> Vec<Option<Rgb>> {
        self.lookup_batch(Lookup::Nearest, pairs)
    }

    /// [`lookup_batch`](Self::lookup_batch) with [`Lookup::Interpolated`].
    pub fn interpolated_batch(&self, pairs: &[(Vec3, Vec3)]) -> Vec<Option<Rgb>> {
        self.lookup_batch(Lookup::Interpolated, pairs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stencils() {
        assert_eq!(clamped_axis(2.25, 4), (2, 3, 0.25));
        assert_eq!(clamped_axis(3.5, 4), (3, 3, 0.0));
        assert_eq!(clamped_axis(0.0, 4), (0, 0, 0.0));
        assert_eq!(clamped_axis(f64::NAN, 4), (0, 0, 0.0));
        assert_eq!(wrapped_axis(3.5, 4), (3, 0, 0.5));
        assert_eq!(wrapped_axis(4.0, 4), (0, 1, 0.0));
        assert_eq!(wrapped_axis(-1e-18, 4), (0, 1, 0.0));
        assert_eq!(wrapped_axis(-0.5, 4), (3, 0, 0.5));
    }
}
