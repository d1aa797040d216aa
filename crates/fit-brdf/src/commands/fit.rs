//! `fit-brdf fit TABLE --model ...`: nonlinear least-squares fits of analytic models.

use super::read_table;
use crate::cli::{FitArgs, FitOptions};
use crate::error::{CliResult, bad_input, bad_msg, runtime};
use crate::output::{write_atomic, write_text};
use anyhow::Context;
use brdfkit::core::Model;
use brdfkit_fit::{
    FitConfig, FitData, FitObserver, FitPlan, FitRecord, IterEvent, Loss, Sharing, SolverKind,
    StartDone, Weighting, fit,
};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Structural choices given on the command line, applied to the models that have them.
pub struct Structure<'a> {
    pub distribution: Option<&'a str>,
    pub masking: Option<&'a str>,
    pub fresnel: Option<&'a str>,
    pub normalization: Option<&'a str>,
}

/// A model family to fit: a label and its model at the start.
pub struct Family {
    pub label: String,
    pub model: Box<dyn Model>,
}

fn fresnel_json(kind: &str) -> CliResult<Value> {
    Ok(match kind {
        "schlick" => json!({"schlick": {}}),
        "conductor" => json!({"conductor": {}}),
        "dielectric" => json!({"dielectric": {}}),
        "none" => json!("none"),
        other => {
            return Err(bad_msg(format!(
                "--fresnel `{other}`: expected schlick, conductor, dielectric or none"
            )));
        }
    })
}

/// Parses `--model` (names or JSON files) and applies the structural options.
pub fn families(list: &str, s: &Structure) -> CliResult<Vec<Family>> {
    let mut out = Vec::new();
    let (mut ct_used, mut ward_used) = (false, false);
    for item in list.split(',').map(str::trim).filter(|x| !x.is_empty()) {
        let is_file = item.ends_with(".json") || Path::new(item).is_file();
        let mut v: Value = if is_file {
            let path = Path::new(item);
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("{}: cannot read the model description", path.display()))
                .map_err(bad_input)?;
            serde_json::from_str(&text)
                .map_err(|e| bad_msg(format!("{}: not valid JSON: {e}", path.display())))?
        } else {
            json!({"model": item, "params": {}})
        };
        let name = v["model"].as_str().unwrap_or("").to_string();
        if !v["params"].is_object() && v.get("params").is_some_and(|p| !p.is_null()) {
            return Err(bad_msg(format!("{item}: `params` must be an object")));
        }
        if v.get("params").is_none_or(Value::is_null) {
            v["params"] = json!({});
        }
        let params = v["params"].as_object_mut().expect("params is an object");
        if name == "cook-torrance" {
            ct_used = true;
            if let Some(d) = s.distribution {
                params.insert("distribution".into(), json!(d));
            }
            if let Some(m) = s.masking {
                params.insert("masking".into(), json!(m));
            }
            if let Some(f) = s.fresnel {
                params.insert("fresnel".into(), fresnel_json(f)?);
            }
        }
        if name == "ward" {
            ward_used = true;
            if let Some(n) = s.normalization {
                params.insert("normalization".into(), json!(n));
            }
        }
        let model =
            brdfkit::models::from_json(&v).map_err(|e| bad_msg(format!("--model {item}: {e}")))?;
        let label = if is_file {
            format!("{} ({item})", model.name())
        } else {
            model.name().to_string()
        };
        out.push(Family { label, model });
    }
    if out.is_empty() {
        return Err(bad_msg("--model: no model given"));
    }
    if !ct_used && (s.distribution.is_some() || s.masking.is_some() || s.fresnel.is_some()) {
        return Err(bad_msg(
            "--distribution, --masking and --fresnel apply to cook-torrance, which is not among the models",
        ));
    }
    if !ward_used && s.normalization.is_some() {
        return Err(bad_msg(
            "--normalization applies to ward, which is not among the models",
        ));
    }
    Ok(out)
}

/// The structural choices of the command line.
pub fn structure(o: &FitOptions) -> Structure<'_> {
    Structure {
        distribution: o.distribution.as_deref(),
        masking: o.masking.as_deref(),
        fresnel: o.fresnel.as_deref(),
        normalization: o.normalization.as_deref(),
    }
}

/// The fit options of the command line, validated.
pub fn config(a: &FitOptions) -> CliResult<FitConfig> {
    let loss: Loss = a
        .loss
        .parse()
        .map_err(|e: String| bad_msg(format!("--loss: {e}")))?;
    let weighting: Weighting = a
        .weighting
        .parse()
        .map_err(|e: String| bad_msg(format!("--weighting: {e}")))?;
    let solver: SolverKind = a
        .solver
        .parse()
        .map_err(|e: String| bad_msg(format!("--solver: {e}")))?;
    let mut c = FitConfig::default()
        .loss(loss)
        .weighting(weighting)
        .solver(solver)
        .sharing(if a.per_channel {
            Sharing::PerChannel
        } else {
            Sharing::SharedShape
        })
        .seed(a.seed)
        .starts(a.starts)
        .map_err(|e| bad_msg(format!("--starts: {e}")))?
        .finish(a.finish)
        .map_err(|e| bad_msg(format!("--finish: {e}")))?;
    if !(a.sample_fraction > 0.0 && a.sample_fraction <= 1.0) {
        return Err(bad_msg(format!(
            "--sample-fraction {}: must lie in (0, 1]",
            a.sample_fraction
        )));
    }
    if a.sample_fraction < 1.0 {
        c = c
            .subsample(a.sample_fraction, a.seed)
            .map_err(|e| bad_msg(format!("--sample-fraction: {e}")))?;
    }
    if let Some(names) = &a.fix {
        let names: Vec<&str> = names
            .split(',')
            .map(str::trim)
            .filter(|x| !x.is_empty())
            .collect();
        if names.is_empty() {
            return Err(bad_msg("--fix: no parameter name given"));
        }
        c = c.fix_params(names);
    }
    if let Some(deg) = a.theta_d_max {
        c = c
            .theta_d_max_deg(deg)
            .map_err(|e| bad_msg(format!("--theta-d-max: {e}")))?;
    }
    let robust: brdfkit_fit::RobustKind = a
        .robust
        .parse()
        .map_err(|e: String| bad_msg(format!("--robust: {e}")))?;
    c = c
        .robust(robust, a.robust_scale)
        .map_err(|e| bad_msg(format!("--robust-scale: {e}")))?;
    Ok(c)
}

/// Checks the free and fixed parameter names against every family before any fitting
/// (an unknown name in `--fix` is bad input, not a failure of each fit).
pub fn check_free(fams: &[Family], cfg: &FitConfig) -> CliResult<()> {
    for f in fams {
        let free = brdfkit_fit::resolve_free(&*f.model, cfg)
            .map_err(|e| bad_msg(format!("--fix: {}: {e}", f.label)))?;
        if free.is_empty() {
            return Err(bad_msg(format!(
                "--fix: {}: every parameter is fixed, nothing is left to fit",
                f.label
            )));
        }
    }
    Ok(())
}

/// A progress bar that appears only once a fit has run for a second (and only on a
/// terminal: indicatif draws nothing when stderr is not one).
pub struct Progress {
    bar: ProgressBar,
    t0: Instant,
    shown: AtomicBool,
    iters: AtomicU64,
    label: String,
    quiet: bool,
}

impl Progress {
    pub fn new(label: &str, quiet: bool) -> Arc<Self> {
        let bar = ProgressBar::with_draw_target(Some(1), ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} {msg} [{bar:24}] {pos}/{len} starts, {elapsed}",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        Arc::new(Progress {
            bar,
            t0: Instant::now(),
            shown: AtomicBool::new(false),
            iters: AtomicU64::new(0),
            label: label.to_string(),
            quiet,
        })
    }

    fn maybe_show(&self) {
        if !self.quiet
            && self.t0.elapsed() > Duration::from_secs(1)
            && !self.shown.swap(true, Ordering::Relaxed)
        {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
        }
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl FitObserver for Progress {
    fn on_plan(&self, plan: &FitPlan) {
        self.bar.set_length((plan.starts * plan.passes) as u64);
        self.bar
            .set_message(format!("fitting {} on {} cells", self.label, plan.cells));
    }
    fn on_iter(&self, ev: &IterEvent) {
        let n = self.iters.fetch_add(1, Ordering::Relaxed) + 1;
        self.maybe_show();
        if n.is_multiple_of(8) {
            self.bar.set_message(format!(
                "fitting {}: {} iterations, best loss {:.4e}",
                self.label,
                n,
                (2.0 * ev.best_cost).sqrt()
            ));
            self.bar.tick();
        }
    }
    fn on_start_done(&self, _d: &StartDone) {
        self.maybe_show();
        self.bar.inc(1);
    }
}

/// One fitted family.
pub struct Outcome {
    pub label: String,
    pub params: Value,
    pub record: FitRecord,
}

/// Fits every family on the table's cells (shared across families).
pub fn fit_all(
    data: &FitData,
    fams: &[Family],
    cfg: &FitConfig,
    quiet: bool,
) -> CliResult<Vec<Outcome>> {
    let mut out = Vec::new();
    for f in fams {
        let progress = Progress::new(&f.label, quiet);
        let obs: Arc<dyn FitObserver> = progress.clone();
        let r = fit(&*f.model, data, cfg, Some(obs));
        progress.finish();
        let r = r.map_err(|e| runtime(anyhow::anyhow!("fitting {}: {e}", f.label)))?;
        out.push(Outcome {
            label: f.label.clone(),
            params: r.fitted.to_json(),
            record: r.record,
        });
    }
    Ok(out)
}

/// The comparison table: every loss on the full table, time, iterations, termination.
pub fn comparison_text(outcomes: &[Outcome], optimised: Loss) -> String {
    let mut s = format!(
        "{:<28} {:>11} {:>11} {:>11} {:>11} {:>8} {:>6}  {}\n",
        "model", "cbrt", "l2", "cosine", "log", "time s", "iters", "termination"
    );
    for o in outcomes {
        let l = &o.record.losses_full;
        s += &format!(
            "{:<28} {:>11.4e} {:>11.4e} {:>11.4e} {:>11.4e} {:>8.3} {:>6}  {}{}\n",
            o.label,
            l.cbrt.overall,
            l.l2.overall,
            l.cosine.overall,
            l.log.overall,
            o.record.wall_time_s,
            o.record.iterations,
            o.record.termination,
            if o.record.converged {
                ""
            } else {
                " (not converged)"
            }
        );
    }
    s += &format!(
        "losses: weighted RMS over all valid cells ({} cells); optimised: {optimised}\n",
        outcomes.first().map_or(0, |o| o.record.cells_full)
    );
    s
}

fn pretty(v: &impl serde::Serialize) -> CliResult<String> {
    serde_json::to_string_pretty(v)
        .map(|s| s + "\n")
        .map_err(runtime)
}

pub fn run(a: FitArgs) -> CliResult<()> {
    let fams = families(&a.opts.model, &structure(&a.opts))?;
    let cfg = config(&a.opts)?;
    check_free(&fams, &cfg)?;
    if fams.len() > 1 && a.record.is_some() {
        return Err(bad_msg(
            "--record takes one model; with several, --out DIR receives every record",
        ));
    }
    let table = read_table(&a.table)?;
    // The fit needs only the cells: the table (35 MB) is freed while they are built,
    // before their geometry is allocated (FitData::from_owned_table).
    let data = FitData::from_owned_table(table)
        .map_err(|e| bad_msg(format!("{}: {e}", a.table.display())))?;
    let outcomes = fit_all(&data, &fams, &cfg, a.quiet)?;

    if fams.len() == 1 {
        let o = &outcomes[0];
        if let Some(p) = &a.out {
            write_atomic(p, pretty(&o.params)?.as_bytes())?;
        }
        if let Some(p) = &a.record {
            write_atomic(p, pretty(&o.record)?.as_bytes())?;
        }
    } else if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the output directory", dir.display()))
            .map_err(runtime)?;
        for o in &outcomes {
            let stem = o.record.family.clone();
            let p: PathBuf = dir.join(format!("{stem}.json"));
            write_atomic(&p, pretty(&o.params)?.as_bytes())?;
            write_atomic(
                &dir.join(format!("{stem}.fit.json")),
                pretty(&o.record)?.as_bytes(),
            )?;
        }
    }

    if a.json {
        let v: Vec<Value> = outcomes
            .iter()
            .map(|o| json!({"label": o.label, "params": o.params, "record": o.record}))
            .collect();
        write_text(None, &pretty(&v)?)
    } else {
        let mut text = comparison_text(&outcomes, cfg.get_loss());
        if fams.len() == 1 && a.out.is_none() {
            text += &pretty(&outcomes[0].params)?;
        }
        write_text(None, &text)
    }
}
