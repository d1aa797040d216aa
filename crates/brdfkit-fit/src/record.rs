//! The fit record: what was fitted, how, and how well. Serialises to JSON (see
//! `docs/fitting.md` for the field list).

use crate::config::{FitConfig, Sharing, SolverKind};
use crate::energy::AlbedoQuadrature;
use crate::fitted::Fitted;
use crate::loss::{Loss, LossReport, RobustKind, Weighting};
use crate::reparam::Transform;
use brdfkit_core::{Model, ParamRole};
use serde::{Deserialize, Serialize};

/// One parameter of the fitted model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamRecord {
    /// Name as in the model's parameter vector (`rho_d.r`, `alpha`).
    pub name: String,
    /// Fitted value (per-channel fits: the value of the fit of the channel this
    /// parameter belongs to, or of each channel for shared names, see
    /// [`FitRecord::model`]).
    pub value: f64,
    /// Value at start 0.
    pub start: f64,
    /// True when the fit moved it; false when it was held fixed.
    pub free: bool,
    /// The reparameterisation the solver used (`logit`, `log`, `neg-log`,
    /// `asinh`); `None` for a fixed parameter.
    pub transform: Option<String>,
    /// `"lower"` or `"upper"` when the fit drove this free parameter onto an end of its
    /// domain (the reparameterised coordinate past ±[`crate::reparam::U_ACTIVE`]: within
    /// e^-20 ≈ 2e-9 of the end, relative to a bounded interval's width); absent
    /// otherwise. A bound active at the optimum is a modelling claim the data pushed
    /// against (see [`FitRecord::active_bounds`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_bound: Option<String>,
}

/// A subsample stage of a start (the warm-up, or the exploration of a ranked fit): its
/// fit on that subsample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WarmUpRecord {
    /// Cells of the subsample.
    pub cells: usize,
    /// Iterations on it.
    pub iterations: u64,
    /// Cost passes over it.
    pub cost_evals: u64,
    /// Jacobian passes over it.
    pub jacobian_evals: u64,
    /// The optimised loss over the subsample's cells at its end.
    pub final_loss: f64,
    /// Why it stopped (its last solver run).
    pub termination: String,
    /// Solver runs: 1, or more when the starts were ranked and a run ended at the
    /// iteration cap while still improving (each further run starts where the last
    /// stopped; the counts above are their sums). Absent in older records: 1.
    #[serde(default = "one")]
    pub rounds: u64,
}

fn one() -> u64 {
    1
}

/// One start of one pass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StartRecord {
    /// Start index within its pass (0: the model's own parameters).
    pub index: usize,
    /// Channel of a per-channel pass (0, 1, 2), `None` for a shared fit.
    pub channel: Option<usize>,
    /// Starting values of the free parameters, in the order of
    /// [`FitRecord::free_params`] (of the pass).
    pub start: Vec<f64>,
    /// Final value of the optimised loss (weighted RMS over the fitted cells; for a
    /// per-channel pass, that channel's; with a robust loss sqrt(2F) of the robust
    /// cost F); `None` when the start failed (see `termination`).
    pub final_loss: Option<f64>,
    /// Iterations.
    pub iterations: u64,
    /// Cost evaluations (passes over the cells without derivatives).
    pub cost_evals: u64,
    /// Jacobian evaluations (passes with derivatives: normal equations or gradients).
    pub jacobian_evals: u64,
    /// Why it stopped.
    pub termination: String,
    /// True when a convergence test fired (not an iteration cap or a give-up).
    pub converged: bool,
    /// True for the start kept (the lowest final loss of its pass).
    pub kept: bool,
    /// The warm-up stage, when there was one (the counts above are then those of the
    /// stage on the fitted cells, which started where the warm-up ended).
    pub warm_up: Option<WarmUpRecord>,
    /// True when the start continued on all fitted cells; false for a start that
    /// stopped after its exploration because it did not rank among the best
    /// [`FitRecord::finish`] (its `final_loss` is then its `rank_loss`, its
    /// `iterations` 0 and its `cost_evals` the one ranking pass; see
    /// [`crate::FitConfig::finish`]). Records written before ranking existed finished
    /// every start (absent: true).
    #[serde(default = "yes")]
    pub finished: bool,
    /// The optimised loss over all fitted cells at the end of the start's exploration
    /// (its own subsample, `explore`, or the warm-up set), by which the starts were
    /// ranked; absent when there was no ranking (one start, no
    /// warm-up, or every start finished).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rank_loss: Option<f64>,
    /// The exploration stage of a ranked fit, when it ran on its own subsample (an
    /// eighth of the warm-up's size, see [`crate::FitConfig::finish`]): the start
    /// converged there (to the ranking's looser tolerance when there was a ranking to
    /// make; its `termination` then says so, and a finisher resumed it to the fit's own
    /// tolerance), was ranked, and if finished went on through `warm_up` to the
    /// fitted cells (`warm_up` is then absent for an unfinished start). Absent when the
    /// warm-up set was explored directly, or there was no ranking.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub explore: Option<WarmUpRecord>,
}

fn yes() -> bool {
    true
}

/// Iterations run, by stage, summed over every start of every pass: where a fit's
/// work went. A ranked fit explores each start on a small subsample, warms the
/// finishers up on a larger one and finishes on all fitted cells (see
/// [`crate::FitConfig::finish`]); a fit without a warm-up has only the finish.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct StageIterations {
    /// On the starts' exploration subsamples ([`StartRecord::explore`]).
    pub explore: u64,
    /// On the warm-up subsample ([`StartRecord::warm_up`]).
    pub warm_up: u64,
    /// On all fitted cells ([`StartRecord::iterations`]).
    pub finish: u64,
}

impl StageIterations {
    /// The sums over `starts`.
    pub fn of_starts(starts: &[StartRecord]) -> Self {
        let stage = |s: &Option<WarmUpRecord>| s.as_ref().map_or(0, |w| w.iterations);
        starts
            .iter()
            .fold(Self::default(), |acc, s| StageIterations {
                explore: acc.explore + stage(&s.explore),
                warm_up: acc.warm_up + stage(&s.warm_up),
                finish: acc.finish + s.iterations,
            })
    }

    /// Every iteration of every stage.
    pub fn total(&self) -> u64 {
        self.explore + self.warm_up + self.finish
    }

    /// `172 (explore 120 + warm-up 52 + finish 0)`: the total and where it was spent,
    /// as the command line's fit table and Python's `FitResult` print it.
    pub fn summary(&self) -> String {
        format!(
            "{} (explore {} + warm-up {} + finish {})",
            self.total(),
            self.explore,
            self.warm_up,
            self.finish
        )
    }
}

/// The robust stage of a fit (see [`crate::FitConfig::robust`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobustRecord {
    /// Which ρ.
    pub kind: RobustKind,
    /// The scale c of each pass (one for a shared fit, r, g, b for per-channel fits),
    /// in the units of the loss's transform.
    pub scale: Vec<f64>,
    /// `"given"`, or `"auto"` (k · 1.4826 · median |e| at the best plain start).
    pub scale_source: String,
    /// Per pass: the plain loss of the best start of the plain stage (auto scale only;
    /// empty otherwise), to compare with the robust fit's `losses_fit`.
    pub plain_stage_loss: Vec<f64>,
    /// Per pass: sqrt(2F) of the kept start, F = ½ Σ s² ρ(e²) the robust cost it
    /// minimised (the records' `final_loss` of a start is this same quantity).
    pub objective: Vec<f64>,
}

/// The whole record of a fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitRecord {
    /// The fitted model in the JSON contract (`{"model": ..., "params": {...}}`); for
    /// a per-channel fit `{"per_channel": [r, g, b]}` with one model per channel.
    pub model: serde_json::Value,
    /// The model family.
    pub family: String,
    /// The loss minimised.
    pub loss: Loss,
    /// The cell weights.
    pub weighting: Weighting,
    /// The solver.
    pub solver: SolverKind,
    /// Shared shape parameters or per-channel fits.
    pub sharing: Sharing,
    /// θd cutoff in degrees, if any. Written `theta_d_max`, the name of the setting in
    /// Python and the CLI (`--theta-d-max`, also degrees); older records' `theta_d_max_deg`
    /// still reads.
    #[serde(rename = "theta_d_max", alias = "theta_d_max_deg")]
    pub theta_d_max_deg: Option<f64>,
    /// θi / θo cutoff in degrees, if any (absent from records without one); written
    /// `theta_max` (older: `theta_max_deg`).
    #[serde(
        rename = "theta_max",
        alias = "theta_max_deg",
        default,
        skip_serializing_if = "Option::is_none"
    )]
    pub theta_max_deg: Option<f64>,
    /// Subsample fraction, if any; written `sample_fraction`, the setting's name (older:
    /// `subsample`).
    #[serde(rename = "sample_fraction", alias = "subsample")]
    pub subsample: Option<f64>,
    /// Seed of the starts and the subsample.
    pub seed: u64,
    /// Number of starts per pass: the `starts` setting (the record's `starts` is the
    /// list of those starts' records).
    pub starts_per_pass: usize,
    /// How many starts per pass were to be finished on all fitted cells after the
    /// warm-up ranking ([`crate::FitConfig::finish`]); absent in records written before
    /// ranking existed, which finished every start.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub finish: Option<usize>,
    /// Free parameters (shared fit) or the union over the channel passes.
    pub free_params: Vec<String>,
    /// Every model parameter: fitted value, start, free or fixed, transform.
    pub params: Vec<ParamRecord>,
    /// Cells the solver saw (after cutoff and subsample).
    pub cells_fit: usize,
    /// Valid cells after the cutoff (the "full table").
    pub cells_full: usize,
    /// Size of the warm-up subsample each start converged on first, if any.
    pub warm_up_cells: Option<usize>,
    /// After a warm-up, the iterations the finishers took on all fitted cells as the
    /// model resolved the rule ([`crate::FitConfig::full_iters`]): `"0"` (the warm-up
    /// optimum evaluated), a cap, or `"all"`; absent without a warm-up and in older
    /// records.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub full_iters: Option<crate::config::FullIters>,
    /// Every loss over the fitted cells.
    pub losses_fit: LossReport,
    /// Every loss over all valid cells (after the cutoff), the figure to compare.
    pub losses_full: LossReport,
    /// Iterations of the kept start(s) on the fitted cells, after any warm-up (summed
    /// over channel passes): 0 when the warm-up optimum was kept as it was (see
    /// `full_iters`); `iterations_run` has every stage.
    pub iterations: u64,
    /// Iterations of every start by stage (absent in older records: see
    /// [`FitRecord::stage_iterations`], which sums the starts then).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub iterations_run: Option<StageIterations>,
    /// Cost evaluations over the fitted cells, of every start and pass (warm-up passes
    /// are in each start's `warm_up`).
    pub cost_evals: u64,
    /// Jacobian evaluations over the fitted cells, of every start and pass.
    pub jacobian_evals: u64,
    /// Wall time of the whole fit, seconds.
    pub wall_time_s: f64,
    /// Why the kept start stopped (per-channel: `r: …; g: …; b: …`).
    pub termination: String,
    /// True when the kept start(s) converged.
    pub converged: bool,
    /// Every start tried.
    pub starts: Vec<StartRecord>,
    /// The robust stage, when a robust loss was asked for (absent in records of
    /// plain fits; `losses_fit` and `losses_full` are always the plain losses).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robust: Option<RobustRecord>,
    /// The parameters at an end of their domain at the optimum, as `name (lower end
    /// lo)` / `name (upper end hi)`; empty when none (absent in older records).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub active_bounds: Vec<String>,
    /// The bound on the directional albedo of an energy-conserving fit
    /// ([`crate::FitConfig::albedo_max`]); absent when the fit was unconstrained.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub albedo_max: Option<f64>,
    /// The fitted model's largest directional albedo over the channels and the
    /// incidence angles of [`crate::energy::AlbedoQuadrature`] (per-channel fits: over
    /// the three channel models); absent in older records.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_albedo: Option<f64>,
    /// The scattered samples the fit's cells were built from (absent for a MERL
    /// table and in older records): kind, rows, kept, dropped ([`crate::samples`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input: Option<crate::data::SampleInput>,
}

impl FitRecord {
    /// Iterations of every start by stage: the record's `iterations_run`, or the sums
    /// over its starts for a record written before that field existed.
    pub fn stage_iterations(&self) -> StageIterations {
        self.iterations_run
            .unwrap_or_else(|| StageIterations::of_starts(&self.starts))
    }
}

/// What the record keeps of one pass of a fit (all channels, or one).
pub(crate) struct PassSummary<'a> {
    /// The pass's fitted model.
    pub model: &'a dyn Model,
    /// The model-vector indices the pass freed, and their transforms.
    pub free: &'a [usize],
    pub transforms: &'a [Transform],
    /// The kept start's point in the solver's coordinates.
    pub u: &'a [f64],
    pub starts: &'a [StartRecord],
    /// The kept start's iterations on the fitted cells, termination, convergence, and
    /// optimised cost.
    pub iterations: u64,
    pub termination: &'a str,
    pub converged: bool,
    pub cost: f64,
    /// The pass's robust scale and, with an automatic one, the plain stage's loss.
    pub robust: Option<(f64, Option<f64>)>,
}

/// Everything a fit's record is assembled from.
pub(crate) struct RecordParts<'a> {
    /// The model the fit started from (start 0, the fixed parameters' values).
    pub start: &'a dyn Model,
    pub fitted: &'a Fitted,
    pub config: &'a FitConfig,
    /// The free parameters of the fit (the union over its passes).
    pub free: &'a [usize],
    pub passes: Vec<PassSummary<'a>>,
    pub cells_fit: usize,
    pub cells_full: usize,
    pub losses_fit: LossReport,
    pub losses_full: LossReport,
    pub wall_time_s: f64,
}

impl FitRecord {
    /// The record of a fit from its parts.
    pub(crate) fn assemble(p: RecordParts<'_>) -> FitRecord {
        let config = p.config;
        let params = param_records(&p);
        let starts: Vec<StartRecord> = p.passes.iter().flat_map(|r| r.starts.to_vec()).collect();
        let (termination, converged) = termination_of(&p.passes);
        let warm_up_cells = config.warm_up_cells_for(p.cells_fit);
        let specs = p.start.param_specs();
        FitRecord {
            model: p.fitted.to_json(),
            family: p.start.name().into(),
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
            free_params: p.free.iter().map(|&q| specs[q].name.clone()).collect(),
            active_bounds: active_bounds(&params, p.start),
            params,
            cells_fit: p.cells_fit,
            cells_full: p.cells_full,
            warm_up_cells,
            full_iters: warm_up_cells.map(|_| config.full_iters.for_model(p.start)),
            losses_fit: p.losses_fit,
            losses_full: p.losses_full,
            iterations: p.passes.iter().map(|r| r.iterations).sum(),
            iterations_run: Some(StageIterations::of_starts(&starts)),
            cost_evals: starts.iter().map(|s| s.cost_evals).sum(),
            jacobian_evals: starts.iter().map(|s| s.jacobian_evals).sum(),
            wall_time_s: p.wall_time_s,
            termination,
            converged,
            starts,
            robust: robust_record(config, &p.passes),
            albedo_max: config.albedo_max,
            max_albedo: Some(max_albedo(p.fitted)).filter(|v| v.is_finite()),
            input: None,
        }
    }
}

/// Every parameter's record. Per-channel fits: a channel parameter from its channel's
/// pass, a shared one from the green pass (the record's `model` holds all three).
fn param_records(p: &RecordParts<'_>) -> Vec<ParamRecord> {
    let x0 = p.start.params();
    p.start
        .param_specs()
        .iter()
        .enumerate()
        .map(|(q, s)| {
            let pass = match (s.role, p.passes.len()) {
                (_, 1) => 0,
                (ParamRole::Channel(c), _) => c,
                (ParamRole::Shared, _) => 1,
            };
            let r = &p.passes[pass];
            let k = r.free.iter().position(|&f| f == q);
            ParamRecord {
                name: s.name.clone(),
                value: r.model.params()[q],
                start: x0[q],
                free: k.is_some(),
                transform: k.map(|k| r.transforms[k].name().to_string()),
                at_bound: k
                    .and_then(|k| r.transforms[k].end_at(r.u[k]))
                    .map(String::from),
            }
        })
        .collect()
}

/// The parameters at an end of their domain, as `name (lower end lo)`.
fn active_bounds(params: &[ParamRecord], start: &dyn Model) -> Vec<String> {
    params
        .iter()
        .zip(&start.param_specs())
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
        .collect()
}

/// The kept start's termination and convergence (per-channel: `r: …; g: …; b: …`,
/// converged when all three are).
fn termination_of(passes: &[PassSummary<'_>]) -> (String, bool) {
    if let [one] = passes {
        return (one.termination.to_string(), one.converged);
    }
    let text = ["r", "g", "b"]
        .iter()
        .zip(passes)
        .map(|(c, r)| format!("{c}: {}", r.termination))
        .collect::<Vec<_>>()
        .join("; ");
    (text, passes.iter().all(|r| r.converged))
}

/// The robust stage's record, when a robust loss was asked for.
fn robust_record(config: &FitConfig, passes: &[PassSummary<'_>]) -> Option<RobustRecord> {
    (config.robust != RobustKind::None).then(|| RobustRecord {
        kind: config.robust,
        scale: passes
            .iter()
            .map(|r| r.robust.map_or(f64::NAN, |x| x.0))
            .collect(),
        scale_source: if config.robust_scale.is_some() {
            "given".into()
        } else {
            "auto".into()
        },
        plain_stage_loss: passes
            .iter()
            .filter_map(|r| r.robust.and_then(|x| x.1))
            .collect(),
        objective: passes.iter().map(|r| (2.0 * r.cost).sqrt()).collect(),
    })
}

/// The fitted model's largest directional albedo over channels and incidence angles.
fn max_albedo(fitted: &Fitted) -> f64 {
    let quad = AlbedoQuadrature::new();
    (0..3)
        .map(|c| {
            quad.albedos(fitted.channel_model(c))
                .iter()
                .map(|a| a[c])
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stage(iterations: u64) -> WarmUpRecord {
        WarmUpRecord {
            cells: 100,
            iterations,
            cost_evals: 0,
            jacobian_evals: 0,
            final_loss: 0.0,
            termination: String::new(),
            rounds: 1,
        }
    }

    fn start(explore: Option<u64>, warm_up: Option<u64>, finish: u64) -> StartRecord {
        StartRecord {
            index: 0,
            channel: None,
            start: vec![],
            final_loss: Some(0.0),
            iterations: finish,
            cost_evals: 0,
            jacobian_evals: 0,
            termination: String::new(),
            converged: true,
            kept: false,
            warm_up: warm_up.map(stage),
            finished: true,
            rank_loss: None,
            explore: explore.map(stage),
        }
    }

    /// Every stage of every start is counted, so a fit whose kept start took 0
    /// iterations on all cells (the warm-up optimum kept) does not read as idle.
    #[test]
    fn stage_iterations_sum_every_start() {
        let starts = [
            start(Some(30), Some(12), 0),
            start(Some(25), None, 0),
            start(None, Some(7), 3),
        ];
        let s = StageIterations::of_starts(&starts);
        assert_eq!(
            s,
            StageIterations {
                explore: 55,
                warm_up: 19,
                finish: 3
            }
        );
        assert_eq!(s.total(), 77);
        assert_eq!(s.summary(), "77 (explore 55 + warm-up 19 + finish 3)");
        let json = serde_json::to_value(s).unwrap();
        assert_eq!(
            json,
            serde_json::json!({"explore": 55, "warm_up": 19, "finish": 3})
        );
    }
}
