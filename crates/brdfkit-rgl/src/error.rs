//! Errors of the reader, the evaluator and the writer: each names the file and, where
//! there is one, the field.

use std::path::PathBuf;

/// A tensor file or a `.bsdf` file could not be read, or is not what it claims to be.
#[derive(Debug, thiserror::Error)]
pub enum RglError {
    /// The file could not be read from disk.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The first 12 bytes are not `tensor_file\0`.
    #[error("{}: not a Mitsuba tensor file (no `tensor_file` magic at the start)", path.display())]
    NotTensorFile { path: PathBuf },
    /// A format version other than 1.0.
    #[error("{}: tensor file version {major}.{minor}; only 1.0 is known", path.display())]
    Version { path: PathBuf, major: u8, minor: u8 },
    /// The file ends inside the header or a field's directory entry.
    #[error("{}: truncated: the file ends inside {what}", path.display())]
    Truncated { path: PathBuf, what: String },
    /// A field's data lies (partly) past the end of the file.
    #[error("{}: field `{field}`: its data (offset {offset}, {len} bytes) runs past the end of the file ({file_len} bytes)", path.display())]
    OutOfBounds {
        path: PathBuf,
        field: String,
        offset: u64,
        len: u64,
        file_len: u64,
    },
    /// The product of a field's shape (times its element size) does not fit in 64 bits.
    #[error("{}: field `{field}`: the shape {shape:?} overflows", path.display())]
    ShapeOverflow {
        path: PathBuf,
        field: String,
        shape: Vec<u64>,
    },
    /// An unknown dtype code, or a dtype the field may not have.
    #[error("{}: field `{field}`: {problem}", path.display())]
    Dtype {
        path: PathBuf,
        field: String,
        problem: String,
    },
    /// A field the format requires is absent.
    #[error("{}: field `{field}` is missing", path.display())]
    Missing { path: PathBuf, field: String },
    /// Two fields of the same name.
    #[error("{}: field `{field}` appears twice", path.display())]
    Duplicate { path: PathBuf, field: String },
    /// A field's shape disagrees with the format or with another field.
    #[error("{}: field `{field}`: {problem}", path.display())]
    Shape {
        path: PathBuf,
        field: String,
        problem: String,
    },
    /// A field's values are unusable (NaN, unsorted, out of range).
    #[error("{}: field `{field}`: {problem}", path.display())]
    Value {
        path: PathBuf,
        field: String,
        problem: String,
    },
    /// Writing a tensor file failed (brdfkit-core's atomic writer).
    #[error(transparent)]
    Write(#[from] brdfkit_core::atomic::WriteError),
    /// A tensor to write is inconsistent (data length against shape, a name too long).
    #[error("{}: field `{field}`: {problem}", path.display())]
    BadTensor {
        path: PathBuf,
        field: String,
        problem: String,
    },
}
