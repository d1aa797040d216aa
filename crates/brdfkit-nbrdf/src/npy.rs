//! Reading float32 `.npy` arrays with their shape and dtype checked, through `npyz`.

use crate::error::NbrdfError;
use npyz::{DType, NpyFile, Order, TypeChar};
use std::path::Path;

/// A float32 array read from a `.npy` file, in C (row-major) order whatever the file's
/// order.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrayF32 {
    /// The shape as written in the file.
    pub shape: Vec<u64>,
    /// The values, last axis fastest.
    pub data: Vec<f32>,
}

/// Reads a float32 array (`<f4` or `>f4`) of any shape.
///
/// Errors name `path`: [`NbrdfError::Missing`] when it does not exist,
/// [`NbrdfError::Read`] on another I/O failure, [`NbrdfError::Format`] for a file that is
/// not `.npy` or has fewer data bytes than its shape needs, [`NbrdfError::Dtype`] for any
/// other dtype (float64, integers, records, pickled objects: none is converted, since a
/// different dtype means a different file than the NBRDF layout describes).
pub fn read_f32(path: &Path) -> Result<ArrayF32, NbrdfError> {
    let bytes = std::fs::read(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            NbrdfError::Missing {
                path: path.to_owned(),
            }
        } else {
            NbrdfError::Read {
                path: path.to_owned(),
                source: e,
            }
        }
    })?;
    parse_f32(&bytes, path)
}

/// [`read_f32`] of a file's bytes already in memory (an embedded file); `path` names it
/// in errors.
pub fn parse_f32(bytes: &[u8], path: &Path) -> Result<ArrayF32, NbrdfError> {
    let format = |source| NbrdfError::Format {
        path: path.to_owned(),
        source,
    };
    let npy = NpyFile::new(bytes).map_err(format)?;
    let dtype = npy.dtype();
    let is_f32 = matches!(&dtype, DType::Plain(t)
        if t.type_char() == TypeChar::Float && t.size_field() == 4);
    if !is_f32 || npy.uses_pickled_array() {
        return Err(NbrdfError::Dtype {
            path: path.to_owned(),
            found: dtype.descr(),
            expected: "float32 ('<f4')",
        });
    }
    let shape = npy.shape().to_vec();
    let order = npy.order();
    let data: Vec<f32> = npy.into_vec().map_err(format)?;
    let data = if order == Order::Fortran && shape.len() == 2 {
        // Column-major on disk: transpose into row-major.
        let (rows, cols) = (shape[0] as usize, shape[1] as usize);
        let mut c = vec![0.0f32; data.len()];
        for r in 0..rows {
            for k in 0..cols {
                c[r * cols + k] = data[k * rows + r];
            }
        }
        c
    } else if order == Order::Fortran && shape.len() > 2 {
        // The layout has no such arrays; refuse rather than guess an axis order.
        return Err(NbrdfError::Shape {
            path: path.to_owned(),
            found: shape,
            expected: "at most 2 axes for a Fortran-order array".into(),
        });
    } else {
        data
    };
    Ok(ArrayF32 { shape, data })
}
