//! `brdfkit.MerlTable`: a MERL binary table (`brdfkit_merl::MerlTable`).

use crate::errors;
use brdfkit_core::Rgb;
use brdfkit_merl::{Dims, Lookup, MerlTable};
use numpy::{
    PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray4, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::Arc;

/// A measured isotropic BRDF on the MERL (θh, θd, φd) grid.
///
/// Read one with `MerlTable.read(path)`; `values` is the (3, nθh, nθd, nφd) array of
/// f_r in 1/sr (NaN where the table has no sample), `lookup(wi, wo)` evaluates it
/// at direction pairs.
#[pyclass(name = "MerlTable", module = "brdfkit", frozen)]
pub struct PyTable {
    pub(crate) inner: Arc<MerlTable>,
    /// The file it was read from, for `repr` and error messages.
    pub(crate) path: Option<PathBuf>,
}

impl PyTable {
    /// A table made in memory (a resample, `from_values`).
    pub(crate) fn new(t: MerlTable) -> Self {
        PyTable {
            inner: Arc::new(t),
            path: None,
        }
    }

    /// What error messages call this table: its file, or `<table>`.
    pub(crate) fn label(&self) -> String {
        self.path
            .as_ref()
            .map_or_else(|| "<table>".into(), |p| p.display().to_string())
    }
}

/// The lookup mode of `interp`.
pub(crate) fn lookup_mode(interp: &str) -> PyResult<Lookup> {
    match interp {
        "nearest" => Ok(Lookup::Nearest),
        "linear" | "interpolated" => Ok(Lookup::Interpolated),
        other => Err(errors::value(format!(
            "interp `{other}`: expected \"nearest\" or \"linear\""
        ))),
    }
}

/// Grid dims from a Python triple.
pub(crate) fn dims_of(d: (i64, i64, i64)) -> PyResult<Dims> {
    Dims::new(d.0, d.1, d.2).map_err(errors::input)
}

/// Directions as a C-contiguous float64 (N, 3) array: the array itself when it is one
/// already (no copy), else NumPy's conversion of it (a list, float32, a strided view;
/// one direction (3,) is one row).
pub(crate) fn directions<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<PyReadonlyArray2<'py, f64>> {
    let np = obj.py().import("numpy")?;
    let kw = PyDict::new(obj.py());
    kw.set_item("dtype", "float64")?;
    let a = np.getattr("ascontiguousarray")?.call((obj,), Some(&kw))?;
    let a = np.call_method1("atleast_2d", (a,))?;
    let a = a
        .cast_into::<PyArray2<f64>>()
        .map_err(|_| errors::value(format!("{name}: expected an (N, 3) array of directions")))?;
    if a.shape()[1] != 3 {
        return Err(errors::value(format!(
            "{name}: shape {:?}, expected (N, 3)",
            a.shape()
        )));
    }
    Ok(a.readonly())
}

/// Rows of three of an array from [`directions`].
pub(crate) fn rows3<'a>(a: &'a PyReadonlyArray2<'_, f64>) -> PyResult<&'a [[f64; 3]]> {
    let (rows, _) = a.as_slice()?.as_chunks::<3>();
    Ok(rows)
}

/// An (N, 3) float64 array that takes over `v` (3N values) without a copy.
pub(crate) fn rows_array<'py>(py: Python<'py>, v: Vec<f64>) -> PyResult<Bound<'py, PyAny>> {
    let n = v.len() / 3;
    Ok(PyArray1::from_vec(py, v).reshape([n, 3])?.into_any())
}

#[pymethods]
impl PyTable {
    /// Reads a MERL binary table (any dims).
    #[staticmethod]
    fn read(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let t = py.detach(|| MerlTable::read(&path)).map_err(errors::merl)?;
        Ok(PyTable {
            inner: Arc::new(t),
            path: Some(path),
        })
    }

    /// A table from a (3, nθh, nθd, nφd) array of f_r in 1/sr; NaN marks a missing
    /// cell (in any channel: the whole cell).
    #[staticmethod]
    fn from_values(py: Python<'_>, values: PyReadonlyArray4<'_, f64>) -> PyResult<Self> {
        let s = values.shape();
        if s[0] != 3 {
            return Err(errors::value(format!(
                "values: shape {s:?}, expected (3, n_theta_h, n_theta_d, n_phi_d)"
            )));
        }
        let dims = dims_of((s[1] as i64, s[2] as i64, s[3] as i64))?;
        let v = values.as_slice()?;
        let n = dims.cells();
        let slab = dims.theta_d() * dims.phi_d();
        let t = py
            .detach(|| {
                MerlTable::from_fn(dims, |i, j, k| {
                    let x = i * slab + j * dims.phi_d() + k;
                    let c = [v[x], v[n + x], v[2 * n + x]];
                    (!c.iter().any(|c| c.is_nan())).then_some(Rgb(c))
                })
            })
            .map_err(errors::input)?;
        Ok(PyTable::new(t))
    }

    /// Writes the table atomically (a temporary file renamed into place).
    fn write(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        py.detach(|| self.inner.write(&path)).map_err(errors::merl)
    }

    /// (nθh, nθd, nφd).
    #[getter]
    fn dims(&self) -> (usize, usize, usize) {
        let d = self.inner.dims();
        (d.theta_h(), d.theta_d(), d.phi_d())
    }

    /// The file the table was read from (None for a table made in memory).
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.path.clone()
    }

    /// Fraction of cells with a sample.
    #[getter]
    fn valid_fraction(&self) -> f64 {
        self.inner.valid_fraction()
    }

    /// f_r in 1/sr as a new (3, nθh, nθd, nφd) float64 array (R, G, B planes, raw × the
    /// MERL scales), NaN where the table has no sample.
    #[getter]
    fn values<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let t = &self.inner;
        let n = t.cells();
        let v = py.detach(|| {
            let mut v = vec![f64::NAN; 3 * n];
            for x in 0..n {
                if let Some(c) = t.get_flat(x) {
                    (v[x], v[n + x], v[2 * n + x]) = (c[0], c[1], c[2]);
                }
            }
            v
        });
        let (a, b, c) = self.dims();
        Ok(PyArray1::from_vec(py, v).reshape([3, a, b, c])?.into_any())
    }

    /// True where the table has a sample: a (nθh, nθd, nφd) bool array.
    #[getter]
    fn valid_mask<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let (a, b, c) = self.dims();
        Ok(PyArray1::from_slice(py, self.inner.valid_mask())
            .reshape([a, b, c])?
            .into_any())
    }

    /// f_r at each pair (wi[k], wo[k]): (N, 3) float64 arrays in, (N, 3) out, NaN
    /// where there is no sample (below the horizon or a missing cell).
    #[pyo3(signature = (wi, wo, interp = "nearest"))]
    fn lookup<'py>(
        &self,
        py: Python<'py>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
        interp: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mode = lookup_mode(interp)?;
        let (wi, wo) = (directions(wi, "wi")?, directions(wo, "wo")?);
        let (wi, wo) = (rows3(&wi)?, rows3(&wo)?);
        let mut out = vec![0.0; 3 * wi.len()];
        py.detach(|| {
            let (rows, _) = out.as_chunks_mut::<3>();
            self.inner.lookup_split(mode, wi, wo, rows)
        })
        .map_err(errors::input)?;
        rows_array(py, out)
    }

    fn __repr__(&self) -> String {
        let (a, b, c) = self.dims();
        let src = self.path.as_ref().map_or_else(String::new, |p| {
            format!(", path={:?}", p.display().to_string())
        });
        format!(
            "MerlTable(dims=({a}, {b}, {c}), valid={:.2}%{src})",
            100.0 * self.inner.valid_fraction()
        )
    }
}

/// Seconds the library's batch lookup takes on these pairs, timed inside Rust (no
/// argument conversion, no output array): what `MerlTable.lookup`'s binding overhead is
/// measured against (bench/bench_python.py).
#[pyfunction(name = "_lookup_seconds")]
pub fn lookup_seconds(
    py: Python<'_>,
    table: &Bound<'_, PyTable>,
    wi: &Bound<'_, PyAny>,
    wo: &Bound<'_, PyAny>,
    interp: &str,
) -> PyResult<f64> {
    let mode = lookup_mode(interp)?;
    let (wi, wo) = (directions(wi, "wi")?, directions(wo, "wo")?);
    let (wi, wo) = (rows3(&wi)?, rows3(&wo)?);
    let mut out = vec![[0.0; 3]; wi.len()];
    let t = table.get();
    py.detach(|| {
        let start = std::time::Instant::now();
        t.inner
            .lookup_split(mode, wi, wo, &mut out)
            .map(|()| start.elapsed().as_secs_f64())
    })
    .map_err(errors::input)
}
