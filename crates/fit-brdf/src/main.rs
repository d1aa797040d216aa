//! `fit-brdf`: a thin command line over the brdfkit crates.
//! Parse → validated configuration → library call → output; exit 0 on success,
//! 1 on a runtime failure, 2 on bad input or usage.
//!
//! One import rule: what the facade crate `brdfkit` re-exports (core, fit, io,
//! merl, models, nbrdf, rgl, synth) is always reached through it (`brdfkit::fit::...`); only the crates
//! it does not re-export (brdfkit-validate, brdfkit-render, brdfkit-study) are used
//! directly.

mod cli;
mod commands;
mod error;
mod output;
mod progress;

use clap::Parser;

fn main() {
    let args = cli::Cli::parse();
    let result = commands::run(args);
    std::process::exit(match result {
        Ok(()) => 0,
        Err(e) => {
            e.report();
            e.exit_code()
        }
    });
}
