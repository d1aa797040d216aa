//! [`FitData`]: the cells a fit sees, precomputed once as a structure of arrays.

use crate::error::FitError;
use brdfkit_core::geometry::split_runs;
use brdfkit_core::lanes::{Run, dispatch};
use brdfkit_core::{Columns, GeomSlice, GeometryBatch, Model, Rgb};
use brdfkit_merl::{CellBatch, CellRuns, MerlTable, TableCells, cell_weight, zeroed_f64_exact};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::FRAC_PI_2;
use std::ops::Range;
use std::sync::{Arc, Mutex, OnceLock};

/// The error of a table without a valid cell, whichever way its cells are built.
fn no_valid_cell() -> FitError {
    FitError::NoCells("the table has no valid cell".into())
}

/// Valid cells of each θh slab of a table (an error when there is none).
fn valid_per_slab(t: &MerlTable) -> Result<Vec<usize>, FitError> {
    if t.valid_count() == 0 {
        return Err(no_valid_cell());
    }
    let d = t.dims();
    Ok(t.valid_mask()
        .par_chunks(d.theta_d() * d.phi_d())
        .map(|s| s.iter().filter(|&&v| v).count())
        .collect())
}

/// Number of bins along each of √(θh/(π/2)) and θd/(π/2) used to stratify a subsample.
/// The square root follows MERL's θh spacing, so each bin holds a similar cell count.
pub const STRATA: usize = 16;

/// Cells per chunk of a parallel pass over a [`FitData`] (model values here, the cost
/// and normal-equation passes of [`crate::problem`]): big enough to amortise a model
/// call and a rayon task, small enough that a chunk's scratch
/// (12 params × 2048 × 24 B ≈ 0.6 MB) stays in the L2 cache.
pub const PASS_CHUNK_CELLS: usize = 2048;

/// The cells of a fit: per-cell geometry, measured values per channel, the cell's
/// measure of (wi, wo) pairs, and a multiplicity (how many cells of the full set a cell
/// stands for after subsampling; 1 otherwise).
///
/// Cell m has geometry pair m of [`geometry`](Self::geometry), value
/// `values()[c][m]` in channel c (1/sr), measure `measure()[m]` (sr²) and angles
/// `theta_h()[m]`, `theta_d()[m]` (radians).
///
/// # Memory
/// Only what every pass of a fit reads is stored: the three value planes and the
/// measures, and the geometry: ten columns for cells given by their directions
/// ([`from_parts`](Self::from_parts)) and for subsets, but for a table's cells
/// ([`from_table`](Self::from_table)) only what identifies each cell ([`CellRuns`]:
/// its grid row and φd index, 0.4 MB for a MERL table, where the ten columns take
/// 89 MB). A default fit reads a table's full geometry only in single passes (the
/// subsample's strata, the targets' RMS, the loss report), which build it chunk by chunk
/// ([`geometry_of`](Self::geometry_of)) in cache-sized scratch, of only the columns
/// they read where they say which ([`columns_of`](Self::columns_of)); the whole-set
/// columns are built on the first call of [`geometry`](Self::geometry) and kept.
/// Multiplicities are stored only for a subsample (a full set's are all 1), and the
/// angles, which only subsampling, the θd cutoff and reports need, are recomputed from
/// the geometry (θh = acos h.z, θd = acos cos_d) where used;
/// [`theta_h`](Self::theta_h), [`theta_d`](Self::theta_d) and
/// [`multiplicity`](Self::multiplicity) build their arrays on first call and keep them.
#[derive(Debug, Clone)]
pub struct FitData {
    geometry: Geometry,
    values: [Vec<f64>; 3],
    measure: Vec<f64>,
    /// `None`: every cell stands for itself (multiplicity 1).
    mult: Option<Vec<f64>>,
    /// Lazily built views (see the type's doc).
    ones: OnceLock<Vec<f64>>,
    theta_h: OnceLock<Vec<f64>>,
    theta_d: OnceLock<Vec<f64>>,
    /// Subsamples already drawn from these cells ([`FitData::shared_subsample`]).
    subsets: SubsetCache,
    /// ∛(f cos θi) per channel ([`FitData::cbrt_targets`]).
    cbrt_targets: OnceLock<[Vec<f64>; 3]>,
    /// Σ of the weights under solid-angle and uniform weighting
    /// ([`FitData::weight_sum`]), formed on first use.
    weight_sums: [OnceLock<f64>; 2],
    /// What scattered samples these cells were built from (`None`: a table, or a
    /// subset of cells), which a fit's record carries.
    input: Option<SampleInput>,
}

/// The geometry of a [`FitData`]'s cells.
#[derive(Debug, Clone)]
enum Geometry {
    /// The ten columns, given (cells from directions, subsets).
    Given(GeometryBatch),
    /// A table's valid cells, whose columns are computed where read and built whole on
    /// first use of [`FitData::geometry`].
    Table {
        cells: Arc<CellRuns>,
        built: OnceLock<GeometryBatch>,
    },
}

impl Geometry {
    /// The whole-set columns if they exist.
    fn built(&self) -> Option<&GeometryBatch> {
        match self {
            Geometry::Given(g) => Some(g),
            Geometry::Table { built, .. } => built.get(),
        }
    }

    /// A table's cells, while their columns are not built.
    fn lazy(&self) -> Option<&CellRuns> {
        match self {
            Geometry::Table { cells, built } if built.get().is_none() => Some(cells),
            _ => None,
        }
    }
}

/// The stratified subsamples drawn from a cell set, by (fraction, seed): the warm-up
/// and exploration sets depend on the cells and the settings, not on the model, so the
/// families of a batch, a report or `fit --model a,b,c` (and the three passes of a
/// per-channel fit) draw them once. A clone starts empty (its values may be changed),
/// and so does a set whose values are changed ([`FitData::values_mut`]).
#[derive(Default)]
struct SubsetCache(Mutex<Vec<Subset>>);

/// A drawn subsample and its key: (the fraction's bits, the seed).
type Subset = ((u64, u64), Arc<FitData>);

impl Clone for SubsetCache {
    fn clone(&self) -> Self {
        SubsetCache::default()
    }
}

impl std::fmt::Debug for SubsetCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.0.lock().map_or(0, |v| v.len());
        write!(f, "SubsetCache({n} subsamples)")
    }
}

/// The strata's edges as cosines, so that a cell's bin needs no `acos`.
///
/// The bin of a cosine z is a = ⌊√(θ/(π/2)) · [`STRATA`]⌋ along θh and
/// b = ⌊θ/(π/2) · [`STRATA`]⌋ along θd, with θ = acos z clamped ([`acos_clamped`]; a
/// NaN θ counts as 0, θ > π/2 falls in the last bin). Both are non-increasing in z,
/// so bin ≥ e exactly when z ≤ the largest z of bin ≥ e; that cosine is found once,
/// by bisection over the ordered f64 values of [−1, 1] on the formula itself, so the
/// edge test gives the formula's bin for every z, bit for bit (`tests` compares them
/// on a whole table and beside every edge).
struct StrataEdges {
    /// `h[e − 1]`: the largest cos θh whose θh bin is ≥ e, for e = 1 … STRATA − 1.
    h: [f64; STRATA - 1],
    d: [f64; STRATA - 1],
}

impl StrataEdges {
    fn get() -> &'static StrataEdges {
        static EDGES: OnceLock<StrataEdges> = OnceLock::new();
        EDGES.get_or_init(|| StrataEdges {
            h: std::array::from_fn(|e| Self::edge(e + 1, Self::h_bin)),
            d: std::array::from_fn(|e| Self::edge(e + 1, Self::d_bin)),
        })
    }

    /// The θh bin of cos θh = z by the formula (not capped at STRATA − 1).
    fn h_bin(z: f64) -> usize {
        ((acos_clamped(z).max(0.0) / FRAC_PI_2).sqrt() * STRATA as f64) as usize
    }

    /// The θd bin of cos θd = z by the formula (not capped).
    fn d_bin(z: f64) -> usize {
        ((acos_clamped(z).max(0.0) / FRAC_PI_2) * STRATA as f64) as usize
    }

    /// The largest z in [−1, 1] with `bin(z) ≥ e` (the bin is ≥ e at −1 and 0 at 1).
    fn edge(e: usize, bin: fn(f64) -> usize) -> f64 {
        brdfkit_core::direction::last_cosine_where(|z| bin(z) >= e)
    }

    /// The bin of z: how many edges z is at or below (NaN: none, bin 0).
    #[inline]
    fn bin(edges: &[f64; STRATA - 1], z: f64) -> usize {
        edges.iter().map(|&t| usize::from(z <= t)).sum()
    }

    /// The stratum `a · STRATA + b` of a cell with cos θh = `hz` and cos θd = `cd`.
    #[inline]
    fn stratum(&self, hz: f64, cd: f64) -> usize {
        Self::bin(&self.h, hz) * STRATA + Self::bin(&self.d, cd)
    }
}

/// The geometry of all the valid cells of a table, built in parallel chunks of
/// [`PASS_CHUNK_CELLS`] ([`CellRuns::fill`]), on columns that lie on huge pages where the
/// system allows ([`zeroed_f64_exact`]): a MERL table's cells are 89 MB of fresh columns,
/// and with 4 KiB pages their 22,000 first-touch faults cost more CPU than filling them
/// (docs/performance.md, "Issue 28, session 11").
fn table_geometry(cells: &CellRuns) -> GeometryBatch {
    let n = cells.len();
    let mut g = GeometryBatch::from_column_fn(|| zeroed_f64_exact(n));
    let lens: Vec<usize> = (0..n.div_ceil(PASS_CHUNK_CELLS))
        .map(|c| PASS_CHUNK_CELLS.min(n - c * PASS_CHUNK_CELLS))
        .collect();
    split_runs(g.columns_mut(), &lens)
        .into_par_iter()
        .enumerate()
        .for_each(|(c, cols)| {
            let s = c * PASS_CHUNK_CELLS;
            cells.fill(s..s + cols[0].len(), cols);
        });
    g
}

/// Scratch for one chunk's geometry computed where read ([`FitData::columns_of`]): the
/// columns the pass does not read hold NaN, so that a model reading a column it did not
/// declare ([`Model::geometry_columns`]) gives NaN, never another cell's numbers.
#[derive(Debug, Default)]
pub struct ChunkGeometry {
    g: GeometryBatch,
    /// (rows, columns filled) of the last chunk; the other columns hold NaN.
    shape: Option<(usize, Columns)>,
}

impl ChunkGeometry {
    /// The columns, `n` rows each, for filling the ones of `set`: the others are set to
    /// NaN when the rows or the set change (not at every chunk: it would cost the
    /// stores that filling only `set` saves).
    fn prepare(&mut self, n: usize, set: Columns) -> [&mut [f64]; 10] {
        if self.shape != Some((n, set)) {
            self.g.resize(n);
            for (c, col) in self.g.columns_mut().into_iter().enumerate() {
                if !set.has(c) {
                    col.fill(f64::NAN);
                }
            }
            self.shape = Some((n, set));
        }
        self.g.columns_mut()
    }
}

/// acos with its argument clamped to [−1, 1]: normalisation can land a ulp beyond 1.
#[inline]
fn acos_clamped(z: f64) -> f64 {
    z.clamp(-1.0, 1.0).acos()
}

impl FitData {
    /// The valid cells of a table with their values and measures allocated (zeroed) and
    /// multiplicity 1.
    fn zeroed(cells: CellRuns) -> FitData {
        let n = cells.len();
        FitData::assemble(
            Geometry::Table {
                cells: Arc::new(cells),
                built: OnceLock::new(),
            },
            [0, 1, 2].map(|_| zeroed_f64_exact(n)),
            zeroed_f64_exact(n),
            None,
        )
    }

    fn assemble(
        geometry: Geometry,
        values: [Vec<f64>; 3],
        measure: Vec<f64>,
        mult: Option<Vec<f64>>,
    ) -> FitData {
        FitData {
            geometry,
            values,
            measure,
            mult,
            ones: OnceLock::new(),
            theta_h: OnceLock::new(),
            theta_d: OnceLock::new(),
            subsets: SubsetCache::default(),
            cbrt_targets: OnceLock::new(),
            weight_sums: Default::default(),
            input: None,
        }
    }

    /// These cells, described as built from `input` ([`FitData::from_samples`]).
    pub(crate) fn with_input(mut self, input: SampleInput) -> FitData {
        self.input = Some(input);
        self
    }

    /// What scattered samples the cells were built from; `None` for a table's cells
    /// and for subsets (cutoffs, subsamples).
    pub fn input(&self) -> Option<&SampleInput> {
        self.input.as_ref()
    }

    pub(crate) fn input_mut(&mut self) -> Option<&mut SampleInput> {
        self.input.as_mut()
    }

    /// Cells from their parts: geometry, values per channel (finite, ≥ 0) and the
    /// measure of each cell (finite, > 0; pass ones when only uniform weighting will be
    /// used). Angles are recomputed from the geometry: θh = acos(h.z), θd = acos(wi·h).
    pub fn from_parts(
        geometry: GeometryBatch,
        values: [Vec<f64>; 3],
        measure: Vec<f64>,
    ) -> Result<Self, FitError> {
        let n = geometry.len();
        check_channel_lengths(&values, n)?;
        for (c, v) in values.iter().enumerate() {
            if let Some((k, x)) = first_bad(v, |x| x >= 0.0) {
                return Err(FitError::Data(format!(
                    "channel {c} value {x} at cell {k} is not a finite non-negative number"
                )));
            }
        }
        if measure.len() != n {
            let len = measure.len();
            return Err(FitError::Data(format!("{len} measures for {n} cells")));
        }
        if let Some((k, x)) = first_bad(&measure, |x| x > 0.0) {
            return Err(FitError::Data(format!(
                "measure {x} at cell {k} is not a finite positive number"
            )));
        }
        Ok(FitData::assemble(
            Geometry::Given(geometry),
            values,
            measure,
            None,
        ))
    }

    /// The valid cells of a table batch ([`MerlTable::cell_batch`]).
    pub fn from_cell_batch(b: CellBatch) -> Result<Self, FitError> {
        FitData::from_parts(b.geometry, b.values, b.weights)
    }

    /// The valid cells of a table (only they take part in a fit), in file order: the
    /// same cells, values, measures and geometry as [`MerlTable::cell_batch`], built in
    /// place (the peak is the table plus the cells' values and measures). The geometry
    /// is kept as the cells' grid indices ([`CellRuns`]), its columns computed where
    /// they are read (see the type's doc).
    pub fn from_table(t: &MerlTable) -> Result<Self, FitError> {
        let counts = valid_per_slab(t)?;
        let mut data = FitData::zeroed(CellRuns::new(t.dims(), t.valid_mask()));
        debug_assert_eq!(data.len(), counts.iter().sum::<usize>());
        data.fill_values(t, &counts);
        Ok(data)
    }

    /// The valid cells of a table file read straight into the cells' arrays
    /// ([`TableCells`]: no table is built, so the values are copied from the file into
    /// fresh memory once, where going through [`from_table`](Self::from_table) copies
    /// them twice and holds the table and the cells together). The same cells, values,
    /// measures and geometry as `from_table` of the table read from the file, bit for
    /// bit.
    pub fn from_table_cells(c: TableCells) -> Result<Self, FitError> {
        if c.runs.is_empty() {
            return Err(no_valid_cell());
        }
        Ok(FitData::assemble(
            Geometry::Table {
                cells: Arc::new(c.runs),
                built: OnceLock::new(),
            },
            c.values,
            c.measure,
            None,
        ))
    }

    /// [`from_table`](Self::from_table) for a table the caller no longer needs: the
    /// table is freed as soon as its values are taken. Identical result.
    pub fn from_owned_table(t: MerlTable) -> Result<Self, FitError> {
        FitData::from_table(&t)
    }

    /// Values and measures of the valid cells, one θh slab (`counts[i]` valid cells)
    /// per parallel task.
    fn fill_values(&mut self, t: &MerlTable, counts: &[usize]) {
        let dims = t.dims();
        let slab = dims.theta_d() * dims.phi_d();
        let [r, g, b] = &mut self.values;
        let runs = split_runs([r, g, b, &mut self.measure], counts);
        let np = dims.phi_d();
        runs.into_par_iter()
            .enumerate()
            .for_each(|(i, [r, g, b, w])| {
                let mut m = 0;
                // Row by row, so that no cell's (i, j) is recovered from its index (two
                // integer divisions a cell). The weight is one per (i, j) row (four
                // sines): computed at the row's first valid cell.
                for j in 0..dims.theta_d() {
                    let mut weight = None;
                    for x in i * slab + j * np..i * slab + (j + 1) * np {
                        // `get_flat` is `Some` exactly for valid cells.
                        if let Some(v) = t.get_flat(x) {
                            (r[m], g[m], b[m]) = (v[0], v[1], v[2]);
                            w[m] = *weight.get_or_insert_with(|| cell_weight(dims, i, j));
                            m += 1;
                        }
                    }
                }
                debug_assert_eq!(m, r.len());
            });
    }

    /// A table's cells with values replaced by a model's at the cells' directions (a
    /// synthetic table for tests and benchmarks). Equivalent to fitting
    /// `MerlTable::from_brdf(model)` but keeps full f64 values.
    pub fn with_model_values(&self, model: &dyn Model) -> FitData {
        let mut out = self.clone();
        let n = self.len();
        let vals: Vec<Rgb> = {
            let mut v = vec![Rgb::ZERO; n];
            v.par_chunks_mut(PASS_CHUNK_CELLS)
                .enumerate()
                .for_each_init(GeometryBatch::default, |scratch, (ci, o)| {
                    let s = ci * PASS_CHUNK_CELLS;
                    model.eval_batch(&self.geometry_of(s..s + o.len(), scratch), o);
                });
            v
        };
        for (c, v) in out.values_mut().iter_mut().enumerate() {
            *v = vals.iter().map(|x| x[c]).collect();
        }
        out
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.measure.len()
    }

    /// True when there is no cell.
    pub fn is_empty(&self) -> bool {
        self.measure.is_empty()
    }

    /// Per-cell geometry: for a table's cells, built on the first call (ten columns,
    /// 80 bytes a cell) and kept. Passes that read each cell once take
    /// [`geometry_of`](Self::geometry_of) instead.
    pub fn geometry(&self) -> &GeometryBatch {
        match &self.geometry {
            Geometry::Given(g) => g,
            Geometry::Table { cells, built } => built.get_or_init(|| table_geometry(cells)),
        }
    }

    /// The whole-set geometry if it is built (always, for cells not from a table).
    pub fn geometry_if_built(&self) -> Option<&GeometryBatch> {
        self.geometry.built()
    }

    /// The geometry of the cells `r`, the same bits as `geometry().slice(r)`: that slice
    /// when the whole-set columns are built, otherwise computed into `scratch` (its
    /// columns reused; at [`PASS_CHUNK_CELLS`] cells, 160 kB, they stay in the L2
    /// cache). Panics when `r` reaches past [`len`](Self::len).
    pub fn geometry_of<'a>(
        &'a self,
        r: Range<usize>,
        scratch: &'a mut GeometryBatch,
    ) -> GeomSlice<'a> {
        match self.geometry.lazy() {
            None => self.geometry().slice(r),
            Some(cells) => {
                scratch.resize(r.len());
                cells.fill(r, scratch.columns_mut());
                scratch.as_slice()
            }
        }
    }

    /// [`geometry_of`](Self::geometry_of) where only the columns `set` are read: a
    /// table's cells compute those alone ([`CellRuns::fill_columns`], the same bits),
    /// the others hold NaN; built or given columns are sliced whole.
    pub fn columns_of<'a>(
        &'a self,
        r: Range<usize>,
        set: Columns,
        scratch: &'a mut ChunkGeometry,
    ) -> GeomSlice<'a> {
        match self.geometry.lazy() {
            None => self.geometry().slice(r),
            Some(cells) => {
                cells.fill_columns(r.clone(), set, scratch.prepare(r.len(), set));
                scratch.g.as_slice()
            }
        }
    }

    /// The ten geometry columns of cell m ([`brdfkit_core::geometry::pair_columns`]'s
    /// order), from the whole-set columns when built.
    #[inline]
    fn pair_at(&self, m: usize) -> [f64; 10] {
        match self.geometry.lazy() {
            None => self.geometry().as_slice().columns().map(|c| c[m]),
            Some(cells) => cells.cell(m),
        }
    }

    /// Measured values, one plane per channel.
    pub fn values(&self) -> &[Vec<f64>; 3] {
        &self.values
    }

    /// Mutable value planes (e.g. to add noise to a synthetic table). Values must stay
    /// finite and non-negative.
    pub fn values_mut(&mut self) -> &mut [Vec<f64>; 3] {
        self.subsets = SubsetCache::default();
        self.cbrt_targets = OnceLock::new();
        &mut self.values
    }

    /// Each cell's measure of (wi, wo) pairs.
    pub fn measure(&self) -> &[f64] {
        &self.measure
    }

    /// How many cells of the full set each cell stands for (1 unless subsampled).
    pub fn multiplicity(&self) -> &[f64] {
        match &self.mult {
            Some(m) => m,
            None => self.ones.get_or_init(|| vec![1.0; self.len()]),
        }
    }

    /// The stored multiplicities: `None` when every cell's is 1 (a set that was not
    /// subsampled), so loops can skip the multiply.
    pub(crate) fn multiplicity_if_any(&self) -> Option<&[f64]> {
        self.mult.as_deref()
    }

    /// θh of each cell (built on first call; see the type's doc).
    pub fn theta_h(&self) -> &[f64] {
        self.acos_column(&self.theta_h, Columns::H_Z, |g| g.h_z)
    }

    /// θd of each cell (built on first call; see the type's doc).
    pub fn theta_d(&self) -> &[f64] {
        self.acos_column(&self.theta_d, Columns::COS_D, |g| g.cos_d)
    }

    /// The angles of the geometry column `col` picks ([`acos_clamped`]), built into
    /// `cell` on first call, chunk by chunk, from that column alone.
    fn acos_column<'a>(
        &'a self,
        cell: &'a OnceLock<Vec<f64>>,
        set: Columns,
        col: for<'g> fn(&GeomSlice<'g>) -> &'g [f64],
    ) -> &'a [f64] {
        cell.get_or_init(|| {
            let mut out = vec![0.0; self.len()];
            self.for_chunks(set, &mut out, |g, o| {
                for (o, &z) in o.iter_mut().zip(col(&g)) {
                    *o = acos_clamped(z);
                }
            });
            out
        })
    }

    /// `f(geometry of the chunk, the chunk of out)` for each [`PASS_CHUNK_CELLS`]
    /// chunk of the cells, in parallel (`out` holds one entry per cell); `f` reads the
    /// columns `set` only ([`columns_of`](Self::columns_of)).
    fn for_chunks<T: Send>(
        &self,
        set: Columns,
        out: &mut [T],
        f: impl Fn(GeomSlice<'_>, &mut [T]) + Sync,
    ) {
        out.par_chunks_mut(PASS_CHUNK_CELLS)
            .enumerate()
            .for_each_init(ChunkGeometry::default, |scratch, (ci, o)| {
                let s = ci * PASS_CHUNK_CELLS;
                f(self.columns_of(s..s + o.len(), set, scratch), o)
            });
    }

    /// The cube-root targets ∛(f cos θi) of each channel, the measured side of the
    /// `cbrt` loss ([`crate::Loss::Cbrt`]): built on first call (a pass of 3 cube roots
    /// a cell, 24 bytes a cell kept) and then shared by every loss report on these
    /// cells, so the families of a batch, a report or `fit --model a,b,c` pay the roots
    /// once per table. The same expression as the report's, so the same bits.
    pub fn cbrt_targets(&self) -> &[Vec<f64>; 3] {
        self.cbrt_targets.get_or_init(|| {
            [0, 1, 2].map(|c| {
                let mut t = self.values[c].clone();
                self.for_chunks(Columns::WI_Z, &mut t, |g, t| {
                    crate::Loss::Cbrt.transform_all(g.wi_z, t)
                });
                t
            })
        })
    }

    /// The cube-root targets if [`cbrt_targets`](Self::cbrt_targets) has built them
    /// (a single fit does not: it would keep 24 bytes a cell for one report).
    pub fn cbrt_targets_if_built(&self) -> Option<&[Vec<f64>; 3]> {
        self.cbrt_targets.get()
    }

    /// θd of cell m.
    #[inline]
    pub(crate) fn theta_d_at(&self, m: usize) -> f64 {
        acos_clamped(self.pair_at(m)[9])
    }

    /// Weight of cell m under a weighting: multiplicity × (measure or 1).
    #[inline]
    pub(crate) fn weight_at(&self, w: crate::Weighting, m: usize) -> f64 {
        let a = self.mult.as_ref().map_or(1.0, |v| v[m]);
        match w {
            crate::Weighting::SolidAngle => a * self.measure[m],
            crate::Weighting::Uniform => a,
        }
    }

    /// The weights of the cells `start .. start + out.len()` ([`weight_at`](Self::weight_at),
    /// the same bits: a multiplicity of 1 multiplies exactly), one branch-free loop.
    pub(crate) fn fill_weights(&self, w: crate::Weighting, start: usize, out: &mut [f64]) {
        let r = start..start + out.len();
        let meas = &self.measure[r.clone()];
        match (&self.mult, w) {
            (Some(m), crate::Weighting::SolidAngle) => {
                for ((o, a), x) in out.iter_mut().zip(&m[r]).zip(meas) {
                    *o = a * x;
                }
            }
            (Some(m), crate::Weighting::Uniform) => out.copy_from_slice(&m[r]),
            (None, crate::Weighting::SolidAngle) => out.copy_from_slice(meas),
            (None, crate::Weighting::Uniform) => out.fill(1.0),
        }
    }

    /// Σ of the cells' weights, summed in cell order: formed on first use and kept (the
    /// weights never change), so the loss reports of the families of a batch, a
    /// report or `fit --model a,b,c` do not each repeat a serial pass over every cell.
    pub(crate) fn weight_sum(&self, w: crate::Weighting) -> f64 {
        let at = match w {
            crate::Weighting::SolidAngle => 0,
            crate::Weighting::Uniform => 1,
        };
        *self.weight_sums[at].get_or_init(|| (0..self.len()).map(|m| self.weight_at(w, m)).sum())
    }

    /// The weight factor g(θi, θo) of a loss at cell m ([`crate::Loss::cell_factor`]).
    #[inline]
    pub(crate) fn loss_factor_at(&self, loss: crate::Loss, m: usize) -> f64 {
        let g = self.geometry();
        loss.cell_factor(g.wi_z[m], g.wo_z[m])
    }

    /// Σ of the cells' weights under a loss (weight × the loss's factor), in cell
    /// order; the plain [`weight_sum`](Self::weight_sum) for brdfkit's own losses.
    pub(crate) fn loss_weight_sum(&self, w: crate::Weighting, loss: crate::Loss) -> f64 {
        if !loss.has_cell_factor() {
            return self.weight_sum(w);
        }
        (0..self.len())
            .map(|m| self.weight_at(w, m) * self.loss_factor_at(loss, m))
            .sum()
    }

    /// The cells' weights under a weighting: multiplicity × (measure or 1).
    pub fn weights(&self, w: crate::Weighting) -> Vec<f64> {
        (0..self.len()).map(|m| self.weight_at(w, m)).collect()
    }

    /// Bytes held by the per-cell arrays (including any built angle or multiplicity
    /// views and the subsamples kept by [`shared_subsample`](Self::shared_subsample)).
    pub fn heap_bytes(&self) -> usize {
        let f = std::mem::size_of::<f64>();
        let opt = |v: Option<&Vec<f64>>| v.map_or(0, |v| v.capacity() * f);
        let geometry = match &self.geometry {
            Geometry::Given(g) => g.heap_bytes(),
            Geometry::Table { cells, built } => {
                cells.heap_bytes() + built.get().map_or(0, GeometryBatch::heap_bytes)
            }
        };
        geometry
            + self.values.iter().map(|v| v.capacity() * f).sum::<usize>()
            + self.measure.capacity() * f
            + opt(self.mult.as_ref())
            + opt(self.ones.get())
            + opt(self.theta_h.get())
            + opt(self.theta_d.get())
            + self
                .cbrt_targets
                .get()
                .map_or(0, |t| 3 * t[0].capacity() * f)
            + self
                .subsets
                .0
                .lock()
                .map_or(0, |v| v.iter().map(|(_, d)| d.heap_bytes()).sum::<usize>())
    }

    /// The cells with `keep[m]` true.
    pub fn filter(&self, keep: impl Fn(usize) -> bool) -> FitData {
        let idx: Vec<usize> = (0..self.len()).filter(|&m| keep(m)).collect();
        self.select(&idx, None)
    }

    /// The cells `idx`, with multiplicities multiplied by `mult` when given.
    fn select(&self, idx: &[usize], mult: Option<&[f64]>) -> FitData {
        let pick = |v: &[f64]| idx.iter().map(|&m| v[m]).collect::<Vec<f64>>();
        // The 14 columns gathered in parallel: each gather reads a cache line a value
        // (the cells are scattered), so it waits on memory, and one core left the
        // other idle for 6 % of a default fit's CPU time.
        let [r, g, b] = &self.values;
        let (geometry, [r, g, b, measure]) = rayon::join(
            || self.select_geometry(idx),
            || {
                let sources = [&r[..], g, b, &self.measure];
                let picked: Vec<Vec<f64>> = sources.into_par_iter().map(pick).collect();
                <[Vec<f64>; 4]>::try_from(picked).expect("4 columns")
            },
        );
        let values = [r, g, b];
        let m = match (&self.mult, mult) {
            (None, None) => None,
            (Some(a), None) => Some(pick(a)),
            (a, Some(f)) => Some(
                idx.iter()
                    .zip(f)
                    .map(|(&m, b)| a.as_ref().map_or(1.0, |a| a[m]) * b)
                    .collect(),
            ),
        };
        FitData::assemble(Geometry::Given(geometry), values, measure, m)
    }

    /// The geometry of the cells `idx`: gathered from the whole-set columns when built,
    /// otherwise computed cell by cell ([`CellRuns::gather`], the same bits), in
    /// parallel chunks.
    fn select_geometry(&self, idx: &[usize]) -> GeometryBatch {
        let Some(cells) = self.geometry.lazy() else {
            let g = self.geometry();
            let pick = |v: &[f64]| idx.iter().map(|&m| v[m]).collect::<Vec<f64>>();
            let cols: Vec<Vec<f64>> = g.as_slice().columns().into_par_iter().map(pick).collect();
            let mut cols = cols.into_iter();
            return GeometryBatch::from_column_fn(|| cols.next().expect("10 columns"));
        };
        let mut g = GeometryBatch::zeroed(idx.len());
        let lens: Vec<usize> = idx.chunks(PASS_CHUNK_CELLS).map(<[usize]>::len).collect();
        split_runs(g.columns_mut(), &lens)
            .into_par_iter()
            .zip(idx.par_chunks(PASS_CHUNK_CELLS))
            .for_each(|(cols, idx)| cells.gather(idx, cols));
        g
    }

    /// The cells with θd ≤ `max_theta_d` (radians): the grazing cells, the least
    /// reliable measurements, are left out.
    pub fn with_theta_d_max(&self, max_theta_d: f64) -> FitData {
        let cd = &self.geometry().cos_d;
        self.filter(|m| acos_clamped(cd[m]) <= max_theta_d)
    }

    /// The cells whose incident and outgoing directions are both within `max_theta`
    /// (radians) of the normal: θi ≤ max and θo ≤ max, the angular domain of a fit as
    /// the papers state it (Ngan et al. 2005 drop θi or θo > 80°). The angles are those
    /// of the cell's own direction pair (for a Rusinkiewicz cell, the (wi, wo) of its
    /// (θh, θd, φd) centre), compared through their cosines.
    pub fn with_theta_max(&self, max_theta: f64) -> FitData {
        let c = max_theta.cos();
        let g = self.geometry();
        self.filter(|m| g.wi_z[m] >= c && g.wo_z[m] >= c)
    }

    /// The stratum of cell `m`: its bin on the [`STRATA`] × [`STRATA`] grid over
    /// (√(θh/(π/2)), θd/(π/2)), as `a · STRATA + b`.
    ///
    /// The bins are those of θh = acos h.z and θd = acos cos θd, found by comparing the
    /// cosines with the bins' edge cosines (computed once, by bisection on that
    /// formula): no `acos` a cell, and the formula's bin for every cosine.
    #[inline]
    pub fn stratum_at(&self, m: usize) -> usize {
        let p = self.pair_at(m);
        StrataEdges::get().stratum(p[8], p[9])
    }

    /// [`stratum_at`](Self::stratum_at) of every cell, as bytes. A table's cells are
    /// binned a run at a time where their row's cos θh and cos θd lie clear of every
    /// bin edge (`table_strata`: the cells' own cosines are not computed), other cells
    /// a chunk per task from their two cosines (for a table's geometry only those two
    /// columns are computed, [`columns_of`](Self::columns_of): the same bits as the
    /// whole columns). A bin is the count of edges a cosine is at or below, counted
    /// edge by edge over the chunk's cells, so the comparisons run across cells in
    /// vector lanes (cell by cell, the 15 comparisons and their sum were 7 % of a
    /// default fit's CPU).
    pub fn strata(&self) -> Vec<u8> {
        const _: () = assert!(STRATA * STRATA <= 256);
        if let Some(cells) = self.geometry.lazy() {
            return table_strata(cells);
        }
        let mut ids = vec![0u8; self.len()];
        self.for_chunks(Columns::H_Z | Columns::COS_D, &mut ids, chunk_strata);
        ids
    }

    /// [`stratified_subsample`](Self::stratified_subsample), drawn on the first call
    /// for a (fraction, seed) and shared by the later ones (same cells, same bits).
    pub fn shared_subsample(&self, fraction: f64, seed: u64) -> Arc<FitData> {
        let key = (fraction.to_bits(), seed);
        let hit = |v: &Vec<Subset>| v.iter().find(|(k, _)| *k == key).map(|(_, d)| d.clone());
        // A poisoned lock only means another thread panicked mid-draw: draw again.
        if let Some(d) = self.subsets.0.lock().ok().and_then(|v| hit(&v)) {
            return d;
        }
        let d = Arc::new(self.stratified_subsample(fraction, seed));
        if let Ok(mut v) = self.subsets.0.lock() {
            match hit(&v) {
                Some(other) => return other,
                None => v.push((key, d.clone())),
            }
        }
        d
    }

    /// A stratified, seeded subsample of about `fraction` of the cells.
    ///
    /// Cells are binned on a [`STRATA`] × [`STRATA`] grid over (√(θh/(π/2)), θd/(π/2));
    /// from a bin of n cells, max(1, round(fraction · n)) are drawn without replacement
    /// (a ChaCha8 shuffle seeded by `seed` and the bin), and each drawn cell's
    /// multiplicity becomes n / drawn, so the weighted sums of a subsample estimate
    /// those of the full set bin by bin. The same seed gives the same cells.
    pub fn stratified_subsample(&self, fraction: f64, seed: u64) -> FitData {
        if fraction >= 1.0 {
            return self.clone();
        }
        // The bins' members as one counting-sorted array of u32 (4 bytes a cell, plus
        // a one-byte bin id: STRATA² = 256 bins), not a Vec<usize> per bin (≥ 8 bytes
        // a cell plus growth slack, 17 MB for a MERL table). Members stay in cell order
        // within a bin, and a shuffle's swaps depend only on the length, so the draw is
        // the same as with any other element type. u32: a set of 2³² cells would need
        // over 450 GB of columns.
        let ids = self.strata();
        let mut start = vec![0usize; STRATA * STRATA + 1];
        for &b in &ids {
            start[b as usize + 1] += 1;
        }
        for b in 0..STRATA * STRATA {
            start[b + 1] += start[b];
        }
        let mut members = vec![0u32; self.len()];
        let mut next = start.clone();
        for (m, &b) in ids.iter().enumerate() {
            members[next[b as usize]] = m as u32;
            next[b as usize] += 1;
        }
        drop(ids);
        // The bins drawn in parallel: each draw depends only on its bin's cells, the
        // seed and the bin, and the drawn cells are put in file order below, so the
        // result is the serial loop's, bit for bit (1.1 M swaps and draws on one core
        // were a third of the subsample stage).
        let mut bins = Vec::with_capacity(STRATA * STRATA);
        let mut rest = &mut members[..];
        for b in 0..STRATA * STRATA {
            let (bin, tail) = rest.split_at_mut(start[b + 1] - start[b]);
            bins.push(bin);
            rest = tail;
        }
        let mut drawn: Vec<(u32, f64)> = bins
            .into_par_iter()
            .enumerate()
            .filter(|(_, cells)| !cells.is_empty())
            .flat_map_iter(|(b, cells)| {
                let take = draw_stratum(cells, fraction, seed, b);
                let w = cells.len() as f64 / take as f64;
                cells[..take].iter().map(move |&m| (m, w))
            })
            .collect();
        // Freed before the columns of the subsample are allocated (peak memory).
        drop(members);
        // File order keeps the geometry columns' memory access sequential.
        drawn.sort_unstable_by_key(|&(m, _)| m);
        let idx: Vec<usize> = drawn.iter().map(|&(m, _)| m as usize).collect();
        let mult: Vec<f64> = drawn.iter().map(|&(_, w)| w).collect();
        self.select(&idx, Some(&mult))
    }
}

/// The strata of the cells of a chunk (`ids`, one per cell) from its cos θh and cos θd
/// columns ([`FitData::strata`]).
fn chunk_strata(g: GeomSlice<'_>, ids: &mut [u8]) {
    let e = StrataEdges::get();
    let mut b = [0u8; PASS_CHUNK_CELLS];
    let b = &mut b[..ids.len()];
    count_at_or_below(&e.h, g.h_z, ids);
    count_at_or_below(&e.d, g.cos_d, b);
    for (id, &b) in ids.iter_mut().zip(b.iter()) {
        *id = *id * STRATA as u8 + b;
    }
}

/// Below this cos θd a row's cells are binned one by one in [`table_strata`]: the half
/// vector is (wi + wo) / |wi + wo| with |wi + wo| = 2 cos θd, so its rounding error
/// grows as 1 / cos θd (MERL's last θd bin has cos θd ≈ 0.009).
const ROW_STRATA_MIN_COS_D: f64 = 1e-3;

/// How far a cell's computed cos θh or cos θd may lie from its row's
/// ([`CellRuns::row_cosines`]) for [`table_strata`] to bin the row as one: their
/// difference is a few rounding errors of a dozen operations on unit vectors, amplified
/// at most 1 / [`ROW_STRATA_MIN_COS_D`]-fold, below 1e-12; this leaves a thousandfold
/// margin.
const ROW_STRATA_SLACK: f64 = 1e-9;

/// The strata of a table's valid cells ([`FitData::strata`]), a run of a row at a time:
/// a bin is non-increasing in its cosine, so when the row's cos θh ± the slack
/// ([`ROW_STRATA_SLACK`]) fall in one θh bin, and likewise cos θd, every cell of the row
/// is in that stratum whatever the rounding of its own cosines; such a run is filled
/// at once. A row near a bin edge (or at a grazing θd) has its cells' cosines computed
/// and binned one by one ([`chunk_strata`]), so every cell gets the formula's bin
/// (tests/data.rs compares it with the cell-by-cell strata on a whole MERL grid). A
/// MERL table's 1.1 M valid cells come in about 16,000 runs: the runs filled whole
/// need none of their cells' two cosines (two square roots and a division a cell).
fn table_strata(cells: &CellRuns) -> Vec<u8> {
    let e = StrataEdges::get();
    let set = Columns::H_Z | Columns::COS_D;
    let one = |edges: &[f64; STRATA - 1], z: f64| {
        let lo = StrataEdges::bin(edges, z + ROW_STRATA_SLACK);
        (lo == StrataEdges::bin(edges, z - ROW_STRATA_SLACK)).then_some(lo)
    };
    let mut ids = vec![0u8; cells.len()];
    let mut scratch = ChunkGeometry::default();
    for s in cells.spans() {
        let [ch, cd] = cells.row_cosines(s.i, s.j);
        let out = &mut ids[s.cells.clone()];
        match (one(&e.h, ch), one(&e.d, cd)) {
            (Some(a), Some(b)) if cd >= ROW_STRATA_MIN_COS_D => {
                out.fill((a * STRATA + b) as u8);
            }
            _ => {
                for (part, out) in s
                    .cells
                    .clone()
                    .step_by(PASS_CHUNK_CELLS)
                    .zip(out.chunks_mut(PASS_CHUNK_CELLS))
                {
                    let r = part..part + out.len();
                    cells.fill_columns(r.clone(), set, scratch.prepare(r.len(), set));
                    chunk_strata(scratch.g.as_slice(), out);
                }
            }
        }
    }
    ids
}

/// `out[k]` = how many of `edges` `z[k]` is at or below ([`StrataEdges::bin`], NaN: 0),
/// edge by edge over all k, in vector lanes ([`brdfkit_core::lanes`]: compiled at the
/// baseline's two lanes, the comparisons and their byte sums were a third of the
/// subsample's draw).
fn count_at_or_below(edges: &[f64; STRATA - 1], z: &[f64], out: &mut [u8]) {
    struct Count<'a>(&'a [f64; STRATA - 1], &'a [f64], &'a mut [u8]);
    impl Run for Count<'_> {
        #[inline(always)]
        fn run(&mut self) {
            let Count(edges, z, out) = self;
            out.fill(0);
            for &t in edges.iter() {
                for (o, &z) in out.iter_mut().zip(z.iter()) {
                    *o += u8::from(z <= t);
                }
            }
        }
    }
    dispatch(&mut Count(edges, z, out));
}

/// The draw within bin `b` of [`FitData::stratified_subsample`]: the bin's n `cells`
/// shuffled by a ChaCha8 generator seeded with `seed` and the bin, of which the first
/// max(1, round(fraction · n)) are the drawn ones; returns that count. `cells` must not
/// be empty. tests/data.rs restates it on its own, as an independent reference.
fn draw_stratum<T>(cells: &mut [T], fraction: f64, seed: u64, b: usize) -> usize {
    let n = cells.len();
    let take = ((fraction * n as f64).round() as usize).clamp(1, n);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ (b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    cells.shuffle(&mut rng);
    take
}

/// `values` hold one value per cell of `n` in every channel (the first channel that
/// does not is named).
pub(crate) fn check_channel_lengths(values: &[Vec<f64>; 3], n: usize) -> Result<(), FitError> {
    match (0..3).find(|&c| values[c].len() != n) {
        Some(c) => Err(FitError::Data(format!(
            "channel {c} has {} values for {n} cells",
            values[c].len()
        ))),
        None => Ok(()),
    }
}

/// The first entry of `v` (cell, value) that is not finite or fails `ok`.
fn first_bad(v: &[f64], ok: impl Fn(f64) -> bool) -> Option<(usize, f64)> {
    v.iter()
        .copied()
        .enumerate()
        .find(|&(_, x)| !(x.is_finite() && ok(x)))
}

/// What a fit's input was, kept in its record (`input`): absent for a MERL table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SampleInput {
    /// `samples` (a user's rows) or `bsdf-points` (a `.bsdf`'s measured points).
    pub kind: String,
    /// The file, when the caller names one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// Rows given.
    pub rows: usize,
    /// Samples kept (the fit's cells before any cutoff).
    pub samples: usize,
    /// Rows dropped for a missing (NaN) value.
    pub dropped_missing: usize,
    /// Rows dropped by the producer before they got here (a `.bsdf`'s points whose wo
    /// is below the horizon, or on a slice at θi = 90°).
    #[serde(default)]
    pub dropped_other: usize,
    /// Negative channel values stored as 0.
    pub negative_zeroed: usize,
    /// `given` (the rows' own weights) or `uniform` (1 each).
    pub weights: String,
}
