//! Typed Rust errors as Python exceptions, with the Rust messages.
//!
//! An error with an `std::io::Error` anywhere in its cause chain is an `OSError` (the
//! subclass Python itself raises for that kind: `FileNotFoundError`,
//! `PermissionError`, `IsADirectoryError`), unless the I/O error says the bytes read
//! are wrong (`InvalidData`, `UnexpectedEof`: a malformed file, a `ValueError`); any
//! other error of the input (a malformed
//! table, an unknown model or parameter, a bad setting, mismatched arrays) is a
//! `ValueError`; a failure of the computation itself is a `RuntimeError`. The message
//! is the error's `Display` followed by each cause it does not already contain, as the
//! command line prints them.

use pyo3::PyErr;
use pyo3::exceptions::{
    PyFileNotFoundError, PyIsADirectoryError, PyOSError, PyPermissionError, PyRuntimeError,
    PyTypeError, PyValueError,
};
use std::error::Error;
use std::io::ErrorKind;

/// The message with its cause chain.
pub(crate) fn message(e: &(dyn Error + 'static)) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let t = c.to_string();
        if !s.contains(&t) {
            s.push_str(": ");
            s.push_str(&t);
        }
        cause = c.source();
    }
    s
}

/// The kind of the first I/O error in the chain, unless it is about the content read
/// (a malformed file is the caller's bad input, not a failure of the system).
fn io_kind(e: &(dyn Error + 'static)) -> Option<ErrorKind> {
    let mut cur = Some(e);
    while let Some(c) = cur {
        if let Some(io) = c.downcast_ref::<std::io::Error>() {
            return match io.kind() {
                ErrorKind::InvalidData | ErrorKind::UnexpectedEof => None,
                k => Some(k),
            };
        }
        cur = c.source();
    }
    None
}

/// The `OSError` subclass of an I/O error kind.
fn os_error(kind: ErrorKind, msg: String) -> PyErr {
    match kind {
        ErrorKind::NotFound => PyFileNotFoundError::new_err(msg),
        ErrorKind::PermissionDenied => PyPermissionError::new_err(msg),
        ErrorKind::IsADirectory => PyIsADirectoryError::new_err(msg),
        _ => PyOSError::new_err(msg),
    }
}

/// An error of the caller's input or files: `OSError` (by kind) or `ValueError`.
pub(crate) fn input<E: Error + 'static>(e: E) -> PyErr {
    let msg = message(&e);
    match io_kind(&e) {
        Some(kind) => os_error(kind, msg),
        None => PyValueError::new_err(msg),
    }
}

/// A table read or write error; a directory given for a table is `IsADirectoryError`.
pub(crate) fn merl(e: brdfkit_merl::MerlError) -> PyErr {
    if matches!(e, brdfkit_merl::MerlError::IsDirectory { .. }) {
        return PyIsADirectoryError::new_err(message(&e));
    }
    input(e)
}

/// A failure of the computation (not of its input): `RuntimeError`, or `OSError` when
/// an I/O error caused it.
pub(crate) fn runtime<E: Error + 'static>(e: E) -> PyErr {
    let msg = message(&e);
    match io_kind(&e) {
        Some(kind) => os_error(kind, msg),
        None => PyRuntimeError::new_err(msg),
    }
}

/// A `ValueError` with a message of the bindings' own (argument shapes and names).
pub(crate) fn value(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// A `TypeError`: an argument of a kind the call does not take.
pub(crate) fn type_error(msg: impl Into<String>) -> PyErr {
    PyTypeError::new_err(msg.into())
}

/// A missing input file: `FileNotFoundError` with the message.
pub(crate) fn not_found(msg: impl Into<String>) -> PyErr {
    PyFileNotFoundError::new_err(msg.into())
}

/// A neural BRDF's load error: a missing weight file is `FileNotFoundError` (the
/// library checks existence itself, so there is no I/O error in the chain).
pub(crate) fn nbrdf(e: brdfkit_nbrdf::NbrdfError) -> PyErr {
    if matches!(e, brdfkit_nbrdf::NbrdfError::Missing { .. }) {
        return not_found(message(&e));
    }
    input(e)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chain is appended only where the top message lacks it.
    #[test]
    fn message_appends_missing_causes_once() {
        let io = std::io::Error::new(ErrorKind::NotFound, "no such file");
        let e = brdfkit_merl::MerlError::Io {
            path: "t.binary".into(),
            action: "opening",
            source: io,
        };
        assert_eq!(message(&e), "t.binary: opening: no such file");
        assert_eq!(io_kind(&e), Some(ErrorKind::NotFound));
        let fam = brdfkit_fit::families::FamilyError::Read {
            path: "m.json".into(),
            source: std::io::Error::new(ErrorKind::PermissionDenied, "denied"),
        };
        assert_eq!(
            message(&fam),
            "m.json: cannot read the model description: denied"
        );
        assert_eq!(io_kind(&fam), Some(ErrorKind::PermissionDenied));
        let bad = brdfkit_core::ModelError::Invalid("unknown model `x`".into());
        assert_eq!(io_kind(&bad), None);
        // A malformed file is bad input (ValueError), not a failure of the system.
        let npy = brdfkit_nbrdf::NbrdfError::Npy(brdfkit_nbrdf::NpyError::Format {
            path: "w_fc1.npy".into(),
            source: std::io::Error::new(ErrorKind::InvalidData, "bad magic"),
        });
        assert_eq!(io_kind(&npy), None);
    }
}
