//! Pickling and equality shared by the classes: work must go to other processes and machines.
//!
//! A model, cost, constraint or problem pickles as the call that builds it again (its
//! constructor and arguments, `__reduce__` / `__getnewargs__`), so an unpickled object is checked
//! exactly as a new one and equals the original. Results (`Solution`, `SafeSolution`) pickle as
//! their fields. Equality compares those same arguments or fields, numpy arrays by value.

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

/// Whether `a` and `b` are equal values: numpy arrays by shape and entries (`numpy.array_equal`),
/// tuples, lists and dicts item by item, anything else by `==`.
pub fn equal_values(a: &Bound<'_, PyAny>, b: &Bound<'_, PyAny>) -> PyResult<bool> {
    let py = a.py();
    let is_array = |o: &Bound<'_, PyAny>| o.hasattr("__array_interface__").unwrap_or(false);
    if is_array(a) || is_array(b) {
        if !(is_array(a) && is_array(b)) {
            return Ok(false);
        }
        return py.import("numpy")?.call_method1("array_equal", (a, b))?.is_truthy();
    }
    if let (Ok(x), Ok(y)) = (a.cast::<PyTuple>(), b.cast::<PyTuple>()) {
        return seq_equal(x.iter(), y.iter(), x.len(), y.len());
    }
    if let (Ok(x), Ok(y)) = (a.cast::<PyList>(), b.cast::<PyList>()) {
        return seq_equal(x.iter(), y.iter(), x.len(), y.len());
    }
    if let (Ok(x), Ok(y)) = (a.cast::<PyDict>(), b.cast::<PyDict>()) {
        if x.len() != y.len() {
            return Ok(false);
        }
        for (k, v) in x.iter() {
            match y.get_item(&k)? {
                Some(w) if equal_values(&v, &w)? => {}
                _ => return Ok(false),
            }
        }
        return Ok(true);
    }
    // NaN equals NaN here (a solve that ended in a numerical error has a NaN cost).
    if let (Ok(x), Ok(y)) = (a.extract::<f64>(), b.extract::<f64>()) {
        if a.is_instance_of::<pyo3::types::PyFloat>()
            && b.is_instance_of::<pyo3::types::PyFloat>()
            && x.is_nan()
            && y.is_nan()
        {
            return Ok(true);
        }
    }
    a.eq(b)
}

fn seq_equal<'py>(
    a: impl Iterator<Item = Bound<'py, PyAny>>,
    b: impl Iterator<Item = Bound<'py, PyAny>>,
    na: usize,
    nb: usize,
) -> PyResult<bool> {
    if na != nb {
        return Ok(false);
    }
    for (x, y) in a.zip(b) {
        if !equal_values(&x, &y)? {
            return Ok(false);
        }
    }
    Ok(true)
}

/// Whether `a` and `b` have the same Python type and pickle to equal values (what
/// `__reduce_ex__(2)` returns: the constructor and its arguments).
pub fn reduce_equal(a: &Bound<'_, PyAny>, b: &Bound<'_, PyAny>) -> PyResult<bool> {
    if !a.get_type().is(b.get_type()) {
        return Ok(false);
    }
    let ra = a.call_method1("__reduce_ex__", (2,))?;
    let rb = b.call_method1("__reduce_ex__", (2,))?;
    equal_values(&ra, &rb)
}

/// `getattr(ddpkit._ddpkit, name)`: the classes and functions that rebuild pickled objects.
pub fn module_attr<'py>(py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
    py.import("ddpkit._ddpkit")?.getattr(name)
}

/// The iteration table of a result: the solver's report, or its text once unpickled.
pub enum Table {
    /// A DDP solve's report.
    Core(Box<ddp_core::Report>),
    /// A Safe-CDDP solve's report.
    Safe(Box<safe_cddp::Report>),
    /// The table as text (an unpickled result).
    Text(String),
}

impl Table {
    /// The table (deterministic: no timings).
    pub fn text(&self) -> String {
        match self {
            Table::Core(r) => r.table(),
            Table::Safe(r) => r.table(),
            Table::Text(t) => t.clone(),
        }
    }
}

/// Rebuilds a pickled `Solution`, `SafeSolution` or `Episode` (`kind`) from its fields.
#[pyfunction]
#[pyo3(name = "_unpickle_result")]
pub fn unpickle_result(py: Python<'_>, kind: &str, state: &Bound<'_, PyDict>) -> PyResult<Py<PyAny>> {
    match kind {
        "Solution" => Ok(Py::new(py, crate::solver::Solution::from_state(state)?)?.into_any()),
        "SafeSolution" => Ok(Py::new(py, crate::safe::SafeSolution::from_state(state)?)?.into_any()),
        "Episode" => Ok(Py::new(py, crate::safe::Episode::from_state(state)?)?.into_any()),
        other => Err(crate::errors::invalid(
            "kind",
            format!("must be 'Solution', 'SafeSolution' or 'Episode', got '{other}'"),
        )
        .into()),
    }
}

/// `state[key]`, or an error naming the missing field.
pub fn field<'py, T: pyo3::conversion::FromPyObjectOwned<'py>>(state: &Bound<'py, PyDict>, key: &str) -> PyResult<T> {
    match state.get_item(key)? {
        Some(v) => v.extract::<T>().map_err(|e| {
            let e: PyErr = e.into();
            crate::errors::invalid(format!("state['{key}']"), format!("has the wrong type: {e}")).into()
        }),
        None => Err(crate::errors::invalid(format!("state['{key}']"), "missing from the pickled fields").into()),
    }
}
