//! The one way brdfkit writes a file: whole, or not at all.
//!
//! Every output (tables, JSON, CSV, images, report pages, study data) goes through
//! [`write_file`] or, for several files that only make sense together (a report's
//! `index.html` and `report.json`), through [`FileSet`]. The bytes go to a temporary file
//! created in the destination's directory (so the final rename stays on one file system
//! and is atomic), which is synced and renamed over the destination. A failure at any
//! step removes the temporary file and leaves the destination as it was.
//!
//! Permissions follow one rule: a file that replaces another keeps the old file's
//! permissions; a new file gets what a plain `open(O_CREAT, 0666)` gives, i.e. 0644 under
//! the usual umask 022. (A bare temporary file is 0600, which would make every output
//! readable by its owner only.)

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// A file could not be written; `path` is the destination, not the temporary file.
#[derive(Debug, thiserror::Error)]
#[error("{}: {step}: {source}", path.display())]
pub struct WriteError {
    /// The destination.
    pub path: PathBuf,
    /// What was being done: "creating a temporary file beside it", "writing", ...
    pub step: &'static str,
    /// The underlying error.
    #[source]
    pub source: io::Error,
}

impl WriteError {
    fn new(path: &Path, step: &'static str, source: io::Error) -> Self {
        WriteError {
            path: path.to_path_buf(),
            step,
            source,
        }
    }
}

/// Prefix of every temporary file, so leftovers of a killed process are recognisable.
pub const TEMP_PREFIX: &str = ".brdfkit-";

/// The names of the writer's temporary files in `dir` (those starting with
/// [`TEMP_PREFIX`]), sorted: what a process killed mid-write leaves behind, and what
/// a failed write must not.
pub fn leftovers(dir: &Path) -> io::Result<Vec<String>> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir)? {
        let name = e?.file_name().to_string_lossy().into_owned();
        if name.starts_with(TEMP_PREFIX) {
            v.push(name);
        }
    }
    v.sort();
    Ok(v)
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), WriteError> {
    write_file(path, |f| f.write_all(bytes))
}

/// Writes through `fill` into a temporary file beside `path`, then renames it over
/// `path`. If `fill`, the sync or the rename fails, the temporary file is deleted and
/// `path` is untouched.
pub fn write_file(
    path: &Path,
    fill: impl FnOnce(&mut File) -> io::Result<()>,
) -> Result<(), WriteError> {
    let staged = Staged::new(path, fill)?;
    staged
        .tmp
        .persist(path)
        .map_err(|e| WriteError::new(path, "renaming the finished file into place", e.error))?;
    Ok(())
}

/// Several files written as a unit: all are staged as temporary files first; only when
/// every one is complete are they renamed into place. If a rename fails, the files
/// already placed are put back as they were (their old contents restored, or removed if
/// they were new), so the set is either all new or all old.
#[derive(Default)]
pub struct FileSet {
    staged: Vec<(PathBuf, Staged)>,
}

impl FileSet {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Stages `path` with the bytes `fill` writes. Nothing is visible at `path` until
    /// [`FileSet::commit`].
    pub fn stage(
        &mut self,
        path: &Path,
        fill: impl FnOnce(&mut File) -> io::Result<()>,
    ) -> Result<&mut Self, WriteError> {
        let staged = Staged::new(path, fill)?;
        self.staged.push((path.to_path_buf(), staged));
        Ok(self)
    }

    /// Stages `path` with `bytes`.
    pub fn stage_bytes(&mut self, path: &Path, bytes: &[u8]) -> Result<&mut Self, WriteError> {
        self.stage(path, |f| f.write_all(bytes))
    }

    /// Renames every staged file into place, in staging order.
    pub fn commit(self) -> Result<(), WriteError> {
        // Keep the old version of each destination (a hard link, so nothing is copied)
        // until the whole set is placed, so a failure can roll back to it.
        let mut placed: Vec<(PathBuf, Option<PathBuf>)> = Vec::new();
        for (path, staged) in self.staged {
            let backup = backup_of(&path);
            if let Err(e) = staged.tmp.persist(&path) {
                rollback(&placed);
                if let Some(b) = backup {
                    let _ = std::fs::remove_file(b);
                }
                return Err(WriteError::new(
                    &path,
                    "renaming the finished file into place",
                    e.error,
                ));
            }
            placed.push((path, backup));
        }
        for (_, backup) in placed {
            if let Some(b) = backup {
                // Best effort: a leftover hidden link is harmless, the set is in place.
                let _ = std::fs::remove_file(b);
            }
        }
        Ok(())
    }
}

/// A hard link to the current file at `path`, if there is one and the file system
/// allows it.
fn backup_of(path: &Path) -> Option<PathBuf> {
    if !path.is_file() {
        return None;
    }
    let dir = parent_dir(path);
    for n in 0..16u32 {
        let name = format!(
            "{TEMP_PREFIX}{}.{}.{n}.old",
            path.file_name()?.to_string_lossy(),
            std::process::id()
        );
        let b = dir.join(name);
        match std::fs::hard_link(path, &b) {
            Ok(()) => return Some(b),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
            Err(_) => return None,
        }
    }
    None
}

/// Puts back what a failed commit had already placed (best effort: the commit's own
/// error is the one the user needs to see).
fn rollback(placed: &[(PathBuf, Option<PathBuf>)]) {
    for (path, backup) in placed.iter().rev() {
        match backup {
            Some(b) => {
                let _ = std::fs::rename(b, path);
            }
            None => {
                let _ = std::fs::remove_file(path);
            }
        }
    }
}

fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// A complete, synced temporary file beside its destination, with the destination's
/// permissions; deleted on drop unless persisted.
struct Staged {
    tmp: tempfile::NamedTempFile,
}

impl Staged {
    fn new(
        path: &Path,
        fill: impl FnOnce(&mut File) -> io::Result<()>,
    ) -> Result<Self, WriteError> {
        let dir = parent_dir(path);
        let mut b = tempfile::Builder::new();
        b.prefix(TEMP_PREFIX).suffix(".tmp");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            // Passed to open(2), so the umask applies, exactly as for a plain create.
            b.permissions(std::fs::Permissions::from_mode(0o666));
        }
        let mut tmp = b
            .tempfile_in(dir)
            .map_err(|e| WriteError::new(path, "creating a temporary file beside it", e))?;
        fill(tmp.as_file_mut()).map_err(|e| WriteError::new(path, "writing", e))?;
        if let Ok(m) = std::fs::metadata(path)
            && m.is_file()
        {
            tmp.as_file()
                .set_permissions(m.permissions())
                .map_err(|e| WriteError::new(path, "setting permissions", e))?;
        }
        tmp.as_file()
            .sync_all()
            .map_err(|e| WriteError::new(path, "syncing", e))?;
        Ok(Staged { tmp })
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

    #[cfg(unix)]
    fn mode(p: &Path) -> u32 {
        use std::os::unix::fs::PermissionsExt;
        std::fs::metadata(p).unwrap().permissions().mode() & 0o777
    }

    #[cfg(unix)]
    fn umask() -> u32 {
        // Read the process umask the way a plain create sees it.
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("probe");
        std::fs::File::create(&p).unwrap();
        0o666 & !mode(&p)
    }

    /// A fresh directory holding one file `name` with `contents`, and that file's path.
    fn dir_with(name: &str, contents: &str) -> (tempfile::TempDir, PathBuf) {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join(name);
        std::fs::write(&p, contents).unwrap();
        (d, p)
    }

    /// `p` holds `contents` and is the only entry of its directory (no temporary file
    /// left beside it).
    fn assert_alone_with(p: &Path, contents: &str) {
        assert_eq!(std::fs::read_to_string(p).unwrap(), contents);
        let name = p.file_name().unwrap().to_str().unwrap();
        assert_eq!(entries(p.parent().unwrap()), vec![name]);
    }

    #[test]
    fn a_write_replaces_the_file_whole_and_leaves_nothing_else() {
        let (_d, p) = dir_with("a.csv", "old");
        write_bytes(&p, b"r,g,b\n").unwrap();
        assert_alone_with(&p, "r,g,b\n");
    }

    #[test]
    fn a_write_failing_midway_keeps_the_old_file_and_leaves_no_temp_file() {
        let (_d, p) = dir_with("params.json", "old contents");
        let e = write_file(&p, |w| {
            w.write_all(b"{\"model\": \"lamb")?;
            Err(io::Error::other("disk full (injected)"))
        })
        .unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("params.json") && msg.contains("injected") && msg.contains("writing"),
            "{msg}"
        );
        assert_alone_with(&p, "old contents");
    }

    #[test]
    fn a_failed_rename_keeps_the_destination_and_leaves_no_temp_file() {
        let d = tempfile::tempdir().unwrap();
        // A non-empty directory in the way: rename(2) cannot replace it.
        let p = d.path().join("out");
        std::fs::create_dir(&p).unwrap();
        std::fs::write(p.join("keep"), "x").unwrap();
        let e = write_bytes(&p, b"new").unwrap_err();
        assert_eq!(e.step, "renaming the finished file into place");
        assert!(p.join("keep").exists());
        assert_eq!(entries(d.path()), vec!["out"]);
    }

    #[test]
    fn a_missing_directory_is_named_in_the_error() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("no-such-dir").join("t.binary");
        let e = write_bytes(&p, b"x").unwrap_err();
        assert!(e.to_string().contains("no-such-dir"), "{e}");
        assert_eq!(e.step, "creating a temporary file beside it");
    }

    #[cfg(unix)]
    #[test]
    fn a_new_file_gets_the_mode_a_plain_create_gives() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("image.png");
        write_bytes(&p, b"x").unwrap();
        assert_eq!(mode(&p), 0o666 & !umask());
        // And the same through a set.
        let q = d.path().join("report.json");
        let mut set = FileSet::new();
        set.stage_bytes(&q, b"{}").unwrap();
        set.commit().unwrap();
        assert_eq!(mode(&q), 0o666 & !umask());
    }

    #[cfg(unix)]
    #[test]
    fn a_replaced_file_keeps_its_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let (_d, p) = dir_with("t.binary", "old");
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_bytes(&p, b"new").unwrap();
        assert_eq!(mode(&p), 0o640);
    }

    #[test]
    fn a_set_is_placed_whole() {
        let d = tempfile::tempdir().unwrap();
        let a = d.path().join("report.json");
        let b = d.path().join("index.html");
        std::fs::write(&a, "old json").unwrap();
        let mut set = FileSet::new();
        set.stage_bytes(&a, b"new json").unwrap();
        set.stage_bytes(&b, b"new html").unwrap();
        set.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "new json");
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "new html");
        assert_eq!(entries(d.path()), vec!["index.html", "report.json"]);
    }

    #[test]
    fn a_set_whose_last_rename_fails_is_rolled_back_to_the_old_files() {
        let d = tempfile::tempdir().unwrap();
        let a = d.path().join("report.json");
        let fresh = d.path().join("summary.csv");
        let blocked = d.path().join("index.html");
        std::fs::write(&a, "old json").unwrap();
        std::fs::create_dir(&blocked).unwrap();
        std::fs::write(blocked.join("keep"), "x").unwrap();
        let mut set = FileSet::new();
        set.stage_bytes(&a, b"new json").unwrap();
        set.stage_bytes(&fresh, b"new csv").unwrap();
        set.stage_bytes(&blocked, b"new html").unwrap();
        let e = set.commit().unwrap_err();
        assert!(e.to_string().contains("index.html"), "{e}");
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "old json");
        assert!(!fresh.exists());
        assert_eq!(entries(d.path()), vec!["index.html", "report.json"]);
    }

    #[test]
    fn a_set_failing_while_staging_writes_nothing() {
        let d = tempfile::tempdir().unwrap();
        let a = d.path().join("a.json");
        let mut set = FileSet::new();
        set.stage_bytes(&a, b"x").unwrap();
        let e = set
            .stage(&d.path().join("b.json"), |_| Err(io::Error::other("boom")))
            .err()
            .unwrap();
        assert!(e.to_string().contains("b.json"));
        drop(set);
        assert!(entries(d.path()).is_empty());
    }
}
