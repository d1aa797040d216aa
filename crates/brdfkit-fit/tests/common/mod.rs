//! Shared helpers of the fitter's integration tests.
#![allow(dead_code)]

use brdfkit_core::Model;
use brdfkit_fit::synth::{Coverage, synth_data};
use brdfkit_fit::{FitConfig, FitData, FitResult, fit};
use brdfkit_merl::Dims;
use serde_json::Value;

/// A model from JSON text (panics with the message on a bad description).
pub fn model(json: &str) -> Box<dyn Model> {
    brdfkit_models::from_json_str(json).unwrap_or_else(|e| panic!("{json}: {e}"))
}

/// True when the registry knows the family (models land while this crate is written).
pub fn registered(name: &str) -> bool {
    brdfkit_models::default_model(name).is_ok()
}

pub fn dims(a: i64, b: i64, c: i64) -> Dims {
    Dims::new(a, b, c).unwrap()
}

/// Cells of a grid with the model's values.
pub fn synth(m: &dyn Model, d: Dims, cov: Coverage) -> FitData {
    synth_data(m, d, cov).unwrap()
}

pub fn rel(a: f64, b: f64) -> f64 {
    let s = a.abs().max(b.abs());
    if s == 0.0 { 0.0 } else { (a - b).abs() / s }
}

/// Largest relative error of the fitted free parameters against the truth, and the
/// name of the worst one.
pub fn worst_param(res: &FitResult, truth: &dyn Model) -> (f64, String) {
    let fitted = res.fitted.channel_model(0);
    let names: Vec<String> = truth.param_specs().into_iter().map(|s| s.name).collect();
    let mut worst = (0.0, String::new());
    for (p, (a, b)) in fitted.params().iter().zip(truth.params()).enumerate() {
        if !res.record.params[p].free {
            continue;
        }
        let e = rel(*a, b);
        if e > worst.0 {
            worst = (e, names[p].clone());
        }
    }
    worst
}

/// The record as JSON text (for failure messages).
pub fn show(res: &FitResult) -> String {
    let mut v: Value = serde_json::to_value(&res.record).unwrap();
    v.as_object_mut().unwrap().remove("starts");
    serde_json::to_string(&v).unwrap()
}

/// Fits `start` to `data` with the default configuration and asserts that it converged
/// with every free parameter within `tol` (relative) of `truth`'s; returns the result,
/// the worst relative error and that parameter's name.
pub fn fit_recovers(
    start: &dyn Model,
    truth: &dyn Model,
    data: &FitData,
    tol: f64,
) -> (FitResult, f64, String) {
    let res = fit(start, data, &FitConfig::default(), None).unwrap();
    let (err, name) = worst_param(&res, truth);
    assert!(res.record.converged, "{}: {}", truth.name(), show(&res));
    assert!(
        err <= tol,
        "{}: parameter {name} off by {err:e} relative: {}",
        truth.name(),
        show(&res)
    );
    (res, err, name)
}

/// The central difference of `f` along coordinate `q` of `u`, with the step
/// 1e-6 · max(|u_q|, 1).
pub fn central_diff<T>(
    u: &nalgebra::DVector<f64>,
    q: usize,
    f: impl Fn(&nalgebra::DVector<f64>) -> T,
) -> T
where
    T: std::ops::Sub<Output = T> + std::ops::Div<f64, Output = T>,
{
    let h = 1e-6 * u[q].abs().max(1.0);
    let mut up = u.clone();
    up[q] += h;
    let mut um = u.clone();
    um[q] -= h;
    (f(&up) - f(&um)) / (2.0 * h)
}
