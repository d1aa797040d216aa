//! Hand-built tiny `.bsdf` files with known values, write → read round trips of the
//! tensor container (every dtype), and the model's closed-form properties.

mod common;

use brdfkit_core::{Brdf, Vec3};
use brdfkit_rgl::tensor::{self, encode};
use brdfkit_rgl::{Dtype, RglBsdf, Tensor, TensorData, TensorFile};
use std::path::Path;

/// A tiny isotropic RGB file: θi = 0, 40°, 80°; 2 × 2 grids; `rgb` per θi slice
/// constant over the grid (`slice_rgb[t]`); ndf and σ constant.
fn tiny(slice_rgb: [[f32; 3]; 3], jacobian: u8, ndf: f32, sigma: f32) -> Vec<Tensor> {
    let theta: Vec<f32> = [0.0f32, 40.0, 80.0]
        .iter()
        .map(|d| d.to_radians())
        .collect();
    let rgb: Vec<f32> = slice_rgb
        .iter()
        .flat_map(|c| c.iter().flat_map(|&v| [v; 4]))
        .collect();
    vec![
        Tensor::new("description", &[4], TensorData::U8(b"tiny".to_vec())),
        Tensor::new("phi_i", &[1], TensorData::F32(vec![0.0])),
        Tensor::new("theta_i", &[3], TensorData::F32(theta)),
        Tensor::new("sigma", &[2, 2], TensorData::F32(vec![sigma; 4])),
        Tensor::new("ndf", &[2, 2], TensorData::F32(vec![ndf; 4])),
        Tensor::new("vndf", &[1, 3, 2, 2], TensorData::F32(vec![1.0; 12])),
        Tensor::new("luminance", &[1, 3, 2, 2], TensorData::F32(vec![1.0; 12])),
        Tensor::new("rgb", &[1, 3, 3, 2, 2], TensorData::F32(rgb)),
        Tensor::new("jacobian", &[1], TensorData::U8(vec![jacobian])),
        Tensor::new(
            "valid",
            &[2],
            TensorData::U8(vec![0b1011_0001, 0b0000_0111]),
        ),
    ]
}

fn load(fields: &[Tensor]) -> RglBsdf {
    let bytes = encode(fields, Path::new("tiny.bsdf")).unwrap();
    RglBsdf::from_tensor(&TensorFile::from_bytes(bytes, "tiny.bsdf").unwrap()).unwrap()
}

/// The stored value (times the Jacobian) at a pair: Mitsuba's `eval`, f · cos θo; the
/// reader's f_r is it over cos θo.
fn stored(b: &RglBsdf, wi: &Vec3, wo: &Vec3) -> brdfkit_core::Rgb {
    let f = b.eval(wi, wo);
    assert!(wo.z > 0.0 || f.0 == [0.0; 3], "a value below the horizon");
    f.map(|c| c * wo.z)
}

fn dir(theta_deg: f64, phi_deg: f64) -> Vec3 {
    brdfkit_core::direction::spherical(theta_deg.to_radians(), phi_deg.to_radians())
}

#[test]
fn constant_values_come_back_and_nothing_below_the_horizon() {
    let b = load(&tiny([[0.5, -0.25, 2.0]; 3], 0, 1.0, 1.0));
    for (ti, pi, to, po) in [
        (10.0, 0.0, 50.0, 180.0),
        (70.0, 33.0, 5.0, -120.0),
        (0.5, 0.0, 89.0, 90.0),
    ] {
        let v = stored(&b, &dir(ti, pi), &dir(to, po));
        assert!(
            (v.0[0] - 0.5).abs() < 1e-6
                && (v.0[1] + 0.25).abs() < 1e-6
                && (v.0[2] - 2.0).abs() < 1e-6,
            "{v:?}"
        );
    }
    // Negative values are kept, as stored; below the horizon everything is 0.
    assert_eq!(stored(&b, &dir(100.0, 0.0), &dir(30.0, 0.0)).0, [0.0; 3]);
    assert_eq!(stored(&b, &dir(30.0, 0.0), &dir(95.0, 0.0)).0, [0.0; 3]);
}

#[test]
fn the_jacobian_flag_scales_by_ndf_over_four_sigma() {
    let b = load(&tiny([[1.0, 1.0, 1.0]; 3], 1, 6.0, 0.5));
    let v = stored(&b, &dir(20.0, 10.0), &dir(60.0, 200.0));
    // D / (4 σ) = 6 / 2 = 3.
    assert!((v.0[0] - 3.0).abs() < 1e-6, "{v:?}");
}

#[test]
fn values_interpolate_linearly_in_theta_i_and_not_in_theta_o() {
    let b = load(&tiny(
        [[1.0, 0.0, 0.0], [3.0, 0.0, 0.0], [7.0, 0.0, 0.0]],
        0,
        1.0,
        1.0,
    ));
    // On a slice: its value; halfway between 40° and 80°: the mean; θo does not matter.
    for to in [5.0, 45.0, 85.0] {
        assert!((stored(&b, &dir(40.0, 0.0), &dir(to, 90.0)).0[0] - 3.0).abs() < 1e-5);
        assert!((stored(&b, &dir(60.0, 0.0), &dir(to, 90.0)).0[0] - 5.0).abs() < 1e-5);
        assert!((stored(&b, &dir(20.0, 0.0), &dir(to, 90.0)).0[0] - 2.0).abs() < 1e-5);
    }
    // So the file is not reciprocal: f(wi, wo) ≠ f(wo, wi).
    let (a, c) = (dir(20.0, 0.0), dir(60.0, 180.0));
    assert!((stored(&b, &a, &c).0[0] - stored(&b, &c, &a).0[0]).abs() > 2.0);
    let asym = b.asymmetry(2000, 5.0, 1);
    assert!(asym.median > 0.05 && asym.skipped == 0, "{asym:?}");
}

#[test]
fn the_summary_reports_grids_negatives_and_measured_points() {
    let b = load(&tiny([[0.5, -0.25, 2.0]; 3], 0, 1.0, 1.0));
    let s = b.summary();
    assert_eq!(
        (s.n_phi_i, s.n_theta_i, s.value_grid, s.vndf_grid),
        (1, 3, [2, 2], [2, 2])
    );
    assert_eq!((s.values, s.negative), (36, 12));
    // 1 × 3 × 2 × 2 = 12 bits; set bits of 0b1011_0001, 0b0000_0111: 4 + 3.
    assert_eq!(s.measured_points, Some((7, 12)));
    assert_eq!(b.description(), "tiny");
    assert!(!b.is_spectral() && !b.is_anisotropic());
}

#[test]
fn a_flat_spectral_file_is_white_in_srgb() {
    let mut f = tiny([[0.0; 3]; 3], 0, 1.0, 1.0);
    f.retain(|t| t.name != "rgb");
    let wl: Vec<f32> = (0..=47).map(|k| 360.0 + 10.0 * k as f32).collect();
    let n = wl.len() as u64;
    f.push(Tensor::new("wavelengths", &[n], TensorData::F32(wl)));
    f.push(Tensor::new(
        "spectra",
        &[1, 3, n, 2, 2],
        TensorData::F32(vec![0.8; 12 * n as usize]),
    ));
    let b = load(&f);
    let v = stored(&b, &dir(30.0, 0.0), &dir(50.0, 120.0));
    for c in 0..3 {
        assert!((v.0[c] - 0.8).abs() < 2e-3, "{v:?}");
    }
    let (wi, wo) = (dir(30.0, 0.0), dir(50.0, 120.0));
    assert!((b.eval_spectral(&wi, &wo, 555.0).unwrap() * wo.z - 0.8).abs() < 1e-6);
}

#[test]
fn every_dtype_round_trips() {
    let fields = vec![
        Tensor::new("a", &[2], TensorData::U8(vec![0, 255])),
        Tensor::new("b", &[2], TensorData::I8(vec![-128, 127])),
        Tensor::new("c", &[1, 2], TensorData::U16(vec![0, 65535])),
        Tensor::new("d", &[2], TensorData::I16(vec![-32768, 5])),
        Tensor::new("e", &[2], TensorData::U32(vec![7, u32::MAX])),
        Tensor::new("f", &[2], TensorData::I32(vec![-7, i32::MIN])),
        Tensor::new("g", &[2], TensorData::U64(vec![1 << 40, 3])),
        Tensor::new("h", &[2], TensorData::I64(vec![-(1 << 40), 3])),
        Tensor::new(
            "i",
            &[2],
            TensorData::F16(vec![half::f16::from_f32(1.5), half::f16::from_f32(-0.25)]),
        ),
        Tensor::new(
            "j",
            &[2, 1, 1],
            TensorData::F32(vec![1.25, f32::MIN_POSITIVE]),
        ),
        Tensor::new("k", &[0], TensorData::F64(vec![])),
        Tensor::new("l", &[2], TensorData::F64(vec![1e300, -2.5])),
    ];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("all.tensor");
    tensor::write(&fields, &path).unwrap();
    let tf = TensorFile::read(&path).unwrap();
    assert_eq!(tf.fields().len(), fields.len());
    for (f, g) in fields.iter().zip(tf.fields()) {
        assert_eq!(
            (&f.name, f.data.dtype(), &f.shape),
            (&g.name, g.dtype, &g.shape)
        );
        assert_eq!(g.offset % 8, 0, "aligned like Mitsuba's writer");
    }
    let want: [&[f64]; 12] = [
        &[0.0, 255.0],
        &[-128.0, 127.0],
        &[0.0, 65535.0],
        &[-32768.0, 5.0],
        &[7.0, u32::MAX as f64],
        &[-7.0, i32::MIN as f64],
        &[(1u64 << 40) as f64, 3.0],
        &[-((1i64 << 40) as f64), 3.0],
        &[1.5, -0.25],
        &[1.25, f64::from(f32::MIN_POSITIVE)],
        &[],
        &[1e300, -2.5],
    ];
    for (f, w) in fields.iter().zip(want) {
        assert_eq!(tf.to_f64(&f.name).unwrap(), w, "{}", f.name);
    }
    assert_eq!(tf.get("i").unwrap().dtype, Dtype::F16);
}

#[test]
fn a_realistic_file_round_trips_bit_for_bit() {
    let f = common::fields(common::Spec {
        anisotropic: true,
        spectral: false,
        n: 32,
        m: 32,
        seed: 3,
    });
    let bytes = encode(&f, Path::new("x.bsdf")).unwrap();
    let tf = TensorFile::from_bytes(bytes.clone(), "x.bsdf").unwrap();
    for t in &f {
        if let TensorData::F32(v) = &t.data {
            assert_eq!(&tf.f32s(&t.name).unwrap(), v);
        }
    }
    let b = RglBsdf::from_tensor(&tf).unwrap();
    assert!(b.is_anisotropic());
    // Re-encoding what was read gives the same bytes.
    let again: Vec<Tensor> = tf
        .fields()
        .iter()
        .map(|g| {
            let data = match g.dtype {
                Dtype::F32 => TensorData::F32(tf.f32s(&g.name).unwrap()),
                Dtype::U8 => TensorData::U8(tf.u8s(&g.name).unwrap().to_vec()),
                Dtype::U32 => TensorData::U32(
                    tf.to_f64(&g.name)
                        .unwrap()
                        .iter()
                        .map(|&x| x as u32)
                        .collect(),
                ),
                d => panic!("unexpected {d:?}"),
            };
            Tensor::new(g.name.clone(), &g.shape, data)
        })
        .collect();
    assert_eq!(encode(&again, Path::new("x.bsdf")).unwrap(), bytes);
}

#[test]
fn the_writer_refuses_a_shape_that_disagrees_with_the_data() {
    let e = encode(
        &[Tensor::new("x", &[3], TensorData::F32(vec![1.0]))],
        Path::new("o.bsdf"),
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("o.bsdf") && e.to_string().contains("`x`"),
        "{e}"
    );
}
