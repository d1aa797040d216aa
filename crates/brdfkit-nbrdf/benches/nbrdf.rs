//! NBRDF benchmarks: the whole 90 × 90 × 180 MERL table from a proxy (`to_table`), and
//! 1,458,000 random direction pairs through the batch path (`eval_pairs`) and the
//! per-pair `Brdf::eval`.
//!
//! Run: `cargo bench -p brdfkit-nbrdf --bench nbrdf`.

use brdfkit_core::direction::spherical;
use brdfkit_core::{Brdf, Rgb, Vec3};
use brdfkit_merl::Dims;
use brdfkit_nbrdf::Nbrdf;
use criterion::{Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Duration;

fn net() -> Nbrdf {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data-measured/merl/gold-paint");
    Nbrdf::load(&p).expect("data-measured/merl/gold-paint")
}

fn pairs(n: usize) -> Vec<(Vec3, Vec3)> {
    let mut rng = ChaCha8Rng::seed_from_u64(0x4e42);
    let mut dir = move || {
        let z: f64 = 1.0 - rng.random::<f64>();
        spherical(z.acos(), rng.random_range(-PI..PI))
    };
    (0..n).map(|_| (dir(), dir())).collect()
}

fn main() {
    let mut c = Criterion::default()
        .sample_size(10)
        .measurement_time(Duration::from_secs(10))
        .configure_from_args();
    let net = net();
    let (_, st) = net.to_table(Dims::MERL).unwrap();
    println!(
        "gold-paint, MERL grid: {} cells, {} missing ({:.2} %), {} evaluated",
        st.cells,
        st.missing,
        100.0 * st.missing_fraction(),
        st.cells - st.missing
    );
    let mut g = c.benchmark_group("nbrdf");
    g.throughput(Throughput::Elements(Dims::MERL.cells() as u64));
    g.bench_function("to_table_merl_grid", |b| {
        b.iter(|| black_box(net.to_table(black_box(Dims::MERL)).unwrap()))
    });
    let p = pairs(Dims::MERL.cells());
    g.bench_function("eval_pairs_1458000", |b| {
        b.iter(|| black_box(net.eval_pairs(black_box(&p))))
    });
    g.bench_function("brdf_eval_per_pair_1458000", |b| {
        b.iter(|| {
            let v: Vec<Rgb> = p.par_iter().map(|(wi, wo)| net.eval(wi, wo)).collect();
            black_box(v)
        })
    });
    g.finish();
    c.final_summary();
}
