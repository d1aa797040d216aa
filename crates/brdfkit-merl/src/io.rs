//! Reading and writing the binary format.
//!
//! Layout: three little-endian int32 dims (θh, θd, φd), then 3 × n little-endian
//! float64, whole channel planes R, G, B, each in the order `k + nφd · (j + nθd · i)`.
//!
//! Reading checks the header against the file's length (from its metadata) **before**
//! allocating, so a corrupt header cannot make the reader allocate more than the file
//! holds. The body is then read in parallel (rayon) by positional reads of [`IO_CHUNK_CELLS`]
//! cells per channel into per-thread staging buffers that stay in cache (placed where
//! the copy is fast: see `ALIAS_PERIOD`), and converted, validated (finite values, the
//! missing mask) and stored from there: one pass over the data, into a table allocated
//! once on huge pages. `docs/merl-format.md` (Performance) has the measurements.
//!
//! Writing goes to a temporary file in the destination directory, synced, then renamed
//! over the destination: a reader sees the old file or the new one, never a partial
//! one, and a failed write removes its temporary file and leaves the old file intact.

use crate::error::{BadValue, ByteCount, MerlError};
use crate::grid::{Dims, HEADER_BYTES, IO_CHUNK_CELLS};
use crate::table::{
    MerlTable, acceptable_raw, alloc_mask, alloc_raw, raw_valid, spread, zeroed_f64,
};
use byteorder::{ByteOrder, LittleEndian};
use std::cell::RefCell;
use std::fs::File;
use std::io::{self, Read, Write};
use std::path::Path;

/// Where the body's bytes come from: a file read positionally (parallel tasks share it)
/// or a byte slice.
trait Source: Sync {
    /// The bytes of cells `first .. first + len` of the three planes of `n` cells (R, G,
    /// B), read into `buf` if they are not already in memory, plane c's copy placed
    /// `shift[c]` bytes (modulo [`ALIAS_PERIOD`]) after the address of its file offset.
    fn planes<'a>(
        &'a self,
        n: usize,
        first: usize,
        len: usize,
        shift: [usize; 3],
        buf: &'a mut Vec<u8>,
    ) -> io::Result<[&'a [u8]; 3]>;
}

impl Source for &[u8] {
    fn planes<'a>(
        &'a self,
        n: usize,
        first: usize,
        len: usize,
        _shift: [usize; 3],
        _buf: &'a mut Vec<u8>,
    ) -> io::Result<[&'a [u8]; 3]> {
        Ok(std::array::from_fn(|c| {
            let off = 8 * (c * n + first);
            &self[off..off + 8 * len]
        }))
    }
}

#[cfg(unix)]
impl Source for File {
    fn planes<'a>(
        &'a self,
        n: usize,
        first: usize,
        len: usize,
        shift: [usize; 3],
        buf: &'a mut Vec<u8>,
    ) -> io::Result<[&'a [u8]; 3]> {
        use std::os::unix::fs::FileExt;
        // One region per plane, with room to place the copy at any address modulo
        // ALIAS_PERIOD.
        let region = 8 * len + ALIAS_PERIOD;
        if buf.len() < 3 * region {
            buf.resize(3 * region, 0);
        }
        let (r, gb) = buf[..3 * region].split_at_mut(region);
        let (g, b) = gb.split_at_mut(region);
        let mut parts: [&mut [u8]; 3] = [r, g, b];
        for (c, part) in parts.iter_mut().enumerate() {
            let off = HEADER_BYTES as usize + 8 * (c * n + first);
            // A page-cache page is page-aligned, so the kernel reads byte `off` at an
            // address ≡ off (mod 4 KiB).
            let at = (off + shift[c]).wrapping_sub(part.as_ptr() as usize) % ALIAS_PERIOD;
            let dst = &mut std::mem::take(part)[at..at + 8 * len];
            self.read_exact_at(dst, off as u64)?;
            *part = dst;
        }
        let [r, g, b] = parts;
        Ok([r, g, b])
    }
}

/// Addresses that agree in their low 12 bits look alike to the processor's check of
/// loads against earlier stores (x86-64; "4K aliasing"). A copy whose destination runs
/// a few bytes *ahead* of its source modulo 4 KiB is slow: on the project machine (AMD
/// EPYC, Zen 4) `pread` of the 35 MB body in 64 KiB pieces took 15 ms of CPU into a
/// buffer 1–16 bytes ahead of the file offset modulo 4 KiB, and 5.7 ms at any distance
/// from 32 bytes up or at an equal or lower address. The kernel's `rep movsb` copy hits
/// this with the usual 16-byte `malloc` header: the file's values start at offset 12.
const ALIAS_PERIOD: usize = 4096;

/// Where to put a staging copy, as a shift from its file offset modulo
/// [`ALIAS_PERIOD`], given the table's own shift (`table_shift`: its address minus the
/// file offset of the same value). Two copies pass through the staging buffer, file →
/// staging (shift `s`) and staging → table (shift `table_shift − s`); half a period
/// keeps both far from the slow distances, or, when the table's shift is itself near
/// half a period, no shift at all.
fn staging_shift(table_shift: usize) -> usize {
    let half = ALIAS_PERIOD / 2;
    if table_shift.wrapping_sub(half) % ALIAS_PERIOD < 256 {
        0
    } else {
        half
    }
}

thread_local! {
    /// Each thread's staging buffer for positional reads (24 × [`IO_CHUNK_CELLS`] bytes), kept
    /// from one read to the next: allocating it per task would cost a `calloc` of 192
    /// KiB (zeroing, or fresh pages to fault) some 20 times per table.
    static STAGE: RefCell<Vec<u8>> = const { RefCell::new(Vec::new()) };
}

/// Converts one run of cells from the little-endian bytes of its three planes into the
/// table, checking every value and writing the run's mask in the same pass. Returns the
/// number of valid cells and whether every value was acceptable; an unacceptable value
/// is stored as 0.0 (the table is discarded: [`first_bad`] finds it in `src`).
///
/// One loop over the cells with all three channels in hand: the mask entry is written
/// once, from the three signs, instead of being read back and updated per channel.
/// Non-short-circuiting (`&`) so the loop vectorises. Storing through the select also
/// keeps LLVM from splitting the loop into three `memcpy` calls and a second pass for
/// the checks, which measured 1.7 ms (13 %) more CPU per MERL table: `memcpy` there is
/// `rep movsb`, no faster than the vector stores, and the checks then read everything
/// again.
fn decode_run(
    src: [&[u8]; 3],
    r: &mut [f64],
    g: &mut [f64],
    b: &mut [f64],
    v: &mut [bool],
) -> (usize, bool) {
    let le = |s: &[u8]| f64::from_le_bytes(s.try_into().expect("8 bytes"));
    let mut all_ok = true;
    let mut count = 0;
    let cells = r
        .iter_mut()
        .zip(g.iter_mut())
        .zip(b.iter_mut())
        .zip(v.iter_mut());
    let values = src[0]
        .chunks_exact(8)
        .zip(src[1].chunks_exact(8))
        .zip(src[2].chunks_exact(8));
    for ((((r, g), b), v), ((sr, sg), sb)) in cells.zip(values) {
        let (x, y, z) = (le(sr), le(sg), le(sb));
        // One comparison each rejects NaN, ±inf and corrupt magnitudes alike.
        let (ox, oy, oz) = (acceptable_raw(x), acceptable_raw(y), acceptable_raw(z));
        all_ok &= ox & oy & oz;
        *r = if ox { x } else { 0.0 };
        *g = if oy { y } else { 0.0 };
        *b = if oz { z } else { 0.0 };
        let ok = raw_valid(x, y, z);
        *v = ok;
        count += ok as usize;
    }
    (count, all_ok)
}

/// The first unacceptable value of a run in file order (the red plane's values come
/// before the green plane's): its channel, its offset in the run, and the value.
fn first_bad(src: [&[u8]; 3]) -> Option<(usize, usize, f64)> {
    src.iter().enumerate().find_map(|(c, plane)| {
        plane.chunks_exact(8).enumerate().find_map(|(i, s)| {
            let x = f64::from_le_bytes(s.try_into().expect("8 bytes"));
            (!acceptable_raw(x)).then_some((c, i, x))
        })
    })
}

/// The dims of a header (positive, within int32, size representable).
fn header_dims(header: &[u8; 12], path: &Path) -> Result<Dims, MerlError> {
    if let Some(e) = MerlError::not_merl(header, path) {
        return Err(e);
    }
    let d = [
        LittleEndian::read_i32(&header[0..4]) as i64,
        LittleEndian::read_i32(&header[4..8]) as i64,
        LittleEndian::read_i32(&header[8..12]) as i64,
    ];
    Dims::new(d[0], d[1], d[2]).map_err(|source| MerlError::Dims {
        path: path.to_path_buf(),
        source,
    })
}

/// Checks a total length in bytes against the dims.
fn check_length(dims: Dims, len: u64, path: &Path) -> Result<(), MerlError> {
    let size = ByteCount {
        dims,
        cells: dims.cells(),
        expected: dims.file_bytes(),
        actual: len,
    };
    let path = path.to_path_buf();
    match len.cmp(&size.expected) {
        std::cmp::Ordering::Less => Err(MerlError::Truncated { path, size }),
        std::cmp::Ordering::Greater => Err(MerlError::TrailingBytes { path, size }),
        std::cmp::Ordering::Equal => Ok(()),
    }
}

/// Parses the header and checks it against the total length in bytes.
fn parse_header(header: &[u8; 12], len: u64, path: &Path) -> Result<Dims, MerlError> {
    let dims = header_dims(header, path)?;
    check_length(dims, len, path)?;
    Ok(dims)
}

/// Reads the dims and the body of a table from a stream without a known length (a
/// pipe, a device): the header, then the body through `take`, so the buffer grows with the bytes actually present
/// and never beyond what the header claims; any excess is counted, not stored.
fn read_stream(mut r: impl Read, path: &Path) -> Result<(Dims, Vec<u8>), MerlError> {
    let mut header = [0u8; 12];
    let mut got = 0;
    while got < 12 {
        match r.read(&mut header[got..]) {
            Ok(0) => {
                return Err(MerlError::TooShort {
                    path: path.to_path_buf(),
                    len: got as u64,
                });
            }
            Ok(k) => got += k,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(MerlError::io(path, "reading the header", e)),
        }
    }
    let dims = header_dims(&header, path)?;
    let body_len = dims.file_bytes() - HEADER_BYTES;
    let mut body = Vec::new();
    (&mut r)
        .take(body_len)
        .read_to_end(&mut body)
        .map_err(|e| MerlError::io(path, "reading", e))?;
    let extra = io::copy(&mut r, &mut io::sink()).map_err(|e| MerlError::io(path, "reading", e))?;
    check_length(dims, HEADER_BYTES + body.len() as u64 + extra, path)?;
    Ok((dims, body))
}

/// Reads the body (3 planes of little-endian f64) from `src` into a new table
/// ([`decode_body`]).
fn read_body(
    dims: Dims,
    path: &Path,
    src: &(impl Source + ?Sized),
    chunk: usize,
) -> Result<MerlTable, MerlError> {
    let n = dims.cells();
    let mut raw = alloc_raw(n);
    let (r, gb) = raw.split_at_mut(n);
    let (g, b) = gb.split_at_mut(n);
    let (valid, n_valid) = decode_body(dims, path, src, chunk, [r, g, b])?;
    Ok(MerlTable::assemble(dims, raw, valid, n_valid))
}

/// A table file's three raw planes, each in a buffer of its own (`dims.cells()` long,
/// on huge pages where the system allows), with the validity mask
/// and the count of valid cells: what [`TableCells::from_planes`](crate::TableCells::from_planes)
/// turns, in place, into the valid cells' values, so that a fit copies the measured
/// values from the file into fresh memory once (through a [`MerlTable`] it copied them
/// twice: file → table → cells).
#[derive(Debug)]
pub struct TablePlanes {
    pub(crate) dims: Dims,
    pub(crate) planes: [Vec<f64>; 3],
    pub(crate) valid: Vec<bool>,
    pub(crate) n_valid: usize,
}

impl TablePlanes {
    /// Reads a table file's planes without building the table: the same checks, the
    /// same values and every failure the same [`MerlError`] as [`MerlTable::read`].
    pub fn read(path: impl AsRef<Path>) -> Result<TablePlanes, MerlError> {
        let path = path.as_ref();
        read_file(path, |dims, src| {
            // Rounded up to whole huge pages (`zeroed_f64`, not the exact length): the
            // ends' 4 KiB faults would cost more than the rounding, which the cells
            // give back when they cut the planes to the valid cells.
            let mut planes = [0, 1, 2].map(|_| zeroed_f64(dims.cells()));
            let [r, g, b] = &mut planes;
            let (valid, n_valid) = decode_body(dims, path, src, IO_CHUNK_CELLS, [r, g, b])?;
            Ok(TablePlanes {
                dims,
                planes,
                valid,
                n_valid,
            })
        })
    }

    /// The grid.
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// Number of valid cells.
    pub fn valid_count(&self) -> usize {
        self.n_valid
    }
}

/// Decodes the body (3 planes of little-endian f64) from `src` into the planes `rgb`
/// (raw values, `dims.cells()` each) and returns the validity mask and the number of
/// valid cells. In parallel over runs of `chunk` cells ([`IO_CHUNK_CELLS`] outside
/// tests), validating in the same pass: each task takes the same cells from the three
/// planes, so it alone owns their mask entries. The first unacceptable value in file
/// order is an error: each task reports its own first one, and the earliest in the
/// file wins.
fn decode_body(
    dims: Dims,
    path: &Path,
    src: &(impl Source + ?Sized),
    chunk: usize,
    rgb: [&mut [f64]; 3],
) -> Result<(Vec<bool>, usize), MerlError> {
    /// A task's result: its valid cells, and its first bad value as (position in the
    /// file's value order, value).
    type Run = (usize, Option<(usize, f64)>);
    let n = dims.cells();
    let mut valid = alloc_mask(n);
    // Each plane's own distance from its file offset (one buffer or three).
    let shift = [0, 1, 2].map(|c| {
        let file_at = HEADER_BYTES as usize + 8 * c * n;
        staging_shift((rgb[c].as_ptr() as usize).wrapping_sub(file_at))
    });
    let [r, g, b] = rgb;
    let earliest = |a: Option<(usize, f64)>, b: Option<(usize, f64)>| match (a, b) {
        (Some(x), Some(y)) => Some(if y.0 < x.0 { y } else { x }),
        (x, y) => x.or(y),
    };
    // Every worker of the pool woken up front (`spread`): a plain `par_chunks_mut` left
    // one of two workers asleep for a whole read now and then, doubling its time.
    let mut results: Vec<io::Result<Run>> = (0..n.div_ceil(chunk)).map(|_| Ok((0, None))).collect();
    let runs: Vec<_> = r
        .chunks_mut(chunk)
        .zip(g.chunks_mut(chunk))
        .zip(b.chunks_mut(chunk))
        .zip(valid.chunks_mut(chunk))
        .zip(results.iter_mut())
        .collect();
    spread(runs, |q, ((((r, g), b), v), result)| {
        *result = STAGE.with_borrow_mut(|buf| {
            let bytes = src.planes(n, q * chunk, r.len(), shift, buf)?;
            let (count, all_ok) = decode_run(bytes, r, g, b, v);
            let bad = if all_ok {
                None
            } else {
                first_bad(bytes).map(|(c, i, x)| (c * n + q * chunk + i, x))
            };
            Ok((count, bad))
        });
    });
    let (mut n_valid, mut bad) = (0, None);
    for result in results {
        let (count, b) = result.map_err(|e| MerlError::io(path, "reading", e))?;
        n_valid += count;
        bad = earliest(bad, b);
    }
    if let Some((at, value)) = bad {
        return Err(MerlError::bad_raw(path, BadValue::at_flat(dims, at, value)));
    }
    debug_assert!(
        valid
            .iter()
            .enumerate()
            .all(|(x, &v)| v == raw_valid(r[x], g[x], b[x]))
    );
    Ok((valid, n_valid))
}

/// Opens a table file and hands its dims and body to `body`: a regular file's header
/// checked against its length, then the file itself for positional reads (its bytes
/// elsewhere); a pipe or a device read whole through [`read_stream`]'s checks. Every
/// failure is a [`MerlError`] naming the file.
fn read_file<T>(
    path: &Path,
    body: impl FnOnce(Dims, &dyn Source) -> Result<T, MerlError>,
) -> Result<T, MerlError> {
    let mut file = File::open(path).map_err(|e| MerlError::io(path, "opening", e))?;
    let meta = file
        .metadata()
        .map_err(|e| MerlError::io(path, "reading metadata", e))?;
    if meta.is_dir() {
        return Err(MerlError::IsDirectory {
            path: path.to_path_buf(),
        });
    }
    if !meta.is_file() {
        // A pipe or a device has no length to check the header against.
        let (dims, bytes) = read_stream(file, path)?;
        return body(dims, &&bytes[..]);
    }
    let len = meta.len();
    if len < HEADER_BYTES {
        return Err(MerlError::TooShort {
            path: path.to_path_buf(),
            len,
        });
    }
    let mut header = [0u8; 12];
    file.read_exact(&mut header)
        .map_err(|e| MerlError::io(path, "reading the header", e))?;
    let dims = parse_header(&header, len, path)?;
    #[cfg(unix)]
    {
        body(dims, &file)
    }
    #[cfg(not(unix))]
    {
        // No positional reads: the body in one buffer (its size was checked
        // against the file's length above), then the same conversion.
        let mut bytes = vec![0u8; len as usize - 12];
        file.read_exact(&mut bytes)
            .map_err(|e| MerlError::io(path, "reading", e))?;
        body(dims, &&bytes[..])
    }
}

impl MerlTable {
    /// Reads a table file. Every failure is a [`MerlError`] naming the file.
    pub fn read(path: impl AsRef<Path>) -> Result<MerlTable, MerlError> {
        let path = path.as_ref();
        read_file(path, |dims, src| read_body(dims, path, src, IO_CHUNK_CELLS))
    }

    /// Parses a table from bytes; `name` stands for the file in error messages.
    pub fn from_bytes(bytes: &[u8], name: impl AsRef<Path>) -> Result<MerlTable, MerlError> {
        let path = name.as_ref();
        let len = bytes.len() as u64;
        if len < HEADER_BYTES {
            return Err(MerlError::TooShort {
                path: path.to_path_buf(),
                len,
            });
        }
        let header: [u8; 12] = bytes[..12].try_into().expect("12 bytes");
        let dims = parse_header(&header, len, path)?;
        read_body(dims, path, &&bytes[HEADER_BYTES as usize..], IO_CHUNK_CELLS)
    }

    /// The file image: header then the raw planes, exactly the bytes [`write`](Self::write)
    /// stores.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = vec![0u8; self.dims.file_bytes() as usize];
        write_header(self.dims, &mut out[..12]);
        LittleEndian::write_f64_into(&self.raw, &mut out[12..]);
        out
    }

    /// Writes the table to `path` atomically (temporary file in the same directory,
    /// synced, renamed into place). On error the old file, if any, is untouched and no
    /// temporary file is left.
    pub fn write(&self, path: impl AsRef<Path>) -> Result<(), MerlError> {
        atomic_write(path.as_ref(), |file| {
            let mut header = [0u8; 12];
            write_header(self.dims, &mut header);
            file.write_all(&header)?;
            let mut buf = vec![0u8; 8 * IO_CHUNK_CELLS];
            for chunk in self.raw.chunks(IO_CHUNK_CELLS) {
                let bytes = &mut buf[..8 * chunk.len()];
                LittleEndian::write_f64_into(chunk, bytes);
                file.write_all(bytes)?;
            }
            Ok(())
        })
    }
}

fn write_header(dims: Dims, out: &mut [u8]) {
    // Dims::new guarantees every dimension fits in an i32.
    LittleEndian::write_i32(&mut out[0..4], dims.theta_h() as i32);
    LittleEndian::write_i32(&mut out[4..8], dims.theta_d() as i32);
    LittleEndian::write_i32(&mut out[8..12], dims.phi_d() as i32);
}

/// Writes a file atomically through the one writer of brdfkit,
/// [`brdfkit_core::atomic::write_file`] (temporary file beside `path`, synced, renamed
/// over it; new files get 0666 & ~umask, replaced files keep their mode), with its
/// error as a [`MerlError::Io`] naming `path` and the failed step.
pub fn atomic_write(
    path: &Path,
    body: impl FnOnce(&mut File) -> io::Result<()>,
) -> Result<(), MerlError> {
    brdfkit_core::atomic::write_file(path, body)
        .map_err(|e| MerlError::io(&e.path, e.step, e.source))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Channel;
    use crate::table::MAX_ABS_RAW;
    use rayon::prelude::*;
    use std::path::PathBuf;

    fn leftovers(dir: &Path) -> Vec<String> {
        brdfkit_core::atomic::leftovers(dir).unwrap()
    }

    use crate::table::{alloc_mask, alloc_raw};
    use rand::{Rng, SeedableRng};

    /// A file image of `dims` with the given raw planes.
    fn image(dims: Dims, raw: &[f64]) -> Vec<u8> {
        let mut out = vec![0u8; 12 + 8 * raw.len()];
        write_header(dims, &mut out[..12]);
        LittleEndian::write_f64_into(raw, &mut out[12..]);
        out
    }

    /// Raw values with every kind the reader distinguishes: positive, +0.0, −0.0,
    /// negative (missing), and magnitudes up to the limit.
    fn assorted_raw(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..3 * n)
            .map(|_| match rng.random_range(0..8) {
                0 => -rng.random::<f64>(),
                1 => -0.0,
                2 => 0.0,
                3 => MAX_ABS_RAW,
                4 => -1.0,
                _ => rng.random::<f64>() * 1e4,
            })
            .collect()
    }

    fn assert_bit_identical(a: &MerlTable, b: &MerlTable, what: &str) {
        assert_eq!(a.dims, b.dims, "{what}");
        assert_eq!(a.raw.len(), b.raw.len(), "{what}");
        for (x, (p, q)) in a.raw.iter().zip(&b.raw).enumerate() {
            assert_eq!(p.to_bits(), q.to_bits(), "{what}: value {x}");
        }
        assert_eq!(a.valid, b.valid, "{what}");
        assert_eq!(a.n_valid, b.n_valid, "{what}");
    }

    /// Runs of odd lengths (1, 3, 7 cells: byte runs of 8, 24, 56 at file offsets
    /// 12 + 8 · k, aligned to nothing), runs that do not divide the plane, one run
    /// longer than it, through the file (positional reads) and through a slice: the
    /// same table bit for bit as `from_bytes`, and the same mask and count as the
    /// definition computes from the raw values.
    #[test]
    fn any_run_length_reads_the_same_table_as_from_bytes() {
        let dims = Dims::new(7, 11, 13).unwrap(); // 1001 cells: odd, prime factors only
        let n = dims.cells();
        let raw = assorted_raw(n, 11);
        let bytes = image(dims, &raw);
        let reference = MerlTable::from_bytes(&bytes, "mem").unwrap();
        for (x, v) in reference.valid.iter().enumerate() {
            assert_eq!(
                *v,
                raw_valid(raw[x], raw[n + x], raw[2 * n + x]),
                "cell {x}"
            );
        }
        assert_eq!(
            reference.n_valid,
            reference.valid.iter().filter(|v| **v).count()
        );
        assert!(reference.n_valid > 0 && reference.n_valid < n);
        for (x, (p, q)) in reference.raw.iter().zip(&raw).enumerate() {
            assert_eq!(p.to_bits(), q.to_bits(), "value {x}");
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("odd.binary");
        std::fs::write(&path, &bytes).unwrap();
        let file = File::open(&path).unwrap();
        for chunk in [1, 3, 7, 8, 13, 500, 1000, 1001, 1002, IO_CHUNK_CELLS] {
            let what = format!("run of {chunk} cells");
            let t = read_body(dims, &path, &file, chunk).unwrap();
            assert_bit_identical(&t, &reference, &format!("file, {what}"));
            let t = read_body(dims, &path, &&bytes[12..], chunk).unwrap();
            assert_bit_identical(&t, &reference, &format!("slice, {what}"));
        }
        assert_bit_identical(&MerlTable::read(&path).unwrap(), &reference, "read");
    }

    /// Reads running inside parallel tasks (a batch of tables read with rayon) share the
    /// pool's threads and so their staging buffers: each borrow ends before a thread can
    /// take up another task, so nested reads neither panic nor mix their data.
    #[test]
    fn reads_nested_in_parallel_tasks_are_independent() {
        let dims = Dims::new(7, 11, 13).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let files: Vec<(PathBuf, Vec<u8>)> = (0..8)
            .map(|s| {
                let bytes = image(dims, &assorted_raw(dims.cells(), 100 + s));
                let path = dir.path().join(format!("t{s}.binary"));
                std::fs::write(&path, &bytes).unwrap();
                (path, bytes)
            })
            .collect();
        files.par_iter().for_each(|(path, bytes)| {
            let file = File::open(path).unwrap();
            let t = read_body(dims, path, &file, 5).unwrap();
            assert_bit_identical(&t, &MerlTable::from_bytes(bytes, "mem").unwrap(), "nested");
        });
    }

    /// Several bad values in different runs and planes: whatever the run length, the
    /// first in file order is the one reported (here a red value beyond the limit at a
    /// later cell than a NaN in green and an infinity in blue).
    #[test]
    fn the_first_bad_value_in_file_order_is_reported_whatever_the_run_length() {
        let dims = Dims::new(7, 11, 13).unwrap();
        let n = dims.cells();
        let mut raw = assorted_raw(n, 12);
        raw[900] = -2e30;
        raw[n + 17] = f64::NAN;
        raw[2 * n + 3] = f64::INFINITY;
        let bytes = image(dims, &raw);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.binary");
        std::fs::write(&path, &bytes).unwrap();
        let file = File::open(&path).unwrap();
        let (i, j, k) = dims.unflatten(900);
        for chunk in [1, 3, 7, 64, 901, 1001, IO_CHUNK_CELLS] {
            for e in [
                read_body(dims, &path, &file, chunk).unwrap_err(),
                read_body(dims, &path, &&bytes[12..], chunk).unwrap_err(),
            ] {
                match e {
                    MerlError::TooLarge {
                        bad:
                            BadValue {
                                channel: Channel::Red,
                                i: ei,
                                j: ej,
                                k: ek,
                                value,
                            },
                        index: 900,
                        ..
                    } => assert_eq!((ei, ej, ek, value), (i, j, k, -2e30)),
                    other => panic!("run of {chunk}: {other}"),
                }
            }
        }
        // With the red value fixed, the green NaN (earlier in the file than the blue
        // infinity) is next.
        raw[900] = 1.0;
        let bytes = image(dims, &raw);
        for chunk in [1, 7, 1001] {
            let e = read_body(dims, &path, &&bytes[12..], chunk).unwrap_err();
            assert!(
                matches!(
                    e,
                    MerlError::NonFinite {
                        bad: BadValue {
                            channel: Channel::Green,
                            ..
                        },
                        index: 17,
                        ..
                    }
                ),
                "{e}"
            );
        }
    }

    /// The buffers are sized, zeroed and false as asked, also when rounded up for huge
    /// pages (the MERL sizes) and when not (small ones).
    #[test]
    fn table_buffers_have_the_asked_length_and_start_empty() {
        for n in [1, 1001, Dims::MERL.cells()] {
            let raw = alloc_raw(n);
            assert_eq!(raw.len(), 3 * n);
            assert!(raw.iter().all(|x| x.to_bits() == 0));
            let mask = alloc_mask(n);
            assert_eq!(mask.len(), n);
            assert!(mask.iter().all(|v| !v));
            let exact = crate::table::zeroed_f64_exact(n);
            assert_eq!((exact.len(), exact.capacity()), (n, n));
            assert!(exact.iter().all(|x| x.to_bits() == 0));
        }
    }

    #[test]
    fn failing_body_leaves_old_file_and_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.binary");
        std::fs::write(&p, b"old contents").unwrap();
        let err = atomic_write(&p, |f| {
            f.write_all(b"half of the new")?;
            Err(io::Error::other("disk full (simulated)"))
        })
        .unwrap_err();
        assert!(matches!(
            err,
            MerlError::Io {
                action: "writing",
                ..
            }
        ));
        assert!(err.to_string().contains("t.binary"), "{err}");
        assert_eq!(std::fs::read(&p).unwrap(), b"old contents");
        assert!(leftovers(dir.path()).is_empty());
    }

    #[test]
    fn successful_write_replaces_and_cleans_up() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.binary");
        std::fs::write(&p, b"old").unwrap();
        atomic_write(&p, |f| f.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        assert!(leftovers(dir.path()).is_empty());
    }
}
