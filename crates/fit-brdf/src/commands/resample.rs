//! `fit-brdf resample`: a table onto another grid, or a model written as a table.

use super::{lookup_mode, parse_dims, read_model, read_table, write_table};
use crate::cli::ResampleArgs;
use crate::error::{CliResult, runtime};
use brdfkit::merl::MerlTable;

pub fn run(a: ResampleArgs) -> CliResult<()> {
    let dims = parse_dims(&a.dims)?;
    let out = if let Some(t) = &a.source.table {
        read_table(t)?.resample(dims, lookup_mode(a.interp))
    } else {
        let path = a
            .source
            .model
            .as_ref()
            .expect("clap requires --table or --model");
        let model = read_model(path)?;
        MerlTable::from_brdf(&*model, dims).map_err(runtime)?
    };
    write_table(&out, &a.out)?;
    if a.quiet {
        return Ok(());
    }
    eprintln!(
        "wrote {} ({} x {} x {}, {:.2} % valid)",
        a.out.display(),
        dims.theta_h(),
        dims.theta_d(),
        dims.phi_d(),
        100.0 * out.valid_fraction()
    );
    Ok(())
}
