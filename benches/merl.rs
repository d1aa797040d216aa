//! MERL table benchmarks: reading a full 90 x 90 x 180 table against `cat FILE >
//! /dev/null` in the same run, and batch lookups of 1,458,000 random direction pairs.
//!
//! Run: `cargo bench --bench merl` (add `-- merl_read` to run only criterion's read and
//! `cat` benchmarks). After criterion's figures it prints an interleaved comparison of
//! the read and `cat` (medians, spread, ratio of medians, distribution of the ratio of
//! each pair) and the load average, then timings of the lookup batches: `lookup_batch`
//! over `(Vec3, Vec3)` pairs and `lookup_flat` over N × 6 rows, nearest and
//! interpolated.

use brdfkit::core::direction::spherical;
use brdfkit::core::{Rgb, Vec3};
use brdfkit::merl::{Dims, Lookup, MerlTable};
use criterion::{BenchmarkId, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;
use std::hint::black_box;

#[path = "common/interleaved.rs"]
mod interleaved;
use interleaved::{cat, read_vs_cat};
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

fn random_pairs() -> Vec<(Vec3, Vec3)> {
    let mut rng = ChaCha8Rng::seed_from_u64(0x4d45524c);
    let mut dir = move || {
        // z uniform in (0, 1]: uniform over the upper hemisphere, z > 0.
        let z: f64 = 1.0 - rng.random::<f64>();
        spherical(z.acos(), rng.random_range(-PI..PI))
    };
    (0..PAIRS).map(|_| (dir(), dir())).collect()
}

/// The pairs as N × 6 rows (wi, wo), the layout of an N × 6 `.npy`.
fn flat_rows(pairs: &[(Vec3, Vec3)]) -> Vec<f64> {
    pairs
        .iter()
        .flat_map(|(a, b)| [a.x, a.y, a.z, b.x, b.y, b.z])
        .collect()
}

/// Times `run` five times and prints `merl <what>` with the median rate over PAIRS pairs.
fn print_rate(what: &str, mut run: impl FnMut()) {
    let mut runs = Vec::new();
    for _ in 0..5 {
        let s = Instant::now();
        run();
        runs.push(s.elapsed());
    }
    let m = median(runs).as_secs_f64();
    println!(
        "merl {what}: {PAIRS} pairs in {:.1} ms (median of 5): {:.2} M pairs/s",
        m * 1e3,
        PAIRS as f64 / m / 1e6
    );
}

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

/// The `p`-quantile (nearest rank) of sorted values.
fn quantile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

/// Interleaved read/`cat` pairs. The order within a pair alternates, so that neither
/// side always runs right after the other's cache and page traffic.
const PAIRS_READ_CAT: usize = 100;

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
    // The flat N × 6 -> N × 3 form (the `.npy` layout), fast path for both modes.
    let rows = flat_rows(&pairs);
    let mut out = vec![0.0; 3 * PAIRS];
    for (name, mode) in [
        ("nearest_flat", Lookup::Nearest),
        ("interpolated_flat", Lookup::Interpolated),
    ] {
        g.bench_with_input(BenchmarkId::new(name, PAIRS), &rows, |b, r| {
            b.iter(|| {
                t.lookup_flat(mode, black_box(r), &mut out).unwrap();
                black_box(&out);
            })
        });
    }
    g.finish();
    c.final_summary();

    // The read/cat ratio, measured interleaved so both see the same machine state.
    let load0 = load_average();
    let (reads, cats, ratios) = read_vs_cat(&path, PAIRS_READ_CAT);
    let ms = |v: &[f64], p: f64| quantile(v, p) * 1e3;
    let (r, k) = (ms(&reads, 0.5), ms(&cats, 0.5));
    println!(
        "merl read vs cat ({PAIRS_READ_CAT} interleaved pairs, {bytes} bytes, load average {load0} -> {}):",
        load_average()
    );
    println!(
        "  read: median {r:.2} ms (p10 {:.2}, p90 {:.2}, min {:.2}); cat: median {k:.2} ms (p10 {:.2}, p90 {:.2}, min {:.2})",
        ms(&reads, 0.1),
        ms(&reads, 0.9),
        ms(&reads, 0.0),
        ms(&cats, 0.1),
        ms(&cats, 0.9),
        ms(&cats, 0.0),
    );
    println!(
        "  ratio of medians {:.2}; per-pair ratio p10 {:.2}, p25 {:.2}, median {:.2}, p75 {:.2}, p90 {:.2}; pairs within 1.5: {} of {PAIRS_READ_CAT}",
        r / k,
        quantile(&ratios, 0.1),
        quantile(&ratios, 0.25),
        quantile(&ratios, 0.5),
        quantile(&ratios, 0.75),
        quantile(&ratios, 0.9),
        ratios.iter().filter(|&&x| x <= 1.5).count(),
    );
    for (name, mode) in [
        ("nearest", Lookup::Nearest),
        ("interpolated", Lookup::Interpolated),
    ] {
        print_rate(&format!("{name} lookup"), || {
            black_box(t.lookup_batch(mode, &pairs));
        });
        let mut out = vec![0.0; 3 * PAIRS];
        print_rate(&format!("{name} lookup_flat"), || {
            t.lookup_flat(mode, &rows, &mut out).unwrap();
            black_box(&out);
        });
    }
}
