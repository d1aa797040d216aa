//! Resampling: analytic model → table, table → table of other dims, and the per-cell
//! view (angles, directions, value, solid-angle weight) that fitting and integration use.

use crate::error::{Channel, TableError};
use crate::grid::{
    Dims, cell_weight, phi_d_angle, phi_d_coord, snap_coord, theta_d_angle, theta_d_coord,
    theta_h_angle, theta_h_coord,
};
use crate::lookup::Lookup;
use crate::table::MerlTable;
use brdfkit_core::{Brdf, GeometryBatch, HalfDiff, Rgb, Vec3, from_half_diff};
use rayon::prelude::*;

/// One valid cell of a table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Flat index `k + nφd · (j + nθd · i)`.
    pub index: usize,
    /// θh bin.
    pub i: usize,
    /// θd bin.
    pub j: usize,
    /// φd bin.
    pub k: usize,
    /// The cell's angles (lower bin edges), φh = 0.
    pub angles: HalfDiff,
    /// Incident direction at the cell's angles ([`from_half_diff`]).
    pub wi: Vec3,
    /// Outgoing direction at the cell's angles.
    pub wo: Vec3,
    /// Physical value.
    pub value: Rgb,
    /// Solid-angle measure of the cell's bin in (wi, wo) space ([`cell_weight`]).
    pub weight: f64,
}

/// All valid cells as a structure of arrays: the input of a fit.
///
/// Entry m belongs to cell `indices[m]`: its geometry is pair m of `geometry` (the
/// cell's directions with φh = 0), its value is `values[c][m]` for channel c (physical
/// units) and its solid-angle weight `weights[m]`.
#[derive(Clone, Debug, Default)]
pub struct CellBatch {
    /// Flat cell index of each entry.
    pub indices: Vec<usize>,
    /// Directions of each entry (φh = 0).
    pub geometry: GeometryBatch,
    /// Values per channel (physical units).
    pub values: [Vec<f64>; 3],
    /// Solid-angle weight of each entry.
    pub weights: Vec<f64>,
}

impl CellBatch {
    /// Number of cells.
    pub fn len(&self) -> usize {
        self.indices.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }
}

/// The directions of a cell's angles (φh = 0), and whether both are strictly above the
/// horizon: the rule that marks cells missing (real MERL files are masked by the same
/// corner-angle test). Cells exactly at grazing (θh + θd = π/2 at φd = 0: cells
/// (30, 80, 0) and (60, 50, 0) of the MERL grid) fall on the side the round-off of
/// [`from_half_diff`] puts them.
pub fn cell_directions(dims: Dims, i: usize, j: usize, k: usize) -> (HalfDiff, Vec3, Vec3, bool) {
    let c = dims.cell_angles(i, j, k);
    let (wi, wo) = from_half_diff(&c);
    (c, wi, wo, wi.z > 0.0 && wo.z > 0.0)
}

/// A present cell of a table: its indices (θh, θd, φd), its directions
/// ([`cell_directions`]) and its value.
#[derive(Clone, Copy, Debug)]
pub struct PresentCell {
    /// (i, j, k): the θh, θd and φd indices.
    pub index: [usize; 3],
    /// The incoming direction at the cell's angles.
    pub wi: Vec3,
    /// The outgoing direction at the cell's angles.
    pub wo: Vec3,
    /// The stored value.
    pub value: Rgb,
}

impl MerlTable {
    /// Every present cell in file order (φd fastest), with its directions: what a
    /// comparison of the table against another BRDF walks.
    pub fn present_cells(&self) -> impl Iterator<Item = PresentCell> + '_ {
        let dims = self.dims();
        let (nj, nk) = (dims.theta_d(), dims.phi_d());
        (0..dims.cells()).filter_map(move |x| {
            let value = self.get_flat(x)?;
            let index = [x / (nj * nk), (x / nk) % nj, x % nk];
            let (_, wi, wo, _) = cell_directions(dims, index[0], index[1], index[2]);
            Some(PresentCell {
                index,
                wi,
                wo,
                value,
            })
        })
    }

    /// Samples an analytic BRDF onto a grid of `dims`, in parallel.
    ///
    /// Each cell gets the model's value at the cell's angles (the lower bin edges, φh =
    /// 0), assigned by index (a lookup at those angles would land a bin lower for most
    /// cells; see [`crate::grid`]). Cells whose directions at those angles have wi.z ≤ 0
    /// or wo.z ≤ 0 are missing. A model value that is negative or not finite is an
    /// error naming the cell.
    pub fn from_brdf(brdf: &dyn Brdf, dims: Dims) -> Result<MerlTable, TableError> {
        MerlTable::from_fn(dims, |i, j, k| {
            let (_, wi, wo, above) = cell_directions(dims, i, j, k);
            above.then(|| brdf.eval(&wi, &wo))
        })
    }

    /// Values at arbitrary direction pairs ([`lookup_batch`](Self::lookup_batch)).
    pub fn sample_pairs(&self, mode: Lookup, pairs: &[(Vec3, Vec3)]) -> Vec<Option<Rgb>> {
        self.lookup_batch(mode, pairs)
    }

    /// Resamples the table onto a grid of other dims, in parallel.
    ///
    /// Each target cell's angles are mapped to continuous source index coordinates
    /// directly (θh → `theta_h_coord`, θd → `theta_d_coord`, φd → `phi_d_coord`, not
    /// through direction vectors), and coordinates within 1e-9 of an integer are
    /// snapped onto it ([`snap_coord`]): without that, a target cell that coincides with
    /// a source node (doubling or halving a grid) would land a few ulps low and truncate
    /// into the wrong cell. Then:
    /// - [`Lookup::Nearest`]: the raw values of source cell (⌊u⌋, ⌊v⌋, ⌊w⌋) (clamped; φd
    ///   wrapped) are copied bit for bit, missing or not;
    /// - [`Lookup::Interpolated`]: multilinear interpolation of the raw values, missing
    ///   sources renormalised out ([`interpolate_raw`](Self::interpolate_raw)); no valid
    ///   source gives a missing cell.
    ///
    /// Doubling a grid and halving it back with `Nearest` gives the original table
    /// exactly.
    pub fn resample(&self, dims: Dims, mode: Lookup) -> MerlTable {
        let src = self.dims;
        // Per axis: the source coordinate of each target cell's angle.
        let axis =
            |n: usize, n_src: usize, angle: fn(f64, usize) -> f64, coord: fn(f64, usize) -> f64| {
                (0..n)
                    .map(|i| snap_coord(coord(angle(i as f64, n), n_src)))
                    .collect::<Vec<f64>>()
            };
        let us = axis(dims.theta_h(), src.theta_h(), theta_h_angle, theta_h_coord);
        let vs = axis(dims.theta_d(), src.theta_d(), theta_d_angle, theta_d_coord);
        let ws = axis(dims.phi_d(), src.phi_d(), phi_d_angle, phi_d_coord);
        let Ok(table) = MerlTable::try_from_raw_fn(dims, |i, j, k| {
            let coords = [us[i], vs[j], ws[k]];
            Ok::<_, std::convert::Infallible>(match mode {
                Lookup::Nearest => self.raw_at(self.nearest_node(coords)),
                Lookup::Interpolated => self
                    .interpolate_raw(coords)
                    .unwrap_or([crate::table::MISSING_RAW; 3]),
            })
        });
        table
    }

    /// Flat index of the cell holding continuous coordinates: truncation, θh and θd
    /// clamped to the grid, φd wrapped (coordinate nφd is node 0).
    fn nearest_node(&self, c: [f64; 3]) -> usize {
        let d = self.dims;
        // Target coordinates are i · nS / nT < nS, so the clamps only catch a round-off
        // up to exactly nS (and `as` saturates); φd wraps instead: coordinate nφd is
        // φd = π, the same place as 0 by reciprocity.
        let i = (c[0] as usize).min(d.theta_h() - 1);
        let j = (c[1] as usize).min(d.theta_d() - 1);
        let k = (c[2] as usize) % d.phi_d();
        d.index(i, j, k)
    }

    /// The full view of valid cell `index` (`None` when missing).
    pub fn cell(&self, index: usize) -> Option<Cell> {
        let value = self.get_flat(index)?;
        let (i, j, k) = self.dims.unflatten(index);
        let (angles, wi, wo, _) = cell_directions(self.dims, i, j, k);
        Some(Cell {
            index,
            i,
            j,
            k,
            angles,
            wi,
            wo,
            value,
            weight: cell_weight(self.dims, i, j),
        })
    }

    /// The valid cells in file order.
    pub fn valid_cells(&self) -> impl Iterator<Item = Cell> + '_ {
        (0..self.cells()).filter_map(move |x| self.cell(x))
    }

    /// The valid cells, in parallel.
    pub fn par_valid_cells(&self) -> impl ParallelIterator<Item = Cell> + '_ {
        (0..self.cells())
            .into_par_iter()
            .filter_map(move |x| self.cell(x))
    }

    /// Every valid cell's geometry, values and weight as a structure of arrays, in one
    /// parallel pass (cells in file order). Includes valid cells whose directions are
    /// below the horizon, if a table has any (MERL files do not).
    pub fn cell_batch(&self) -> CellBatch {
        let indices: Vec<usize> = (0..self.cells()).filter(|&x| self.valid[x]).collect();
        let m = indices.len();
        let z = || vec![0.0; m];
        let mut out = CellBatch {
            geometry: GeometryBatch::zeroed(m),
            values: [z(), z(), z()],
            weights: z(),
            indices: Vec::new(),
        };
        // Runs of cells fill their stretch of the final columns in parallel: the peak
        // is the result itself (no per-run copies to append, no Vec of whole `Cell`s).
        const RUN: usize = 8192;
        let [vr, vg, vb] = &mut out.values;
        let [c0, c1, c2, c3, c4, c5, c6, c7, c8, c9] = out.geometry.columns_mut();
        let cols: [&mut [f64]; 14] = [
            c0,
            c1,
            c2,
            c3,
            c4,
            c5,
            c6,
            c7,
            c8,
            c9,
            vr,
            vg,
            vb,
            &mut out.weights,
        ];
        let lens: Vec<usize> = (0..m).step_by(RUN).map(|s| RUN.min(m - s)).collect();
        let runs = brdfkit_core::geometry::split_runs(cols, &lens);
        runs.into_par_iter()
            .zip(indices.par_chunks(RUN))
            .for_each(|(mut run, idx)| {
                let (geo, rest) = run.split_at_mut(10);
                let [r, gr, b, w] = rest else {
                    unreachable!("14 columns: 10 of geometry, 3 values, the weight")
                };
                for (p, &x) in idx.iter().enumerate() {
                    let c = self.cell(x).expect("index is valid");
                    let pc = brdfkit_core::geometry::pair_columns(&c.wi, &c.wo);
                    for (col, v) in geo.iter_mut().zip(pc) {
                        col[p] = v;
                    }
                    (r[p], gr[p], b[p]) = (
                        c.value[Channel::Red.index()],
                        c.value[Channel::Green.index()],
                        c.value[Channel::Blue.index()],
                    );
                    w[p] = c.weight;
                }
            });
        out.indices = indices;
        out
    }
}
