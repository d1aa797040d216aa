//! Lookups: the reference nearest-bin lookup and multilinear interpolation.

use crate::grid::{Dims, theta_d_bin, theta_h_bin, theta_h_coord};
use crate::table::{CELL_STRIDE, MerlTable, SCALES, raw_valid};
use brdfkit_core::lanes::{Run, dispatch};
use brdfkit_core::{HalfDiff, Rgb, Vec3, to_half_diff};
use rayon::prelude::*;
use std::f64::consts::{FRAC_1_PI, FRAC_2_PI, FRAC_PI_2, PI};
use std::sync::{Arc, Mutex};
use thiserror::Error;

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

/// The pair's Rusinkiewicz angles ([`to_half_diff`]) when both directions are
/// [`usable`], else `None`: the one gate of every lookup by directions.
#[inline]
fn usable_half_diff(wi: &Vec3, wo: &Vec3) -> Option<HalfDiff> {
    (usable(wi) && usable(wo)).then(|| to_half_diff(wi, wo))
}

/// A stencil along one axis: lower node, upper node, fraction towards the upper one.
type Axis = (usize, usize, f64);

/// Finite and strictly above the horizon, as [`usable`]; without branches (`&`), so
/// that it vectorises.
#[inline(always)]
fn usable3(w: &[f64; 3]) -> bool {
    (w[2] > 0.0) & w[0].is_finite() & w[1].is_finite() & w[2].is_finite()
}

/// Interpolation stencil along θh or θd: lower node, upper node, fraction.
///
/// The nodes are the cells' angles (coordinate i for cell i). Past the last node
/// (coordinates in [n − 1, n], i.e. up to π/2, and beyond for pairs below the
/// horizon) there is no node to interpolate towards: the last one is held, as the
/// nearest lookup's clamp does. A NaN coordinate (which [`usable`] keeps out) goes to
/// node 0 rather than indexing out of range.
#[inline]
fn clamped_axis(x: f64, n: usize) -> Axis {
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
fn wrapped_axis(x: f64, n: usize) -> Axis {
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
        self.nearest_half_diff(&usable_half_diff(wi, wo)?)
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
        self.interpolated_half_diff(&usable_half_diff(wi, wo)?)
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
        self.interpolate_stencil([
            clamped_axis(coords[0], d.theta_h()),
            clamped_axis(coords[1], d.theta_d()),
            wrapped_axis(coords[2], d.phi_d()),
        ])
    }

    /// Multilinear interpolation of raw values over a stencil (lower node, upper node,
    /// fraction along θh, θd, φd); see [`interpolate_coords`](Self::interpolate_coords).
    fn interpolate_stencil(&self, stencil: [Axis; 3]) -> Option<[f64; 3]> {
        let d: Dims = self.dims;
        let [(i0, i1, tu), (j0, j1, tv), (k0, k1, tw)] = stencil;
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

    /// Readies the table for about `pairs` lookups in `mode` to come, in batches of any
    /// size: with [`Lookup::Nearest`] and a large enough total, the interleaved copy of
    /// the values that large batches read (one cache line per lookup instead of three)
    /// is built now rather than by the first large batch, so that the batches of a
    /// chunked lookup use it too. Results are the same with or without it.
    pub fn prepare_lookups(&self, mode: Lookup, pairs: usize) {
        if mode == Lookup::Nearest {
            self.cells_for(pairs);
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
    /// to [`lookup`](Self::lookup) of that pair, bit for bit.
    ///
    /// [`Lookup::Nearest`] runs the fast exact path of [`lookup_flat`](Self::lookup_flat).
    /// [`Lookup::Interpolated`] runs the reference conversion per pair, in runs of
    /// [`BATCH_RUN`] pairs in two phases: first the angles and cell coordinates of the
    /// whole run (pure arithmetic), then the table reads, so that the processor overlaps
    /// the cache misses of a run's reads (use [`lookup_flat`](Self::lookup_flat) for the
    /// fast interpolation, equal to a few ulps).
    pub fn lookup_batch(&self, mode: Lookup, pairs: &[(Vec3, Vec3)]) -> Vec<Option<Rgb>> {
        let mut out = vec![None; pairs.len()];
        match mode {
            Lookup::Nearest => {
                let pair = |k: usize| {
                    let (wi, wo) = &pairs[k];
                    ([wi.x, wi.y, wi.z], [wo.x, wo.y, wo.z])
                };
                let streams = Streams([Streams::of(pairs), (0, 0)]);
                self.fast_batch(Lookup::Nearest, &pair, streams, &mut out, |v| v);
            }
            Lookup::Interpolated => {
                out.par_chunks_mut(BATCH_RUN)
                    .zip(pairs.par_chunks(BATCH_RUN))
                    .with_min_len(4)
                    .for_each(|(out, pairs)| {
                        // NaN marks a pair with no lookup (below the horizon, not finite).
                        let mut coords = [[f64::NAN; 3]; BATCH_RUN];
                        for ((wi, wo), c) in pairs.iter().zip(coords.iter_mut()) {
                            if let Some(hd) = usable_half_diff(wi, wo) {
                                *c = self.dims.coords(&hd);
                            }
                        }
                        for (o, c) in out.iter_mut().zip(coords.iter()) {
                            if !c[0].is_nan() {
                                *o = self.interpolate_coords(*c);
                            }
                        }
                    });
            }
        }
        out
    }

    /// Lookups of N direction pairs given as the rows of an N × 6 array (row-major, as an
    /// N × 6 float64 `.npy`: wi_x, wi_y, wi_z, wo_x, wo_y, wo_z), into the rows of an
    /// N × 3 array (R, G, B in 1/sr), in parallel over every thread of the current rayon
    /// pool.
    ///
    /// A row with no value is NaN in all three channels: either direction at or below
    /// the horizon (z ≤ 0) or not finite, or (nearest) the cell missing, or
    /// (interpolated) every stencil cell with a positive weight missing.
    ///
    /// - [`Lookup::Nearest`] gives exactly the value of [`nearest`](Self::nearest): the
    ///   same cell as the reference mapping, bit for bit, the wi = wo convention
    ///   included ([`to_half_diff`]). See [`lookup_flat`](Self::lookup_flat)'s method
    ///   below.
    /// - [`Lookup::Interpolated`] interpolates over the same stencil cells as
    ///   [`interpolated`](Self::interpolated), with fractions from a different
    ///   evaluation of the same angles: the values agree to about 1e-13 relative
    ///   (the tests demand 1e-11), not bit for bit.
    ///
    /// # Method
    /// The reference computes θh, φh, θd, φd with acos, atan2 and two rotations by sines
    /// and cosines of those angles (six library calls), then truncates scaled angles.
    /// The bins only need comparisons against bin edges, which need no angle:
    /// - the half vector h is computed as the reference does (bit-identical); the θh bin
    ///   is a non-increasing step function of h.z alone, so its exact thresholds (the
    ///   largest h.z of each bin, found once per grid by walking the reference function
    ///   ulp by ulp from cos of the edge angle) give the bin by comparison;
    /// - the rotations' sines and cosines are ratios of h's components
    ///   (cos φh = hx/r, sin φh = hy/r, r = √(hx² + hy²); cos θh = hz,
    ///   sin θh = √((1 − hz)(1 + hz))), so cos θd = d.z and r · (d.x, d.y) follow from
    ///   products; cos θd is compared with the θd thresholds, and the direction
    ///   r · (d.x, d.y), folded into the upper half plane (φd + π for φd < 0), with the
    ///   φd edge directions (cos kπ/nφd, sin kπ/nφd) by cross products;
    /// - a cheap approximation (Abramowitz & Stegun 4.4.46 for acos, 4.4.49 for atan,
    ///   ≤ 2.2e-8 rad) picks the bracket to compare with, corrected by one step when off.
    ///
    /// These values differ from the reference's rotated vector by round-off (a few
    /// 1e-16); where a pair lies within a margin of a bin edge that round-off could
    /// decide (cos θh within 1e-15 of a threshold, cos θd within 1e-12, the φd cross
    /// product within 1e-12 · r), and for wi = wo and h on the normal, the pair goes
    /// through the reference conversion instead: none of 10⁶ random pairs did in the
    /// unit test that measures the round-off against the margins.
    ///
    /// The interpolation's fractions come from the angle past the lower edge,
    /// atan of a small ratio (a series to 1e-17, or `atan2` for bins wider than 0.05
    /// rad), so no acos or full-range atan2 either.
    ///
    /// Work goes to the pool's threads in runs of 4096 pairs ([`rayon::broadcast`], so
    /// a short job uses both threads of a small pool). Within a run, 128 pairs at a time:
    /// the arithmetic above, branch-free and vectorised (an AVX-512 or AVX2 copy chosen
    /// at run time). The nearest lookup finds the cells in that loop instead, from
    /// wi + wo unnormalised with cheaper arithmetic, for every pair that lies inside its
    /// approximate bins by a margin (`Edges::quick_cell`; the others, a few in 10⁵
    /// random pairs, take the exact arithmetic and the comparisons above); after each
    /// block of 16 pairs it asks for (prefetches) their cells' lines and some of the
    /// input lines of the run two runs ahead; then it reads the previous 128 pairs'
    /// values, whose lines were asked for a run earlier.
    ///
    /// A nearest batch of at least an eighth as many pairs as the table has cells (or
    /// any batch after [`prepare_lookups`](Self::prepare_lookups)) reads an interleaved
    /// copy of the values that the table builds once and keeps: one cache line per
    /// pair instead of one in each of the three channel planes (same values, bit for
    /// bit; 32 bytes per cell, 47 MB for a MERL table).
    pub fn lookup_flat(
        &self,
        mode: Lookup,
        pairs: &[f64],
        out: &mut [f64],
    ) -> Result<(), PairsError> {
        let (rows, rest) = pairs.as_chunks::<6>();
        if !rest.is_empty() {
            return Err(PairsError::NotRows { len: pairs.len() });
        }
        if out.len() != 3 * rows.len() {
            return Err(PairsError::Output {
                pairs: rows.len(),
                expected: 3 * rows.len(),
                actual: out.len(),
            });
        }
        let (out, _) = out.as_chunks_mut::<3>();
        let pair = |k: usize| {
            let r = &rows[k];
            ([r[0], r[1], r[2]], [r[3], r[4], r[5]])
        };
        let streams = Streams([Streams::of(rows), (0, 0)]);
        self.fast_batch(mode, &pair, streams, out, rgb_or_nan);
        Ok(())
    }

    /// [`lookup_flat`](Self::lookup_flat) with [`Lookup::Nearest`].
    pub fn nearest_flat(&self, pairs: &[f64], out: &mut [f64]) -> Result<(), PairsError> {
        self.lookup_flat(Lookup::Nearest, pairs, out)
    }

    /// [`lookup_flat`](Self::lookup_flat) with [`Lookup::Interpolated`].
    pub fn interpolated_flat(&self, pairs: &[f64], out: &mut [f64]) -> Result<(), PairsError> {
        self.lookup_flat(Lookup::Interpolated, pairs, out)
    }

    /// [`lookup_flat`](Self::lookup_flat) over separate arrays: `out[k]` is the value at
    /// (`wi[k]`, `wo[k]`); NaN when there is none. The three lengths must be equal.
    pub fn lookup_split(
        &self,
        mode: Lookup,
        wi: &[[f64; 3]],
        wo: &[[f64; 3]],
        out: &mut [[f64; 3]],
    ) -> Result<(), PairsError> {
        if wi.len() != wo.len() || wi.len() != out.len() {
            return Err(PairsError::Lengths {
                wi: wi.len(),
                wo: wo.len(),
                out: out.len(),
            });
        }
        let pair = |k: usize| (wi[k], wo[k]);
        let streams = Streams([Streams::of(wi), Streams::of(wo)]);
        self.fast_batch(mode, &pair, streams, out, rgb_or_nan);
        Ok(())
    }

    /// The fast path over pairs `pair(0..out.len())`, each result converted by `conv`.
    fn fast_batch<T: Send>(
        &self,
        mode: Lookup,
        pair: &(impl Fn(usize) -> ([f64; 3], [f64; 3]) + Sync),
        streams: Streams,
        out: &mut [T],
        conv: impl Fn(Option<Rgb>) -> T + Sync,
    ) {
        let edges = edges(self.dims);
        // Nearest: the cells of all pairs of a run are found by one branch-free pass
        // when the grid's thresholds are exact.
        let quick = mode == Lookup::Nearest && edges.exact;
        let cells = match mode {
            Lookup::Nearest => self.cells_for(out.len()),
            Lookup::Interpolated => None,
        };
        spread_chunks(out, FLAT_RUN, |start, out| {
            let end = out.len();
            let mut run = PrepRun::new();
            // The previous run of a nearest lookup: its outputs and cells, whose lines
            // were asked for (prefetched) one run ago, so that the misses of one run
            // overlap the arithmetic of the next.
            let mut pending: Option<(&mut [T], [usize; FAST_RUN])> = None;
            for (s, out) in out.chunks_mut(FAST_RUN).enumerate() {
                // Asked for while the cells of a run are found, a block at a time: the
                // lines of the cells of the block just found, and some of the input
                // lines of the run AHEAD runs on (the input is read by gathers across
                // the rows, which the hardware prefetcher does not keep ahead of).
                let a = (s + AHEAD) * FAST_RUN;
                let len = FAST_RUN.min(end.saturating_sub(a));
                let ask = |block: &[usize], b: usize| {
                    for &i in block {
                        self.prefetch_cell(cells, i);
                    }
                    for l in b * LINES_PER_BLOCK..(b + 1) * LINES_PER_BLOCK {
                        streams.prefetch_line(start + a, len, l);
                    }
                };
                run.compute_dispatch(&Job {
                    pair,
                    first: start + s * FAST_RUN,
                    len: out.len(),
                    edges: &edges,
                    quick,
                    ask: &ask,
                });
                match mode {
                    Lookup::Nearest => {
                        let found = self.nearest_cells(&edges, &run, out.len());
                        self.read_cells(pending.take(), cells, &conv);
                        pending = Some((out, found));
                    }
                    Lookup::Interpolated => self.interpolated_run(&edges, &run, out, &conv),
                }
            }
            self.read_cells(pending, cells, &conv);
        });
    }

    /// Asks for (prefetches) the table lines of cell `i` (none for [`SLOW`] or
    /// [`NO_CELL`]): its line of the interleaved `values` when given, else its lines of
    /// the three planes.
    #[inline(always)]
    fn prefetch_cell(&self, values: Option<&[f64]>, i: usize) {
        let n = self.cells();
        if i >= n {
            return;
        }
        match values {
            Some(v) => prefetch(v, CELL_STRIDE * i),
            None => {
                prefetch(&self.raw, i);
                prefetch(&self.raw, n + i);
                prefetch(&self.raw, 2 * n + i);
            }
        }
    }

    /// The cells of the first `len` pairs of `run`, its arithmetic and quick pass done,
    /// [`NO_CELL`] for a pair with no lookup.
    fn nearest_cells(&self, edges: &Edges, run: &PrepRun, len: usize) -> [usize; FAST_RUN] {
        let mut cells = [NO_CELL; FAST_RUN];
        for (k, x) in cells[..len].iter_mut().enumerate() {
            let mut i = run.cell[k];
            if i == SLOW {
                let (wi, wo) = run.pair(k);
                if !(usable3(&wi) && usable3(&wo)) {
                    continue;
                }
                i = match edges.finish(&wi, &wo, &prep(wi, wo, edges.n)) {
                    Some(f) => self.dims.index(f.i, f.j, f.k),
                    None => self
                        .dims
                        .bin_index(&to_half_diff(&Vec3::from(wi), &Vec3::from(wo))),
                };
            }
            *x = i;
        }
        cells
    }

    /// Reads the values of the previous run's cells (`prev`: its outputs and cells) into
    /// its outputs; their lines were asked for while that run's cells were found. The
    /// values come from the interleaved `values` when given (the same bits: `get_flat`'s
    /// products, NaN for missing), else from the planes. [`NO_CELL`]: no value.
    fn read_cells<T>(
        &self,
        prev: Option<(&mut [T], [usize; FAST_RUN])>,
        values: Option<&[f64]>,
        conv: &impl Fn(Option<Rgb>) -> T,
    ) {
        let Some((out, cells)) = prev else {
            return;
        };
        for (o, &x) in out.iter_mut().zip(cells.iter()) {
            *o = conv(if x == NO_CELL {
                None
            } else if let Some(v) = values {
                let c = &v[CELL_STRIDE * x..CELL_STRIDE * x + 3];
                (!c[0].is_nan()).then(|| Rgb::new(c[0], c[1], c[2]))
            } else {
                self.get_flat(x)
            });
        }
    }

    /// Interpolated lookups of the pairs of `run` (the first `out.len()`).
    fn interpolated_run<T>(
        &self,
        edges: &Edges,
        run: &PrepRun,
        out: &mut [T],
        conv: &impl Fn(Option<Rgb>) -> T,
    ) {
        let d = self.dims;
        let n = d.cells();
        // `None`: no lookup (below the horizon, not finite).
        let mut st: [Option<[Axis; 3]>; FAST_RUN] = [None; FAST_RUN];
        for (k, x) in st[..out.len()].iter_mut().enumerate() {
            let (wi, wo) = run.pair(k);
            if !(usable3(&wi) && usable3(&wo)) {
                continue;
            }
            let s = match edges.finish(&wi, &wo, &run.prep(k)) {
                Some(f) => edges.stencil(&f),
                None => {
                    let c = d.coords(&to_half_diff(&Vec3::from(wi), &Vec3::from(wo)));
                    [
                        clamped_axis(c[0], d.theta_h()),
                        clamped_axis(c[1], d.theta_d()),
                        wrapped_axis(c[2], d.phi_d()),
                    ]
                }
            };
            // The four (θh, θd) rows of the stencil, each plane; the two φd neighbours
            // share a line or sit on the next one.
            for i in [s[0].0, s[0].1] {
                for j in [s[1].0, s[1].1] {
                    let row = d.index(i, j, s[2].0);
                    for p in 0..3 {
                        prefetch(&self.raw, p * n + row);
                    }
                }
            }
            *x = Some(s);
        }
        for (o, s) in out.iter_mut().zip(st.iter()) {
            *o = conv(s.and_then(|s| {
                self.interpolate_stencil(s)
                    .map(|r| Rgb::new(r[0] * SCALES[0], r[1] * SCALES[1], r[2] * SCALES[2]))
            }));
        }
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

// ---- The fast batch path ------------------------------------------------------------

/// Pairs per unit of work a thread takes in the fast batch lookups.
const FLAT_RUN: usize = 4096;

/// Margin in radians around a bin edge within which [`Edges::quick_cell`] leaves a pair
/// to [`Edges::finish`]: about ten times the approximations' error (2.2e-8 rad) and the
/// round-off it adds to. Pairs that close to an edge, or with sin θd below
/// [`QUICK_SIN_D`], are few: 17 of 300,000 random pairs on the MERL grid (unit test).
const QUICK_MARGIN: f64 = 2.5e-7;

/// Smallest sin θd (|(d.x, d.y)| of the rotated wi) for which [`Edges::quick_cell`]
/// vouches for φd: round-off δ of r · (d.x, d.y) turns its direction by at most
/// δ / (r sin θd) ≤ 1e-14 / 1e-5 = 1e-9 rad, far within [`QUICK_MARGIN`].
const QUICK_SIN_D: f64 = 1e-5;

/// A pair whose cell the quick pass could not vouch for ([`Edges::quick_cell`]).
const SLOW: usize = usize::MAX;

/// A pair with no lookup (below the horizon, not finite).
const NO_CELL: usize = usize::MAX - 1;

/// Margin on cos θh around a θh threshold within which a pair goes through the reference
/// conversion. The fast path's h.z is the reference's bit for bit and the thresholds are
/// exact, so this only guards against the reference function not being monotone in h.z
/// right at a threshold (about 9 ulps of h.z near 1).
const MARGIN_H: f64 = 1e-15;

/// Margin on cos θd around a θd threshold. The fast cos θd and the reference's rotated
/// d.z differ by round-off of a few 1e-16 (about 20 operations on unit-sized values; the
/// tests measure the largest difference over 4 · 10⁶ pairs).
const MARGIN_D: f64 = 1e-12;

/// Margin on the φd cross products, per unit of r = √(hx² + hy²): r · (d.x, d.y) differs
/// from r times the reference's (d.x, d.y) by a few 1e-16 · r per component, which moves
/// the cross product with a unit edge direction by as much.
const MARGIN_PHI: f64 = 1e-12;

/// Most ulps walked from an edge's cosine to the reference's threshold; far more than
/// the one or two it takes (a grid whose thresholds are further off is looked up by the
/// reference conversion throughout).
const WALK: usize = 4096;

/// Sizes of the inputs of the batch lookups that do not fit together.
#[derive(Clone, Debug, Error, PartialEq, Eq)]
pub enum PairsError {
    /// A flat pair array whose length is not a multiple of 6.
    #[error("pairs: {len} values are not rows of 6 (wi_x, wi_y, wi_z, wo_x, wo_y, wo_z per pair)")]
    NotRows {
        /// Number of values given.
        len: usize,
    },
    /// A flat output array of the wrong length.
    #[error("output: {actual} values for {pairs} pairs, which need {expected} (R, G, B per pair)")]
    Output {
        /// Number of pairs.
        pairs: usize,
        /// 3 × pairs.
        expected: usize,
        /// Number of output values given.
        actual: usize,
    },
    /// Separate arrays of different lengths.
    #[error("{wi} wi directions, {wo} wo directions, {out} output rows: they must be equal")]
    Lengths {
        /// Length of wi.
        wi: usize,
        /// Length of wo.
        wo: usize,
        /// Length of the output.
        out: usize,
    },
}

/// A value as an output row: NaN in every channel when there is none.
#[inline]
fn rgb_or_nan(v: Option<Rgb>) -> [f64; 3] {
    v.map_or([f64::NAN; 3], |v| [v[0], v[1], v[2]])
}

/// Asks for the cache line of `v[i]` (a hint: no effect on results).
#[inline(always)]
fn prefetch(v: &[f64], i: usize) {
    prefetch_addr(v.as_ptr().wrapping_add(i) as usize);
}

/// Runs ahead of the current one whose input lines a batch asks for (prefetches) while
/// it finds the current run's cells: the input is read by gathers across the rows,
/// which the hardware prefetcher does not keep ahead of (docs/performance.md).
const AHEAD: usize = 2;

/// Pairs per block of the quick pass after which their cells' lines are asked for.
const ASK_BLOCK: usize = 16;

/// Input lines asked for per block: a run's 128 pairs take 96 lines (48 bytes a pair,
/// as rows or as wi and wo).
const LINES_PER_BLOCK: usize = 12;

/// Where the pairs of a batch lie in memory, for [`prefetch`]ing them a run ahead: up
/// to two arrays (the rows, or wi and wo), each as (address, bytes per pair); (0, 0)
/// for none.
#[derive(Clone, Copy)]
struct Streams([(usize, usize); 2]);

impl Streams {
    fn of<P>(a: &[P]) -> (usize, usize) {
        (a.as_ptr() as usize, std::mem::size_of::<P>())
    }

    /// Asks for line `l` of the bytes of pairs `first .. first + len`: the lines of the
    /// first array, then those of the second; nothing past them.
    #[inline(always)]
    fn prefetch_line(&self, first: usize, len: usize, mut l: usize) {
        for &(base, size) in &self.0 {
            if size == 0 || len == 0 {
                continue;
            }
            let (a, b) = (base + first * size, base + (first + len) * size);
            let lines = b.div_ceil(64) - a / 64;
            if l < lines {
                prefetch_addr((a / 64 + l) * 64);
                return;
            }
            l -= lines;
        }
    }
}

/// Asks for the cache line at address `a` (a hint: no effect on results).
#[inline(always)]
fn prefetch_addr(a: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: a prefetch never faults and never changes memory, whatever the
        // address; the callers' lie inside their arrays anyway.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(std::ptr::without_provenance::<i8>(a)) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = a;
}

/// Runs `f(first index, chunk)` over `out` in chunks of `run` on every thread of the
/// current rayon pool ([`spread`](crate::table::spread)); on the calling thread when
/// there is one chunk.
fn spread_chunks<T: Send>(out: &mut [T], run: usize, f: impl Fn(usize, &mut [T]) + Sync) {
    if out.len() <= run || rayon::current_num_threads() == 1 {
        for (c, chunk) in out.chunks_mut(run).enumerate() {
            f(c * run, chunk);
        }
        return;
    }
    crate::table::spread(out.chunks_mut(run).collect(), |c, chunk| f(c * run, chunk));
}

/// The bin edges of a grid in the forms the fast path compares with.
#[derive(Debug)]
struct Edges {
    dims: Dims,
    /// The grid sizes (θh, θd, φd) as f64.
    n: [f64; 3],
    /// [`QUICK_MARGIN`] in the units [`Edges::quick_cell`] compares in: on u² for θh
    /// (2 n² / π per radian), on the θd and φd coordinates (2 n / π and n / π).
    quick_margin: [f64; 3],
    /// False when a threshold was not found: every pair takes the reference conversion.
    exact: bool,
    /// θh thresholds on h.z, `nθh + 1` of them: bin ≥ i ⇔ h.z ≤ `th[i]` (the largest
    /// h.z whose reference bin is ≥ i); `th[0]` = +∞, `th[nθh]` = −∞.
    th: Vec<f64>,
    /// θd thresholds on cos θd, the same way.
    td: Vec<f64>,
    /// Lower edge angle of each θh bin, its cosine and sine.
    th_edge: Vec<[f64; 3]>,
    /// The same for θd.
    td_edge: Vec<[f64; 3]>,
    /// φd edge directions (cos kπ/nφd, sin kπ/nφd), k = 0..=nφd, exactly (1, 0) and
    /// (−1, 0) at the ends.
    pd: Vec<[f64; 2]>,
}

/// The edges of `dims`, built once per grid and kept (the last few grids).
fn edges(dims: Dims) -> Arc<Edges> {
    static CACHE: Mutex<Vec<Arc<Edges>>> = Mutex::new(Vec::new());
    if let Ok(c) = CACHE.lock()
        && let Some(e) = c.iter().find(|e| e.dims == dims)
    {
        return e.clone();
    }
    let e = Arc::new(Edges::new(dims));
    if let Ok(mut c) = CACHE.lock() {
        if c.len() >= 8 {
            c.remove(0);
        }
        c.push(e.clone());
    }
    e
}

/// The largest x with `g(x) ≥ j`, for `g` non-increasing, walked ulp by ulp from
/// `start`; `None` when not within [`WALK`] ulps.
fn threshold(g: impl Fn(f64) -> usize, j: usize, start: f64) -> Option<f64> {
    let mut x = start;
    if g(x) >= j {
        for _ in 0..WALK {
            let up = x.next_up();
            if g(up) < j {
                return Some(x);
            }
            x = up;
        }
    } else {
        for _ in 0..WALK {
            x = x.next_down();
            if g(x) >= j {
                return Some(x);
            }
        }
    }
    None
}

/// Thresholds of the bin function `g` of a cosine over `n` bins whose edge j lies at
/// angle `edge(j)`; see [`Edges::th`].
fn thresholds(n: usize, g: impl Fn(f64) -> usize, edge: impl Fn(usize) -> f64) -> Option<Vec<f64>> {
    let mut t = Vec::with_capacity(n + 1);
    t.push(f64::INFINITY);
    for j in 1..n {
        t.push(threshold(&g, j, edge(j).cos())?);
    }
    t.push(f64::NEG_INFINITY);
    // Non-increasing, or the bracket search below would not hold.
    t.windows(2).all(|w| w[0] >= w[1]).then_some(t)
}

/// What the fast path found for one pair: the bins, and the quantities the
/// interpolation's fractions are computed from.
struct Found {
    i: usize,
    j: usize,
    k: usize,
    /// h.z clamped to ≤ 1 (cos θh) and sin θh.
    cos_h: f64,
    sin_h: f64,
    /// cos θd.
    cos_d: f64,
    /// r · (d.x, d.y), folded into the upper half plane (d.y ≥ 0), and r.
    dx: f64,
    dy: f64,
    r: f64,
}

impl Edges {
    fn new(dims: Dims) -> Edges {
        let (nh, nd, np) = (dims.theta_h(), dims.theta_d(), dims.phi_d());
        let th_angle = |i: usize| crate::grid::theta_h_angle(i as f64, nh);
        let td_angle = |j: usize| crate::grid::theta_d_angle(j as f64, nd);
        // The reference bins as functions of the cosines, clamp and acos included.
        let th = thresholds(nh, |x| theta_h_bin(x.clamp(-1.0, 1.0).acos(), nh), th_angle);
        let td = thresholds(nd, |x| theta_d_bin(x.clamp(-1.0, 1.0).acos(), nd), td_angle);
        let trig = |t: f64| [t, t.cos(), t.sin()];
        let pd = (0..=np)
            .map(|k| match k {
                0 => [1.0, 0.0],
                k if k == np => [-1.0, 0.0],
                k => {
                    let a = crate::grid::phi_d_angle(k as f64, np);
                    [a.cos(), a.sin()]
                }
            })
            .collect();
        let exact = th.is_some() && td.is_some();
        let n = [nh as f64, nd as f64, np as f64];
        Edges {
            dims,
            n,
            quick_margin: [
                QUICK_MARGIN * 2.0 * n[0] * n[0] / PI,
                QUICK_MARGIN * 2.0 * n[1] / PI,
                QUICK_MARGIN * n[2] / PI,
            ],
            exact,
            th: th.unwrap_or_default(),
            td: td.unwrap_or_default(),
            th_edge: (0..nh).map(|i| trig(th_angle(i))).collect(),
            td_edge: (0..nd).map(|j| trig(td_angle(j))).collect(),
            pd,
        }
    }

    /// The reference bins of a pair of usable directions (finite, z > 0), or `None`
    /// where the fast path cannot vouch for them (the caller then runs the reference).
    #[cfg(test)]
    fn locate(&self, wi: &[f64; 3], wo: &[f64; 3]) -> Option<Found> {
        let d = self.dims;
        let n = [d.theta_h() as f64, d.theta_d() as f64, d.phi_d() as f64];
        self.finish(wi, wo, &prep(*wi, *wo, n))
    }

    /// The checks of the fast path on the arithmetic of [`prep`]: the bins, or `None`
    /// for wi = wo, h on the normal, or a pair within a margin of a bin edge.
    #[inline(always)]
    fn finish(&self, wi: &[f64; 3], wo: &[f64; 3], p: &Prep) -> Option<Found> {
        // wi = wo is the reference's special case (θd = φd = 0, θh from to_spherical).
        if !self.exact || wi == wo {
            return None;
        }
        let i = bracket(&self.th, p.hz, p.u, MARGIN_H)?;
        // h on the normal: the reference's φh = 0 branch (r = 0 exactly when
        // hx² + hy² = 0, which the reference's hx = hy = 0 test implies).
        if p.r == 0.0 {
            return None;
        }
        let j = bracket(&self.td, p.cos_d, p.v, MARGIN_D)?;
        let m = MARGIN_PHI * p.r;
        // Near φd = 0 or ±π the fold itself is decided by round-off.
        if p.dy <= m {
            return None;
        }
        let k = sector(&self.pd, p.dx, p.dy, p.w, m)?;
        Some(Found {
            i,
            j,
            k,
            cos_h: p.hz.min(1.0),
            sin_h: p.sin_h,
            cos_d: p.cos_d,
            dx: p.dx,
            dy: p.dy,
            r: p.r,
        })
    }

    /// The cell of a pair without walks, tables or branches, so that a loop over a run
    /// vectorises; [`SLOW`] where it cannot vouch for the reference's bins, and for
    /// everything [`finish`](Self::finish) turns away (wi = wo, h on the normal,
    /// unusable directions): those pairs go through `finish` and the reference.
    ///
    /// Each bin is the approximate coordinate truncated (and clamped, as the reference
    /// clamps), kept when the approximate angle lies inside the bin by more than
    /// [`QUICK_MARGIN`] radians from each edge (an edge at the end of the axis needs no
    /// test: the reference clamps there). The approximations are within 2.2e-8 rad of
    /// the angles of this pair's cos θh, cos θd and q (d.x, d.y) (formed as below, not
    /// as `prep` forms them); those differ from the reference's by round-off of a few
    /// 1e-16, which moves θh by at most that over sin θh (≤ 1e-11 rad at any θh edge
    /// of grids up to 200 θh bins), θd by at most that over sin θd (≤ 1e-12 rad at any
    /// θd edge, sin θd ≥ sin(π / (2 nθd))), and φd by at most that over |(d.x, d.y)| =
    /// sin θd, bounded here by asking sin θd > [`QUICK_SIN_D`]. The reference's own
    /// angles and bins are correctly rounded to a few ulps (≤ 1e-15 rad). So a pair
    /// inside by the margin lies in the same bin for the reference. The tests compare
    /// millions of random pairs and pairs within an ulp of every edge with the reference.
    ///
    /// The margins in coordinate units: θd and φd coordinates are linear in the angle
    /// (n / (π/2), n / π per radian); θh's square, u² = θh / (π/2) · n², is linear in
    /// θh, so θh is tested on u² against the squared edges i² and (i + 1)².
    #[inline(always)]
    fn quick_cell(&self, wi: &[f64; 3], wo: &[f64; 3]) -> usize {
        let [nh, nd, np] = self.n;
        let [mh, md, mp] = self.quick_margin;
        // The arithmetic of [`prep`] on s = wi + wo unnormalised, with one reciprocal
        // square root for h = s/|s| and no quotient for cos θd or the rotated wi: four
        // square roots and two divisions a pair instead of six and five, the loop being
        // bound by the divider (docs/performance.md). With q² = sx² + sy² (r = q/|s|,
        // and sin θh = r for a unit h):
        // cos θh = sz/|s|, cos θd = wi·s/|s|, and r · (d.x, d.y) = (X/|s|², Y/|s|) for
        // X = (wi_x sx + wi_y sy) sz − wi_z q², Y = wi_y sx − wi_x sy, so (X/|s|, Y) =
        // q (d.x, d.y): the tests below take those and q, as `finish` takes
        // r (d.x, d.y) and r. The round-off is a few ulps of each, like prep's.
        let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let q2 = s[0] * s[0] + s[1] * s[1];
        let rn = 1.0 / (q2 + s[2] * s[2]).sqrt();
        let u = (acos_approx((s[2] * rn).min(1.0)) * FRAC_2_PI).sqrt() * nh;
        let cos_d = (wi[0] * s[0] + wi[1] * s[1] + wi[2] * s[2]) * rn;
        let v = acos_approx(cos_d) * FRAC_2_PI * nd;
        let x = ((wi[0] * s[0] + wi[1] * s[1]) * s[2] - wi[2] * q2) * rn;
        let y = wi[1] * s[0] - wi[0] * s[1];
        // φd < 0 folds by +π: the same direction as −d.
        let (dx, dy) = if y < 0.0 { (-x, -y) } else { (x, y) };
        let w = atan2_upper_approx(dy, dx) * FRAC_1_PI * np;
        let inside = |x: f64, b: f64, lo: f64, hi: f64, last: f64, m: f64| {
            ((x - lo > m) | (b == 0.0)) & ((hi - x > m) | (b == last))
        };
        // `max` and `min`, not `clamp` (whose assertion would keep the loop scalar). A
        // NaN coordinate becomes bin 0, and fails the upper edge's test.
        let bin = |x: f64, n: f64| x.floor().max(0.0).min(n - 1.0);
        let (i, j, k) = (bin(u, nh), bin(v, nd), bin(w, np));
        let u2 = u * u;
        let same = (wi[0] == wo[0]) & (wi[1] == wo[1]) & (wi[2] == wo[2]);
        let ok = usable3(wi)
            & usable3(wo)
            & !same
            // h off the normal (r > 0), d.y > MARGIN_PHI r and sin θd > QUICK_SIN_D, as
            // in `finish` and above, on the scaled quantities.
            & (q2 > 0.0)
            & (dy > 0.0)
            & (dy * dy > MARGIN_PHI * MARGIN_PHI * q2)
            & (dx * dx + dy * dy > QUICK_SIN_D * QUICK_SIN_D * q2)
            & inside(u2, i, i * i, (i + 1.0) * (i + 1.0), nh - 1.0, mh)
            & inside(v, j, j, j + 1.0, nd - 1.0, md)
            & inside(w, k, k, k + 1.0, np - 1.0, mp);
        // Integers below 2⁵³ in f64: the index is exact. Through i64, which converts as
        // a vector (AVX-512 DQ); usize does not.
        let idx = (k + np * (j + nd * i)) as i64 as usize;
        if ok { idx } else { SLOW }
    }

    /// The interpolation stencil of a located pair: the bins found as lower nodes (the
    /// last θh / θd node held, φd wrapping), fractions from the angles past the edges.
    #[inline]
    fn stencil(&self, f: &Found) -> [Axis; 3] {
        let (nh, nd, np) = (self.dims.theta_h(), self.dims.theta_d(), self.dims.phi_d());
        let [t, c, s] = self.th_edge[f.i];
        let theta_h = t + small_angle(f.sin_h * c - f.cos_h * s, f.cos_h * c + f.sin_h * s);
        let u = theta_h_coord(theta_h, nh);
        let ax_h = if f.i + 1 >= nh {
            (f.i, f.i, 0.0)
        } else {
            (f.i, f.i + 1, (u - f.i as f64).clamp(0.0, 1.0))
        };
        let sin_d = (f.dx * f.dx + f.dy * f.dy).sqrt() / f.r;
        let [_, c, s] = self.td_edge[f.j];
        let delta = small_angle(sin_d * c - f.cos_d * s, f.cos_d * c + sin_d * s);
        let ax_d = if f.j + 1 >= nd {
            (f.j, f.j, 0.0)
        } else {
            (
                f.j,
                f.j + 1,
                (delta * FRAC_2_PI * nd as f64).clamp(0.0, 1.0),
            )
        };
        let [ex, ey] = self.pd[f.k];
        let delta = small_angle(ex * f.dy - ey * f.dx, ex * f.dx + ey * f.dy);
        let ax_p = (
            f.k,
            (f.k + 1) % np,
            (delta * FRAC_1_PI * np as f64).clamp(0.0, 1.0),
        );
        [ax_h, ax_d, ax_p]
    }
}

/// Pairs per arithmetic pass of the fast path: its arrays (about 17 KiB) stay in L1.
const FAST_RUN: usize = 128;

/// The arithmetic of the fast path for one pair, branch-free so that a loop over a run
/// vectorises; [`Edges::finish`] does the comparisons.
#[derive(Clone, Copy, Debug, Default)]
struct Prep {
    /// h.z exactly as the reference computes it, and the approximate θh coordinate.
    hz: f64,
    u: f64,
    /// r = √(hx² + hy²) and sin θh = √((1 − h.z)(1 + h.z)).
    r: f64,
    sin_h: f64,
    /// cos θd and the approximate θd coordinate.
    cos_d: f64,
    v: f64,
    /// r · (d.x, d.y) folded into d.y ≥ 0, and the approximate φd coordinate.
    dx: f64,
    dy: f64,
    w: f64,
}

/// [`Prep`] of a pair, for grid sizes `n` (θh, θd, φd). Meaningless (but harmless) for
/// pairs that [`Edges::finish`] or [`usable3`] turn away.
#[inline(always)]
fn prep(wi: [f64; 3], wo: [f64; 3], n: [f64; 3]) -> Prep {
    // The half vector exactly as `to_half_diff` computes it: sum, norm, divide.
    let hx = wi[0] + wo[0];
    let hy = wi[1] + wo[1];
    let hz = wi[2] + wo[2];
    let norm = (hx * hx + hy * hy + hz * hz).sqrt();
    let (hx, hy, hz) = (hx / norm, hy / norm, hz / norm);
    let cos_h = hz.min(1.0);
    let u = (acos_approx(cos_h) * FRAC_2_PI).sqrt() * n[0];
    let r = (hx * hx + hy * hy).sqrt();
    let sin_h = ((1.0 - cos_h) * (1.0 + cos_h)).sqrt();
    // wi rotated by −φh about the normal, times r: (a, dy, wi.z · r); then by −θh about
    // the binormal: d.x = t.x cos θh − t.z sin θh, d.z = t.z cos θh + t.x sin θh.
    let a = wi[0] * hx + wi[1] * hy;
    let cos_d = a / r * sin_h + wi[2] * hz;
    let v = acos_approx(cos_d) * FRAC_2_PI * n[1];
    let dx = a * hz - wi[2] * sin_h * r;
    let dy = wi[1] * hx - wi[0] * hy;
    // φd < 0 folds by +π: the same direction as −d.
    let (dx, dy) = if dy < 0.0 { (-dx, -dy) } else { (dx, dy) };
    let w = atan2_upper_approx(dy, dx) * FRAC_1_PI * n[2];
    Prep {
        hz,
        u,
        r,
        sin_h,
        cos_d,
        v,
        dx,
        dy,
        w,
    }
}

/// A run of pairs in columns, their [`Prep`]s in columns, and (nearest) their cells
/// from the quick pass.
struct PrepRun {
    w: [[f64; FAST_RUN]; 6],
    out: [[f64; FAST_RUN]; 9],
    cell: [usize; FAST_RUN],
}

impl PrepRun {
    fn new() -> Self {
        PrepRun {
            w: [[0.0; FAST_RUN]; 6],
            out: [[0.0; FAST_RUN]; 9],
            cell: [SLOW; FAST_RUN],
        }
    }

    /// Pair k of the run.
    #[inline]
    fn pair(&self, k: usize) -> ([f64; 3], [f64; 3]) {
        let w = &self.w;
        ([w[0][k], w[1][k], w[2][k]], [w[3][k], w[4][k], w[5][k]])
    }

    /// The [`Prep`] of pair k.
    #[inline]
    fn prep(&self, k: usize) -> Prep {
        let o = &self.out;
        Prep {
            hz: o[0][k],
            u: o[1][k],
            r: o[2][k],
            sin_h: o[3][k],
            cos_d: o[4][k],
            v: o[5][k],
            dx: o[6][k],
            dy: o[7][k],
            w: o[8][k],
        }
    }

    /// Loads pairs `first .. first + len` (`len` ≤ [`FAST_RUN`]) into the columns, then
    /// [`prep`] over the whole run (every lane, so the loop has no remainder; lanes past
    /// `len` hold stale pairs, never read), and with `quick` the cells of the quick pass
    /// ([`Edges::quick_cell`]) in the same loop.
    #[inline(always)]
    fn compute<P: Fn(usize) -> ([f64; 3], [f64; 3]), A: Fn(&[usize], usize)>(
        &mut self,
        job: &Job<P, A>,
    ) {
        let &Job {
            pair,
            first,
            len,
            edges,
            quick,
            ask,
        } = job;
        for k in 0..len {
            let (wi, wo) = pair(first + k);
            for c in 0..3 {
                self.w[c][k] = wi[c];
                self.w[3 + c][k] = wo[c];
            }
        }
        if quick {
            // Nearest: the cells alone (the few SLOW pairs form their Prep again), a
            // block at a time, each block's lines asked for before the next block's
            // arithmetic: spread that way, the misses stay within what the processor
            // keeps in flight while the arithmetic goes on.
            for b in 0..FAST_RUN / ASK_BLOCK {
                let r = b * ASK_BLOCK..(b + 1) * ASK_BLOCK;
                for k in r.clone() {
                    let (wi, wo) = self.pair(k);
                    self.cell[k] = edges.quick_cell(&wi, &wo);
                }
                ask(&self.cell[r][..], b);
            }
            return;
        }
        // Interpolated: no cells yet; the input lines of the run ahead only.
        for b in 0..FAST_RUN / ASK_BLOCK {
            ask(&[], b);
        }
        for k in 0..FAST_RUN {
            let (wi, wo) = self.pair(k);
            let p = prep(wi, wo, edges.n);
            self.cell[k] = SLOW;
            let o = &mut self.out;
            o[0][k] = p.hz;
            o[1][k] = p.u;
            o[2][k] = p.r;
            o[3][k] = p.sin_h;
            o[4][k] = p.cos_d;
            o[5][k] = p.v;
            o[6][k] = p.dx;
            o[7][k] = p.dy;
            o[8][k] = p.w;
        }
    }

    /// [`compute`](Self::compute) through [`brdfkit_core::lanes::dispatch`]: in a copy
    /// compiled for AVX-512 or AVX2 when the processor has them (the crate is compiled
    /// for baseline x86-64). Rust never fuses a multiply and an add, and division and
    /// square root are correctly rounded in every instruction set, so every copy
    /// computes the same bits (h.z included, which must equal the reference's).
    fn compute_dispatch<P: Fn(usize) -> ([f64; 3], [f64; 3]), A: Fn(&[usize], usize)>(
        &mut self,
        job: &Job<P, A>,
    ) {
        struct Compute<'r, 'j, 'a, P, A> {
            run: &'r mut PrepRun,
            job: &'j Job<'a, P, A>,
        }
        impl<P: Fn(usize) -> ([f64; 3], [f64; 3]), A: Fn(&[usize], usize)> Run
            for Compute<'_, '_, '_, P, A>
        {
            #[inline(always)]
            fn run(&mut self) {
                self.run.compute(self.job)
            }
        }
        dispatch(&mut Compute { run: self, job });
    }
}

/// What [`PrepRun::compute`] works on: pairs `first .. first + len` of `pair`, the
/// grid's edges, and whether to run the quick pass.
struct Job<'a, P, A> {
    pair: &'a P,
    first: usize,
    len: usize,
    edges: &'a Edges,
    quick: bool,
    /// Called after each block of [`ASK_BLOCK`] pairs with their cells ([`SLOW`]
    /// without the quick pass) and the block's number: prefetches.
    ask: &'a A,
}

/// The bracket b with `t[b + 1] < x ≤ t[b]` of non-increasing thresholds `t`, starting
/// from the approximate bin `approx`; `None` when x lies within `margin` of either
/// threshold (or is NaN).
#[inline(always)]
fn bracket(t: &[f64], x: f64, approx: f64, margin: f64) -> Option<usize> {
    if x.is_nan() {
        return None;
    }
    // `as` saturates: a NaN or negative estimate is bin 0.
    let mut b = (approx as usize).min(t.len() - 2);
    // t[0] = +∞ and t[n] = −∞ stop both walks.
    while x > t[b] {
        b -= 1;
    }
    while x <= t[b + 1] {
        b += 1;
    }
    (x - t[b + 1] > margin && t[b] - x > margin).then_some(b)
}

/// The φd sector k of the folded direction (dx, dy), dy > 0: strictly between edge
/// directions k and k + 1 by more than `margin` (cross products), starting from the
/// approximate coordinate `approx`; `None` when that cannot be vouched for.
#[inline(always)]
fn sector(pd: &[[f64; 2]], dx: f64, dy: f64, approx: f64, margin: f64) -> Option<usize> {
    let n = pd.len() - 1;
    let mut k = (approx as usize).min(n - 1);
    for _ in 0..4 {
        // cross(e_k, d) > 0: d is past edge k; cross(d, e_{k+1}) > 0: before edge k + 1.
        let c0 = pd[k][0] * dy - pd[k][1] * dx;
        let c1 = dx * pd[k + 1][1] - dy * pd[k + 1][0];
        if c0 < 0.0 && k > 0 {
            k -= 1;
        } else if c1 < 0.0 && k + 1 < n {
            k += 1;
        } else {
            return (c0 > margin && c1 > margin).then_some(k);
        }
    }
    None
}

/// acos(x) for x in [0, 1] (clamped into it), absolute error ≤ 2.2e-8: Abramowitz &
/// Stegun 4.4.46, acos x = √(1 − x) · Σ aₖ xᵏ. Only picks a bracket; never a result.
#[inline]
fn acos_approx(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    let a = [
        -0.001_262_491_1,
        0.006_670_090_1,
        -0.017_088_125_6,
        0.030_891_881_0,
        -0.050_174_304_6,
        0.088_978_987_4,
        -0.214_598_801_6,
        1.570_796_305_0,
    ];
    (1.0 - x).sqrt() * horner(x, &a)
}

/// Σ cₖ xᵏ by Horner's rule, `coeffs` from the highest power down: p ← p·x + c at
/// each step, the operations the series are written with.
#[inline(always)]
fn horner(x: f64, coeffs: &[f64]) -> f64 {
    coeffs[1..].iter().fold(coeffs[0], |p, &c| p * x + c)
}

/// atan2(y, x) for y ≥ 0 (in [0, π]), absolute error ≤ 1.4e-8: Abramowitz & Stegun
/// 4.4.49 for atan t, t ∈ [0, 1], after reducing by octant. Only picks a bracket.
#[inline]
fn atan2_upper_approx(y: f64, x: f64) -> f64 {
    let ax = x.abs();
    let (num, den) = if y > ax { (ax, y) } else { (y, ax) };
    let t = num / den;
    let t2 = t * t;
    let c = [
        0.002_866_225_7,
        -0.016_165_736_7,
        0.042_909_613_8,
        -0.075_289_640_0,
        0.106_562_639_3,
        -0.142_088_994_4,
        0.199_935_508_5,
        -0.333_331_452_8,
        1.0,
    ];
    let a = t * horner(t2, &c);
    let a = if y > ax { FRAC_PI_2 - a } else { a };
    if x < 0.0 { PI - a } else { a }
}

/// The angle whose sine and cosine are proportional to (s, c), for the small angles
/// past a bin edge: the series of atan(s / c) to t¹³ (error below 1e-17 relative for
/// t ≤ 0.05), `atan2` for wider bins.
#[inline]
fn small_angle(s: f64, c: f64) -> f64 {
    let t = s / c;
    if c > 0.0 && t.abs() <= 0.05 {
        let t2 = t * t;
        let c = [
            1.0 / 13.0,
            -1.0 / 11.0,
            1.0 / 9.0,
            -1.0 / 7.0,
            1.0 / 5.0,
            -1.0 / 3.0,
            1.0,
        ];
        t * horner(t2, &c)
    } else {
        s.atan2(c)
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

    /// Uniform directions on the upper hemisphere (z in [0, 1), so a few at the horizon)
    /// from a small deterministic generator (xorshift; no dev-dependency needed).
    fn directions(seed: u64) -> impl FnMut() -> [f64; 3] {
        let mut state = seed;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        move || {
            let z: f64 = uniform();
            let p = (2.0 * uniform() - 1.0) * PI;
            let s = (1.0 - z * z).sqrt();
            [s * p.cos(), s * p.sin(), z]
        }
    }

    /// Where the quick pass vouches for a cell, it is the reference's (and `finish`
    /// vouches for it too); it leaves next to no random pair to the slow path; and it
    /// turns away wi = wo, h on the normal and unusable pairs.
    #[test]
    fn quick_cells_are_the_reference_cells() {
        for (d, seed) in [
            (Dims::MERL, 3u64),
            (Dims::new(13, 17, 11).unwrap(), 4),
            (Dims::new(200, 7, 360).unwrap(), 5),
        ] {
            let e = Edges::new(d);
            assert!(e.exact);
            let mut dir = directions(seed);
            let (n, mut slow) = (300_000, 0);
            for _ in 0..n {
                let (wi, wo) = (dir(), dir());
                let q = e.quick_cell(&wi, &wo);
                if q == SLOW {
                    slow += 1;
                    continue;
                }
                let (vi, vo) = (Vec3::from(wi), Vec3::from(wo));
                assert!(usable(&vi) && usable(&vo));
                assert_eq!(
                    q,
                    d.bin_index(&to_half_diff(&vi, &vo)),
                    "{d}: {wi:?} {wo:?}"
                );
                let f = e.locate(&wi, &wo).expect("finish vouches where quick does");
                assert_eq!(q, d.index(f.i, f.j, f.k));
            }
            assert!(
                slow * 2000 <= n,
                "{d}: {slow} of {n} pairs left to the slow path"
            );
            let w = dir();
            let mirror = [-w[0], -w[1], w[2]];
            for (wi, wo) in [
                (w, w),
                (w, mirror),
                (w, [w[0], w[1], -w[2]]),
                (w, [f64::NAN, 0.0, 1.0]),
            ] {
                assert_eq!(e.quick_cell(&wi, &wo), SLOW, "{wi:?} {wo:?}");
            }
        }
    }

    /// Large batches read the interleaved copy, small ones the planes until it exists:
    /// the same bits either way, missing cells included; a change to the table drops
    /// the copy and a clone starts without it.
    #[test]
    fn cell_copy_reads_the_same_bits_as_the_planes() {
        let d = Dims::new(30, 30, 60).unwrap();
        let mut t = MerlTable::from_fn(d, |i, j, k| {
            ((i + 2 * j + 3 * k) % 7 != 0)
                .then(|| Rgb::new(0.1 * i as f64, j as f64 / 3.0, k as f64 + 0.7))
        })
        .unwrap();
        let mut dir = directions(9);
        let rows: Vec<f64> = (0..d.cells())
            .flat_map(|_| [dir(), dir()].concat())
            .collect();
        let small = &rows[..6 * (d.cells() / 16)];
        let mut planes = vec![0.0; small.len() / 2];
        t.nearest_flat(small, &mut planes).unwrap();
        assert!(t.cells.0.get().is_none(), "a small batch built the copy");
        let mut all = vec![0.0; rows.len() / 2];
        t.nearest_flat(&rows, &mut all).unwrap();
        assert!(
            t.cells.0.get().is_some(),
            "a large batch did not build the copy"
        );
        let mut copy = vec![0.0; small.len() / 2];
        t.nearest_flat(small, &mut copy).unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&planes), bits(&copy));
        assert_eq!(bits(&planes), bits(&all[..planes.len()]));
        assert!(planes.iter().any(|x| x.is_nan()) && planes.iter().any(|x| !x.is_nan()));
        assert!(t.clone().cells.0.get().is_none());
        // A changed cell is seen at once.
        let (wi, wo) = (&rows[..3], &rows[3..6]);
        let (wi, wo) = (
            Vec3::new(wi[0], wi[1], wi[2]),
            Vec3::new(wo[0], wo[1], wo[2]),
        );
        let (i, j, k) = d.unflatten(d.bin_index(&to_half_diff(&wi, &wo)));
        t.set(i, j, k, Some(Rgb::new(42.0, 43.0, 44.0))).unwrap();
        assert!(t.cells.0.get().is_none());
        t.prepare_lookups(Lookup::Nearest, d.cells());
        t.nearest_flat(&rows[..6], &mut copy[..3]).unwrap();
        assert_eq!(bits(&copy[..3]), bits(&rgb_or_nan(t.nearest(&wi, &wo))));
        assert_eq!(copy[0], 42.0);
    }

    /// The approximations pick brackets only, but their stated errors hold.
    #[test]
    fn approximations_within_their_bounds() {
        for k in 0..=100_000 {
            let x = k as f64 / 100_000.0;
            assert!((acos_approx(x) - x.acos()).abs() <= 2.2e-8, "{x}");
            let a = x * PI;
            let (s, c) = a.sin_cos();
            assert!(
                (atan2_upper_approx(s, c) - s.atan2(c)).abs() <= 1.4e-8,
                "{a}"
            );
            let t = x * 0.05;
            assert!(
                (small_angle(t, 1.0) - t.atan()).abs() <= 1e-17 + 1e-16 * t,
                "{t}"
            );
        }
    }

    /// Each threshold is the reference's exact switch point, and the reference is
    /// monotone for 256 ulps on both sides of it.
    #[test]
    fn thresholds_are_the_reference_switch_points() {
        let d = Dims::MERL;
        let e = Edges::new(d);
        assert!(e.exact);
        for (t, n, f) in [
            (&e.th, d.theta_h(), theta_h_bin as fn(f64, usize) -> usize),
            (&e.td, d.theta_d(), theta_d_bin),
        ] {
            let g = |x: f64| f(x.clamp(-1.0, 1.0).acos(), n);
            assert_eq!(t.len(), n + 1);
            for (j, &tj) in t.iter().enumerate().take(n).skip(1) {
                assert!(g(tj) >= j && g(tj.next_up()) < j, "threshold {j}");
                let (mut lo, mut hi) = (tj, tj.next_up());
                for _ in 0..256 {
                    lo = lo.next_down();
                    hi = hi.next_up();
                    assert!(g(lo) >= j && g(hi) < j, "not monotone near threshold {j}");
                }
            }
        }
    }

    /// The margins against the round-off they guard: over a million random pairs the
    /// fast cos θd and r · (d.x, d.y) are compared with the reference's rotated vector;
    /// the largest differences must stay 100 times below the margins. And the reference
    /// conversion is needed for next to no random pair.
    #[test]
    fn margins_cover_the_measured_round_off() {
        use brdfkit_core::direction::{BINORMAL, NORMAL, rotate};
        let e = Edges::new(Dims::MERL);
        let mut dir = directions(0x9e37_79b9_7f4a_7c15);
        let (mut max_d, mut max_xy, mut fallbacks) = (0.0f64, 0.0f64, 0);
        let n = 1_000_000;
        for _ in 0..n {
            let (wi, wo) = (dir(), dir());
            if !(usable3(&wi) && usable3(&wo)) {
                continue;
            }
            let Some(f) = e.locate(&wi, &wo) else {
                fallbacks += 1;
                continue;
            };
            // The reference's rotated vector, as to_half_diff computes it.
            let (vi, vo) = (Vec3::from(wi), Vec3::from(wo));
            let h = (vi + vo) / (vi + vo).norm();
            let temp = rotate(&vi, &NORMAL, -h.y.atan2(h.x));
            let dref = rotate(&temp, &BINORMAL, -h.z.clamp(-1.0, 1.0).acos());
            max_d = max_d.max((f.cos_d - dref.z).abs());
            // The fast (dx, dy) is folded: compare with ± the reference's, per unit r.
            let sgn = if dref.y < 0.0 { -1.0 } else { 1.0 };
            let ex = (f.dx / f.r - sgn * dref.x).abs();
            let ey = (f.dy / f.r - sgn * dref.y).abs();
            max_xy = max_xy.max(ex.max(ey));
        }
        assert!(max_d * 100.0 <= MARGIN_D, "cos θd round-off {max_d:e}");
        assert!(max_xy * 100.0 <= MARGIN_PHI, "d.xy round-off {max_xy:e}");
        assert!(
            fallbacks <= 10,
            "{fallbacks} of {n} pairs took the reference"
        );
    }
}
