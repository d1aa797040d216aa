//! The lobe shape shared by the anisotropic models: one value (isotropic) or a pair
//! along the tangent x and the binormal y, with its parameter entries, checks and JSON
//! keys (`alpha` or `alpha_x`, `alpha_y` of `cook-torrance` and `ward`; `n` or `n_u`,
//! `n_v` of `ashikhmin-shirley`).

use crate::json;
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::{ModelError, ParamSpec};
use serde_json::{Map, Value};

/// A lobe-shape parameter that is either one number (isotropic) or a pair along the
/// tangent x and the binormal y (anisotropic): α or (αx, αy) of a microfacet lobe,
/// n or (n_u, n_v) of Ashikhmin-Shirley.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// The same value along both axes: one entry in the parameter vector.
    Isotropic(f64),
    /// (along x, along y): two entries.
    Anisotropic(f64, f64),
}

impl Shape {
    /// The values along x and y.
    #[inline]
    pub fn xy(&self) -> (f64, f64) {
        match *self {
            Shape::Isotropic(a) => (a, a),
            Shape::Anisotropic(x, y) => (x, y),
        }
    }

    /// The same value along x and y (an anisotropic shape may have it too): the lobe is
    /// then isotropic.
    pub fn is_symmetric(&self) -> bool {
        let (x, y) = self.xy();
        x == y
    }

    /// Entries in the parameter vector (1 or 2).
    pub fn len(&self) -> usize {
        match self {
            Shape::Isotropic(_) => 1,
            Shape::Anisotropic(..) => 2,
        }
    }

    /// Never empty; for clippy's `len_without_is_empty`.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Checks the value(s) against `domain`, naming `iso` or `x`/`y` in the error.
    pub(crate) fn check(
        self,
        iso: &str,
        x: &str,
        y: &str,
        domain: Domain,
    ) -> Result<Self, ModelError> {
        match self {
            Shape::Isotropic(a) => check_param(iso, a, domain).map(Shape::Isotropic),
            Shape::Anisotropic(a, b) => Ok(Shape::Anisotropic(
                check_param(x, a, domain)?,
                check_param(y, b, domain)?,
            )),
        }
    }

    /// Parameter specs: `iso`, or `x` and `y`.
    pub(crate) fn specs(
        &self,
        iso: &str,
        x: &str,
        y: &str,
        domain: Domain,
        def: f64,
    ) -> Vec<ParamSpec> {
        match self {
            Shape::Isotropic(_) => vec![ParamSpec::shared(iso, domain, def)],
            Shape::Anisotropic(..) => vec![
                ParamSpec::shared(x, domain, def),
                ParamSpec::shared(y, domain, def),
            ],
        }
    }

    /// The same kind of shape from parameter-vector entries.
    pub(crate) fn with_values(&self, p: &[f64]) -> Shape {
        match self {
            Shape::Isotropic(_) => Shape::Isotropic(p[0]),
            Shape::Anisotropic(..) => Shape::Anisotropic(p[0], p[1]),
        }
    }

    /// Appends the values to a parameter vector.
    pub(crate) fn push_to(&self, v: &mut Vec<f64>) {
        match *self {
            Shape::Isotropic(a) => v.push(a),
            Shape::Anisotropic(x, y) => {
                v.push(x);
                v.push(y);
            }
        }
    }

    /// Reads `iso` or (`x`, `y`) from a params object; both forms at once is an error,
    /// absent values take `def`, and neither present gives `Isotropic(def)`.
    pub(crate) fn from_json(
        o: &Map<String, Value>,
        keys: (&str, &str, &str),
        def: f64,
        model: &str,
    ) -> Result<Self, ModelError> {
        let (iso, x, y) = keys;
        let has_xy = o.contains_key(x) || o.contains_key(y);
        if o.contains_key(iso) && has_xy {
            return Err(ModelError::Invalid(format!(
                "`{model}` takes either `{iso}` (isotropic) or `{x}` and `{y}` (anisotropic), not both"
            )));
        }
        if has_xy {
            Ok(Shape::Anisotropic(
                json::number_or(o, x, def, model)?,
                json::number_or(o, y, def, model)?,
            ))
        } else {
            Ok(Shape::Isotropic(json::number_or(o, iso, def, model)?))
        }
    }

    /// Writes the value(s) into a params object.
    pub(crate) fn to_json(self, o: &mut Map<String, Value>, keys: (&str, &str, &str)) {
        match self {
            Shape::Isotropic(a) => {
                o.insert(keys.0.into(), a.into());
            }
            Shape::Anisotropic(x, y) => {
                o.insert(keys.1.into(), x.into());
                o.insert(keys.2.into(), y.into());
            }
        }
    }
}
