//! `fit-brdf export PARAMS.json --to mitsuba|pbrt`: the model as a renderer's material.
//! The mapping, its conditions and the writers are `brdfkit_validate::export` (shared
//! with the Mitsuba cross-check); this is the glue: arguments, file, output.

use crate::cli::{ExportArgs, ExportFormat, Renderer};
use crate::error::{CliResult, bad_input, bad_msg};
use crate::output::write_text;
use anyhow::Context;
use brdfkit_validate::export::{ExportError, ExportForm, export_str};

pub fn run(a: ExportArgs) -> CliResult<()> {
    let form = match (a.to, a.format) {
        (Renderer::Pbrt, Some(_)) => {
            return Err(bad_msg(
                "--format applies to --to mitsuba (pbrt-v4 has one scene format)",
            ));
        }
        (Renderer::Pbrt, None) => ExportForm::Pbrt,
        (Renderer::Mitsuba, None | Some(ExportFormat::Xml)) => ExportForm::MitsubaXml,
        (Renderer::Mitsuba, Some(ExportFormat::Dict)) => ExportForm::MitsubaDict,
    };
    let path = a.params.display();
    let bytes = std::fs::read(&a.params)
        .with_context(|| format!("{path}: cannot read the model description"))
        .map_err(bad_input)?;
    let text = String::from_utf8(bytes).map_err(|_| bad_msg(format!("{path}: not valid UTF-8")))?;
    let name = a
        .params
        .file_name()
        .map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned());
    // Every refusal is the input's (exit 2): an invalid description, or a model the
    // renderer evaluates differently.
    let out =
        export_str(&text, form, &name).map_err(|e: ExportError| bad_msg(format!("{path}: {e}")))?;
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
