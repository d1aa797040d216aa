//! The weights' float32 `.npy` files, read by brdfkit-io's one `.npy` reader; its errors
//! become [`NbrdfError`]s, which tell a missing part of the six-file layout apart.

use crate::error::NbrdfError;
pub use brdfkit_io::npy::ArrayF32;
use brdfkit_io::npy::{self, NpyError};
use std::path::Path;

/// Reads a float32 array (`<f4` or `>f4`) of any shape: [`NbrdfError::Missing`] when the
/// file does not exist, the reader's other errors as [`NbrdfError::Npy`].
pub fn read_f32(path: &Path) -> Result<ArrayF32, NbrdfError> {
    npy::read_f32(path).map_err(from_npy)
}

/// [`read_f32`] of a file's bytes already in memory (an embedded file); `path` names it
/// in errors.
pub fn parse_f32(bytes: &[u8], path: &Path) -> Result<ArrayF32, NbrdfError> {
    npy::parse_f32(bytes, path).map_err(from_npy)
}

fn from_npy(e: NpyError) -> NbrdfError {
    match e {
        NpyError::Read { path, source } if source.kind() == std::io::ErrorKind::NotFound => {
            NbrdfError::Missing { path }
        }
        e => NbrdfError::Npy(e),
    }
}
