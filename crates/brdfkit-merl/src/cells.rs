//! The directions of a grid's cells from per-axis sines and cosines.
//!
//! [`cell_directions`](crate::cell_directions) converts a cell's angles with
//! [`from_half_diff`](brdfkit_core::from_half_diff): six sines and cosines per cell.
//! Every cell of a row shares θh and θd, and every row the same φd angles, so
//! [`CellDirections`] computes each axis's sines and cosines once and repeats the rest
//! of `from_half_diff`'s arithmetic, operation for operation: the same directions, bit
//! for bit, for the price of a few multiplications (building the cells of a 1.46 M-cell
//! table for a fit spent about a fifth of its CPU in `sin`/`cos` before).

use crate::grid::{Dims, cell_weight, phi_d_angle, theta_d_angle, theta_h_angle};
use crate::io::TablePlanes;
use crate::table::SCALES;
use brdfkit_core::geometry::pair_columns_of;
use brdfkit_core::lanes::{Run, dispatch};
use brdfkit_core::{Columns, Vec3};
use std::ops::Range;

/// (cos, sin) of an angle.
type CosSin = [f64; 2];

/// The sines and cosines of a grid's cell angles, per axis; see the module doc.
#[derive(Clone, Debug)]
pub struct CellDirections {
    theta_h: Vec<CosSin>,
    theta_d: Vec<CosSin>,
    phi_d: Vec<CosSin>,
}

fn cos_sin(a: f64) -> CosSin {
    [a.cos(), a.sin()]
}

/// `brdfkit_core::rotate(v, axis, angle)` with cos and sin of the angle given: the same
/// operations in the same order (Rodrigues' formula, v cos + a (a·v)(1 − cos) + (a × v)
/// sin), hence the same bits.
fn rotate_cs(v: [f64; 3], a: [f64; 3], [c, s]: CosSin) -> [f64; 3] {
    let along = (a[0] * v[0] + a[1] * v[1] + a[2] * v[2]) * (1.0 - c);
    let cross = [
        a[1] * v[2] - a[2] * v[1],
        a[2] * v[0] - a[0] * v[2],
        a[0] * v[1] - a[1] * v[0],
    ];
    std::array::from_fn(|m| v[m] * c + a[m] * along + cross[m] * s)
}

impl CellDirections {
    /// The tables of `dims`.
    pub fn new(dims: Dims) -> Self {
        let (nh, nd, np) = (dims.theta_h(), dims.theta_d(), dims.phi_d());
        CellDirections {
            theta_h: (0..nh)
                .map(|i| cos_sin(theta_h_angle(i as f64, nh)))
                .collect(),
            theta_d: (0..nd)
                .map(|j| cos_sin(theta_d_angle(j as f64, nd)))
                .collect(),
            phi_d: (0..np)
                .map(|k| cos_sin(phi_d_angle(k as f64, np)))
                .collect(),
        }
    }

    /// (wi, wo) of cell (i, j, k): [`cell_directions`](crate::cell_directions)'s, bit
    /// for bit. Panics when the cell is out of range.
    #[inline(always)]
    pub fn get(&self, i: usize, j: usize, k: usize) -> (Vec3, Vec3) {
        Self::dirs(self.theta_h[i], self.theta_d[j], self.phi_d[k])
    }

    /// (wi, wo) of the cell with these (cos, sin) of θh, θd and φd ([`get`](Self::get)).
    #[inline(always)]
    fn dirs([ch, sh]: CosSin, [cd, sd]: CosSin, [cp, sp]: CosSin) -> (Vec3, Vec3) {
        // from_half_diff with φh = 0: d = spherical(θd, φd), rotated by θh about the
        // binormal, then by φh = 0 about the normal (cos 0 = 1, sin 0 = 0 exactly).
        let d = [sd * cp, sd * sp, cd];
        let t = rotate_cs(d, [0.0, 1.0, 0.0], [ch, sh]);
        let wi = Vec3::from(rotate_cs(t, [0.0, 0.0, 1.0], [1.0, 0.0]));
        let h = Vec3::new(sh * 1.0, sh * 0.0, ch);
        let wo = 2.0 * wi.dot(&h) * h - wi;
        (wi, wo)
    }

    /// The ten geometry columns ([`pair_columns_of`]: wi, wo, h, cos θd) of a cell.
    /// The one computation of a cell's columns: [`row_columns`](Self::row_columns)
    /// runs it in its loop, so a cell's columns have the same bits whichever path
    /// builds them.
    #[inline(always)]
    pub fn columns(&self, i: usize, j: usize, k: usize) -> [f64; 10] {
        Self::columns_cs(self.theta_h[i], self.theta_d[j], self.phi_d[k])
    }

    /// [`columns`](Self::columns) from the cell's (cos, sin) of θh, θd and φd.
    #[inline(always)]
    fn columns_cs(th: CosSin, td: CosSin, ph: CosSin) -> [f64; 10] {
        let (wi, wo) = Self::dirs(th, td, ph);
        pair_columns_of([wi.x, wi.y, wi.z], [wo.x, wo.y, wo.z])
    }

    /// [`columns`](Self::columns) of the cells (i, j, k) of row (i, j) with k in `ks`,
    /// into `cols[c][k − ks.start]` (each column at least `ks.len()` long), in one loop
    /// compiled for the widest vector instructions the processor has
    /// ([`brdfkit_core::lanes`]; every operation is branch-free IEEE arithmetic, so the
    /// vector lanes give the scalar bits).
    pub fn row_columns(&self, i: usize, j: usize, ks: Range<usize>, cols: [&mut [f64]; 10]) {
        self.row_columns_of(Columns::ALL, i, j, ks, cols);
    }

    /// [`row_columns`](Self::row_columns) of the columns `set` only; the others are
    /// left as they are (they may be of any length). Each column is the same
    /// computation, so the same bits, as in [`columns`](Self::columns); what differs is
    /// what is computed: the sets a fit reads have their own copy of the loop, from
    /// which the compiler drops the arithmetic of the columns not stored (cos θi and
    /// cos θo need no square root and no division; the strata's cos θh and cos θd need
    /// the half vector but store two columns of ten). Other sets take the ten-column
    /// loop and store theirs only.
    pub fn row_columns_of(
        &self,
        set: Columns,
        i: usize,
        j: usize,
        ks: Range<usize>,
        cols: [&mut [f64]; 10],
    ) {
        const ZS: u16 = Columns::WI_Z.union(Columns::WO_Z).bits();
        const HD: u16 = Columns::H_Z.union(Columns::COS_D).bits();
        const DIRS: u16 = Columns::DIRS.bits();
        const ALL: u16 = Columns::ALL.bits();
        assert!(ks.end <= self.phi_d.len(), "φd range {ks:?} past the grid");
        match set.bits() {
            ZS => dispatch(&mut Row::<ZS>::new(self, set, [i, j], ks, cols)),
            HD => dispatch(&mut Row::<HD>::new(self, set, [i, j], ks, cols)),
            DIRS => dispatch(&mut Row::<DIRS>::new(self, set, [i, j], ks, cols)),
            0 => {}
            _ => dispatch(&mut Row::<ALL>::new(self, set, [i, j], ks, cols)),
        }
    }
}

/// The loop of [`CellDirections::row_columns_of`] computing the columns of the bit
/// mask `M` and storing those of `set` (a subset of `M`).
struct Row<'a, const M: u16> {
    cells: &'a CellDirections,
    set: Columns,
    i: usize,
    j: usize,
    ks: Range<usize>,
    cols: [&'a mut [f64]; 10],
}

impl<'a, const M: u16> Row<'a, M> {
    fn new(
        cells: &'a CellDirections,
        set: Columns,
        [i, j]: [usize; 2],
        ks: Range<usize>,
        cols: [&'a mut [f64]; 10],
    ) -> Self {
        Row {
            cells,
            set,
            i,
            j,
            ks,
            cols,
        }
    }

    /// Whether column c is computed.
    #[inline(always)]
    const fn computed(c: usize) -> bool {
        M & (1 << c) != 0
    }

    /// Whether column c is stored.
    #[inline(always)]
    fn stored(&self, c: usize) -> bool {
        Self::computed(c) && self.set.has(c)
    }
}

impl<const M: u16> Run for Row<'_, M> {
    #[inline(always)]
    fn run(&mut self) {
        // Blocks of B cells computed into a local buffer, then copied out: with ten
        // output columns the compiler cannot prove they do not overlap the tables (too
        // many pairs to check at run time), and left the direct loop scalar; a local
        // buffer overlaps nothing, so the block's loop runs in vector lanes.
        const B: usize = 16;
        let c = self.cells;
        let (th, td) = (c.theta_h[self.i], c.theta_d[self.j]);
        let phi = &c.phi_d[self.ks.clone()];
        let mut buf = [[0.0f64; B]; 10];
        let mut at = 0;
        let (blocks, tail) = phi.as_chunks::<B>();
        for ph in blocks {
            for q in 0..B {
                let v = CellDirections::columns_cs(th, td, ph[q]);
                for (m, (col, x)) in buf.iter_mut().zip(v).enumerate() {
                    if Self::computed(m) {
                        col[q] = x;
                    }
                }
            }
            for (m, x) in buf.iter().enumerate() {
                if self.stored(m) {
                    self.cols[m][at..at + B].copy_from_slice(x);
                }
            }
            at += B;
        }
        for &ph in tail {
            let v = CellDirections::columns_cs(th, td, ph);
            for (m, x) in v.into_iter().enumerate() {
                if self.stored(m) {
                    self.cols[m][at] = x;
                }
            }
            at += 1;
        }
    }
}

/// The valid cells of a table, numbered in file order (cell m is the m-th valid cell),
/// held compactly: the runs of consecutive valid cells along φd (a run is a row (i, j)
/// and a first k), plus the per-axis sines and cosines of [`CellDirections`]. A cell's
/// geometry columns are computed on demand, by [`CellDirections::columns`], for a range
/// ([`fill`](Self::fill)) or a list ([`gather`](Self::gather)) of cells; a MERL table's
/// 1.1 M valid cells come in about 16,000 runs (0.4 MB), where their ten geometry columns
/// take 89 MB.
#[derive(Clone, Debug)]
pub struct CellRuns {
    dirs: CellDirections,
    /// The runs in file order; run r covers cells `runs[r].start .. runs[r + 1].start`
    /// (the last up to `len`).
    runs: Vec<CellRun>,
    len: usize,
}

/// A run of valid cells: cells `start ..` are (i, j, k), (i, j, k + 1), …
#[derive(Clone, Copy, Debug)]
struct CellRun {
    start: usize,
    i: u32,
    j: u32,
    k: u32,
}

impl CellRuns {
    /// The valid cells of a grid `dims` with validity `mask` (one flag per cell, in file
    /// order). Panics when the mask's length is not the grid's cell count.
    pub fn new(dims: Dims, mask: &[bool]) -> Self {
        assert_eq!(mask.len(), dims.cells(), "one validity flag per cell");
        let np = dims.phi_d();
        let mut runs = Vec::new();
        let mut len = 0;
        for (row, valid) in mask.chunks(np).enumerate() {
            let (i, j) = (row / dims.theta_d(), row % dims.theta_d());
            let mut k = 0;
            while k < np {
                let start = k + valid[k..].iter().take_while(|v| !**v).count();
                let end = start + valid[start..].iter().take_while(|v| **v).count();
                if end > start {
                    // u32: a grid axis of 2³² cells would hold more cells than memory.
                    let run = CellRun {
                        start: len,
                        i: i as u32,
                        j: j as u32,
                        k: start as u32,
                    };
                    runs.push(run);
                    len += end - start;
                }
                k = end;
            }
        }
        CellRuns {
            dirs: CellDirections::new(dims),
            runs,
            len,
        }
    }

    /// Number of valid cells.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when no cell is valid.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bytes held (for memory reports).
    pub fn heap_bytes(&self) -> usize {
        let d = &self.dirs;
        self.runs.capacity() * std::mem::size_of::<CellRun>()
            + (d.theta_h.capacity() + d.theta_d.capacity() + d.phi_d.capacity())
                * std::mem::size_of::<CosSin>()
    }

    /// The run holding cell m (m < len).
    fn run_of(&self, m: usize) -> usize {
        self.runs.partition_point(|r| r.start <= m) - 1
    }

    /// The end (one past the last cell) of run r.
    fn run_end(&self, r: usize) -> usize {
        self.runs.get(r + 1).map_or(self.len, |n| n.start)
    }

    /// The ten geometry columns of cell m ([`CellDirections::columns`]). Panics when
    /// m ≥ [`len`](Self::len).
    pub fn cell(&self, m: usize) -> [f64; 10] {
        assert!(m < self.len, "cell {m} of {}", self.len);
        let run = self.runs[self.run_of(m)];
        let k = run.k as usize + (m - run.start);
        self.dirs.columns(run.i as usize, run.j as usize, k)
    }

    /// The columns of cells `cells` into `cols[c][..cells.len()]`, run by run
    /// ([`CellDirections::row_columns`]). Panics when the range reaches past
    /// [`len`](Self::len) or a column is shorter than the range.
    pub fn fill(&self, cells: Range<usize>, cols: [&mut [f64]; 10]) {
        self.fill_columns(cells, Columns::ALL, cols);
    }

    /// [`fill`](Self::fill) of the columns `set` only
    /// ([`CellDirections::row_columns_of`]; the others are left as they are, but must
    /// be as long as the range).
    pub fn fill_columns(&self, cells: Range<usize>, set: Columns, cols: [&mut [f64]; 10]) {
        assert!(cells.end <= self.len, "cells {cells:?} of {}", self.len);
        let mut cols = cols;
        let mut m = cells.start;
        let mut r = if cells.is_empty() { 0 } else { self.run_of(m) };
        while m < cells.end {
            let run = self.runs[r];
            let end = self.run_end(r).min(cells.end);
            let k = run.k as usize + (m - run.start);
            let at = m - cells.start..end - cells.start;
            let out = cols.each_mut().map(|c| &mut c[at.clone()]);
            let ks = k..k + (end - m);
            self.dirs
                .row_columns_of(set, run.i as usize, run.j as usize, ks, out);
            m = end;
            r += 1;
        }
    }

    /// The columns of the cells `idx` (in any order) into `cols[c][..idx.len()]`.
    /// A cell in the run of the one before it (cells in file order, as a subsample
    /// draws them) is found without a search.
    pub fn gather(&self, idx: &[usize], cols: [&mut [f64]; 10]) {
        let mut cols = cols.map(|c| &mut c[..idx.len()]);
        let mut r = 0;
        for (n, &m) in idx.iter().enumerate() {
            assert!(m < self.len, "cell {m} of {}", self.len);
            if !(self.runs[r].start <= m && m < self.run_end(r)) {
                r = self.run_of(m);
            }
            let run = self.runs[r];
            let k = run.k as usize + (m - run.start);
            let v = self.dirs.columns(run.i as usize, run.j as usize, k);
            for (c, x) in cols.iter_mut().zip(v) {
                c[n] = x;
            }
        }
    }
}

/// A run of valid cells as [`CellRuns::spans`] gives it: cells `cells` are the
/// grid's cells `flat .. flat + cells.len()` (file order), all in row (i, j).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CellSpan {
    /// The cells' numbers (the m of the m-th valid cell).
    pub cells: Range<usize>,
    /// The grid index of the first (`k + nφd · (j + nθd · i)`).
    pub flat: usize,
    /// θh bin of the row.
    pub i: usize,
    /// θd bin of the row.
    pub j: usize,
}

impl CellRuns {
    /// The runs of consecutive valid cells, in file order.
    pub fn spans(&self) -> impl Iterator<Item = CellSpan> + '_ {
        let d = self.dirs_dims();
        self.runs.iter().enumerate().map(move |(r, run)| {
            let (i, j, k) = (run.i as usize, run.j as usize, run.k as usize);
            CellSpan {
                cells: run.start..self.run_end(r),
                flat: k + d[2] * (j + d[1] * i),
                i,
                j,
            }
        })
    }

    /// cos θh and cos θd of the grid's row (i, j), the cosines of its cells' half and
    /// difference angles before their directions are formed: a cell's computed h.z and
    /// cos θd ([`CellDirections::columns`]) differ from them by rounding only.
    pub fn row_cosines(&self, i: usize, j: usize) -> [f64; 2] {
        [self.dirs.theta_h[i][0], self.dirs.theta_d[j][0]]
    }

    /// The grid's (θh, θd, φd) bin counts.
    fn dirs_dims(&self) -> [usize; 3] {
        [
            self.dirs.theta_h.len(),
            self.dirs.theta_d.len(),
            self.dirs.phi_d.len(),
        ]
    }
}

/// The valid cells of a table as a fit takes them, in file order: their grid positions
/// ([`CellRuns`]), their physical values per channel (raw × [`SCALES`], the product
/// [`MerlTable::get_flat`](crate::MerlTable::get_flat) forms) and each cell's measure
/// ([`cell_weight`] of its row).
#[derive(Clone, Debug)]
pub struct TableCells {
    /// Which cells.
    pub runs: CellRuns,
    /// Values (1/sr), one plane per channel; cell m at index m.
    pub values: [Vec<f64>; 3],
    /// Measure of each cell's (wi, wo) pairs (sr²).
    pub measure: Vec<f64>,
}

impl TableCells {
    /// The valid cells of a table file, read without building the table
    /// ([`TablePlanes::read`], then [`from_planes`](Self::from_planes)). Every failure is
    /// the [`MerlError`](crate::MerlError) that [`MerlTable::read`](crate::MerlTable::read)
    /// gives.
    pub fn read(path: impl AsRef<std::path::Path>) -> Result<TableCells, crate::MerlError> {
        Ok(TableCells::from_planes(TablePlanes::read(path)?))
    }

    /// The valid cells of a file's planes, built in the planes' own buffers: each
    /// plane's valid values are moved to its front, in cell order, and it is cut to
    /// them. The values go from the file into fresh memory once; the planes' invalid
    /// cells (a quarter of a MERL table) are given back. The three planes and the
    /// measures are four parallel tasks.
    pub fn from_planes(p: TablePlanes) -> TableCells {
        let TablePlanes {
            dims,
            planes,
            valid,
            n_valid,
        } = p;
        let runs = CellRuns::new(dims, &valid);
        drop(valid);
        debug_assert_eq!(runs.len(), n_valid);
        let [r, g, b] = planes;
        let ((r, g), (b, measure)) = rayon::join(
            || rayon::join(|| runs.compact(r, 0), || runs.compact(g, 1)),
            || rayon::join(|| runs.compact(b, 2), || runs.measures(dims)),
        );
        TableCells {
            runs,
            values: [r, g, b],
            measure,
        }
    }
}

impl CellRuns {
    /// The valid cells' physical values of channel `c` from its raw plane (one value per
    /// grid cell), computed in place: a cell's number is never above its grid index, so
    /// a forward pass moves each run before anything overwrites it. The plane is then
    /// cut to the valid cells (a shrink in place: no copy).
    fn compact(&self, mut plane: Vec<f64>, c: usize) -> Vec<f64> {
        for s in self.spans() {
            plane.copy_within(s.flat..s.flat + s.cells.len(), s.cells.start);
            for v in &mut plane[s.cells] {
                *v *= SCALES[c];
            }
        }
        plane.truncate(self.len);
        plane.shrink_to_fit();
        plane
    }

    /// Each valid cell's measure, [`cell_weight`] of its row (four sines a span).
    fn measures(&self, dims: Dims) -> Vec<f64> {
        let mut w = crate::zeroed_f64_exact(self.len);
        for s in self.spans() {
            w[s.cells].fill(cell_weight(dims, s.i, s.j));
        }
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cell_directions;

    /// Ten columns as the slices the fills take.
    fn ten(cols: &mut [Vec<f64>]) -> [&mut [f64]; 10] {
        let mut it = cols.iter_mut();
        std::array::from_fn(|_| it.next().expect("ten columns").as_mut_slice())
    }

    /// A row's columns are `get`'s directions and `pair_columns`' numbers, bit for bit.
    #[test]
    fn row_columns_are_the_cells_columns() {
        for (a, b, c) in [(90, 90, 180), (13, 17, 11), (1, 1, 1)] {
            let dims = Dims::new(a, b, c).unwrap();
            let fast = CellDirections::new(dims);
            let np = dims.phi_d();
            let mut cols = vec![vec![0.0; np + 3]; 10];
            for i in 0..dims.theta_h() {
                for j in 0..dims.theta_d() {
                    fast.row_columns(i, j, 0..np, ten(&mut cols));
                    let want: Vec<[u64; 10]> = (0..np)
                        .map(|k| {
                            let (wi, wo) = fast.get(i, j, k);
                            brdfkit_core::geometry::pair_columns(&wi, &wo).map(f64::to_bits)
                        })
                        .collect();
                    let got: Vec<[u64; 10]> = (0..np)
                        .map(|k| std::array::from_fn(|m| cols[m][k].to_bits()))
                        .collect();
                    assert_eq!(got, want, "row {i} {j}");
                }
            }
        }
    }

    /// A column set's loop stores that set's columns with the ten-column loop's bits
    /// and leaves the others as they were, for the sets with their own loop and others.
    #[test]
    fn a_column_set_s_row_is_the_row_s_columns() {
        let dims = Dims::new(90, 90, 180).unwrap();
        let fast = CellDirections::new(dims);
        let np = dims.phi_d();
        let sets = [
            Columns::WI_Z | Columns::WO_Z,
            Columns::H_Z | Columns::COS_D,
            Columns::DIRS,
            Columns::WO_Z,
            Columns::NONE,
            Columns::ALL,
        ];
        for (i, j) in [(0, 0), (45, 45), (89, 89), (13, 70), (70, 3)] {
            let mut all = vec![vec![0.0; np]; 10];
            fast.row_columns(i, j, 0..np, ten(&mut all));
            for set in sets {
                for ks in [0..np, 3..40, 170..171] {
                    let mut cols = vec![vec![-7.0; np]; 10];
                    fast.row_columns_of(set, i, j, ks.clone(), ten(&mut cols));
                    for c in 0..10 {
                        let want: Vec<u64> = if set.has(c) {
                            all[c][ks.clone()].iter().map(|x| x.to_bits()).collect()
                        } else {
                            vec![(-7.0f64).to_bits(); ks.len()]
                        };
                        let got: Vec<u64> =
                            cols[c][..ks.len()].iter().map(|x| x.to_bits()).collect();
                        assert_eq!(got, want, "row {i} {j}, {set:?}, column {c}");
                    }
                }
            }
        }
    }

    #[test]
    fn same_bits_as_cell_directions_on_every_cell() {
        let grids = [(90, 90, 180), (13, 17, 11), (1, 1, 1)];
        for dims in grids.map(|(a, b, c)| Dims::new(a, b, c).unwrap()) {
            let fast = CellDirections::new(dims);
            for x in 0..dims.cells() {
                let (i, j, k) = dims.unflatten(x);
                let (_, wi, wo, _) = cell_directions(dims, i, j, k);
                let (a, b) = fast.get(i, j, k);
                let bits = |v: Vec3| v.map(f64::to_bits);
                assert_eq!((bits(a), bits(b)), (bits(wi), bits(wo)), "cell {i} {j} {k}");
            }
        }
    }

    /// The valid cells of a grid whose mask leaves out a few runs per row (and whole
    /// rows), built three ways: whole rows then the valid cells copied out (how a
    /// table's columns were built before), by ranges (`fill`, ranges that split runs
    /// and rows) and cell by cell (`gather`, in any order); the same bits.
    #[test]
    fn runs_give_the_valid_cells_columns_by_range_and_by_cell() {
        let dims = Dims::new(13, 17, 23).unwrap();
        let mask: Vec<bool> = (0..dims.cells())
            .map(|x| {
                let (i, j, k) = dims.unflatten(x);
                i != 4 && (k * 7 + i * 3 + j) % 11 > 2 && !(j == 5 && k > 10)
            })
            .collect();
        let fast = CellDirections::new(dims);
        let mut want: Vec<[u64; 10]> = Vec::new();
        let np = dims.phi_d();
        for (row, valid) in mask.chunks(np).enumerate() {
            let (i, j) = (row / dims.theta_d(), row % dims.theta_d());
            let mut cols = vec![vec![0.0; np]; 10];
            fast.row_columns(i, j, 0..np, ten(&mut cols));
            for k in (0..np).filter(|&k| valid[k]) {
                want.push(std::array::from_fn(|c| cols[c][k].to_bits()));
            }
        }
        let runs = CellRuns::new(dims, &mask);
        assert_eq!(runs.len(), mask.iter().filter(|v| **v).count());
        assert_eq!(runs.len(), want.len());
        let n = runs.len();
        let bits = |cols: &[Vec<f64>], len: usize| -> Vec<[u64; 10]> {
            (0..len)
                .map(|k| std::array::from_fn(|c| cols[c][k].to_bits()))
                .collect()
        };
        for size in [1, 5, 37, 2048] {
            let mut start = 0;
            while start < n {
                let end = (start + size).min(n);
                let mut cols = vec![vec![f64::NAN; size]; 10];
                runs.fill(start..end, ten(&mut cols));
                assert_eq!(bits(&cols, end - start), want[start..end], "{start}..{end}");
                start = end;
            }
        }
        // In reverse order (a search per cell) and in file order (runs followed).
        for idx in [
            (0..n).rev().step_by(3).collect::<Vec<usize>>(),
            (0..n).filter(|m| m % 5 != 1).collect(),
        ] {
            let mut cols = vec![vec![0.0; idx.len()]; 10];
            runs.gather(&idx, ten(&mut cols));
            let picked: Vec<[u64; 10]> = idx.iter().map(|&m| want[m]).collect();
            assert_eq!(bits(&cols, idx.len()), picked);
        }
        assert!(CellRuns::new(dims, &vec![false; dims.cells()]).is_empty());
    }

    /// The spans cover the valid cells once each, in file order, with their grid index
    /// and row; a file's planes turned in place into cells give every valid cell's
    /// `get_flat` value and `cell_weight` measure, bit for bit, in buffers cut to the
    /// valid cells.
    #[test]
    fn spans_and_cells_in_place_are_the_tables_valid_cells() {
        let dims = Dims::new(13, 17, 23).unwrap();
        let t = crate::MerlTable::from_fn(dims, |i, j, k| {
            let x = (i * 31 + j * 7 + k) as f64;
            // Gaps of every length, a row with none valid (i = 4), whole valid rows.
            ((k * 7 + i * 3 + j) % 11 > 2 && i != 4 || j == 0)
                .then(|| brdfkit_core::Rgb::new(x.sin().abs(), x * 1e-3, 1.0 / (1.0 + x)))
        })
        .unwrap();
        let valid: Vec<usize> = (0..dims.cells()).filter(|&x| t.is_valid(x)).collect();
        let runs = CellRuns::new(dims, t.valid_mask());
        let mut covered = Vec::new();
        for s in runs.spans() {
            assert_eq!(s.cells.start, covered.len());
            for (n, m) in s.cells.clone().enumerate() {
                assert_eq!(
                    dims.unflatten(s.flat + n),
                    (s.i, s.j, dims.unflatten(valid[m]).2)
                );
                covered.push(s.flat + n);
            }
        }
        assert_eq!(covered, valid);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.binary");
        t.write(&path).unwrap();
        let cells = TableCells::read(&path).unwrap();
        assert_eq!(cells.runs.len(), valid.len());
        for c in 0..3 {
            let want: Vec<u64> = valid
                .iter()
                .map(|&x| t.get_flat(x).unwrap()[c].to_bits())
                .collect();
            let got: Vec<u64> = cells.values[c].iter().map(|v| v.to_bits()).collect();
            assert_eq!(got, want, "channel {c}");
            assert_eq!(cells.values[c].capacity(), valid.len(), "cut to the cells");
        }
        let want: Vec<f64> = valid
            .iter()
            .map(|&x| {
                let (i, j, _) = dims.unflatten(x);
                cell_weight(dims, i, j)
            })
            .collect();
        assert_eq!(cells.measure, want);
    }
}
