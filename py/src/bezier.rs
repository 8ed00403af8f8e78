//! Bindings of the `bezier` crate (Queen Elizabeth's School 2022): curves of any degree, splines through waypoints,
//! the sigmoid motion profile, time-parametrised trajectories, the paper's jerk and curvature
//! costs and the direct optimiser, with numpy arrays in and out.
//!
//! | Python (`ddpkit.bezier`) | Rust (`bezier`) |
//! |---|---|
//! | `Bezier` | [`CubicBez`] (4 control points) or [`BezierDyn`] (any other number) |
//! | `Spline` | [`Spline`] |
//! | `SigmoidProfile` | [`SigmoidProfile`] |
//! | `Trajectory`, `TrajectorySamples` | [`Trajectory`], [`TrajectorySample`] |
//! | `spline_cost`, `optimize_spline`, `SplineOptimizeResult` | [`SplineCost`], [`optimize_spline`](::bezier::optimize_spline), [`OptimizeReport`] |
//! | `arclen_batch` | [`ParamCurveArclen::arclen`] over many curves in one call |
//!
//! The classes are registered at the top level of `ddpkit._ddpkit` (so that the single stub file
//! `_ddpkit.pyi` describes them and `mypy.stubtest` checks them); the public namespace is the
//! Python module `ddpkit.bezier`.
//!
//! Vectorised methods take the parameter as a Python number (and return a number, or a `(2,)`
//! array for a point) or as anything `numpy.asarray` turns into a float array of any shape `S`
//! (and return shape `S`, or `S + (2,)` for points), looping in Rust with the GIL released.
//! Every error is an exception of the `ddpkit.DdpError` tree naming the argument; NaN and
//! infinite inputs are rejected, never propagated.

use ::bezier::{
    curvature_from, optimize_spline as bz_optimize_spline, BezierDyn, Continuity, CubicBez, Error as BzError,
    JerkMeasure, OptimizeReport, OptimizeSettings, OptimizeStatus, ParamCurve, ParamCurveArclen, ParamCurveCurvature,
    ParamCurveDeriv, ParamCurveExtrema, Point, Rect, SigmoidProfile, Spline, SplineCost, Trajectory, TrajectorySample,
    Vec2, DEFAULT_ACCURACY,
};
use ddp_core::Error as DdpError;
use ddpkit_util::check::{self, CheckError, Requirement};
use numpy::ndarray::{Array1, ArrayD, IxDyn};
use numpy::{IntoPyArray, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyFloat, PyInt};

use crate::convert::{check_allocation, internal, rows_to_numpy, shape_str, stack_to_numpy, vec_to_numpy, Arr};
use crate::errors::{invalid, shape, CoreError, CoreResult};

// ------------------------------------------------------------------------------------------------
// Errors and argument conversion
// ------------------------------------------------------------------------------------------------

/// A `bezier` error as a ddpkit error (so it becomes the matching `DdpError` subclass).
fn be(e: BzError) -> CoreError {
    match e {
        BzError::NonFinite { field, index } => CoreError(DdpError::NotFinite {
            field: field.to_string(),
            index,
            value: f64::NAN,
        }),
        BzError::TooFew { field, got, need } => shape(field, format!("{got} elements"), format!("at least {need}")),
        BzError::InvalidParameter { field, value, reason } => invalid(field, format!("got {value}: {reason}")),
        BzError::Discontinuous { field, index, gap } => invalid(
            format!("{field}[{index}]"),
            format!("does not start where the previous segment ends (gap {gap:e})"),
        ),
        #[allow(unreachable_patterns)]
        other => invalid("bezier", other.to_string()),
    }
}

/// A failed scalar check as a ddpkit error: NaN and infinities are `NotFinite`, finite values
/// out of range `Invalid` (`must be > 0, got -1`).
fn checked(e: CheckError) -> CoreError {
    if !e.value.is_finite() {
        return CoreError(DdpError::NotFinite {
            field: e.field,
            index: 0,
            value: e.value,
        });
    }
    let bound = match e.requirement {
        Requirement::Positive => "> 0",
        Requirement::Nonnegative => ">= 0",
        Requirement::Finite => unreachable!("a finite value passes the finiteness check"),
    };
    invalid(e.field, format!("must be {bound}, got {}", e.value))
}

/// Rejects NaN and infinities in a scalar argument.
fn finite(field: &str, v: f64) -> CoreResult<f64> {
    check::finite(field, v).map_err(checked)
}

/// A finite, strictly positive scalar.
fn positive(field: &str, v: f64) -> CoreResult<f64> {
    check::positive(field, v).map_err(checked)
}

/// A finite, non-negative scalar.
fn nonnegative(field: &str, v: f64) -> CoreResult<f64> {
    check::nonnegative(field, v).map_err(checked)
}

/// An accuracy: finite and > 0.
fn accuracy_arg(v: f64) -> CoreResult<f64> {
    positive("accuracy", v)
}

/// A count given as a Python int (negative values are an `InvalidInputError`, not an
/// `OverflowError`), at least `min`.
fn count(field: &str, v: i64, min: usize) -> CoreResult<usize> {
    usize::try_from(v)
        .ok()
        .filter(|&n| n >= min)
        .ok_or_else(|| invalid(field, format!("must be an integer >= {min}, got {v}")))
}

/// Most control points of one `Bezier`: the Bernstein form's binomial coefficients overflow
/// `f64` a little above degree 1000 (NaN results), and such degrees are meaningless anyway.
const MAX_CONTROL_POINTS: usize = 1000;

/// An `(n, 2)` array of finite points with `n >= min`.
fn points_arg(obj: &Bound<'_, PyAny>, field: &str, min: usize) -> PyResult<Vec<Point>> {
    let a = to_arr(obj, field)?;
    if a.shape.len() != 2 || a.shape[1] != 2 || a.shape[0] < min {
        return Err(shape(field, shape_str(&a.shape), format!("(n, 2) with n >= {min}")).into());
    }
    Ok(to_points(&a.finite(field)?.data))
}

/// Control points of one curve: `(n, 2)`, `1 <= n <= MAX_CONTROL_POINTS`, finite.
fn control_points_arg(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Vec<Point>> {
    let a = to_arr(obj, field)?;
    if a.shape.len() != 2 || a.shape[1] != 2 || a.shape[0] < 1 || a.shape[0] > MAX_CONTROL_POINTS {
        return Err(shape(
            field,
            shape_str(&a.shape),
            format!("(n, 2) with 1 <= n <= {MAX_CONTROL_POINTS}"),
        )
        .into());
    }
    Ok(to_points(&a.finite(field)?.data))
}

fn to_points(data: &[f64]) -> Vec<Point> {
    data.chunks_exact(2).map(|c| Point::new(c[0], c[1])).collect()
}

/// A finite 2-vector.
fn vec2_arg(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Vec2> {
    let a = to_arr(obj, field)?;
    a.expect_shape(field, &[2])?;
    let a = a.finite(field)?;
    Ok(Vec2::new(a.data[0], a.data[1]))
}

static ASARRAY: PyOnceLock<Py<PyAny>> = PyOnceLock::new();

/// Copies `obj` through `numpy.asarray(obj, dtype=float64, order="C")` into an [`Arr`] (a
/// `memcpy` of the buffer: large batches stay cheap). Like `convert::to_arr`: anything numpy
/// cannot turn into float64 is an `InvalidInputError` naming `field`.
fn to_arr(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Arr> {
    // Fast path: a float64 C-contiguous array needs no call into numpy. (`as_slice` accepts
    // Fortran order too, whose buffer is not in the row-major order `Arr` holds.)
    if let Ok(array) = obj.cast::<PyArrayDyn<f64>>() {
        if !array.is_c_contiguous() {
            // Fall through to numpy.asarray(order="C").
        } else if let Ok(view) = array.try_readonly() {
            if let Ok(s) = view.as_slice() {
                return Ok(Arr {
                    shape: view.shape().to_vec(),
                    data: s.to_vec(),
                });
            }
        }
    }
    let py = obj.py();
    let asarray = ASARRAY.get_or_try_init(py, || -> PyResult<Py<PyAny>> {
        Ok(py.import("numpy")?.getattr("asarray")?.unbind())
    })?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    kwargs.set_item("order", "C")?;
    let converted = asarray.bind(py).call((obj,), Some(&kwargs)).map_err(|e| {
        invalid(
            field,
            format!("cannot be converted to a float64 array: {}", e.value(py)),
        )
    })?;
    let array = converted.cast::<PyArrayDyn<f64>>()?;
    let view = array.readonly();
    let data = match view.as_slice() {
        Ok(s) => s.to_vec(),
        Err(_) => view.as_array().iter().copied().collect(),
    };
    Ok(Arr {
        shape: view.shape().to_vec(),
        data,
    })
}

/// A curve parameter (or time, or distance): a Python number, or an array of any shape.
enum Params {
    Scalar(f64),
    Array(Arr),
}

impl Params {
    fn values(&self) -> &[f64] {
        match self {
            Params::Scalar(v) => std::slice::from_ref(v),
            Params::Array(a) => &a.data,
        }
    }
}

fn params_arg(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Params> {
    if obj.is_instance_of::<PyFloat>() || obj.is_instance_of::<PyInt>() {
        let v: f64 = obj
            .extract()
            .map_err(|e| invalid(field, format!("cannot be converted to a float: {e}")))?;
        return Ok(Params::Scalar(finite(field, v)?));
    }
    Ok(Params::Array(to_arr(obj, field)?.finite(field)?))
}

/// A 1-D sequence of values (a scalar counts as one).
fn values_1d(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Vec<f64>> {
    match params_arg(obj, field)? {
        Params::Scalar(v) => Ok(vec![v]),
        Params::Array(a) if a.shape.len() <= 1 => Ok(a.data),
        Params::Array(a) => Err(shape(field, shape_str(&a.shape), "a scalar or (n,)").into()),
    }
}

/// A C-ordered array of any shape.
fn nd(py: Python<'_>, shape: Vec<usize>, data: Vec<f64>) -> PyResult<Bound<'_, PyAny>> {
    let a = ArrayD::from_shape_vec(IxDyn(&shape), data).map_err(|e| internal(e.to_string()))?;
    Ok(a.into_pyarray(py).into_any())
}

/// `f` at every parameter: a `(2,)` array for a scalar, shape `S + (2,)` for an array of shape `S`.
fn map_points<'py, F>(py: Python<'py>, p: &Params, f: F) -> PyResult<Bound<'py, PyAny>>
where
    F: Fn(f64) -> [f64; 2] + Sync,
{
    match p {
        Params::Scalar(t) => Ok(vec_to_numpy(py, f(*t).to_vec())),
        Params::Array(a) => {
            let out: Vec<f64> = py.detach(|| a.data.iter().flat_map(|&t| f(t)).collect());
            let mut s = a.shape.clone();
            s.push(2);
            nd(py, s, out)
        }
    }
}

/// `f` at every parameter: a float for a scalar, an array of the same shape for an array.
fn map_scalars<'py, F>(py: Python<'py>, p: &Params, f: F) -> PyResult<Bound<'py, PyAny>>
where
    F: Fn(f64) -> f64 + Sync,
{
    match p {
        Params::Scalar(t) => Ok(PyFloat::new(py, f(*t)).into_any()),
        Params::Array(a) => {
            let out: Vec<f64> = py.detach(|| a.data.iter().map(|&t| f(t)).collect());
            nd(py, a.shape.clone(), out)
        }
    }
}

fn flat_points(points: &[Point]) -> Vec<f64> {
    points.iter().flat_map(|p| p.to_array()).collect()
}

fn rect_tuple(r: Rect) -> (f64, f64, f64, f64) {
    (r.x0, r.y0, r.x1, r.y1)
}

fn continuity_str(c: Continuity) -> &'static str {
    match c {
        Continuity::C0 => "C0",
        Continuity::C1 => "C1",
        Continuity::C2 => "C2",
    }
}

// ------------------------------------------------------------------------------------------------
// Bezier
// ------------------------------------------------------------------------------------------------

/// The curve behind a `Bezier`: cubics use the specialised type (closed-form hodograph roots,
/// a-priori Gauss-Legendre), every other degree the run-time-degree one.
#[derive(Clone, Debug)]
enum Curve {
    Cubic(CubicBez),
    Dyn(BezierDyn),
}

/// Runs `$e` with `$c` bound to the concrete curve.
macro_rules! on_curve {
    ($curve:expr, $c:ident => $e:expr) => {
        match $curve {
            Curve::Cubic($c) => $e,
            Curve::Dyn($c) => $e,
        }
    };
}

impl Curve {
    /// From finite control points (at least one).
    fn from_points(points: Vec<Point>) -> CoreResult<Curve> {
        match <[Point; 4]>::try_from(&points[..]) {
            Ok(p) => Ok(Curve::Cubic(CubicBez::from_points(p))),
            Err(_) => Ok(Curve::Dyn(BezierDyn::new(points).map_err(be)?)),
        }
    }

    fn points(&self) -> Vec<Point> {
        match self {
            Curve::Cubic(c) => c.points().to_vec(),
            Curve::Dyn(d) => d.points().to_vec(),
        }
    }

    fn to_dyn(&self) -> BezierDyn {
        match self {
            Curve::Cubic(c) => c.to_bezier().to_dyn(),
            Curve::Dyn(d) => d.clone(),
        }
    }

    /// The `order`-th derivative curve (hodograph of the hodograph ...), exact.
    fn nth_hodograph(&self, order: usize) -> BezierDyn {
        let mut h = self.to_dyn();
        for _ in 0..order {
            if h.points().len() == 1 {
                // The derivative of a constant is the zero point; further ones too.
                return h.deriv();
            }
            h = h.deriv();
        }
        h
    }
}

/// A Bézier curve of any degree on `t in [0, 1]` (De Casteljau / Bernstein form, as in Queen Elizabeth's School 2022).
#[pyclass(module = "ddpkit._ddpkit", name = "Bezier", frozen)]
#[derive(Clone, Debug)]
pub struct BezierCurve {
    curve: Curve,
}

impl BezierCurve {
    fn of(curve: Curve) -> BezierCurve {
        BezierCurve { curve }
    }

    fn wrap_dyn(d: BezierDyn) -> PyResult<BezierCurve> {
        Ok(BezierCurve::of(Curve::from_points(d.points().to_vec())?))
    }
}

#[pymethods]
impl BezierCurve {
    /// A curve from its control points, shape `(n, 2)`, `1 <= n <= 1000` (degree `n - 1`).
    #[new]
    fn new(points: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(BezierCurve::of(Curve::from_points(control_points_arg(
            points, "points",
        )?)?))
    }

    /// The control points, shape `(n, 2)`.
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let p = self.curve.points();
        rows_to_numpy(py, p.len(), 2, flat_points(&p))
    }

    /// The degree, `n - 1`.
    #[getter]
    fn degree(&self) -> usize {
        on_curve!(&self.curve, c => c.points().len() - 1)
    }

    /// `B(t)`: a `(2,)` array for a number `t`, shape `t.shape + (2,)` for an array.
    fn eval<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let p = params_arg(t, "t")?;
        match &self.curve {
            Curve::Cubic(c) => map_points(py, &p, |t| c.eval(t).to_array()),
            Curve::Dyn(d) => map_points(py, &p, |t| d.eval(t).to_array()),
        }
    }

    /// `B(t)` by De Casteljau's algorithm (repeated linear interpolation; slower, very stable).
    fn eval_de_casteljau<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let p = params_arg(t, "t")?;
        match &self.curve {
            Curve::Cubic(c) => map_points(py, &p, |t| c.eval_de_casteljau(t).to_array()),
            Curve::Dyn(d) => map_points(py, &p, |t| d.eval_de_casteljau(t).to_array()),
        }
    }

    /// The `order`-th derivative `d^order B / dt^order` at `t` (`order = 0` is `eval`).
    #[pyo3(signature = (t, order = 1))]
    fn derivative<'py>(
        &self,
        py: Python<'py>,
        t: &Bound<'py, PyAny>,
        #[pyo3(from_py_with = crate::convert::int_i64)] order: i64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let order = count("order", order, 0)?;
        let p = params_arg(t, "t")?;
        match (&self.curve, order) {
            (Curve::Cubic(c), 1) => map_points(py, &p, |t| c.velocity(t).to_array()),
            (Curve::Cubic(c), 2) => map_points(py, &p, |t| c.acceleration(t).to_array()),
            (Curve::Cubic(c), 3) => map_points(py, &p, |t| c.jerk(t).to_array()),
            _ => {
                let h = self.curve.nth_hodograph(order);
                map_points(py, &p, |t| h.eval(t).to_array())
            }
        }
    }

    /// `B'(t)` (same shapes as `eval`).
    fn velocity<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        self.derivative(py, t, 1)
    }

    /// `B''(t)` (same shapes as `eval`).
    fn acceleration<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        self.derivative(py, t, 2)
    }

    /// `B'''(t)` (same shapes as `eval`).
    fn jerk<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        self.derivative(py, t, 3)
    }

    /// Speed `|B'(t)|`: a float for a number `t`, an array of `t`'s shape otherwise.
    fn speed<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let p = params_arg(t, "t")?;
        match &self.curve {
            Curve::Cubic(c) => map_scalars(py, &p, |t| c.speed(t)),
            Curve::Dyn(_) => {
                let h = self.curve.nth_hodograph(1);
                map_scalars(py, &p, |t| h.eval(t).to_vec2().hypot())
            }
        }
    }

    /// Signed curvature `(x' y'' - y' x'') / (x'^2 + y'^2)^(3/2)` (the paper's `K(t)` without
    /// the absolute value; `0` where the speed vanishes).
    fn curvature<'py>(&self, py: Python<'py>, t: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let p = params_arg(t, "t")?;
        match &self.curve {
            Curve::Cubic(c) => map_scalars(py, &p, |t| c.curvature(t)),
            Curve::Dyn(_) => {
                let h1 = self.curve.nth_hodograph(1);
                let h2 = self.curve.nth_hodograph(2);
                map_scalars(py, &p, |t| curvature_from(h1.eval(t).to_vec2(), h2.eval(t).to_vec2()))
            }
        }
    }

    /// The derivative curve (hodograph), degree one less (a constant curve gives the zero point).
    fn hodograph(&self) -> PyResult<BezierCurve> {
        BezierCurve::wrap_dyn(self.curve.nth_hodograph(1))
    }

    /// Parameters in `(0, 1)`, ascending, where `x'(t) = 0` or `y'(t) = 0`.
    fn extrema<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, on_curve!(&self.curve, c => c.extrema()))
    }

    /// The exact axis-aligned bounding box `(x_min, y_min, x_max, y_max)`.
    fn bounding_box(&self) -> (f64, f64, f64, f64) {
        rect_tuple(on_curve!(&self.curve, c => c.bounding_box()))
    }

    /// Splits at `t` into the curves on `[0, t]` and `[t, 1]` (same degree).
    fn subdivide(&self, t: f64) -> PyResult<(BezierCurve, BezierCurve)> {
        let t = finite("t", t)?;
        Ok(match &self.curve {
            Curve::Cubic(c) => {
                let (a, b) = c.subdivide(t);
                (BezierCurve::of(Curve::Cubic(a)), BezierCurve::of(Curve::Cubic(b)))
            }
            Curve::Dyn(d) => {
                let (a, b) = d.subdivide(t);
                (BezierCurve::of(Curve::Dyn(a)), BezierCurve::of(Curve::Dyn(b)))
            }
        })
    }

    /// The part between `t0` and `t1`, reparametrised to `[0, 1]` (reversed when `t1 < t0`).
    fn subsegment(&self, t0: f64, t1: f64) -> PyResult<BezierCurve> {
        let (t0, t1) = (finite("t0", t0)?, finite("t1", t1)?);
        Ok(match &self.curve {
            Curve::Cubic(c) => BezierCurve::of(Curve::Cubic(c.subsegment(t0, t1))),
            Curve::Dyn(d) => BezierCurve::of(Curve::Dyn(d.subsegment(t0, t1))),
        })
    }

    /// Exact degree elevation: the same curve with one more control point (at most 1000).
    fn elevate(&self) -> PyResult<BezierCurve> {
        if self.curve.points().len() >= MAX_CONTROL_POINTS {
            return Err(invalid(
                "points",
                format!("elevation would exceed {MAX_CONTROL_POINTS} control points"),
            )
            .into());
        }
        BezierCurve::wrap_dyn(self.curve.to_dyn().elevate())
    }

    /// Arc length by adaptive Gauss-Legendre, absolute error at most `accuracy` (> 0).
    #[pyo3(signature = (accuracy = 1e-9))]
    fn arclen(&self, accuracy: f64) -> PyResult<f64> {
        let acc = accuracy_arg(accuracy)?;
        Ok(on_curve!(&self.curve, c => c.arclen(acc)))
    }

    /// Arc length by composite Simpson's rule as in the paper (intervals doubled until two
    /// estimates differ by less than `15 * accuracy`, at most `2^20` intervals).
    #[pyo3(signature = (accuracy = 1e-9))]
    fn arclen_simpson(&self, accuracy: f64) -> PyResult<f64> {
        let acc = accuracy_arg(accuracy)?;
        Ok(on_curve!(&self.curve, c => c.arclen_simpson(acc)))
    }

    /// Length between parameters `t0` and `t1` (negative when `t1 < t0`).
    #[pyo3(signature = (t0, t1, accuracy = 1e-9))]
    fn arclen_range(&self, t0: f64, t1: f64, accuracy: f64) -> PyResult<f64> {
        let (t0, t1, acc) = (finite("t0", t0)?, finite("t1", t1)?, accuracy_arg(accuracy)?);
        Ok(on_curve!(&self.curve, c => c.arclen_range(t0, t1, acc)))
    }

    /// The parameter `t(s)` at which the length from the start is `s` (clamped to
    /// `[0, arclen]`), to `accuracy` in length; vectorised over `s` like `speed`.
    #[pyo3(signature = (s, accuracy = 1e-9))]
    fn inv_arclen<'py>(&self, py: Python<'py>, s: &Bound<'py, PyAny>, accuracy: f64) -> PyResult<Bound<'py, PyAny>> {
        let acc = accuracy_arg(accuracy)?;
        let p = params_arg(s, "s")?;
        match &self.curve {
            Curve::Cubic(c) => {
                let e = c.arclen_engine();
                let total = e.arclen_range(0.0, 1.0, 0.25 * acc);
                map_scalars(py, &p, |s| e.inv_arclen(s, Some(total), acc))
            }
            Curve::Dyn(d) => map_scalars(py, &p, |s| d.inv_arclen(s, acc)),
        }
    }

    /// `n` parameters (ends included) splitting the curve into `n - 1` pieces of equal length.
    #[pyo3(signature = (n, accuracy = 1e-9))]
    fn resample_uniform<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = crate::convert::int_i64)] n: i64,
        accuracy: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (n, acc) = (count("n", n, 0)?, accuracy_arg(accuracy)?);
        check_allocation("n", n, 3 * std::mem::size_of::<f64>())?;
        let ts = py.detach(|| on_curve!(&self.curve, c => c.resample_uniform(n, acc)));
        Ok(vec_to_numpy(py, ts))
    }

    /// The points at `resample_uniform(n, accuracy)`, shape `(n, 2)`.
    #[pyo3(signature = (n, accuracy = 1e-9))]
    fn resample_points<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = crate::convert::int_i64)] n: i64,
        accuracy: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let (n, acc) = (count("n", n, 0)?, accuracy_arg(accuracy)?);
        check_allocation("n", n, 3 * std::mem::size_of::<Point>())?;
        let pts = py.detach(|| on_curve!(&self.curve, c => c.resample_points(n, acc)));
        rows_to_numpy(py, pts.len(), 2, flat_points(&pts))
    }

    fn __repr__(&self) -> String {
        let p = self.curve.points();
        let pts: Vec<String> = p.iter().map(|p| format!("({}, {})", p.x, p.y)).collect();
        format!("Bezier([{}])", pts.join(", "))
    }
}

/// Arc lengths of many curves with the same number of control points in one call:
/// `control_points` has shape `(m, n, 2)`; returns shape `(m,)`. `method` is `"gauss"`
/// (adaptive Gauss-Legendre) or `"simpson"`. The GIL is released.
#[pyfunction]
#[pyo3(signature = (control_points, accuracy = 1e-9, method = "gauss"))]
fn arclen_batch<'py>(
    py: Python<'py>,
    control_points: &Bound<'py, PyAny>,
    accuracy: f64,
    method: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let field = "control_points";
    let acc = accuracy_arg(accuracy)?;
    let simpson = match method {
        "gauss" => false,
        "simpson" => true,
        other => return Err(invalid("method", format!("must be \"gauss\" or \"simpson\", got {other:?}")).into()),
    };
    if !simpson {
        if let Some(lengths) = cubic_arclen_batch_in_place(py, control_points, field, acc)? {
            return Ok(lengths);
        }
    }
    let a = to_arr(control_points, field)?;
    if a.shape.len() != 3 || a.shape[1] < 1 || a.shape[1] > MAX_CONTROL_POINTS || a.shape[2] != 2 {
        return Err(shape(
            field,
            shape_str(&a.shape),
            format!("(m, n, 2) with 1 <= n <= {MAX_CONTROL_POINTS}"),
        )
        .into());
    }
    let a = a.finite(field)?;
    let n = a.shape[1];
    let out: Vec<f64> = py.detach(|| {
        let chunk = 2 * n;
        if n == 4 {
            a.data
                .chunks_exact(chunk)
                .map(|c| {
                    let cb = CubicBez::new((c[0], c[1]), (c[2], c[3]), (c[4], c[5]), (c[6], c[7]));
                    if simpson {
                        cb.arclen_simpson(acc)
                    } else {
                        cb.arclen(acc)
                    }
                })
                .collect()
        } else {
            a.data
                .chunks_exact(chunk)
                .map(|c| match BezierDyn::new(to_points(c)) {
                    Ok(d) if simpson => d.arclen_simpson(acc),
                    Ok(d) => d.arclen(acc),
                    Err(_) => f64::NAN, // unreachable: at least one finite point
                })
                .collect()
        }
    });
    Ok(vec_to_numpy(py, out))
}

/// The instructions the arc-length sums run with on this CPU: ``"avx512"``, ``"avx2+fma"`` or
/// ``"portable"`` (chosen at run time; the environment variable ``DDPKIT_SIMD=avx2`` or ``off``
/// narrows the choice). Results agree to an ulp or two across them.
#[pyfunction]
fn simd_level() -> &'static str {
    ::bezier::simd_level()
}

/// [`arclen_batch`]'s common case without copies: a C-contiguous float64 array of cubics
/// (shape `(m, 4, 2)`) is read where it lies, cubic by cubic, by [`CubicBez::arclen_batch`],
/// which writes the lengths straight into the new array. A batch then allocates nothing but its
/// result: fresh megabyte buffers cost a page fault every 4 KiB, as much as the arc lengths
/// themselves. `None` when `obj` is anything else (the general path converts it). The GIL is
/// released, as numpy does for its own loops over an array's buffer.
fn cubic_arclen_batch_in_place<'py>(
    py: Python<'py>,
    obj: &Bound<'py, PyAny>,
    field: &str,
    accuracy: f64,
) -> PyResult<Option<Bound<'py, PyAny>>> {
    let Ok(array) = obj.cast::<PyArrayDyn<f64>>() else {
        return Ok(None);
    };
    if !array.is_c_contiguous() || array.shape().len() != 3 || array.shape()[1..] != [4, 2] {
        return Ok(None);
    }
    let Ok(view) = array.try_readonly() else {
        return Ok(None);
    };
    let Ok(data) = view.as_slice() else {
        return Ok(None);
    };
    let m = array.shape()[0];
    let out = numpy::PyArray1::<f64>::zeros(py, m, false);
    {
        let mut rw = out.readwrite();
        let lengths = rw
            .as_slice_mut()
            .map_err(|e| internal(format!("new array not contiguous: {e}")))?;
        // One branch-free pass (it vectorises) decides finiteness; the error then names the
        // first non-finite value.
        let exponent = 0x7ff0_0000_0000_0000u64;
        let any_bad = data
            .iter()
            .fold(false, |bad, v| bad | (v.to_bits() & exponent == exponent));
        if any_bad {
            ddp_core::error::check_finite(field, data.iter()).map_err(CoreError)?;
        }
        py.detach(|| {
            let curves = data
                .chunks_exact(8)
                .map(|c| CubicBez::new((c[0], c[1]), (c[2], c[3]), (c[4], c[5]), (c[6], c[7])));
            CubicBez::arclen_batch(curves, accuracy, lengths)
        })
        .map_err(|e| internal(format!("arclen_batch: {e}")))?;
    }
    Ok(Some(out.into_any()))
}

// ------------------------------------------------------------------------------------------------
// Spline
// ------------------------------------------------------------------------------------------------

/// A chain of cubic Bézier segments through waypoints (segment `i` on the global parameter
/// `u in [i, i + 1]`).
#[pyclass(module = "ddpkit._ddpkit", name = "Spline", frozen)]
#[derive(Clone, Debug)]
pub struct BezierSpline {
    pub(crate) inner: Spline,
}

fn continuity_arg(s: &str) -> CoreResult<Continuity> {
    match s {
        "C1" | "c1" => Ok(Continuity::C1),
        "C2" | "c2" => Ok(Continuity::C2),
        other => Err(invalid(
            "continuity",
            format!("must be \"C1\" or \"C2\", got {other:?}"),
        )),
    }
}

#[pymethods]
impl BezierSpline {
    /// A spline from joined cubic segments, shape `(k, 4, 2)`, `k >= 1`; each segment must
    /// start where the previous ends (an `InvalidInputError` names `segments[i]` otherwise).
    #[new]
    fn new(segments: &Bound<'_, PyAny>) -> PyResult<Self> {
        let field = "segments";
        let a = to_arr(segments, field)?;
        if a.shape.len() != 3 || a.shape[0] < 1 || a.shape[1] != 4 || a.shape[2] != 2 {
            return Err(shape(field, shape_str(&a.shape), "(k, 4, 2) with k >= 1").into());
        }
        let pts = to_points(&a.finite(field)?.data);
        let segs = pts
            .chunks_exact(4)
            .map(|p| CubicBez::from_points([p[0], p[1], p[2], p[3]]))
            .collect();
        Ok(BezierSpline {
            inner: Spline::from_segments(segs).map_err(be)?,
        })
    }

    /// The uniform Catmull-Rom spline (C1) through `waypoints`, shape `(n, 2)`, `n >= 2`.
    #[staticmethod]
    fn catmull_rom(waypoints: &Bound<'_, PyAny>) -> PyResult<Self> {
        let w = points_arg(waypoints, "waypoints", 2)?;
        Ok(BezierSpline {
            inner: Spline::catmull_rom(&w).map_err(be)?,
        })
    }

    /// The natural C2 cubic spline (zero second derivative at both ends) through `waypoints`.
    #[staticmethod]
    fn c2_natural(waypoints: &Bound<'_, PyAny>) -> PyResult<Self> {
        let w = points_arg(waypoints, "waypoints", 2)?;
        Ok(BezierSpline {
            inner: Spline::c2_natural(&w).map_err(be)?,
        })
    }

    /// The clamped C2 cubic spline with end derivatives `start_tangent`, `end_tangent` (`(2,)`).
    #[staticmethod]
    fn c2_clamped(
        waypoints: &Bound<'_, PyAny>,
        start_tangent: &Bound<'_, PyAny>,
        end_tangent: &Bound<'_, PyAny>,
    ) -> PyResult<Self> {
        let w = points_arg(waypoints, "waypoints", 2)?;
        let d0 = vec2_arg(start_tangent, "start_tangent")?;
        let d1 = vec2_arg(end_tangent, "end_tangent")?;
        Ok(BezierSpline {
            inner: Spline::c2_clamped(&w, d0, d1).map_err(be)?,
        })
    }

    /// The C1 Hermite spline with derivative `tangents[i]` (global parameter) at `waypoints[i]`;
    /// both of shape `(n, 2)`. Segment `i` has control points
    /// `(w_i, w_i + d_i / 3, w_{i+1} - d_{i+1} / 3, w_{i+1})`.
    #[staticmethod]
    fn hermite(waypoints: &Bound<'_, PyAny>, tangents: &Bound<'_, PyAny>) -> PyResult<Self> {
        let w = points_arg(waypoints, "waypoints", 2)?;
        let a = to_arr(tangents, "tangents")?;
        a.expect_shape("tangents", &[w.len(), 2])?;
        let d: Vec<Vec2> = to_points(&a.finite("tangents")?.data)
            .into_iter()
            .map(Point::to_vec2)
            .collect();
        Ok(BezierSpline {
            inner: Spline::hermite(&w, &d).map_err(be)?,
        })
    }

    /// The segments' control points, shape `(k, 4, 2)`.
    #[getter]
    fn segments<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let s = self.inner.segments();
        let data = s.iter().flat_map(|c| flat_points(&c.points())).collect();
        stack_to_numpy(py, s.len(), 4, 2, data)
    }

    /// The joints, shape `(k + 1, 2)`.
    #[getter]
    fn waypoints<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let w = self.inner.waypoints();
        rows_to_numpy(py, w.len(), 2, flat_points(&w))
    }

    /// Derivatives at the joints (outgoing; the last segment's end derivative last), `(k + 1, 2)`.
    #[getter]
    fn tangents<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let d = self.inner.tangents();
        let data = d.iter().flat_map(|v| v.to_array()).collect();
        rows_to_numpy(py, d.len(), 2, data)
    }

    /// Number of segments.
    fn __len__(&self) -> usize {
        self.inner.len()
    }

    /// Segment `index` (negative indices count from the end) as a cubic `Bezier`.
    fn segment(&self, #[pyo3(from_py_with = crate::convert::int_i64)] index: i64) -> PyResult<BezierCurve> {
        let n = self.inner.len() as i64;
        let i = if index < 0 { index + n } else { index };
        if !(0..n).contains(&i) {
            return Err(invalid("index", format!("{index} is out of range for {n} segments")).into());
        }
        Ok(BezierCurve::of(Curve::Cubic(self.inner.segments()[i as usize])))
    }

    /// The point at global parameter `u in [0, k]` (clamped); shapes as `Bezier.eval`.
    fn eval<'py>(&self, py: Python<'py>, u: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let p = params_arg(u, "u")?;
        map_points(py, &p, |u| self.inner.eval(u).to_array())
    }

    /// Signed curvature at global parameter `u` (clamped); shapes as `Bezier.curvature`.
    fn curvature<'py>(&self, py: Python<'py>, u: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let p = params_arg(u, "u")?;
        map_scalars(py, &p, |u| {
            let (i, t) = self.inner.locate_param(u);
            self.inner.segments()[i].curvature(t)
        })
    }

    /// `"C0"`, `"C1"` or `"C2"`: the highest class holding at every joint, with derivative
    /// mismatches up to `tolerance * (1 + |derivative|)` accepted.
    #[pyo3(signature = (tolerance = 1e-9))]
    fn continuity(&self, tolerance: f64) -> PyResult<&'static str> {
        let tol = nonnegative("tolerance", tolerance)?;
        Ok(continuity_str(self.inner.continuity(tol)))
    }

    /// Length of each segment, shape `(k,)`.
    #[pyo3(signature = (accuracy = 1e-9))]
    fn segment_lengths<'py>(&self, py: Python<'py>, accuracy: f64) -> PyResult<Bound<'py, PyAny>> {
        let acc = accuracy_arg(accuracy)?;
        Ok(vec_to_numpy(py, self.inner.segment_lengths(acc)))
    }

    /// Total length, absolute error at most `accuracy`.
    #[pyo3(signature = (accuracy = 1e-9))]
    fn arclen(&self, accuracy: f64) -> PyResult<f64> {
        Ok(self.inner.arclen(accuracy_arg(accuracy)?))
    }

    /// The exact bounding box `(x_min, y_min, x_max, y_max)`.
    fn bounding_box(&self) -> (f64, f64, f64, f64) {
        rect_tuple(self.inner.bounding_box())
    }

    /// Parametric jerk `sum_i int_0^1 |B_i'''(t)|^2 dt` (unit time per segment; exact).
    fn jerk_cost_param(&self) -> f64 {
        self.inner.jerk_cost_param()
    }

    /// Sum of `|curvature|` at `samples_per_segment` parameters uniform in each segment's `t`.
    #[pyo3(signature = (samples_per_segment = 100))]
    fn curvature_sum_param(
        &self,
        #[pyo3(from_py_with = crate::convert::int_i64)] samples_per_segment: i64,
    ) -> PyResult<f64> {
        let m = count("samples_per_segment", samples_per_segment, 2)?;
        Ok(self.inner.curvature_sum_param(m))
    }

    fn __repr__(&self) -> String {
        format!("Spline(segments={})", self.inner.len())
    }
}

// ------------------------------------------------------------------------------------------------
// Motion profile and trajectory
// ------------------------------------------------------------------------------------------------

/// The paper's sigmoid distance-time profile `s(T) = L S(T / T_f)` with steepness `m` and
/// midpoint `k`.
#[pyclass(module = "ddpkit._ddpkit", name = "SigmoidProfile", frozen)]
#[derive(Clone, Debug)]
pub struct Profile {
    inner: SigmoidProfile,
}

#[pymethods]
impl Profile {
    /// A profile over `length` (>= 0) lasting `duration` (> 0 unless `length` is 0), with
    /// steepness `m >= 0` and midpoint `k` (fraction of the duration).
    #[new]
    #[pyo3(signature = (length, m, duration, k = 0.5))]
    fn new(length: f64, m: f64, duration: f64, k: f64) -> PyResult<Self> {
        Ok(Profile {
            inner: SigmoidProfile::new(length, m, k, duration).map_err(be)?,
        })
    }

    /// The shortest profile over `length` whose peak speed is `max_speed`.
    #[staticmethod]
    #[pyo3(signature = (length, m, max_speed = 1.0, k = 0.5))]
    fn with_max_speed(length: f64, m: f64, max_speed: f64, k: f64) -> PyResult<Self> {
        Ok(Profile {
            inner: SigmoidProfile::with_max_speed(length, m, k, max_speed).map_err(be)?,
        })
    }

    /// The largest `m` for which a profile over `length` lasting `duration` keeps its peak
    /// speed at or below `max_speed`.
    #[staticmethod]
    #[pyo3(signature = (length, duration, max_speed, k = 0.5))]
    fn max_steepness(length: f64, duration: f64, max_speed: f64, k: f64) -> PyResult<f64> {
        Ok(SigmoidProfile::max_steepness(length, k, duration, max_speed).map_err(be)?)
    }

    /// Path length `L`.
    #[getter]
    fn length(&self) -> f64 {
        self.inner.length()
    }

    /// Steepness `m`.
    #[getter]
    fn m(&self) -> f64 {
        self.inner.m()
    }

    /// Midpoint `k`.
    #[getter]
    fn k(&self) -> f64 {
        self.inner.k()
    }

    /// Duration `T_f`.
    #[getter]
    fn duration(&self) -> f64 {
        self.inner.duration()
    }

    /// Peak speed.
    #[getter]
    fn peak_speed(&self) -> f64 {
        self.inner.peak_speed()
    }

    /// Distance `s(T)` (held at 0 before the start and `L` after the end); vectorised.
    fn distance<'py>(&self, py: Python<'py>, time: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let p = params_arg(time, "time")?;
        map_scalars(py, &p, |t| self.inner.distance(t))
    }

    /// `(s, s', s'', s''')` at `time`: four floats for a number, four arrays of its shape otherwise.
    fn derivatives<'py>(&self, py: Python<'py>, time: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let p = params_arg(time, "time")?;
        let d: Vec<(f64, f64, f64, f64)> = p.values().iter().map(|&t| self.inner.derivatives(t)).collect();
        let cols: [Vec<f64>; 4] = [
            d.iter().map(|v| v.0).collect(),
            d.iter().map(|v| v.1).collect(),
            d.iter().map(|v| v.2).collect(),
            d.iter().map(|v| v.3).collect(),
        ];
        match &p {
            Params::Scalar(_) => Ok((cols[0][0], cols[1][0], cols[2][0], cols[3][0])
                .into_pyobject(py)?
                .into_any()),
            Params::Array(a) => {
                let [c0, c1, c2, c3] = cols;
                Ok((
                    nd(py, a.shape.clone(), c0)?,
                    nd(py, a.shape.clone(), c1)?,
                    nd(py, a.shape.clone(), c2)?,
                    nd(py, a.shape.clone(), c3)?,
                )
                    .into_pyobject(py)?
                    .into_any())
            }
        }
    }

    /// The time at which the distance is `s` (clamped to `[0, L]`); vectorised.
    fn time_at_distance<'py>(&self, py: Python<'py>, s: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let p = params_arg(s, "s")?;
        map_scalars(py, &p, |s| self.inner.time_at_distance(s))
    }

    fn __repr__(&self) -> String {
        format!(
            "SigmoidProfile(length={}, m={}, duration={}, k={})",
            self.inner.length(),
            self.inner.m(),
            self.inner.duration(),
            self.inner.k()
        )
    }
}

/// Time-parametrised samples of a `Trajectory` (one row per time).
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct TrajectorySamples {
    n: usize,
    time: Vec<f64>,
    distance: Vec<f64>,
    segment: Vec<i64>,
    t: Vec<f64>,
    position: Vec<f64>,
    velocity: Vec<f64>,
    acceleration: Vec<f64>,
    jerk: Vec<f64>,
    speed: Vec<f64>,
    tangential_acceleration: Vec<f64>,
    heading: Vec<f64>,
    curvature: Vec<f64>,
    yaw_rate: Vec<f64>,
}

impl TrajectorySamples {
    fn from_samples(s: &[TrajectorySample]) -> TrajectorySamples {
        let col = |f: &dyn Fn(&TrajectorySample) -> f64| s.iter().map(f).collect::<Vec<f64>>();
        let col2 = |f: &dyn Fn(&TrajectorySample) -> [f64; 2]| s.iter().flat_map(f).collect::<Vec<f64>>();
        TrajectorySamples {
            n: s.len(),
            time: col(&|p| p.time),
            distance: col(&|p| p.distance),
            segment: s.iter().map(|p| p.segment as i64).collect(),
            t: col(&|p| p.t),
            position: col2(&|p| p.position.to_array()),
            velocity: col2(&|p| p.velocity.to_array()),
            acceleration: col2(&|p| p.acceleration.to_array()),
            jerk: col2(&|p| p.jerk.to_array()),
            speed: col(&|p| p.speed),
            tangential_acceleration: col(&|p| p.tangential_acceleration),
            heading: col(&|p| p.heading),
            curvature: col(&|p| p.curvature),
            yaw_rate: col(&|p| p.yaw_rate),
        }
    }
}

#[pymethods]
impl TrajectorySamples {
    /// Number of samples.
    fn __len__(&self) -> usize {
        self.n
    }

    /// Times, shape `(n,)`.
    #[getter]
    fn time<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.time.clone())
    }

    /// Distance along the path, `(n,)`.
    #[getter]
    fn distance<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.distance.clone())
    }

    /// Segment index, `(n,)` int64.
    #[getter]
    fn segment<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        Array1::from_vec(self.segment.clone()).into_pyarray(py).into_any()
    }

    /// Local parameter in the segment, `(n,)`.
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.t.clone())
    }

    /// Position, `(n, 2)`.
    #[getter]
    fn position<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        rows_to_numpy(py, self.n, 2, self.position.clone())
    }

    /// Velocity (time derivative of the position), `(n, 2)`.
    #[getter]
    fn velocity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        rows_to_numpy(py, self.n, 2, self.velocity.clone())
    }

    /// Acceleration, `(n, 2)`.
    #[getter]
    fn acceleration<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        rows_to_numpy(py, self.n, 2, self.acceleration.clone())
    }

    /// Jerk (tangential and normal), `(n, 2)`.
    #[getter]
    fn jerk<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        rows_to_numpy(py, self.n, 2, self.jerk.clone())
    }

    /// Speed `s'`, `(n,)`.
    #[getter]
    fn speed<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.speed.clone())
    }

    /// Tangential acceleration `s''`, `(n,)`.
    #[getter]
    fn tangential_acceleration<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.tangential_acceleration.clone())
    }

    /// Heading (angle of the unit tangent), `(n,)`.
    #[getter]
    fn heading<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.heading.clone())
    }

    /// Signed curvature of the path, `(n,)`.
    #[getter]
    fn curvature<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.curvature.clone())
    }

    /// Yaw rate `curvature * speed`, `(n,)`.
    #[getter]
    fn yaw_rate<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.yaw_rate.clone())
    }

    fn __repr__(&self) -> String {
        format!("TrajectorySamples(n={})", self.n)
    }
}

/// A spline traversed with a sigmoid profile: position, velocity, acceleration, jerk, heading
/// and curvature at any time, and states/controls for the unicycle and car models.
#[pyclass(module = "ddpkit._ddpkit", name = "Trajectory", frozen)]
pub struct BezierTrajectory {
    inner: Trajectory,
}

/// `steps` given, or enough steps of `dt` to cover the duration.
fn steps_arg(traj: &Trajectory, dt: f64, steps: Option<i64>) -> CoreResult<usize> {
    let dt = positive("dt", dt)?;
    let n = match steps {
        Some(s) => count("steps", s, 0)?,
        None => {
            let n = (traj.duration() / dt).ceil();
            if n.is_nan() || n >= 1e12 {
                return Err(invalid(
                    "dt",
                    format!("{dt:e} needs more than 1e12 steps to cover the duration"),
                ));
            }
            n as usize
        }
    };
    check_allocation(
        "steps",
        n.saturating_add(1),
        std::mem::size_of::<TrajectorySample>() + 64,
    )?;
    Ok(n)
}

#[pymethods]
impl BezierTrajectory {
    /// The trajectory following `spline` with `profile` (whose `length` must equal the spline's).
    #[new]
    fn new(spline: &BezierSpline, profile: &Profile) -> PyResult<Self> {
        Ok(BezierTrajectory {
            inner: Trajectory::new(spline.inner.clone(), profile.inner).map_err(be)?,
        })
    }

    /// `spline` traversed with a sigmoid of steepness `m`, midpoint `k` and peak speed `max_speed`.
    #[staticmethod]
    #[pyo3(signature = (spline, m = 10.0, k = 0.5, max_speed = 1.0))]
    fn with_sigmoid(spline: &BezierSpline, m: f64, k: f64, max_speed: f64) -> PyResult<Self> {
        Ok(BezierTrajectory {
            inner: Trajectory::with_sigmoid(spline.inner.clone(), m, k, max_speed).map_err(be)?,
        })
    }

    /// The path.
    #[getter]
    fn spline(&self) -> BezierSpline {
        BezierSpline {
            inner: self.inner.spline().clone(),
        }
    }

    /// The motion profile.
    #[getter]
    fn profile(&self) -> Profile {
        Profile {
            inner: *self.inner.profile(),
        }
    }

    /// Duration `T_f`.
    #[getter]
    fn duration(&self) -> f64 {
        self.inner.duration()
    }

    /// Path length.
    #[getter]
    fn length(&self) -> f64 {
        self.inner.length()
    }

    /// Position at `time` (held at the ends outside `[0, T_f]`); shapes as `Bezier.eval`.
    fn position<'py>(&self, py: Python<'py>, time: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let p = params_arg(time, "time")?;
        map_points(py, &p, |t| self.inner.position_at(t).to_array())
    }

    /// Full kinematic state at each of `times` (a number or a 1-D array).
    fn sample(&self, py: Python<'_>, times: &Bound<'_, PyAny>) -> PyResult<TrajectorySamples> {
        let ts = values_1d(times, "times")?;
        let s: Vec<TrajectorySample> = py.detach(|| ts.iter().map(|&t| self.inner.sample(t)).collect());
        Ok(TrajectorySamples::from_samples(&s))
    }

    /// Samples at `T_k = k dt`, `k = 0..=steps` (default: enough steps to cover the duration),
    /// with the heading unwrapped (continuous).
    #[pyo3(signature = (dt, steps = None))]
    fn sample_grid(
        &self,
        py: Python<'_>,
        dt: f64,
        #[pyo3(from_py_with = crate::convert::opt_int_i64)] steps: Option<i64>,
    ) -> PyResult<TrajectorySamples> {
        let n = steps_arg(&self.inner, dt, steps)?;
        let s = py.detach(|| self.inner.sample_grid(dt, n)).map_err(be)?;
        Ok(TrajectorySamples::from_samples(&s))
    }

    /// Unicycle states `(x, y, theta)`, shape `(steps + 1, 3)`, and controls `(v, omega)`,
    /// shape `(steps, 2)`, on the grid `T_k = k dt` (for `ddpkit.Unicycle(dt)`).
    #[pyo3(signature = (dt, steps = None))]
    fn unicycle<'py>(
        &self,
        py: Python<'py>,
        dt: f64,
        #[pyo3(from_py_with = crate::convert::opt_int_i64)] steps: Option<i64>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let n = steps_arg(&self.inner, dt, steps)?;
        let (x, u) = py.detach(|| self.inner.unicycle(dt, n)).map_err(be)?;
        Ok((
            rows_to_numpy(py, x.len(), 3, x.concat())?,
            rows_to_numpy(py, u.len(), 2, u.concat())?,
        ))
    }

    /// Car states `(x, y, theta, v)`, shape `(steps + 1, 4)`, and controls `(omega, a)`,
    /// shape `(steps, 2)`, on the grid `T_k = k dt` (for `ddpkit.Car(dt)`).
    #[pyo3(signature = (dt, steps = None))]
    fn car<'py>(
        &self,
        py: Python<'py>,
        dt: f64,
        #[pyo3(from_py_with = crate::convert::opt_int_i64)] steps: Option<i64>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let n = steps_arg(&self.inner, dt, steps)?;
        let (x, u) = py.detach(|| self.inner.car(dt, n)).map_err(be)?;
        Ok((
            rows_to_numpy(py, x.len(), 4, x.concat())?,
            rows_to_numpy(py, u.len(), 2, u.concat())?,
        ))
    }

    /// The paper's discrete jerk cost (tangential speed at `samples` uniform times, jerk by
    /// second differences, `sum j_k^2 dT`).
    #[pyo3(signature = (samples = 100))]
    fn jerk_cost_discrete(
        &self,
        py: Python<'_>,
        #[pyo3(from_py_with = crate::convert::int_i64)] samples: i64,
    ) -> PyResult<f64> {
        let n = count("samples", samples, 0)?;
        check_allocation("samples", n, 3 * std::mem::size_of::<Point>())?;
        Ok(py.detach(|| self.inner.jerk_cost_discrete(n)))
    }

    /// `int_0^T_f |x'''(T)|^2 dT` of the full 2D jerk, to relative `accuracy`.
    #[pyo3(signature = (accuracy = 1e-8))]
    fn jerk_cost_integral(&self, py: Python<'_>, accuracy: f64) -> PyResult<f64> {
        let acc = accuracy_arg(accuracy)?;
        Ok(py.detach(|| self.inner.jerk_cost_integral(acc)))
    }

    /// The paper's curvature measure: `sum |curvature|` at `samples` uniform times.
    #[pyo3(signature = (samples = 100))]
    fn curvature_sum(
        &self,
        py: Python<'_>,
        #[pyo3(from_py_with = crate::convert::int_i64)] samples: i64,
    ) -> PyResult<f64> {
        let n = count("samples", samples, 0)?;
        Ok(py.detach(|| self.inner.curvature_sum(n)))
    }

    fn __repr__(&self) -> String {
        format!(
            "Trajectory(segments={}, length={}, duration={})",
            self.inner.spline().len(),
            self.inner.length(),
            self.inner.duration()
        )
    }
}

// ------------------------------------------------------------------------------------------------
// Costs and the direct optimiser
// ------------------------------------------------------------------------------------------------

/// A validated [`SplineCost`] from the keyword arguments (fields named as in Python).
fn cost_args(
    jerk_weight: f64,
    curvature_weight: f64,
    m: f64,
    k: f64,
    max_speed: f64,
    samples: i64,
    jerk: &str,
) -> CoreResult<SplineCost> {
    Ok(SplineCost {
        jerk_weight: nonnegative("jerk_weight", jerk_weight)?,
        curvature_weight: nonnegative("curvature_weight", curvature_weight)?,
        m: nonnegative("m", m)?,
        k: finite("k", k)?,
        max_speed: positive("max_speed", max_speed)?,
        samples: count("samples", samples, 4)?,
        jerk: match jerk {
            "integral" => JerkMeasure::Integral,
            "discrete" => JerkMeasure::Discrete,
            other => {
                return Err(invalid(
                    "jerk",
                    format!("must be \"integral\" or \"discrete\", got {other:?}"),
                ))
            }
        },
    })
}

/// The objective of Queen Elizabeth's School (2022) for `spline` traversed with a sigmoid profile:
/// `jerk_weight * J + curvature_weight * K`, with `J` the jerk (`"integral"`: the full 2D jerk
/// `int |x'''|^2 dT`; `"discrete"`: the paper's tangential second differences) and `K` the sum
/// of `|curvature|` at `samples` uniform times.
#[pyfunction]
#[pyo3(signature = (spline, *, jerk_weight = 1.0, curvature_weight = 0.01, m = 10.0, k = 0.5, max_speed = 1.0, samples = 100, jerk = "integral"))]
fn spline_cost(
    py: Python<'_>,
    spline: &BezierSpline,
    jerk_weight: f64,
    curvature_weight: f64,
    m: f64,
    k: f64,
    max_speed: f64,
    #[pyo3(from_py_with = crate::convert::int_i64)] samples: i64,
    jerk: &str,
) -> PyResult<f64> {
    let cost = cost_args(jerk_weight, curvature_weight, m, k, max_speed, samples, jerk)?;
    Ok(py.detach(|| cost.evaluate(&spline.inner)).map_err(be)?)
}

/// The result of `optimize_spline`.
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct SplineOptimizeResult {
    spline: Py<BezierSpline>,
    initial_cost: f64,
    cost: f64,
    iterations: usize,
    evaluations: usize,
    status: &'static str,
}

#[pymethods]
impl SplineOptimizeResult {
    /// The optimised spline (through the same waypoints).
    #[getter]
    fn spline(&self, py: Python<'_>) -> Py<BezierSpline> {
        self.spline.clone_ref(py)
    }

    /// Cost of the starting spline (Catmull-Rom for C1, natural for C2).
    #[getter]
    fn initial_cost(&self) -> f64 {
        self.initial_cost
    }

    /// Final cost.
    #[getter]
    fn cost(&self) -> f64 {
        self.cost
    }

    /// BFGS iterations.
    #[getter]
    fn iterations(&self) -> usize {
        self.iterations
    }

    /// Cost evaluations.
    #[getter]
    fn evaluations(&self) -> usize {
        self.evaluations
    }

    /// `"converged"`, `"max_iterations"` or `"line_search_failed"`.
    #[getter]
    fn status(&self) -> &'static str {
        self.status
    }

    fn __repr__(&self) -> String {
        format!(
            "SplineOptimizeResult(status={:?}, cost={}, initial_cost={}, iterations={})",
            self.status, self.cost, self.initial_cost, self.iterations
        )
    }
}

/// The direct optimiser: minimises `spline_cost` over the free tangents of a spline through
/// `waypoints` (C1: every tangent; C2: the two end tangents) by BFGS, starting from Catmull-Rom
/// (C1) or the natural spline (C2). The GIL is released.
#[pyfunction]
#[pyo3(signature = (waypoints, *, continuity = "C1", max_iterations = 100, gradient_tolerance = 1e-6, jerk_weight = 1.0, curvature_weight = 0.01, m = 10.0, k = 0.5, max_speed = 1.0, samples = 100, jerk = "integral"))]
fn optimize_spline(
    py: Python<'_>,
    waypoints: &Bound<'_, PyAny>,
    continuity: &str,
    #[pyo3(from_py_with = crate::convert::int_i64)] max_iterations: i64,
    gradient_tolerance: f64,
    jerk_weight: f64,
    curvature_weight: f64,
    m: f64,
    k: f64,
    max_speed: f64,
    #[pyo3(from_py_with = crate::convert::int_i64)] samples: i64,
    jerk: &str,
) -> PyResult<SplineOptimizeResult> {
    let w = points_arg(waypoints, "waypoints", 2)?;
    let settings = OptimizeSettings {
        continuity: continuity_arg(continuity)?,
        cost: cost_args(jerk_weight, curvature_weight, m, k, max_speed, samples, jerk)?,
        max_iterations: count("max_iterations", max_iterations, 0)?,
        gradient_tolerance: nonnegative("gradient_tolerance", gradient_tolerance)?,
    };
    let report: OptimizeReport = py.detach(|| bz_optimize_spline(&w, &settings)).map_err(be)?;
    Ok(SplineOptimizeResult {
        spline: Py::new(py, BezierSpline { inner: report.spline })?,
        initial_cost: report.initial_cost,
        cost: report.cost,
        iterations: report.iterations,
        evaluations: report.evaluations,
        status: match report.status {
            OptimizeStatus::Converged => "converged",
            OptimizeStatus::MaxIterations => "max_iterations",
            OptimizeStatus::LineSearchFailed => "line_search_failed",
            #[allow(unreachable_patterns)]
            _ => "unknown",
        },
    })
}

/// Registers the classes and functions in the extension module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<BezierCurve>()?;
    m.add_class::<BezierSpline>()?;
    m.add_class::<Profile>()?;
    m.add_class::<BezierTrajectory>()?;
    m.add_class::<TrajectorySamples>()?;
    m.add_class::<SplineOptimizeResult>()?;
    m.add_function(wrap_pyfunction!(arclen_batch, m)?)?;
    m.add_function(wrap_pyfunction!(simd_level, m)?)?;
    m.add_function(wrap_pyfunction!(spline_cost, m)?)?;
    m.add_function(wrap_pyfunction!(optimize_spline, m)?)?;
    m.add("BEZIER_DEFAULT_ACCURACY", DEFAULT_ACCURACY)?;
    Ok(())
}
