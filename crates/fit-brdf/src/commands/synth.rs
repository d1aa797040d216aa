//! `fit-brdf synth SPEC --out TABLE`: the table of a synthetic material.

use super::{write_table, wrote_table};
use crate::cli::SynthArgs;
use crate::error::{CliResult, bad_input, runtime};
use brdfkit::synth::SynthSpec;

pub fn run(a: SynthArgs) -> CliResult<()> {
    let spec = SynthSpec::read(&a.spec).map_err(bad_input)?;
    let table = spec.synthesize().map_err(runtime)?;
    write_table(&table, &a.out)?;
    if a.quiet {
        return Ok(());
    }
    eprintln!("{}", wrote_table(&table, &a.out, Some(&spec.name)));
    Ok(())
}
