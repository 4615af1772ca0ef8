//! Core errors to Python exceptions, one arm per variant. The exception classes live in
//! `shieldnav/exceptions.py` (so that `InvalidArgumentError` is also a `ValueError`).

use pyo3::prelude::*;
use shieldnav_core::Error;

pyo3::import_exception!(shieldnav.exceptions, InvalidArgumentError);
pyo3::import_exception!(shieldnav.exceptions, SolverError);
pyo3::import_exception!(shieldnav.exceptions, MapFileError);

/// Maps a core error to its Python exception.
pub fn to_py(err: Error) -> PyErr {
    match err {
        Error::InvalidArgument { .. } | Error::DimensionMismatch { .. } | Error::UnknownPreset { .. } => {
            InvalidArgumentError::new_err(err.to_string())
        }
        Error::MapFile { .. } => MapFileError::new_err(err.to_string()),
        Error::Solver(_) => SolverError::new_err(err.to_string()),
    }
}

/// An `InvalidArgumentError` (a `ValueError`) about argument `name`.
pub fn invalid(name: &str, reason: impl std::fmt::Display) -> PyErr {
    InvalidArgumentError::new_err(format!("invalid `{name}`: {reason}"))
}
