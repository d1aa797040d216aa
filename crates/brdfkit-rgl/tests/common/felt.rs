//! The "test felt": a small isotropic RGB RGL `.bsdf` (8 θi slices, 16 × 16 smooth values
//! with negatives, smooth `ndf`, `sigma`, `vndf` and `luminance`), deterministic, for
//! the tests that read such a file through brdfkit's users: fit-brdf's `tests/rgl.rs` and
//! brdfkit-python's `tests/pytest.rs`. Included there with `#[path]`; the including
//! module has brdfkit-rgl's `Tensor` and `TensorData` in scope (one crate reaches
//! brdfkit-rgl through the `brdfkit` facade, the other directly).

use super::{Tensor, TensorData};

/// The felt's fields, in the order the RGL files store them, without `valid`.
pub fn fields() -> Vec<Tensor> {
    let theta: Vec<f32> = (0..8).map(|k| (k as f32 * 11.0).to_radians()).collect();
    let n = 16usize;
    let mut rgb = Vec::new();
    for t in 0..8 {
        for c in 0..3 {
            for y in 0..n {
                for x in 0..n {
                    let (u, v) = (x as f32 / 15.0, y as f32 / 15.0);
                    let (c, t) = (c as f32, t as f32);
                    rgb.push(0.3 + 0.4 * (3.0 * u + c + t).sin() * (2.0 * v + c).sin());
                }
            }
        }
    }
    let smooth = |len: usize, k: f32| -> Vec<f32> {
        (0..len)
            .map(|i| 1.0 + 0.3 * (k * i as f32 / len as f32).sin())
            .collect()
    };
    vec![
        Tensor::new("version", &[2], TensorData::U32(vec![1, 0])),
        Tensor::new("description", &[9], TensorData::U8(b"test felt".to_vec())),
        Tensor::new("phi_i", &[1], TensorData::F32(vec![0.0])),
        Tensor::new("theta_i", &[8], TensorData::F32(theta)),
        Tensor::new("sigma", &[2, 32], TensorData::F32(smooth(64, 3.0))),
        Tensor::new("ndf", &[2, 32], TensorData::F32(smooth(64, 5.0))),
        Tensor::new("vndf", &[1, 8, 16, 16], TensorData::F32(smooth(2048, 40.0))),
        Tensor::new(
            "luminance",
            &[1, 8, 16, 16],
            TensorData::F32(smooth(2048, 20.0)),
        ),
        Tensor::new("rgb", &[1, 8, 3, 16, 16], TensorData::F32(rgb)),
        Tensor::new("jacobian", &[1], TensorData::U8(vec![1])),
    ]
}
