//! The fit-quality report on scattered data: a `.bsdf` file's measured points or a
//! user's samples (`fit-brdf report X.bsdf`, `fit-brdf report --samples S`).
//!
//! The table report's slices, residual maps, albedo and interactive panels read a full
//! MERL grid; scattered data have none, and nothing here resamples them. Every figure
//! is taken at the samples' own directions:
//! - every loss of every model over all samples, with the samples' weights (the
//!   fitter's function, [`evaluate_losses`]);
//! - measured against model value per sample and channel (a log–log scatter: a perfect
//!   fit lies on the diagonal);
//! - the residual by θh and by θd: the weighted mean of log10(f_model / f_measured)
//!   over the samples in each 5° band (the table report's residual map, marginalised,
//!   without a grid);
//! - the sphere renders, against the measured side only where something measured can
//!   be evaluated anywhere: a `.bsdf` is rendered from the file itself (its own
//!   interpolation, as Mitsuba's `measured` plugin renders it); scattered samples have
//!   no measured sphere, and the page says so;
//! - the physical checks of each model (the table report's bounded set).

use super::AnyReport;
use super::analysis::LOG_RATIO_FLOOR;
use super::renders::{Lighting, RenderSet, Shown, render_set};
pub use super::scattered_data::{
    BAND_DEG, Band, MAX_PLOTTED, ScatteredData, ScatteredModel, ScatteredSummary,
};
use super::{ModelFit, ModelSummary, ReportError, ReportOptions, Timings, physical};
use crate::physical::PhysicalReport;
use brdfkit_core::Rgb;
use brdfkit_core::progress::{Event, Observe};
use brdfkit_fit::{
    FitConfig, FitData, Fitted, InputInfo, Measured, MeasuredSide, Weighting, evaluate_losses,
};
use brdfkit_rgl::RglBsdf;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// What stands beside the samples.
pub enum ScatteredSide {
    /// The `.bsdf` file the points come from: it evaluates anywhere.
    Bsdf(Arc<RglBsdf>),
    /// A user's samples: nothing evaluates between them.
    Samples,
}

/// A report on scattered data: its data and its page.
pub struct ScatteredReport {
    /// `report.json`.
    pub data: ScatteredData,
    /// The self-contained page.
    pub html: String,
}

/// Every model's values at every sample.
fn values_of(f: &Fitted, data: &FitData) -> Vec<Rgb> {
    let g = data.geometry();
    let mut out = vec![Rgb::ZERO; data.len()];
    let mut ch = vec![Rgb::ZERO; data.len()];
    for (c, m) in f.channel_models().into_iter().enumerate() {
        m.eval_batch(&g.slice(0..data.len()), &mut ch);
        for (o, v) in out.iter_mut().zip(&ch) {
            o[c] = v[c];
        }
    }
    out
}

/// The residual profile of `model` over `angle` (radians per sample) in 5° bands.
fn profile(angle: &[f64], w: &[f64], measured: &[Vec<f64>; 3], model: &[Rgb]) -> Vec<Band> {
    let bands = (90.0 / BAND_DEG) as usize;
    let mut acc = vec![(0usize, 0.0f64, 0.0f64); bands];
    for (k, a) in angle.iter().enumerate() {
        let b = ((a.to_degrees() / BAND_DEG) as usize).min(bands - 1);
        acc[b].0 += 1;
        for c in 0..3 {
            let meas = measured[c][k];
            if meas > 0.0 {
                let f = model[k][c];
                let r = if f > 0.0 {
                    (f / meas).log10().max(LOG_RATIO_FLOOR)
                } else {
                    LOG_RATIO_FLOOR
                };
                acc[b].1 += w[k] * r;
                acc[b].2 += w[k];
            }
        }
    }
    acc.iter()
        .enumerate()
        .map(|(b, &(n, s, sw))| Band {
            lo_deg: b as f64 * BAND_DEG,
            samples: n,
            mean_log10_ratio: (sw > 0.0).then(|| s / sw),
        })
        .collect()
}

/// One model's summary line and its measurements at the samples (`w` their weights,
/// `shown` the plotted ones).
fn measure_model(
    f: &ModelFit,
    cells: &FitData,
    w: &[f64],
    shown: &[usize],
    weighting: Weighting,
) -> (ModelSummary, ScatteredModel) {
    let vals = values_of(&f.fitted, cells);
    let summary = ModelSummary {
        label: f.label.clone(),
        origin: f.origin,
        params: f.fitted.to_json(),
        losses: evaluate_losses(f.fitted.channel_models(), cells, weighting),
        fit_time_s: f.record.as_ref().map(|r| r.wall_time_s),
        iterations: f.record.as_ref().map(|r| r.iterations),
        converged: f.record.as_ref().map(|r| r.converged),
        physical_passed: None,
    };
    let model = ScatteredModel {
        label: f.label.clone(),
        origin: f.origin,
        by_theta_h: profile(cells.theta_h(), w, cells.values(), &vals),
        by_theta_d: profile(cells.theta_d(), w, cells.values(), &vals),
        physical: Vec::new(),
        record: f.record.clone(),
        plotted: shown.iter().map(|&k| vals[k]).collect(),
    };
    (summary, model)
}

/// The samples the scatter charts draw: every k-th, at most [`MAX_PLOTTED`].
fn plotted_indices(n: usize) -> Vec<usize> {
    let step = n.div_ceil(MAX_PLOTTED).max(1);
    (0..n).step_by(step).collect()
}

/// Builds the report of `fits` on scattered `cells` (`side`: what stands beside them;
/// `input`: their file and counts). `config` is the fit configuration when something
/// was fitted. Nothing is resampled (module doc).
pub fn build_scattered_report(
    cells: &FitData,
    side: &ScatteredSide,
    input: InputInfo,
    fits: &[ModelFit],
    config: Option<&FitConfig>,
    o: &ReportOptions,
    progress: &dyn Observe,
) -> Result<ScatteredReport, ReportError> {
    if fits.is_empty() {
        return Err(ReportError::NoModels);
    }
    o.check()?;
    let t_all = Instant::now();
    let mut timings = Timings::default();
    progress.observe(&Event::Section(
        "losses and residual profiles at the samples' own directions".into(),
    ));
    let t = Instant::now();
    let w = cells.weights(o.weighting);
    let shown = plotted_indices(cells.len());
    let (mut summaries, mut models): (Vec<_>, Vec<_>) = fits
        .iter()
        .map(|f| measure_model(f, cells, &w, &shown, o.weighting))
        .unzip();
    timings.quality_s = t.elapsed().as_secs_f64();
    run_checks(fits, o, &mut models, &mut summaries, &mut timings, progress);
    let renders = sphere_renders(side, fits, o, &mut timings, progress)?;
    let measured_sphere = match side {
        ScatteredSide::Bsdf(_) => Some(format!("{} (the file's own evaluation)", input.path)),
        ScatteredSide::Samples => None,
    };
    let m = cells.values();
    let mut data = ScatteredData {
        summary: ScatteredSummary {
            input,
            loss_optimised: config.map(|c| c.get_loss().name().to_string()),
            weighting: o.weighting,
            measured_sphere,
            resampled: false,
            models: summaries,
        },
        fit_config: config.cloned(),
        models,
        plotted: shown.len(),
        plotted_measured: shown
            .iter()
            .map(|&k| Rgb::new(m[0][k], m[1][k], m[2][k]))
            .collect(),
        renders,
        timings,
    };
    progress.observe(&Event::Section("charts and page".into()));
    let t = Instant::now();
    let html = super::scattered_page::page(&data, &o.title)?;
    data.timings.page_s = t.elapsed().as_secs_f64();
    data.timings.total_s = t_all.elapsed().as_secs_f64();
    Ok(ScatteredReport { data, html })
}

/// The physical checks of every model, when the options ask for them.
fn run_checks(
    fits: &[ModelFit],
    o: &ReportOptions,
    models: &mut [ScatteredModel],
    summaries: &mut [ModelSummary],
    timings: &mut Timings,
    progress: &dyn Observe,
) {
    let Some(co) = &o.checks else { return };
    progress.observe(&Event::Section("physical checks of the models".into()));
    let t = Instant::now();
    let reports: Vec<Vec<PhysicalReport>> =
        fits.par_iter().map(|f| physical(&f.fitted, co)).collect();
    for ((m, s), r) in models.iter_mut().zip(summaries.iter_mut()).zip(reports) {
        s.physical_passed = Some(r.iter().all(|p| p.passed));
        m.physical = r;
    }
    timings.checks_s = t.elapsed().as_secs_f64();
}

/// The spheres: a `.bsdf` from the file itself against every model; none for samples.
fn sphere_renders(
    side: &ScatteredSide,
    fits: &[ModelFit],
    o: &ReportOptions,
    timings: &mut Timings,
    progress: &dyn Observe,
) -> Result<Vec<RenderSet>, ReportError> {
    let (Some(ro), ScatteredSide::Bsdf(bsdf)) = (&o.render, side) else {
        return Ok(Vec::new());
    };
    let t = Instant::now();
    let fitted: Vec<&Fitted> = fits.iter().map(|f| &f.fitted).collect();
    let mut sets = Vec::new();
    for l in Lighting::ALL {
        progress.observe(&Event::Section(format!(
            "rendering spheres under the {}",
            l.title()
        )));
        sets.push(render_set(l, ro, Shown::Measured(bsdf), &fitted)?);
    }
    timings.renders_s = t.elapsed().as_secs_f64();
    Ok(sets)
}

/// The report on a measured input ([`Measured`], the fitter's one rule for inputs):
/// the table report on a table (a `.bsdf` resampled to one is named so on the page,
/// from [`InputInfo::kind`]), or the report on scattered data for a `.bsdf`'s points
/// (the spheres rendered from the file) and a user's samples (no measured sphere).
/// A table input must have been read with its table kept.
pub fn build_any_report(
    m: Measured,
    fits: &[ModelFit],
    config: Option<&FitConfig>,
    o: &ReportOptions,
    progress: &dyn Observe,
) -> Result<AnyReport, ReportError> {
    let info = m.info();
    let side = match m.side {
        MeasuredSide::Table { table, .. } => {
            let table = table.ok_or(ReportError::Option {
                option: "table",
                reason: "the input was read without its table".into(),
            })?;
            let mut name = m
                .path
                .file_name()
                .map_or_else(|| info.path.clone(), |n| n.to_string_lossy().into_owned());
            if info.kind == "bsdf-table" {
                name +=
                    " (resampled to a 90 × 90 × 180 MERL table, each cell the mean of both orders)";
            }
            return super::build_report_from(
                Arc::new(table),
                m.data,
                &name,
                fits,
                config,
                o,
                progress,
            )
            .map(|r| AnyReport::Table(Box::new(r)));
        }
        MeasuredSide::BsdfPoints(b) => ScatteredSide::Bsdf(Arc::new(*b)),
        MeasuredSide::Samples => ScatteredSide::Samples,
    };
    build_scattered_report(&m.data, &side, info, fits, config, o, progress)
        .map(|r| AnyReport::Scattered(Box::new(r)))
}

impl ScatteredReport {
    /// `report.json`.
    pub fn to_json_pretty(&self) -> String {
        serde_json::to_string_pretty(&self.data).expect("the report serialises") + "\n"
    }

    /// The summary alone, as pretty JSON.
    pub fn summary_json_pretty(&self) -> String {
        serde_json::to_string_pretty(&self.data.summary).expect("the summary serialises") + "\n"
    }
}
