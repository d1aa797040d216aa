//! Fit quality: how well a fitted model reproduces a measured table, and where it fails.
//!
//! Over the table's valid cells (the cells a fit sees, [`FitData::from_table`]):
//! - **losses**: every loss of the fitter (`l2`, `cosine`, `cbrt`, `log`), the weighted
//!   RMS of the transformed difference per channel and overall, computed by
//!   [`brdfkit_fit::evaluate_losses`] (the fitter's own code; definitions in
//!   [`brdfkit_fit::loss`] and `docs/validation.md`);
//! - **bands**: the same losses restricted to bands of θh (the specular peak is θh ≈ 0)
//!   and of θd (retro-reflection is θd ≈ 0, grazing θd → 90°);
//! - **relative-error percentiles**: |f − f̂| / f̂ per cell and channel (cells measured
//!   as exactly 0 are counted and left out), the 50th, 90th and 99th percentiles per
//!   channel and pooled, by the nearest-rank definition (the ⌈p·n/100⌉-th smallest);
//! - **albedo**: the directional albedo of the fit and of the table at several θo,
//!   by the same quadrature as the physical checks;
//! - **held-out validation** (optional, [`held_out`]): the model family is fitted again
//!   by [`brdfkit_fit::fit`] on a stratified subset of the cells and scored on the
//!   others; the ratio of held-out to training loss measures over-fitting.

use crate::html::analysis::{ResidualMap, RowSums, add_residual_cell, residual_map_of_rows};
use crate::physical::{PoleChoice, auto_pole, converged_with, model_albedo_converged};
use crate::report::{deg, num, rgb};
use crate::table::{table_albedo, table_brdf};
use brdfkit_core::direction::spherical;
use brdfkit_core::{GeomSlice, GeometryBatch, Model, ModelError, Rgb};
use brdfkit_fit::data::STRATA;
use brdfkit_fit::loss::{Lanes8, cbrt_all, ln_1p_all};
use brdfkit_fit::{
    FitConfig, FitData, FitError, Fitted, Loss, LossReport, Weighting, evaluate_losses, fit,
};
use brdfkit_merl::{Lookup, MerlTable};
use brdfkit_models::testing::SplitMix64;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::f64::consts::FRAC_PI_2;
use std::ops::Range;
use std::sync::Mutex;
use thiserror::Error;

/// Errors of the fit-quality computation.
#[derive(Debug, Error)]
pub enum QualityError {
    /// The fitter rejected the data or the configuration, or failed.
    #[error(transparent)]
    Fit(#[from] FitError),
    /// A model description that does not build.
    #[error("model: {0}")]
    Model(#[from] ModelError),
    /// An option out of range.
    #[error("fit-quality option `{option}`: {reason}")]
    Option {
        /// The option's name.
        option: &'static str,
        /// Why its value is refused.
        reason: String,
    },
}

/// A fitted model as JSON: a model description, or `{"per_channel": [r, g, b]}` as
/// [`Fitted::to_json`] writes it.
pub fn fitted_from_json(v: &Value) -> Result<Fitted, ModelError> {
    Fitted::from_json(v)
}

/// Held-out validation settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOutOptions {
    /// The model family and start, in the JSON contract (what was fitted).
    pub family: Value,
    /// The fit's configuration (loss, weighting, solver, starts …).
    pub config: FitConfig,
    /// Fraction of the cells, per stratum, the model is fitted on (the rest is scored).
    pub train_fraction: f64,
    /// Seed of the split.
    pub seed: u64,
}

/// What [`fit_quality_with`] computes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QualityOptions {
    /// Cell weights of every loss.
    pub weighting: Weighting,
    /// Band edges in θh (radians, increasing, from 0 to π/2).
    pub theta_h_bands: Vec<f64>,
    /// Band edges in θd (radians).
    pub theta_d_bands: Vec<f64>,
    /// Outgoing angles (radians) of the albedo comparison.
    pub albedo_thetas: Vec<f64>,
    /// Held-out validation, when wanted (it runs a fit).
    pub held_out: Option<HeldOutOptions>,
}

impl Default for QualityOptions {
    /// Solid-angle weights; θh bands 0, 0.5, 1, 2, 5, 10, 20, 40, 90° (the first three
    /// cover the specular peak of shiny materials); θd bands 0, 5, 10, 20, 40, 60, 70,
    /// 80, 85, 90° (retro-reflection first, grazing last); albedo at 0, 15, …, 75, 85°;
    /// no held-out fit.
    fn default() -> Self {
        QualityOptions {
            weighting: Weighting::SolidAngle,
            theta_h_bands: radians(&[0.0, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 40.0, 90.0]),
            theta_d_bands: radians(&[0.0, 5.0, 10.0, 20.0, 40.0, 60.0, 70.0, 80.0, 85.0, 90.0]),
            albedo_thetas: radians(&[0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0]),
            held_out: None,
        }
    }
}

/// The losses over the cells of one angular band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Band {
    /// Lower edge (radians, inclusive).
    pub lo: f64,
    /// Upper edge (radians; exclusive, inclusive for the last band).
    pub hi: f64,
    /// Valid cells in the band.
    pub cells: usize,
    /// `None` when the band holds no cell.
    pub losses: Option<LossReport>,
}

/// The 50th, 90th and 99th percentiles of a sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Percentiles {
    /// The median.
    pub p50: f64,
    /// The 90th percentile.
    pub p90: f64,
    /// The 99th percentile.
    pub p99: f64,
}

/// Relative-error percentiles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RelativeErrors {
    /// Per channel (R, G, B).
    pub channels: [Option<Percentiles>; 3],
    /// All channels pooled.
    pub overall: Option<Percentiles>,
    /// Cell channels counted.
    pub samples: usize,
    /// Cell channels measured as exactly 0, left out (their relative error is
    /// undefined).
    pub zero_measured: usize,
}

/// The albedo of the fit and of the table at one θo.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AlbedoComparison {
    /// θo (radians), φo = 0.
    pub theta_o: f64,
    /// The table's albedo (missing lookups filled with the mean, as in
    /// [`crate::table`]); `None` when no lookup found a sample.
    pub table: Option<Rgb>,
    /// Fraction of the cosine-weighted hemisphere whose lookups were missing.
    pub table_missing_weight: f64,
    /// The fitted model's albedo (channel c from the channel-c model).
    pub fit: Rgb,
    /// fit − table.
    pub difference: Option<Rgb>,
}

/// Fit on part of the cells, scored on the rest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOutReport {
    /// Fraction of the cells fitted on, in (0, 1).
    pub train_fraction: f64,
    /// Seed of the stratified split.
    pub seed: u64,
    /// Cells fitted on.
    pub train_cells: usize,
    /// Cells held out and scored.
    pub test_cells: usize,
    /// The loss the fit minimised.
    pub loss: Loss,
    /// The model fitted on the training cells.
    pub fitted: Value,
    /// Losses on the training cells.
    pub train: LossReport,
    /// Losses on the held-out cells.
    pub test: LossReport,
    /// Held-out over training value of the fitted loss (overall): ≈ 1 when the model
    /// generalises, ≫ 1 when it over-fits.
    pub ratio: f64,
}

/// Everything [`fit_quality_with`] measures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QualityReport {
    /// The fitted model(s) in the JSON contract.
    pub model: Value,
    /// The weighting the losses are measured with.
    pub weighting: Weighting,
    /// Valid cells of the table.
    pub cells: usize,
    /// Every loss over all valid cells.
    pub losses: LossReport,
    /// Losses by θh band.
    pub theta_h_bands: Vec<Band>,
    /// Losses by θd band.
    pub theta_d_bands: Vec<Band>,
    /// Relative-error percentiles.
    pub relative_error: RelativeErrors,
    /// The albedo of fit and table along θo.
    pub albedo: Vec<AlbedoComparison>,
    /// Held-out validation, when asked for.
    pub held_out: Option<HeldOutReport>,
}

/// Fit quality of `fitted` against `table` with the default options (no held-out
/// fit).
pub fn fit_quality(table: &MerlTable, fitted: &Fitted) -> Result<QualityReport, QualityError> {
    fit_quality_with(table, fitted, &QualityOptions::default())
}

fn models_of(fitted: &Fitted) -> [&dyn Model; 3] {
    [
        fitted.channel_model(0),
        fitted.channel_model(1),
        fitted.channel_model(2),
    ]
}

/// Degrees to radians, for the defaults.
fn radians(d: &[f64]) -> Vec<f64> {
    d.iter().map(|x| x.to_radians()).collect()
}

fn check_edges(option: &'static str, e: &[f64]) -> Result<(), QualityError> {
    // π/2 computed as 90°.to_radians() may differ from FRAC_PI_2 by an ulp.
    let ok = e.len() >= 2
        && e.iter()
            .all(|x| x.is_finite() && (0.0..=FRAC_PI_2 + 1e-12).contains(x))
        && e.windows(2).all(|w| w[0] < w[1]);
    if ok {
        Ok(())
    } else {
        Err(QualityError::Option {
            option,
            reason: format!("band edges must increase within [0, π/2] radians, got {e:?}"),
        })
    }
}

/// Nearest-rank percentiles of `v`; `None` when empty.
///
/// The ⌈p·n/100⌉-th smallest value in the `total_cmp` order ([`kth_smallest`]): one
/// value whatever the algorithm, so the result is the sort's to the bit.
fn percentiles(v: &[f64]) -> Option<Percentiles> {
    if v.is_empty() {
        return None;
    }
    let n = v.len();
    let rank = |p: f64| ((p / 100.0 * n as f64).ceil() as usize).clamp(1, n) - 1;
    let [p50, p90, p99] = kth_smallest(v, [rank(50.0), rank(90.0), rank(99.0)]);
    Some(Percentiles { p50, p90, p99 })
}

/// `x` as an unsigned key in `f64::total_cmp`'s order (its own bit mapping: a negative
/// value's bits all flipped, the sign bit set on the others), so keys compare as the
/// values do.
#[inline]
fn order_key(x: f64) -> u64 {
    let b = x.to_bits();
    if b >> 63 == 1 { !b } else { b | 1 << 63 }
}

/// Bits of [`order_key`] that pick a value's bucket in [`kth_smallest`]: the sign, the
/// exponent and 4 mantissa bits (16 buckets an octave).
const BUCKET_SHIFT: u32 = 48;

/// The values of ranks `ranks` (0-based, each < `v.len()`) of `v` in the `total_cmp`
/// order, by one radix step then selection: a histogram of the keys' top 16 bits
/// ([`BUCKET_SHIFT`]) finds each rank's bucket and its rank inside it, a second pass
/// gathers those buckets' values, and each is selected among its bucket's values alone.
/// Two passes over `v` and a selection among a few percent of it, where three
/// quickselects over the pooled 3.3 M relative errors of a model (the 99th, then the
/// 90th and 50th among the values left of it) were 4 % of the five-model report's CPU.
fn kth_smallest<const K: usize>(v: &[f64], ranks: [usize; K]) -> [f64; K] {
    let mut hist = vec![0usize; 1 << (64 - BUCKET_SHIFT)];
    for x in v {
        hist[(order_key(*x) >> BUCKET_SHIFT) as usize] += 1;
    }
    // Each rank's bucket and its rank among the bucket's values.
    let mut at = ranks.map(|r| (0u64, r));
    let mut below = 0;
    let mut next = 0;
    let mut order: Vec<usize> = (0..K).collect();
    order.sort_by_key(|&i| ranks[i]);
    for (b, &count) in hist.iter().enumerate() {
        while next < K && ranks[order[next]] < below + count {
            at[order[next]] = (b as u64, ranks[order[next]] - below);
            next += 1;
        }
        below += count;
    }
    let mut buckets: Vec<u64> = at.iter().map(|a| a.0).collect();
    buckets.sort_unstable();
    buckets.dedup();
    let mut members: Vec<Vec<f64>> = buckets.iter().map(|_| Vec::new()).collect();
    for x in v {
        let b = order_key(*x) >> BUCKET_SHIFT;
        if let Some(i) = buckets.iter().position(|&c| c == b) {
            members[i].push(*x);
        }
    }
    at.map(|(b, r)| {
        let i = buckets
            .iter()
            .position(|&c| c == b)
            .expect("a rank's bucket");
        *members[i].select_nth_unstable_by(r, f64::total_cmp).1
    })
}

/// Cells per block of the per-cell pass below (about: a block of the table's rows
/// closes before the row that would take it past this): a few buffers of this size
/// per thread instead of full-length planes. 2048, not 4096: the pass keeps its
/// buffers ([`BlockOut`], [`BlockScratch`]) from block to block, and at this size they
/// hold about 1.7 MB, so the report's peak memory is not raised by them.
const BLOCK: usize = 2048;

/// Blocks computed in parallel before their sums are taken in cell order (their
/// outputs, [`BlockOut`], are kept for the whole pass: 4 × 0.26 MB).
const WINDOW: usize = 4;

/// The band of an angle: the `b` with lo ≤ θ < hi, the last band closed and taking the
/// round-off above 90° too (θ computed by acos of a dot product); `None` below the
/// first edge. The reference of [`BandCuts`].
#[cfg(test)]
fn band_of(edges: &[f64], theta: f64) -> Option<usize> {
    let last = edges.len() - 2;
    (0..=last).find(|&b| theta >= edges[b] && (theta < edges[b + 1] || b == last))
}

/// θ = acos z of a cell's cosine, as `FitData::theta_h` and `theta_d` compute it.
fn theta_of(z: f64) -> f64 {
    z.clamp(-1.0, 1.0).acos()
}

/// Band edges as cosines: the band of a cell from its cosine z by comparisons, with no
/// acos a cell (two a cell and model were a fifth of the quality pass).
///
/// `cuts[b]` is the largest z in [−1, 1] with θ(z) = acos(clamp(z)) ≥ edges[b], found
/// by bisection on the f64 order of [−1, 1] with the acos itself, so θ(z) ≥ edges[b]
/// exactly when clamp(z) ≤ cuts[b] (acos is monotone), and the band of z is the
/// reference's (`band_of` of θ(z)): how many edges θ reaches, less one, the last band
/// taking everything above its edge; none below the first edge or for NaN. Tested on
/// every cell of a 90 × 90 × 180 grid and one ulp either side of every cut.
struct BandCuts(Vec<f64>);

impl BandCuts {
    fn new(edges: &[f64]) -> Self {
        BandCuts(edges.iter().map(|&e| Self::cut(e)).collect())
    }

    /// The θh and the θd bands' cuts.
    fn of(o: &QualityOptions) -> [BandCuts; 2] {
        [Self::new(&o.theta_h_bands), Self::new(&o.theta_d_bands)]
    }

    /// The largest z in [−1, 1] with θ(z) ≥ e; −∞ when none (e above π).
    fn cut(e: f64) -> f64 {
        if theta_of(1.0) >= e {
            return 1.0;
        }
        if theta_of(-1.0) < e {
            return f64::NEG_INFINITY;
        }
        brdfkit_core::direction::last_cosine_where(|z| theta_of(z) >= e)
    }

    /// The band of a cell with cosine `z`; `None` as [`u32::MAX`].
    #[inline]
    fn band(&self, z: f64) -> u32 {
        let zc = z.clamp(-1.0, 1.0);
        let reached = self.0.iter().map(|&c| u32::from(zc <= c)).sum::<u32>();
        let last = self.0.len() as u32 - 2;
        if reached == 0 {
            u32::MAX
        } else {
            (reached - 1).min(last)
        }
    }
}

/// The weighted sums of [`brdfkit_fit::evaluate_losses`] over one subset of the cells,
/// taken cell by cell in cell order: one partial sum per run of
/// [`brdfkit_fit::data::PASS_CHUNK_CELLS`] member cells (the own losses in the fitter's
/// eight interleaved lanes, [`Lanes8`]), the partial sums added in chunk order, exactly as
/// `evaluate_losses` sums the subset gathered into a set of its own.
struct LossSums {
    parts: [[f64; 3]; 4],
    /// The current chunk's own-loss sums, in the fitter's interleaved lanes.
    cur: [[Lanes8; 3]; 4],
    /// The published metrics ([`Loss::PUBLISHED`]): Σ w g r² and Σ w g, chunked
    /// like `parts`.
    pub_parts: ([[f64; 3]; 4], [f64; 4]),
    pub_cur: ([[f64; 3]; 4], [f64; 4]),
    in_chunk: usize,
    cells: usize,
    wsum: f64,
}

impl LossSums {
    fn new() -> Self {
        LossSums {
            parts: [[0.0; 3]; 4],
            cur: [[Lanes8::default(); 3]; 4],
            pub_parts: ([[0.0; 3]; 4], [0.0; 4]),
            pub_cur: ([[0.0; 3]; 4], [0.0; 4]),
            in_chunk: 0,
            cells: 0,
            wsum: 0.0,
        }
    }

    /// Adds a cell of weight `w` with differences `d[loss][channel]` and the
    /// published metrics' factors `g` ([`Loss::cell_factor`]).
    #[inline]
    fn add(&mut self, w: f64, d: &[f64], g: [f64; 4]) {
        for l in 0..4 {
            for c in 0..3 {
                let x = d[l * 3 + c];
                self.cur[l][c].add(self.in_chunk, w * x * x);
            }
        }
        for (l, loss) in Loss::PUBLISHED.into_iter().enumerate() {
            let gw = w * g[l];
            self.pub_cur.1[l] += gw;
            // The published metrics use the residual of their base transform.
            let base = if loss.base() == Loss::Cosine { 1 } else { 3 };
            for c in 0..3 {
                let x = d[base * 3 + c];
                self.pub_cur.0[l][c] += gw * x * x;
            }
        }
        self.wsum += w;
        self.cells += 1;
        self.in_chunk += 1;
        if self.in_chunk == brdfkit_fit::data::PASS_CHUNK_CELLS {
            self.close_chunk();
        }
    }

    fn close_chunk(&mut self) {
        for l in 0..4 {
            for c in 0..3 {
                self.parts[l][c] += self.cur[l][c].total();
                self.pub_parts.0[l][c] += self.pub_cur.0[l][c];
            }
            self.pub_parts.1[l] += self.pub_cur.1[l];
        }
        self.cur = [[Lanes8::default(); 3]; 4];
        self.pub_cur = ([[0.0; 3]; 4], [0.0; 4]);
        self.in_chunk = 0;
    }

    /// The losses (`LossReport::from_sums`); `None` for an empty subset.
    fn finish(mut self) -> Option<LossReport> {
        if self.cells == 0 {
            return None;
        }
        if self.in_chunk > 0 {
            self.close_chunk();
        }
        Some(LossReport::from_sums(
            self.parts,
            self.wsum,
            self.pub_parts,
            self.cells,
        ))
    }
}

/// Numbers a cell of [`BlockOut::terms`]: 4 losses × 3 channels, then 4 factors.
const TERMS: usize = 16;

/// The table's (θh, θd) rows among its cells, for the residual maps the quality pass
/// computes on the way ([`fit_quality_and_maps`]): row r (θh slowest) holds the cells
/// `starts[r]..starts[r + 1]` (none when every cell of the row is missing).
struct CellRows {
    starts: Vec<usize>,
    bins: [usize; 2],
}

impl CellRows {
    /// The rows of `table`'s valid cells in file order: the cells of
    /// [`FitData::from_table`].
    fn of(table: &MerlTable) -> Self {
        let d = table.dims();
        let mut starts = Vec::with_capacity(d.theta_h() * d.theta_d() + 1);
        starts.push(0);
        let mut n = 0;
        for row in table.valid_mask().chunks(d.phi_d()) {
            n += row.iter().filter(|v| **v).count();
            starts.push(n);
        }
        CellRows {
            starts,
            bins: [d.theta_h(), d.theta_d()],
        }
    }

    fn len(&self) -> usize {
        self.starts.len() - 1
    }
}

/// A block of [`cell_pass`]: its cells, and the rows they make up when residual maps
/// are computed (empty otherwise).
struct Block {
    cells: Range<usize>,
    rows: Range<usize>,
}

/// The blocks of `n` cells: runs of [`BLOCK`] cells, or, with `rows`, runs of whole
/// rows of at most [`BLOCK`] cells (a longer row alone), so that each row's residual
/// sums are taken inside one block, cell by cell in order. Blocks only split the
/// evaluation: every sum of the pass is taken in cell order whatever they are.
fn blocks(n: usize, rows: Option<&CellRows>) -> Vec<Block> {
    let Some(r) = rows else {
        return (0..n.div_ceil(BLOCK))
            .map(|k| Block {
                cells: k * BLOCK..((k + 1) * BLOCK).min(n),
                rows: 0..0,
            })
            .collect();
    };
    let mut out = Vec::new();
    let mut first = 0;
    for row in 0..r.len() {
        if row > first && r.starts[row + 1] - r.starts[first] > BLOCK {
            out.push(first..row);
            first = row;
        }
    }
    out.push(first..r.len());
    out.into_iter()
        .map(|rows| Block {
            cells: r.starts[rows.start]..r.starts[rows.end],
            rows,
        })
        .filter(|b| !b.cells.is_empty())
        .collect()
}

/// What one block of [`cell_pass`] hands to the sums, in buffers kept from window to
/// window and model to model (no fresh pages to fault in and zero a block): its first
/// cell, its cells' terms (per cell, [`TERMS`] numbers: the loss differences
/// `d[loss][channel]`, then the published metrics' weight factors
/// [`Loss::cell_factor`], so the sums need no geometry), their (θh, θd) bands
/// ([`BandCuts::band`]) and, for residual maps, its rows' sums from `first_row` on.
#[derive(Default)]
struct BlockOut {
    start: usize,
    terms: Vec<f64>,
    bands: Vec<[u32; 2]>,
    first_row: usize,
    rows: Vec<RowSums>,
}

/// The working buffers of one [`block_terms`] at a time, kept between blocks in the
/// layout's pool (one a thread at work; freed with the layout, so that nothing of the
/// pass outlives it).
#[derive(Default)]
struct BlockScratch {
    geometry: GeometryBatch,
    values: Vec<Rgb>,
    tmp: Vec<Rgb>,
    planes: [Vec<f64>; 4],
}

/// What the passes of every model over one set of cells share: the blocks, where each
/// block's relative errors go (positive measurements per block and channel), the
/// cells measured as 0, and the buffers (the relative errors' array and the window's
/// block outputs), reused from model to model.
struct PassLayout {
    blocks: Vec<Block>,
    counts: Vec<[usize; 3]>,
    totals: [usize; 3],
    zero: usize,
    rel: Vec<f64>,
    outs: Vec<BlockOut>,
    scratch: Mutex<Vec<BlockScratch>>,
}

impl PassLayout {
    fn new(data: &FitData, rows: Option<&CellRows>) -> Self {
        let vals = data.values();
        let blocks = blocks(data.len(), rows);
        let counts: Vec<[usize; 3]> = blocks
            .par_iter()
            .map(|b| {
                [0, 1, 2].map(|c| {
                    vals[c][b.cells.clone()]
                        .iter()
                        .filter(|m| **m > 0.0)
                        .count()
                })
            })
            .collect();
        let totals = [0, 1, 2].map(|c| counts.iter().map(|k| k[c]).sum::<usize>());
        let zero = (0..3)
            .map(|c| vals[c].iter().filter(|m| **m == 0.0).count())
            .sum();
        PassLayout {
            blocks,
            counts,
            totals,
            zero,
            rel: vec![0.0; totals.iter().sum()],
            outs: (0..WINDOW).map(|_| BlockOut::default()).collect(),
            scratch: Mutex::new(Vec::new()),
        }
    }

    /// The relative-error array cut into each block's places, channel after channel.
    #[allow(clippy::type_complexity)]
    fn pieces(
        &mut self,
    ) -> (
        Vec<[&mut [f64]; 3]>,
        &[Block],
        &mut [BlockOut],
        &Mutex<Vec<BlockScratch>>,
    ) {
        let totals = self.totals;
        let mut pieces: Vec<[&mut [f64]; 3]> = Vec::with_capacity(self.blocks.len());
        let (r, rest) = self.rel.split_at_mut(totals[0]);
        let (gr, b) = rest.split_at_mut(totals[1]);
        let mut planes = [r, gr, b];
        for k in &self.counts {
            let [r, gr, b] = planes;
            let (r0, r1) = r.split_at_mut(k[0]);
            let (g0, g1) = gr.split_at_mut(k[1]);
            let (b0, b1) = b.split_at_mut(k[2]);
            pieces.push([r0, g0, b0]);
            planes = [r1, g1, b1];
        }
        (pieces, &self.blocks, &mut self.outs, &self.scratch)
    }

    /// The relative errors of the last pass: all, then each channel's.
    fn rel_planes(&self) -> (&[f64], [&[f64]; 3]) {
        let t = self.totals;
        let rel = &self.rel[..];
        (
            rel,
            [&rel[..t[0]], &rel[t[0]..t[0] + t[1]], &rel[t[0] + t[1]..]],
        )
    }
}

/// Adds the cells of a window's blocks, in cell order, to the sums of their band on
/// `axis` (0: θh, 1: θd) and, when given, to `full`.
fn add_window(
    outs: &[BlockOut],
    axis: usize,
    sums: &mut [LossSums],
    mut full: Option<&mut LossSums>,
    weight: &(dyn Fn(usize) -> f64 + Sync),
) {
    for o in outs {
        for (k, (dk, b)) in o.terms.chunks_exact(TERMS).zip(&o.bands).enumerate() {
            let m = o.start + k;
            let (dk, gk) = dk.split_at(12);
            let gk: [f64; 4] = gk.try_into().expect("four factors");
            if let Some(sum) = sums.get_mut(b[axis] as usize) {
                sum.add(weight(m), dk, gk);
            }
            if let Some(f) = full.as_deref_mut() {
                f.add(weight(m), dk, gk);
            }
        }
    }
}

/// What one pass over the cells measures of one model.
struct CellPass {
    /// Over all cells (`None` when not asked for).
    losses: Option<LossReport>,
    theta_h_bands: Vec<Band>,
    theta_d_bands: Vec<Band>,
    relative_error: RelativeErrors,
    /// Every row's residual sums, when the rows were given.
    rows: Option<Vec<RowSums>>,
}

/// Every per-cell figure of one model in one pass over the cells (`data` of a whole
/// table: multiplicity 1): the model is evaluated once per cell, in blocks, and each
/// cell's loss terms are added to its θh band, its θd band and (when `all`) the whole
/// set, in cell order, with the arithmetic and the chunked summation of
/// [`brdfkit_fit::evaluate_losses`], so every band's losses are those of
/// `evaluate_losses` on the band's cells gathered into a set of their own (to the bit;
/// a test holds them together) without gathering them. The relative errors of the
/// cell channels measured above 0 are written straight into the layout's array (each
/// block's place counted once from the measurements). With `rows`, each row's residual
/// sums (the residual maps' arithmetic, [`add_residual_cell`]) are taken from the same
/// values, cell by cell in order inside the row's block.
fn cell_pass(
    models: [&dyn Model; 3],
    data: &FitData,
    o: &QualityOptions,
    cuts: &[BandCuts; 2],
    all: bool,
    (layout, rows): (&mut PassLayout, Option<&CellRows>),
) -> CellPass {
    let measure = data.measure();
    let same = std::ptr::addr_eq(models[0], models[1]) && std::ptr::addr_eq(models[1], models[2]);
    let weight = |m: usize| match o.weighting {
        Weighting::SolidAngle => measure[m],
        Weighting::Uniform => 1.0,
    };
    let mut hs: Vec<LossSums> = o
        .theta_h_bands
        .windows(2)
        .map(|_| LossSums::new())
        .collect();
    let mut ds: Vec<LossSums> = o
        .theta_d_bands
        .windows(2)
        .map(|_| LossSums::new())
        .collect();
    let mut full = LossSums::new();
    let mut row_sums = rows.map(|r| vec![(0.0, 0, 0); r.len()]);
    {
        let (pieces, blocks, outs, pool) = layout.pieces();
        let mut work = blocks.iter().zip(pieces);
        loop {
            let window: Vec<(&Block, [&mut [f64]; 3])> = work.by_ref().take(WINDOW).collect();
            if window.is_empty() {
                break;
            }
            let used = &mut outs[..window.len()];
            // In parallel: each block's loss differences d[cell][loss][channel] (and its
            // relative errors, into their places; its rows' residual sums).
            used.par_iter_mut().zip(window).for_each(|(out, (b, dst))| {
                // A poisoned pool only means a block panicked: start afresh.
                let mut sc = pool
                    .lock()
                    .ok()
                    .and_then(|mut p| p.pop())
                    .unwrap_or_default();
                block_terms((models, same), data, cuts, (b, rows), dst, (out, &mut sc));
                if let Ok(mut p) = pool.lock() {
                    p.push(sc);
                }
            });
            let used = &*used;
            // In cell order: the sums, the θh bands beside the θd bands and the whole set
            // (each sum is still taken cell by cell in cell order: the same bits).
            rayon::join(
                || add_window(used, 0, &mut hs, None, &weight),
                || add_window(used, 1, &mut ds, all.then_some(&mut full), &weight),
            );
            if let Some(all_rows) = row_sums.as_mut() {
                for out in used {
                    all_rows[out.first_row..out.first_row + out.rows.len()]
                        .copy_from_slice(&out.rows);
                }
            }
        }
    }
    let bands = |edges: &[f64], sums: Vec<LossSums>| -> Vec<Band> {
        edges
            .windows(2)
            .zip(sums)
            .map(|(e, s)| Band {
                lo: e[0],
                hi: e[1],
                cells: s.cells,
                losses: s.finish(),
            })
            .collect()
    };
    let (rel, planes) = layout.rel_planes();
    // The channels' selections beside the pool's.
    let (channels, overall) = rayon::join(
        || {
            let mut out = [None; 3];
            out.par_iter_mut()
                .zip(planes)
                .for_each(|(o, r)| *o = percentiles(r));
            out
        },
        || percentiles(rel),
    );
    let relative_error = RelativeErrors {
        channels,
        samples: rel.len(),
        overall,
        zero_measured: layout.zero,
    };
    CellPass {
        losses: if all { full.finish() } else { None },
        theta_h_bands: bands(&o.theta_h_bands, hs),
        theta_d_bands: bands(&o.theta_d_bands, ds),
        relative_error,
        rows: row_sums,
    }
}

/// One block of [`cell_pass`] into `out`: the loss differences d[cell][loss][channel]
/// of its cells (the terms of `evaluate_losses`, in its order), the cells' θh and θd
/// bands, the relative errors of its cells measured above 0, written into `dst` (one
/// slice per channel, placed by the layout), and with `rows` its rows' residual sums.
/// `same`: one model for the three channels.
fn block_terms(
    (models, same): ([&dyn Model; 3], bool),
    data: &FitData,
    cuts: &[BandCuts; 2],
    (b, rows): (&Block, Option<&CellRows>),
    dst: [&mut [f64]; 3],
    (out, sc): (&mut BlockOut, &mut BlockScratch),
) {
    {
        let BlockScratch {
            geometry,
            values,
            tmp,
            planes,
        } = sc;
        let vals = data.values();
        let (s, e) = (b.cells.start, b.cells.end);
        let len = e - s;
        // The block's geometry, computed here for a table's cells whose whole-set columns
        // are not built (`FitData::geometry_of`: the same bits).
        let gs = data.geometry_of(s..e, geometry);
        values.clear();
        values.resize(len, Rgb::ZERO);
        models[0].eval_batch(&gs, values);
        if !same {
            tmp.clear();
            tmp.resize(len, Rgb::ZERO);
            for c in 1..3 {
                models[c].eval_batch(&gs, tmp);
                for (a, b) in values.iter_mut().zip(tmp.iter()) {
                    a[c] = b[c];
                }
            }
        }
        out.start = s;
        // The cells' bands of θ = acos(z) as `FitData::theta_h` / `theta_d` compute it
        // (no full-length angle arrays).
        out.bands.clear();
        out.bands
            .extend((0..len).map(|k| [cuts[0].band(gs.h_z[k]), cuts[1].band(gs.cos_d[k])]));
        if let Some(r) = rows {
            // Each row's cells in order, from 0: `residual_map`'s sums to the bit.
            out.first_row = b.rows.start;
            out.rows.clear();
            out.rows.extend(b.rows.clone().map(|row| {
                let mut a = (0.0, 0, 0);
                for q in r.starts[row]..r.starts[row + 1] {
                    add_residual_cell(&mut a, &values[q - s], [0, 1, 2].map(|c| vals[c][q]));
                }
                a
            }));
        }
        // Every term of every cell is written below.
        out.terms.resize(len * TERMS, 0.0);
        for p in planes.iter_mut() {
            p.resize(len, 0.0);
        }
        loss_terms(data, (s, e), values, &gs, dst, planes, &mut out.terms);
    }
}

/// The terms of `evaluate_losses` of cells `s..e` with the model's `values`, in its
/// order, a channel at a time in passes over plain slices: the cube roots and
/// logarithms in its vectorised loops (`cbrt_all`, `ln_1p_all`: the scalar functions'
/// bits), the measured roots from the stored targets when the fit built them
/// (`FitData::cbrt_targets`: the same roots). `planes` are four scratch planes of the
/// block's length; the relative errors go to `dst`.
fn loss_terms(
    data: &FitData,
    (s, e): (usize, usize),
    values: &[Rgb],
    gs: &GeomSlice<'_>,
    dst: [&mut [f64]; 3],
    planes: &mut [Vec<f64>; 4],
    d: &mut [f64],
) {
    let len = e - s;
    let vals = data.values();
    let ci = gs.wi_z;
    let roots = data.cbrt_targets_if_built();
    let [xm, xt, tm, lg] = planes;
    for (k, dk) in d.chunks_exact_mut(TERMS).enumerate() {
        let f = Loss::PUBLISHED.map(|l| l.cell_factor(gs.wi_z[k], gs.wo_z[k]));
        dk[12..].copy_from_slice(&f);
    }
    for (c, dst) in dst.into_iter().enumerate() {
        let fm = &vals[c][s..e];
        let mut q = 0;
        for k in 0..len {
            let x = values[k][c];
            if fm[k] > 0.0 {
                dst[q] = (x - fm[k]).abs() / fm[k];
                q += 1;
            }
            xm[k] = x * ci[k];
            xt[k] = fm[k] * ci[k];
            d[k * TERMS + c] = x - fm[k];
            d[k * TERMS + 3 + c] = xm[k] - xt[k];
            lg[k] = (xm[k] - xt[k]) / (1.0 + xt[k]);
        }
        debug_assert_eq!(q, dst.len());
        tm.copy_from_slice(xm);
        cbrt_all(tm);
        ln_1p_all(lg);
        let rt: &[f64] = match roots {
            Some(r) => &r[c][s..e],
            None => {
                cbrt_all(xt);
                xt
            }
        };
        for k in 0..len {
            d[k * TERMS + 6 + c] = tm[k] - rt[k];
            d[k * TERMS + 9 + c] = lg[k];
        }
    }
}

fn albedo_comparison(
    models: [&dyn Model; 3],
    table: &MerlTable,
    thetas: &[f64],
) -> Vec<AlbedoComparison> {
    thetas
        .par_iter()
        .map(|&theta_o| {
            let wo = spherical(theta_o, 0.0);
            let mut fit = Rgb::ZERO;
            for (c, m) in models.iter().enumerate() {
                // Per-channel fits are three models; a shared one is integrated once
                // per channel too (cheap next to the table's lookups).
                fit[c] = model_albedo_converged(*m, &wo, PoleChoice::Auto, 1e-6, false).0[c];
            }
            let guess = auto_pole(&table_brdf(table, Lookup::Interpolated), &wo);
            let (_, _, _, (t, missing)) = converged_with(&wo, PoleChoice::Auto, 1e-4, guess, |q| {
                let (a, m) = table_albedo(table, Lookup::Interpolated, &wo, q);
                (a.unwrap_or(Rgb::splat(f64::NAN)), (a, m))
            });
            AlbedoComparison {
                theta_o,
                table: t,
                table_missing_weight: missing,
                fit,
                difference: t.map(|t| fit - t),
            }
        })
        .collect()
}

/// A stratified split of the cells: per stratum of the [`STRATA`] × [`STRATA`] grid
/// over (√(θh/(π/2)), θd/(π/2)) (the fitter's own strata), round(fraction · n) cells
/// (at least one, and one fewer than n when n > 1) go to training, chosen by a seeded
/// Fisher-Yates shuffle.
pub fn stratified_split(data: &FitData, fraction: f64, seed: u64) -> (FitData, FitData) {
    let mut bins: Vec<Vec<usize>> = vec![Vec::new(); STRATA * STRATA];
    for m in 0..data.len() {
        bins[data.stratum_at(m)].push(m);
    }
    let mut train = vec![false; data.len()];
    for (b, cells) in bins.iter_mut().enumerate() {
        let n = cells.len();
        if n == 0 {
            continue;
        }
        let take = if n == 1 {
            1
        } else {
            ((fraction * n as f64).round() as usize).clamp(1, n - 1)
        };
        let mut r = SplitMix64(seed ^ (b as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
        for k in (1..n).rev() {
            let j = (r.next_u64() % (k as u64 + 1)) as usize;
            cells.swap(k, j);
        }
        for &m in &cells[..take] {
            train[m] = true;
        }
    }
    (data.filter(|m| train[m]), data.filter(|m| !train[m]))
}

/// Held-out validation: fits `family` (structure and start) with `config` on a
/// stratified `train_fraction` of `data` and scores the fit on the other cells. A θd
/// cutoff in `config` applies to both parts.
pub fn held_out(
    family: &dyn Model,
    data: &FitData,
    config: &FitConfig,
    train_fraction: f64,
    seed: u64,
) -> Result<HeldOutReport, QualityError> {
    if !(train_fraction > 0.0 && train_fraction < 1.0) {
        return Err(QualityError::Option {
            option: "train_fraction",
            reason: format!("must lie in (0, 1), got {train_fraction}"),
        });
    }
    let cut;
    let data = match config.angular_domain(data) {
        Some(d) => {
            cut = d;
            &cut
        }
        None => data,
    };
    let (train, test) = stratified_split(data, train_fraction, seed);
    if test.is_empty() {
        return Err(QualityError::Option {
            option: "train_fraction",
            reason: "no cell left to score".into(),
        });
    }
    let res = fit(family, &train, config, None)?;
    let models = models_of(&res.fitted);
    let w = config.get_weighting();
    let train_l = evaluate_losses(models, &train, w);
    let test_l = evaluate_losses(models, &test, w);
    let loss = config.get_loss();
    let (a, b) = (test_l.get(loss).overall, train_l.get(loss).overall);
    Ok(HeldOutReport {
        train_fraction,
        seed,
        train_cells: train.len(),
        test_cells: test.len(),
        loss,
        fitted: res.fitted.to_json(),
        train: train_l,
        test: test_l,
        ratio: if b > 0.0 { a / b } else { f64::INFINITY },
    })
}

/// Fit quality of `fitted` against `table`.
pub fn fit_quality_with(
    table: &MerlTable,
    fitted: &Fitted,
    o: &QualityOptions,
) -> Result<QualityReport, QualityError> {
    check_edges("theta_h_bands", &o.theta_h_bands)?;
    check_edges("theta_d_bands", &o.theta_d_bands)?;
    let data = FitData::from_table(table)?;
    let mut r = fit_quality_and_maps(table, &data, &[(fitted, None)], o, None)?.0;
    Ok(r.remove(0))
}

/// Fit quality of several fitted models against one table, on its cells `data`
/// ([`FitData::from_table`] of `table`, built once by the caller and shared by every
/// model), and with `map_bins` every model's residual map on blocks of at most
/// `map_bins` × `map_bins` (the report's). A model may come with its losses over
/// exactly these cells under `o.weighting` (the fit's record has them:
/// [`brdfkit_fit::FitRecord::losses_full`]); they are then used as they are instead of
/// being evaluated again.
///
/// The maps are taken from the values the quality pass evaluates, the rows' sums in the
/// same order: the maps of `html::analysis`'s reference `residual_map` to the bit (a
/// test holds them together), without evaluating every model at every cell a second
/// time. The blocks, the relative errors' array and the blocks' buffers are laid out
/// once for all the models.
pub(crate) fn fit_quality_and_maps(
    table: &MerlTable,
    data: &FitData,
    fits: &[(&Fitted, Option<&LossReport>)],
    o: &QualityOptions,
    map_bins: Option<usize>,
) -> Result<(Vec<QualityReport>, Vec<ResidualMap>), QualityError> {
    check_edges("theta_h_bands", &o.theta_h_bands)?;
    check_edges("theta_d_bands", &o.theta_d_bands)?;
    let cuts = BandCuts::of(o);
    let rows = map_bins.map(|_| CellRows::of(table));
    if let Some(r) = &rows
        && r.starts[r.len()] != data.len()
    {
        return Err(QualityError::Option {
            option: "cells",
            reason: format!(
                "{} cells given for a table with {} valid cells",
                data.len(),
                r.starts[r.len()]
            ),
        });
    }
    let mut layout = PassLayout::new(data, rows.as_ref());
    let mut maps = Vec::new();
    let mut reports = Vec::with_capacity(fits.len());
    for (fitted, known) in fits {
        let models = models_of(fitted);
        let pass = cell_pass(
            models,
            data,
            o,
            &cuts,
            known.is_none(),
            (&mut layout, rows.as_ref()),
        );
        if let (Some(r), Some(sums), Some(bins)) = (&rows, &pass.rows, map_bins) {
            maps.push(residual_map_of_rows(sums, r.bins, bins));
        }
        reports.push(quality_report(table, data, fitted, models, known, pass, o)?);
    }
    Ok((reports, maps))
}

/// One model's [`QualityReport`] from its cell pass: the losses (the known ones, or
/// the pass's), the bands, the relative errors, the albedo comparison and the held-out
/// fit when asked for.
fn quality_report(
    table: &MerlTable,
    data: &FitData,
    fitted: &Fitted,
    models: [&dyn Model; 3],
    known: &Option<&LossReport>,
    pass: CellPass,
    o: &QualityOptions,
) -> Result<QualityReport, QualityError> {
    let losses = match (known, pass.losses) {
        (Some(l), _) => **l,
        (None, Some(l)) => l,
        // A set without cells: the fitter's own report of it.
        (None, None) => evaluate_losses(models, data, o.weighting),
    };
    let albedo = albedo_comparison(models, table, &o.albedo_thetas);
    let held_out = match &o.held_out {
        Some(h) => {
            let family = brdfkit_models::from_json(&h.family)?;
            Some(held_out(
                family.as_ref(),
                data,
                &h.config,
                h.train_fraction,
                h.seed,
            )?)
        }
        None => None,
    };
    Ok(QualityReport {
        model: fitted.to_json(),
        weighting: o.weighting,
        cells: data.len(),
        losses,
        theta_h_bands: pass.theta_h_bands,
        theta_d_bands: pass.theta_d_bands,
        relative_error: pass.relative_error,
        albedo,
        held_out,
    })
}

fn loss_row(l: &LossReport, loss: Loss) -> String {
    let c = l.get(loss);
    format!(
        "{:<8} {:<10} [{}, {}, {}]",
        loss.name(),
        num(c.overall),
        num(c.channels[0]),
        num(c.channels[1]),
        num(c.channels[2])
    )
}

fn band_rows(s: &mut String, what: &str, bands: &[Band]) {
    *s += &format!("  by {what} band (overall cbrt / log / l2 loss, cells):\n");
    for b in bands {
        let range = format!("{}–{}", deg(b.lo.to_degrees()), deg(b.hi.to_degrees()));
        match &b.losses {
            Some(l) => {
                *s += &format!(
                    "    {:<12} cbrt {:<10} log {:<10} l2 {:<10} {} cells\n",
                    range,
                    num(l.cbrt.overall),
                    num(l.log.overall),
                    num(l.l2.overall),
                    b.cells
                )
            }
            None => *s += &format!("    {range:<12} no cells\n"),
        }
    }
}

impl QualityReport {
    /// The report as indented text.
    pub fn to_text(&self) -> String {
        let mut s = format!(
            "fit quality of {} over {} valid cells ({} weights)\n",
            self.model,
            self.cells,
            self.weighting.name()
        );
        s += "  losses (weighted RMS; overall [R, G, B]):\n";
        for l in Loss::ALL {
            s += &format!("    {}\n", loss_row(&self.losses, l));
        }
        band_rows(&mut s, "θh", &self.theta_h_bands);
        band_rows(&mut s, "θd", &self.theta_d_bands);
        let r = &self.relative_error;
        s += &format!(
            "  relative error |f − f̂|/f̂ percentiles (50 / 90 / 99) over {} cell channels ({} measured as 0 left out):\n",
            r.samples, r.zero_measured
        );
        let p = |x: &Option<Percentiles>| match x {
            Some(p) => format!("{} / {} / {}", num(p.p50), num(p.p90), num(p.p99)),
            None => "none".into(),
        };
        s += &format!("    overall {}\n", p(&r.overall));
        for (c, name) in ["R", "G", "B"].iter().enumerate() {
            s += &format!("    {name}       {}\n", p(&r.channels[c]));
        }
        s += "  albedo a(θo) = ∫f cosθi dωi, fit vs table:\n";
        for a in &self.albedo {
            s += &format!(
                "    θo {:>5}  fit {:<31} table {:<31} fit − table {}\n",
                deg(a.theta_o.to_degrees()),
                rgb(&a.fit),
                a.table.as_ref().map(rgb).unwrap_or_else(|| "none".into()),
                a.difference
                    .as_ref()
                    .map(rgb)
                    .unwrap_or_else(|| "none".into())
            );
        }
        if let Some(h) = &self.held_out {
            s += &format!(
                "  held-out: fitted on {} cells ({} per stratum, seed {}), scored on {}: {} loss train {} held-out {} (ratio {:.3})\n",
                h.train_cells,
                num(h.train_fraction),
                h.seed,
                h.test_cells,
                h.loss.name(),
                num(h.train.get(h.loss).overall),
                num(h.test.get(h.loss).overall),
                h.ratio
            );
            for l in Loss::ALL {
                s += &format!(
                    "    held-out {}   train {}\n",
                    loss_row(&h.test, l),
                    num(h.train.get(l).overall)
                );
            }
        }
        s
    }
}

crate::report::display_as_text!(QualityReport);

#[cfg(test)]
mod tests {
    use super::*;
    use brdfkit_merl::Dims;

    /// A table of a model with a different one's values in a few cells, and some holes.
    fn table() -> MerlTable {
        let m = brdfkit_models::from_json_str(
            r#"{"model": "ward", "params": {"rho_d": [0.2, 0.3, 0.4], "rho_s": 0.3, "alpha_x": 0.15, "alpha_y": 0.15}}"#,
        )
        .unwrap();
        let dims = Dims::new(40, 30, 60).unwrap();
        MerlTable::from_fn(dims, |i, j, k| {
            let (_, wi, wo, up) = brdfkit_merl::cell_directions(dims, i, j, k);
            let f = m.eval(&wi, &wo);
            (up && (i * 7 + j * 3 + k) % 11 != 0).then(|| {
                // Every 13th cell measured as 0 in red (a relative error left out).
                if (i + j + k) % 13 == 0 {
                    Rgb([0.0, f[1], f[2]])
                } else {
                    f * 1.1
                }
            })
        })
        .unwrap()
    }

    fn fits() -> Vec<Fitted> {
        let m = |j: &str| brdfkit_models::from_json_str(j).unwrap();
        let ct = r#"{"model": "cook-torrance", "params": {"rho_d": [0.2, 0.25, 0.3], "rho_s": 0.5, "alpha": 0.2}}"#;
        let lam = |r: f64| format!(r#"{{"model": "lambert", "params": {{"rho_d": {r}}}}}"#);
        vec![
            Fitted::Shared(m(ct)),
            Fitted::PerChannel([m(&lam(0.2)), m(&lam(0.3)), m(&lam(0.5))]),
        ]
    }

    /// The band of every cell of a MERL grid, and of cosines one ulp either side of
    /// every cut (and ±0, ±1, beyond ±1, NaN), from the cuts equals the acos formula's.
    #[test]
    fn bands_from_cuts_are_the_acos_formula_s() {
        let o = QualityOptions::default();
        let lambert =
            brdfkit_models::from_json_str(r#"{"model": "lambert", "params": {"rho_d": 0.5}}"#)
                .unwrap();
        let t = MerlTable::from_brdf(lambert.as_ref(), Dims::new(90, 90, 180).unwrap()).unwrap();
        let data = FitData::from_table(&t).unwrap();
        let g = data.geometry();
        for edges in [&o.theta_h_bands, &o.theta_d_bands] {
            let cuts = BandCuts::new(edges);
            let want = |z: f64| band_of(edges, theta_of(z)).map_or(u32::MAX, |b| b as u32);
            let mut zs = vec![-1.5, -1.0, -0.0, 0.0, 1.0, 1.5, f64::NAN];
            for &c in &cuts.0 {
                let mut z = c;
                for _ in 0..4 {
                    z = z.next_down();
                }
                for _ in 0..9 {
                    zs.push(z);
                    z = z.next_up();
                }
            }
            zs.extend(g.h_z.iter().chain(&g.cos_d));
            for z in zs {
                assert_eq!(cuts.band(z), want(z), "z = {z:e}");
            }
        }
        // An edge beyond π: no cosine reaches it.
        assert_eq!(BandCuts::cut(4.0), f64::NEG_INFINITY);
    }

    /// Sorting percentiles, as the nearest-rank definition reads.
    fn sorted_percentiles(v: &[f64]) -> Option<Percentiles> {
        let mut v = v.to_vec();
        if v.is_empty() {
            return None;
        }
        v.sort_unstable_by(f64::total_cmp);
        let n = v.len();
        let at = |p: f64| v[((p / 100.0 * n as f64).ceil() as usize).clamp(1, n) - 1];
        Some(Percentiles {
            p50: at(50.0),
            p90: at(90.0),
            p99: at(99.0),
        })
    }

    /// The one-pass figures are those of `evaluate_losses` on each band's cells
    /// gathered into a set of their own, and of sorting the relative errors, to the bit.
    #[test]
    fn one_pass_matches_gathered_bands_and_sorted_percentiles() {
        let t = table();
        let data = FitData::from_table(&t).unwrap();
        assert!(data.len() > 4 * brdfkit_fit::data::PASS_CHUNK_CELLS);
        // The first pass below runs on a table's cells whose whole-set geometry is not
        // built (each block's computed where read), the later ones on the built columns
        // (the relative errors' check builds them): the same figures either way.
        let o = QualityOptions::default();
        cell_pass(
            models_of(&fits()[0]),
            &data,
            &o,
            &BandCuts::of(&o),
            true,
            (&mut PassLayout::new(&data, None), None),
        );
        assert!(data.geometry_if_built().is_none());
        for w in [Weighting::SolidAngle, Weighting::Uniform] {
            let o = QualityOptions {
                weighting: w,
                ..QualityOptions::default()
            };
            for f in fits() {
                let models = models_of(&f);
                let p = cell_pass(
                    models,
                    &data,
                    &o,
                    &BandCuts::of(&o),
                    true,
                    (&mut PassLayout::new(&data, None), None),
                );
                assert_eq!(p.losses, Some(evaluate_losses(models, &data, w)));
                // With the fit's stored cube-root targets: the same figures.
                let stored = data.clone();
                stored.cbrt_targets();
                let q = cell_pass(
                    models,
                    &stored,
                    &o,
                    &BandCuts::of(&o),
                    true,
                    (&mut PassLayout::new(&stored, None), None),
                );
                assert!(stored.cbrt_targets_if_built().is_some());
                assert_eq!(
                    (
                        &q.losses,
                        &q.theta_h_bands,
                        &q.theta_d_bands,
                        &q.relative_error
                    ),
                    (
                        &p.losses,
                        &p.theta_h_bands,
                        &p.theta_d_bands,
                        &p.relative_error
                    )
                );
                for (bands, angle, edges) in [
                    (&p.theta_h_bands, data.theta_h(), &o.theta_h_bands),
                    (&p.theta_d_bands, data.theta_d(), &o.theta_d_bands),
                ] {
                    let last = edges.len() - 2;
                    assert_eq!(bands.len(), last + 1);
                    for (b, band) in bands.iter().enumerate() {
                        let (lo, hi) = (edges[b], edges[b + 1]);
                        let sub = data.filter(|m| angle[m] >= lo && (angle[m] < hi || b == last));
                        assert_eq!(band.cells, sub.len());
                        assert_eq!(
                            band.losses,
                            (!sub.is_empty()).then(|| evaluate_losses(models, &sub, w)),
                            "band {b}"
                        );
                    }
                }
                // Relative errors: every cell channel measured above 0.
                let mut per: [Vec<f64>; 3] = Default::default();
                let mut zero = 0;
                for c in 0..3 {
                    for m in 0..data.len() {
                        let g = data.geometry().slice(m..m + 1);
                        let mut v = [Rgb::ZERO];
                        models[c].eval_batch(&g, &mut v);
                        let fm = data.values()[c][m];
                        if fm > 0.0 {
                            per[c].push((v[0][c] - fm).abs() / fm);
                        } else if fm == 0.0 {
                            zero += 1;
                        }
                    }
                }
                let r = &p.relative_error;
                assert!(zero > 0);
                assert_eq!(r.zero_measured, zero);
                let pooled: Vec<f64> = per.iter().flatten().copied().collect();
                assert_eq!(r.samples, pooled.len());
                assert_eq!(r.overall, sorted_percentiles(&pooled));
                for (got, v) in r.channels.iter().zip(&per) {
                    assert_eq!(*got, sorted_percentiles(v));
                }
            }
        }
    }

    /// The report's pass (blocks of whole rows, the residual sums on the way, one
    /// layout for every model) gives the figures of a pass of its own per model, and
    /// the maps of the reference `residual_map` (its own evaluation), to the bit; with
    /// a model 0 on part of the table (the floor and the zeros' count).
    #[test]
    fn report_pass_keeps_the_figures_and_gives_the_reference_maps() {
        use crate::html::analysis::residual_map;
        let t = table();
        let data = FitData::from_table(&t).unwrap();
        let o = QualityOptions {
            albedo_thetas: Vec::new(),
            ..QualityOptions::default()
        };
        let mut fs = fits();
        fs.push(Fitted::Shared(
            brdfkit_models::from_json_str(
                r#"{"model": "lambert", "params": {"rho_d": [0.0, 0.3, 0.0]}}"#,
            )
            .unwrap(),
        ));
        let given: Vec<(&Fitted, Option<&LossReport>)> = fs.iter().map(|f| (f, None)).collect();
        for bins in [45, 7, 1] {
            let (reports, maps) = fit_quality_and_maps(&t, &data, &given, &o, Some(bins)).unwrap();
            for ((f, r), m) in fs.iter().zip(&reports).zip(&maps) {
                let alone = fit_quality_and_maps(&t, &data, &[(f, None)], &o, None)
                    .unwrap()
                    .0
                    .remove(0);
                assert_eq!(r, &alone);
                assert_eq!(m, &residual_map(&t, &data, f, bins));
            }
            assert!(maps[2].model_zero > 0);
        }
        // Whole-row blocks hold every cell once, in order.
        let rows = CellRows::of(&t);
        let b = blocks(data.len(), Some(&rows));
        assert!(b.len() > 1);
        assert_eq!(b[0].cells.start, 0);
        assert_eq!(b.last().unwrap().cells.end, data.len());
        for w in b.windows(2) {
            assert_eq!(w[0].cells.end, w[1].cells.start);
            assert!(w[0].cells.len() <= BLOCK);
        }
    }

    #[test]
    fn selection_percentiles_are_the_sorted_ones() {
        let mut r = brdfkit_models::testing::SplitMix64(3);
        for n in [1usize, 2, 3, 10, 99, 100, 101, 1000, 4097] {
            let v: Vec<f64> = (0..n).map(|_| (r.next_u64() % 1000) as f64 / 7.0).collect();
            assert_eq!(percentiles(&v), sorted_percentiles(&v), "n = {n}");
        }
        assert_eq!(percentiles(&[]), None);
    }

    /// The radix step keeps `total_cmp`'s order across signs, zeros, infinities, NaNs
    /// and subnormals, and finds ranks that share a bucket or fall in different ones.
    #[test]
    fn bucketed_selection_is_the_total_order() {
        let mut r = brdfkit_models::testing::SplitMix64(11);
        let special = [
            -0.0,
            0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            f64::MIN_POSITIVE / 8.0,
            -1e300,
            1.0 + f64::EPSILON,
            1.0,
        ];
        for n in [1usize, 5, 64, 1000, 30_000] {
            let mut v: Vec<f64> = (0..n)
                .map(|k| match r.next_u64() % 4 {
                    0 => special[k % special.len()],
                    1 => f64::from_bits(r.next_u64()),
                    // Many values in a few buckets: ranks inside one bucket.
                    2 => 1.0 + (r.next_u64() % 50) as f64 * f64::EPSILON,
                    _ => (r.next_u64() % 1000) as f64 / 7.0 - 70.0,
                })
                .collect();
            let mut sorted = v.clone();
            sorted.sort_unstable_by(f64::total_cmp);
            let ranks = [n / 2, n - 1, 0, (9 * n) / 10, n / 2];
            let got = kth_smallest(&v, ranks);
            for (g, k) in got.iter().zip(ranks) {
                assert_eq!(g.to_bits(), sorted[k].to_bits(), "n = {n}, rank {k}");
            }
            v.reverse();
            let bits = |p: Option<Percentiles>| p.map(|p| [p.p50, p.p90, p.p99].map(f64::to_bits));
            assert_eq!(
                bits(percentiles(&v)),
                bits(sorted_percentiles(&v)),
                "n = {n}"
            );
        }
    }
}
