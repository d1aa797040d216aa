//! The fit driver: cells → passes → starts (in parallel) → solver → best → record.

use crate::config::{FitConfig, Sharing, SolverKind};
use crate::data::FitData;
use crate::energy::{AlbedoPenalty, AlbedoQuadrature, PENALTY_WEIGHT};
use crate::error::FitError;
use crate::lm::{GaussNewtonLs, LevenbergMarquardt, LsState, Stall};
use crate::loss::{Robust, RobustKind};
use crate::observer::{Bridge, FitObserver, FitPlan, StartDone};
use crate::problem::{FitProblem, NormalEquations, evaluate_losses};
use crate::record::{
    FitRecord, ParamRecord, RobustRecord, StageIterations, StartRecord, WarmUpRecord,
};
use crate::score::CellFilter;
use crate::starts::start_points;
use argmin::core::observers::ObserverMode;
use argmin::core::{Executor, IterState, State, TerminationReason};
use argmin::solver::linesearch::MoreThuenteLineSearch as MoreThuente;
use argmin::solver::neldermead::NelderMead;
use argmin::solver::quasinewton::LBFGS;
use argmin::solver::trustregion::{Steihaug, TrustRegion};
use brdfkit_core::{Model, ParamRole};
use brdfkit_merl::MerlTable;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde_json::{Value, json};
use std::sync::Arc;
use std::time::Instant;

/// The fitted model(s).
#[derive(Debug, Clone)]
pub enum Fitted {
    /// One model for all channels (shared shape parameters).
    Shared(Box<dyn Model>),
    /// One model per channel (R, G, B); model c is meant for channel c only.
    PerChannel([Box<dyn Model>; 3]),
}

impl Fitted {
    /// The model of channel c.
    pub fn channel_model(&self, c: usize) -> &dyn Model {
        match self {
            Fitted::Shared(m) => m.as_ref(),
            Fitted::PerChannel(ms) => ms[c].as_ref(),
        }
    }

    /// The shared model, if the fit was shared.
    pub fn shared(&self) -> Option<&dyn Model> {
        match self {
            Fitted::Shared(m) => Some(m.as_ref()),
            Fitted::PerChannel(_) => None,
        }
    }

    /// The JSON contract of the result: the model's `to_json()`, or
    /// `{"per_channel": [r, g, b]}`.
    pub fn to_json(&self) -> Value {
        match self {
            Fitted::Shared(m) => m.to_json(),
            Fitted::PerChannel(ms) => {
                json!({"per_channel": [ms[0].to_json(), ms[1].to_json(), ms[2].to_json()]})
            }
        }
    }
}

/// A fit's outcome: the model(s) and the record.
#[derive(Debug, Clone)]
pub struct FitResult {
    /// The fitted model(s).
    pub fitted: Fitted,
    /// What was done and how well it went.
    pub record: FitRecord,
}

/// The outcome of one start.
#[derive(Debug, Clone)]
struct Outcome {
    u: DVector<f64>,
    cost: f64,
    iterations: u64,
    cost_evals: u64,
    jac_evals: u64,
    termination: String,
    converged: bool,
    warm: Option<WarmUpRecord>,
    explore: Option<WarmUpRecord>,
}

/// A start after its subsample stages: where it got to, the stages' records and, when
/// the starts are ranked, the optimised cost over all fitted cells where its
/// exploration ended.
#[derive(Clone)]
struct Explored {
    u: DVector<f64>,
    explore: Option<WarmUpRecord>,
    warm: Option<WarmUpRecord>,
    rank_cost: Option<f64>,
}

/// Size of the exploration set of a ranked fit: the warm-up size over this, unless
/// [`FitConfig::explore_cells`] gives a size.
const EXPLORE_DIVISOR: usize = 8;

/// Smallest separate exploration set of the default rule (a few cells per stratum of
/// the 16 × 16 grid); below it the warm-up set is explored directly.
const EXPLORE_MIN_CELLS: usize = 4096;

/// Seed offset of the exploration subsample.
const EXPLORE_SEED: u64 = 0x4558_504C;

/// Most solver runs of one warm-up when the starts are ranked (see `run_pass`).
const WARM_UP_ROUNDS: u64 = 4;

/// Seed offset of the warm-up subsample (distinct from a user subsample's draw).
const WARM_UP_SEED: u64 = 0x5741_524D;

/// Which parameters a config frees: the model's `fit_by_default` ones, plus
/// `config.free`, minus `config.fixed`. A name matches a parameter exactly or as its
/// group (`rho_d` matches `rho_d.r`, `rho_d.g`, `rho_d.b`).
pub fn resolve_free(model: &dyn Model, config: &FitConfig) -> Result<Vec<usize>, FitError> {
    let specs = model.param_specs();
    let matches = |name: &str| -> Result<Vec<usize>, FitError> {
        let v: Vec<usize> = specs
            .iter()
            .enumerate()
            .filter(|(_, s)| {
                s.name == name
                    || (s.name.starts_with(name) && s.name[name.len()..].starts_with('.'))
            })
            .map(|(p, _)| p)
            .collect();
        if v.is_empty() {
            Err(FitError::UnknownParam {
                model: model.name().into(),
                name: name.into(),
                known: specs
                    .iter()
                    .map(|s| s.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
        } else {
            Ok(v)
        }
    };
    let mut free: Vec<bool> = specs.iter().map(|s| s.fit_by_default).collect();
    for n in &config.free {
        for p in matches(n)? {
            free[p] = true;
        }
    }
    for n in &config.fixed {
        for p in matches(n)? {
            free[p] = false;
        }
    }
    Ok((0..specs.len()).filter(|&p| free[p]).collect())
}

fn describe(reason: Option<&TerminationReason>, criterion: Option<&str>) -> (String, bool) {
    match reason {
        Some(TerminationReason::SolverConverged) => (
            format!("converged: {}", criterion.unwrap_or("solver's own test")),
            true,
        ),
        Some(TerminationReason::TargetCostReached) => (
            "converged: cost at the round-off floor of a perfect fit".into(),
            true,
        ),
        Some(TerminationReason::MaxItersReached) => ("maximum iterations reached".into(), false),
        Some(TerminationReason::SolverExit(s)) => (format!("solver gave up: {s}"), false),
        Some(other) => (format!("stopped: {other}"), false),
        None => ("not terminated".into(), false),
    }
}

/// `run` from where `prev` ended; the outcome counts the iterations and passes of both
/// runs.
fn run_on(
    prev: &Outcome,
    run: impl FnOnce(DVector<f64>) -> Result<Outcome, FitError>,
) -> Result<Outcome, FitError> {
    let r = run(prev.u.clone())?;
    Ok(Outcome {
        iterations: prev.iterations + r.iterations,
        cost_evals: prev.cost_evals + r.cost_evals,
        jac_evals: prev.jac_evals + r.jac_evals,
        ..r
    })
}

/// Runs one start with the configured solver.
fn run_start(
    problem: FitProblem<'_>,
    u0: DVector<f64>,
    config: &FitConfig,
    observer: Option<&Arc<dyn FitObserver>>,
    start: usize,
    channel: Option<usize>,
    warm_up: bool,
) -> Result<Outcome, FitError> {
    let mi = config.get_max_iters();
    let tol = config.get_tolerances();
    let floor = problem.cost_floor();
    let err = |e: argmin::core::Error| FitError::Solver {
        solver: config.solver.name().into(),
        start,
        reason: e.to_string(),
    };
    let bridge = || {
        observer.map(|o| Bridge {
            obs: o.clone(),
            start,
            channel,
            warm_up,
        })
    };
    macro_rules! run {
        ($solver:expr, $state:ty, $init:expr) => {{
            let mut ex = Executor::new(problem.clone(), $solver)
                .configure(|s: $state| $init(s).max_iters(mi).target_cost(floor))
                .ctrlc(false);
            if let Some(b) = bridge() {
                ex = ex.add_observer(b, ObserverMode::Always);
            }
            ex.run().map_err(err)?
        }};
    }
    // (best u, best cost, iterations, (termination, converged), (cost, Jacobian) passes)
    macro_rules! summary {
        ($r:expr) => {{
            let r = $r;
            let term = describe(r.state.get_termination_reason(), r.solver.criterion);
            let evals = r
                .problem
                .problem
                .as_ref()
                .map(|p| (p.cost_evals(), p.jacobian_evals()));
            (
                r.state.get_best_param().cloned(),
                r.state.get_best_cost(),
                r.state.get_iter(),
                term,
                evals,
            )
        }};
    }
    let (u, cost, iters, term, evals) = match config.solver {
        SolverKind::Lm => {
            let r = run!(
                LevenbergMarquardt::new(config.tau, tol),
                LsState,
                |s: LsState| s.param(u0.clone())
            );
            summary!(r)
        }
        SolverKind::GaussNewton => {
            let r = run!(GaussNewtonLs::new(tol), LsState, |s: LsState| s
                .param(u0.clone()));
            summary!(r)
        }
        SolverKind::TrustRegion => {
            type S = IterState<DVector<f64>, DVector<f64>, (), DMatrix<f64>, (), f64>;
            let tr = TrustRegion::new(Steihaug::new().with_max_iters(50))
                .with_radius(1.0)
                .and_then(|t| t.with_max_radius(100.0))
                .map_err(err)?;
            let r = run!(Stall::new(tr, tol.ftol, 5, floor), S, |s: S| s
                .param(u0.clone()));
            summary!(r)
        }
        SolverKind::Lbfgs => {
            let c0 = problem.cost_at(&u0);
            let lb = LBFGS::new(MoreThuente::new(), 7)
                .with_tolerance_cost(tol.ftol * c0.max(floor))
                .and_then(|l| l.with_tolerance_grad(0.0))
                .map_err(err)?;
            let r = run!(
                Stall::new(lb, tol.ftol, 10, floor),
                LsState,
                |s: LsState| s.param(u0.clone())
            );
            summary!(r)
        }
        SolverKind::NelderMead => {
            type S = IterState<DVector<f64>, (), (), (), (), f64>;
            // Initial simplex: u0 and u0 + 0.5 e_q (a factor e^0.5 on a log
            // parameter, a quarter of the logit's central range).
            let mut simplex = vec![u0.clone()];
            for q in 0..u0.len() {
                let mut v = u0.clone();
                v[q] += 0.5;
                simplex.push(v);
            }
            let nm = NelderMead::new(simplex)
                .with_sd_tolerance(0.0)
                .map_err(err)?;
            let r = run!(
                Stall::new(nm, tol.ftol, 50 * u0.len().max(1), floor),
                S,
                |s: S| s
            );
            summary!(r)
        }
    };
    // argmin's `run()` is Ok even when a solver gave up; the best point can also be
    // missing (a solver that never produced a cost). Fall back to the start.
    let (u, cost) = match u {
        Some(u) if cost.is_finite() && u.iter().all(|v| v.is_finite()) => (u, cost),
        _ => {
            let c = problem.cost_at(&u0);
            (u0, c)
        }
    };
    let (ce, je) = evals.unwrap_or((0, 0));
    Ok(Outcome {
        u,
        cost,
        iterations: iters,
        cost_evals: ce,
        jac_evals: je,
        termination: term.0,
        converged: term.1,
        warm: None,
        explore: None,
    })
}

/// A start's run on a subsample (`problem`) from `u0`: where it ended and the stage's
/// record.
///
/// With `restart`, a run that stopped at the iteration cap is run again from where it
/// stopped (fresh damping), up to [`WARM_UP_ROUNDS`] runs, while it improves by more
/// than ftol: far from the answer (a nearly flat lobe) LM's damping grows and its
/// steps shrink; a fresh run takes the large steps a continuation on all cells would
/// otherwise take, at the subsample's cost, so a ranking sees where a start leads.
fn sub_stage(
    problem: &FitProblem<'_>,
    u0: DVector<f64>,
    config: &FitConfig,
    observer: Option<&Arc<dyn FitObserver>>,
    k: usize,
    channel: Option<usize>,
    restart: bool,
) -> Result<(DVector<f64>, WarmUpRecord), FitError> {
    let mut w = run_start(problem.clone(), u0, config, observer, k, channel, true)?;
    let mut rounds = 1;
    while restart
        && rounds < WARM_UP_ROUNDS
        && !w.converged
        && w.iterations >= config.get_max_iters() * rounds
    {
        let r = run_on(&w, |u| {
            run_start(problem.clone(), u, config, observer, k, channel, true)
        })?;
        rounds += 1;
        let gain = w.cost - r.cost;
        // This round alone ran into the iteration cap.
        let capped = r.iterations - w.iterations >= config.get_max_iters();
        w = r;
        // Stop unless it improved by more than ftol (relative); a NaN gain stops too.
        let improved = gain > config.get_tolerances().ftol * w.cost;
        if !improved || !capped {
            break;
        }
    }
    let rec = WarmUpRecord {
        cells: problem.num_residuals() / problem.channels().len(),
        iterations: w.iterations,
        cost_evals: w.cost_evals,
        jacobian_evals: w.jac_evals,
        final_loss: (2.0 * w.cost).sqrt(),
        termination: w.termination.clone(),
        rounds,
    };
    Ok((w.u, rec))
}

struct PassResult {
    model: Box<dyn Model>,
    free: Vec<usize>,
    starts: Vec<StartRecord>,
    best: Outcome,
    transforms: Vec<crate::reparam::Transform>,
    /// The robust scale of the pass and, with an automatic scale, the plain stage's
    /// best loss.
    robust: Option<(f64, Option<f64>)>,
    /// The pass's channel (a per-channel pass) or `None` (all three).
    channel: Option<usize>,
    /// The kept start's cost over the fitted cells is left to [`fit`]'s loss report
    /// (see `defer` in `run_pass`): `best.cost` and its record's `final_loss` are
    /// filled in there.
    deferred: bool,
}

/// Floor of the automatic robust scale, relative to the targets' RMS: a plain fit that
/// is exact (median |e| = 0) would otherwise give c = 0. Any c gives the same optimum
/// there (no residual is an outlier).
const ROBUST_SCALE_FLOOR: f64 = 1e-9;

fn run_pass(
    data: &FitData,
    model: &dyn Model,
    free: Vec<usize>,
    channels: Vec<usize>,
    config: &FitConfig,
    observer: Option<&Arc<dyn FitObserver>>,
) -> Result<PassResult, FitError> {
    let channel = (channels.len() == 1).then(|| channels[0]);
    let problem = FitProblem::new(
        data,
        model,
        free.clone(),
        channels.clone(),
        config.loss,
        config.weighting,
    )?;
    // Energy conservation: the albedo penalty on every stage's problem (λ relative to
    // the full set's targets, so the stages share it).
    let penalty = config.albedo_max.map(|a| {
        Arc::new(AlbedoPenalty {
            quad: AlbedoQuadrature::new(),
            max: a,
            lambda: PENALTY_WEIGHT * problem.target_rms().powi(2),
        })
    });
    let problem = problem.with_penalty(penalty.clone());
    // Warm-up set: a stratified subsample each start converges on first.
    let specs = model.param_specs();
    let x0 = model.params();
    let points = start_points(&specs, &x0, &free, config.starts, config.seed);
    let n = points.len();
    let warm_cells = config.warm_up_cells_for(data.len());
    // Ranking pays only when a warm-up makes exploring cheap and some start can be
    // left unfinished; otherwise every start is finished (as with one start).
    let ranked = warm_cells.is_some() && config.finish < n;
    // The exploration set of a ranked fit: an eighth of the warm-up's size (each start
    // converges there; the finishers then pass through the warm-up set to the full
    // one), unless that would be under EXPLORE_MIN_CELLS, when the warm-up set is the
    // exploration set.
    let explore_cells = warm_cells
        .filter(|_| ranked)
        .and_then(|w| match config.explore_cells {
            None => Some(w / EXPLORE_DIVISOR).filter(|&e| e >= EXPLORE_MIN_CELLS),
            Some(e) => (e < w).then_some(e),
        });
    let subsample = |cells: usize, seed: u64| {
        data.stratified_subsample(cells as f64 / data.len() as f64, config.seed ^ seed)
    };
    let warm_data = warm_cells.map(|c| subsample(c, WARM_UP_SEED));
    // Drawn from the warm-up set (stratified again; multiplicities multiply, so its
    // weighted sums still estimate the full set's), not from the full set: no
    // full-size temporary while the warm-up set is held.
    let explore_data = match (explore_cells, &warm_data) {
        (Some(c), Some(w)) => {
            Some(w.stratified_subsample(c as f64 / w.len() as f64, config.seed ^ EXPLORE_SEED))
        }
        _ => None,
    };
    // A given robust scale applies from the start (subsamples included); an automatic
    // one needs a plain fit first (see `FitConfig::robust`).
    let given = match (config.robust, config.robust_scale) {
        (RobustKind::None, _) => None,
        (kind, Some(scale)) => Some(Robust { kind, scale }),
        (_, None) => None,
    };
    /// What every stage's problem shares: model, free parameters, channels, config,
    /// robust loss, albedo penalty.
    type Parts<'a> = (
        &'a dyn Model,
        &'a [usize],
        &'a [usize],
        &'a FitConfig,
        Option<Robust>,
        &'a Option<Arc<AlbedoPenalty>>,
    );
    /// The problem on a subsample `d` (none without one).
    fn sub_problem<'d>(
        d: Option<&'d FitData>,
        (model, free, channels, config, given, penalty): Parts<'_>,
    ) -> Result<Option<FitProblem<'d>>, FitError> {
        d.map(|d| {
            let p = FitProblem::new(
                d,
                model,
                free.to_vec(),
                channels.to_vec(),
                config.loss,
                config.weighting,
            )?
            .with_penalty(penalty.clone());
            Ok(match given {
                Some(r) => p.with_robust(r),
                None => p,
            })
        })
        .transpose()
    }
    let parts: Parts<'_> = (model, &free, &channels, config, given, &penalty);
    let warm_problem = sub_problem(warm_data.as_ref(), parts)?;
    let explore_problem = sub_problem(explore_data.as_ref(), parts)?;
    let auto = config.robust != RobustKind::None && config.robust_scale.is_none();
    let stage1 = match given {
        Some(r) => problem.with_robust(r),
        None => problem.clone(),
    };
    let done = |k: usize, o: &Result<Outcome, FitError>| {
        if let (Some(obs), Ok(o)) = (observer, o) {
            obs.on_start_done(&StartDone {
                start: k,
                channel,
                loss: (2.0 * o.cost).sqrt(),
                iterations: o.iterations,
                termination: o.termination.clone(),
            });
        }
    };
    // Stage 1, every start in parallel. Unranked: its warm-up. Ranked: it converges on
    // the exploration set (restarted while it hits the iteration cap, see
    // `sub_stage`), and the optimised cost over all fitted cells where it ended is its
    // rank (a fresh clone of the problem, so the pass is counted for this start).
    // After a separate exploration the starts are ranked on the warm-up set (a cost
    // pass over 65 536 cells instead of all fitted cells: the same order on every
    // measured table tried, at a sixteenth of the cost); without one, on the fitted
    // cells as before.
    let rank_on_warm = explore_problem.is_some() && warm_problem.is_some();
    let explored: Vec<Result<Explored, FitError>> = points
        .par_iter()
        .enumerate()
        .map(|(k, x)| {
            let u0 = stage1.to_u(x);
            let first = explore_problem.as_ref().or(warm_problem.as_ref());
            let (u, rec) = match first {
                Some(p) => {
                    let (u, rec) = sub_stage(p, u0, config, observer, k, channel, ranked)?;
                    (u, Some(rec))
                }
                None => (u0, None),
            };
            let rank_cost = ranked.then(|| match (&warm_problem, rank_on_warm) {
                (Some(wp), true) => wp.clone().cost_at(&u),
                _ => stage1.clone().cost_at(&u),
            });
            // With a separate exploration set the start has not warmed up yet.
            let (explore, warm) = if explore_problem.is_some() {
                (rec, None)
            } else {
                (None, rec)
            };
            Ok(Explored {
                u,
                explore,
                warm,
                rank_cost,
            })
        })
        .collect();
    drop(explore_problem);
    drop(explore_data);
    // Ranking: finite costs first, lowest first; ties and non-finite costs in start
    // order. Starts whose warm-up failed are never finished (their error is recorded).
    let rank_key = |k: usize| match &explored[k] {
        Ok(e) => e
            .rank_cost
            .filter(|c| c.is_finite())
            .unwrap_or(f64::INFINITY),
        Err(_) => f64::NAN,
    };
    let mut order: Vec<usize> = (0..n).filter(|&k| explored[k].is_ok()).collect();
    if ranked {
        order.sort_by(|&a, &b| rank_key(a).total_cmp(&rank_key(b)).then(a.cmp(&b)));
    }
    let mut rank_of = vec![None; n];
    for (pos, &k) in order.iter().enumerate() {
        rank_of[k] = Some(pos);
    }
    let finishers: Vec<usize> = if ranked {
        order.iter().copied().take(config.finish).collect()
    } else {
        order
    };
    if let Some(obs) = observer {
        for k in (0..n).filter(|k| !finishers.contains(k)) {
            if let Ok(e) = &explored[k] {
                obs.on_start_done(&StartDone {
                    start: k,
                    channel,
                    loss: (2.0 * e.rank_cost.unwrap_or(f64::NAN)).sqrt(),
                    iterations: 0,
                    termination: "not finished (ranked out after its exploration)".into(),
                });
            }
        }
    }
    // Stage 2a: after a separate exploration, the finishers warm up from where they
    // got to. Then the subsample is freed before the full-set fits.
    let warmed: Vec<Result<Explored, FitError>> = finishers
        .par_iter()
        .map(|&k| {
            let e = explored[k].as_ref().expect("finishers explored fine");
            match (&warm_problem, e.warm.is_none() && e.explore.is_some()) {
                (Some(wp), true) => {
                    let (u, rec) = sub_stage(wp, e.u.clone(), config, observer, k, channel, false)?;
                    Ok(Explored {
                        u,
                        warm: Some(rec),
                        explore: e.explore.clone(),
                        rank_cost: e.rank_cost,
                    })
                }
                _ => Ok(e.clone()),
            }
        })
        .collect();
    drop(warm_problem);
    drop(warm_data);
    // Stage 2b: the finishers continue on all fitted cells, in parallel.
    // A start that warmed up takes at most `full_iters` iterations here (see
    // `FitConfig::full_iters`); 0: its warm-up optimum is only evaluated.
    let full_iters = config.full_iters.cap_for(model);
    // One finisher whose warm-up optimum is only evaluated (full_iters 0) under the
    // plain loss: its cost over the fitted cells, ½ loss², is what `fit`'s loss report
    // sums anyway (the same terms in another order), so that pass over all cells is
    // not paid twice: `fit` takes the cost from the report.
    let defer = full_iters == Some(0)
        && finishers.len() == 1
        && given.is_none()
        && !auto
        && penalty.is_none();
    let capped_cfg = match full_iters {
        Some(n) if n > 0 => config
            .clone()
            .max_iters(n)
            .unwrap_or_else(|_| config.clone()),
        _ => config.clone(),
    };
    let mut finished: Vec<(usize, Result<Outcome, FitError>)> = finishers
        .par_iter()
        .zip(warmed)
        .map(|(&k, e)| {
            let e = match e {
                Ok(e) => e,
                Err(err) => return (k, Err(err)),
            };
            let o = if let (Some(w), Some(0)) = (&e.warm, full_iters) {
                // The warm-up optimum, evaluated on all fitted cells (one cost pass).
                let probe = stage1.clone();
                let cost = if defer { f64::NAN } else { probe.cost_at(&e.u) };
                Ok(Outcome {
                    u: e.u.clone(),
                    cost,
                    iterations: 0,
                    // Deferred: the loss report's pass is this start's cost pass.
                    cost_evals: if defer { 1 } else { probe.cost_evals() },
                    jac_evals: 0,
                    termination: format!(
                        "{} on the warm-up set; evaluated on all fitted cells (full_iters 0)",
                        w.termination
                    ),
                    converged: w.termination.starts_with("converged"),
                    warm: None,
                    explore: None,
                })
            } else {
                run_start(
                    stage1.clone(),
                    e.u.clone(),
                    if e.warm.is_some() {
                        &capped_cfg
                    } else {
                        config
                    },
                    observer,
                    k,
                    channel,
                    false,
                )
            }
            .map(|mut o| {
                o.warm = e.warm.clone();
                o.explore = e.explore.clone();
                // The ranking pass was a cost pass over the fitted cells too.
                o.cost_evals += u64::from(e.rank_cost.is_some() && !rank_on_warm);
                o
            });
            if !auto && !defer {
                done(k, &o);
            }
            (k, o)
        })
        .collect();
    let mut robust_info = given.map(|r| (r.scale, None));
    if auto {
        // The scale from the best plain start, common to every finished start so their
        // robust costs compare.
        let plain_best = finished
            .iter()
            .filter_map(|(_, o)| o.as_ref().ok())
            .filter(|o| o.cost.is_finite())
            .min_by(|a, b| a.cost.total_cmp(&b.cost));
        if let Some(pb) = plain_best {
            let floor = ROBUST_SCALE_FLOOR * problem.target_rms();
            let med = problem.median_abs_residual(&pb.u).unwrap_or(0.0);
            let scale = (config.robust.tuning() * 1.4826 * med).max(floor);
            let plain_loss = (2.0 * pb.cost).sqrt();
            let rp = problem.with_robust(Robust {
                kind: config.robust,
                scale,
            });
            finished = finished
                .into_par_iter()
                .map(|(k, o1)| {
                    let o1 = match o1 {
                        Ok(o) => o,
                        Err(e) => return (k, Err(e)),
                    };
                    let o = run_on(&o1, |u| {
                        run_start(rp.clone(), u, config, observer, k, channel, false)
                    })
                    .map(|mut o| {
                        o.warm = o1.warm.clone();
                        o.explore = o1.explore.clone();
                        o
                    });
                    done(k, &o);
                    (k, o)
                })
                .collect();
            robust_info = Some((scale, Some(plain_loss)));
        }
    }
    let mut outcome_of: Vec<Option<Result<Outcome, FitError>>> = (0..n).map(|_| None).collect();
    for (k, o) in finished {
        outcome_of[k] = Some(o);
    }
    let mut best: Option<(usize, f64)> = None;
    let mut records = Vec::with_capacity(n);
    let mut first_err = None;
    for k in 0..n {
        let start: Vec<f64> = free.iter().map(|&p| points[k][p]).collect();
        let rank_loss = explored[k]
            .as_ref()
            .ok()
            .and_then(|e| e.rank_cost)
            .map(|c| (2.0 * c).sqrt());
        let explore = explored[k].as_ref().ok().and_then(|e| e.explore.clone());
        let failed = |e: &FitError, finished: bool, warm: Option<WarmUpRecord>| StartRecord {
            index: k,
            channel,
            start: start.clone(),
            final_loss: None,
            iterations: 0,
            cost_evals: 0,
            jacobian_evals: 0,
            termination: format!("error: {e}"),
            converged: false,
            kept: false,
            warm_up: warm,
            finished,
            rank_loss,
            explore: explore.clone(),
        };
        let rec = match (&explored[k], &outcome_of[k]) {
            (Err(e), _) => {
                first_err.get_or_insert_with(|| e.to_string());
                failed(e, false, None)
            }
            (Ok(x), Some(Err(e))) => {
                first_err.get_or_insert_with(|| e.to_string());
                failed(e, true, x.warm.clone())
            }
            (Ok(_), Some(Ok(o))) => {
                if (o.cost.is_finite() || defer) && best.is_none_or(|(_, c)| o.cost < c) {
                    best = Some((k, o.cost));
                }
                StartRecord {
                    index: k,
                    channel,
                    start,
                    final_loss: Some((2.0 * o.cost).sqrt()).filter(|v| v.is_finite()),
                    iterations: o.iterations,
                    cost_evals: o.cost_evals,
                    jacobian_evals: o.jac_evals,
                    termination: o.termination.clone(),
                    converged: o.converged,
                    kept: false,
                    warm_up: o.warm.clone(),
                    finished: true,
                    rank_loss,
                    explore: o.explore.clone(),
                }
            }
            (Ok(x), None) => StartRecord {
                index: k,
                channel,
                start,
                final_loss: rank_loss.filter(|v| v.is_finite()),
                iterations: 0,
                cost_evals: u64::from(x.rank_cost.is_some()),
                jacobian_evals: 0,
                termination: format!(
                    "not finished: ranked {} of {n} by the loss over the fitted cells after \
                     its exploration; the best {} continued",
                    rank_of[k].map_or(n, |r| r + 1),
                    config.finish
                ),
                converged: false,
                kept: false,
                warm_up: x.warm.clone(),
                finished: false,
                rank_loss,
                explore: x.explore.clone(),
            },
        };
        records.push(rec);
    }
    let Some((b, _)) = best else {
        return Err(FitError::Solver {
            solver: config.solver.name().into(),
            start: 0,
            reason: format!(
                "no start reached a finite loss ({})",
                first_err.unwrap_or_else(|| "every cost was infinite or NaN".into())
            ),
        });
    };
    records[b].kept = true;
    let best = match outcome_of[b].take() {
        Some(Ok(o)) => o,
        _ => unreachable!("the best start has an outcome"),
    };
    let fitted = problem.model_at(&best.u)?;
    Ok(PassResult {
        model: fitted,
        transforms: problem.transforms().to_vec(),
        free,
        starts: records,
        best,
        robust: robust_info,
        channel,
        deferred: defer,
    })
}

/// Fits `model`'s family to the cells of `data`.
///
/// `model` fixes the family and its structural choices (distribution, Fresnel, lobe
/// count) and gives start 0 and the values of the fixed parameters (normally
/// [`brdfkit_models::default_model`] or a user's JSON). See the crate doc and
/// `docs/fitting.md` for what happens; `observer` receives progress events (pass
/// `None` for a silent fit).
pub fn fit(
    model: &dyn Model,
    data: &FitData,
    config: &FitConfig,
    observer: Option<Arc<dyn FitObserver>>,
) -> Result<FitResult, FitError> {
    let t0 = Instant::now();
    config.validate()?;
    // The cells of the final losses: the ones a score of the result takes (score.rs).
    let full = CellFilter::of(config).apply(data)?;
    let full: &FitData = &full;
    let sub_owned;
    let fitset: &FitData = match config.subsample {
        Some(f) => {
            sub_owned = full.stratified_subsample(f, config.seed);
            &sub_owned
        }
        None => full,
    };
    let specs = model.param_specs();
    let free = resolve_free(model, config)?;
    if free.is_empty() {
        return Err(FitError::NothingToFit(model.name().into()));
    }
    let passes: Vec<(Vec<usize>, Vec<usize>)> = match config.sharing {
        Sharing::SharedShape => vec![(free.clone(), vec![0, 1, 2])],
        Sharing::PerChannel => (0..3)
            .map(|c| {
                let f: Vec<usize> = free
                    .iter()
                    .copied()
                    .filter(|&p| match specs[p].role {
                        ParamRole::Shared => true,
                        ParamRole::Channel(k) => k == c,
                    })
                    .collect();
                (f, vec![c])
            })
            .collect(),
    };
    if let Some(o) = &observer {
        o.on_plan(&FitPlan {
            starts: config.starts,
            // Ranked passes finish `finish` starts, unranked ones every start.
            finish: if config.warm_up_cells_for(fitset.len()).is_some() {
                config.finish.min(config.starts)
            } else {
                config.starts
            },
            passes: passes.len(),
            max_iters: config.get_max_iters(),
            cells: fitset.len(),
        });
    }
    let mut results: Vec<PassResult> = passes
        .into_iter()
        .map(|(f, ch)| run_pass(fitset, model, f, ch, config, observer.as_ref()))
        .collect::<Result<_, _>>()?;

    let fitted = if results.len() == 1 {
        Fitted::Shared(results[0].model.clone())
    } else {
        Fitted::PerChannel([
            results[0].model.clone(),
            results[1].model.clone(),
            results[2].model.clone(),
        ])
    };
    let ms = [
        fitted.channel_model(0),
        fitted.channel_model(1),
        fitted.channel_model(2),
    ];
    let losses_fit = evaluate_losses(ms, fitset, config.weighting);
    let losses_full = if std::ptr::eq(fitset, full) {
        losses_fit
    } else {
        evaluate_losses(ms, full, config.weighting)
    };
    // Deferred costs (see `run_pass`): the report's value of the optimised loss over
    // the fitted cells, overall or of the pass's channel.
    for r in results.iter_mut().filter(|r| r.deferred) {
        let l = losses_fit.get(config.loss);
        let v = r.channel.map_or(l.overall, |c| l.channels[c]);
        if !v.is_finite() {
            return Err(FitError::Solver {
                solver: config.solver.name().into(),
                start: 0,
                reason: "no start reached a finite loss (every cost was infinite or NaN)".into(),
            });
        }
        r.best.cost = 0.5 * v * v;
        if let Some(s) = r.starts.iter_mut().find(|s| s.kept) {
            s.final_loss = Some(v);
            if let Some(o) = &observer {
                o.on_start_done(&StartDone {
                    start: s.index,
                    channel: r.channel,
                    loss: v,
                    iterations: r.best.iterations,
                    termination: r.best.termination.clone(),
                });
            }
        }
    }

    let x0 = model.params();
    let params: Vec<ParamRecord> = specs
        .iter()
        .enumerate()
        .map(|(p, s)| {
            // Per-channel fits: a channel parameter from its channel's pass, a shared
            // one from the green pass (the record's `model` holds all three).
            let pass = match (s.role, results.len()) {
                (_, 1) => 0,
                (ParamRole::Channel(c), _) => c,
                (ParamRole::Shared, _) => 1,
            };
            let r = &results[pass];
            let q = r.free.iter().position(|&f| f == p);
            ParamRecord {
                name: s.name.clone(),
                value: r.model.params()[p],
                start: x0[p],
                free: q.is_some(),
                transform: q.map(|q| r.transforms[q].name().to_string()),
                at_bound: q
                    .and_then(|q| r.transforms[q].end_at(r.best.u[q]))
                    .map(String::from),
            }
        })
        .collect();
    let active_bounds: Vec<String> = params
        .iter()
        .zip(&specs)
        .filter_map(|(r, s)| {
            r.at_bound.as_deref().map(|end| {
                let v = if end == "lower" {
                    s.domain.lo
                } else {
                    s.domain.hi
                };
                format!("{} ({end} end {v})", r.name)
            })
        })
        .collect();
    let quad = AlbedoQuadrature::new();
    let max_albedo = (0..3)
        .map(|c| {
            quad.albedos(fitted.channel_model(c))
                .iter()
                .map(|a| a[c])
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    let free_params = free.iter().map(|&p| specs[p].name.clone()).collect();
    let starts: Vec<StartRecord> = results.iter().flat_map(|r| r.starts.clone()).collect();
    let (termination, converged) = if results.len() == 1 {
        (
            results[0].best.termination.clone(),
            results[0].best.converged,
        )
    } else {
        (
            ["r", "g", "b"]
                .iter()
                .zip(&results)
                .map(|(c, r)| format!("{c}: {}", r.best.termination))
                .collect::<Vec<_>>()
                .join("; "),
            results.iter().all(|r| r.best.converged),
        )
    };
    let warm_up_cells = config.warm_up_cells_for(fitset.len());
    let record = FitRecord {
        model: fitted.to_json(),
        family: model.name().into(),
        loss: config.loss,
        weighting: config.weighting,
        solver: config.solver,
        sharing: config.sharing,
        theta_d_max_deg: config.theta_d_max.map(f64::to_degrees),
        theta_max_deg: config.theta_max.map(f64::to_degrees),
        subsample: config.subsample,
        seed: config.seed,
        starts_per_pass: config.starts,
        finish: Some(config.finish),
        free_params,
        params,
        cells_fit: fitset.len(),
        cells_full: full.len(),
        warm_up_cells,
        full_iters: warm_up_cells.map(|_| config.full_iters.for_model(model)),
        losses_fit,
        losses_full,
        iterations: results.iter().map(|r| r.best.iterations).sum(),
        iterations_run: Some(StageIterations::of_starts(&starts)),
        cost_evals: starts.iter().map(|s| s.cost_evals).sum(),
        jacobian_evals: starts.iter().map(|s| s.jacobian_evals).sum(),
        wall_time_s: t0.elapsed().as_secs_f64(),
        termination,
        converged,
        starts,
        robust: (config.robust != RobustKind::None).then(|| RobustRecord {
            kind: config.robust,
            scale: results
                .iter()
                .map(|r| r.robust.map_or(f64::NAN, |x| x.0))
                .collect(),
            scale_source: if config.robust_scale.is_some() {
                "given".into()
            } else {
                "auto".into()
            },
            plain_stage_loss: results
                .iter()
                .filter_map(|r| r.robust.and_then(|x| x.1))
                .collect(),
            objective: results.iter().map(|r| (2.0 * r.best.cost).sqrt()).collect(),
        }),
        active_bounds,
        albedo_max: config.albedo_max,
        max_albedo: Some(max_albedo).filter(|v| v.is_finite()),
    };
    Ok(FitResult { fitted, record })
}

/// [`fit`] on the valid cells of a table.
pub fn fit_table(
    model: &dyn Model,
    table: &MerlTable,
    config: &FitConfig,
    observer: Option<Arc<dyn FitObserver>>,
) -> Result<FitResult, FitError> {
    let data = FitData::from_table(table)?;
    fit(model, &data, config, observer)
}
