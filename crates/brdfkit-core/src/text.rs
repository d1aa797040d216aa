//! The one way a text input (a spec, a scene, a CSV file, a model description) is read:
//! the whole file as UTF-8, with an error that names the file, what it was read as, and
//! where its bytes stop being UTF-8.
//!
//! [`std::fs::read_to_string`] says only "stream did not contain valid UTF-8"; a user
//! with a file saved in Latin-1 or a binary passed by mistake needs the file and the
//! offset of the first bad byte to find it.

use std::path::{Path, PathBuf};

/// Why a text file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum TextFileError {
    /// The file could not be read (missing, a directory, no permission …).
    #[error("{}: cannot read {what}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the file was read as ("the scene file", "the spec" …).
        what: &'static str,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The bytes are not UTF-8 text.
    #[error(
        "{}: {what} is not valid UTF-8 text (the first invalid byte is at offset {offset})",
        path.display()
    )]
    NotUtf8 {
        /// The file.
        path: PathBuf,
        /// What the file was read as.
        what: &'static str,
        /// The offset of the first byte that is not part of valid UTF-8.
        offset: usize,
    },
}

impl TextFileError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            TextFileError::Read { path, .. } | TextFileError::NotUtf8 { path, .. } => path,
        }
    }
}

/// Reads `path` whole as UTF-8 text; `what` says what the file is, in errors.
pub fn read_utf8(path: &Path, what: &'static str) -> Result<String, TextFileError> {
    let bytes = std::fs::read(path).map_err(|source| TextFileError::Read {
        path: path.to_path_buf(),
        what,
        source,
    })?;
    utf8(bytes, path, what)
}

/// The bytes of a file already read (`path` names it, `what` says what it is) as
/// UTF-8 text.
pub fn utf8(bytes: Vec<u8>, path: &Path, what: &'static str) -> Result<String, TextFileError> {
    String::from_utf8(bytes).map_err(|e| TextFileError::NotUtf8 {
        path: path.to_path_buf(),
        what,
        offset: e.utf8_error().valid_up_to(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `bytes` in a file `name` of a fresh directory (kept alive by the caller).
    fn written(name: &str, bytes: &[u8]) -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        (dir, p)
    }

    #[test]
    fn names_the_file_and_the_first_invalid_byte() {
        let (_dir, p) = written("latin1.csv", b"wi_x,caf\xe9\n");
        let e = read_utf8(&p, "the directions file").unwrap_err();
        assert!(
            matches!(e, TextFileError::NotUtf8 { offset: 8, .. }),
            "{e:?}"
        );
        let msg = e.to_string();
        assert!(msg.starts_with(&p.display().to_string()), "{msg}");
        assert!(
            msg.contains("the directions file is not valid UTF-8"),
            "{msg}"
        );
        assert_eq!(e.path(), p);
    }

    #[test]
    fn a_missing_file_is_a_read_error_and_text_reads_whole() {
        let (dir, p) = written("spec.toml", "a = \"é\"\n".as_bytes());
        assert_eq!(read_utf8(&p, "the spec").unwrap(), "a = \"é\"\n");
        let e = read_utf8(&dir.path().join("none.toml"), "the spec").unwrap_err();
        assert!(
            matches!(&e, TextFileError::Read { source, .. } if source.kind() == std::io::ErrorKind::NotFound),
            "{e:?}"
        );
        assert!(e.to_string().contains("cannot read the spec"), "{e}");
    }
}
