//! `fit-brdf eval`: a table or a model at the direction pairs of a CSV file.

use super::{lookup_mode, read_model, read_table};
use crate::cli::EvalArgs;
use crate::csvio::{format_rgb, read_pairs};
use crate::error::CliResult;
use crate::output::write_text;
use brdfkit::core::Rgb;
use rayon::prelude::*;

pub fn run(a: EvalArgs) -> CliResult<()> {
    let pairs = read_pairs(&a.dirs)?;
    let values: Vec<Option<Rgb>> = if let Some(t) = &a.source.table {
        let table = read_table(t)?;
        table.lookup_batch(lookup_mode(a.interp), &pairs)
    } else {
        let path = a
            .source
            .model
            .as_ref()
            .expect("clap requires --table or --model");
        let model = read_model(path)?;
        pairs
            .par_iter()
            .map(|(wi, wo)| Some(model.eval(wi, wo)))
            .collect()
    };
    write_text(a.out.as_deref(), &format_rgb(&values))
}
