//! numpy <-> nalgebra conversions that check shapes and finiteness and name the field.
//!
//! Input goes through `numpy.asarray(obj, dtype=float64)`, so lists, tuples, scalars and arrays of
//! any real dtype are accepted; anything numpy cannot turn into float64 is an
//! `InvalidInputError`, a wrong shape a `ShapeError`, and NaN/inf a `NotFiniteError`.

use ddp_core::dims::{Allocator, DefaultAllocator, Dim, MatrixN, VectorN, U1};
use ddp_core::error::check_finite;
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyArrayDyn, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyDict;

use crate::errors::{invalid, shape, CoreError, CoreResult};

/// A dense float64 array copied out of Python: shape and data in C order.
#[derive(Debug, Clone, PartialEq)]
pub struct Arr {
    /// The numpy shape.
    pub shape: Vec<usize>,
    /// The entries in C (row-major) order.
    pub data: Vec<f64>,
}

/// `"(a, b)"` as numpy prints a shape.
pub fn shape_str(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", ")
        ),
    }
}

impl Arr {
    /// Rejects NaN/inf, naming `field` and the flat index.
    pub fn finite(self, field: &str) -> CoreResult<Self> {
        check_finite(field, self.data.iter())?;
        Ok(self)
    }

    /// Requires exactly `expected` as the shape.
    pub fn expect_shape(&self, field: &str, expected: &[usize]) -> CoreResult<()> {
        if self.shape != expected {
            return Err(shape(field, shape_str(&self.shape), shape_str(expected)));
        }
        Ok(())
    }

    /// A vector of `n` entries (shape `(n,)`), `n` a compile-time or run-time dimension.
    pub fn vector<N: Dim>(&self, field: &str, n: N) -> CoreResult<VectorN<N>>
    where
        DefaultAllocator: Allocator<N>,
    {
        self.expect_shape(field, &[n.value()])?;
        Ok(VectorN::from_row_slice_generic(n, U1, &self.data))
    }

    /// An `r x c` matrix (shape `(r, c)`).
    pub fn matrix<R: Dim, C: Dim>(&self, field: &str, r: R, c: C) -> CoreResult<MatrixN<R, C>>
    where
        DefaultAllocator: Allocator<R, C>,
    {
        self.expect_shape(field, &[r.value(), c.value()])?;
        Ok(MatrixN::from_row_slice_generic(r, c, &self.data))
    }

    /// The number of rows of a 2-D array.
    pub fn rows(&self) -> usize {
        self.shape.first().copied().unwrap_or(0)
    }
}

/// Most elements an array argument may hold (2^28 float64 values, 2 GiB).
pub const MAX_ELEMENTS: usize = 1 << 28;

static ASARRAY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();

/// Copies `obj` into an [`Arr`] through `numpy.asarray(obj, dtype=float64)`.
pub fn to_arr(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Arr> {
    let py = obj.py();
    let asarray = ASARRAY.get_or_try_init(py, || -> PyResult<Py<PyAny>> {
        Ok(py.import("numpy")?.getattr("asarray")?.unbind())
    })?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let converted = match asarray.bind(py).call((obj,), Some(&kwargs)) {
        Ok(a) => a,
        Err(e) => {
            return Err(invalid(
                field,
                format!("cannot be converted to a float64 array: {}", e.value(py)),
            )
            .into())
        }
    };
    let array = converted.cast::<PyArrayDyn<f64>>()?;
    let view = array.readonly();
    let view = view.as_array();
    // A broadcast view (`numpy.broadcast_to`) is float64 without memory behind it: check its
    // size before copying it, so that a huge one is an error rather than an allocation failure.
    if view.len() > MAX_ELEMENTS {
        return Err(invalid(
            field,
            format!(
                "has shape {} ({} elements), more than the {MAX_ELEMENTS} an argument may hold",
                shape_str(view.shape()),
                view.len()
            ),
        )
        .into());
    }
    Ok(Arr {
        shape: view.shape().to_vec(),
        data: view.iter().copied().collect(),
    })
}

/// A finite float array.
pub fn finite_arr(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Arr> {
    Ok(to_arr(obj, field)?.finite(field)?)
}

/// A finite scalar (a Python number or a 0-d / 1-element array).
pub fn finite_scalar(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<f64> {
    let a = to_arr(obj, field)?;
    if a.data.len() != 1 || a.shape.len() > 1 {
        return Err(shape(field, shape_str(&a.shape), "a scalar").into());
    }
    Ok(a.finite(field)?.data[0])
}

/// Copies a slice of vectors of `n` entries each into an `(len, n)` numpy array.
pub fn vectors_to_numpy<'py, N: Dim>(py: Python<'py>, v: &[VectorN<N>], n: usize) -> PyResult<Bound<'py, PyAny>>
where
    DefaultAllocator: Allocator<N>,
{
    rows_to_numpy(py, v.len(), n, flatten_vectors(v, n))
}

/// Vectors of `n` entries each, one after the other, in one buffer allocated once.
pub fn flatten_vectors<N: Dim>(v: &[VectorN<N>], n: usize) -> Vec<f64>
where
    DefaultAllocator: Allocator<N>,
{
    let mut out = Vec::with_capacity(v.len() * n);
    for x in v {
        out.extend(x.iter().copied());
    }
    out
}

/// Matrices, each in row-major order, one after the other, in one buffer allocated once.
pub fn flatten_matrices<R: Dim, C: Dim>(m: &[MatrixN<R, C>]) -> Vec<f64>
where
    DefaultAllocator: Allocator<R, C>,
{
    let mut out = Vec::with_capacity(m.len() * m.first().map_or(0, |a| a.len()));
    for a in m {
        push_row_major(&mut out, a);
    }
    out
}

/// A result array: its Rust data until Python first reads it, then that numpy array, which
/// every later read returns. A solve's results thus become numpy arrays only where they are
/// read (most callers read the states and controls only): each one made costs two Python
/// objects and an allocation of its buffer.
pub struct LazyArray {
    shape: [usize; 3],
    ndim: usize,
    data: Vec<f64>,
    array: PyOnceLock<Py<PyAny>>,
}

impl LazyArray {
    /// An array of `shape` (one to three axes) over C-ordered `data`.
    pub fn new(shape: &[usize], data: Vec<f64>) -> Self {
        debug_assert!((1..=3).contains(&shape.len()) && shape.iter().product::<usize>() == data.len());
        let mut s = [0; 3];
        s[..shape.len()].copy_from_slice(shape);
        Self {
            shape: s,
            ndim: shape.len(),
            data,
            array: PyOnceLock::new(),
        }
    }

    /// An array that already is a Python object (an unpickled result's).
    pub fn ready(py: Python<'_>, array: Py<PyAny>) -> Self {
        let cell = PyOnceLock::new();
        // (A new cell: setting it cannot fail.)
        let _ = cell.set(py, array);
        Self {
            shape: [0; 3],
            ndim: 0,
            data: Vec::new(),
            array: cell,
        }
    }

    /// The numpy array, made at the first call.
    pub fn get<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let array = self.array.get_or_try_init(py, || -> PyResult<Py<PyAny>> {
            let data = self.data.clone();
            let [a, b, c] = self.shape;
            Ok(match self.ndim {
                1 => vec_to_numpy(py, data),
                2 => rows_to_numpy(py, a, b, data)?,
                _ => stack_to_numpy(py, a, b, c, data)?,
            }
            .unbind())
        })?;
        Ok(array.bind(py).clone())
    }
}

/// An `(rows, cols)` array from C-ordered data.
pub fn rows_to_numpy(py: Python<'_>, rows: usize, cols: usize, data: Vec<f64>) -> PyResult<Bound<'_, PyAny>> {
    let a = Array2::from_shape_vec((rows, cols), data).map_err(|e| internal(e.to_string()))?;
    Ok(a.into_pyarray(py).into_any())
}

/// An `(n, rows, cols)` array from C-ordered data.
pub fn stack_to_numpy(
    py: Python<'_>,
    n: usize,
    rows: usize,
    cols: usize,
    data: Vec<f64>,
) -> PyResult<Bound<'_, PyAny>> {
    let a = Array3::from_shape_vec((n, rows, cols), data).map_err(|e| internal(e.to_string()))?;
    Ok(a.into_pyarray(py).into_any())
}

/// A 1-D array.
pub fn vec_to_numpy(py: Python<'_>, data: Vec<f64>) -> Bound<'_, PyAny> {
    Array1::from_vec(data).into_pyarray(py).into_any()
}

/// A vector as a 1-D array.
pub fn vector_to_numpy<'py, N: Dim>(py: Python<'py>, v: &VectorN<N>) -> Bound<'py, PyAny>
where
    DefaultAllocator: Allocator<N>,
{
    vec_to_numpy(py, v.iter().copied().collect())
}

/// A matrix as a 2-D array.
pub fn matrix_to_numpy<'py, R: Dim, C: Dim>(py: Python<'py>, m: &MatrixN<R, C>) -> PyResult<Bound<'py, PyAny>>
where
    DefaultAllocator: Allocator<R, C>,
{
    rows_to_numpy(py, m.nrows(), m.ncols(), row_major(m))
}

/// The entries of `m` in row-major order.
pub fn row_major<R: Dim, C: Dim>(m: &MatrixN<R, C>) -> Vec<f64>
where
    DefaultAllocator: Allocator<R, C>,
{
    let mut out = Vec::with_capacity(m.len());
    push_row_major(&mut out, m);
    out
}

/// Appends the entries of `m` in row-major order.
fn push_row_major<R: Dim, C: Dim>(out: &mut Vec<f64>, m: &MatrixN<R, C>)
where
    DefaultAllocator: Allocator<R, C>,
{
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            out.push(m[(i, j)]);
        }
    }
}

/// An error that only a bug can cause.
pub fn internal(msg: String) -> CoreError {
    invalid("internal", format!("{msg} (a ddpkit bug)"))
}

/// Checks that `count` items of `item_bytes` each could be allocated, so that an absurd horizon
/// is an error naming `field` instead of an allocation failure (which aborts the process).
pub fn check_allocation(field: &str, count: usize, item_bytes: usize) -> CoreResult<()> {
    let bytes = count.checked_mul(item_bytes.max(1));
    let mut probe: Vec<u8> = Vec::new();
    match bytes.map(|b| probe.try_reserve_exact(b)) {
        Some(Ok(())) => Ok(()),
        _ => Err(invalid(
            field,
            format!(
                "{count} knots need about {:.3e} bytes, which cannot be allocated",
                count as f64 * item_bytes as f64
            ),
        )),
    }
}

/// Integer arguments. pyo3's own conversion answers a Python int that does not fit the Rust type
/// of an argument (`-1` or `10**30` for a count) with Python's `OverflowError`; an argument
/// declared `#[pyo3(from_py_with = crate::convert::int_usize)]` (and the others below) answers it
/// with `ddpkit.InvalidInputError` (a `ValueError`) stating the range, and pyo3 adds the note
/// "while processing 'name'" that names the argument. Anything that is not an integer stays a
/// `TypeError`, as without the attribute.
fn int_arg<'py, T>(obj: &Bound<'py, PyAny>, type_name: &str, min: &str, max: &str) -> PyResult<T>
where
    T: for<'a> FromPyObject<'a, 'py, Error = PyErr>,
{
    match obj.extract::<T>() {
        Ok(v) => Ok(v),
        Err(e) if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(obj.py()) => {
            let got = obj.repr().map(|r| r.to_string()).unwrap_or_else(|_| "?".into());
            Err(invalid(
                "integer argument",
                format!("{got} does not fit a {type_name} (at least {min}, at most {max})"),
            )
            .into())
        }
        Err(e) => Err(e),
    }
}

macro_rules! int_args {
    ($($name:ident, $opt:ident: $t:ty;)*) => {$(
        #[doc = concat!("A `", stringify!($t), "` argument (see [`int_arg`]).")]
        pub fn $name(obj: &Bound<'_, PyAny>) -> PyResult<$t> {
            int_arg::<$t>(obj, stringify!($t), &<$t>::MIN.to_string(), &<$t>::MAX.to_string())
        }
        #[doc = concat!("An optional `", stringify!($t), "` argument: `None` or an integer (see [`int_arg`]).")]
        pub fn $opt(obj: &Bound<'_, PyAny>) -> PyResult<Option<$t>> {
            if obj.is_none() {
                Ok(None)
            } else {
                $name(obj).map(Some)
            }
        }
    )*};
}

int_args! {
    int_usize, opt_int_usize: usize;
    int_u64, opt_int_u64: u64;
    int_u8, opt_int_u8: u8;
    int_i64, opt_int_i64: i64;
}
