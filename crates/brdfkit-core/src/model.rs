//! Parametric models: the interface between an analytic BRDF and the fitter.
//!
//! A [`Model`] is a [`Brdf`] whose continuous parameters form a flat vector with names,
//! domains and a default start ([`ParamSpec`]). Structural choices (the microfacet
//! distribution, the Fresnel kind, the number of lobes) are fixed when the model is
//! built and are not part of the vector.
//!
//! Gradients are with respect to the physical parameters of that vector; the fitter
//! applies its own reparameterisation (log / logit) on top.

use crate::geometry::DirPairs;
use crate::{Brdf, GeomSlice, GeomSliceF32, GeometryBatch, Rgb, Vec3};
use std::fmt;
use thiserror::Error;

/// Errors of model construction and parameter handling.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ModelError {
    /// A parameter value outside its domain.
    #[error("parameter `{name}` = {value} is outside its domain {domain}")]
    OutOfDomain {
        /// The parameter.
        name: String,
        /// The value given.
        value: f64,
        /// Its domain.
        domain: Domain,
    },
    /// A parameter vector of the wrong length.
    #[error("expected {expected} parameters, got {got}")]
    ParamCount {
        /// Parameters the model has.
        expected: usize,
        /// Parameters given.
        got: usize,
    },
    /// A model description that does not parse or names unknown things.
    #[error("{0}")]
    Invalid(String),
}

/// The interval a parameter lives in. Infinite ends are allowed (always open).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Domain {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
    /// Whether the lower end is excluded.
    pub lo_open: bool,
    /// Whether the upper end is excluded.
    pub hi_open: bool,
}

impl Domain {
    /// [lo, hi]
    pub const fn closed(lo: f64, hi: f64) -> Self {
        Domain {
            lo,
            hi,
            lo_open: false,
            hi_open: false,
        }
    }
    /// (lo, hi)
    pub const fn open(lo: f64, hi: f64) -> Self {
        Domain {
            lo,
            hi,
            lo_open: true,
            hi_open: true,
        }
    }
    /// [lo, ∞)
    pub const fn at_least(lo: f64) -> Self {
        Domain {
            lo,
            hi: f64::INFINITY,
            lo_open: false,
            hi_open: true,
        }
    }
    /// (lo, ∞)
    pub const fn above(lo: f64) -> Self {
        Domain {
            lo,
            hi: f64::INFINITY,
            lo_open: true,
            hi_open: true,
        }
    }
    /// (-∞, ∞)
    pub const fn real() -> Self {
        Domain::open(f64::NEG_INFINITY, f64::INFINITY)
    }

    /// True when `v` is finite and inside the interval.
    pub fn contains(&self, v: f64) -> bool {
        if !v.is_finite() {
            return false;
        }
        let lo_ok = if self.lo_open {
            v > self.lo
        } else {
            v >= self.lo
        };
        let hi_ok = if self.hi_open {
            v < self.hi
        } else {
            v <= self.hi
        };
        lo_ok && hi_ok
    }
}

impl fmt::Display for Domain {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let end = |v: f64| {
            if v == f64::INFINITY {
                "inf".to_string()
            } else if v == f64::NEG_INFINITY {
                "-inf".to_string()
            } else {
                format!("{v}")
            }
        };
        write!(
            f,
            "{}{}, {}{}",
            if self.lo_open { '(' } else { '[' },
            end(self.lo),
            end(self.hi),
            if self.hi_open { ')' } else { ']' }
        )
    }
}

/// Checks `value` against `domain`, naming the parameter in the error.
pub fn check_param(name: &str, value: f64, domain: Domain) -> Result<f64, ModelError> {
    if domain.contains(value) {
        Ok(value)
    } else {
        Err(ModelError::OutOfDomain {
            name: name.to_string(),
            value,
            domain,
        })
    }
}

/// How a parameter couples to the colour channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParamRole {
    /// Affects only channel `0..3` (albedo-like: ρd, ρs, Schlick f0, eta, k).
    Channel(usize),
    /// Affects every channel (lobe shape: roughness, exponent, σ).
    Shared,
}

/// One entry of a model's flat parameter vector.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSpec {
    /// Name as in the JSON contract, with a channel suffix for per-channel entries
    /// (`rho_d.r`) and an index for lists (`lobes[1].n`).
    pub name: String,
    /// Which channels it acts on (per-channel albedo-like or shared).
    pub role: ParamRole,
    /// Where the model is defined; builders reject values outside.
    pub domain: Domain,
    /// A sensible default start for a fit.
    pub default: f64,
    /// False for parameters a fit keeps fixed unless asked (e.g. the complex index of
    /// refraction of a conductor, which trades off against ρs).
    pub fit_by_default: bool,
}

impl ParamSpec {
    /// A shared (lobe-shape) parameter, fitted by default.
    pub fn shared(name: impl Into<String>, domain: Domain, default: f64) -> Self {
        ParamSpec {
            name: name.into(),
            role: ParamRole::Shared,
            domain,
            default,
            fit_by_default: true,
        }
    }

    /// Three per-channel entries `name.r`, `name.g`, `name.b`, fitted by default.
    pub fn per_channel(name: &str, domain: Domain, default: f64) -> [Self; 3] {
        ["r", "g", "b"].map(|c| {
            let ch = match c {
                "r" => 0,
                "g" => 1,
                _ => 2,
            };
            ParamSpec {
                name: format!("{name}.{c}"),
                role: ParamRole::Channel(ch),
                domain,
                default,
                fit_by_default: true,
            }
        })
    }

    /// The same spec, not fitted by default.
    pub fn fixed(mut self) -> Self {
        self.fit_by_default = false;
        self
    }
}

/// The concrete type behind a `dyn Model`, for code that needs a model's typed
/// accessors (its structural choices, its blocks) instead of its name and JSON: see
/// [`downcast`]. Every `'static` type has it.
pub trait AsAny: std::any::Any {
    /// `self` as [`std::any::Any`].
    fn as_any(&self) -> &dyn std::any::Any;
}

impl<T: std::any::Any> AsAny for T {
    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

/// The model as its concrete type `T`, or None when it is another model.
///
/// Takes `&dyn Model`, not `&Box<dyn Model>`: the box itself is also `Any`, and asking
/// it would always answer None.
pub fn downcast<T: Model>(m: &dyn Model) -> Option<&T> {
    m.as_any().downcast_ref::<T>()
}

/// A boxed copy of a model (models are small; a fit clones one per candidate
/// parameter). Every `Clone` model has it, so no model writes it out.
pub trait CloneModel {
    /// `self`, boxed.
    fn clone_box(&self) -> Box<dyn Model>;
}

impl<T: Model + Clone> CloneModel for T {
    fn clone_box(&self) -> Box<dyn Model> {
        Box::new(self.clone())
    }
}

/// A parametric, differentiable BRDF model.
///
/// Every implementation must keep four paths numerically identical: [`Brdf::eval`],
/// [`Model::eval_grad`] (value part), [`Model::eval_batch`] and
/// [`Model::eval_grad_batch`]; and return exactly 0 (value and gradient) for a pair
/// with either direction at or below the horizon.
pub trait Model: Brdf + fmt::Debug + AsAny + CloneModel {
    /// The model's name in the JSON contract (`"cook-torrance"`).
    fn name(&self) -> &'static str;

    /// Names, domains and default start of the flat parameter vector.
    fn param_specs(&self) -> Vec<ParamSpec>;

    /// Current values of the flat parameter vector.
    fn params(&self) -> Vec<f64>;

    /// Number of parameters.
    fn num_params(&self) -> usize {
        self.param_specs().len()
    }

    /// Replaces every parameter; rejects a wrong length or an out-of-domain value
    /// (naming the parameter) and then leaves the model unchanged.
    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError>;

    /// f_r and its gradient: `grad[p]` is ∂f/∂param_p per channel (`grad.len()` ==
    /// `num_params()`).
    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb;

    /// f_r for every pair of a precomputed batch: `out[k]` for pair k.
    fn eval_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb]);

    /// The geometry columns [`eval_batch`](Model::eval_batch) and
    /// [`eval_grad_batch`](Model::eval_grad_batch) read: a pass over cells whose
    /// geometry is computed where read (a table's) computes only these, and gives the
    /// others as NaN. The default, every column, is always right; a model that declares
    /// fewer must give the same bits from them alone (its tests check it with the
    /// others NaN).
    fn geometry_columns(&self) -> crate::Columns {
        crate::Columns::ALL
    }

    /// f_r and gradients for a batch. `grad` is parameter-major:
    /// `grad[p * g.len() + k]` is ∂f/∂param_p at pair k.
    fn eval_grad_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: &mut [Rgb]);

    /// f_r in single precision for every pair of a float32 batch, into one plane per
    /// channel: `out[c][k]` is channel c at pair k (each plane at least `g.len()` long).
    ///
    /// For bulk evaluation where float32 is enough (previews, model → table at the
    /// precision of measured data): twice the vector lanes and half the memory traffic
    /// of [`Model::eval_batch`]. The default widens runs of pairs to `f64`, calls
    /// [`Model::eval_batch`] and rounds the result, so every model has the path and its
    /// only error is the rounding of the geometry and of f_r; a model with a native
    /// float32 kernel overrides it (`cook-torrance` with GGX) and documents its error.
    fn eval_batch_f32(&self, g: &GeomSliceF32<'_>, out: [&mut [f32]; 3]) {
        eval_batch_f32_widened(self, g, out)
    }

    /// f_r of a run of raw direction pairs into `out[k]` through the model's own fused
    /// kernel, one that reads the directions itself (the half vector computed in the
    /// loop) instead of a filled [`Geometry`](crate::Geometry) run: one pass over memory
    /// instead of a fill, the kernel and a copy. Returns false, writing nothing, when
    /// the model (or its configuration) has none; the bulk driver
    /// (`brdfkit_models::raw`) then fills a geometry run
    /// ([`Geometry::fill_from_pairs`](crate::Geometry::fill_from_pairs)) and calls
    /// [`Model::eval_batch`]. An override must give exactly `eval_batch`'s bits.
    /// `out` is as long as `dirs`.
    fn eval_dirs_fused(&self, dirs: DirPairs<'_, f64>, out: &mut [Rgb]) -> bool {
        let _ = (dirs, out);
        false
    }

    /// [`Model::eval_dirs_fused`] into `[r, g, b]` rows.
    fn eval_dirs_fused_rows(&self, dirs: DirPairs<'_, f64>, out: &mut [[f64; 3]]) -> bool {
        let _ = (dirs, out);
        false
    }

    /// [`Model::eval_dirs_fused`] in single precision, into `[r, g, b]` rows; the
    /// fallback is [`Model::eval_batch_f32`], whose error bound an override keeps.
    fn eval_dirs_fused_f32(&self, dirs: DirPairs<'_, f32>, out: &mut [[f32; 3]]) -> bool {
        let _ = (dirs, out);
        false
    }

    /// The model in the JSON contract: `{"model": name, "params": {...}}`.
    fn to_json(&self) -> serde_json::Value;

    /// f(wi, wo) = f(wo, wi) for all parameters. The original Phong model does not.
    fn is_reciprocal(&self) -> bool {
        true
    }

    /// Directional albedo ≤ 1 whenever the model's albedo parameters allow it
    /// (documented per model). The original Phong model makes no such promise.
    fn conserves_energy(&self) -> bool {
        true
    }

    /// A fit's optimum on a stratified subsample of a measured table is (measured to
    /// be) its optimum on every cell, so a fit may evaluate it there instead of
    /// iterating on all cells (`brdfkit_fit`'s `FullIters::Auto`). Ward with Dür's
    /// normalisation does not: its subsample optimum lies 2.3–4.6 % above on three of
    /// seven measured materials (docs/fitting.md; likely because its 1/(cos θi cos θo)
    /// weighs grazing pairs, which the subsample holds thinly).
    fn subsample_optimum_holds(&self) -> bool {
        true
    }
}

/// The default [`Model::eval_batch_f32`]: widens runs of 1024 pairs to `f64`, calls
/// [`Model::eval_batch`] and rounds f_r to `f32`. Public so that a model whose native
/// kernel covers only some configurations can fall back to it for the others.
pub fn eval_batch_f32_widened<M: Model + ?Sized>(
    m: &M,
    g: &GeomSliceF32<'_>,
    out: [&mut [f32]; 3],
) {
    const RUN: usize = 1024;
    let n = g.len();
    let mut wide = GeometryBatch::with_capacity(RUN.min(n));
    let mut vals = vec![Rgb::ZERO; RUN.min(n)];
    let [r, gg, b] = out;
    let mut start = 0;
    while start < n {
        let end = (start + RUN).min(n);
        wide.clear();
        g.widen_into(start..end, &mut wide);
        let v = &mut vals[..end - start];
        m.eval_batch(&wide.as_slice(), v);
        for (k, x) in v.iter().enumerate() {
            r[start + k] = x[0] as f32;
            gg[start + k] = x[1] as f32;
            b[start + k] = x[2] as f32;
        }
        start = end;
    }
}

impl Clone for Box<dyn Model> {
    fn clone(&self) -> Self {
        self.clone_box()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn domains_check_and_print() {
        let d = Domain::closed(0.0, 1.0);
        assert!(d.contains(0.0) && d.contains(1.0) && !d.contains(1.0000001));
        assert!(!d.contains(f64::NAN));
        let a = Domain::above(0.0);
        assert!(!a.contains(0.0) && a.contains(1e-300) && !a.contains(f64::INFINITY));
        assert_eq!(format!("{a}"), "(0, inf)");
        assert_eq!(format!("{d}"), "[0, 1]");
        let e = check_param("alpha", -1.0, a).unwrap_err();
        assert_eq!(
            e.to_string(),
            "parameter `alpha` = -1 is outside its domain (0, inf)"
        );
    }

    #[test]
    fn per_channel_specs_name_their_channel() {
        let s = ParamSpec::per_channel("rho_d", Domain::closed(0.0, 1.0), 0.5);
        assert_eq!(s[1].name, "rho_d.g");
        assert_eq!(s[2].role, ParamRole::Channel(2));
    }
}
