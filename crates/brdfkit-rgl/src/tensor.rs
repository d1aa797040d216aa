//! Mitsuba tensor files (`mitsuba/core/tensor.h`, `mitsuba.tensor_io`): a header, a
//! directory of named fields, and their data.
//!
//! Layout, all little-endian:
//! - 12 bytes `tensor_file\0`, the version bytes `1 0`, a u32 field count;
//! - per field: u16 name length, the name (UTF-8), u16 ndim, u8 dtype ([`Dtype`]), u64
//!   offset of the data from the start of the file, ndim × u64 shape;
//! - the data of each field, C order, at its offset (Mitsuba's writer aligns to 8).
//!
//! Reading never trusts a count: every directory entry must fit in the bytes that are
//! left, every shape product is computed with overflow checks and every field's data
//! must lie inside the file, so nothing is allocated beyond the file's own size.

use crate::error::RglError;
use std::path::{Path, PathBuf};

/// The 12 bytes every tensor file starts with.
pub const MAGIC: &[u8; 12] = b"tensor_file\0";

/// Whether `bytes` start like a tensor file (the magic): the CLI's input-kind rule.
pub fn is_tensor_file(bytes: &[u8]) -> bool {
    bytes.starts_with(MAGIC)
}

/// Element type of a field, with Mitsuba's codes (`Struct::Type`, as `tensor_io.py`
/// maps them).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dtype {
    U8 = 1,
    I8 = 2,
    U16 = 3,
    I16 = 4,
    U32 = 5,
    I32 = 6,
    U64 = 7,
    I64 = 8,
    F16 = 9,
    F32 = 10,
    F64 = 11,
}

impl Dtype {
    const ALL: [Dtype; 11] = [
        Dtype::U8,
        Dtype::I8,
        Dtype::U16,
        Dtype::I16,
        Dtype::U32,
        Dtype::I32,
        Dtype::U64,
        Dtype::I64,
        Dtype::F16,
        Dtype::F32,
        Dtype::F64,
    ];

    /// The dtype of a file's code, if it is one.
    pub fn from_code(code: u8) -> Option<Dtype> {
        Dtype::ALL.into_iter().find(|d| *d as u8 == code)
    }

    /// Bytes per element.
    pub fn size(self) -> usize {
        match self {
            Dtype::U8 | Dtype::I8 => 1,
            Dtype::U16 | Dtype::I16 | Dtype::F16 => 2,
            Dtype::U32 | Dtype::I32 | Dtype::F32 => 4,
            Dtype::U64 | Dtype::I64 | Dtype::F64 => 8,
        }
    }

    /// The name numpy gives it.
    pub fn name(self) -> &'static str {
        match self {
            Dtype::U8 => "uint8",
            Dtype::I8 => "int8",
            Dtype::U16 => "uint16",
            Dtype::I16 => "int16",
            Dtype::U32 => "uint32",
            Dtype::I32 => "int32",
            Dtype::U64 => "uint64",
            Dtype::I64 => "int64",
            Dtype::F16 => "float16",
            Dtype::F32 => "float32",
            Dtype::F64 => "float64",
        }
    }

    /// Element `k` of little-endian `bytes` of this dtype as f64 (64-bit integers beyond
    /// 2⁵³ are rounded).
    fn value(self, bytes: &[u8], k: usize) -> f64 {
        let n = self.size();
        let b = &bytes[k * n..(k + 1) * n];
        let mut x = [0u8; 8];
        x[..n].copy_from_slice(b);
        match self {
            Dtype::U8 => f64::from(b[0]),
            Dtype::I8 => f64::from(b[0] as i8),
            Dtype::U16 => f64::from(u16::from_le_bytes([x[0], x[1]])),
            Dtype::I16 => f64::from(i16::from_le_bytes([x[0], x[1]])),
            Dtype::F16 => f64::from(half::f16::from_le_bytes([x[0], x[1]])),
            Dtype::U32 => f64::from(u32::from_le_bytes([x[0], x[1], x[2], x[3]])),
            Dtype::I32 => f64::from(i32::from_le_bytes([x[0], x[1], x[2], x[3]])),
            Dtype::F32 => f64::from(f32::from_le_bytes([x[0], x[1], x[2], x[3]])),
            Dtype::U64 => u64::from_le_bytes(x) as f64,
            Dtype::I64 => i64::from_le_bytes(x) as f64,
            Dtype::F64 => f64::from_le_bytes(x),
        }
    }
}

/// One field's directory entry.
#[derive(Clone, Debug, PartialEq)]
pub struct FieldInfo {
    pub name: String,
    pub dtype: Dtype,
    pub shape: Vec<u64>,
    /// Offset of the data from the start of the file.
    pub offset: u64,
    /// Number of elements (the product of the shape).
    pub len: usize,
}

/// A tensor file held in memory: its bytes and its directory.
#[derive(Debug)]
pub struct TensorFile {
    path: PathBuf,
    bytes: Vec<u8>,
    fields: Vec<FieldInfo>,
}

/// A cursor over the header that fails with [`RglError::Truncated`] instead of reading
/// past the end.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
    path: &'a Path,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize, what: &dyn Fn() -> String) -> Result<&'a [u8], RglError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        let Some(end) = end else {
            return Err(RglError::Truncated {
                path: self.path.to_path_buf(),
                what: what(),
            });
        };
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn u16(&mut self, what: &dyn Fn() -> String) -> Result<u16, RglError> {
        let b = self.take(2, what)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }
    fn u64(&mut self, what: &dyn Fn() -> String) -> Result<u64, RglError> {
        let b = self.take(8, what)?;
        Ok(u64::from_le_bytes(b.try_into().expect("8 bytes")))
    }
}

impl TensorFile {
    /// Reads and parses the file at `path`.
    pub fn read(path: &Path) -> Result<TensorFile, RglError> {
        let bytes = std::fs::read(path).map_err(|source| RglError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        TensorFile::from_bytes(bytes, path)
    }

    /// Parses `bytes`; `path` names the file in errors.
    pub fn from_bytes(bytes: Vec<u8>, path: impl AsRef<Path>) -> Result<TensorFile, RglError> {
        let path = path.as_ref();
        if !is_tensor_file(&bytes) {
            return Err(RglError::NotTensorFile {
                path: path.to_path_buf(),
            });
        }
        let mut c = Cursor {
            bytes: &bytes,
            at: MAGIC.len(),
            path,
        };
        let v = c.take(2, &|| "the version".into())?;
        if v != [1, 0] {
            return Err(RglError::Version {
                path: path.to_path_buf(),
                major: v[0],
                minor: v[1],
            });
        }
        let n = c.take(4, &|| "the field count".into())?;
        let count = u32::from_le_bytes(n.try_into().expect("4 bytes"));
        // No capacity from the count: a directory entry takes at least 13 bytes, so the
        // vector grows only with entries that are really there.
        let mut fields: Vec<FieldInfo> = Vec::new();
        for index in 0..count {
            let f = read_entry(&mut c, index)?;
            if fields.iter().any(|g| g.name == f.name) {
                return Err(RglError::Duplicate {
                    path: path.to_path_buf(),
                    field: f.name,
                });
            }
            check_bounds(&f, bytes.len(), path)?;
            fields.push(f);
        }
        Ok(TensorFile {
            path: path.to_path_buf(),
            bytes,
            fields,
        })
    }

    /// The file's name, as given.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The directory, in file order.
    pub fn fields(&self) -> &[FieldInfo] {
        &self.fields
    }

    /// The size of the file in bytes.
    pub fn len_bytes(&self) -> usize {
        self.bytes.len()
    }

    /// The entry of field `name`, if present.
    pub fn get(&self, name: &str) -> Option<&FieldInfo> {
        self.fields.iter().find(|f| f.name == name)
    }

    /// The entry of field `name`, or [`RglError::Missing`].
    pub fn field(&self, name: &str) -> Result<&FieldInfo, RglError> {
        self.get(name).ok_or_else(|| RglError::Missing {
            path: self.path.clone(),
            field: name.to_owned(),
        })
    }

    /// The raw little-endian bytes of a field (in bounds: checked when parsed).
    pub fn data(&self, f: &FieldInfo) -> &[u8] {
        let at = f.offset as usize;
        &self.bytes[at..at + f.len * f.dtype.size()]
    }

    /// Field `name` as f64 values, whatever its numeric dtype.
    pub fn to_f64(&self, name: &str) -> Result<Vec<f64>, RglError> {
        let f = self.field(name)?;
        let d = self.data(f);
        Ok((0..f.len).map(|k| f.dtype.value(d, k)).collect())
    }

    /// Field `name`, which must be float32, as f32 values.
    pub fn f32s(&self, name: &str) -> Result<Vec<f32>, RglError> {
        let f = self.expect_dtype(name, Dtype::F32)?;
        Ok(self
            .data(f)
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
            .collect())
    }

    /// Field `name`, which must be uint8, as bytes.
    pub fn u8s(&self, name: &str) -> Result<&[u8], RglError> {
        let f = self.expect_dtype(name, Dtype::U8)?;
        Ok(self.data(f))
    }

    /// The entry of `name`, failing with [`RglError::Dtype`] unless its dtype is `want`.
    pub fn expect_dtype(&self, name: &str, want: Dtype) -> Result<&FieldInfo, RglError> {
        let f = self.field(name)?;
        if f.dtype != want {
            return Err(RglError::Dtype {
                path: self.path.clone(),
                field: name.to_owned(),
                problem: format!("dtype {}, expected {}", f.dtype.name(), want.name()),
            });
        }
        Ok(f)
    }
}

/// Reads directory entry `index` at the cursor.
fn read_entry(c: &mut Cursor, index: u32) -> Result<FieldInfo, RglError> {
    let at = |what: &'static str| move || format!("the {what} of field #{index}");
    let name_len = c.u16(&at("name length"))?;
    let name_bytes = c.take(usize::from(name_len), &at("name"))?;
    let name = String::from_utf8_lossy(name_bytes).into_owned();
    let named = |what: &'static str| {
        let name = name.clone();
        move || format!("the {what} of field `{name}`")
    };
    let ndim = c.u16(&named("dimension count"))?;
    let code = c.take(1, &named("dtype"))?[0];
    let offset = c.u64(&named("offset"))?;
    let mut shape = Vec::new();
    for _ in 0..ndim {
        shape.push(c.u64(&named("shape"))?);
    }
    let Some(dtype) = Dtype::from_code(code) else {
        return Err(RglError::Dtype {
            path: c.path.to_path_buf(),
            field: name,
            problem: format!("unknown dtype code {code} (known: 1 to 11)"),
        });
    };
    let overflow = || RglError::ShapeOverflow {
        path: c.path.to_path_buf(),
        field: name.clone(),
        shape: shape.clone(),
    };
    let len = shape
        .iter()
        .try_fold(1u64, |a, &d| a.checked_mul(d))
        .and_then(|n| n.checked_mul(dtype.size() as u64).map(|_| n))
        .and_then(|n| usize::try_from(n).ok())
        .ok_or_else(overflow)?;
    Ok(FieldInfo {
        name,
        dtype,
        shape,
        offset,
        len,
    })
}

/// Fails unless the field's data lie inside a file of `file_len` bytes.
fn check_bounds(f: &FieldInfo, file_len: usize, path: &Path) -> Result<(), RglError> {
    let bytes = f.len as u64 * f.dtype.size() as u64;
    let inside = f
        .offset
        .checked_add(bytes)
        .is_some_and(|end| end <= file_len as u64);
    if inside {
        Ok(())
    } else {
        Err(RglError::OutOfBounds {
            path: path.to_path_buf(),
            field: f.name.clone(),
            offset: f.offset,
            len: bytes,
            file_len: file_len as u64,
        })
    }
}

/// The data of a field to write, in C order.
#[derive(Clone, Debug, PartialEq)]
pub enum TensorData {
    U8(Vec<u8>),
    I8(Vec<i8>),
    U16(Vec<u16>),
    I16(Vec<i16>),
    U32(Vec<u32>),
    I32(Vec<i32>),
    U64(Vec<u64>),
    I64(Vec<i64>),
    F16(Vec<half::f16>),
    F32(Vec<f32>),
    F64(Vec<f64>),
}

macro_rules! per_variant {
    ($self:expr, $v:ident => $e:expr) => {
        match $self {
            TensorData::U8($v) => $e,
            TensorData::I8($v) => $e,
            TensorData::U16($v) => $e,
            TensorData::I16($v) => $e,
            TensorData::U32($v) => $e,
            TensorData::I32($v) => $e,
            TensorData::U64($v) => $e,
            TensorData::I64($v) => $e,
            TensorData::F16($v) => $e,
            TensorData::F32($v) => $e,
            TensorData::F64($v) => $e,
        }
    };
}

impl TensorData {
    /// Its dtype.
    pub fn dtype(&self) -> Dtype {
        match self {
            TensorData::U8(_) => Dtype::U8,
            TensorData::I8(_) => Dtype::I8,
            TensorData::U16(_) => Dtype::U16,
            TensorData::I16(_) => Dtype::I16,
            TensorData::U32(_) => Dtype::U32,
            TensorData::I32(_) => Dtype::I32,
            TensorData::U64(_) => Dtype::U64,
            TensorData::I64(_) => Dtype::I64,
            TensorData::F16(_) => Dtype::F16,
            TensorData::F32(_) => Dtype::F32,
            TensorData::F64(_) => Dtype::F64,
        }
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        per_variant!(self, v => v.len())
    }

    /// Whether it holds no element.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn extend_le(&self, out: &mut Vec<u8>) {
        per_variant!(self, v => v.iter().for_each(|x| out.extend_from_slice(&x.to_le_bytes())))
    }
}

/// A field to write: name, shape and data.
#[derive(Clone, Debug, PartialEq)]
pub struct Tensor {
    pub name: String,
    pub shape: Vec<u64>,
    pub data: TensorData,
}

impl Tensor {
    /// A field from its parts (checked when written).
    pub fn new(name: impl Into<String>, shape: &[u64], data: TensorData) -> Tensor {
        Tensor {
            name: name.into(),
            shape: shape.to_vec(),
            data,
        }
    }
}

/// The bytes of a tensor file holding `fields` in order, each field's data aligned to 8
/// bytes like Mitsuba's writer. `path` names the file in errors.
pub fn encode(fields: &[Tensor], path: &Path) -> Result<Vec<u8>, RglError> {
    let bad = |f: &Tensor, problem: String| RglError::BadTensor {
        path: path.to_path_buf(),
        field: f.name.clone(),
        problem,
    };
    let mut header = MAGIC.to_vec();
    header.extend_from_slice(&[1, 0]);
    let count = u32::try_from(fields.len()).map_err(|_| RglError::BadTensor {
        path: path.to_path_buf(),
        field: String::new(),
        problem: "more than 2³² fields".into(),
    })?;
    header.extend_from_slice(&count.to_le_bytes());
    for f in fields {
        let n = f.shape.iter().try_fold(1u64, |a, &d| a.checked_mul(d));
        if n != Some(f.data.len() as u64) {
            return Err(bad(
                f,
                format!("shape {:?} but {} values", f.shape, f.data.len()),
            ));
        }
        let name_len = u16::try_from(f.name.len()).map_err(|_| bad(f, "name too long".into()))?;
        let ndim =
            u16::try_from(f.shape.len()).map_err(|_| bad(f, "too many dimensions".into()))?;
        header.extend_from_slice(&name_len.to_le_bytes());
        header.extend_from_slice(f.name.as_bytes());
        header.extend_from_slice(&ndim.to_le_bytes());
        header.push(f.data.dtype() as u8);
        header.extend_from_slice(&[0; 8]); // the offset, filled below
        f.shape
            .iter()
            .for_each(|d| header.extend_from_slice(&d.to_le_bytes()));
    }
    // Second pass: place the data and patch each offset (its slot follows the dtype).
    let mut out = header;
    let mut slot = MAGIC.len() + 6;
    for f in fields {
        slot += 2 + f.name.len() + 2 + 1;
        out.resize(out.len().next_multiple_of(8), 0);
        let offset = out.len() as u64;
        out[slot..slot + 8].copy_from_slice(&offset.to_le_bytes());
        slot += 8 + 8 * f.shape.len();
        f.data.extend_le(&mut out);
    }
    Ok(out)
}

/// Writes `fields` as a tensor file at `path`, atomically (brdfkit-core's writer).
pub fn write(fields: &[Tensor], path: &Path) -> Result<(), RglError> {
    let bytes = encode(fields, path)?;
    brdfkit_core::atomic::write_bytes(path, &bytes)?;
    Ok(())
}
