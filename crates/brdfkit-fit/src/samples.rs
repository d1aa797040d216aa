//! Scattered measured samples as the fitter's input: a gonioreflectometer's own
//! (wi, wo, RGB[, weight]) rows ([`FitData::from_samples`]) and the measured points of
//! an RGL-EPFL `.bsdf` file at their own directions ([`FitData::from_bsdf_points`]).
//! A MERL table is a third such set ([`FitData::from_table`]); all three become the
//! same [`FitData`], so every loss, solver, start strategy and subsample works on them.
//!
//! The rules (docs/fitting.md, "Scattered samples"):
//! - a sample with a NaN value in any channel is *missing*: dropped and counted;
//! - a direction that is not finite and of unit length (within
//!   [`brdfkit_core::direction::UNIT_TOLERANCE`]), or on or below the horizon, is an
//!   error naming the sample: nothing is renormalised or clamped;
//! - a negative value (RGL's spectral-to-RGB conversion leaves some) is stored as 0 and
//!   counted, as `resample --bsdf` does: every loss of the fitter compares
//!   non-negative values (the `cbrt` and `log` losses are not defined below 0), and a
//!   negative reflectance is noise around a near-zero truth that 0 is the closest
//!   physical value to;
//! - the weight is the sample's measure of (wi, wo) pairs (sr², the solid-angle weight
//!   a table cell carries); without weights every sample weighs 1: nothing about a
//!   lab's sampling density is assumed (give a weight column for a non-uniform
//!   design);
//! - samples enter in their measured order: a reciprocal model fitted to a set holding
//!   both f(a, b) and f(b, a) sees both, which is the least-squares fit to their
//!   (weighted) mean; nothing is symmetrised.

use crate::data::{FitData, SampleInput};
use crate::error::FitError;
use brdfkit_core::direction::UNIT_TOLERANCE;
use brdfkit_core::{GeometryBatch, Vec3};
use thiserror::Error;

/// One measured sample: a direction pair (both pointing away from the surface, local
/// frame z = normal), f_r in linear RGB (1/sr, without the cosine; NaN = missing) and,
/// optionally, the measure of pairs it stands for (sr²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Incident direction.
    pub wi: Vec3,
    /// Outgoing direction.
    pub wo: Vec3,
    /// f_r(wi, wo) per channel.
    pub rgb: [f64; 3],
    /// The sample's weight (finite, > 0), or `None` (weight 1).
    pub weight: Option<f64>,
}

/// What is wrong with a sample set.
#[derive(Debug, Error, PartialEq)]
pub enum SampleError {
    /// A bad sample; `row` counts samples from 0 in the caller's order.
    #[error("row {row}: {problem}")]
    Row {
        /// The sample.
        row: usize,
        /// What is wrong with it.
        problem: SampleProblem,
    },
    /// Nothing left to fit.
    #[error("no sample to fit ({rows} rows, {missing} with a missing value)")]
    Empty {
        /// Rows given.
        rows: usize,
        /// Rows dropped as missing.
        missing: usize,
    },
}

/// What is wrong with one sample.
#[derive(Debug, Error, PartialEq)]
pub enum SampleProblem {
    /// A direction that is not finite and of unit length.
    #[error("{name} = {v:?} has length {norm}, expected a unit vector (within {tol})", tol = UNIT_TOLERANCE)]
    NotUnit {
        /// `wi` or `wo`.
        name: &'static str,
        /// The direction.
        v: [f64; 3],
        /// Its length.
        norm: f64,
    },
    /// A direction on or below the horizon (z ≤ 0).
    #[error("{name} has z = {z}: on or below the horizon (f_r is defined above it)")]
    BelowHorizon {
        /// `wi` or `wo`.
        name: &'static str,
        /// Its z.
        z: f64,
    },
    /// An infinite value (a missing value is NaN).
    #[error("channel {channel} is {value}: values must be finite (NaN marks a missing value)")]
    Value {
        /// 0, 1, 2 for r, g, b.
        channel: usize,
        /// The value.
        value: f64,
    },
    /// A weight that is not finite and positive.
    #[error("weight {weight} is not a finite positive number")]
    Weight {
        /// The weight.
        weight: f64,
    },
    /// Some samples with a weight and some without.
    #[error("no weight, but row {first} has one: give every sample a weight or none")]
    MixedWeights {
        /// The first sample with one.
        first: usize,
    },
}

/// The checks of one sample's directions.
fn check_dirs(s: &Sample) -> Result<(), SampleProblem> {
    for (name, w) in [("wi", s.wi), ("wo", s.wo)] {
        let norm = w.norm();
        if !brdfkit_core::direction::is_unit([w.x, w.y, w.z]) {
            return Err(SampleProblem::NotUnit {
                name,
                v: [w.x, w.y, w.z],
                norm,
            });
        }
        if w.z <= 0.0 {
            return Err(SampleProblem::BelowHorizon { name, z: w.z });
        }
    }
    Ok(())
}

/// The sample's weight under the set's rule (`first`: the first weighted row, if any).
fn weight_of(s: &Sample, first: Option<usize>) -> Result<f64, SampleProblem> {
    match (s.weight, first) {
        (Some(w), _) if w.is_finite() && w > 0.0 => Ok(w),
        (Some(weight), _) => Err(SampleProblem::Weight { weight }),
        (None, Some(first)) => Err(SampleProblem::MixedWeights { first }),
        (None, None) => Ok(1.0),
    }
}

/// A sample's checks: its directions, weight and values (`None`: a missing value).
fn check(s: &Sample, first: Option<usize>) -> Result<Option<f64>, SampleProblem> {
    check_dirs(s)?;
    let w = weight_of(s, first)?;
    if let Some((channel, &value)) = s.rgb.iter().enumerate().find(|(_, v)| v.is_infinite()) {
        return Err(SampleProblem::Value { channel, value });
    }
    Ok((!s.rgb.iter().any(|v| v.is_nan())).then_some(w))
}

/// What is wrong with a samples file (`fit-brdf fit --samples`): its structure, or a
/// sample, named by the file and its row (`.npy`) or line (CSV).
#[derive(Debug, Error)]
pub enum SamplesFileError {
    /// Unreadable, or not the documented layout ([`brdfkit_io::samples`]).
    #[error(transparent)]
    File(#[from] brdfkit_io::samples::SamplesError),
    /// A bad sample.
    #[error("{}: {at}: {problem}", path.display())]
    Row {
        /// The file.
        path: std::path::PathBuf,
        /// `row k` or `line L`.
        at: String,
        /// What is wrong with it.
        problem: SampleProblem,
    },
    /// No sample left.
    #[error("{}: {source}", path.display())]
    Empty {
        /// The file.
        path: std::path::PathBuf,
        /// The counts.
        source: SampleError,
    },
}

/// The samples of a file's rows (9 columns, or 10 with the weight).
pub fn samples_of_rows(rows: &brdfkit_io::samples::SampleRows) -> Vec<Sample> {
    (0..rows.len())
        .map(|k| {
            let r = rows.row(k);
            Sample {
                wi: Vec3::new(r[0], r[1], r[2]),
                wo: Vec3::new(r[3], r[4], r[5]),
                rgb: [r[6], r[7], r[8]],
                weight: r.get(9).copied(),
            }
        })
        .collect()
}

impl FitData {
    /// The cells of scattered samples (see the module doc for the rules), in the given
    /// order; `kind` and `source` go into [`SampleInput`], which the fit's record
    /// carries. Every row is checked before a missing value drops it, so an error
    /// always names the first bad row.
    pub fn from_samples(
        samples: &[Sample],
        kind: &str,
        source: Option<String>,
    ) -> Result<FitData, SampleError> {
        let first = samples.iter().position(|s| s.weight.is_some());
        let mut geometry = GeometryBatch::with_capacity(samples.len());
        let mut values: [Vec<f64>; 3] = Default::default();
        let mut measure = Vec::with_capacity(samples.len());
        let (mut missing, mut negative) = (0, 0);
        for (row, s) in samples.iter().enumerate() {
            let Some(w) = check(s, first).map_err(|problem| SampleError::Row { row, problem })?
            else {
                missing += 1;
                continue;
            };
            geometry.push(&s.wi, &s.wo);
            for (c, v) in values.iter_mut().zip(s.rgb) {
                negative += usize::from(v < 0.0);
                c.push(v.max(0.0));
            }
            measure.push(w);
        }
        if measure.is_empty() {
            return Err(SampleError::Empty {
                rows: samples.len(),
                missing,
            });
        }
        let input = SampleInput {
            kind: kind.into(),
            source,
            rows: samples.len(),
            samples: measure.len(),
            dropped_missing: missing,
            dropped_other: 0,
            negative_zeroed: negative,
            weights: if first.is_some() { "given" } else { "uniform" }.into(),
        };
        let data = FitData::from_parts(geometry, values, measure)
            .expect("values and weights were checked above");
        Ok(data.with_input(input))
    }

    /// The samples of a file ([`brdfkit_io::samples`]: `.npy` N × 9|10 or CSV), as
    /// [`from_samples`](Self::from_samples) builds them; every error names the file.
    pub fn read_samples(path: &std::path::Path) -> Result<FitData, SamplesFileError> {
        let rows = brdfkit_io::samples::read_samples(path)?;
        let source = Some(path.display().to_string());
        FitData::from_samples(&samples_of_rows(&rows), "samples", source).map_err(|e| match e {
            SampleError::Row { row, problem } => SamplesFileError::Row {
                path: path.to_owned(),
                at: rows.locate(row),
                problem,
            },
            e @ SampleError::Empty { .. } => SamplesFileError::Empty {
                path: path.to_owned(),
                source: e,
            },
        })
    }

    /// The measured points of a `.bsdf` file at their own directions, with the solid
    /// angle each stands for as its weight ([`brdfkit_rgl::MeasuredPoints::read`]; the
    /// construction and its sources are in `crates/brdfkit-rgl/src/points.rs`).
    pub fn from_bsdf_points(pts: &brdfkit_rgl::MeasuredPoints) -> Result<FitData, FitError> {
        let samples: Vec<Sample> = pts
            .points
            .iter()
            .map(|p| Sample {
                wi: p.wi,
                wo: p.wo,
                rgb: p.rgb,
                weight: Some(p.weight),
            })
            .collect();
        let mut data = FitData::from_samples(&samples, "bsdf-points", Some(pts.name.clone()))
            .map_err(|e| FitError::Data(format!("{}: measured points: {e}", pts.name)))?;
        if let Some(i) = data.input_mut() {
            i.dropped_other = pts.skipped;
        }
        Ok(data)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{FitConfig, Loss, fit};
    use brdfkit_core::Model;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn dir(rng: &mut ChaCha8Rng) -> Vec3 {
        // Uniform over the hemisphere above 5°.
        let z: f64 = rng.random_range(0.0872..1.0);
        let phi: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let r = (1.0 - z * z).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// `n` samples of a model's exact values at random pairs.
    fn model_samples(m: &dyn Model, n: usize, seed: u64) -> Vec<Sample> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let (wi, wo) = (dir(&mut rng), dir(&mut rng));
                Sample {
                    wi,
                    wo,
                    rgb: m.eval(&wi, &wo).0,
                    weight: None,
                }
            })
            .collect()
    }

    fn model(json: &str) -> Box<dyn Model> {
        brdfkit_models::from_json_str(json).unwrap()
    }

    const TRUTH: &str = r#"{"model":"cook-torrance","params":{"rho_d":[0.3,0.2,0.1],"rho_s":[0.4,0.5,0.6],"alpha":0.2}}"#;

    /// The fit of a model's exact values at scattered pairs recovers its parameters,
    /// with and without a warm-up (here: 20,000 samples, more than 4 × a 4,096-cell
    /// warm-up, and 600 samples, fewer than one warm-up set), multi-start.
    #[test]
    fn a_fit_of_exact_samples_recovers_the_parameters() {
        let truth = model(TRUTH);
        for (n, warm) in [(20_000, Some(4096)), (600, Some(4096))] {
            let data = FitData::from_samples(&model_samples(truth.as_ref(), n, 7), "samples", None)
                .unwrap();
            let cfg = FitConfig::default()
                .loss(Loss::Cbrt)
                .starts(3)
                .unwrap()
                .warm_up(warm)
                .unwrap();
            let start = brdfkit_models::default_model("cook-torrance").unwrap();
            let out = fit(start.as_ref(), &data, &cfg, None).unwrap();
            assert_eq!(out.record.warm_up_cells.is_some(), n > 4 * 4096);
            let got = out.fitted.to_json();
            let alpha = got["params"]["alpha"].as_f64().unwrap();
            assert!((alpha - 0.2).abs() < 2e-5, "{n}: alpha = {alpha}");
            for (k, want) in [("rho_d", [0.3, 0.2, 0.1]), ("rho_s", [0.4, 0.5, 0.6])] {
                for (c, w) in want.iter().enumerate() {
                    let v = got["params"][k][c].as_f64().unwrap();
                    assert!((v - w).abs() < 1e-4 * w, "{n}: {k}[{c}] = {v}");
                }
            }
            let input = out
                .record
                .input
                .as_ref()
                .expect("the record names the input");
            assert_eq!((input.kind.as_str(), input.samples), ("samples", n));
            assert_eq!(input.weights, "uniform");
        }
    }

    /// A subsample of a sparse set keeps at least one cell per occupied stratum, and
    /// its multiplicities sum to the set's size.
    #[test]
    fn a_sparse_set_subsamples() {
        let truth = model(TRUTH);
        let data =
            FitData::from_samples(&model_samples(truth.as_ref(), 300, 3), "samples", None).unwrap();
        let sub = data.stratified_subsample(0.1, 1);
        let occupied: std::collections::BTreeSet<usize> =
            (0..data.len()).map(|m| data.stratum_at(m)).collect();
        assert!(
            sub.len() >= occupied.len(),
            "{} < {}",
            sub.len(),
            occupied.len()
        );
        let total: f64 = sub.multiplicity().iter().sum();
        assert!((total - 300.0).abs() < 1e-9, "{total}");
        let cfg = FitConfig::default().subsample(0.5, 1).unwrap();
        let start = brdfkit_models::default_model("lambert").unwrap();
        let out = fit(start.as_ref(), &data, &cfg, None).unwrap();
        assert!(out.record.cells_fit < 300 && out.record.cells_full == 300);
    }

    #[test]
    fn missing_values_drop_negatives_zero_and_bad_rows_are_named() {
        let z = Vec3::new(0.0, 0.0, 1.0);
        let s = |rgb: [f64; 3]| Sample {
            wi: z,
            wo: z,
            rgb,
            weight: None,
        };
        let rows = [s([0.1, f64::NAN, 0.2]), s([0.1, -0.05, 0.2]), s([0.3; 3])];
        let d = FitData::from_samples(&rows, "samples", Some("x.csv".into())).unwrap();
        assert_eq!(d.len(), 2);
        assert_eq!(d.values()[1], vec![0.0, 0.3]);
        let i = d.input().unwrap();
        assert_eq!((i.rows, i.dropped_missing, i.negative_zeroed), (3, 1, 1));
        let tilt = Vec3::new(0.6, 0.0, 0.8);
        let weighted = |w: f64| Sample {
            weight: Some(w),
            wo: tilt,
            ..s([0.1; 3])
        };
        let row = |row, problem| SampleError::Row { row, problem };
        let cases: [(Vec<Sample>, SampleError); 5] = [
            (
                vec![
                    s([0.1; 3]),
                    Sample {
                        wi: Vec3::new(0.0, 0.0, 2.0),
                        ..s([0.1; 3])
                    },
                ],
                row(
                    1,
                    SampleProblem::NotUnit {
                        name: "wi",
                        v: [0.0, 0.0, 2.0],
                        norm: 2.0,
                    },
                ),
            ),
            (
                vec![
                    s([0.1; 3]),
                    Sample {
                        wo: Vec3::new(0.6, 0.0, -0.8),
                        ..s([0.1; 3])
                    },
                ],
                row(
                    1,
                    SampleProblem::BelowHorizon {
                        name: "wo",
                        z: -0.8,
                    },
                ),
            ),
            (
                vec![s([0.1; 3]), s([0.1, f64::INFINITY, 0.0])],
                row(
                    1,
                    SampleProblem::Value {
                        channel: 1,
                        value: f64::INFINITY,
                    },
                ),
            ),
            (
                vec![weighted(1.0), weighted(0.0)],
                row(1, SampleProblem::Weight { weight: 0.0 }),
            ),
            (
                vec![s([0.1; 3]), weighted(1.0)],
                row(0, SampleProblem::MixedWeights { first: 1 }),
            ),
        ];
        for (rows, want) in cases {
            let e = FitData::from_samples(&rows, "samples", None).unwrap_err();
            assert_eq!(e, want);
            assert!(e.to_string().starts_with("row "), "{e}");
        }
        let e = FitData::from_samples(&[s([f64::NAN; 3])], "samples", None).unwrap_err();
        assert_eq!(
            e,
            SampleError::Empty {
                rows: 1,
                missing: 1
            }
        );
    }

    /// Both orders of a non-reciprocal pair in: a reciprocal model (Lambert) fits
    /// their weighted mean.
    #[test]
    fn both_orders_fit_the_mean() {
        let (a, b) = (Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.0, 0.8, 0.6));
        let rows = [
            Sample {
                wi: a,
                wo: b,
                rgb: [0.1; 3],
                weight: Some(1.0),
            },
            Sample {
                wi: b,
                wo: a,
                rgb: [0.3; 3],
                weight: Some(1.0),
            },
        ];
        let d = FitData::from_samples(&rows, "samples", None).unwrap();
        // The l2 loss compares f itself: Lambert's ρ/π is the pair's mean.
        let cfg = FitConfig::default().loss(Loss::L2);
        let start = brdfkit_models::default_model("lambert").unwrap();
        let out = fit(start.as_ref(), &d, &cfg, None).unwrap();
        let rho = out.fitted.to_json()["params"]["rho_d"][0].as_f64().unwrap();
        let want = std::f64::consts::PI * 0.2;
        assert!((rho - want).abs() < 1e-6, "{rho} vs {want}");
    }
}
