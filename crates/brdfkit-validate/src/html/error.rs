//! The report's errors, apart from the report so that the comparison (which renders
//! with the report's renderer) can name them without importing the report.

use crate::quality::QualityError;
use thiserror::Error;

/// Errors of the report.
#[derive(Debug, Error)]
pub enum ReportError {
    /// No model to report on.
    #[error("the report needs at least one fitted model")]
    NoModels,
    /// The fit-quality computation failed.
    #[error(transparent)]
    Quality(#[from] QualityError),
    /// A chart could not be drawn.
    #[error("chart: {0}")]
    Chart(String),
    /// A sphere could not be rendered.
    #[error("render: {0}")]
    Render(String),
    /// A fitted model's description could not be read back.
    #[error("{0}")]
    Model(String),
    /// The interactive panels could not be built (a model that cannot be tabulated).
    #[error("interactive panels: {0}")]
    Panels(String),
    /// An option out of range.
    #[error("report option `{option}`: {reason}")]
    Option {
        /// The option's name.
        option: &'static str,
        /// Why its value is refused.
        reason: String,
    },
}
