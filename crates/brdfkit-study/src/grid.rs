//! The fit grid: model × solver × sample fraction × starts on every material, with the
//! wall time and every loss on the full table, and the Pareto front of loss against
//! time.
//!
//! Two sets of materials: the synthetic ones of `data-synthetic/` ([`run_grid`]), whose
//! truth the models represent, and measured ones ([`run_measured_grid`]): the NBRDF
//! proxies of `data-measured/` resampled onto the MERL grid, where no model is exact and
//! each fit is compared with the exhaustive reference fit of
//! `data-measured/reference-fits.json` where one exists ([`read_references`]), else with
//! the best loss the grid reached ([`baselines`], [`relative`]).

use crate::{ModelChoice, StudyConfig, StudyError, SynthMaterial};
use brdfkit_core::progress::{Event, Observe};
use brdfkit_fit::{FitConfig, FitData, Loss, SolverKind, fit};
use brdfkit_merl::{Dims, MerlTable};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One fit of the grid.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct GridRow {
    /// Spec name of the material.
    pub material: String,
    /// Label of the model family.
    pub model: String,
    /// Solver name.
    pub solver: String,
    /// Sample fraction of the valid cells the solver saw (1 = all).
    pub fraction: f64,
    /// Number of starts.
    pub starts: usize,
    /// Cells the solver saw.
    pub cells_fit: usize,
    /// Wall time of the `fit` call (subsampling, warm-up, starts, loss report), s.
    pub wall_s: f64,
    /// CPU time of the call, all threads, s (load-insensitive; ≈ 2 × wall on an idle
    /// 2-core machine when both threads are busy).
    pub cpu_s: f64,
    /// Overall losses on the full table (all valid cells).
    pub cbrt: f64,
    /// The `l2` loss on the full table.
    pub l2: f64,
    /// The `cosine` loss on the full table.
    pub cosine: f64,
    /// The `log` loss on the full table.
    pub log: f64,
    /// Iterations of the kept start.
    pub iterations: u64,
    /// Passes over the fitted cells without / with derivatives, all starts.
    pub cost_evals: u64,
    /// Passes with derivatives, all starts.
    pub jacobian_evals: u64,
    /// Whether the kept start met a convergence test.
    pub converged: bool,
    /// Why the kept start stopped, or the error of a failed fit (losses NaN then).
    pub termination: String,
}

/// The configurations of the grid, in run order: Nelder-Mead only on fractions up to
/// `nelder_mead_max_fraction`.
pub fn configurations(cfg: &StudyConfig) -> Vec<(SolverKind, f64, usize)> {
    let mut v = Vec::new();
    for &s in &cfg.solvers {
        for &f in &cfg.fractions {
            if s == SolverKind::NelderMead && f > cfg.nelder_mead_max_fraction {
                continue;
            }
            for &n in &cfg.starts {
                let budget = cfg.starts_budget.map(|b| {
                    if s == SolverKind::NelderMead {
                        b / 4.0
                    } else {
                        b
                    }
                });
                // A small tolerance: 4 × 10 % is 0.4 in decimal but not in binary.
                if n > 1 && budget.is_some_and(|b| n as f64 * f > b * (1.0 + 1e-9)) {
                    continue;
                }
                v.push((s, f, n));
            }
        }
    }
    v
}

/// Fits one configuration and records it (a failed fit is a row with NaN losses).
pub fn fit_one(
    cfg: &StudyConfig,
    material: &str,
    model_label: &str,
    start: &dyn brdfkit_core::Model,
    data: &FitData,
    (solver, fraction, starts): (SolverKind, f64, usize),
) -> Result<GridRow, StudyError> {
    let what = format!("{material}/{model_label}/{}", solver.name());
    let err = |source| StudyError::Fit {
        what: what.clone(),
        source,
    };
    let mut fc = FitConfig::default()
        .solver(solver)
        .starts(starts)
        .map_err(err)?
        .seed(0);
    if fraction < 1.0 {
        fc = fc.subsample(fraction, 1).map_err(err)?;
    }
    if let Some(t) = cfg.theta_max_deg {
        fc = fc.theta_max_deg(t).map_err(err)?;
    }
    let cap = if solver == SolverKind::NelderMead {
        cfg.nelder_mead_max_iters
    } else {
        cfg.max_iters
    };
    if let Some(n) = cap {
        fc = fc.max_iters(n).map_err(err)?;
    }
    Ok(timed_fit(
        &fc,
        [material, model_label, solver.name()],
        start,
        data,
        (fraction, starts),
    ))
}

/// The solver column of the grid's row for `fit-brdf fit`'s own defaults
/// ([`fit_cli_default`]).
pub const CLI_DEFAULT: &str = "fit-brdf default";

/// Starts of `fit-brdf fit` (its `--starts` default).
pub const CLI_STARTS: usize = 8;

/// Fits with the configuration of a plain `fit-brdf fit T --model M` (LM, 8 starts
/// ranked on a 1,024-cell exploration subsample, the best finished, no iteration cap
/// of the grid; the cell filter of the grid) and records it as solver [`CLI_DEFAULT`].
pub fn fit_cli_default(
    cfg: &StudyConfig,
    material: &str,
    model_label: &str,
    start: &dyn brdfkit_core::Model,
    data: &FitData,
) -> Result<GridRow, StudyError> {
    let err = |source| StudyError::Fit {
        what: format!("{material}/{model_label}/{CLI_DEFAULT}"),
        source,
    };
    let mut fc = FitConfig::default()
        .starts(CLI_STARTS)
        .and_then(|c| c.explore_cells(Some(brdfkit_fit::config::DEFAULT_EXPLORE_CELLS)))
        .map_err(err)?
        .full_iters(brdfkit_fit::config::DEFAULT_FULL_ITERS)
        .seed(0);
    if let Some(t) = cfg.theta_max_deg {
        fc = fc.theta_max_deg(t).map_err(err)?;
    }
    Ok(timed_fit(
        &fc,
        [material, model_label, CLI_DEFAULT],
        start,
        data,
        (1.0, CLI_STARTS),
    ))
}

/// Runs one fit, timing it, and records it: `names` are (material, model, solver).
fn timed_fit(
    fc: &FitConfig,
    [material, model_label, solver]: [&str; 3],
    start: &dyn brdfkit_core::Model,
    data: &FitData,
    (fraction, starts): (f64, usize),
) -> GridRow {
    let c0 = crate::cpu_seconds();
    let t = Instant::now();
    let out = fit(start, data, fc, None);
    let wall_s = t.elapsed().as_secs_f64();
    let cpu_s = crate::cpu_seconds() - c0;
    let mut row = GridRow {
        material: material.into(),
        model: model_label.into(),
        solver: solver.into(),
        fraction,
        starts,
        cells_fit: 0,
        wall_s,
        cpu_s,
        cbrt: f64::NAN,
        l2: f64::NAN,
        cosine: f64::NAN,
        log: f64::NAN,
        iterations: 0,
        cost_evals: 0,
        jacobian_evals: 0,
        converged: false,
        termination: String::new(),
    };
    match out {
        Ok(o) => {
            let r = &o.record;
            let l = &r.losses_full;
            row.cells_fit = r.cells_fit;
            row.cbrt = l.get(Loss::Cbrt).overall;
            row.l2 = l.get(Loss::L2).overall;
            row.cosine = l.get(Loss::Cosine).overall;
            row.log = l.get(Loss::Log).overall;
            row.iterations = r.iterations;
            row.cost_evals = r.cost_evals;
            row.jacobian_evals = r.jacobian_evals;
            row.converged = r.converged;
            row.termination = r.termination.clone();
        }
        Err(e) => row.termination = format!("error: {e}"),
    }
    row
}

/// Runs the whole grid on the synthetic materials (model-major: a stopped run has
/// every material of the first models).
pub fn run_grid(
    cfg: &StudyConfig,
    materials: &[SynthMaterial],
    progress: &dyn Observe,
) -> Result<Vec<GridRow>, StudyError> {
    let jobs: Vec<(&str, &MerlTable, &ModelChoice)> = cfg
        .models
        .iter()
        .flat_map(|mc| {
            materials
                .iter()
                .map(move |m| (m.spec.name.as_str(), &m.table, mc))
        })
        .collect();
    run_jobs(cfg, &jobs, "grid-partial.json", false, progress)
}

/// Runs the grid on the measured materials, material-major (a stopped run has every
/// model of the first materials), with one more row per material and model: the fit
/// of `fit-brdf fit`'s defaults ([`fit_cli_default`]).
pub fn run_measured_grid(
    cfg: &StudyConfig,
    tables: &[(String, MerlTable)],
    progress: &dyn Observe,
) -> Result<Vec<GridRow>, StudyError> {
    let jobs: Vec<(&str, &MerlTable, &ModelChoice)> = tables
        .iter()
        .flat_map(|(n, t)| cfg.models.iter().map(move |mc| (n.as_str(), t, mc)))
        .collect();
    run_jobs(cfg, &jobs, "grid-measured-partial.json", true, progress)
}

/// Fits every configuration on each (material, table, model) job in order, skipping
/// the rows `partial` holds when resuming and saving them there after every job.
fn run_jobs(
    cfg: &StudyConfig,
    jobs: &[(&str, &MerlTable, &ModelChoice)],
    partial: &str,
    cli_default: bool,
    progress: &dyn Observe,
) -> Result<Vec<GridRow>, StudyError> {
    let confs = configurations(cfg);
    let total = (confs.len() + usize::from(cli_default)) * jobs.len();
    let partial = cfg.out.join(partial);
    let mut rows: Vec<GridRow> = if cfg.resume {
        std::fs::read_to_string(&partial)
            .ok()
            .and_then(|s| serde_json::from_str(&s).ok())
            .unwrap_or_default()
    } else {
        Vec::new()
    };
    let key = |m: &str, l: &str, s: &str, f: f64, n: usize| format!("{m}|{l}|{s}|{f}|{n}");
    let done: std::collections::HashSet<String> = rows
        .iter()
        .map(|r| key(&r.material, &r.model, &r.solver, r.fraction, r.starts))
        .collect();
    let t0 = Instant::now();
    for &(name, table, mc) in jobs {
        let data = FitData::from_table(table).map_err(|source| StudyError::Fit {
            what: name.to_string(),
            source,
        })?;
        let start = brdfkit_models::from_json(&mc.start).map_err(|e| StudyError::Model {
            what: mc.label.clone(),
            msg: e.to_string(),
        })?;
        let mut todo: Vec<Option<(SolverKind, f64, usize)>> =
            confs.iter().copied().map(Some).collect();
        if cli_default {
            todo.push(None);
        }
        for c in todo {
            let (solver, fraction, starts) = match c {
                Some((s, f, n)) => (s.name(), f, n),
                None => (CLI_DEFAULT, 1.0, CLI_STARTS),
            };
            if done.contains(&key(name, &mc.label, solver, fraction, starts)) {
                continue;
            }
            let row = match c {
                Some(c) => fit_one(cfg, name, &mc.label, start.as_ref(), &data, c)?,
                None => fit_cli_default(cfg, name, &mc.label, start.as_ref(), &data)?,
            };
            progress.observe(&Event::Step(format!(
                "grid {}/{} ({:.0} s): {} {} {} {:.3} % x{}: {:.3} s (cpu {:.3} s), cbrt {:.4e}",
                rows.len() + 1,
                total,
                t0.elapsed().as_secs_f64(),
                row.material,
                row.model,
                row.solver,
                row.fraction * 100.0,
                row.starts,
                row.wall_s,
                row.cpu_s,
                row.cbrt
            )));
            rows.push(row);
        }
        // Saved after every job, so a stopped run can resume.
        crate::files::write_json(&partial, &rows)?;
    }
    Ok(rows)
}

/// The directory holding a proxy's six files `NAME_{fc1,b1,…}.npy`: `dir` itself or one
/// of its subfolders (`merl/`, `rgl-isotropic/`, `nielsen/` in `data-measured/`).
pub fn proxy_stem(dir: &Path, name: &str) -> Option<PathBuf> {
    let has = |d: &Path| d.join(format!("{name}_fc1.npy")).is_file();
    if has(dir) {
        return Some(dir.join(name));
    }
    let mut subs: Vec<PathBuf> = std::fs::read_dir(dir)
        .ok()?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    subs.sort();
    subs.into_iter().find(|d| has(d)).map(|d| d.join(name))
}

/// The environment variable naming the proxies' folder when `--measured-dir` is not
/// given ([`find_measured_dir`]).
pub const MEASURED_DIR_ENV: &str = "BRDFKIT_MEASURED_DIR";

/// The folder of the vendored proxies when none is given, in the order a user of a
/// checkout expects: `$BRDFKIT_MEASURED_DIR`; else `data-measured/` in `cwd` or the
/// nearest folder above it that has one (so the study works from `tour/`, `docs/` or
/// any other folder of the checkout; the path stays relative, as the report prints
/// it); else the `data-measured/` of the checkout this crate was built from, while it
/// exists (an installed `fit-brdf` run outside the checkout). `None`: none of these.
pub fn find_measured_dir(cwd: &Path) -> Option<PathBuf> {
    if let Some(d) = std::env::var_os(MEASURED_DIR_ENV).filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d));
    }
    let mut rel = PathBuf::new();
    for dir in cwd.ancestors() {
        if dir.join("data-measured").is_dir() {
            return Some(rel.join("data-measured"));
        }
        rel.push("..");
    }
    let built = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data-measured");
    built.is_dir().then_some(built)
}

/// [`find_measured_dir`] from the current folder.
pub fn find_measured_dir_here() -> Option<PathBuf> {
    std::env::current_dir()
        .ok()
        .and_then(|cwd| find_measured_dir(&cwd))
}

/// The error of a name in `cfg.measured` with no proxy: a missing folder names the
/// options that set it, a folder without the proxy the name.
pub fn no_proxy(cfg: &StudyConfig, name: &str) -> StudyError {
    let dir = cfg.measured_dir.display();
    if !cfg.measured_dir.is_dir() {
        return StudyError::Config {
            option: "measured-dir",
            msg: format!(
                "`{dir}` is not a folder: the proxies of `measured` (here `{name}`) are read \
                 from `measured-dir` (or ${MEASURED_DIR_ENV}; by default `data-measured/` \
                 of the checkout, found from the current folder upwards)"
            ),
        };
    }
    StudyError::Config {
        option: "measured",
        msg: format!(
            "no proxy `{name}` ({name}_fc1.npy …) in `{dir}` or a subfolder (`measured-dir` \
             sets the folder)"
        ),
    }
}

/// The measured part of the grid: loads the proxies, fits the grid on them, reads the
/// reference fits, and stores the rows, the references and the run's record in `res`;
/// writes `grid-measured.csv` (every fit with its excess over its baseline).
pub fn run_measured(
    cfg: &StudyConfig,
    res: &mut crate::StudyResults,
    progress: &dyn Observe,
) -> Result<(), StudyError> {
    let mut info = crate::RunInfo::start(cfg);
    // The references first: a bad file must not waste the grid.
    let refs = read_references(&cfg.measured_dir.join("reference-fits.json"), cfg)?;
    let t = Instant::now();
    let tables = load_measured(cfg)?;
    progress.observe(&Event::Step(format!(
        "measured: {} proxies resampled in {:.1} s",
        tables.len(),
        t.elapsed().as_secs_f64()
    )));
    res.measured_references = refs;
    res.measured_grid = run_measured_grid(cfg, &tables, progress)?;
    info.grid_s = Some(t.elapsed().as_secs_f64());
    info.load_end = crate::load_average();
    res.measured_run = Some(info);
    crate::files::write_csv(
        &cfg.out.join("grid-measured.csv"),
        &relative(&res.measured_grid, &res.measured_references),
    )
}

/// The measured materials of the grid: each proxy of `cfg.measured` read from
/// `cfg.measured_dir` and resampled onto `cfg.measured_dims` in memory (as `fit-brdf
/// resample --nbrdf` does). A missing or unreadable proxy is a configuration error.
pub fn load_measured(cfg: &StudyConfig) -> Result<Vec<(String, MerlTable)>, StudyError> {
    let bad = |msg: String| StudyError::Config {
        option: "measured",
        msg,
    };
    let [h, d, p] = cfg.measured_dims;
    let dims = Dims::new(h as i64, d as i64, p as i64).map_err(|e| bad(e.to_string()))?;
    cfg.measured
        .iter()
        .map(|name| {
            let stem = proxy_stem(&cfg.measured_dir, name).ok_or_else(|| no_proxy(cfg, name))?;
            let net = brdfkit_nbrdf::Nbrdf::load(&stem).map_err(|e| bad(e.to_string()))?;
            let (table, _) = net.to_table(dims).map_err(|e| bad(e.to_string()))?;
            Ok((name.clone(), table))
        })
        .collect()
}

/// An exhaustive reference fit of a measured material (`data-measured/reference-fits.json`).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Reference {
    /// The proxy's name.
    pub material: String,
    /// The model label of the grid it applies to.
    pub model: String,
    /// Its full-table cbrt loss.
    pub loss: f64,
}

/// Whether a reference fit's model is the grid's model family: same family and, for
/// every structural choice of the grid's start (a string parameter such as
/// `distribution`, or an object keyed by the choice such as `{"schlick": {"f0": …}}`),
/// the same choice. The fitted model is read back through the registry first, so a
/// choice it leaves out counts as the registry's default, as it does when it is fitted.
fn same_structure(start: &serde_json::Value, fitted: &serde_json::Value) -> bool {
    if start["model"] != fitted["model"] {
        return false;
    }
    let Ok(fitted) = brdfkit_models::from_json(fitted).map(|m| m.to_json()) else {
        return false;
    };
    let Some(params) = start["params"].as_object() else {
        return false;
    };
    params.iter().all(|(k, v)| match choice(v) {
        None => true,
        Some(c) => choice(&fitted["params"][k]) == Some(c),
    })
}

/// The structural choice a parameter value names: a string, or the one key of an object
/// whose value is an object (`{"schlick": {"f0": …}}`); None for a number or an array.
fn choice(v: &serde_json::Value) -> Option<&str> {
    match v {
        serde_json::Value::String(s) => Some(s),
        serde_json::Value::Object(o) if o.len() == 1 => o
            .iter()
            .next()
            .filter(|(_, b)| b.is_object())
            .map(|(k, _)| k.as_str()),
        _ => None,
    }
}

/// The reference fits of `path` that apply to the grid of `cfg`: cbrt loss, solid-angle
/// weights, a model of `cfg.models` with the same structural choices, the MERL grid and
/// no θ cutoff (the references are over every valid cell of the MERL-grid
/// resampling). A missing file gives none; an unreadable one is an error.
pub fn read_references(path: &Path, cfg: &StudyConfig) -> Result<Vec<Reference>, StudyError> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(StudyError::io(path, e)),
    };
    let bad = |msg: String| {
        StudyError::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, msg),
        )
    };
    let doc: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let fits = doc["fits"]
        .as_array()
        .ok_or_else(|| bad("no `fits` array".into()))?;
    let merl = [
        Dims::MERL.theta_h(),
        Dims::MERL.theta_d(),
        Dims::MERL.phi_d(),
    ];
    if cfg.theta_max_deg.is_some() || cfg.measured_dims != merl {
        return Ok(Vec::new());
    }
    let mut out = Vec::new();
    for f in fits {
        let (Some(material), Some(loss)) = (f["material"].as_str(), f["best_loss"].as_f64()) else {
            return Err(bad("a fit without `material` or `best_loss`".into()));
        };
        if f["loss"] != "cbrt" || f["weighting"] != "solid-angle" {
            continue;
        }
        for mc in cfg
            .models
            .iter()
            .filter(|mc| same_structure(&mc.start, &f["model"]))
        {
            out.push(Reference {
                material: material.into(),
                model: mc.label.clone(),
                loss,
            });
        }
    }
    Ok(out)
}

/// What a measured fit's loss is compared with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Baseline {
    /// The loss.
    pub loss: f64,
    /// True: the exhaustive reference fit; false: the best loss any configuration of
    /// the grid reached for that material and model.
    pub is_reference: bool,
}

impl Baseline {
    /// How the report names it.
    pub fn name(&self) -> &'static str {
        if self.is_reference {
            "reference"
        } else {
            "best in grid"
        }
    }
}

/// The baseline of every (model, material) of `rows`: its reference where `refs` has
/// one, else the lowest finite cbrt loss of its rows.
pub fn baselines(rows: &[GridRow], refs: &[Reference]) -> BTreeMap<(String, String), Baseline> {
    let mut out: BTreeMap<(String, String), Baseline> = BTreeMap::new();
    for r in rows.iter().filter(|r| r.cbrt.is_finite()) {
        let e = out
            .entry((r.model.clone(), r.material.clone()))
            .or_insert(Baseline {
                loss: f64::INFINITY,
                is_reference: false,
            });
        e.loss = e.loss.min(r.cbrt);
    }
    for f in refs {
        if let Some(b) = out.get_mut(&(f.model.clone(), f.material.clone())) {
            *b = Baseline {
                loss: f.loss,
                is_reference: true,
            };
        }
    }
    out
}

/// A measured fit with its loss relative to its baseline (`grid-measured.csv`).
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct RelativeRow {
    /// The fit.
    #[serde(flatten)]
    pub row: GridRow,
    /// The baseline's cbrt loss.
    pub baseline: f64,
    /// `reference` or `best in grid`.
    pub baseline_is: String,
    /// cbrt / baseline − 1 (negative when a fit beat the reference).
    pub excess: f64,
}

/// Every row of `rows` with its excess over its baseline ([`baselines`]).
pub fn relative(rows: &[GridRow], refs: &[Reference]) -> Vec<RelativeRow> {
    let base = baselines(rows, refs);
    rows.iter()
        .map(|r| {
            let b = base
                .get(&(r.model.clone(), r.material.clone()))
                .copied()
                .unwrap_or(Baseline {
                    loss: f64::NAN,
                    is_reference: false,
                });
            RelativeRow {
                row: r.clone(),
                baseline: b.loss,
                baseline_is: b.name().into(),
                excess: r.cbrt / b.loss - 1.0,
            }
        })
        .collect()
}

/// Indices of the Pareto-optimal rows among `rows` by (wall time, cbrt loss): no other
/// row is at least as fast and strictly better, or faster and at least as good. Rows
/// with a NaN loss are never on the front. Returned in increasing time.
pub fn pareto(rows: &[&GridRow]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..rows.len())
        .filter(|&i| rows[i].cbrt.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        rows[a]
            .wall_s
            .total_cmp(&rows[b].wall_s)
            .then(rows[a].cbrt.total_cmp(&rows[b].cbrt))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if rows[i].cbrt < best {
            best = rows[i].cbrt;
            front.push(i);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(t: f64, l: f64) -> GridRow {
        GridRow {
            material: "m".into(),
            model: "x".into(),
            solver: "lm".into(),
            fraction: 1.0,
            starts: 1,
            cells_fit: 1,
            wall_s: t,
            cpu_s: t,
            cbrt: l,
            l2: l,
            cosine: l,
            log: l,
            iterations: 0,
            cost_evals: 0,
            jacobian_evals: 0,
            converged: true,
            termination: String::new(),
        }
    }

    #[test]
    fn pareto_keeps_only_undominated_points() {
        let rows = [
            row(1.0, 0.5),
            row(2.0, 0.6), // dominated by the first
            row(3.0, 0.1),
            row(0.5, 0.9),
            row(4.0, 0.1),      // as good as a faster one: dominated
            row(0.1, f64::NAN), // failed fit
        ];
        let refs: Vec<&GridRow> = rows.iter().collect();
        assert_eq!(pareto(&refs), vec![3, 0, 2]);
    }

    fn at(material: &str, model: &str, solver: &str, l: f64) -> GridRow {
        GridRow {
            material: material.into(),
            model: model.into(),
            solver: solver.into(),
            ..row(1.0, l)
        }
    }

    #[test]
    fn excess_is_over_the_reference_where_there_is_one_else_over_the_best_found() {
        let rows = [
            at("steel", "cook-torrance", "lm", 0.0102),
            at("steel", "cook-torrance", "lbfgs", 0.0099), // beats the reference
            at("steel", "ward", "lm", 0.03),
            at("steel", "ward", "lbfgs", 0.024),
            at("steel", "ward", "nelder-mead", f64::NAN), // failed
            at("felt", "cook-torrance", "lm", 0.05),
        ];
        let refs = [
            Reference {
                material: "steel".into(),
                model: "cook-torrance".into(),
                loss: 0.01,
            },
            // No row of this pair: ignored.
            Reference {
                material: "paint".into(),
                model: "cook-torrance".into(),
                loss: 0.02,
            },
        ];
        let rel = relative(&rows, &refs);
        let got: Vec<(f64, &str, f64)> = rel
            .iter()
            .map(|r| (r.baseline, r.baseline_is.as_str(), r.excess))
            .collect();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        let want = [
            (0.01, "reference", 0.02),
            (0.01, "reference", -0.01),
            (0.024, "best in grid", 0.25),
            (0.024, "best in grid", 0.0),
            (0.024, "best in grid", f64::NAN),
            (0.05, "best in grid", 0.0),
        ];
        for (g, w) in got.iter().zip(want) {
            assert_eq!(g.0, w.0, "{got:?}");
            assert_eq!(g.1, w.1, "{got:?}");
            assert!(close(g.2, w.2) || (g.2.is_nan() && w.2.is_nan()), "{got:?}");
        }
        assert_eq!(rel.len(), rows.len());
        assert_eq!(rel[1].row, rows[1]);
    }

    #[test]
    fn references_apply_to_the_same_model_structure_on_the_merl_grid_only() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("reference-fits.json");
        let fit = |material: &str, distribution: &str, loss: &str| {
            serde_json::json!({"material": material, "family": "cook-torrance",
                "loss": loss, "weighting": "solid-angle", "best_loss": 0.5,
                "model": {"model": "cook-torrance", "params": {
                    "distribution": distribution, "masking": "smith-separable",
                    "fresnel": {"schlick": {"f0": [0.1, 0.1, 0.1]}}, "alpha": 0.2}}})
        };
        let doc = serde_json::json!({"fits": [
            fit("a", "ggx", "cbrt"),
            fit("b", "beckmann", "cbrt"),
            fit("c", "ggx", "l2"),
        ]});
        std::fs::write(&p, doc.to_string()).unwrap();
        let mut cfg = StudyConfig::quick("x", "y");
        cfg.models = ["cook-torrance", "ward"]
            .iter()
            .map(|m| ModelChoice::by_label(m).unwrap())
            .collect();
        let refs = read_references(&p, &cfg).unwrap();
        assert_eq!(
            refs,
            vec![Reference {
                material: "a".into(),
                model: "cook-torrance".into(),
                loss: 0.5
            }]
        );
        // Another grid or a θ cutoff: the references are over other cells.
        cfg.measured_dims = [16, 16, 32];
        assert!(read_references(&p, &cfg).unwrap().is_empty());
        cfg.measured_dims = [90, 90, 180];
        cfg.theta_max_deg = Some(80.0);
        assert!(read_references(&p, &cfg).unwrap().is_empty());
        cfg.theta_max_deg = None;
        // No file: no reference; a broken one: an error naming it.
        assert!(
            read_references(&dir.path().join("none.json"), &cfg)
                .unwrap()
                .is_empty()
        );
        std::fs::write(&p, "{").unwrap();
        let e = read_references(&p, &cfg).unwrap_err().to_string();
        assert!(e.contains("reference-fits.json"), "{e}");
    }

    /// The committed proxies' directory.
    fn data_measured() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data-measured")
    }

    /// From a folder below the checkout's root (the README's `tour/`), the proxies'
    /// folder is the nearest `data-measured/` above, as a relative path.
    #[test]
    fn the_measured_folder_is_found_from_below() {
        if std::env::var_os(MEASURED_DIR_ENV).is_some() {
            return; // the variable wins, by design; covered by the CLI test
        }
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("checkout");
        std::fs::create_dir_all(root.join("data-measured")).unwrap();
        std::fs::create_dir_all(root.join("tour/deeper")).unwrap();
        let found = |cwd: &Path| find_measured_dir(cwd).unwrap();
        assert_eq!(found(&root), PathBuf::from("data-measured"));
        assert_eq!(
            found(&root.join("tour")),
            Path::new("..").join("data-measured")
        );
        assert_eq!(
            found(&root.join("tour/deeper")),
            Path::new("../..").join("data-measured")
        );
        // Outside any checkout: the one this crate was built from.
        let outside = dir.path().join("elsewhere");
        std::fs::create_dir_all(&outside).unwrap();
        assert_eq!(
            found(&outside).canonicalize().unwrap(),
            data_measured().canonicalize().unwrap()
        );
    }

    #[test]
    fn proxies_are_found_in_subfolders() {
        let d = data_measured();
        assert_eq!(
            proxy_stem(&d, "pink-fabric"),
            Some(d.join("merl").join("pink-fabric"))
        );
        assert_eq!(
            proxy_stem(&d, "bindercover"),
            Some(d.join("nielsen").join("bindercover"))
        );
        assert_eq!(proxy_stem(&d, "no-such-proxy"), None);
    }

    #[test]
    fn the_measured_grid_runs_end_to_end_on_one_proxy() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("avt");
        let mut cfg = StudyConfig::quick(&out, "unused");
        cfg.materials = Vec::new();
        cfg.measured = vec!["pink-fabric".into()];
        cfg.measured_dir = data_measured();
        // A small grid keeps the test fast (and the MERL-grid references out).
        cfg.measured_dims = [16, 16, 32];
        cfg.solvers = vec![SolverKind::Lm, SolverKind::GaussNewton];
        cfg.fractions = vec![0.1, 1.0];
        cfg.starts = vec![1];
        cfg.choices = false;
        cfg.scale = false;
        let res = crate::run(&cfg, &()).unwrap();
        // 2 solvers × 2 fractions + fit-brdf's default, on one material and model.
        assert_eq!(res.measured_grid.len(), 5);
        assert!(res.grid.is_empty());
        assert!(res.measured_references.is_empty());
        let rows = &res.measured_grid;
        assert!(rows.iter().all(|r| r.material == "pink-fabric"
            && r.model == "cook-torrance"
            && r.cbrt.is_finite()
            && r.cbrt > 1e-4 // measured data: no model is exact
            && r.wall_s > 0.0));
        let d = rows.iter().find(|r| r.solver == CLI_DEFAULT).unwrap();
        assert_eq!((d.fraction, d.starts), (1.0, CLI_STARTS));
        // The CSV: every row with its excess over the best in the grid, 0 for the best.
        let csv = std::fs::read_to_string(out.join("grid-measured.csv")).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 6, "{csv}");
        let head: Vec<&str> = lines[0].split(',').collect();
        let col = |name: &str| head.iter().position(|h| *h == name).unwrap();
        let (ex, bi) = (col("excess"), col("baseline_is"));
        let excesses: Vec<f64> = lines[1..]
            .iter()
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                assert_eq!(f[bi], "best in grid");
                f[ex].parse().unwrap()
            })
            .collect();
        assert!(excesses.iter().all(|x| *x >= 0.0), "{excesses:?}");
        assert!(excesses.contains(&0.0), "{excesses:?}");
        // The report: the measured sections and plot, no synthetic run section.
        let md = std::fs::read_to_string(dir.path().join("avt.md")).unwrap();
        let sections = ["run", "summary", "solvers", "plots", "fronts"];
        let missing: Vec<&str> = sections
            .into_iter()
            .filter(|m| !md.contains(&format!("<!-- study:measured-{m} -->")))
            .collect();
        assert!(missing.is_empty(), "{missing:?} missing:\n{md}");
        assert!(md.contains("pareto-measured-cook-torrance.png") && md.contains(CLI_DEFAULT));
        assert!(!md.contains("<!-- study:run -->"), "{md}");
        assert!(image::open(out.join("pareto-measured-cook-torrance.png")).is_ok());
        // A proxy that does not exist is a configuration error naming it.
        cfg.measured = vec!["no-such-proxy".into()];
        let e = crate::run(&cfg, &()).unwrap_err();
        assert!(matches!(e, StudyError::Config { .. }) && e.to_string().contains("no-such-proxy"));
    }

    #[test]
    fn nelder_mead_is_limited_to_small_fractions() {
        let mut c = StudyConfig::quick("x", "y");
        c.solvers = vec![SolverKind::NelderMead, SolverKind::Lm];
        c.fractions = vec![0.005, 0.02, 0.5];
        c.starts = vec![1];
        c.starts_budget = None;
        let confs = configurations(&c);
        assert_eq!(confs.len(), 2 + 3);
        assert!(
            confs
                .iter()
                .all(|(s, f, _)| *s != SolverKind::NelderMead || *f <= 0.02)
        );
    }
}
