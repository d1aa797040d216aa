//! What the writer's tests share: the seven vendored proxies (data-measured/, NBRDF fits
//! of real measurements), random direction pairs, and the error statistics.

#![allow(dead_code)]

use brdfkit_core::{Brdf, Rgb, Vec3};
use brdfkit_nbrdf::Nbrdf;
use rand::{Rng, SeedableRng};
use std::path::PathBuf;

/// The seven proxies, as (name, DIR/NAME stem).
pub fn proxies() -> Vec<(&'static str, PathBuf)> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data-measured");
    [
        ("chrome-steel", "merl/chrome-steel"),
        ("gold-paint", "merl/gold-paint"),
        ("specular-red-phenolic", "merl/specular-red-phenolic"),
        ("pink-fabric", "merl/pink-fabric"),
        ("blue-rubber", "merl/blue-rubber"),
        (
            "acrylic_felt_green_rgb",
            "rgl-isotropic/acrylic_felt_green_rgb",
        ),
        ("bindercover", "nielsen/bindercover"),
    ]
    .into_iter()
    .map(|(n, p)| (n, root.join(p)))
    .collect()
}

pub fn proxy(name: &str) -> Nbrdf {
    let (_, p) = proxies().into_iter().find(|(n, _)| *n == name).unwrap();
    Nbrdf::load(&p).unwrap()
}

/// `count` pairs, each direction uniform on the hemisphere above `min_deg` elevation.
pub fn pairs(count: usize, min_deg: f64, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let zmin = min_deg.to_radians().sin();
    let mut dir = || {
        let z: f64 = rng.random_range(zmin..1.0);
        let phi = rng.random::<f64>() * std::f64::consts::TAU;
        let r = (1.0 - z * z).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    (0..count).map(|_| (dir(), dir())).collect()
}

/// |a − b| / |b| of RGB vectors (Euclidean), `None` where the source is black.
pub fn rel(a: &Rgb, b: &Rgb) -> Option<f64> {
    let n = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let bn = n(b.0);
    (bn > 1e-6).then(|| n([0, 1, 2].map(|c| a.0[c] - b.0[c])) / bn)
}

/// Median and 90th percentile.
pub fn median_p90(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.9))
}

/// Median and p90 relative error of `file` (f_r, as brdfkit's reader returns it) against
/// `source`.
pub fn against_source(
    file: &dyn Fn(usize) -> Rgb,
    source: &dyn Brdf,
    pairs: &[(Vec3, Vec3)],
) -> (f64, f64) {
    let errs: Vec<f64> = pairs
        .iter()
        .enumerate()
        .filter_map(|(k, (wi, wo))| rel(&file(k), &source.eval(wi, wo)))
        .collect();
    median_p90(errs)
}
