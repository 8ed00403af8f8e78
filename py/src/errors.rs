//! The exception tree and the mapping from [`ddp_core::Error`].
//!
//! ```text
//! DdpError(Exception)
//! ├── ShapeError(DdpError, ValueError)        <- Error::Shape, unsupported (nx, nu)
//! ├── NotFiniteError(DdpError, ValueError)    <- Error::NotFinite
//! └── InvalidInputError(DdpError, ValueError) <- Error::Invalid, Error::NotPsd, Error::EmptyHorizon
//! ```
//!
//! Every exception carries the offending field in its `field` attribute (for example
//! `"running_cost.Q"` or `"x0"`); the message is the [`ddp_core::Error`] text.

use ddp_core::Error;
use pyo3::exceptions::{PyException, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

/// The Python module the exception classes claim to live in.
const MODULE: &str = "ddpkit._ddpkit";

static DDP_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static SHAPE_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static NOT_FINITE_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();
static INVALID_INPUT_ERROR: PyOnceLock<Py<PyType>> = PyOnceLock::new();

/// Creates `class name(*bases)` with a docstring, through `type(name, bases, dict)` so that a
/// class can have two bases (`DdpError` and `ValueError`).
fn make_type<'py>(py: Python<'py>, name: &str, doc: &str, bases: Bound<'py, PyTuple>) -> PyResult<Py<PyType>> {
    let dict = PyDict::new(py);
    dict.set_item("__doc__", doc)?;
    dict.set_item("__module__", MODULE)?;
    let ty = py.get_type::<PyType>().call1((name, bases, dict))?;
    Ok(ty.cast_into::<PyType>()?.unbind())
}

/// `ddpkit.DdpError`, the root of every ddpkit exception.
pub fn ddp_error(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    DDP_ERROR
        .get_or_try_init(py, || {
            let bases = PyTuple::new(py, [py.get_type::<PyException>()])?;
            make_type(
                py,
                "DdpError",
                "Base class of every ddpkit error. `field` names the offending input.",
                bases,
            )
        })
        .map(|t| t.bind(py))
}

fn value_subclass<'py>(
    py: Python<'py>,
    cell: &'static PyOnceLock<Py<PyType>>,
    name: &str,
    doc: &str,
) -> PyResult<&'py Bound<'py, PyType>> {
    cell.get_or_try_init(py, || {
        let bases = PyTuple::new(py, [ddp_error(py)?.clone(), py.get_type::<PyValueError>()])?;
        make_type(py, name, doc, bases)
    })
    .map(|t| t.bind(py))
}

/// `ddpkit.ShapeError`: an array has the wrong shape, or a list the wrong length.
pub fn shape_error(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    value_subclass(
        py,
        &SHAPE_ERROR,
        "ShapeError",
        "An array has the wrong shape or a list the wrong length.",
    )
}

/// `ddpkit.NotFiniteError`: a value is NaN or infinite.
pub fn not_finite_error(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    value_subclass(
        py,
        &NOT_FINITE_ERROR,
        "NotFiniteError",
        "A value that must be finite is NaN or infinite.",
    )
}

/// `ddpkit.InvalidInputError`: a value is out of range, of the wrong kind, or a weight is not PSD.
pub fn invalid_input_error(py: Python<'_>) -> PyResult<&Bound<'_, PyType>> {
    value_subclass(
        py,
        &INVALID_INPUT_ERROR,
        "InvalidInputError",
        "A value is outside its allowed range, of the wrong kind, or a weight matrix is not PSD.",
    )
}

/// A [`ddp_core::Error`] on its way to Python. Bindings return `Result<_, CoreError>` where the
/// error comes from ddp-core or from our own checks (written as ddp-core errors so every message
/// has the same form); `?` turns it into the right Python exception.
#[derive(Debug, Clone, PartialEq)]
pub struct CoreError(pub Error);

impl From<Error> for CoreError {
    fn from(e: Error) -> Self {
        CoreError(e)
    }
}

/// Renames ddp-core's lower-case weight names to the Python argument names.
fn python_name(field: &str) -> String {
    let (head, tail) = match field.find(['[', '.']) {
        Some(i) => field.split_at(i),
        None => (field, ""),
    };
    let head = match head {
        "q" => "Q",
        "r" => "R",
        "qf" => "Qf",
        "a" => "A",
        "b" => "B",
        other => other,
    };
    format!("{head}{tail}")
}

impl CoreError {
    /// The field the error names.
    pub fn field(&self) -> String {
        match &self.0 {
            Error::NotFinite { field, .. }
            | Error::Shape { field, .. }
            | Error::Invalid { field, .. }
            | Error::NotPsd { field, .. } => field.clone(),
            Error::EmptyHorizon => "horizon".to_string(),
            #[allow(unreachable_patterns)]
            _ => String::new(),
        }
    }

    /// Renames ddp-core's field (`q` -> `Q`, ...) and puts `prefix.` in front of it, so the
    /// message names the argument path the user wrote (`running_cost[3].Q`).
    pub fn context(mut self, prefix: &str) -> Self {
        let rename = |field: &mut String| {
            let f = python_name(field);
            *field = if prefix.is_empty() { f } else { format!("{prefix}.{f}") };
        };
        match &mut self.0 {
            Error::NotFinite { field, .. }
            | Error::Shape { field, .. }
            | Error::Invalid { field, .. }
            | Error::NotPsd { field, .. } => rename(field),
            _ => {}
        }
        self
    }
}

/// Result of binding code: a ddp-core-style error until it reaches Python.
pub type CoreResult<T> = std::result::Result<T, CoreError>;

/// Shorthand for an [`Error::Invalid`].
pub fn invalid(field: impl Into<String>, reason: impl Into<String>) -> CoreError {
    CoreError(Error::invalid(field, reason))
}

/// Shorthand for an [`Error::Shape`].
pub fn shape(field: impl Into<String>, got: impl Into<String>, expected: impl Into<String>) -> CoreError {
    CoreError(Error::Shape {
        field: field.into(),
        got: got.into(),
        expected: expected.into(),
    })
}

fn to_pyerr(py: Python<'_>, e: &CoreError) -> PyResult<PyErr> {
    let ty = match e.0 {
        Error::Shape { .. } => shape_error(py)?,
        Error::NotFinite { .. } => not_finite_error(py)?,
        _ => invalid_input_error(py)?,
    };
    let exc = ty.call1((e.0.to_string(),))?;
    exc.setattr("field", e.field())?;
    Ok(PyErr::from_value(exc))
}

impl From<CoreError> for PyErr {
    fn from(e: CoreError) -> PyErr {
        Python::attach(|py| to_pyerr(py, &e).unwrap_or_else(|err| err))
    }
}

/// Registers the exception classes in the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("DdpError", ddp_error(py)?)?;
    m.add("ShapeError", shape_error(py)?)?;
    m.add("NotFiniteError", not_finite_error(py)?)?;
    m.add("InvalidInputError", invalid_input_error(py)?)?;
    Ok(())
}
