//! The package's exception: every failure of the pipelines, with the file and the problem.

use pyo3::PyErr;
use pyo3::create_exception;
use pyo3::exceptions::PyException;

create_exception!(
    neuroom,
    NeuroomError,
    PyException,
    "A neuroom pipeline failed: the message names the file and the problem."
);

/// A pipeline's error as the package's exception, with its whole chain of causes.
pub fn to_py(error: anyhow::Error) -> PyErr {
    NeuroomError::new_err(format!("{error:#}"))
}
