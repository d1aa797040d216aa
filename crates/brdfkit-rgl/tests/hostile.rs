//! Hostile `.bsdf` files: each is a typed error naming the file and the field, never a
//! panic, and nothing is allocated from a count or a shape before it is checked
//! against the file's size.

mod common;

use brdfkit_rgl::tensor::encode;
use brdfkit_rgl::{RglBsdf, RglError, Tensor, TensorData, TensorFile};
use std::path::Path;

const NAME: &str = "hostile.bsdf";

/// Asserts that `result` is the error `RglError::$variant` naming `$field`.
macro_rules! assert_error {
    ($result:expr, $variant:ident, $field:literal) => {
        let e = $result.unwrap_err();
        assert!(
            matches!(&e, RglError::$variant { field, .. } if field == $field),
            "{e}"
        );
    };
}

fn good() -> Vec<Tensor> {
    common::fields(common::Spec {
        anisotropic: false,
        spectral: false,
        n: 32,
        m: 32,
        seed: 5,
    })
}

fn read(bytes: Vec<u8>) -> Result<RglBsdf, RglError> {
    RglBsdf::from_tensor(&TensorFile::from_bytes(bytes, NAME)?)
}

fn bytes_of(fields: &[Tensor]) -> Vec<u8> {
    encode(fields, Path::new(NAME)).unwrap()
}

/// The error of `fields` changed by `edit`, which must name the file and `field`.
fn error_with(edit: impl FnOnce(&mut Vec<Tensor>), field: &str) -> RglError {
    let mut f = good();
    edit(&mut f);
    let e = read(bytes_of(&f)).expect_err("must fail");
    let msg = e.to_string();
    assert!(msg.contains(NAME) && msg.contains(field), "{msg}");
    e
}

/// [`error_with`] of the file whose field `name` is given `shape` and `data`.
fn error_setting(name: &str, shape: &[u64], data: TensorData) -> RglError {
    error_with(|f| set(f, name, shape, data), name)
}

fn set(f: &mut [Tensor], name: &str, shape: &[u64], data: TensorData) {
    let t = f.iter_mut().find(|t| t.name == name).unwrap();
    t.shape = shape.to_vec();
    t.data = data;
}

/// Position of the directory entry of field `index` (its name length).
fn entry_at(bytes: &[u8], index: usize) -> usize {
    let mut at = 18;
    for _ in 0..index {
        let name = u16::from_le_bytes([bytes[at], bytes[at + 1]]) as usize;
        let ndim = u16::from_le_bytes([bytes[at + 2 + name], bytes[at + 3 + name]]) as usize;
        at += 2 + name + 2 + 1 + 8 + 8 * ndim;
    }
    at
}

/// (offset position, first shape position) of the entry of field `index`.
fn slots(bytes: &[u8], index: usize) -> (usize, usize) {
    let at = entry_at(bytes, index);
    let name = u16::from_le_bytes([bytes[at], bytes[at + 1]]) as usize;
    let off = at + 2 + name + 2 + 1;
    (off, off + 8)
}

#[test]
fn the_good_file_reads() {
    read(bytes_of(&good())).unwrap();
}

#[test]
fn every_truncation_is_an_error() {
    let bytes = bytes_of(&good());
    let header_end = entry_at(&bytes, good().len());
    // Every cut inside the header and directory, then cuts through the data.
    let cuts = (0..header_end).chain((header_end..bytes.len()).step_by(997));
    for n in cuts {
        let e = read(bytes[..n].to_vec()).expect_err("truncated");
        assert!(e.to_string().contains(NAME), "{e}");
        if n > header_end {
            assert!(matches!(e, RglError::OutOfBounds { .. }), "{e}");
        }
    }
}

#[test]
fn an_offset_past_the_end_names_the_field() {
    let mut bytes = bytes_of(&good());
    let (off, _) = slots(&bytes, 6); // vndf
    bytes[off..off + 8].copy_from_slice(&(u64::MAX - 3).to_le_bytes());
    assert_error!(read(bytes), OutOfBounds, "vndf");
}

#[test]
fn a_shape_whose_product_overflows_names_the_field() {
    let mut bytes = bytes_of(&good());
    let (_, shape) = slots(&bytes, 6); // vndf: 4 dims
    for k in 0..4 {
        bytes[shape + 8 * k..shape + 8 * k + 8].copy_from_slice(&(1u64 << 20).to_le_bytes());
    }
    assert_error!(read(bytes), ShapeOverflow, "vndf");
}

#[test]
fn a_huge_shape_inside_u64_is_out_of_bounds_not_an_allocation() {
    let mut bytes = bytes_of(&good());
    let (_, shape) = slots(&bytes, 7); // luminance
    bytes[shape..shape + 8].copy_from_slice(&(1u64 << 40).to_le_bytes());
    assert_error!(read(bytes), OutOfBounds, "luminance");
}

#[test]
fn a_field_count_beyond_the_file_is_an_error_not_an_allocation() {
    // 4 billion entries claimed: the parser reads the data as further entries and stops
    // at the first that makes no sense; nothing is reserved from the count.
    let mut bytes = bytes_of(&good());
    bytes[14..18].copy_from_slice(&u32::MAX.to_le_bytes());
    let e = read(bytes).unwrap_err();
    assert!(e.to_string().contains(NAME), "{e}");
    let mut header_only = bytes_of(&good())[..18].to_vec();
    header_only[14..18].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(
        read(header_only).unwrap_err(),
        RglError::Truncated { .. }
    ));
}

#[test]
fn shapes_that_disagree_name_the_field() {
    let e = error_setting(
        "vndf",
        &[1, 7, 32, 32],
        TensorData::F32(vec![1.0; 7 * 1024]),
    );
    assert!(matches!(e, RglError::Shape { .. }));
    error_setting(
        "luminance",
        &[1, 8, 16, 16],
        TensorData::F32(vec![1.0; 8 * 256]),
    );
    error_setting(
        "rgb",
        &[1, 8, 4, 32, 32],
        TensorData::F32(vec![1.0; 8 * 4 * 1024]),
    );
    error_setting("ndf", &[64], TensorData::F32(vec![1.0; 64]));
    error_setting("sigma", &[1, 32], TensorData::F32(vec![1.0; 32]));
    error_setting("jacobian", &[2], TensorData::U8(vec![1, 1]));
}

#[test]
fn wrong_dtypes_name_the_field() {
    let e = error_setting("theta_i", &[8], TensorData::F64(vec![0.1; 8]));
    assert!(matches!(e, RglError::Dtype { .. }));
    error_setting("jacobian", &[1], TensorData::U32(vec![1]));
    error_setting(
        "vndf",
        &[1, 8, 32, 32],
        TensorData::F64(vec![1.0; 8 * 1024]),
    );
    error_setting("valid", &[1024], TensorData::I8(vec![0; 1024]));
}

#[test]
fn an_unknown_dtype_code_names_the_field() {
    let mut bytes = bytes_of(&good());
    let (off, _) = slots(&bytes, 4); // sigma: the dtype byte precedes the offset
    bytes[off - 1] = 12;
    assert_error!(read(bytes), Dtype, "sigma");
}

#[test]
fn missing_fields_name_the_field() {
    for name in [
        "theta_i",
        "phi_i",
        "ndf",
        "sigma",
        "vndf",
        "luminance",
        "rgb",
        "jacobian",
        "description",
    ] {
        let e = error_with(|f| f.retain(|t| t.name != name), name);
        assert!(matches!(e, RglError::Missing { .. }), "{e}");
    }
}

#[test]
fn nan_or_unsorted_theta_i_names_the_field() {
    let th = |v: Vec<f32>| move |f: &mut Vec<Tensor>| set(f, "theta_i", &[8], TensorData::F32(v));
    let e = error_with(
        th(vec![0.0, 0.1, f32::NAN, 0.3, 0.4, 0.5, 0.6, 0.7]),
        "theta_i",
    );
    assert!(matches!(e, RglError::Value { .. }));
    error_with(th(vec![0.0, 0.2, 0.1, 0.3, 0.4, 0.5, 0.6, 0.7]), "theta_i");
    error_with(th(vec![0.0, 0.1, 0.1, 0.3, 0.4, 0.5, 0.6, 0.7]), "theta_i");
    error_setting("theta_i", &[0], TensorData::F32(vec![]));
}

#[test]
fn a_valid_field_of_the_wrong_length_names_the_field() {
    let e = error_setting("valid", &[1023], TensorData::U8(vec![0; 1023]));
    assert!(matches!(e, RglError::Shape { .. }));
}

#[test]
fn a_duplicate_field_or_a_foreign_file_is_an_error() {
    let mut f = good();
    f.push(f[3].clone());
    assert!(matches!(
        read(bytes_of(&f)).unwrap_err(),
        RglError::Duplicate { .. }
    ));
    let e = read(b"MERL table, not a tensor file".to_vec()).unwrap_err();
    assert!(matches!(e, RglError::NotTensorFile { .. }));
    let mut v = bytes_of(&good());
    v[12] = 2;
    assert!(matches!(read(v).unwrap_err(), RglError::Version { .. }));
}

#[test]
fn random_byte_flips_never_panic() {
    let bytes = bytes_of(&good());
    let header_end = entry_at(&bytes, good().len());
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..3000 {
        let mut b = bytes.clone();
        for _ in 0..4 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let at = (x as usize) % header_end;
            b[at] = (x >> 32) as u8;
        }
        let _ = read(b);
    }
}
