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
//! - [`compare`]: two representations of a material (tables, models, neural BRDFs)
//!   against each other: every loss, the largest relative differences and where they
//!   are, the render pair and its difference images;
//! - [`mitsuba`]: the cross-check against Mitsuba 3's `diffuse` and `roughconductor`
//!   (case generation, the JSON batch exchanged with `python/mitsuba_eval.py`, the
//!   comparison and its tolerances).
//!
//! Every report serialises with serde (the CLI's `--json`) and renders as text
//! ([`std::fmt::Display`] / `to_text()`), with a verdict per check and the thresholds
//! used. The thresholds, the cases and the measured figures are documented in
//! `docs/validation.md`.
//!
//! ```
//! use brdfkit_validate::{Verdict, check_model};
//! let phong = brdfkit_models::from_json_str(
//!     r#"{"model": "phong", "params": {"k_d": 0.2, "k_s": 0.5, "n": 10}}"#,
//! )?;
//! let report = check_model(phong.as_ref());
//! assert!(!report.passed);
//! assert_eq!(report.reciprocity.verdict, Verdict::Fail);
//! println!("{report}"); // text; serde_json::to_string(&report) for JSON
//! # Ok::<(), brdfkit_core::ModelError>(())
//! ```
//!
//! ```no_run
//! use brdfkit_validate::{check_table, fit_quality, fitted_from_json};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let table = brdfkit_merl::MerlTable::read("gold-metallic-paint.binary")?;
//! println!("{}", check_table(&table));
//! let fit: serde_json::Value = serde_json::from_str(&std::fs::read_to_string("fit.json")?)?;
//! let report = fit_quality(&table, &fitted_from_json(&fit)?)?;
//! println!("{}", serde_json::to_string_pretty(&report)?);
//! # Ok(()) }
//! ```

#![warn(missing_docs)]

pub mod compare;
pub mod html;
pub mod mitsuba;
pub mod physical;
pub mod quality;
pub mod report;
mod rings;
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
