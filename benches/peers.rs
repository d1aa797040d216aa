//! brdfkit's side of the peer comparison run by `benches/peers/run` (docs/performance.md).
//!
//! Writes the inputs the peers read into `--dir DIR` and prints one JSON object of our
//! timings and checksums on stdout (`--json FILE` also writes it):
//!
//! - `eval`: Cook-Torrance GGX, separable Smith, exact conductor Fresnel (gold, α = 0.2,
//!   ρd = 0, ρs = 1: Mitsuba 3's `roughconductor`), RGB, over all 1,458,000 (wi, wo)
//!   pairs of the MERL grid cells (`DIR/grid_pairs.f64`, 6 planes wi_x … wo_z). Timed:
//!   the model's `eval_batch_f32` (float32, as Mitsuba's `llvm_ad_rgb`) and `eval_batch`
//!   (f64) on precomputed geometry through `brdfkit::models::par` (runs of 8192 pairs
//!   over every thread of the global rayon pool), `Brdf::eval` per direction pair, and
//!   the raw-direction batch paths `brdfkit::models::raw::{eval_dirs_f32, eval_dirs}`
//!   (`[x, y, z]` arrays of wi and wo in, the half vector and cos θd computed in the
//!   call, as Mitsuba computes them in its kernel; f32 directions are the f64 ones
//!   rounded, as Mitsuba reads them).
//! - `read`: `MerlTable::read` of `DIR/table.binary` (the gold table) and `cat FILE >
//!   /dev/null`, interleaved in alternating order, at least 100 pairs.
//! - `nearest`: `MerlTable::nearest_flat` of 1,458,000 seeded random pairs
//!   (`DIR/random_pairs.f64`) as N × 6 rows into N × 3 (and `lookup_batch(Nearest)` of
//!   the same pairs as `(Vec3, Vec3)`);
//! - `interpolated`: `MerlTable::interpolated_flat` of the same pairs.
//! - `fit`: the default full-table fit of the `fit` bench's noise-free table (Cook-Torrance
//!   GGX + Schlick, ρd = (0.1, 0.2, 0.3), ρs = (0.5, 0.4, 0.3), α = 0.08, f0 = (0.9, 0.6,
//!   0.3)), cells in `DIR/fit_cells.bin` for `fit_scipy.py`.
//!
//! Timings are the median of `--reps N` runs (default 7) after one warm-up run.

use brdfkit::core::{Brdf, GeometryBatch, GeometryBatchF32, Model, Rgb, Vec3};
use brdfkit::fit::{FitConfig, FitData, Loss, fit};
use brdfkit::merl::{Dims, Lookup, MerlTable};
use brdfkit::models::par::{RUN, eval_batch_f32_par, eval_batch_par};
use brdfkit::models::raw::{eval_dirs, eval_dirs_f32};
use rayon::prelude::*;
use serde_json::json;
use std::hint::black_box;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Gold as Mitsuba 3's `roughconductor` (ρd = 0, ρs = 1, GGX, separable Smith).
const GOLD: &str = r#"{"model":"cook-torrance","params":{"rho_d":0.0,"rho_s":1.0,"alpha":0.2,
    "distribution":"ggx","masking":"smith-separable",
    "fresnel":{"conductor":{"eta":[0.143,0.374,1.442],"k":[3.983,2.385,1.603]}}}}"#;

const FIT_TRUTH: &str = r#"{"model":"cook-torrance","params":{"distribution":"ggx","masking":"smith-separable",
    "fresnel":{"schlick":{"f0":[0.9,0.6,0.3]}},"rho_d":[0.1,0.2,0.3],"rho_s":[0.5,0.4,0.3],"alpha":0.08}}"#;
const FIT_START: &str = r#"{"model":"cook-torrance","params":{"distribution":"ggx","masking":"smith-separable","fresnel":"schlick"}}"#;

fn median_time(reps: usize, mut f: impl FnMut()) -> (f64, f64) {
    f(); // warm-up
    let mut v: Vec<f64> = (0..reps.max(1))
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .collect();
    v.sort_by(|a, b| a.total_cmp(b));
    (v[v.len() / 2], v[0])
}

/// Six little-endian f64 planes: wi_x wi_y wi_z wo_x wo_y wo_z.
fn write_pairs(path: &Path, pairs: &[(Vec3, Vec3)]) -> std::io::Result<()> {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    for c in 0..6 {
        for (wi, wo) in pairs {
            let x = if c < 3 { wi[c] } else { wo[c - 3] };
            f.write_all(&x.to_le_bytes())?;
        }
    }
    f.flush()
}

#[path = "common/cells.rs"]
mod cells;
use cells::write_cells;
#[path = "common/cpu.rs"]
mod cpu;
use cpu::cpu_seconds;
#[path = "common/pairs.rs"]
mod pairs;
use pairs::merl_pairs;
#[path = "common/interleaved.rs"]
mod interleaved;
use interleaved::{cat, read_vs_cat};

fn sums(v: &[Rgb]) -> [f64; 3] {
    let mut s = [0.0; 3];
    for x in v {
        for c in 0..3 {
            s[c] += x[c];
        }
    }
    s
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let opt = |name: &str| {
        args.iter()
            .position(|a| a == name)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    let reps: usize = opt("--reps").and_then(|s| s.parse().ok()).unwrap_or(7);
    let dir = PathBuf::from(opt("--dir").unwrap_or_else(|| "target/peers".into()));
    std::fs::create_dir_all(&dir).expect("the exchange directory");
    let threads = rayon::current_num_threads();
    let mut out = json!({"threads": threads, "reps": reps});

    // --- model evaluation over the MERL grid ---
    let pairs = merl_pairs();
    let n = pairs.len();
    write_pairs(&dir.join("grid_pairs.f64"), &pairs).expect("write grid pairs");
    let batch = GeometryBatch::from_pairs(&pairs);
    let gold: serde_json::Value = serde_json::from_str(GOLD).expect("the gold JSON");
    let model = brdfkit::models::from_json(&gold).expect("the gold model");
    let m: &dyn Model = model.as_ref();
    let s = batch.as_slice();
    let mut o = vec![Rgb::ZERO; n];
    let (t_batch, t_batch_min) = median_time(reps, || {
        eval_batch_par(m, &s, &mut o);
        black_box(&o);
    });
    let sum_batch = sums(&o);
    let b32 = GeometryBatchF32::from_slice(&s);
    let s32 = b32.as_slice();
    let mut p32 = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
    let (t_f32, t_f32_min) = median_time(reps, || {
        let [r, g, b] = &mut p32;
        eval_batch_f32_par(m, &s32, [r, g, b]);
        black_box(&p32);
    });
    let sum32: [f64; 3] = std::array::from_fn(|c| p32[c].iter().map(|&x| x as f64).sum());
    let (t_pairs, t_pairs_min) = median_time(reps, || {
        o.par_chunks_mut(RUN)
            .zip(pairs.par_chunks(RUN))
            .for_each(|(o, p)| {
                for (o, (wi, wo)) in o.iter_mut().zip(p) {
                    *o = Brdf::eval(m, wi, wo);
                }
            });
        black_box(&o);
    });
    // From raw directions, in batch: `[x, y, z]` arrays in, nothing precomputed.
    let wi: Vec<[f64; 3]> = pairs.iter().map(|p| [p.0.x, p.0.y, p.0.z]).collect();
    let wo: Vec<[f64; 3]> = pairs.iter().map(|p| [p.1.x, p.1.y, p.1.z]).collect();
    let (t_dirs, t_dirs_min) = median_time(reps, || {
        eval_dirs(m, &wi, &wo, &mut o).expect("equal lengths");
        black_box(&o);
    });
    let sum_dirs = sums(&o);
    let same = o
        .iter()
        .zip(&pairs)
        .filter(|(v, (a, b))| **v == Brdf::eval(m, a, b))
        .count();
    assert_eq!(same, n, "eval_dirs must give eval's values");
    let r32 = |v: &[f64; 3]| v.map(|x| x as f32);
    let wi32: Vec<[f32; 3]> = wi.iter().map(r32).collect();
    let wo32: Vec<[f32; 3]> = wo.iter().map(r32).collect();
    let mut o32 = vec![[0f32; 3]; n];
    let (t_dirs32, t_dirs32_min) = median_time(reps, || {
        eval_dirs_f32(m, &wi32, &wo32, &mut o32).expect("equal lengths");
        black_box(&o32);
    });
    let sum_dirs32: [f64; 3] = std::array::from_fn(|c| o32.iter().map(|v| v[c] as f64).sum());
    out["eval"] = json!({
        "cells": n,
        "params": gold,
        "eval_batch_s": t_batch, "eval_batch_min_s": t_batch_min,
        "eval_f32_s": t_f32, "eval_f32_min_s": t_f32_min,
        "eval_pairs_s": t_pairs, "eval_pairs_min_s": t_pairs_min,
        "eval_dirs_s": t_dirs, "eval_dirs_min_s": t_dirs_min,
        "eval_dirs_f32_s": t_dirs32, "eval_dirs_f32_min_s": t_dirs32_min,
        "sum_f64": sum_batch, "sum_f32": sum32,
        "sum_dirs": sum_dirs, "sum_dirs_f32": sum_dirs32,
    });
    eprintln!(
        "eval: eval_batch_f32 {:.2} ms, eval_batch {:.2} ms, eval(pairs) {:.1} ms, \
         eval_dirs_f32 {:.2} ms, eval_dirs {:.2} ms",
        t_f32 * 1e3,
        t_batch * 1e3,
        t_pairs * 1e3,
        t_dirs32 * 1e3,
        t_dirs * 1e3,
    );

    // `--eval-only`: the model-evaluation rows alone (for quick repeats of them).
    if args.iter().any(|a| a == "--eval-only") {
        println!("{}", serde_json::to_string_pretty(&out).expect("json"));
        return;
    }

    // --- reading a table vs cat ---
    let table = MerlTable::from_brdf(m, Dims::MERL).expect("the gold table");
    let tpath = dir.join("table.binary");
    table.write(&tpath).expect("write the table");
    // Interleaved pairs, the order alternating so neither side always runs on a cache or
    // page state the other left; many pairs, because a fresh 35 MB allocation costs 2–3×
    // more in some stretches of time than in others on this VM (docs/merl-format.md).
    black_box(MerlTable::read(&tpath).unwrap());
    cat(&tpath);
    let (rs, cs, ratios) = read_vs_cat(&tpath, (14 * reps).max(100));
    let within = ratios.iter().filter(|&&x| x <= 1.5).count();
    let raw_sum: f64 = table.raw().iter().filter(|x| **x >= 0.0).sum();
    out["read"] = json!({
        "bytes": std::fs::metadata(&tpath).map(|m| m.len()).unwrap_or(0),
        "read_s": rs[rs.len() / 2], "read_min_s": rs[0],
        "cat_s": cs[cs.len() / 2], "cat_min_s": cs[0],
        "pair_ratio_median": ratios[ratios.len() / 2],
        "pair_ratio_p10": ratios[ratios.len() / 10],
        "pair_ratio_p90": ratios[ratios.len() * 9 / 10],
        "pairs_within_1_5": within,
        "runs": rs.len(), "valid_raw_sum": raw_sum,
    });
    eprintln!(
        "read: {:.1} ms, cat {:.1} ms; per-pair read/cat median {:.2} (p10 {:.2}, p90 {:.2}), {} of {} pairs <= 1.5",
        rs[rs.len() / 2] * 1e3,
        cs[cs.len() / 2] * 1e3,
        ratios[ratios.len() / 2],
        ratios[ratios.len() / 10],
        ratios[ratios.len() * 9 / 10],
        within,
        ratios.len()
    );

    // --- nearest and interpolated lookups of random pairs ---
    let rp = brdfkit_study::choices::random_pairs(n, 0x4d45524c);
    write_pairs(&dir.join("random_pairs.f64"), &rp).expect("write random pairs");
    // The N × 6 rows of the `.npy` layout (wi, wo per row), N × 3 out.
    let rows: Vec<f64> = rp
        .iter()
        .flat_map(|(a, b)| [a.x, a.y, a.z, b.x, b.y, b.z])
        .collect();
    let mut flat = vec![0.0; 3 * n];
    let found_sums = |flat: &[f64]| {
        let rgb: Vec<Rgb> = flat
            .chunks_exact(3)
            .filter(|r| !r[0].is_nan())
            .map(|r| Rgb::new(r[0], r[1], r[2]))
            .collect();
        (rgb.len(), sums(&rgb))
    };
    let (t_near, t_near_min) = median_time(reps, || {
        table
            .nearest_flat(black_box(&rows), &mut flat)
            .expect("shapes");
    });
    let (found, sum_near) = found_sums(&flat);
    let mut got = Vec::new();
    let (t_batch, t_batch_min) = median_time(reps, || {
        got = table.lookup_batch(Lookup::Nearest, black_box(&rp));
    });
    assert_eq!(got.iter().filter(|g| g.is_some()).count(), found);
    out["nearest"] = json!({
        "pairs": n, "time_s": t_near, "min_s": t_near_min,
        "lookup_batch_s": t_batch, "lookup_batch_min_s": t_batch_min,
        "found": found, "sum": sum_near,
    });
    eprintln!(
        "nearest: nearest_flat {:.1} ms, lookup_batch {:.1} ms, {found} found",
        t_near * 1e3,
        t_batch * 1e3
    );
    let (t_interp, t_interp_min) = median_time(reps, || {
        table
            .interpolated_flat(black_box(&rows), &mut flat)
            .expect("shapes");
    });
    let (found_i, sum_interp) = found_sums(&flat);
    out["interpolated"] = json!({
        "pairs": n, "time_s": t_interp, "min_s": t_interp_min,
        "found": found_i, "sum": sum_interp,
    });
    eprintln!(
        "interpolated: interpolated_flat {:.1} ms, {found_i} found",
        t_interp * 1e3
    );

    // --- a full-table fit ---
    if !args.iter().any(|a| a == "--no-fit") {
        let truth = brdfkit::models::from_json_str(FIT_TRUTH).expect("truth");
        let ftable = MerlTable::from_brdf(truth.as_ref(), Dims::MERL).expect("fit table");
        let data = FitData::from_table(&ftable).expect("cells");
        write_cells(&data, &dir.join("fit_cells.bin")).expect("write cells");
        let start = brdfkit::models::from_json_str(FIT_START).expect("start");
        let cfg = FitConfig::default();
        let mut last = None;
        let c0 = cpu_seconds();
        let (t_fit, t_fit_min) = median_time(reps.min(5), || {
            last = Some(fit(start.as_ref(), &data, &cfg, None).expect("fit"));
        });
        let cpu = c0
            .zip(cpu_seconds())
            .map(|(a, b)| (b - a) / (reps.min(5) + 1) as f64);
        let rec = &last.expect("a fit ran").record;
        out["fit"] = json!({
            "cells": data.len(), "time_s": t_fit, "min_s": t_fit_min, "cpu_s_per_fit": cpu,
            "loss_cbrt": rec.losses_full.get(Loss::Cbrt).overall,
            "iterations": rec.iterations, "model": rec.model,
        });
        eprintln!(
            "fit: {:.3} s, loss {:.3e}",
            t_fit,
            rec.losses_full.get(Loss::Cbrt).overall
        );
    }

    let s = serde_json::to_string_pretty(&out).expect("json");
    if let Some(p) = opt("--json") {
        std::fs::write(&p, &s).expect("write the JSON");
    }
    println!("{s}");
}
