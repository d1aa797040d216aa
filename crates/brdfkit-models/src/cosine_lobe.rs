//! The machinery of the Phong family: a diffuse base plus one cosine-power lobe,
//!
//! f_r(wi, wo) = D · d + s · L(n; c, cos θi),   L = N(n, cos θi) · max(0, c)ⁿ,
//!
//! with d and s per channel, one exponent n, D = 1/π when d is an albedo (1 for the
//! original Phong model, whose kd is a BRDF value), c the cosine the lobe is raised on
//! (about the mirror direction or the half vector, [`Cosine`]) and N the lobe's
//! normalisation. `phong`, `plausible-phong` and `blinn-phong` differ only in D, c, N
//! and their parameter table; each states them, with its formula and citation, in its
//! own module through a [`LobeKind`]. Everything else lives here once: the cosine power
//! and its n-derivative, the builder's validation, the parameter vector and its specs,
//! the JSON contract, and the four evaluation paths of [`Model`].
//!
//! The parameter vector is `d.{r,g,b}`, `s.{r,g,b}`, `n`; the gradient is
//! ∂f/∂d = D, ∂f/∂s = L (each in its own channel) and ∂f/∂n = s ∂L/∂n.

use crate::json;
use crate::params::{DiffuseSpecular, channel, check_count};
use brdfkit_core::geometry::half_vector;
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::{Brdf, GeomSlice, Model, ModelError, ParamSpec, Rgb, Vec3};
use serde_json::{Value, json};
use std::fmt;
use std::marker::PhantomData;

/// The domain of a cosine-power exponent.
pub const N_DOMAIN: Domain = Domain::at_least(0.0);

/// cⁿ on the open lobe c > 0, and 0 elsewhere.
///
/// The clamp at c ≤ 0 is the lobe's definition (max(0, cos)ⁿ). At c = 0 with n = 0 this
/// gives 0, not IEEE's pow(0, 0) = 1: 0 is the limit of 0ⁿ as n → 0⁺, so the value stays
/// continuous in n, and the lobe boundary has measure zero for every integral.
#[inline(always)]
pub fn cos_pow(c: f64, n: f64) -> f64 {
    if c > 0.0 { c.powf(n) } else { 0.0 }
}

/// (cⁿ, ∂cⁿ/∂n = cⁿ ln c), both 0 for c ≤ 0 (see [`cos_pow`]).
///
/// No clamp is needed for finiteness: for c > 0 the smallest double gives
/// ln c ≥ −745, and cⁿ ≤ 1 for c ≤ 1 (cosines exceed 1 only by round-off). At c = 0 the
/// derivative is the limit of cⁿ ln c as c → 0⁺, which is 0 for n > 0.
#[inline(always)]
pub fn cos_pow_dn(c: f64, n: f64) -> (f64, f64) {
    if c > 0.0 {
        let p = c.powf(n);
        (p, p * c.ln())
    } else {
        (0.0, 0.0)
    }
}

/// The cosine a lobe raises to the power n.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cosine {
    /// cos θr = r·wo with r = (−wi.x, −wi.y, wi.z) the mirror direction of wi:
    /// wi.z wo.z − wi.x wo.x − wi.y wo.y (symmetric in wi and wo).
    Mirror,
    /// cos θh = h.z with h = (wi + wo)/|wi + wo|, the half vector of `half_vector`, which
    /// `GeometryBatch` stores, so that every evaluation path sees the same bits.
    Half,
}

/// cos θr from the coordinates ([`Cosine::Mirror`]).
#[inline(always)]
fn mirror_cos(ix: f64, iy: f64, iz: f64, ox: f64, oy: f64, oz: f64) -> f64 {
    iz * oz - ix * ox - iy * oy
}

/// What distinguishes one model of the family: names, parameter table, and the lobe
/// L(n; c, cos θi) with its n-derivative. Implemented by a marker type in each model's
/// module, beside the model's formula.
pub trait LobeKind: Copy + PartialEq + fmt::Debug + Send + Sync + 'static {
    /// The model's name in the JSON contract.
    const NAME: &'static str;
    /// The Rust name of the model type (its `Debug` form).
    const TYPE: &'static str;
    /// Names, domain and defaults of d and s.
    const PARAMS: DiffuseSpecular;
    /// The default exponent.
    const DEFAULT_N: f64;
    /// D = ∂f/∂d: 1/π for an albedo, 1 for a BRDF value.
    const DIFFUSE_SCALE: f64;
    /// The cosine the lobe is raised on.
    const COSINE: Cosine;
    /// [`Model::is_reciprocal`].
    const RECIPROCAL: bool;
    /// [`Model::conserves_energy`].
    const CONSERVES_ENERGY: bool;

    /// L(n; c, cos θi), for cos θi > 0 and cos θo > 0.
    fn lobe(n: f64, c: f64, cos_i: f64) -> f64;

    /// (L, ∂L/∂n), with the same L as [`LobeKind::lobe`] to the last bit.
    fn lobe_dn(n: f64, c: f64, cos_i: f64) -> (f64, f64);
}

/// A model of the Phong family (module doc). The models are aliases of it:
/// [`Phong`](crate::phong::Phong), [`PlausiblePhong`](crate::plausible_phong::PlausiblePhong)
/// and [`BlinnPhong`](crate::blinn_phong::BlinnPhong).
#[derive(Clone, PartialEq)]
pub struct CosineLobeModel<K: LobeKind> {
    d: Rgb,
    s: Rgb,
    n: f64,
    kind: PhantomData<K>,
}

/// The number of parameters: d (3), s (3), n.
const NP: usize = 7;

impl<K: LobeKind> Default for CosineLobeModel<K> {
    fn default() -> Self {
        let (d, s) = K::PARAMS.defaults;
        CosineLobeModel {
            d: Rgb::splat(d),
            s: Rgb::splat(s),
            n: K::DEFAULT_N,
            kind: PhantomData,
        }
    }
}

/// `Name { d: …, s: …, n: … }` under the model's own names, as a derived `Debug` of a
/// plain struct would print it.
impl<K: LobeKind> fmt::Debug for CosineLobeModel<K> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (dn, sn) = K::PARAMS.names;
        f.debug_struct(K::TYPE)
            .field(dn, &self.d)
            .field(sn, &self.s)
            .field("n", &self.n)
            .finish()
    }
}

impl<K: LobeKind> CosineLobeModel<K> {
    /// A model from d and s (per channel, in the model's domain) and n ∈ [0, ∞).
    pub fn new(d: Rgb, s: Rgb, n: f64) -> Result<Self, ModelError> {
        Self::default().with_diffuse(d)?.with_specular(s)?.with_n(n)
    }

    /// Sets d (each channel in the model's domain).
    pub(crate) fn with_diffuse(mut self, d: Rgb) -> Result<Self, ModelError> {
        self.d = K::PARAMS.check_d(d)?;
        Ok(self)
    }

    /// Sets s (each channel in the model's domain).
    pub(crate) fn with_specular(mut self, s: Rgb) -> Result<Self, ModelError> {
        self.s = K::PARAMS.check_s(s)?;
        Ok(self)
    }

    /// Sets the exponent n ∈ [0, ∞).
    pub fn with_n(mut self, n: f64) -> Result<Self, ModelError> {
        self.n = check_param("n", n, N_DOMAIN)?;
        Ok(self)
    }

    /// The diffuse parameter d.
    pub(crate) fn diffuse(&self) -> Rgb {
        self.d
    }

    /// The specular parameter s.
    pub(crate) fn specular(&self) -> Rgb {
        self.s
    }

    /// The exponent n.
    pub fn n(&self) -> f64 {
        self.n
    }

    /// From the `params` object of the JSON contract; absent parameters take the
    /// default start, unknown keys and out-of-domain values are errors naming them.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        let m = K::NAME;
        let o = json::params_object(params, m)?;
        json::deny_unknown(&o, &[K::PARAMS.names.0, K::PARAMS.names.1, "n"], m)?;
        let (d, s) = K::PARAMS.read_json(&o, m)?;
        Self::new(d, s, json::number_or(&o, "n", K::DEFAULT_N, m)?)
    }

    /// The lobe's cosine c of a pair ([`Cosine`]).
    #[inline(always)]
    fn cosine(wi: &Vec3, wo: &Vec3) -> f64 {
        match K::COSINE {
            Cosine::Mirror => mirror_cos(wi.x, wi.y, wi.z, wo.x, wo.y, wo.z),
            Cosine::Half => half_vector(wi, wo).z,
        }
    }

    /// Calls `f(k, cos θi, cos θo, c)` for every pair k of a batch.
    #[inline(always)]
    fn for_each_pair(g: &GeomSlice<'_>, mut f: impl FnMut(usize, f64, f64, f64)) {
        let n = g.len();
        let (iz, oz) = (&g.wi_z[..n], &g.wo_z[..n]);
        match K::COSINE {
            Cosine::Mirror => {
                let (ix, iy) = (&g.wi_x[..n], &g.wi_y[..n]);
                let (ox, oy) = (&g.wo_x[..n], &g.wo_y[..n]);
                for k in 0..n {
                    f(
                        k,
                        iz[k],
                        oz[k],
                        mirror_cos(ix[k], iy[k], iz[k], ox[k], oy[k], oz[k]),
                    );
                }
            }
            Cosine::Half => {
                let hz = &g.h_z[..n];
                for k in 0..n {
                    f(k, iz[k], oz[k], hz[k]);
                }
            }
        }
    }

    /// f from cos θi, cos θo and the lobe's cosine; the single kernel of `eval` and
    /// `eval_batch`.
    #[inline(always)]
    fn kernel(&self, cos_i: f64, cos_o: f64, c: f64) -> Rgb {
        if cos_i <= 0.0 || cos_o <= 0.0 {
            return Rgb::ZERO;
        }
        self.d * K::DIFFUSE_SCALE + self.s * K::lobe(self.n, c, cos_i)
    }

    /// f, ∂f/∂d (any channel), ∂f/∂s (any channel), ∂f/∂n; the single kernel of
    /// `eval_grad` and `eval_grad_batch`.
    #[inline(always)]
    fn kernel_grad(&self, cos_i: f64, cos_o: f64, c: f64) -> (Rgb, f64, f64, Rgb) {
        if cos_i <= 0.0 || cos_o <= 0.0 {
            return (Rgb::ZERO, 0.0, 0.0, Rgb::ZERO);
        }
        let (l, dl_dn) = K::lobe_dn(self.n, c, cos_i);
        (
            self.d * K::DIFFUSE_SCALE + self.s * l,
            K::DIFFUSE_SCALE,
            l,
            self.s * dl_dn,
        )
    }
}

/// The kinds whose d and s are the albedos ρd and ρs (`rho_d`, `rho_s`, in [0, 1]).
pub trait AlbedoLobe: LobeKind {}

impl<K: AlbedoLobe> CosineLobeModel<K> {
    /// Sets ρd (each channel in [0, 1]).
    pub fn with_rho_d(self, rho_d: Rgb) -> Result<Self, ModelError> {
        self.with_diffuse(rho_d)
    }

    /// Sets ρs (each channel in [0, 1]).
    pub fn with_rho_s(self, rho_s: Rgb) -> Result<Self, ModelError> {
        self.with_specular(rho_s)
    }

    /// The diffuse albedo ρd.
    pub fn rho_d(&self) -> Rgb {
        self.diffuse()
    }

    /// The specular coefficient ρs (what it bounds depends on the model's
    /// normalisation; see its module).
    pub fn rho_s(&self) -> Rgb {
        self.specular()
    }
}

impl<K: LobeKind> Brdf for CosineLobeModel<K> {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        self.kernel(wi.z, wo.z, Self::cosine(wi, wo))
    }
}

impl<K: LobeKind> Model for CosineLobeModel<K> {
    fn name(&self) -> &'static str {
        K::NAME
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let mut v = K::PARAMS.specs();
        v.push(ParamSpec::shared("n", N_DOMAIN, K::DEFAULT_N));
        v
    }

    fn params(&self) -> Vec<f64> {
        let mut v = DiffuseSpecular::values(self.d, self.s, 1);
        v.push(self.n);
        v
    }

    fn num_params(&self) -> usize {
        NP
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        check_count(NP, p.len())?;
        let (d, s) = DiffuseSpecular::from_values(p);
        *self = Self::new(d, s, p[6])?;
        Ok(())
    }

    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb {
        let (f, dd, ds, dn) = self.kernel_grad(wi.z, wo.z, Self::cosine(wi, wo));
        for c in 0..3 {
            grad[c] = channel(c, dd);
            grad[3 + c] = channel(c, ds);
        }
        grad[6] = dn;
        f
    }

    fn eval_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb]) {
        let out = &mut out[..g.len()];
        Self::for_each_pair(g, |k, ci, co, c| out[k] = self.kernel(ci, co, c));
    }

    fn eval_grad_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: &mut [Rgb]) {
        let n = g.len();
        let out = &mut out[..n];
        let (g_d, rest) = grad[..NP * n].split_at_mut(3 * n);
        let (g_s, g_n) = rest.split_at_mut(3 * n);
        Self::for_each_pair(g, |k, ci, co, c| {
            let (f, dd, ds, dn) = self.kernel_grad(ci, co, c);
            out[k] = f;
            for c in 0..3 {
                g_d[c * n + k] = channel(c, dd);
                g_s[c * n + k] = channel(c, ds);
            }
            g_n[k] = dn;
        });
    }

    fn to_json(&self) -> Value {
        let mut p = K::PARAMS.write_json(self.d, self.s);
        p.insert("n".into(), self.n.into());
        json!({"model": K::NAME, "params": p})
    }

    fn clone_box(&self) -> Box<dyn Model> {
        Box::new(self.clone())
    }

    fn is_reciprocal(&self) -> bool {
        K::RECIPROCAL
    }

    fn conserves_energy(&self) -> bool {
        K::CONSERVES_ENERGY
    }
}
