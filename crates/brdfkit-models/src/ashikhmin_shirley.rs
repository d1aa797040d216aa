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
//! ln(hz)/(hx² + hy²), where ln hz = ½ ln(1 − (hx² + hy²)) (as ln(1 + x), exact near the
//! normal, where the ratio tends to −½) below hx² + hy² = ½ and ln hz above (exact near
//! the horizon, where 1 − (hx² + hy²) cancels), both by the branch-free ln and exp of
//! `lanes` (within 1 ulp of the libm's), so the batch loops vectorise (`Lobe::terms`).
//! At h = n the power is 1 for every
//! exponent, including 0. h·k is taken as |wi + wo|/2, which equals wi·h = wo·h for unit
//! vectors and is symmetric in (wi, wo) to the last bit (wi·h is not, which would
//! break reciprocity at grazing pairs where h·k ~ 1e-16).
//!
//! **Reciprocal. Energy:** the diffuse term integrates to Rd (1 − Rs)(1 − (1 −
//! cos θ/2)⁵) ≤ (31/32) Rd (1 − Rs) (the 28/23 is chosen for this); the albedo is
//! bilinear in (Rd, Rs), so its maximum over [0, 1]² is at a corner, and the tests
//! measure the corners: see [`Model::conserves_energy`] and `docs/models.md`.

use crate::json;
use crate::lanes::{self, select};
use crate::pair::{
    PairGeom, PairTerms, lane_batch, pair_kernel_brdf, pair_terms_evals, pair_terms_kernel,
};
use crate::params::{DiffuseSpecular, ShapedLayout, shape_gradient};
use crate::shape::Shape;
use brdfkit_core::model::Domain;
use brdfkit_core::scattering::fresnel::schlick_weight;
use brdfkit_core::{GeomSlice, Model, ModelError, ParamSpec, Rgb};
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

    /// The model's [`PairTerms`] kernel: the lobe's constants hoisted.
    #[inline(always)]
    fn lanes(&self) -> Kernel {
        let (nu, nv) = self.n.xy();
        Kernel {
            rho_d: self.rho_d,
            rho_s: self.rho_s,
            n: self.n,
            lobe: Lobe {
                nu,
                nv,
                norm: ((nu + 1.0) * (nv + 1.0)).sqrt() / (8.0 * PI),
                du: 0.5 / (nu + 1.0),
                dv: 0.5 / (nv + 1.0),
            },
        }
    }

    /// Value and (optionally) gradient for one pair.
    #[inline(always)]
    fn kernel(&self, p: PairGeom, grad: Option<&mut [Rgb; MAXP]>) -> Rgb {
        pair_terms_kernel(&self.lanes(), p, grad)
    }

    /// `eval_batch` (`grad` None) and `eval_grad_batch` as lane loops.
    fn batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: Option<&mut [Rgb]>) {
        lane_batch(&self.lanes(), self.num_params(), g, out, grad);
    }
}

/// The model's parameters with its lobe's constants.
#[derive(Clone, Copy)]
struct Kernel {
    rho_d: Rgb,
    rho_s: Rgb,
    n: Shape,
    lobe: Lobe,
}

impl PairTerms<MAXP> for Kernel {
    type Terms = Terms;

    #[inline(always)]
    fn terms(&self, above: bool, wi: [f64; 3], wo: [f64; 3], h: [f64; 3]) -> Terms {
        let t = self.lobe.terms(wi, wo, h);
        let z = |x: f64| select(above, x, 0.0);
        Terms {
            dd: z(t.dd),
            p: z(t.p),
            w: z(t.w),
            p_u: z(t.p_u),
            p_v: z(t.p_v),
        }
    }

    /// Rd (1 − Rs) dd + P F per channel.
    #[inline(always)]
    fn value(&self, t: &Terms) -> Rgb {
        let m = self;
        let mut out = [0.0; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let rs = m.rho_s.0[c];
            let f = rs + (1.0 - rs) * t.w;
            *o = t.dd * m.rho_d.0[c] * (1.0 - rs) + t.p * f;
        }
        Rgb(out)
    }

    /// ∂f/∂Rd = dd (1 − Rs), ∂f/∂Rs = −dd Rd + P (1 − w) (each in its channel),
    /// ∂f/∂n_u = F ∂P/∂n_u, likewise n_v (`shape_gradient`).
    #[inline(always)]
    fn gradient(&self, t: &Terms) -> [Rgb; MAXP] {
        let m = self;
        let mut gr = [Rgb::ZERO; MAXP];
        let mut f = [0.0; 3];
        for c in 0..3 {
            let (rd, rs) = (m.rho_d.0[c], m.rho_s.0[c]);
            f[c] = rs + (1.0 - rs) * t.w;
            gr[c].0[c] = t.dd * (1.0 - rs);
            gr[3 + c].0[c] = -t.dd * rd + t.p * (1.0 - t.w);
        }
        shape_gradient(&m.n, Rgb(f), t.p_u, t.p_v, &mut gr);
        gr
    }
}

/// The constants of one model's lobe: the exponents, √((n_u + 1)(n_v + 1))/(8π) and
/// the ½/(n + 1) of ∂P/∂n.
#[derive(Clone, Copy)]
struct Lobe {
    nu: f64,
    nv: f64,
    norm: f64,
    du: f64,
    dv: f64,
}

/// The channel-free factors of one pair, from which [`Kernel`] assembles the value and
/// the gradient.
#[derive(Clone, Copy, Default)]
struct Terms {
    /// 28/(23π) (1 − (1 − cos θi/2)⁵)(1 − (1 − cos θo/2)⁵).
    dd: f64,
    /// P = √((n_u + 1)(n_v + 1))/(8π) (n·h)^e / ((h·k) max(cos θi, cos θo)).
    p: f64,
    /// Schlick's weight (1 − h·k)⁵.
    w: f64,
    /// ∂P/∂n_u = P (1/(2(n_u + 1)) + hx² ln(hz)/(hx² + hy²)).
    p_u: f64,
    /// ∂P/∂n_v, likewise.
    p_v: f64,
}

impl Lobe {
    /// The [`Terms`] of a pair with both directions above the horizon, without a branch
    /// or a library call (so a loop of it vectorises; finite garbage below the horizon,
    /// which callers select away). ln hz is ½ ln(1 − s²) below s² = hx² + hy² = ½ and
    /// ln hz above (module doc), taken by one [`lanes::ln_sum`]: of 1 − s² with its
    /// rounding error ([`lanes::one_plus`]), or of hz.
    #[inline(always)]
    fn terms(&self, wi: [f64; 3], wo: [f64; 3], h: [f64; 3]) -> Terms {
        let (hx2, hy2) = (h[0] * h[0], h[1] * h[1]);
        let s2 = hx2 + hy2;
        let near = s2 < 0.5;
        let (one_minus, c) = lanes::one_plus(-s2);
        let u = select(near, one_minus, h[2]);
        let c = select(near, c, 0.0);
        let ln_hz = select(near, 0.5, 1.0) * lanes::ln_sum(u, c);
        // ln(hz)/(hx² + hy²), −½ at h = n (its limit), where the power is 1.
        let r = select(s2 == 0.0, -0.5, ln_hz / s2);
        let pw = lanes::exp((self.nu * hx2 + self.nv * hy2) * r);
        let v = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let kh = 0.5 * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let p = self.norm * pw / (kh * lanes::max(wi[2], wo[2]));
        Terms {
            dd: DIFFUSE_NORM * diffuse_factor(wi[2]) * diffuse_factor(wo[2]),
            p,
            w: schlick_weight(kh),
            p_u: p * (self.du + hx2 * r),
            p_v: p * (self.dv + hy2 * r),
        }
    }
}

pair_kernel_brdf!(AshikhminShirley, isotropic: n);

model_name!(AshikhminShirley, "ashikhmin-shirley");

impl Model for AshikhminShirley {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    shaped_lobe_params!(n);

    pair_terms_evals!(MAXP);

    fn to_json(&self) -> Value {
        let o = LAYOUT.write_json(self.rho_d, self.rho_s, self.n);
        json!({"model": "ashikhmin-shirley", "params": o})
    }
}
