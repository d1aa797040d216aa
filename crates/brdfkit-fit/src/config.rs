//! [`FitConfig`]: everything a fit needs besides the model and the cells.

use crate::data::FitData;
use crate::error::FitError;
use crate::lm::Tolerances;
use crate::loss::{Loss, LossSet, RobustKind, Weighting};
use brdfkit_core::Model;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::fmt;
use std::str::FromStr;

/// The optimiser.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum SolverKind {
    /// Levenberg-Marquardt on the normal equations (this crate's argmin solver); the
    /// default.
    #[default]
    Lm,
    /// Gauss-Newton with argmin's backtracking (Armijo) line search.
    GaussNewton,
    /// argmin's trust-region method with the Steihaug subproblem and JᵀJ as Hessian.
    TrustRegion,
    /// argmin's L-BFGS (memory 7) with the Moré-Thuente line search.
    Lbfgs,
    /// argmin's Nelder-Mead simplex: no derivatives (a fallback for a model whose
    /// gradient is suspect).
    NelderMead,
}

brdfkit_core::named_choice!(SolverKind, "solver", {
    Lm => "lm",
    GaussNewton => "gauss-newton",
    TrustRegion => "trust-region",
    Lbfgs => "lbfgs",
    NelderMead => "nelder-mead",
});

impl SolverKind {
    /// Default iteration cap: derivative-free and first-order methods need many more
    /// (cheaper) iterations than the Newton-type ones.
    pub fn default_max_iters(&self) -> u64 {
        match self {
            SolverKind::Lm | SolverKind::GaussNewton => 200,
            SolverKind::TrustRegion => 500,
            SolverKind::Lbfgs => 2000,
            SolverKind::NelderMead => 5000,
        }
    }
}

/// How parameters couple across the colour channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Sharing {
    /// Albedo-like parameters per channel, lobe-shape parameters shared by the three
    /// channels (Ngan et al. 2005); one fit over all channels. The default.
    #[default]
    SharedShape,
    /// Three independent fits, one per channel, each with its own shape parameters.
    PerChannel,
}

brdfkit_core::named_choice!(Sharing, "sharing", {
    SharedShape => "shared-shape",
    PerChannel => "per-channel",
});

/// Options of a fit. Start from [`FitConfig::default`] and chain the builders; numeric
/// options are validated and return [`FitError::InvalidOption`] when out of range.
///
/// ```
/// use brdfkit_fit::{FitConfig, Loss, SolverKind};
/// let cfg = FitConfig::default()
///     .loss(Loss::Cbrt)
///     .solver(SolverKind::Lm)
///     .starts(8)?
///     .subsample(0.25, 7)?
///     .theta_d_max_deg(80.0)?;
/// assert_eq!(cfg.get_starts(), 8);
/// # Ok::<(), brdfkit_fit::FitError>(())
/// ```
///
/// The config (de)serialises with serde; absent fields take their defaults, and
/// [`fit`](crate::fit) re-checks every value ([`FitConfig::validate`]), so a config read
/// from a file gets the same errors as one built with the builders.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FitConfig {
    pub(crate) loss: Loss,
    pub(crate) weighting: Weighting,
    pub(crate) solver: SolverKind,
    pub(crate) sharing: Sharing,
    pub(crate) starts: usize,
    pub(crate) finish: usize,
    pub(crate) seed: u64,
    pub(crate) subsample: Option<f64>,
    pub(crate) theta_d_max: Option<f64>,
    /// θi and θo cutoff (radians); absent from serialised configs when unset.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) theta_max: Option<f64>,
    pub(crate) max_iters: Option<u64>,
    pub(crate) ftol: f64,
    /// The warm-up set's tolerance of a Levenberg-Marquardt run on it (set by the fit's
    /// pass, never by a user; see `LevenbergMarquardt::subsample_tolerance`).
    #[serde(skip)]
    pub(crate) subsample_ftol: Option<f64>,
    pub(crate) xtol: f64,
    pub(crate) gtol: f64,
    pub(crate) tau: f64,
    pub(crate) free: Vec<String>,
    pub(crate) fixed: Vec<String>,
    pub(crate) warm_up: Option<usize>,
    pub(crate) robust: RobustKind,
    pub(crate) robust_scale: Option<f64>,
    pub(crate) albedo_max: Option<f64>,
    pub(crate) full_iters: FullIters,
    pub(crate) explore_cells: Option<usize>,
    /// Absent from serialised configs at the library's default, all eight (configs
    /// written before the setting existed hash the same).
    #[serde(skip_serializing_if = "is_all")]
    pub(crate) losses: LossSet,
}

fn is_all(l: &LossSet) -> bool {
    *l == LossSet::All
}

impl Default for FitConfig {
    fn default() -> Self {
        let t = Tolerances::default();
        FitConfig {
            loss: Loss::Cbrt,
            weighting: Weighting::SolidAngle,
            solver: SolverKind::Lm,
            sharing: Sharing::SharedShape,
            starts: 1,
            finish: DEFAULT_FINISH,
            seed: 0,
            subsample: None,
            theta_d_max: None,
            theta_max: None,
            max_iters: None,
            ftol: t.ftol,
            subsample_ftol: None,
            xtol: t.xtol,
            gtol: t.gtol,
            tau: 1e-3,
            free: Vec::new(),
            fixed: Vec::new(),
            warm_up: Some(DEFAULT_WARM_UP_CELLS),
            robust: RobustKind::None,
            robust_scale: None,
            albedo_max: None,
            full_iters: FullIters::All,
            explore_cells: None,
            losses: LossSet::All,
        }
    }
}

/// The default exploration set of a ranked fit ([`crate::families::FitSettings`]'s;
/// see [`FitConfig::explore_cells`]): 1,024 cells, 4 per stratum of the 16 × 16 grid.
pub const DEFAULT_EXPLORE_CELLS: usize = 1024;

/// The default rule for the iterations over all fitted cells of a start that warmed
/// up ([`crate::families::FitSettings`]'s; see [`FitConfig::full_iters`]):
/// [`FullIters::Auto`], the warm-up optimum evaluated, not refined, for every model
/// whose subsample optimum holds.
pub const DEFAULT_FULL_ITERS: FullIters = FullIters::Auto;

/// The default number of starts ([`crate::families::FitSettings`]'s): eight, the
/// multi-start grid that finds the global optimum on the measured tables
/// (docs/fitting.md, "Multiple starts").
pub const DEFAULT_STARTS: usize = 8;

/// How many LM iterations on all fitted cells a start that warmed up takes (see
/// [`FitConfig::full_iters`]). Written `N`, `all` or `auto` ([`FromStr`], [`fmt::Display`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FullIters {
    /// At most n; `Cap(0)` only evaluates the warm-up optimum on all cells.
    Cap(u64),
    /// To convergence (the library default).
    All,
    /// `Cap(0)` for a model whose optimum on the warm-up subsample holds on all cells
    /// ([`Model::subsample_optimum_holds`]), `All` for the others (Ward with Dür's
    /// normalisation): the command line's default.
    Auto,
}

impl FullIters {
    /// The rule for `model`: `Auto` resolved, the others as they are.
    pub fn for_model(self, model: &dyn Model) -> FullIters {
        match self {
            FullIters::Auto if model.subsample_optimum_holds() => FullIters::Cap(0),
            FullIters::Auto => FullIters::All,
            other => other,
        }
    }

    /// The cap for `model` (None: to convergence).
    pub fn cap_for(self, model: &dyn Model) -> Option<u64> {
        match self.for_model(model) {
            FullIters::Cap(n) => Some(n),
            _ => None,
        }
    }
}

impl FromStr for FullIters {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "all" => Ok(FullIters::All),
            "auto" => Ok(FullIters::Auto),
            _ => s
                .parse()
                .map(FullIters::Cap)
                .map_err(|_| format!("'{s}': expected a number of iterations, 'all' or 'auto'")),
        }
    }
}

// In JSON as on the command line: `"0"`, `"all"`, `"auto"`.
impl Serialize for FullIters {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for FullIters {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d)?
            .parse()
            .map_err(serde::de::Error::custom)
    }
}

impl fmt::Display for FullIters {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FullIters::Cap(n) => write!(f, "{n}"),
            FullIters::All => f.write_str("all"),
            FullIters::Auto => f.write_str("auto"),
        }
    }
}

/// Default size of the warm-up subsample.
pub const DEFAULT_WARM_UP_CELLS: usize = 65_536;

/// Default number of starts finished on all fitted cells after the warm-up ranking
/// (see [`FitConfig::finish`]).
pub const DEFAULT_FINISH: usize = 1;

fn bad(option: &'static str, value: impl fmt::Display, reason: &str) -> FitError {
    FitError::InvalidOption {
        option,
        value: value.to_string(),
        reason: reason.into(),
    }
}

impl FitConfig {
    /// The loss to minimise (default `cbrt`).
    pub fn loss(mut self, l: Loss) -> Self {
        self.loss = l;
        self
    }

    /// The cell weights (default solid angle).
    pub fn weighting(mut self, w: Weighting) -> Self {
        self.weighting = w;
        self
    }

    /// The optimiser (default LM).
    pub fn solver(mut self, s: SolverKind) -> Self {
        self.solver = s;
        self
    }

    /// Shared shape parameters (default) or independent per-channel fits.
    pub fn sharing(mut self, s: Sharing) -> Self {
        self.sharing = s;
        self
    }

    /// Number of starts (≥ 1; start 0 is the model's own parameters, the others spread
    /// over the shape parameters; see [`crate::starts`]).
    pub fn starts(mut self, n: usize) -> Result<Self, FitError> {
        if n == 0 || n > 4096 {
            return Err(bad("starts", n, "must be in 1..=4096"));
        }
        self.starts = n;
        Ok(self)
    }

    /// How many starts are finished on all fitted cells (≥ 1; default
    /// [`DEFAULT_FINISH`] = 1).
    ///
    /// When a warm-up applies ([`warm_up`](Self::warm_up)) and there are more starts
    /// than this, every start first converges on an exploration subsample (stratified,
    /// an eighth of the warm-up's size, or the warm-up set itself when that eighth
    /// would be under 4096 cells; a run that hits the iteration cap is restarted from
    /// where it stopped, up to 4 runs, while it improves), the starts are ranked by the
    /// optimised loss over all fitted cells where they ended (one cost pass each), and
    /// only the best `n` go on, through the warm-up set, to all fitted cells; the
    /// others are recorded as not finished
    /// ([`StartRecord::finished`](crate::StartRecord::finished)). s starts then cost s
    /// explorations on the small set plus s cost passes plus `n` warm-ups and full-set
    /// fits, instead of s of each. `n` ≥ `starts`, or no warm-up, finishes every start
    /// (the behaviour before this option existed). The ranking is a heuristic: a start
    /// whose exploration ends in a worse basin is not finished, though a continuation
    /// on all cells might have left it (`docs/fitting.md` measures how often).
    pub fn finish(mut self, n: usize) -> Result<Self, FitError> {
        if n == 0 || n > 4096 {
            return Err(bad("finish", n, "must be in 1..=4096"));
        }
        self.finish = n;
        Ok(self)
    }

    /// Seed of the start spread and of the subsample.
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Fit on a stratified subsample of about `fraction` ∈ (0, 1] of the cells, drawn
    /// with `seed` (see [`crate::FitData::stratified_subsample`]). The record always
    /// reports the losses over all cells as well.
    pub fn subsample(mut self, fraction: f64, seed: u64) -> Result<Self, FitError> {
        if !(fraction > 0.0 && fraction <= 1.0) {
            return Err(bad("subsample", fraction, "must be in (0, 1]"));
        }
        self.subsample = (fraction < 1.0).then_some(fraction);
        self.seed = seed;
        Ok(self)
    }

    /// Leave out cells with θd above `deg` degrees (in (0, 90]).
    pub fn theta_d_max_deg(mut self, deg: f64) -> Result<Self, FitError> {
        if !(deg > 0.0 && deg <= 90.0) {
            return Err(bad("theta_d_max", deg, "must be in (0, 90] degrees"));
        }
        self.theta_d_max = (deg < 90.0).then_some(deg.to_radians());
        Ok(self)
    }

    /// Iteration cap per start (default per solver: [`SolverKind::default_max_iters`]).
    pub fn max_iters(mut self, n: u64) -> Result<Self, FitError> {
        if n == 0 {
            return Err(bad("max_iters", n, "must be at least 1"));
        }
        self.max_iters = Some(n);
        Ok(self)
    }

    /// Stopping tolerances (see [`Tolerances`]); each in [0, 1).
    pub fn tolerances(mut self, ftol: f64, xtol: f64, gtol: f64) -> Result<Self, FitError> {
        for (name, v) in [("ftol", ftol), ("xtol", xtol), ("gtol", gtol)] {
            if !(0.0..1.0).contains(&v) {
                return Err(bad(
                    match name {
                        "ftol" => "ftol",
                        "xtol" => "xtol",
                        _ => "gtol",
                    },
                    v,
                    "must be in [0, 1)",
                ));
            }
        }
        self.ftol = ftol;
        self.xtol = xtol;
        self.gtol = gtol;
        Ok(self)
    }

    /// LM's initial damping factor τ (μ₀ = τ · max diag JᵀJ), > 0.
    pub fn lm_tau(mut self, tau: f64) -> Result<Self, FitError> {
        if !(tau > 0.0 && tau.is_finite()) {
            return Err(bad("lm_tau", tau, "must be a positive number"));
        }
        self.tau = tau;
        Ok(self)
    }

    /// Frees parameters the model keeps fixed by default (`fit_by_default == false`).
    /// A name is a parameter (`eta.r`) or a per-channel group (`eta`: all three);
    /// checked against the model when the fit starts.
    pub fn free_params<S: Into<String>>(mut self, names: impl IntoIterator<Item = S>) -> Self {
        self.free.extend(names.into_iter().map(Into::into));
        self
    }

    /// Fixes parameters at the model's value (same naming as [`free_params`](Self::free_params)).
    pub fn fix_params<S: Into<String>>(mut self, names: impl IntoIterator<Item = S>) -> Self {
        self.fixed.extend(names.into_iter().map(Into::into));
        self
    }

    /// Warm-up: with `Some(n)`, each start first converges on a stratified, seeded
    /// subsample of about n cells and then continues on all fitted cells from there,
    /// whenever the fitted cells number more than 4n (coarse to fine: the far-from-the-
    /// answer iterations run on the cheap set; the last, quadratically convergent ones
    /// on the full set). `None` disables it. Default: Some(65 536); n ≥ 1000.
    pub fn warm_up(mut self, cells: Option<usize>) -> Result<Self, FitError> {
        if let Some(n) = cells
            && n < 1000
        {
            return Err(bad("warm_up", n, "must be at least 1000 cells (or none)"));
        }
        self.warm_up = cells;
        Ok(self)
    }

    /// A robust function on the residuals (see [`RobustKind`] for the formulas and
    /// `docs/fitting.md` for how it enters the solvers), with scale c in the units of
    /// the loss's transform t (a `cbrt` residual is a difference of cube roots).
    ///
    /// `scale: None` (the default) picks c from the data: every start is first fitted
    /// with the plain loss, then c = k · 1.4826 · median |e| over the cells and
    /// channels at the best plain start (k = 1.345 Huber, 2.385 Cauchy: 95 %
    /// efficiency under Gaussian noise; 1.4826 · median |e| estimates its standard
    /// deviation and ignores up to half the cells being outliers), floored at 1e-9 of
    /// the targets' RMS; then every start continues with the robust cost from where its
    /// plain fit ended. With `Some(c)` the robust cost is minimised from the starts
    /// directly. `RobustKind::None` is the plain loss (a scale is then an error).
    pub fn robust(mut self, kind: RobustKind, scale: Option<f64>) -> Result<Self, FitError> {
        if let Some(c) = scale {
            if !(c > 0.0 && c.is_finite()) {
                return Err(bad("robust_scale", c, "must be a positive finite number"));
            }
            if kind == RobustKind::None {
                return Err(bad(
                    "robust_scale",
                    c,
                    "a scale needs a robust loss (huber or cauchy)",
                ));
            }
        }
        self.robust = kind;
        self.robust_scale = scale;
        Ok(self)
    }

    /// Energy conservation as an option: with `Some(a)`, the fitted model's
    /// directional albedo ∫ f cos θo dωo stays ≤ a (normally 1) per channel, at a fixed
    /// set of incidence angles, through a penalty residual block (see
    /// [`crate::energy`]); `None` (the default) fits the data without it. This, not a
    /// bound on a raw parameter such as ρs, is what energy conservation means; the
    /// record's `max_albedo` reports the fitted model's largest albedo either way.
    /// a must be a positive finite number.
    pub fn albedo_max(mut self, a: Option<f64>) -> Result<Self, FitError> {
        if let Some(v) = a
            && !(v > 0.0 && v.is_finite())
        {
            return Err(bad("albedo_max", v, "must be a positive finite number"));
        }
        self.albedo_max = a;
        Ok(self)
    }

    /// Iterations over all fitted cells for a start that warmed up (a fit over more
    /// than 4 × the warm-up's cells): `Cap(n)` caps them at n; `Cap(0)` takes the
    /// start's warm-up optimum (converged on the stratified 65 536-cell subsample) and
    /// only evaluates it on all cells; `All` (the library default) iterates to
    /// convergence on all cells; `Auto` (the command line's default,
    /// [`DEFAULT_FULL_ITERS`]) is `Cap(0)` where the model's subsample optimum holds and
    /// `All` elsewhere. Measured on 15 measured tables (docs/fitting.md): the
    /// full-table loss of Cook-Torrance's `Cap(0)` is within 0.004 % of `All`'s, for
    /// about half the CPU time; every other default family's within 0.14 % on seven.
    /// Fits without a warm-up always converge on all fitted cells.
    pub fn full_iters(mut self, n: FullIters) -> Self {
        self.full_iters = n;
        self
    }

    /// Size of the exploration set of a ranked fit (see [`finish`](Self::finish)):
    /// `Some(n)` (n ≥ 256) draws n cells from the warm-up set when n is below its size
    /// (else the warm-up set is explored directly); `None` (the library default) an
    /// eighth of the warm-up set, or the warm-up set itself when that is under 4,096
    /// cells. The command line uses [`DEFAULT_EXPLORE_CELLS`] = 1,024: on 15 measured
    /// tables (docs/fitting.md) no full-table loss moved by more than 0.004 % against
    /// 8,192, at an eighth of the exploration's CPU time.
    pub fn explore_cells(mut self, n: Option<usize>) -> Result<Self, FitError> {
        if let Some(v) = n
            && v < 256
        {
            return Err(bad(
                "explore_cells",
                v,
                "must be at least 256 cells (or none)",
            ));
        }
        self.explore_cells = n;
        Ok(self)
    }

    /// The exploration set's size, if given (see [`FitConfig::explore_cells`]).
    pub fn get_explore_cells(&self) -> Option<usize> {
        self.explore_cells
    }

    /// The rule for full-set iterations after a warm-up (see [`FitConfig::full_iters`]).
    pub fn get_full_iters(&self) -> FullIters {
        self.full_iters
    }

    /// The albedo bound of an energy-conserving fit, if any.
    pub fn get_albedo_max(&self) -> Option<f64> {
        self.albedo_max
    }

    /// The warm-up subsample size for a fit over `cells` cells, if one is used.
    pub fn warm_up_cells_for(&self, cells: usize) -> Option<usize> {
        self.warm_up.filter(|&n| cells > 4 * n)
    }

    /// Leave out cells whose θi or θo exceeds `deg` degrees (in (0, 90]): the angular
    /// domain of the data as the fitting papers state it (Ngan et al. 2005: 80°). See
    /// [`crate::FitData::with_theta_max`].
    pub fn theta_max_deg(mut self, deg: f64) -> Result<Self, FitError> {
        if !(deg > 0.0 && deg <= 90.0) {
            return Err(bad("theta_max", deg, "must be in (0, 90] degrees"));
        }
        self.theta_max = (deg < 90.0).then_some(deg.to_radians());
        Ok(self)
    }

    /// The cells a fit under this config uses: `data` with the θd cutoff
    /// ([`theta_d_max_deg`](Self::theta_d_max_deg)) and the θi/θo cutoff
    /// ([`theta_max_deg`](Self::theta_max_deg)) applied; `None` when neither is set
    /// (use `data` itself, no copy).
    pub fn angular_domain(&self, data: &crate::FitData) -> Option<crate::FitData> {
        // One definition of the kept cells: the score's filter, which `fit` also uses.
        let f = CellFilter::of(self);
        (!f.keeps_all()).then(|| data.filter(f.predicate(data)))
    }

    /// Checks every value as the builders do (for configs made by deserialisation).
    pub fn validate(&self) -> Result<(), FitError> {
        let c = FitConfig::default();
        c.clone().starts(self.starts)?;
        c.clone().finish(self.finish)?;
        if let Some(f) = self.subsample {
            c.clone().subsample(f, self.seed)?;
        }
        if let Some(t) = self.theta_d_max {
            c.clone().theta_d_max_deg(t.to_degrees())?;
        }
        if let Some(t) = self.theta_max {
            c.clone().theta_max_deg(t.to_degrees())?;
        }
        if let Some(n) = self.max_iters {
            c.clone().max_iters(n)?;
        }
        c.clone().tolerances(self.ftol, self.xtol, self.gtol)?;
        c.clone().lm_tau(self.tau)?;
        c.clone().robust(self.robust, self.robust_scale)?;
        c.clone().albedo_max(self.albedo_max)?;
        c.clone().explore_cells(self.explore_cells)?;
        c.warm_up(self.warm_up)?;
        Ok(())
    }

    /// Which losses the fit's report computes: all eight (the library's default, as
    /// before the setting existed) or brdfkit's own four (the command line's default,
    /// `--losses own`: the published metrics cost a third of the report's pass) (see [`LossSet`]; a published metric that
    /// is the optimised loss is always reported).
    pub fn report_losses(mut self, set: LossSet) -> Self {
        self.losses = set;
        self
    }

    /// The losses the report computes, as asked ([`report_losses`](Self::report_losses)).
    pub fn get_report_losses(&self) -> LossSet {
        self.losses
    }

    /// The losses the report computes: as asked, and all eight when the optimised
    /// loss is a published metric.
    pub fn reported_losses(&self) -> LossSet {
        if Loss::PUBLISHED.contains(&self.loss) {
            LossSet::All
        } else {
            self.losses
        }
    }

    /// The loss.
    pub fn get_loss(&self) -> Loss {
        self.loss
    }
    /// The weighting.
    pub fn get_weighting(&self) -> Weighting {
        self.weighting
    }
    /// The solver.
    pub fn get_solver(&self) -> SolverKind {
        self.solver
    }
    /// The sharing mode.
    pub fn get_sharing(&self) -> Sharing {
        self.sharing
    }
    /// Number of starts.
    pub fn get_starts(&self) -> usize {
        self.starts
    }
    /// Number of starts finished on all fitted cells (see [`finish`](Self::finish)).
    pub fn get_finish(&self) -> usize {
        self.finish
    }
    /// The seed.
    pub fn get_seed(&self) -> u64 {
        self.seed
    }
    /// Subsample fraction, if any.
    pub fn get_subsample(&self) -> Option<f64> {
        self.subsample
    }
    /// θd cutoff in radians, if any.
    pub fn get_theta_d_max(&self) -> Option<f64> {
        self.theta_d_max
    }
    /// θi / θo cutoff in radians, if any.
    pub fn get_theta_max(&self) -> Option<f64> {
        self.theta_max
    }
    /// Effective iteration cap.
    pub fn get_max_iters(&self) -> u64 {
        self.max_iters.unwrap_or(self.solver.default_max_iters())
    }
    /// The robust function (`None`: plain least squares).
    pub fn get_robust(&self) -> RobustKind {
        self.robust
    }
    /// The robust scale, when given (`None`: automatic, or no robust function).
    pub fn get_robust_scale(&self) -> Option<f64> {
        self.robust_scale
    }
    /// The tolerances.
    pub fn get_tolerances(&self) -> Tolerances {
        Tolerances {
            ftol: self.ftol,
            xtol: self.xtol,
            gtol: self.gtol,
        }
    }
}

/// Which of a table's valid cells the losses are taken over: every filter of a
/// [`FitConfig`] that removes cells (the θd cutoff and the θi/θo cutoff). A fit's
/// `cells_full` set and a score's are this filter applied to the table's valid cells.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct CellFilter {
    /// Cells with θd above this angle (radians) are left out.
    pub theta_d_max: Option<f64>,
    /// Cells whose θi or θo exceeds this angle (radians) are left out.
    pub theta_max: Option<f64>,
}

impl CellFilter {
    /// The filter of a fit configuration.
    pub fn of(config: &FitConfig) -> CellFilter {
        CellFilter {
            theta_d_max: config.theta_d_max,
            theta_max: config.theta_max,
        }
    }

    /// True when the filter keeps every cell.
    pub fn keeps_all(&self) -> bool {
        *self == CellFilter::default()
    }

    /// Whether cell `m` of `data` passes.
    #[inline]
    pub fn keeps(&self, data: &FitData, m: usize) -> bool {
        self.predicate(data)(m)
    }

    /// The pass test of `data`'s cells, with the cutoff's cosine taken once rather than
    /// per cell.
    pub fn predicate<'a>(&self, data: &'a FitData) -> impl Fn(usize) -> bool + 'a {
        let (td, cos_max) = (self.theta_d_max, self.theta_max.map(f64::cos));
        let g = data.geometry();
        move |m| {
            td.is_none_or(|t| data.theta_d_at(m) <= t)
                // Compared through the cosines, as `FitData::with_theta_max` does.
                && cos_max.is_none_or(|c| g.wi_z[m] >= c && g.wo_z[m] >= c)
        }
    }

    /// The indices (into `data`) of the cells that pass, in order.
    pub fn indices(&self, data: &FitData) -> Vec<usize> {
        let keep = self.predicate(data);
        (0..data.len()).filter(|&m| keep(m)).collect()
    }

    /// The cells that pass (borrowed when the filter keeps all); an error when none
    /// does.
    pub fn apply<'a>(&self, data: &'a FitData) -> Result<Cow<'a, FitData>, FitError> {
        let cells = if self.keeps_all() {
            Cow::Borrowed(data)
        } else {
            Cow::Owned(data.filter(self.predicate(data)))
        };
        if cells.is_empty() {
            return Err(FitError::NoCells(format!(
                "{} cells, none within the angular cutoffs (θd, θi/θo)",
                data.len()
            )));
        }
        Ok(cells)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builders_validate() {
        let c = FitConfig::default();
        assert!(c.clone().starts(0).is_err());
        assert!(c.clone().finish(0).is_err());
        assert!(c.clone().finish(4097).is_err());
        assert_eq!(c.get_finish(), DEFAULT_FINISH);
        assert_eq!(c.clone().finish(3).unwrap().get_finish(), 3);
        let f: FitConfig = serde_json::from_str(r#"{"finish": 0}"#).unwrap();
        let e = f.validate().unwrap_err().to_string();
        assert!(e.contains("finish"), "{e}");
        assert!(c.clone().subsample(0.0, 1).is_err());
        assert!(c.clone().subsample(1.5, 1).is_err());
        assert!(c.clone().subsample(f64::NAN, 1).is_err());
        assert!(c.clone().theta_d_max_deg(95.0).is_err());
        assert!(c.clone().theta_max_deg(0.0).is_err());
        assert!(c.clone().theta_max_deg(90.5).is_err());
        assert_eq!(c.clone().theta_max_deg(90.0).unwrap().get_theta_max(), None);
        let t = c
            .clone()
            .theta_max_deg(80.0)
            .unwrap()
            .get_theta_max()
            .unwrap();
        assert!((t - 80f64.to_radians()).abs() < 1e-15);
        assert!(c.clone().max_iters(0).is_err());
        assert!(c.clone().tolerances(1.0, 0.0, 0.0).is_err());
        assert!(c.clone().lm_tau(-1.0).is_err());
        assert!(c.clone().warm_up(Some(10)).is_err());
        assert!(c.clone().robust(RobustKind::Huber, Some(0.0)).is_err());
        assert!(
            c.clone()
                .robust(RobustKind::Cauchy, Some(f64::NAN))
                .is_err()
        );
        assert!(c.clone().robust(RobustKind::None, Some(0.1)).is_err());
        let r = c.clone().robust(RobustKind::Huber, None).unwrap();
        assert_eq!(
            (r.get_robust(), r.get_robust_scale()),
            (RobustKind::Huber, None)
        );
        let d: FitConfig =
            serde_json::from_str(r#"{"robust": "cauchy", "robust_scale": 0.02}"#).unwrap();
        assert_eq!(d.get_robust(), RobustKind::Cauchy);
        assert!(d.validate().is_ok());
        let bad_r: FitConfig = serde_json::from_str(r#"{"robust_scale": -1}"#).unwrap();
        assert!(bad_r.validate().is_err());
        assert_eq!(
            c.clone().warm_up(None).unwrap().warm_up_cells_for(1 << 30),
            None
        );
        assert_eq!(
            c.warm_up_cells_for(100_000),
            None,
            "small sets need no warm-up"
        );
        assert_eq!(c.warm_up_cells_for(1_000_000), Some(DEFAULT_WARM_UP_CELLS));
        let e = c.clone().subsample(2.0, 0).unwrap_err().to_string();
        assert!(e.contains("subsample") && e.contains('2'), "{e}");
        let ok = c.subsample(1.0, 3).unwrap();
        assert_eq!(ok.get_subsample(), None, "a fraction of 1 is the full set");
        for s in SolverKind::ALL {
            assert_eq!(s.name().parse::<SolverKind>().unwrap(), s);
        }
        // Deserialised configs: defaults fill the gaps, validation catches bad values.
        let d: FitConfig = serde_json::from_str(r#"{"loss": "log", "starts": 4}"#).unwrap();
        assert_eq!(d.get_loss(), Loss::Log);
        assert_eq!(d.get_starts(), 4);
        assert!(d.validate().is_ok());
        let bad_cfg: FitConfig = serde_json::from_str(r#"{"starts": 0}"#).unwrap();
        assert!(bad_cfg.validate().is_err());
        assert!(serde_json::from_str::<FitConfig>(r#"{"stars": 3}"#).is_err());
    }

    #[test]
    fn full_iters_reads_and_writes_as_on_the_command_line() {
        for (text, v) in [
            ("0", FullIters::Cap(0)),
            ("12", FullIters::Cap(12)),
            ("all", FullIters::All),
            ("auto", FullIters::Auto),
        ] {
            assert_eq!(text.parse::<FullIters>(), Ok(v));
            assert_eq!(v.to_string(), text);
            let json = serde_json::to_string(&v).unwrap();
            assert_eq!(json, format!("\"{text}\""));
            assert_eq!(serde_json::from_str::<FullIters>(&json).unwrap(), v);
        }
        for bad in ["", "-1", "1.5", "All", "some"] {
            let e = bad.parse::<FullIters>().unwrap_err();
            assert!(e.contains(&format!("'{bad}'")), "{e}");
        }
        assert_eq!(FitConfig::default().get_full_iters(), FullIters::All);
    }

    #[test]
    fn auto_iterates_on_all_cells_only_where_the_subsample_optimum_does_not_hold() {
        use brdfkit_models::ward::{Normalization, Ward};
        let duer = Ward::default().with_normalization(Normalization::Duer);
        let sum = brdfkit_models::sum::Sum::new(vec![
            brdfkit_models::default_model("lambert").unwrap(),
            Box::new(duer.clone()),
        ])
        .unwrap();
        let ct = brdfkit_models::default_model("cook-torrance").unwrap();
        let cases: [(&dyn Model, FullIters); 5] = [
            (&duer, FullIters::All),
            (&sum, FullIters::All),
            (&Ward::default(), FullIters::Cap(0)),
            (
                &Ward::default().with_normalization(Normalization::Ward),
                FullIters::Cap(0),
            ),
            (ct.as_ref(), FullIters::Cap(0)),
        ];
        for (m, want) in cases {
            assert_eq!(FullIters::Auto.for_model(m), want, "{}", m.to_json());
            // Explicit rules are kept whatever the model.
            assert_eq!(FullIters::Cap(3).for_model(m), FullIters::Cap(3));
            assert_eq!(FullIters::All.cap_for(m), None);
        }
        assert_eq!(FullIters::Auto.cap_for(&duer), None);
        assert_eq!(FullIters::Auto.cap_for(&Ward::default()), Some(0));
    }
}
