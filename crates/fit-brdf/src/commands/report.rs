//! `fit-brdf report TABLE|X.bsdf|--samples S --models ... [--given MODEL.json,...] --out
//! DIR`: fit every model, add the given ones (not fitted), and write the fit-quality
//! report (DIR/index.html, DIR/report.json) of `brdfkit_validate::html`: the table
//! report, or the report on scattered data for a `.bsdf`'s points and samples.

use super::{cell_config, fit_setup, read_fitted, render_options};
use crate::cli::ReportArgs;
use crate::error::{CliResult, bad_msg, runtime};
use crate::output::{write_failed, write_text};
use crate::progress;
use brdfkit::fit::families::{Outcome, comparison_text, fit_each};
use brdfkit::fit::score::check_isotropic;
use brdfkit::fit::{FitConfig, FitData};
use brdfkit::merl::MerlTable;
use brdfkit_validate::html::{
    AnyReport, FitReport, ModelFit, ReportOptions, build_any_report, build_report_from,
};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// The report's models: each outcome's fitted model, with its record.
pub fn model_fits(outcomes: &[Outcome]) -> CliResult<Vec<ModelFit>> {
    outcomes
        .iter()
        .map(|o| ModelFit::fitted(o).map_err(runtime))
        .collect()
}

/// The report's given models: each file read ([`read_fitted`]), labelled as given.
fn given_fits(paths: &[PathBuf]) -> CliResult<Vec<ModelFit>> {
    paths
        .iter()
        .map(|p| {
            let fitted = read_fitted(p)?;
            check_isotropic(&fitted).map_err(|e| bad_msg(format!("{}: {e}", p.display())))?;
            Ok(ModelFit::given(fitted, p))
        })
        .collect()
}

/// Builds the report of `fits` on the table and the cells the fits used (`cells` is
/// `FitData::from_table(&table)`: the report reuses them and the fits' losses instead of
/// rebuilding them, and frees the cells once it no longer needs them); `cfg` is the fit
/// configuration when something was fitted. Progress lines go to stderr unless `quiet`.
pub fn make_report(
    (table, cells): (Arc<MerlTable>, FitData),
    table_name: &str,
    fits: &[ModelFit],
    cfg: Option<&FitConfig>,
    options: &ReportOptions,
    quiet: bool,
) -> CliResult<FitReport> {
    let progress = progress::Progress::new(quiet);
    build_report_from(table, cells, table_name, fits, cfg, options, &progress)
        .map_err(|e| runtime(anyhow::anyhow!("{table_name}: the report failed: {e}")))
}

/// The report options of the command line.
fn options(a: &ReportArgs, cfg: &FitConfig) -> CliResult<ReportOptions> {
    let mut o = ReportOptions {
        render: render_options(&a.spheres)?,
        weighting: cfg.get_weighting(),
        ..ReportOptions::default()
    };
    if a.no_checks {
        o.checks = None;
    }
    Ok(o)
}

/// The text `report` prints: the fitted models' comparison, the given models' losses,
/// where the files are and what they took.
fn summary_text(
    outcomes: &[Outcome],
    cfg: &FitConfig,
    report: &AnyReport,
    at: &[PathBuf; 2],
    t_fit: f64,
) -> String {
    let mut text = if outcomes.is_empty() {
        String::new()
    } else {
        comparison_text(outcomes, cfg.get_loss())
    };
    text += &report.given_losses_text();
    text += &format!(
        "report: {} (and {}); fits {:.1} s, report {:.1} s\n",
        at[0].display(),
        at[1].display(),
        t_fit,
        report.total_s()
    );
    text
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
    let opts = options(&a, &cfg)?;
    let m = a.input.read(true, a.quiet)?;
    let progress = progress::Progress::with_family_lines(a.quiet);
    let (n, info) = (fams.len(), m.info().text());
    progress.say(&format!(
        "fitting {n} model(s) to {info}; {} given",
        given.len()
    ));
    let outcomes = fit_each(&m.data, &fams, &cfg, &progress).map_err(runtime)?;
    let t_fit = t0.elapsed().as_secs_f64();
    let mut fits = model_fits(&outcomes)?;
    fits.extend(given);
    let path = m.path.display().to_string();
    let report = build_any_report(m, &fits, fitting.then_some(&cfg), &opts, &progress)
        .map_err(|e| runtime(anyhow::anyhow!("{path}: the report failed: {e}")))?;
    let (html, json) = report.write_to(&a.out).map_err(write_failed)?;
    if a.json {
        return write_text(None, &report.summary_json_pretty());
    }
    let at = [html, json];
    write_text(None, &summary_text(&outcomes, &cfg, &report, &at, t_fit))
}
