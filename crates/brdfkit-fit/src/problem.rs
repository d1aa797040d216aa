//! [`FitProblem`]: the weighted least-squares problem of one model against one cell set,
//! in the reparameterised coordinates u, with residuals, normal equations and the argmin
//! operator traits.
//!
//! # Residuals
//! For active channel c and cell k,
//!
//! ```text
//! r_ck(u) = s_k · ( t(f_c(x(u); k), cos θi_k) − t(f̂_ck, cos θi_k) ),
//! s_k = sqrt( w_k / (n_ch · Σ_j w_j) ),
//! ```
//!
//! so the cost ½ Σ r² is half the mean over channels of the weighted mean square, and
//! sqrt(2 · cost) is the overall loss of [`crate::loss`]. The Jacobian is
//!
//! ```text
//! ∂r_ck/∂u_q = s_k · t'(f_ck) · ∂f_c/∂x_p · dx_p/du_q      (p the model index of u_q)
//! ```
//!
//! # Evaluation
//! The cells are split into chunks of [`PASS_CHUNK_CELLS`]; rayon maps over the chunks with one
//! scratch set per job (`map_init`: model values, the model's parameter-major
//! gradient, the Jacobian columns of the chunk), so nothing is allocated per cell.
//! Each chunk's partial sums are collected and added in chunk order, so a pass gives
//! the same bits whatever the number of threads and however the work was split (a
//! fold's per-split partials are grouped by work stealing). Per chunk and
//! channel the Jacobian columns of the parameters that act on that channel (the
//! channel's own albedo-like parameters and the shared ones; see
//! [`brdfkit_core::ParamRole`]) are formed as contiguous arrays, and JᵀJ and Jᵀr are
//! accumulated as dot products of those columns. The full Jacobian (4.4 M rows for a
//! MERL table) is never stored.
//!
//! # Robust losses (iteratively reweighted least squares)
//! With a robust function ρ of scale c ([`crate::loss::Robust`],
//! [`FitProblem::with_robust`]) the cost is F = ½ Σ s² ρ(e²), e = r / s the unscaled
//! residual. Its gradient is Σ ρ'(e²) r ∇r, and its Hessian
//! Σ (ρ' ∇rᵀ∇r + 2ρ'' e² ∇rᵀ∇r + ρ' r ∇²r) is replaced by the Gauss-Newton
//! approximation Σ ρ'(e²) ∇rᵀ∇r: per residual a weight ρ' ∈ (0, 1] on its row of J
//! and its residual (Triggs et al., "Bundle Adjustment — A Modern Synthesis", 2000,
//! §4.3, the "IRLS-like" approximation; dropping the 2ρ''e² term, which is ≤ 0 for
//! Huber and Cauchy, keeps the matrix positive semi-definite). In the pass this is
//! √ρ' multiplied into the residual and the Jacobian column entries of each cell, so
//! JᵀJ and Jᵀr become Σ ρ' JᵢᵀJᵢ and Σ ρ' Jᵢᵀrᵢ with no other change; the solvers
//! then see a quadratic model of the robust cost and measure their gain ratio on F
//! itself, so LM's acceptance test is exact. Without a robust function the pass is
//! the plain one, unchanged.

use crate::data::ChunkGeometry;
use crate::data::{FitData, PASS_CHUNK_CELLS};
use crate::energy::AlbedoPenalty;
use crate::error::FitError;
use crate::loss::{
    Loss, LossSet, OwnLossCells, OwnLossScratch, Robust, RobustKind, Weighting, own_loss_sums,
};
use crate::reparam::{Transform, nudge_into};
use argmin::core::{CostFunction, Error as ArgminError, Gradient, Hessian, Jacobian, Operator};
use brdfkit_core::lanes::{Run, dispatch};
use brdfkit_core::model::Domain;
use brdfkit_core::{Columns, Model, ParamRole, Rgb};
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

/// JᵀJ, Jᵀr and the cost at one point.
#[derive(Debug, Clone)]
pub struct NormalEq {
    /// JᵀJ (m × m, symmetric).
    pub jtj: DMatrix<f64>,
    /// Jᵀr, the gradient of the cost ½‖r‖².
    pub jtr: DVector<f64>,
    /// ½‖r‖².
    pub cost: f64,
}

/// Problems a least-squares solver can drive through their normal equations.
pub trait NormalEquations {
    /// JᵀJ, Jᵀr and ½‖r‖² at `u`. A point where the model is not finite must give a
    /// non-finite cost (the solvers then reject the step), not an error.
    fn normal_equations(&self, u: &DVector<f64>) -> Result<NormalEq, ArgminError>;

    /// A cost at or below which the residuals are round-off (a perfect fit): solvers
    /// stop there. 0 disables the test.
    fn cost_floor(&self) -> f64 {
        0.0
    }

    /// Whether coordinate `q` at the value `u` sits at a bound of its parameter's
    /// domain, where the cost is flat along it (a saturated logit or log: see
    /// [`crate::reparam::Transform::end_at`]). The default: never.
    fn at_bound(&self, _q: usize, _u: f64) -> bool {
        false
    }
}

struct Inner<'a> {
    data: &'a FitData,
    proto: Box<dyn Model>,
    base: Vec<f64>,
    free: Vec<usize>,
    names: Vec<String>,
    transforms: Vec<Transform>,
    domains: Vec<Domain>,
    channels: Vec<usize>,
    loss: Loss,
    /// The targets t(f̂) are not stored: each pass forms them per chunk from the
    /// cells' values (`fill_target`), the same function on the same numbers, so the
    /// residuals are bit-identical. Storing them cost 8 bytes per cell and channel
    /// (35 MB for a MERL table with every cell valid) for one transform per cell and
    /// channel per pass (≈ 6 ns for `cbrt`, see [`crate::loss::cbrt`]).
    /// The weighting; s_k = sqrt(w_k · inv_wsum) is formed per chunk from the cells'
    /// multiplicity and measure rather than stored: one array fewer (8.9 MB on a MERL
    /// table) for a multiply and a square root per cell, which vectorise.
    weighting: Weighting,
    /// 1 / (n_ch Σ_j w_j).
    inv_wsum: f64,
    /// Per channel: positions q (into the free vector) of the parameters acting on it.
    cols: [Vec<usize>; 3],
    /// Σ s² t(f̂)² over the active channels: the weighted mean square of the targets.
    /// Formed on first use (a pass over the cells; the full set of a fit whose
    /// solvers run only on subsamples never needs it).
    target_ms: OnceLock<f64>,
    /// The scales and targets of a small set ([`STORE_MAX_CELLS`]), formed once.
    stored: Option<Stored>,
}

/// Largest cell set whose scales s and targets t(f̂) a problem stores rather than
/// forming per chunk and pass: 2 MB for 65,536 cells (the warm-up set), against one
/// transform per cell and channel on every pass of every start (on the exploration
/// and warm-up sets, where LM takes nearly all of its passes, `fill_target` was 15 %
/// of a default fit's CPU time). A full table keeps the per-chunk forming (35 MB saved).
const STORE_MAX_CELLS: usize = 1 << 18;

/// Stored s and t(f̂) of a small set: the same functions of the same numbers as the
/// per-chunk forming, so the same bits.
struct Stored {
    s: Vec<f64>,
    /// Per channel; empty for an inactive one.
    t: [Vec<f64>; 3],
}

/// The least-squares problem of one model family against a cell set.
///
/// Cheap to clone (the precomputed arrays are shared); each clone has its own
/// evaluation counters.
pub struct FitProblem<'a> {
    inner: Arc<Inner<'a>>,
    robust: Option<Robust>,
    /// The albedo penalty of an energy-conserving fit ([`crate::energy`]).
    penalty: Option<Arc<AlbedoPenalty>>,
    cost_evals: AtomicU64,
    jac_evals: AtomicU64,
    cache: Mutex<Option<(DVector<f64>, NormalEq)>>,
}

impl Clone for FitProblem<'_> {
    fn clone(&self) -> Self {
        FitProblem {
            inner: self.inner.clone(),
            robust: self.robust,
            penalty: self.penalty.clone(),
            cost_evals: AtomicU64::new(0),
            jac_evals: AtomicU64::new(0),
            cache: Mutex::new(None),
        }
    }
}

impl std::fmt::Debug for FitProblem<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FitProblem")
            .field("model", &self.inner.proto.name())
            .field("free", &self.inner.names)
            .field("channels", &self.inner.channels)
            .field("loss", &self.inner.loss)
            .field("robust", &self.robust)
            .field("cells", &self.inner.data.len())
            .finish()
    }
}

/// Sum of products with four independent accumulators, so the loop vectorises (a single
/// accumulator is a serial dependency the compiler may not reorder).
#[inline(always)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut s = [0.0f64; 4];
    let ca = a.chunks_exact(4);
    let cb = b.chunks_exact(4);
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        s[0] += x[0] * y[0];
        s[1] += x[1] * y[1];
        s[2] += x[2] * y[2];
        s[3] += x[3] * y[3];
    }
    let mut t = (s[0] + s[1]) + (s[2] + s[3]);
    for (x, y) in ra.iter().zip(rb) {
        t += x * y;
    }
    t
}

/// Smallest run of chunks a rayon job takes: about four jobs per thread. Each job of
/// a fold allocates its own scratch (≈ 0.6 MB for a 10-parameter model, fresh pages
/// from the allocator); with rayon's default splitting that was ~135 allocations per
/// pass over a MERL table, and their zeroing and page faults cost ~10 % of the pass.
fn min_len(nchunks: usize) -> usize {
    (nchunks / (4 * rayon::current_num_threads())).max(1)
}

/// The one way every pass splits `n` cells: chunks of [`PASS_CHUNK_CELLS`] as cell
/// ranges, in order, at least [`min_len`] chunks a rayon job. A pass's per-chunk
/// scratch holds [`chunk_cap`] cells.
fn chunks(n: usize) -> impl IndexedParallelIterator<Item = Range<usize>> {
    let nchunks = n.div_ceil(PASS_CHUNK_CELLS);
    (0..nchunks)
        .into_par_iter()
        .with_min_len(min_len(nchunks))
        .map(move |ci| ci * PASS_CHUNK_CELLS..((ci + 1) * PASS_CHUNK_CELLS).min(n))
}

/// Cells of the largest chunk of [`chunks`]`(n)`.
fn chunk_cap(n: usize) -> usize {
    PASS_CHUNK_CELLS.min(n)
}

/// s_k = sqrt(w_k / (n_ch Σ w)) of the cells `start .. start + out.len()`. A set
/// without stored multiplicities (all 1) skips the multiply by 1, which is exact, so
/// the scales are the same bits either way. A published metric's weight factor g
/// ([`Loss::cell_factor`]) multiplies w_k (and `inv_wsum` is then 1/(n_ch Σ w g));
/// brdfkit's own losses skip it, so their scales are unchanged.
#[inline]
fn fill_scale(
    data: &FitData,
    weighting: Weighting,
    loss: Loss,
    inv_wsum: f64,
    start: usize,
    out: &mut [f64],
) {
    fill_scale_plain(data, weighting, inv_wsum, start, out);
    if loss.has_cell_factor() {
        for (k, x) in out.iter_mut().enumerate() {
            *x *= data.loss_factor_at(loss, start + k).sqrt();
        }
    }
}

/// [`fill_scale`] without a loss's factor.
#[inline]
fn fill_scale_plain(
    data: &FitData,
    weighting: Weighting,
    inv_wsum: f64,
    start: usize,
    out: &mut [f64],
) {
    let range = start..start + out.len();
    let meas = &data.measure()[range.clone()];
    match (data.multiplicity_if_any(), weighting) {
        (Some(m), Weighting::SolidAngle) => {
            let mult = &m[range];
            for k in 0..out.len() {
                out[k] = (mult[k] * meas[k] * inv_wsum).sqrt();
            }
        }
        (Some(m), Weighting::Uniform) => {
            let mult = &m[range];
            for k in 0..out.len() {
                out[k] = (mult[k] * inv_wsum).sqrt();
            }
        }
        (None, Weighting::SolidAngle) => {
            for k in 0..out.len() {
                out[k] = (meas[k] * inv_wsum).sqrt();
            }
        }
        (None, Weighting::Uniform) => out.fill(inv_wsum.sqrt()),
    }
}

/// The targets t(f̂, cos θi) of channel c for the cells `start .. start + out.len()`.
/// A table's cells whose whole-set geometry is not built compute the chunk's here
/// ([`FitData::geometry_of`]): the default fit's one pass over the full set (the
/// targets' RMS that scales the albedo penalty) builds no full-set columns.
#[inline]
fn fill_target(data: &FitData, loss: Loss, c: usize, start: usize, out: &mut [f64]) {
    let range = start..start + out.len();
    let f = &data.values()[c][range.clone()];
    out.copy_from_slice(f);
    let mut scratch = brdfkit_core::GeometryBatch::default();
    loss.transform_all(data.geometry_of(range, &mut scratch).wi_z, out);
}

struct Scratch {
    s: Vec<f64>,
    t: Vec<f64>,
    out: Vec<Rgb>,
    grad: Vec<Rgb>,
    jcol: Vec<f64>,
    r: Vec<f64>,
    d: Vec<f64>,
    jtj: Vec<f64>,
    jtr: Vec<f64>,
    cost: f64,
}

impl Inner<'_> {
    /// s_k of every cell ([`fill_scale`]), for the dense residual and Jacobian.
    fn scales(&self) -> Vec<f64> {
        match &self.stored {
            Some(st) => st.s.clone(),
            None => {
                let mut scale = vec![0.0; self.data.len()];
                self.scale_of(0, &mut scale);
                scale
            }
        }
    }

    /// s_k of the cells `start .. start + buf.len()`: the stored ones, or formed in
    /// `buf`.
    fn scale_of<'b>(&'b self, start: usize, buf: &'b mut [f64]) -> &'b [f64] {
        match &self.stored {
            Some(st) => &st.s[start..start + buf.len()],
            None => {
                let (w, l) = (self.weighting, self.loss);
                fill_scale(self.data, w, l, self.inv_wsum, start, buf);
                buf
            }
        }
    }

    /// The targets t(f̂) of channel c for the cells `start .. start + buf.len()`: the
    /// stored ones, or formed in `buf`.
    fn target_of<'b>(&'b self, c: usize, start: usize, buf: &'b mut [f64]) -> &'b [f64] {
        match &self.stored {
            Some(st) => &st.t[c][start..start + buf.len()],
            None => {
                fill_target(self.data, self.loss, c, start, buf);
                buf
            }
        }
    }

    /// Σ s² t² over the active channels (see `target_ms`), chunk by chunk; per-chunk
    /// sums in parallel, added in chunk order (deterministic).
    fn target_ms(&self) -> f64 {
        *self.target_ms.get_or_init(|| {
            let n = self.data.len();
            let cap = chunk_cap(n);
            let mut ms = 0.0;
            for &c in &self.channels {
                let parts: Vec<f64> = chunks(n)
                    .map_init(
                        || (vec![0.0; cap], vec![0.0; cap]),
                        |(sbuf, tbuf), Range { start: s, end: e }| {
                            let len = e - s;
                            let sb = self.scale_of(s, &mut sbuf[..len]);
                            let tb = self.target_of(c, s, &mut tbuf[..len]);
                            tb.iter()
                                .zip(sb.iter())
                                .map(|(t, s)| (t * s) * (t * s))
                                .sum::<f64>()
                        },
                    )
                    .collect();
                for p in parts {
                    ms += p;
                }
            }
            ms
        })
    }
}

impl<'a> FitProblem<'a> {
    /// A problem: `model` at its start parameters (fixed parameters keep these values),
    /// `free` the model-vector indices to fit, the active `channels`, the loss and the
    /// weighting.
    pub fn new(
        data: &'a FitData,
        model: &dyn Model,
        free: Vec<usize>,
        channels: Vec<usize>,
        loss: Loss,
        weighting: Weighting,
    ) -> Result<Self, FitError> {
        let specs = model.param_specs();
        let base = model.params();
        if data.is_empty() {
            return Err(FitError::NoCells("the cell set is empty".into()));
        }
        if free.is_empty() {
            return Err(FitError::NothingToFit(model.name().into()));
        }
        if channels.is_empty() || channels.iter().any(|&c| c > 2) {
            return Err(FitError::InvalidOption {
                option: "channels",
                value: format!("{channels:?}"),
                reason: "must be a non-empty subset of 0, 1, 2".into(),
            });
        }
        for &p in &free {
            if p >= specs.len() {
                return Err(FitError::Data(format!(
                    "free parameter index {p} beyond the model's {} parameters",
                    specs.len()
                )));
            }
        }
        let names = free.iter().map(|&p| specs[p].name.clone()).collect();
        let domains: Vec<Domain> = free.iter().map(|&p| specs[p].domain).collect();
        let transforms = domains.iter().map(Transform::for_domain).collect();
        let wsum = data.loss_weight_sum(weighting, loss);
        let nch = channels.len() as f64;
        let inv_wsum = 1.0 / (nch * wsum);
        let mut cols: [Vec<usize>; 3] = Default::default();
        let n = data.len();
        let stored = (n <= STORE_MAX_CELLS).then(|| {
            let mut st = Stored {
                s: vec![0.0; n],
                t: Default::default(),
            };
            fill_scale(data, weighting, loss, inv_wsum, 0, &mut st.s);
            for &c in &channels {
                st.t[c] = vec![0.0; n];
                fill_target(data, loss, c, 0, &mut st.t[c]);
            }
            st
        });
        for &c in &channels {
            cols[c] = free
                .iter()
                .enumerate()
                .filter(|(_, p)| match specs[**p].role {
                    ParamRole::Shared => true,
                    ParamRole::Channel(k) => k == c,
                })
                .map(|(q, _)| q)
                .collect();
        }
        Ok(FitProblem {
            inner: Arc::new(Inner {
                data,
                proto: model.clone_box(),
                base,
                free,
                names,
                transforms,
                domains,
                channels,
                loss,
                weighting,
                inv_wsum,
                cols,
                target_ms: OnceLock::new(),
                stored,
            }),
            robust: None,
            penalty: None,
            cost_evals: AtomicU64::new(0),
            jac_evals: AtomicU64::new(0),
            cache: Mutex::new(None),
        })
    }

    /// The same problem with the robust function `robust` (a `None` kind or a scale
    /// that is not a positive finite number gives the plain problem). Cheap: the
    /// precomputed arrays are shared.
    pub fn with_robust(&self, robust: Robust) -> Self {
        let mut p = self.clone();
        p.robust =
            (robust.kind != RobustKind::None && robust.scale.is_finite() && robust.scale > 0.0)
                .then_some(robust);
        p
    }

    /// The same problem with an albedo penalty added to its cost and normal
    /// equations (see [`crate::energy`]): the penalty residuals join the cell
    /// residuals in [`cost_at`](Self::cost_at) and [`normal_eq`](Self::normal_eq)
    /// (every solver's path); the dense [`residuals`](Self::residuals) and
    /// [`jacobian_dense`](Self::jacobian_dense) stay those of the cells.
    pub fn with_penalty(&self, penalty: Option<Arc<AlbedoPenalty>>) -> Self {
        let mut p = self.clone();
        p.penalty = penalty;
        p
    }

    /// The albedo penalty in force, if any.
    pub fn penalty(&self) -> Option<&AlbedoPenalty> {
        self.penalty.as_deref()
    }

    /// The robust function in force, if any.
    pub fn robust(&self) -> Option<Robust> {
        self.robust
    }

    /// The root-mean-square of the targets t(f̂) with the cells' weights (the scale of
    /// the residuals of a fit that explains nothing).
    pub fn target_rms(&self) -> f64 {
        self.inner.target_ms().sqrt()
    }

    /// Median of |e| = |t(f) − t(f̂)| over every cell and active channel at u (unweighted;
    /// `None` where the model is not finite there). 1.4826 times it estimates the
    /// standard deviation of Gaussian residuals and ignores up to half of the cells
    /// being outliers (the MAD about 0 of the residuals of a fit).
    pub fn median_abs_residual(&self, u: &DVector<f64>) -> Option<f64> {
        let (m, _) = self.model_or_nan(u)?;
        let inn = &*self.inner;
        let n = inn.data.len();
        let g = inn.data.geometry();
        let cap = chunk_cap(n);
        let mut e: Vec<f64> = chunks(n)
            .fold(
                || (vec![Rgb::ZERO; cap], vec![0.0; cap], Vec::new()),
                |(mut out, mut tbuf, mut acc): (Vec<Rgb>, Vec<f64>, Vec<f64>),
                 Range { start: s, end: e }| {
                    m.eval_batch(&g.slice(s..e), &mut out[..e - s]);
                    for &c in &inn.channels {
                        let tg = inn.target_of(c, s, &mut tbuf[..e - s]);
                        for k in 0..e - s {
                            let t = inn.loss.transform(out[k][c], g.wi_z[s + k]);
                            acc.push((t - tg[k]).abs());
                        }
                    }
                    (out, tbuf, acc)
                },
            )
            .map(|(_, _, a)| a)
            .reduce(Vec::new, |mut a, mut b| {
                a.append(&mut b);
                a
            });
        if e.is_empty() || e.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let mid = e.len() / 2;
        let (_, med, _) = e.select_nth_unstable_by(mid, f64::total_cmp);
        Some(*med)
    }

    /// Number of free parameters m.
    pub fn dim(&self) -> usize {
        self.inner.free.len()
    }

    /// Number of residuals (cells × active channels).
    pub fn num_residuals(&self) -> usize {
        self.inner.data.len() * self.inner.channels.len()
    }

    /// Names of the free parameters, in u order.
    pub fn free_names(&self) -> &[String] {
        &self.inner.names
    }

    /// Model-vector indices of the free parameters.
    pub fn free_indices(&self) -> &[usize] {
        &self.inner.free
    }

    /// The transforms of the free parameters.
    pub fn transforms(&self) -> &[Transform] {
        &self.inner.transforms
    }

    /// The active channels.
    pub fn channels(&self) -> &[usize] {
        &self.inner.channels
    }

    /// The loss minimised.
    pub fn loss(&self) -> Loss {
        self.inner.loss
    }

    /// Cost evaluations (passes over the cells without derivatives) so far.
    pub fn cost_evals(&self) -> u64 {
        self.cost_evals.load(Ordering::Relaxed)
    }

    /// Jacobian evaluations (passes over the cells with derivatives) so far.
    pub fn jacobian_evals(&self) -> u64 {
        self.jac_evals.load(Ordering::Relaxed)
    }

    /// u of a full physical parameter vector (its free entries).
    pub fn to_u(&self, x: &[f64]) -> DVector<f64> {
        DVector::from_iterator(
            self.dim(),
            self.inner
                .free
                .iter()
                .zip(&self.inner.transforms)
                .map(|(&p, t)| t.inverse(x[p])),
        )
    }

    /// u of the start model.
    pub fn start_u(&self) -> DVector<f64> {
        self.to_u(&self.inner.base)
    }

    /// The full physical vector at u and dx/du of each free entry.
    pub fn params_at(&self, u: &DVector<f64>) -> (Vec<f64>, Vec<f64>) {
        let mut x = self.inner.base.clone();
        let mut dx = vec![0.0; self.dim()];
        for q in 0..self.dim() {
            let (v, d) = self.inner.transforms[q].forward(u[q]);
            x[self.inner.free[q]] = nudge_into(&self.inner.domains[q], v);
            dx[q] = d;
        }
        (x, dx)
    }

    /// The model at u.
    pub fn model_at(&self, u: &DVector<f64>) -> Result<Box<dyn Model>, FitError> {
        let (x, _) = self.params_at(u);
        let mut m = self.inner.proto.clone_box();
        m.set_params(&x).map_err(|e| FitError::Model {
            model: m.name().into(),
            source: e,
        })?;
        Ok(m)
    }

    fn model_or_nan(&self, u: &DVector<f64>) -> Option<(Box<dyn Model>, Vec<f64>)> {
        if u.iter().any(|v| !v.is_finite()) {
            return None;
        }
        let (x, dx) = self.params_at(u);
        let mut m = self.inner.proto.clone_box();
        m.set_params(&x).ok()?;
        Some((m, dx))
    }

    /// The cost at u: ½‖r(u)‖², or ½ Σ s² ρ(e²) with a robust function (+∞ where the
    /// model is not finite or rejects the parameters).
    pub fn cost_at(&self, u: &DVector<f64>) -> f64 {
        self.cost_evals.fetch_add(1, Ordering::Relaxed);
        let Some((m, _)) = self.model_or_nan(u) else {
            return f64::INFINITY;
        };
        let inn = &*self.inner;
        let robust = self.robust;
        let n = inn.data.len();
        let g = inn.data.geometry();
        let cap = chunk_cap(n);
        let parts: Vec<f64> = chunks(n)
            .map_init(
                || {
                    (
                        vec![Rgb::ZERO; cap],
                        vec![0.0; cap],
                        vec![0.0; cap],
                        vec![0.0; cap],
                    )
                },
                |(out, sbuf, tbuf, xbuf), Range { start: s, end: e }| {
                    let mut acc = 0.0;
                    let len = e - s;
                    m.eval_batch(&g.slice(s..e), &mut out[..len]);
                    let cos_i = &g.wi_z[s..e];
                    let sc = inn.scale_of(s, &mut sbuf[..len]);
                    for &c in &inn.channels {
                        let tg = inn.target_of(c, s, &mut tbuf[..len]);
                        let t = &mut xbuf[..len];
                        for (x, o) in t.iter_mut().zip(&out[..len]) {
                            *x = o[c];
                        }
                        inn.loss.transform_all(cos_i, t);
                        let mut part = 0.0;
                        match robust {
                            None => {
                                for k in 0..len {
                                    let r = sc[k] * (t[k] - tg[k]);
                                    part += r * r;
                                }
                            }
                            Some(rb) => {
                                for k in 0..len {
                                    let e = t[k] - tg[k];
                                    part += sc[k] * sc[k] * rb.rho(e * e).0;
                                }
                            }
                        }
                        acc += part;
                    }
                    acc
                },
            )
            .collect();
        // Chunk partials added in chunk order: the same sum whatever the threads.
        let mut c = 0.5 * parts.iter().sum::<f64>();
        if let Some(pen) = &self.penalty {
            c += pen.cost(m.as_ref(), &inn.channels);
        }
        if c.is_finite() { c } else { f64::INFINITY }
    }

    /// JᵀJ, Jᵀr and the cost at u in one parallel pass (see the module doc).
    pub fn normal_eq(&self, u: &DVector<f64>) -> NormalEq {
        if let Some((cu, ne)) = self.cache.lock().expect("cache lock").as_ref()
            && cu == u
        {
            return ne.clone();
        }
        self.jac_evals.fetch_add(1, Ordering::Relaxed);
        let mdim = self.dim();
        let bad = || NormalEq {
            jtj: DMatrix::zeros(mdim, mdim),
            jtr: DVector::zeros(mdim),
            cost: f64::INFINITY,
        };
        let Some((model, dx)) = self.model_or_nan(u) else {
            return bad();
        };
        let inn = &*self.inner;
        let robust = self.robust;
        let n = inn.data.len();
        let np = inn.proto.num_params();
        let g = inn.data.geometry();
        let cap = chunk_cap(n);
        let maxcols = inn.cols.iter().map(Vec::len).max().unwrap_or(0);
        let parts: Vec<(Vec<f64>, Vec<f64>, f64)> = chunks(n)
            .map_init(
                || Scratch {
                    s: vec![0.0; cap],
                    t: vec![0.0; cap],
                    out: vec![Rgb::ZERO; cap],
                    grad: vec![Rgb::ZERO; np * cap],
                    jcol: vec![0.0; maxcols * cap],
                    r: vec![0.0; cap],
                    d: vec![0.0; cap],
                    jtj: vec![0.0; mdim * mdim],
                    jtr: vec![0.0; mdim],
                    cost: 0.0,
                },
                |sc, Range { start: s, end: e }| {
                    // This chunk's own sums (added up in chunk order below).
                    sc.jtj.fill(0.0);
                    sc.jtr.fill(0.0);
                    sc.cost = 0.0;
                    let len = e - s;
                    model.eval_grad_batch(
                        &g.slice(s..e),
                        &mut sc.out[..len],
                        &mut sc.grad[..np * len],
                    );
                    dispatch(&mut ChunkSums {
                        inn,
                        robust,
                        dx: &dx,
                        mdim,
                        cos_i: &g.wi_z[s..e],
                        start: s,
                        sc,
                    });
                    (sc.jtj.clone(), sc.jtr.clone(), sc.cost)
                },
            )
            .collect();
        let (mut jtj, jtr, mut cost) = sum_chunks(&parts, mdim);
        let mut jtr = jtr;
        if let Some(pen) = &self.penalty {
            cost += pen.add_normal_eq(
                model.as_ref(),
                &inn.free,
                &dx,
                &inn.channels,
                &mut jtj,
                &mut jtr,
            );
        }
        let ne = NormalEq { jtj, jtr, cost };
        if !(ne.cost.is_finite()
            && ne.jtr.iter().all(|v| v.is_finite())
            && ne.jtj.iter().all(|v| v.is_finite()))
        {
            return bad();
        }
        *self.cache.lock().expect("cache lock") = Some((u.clone(), ne.clone()));
        ne
    }

    /// The residual vector r(u), channel-major (all cells of the first active channel,
    /// then the next). Dense; for tests and small cell sets. These are the plain
    /// residuals, whatever the robust function (whose cost is not ½‖r‖²).
    pub fn residuals(&self, u: &DVector<f64>) -> Result<DVector<f64>, FitError> {
        let m = self.model_at(u)?;
        let inn = &*self.inner;
        let n = inn.data.len();
        let g = inn.data.geometry();
        let mut out = vec![Rgb::ZERO; n];
        m.eval_batch(&g.as_slice(), &mut out);
        let scale = inn.scales();
        let mut r = DVector::zeros(n * inn.channels.len());
        let mut tg = vec![0.0; n];
        for (ci, &c) in inn.channels.iter().enumerate() {
            let tg = inn.target_of(c, 0, &mut tg);
            for k in 0..n {
                r[ci * n + k] = scale[k] * (inn.loss.transform(out[k][c], g.wi_z[k]) - tg[k]);
            }
        }
        Ok(r)
    }

    /// The Jacobian ∂r/∂u (rows as in [`residuals`](Self::residuals)). Dense; for tests,
    /// small cell sets and argmin's dense Gauss-Newton.
    pub fn jacobian_dense(&self, u: &DVector<f64>) -> Result<DMatrix<f64>, FitError> {
        let m = self.model_at(u)?;
        let (_, dx) = self.params_at(u);
        let inn = &*self.inner;
        let n = inn.data.len();
        let np = inn.proto.num_params();
        let g = inn.data.geometry();
        let mut out = vec![Rgb::ZERO; n];
        let mut grad = vec![Rgb::ZERO; np * n];
        m.eval_grad_batch(&g.as_slice(), &mut out, &mut grad);
        let scale = inn.scales();
        let mut j = DMatrix::zeros(n * inn.channels.len(), self.dim());
        for (ci, &c) in inn.channels.iter().enumerate() {
            for k in 0..n {
                let (_, dt) = inn.loss.transform_deriv(out[k][c], g.wi_z[k]);
                for q in 0..self.dim() {
                    let p = inn.free[q];
                    j[(ci * n + k, q)] = scale[k] * dt * grad[p * n + k][c] * dx[q];
                }
            }
        }
        Ok(j)
    }
}

impl NormalEquations for FitProblem<'_> {
    fn normal_equations(&self, u: &DVector<f64>) -> Result<NormalEq, ArgminError> {
        Ok(self.normal_eq(u))
    }
    fn cost_floor(&self) -> f64 {
        // A perfect fit leaves residuals of the order of the round-off of t itself,
        // ~1e-16 of the targets' RMS; the floor is (1e-14 · RMS)², a hundred times that.
        0.5 * self.inner.target_ms() * 1e-28
    }
    fn at_bound(&self, q: usize, u: f64) -> bool {
        self.inner
            .transforms
            .get(q)
            .is_some_and(|t| t.end_at(u).is_some())
    }
}

/// One chunk's sums of the normal equations (JᵀJ's lower triangle, Jᵀr, cost) from its
/// model values and gradients in `sc`: the loss transform, the scaled residuals and
/// Jacobian columns and their dot products. Run through [`dispatch`] so the loops take
/// the widest vector instructions (the baseline build gives them two lanes); the same
/// operations in the same order, so the same bits.
struct ChunkSums<'a, 'b> {
    inn: &'a Inner<'b>,
    robust: Option<Robust>,
    dx: &'a [f64],
    mdim: usize,
    cos_i: &'a [f64],
    start: usize,
    sc: &'a mut Scratch,
}

impl Run for ChunkSums<'_, '_> {
    #[inline(always)]
    fn run(&mut self) {
        let (inn, robust, dx, mdim) = (self.inn, self.robust, self.dx, self.mdim);
        let (cos_i, s, sc) = (self.cos_i, self.start, &mut *self.sc);
        let len = cos_i.len();
        let scale = inn.scale_of(s, &mut sc.s[..len]);
        for &c in &inn.channels {
            let tg = inn.target_of(c, s, &mut sc.t[..len]);
            // t and ∂t/∂f of every cell, into r and d.
            for (x, o) in sc.r[..len].iter_mut().zip(&sc.out[..len]) {
                *x = o[c];
            }
            inn.loss
                .transform_deriv_all(cos_i, &mut sc.r[..len], &mut sc.d[..len]);
            match robust {
                None => {
                    for k in 0..len {
                        sc.r[k] = scale[k] * (sc.r[k] - tg[k]);
                        sc.d[k] *= scale[k];
                    }
                }
                Some(rb) => {
                    // IRLS (module doc): √ρ'(e²) on the residual and its
                    // Jacobian row; the cost takes ρ itself.
                    let mut part = 0.0;
                    for k in 0..len {
                        let (t, dt) = (sc.r[k], sc.d[k]);
                        let e = t - tg[k];
                        let (rho, w) = rb.rho(e * e);
                        let sw = scale[k] * w.sqrt();
                        sc.r[k] = sw * e;
                        sc.d[k] = sw * dt;
                        part += scale[k] * scale[k] * rho;
                    }
                    sc.cost += 0.5 * part;
                }
            }
            let cols = &inn.cols[c];
            for (a, &q) in cols.iter().enumerate() {
                let p = inn.free[q];
                let dxq = dx[q];
                let gp = &sc.grad[p * len..(p + 1) * len];
                let col = &mut sc.jcol[a * len..(a + 1) * len];
                for k in 0..len {
                    col[k] = sc.d[k] * gp[k][c] * dxq;
                }
            }
            for (a, &qa) in cols.iter().enumerate() {
                let ca = &sc.jcol[a * len..(a + 1) * len];
                sc.jtr[qa] += dot(ca, &sc.r[..len]);
                for (b, &qb) in cols.iter().enumerate().take(a + 1) {
                    let cb = &sc.jcol[b * len..(b + 1) * len];
                    sc.jtj[qa * mdim + qb] += dot(ca, cb);
                }
            }
            if robust.is_none() {
                sc.cost += 0.5 * dot(&sc.r[..len], &sc.r[..len]);
            }
        }
    }
}

/// An argmin problem trait on [`FitProblem`], forwarding to the inherent method that
/// computes it: `Trait, AssociatedType = Value, method(problem, u) => body`.
macro_rules! argmin_trait {
    ($tr:ident, $assoc:ident = $out:ty, $f:ident($p:ident, $u:ident) => $body:expr) => {
        impl $tr for FitProblem<'_> {
            type Param = DVector<f64>;
            type $assoc = $out;
            fn $f(&self, $u: &DVector<f64>) -> Result<$out, ArgminError> {
                let $p = self;
                $body
            }
        }
    };
}

argmin_trait!(CostFunction, Output = f64, cost(p, u) => Ok(p.cost_at(u)));
argmin_trait!(Gradient, Gradient = DVector<f64>, gradient(p, u) => Ok(p.normal_eq(u).jtr));
// The Gauss-Newton approximation JᵀJ.
argmin_trait!(Hessian, Hessian = DMatrix<f64>, hessian(p, u) => Ok(p.normal_eq(u).jtj));
// The dense residuals and Jacobian count as a cost and a Jacobian evaluation.
argmin_trait!(Operator, Output = DVector<f64>, apply(p, u) => {
    p.cost_evals.fetch_add(1, Ordering::Relaxed);
    Ok(p.residuals(u)?)
});
argmin_trait!(Jacobian, Jacobian = DMatrix<f64>, jacobian(p, u) => {
    p.jac_evals.fetch_add(1, Ordering::Relaxed);
    Ok(p.jacobian_dense(u)?)
});

/// The normal equations from per-chunk partials (JᵀJ's lower triangle row-major, Jᵀr,
/// cost), added in chunk order: the same sums, to the bit, whatever the number of
/// threads and however rayon split the work (a fold's per-split partials are grouped
/// by work stealing, so their round-off varied from run to run, and a long fit could
/// end elsewhere). Only the lower triangle was accumulated (column lists increase in
/// q, so qb ≤ qa): it is mirrored.
fn sum_chunks(
    parts: &[(Vec<f64>, Vec<f64>, f64)],
    mdim: usize,
) -> (DMatrix<f64>, DVector<f64>, f64) {
    let (mut jtj_l, mut jtr, mut cost) = (vec![0.0; mdim * mdim], vec![0.0; mdim], 0.0);
    for (a, b, c) in parts {
        for (x, y) in jtj_l.iter_mut().zip(a) {
            *x += y;
        }
        for (x, y) in jtr.iter_mut().zip(b) {
            *x += y;
        }
        cost += c;
    }
    let mut jtj = DMatrix::zeros(mdim, mdim);
    for a in 0..mdim {
        for b in 0..mdim {
            let v = jtj_l[a * mdim + b];
            if v != 0.0 {
                jtj[(a, b)] += v;
                if a != b {
                    jtj[(b, a)] += v;
                }
            }
        }
    }
    (jtj, DVector::from_vec(jtr), cost)
}

/// Every loss of per-channel models against a cell set: channel c is evaluated with
/// `models[c]` (pass the same model three times for a shared fit). All eight losses;
/// [`evaluate_losses_of`] chooses.
pub fn evaluate_losses(
    models: [&dyn Model; 3],
    data: &FitData,
    weighting: Weighting,
) -> crate::loss::LossReport {
    evaluate_losses_of(models, data, weighting, LossSet::All)
}

/// Σ w r² per own loss and channel; with the published metrics, Σ w g r² per metric
/// and channel and Σ w g per metric.
type Sums = ([[f64; 3]; 4], [[f64; 3]; 4], [f64; 4]);

/// Per-task buffers of [`evaluate_losses_of`], one chunk long; those a report may not
/// need (a second channel model's values, the cube roots, the weights) grow on first use.
struct LossScratch {
    out: [Vec<Rgb>; 2],
    /// One channel's model values.
    xm: Vec<f64>,
    /// Cube roots of the measurement's x (when not stored).
    tt: Vec<f64>,
    /// The weights, when not the stored measures ([`weights_of`]).
    wb: Vec<f64>,
    gb: Vec<[f64; 4]>,
    own: OwnLossScratch,
}

/// The losses of `set` (brdfkit's own four, or all eight) of per-channel models
/// against a cell set, in one pass over the cells; the measured side of the cbrt loss
/// comes from [`FitData::cbrt_targets`] when they are built (by [`crate::prepare`],
/// once per table for several families), else is formed per chunk (same bits). Of a
/// table's geometry only the columns read are computed: cos θi (the losses), cos θo
/// (the published metrics) and the models' own ([`Model::geometry_columns`]).
pub fn evaluate_losses_of(
    models: [&dyn Model; 3],
    data: &FitData,
    weighting: Weighting,
    set: LossSet,
) -> crate::loss::LossReport {
    let n = data.len();
    // Weights per chunk, not a full-length array (8 bytes a cell); the sum in cell
    // order as before.
    let wsum = data.weight_sum(weighting);
    let roots = data.cbrt_targets_if_built();
    let cap = chunk_cap(n);
    let published = set == LossSet::All;
    let read = models.iter().fold(Columns::WI_Z | Columns::WO_Z, |c, m| {
        c | m.geometry_columns()
    });
    let parts: Vec<Sums> = chunks(n)
        .map_init(
            || {
                let sc = LossScratch {
                    out: [vec![Rgb::ZERO; cap], Vec::new()],
                    xm: vec![0.0; cap],
                    tt: Vec::new(),
                    wb: Vec::new(),
                    gb: vec![[0.0; 4]; if published { cap } else { 0 }],
                    own: OwnLossScratch::default(),
                };
                // A table's chunk geometry ([`FitData::columns_of`]).
                (sc, ChunkGeometry::default())
            },
            |(sc, geom), r| {
                let gs = data.columns_of(r.clone(), read, geom);
                let cells = ChunkCells {
                    data,
                    roots,
                    weighting,
                    r,
                    gs,
                };
                chunk_losses(models, cells, published, sc)
            },
        )
        .collect();
    // In chunk order: the same report whatever the threads.
    let mut sums = [[0.0f64; 3]; 4];
    let mut psums = [[0.0f64; 3]; 4];
    let mut pw = [0.0f64; 4];
    for (p, q, w) in &parts {
        for l in 0..4 {
            for c in 0..3 {
                sums[l][c] += p[l][c];
                psums[l][c] += q[l][c];
            }
            pw[l] += w[l];
        }
    }
    crate::loss::LossReport::from_own_sums(sums, wsum, published.then_some((psums, pw)), n)
}

/// One chunk of [`evaluate_losses_of`]: the cells `r` and their geometry `gs`.
struct ChunkCells<'a> {
    data: &'a FitData,
    roots: Option<&'a [Vec<f64>; 3]>,
    weighting: Weighting,
    r: Range<usize>,
    gs: brdfkit_core::GeomSlice<'a>,
}

/// The sums of [`evaluate_losses_of`] over one chunk.
fn chunk_losses(
    models: [&dyn Model; 3],
    cells: ChunkCells<'_>,
    published: bool,
    sc: &mut LossScratch,
) -> Sums {
    let ChunkCells {
        data,
        roots,
        weighting,
        r,
        gs,
    } = cells;
    let same = std::ptr::addr_eq(models[0], models[1]) && std::ptr::addr_eq(models[1], models[2]);
    let len = r.len();
    let mut acc = [[0.0f64; 3]; 4];
    let mut pacc = [[0.0f64; 3]; 4];
    let mut pw = [0.0f64; 4];
    let wb = weights_of(data, weighting, r.clone(), &mut sc.wb);
    if published {
        for (k, &x) in wb.iter().enumerate() {
            for (l, loss) in crate::Loss::PUBLISHED.into_iter().enumerate() {
                sc.gb[k][l] = x * loss.cell_factor(gs.wi_z[k], gs.wo_z[k]);
                pw[l] += sc.gb[k][l];
            }
        }
    }
    let [out0, out1] = &mut sc.out;
    models[0].eval_batch(&gs, &mut out0[..len]);
    for c in 0..3 {
        let vals: &[Rgb] = if same || c == 0 {
            &out0[..len]
        } else {
            let out1 = grown(out1, len, Rgb::ZERO);
            models[c].eval_batch(&gs, out1);
            out1
        };
        let fm = &data.values()[c][r.clone()];
        let ci = &gs.wi_z[..len];
        let xm = &mut sc.xm[..len];
        for (x, v) in xm.iter_mut().zip(vals) {
            *x = v[c];
        }
        let rt: &[f64] = match roots {
            Some(roots) => &roots[c][r.clone()],
            None => {
                let tt = grown(&mut sc.tt, len, 0.0);
                tt.copy_from_slice(fm);
                crate::Loss::Cbrt.transform_all(ci, tt);
                tt
            }
        };
        let own = OwnLossCells {
            w: wb,
            model: xm,
            measured: fm,
            cos_i: ci,
            roots: rt,
        };
        let s = own_loss_sums(own, &mut sc.own, published);
        for l in 0..4 {
            acc[l][c] = s[l];
        }
        if published {
            for k in 0..len {
                // Ngan and Löw E1 on the cosine residual, Löw E2 and Bieron-Peers on
                // the log one (`Loss::base`).
                let (e, d) = (sc.own.cosine[k], sc.own.log[k]);
                let [g0, g1, g2, g3] = sc.gb[k];
                pacc[0][c] += g0 * e * e;
                pacc[1][c] += g1 * e * e;
                pacc[2][c] += g2 * d * d;
                pacc[3][c] += g3 * d * d;
            }
        }
    }
    (acc, pacc, pw)
}

/// The weights of the cells `r` ([`FitData::fill_weights`]'s): a table's or a cut's
/// cells under solid-angle weighting (multiplicity 1) weigh their stored measures, which
/// are borrowed rather than copied (a chunk's copy was ~4 % of a Lambert report);
/// others are filled into `buf`.
fn weights_of<'a>(
    data: &'a FitData,
    weighting: Weighting,
    r: Range<usize>,
    buf: &'a mut Vec<f64>,
) -> &'a [f64] {
    match (data.multiplicity_if_any(), weighting) {
        (None, Weighting::SolidAngle) => &data.measure()[r],
        _ => {
            let out = grown(buf, r.len(), 0.0);
            data.fill_weights(weighting, r.start, out);
            out
        }
    }
}

/// The first `len` entries of `buf`, grown to hold them (a scratch allocated when a
/// pass first needs it).
fn grown<T: Clone>(buf: &mut Vec<T>, len: usize, zero: T) -> &mut [T] {
    if buf.len() < len {
        buf.resize(len, zero);
    }
    &mut buf[..len]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::{Coverage, synth_data};

    /// The report's weights are `fill_weights`' bits, chunk by chunk, for a table's
    /// cells (borrowed measures under solid-angle weighting) and for a subsample
    /// (multiplicities), under both weightings, through one reused buffer.
    #[test]
    fn report_weights_are_the_filled_weights() {
        let m = brdfkit_models::default_model("lambert").unwrap();
        let dims = brdfkit_merl::Dims::new(16, 16, 32).unwrap();
        let full = synth_data(m.as_ref(), dims, Coverage::AboveHorizon).unwrap();
        let sub = full.stratified_subsample(0.3, 7);
        assert!(full.multiplicity_if_any().is_none() && sub.multiplicity_if_any().is_some());
        let mut buf = Vec::new();
        for data in [&full, &sub] {
            for w in [Weighting::SolidAngle, Weighting::Uniform] {
                for r in [
                    0..data.len(),
                    0..1,
                    3..data.len() / 2,
                    data.len() - 1..data.len(),
                ] {
                    let mut want = vec![f64::NAN; r.len()];
                    data.fill_weights(w, r.start, &mut want);
                    let got = weights_of(data, w, r.clone(), &mut buf);
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(got), bits(&want), "{w:?} {r:?}");
                }
            }
        }
    }
}
