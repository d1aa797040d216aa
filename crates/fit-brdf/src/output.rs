//! Output files: written whole to a temporary file in the destination directory and
//! renamed into place, so a failure never leaves a half-written file: the old file, if
//! any, stays as it was, and the temporary file is removed.

use crate::error::{CliResult, runtime};
use anyhow::Context;
use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> CliResult<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// Writes through `fill` into a temporary file beside `path`, then renames it into
/// place. If `fill` fails (or the flush, or the rename), the temporary file is removed
/// (tempfile deletes it on drop) and `path` is untouched.
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> CliResult<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    // Mode 0o644 less the umask, as a plain `create` gives (tempfile's default, 0o600,
    // would make every output private to its owner).
    let mut builder = tempfile::Builder::new();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o644));
    }
    let mut tmp = builder
        .tempfile_in(dir)
        .with_context(|| {
            format!(
                "{}: cannot create a temporary file in {}",
                path.display(),
                dir.display()
            )
        })
        .map_err(runtime)?;
    fill(tmp.as_file_mut())
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

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_write_failing_midway_keeps_the_old_file_and_leaves_no_temp_file() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("params.json");
        std::fs::write(&p, "old contents").unwrap();
        let e = write_atomic_with(&p, |w| {
            w.write_all(b"{\"model\": \"lamb")?;
            Err(std::io::Error::other("disk full (injected)"))
        })
        .unwrap_err();
        assert_eq!(e.exit_code(), 1);
        let msg = format!("{:#}", e.error);
        assert!(
            msg.contains("params.json") && msg.contains("injected"),
            "{msg}"
        );
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old contents");
        assert_eq!(entries(d.path()), vec!["params.json"]);
    }

    #[test]
    fn a_failed_rename_keeps_the_destination_and_leaves_no_temp_file() {
        let d = tempfile::tempdir().unwrap();
        // A non-empty directory in the way: rename(2) cannot replace it.
        let p = d.path().join("out");
        std::fs::create_dir(&p).unwrap();
        std::fs::write(p.join("keep"), "x").unwrap();
        let e = write_atomic(&p, b"new").unwrap_err();
        assert_eq!(e.exit_code(), 1);
        assert!(p.join("keep").exists());
        assert_eq!(entries(d.path()), vec!["out"]);
    }

    #[test]
    fn a_successful_write_replaces_the_file_whole() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a.csv");
        std::fs::write(&p, "old").unwrap();
        write_atomic(&p, b"r,g,b\n").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "r,g,b\n");
        assert_eq!(entries(d.path()), vec!["a.csv"]);
    }
}
