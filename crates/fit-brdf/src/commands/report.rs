//! `fit-brdf report TABLE --models ... --out DIR`: fit every model and write the
//! fit-quality report (DIR/index.html, DIR/report.json) of `brdfkit_validate::html`.

use super::fit::{Family, Outcome, comparison_text, config, families, fit_all, structure};
use super::read_table;
use crate::cli::ReportArgs;
use crate::error::{CliResult, bad_msg, runtime};
use crate::output::write_text;
use anyhow::Context;
use brdfkit::merl::MerlTable;
use brdfkit_fit::{FitConfig, FitData};
use brdfkit_validate::html::renders::RenderOptions;
use brdfkit_validate::html::{FitReport, ModelFit, ReportOptions, build_report};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The report's files in DIR.
pub const HTML_FILE: &str = "index.html";
pub const JSON_FILE: &str = "report.json";

/// Fits every family, one after the other, with a line per model on stderr (the
/// progress bar of `fit` appears under it when a fit runs for more than a second).
pub fn fit_families(
    data: &FitData,
    fams: &[Family],
    cfg: &FitConfig,
    quiet: bool,
) -> CliResult<Vec<Outcome>> {
    let mut out = Vec::new();
    for (k, f) in fams.iter().enumerate() {
        if !quiet {
            eprintln!("[{}/{}] fitting {} ...", k + 1, fams.len(), f.label);
        }
        let mut o = fit_all(data, std::slice::from_ref(f), cfg, quiet)?;
        let o = o.remove(0);
        if !quiet {
            eprintln!(
                "      {} loss {:.4e} in {:.2} s ({} iterations{})",
                cfg.get_loss(),
                o.record.losses_full.get(cfg.get_loss()).overall,
                o.record.wall_time_s,
                o.record.iterations,
                if o.record.converged {
                    ""
                } else {
                    ", not converged"
                }
            );
        }
        out.push(o);
    }
    Ok(out)
}

/// Builds the report of fitted outcomes; progress lines go to stderr unless `quiet`.
pub fn make_report(
    table: &MerlTable,
    table_name: &str,
    outcomes: &[Outcome],
    cfg: &FitConfig,
    options: &ReportOptions,
    quiet: bool,
) -> CliResult<FitReport> {
    let fits = outcomes
        .iter()
        .map(|o| {
            Ok(ModelFit {
                label: o.label.clone(),
                fitted: brdfkit_validate::fitted_from_json(&o.params)
                    .map_err(|e| runtime(anyhow::anyhow!("{}: fitted model: {e}", o.label)))?,
                record: Some(o.record.clone()),
            })
        })
        .collect::<CliResult<Vec<_>>>()?;
    let progress = |s: &str| {
        if !quiet {
            eprintln!("report: {s}");
        }
    };
    build_report(table, table_name, &fits, Some(cfg), options, &progress)
        .map_err(|e| runtime(anyhow::anyhow!("{table_name}: the report failed: {e}")))
}

/// Writes DIR/report.json and DIR/index.html: both are written whole to temporary files
/// in DIR first, then renamed into place; if the second rename fails the first file is
/// removed again, so DIR never holds half a report. DIR may exist.
pub fn write_report(dir: &Path, report: &FitReport) -> CliResult<(PathBuf, PathBuf)> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create the output directory", dir.display()))
        .map_err(runtime)?;
    let files = [
        (dir.join(JSON_FILE), report.to_json_pretty()),
        (dir.join(HTML_FILE), report.html.clone()),
    ];
    let mut temps = Vec::new();
    for (path, text) in &files {
        let mut tmp = tempfile::NamedTempFile::new_in(dir)
            .with_context(|| {
                format!(
                    "{}: cannot create a temporary file in {}",
                    path.display(),
                    dir.display()
                )
            })
            .map_err(runtime)?;
        // A temporary file is private (0600); a report is for reading: 0644.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let _ = tmp
                .as_file()
                .set_permissions(std::fs::Permissions::from_mode(0o644));
        }
        tmp.write_all(text.as_bytes())
            .and_then(|_| tmp.as_file().sync_all())
            .with_context(|| format!("{}: write failed", path.display()))
            .map_err(runtime)?;
        temps.push(tmp);
    }
    let mut placed: Vec<&Path> = Vec::new();
    for (tmp, (path, _)) in temps.into_iter().zip(&files) {
        if let Err(e) = tmp.persist(path) {
            for p in &placed {
                // Best effort: the error below is what the user needs to see.
                let _ = std::fs::remove_file(p);
            }
            return Err(runtime(anyhow::Error::new(e.error).context(format!(
                "{}: cannot move the finished file into place",
                path.display()
            ))));
        }
        placed.push(path);
    }
    Ok((files[1].0.clone(), files[0].0.clone()))
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
    let fams = families(&a.opts.model, &structure(&a.opts))?;
    let cfg = config(&a.opts)?;
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
    let outcomes = fit_families(&data, &fams, &cfg, a.quiet)?;
    let t_fit = t0.elapsed().as_secs_f64();
    let name = a
        .table
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| a.table.display().to_string());
    let report = make_report(&table, &name, &outcomes, &cfg, &opts, a.quiet)?;
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
