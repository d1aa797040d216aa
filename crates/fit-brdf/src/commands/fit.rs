//! `fit-brdf fit TABLE --model ...`: nonlinear least-squares fits of analytic models
//! (the families and the settings: `brdfkit::fit::families`); `--for RENDERER`: the
//! renderer's configurations, the best written (`brdfkit::fit::target`).

use super::{fit_data, fit_setup};
use crate::cli::FitArgs;
use crate::error::{CliResult, bad_msg, runtime};
use crate::output::{write_atomic, write_text};
use crate::progress;
use anyhow::Context;
use brdfkit::fit::families::{Outcome, comparison_text, fit_each, pretty_file, stage_times_text};
use brdfkit::fit::target::fit_for;
use serde_json::Value;
use std::time::Instant;

/// Pretty JSON with a final newline (the library's, which Python's `FitResult.save`
/// writes too).
fn pretty(v: &impl serde::Serialize) -> CliResult<String> {
    pretty_file(v).map_err(runtime)
}

pub fn run(a: FitArgs) -> CliResult<()> {
    let (fams, cfg) = fit_setup(&a.opts)?;
    if fams.len() > 1 && a.record.is_some() {
        return Err(bad_msg(
            "--record takes one model; with several, --out DIR receives every record",
        ));
    }
    let (data, read_s, cells_s) = fit_data(&a.input)?;
    let bars = progress::Progress::new(a.quiet);
    let (outcomes, best) = match a.for_renderer {
        None => (fit_each(&data, &fams, &cfg, &bars).map_err(runtime)?, None),
        Some(r) => {
            let t = fit_for(&data, r.target(), &cfg, &bars).map_err(runtime)?;
            (t.outcomes, Some((r, t.best, t.why)))
        }
    };
    if let Some((r, best, why)) = best {
        return write_best(&a, &outcomes, best, &why, r, cfg.get_loss());
    }

    let t = Instant::now();
    if let [o] = &outcomes[..] {
        if let Some(p) = &a.out {
            write_atomic(p, pretty(&o.params())?.as_bytes())?;
        }
        if let Some(p) = &a.record {
            write_atomic(p, pretty(&o.record)?.as_bytes())?;
        }
    } else if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: cannot create the output directory", dir.display()))
            .map_err(runtime)?;
        for o in &outcomes {
            let stem = &o.record.family;
            write_atomic(
                &dir.join(format!("{stem}.json")),
                pretty(&o.params())?.as_bytes(),
            )?;
            write_atomic(
                &dir.join(format!("{stem}.fit.json")),
                pretty(&o.record)?.as_bytes(),
            )?;
        }
    }
    if a.stage_times {
        let per_table = [("read", read_s), ("cells", cells_s)];
        eprint!("{}", stage_times_text(&per_table, &outcomes));
        eprintln!("write {:.1} ms", 1e3 * t.elapsed().as_secs_f64());
    }
    if a.json {
        let v: Vec<Value> = outcomes.iter().map(Outcome::to_json).collect();
        write_text(None, &pretty(&v)?)
    } else {
        let mut text = comparison_text(&outcomes, cfg.get_loss());
        if outcomes.len() == 1 && a.out.is_none() {
            text += &pretty(&outcomes[0].params())?;
        }
        write_text(None, &text)
    }
}

/// `--for`: the comparison, the choice and the best model (to --out, or stdout).
fn write_best(
    a: &FitArgs,
    outcomes: &[Outcome],
    best: usize,
    why: &str,
    r: crate::cli::Renderer,
    loss: brdfkit::fit::Loss,
) -> CliResult<()> {
    let o = &outcomes[best];
    if let Some(p) = &a.out {
        write_atomic(p, pretty(&o.params())?.as_bytes())?;
    }
    if let Some(p) = &a.record {
        write_atomic(p, pretty(&o.record)?.as_bytes())?;
    }
    let target = r.target().name();
    if a.json {
        let v: Vec<Value> = outcomes.iter().map(Outcome::to_json).collect();
        let v = serde_json::json!({"for": target, "best": o.label, "why": why, "outcomes": v});
        return write_text(None, &pretty(&v)?);
    }
    let mut text = comparison_text(outcomes, loss);
    text += &format!(
        "best for {target}: {} ({why}; {loss} loss); `fit-brdf export {} --to {target}` writes it\n",
        o.label,
        a.out
            .as_ref()
            .map_or_else(|| "PARAMS.json".into(), |p| p.display().to_string()),
    );
    if a.out.is_none() {
        text += &pretty(&o.params())?;
    }
    write_text(None, &text)
}
