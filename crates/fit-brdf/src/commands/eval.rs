//! `fit-brdf eval`: a table, a model, a neural BRDF or a `.bsdf` file at direction pairs,
//! CSV or `.npy` in and out (chosen by extension).

use super::{lookup_mode, read_bsdf, read_model, read_nbrdf, read_table};
use crate::cli::EvalArgs;
use crate::error::{CliResult, bad_input, runtime};
use crate::output::{write_file, write_text};
use brdfkit::core::{Rgb, Vec3};
use brdfkit::io::csv::{UNIT_TOLERANCE, format_rgb, read_pairs};
use brdfkit::io::npy::{self as npyio, Pairs, is_npy};
use brdfkit::models::raw::eval_dirs_flat;
use rayon::prelude::*;

pub fn run(a: EvalArgs) -> CliResult<()> {
    // Both sides as flat rows: N×6 directions in, N×3 values out, NaN for no sample.
    let dirs = if is_npy(&a.dirs) {
        npyio::read_pairs(&a.dirs, UNIT_TOLERANCE).map_err(bad_input)?
    } else {
        Pairs::Owned(
            read_pairs(&a.dirs)
                .map_err(bad_input)?
                .iter()
                .flat_map(|(wi, wo)| [wi.x, wi.y, wi.z, wo.x, wo.y, wo.z])
                .collect(),
        )
    };
    if let (Some(b), Some(p)) = (&a.source.bsdf, &a.out)
        && is_npy(p)
    {
        // As for a table: evaluated chunk by chunk while the previous chunk is written.
        let bsdf = read_bsdf(b)?;
        return write_file(p, |f| {
            npyio::write_values_with(f, dirs.len() / 6, |first, out| {
                bsdf.eval_flat(&dirs[6 * first..6 * first + 2 * out.len()], out);
                Ok(())
            })
        });
    }
    if let (Some(t), Some(p)) = (&a.source.table, &a.out)
        && is_npy(p)
    {
        // Table to .npy: looked up chunk by chunk while the previous chunk is written.
        // The chunks are below the size that builds the table's interleaved copy
        // (one cache line per nearest lookup instead of three), so it is built here for
        // the whole input: for 1.46 M pairs it costs 46 MB and saves about a tenth of
        // the process's time (docs/performance.md).
        let (table, mode) = (read_table(t)?, lookup_mode(a.interp));
        table.prepare_lookups(mode, dirs.len() / 6);
        return write_file(p, |f| {
            npyio::write_values_with(f, dirs.len() / 6, |first, out| {
                let rows = &dirs[6 * first..6 * first + 2 * out.len()];
                table
                    .lookup_flat(mode, rows, out)
                    .map_err(std::io::Error::other)
            })
        });
    }
    // On huge pages: 35 MB of 4 KiB first-touch faults for 1.46 M pairs cost about as
    // much CPU as the lookups.
    let mut values = brdfkit::merl::zeroed_f64(dirs.len() / 2);
    if let Some(t) = &a.source.table {
        read_table(t)?
            .lookup_flat(lookup_mode(a.interp), &dirs, &mut values)
            .map_err(runtime)?;
    } else if let Some(b) = &a.source.bsdf {
        read_bsdf(b)?.eval_flat(&dirs, &mut values);
    } else if let Some(n) = &a.source.nbrdf {
        let pairs: Vec<(Vec3, Vec3)> = dirs
            .par_chunks_exact(6)
            .map(|r| (Vec3::new(r[0], r[1], r[2]), Vec3::new(r[3], r[4], r[5])))
            .collect();
        for (o, v) in values
            .chunks_exact_mut(3)
            .zip(read_nbrdf(n)?.eval_pairs(&pairs))
        {
            o.copy_from_slice(&v.0);
        }
    } else {
        let path = a.source.model.as_ref().expect("clap requires a source");
        eval_dirs_flat(&*read_model(path)?, &dirs, &mut values).map_err(runtime)?;
    }
    match &a.out {
        Some(p) if is_npy(p) => write_file(p, |f| npyio::write_values(f, &values)),
        out => {
            let rows: Vec<Option<Rgb>> = values
                .chunks_exact(3)
                .map(|v| (!v[0].is_nan()).then(|| Rgb([v[0], v[1], v[2]])))
                .collect();
            write_text(out.as_deref(), &format_rgb(&rows))
        }
    }
}
