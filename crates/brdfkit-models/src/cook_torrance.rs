//! `cook-torrance`: a Lambertian base plus a microfacet specular lobe.
//!
//! f_r(wi, wo) = ρd/π + ρs · D(h) G(wi, wo, h) F(wi·h) / (4 cos θi cos θo),
//! h = (wi + wo)/|wi + wo|
//!
//! (R. L. Cook and K. E. Torrance, "A Reflectance Model for Computer Graphics", ACM ToG
//! 1(1), 1982; in the normalisation of B. Walter, S. R. Marschner, H. Li and
//! K. E. Torrance, "Microfacet Models for Refraction through Rough Surfaces", EGSR 2007,
//! eq. 20, where D is a density of projected microfacet area, ∫ D cos θh dωh = 1.)
//! D, G and F are the functions of [`brdfkit_core::scattering`]:
//!
//! - D: `beckmann` or `ggx`, isotropic (`alpha`) or anisotropic (`alpha_x` along the
//!   tangent x, `alpha_y`);
//! - G: `smith-separable` G1(wi)G1(wo), `smith-correlated` 1/(1 + Λ(wi) + Λ(wo)) (Heitz
//!   2014), or `v-cavity` (Cook & Torrance 1982); Beckmann's Smith Λ is `exact` (erf)
//!   or `rational` (Walter et al. 2007 eq. 27, as Mitsuba 3);
//! - F at cos θd = wi·h: `schlick` (f0 per channel), `conductor` (η, k per channel),
//!   `dielectric` (one real η), or `none` (F = 1).
//!
//! | parameter | JSON | per channel | domain | default |
//! |-----------|------|-------------|--------|---------|
//! | ρd | `rho_d` | yes | [0, 1] | 0.3 |
//! | ρs | `rho_s` | yes | [0, ∞) (a scale; see `params::RHO_S_DOMAIN`) | 0.3 |
//! | α (isotropic) | `alpha` | no | [1e-6, 100] | 0.2 |
//! | αx, αy (anisotropic) | `alpha_x`, `alpha_y` | no | [1e-6, 100] | 0.2 |
//! | distribution | `distribution` | structural | `beckmann`, `ggx` | `ggx` |
//! | masking | `masking` | structural | `smith-separable`, `smith-correlated`, `v-cavity` | `smith-separable` |
//! | Beckmann G1 | `beckmann_g1` | structural | `exact`, `rational` | `exact` |
//! | Fresnel | `fresnel` | structural | see below | `{"schlick": {"f0": 0.04}}` |
//! | f0 | `fresnel.schlick.f0` | yes | [0, 1] | 0.04 (fitted) |
//! | η | `fresnel.conductor.eta` | yes | (0, 1000] | 0.2 (fixed) |
//! | k | `fresnel.conductor.k` | yes | [0, 1000] | 3.0 (fixed) |
//! | η | `fresnel.dielectric.eta` | no | (0, 1000] | 1.5 (fixed) |
//!
//! `fresnel` is `"none"`, `{"schlick": {"f0": ...}}`, `{"conductor": {"eta": ...,
//! "k": ...}}` or `{"dielectric": {"eta": ...}}` (a bare `"schlick"`, `"conductor"` or
//! `"dielectric"` takes the defaults). The flat parameter vector is `rho_d.{r,g,b}`,
//! `rho_s.{r,g,b}`, `alpha` (or `alpha_x`, `alpha_y`), then `f0.{r,g,b}`, or
//! `eta.{r,g,b}`, `k.{r,g,b}`, or `eta`.
//!
//! **Mitsuba 3.** With ρd = 0, ρs = 1, `smith-separable`, `conductor` Fresnel, and
//! Beckmann with `beckmann_g1 = rational` (or GGX), this is Mitsuba 3's `roughconductor`:
//! Mitsuba's `eval` is f_r cos θ of its light-side direction, so divide by that cosine
//! (the model is reciprocal, and F is taken at wi·h = wo·h, so the naming of the two
//! directions does not matter). Mitsuba also zeroes D where D cos θh < 1e-20, a float32
//! guard not copied here: there f_r = D·G·F/(4 cosθi cosθo) can still reach a few 1e-19
//! at grazing pairs, where Mitsuba returns exactly 0 (measured by the cross-check in
//! brdfkit-validate: at most 2.2e-19). A test compares against
//! an independent transcription of Mitsuba's formulas (agreement 2e-13 relative).
//!
//! **Reciprocal.** **Energy:** for F ≤ 1 and ρd + ρs ≤ 1 the directional albedo is
//! ≤ 1: with the exact Smith forms and the V-cavity, G ≤ G1(wo) and G1 passes the weak
//! white furnace ∫ G1(wo) D ⟨wo·h⟩ dωh = cos θo (Heitz 2014), so the specular albedo
//! is ≤ ρs. Walter's rational Beckmann G1 exceeds the exact one by up to 0.31 %, but only
//! where the lobe is also shadowed or cut by the horizon: the measured albedo stays
//! ≤ 1 (figures in `docs/models.md`).
//!
//! The roughness domain [1e-6, 100] keeps every value and gradient finite in double
//! precision (at α = 1e-6, D at the mirror direction is 1/(π α²) ≈ 3e11); both ends
//! are tested over the hard-case grid.

use crate::json;
use crate::lanes::Real;
use crate::pair::{PairGeom, batch_pair, pair_geometry};
use crate::params::{
    DiffuseSpecular, ShapedLayout, above_horizon, check_count, check_rgb, grad_batch_via, grad_via,
    shape_gradient,
};
use brdfkit_core::UnknownName;
use brdfkit_core::model::{Domain, check_param, eval_batch_f32_widened};
use brdfkit_core::scattering::fresnel::{
    conductor, conductor_grad, dielectric_grad, schlick_weight,
};
use brdfkit_core::scattering::{BeckmannG1, Distribution, Masking, Smith};
use brdfkit_core::{
    Brdf, DirPairs, GeomSlice, GeomSliceF32, GeomSliceOf, Model, ModelError, ParamSpec, Rgb, Vec3,
};
use serde_json::{Value, json};
use std::f64::consts::FRAC_1_PI;

#[path = "cook_torrance_ggx.rs"]
mod kernel;
pub(crate) use kernel::ggx_iso_dv;

/// The roughness shape α or (αx, αy); defined in [`crate::shape`], shared with `ward`
/// and `ashikhmin-shirley`.
pub use crate::shape::Shape;

/// The domain of ρd, and of ρs.
pub use crate::params::{RHO_DOMAIN, RHO_S_DOMAIN};
/// The domain of the roughness α (and αx, αy).
pub const ALPHA_DOMAIN: Domain = Domain::closed(1e-6, 100.0);
/// The domain of Schlick's f0.
pub const F0_DOMAIN: Domain = Domain::closed(0.0, 1.0);
/// The domain of a real index of refraction (conductor η, dielectric η): (0, 1000].
/// Bounded above so η², k² and their products cannot overflow in the conductor formula
/// (measured metals have η, k below ~50 in the visible).
pub const ETA_DOMAIN: Domain = Domain {
    lo: 0.0,
    hi: 1e3,
    lo_open: true,
    hi_open: false,
};
/// The domain of a conductor's extinction coefficient k: [0, 1000].
pub const K_DOMAIN: Domain = Domain::closed(0.0, 1e3);

/// The parameter layout before the Fresnel parameters: ρd, ρs (default 0.3), then α or
/// αx, αy (default 0.2). The Fresnel defaults are the `Fresnel::DEFAULT*` constants.
const LAYOUT: ShapedLayout = ShapedLayout {
    rhos: DiffuseSpecular::albedos(0.3, 0.3),
    keys: ("alpha", "alpha_x", "alpha_y"),
    domain: ALPHA_DOMAIN,
    default: 0.2,
};

/// The default Schlick f0 (every channel).
const DEFAULT_F0: f64 = 0.04;
/// The default conductor η and k (every channel).
const DEFAULT_CONDUCTOR: (f64, f64) = (0.2, 3.0);
/// The default dielectric η.
const DEFAULT_DIELECTRIC_ETA: f64 = 1.5;

/// The Fresnel factor of the specular lobe, with its parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fresnel {
    /// F = 1.
    None,
    /// Schlick's approximation with normal-incidence reflectance f0 per channel.
    Schlick {
        /// Reflectance at normal incidence, per channel, in [0, 1].
        f0: Rgb,
    },
    /// Exact conductor Fresnel with complex index η + i·k per channel.
    Conductor {
        /// Real part of the relative index, per channel, > 0.
        eta: Rgb,
        /// Extinction coefficient, per channel, ≥ 0.
        k: Rgb,
    },
    /// Exact dielectric Fresnel with one real relative index.
    Dielectric {
        /// Relative index of refraction, > 0.
        eta: f64,
    },
}

/// The kind of a [`Fresnel`] factor, without its parameters: what `--fresnel` chooses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FresnelKind {
    /// [`Fresnel::None`].
    None,
    /// [`Fresnel::Schlick`].
    Schlick,
    /// [`Fresnel::Conductor`].
    Conductor,
    /// [`Fresnel::Dielectric`].
    Dielectric,
}

impl FresnelKind {
    /// This kind with its default parameters.
    pub fn with_defaults(self) -> Fresnel {
        match self {
            FresnelKind::None => Fresnel::None,
            FresnelKind::Schlick => Fresnel::DEFAULT,
            FresnelKind::Conductor => Fresnel::DEFAULT_CONDUCTOR,
            FresnelKind::Dielectric => Fresnel::DEFAULT_DIELECTRIC,
        }
    }
}

brdfkit_core::named_choice!(FresnelKind, "fresnel", {
    None => "none",
    Schlick => "schlick",
    Conductor => "conductor",
    Dielectric => "dielectric",
});

impl Fresnel {
    /// The kind of this factor.
    pub fn kind(&self) -> FresnelKind {
        match self {
            Fresnel::None => FresnelKind::None,
            Fresnel::Schlick { .. } => FresnelKind::Schlick,
            Fresnel::Conductor { .. } => FresnelKind::Conductor,
            Fresnel::Dielectric { .. } => FresnelKind::Dielectric,
        }
    }

    /// Schlick with f0 = 0.04 in every channel (the model's default).
    pub const DEFAULT: Fresnel = Fresnel::Schlick {
        f0: Rgb::splat(DEFAULT_F0),
    };
    /// The default conductor (a generic bright metal, F(0) ≈ 0.87).
    pub const DEFAULT_CONDUCTOR: Fresnel = Fresnel::Conductor {
        eta: Rgb::splat(DEFAULT_CONDUCTOR.0),
        k: Rgb::splat(DEFAULT_CONDUCTOR.1),
    };
    /// The default dielectric (glass-like, F(0) = 0.04).
    pub const DEFAULT_DIELECTRIC: Fresnel = Fresnel::Dielectric {
        eta: DEFAULT_DIELECTRIC_ETA,
    };

    fn validate(self) -> Result<Self, ModelError> {
        match self {
            Fresnel::None => {}
            Fresnel::Schlick { f0 } => {
                check_rgb("f0", f0, F0_DOMAIN)?;
            }
            Fresnel::Conductor { eta, k } => {
                check_rgb("eta", eta, ETA_DOMAIN)?;
                check_rgb("k", k, K_DOMAIN)?;
            }
            Fresnel::Dielectric { eta } => {
                check_param("eta", eta, ETA_DOMAIN)?;
            }
        }
        Ok(self)
    }

    fn num_params(&self) -> usize {
        match self {
            Fresnel::None => 0,
            Fresnel::Schlick { .. } => 3,
            Fresnel::Conductor { .. } => 6,
            Fresnel::Dielectric { .. } => 1,
        }
    }

    fn specs(&self) -> Vec<ParamSpec> {
        match self {
            Fresnel::None => vec![],
            Fresnel::Schlick { .. } => ParamSpec::per_channel("f0", F0_DOMAIN, DEFAULT_F0).to_vec(),
            Fresnel::Conductor { .. } => {
                let (eta, k) = DEFAULT_CONDUCTOR;
                ParamSpec::per_channel("eta", ETA_DOMAIN, eta)
                    .into_iter()
                    .chain(ParamSpec::per_channel("k", K_DOMAIN, k))
                    .map(ParamSpec::fixed)
                    .collect()
            }
            Fresnel::Dielectric { .. } => {
                vec![ParamSpec::shared("eta", ETA_DOMAIN, DEFAULT_DIELECTRIC_ETA).fixed()]
            }
        }
    }

    fn push_to(&self, v: &mut Vec<f64>) {
        match *self {
            Fresnel::None => {}
            Fresnel::Schlick { f0 } => v.extend_from_slice(&f0.0),
            Fresnel::Conductor { eta, k } => {
                v.extend_from_slice(&eta.0);
                v.extend_from_slice(&k.0);
            }
            Fresnel::Dielectric { eta } => v.push(eta),
        }
    }

    fn with_values(&self, p: &[f64]) -> Fresnel {
        match self {
            Fresnel::None => Fresnel::None,
            Fresnel::Schlick { .. } => Fresnel::Schlick {
                f0: Rgb::new(p[0], p[1], p[2]),
            },
            Fresnel::Conductor { .. } => Fresnel::Conductor {
                eta: Rgb::new(p[0], p[1], p[2]),
                k: Rgb::new(p[3], p[4], p[5]),
            },
            Fresnel::Dielectric { .. } => Fresnel::Dielectric { eta: p[0] },
        }
    }

    /// The `fresnel` value of the JSON contract.
    pub fn to_json(&self) -> Value {
        match *self {
            Fresnel::None => json!("none"),
            Fresnel::Schlick { f0 } => json!({"schlick": {"f0": json::rgb_value(f0)}}),
            Fresnel::Conductor { eta, k } => json!({"conductor": {
                "eta": json::rgb_value(eta), "k": json::rgb_value(k)}}),
            Fresnel::Dielectric { eta } => json!({"dielectric": {"eta": eta}}),
        }
    }

    /// Parses the `fresnel` value of the JSON contract.
    pub fn from_json(v: &Value) -> Result<Self, ModelError> {
        const M: &str = "cook-torrance fresnel";
        let kinds = "\"none\", {\"schlick\": {\"f0\": ...}}, {\"conductor\": {\"eta\": ..., \"k\": ...}} or {\"dielectric\": {\"eta\": ...}}";
        let (kind, body) = match v {
            Value::String(s) => (s.as_str(), None),
            Value::Object(o) if o.len() == 1 => {
                let (k, b) = o.iter().next().expect("one entry");
                (k.as_str(), Some(b))
            }
            other => {
                return Err(ModelError::Invalid(format!(
                    "`fresnel` must be {kinds}, found {}",
                    json::kind(other)
                )));
            }
        };
        let empty = Value::Null;
        let body = json::params_object(body.unwrap_or(&empty), M)?;
        let kind: FresnelKind = kind.parse().map_err(|e: UnknownName| {
            ModelError::Invalid(format!("unknown fresnel `{}` (expected {kinds})", e.given))
        })?;
        // The body's keys are those of the kind's flat parameters (`f0`; `eta`, `k`;
        // `eta`), absent ones at the kind's defaults.
        let m = format!("fresnel {}", kind.name());
        let f = match kind.with_defaults() {
            Fresnel::None => {
                json::deny_unknown(&body, &[], &m)?;
                Fresnel::None
            }
            Fresnel::Schlick { f0 } => {
                json::deny_unknown(&body, &["f0"], &m)?;
                Fresnel::Schlick {
                    f0: json::rgb_or(&body, "f0", f0[0], &m)?,
                }
            }
            Fresnel::Conductor { eta, k } => {
                json::deny_unknown(&body, &["eta", "k"], &m)?;
                Fresnel::Conductor {
                    eta: json::rgb_or(&body, "eta", eta[0], &m)?,
                    k: json::rgb_or(&body, "k", k[0], &m)?,
                }
            }
            Fresnel::Dielectric { eta } => {
                json::deny_unknown(&body, &["eta"], &m)?;
                Fresnel::Dielectric {
                    eta: json::number_or(&body, "eta", eta, &m)?,
                }
            }
        };
        f.validate()
    }
}

/// Largest parameter count: 3 ρd + 3 ρs + 2 α + 6 (η, k).
const MAXP: usize = 14;

/// The Cook-Torrance microfacet BRDF with a Lambertian base.
#[derive(Debug, Clone, PartialEq)]
pub struct CookTorrance {
    rho_d: Rgb,
    rho_s: Rgb,
    alpha: Shape,
    distribution: Distribution,
    masking: Masking,
    beckmann_g1: BeckmannG1,
    fresnel: Fresnel,
    /// The branch-free kernel's configuration and f64 constants, derived from the fields above
    /// by [`refreshed`](Self::refreshed) at the end of every builder (a per-pair `eval`
    /// would otherwise recompute five divisions per call).
    kernel64: Option<(kernel::Config, kernel::Consts<f64>)>,
}

impl Default for CookTorrance {
    fn default() -> Self {
        CookTorrance {
            rho_d: Rgb::splat(LAYOUT.rhos.defaults.0),
            rho_s: Rgb::splat(LAYOUT.rhos.defaults.1),
            alpha: Shape::Isotropic(LAYOUT.default),
            distribution: Distribution::Ggx,
            masking: Masking::SmithSeparable,
            beckmann_g1: BeckmannG1::Exact,
            fresnel: Fresnel::DEFAULT,
            kernel64: None,
        }
        .refreshed()
    }
}

impl CookTorrance {
    /// The default model (see the module table).
    pub fn new() -> Self {
        Self::default()
    }

    shaped_lobe_builders! {
        done: Self::refreshed,
        rho_d: "Sets ρd (each channel in [0, 1]).", "ρd.",
        rho_s: "Sets ρs (each channel in [0, ∞)).", "ρs.",
        alpha: "Sets the roughness shape (isotropic or anisotropic).", "The roughness.",
        with_alpha(alpha): "An isotropic roughness α in [1e-6, 100].",
        with_alpha_xy(alpha_x, alpha_y): "An anisotropic roughness (αx along the tangent, αy), each in [1e-6, 100].",
    }

    /// The microfacet distribution.
    pub fn with_distribution(mut self, d: Distribution) -> Self {
        self.distribution = d;
        self.refreshed()
    }

    /// The masking-shadowing function.
    pub fn with_masking(mut self, m: Masking) -> Self {
        self.masking = m;
        self.refreshed()
    }

    /// How Beckmann's Smith G1 is evaluated (ignored for GGX).
    pub fn with_beckmann_g1(mut self, b: BeckmannG1) -> Self {
        self.beckmann_g1 = b;
        self.refreshed()
    }

    /// The Fresnel factor; its parameters are checked.
    pub fn with_fresnel(mut self, f: Fresnel) -> Result<Self, ModelError> {
        self.fresnel = f.validate()?;
        Ok(self.refreshed())
    }

    /// The model with its derived kernel constants brought up to date.
    fn refreshed(mut self) -> Self {
        self.kernel64 = self
            .kernel_config()
            .map(|c| (c, self.kernel_consts::<f64>()));
        self
    }

    /// The distribution.
    pub fn distribution(&self) -> Distribution {
        self.distribution
    }
    /// The masking-shadowing function.
    pub fn masking(&self) -> Masking {
        self.masking
    }
    /// The Beckmann G1 form.
    pub fn beckmann_g1(&self) -> BeckmannG1 {
        self.beckmann_g1
    }
    /// The Fresnel factor.
    pub fn fresnel(&self) -> Fresnel {
        self.fresnel
    }

    /// From the `params` object of the JSON contract.
    pub fn from_params_json(params: &Value) -> Result<Self, ModelError> {
        const M: &str = "cook-torrance";
        let o = json::params_object(params, M)?;
        let mut keys = LAYOUT.json_keys().to_vec();
        keys.extend(["distribution", "masking", "beckmann_g1", "fresnel"]);
        json::deny_unknown(&o, &keys, M)?;
        let d = CookTorrance::default();
        let distribution = json::choice_or(&o, "distribution", d.distribution, M)?;
        let masking = json::choice_or(&o, "masking", d.masking, M)?;
        let beckmann_g1 = json::choice_or(&o, "beckmann_g1", d.beckmann_g1, M)?;
        let fresnel = match o.get("fresnel") {
            None => d.fresnel,
            Some(v) => Fresnel::from_json(v)?,
        };
        d.with_lobes_from_json(&o, M)?
            .with_distribution(distribution)
            .with_masking(masking)
            .with_beckmann_g1(beckmann_g1)
            .with_fresnel(fresnel)
    }

    fn smith(&self) -> Smith {
        Smith::of(self.distribution, self.beckmann_g1)
    }

    /// The model for one pair: value, and when `grad` is given, every ∂f/∂p.
    ///
    /// The pair is [`PairGeom`]: the unit half vector `h` and `cos_d` = wi·h exactly as
    /// [`GeometryBatch`](brdfkit_core::GeometryBatch) stores them, so the slow and the
    /// fast paths share every operation.
    #[inline(always)]
    fn kernel(&self, p: PairGeom, grad: Option<&mut [Rgb; MAXP]>) -> Rgb {
        let PairGeom { wi, wo, h, cos_d } = p;
        let Some(grad) = above_horizon(&wi, &wo, grad) else {
            return Rgb::ZERO;
        };
        let (ax, ay) = self.alpha.xy();
        let d = self.distribution.d_grad(h[0], h[1], h[2], ax, ay);
        let g = self
            .masking
            .g(self.smith(), wi, wo, h, cos_d, cos_d, ax, ay);
        // D·G first: at α = 1e-6 and grazing mirror pairs D ~ 3e11 while G ~ 1e-20, and
        // 1/(4 cos θi cos θo) ~ 1e32; the product of all three stays finite (~1e23).
        let inv = 0.25 / (wi[2] * wo[2]);
        let s = d.d * g.v * inv;

        // F per channel at cos θd, and what the Fresnel parameters need.
        let mut f = [1.0; 3];
        let mut df = [[0.0; 3]; 2];
        match self.fresnel {
            Fresnel::None => {}
            Fresnel::Schlick { f0 } => {
                let w = schlick_weight(cos_d);
                for c in 0..3 {
                    f[c] = f0[c] + (1.0 - f0[c]) * w;
                    df[0][c] = 1.0 - w;
                }
            }
            Fresnel::Conductor { eta, k } => {
                if grad.is_some() {
                    for c in 0..3 {
                        let fc = conductor_grad(cos_d, eta[c], k[c]);
                        f[c] = fc.f;
                        df[0][c] = fc.d_eta;
                        df[1][c] = fc.d_k;
                    }
                } else {
                    // The same bits as conductor_grad(..).f, without the derivatives.
                    for c in 0..3 {
                        f[c] = conductor(cos_d, eta[c], k[c]);
                    }
                }
            }
            Fresnel::Dielectric { eta } => {
                let (fv, dv) = dielectric_grad(cos_d, eta);
                f = [fv; 3];
                df[0] = [dv; 3];
            }
        }
        let mut out = Rgb::ZERO;
        for c in 0..3 {
            out[c] = self.rho_d[c] * FRAC_1_PI + self.rho_s[c] * s * f[c];
        }

        if let Some(gr) = grad {
            *gr = [Rgb::ZERO; MAXP];
            for c in 0..3 {
                gr[c][c] = FRAC_1_PI;
                gr[3 + c][c] = s * f[c];
            }
            let s_ax = (d.d_ax * g.v + d.d * g.d_ax) * inv;
            let s_ay = (d.d_ay * g.v + d.d * g.d_ay) * inv;
            let spec = Rgb::new(
                self.rho_s[0] * f[0],
                self.rho_s[1] * f[1],
                self.rho_s[2] * f[2],
            );
            shape_gradient(&self.alpha, spec, s_ax, s_ay, gr);
            let p = ShapedLayout::count(&self.alpha);
            match self.fresnel {
                Fresnel::None => {}
                Fresnel::Schlick { .. } => {
                    for c in 0..3 {
                        gr[p + c][c] = self.rho_s[c] * s * df[0][c];
                    }
                }
                Fresnel::Conductor { .. } => {
                    for c in 0..3 {
                        gr[p + c][c] = self.rho_s[c] * s * df[0][c];
                        gr[p + 3 + c][c] = self.rho_s[c] * s * df[1][c];
                    }
                }
                Fresnel::Dielectric { .. } => {
                    for c in 0..3 {
                        gr[p][c] = self.rho_s[c] * s * df[0][c];
                    }
                }
            }
        }
        out
    }
}

impl CookTorrance {
    /// f_r of one pair from its batch geometry: the branch-free kernel where it applies
    /// (the value of every path of those configurations), else the per-pair code.
    fn value(&self, p: PairGeom) -> Rgb {
        match &self.kernel64 {
            Some((cfg, k)) => {
                let mut out = Rgb::ZERO;
                kernel::with_config(
                    *cfg,
                    kernel::Pair {
                        k,
                        p,
                        out: &mut out,
                        grad: None,
                    },
                );
                out
            }
            None => self.kernel(p, None),
        }
    }

    /// The kernel's value loop over a batch in precision `T` into `out`; false (and nothing
    /// written) when the configuration has no such kernel.
    fn kernel_batch<T: Real, O: kernel::Sink<T>>(
        &self,
        g: &GeomSliceOf<'_, T>,
        out: O,
        baseline: bool,
    ) -> bool {
        let Some(cfg) = self.kernel_config() else {
            return false;
        };
        let k = self.kernel_consts::<T>();
        kernel::with_config(
            cfg,
            kernel::Batch {
                k: &k,
                g,
                out,
                baseline,
            },
        );
        true
    }

    /// [`Model::eval_batch`] through the baseline (non-dispatched) copy of the kernel's
    /// loop, for the test that the dispatched copies compute the same bits.
    #[doc(hidden)]
    pub fn eval_batch_baseline(&self, g: &GeomSlice<'_>, out: &mut [Rgb]) -> bool {
        self.kernel_batch(g, out, true)
    }

    /// [`Model::eval_batch_f32`] through the baseline copy (as above).
    #[doc(hidden)]
    pub fn eval_batch_f32_baseline(&self, g: &GeomSliceF32<'_>, out: [&mut [f32]; 3]) -> bool {
        self.kernel_batch(g, out, true)
    }
}

impl Brdf for CookTorrance {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        self.value(pair_geometry(wi, wo))
    }

    fn is_isotropic(&self) -> bool {
        self.alpha.is_symmetric()
    }
}

model_name!(CookTorrance, "cook-torrance");

impl Model for CookTorrance {
    fn name(&self) -> &'static str {
        Self::NAME
    }

    fn param_specs(&self) -> Vec<ParamSpec> {
        let mut v = LAYOUT.specs(&self.alpha);
        v.extend(self.fresnel.specs());
        v
    }

    fn params(&self) -> Vec<f64> {
        let mut v = ShapedLayout::values(self.rho_d, self.rho_s, &self.alpha);
        self.fresnel.push_to(&mut v);
        v
    }

    fn num_params(&self) -> usize {
        ShapedLayout::count(&self.alpha) + self.fresnel.num_params()
    }

    fn set_params(&mut self, p: &[f64]) -> Result<(), ModelError> {
        check_count(self.num_params(), p.len())?;
        let na = ShapedLayout::count(&self.alpha);
        let (d, s, alpha) = ShapedLayout::from_values(&p[..na], &self.alpha)?;
        *self = self
            .clone()
            .with_lobes(d, s, alpha)?
            .with_fresnel(self.fresnel.with_values(&p[na..]))?;
        Ok(())
    }

    fn eval_grad(&self, wi: &Vec3, wo: &Vec3, grad: &mut [Rgb]) -> Rgb {
        let p = pair_geometry(wi, wo);
        if let (Some(cfg), Some((_, k))) = (self.kernel_grad_config(), &self.kernel64) {
            let mut out = Rgb::ZERO;
            let np = self.num_params();
            kernel::with_grad_config(
                cfg,
                kernel::Pair {
                    k,
                    p,
                    out: &mut out,
                    grad: Some(&mut grad[..np]),
                },
            );
            return out;
        }
        let f = grad_via::<MAXP>(self.num_params(), grad, |g| self.kernel(p, Some(g)));
        if self.kernel_config().is_some() {
            // The value of the kernel, as every other path returns it.
            self.value(p)
        } else {
            f
        }
    }

    fn eval_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb]) {
        if self.kernel_batch(g, &mut *out, false) {
            return;
        }
        for (k, o) in out.iter_mut().enumerate().take(g.len()) {
            *o = self.kernel(batch_pair(g, k), None);
        }
    }

    /// The kernel's configurations (GGX, and Beckmann with its exact Λ) run the kernel of
    /// `cook_torrance_ggx.rs` in `f32` (error
    /// against the `f64` model: a few float32 ulp per operation, amplified where D is
    /// steep; measured in docs/models.md); the others widen to `f64`.
    fn eval_batch_f32(&self, g: &GeomSliceF32<'_>, out: [&mut [f32]; 3]) {
        if self.kernel_config().is_some() {
            self.kernel_batch(g, out, false);
        } else {
            eval_batch_f32_widened(self, g, out);
        }
    }

    /// The kernel's configurations: the loop of `cook_torrance_ggx.rs` that reads the
    /// directions itself (fused with the half vector), with the bits of `eval_batch` in
    /// `f64` and of `eval_batch_f32` in `f32`; the others have no fused kernel.
    fn eval_dirs_fused(&self, dirs: DirPairs<'_, f64>, out: &mut [Rgb]) -> bool {
        self.kernel_dirs(dirs, out)
    }

    fn eval_dirs_fused_rows(&self, dirs: DirPairs<'_, f64>, out: &mut [[f64; 3]]) -> bool {
        self.kernel_dirs(dirs, out)
    }

    fn eval_dirs_fused_f32(&self, dirs: DirPairs<'_, f32>, out: &mut [[f32; 3]]) -> bool {
        self.kernel_dirs(dirs, out)
    }

    fn eval_grad_batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: &mut [Rgb]) {
        let n = g.len();
        let np = self.num_params();
        if let (Some(cfg), Some((_, k))) = (self.kernel_grad_config(), &self.kernel64) {
            kernel::with_grad_config(
                cfg,
                kernel::BatchGrad64 {
                    k,
                    g,
                    out,
                    grad,
                    np,
                },
            );
            return;
        }
        grad_batch_via::<MAXP>(n, np, out, grad, |k, gk| {
            self.kernel(batch_pair(g, k), Some(gk))
        });
        if self.kernel_config().is_some() {
            // The values of the kernel, as every other path returns them.
            self.eval_batch(g, &mut out[..n]);
        }
    }

    fn to_json(&self) -> Value {
        let mut o = LAYOUT.write_json(self.rho_d, self.rho_s, self.alpha);
        o.insert("distribution".into(), self.distribution.name().into());
        o.insert("masking".into(), self.masking.name().into());
        o.insert("beckmann_g1".into(), self.beckmann_g1.name().into());
        o.insert("fresnel".into(), self.fresnel.to_json());
        json!({"model": "cook-torrance", "params": o})
    }

    /// True: with F ≤ 1 and ρd + ρs ≤ 1 the albedo is ≤ 1 for every distribution and
    /// masking (proof for the exact Smith forms and the V-cavity via the weak white
    /// furnace; measured for Walter's rational G1, see `docs/models.md`).
    fn conserves_energy(&self) -> bool {
        true
    }
}
