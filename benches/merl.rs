//! MERL table benchmarks: reading a full 90 x 90 x 180 table against `cat FILE >
//! /dev/null` in the same run, and batch lookups of 1,458,000 random direction pairs.
//!
//! Run: `cargo bench --bench merl`. After criterion's figures it prints an interleaved
//! median comparison of the read and `cat`, and their ratio.

use brdfkit::core::direction::spherical;
use brdfkit::core::{Rgb, Vec3};
use brdfkit::merl::{Dims, Lookup, MerlTable};
use criterion::{BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;
use std::hint::black_box;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Number of lookups per batch: as many pairs as the MERL grid has cells.
const PAIRS: usize = 1_458_000;

/// A full MERL-grid table with smooth values and a horizon mask like a real file.
fn table() -> MerlTable {
    MerlTable::from_fn(Dims::MERL, |i, j, k| {
        let c = Dims::MERL.cell_angles(i, j, k);
        let (wi, wo) = brdfkit::core::from_half_diff(&c);
        (wi.z > 0.0 && wo.z > 0.0).then(|| {
            let s = 0.05 + 3.0 * (-(c.theta_h * 12.0).powi(2)).exp();
            Rgb::new(s, 0.9 * s, 0.8 * s + 0.01 * c.phi_d)
        })
    })
    .expect("finite, non-negative values")
}

fn cat(path: &Path) {
    let status = Command::new("cat")
        .arg(path)
        .stdout(Stdio::null())
        .status()
        .expect("spawn cat");
    assert!(status.success());
}

fn random_pairs() -> Vec<(Vec3, Vec3)> {
    let mut rng = ChaCha8Rng::seed_from_u64(0x4d45524c);
    let mut dir = move || {
        // z uniform in (0, 1]: uniform over the upper hemisphere, z > 0.
        let z: f64 = 1.0 - rng.random::<f64>();
        spherical(z.acos(), rng.random_range(-PI..PI))
    };
    (0..PAIRS).map(|_| (dir(), dir())).collect()
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn main() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("bench.binary");
    let t = table();
    t.write(&path).expect("write the table");
    let bytes = std::fs::metadata(&path).unwrap().len();
    assert_eq!(bytes, Dims::MERL.file_bytes());

    let mut c = Criterion::default().configure_from_args();

    let mut g = c.benchmark_group("merl_read");
    g.throughput(Throughput::Bytes(bytes));
    g.sample_size(50);
    g.bench_function("read_90x90x180", |b| {
        b.iter(|| black_box(MerlTable::read(black_box(&path)).unwrap()))
    });
    g.bench_function("cat_to_dev_null", |b| b.iter(|| cat(black_box(&path))));
    g.finish();

    let pairs = random_pairs();
    let mut g = c.benchmark_group("merl_lookup");
    g.throughput(Throughput::Elements(PAIRS as u64));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(15));
    for (name, mode) in [
        ("nearest", Lookup::Nearest),
        ("interpolated", Lookup::Interpolated),
    ] {
        g.bench_with_input(BenchmarkId::new(name, PAIRS), &pairs, |b, p| {
            b.iter(|| black_box(t.lookup_batch(mode, black_box(p))))
        });
    }
    g.finish();
    c.final_summary();

    // The read/cat ratio, measured interleaved so both see the same machine state.
    let (mut reads, mut cats) = (Vec::new(), Vec::new());
    for _ in 0..40 {
        let s = Instant::now();
        black_box(MerlTable::read(&path).unwrap());
        reads.push(s.elapsed());
        let s = Instant::now();
        cat(&path);
        cats.push(s.elapsed());
    }
    let (r, k) = (median(reads), median(cats));
    println!(
        "merl read vs cat (median of 40 interleaved runs, {bytes} bytes): read {:.2} ms, cat {:.2} ms, ratio {:.2}",
        r.as_secs_f64() * 1e3,
        k.as_secs_f64() * 1e3,
        r.as_secs_f64() / k.as_secs_f64()
    );
    for (name, mode) in [
        ("nearest", Lookup::Nearest),
        ("interpolated", Lookup::Interpolated),
    ] {
        let mut runs = Vec::new();
        for _ in 0..5 {
            let s = Instant::now();
            black_box(t.lookup_batch(mode, &pairs));
            runs.push(s.elapsed());
        }
        let m = median(runs).as_secs_f64();
        println!(
            "merl {name} lookup: {PAIRS} pairs in {:.1} ms (median of 5): {:.2} M pairs/s",
            m * 1e3,
            PAIRS as f64 / m / 1e6
        );
    }
}
