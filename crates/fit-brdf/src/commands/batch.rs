//! `fit-brdf batch INPUT... --models ... --out OUTDIR [--shard I/N]`: fit every table of
//! a database with the batch engine of `brdfkit::fit::batch` (its module doc describes
//! the per-table JSON, the summary CSV, resuming and shards).
//!
//! **Interrupts** (installed here, the engine only sees its cancel token): the first
//! SIGINT, SIGTERM or SIGHUP lets the current table finish and stops before the next
//! one; a second stops at once, but never inside a file write (the handler waits for
//! the token's write lock). Either way every output present is complete and no
//! temporary file is left.

use super::fit_setup;
use crate::cli::BatchArgs;
use crate::error::{CliResult, bad_input, runtime};
use crate::output::write_text;
use crate::progress;
use anyhow::{Context, anyhow};
use brdfkit::fit::batch::{BatchError, BatchJob, Cancel, Source};

/// The stop requests of this process (a signal handler can reach only a static).
static CANCEL: Cancel = Cancel::new();

/// Installs the interrupt handler (once per process).
fn install_handler() -> CliResult<()> {
    ctrlc::set_handler(|| {
        if CANCEL.request() == 1 {
            eprintln!(
                "\nfit-brdf batch: interrupted; finishing the current table, then stopping \
                 (interrupt again to stop now)"
            );
        } else {
            // Never between a temporary file's creation and its rename.
            let _g = CANCEL.hold_writes();
            eprintln!("fit-brdf batch: stopped; rerun the same command to resume");
            std::process::exit(1);
        }
    })
    .context("cannot install the interrupt handler")
    .map_err(runtime)
}

fn batch_error(e: BatchError) -> crate::error::CliError {
    if let BatchError::Family(f) = e {
        return crate::error::bad_settings(f);
    }
    if e.is_bad_input() {
        bad_input(e)
    } else {
        runtime(e)
    }
}

pub fn run(a: BatchArgs) -> CliResult<()> {
    let (fams, cfg) = fit_setup(&a.opts)?;
    let source = if a.nbrdf {
        Source::Nbrdf
    } else {
        Source::Binary
    };
    let job = BatchJob::new_from(&a.inputs, source, &a.out, a.shard, fams, cfg)
        .map_err(batch_error)?
        .with_bsdf_input(a.bsdf.bsdf_input);
    install_handler()?;
    let bars = progress::Progress::new(a.quiet);
    let report = job.run(a.force, &CANCEL, &bars);
    bars.finish();
    let report = report.map_err(batch_error)?;
    if a.json {
        let text = serde_json::to_string_pretty(&report.to_json()).map_err(runtime)?;
        write_text(None, &(text + "\n"))?;
    } else {
        write_text(None, &report.text())?;
    }
    match report.problem() {
        Some(p) => Err(runtime(anyhow!(p))),
        None => Ok(()),
    }
}
