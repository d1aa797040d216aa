//! `fit-brdf synth SPEC --out TABLE`: the table of a synthetic material.

use super::write_table;
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
    eprintln!(
        "wrote {} ({}: {} x {} x {}, {:.2} % valid)",
        a.out.display(),
        spec.name,
        spec.dims.theta_h(),
        spec.dims.theta_d(),
        spec.dims.phi_d(),
        100.0 * table.valid_fraction()
    );
    Ok(())
}
