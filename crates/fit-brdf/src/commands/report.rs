//! `fit-brdf report TABLE --models ... [--given MODEL.json,...] --out DIR`: fit every
//! model, add the given ones (not fitted), and write the fit-quality report
//! (DIR/index.html, DIR/report.json) of `brdfkit_validate::html`.

use super::{cell_config, fit_setup, read_fitted, read_table};
use crate::cli::{ReportArgs, SphereOptions};
use crate::error::{CliResult, bad_msg, runtime};
use crate::output::{write_failed, write_text};
use crate::progress;
use anyhow::Context;
use brdfkit::core::atomic::FileSet;
use brdfkit::fit::families::{Outcome, comparison_text, fit_each};
use brdfkit::fit::score::check_isotropic;
use brdfkit::fit::{FitConfig, FitData};
use brdfkit::merl::MerlTable;
use brdfkit_validate::html::renders::RenderOptions;
use brdfkit_validate::html::{FitReport, ModelFit, Origin, ReportOptions, build_report_from};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// The report's files in DIR.
pub const HTML_FILE: &str = "index.html";
pub const JSON_FILE: &str = "report.json";

/// The report's models: each outcome's fitted model, with its record.
fn model_fits(outcomes: &[Outcome]) -> CliResult<Vec<ModelFit>> {
    outcomes
        .iter()
        .map(|o| {
            Ok(ModelFit {
                label: o.label.clone(),
                fitted: brdfkit_validate::fitted_from_json(&o.params)
                    .map_err(|e| runtime(anyhow::anyhow!("{}: fitted model: {e}", o.label)))?,
                record: Some(o.record.clone()),
                origin: Origin::Fitted,
            })
        })
        .collect()
}

/// The report's given models: each file read ([`read_fitted`]), labelled as given.
fn given_fits(paths: &[PathBuf]) -> CliResult<Vec<ModelFit>> {
    paths
        .iter()
        .map(|p| {
            let fitted = read_fitted(p)?;
            check_isotropic(&fitted).map_err(|e| bad_msg(format!("{}: {e}", p.display())))?;
            let name = fitted
                .shared()
                .map_or("per-channel", |m| m.name())
                .to_string();
            Ok(ModelFit {
                label: format!("{name} (given: {})", p.display()),
                fitted,
                record: None,
                origin: Origin::Given,
            })
        })
        .collect()
}

/// A progress sink that prints `report: <step>` on stderr unless `quiet`.
fn progress_lines(quiet: bool) -> impl Fn(&str) + Sync {
    move |s: &str| {
        if !quiet {
            eprintln!("report: {s}");
        }
    }
}

/// Builds the report of fitted outcomes on the table and the cells the fits used
/// (`cells` is `FitData::from_table(&table)`); progress lines go to stderr unless
/// `quiet`. The report reuses the cells and the fits' losses
/// instead of rebuilding them, and frees the cells once it no longer needs them.
pub fn make_report_from(
    table: Arc<MerlTable>,
    cells: FitData,
    table_name: &str,
    outcomes: &[Outcome],
    cfg: &FitConfig,
    options: &ReportOptions,
    quiet: bool,
) -> CliResult<FitReport> {
    make_report_with(
        table,
        cells,
        table_name,
        &model_fits(outcomes)?,
        Some(cfg),
        options,
        quiet,
    )
}

/// [`make_report_from`] for any models, fitted or given; `cfg` is the fit
/// configuration when something was fitted.
fn make_report_with(
    table: Arc<MerlTable>,
    cells: FitData,
    table_name: &str,
    fits: &[ModelFit],
    cfg: Option<&FitConfig>,
    options: &ReportOptions,
    quiet: bool,
) -> CliResult<FitReport> {
    build_report_from(
        table,
        cells,
        table_name,
        fits,
        cfg,
        options,
        &progress_lines(quiet),
    )
    .map_err(|e| runtime(anyhow::anyhow!("{table_name}: the report failed: {e}")))
}

/// Writes DIR/report.json and DIR/index.html as one [`FileSet`]: both are staged whole
/// beside their destinations, then renamed into place; if the second rename fails the
/// first is rolled back, so DIR never holds half a report. DIR may exist.
pub fn write_report(dir: &Path, report: &FitReport) -> CliResult<(PathBuf, PathBuf)> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create the output directory", dir.display()))
        .map_err(runtime)?;
    let (json, html) = (dir.join(JSON_FILE), dir.join(HTML_FILE));
    let mut set = FileSet::new();
    set.stage_bytes(&json, report.to_json_pretty().as_bytes())
        .map_err(write_failed)?;
    set.stage_bytes(&html, report.html.as_bytes())
        .map_err(write_failed)?;
    set.commit().map_err(write_failed)?;
    Ok((html, json))
}

/// The sphere renders of the command line (`None`: skipped); shared with `compare`.
pub fn render_options(s: &SphereOptions) -> CliResult<Option<RenderOptions>> {
    if !(8..=1024).contains(&s.render_size) {
        return Err(bad_msg(format!(
            "--render-size {}: must be in 8..=1024 pixels",
            s.render_size
        )));
    }
    if !(1..=4096).contains(&s.env_spp) {
        return Err(bad_msg(format!(
            "--env-spp {}: must be in 1..=4096",
            s.env_spp
        )));
    }
    Ok((!s.no_renders).then(|| RenderOptions {
        size: s.render_size,
        env_spp: s.env_spp,
        ..RenderOptions::default()
    }))
}

/// The report options of the command line.
fn options(a: &ReportArgs) -> CliResult<ReportOptions> {
    let mut o = ReportOptions {
        render: render_options(&a.spheres)?,
        ..ReportOptions::default()
    };
    if a.no_checks {
        o.checks = None;
    }
    Ok(o)
}

pub fn run(a: ReportArgs) -> CliResult<()> {
    let t0 = Instant::now();
    let given = given_fits(&a.given)?;
    // `--given` alone leaves --models empty: nothing is fitted.
    let fitting = !a.opts.model.trim().is_empty() || given.is_empty();
    let (fams, cfg) = if fitting {
        fit_setup(&a.opts)?
    } else {
        (Vec::new(), cell_config(&a.opts.cells)?)
    };
    let mut opts = options(&a)?;
    opts.weighting = cfg.get_weighting();
    let table = read_table(&a.table)?;
    let data =
        FitData::from_table(&table).map_err(|e| bad_msg(format!("{}: {e}", a.table.display())))?;
    if !a.quiet {
        eprintln!(
            "fitting {} model(s) to {} ({} valid cells); {} given",
            fams.len(),
            a.table.display(),
            data.len(),
            given.len()
        );
    }
    let outcomes = fit_each(
        &data,
        &fams,
        &cfg,
        &progress::Families::with_lines(cfg.get_loss(), a.quiet),
    )
    .map_err(runtime)?;
    let t_fit = t0.elapsed().as_secs_f64();
    let name = a
        .table
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| a.table.display().to_string());
    let mut fits = model_fits(&outcomes)?;
    fits.extend(given);
    // The report takes the table and the fits' cells over: it shares the cells' geometry
    // across models and sections and frees it before the renders.
    let report = make_report_with(
        Arc::new(table),
        data,
        &name,
        &fits,
        fitting.then_some(&cfg),
        &opts,
        a.quiet,
    )?;
    let (html, json) = write_report(&a.out, &report)?;
    if a.json {
        return write_text(None, &report.summary_json_pretty());
    }
    let mut text = if outcomes.is_empty() {
        String::new()
    } else {
        comparison_text(&outcomes, cfg.get_loss())
    };
    for m in report.data.summary.models.iter() {
        if m.origin == Origin::Given {
            let l = &m.losses;
            text += &format!(
                "{}: cbrt {:.6e}, l2 {:.6e}, cosine {:.6e}, log {:.6e}\n",
                m.label, l.cbrt.overall, l.l2.overall, l.cosine.overall, l.log.overall
            );
        }
    }
    text += &format!(
        "report: {} (and {}); fits {:.1} s, report {:.1} s\n",
        html.display(),
        json.display(),
        t_fit,
        report.data.timings.total_s
    );
    write_text(None, &text)
}
