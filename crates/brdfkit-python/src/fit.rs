//! `brdfkit.fit`: `fit-brdf fit` from Python, through the same library calls
//! (`brdfkit_fit::families`: the model list, the settings, `fit_each`), with an
//! optional progress callback.

use crate::model::PyModel;
use crate::table::PyTable;
use crate::{errors, json_to_py};
use brdfkit_fit::config::{CLI_EXPLORE_CELLS, DEFAULT_FINISH};
use brdfkit_fit::families::{
    Family, FamilyObserver, FitSettings, Structure, check_free, families, fit_each,
};
use brdfkit_fit::{FitData, FitObserver, FitPlan, IterEvent, StartDone};
use pyo3::prelude::*;
use serde_json::json;
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// A named choice (`loss = "cbrt"`, ...) parsed by the library's own `FromStr`, whose
/// message names the choice and the accepted names.
fn choice<T: FromStr<Err = E>, E: std::fmt::Display>(s: &str) -> PyResult<T> {
    T::from_str(s).map_err(|e| errors::value(e.to_string()))
}

/// An optional named choice.
fn opt_choice<T: FromStr<Err = E>, E: std::fmt::Display>(s: Option<&str>) -> PyResult<Option<T>> {
    s.map(choice).transpose()
}

/// Forwards fit progress to a Python callable, one dict per event, from whichever
/// thread the event comes (the GIL is taken for the call only; the dict is the event's
/// JSON, so floats cross bit for bit). The first exception the
/// callable raises stops the forwarding and is raised when the fit returns.
struct Progress {
    callback: Py<PyAny>,
    stopped: AtomicBool,
    error: Mutex<Option<PyErr>>,
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
}

/// The progress of one family's fit.
struct FamilyProgress {
    shared: Arc<Progress>,
    family: String,
}

impl FitObserver for FamilyProgress {
    fn on_plan(&self, p: &FitPlan) {
        self.shared.send(
            json!({"event": "plan", "family": self.family, "starts": p.starts,
            "finish": p.finish, "passes": p.passes, "max_iters": p.max_iters, "cells": p.cells}),
        );
    }

    fn on_iter(&self, e: &IterEvent) {
        self.shared.send(
            json!({"event": "iter", "family": self.family, "start": e.start,
            "channel": e.channel, "iter": e.iter, "cost": e.cost, "best_cost": e.best_cost,
            "warm_up": e.warm_up}),
        );
    }

    fn on_start_done(&self, s: &StartDone) {
        self.shared.send(
            json!({"event": "start_done", "family": self.family, "start": s.start,
            "channel": s.channel, "loss": s.loss, "iterations": s.iterations,
            "termination": s.termination}),
        );
    }
}

/// Hands each family's fit a [`FamilyProgress`].
struct Families(Arc<Progress>);

impl FamilyObserver for Families {
    fn on_family_start(&self, _k: usize, _n: usize, f: &Family) -> Option<Arc<dyn FitObserver>> {
        Some(Arc::new(FamilyProgress {
            shared: Arc::clone(&self.0),
            family: f.label.clone(),
        }))
    }
}

/// The families to fit: a `Model`, or a comma-separated list of model names and model
/// JSON files (as `fit-brdf fit --model`) with the structural choices applied.
fn families_of(model: &Bound<'_, PyAny>, s: &Structure) -> PyResult<Vec<Family>> {
    if let Ok(m) = model.cast::<PyModel>() {
        if *s != Structure::default() {
            return Err(errors::value(
                "distribution, masking, fresnel and normalization apply to model names; \
                 a Model carries its own choices",
            ));
        }
        let m = m.get();
        return Ok(vec![Family {
            label: m.inner.name().to_string(),
            model: m.inner.clone_box(),
        }]);
    }
    let list: String = model.extract().map_err(|_| {
        errors::value("model: expected a model name, a list of names, a JSON file or a Model")
    })?;
    families(&list, s).map_err(errors::input)
}

/// Fits each model family to the table as `fit-brdf fit` does (same defaults); returns
/// (label, fitted model JSON, fit record JSON) per family.
#[pyfunction]
#[pyo3(signature = (
    table, model, *, loss = "cbrt", weighting = "solid-angle", solver = "lm", starts = 8,
    finish = DEFAULT_FINISH, sample_fraction = 1.0, theta_d_max = None, theta_max = None, per_channel = false,
    seed = 0, fix = None, robust = "none", robust_scale = None, energy_conserving = false,
    full_iters = "auto", explore_cells = CLI_EXPLORE_CELLS, distribution = None,
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
    full_iters: &str,
    explore_cells: usize,
    distribution: Option<&str>,
    masking: Option<&str>,
    fresnel: Option<&str>,
    normalization: Option<&str>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Vec<(String, String, String)>> {
    let structure = Structure {
        distribution: opt_choice(distribution)?,
        masking: opt_choice(masking)?,
        fresnel: opt_choice(fresnel)?,
        normalization: opt_choice(normalization)?,
    };
    let fams = families_of(model, &structure)?;
    let settings = FitSettings {
        loss: choice(loss)?,
        weighting: choice(weighting)?,
        solver: choice(solver)?,
        starts,
        finish,
        sample_fraction,
        theta_d_max_deg: theta_d_max,
        theta_max_deg: theta_max,
        per_channel,
        seed,
        fix,
        robust: choice(robust)?,
        robust_scale,
        albedo_max: energy_conserving.then_some(1.0),
        full_iters: full_iters
            .parse()
            .map_err(|e: String| errors::value(format!("full_iters: {e}")))?,
        explore_cells: Some(explore_cells),
    };
    let cfg = settings.config().map_err(errors::input)?;
    check_free(&fams, &cfg).map_err(errors::input)?;
    let t = table.get();
    let observer = progress.map(|callback| {
        Arc::new(Progress {
            callback,
            stopped: AtomicBool::new(false),
            error: Mutex::new(None),
        })
    });
    let outcomes = py.detach(|| {
        let data = FitData::from_table(&t.inner)
            .map_err(|e| errors::value(format!("{}: {}", t.label(), errors::message(&e))))?;
        match &observer {
            Some(o) => fit_each(&data, &fams, &cfg, &Families(Arc::clone(o))),
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
            let params = serde_json::to_string(&o.params).map_err(errors::runtime)?;
            let record = serde_json::to_string(&o.record).map_err(errors::runtime)?;
            Ok((o.label, params, record))
        })
        .collect()
}
