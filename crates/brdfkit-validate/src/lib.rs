//! Validation of brdfkit's models and tables: physical checks with a report, fit
//! quality, and the Mitsuba 3 cross-check.
//!
//! - [`physical`]: [`check_model`] runs non-negativity, reciprocity, energy
//!   (directional albedo by converged quadrature), isotropy and finiteness checks on a
//!   [`brdfkit_core::Model`] and returns a [`PhysicalReport`];
//! - [`table`]: [`check_table`] runs the checks that make sense on a measured
//!   [`brdfkit_merl::MerlTable`] (coverage, negative and non-finite scans, the albedo
//!   curve) and returns a [`TableReport`];
//! - [`quality`]: [`fit_quality`] measures a fitted model against a table (every loss
//!   of the fitter, per channel and overall, by θh and θd band; relative-error
//!   percentiles; the albedo of fit and table; held-out validation) and returns a
//!   [`QualityReport`];
//! - [`mitsuba`]: the cross-check against Mitsuba 3's `diffuse` and `roughconductor`
//!   (case generation, the JSON batch exchanged with `python/mitsuba_eval.py`, the
//!   comparison and its tolerances).
//!
//! Every report serialises with serde (the CLI's `--json`) and renders as text
//! ([`std::fmt::Display`] / `to_text()`), with a verdict per check and the thresholds
//! used. The thresholds, the cases and the measured figures are documented in
//! `docs/validation.md`.

pub mod mitsuba;
pub mod physical;
pub mod quality;
pub mod report;
pub mod table;

pub use physical::{
    CheckOptions, PhysicalReport, PoleChoice, QuadPole, Thresholds, check_model, check_model_with,
};
pub use quality::{
    HeldOutOptions, HeldOutReport, QualityError, QualityOptions, QualityReport, fit_quality,
    fit_quality_with, fitted_from_json, held_out,
};
pub use report::{PairAt, Verdict};
pub use table::{TableCheckOptions, TableReport, check_table, check_table_with};
