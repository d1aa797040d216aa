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
use crate::lanes::{self, select};
use crate::pair::{
    PairGeom, PairTerms, diffuse_specular_grad, lane_batch, pair_geometry, pair_terms_evals,
    pair_terms_kernel,
};
use crate::params::{DiffuseSpecular, check_count};
use brdfkit_core::model::{Domain, check_param};
use brdfkit_core::{Brdf, GeomSlice, Model, ModelError, ParamSpec, Rgb, Vec3};
use serde_json::{Value, json};
use std::f64::consts::PI;
use std::fmt;
use std::marker::PhantomData;

/// The domain of a cosine-power exponent.
pub const N_DOMAIN: Domain = Domain::at_least(0.0);

/// cⁿ on the open lobe c > 0, and 0 elsewhere, by the branch-free
/// `lanes::pow` (within 4 ulp of `f64::powf`; no library call, so
/// the batch loops vectorise).
///
/// The clamp at c ≤ 0 is the lobe's definition (max(0, cos)ⁿ). At c = 0 with n = 0 this
/// gives 0, not IEEE's pow(0, 0) = 1: 0 is the limit of 0ⁿ as n → 0⁺, so the value stays
/// continuous in n, and the lobe boundary has measure zero for every integral.
#[inline(always)]
pub fn cos_pow(c: f64, n: f64) -> f64 {
    lanes::pow(c, n)
}

/// (cⁿ, ∂cⁿ/∂n = cⁿ ln c), both 0 for c ≤ 0 (see [`cos_pow`]).
///
/// No clamp is needed for finiteness: for c > 0 the smallest double gives
/// ln c ≥ −745, and cⁿ ≤ 1 for c ≤ 1 (cosines exceed 1 only by round-off). At c = 0 the
/// derivative is the limit of cⁿ ln c as c → 0⁺, which is 0 for n > 0.
/// cⁿ to the last bit as [`cos_pow`], ln c from the same reduction
/// (`lanes::pow_ln`).
#[inline(always)]
pub fn cos_pow_dn(c: f64, n: f64) -> (f64, f64) {
    let (p, ln_c) = lanes::pow_ln(c, n);
    (p, p * ln_c)
}

/// (n+a)/(aπ) · cⁿ, the cosine power with the normalisation (n+a)/(aπ): a = 2 is
/// Lewis's exact one for a lobe about the mirror direction, a = 8 the Real-Time
/// Rendering approximation for a half-vector lobe.
#[inline(always)]
pub fn normalised_cos_pow(a: f64, c: f64, n: f64) -> f64 {
    (n + a) / (a * PI) * cos_pow(c, n)
}

/// ((n+a)/(aπ) cⁿ, its n-derivative cⁿ/(aπ) + (n+a)/(aπ) cⁿ ln c); see
/// [`normalised_cos_pow`], whose value it repeats to the last bit.
#[inline(always)]
pub fn normalised_cos_pow_dn(a: f64, c: f64, n: f64) -> (f64, f64) {
    let (p, dp) = cos_pow_dn(c, n);
    let norm = (n + a) / (a * PI);
    (norm * p, p / (a * PI) + norm * dp)
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

    /// (L(n; c, cos θi), ∂L/∂n), for cos θi > 0 and cos θo > 0: the one lobe kernel of
    /// every evaluation path (branch-free, so the batch loops vectorise; where only the
    /// value is used, the derivative's few operations are dropped by the compiler).
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

    /// The model's [`PairTerms`] kernel.
    #[inline(always)]
    fn lanes(&self) -> Kernel<K> {
        Kernel {
            d: self.d,
            s: self.s,
            n: self.n,
            kind: PhantomData,
        }
    }

    /// Value and (optionally) gradient for one pair.
    #[inline(always)]
    fn kernel(&self, p: PairGeom, grad: Option<&mut [Rgb; NP]>) -> Rgb {
        pair_terms_kernel(&self.lanes(), p, grad)
    }

    /// `eval_batch` (`grad` None) and `eval_grad_batch` as lane loops.
    fn batch(&self, g: &GeomSlice<'_>, out: &mut [Rgb], grad: Option<&mut [Rgb]>) {
        lane_batch(&self.lanes(), NP, g, out, grad);
    }
}

/// A model's parameters as its [`PairTerms`] kernel.
struct Kernel<K> {
    d: Rgb,
    s: Rgb,
    n: f64,
    kind: PhantomData<K>,
}

// By hand: a derive would ask `K: Copy` of the marker type too.
impl<K> Clone for Kernel<K> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<K> Copy for Kernel<K> {}

/// The channel-free factors of one pair: D (0 below the horizon), L and ∂L/∂n.
#[derive(Clone, Copy, Default)]
struct Terms {
    dd: f64,
    l: f64,
    dl: f64,
}

impl<K: LobeKind> PairTerms<NP> for Kernel<K> {
    type Terms = Terms;

    /// The lobe's cosine c ([`Cosine`]; h as [`GeometryBatch`](brdfkit_core::GeometryBatch)
    /// stores it), then [`LobeKind::lobe_dn`].
    #[inline(always)]
    fn terms(&self, above: bool, wi: [f64; 3], wo: [f64; 3], h: [f64; 3]) -> Terms {
        let c = match K::COSINE {
            Cosine::Mirror => mirror_cos(wi[0], wi[1], wi[2], wo[0], wo[1], wo[2]),
            Cosine::Half => h[2],
        };
        let (l, dl) = K::lobe_dn(self.n, c, wi[2]);
        Terms {
            dd: select(above, K::DIFFUSE_SCALE, 0.0),
            l: select(above, l, 0.0),
            dl: select(above, dl, 0.0),
        }
    }

    /// D d + L s per channel.
    #[inline(always)]
    fn value(&self, t: &Terms) -> Rgb {
        Rgb(std::array::from_fn(|c| {
            self.d.0[c] * t.dd + self.s.0[c] * t.l
        }))
    }

    /// ∂f/∂d = D, ∂f/∂s = L (each in its channel), ∂f/∂n = s ∂L/∂n.
    #[inline(always)]
    fn gradient(&self, t: &Terms) -> [Rgb; NP] {
        let mut gr = diffuse_specular_grad(t.dd, t.l);
        gr[6] = Rgb(std::array::from_fn(|c| self.s.0[c] * t.dl));
        gr
    }
}

/// The kinds whose d and s are the albedos ρd and ρs (`rho_d` in [0, 1]; `rho_s` in [0, ∞), or [0, 1] for plausible Phong).
pub trait AlbedoLobe: LobeKind {}

impl<K: AlbedoLobe> CosineLobeModel<K> {
    /// Sets ρd (each channel in [0, 1]).
    pub fn with_rho_d(self, rho_d: Rgb) -> Result<Self, ModelError> {
        self.with_diffuse(rho_d)
    }

    /// Sets ρs (each channel in its domain: [0, ∞), plausible Phong [0, 1]).
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
        self.kernel(pair_geometry(wi, wo), None)
    }
}

impl<K: LobeKind> CosineLobeModel<K> {
    /// The model's name in the JSON contract.
    pub const NAME: &'static str = K::NAME;
}

impl<K: LobeKind> Model for CosineLobeModel<K> {
    fn name(&self) -> &'static str {
        Self::NAME
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

    pair_terms_evals!(NP);

    fn to_json(&self) -> Value {
        let mut p = K::PARAMS.write_json(self.d, self.s);
        p.insert("n".into(), self.n.into());
        json!({"model": K::NAME, "params": p})
    }

    fn is_reciprocal(&self) -> bool {
        K::RECIPROCAL
    }

    fn conserves_energy(&self) -> bool {
        K::CONSERVES_ENERGY
    }
}

/// The checks every model of the family shares, run for each of the three kinds; the
/// formula of each lobe is checked against an independent form in its own module.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::blinn_phong::BlinnPhongLobe;
    use crate::phong::PhongLobe;
    use crate::plausible_phong::PlausiblePhongLobe;
    use crate::testing::*;
    use proptest::prelude::*;

    /// A model inside every kind's domain (ρd + ρs ≤ 1 per channel).
    fn model<K: LobeKind>() -> CosineLobeModel<K> {
        CosineLobeModel::new(Rgb::new(0.2, 0.4, 0.6), Rgb::new(0.5, 0.3, 0.1), 35.0).unwrap()
    }

    /// Runs `check::<K>()` for the three kinds.
    macro_rules! for_each_kind {
        ($check:ident) => {
            $check::<PhongLobe>();
            $check::<PlausiblePhongLobe>();
            $check::<BlinnPhongLobe>();
        };
    }

    #[test]
    fn cos_pow_conventions() {
        assert_eq!(cos_pow(0.0, 0.0), 0.0, "0⁰ is the limit from n > 0");
        assert_eq!(cos_pow(-0.5, 0.0), 0.0);
        assert_eq!(cos_pow(0.5, 0.0), 1.0);
        assert_eq!(cos_pow(0.5, 2.0), 0.25);
        assert_eq!(cos_pow_dn(0.0, 0.0), (0.0, 0.0));
        let (p, d) = cos_pow_dn(0.5, 3.0);
        assert_eq!(p, 0.125);
        assert!((d - 0.125 * 0.5f64.ln()).abs() < 1e-16);
        let (p, d) = cos_pow_dn(5e-324, 0.0);
        assert!(p == 1.0 && d.is_finite() && d < -744.0);
        // The normalised power and its derivative against the closed forms.
        for a in [2.0, 8.0] {
            let (c, n) = (0.9f64, 13.0);
            let v = (n + a) / (a * PI) * c.powf(n);
            assert!((normalised_cos_pow(a, c, n) - v).abs() <= 1e-15 * v);
            let (w, dw) = normalised_cos_pow_dn(a, c, n);
            assert_eq!(w, normalised_cos_pow(a, c, n));
            let want = c.powf(n) / (a * PI) + v * c.ln();
            assert!((dw - want).abs() <= 1e-14 * want.abs(), "{dw} vs {want}");
            assert_eq!(normalised_cos_pow_dn(a, -0.1, n), (0.0, 0.0));
        }
    }

    fn builder_and_set_params_validate<K: LobeKind>() {
        let (dn, sn) = K::PARAMS.names;
        let dom = K::PARAMS.domain.to_string();
        let bad = Rgb::new(0.1, -0.2, 0.1);
        let e = CosineLobeModel::<K>::new(bad, Rgb::splat(0.1), 5.0).unwrap_err();
        let e = e.to_string();
        assert!(e.contains(&format!("`{dn}.g`")) && e.contains(&dom), "{e}");
        let e = CosineLobeModel::<K>::new(Rgb::splat(0.1), Rgb::new(0.1, 0.1, f64::NAN), 5.0)
            .unwrap_err();
        assert!(e.to_string().contains(&format!("`{sn}.b`")), "{e}");
        for n in [-0.5, f64::NAN, f64::INFINITY] {
            let e = model::<K>().with_n(n).unwrap_err();
            assert!(e.to_string().contains("`n`"), "{e}");
        }
        assert!(
            model::<K>()
                .with_diffuse(Rgb::splat(f64::INFINITY))
                .is_err()
        );
        let mut m = model::<K>();
        assert!(m.set_params(&[0.1, 0.1, 0.1, 0.1, 0.1, 0.1, -3.0]).is_err());
        assert!(m.set_params(&[0.1, 0.1, 0.1, 0.1, -0.1, 0.1, 3.0]).is_err());
        assert!(m.set_params(&[0.1; 6]).is_err());
        assert!(m.set_params(&[0.1; 8]).is_err());
        assert_eq!(
            m,
            model(),
            "a rejected set_params leaves the model unchanged"
        );
        m.set_params(&[0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 7.0]).unwrap();
        assert_eq!(m.params(), vec![0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 7.0]);
        assert_eq!(
            (m.diffuse(), m.specular(), m.n()),
            (Rgb::new(0.1, 0.2, 0.3), Rgb::new(0.4, 0.5, 0.6), 7.0)
        );
        let names: Vec<_> = m.param_specs().into_iter().map(|s| s.name).collect();
        let want: Vec<String> = [dn, sn]
            .iter()
            .flat_map(|p| ["r", "g", "b"].map(|c| format!("{p}.{c}")))
            .chain(["n".to_string()])
            .collect();
        assert_eq!(names, want);
        assert_eq!(m.num_params(), m.param_specs().len());
        assert_eq!(m.is_reciprocal(), K::RECIPROCAL);
        assert_eq!(m.conserves_energy(), K::CONSERVES_ENERGY);
        let dbg = format!("{:?}", model::<K>());
        assert!(dbg.starts_with(&format!("{} {{ {dn}: ", K::TYPE)), "{dbg}");
    }

    #[test]
    fn builders_and_set_params_validate() {
        for_each_kind!(builder_and_set_params_validate);
    }

    fn json_round_trip_and_errors<K: LobeKind>() {
        let (dn, sn) = K::PARAMS.names;
        let m = model::<K>();
        assert_eq!(m.name(), K::NAME);
        assert_json_round_trip(&m);
        let d = crate::default_model(K::NAME).unwrap();
        assert_eq!(d.params(), CosineLobeModel::<K>::default().params());
        let (dd, ds) = K::PARAMS.defaults;
        let p = crate::from_json_str(&format!(
            r#"{{"model":"{}","params":{{"{dn}":0.2,"n":3}}}}"#,
            K::NAME
        ))
        .unwrap();
        assert_eq!(p.params(), vec![0.2, 0.2, 0.2, ds, ds, ds, 3.0]);
        let p = crate::from_json_str(&format!(r#"{{"model":"{}"}}"#, K::NAME)).unwrap();
        assert_eq!(p.params()[..4], [dd, dd, dd, ds]);
        let err = |params: &str| {
            crate::from_json_str(&format!(r#"{{"model":"{}","params":{params}}}"#, K::NAME))
                .unwrap_err()
        };
        let e = err(r#"{"kd":0.2}"#);
        assert!(e.to_string().contains("`kd`"), "{e}");
        let e = err(&format!(r#"{{"{sn}":[0.1,0.2]}}"#));
        assert!(e.to_string().contains(&format!("`{sn}`")), "{e}");
        let e = err(r#"{"n":"x"}"#);
        assert!(e.to_string().contains("`n`"), "{e}");
        let e = err(r#"{"n":-2}"#);
        assert!(matches!(e, ModelError::OutOfDomain { .. }), "{e}");
        let e = err("[1]");
        assert!(e.to_string().contains(K::NAME), "{e}");
    }

    #[test]
    fn albedo_names_set_and_get_rho_d_and_rho_s() {
        fn check<K: AlbedoLobe>() {
            let (d, s) = (Rgb::new(0.1, 0.2, 0.3), Rgb::new(0.4, 0.5, 0.6));
            let m = model::<K>().with_rho_d(d).unwrap().with_rho_s(s).unwrap();
            assert_eq!((m.rho_d(), m.rho_s()), (d, s));
            let e = m.clone().with_rho_s(Rgb::new(0.1, -1.5, 0.1)).unwrap_err();
            assert!(e.to_string().contains("`rho_s.g`"), "{e}");
            let e = m.with_rho_d(Rgb::new(0.1, 0.1, -0.5)).unwrap_err();
            assert!(e.to_string().contains("`rho_d.b`"), "{e}");
        }
        check::<PlausiblePhongLobe>();
        check::<BlinnPhongLobe>();
    }

    #[test]
    fn json_round_trips_and_errors() {
        for_each_kind!(json_round_trip_and_errors);
    }

    fn shared_checks<K: LobeKind>() {
        assert_shared_checks(&model::<K>(), 11);
    }

    #[test]
    fn shared_checks_of_every_kind() {
        for_each_kind!(shared_checks);
    }

    fn hard_cases_stay_finite<K: LobeKind>() {
        let hi = K::PARAMS.domain.hi.min(1e3);
        for n in [0.0, 1.0, 1e3, 1e6, 1e300] {
            for (d, s) in [(0.0, 0.0), (0.3, 0.7), (hi, hi)] {
                let m = CosineLobeModel::<K>::new(Rgb::splat(d), Rgb::splat(s), n).unwrap();
                assert_finite_everywhere(&m, &hard_case_pairs());
                assert_paths_agree(&m, &hard_case_pairs(), 0.0);
                assert_zero_below_horizon(&m);
            }
        }
    }

    #[test]
    fn hard_cases_stay_finite_for_every_kind() {
        for_each_kind!(hard_cases_stay_finite);
    }

    /// d, s in (0, 1) scaled up to (0, 2) where the domain allows (phong's kd, ks).
    fn fd_case<K: LobeKind>(d: f64, s: f64, n: f64, seed: u64) {
        let k = K::PARAMS.domain.hi.min(2.0);
        let (d, s) = (k * d, k * s);
        let m = CosineLobeModel::<K>::new(Rgb::new(d, 0.5, 0.3 * d), Rgb::new(0.2, s, 0.9 * s), n)
            .unwrap();
        assert_gradient_paths_reciprocity(&m, seed);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn gradient_matches_finite_differences(
            d in 0.01f64..0.99, s in 0.01f64..0.99, n in 0.5f64..1000.0, seed in any::<u64>()
        ) {
            fd_case::<PhongLobe>(d, s, n, seed);
            fd_case::<PlausiblePhongLobe>(d, s, n, seed);
            fd_case::<BlinnPhongLobe>(d, s, n, seed);
        }
    }
}
