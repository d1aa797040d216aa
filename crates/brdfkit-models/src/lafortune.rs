//! `lafortune`: a diffuse term plus any number of generalised cosine lobes.
//!
//! f_r(wi, wo) = ρd/π + Σⱼ ρⱼ · max(0, bⱼ)^nⱼ,
//! bⱼ = cxyⱼ (wi.x wo.x + wi.y wo.y) + czⱼ wi.z wo.z
//!
//! (the isotropic form, Cx = Cy = cxy). E. P. F. Lafortune, S.-C. Foo, K. E. Torrance,
//! D. P. Greenberg, "Non-Linear Approximation of Reflectance Functions", SIGGRAPH 1997.
//! With directions pointing away from the surface, the mirror of wi is (−wi.x, −wi.y,
//! wi.z), so cxy = −cz gives a lobe about the mirror direction (cxy = −1, cz = 1 is
//! cosⁿθr, the Phong lobe); cxy < 0 with |cxy| ≠ cz tilts the lobe towards (|cxy| > cz)
//! or away from (|cxy| < cz) grazing angles, as measured materials show; cxy > 0 makes
//! a retro-reflective lobe. A negative base gives zero.
//!
//! | parameter | JSON             | per channel | domain  | default |
//! |-----------|------------------|-------------|---------|---------|
//! | ρd        | `rho_d`          | yes         | [0, 1]  | 0.5     |
//! | cxy       | `lobes[i].cxy`   | no          | ℝ       | −1      |
//! | cz        | `lobes[i].cz`    | no          | ℝ       | 1 (not fitted by default) |
//! | n         | `lobes[i].n`     | no          | [0, ∞)  | 20      |
//! | ρ         | `lobes[i].rho`   | yes         | [0, ∞)  | 1       |
//!
//! The default is one lobe. JSON: `{"model": "lafortune", "params": {"rho_d": 0.5,
//! "lobes": [{"cxy": -1, "cz": 1, "n": 20, "rho": [1, 1, 1]}]}}`; an empty list is a
//! Lambertian surface. Flat parameter names: `rho_d.r`, …, `lobes[0].cxy`,
//! `lobes[0].cz`, `lobes[0].n`, `lobes[0].rho.r`, ….
//!
//! A lobe whose peak ρ · max(|cxy|, |cz|)ⁿ exceeds [`MAX_PEAK`] = 1e250 is rejected (with
//! |c| > 1 a large n overflows f64).
//!
//! Redundancy: scaling (cxy, cz) by t > 0 and ρ by t^(−n) leaves f unchanged, so a lobe
//! has one degree of freedom fewer than its parameters; cz is therefore marked not
//! fitted by default (`fit_by_default = false`), which keeps the family for cz > 0.
//!
//! Reciprocal (b is symmetric in wi and wo). Energy: the lobes are not normalised, so
//! nothing in the parameters bounds the albedo by 1 and [`Model::conserves_energy`] is
//! false. [`Lafortune::albedo_bound`] gives a sufficient bound: since
//! b = wi·v with v = (cxy wo.x, cxy wo.y, cz wo.z), |v| ≤ M = max(|cxy|, |cz|), a lobe's
//! albedo is at most ρ Mⁿ · 2π/(n+2) (a cosine lobe's albedo is largest about the normal,
//! Lewis 1994, as the plausible-phong tests measure), and the surface conserves energy
//! when ρd + Σ ρⱼ Mⱼ^nⱼ 2π/(nⱼ+2) ≤ 1.

use crate::cosine_lobe::N_DOMAIN;
use crate::json;
use crate::lanes::{self, Run, dispatch, max, select};
use crate::params::{RHO_DOMAIN, channel, check_count, check_rgb};
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::{Brdf, GeomSlice, Model, ModelError, ParamSpec, Rgb, Vec3};
use serde_json::{Map, Value, json};
use std::f64::consts::{FRAC_1_PI, PI};

/// The domain of cxy and cz.
pub const C_DOMAIN: Domain = Domain::real();
/// The domain of a lobe's ρ (not an albedo: the lobe integral depends on c and n).
pub const LOBE_RHO_DOMAIN: Domain = Domain::at_least(0.0);

/// The largest allowed lobe peak ρ · max(|cxy|, |cz|)ⁿ, leaving 1e58 of headroom for
/// the factors n, ln b and 1/b of the gradient.
pub const MAX_PEAK: f64 = 1e250;

/// Parameters per lobe in the flat vector: cxy, cz, n, ρ (3).
const PER_LOBE: usize = 6;

/// max(0, b)ⁿ by the branch-free [`pow`](crate::lanes::pow) of every evaluation path.
///
/// Bases below the smallest normal double (2.2e-308, including 0 and the negative
/// bases of the lobe's definition) count as 0: there n bⁿ⁻¹ = n bⁿ/b overflows for n < 1,
/// and such a base only arises within ~1e-154 rad of the horizon or of the lobe's
/// zero set. At b = 0 this also settles 0⁰ as 0, the limit of 0ⁿ as n → 0⁺ (as in
/// [`crate::cosine_lobe::cos_pow`]).
#[inline(always)]
fn lobe_pow(b: f64, n: f64) -> f64 {
    lanes::pow(lobe_base(b), n)
}

/// b where b ≥ the smallest normal double, else 0 ([`lobe_pow`]).
#[inline(always)]
fn lobe_base(b: f64) -> f64 {
    select(b >= f64::MIN_POSITIVE, b, 0.0)
}

/// (bⁿ, ∂bⁿ/∂b = n bⁿ/b, ∂bⁿ/∂n = bⁿ ln b), all 0 where [`lobe_pow`] is; bⁿ to the
/// last bit as [`lobe_pow`], ln b from the same reduction ([`lanes::pow_ln`]).
#[inline(always)]
fn lobe_pow_grad(b: f64, n: f64) -> (f64, f64, f64) {
    let b = lobe_base(b);
    let (p, ln_b) = lanes::pow_ln(b, n);
    let db = n * p / max(b, f64::MIN_POSITIVE);
    (p, db, p * ln_b)
}

/// `v` scaled by `t`, per channel, as `Rgb * f64` computes it (written out: `Rgb`'s
/// operators are calls across crates, which keep a loop scalar).
#[inline(always)]
fn scaled(v: Rgb, t: f64) -> Rgb {
    Rgb([v.0[0] * t, v.0[1] * t, v.0[2] * t])
}

/// `a + b` per channel, as `Rgb + Rgb` computes it ([`scaled`]).
#[inline(always)]
fn sum(a: Rgb, b: Rgb) -> Rgb {
    Rgb([a.0[0] + b.0[0], a.0[1] + b.0[1], a.0[2] + b.0[2]])
}

/// One generalised cosine lobe ρ · max(0, cxy (wi.x wo.x + wi.y wo.y) + cz wi.z wo.z)ⁿ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LafortuneLobe {
    cxy: f64,
    cz: f64,
    n: f64,
    rho: Rgb,
}

impl Default for LafortuneLobe {
    /// The Phong lobe cos²⁰θr with ρ = 1 (albedo at most 2π/22 ≈ 0.286).
    fn default() -> Self {
        LafortuneLobe {
            cxy: -1.0,
            cz: 1.0,
            n: 20.0,
            rho: Rgb::splat(1.0),
        }
    }
}

impl LafortuneLobe {
    /// A lobe; cxy, cz real, n ∈ [0, ∞), ρ per channel in [0, ∞).
    pub fn new(cxy: f64, cz: f64, n: f64, rho: Rgb) -> Result<Self, ModelError> {
        Self::checked(cxy, cz, n, rho, "")
    }

    /// Validates with parameter names prefixed by `prefix` (e.g. `lobes[1].`).
    ///
    /// Beyond the domain of each parameter, the lobe's peak value ρ Mⁿ
    /// (M = max(|cxy|, |cz|) bounds the base) must not exceed [`MAX_PEAK`]: with M > 1
    /// and a large n it overflows to ∞ (1.1⁷⁵⁰⁰ already does), which no evaluation
    /// could represent.
    fn checked(cxy: f64, cz: f64, n: f64, rho: Rgb, prefix: &str) -> Result<Self, ModelError> {
        let l = LafortuneLobe {
            cxy: check_param(&format!("{prefix}cxy"), cxy, C_DOMAIN)?,
            cz: check_param(&format!("{prefix}cz"), cz, C_DOMAIN)?,
            n: check_param(&format!("{prefix}n"), n, N_DOMAIN)?,
            rho: check_rgb(&format!("{prefix}rho"), rho, LOBE_RHO_DOMAIN)?,
        };
        let peak = l.rho.max_channel() * cxy.abs().max(cz.abs()).powf(n);
        // NaN (0 · ∞ when ρ = 0 and Mⁿ overflows) is rejected too.
        if peak.is_nan() || peak > MAX_PEAK {
            let who = if prefix.is_empty() {
                "a lafortune lobe".to_string()
            } else {
                format!("`{}`", prefix.trim_end_matches('.'))
            };
            return Err(ModelError::Invalid(format!(
                "{who}: peak value ρ · max(|cxy|, |cz|)^n = {peak:e} exceeds {MAX_PEAK:e} \
                 (cxy = {cxy}, cz = {cz}, n = {n}): the lobe overflows"
            )));
        }
        Ok(l)
    }

    /// The coefficient of wi.x wo.x + wi.y wo.y.
    pub fn cxy(&self) -> f64 {
        self.cxy
    }

    /// The coefficient of wi.z wo.z.
    pub fn cz(&self) -> f64 {
        self.cz
    }

    /// The exponent.
    pub fn n(&self) -> f64 {
        self.n
    }

    /// The lobe's scale ρ.
    pub fn rho(&self) -> Rgb {
        self.rho
    }

    /// An upper bound of the lobe's directional albedo, ρ Mⁿ 2π/(n+2) with
    /// M = max(|cxy|, |cz|) (module doc).
    pub fn albedo_bound(&self) -> Rgb {
        let m = self.cxy.abs().max(self.cz.abs());
        self.rho * (m.powf(self.n) * 2.0 * PI / (self.n + 2.0))
    }

    fn to_json(self) -> Value {
        json!({"cxy": self.cxy, "cz": self.cz, "n": self.n, "rho": json::rgb_value(self.rho)})
    }
}

/// The Lafortune model: ρd/π plus generalised cosine lobes.
#[derive(Debug, Clone, PartialEq)]
pub struct Lafortune {
    rho_d: Rgb,
    lobes: Vec<LafortuneLobe>,
}

impl Default for Lafortune {
    fn default() -> Self {
        Lafortune {
            rho_d: Rgb::splat(0.5),
            lobes: vec![LafortuneLobe::default()],
        }
    }
}

impl Lafortune {
    /// ρd per channel in [0, 1] and any number of lobes.
    pub fn new(rho_d: Rgb, lobes: Vec<LafortuneLobe>) -> Result<Self, ModelError> {
        Lafortune::default().with_rho_d(rho_d)?.with_lobes(lobes)
    }

    /// Sets ρd (each channel in [0, 1]).
    pub fn with_rho_d(mut self, rho_d: Rgb) -> Result<Self, ModelError> {
        self.rho_d = check_rgb("rho_d", rho_d, RHO_DOMAIN)?;
        Ok(self)
    }

    /// Replaces the lobes. Each lobe was validated when built ([`LafortuneLobe::new`]),
    /// so this cannot fail; it returns `Result` like every other builder step.
    pub fn with_lobes(mut self, lobes: Vec<LafortuneLobe>) -> Result<Self, ModelError> {
        self.lobes = lobes;
        Ok(self)
    }

    /// Appends a lobe (cannot fail, see [`Lafortune::with_lobes`]).
    pub fn with_lobe(mut self, lobe: LafortuneLobe) -> Result<Self, ModelError> {
        self.lobes.push(lobe);
        Ok(self)
    }

    /// The diffuse albedo ρd.
    pub fn rho_d(&self) -> Rgb {
        self.rho_d
    }

    /// The lobes.
    pub fn lobes(&self) -> &[LafortuneLobe] {
        &self.lobes
    }

    /// A sufficient bound of the directional albedo: ρd + Σ ρⱼ Mⱼ^nⱼ 2π/(nⱼ+2) per
    /// channel (module doc). Energy is conserved when every channel is ≤ 1.
    pub fn albedo_bound(&self) -> Rgb {
        self.lobes
            .iter()
            .fold(self.rho_d, |a, l| a + l.albedo_bound())
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        const M: &str = "lafortune";
        let o = json::params_object(params, M)?;
        json::deny_unknown(&o, &["rho_d", "lobes"], M)?;
        let d = Lafortune::default();
        let rho_d = json::rgb_or(&o, "rho_d", d.rho_d.r(), M)?;
        let lobes = match o.get("lobes") {
            None => d.lobes,
            Some(Value::Array(a)) => a
                .iter()
                .enumerate()
                .map(|(i, v)| lobe_from_json(i, v))
                .collect::<Result<_, _>>()?,
            Some(v) => {
                return Err(ModelError::Invalid(format!(
                    "`lobes` of `lafortune` must be an array of lobe objects, found {}",
                    json::kind(v)
                )));
            }
        };
        Lafortune::new(rho_d, lobes)
    }
}

/// Lobe `i` of the JSON `lobes` list; absent fields take the default lobe's values.
fn lobe_from_json(i: usize, v: &Value) -> Result<LafortuneLobe, ModelError> {
    let what = format!("lafortune lobes[{i}]");
    let o: &Map<String, Value> = v.as_object().ok_or_else(|| {
        ModelError::Invalid(format!(
            "`lobes[{i}]` of `lafortune` must be an object {{\"cxy\", \"cz\", \"n\", \"rho\"}}, found {}",
            json::kind(v)
        ))
    })?;
    json::deny_unknown(o, &["cxy", "cz", "n", "rho"], &what)?;
    let d = LafortuneLobe::default();
    LafortuneLobe::checked(
        json::number_or(o, "cxy", d.cxy, &what)?,
        json::number_or(o, "cz", d.cz, &what)?,
        json::number_or(o, "n", d.n, &what)?,
        json::rgb_or(o, "rho", d.rho.r(), &what)?,
        &format!("lobes[{i}]."),
    )
}

impl Lafortune {
    /// f from the products wi.x wo.x + wi.y wo.y and wi.z wo.z (both directions above the
    /// horizon); the single kernel of `eval` and `eval_batch`.
    #[inline(always)]
    fn kernel(&self, xy: f64, zz: f64) -> Rgb {
        let mut f = scaled(self.rho_d, FRAC_1_PI);
        for l in &self.lobes {
            f = sum(f, scaled(l.rho, lobe_pow(l.cxy * xy + l.cz * zz, l.n)));
        }
        f
    }

    /// f and the gradient of one pair into `grad[..num_params]`; `eval_grad`'s kernel
    /// (`eval_grad_batch` does the same per column).
    ///
    /// With p = bⁿ: ∂f/∂ρd = 1/π, ∂f/∂cxy = ρ n bⁿ⁻¹ (wi.x wo.x + wi.y wo.y),
    /// ∂f/∂cz = ρ n bⁿ⁻¹ wi.z wo.z, ∂f/∂n = ρ bⁿ ln b, ∂f/∂ρ = bⁿ (per channel).
    #[inline(always)]
    fn kernel_grad(&self, xy: f64, zz: f64, grad: &mut [Rgb]) -> Rgb {
        let mut f = scaled(self.rho_d, FRAC_1_PI);
        for (c, gc) in grad[..3].iter_mut().enumerate() {
            *gc = channel(c, FRAC_1_PI);
        }
        for (l, gl) in self.lobes.iter().zip(grad[3..].chunks_exact_mut(PER_LOBE)) {
            let (p, dp_db, dp_dn) = lobe_pow_grad(l.cxy * xy + l.cz * zz, l.n);
            f = sum(f, scaled(l.rho, p));
            gl[0] = scaled(l.rho, dp_db * xy);
            gl[1] = scaled(l.rho, dp_db * zz);
            gl[2] = scaled(l.rho, dp_dn);
            for c in 0..3 {
                gl[3 + c] = channel(c, p);
            }
        }
        f
    }
}

impl Brdf for Lafortune {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.kernel(wi.x * wo.x + wi.y * wo.y, wi.z * wo.z)
    }
}

model_name!(Lafortune, "lafortune");

impl Model for Lafortune {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let d = LafortuneLobe::default();
        let mut v = ParamSpec::per_channel("rho_d", RHO_DOMAIN, 0.5).to_vec();
        for j in 0..self.lobes.len() {
            v.push(ParamSpec::shared(
                format!("lobes[{j}].cxy"),
                C_DOMAIN,
                d.cxy,
            ));
            v.push(ParamSpec::shared(format!("lobes[{j}].cz"), C_DOMAIN, d.cz).fixed());
            v.push(ParamSpec::shared(format!("lobes[{j}].n"), N_DOMAIN, d.n));
            v.extend(ParamSpec::per_channel(
                &format!("lobes[{j}].rho"),
                LOBE_RHO_DOMAIN,
                d.rho.r(),
            ));
        }
        v
    }

    fn params(&self) -> Vec<f64> {
        let mut v = self.rho_d.0.to_vec();
        for l in &self.lobes {
            v.extend([l.cxy, l.cz, l.n]);
            v.extend(l.rho.0);
        }
        v
    }

    fn num_params(&self) -> usize {
        3 + PER_LOBE * self.lobes.len()
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        check_count(self.num_params(), p.len())?;
        let lobes = p[3..]
            .chunks_exact(PER_LOBE)
            .enumerate()
            .map(|(j, q)| {
                LafortuneLobe::checked(
                    q[0],
                    q[1],
                    q[2],
                    Rgb::new(q[3], q[4], q[5]),
                    &format!("lobes[{j}]."),
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        *self = Lafortune::new(Rgb::new(p[0], p[1], p[2]), lobes)?;
        Ok(())
    }

    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb {
        let np = self.num_params();
        if wi.z <= 0.0 || wo.z <= 0.0 {
            grad[..np].fill(Rgb::ZERO);
            return Rgb::ZERO;
        }
        self.kernel_grad(wi.x * wo.x + wi.y * wo.y, wi.z * wo.z, grad)
    }

    /// The lane loops of `Batch`: ρd/π, then one pass per lobe, so the value
    /// accumulates in the order of `eval` (identical numbers).
    fn eval_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb]) {
        dispatch(&mut Batch {
            m: self,
            g,
            out,
            grad: None,
        });
    }

    /// Column by column: the ρd columns first, then each lobe's six columns, so every
    /// write has unit stride (`Batch`). Per pair the value is accumulated in the
    /// order of `eval` (ρd/π, then lobe 0, 1, …), so the numbers are identical.
    fn eval_grad_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: &mut [Rgb]) {
        let grad = Some(grad);
        dispatch(&mut Batch {
            m: self,
            g,
            out,
            grad,
        });
    }

    fn to_json(&self) -> Value {
        let lobes: Vec<Value> = self.lobes.iter().map(|l| l.to_json()).collect();
        json!({"model": "lafortune", "params": {
            "rho_d": json::rgb_value(self.rho_d),
            "lobes": lobes,
        }})
    }

    /// False: the lobes are not normalised; see [`Lafortune::albedo_bound`].
    fn conserves_energy(&self) -> bool {
        false
    }
}

/// The geometry columns of a batch, each cut to the batch's length (so the loops over
/// them carry no bounds checks and vectorise).
type Dirs<'a> = [&'a [f64]; 6];

/// The directions of the first `n` pairs of `g` ([`Dirs`]).
#[inline(always)]
fn dirs<'a>(g: &GeomSlice<'a>, n: usize) -> Dirs<'a> {
    let [[ix, iy, iz], [ox, oy, oz]] = g.dirs();
    [&ix[..n], &iy[..n], &iz[..n], &ox[..n], &oy[..n], &oz[..n]]
}

/// Whether pair k is above the horizon, and the products (wi.x wo.x + wi.y wo.y,
/// wi.z wo.z) of [`Lafortune::kernel`], both 0 below the horizon, where every lobe's
/// base is then 0 and its terms +0.
#[inline(always)]
fn pair_products(d: &Dirs<'_>, k: usize) -> (bool, f64, f64) {
    let [ix, iy, iz, ox, oy, oz] = d;
    let above = iz[k] > 0.0 && oz[k] > 0.0;
    let xy = ix[k] * ox[k] + iy[k] * oy[k];
    let zz = iz[k] * oz[k];
    (above, select(above, xy, 0.0), select(above, zz, 0.0))
}

/// [`Model::eval_batch`] (`grad` None) and [`Model::eval_grad_batch`] as branch-free
/// loops that vectorise (`lanes`): one pass for ρd/π, one per lobe.
struct Batch<'a, 'g> {
    m: &'a Lafortune,
    g: &'a GeomSlice<'g>,
    out: &'a mut [Rgb],
    grad: Option<&'a mut [Rgb]>,
}

impl Run for Batch<'_, '_> {
    #[inline(always)]
    fn run(&mut self) {
        let n = self.g.len();
        let out = &mut self.out[..n];
        let d = dirs(self.g, n);
        match self.grad.as_deref_mut() {
            None => values(self.m, &d, out),
            Some(grad) => values_grad(self.m, &d, out, grad),
        }
    }
}

/// The value passes of [`Batch`].
#[inline(always)]
fn values(m: &Lafortune, d: &Dirs<'_>, out: &mut [Rgb]) {
    let fd = scaled(m.rho_d, FRAC_1_PI);
    for (k, o) in out.iter_mut().enumerate() {
        let above = pair_products(d, k).0;
        *o = Rgb(fd.0.map(|v| select(above, v, 0.0)));
    }
    for l in &m.lobes {
        for (k, o) in out.iter_mut().enumerate() {
            let (_, xy, zz) = pair_products(d, k);
            *o = sum(*o, scaled(l.rho, lobe_pow(l.cxy * xy + l.cz * zz, l.n)));
        }
    }
}

/// Pairs per block of [`lobe_block`].
const BLOCK: usize = 64;

/// One lobe over a block of at most [`BLOCK`] pairs: bⁿ, ∂bⁿ/∂b · xy, ∂bⁿ/∂b · zz and
/// ∂bⁿ/∂n per pair, into four local planes. Apart from the stores of the seven `Rgb`
/// columns (which, in the same loop, kept it scalar), so that this loop vectorises.
#[inline(always)]
fn lobe_block(l: &LafortuneLobe, d: &Dirs<'_>) -> [[f64; BLOCK]; 4] {
    let mut q = [[0.0; BLOCK]; 4];
    let len = d[0].len().min(BLOCK);
    let d = d.map(|c| &c[..len]);
    let [q0, q1, q2, q3] = &mut q;
    let (q0, q1, q2, q3) = (
        &mut q0[..len],
        &mut q1[..len],
        &mut q2[..len],
        &mut q3[..len],
    );
    for i in 0..len {
        let (_, xy, zz) = pair_products(&d, i);
        let (p, dp_db, dp_dn) = lobe_pow_grad(l.cxy * xy + l.cz * zz, l.n);
        q0[i] = p;
        q1[i] = dp_db * xy;
        q2[i] = dp_db * zz;
        q3[i] = dp_dn;
    }
    q
}

/// The value and gradient passes of [`Batch`], column by column.
#[inline(always)]
fn values_grad(m: &Lafortune, d: &Dirs<'_>, out: &mut [Rgb], grad: &mut [Rgb]) {
    let n = out.len();
    let (g_rho_d, mut g_lobes) = grad[..m.num_params() * n].split_at_mut(3 * n);
    let (g0, rest) = g_rho_d.split_at_mut(n);
    let (g1, g2) = rest.split_at_mut(n);
    let fd = scaled(m.rho_d, FRAC_1_PI);
    for k in 0..n {
        let above = pair_products(d, k).0;
        out[k] = Rgb(fd.0.map(|v| select(above, v, 0.0)));
        let v = select(above, FRAC_1_PI, 0.0);
        g0[k] = Rgb([v, 0.0, 0.0]);
        g1[k] = Rgb([0.0, v, 0.0]);
        g2[k] = Rgb([0.0, 0.0, v]);
    }
    for l in &m.lobes {
        let (cols, rest) = std::mem::take(&mut g_lobes).split_at_mut(PER_LOBE * n);
        g_lobes = rest;
        let (g_cxy, cols) = cols.split_at_mut(n);
        let (g_cz, cols) = cols.split_at_mut(n);
        let (g_n, cols) = cols.split_at_mut(n);
        let (g_r, cols) = cols.split_at_mut(n);
        let (g_g, g_b) = cols.split_at_mut(n);
        for s in (0..n).step_by(BLOCK) {
            let e = (s + BLOCK).min(n);
            let q = lobe_block(l, &d.map(|c| &c[s..e]));
            for (i, k) in (s..e).enumerate() {
                let [p, dx, dz, dn] = [q[0][i], q[1][i], q[2][i], q[3][i]];
                out[k] = sum(out[k], scaled(l.rho, p));
                g_cxy[k] = scaled(l.rho, dx);
                g_cz[k] = scaled(l.rho, dz);
                g_n[k] = scaled(l.rho, dn);
                g_r[k] = Rgb([p, 0.0, 0.0]);
                g_g[k] = Rgb([0.0, p, 0.0]);
                g_b[k] = Rgb([0.0, 0.0, p]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lambert::Lambert;
    use crate::plausible_phong::PlausiblePhong;
    use crate::testing::*;
    use brdfkit_core::direction::spherical;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn lobe(cxy: f64, cz: f64, n: f64, rho: Rgb) -> LafortuneLobe {
        LafortuneLobe::new(cxy, cz, n, rho).unwrap()
    }

    /// A forward-scattering lobe tilted towards grazing plus a retro-reflective one.
    fn model() -> Lafortune {
        Lafortune::new(
            Rgb::new(0.2, 0.3, 0.4),
            vec![
                lobe(-1.1, 0.9, 15.0, Rgb::new(0.8, 0.6, 0.4)),
                lobe(0.6, 0.7, 4.0, Rgb::new(0.1, 0.2, 0.3)),
            ],
        )
        .unwrap()
    }

    #[test]
    fn value_matches_the_angle_formula() {
        let m = model();
        assert_matches_angle_formula(&m, 15, 500, 1.5, 1e-12, |ti, pi, to, po| {
            let xy = ti.sin() * to.sin() * (pi - po).cos();
            let zz = ti.cos() * to.cos();
            let mut want = m.rho_d() / PI;
            for l in m.lobes() {
                let b = l.cxy() * xy + l.cz() * zz;
                if b > 0.0 {
                    want += l.rho() * b.powf(l.n());
                }
            }
            want
        });
    }

    #[test]
    fn phong_lobe_is_plausible_phong() {
        // cxy = −1, cz = 1: the base is cos θr; ρ = ρs (n+2)/(2π) is plausible Phong.
        let n = 35.0;
        let rho_s = Rgb::new(0.5, 0.3, 0.1);
        let p = PlausiblePhong::new(Rgb::new(0.2, 0.4, 0.6), rho_s, n).unwrap();
        let l = Lafortune::new(
            Rgb::new(0.2, 0.4, 0.6),
            vec![lobe(-1.0, 1.0, n, rho_s * ((n + 2.0) / (2.0 * PI)))],
        )
        .unwrap();
        for (wi, wo) in random_pairs(5, 1000) {
            let (a, b) = (l.eval(&wi, &wo), p.eval(&wi, &wo));
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-12 * b[c], "{a:?} vs {b:?}");
            }
        }
        // No lobes: Lambert, exactly.
        let l = Lafortune::new(Rgb::new(0.2, 0.4, 0.6), vec![]).unwrap();
        let lam = Lambert::new(Rgb::new(0.2, 0.4, 0.6)).unwrap();
        for (wi, wo) in random_pairs(6, 100) {
            assert_eq!(l.eval(&wi, &wo), lam.eval(&wi, &wo));
        }
    }

    #[test]
    fn retro_lobe_peaks_at_the_viewer() {
        let m = Lafortune::new(Rgb::ZERO, vec![lobe(1.0, 1.0, 50.0, Rgb::splat(1.0))]).unwrap();
        let wo = spherical(0.8, 0.5);
        assert!((m.eval(&wo, &wo).r() - 1.0).abs() < 1e-13);
        assert!(m.eval(&Vec3::new(-wo.x, -wo.y, wo.z), &wo).r() < 1e-10);
    }

    #[test]
    fn lobe_pow_conventions() {
        assert_eq!(lobe_pow(0.0, 0.0), 0.0);
        assert_eq!(lobe_pow(-1.0, 2.0), 0.0);
        assert_eq!(lobe_pow(1e-310, 0.01), 0.0, "subnormal bases count as 0");
        assert_eq!(lobe_pow(0.5, 2.0), 0.25);
        assert_eq!(lobe_pow_grad(0.5, 2.0), (0.25, 1.0, 0.25 * 0.5f64.ln()));
        let (p, db, dn) = lobe_pow_grad(f64::MIN_POSITIVE, 0.01);
        assert!(p > 0.0 && db.is_finite() && dn.is_finite());
    }

    #[test]
    fn builder_and_set_params_validate() {
        let e = LafortuneLobe::new(-1.0, 1.0, -2.0, Rgb::splat(1.0)).unwrap_err();
        assert!(e.to_string().contains("`n`"), "{e}");
        assert!(LafortuneLobe::new(f64::NAN, 1.0, 2.0, Rgb::splat(1.0)).is_err());
        assert!(LafortuneLobe::new(-1.0, 1.0, 2.0, Rgb::new(1.0, -1.0, 1.0)).is_err());
        // A lobe that overflows is rejected, naming the lobe; |c| ≤ 1 never overflows.
        let e = LafortuneLobe::new(-1.1, 1.0, 1e4, Rgb::splat(1.0)).unwrap_err();
        assert!(e.to_string().contains("overflows"), "{e}");
        assert!(
            LafortuneLobe::new(-1.1, 1.0, 1e4, Rgb::ZERO).is_err(),
            "0 · ∞"
        );
        assert!(LafortuneLobe::new(-1.0, 1.0, 1e300, Rgb::splat(1e250)).is_ok());
        let v: Value = serde_json::from_str(r#"{"lobes":[{}, {"cz": 2, "n": 1000}]}"#).unwrap();
        let e = Lafortune::from_params_json(&v).unwrap_err();
        assert!(e.to_string().contains("`lobes[1]`"), "{e}");
        let mut m = model();
        let mut p = m.params();
        assert_eq!(p.len(), 15);
        p[3 + 6 + 2] = -1.0; // lobes[1].n
        let e = m.set_params(&p).unwrap_err();
        assert!(e.to_string().contains("`lobes[1].n`"), "{e}");
        assert!(m.set_params(&p[..14]).is_err());
        assert_eq!(m, model());
        let specs = m.param_specs();
        let names: Vec<_> = specs.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(
            &names[..9],
            [
                "rho_d.r",
                "rho_d.g",
                "rho_d.b",
                "lobes[0].cxy",
                "lobes[0].cz",
                "lobes[0].n",
                "lobes[0].rho.r",
                "lobes[0].rho.g",
                "lobes[0].rho.b"
            ]
        );
        assert_eq!(names[14], "lobes[1].rho.b");
        assert!(!specs[4].fit_by_default && specs[3].fit_by_default);
        assert!(m.is_reciprocal() && !m.conserves_energy());
        let mut q = m.params();
        q[3] = -0.5;
        m.set_params(&q).unwrap();
        assert_eq!(m.lobes()[0].cxy(), -0.5);
    }

    #[test]
    fn json_round_trip_and_errors() {
        let m = model();
        let back = crate::from_json(&m.to_json()).unwrap();
        assert_eq!(back.params(), m.params());
        let d = crate::default_model("lafortune").unwrap();
        assert_eq!(
            d.params(),
            vec![0.5, 0.5, 0.5, -1.0, 1.0, 20.0, 1.0, 1.0, 1.0]
        );
        let two = crate::from_json_str(
            r#"{"model":"lafortune","params":{"lobes":[{"cxy":-0.9,"rho":[0.1,0.2,0.3]},{"n":3}]}}"#,
        )
        .unwrap();
        assert_eq!(two.num_params(), 15);
        assert_eq!(two.params()[3..9], [-0.9, 1.0, 20.0, 0.1, 0.2, 0.3]);
        let none = crate::from_json_str(r#"{"model":"lafortune","params":{"lobes":[]}}"#).unwrap();
        assert_eq!(none.num_params(), 3);
        for (bad, needle) in [
            (r#"{"lobes":[{"cx":1}]}"#, "`cx`"),
            (r#"{"lobes":[{"n":-1}]}"#, "`lobes[0].n`"),
            (r#"{"lobes":[{}, 3]}"#, "`lobes[1]`"),
            (r#"{"lobes":{"cxy":1}}"#, "`lobes`"),
            (r#"{"lobe":[]}"#, "`lobe`"),
        ] {
            let v: Value = serde_json::from_str(bad).unwrap();
            let e = Lafortune::from_params_json(&v).unwrap_err();
            assert!(e.to_string().contains(needle), "{bad}: {e}");
        }
    }

    #[test]
    fn shared_checks() {
        assert_shared_checks(&model(), 16);
    }

    #[test]
    fn hard_cases_stay_finite() {
        for n in [0.0, 1.0, 1e3, 1e6] {
            for rho in [0.0, 1.0, 100.0] {
                let m = Lafortune::new(
                    Rgb::splat(0.5),
                    vec![
                        lobe(-1.0, 1.0, n, Rgb::splat(rho)),
                        lobe(-0.9, 0.95, n, Rgb::splat(rho)),
                        lobe(1.0, 1.0, n, Rgb::splat(rho)),
                        lobe(0.5, -0.2, n, Rgb::splat(rho)),
                    ],
                )
                .unwrap();
                assert_finite_everywhere(&m, &hard_case_pairs());
                assert_paths_agree(&m, &hard_case_pairs(), 0.0);
                assert_zero_below_horizon(&m);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn gradient_matches_finite_differences(
            cxy in -1.2f64..-0.3, cz in 0.3f64..1.2, n in 2.0f64..100.0, rho in 0.01f64..3.0,
            rcxy in 0.1f64..1.0, rn in 2.0f64..10.0, d in 0.01f64..0.99, seed in any::<u64>()
        ) {
            let m = Lafortune::new(
                Rgb::new(d, 0.5, 0.3),
                vec![lobe(cxy, cz, n, Rgb::new(rho, 0.5 * rho, 0.2)), lobe(rcxy, 0.8, rn, Rgb::splat(0.3))],
            )
            .unwrap();
            assert_gradient_paths_reciprocity(&m, seed);
        }
    }
}
