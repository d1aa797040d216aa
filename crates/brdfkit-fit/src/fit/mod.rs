//! The fit driver: cells → passes → starts (in parallel) → solver → best → record.
//!
//! Rooms: [`cells`] (the cell sets, shared across families), [`pass`] (one pass as
//! its stages: explore, rank, warm up, finish), [`solve`] (one solver run), [`timing`]
//! (where the time went); the record is assembled in [`crate::record`].

mod cells;
mod pass;
mod solve;
mod timing;

pub use timing::StageTimes;

use crate::config::{CellFilter, FitConfig, Sharing};
use crate::data::FitData;
use crate::error::FitError;
use crate::fitted::Fitted;
use crate::loss::LossReport;
use crate::problem::evaluate_losses_of;
use crate::record::{FitRecord, PassSummary, RecordParts};
use brdfkit_core::progress::{Event, FitPlan, Observe, StartDone, relay};
use brdfkit_core::{Model, ParamRole};
use brdfkit_merl::MerlTable;
use cells::Cells;
use pass::{PassResult, run_pass, stage_done};
use std::sync::Arc;
use std::time::Instant;

/// A fit's outcome: the model(s) and the record.
#[derive(Debug, Clone)]
pub struct FitResult {
    /// The fitted model(s).
    pub fitted: Fitted,
    /// What was done and how well it went.
    pub record: FitRecord,
    /// Where the fit's wall time went, stage by stage (not in the record).
    pub stages: StageTimes,
}

/// Which parameters a config frees: the model's `fit_by_default` ones, plus
/// `config.free`, minus `config.fixed`. A name matches a parameter exactly or as its
/// group (`rho_d` matches `rho_d.r`, `rho_d.g`, `rho_d.b`).
pub fn resolve_free(model: &dyn Model, config: &FitConfig) -> Result<Vec<usize>, FitError> {
    let specs = model.param_specs();
    let matches = |name: &str| -> Result<Vec<usize>, FitError> {
        let v: Vec<usize> = specs
            .iter()
            .enumerate()
            .filter(|(_, s)| {
                s.name == name
                    || (s.name.starts_with(name) && s.name[name.len()..].starts_with('.'))
            })
            .map(|(p, _)| p)
            .collect();
        if v.is_empty() {
            Err(FitError::UnknownParam {
                model: model.name().into(),
                name: name.into(),
                known: specs
                    .iter()
                    .map(|s| s.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            })
        } else {
            Ok(v)
        }
    };
    let mut free: Vec<bool> = specs.iter().map(|s| s.fit_by_default).collect();
    for n in &config.free {
        for p in matches(n)? {
            free[p] = true;
        }
    }
    for n in &config.fixed {
        for p in matches(n)? {
            free[p] = false;
        }
    }
    Ok((0..specs.len()).filter(|&p| free[p]).collect())
}

/// The passes of a fit: one over all channels (shared shape), or one per channel with
/// the shared parameters and that channel's own.
fn passes(model: &dyn Model, free: &[usize], config: &FitConfig) -> Vec<(Vec<usize>, Vec<usize>)> {
    let specs = model.param_specs();
    match config.sharing {
        Sharing::SharedShape => vec![(free.to_vec(), vec![0, 1, 2])],
        Sharing::PerChannel => (0..3)
            .map(|c| {
                let f: Vec<usize> = free
                    .iter()
                    .copied()
                    .filter(|&p| match specs[p].role {
                        ParamRole::Shared => true,
                        ParamRole::Channel(k) => k == c,
                    })
                    .collect();
                (f, vec![c])
            })
            .collect(),
    }
}

/// Fits `model`'s family to the cells of `data`.
///
/// `model` fixes the family and its structural choices (distribution, Fresnel, lobe
/// count) and gives start 0 and the values of the fixed parameters (normally
/// [`brdfkit_models::default_model`] or a user's JSON). See the crate doc and
/// `docs/fitting.md` for what happens; `observer` receives progress events
/// ([`Event::FitPlanned`], then [`Event::Iteration`]s and [`Event::StartDone`]s from the
/// starts, all delivered before `fit` returns; pass `None` for a silent fit).
pub fn fit(
    model: &dyn Model,
    data: &FitData,
    config: &FitConfig,
    observer: Option<&dyn Observe>,
) -> Result<FitResult, FitError> {
    match observer.filter(|o| !o.is_silent()) {
        None => fit_observed(model, data, config, None),
        // The solvers' observers must be 'static: the events go through a relay.
        Some(obs) => relay(obs, |o| fit_observed(model, data, config, Some(o))),
    }
}

/// [`fit`] with its observer owned.
fn fit_observed(
    model: &dyn Model,
    data: &FitData,
    config: &FitConfig,
    observer: Option<Arc<dyn Observe>>,
) -> Result<FitResult, FitError> {
    let t0 = Instant::now();
    let mut times = StageTimes::default();
    config.validate()?;
    let cells = Cells::of(data, config)?;
    times.subsample = t0.elapsed().as_secs_f64();
    let free = resolve_free(model, config)?;
    if free.is_empty() {
        return Err(FitError::NothingToFit(model.name().into()));
    }
    let passes = passes(model, &free, config);
    if let Some(o) = &observer {
        o.observe(&Event::FitPlanned(plan(
            config,
            cells.fitset().len(),
            passes.len(),
        )));
        // Told after the plan, which needs its cells.
        o.observe(&Event::StageDone {
            stage: "subsample",
            channel: None,
            seconds: times.subsample,
        });
    }
    let sets = cells.sets();
    let mut results: Vec<PassResult> = passes
        .into_iter()
        .map(|(f, ch)| run_pass(&sets, model, f, ch, config, observer.as_ref(), &mut times))
        .collect::<Result<_, _>>()?;
    let fitted = match &results[..] {
        [one] => Fitted::Shared(one.model.clone()),
        [r, g, b] => Fitted::PerChannel([r.model.clone(), g.model.clone(), b.model.clone()]),
        _ => unreachable!("a fit has one pass or three"),
    };
    let t = Instant::now();
    let (losses_fit, losses_full) = loss_reports(&fitted, &cells, config);
    settle_deferred(&mut results, &losses_fit, config, observer.as_ref())?;
    times.losses = stage_done(observer.as_ref(), "losses", None, t);
    let t = Instant::now();
    let u: Vec<Vec<f64>> = results
        .iter()
        .map(|r| r.best.u.iter().copied().collect())
        .collect();
    let summaries = results
        .iter()
        .zip(&u)
        .map(|(r, u)| PassSummary {
            model: r.model.as_ref(),
            free: &r.free,
            transforms: &r.transforms,
            u,
            starts: &r.starts,
            iterations: r.best.iterations,
            termination: &r.best.termination,
            converged: r.best.converged,
            cost: r.best.cost,
            robust: r.robust,
        })
        .collect();
    let mut record = FitRecord::assemble(RecordParts {
        start: model,
        fitted: &fitted,
        config,
        free: &free,
        passes: summaries,
        cells_fit: cells.fitset().len(),
        cells_full: cells.full.len(),
        losses_fit,
        losses_full,
        wall_time_s: 0.0,
    });
    times.record = stage_done(observer.as_ref(), "record", None, t);
    record.wall_time_s = t0.elapsed().as_secs_f64();
    record.input = data.input().cloned();
    Ok(FitResult {
        fitted,
        record,
        stages: times,
    })
}

/// Builds what every fit of `data` under `config` shares whatever the model: the
/// warm-up and exploration subsamples, the cube-root targets and the weight sum of the
/// loss report (see `docs/fitting.md`, "The fit's rooms"). [`fit`] builds them on first
/// use anyway; calling this first (as [`crate::families::fit_each`] does) pays them once
/// per table, outside every family's `wall_time_s`. Errors are the ones `fit` would
/// give (no cell within the cutoffs).
pub fn prepare(data: &FitData, config: &FitConfig) -> Result<(), FitError> {
    // Cells behind an angular cutoff are a copy each fit makes: nothing of it is kept.
    if !CellFilter::of(config).keeps_all() {
        return Ok(());
    }
    let cells = Cells::of(data, config)?;
    cells.fitset().cbrt_targets();
    data.cbrt_targets();
    data.weight_sum(config.weighting);
    Ok(())
}

/// What the observer is told before the passes: ranked passes finish `finish` starts,
/// unranked ones every start.
fn plan(config: &FitConfig, cells: usize, passes: usize) -> FitPlan {
    FitPlan {
        starts: config.starts,
        finish: if config.warm_up_cells_for(cells).is_some() {
            config.finish.min(config.starts)
        } else {
            config.starts
        },
        passes,
        max_iters: config.get_max_iters(),
        cells,
    }
}

/// The loss report over the fitted cells and over the full set (one pass when they
/// are the same cells).
fn loss_reports(
    fitted: &Fitted,
    cells: &Cells<'_>,
    config: &FitConfig,
) -> (LossReport, LossReport) {
    let ms = fitted.channel_models();
    let (w, set) = (config.weighting, config.reported_losses());
    let losses_fit = evaluate_losses_of(ms, cells.fitset(), w, set);
    let losses_full = if cells.fits_all() {
        losses_fit
    } else {
        evaluate_losses_of(ms, &cells.full, w, set)
    };
    (losses_fit, losses_full)
}

/// Deferred costs (see `pass::defers_cost`): the report's value of the optimised loss
/// over the fitted cells, overall or of the pass's channel, becomes the kept start's.
fn settle_deferred(
    results: &mut [PassResult],
    losses_fit: &LossReport,
    config: &FitConfig,
    observer: Option<&Arc<dyn Observe>>,
) -> Result<(), FitError> {
    for r in results.iter_mut().filter(|r| r.deferred) {
        let l = losses_fit.get(config.loss);
        let v = r.channel.map_or(l.overall, |c| l.channels[c]);
        if !v.is_finite() {
            return Err(FitError::Solver {
                solver: config.solver.name().into(),
                start: 0,
                reason: "no start reached a finite loss (every cost was infinite or NaN)".into(),
            });
        }
        r.best.cost = 0.5 * v * v;
        if let Some(s) = r.starts.iter_mut().find(|s| s.kept) {
            s.final_loss = Some(v);
            if let Some(o) = observer {
                o.observe(&Event::StartDone(StartDone {
                    start: s.index,
                    channel: r.channel,
                    loss: v,
                    iterations: r.best.iterations,
                    termination: r.best.termination.clone(),
                }));
            }
        }
    }
    Ok(())
}

/// [`fit`] on the valid cells of a table.
pub fn fit_table(
    model: &dyn Model,
    table: &MerlTable,
    config: &FitConfig,
    observer: Option<&dyn Observe>,
) -> Result<FitResult, FitError> {
    let data = FitData::from_table(table)?;
    fit(model, &data, config, observer)
}
