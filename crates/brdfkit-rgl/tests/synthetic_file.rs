//! The vendored `data-synthetic/felt-synthetic.bsdf` (the README tour's `.bsdf`: there is
//! no database file in the repository) is exactly what this generator writes, so it can
//! be remade and checked: `BRDFKIT_REGENERATE=1 cargo test -p brdfkit-rgl --test
//! synthetic_file` rewrites it. It is synthetic (a formula, not a measurement): an
//! isotropic RGB file in the layout of the RGL-EPFL database's `*_rgb.bsdf` files
//! (Dupuy & Jakob 2018), smaller (8 θi slices, 16 × 16 VNDF and values).

use brdfkit_core::{Brdf, Vec3};
use brdfkit_rgl::{RglBsdf, Tensor, TensorData, tensor};
use std::path::PathBuf;

fn vendored() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data-synthetic/felt-synthetic.bsdf")
}

/// A rough, reddish felt: nearly diffuse values that grow towards grazing θi and
/// with the sample position (the warped grid's v ~ θ of the half vector), a few
/// percent negative in blue at grazing angles (as the database's spectral-to-RGB
/// conversion leaves them), a broad NDF and σ from it, and a VNDF peaked at the pole.
fn fields() -> Vec<Tensor> {
    let (nt, n) = (8usize, 16usize);
    let theta: Vec<f32> = (0..nt)
        .map(|k| (k as f32 / (nt - 1) as f32 * 89.0).to_radians())
        .collect();
    let albedo = [0.55f32, 0.28, 0.16];
    let mut rgb = Vec::with_capacity(nt * 3 * n * n);
    for (t, th) in theta.iter().enumerate() {
        for (c, a) in albedo.iter().enumerate() {
            for y in 0..n {
                for x in 0..n {
                    let (u, v) = (x as f32 / (n - 1) as f32, y as f32 / (n - 1) as f32);
                    let grazing = th.sin().powi(4) * v * v;
                    let base =
                        a / std::f32::consts::PI * (1.0 + 0.6 * grazing + 0.05 * (6.0 * u).cos());
                    // Blue dips below 0 at the last slice's far rows.
                    let dip = if c == 2 && t == nt - 1 && y >= n - 2 {
                        0.12
                    } else {
                        0.0
                    };
                    rgb.push(base - dip);
                }
            }
        }
    }
    let lum: Vec<f32> = rgb
        .chunks_exact(3 * n * n)
        .flat_map(|s| {
            (0..n * n)
                .map(move |i| 0.2126 * s[i] + 0.7152 * s[n * n + i] + 0.0722 * s[2 * n * n + i])
        })
        .map(|l| l.max(1e-4))
        .collect();
    // NDF and σ on (2, 32) grids over (θ, φ); the VNDF per θi slice, over the unit square.
    let ndf: Vec<f32> = (0..64)
        .map(|i| 1.0 + 0.8 * (1.0 - (i % 32) as f32 / 31.0))
        .collect();
    let sigma: Vec<f32> = (0..64)
        .map(|i| 1.0 + 0.2 * ((i % 32) as f32 / 31.0))
        .collect();
    let vndf: Vec<f32> = (0..nt * n * n)
        .map(|i| {
            let (t, y) = (i / (n * n), (i / n) % n);
            1.0 + (1.0 - y as f32 / (n - 1) as f32) * (1.0 + 0.1 * t as f32)
        })
        .collect();
    let description = b"synthetic felt: a formula in the layout of an RGL-EPFL *_rgb.bsdf (brdfkit, data-synthetic/README.md)".to_vec();
    let mut valid = vec![0u8; nt * n * n / 8];
    for (k, b) in valid.iter_mut().enumerate() {
        *b = if k % 4 == 0 { 0xff } else { 0x11 };
    }
    vec![
        Tensor::new("version", &[2], TensorData::U32(vec![1, 0])),
        Tensor::new(
            "description",
            &[description.len() as u64],
            TensorData::U8(description),
        ),
        Tensor::new("phi_i", &[1], TensorData::F32(vec![0.0])),
        Tensor::new("theta_i", &[nt as u64], TensorData::F32(theta)),
        Tensor::new("sigma", &[2, 32], TensorData::F32(sigma)),
        Tensor::new("ndf", &[2, 32], TensorData::F32(ndf)),
        Tensor::new(
            "vndf",
            &[1, nt as u64, n as u64, n as u64],
            TensorData::F32(vndf),
        ),
        Tensor::new(
            "luminance",
            &[1, nt as u64, n as u64, n as u64],
            TensorData::F32(lum),
        ),
        Tensor::new(
            "rgb",
            &[1, nt as u64, 3, n as u64, n as u64],
            TensorData::F32(rgb),
        ),
        Tensor::new("jacobian", &[1], TensorData::U8(vec![1])),
        Tensor::new("valid", &[(nt * n * n / 8) as u64], TensorData::U8(valid)),
    ]
}

#[test]
fn the_vendored_synthetic_bsdf_is_what_the_generator_writes() {
    let bytes = tensor::encode(&fields(), &vendored()).unwrap();
    if std::env::var_os("BRDFKIT_REGENERATE").is_some() {
        std::fs::write(vendored(), &bytes).unwrap();
    }
    let on_disk = std::fs::read(vendored()).expect("data-synthetic/felt-synthetic.bsdf");
    assert!(
        on_disk == bytes,
        "regenerate with BRDFKIT_REGENERATE=1 (see the module doc)"
    );
    // It reads back, is a plausible material, and has a few negative values.
    let b = RglBsdf::read(&vendored()).unwrap();
    let s = b.summary();
    assert!(
        s.negative > 0 && s.negative * 50 < s.values,
        "{} of {}",
        s.negative,
        s.values
    );
    let v = b.eval(
        &Vec3::new(0.0, 0.0, 1.0),
        &Vec3::new(0.3, 0.0, 0.953_939_2).normalize(),
    );
    assert!(v.0.iter().all(|&x| x > 0.0 && x < 1.0), "{v:?}");
    assert!(v.0[0] > v.0[1] && v.0[1] > v.0[2], "reddish: {v:?}");
}
