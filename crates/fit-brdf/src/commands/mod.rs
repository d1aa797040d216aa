//! One module per subcommand; `run` dispatches.

mod batch;
mod check;
mod compare;
mod completions;
mod demo;
mod demo_material;
mod eval;
mod export;
mod fit;
mod info;
mod info_rgl;
mod render;
mod report;
mod resample;
mod score;
mod study;
mod synth;
mod view;

use crate::cli::{CellOptions, Cli, Command, FitOptions, Interp, MeasuredArgs, SphereOptions};
use crate::error::{CliResult, bad_input, bad_msg, bad_report_option, bad_settings, runtime};
use anyhow::Context;
use brdfkit::core::Model;
use brdfkit::fit::families::{Family, FitSettings, Structure, check_free, families};
use brdfkit::fit::{BsdfInput, FitConfig, FitData, Fitted, Measured};
use brdfkit::merl::{Dims, Lookup, MerlError, MerlTable};
use brdfkit_validate::html::renders::RenderOptions;
use std::path::Path;

pub fn run(cli: Cli) -> CliResult<()> {
    match cli.command {
        Command::Info(a) => info::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Resample(a) => resample::run(a),
        Command::Synth(a) => synth::run(a),
        Command::Fit(a) => fit::run(a),
        Command::Check(a) => check::run(a),
        Command::Render(a) => render::run(a),
        Command::Demo(a) => demo::run(a),
        Command::Report(a) => report::run(a),
        Command::Batch(a) => batch::run(a),
        Command::Export(a) => export::run(a),
        Command::Completions(a) => completions::run(a),
        Command::Study(a) => study::run(*a),
        Command::Score(a) => score::run(a),
        Command::Compare(a) => compare::run(a),
        Command::View(a) => view::run(a),
    }
}

/// The model families and the validated fit configuration of the fit options (shared by
/// `fit`, `report` and `batch`), every `--fix` name checked against every family; any
/// error is bad input (exit 2).
pub fn fit_setup(o: &FitOptions) -> CliResult<(Vec<Family>, FitConfig)> {
    let structure = Structure {
        distribution: o.distribution,
        masking: o.masking,
        fresnel: o.fresnel,
        normalization: o.normalization,
    };
    let fams = families(&o.model, &structure).map_err(bad_settings)?;
    let cfg = settings_of(o).config().map_err(bad_settings)?;
    check_free(&fams, &cfg).map_err(bad_settings)?;
    Ok((fams, cfg))
}

/// The fit options as the library's settings, field by field (their defaults are
/// [`FitSettings::default`]'s: `cli::defaults`).
fn settings_of(o: &FitOptions) -> FitSettings {
    FitSettings {
        loss: o.loss,
        solver: o.solver,
        starts: o.starts,
        finish: o.finish,
        sample_fraction: o.sample_fraction,
        per_channel: o.per_channel,
        seed: o.seed,
        fix: o.fix.clone(),
        robust: o.robust,
        robust_scale: o.robust_scale,
        albedo_max: o.energy_conserving.then_some(1.0),
        full_iters: o.full_iters,
        explore_cells: Some(o.explore_cells),
        losses: o.losses,
        ..cell_settings(&o.cells)
    }
}

/// The cell options as fit settings, the rest at their defaults: the one place where a
/// cell option (shared by `fit`, `report`, `batch`, `score` and `compare`) becomes a
/// library setting.
pub fn cell_settings(c: &CellOptions) -> FitSettings {
    FitSettings {
        weighting: c.weighting,
        theta_d_max_deg: c.theta_d_max,
        theta_max_deg: c.theta_max,
        ..FitSettings::default()
    }
}

/// The sphere renders of the command line (`None`: skipped), checked by the library and
/// named by their flags; shared with `compare`.
pub fn render_options(s: &SphereOptions) -> CliResult<Option<RenderOptions>> {
    let r = RenderOptions {
        size: s.render_size,
        env_spp: s.env_spp,
        ..RenderOptions::default()
    };
    r.check().map_err(bad_report_option)?;
    Ok((!s.no_renders).then_some(r))
}

/// The validated configuration of the cell options alone (what `score` and `compare`
/// need); an error is bad input (exit 2).
pub fn cell_config(c: &CellOptions) -> CliResult<FitConfig> {
    cell_settings(c).config().map_err(bad_settings)
}

pub use brdfkit::rgl::InputKind;

/// The input-kind rule of every command that takes a table (or a model): the library's
/// one rule ([`InputKind::of_file`]), its I/O failure as bad input.
pub fn input_kind(path: &Path) -> CliResult<InputKind> {
    InputKind::of_file(path)
        .with_context(|| format!("{}: cannot read", path.display()))
        .map_err(bad_input)
}

/// Reads a table; every read failure is the user's input (exit 2). A `.bsdf` file (by
/// [`input_kind`]) is resampled in memory to a 90 × 90 × 180 MERL table, as `resample
/// --bsdf` would write it, with a note on standard error ([`brdfkit::fit::input::read_table`]).
pub fn read_table(path: &Path) -> CliResult<MerlTable> {
    let (table, note) = brdfkit::fit::input::read_table(path).map_err(bad_input)?;
    if let Some(n) = note {
        eprintln!("{n}");
    }
    Ok(table)
}

/// The measured input of `fit`, `score` and `report` by the library's one rule
/// ([`Measured`]): a table, a `.bsdf` (as `how` says) or a samples file; `keep_table`
/// keeps a table beside its cells (the report draws from it). Its note goes to standard
/// error unless `quiet`. Every failure is the user's input (exit 2).
pub fn measured(
    table: Option<&Path>,
    samples: Option<&Path>,
    how: BsdfInput,
    keep_table: bool,
    quiet: bool,
) -> CliResult<Measured> {
    let m = match (table, samples) {
        (_, Some(s)) => Measured::read_samples(s),
        (Some(p), None) => Measured::read(p, how, keep_table),
        (None, None) => return Err(bad_msg("give a table, a .bsdf file or --samples")),
    }
    .map_err(bad_input)?;
    if let (Some(n), false) = (&m.note, quiet) {
        eprintln!("{n}");
    }
    Ok(m)
}

impl MeasuredArgs {
    /// The measurement these arguments name ([`measured`]).
    pub fn read(&self, keep_table: bool, quiet: bool) -> CliResult<Measured> {
        let (table, samples) = (self.table.as_deref(), self.samples.as_deref());
        measured(table, samples, self.bsdf.bsdf_input, keep_table, quiet)
    }
}

/// The cells `fit` fits ([`measured`]) and the seconds spent reading the file (and
/// parsing it: [`Measured::read_s`]) and building the cells.
pub fn fit_data(input: &MeasuredArgs) -> CliResult<(FitData, f64, f64)> {
    let t = std::time::Instant::now();
    let m = input.read(false, false)?;
    let total = t.elapsed().as_secs_f64();
    Ok((m.data, m.read_s, total - m.read_s))
}

/// Reads an RGL-EPFL `.bsdf` file; every failure is the user's input (exit 2).
pub fn read_bsdf(path: &Path) -> CliResult<brdfkit::rgl::RglBsdf> {
    brdfkit::rgl::RglBsdf::read(path).map_err(bad_input)
}

/// Writes a table atomically; a failure is a runtime failure (exit 1).
pub fn write_table(table: &MerlTable, path: &Path) -> CliResult<()> {
    table.write(path).map_err(|e: MerlError| runtime(e))
}

/// The line `synth` and `resample` print for a table they wrote: its path, its name
/// when it has one, its grid and the share of valid cells.
pub fn wrote_table(table: &MerlTable, path: &Path, name: Option<&str>) -> String {
    let d = table.dims();
    let name = name.map(|n| format!("{n}: ")).unwrap_or_default();
    format!(
        "wrote {} ({name}{} x {} x {}, {:.2} % valid)",
        path.display(),
        d.theta_h(),
        d.theta_d(),
        d.phi_d(),
        100.0 * table.valid_fraction()
    )
}

/// Loads a neural BRDF (DIR/NAME); every failure is the user's input (exit 2).
pub fn read_nbrdf(path: &Path) -> CliResult<brdfkit::nbrdf::Nbrdf> {
    brdfkit::nbrdf::Nbrdf::load(path).map_err(bad_input)
}

/// The text of a model description file; every failure is bad input.
pub(crate) fn read_model_text(path: &Path) -> CliResult<String> {
    brdfkit::core::text::read_utf8(path, "the model description").map_err(bad_input)
}

/// Reads a model description (JSON) from a file.
pub fn read_model(path: &Path) -> CliResult<Box<dyn Model>> {
    let text = read_model_text(path)?;
    brdfkit::models::from_json_str(&text).map_err(|e| bad_msg(format!("{}: {e}", path.display())))
}

/// Reads given parameters: a model description, a per-channel fit or a fit record
/// ([`Fitted::from_json`]); every failure is bad input naming the file.
pub fn read_fitted(path: &Path) -> CliResult<Fitted> {
    let text = read_model_text(path)?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| bad_msg(format!("{}: not valid JSON: {e}", path.display())))?;
    Fitted::from_json(&v).map_err(|e| bad_msg(format!("{}: {e}", path.display())))
}

/// Parses `A,B,C` into grid dims.
pub fn parse_dims(s: &str) -> CliResult<Dims> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || {
        bad_msg(format!(
            "--dims `{s}`: expected three positive integers A,B,C (θh, θd, φd bins)"
        ))
    };
    if parts.len() != 3 {
        return Err(bad());
    }
    let mut v = [0i64; 3];
    for (k, p) in parts.iter().enumerate() {
        v[k] = p.parse().map_err(|_| bad())?;
    }
    Dims::new(v[0], v[1], v[2]).map_err(|e| bad_msg(format!("--dims `{s}`: {e}")))
}

pub fn lookup_mode(i: Interp) -> Lookup {
    match i {
        Interp::Nearest => Lookup::Nearest,
        Interp::Linear => Lookup::Interpolated,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    /// The flags' defaults are the library's settings, for every verb that fits.
    #[test]
    fn fit_flags_default_to_the_library_settings() {
        for args in [
            &["fit-brdf", "fit", "t.binary"][..],
            &["fit-brdf", "batch", "db", "--out", "o"][..],
        ] {
            let opts = match Cli::try_parse_from(args).unwrap().command {
                Command::Fit(a) => a.opts,
                Command::Batch(a) => a.opts,
                _ => unreachable!(),
            };
            assert_eq!(settings_of(&opts), FitSettings::default(), "{args:?}");
            assert_eq!(opts.model, brdfkit::models::named::DEFAULT_FAMILY);
        }
    }
}
