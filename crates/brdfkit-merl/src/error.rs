//! Typed errors: one variant per way a file or an in-memory table can be wrong.

use crate::grid::DimsError;
use std::fmt;
use std::path::PathBuf;
use thiserror::Error;

/// A colour channel of the table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Red, the first plane.
    Red,
    /// Green, the second plane.
    Green,
    /// Blue, the third plane.
    Blue,
}

impl Channel {
    /// The channels in file order.
    pub const ALL: [Channel; 3] = [Channel::Red, Channel::Green, Channel::Blue];

    /// 0, 1, 2 for R, G, B.
    pub const fn index(self) -> usize {
        self as usize
    }
}

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Channel::Red => "red",
            Channel::Green => "green",
            Channel::Blue => "blue",
        })
    }
}

/// A value that cannot go into a table, and where it sits: the one description of a
/// bad cell that the file reader and the in-memory constructors report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BadValue {
    /// The colour channel.
    pub channel: Channel,
    /// θh index of the cell.
    pub i: usize,
    /// θd index of the cell.
    pub j: usize,
    /// φd index of the cell.
    pub k: usize,
    /// The value.
    pub value: f64,
}

impl BadValue {
    /// "in the red channel at cell (θh i, θd j, φd k)", for messages.
    pub fn place(&self) -> String {
        format!(
            "in the {} channel at cell (θh {}, θd {}, φd {})",
            self.channel, self.i, self.j, self.k
        )
    }

    /// The first value of `raw` (three planes of `dims`' cells) that no table may hold,
    /// `ok` being the rule, and its flat index within its plane.
    pub(crate) fn first_in(
        raw: &[f64],
        dims: crate::Dims,
        ok: impl Fn(f64) -> bool,
    ) -> Option<(BadValue, usize)> {
        let at = raw.iter().position(|&v| !ok(v))?;
        Some(BadValue::at_flat(dims, at, raw[at]))
    }

    /// The bad value `value` at flat position `at` of three planes of `dims`' cells, and
    /// its flat index within its plane.
    pub(crate) fn at_flat(dims: crate::Dims, at: usize, value: f64) -> (BadValue, usize) {
        let n = dims.cells();
        let index = at % n;
        let (i, j, k) = dims.unflatten(index);
        let channel = Channel::ALL[at / n];
        (
            BadValue {
                channel,
                i,
                j,
                k,
                value,
            },
            index,
        )
    }
}

/// A body whose length disagrees with its header's dims: what they require and what
/// the file has.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ByteCount {
    /// The grid dims.
    pub dims: crate::Dims,
    /// Cells of the grid.
    pub cells: usize,
    /// What the dims require, bytes.
    pub expected: u64,
    /// What was found, bytes.
    pub actual: u64,
}

impl fmt::Display for ByteCount {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "dims {} need {} bytes (12 + 3 x {} x 8), the file has {}",
            self.dims, self.expected, self.cells, self.actual
        )
    }
}

/// Errors reading or writing a table file (or bytes given a name). Every message starts
/// with the file's path (or the name given to [`from_bytes`](crate::MerlTable::from_bytes)).
#[derive(Debug, Error)]
pub enum MerlError {
    /// Shorter than the 12-byte header.
    #[error("{}: {len} bytes is shorter than the 12-byte header", path.display())]
    TooShort {
        /// The file.
        path: PathBuf,
        /// Length of the file, bytes.
        len: u64,
    },

    /// The file is not a MERL table at all (text, a compressed archive, an image, a
    /// NumPy array): found from its first bytes before the dims are judged.
    #[error(
        "{}: not a MERL table: {what}, so its header dims {} x {} x {} are not plausible \
         (a MERL table starts with three little-endian int32 dims such as 90 90 180, then \
         3 x n float64)",
        path.display(), dims[0], dims[1], dims[2]
    )]
    NotMerl {
        /// The file.
        path: PathBuf,
        /// The dims its first 12 bytes would give.
        dims: [i64; 3],
        /// What the file is instead.
        what: String,
    },

    /// Dims ≤ 0, or so large the size overflows.
    #[error("{}: {source}", path.display())]
    Dims {
        /// The file.
        path: PathBuf,
        #[source]
        /// The underlying error.
        source: DimsError,
    },

    /// Fewer bytes than the header's dims require.
    #[error("{}: truncated: {size}", path.display())]
    Truncated {
        /// The file.
        path: PathBuf,
        /// What the dims require and what was found.
        size: ByteCount,
    },

    /// More bytes than the header's dims account for.
    #[error("{}: {} trailing bytes: {size}", path.display(), size.actual - size.expected)]
    TrailingBytes {
        /// The file.
        path: PathBuf,
        /// What the dims require and what was found.
        size: ByteCount,
    },

    /// A NaN or infinite value (the first one in file order).
    #[error(
        "{}: non-finite value {} {} (flat index {index})",
        path.display(), bad.value, bad.place()
    )]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// The value and its cell.
        bad: BadValue,
        /// Flat index of the cell.
        index: usize,
    },

    /// A value beyond ±[`crate::MAX_ABS_RAW`] (the first one in file order).
    #[error(
        "{}: value {:e} {} (flat index {index}) exceeds 1e30 in magnitude: corrupt data, not a measurement",
        path.display(), bad.value, bad.place()
    )]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// The value and its cell.
        bad: BadValue,
        /// Flat index of the cell.
        index: usize,
    },

    /// The path names a directory, not a table.
    #[error("{}: is a directory, not a table file", path.display())]
    IsDirectory {
        /// The file.
        path: PathBuf,
    },

    /// An I/O error while `action` (opening, reading, writing, renaming ...).
    #[error("{}: {action}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The step that failed.
        action: &'static str,
        #[source]
        /// The underlying error.
        source: std::io::Error,
    },
}

impl MerlError {
    /// The file (or name) the error is about.
    pub fn path(&self) -> &std::path::Path {
        match self {
            MerlError::TooShort { path, .. }
            | MerlError::NotMerl { path, .. }
            | MerlError::Dims { path, .. }
            | MerlError::Truncated { path, .. }
            | MerlError::TrailingBytes { path, .. }
            | MerlError::NonFinite { path, .. }
            | MerlError::TooLarge { path, .. }
            | MerlError::IsDirectory { path }
            | MerlError::Io { path, .. } => path,
        }
    }

    /// The error for a header that is not a MERL header, or None: its dims are not
    /// plausible (one outside 1..=[`PLAUSIBLE_DIM`]) and its bytes say what the file is
    /// instead (text, another format's signature). The header of any plausible grid
    /// has a zero high byte in every dim, so it is never text. Other implausible
    /// headers (negative dims, dims that overflow) are left to
    /// [`Dims::new`](crate::Dims::new) to judge.
    pub(crate) fn not_merl(header: &[u8; 12], path: &std::path::Path) -> Option<MerlError> {
        let dims: [i64; 3] = std::array::from_fn(|k| {
            i32::from_le_bytes(header[4 * k..4 * k + 4].try_into().expect("4 bytes")) as i64
        });
        if dims.iter().all(|d| (1..=PLAUSIBLE_DIM).contains(d)) {
            return None;
        }
        Some(MerlError::NotMerl {
            path: path.to_path_buf(),
            dims,
            what: not_merl_what(header)?,
        })
    }

    /// The error for a raw value no table may hold: beyond ±1e30 if finite, else not
    /// finite.
    pub(crate) fn bad_raw(path: &std::path::Path, (bad, index): (BadValue, usize)) -> Self {
        let path = path.to_path_buf();
        if bad.value.is_finite() {
            MerlError::TooLarge { path, bad, index }
        } else {
            MerlError::NonFinite { path, bad, index }
        }
    }

    pub(crate) fn io(path: &std::path::Path, action: &'static str, source: std::io::Error) -> Self {
        MerlError::Io {
            path: path.to_path_buf(),
            action,
            source,
        }
    }
}

/// The largest dim a header may plausibly hold: 2^24 bins along one axis (MERL has
/// 90 × 90 × 180; one such axis alone would make a 400 MB table).
pub const PLAUSIBLE_DIM: i64 = 1 << 24;

/// Signatures of formats mistaken for tables: (first bytes, what the file is).
const SIGNATURES: [(&[u8], &str); 5] = [
    (b"\x1f\x8b", "it is gzip-compressed (decompress it first)"),
    (
        b"PK\x03\x04",
        "it is a zip archive (extract the table first)",
    ),
    (
        b"\x93NUMPY",
        "it is a NumPy .npy array (a neural BRDF's weights are read as an NBRDF, not a table)",
    ),
    (b"\x89PNG", "it is a PNG image"),
    (b"v/1\x01", "it is an OpenEXR image"),
];

/// What a 12-byte header is when it is not a MERL header: another format by its
/// signature, or text (UTF-8 without control characters other than whitespace).
fn not_merl_what(header: &[u8; 12]) -> Option<String> {
    if let Some((_, what)) = SIGNATURES.iter().find(|(sig, _)| header.starts_with(sig)) {
        return Some((*what).to_string());
    }
    let text = match std::str::from_utf8(header) {
        Ok(s) => s,
        // A multi-byte character cut by the 12th byte.
        Err(e) if e.error_len().is_none() => {
            std::str::from_utf8(&header[..e.valid_up_to()]).expect("the valid prefix")
        }
        Err(_) => return None,
    };
    let printable = |c: char| !c.is_control() || matches!(c, '\t' | '\n' | '\r');
    (!text.is_empty() && text.chars().all(printable)).then(|| {
        format!(
            "it starts with text (`{}`)",
            text.trim_end().escape_default()
        )
    })
}

/// Errors building or changing a table in memory.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum TableError {
    /// A raw buffer or plane of the wrong length.
    #[error("expected {expected} values for dims {dims}, got {actual}")]
    Length {
        /// The grid dims.
        dims: crate::Dims,
        /// What the dims require.
        expected: usize,
        /// What was found.
        actual: usize,
    },
    /// A NaN or infinite value.
    #[error("non-finite value {} {}", .0.value, .0.place())]
    NonFinite(BadValue),
    /// A value whose raw form would exceed ±[`crate::MAX_ABS_RAW`].
    #[error("value {:e} {} exceeds 1e30 in magnitude", .0.value, .0.place())]
    TooLarge(BadValue),
    /// A negative physical value: it would be stored as a negative raw value, which the
    /// format reserves for missing samples. Use `None` for a missing cell.
    #[error(
        "negative value {} {}: negative raw values mean 'missing'; give None instead",
        .0.value, .0.place()
    )]
    Negative(BadValue),
    /// A cell index outside the grid.
    #[error("cell ({i}, {j}, {k}) is outside the grid {dims}")]
    OutOfRange {
        /// The grid dims.
        dims: crate::Dims,
        /// θh index of the cell.
        i: usize,
        /// θd index of the cell.
        j: usize,
        /// φd index of the cell.
        k: usize,
    },
}

impl TableError {
    /// The error for a raw value no table may hold: beyond ±1e30 if finite, else not
    /// finite.
    pub(crate) fn bad_raw(bad: BadValue) -> Self {
        if bad.value.is_finite() {
            TableError::TooLarge(bad)
        } else {
            TableError::NonFinite(bad)
        }
    }
}
