//! brdfkit: measured BRDFs made practical.
//!
//! This facade re-exports the workspace crates so a user depends on one crate; it holds
//! no logic of its own:
//!
//! - [`core`]: directions, the local frame, Rusinkiewicz coordinates, [`core::Rgb`],
//!   the [`core::Brdf`] trait and the shared scattering math.
//! - [`merl`]: the MERL binary table format, lookup and resampling.
//! - [`models`]: the analytic BRDF models and their JSON contract.
//! - [`nbrdf`]: neural BRDFs (NBRDF) of measured materials as a source.
//! - [`rgl`]: the RGL-EPFL `.bsdf` measured format (Mitsuba tensor files), read,
//!   evaluated as Mitsuba 3's `measured` plugin and resampled to MERL tables.
//! - [`fit`]: fitting models to tables (losses, LM, multi-start, the fit record).
//! - [`synth`]: synthetic materials with known parameters (the `data-synthetic/` specs),
//!   i.e. [`fit::synth`].
pub use brdfkit_core as core;
pub use brdfkit_fit as fit;
pub use brdfkit_fit::synth;
pub use brdfkit_io as io;
pub use brdfkit_merl as merl;
pub use brdfkit_models as models;
pub use brdfkit_nbrdf as nbrdf;
pub use brdfkit_rgl as rgl;
