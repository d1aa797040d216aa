//! What a file given where a measured material goes holds, told by its first bytes and
//! never by its name: the one rule of every reader that takes a MERL table, a model
//! description or a `.bsdf` (the `fit-brdf` verbs, `brdfkit_validate`'s `compare`, the
//! renderer's scene materials).

use crate::tensor::is_tensor_file;
use std::io::Read;
use std::path::Path;

/// Bytes of a file's start that decide its kind.
pub const HEAD_BYTES: usize = 256;

/// What a file holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputKind {
    /// A model description: the first non-blank byte is `{`.
    Json,
    /// An RGL-EPFL `.bsdf` (a Mitsuba tensor file): it starts with `tensor_file\0`.
    Rgl,
    /// Anything else is read as a MERL table (whose reader says if it is not one).
    Table,
}

impl InputKind {
    /// The kind of a file that starts with `head` (its first [`HEAD_BYTES`] bytes, or
    /// all of a shorter file).
    pub fn of_head(head: &[u8]) -> InputKind {
        if is_tensor_file(head) {
            InputKind::Rgl
        } else if head.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{') {
            InputKind::Json
        } else {
            InputKind::Table
        }
    }

    /// The kind of the file at `path`, from its first [`HEAD_BYTES`] bytes. A
    /// directory is a [`Table`](InputKind::Table) (the table reader names the problem);
    /// a file that cannot be opened or read is the I/O error.
    pub fn of_file(path: &Path) -> std::io::Result<InputKind> {
        if path.is_dir() {
            return Ok(InputKind::Table);
        }
        let mut head = Vec::with_capacity(HEAD_BYTES);
        std::fs::File::open(path)?
            .take(HEAD_BYTES as u64)
            .read_to_end(&mut head)?;
        Ok(InputKind::of_head(&head))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_by_first_bytes() {
        assert_eq!(InputKind::of_head(b"tensor_file\0\x01\x00"), InputKind::Rgl);
        assert_eq!(InputKind::of_head(b"  \n {\"model\": 1}"), InputKind::Json);
        assert_eq!(InputKind::of_head(&[90, 0, 0, 0]), InputKind::Table);
        assert_eq!(InputKind::of_head(b""), InputKind::Table);
        assert_eq!(InputKind::of_head(b"tensor_fil"), InputKind::Table);
    }

    #[test]
    fn a_file_is_read_only_as_far_as_its_head() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.binary"); // the name says table; the bytes decide
        let mut bytes = b"tensor_file\0".to_vec();
        bytes.resize(10_000, 7);
        std::fs::write(&p, &bytes).unwrap();
        assert_eq!(InputKind::of_file(&p).unwrap(), InputKind::Rgl);
        assert_eq!(InputKind::of_file(dir.path()).unwrap(), InputKind::Table);
        assert!(InputKind::of_file(&dir.path().join("none")).is_err());
    }
}
