//! `fit X.bsdf` on an anisotropic file fits its measured points at their own directions,
//! as for an isotropic file (docs/rgl.md, "The sample-set fit"), end to end through the
//! binary: a file built from a known model gives the model back.

mod common;

use brdfkit::core::{Model, Vec3};
use brdfkit::rgl::{Tensor, TensorData};
use common::{assert_alpha_rho_d, bin, param, stderr};
use serde_json::Value;
use std::f64::consts::PI;
use std::path::Path;

const TRUTH: &str = r#"{"model":"cook-torrance","params":{"rho_d":[0.3,0.2,0.1],"rho_s":[0.4,0.5,0.6],"alpha":0.2}}"#;

/// The value grid, n × n.
const N: usize = 32;

fn spherical(theta: f64, phi: f64) -> Vec3 {
    Vec3::new(
        phi.cos() * theta.sin(),
        phi.sin() * theta.sin(),
        theta.cos(),
    )
}

/// An anisotropic file (five φi slices over a quarter turn: a 4-fold reduction; nine
/// θi) of the model's values. The VNDF is constant, so the warp is the identity and
/// node s = (x, y)/(n − 1) is the half vector u_m = s (θm = πu_θ²/2, φm = 2πu_φ − π,
/// absolute as in an anisotropic file); no `jacobian` flag, so the stored value is
/// f · cos θo (Mitsuba's `eval` convention); `valid` marks the nodes with wo above the
/// horizon. Everything is written as the format says, not by brdfkit's writer.
fn anisotropic_file(m: &dyn Model, path: &Path) {
    let phi: Vec<f32> = (0..5).map(|k| (-PI + k as f64 * PI / 8.0) as f32).collect();
    let theta: Vec<f32> = (0..9)
        .map(|k| (k as f64 * 10.0).to_radians() as f32)
        .collect();
    let (np, nt, n) = (phi.len(), theta.len(), N as u64);
    let mut rgb = vec![0.0f32; np * nt * 3 * N * N];
    let mut valid = vec![0u8; (np * nt * N * N).div_ceil(8)];
    for (a, &pa) in phi.iter().enumerate() {
        for (b, &tb) in theta.iter().enumerate() {
            let wi = spherical(f64::from(tb), f64::from(pa));
            for y in 0..N {
                for x in 0..N {
                    let u = [x as f64 / (N - 1) as f64, y as f64 / (N - 1) as f64];
                    let h = spherical(PI / 2.0 * u[0] * u[0], 2.0 * PI * u[1] - PI);
                    let wo = h * (2.0 * wi.dot(&h)) - wi;
                    if wo.z <= 0.0 {
                        continue;
                    }
                    let k = (a * nt + b) * N * N + y * N + x;
                    valid[k / 8] |= 0x80 >> (k % 8);
                    let f = m.eval(&wi, &wo).0;
                    for c in 0..3 {
                        rgb[((a * nt + b) * 3 + c) * N * N + y * N + x] = (f[c] * wo.z) as f32;
                    }
                }
            }
        }
    }
    let ones = |len: usize| TensorData::F32(vec![1.0; len]);
    let (p, t) = (np as u64, nt as u64);
    let fields = vec![
        Tensor::new("version", &[2], TensorData::U32(vec![1, 0])),
        Tensor::new("description", &[5], TensorData::U8(b"aniso".to_vec())),
        Tensor::new("phi_i", &[p], TensorData::F32(phi)),
        Tensor::new("theta_i", &[t], TensorData::F32(theta)),
        Tensor::new("sigma", &[16, 32], ones(16 * 32)),
        Tensor::new("ndf", &[16, 32], ones(16 * 32)),
        Tensor::new("vndf", &[p, t, 2, 2], ones(np * nt * 4)),
        Tensor::new("luminance", &[p, t, n, n], ones(np * nt * N * N)),
        Tensor::new("rgb", &[p, t, 3, n, n], TensorData::F32(rgb)),
        Tensor::new("jacobian", &[1], TensorData::U8(vec![0])),
        Tensor::new("valid", &[valid.len() as u64], TensorData::U8(valid)),
    ];
    brdfkit::rgl::tensor::write(&fields, path).unwrap();
}

#[test]
fn an_anisotropic_bsdf_is_fitted_at_its_measured_points() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("aniso_rgb.bsdf");
    let truth = brdfkit::models::from_json_str(TRUTH).unwrap();
    anisotropic_file(truth.as_ref(), &path);
    assert!(brdfkit::rgl::RglBsdf::read(&path).unwrap().is_anisotropic());
    let rec = dir.path().join("r.json");
    let o = bin()
        .args([
            "fit",
            path.to_str().unwrap(),
            "--record",
            rec.to_str().unwrap(),
        ])
        .arg("--out")
        .arg(dir.path().join("fit.json"))
        .output()
        .unwrap();
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    common::assert_mentions(&err, &["measured points"]);
    assert!(!err.contains("resampled"), "{err}");
    let r: Value = serde_json::from_slice(&std::fs::read(rec).unwrap()).unwrap();
    assert_eq!(r["input"]["kind"], "bsdf-points", "{}", r["input"]);
    assert_eq!(r["input"]["weights"], "given");
    assert_alpha_rho_d(&r, 0.2, [0.3, 0.2, 0.1], 2e-3, "points");
    for (c, w) in [0.4, 0.5, 0.6].iter().enumerate() {
        let v = param(&r, "rho_s", Some(c));
        assert!((v - w).abs() < 1e-2, "rho_s[{c}] {v}");
    }
}
