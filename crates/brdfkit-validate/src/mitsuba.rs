//! The Mitsuba 3 cross-check: brdfkit's `lambert` and `cook-torrance` against Mitsuba's
//! `diffuse` and `roughconductor`, evaluated by Mitsuba itself (`scalar_rgb` variant of
//! the pinned PyPI wheels) on the same direction pairs.
//!
//! The pieces:
//! - [`cases`]: ≥ 5,000 direction pairs per configuration (random, grazing at 89.9°,
//!   exact and near mirror configurations, near-normal), rounded to float32 so that both
//!   sides see bit-identical inputs;
//! - [`standard_configs`]: `diffuse` vs `lambert`, and `roughconductor` (GGX and
//!   Beckmann, α from 0.01 to 1, the RGB η and k of gold, copper, silver and aluminium)
//!   vs `cook-torrance` with ρd = 0, ρs = 1, `smith-separable` masking and conductor
//!   Fresnel (Beckmann with `beckmann_g1 = rational`, Walter's G1 as Mitsuba); the
//!   Mitsuba dictionary of each comes from [`brdfkit_export`]'s mapping, the one
//!   `fit-brdf export` writes, so the cross-check tests the export too;
//! - [`run_mitsuba`]: one Python process (`python/mitsuba_eval.py` of this crate)
//!   evaluates every configuration's batch;
//! - [`compare`]: the per-case tolerance test and the measured maxima.
//!
//! # Conventions (what has to be right for the values to agree)
//! - Mitsuba's `si.wi` is the viewer side (brdfkit's `wo`); the `wo` argument of its
//!   `eval` is the light side (brdfkit's `wi`); `eval` returns f_r · cos θ of its `wo`,
//!   which the script divides out (by the float32 z of brdfkit's `wi`).
//! - `roughconductor` is one-sided (0 unless both directions are above the horizon),
//!   reciprocal, and uses the separable Smith G = G1(wi) G1(wo), Walter et al.'s rational
//!   G1 for Beckmann (EGSR 2007 eq. 27), and the exact unpolarised conductor Fresnel
//!   with η + i·k relative to vacuum at cos θd = wi·h.
//! - Mitsuba zeroes D where D(h) cos θh < 1e-20 (`MicrofacetDistribution::eval`, a
//!   float32 guard); `cook-torrance` does not, so those cases are predicted from the
//!   f64 D and must be exactly 0 on Mitsuba's side ([`Comparison::floor_cases`]).
//! - Mitsuba computes in float32: agreement is to ~1e-6 relative, not to round-off.
//!
//! # Tolerances ([`Tolerance`])
//! Per case and channel, with a = brdfkit's f_r(wi, wo), a' = f_r(wo, wi) and b =
//! Mitsuba's:
//! - both zero: agree;
//! - exactly one zero: the other must be ≤ 1e-19 ([`ZERO_FLOOR`]), unless the case is
//!   under Mitsuba's D floor (then b must be 0 and a may be anything);
//! - both non-zero: |a − b| ≤ tol · max(|a|, |b|) + |a − a'|, tol = 1e-5 for `diffuse`
//!   and GGX, and 2e-6 + 1e-6 · tan²θh / α² for Beckmann, whose exponential
//!   exp(−tan²θh/α²) amplifies the float32 rounding of its argument (the float32
//!   baseline away from the exponential is 1.4e-6, measured on GGX and Beckmann alike).
//!
//! The term |a − a'| is the **input ambiguity** of float32 directions: they are unit
//! only to ~6e-8, so wi·h and wo·h (the two readings of cos θd, equal for unit vectors)
//! differ by (|wi|² − |wo|²)/|wi + wo|, which grows without bound as wi → −wo (a
//! grazing pair on opposite sides). Mitsuba takes its Fresnel at `si.wi`·h (brdfkit's
//! wo·h) and `cook-torrance` at wi·h; a reciprocal model evaluated the other way round
//! is exactly the other reading. At θi = θo = 89.9° with azimuths 180° apart it reaches
//! 2e-5 relative (gold, blue), all of it on brdfkit's side of the comparison, since
//! float32 emulation of Mitsuba's arithmetic with wo·h reproduces Mitsuba to 5e-8.

use crate::report::{PairAt, num};
use brdfkit_core::geometry::half_vector;
use brdfkit_core::scattering::Distribution;
use brdfkit_core::{Model, Rgb, Vec3};
use brdfkit_export::{ExportError, Renderer, RendererMaterial, renderer_material};
use brdfkit_models::cook_torrance::{CookTorrance, Shape};
use brdfkit_models::lambert::Lambert;
use brdfkit_models::testing::SplitMix64;
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::Command;
use thiserror::Error;

/// Where exactly one side is zero, the other must not exceed this (1/sr).
pub const ZERO_FLOOR: f64 = 1e-19;

/// Mitsuba's floor on D(h) cos θh (`MicrofacetDistribution::eval`).
pub const MITSUBA_D_FLOOR: f64 = 1e-20;

/// Within this relative distance of [`MITSUBA_D_FLOOR`] a case may fall on either side
/// of Mitsuba's float32 test, so either outcome is accepted.
pub const FLOOR_BAND: f64 = 1e-3;

/// The version pins of `python/requirements.txt` the tolerances were measured with.
pub const MITSUBA_VERSION: &str = "3.9.1";
/// See [`MITSUBA_VERSION`].
pub const DRJIT_VERSION: &str = "1.5.0";

/// The polar angle (degrees) of the grazing cases.
pub const GRAZING_DEG: f64 = 89.9;

/// Errors of running the Python side.
#[derive(Debug, Error)]
pub enum MitsubaError {
    /// No interpreter found, Mitsuba not importable, or the variant missing: the
    /// cross-check cannot run (a skip outside CI, a failure under CI).
    #[error("Mitsuba 3 is not available: {0}")]
    Missing(String),
    /// The script ran and failed.
    #[error("{script}: exit status {status}: {stderr}")]
    Failed {
        /// The script run.
        script: String,
        /// Its exit status.
        status: String,
        /// What it wrote on stderr (trimmed).
        stderr: String,
    },
    /// Reading or writing the batch files.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O failure.
        #[source]
        source: std::io::Error,
    },
    /// The script's output does not match the batch.
    #[error("{0}")]
    Output(String),
}

/// How close brdfkit and Mitsuba must be where both are non-zero.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum Tolerance {
    /// |a − b| ≤ `rel` · max(|a|, |b|).
    Relative {
        /// The relative tolerance.
        rel: f64,
    },
    /// |a − b| ≤ (`base` + `slope` · tan²θh / α²) · max(|a|, |b|).
    Beckmann {
        /// The float32 baseline.
        base: f64,
        /// The growth with the exponent tan²θh / α².
        slope: f64,
        /// The Beckmann α.
        alpha: f64,
    },
}

impl Tolerance {
    /// The relative tolerance at a pair with half vector `h`.
    pub fn at(&self, h: &Vec3) -> f64 {
        match *self {
            Tolerance::Relative { rel } => rel,
            Tolerance::Beckmann { base, slope, alpha } => {
                let tan2 = (h.x * h.x + h.y * h.y) / (h.z * h.z);
                base + slope * tan2 / (alpha * alpha)
            }
        }
    }

    /// `1e-5 relative` or `2e-6 + 1e-6·tan²θh/α² relative`.
    pub fn describe(&self) -> String {
        match *self {
            Tolerance::Relative { rel } => format!("{} relative", num(rel)),
            Tolerance::Beckmann { base, slope, .. } => {
                format!("{} + {}·tan²θh/α² relative", num(base), num(slope))
            }
        }
    }
}

/// One configuration of the cross-check.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CrossConfig {
    /// `roughconductor-beckmann-gold-a0.1`.
    pub name: String,
    /// The Mitsuba BSDF as a `mitsuba.load_dict` dictionary.
    pub mitsuba: Value,
    /// The brdfkit model in the JSON contract.
    pub model: Value,
    /// How close the two sides must be where both are non-zero.
    pub tolerance: Tolerance,
    /// For a microfacet configuration: the distribution and α (or αx, αy), to predict
    /// Mitsuba's D floor.
    #[serde(skip)]
    pub microfacet: Option<(Distribution, Shape)>,
    /// A second brdfkit model whose difference is measured and reported, not judged
    /// (Beckmann with the exact erf Smith G1).
    pub reference: Option<Value>,
}

/// Gold, copper, silver and aluminium: (name, η RGB, k RGB), relative to vacuum.
///
/// RGB values commonly tabulated for RGB renderers, from the spectral optical constants
/// of the metals (Palik, *Handbook of Optical Constants of Solids*) at red, green and
/// blue wavelengths. Only their realism matters here: both sides get the same numbers.
pub const METALS: [(&str, [f64; 3], [f64; 3]); 4] = [
    ("gold", [0.143, 0.374, 1.442], [3.983, 2.385, 1.603]),
    ("copper", [0.200, 0.924, 1.102], [3.912, 2.452, 2.142]),
    ("silver", [0.155, 0.117, 0.138], [4.828, 3.122, 2.147]),
    ("aluminium", [1.657, 0.880, 0.521], [9.224, 6.270, 4.837]),
];

/// The roughness values of the `roughconductor` configurations.
pub const ALPHAS: [f64; 6] = [0.01, 0.03, 0.1, 0.3, 0.6, 1.0];

impl CrossConfig {
    /// The configuration `name` of the brdfkit `model`, with the Mitsuba dictionary and
    /// the microfacet parameters of [`brdfkit_export`]'s mapping: the cross-check tests
    /// the very dictionary `fit-brdf export --to mitsuba --format dict` writes.
    pub fn from_model(
        name: impl Into<String>,
        model: Value,
        tolerance: Tolerance,
        reference: Option<Value>,
    ) -> Result<Self, ExportError> {
        let material = renderer_material(&model, Renderer::Mitsuba)?;
        let microfacet = match material {
            RendererMaterial::Conductor {
                distribution,
                alpha,
                ..
            } => Some((distribution, alpha)),
            RendererMaterial::Diffuse { .. } | RendererMaterial::Plastic { .. } => None,
        };
        Ok(CrossConfig {
            name: name.into(),
            mitsuba: material.mitsuba_dict(),
            model,
            tolerance,
            microfacet,
            reference,
        })
    }
}

/// Every configuration of the cross-check: `diffuse` vs `lambert`, then for GGX and
/// Beckmann every α of [`ALPHAS`] with every metal of [`METALS`]. The Mitsuba side of
/// each is the export mapping's dictionary ([`CrossConfig::from_model`]).
pub fn standard_configs() -> Vec<CrossConfig> {
    let config = |name: String, model: Value, tolerance, reference| {
        CrossConfig::from_model(name, model, tolerance, reference)
            .expect("the standard configurations are exportable to Mitsuba")
    };
    let mut v = vec![config(
        "diffuse".into(),
        json!({"model": Lambert::NAME, "params": {"rho_d": [0.2, 0.5, 0.9]}}),
        Tolerance::Relative { rel: 1e-5 },
        None,
    )];
    for dist in [Distribution::Ggx, Distribution::Beckmann] {
        for &alpha in &ALPHAS {
            for (metal, eta, k) in METALS {
                let model = |g1: &str| {
                    json!({"model": CookTorrance::NAME, "params": {
                        "rho_d": 0.0, "rho_s": 1.0, "alpha": alpha,
                        "distribution": dist.name(), "masking": "smith-separable",
                        "beckmann_g1": g1,
                        "fresnel": {"conductor": {"eta": eta, "k": k}}}})
                };
                let beckmann = dist == Distribution::Beckmann;
                v.push(config(
                    format!("roughconductor-{}-{metal}-a{alpha}", dist.name()),
                    model(if beckmann { "rational" } else { "exact" }),
                    if beckmann {
                        Tolerance::Beckmann {
                            base: 2e-6,
                            slope: 1e-6,
                            alpha,
                        }
                    } else {
                        Tolerance::Relative { rel: 1e-5 }
                    },
                    beckmann.then(|| model("exact")),
                ));
            }
        }
    }
    v
}

/// A direction rounded to float32 per component (both sides then see the same bits).
fn f32_dir(w: Vec3) -> Vec3 {
    w.map(|x| x as f32 as f64)
}

/// Unit direction at polar angle `theta`, azimuth `phi`.
fn dir(theta: f64, phi: f64) -> Vec3 {
    brdfkit_core::direction::spherical(theta, phi)
}

/// The cases of the cross-check, rounded to float32, every direction strictly above
/// the horizon:
/// - 2,600 pairs uniform over the hemisphere (solid angle);
/// - 600 grazing: wi, wo or both at 89.9°, random azimuths;
/// - 700 exact mirror pairs wo = (−wi.x, −wi.y, wi.z) (h = normal): 500 uniform, 100
///   with θi = 89.9°, 100 with θi < 1e-3;
/// - 1,200 near-mirror pairs: the mirror direction tilted by δ log-uniform in
///   [1e-4, 1] rad, so the specular peak of every α from 0.01 to 1 is sampled;
/// - 500 near-normal: both directions within 1e-2 rad of the normal (100 of them with
///   one direction exactly on it, and (n, n) itself).
///
/// 5,600 in all, seeded: the same cases on every machine.
pub fn cases(seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut r = SplitMix64(seed);
    let mut v = Vec::with_capacity(5_600);
    let graze = GRAZING_DEG.to_radians();
    let push = |wi: Vec3, wo: Vec3, v: &mut Vec<(Vec3, Vec3)>| {
        let (a, b) = (f32_dir(wi), f32_dir(wo));
        debug_assert!(a.z > 0.0 && b.z > 0.0);
        v.push((a, b));
    };
    for _ in 0..2_600 {
        let (wi, wo) = (r.hemisphere(), r.hemisphere());
        push(wi, wo, &mut v);
    }
    for k in 0..600 {
        let g = dir(graze, r.uniform(-PI, PI));
        let o = r.hemisphere();
        match k % 3 {
            0 => push(g, o, &mut v),
            1 => push(o, g, &mut v),
            _ => push(g, dir(graze, r.uniform(-PI, PI)), &mut v),
        }
    }
    for k in 0..700 {
        let wi = match k {
            0..500 => r.hemisphere(),
            500..600 => dir(graze, r.uniform(-PI, PI)),
            _ => dir(r.uniform(0.0, 1e-3), r.uniform(-PI, PI)),
        };
        push(wi, Vec3::new(-wi.x, -wi.y, wi.z), &mut v);
    }
    let mut k = 0;
    while k < 1_200 {
        let wi = r.hemisphere();
        let m = Vec3::new(-wi.x, -wi.y, wi.z);
        // Tilt the mirror direction by δ towards a random direction perpendicular to it.
        let delta = 10f64.powf(r.uniform(-4.0, 0.0));
        let (t, b) = brdfkit_core::quadrature::frame_around(&m);
        let psi = r.uniform(-PI, PI);
        let axis = psi.cos() * t + psi.sin() * b;
        let wo = delta.cos() * m + delta.sin() * axis;
        if wo.z > 1e-3 {
            push(wi, wo, &mut v);
            k += 1;
        }
    }
    let n = Vec3::new(0.0, 0.0, 1.0);
    push(n, n, &mut v);
    for k in 0..499 {
        let a = dir(r.uniform(0.0, 1e-2), r.uniform(-PI, PI));
        let b = dir(r.uniform(0.0, 1e-2), r.uniform(-PI, PI));
        match k % 5 {
            0 => push(n, b, &mut v),
            1 => push(a, n, &mut v),
            _ => push(a, b, &mut v),
        }
    }
    v
}

/// The script of this crate that evaluates Mitsuba (`python/mitsuba_eval.py`).
pub fn script_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("python")
        .join("mitsuba_eval.py")
}

/// What the Python side reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MitsubaOutput {
    /// Mitsuba's version (`mitsuba.__version__`).
    pub mitsuba: String,
    /// Dr.Jit's version.
    pub drjit: String,
    /// The variant evaluated (`scalar_rgb`).
    pub variant: String,
    /// Per configuration, in batch order: Mitsuba's f_r per case.
    pub values: Vec<Vec<Rgb>>,
}

#[derive(Deserialize)]
struct RawConfig {
    name: String,
    f: Vec<[f64; 3]>,
}

#[derive(Deserialize)]
struct RawOutput {
    mitsuba: String,
    drjit: String,
    variant: String,
    configs: Vec<RawConfig>,
}

/// Runs `script` under `python` on every configuration with the same cases, in one
/// process, through JSON files in a temporary directory.
pub fn run_mitsuba(
    python: &Path,
    script: &Path,
    configs: &[CrossConfig],
    cases: &[(Vec3, Vec3)],
) -> Result<MitsubaOutput, MitsubaError> {
    let dir = tempfile::tempdir().map_err(|e| MitsubaError::Io {
        path: std::env::temp_dir().display().to_string(),
        source: e,
    })?;
    let flat: Vec<[f64; 6]> = cases
        .iter()
        .map(|(a, b)| [a.x, a.y, a.z, b.x, b.y, b.z])
        .collect();
    let batch = json!({
        "variant": "scalar_rgb",
        "configs": configs.iter().map(|c| json!({
            "name": c.name, "bsdf": c.mitsuba, "cases": flat})).collect::<Vec<_>>(),
    });
    let input = dir.path().join("batch.json");
    let output = dir.path().join("result.json");
    let io = |p: &Path| {
        let p = p.display().to_string();
        move |e| MitsubaError::Io { path: p, source: e }
    };
    std::fs::write(
        &input,
        serde_json::to_vec(&batch).expect("JSON of plain values"),
    )
    .map_err(io(&input))?;
    let out = Command::new(python)
        .arg(script)
        .arg(&input)
        .arg(&output)
        .output()
        .map_err(|e| MitsubaError::Missing(format!("cannot run {}: {e}", python.display())))?;
    let stderr = String::from_utf8_lossy(&out.stderr).trim().to_string();
    if out.status.code() == Some(3) {
        return Err(MitsubaError::Missing(stderr));
    }
    if !out.status.success() {
        return Err(MitsubaError::Failed {
            script: script.display().to_string(),
            status: out.status.to_string(),
            stderr,
        });
    }
    let text = std::fs::read(&output).map_err(io(&output))?;
    let raw: RawOutput = serde_json::from_slice(&text)
        .map_err(|e| MitsubaError::Output(format!("{}: {e}", output.display())))?;
    if raw.configs.len() != configs.len() {
        return Err(MitsubaError::Output(format!(
            "{} configurations back for {} sent",
            raw.configs.len(),
            configs.len()
        )));
    }
    let mut values = Vec::with_capacity(configs.len());
    for (c, r) in configs.iter().zip(raw.configs) {
        if r.name != c.name || r.f.len() != cases.len() {
            return Err(MitsubaError::Output(format!(
                "configuration `{}`: got `{}` with {} values for {} cases",
                c.name,
                r.name,
                r.f.len(),
                cases.len()
            )));
        }
        values.push(r.f.into_iter().map(Rgb::from).collect());
    }
    Ok(MitsubaOutput {
        mitsuba: raw.mitsuba,
        drjit: raw.drjit,
        variant: raw.variant,
        values,
    })
}

/// The outcome of one configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// The configuration's name ([`CrossConfig::name`]).
    pub name: String,
    /// Direction pairs compared.
    pub cases: usize,
    /// The tolerance applied ([`CrossConfig::tolerance`]).
    pub tolerance: Tolerance,
    /// Largest |a − b| / max(|a|, |b|) over the case channels where both are non-zero.
    pub max_rel_diff: f64,
    /// Where (values: [brdfkit, Mitsuba]).
    pub worst: Option<PairAt>,
    /// Largest relative distance from Mitsuba's value to the interval between
    /// f(wi, wo) and f(wo, wi): the float32 error of Mitsuba's arithmetic proper, with
    /// the ambiguity of float32 inputs (see [`compare`]) taken out.
    pub max_rel_diff_beyond_ambiguity: f64,
    /// Largest ratio of the relative difference to its allowance (tolerance plus
    /// input ambiguity; ≤ 1 passes).
    pub max_tolerance_ratio: f64,
    /// Where (values: [brdfkit, Mitsuba, allowed relative difference]).
    pub worst_ratio: Option<PairAt>,
    /// Largest |f(wi, wo) − f(wo, wi)| / |f(wi, wo)| of brdfkit's model at the float32
    /// cases (see [`compare`]).
    pub max_input_ambiguity: f64,
    /// Case channels beyond the tolerance.
    pub beyond_tolerance: usize,
    /// Case channels where both sides are exactly 0.
    pub both_zero: usize,
    /// Case channels where exactly one side is 0 (or not finite) and the other exceeds
    /// [`ZERO_FLOOR`], outside Mitsuba's D floor (must be 0).
    pub zero_mismatch: usize,
    /// The first of those (values: [brdfkit, Mitsuba]).
    pub first_zero_mismatch: Option<PairAt>,
    /// Cases under Mitsuba's D floor (D cos θh < 1e-20).
    pub floor_cases: usize,
    /// Of those, where Mitsuba is not 0 although the floor applies (must be 0).
    pub floor_violations: usize,
    /// Largest brdfkit value among the floor cases (what the floor discards).
    pub max_value_under_floor: f64,
    /// Largest relative difference of the reference model (Beckmann with the exact
    /// erf G1) to Mitsuba over the case channels where both are non-zero: reported,
    /// not judged.
    pub reference_max_rel_diff: Option<f64>,
    /// No case beyond the tolerance, no zero mismatch and no floor violation.
    pub passed: bool,
}

/// |a − b| / max(|a|, |b|) (both non-zero).
fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs())
}

/// Compares brdfkit's model of `config` with Mitsuba's values on `cases`.
pub fn compare(
    config: &CrossConfig,
    cases: &[(Vec3, Vec3)],
    mitsuba: &[Rgb],
) -> Result<Comparison, brdfkit_core::ModelError> {
    let model: Box<dyn Model> = brdfkit_models::from_json(&config.model)?;
    let reference = config
        .reference
        .as_ref()
        .map(brdfkit_models::from_json)
        .transpose()?;
    let mut c = Comparison {
        name: config.name.clone(),
        cases: cases.len(),
        tolerance: config.tolerance,
        max_rel_diff: 0.0,
        worst: None,
        max_rel_diff_beyond_ambiguity: 0.0,
        max_tolerance_ratio: 0.0,
        max_input_ambiguity: 0.0,
        worst_ratio: None,
        beyond_tolerance: 0,
        both_zero: 0,
        zero_mismatch: 0,
        first_zero_mismatch: None,
        floor_cases: 0,
        floor_violations: 0,
        max_value_under_floor: 0.0,
        reference_max_rel_diff: reference.as_ref().map(|_| 0.0),
        passed: false,
    };
    for ((wi, wo), m) in cases.iter().zip(mitsuba) {
        let a = model.eval(wi, wo);
        // The same model with the arguments swapped: equal for unit directions (the
        // model is reciprocal), different for float32 ones through wi·h ≠ wo·h.
        let swapped = model.eval(wo, wi);
        let h = half_vector(wi, wo);
        // Mitsuba's D floor, predicted in f64: under it (outside the band where float32
        // may decide either way) Mitsuba must give exactly 0.
        let floor = config.microfacet.map(|(dist, alpha)| {
            let (ax, ay) = alpha.xy();
            let dc = dist.d(h.x, h.y, h.z, ax, ay) * h.z;
            if dc < MITSUBA_D_FLOOR * (1.0 - FLOOR_BAND) {
                Some(true)
            } else if dc > MITSUBA_D_FLOOR * (1.0 + FLOOR_BAND) {
                Some(false)
            } else {
                None
            }
        });
        match floor {
            Some(Some(true)) => {
                c.floor_cases += 1;
                if *m != Rgb::ZERO {
                    c.floor_violations += 1;
                }
                c.max_value_under_floor = c.max_value_under_floor.max(a.max_channel());
                continue;
            }
            // In the band: either side of the floor is right; compare only if Mitsuba
            // kept the value.
            Some(None) if *m == Rgb::ZERO => continue,
            _ => {}
        }
        let tol = config.tolerance.at(&h);
        let r = reference.as_ref().map(|r| r.eval(wi, wo));
        for ch in 0..3 {
            let (x, y) = (a[ch], m[ch]);
            let ambiguity = (x - swapped[ch]).abs();
            c.max_input_ambiguity =
                c.max_input_ambiguity
                    .max(if x != 0.0 { ambiguity / x.abs() } else { 0.0 });
            if x == 0.0 && y == 0.0 {
                c.both_zero += 1;
                continue;
            }
            if x == 0.0 || y == 0.0 || !x.is_finite() || !y.is_finite() {
                if !(x.abs() <= ZERO_FLOOR && y.abs() <= ZERO_FLOOR) {
                    c.zero_mismatch += 1;
                    if c.first_zero_mismatch.is_none() {
                        c.first_zero_mismatch = Some(PairAt::new(wi, wo, vec![x, y], ch));
                    }
                }
                continue;
            }
            let d = rel(x, y);
            if c.worst.is_none() || d > c.max_rel_diff {
                c.max_rel_diff = d;
                c.worst = Some(PairAt::new(wi, wo, vec![x, y], ch));
            }
            // Distance from Mitsuba's value to the interval between the two readings.
            let (lo, hi) = (x.min(swapped[ch]), x.max(swapped[ch]));
            let outside = (lo - y).max(y - hi).max(0.0) / x.abs().max(y.abs());
            c.max_rel_diff_beyond_ambiguity = c.max_rel_diff_beyond_ambiguity.max(outside);
            let allowed = tol + ambiguity / x.abs().max(y.abs());
            if c.worst_ratio.is_none() || d / allowed > c.max_tolerance_ratio {
                c.max_tolerance_ratio = d / allowed;
                c.worst_ratio = Some(PairAt::new(wi, wo, vec![x, y, allowed], ch));
            }
            if d > allowed {
                c.beyond_tolerance += 1;
            }
            if let (Some(r), Some(best)) = (r, c.reference_max_rel_diff.as_mut())
                && r[ch] != 0.0
            {
                *best = best.max(rel(r[ch], y));
            }
        }
    }
    c.passed = c.beyond_tolerance == 0 && c.zero_mismatch == 0 && c.floor_violations == 0;
    Ok(c)
}

impl Comparison {
    /// One line: name, verdict, maxima and counts.
    pub fn to_text(&self) -> String {
        let mut s = format!(
            "{:<40} {} rel diff {:<9} net {:<9} (input ambiguity {:<9}) diff/allowance {:.3}; tolerance {}; {} cases",
            self.name,
            if self.passed { "PASS" } else { "FAIL" },
            num(self.max_rel_diff),
            num(self.max_rel_diff_beyond_ambiguity),
            num(self.max_input_ambiguity),
            self.max_tolerance_ratio,
            self.tolerance.describe(),
            self.cases
        );
        if self.floor_cases > 0 {
            s += &format!(
                ", {} under Mitsuba's D floor (ours ≤ {})",
                self.floor_cases,
                num(self.max_value_under_floor)
            );
        }
        if self.zero_mismatch + self.floor_violations + self.beyond_tolerance > 0 {
            s += &format!(
                "; {} beyond tolerance, {} zero mismatches, {} floor violations",
                self.beyond_tolerance, self.zero_mismatch, self.floor_violations
            );
        }
        if let Some(r) = self.reference_max_rel_diff {
            s += &format!("; exact-erf Beckmann differs by up to {}", num(r));
        }
        if !self.passed {
            for (what, w) in [
                ("largest difference", &self.worst),
                ("largest difference/allowance", &self.worst_ratio),
                ("first zero mismatch", &self.first_zero_mismatch),
            ] {
                if let Some(w) = w {
                    s += &format!(
                        "\n    {what} at {}: brdfkit {} vs Mitsuba {}",
                        w.describe(),
                        num(w.values[0]),
                        num(w.values[1])
                    );
                }
            }
        }
        s
    }
}

crate::report::display_as_text!(Comparison);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cases_cover_the_hard_configurations() {
        let v = cases(1);
        assert!(v.len() >= 5_000, "{}", v.len());
        assert!(v.iter().all(|(a, b)| a.z > 0.0 && b.z > 0.0));
        // Bit-identical in float32.
        assert!(
            v.iter()
                .all(|(a, b)| f32_dir(*a) == *a && f32_dir(*b) == *b)
        );
        let graze = GRAZING_DEG.to_radians().cos();
        let grazing = v
            .iter()
            .filter(|(a, b)| (a.z - graze).abs() < 1e-6 || (b.z - graze).abs() < 1e-6)
            .count();
        assert!(grazing >= 700, "{grazing}");
        let mirror = v
            .iter()
            .filter(|(a, b)| a.x == -b.x && a.y == -b.y && a.z == b.z)
            .count();
        assert!(mirror >= 700, "{mirror}");
        let near_normal = v
            .iter()
            .filter(|(a, b)| a.z > 0.9999 && b.z > 0.9999)
            .count();
        assert!(near_normal >= 500, "{near_normal}");
        assert_eq!(cases(1), v, "seeded");
    }

    #[test]
    fn configs_cover_metals_and_roughness() {
        let c = standard_configs();
        assert_eq!(c.len(), 1 + 2 * ALPHAS.len() * METALS.len());
        for cfg in &c {
            brdfkit_models::from_json(&cfg.model).unwrap_or_else(|e| panic!("{}: {e}", cfg.name));
        }
        assert!(
            c.iter()
                .any(|c| c.name == "roughconductor-beckmann-aluminium-a0.01")
        );
    }

    #[test]
    fn configs_use_the_export_mapping() {
        let c = standard_configs();
        // An independent transcription of Mitsuba's parameters for one configuration.
        let gold = c
            .iter()
            .find(|c| c.name == "roughconductor-beckmann-gold-a0.3")
            .unwrap();
        let rgb = |v: [f64; 3]| json!({"type": "rgb", "value": v});
        assert_eq!(
            gold.mitsuba,
            json!({"type": "roughconductor", "distribution": "beckmann", "alpha": 0.3,
                "eta": rgb([0.143, 0.374, 1.442]), "k": rgb([3.983, 2.385, 1.603]),
                "specular_reflectance": rgb([1.0, 1.0, 1.0])})
        );
        assert_eq!(
            gold.microfacet,
            Some((Distribution::Beckmann, Shape::Isotropic(0.3)))
        );
        assert_eq!(
            c[0].mitsuba,
            json!({"type": "diffuse", "reflectance": rgb([0.2, 0.5, 0.9])})
        );
        assert_eq!(c[0].microfacet, None);
        for cfg in &c {
            let m = renderer_material(&cfg.model, Renderer::Mitsuba).unwrap();
            assert_eq!(cfg.mitsuba, m.mitsuba_dict(), "{}", cfg.name);
        }
        // What Mitsuba cannot evaluate is not a configuration.
        let e = CrossConfig::from_model(
            "x",
            json!({"model": "cook-torrance", "params": {"rho_d": 0.1}}),
            Tolerance::Relative { rel: 1e-5 },
            None,
        )
        .unwrap_err();
        assert!(e.to_string().contains("Schlick"), "{e}");
    }

    #[test]
    fn anisotropic_floor_uses_both_alphas() {
        let cfg = CrossConfig::from_model(
            "aniso",
            json!({"model": "cook-torrance", "params": {"rho_d": 0, "alpha_x": 0.01,
                "alpha_y": 0.5, "distribution": "beckmann", "beckmann_g1": "rational",
                "fresnel": {"conductor": {"eta": METALS[0].1, "k": METALS[0].2}}}}),
            Tolerance::Relative { rel: 1e-5 },
            None,
        )
        .unwrap();
        assert_eq!(
            cfg.microfacet,
            Some((Distribution::Beckmann, Shape::Anisotropic(0.01, 0.5)))
        );
        assert_eq!(cfg.mitsuba["alpha_u"], 0.01);
        assert_eq!(cfg.mitsuba["alpha_v"], 0.5);
        let v = cases(9);
        let exact = ours(&cfg, &v);
        let floored = beckmann_floored(&v, &exact, 0.01, 0.5);
        let c = compare(&cfg, &v, &floored).unwrap();
        assert!(c.passed && c.floor_cases > 0, "{c}");
    }

    #[test]
    fn tolerance_grows_with_the_beckmann_exponent() {
        let t = Tolerance::Beckmann {
            base: 2e-6,
            slope: 1e-6,
            alpha: 0.1,
        };
        let h = Vec3::new(0.3f64.sin(), 0.0, 0.3f64.cos());
        let tan2 = 0.3f64.tan().powi(2);
        assert!((t.at(&h) - (2e-6 + 1e-6 * tan2 / 0.01)).abs() < 1e-18);
        assert_eq!(t.at(&Vec3::new(0.0, 0.0, 1.0)), 2e-6);
        assert_eq!(Tolerance::Relative { rel: 1e-5 }.at(&h), 1e-5);
    }

    /// Mitsuba's behaviour on `values` at `cases`: zero where the Beckmann D cos θh
    /// (roughness αx, αy) is below 1e-20.
    fn beckmann_floored(cases: &[(Vec3, Vec3)], values: &[Rgb], ax: f64, ay: f64) -> Vec<Rgb> {
        cases
            .iter()
            .zip(values)
            .map(|((a, b), x)| {
                let h = half_vector(a, b);
                let dc = Distribution::Beckmann.d(h.x, h.y, h.z, ax, ay) * h.z;
                if dc < 1e-20 { Rgb::ZERO } else { *x }
            })
            .collect()
    }

    fn lambert_config() -> CrossConfig {
        standard_configs().remove(0)
    }

    fn ours(cfg: &CrossConfig, cases: &[(Vec3, Vec3)]) -> Vec<Rgb> {
        let m = brdfkit_models::from_json(&cfg.model).unwrap();
        cases.iter().map(|(a, b)| m.eval(a, b)).collect()
    }

    #[test]
    fn comparison_passes_identical_values_and_fails_perturbed_ones() {
        let cfg = lambert_config();
        let v = cases(3);
        let exact = ours(&cfg, &v);
        let c = compare(&cfg, &v, &exact).unwrap();
        assert!(c.passed && c.max_rel_diff == 0.0, "{c}");
        // A float32-sized difference passes, a 2e-5 one does not.
        let small: Vec<Rgb> = exact.iter().map(|x| *x * (1.0 + 1e-7)).collect();
        let c = compare(&cfg, &v, &small).unwrap();
        assert!(c.passed && (c.max_rel_diff - 1e-7).abs() < 1e-9, "{c}");
        let mut big = exact.clone();
        big[17] *= 1.0 + 2e-5;
        let c = compare(&cfg, &v, &big).unwrap();
        assert!(!c.passed && c.beyond_tolerance == 3, "{c}");
        assert!(c.to_text().contains("FAIL") && c.to_text().contains("largest difference at"));
        // The cosine left in (Mitsuba's raw eval) is caught.
        let with_cos: Vec<Rgb> = exact.iter().zip(&v).map(|(x, (a, _))| *x * a.z).collect();
        assert!(!compare(&cfg, &v, &with_cos).unwrap().passed);
        // One side zero.
        let mut zero = exact.clone();
        zero[5] = Rgb::ZERO;
        let c = compare(&cfg, &v, &zero).unwrap();
        assert!(!c.passed && c.zero_mismatch == 3, "{c}");
    }

    #[test]
    fn mitsubas_d_floor_is_predicted() {
        // A sharp Beckmann lobe: most random pairs are under the floor.
        let cfg = standard_configs()
            .into_iter()
            .find(|c| c.name == "roughconductor-beckmann-gold-a0.01")
            .unwrap();
        let v = cases(5);
        let exact = ours(&cfg, &v);
        let floored = beckmann_floored(&v, &exact, 0.01, 0.01);
        let c = compare(&cfg, &v, &floored).unwrap();
        assert!(c.passed, "{c}");
        assert!(c.floor_cases > 1_000, "{c}");
        // Values kept where Mitsuba would have zeroed them are flagged.
        let c = compare(&cfg, &v, &exact).unwrap();
        let kept = v.iter().zip(&exact).filter(|((a, b), x)| {
            let h = half_vector(a, b);
            Distribution::Beckmann.d(h.x, h.y, h.z, 0.01, 0.01) * h.z < 0.999e-20
                && **x != Rgb::ZERO
        });
        assert_eq!(c.floor_violations, kept.count());
    }
}
