//! The report's files and its plain-text lines: what `fit-brdf report` and `demo` write
//! and print, in one place.

use super::scattered::ScatteredReport;
use super::{FitReport, ModelFit, ModelSummary, Origin, ReportError};
use brdfkit_core::atomic::{FileSet, WriteError};
use brdfkit_fit::Fitted;
use brdfkit_fit::families::Outcome;
use std::path::{Path, PathBuf};

/// The page in the report's directory.
pub const HTML_FILE: &str = "index.html";
/// The report's data in its directory.
pub const JSON_FILE: &str = "report.json";

/// Writes DIR/report.json and DIR/index.html as one [`FileSet`]: both are staged whole
/// beside their destinations, then renamed into place; if the second rename fails the
/// first is rolled back, so DIR never holds half a report. DIR may exist. Returns the
/// page's and the data's paths.
fn write_pair(dir: &Path, json: &str, html: &str) -> Result<(PathBuf, PathBuf), WriteError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError {
        path: dir.to_owned(),
        step: "creating the output directory",
        source,
    })?;
    let (json_path, html_path) = (dir.join(JSON_FILE), dir.join(HTML_FILE));
    let mut set = FileSet::new();
    set.stage_bytes(&json_path, json.as_bytes())?;
    set.stage_bytes(&html_path, html.as_bytes())?;
    set.commit()?;
    Ok((html_path, json_path))
}

/// One line per given model: its label and its four losses (the fitted models' lines
/// come from the fitter's comparison).
fn given_losses(models: &[ModelSummary]) -> String {
    models
        .iter()
        .filter(|m| m.origin == Origin::Given)
        .map(|m| {
            let l = &m.losses;
            format!(
                "{}: cbrt {:.6e}, l2 {:.6e}, cosine {:.6e}, log {:.6e}\n",
                m.label, l.cbrt.overall, l.l2.overall, l.cosine.overall, l.log.overall
            )
        })
        .collect()
}

impl FitReport {
    /// Writes DIR/report.json and DIR/index.html as one [`FileSet`]: both are staged
    /// whole beside their destinations, then renamed into place; if the second rename
    /// fails the first is rolled back, so DIR never holds half a report. DIR may exist.
    /// Returns the page's and the data's paths.
    pub fn write_to(&self, dir: &Path) -> Result<(PathBuf, PathBuf), WriteError> {
        write_pair(dir, &self.to_json_pretty(), &self.html)
    }

    /// One line per given model: its label and its four losses.
    pub fn given_losses_text(&self) -> String {
        given_losses(&self.data.summary.models)
    }
}

/// A report on a table ([`FitReport`]) or on scattered data ([`ScatteredReport`]):
/// what `fit-brdf report` writes and prints, either way.
pub enum AnyReport {
    /// On a MERL table.
    Table(Box<FitReport>),
    /// On scattered data.
    Scattered(Box<ScatteredReport>),
}

impl AnyReport {
    /// Writes DIR/report.json and DIR/index.html; returns their paths (page, data).
    pub fn write_to(&self, dir: &Path) -> Result<(PathBuf, PathBuf), WriteError> {
        match self {
            AnyReport::Table(r) => r.write_to(dir),
            AnyReport::Scattered(r) => write_pair(dir, &r.to_json_pretty(), &r.html),
        }
    }

    /// The summary as pretty JSON (what `--json` prints).
    pub fn summary_json_pretty(&self) -> String {
        match self {
            AnyReport::Table(r) => r.summary_json_pretty(),
            AnyReport::Scattered(r) => r.summary_json_pretty(),
        }
    }

    /// One line per given model: its label and its four losses.
    pub fn given_losses_text(&self) -> String {
        match self {
            AnyReport::Table(r) => r.given_losses_text(),
            AnyReport::Scattered(r) => given_losses(&r.data.summary.models),
        }
    }

    /// The report's wall time (s).
    pub fn total_s(&self) -> f64 {
        match self {
            AnyReport::Table(r) => r.data.timings.total_s,
            AnyReport::Scattered(r) => r.data.timings.total_s,
        }
    }
}

impl ModelFit {
    /// A fitted family of the report, with its record.
    pub fn fitted(o: &Outcome) -> Result<ModelFit, ReportError> {
        Ok(ModelFit {
            label: o.label.clone(),
            fitted: o.fitted.clone(),
            record: Some(o.record.clone()),
            origin: Origin::Fitted,
        })
    }

    /// A given model (not fitted here), labelled with its family and its file.
    pub fn given(fitted: Fitted, file: &Path) -> ModelFit {
        let name = fitted.shared().map_or("per-channel", |m| m.name());
        ModelFit {
            label: format!("{name} (given: {})", file.display()),
            fitted,
            record: None,
            origin: Origin::Given,
        }
    }
}
