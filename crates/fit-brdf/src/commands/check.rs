//! `fit-brdf check PARAMS.json|TABLE`: the physical checks of brdfkit-validate.

use super::{InputKind, input_kind, read_model, read_table};
use crate::cli::CheckArgs;
use crate::error::{CliResult, bad_input, runtime};
use crate::output::write_text;
use anyhow::anyhow;

pub fn run(a: CheckArgs) -> CliResult<()> {
    if a.input.is_dir() {
        return Err(bad_input(anyhow!(
            "{}: is a directory, expected a model JSON or a table",
            a.input.display()
        )));
    }
    let (text, passed) = if input_kind(&a.input)? == InputKind::Json {
        let model = read_model(&a.input)?;
        let r = brdfkit_validate::check_model(&*model);
        let text = if a.json {
            serde_json::to_string_pretty(&r).map_err(runtime)? + "\n"
        } else {
            format!("{}: {}\n{}", a.input.display(), model.name(), r.to_text())
        };
        (text, r.passed)
    } else {
        let table = read_table(&a.input)?;
        let r = brdfkit_validate::check_table(&table);
        let text = if a.json {
            serde_json::to_string_pretty(&r).map_err(runtime)? + "\n"
        } else {
            format!("{}\n{}", a.input.display(), r.to_text())
        };
        (text, r.passed)
    };
    if !a.quiet {
        write_text(None, &text)?;
    }
    if passed {
        Ok(())
    } else {
        Err(runtime(anyhow!(
            "{}: a physical check failed (see above)",
            a.input.display()
        )))
    }
}
