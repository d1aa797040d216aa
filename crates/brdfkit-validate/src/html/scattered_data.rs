//! The data of the report on scattered data ([`super::scattered`]): what
//! `report.json` holds and the page ([`super::scattered_page`]) draws.

use super::renders::RenderSet;
use super::{ModelSummary, Origin, Timings};
use crate::physical::PhysicalReport;
use brdfkit_core::Rgb;
use brdfkit_fit::{FitConfig, FitRecord, InputInfo, Weighting};
use serde::{Deserialize, Serialize};

/// Width of the residual bands (degrees).
pub const BAND_DEG: f64 = 5.0;

/// At most this many samples are drawn in each scatter chart (every k-th, in the
/// input's order; the page says how many of how many).
pub const MAX_PLOTTED: usize = 4000;

/// One band of a residual profile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Band {
    /// Lower edge (degrees).
    pub lo_deg: f64,
    /// Samples in the band.
    pub samples: usize,
    /// Weighted mean over the band's samples and channels of log10(f_model /
    /// f_measured) (channels where the measurement is 0 left out; a model value of 0
    /// counts as [`LOG_RATIO_FLOOR`](super::analysis::LOG_RATIO_FLOOR)); `None` for an empty band.
    pub mean_log10_ratio: Option<f64>,
}

/// Everything measured about one model on the samples.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScatteredModel {
    /// The model's label.
    pub label: String,
    /// Fitted here or given.
    pub origin: Origin,
    /// The residual profile over θh.
    pub by_theta_h: Vec<Band>,
    /// The residual profile over θd.
    pub by_theta_d: Vec<Band>,
    /// The physical checks (empty when not run).
    pub physical: Vec<PhysicalReport>,
    /// The fit's record, when fitted here.
    pub record: Option<FitRecord>,
    /// Model values at the plotted samples (the scatter charts), per channel.
    #[serde(skip)]
    pub plotted: Vec<Rgb>,
}

/// The summary of a report on scattered data (what `--json` prints).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScatteredSummary {
    /// The input: file, kind, counts.
    pub input: InputInfo,
    /// The loss the fits minimised, when known.
    pub loss_optimised: Option<String>,
    /// The weighting of the losses.
    pub weighting: Weighting,
    /// What the spheres show as measured: the `.bsdf` file's own evaluation, or `None`
    /// (scattered samples: no measured sphere).
    pub measured_sphere: Option<String>,
    /// Whether anything was resampled: always false (the page says so).
    pub resampled: bool,
    /// One line per model.
    pub models: Vec<ModelSummary>,
}

/// The report's data (`report.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ScatteredData {
    /// The summary.
    pub summary: ScatteredSummary,
    /// The fit configuration, when something was fitted.
    pub fit_config: Option<FitConfig>,
    /// Per model, everything measured.
    pub models: Vec<ScatteredModel>,
    /// Samples drawn in each scatter chart.
    pub plotted: usize,
    /// The measured values of the plotted samples.
    #[serde(skip)]
    pub plotted_measured: Vec<Rgb>,
    /// The sphere renders (a `.bsdf` only).
    pub renders: Vec<RenderSet>,
    /// Wall times.
    pub timings: Timings,
}
