//! `brdfkit.MerlTable`: a MERL binary table (`brdfkit_merl::MerlTable`).

use crate::arrays::{check_pairs, directions, eval_pairs, float64, rows3, shape_text};
use crate::errors;
use brdfkit_core::Rgb;
use brdfkit_merl::{Dims, Lookup, MerlTable};
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
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

    /// A table from a (3, nθh, nθd, nφd) array of f_r in 1/sr (anything
    /// `numpy.asarray(values, dtype=float64)` takes); NaN marks a missing cell (in any
    /// channel: the whole cell).
    #[staticmethod]
    fn from_values(py: Python<'_>, values: &Bound<'_, PyAny>) -> PyResult<Self> {
        let values = float64(values, "values")?;
        let s = values.shape();
        let dims = match *s {
            [3, a, b, c] => Dims::new(a as i64, b as i64, c as i64)
                .map_err(|e| errors::value(format!("values: {e}")))?,
            _ => {
                return Err(errors::value(format!(
                    "values: shape {}, expected (3, n_theta_h, n_theta_d, n_phi_d)",
                    shape_text(s)
                )));
            }
        };
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

    /// f_r at each pair (wi[k], wo[k]): (N, 3) unit directions in (any array NumPy
    /// converts to float64; a (3,) direction is one row), (N, 3) float64 out, NaN where
    /// there is no sample (below the horizon or a missing cell).
    #[pyo3(signature = (wi, wo, interp = "nearest"))]
    fn lookup<'py>(
        &self,
        py: Python<'py>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
        interp: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let mode = lookup_mode(interp)?;
        eval_pairs(py, wi, wo, |wi, wo, rows| {
            self.inner
                .lookup_split(mode, wi, wo, rows)
                .map_err(errors::input)
        })
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
    check_pairs(wi, wo)?;
    py.detach(|| {
        let start = std::time::Instant::now();
        t.inner
            .lookup_split(mode, wi, wo, &mut out)
            .map(|()| start.elapsed().as_secs_f64())
    })
    .map_err(errors::input)
}
