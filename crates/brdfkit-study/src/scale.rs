//! How fit time grows: with the number of valid cells, the number of
//! parameters (a Lambertian plus 1–3 Cook-Torrance lobes), the number of threads, over
//! a batch of tables, all in-process. Whole-process figures (wall time and peak resident
//! memory of `fit-brdf batch`, `info` and `fit`) belong to the benchmarks:
//! `benches/peers/process_memory.py`.

use crate::choices::pool;
use crate::{StudyConfig, StudyError, SynthMaterial};
use brdfkit_core::progress::{Event, Observe};
use brdfkit_fit::{FitConfig, FitData, Loss, fit, resolve_free};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Fit time against a quantity.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ScalePoint {
    /// What varies (`cells`, `params`, `threads`).
    pub axis: String,
    /// Its value.
    pub x: f64,
    /// Cells fitted.
    pub cells: usize,
    /// Free parameters.
    pub params: usize,
    /// Rayon threads.
    pub threads: usize,
    /// Starts.
    pub starts: usize,
    /// Median wall time of the fit over the repetitions, s.
    pub wall_s: f64,
    /// Full-table cbrt loss.
    pub cbrt: f64,
}

/// Throughput of fitting many tables.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct BatchPoint {
    /// How the tables were fitted (in-process, one after the other).
    pub how: String,
    /// Tables fitted.
    pub tables: usize,
    /// Wall time of all of them, s.
    pub wall_s: f64,
    /// Tables per second.
    pub tables_per_s: f64,
    /// Why a way was not measured, if so.
    pub note: String,
}

/// All scaling measurements.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
pub struct ScaleResults {
    /// Fit time against cells, parameters and threads.
    pub points: Vec<ScalePoint>,
    /// Throughput of many fits, in-process. The whole-process figures (`fit-brdf batch`,
    /// `info`, `fit`: wall time and peak RSS) are measured by
    /// `benches/peers/process_memory.py`.
    pub batch: Vec<BatchPoint>,
}

fn fit_err(what: &str) -> impl FnOnce(brdfkit_fit::FitError) -> StudyError + '_ {
    move |source| StudyError::Fit {
        what: what.to_string(),
        source,
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// A Lambertian plus `lobes` Cook-Torrance lobes (GGX, Schlick) with their own ρd held
/// at 0 (a sum's diffuse parts are not separately identifiable), started at
/// α = 0.05, 0.2, 0.5.
pub fn lobes_model(lobes: usize) -> serde_json::Value {
    use brdfkit_core::Model;
    use brdfkit_models::{cook_torrance::CookTorrance, lambert::Lambert, sum::Sum};
    let mut terms =
        vec![serde_json::json!({"model": Lambert::default().name(), "params": {"rho_d": 0.3}})];
    for (i, a) in [0.05, 0.2, 0.5].iter().take(lobes).enumerate() {
        terms.push(
            serde_json::json!({"model": CookTorrance::default().name(), "params": {
            "rho_d": 0.0, "rho_s": 0.3 / (i + 1) as f64, "alpha": a,
            "distribution": "ggx", "masking": "smith-separable", "fresnel": "schlick"}}),
        );
    }
    serde_json::json!({"model": Sum::default().name(), "params": {"terms": terms}})
}

/// The held diffuse parameters of [`lobes_model`].
fn lobes_fixed(lobes: usize) -> Vec<String> {
    (1..=lobes).map(|i| format!("terms[{i}].rho_d")).collect()
}

/// Runs every scaling measurement, in-process: fit time against cells, parameters and
/// threads, and the throughput of fitting `cfg.batch_tables` tables one after the other.
/// The tables of the batch figure are written to a temporary directory (removed
/// afterwards) so that their reading is part of the figure.
pub fn run_scale(
    cfg: &StudyConfig,
    materials: &[SynthMaterial],
    progress: &dyn Observe,
) -> Result<ScaleResults, StudyError> {
    let mut res = ScaleResults::default();
    let pick = |name: &str| {
        materials
            .iter()
            .find(|m| m.spec.name == name)
            .or(materials.first())
    };
    let Some(plastic) = pick("demo-plastic") else {
        return Ok(res);
    };
    let full = FitData::from_table(&plastic.table).map_err(fit_err("demo-plastic"))?;
    let ct = default_start()?;
    let bench = Bench {
        start: ct.as_ref(),
        full: &full,
        reps: cfg.reps.clamp(1, 3),
        progress,
    };
    res.points = bench.cells()?;
    let multi = pick("lafortune-two-lobes").unwrap_or(plastic);
    res.points.extend(bench.params(multi)?);
    res.points.extend(bench.threads()?);
    res.batch
        .push(scale_batch(cfg, materials, ct.as_ref(), progress)?);
    Ok(res)
}

/// The start of the single-model figures: the study's first family (Cook-Torrance GGX at
/// its default start), so that they measure the fit the grid measures.
fn default_start() -> Result<Box<dyn brdfkit_core::Model>, StudyError> {
    let choice = crate::ModelChoice::default_family();
    brdfkit_models::from_json(&choice.start).map_err(|e| StudyError::Model {
        what: choice.label.clone(),
        msg: e.to_string(),
    })
}

/// What the fit-time figures share: the single-model start ([`default_start`]) and the
/// full table it is fitted to, the repetitions of each fit and where progress goes.
struct Bench<'a> {
    start: &'a dyn brdfkit_core::Model,
    full: &'a FitData,
    reps: usize,
    progress: &'a dyn Observe,
}

impl Bench<'_> {
    /// One point of the figures: `reps` identical fits of `start` to `data` with `fc`,
    /// on the calling rayon pool (its thread count is the point's `threads`): the median
    /// wall time and the full-table cbrt loss. `what` names the measurement in errors.
    fn point(
        &self,
        (axis, x): (&str, f64),
        (start, data): (&dyn brdfkit_core::Model, &FitData),
        fc: &FitConfig,
        what: &str,
    ) -> Result<ScalePoint, StudyError> {
        let params = resolve_free(start, fc).map_err(fit_err(what))?.len();
        let mut times = Vec::new();
        let mut loss = f64::NAN;
        for _ in 0..self.reps.max(1) {
            let t = Instant::now();
            let o = fit(start, data, fc, None).map_err(fit_err(what))?;
            times.push(t.elapsed().as_secs_f64());
            loss = o.record.losses_full.get(Loss::Cbrt).overall;
        }
        Ok(ScalePoint {
            axis: axis.into(),
            x,
            cells: data.len(),
            params,
            threads: rayon::current_num_threads(),
            starts: fc.get_starts(),
            wall_s: median(times),
            cbrt: loss,
        })
    }

    /// Fit time against the number of cells. The solver sees a stratified subset (the
    /// fit is then a full fit of a smaller table: no `subsample` option, so the losses
    /// are over that subset).
    fn cells(&self) -> Result<Vec<ScalePoint>, StudyError> {
        let mut points = Vec::new();
        for f in [0.01, 0.02, 0.05, 0.1, 0.25, 0.5, 1.0] {
            let data = if f < 1.0 {
                self.full.stratified_subsample(f, 11)
            } else {
                self.full.clone()
            };
            let fc = FitConfig::default();
            let p = self.point(("cells", f), (self.start, &data), &fc, "scale cells")?;
            let (n, wall_s) = (p.cells, p.wall_s);
            let msg = format!("scale cells {n}: {wall_s:.3} s");
            self.progress.observe(&Event::Step(msg));
            points.push(p);
        }
        Ok(points)
    }

    /// Fit time against the number of free parameters: a Lambertian plus 1–3 lobes
    /// ([`lobes_model`]) on `multi` (the multi-lobe material when present).
    fn params(&self, multi: &SynthMaterial) -> Result<Vec<ScalePoint>, StudyError> {
        let mdata = FitData::from_table(&multi.table).map_err(fit_err("multi-lobe"))?;
        let mut points = Vec::new();
        for lobes in 1..=3 {
            let m =
                brdfkit_models::from_json(&lobes_model(lobes)).map_err(|e| StudyError::Model {
                    what: format!("sum of {lobes} lobes"),
                    msg: e.to_string(),
                })?;
            let fc = FitConfig::default().fix_params(lobes_fixed(lobes));
            let np = resolve_free(m.as_ref(), &fc)
                .map_err(fit_err("lobes"))?
                .len();
            let axis = ("params", np as f64);
            let p = self.point(axis, (m.as_ref(), &mdata), &fc, "scale params")?;
            let (wall_s, cbrt) = (p.wall_s, p.cbrt);
            let msg = format!("scale params {np}: {wall_s:.3} s, cbrt {cbrt:.3e}");
            self.progress.observe(&Event::Step(msg));
            points.push(p);
        }
        Ok(points)
    }

    /// Fit time against threads: 1 and 2 (and all, if more), one start and four.
    fn threads(&self) -> Result<Vec<ScalePoint>, StudyError> {
        let threads = rayon::current_num_threads();
        let mut ts = vec![1, 2];
        if threads > 2 {
            ts.push(threads);
        }
        let mut points = Vec::new();
        for &t in &ts {
            for starts in [1, 4] {
                let fc = FitConfig::default()
                    .starts(starts)
                    .map_err(fit_err("threads"))?;
                let on = (self.start, self.full);
                let p = pool(t)
                    .install(|| self.point(("threads", t as f64), on, &fc, "scale threads"))?;
                let msg = format!("scale threads {t} starts {starts}: {:.3} s", p.wall_s);
                self.progress.observe(&Event::Step(msg));
                points.push(p);
            }
        }
        Ok(points)
    }
}

/// Throughput of fitting `cfg.batch_tables` tables in turn: each written to disk first,
/// then read and fitted (one start), so the figure covers what a batch run does per
/// table apart from writing its results.
fn scale_batch(
    cfg: &StudyConfig,
    materials: &[SynthMaterial],
    ct: &dyn brdfkit_core::Model,
    progress: &dyn Observe,
) -> Result<BatchPoint, StudyError> {
    let dir = tempfile::tempdir().map_err(|e| StudyError::io(Path::new("temp dir"), e))?;
    let n = cfg.batch_tables.max(1);
    let mut paths: Vec<PathBuf> = Vec::new();
    for i in 0..n {
        let m = &materials[i % materials.len()];
        let p = dir.path().join(format!("{:02}-{}.binary", i, m.spec.name));
        m.table
            .write(&p)
            .map_err(|e| StudyError::io(&p, std::io::Error::other(e.to_string())))?;
        paths.push(p);
    }
    let t = Instant::now();
    for p in &paths {
        let table = brdfkit_merl::MerlTable::read(p)
            .map_err(|e| StudyError::io(p, std::io::Error::other(e.to_string())))?;
        let data = FitData::from_table(&table).map_err(fit_err("batch"))?;
        fit(ct, &data, &FitConfig::default(), None).map_err(fit_err("batch"))?;
    }
    let wall = t.elapsed().as_secs_f64();
    progress.observe(&Event::Step(format!(
        "scale batch: {n} tables in {wall:.2} s (sequential)"
    )));
    Ok(BatchPoint {
        how: "sequential in-process (read + cook-torrance fit, 1 start)".into(),
        tables: n,
        wall_s: wall,
        tables_per_s: n as f64 / wall,
        note: String::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lobe_models_have_the_expected_free_parameters() {
        for lobes in 1..=3 {
            let m = brdfkit_models::from_json(&lobes_model(lobes)).unwrap();
            let fc = FitConfig::default().fix_params(lobes_fixed(lobes));
            // Lambert ρd (3) + per lobe ρs (3), α (1), f0 (3).
            assert_eq!(resolve_free(m.as_ref(), &fc).unwrap().len(), 3 + 7 * lobes);
        }
    }
}
