//! Synthetic materials with known parameters: the ground truth of the recovery tests,
//! the study and the benchmarks.
//!
//! Two entry points share one seeded generator:
//!
//! - [`SynthSpec`]: the spec format of `data-synthetic/` and the table generator behind
//!   `fit-brdf synth` (a [`MerlTable`] with noise and missing cells);
//! - [`synth_data`], [`add_lognormal_noise`], [`drop_cells`]: cell sets ([`FitData`])
//!   straight from a model, at full f64 precision, for the fitter's tests.
//!
//! # The spec format
//!
//! A spec is a TOML file:
//!
//! ```toml
//! name = "red-plastic"                 # required
//! description = "what it stands for"   # optional
//! dims = [90, 90, 180]                 # optional, the MERL grid by default
//!
//! [material]                           # required: the model JSON contract, in TOML
//! model = "lambert"
//! params = { rho_d = [0.5, 0.1, 0.1] }
//!
//! [noise]                              # optional
//! kind = "log-normal"                  # the only kind
//! sigma = 0.05                         # value · exp(sigma · z), z ~ N(0, 1)
//! seed = 7
//!
//! [missing]                            # optional
//! below_horizon = true                 # default true: cells whose corner-angle directions
//!                                      # have wi.z ≤ 0 or wo.z ≤ 0 are missing, as in MERL
//! fraction = 0.1                       # default 0: a further random fraction of cells
//! seed = 3
//! ```
//!
//! Unknown keys, wrong types, missing fields and out-of-domain values are errors naming
//! the file. Generation is deterministic: the noise factor and the missing draw of a cell
//! are functions of (seed, cell index, channel) through a counter-based hash (SplitMix64
//! finaliser), so the table is the same on every machine and for any thread count.
//!
//! The log-normal noise is median-preserving: the noisy value is f · exp(σ z), so ln of
//! the ratio to the truth is N(0, σ²). With `below_horizon = false` the below-horizon
//! cells keep the model's value there, which is exactly 0, as valid data.
//!
//! # The generator
//!
//! Every random draw here is a function of (seed, index, stream) through the SplitMix64
//! finaliser (Steele, Lea & Flood, "Fast splittable pseudorandom number generators",
//! OOPSLA 2014), not a sequential stream: the result does not depend on the order of
//! the draws, so it is the same for any thread count. Stream 3 decides missing cells,
//! streams 4 + c the noise of channel c. A cell set's index is the position of the cell
//! in the [`FitData`].

use crate::data::FitData;
use crate::error::FitError;
use brdfkit_core::{Model, Rgb, from_half_diff};
use brdfkit_merl::{Dims, MerlTable, cell_directions, cell_weight};
use rayon::prelude::*;
use serde::Deserialize;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Errors reading or using a synthetic-material spec.
#[derive(Debug, Error)]
pub enum SpecError {
    /// The file could not be read, or is not UTF-8 text.
    #[error(transparent)]
    Text(#[from] brdfkit_core::text::TextFileError),
    /// The file is not valid TOML or not of the spec's shape.
    #[error("{path}: {msg}")]
    Invalid {
        /// The spec file.
        path: PathBuf,
        /// What is wrong, naming the key.
        msg: String,
    },
    /// The table could not be built.
    #[error("{path}: {msg}")]
    Table {
        /// The spec (its name when it was not read from a file).
        path: PathBuf,
        /// Why the table could not be built.
        msg: String,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpecFile {
    name: String,
    description: Option<String>,
    dims: Option<[i64; 3]>,
    material: toml::Value,
    noise: Option<NoiseFile>,
    missing: Option<MissingFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NoiseFile {
    kind: String,
    sigma: f64,
    seed: u64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MissingFile {
    below_horizon: Option<bool>,
    fraction: Option<f64>,
    seed: Option<u64>,
}

/// Multiplicative log-normal noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Noise {
    /// Standard deviation of ln(noisy / true).
    pub sigma: f64,
    /// Seed of the noise stream.
    pub seed: u64,
}

/// Which cells are missing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Missing {
    /// Cells whose corner-angle directions are at or below the horizon.
    pub below_horizon: bool,
    /// A further fraction of cells, drawn at random, in [0, 1).
    pub fraction: f64,
    /// Seed of the random draw.
    pub seed: u64,
}

impl Default for Missing {
    fn default() -> Self {
        Missing {
            below_horizon: true,
            fraction: 0.0,
            seed: 0,
        }
    }
}

/// A synthetic material: a model with known parameters and how to sample it.
#[derive(Debug, Clone)]
pub struct SynthSpec {
    /// Short name.
    pub name: String,
    /// What the material stands for.
    pub description: String,
    /// Grid of the generated table.
    pub dims: Dims,
    /// The material's model and parameters.
    pub material: Box<dyn Model>,
    /// Optional multiplicative noise.
    pub noise: Option<Noise>,
    /// Missing-sample pattern.
    pub missing: Missing,
}

fn toml_to_json(v: &toml::Value) -> serde_json::Value {
    match v {
        toml::Value::String(s) => serde_json::Value::String(s.clone()),
        toml::Value::Integer(i) => serde_json::Value::from(*i),
        toml::Value::Float(f) => serde_json::Number::from_f64(*f)
            .map(serde_json::Value::Number)
            // JSON has no NaN/inf; a null makes the model parser reject it by name.
            .unwrap_or(serde_json::Value::Null),
        toml::Value::Boolean(b) => serde_json::Value::Bool(*b),
        toml::Value::Datetime(d) => serde_json::Value::String(d.to_string()),
        toml::Value::Array(a) => serde_json::Value::Array(a.iter().map(toml_to_json).collect()),
        toml::Value::Table(t) => serde_json::Value::Object(
            t.iter()
                .map(|(k, v)| (k.clone(), toml_to_json(v)))
                .collect(),
        ),
    }
}

impl SynthSpec {
    /// Reads and validates a spec file.
    pub fn read(path: impl AsRef<Path>) -> Result<SynthSpec, SpecError> {
        let path = path.as_ref();
        let text = brdfkit_core::text::read_utf8(path, "the spec")?;
        SynthSpec::from_toml_str(&text, path)
    }

    /// Parses and validates a spec; `path` names it in errors.
    pub fn from_toml_str(text: &str, path: impl AsRef<Path>) -> Result<SynthSpec, SpecError> {
        let path = path.as_ref();
        let invalid = |msg: String| SpecError::Invalid {
            path: path.to_path_buf(),
            msg,
        };
        let f: SpecFile = toml::from_str(text).map_err(|e| invalid(e.to_string()))?;
        let dims = match f.dims {
            None => Dims::MERL,
            Some([a, b, c]) => Dims::new(a, b, c).map_err(|e| invalid(format!("dims: {e}")))?,
        };
        let material = brdfkit_models::from_json(&toml_to_json(&f.material))
            .map_err(|e| invalid(format!("material: {e}")))?;
        let noise = match f.noise {
            None => None,
            Some(n) => {
                if n.kind != "log-normal" {
                    return Err(invalid(format!(
                        "noise.kind = \"{}\": the only kind is \"log-normal\"",
                        n.kind
                    )));
                }
                if !(n.sigma.is_finite() && n.sigma >= 0.0) {
                    return Err(invalid(format!(
                        "noise.sigma = {} must be finite and ≥ 0",
                        n.sigma
                    )));
                }
                Some(Noise {
                    sigma: n.sigma,
                    seed: n.seed,
                })
            }
        };
        let missing = match f.missing {
            None => Missing::default(),
            Some(m) => {
                let fraction = m.fraction.unwrap_or(0.0);
                if !(0.0..1.0).contains(&fraction) {
                    return Err(invalid(format!(
                        "missing.fraction = {fraction} must lie in [0, 1)"
                    )));
                }
                Missing {
                    below_horizon: m.below_horizon.unwrap_or(true),
                    fraction,
                    seed: m.seed.unwrap_or(0),
                }
            }
        };
        Ok(SynthSpec {
            name: f.name,
            description: f.description.unwrap_or_default(),
            dims,
            material,
            noise,
            missing,
        })
    }

    /// Generates the table (in parallel; deterministic).
    pub fn synthesize(&self) -> Result<MerlTable, SpecError> {
        let dims = self.dims;
        let model = &*self.material;
        let noise = self.noise;
        let missing = self.missing;
        MerlTable::from_fn(dims, |i, j, k| {
            let idx = dims.index(i, j, k) as u64;
            let (wi, wo) = from_half_diff(&dims.cell_angles(i, j, k));
            if missing.below_horizon && (wi.z <= 0.0 || wo.z <= 0.0) {
                return None;
            }
            if missing.fraction > 0.0 && unit(missing.seed, idx, MISSING_STREAM) < missing.fraction
            {
                return None;
            }
            let mut f = model.eval(&wi, &wo);
            if let Some(n) = noise {
                for c in 0..3 {
                    f[c] *= (n.sigma * standard_normal(n.seed, idx, c as u64)).exp();
                }
            }
            Some(f)
        })
        .map_err(|e| SpecError::Table {
            path: PathBuf::from(&self.name),
            msg: e.to_string(),
        })
    }

    /// The material's value at a pair, without noise (the ground truth of the table).
    pub fn truth(&self, wi: &brdfkit_core::Vec3, wo: &brdfkit_core::Vec3) -> Rgb {
        self.material.eval(wi, wo)
    }
}

/// Which cells of the grid a synthetic table keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Coverage {
    /// Every cell of the grid, including those whose directions are below the horizon
    /// (where every model is 0): "all cells valid".
    All,
    /// The MERL pattern: cells whose directions (at the cell's angles) are below the
    /// horizon are missing ([`MerlTable::from_brdf`]).
    AboveHorizon,
}

/// The cells of a `dims` grid with the model's values (full f64, no table round-off),
/// solid-angle measures and the chosen coverage.
pub fn synth_data(model: &dyn Model, dims: Dims, coverage: Coverage) -> Result<FitData, FitError> {
    let data = match coverage {
        Coverage::AboveHorizon => {
            let t = MerlTable::from_brdf(model, dims)
                .map_err(|e| FitError::Data(format!("synthetic table: {e}")))?;
            FitData::from_table(&t)?
        }
        Coverage::All => {
            let n = dims.cells();
            let mut g = brdfkit_core::GeometryBatch::with_capacity(n);
            let mut w = Vec::with_capacity(n);
            for x in 0..n {
                let (i, j, k) = dims.unflatten(x);
                let (_, wi, wo, _) = cell_directions(dims, i, j, k);
                g.push(&wi, &wo);
                w.push(cell_weight(dims, i, j));
            }
            let z = vec![0.0; n];
            FitData::from_parts(g, [z.clone(), z.clone(), z], w)?
        }
    };
    Ok(data.with_model_values(model))
}

/// Multiplies every value by exp(σ z), z ~ N(0, 1) (median-preserving log-normal noise
/// of relative size σ): the draw of value m, channel c is the one [`SynthSpec`] gives
/// cell m of a table with the same seed.
pub fn add_lognormal_noise(data: &mut FitData, sigma: f64, seed: u64) {
    for (c, plane) in data.values_mut().iter_mut().enumerate() {
        plane.par_iter_mut().enumerate().for_each(|(m, v)| {
            *v *= (sigma * standard_normal(seed, m as u64, c as u64)).exp();
        });
    }
}

/// Marks a seeded random `fraction` of the cells missing (drops them): the draw of
/// [`Missing::fraction`].
pub fn drop_cells(data: &FitData, fraction: f64, seed: u64) -> FitData {
    data.filter(|m| unit(seed, m as u64, MISSING_STREAM) >= fraction)
}

/// Stream of the missing-cell draw.
const MISSING_STREAM: u64 = 3;
/// First stream of the noise draws (one per channel).
const NOISE_STREAM: u64 = 4;

/// SplitMix64's finaliser: a bijective 64-bit mix (Steele, Lea & Flood 2014).
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Uniform in (0, 1) from (seed, cell, stream): never exactly 0, so ln is finite.
fn unit(seed: u64, cell: u64, stream: u64) -> f64 {
    let h =
        mix(mix(seed ^ 0x9E37_79B9_7F4A_7C15)
            .wrapping_add(cell.wrapping_mul(8).wrapping_add(stream)));
    ((h >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
}

/// A standard normal deviate from (seed, cell, channel) by Box-Muller.
fn standard_normal(seed: u64, cell: u64, channel: u64) -> f64 {
    let u1 = unit(seed, cell, NOISE_STREAM + channel);
    let u2 = unit(seed ^ 0xD1B5_4A32_D192_ED03, cell, NOISE_STREAM + channel);
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    const LAMBERT: &str = r#"
name = "grey"
dims = [16, 16, 32]
[material]
model = "lambert"
params = { rho_d = [0.5, 0.25, 0.125] }
"#;

    #[test]
    fn lambert_spec_gives_rho_over_pi_with_merl_missing_pattern() {
        let s = SynthSpec::from_toml_str(LAMBERT, "grey.toml").unwrap();
        let t = s.synthesize().unwrap();
        assert!(t.valid_fraction() > 0.3 && t.valid_fraction() < 1.0);
        let d = t.dims();
        let mut seen = 0;
        for idx in 0..d.cells() {
            let (i, j, k) = d.unflatten(idx);
            let (wi, wo) = from_half_diff(&d.cell_angles(i, j, k));
            let below = wi.z <= 0.0 || wo.z <= 0.0;
            assert_eq!(t.is_valid(idx), !below, "cell {idx}");
            if let Some(v) = t.get_flat(idx) {
                let expect = Rgb::new(0.5, 0.25, 0.125) / std::f64::consts::PI;
                for c in 0..3 {
                    assert!((v[c] - expect[c]).abs() <= 1e-15 * expect[c] * 4.0);
                }
                seen += 1;
            }
        }
        assert!(seen > 0);
    }

    #[test]
    fn noise_has_the_requested_log_spread_and_is_deterministic() {
        let text = format!("{LAMBERT}\n[noise]\nkind = \"log-normal\"\nsigma = 0.05\nseed = 9\n");
        let s = SynthSpec::from_toml_str(&text, "n.toml").unwrap();
        let a = s.synthesize().unwrap();
        let b = s.synthesize().unwrap();
        assert_eq!(a.raw(), b.raw(), "same seed, same table");
        let truth = 0.5 / std::f64::consts::PI;
        let logs: Vec<f64> = (0..a.cells())
            .filter_map(|i| a.get_flat(i))
            .map(|v| (v[0] / truth).ln())
            .collect();
        let n = logs.len() as f64;
        let mean = logs.iter().sum::<f64>() / n;
        let sd = (logs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        // n ≈ 5000: the standard error of the mean is 0.05/√n ≈ 7e-4.
        assert!(mean.abs() < 3e-3, "mean {mean}");
        assert!((sd - 0.05).abs() < 3e-3, "sd {sd}");
    }

    #[test]
    fn random_missing_fraction_is_honoured() {
        let text =
            format!("{LAMBERT}\n[missing]\nbelow_horizon = false\nfraction = 0.6\nseed = 1\n");
        let s = SynthSpec::from_toml_str(&text, "m.toml").unwrap();
        let t = s.synthesize().unwrap();
        let f = 1.0 - t.valid_fraction();
        assert!((f - 0.6).abs() < 0.02, "missing fraction {f}");
    }

    #[test]
    fn bad_specs_are_rejected_with_the_file_name() {
        let cases = [
            (
                "name = 1\n[material]\nmodel = \"lambert\"\n",
                "invalid type",
            ),
            ("[material]\nmodel = \"lambert\"\n", "missing field `name`"),
            (
                "name = \"x\"\nfoo = 1\n[material]\nmodel = \"lambert\"\n",
                "unknown field `foo`",
            ),
            (
                "name = \"x\"\n[material]\nmodel = \"lambert\"\nparams = { rho_d = 2.0 }\n",
                "rho_d",
            ),
            (
                "name = \"x\"\n[material]\nmodel = \"nope\"\n",
                "unknown model",
            ),
            (
                "name = \"x\"\ndims = [0, 1, 1]\n[material]\nmodel = \"lambert\"\n",
                "dims",
            ),
            (
                "name = \"x\"\n[material]\nmodel = \"lambert\"\n[noise]\nkind = \"gauss\"\nsigma = 0.1\nseed = 1\n",
                "log-normal",
            ),
            (
                "name = \"x\"\n[material]\nmodel = \"lambert\"\n[noise]\nkind = \"log-normal\"\nsigma = -0.1\nseed = 1\n",
                "sigma",
            ),
            (
                "name = \"x\"\n[material]\nmodel = \"lambert\"\n[missing]\nfraction = 1.0\n",
                "fraction",
            ),
        ];
        for (text, what) in cases {
            let e = SynthSpec::from_toml_str(text, "bad.toml")
                .unwrap_err()
                .to_string();
            assert!(e.starts_with("bad.toml: "), "{e}");
            assert!(e.contains(what), "expected `{what}` in: {e}");
        }
    }

    #[test]
    fn normal_deviates_look_normal() {
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|i| standard_normal(5, i, 0)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        let tail = xs.iter().filter(|x| x.abs() > 1.96).count() as f64 / n as f64;
        assert!(
            mean.abs() < 0.01 && (var - 1.0).abs() < 0.01,
            "{mean} {var}"
        );
        assert!((tail - 0.05).abs() < 0.003, "{tail}");
    }
}
