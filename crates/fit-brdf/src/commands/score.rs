//! `fit-brdf score TABLE MODEL.json...`: every loss of given parameters against a
//! table, without fitting (the engine: `brdfkit::fit::score`).

use super::{cell_config, read_fitted, read_table};
use crate::cli::ScoreArgs;
use crate::error::{CliResult, bad_msg, runtime};
use crate::output::write_text;
use brdfkit::fit::{FitData, Loss, LossReport, Score, score};
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
    // Every model file is read before the table, so a bad one fails fast.
    let given = a
        .models
        .iter()
        .map(|p| Ok((p, read_fitted(p)?)))
        .collect::<CliResult<Vec<_>>>()?;
    let table = read_table(&a.table)?;
    // The cells of `fit` (FitData::from_owned_table gives those of from_table).
    let data = FitData::from_owned_table(table)
        .map_err(|e| bad_msg(format!("{}: {e}", a.table.display())))?;
    let scores: Vec<(&PathBuf, Score)> = given
        .into_iter()
        .map(|(p, f)| {
            score(&f, &data, &cfg).map(|s| (p, s)).map_err(|e| {
                bad_msg(format!(
                    "{} against {}: {e}",
                    p.display(),
                    a.table.display()
                ))
            })
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
        let out = json!({"table": a.table.display().to_string(), "models": models});
        let text = serde_json::to_string_pretty(&out).map_err(runtime)? + "\n";
        write_text(None, &text)
    } else {
        let text: String = scores
            .iter()
            .map(|(p, s)| score_text(&p.display().to_string(), s))
            .collect();
        write_text(None, &text)
    }
}
