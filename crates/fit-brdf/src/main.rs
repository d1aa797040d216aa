//! `fit-brdf`: a thin command line over the brdfkit crates.
//! Parse → validated configuration → library call → output; exit 0 on success,
//! 1 on a runtime failure, 2 on bad input or usage.

mod cli;
mod commands;
mod csvio;
mod error;
mod output;

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
