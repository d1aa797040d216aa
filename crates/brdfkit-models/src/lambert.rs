//! `lambert`: the ideal diffuse reflector.
//!
//! f_r(wi, wo) = ρd / π
//!
//! | parameter | JSON      | per channel | domain | default |
//! |-----------|-----------|-------------|--------|---------|
//! | ρd        | `rho_d`   | yes         | [0, 1] | 0.5     |
//!
//! Reciprocal; directional albedo exactly ρd for every direction, so energy is
//! conserved for ρd ≤ 1. J. H. Lambert, *Photometria*, 1760.

use crate::json;
use crate::params::{check_count, check_rgb};
use brdfkit_core::{Brdf, Columns, GeomSlice, Model, ModelError, ParamSpec, Rgb, Vec3};
use serde_json::{Value, json};
use std::f64::consts::FRAC_1_PI;

/// The domain of ρd.
pub use crate::params::RHO_DOMAIN;

/// The Lambertian BRDF ρd/π.
#[derive(Debug, Clone, PartialEq)]
pub struct Lambert {
    rho_d: Rgb,
}

impl Default for Lambert {
    fn default() -> Self {
        Lambert {
            rho_d: Rgb::splat(0.5),
        }
    }
}

impl Lambert {
    /// A Lambertian surface of albedo `rho_d` (each channel in [0, 1]).
    pub fn new(rho_d: Rgb) -> Result<Self, ModelError> {
        Lambert::default().with_rho_d(rho_d)
    }

    /// Sets ρd; each channel must lie in [0, 1].
    pub fn with_rho_d(mut self, rho_d: Rgb) -> Result<Self, ModelError> {
        self.rho_d = check_rgb("rho_d", rho_d, RHO_DOMAIN)?;
        Ok(self)
    }

    /// The albedo ρd.
    pub fn rho_d(&self) -> Rgb {
        self.rho_d
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        let o = json::params_object(params, "lambert")?;
        json::deny_unknown(&o, &["rho_d"], "lambert")?;
        Lambert::new(json::rgb_or(&o, "rho_d", 0.5, "lambert")?)
    }
}

impl Brdf for Lambert {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.rho_d * FRAC_1_PI
    }
}

model_name!(Lambert, "lambert");

impl Model for Lambert {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        ParamSpec::per_channel("rho_d", RHO_DOMAIN, 0.5).to_vec()
    }

    fn params(&self) -> Vec<f64> {
        self.rho_d.0.to_vec()
    }

    fn num_params(&self) -> usize {
        3
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        check_count(3, p.len())?;
        *self = self.clone().with_rho_d(Rgb::new(p[0], p[1], p[2]))?;
        Ok(())
    }

    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb {
        grad[..3].fill(Rgb::ZERO);
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        for (c, g) in grad[..3].iter_mut().enumerate() {
            g[c] = FRAC_1_PI;
        }
        self.rho_d * FRAC_1_PI
    }

    /// Only the horizon test: cos θi and cos θo.
    fn geometry_columns(&self) -> Columns {
        Columns::WI_Z | Columns::WO_Z
    }

    fn eval_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb]) {
        let f = self.rho_d * FRAC_1_PI;
        for ((o, &ci), &co) in out.iter_mut().zip(g.wi_z).zip(g.wo_z) {
            *o = if ci > 0.0 && co > 0.0 { f } else { Rgb::ZERO };
        }
    }

    fn eval_grad_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: &mut [Rgb]) {
        let n = g.len();
        self.eval_batch(g, out);
        for c in 0..3 {
            let mut d = Rgb::ZERO;
            d[c] = FRAC_1_PI;
            for k in 0..n {
                grad[c * n + k] = if g.wi_z[k] > 0.0 && g.wo_z[k] > 0.0 {
                    d
                } else {
                    Rgb::ZERO
                };
            }
        }
    }

    fn to_json(&self) -> Value {
        json!({"model": "lambert", "params": {"rho_d": json::rgb_value(self.rho_d)}})
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::*;
    use brdfkit_core::direction::spherical;
    use brdfkit_core::quadrature::{AlbedoQuadrature, directional_albedo};

    fn model() -> Lambert {
        Lambert::new(Rgb::new(0.2, 0.5, 0.9)).unwrap()
    }

    #[test]
    fn value_is_rho_over_pi() {
        let f = model().eval(&spherical(0.3, 0.0), &spherical(1.0, 2.0));
        assert_eq!(f, Rgb::new(0.2, 0.5, 0.9) / std::f64::consts::PI);
    }

    #[test]
    fn builder_rejects_out_of_domain_albedo() {
        let e = Lambert::new(Rgb::new(0.2, 1.5, 0.1)).unwrap_err();
        assert!(e.to_string().contains("rho_d.g"), "{e}");
        assert!(Lambert::new(Rgb::new(f64::NAN, 0.1, 0.1)).is_err());
        let mut m = model();
        assert!(m.set_params(&[0.1, -0.1, 0.1]).is_err());
        assert_eq!(
            m,
            model(),
            "a rejected set_params leaves the model unchanged"
        );
    }

    #[test]
    fn albedo_equals_rho() {
        for &t in &[0.0, 0.7, 1.4] {
            let a = directional_albedo(&model(), &spherical(t, 0.0), &AlbedoQuadrature::default());
            assert!(
                (a - model().rho_d()).0.iter().all(|e| e.abs() < 1e-6),
                "{a:?}"
            );
        }
    }

    #[test]
    fn shared_checks() {
        let m = model();
        // The shared set (on 300 pairs of seed 1, the 200 below among them), plus exact
        // reciprocity: f does not depend on the directions at all.
        assert_shared_checks(&m, 1);
        assert_reciprocal(&m, &random_pairs(1, 200), 0.0);
        assert_nonnegative(&m, &dense_grid_pairs(20, 8));
        assert_finite_everywhere(&m, &hard_case_pairs());
    }

    #[test]
    fn json_round_trip() {
        let m = model();
        assert_json_round_trip(&m);
        assert!(crate::from_json_str(r#"{"model":"lambert","params":{"rho":0.5}}"#).is_err());
        let d = crate::default_model("lambert").unwrap();
        assert_eq!(d.params(), vec![0.5; 3]);
    }
}
