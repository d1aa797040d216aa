//! `fit-brdf view SOURCE... --out DIR`: the report's interactive panels for any sources
//! brdfkit reads, overlaid, nothing fitted (the engine:
//! `brdfkit_validate::html::interactive::view_page`). A source is recognised by its
//! content as in `compare` (`Representation::load`): a new kind of source plugs in there.

use crate::cli::ViewArgs;
use crate::error::{CliError, CliResult, bad_input, bad_msg, runtime};
use crate::output::{write_failed, write_text};
use anyhow::Context;
use brdfkit::core::atomic::FileSet;
use brdfkit_validate::compare::{CompareError, Representation};
use brdfkit_validate::html::interactive::{PanelSource, view_page};

/// The page's file in DIR.
pub const HTML_FILE: &str = "index.html";

fn failed(e: CompareError) -> CliError {
    if e.is_bad_input() {
        bad_input(e)
    } else {
        runtime(e)
    }
}

pub fn run(a: ViewArgs) -> CliResult<()> {
    let mut seen = std::collections::HashSet::new();
    if let Some(dup) = a.sources.iter().find(|p| !seen.insert(p.as_path())) {
        return Err(bad_msg(format!(
            "{}: given twice (each source is one curve)",
            dup.display()
        )));
    }
    let reps = a
        .sources
        .iter()
        .map(|p| Representation::load(p).map_err(failed))
        .collect::<CliResult<Vec<_>>>()?;
    let sources: Vec<PanelSource> = a
        .sources
        .iter()
        .zip(&reps)
        .map(|(p, source)| PanelSource {
            label: p.display().to_string(),
            source,
        })
        .collect();
    let title = a.title.clone().unwrap_or_else(|| "BRDF view".to_string());
    let html = view_page(&title, &sources).map_err(failed)?;
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("{}: cannot create the output directory", a.out.display()))
        .map_err(runtime)?;
    let path = a.out.join(HTML_FILE);
    let mut set = FileSet::new();
    set.stage_bytes(&path, html.as_bytes())
        .map_err(write_failed)?;
    set.commit().map_err(write_failed)?;
    if a.quiet {
        return Ok(());
    }
    write_text(
        None,
        &format!("view: {} ({} source(s))\n", path.display(), sources.len()),
    )
}
