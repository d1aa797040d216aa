//! `ashikhmin-shirley`: the anisotropic Phong BRDF of Ashikhmin and Shirley, with its
//! coupled diffuse term.
//!
//! M. Ashikhmin and P. Shirley, "An Anisotropic Phong BRDF Model", Journal of Graphics
//! Tools 5(2), 2000, eqs. 4, 5 and 6 (with h = (wi + wo)/|wi + wo|, k = wi or wo, the
//! tangent x carrying n_u and the binormal y carrying n_v):
//!
//! f_r = ρ_spec + ρ_diff,
//!
//! ρ_spec = √((n_u + 1)(n_v + 1)) / (8π) · (n·h)^((n_u hx² + n_v hy²)/(1 − hz²))
//!          / ((h·k) max(cos θi, cos θo)) · F(h·k),
//! F(c) = Rs + (1 − Rs)(1 − c)⁵ (Schlick),
//!
//! ρ_diff = 28 Rd / (23π) · (1 − Rs) · (1 − (1 − cos θi/2)⁵) · (1 − (1 − cos θo/2)⁵),
//!
//! per channel with Rd = `rho_d`, Rs = `rho_s`.
//!
//! | parameter | JSON | per channel | domain | default |
//! |-----------|------|-------------|--------|---------|
//! | Rd | `rho_d` | yes | [0, 1] | 0.3 |
//! | Rs | `rho_s` | yes | [0, 1] (a Fresnel reflectance; 1 − Rs weights the diffuse term) | 0.3 |
//! | n (isotropic) | `n` | no | [0, 1e6] | 100 |
//! | n_u, n_v (anisotropic) | `n_u`, `n_v` | no | [0, 1e6] | 100 |
//!
//! The flat parameter vector is `rho_d.{r,g,b}`, `rho_s.{r,g,b}`, then `n` or `n_u`,
//! `n_v`.
//!
//! **Evaluation.** The power is exp(e · ln hz) with e · ln hz = (n_u hx² + n_v hy²) ·
//! ln(hz)/(hx² + hy²), where ln hz = ½ ln(1 − (hx² + hy²)) (by `ln_1p`, exact near the
//! normal, where the ratio tends to −½) below hx² + hy² = ½ and ln hz above (exact near
//! the horizon, where 1 − (hx² + hy²) cancels). At h = n the power is 1 for every
//! exponent, including 0. h·k is taken as |wi + wo|/2, which equals wi·h = wo·h for unit
//! vectors and is symmetric in (wi, wo) to the last bit (wi·h is not, which would
//! break reciprocity at grazing pairs where h·k ~ 1e-16).
//!
//! **Reciprocal. Energy:** the diffuse term integrates to Rd (1 − Rs)(1 − (1 −
//! cos θ/2)⁵) ≤ (31/32) Rd (1 − Rs) (the 28/23 is chosen for this); the albedo is
//! bilinear in (Rd, Rs), so its maximum over [0, 1]² is at a corner, and the tests
//! measure the corners: see [`Model::conserves_energy`] and `docs/models.md`.

use crate::json;
use crate::pair::{PairGeom, pair_kernel_brdf, pair_kernel_evals};
use crate::params::{DiffuseSpecular, ShapedLayout, above_horizon, shape_gradient};
use crate::shape::Shape;
use brdfkit_core::model::Domain;
use brdfkit_core::scattering::fresnel::schlick_weight;
use brdfkit_core::{Model, ModelError, ParamSpec, Rgb};
use serde_json::{Value, json};
use std::f64::consts::PI;

/// The domain of Rd and Rs.
pub use crate::params::RHO_DOMAIN;
/// The domain of the exponents.
pub const N_DOMAIN: Domain = Domain::closed(0.0, 1e6);

/// The parameter layout: Rd, Rs (default 0.3), then n or n_u, n_v (default 100).
const LAYOUT: ShapedLayout = ShapedLayout {
    rhos: DiffuseSpecular::bounded_albedos(0.3, 0.3),
    keys: ("n", "n_u", "n_v"),
    domain: N_DOMAIN,
    default: 100.0,
};

/// 28/(23π), the diffuse normalisation.
const DIFFUSE_NORM: f64 = 28.0 / (23.0 * PI);

/// Largest parameter count: 3 Rd + 3 Rs + 2 exponents.
const MAXP: usize = 8;

/// The Ashikhmin-Shirley BRDF.
#[derive(Debug, Clone, PartialEq)]
pub struct AshikhminShirley {
    rho_d: Rgb,
    rho_s: Rgb,
    n: Shape,
}

impl Default for AshikhminShirley {
    fn default() -> Self {
        AshikhminShirley {
            rho_d: Rgb::splat(LAYOUT.rhos.defaults.0),
            rho_s: Rgb::splat(LAYOUT.rhos.defaults.1),
            n: Shape::Isotropic(LAYOUT.default),
        }
    }
}

/// 1 − (1 − c/2)⁵, the diffuse term's angular factor.
#[inline]
fn diffuse_factor(c: f64) -> f64 {
    let m = 1.0 - 0.5 * c;
    let m2 = m * m;
    1.0 - m2 * m2 * m
}

impl AshikhminShirley {
    /// The default model (see the module table).
    pub fn new() -> Self {
        Self::default()
    }

    shaped_lobe_builders! {
        done: std::convert::identity,
        rho_d: "Sets Rd (each channel in [0, 1]).", "Rd.",
        rho_s: "Sets Rs (each channel in [0, 1]).", "Rs.",
        n: "Sets the exponents.", "The exponents.",
        with_n(n): "An isotropic exponent n in [0, 1e6].",
        with_n_uv(n_u, n_v): "Anisotropic exponents (n_u along the tangent x, n_v), each in [0, 1e6].",
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        const M: &str = "ashikhmin-shirley";
        let o = json::params_object(params, M)?;
        json::deny_unknown(&o, &LAYOUT.json_keys(), M)?;
        AshikhminShirley::new().with_lobes_from_json(&o, M)
    }

    /// Value and (optionally) gradient for one pair; see `CookTorrance::kernel`.
    #[inline(always)]
    fn kernel(&self, p: PairGeom, grad: Option<&mut [Rgb; MAXP]>) -> Rgb {
        let PairGeom { wi, wo, h, .. } = p;
        let Some(grad) = above_horizon(&wi, &wo, grad) else {
            return Rgb::ZERO;
        };
        let (nu, nv) = self.n.xy();
        let (hx2, hy2) = (h[0] * h[0], h[1] * h[1]);
        let s2 = hx2 + hy2;
        // ln(hz)/(hx² + hy²): see the module doc. h.z > 0 whenever both directions are
        // above the horizon, so ln(hz) is finite.
        let r = if s2 == 0.0 {
            -0.5
        } else if s2 < 0.5 {
            0.5 * (-s2).ln_1p() / s2
        } else {
            h[2].ln() / s2
        };
        let pw = ((nu * hx2 + nv * hy2) * r).exp();
        let u = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let kh = 0.5 * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
        let norm = ((nu + 1.0) * (nv + 1.0)).sqrt() / (8.0 * PI);
        let p = norm * pw / (kh * wi[2].max(wo[2]));
        let w = schlick_weight(kh);
        let dd = DIFFUSE_NORM * diffuse_factor(wi[2]) * diffuse_factor(wo[2]);
        let mut out = Rgb::ZERO;
        let mut f = [0.0; 3];
        for c in 0..3 {
            let rs = self.rho_s[c];
            f[c] = rs + (1.0 - rs) * w;
            out[c] = dd * self.rho_d[c] * (1.0 - rs) + p * f[c];
        }
        if let Some(gr) = grad {
            *gr = [Rgb::ZERO; MAXP];
            for c in 0..3 {
                gr[c][c] = dd * (1.0 - self.rho_s[c]);
                gr[3 + c][c] = -dd * self.rho_d[c] + p * (1.0 - w);
            }
            // ∂P/∂n_u = P (1/(2(n_u + 1)) + hx² ln(hz)/(hx² + hy²)), likewise n_v.
            let p_u = p * (0.5 / (nu + 1.0) + hx2 * r);
            let p_v = p * (0.5 / (nv + 1.0) + hy2 * r);
            shape_gradient(&self.n, Rgb::new(f[0], f[1], f[2]), p_u, p_v, gr);
        }
        out
    }
}

pair_kernel_brdf!(AshikhminShirley, isotropic: n);

model_name!(AshikhminShirley, "ashikhmin-shirley");

impl Model for AshikhminShirley {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    shaped_lobe_params!(n);

    pair_kernel_evals!(MAXP);

    fn to_json(&self) -> Value {
        let o = LAYOUT.write_json(self.rho_d, self.rho_s, self.n);
        json!({"model": "ashikhmin-shirley", "params": o})
    }
}
