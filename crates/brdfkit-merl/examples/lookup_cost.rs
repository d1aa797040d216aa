//! CPU cost of lookups, for measuring on a busy machine where wall-clock benchmarks are
//! noisy: runs 10 × 1,458,000 lookups of one kind, to be timed with `time` on one thread.
//!
//! ```text
//! cargo build --release -p brdfkit-merl --example lookup_cost
//! for m in none half-diff nearest nearest-batch interpolated interpolated-batch; do
//!   RAYON_NUM_THREADS=1 /usr/bin/time -f "$m %U s user %S s sys" \
//!     target/release/examples/lookup_cost $m
//! done
//! ```
//! Subtract `none` (setup) and divide by 14,580,000 for the cost per pair.

use brdfkit_core::direction::spherical;
use brdfkit_core::{Rgb, Vec3, to_half_diff};
use brdfkit_merl::{Dims, MerlTable};
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

fn main() {
    let mode = std::env::args().nth(1).unwrap_or_else(|| "none".into());
    let t = MerlTable::from_fn(Dims::MERL, |i, j, k| Some(Rgb::splat((i + j + k) as f64)))
        .expect("finite values");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let mut dir = || {
        let z: f64 = 1.0 - rng.random::<f64>();
        spherical(z.acos(), rng.random_range(-PI..PI))
    };
    let pairs: Vec<(Vec3, Vec3)> = (0..1_458_000).map(|_| (dir(), dir())).collect();
    let first = |v: Option<Rgb>| v.map_or(0.0, |v| v[0]);
    let mut acc = 0.0;
    for _ in 0..10 {
        acc += match mode.as_str() {
            "half-diff" => pairs.iter().map(|(a, b)| to_half_diff(a, b).theta_h).sum(),
            "nearest" => pairs.iter().map(|(a, b)| first(t.nearest(a, b))).sum(),
            "interpolated" => pairs.iter().map(|(a, b)| first(t.interpolated(a, b))).sum(),
            "nearest-batch" => t.nearest_batch(&pairs).into_iter().map(first).sum(),
            "interpolated-batch" => t.interpolated_batch(&pairs).into_iter().map(first).sum(),
            _ => 0.0,
        };
    }
    println!("{mode}: checksum {acc}");
}
