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
//!   albedo parameters (ρd + ρs, or ρd for `lambert`, as each model documents), so the
//!   sum's directional albedo is ≤ 1 whenever, per channel, the albedo parameters of
//!   **all terms together** add up to at most 1 — not merely each term's. With one
//!   non-conserving term the sum promises nothing.
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
    /// Flat parameter names or groups a fit keeps at their start values unless asked
    /// (see [`Sum::with_fixed`]).
    fixed: Vec<String>,
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

/// Whether flat parameter `name` is `group` or one of its entries (`rho_d.r` of
/// `rho_d`).
fn in_group(name: &str, group: &str) -> bool {
    name == group || (name.starts_with(group) && name[group.len()..].starts_with('.'))
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
        Ok(Sum {
            terms,
            offsets,
            fixed: Vec::new(),
        })
    }

    /// Appends a term (the parameters held fixed stay so).
    pub fn with_term(self, term: Box<dyn Model>) -> Result<Self, ModelError> {
        let fixed = self.fixed;
        let mut terms = self.terms;
        terms.push(term);
        Ok(Sum {
            fixed,
            ..Sum::new(terms)?
        })
    }

    /// Marks parameters a fit keeps at their start values unless asked
    /// ([`ParamSpec::fit_by_default`] false), by flat name or group (`terms[1].rho_d`
    /// for its three channels). Why: the diffuse parts of several terms add up, so all
    /// but one must stay fixed for the fit to be identifiable (module doc). The mark
    /// is a fitting default, not a parameter: `to_json` does not carry it.
    pub fn with_fixed(mut self, names: &[&str]) -> Result<Self, ModelError> {
        let specs = self.param_specs();
        for &n in names {
            if !specs.iter().any(|s| in_group(&s.name, n)) {
                return Err(ModelError::Invalid(format!(
                    "`sum` has no parameter `{n}` to hold fixed"
                )));
            }
            self.fixed.push(n.to_string());
        }
        Ok(self)
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

model_name!(Sum, "sum");

impl Model for Sum {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let mut v = Vec::with_capacity(self.num_params());
        for (i, t) in self.terms.iter().enumerate() {
            v.extend(t.param_specs().into_iter().map(|mut s| {
                s.name = format!("terms[{i}].{}", s.name);
                if self.fixed.iter().any(|g| in_group(&s.name, g)) {
                    s.fit_by_default = false;
                }
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

    /// True iff every term is reciprocal.
    fn is_reciprocal(&self) -> bool {
        self.terms.iter().all(|t| t.is_reciprocal())
    }

    /// True iff every term conserves energy; then the albedo is ≤ 1 when the albedo
    /// parameters of all terms together add up to ≤ 1 per channel (module doc).
    fn conserves_energy(&self) -> bool {
        self.terms.iter().all(|t| t.conserves_energy())
    }

    /// True iff it holds for every term.
    fn subsample_optimum_holds(&self) -> bool {
        self.terms.iter().all(|t| t.subsample_optimum_holds())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::blinn_phong::BlinnPhong;
    use crate::lafortune::{Lafortune, LafortuneLobe};
    use crate::lambert::Lambert;
    use crate::oren_nayar::OrenNayar;
    use crate::phong::Phong;
    use crate::plausible_phong::PlausiblePhong;
    use crate::testing::*;
    use brdfkit_core::CloneModel;
    use brdfkit_core::GeometryBatch;
    use proptest::prelude::*;

    fn terms() -> Vec<Box<dyn Model>> {
        vec![
            Box::new(OrenNayar::new(Rgb::new(0.3, 0.2, 0.1), 0.3).unwrap()),
            Box::new(PlausiblePhong::new(Rgb::splat(0.05), Rgb::new(0.2, 0.3, 0.4), 25.0).unwrap()),
            Box::new(
                Lafortune::new(
                    Rgb::splat(0.01),
                    vec![LafortuneLobe::new(-1.05, 0.95, 200.0, Rgb::splat(5.0)).unwrap()],
                )
                .unwrap(),
            ),
        ]
    }

    fn model() -> Sum {
        Sum::new(terms()).unwrap()
    }

    #[test]
    fn value_and_gradient_are_the_terms_summed_and_concatenated() {
        let m = model();
        let t = terms();
        assert_eq!(m.num_params(), 4 + 7 + 9);
        let mut g = vec![Rgb::ZERO; m.num_params()];
        for (wi, wo) in random_pairs(17, 300).iter().chain(&hard_case_pairs()) {
            let f = m.eval_grad(wi, wo, &mut g);
            let mut want = Rgb::ZERO;
            let mut off = 0;
            for term in &t {
                let mut gt = vec![Rgb::ZERO; term.num_params()];
                want += term.eval_grad(wi, wo, &mut gt);
                assert_eq!(&g[off..off + gt.len()], &gt[..]);
                off += gt.len();
            }
            assert_eq!(f, want);
            assert_eq!(m.eval(wi, wo), want);
        }
        // The batch gradient holds each term's parameter-major block in place.
        let pairs = random_pairs(18, 50);
        let b = GeometryBatch::from_pairs(&pairs);
        let (mut out, mut grad) = (vec![Rgb::ZERO; 50], vec![Rgb::ZERO; 20 * 50]);
        m.eval_grad_batch(&b.as_slice(), &mut out, &mut grad);
        let (mut o1, mut g1) = (vec![Rgb::ZERO; 50], vec![Rgb::ZERO; 7 * 50]);
        t[1].eval_grad_batch(&b.as_slice(), &mut o1, &mut g1);
        assert_eq!(&grad[4 * 50..11 * 50], &g1[..]);
    }

    #[test]
    fn parameters_are_prefixed_and_validated() {
        let mut m = model();
        let names: Vec<_> = m.param_specs().into_iter().map(|s| s.name).collect();
        assert_eq!(names[0], "terms[0].rho_d.r");
        assert_eq!(names[3], "terms[0].sigma");
        assert_eq!(names[10], "terms[1].n");
        assert_eq!(names[14], "terms[2].lobes[0].cxy");
        assert!(
            !m.param_specs()[15].fit_by_default,
            "lafortune cz stays fixed"
        );
        let before = m.params();
        let mut p = before.clone();
        p[0] = 0.9; // valid, but the next one is not: nothing may change
        p[10] = -1.0;
        let e = m.set_params(&p).unwrap_err();
        assert!(e.to_string().contains("`terms[1].n`"), "{e}");
        assert_eq!(m.params(), before);
        assert!(m.set_params(&p[..5]).is_err());
        p[10] = 3.0;
        m.set_params(&p).unwrap();
        assert_eq!(m.params(), p);
        assert!(Sum::new(vec![]).is_err());
        let m2 = Sum::new(vec![Box::new(Lambert::default())])
            .unwrap()
            .with_term(Box::new(BlinnPhong::default()))
            .unwrap();
        assert_eq!(m2.num_params(), 10);
    }

    #[test]
    fn held_parameters_are_not_fitted_by_default_and_unknown_ones_are_errors() {
        let m = model()
            .with_fixed(&["terms[1].rho_d", "terms[0].sigma"])
            .unwrap();
        let specs = m.param_specs();
        let held: Vec<&str> = specs
            .iter()
            .filter(|s| !s.fit_by_default)
            .map(|s| s.name.as_str())
            .collect();
        // Lafortune's cz is fixed by its own spec; `terms[1].rho_d` is a group.
        assert_eq!(
            held,
            [
                "terms[0].sigma",
                "terms[1].rho_d.r",
                "terms[1].rho_d.g",
                "terms[1].rho_d.b",
                "terms[2].lobes[0].cz"
            ]
        );
        // A group is matched whole, not by prefix: `terms[1].rho` is not `rho_d`.
        let e = model().with_fixed(&["terms[1].rho"]).unwrap_err();
        assert!(e.to_string().contains("`terms[1].rho`"), "{e}");
        // The mark survives an appended term and a clone, not the JSON.
        let m2 = m.with_term(Box::new(Lambert::default())).unwrap();
        assert!(!m2.clone_box().param_specs()[4].fit_by_default);
        let back = Sum::from_params_json(&m2.to_json()["params"]).unwrap();
        assert!(back.param_specs()[4].fit_by_default);
    }

    #[test]
    fn flags_are_combined() {
        assert!(model().is_reciprocal());
        assert!(
            !model().conserves_energy(),
            "oren-nayar and lafortune do not promise it"
        );
        let pp = || Box::new(PlausiblePhong::default()) as Box<dyn Model>;
        let s = Sum::new(vec![Box::new(Lambert::default()), pp()]).unwrap();
        assert!(s.is_reciprocal() && s.conserves_energy() && s.is_isotropic());
        let s = s.with_term(Box::new(Phong::default())).unwrap();
        assert!(!s.is_reciprocal() && !s.conserves_energy());
        assert!(max_reciprocity_error(&s, &random_pairs(1, 200)) > 0.1);
        let s = Sum::new(vec![pp(), Box::new(BlinnPhong::default())]).unwrap();
        assert!(s.is_reciprocal() && !s.conserves_energy());
    }

    #[test]
    fn json_round_trip_nesting_and_errors() {
        let m = model();
        assert_json_round_trip(&m);
        let d = crate::default_model("sum").unwrap();
        assert_eq!(d.num_params(), 3 + 7 + 7);
        assert_eq!(d.params()[..3], [0.4, 0.4, 0.4]);
        let nested = json!({"model": "sum", "params": {"terms": [
            {"model": "lambert"},
            {"model": "sum", "params": {"terms": [{"model": "phong"}]}}
        ]}});
        let n = crate::from_json(&nested).unwrap();
        assert_eq!(n.param_specs()[3].name, "terms[1].terms[0].k_d.r");
        assert!(!n.is_reciprocal());
        for (bad, needle) in [
            (json!({"terms": []}), "at least one"),
            (json!({"terms": {"model": "lambert"}}), "`terms`"),
            (json!({"term": []}), "`term`"),
            (
                json!({"terms": [{"model": "lambert"}, {"model": "nope"}]}),
                "`terms[1]`",
            ),
            (
                json!({"terms": [{"model": "lambert"}, {"model": "phong", "params": {"n": -1}}]}),
                "`terms[1].n`",
            ),
            (
                json!({"terms": [{"model": "lambert", "params": {"x": 1}}]}),
                "`x`",
            ),
        ] {
            let e = Sum::from_params_json(&bad).unwrap_err();
            assert!(e.to_string().contains(needle), "{bad}: {e}");
        }
    }

    #[test]
    fn shared_checks() {
        let m = model();
        // Reciprocal, so the shared set checks reciprocity too.
        assert!(m.is_reciprocal());
        assert_shared_checks(&m, 19);
        assert_finite_everywhere(&m, &hard_case_pairs());
        let d = Sum::default();
        assert_paths_agree(&d, &random_pairs(19, 300), 0.0);
        assert_zero_below_horizon(&d);
    }

    #[test]
    fn hard_cases_stay_finite() {
        for n in [0.0, 1.0, 1e3, 1e6] {
            for sigma in [0.0, 1e-6, std::f64::consts::FRAC_PI_2] {
                let m = Sum::new(vec![
                    Box::new(OrenNayar::new(Rgb::splat(0.5), sigma).unwrap()),
                    Box::new(PlausiblePhong::new(Rgb::splat(0.1), Rgb::splat(0.4), n).unwrap()),
                    Box::new(BlinnPhong::new(Rgb::splat(0.1), Rgb::splat(0.4), n).unwrap()),
                ])
                .unwrap();
                assert_finite_everywhere(&m, &hard_case_pairs());
                assert_paths_agree(&m, &hard_case_pairs(), 0.0);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn gradient_matches_finite_differences(
            rho in 0.01f64..0.99, sigma in 0.01f64..1.5, s in 0.01f64..0.99,
            n1 in 0.5f64..100.0, n2 in 100.0f64..2000.0, seed in any::<u64>()
        ) {
            let m = Sum::new(vec![
                Box::new(OrenNayar::new(Rgb::new(rho, 0.5, 0.2), sigma).unwrap()),
                Box::new(PlausiblePhong::new(Rgb::splat(0.05), Rgb::new(s, 0.3, 0.1), n1).unwrap()),
                Box::new(BlinnPhong::new(Rgb::splat(0.05), Rgb::new(0.1, s, 0.3), n2).unwrap()),
            ])
            .unwrap();
            let pairs = random_pairs(seed, 10);
            assert_gradient_matches_fd(&m, &pairs, 1e-6, 1e-6);
            assert_paths_agree(&m, &pairs, 0.0);
        }
    }
}
