//! Reading and writing the binary format.
//!
//! Layout: three little-endian int32 dims (θh, θd, φd), then 3 × n little-endian
//! float64, whole channel planes R, G, B, each in the order `k + nφd · (j + nθd · i)`.
//!
//! Reading checks the header against the file's length (from its metadata) **before**
//! allocating, so a corrupt header cannot make the reader allocate more than the file
//! holds. The body is then read in parallel (rayon) by positional reads of [`CHUNK`]
//! cells per channel into small buffers that stay in cache, and converted, validated
//! (finite values, the missing mask) and stored from there: one pass over the data.
//!
//! Writing goes to a temporary file in the destination directory, synced, then renamed
//! over the destination: a reader sees the old file or the new one, never a partial
//! one, and a failed write removes its temporary file and leaves the old file intact.

use crate::error::{Channel, MerlError};
use crate::grid::{Dims, HEADER_BYTES};
use crate::table::{MerlTable, acceptable_raw, alloc_raw, raw_valid};
use byteorder::{ByteOrder, LittleEndian};
use rayon::prelude::*;
use std::fs::File;
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

/// Cells per parallel task: each task reads this many values of each channel (3 × 64
/// KiB) into a buffer that stays in L2, converts and validates them from there, and
/// writes them to the table. 64 KiB stays under glibc's mmap threshold, so the
/// per-task buffers come from the heap rather than fresh (faulting) pages.
pub const CHUNK: usize = 8 * 1024;

/// Where the body's bytes come from: a file read positionally (parallel tasks share it)
/// or a byte slice.
trait Source: Sync {
    /// The `buf.len()` bytes at byte offset `off` of the body (read into `buf` if they
    /// are not already in memory).
    fn bytes<'a>(&'a self, off: usize, buf: &'a mut [u8]) -> io::Result<&'a [u8]>;
}

impl Source for [u8] {
    fn bytes<'a>(&'a self, off: usize, buf: &'a mut [u8]) -> io::Result<&'a [u8]> {
        Ok(&self[off..off + buf.len()])
    }
}

#[cfg(unix)]
impl Source for File {
    fn bytes<'a>(&'a self, off: usize, buf: &'a mut [u8]) -> io::Result<&'a [u8]> {
        use std::os::unix::fs::FileExt;
        self.read_exact_at(buf, HEADER_BYTES + off as u64)?;
        Ok(buf)
    }
}

/// The dims of a header (positive, within int32, size representable).
fn header_dims(header: &[u8; 12], path: &Path) -> Result<Dims, MerlError> {
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
    let expected = dims.file_bytes();
    let (cells, path) = (dims.cells(), path.to_path_buf());
    if len < expected {
        return Err(MerlError::Truncated {
            path,
            dims,
            cells,
            expected,
            actual: len,
        });
    }
    if len > expected {
        return Err(MerlError::TrailingBytes {
            path,
            dims,
            cells,
            expected,
            actual: len,
        });
    }
    Ok(())
}

/// Parses the header and checks it against the total length in bytes.
fn parse_header(header: &[u8; 12], len: u64, path: &Path) -> Result<Dims, MerlError> {
    let dims = header_dims(header, path)?;
    check_length(dims, len, path)?;
    Ok(dims)
}

/// Reads a table from a stream without a known length (a pipe, a device): the header,
/// then the body through `take`, so the buffer grows with the bytes actually present
/// and never beyond what the header claims; any excess is counted, not stored.
fn read_stream(mut r: impl Read, path: &Path) -> Result<MerlTable, MerlError> {
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
    read_body(dims, path, &body[..])
}

/// Reads the body (3 planes of little-endian f64) from `src` into a new table, in
/// parallel over runs of [`CHUNK`] cells, validating in the same pass: each task takes
/// the same cells from the three planes, so it alone owns their mask entries. The first
/// non-finite value in file order is an error (searched for only when a task saw one).
fn read_body(
    dims: Dims,
    path: &Path,
    src: &(impl Source + ?Sized),
) -> Result<MerlTable, MerlError> {
    let n = dims.cells();
    let mut raw = alloc_raw(n);
    let mut valid = vec![false; n];
    let (r, gb) = raw.split_at_mut(n);
    let (g, b) = gb.split_at_mut(n);
    let (n_valid, finite) = r
        .par_chunks_mut(CHUNK)
        .zip(g.par_chunks_mut(CHUNK))
        .zip(b.par_chunks_mut(CHUNK))
        .zip(valid.par_chunks_mut(CHUNK))
        .enumerate()
        .map_init(
            || vec![0u8; 8 * CHUNK],
            |buf, (q, (((r, g), b), v))| -> io::Result<(usize, bool)> {
                let mut finite = true;
                for (c, dst) in [r, g, b].into_iter().enumerate() {
                    let off = 8 * (c * n + q * CHUNK);
                    let bytes = src.bytes(off, &mut buf[..8 * dst.len()])?;
                    // Non-short-circuiting so the loop vectorises.
                    for ((d, s), ok) in dst.iter_mut().zip(bytes.chunks_exact(8)).zip(v.iter_mut())
                    {
                        let x = f64::from_le_bytes(s.try_into().expect("8 bytes"));
                        // One comparison rejects NaN, ±inf and corrupt magnitudes alike.
                        finite &= acceptable_raw(x);
                        *d = x;
                        // A cell is valid when no channel is negative (−0.0 is not).
                        *ok = (c == 0 || *ok) & (x >= 0.0);
                    }
                }
                Ok((v.iter().filter(|&&x| x).count(), finite))
            },
        )
        .try_reduce(|| (0, true), |a, b| Ok((a.0 + b.0, a.1 & b.1)))
        .map_err(|e| MerlError::io(path, "reading", e))?;
    if !finite {
        let at = raw
            .iter()
            .position(|&x| !acceptable_raw(x))
            .expect("a task saw one");
        let (c, index) = (at / n, at % n);
        let (i, j, k) = dims.unflatten(index);
        let (path, channel, value) = (path.to_path_buf(), Channel::ALL[c], raw[at]);
        return Err(if value.is_finite() {
            MerlError::TooLarge {
                path,
                channel,
                i,
                j,
                k,
                index,
                value,
            }
        } else {
            MerlError::NonFinite {
                path,
                channel,
                i,
                j,
                k,
                index,
                value,
            }
        });
    }
    debug_assert!(
        valid
            .iter()
            .enumerate()
            .all(|(x, &v)| v == raw_valid(raw[x], raw[n + x], raw[2 * n + x]))
    );
    Ok(MerlTable {
        dims,
        raw,
        valid,
        n_valid,
    })
}

impl MerlTable {
    /// Reads a table file. Every failure is a [`MerlError`] naming the file.
    pub fn read(path: impl AsRef<Path>) -> Result<MerlTable, MerlError> {
        let path = path.as_ref();
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
            return read_stream(file, path);
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
            read_body(dims, path, &file)
        }
        #[cfg(not(unix))]
        {
            // No positional reads: the body in one buffer (its size was checked
            // against the file's length above), then the same conversion.
            let mut bytes = vec![0u8; len as usize - 12];
            file.read_exact(&mut bytes)
                .map_err(|e| MerlError::io(path, "reading", e))?;
            read_body(dims, path, &bytes[..])
        }
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
        read_body(dims, path, &bytes[HEADER_BYTES as usize..])
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
            let mut buf = vec![0u8; 8 * CHUNK];
            for chunk in self.raw.chunks(CHUNK) {
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

/// Writes a file atomically: `body` writes into a temporary file created in the
/// destination's directory; the file is synced and renamed over `path`. A failure at any
/// step drops (and so deletes) the temporary file, leaving `path` as it was.
///
/// The new file takes the permissions of the file it replaces, or 0644 when there was
/// none (a temporary file is created 0600).
pub fn atomic_write(
    path: &Path,
    body: impl FnOnce(&mut File) -> io::Result<()>,
) -> Result<(), MerlError> {
    let dir: PathBuf = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut tmp = tempfile::Builder::new()
        .prefix(".brdfkit-merl-")
        .suffix(".tmp")
        .tempfile_in(&dir)
        .map_err(|e| MerlError::io(path, "creating a temporary file in its directory", e))?;
    body(tmp.as_file_mut()).map_err(|e| MerlError::io(path, "writing", e))?;
    let perms = match std::fs::metadata(path) {
        Ok(m) => Some(m.permissions()),
        Err(_) => default_permissions(),
    };
    if let Some(p) = perms {
        tmp.as_file()
            .set_permissions(p)
            .map_err(|e| MerlError::io(path, "setting permissions", e))?;
    }
    tmp.as_file()
        .sync_all()
        .map_err(|e| MerlError::io(path, "syncing", e))?;
    tmp.persist(path)
        .map_err(|e| MerlError::io(path, "renaming the temporary file into place", e.error))?;
    Ok(())
}

#[cfg(unix)]
fn default_permissions() -> Option<std::fs::Permissions> {
    use std::os::unix::fs::PermissionsExt;
    Some(std::fs::Permissions::from_mode(0o644))
}

#[cfg(not(unix))]
fn default_permissions() -> Option<std::fs::Permissions> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(".brdfkit-merl-"))
            .collect()
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
