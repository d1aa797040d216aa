//! One pass of a fit (the three channels of a shared fit, or one channel), as the
//! staged strategy of `docs/fitting.md`: every start **explores** (on the exploration
//! set, or warms up when there is none), the starts are **ranked**, the finishers
//! **warm up** on the warm-up set, then **finish** on all fitted cells (an automatic
//! robust scale adds a **robust** stage). Each stage is one function below; [`run_pass`]
//! strings them together and [`start_records`] says what became of every start.

use super::cells::CellSets;
use super::solve::{Outcome, SubStage, Where, run_on, run_start, sub_stage, sub_stage_on};
use super::timing::StageTimes;
use crate::config::FitConfig;
use crate::energy::{AlbedoPenalty, AlbedoQuadrature, PENALTY_WEIGHT};
use crate::error::FitError;
use crate::lm::SUBSAMPLE_STOP;
use crate::loss::{Robust, RobustKind};
use crate::problem::FitProblem;
use crate::record::{StartRecord, WarmUpRecord};
use crate::reparam::Transform;
use crate::starts::start_points;
use brdfkit_core::Model;
use brdfkit_core::progress::{Event, Observe, StartDone};
use nalgebra::DVector;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// What a pass leaves for the fit's record.
pub(super) struct PassResult {
    pub(super) model: Box<dyn Model>,
    pub(super) free: Vec<usize>,
    pub(super) starts: Vec<StartRecord>,
    pub(super) best: Outcome,
    pub(super) transforms: Vec<Transform>,
    /// The robust scale of the pass and, with an automatic scale, the plain stage's
    /// best loss.
    pub(super) robust: Option<(f64, Option<f64>)>,
    /// The pass's channel (a per-channel pass) or `None` (all three).
    pub(super) channel: Option<usize>,
    /// The kept start's cost over the fitted cells is left to the fit's loss report
    /// (see [`defers_cost`]): `best.cost` and its record's `final_loss` are filled in
    /// there.
    pub(super) deferred: bool,
}

/// A start after its subsample stages: where it got to, the stages' records and, when
/// the starts are ranked, the optimised cost (on the warm-up set after a separate
/// exploration, else on all fitted cells) where its exploration ended.
#[derive(Clone)]
struct Explored {
    u: DVector<f64>,
    explore: Option<WarmUpRecord>,
    warm: Option<WarmUpRecord>,
    rank_cost: Option<f64>,
    /// Its exploration, when it stopped at the ranking tolerance ([`RANKING_FTOL`]): a
    /// finisher goes on from there on the exploration set first ([`Pass::settle`]).
    stopped: Option<SubStage>,
    /// Not run: its start point is that of this earlier start, which ran.
    same_as: Option<usize>,
}

/// Relative cost decrease below which a start's exploration stops when it only needs a
/// rank (Levenberg-Marquardt's two ftol rules at this tolerance, see
/// [`crate::LevenbergMarquardt::stopping_early`]): the ranking cost is the warm-up
/// set's at the exploration's end point, which differs from the exploration set's own
/// optimum by the subsample's error (median 1.3 % of the loss over the database's
/// explorations), so the last decades of the cost's convergence there do not make an
/// order. The finishers then go on from where they stopped exactly as an uninterrupted
/// run would ([`Pass::settle`]; docs/fitting.md, "Explore, rank, finish").
pub(super) const RANKING_FTOL: f64 = 1e-5;

/// The share of a subsample's sampling excess below which a run on the warm-up set
/// stops (see [`warm_up_ftol`]).
pub(super) const WARM_UP_FTOL_SHARE: f64 = 0.01;

/// The relative cost decrease below which a run on the warm-up set stops: the config's
/// ftol, or [`WARM_UP_FTOL_SHARE`] of p / m when that is looser, for p free parameters
/// and m residuals on the set.
///
/// Why p / m: the warm-up set is a sample of the fitted cells, and the optimum of a
/// least-squares fit to m observations with p parameters lies, on the population it was
/// drawn from, above the population's optimum by ≈ p / m of the cost (the excess in
/// Akaike's final prediction error, FPE = σ² (m + p) / (m − p): H. Akaike, "Statistical
/// predictor identification", Ann. Inst. Statist. Math. 22, 1970). A step that lowers
/// the warm-up set's cost by far less than that moves the point by less than the
/// sample can resolve: the loss over all cells, where the warm-up optimum is evaluated
/// (`full_iters` 0) or from where the finish goes on, does not see it. On measured
/// tables the warm-up's last steps are Gauss-Newton's linear convergence (gain ratio
/// ≈ 1.9, μ → 0: the residuals' second-order term, which Gauss-Newton drops, is
/// comparable to JᵀJ), each lowering the cost by ≈ 0.8 of the one before; the run
/// stops where the remaining decrease of that steady tail is estimated below ε
/// ([`crate::LevenbergMarquardt::subsample_tolerance`]): 1 % of the sampling excess. With 65,536 cells and three channels, ε = 1.5e-7 (Lambert, p = 3)
/// to 8.7e-7 (two-lobe Cook-Torrance, p = 17) against the fit's ftol 1e-10.
pub(super) fn warm_up_ftol(config: &FitConfig, params: usize, residuals: usize) -> f64 {
    let share = WARM_UP_FTOL_SHARE * params as f64 / residuals.max(1) as f64;
    config.get_tolerances().ftol.max(share)
}

/// Floor of the automatic robust scale, relative to the targets' RMS: a plain fit that
/// is exact (median |e| = 0) would otherwise give c = 0. Any c gives the same optimum
/// there (no residual is an outlier).
const ROBUST_SCALE_FLOOR: f64 = 1e-9;

/// Everything the stages of one pass share: the problems on each cell set (with the
/// albedo penalty and a given robust scale), the starts, the settings.
struct Pass<'a> {
    config: &'a FitConfig,
    observer: Option<&'a Arc<dyn Observe>>,
    channel: Option<usize>,
    points: Vec<Vec<f64>>,
    ranked: bool,
    /// A given robust loss (applies from the start); an automatic one is `auto`.
    given: Option<Robust>,
    auto: bool,
    penalty: bool,
    /// All fitted cells, plain (the automatic robust stage starts from it).
    plain: FitProblem<'a>,
    /// All fitted cells with the given robust loss, if any: the finish's problem.
    full: FitProblem<'a>,
    warm: Option<FitProblem<'a>>,
    /// The config of the runs on the warm-up set: with [`warm_up_ftol`]'s tolerance.
    warm_cfg: FitConfig,
    explore: Option<FitProblem<'a>>,
    /// Per start: the earlier start with the same point, if any (see [`same_starts`]).
    same_as: Vec<Option<usize>>,
    /// The early ftol of the explorations: [`RANKING_FTOL`] when there is a ranking to
    /// make (see [`Pass::ranks`]).
    early: Option<f64>,
}

/// For each start, the first earlier start whose point is the same, bit for bit: a
/// family without a free shape parameter (Lambert) has nothing to spread its starts
/// over, and every start is start 0. One run per point is enough: the others would
/// repeat it step for step.
fn same_starts(points: &[Vec<f64>]) -> Vec<Option<usize>> {
    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    (0..points.len())
        .map(|k| (0..k).find(|&j| bits(&points[j]) == bits(&points[k])))
        .collect()
}

/// The problem of one pass on the cells `d`: `model`, its free parameters and channels,
/// the config's loss and weighting, and the albedo penalty.
fn problem_on<'d>(
    d: &'d FitData,
    model: &dyn Model,
    free: &[usize],
    channels: &[usize],
    config: &FitConfig,
    penalty: &Option<Arc<AlbedoPenalty>>,
) -> Result<FitProblem<'d>, FitError> {
    let p = FitProblem::new(
        d,
        model,
        free.to_vec(),
        channels.to_vec(),
        config.loss,
        config.weighting,
    )?;
    Ok(p.with_penalty(penalty.clone()))
}

use crate::data::FitData;

impl<'a> Pass<'a> {
    /// The problems of a pass on `cells` (cell preparation: scales, targets).
    fn new(
        cells: &CellSets<'a>,
        model: &dyn Model,
        free: &[usize],
        channels: &[usize],
        config: &'a FitConfig,
        observer: Option<&'a Arc<dyn Observe>>,
    ) -> Result<Pass<'a>, FitError> {
        let plain = problem_on(cells.fit, model, free, channels, config, &None)?;
        // Energy conservation: the albedo penalty on every stage's problem (λ relative
        // to the full set's targets, so the stages share it).
        let penalty = config.albedo_max.map(|a| {
            Arc::new(AlbedoPenalty {
                quad: AlbedoQuadrature::new(),
                max: a,
                lambda: PENALTY_WEIGHT * plain.target_rms().powi(2),
            })
        });
        let plain = plain.with_penalty(penalty.clone());
        // A given robust scale applies from the start (subsamples included); an
        // automatic one needs a plain fit first (see `FitConfig::robust`).
        let given = match (config.robust, config.robust_scale) {
            (RobustKind::None, _) | (_, None) => None,
            (kind, Some(scale)) => Some(Robust { kind, scale }),
        };
        let robust = |p: FitProblem<'a>| match given {
            Some(r) => p.with_robust(r),
            None => p,
        };
        let sub = |d: Option<&'a FitData>| {
            d.map(|d| problem_on(d, model, free, channels, config, &penalty).map(robust))
                .transpose()
        };
        let points = start_points(
            &model.param_specs(),
            &model.params(),
            free,
            config.starts,
            config.seed,
        );
        let same_as = same_starts(&points);
        let distinct = same_as.iter().filter(|s| s.is_none()).count();
        let warm = sub(cells.warm)?;
        let mut warm_cfg = config.clone();
        if let Some(w) = &warm {
            warm_cfg.subsample_ftol = Some(warm_up_ftol(config, free.len(), w.num_residuals()));
        }
        Ok(Pass {
            early: (cells.ranked && distinct > config.finish).then_some(RANKING_FTOL),
            same_as,
            config,
            observer,
            channel: (channels.len() == 1).then(|| channels[0]),
            ranked: cells.ranked,
            given,
            auto: config.robust != RobustKind::None && config.robust_scale.is_none(),
            penalty: penalty.is_some(),
            full: robust(plain.clone()),
            plain,
            warm,
            warm_cfg,
            explore: sub(cells.explore)?,
            points,
        })
    }

    /// Reports a finished start to the observer.
    fn done(&self, k: usize, o: &Result<Outcome, FitError>) {
        if let (Some(obs), Ok(o)) = (self.observer, o) {
            obs.observe(&Event::StartDone(StartDone {
                start: k,
                channel: self.channel,
                loss: (2.0 * o.cost).sqrt(),
                iterations: o.iterations,
                termination: o.termination.clone(),
            }));
        }
    }

    /// After a separate exploration the starts are ranked on the warm-up set (a cost
    /// pass over 65,536 cells instead of all fitted cells: the same order on every
    /// measured table tried, at a sixteenth of the cost); without one, on the fitted
    /// cells.
    fn rank_on_warm(&self) -> bool {
        self.explore.is_some() && self.warm.is_some()
    }

    /// Whether there is a ranking to make: a ranked pass with more different starts
    /// than finishers. Otherwise no start needs a ranking cost pass.
    fn ranks(&self) -> bool {
        self.early.is_some()
    }

    /// The set every start explores first, with the config of its runs: the
    /// exploration set, or the warm-up set when there is none.
    fn first(&self) -> Option<(&FitProblem<'a>, &FitConfig)> {
        match (&self.explore, &self.warm) {
            (Some(p), _) => Some((p, self.config)),
            (None, Some(p)) => Some((p, &self.warm_cfg)),
            (None, None) => None,
        }
    }

    /// The record of a sub-stage on `p` run with `cfg`; a stop on an ftol rule at the
    /// warm-up set's tolerance says which ([`warm_up_ftol`]).
    fn record_of(&self, st: &SubStage, p: &FitProblem<'_>, cfg: &FitConfig) -> WarmUpRecord {
        let mut rec = st.record(p);
        if let Some(e) = cfg.subsample_ftol
            && rec.termination.contains(SUBSAMPLE_STOP)
        {
            rec.termination += &format!(" (ftol {e:.1e})");
        }
        rec
    }

    /// Who start k's runs on a subsample are.
    fn at(&self, k: usize) -> Where<'a> {
        Where {
            observer: self.observer,
            start: k,
            channel: self.channel,
            warm_up: true,
        }
    }

    /// Stage 1, every start in parallel (a start whose point an earlier start has is
    /// not run: it is recorded as that start's). Unranked: its warm-up. Ranked: it
    /// converges on the exploration set (restarted while it hits the iteration cap, see
    /// [`sub_stage`]; to the ranking tolerance when there is a ranking to make, see
    /// [`RANKING_FTOL`]), and the optimised cost where it ended is its rank (a fresh
    /// clone of the problem, so the pass is counted for this start).
    fn explore(&self) -> Vec<Result<Explored, FitError>> {
        let first = self.first();
        let ranks = self.ranks();
        self.points
            .par_iter()
            .enumerate()
            .map(|(k, x)| {
                if let Some(j) = self.same_as[k] {
                    return Ok(Explored {
                        u: self.full.to_u(x),
                        explore: None,
                        warm: None,
                        rank_cost: None,
                        stopped: None,
                        same_as: Some(j),
                    });
                }
                let u0 = self.full.to_u(x);
                let (u, rec, stopped) = match first {
                    Some((p, cfg)) => {
                        let st = sub_stage(p, u0, cfg, self.at(k), self.ranked, self.early)?;
                        let mut rec = self.record_of(&st, p, cfg);
                        let stopped = st.w.early.is_some().then(|| st.clone());
                        if stopped.is_some() {
                            rec.termination += &format!(" (ftol {RANKING_FTOL:e})");
                        }
                        (st.w.u, Some(rec), stopped)
                    }
                    None => (u0, None, None),
                };
                let rank_cost = ranks.then(|| match (&self.warm, self.rank_on_warm()) {
                    (Some(wp), true) => wp.clone().cost_at(&u),
                    _ => self.full.clone().cost_at(&u),
                });
                // With a separate exploration set the start has not warmed up yet.
                let (explore, warm) = match self.explore {
                    Some(_) => (rec, None),
                    None => (None, rec),
                };
                Ok(Explored {
                    u,
                    explore,
                    warm,
                    rank_cost,
                    stopped,
                    same_as: None,
                })
            })
            .collect()
    }

    /// Ranking: finite costs first, lowest first; ties and non-finite costs in start
    /// order. Starts whose exploration failed are never finished (their error is
    /// recorded). Returns the finishers and each start's rank; the observer hears of
    /// the starts ranked out.
    fn rank(&self, explored: &[Result<Explored, FitError>]) -> (Vec<usize>, Vec<Option<usize>>) {
        let n = explored.len();
        let rank_key = |k: usize| match &explored[k] {
            Ok(e) => e
                .rank_cost
                .filter(|c| c.is_finite())
                .unwrap_or(f64::INFINITY),
            Err(_) => f64::NAN,
        };
        let ran = |k: usize| explored[k].as_ref().is_ok_and(|e| e.same_as.is_none());
        let mut order: Vec<usize> = (0..n).filter(|&k| ran(k)).collect();
        if self.ranked {
            order.sort_by(|&a, &b| rank_key(a).total_cmp(&rank_key(b)).then(a.cmp(&b)));
        }
        let mut rank_of = vec![None; n];
        for (pos, &k) in order.iter().enumerate() {
            rank_of[k] = Some(pos);
        }
        if self.ranked {
            order.truncate(self.config.finish);
        }
        if let Some(obs) = self.observer {
            for k in (0..n).filter(|k| !order.contains(k)) {
                if let Ok(e) = &explored[k] {
                    let termination = match e.same_as {
                        Some(j) => same_start_words(self, j),
                        None => "not finished (ranked out after its exploration)".into(),
                    };
                    obs.observe(&Event::StartDone(StartDone {
                        start: k,
                        channel: self.channel,
                        loss: (2.0 * e.rank_cost.unwrap_or(f64::NAN)).sqrt(),
                        iterations: 0,
                        termination,
                    }));
                }
            }
        }
        (order, rank_of)
    }

    /// Stage 1b: a finisher whose exploration stopped at the ranking tolerance goes on
    /// converging on the same set with the fit's own tolerances (restarted like an
    /// exploration), so it leaves for the warm-up from the exploration set's optimum,
    /// as every start did before [`RANKING_FTOL`]: a slow tail (a lobe creeping to a
    /// bound) is paid on the small set, not on the warm-up set. Its exploration record
    /// counts both runs. Returns the finishers' states, in `finishers`' order.
    fn settle(
        &self,
        finishers: &[usize],
        explored: &[Result<Explored, FitError>],
    ) -> Vec<Result<Explored, FitError>> {
        let first = self.first();
        finishers
            .par_iter()
            .map(|&k| {
                let e = explored[k].as_ref().expect("finishers explored fine");
                let (Some((p, cfg)), Some(st)) = (first, &e.stopped) else {
                    return Ok(e.clone());
                };
                let st = sub_stage_on(p, st.clone(), cfg, self.at(k), true)?;
                let rec = Some(self.record_of(&st, p, cfg));
                let sep = self.explore.is_some();
                Ok(Explored {
                    u: st.w.u,
                    explore: if sep { rec.clone() } else { None },
                    warm: if sep { None } else { rec },
                    stopped: None,
                    ..e.clone()
                })
            })
            .collect()
    }

    /// Stage 2a: after a separate exploration, the finishers warm up from where they
    /// got to (`settled`, in `finishers`' order), restarted with fresh damping while a
    /// run hits the iteration cap and still improves ([`sub_stage`]). A warm-up that
    /// converges within the cap is unchanged by this; one that does not used to end
    /// "maximum iterations reached" with LM's damping grown and its steps shrunk
    /// (plausible-Phong on MERL's steel, n ≈ 1,200: linear convergence along the
    /// valley where n and ρs trade off).
    fn warm_up(
        &self,
        finishers: &[usize],
        settled: Vec<Result<Explored, FitError>>,
    ) -> Vec<Result<Explored, FitError>> {
        finishers
            .par_iter()
            .zip(settled)
            .map(|(&k, e)| {
                let e = e?;
                match (&self.warm, e.warm.is_none() && e.explore.is_some()) {
                    (Some(wp), true) => {
                        let cfg = &self.warm_cfg;
                        let st = sub_stage(wp, e.u.clone(), cfg, self.at(k), true, None)?;
                        Ok(Explored {
                            warm: Some(self.record_of(&st, wp, cfg)),
                            u: st.w.u,
                            ..e
                        })
                    }
                    _ => Ok(e),
                }
            })
            .collect()
    }
}

/// Why a start whose point start `j` has did not run (see [`same_starts`]).
fn same_start_words(pass: &Pass<'_>, j: usize) -> String {
    let why = if pass.same_as.iter().skip(1).all(|&s| s == Some(0)) {
        " (no free shape parameter to spread the starts over)"
    } else {
        ""
    };
    format!("not run: the same start point as start {j}, which ran{why}")
}

/// Whether the kept start's cost over the fitted cells is left to the fit's loss
/// report: one finisher whose warm-up optimum is only evaluated (`full_iters` 0) under
/// the plain loss. Its cost, ½ loss², is what the report sums anyway (the same terms in
/// another order), so that pass over all cells is not paid twice.
fn defers_cost(pass: &Pass<'_>, full_iters: Option<u64>, finishers: usize) -> bool {
    full_iters == Some(0) && finishers == 1 && pass.given.is_none() && !pass.auto && !pass.penalty
}

type Finished = Vec<(usize, Result<Outcome, FitError>)>;

impl Pass<'_> {
    /// Stage 2b: the finishers continue on all fitted cells, in parallel. A start that
    /// warmed up takes at most `full_iters` iterations here (see
    /// `FitConfig::full_iters`); 0: its warm-up optimum is only evaluated (one cost
    /// pass, or none when `defer`).
    fn finish(
        &self,
        finishers: &[usize],
        warmed: Vec<Result<Explored, FitError>>,
        full_iters: Option<u64>,
        defer: bool,
    ) -> Finished {
        let config = self.config;
        let capped_cfg = match full_iters {
            Some(n) if n > 0 => config
                .clone()
                .max_iters(n)
                .unwrap_or_else(|_| config.clone()),
            _ => config.clone(),
        };
        let rank_on_warm = self.rank_on_warm();
        finishers
            .par_iter()
            .zip(warmed)
            .map(|(&k, e)| {
                let e = match e {
                    Ok(e) => e,
                    Err(err) => return (k, Err(err)),
                };
                let o = match (&e.warm, full_iters) {
                    (Some(w), Some(0)) => Ok(self.evaluate_warm_optimum(&e.u, w, defer)),
                    _ => {
                        let cfg = if e.warm.is_some() {
                            &capped_cfg
                        } else {
                            config
                        };
                        let (obs, ch) = (self.observer, self.channel);
                        run_start(self.full.clone(), e.u.clone(), cfg, obs, k, ch, false)
                    }
                };
                let o = o.map(|mut o| {
                    o.warm = e.warm.clone();
                    o.explore = e.explore.clone();
                    // The ranking pass was a cost pass over the fitted cells too.
                    o.cost_evals += u64::from(e.rank_cost.is_some() && !rank_on_warm);
                    o
                });
                if !self.auto && !defer {
                    self.done(k, &o);
                }
                (k, o)
            })
            .collect()
    }

    /// The warm-up optimum `u`, evaluated on all fitted cells (one cost pass; none when
    /// `defer`: the loss report's pass is this start's cost pass).
    fn evaluate_warm_optimum(&self, u: &DVector<f64>, w: &WarmUpRecord, defer: bool) -> Outcome {
        let probe = self.full.clone();
        let cost = if defer { f64::NAN } else { probe.cost_at(u) };
        Outcome {
            u: u.clone(),
            cost,
            iterations: 0,
            cost_evals: if defer { 1 } else { probe.cost_evals() },
            jac_evals: 0,
            termination: format!(
                "{} on the warm-up set; evaluated on all fitted cells (full_iters 0)",
                w.termination
            ),
            converged: w.termination.starts_with("converged"),
            warm: None,
            explore: None,
            early: None,
        }
    }

    /// The automatic robust stage: the scale from the best plain start (common to every
    /// finished start so their robust costs compare), then every finished start
    /// continues under the robust loss. Returns the scale and the plain best loss.
    fn robust_stage(&self, finished: Finished) -> (Finished, Option<(f64, Option<f64>)>) {
        let plain_best = finished
            .iter()
            .filter_map(|(_, o)| o.as_ref().ok())
            .filter(|o| o.cost.is_finite())
            .min_by(|a, b| a.cost.total_cmp(&b.cost));
        let Some(pb) = plain_best else {
            return (finished, None);
        };
        let floor = ROBUST_SCALE_FLOOR * self.plain.target_rms();
        let med = self.plain.median_abs_residual(&pb.u).unwrap_or(0.0);
        let scale = (self.config.robust.tuning() * 1.4826 * med).max(floor);
        let plain_loss = (2.0 * pb.cost).sqrt();
        let rp = self.plain.with_robust(Robust {
            kind: self.config.robust,
            scale,
        });
        let finished = finished
            .into_par_iter()
            .map(|(k, o1)| {
                let o1 = match o1 {
                    Ok(o) => o,
                    Err(e) => return (k, Err(e)),
                };
                let (obs, ch) = (self.observer, self.channel);
                let o = run_on(&o1, |u| {
                    run_start(rp.clone(), u, self.config, obs, k, ch, false)
                })
                .map(|mut o| {
                    o.warm = o1.warm.clone();
                    o.explore = o1.explore.clone();
                    o
                });
                self.done(k, &o);
                (k, o)
            })
            .collect();
        (finished, Some((scale, Some(plain_loss))))
    }
}

/// The seconds since `t`, told to the observer as stage `name` done.
pub(super) fn stage_done(
    observer: Option<&Arc<dyn Observe>>,
    stage: &'static str,
    channel: Option<usize>,
    t: Instant,
) -> f64 {
    let seconds = t.elapsed().as_secs_f64();
    if let Some(o) = observer {
        o.observe(&Event::StageDone {
            stage,
            channel,
            seconds,
        });
    }
    seconds
}

/// One pass: the stages in order, each timed into `times` and told to the observer.
pub(super) fn run_pass(
    cells: &CellSets<'_>,
    model: &dyn Model,
    free: Vec<usize>,
    channels: Vec<usize>,
    config: &FitConfig,
    observer: Option<&Arc<dyn Observe>>,
    times: &mut StageTimes,
) -> Result<PassResult, FitError> {
    let channel = (channels.len() == 1).then(|| channels[0]);
    let stage = |name, t: Instant, total: &mut f64| {
        *total += stage_done(observer, name, channel, t);
    };
    let t = Instant::now();
    let pass = Pass::new(cells, model, &free, &channels, config, observer)?;
    stage("prepare", t, &mut times.prepare);
    let t = Instant::now();
    let explored = pass.explore();
    let (finishers, rank_of) = pass.rank(&explored);
    let settled = pass.settle(&finishers, &explored);
    stage("explore", t, &mut times.explore);
    let t = Instant::now();
    let warmed = pass.warm_up(&finishers, settled);
    stage("warm-up", t, &mut times.warm_up);
    let t = Instant::now();
    let full_iters = config.full_iters.cap_for(model);
    let defer = defers_cost(&pass, full_iters, finishers.len());
    let mut finished = pass.finish(&finishers, warmed, full_iters, defer);
    let mut robust = pass.given.map(|r| (r.scale, None));
    if pass.auto {
        let (f, r) = pass.robust_stage(finished);
        finished = f;
        robust = r.or(robust);
    }
    stage("finish", t, &mut times.finish);
    let (starts, best) = start_records(&pass, &explored, finished, &rank_of, defer)?;
    Ok(PassResult {
        model: pass.full.model_at(&best.u)?,
        transforms: pass.full.transforms().to_vec(),
        free,
        starts,
        best,
        robust,
        channel: pass.channel,
        deferred: defer,
    })
}

/// The record of every start (kept, finished, ranked out or failed) and the kept
/// start's outcome: the lowest finite cost, the first in start order on ties.
fn start_records(
    pass: &Pass<'_>,
    explored: &[Result<Explored, FitError>],
    finished: Finished,
    rank_of: &[Option<usize>],
    defer: bool,
) -> Result<(Vec<StartRecord>, Outcome), FitError> {
    let n = explored.len();
    let mut outcome_of: Vec<Option<Result<Outcome, FitError>>> = (0..n).map(|_| None).collect();
    for (k, o) in finished {
        outcome_of[k] = Some(o);
    }
    let mut best: Option<(usize, f64)> = None;
    let mut first_err = None;
    let mut records = Vec::with_capacity(n);
    for k in 0..n {
        let rec = StartFacts::of(pass, k, &explored[k]);
        records.push(match (&explored[k], &outcome_of[k]) {
            (Err(e), _) => {
                first_err.get_or_insert_with(|| e.to_string());
                rec.failed(e, false, None)
            }
            (Ok(x), Some(Err(e))) => {
                first_err.get_or_insert_with(|| e.to_string());
                rec.failed(e, true, x.warm.clone())
            }
            (Ok(_), Some(Ok(o))) => {
                if (o.cost.is_finite() || defer) && best.is_none_or(|(_, c)| o.cost < c) {
                    best = Some((k, o.cost));
                }
                rec.finished(o)
            }
            (Ok(x), None) => match x.same_as {
                Some(j) => rec.same_as(same_start_words(pass, j)),
                None => rec.ranked_out(x, rank_of[k], n, pass.config.finish),
            },
        });
    }
    let Some((b, _)) = best else {
        return Err(FitError::Solver {
            solver: pass.config.solver.name().into(),
            start: 0,
            reason: format!(
                "no start reached a finite loss ({})",
                first_err.unwrap_or_else(|| "every cost was infinite or NaN".into())
            ),
        });
    };
    records[b].kept = true;
    match outcome_of[b].take() {
        Some(Ok(o)) => Ok((records, o)),
        _ => unreachable!("the best start has an outcome"),
    }
}

/// What every record of start k says whatever became of it.
struct StartFacts {
    index: usize,
    channel: Option<usize>,
    start: Vec<f64>,
    rank_loss: Option<f64>,
    explore: Option<WarmUpRecord>,
}

impl StartFacts {
    fn of(pass: &Pass<'_>, k: usize, explored: &Result<Explored, FitError>) -> StartFacts {
        let e = explored.as_ref().ok();
        StartFacts {
            index: k,
            channel: pass.channel,
            start: pass
                .full
                .free_indices()
                .iter()
                .map(|&p| pass.points[k][p])
                .collect(),
            rank_loss: e.and_then(|e| e.rank_cost).map(|c| (2.0 * c).sqrt()),
            explore: e.and_then(|e| e.explore.clone()),
        }
    }

    fn record(self, termination: String, finished: bool) -> StartRecord {
        StartRecord {
            index: self.index,
            channel: self.channel,
            start: self.start,
            final_loss: None,
            iterations: 0,
            cost_evals: 0,
            jacobian_evals: 0,
            termination,
            converged: false,
            kept: false,
            warm_up: None,
            finished,
            rank_loss: self.rank_loss,
            explore: self.explore,
        }
    }

    fn failed(self, e: &FitError, finished: bool, warm: Option<WarmUpRecord>) -> StartRecord {
        StartRecord {
            warm_up: warm,
            ..self.record(format!("error: {e}"), finished)
        }
    }

    fn finished(self, o: &Outcome) -> StartRecord {
        StartRecord {
            final_loss: Some((2.0 * o.cost).sqrt()).filter(|v| v.is_finite()),
            iterations: o.iterations,
            cost_evals: o.cost_evals,
            jacobian_evals: o.jac_evals,
            converged: o.converged,
            warm_up: o.warm.clone(),
            explore: o.explore.clone(),
            ..self.record(o.termination.clone(), true)
        }
    }

    fn same_as(self, words: String) -> StartRecord {
        self.record(words, false)
    }

    fn ranked_out(self, x: &Explored, rank: Option<usize>, n: usize, finish: usize) -> StartRecord {
        let termination = format!(
            "not finished: ranked {} of {n} by the loss over the fitted cells after its \
             exploration; the best {finish} continued",
            rank.map_or(n, |r| r + 1),
        );
        StartRecord {
            final_loss: self.rank_loss.filter(|v| v.is_finite()),
            cost_evals: u64::from(x.rank_cost.is_some()),
            warm_up: x.warm.clone(),
            explore: x.explore.clone(),
            ..self.record(termination, false)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::cells::Cells;
    use super::super::timing::StageTimes;
    use super::*;
    use brdfkit_merl::{Dims, MerlTable};

    /// The cells of `truth` on a 30 × 30 × 60 grid, a ranked config of 4 starts (a
    /// 2,000-cell warm-up set, explored directly), and `family` at its default start
    /// with its free parameters.
    fn setup_of(truth: &str, family: &str) -> (FitData, FitConfig, Box<dyn Model>, Vec<usize>) {
        let truth = brdfkit_models::from_json_str(truth).unwrap();
        let t = MerlTable::from_brdf(truth.as_ref(), Dims::new(30, 30, 60).unwrap()).unwrap();
        let cfg = FitConfig::default()
            .starts(4)
            .unwrap()
            .warm_up(Some(2000))
            .unwrap();
        let model = brdfkit_models::default_model(family).unwrap();
        let free = crate::resolve_free(model.as_ref(), &cfg).unwrap();
        (FitData::from_table(&t).unwrap(), cfg, model, free)
    }

    /// Lambertian cells with ρd = (0.3, 0.4, 0.5) and the Lambert family.
    fn setup() -> (FitData, FitConfig, Box<dyn Model>, Vec<usize>) {
        setup_of(
            r#"{"model": "lambert", "params": {"rho_d": [0.3, 0.4, 0.5]}}"#,
            "lambert",
        )
    }

    /// Cook-Torrance cells (α = 0.15) and the Cook-Torrance family, whose starts spread
    /// over α.
    fn setup_ct() -> (FitData, FitConfig, Box<dyn Model>, Vec<usize>) {
        setup_of(
            r#"{"model": "cook-torrance", "params": {"rho_d": [0.1, 0.2, 0.3],
                "rho_s": [0.5, 0.4, 0.3], "alpha": 0.15}}"#,
            "cook-torrance",
        )
    }

    #[test]
    fn the_stages_explore_rank_warm_up_and_finish() {
        let (d, cfg, model, free) = setup_ct();
        let cells = Cells::of(&d, &cfg).unwrap();
        let sets = cells.sets();
        assert!(sets.ranked);
        let pass = Pass::new(&sets, model.as_ref(), &free, &[0, 1, 2], &cfg, None).unwrap();
        let explored = pass.explore();
        assert_eq!(explored.len(), 4, "one exploration per start");
        let costs: Vec<f64> = explored
            .iter()
            .map(|e| e.as_ref().unwrap().rank_cost.unwrap())
            .collect();
        let (finishers, rank_of) = pass.rank(&explored);
        assert_eq!(finishers.len(), 1, "the default: one finisher");
        let best = finishers[0];
        assert_eq!(rank_of[best], Some(0));
        assert!(costs.iter().all(|&c| costs[best] <= c), "{costs:?}");
        let settled = pass.settle(&finishers, &explored);
        // The warm-up set was explored directly: the warm-up stage passes the start on.
        let settled_u = settled[0].as_ref().unwrap().u.clone();
        let warmed = pass.warm_up(&finishers, settled);
        assert_eq!(warmed[0].as_ref().unwrap().u, settled_u);
        let finished = pass.finish(&finishers, warmed, None, false);
        let o = finished[0].1.as_ref().unwrap();
        assert!(o.converged, "{}", o.termination);
        assert!(
            (2.0 * o.cost).sqrt() < 1e-6,
            "a table of the family is fitted exactly"
        );
        let end = o.u.clone();
        let (starts, kept) = start_records(&pass, &explored, finished, &rank_of, false).unwrap();
        assert!(starts[best].kept && starts[best].finished);
        assert_eq!(kept.u, end, "the kept outcome is the finisher's");
        let out = starts.iter().find(|s| !s.finished).unwrap();
        assert!(
            out.termination.starts_with("not finished: ranked"),
            "{}",
            out.termination
        );
    }

    /// Ranking needs an order, not an optimum: every start's exploration stops at the
    /// ranking's tolerance, and the finisher then goes on from there exactly as a run
    /// with the warm-up set's own tolerances goes: the same end point, bit for bit, and
    /// its record counts the iterations of both runs.
    #[test]
    fn starts_explore_to_the_ranking_tolerance_and_the_finisher_resumes_exactly() {
        // Another family's table: an optimum with a residual, approached linearly at
        // the end, where the ranking's tolerance stops a run before ftol. A 6,000-cell
        // warm-up set (explored directly), so that its own tolerance (warm_up_ftol,
        // 5.6e-6) is below the ranking's.
        let (d, cfg, model, free) = setup_of(r#"{"model": "ward"}"#, "cook-torrance");
        let cfg = cfg.warm_up(Some(6000)).unwrap();
        let cells = Cells::of(&d, &cfg).unwrap();
        let pass = Pass::new(&cells.sets(), model.as_ref(), &free, &[0, 1, 2], &cfg, None).unwrap();
        assert!(pass.ranks());
        assert_eq!(pass.early, Some(RANKING_FTOL));
        let explored = pass.explore();
        // The warm-up set is explored directly here: its record is `warm`.
        let first = |e: &Explored| e.warm.clone().unwrap();
        let early: Vec<bool> = explored
            .iter()
            .map(|e| e.as_ref().unwrap().stopped.is_some())
            .collect();
        assert!(early.iter().any(|&x| x), "{early:?}");
        for e in explored.iter().map(|e| e.as_ref().unwrap()) {
            let t = first(e).termination;
            assert_eq!(
                e.stopped.is_some(),
                t == "converged: cost decrease below the ranking's tolerance (ftol 1e-5)",
                "{t}"
            );
        }
        let (finishers, _) = pass.rank(&explored);
        let settled = pass.settle(&finishers, &explored);
        let wp = pass.warm.as_ref().unwrap();
        let wcfg = &pass.warm_cfg;
        assert!(
            wcfg.subsample_ftol
                .is_some_and(|e| e < RANKING_FTOL && e > cfg.ftol)
        );
        // Every start resumed against its uninterrupted run with the warm-up set's
        // tolerances.
        for (k, x) in pass.points.iter().enumerate() {
            let e = explored[k].as_ref().unwrap();
            let whole = sub_stage(wp, pass.full.to_u(x), wcfg, pass.at(k), true, None).unwrap();
            let resumed = match &e.stopped {
                Some(st) => sub_stage_on(wp, st.clone(), wcfg, pass.at(k), true).unwrap(),
                None => continue,
            };
            assert_eq!(resumed.w.u, whole.w.u, "start {k}");
            assert_eq!(resumed.w.cost, whole.w.cost);
            assert!(resumed.w.termination.starts_with("converged"));
            assert!(resumed.w.early.is_none());
            let (a, b) = (first(e), pass.record_of(&resumed, wp, wcfg));
            // One iteration more than the whole run at most: a stop on the predicted
            // decrease counts an iteration without a step.
            assert!(b.iterations > a.iterations);
            assert!(
                b.iterations <= whole.w.iterations + 1,
                "{} vs {}",
                b.iterations,
                whole.w.iterations
            );
            if finishers.contains(&k) {
                let s = settled[0].as_ref().unwrap();
                assert_eq!(s.u, whole.w.u);
                assert_eq!(first(s), b);
            }
        }
    }

    /// No ranking to make (no more different starts than finishers): the explorations
    /// keep the fit's tolerances.
    #[test]
    fn the_ranking_tolerance_applies_only_to_a_ranking() {
        let (d, cfg, model, free) = setup_ct();
        let all = cfg.clone().finish(4).unwrap();
        let cells = Cells::of(&d, &all).unwrap();
        let pass = Pass::new(&cells.sets(), model.as_ref(), &free, &[0, 1, 2], &all, None).unwrap();
        assert_eq!(pass.early, None);
        assert!(
            pass.explore()
                .iter()
                .all(|e| e.as_ref().unwrap().stopped.is_none())
        );
    }

    /// Lambert has no shape parameter: its four starts are one point, which explores
    /// once, is finished without a ranking pass, and the others are recorded as that
    /// start's; the fit is the same as one start's.
    #[test]
    fn a_family_whose_starts_cannot_differ_explores_once() {
        let (d, cfg, model, free) = setup();
        let kept_u = with_pass(&d, &cfg, model.as_ref(), &free, |pass| {
            assert_eq!(pass.same_as, vec![None, Some(0), Some(0), Some(0)]);
            assert!(!pass.ranks() && pass.early.is_none());
            let explored = pass.explore();
            let ran: Vec<bool> = explored
                .iter()
                .map(|e| e.as_ref().unwrap().warm.is_some())
                .collect();
            assert_eq!(ran, [true, false, false, false], "one exploration");
            let no_rank = |e: &Result<Explored, FitError>| e.as_ref().unwrap().rank_cost.is_none();
            assert!(explored.iter().all(no_rank));
            let (finishers, rank_of) = pass.rank(&explored);
            assert_eq!(finishers, [0]);
            let warmed = pass.warm_up(&finishers, pass.settle(&finishers, &explored));
            let finished = pass.finish(&finishers, warmed, None, false);
            let (starts, kept) = start_records(pass, &explored, finished, &rank_of, false).unwrap();
            assert!(starts[0].kept && starts[0].rank_loss.is_none());
            for s in &starts[1..] {
                assert!(!s.finished && s.warm_up.is_none() && s.final_loss.is_none());
                let t = &s.termination;
                assert!(
                    t.starts_with("not run: the same start point as start 0"),
                    "{t}"
                );
                assert!(t.ends_with("(no free shape parameter to spread the starts over)"));
            }
            kept.u
        });
        // The same fit as a single start's.
        let one = cfg.clone().starts(1).unwrap();
        let cells1 = Cells::of(&d, &one).unwrap();
        let mut times = StageTimes::default();
        let r = run_pass(
            &cells1.sets(),
            model.as_ref(),
            free,
            vec![0, 1, 2],
            &one,
            None,
            &mut times,
        )
        .unwrap();
        assert_eq!(kept_u, r.best.u);
    }

    #[test]
    fn only_a_plain_single_finisher_evaluated_once_defers_its_cost() {
        let (d, cfg, model, free) = setup();
        with_pass(&d, &cfg, model.as_ref(), &free, |pass| {
            assert!(defers_cost(pass, Some(0), 1));
            assert!(!defers_cost(pass, Some(0), 2));
            assert!(!defers_cost(pass, None, 1));
        });
        let penalised = cfg.clone().albedo_max(Some(1.0)).unwrap();
        with_pass(&d, &penalised, model.as_ref(), &free, |pass| {
            assert!(
                !defers_cost(pass, Some(0), 1),
                "a penalty is not in the report"
            );
        });
    }

    #[test]
    fn the_warm_up_tolerance_is_a_share_of_the_sampling_excess() {
        let cfg = FitConfig::default();
        let m = 3 * 65_536;
        assert_eq!(warm_up_ftol(&cfg, 10, m), 0.01 * 10.0 / m as f64);
        // Never tighter than the fit's own ftol.
        let loose = cfg.clone().tolerances(1e-4, 1e-10, 1e-10).unwrap();
        assert_eq!(warm_up_ftol(&loose, 10, m), 1e-4);
        assert_eq!(warm_up_ftol(&cfg, 3, 0), 0.03);
    }

    /// The finisher's warm-up after a separate exploration stops at the warm-up set's
    /// tolerance ([`warm_up_ftol`]), not at the fit's ftol: on another family's table
    /// (an optimum with a residual, approached linearly) in fewer iterations than a run
    /// to the fit's ftol, at a warm-up cost within 10 ε of that run's (the tail's
    /// bound, see [`warm_up_ftol`]), and its record says which tolerance stopped it.
    #[test]
    fn the_warm_up_stops_at_the_warm_up_sets_tolerance() {
        let (d, cfg, model, free) = setup_of(r#"{"model": "ward"}"#, "cook-torrance");
        let cfg = cfg.explore_cells(Some(256)).unwrap();
        with_pass(&d, &cfg, model.as_ref(), &free, |pass| {
            assert!(pass.explore.is_some(), "a separate exploration set");
            let wp = pass.warm.as_ref().unwrap();
            let eps = warm_up_ftol(&cfg, free.len(), wp.num_residuals());
            assert_eq!(pass.warm_cfg.subsample_ftol, Some(eps));
            assert!(eps > 100.0 * cfg.get_tolerances().ftol);
            let explored = pass.explore();
            let (finishers, _) = pass.rank(&explored);
            let settled = pass.settle(&finishers, &explored);
            let from = settled[0].as_ref().unwrap().u.clone();
            let warmed = pass.warm_up(&finishers, settled);
            let w = warmed[0].as_ref().unwrap().warm.clone().unwrap();
            let at = pass.at(finishers[0]);
            let full = sub_stage(wp, from, &cfg, at, true, None).unwrap();
            assert!(w.termination.starts_with("converged"), "{}", w.termination);
            assert!(
                w.termination
                    .ends_with(&format!("{SUBSAMPLE_STOP} (ftol {eps:.1e})")),
                "{}",
                w.termination
            );
            assert!(
                w.iterations < full.w.iterations,
                "{} vs {}",
                w.iterations,
                full.w.iterations
            );
            let cost = 0.5 * w.final_loss * w.final_loss;
            assert!(cost >= full.w.cost && cost - full.w.cost <= 10.0 * eps * full.w.cost);
        });
    }

    /// `f` of the shared pass of `model` over the cells of `d` under `cfg`.
    fn with_pass<R>(
        d: &FitData,
        cfg: &FitConfig,
        model: &dyn Model,
        free: &[usize],
        f: impl FnOnce(&Pass<'_>) -> R,
    ) -> R {
        let cells = Cells::of(d, cfg).unwrap();
        let pass = Pass::new(&cells.sets(), model, free, &[0, 1, 2], cfg, None).unwrap();
        f(&pass)
    }
}
