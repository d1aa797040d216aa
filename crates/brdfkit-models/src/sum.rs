//! `sum`: a sum of models is a model — a diffuse term plus one or two specular lobes,
//! so a fit can use mixtures.
//!
//! f_r(wi, wo) = Σᵢ fᵢ(wi, wo)
//!
//! JSON: `{"model": "sum", "params": {"terms": [{model json}, {model json}, ...]}}`, each
//! term any model of the contract (built by [`crate::from_json`], so sums nest). The flat
//! parameter vector is the concatenation of the terms' vectors, each name prefixed by
//! `terms[i].` (`terms[0].rho_d.r`, `terms[1].n`, …), and so is the gradient.
//!
//! Default (absent `terms`): Lambert ρd = 0.4 plus two plausible-Phong lobes,
//! (ρd, ρs, n) = (0.05, 0.2, 10) and (0.05, 0.1, 500): albedo parameters summing to 0.8.
//!
//! Flags, combined honestly:
//! - [`Model::is_reciprocal`]: true iff every term is reciprocal (a sum of symmetric
//!   functions is symmetric; one asymmetric term makes the sum asymmetric).
//! - [`Model::conserves_energy`]: true iff every term does. The albedo of a sum is the
//!   sum of the terms' albedos and each conserving term's albedo is bounded by its own
//!   albedo parameters (ρd + ρs, or ρd for `lambert`), so the sum's directional albedo is
//!   ≤ 1 whenever, per channel, the albedo parameters of **all terms together** add up to
//!   at most 1 — not merely each term's. With one non-conserving term the sum promises
//!   nothing.
//!
//! Identifiability: diffuse parts of several terms add up (`lambert` ρd and a
//! `plausible-phong` ρd are indistinguishable); a fit should keep all but one fixed.

use crate::json;
use brdfkit_core::{Brdf, GeomSlice, Model, ModelError, ParamSpec, Rgb, Vec3};
use serde_json::{Value, json};

/// A sum of models.
#[derive(Debug, Clone)]
pub struct Sum {
    terms: Vec<Box<dyn Model>>,
    /// Offset of term i's parameters in the flat vector; `offsets[len]` is the total.
    offsets: Vec<usize>,
}

impl Default for Sum {
    fn default() -> Self {
        Sum::from_params_json(&default_terms_json()).expect("the default terms are valid")
    }
}

/// The default terms (module doc).
fn default_terms_json() -> Value {
    json!({"terms": [
        {"model": "lambert", "params": {"rho_d": 0.4}},
        {"model": "plausible-phong", "params": {"rho_d": 0.05, "rho_s": 0.2, "n": 10.0}},
        {"model": "plausible-phong", "params": {"rho_d": 0.05, "rho_s": 0.1, "n": 500.0}},
    ]})
}

/// Prefixes the parameter named in an error with `terms[i].`.
fn in_term(i: usize, e: ModelError) -> ModelError {
    match e {
        ModelError::OutOfDomain {
            name,
            value,
            domain,
        } => ModelError::OutOfDomain {
            name: format!("terms[{i}].{name}"),
            value,
            domain,
        },
        ModelError::Invalid(m) => ModelError::Invalid(format!("`terms[{i}]` of `sum`: {m}")),
        ModelError::ParamCount { expected, got } => ModelError::Invalid(format!(
            "`terms[{i}]` of `sum`: expected {expected} parameters, got {got}"
        )),
    }
}

impl Sum {
    /// The sum of `terms` (at least one).
    pub fn new(terms: Vec<Box<dyn Model>>) -> Result<Self, ModelError> {
        if terms.is_empty() {
            return Err(ModelError::Invalid(
                "`terms` of `sum` must hold at least one model".into(),
            ));
        }
        let mut offsets = Vec::with_capacity(terms.len() + 1);
        let mut o = 0;
        for t in &terms {
            offsets.push(o);
            o += t.num_params();
        }
        offsets.push(o);
        Ok(Sum { terms, offsets })
    }

    /// Appends a term.
    pub fn with_term(self, term: Box<dyn Model>) -> Result<Self, ModelError> {
        let mut terms = self.terms;
        terms.push(term);
        Sum::new(terms)
    }

    /// The terms.
    pub fn terms(&self) -> &[Box<dyn Model>] {
        &self.terms
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        let o = json::params_object(params, "sum")?;
        json::deny_unknown(&o, &["terms"], "sum")?;
        match o.get("terms") {
            None => Ok(Sum::default()),
            Some(Value::Array(a)) => {
                let terms = a
                    .iter()
                    .enumerate()
                    .map(|(i, t)| crate::from_json(t).map_err(|e| in_term(i, e)))
                    .collect::<Result<Vec<_>, _>>()?;
                Sum::new(terms)
            }
            Some(v) => Err(ModelError::Invalid(format!(
                "`terms` of `sum` must be an array of model descriptions, found {}",
                json::kind(v)
            ))),
        }
    }

    /// The flat-vector range of term i.
    fn range(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }
}

impl Brdf for Sum {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        let mut f = Rgb::ZERO;
        for t in &self.terms {
            f += t.eval(wi, wo);
        }
        f
    }

    fn is_isotropic(&self) -> bool {
        self.terms.iter().all(|t| t.is_isotropic())
    }
}

impl Model for Sum {
    fn name(&self) -> &'static str {
        "sum"
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let mut v = Vec::with_capacity(self.num_params());
        for (i, t) in self.terms.iter().enumerate() {
            v.extend(t.param_specs().into_iter().map(|mut s| {
                s.name = format!("terms[{i}].{}", s.name);
                s
            }));
        }
        v
    }

    fn params(&self) -> Vec<f64> {
        self.terms.iter().flat_map(|t| t.params()).collect()
    }

    fn num_params(&self) -> usize {
        self.offsets[self.terms.len()]
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        if p.len() != self.num_params() {
            return Err(ModelError::ParamCount {
                expected: self.num_params(),
                got: p.len(),
            });
        }
        // Set every term on a copy first, so a rejected value leaves all terms unchanged.
        let mut terms = self.terms.clone();
        for (i, t) in terms.iter_mut().enumerate() {
            t.set_params(&p[self.range(i)]).map_err(|e| in_term(i, e))?;
        }
        self.terms = terms;
        Ok(())
    }

    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb {
        let mut f = Rgb::ZERO;
        for (i, t) in self.terms.iter().enumerate() {
            f += t.eval_grad(wi, wo, &mut grad[self.range(i)]);
        }
        f
    }

    fn eval_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb]) {
        let n = g.len();
        let out = &mut out[..n];
        self.terms[0].eval_batch(g, out);
        if self.terms.len() > 1 {
            // One scratch buffer per call, reused by every further term.
            let mut tmp = vec![Rgb::ZERO; n];
            for t in &self.terms[1..] {
                t.eval_batch(g, &mut tmp);
                for (o, v) in out.iter_mut().zip(&tmp) {
                    *o += *v;
                }
            }
        }
    }

    fn eval_grad_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: &mut [Rgb]) {
        let n = g.len();
        let out = &mut out[..n];
        // Term i's parameter-major block is exactly rows range(i) of the sum's gradient.
        let r0 = self.range(0);
        self.terms[0].eval_grad_batch(g, out, &mut grad[r0.start * n..r0.end * n]);
        if self.terms.len() > 1 {
            let mut tmp = vec![Rgb::ZERO; n];
            for (i, t) in self.terms.iter().enumerate().skip(1) {
                let r = self.range(i);
                t.eval_grad_batch(g, &mut tmp, &mut grad[r.start * n..r.end * n]);
                for (o, v) in out.iter_mut().zip(&tmp) {
                    *o += *v;
                }
            }
        }
    }

    fn to_json(&self) -> Value {
        let terms: Vec<Value> = self.terms.iter().map(|t| t.to_json()).collect();
        json!({"model": "sum", "params": {"terms": terms}})
    }

    fn clone_box(&self) -> Box<dyn Model> {
        Box::new(self.clone())
    }

    /// True iff every term is reciprocal.
    fn is_reciprocal(&self) -> bool {
        self.terms.iter().all(|t| t.is_reciprocal())
    }

    /// True iff every term conserves energy; then the albedo is ≤ 1 when the albedo
    /// parameters of all terms together add up to ≤ 1 per channel (module doc).
    fn conserves_energy(&self) -> bool {
        self.terms.iter().all(|t| t.conserves_energy())
    }
}
