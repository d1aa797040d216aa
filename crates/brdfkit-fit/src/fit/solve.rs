//! One start's solver run ([`run_start`]) and a subsample stage of a start
//! ([`sub_stage`]): the configured argmin solver from a point to where it stops, with
//! the termination in words.

use crate::config::{FitConfig, SolverKind};
use crate::error::FitError;
use crate::lm::{GaussNewtonLs, LevenbergMarquardt, LmMemory, LsState, Stall};
use crate::observer::Bridge;
use crate::problem::{FitProblem, NormalEquations};
use crate::record::WarmUpRecord;
use argmin::core::observers::ObserverMode;
use argmin::core::{Executor, IterState, State, TerminationReason};
use argmin::solver::linesearch::MoreThuenteLineSearch as MoreThuente;
use argmin::solver::neldermead::NelderMead;
use argmin::solver::quasinewton::LBFGS;
use argmin::solver::trustregion::{Steihaug, TrustRegion};
use brdfkit_core::progress::Observe;
use nalgebra::{DMatrix, DVector};
use std::sync::Arc;

/// The outcome of one start.
#[derive(Debug, Clone)]
pub(super) struct Outcome {
    pub(super) u: DVector<f64>,
    pub(super) cost: f64,
    pub(super) iterations: u64,
    pub(super) cost_evals: u64,
    pub(super) jac_evals: u64,
    pub(super) termination: String,
    pub(super) converged: bool,
    pub(super) warm: Option<WarmUpRecord>,
    pub(super) explore: Option<WarmUpRecord>,
    /// A Levenberg-Marquardt run that stopped at the early tolerance: its damping, to
    /// go on from exactly ([`LmRun`]).
    pub(super) early: Option<LmMemory>,
}

/// How a Levenberg-Marquardt run begins and ends beyond the config: an early, looser
/// ftol to stop at (see [`LevenbergMarquardt::stopping_early`]), and the damping of a
/// run to go on from. Other solvers ignore it.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct LmRun {
    pub(super) early: Option<f64>,
    pub(super) resume: Option<LmMemory>,
}

/// Most solver runs of one warm-up when the starts are ranked (see `run_pass`).
const WARM_UP_ROUNDS: u64 = 4;

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
pub(super) fn run_on(
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
pub(super) fn run_start(
    problem: FitProblem<'_>,
    u0: DVector<f64>,
    config: &FitConfig,
    observer: Option<&Arc<dyn Observe>>,
    start: usize,
    channel: Option<usize>,
    warm_up: bool,
) -> Result<Outcome, FitError> {
    let at = Where {
        observer,
        start,
        channel,
        warm_up,
    };
    run_start_with(problem, u0, config, at, LmRun::default())
}

/// Who a run is: what its observer is told.
#[derive(Clone, Copy)]
pub(super) struct Where<'o> {
    pub(super) observer: Option<&'o Arc<dyn Observe>>,
    pub(super) start: usize,
    pub(super) channel: Option<usize>,
    pub(super) warm_up: bool,
}

/// [`run_start`] with an [`LmRun`].
pub(super) fn run_start_with(
    problem: FitProblem<'_>,
    u0: DVector<f64>,
    config: &FitConfig,
    at: Where<'_>,
    lm: LmRun,
) -> Result<Outcome, FitError> {
    let Where {
        observer,
        start,
        channel,
        warm_up,
    } = at;
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
    let mut early = None;
    let (u, cost, iters, term, evals) = match config.solver {
        SolverKind::Lm => {
            let lmr = LevenbergMarquardt::new(config.tau, tol)
                .stopping_early(lm.early)
                .subsample_tolerance(config.subsample_ftol)
                // Only a warm-up run (the one with the warm-up set's tolerance) extends
                // the steps its model under-predicts (`LevenbergMarquardt::extending`):
                // the exploration's runs rank the starts, and extended there they moved
                // three two-lobe Lafortune fits of the database to worse basins
                // (docs/performance.md, "Session 16").
                .extending(config.subsample_ftol.is_some())
                .resumed(lm.resume);
            let r = run!(lmr, LsState, |s: LsState| s.param(u0.clone()));
            early = r.solver.stopped_early.then(|| r.solver.memory());
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
        early,
    })
}

/// Where a sub-stage stopped: the outcome so far (counts of every run), its rounds and
/// the cost where its last round began. A sub-stage stopped at the early tolerance goes
/// on from here exactly ([`sub_stage_on`]).
#[derive(Debug, Clone)]
pub(super) struct SubStage {
    pub(super) w: Outcome,
    rounds: u64,
    round_start: f64,
}

impl SubStage {
    /// The stage's record on `problem`'s cells.
    pub(super) fn record(&self, problem: &FitProblem<'_>) -> WarmUpRecord {
        let w = &self.w;
        WarmUpRecord {
            cells: problem.num_residuals() / problem.channels().len(),
            iterations: w.iterations,
            cost_evals: w.cost_evals,
            jacobian_evals: w.jac_evals,
            final_loss: (2.0 * w.cost).sqrt(),
            termination: w.termination.clone(),
            rounds: self.rounds,
        }
    }
}

/// A start's run on a subsample (`problem`) from `u0`, stopping at the early ftol
/// `early` if given (see [`LmRun`]).
///
/// With `restart`, a run that stopped at the iteration cap is run again from where it
/// stopped (fresh damping), up to [`WARM_UP_ROUNDS`] runs, while it improves by more
/// than ftol: far from the answer (a nearly flat lobe) LM's damping grows and its
/// steps shrink; a fresh run takes the large steps a continuation on all cells would
/// otherwise take, at the subsample's cost, so a ranking sees where a start leads.
pub(super) fn sub_stage(
    problem: &FitProblem<'_>,
    u0: DVector<f64>,
    config: &FitConfig,
    at: Where<'_>,
    restart: bool,
    early: Option<f64>,
) -> Result<SubStage, FitError> {
    let lm = LmRun {
        early,
        resume: None,
    };
    let w = run_start_with(problem.clone(), u0, config, at, lm)?;
    let cost = w.cost;
    rounds(
        problem,
        SubStage {
            w,
            rounds: 1,
            round_start: cost,
        },
        config,
        at,
        restart,
        early,
    )
}

/// A sub-stage that stopped at the early ftol, gone on with the config's own
/// tolerances: its round resumed with the damping it stopped with (the rest of the
/// round's iteration cap), then the rounds as [`sub_stage`]'s. The steps are the ones
/// an uninterrupted run with the config's tolerances takes, so it ends where that
/// run ends. A sub-stage that did not stop early is returned as it is.
pub(super) fn sub_stage_on(
    problem: &FitProblem<'_>,
    s: SubStage,
    config: &FitConfig,
    at: Where<'_>,
    restart: bool,
) -> Result<SubStage, FitError> {
    let Some(memory) = s.w.early else {
        return Ok(s);
    };
    let m = config.get_max_iters();
    let in_round = s.w.iterations - m * (s.rounds - 1);
    let w = if in_round < m {
        let cfg = config.clone().max_iters(m - in_round)?;
        let lm = LmRun {
            early: None,
            resume: Some(memory),
        };
        run_on(&s.w, |u| run_start_with(problem.clone(), u, &cfg, at, lm))?
    } else {
        s.w
    };
    rounds(problem, SubStage { w, ..s }, config, at, restart, None)
}

/// The restarted rounds of a sub-stage from `s` (see [`sub_stage`]): another round
/// while the last one hit the iteration cap and (after the first) improved by more
/// than ftol.
fn rounds(
    problem: &FitProblem<'_>,
    mut s: SubStage,
    config: &FitConfig,
    at: Where<'_>,
    restart: bool,
    early: Option<f64>,
) -> Result<SubStage, FitError> {
    let m = config.get_max_iters();
    let ftol = config.get_tolerances().ftol;
    // A NaN gain stops too.
    let more = |s: &SubStage| {
        restart
            && s.rounds < WARM_UP_ROUNDS
            && !s.w.converged
            && s.w.iterations >= m * s.rounds
            && (s.rounds == 1 || s.round_start - s.w.cost > ftol * s.w.cost)
    };
    while more(&s) {
        let lm = LmRun {
            early,
            resume: None,
        };
        let r = run_on(&s.w, |u| run_start_with(problem.clone(), u, config, at, lm))?;
        s = SubStage {
            round_start: s.w.cost,
            w: r,
            rounds: s.rounds + 1,
        };
    }
    Ok(s)
}
