//! `brdfkit.Model` (an analytic model of `brdfkit_models`), `brdfkit.Nbrdf` (a neural
//! BRDF of `brdfkit_nbrdf`), `check` (`brdfkit_validate`) and `resample`.

use crate::arrays::{dims_of, eval_pairs};
use crate::table::{PyTable, lookup_mode};
use crate::{errors, json_to_py};
use brdfkit_core::{Model, Rgb};
use brdfkit_fit::families::FamilyError;
use brdfkit_merl::{Dims, MerlTable};
use brdfkit_nbrdf::Nbrdf;
use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::PyString;
use std::path::PathBuf;

/// An analytic BRDF model with its parameters, as the JSON contract
/// `{"model": "<name>", "params": {...}}` describes it.
#[pyclass(name = "Model", module = "brdfkit", frozen)]
pub struct PyModel {
    pub(crate) inner: Box<dyn Model>,
}

/// What `Model.from_json` says it takes, in its errors.
const FROM_JSON_TAKES: &str =
    "Model.from_json takes JSON text, a dict or the path of a model JSON file";

/// The JSON text of a description: a `str` that starts with `{` is the text itself,
/// any other `str` or an `os.PathLike` is the path of a model file (read here), and any
/// other object is given to `json.dumps` (a dict).
fn json_text(obj: &Bound<'_, PyAny>) -> PyResult<String> {
    let py = obj.py();
    let path: PathBuf = if let Ok(s) = obj.cast::<PyString>() {
        let s = s.to_string();
        if s.trim_start().starts_with('{') {
            return Ok(s);
        }
        PathBuf::from(s)
    } else if obj.is_instance(&py.import("os")?.getattr("PathLike")?)? {
        obj.extract()?
    } else {
        return py
            .import("json")?
            .call_method1("dumps", (obj,))
            .map_err(|e| errors::type_error(format!("{FROM_JSON_TAKES} ({})", e.value(py))))?
            .extract();
    };
    match std::fs::read_to_string(&path) {
        Ok(text) => Ok(text),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Err(errors::not_found(format!(
            "{}: no such model file ({FROM_JSON_TAKES}; JSON text starts with `{{`)",
            path.display()
        ))),
        Err(source) => Err(errors::input(FamilyError::Read { path, source })),
    }
}

impl PyModel {
    /// The compact JSON description, the identity of a model.
    fn text(&self) -> PyResult<String> {
        serde_json::to_string(&self.inner.to_json()).map_err(errors::runtime)
    }
}

#[pymethods]
impl PyModel {
    /// A model from its JSON description: the text (a `str` starting with `{`), the
    /// dict, or the path of a model JSON file (a `str` or `os.PathLike`).
    #[staticmethod]
    fn from_json(description: &Bound<'_, PyAny>) -> PyResult<Self> {
        let text = json_text(description)?;
        let inner = brdfkit_models::from_json_str(&text).map_err(errors::input)?;
        Ok(PyModel { inner })
    }

    /// Equal when the JSON descriptions are (the same model, choices and parameters,
    /// to the bit).
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        let py = other.py();
        Ok(match other.cast::<PyModel>() {
            Ok(o) => (self.text()? == o.get().text()?)
                .into_pyobject(py)?
                .to_owned()
                .into_any()
                .unbind(),
            Err(_) => py.NotImplemented(),
        })
    }

    /// The hash of the JSON description (equal models hash alike).
    fn __hash__(&self) -> PyResult<u64> {
        use std::hash::{Hash, Hasher};
        let mut h = std::collections::hash_map::DefaultHasher::new();
        self.text()?.hash(&mut h);
        Ok(h.finish())
    }

    /// The model `name` at its default start.
    #[staticmethod]
    fn default(name: &str) -> PyResult<Self> {
        let inner = brdfkit_models::default_model(name).map_err(errors::input)?;
        Ok(PyModel { inner })
    }

    /// The JSON description (the text `fit-brdf` reads and writes), compact or
    /// pretty-printed.
    #[pyo3(signature = (pretty = false))]
    fn to_json(&self, pretty: bool) -> PyResult<String> {
        let v = self.inner.to_json();
        let s = if pretty {
            serde_json::to_string_pretty(&v)
        } else {
            serde_json::to_string(&v)
        };
        s.map_err(errors::runtime)
    }

    /// The model's name (`cook-torrance`, ...).
    #[getter]
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    /// The `params` object of the JSON description, as a dict.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = self.inner.to_json();
        json_to_py(py, v.get("params").unwrap_or(&serde_json::Value::Null))
    }

    /// Names of the flat parameter vector (the fitter's view).
    #[getter]
    fn param_names(&self) -> Vec<String> {
        self.inner
            .param_specs()
            .into_iter()
            .map(|s| s.name)
            .collect()
    }

    /// The flat parameter vector, float64.
    #[getter]
    fn param_vector<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.params())
    }

    /// f_r (1/sr, no cosine) at each pair (wi[k], wo[k]): (N, 3) unit directions in (any
    /// array NumPy converts to float64; a (3,) direction is one row), (N, 3) float64
    /// out; 0 where either direction is below the horizon (z ≤ 0).
    fn eval<'py>(
        &self,
        py: Python<'py>,
        wi: &Bound<'py, PyAny>,
        wo: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        eval_pairs(py, wi, wo, |wi, wo, rows| {
            let mut rgb = vec![Rgb([0.0; 3]); wi.len()];
            brdfkit_models::raw::eval_dirs(&*self.inner, wi, wo, &mut rgb)
                .map_err(errors::input)?;
            rows.iter_mut().zip(&rgb).for_each(|(r, c)| *r = c.0);
            Ok(())
        })
    }

    fn __repr__(&self) -> String {
        let v = self.inner.to_json();
        let params = v.get("params").map_or_else(String::new, |p| p.to_string());
        format!("Model({}, params={params})", self.inner.name())
    }
}

/// A neural BRDF (Sztrajman et al. 2021): the six `.npy` weight files `DIR/NAME_*.npy`.
#[pyclass(name = "Nbrdf", module = "brdfkit", frozen)]
pub struct PyNbrdf {
    inner: Nbrdf,
}

#[pymethods]
impl PyNbrdf {
    /// Loads `DIR/NAME` (the stem of the six weight files).
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let inner = py.detach(|| Nbrdf::load(&path)).map_err(errors::nbrdf)?;
        Ok(PyNbrdf { inner })
    }

    /// The material's name.
    #[getter]
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn __repr__(&self) -> String {
        let (a, b) = self.inner.widths();
        format!("Nbrdf({:?}, hidden widths ({a}, {b}))", self.inner.name())
    }
}

/// The physical-check report of a model or a table (`fit-brdf check --json`), as a
/// dict.
#[pyfunction]
pub fn check<'py>(py: Python<'py>, source: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let report = if let Ok(m) = source.cast::<PyModel>() {
        let m = m.get();
        py.detach(|| serde_json::to_value(brdfkit_validate::check_model(&*m.inner)))
    } else if let Ok(t) = source.cast::<PyTable>() {
        let t = t.get();
        py.detach(|| serde_json::to_value(brdfkit_validate::check_table(&t.inner)))
    } else {
        return Err(errors::value(
            "check: expected a brdfkit.Model or a brdfkit.MerlTable",
        ));
    };
    json_to_py(py, &report.map_err(errors::runtime)?)
}

/// A table on the grid `dims` (any sequence of three sizes; default the MERL grid)
/// from a model (evaluated at each cell), a table (resampled with `interp`) or a
/// neural BRDF, as `fit-brdf resample` makes it.
#[pyfunction]
#[pyo3(
    signature = (source, dims = None, interp = "nearest"),
    text_signature = "(source, dims=(90, 90, 180), interp='nearest')"
)]
pub fn resample(
    py: Python<'_>,
    source: &Bound<'_, PyAny>,
    dims: Option<&Bound<'_, PyAny>>,
    interp: &str,
) -> PyResult<PyTable> {
    let dims = match dims {
        Some(d) => dims_of(d)?,
        None => Dims::MERL,
    };
    let mode = lookup_mode(interp)?;
    let table = if let Ok(m) = source.cast::<PyModel>() {
        let m = m.get();
        py.detach(|| MerlTable::from_brdf(&*m.inner, dims))
            .map_err(errors::runtime)?
    } else if let Ok(t) = source.cast::<PyTable>() {
        let t = t.get();
        py.detach(|| t.inner.resample(dims, mode))
    } else if let Ok(n) = source.cast::<PyNbrdf>() {
        let n = n.get();
        py.detach(|| n.inner.to_table(dims))
            .map_err(errors::runtime)?
            .0
    } else {
        return Err(errors::value(
            "resample: expected a brdfkit.Model, a brdfkit.MerlTable or a brdfkit.Nbrdf",
        ));
    };
    Ok(PyTable::new(table))
}
