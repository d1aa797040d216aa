//! Output files: written whole to a temporary file in the destination directory and
//! renamed into place, so a failure never leaves a half-written file.

use crate::error::{CliResult, runtime};
use anyhow::Context;
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> CliResult<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| {
            format!(
                "{}: cannot create a temporary file in {}",
                path.display(),
                dir.display()
            )
        })
        .map_err(runtime)?;
    tmp.write_all(bytes)
        .and_then(|_| tmp.as_file().sync_all())
        .with_context(|| format!("{}: write failed", path.display()))
        .map_err(runtime)?;
    tmp.persist(path)
        .map_err(|e| e.error)
        .with_context(|| {
            format!(
                "{}: cannot move the finished file into place",
                path.display()
            )
        })
        .map_err(runtime)?;
    Ok(())
}

/// Writes text to `path` atomically, or to stdout when `path` is None.
pub fn write_text(path: Option<&Path>, text: &str) -> CliResult<()> {
    match path {
        Some(p) => write_atomic(p, text.as_bytes()),
        None => {
            let mut out = std::io::stdout().lock();
            out.write_all(text.as_bytes())
                .and_then(|_| out.flush())
                .context("cannot write to standard output")
                .map_err(runtime)
        }
    }
}
