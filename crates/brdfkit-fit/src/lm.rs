//! Least-squares solvers on the normal equations, as argmin [`Solver`]s: a
//! Levenberg-Marquardt method (argmin has none) and Gauss-Newton with argmin's
//! backtracking line search; plus [`Stall`], a termination wrapper for argmin solvers
//! whose own stopping test never fires.
//!
//! Both work on [`NormalEquations`]: JᵀJ and Jᵀr come from one parallel pass over the
//! cells, so the m × m system is all they factor, whatever the number of residuals.

use crate::problem::{NormalEq, NormalEquations};
use argmin::core::{
    CostFunction, Error, Executor, Gradient, IterState, KV, LineSearch, Problem, Solver, State,
    TerminationReason, TerminationStatus,
};
use argmin::solver::linesearch::BacktrackingLineSearch;
use argmin::solver::linesearch::condition::ArmijoCondition;
use nalgebra::{DMatrix, DVector};

/// The state type of the least-squares solvers: parameter and gradient vectors.
pub type LsState = IterState<DVector<f64>, DVector<f64>, (), (), (), f64>;

/// What an argmin solver's `init` and `next_iter` return: the new state and the
/// key-values the iteration reports.
type Step<I = LsState> = Result<(I, Option<KV>), Error>;

/// Stopping tolerances shared by the solvers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    /// Relative cost decrease of an accepted step below which the fit has converged.
    pub ftol: f64,
    /// Step length, relative to ‖u‖ + xtol, below which the fit has converged.
    pub xtol: f64,
    /// Largest cosine between the residual vector and a Jacobian column,
    /// |Jᵀr|_q / (‖r‖ ‖J_q‖), below which the fit has converged (MINPACK's gtol).
    pub gtol: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            ftol: 1e-10,
            xtol: 1e-10,
            gtol: 1e-10,
        }
    }
}

/// MINPACK's gtol measure: max_q |g_q| / (‖r‖ · ‖J_q‖), with ‖r‖ = sqrt(2 cost) and
/// ‖J_q‖ = sqrt((JᵀJ)_qq). A column that is identically zero does not count.
fn gradient_cosine(ne: &NormalEq) -> f64 {
    let rn = (2.0 * ne.cost).sqrt();
    if rn == 0.0 {
        return 0.0;
    }
    (0..ne.jtr.len())
        .filter(|&q| ne.jtj[(q, q)] > 0.0)
        .map(|q| ne.jtr[q].abs() / (rn * ne.jtj[(q, q)].sqrt()))
        .fold(0.0, f64::max)
}

/// Marquardt's scaling D = diag(JᵀJ), each entry floored at 1e-12 of the largest: a
/// parameter with no influence at the current point (a lobe of zero albedo, a logit at
/// saturation) would otherwise get no damping and a singular system.
fn scaling(a: &DMatrix<f64>) -> DVector<f64> {
    let m = a.nrows();
    let max = max_diag(a);
    let floor = if max > 0.0 { 1e-12 * max } else { 1.0 };
    DVector::from_iterator(m, (0..m).map(|q| a[(q, q)].max(floor)))
}

/// The largest diagonal entry of `a` (0 for an empty or non-positive diagonal).
fn max_diag(a: &DMatrix<f64>) -> f64 {
    (0..a.nrows()).map(|q| a[(q, q)]).fold(0.0, f64::max)
}

/// Largest change of any reparameterised coordinate in one step. A Newton step can be
/// huge where the model is far from the data; taken whole, it drives a logit to
/// saturation (dx/du ≈ 0) where the parameter can never come back. e³ ≈ 20 is a big
/// move for a log parameter, and 0.05 → 0.5 for a logit one.
pub const MAX_STEP: f64 = 3.0;

/// Scales a step so no coordinate changes by more than [`MAX_STEP`]; returns the step
/// and whether it was cut.
///
/// A coordinate at a bound of its domain ([`NormalEquations::at_bound`]) that the step
/// moves further out is limited to ±[`MAX_STEP`] on its own and does not set the
/// scale: its Newton step grows like e^|u| (dx/du ≈ e^−|u|) while the cost is flat
/// along it, so scaling the whole step by it cut every other coordinate, and the step
/// counted as cut (the ftol rules ignore cut steps) however flat the cost was. On a
/// metal (ρd → 0, f0 → 1) LM then crept outward 3 units of u per iteration for up to
/// 200 iterations without ever stopping on ftol.
fn clip_step(h: DVector<f64>, outward_at_bound: impl Fn(usize) -> bool) -> (DVector<f64>, bool) {
    let sat: Vec<bool> = (0..h.len()).map(&outward_at_bound).collect();
    let m = (0..h.len())
        .filter(|&q| !sat[q])
        .map(|q| h[q].abs())
        .fold(0.0, f64::max);
    let cut = m > MAX_STEP;
    let mut h = if cut { h * (MAX_STEP / m) } else { h };
    for q in (0..h.len()).filter(|&q| sat[q]) {
        h[q] = h[q].clamp(-MAX_STEP, MAX_STEP);
    }
    (h, cut)
}

/// Whether coordinate q of u is at a bound of its domain and `h` moves it further out.
fn outward<O: NormalEquations>(
    problem: &Problem<O>,
    u: &DVector<f64>,
    h: &DVector<f64>,
    q: usize,
) -> bool {
    h[q] * u[q] > 0.0
        && problem
            .problem
            .as_ref()
            .is_some_and(|p| p.at_bound(q, u[q]))
}

/// The length α, in steps, of step h's extension along its own direction: the
/// minimiser of the parabola φ(α) with φ(0) = F(u) = `f0`, φ'(0) = hᵀJᵀr = `slope` and
/// φ(1) = F(u + h) = `f1` (none when the cost does not curve upwards along h: then
/// [`EXTEND_MAX`]), at most [`EXTEND_MAX`] and no further than any coordinate may move
/// in one step ([`MAX_STEP`]); `None` when that is not at least twice the step.
fn extension(f0: f64, slope: f64, f1: f64, h: &DVector<f64>) -> Option<f64> {
    let curvature = 2.0 * (f1 - f0 - slope);
    let alpha = if curvature > 0.0 {
        -slope / curvature
    } else {
        EXTEND_MAX
    };
    let alpha = alpha.min(EXTEND_MAX).min(MAX_STEP / h.amax());
    (alpha >= 2.0).then_some(alpha)
}

/// The accepted step from `at` (u and its normal equations) to `to` (u + h and its),
/// extended along h to [`extension`]'s length when the cost there is lower; else `to`.
/// One cost pass, and one normal-equation pass when the extension is taken.
fn extended<O>(
    problem: &mut Problem<O>,
    at: (&DVector<f64>, &NormalEq),
    h: &DVector<f64>,
    to: (DVector<f64>, NormalEq),
) -> Result<(DVector<f64>, NormalEq), Error>
where
    O: NormalEquations + CostFunction<Param = DVector<f64>, Output = f64>,
{
    let (u, ne) = at;
    let Some(alpha) = extension(ne.cost, h.dot(&ne.jtr), to.1.cost, h) else {
        return Ok(to);
    };
    let ux = u + h * alpha;
    let fx = problem.cost(&ux)?;
    // A NaN cost is not lower either.
    if fx.partial_cmp(&to.1.cost) != Some(std::cmp::Ordering::Less) {
        return Ok(to);
    }
    let nex = problem.problem("jacobian_count", |p| p.normal_equations(&ux))?;
    Ok((ux, nex))
}

/// Solves (A + μ D) h = −g by Cholesky; `None` when the matrix is not numerically
/// positive definite (the caller raises μ).
fn damped_step(
    a: &DMatrix<f64>,
    g: &DVector<f64>,
    d: &DVector<f64>,
    mu: f64,
) -> Option<DVector<f64>> {
    let mut m = a.clone();
    for q in 0..m.nrows() {
        m[(q, q)] += mu * d[q];
    }
    let ch = m.cholesky()?;
    let h = ch.solve(&(-g));
    h.iter().all(|v| v.is_finite()).then_some(h)
}

/// The normal equations at the start point, which must have a finite cost.
fn start<O: NormalEquations>(
    problem: &mut Problem<O>,
    state: &LsState,
    solver: &str,
) -> Result<(DVector<f64>, NormalEq), Error> {
    let u = state
        .get_param()
        .cloned()
        .ok_or_else(|| Error::msg(format!("{solver} needs a start point")))?;
    let ne = problem.problem("jacobian_count", |p| p.normal_equations(&u))?;
    if !ne.cost.is_finite() {
        return Err(Error::msg("the cost at the start point is not finite"));
    }
    Ok((u, ne))
}

/// The current point and its normal equations, taken out of the state and the solver.
fn resume(
    state: &mut LsState,
    slot: &mut Option<NormalEq>,
    solver: &str,
) -> Result<(DVector<f64>, NormalEq), Error> {
    let u = state
        .take_param()
        .ok_or_else(|| Error::msg(format!("{solver} lost its parameter")))?;
    let ne = slot.take().ok_or_else(|| Error::msg("not initialised"))?;
    Ok((u, ne))
}

/// Moves the state to `u` with its normal equations `ne` (kept for the next iteration
/// and the stop tests); with the gradient when `u` is a new point.
fn settle(
    slot: &mut Option<NormalEq>,
    state: LsState,
    u: DVector<f64>,
    ne: NormalEq,
    new: bool,
) -> LsState {
    let state = state.param(u).cost(ne.cost);
    let state = if new {
        state.gradient(ne.jtr.clone())
    } else {
        state
    };
    *slot = Some(ne);
    state
}

/// The stop tests both solvers share: a failure, a rule that fired in the iteration,
/// the cost at the round-off floor, or gtol.
fn stop_tests(
    failed: Option<&'static str>,
    criterion: &mut Option<&'static str>,
    ne: Option<&NormalEq>,
    state: &LsState,
    gtol: f64,
) -> TerminationStatus {
    if let Some(why) = failed {
        return TerminationStatus::Terminated(TerminationReason::SolverExit(why.into()));
    }
    if criterion.is_some() {
        return TerminationStatus::Terminated(TerminationReason::SolverConverged);
    }
    if let Some(ne) = ne {
        if ne.cost <= state.get_problem_floor() {
            *criterion = Some("cost at the round-off floor of a perfect fit");
            return TerminationStatus::Terminated(TerminationReason::SolverConverged);
        }
        if gradient_cosine(ne) <= gtol {
            *criterion = Some("gradient orthogonal to the residuals (gtol)");
            return TerminationStatus::Terminated(TerminationReason::SolverConverged);
        }
    }
    TerminationStatus::NotTerminated
}

/// The [`Solver`] impl of a normal-equation solver `$solver` (fields `ne`, `failed`,
/// `criterion`, `tol`): `init` evaluates the normal equations at the start point and
/// calls the solver's `started`, `next_iter` is its `iterate`, `terminate` the shared
/// stop tests.
macro_rules! normal_equation_solver {
    ($solver:ty, $name:literal, [$($bound:tt)+]) => {
        impl<O> Solver<O, LsState> for $solver
        where
            O: $($bound)+,
        {
            fn name(&self) -> &str {
                $name
            }

            fn init(
                &mut self,
                problem: &mut Problem<O>,
                state: LsState,
            ) -> Step {
                let (u, ne) = start(problem, &state, $name)?;
                self.started(&ne);
                Ok((settle(&mut self.ne, state, u, ne, true), None))
            }

            fn next_iter(
                &mut self,
                problem: &mut Problem<O>,
                state: LsState,
            ) -> Step {
                self.iterate(problem, state)
            }

            fn terminate(&mut self, state: &LsState) -> TerminationStatus {
                let ne = self.ne.as_ref();
                stop_tests(self.failed, &mut self.criterion, ne, state, self.tol.gtol)
            }
        }
    };
}

/// Levenberg-Marquardt with Marquardt's diagonal scaling and Nielsen's damping update.
///
/// Iteration (Madsen, Nielsen & Tingleff, *Methods for Non-Linear Least Squares
/// Problems*, 2nd ed. 2004, Algorithm 3.16; scaling after Moré, "The Levenberg-Marquardt
/// algorithm: implementation and theory", 1978):
///
/// 1. Solve (JᵀJ + μ D) h = −Jᵀr, D = diag(JᵀJ) (floored, see `scaling`).
/// 2. Gain ratio ρ = (F(u) − F(u + h)) / (L(0) − L(h)), with the predicted decrease
///    L(0) − L(h) = ½ hᵀ(μ D h − Jᵀr).
/// 3. ρ > 0: accept, μ ← μ · max(1/3, 1 − (2ρ − 1)³), ν ← 2, and form the normal
///    equations at the new point. Otherwise μ ← μ ν, ν ← 2ν and solve again.
///
/// Steps are clipped to [`MAX_STEP`] per coordinate. A trial after an accepted step
/// is evaluated with the full normal equations (it is usually accepted, and then they
/// are needed anyway); a trial after a rejection with a cost pass only.
///
/// μ starts at τ · max diag(JᵀJ). One argmin iteration is one accepted step (with the
/// rejected trials it took); it stops when
/// - the cost is at the round-off floor of a perfect fit ([`NormalEquations::cost_floor`]),
/// - the gradient is orthogonal to the residuals to `gtol` (cosine test),
/// - an accepted step reduced the cost by less than `ftol` relative, or the
///   lightly damped (μ ≤ max diag JᵀJ) model predicts less than that for the next,
/// - the step is below `xtol` relative to ‖u‖,
/// - or (a failure) μ grows past 1e30 · max diag without a descent step.
#[derive(Debug, Clone)]
pub struct LevenbergMarquardt {
    tau: f64,
    tol: Tolerances,
    mu: f64,
    nu: f64,
    ne: Option<NormalEq>,
    /// Which rule stopped the solver.
    pub criterion: Option<&'static str>,
    failed: Option<&'static str>,
    last_accepted: bool,
    /// A looser ftol at which to stop early (see [`LevenbergMarquardt::stopping_early`]).
    early: Option<f64>,
    /// The damping to begin with instead of τ's (see [`LevenbergMarquardt::resumed`]).
    resume: Option<LmMemory>,
    /// True when the run stopped at the early tolerance, not at ftol.
    pub stopped_early: bool,
    /// A subsample's tolerance (see [`LevenbergMarquardt::subsample_tolerance`]).
    subsample: Option<f64>,
    /// The cost decreases of the last two accepted steps of this run, the latest first.
    decreases: [Option<f64>; 2],
    /// Whether an accepted step the Gauss-Newton model badly under-predicted is
    /// extended along its direction (see [`LevenbergMarquardt::extending`]).
    extend: bool,
}

/// The damping state of a Levenberg-Marquardt run: with it, a run that stopped can be
/// continued step for step as if it had not (see [`LevenbergMarquardt::resumed`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmMemory {
    mu: f64,
    nu: f64,
    last_accepted: bool,
    decreases: [Option<f64>; 2],
}

/// The words of a stop at the early tolerance.
pub const EARLY_STOP: &str = "cost decrease below the ranking's tolerance";

/// The words of a stop at a subsample's tolerance.
pub const SUBSAMPLE_STOP: &str =
    "remaining cost decrease of a linear tail below the warm-up set's tolerance";

/// The gain ratio above which an accepted step is extended along its direction
/// ([`LevenbergMarquardt::extending`]). A gain ratio ρ of the Gauss-Newton step puts
/// the parabola's minimiser at α = 1 / (2 − ρ) steps: 1.75 is a step 4 times as long.
/// Why not lower: an extension costs a cost pass and a normal-equation pass (the
/// trial's is discarded), about two iterations; from ρ = 1.5 (α ≈ 2.7) it was taken
/// every other step of Cook-Torrance's warm-up on MERL's brass and saved one
/// iteration of 11, making the warm-up 27 % slower.
pub const EXTEND_GAIN: f64 = 1.75;

/// The longest extension, in steps. The parabola is fitted to the cost at α = 0 and
/// α = 1 only, so a longer reach would trust it far outside its data; the cost is
/// then tested there, and the step kept when it is not lower.
pub const EXTEND_MAX: f64 = 16.0;

/// How far apart (relative) two successive ratios of cost decreases may be for the
/// run to count as on a steady linear tail ([`LevenbergMarquardt::subsample_tolerance`]).
pub const TAIL_RATIO_SPREAD: f64 = 0.1;

impl LevenbergMarquardt {
    /// With the initial damping factor τ (1e-3 for a start believed close; 1 when far).
    pub fn new(tau: f64, tol: Tolerances) -> Self {
        LevenbergMarquardt {
            tau,
            tol,
            mu: 0.0,
            nu: 2.0,
            ne: None,
            criterion: None,
            failed: None,
            last_accepted: true,
            early: None,
            resume: None,
            stopped_early: false,
            subsample: None,
            decreases: [None, None],
            extend: false,
        }
    }

    /// Also extends an accepted, unclipped step h whose gain ratio passes
    /// [`EXTEND_GAIN`] along its own direction, to the minimiser of the parabola
    /// through F(u), the slope hᵀJᵀr and F(u + h).
    ///
    /// Why: on a large-residual problem the Gauss-Newton Hessian JᵀJ misses the
    /// second-order term Σ rᵢ∇²rᵢ, which can cancel most of the curvature along a
    /// valley. The damping is then already ≈ 0, every step is the Gauss-Newton step,
    /// and every step gains about twice what its model predicted (gain ratio ≈ 1.95):
    /// the steps are an order of magnitude too short, and the run crawls along the
    /// valley on a linear tail. Plausible-Phong on MERL's steel took 240 warm-up
    /// iterations so, each lowering the cost by a factor ≈ 0.9 less than the last.
    /// Dennis, Gay & Welsch's NL2SOL (ACM TOMS 7, 1981) model that term by secant
    /// updates; a line search along the accepted step (Nocedal & Wright, *Numerical
    /// Optimization*, 2nd ed., §3.5, the interpolating step) costs one cost pass and
    /// leaves the LM iteration itself as it was.
    pub fn extending(mut self, on: bool) -> Self {
        self.extend = on;
        self
    }

    /// Also stops, as converged ([`SUBSAMPLE_STOP`]), on a run on a subsample whose
    /// optimum the cells it samples only evaluate or refine (the fit's warm-up set; the
    /// tolerance: `fit::pass::warm_up_ftol`) where the run is on a linear tail whose
    /// remaining decrease is estimated below `ftol` of the cost: the last three accepted
    /// (unclipped) steps lowered the cost by a₂, a₁, a₀ with ratios q = a₀/a₁ and
    /// q' = a₁/a₂ both in (0, 1) and within [`TAIL_RATIO_SPREAD`] of each other, and
    /// the geometric tail a₀ q / (1 − q) (Aitken's estimate of a linearly converging
    /// sequence's remaining sum) is at most `ftol` · F.
    ///
    /// Why not a small decrease alone (MINPACK's ftol test: actual and predicted
    /// decrease ≤ ftol, gain ratio ≤ 2; Moré, Garbow & Hillstrom, MINPACK-1 `lmder`):
    /// a warm-up can begin with steps of 1e-9 of the cost that grow threefold a step as
    /// μ falls (two-lobe Lafortune on RGL's aurora_white, whose warm-up then lowered the
    /// cost by 6 %), or zigzag through a non-quadratic valley with gain ratios from 1 to
    /// 200 and decreases from 6e-7 to 2e-4 of the cost in consecutive steps (paper_red),
    /// where a looser ftol stopped it 1.1 % above. The Gauss-Newton tail of a
    /// large-residual problem (gain ratio ≈ 1.9 step after step) shrinks by a steady
    /// factor, and the estimate holds there.
    pub fn subsample_tolerance(mut self, ftol: Option<f64>) -> Self {
        self.subsample = ftol.filter(|&e| e > self.tol.ftol);
        self
    }

    /// Whether an accepted step's decrease `dec` of `cost` ends a steady linear tail
    /// whose remaining decrease is below the subsample tolerance (see
    /// [`subsample_tolerance`](Self::subsample_tolerance)).
    fn subsample_stop(&mut self, dec: f64, cost: f64) -> bool {
        let [Some(a1), Some(a2)] = self.decreases else {
            return false;
        };
        let (q, q1) = (dec / a1, a1 / a2);
        let steady = (0.0..1.0).contains(&q)
            && (0.0..1.0).contains(&q1)
            && (q - q1).abs() <= TAIL_RATIO_SPREAD * q.max(q1);
        let hit = steady
            && self
                .subsample
                .is_some_and(|e| dec * q / (1.0 - q) <= e * cost);
        if hit {
            self.criterion = Some(SUBSAMPLE_STOP);
        }
        hit
    }

    /// Also stops where one of the two ftol rules holds at `ftol` (looser than the
    /// tolerances' own), saying so ([`EARLY_STOP`], `stopped_early`): the state is then
    /// exactly that of a run with the tolerances alone at that step, so
    /// [`resumed`](Self::resumed) with its [`memory`](Self::memory) goes on as that
    /// run would have.
    pub fn stopping_early(mut self, ftol: Option<f64>) -> Self {
        self.early = ftol.filter(|&e| e > self.tol.ftol);
        self
    }

    /// Begins with the damping of `memory` (a run that stopped) instead of τ's.
    pub fn resumed(mut self, memory: Option<LmMemory>) -> Self {
        self.resume = memory;
        self
    }

    /// The damping state now.
    pub fn memory(&self) -> LmMemory {
        LmMemory {
            mu: self.mu,
            nu: self.nu,
            last_accepted: self.last_accepted,
            decreases: self.decreases,
        }
    }

    /// μ = τ · max diag(JᵀJ) at the start point, or a resumed run's damping.
    fn started(&mut self, ne: &NormalEq) {
        if let Some(m) = self.resume.take() {
            (self.mu, self.nu, self.last_accepted) = (m.mu, m.nu, m.last_accepted);
            self.decreases = m.decreases;
            return;
        }
        let max = max_diag(&ne.jtj);
        self.mu = self.tau * if max > 0.0 { max } else { 1.0 };
        self.nu = 2.0;
    }

    /// Whether a decrease `dec` (predicted or actual) of `cost` is below the early
    /// tolerance while above ftol: then the run stops early, saying so.
    fn early_stop(&mut self, dec: f64, cost: f64) -> bool {
        let hit = self.early.is_some_and(|e| dec <= e * cost) && dec > self.tol.ftol * cost;
        if hit {
            self.criterion = Some(EARLY_STOP);
            self.stopped_early = true;
        }
        hit
    }

    /// One accepted step (with the rejected trials it took), or a stop.
    fn iterate<O>(&mut self, problem: &mut Problem<O>, mut state: LsState) -> Step
    where
        O: NormalEquations + CostFunction<Param = DVector<f64>, Output = f64>,
    {
        let (u, ne) = resume(&mut state, &mut self.ne, "Levenberg-Marquardt")?;
        let d = scaling(&ne.jtj);
        let maxd = d.max();
        let mut rejected = 0u64;
        loop {
            if self.mu > 1e30 * maxd.max(1e-300) {
                self.failed = Some("damping grew past 1e30 without a descent step");
                let kv = argmin::kv!("rejected" => rejected;);
                return Ok((settle(&mut self.ne, state, u, ne, false), Some(kv)));
            }
            let Some(h) = damped_step(&ne.jtj, &ne.jtr, &d, self.mu) else {
                self.mu *= self.nu;
                self.nu *= 2.0;
                rejected += 1;
                continue;
            };
            // A clipped step is a cut-down step: a small predicted or actual decrease
            // along it says the step was cut, not that the cost is flat there (a
            // Lafortune start with f ~ 1e99 "converged" at a loss of 5e33 on this
            // before the guard), so the ftol rules only judge unclipped steps.
            let (h, clipped) = clip_step(h.clone(), |q| outward(problem, &u, &h, q));
            let small = h.norm() <= self.tol.xtol * (u.norm() + self.tol.xtol);
            // Predicted decrease of the quadratic model, −hᵀg − ½ hᵀ(JᵀJ)h: valid for
            // the clipped step too (the closed form ½ hᵀ(μDh − g) is not).
            let pred = -h.dot(&ne.jtr) - 0.5 * h.dot(&(&ne.jtj * &h));
            if !clipped && pred >= 0.0 && pred <= self.tol.ftol * ne.cost && self.mu <= maxd {
                // The Gauss-Newton model (lightly damped: μ ≤ max diag) promises less
                // than ftol: converged, without paying for a trial pass (MINPACK's
                // ftol test uses the predicted reduction the same way).
                self.criterion = Some("predicted cost decrease below ftol");
                let kv = argmin::kv!("rejected" => rejected;);
                return Ok((settle(&mut self.ne, state, u, ne, false), Some(kv)));
            }
            if !clipped && pred >= 0.0 && self.mu <= maxd && self.early_stop(pred, ne.cost) {
                let kv = argmin::kv!("rejected" => rejected;);
                return Ok((settle(&mut self.ne, state, u, ne, false), Some(kv)));
            }
            let un = &u + &h;
            // After an accepted step the next trial is usually accepted too: evaluate
            // the normal equations there at once (one pass instead of a cost pass and
            // then a Jacobian pass). After a rejection, probe with the cheaper cost
            // pass until a step is accepted.
            let trial = if self.last_accepted {
                Some(problem.problem("jacobian_count", |p| p.normal_equations(&un))?)
            } else {
                None
            };
            let fnew = match &trial {
                Some(t) => t.cost,
                None => problem.cost(&un)?,
            };
            let actual = ne.cost - fnew;
            let rho = if pred > 0.0 { actual / pred } else { -1.0 };
            if fnew.is_finite() && rho > 0.0 {
                let t = 2.0 * rho - 1.0;
                self.mu *= (1.0f64 / 3.0).max(1.0 - t * t * t);
                self.nu = 2.0;
                self.last_accepted = true;
                let ne2 = match trial {
                    Some(t) => t,
                    None => problem.problem("jacobian_count", |p| p.normal_equations(&un))?,
                };
                let (un, ne2) = if self.extend && !clipped && rho > EXTEND_GAIN {
                    extended(problem, (&u, &ne), &h, (un, ne2))?
                } else {
                    (un, ne2)
                };
                let actual = ne.cost - ne2.cost;
                if small {
                    // MINPACK's xtol: tested on a step that was taken.
                    self.criterion = Some("step below xtol");
                } else if !clipped && actual <= self.tol.ftol * ne.cost {
                    self.criterion = Some("relative cost decrease below ftol");
                } else if !clipped && !self.subsample_stop(actual, ne.cost) {
                    self.early_stop(actual, ne.cost);
                }
                self.decreases = if clipped {
                    [None, None]
                } else {
                    [Some(actual), self.decreases[0]]
                };
                let kv = argmin::kv!("mu" => self.mu; "rejected" => rejected;);
                return Ok((settle(&mut self.ne, state, un, ne2, true), Some(kv)));
            }
            self.last_accepted = false;
            if small {
                // A rejected step this small: more damping only shrinks it further.
                self.criterion = Some("step below xtol");
                let kv = argmin::kv!("rejected" => rejected;);
                return Ok((settle(&mut self.ne, state, u, ne, false), Some(kv)));
            }
            self.mu *= self.nu;
            self.nu *= 2.0;
            rejected += 1;
        }
    }
}

normal_equation_solver!(
    LevenbergMarquardt,
    "Levenberg-Marquardt",
    [NormalEquations + CostFunction<Param = DVector<f64>, Output = f64>]
);

/// Access to the cost floor from a state (the solvers store it as the target cost).
trait FloorOf {
    fn get_problem_floor(&self) -> f64;
}

impl FloorOf for LsState {
    fn get_problem_floor(&self) -> f64 {
        // The executor is configured with target_cost = floor; argmin's own
        // TargetCostReached test uses the *best* cost, this one the current cost.
        self.get_target_cost()
    }
}

/// Gauss-Newton with a backtracking (Armijo) line search from argmin.
///
/// The direction solves JᵀJ h = −Jᵀr (with a Tikhonov term 1e-12 · max diag(JᵀJ)
/// on the diagonal so a parameter without influence does not make the system
/// singular); argmin's [`BacktrackingLineSearch`] with the Armijo condition (c = 1e-4,
/// step halving) then picks the step length along it, starting from 1. Stops on the
/// cost floor, gtol, ftol, xtol as [`LevenbergMarquardt`]; a line search that cannot
/// decrease the cost ends the run (SolverExit).
///
/// (argmin's own `GaussNewtonLS` needs the dense Jacobian — 4.4 M × m for a MERL
/// table, copied twice — and measures the line-search cost as ‖r‖ while it passes the
/// gradient of ½‖r‖²; this one shares the normal-equation pass with LM.)
#[derive(Debug, Clone)]
pub struct GaussNewtonLs {
    tol: Tolerances,
    ne: Option<NormalEq>,
    /// Which rule stopped the solver.
    pub criterion: Option<&'static str>,
    failed: Option<&'static str>,
}

impl GaussNewtonLs {
    /// With the given tolerances.
    pub fn new(tol: Tolerances) -> Self {
        GaussNewtonLs {
            tol,
            ne: None,
            criterion: None,
            failed: None,
        }
    }
}

impl GaussNewtonLs {
    /// Nothing to set up beyond the shared start.
    fn started(&mut self, _ne: &NormalEq) {}

    /// One step along the Gauss-Newton direction, its length from the line search.
    fn iterate<O>(&mut self, problem: &mut Problem<O>, mut state: LsState) -> Step
    where
        O: NormalEquations
            + CostFunction<Param = DVector<f64>, Output = f64>
            + Gradient<Param = DVector<f64>, Gradient = DVector<f64>>,
    {
        let (u, ne) = resume(&mut state, &mut self.ne, "Gauss-Newton")?;
        let m = ne.jtj.nrows();
        let maxd = max_diag(&ne.jtj);
        let ones = DVector::from_element(m, 1.0);
        let Some(h) = damped_step(&ne.jtj, &ne.jtr, &ones, 1e-12 * maxd.max(1e-300)) else {
            self.failed = Some("the Gauss-Newton system is not positive definite");
            return Ok((settle(&mut self.ne, state, u, ne, false), None));
        };
        let (h, _) = clip_step(h.clone(), |q| outward(problem, &u, &h, q));
        if h.norm() <= self.tol.xtol * (u.norm() + self.tol.xtol) {
            self.criterion = Some("step below xtol");
            return Ok((settle(&mut self.ne, state, u, ne, false), None));
        }
        let mut ls = BacktrackingLineSearch::new(ArmijoCondition::new(1e-4)?).rho(0.5)?;
        ls.search_direction(h);
        ls.initial_step_length(1.0)?;
        let inner = problem
            .take_problem()
            .ok_or_else(|| Error::msg("Gauss-Newton lost its problem"))?;
        let res = Executor::new(inner, ls)
            .configure(|s| {
                s.param(u.clone())
                    .gradient(ne.jtr.clone())
                    .cost(ne.cost)
                    .max_iters(40)
            })
            .ctrlc(false)
            .run()?;
        let mut lsp = res.problem;
        problem.problem = lsp.take_problem();
        problem.consume_func_counts(lsp);
        let ok = matches!(
            res.state.get_termination_reason(),
            Some(TerminationReason::SolverConverged)
        );
        let un = res.state.get_param().cloned().unwrap_or_else(|| u.clone());
        let fnew = res.state.get_cost();
        if !ok || fnew.is_nan() || fnew >= ne.cost {
            self.failed =
                Some("the line search found no decrease along the Gauss-Newton direction");
            return Ok((settle(&mut self.ne, state, u, ne, false), None));
        }
        let ne2 = problem.problem("jacobian_count", |p| p.normal_equations(&un))?;
        if ne.cost - ne2.cost <= self.tol.ftol * ne.cost {
            self.criterion = Some("relative cost decrease below ftol");
        }
        Ok((settle(&mut self.ne, state, un, ne2, true), None))
    }
}

normal_equation_solver!(
    GaussNewtonLs,
    "Gauss-Newton with line search",
    [NormalEquations
         + CostFunction<Param = DVector<f64>, Output = f64>
         + Gradient<Param = DVector<f64>, Gradient = DVector<f64>>]
);

/// Wraps an argmin solver and stops it when the best cost has not decreased by more
/// than `ftol` (relative) over `window` consecutive iterations, or has reached the
/// round-off floor. argmin's trust-region method has no working stop test of its own
/// (it runs to `max_iters`); a rejected trust-region step keeps the cost, so the
/// window must span several shrinking steps, not one.
#[derive(Debug, Clone)]
pub struct Stall<S> {
    inner: S,
    ftol: f64,
    window: usize,
    floor: f64,
    history: Vec<f64>,
    /// Which rule stopped the solver.
    pub criterion: Option<&'static str>,
}

impl<S> Stall<S> {
    /// Wraps `inner`.
    pub fn new(inner: S, ftol: f64, window: usize, floor: f64) -> Self {
        Stall {
            inner,
            ftol,
            window: window.max(1),
            floor,
            history: Vec::new(),
            criterion: None,
        }
    }
}

impl<O, S, I> Solver<O, I> for Stall<S>
where
    S: Solver<O, I>,
    I: State<Float = f64>,
{
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn init(&mut self, problem: &mut Problem<O>, state: I) -> Step<I> {
        self.inner.init(problem, state)
    }
    fn next_iter(&mut self, problem: &mut Problem<O>, state: I) -> Step<I> {
        self.inner.next_iter(problem, state)
    }
    fn terminate(&mut self, state: &I) -> TerminationStatus {
        let inner = self.inner.terminate(state);
        if inner.terminated() {
            return inner;
        }
        let best = state.get_best_cost();
        if best <= self.floor {
            self.criterion = Some("cost at the round-off floor of a perfect fit");
            return TerminationStatus::Terminated(TerminationReason::SolverConverged);
        }
        self.history.push(best);
        let n = self.history.len();
        if n > self.window {
            let old = self.history[n - 1 - self.window];
            if old - best <= self.ftol * old.abs() {
                self.criterion =
                    Some("best cost stalled (relative decrease below ftol over the window)");
                return TerminationStatus::Terminated(TerminationReason::SolverConverged);
            }
        }
        TerminationStatus::NotTerminated
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use argmin::core::Executor;

    /// Where [`LevenbergMarquardt::subsample_stop`] ends a sequence of accepted steps'
    /// decreases of a cost of 1 (the run's bookkeeping: each decrease joins the last
    /// two): the index of the stopping step, if any.
    fn tail_stop(eps: Option<f64>, decreases: &[f64]) -> Option<usize> {
        let tol = Tolerances {
            ftol: 1e-10,
            xtol: 1e-10,
            gtol: 1e-10,
        };
        let mut lm = LevenbergMarquardt::new(1e-3, tol).subsample_tolerance(eps);
        decreases.iter().position(|&d| {
            let hit = lm.subsample_stop(d, 1.0);
            lm.decreases = [Some(d), lm.decreases[0]];
            hit
        })
    }

    /// The warm-up set's tolerance stops a steady linear tail once its geometric
    /// remainder a₀ q / (1 − q) is below ε, and never a run whose decreases grow,
    /// zigzag, or shrink at changing rates, nor a run without the tolerance (or with
    /// one no looser than ftol).
    #[test]
    fn the_subsample_tolerance_stops_only_a_steady_linear_tail() {
        let geometric: Vec<f64> = (0..40).map(|k| 1e-3 * 0.8f64.powi(k)).collect();
        // a₀ · 0.8 / 0.2 ≤ 1e-6 first at a₀ ≤ 2.5e-7: 1e-3 · 0.8^k, k = 38.
        assert_eq!(tail_stop(Some(1e-6), &geometric), Some(38));
        assert_eq!(tail_stop(None, &geometric), None);
        assert_eq!(tail_stop(Some(1e-10), &geometric), None);
        let growing: Vec<f64> = (0..40).map(|k| 1e-12 * 3f64.powi(k)).collect();
        assert_eq!(tail_stop(Some(1e-6), &growing), None);
        let zigzag: Vec<f64> = (0..40)
            .map(|k| if k % 2 == 0 { 1e-9 } else { 2e-10 })
            .collect();
        assert_eq!(tail_stop(Some(1e-6), &zigzag), None);
        // Ratios 0.5, 0.8, 0.5, …: shrinking, but not at a steady rate.
        let uneven: Vec<f64> = (0..40)
            .scan(1e-6, |a, k| {
                *a *= if k % 2 == 0 { 0.5 } else { 0.8 };
                Some(*a)
            })
            .collect();
        assert_eq!(tail_stop(Some(1e-6), &uneven), None);
    }

    /// The cost ½‖r‖² of a test problem whose `rj` gives its residuals and Jacobian.
    macro_rules! half_square_cost {
        ($t:ident) => {
            impl CostFunction for $t {
                type Param = DVector<f64>;
                type Output = f64;
                fn cost(&self, u: &DVector<f64>) -> Result<f64, Error> {
                    Ok(0.5 * $t::rj(u).0.norm_squared())
                }
            }
        };
    }

    /// Rosenbrock as least squares: r = (10 (y − x²), 1 − x); minimum 0 at (1, 1).
    struct Rosen;
    impl Rosen {
        fn rj(u: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
            let (x, y) = (u[0], u[1]);
            let r = DVector::from_vec(vec![10.0 * (y - x * x), 1.0 - x]);
            let j = DMatrix::from_row_slice(2, 2, &[-20.0 * x, 10.0, -1.0, 0.0]);
            (r, j)
        }
    }
    /// The normal equations of a dense residual vector and Jacobian.
    fn dense_normal_eq((r, j): (DVector<f64>, DMatrix<f64>)) -> NormalEq {
        NormalEq {
            jtj: j.transpose() * &j,
            jtr: j.transpose() * &r,
            cost: 0.5 * r.norm_squared(),
        }
    }
    impl NormalEquations for Rosen {
        fn normal_equations(&self, u: &DVector<f64>) -> Result<NormalEq, Error> {
            Ok(dense_normal_eq(Rosen::rj(u)))
        }
    }
    half_square_cost!(Rosen);
    impl Gradient for Rosen {
        type Param = DVector<f64>;
        type Gradient = DVector<f64>;
        fn gradient(&self, u: &DVector<f64>) -> Result<DVector<f64>, Error> {
            let (r, j) = Rosen::rj(u);
            Ok(j.transpose() * r)
        }
    }

    /// Runs `solver` on Rosenbrock's function from (−1.2, 1) and asserts that it reached
    /// the minimum (1, 1) to 1e-8; returns the final state.
    fn solves_rosenbrock<S: Solver<Rosen, LsState>>(solver: S) -> LsState {
        let res = Executor::new(Rosen, solver)
            .configure(|s: LsState| s.param(DVector::from_vec(vec![-1.2, 1.0])).max_iters(200))
            .run()
            .unwrap();
        let u = res.state.get_best_param().unwrap();
        assert!(
            (u[0] - 1.0).abs() < 1e-8 && (u[1] - 1.0).abs() < 1e-8,
            "{u}"
        );
        res.state
    }

    #[test]
    fn lm_solves_rosenbrock() {
        let state = solves_rosenbrock(LevenbergMarquardt::new(1e-3, Tolerances::default()));
        assert_eq!(
            state.get_termination_reason(),
            Some(&TerminationReason::SolverConverged)
        );
        assert!(state.get_iter() < 100);
    }

    /// A run stopped at an early tolerance and resumed with its damping takes the
    /// uninterrupted run's steps: the same end point, bit for bit.
    #[test]
    fn lm_stopped_early_and_resumed_ends_where_an_uninterrupted_run_ends() {
        // From inside the domain, the cost falls toward its value at the bound by a
        // factor ≈ e⁻³ a step: a relative decrease that shrinks, as on a lobe collapsing.
        let run = |lm: LevenbergMarquardt, u: DVector<f64>| {
            Executor::new(AtBound, lm)
                .configure(|s: LsState| s.param(u).max_iters(200))
                .run()
                .unwrap()
        };
        let u0 = DVector::from_vec(vec![0.0, 0.0]);
        let tol = Tolerances::default();
        let whole = run(LevenbergMarquardt::new(1e-3, tol), u0.clone());
        let first = run(
            LevenbergMarquardt::new(1e-3, tol).stopping_early(Some(1e-2)),
            u0,
        );
        assert!(first.solver.stopped_early);
        assert_eq!(first.solver.criterion, Some(EARLY_STOP));
        assert!(first.state.get_iter() < whole.state.get_iter());
        let u1 = first.state.get_best_param().unwrap().clone();
        let memory = first.solver.memory();
        let second = run(LevenbergMarquardt::new(1e-3, tol).resumed(Some(memory)), u1);
        assert!(!second.solver.stopped_early);
        assert_eq!(second.state.get_best_param(), whole.state.get_best_param());
        assert_eq!(second.state.get_best_cost(), whole.state.get_best_cost());
        // One iteration more at most: a stop on the predicted decrease counts an
        // iteration without a step.
        assert!(first.state.get_iter() + second.state.get_iter() <= whole.state.get_iter() + 1);
    }

    /// The parabola through F(0) = 1, F'(0) = −2 and F(1) = 1 − 2 + c/2 has its
    /// minimum at α = 2 / c.
    #[test]
    fn the_extension_is_the_parabola_s_minimiser_within_its_limits() {
        let h = DVector::from_vec(vec![0.01, -0.02]);
        let f1 = |c: f64| 1.0 - 2.0 + 0.5 * c;
        assert_eq!(extension(1.0, -2.0, f1(0.25), &h), Some(8.0));
        // A cost that does not curve upwards along h: the longest extension.
        assert_eq!(extension(1.0, -2.0, f1(0.0), &h), Some(EXTEND_MAX));
        assert_eq!(extension(1.0, -2.0, f1(-1.0), &h), Some(EXTEND_MAX));
        // Farther than the parabola's reach or a step's reach allows: cut to them.
        assert_eq!(extension(1.0, -2.0, f1(0.01), &h), Some(EXTEND_MAX));
        let long = DVector::from_vec(vec![0.5, 0.0]);
        assert_eq!(extension(1.0, -2.0, f1(0.25), &long), Some(MAX_STEP / 0.5));
        // Less than twice the step: not worth a cost pass.
        assert_eq!(extension(1.0, -2.0, f1(1.5), &h), None);
        assert_eq!(
            extension(1.0, -2.0, f1(0.25), &DVector::from_vec(vec![2.0])),
            None
        );
    }

    /// A large-residual problem: r = (u, u²/2 − 0.9), minimum at u = 0 with r₁ = −0.9.
    /// There F'' = 1 − 0.9 = 0.1 while JᵀJ = 1: every Gauss-Newton step is a tenth of
    /// Newton's, gains ≈ 1.9 times its prediction, and the run converges linearly by a
    /// factor 0.9 a step.
    struct LargeResidual;
    impl LargeResidual {
        fn rj(u: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
            let x = u[0];
            let r = DVector::from_vec(vec![x, 0.5 * x * x - 0.9]);
            (r, DMatrix::from_column_slice(2, 1, &[1.0, x]))
        }
    }
    impl NormalEquations for LargeResidual {
        fn normal_equations(&self, u: &DVector<f64>) -> Result<NormalEq, Error> {
            Ok(dense_normal_eq(LargeResidual::rj(u)))
        }
    }
    half_square_cost!(LargeResidual);

    /// Extended steps reach the large-residual minimum in a few iterations where plain
    /// LM crawls on its linear tail, and both end at it.
    #[test]
    fn extended_steps_end_a_large_residual_crawl() {
        let run = |extend: bool| {
            let lm = LevenbergMarquardt::new(1e-3, Tolerances::default()).extending(extend);
            Executor::new(LargeResidual, lm)
                .configure(|s: LsState| s.param(DVector::from_vec(vec![0.5])).max_iters(500))
                .run()
                .unwrap()
        };
        let (plain, long) = (run(false), run(true));
        for r in [&plain, &long] {
            assert_eq!(
                r.state.get_termination_reason(),
                Some(&TerminationReason::SolverConverged)
            );
            let u = r.state.get_best_param().unwrap()[0];
            assert!(u.abs() < 1e-4, "{u}");
        }
        let (n_plain, n_long) = (plain.state.get_iter(), long.state.get_iter());
        assert!(n_plain > 60, "plain LM took {n_plain} iterations");
        assert!(n_long * 5 < n_plain, "{n_long} extended against {n_plain}");
        assert!(long.state.get_best_cost() <= plain.state.get_best_cost());
    }

    #[test]
    fn gauss_newton_solves_rosenbrock() {
        solves_rosenbrock(GaussNewtonLs::new(Tolerances::default()));
    }

    /// An optimum on a domain bound: x = σ(u₀) ∈ (0, 1) with r₀ = 1.5 − x (cost falls
    /// all the way to x = 1, where r₀ = 0.5) and r₁ = u₁ − 2. From u₀ = 21 (already at
    /// the bound, |u₀| > 20) u₀'s Newton step is ≈ 0.5 e^u₀; with it setting the clip's
    /// scale, every step was cut to 3 along u₀ and ~1e-8 along u₁, and no ftol rule
    /// ever judged a step.
    struct AtBound;
    impl AtBound {
        fn rj(u: &DVector<f64>) -> (DVector<f64>, DMatrix<f64>) {
            let (x, dx) = crate::reparam::Transform::Logit { lo: 0.0, hi: 1.0 }.forward(u[0]);
            let r = DVector::from_vec(vec![1.5 - x, u[1] - 2.0]);
            let j = DMatrix::from_row_slice(2, 2, &[-dx, 0.0, 0.0, 1.0]);
            (r, j)
        }
    }
    impl NormalEquations for AtBound {
        fn normal_equations(&self, u: &DVector<f64>) -> Result<NormalEq, Error> {
            Ok(dense_normal_eq(AtBound::rj(u)))
        }
        fn at_bound(&self, q: usize, u: f64) -> bool {
            q == 0 && u.abs() > crate::reparam::U_ACTIVE
        }
    }
    half_square_cost!(AtBound);

    #[test]
    fn lm_stops_on_ftol_with_a_coordinate_at_its_bound() {
        let res = Executor::new(
            AtBound,
            LevenbergMarquardt::new(1e-3, Tolerances::default()),
        )
        .configure(|s: LsState| s.param(DVector::from_vec(vec![21.0, 0.0])).max_iters(200))
        .run()
        .unwrap();
        let st = &res.state;
        let u = st.get_best_param().unwrap();
        assert_eq!(
            st.get_termination_reason(),
            Some(&TerminationReason::SolverConverged)
        );
        // u₁ takes (nearly, with LM's damping) its whole step at once, where it got
        // ~1e-8 of it per iteration before; u₀ moves out 3 a step until the cost is
        // flat to ftol (e^-u₀ below ~1e-10 of the cost): a handful of iterations.
        assert!((u[1] - 2.0).abs() < 1e-5, "{u}");
        assert!(u[0] > 21.0, "{u}");
        assert!(st.get_iter() <= 10, "{} iterations", st.get_iter());
        // The cost at the bound, 0.125, to round-off.
        assert!(
            (st.get_best_cost() - 0.125).abs() < 1e-9,
            "{}",
            st.get_best_cost()
        );
    }
}
