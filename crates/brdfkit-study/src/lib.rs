//! The accuracy-vs-time study of brdfkit: what each accuracy costs in time.
//!
//! Three parts, each measured on the synthetic materials of `data-synthetic/` (tables
//! generated in memory from the specs, so the truth is known):
//!
//! - [`grid`]: every model × solver × sample fraction × number of starts is fitted;
//!   wall time and every loss on the full table are recorded, and the Pareto front of
//!   loss against time is drawn per model; the grid also runs on measured materials
//!   (NBRDF proxies of `data-measured/`), each loss relative to an exhaustive reference
//!   fit or to the best the grid reached;
//! - [`choices`]: evaluation choices — nearest vs interpolated table lookup (error
//!   against the analytic truth at random directions vs time per lookup), Schlick vs
//!   exact conductor Fresnel, exact-erf vs rational Beckmann G1, separable vs
//!   height-correlated Smith, and float32 vs float64 evaluation of Cook-Torrance GGX
//!   (`Model::eval_batch_f32` against `Model::eval_batch`): error introduced against
//!   time saved;
//! - [`scale`]: fit time against the number of cells, the number of parameters (sums of
//!   a Lambertian and 1–3 Cook-Torrance lobes) and threads, and the throughput of 20
//!   fits, all in-process (the whole-process wall time and peak memory of `fit-brdf`
//!   are benchmarks: `benches/peers/process_memory.py`).
//!
//! A fourth part, [`measured`], reads a whole-database `fit-brdf batch --nbrdf` run of
//! the measured-material proxies and writes `docs/measured.md`'s ranking of every model
//! family (`fit-brdf study --parts measured`). A fifth, [`losses`], fits measured proxies
//! with each loss and scores the rendered spheres of table and fit (`--parts losses`).
//!
//! [`run`] performs the parts a [`StudyConfig`] asks for and writes, below `out`, the
//! raw measurements (CSV and JSON, [`files`]) and PNG plots ([`plot`]), and `out` + `.md`
//! — the Markdown document, whose generated sections sit between `<!-- study:NAME -->`
//! markers so the hand-written reading around them survives a re-run ([`markdown`]).

#![warn(missing_docs)]

pub mod choices;
pub mod files;
pub mod grid;
pub mod losses;
pub mod markdown;
pub mod measured;
pub mod plot;
pub mod scale;

use brdfkit_core::Model as _;
use brdfkit_core::progress::{Event, Observe};
use brdfkit_fit::SolverKind;
use brdfkit_fit::synth::SynthSpec;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;
use thiserror::Error;

/// Errors of the study.
#[derive(Debug, Error)]
pub enum StudyError {
    /// A material spec could not be read or synthesised.
    #[error(transparent)]
    Spec(#[from] brdfkit_fit::synth::SpecError),
    /// A fit failed in a way the study does not record as a data point.
    #[error("{what}: {source}")]
    Fit {
        /// What was being done.
        what: String,
        #[source]
        /// The fitter's error.
        source: brdfkit_fit::FitError,
    },
    /// A model description was rejected.
    #[error("{what}: {msg}")]
    Model {
        /// The model or variant.
        what: String,
        /// What is wrong.
        msg: String,
    },
    /// A file could not be written (the atomic writer names the step).
    #[error(transparent)]
    Write(#[from] brdfkit_core::atomic::WriteError),
    /// An input text file could not be read, or is not UTF-8 text.
    #[error(transparent)]
    Text(#[from] brdfkit_core::text::TextFileError),
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        #[source]
        /// The fitter's error.
        source: std::io::Error,
    },
    /// A plot could not be drawn.
    #[error("{path}: cannot draw the plot: {msg}")]
    Plot {
        /// The file.
        path: PathBuf,
        /// Why it could not be drawn.
        msg: String,
    },
    /// The configuration is unusable.
    #[error("study option {option}: {msg}")]
    Config {
        /// The option.
        option: &'static str,
        /// Why it is unusable.
        msg: String,
    },
}

impl StudyError {
    /// Whether the request is at fault (a spec, an option, a model description) rather
    /// than the run: a command line reports it as bad input.
    pub fn is_bad_input(&self) -> bool {
        matches!(
            self,
            StudyError::Spec(_) | StudyError::Config { .. } | StudyError::Model { .. }
        )
    }

    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        StudyError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// A model family of the fit grid: a name and its start (JSON contract).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ModelChoice {
    /// Label in tables and plots.
    pub label: String,
    /// The start model (family, structural choices, start values).
    pub start: serde_json::Value,
}

impl ModelChoice {
    /// The family `label` of the models crate's registry at its default start (the
    /// registry's structural choices and start values, written out in full so that
    /// [`grid::read_references`] can match reference fits by structure), except that
    /// Ward takes Dür's normalisation, the form the study compares. None for a name the
    /// registry does not know and for the sum, which has no start without its terms.
    pub fn by_label(label: &str) -> Option<ModelChoice> {
        let model = brdfkit_models::default_model(label).ok()?;
        if model.name() == brdfkit_models::sum::Sum::default().name() {
            return None;
        }
        let start = if model.name() == brdfkit_models::ward::Ward::default().name() {
            brdfkit_models::ward::Ward::default()
                .with_normalization(brdfkit_models::ward::Normalization::Duer)
                .to_json()
        } else {
            model.to_json()
        };
        Some(ModelChoice {
            label: label.to_string(),
            start,
        })
    }

    /// The family of model type `M`, named by the type rather than by a string, so that
    /// the study's defaults follow the registry's names.
    pub fn of<M: brdfkit_core::Model + Default>() -> ModelChoice {
        ModelChoice::by_label(M::default().name()).expect("the registry knows its own family")
    }

    /// The study's first family, Cook-Torrance (GGX, separable Smith, Schlick: the
    /// registry's default start), which the scaling figures fit.
    pub fn default_family() -> ModelChoice {
        ModelChoice::of::<brdfkit_models::cook_torrance::CookTorrance>()
    }
}

/// Which parts to run and on what.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StudyConfig {
    /// Directory of the raw data and PNGs; the report is `out` + `.md`.
    pub out: PathBuf,
    /// Directory of the material specs (`data-synthetic/`).
    pub specs_dir: PathBuf,
    /// Spec names (file stems) of the materials.
    pub materials: Vec<String>,
    /// Measured materials of the fit grid: names of NBRDF proxies in `measured_dir`
    /// ([`grid::load_measured`]).
    #[serde(default)]
    pub measured: Vec<String>,
    /// Directory of the proxies (`data-measured/`, searched with its subfolders) and of
    /// `reference-fits.json`.
    #[serde(default = "default_measured_dir")]
    pub measured_dir: PathBuf,
    /// Grid the proxies are resampled onto, (θh, θd, φd) bins: the MERL grid.
    #[serde(default = "default_measured_dims")]
    pub measured_dims: [usize; 3],
    /// Model families fitted.
    pub models: Vec<ModelChoice>,
    /// Solvers.
    pub solvers: Vec<SolverKind>,
    /// Sample fractions of the valid cells (1.0 = the full table, no subsample).
    pub fractions: Vec<f64>,
    /// Numbers of starts.
    pub starts: Vec<usize>,
    /// Nelder-Mead runs only at fractions up to this (one pass per simplex vertex
    /// update: impractical on full tables).
    pub nelder_mead_max_fraction: f64,
    /// Iteration cap per start and stage of the derivative solvers (None: each solver's
    /// default cap).
    pub max_iters: Option<u64>,
    /// Iteration cap per start of Nelder-Mead (None: its default, 5000).
    pub nelder_mead_max_iters: Option<u64>,
    /// Budget of starts × fraction: n > 1 starts at fraction f run only when n·f ≤ this
    /// (Nelder-Mead: a quarter of it); None: everywhere. n starts cost about n fits or
    /// more (each start far from the answer iterates on all its cells); the scaling
    /// part measures 1 and 4 starts on a full table.
    pub starts_budget: Option<f64>,
    /// Keep the rows of an earlier run below `out` (`grid-partial.json`) and measure only
    /// the missing configurations.
    pub resume: bool,
    /// Run the fit grid.
    pub grid: bool,
    /// Run the evaluation-choice measurements.
    pub choices: bool,
    /// Run the scaling measurements.
    pub scale: bool,
    /// Random direction pairs for the lookup comparison.
    pub lookup_pairs: usize,
    /// Timed repetitions per evaluation figure (the minimum is reported).
    pub reps: usize,
    /// Tables of the batch-throughput figure.
    pub batch_tables: usize,
    /// Label of the grid in the report (`full`, `quick`, `custom`).
    pub grid_name: String,
    /// The fit grid leaves out cells whose θi or θo exceeds this angle (degrees;
    /// [`brdfkit_fit::FitConfig::theta_max_deg`]); None: every cell.
    pub theta_max_deg: Option<f64>,
}

fn default_measured_dir() -> PathBuf {
    PathBuf::from("data-measured")
}

fn default_measured_dims() -> [usize; 3] {
    [90, 90, 180]
}

/// The measured materials of the full grid, one per kind: a metal, a metallic paint, a
/// fabric, a phenolic (plastic) and the RGL felt.
pub const DEFAULT_MEASURED: [&str; 5] = [
    "chrome-steel",
    "gold-paint",
    "pink-fabric",
    "specular-red-phenolic",
    "acrylic_felt_green_rgb",
];

/// The six materials of the study, one per shape: diffuse, plastic, metal, near-mirror,
/// Ward-like satin, multi-lobe.
pub const DEFAULT_MATERIALS: [&str; 6] = [
    "lambert-white",
    "demo-plastic",
    "gold-ggx",
    "near-mirror-silver",
    "ward-duer",
    "lafortune-two-lobes",
];

impl StudyConfig {
    /// The full grid of the report: 6 materials × {cook-torrance, ward, plausible-phong}
    /// × 5 solvers × {0.5, 2, 10, 50, 100} % × {1, 4, 16} starts, with the limits that
    /// keep it to about 20 minutes on 2 cores: Nelder-Mead only up to 2 % and 1000
    /// iterations, the derivative solvers at most 25 iterations per start and stage,
    /// starts × fraction ≤ 0.4 (16 starts up to 2 %, 4 up to 10 %, 1 on 50 % and 100 %;
    /// Nelder-Mead ≤ 0.1).
    pub fn full(out: impl Into<PathBuf>, specs_dir: impl Into<PathBuf>) -> Self {
        StudyConfig {
            out: out.into(),
            specs_dir: specs_dir.into(),
            materials: DEFAULT_MATERIALS.iter().map(|s| s.to_string()).collect(),
            measured: DEFAULT_MEASURED.iter().map(|s| s.to_string()).collect(),
            measured_dir: default_measured_dir(),
            measured_dims: default_measured_dims(),
            models: vec![
                ModelChoice::default_family(),
                ModelChoice::of::<brdfkit_models::ward::Ward>(),
                ModelChoice::of::<brdfkit_models::plausible_phong::PlausiblePhong>(),
            ],
            solvers: SolverKind::ALL.to_vec(),
            fractions: vec![0.005, 0.02, 0.1, 0.5, 1.0],
            starts: vec![1, 4, 16],
            nelder_mead_max_fraction: 0.02,
            max_iters: Some(25),
            nelder_mead_max_iters: Some(1000),
            starts_budget: Some(0.4),
            resume: false,
            grid: true,
            choices: true,
            scale: true,
            lookup_pairs: 1_000_000,
            reps: 5,
            batch_tables: 20,
            grid_name: "full".into(),
            theta_max_deg: None,
        }
    }

    /// A CI-sized run: 2 synthetic materials and 1 measured one, Cook-Torrance only, LM,
    /// L-BFGS and Nelder-Mead, 2 % and 100 %, 1 and 4 starts; small lookup and batch
    /// figures.
    pub fn quick(out: impl Into<PathBuf>, specs_dir: impl Into<PathBuf>) -> Self {
        StudyConfig {
            materials: vec!["demo-plastic".into(), "gold-ggx".into()],
            measured: vec!["gold-paint".into()],
            models: vec![ModelChoice::default_family()],
            solvers: vec![SolverKind::Lm, SolverKind::Lbfgs, SolverKind::NelderMead],
            fractions: vec![0.02, 1.0],
            starts: vec![1, 4],
            lookup_pairs: 100_000,
            reps: 2,
            batch_tables: 3,
            grid_name: "quick".into(),
            ..StudyConfig::full(out, specs_dir)
        }
    }

    /// Checks the options before any work.
    pub fn validate(&self) -> Result<(), StudyError> {
        let bad = |option, msg: &str| {
            Err(StudyError::Config {
                option,
                msg: msg.to_string(),
            })
        };
        if self.grid
            && ((self.materials.is_empty() && self.measured.is_empty()) || self.models.is_empty())
        {
            return bad(
                "materials/models",
                "the fit grid needs at least one of each",
            );
        }
        if (self.choices || self.scale) && self.materials.is_empty() {
            return bad(
                "materials",
                "the evaluation choices and the scaling run on synthetic materials: name some, \
                 or run only the grid",
            );
        }
        if self.fractions.iter().any(|f| !(*f > 0.0 && *f <= 1.0)) {
            return bad("fractions", "every sample fraction must be in (0, 1]");
        }
        if self.starts.contains(&0) {
            return bad("starts", "the number of starts must be at least 1");
        }
        if self.reps == 0 {
            return bad("reps", "at least one timed repetition");
        }
        if let Some(t) = self.theta_max_deg
            && brdfkit_fit::FitConfig::default().theta_max_deg(t).is_err()
        {
            return bad("theta-max", "must be in (0, 90] degrees");
        }
        if self.choices && self.lookup_pairs == 0 {
            return bad("lookup-pairs", "at least one pair");
        }
        Ok(())
    }

    /// Path of the report.
    pub fn report_path(&self) -> PathBuf {
        let mut p = self.out.clone().into_os_string();
        p.push(".md");
        PathBuf::from(p)
    }
}

/// A synthetic material of the study: its spec (the truth) and the table synthesised
/// from it.
pub struct SynthMaterial {
    /// The spec (truth, noise, missing pattern).
    pub spec: SynthSpec,
    /// The synthesised table.
    pub table: brdfkit_merl::MerlTable,
}

/// Reads and synthesises the named materials.
pub fn load_materials(cfg: &StudyConfig) -> Result<Vec<SynthMaterial>, StudyError> {
    cfg.materials
        .iter()
        .map(|name| {
            let path = cfg.specs_dir.join(format!("{name}.toml"));
            let spec = SynthSpec::read(&path)?;
            let table = spec.synthesize()?;
            Ok(SynthMaterial { spec, table })
        })
        .collect()
}

/// Facts about the run, kept with the measurements.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunInfo {
    /// UTC start time (seconds since the epoch).
    pub started_unix: u64,
    /// Load average (1 min) at the start and at the end.
    pub load_start: Option<f64>,
    /// Load average (1 min) at the end.
    pub load_end: Option<f64>,
    /// Rayon threads.
    pub threads: usize,
    /// Wall time of each part, seconds.
    pub grid_s: Option<f64>,
    /// Wall time of the evaluation choices, s.
    pub choices_s: Option<f64>,
    /// Wall time of the scaling part, s.
    pub scale_s: Option<f64>,
    /// The configuration.
    pub config: StudyConfig,
}

impl RunInfo {
    /// The record of a run of `cfg` starting now: the time, the load, the threads.
    pub fn start(cfg: &StudyConfig) -> RunInfo {
        RunInfo {
            started_unix: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_secs())
                .unwrap_or(0),
            load_start: load_average(),
            load_end: None,
            threads: rayon::current_num_threads(),
            grid_s: None,
            choices_s: None,
            scale_s: None,
            config: cfg.clone(),
        }
    }
}

/// CPU time (user + system, all threads) this process has used, seconds
/// (`getrusage(RUSAGE_SELF)`, microsecond resolution). On a machine shared with other
/// jobs the wall time of a fit stretches while its CPU time stays near what it needs.
pub fn cpu_seconds() -> f64 {
    // SAFETY: getrusage fills the plain-data struct it is given.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) } != 0 {
        return f64::NAN;
    }
    let tv = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    tv(ru.ru_utime) + tv(ru.ru_stime)
}

/// The 1-minute load average (`/proc/loadavg`).
pub fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Option<T> {
    serde_json::from_str(&std::fs::read_to_string(path).ok()?).ok()
}

/// The figures of the last run below `out` (`results.json`), if any.
pub fn read_results(out: &Path) -> Option<StudyResults> {
    read_json(&out.join("results.json"))
}

/// Rewrites the plots and the report from the figures of the last run (`results.json`,
/// `run.json`) without measuring anything.
pub fn rewrite(out: &Path, progress: &dyn Observe) -> Result<(), StudyError> {
    let missing = |f: &str| StudyError::Config {
        option: "rewrite",
        msg: format!("{}: missing or unreadable", out.join(f).display()),
    };
    // An interrupted grid has only grid-partial.json: use it (and the full grid's
    // configuration when run.json is missing too).
    let mut res = read_results(out).unwrap_or_default();
    if res.grid.is_empty() {
        res.grid = read_json(&out.join("grid-partial.json")).unwrap_or_default();
    }
    if res.grid.is_empty()
        && res.measured_grid.is_empty()
        && res.lookups.is_empty()
        && res.scale.is_none()
    {
        return Err(missing("results.json"));
    }
    let info: RunInfo = read_json(&out.join("run.json")).unwrap_or_else(|| RunInfo {
        started_unix: 0,
        load_start: None,
        load_end: None,
        threads: rayon::current_num_threads(),
        grid_s: None,
        choices_s: None,
        scale_s: None,
        config: StudyConfig::full(out, "data-synthetic"),
    });
    let mut cfg = info.config.clone();
    cfg.out = out.to_path_buf();
    markdown::write_all(&cfg, &info, &res, progress)
}

/// Everything a run measured.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct StudyResults {
    /// The fit grid, one row per fit.
    pub grid: Vec<grid::GridRow>,
    /// Table lookup modes against the truth.
    pub lookups: Vec<choices::LookupRow>,
    /// Cook-Torrance evaluation choices against their references.
    pub variants: Vec<choices::VariantRow>,
    /// The scaling measurements.
    pub scale: Option<scale::ScaleResults>,
    /// The fit grid on measured materials, one row per fit.
    #[serde(default)]
    pub measured_grid: Vec<grid::GridRow>,
    /// The reference fits the measured rows are compared with.
    #[serde(default)]
    pub measured_references: Vec<grid::Reference>,
    /// When and how the measured grid ran (its own run: the grid on measured materials
    /// can run alone).
    #[serde(default)]
    pub measured_run: Option<RunInfo>,
}

/// Runs the study and writes the data, the plots and the report. `progress` receives
/// one line per step.
pub fn run(cfg: &StudyConfig, progress: &dyn Observe) -> Result<StudyResults, StudyError> {
    cfg.validate()?;
    // Specs and proxies first: a bad one must not leave an empty output directory behind.
    let materials = load_materials(cfg)?;
    if cfg.grid {
        for name in &cfg.measured {
            if grid::proxy_stem(&cfg.measured_dir, name).is_none() {
                return Err(grid::no_proxy(cfg, name));
            }
        }
    }
    std::fs::create_dir_all(&cfg.out).map_err(|e| StudyError::io(&cfg.out, e))?;
    let mut info = RunInfo::start(cfg);
    progress.observe(&Event::Step(format!(
        "study: {} threads, load {:.2}",
        info.threads,
        info.load_start.unwrap_or(f64::NAN)
    )));
    // Parts not run keep the figures of the last run (results.json), so one part can be
    // re-measured alone and the report still has all of them.
    let mut res = read_results(&cfg.out).unwrap_or_default();
    if res.grid.is_empty() {
        res.grid = read_json(&cfg.out.join("grid-partial.json")).unwrap_or_default();
    }
    if let Some(old) = read_json::<RunInfo>(&cfg.out.join("run.json")) {
        if !cfg.grid {
            info.grid_s = old.grid_s;
        }
        if !cfg.choices {
            info.choices_s = old.choices_s;
        }
        if !cfg.scale {
            info.scale_s = old.scale_s;
        }
    }
    let synthetic_grid = cfg.grid && !cfg.materials.is_empty();
    if synthetic_grid {
        let t = Instant::now();
        res.grid = grid::run_grid(cfg, &materials, progress)?;
        info.grid_s = Some(t.elapsed().as_secs_f64());
        files::write_csv(&cfg.out.join("grid.csv"), &res.grid)?;
    }
    if cfg.grid && !cfg.measured.is_empty() {
        grid::run_measured(cfg, &mut res, progress)?;
    }
    if cfg.choices {
        let t = Instant::now();
        res.lookups = choices::lookups(cfg, &materials, progress)?;
        res.variants = choices::variants(cfg, progress)?;
        info.choices_s = Some(t.elapsed().as_secs_f64());
        files::write_csv(&cfg.out.join("lookups.csv"), &res.lookups)?;
        files::write_csv(&cfg.out.join("variants.csv"), &res.variants)?;
    }
    if cfg.scale {
        let t = Instant::now();
        res.scale = Some(scale::run_scale(cfg, &materials, progress)?);
        info.scale_s = Some(t.elapsed().as_secs_f64());
    }
    info.load_end = load_average();
    // A run of the measured grid alone keeps the record of the last synthetic run.
    let info = match read_json::<RunInfo>(&cfg.out.join("run.json")) {
        Some(mut old) if !(synthetic_grid || cfg.choices || cfg.scale) => {
            old.config.out = cfg.out.clone();
            old
        }
        _ => info,
    };
    files::write_json(&cfg.out.join("run.json"), &info)?;
    files::write_json(&cfg.out.join("results.json"), &res)?;
    markdown::write_all(&info.config, &info, &res, progress)?;
    Ok(res)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The starts the study wrote out by hand before it asked the registry: the same
    /// models, parameter for parameter.
    #[test]
    fn registry_starts_are_the_hand_written_ones() {
        let by_hand = [
            serde_json::json!({"model": "cook-torrance", "params": {"distribution": "ggx",
                "masking": "smith-separable", "fresnel": "schlick"}}),
            serde_json::json!({"model": "ward", "params": {"normalization": "duer"}}),
            serde_json::json!({"model": "plausible-phong", "params": {}}),
            serde_json::json!({"model": "lambert", "params": {}}),
            serde_json::json!({"model": "blinn-phong", "params": {}}),
            serde_json::json!({"model": "lafortune", "params": {}}),
        ];
        for old in by_hand {
            let label = old["model"].as_str().unwrap();
            let new = ModelChoice::by_label(label).unwrap().start;
            let want = brdfkit_models::from_json(&old).unwrap().to_json();
            assert_eq!(brdfkit_models::from_json(&new).unwrap().to_json(), want);
        }
        assert_eq!(ModelChoice::default_family().label, "cook-torrance");
        assert!(ModelChoice::by_label("sum").is_none());
        assert!(ModelChoice::by_label("no-such-family").is_none());
    }
}
