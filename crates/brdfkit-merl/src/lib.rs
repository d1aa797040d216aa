//! The MERL binary BRDF table: read, write, look up, resample, integrate.
//!
//! A [`MerlTable`] holds an isotropic BRDF sampled on the (θh, θd, φd) grid of
//! Matusik et al., "A Data-Driven Reflectance Model" (SIGGRAPH 2003), in the binary
//! format of the MERL database: three little-endian int32 dims, then three float64
//! channel planes. The 90 × 90 × 180 MERL grid is [`Dims::MERL`]; other dims are read,
//! written, looked up and resampled the same way, with the mappings scaled to them.
//!
//! - [`grid`]: dims, the reference bin mapping (bit-identical to `BRDFRead.cpp`),
//!   continuous index coordinates, cell angles, cell solid-angle weights;
//! - [`MerlTable::read`] / [`MerlTable::write`] (atomic) / [`MerlTable::from_bytes`] /
//!   [`MerlTable::to_bytes`], with typed errors ([`MerlError`]);
//! - lookups: [`MerlTable::nearest`] (the reference), [`MerlTable::interpolated`]
//!   (multilinear), and batches in parallel ([`MerlTable::lookup_batch`]);
//! - resampling: [`MerlTable::from_brdf`], [`MerlTable::resample`], the valid-cell view
//!   ([`MerlTable::valid_cells`], [`MerlTable::cell_batch`]);
//! - statistics: [`MerlTable::stats`], [`MerlTable::albedo`].
//!
//! The format, the mappings, their round-off traps and worked examples are in
//! `docs/merl-format.md`.

#![warn(missing_docs)]

pub mod cells;
pub mod error;
pub mod grid;
mod io;
pub mod lookup;
#[cfg(unix)]
pub mod mapped;
pub mod resample;
pub mod stats;
pub mod table;

pub use cells::{CellDirections, CellRuns, TableCells};
pub use error::{BadValue, ByteCount, Channel, MerlError, TableError};
pub use grid::{
    Dims, DimsError, IO_CHUNK_CELLS, cell_weight, phi_d_angle, phi_d_bin, phi_d_coord, snap_coord,
    theta_d_angle, theta_d_bin, theta_d_coord, theta_h_angle, theta_h_bin, theta_h_coord,
};
pub use io::{TablePlanes, atomic_write};
pub use lookup::{BATCH_RUN, Lookup, PairsError};
#[cfg(unix)]
pub use mapped::MappedF64;
pub use resample::{Cell, CellBatch, PresentCell, cell_directions};
pub use stats::{AlbedoSample, ChannelStats, Quadrature, TableStats, gauss_legendre_01};
pub use table::{MAX_ABS_RAW, MISSING_RAW, MerlTable, SCALES, zeroed_f64, zeroed_f64_exact};
