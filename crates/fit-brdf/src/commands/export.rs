//! `fit-brdf export PARAMS.json --to mitsuba|pbrt|gltf [--approximate]`: the model as a
//! renderer's material. The mapping, its conditions, the writers and the approximation
//! are `brdfkit_validate::export` (shared with the Mitsuba cross-check); this is the
//! glue: arguments, file, output.

use crate::cli::{ExportArgs, ExportFormat, Renderer};
use crate::error::{CliResult, bad_input, bad_msg, runtime};
use crate::output::write_text;
use anyhow::Context;
use brdfkit::core::ModelError;
use brdfkit::fit::FitConfig;
use brdfkit_validate::export::{ExportError, ExportForm, export, export_approximate};

pub fn run(a: ExportArgs) -> CliResult<()> {
    let form = match (a.to, a.format) {
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
    let bytes = std::fs::read(&a.params)
        .with_context(|| format!("{path}: cannot read the model description"))
        .map_err(bad_input)?;
    let text = String::from_utf8(bytes).map_err(|_| bad_msg(format!("{path}: not valid UTF-8")))?;
    let name = a
        .params
        .file_name()
        .map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned());
    // A refusal is the input's (exit 2): an invalid description, or a model the target
    // evaluates differently; a failed approximation is a runtime failure (exit 1).
    let fail = |e: ExportError| match e {
        ExportError::Approximation(_) => runtime(anyhow::anyhow!("{path}: {e}")),
        e => bad_msg(format!("{path}: {e}")),
    };
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| fail(ModelError::Invalid(format!("not valid JSON: {e}")).into()))?;
    let out = if a.approximate {
        if !a.quiet {
            eprintln!(
                "export: fitting the {} configurations to the model if it has no exact counterpart ...",
                a.to.target().name()
            );
        }
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
