//! `brdfkit.RglBsdf`: an RGL-EPFL `.bsdf` measurement (`brdfkit_rgl::RglBsdf`).

use crate::arrays::{dims_of, eval_pairs};
use crate::errors;
use crate::table::PyTable;
use brdfkit_rgl::RglBsdf;
use pyo3::prelude::*;
use std::path::PathBuf;

/// Random pairs (above 5°) of the asymmetry figures in `info`: those of `fit-brdf info`.
const ASYMMETRY_PAIRS: usize = 200_000;

/// An RGL-EPFL `.bsdf` file (Dupuy & Jakob 2018), evaluated exactly as Mitsuba 3's
/// `measured` plugin evaluates it.
///
/// Open one with `RglBsdf.open(path)` (the file is told by its first bytes, whatever
/// its name); `eval(wi, wo)` is f_r in 1/sr without the cosine, linear RGB, 0 below the
/// horizon, negative stored values kept, the file's θi being `wi`; `info` is what
/// `fit-brdf info --json` reports; `resample(dims)` is the `MerlTable` that `fit-brdf
/// resample --bsdf` writes (the weighted mean of both orders of each pair, negatives as 0; docs/rgl.md).
#[pyclass(name = "RglBsdf", module = "brdfkit", frozen)]
pub struct PyRglBsdf {
    inner: RglBsdf,
    path: PathBuf,
}

#[pymethods]
impl PyRglBsdf {
    /// Reads and checks a `.bsdf` file: `FileNotFoundError` (and the other `OSError`s)
    /// for a file that cannot be read, `ValueError` naming the file and the field for a
    /// malformed one.
    #[staticmethod]
    fn open(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let inner = py.detach(|| RglBsdf::read(&path)).map_err(errors::input)?;
        Ok(PyRglBsdf { inner, path })
    }

    /// f_r at each pair (wi[k], wo[k]): (N, 3) unit directions in (anything NumPy
    /// converts to float64; a (3,) direction is one row), (N, 3) float64 out.
    fn eval<'py>(
        &self,
        py: Python<'py>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        eval_pairs(py, wi, wo, |wi, wo, rows| {
            self.inner.eval_split(wi, wo, rows);
            Ok(())
        })
    }

    /// What `fit-brdf info --json` reports: a dict (description, kind, grids, negative
    /// values, measured points, fields, and the asymmetry over 200,000 seeded pairs).
    #[getter]
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = py.detach(|| {
            let asym = self.inner.asymmetry(ASYMMETRY_PAIRS, 5.0, 1);
            self.inner.info_json(&asym)
        });
        crate::json_to_py(py, &v)
    }

    /// The file as a MERL table of `dims` (default the MERL grid, 90 × 90 × 180).
    #[pyo3(signature = (dims = None))]
    fn resample(&self, py: Python<'_>, dims: Option<&Bound<'_, PyAny>>) -> PyResult<PyTable> {
        let dims = match dims {
            Some(d) => dims_of(d)?,
            None => brdfkit_merl::Dims::MERL,
        };
        let (t, _) = py
            .detach(|| self.inner.to_table(dims))
            .map_err(errors::input)?;
        Ok(PyTable::new(t))
    }

    /// The file it was read from.
    #[getter]
    fn path(&self) -> PathBuf {
        self.path.clone()
    }

    fn __repr__(&self) -> String {
        let kind = match (self.inner.is_spectral(), self.inner.is_anisotropic()) {
            (false, false) => "RGB, isotropic",
            (false, true) => "RGB, anisotropic",
            (true, false) => "spectral, isotropic",
            (true, true) => "spectral, anisotropic",
        };
        format!(
            "RglBsdf({kind}, path={:?})",
            self.path.display().to_string()
        )
    }
}
