//! `fit-brdf compare A B`: two representations of a material (tables, models, NBRDFs)
//! against each other (the engine: `brdfkit_validate::compare`).

use super::score::loss_lines;
use super::{cell_config, lookup_mode, parse_dims, render_options};
use crate::cli::CompareArgs;
use crate::error::{CliError, CliResult, bad_input, bad_msg, runtime};
use crate::output::{write_failed, write_text};
use anyhow::Context;
use brdfkit::core::atomic::FileSet;
use brdfkit_validate::compare::{
    CompareError, CompareOptions, Comparison, Kind, Representation, compare,
};
use std::fmt::Write;
use std::path::Path;

fn failed(e: CompareError) -> CliError {
    if matches!(e, CompareError::GridMismatch { .. }) {
        bad_msg(format!("{e} (here: --resample nearest|linear)"))
    } else if e.is_bad_input() {
        bad_input(e)
    } else {
        runtime(e)
    }
}

fn kind(k: Kind) -> &'static str {
    match k {
        Kind::Table => "table",
        Kind::Model => "model",
        Kind::Nbrdf => "NBRDF",
        Kind::RglBsdf => "RGL-EPFL .bsdf",
    }
}

fn text(c: &Comparison) -> String {
    let mut t = format!(
        "{} ({}) against {} ({}) on a {} x {} x {} grid; B: {}\n{} of A's {} valid cells compared ({} missing in B), {} weights{}\n",
        c.b.path.display(),
        kind(c.b.kind),
        c.a.path.display(),
        kind(c.a.kind),
        c.grid[0],
        c.grid[1],
        c.grid[2],
        c.b_on_grid,
        c.losses.cells,
        c.cells_a,
        c.cells_missing_in_b,
        c.weighting.name(),
        c.theta_d_max_deg
            .map_or(String::new(), |d| format!(", θd ≤ {d}°")),
    );
    t += &loss_lines(&c.losses);
    let _ = writeln!(
        t,
        "largest relative differences |B − A| / A ({} channel values with A = 0 ≠ B left out):",
        c.zero_in_a
    );
    for d in &c.largest {
        let _ = writeln!(
            t,
            "  {:>10.4e}  θh {:>6.2}° θd {:>6.2}° φd {:>6.2}° (cell {}, {}, {}) {}: A {:.4e}, B {:.4e}",
            d.relative,
            d.angles_deg[0],
            d.angles_deg[1],
            d.angles_deg[2],
            d.cell[0],
            d.cell[1],
            d.cell[2],
            ["R", "G", "B"][d.channel],
            d.a,
            d.b
        );
    }
    for s in &c.renders {
        let r = &s.models[0].diff;
        let _ = writeln!(
            t,
            "render ({}): mean |Δ| {:.4} display units, rel. RMS radiance {:.2} %",
            s.lighting.title(),
            r.mean_abs_display,
            r.rel_rms_radiance * 100.0
        );
    }
    t
}

/// DIR/compare.json and, per lighting, the A, B and difference PNGs, as one FileSet.
fn write_out(dir: &Path, c: &Comparison) -> CliResult<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create the output directory", dir.display()))
        .map_err(runtime)?;
    let json = serde_json::to_string_pretty(c).map_err(runtime)? + "\n";
    let mut set = FileSet::new();
    set.stage_bytes(&dir.join("compare.json"), json.as_bytes())
        .map_err(write_failed)?;
    for s in &c.renders {
        let l = format!("{:?}", s.lighting).to_lowercase();
        let m = &s.models[0];
        for (what, png) in [("a", &s.table_png), ("b", &m.png), ("diff", &m.diff_png)] {
            set.stage_bytes(&dir.join(format!("{l}-{what}.png")), png)
                .map_err(write_failed)?;
        }
    }
    set.commit().map_err(write_failed)
}

pub fn run(a: CompareArgs) -> CliResult<()> {
    let o = CompareOptions {
        config: cell_config(&a.cells)?,
        resample: a.resample.map(lookup_mode),
        dims: parse_dims(&a.dims)?,
        top: a.top,
        render: render_options(&a.spheres)?,
    };
    let ra = Representation::load(&a.a).map_err(failed)?;
    let rb = Representation::load(&a.b).map_err(failed)?;
    let c = compare(&a.a, &ra, &a.b, &rb, &o).map_err(failed)?;
    if let Some(dir) = &a.out {
        write_out(dir, &c)?;
    }
    if a.json {
        let v = serde_json::to_string_pretty(&c).map_err(runtime)? + "\n";
        write_text(None, &v)
    } else {
        write_text(None, &text(&c))
    }
}
