//! Building an [`RglBsdf`] from a tensor file, checking every field the evaluation
//! touches: dtypes, shapes against each other, and the parameter grids' values. Each
//! failure names the file and the field (the checks of `measured.cpp`'s constructor, and
//! those it leaves to chance: NaN or unsorted grids, a `valid` of the wrong length).

use crate::bsdf::{RglBsdf, Summary, Values};
use crate::cie;
use crate::error::RglError;
use crate::tensor::{Dtype, FieldInfo, TensorFile};
use crate::warp::Warp2D;

// Reading is checking: the constructors live beside the checks they run.
impl RglBsdf {
    /// Reads and checks a `.bsdf` file.
    pub fn read(path: &std::path::Path) -> Result<RglBsdf, RglError> {
        RglBsdf::from_tensor(&TensorFile::read(path)?)
    }

    /// The model of a parsed tensor file; every structural problem is an error naming the
    /// file and the field.
    pub fn from_tensor(tf: &TensorFile) -> Result<RglBsdf, RglError> {
        build(tf)
    }
}

/// Whether `f` has the dtype `want`, else the error naming file and field.
fn want_dtype(tf: &TensorFile, f: &FieldInfo, want: Dtype) -> Result<(), RglError> {
    tf.expect_dtype(&f.name, want).map(|_| ())
}

fn shape_err(tf: &TensorFile, field: &str, problem: String) -> RglError {
    RglError::Shape {
        path: tf.path().to_path_buf(),
        field: field.to_owned(),
        problem,
    }
}

/// The field `name`: float32 of `ndim` dimensions.
fn float_field<'a>(tf: &'a TensorFile, name: &str, ndim: usize) -> Result<&'a FieldInfo, RglError> {
    let f = tf.field(name)?;
    want_dtype(tf, f, Dtype::F32)?;
    if f.shape.len() != ndim {
        return Err(shape_err(
            tf,
            name,
            format!(
                "{} dimensions {:?}, expected {ndim}",
                f.shape.len(),
                f.shape
            ),
        ));
    }
    Ok(f)
}

/// A parameter grid: 1-D float32, at least one value, finite, strictly increasing.
fn grid(tf: &TensorFile, name: &str) -> Result<Vec<f32>, RglError> {
    let f = float_field(tf, name, 1)?;
    let v = tf.f32s(name)?;
    let bad = |problem: String| RglError::Value {
        path: tf.path().to_path_buf(),
        field: name.to_owned(),
        problem,
    };
    if v.is_empty() {
        return Err(shape_err(
            tf,
            name,
            format!("shape {:?}: no value", f.shape),
        ));
    }
    if let Some(k) = v.iter().position(|x| !x.is_finite()) {
        return Err(bad(format!("value #{k} is {}", v[k])));
    }
    if let Some(k) = v.windows(2).position(|p| p[1] <= p[0]) {
        return Err(bad(format!(
            "not strictly increasing: value #{} ({}) ≥ value #{} ({})",
            k,
            v[k],
            k + 1,
            v[k + 1]
        )));
    }
    Ok(v)
}

/// Fails unless dimension `axis` of `f` is `want`, saying which field it must agree with.
fn agree(
    tf: &TensorFile,
    f: &FieldInfo,
    axis: usize,
    want: usize,
    with: &str,
) -> Result<(), RglError> {
    if f.shape[axis] as usize != want {
        return Err(shape_err(
            tf,
            &f.name,
            format!(
                "shape {:?}: axis {axis} is {}, but `{with}` has {want}",
                f.shape, f.shape[axis]
            ),
        ));
    }
    Ok(())
}

/// A 2-D grid size (rows, columns) of a field's last two axes, each ≥ 2.
fn grid2(tf: &TensorFile, f: &FieldInfo) -> Result<(usize, usize), RglError> {
    let n = f.shape.len();
    let (h, w) = (f.shape[n - 2] as usize, f.shape[n - 1] as usize);
    if h < 2 || w < 2 {
        return Err(shape_err(
            tf,
            &f.name,
            format!("shape {:?}: the 2-D grid must be at least 2 × 2", f.shape),
        ));
    }
    Ok((h, w))
}

/// The interpolant of a float field of shape (params…, h, w).
fn warp(
    tf: &TensorFile,
    f: &FieldInfo,
    params: Vec<Vec<f32>>,
    normalize: bool,
    sampling: bool,
) -> Result<Warp2D, RglError> {
    let (h, w) = grid2(tf, f)?;
    for (axis, p) in params.iter().enumerate() {
        agree(
            tf,
            f,
            axis,
            p.len(),
            ["phi_i", "theta_i", "the third parameter"][axis],
        )?;
    }
    let data = tf.f32s(&f.name)?;
    Ok(Warp2D::new(&data, w, h, params, normalize, sampling))
}

/// The whole model.
pub(crate) fn build(tf: &TensorFile) -> Result<RglBsdf, RglError> {
    let phi_i = grid(tf, "phi_i")?;
    let theta_i = grid(tf, "theta_i")?;
    let description = tf.field("description")?;
    want_dtype(tf, description, Dtype::U8)?;
    let description = String::from_utf8_lossy(tf.data(description)).into_owned();
    let jac = tf.field("jacobian")?;
    want_dtype(tf, jac, Dtype::U8)?;
    if jac.len != 1 {
        return Err(shape_err(
            tf,
            "jacobian",
            format!("shape {:?}, expected (1,)", jac.shape),
        ));
    }
    let jacobian = tf.data(jac)[0] != 0;
    let ndf = float_field(tf, "ndf", 2)?;
    let sigma = float_field(tf, "sigma", 2)?;
    let vndf = float_field(tf, "vndf", 4)?;
    let lum = float_field(tf, "luminance", 4)?;
    let pt = vec![phi_i.clone(), theta_i.clone()];
    let ndf_w = warp(tf, ndf, vec![], false, false)?;
    let sigma_w = warp(tf, sigma, vec![], false, false)?;
    let vndf_w = warp(tf, vndf, pt.clone(), true, true)?;
    warp_dims_only(tf, lum, &pt)?;
    let (values, vals_field, wavelengths) = values(tf, &pt)?;
    let (n, m) = grid2(tf, vals_field)?;
    let (lh, lw) = grid2(tf, lum)?;
    if (lh, lw) != (n, m) {
        return Err(shape_err(
            tf,
            "luminance",
            format!("grid {lh} × {lw}, but `{}` has {n} × {m}", vals_field.name),
        ));
    }
    let stored = tf.f32s(&vals_field.name)?;
    let summary = Summary {
        fields: tf
            .fields()
            .iter()
            .map(|f| (f.name.clone(), f.dtype.name(), f.shape.clone()))
            .collect(),
        n_phi_i: phi_i.len(),
        n_theta_i: theta_i.len(),
        theta_i: theta_i.iter().map(|&t| f64::from(t)).collect(),
        vndf_grid: [vndf.shape[2] as usize, vndf.shape[3] as usize],
        value_grid: [n, m],
        wavelengths,
        values: stored.len(),
        negative: stored.iter().filter(|&&v| v < 0.0).count(),
        measured_points: valid_bits(tf, phi_i.len() * theta_i.len() * n * m)?,
        jacobian,
    };
    Ok(RglBsdf::from_parts(
        tf,
        description,
        phi_i,
        theta_i,
        ndf_w,
        sigma_w,
        vndf_w,
        values,
        jacobian,
        summary,
    ))
}

/// The luminance table's parameter axes agree with φi, θi (it is not evaluated: it only
/// drives Mitsuba's importance sampling).
fn warp_dims_only(tf: &TensorFile, f: &FieldInfo, pt: &[Vec<f32>]) -> Result<(), RglError> {
    agree(tf, f, 0, pt[0].len(), "phi_i")?;
    agree(tf, f, 1, pt[1].len(), "theta_i")?;
    grid2(tf, f).map(|_| ())
}

/// The value tables: `rgb` (φi, θi, 3, n, n) or `spectra` (φi, θi, λ, n, n) with
/// `wavelengths`.
fn values<'a>(
    tf: &'a TensorFile,
    pt: &[Vec<f32>],
) -> Result<(Values, &'a FieldInfo, Option<Vec<f64>>), RglError> {
    if tf.get("spectra").is_some() {
        let wl = grid(tf, "wavelengths")?;
        let f = float_field(tf, "spectra", 5)?;
        let mut params = pt.to_vec();
        params.push(wl.clone());
        let w = warp(tf, f, params, false, false)?.interleave_last();
        let to_srgb = cie::srgb_weights(&wl);
        let nm = wl.iter().map(|&l| f64::from(l)).collect();
        return Ok((
            Values::Spectral {
                warp: w,
                wavelengths: wl,
                to_srgb,
            },
            f,
            Some(nm),
        ));
    }
    let f = tf.get("rgb").ok_or_else(|| RglError::Missing {
        path: tf.path().to_path_buf(),
        field: "rgb (or spectra)".into(),
    })?;
    float_field(tf, "rgb", 5)?;
    if f.shape[2] != 3 {
        return Err(shape_err(
            tf,
            "rgb",
            format!("shape {:?}: axis 2 must be 3 (R, G, B)", f.shape),
        ));
    }
    let mut params = pt.to_vec();
    params.push(vec![0.0, 1.0, 2.0]);
    let w = warp(tf, f, params, false, false)?.interleave_last();
    Ok((Values::Rgb(w), f, None))
}

/// Set bits of `valid` and the bits it must hold, or `None` without the field; its
/// length must be ⌈bits / 8⌉ bytes of uint8.
fn valid_bits(tf: &TensorFile, bits: usize) -> Result<Option<(usize, usize)>, RglError> {
    let Some(f) = tf.get("valid") else {
        return Ok(None);
    };
    want_dtype(tf, f, Dtype::U8)?;
    let want = bits.div_ceil(8);
    if f.shape.len() != 1 || f.len != want {
        return Err(shape_err(
            tf,
            "valid",
            format!(
                "shape {:?}, expected ({want},): one bit per sample over (phi_i, theta_i, n, n) = {bits} bits",
                f.shape
            ),
        ));
    }
    let set = tf.data(f).iter().map(|b| b.count_ones() as usize).sum();
    Ok(Some((set, bits)))
}
