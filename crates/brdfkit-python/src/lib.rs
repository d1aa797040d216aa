//! `brdfkit._brdfkit`: the PyO3 extension module behind the `brdfkit` Python package.
//!
//! Thin glue over the library crates: every value comes from the Rust API
//! (`brdfkit_merl`, `brdfkit_models`, `brdfkit_fit`, `brdfkit_validate`,
//! `brdfkit_nbrdf`), so Python gets the same numbers, to the bit. Arrays cross as
//! NumPy arrays: inputs are borrowed without a copy when they are C-contiguous float64
//! (the Python layer makes them so), outputs are built in Rust and handed to NumPy
//! without a copy. The GIL is released around reads, writes, lookups, evaluations,
//! fits, checks and resampling. Errors are Python exceptions with the Rust messages
//! (see the `errors` module). The Python API, its stubs and docs are in `python/brdfkit`, the
//! guide in `docs/python.md`.

#![warn(missing_docs)]

mod errors;
mod fit;
mod model;
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

/// The extension module.
#[pymodule]
fn _brdfkit(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<table::PyTable>()?;
    m.add_class::<model::PyModel>()?;
    m.add_class::<model::PyNbrdf>()?;
    m.add_function(wrap_pyfunction!(fit::fit, m)?)?;
    m.add_function(wrap_pyfunction!(model::check, m)?)?;
    m.add_function(wrap_pyfunction!(model::resample, m)?)?;
    m.add_function(wrap_pyfunction!(table::lookup_seconds, m)?)?;
    Ok(())
}
