//! Physical checks of an analytic model: non-negativity, reciprocity, energy
//! conservation, isotropy, and finiteness over the hard cases.
//!
//! Each check measures one figure over a fixed set of direction pairs and compares it
//! with a threshold ([`Thresholds`]); the thresholds, the pair counts and the worst pair
//! are part of the [`PhysicalReport`].
//!
//! - **Non-negativity**: min f over the dense grid of
//!   [`brdfkit_models::testing::dense_grid_pairs`] plus seeded random pairs; any value
//!   below −`negativity` fails.
//! - **Reciprocity** (Helmholtz): max over the same pairs and channels of
//!   |f(wi, wo) − f(wo, wi)| / max(|f(wi, wo)|, |f(wo, wi)|), the figure of
//!   [`brdfkit_models::testing::max_reciprocity_error`].
//! - **Energy**: the directional albedo in both readings,
//!   a(wo) = ∫ f(wi, wo) cos θi dωi and a(wi) = ∫ f(wi, wo) cos θo dωo (the fraction of
//!   the light arriving from wi that is reflected; equal to the first for a reciprocal
//!   model, and the one energy conservation is about when the model is not), over a grid
//!   of polar angles (and azimuths, for an anisotropic model), by
//!   [`brdfkit_core::quadrature::directional_albedo`] about the best-converged of the
//!   mirror, retro and normal poles ([`PoleChoice`], [`albedo_converged`]), taken with
//!   the fine rule and compared with the default rule for a convergence estimate. Pass: max albedo ≤ 1 + `energy`; a convergence estimate
//!   above `convergence` makes the check inconclusive unless the albedo exceeds the
//!   bound by more than the estimate.
//! - **Isotropy**: max relative change of f when wi and wo are rotated together about
//!   the normal. Required only of models that declare themselves isotropic
//!   ([`Brdf::is_isotropic`]); measured and reported for all.
//! - **Finiteness**: no NaN or infinity in any value or gradient, on any of the four
//!   evaluation paths, over [`brdfkit_models::testing::hard_case_pairs`] (normal,
//!   near-normal, grazing, below the horizon, mirror and retro pairs), nor in any value
//!   of the dense and random pairs above.

use crate::report::{PairAt, Verdict, deg, num, rgb};
use brdfkit_core::direction::{NORMAL, reflect, spherical};
use brdfkit_core::quadrature::{AlbedoQuadrature, Pole, directional_albedo};
use brdfkit_core::{Brdf, GeometryBatch, Model, Rgb, Vec3};
use brdfkit_models::testing::{dense_grid_pairs, hard_case_pairs, random_pairs};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The limits the checks compare against. All are dimensionless.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Thresholds {
    /// f ≥ −`negativity` everywhere (0: any negative value fails).
    pub negativity: f64,
    /// Largest relative asymmetry |f(wi,wo) − f(wo,wi)| / max(|f|) allowed.
    pub reciprocity: f64,
    /// Largest directional albedo allowed is 1 + `energy`.
    pub energy: f64,
    /// Largest |fine − default| quadrature difference for the albedo to count as
    /// converged.
    pub convergence: f64,
    /// Largest relative change of f under a common rotation about the normal.
    pub isotropy: f64,
}

impl Default for Thresholds {
    /// Negativity 0; reciprocity and isotropy 1e-9 (a model computed in f64 in a
    /// different operation order differs by ~1e-15; 1e-9 leaves room for the
    /// amplification of round-off by sharp lobes); energy 1e-4 and convergence 1e-4
    /// (the default albedo rule is accurate to 2e-5 with the pole a degree from the
    /// horizon, the fine rule to 1e-7; a Lambertian ρd = 1 must pass).
    fn default() -> Self {
        Thresholds {
            negativity: 0.0,
            reciprocity: 1e-9,
            energy: 1e-4,
            convergence: 1e-4,
            isotropy: 1e-9,
        }
    }
}

/// Where the albedo quadrature puts its pole (a serialisable mirror of
/// [`brdfkit_core::quadrature::Pole`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum QuadPole {
    /// The mirror direction of the fixed direction: specular lobes.
    Mirror,
    /// The fixed direction itself: retro-reflective lobes.
    Retro,
    /// The surface normal: diffuse lobes.
    Normal,
}

impl From<QuadPole> for Pole {
    fn from(p: QuadPole) -> Pole {
        match p {
            QuadPole::Mirror => Pole::Mirror,
            QuadPole::Retro => Pole::Retro,
            QuadPole::Normal => Pole::Normal,
        }
    }
}

impl QuadPole {
    fn name(self) -> &'static str {
        match self {
            QuadPole::Mirror => "mirror",
            QuadPole::Retro => "retro",
            QuadPole::Normal => "normal",
        }
    }
}

/// How the pole of the albedo quadrature is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PoleChoice {
    /// Per direction, every candidate (mirror, retro, normal) is integrated and the
    /// best-converged one kept (see [`albedo_converged`]).
    Auto,
    /// Always this pole.
    Fixed(QuadPole),
}

/// What the checks run over. [`CheckOptions::default`] is what the CLI uses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CheckOptions {
    /// The pass/fail thresholds.
    pub thresholds: Thresholds,
    /// Polar steps of the dense grid (0 to 90° inclusive).
    pub dense_theta: usize,
    /// Azimuth steps of the dense grid.
    pub dense_phi: usize,
    /// Seeded random pairs added to the dense grid (both directions uniform over the
    /// hemisphere), for the non-negativity, reciprocity and isotropy checks.
    pub random_pairs: usize,
    /// Seed of the random pairs.
    pub seed: u64,
    /// Polar angles (radians) of the albedo curve.
    pub albedo_thetas: Vec<f64>,
    /// Pole of the albedo quadrature.
    pub pole: PoleChoice,
    /// Rotation angles (radians) of the isotropy check.
    pub isotropy_angles: Vec<f64>,
}

impl Default for CheckOptions {
    /// Dense grid 31 × 31 polar steps (3°) × 24 azimuths; 20,000 random pairs; albedo
    /// at 0, 10, …, 80, 85, 88, 89, 89.5° (at 89.9° the azimuth count the horizon needs,
    /// 16,384, made the check 10–60 s per model); rotations by 0.3, 1, 2, π/2 and π rad.
    fn default() -> Self {
        CheckOptions {
            thresholds: Thresholds::default(),
            dense_theta: 31,
            dense_phi: 24,
            random_pairs: 20_000,
            seed: 0x5EED_B4DF,
            albedo_thetas: [
                0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 85.0, 88.0, 89.0, 89.5,
            ]
            .iter()
            .map(|d: &f64| d.to_radians())
            .collect(),
            pole: PoleChoice::Auto,
            isotropy_angles: vec![0.3, 1.0, 2.0, PI / 2.0, PI],
        }
    }
}

/// f ≥ 0.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NonNegativityCheck {
    /// Pass when no pair has a channel below −threshold.
    pub verdict: Verdict,
    /// Pairs evaluated.
    pub pairs: usize,
    /// Pairs with a channel below −threshold.
    pub negative: usize,
    /// Smallest value found (any channel).
    pub min_value: f64,
    /// Where the smallest value is (values: `[f]`).
    pub worst: Option<PairAt>,
}

/// f(wi, wo) = f(wo, wi).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ReciprocityCheck {
    /// Pass when the largest relative error is within the threshold.
    pub verdict: Verdict,
    /// Pairs evaluated.
    pub pairs: usize,
    /// max |f(wi,wo) − f(wo,wi)| / max(|f(wi,wo)|, |f(wo,wi)|).
    pub max_rel_error: f64,
    /// Where (values: [f(wi,wo), f(wo,wi)]).
    pub worst: Option<PairAt>,
    /// What the model declares ([`Model::is_reciprocal`]).
    pub declared: bool,
}

/// The directional albedo at one direction, in both readings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AlbedoPoint {
    /// Polar angle (radians) of the fixed direction.
    pub theta: f64,
    /// Its azimuth (radians).
    pub phi: f64,
    /// a(wo) = ∫ f(wi, wo) cos θi dωi with wo at (θ, φ) (fine rule).
    pub a_wo: Rgb,
    /// a(wi) = ∫ f(wi, wo) cos θo dωo with wi at (θ, φ) (fine rule).
    pub a_wi: Rgb,
    /// Poles used for a(wo) and a(wi).
    pub poles: [QuadPole; 2],
    /// max over channels and both readings of |fine − default|.
    pub convergence: f64,
}

/// Directional albedo ≤ 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnergyCheck {
    /// Pass when the largest albedo is within the threshold.
    pub verdict: Verdict,
    /// Largest albedo over the curve, channels and both readings.
    pub max_albedo: f64,
    /// Which reading: `"a(wo)"` or `"a(wi)"`.
    pub max_reading: String,
    /// Polar angle (radians) where the maximum is.
    pub max_theta: f64,
    /// Largest convergence estimate over the curve.
    pub convergence: f64,
    /// The albedo curve.
    pub curve: Vec<AlbedoPoint>,
    /// What the model declares ([`Model::conserves_energy`]).
    pub declared: bool,
}

/// f invariant under a common rotation of wi and wo about the normal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IsotropyCheck {
    /// Pass when the largest relative change is within the threshold.
    pub verdict: Verdict,
    /// True when the model declares itself isotropic, so the check counts in the
    /// overall verdict.
    pub required: bool,
    /// Pairs evaluated (each at every angle).
    pub pairs: usize,
    /// Rotation angles (radians).
    pub angles: Vec<f64>,
    /// max |f(R wi, R wo) − f(wi, wo)| / max(|·|).
    pub max_rel_change: f64,
    /// Where (values: [f(wi, wo), f(R wi, R wo)]; wi, wo unrotated).
    pub worst: Option<PairAt>,
}

/// No NaN or infinity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FinitenessCheck {
    /// Pass when no value or gradient entry is non-finite.
    pub verdict: Verdict,
    /// Pairs of the hard-case grid.
    pub hard_pairs: usize,
    /// Non-finite values over the hard cases (counted per pair and path).
    pub nonfinite_values: usize,
    /// Non-finite gradient entries over the hard cases (per pair, path, parameter).
    pub nonfinite_gradients: usize,
    /// Non-finite values over the dense and random pairs.
    pub nonfinite_dense: usize,
    /// The first non-finite result found, described.
    pub first: Option<String>,
}

/// Every physical check of one model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhysicalReport {
    /// The model in the JSON contract.
    pub model: serde_json::Value,
    /// The thresholds the verdicts used.
    pub thresholds: Thresholds,
    /// f ≥ 0.
    pub non_negativity: NonNegativityCheck,
    /// f(wi, wo) = f(wo, wi).
    pub reciprocity: ReciprocityCheck,
    /// Directional albedo ≤ 1.
    pub energy: EnergyCheck,
    /// Invariance under a rotation about the normal.
    pub isotropy: IsotropyCheck,
    /// No NaN or infinity.
    pub finiteness: FinitenessCheck,
    /// All required checks passed.
    pub passed: bool,
}

/// |a − b| / max(|a|, |b|); 0 when both are 0; ∞ when either is not finite.
pub fn rel_diff(a: f64, b: f64) -> f64 {
    if !(a.is_finite() && b.is_finite()) {
        return f64::INFINITY;
    }
    let s = a.abs().max(b.abs());
    if s == 0.0 { 0.0 } else { (a - b).abs() / s }
}

/// A BRDF with its arguments swapped: integrating it over its first argument gives
/// the albedo a(wi) = ∫ f(wi, wo) cos θo dωo of the wrapped one.
struct Transposed<'a>(&'a dyn Brdf);

impl Brdf for Transposed<'_> {
    fn eval(&self, wi: &Vec3, wo: &Vec3) -> Rgb {
        self.0.eval(wo, wi)
    }
    fn is_isotropic(&self) -> bool {
        self.0.is_isotropic()
    }
}

/// The candidate (mirror, retro, normal) with the largest f(wi, w) · cos θi, where the
/// integration runs over wi with `w` fixed: where the lobe peaks among the three. A
/// cheap first guess; the checks use [`albedo_converged`], which tries all three.
/// Non-finite scores are ignored; ties keep the earlier candidate (mirror first).
pub fn auto_pole(b: &dyn Brdf, w: &Vec3) -> QuadPole {
    let mut best = (QuadPole::Mirror, f64::NEG_INFINITY);
    for (p, wi) in [
        (QuadPole::Mirror, reflect(w)),
        (QuadPole::Retro, *w),
        (QuadPole::Normal, NORMAL),
    ] {
        let s = b.eval(&wi, w).max_channel() * wi.z;
        if s.is_finite() && s > best.1 {
            best = (p, s);
        }
    }
    best.0
}

/// The default and fine albedo rules for a pole at `w` (the fixed direction).
///
/// With the pole ε above the horizon, the horizon crossing u_max(φ) of the core rule
/// swings from ~ε to ~π − ε within a φ interval of width ~ε, and a specular lobe about
/// a grazing mirror direction is squeezed by cos θd ≈ ε across the plane of incidence:
/// the trapezoid rule in φ needs a step well below ε. Measured with the mirror pole
/// (16-point Gauss segments): a Lambertian albedo has error 4e-5 at 89° and 1e-4 at
/// 89.9° with the core's 128 azimuths, 2e-6 at 89° with 256 (4.5/ε) and 6e-13 with
/// 1,024 (18/ε); a Beckmann lobe of α = 0.01 (F = 1) is off by 2.5e-2 at 88° with 128,
/// 1.1e-3 with 256 (9/ε) and converged to 5e-10 with 1,024 (36/ε). So the φ count is
/// 16/ε rounded up to a power of two, at least the core default's 128; the fine rule
/// doubles it and the Gauss order (as [`AlbedoQuadrature::fine`] does for the default).
pub fn albedo_rules(pole: QuadPole, w: &Vec3) -> (AlbedoQuadrature, AlbedoQuadrature) {
    let elevation = match pole {
        QuadPole::Mirror | QuadPole::Retro => w.z,
        QuadPole::Normal => 1.0,
    };
    // The floor keeps the count finite for a direction on the horizon (whose albedo
    // is 0 anyway): 2^20 nodes at most.
    let n_phi = ((16.0 / elevation.max(1.6e-5)).ceil() as usize)
        .max(128)
        .next_power_of_two();
    let coarse = AlbedoQuadrature {
        n_phi,
        ..AlbedoQuadrature::default()
    }
    .with_pole(pole.into());
    let fine = AlbedoQuadrature {
        n_phi: 2 * n_phi,
        ..AlbedoQuadrature::fine()
    }
    .with_pole(pole.into());
    (coarse, fine)
}

/// Max over channels of |a − b| (∞ when not finite).
fn channel_gap(a: &Rgb, b: &Rgb) -> f64 {
    (0..3)
        .map(|c| {
            let d = (a[c] - b[c]).abs();
            if d.is_finite() { d } else { f64::INFINITY }
        })
        .fold(0.0, f64::max)
}

/// The pole search of [`albedo_converged`], generic over the integral (`rule` gives
/// the value for one quadrature, and anything else the caller wants from the fine
/// rule): the fine-rule value, its pole, the convergence estimate, the fine rule's extra.
pub(crate) fn converged_with<E>(
    w: &Vec3,
    choice: PoleChoice,
    good_enough: f64,
    first_guess: QuadPole,
    rule: impl Fn(&AlbedoQuadrature) -> (Rgb, E),
) -> (Rgb, QuadPole, f64, E) {
    let candidates: Vec<QuadPole> = match choice {
        PoleChoice::Fixed(p) => vec![p],
        PoleChoice::Auto if w.x == 0.0 && w.y == 0.0 => vec![QuadPole::Normal],
        PoleChoice::Auto => {
            // The normal pole is cheap (its φ count does not grow near the horizon):
            // first; then the lobe's likely pole, then the last one.
            let mut v = vec![QuadPole::Normal];
            if first_guess != QuadPole::Normal {
                v.push(first_guess);
            }
            for p in [QuadPole::Mirror, QuadPole::Retro] {
                if !v.contains(&p) {
                    v.push(p);
                }
            }
            v
        }
    };
    let mut best: Option<(Rgb, QuadPole, f64, E)> = None;
    for pole in candidates {
        let (q, qf) = albedo_rules(pole, w);
        let (coarse, _) = rule(&q);
        let (fine, extra) = rule(&qf);
        let conv = channel_gap(&fine, &coarse);
        if best.as_ref().is_none_or(|b| conv < b.2) {
            best = Some((fine, pole, conv, extra));
        }
        if conv <= good_enough {
            break;
        }
    }
    best.expect("at least one candidate pole")
}

/// Albedo of `b` at `w` (integrating over the first argument) with the fine rule of
/// [`albedo_rules`], the pole used, and the convergence estimate max over channels of
/// |fine − default|.
///
/// [`PoleChoice::Auto`] integrates about the candidate poles (normal, then the lobe's
/// likely pole by [`auto_pole`], then the last; only the normal when `w` is the normal,
/// where they coincide) and keeps the one whose estimate is smallest: each converges to
/// the same integral, so the best-converged one is the most accurate. (A lobe missed by
/// both rules about a wrong pole gives two different samplings of its tail, not
/// agreement, so it is not chosen.) The search stops at the first estimate ≤
/// `good_enough`.
pub fn albedo_converged(
    b: &dyn Brdf,
    w: &Vec3,
    choice: PoleChoice,
    good_enough: f64,
) -> (Rgb, QuadPole, f64) {
    let (a, p, c, ()) = converged_with(w, choice, good_enough, auto_pole(b, w), |q| {
        (directional_albedo(b, w, q), ())
    });
    (a, p, c)
}

/// [`albedo_converged`] of a model, every integral a ring of nodes at a time through its
/// batch path ([`crate::rings::model_albedo`]: the same bits); with `transposed`, the
/// albedo a(wi) = ∫ f(w, wo) cos θo dωo (the [`Transposed`] model's).
pub(crate) fn model_albedo_converged(
    m: &dyn Model,
    w: &Vec3,
    choice: PoleChoice,
    good_enough: f64,
    transposed: bool,
) -> (Rgb, QuadPole, f64) {
    let guess = if transposed {
        auto_pole(&Transposed(m), w)
    } else {
        auto_pole(m, w)
    };
    let (a, p, c, ()) = converged_with(w, choice, good_enough, guess, |q| {
        (crate::rings::model_albedo(m, w, q, transposed), ())
    });
    (a, p, c)
}

/// The albedo curve of a BRDF in both readings, at the given polar angles and azimuths
/// (in parallel). With `reciprocal` (the reciprocity check passed), a(wi) is a(wo) and
/// is not integrated again.
pub fn albedo_curve(
    b: &dyn Brdf,
    thetas: &[f64],
    phis: &[f64],
    pole: PoleChoice,
    good_enough: f64,
    reciprocal: bool,
) -> Vec<AlbedoPoint> {
    curve_of(thetas, phis, reciprocal, |w, transposed| {
        if transposed {
            albedo_converged(&Transposed(b), w, pole, good_enough)
        } else {
            albedo_converged(b, w, pole, good_enough)
        }
    })
}

/// [`albedo_curve`] of a model, through its batch path (`model_albedo_converged`:
/// the same points).
pub fn model_albedo_curve(
    m: &dyn Model,
    thetas: &[f64],
    phis: &[f64],
    pole: PoleChoice,
    good_enough: f64,
    reciprocal: bool,
) -> Vec<AlbedoPoint> {
    curve_of(thetas, phis, reciprocal, |w, transposed| {
        model_albedo_converged(m, w, pole, good_enough, transposed)
    })
}

/// The albedo curve at every (θ, φ) (in parallel), `albedo(w, transposed)` giving the
/// converged albedo a(wo) at wo = w, or with `transposed` a(wi) at wi = w.
fn curve_of(
    thetas: &[f64],
    phis: &[f64],
    reciprocal: bool,
    albedo: impl Fn(&Vec3, bool) -> (Rgb, QuadPole, f64) + Sync,
) -> Vec<AlbedoPoint> {
    let dirs: Vec<(f64, f64)> = thetas
        .iter()
        .flat_map(|&t| phis.iter().map(move |&p| (t, p)))
        .collect();
    dirs.par_iter()
        .map(|&(theta, phi)| {
            let w = spherical(theta, phi);
            let (a_wo, p_wo, c_wo) = albedo(&w, false);
            let (a_wi, p_wi, c_wi) = if reciprocal {
                (a_wo, p_wo, c_wo)
            } else {
                albedo(&w, true)
            };
            AlbedoPoint {
                theta,
                phi,
                a_wo,
                a_wi,
                poles: [p_wo, p_wi],
                convergence: c_wo.max(c_wi),
            }
        })
        .collect()
}

/// Worst-case accumulator for parallel scans: the largest `score` and where.
#[derive(Clone)]
struct Worst {
    score: f64,
    at: Option<PairAt>,
    count: usize,
    nonfinite: usize,
}

impl Worst {
    fn new() -> Self {
        Worst {
            score: f64::NEG_INFINITY,
            at: None,
            count: 0,
            nonfinite: 0,
        }
    }
    fn offer(&mut self, score: f64, at: impl FnOnce() -> PairAt) {
        if score > self.score {
            self.score = score;
            self.at = Some(at());
        }
    }
    fn merge(mut self, o: Worst) -> Worst {
        if o.score > self.score {
            self.score = o.score;
            self.at = o.at;
        }
        self.count += o.count;
        self.nonfinite += o.nonfinite;
        self
    }
}

/// Rotation of `w` by `angle` about the normal.
fn rotate_z(w: &Vec3, angle: f64) -> Vec3 {
    let (s, c) = angle.sin_cos();
    Vec3::new(c * w.x - s * w.y, s * w.x + c * w.y, w.z)
}

fn check_non_negativity(
    m: &dyn Model,
    pairs: &[(Vec3, Vec3)],
    t: &Thresholds,
) -> (NonNegativityCheck, usize) {
    let w = pairs
        .par_iter()
        .fold(Worst::new, |mut acc, (wi, wo)| {
            let f = m.eval(wi, wo);
            if !f.is_finite() {
                acc.nonfinite += 1;
            }
            for c in 0..3 {
                // Scored as −f so the worst is the smallest value; NaN is not scored
                // here (the finiteness check counts it).
                if f[c] < -t.negativity {
                    acc.count += 1;
                }
                if f[c].is_finite() {
                    acc.offer(-f[c], || PairAt::new(wi, wo, vec![f[c]], c));
                }
            }
            acc
        })
        .reduce(Worst::new, Worst::merge);
    let min_value = if w.at.is_some() { -w.score } else { f64::NAN };
    (
        NonNegativityCheck {
            verdict: Verdict::from_bool(w.count == 0 && w.at.is_some()),
            pairs: pairs.len(),
            negative: w.count,
            min_value,
            worst: w.at,
        },
        w.nonfinite,
    )
}

/// The largest relative difference, over `pairs` and the channels, between f at a pair
/// and f at each of its `n` images `image(wi, wo, k)`, with where it is. Non-finite
/// values are skipped: they are the finiteness check's to count.
fn worst_change(
    m: &dyn Model,
    pairs: &[(Vec3, Vec3)],
    n: usize,
    image: impl Fn(&Vec3, &Vec3, usize) -> (Vec3, Vec3) + Sync,
) -> Worst {
    pairs
        .par_iter()
        .fold(Worst::new, |mut acc, (wi, wo)| {
            let a = m.eval(wi, wo);
            for k in 0..n {
                let (ii, oo) = image(wi, wo, k);
                let b = m.eval(&ii, &oo);
                for c in 0..3 {
                    if !(a[c].is_finite() && b[c].is_finite()) {
                        continue;
                    }
                    acc.offer(rel_diff(a[c], b[c]), || {
                        PairAt::new(wi, wo, vec![a[c], b[c]], c)
                    });
                }
            }
            acc
        })
        .reduce(Worst::new, Worst::merge)
}

fn check_reciprocity(m: &dyn Model, pairs: &[(Vec3, Vec3)], t: &Thresholds) -> ReciprocityCheck {
    let w = worst_change(m, pairs, 1, |wi, wo, _| (*wo, *wi));
    let e = w.score.max(0.0);
    ReciprocityCheck {
        verdict: Verdict::from_bool(e <= t.reciprocity),
        pairs: pairs.len(),
        max_rel_error: e,
        worst: w.at,
        declared: m.is_reciprocal(),
    }
}

fn check_isotropy(
    m: &dyn Model,
    pairs: &[(Vec3, Vec3)],
    angles: &[f64],
    t: &Thresholds,
) -> IsotropyCheck {
    let w = worst_change(m, pairs, angles.len(), |wi, wo, k| {
        (rotate_z(wi, angles[k]), rotate_z(wo, angles[k]))
    });
    let e = w.score.max(0.0);
    IsotropyCheck {
        verdict: Verdict::from_bool(e <= t.isotropy),
        required: m.is_isotropic(),
        pairs: pairs.len(),
        angles: angles.to_vec(),
        max_rel_change: e,
        worst: w.at,
    }
}

fn check_energy(m: &dyn Model, o: &CheckOptions, reciprocal: bool) -> EnergyCheck {
    let phis: Vec<f64> = if m.is_isotropic() {
        vec![0.0]
    } else {
        vec![0.0, PI / 4.0, PI / 2.0, 3.0 * PI / 4.0]
    };
    // A pole whose estimate is a hundredth of the bound is kept without trying others.
    let good_enough = 1e-2 * o.thresholds.convergence;
    let curve = model_albedo_curve(m, &o.albedo_thetas, &phis, o.pole, good_enough, reciprocal);
    let mut max = (f64::NEG_INFINITY, "a(wo)", 0.0);
    let mut conv: f64 = 0.0;
    for p in &curve {
        for (reading, a) in [("a(wo)", &p.a_wo), ("a(wi)", &p.a_wi)] {
            for c in 0..3 {
                // A non-finite albedo is an unbounded one.
                let v = if a[c].is_nan() { f64::INFINITY } else { a[c] };
                if v > max.0 {
                    max = (v, reading, p.theta);
                }
            }
        }
        conv = conv.max(p.convergence);
    }
    let t = &o.thresholds;
    let measured = (!curve.is_empty()).then_some(max.0);
    let verdict = Verdict::of_energy(measured, conv, t.energy, t.convergence);
    EnergyCheck {
        verdict,
        max_albedo: max.0,
        max_reading: max.1.to_string(),
        max_theta: max.2,
        convergence: conv,
        curve,
        declared: m.conserves_energy(),
    }
}

fn check_finiteness(m: &dyn Model, nonfinite_dense: usize) -> FinitenessCheck {
    let pairs = hard_case_pairs();
    let names: Vec<String> = m.param_specs().into_iter().map(|s| s.name).collect();
    let np = names.len();
    let mut values = 0;
    let mut grads = 0;
    let mut first: Option<String> = None;
    let mut note = |what: String| {
        if first.is_none() {
            first = Some(what);
        }
    };
    let at = |wi: &Vec3, wo: &Vec3| PairAt::new(wi, wo, vec![], 0).describe_angles();
    let mut g = vec![Rgb::ZERO; np];
    for (wi, wo) in &pairs {
        let f = m.eval(wi, wo);
        if !f.is_finite() {
            values += 1;
            note(format!("eval = {f:?} at {}", at(wi, wo)));
        }
        let fg = m.eval_grad(wi, wo, &mut g);
        if !fg.is_finite() {
            values += 1;
            note(format!("eval_grad value = {fg:?} at {}", at(wi, wo)));
        }
        for (p, gp) in g.iter().enumerate() {
            if !gp.is_finite() {
                grads += 1;
                note(format!(
                    "eval_grad ∂f/∂{} = {gp:?} at {}",
                    names[p],
                    at(wi, wo)
                ));
            }
        }
    }
    let batch = GeometryBatch::from_pairs(&pairs);
    let n = pairs.len();
    let mut out = vec![Rgb::ZERO; n];
    m.eval_batch(&batch.as_slice(), &mut out);
    for (k, f) in out.iter().enumerate() {
        if !f.is_finite() {
            values += 1;
            note(format!(
                "eval_batch = {f:?} at {}",
                at(&pairs[k].0, &pairs[k].1)
            ));
        }
    }
    let mut grad = vec![Rgb::ZERO; np * n];
    m.eval_grad_batch(&batch.as_slice(), &mut out, &mut grad);
    for (k, f) in out.iter().enumerate() {
        if !f.is_finite() {
            values += 1;
            note(format!(
                "eval_grad_batch value = {f:?} at {}",
                at(&pairs[k].0, &pairs[k].1)
            ));
        }
    }
    for (idx, gp) in grad.iter().enumerate() {
        if !gp.is_finite() {
            grads += 1;
            let (p, k) = (idx / n, idx % n);
            note(format!(
                "eval_grad_batch ∂f/∂{} = {gp:?} at {}",
                names[p],
                at(&pairs[k].0, &pairs[k].1)
            ));
        }
    }
    if nonfinite_dense > 0 {
        note(format!(
            "{nonfinite_dense} non-finite values over the dense and random pairs"
        ));
    }
    FinitenessCheck {
        verdict: Verdict::from_bool(values + grads + nonfinite_dense == 0),
        hard_pairs: n,
        nonfinite_values: values,
        nonfinite_gradients: grads,
        nonfinite_dense,
        first,
    }
}

/// Runs every physical check on a model with the default options.
pub fn check_model(m: &dyn Model) -> PhysicalReport {
    check_model_with(m, &CheckOptions::default())
}

/// Runs every physical check on a model.
pub fn check_model_with(m: &dyn Model, o: &CheckOptions) -> PhysicalReport {
    let mut pairs = dense_grid_pairs(o.dense_theta.max(2), o.dense_phi.max(1));
    pairs.extend(random_pairs(o.seed, o.random_pairs));
    let t = &o.thresholds;
    let (non_negativity, nonfinite_dense) = check_non_negativity(m, &pairs, t);
    let reciprocity = check_reciprocity(m, &pairs, t);
    // The dense grid has φi = 0 only; rotations of it are the random pairs' job.
    let iso_pairs = random_pairs(o.seed ^ 0x1507, o.random_pairs.clamp(1, 5_000));
    let isotropy = check_isotropy(m, &iso_pairs, &o.isotropy_angles, t);
    // a(wi) = a(wo) for a reciprocal model: integrated once when reciprocity holds.
    let energy = check_energy(m, o, reciprocity.verdict.passed());
    let finiteness = check_finiteness(m, nonfinite_dense);
    let passed = non_negativity.verdict.passed()
        && reciprocity.verdict.passed()
        && energy.verdict.passed()
        && (!isotropy.required || isotropy.verdict.passed())
        && finiteness.verdict.passed();
    PhysicalReport {
        model: m.to_json(),
        thresholds: t.clone(),
        non_negativity,
        reciprocity,
        energy,
        isotropy,
        finiteness,
        passed,
    }
}

impl PhysicalReport {
    /// The report as indented text: one line per check with its verdict, figure and
    /// threshold, then the albedo curve.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let t = &self.thresholds;
        let name = self
            .model
            .get("model")
            .and_then(|v| v.as_str())
            .unwrap_or("?");
        s += &format!(
            "physical checks of `{name}` {}: {}\n",
            self.model
                .get("params")
                .map(|p| p.to_string())
                .unwrap_or_default(),
            if self.passed { "PASS" } else { "FAIL" }
        );
        let nn = &self.non_negativity;
        s += &format!(
            "  non-negativity  {:<12} min f = {} over {} pairs, {} negative (threshold f ≥ {})\n",
            nn.verdict.label(),
            num(nn.min_value),
            nn.pairs,
            nn.negative,
            num(-t.negativity)
        );
        if nn.negative > 0
            && let Some(w) = &nn.worst
        {
            s += &format!("                  worst at {}\n", w.describe());
        }
        let r = &self.reciprocity;
        s += &format!(
            "  reciprocity     {:<12} max relative asymmetry {} over {} pairs (threshold {}; model declares {})\n",
            r.verdict.label(),
            num(r.max_rel_error),
            r.pairs,
            num(t.reciprocity),
            if r.declared {
                "reciprocal"
            } else {
                "non-reciprocal"
            }
        );
        if !r.verdict.passed()
            && let Some(w) = &r.worst
        {
            s += &format!(
                "                  worst at {}: f(wi,wo) = {}, f(wo,wi) = {}\n",
                w.describe(),
                num(w.values[0]),
                num(w.values[1])
            );
        }
        let e = &self.energy;
        s += &format!(
            "  energy          {:<12} max albedo {} ({} at θ = {}), convergence {} (threshold ≤ 1 + {}, convergence ≤ {}; model declares {})\n",
            e.verdict.label(),
            num(e.max_albedo),
            e.max_reading,
            deg(e.max_theta.to_degrees()),
            num(e.convergence),
            num(t.energy),
            num(t.convergence),
            if e.declared {
                "energy-conserving"
            } else {
                "no energy bound"
            }
        );
        let i = &self.isotropy;
        s += &format!(
            "  isotropy        {:<12} max relative change {} over {} pairs × {} rotations (threshold {}{})\n",
            i.verdict.label(),
            num(i.max_rel_change),
            i.pairs,
            i.angles.len(),
            num(t.isotropy),
            if i.required {
                ""
            } else {
                "; not required: the model declares itself anisotropic"
            }
        );
        let f = &self.finiteness;
        s += &format!(
            "  finiteness      {:<12} {} non-finite values, {} non-finite gradient entries over {} hard-case pairs; {} non-finite values over the dense pairs\n",
            f.verdict.label(),
            f.nonfinite_values,
            f.nonfinite_gradients,
            f.hard_pairs,
            f.nonfinite_dense
        );
        if let Some(first) = &f.first {
            s += &format!("                  first: {first}\n");
        }
        s += "  albedo curve (fine rule; a(wo) = ∫f cosθi dωi, a(wi) = ∫f cosθo dωo):\n";
        s += "      θ        φ     a(wo) [R, G, B]                 a(wi) [R, G, B]                 poles          convergence\n";
        for p in &e.curve {
            s += &format!(
                "    {:>7} {:>6}  {:<31} {:<31} {:<14} {}\n",
                deg(p.theta.to_degrees()),
                deg(p.phi.to_degrees()),
                rgb(&p.a_wo),
                rgb(&p.a_wi),
                format!("{}/{}", p.poles[0].name(), p.poles[1].name()),
                num(p.convergence)
            );
        }
        s
    }
}

crate::report::display_as_text!(PhysicalReport);
