//! Output files, all through the one atomic writer of brdfkit
//! ([`brdfkit::core::atomic`]): written whole to a temporary file beside the
//! destination and renamed into place, so a failure never leaves a half-written file.

use crate::error::{CliError, CliResult, runtime};
use anyhow::Context;
use brdfkit::core::atomic::{self, WriteError};
use std::io::Write;
use std::path::Path;

/// A failed write is a runtime failure (exit 1); its message names the destination.
pub fn write_failed(e: WriteError) -> CliError {
    runtime(e)
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> CliResult<()> {
    atomic::write_bytes(path, bytes).map_err(write_failed)
}

/// Writes `path` atomically through `fill`.
pub fn write_file(
    path: &Path,
    fill: impl FnOnce(&mut std::fs::File) -> std::io::Result<()>,
) -> CliResult<()> {
    atomic::write_file(path, fill).map_err(write_failed)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_exits_1_naming_the_file() {
        let d = tempfile::tempdir().unwrap();
        // A non-empty directory in the way: rename(2) cannot replace it.
        let p = d.path().join("out");
        std::fs::create_dir(&p).unwrap();
        std::fs::write(p.join("keep"), "x").unwrap();
        let e = write_atomic(&p, b"new").unwrap_err();
        assert_eq!(e.exit_code(), 1);
        assert!(
            e.render().contains(&p.display().to_string()),
            "{}",
            e.render()
        );
        assert!(p.join("keep").exists());
        write_text(Some(&d.path().join("a.csv")), "r,g,b\n").unwrap();
        assert_eq!(
            std::fs::read_to_string(d.path().join("a.csv")).unwrap(),
            "r,g,b\n"
        );
    }
}
