//! `rough-plastic`: a diffuse base under a rough dielectric coating, as Mitsuba 3's
//! `roughplastic` evaluates it (Mitsuba 3 `src/bsdfs/roughplastic.cpp`, after
//! A. Weidlich and A. Wilkie, "Arbitrarily Layered Micro-Facet Surfaces", GRAPHITE 2007):
//! what most plastics and paints are.
//!
//! f_r(wi, wo) = ρs · F(wi·h; η) D(h) G1(wi) G1(wo) / (4 cos θi cos θo)
//!             + ρd / (1 − R_int · x) · T(cos θi) T(cos θo) / (π η²),
//!
//! x = ρd (`nonlinear`: the colour shift of repeated internal bounces) or 1 (default),
//! with
//! - D: GGX (Walter et al. 2007 eq. 33), isotropic α; G1 the exact GGX Smith
//!   2/(1 + √(1 + α² tan²θ)) (Walter et al. 2007 eq. 34); F the exact dielectric
//!   Fresnel of the real relative index η ([`dielectric`]);
//! - T(μ): the rough interface's transmittance at incidence cos θ = μ, the mean over
//!   visible normals m of (1 − F(wi·m; η)) G1(wt, m) (wt the refracted direction),
//!   tabulated at Mitsuba's 64 points μ_j = max(1e-6, j/63) and interpolated linearly
//!   as Mitsuba's `lerp_gather` does;
//! - R_int: the coating's internal diffuse reflectance, 2 · mean_j(R(μ_j; 1/η) μ_j) over
//!   the same 64 points (Mitsuba's estimate of ∫ R(μ) 2μ dμ), with R(μ; 1/η) the mean
//!   over visible normals of F(wi·m; 1/η) G1(wr, m) seen from inside (wr the reflected
//!   direction).
//!
//! T is a Gauss-Legendre rule on the unit square mapped by Heitz's visible-normal
//! sampling of GGX (E. Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT
//! 7(4), 2018), 32 × 32 nodes, as Mitsuba's `eval_transmittance`
//! (`include/mitsuba/render/microfacet.h`) integrates it with its own sampling routine;
//! its integrand is smooth (from outside, η > 1: no total internal reflection, and the
//! refracted direction never reaches the horizon), so T is smooth in α and η.
//! R's integrand is not: F(·; 1/η) has a square-root kink at the critical angle and
//! wr reaches the horizon. A rule at fixed nodes (Mitsuba's `eval_reflectance`, 128 ×
//! 128) is then only piecewise smooth in α and η, as nodes cross the kink. Here R is
//! integrated in the normal's spherical angles with panels cut at the kink and the
//! horizon, which move with α and η (see `internal_reflectance`): R_int is smooth
//! in both and converged (1e-7), and the cross-check in `brdfkit-validate` measures the
//! agreement with Mitsuba's rules.
//!
//! | parameter | JSON | per channel | domain | default |
//! |-----------|------|-------------|--------|---------|
//! | ρd | `rho_d` | yes | [0, 1] | 0.5 |
//! | ρs | `rho_s` | yes | [0, ∞) | 1 (Mitsuba's `specular_reflectance`) |
//! | α | `alpha` | no | [1e-3, 1] | 0.1 |
//! | η | `eta` | no | [1.05, 3] | 1.49 (fixed; polypropylene) |
//! | nonlinear | `nonlinear` | structural | `true`, `false` | `false` |
//!
//! η is fixed by default (it trades off against ρs); `fit --for mitsuba` frees it.
//! Only GGX: the visible-normal rule above is GGX's, and pbrt-v4's `coateddiffuse` (the
//! same kind of material) has only Trowbridge-Reitz.
//!
//! **Reciprocal**: both terms are symmetric in wi and wo (F at wi·h = wo·h; the diffuse
//! term is T(cos θi) T(cos θo)). **Energy**: the directional albedo stays ≤ 1 for
//! ρd, ρs ≤ 1 (measured by quadrature in the tests over α and η).
//!
//! The gradient with respect to α and η includes the tables' derivatives, computed once
//! per parameter set on the first gradient evaluation: ∂T/∂η exact, the others by
//! central differences (relative step `REL_STEP`; the tables are smooth, so the
//! difference quotient is the derivative of the value the model computes).

use crate::json;
use crate::pair::PairGeom;
use crate::params::{RHO_DOMAIN, RHO_S_DOMAIN, above_horizon, channel, check_count, check_rgb};
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::quadrature::gauss_legendre;
use brdfkit_core::scattering::fresnel::{dielectric, dielectric_grad};
use brdfkit_core::{Model, ModelError, ParamSpec, Rgb};
use serde_json::{Value, json};
use std::f64::consts::{FRAC_1_PI, PI};
use std::sync::{Arc, OnceLock};

/// The domain of α.
pub const ALPHA_DOMAIN: Domain = Domain::closed(1e-3, 1.0);
/// The domain of η (a coating, not an index-matched interface).
pub const ETA_DOMAIN: Domain = Domain::closed(1.05, 3.0);
/// Points of the transmittance table (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TABLE_RES: usize = 64;

const M: &str = "rough-plastic";
const DEFAULT_ALPHA: f64 = 0.1;
const DEFAULT_ETA: f64 = 1.49;
const T_NODES: usize = 32;
/// Relative step of the tables' central differences. They are smooth in α and η, so the
/// truncation error is O(step²), and the round-off of the sums (~1e-15 relative) adds
/// ~1e-9 at this step. Measured, ∂R_int/∂η and ∂R_int/∂α agree to 1e-9 relative between
/// steps 1e-5, 1e-6 and 1e-7 at (α, η) = (0.05, 1.3), (0.2, 1.5), (0.5, 2.2), (0.99, 2.9);
/// at α = 0.003, η = 1.06 (a nearly smooth coating: R(μ) follows F's √ kink at the
/// critical angle within a width ~α) step 1e-5 is 8e-6 off, 1e-6 1e-7.
const REL_STEP: f64 = 1e-6;

/// T(μ_j) and R_int for one (α, η).
#[derive(Debug, Clone, PartialEq)]
struct Tables {
    t: [f64; TABLE_RES],
    r_int: f64,
}

/// ∂/∂α and ∂R_int/∂η (central differences), ∂T/∂η (exact) of [`Tables`].
#[derive(Debug, Clone)]
struct Derivs {
    dt_da: [f64; TABLE_RES],
    dr_da: f64,
    dt_de: [f64; TABLE_RES],
    dr_de: f64,
}

/// GGX Smith G1 of a direction (given with vz > 0) for a facet m with v·m > 0.
#[inline]
fn g1(v: [f64; 3], a: f64) -> f64 {
    let z2 = v[2] * v[2];
    let t2 = (v[0] * v[0] + v[1] * v[1]) / z2;
    2.0 / (1.0 + (1.0 + a * a * t2).sqrt())
}

/// A visible normal of GGX for `wi` (z > 0) from (u1, u2) ∈ [0, 1]² (Heitz 2018, listing 1).
fn sample_vndf(wi: [f64; 3], a: f64, u1: f64, u2: f64) -> [f64; 3] {
    let vh = normalize([a * wi[0], a * wi[1], wi[2]]);
    let lensq = vh[0] * vh[0] + vh[1] * vh[1];
    let t1 = if lensq > 0.0 {
        let l = lensq.sqrt();
        [-vh[1] / l, vh[0] / l, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let t2 = cross(vh, t1);
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let (p1, mut p2) = (r * phi.cos(), r * phi.sin());
    let s = 0.5 * (1.0 + vh[2]);
    p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
    let pz = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    let nh: [f64; 3] = std::array::from_fn(|k| p1 * t1[k] + p2 * t2[k] + pz * vh[k]);
    normalize([a * nh[0], a * nh[1], nh[2].max(0.0)])
}

fn normalize(v: [f64; 3]) -> [f64; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / l)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The means over visible normals at incidence μ of the `N` values `g(wi, m)` on an
/// `n × n` Gauss-Legendre rule.
fn vndf_mean<const N: usize>(
    mu: f64,
    a: f64,
    n: usize,
    g: impl Fn([f64; 3], [f64; 3]) -> [f64; N],
) -> [f64; N] {
    let (x, w) = gauss_legendre(n);
    let wi = [(1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu];
    let mut sum = [0.0; N];
    for (xj, wj) in x.iter().zip(&w) {
        for (xk, wk) in x.iter().zip(&w) {
            let m = sample_vndf(wi, a, 0.5 * (xj + 1.0), 0.5 * (xk + 1.0));
            let v = g(wi, m);
            for (s, v) in sum.iter_mut().zip(v) {
                *s += wj * wk * 0.25 * v;
            }
        }
    }
    sum
}

/// T(μ; α, η): the mean of (1 − F) G1(wt) over visible normals (module doc), and its
/// derivative ∂T/∂η at fixed nodes (the nodes do not depend on η; wt does, by Snell's
/// law: with cos θt = √(1 − (1 − c²)/η²), ∂cos θt/∂η = (1 − c²)/(η³ cos θt) and
/// ∂wt/∂η = wi/η² − (c/η² + ∂cos θt/∂η) m).
fn transmittance(mu: f64, a: f64, eta: f64) -> [f64; 2] {
    vndf_mean(mu, a, T_NODES, |wi, m| {
        let c = dot(wi, m);
        let (f, df) = dielectric_grad(c, eta);
        let sin2_t = (1.0 - c * c) / (eta * eta);
        if sin2_t >= 1.0 {
            return [0.0; 2];
        }
        let ct = (1.0 - sin2_t).sqrt();
        // v = −wt = wi/η − (c/η − cos θt) m points out of the coating, with G1 of wt.
        let v: [f64; 3] = std::array::from_fn(|k| wi[k] / eta - (c / eta - ct) * m[k]);
        if v[2] <= 0.0 {
            return [0.0; 2];
        }
        let dct = (1.0 - c * c) / (eta * eta * eta * ct);
        let dv: [f64; 3] =
            std::array::from_fn(|k| -wi[k] / (eta * eta) + (c / (eta * eta) + dct) * m[k]);
        let (g, dg) = g1_dv(v, dv, a);
        [(1.0 - f) * g, -df * g + (1.0 - f) * dg]
    })
}

/// GGX G1(v) (vz > 0) and its derivative along dv: with q = (vx² + vy²)/vz² and
/// r = √(1 + α² q), G1 = 2/(1 + r) and ∂G1/∂q = −α²/(r (1 + r)²).
fn g1_dv(v: [f64; 3], dv: [f64; 3], a: f64) -> (f64, f64) {
    let z2 = v[2] * v[2];
    let xy = v[0] * v[0] + v[1] * v[1];
    let q = xy / z2;
    let dq = 2.0 * (v[0] * dv[0] + v[1] * dv[1]) / z2 - 2.0 * xy * dv[2] / (z2 * v[2]);
    let r = (1.0 + a * a * q).sqrt();
    (2.0 / (1.0 + r), -a * a / (r * (1.0 + r) * (1.0 + r)) * dq)
}

/// Nodes per panel of the R rule ([`internal_reflectance`]), in θm and in φm.
const R_NODES: usize = 12;

/// Gauss-Legendre nodes and weights on [0, 1] through the smoothstep s(t) = 3t² − 2t³:
/// s′ = 6t(1 − t) vanishes at both ends, so an integrand behaving like √(x − a) at an
/// end of its panel [a, b] becomes smooth in t (x − a ∝ t²) and the rule converges
/// spectrally instead of as a power of the node count.
fn smoothstep_rule(n: usize) -> Vec<(f64, f64)> {
    let (x, w) = gauss_legendre(n);
    x.iter()
        .zip(&w)
        .map(|(x, w)| {
            let t = 0.5 * (x + 1.0);
            (t * t * (3.0 - 2.0 * t), 0.5 * w * 6.0 * t * (1.0 - t))
        })
        .collect()
}

/// The panels between consecutive cut points `cuts` (any order, those outside
/// (`lo`, `hi`) dropped), as (start, width).
fn panels(lo: f64, hi: f64, cuts: &mut Vec<f64>) -> impl Iterator<Item = (f64, f64)> + '_ {
    cuts.retain(|&c| c > lo && c < hi);
    cuts.push(lo);
    cuts.push(hi);
    cuts.sort_by(f64::total_cmp);
    cuts.windows(2).map(|p| (p[0], p[1] - p[0]))
}

/// R(μ; α, 1/η): the mean of F(wi·m; 1/η) G1(wr) over visible normals m, seen from
/// inside (wr = 2(wi·m)m − wi, zero below the horizon).
///
/// The integrand has a square-root kink at the critical angle wi·m = c_crit = √(1 − 1/η²)
/// (F ≡ 1 below it) and ends where wr reaches the horizon. Both are levels of
/// c = wi·m = μ cos θm + sin θi sin θm cos φm, so in the normal's own spherical angles
/// (θm, φm) they are closed-form cuts φm(θm) = acos((level − μ cos θm)/(sin θi sin θm)):
/// the rule integrates φm panel by panel between them, and θm panel by panel between
/// the angles where a cut enters or leaves [0, π] (|θi ∓ θcrit|, (π/2 ± θi)/2, and
/// where the two cuts meet, cos θm = μ/(2 c_crit)). Every panel's integrand is then
/// smooth but for square roots at its ends, which [`smoothstep_rule`] removes, and the
/// cuts move continuously with α and η: R is smooth in both, and difference quotients
/// are its derivatives.
///
/// With the visible-normal density G1(wi) ⟨wi·m⟩ D(m)/μ (Heitz 2018, eq. 3) and GGX's
/// mapping tan θm = α tan(vπ/2) (its CDF is sin²(vπ/2)), D(m) sin θm dθm = W(v) dv with
/// W = ½ sin(vπ/2) √(cos²(vπ/2) + α² sin²(vπ/2)), which follows the peak of D for any α:
/// R = 2 G1(wi)/μ ∫₀¹ W(v) ∫₀^π c F(c) G1(wr) dφm dv (the integrand is even in φm).
fn internal_reflectance(mu: f64, a: f64, eta: f64, rule: &[(f64, f64)]) -> f64 {
    use std::f64::consts::FRAC_PI_2;
    let si = (1.0 - mu * mu).max(0.0).sqrt();
    let theta_i = si.atan2(mu);
    let inv = 1.0 / eta;
    let c_crit = (1.0 - inv * inv).sqrt();
    let theta_crit = inv.asin();
    let mut cuts = vec![
        (theta_i - theta_crit).abs(),
        theta_i + theta_crit,
        0.5 * (FRAC_PI_2 + theta_i),
        0.5 * (FRAC_PI_2 - theta_i),
    ];
    if mu < 2.0 * c_crit {
        cuts.push((mu / (2.0 * c_crit)).acos());
    }
    // θm → v = (2/π) atan(tan θm / α).
    let mut cuts: Vec<f64> = cuts
        .into_iter()
        .map(|t| t.sin().atan2(a * t.cos()) / FRAC_PI_2)
        .collect();
    let mut sum = 0.0;
    for (v0, dv) in panels(0.0, 1.0, &mut cuts) {
        for &(s, ws) in rule {
            let (sw, cw) = ((v0 + dv * s) * FRAC_PI_2).sin_cos();
            let n = (cw * cw + a * a * sw * sw).sqrt();
            let (cos_m, sin_m) = (cw / n, a * sw / n);
            let (c0, b) = (mu * cos_m, si * sin_m);
            // φm where c falls to `level` (c decreases in φm ∈ [0, π]).
            let phi_at = |level: f64| {
                if b > 0.0 {
                    ((level - c0) / b).clamp(-1.0, 1.0).acos()
                } else if c0 > level {
                    PI
                } else {
                    0.0
                }
            };
            let phi_h = phi_at(mu / (2.0 * cos_m));
            let phi_k = phi_at(c_crit).min(phi_h);
            let mut inner = 0.0;
            for (p0, dp) in [(0.0, phi_k), (phi_k, phi_h - phi_k)] {
                if dp <= 0.0 {
                    continue;
                }
                for &(t, wt) in rule {
                    let c = c0 + b * (p0 + dp * t).cos();
                    let wr_z = 2.0 * c * cos_m - mu;
                    if wr_z <= 0.0 {
                        continue;
                    }
                    let g =
                        2.0 / (1.0 + (1.0 + a * a * (1.0 - wr_z * wr_z) / (wr_z * wr_z)).sqrt());
                    inner += dp * wt * c * dielectric(c, inv) * g;
                }
            }
            sum += dv * ws * 0.5 * sw * n * inner;
        }
    }
    2.0 * g1([si, 0.0, mu], a) / mu * sum
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// μ_j = max(1e-6, j/63), Mitsuba's table points.
fn table_mu(j: usize) -> f64 {
    (j as f64 / (TABLE_RES - 1) as f64).max(1e-6)
}

/// R_int = 2 mean_j(R(μ_j) μ_j).
fn r_int(a: f64, eta: f64) -> f64 {
    let rule = smoothstep_rule(R_NODES);
    let s: f64 = (0..TABLE_RES)
        .map(|j| {
            let mu = table_mu(j);
            internal_reflectance(mu, a, eta, &rule) * mu
        })
        .sum();
    2.0 * s / TABLE_RES as f64
}

impl Tables {
    fn new(a: f64, eta: f64) -> Tables {
        Tables {
            t: std::array::from_fn(|j| transmittance(table_mu(j), a, eta)[0]),
            r_int: r_int(a, eta),
        }
    }

    /// `lerp_gather`: linear interpolation at cos θ = `c` ∈ (0, 1].
    #[inline]
    fn lerp(t: &[f64; TABLE_RES], c: f64) -> f64 {
        let x = c * (TABLE_RES - 1) as f64;
        let i = (x as usize).min(TABLE_RES - 2);
        let w1 = x - i as f64;
        (1.0 - w1) * t[i] + w1 * t[i + 1]
    }
}

impl Derivs {
    fn new(a: f64, eta: f64) -> Derivs {
        let ha = REL_STEP * a;
        let (ap, am) = (Tables::new(a + ha, eta), Tables::new(a - ha, eta));
        Derivs {
            dt_da: std::array::from_fn(|j| (ap.t[j] - am.t[j]) / (2.0 * ha)),
            dr_da: (ap.r_int - am.r_int) / (2.0 * ha),
            dt_de: std::array::from_fn(|j| transmittance(table_mu(j), a, eta)[1]),
            dr_de: {
                let he = REL_STEP * eta;
                (r_int(a, eta + he) - r_int(a, eta - he)) / (2.0 * he)
            },
        }
    }
}

/// The rough-plastic BRDF (module doc).
#[derive(Debug, Clone)]
pub struct RoughPlastic {
    rho_d: Rgb,
    rho_s: Rgb,
    alpha: f64,
    eta: f64,
    nonlinear: bool,
    tables: Arc<Tables>,
    derivs: Arc<OnceLock<Derivs>>,
}

impl PartialEq for RoughPlastic {
    fn eq(&self, o: &Self) -> bool {
        (self.rho_d, self.rho_s, self.alpha, self.eta, self.nonlinear)
            == (o.rho_d, o.rho_s, o.alpha, o.eta, o.nonlinear)
    }
}

impl Default for RoughPlastic {
    fn default() -> Self {
        RoughPlastic::new(Rgb::splat(0.5), Rgb::splat(1.0), DEFAULT_ALPHA, DEFAULT_ETA)
            .expect("the defaults are in their domains")
    }
}

impl RoughPlastic {
    /// A linear (`nonlinear = false`) rough plastic.
    pub fn new(rho_d: Rgb, rho_s: Rgb, alpha: f64, eta: f64) -> Result<Self, ModelError> {
        let alpha = check_param("alpha", alpha, ALPHA_DOMAIN)?;
        let eta = check_param("eta", eta, ETA_DOMAIN)?;
        Ok(RoughPlastic {
            rho_d: check_rgb("rho_d", rho_d, RHO_DOMAIN)?,
            rho_s: check_rgb("rho_s", rho_s, RHO_S_DOMAIN)?,
            alpha,
            eta,
            nonlinear: false,
            tables: Arc::new(Tables::new(alpha, eta)),
            derivs: Arc::new(OnceLock::new()),
        })
    }

    /// Sets Mitsuba's `nonlinear` (internal bounces tint by ρd).
    pub fn with_nonlinear(mut self, nonlinear: bool) -> Self {
        self.nonlinear = nonlinear;
        self
    }

    /// ρd (Mitsuba `diffuse_reflectance`).
    pub fn rho_d(&self) -> Rgb {
        self.rho_d
    }
    /// ρs (Mitsuba `specular_reflectance`).
    pub fn rho_s(&self) -> Rgb {
        self.rho_s
    }
    /// α (GGX).
    pub fn alpha(&self) -> f64 {
        self.alpha
    }
    /// η, the coating's index relative to the outside.
    pub fn eta(&self) -> f64 {
        self.eta
    }
    /// Mitsuba's `nonlinear`.
    pub fn nonlinear(&self) -> bool {
        self.nonlinear
    }
    /// The coating's internal diffuse reflectance R_int.
    pub fn internal_reflectance(&self) -> f64 {
        self.tables.r_int
    }
    /// The interface's transmittance T(cos θ) as the model interpolates it.
    pub fn transmittance(&self, cos_theta: f64) -> f64 {
        Tables::lerp(&self.tables.t, cos_theta.clamp(0.0, 1.0))
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        let o = json::params_object(params, M)?;
        json::deny_unknown(&o, &["rho_d", "rho_s", "alpha", "eta", "nonlinear"], M)?;
        let nonlinear = match o.get("nonlinear") {
            None => false,
            Some(Value::Bool(b)) => *b,
            Some(v) => {
                return Err(ModelError::Invalid(format!(
                    "`nonlinear` of `{M}` must be true or false, found {}",
                    json::kind(v)
                )));
            }
        };
        Ok(RoughPlastic::new(
            json::rgb_or(&o, "rho_d", 0.5, M)?,
            json::rgb_or(&o, "rho_s", 1.0, M)?,
            json::number_or(&o, "alpha", DEFAULT_ALPHA, M)?,
            json::number_or(&o, "eta", DEFAULT_ETA, M)?,
        )?
        .with_nonlinear(nonlinear))
    }

    /// f_r of one pair and, with `grad`, its gradient (ρd, ρs, α, η).
    fn kernel(&self, p: PairGeom, grad: Option<&mut [Rgb; 8]>) -> Rgb {
        let PairGeom { wi, wo, h, .. } = p;
        let Some(grad) = above_horizon(&wi, &wo, grad) else {
            return Rgb::ZERO;
        };
        let cd = p.cos_d;
        let (zi, zo) = (wi[2], wo[2]);
        let a = self.alpha;
        let d = brdfkit_core::scattering::microfacet::ggx_grad(h[0], h[1], h[2], a, a);
        let smith = brdfkit_core::scattering::Smith::Ggx;
        let gi = brdfkit_core::scattering::masking::smith_g1(smith, wi, cd, a, a);
        let go = brdfkit_core::scattering::masking::smith_g1(smith, wo, cd, a, a);
        let (f, df_de) = dielectric_grad(cd.clamp(0.0, 1.0), self.eta);
        let norm = 1.0 / (4.0 * zi * zo);
        let lobe = d.d * gi.v * go.v * norm;
        let tab = &*self.tables;
        let (ti, to) = (Tables::lerp(&tab.t, zi), Tables::lerp(&tab.t, zo));
        let e2 = self.eta * self.eta;
        let tt = ti * to * FRAC_1_PI / e2;
        let x = |c: usize| if self.nonlinear { self.rho_d[c] } else { 1.0 };
        let kd = |c: usize| self.rho_d[c] / (1.0 - tab.r_int * x(c));
        let out = Rgb(std::array::from_fn(|c| {
            self.rho_s[c] * f * lobe + kd(c) * tt
        }));
        let Some(g) = grad else {
            return out;
        };
        let dv = self.derivs.get_or_init(|| Derivs::new(a, self.eta));
        for c in 0..3 {
            let den = 1.0 - tab.r_int * x(c);
            // ∂(ρ/(1 − R x))/∂ρ: 1/(1 − R) linear, 1/(1 − Rρ)² nonlinear.
            let dk = if self.nonlinear {
                1.0 / (den * den)
            } else {
                1.0 / den
            };
            g[c] = channel(c, dk * tt);
            g[3 + c] = channel(c, f * lobe);
        }
        // ∂(ρ/(1 − R x))/∂R = ρ x/(1 − R x)².
        let dk_dr = |c: usize| {
            let den = 1.0 - tab.r_int * x(c);
            self.rho_d[c] * x(c) / (den * den)
        };
        let dlobe_da =
            (d.d_alpha() * gi.v * go.v + d.d * (gi.d_alpha() * go.v + gi.v * go.d_alpha())) * norm;
        let (dti_da, dto_da) = (Tables::lerp(&dv.dt_da, zi), Tables::lerp(&dv.dt_da, zo));
        let dtt_da = (dti_da * to + ti * dto_da) * FRAC_1_PI / e2;
        g[6] = Rgb(std::array::from_fn(|c| {
            self.rho_s[c] * f * dlobe_da + kd(c) * dtt_da + dk_dr(c) * dv.dr_da * tt
        }));
        let (dti_de, dto_de) = (Tables::lerp(&dv.dt_de, zi), Tables::lerp(&dv.dt_de, zo));
        let dtt_de = (dti_de * to + ti * dto_de) * FRAC_1_PI / e2 - 2.0 * tt / self.eta;
        g[7] = Rgb(std::array::from_fn(|c| {
            self.rho_s[c] * df_de * lobe + kd(c) * dtt_de + dk_dr(c) * dv.dr_de * tt
        }));
        out
    }
}

crate::pair::pair_kernel_brdf!(RoughPlastic);

model_name!(RoughPlastic, M);

impl Model for RoughPlastic {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let mut v = ParamSpec::per_channel("rho_d", RHO_DOMAIN, 0.5).to_vec();
        v.extend(ParamSpec::per_channel("rho_s", RHO_S_DOMAIN, 1.0));
        v.push(ParamSpec::shared("alpha", ALPHA_DOMAIN, DEFAULT_ALPHA));
        v.push(ParamSpec::shared("eta", ETA_DOMAIN, DEFAULT_ETA).fixed());
        v
    }

    fn params(&self) -> Vec<f64> {
        let (d, s) = (self.rho_d.0, self.rho_s.0);
        vec![d[0], d[1], d[2], s[0], s[1], s[2], self.alpha, self.eta]
    }

    fn num_params(&self) -> usize {
        8
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        check_count(8, p.len())?;
        let rho_d = check_rgb("rho_d", Rgb::new(p[0], p[1], p[2]), RHO_DOMAIN)?;
        let rho_s = check_rgb("rho_s", Rgb::new(p[3], p[4], p[5]), RHO_S_DOMAIN)?;
        let alpha = check_param("alpha", p[6], ALPHA_DOMAIN)?;
        let eta = check_param("eta", p[7], ETA_DOMAIN)?;
        // The tables depend on α and η only: keep them when those are unchanged.
        if alpha != self.alpha || eta != self.eta {
            self.tables = Arc::new(Tables::new(alpha, eta));
            self.derivs = Arc::new(OnceLock::new());
        }
        (self.rho_d, self.rho_s, self.alpha, self.eta) = (rho_d, rho_s, alpha, eta);
        Ok(())
    }

    crate::pair::pair_kernel_evals!(8);

    fn to_json(&self) -> Value {
        json!({"model": M, "params": {
            "rho_d": json::rgb_value(self.rho_d),
            "rho_s": json::rgb_value(self.rho_s),
            "alpha": self.alpha,
            "eta": self.eta,
            "nonlinear": self.nonlinear,
        }})
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::*;
    use brdfkit_core::direction::spherical;
    use brdfkit_core::quadrature::{AlbedoQuadrature, directional_albedo};
    use brdfkit_core::{Brdf, Vec3};

    fn model() -> RoughPlastic {
        RoughPlastic::new(Rgb::new(0.6, 0.3, 0.1), Rgb::new(1.0, 0.9, 0.8), 0.2, 1.5).unwrap()
    }

    /// Brute-force T(μ) by a midpoint rule over all microfacet normals (not the visible
    /// normal mapping): ∫ D(m) G1(wi, m) ⟨wi·m⟩/μ (1 − F) G1(wt, m) dm.
    fn brute_transmittance(mu: f64, a: f64, eta: f64) -> f64 {
        let wi = [(1.0 - mu * mu).sqrt(), 0.0, mu];
        let (nt, np) = (2000, 400);
        let mut s = 0.0;
        for i in 0..nt {
            // θm on a grid dense where GGX is: tan θm = a · tan(u π/2).
            let u = (i as f64 + 0.5) / nt as f64;
            let t = (a * (u * PI / 2.0).tan()).atan();
            let dt_du = a * (PI / 2.0)
                / (u * PI / 2.0).cos().powi(2)
                / (1.0 + (a * (u * PI / 2.0).tan()).powi(2));
            for k in 0..np {
                let p = (k as f64 + 0.5) / np as f64 * 2.0 * PI;
                let m = [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
                let c = dot(wi, m);
                if c <= 0.0 {
                    continue;
                }
                let dd = brdfkit_core::scattering::microfacet::ggx_grad(m[0], m[1], m[2], a, a).d;
                let sin2_t = (1.0 - c * c) / (eta * eta);
                let ct = (1.0 - sin2_t).sqrt();
                let wt: [f64; 3] = std::array::from_fn(|j| -wi[j] / eta + (c / eta - ct) * m[j]);
                if wt[2] >= 0.0 {
                    continue;
                }
                let val = dd * g1(wi, a) * c / mu
                    * (1.0 - brdfkit_core::scattering::fresnel::dielectric(c, eta))
                    * g1([-wt[0], -wt[1], -wt[2]], a);
                s += val * t.sin() * dt_du / nt as f64 * 2.0 * PI / np as f64;
            }
        }
        s
    }

    /// R(μ) by the former rule: an n × n Gauss-Legendre rule over Heitz's visible-normal
    /// square, fixed nodes (an independent parametrization of the same integral).
    fn vndf_reflectance(mu: f64, a: f64, eta: f64, n: usize) -> f64 {
        vndf_mean(mu, a, n, |wi, m| {
            let c = dot(wi, m);
            let wr: [f64; 3] = std::array::from_fn(|k| 2.0 * c * m[k] - wi[k]);
            if wr[2] <= 0.0 {
                return [0.0];
            }
            [dielectric(c, 1.0 / eta) * g1(wr, a)]
        })[0]
    }

    #[test]
    fn the_internal_reflectance_rule_is_converged_and_agrees_with_the_former_rule() {
        let rule = smoothstep_rule(R_NODES);
        let fine = smoothstep_rule(2 * R_NODES);
        for (a, eta) in [
            (1e-3, 1.5),
            (0.05, 1.5),
            (0.2, 1.49),
            (0.6, 1.1),
            (1.0, 3.0),
        ] {
            for mu in [1.0, 0.9, 0.6, 0.3, 0.1, 0.02] {
                let got = internal_reflectance(mu, a, eta, &rule);
                // Doubling the nodes per panel: the panels' integrands are smooth.
                let doubled = internal_reflectance(mu, a, eta, &fine);
                assert!(
                    (got - doubled).abs() < 1e-5,
                    "a {a} eta {eta} mu {mu}: {got} vs {doubled}"
                );
                // A 400 × 400 rule on Heitz's square converges slowly across the kink
                // (measured off by up to 2.5e-4 here), but independently.
                let former = vndf_reflectance(mu, a, eta, 400);
                assert!(
                    (got - former).abs() < 5e-4,
                    "a {a} eta {eta} mu {mu}: {got} vs {former}"
                );
            }
        }
        // Smooth interface limit: R(μ) → F(μ; 1/η) away from the critical angle (whose
        // √ kink a small α blurs over a width ~α).
        for (mu, eta) in [(1.0, 1.5), (0.95, 1.5), (0.98, 2.0), (0.3, 1.5)] {
            let got = internal_reflectance(mu, 1e-3, eta, &rule);
            let want = dielectric(mu, 1.0 / eta);
            assert!(
                (got - want).abs() < 2e-5,
                "mu {mu} eta {eta}: {got} vs {want}"
            );
        }
    }

    /// Second differences of R_int at steps 1e-5 and 1e-3 agree where R_int is smooth
    /// (both ≈ R″); a fixed-node rule fails this at the nodes crossing the critical angle
    /// (the former 64 × 64 rule: 1e-5 differences of −1.6e3 to 4.8e2 against R″ ≈ −1.2 to
    /// −2.2 over η ∈ [1.3, 1.65] at α = 0.1, measured). Over η the critical angle
    /// asin(1/η) sweeps across the fixed table points μ_j.
    #[test]
    fn r_int_and_f_are_smooth_in_eta_and_alpha_across_the_critical_angle() {
        let d2 =
            |r: &dyn Fn(f64) -> f64, x: f64, h: f64| (r(x + h) - 2.0 * r(x) + r(x - h)) / (h * h);
        let (wi, wo) = (spherical(0.7, 0.0), spherical(0.4, 2.5));
        let f = |a: f64, e: f64| {
            RoughPlastic::new(Rgb::splat(0.8), Rgb::splat(1.0), a, e)
                .unwrap()
                .eval(&wi, &wo)[0]
        };
        for k in 0..8 {
            let eta = 1.3 + 0.05 * k as f64;
            let curves: [(&dyn Fn(f64) -> f64, f64); 4] = [
                (&|e| r_int(0.1, e), eta),
                (&|a| r_int(a, eta), 0.1),
                (&|e| f(0.1, e), eta),
                (&|a| f(a, eta), 0.1),
            ];
            for (i, (r, x)) in curves.into_iter().enumerate() {
                let (coarse, fine) = (d2(r, x, 1e-3), d2(r, x, 1e-5));
                assert!(
                    (coarse - fine).abs() <= 1e-3 * coarse.abs().max(1.0),
                    "curve {i} at eta {eta}: {coarse} vs {fine}"
                );
            }
        }
    }

    #[test]
    fn the_transmittance_table_matches_a_brute_force_integral() {
        for (a, eta) in [(0.05, 1.5), (0.3, 1.49), (0.8, 2.0)] {
            for mu in [1.0, 0.7, 0.3, 0.08] {
                let got = transmittance(mu, a, eta)[0];
                let want = brute_transmittance(mu, a, eta);
                assert!(
                    (got - want).abs() < 2e-3,
                    "a {a} eta {eta} mu {mu}: {got} vs {want}"
                );
            }
        }
        // Smooth interface limit: T(1) → 1 − F(0) = 1 − ((η − 1)/(η + 1))².
        let t = transmittance(1.0, 1e-3, 1.5)[0];
        assert!((t - 0.96).abs() < 1e-6, "{t}");
    }

    #[test]
    fn internal_reflectance_is_the_smooth_interface_value_at_small_alpha() {
        // Smooth coating, η = 1.5: the hemispherical internal reflectance is
        // 1 − (1 − R_ext)/η² with R_ext the external diffuse reflectance 0.0918
        // (Walter et al. 2007 / d'Eon), ≈ 0.596; Mitsuba's 64-point mean gives a little
        // less (the rectangle rule misses the grazing end).
        let r = Tables::new(1e-3, 1.5).r_int;
        assert!((r - 0.596).abs() < 0.02, "{r}");
    }

    #[test]
    fn shared_checks_and_gradient() {
        let m = model();
        let pairs = random_pairs(5, 300);
        assert_paths_agree(&m, &pairs, 0.0);
        assert_paths_agree(&m, &dense_grid_pairs(12, 6), 0.0);
        assert_reciprocal(&m, &pairs, 1e-12);
        assert_reciprocal(&m, &dense_grid_pairs(20, 8), 1e-12);
        // Grazing back-scatter pairs: cos θd is a cancellation there (~1e-11 relative),
        // as in cook-torrance.
        assert_reciprocal(&m, &hard_case_pairs(), 1e-10);
        assert_nonnegative(&m, &dense_grid_pairs(40, 16));
        assert_zero_below_horizon(&m);
        assert_gradient_close_to_fd(&m, &pairs[..40]);
        assert_finite_everywhere(&m, &hard_case_pairs());
        let n = model().with_nonlinear(true);
        assert_gradient_close_to_fd(&n, &random_pairs(6, 12));
        // Across the parameter domain, the critical angle asin(1/η) anywhere.
        for (a, e) in [(3e-3, 1.06), (0.05, 1.3), (0.5, 2.2), (0.99, 2.9)] {
            let m = RoughPlastic::new(Rgb::new(0.6, 0.3, 0.1), Rgb::splat(1.0), a, e).unwrap();
            assert_gradient_close_to_fd(&m, &random_pairs(7, 20));
        }
        for (a, e) in [(1e-3, 1.05), (1.0, 3.0)] {
            let m = RoughPlastic::new(Rgb::splat(1.0), Rgb::splat(1.0), a, e).unwrap();
            assert_finite_everywhere(&m, &hard_case_pairs());
            assert_paths_agree(&m, &hard_case_pairs(), 0.0);
        }
    }

    /// Analytic gradients against central differences (step 1e-6) to 1e-5 relative, α and
    /// η (the tables' parameters) included: the tables are smooth in both (module doc).
    fn assert_gradient_close_to_fd(m: &RoughPlastic, pairs: &[(Vec3, Vec3)]) {
        let mut g = [Rgb::ZERO; 8];
        for (wi, wo) in pairs {
            let f = m.eval_grad(wi, wo, &mut g);
            let fd = fd_gradient(m, wi, wo, 1e-6);
            for p in 0..8 {
                for c in 0..3 {
                    let (a, b) = (g[p][c], fd[p][c]);
                    let tol = 1e-5 * a.abs().max(b.abs()) + 1e-8 * f[c].abs() / m.params()[p];
                    assert!(
                        (a - b).abs() <= tol,
                        "param {p} ch {c}: {a} vs {b} at {wi:?} {wo:?}, params {:?}",
                        m.params()
                    );
                }
            }
        }
    }

    #[test]
    fn the_transmittance_eta_derivative_is_exact() {
        // T is smooth in η (no kink from outside): a central difference agrees.
        for (a, mu) in [(0.05, 0.9), (0.3, 0.4), (0.8, 0.1)] {
            let h = 1e-5;
            let fd =
                (transmittance(mu, a, 1.5 + h)[0] - transmittance(mu, a, 1.5 - h)[0]) / (2.0 * h);
            let d = transmittance(mu, a, 1.5)[1];
            assert!(
                (fd - d).abs() <= 1e-7 * d.abs().max(1e-3),
                "a {a} mu {mu}: {d} vs {fd}"
            );
        }
    }

    #[test]
    fn albedo_stays_below_one() {
        let q = AlbedoQuadrature::default();
        let mut worst: f64 = 0.0;
        for (a, e) in [(0.05, 1.5), (0.3, 1.3), (1.0, 2.5)] {
            let m = RoughPlastic::new(Rgb::splat(1.0), Rgb::splat(1.0), a, e).unwrap();
            for t in [0.0, 0.8, 1.3, 1.5] {
                worst = worst.max(directional_albedo(&m, &spherical(t, 0.0), &q)[0]);
            }
        }
        assert!(worst <= 1.0 && worst > 0.8, "max albedo {worst}");
    }

    #[test]
    fn json_round_trip_and_domains() {
        let m = model().with_nonlinear(true);
        assert_json_round_trip(&m);
        assert!(RoughPlastic::new(Rgb::splat(0.5), Rgb::splat(1.0), 0.1, 1.0).is_err());
        assert!(RoughPlastic::new(Rgb::splat(1.5), Rgb::splat(1.0), 0.1, 1.5).is_err());
        let e = crate::from_json_str(r#"{"model":"rough-plastic","params":{"nonlinear":1}}"#)
            .unwrap_err();
        assert!(e.to_string().contains("nonlinear"), "{e}");
        let mut m = model();
        assert!(
            m.set_params(&[0.1, 0.1, 0.1, 1.0, 1.0, 1.0, 0.1, 0.5])
                .is_err()
        );
        assert_eq!(m, model());
        let spec = m.param_specs();
        assert!(!spec[7].fit_by_default, "eta is fixed by default");
    }
}
