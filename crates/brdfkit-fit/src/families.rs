//! What `fit`, `report`, `batch` and `demo` fit: model families with their structural
//! choices, and the fit settings as the command line states them, both validated into
//! the library's types ([`Family`], [`FitConfig`]); then every family fitted in turn
//! ([`fit_each`]) and the comparison of the results ([`comparison_text`]).
//!
//! Structural choices are applied with the models' builders
//! (`CookTorrance::with_distribution`, `Ward::with_normalization`, ...), so a choice is
//! checked by the type system and never written into JSON by hand.
//!
//! Error messages name the setting concerned by its own name (`model`, `fix`,
//! `sample_fraction`: the Python bindings' argument names);
//! [`FamilyError::message_with`] names it otherwise (the command line: `--fix`,
//! `--sample-fraction`).

use crate::config::{DEFAULT_EXPLORE_CELLS, DEFAULT_FINISH, DEFAULT_FULL_ITERS, DEFAULT_STARTS};
use crate::{
    FitConfig, FitData, FitError, FitRecord, FullIters, Loss, LossSet, RobustKind, Sharing,
    SolverKind, Weighting, fit, resolve_free,
};
use brdfkit_core::progress::{Event, FitSummary, Observe};
use brdfkit_core::scattering::{Distribution, Masking};
use brdfkit_core::{Model, ModelError, downcast};
use brdfkit_models::cook_torrance::{CookTorrance, FresnelKind};
use brdfkit_models::ward::{Normalization, Ward};
use serde_json::Value;
use std::fmt;
use std::path::{Path, PathBuf};

pub use brdfkit_models::named::{
    DATABASE_MODELS, DEFAULT_FAMILY, NAMED_FAMILIES, REPORT_MODELS, named_family,
};

/// Why the model list or the settings cannot be used: always the user's input.
///
/// Settings are named as [`FitSettings`] states them to a user, in snake case
/// (`model`, `starts`, `sample_fraction`, `theta_d_max`, `energy_conserving`): the
/// `Display` text; [`message_with`](Self::message_with) renames them.
#[derive(Debug, thiserror::Error)]
pub enum FamilyError {
    /// A model file could not be read.
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A model file is not JSON.
    Json {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        #[source]
        source: serde_json::Error,
    },
    /// A model file's `params` is neither an object nor null.
    ParamsNotObject {
        /// The `model` item (a file).
        item: String,
    },
    /// The model rejected its name, a parameter or a structural choice.
    Model {
        /// The `model` item.
        item: String,
        /// The model's message.
        #[source]
        source: ModelError,
    },
    /// `model` named nothing.
    NoModel,
    /// A structural choice of a model that is not in the list.
    ChoiceWithoutModel {
        /// The settings given, e.g. `["distribution", "masking"]`.
        options: Vec<&'static str>,
        /// The model they belong to.
        model: &'static str,
    },
    /// A fit setting out of range.
    Setting {
        /// The setting, in snake case (`starts`, `sample_fraction`).
        option: &'static str,
        /// Why.
        reason: String,
    },
    /// `fix` names a parameter a family lacks.
    Free {
        /// The family.
        label: String,
        /// The fitter's message.
        #[source]
        source: FitError,
    },
    /// `fix` leaves a family nothing to fit.
    AllFixed {
        /// The family.
        label: String,
    },
}

impl FamilyError {
    /// The message with every setting named by `name(setting)` (`setting` in snake
    /// case, as [`FamilyError`]'s `Display` prints it): the command line passes its
    /// flag spelling, so that one error reads `fix: …` in Python and `--fix: …` there.
    pub fn message_with(&self, name: &dyn Fn(&str) -> String) -> String {
        match self {
            FamilyError::Read { path, .. } => {
                format!("{}: cannot read the model description", path.display())
            }
            FamilyError::Json { path, source } => {
                format!("{}: not valid JSON: {source}", path.display())
            }
            FamilyError::ParamsNotObject { item } => format!("{item}: `params` must be an object"),
            FamilyError::Model { item, source } => format!("{} {item}: {source}", name("model")),
            FamilyError::NoModel => format!("{}: no model given", name("model")),
            FamilyError::ChoiceWithoutModel { options, model } => {
                let names: Vec<String> = options.iter().map(|o| name(o)).collect();
                let list = match names.as_slice() {
                    [] => String::new(),
                    [one] => one.clone(),
                    [init @ .., last] => format!("{} and {last}", init.join(", ")),
                };
                let verb = if names.len() == 1 { "applies" } else { "apply" };
                format!("{list} {verb} to {model}, which is not among the models")
            }
            FamilyError::Setting { option, reason } => format!("{}: {reason}", name(option)),
            FamilyError::Free { label, source } => {
                format!("{}: {label}: {source}", name("fix"))
            }
            FamilyError::AllFixed { label } => format!(
                "{}: {label}: every parameter is fixed, nothing is left to fit",
                name("fix")
            ),
        }
    }
}

impl fmt::Display for FamilyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message_with(&|s| s.to_string()))
    }
}

/// Structural choices given once for the whole model list; each applies to the model
/// that has it and is an error when that model is not in the list.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Structure {
    /// Microfacet distribution of cook-torrance.
    pub distribution: Option<Distribution>,
    /// Masking-shadowing of cook-torrance.
    pub masking: Option<Masking>,
    /// Fresnel kind of cook-torrance (with that kind's default parameters).
    pub fresnel: Option<FresnelKind>,
    /// Normalisation of ward.
    pub normalization: Option<Normalization>,
}

impl Structure {
    fn any_cook_torrance(&self) -> bool {
        self.distribution.is_some() || self.masking.is_some() || self.fresnel.is_some()
    }

    /// `ct` with the cook-torrance choices applied. A Fresnel kind replaces the start's
    /// factor by that kind's defaults, whatever the start had.
    pub fn apply_cook_torrance(&self, mut ct: CookTorrance) -> Result<CookTorrance, ModelError> {
        if let Some(d) = self.distribution {
            ct = ct.with_distribution(d);
        }
        if let Some(m) = self.masking {
            ct = ct.with_masking(m);
        }
        if let Some(f) = self.fresnel {
            ct = ct.with_fresnel(f.with_defaults())?;
        }
        Ok(ct)
    }

    /// `w` with the ward choice applied.
    pub fn apply_ward(&self, w: Ward) -> Ward {
        match self.normalization {
            Some(n) => w.with_normalization(n),
            None => w,
        }
    }
}

/// A model family to fit: a label and its model at the start.
pub struct Family {
    /// The model's name, or `name (file)` for a start read from a file.
    pub label: String,
    /// The start, with its structural choices.
    pub model: Box<dyn Model>,
}

/// One `--model` item: its model name and `params` (a name alone has null params).
fn read_item(item: &str) -> Result<(bool, Value), FamilyError> {
    let is_file = item.ends_with(".json") || Path::new(item).is_file();
    if !is_file {
        return Ok((false, serde_json::json!({"model": item})));
    }
    let path = Path::new(item);
    let text = std::fs::read_to_string(path).map_err(|source| FamilyError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let v: Value = serde_json::from_str(&text).map_err(|source| FamilyError::Json {
        path: path.to_path_buf(),
        source,
    })?;
    if v.get("params")
        .is_some_and(|p| !p.is_object() && !p.is_null())
    {
        return Err(FamilyError::ParamsNotObject { item: item.into() });
    }
    Ok((true, v))
}

/// Parses a model list (comma-separated names or model JSON files) and applies the
/// structural choices with the models' builders.
pub fn families(list: &str, s: &Structure) -> Result<Vec<Family>, FamilyError> {
    let mut out = Vec::new();
    let (mut ct_used, mut ward_used) = (false, false);
    for item in list.split(',').map(str::trim).filter(|x| !x.is_empty()) {
        if let Some(model) = named_family(item) {
            let model = model.map_err(|source| FamilyError::Model {
                item: item.into(),
                source,
            })?;
            out.push(Family {
                label: item.to_string(),
                model,
            });
            continue;
        }
        let (is_file, v) = read_item(item)?;
        let err = |source| FamilyError::Model {
            item: item.into(),
            source,
        };
        // The generic reader checks the whole description (keys, name, parameters);
        // the choices then go through the model's own builders, on the typed model.
        let mut model = brdfkit_models::from_json(&v).map_err(err)?;
        if let Some(ct) = downcast::<CookTorrance>(model.as_ref()) {
            ct_used = true;
            if s.any_cook_torrance() {
                model = Box::new(s.apply_cook_torrance(ct.clone()).map_err(err)?);
            }
        } else if let Some(w) = downcast::<Ward>(model.as_ref()) {
            ward_used = true;
            if s.normalization.is_some() {
                model = Box::new(s.apply_ward(w.clone()));
            }
        }
        let label = if is_file {
            format!("{} ({item})", model.name())
        } else {
            model.name().to_string()
        };
        out.push(Family { label, model });
    }
    if out.is_empty() {
        return Err(FamilyError::NoModel);
    }
    if !ct_used && s.any_cook_torrance() {
        let given = [
            ("distribution", s.distribution.is_some()),
            ("masking", s.masking.is_some()),
            ("fresnel", s.fresnel.is_some()),
        ];
        return Err(FamilyError::ChoiceWithoutModel {
            options: given.iter().filter(|g| g.1).map(|g| g.0).collect(),
            model: CookTorrance::NAME,
        });
    }
    if !ward_used && s.normalization.is_some() {
        return Err(FamilyError::ChoiceWithoutModel {
            options: vec!["normalization"],
            model: Ward::NAME,
        });
    }
    Ok(out)
}

/// The fit settings a user states, typed: the one settings type of the command line
/// (`fit`, `report`, `batch`, `demo`) and of Python's `brdfkit.fit`, which map their
/// flags and arguments onto it field by field and take their defaults from
/// [`FitSettings::default`]. [`FitSettings::config`] validates them into the engine's
/// [`FitConfig`].
#[derive(Debug, Clone, PartialEq)]
pub struct FitSettings {
    /// The loss optimised.
    pub loss: Loss,
    /// Cell weights.
    pub weighting: Weighting,
    /// The solver.
    pub solver: SolverKind,
    /// Number of starts.
    pub starts: usize,
    /// Starts that continue on all cells after the warm-up.
    pub finish: usize,
    /// Stratified fraction of the valid cells fitted, in (0, 1].
    pub sample_fraction: f64,
    /// Cells with θd above this angle (degrees) are left out.
    pub theta_d_max_deg: Option<f64>,
    /// Cells with θi or θo above this angle (degrees) are left out
    /// ([`FitConfig::theta_max_deg`]).
    pub theta_max_deg: Option<f64>,
    /// Every parameter per channel (default: shape shared).
    pub per_channel: bool,
    /// Seed of the starts and the subsample.
    pub seed: u64,
    /// Parameters (names or groups) held at their start values; `Some` of an empty
    /// list is an error.
    pub fix: Option<Vec<String>>,
    /// Robust loss.
    pub robust: RobustKind,
    /// Scale of the robust loss (None: automatic).
    pub robust_scale: Option<f64>,
    /// Energy conservation: the bound on the directional albedo (None: unconstrained;
    /// see [`FitConfig::albedo_max`]).
    pub albedo_max: Option<f64>,
    /// Iterations over all cells after a warm-up (see [`FitConfig::full_iters`]).
    pub full_iters: FullIters,
    /// Size of the exploration set of a ranked fit (see [`FitConfig::explore_cells`];
    /// None: the library's rule).
    pub explore_cells: Option<usize>,
    /// The losses the record reports (see [`FitConfig::report_losses`]).
    pub losses: LossSet,
}

impl Default for FitSettings {
    /// The one set of defaults a user meets, on the command line and in Python:
    /// the cube-root loss with solid-angle weights, Levenberg-Marquardt from
    /// [`DEFAULT_STARTS`] starts ([`DEFAULT_FINISH`] finished), the warm-up optimum kept
    /// where it holds ([`DEFAULT_FULL_ITERS`]), [`DEFAULT_EXPLORE_CELLS`] exploration
    /// cells, every cell, brdfkit's own four losses reported. Their evidence is in
    /// docs/fitting.md. ([`FitConfig::default`] is the engine's bare configuration,
    /// one start over every cell, which tests and studies build on.)
    fn default() -> Self {
        FitSettings {
            loss: Loss::Cbrt,
            weighting: Weighting::SolidAngle,
            solver: SolverKind::Lm,
            starts: DEFAULT_STARTS,
            finish: DEFAULT_FINISH,
            sample_fraction: 1.0,
            theta_d_max_deg: None,
            theta_max_deg: None,
            per_channel: false,
            seed: 0,
            fix: None,
            robust: RobustKind::None,
            robust_scale: None,
            albedo_max: None,
            full_iters: DEFAULT_FULL_ITERS,
            explore_cells: Some(DEFAULT_EXPLORE_CELLS),
            losses: LossSet::Own,
        }
    }
}

impl FitSettings {
    /// The validated configuration; an error names the option at fault.
    pub fn config(&self) -> Result<FitConfig, FamilyError> {
        let bad = |option: &'static str| {
            move |e: FitError| FamilyError::Setting {
                option,
                reason: e.to_string(),
            }
        };
        let mut c = FitConfig::default()
            .loss(self.loss)
            .weighting(self.weighting)
            .solver(self.solver)
            .sharing(if self.per_channel {
                Sharing::PerChannel
            } else {
                Sharing::SharedShape
            })
            .seed(self.seed)
            .starts(self.starts)
            .map_err(bad("starts"))?
            .finish(self.finish)
            .map_err(bad("finish"))?;
        let f = self.sample_fraction;
        if !(f > 0.0 && f <= 1.0) {
            return Err(FamilyError::Setting {
                option: "sample_fraction",
                reason: format!("{f}: must lie in (0, 1]"),
            });
        }
        if f < 1.0 {
            c = c.subsample(f, self.seed).map_err(bad("sample_fraction"))?;
        }
        if let Some(names) = &self.fix {
            let names: Vec<&str> = names
                .iter()
                .map(|s| s.trim())
                .filter(|x| !x.is_empty())
                .collect();
            if names.is_empty() {
                return Err(FamilyError::Setting {
                    option: "fix",
                    reason: "no parameter name given".into(),
                });
            }
            c = c.fix_params(names);
        }
        if let Some(deg) = self.theta_d_max_deg {
            c = c.theta_d_max_deg(deg).map_err(bad("theta_d_max"))?;
        }
        if let Some(deg) = self.theta_max_deg {
            c = c.theta_max_deg(deg).map_err(bad("theta_max"))?;
        }
        c.robust(self.robust, self.robust_scale)
            .map_err(bad("robust_scale"))?
            .albedo_max(self.albedo_max)
            .map_err(bad("energy_conserving"))
            .map(|c| c.full_iters(self.full_iters).report_losses(self.losses))?
            .explore_cells(self.explore_cells)
            .map_err(bad("explore_cells"))
    }
}

/// Checks the free and fixed parameter names against every family before any fitting
/// (an unknown name in `--fix` is bad input, not a failure of each fit).
pub fn check_free(fams: &[Family], cfg: &FitConfig) -> Result<(), FamilyError> {
    for f in fams {
        let free = resolve_free(&*f.model, cfg).map_err(|source| FamilyError::Free {
            label: f.label.clone(),
            source,
        })?;
        if free.is_empty() {
            return Err(FamilyError::AllFixed {
                label: f.label.clone(),
            });
        }
    }
    Ok(())
}

/// One fitted family.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The family's label.
    pub label: String,
    /// The fitted model(s), typed: [`Outcome::params`] is their JSON.
    pub fitted: crate::Fitted,
    /// The fit record.
    pub record: FitRecord,
    /// Where the fit's time went ([`crate::FitResult::stages`]).
    pub stages: crate::StageTimes,
}

impl Outcome {
    /// The fitted model in the JSON contract (`fit --out`'s file).
    pub fn params(&self) -> Value {
        self.fitted.to_json()
    }

    /// `{"label", "params", "record"}`: what `fit --json` prints and a batch stores.
    pub fn to_json(&self) -> Value {
        serde_json::json!({"label": self.label, "params": self.params(), "record": self.record})
    }

    /// The text of the fitted model's file (`fit --out`): pretty JSON and a newline.
    pub fn params_file(&self) -> Result<String, serde_json::Error> {
        pretty_file(&self.params())
    }

    /// The text of the fit record's file (`fit --record`): pretty JSON and a newline.
    pub fn record_file(&self) -> Result<String, serde_json::Error> {
        pretty_file(&self.record)
    }
}

/// Pretty JSON with a final newline: how every JSON file of a fit is written.
pub fn pretty_file(v: &impl serde::Serialize) -> Result<String, serde_json::Error> {
    serde_json::to_string_pretty(v).map(|s| s + "\n")
}

/// A family's fit failed.
#[derive(Debug, thiserror::Error)]
#[error("fitting {label}: {source}")]
pub struct FamilyFitError {
    /// The family.
    pub label: String,
    /// The fitter's error.
    #[source]
    pub source: FitError,
}

/// Fits every family, one after the other, on the same cells; stops at the first
/// failure. `obs` hears [`Event::FamilyStarted`], the family's fit events (see
/// [`fit`]), then [`Event::FamilyDone`] (with no summary when the fit failed), for each
/// family in turn.
pub fn fit_each(
    data: &FitData,
    fams: &[Family],
    cfg: &FitConfig,
    obs: &dyn Observe,
) -> Result<Vec<Outcome>, FamilyFitError> {
    let mut out = Vec::with_capacity(fams.len());
    // The model-independent preparation, once for all families (a failure here is
    // the first family's to report).
    if fams.len() > 1 {
        let _ = crate::prepare(data, cfg);
    }
    let count = fams.len();
    for (index, f) in fams.iter().enumerate() {
        let label = f.label.clone();
        obs.observe(&Event::FamilyStarted {
            index,
            count,
            label: label.clone(),
        });
        let r = fit(&*f.model, data, cfg, Some(obs));
        let summary = r.as_ref().ok().map(|r| summary(&r.record, cfg.loss));
        obs.observe(&Event::FamilyDone {
            index,
            count,
            label,
            summary,
        });
        match r {
            Ok(r) => out.push(Outcome {
                label: f.label.clone(),
                fitted: r.fitted,
                record: r.record,
                stages: r.stages,
            }),
            Err(source) => {
                return Err(FamilyFitError {
                    label: f.label.clone(),
                    source,
                });
            }
        }
    }
    Ok(out)
}

/// A family's fit in the figures of its progress line: the optimised loss over the
/// full table, time, iterations by stage, convergence.
fn summary(record: &FitRecord, loss: Loss) -> FitSummary {
    FitSummary {
        loss_name: loss.to_string(),
        loss: record.losses_full.get(loss).overall,
        wall_time_s: record.wall_time_s,
        iterations: record.stage_iterations().summary(),
        converged: record.converged,
    }
}

/// The table of `fit --stage-times`: the table's own stages (`per_table`, e.g. read
/// and cells, paid once whatever the families), then one row per family with the
/// fit's stages ([`crate::StageTimes`]) and its whole `fit` call, in milliseconds.
pub fn stage_times_text(per_table: &[(&str, f64)], outcomes: &[Outcome]) -> String {
    let ms = |s: f64| format!("{:.1}", 1e3 * s);
    let mut t = per_table
        .iter()
        .map(|(n, s)| format!("{n} {} ms", ms(*s)))
        .collect::<Vec<_>>()
        .join(", ");
    t += "\nmodel";
    for (n, _) in crate::StageTimes::default().stages() {
        t += &format!("\t{n}");
    }
    t += "\tfit (wall_time_s)\n";
    for o in outcomes {
        t += &o.label;
        for (_, s) in o.stages.stages() {
            t += &format!("\t{}", ms(s));
        }
        t += &format!("\t{}\n", ms(o.record.wall_time_s));
    }
    t
}

/// The comparison table: every loss on the full table, time, iterations by stage
/// ([`FitRecord::stage_iterations`]: never a bare 0 for a fit that iterated only on its
/// subsamples), termination.
pub fn comparison_text(outcomes: &[Outcome], optimised: Loss) -> String {
    let iters: Vec<String> = outcomes
        .iter()
        .map(|o| o.record.stage_iterations().summary())
        .collect();
    let w = iters.iter().map(String::len).max().unwrap_or(0).max(10);
    let mut s = format!(
        "{:<28} {:>11} {:>11} {:>11} {:>11} {:>8}  {:<w$}  {}\n",
        "model", "cbrt", "l2", "cosine", "log", "time s", "iterations", "termination"
    );
    for (o, it) in outcomes.iter().zip(&iters) {
        let l = &o.record.losses_full;
        s += &format!(
            "{:<28} {:>11.4e} {:>11.4e} {:>11.4e} {:>11.4e} {:>8.3}  {it:<w$}  {}{}\n",
            o.label,
            l.cbrt.overall,
            l.l2.overall,
            l.cosine.overall,
            l.log.overall,
            o.record.wall_time_s,
            o.record.termination,
            if o.record.converged {
                ""
            } else {
                " (not converged)"
            }
        );
    }
    s += &format!(
        "losses: weighted RMS over all valid cells ({} cells); optimised: {optimised}\n\
         iterations: of every start: on its exploration subsample, the warm-up subsample, \
         and all fitted cells (the finish)\n",
        outcomes.first().map_or(0, |o| o.record.cells_full)
    );
    for o in outcomes {
        if !o.record.active_bounds.is_empty() {
            s += &format!(
                "note: {}: at a domain bound at the optimum: {}\n",
                o.label,
                o.record.active_bounds.join(", ")
            );
        }
        if let Some(a) = reflects_more_than_it_receives(&o.record) {
            s += &format!(
                "note: {}: not energy-conserving: its directional albedo reaches {a:.3} (it \
                 reflects more light than it receives at some incidence); an energy-conserving \
                 fit keeps it at most 1\n",
                o.label
            );
        }
    }
    s
}

/// The albedo above which an unconstrained fit is called not energy-conserving: 1 plus
/// a margin for the quadrature's error (its estimate of a white Lambertian's albedo,
/// exactly 1, is off by up to 5.3e-4), so that only a real excess is reported.
const ALBEDO_NOTE: f64 = 1.0 + 1e-2;

/// The fitted model's largest directional albedo when it exceeds 1 and the fit was not
/// held under a bound: a physically impossible answer the user should hear about (a
/// flat lobe trading ρs against α far along a degenerate direction gives one, as the
/// Cook-Torrance fit of a felt's measured points does).
fn reflects_more_than_it_receives(r: &FitRecord) -> Option<f64> {
    r.max_albedo
        .filter(|&a| a > ALBEDO_NOTE && r.albedo_max.is_none())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The note's margin over 1 is far above the quadrature's error on a white
    /// Lambertian, whose albedo is exactly 1 at every incidence.
    #[test]
    fn the_albedo_note_margin_is_above_the_quadrature_error() {
        let white = brdfkit_models::from_json(&serde_json::json!(
            {"model": "lambert", "params": {"rho_d": 1.0}}
        ))
        .unwrap();
        let worst = crate::energy::AlbedoQuadrature::new()
            .albedos(white.as_ref())
            .iter()
            .flat_map(|a| a.0)
            .map(|a| (a - 1.0).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-3, "quadrature error {worst}");
        assert!(ALBEDO_NOTE - 1.0 > 10.0 * worst, "quadrature error {worst}");
    }

    fn json_of(f: &Family) -> Value {
        f.model.to_json()
    }

    #[test]
    fn names_and_files_become_families_with_their_choices() {
        let d = tempfile::tempdir().unwrap();
        let start = d.path().join("start.json");
        std::fs::write(
            &start,
            r#"{"model": "cook-torrance", "params": {"rho_d": 0, "fresnel": {"conductor": {"eta": 1.5, "k": 2}}}}"#,
        )
        .unwrap();
        let list = format!("lambert, ward,{}", start.display());
        let s = Structure {
            distribution: Some(Distribution::Beckmann),
            masking: Some(Masking::VCavity),
            fresnel: Some(FresnelKind::Schlick),
            normalization: Some(Normalization::Duer),
        };
        let f = families(&list, &s).unwrap();
        assert_eq!(f.len(), 3);
        assert_eq!(f[0].label, "lambert");
        assert_eq!(f[2].label, format!("cook-torrance ({})", start.display()));
        assert_eq!(json_of(&f[1])["params"]["normalization"], "duer");
        let ct = &json_of(&f[2])["params"];
        assert_eq!(ct["distribution"], "beckmann");
        assert_eq!(ct["masking"], "v-cavity");
        assert_eq!(ct["rho_d"], serde_json::json!([0.0, 0.0, 0.0]));
        // The kind's defaults replace the start's factor.
        let want = CookTorrance::new()
            .with_fresnel(FresnelKind::Schlick.with_defaults())
            .unwrap()
            .fresnel();
        assert_eq!(
            CookTorrance::from_params_json(ct).unwrap().fresnel(),
            want,
            "{ct}"
        );
    }

    #[test]
    fn the_builders_give_what_the_json_contract_gives() {
        // The same start as the JSON patching of the command line used to build: the
        // batch's options hash, which hashes these descriptions, must not change.
        for kind in FresnelKind::ALL {
            let s = Structure {
                fresnel: Some(kind),
                distribution: Some(Distribution::Beckmann),
                ..Structure::default()
            };
            let built = families("cook-torrance", &s).unwrap().remove(0);
            let fresnel = match kind {
                FresnelKind::None => serde_json::json!("none"),
                k => serde_json::json!({ k.name(): {} }),
            };
            let patched = brdfkit_models::from_json(&serde_json::json!({
                "model": "cook-torrance",
                "params": {"distribution": "beckmann", "fresnel": fresnel}
            }))
            .unwrap();
            assert_eq!(built.model.to_json(), patched.to_json(), "{kind}");
        }
    }

    #[test]
    fn choices_without_their_model_and_bad_items_are_errors() {
        let ggx = Structure {
            distribution: Some(Distribution::Ggx),
            ..Structure::default()
        };
        let e = families("lambert", &ggx).err().unwrap();
        assert!(
            matches!(
                e,
                FamilyError::ChoiceWithoutModel {
                    model: "cook-torrance",
                    ..
                }
            ),
            "{e}"
        );
        let duer = Structure {
            normalization: Some(Normalization::Duer),
            ..Structure::default()
        };
        assert!(e.to_string().contains("not among the models"));
        assert!(families("cook-torrance", &duer).is_err());
        assert!(matches!(
            families(" , ", &Structure::default()),
            Err(FamilyError::NoModel)
        ));
        let e = families("nope", &Structure::default()).err().unwrap();
        assert!(e.to_string().contains("nope"), "{e}");
        let e = families("/no/such/start.json", &Structure::default())
            .err()
            .unwrap();
        assert!(matches!(e, FamilyError::Read { .. }), "{e}");
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("p.json");
        std::fs::write(&p, r#"{"model": "lambert", "params": 3}"#).unwrap();
        let e = families(p.to_str().unwrap(), &Structure::default())
            .err()
            .unwrap();
        assert!(matches!(e, FamilyError::ParamsNotObject { .. }), "{e}");
    }

    #[test]
    fn settings_are_validated_naming_the_option() {
        let ok = FitSettings {
            sample_fraction: 0.5,
            fix: Some(vec!["rho_d".into()]),
            theta_d_max_deg: Some(80.0),
            theta_max_deg: Some(80.0),
            ..FitSettings::default()
        };
        let c = ok.config().unwrap();
        assert_eq!(c.get_subsample(), Some(0.5));
        assert_eq!(c.get_theta_max(), Some(80f64.to_radians()));
        // The user's defaults are the bare engine's configuration with 8 starts, the
        // warm-up optimum kept, 1,024 exploration cells and brdfkit's own losses.
        let user = FitConfig::default()
            .starts(DEFAULT_STARTS)
            .unwrap()
            .full_iters(DEFAULT_FULL_ITERS)
            .explore_cells(Some(DEFAULT_EXPLORE_CELLS))
            .unwrap()
            .report_losses(LossSet::Own);
        assert_eq!(FitSettings::default().config().unwrap(), user);
        for (s, option) in [
            (
                FitSettings {
                    starts: 0,
                    ..FitSettings::default()
                },
                "starts",
            ),
            (
                FitSettings {
                    sample_fraction: 0.0,
                    ..FitSettings::default()
                },
                "sample_fraction",
            ),
            (
                FitSettings {
                    fix: Some(vec![" ".into()]),
                    ..FitSettings::default()
                },
                "fix",
            ),
            (
                FitSettings {
                    robust_scale: Some(-1.0),
                    robust: RobustKind::Huber,
                    ..FitSettings::default()
                },
                "robust_scale",
            ),
            (
                FitSettings {
                    theta_max_deg: Some(95.0),
                    ..FitSettings::default()
                },
                "theta_max",
            ),
        ] {
            match s.config() {
                Err(FamilyError::Setting { option: o, .. }) => assert_eq!(o, option),
                other => panic!("{option}: {other:?}"),
            }
        }
        let fams = families("lambert", &Structure::default()).unwrap();
        let fix_all = FitSettings {
            fix: Some(vec!["rho_d".into()]),
            ..FitSettings::default()
        };
        let e = check_free(&fams, &fix_all.config().unwrap()).unwrap_err();
        assert!(matches!(e, FamilyError::AllFixed { .. }), "{e}");
        let fix_none = FitSettings {
            fix: Some(vec!["gloss".into()]),
            ..FitSettings::default()
        };
        let e = check_free(&fams, &fix_none.config().unwrap()).unwrap_err();
        assert!(matches!(e, FamilyError::Free { .. }), "{e}");
    }
}
