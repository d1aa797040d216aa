//! Evaluation choices: the error each cheaper choice introduces and the time it saves.
//!
//! - table lookup: nearest bin vs multilinear interpolation, against the analytic truth
//!   of the synthetic material at random direction pairs;
//! - Cook-Torrance variants against a reference on the valid cells of the MERL grid:
//!   Schlick vs exact conductor Fresnel, rational vs exact-erf Beckmann G1, separable vs
//!   height-correlated Smith, and the model's float32 path (`Model::eval_batch_f32`) vs
//!   its `f64` path.
//!
//! Errors: relative error |f̂ − f|/f over the (pair, channel)s where the reference is
//! positive (median, 90th and 99th percentile, maximum), and the `cbrt` error — the
//! solid-angle-weighted RMS of ∛(f̂ cos θi) − ∛(f cos θi), the fitter's default loss
//! (docs/fitting.md), so it reads on the same scale as the fit grid's losses. Times: one
//! thread, minimum over `reps` runs, per evaluated cell or pair.

use crate::{StudyConfig, StudyError, SynthMaterial};
use brdfkit_core::direction::spherical;
use brdfkit_core::progress::{Event, Observe};
use brdfkit_core::scattering::{BeckmannG1, Masking};
use brdfkit_core::{GeometryBatch, GeometryBatchF32, Model, ModelError, Rgb, Vec3};
use brdfkit_fit::synth::SynthSpec;
use brdfkit_fit::{FitConfig, FitData, fit};
use brdfkit_merl::Lookup;
use brdfkit_models::cook_torrance::{CookTorrance, Fresnel};
use brdfkit_models::par::{eval_batch_f32_par, eval_batch_par};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::hint::black_box;
use std::time::Instant;

/// Error statistics of an approximation against a reference.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq)]
pub struct ErrorStats {
    /// (pair, channel)s compared (reference > 0, approximation present).
    pub n: usize,
    /// Median relative error.
    pub rel_median: f64,
    /// 90th percentile of the relative error.
    pub rel_p90: f64,
    /// 99th percentile of the relative error.
    pub rel_p99: f64,
    /// Largest relative error.
    pub rel_max: f64,
    /// Weighted RMS of the cube-root difference (the `cbrt` loss).
    pub cbrt_rms: f64,
}

/// Accumulates errors of (reference, approximation, cos θi, weight) samples.
#[derive(Default)]
struct ErrAcc {
    rel: Vec<f64>,
    sq: [f64; 3],
    w: f64,
}

impl ErrAcc {
    fn add(&mut self, reference: Rgb, approx: Rgb, cos_i: f64, w: f64) {
        for c in 0..3 {
            let (f, g) = (reference[c], approx[c]);
            if f > 0.0 {
                self.rel.push((g - f).abs() / f);
            }
            let d = brdfkit_fit::loss::cbrt(g * cos_i) - brdfkit_fit::loss::cbrt(f * cos_i);
            self.sq[c] += w * d * d;
        }
        self.w += w;
    }

    fn finish(mut self) -> ErrorStats {
        self.rel.sort_by(|a, b| a.total_cmp(b));
        let q = |p: f64| {
            if self.rel.is_empty() {
                f64::NAN
            } else {
                self.rel[((self.rel.len() - 1) as f64 * p).round() as usize]
            }
        };
        let per_ch: Vec<f64> = self.sq.iter().map(|s| s / self.w).collect();
        ErrorStats {
            n: self.rel.len(),
            rel_median: q(0.5),
            rel_p90: q(0.9),
            rel_p99: q(0.99),
            rel_max: q(1.0),
            cbrt_rms: (per_ch.iter().sum::<f64>() / 3.0).sqrt(),
        }
    }
}

/// Minimum wall time of `reps` runs of `f`, seconds.
pub fn time_min(reps: usize, mut f: impl FnMut()) -> f64 {
    (0..reps.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// A rayon pool of `n` threads.
pub fn pool(n: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .expect("a rayon pool")
}

/// One lookup mode on one material.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct LookupRow {
    /// Spec name of the material.
    pub material: String,
    /// `nearest` or `interpolated`.
    pub mode: String,
    /// Direction pairs looked up.
    pub pairs: usize,
    /// Fraction of the pairs that got a value (the rest land in missing cells).
    pub found: f64,
    #[serde(flatten)]
    /// Errors against the reference.
    pub err: ErrorStats,
    /// Time per lookup through `lookup_batch`, one thread and all threads, ns.
    pub ns_1_thread: f64,
    /// Same on all threads, ns.
    pub ns_all_threads: f64,
}

/// `n` seeded random pairs, both directions uniform over the upper hemisphere.
pub fn random_pairs(n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut dir = move || {
        // z uniform in (0, 1] is uniform in solid angle, strictly above the horizon.
        let z: f64 = 1.0 - rng.random::<f64>();
        spherical(z.acos(), rng.random_range(-PI..PI))
    };
    (0..n).map(|_| (dir(), dir())).collect()
}

/// Nearest vs interpolated lookups against the truth, per material (the noise-free
/// ones: a noisy table's error is mostly its noise).
pub fn lookups(
    cfg: &StudyConfig,
    materials: &[SynthMaterial],
    progress: &dyn Observe,
) -> Result<Vec<LookupRow>, StudyError> {
    let pairs = random_pairs(cfg.lookup_pairs, 0x4c4f4f4b);
    let one = pool(1);
    let mut rows = Vec::new();
    for m in materials.iter().filter(|m| m.spec.noise.is_none()) {
        let truth: Vec<Rgb> = pairs
            .par_iter()
            .map(|(wi, wo)| m.spec.truth(wi, wo))
            .collect();
        for (name, mode) in [
            ("nearest", Lookup::Nearest),
            ("interpolated", Lookup::Interpolated),
        ] {
            let got = m.table.lookup_batch(mode, &pairs);
            let mut acc = ErrAcc::default();
            let mut found = 0usize;
            for ((g, t), (wi, _)) in got.iter().zip(&truth).zip(&pairs) {
                if let Some(g) = g {
                    found += 1;
                    acc.add(*t, *g, wi.z, 1.0);
                }
            }
            let t1 = one.install(|| {
                time_min(cfg.reps, || {
                    black_box(m.table.lookup_batch(mode, black_box(&pairs)));
                })
            });
            let ta = time_min(cfg.reps, || {
                black_box(m.table.lookup_batch(mode, black_box(&pairs)));
            });
            let row = LookupRow {
                material: m.spec.name.clone(),
                mode: name.into(),
                pairs: pairs.len(),
                found: found as f64 / pairs.len() as f64,
                err: acc.finish(),
                ns_1_thread: t1 / pairs.len() as f64 * 1e9,
                ns_all_threads: ta / pairs.len() as f64 * 1e9,
            };
            progress.observe(&Event::Step(format!(
                "lookup {} {}: median rel {:.2e}, cbrt {:.2e}, {:.0} ns",
                row.material, row.mode, row.err.rel_median, row.err.cbrt_rms, row.ns_1_thread
            )));
            rows.push(row);
        }
    }
    Ok(rows)
}

/// One evaluation choice: a variant against its reference.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct VariantRow {
    /// What is chosen (`fresnel`, `beckmann-g1`, `smith`, `precision`).
    pub choice: String,
    /// Spec name of the material.
    pub material: String,
    /// The reference choice.
    pub reference: String,
    /// The cheaper choice.
    pub variant: String,
    #[serde(flatten)]
    /// Errors against the reference.
    pub err: ErrorStats,
    /// One thread, per valid MERL cell, ns.
    pub ns_reference: f64,
    /// Same for the variant, ns.
    pub ns_variant: f64,
}

/// Times `eval_batch` of a model over all cells of `g`, one thread, chunks of 8192.
fn time_model(reps: usize, m: &dyn Model, g: &GeometryBatch) -> f64 {
    let s = g.as_slice();
    let mut out = vec![Rgb::ZERO; g.len()];
    let t = pool(1).install(|| {
        time_min(reps, || {
            eval_batch_par(m, &s, &mut out);
            black_box(&out);
        })
    });
    t / g.len() as f64 * 1e9
}

fn eval_model(m: &dyn Model, g: &GeometryBatch) -> Vec<Rgb> {
    let mut out = vec![Rgb::ZERO; g.len()];
    m.eval_batch(&g.as_slice(), &mut out);
    out
}

fn compare(data: &FitData, reference: &[Rgb], variant: &[Rgb]) -> ErrorStats {
    let mut acc = ErrAcc::default();
    let g = data.geometry();
    for (k, (r, v)) in reference.iter().zip(variant).enumerate() {
        acc.add(*r, *v, g.wi_z[k], data.measure()[k]);
    }
    acc.finish()
}

/// The spec's material as a [`CookTorrance`], whose builders make the variants.
fn cook_torrance(spec: &SynthSpec) -> Result<CookTorrance, StudyError> {
    let params = spec.material.to_json()["params"].clone();
    CookTorrance::from_params_json(&params).map_err(|e| StudyError::Model {
        what: spec.name.clone(),
        msg: format!("expected a cook-torrance material: {e}"),
    })
}

/// A builder's result, its error naming the variant.
fn built(m: Result<CookTorrance, ModelError>, what: &str) -> Result<CookTorrance, StudyError> {
    m.map_err(|e| StudyError::Model {
        what: what.into(),
        msg: e.to_string(),
    })
}

/// Every Cook-Torrance variant against its reference: the Fresnel approximations on
/// gold, the Beckmann G1 forms and the Smith masking forms, and float32 evaluation.
pub fn variants(cfg: &StudyConfig, progress: &dyn Observe) -> Result<Vec<VariantRow>, StudyError> {
    let gold = VariantMaterial::read(cfg, "gold-ggx")?;
    let copper = VariantMaterial::read(cfg, "copper-beckmann")?;
    let mut rows = Rows {
        cfg,
        progress,
        rows: Vec::new(),
    };
    fresnel_variants(&mut rows, &gold)?;
    // Beckmann G1: Walter's rational form against the exact erf form. Smith: separable
    // against height-correlated, on GGX (gold) and on Beckmann (copper).
    let g1 = |m: &VariantMaterial, g| m.ct.clone().with_beckmann_g1(g);
    let smith = |m: &VariantMaterial, s| m.ct.clone().with_masking(s);
    let cexact = g1(&copper, BeckmannG1::Exact);
    let structural = [
        (
            "beckmann-g1",
            &copper,
            ("exact (erf)", cexact.clone()),
            ("rational (Walter 2007)", g1(&copper, BeckmannG1::Rational)),
        ),
        (
            "smith",
            &gold,
            ("height-correlated", smith(&gold, Masking::SmithCorrelated)),
            ("separable", smith(&gold, Masking::SmithSeparable)),
        ),
        (
            "smith",
            &copper,
            ("height-correlated", cexact),
            ("separable", smith(&copper, Masking::SmithSeparable)),
        ),
    ];
    for (choice, mat, (rn, r), (vn, v)) in &structural {
        rows.push(choice, mat, (rn, r), (vn, v));
    }
    // Precision: on gold and on the near-mirror silver (the steepest D).
    let mut rows = rows.rows;
    for name in ["gold-ggx", "near-mirror-silver"] {
        rows.push(precision_variant(cfg, name, progress)?);
    }
    Ok(rows)
}

/// A material of the variant comparisons: its spec's name, its cells and its
/// Cook-Torrance model.
struct VariantMaterial {
    name: String,
    cells: FitData,
    ct: CookTorrance,
}

/// The spec `name` of `cfg.specs_dir`, synthesised into its cells.
fn spec_cells(cfg: &StudyConfig, name: &str) -> Result<(SynthSpec, FitData), StudyError> {
    let s = SynthSpec::read(cfg.specs_dir.join(format!("{name}.toml")))?;
    let t = s.synthesize()?;
    let cells = FitData::from_table(&t).map_err(|source| StudyError::Fit {
        what: s.name.clone(),
        source,
    })?;
    Ok((s, cells))
}

impl VariantMaterial {
    fn read(cfg: &StudyConfig, name: &str) -> Result<VariantMaterial, StudyError> {
        let (s, cells) = spec_cells(cfg, name)?;
        Ok(VariantMaterial {
            name: name.to_string(),
            ct: cook_torrance(&s)?,
            cells,
        })
    }
}

/// The rows measured so far, and what measuring one needs.
struct Rows<'a> {
    cfg: &'a StudyConfig,
    progress: &'a dyn Observe,
    rows: Vec<VariantRow>,
}

impl Rows<'_> {
    /// Measures variant `v` against reference `r` on `mat`'s cells: the error it
    /// introduces and both evaluation times.
    fn push(
        &mut self,
        choice: &str,
        mat: &VariantMaterial,
        (rn, r): (&str, &dyn Model),
        (vn, v): (&str, &dyn Model),
    ) {
        let data = &mat.cells;
        let g = data.geometry();
        let err = compare(data, &eval_model(r, g), &eval_model(v, g));
        let row = VariantRow {
            choice: choice.into(),
            material: mat.name.clone(),
            reference: rn.into(),
            variant: vn.into(),
            err,
            ns_reference: time_model(self.cfg.reps, r, g),
            ns_variant: time_model(self.cfg.reps, v, g),
        };
        self.progress.observe(&Event::Step(format!(
            "variant {choice} {vn} vs {rn}: max rel {:.2e}, cbrt {:.2e}, {:.1} vs {:.1} ns",
            row.err.rel_max, row.err.cbrt_rms, row.ns_variant, row.ns_reference
        )));
        self.rows.push(row);
    }
}

/// Fresnel: Schlick with f0 = the conductor's normal-incidence reflectance, and with
/// f0 fitted (cbrt loss, everything else held) to the conductor's values.
fn fresnel_variants(rows: &mut Rows, gold: &VariantMaterial) -> Result<(), StudyError> {
    let Fresnel::Conductor { eta, k } = gold.ct.fresnel() else {
        return Err(StudyError::Model {
            what: gold.name.clone(),
            msg: "expected an exact conductor Fresnel".into(),
        });
    };
    let f0c = |c: usize| brdfkit_core::scattering::fresnel::conductor(1.0, eta[c], k[c]);
    let f0 = Rgb::new(f0c(0), f0c(1), f0c(2));
    let reference = gold.ct.clone();
    let schlick = built(
        gold.ct.clone().with_fresnel(Fresnel::Schlick { f0 }),
        "schlick",
    )?;
    rows.push(
        "fresnel",
        gold,
        ("conductor (exact)", &reference),
        ("Schlick, f0 = F(0°)", &schlick),
    );
    let fit_err = |source| StudyError::Fit {
        what: "schlick f0 fit".into(),
        source,
    };
    let fc = FitConfig::default()
        .fix_params(["rho_d", "rho_s", "alpha"])
        .warm_up(None)
        .map_err(fit_err)?;
    let fitted = fit(&schlick, &gold.cells, &fc, None).map_err(fit_err)?;
    let fitted = fitted
        .fitted
        .shared()
        .map(|m| m.clone_box())
        .ok_or_else(|| StudyError::Model {
            what: "schlick f0 fit".into(),
            msg: "expected a shared fit".into(),
        })?;
    rows.push(
        "fresnel",
        gold,
        ("conductor (exact)", &reference),
        ("Schlick, f0 fitted (cbrt)", fitted.as_ref()),
    );
    Ok(())
}

/// The model's float32 path (`eval_batch_f32`, one thread) against its f64 path on the
/// material `name`: the error float32 introduces and the time it saves.
fn precision_variant(
    cfg: &StudyConfig,
    name: &str,
    progress: &dyn Observe,
) -> Result<VariantRow, StudyError> {
    let (s, data) = spec_cells(cfg, name)?;
    let m = &s.material;
    let g = data.geometry();
    let reference = eval_model(m.as_ref(), g);
    let ns_ref = time_model(cfg.reps, m.as_ref(), g);
    let g32 = GeometryBatchF32::from_slice(&g.as_slice());
    let s32 = g32.as_slice();
    let n = g.len();
    let mut o32 = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
    let t32 = pool(1).install(|| {
        time_min(cfg.reps, || {
            let [r, gg, b] = &mut o32;
            eval_batch_f32_par(m.as_ref(), &s32, [r, gg, b]);
            black_box(&o32);
        })
    });
    let v32: Vec<Rgb> = (0..n)
        .map(|i| Rgb::new(o32[0][i] as f64, o32[1][i] as f64, o32[2][i] as f64))
        .collect();
    let row = VariantRow {
        choice: "precision".into(),
        material: name.into(),
        reference: "f64 (eval_batch)".into(),
        variant: "f32 (eval_batch_f32)".into(),
        err: compare(&data, &reference, &v32),
        ns_reference: ns_ref,
        ns_variant: t32 / n as f64 * 1e9,
    };
    progress.observe(&Event::Step(format!(
        "variant precision {name} f32: max rel {:.2e}, {:.1} vs {:.1} ns",
        row.err.rel_max, row.ns_variant, row.ns_reference
    )));
    Ok(row)
}
