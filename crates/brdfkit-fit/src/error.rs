//! Typed errors of the fitter.

use brdfkit_core::ModelError;
use thiserror::Error;

/// Everything that can stop a fit before or while it runs. A fit that runs but does
/// not converge is not an error: its record says why it stopped.
#[derive(Debug, Error)]
pub enum FitError {
    /// A configuration value outside its allowed range.
    #[error("fit option `{option}` = {value}: {reason}")]
    InvalidOption {
        /// The option.
        option: &'static str,
        /// The value given.
        value: String,
        /// What the optimiser reported.
        reason: String,
    },
    /// A parameter name (to free or fix) the model does not have.
    #[error("model `{model}` has no parameter `{name}` (parameters: {known})")]
    UnknownParam {
        /// The model.
        model: String,
        /// The name given.
        name: String,
        /// The parameters the model has.
        known: String,
    },
    /// The model rejected a parameter vector or description.
    #[error("model `{model}`: {source}")]
    Model {
        /// The model.
        model: String,
        #[source]
        /// What the model rejected.
        source: ModelError,
    },
    /// Input arrays of inconsistent length or with invalid entries.
    #[error("fit data: {0}")]
    Data(String),
    /// No cell is left to fit (an empty table, or the cutoff removed all).
    #[error("fit data: no cells left to fit ({0})")]
    NoCells(String),
    /// Every free parameter is fixed: there is nothing to fit.
    #[error("model `{0}`: no free parameters (all fixed)")]
    NothingToFit(String),
    /// The optimiser itself failed (an argmin error, not a non-convergence).
    #[error("solver `{solver}` failed on start {start}: {reason}")]
    Solver {
        /// The solver.
        solver: String,
        /// Index of the start.
        start: usize,
        /// What the optimiser reported.
        reason: String,
    },
}
