//! `fit-brdf score TABLE MODEL.json...` (or `--samples S MODEL.json...`): every loss of
//! given parameters against the input kinds of `fit` (a table, a `.bsdf` as
//! `--bsdf-input` says, scattered samples with their weights), without fitting (the
//! engines: `brdfkit::fit::{Measured, score}`).

use super::{cell_config, measured, read_fitted};
use crate::cli::ScoreArgs;
use crate::error::{CliResult, bad_msg, runtime};
use crate::output::write_text;
use brdfkit::fit::{Loss, LossReport, Score, score};
use serde_json::{Value, json};
use std::fmt::Write;
use std::path::PathBuf;

/// A loss table: a header, then a line per loss, overall then R, G, B (cbrt, the
/// default loss, first as in `fit` and the report).
pub fn loss_lines(l: &LossReport) -> String {
    let mut t = format!(
        "  {:<7} {:>12} {:>12} {:>12} {:>12}\n",
        "loss", "overall", "R", "G", "B"
    );
    for loss in [Loss::Cbrt, Loss::L2, Loss::Cosine, Loss::Log] {
        let c = l.get(loss);
        let _ = writeln!(
            t,
            "  {:<7} {:>12.6e} {:>12.6e} {:>12.6e} {:>12.6e}",
            loss.name(),
            c.overall,
            c.channels[0],
            c.channels[1],
            c.channels[2]
        );
    }
    t
}

/// One model file's score as text.
fn score_text(file: &str, s: &Score) -> String {
    let name = s
        .model
        .get("model")
        .and_then(Value::as_str)
        .unwrap_or("per-channel fit");
    format!(
        "{name} ({file}): {} cells of {} valid, {} weights{}\n{}",
        s.losses.cells,
        s.cells_valid,
        s.weighting.name(),
        s.theta_d_max_deg
            .map_or(String::new(), |d| format!(", θd ≤ {d}°")),
        loss_lines(&s.losses)
    )
}

pub fn run(a: ScoreArgs) -> CliResult<()> {
    let cfg = cell_config(&a.cells)?;
    // Without --samples the first file is the measurement.
    let (input, models) = match (&a.samples, &a.files[..]) {
        (Some(_), m) => (None, m),
        (None, [t, m @ ..]) if !m.is_empty() => (Some(t.as_path()), m),
        (None, _) => {
            return Err(bad_msg(
                "give a table (or --samples) and at least one model",
            ));
        }
    };
    // Every model file is read before the measurement, so a bad one fails fast.
    let given = models
        .iter()
        .map(|p| Ok((p, read_fitted(p)?)))
        .collect::<CliResult<Vec<_>>>()?;
    let m = measured(
        input,
        a.samples.as_deref(),
        a.bsdf.bsdf_input,
        false,
        a.json,
    )?;
    let info = m.info();
    let scores: Vec<(&PathBuf, Score)> = given
        .into_iter()
        .map(|(p, f)| {
            score(&f, &m.data, &cfg)
                .map(|s| (p, s))
                .map_err(|e| bad_msg(format!("{} against {}: {e}", p.display(), info.path)))
        })
        .collect::<CliResult<_>>()?;
    if a.json {
        let models: Vec<Value> = scores
            .iter()
            .map(|(p, s)| {
                let mut v = serde_json::to_value(s).map_err(runtime)?;
                v["file"] = json!(p.display().to_string());
                Ok(v)
            })
            .collect::<CliResult<_>>()?;
        // `table` (the file) is kept for the readers of older output.
        let out = json!({"table": info.path, "input": info, "models": models});
        let text = serde_json::to_string_pretty(&out).map_err(runtime)? + "\n";
        write_text(None, &text)
    } else {
        let mut text = format!("scored on {}\n", info.text());
        text.extend(
            scores
                .iter()
                .map(|(p, s)| score_text(&p.display().to_string(), s)),
        );
        write_text(None, &text)
    }
}
