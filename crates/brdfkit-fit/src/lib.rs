//! Nonlinear least-squares fitting of analytic BRDF models to measured tables.
//!
//! A fit takes the valid cells of a table ([`FitData`]), a model family with its fixed
//! structural choices (any [`brdfkit_core::Model`], normally from
//! [`brdfkit_models::from_json`] or [`brdfkit_models::default_model`]), a loss and
//! options ([`FitConfig`]), and returns the fitted parameters in the model JSON contract
//! plus a [`FitRecord`]: every loss per channel and overall on the fitted cells and on
//! the full table, iterations, cost and Jacobian evaluations, wall time, the
//! termination reason and every start tried.
//!
//! ```no_run
//! use brdfkit_fit::{FitConfig, FitData, Loss, fit};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let table = brdfkit_merl::MerlTable::read("gold-metallic-paint.binary")?;
//! let data = FitData::from_table(&table)?;
//! let model = brdfkit_models::default_model("lambert")?;
//! let cfg = FitConfig::default().loss(Loss::Cbrt).starts(4)?;
//! let out = fit(model.as_ref(), &data, &cfg, None)?;
//! println!("{}", out.fitted.to_json());
//! println!("{}", serde_json::to_string_pretty(&out.record)?);
//! # Ok(()) }
//! ```
//!
//! Modules:
//! - [`loss`]: the four losses (`l2`, `cosine`, `cbrt`, `log`) and the cell weights;
//! - [`reparam`]: the smooth log / logit reparameterisation that enforces bounds;
//! - [`data`]: the cells, their cutoff and stratified subsampling;
//! - [`samples`]: scattered samples (a lab's rows, a `.bsdf`'s measured points) as cells;
//! - [`problem`]: residuals, the normal equations in one parallel pass, argmin traits;
//! - [`lm`]: Levenberg-Marquardt and Gauss-Newton as argmin solvers;
//! - [`starts`]: the multi-start scheme;
//! - [`config`], [`record`]: options, the JSON record (progress events are
//!   [`brdfkit_core::progress`]'s, re-exported here: [`Event`], [`Observe`]);
//! - [`synth`]: synthetic materials with known parameters: the `data-synthetic/` spec
//!   format and its tables, cell sets from a model, seeded noise (tests, benchmarks);
//! - [`score`](mod@score): every loss of given parameters on a fit's cells, without fitting;
//! - [`families`]: model lists with structural choices and fit settings as the command
//!   line gives them, fitted family by family;
//! - [`target`]: fits for a renderer (`--for mitsuba|pbrt|gltf`): its configurations,
//!   each fitted, the best by loss;
//! - [`batch`]: the batch engine (every table of a database, resumable, sharded,
//!   cancellable between tables).
//!
//! The formulas, sources and measured performance are in `docs/fitting.md`.

#![warn(missing_docs)]

pub mod batch;
pub mod config;
pub mod data;
pub mod energy;
pub mod error;
pub mod families;
mod fit;
mod fitted;
pub mod input;
pub mod lm;
pub mod loss;
mod observer;
pub mod problem;
pub mod record;
pub mod reparam;
pub mod samples;
pub mod score;
pub mod starts;
pub mod synth;
pub mod target;

pub use brdfkit_core::progress::{Event, FitPlan, IterEvent, Observe, StartDone};
pub use config::{CellFilter, FitConfig, FullIters, Sharing, SolverKind};
pub use data::FitData;
pub use data::SampleInput;
pub use error::FitError;
pub use fit::{FitResult, StageTimes, fit, fit_table, prepare, resolve_free};
pub use fitted::Fitted;
pub use input::{BsdfInput, InputError, InputInfo, Measured, MeasuredSide};
pub use lm::{GaussNewtonLs, LevenbergMarquardt, Stall, Tolerances};
pub use loss::{ChannelLoss, Loss, LossReport, LossSet, Robust, RobustKind, Weighting};
pub use problem::{FitProblem, NormalEq, NormalEquations, evaluate_losses, evaluate_losses_of};
pub use record::{
    FitRecord, ParamRecord, RobustRecord, StageIterations, StartRecord, WarmUpRecord,
};
pub use samples::{Sample, SampleError, SampleProblem, SamplesFileError};
pub use score::{Score, ScoreError, losses_of_values, score};
