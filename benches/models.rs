//! Evaluations per second of every registered model over the 1,458,000 cells of a MERL
//! grid (90 θh × 90 θd × 180 φd, φh = 0), single thread and all threads:
//!
//! - `eval`: the direction path, `Brdf::eval` over (wi, wo) pairs;
//! - `eval_batch`: the fast path over precomputed `GeometryBatch` geometry;
//! - `eval_batch_f32`: the single-precision path over a `GeometryBatchF32` (a native
//!   float32 kernel for `cook-torrance` with GGX, the widening default elsewhere);
//! - `eval_grad_batch`: value and gradient, as a fit needs them;
//! - `eval_dirs` / `eval_dirs_f32`: `brdfkit_models::raw` from raw `[x, y, z]` arrays of
//!   wi and wo (f64, and the directions rounded to f32), nothing precomputed.
//!
//! Run with `cargo bench --bench models`. Each measurement is one pass over all cells
//! (`Throughput::Elements(1_458_000)`). The batch is cut into runs of `CHUNK` cells
//! (`GeomSlice::sub`) spread over a pool of 1 thread or of all threads (the batch paths
//! through `brdfkit_models::par`, which wakes every worker);
//! the gradient is written into a per-thread buffer of `CHUNK × num_params` (the full
//! gradient of a 17-parameter model over the grid would be 0.6 GB).
//! A model name of `brdfkit_models::MODEL_NAMES` that is not registered yet is reported
//! and skipped.

use brdfkit_core::{GeometryBatch, GeometryBatchF32, Model, Rgb, Vec3};
use brdfkit_models::par::{eval_batch_f32_par, eval_batch_par};
use brdfkit_models::raw::{eval_dirs, eval_dirs_f32};
use brdfkit_models::{MODEL_NAMES, default_model};
use criterion::{Criterion, SamplingMode, Throughput, criterion_group, criterion_main};
use rayon::ThreadPool;
use rayon::prelude::*;
use std::hint::black_box;
use std::sync::Mutex;
use std::time::Duration;

#[path = "common/pairs.rs"]
mod pairs;
use pairs::merl_pairs;

/// Cells per rayon task: large enough to amortise scheduling, small enough that the
/// per-thread gradient buffer stays in the cache hierarchy.
const CHUNK: usize = 8192;

fn pool(threads: Option<usize>) -> ThreadPool {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        b = b.num_threads(t);
    }
    b.build().expect("a rayon pool")
}

fn eval_pairs(pool: &ThreadPool, m: &dyn Model, pairs: &[(Vec3, Vec3)], out: &mut [Rgb]) {
    pool.install(|| {
        out.par_chunks_mut(CHUNK)
            .zip(pairs.par_chunks(CHUNK))
            .for_each(|(o, p)| {
                for (o, (wi, wo)) in o.iter_mut().zip(p) {
                    *o = m.eval(wi, wo);
                }
            })
    });
}

fn eval_batch(pool: &ThreadPool, m: &dyn Model, g: &GeometryBatch, out: &mut [Rgb]) {
    pool.install(|| eval_batch_par(m, &g.as_slice(), out));
}

fn eval_batch_f32(pool: &ThreadPool, m: &dyn Model, g: &GeometryBatchF32, out: &mut [Vec<f32>; 3]) {
    let [r, gg, b] = out;
    pool.install(|| eval_batch_f32_par(m, &g.as_slice(), [r, gg, b]));
}

/// One gradient buffer per pool thread (locked once per chunk, never contended).
fn eval_grad_batch(
    pool: &ThreadPool,
    m: &dyn Model,
    g: &GeometryBatch,
    out: &mut [Rgb],
    bufs: &[Mutex<Vec<Rgb>>],
) {
    let s = g.as_slice();
    let np = m.num_params();
    pool.install(|| {
        out.par_chunks_mut(CHUNK).enumerate().for_each(|(c, o)| {
            let start = c * CHUNK;
            let t = rayon::current_thread_index().unwrap_or(0);
            let mut grad = bufs[t].lock().expect("an unpoisoned buffer");
            m.eval_grad_batch(&s.sub(start..start + o.len()), o, &mut grad[..np * o.len()]);
            black_box(&grad[0]);
        })
    });
}

fn bench_models(c: &mut Criterion) {
    let pairs = merl_pairs();
    let n = pairs.len();
    assert_eq!(n, 1_458_000);
    let batch = GeometryBatch::from_pairs(&pairs);
    let pools = [("1-thread", pool(Some(1))), ("all-threads", pool(None))];
    println!(
        "models bench: {n} MERL cells, pools of 1 and {} threads, chunks of {CHUNK}",
        pools[1].1.current_num_threads()
    );
    let mut out = vec![Rgb::ZERO; n];
    let mut out2 = vec![Rgb::ZERO; n];
    let batch32 = GeometryBatchF32::from_slice(&batch.as_slice());
    let mut out32 = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
    let wi: Vec<[f64; 3]> = pairs.iter().map(|p| [p.0.x, p.0.y, p.0.z]).collect();
    let wo: Vec<[f64; 3]> = pairs.iter().map(|p| [p.1.x, p.1.y, p.1.z]).collect();
    let wi32: Vec<[f32; 3]> = wi.iter().map(|v| v.map(|x| x as f32)).collect();
    let wo32: Vec<[f32; 3]> = wo.iter().map(|v| v.map(|x| x as f32)).collect();
    let mut rows32 = vec![[0f32; 3]; n];
    for &name in MODEL_NAMES {
        let m = match default_model(name) {
            Ok(m) => m,
            Err(e) => {
                println!("{name}: not benchmarked ({e})");
                continue;
            }
        };
        let m = m.as_ref();
        let np = m.num_params();
        // The fast path must give the direction path's numbers on every cell.
        eval_pairs(&pools[1].1, m, &pairs, &mut out);
        eval_batch(&pools[1].1, m, &batch, &mut out2);
        let mut differ = out.iter().zip(&out2).filter(|(a, b)| a != b).count();
        pools[1]
            .1
            .install(|| eval_dirs(m, &wi, &wo, &mut out2).expect("lengths"));
        differ += out.iter().zip(&out2).filter(|(a, b)| a != b).count();
        let lit = out.iter().filter(|v| v.max_channel() > 0.0).count();
        println!(
            "{name}: {np} parameters, {lit} of {n} cells non-zero, {differ} cells where eval_batch or eval_dirs != eval"
        );

        let mut group = c.benchmark_group(name);
        group
            .throughput(Throughput::Elements(n as u64))
            .sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_millis(300))
            .measurement_time(Duration::from_secs(2));
        for (label, p) in &pools {
            group.bench_function(format!("eval/{label}"), |b| {
                b.iter(|| eval_pairs(p, m, &pairs, &mut out))
            });
            group.bench_function(format!("eval_batch/{label}"), |b| {
                b.iter(|| eval_batch(p, m, &batch, &mut out))
            });
            group.bench_function(format!("eval_batch_f32/{label}"), |b| {
                b.iter(|| eval_batch_f32(p, m, &batch32, &mut out32))
            });
            group.bench_function(format!("eval_dirs/{label}"), |b| {
                b.iter(|| p.install(|| eval_dirs(m, &wi, &wo, &mut out).expect("lengths")))
            });
            group.bench_function(format!("eval_dirs_f32/{label}"), |b| {
                b.iter(|| {
                    p.install(|| eval_dirs_f32(m, &wi32, &wo32, &mut rows32).expect("lengths"))
                })
            });
            let bufs: Vec<Mutex<Vec<Rgb>>> = (0..p.current_num_threads())
                .map(|_| Mutex::new(vec![Rgb::ZERO; np * CHUNK]))
                .collect();
            group.bench_function(format!("eval_grad_batch/{label}"), |b| {
                b.iter(|| eval_grad_batch(p, m, &batch, &mut out, &bufs))
            });
        }
        group.finish();
        black_box(&out);
    }
}

criterion_group!(benches, bench_models);
criterion_main!(benches);
