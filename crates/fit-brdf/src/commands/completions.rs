//! `fit-brdf completions SHELL`: the shell completion script, generated from the clap
//! definition of the command line (so it always lists every subcommand and option).

use crate::cli::{Cli, CompletionsArgs};
use crate::error::{CliResult, runtime};
use anyhow::Context;
use clap::CommandFactory;
use std::io::Write;

pub fn run(a: CompletionsArgs) -> CliResult<()> {
    let mut cmd = Cli::command();
    let mut buf = Vec::new();
    clap_complete::generate(a.shell, &mut cmd, "fit-brdf", &mut buf);
    let mut out = std::io::stdout().lock();
    out.write_all(&buf)
        .and_then(|_| out.flush())
        .context("cannot write to standard output")
        .map_err(runtime)
}
