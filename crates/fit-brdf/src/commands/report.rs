//! `fit-brdf report TABLE --models ... --out DIR`: fit every model and write the
//! fit-quality report (DIR/index.html, DIR/report.json) of `brdfkit_validate::html`.

use super::{fit_setup, read_table};
use crate::cli::ReportArgs;
use crate::error::{CliResult, bad_msg, runtime};
use crate::output::{write_failed, write_text};
use crate::progress;
use anyhow::Context;
use brdfkit::core::atomic::FileSet;
use brdfkit::fit::families::{Outcome, comparison_text, fit_each};
use brdfkit::fit::{FitConfig, FitData};
use brdfkit::merl::MerlTable;
use brdfkit_validate::html::renders::RenderOptions;
use brdfkit_validate::html::{FitReport, ModelFit, ReportOptions, build_report_from};
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
    let fits = model_fits(outcomes)?;
    build_report_from(
        table,
        cells,
        table_name,
        &fits,
        Some(cfg),
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

/// The report options of the command line.
fn options(a: &ReportArgs) -> CliResult<ReportOptions> {
    if !(8..=1024).contains(&a.render_size) {
        return Err(bad_msg(format!(
            "--render-size {}: must be in 8..=1024 pixels",
            a.render_size
        )));
    }
    if !(1..=4096).contains(&a.env_spp) {
        return Err(bad_msg(format!(
            "--env-spp {}: must be in 1..=4096",
            a.env_spp
        )));
    }
    let mut o = ReportOptions::default();
    if a.no_renders {
        o.render = None;
    } else {
        o.render = Some(RenderOptions {
            size: a.render_size,
            env_spp: a.env_spp,
            ..RenderOptions::default()
        });
    }
    if a.no_checks {
        o.checks = None;
    }
    Ok(o)
}

pub fn run(a: ReportArgs) -> CliResult<()> {
    let t0 = Instant::now();
    let (fams, cfg) = fit_setup(&a.opts)?;
    let mut opts = options(&a)?;
    opts.weighting = cfg.get_weighting();
    let table = read_table(&a.table)?;
    let data =
        FitData::from_table(&table).map_err(|e| bad_msg(format!("{}: {e}", a.table.display())))?;
    if !a.quiet {
        eprintln!(
            "fitting {} model(s) to {} ({} valid cells)",
            fams.len(),
            a.table.display(),
            data.len()
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
    // The report takes the table and the fits' cells over: it shares the cells' geometry
    // across models and sections and frees it before the renders.
    let report = make_report_from(
        Arc::new(table),
        data,
        &name,
        &outcomes,
        &cfg,
        &opts,
        a.quiet,
    )?;
    let (html, json) = write_report(&a.out, &report)?;
    if a.json {
        write_text(None, &report.summary_json_pretty())
    } else {
        let text = format!(
            "{}report: {} (and {}); fits {:.1} s, report {:.1} s\n",
            comparison_text(&outcomes, cfg.get_loss()),
            html.display(),
            json.display(),
            t_fit,
            report.data.timings.total_s
        );
        write_text(None, &text)
    }
}
