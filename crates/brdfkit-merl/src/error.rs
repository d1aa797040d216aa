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
    #[error(
        "{}: truncated: dims {dims} need {expected} bytes (12 + 3 x {cells} x 8), the file has {actual}",
        path.display()
    )]
    Truncated {
        /// The file.
        path: PathBuf,
        /// The grid dims.
        dims: crate::Dims,
        /// Cells of the grid.
        cells: usize,
        /// What the dims require.
        expected: u64,
        /// What was found.
        actual: u64,
    },

    /// More bytes than the header's dims account for.
    #[error(
        "{}: {} trailing bytes: dims {dims} need {expected} bytes (12 + 3 x {cells} x 8), the file has {actual}",
        path.display(), actual - expected
    )]
    TrailingBytes {
        /// The file.
        path: PathBuf,
        /// The grid dims.
        dims: crate::Dims,
        /// Cells of the grid.
        cells: usize,
        /// What the dims require.
        expected: u64,
        /// What was found.
        actual: u64,
    },

    /// A NaN or infinite value (the first one in file order).
    #[error(
        "{}: non-finite value {value} in the {channel} channel at cell (θh {i}, θd {j}, φd {k}) (flat index {index})",
        path.display()
    )]
    NonFinite {
        /// The file.
        path: PathBuf,
        /// The colour channel.
        channel: Channel,
        /// θh index of the cell.
        i: usize,
        /// θd index of the cell.
        j: usize,
        /// φd index of the cell.
        k: usize,
        /// Flat index of the cell.
        index: usize,
        /// The value.
        value: f64,
    },

    /// A value beyond ±[`crate::MAX_ABS_RAW`] (the first one in file order).
    #[error(
        "{}: value {value:e} in the {channel} channel at cell (θh {i}, θd {j}, φd {k}) (flat index {index}) exceeds 1e30 in magnitude: corrupt data, not a measurement",
        path.display()
    )]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// The colour channel.
        channel: Channel,
        /// θh index of the cell.
        i: usize,
        /// θd index of the cell.
        j: usize,
        /// φd index of the cell.
        k: usize,
        /// Flat index of the cell.
        index: usize,
        /// The offending value.
        value: f64,
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
    #[error("non-finite value {value} in the {channel} channel at cell ({i}, {j}, {k})")]
    NonFinite {
        /// The colour channel.
        channel: Channel,
        /// θh index of the cell.
        i: usize,
        /// θd index of the cell.
        j: usize,
        /// φd index of the cell.
        k: usize,
        /// The offending value.
        value: f64,
    },
    /// A value whose raw form would exceed ±[`crate::MAX_ABS_RAW`].
    #[error(
        "value {value:e} in the {channel} channel at cell ({i}, {j}, {k}) exceeds 1e30 in magnitude"
    )]
    TooLarge {
        /// The colour channel.
        channel: Channel,
        /// θh index of the cell.
        i: usize,
        /// θd index of the cell.
        j: usize,
        /// φd index of the cell.
        k: usize,
        /// The offending value.
        value: f64,
    },
    /// A negative physical value: it would be stored as a negative raw value, which the
    /// format reserves for missing samples. Use `None` for a missing cell.
    #[error(
        "negative value {value} in the {channel} channel at cell ({i}, {j}, {k}): negative raw values mean 'missing'; give None instead"
    )]
    Negative {
        /// The colour channel.
        channel: Channel,
        /// θh index of the cell.
        i: usize,
        /// θd index of the cell.
        j: usize,
        /// φd index of the cell.
        k: usize,
        /// The offending value.
        value: f64,
    },
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
