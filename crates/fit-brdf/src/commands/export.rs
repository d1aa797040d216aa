//! `fit-brdf export PARAMS.json --to mitsuba|pbrt|gltf [--approximate]`: the model as a
//! renderer's material. The mapping, its conditions, the writers and the approximation
//! are `brdfkit_export` (shared with the Mitsuba cross-check); this is the
//! glue: arguments, file, output.
//!
//! `fit-brdf export TABLE|MODEL.json|NBRDF --to rgl --out X_rgb.bsdf [--theta-i N]
//! [--phi-i N] [--grid 32|64]`: an RGL-EPFL measured file, written by `brdfkit_rgl::write`
//! from the source as `brdfkit_validate::compare::Representation::as_brdf` reads it; an
//! anisotropic source gives an anisotropic file (docs/rgl.md).

use crate::cli::{ExportArgs, ExportFormat, Renderer, RglGrid};
use crate::error::{CliResult, bad_msg, runtime};
use crate::output::write_text;
use brdfkit::core::ModelError;
use brdfkit::fit::FitConfig;
use brdfkit_export::{ExportError, ExportForm, export, export_approximate};

pub fn run(a: ExportArgs) -> CliResult<()> {
    let Some(to) = a.to.renderer() else {
        return run_rgl(&a);
    };
    if a.theta_i.is_some() || a.phi_i.is_some() || a.grid.is_some() {
        return Err(bad_msg(
            "--theta-i, --phi-i and --grid apply to --to rgl only",
        ));
    }
    let form = match (to, a.format) {
        (Renderer::Pbrt | Renderer::Gltf, Some(_)) => {
            return Err(bad_msg(
                "--format applies to --to mitsuba (pbrt-v4 and glTF have one format each)",
            ));
        }
        (Renderer::Pbrt, None) => ExportForm::Pbrt,
        (Renderer::Gltf, None) => ExportForm::Gltf,
        (Renderer::Mitsuba, None | Some(ExportFormat::Xml)) => ExportForm::MitsubaXml,
        (Renderer::Mitsuba, Some(ExportFormat::Dict)) => ExportForm::MitsubaDict,
    };
    let path = a.params.display();
    let text = super::read_model_text(&a.params)?;
    let name = a
        .params
        .file_name()
        .map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned());
    // A refusal is the input's (exit 2): an invalid description, or a model the target
    // evaluates differently; a failed approximation is a runtime failure (exit 1).
    let fail = |e: ExportError| match e {
        ExportError::Approximation(_) => runtime(anyhow::anyhow!("{path}: {e}")),
        e if e.hints_approximate() => bad_msg(format!(
            "{path}: {e} (here: `fit-brdf export --approximate`, `fit-brdf fit TABLE --for {}`)",
            to.target().name()
        )),
        e => bad_msg(format!("{path}: {e}")),
    };
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| fail(ModelError::Invalid(format!("not valid JSON: {e}")).into()))?;
    let out = if a.approximate {
        crate::progress::Progress::new(a.quiet).say(&format!(
            "export: fitting the {} configurations to the model if it has no exact counterpart ...",
            to.target().name()
        ));
        export_approximate(&v, form, &name, &FitConfig::default())
            .map(|x| x.exported)
            .map_err(fail)?
    } else {
        export(&v, form, &name).map_err(fail)?
    };
    if !a.quiet {
        for n in &out.notes {
            eprintln!("note: {n}");
        }
    }
    write_text(a.out.as_deref(), &out.text)?;
    if !a.quiet
        && let Some(p) = &a.out
    {
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

/// `--to rgl`: the source (a MERL table, a model, an NBRDF) as a `.bsdf` file.
fn run_rgl(a: &ExportArgs) -> CliResult<()> {
    use brdfkit::rgl::write::{WriteError, WriteOptions, write};
    use brdfkit_validate::compare::Representation;
    if a.format.is_some() || a.approximate {
        return Err(bad_msg(
            "--format and --approximate do not apply to --to rgl",
        ));
    }
    let Some(out) = &a.out else {
        return Err(bad_msg(
            "--to rgl writes a binary file: give --out X_rgb.bsdf",
        ));
    };
    let path = a.params.display();
    if a.params.is_file()
        && crate::commands::input_kind(&a.params)? == crate::commands::InputKind::Rgl
    {
        return Err(bad_msg(format!(
            "{path}: already an RGL-EPFL .bsdf file (export takes a MERL table, a model or an NBRDF)"
        )));
    }
    let rep = Representation::load(&a.params).map_err(|e| bad_msg(e.to_string()))?;
    let source = rep.as_brdf();
    if a.phi_i.is_some() && source.is_isotropic() {
        return Err(bad_msg(format!(
            "{path}: --phi-i applies to anisotropic sources; this {} is isotropic, and its file \
             has one phi_i slice (phi_i = [0])",
            kind_name(&rep)
        )));
    }
    let name = a
        .params
        .file_name()
        .map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned());
    let opts = WriteOptions {
        theta_i: a.theta_i.map_or(8, usize::from),
        phi_i: a.phi_i.map(usize::from),
        grid: match a.grid {
            Some(RglGrid::G64) => 64,
            _ => 32,
        },
        description: format!("{name} ({})", kind_name(&rep)),
    };
    let report = write(source.as_ref(), &opts, out).map_err(|e| match e {
        WriteError::Write(e) => runtime(e),
        e => bad_msg(format!("{path}: {e}")),
    })?;
    if !a.quiet {
        let change = report.power_iteration.change;
        eprintln!(
            "note: {} (last change of the iteration {change:.1e})",
            report.how(&opts)
        );
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}

fn kind_name(rep: &brdfkit_validate::compare::Representation) -> &'static str {
    use brdfkit_validate::compare::Kind;
    match rep.kind() {
        Kind::Table => "MERL table",
        Kind::Model => "model",
        Kind::Nbrdf => "NBRDF",
        Kind::RglBsdf => "RGL-EPFL .bsdf",
    }
}
