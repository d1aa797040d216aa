//! `fit-brdf resample`: a table onto another grid, or a model, a neural BRDF or a `.bsdf`
//! file written as a table.

use super::{
    lookup_mode, parse_dims, read_bsdf, read_model, read_nbrdf, read_table, write_table,
    wrote_table,
};
use crate::cli::ResampleArgs;
use crate::error::{CliResult, runtime};
use brdfkit::merl::MerlTable;

/// Random pairs of the asymmetry figure `resample --bsdf` reports (`info` uses more).
const ASYMMETRY_PAIRS: usize = 20_000;

pub fn run(a: ResampleArgs) -> CliResult<()> {
    let dims = parse_dims(&a.dims)?;
    let mut note = None;
    let out = if let Some(t) = &a.source.table {
        read_table(t)?.resample(dims, lookup_mode(a.interp))
    } else if let Some(b) = &a.source.bsdf {
        let bsdf = read_bsdf(b)?;
        let (table, stats) = bsdf.to_table(dims).map_err(runtime)?;
        let asym = bsdf.asymmetry(ASYMMETRY_PAIRS, 5.0, 1);
        note = Some(format!(
            "each cell holds the mean of f(wi, wo) and f(wo, wi), each order weighted by how \
             well the file determines it (cos^2/(cos^2 + {}^2) of the direction it divides by; \
             {} cells near grazing are held by one order): the file is not reciprocal \
             (|f(wi,wo) - f(wo,wi)| / mean over {} random pairs above 5°: median {:.1} %, \
             90th percentile {:.1} %); {} negative channel values stored as 0 (most negative \
             {:.3e} 1/sr); {} cells below the horizon are missing",
            brdfkit::rgl::ORDER_ERROR_COS,
            stats.one_order,
            asym.pairs,
            100.0 * asym.median,
            100.0 * asym.p90,
            stats.clamped_values,
            stats.most_negative,
            stats.missing
        ));
        table
    } else if let Some(n) = &a.source.nbrdf {
        let (table, stats) = read_nbrdf(n)?.to_table(dims).map_err(runtime)?;
        // The network can dip below zero where the measurement is dark; a table cannot
        // hold negative values as data (they mean "missing"), so they are clamped to 0:
        // say how many, and how far below zero they were.
        note = Some(format!(
            "{} values in {} cells were negative and are stored as 0 (most negative {:.3e} 1/sr); \
             {} cells below the horizon are missing",
            stats.clamped_values, stats.clamped_cells, stats.most_negative, stats.missing
        ));
        table
    } else {
        let path = a.source.model.as_ref().expect("clap requires a source");
        let model = read_model(path)?;
        MerlTable::from_brdf(&*model, dims).map_err(runtime)?
    };
    write_table(&out, &a.out)?;
    if a.quiet {
        return Ok(());
    }
    eprintln!("{}", wrote_table(&out, &a.out, None));
    if let Some(n) = note {
        eprintln!("{n}");
    }
    Ok(())
}
