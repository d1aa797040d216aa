//! `brdfkit._brdfkit`: the PyO3 extension module behind the `brdfkit` Python package.
//!
//! Thin glue over the library crates: every value comes from the Rust API
//! (`brdfkit_merl`, `brdfkit_models`, `brdfkit_fit`, `brdfkit_validate`,
//! `brdfkit_nbrdf`, `brdfkit_rgl`), so Python gets the same numbers, to the bit. Arrays cross as
//! NumPy arrays: any input NumPy converts to float64 is taken (one rule, the `arrays`
//! module), borrowed without a copy when it is C-contiguous float64 already, outputs are built in Rust and handed to NumPy
//! without a copy. The GIL is released around reads, writes, lookups, evaluations,
//! fits, checks and resampling. Errors are Python exceptions with the Rust messages
//! (see the `errors` module). The Python API, its stubs and docs are in `python/brdfkit`, the
//! guide in `docs/python.md`.

#![warn(missing_docs)]

mod arrays;
mod errors;
mod fit;
mod model;
mod rgl;
mod table;

use pyo3::prelude::*;
use pyo3::types::PyAnyMethods;

/// A serde JSON value as the Python object `json.loads` makes of it (dicts, lists,
/// floats: the shortest round-trip text, so every float crosses bit for bit).
pub(crate) fn json_to_py<'py>(
    py: Python<'py>,
    v: &serde_json::Value,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(errors::runtime)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// Writes `text` to `path` through the library's atomic writer (whole, or not at
/// all): how the Python layer saves what it writes (`FitResult.save`).
#[pyfunction(name = "_write_text")]
fn write_text(py: Python<'_>, path: std::path::PathBuf, text: &str) -> PyResult<()> {
    py.detach(|| brdfkit_core::atomic::write_bytes(&path, text.as_bytes()))
        .map_err(errors::runtime)
}

/// The extension module.
#[pymodule]
fn _brdfkit(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(write_text, m)?)?;
    m.add_class::<table::PyTable>()?;
    m.add_class::<model::PyModel>()?;
    m.add_class::<model::PyNbrdf>()?;
    m.add_class::<rgl::PyRglBsdf>()?;
    m.add_function(wrap_pyfunction!(fit::fit, m)?)?;
    m.add("FIT_DEFAULTS", fit::defaults_dict(m.py())?)?;
    m.add_function(wrap_pyfunction!(model::check, m)?)?;
    m.add_function(wrap_pyfunction!(model::resample, m)?)?;
    m.add_function(wrap_pyfunction!(table::lookup_seconds, m)?)?;
    Ok(())
}
