//! One start's solver run ([`run_start`]) and a subsample stage of a start
//! ([`sub_stage`]): the configured argmin solver from a point to where it stops, with
//! the termination in words.

use crate::config::{FitConfig, SolverKind};
use crate::error::FitError;
use crate::lm::{GaussNewtonLs, LevenbergMarquardt, LsState, Stall};
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
pub(super) fn sub_stage(
    problem: &FitProblem<'_>,
    u0: DVector<f64>,
    config: &FitConfig,
    observer: Option<&Arc<dyn Observe>>,
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
