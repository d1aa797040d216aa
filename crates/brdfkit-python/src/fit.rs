//! `brdfkit.fit`: `fit-brdf fit` from Python, through the same library calls
//! (`brdfkit_fit::families`: the model list, the settings, `fit_each`), with an
//! optional progress callback.

use crate::model::PyModel;
use crate::table::PyTable;
use crate::{errors, json_to_py};
use brdfkit_fit::config::DEFAULT_EXPLORE_CELLS;
use brdfkit_fit::families::{Family, FitSettings, Structure, check_free, families, fit_each};
use brdfkit_fit::{Event, FitData, Observe};
use pyo3::prelude::*;
use pyo3::types::PyString;
use serde_json::json;
use std::path::PathBuf;
use std::str::FromStr;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

/// The argument `arg` (`loss = "cbrt"`, ...) parsed by the library's own `FromStr`,
/// whose message names the value and the accepted names; the argument's name leads.
fn choice<T: FromStr<Err = E>, E: std::fmt::Display>(arg: &str, s: &str) -> PyResult<T> {
    T::from_str(s).map_err(|e| errors::value(format!("{arg}: {e}")))
}

/// An optional named choice.
fn opt_choice<T: FromStr<Err = E>, E: std::fmt::Display>(
    arg: &str,
    s: Option<&str>,
) -> PyResult<Option<T>> {
    s.map(|s| choice(arg, s)).transpose()
}

/// Forwards fit progress to a Python callable, one dict per event, from whichever
/// thread the event comes (the GIL is taken for the call only; the dict is the event's
/// JSON, so floats cross bit for bit). The first exception the
/// callable raises stops the forwarding and is raised when the fit returns.
struct Progress {
    callback: Py<PyAny>,
    stopped: AtomicBool,
    error: Mutex<Option<PyErr>>,
    /// The label of the family being fitted (families are fitted one after the other).
    family: Mutex<String>,
}

impl Progress {
    /// Calls the callable with the event as a dict.
    fn send(&self, event: serde_json::Value) {
        if self.stopped.load(Ordering::Relaxed) {
            return;
        }
        // The lock is never held while Python runs (the callback may release the GIL).
        let failed = Python::attach(|py| {
            json_to_py(py, &event)
                .and_then(|d| self.callback.call1(py, (d,)))
                .err()
        });
        if let Some(e) = failed {
            self.stopped.store(true, Ordering::Relaxed);
            let mut slot = self.error.lock().unwrap_or_else(|p| p.into_inner());
            slot.get_or_insert(e);
        }
    }

    fn family(&self) -> String {
        self.family
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }
}

impl Observe for Progress {
    fn observe(&self, e: &Event) {
        let family = self.family();
        match e {
            Event::FamilyStarted { label, .. } => {
                *self.family.lock().unwrap_or_else(|p| p.into_inner()) = label.clone();
            }
            Event::FitPlanned(p) => self.send(
                json!({"event": "plan", "family": family, "starts": p.starts,
                "finish": p.finish, "passes": p.passes, "max_iters": p.max_iters, "cells": p.cells}),
            ),
            Event::Iteration(e) => self.send(
                json!({"event": "iter", "family": family, "start": e.start,
                "channel": e.channel, "iter": e.iter, "cost": e.cost, "best_cost": e.best_cost,
                "warm_up": e.warm_up}),
            ),
            Event::StartDone(s) => self.send(
                json!({"event": "start_done", "family": family, "start": s.start,
                "channel": s.channel, "loss": s.loss, "iterations": s.iterations,
                "termination": s.termination}),
            ),
            _ => {}
        }
    }
}

/// What `model` takes, in its errors.
const MODEL_TAKES: &str = "model: expected a model name or model JSON file (a str or os.PathLike), \
     a comma-separated str of them, a brdfkit.Model, or a sequence (list, tuple) of these";

/// One item of a model sequence: a `Model`, or the text of a name or a file path.
enum Item {
    Model(Family),
    Text(String),
}

/// A `Model`, or a name or path (a `str` or `os.PathLike`).
fn item_of(obj: &Bound<'_, PyAny>) -> PyResult<Option<Item>> {
    if let Ok(m) = obj.cast::<PyModel>() {
        let m = m.get();
        return Ok(Some(Item::Model(Family {
            label: m.inner.name().to_string(),
            model: m.inner.clone_box(),
        })));
    }
    if obj.cast::<PyString>().is_ok()
        || obj.is_instance(&obj.py().import("os")?.getattr("PathLike")?)?
    {
        let path: PathBuf = obj.extract()?;
        return Ok(Some(Item::Text(path.to_string_lossy().into_owned())));
    }
    Ok(None)
}

/// The families to fit, in order: from a `Model`, a name or a path, a comma-separated
/// list of names and model JSON files (as `fit-brdf fit --model`), or any sequence of
/// these, with the structural choices applied to the names and files.
fn families_of(model: &Bound<'_, PyAny>, s: &Structure) -> PyResult<Vec<Family>> {
    let items = match item_of(model)? {
        Some(item) => vec![item],
        None => {
            let seq: Vec<Bound<'_, PyAny>> = model
                .extract()
                .map_err(|_| errors::type_error(MODEL_TAKES))?;
            seq.iter()
                .map(|x| item_of(x)?.ok_or_else(|| errors::type_error(MODEL_TAKES)))
                .collect::<PyResult<_>>()?
        }
    };
    let texts: Vec<&str> = items
        .iter()
        .filter_map(|i| match i {
            Item::Text(t) => Some(t.as_str()),
            Item::Model(_) => None,
        })
        .collect();
    if texts.len() == items.len() {
        // Names and files only: one list, so a structural choice needs its model
        // somewhere in it (as on the command line).
        return families(&texts.join(","), s).map_err(errors::input);
    }
    if *s != Structure::default() {
        return Err(errors::value(
            "distribution, masking, fresnel and normalization apply to model names; \
             a Model carries its own choices",
        ));
    }
    let mut out = Vec::with_capacity(items.len());
    for item in items {
        match item {
            Item::Model(f) => out.push(f),
            Item::Text(t) => out.extend(families(&t, s).map_err(errors::input)?),
        }
    }
    Ok(out)
}

/// The defaults of every argument of [`fit`]: the library's one set
/// ([`FitSettings::default`]), shared with the command line.
fn d() -> FitSettings {
    FitSettings::default()
}

/// The defaults of `brdfkit.fit` as a dict (`brdfkit._brdfkit.FIT_DEFAULTS`): the Python
/// wrapper's signature takes them from here, so no default is written twice.
pub fn defaults_dict(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    let s = d();
    let v = json!({
        "model": brdfkit_models::named::DEFAULT_FAMILY,
        "loss": s.loss.name(),
        "starts": s.starts,
        "losses": s.losses.name(),
        "weighting": s.weighting.name(),
        "solver": s.solver.name(),
        "finish": s.finish,
        "full_iters": s.full_iters.to_string(),
        "explore_cells": s.explore_cells,
    });
    json_to_py(py, &v)
}

/// Fits each model family to the table as `fit-brdf fit` does (same defaults); returns
/// (label, fitted model file text, fit record file text, iterations by stage) per
/// family: the bytes `fit-brdf fit --out` and `--record` write, and the iterations as
/// the command line's fit table prints them.
#[pyfunction]
#[pyo3(signature = (
    table, model, *, loss = d().loss.name(), weighting = d().weighting.name(),
    solver = d().solver.name(), starts = d().starts, finish = d().finish,
    sample_fraction = d().sample_fraction, theta_d_max = None, theta_max = None,
    per_channel = d().per_channel, seed = d().seed, fix = None, robust = d().robust.name(),
    robust_scale = None, energy_conserving = false, full_iters = d().full_iters.to_string(),
    explore_cells = DEFAULT_EXPLORE_CELLS, losses = d().losses.name(), distribution = None,
    masking = None, fresnel = None, normalization = None, progress = None
))]
#[allow(clippy::too_many_arguments)]
pub fn fit(
    py: Python<'_>,
    table: &Bound<'_, PyTable>,
    model: &Bound<'_, PyAny>,
    loss: &str,
    weighting: &str,
    solver: &str,
    starts: usize,
    finish: usize,
    sample_fraction: f64,
    theta_d_max: Option<f64>,
    theta_max: Option<f64>,
    per_channel: bool,
    seed: u64,
    fix: Option<Vec<String>>,
    robust: &str,
    robust_scale: Option<f64>,
    energy_conserving: bool,
    full_iters: String,
    explore_cells: usize,
    losses: &str,
    distribution: Option<&str>,
    masking: Option<&str>,
    fresnel: Option<&str>,
    normalization: Option<&str>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<(String, String, String, String)>> {
    let structure = Structure {
        distribution: opt_choice("distribution", distribution)?,
        masking: opt_choice("masking", masking)?,
        fresnel: opt_choice("fresnel", fresnel)?,
        normalization: opt_choice("normalization", normalization)?,
    };
    let fams = families_of(model, &structure)?;
    let settings = FitSettings {
        loss: choice("loss", loss)?,
        weighting: choice("weighting", weighting)?,
        solver: choice("solver", solver)?,
        starts,
        finish,
        sample_fraction,
        theta_d_max_deg: theta_d_max,
        theta_max_deg: theta_max,
        per_channel,
        seed,
        fix,
        robust: choice("robust", robust)?,
        robust_scale,
        albedo_max: energy_conserving.then_some(1.0),
        full_iters: full_iters
            .parse()
            .map_err(|e: String| errors::value(format!("full_iters: {e}")))?,
        explore_cells: Some(explore_cells),
        losses: choice("losses", losses)?,
    };
    let cfg = settings.config().map_err(errors::input)?;
    check_free(&fams, &cfg).map_err(errors::input)?;
    let t = table.get();
    let observer = progress.map(|callback| Progress {
        callback,
        stopped: AtomicBool::new(false),
        error: Mutex::new(None),
        family: Mutex::new(String::new()),
    });
    let outcomes = py.detach(|| {
        let data = FitData::from_table(&t.inner)
            .map_err(|e| errors::value(format!("{}: {}", t.label(), errors::message(&e))))?;
        match &observer {
            Some(o) => fit_each(&data, &fams, &cfg, o),
            None => fit_each(&data, &fams, &cfg, &()),
        }
        .map_err(errors::runtime)
    })?;
    if let Some(e) = observer.and_then(|o| o.error.lock().ok().and_then(|mut s| s.take())) {
        return Err(e);
    }
    outcomes
        .into_iter()
        .map(|o| {
            let params = o.params_file().map_err(errors::runtime)?;
            let record = o.record_file().map_err(errors::runtime)?;
            let iterations = o.record.stage_iterations().summary();
            Ok((o.label, params, record, iterations))
        })
        .collect()
}
