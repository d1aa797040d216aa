//! The fit-quality report: one self-contained HTML page (charts as inline SVG, renders
//! as embedded PNGs, no script or style from outside) and its JSON, for a measured
//! table and the models fitted to it.
//!
//! [`build_report`] computes, for every fitted model:
//! - every loss of the fitter over all valid cells ([`crate::fit_quality_with`]: overall, per
//!   channel, by θh and θd band, relative-error percentiles);
//! - θh slices of the table and the model at several θd (φd = 90° by default), per
//!   channel, on a log axis ([`analysis::Slice`]);
//! - a residual map over (θh, θd): the mean over φd and channels of
//!   log10(f_model / f_measured) on blocks of the grid ([`analysis::ResidualMap`]);
//! - spheres rendered with the table and with the model under a point light and a
//!   studio environment, same seed, and their difference ([`renders`]);
//! - the albedo a(θo) of the model and of the table ([`analysis::AlbedoCurves`]);
//! - the physical checks of the model ([`check_model_with`], with bounded options:
//!   [`ReportOptions::checks`]);
//! - the interactive panels (incidence plane, θh–θd slice, lit sphere, albedo at a chosen
//!   θo), drawn in the page from the table and every model embedded on a grid
//!   ([`interactive`]), with what the embedding costs against `fit-brdf eval`.
//!
//! The caller fits (the CLI's `fit-brdf report` and `demo` use `brdfkit_fit::fit`) and
//! writes the files; this module only computes and formats. A `.bsdf` file's measured
//! points and a user's scattered samples have no grid: their report is
//! [`build_scattered_report`] ([`scattered`]), which resamples nothing. Models can also be given
//! ([`Origin::Given`]: published parameters, another tool's fit): they are measured the
//! same way, labelled as given. What each section shows
//! and how to read it: `docs/report.md`.

pub mod analysis;
pub mod charts;
pub(crate) mod error;
mod files;
pub mod interactive;
mod page;
pub mod renders;
pub mod scattered;
mod scattered_data;
mod scattered_page;
mod style;

pub use error::ReportError;
pub use files::{AnyReport, HTML_FILE, JSON_FILE};
pub use scattered::{ScatteredReport, ScatteredSide, build_any_report, build_scattered_report};

use crate::physical::{CheckOptions, PhysicalReport, PoleChoice, check_model_with};
use crate::quality::{QualityError, QualityOptions, QualityReport, fit_quality_and_maps};
use analysis::{AlbedoCurves, ResidualMap, Slice};
use brdfkit_core::progress::{Event, Observe};
use brdfkit_fit::{FitConfig, FitData, FitRecord, Fitted, LossReport, Weighting};
use brdfkit_merl::MerlTable;
use rayon::prelude::*;
use renders::{Lighting, RenderOptions, RenderSet};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::sync::Arc;
use std::time::Instant;

/// Where a model of the report comes from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Origin {
    /// Fitted to the table (reports written before given models existed: all).
    #[default]
    Fitted,
    /// Given (published parameters, another tool's fit): reported, not fitted.
    Given,
}

/// One model of the report: fitted here, or given.
pub struct ModelFit {
    /// Its name in the report (`cook-torrance`).
    pub label: String,
    /// The model(s).
    pub fitted: Fitted,
    /// The fitter's record (fit time, iterations, starts), when it was fitted here.
    pub record: Option<FitRecord>,
    /// Fitted or given.
    pub origin: Origin,
}

/// What the report computes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReportOptions {
    /// The page's title.
    pub title: String,
    /// Cell weights of the losses.
    pub weighting: Weighting,
    /// θd of the slices (radians; the nearest bin edge is used).
    pub slice_theta_d: Vec<f64>,
    /// φd of the slices (radians).
    pub slice_phi_d: f64,
    /// θo of the albedo curves (radians).
    pub albedo_theta_o: Vec<f64>,
    /// At most this many blocks along θh and along θd in the residual maps.
    pub residual_max_bins: usize,
    /// The sphere renders; `None`: none.
    pub render: Option<RenderOptions>,
    /// The physical checks of each fitted model; `None`: not run.
    pub checks: Option<CheckOptions>,
}

/// The physical checks the report runs: the thresholds of [`CheckOptions::default`]
/// on a coarser set (dense grid in 6° steps × 12 azimuths, 5,000 random pairs, the
/// albedo at 0, 15, 30, 45, 60, 75, 85 and 89°), a quarter to a third of the full
/// check's cost; `fit-brdf check` runs the full set.
pub fn bounded_checks() -> CheckOptions {
    CheckOptions {
        dense_theta: 16,
        dense_phi: 12,
        random_pairs: 5_000,
        albedo_thetas: [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0]
            .iter()
            .map(|d: &f64| d.to_radians())
            .collect(),
        ..CheckOptions::default()
    }
}

impl Default for ReportOptions {
    /// Slices at θd = 1, 20, 45 and 70°, φd = 90°; albedo at θo = 0, 10, …, 80, 85°;
    /// residual maps on at most 45 × 45 blocks; default renders; [`bounded_checks`].
    fn default() -> Self {
        ReportOptions {
            title: "Fit-quality report".into(),
            weighting: Weighting::SolidAngle,
            slice_theta_d: [1.0f64, 20.0, 45.0, 70.0].map(f64::to_radians).to_vec(),
            slice_phi_d: 90f64.to_radians(),
            albedo_theta_o: [0.0f64, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0]
                .map(f64::to_radians)
                .to_vec(),
            residual_max_bins: 45,
            render: Some(RenderOptions::default()),
            checks: Some(bounded_checks()),
        }
    }
}

/// The table reported on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TableInfo {
    /// Its name (a file name).
    pub name: String,
    /// θh, θd, φd bins.
    pub dims: [usize; 3],
    /// Cells of the table.
    pub cells: usize,
    /// Cells holding a sample (not missing).
    pub valid_cells: usize,
}

/// One model's line of the summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelSummary {
    /// The model's label in the report's tables and charts.
    pub label: String,
    /// Fitted here or given.
    #[serde(default)]
    pub origin: Origin,
    /// The parameters in the JSON contract.
    pub params: Value,
    /// Every loss over all valid cells (overall and per channel).
    pub losses: LossReport,
    /// Fit wall time (s), when fitted here.
    pub fit_time_s: Option<f64>,
    /// Iterations of the fit, when fitted here.
    pub iterations: Option<u64>,
    /// Whether the fit converged, when fitted here.
    pub converged: Option<bool>,
    /// The physical checks' verdict (all channel models); `None` when not run.
    pub physical_passed: Option<bool>,
}

/// The summary: what `fit-brdf report --json` prints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReportSummary {
    /// The table reported on.
    pub table: TableInfo,
    /// The loss the fits minimised, when known.
    pub loss_optimised: Option<String>,
    /// The weighting the losses are measured with.
    pub weighting: Weighting,
    /// One line per model, in the report's order.
    pub models: Vec<ModelSummary>,
}

/// Everything measured about one model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelDetail {
    /// The model's label (as in [`ModelSummary::label`]).
    pub label: String,
    /// Fitted here or given.
    #[serde(default)]
    pub origin: Origin,
    /// Fit quality against the table.
    pub quality: QualityReport,
    /// One report for a shared model, three (R, G, B) for a per-channel fit; empty when
    /// the checks did not run.
    pub physical: Vec<PhysicalReport>,
    /// Wall time of the physical checks (s).
    pub physical_time_s: f64,
    /// The signed log-ratio map over (θh, θd).
    pub residual_map: ResidualMap,
    /// The fit's record, when fitted here.
    pub record: Option<FitRecord>,
}

/// Wall times of the report's parts (s).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Fit-quality measurements (since session 16 with the residual maps, which take
    /// the quality pass's values).
    pub quality_s: f64,
    /// The slices (the residual maps before session 16; the name is kept for the
    /// reports already written).
    pub slices_and_maps_s: f64,
    /// Albedo curves (the table's and the models' times added). The albedo, checks
    /// and renders run beside each other and beside the quality, the slices and the
    /// panels: each part's figure is its own wall time, and they overlap.
    pub albedo_s: f64,
    /// Physical checks.
    pub checks_s: f64,
    /// Sphere renders.
    pub renders_s: f64,
    /// The interactive panels' embedded grids and their precision.
    #[serde(default)]
    pub panels_s: f64,
    /// Building the HTML page.
    pub page_s: f64,
    /// The whole report.
    pub total_s: f64,
}

/// The JSON of the report (`report.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReportData {
    /// The summary (what `--json` prints).
    pub summary: ReportSummary,
    /// The fit configuration, when given.
    pub fit_config: Option<FitConfig>,
    /// The options the report was made with.
    pub options: ReportOptions,
    /// Per model, everything measured.
    pub models: Vec<ModelDetail>,
    /// The BRDF slices of the charts.
    pub slices: Vec<Slice>,
    /// The albedo curves of the table and the models.
    pub albedo: AlbedoCurves,
    /// The sphere renders, one set per lighting.
    pub renders: Vec<RenderSet>,
    /// What the interactive panels' embedding costs, per source (the table first).
    #[serde(default)]
    pub view_precision: Vec<interactive::SourcePrecision>,
    /// Wall times of the parts.
    pub timings: Timings,
}

/// The report: its data and its page.
pub struct FitReport {
    /// The report's data (`report.json`).
    pub data: ReportData,
    /// The self-contained HTML page.
    pub html: String,
}

impl ReportOptions {
    /// Refuses a value out of its domain, naming the setting ([`ReportError::Option`]):
    /// a caller can check its options before it fits anything.
    pub fn check(&self) -> Result<(), ReportError> {
        check_options(self)
    }
}

fn check_options(o: &ReportOptions) -> Result<(), ReportError> {
    let bad = |option, reason: &str| {
        Err(ReportError::Option {
            option,
            reason: reason.into(),
        })
    };
    let in_quarter = |v: &[f64]| {
        v.iter()
            .all(|x| x.is_finite() && (0.0..=std::f64::consts::FRAC_PI_2).contains(x))
    };
    if !in_quarter(&o.slice_theta_d) {
        return bad("slice_theta_d", "angles must lie in [0, π/2] radians");
    }
    if !(o.slice_phi_d.is_finite() && (0.0..=std::f64::consts::PI).contains(&o.slice_phi_d)) {
        return bad("slice_phi_d", "must lie in [0, π] radians");
    }
    if !in_quarter(&o.albedo_theta_o)
        || o.albedo_theta_o
            .iter()
            .any(|t| *t >= std::f64::consts::FRAC_PI_2)
    {
        return bad("albedo_theta_o", "angles must lie in [0, π/2) radians");
    }
    if o.residual_max_bins == 0 {
        return bad("residual_max_bins", "must be at least 1");
    }
    o.render.as_ref().map_or(Ok(()), RenderOptions::check)
}

/// The physical checks of a fitted model: one per channel model.
pub(crate) fn physical(f: &Fitted, o: &CheckOptions) -> Vec<PhysicalReport> {
    match f {
        Fitted::Shared(m) => vec![check_model_with(m.as_ref(), o)],
        Fitted::PerChannel(ms) => ms.iter().map(|m| check_model_with(m.as_ref(), o)).collect(),
    }
}

/// Builds the report of `fits` against `table`. `progress` receives a short line per
/// step (for a command line's stderr). `config` is the fit configuration, recorded and
/// shown when given.
///
/// Builds the table's cells and copies the table for the renders; a caller that holds
/// them already (the fitter's cells) saves both with [`build_report_from`].
pub fn build_report(
    table: &MerlTable,
    table_name: &str,
    fits: &[ModelFit],
    config: Option<&FitConfig>,
    o: &ReportOptions,
    progress: &dyn Observe,
) -> Result<FitReport, ReportError> {
    if fits.is_empty() {
        return Err(ReportError::NoModels);
    }
    check_options(o)?;
    let cells = FitData::from_table(table).map_err(QualityError::from)?;
    build_report_from(
        Arc::new(table.clone()),
        cells,
        table_name,
        fits,
        config,
        o,
        progress,
    )
}

/// [`build_report`] on a shared table and its cells (`cells` must be
/// [`FitData::from_table`] of `table`: the cells a fit of the whole table sees, so the
/// fitter's own can be handed on).
///
/// The cells' geometry is built once and shared by every model and section (losses,
/// bands, relative errors, residual maps), each model is evaluated in chunks (no
/// full-length value planes), the cells are dropped as soon as the sections that read
/// them are done, and the renders read `table` itself (no copy). A model whose
/// [`ModelFit::record`] is its fit on these cells under the report's weighting (the
/// record's model, cell count and weighting match) takes its overall losses from the
/// record: the fitter computed them with the same function on the same cells.
pub fn build_report_from(
    table: Arc<MerlTable>,
    cells: FitData,
    table_name: &str,
    fits: &[ModelFit],
    config: Option<&FitConfig>,
    o: &ReportOptions,
    progress: &dyn Observe,
) -> Result<FitReport, ReportError> {
    if fits.is_empty() {
        return Err(ReportError::NoModels);
    }
    check_options(o)?;
    if cells.len() != table.valid_count() {
        return Err(ReportError::Option {
            option: "cells",
            reason: format!(
                "{} cells given for a table with {} valid cells",
                cells.len(),
                table.valid_count()
            ),
        });
    }
    let t_all = Instant::now();
    let fitted: Vec<&Fitted> = fits.iter().map(|f| &f.fitted).collect();
    // The sections that read the cells (quality, slices and maps, then the panels) run
    // beside the ones that read only the table and the models (albedo, checks, renders): each
    // alone leaves a core idle part of the time (a serial sum, the slowest θo, the last
    // model), and together rayon's work stealing keeps both busy. They are announced
    // in the report's order as they start together.
    for s in [
        "fit quality: losses, bands, percentiles",
        "θh slices and residual maps",
        "albedo curves",
    ] {
        progress.observe(&Event::Section(s.into()));
    }
    if o.checks.is_some() {
        progress.observe(&Event::Section(
            "physical checks of the fitted models".into(),
        ));
    }
    if o.render.is_some() {
        for l in Lighting::ALL {
            progress.observe(&Event::Section(format!(
                "rendering spheres under the {}",
                l.title()
            )));
        }
    }
    progress.observe(&Event::Section("interactive panels: embedded grids".into()));
    let (cell_parts, table_parts) = rayon::join(
        || cell_sections(&table, table_name, cells, fits, &fitted, o),
        || table_sections(&table, &fitted, o),
    );
    let CellSections {
        quality,
        slices,
        maps,
        panels,
        quality_s,
        slices_and_maps_s,
        panels_s,
    } = cell_parts?;
    let TableSections {
        albedo,
        physical_reports,
        render_sets,
        mut timings,
    } = table_parts?;
    timings.quality_s = quality_s;
    timings.slices_and_maps_s = slices_and_maps_s;
    timings.panels_s = panels_s;

    let summary = report_summary(
        &table,
        table_name,
        config,
        o,
        fits,
        &quality,
        &physical_reports,
    );
    let models = model_details(fits, quality, maps, &physical_reports);
    let mut data = ReportData {
        summary,
        fit_config: config.cloned(),
        options: o.clone(),
        models,
        slices,
        albedo,
        renders: render_sets,
        view_precision: panels.precision,
        timings,
    };
    progress.observe(&Event::Section("charts and page".into()));
    let t = Instant::now();
    // The page states the time the report took so far (its parts overlap).
    data.timings.total_s = t_all.elapsed().as_secs_f64();
    let html = page::page(&data, table.dims().theta_h(), &panels.markup)?;
    data.timings.page_s = t.elapsed().as_secs_f64();
    data.timings.total_s = t_all.elapsed().as_secs_f64();
    Ok(FitReport { data, html })
}

/// What [`cell_sections`] measures, with the wall time of each part (s).
struct CellSections {
    quality: Vec<QualityReport>,
    slices: Vec<Slice>,
    maps: Vec<ResidualMap>,
    panels: interactive::Panels,
    quality_s: f64,
    slices_and_maps_s: f64,
    panels_s: f64,
}

/// The sections that read the cells: every model's fit quality, then the slices and
/// the residual maps; then, with the cells dropped (nothing else reads them), the
/// interactive panels, whose embedded grids would otherwise add to the peak of the
/// cells' passes.
fn cell_sections(
    table: &Arc<MerlTable>,
    table_name: &str,
    cells: FitData,
    fits: &[ModelFit],
    fitted: &[&Fitted],
    o: &ReportOptions,
) -> Result<CellSections, ReportError> {
    let t = Instant::now();
    // The albedo comparison of `fit_quality` would integrate the table once per model:
    // the report integrates it once ([`analysis::albedo_curves`]).
    let qopt = QualityOptions {
        weighting: o.weighting,
        albedo_thetas: Vec::new(),
        ..QualityOptions::default()
    };
    let known: Vec<(&Fitted, Option<&LossReport>)> = fits
        .iter()
        .map(|f| {
            let losses = f.record.as_ref().and_then(|r| {
                (r.weighting == o.weighting
                    && r.cells_full == cells.len()
                    && r.model == f.fitted.to_json())
                .then_some(&r.losses_full)
            });
            (&f.fitted, losses)
        })
        .collect();
    // The residual maps come from the quality pass's own evaluation of every model at
    // every cell (the same sums as a pass of their own, without the second evaluation).
    let (quality, maps) =
        fit_quality_and_maps(table, &cells, &known, &qopt, Some(o.residual_max_bins))?;
    drop(cells);
    let quality_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let slices = analysis::slices(table, fitted, &o.slice_theta_d, o.slice_phi_d);
    let slices_and_maps_s = t.elapsed().as_secs_f64();
    let (panels, panels_s) = timed(|| report_panels(table, table_name, fits));
    Ok(CellSections {
        quality,
        slices,
        maps,
        panels: panels?,
        quality_s,
        slices_and_maps_s,
        panels_s,
    })
}

/// `f`'s result and its wall time (s).
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let r = f();
    (r, t.elapsed().as_secs_f64())
}

/// The physical checks of every model (in parallel) with each one's wall time; none
/// when `checks` is `None`.
fn physical_checks(
    fitted: &[&Fitted],
    checks: Option<&CheckOptions>,
) -> Vec<(Vec<PhysicalReport>, f64)> {
    let Some(co) = checks else {
        return Vec::new();
    };
    fitted
        .par_iter()
        .map(|f| timed(|| physical(f, co)))
        .collect()
}

/// The sphere renders under every lighting (none when `o.render` is `None`).
fn sphere_renders(
    table: &Arc<MerlTable>,
    fitted: &[&Fitted],
    o: &ReportOptions,
) -> Result<Vec<RenderSet>, ReportError> {
    let Some(ro) = &o.render else {
        return Ok(Vec::new());
    };
    Lighting::ALL
        .par_iter()
        .map(|l| renders::render_set(*l, ro, renders::Shown::Table(table), fitted))
        .collect()
}

/// What [`table_sections`] computes; `timings` holds the albedo, checks and renders
/// parts.
struct TableSections {
    albedo: AlbedoCurves,
    physical_reports: Vec<(Vec<PhysicalReport>, f64)>,
    render_sets: Vec<RenderSet>,
    timings: Timings,
}

/// The sections that read only the table and the models, each beside the others
/// (`rayon::join`): the albedo curves, the physical checks and the renders. Each
/// part's time is its own wall time; they overlap.
fn table_sections(
    table: &Arc<MerlTable>,
    fitted: &[&Fitted],
    o: &ReportOptions,
) -> Result<TableSections, ReportError> {
    // The models' albedo curves take the values the checks' energy curves hold
    // ([`analysis::model_albedo_curves`]), so they follow the checks.
    let auto_pole = o.checks.as_ref().is_none_or(|c| c.pole == PoleChoice::Auto);
    let (table_albedo, ((checks, models_albedo), renders)) = rayon::join(
        || timed(|| analysis::table_albedo_curve(table, &o.albedo_theta_o)),
        || {
            rayon::join(
                || {
                    let checks = timed(|| physical_checks(fitted, o.checks.as_ref()));
                    let reports: Vec<Vec<PhysicalReport>> =
                        checks.0.iter().map(|c| c.0.clone()).collect();
                    let models = timed(|| {
                        analysis::model_albedo_curves(
                            fitted,
                            &o.albedo_theta_o,
                            &reports,
                            auto_pole,
                        )
                    });
                    (checks, models)
                },
                || timed(|| sphere_renders(table, fitted, o)),
            )
        },
    );
    let albedo = analysis::albedo_curves(&o.albedo_theta_o, table_albedo.0, models_albedo.0);
    Ok(TableSections {
        albedo,
        physical_reports: checks.0,
        render_sets: renders.0?,
        timings: Timings {
            albedo_s: table_albedo.1 + models_albedo.1,
            checks_s: checks.1,
            renders_s: renders.1,
            ..Timings::default()
        },
    })
}

/// The report's summary: the table, the optimised loss and one row per model.
fn report_summary(
    table: &MerlTable,
    table_name: &str,
    config: Option<&FitConfig>,
    o: &ReportOptions,
    fits: &[ModelFit],
    quality: &[QualityReport],
    physical_reports: &[(Vec<PhysicalReport>, f64)],
) -> ReportSummary {
    let d = table.dims();
    ReportSummary {
        table: TableInfo {
            name: table_name.to_string(),
            dims: [d.theta_h(), d.theta_d(), d.phi_d()],
            cells: table.cells(),
            valid_cells: table.valid_count(),
        },
        loss_optimised: config.map(|c| c.get_loss().name().to_string()),
        weighting: o.weighting,
        models: fits
            .iter()
            .enumerate()
            .map(|(m, f)| ModelSummary {
                label: f.label.clone(),
                origin: f.origin,
                params: f.fitted.to_json(),
                losses: quality[m].losses,
                fit_time_s: f.record.as_ref().map(|r| r.wall_time_s),
                iterations: f.record.as_ref().map(|r| r.iterations),
                converged: f.record.as_ref().map(|r| r.converged),
                physical_passed: physical_reports
                    .get(m)
                    .map(|(r, _)| r.iter().all(|p| p.passed)),
            })
            .collect(),
    }
}

/// The report's details per model: its quality, checks, residual map and record.
fn model_details(
    fits: &[ModelFit],
    quality: Vec<QualityReport>,
    maps: Vec<ResidualMap>,
    physical_reports: &[(Vec<PhysicalReport>, f64)],
) -> Vec<ModelDetail> {
    fits.iter()
        .zip(quality)
        .zip(maps)
        .enumerate()
        .map(|(m, ((f, q), map))| {
            let (physical, physical_time_s) = physical_reports.get(m).cloned().unwrap_or_default();
            ModelDetail {
                label: f.label.clone(),
                origin: f.origin,
                quality: q,
                physical,
                physical_time_s,
                residual_map: map,
                record: f.record.clone(),
            }
        })
        .collect()
}

/// The interactive panels of a report: the table first (the reference of ratios and
/// differences), then every model.
fn report_panels(
    table: &Arc<MerlTable>,
    table_name: &str,
    fits: &[ModelFit],
) -> Result<interactive::Panels, ReportError> {
    use crate::compare::Representation;
    let mut reps = vec![Representation::Table(table.clone())];
    reps.extend(fits.iter().map(|f| Representation::Model(f.fitted.clone())));
    let labels = std::iter::once(format!("{table_name} (measured)"))
        .chain(fits.iter().map(|f| f.label.clone()));
    let sources: Vec<interactive::PanelSource> = labels
        .zip(&reps)
        .map(|(label, source)| interactive::PanelSource { label, source })
        .collect();
    interactive::panels(&sources).map_err(|e| ReportError::Panels(e.to_string()))
}

impl FitReport {
    /// `report.json`: every figure of the report (not the images).
    pub fn to_json_pretty(&self) -> String {
        serde_json::to_string_pretty(&self.data).expect("the report serialises") + "\n"
    }

    /// The summary alone, as pretty JSON.
    pub fn summary_json_pretty(&self) -> String {
        serde_json::to_string_pretty(&self.data.summary).expect("the summary serialises") + "\n"
    }
}
