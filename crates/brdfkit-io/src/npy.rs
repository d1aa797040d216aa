//! NumPy `.npy` arrays. `eval`'s contract: direction pairs in as an N×6 float64 array (rows
//! `wi_x wi_y wi_z wo_x wo_y wo_z`), values out as an N×3 float64 array (`r g b`, NaN
//! where there is no sample). The header is parsed and written by `npyz`; the body is
//! converted in bulk, since a million pairs are 48 MB that a per-element reader would
//! spend most of the command's time on.
//!
//! Float32 arrays of any shape are read for the NBRDF weights ([`read_f32`]).

#[cfg(unix)]
use brdfkit_merl::MappedF64;
use npyz::{DType, NpyFile, NpyHeader, Order, TypeChar, TypeStr, WriteOptions, WriterBuilder};
use rayon::prelude::*;
use std::io::Seek;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// What is wrong with a `.npy` file.
#[derive(Debug, Error)]
pub enum NpyError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// Not a `.npy` file, or a damaged header.
    #[error("{}: not a valid .npy file: {source}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What npyz found.
        #[source]
        source: std::io::Error,
    },
    /// Another dtype than the reader's (none is converted: a different dtype means a
    /// different file than the contract describes).
    #[error("{}: dtype '{found}', expected {expected}", path.display())]
    Dtype {
        /// The file.
        path: PathBuf,
        /// The file's dtype descriptor.
        found: String,
        /// The dtype the reader takes, and how to convert to it.
        expected: &'static str,
    },
    /// Another shape than the reader's.
    #[error("{}: shape {}, expected {expected}", path.display(), fmt_shape(found))]
    Shape {
        /// The file.
        path: PathBuf,
        /// The file's shape.
        found: Vec<u64>,
        /// The shape the reader takes.
        expected: String,
    },
    /// Fewer or more data bytes than the header's shape.
    #[error("{}: the header says {rows} rows ({need} bytes of data) but the file holds {got}", path.display())]
    Length {
        /// The file.
        path: PathBuf,
        /// Rows in the header.
        rows: u64,
        /// Data bytes they need.
        need: u64,
        /// Data bytes present.
        got: u64,
    },
    /// A row that is not two unit directions.
    #[error("{}: row {row}: {what}", path.display())]
    Row {
        /// The file.
        path: PathBuf,
        /// Zero-based row index, as numpy counts.
        row: usize,
        /// What is wrong with it.
        what: String,
    },
}

impl NpyError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            NpyError::Read { path, .. }
            | NpyError::Format { path, .. }
            | NpyError::Dtype { path, .. }
            | NpyError::Shape { path, .. }
            | NpyError::Length { path, .. }
            | NpyError::Row { path, .. } => path,
        }
    }
}

/// `(6, 21)` as numpy prints shapes (`(3,)` for one axis).
pub fn fmt_shape(s: &[u64]) -> String {
    match s {
        [n] => format!("({n},)"),
        _ => {
            let parts: Vec<String> = s.iter().map(u64::to_string).collect();
            format!("({})", parts.join(", "))
        }
    }
}

/// Whether `path` names a `.npy` file (by extension, case-insensitive).
pub fn is_npy(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("npy"))
}

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
/// Errors name `path`: [`NpyError::Read`] on an I/O failure (its source's kind tells a
/// missing file), [`NpyError::Format`] for a file that is not `.npy` or has fewer data
/// bytes than its shape needs, [`NpyError::Dtype`] for any other dtype (float64,
/// integers, records, pickled objects), [`NpyError::Shape`] for a Fortran-order array of
/// more than two axes.
pub fn read_f32(path: &Path) -> Result<ArrayF32, NpyError> {
    let bytes = std::fs::read(path).map_err(|source| NpyError::Read {
        path: path.to_owned(),
        source,
    })?;
    parse_f32(&bytes, path)
}

/// [`read_f32`] of a file's bytes already in memory (an embedded file); `path` names it
/// in errors.
pub fn parse_f32(bytes: &[u8], path: &Path) -> Result<ArrayF32, NpyError> {
    let format = |source| format_error(path, source);
    let npy = open_bytes(bytes, path)?;
    if float_size(&npy) != Some(4) {
        return Err(NpyError::Dtype {
            path: path.to_owned(),
            found: npy.dtype().descr(),
            expected: "float32 ('<f4')",
        });
    }
    let shape = npy.shape().to_vec();
    let order = npy.order();
    let data: Vec<f32> = npy.into_vec().map_err(format)?;
    let data = if order == Order::Fortran && shape.len() == 2 {
        fortran_to_c(&data, shape[0] as usize, shape[1] as usize)
    } else if order == Order::Fortran && shape.len() > 2 {
        // The layout has no such arrays; refuse rather than guess an axis order.
        return Err(NpyError::Shape {
            path: path.to_owned(),
            found: shape,
            expected: "at most 2 axes for a Fortran-order array".into(),
        });
    } else {
        data
    };
    Ok(ArrayF32 { shape, data })
}

/// [`NpyError::Format`] for `path`: not `.npy`, or a body shorter than its shape.
pub(crate) fn format_error(path: &Path, source: std::io::Error) -> NpyError {
    NpyError::Format {
        path: path.to_owned(),
        source,
    }
}

/// A `.npy` file's bytes already in memory, its header parsed; `path` names it in errors.
pub(crate) fn open_bytes<'a>(bytes: &'a [u8], path: &Path) -> Result<NpyFile<&'a [u8]>, NpyError> {
    NpyFile::new(bytes).map_err(|source| format_error(path, source))
}

/// The element size in bytes of a plain float dtype (`<f4`, `>f8`, ...), or `None` for
/// any other dtype and for pickled objects.
pub(crate) fn float_size(npy: &NpyFile<&[u8]>) -> Option<u64> {
    match npy.dtype() {
        DType::Plain(t) if t.type_char() == TypeChar::Float && !npy.uses_pickled_array() => {
            Some(t.size_field())
        }
        _ => None,
    }
}

/// A Fortran-order (column-major) `rows` × `cols` body in C (row-major) order.
pub(crate) fn fortran_to_c<T: Copy + Default>(data: &[T], rows: usize, cols: usize) -> Vec<T> {
    let mut c = vec![T::default(); data.len()];
    for r in 0..rows {
        for k in 0..cols {
            c[r * cols + k] = data[k * rows + r];
        }
    }
    c
}

/// N rows of six values: the body of a `.npy` file mapped into memory, or an array.
#[derive(Debug)]
pub enum Pairs {
    /// A C-order little-endian body, read in place from the page cache.
    #[cfg(unix)]
    Mapped(MappedF64),
    /// Values in memory.
    Owned(Vec<f64>),
}

impl std::ops::Deref for Pairs {
    type Target = [f64];
    fn deref(&self) -> &[f64] {
        match self {
            #[cfg(unix)]
            Pairs::Mapped(m) => m.values(),
            Pairs::Owned(v) => v,
        }
    }
}

/// Reads an N×6 float64 array (C or Fortran order) as N rows of six values, and checks
/// every direction is finite and of unit length within `unit_tol`, as the CSV contract
/// does (directions are not renormalised behind the user's back). A C-order body of a
/// regular file on a little-endian machine is mapped ([`MappedF64`]), otherwise read.
pub fn read_pairs(path: &Path, unit_tol: f64) -> Result<Pairs, NpyError> {
    let read_err = |source| NpyError::Read {
        path: path.to_owned(),
        source,
    };
    let mut file = std::io::BufReader::new(std::fs::File::open(path).map_err(read_err)?);
    let header = NpyHeader::from_reader(&mut file).map_err(|source| NpyError::Format {
        path: path.to_owned(),
        source,
    })?;
    // descr() quotes a plain type string: `'<f8'`.
    let dtype = header.dtype();
    let descr = dtype.descr().trim_matches('\'').to_string();
    let little_f64 = matches!(&dtype, DType::Plain(t)
        if t.type_char() == TypeChar::Float && t.size_field() == 8 && descr.starts_with('<'));
    if !little_f64 {
        return Err(NpyError::Dtype {
            path: path.to_owned(),
            found: descr,
            expected: "float64 ('<f8'): convert with arr.astype(np.float64)",
        });
    }
    let shape = header.shape().to_vec();
    if shape.len() != 2 || shape[1] != 6 {
        return Err(NpyError::Shape {
            path: path.to_owned(),
            found: shape,
            expected: "(N, 6): one row wi_x, wi_y, wi_z, wo_x, wo_y, wo_z per pair".into(),
        });
    }
    let rows = shape[0];
    let need = rows.saturating_mul(48);
    // The body's length from the file's size (a regular file), checked before
    // allocating: a damaged header cannot make the reader allocate more than it holds.
    let meta = file.get_ref().metadata().map_err(read_err)?;
    if meta.is_file() {
        let at = file.stream_position().map_err(read_err)?;
        let got = meta.len().saturating_sub(at);
        if got != need {
            return Err(NpyError::Length {
                path: path.to_owned(),
                rows,
                need,
                got,
            });
        }
    }
    let row_err = |(row, what)| NpyError::Row {
        path: path.to_owned(),
        row,
        what,
    };
    #[cfg(unix)]
    if meta.is_file() && cfg!(target_endian = "little") && header.order() == Order::C {
        let at = file.stream_position().map_err(read_err)? as usize;
        if let Some(m) = MappedF64::new(file.get_ref(), meta.len() as usize, at) {
            let pairs = Pairs::Mapped(m);
            check_rows(&pairs, unit_tol).map_err(row_err)?;
            return Ok(pairs);
        }
    }
    // The body is read straight into the f64 array (little-endian bytes on a
    // little-endian machine: no second copy of a 70 MB input), which lies on huge pages:
    // 4 KiB pages cost 17,000 first-touch faults for 1.46 M pairs.
    let mut v = brdfkit_merl::zeroed_f64((rows * 6) as usize);
    let got = read_full(&mut file, bytemuck::cast_slice_mut(&mut v)).map_err(read_err)?;
    let extra = read_full(&mut file, &mut [0u8; 1]).map_err(read_err)?;
    if got as u64 != need || extra != 0 {
        let rest = std::io::copy(&mut file, &mut std::io::sink()).map_err(read_err)?;
        return Err(NpyError::Length {
            path: path.to_owned(),
            rows,
            need,
            got: got as u64 + extra as u64 + rest,
        });
    }
    if cfg!(target_endian = "big") {
        for x in &mut v {
            *x = f64::from_bits(u64::from_le(x.to_bits()));
        }
    }
    if header.order() == Order::Fortran && rows > 1 {
        let n = rows as usize;
        let mut c = brdfkit_merl::zeroed_f64(v.len());
        for (col, column) in v.chunks_exact(n).enumerate() {
            for (r, &x) in column.iter().enumerate() {
                c[r * 6 + col] = x;
            }
        }
        v = c;
    }
    check_rows(&v, unit_tol).map_err(row_err)?;
    Ok(Pairs::Owned(v))
}

/// Reads until `buf` is full or the file ends; the number of bytes read.
fn read_full(r: &mut impl std::io::Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

/// The first row that is not two finite directions of unit length.
fn check_rows(v: &[f64], tol: f64) -> Result<(), (usize, String)> {
    // Written as a "good" test so NaN lands on the bad side.
    let good = |r: &[f64]| {
        let ni = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
        let no = r[3] * r[3] + r[4] * r[4] + r[5] * r[5];
        (ni.sqrt() - 1.0).abs() <= tol && (no.sqrt() - 1.0).abs() <= tol
    };
    // Blocks of rows tested without an early exit (a loop that vectorises), on every
    // thread (a pass over 70 MB for 1.46 M rows), the first bad row searched for only
    // in the first failing block.
    const BLOCK: usize = 6 * 256;
    let bad = v
        .par_chunks(BLOCK)
        .enumerate()
        .with_min_len(64)
        .find_map_first(|(b, block)| {
            let all = block.chunks_exact(6).fold(true, |ok, r| ok & good(r));
            (!all)
                .then(|| b * BLOCK / 6 + block.chunks_exact(6).position(|r| !good(r)).unwrap_or(0))
        });
    match bad {
        None => Ok(()),
        Some(k) => {
            let r = &v[6 * k..6 * k + 6];
            let what = if r.iter().any(|x| !x.is_finite()) {
                format!("non-finite value in {r:?}")
            } else {
                let ni = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
                let no = (r[3] * r[3] + r[4] * r[4] + r[5] * r[5]).sqrt();
                format!("|wi| = {ni}, |wo| = {no}: directions must be unit vectors (within {tol})")
            };
            Err((k, what))
        }
    }
}

/// Writes `values` (r, g, b per row) as an N×3 float64 `.npy` file into `w`: the
/// header by npyz, the body as the array's own bytes (no 35 MB copy).
pub fn write_values(w: &mut impl std::io::Write, values: &[f64]) -> std::io::Result<()> {
    debug_assert_eq!(values.len() % 3, 0);
    write_header(w, values.len() / 3)?;
    write_body(w, values)
}

/// Where [`write_values_with`] writes: any writer; a file also starts writing each chunk
/// back to its disk once it is written, so that the sync before the file is renamed
/// into place (`brdfkit::core::atomic`) waits for the last chunk only instead of the
/// whole 35 MB of 1.46 M rows.
pub trait Sink: std::io::Write + Send {
    /// Starts writing bytes `from .. from + len` back to the disk, without waiting (a
    /// hint: nothing happens where the system has no such call).
    fn start_writeback(&mut self, from: u64, len: u64) {
        let _ = (from, len);
    }
}

impl Sink for Vec<u8> {}

impl Sink for std::fs::File {
    #[cfg(target_os = "linux")]
    fn start_writeback(&mut self, from: u64, len: u64) {
        use std::os::fd::AsRawFd;
        // SAFETY: a plain system call on an open descriptor; its failure only means
        // the writeback starts at the sync instead, so the result is not needed.
        unsafe {
            libc::sync_file_range(
                self.as_raw_fd(),
                from as libc::off64_t,
                len as libc::off64_t,
                libc::SYNC_FILE_RANGE_WRITE,
            );
        }
    }
}

/// The header of an N×3 float64 array; returns its length in bytes.
fn write_header(w: &mut impl std::io::Write, rows: usize) -> std::io::Result<usize> {
    let f8: TypeStr = "<f8".parse().expect("a valid type string");
    let header = WriteOptions::new_header_only()
        .dtype(DType::Plain(f8))
        .shape(&[rows as u64, 3])
        .writer(Vec::new())
        .write_header_only()?;
    w.write_all(&header)?;
    Ok(header.len())
}

/// Values as little-endian bytes.
fn write_body(w: &mut impl std::io::Write, values: &[f64]) -> std::io::Result<()> {
    if cfg!(target_endian = "little") {
        w.write_all(bytemuck::cast_slice(values))
    } else {
        let le: Vec<u8> = values.iter().flat_map(|x| x.to_le_bytes()).collect();
        w.write_all(&le)
    }
}

/// Rows per chunk of [`write_values_with`] (1.5 MB of values).
const WRITE_CHUNK_ROWS: usize = 1 << 16;

/// Writes an N×3 float64 `.npy` file of `rows` rows that `fill(first_row, out)`
/// computes chunk by chunk (`out.len() / 3` rows from `first_row`): the same bytes as
/// [`write_values`] of the whole array. Each chunk is written by a second thread while
/// the next one is computed, so no N×3 array is allocated (35 MB of fresh pages for
/// 1.46 M rows, zeroed by the kernel) and the writing overlaps the computation.
pub fn write_values_with(
    w: &mut impl Sink,
    rows: usize,
    fill: impl Fn(usize, &mut [f64]) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut at = write_header(w, rows)? as u64;
    let len = |c: usize| 3 * (rows - c * WRITE_CHUNK_ROWS).min(WRITE_CHUNK_ROWS);
    let chunks = rows.div_ceil(WRITE_CHUNK_ROWS);
    let mut cur = vec![0.0; len(0)];
    let mut next = vec![0.0; if chunks > 1 { len(1) } else { 0 }];
    fill(0, &mut cur)?;
    for c in 0..chunks {
        if c + 1 == chunks {
            return write_body(w, &cur);
        }
        next.resize(len(c + 1), 0.0);
        let bytes = 8 * cur.len() as u64;
        let written = std::thread::scope(|s| {
            let h = s.spawn(|| {
                write_body(&mut *w, &cur)?;
                w.start_writeback(at, bytes);
                Ok(())
            });
            let filled = fill((c + 1) * WRITE_CHUNK_ROWS, &mut next);
            let written = h
                .join()
                .unwrap_or_else(|_| Err(std::io::Error::other("writer thread panicked")));
            written.and(filled)
        });
        written?;
        at += bytes;
        std::mem::swap(&mut cur, &mut next);
    }
    Ok(())
}

#[cfg(test)]
#[path = "../tests/common/npy_bytes.rs"]
mod npy_file;

#[cfg(test)]
mod tests {
    use super::*;

    use super::npy_file::npy_bytes as npy;

    fn f64s(x: &[f64]) -> Vec<u8> {
        x.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    #[test]
    fn reads_rows_and_writes_values_that_numpy_layout_expects() {
        let d = tempfile::tempdir().unwrap();
        let rows = [0.0, 0.0, 1.0, 0.6, 0.0, 0.8, 0.8, 0.0, 0.6, 0.0, 0.0, 1.0];
        let p = write(d.path(), "p.npy", &npy("<f8", "(2, 6)", &f64s(&rows)));
        assert!(matches!(read_pairs(&p, 1e-6).unwrap(), Pairs::Mapped(_)));
        assert_eq!(&*read_pairs(&p, 1e-6).unwrap(), &rows[..]);
        let mut out = Vec::new();
        write_values(&mut out, &[1.0, 2.0, f64::NAN, 4.0, 5.0, 6.0]).unwrap();
        let mut body: &[u8] = &out;
        let h = NpyHeader::from_reader(&mut body).unwrap();
        assert_eq!(h.shape(), &[2, 3]);
        assert_eq!(h.dtype().descr(), "'<f8'");
        assert_eq!(body.len(), 48);
        assert!(f64::from_le_bytes(body[16..24].try_into().unwrap()).is_nan());
    }

    #[test]
    fn chunked_writing_gives_the_bytes_of_the_whole_array() {
        for rows in [0, 1, WRITE_CHUNK_ROWS, 2 * WRITE_CHUNK_ROWS + 5] {
            let values: Vec<f64> = (0..3 * rows).map(|x| x as f64 * 0.25).collect();
            let mut whole = Vec::new();
            write_values(&mut whole, &values).unwrap();
            let mut chunked = Vec::new();
            write_values_with(&mut chunked, rows, |first, out| {
                out.copy_from_slice(&values[3 * first..3 * first + out.len()]);
                Ok(())
            })
            .unwrap();
            assert!(whole == chunked, "{rows} rows");
        }
        let failed = write_values_with(&mut Vec::new(), 2 * WRITE_CHUNK_ROWS, |first, _| {
            if first > 0 {
                Err(std::io::Error::other("no value"))
            } else {
                Ok(())
            }
        });
        assert_eq!(failed.unwrap_err().to_string(), "no value");
    }

    #[test]
    fn a_body_off_the_8_byte_grid_is_read_not_mapped() {
        let d = tempfile::tempdir().unwrap();
        let rows = [0.0, 0.0, 1.0, 0.6, 0.0, 0.8];
        // Version 1.0 with a 4-byte-padded header: the body starts at byte 36.
        let h = "{'descr': '<f8', 'fortran_order': False, 'shape': (1, 6), }   \n";
        let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
        bytes.extend_from_slice(&(h.len() as u16).to_le_bytes());
        bytes.extend_from_slice(h.as_bytes());
        assert_ne!(bytes.len() % 8, 0);
        bytes.extend_from_slice(&f64s(&rows));
        let p = write(d.path(), "odd.npy", &bytes);
        let got = read_pairs(&p, 1e-6).unwrap();
        assert!(matches!(got, Pairs::Owned(_)));
        assert_eq!(&*got, &rows[..]);
    }

    #[test]
    fn fortran_order_is_transposed() {
        let d = tempfile::tempdir().unwrap();
        let c = [0.0, 0.0, 1.0, 0.6, 0.0, 0.8, 0.8, 0.0, 0.6, 0.0, 0.0, 1.0];
        let mut f = [0.0; 12];
        for r in 0..2 {
            for k in 0..6 {
                f[k * 2 + r] = c[r * 6 + k];
            }
        }
        let mut bytes = npy("<f8", "(2, 6)", &f64s(&f));
        let at = bytes.windows(5).position(|w| w == b"False").unwrap();
        bytes[at..at + 5].copy_from_slice(b"True ");
        let p = write(d.path(), "f.npy", &bytes);
        assert_eq!(&*read_pairs(&p, 1e-6).unwrap(), &c[..]);
    }

    #[test]
    fn bad_files_get_typed_errors_naming_the_file() {
        let d = tempfile::tempdir().unwrap();
        let one = f64s(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0]);
        let cases: Vec<(&str, Vec<u8>, &str)> = vec![
            ("text.npy", b"wi_x,wi_y\n".to_vec(), "not a valid .npy"),
            ("f32.npy", npy("<f4", "(1, 6)", &[0u8; 24]), "dtype '<f4'"),
            ("shape.npy", npy("<f8", "(2, 3)", &one), "shape (2, 3)"),
            ("short.npy", npy("<f8", "(2, 6)", &one), "holds 48"),
            (
                "long.npy",
                npy("<f8", "(1, 6)", &f64s(&[0.0, 0.0, 2.0, 0.0, 0.0, 1.0])),
                "row 0: |wi| = 2",
            ),
            (
                "nan.npy",
                npy("<f8", "(1, 6)", &f64s(&[f64::NAN, 0.0, 1.0, 0.0, 0.0, 1.0])),
                "row 0: non-finite",
            ),
        ];
        for (name, bytes, want) in cases {
            let p = write(d.path(), name, &bytes);
            let e = read_pairs(&p, 1e-6).unwrap_err().to_string();
            assert!(e.contains(name) && e.contains(want), "{name}: {e}");
        }
        let e = read_pairs(&d.path().join("none.npy"), 1e-6).unwrap_err();
        assert!(matches!(e, NpyError::Read { .. }), "{e}");
    }
}
