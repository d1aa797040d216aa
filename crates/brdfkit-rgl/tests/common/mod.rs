//! Hand-built but realistic `.bsdf` files for the tests: random positive NDF, σ, VNDF
//! and luminance tables, RGB values with some negatives (as the database's are) or
//! spectra, isotropic or anisotropic, on a chosen grid; written with brdfkit's own
//! tensor writer.

#![allow(dead_code)]

pub mod tally;

use brdfkit_rgl::{Tensor, TensorData};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f32::consts::PI;

/// What kind of file to build.
#[derive(Clone, Copy, Debug)]
pub struct Spec {
    pub anisotropic: bool,
    pub spectral: bool,
    /// The value (luminance, rgb, spectra) grid, n × n.
    pub n: u64,
    /// The VNDF grid, m × m.
    pub m: u64,
    pub seed: u64,
}

/// The fields of a file of `spec`. An anisotropic file stores a quarter turn of φi
/// (a 4-fold reduction: Mitsuba folds wi into x, y ≤ 0) in five slices.
pub fn fields(spec: Spec) -> Vec<Tensor> {
    let phi_i: Vec<f32> = if spec.anisotropic {
        (0..5).map(|k| -PI + k as f32 * (PI / 2.0) / 4.0).collect()
    } else {
        vec![0.0]
    };
    fields_with_phi(spec, phi_i)
}

/// [`fields`] with the given φi grid (more than two values: anisotropic; a half turn
/// [−π, 0] is a 2-fold reduction, Mitsuba folding wi into y ≤ 0).
pub fn fields_with_phi(spec: Spec, phi_i: Vec<f32>) -> Vec<Tensor> {
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let theta_i: Vec<f32> = [0.0f32, 12.0, 25.0, 38.0, 50.0, 61.0, 71.0, 80.0]
        .iter()
        .map(|d| d.to_radians())
        .collect();
    let (np, nt) = (phi_i.len() as u64, theta_i.len() as u64);
    let (n, m) = (spec.n, spec.m);
    let ndf_rows = if spec.anisotropic { 16 } else { 2 };
    let mut f = vec![
        Tensor::new("version", &[2], TensorData::U32(vec![1, 0])),
        Tensor::new(
            "description",
            &[21],
            TensorData::U8(b"hand-built test file!".to_vec()),
        ),
        Tensor::new("phi_i", &[np], TensorData::F32(phi_i)),
        Tensor::new("theta_i", &[nt], TensorData::F32(theta_i)),
        Tensor::new(
            "sigma",
            &[ndf_rows, 32],
            TensorData::F32(positive(&mut rng, ndf_rows * 32, 0.5, 1.5)),
        ),
        Tensor::new(
            "ndf",
            &[ndf_rows, 32],
            TensorData::F32(positive(&mut rng, ndf_rows * 32, 0.1, 10.0)),
        ),
        Tensor::new(
            "vndf",
            &[np, nt, m, m],
            TensorData::F32(positive(&mut rng, np * nt * m * m, 0.05, 5.0)),
        ),
        Tensor::new(
            "luminance",
            &[np, nt, n, n],
            TensorData::F32(positive(&mut rng, np * nt * n * n, 0.01, 2.0)),
        ),
    ];
    if spec.spectral {
        let wl: Vec<f32> = (0..=32).map(|k| 360.0 + 20.0 * k as f32).collect();
        let nl = wl.len() as u64;
        f.push(Tensor::new("wavelengths", &[nl], TensorData::F32(wl)));
        f.push(Tensor::new(
            "spectra",
            &[np, nt, nl, n, n],
            TensorData::F32(values(&mut rng, np * nt * nl * n * n, n)),
        ));
    } else {
        f.push(Tensor::new(
            "rgb",
            &[np, nt, 3, n, n],
            TensorData::F32(values(&mut rng, np * nt * 3 * n * n, n)),
        ));
    }
    f.push(Tensor::new("jacobian", &[1], TensorData::U8(vec![1])));
    let bits = np * nt * n * n;
    let valid: Vec<u8> = (0..bits.div_ceil(8)).map(|_| rng.random()).collect();
    f.push(Tensor::new(
        "valid",
        &[bits.div_ceil(8)],
        TensorData::U8(valid),
    ));
    f
}

/// Values as measured data look: smooth over each n × n slice (a product of sines of
/// random frequency and phase) with 2 % noise, about 5 % of them negative, as the
/// database's saturated colours are. (White noise would make every value hinge on the
/// last bits of the sample position, which Mitsuba computes in f32.)
fn values(rng: &mut ChaCha8Rng, len: u64, n: u64) -> Vec<f32> {
    let mut out = Vec::with_capacity(len as usize);
    while (out.len() as u64) < len {
        let (a, b, c, d): (f32, f32, f32, f32) = (
            rng.random_range(1.0..5.0),
            rng.random_range(0.0..6.3),
            rng.random_range(1.0..5.0),
            rng.random_range(0.0..6.3),
        );
        for y in 0..n {
            for x in 0..n {
                let (u, v) = (x as f32 / (n - 1) as f32, y as f32 / (n - 1) as f32);
                let s = (a * u + b).sin() * (c * v + d).sin();
                out.push(0.3 + 0.36 * s + 0.02 * (rng.random::<f32>() - 0.5));
            }
        }
    }
    out
}

/// Positive smooth tables (NDF, σ, VNDF, luminance shapes): `lo..hi` modulated by a
/// smooth random bump, with 2 % noise.
fn positive(rng: &mut ChaCha8Rng, len: u64, lo: f32, hi: f32) -> Vec<f32> {
    let (a, b): (f32, f32) = (rng.random_range(1.0..6.0), rng.random_range(0.0..6.3));
    (0..len)
        .map(|k| {
            let t = 0.5 + 0.5 * (a * (k % 97) as f32 / 97.0 + b).sin();
            (lo + (hi - lo) * t) * (1.0 + 0.02 * (rng.random::<f32>() - 0.5))
        })
        .collect()
}

/// `count` unit direction pairs, uniform on the hemisphere above `min_deg` elevation.
pub fn pairs(count: usize, min_deg: f64, seed: u64) -> Vec<[f64; 6]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let zmin = min_deg.to_radians().sin();
    let mut dir = || loop {
        let (z, phi): (f64, f64) = (rng.random(), rng.random::<f64>() * std::f64::consts::TAU);
        if z > zmin {
            let r = (1.0 - z * z).sqrt();
            return [r * phi.cos(), r * phi.sin(), z];
        }
    };
    (0..count)
        .map(|_| {
            let (a, b) = (dir(), dir());
            [a[0], a[1], a[2], b[0], b[1], b[2]]
        })
        .collect()
}
