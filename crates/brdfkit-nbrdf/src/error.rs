//! Typed errors: every variant names the file (or the network) it is about.

use brdfkit_merl::TableError;
use std::path::PathBuf;
use thiserror::Error;

/// What can go wrong reading an NBRDF or building a table from it.
#[derive(Debug, Error)]
pub enum NbrdfError {
    /// The path given to [`Nbrdf::load`](crate::Nbrdf::load) has no final component to
    /// use as the stem of the six file names (empty, `/`, or ending in `..`).
    #[error("{}: no material name: give DIR/NAME, the stem of the six <NAME>_fc1.npy ... files", path.display())]
    NoStem { path: PathBuf },

    /// One of the six files does not exist.
    #[error("{}: missing: an NBRDF needs all six files <NAME>_{{fc1,b1,fc2,b2,fc3,b3}}.npy", path.display())]
    Missing { path: PathBuf },

    /// A weight file that cannot be read as the `.npy` array it should be: unreadable,
    /// not `.npy`, too short for its shape, or another dtype than float32 (brdfkit-io's
    /// reader names the file and the problem).
    #[error(transparent)]
    Npy(#[from] brdfkit_io::npy::NpyError),

    /// The array's shape is not the one expected, or is inconsistent with the other
    /// layers (e.g. `fc2` must have as many rows as `fc1` has columns).
    #[error("{}: shape {}, expected {expected}", path.display(), fmt_shape(found))]
    Shape {
        path: PathBuf,
        found: Vec<u64>,
        expected: String,
    },

    /// A weight or bias is NaN or infinite (the first one in file order).
    #[error("{}: non-finite weight {value} at {}", path.display(), fmt_index(index))]
    NonFinite {
        path: PathBuf,
        /// Index of the value: `[row, column]` for a kernel, `[i]` for a bias.
        index: Vec<usize>,
        value: f32,
    },

    /// Building a table from the network failed (a value out of the format's range:
    /// possible only for weights that make exp(y) overflow).
    #[error("{name}: cannot build the table: {source}")]
    Table {
        name: String,
        #[source]
        source: TableError,
    },
}

use brdfkit_io::npy::fmt_shape;

fn fmt_index(i: &[usize]) -> String {
    let parts: Vec<String> = i.iter().map(usize::to_string).collect();
    format!("[{}]", parts.join(", "))
}
