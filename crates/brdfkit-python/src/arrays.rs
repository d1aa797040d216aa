//! The one conversion rule of every array argument, and the direction and grid checks.
//!
//! An array argument is anything `numpy.asarray(x, dtype=numpy.float64)` accepts
//! (float64 or float32 arrays, integer arrays, nested lists and tuples, Fortran-order
//! arrays and strided views): it is converted by `numpy.ascontiguousarray(x,
//! dtype=float64)`, which returns a C-contiguous float64 array itself (no copy) and
//! copies anything else once. The shape is then checked, and an error names the
//! argument and the shape expected. Directions must also be unit vectors
//! (`brdfkit_core::direction::check_unit_pairs`, the command line's rule).

use crate::errors;
use brdfkit_core::direction::check_unit_pairs;
use brdfkit_merl::Dims;
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use rayon::prelude::*;

/// A shape as Python prints it: `(4, 2)`, `(3,)`.
pub(crate) fn shape_text(s: &[usize]) -> String {
    match s {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            s.iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// `obj` as a C-contiguous float64 array; a failure of NumPy's conversion keeps its
/// exception type (`ValueError`, `TypeError`) with the argument's name in front.
pub(crate) fn float64<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
    let py = obj.py();
    let kw = PyDict::new(py);
    kw.set_item("dtype", "float64")?;
    let converted = py
        .import("numpy")?
        .getattr("ascontiguousarray")?
        .call((obj,), Some(&kw))
        .map_err(|e| {
            let msg = format!(
                "{name}: cannot be converted to a float64 array ({})",
                e.value(py)
            );
            PyErr::from_type(e.get_type(py), msg)
        })?;
    let a = converted
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|_| errors::value(format!("{name}: not convertible to a float64 array")))?;
    Ok(a.readonly())
}

/// Directions: an (N, 3) array, or one direction (3,) as one row.
pub(crate) fn directions<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<PyReadonlyArrayDyn<'py, f64>> {
    let a = float64(obj, name)?;
    match a.shape() {
        [_, 3] | [3] => Ok(a),
        s => Err(errors::value(format!(
            "{name}: shape {}, expected (N, 3) or (3,)",
            shape_text(s)
        ))),
    }
}

/// Rows of three of an array from [`directions`].
pub(crate) fn rows3<'a>(a: &'a PyReadonlyArrayDyn<'_, f64>) -> PyResult<&'a [[f64; 3]]> {
    let (rows, _) = a.as_slice()?.as_chunks::<3>();
    Ok(rows)
}

/// Checks the direction pairs `a` (of `wi`) and `b` (of `wo`): as many of each, every
/// one a unit vector (the first offending row named). Needs no GIL.
pub(crate) fn check_pairs(a: &[[f64; 3]], b: &[[f64; 3]]) -> PyResult<()> {
    if a.len() != b.len() {
        return Err(errors::value(format!(
            "{} wi directions, {} wo directions: expected as many of each",
            a.len(),
            b.len()
        )));
    }
    // On every thread: the check is a pass over 70 MB for 1.46 M pairs, which on one
    // thread took half as long as the nearest lookup it guards.
    const BLOCK: usize = 1 << 14;
    let bad = a
        .par_chunks(BLOCK)
        .zip(b.par_chunks(BLOCK))
        .enumerate()
        .find_map_first(|(k, (x, y))| {
            check_unit_pairs(x, y).err().map(|mut e| {
                e.row += k * BLOCK;
                e
            })
        });
    bad.map_or(Ok(()), |e| Err(errors::input(e)))
}

/// The pairs (wi[k], wo[k]) of two direction arguments, checked ([`check_pairs`]), and
/// `f` of them into (N, 3) rows, with the GIL released: the one path of every
/// per-pair evaluation of the package (`Model.eval`, `MerlTable.lookup`,
/// `RglBsdf.eval`), returned as an (N, 3) float64 array.
pub(crate) fn eval_pairs<'py, F>(
    py: Python<'py>,
    wi: &Bound<'py, PyAny>,
    wo: &Bound<'py, PyAny>,
    f: F,
) -> PyResult<Bound<'py, PyAny>>
where
    F: FnOnce(&[[f64; 3]], &[[f64; 3]], &mut [[f64; 3]]) -> PyResult<()> + Send,
{
    let (wi, wo) = (directions(wi, "wi")?, directions(wo, "wo")?);
    let (wi, wo) = (rows3(&wi)?, rows3(&wo)?);
    let mut out = vec![0.0; 3 * wi.len()];
    py.detach(|| {
        check_pairs(wi, wo)?;
        let (rows, _) = out.as_chunks_mut::<3>();
        f(wi, wo, rows)
    })?;
    rows_array(py, out)
}

/// Grid dims from any sequence of three integers (a tuple, a list, a NumPy array).
pub(crate) fn dims_of(obj: &Bound<'_, PyAny>) -> PyResult<Dims> {
    const WANT: &str = "expected a sequence of three integers (n_theta_h, n_theta_d, n_phi_d)";
    if obj.cast::<PyString>().is_ok() {
        return Err(errors::type_error(format!("dims: {WANT}, got a str")));
    }
    let v: Vec<i64> = obj
        .extract()
        .map_err(|e: PyErr| errors::type_error(format!("dims: {WANT} ({})", e.value(obj.py()))))?;
    match v[..] {
        [a, b, c] => Dims::new(a, b, c).map_err(|e| errors::value(format!("dims: {e}"))),
        _ => Err(errors::value(format!(
            "dims: {WANT}, got {} values",
            v.len()
        ))),
    }
}

/// An (N, 3) float64 array that takes over `v` (3N values) without a copy.
pub(crate) fn rows_array<'py>(py: Python<'py>, v: Vec<f64>) -> PyResult<Bound<'py, PyAny>> {
    let n = v.len() / 3;
    Ok(PyArray1::from_vec(py, v).reshape([n, 3])?.into_any())
}
