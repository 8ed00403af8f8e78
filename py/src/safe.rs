//! Safe-CDDP in Python (crate `safe-cddp`): constraints, the constrained solver with
//! chance-constraint tightening, and the shrinking-horizon MPC loop of Algorithm 1.
//!
//! | Python | Rust |
//! |---|---|
//! | `Constraint`, `Circle`, `ConvexPolygon`, `Cylinder`, `StateBox`, `ControlBox` | `safe_cddp::constraints` |
//! | `Tightening` | `safe_cddp::Tightening` (eqs. 19-20) |
//! | `SafeCddpSolver`, `SafeSolution` | `safe_cddp::SafeCddpSolver`, `safe_cddp::Report` |
//! | `Mpc`, `Episode` | `safe_cddp::mpc::Mpc`, `safe_cddp::mpc::Episode` |
//!
//! Constraints are dimension-agnostic specifications (like the costs), checked against the
//! problem's `(nx, nu)` when a solver is built. Solves and episodes release the GIL.

use std::sync::{Arc, RwLock};

use ddp_core::dims::{Alloc, Const, DefaultAllocator, Dim, Dims, Dyn, VectorN};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyList, PyTuple};
use safe_cddp::constraints::{Circle as CoreCircle, ControlBox as CoreControlBox, ConvexPolygon as CorePolygon};
use safe_cddp::constraints::{Cylinder as CoreCylinder, StateBox as CoreStateBox};
use safe_cddp::mpc::{Mpc as CoreMpc, MpcSettings};
use safe_cddp::qp::QpMethod;
use safe_cddp::{
    Constraint as CoreConstraint, Gains, Report, SafeCddpSolver as CoreSolver, Settings, Tightening as CoreTightening,
    WarmUp,
};

use crate::convert::{finite_arr, flatten_matrices, flatten_vectors, rows_to_numpy, shape_str, Arr, LazyArray};
use crate::dims::{internal_mismatch, problem_of, AnyProblem, Dispatch, Pair};
use crate::errors::{invalid, shape, CoreResult};
use crate::models::type_name;
use crate::pickle::{field, Table};
use crate::problem::{controls, Problem};
use crate::solver::{method_name, parse_method};

// ------------------------------------------------------------------------------------------------
// Constraints

/// A constraint, independent of the dimensions until a solver is built.
#[derive(Debug, Clone, PartialEq)]
enum Spec {
    Circle {
        center: [f64; 2],
        radius: f64,
        indices: [usize; 2],
        distance: bool,
    },
    Polygon {
        vertices: Vec<[f64; 2]>,
        margin: f64,
        indices: [usize; 2],
    },
    Cylinder {
        center: [f64; 2],
        radius: f64,
        height: f64,
        band: f64,
        indices: [usize; 3],
    },
    StateBox {
        lower: Vec<f64>,
        upper: Vec<f64>,
    },
    ControlBox {
        lower: Vec<f64>,
        upper: Vec<f64>,
    },
    Tape(Arc<ddp_tape::TapeModel>),
    Callable(crate::callable::CallableConstraint),
}

fn bound_vector<N: Dim>(v: &[f64], field: &str, n: N) -> CoreResult<VectorN<N>>
where
    DefaultAllocator: Alloc<N, N>,
{
    if v.len() != n.value() {
        return Err(shape(field, format!("({},)", v.len()), format!("({},)", n.value())));
    }
    Ok(VectorN::from_row_slice_generic(n, nalgebra::U1, v))
}

impl Spec {
    /// The typed constraint for `(NX, NU)`; errors name `field`.
    fn build<NX: Dim, NU: Dim>(&self, field: &str, d: Dims<NX, NU>) -> CoreResult<Arc<dyn CoreConstraint<NX, NU>>>
    where
        DefaultAllocator: Alloc<NX, NU>,
    {
        Ok(match self {
            Spec::Circle {
                center,
                radius,
                indices,
                distance,
            } => {
                check_index(indices, field, d.nx())?;
                if *distance {
                    Arc::new(CoreCircle::<NX>::distance(*center, *radius, *indices)?)
                } else {
                    Arc::new(CoreCircle::<NX>::squared(*center, *radius, *indices)?)
                }
            }
            Spec::Polygon {
                vertices,
                margin,
                indices,
            } => {
                check_index(indices, field, d.nx())?;
                Arc::new(CorePolygon::<NX>::new(vertices, *margin, *indices)?)
            }
            Spec::Cylinder {
                center,
                radius,
                height,
                band,
                indices,
            } => {
                check_index(indices, field, d.nx())?;
                Arc::new(CoreCylinder::<NX>::new(*center, *radius, *height, *band, *indices)?)
            }
            Spec::StateBox { lower, upper } => Arc::new(CoreStateBox::<NX>::new(
                bound_vector(lower, &format!("{field}.lower"), d.nx)?,
                bound_vector(upper, &format!("{field}.upper"), d.nx)?,
            )?),
            Spec::ControlBox { lower, upper } => Arc::new(CoreControlBox::<NU>::new(
                bound_vector(lower, &format!("{field}.lower"), d.nu)?,
                bound_vector(upper, &format!("{field}.upper"), d.nu)?,
            )?),
            Spec::Callable(c) => {
                CoreConstraint::<NX, NU>::check_sizes(c, d.nx(), d.nu())
                    .map_err(|e| crate::errors::CoreError(e).context(field))?;
                Arc::new(c.clone())
            }
            Spec::Tape(m) => match &**m {
                ddp_tape::TapeModel::Constraint(c) => {
                    CoreConstraint::<NX, NU>::check_sizes(c, d.nx(), d.nu())
                        .map_err(|e| crate::errors::CoreError(e).context(field))?;
                    Arc::new(c.clone())
                }
                _ => {
                    return Err(crate::convert::internal(
                        "a tape constraint that is not a constraint".into(),
                    ))
                }
            },
        })
    }
}

fn check_index(indices: &[usize], field: &str, nx: usize) -> CoreResult<()> {
    for (i, &j) in indices.iter().enumerate() {
        if j >= nx {
            return Err(invalid(
                format!("{field}.indices[{i}]"),
                format!("state index {j} out of range for {nx} states"),
            ));
        }
    }
    Ok(())
}

fn index_arg(v: i64, field: &str) -> PyResult<usize> {
    usize::try_from(v).map_err(|_| invalid(field, format!("must be a non-negative index, got {v}")).into())
}

fn point_arg(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<[f64; 2]> {
    let a = finite_arr(obj, field)?;
    a.expect_shape(field, &[2])?;
    Ok([a.data[0], a.data[1]])
}

fn vector_arg(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Vec<f64>> {
    let a = crate::convert::to_arr(obj, field)?;
    if a.shape.len() != 1 {
        return Err(shape(field, shape_str(&a.shape), "(n,)").into());
    }
    if let Some(i) = a.data.iter().position(|v| v.is_nan()) {
        return Err(crate::errors::CoreError(ddp_core::Error::NotFinite {
            field: field.to_string(),
            index: i,
            value: f64::NAN,
        })
        .into());
    }
    Ok(a.data)
}

/// Base class of the Safe-CDDP constraints `g(x, u) <= 0`.
///
/// State constraints (obstacles, state boxes) are imposed on `x_1 .. x_N`; the solver moves
/// each to the knot whose control can change it (its relative degree). Control boxes are mixed
/// constraints on `(x_k, u_k)` and are tightened like the others (unlike the problem's hard
/// `u_min`/`u_max`).
#[pyclass(module = "ddpkit._ddpkit", subclass, frozen)]
pub struct Constraint {
    spec: Arc<Spec>,
}

/// The call that builds `spec` again: `(constructor, arguments)` (pickling).
fn constraint_reduce<'py>(py: Python<'py>, spec: &Spec) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
    use crate::pickle::module_attr;
    let pair = |i: &[usize; 2]| (i[0], i[1]);
    Ok(match spec {
        Spec::Circle {
            center,
            radius,
            indices,
            distance,
        } => {
            let form = if *distance { "distance" } else { "squared" };
            (
                module_attr(py, "Circle")?,
                ((center[0], center[1]), *radius, pair(indices), form).into_pyobject(py)?,
            )
        }
        Spec::Polygon {
            vertices,
            margin,
            indices,
        } => {
            let v: Vec<Vec<f64>> = vertices.iter().map(|p| p.to_vec()).collect();
            (
                module_attr(py, "ConvexPolygon")?,
                (v, *margin, pair(indices)).into_pyobject(py)?,
            )
        }
        Spec::Cylinder {
            center,
            radius,
            height,
            band,
            indices,
        } => (
            module_attr(py, "Cylinder")?,
            (
                (center[0], center[1]),
                *radius,
                *height,
                *band,
                (indices[0], indices[1], indices[2]),
            )
                .into_pyobject(py)?,
        ),
        Spec::StateBox { lower, upper } => (
            module_attr(py, "StateBox")?,
            (lower.clone(), upper.clone()).into_pyobject(py)?,
        ),
        Spec::ControlBox { lower, upper } => (
            module_attr(py, "ControlBox")?,
            (lower.clone(), upper.clone()).into_pyobject(py)?,
        ),
        Spec::Tape(m) => (
            module_attr(py, "model_from_json")?,
            (m.to_json(None),).into_pyobject(py)?,
        ),
        Spec::Callable(c) => {
            let (g, nx, nu, rows) = c.parts(py);
            (
                module_attr(py, "Constraint")?.getattr("from_callable")?,
                (g, nx, nu, rows).into_pyobject(py)?,
            )
        }
    })
}

#[pymethods]
impl Constraint {
    fn __repr__(&self) -> String {
        format!("{:?}", self.spec)
    }

    /// Pickles as the call that builds the constraint again.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        constraint_reduce(py, &self.spec)
    }

    /// Equal when the same constraint with equal parameters.
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Constraint>()
            .map(|o| *o.get().spec == *self.spec)
            .unwrap_or(false)
    }

    /// Constraints `g(x, u) <= 0` traced from a Python function returning one value or a 1-D
    /// array of rows (`g(x)` when `nu` is None). Rows that do not depend on `u` are state-only
    /// (imposed on `x_1 .. x_N`, like the obstacles).
    #[staticmethod]
    #[pyo3(signature = (g, nx, nu = None))]
    fn from_function(
        py: Python<'_>,
        g: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = crate::convert::int_i64)] nx: i64,
        #[pyo3(from_py_with = crate::convert::opt_int_i64)] nu: Option<i64>,
    ) -> PyResult<Py<PyAny>> {
        crate::tape::constraint_from_function(py, g, nx, nu)
    }

    /// Constraints `g(x, u) <= 0` from a plain Python callable returning `rows` values (`g(x)`
    /// when `nu` is None: state-only rows, imposed on `x_1 .. x_N`): the slow path for what cannot
    /// be traced. Jacobians by central finite differences; an exception raised by `g` during a
    /// solve is raised by the solve.
    #[staticmethod]
    #[pyo3(signature = (g, nx, nu = None, rows = 1))]
    fn from_callable(
        py: Python<'_>,
        g: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = crate::convert::int_i64)] nx: i64,
        #[pyo3(from_py_with = crate::convert::opt_int_i64)] nu: Option<i64>,
        #[pyo3(from_py_with = crate::convert::int_i64)] rows: i64,
    ) -> PyResult<Py<PyAny>> {
        crate::callable::constraint_from_callable(py, g, nx, nu, rows)
    }

    /// Constraints read from a CasADi SX function `g(x, u)` or `g(x)` (first output, a vector).
    #[staticmethod]
    fn from_casadi(py: Python<'_>, g: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        crate::tape::constraint_from_casadi(py, g)
    }
}

/// The base object of a tape constraint.
pub(crate) fn tape_constraint(model: Arc<ddp_tape::TapeModel>) -> Constraint {
    Constraint {
        spec: Arc::new(Spec::Tape(model)),
    }
}

/// Constraints of a plain Python callable (`Constraint.from_callable`): the slow path.
#[pyclass(module = "ddpkit._ddpkit", extends = Constraint, frozen, name = "CallableConstraint")]
pub struct PyCallableConstraint {
    model: crate::callable::CallableConstraint,
}

#[pymethods]
impl PyCallableConstraint {
    /// The Python function.
    #[getter]
    fn function(&self, py: Python<'_>) -> Py<PyAny> {
        self.model.parts(py).0
    }

    /// Number of rows of `g`.
    #[getter]
    fn rows(&self, py: Python<'_>) -> usize {
        self.model.parts(py).3
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        let (_, nx, nu, rows) = self.model.parts(py);
        format!("CallableConstraint(nx={nx}, nu={nu:?}, rows={rows})")
    }
}

/// The Python object of a callable constraint.
pub(crate) fn callable_constraint(py: Python<'_>, model: crate::callable::CallableConstraint) -> PyResult<Py<PyAny>> {
    let base = Constraint {
        spec: Arc::new(Spec::Callable(model.clone())),
    };
    Ok(Py::new(
        py,
        PyClassInitializer::from(base).add_subclass(PyCallableConstraint { model }),
    )?
    .into_any())
}

fn init<T: pyo3::PyClass<BaseType = Constraint>>(spec: Spec, sub: T) -> PyClassInitializer<T> {
    PyClassInitializer::from(Constraint { spec: Arc::new(spec) }).add_subclass(sub)
}

/// A circular obstacle on the position `(x[i0], x[i1])` (a vertical cylinder of infinite height
/// for a 3-D robot): `r^2 - |p - c|^2 <= 0` (`form="squared"`, as Xie et al. and the benchmark
/// problems) or `r - |p - c| <= 0` (`form="distance"`: margins in metres).
#[pyclass(module = "ddpkit._ddpkit", extends = Constraint, frozen)]
pub struct Circle {
    center: [f64; 2],
    radius: f64,
}

#[pymethods]
impl Circle {
    #[new]
    #[pyo3(signature = (center, radius, indices = (0, 1), form = "squared"))]
    fn new(
        center: &Bound<'_, PyAny>,
        radius: f64,
        indices: (i64, i64),
        form: &str,
    ) -> PyResult<PyClassInitializer<Self>> {
        let center = point_arg(center, "center")?;
        let indices = [index_arg(indices.0, "indices[0]")?, index_arg(indices.1, "indices[1]")?];
        let distance = match form {
            "squared" => false,
            "distance" => true,
            other => return Err(invalid("form", format!("must be 'squared' or 'distance', got '{other}'")).into()),
        };
        // Validate now (the dimension check waits for the solver).
        CoreCircle::<Dyn>::new(
            center,
            radius,
            [0, 1],
            safe_cddp::constraints::CircleForm::SquaredDistance,
        )
        .map_err(crate::errors::CoreError)?;
        if indices[0] == indices[1] {
            return Err(invalid("indices", "the two position indices must differ").into());
        }
        Ok(init(
            Spec::Circle {
                center,
                radius,
                indices,
                distance,
            },
            Self { center, radius },
        ))
    }
    /// The centre `(x, y)`.
    #[getter]
    fn center(&self) -> (f64, f64) {
        (self.center[0], self.center[1])
    }
    /// The radius.
    #[getter]
    fn radius(&self) -> f64 {
        self.radius
    }
}

/// A convex polygonal obstacle (the convex hull of `vertices`, shape `(n, 2)`, n >= 3) inflated
/// by `margin`: `margin - sd(p) <= 0` with the signed distance `sd` from parry.
#[pyclass(module = "ddpkit._ddpkit", extends = Constraint, frozen)]
pub struct ConvexPolygon {}

#[pymethods]
impl ConvexPolygon {
    #[new]
    #[pyo3(signature = (vertices, margin = 0.0, indices = (0, 1)))]
    fn new(vertices: &Bound<'_, PyAny>, margin: f64, indices: (i64, i64)) -> PyResult<PyClassInitializer<Self>> {
        let a = finite_arr(vertices, "vertices")?;
        if a.shape.len() != 2 || a.shape[1] != 2 {
            return Err(shape("vertices", shape_str(&a.shape), "(n, 2)").into());
        }
        let vertices: Vec<[f64; 2]> = a.data.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
        let indices = [index_arg(indices.0, "indices[0]")?, index_arg(indices.1, "indices[1]")?];
        CorePolygon::<Dyn>::new(&vertices, margin, [0, 1]).map_err(crate::errors::CoreError)?;
        if indices[0] == indices[1] {
            return Err(invalid("indices", "the two position indices must differ").into());
        }
        Ok(init(
            Spec::Polygon {
                vertices,
                margin,
                indices,
            },
            Self {},
        ))
    }
}

/// A vertical cylinder of `radius` around `center` standing up to `height` on the position
/// `(x[i0], x[i1], x[i2])` (z up): the robot may pass beside or over it. The rim is smoothed over
/// `band` (m).
#[pyclass(module = "ddpkit._ddpkit", extends = Constraint, frozen)]
pub struct Cylinder {}

#[pymethods]
impl Cylinder {
    #[new]
    #[pyo3(signature = (center, radius, height, band = 0.02, indices = (0, 1, 2)))]
    fn new(
        center: &Bound<'_, PyAny>,
        radius: f64,
        height: f64,
        band: f64,
        indices: (i64, i64, i64),
    ) -> PyResult<PyClassInitializer<Self>> {
        let center = point_arg(center, "center")?;
        let indices = [
            index_arg(indices.0, "indices[0]")?,
            index_arg(indices.1, "indices[1]")?,
            index_arg(indices.2, "indices[2]")?,
        ];
        CoreCylinder::<Dyn>::new(center, radius, height, band, [0, 1, 2]).map_err(crate::errors::CoreError)?;
        if indices[0] == indices[1] || indices[0] == indices[2] || indices[1] == indices[2] {
            return Err(invalid("indices", "the three position indices must differ").into());
        }
        Ok(init(
            Spec::Cylinder {
                center,
                radius,
                height,
                band,
                indices,
            },
            Self {},
        ))
    }
}

/// State limits `lower <= x <= upper` (shape `(nx,)` each; `+-inf` for no limit).
#[pyclass(module = "ddpkit._ddpkit", extends = Constraint, frozen)]
pub struct StateBox {}

#[pymethods]
impl StateBox {
    #[new]
    fn new(lower: &Bound<'_, PyAny>, upper: &Bound<'_, PyAny>) -> PyResult<PyClassInitializer<Self>> {
        let (lower, upper) = box_args(lower, upper)?;
        Ok(init(Spec::StateBox { lower, upper }, Self {}))
    }
}

/// Control limits `lower <= u <= upper` as (tightened) constraints, shape `(nu,)` each.
#[pyclass(module = "ddpkit._ddpkit", extends = Constraint, frozen)]
pub struct ControlBox {}

#[pymethods]
impl ControlBox {
    #[new]
    fn new(lower: &Bound<'_, PyAny>, upper: &Bound<'_, PyAny>) -> PyResult<PyClassInitializer<Self>> {
        let (lower, upper) = box_args(lower, upper)?;
        Ok(init(Spec::ControlBox { lower, upper }, Self {}))
    }
}

fn box_args(lower: &Bound<'_, PyAny>, upper: &Bound<'_, PyAny>) -> PyResult<(Vec<f64>, Vec<f64>)> {
    let (lo, hi) = (vector_arg(lower, "lower")?, vector_arg(upper, "upper")?);
    if lo.len() != hi.len() {
        return Err(shape("upper", format!("({},)", hi.len()), format!("({},)", lo.len())).into());
    }
    for (i, (l, h)) in lo.iter().zip(&hi).enumerate() {
        if l > h {
            return Err(invalid(format!("lower[{i}]"), format!("{l} exceeds upper[{i}] = {h}")).into());
        }
    }
    Ok((lo, hi))
}

fn extract_constraints(obj: &Bound<'_, PyAny>) -> PyResult<Vec<Arc<Spec>>> {
    extract_constraints_at(obj, "constraints")
}

/// [`extract_constraints`] with errors naming `{field}[i]`.
fn extract_constraints_at(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Vec<Arc<Spec>>> {
    let mut out = Vec::new();
    for (i, item) in obj.try_iter()?.enumerate() {
        let item = item?;
        match item.cast::<Constraint>() {
            Ok(c) => out.push(c.get().spec.clone()),
            Err(_) => {
                return Err(invalid(
                    format!("{field}[{i}]"),
                    format!(
                        "must be a ddpkit constraint (e.g. ddpkit.Circle), got {}",
                        type_name(&item)
                    ),
                )
                .into())
            }
        }
    }
    Ok(out)
}

// ------------------------------------------------------------------------------------------------
// Tightening

const GAINS: &str = "must be 'closed_loop', 'active_set', 'open_loop' or an (nu, nx) array";

#[derive(Debug, Clone, PartialEq)]
enum GainSpec {
    ClosedLoop,
    ActiveSet,
    OpenLoop,
    Fixed(Arr),
}

/// Chance-constraint tightening (eqs. 19-20): `beta`, the process noise `sigma_w` (`(nx, nx)`,
/// symmetric PSD), the gains of the covariance propagation and the update period `n2`.
///
/// `gains`: `"closed_loop"` (Safe-CDDP: the backward pass's gains with the control bounds as
/// its only constraint rows), `"active_set"` (eq. 12 with the state-constraint rows too),
/// `"open_loop"` (`K = 0`) or a fixed gain, shape `(nu, nx)` (cautious MPC).
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct Tightening {
    beta: f64,
    sigma_w: Arr,
    sigma_0: Option<Arr>,
    gains: GainSpec,
    update_every: usize,
}

impl Tightening {
    fn build<NX: Dim, NU: Dim>(&self, d: Dims<NX, NU>) -> CoreResult<CoreTightening<NX, NU>>
    where
        DefaultAllocator: Alloc<NX, NU>,
    {
        let sigma_w = self.sigma_w.matrix("tightening.sigma_w", d.nx, d.nx)?;
        let gains = match &self.gains {
            GainSpec::ClosedLoop => Gains::ClosedLoop,
            GainSpec::ActiveSet => Gains::ActiveSet,
            GainSpec::OpenLoop => Gains::OpenLoop,
            GainSpec::Fixed(k) => Gains::Fixed(k.matrix("tightening.gains", d.nu, d.nx)?),
        };
        let mut t = CoreTightening::new(self.beta, sigma_w)?
            .with_gains(gains)?
            .with_update_every(self.update_every)?;
        if let Some(s0) = &self.sigma_0 {
            t = t.with_initial_covariance(s0.matrix("tightening.sigma_0", d.nx, d.nx)?)?;
        }
        Ok(t)
    }
}

#[pymethods]
impl Tightening {
    #[new]
    #[pyo3(signature = (beta, sigma_w, gains = None, update_every = 5, sigma_0 = None))]
    fn new(
        beta: f64,
        sigma_w: &Bound<'_, PyAny>,
        gains: Option<&Bound<'_, PyAny>>,
        #[pyo3(from_py_with = crate::convert::int_i64)] update_every: i64,
        sigma_0: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let sigma_w = finite_arr(sigma_w, "sigma_w")?;
        let n = sigma_w.rows();
        sigma_w.expect_shape("sigma_w", &[n, n])?;
        // beta in (0, 1) and a symmetric PSD sigma_w, whatever its size (checked against nx later).
        check_tightening(beta, &sigma_w)?;
        let gains = match gains {
            None => GainSpec::ClosedLoop,
            Some(g) if g.is_none() => GainSpec::ClosedLoop,
            Some(g) => match g.extract::<String>() {
                Ok(s) => match s.as_str() {
                    "closed_loop" => GainSpec::ClosedLoop,
                    "active_set" => GainSpec::ActiveSet,
                    "open_loop" => GainSpec::OpenLoop,
                    other => return Err(invalid("gains", format!("{GAINS}, got '{other}'")).into()),
                },
                Err(_) => {
                    let k = finite_arr(g, "gains")?;
                    if k.shape.len() != 2 || k.shape[1] != n {
                        return Err(shape("gains", shape_str(&k.shape), format!("(nu, {n})")).into());
                    }
                    GainSpec::Fixed(k)
                }
            },
        };
        let update_every = usize::try_from(update_every)
            .ok()
            .filter(|&v| v >= 1)
            .ok_or_else(|| invalid("update_every", format!("must be at least 1, got {update_every}")))?;
        let sigma_0 = match sigma_0 {
            Some(s) if !s.is_none() => {
                let s = finite_arr(s, "sigma_0")?;
                s.expect_shape("sigma_0", &[n, n])?;
                check_tightening(0.9, &s).map_err(|e| rename(e, "sigma_w", "sigma_0"))?;
                Some(s)
            }
            _ => None,
        };
        Ok(Self {
            beta,
            sigma_w,
            sigma_0,
            gains,
            update_every,
        })
    }
    /// The constructor's arguments (pickling).
    #[allow(clippy::type_complexity)]
    fn __getnewargs__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(
        f64,
        Bound<'py, PyAny>,
        Bound<'py, PyAny>,
        usize,
        Option<Bound<'py, PyAny>>,
    )> {
        let matrix = |a: &Arr| rows_to_numpy(py, a.rows(), a.shape.get(1).copied().unwrap_or(0), a.data.clone());
        let gains = match &self.gains {
            GainSpec::ClosedLoop => "closed_loop".into_pyobject(py)?.into_any(),
            GainSpec::ActiveSet => "active_set".into_pyobject(py)?.into_any(),
            GainSpec::OpenLoop => "open_loop".into_pyobject(py)?.into_any(),
            GainSpec::Fixed(k) => matrix(k)?,
        };
        let sigma_0 = self.sigma_0.as_ref().map(matrix).transpose()?;
        Ok((self.beta, matrix(&self.sigma_w)?, gains, self.update_every, sigma_0))
    }
    /// Equal when built from equal arguments.
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Tightening>()
            .map(|o| {
                let o = o.get();
                (o.beta, &o.sigma_w, &o.sigma_0, &o.gains, o.update_every)
                    == (self.beta, &self.sigma_w, &self.sigma_0, &self.gains, self.update_every)
            })
            .unwrap_or(false)
    }
    /// `beta`.
    #[getter]
    fn beta(&self) -> f64 {
        self.beta
    }
    /// `phi^{-1}(beta)`, the standard-normal quantile.
    #[getter]
    fn quantile(&self) -> f64 {
        safe_cddp::quantile::normal_quantile(self.beta).unwrap_or(f64::NAN)
    }
    /// `n2`: iterations between tightenings.
    #[getter]
    fn update_every(&self) -> usize {
        self.update_every
    }
    fn __repr__(&self) -> String {
        let g = match &self.gains {
            GainSpec::ClosedLoop => "'closed_loop'".to_string(),
            GainSpec::ActiveSet => "'active_set'".to_string(),
            GainSpec::OpenLoop => "'open_loop'".to_string(),
            GainSpec::Fixed(k) => format!("<fixed {}>", shape_str(&k.shape)),
        };
        format!(
            "Tightening(beta={}, gains={g}, update_every={})",
            self.beta, self.update_every
        )
    }
}

fn rename(e: crate::errors::CoreError, from: &str, to: &str) -> crate::errors::CoreError {
    let msg = e.0.to_string().replace(from, to);
    invalid(to, msg)
}

/// Checks `beta` and that `sigma` is symmetric PSD (any size), with the core's messages.
fn check_tightening(beta: f64, sigma: &Arr) -> CoreResult<()> {
    if safe_cddp::quantile::normal_quantile(beta).is_none() {
        return Err(invalid("beta", format!("must be in (0, 1), got {beta}")));
    }
    let n = sigma.rows();
    let m = nalgebra::DMatrix::from_row_slice(n, n, &sigma.data);
    let scale = m.amax().max(1.0);
    for i in 0..n {
        for j in 0..i {
            if (m[(i, j)] - m[(j, i)]).abs() > 1e-9 * scale {
                return Err(crate::errors::CoreError(ddp_core::Error::NotPsd {
                    field: "sigma_w".into(),
                    reason: format!("not symmetric at ({i}, {j})"),
                }));
            }
        }
    }
    if n > 0 {
        let eig = nalgebra::SymmetricEigen::new(m).eigenvalues;
        if eig.iter().any(|&v| v < -1e-12 * scale) {
            return Err(crate::errors::CoreError(ddp_core::Error::NotPsd {
                field: "sigma_w".into(),
                reason: "has a negative eigenvalue".into(),
            }));
        }
    }
    Ok(())
}

// ------------------------------------------------------------------------------------------------
// Settings

/// The Python name of a [`QpMethod`].
fn qp_name(q: QpMethod) -> &'static str {
    match q {
        QpMethod::Fast => "fast",
        QpMethod::Clarabel => "clarabel",
    }
}

/// `max_iterations` of [`Mpc`]'s inner solver: 400, as the Table I experiments
/// (`safe_cddp::table`) and this binding before, not `Settings::default()`'s 200. A binding
/// default, written once here and exported by `default_settings("Mpc")`.
const MPC_MAX_ITERATIONS: usize = 400;

/// The MPC loop's defaults (`MpcSettings::default()`; its goal has none and is not used).
fn mpc_default() -> MpcSettings<Const<1>> {
    MpcSettings::default()
}

fn default_goal_indices() -> Vec<i64> {
    mpc_default().goal_indices.iter().map(|&i| i as i64).collect()
}

fn default_position_indices() -> (i64, i64) {
    let [a, b] = mpc_default().position_indices;
    (a as i64, b as i64)
}

/// `Settings::portfolio_mirror`'s default as the keyword argument's type.
fn default_mirror() -> Option<i64> {
    Settings::default().portfolio_mirror.map(|v| v as i64)
}

/// `Settings::portfolio_plan`'s default as the keyword argument's type.
fn default_plan() -> Option<i64> {
    Settings::default().portfolio_plan.map(|v| v as i64)
}

/// The defaults of `SafeCddpSolver`'s keyword arguments (`safe_cddp::Settings::default()`).
pub(crate) fn safe_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    safe_settings_dict(py, &Settings::default())
}

/// The keyword arguments of `SafeCddpSolver` that give `s`.
fn safe_settings_dict<'py>(py: Python<'py>, s: &Settings) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("method", method_name(s.method))?;
    d.set_item("max_iterations", s.max_iterations)?;
    d.set_item("constraint_tolerance", s.constraint_tolerance)?;
    d.set_item("qp_method", qp_name(s.qp_method))?;
    d.set_item("warm_up", s.warm_up.as_str())?;
    d.set_item("portfolio_polish", s.portfolio_polish)?;
    d.set_item("portfolio_new_side", s.portfolio_new_side)?;
    d.set_item("portfolio_threads", s.portfolio_threads)?;
    d.set_item("portfolio_third_mu", s.portfolio_third_mu)?;
    d.set_item("portfolio_apart", s.portfolio_apart)?;
    d.set_item("portfolio_flip", s.portfolio_flip)?;
    d.set_item("portfolio_flip_apart", s.portfolio_flip_apart)?;
    d.set_item("portfolio_flip_starts", s.portfolio_flip_starts)?;
    d.set_item("portfolio_mirror", s.portfolio_mirror)?;
    d.set_item("portfolio_plan", s.portfolio_plan)?;
    d.set_item("portfolio_abandon", s.portfolio_abandon)?;
    d.set_item("portfolio_dual_bound", s.portfolio_dual_bound)?;
    d.set_item(
        "barrier_funnel",
        s.barrier_funnel.is_finite().then_some(s.barrier_funnel),
    )?;
    d.set_item("barrier_mu_init", s.barrier_mu_init)?;
    d.set_item("barrier_relaxation", s.barrier_relaxation)?;
    d.set_item("al_inner_progress", s.al_inner_progress)?;
    Ok(d)
}

/// The defaults of `Mpc`'s keyword arguments (`MpcSettings::default()`, [`MPC_MAX_ITERATIONS`]).
pub(crate) fn mpc_defaults(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let m = mpc_default();
    let d = PyDict::new(py);
    d.set_item("goal_indices", default_goal_indices())?;
    d.set_item("goal_radius", m.goal_radius)?;
    d.set_item("iterations", m.iterations)?;
    d.set_item("initial_iterations", m.initial_iterations)?;
    d.set_item("position_indices", default_position_indices())?;
    d.set_item("max_iterations", MPC_MAX_ITERATIONS)?;
    Ok(d)
}

fn settings_from(
    method: &str,
    max_iterations: i64,
    constraint_tolerance: f64,
    qp_method: &str,
    warm_up: &str,
    portfolio_polish: bool,
    portfolio_new_side: Option<f64>,
    portfolio_threads: i64,
    portfolio_third_mu: Option<f64>,
    portfolio_apart: f64,
    portfolio_flip: Option<f64>,
    portfolio_flip_apart: f64,
    portfolio_flip_starts: i64,
    portfolio_mirror: Option<i64>,
    portfolio_plan: Option<i64>,
    portfolio_abandon: Option<f64>,
    portfolio_dual_bound: Option<f64>,
    barrier_funnel: Option<f64>,
    barrier_mu_init: f64,
    barrier_relaxation: f64,
    al_inner_progress: f64,
) -> CoreResult<Settings> {
    let method = parse_method(method)?;
    let warm_up = [
        WarmUp::Portfolio,
        WarmUp::Barrier,
        WarmUp::AugmentedLagrangian,
        WarmUp::None,
    ]
    .into_iter()
    .find(|w| w.as_str() == warm_up.to_ascii_lowercase())
    .ok_or_else(|| {
        invalid(
            "warm_up",
            format!("must be 'portfolio', 'barrier', 'augmented_lagrangian' or 'none', got '{warm_up}'"),
        )
    })?;
    let qp_method = match qp_method.to_ascii_lowercase().as_str() {
        "fast" => QpMethod::Fast,
        "clarabel" => QpMethod::Clarabel,
        other => {
            return Err(invalid(
                "qp_method",
                format!("must be 'fast' or 'clarabel', got '{other}'"),
            ))
        }
    };
    let max_iterations = usize::try_from(max_iterations)
        .ok()
        .filter(|&v| v >= 1)
        .ok_or_else(|| invalid("max_iterations", format!("must be at least 1, got {max_iterations}")))?;
    let portfolio_threads = usize::try_from(portfolio_threads)
        .ok()
        .filter(|v| (1..=2).contains(v))
        .ok_or_else(|| invalid("portfolio_threads", format!("must be 1 or 2, got {portfolio_threads}")))?;
    let portfolio_flip_starts = usize::try_from(portfolio_flip_starts)
        .ok()
        .filter(|&v| v >= 1)
        .ok_or_else(|| {
            invalid(
                "portfolio_flip_starts",
                format!("must be at least 1 (portfolio_flip=None: no flipped starts), got {portfolio_flip_starts}"),
            )
        })?;
    // A guided start's iterations: at least 1, or `None` for no such start.
    let guided = |field: &str, start: &str, v: Option<i64>| -> CoreResult<Option<usize>> {
        v.map(|v| {
            usize::try_from(v).ok().filter(|&v| v >= 1).ok_or_else(|| {
                invalid(
                    field,
                    format!("must be at least 1 iteration, or None for no {start} start, got {v}"),
                )
            })
        })
        .transpose()
    };
    let portfolio_mirror = guided("portfolio_mirror", "mirrored", portfolio_mirror)?;
    let portfolio_plan = guided("portfolio_plan", "planned", portfolio_plan)?;
    let s = Settings {
        method,
        max_iterations,
        constraint_tolerance,
        qp_method,
        warm_up,
        portfolio_polish,
        portfolio_new_side,
        portfolio_threads,
        portfolio_third_mu,
        portfolio_apart,
        portfolio_flip,
        portfolio_flip_apart,
        portfolio_flip_starts,
        portfolio_mirror,
        portfolio_plan,
        portfolio_abandon,
        portfolio_dual_bound,
        // `None`: no limit.
        barrier_funnel: barrier_funnel.unwrap_or(f64::INFINITY),
        barrier_mu_init,
        barrier_relaxation,
        al_inner_progress,
        ..Settings::default()
    };
    s.validate()?;
    Ok(s)
}

// ------------------------------------------------------------------------------------------------
// Dimension dispatch: one solver / MPC variant per compiled pair.

macro_rules! any_safe {
    ($( $var:ident = ($nx:literal, $nu:literal) ),+ $(,)?) => {
        enum AnySafe {
            $( $var(Box<CoreSolver<Const<$nx>, Const<$nu>>>), )+
            Dyn(Box<CoreSolver<Dyn, Dyn>>),
        }
        enum AnyMpc {
            $( $var(Box<CoreMpc<Const<$nx>, Const<$nu>>>), )+
            Dyn(Box<CoreMpc<Dyn, Dyn>>),
        }
        $( impl_safe_pair!($var, Const<$nx>, Const<$nu>); )+
        impl_safe_pair!(Dyn, Dyn, Dyn);
    };
}

/// Access to the variants of [`AnySafe`] and [`AnyMpc`] for one dimension pair.
trait SafePair<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn solver(s: &mut AnySafe) -> Option<&mut CoreSolver<NX, NU>>;
    fn wrap(s: CoreSolver<NX, NU>) -> AnySafe;
    fn mpc(m: &mut AnyMpc) -> Option<&mut CoreMpc<NX, NU>>;
    fn wrap_mpc(m: CoreMpc<NX, NU>) -> AnyMpc;
}

macro_rules! impl_safe_pair {
    ($var:ident, $nx:ty, $nu:ty) => {
        #[allow(unreachable_patterns)]
        impl SafePair<$nx, $nu> for Dispatch {
            fn solver(s: &mut AnySafe) -> Option<&mut CoreSolver<$nx, $nu>> {
                match s {
                    AnySafe::$var(x) => Some(&mut **x),
                    _ => None,
                }
            }
            fn wrap(s: CoreSolver<$nx, $nu>) -> AnySafe {
                AnySafe::$var(Box::new(s))
            }
            fn mpc(m: &mut AnyMpc) -> Option<&mut CoreMpc<$nx, $nu>> {
                match m {
                    AnyMpc::$var(x) => Some(&mut **x),
                    _ => None,
                }
            }
            fn wrap_mpc(m: CoreMpc<$nx, $nu>) -> AnyMpc {
                AnyMpc::$var(Box::new(m))
            }
        }
    };
}

// Safe-CDDP at the compiled pairs of `crate::dims` (the fixed-size fast path) and at run-time
// sizes; `with_dims!` dispatches to the generic functions below.
compiled_pairs!(any_safe);

fn typed_constraints<NX: Dim, NU: Dim>(
    specs: &[Arc<Spec>],
    d: Dims<NX, NU>,
) -> CoreResult<Vec<Arc<dyn CoreConstraint<NX, NU>>>>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    specs
        .iter()
        .enumerate()
        .map(|(i, s)| s.build::<NX, NU>(&format!("constraints[{i}]"), d))
        .collect()
}

fn new_safe<NX: Dim, NU: Dim>(
    p: &AnyProblem,
    specs: &[Arc<Spec>],
    tightening: Option<&Tightening>,
    settings: Settings,
) -> CoreResult<AnySafe>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU> + SafePair<NX, NU>,
{
    let p = problem_of::<NX, NU>(p)?;
    let per_knot = 40 * p.dims().nx() * p.dims().nx() * std::mem::size_of::<f64>();
    crate::convert::check_allocation("horizon", p.horizon() + 1, per_knot)?;
    let d = p.dims();
    let mut s = CoreSolver::new(p, typed_constraints(specs, d)?, settings)?;
    s.set_tightening(tightening.map(|t| t.build(d)).transpose()?)?;
    Ok(<Dispatch as SafePair<NX, NU>>::wrap(s))
}

/// Plain-data results copied out of the workspace without the GIL.
struct Out {
    n: usize,
    xs: Vec<f64>,
    us: Vec<f64>,
    gains: Vec<f64>,
    feedforward: Vec<f64>,
    propagation_gains: Vec<f64>,
    covariances: Vec<f64>,
    margins: Vec<f64>,
    rows: usize,
    report: Report,
}

fn out_of<NX: Dim, NU: Dim>(s: &CoreSolver<NX, NU>) -> Out
where
    DefaultAllocator: Alloc<NX, NU>,
{
    let n = s.horizon();
    let (nx, nu, rows) = (s.dims().nx(), s.dims().nu(), s.rows_per_knot());
    let mut margins = Vec::with_capacity(n * rows);
    for k in 0..n {
        margins.extend_from_slice(s.margins(k));
    }
    Out {
        n,
        xs: flatten_vectors(s.xs(), nx),
        us: flatten_vectors(s.us(), nu),
        gains: flatten_matrices(s.gains()),
        feedforward: flatten_vectors(s.feedforward(), nu),
        propagation_gains: flatten_matrices(s.propagation_gains()),
        covariances: flatten_matrices(s.covariances()),
        margins,
        rows,
        report: s.report().clone(),
    }
}

fn solve_safe<NX: Dim, NU: Dim>(s: &mut AnySafe, p: &AnyProblem, us0: Option<&Arr>, warm_start: bool) -> CoreResult<Out>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU> + SafePair<NX, NU>,
{
    let s = <Dispatch as SafePair<NX, NU>>::solver(s).ok_or_else(|| internal_mismatch("solver"))?;
    let p = problem_of::<NX, NU>(p)?;
    // `warm_start` decides whether the last solve's state (multipliers, margins,
    // regularisation) carries over; `us0` only replaces the controls.
    if !warm_start {
        s.reset();
    }
    if let Some(us) = us0 {
        s.set_controls(&controls(us, "us0", s.horizon(), p.dims().nu)?)?;
    }
    s.solve(p)?;
    Ok(out_of(s))
}

fn tighten_safe<NX: Dim, NU: Dim>(s: &mut AnySafe, p: &AnyProblem) -> CoreResult<f64>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU> + SafePair<NX, NU>,
{
    let s = <Dispatch as SafePair<NX, NU>>::solver(s).ok_or_else(|| internal_mismatch("solver"))?;
    let p = problem_of::<NX, NU>(p)?;
    Ok(s.tighten(p)?)
}

fn edit_safe<NX: Dim, NU: Dim>(s: &mut AnySafe, what: Edit) -> CoreResult<usize>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU> + SafePair<NX, NU>,
{
    let s = <Dispatch as SafePair<NX, NU>>::solver(s).ok_or_else(|| internal_mismatch("solver"))?;
    match what {
        Edit::Shift => s.shift(),
        Edit::Reset => s.reset(),
        Edit::Horizon(n) => s.set_horizon(n)?,
        Edit::Get => {}
    }
    Ok(s.horizon())
}

#[derive(Clone, Copy)]
enum Edit {
    Shift,
    Reset,
    Horizon(usize),
    Get,
}

/// The Safe-CDDP solver: constrained DDP (Xie et al. 2017, KKT backward pass and per-step QPs)
/// with an augmented-Lagrangian warm-up, and, with a :class:`Tightening`, the chance-constraint
/// margins of Safe-CDDP (eqs. 19-20) updated every ``n2`` iterations.
#[pyclass(module = "ddpkit._ddpkit")]
pub struct SafeCddpSolver {
    /// `(problem, constraints, tightening)` as given (constraints as a list), for pickling.
    source: Py<PyTuple>,
    settings: Settings,
    shared: Arc<RwLock<AnyProblem>>,
    inner: AnySafe,
    nx: usize,
    nu: usize,
}

#[pymethods]
impl SafeCddpSolver {
    #[new]
    #[pyo3(signature = (problem, constraints, tightening = None,
                        method = method_name(Settings::default().method),
                        max_iterations = Settings::default().max_iterations as i64,
                        constraint_tolerance = Settings::default().constraint_tolerance,
                        qp_method = qp_name(Settings::default().qp_method),
                        warm_up = Settings::default().warm_up.as_str(),
                        portfolio_polish = Settings::default().portfolio_polish,
                        portfolio_new_side = Settings::default().portfolio_new_side,
                        portfolio_threads = Settings::default().portfolio_threads as i64,
                        portfolio_third_mu = Settings::default().portfolio_third_mu,
                        portfolio_apart = Settings::default().portfolio_apart,
                        portfolio_flip = Settings::default().portfolio_flip,
                        portfolio_flip_apart = Settings::default().portfolio_flip_apart,
                        portfolio_flip_starts = Settings::default().portfolio_flip_starts as i64,
                        portfolio_mirror = default_mirror(),
                        portfolio_plan = default_plan(),
                        portfolio_abandon = Settings::default().portfolio_abandon,
                        portfolio_dual_bound = Settings::default().portfolio_dual_bound,
                        barrier_funnel = Some(Settings::default().barrier_funnel),
                        barrier_mu_init = Settings::default().barrier_mu_init,
                        barrier_relaxation = Settings::default().barrier_relaxation,
                        al_inner_progress = Settings::default().al_inner_progress))]
    // The defaults as Python sees them; tests compare them and the stub with `default_settings`.
    #[pyo3(
        text_signature = "(problem, constraints, tightening=None, method='ilqr', max_iterations=200, \
                             constraint_tolerance=1e-8, qp_method='fast', warm_up='portfolio', \
                             portfolio_polish=True, portfolio_new_side=1.2, portfolio_threads=1, portfolio_third_mu=0.003, \
                             portfolio_apart=0.001, portfolio_flip=1.5, portfolio_flip_apart=1.25, portfolio_flip_starts=2, portfolio_mirror=5, portfolio_plan=5, portfolio_abandon=0.3, portfolio_dual_bound=0.01, barrier_funnel=0.03, barrier_mu_init=0.03, \
                             barrier_relaxation=0.1, al_inner_progress=1.0)"
    )]
    #[allow(clippy::too_many_arguments)]
    fn new(
        problem: Bound<'_, Problem>,
        constraints: &Bound<'_, PyAny>,
        tightening: Option<Bound<'_, Tightening>>,
        method: &str,
        #[pyo3(from_py_with = crate::convert::int_i64)] max_iterations: i64,
        constraint_tolerance: f64,
        qp_method: &str,
        warm_up: &str,
        portfolio_polish: bool,
        portfolio_new_side: Option<f64>,
        #[pyo3(from_py_with = crate::convert::int_i64)] portfolio_threads: i64,
        portfolio_third_mu: Option<f64>,
        portfolio_apart: f64,
        portfolio_flip: Option<f64>,
        portfolio_flip_apart: f64,
        #[pyo3(from_py_with = crate::convert::int_i64)] portfolio_flip_starts: i64,
        #[pyo3(from_py_with = crate::convert::opt_int_i64)] portfolio_mirror: Option<i64>,
        #[pyo3(from_py_with = crate::convert::opt_int_i64)] portfolio_plan: Option<i64>,
        portfolio_abandon: Option<f64>,
        portfolio_dual_bound: Option<f64>,
        barrier_funnel: Option<f64>,
        barrier_mu_init: f64,
        barrier_relaxation: f64,
        al_inner_progress: f64,
    ) -> PyResult<Self> {
        let specs = extract_constraints(constraints)?;
        let settings = settings_from(
            method,
            max_iterations,
            constraint_tolerance,
            qp_method,
            warm_up,
            portfolio_polish,
            portfolio_new_side,
            portfolio_threads,
            portfolio_third_mu,
            portfolio_apart,
            portfolio_flip,
            portfolio_flip_apart,
            portfolio_flip_starts,
            portfolio_mirror,
            portfolio_plan,
            portfolio_abandon,
            portfolio_dual_bound,
            barrier_funnel,
            barrier_mu_init,
            barrier_relaxation,
            al_inner_progress,
        )?;
        let p = problem.get();
        let (nx, nu) = (p.nx, p.nu);
        let shared = p.inner.clone();
        let t = tightening.as_ref().map(|t| t.get());
        let inner = Problem::read(&shared, |q| with_dims!(nx, nu, new_safe(q, &specs, t, settings)))?;
        let py = problem.py();
        let list = pyo3::types::PyList::new(py, constraints.try_iter()?.collect::<PyResult<Vec<_>>>()?)?;
        let source = PyTuple::new(
            py,
            [
                problem.into_any(),
                list.into_any(),
                tightening.map_or_else(|| py.None().into_bound(py), |t| t.into_any()),
            ],
        )?
        .unbind();
        Ok(Self {
            source,
            settings,
            shared,
            inner,
            nx,
            nu,
        })
    }

    /// Pickles as its problem, constraints, tightening and settings: the unpickled solver has a
    /// fresh workspace.
    #[allow(clippy::type_complexity)]
    fn __getnewargs_ex__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyTuple>, Bound<'py, PyDict>)> {
        Ok((self.source.bind(py).clone(), safe_settings_dict(py, &self.settings)?))
    }

    /// Equal when the problems, constraints, tightenings and settings are.
    fn __eq__(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        let Ok(o) = other.cast::<SafeCddpSolver>() else {
            return Ok(false);
        };
        let o = o.try_borrow()?;
        Ok(o.settings == self.settings && crate::pickle::equal_values(self.source.bind(py), o.source.bind(py))?)
    }

    /// Solves and returns a :class:`SafeSolution`; the GIL is released meanwhile.
    ///
    /// The initial guess is ``us0`` if given (shape ``(n, nu)`` for the active horizon ``n``),
    /// else the controls of the last solve when ``warm_start`` is true, else zeros. Without
    /// ``warm_start`` every solve is a cold start (as after :meth:`reset`), ``us0`` or not; with
    /// it the multipliers and margins of the last solve carry over (a receding-horizon warm
    /// start, ``us0`` then replacing only the controls).
    #[pyo3(signature = (us0 = None, warm_start = false))]
    fn solve(&mut self, py: Python<'_>, us0: Option<&Bound<'_, PyAny>>, warm_start: bool) -> PyResult<SafeSolution> {
        let us0 = match us0 {
            Some(u) if !u.is_none() => Some(finite_arr(u, "us0")?),
            _ => None,
        };
        let (nx, nu) = (self.nx, self.nu);
        let shared = &self.shared;
        let inner = &mut self.inner;
        let out = py.detach(|| -> CoreResult<Out> {
            Problem::read(shared, |p| {
                with_dims!(nx, nu, solve_safe(inner, p, us0.as_ref(), warm_start))
            })
        });
        crate::callable::raise_pending()?;
        let out = out?;
        Ok(SafeSolution::from_out(out, nx, nu))
    }

    /// Constraint tightening at the current trajectory (eqs. 19-20); returns the largest change
    /// of a margin (0 without a tightening).
    fn tighten(&mut self, py: Python<'_>) -> PyResult<f64> {
        let (nx, nu) = (self.nx, self.nu);
        let shared = &self.shared;
        let inner = &mut self.inner;
        let r =
            py.detach(|| -> CoreResult<f64> { Problem::read(shared, |p| with_dims!(nx, nu, tighten_safe(inner, p))) });
        crate::callable::raise_pending()?;
        Ok(r?)
    }

    /// Receding horizon: drops knot 0 of the solution (controls, gains, multipliers, margins).
    fn shift(&mut self) -> PyResult<()> {
        with_dims!(self.nx, self.nu, edit_safe(&mut self.inner, Edit::Shift))?;
        Ok(())
    }

    /// A cold start: zeros the initial guess, gains, multipliers and margins.
    fn reset(&mut self) -> PyResult<()> {
        with_dims!(self.nx, self.nu, edit_safe(&mut self.inner, Edit::Reset))?;
        Ok(())
    }

    /// Shortens (or restores) the active horizon ``1 <= n <= N`` (shrinking-horizon MPC).
    fn set_horizon(&mut self, #[pyo3(from_py_with = crate::convert::int_i64)] n: i64) -> PyResult<()> {
        let n = usize::try_from(n).map_err(|_| invalid("horizon", format!("must be at least 1, got {n}")))?;
        with_dims!(self.nx, self.nu, edit_safe(&mut self.inner, Edit::Horizon(n)))?;
        Ok(())
    }

    /// The active horizon.
    #[getter]
    fn horizon(&mut self) -> PyResult<usize> {
        Ok(with_dims!(self.nx, self.nu, edit_safe(&mut self.inner, Edit::Get))?)
    }

    /// Number of states.
    #[getter]
    fn nx(&self) -> usize {
        self.nx
    }

    /// Number of controls.
    #[getter]
    fn nu(&self) -> usize {
        self.nu
    }

    fn __repr__(&mut self) -> String {
        let n = self.horizon().unwrap_or(0);
        format!("SafeCddpSolver(nx={}, nu={}, horizon={n})", self.nx, self.nu)
    }
}

/// The result of :meth:`SafeCddpSolver.solve`.
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct SafeSolution {
    // The arrays (numpy arrays once read; see the getters).
    xs: LazyArray,
    us: LazyArray,
    gains: LazyArray,
    feedforward: LazyArray,
    propagation_gains: LazyArray,
    covariances: LazyArray,
    margins: LazyArray,
    /// `"converged"`, `"max_iterations"`, `"regularization_limit"`, `"line_search_failed"`,
    /// `"infeasible"`, `"qp_failed"` or `"numerical_error"`.
    #[pyo3(get)]
    status: String,
    /// Accepted steps.
    #[pyo3(get)]
    iterations: usize,
    /// Iterations of the `"portfolio"` start whose solution was not kept.
    #[pyo3(get)]
    discarded_iterations: usize,
    /// Final cost.
    #[pyo3(get)]
    cost: f64,
    /// Largest violation of an original constraint.
    #[pyo3(get)]
    max_violation: f64,
    /// Largest violation of a tightened row.
    #[pyo3(get)]
    max_violation_tightened: f64,
    /// Tightenings performed.
    #[pyo3(get)]
    tightenings: usize,
    /// Wall time of the solve inside Rust (s).
    #[pyo3(get)]
    solve_time: f64,
    /// The starts as Python dicts, made at the first read (see the getter).
    starts: PyOnceLock<Py<PyList>>,
    table: Table,
}

/// The fields of a `SafeSolution` as pickled, in order.
const SAFE_SOLUTION_FIELDS: [&str; 17] = [
    "xs",
    "us",
    "K",
    "k",
    "propagation_gains",
    "covariances",
    "margins",
    "status",
    "iterations",
    "discarded_iterations",
    "cost",
    "max_violation",
    "max_violation_tightened",
    "tightenings",
    "solve_time",
    "table",
    "starts",
];

impl SafeSolution {
    /// A solution from its pickled fields.
    pub(crate) fn from_state(d: &Bound<'_, PyDict>) -> PyResult<Self> {
        let py = d.py();
        Ok(Self {
            xs: LazyArray::ready(py, field(d, "xs")?),
            us: LazyArray::ready(py, field(d, "us")?),
            gains: LazyArray::ready(py, field(d, "K")?),
            feedforward: LazyArray::ready(py, field(d, "k")?),
            propagation_gains: LazyArray::ready(py, field(d, "propagation_gains")?),
            covariances: LazyArray::ready(py, field(d, "covariances")?),
            margins: LazyArray::ready(py, field(d, "margins")?),
            status: field(d, "status")?,
            iterations: field(d, "iterations")?,
            discarded_iterations: field(d, "discarded_iterations")?,
            cost: field(d, "cost")?,
            max_violation: field(d, "max_violation")?,
            max_violation_tightened: field(d, "max_violation_tightened")?,
            tightenings: field(d, "tightenings")?,
            solve_time: field(d, "solve_time")?,
            table: Table::Text(field(d, "table")?),
            // Absent from the pickles of earlier versions.
            starts: {
                let list = match d.get_item("starts")? {
                    Some(v) => v
                        .cast_into::<PyList>()
                        .map_err(|_| -> PyErr {
                            crate::errors::invalid("state['starts']", "has the wrong type: not a list").into()
                        })?
                        .unbind(),
                    None => PyList::empty(py).unbind(),
                };
                let cell = PyOnceLock::new();
                // (A new cell: setting it cannot fail.)
                let _ = cell.set(py, list);
                cell
            },
        })
    }

    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let values: [Bound<'py, PyAny>; 17] = [
            self.xs.get(py)?,
            self.us.get(py)?,
            self.gains.get(py)?,
            self.feedforward.get(py)?,
            self.propagation_gains.get(py)?,
            self.covariances.get(py)?,
            self.margins.get(py)?,
            self.status.clone().into_pyobject(py)?.into_any(),
            self.iterations.into_pyobject(py)?.into_any(),
            self.discarded_iterations.into_pyobject(py)?.into_any(),
            self.cost.into_pyobject(py)?.into_any(),
            self.max_violation.into_pyobject(py)?.into_any(),
            self.max_violation_tightened.into_pyobject(py)?.into_any(),
            self.tightenings.into_pyobject(py)?.into_any(),
            self.solve_time.into_pyobject(py)?.into_any(),
            self.table.text().into_pyobject(py)?.into_any(),
            self.starts(py)?.into_any(),
        ];
        for (k, v) in SAFE_SOLUTION_FIELDS.iter().zip(values) {
            d.set_item(k, v)?;
        }
        Ok(d)
    }

    fn from_out(o: Out, nx: usize, nu: usize) -> Self {
        let n = o.n;
        let r = o.report;
        Self {
            xs: LazyArray::new(&[n + 1, nx], o.xs),
            us: LazyArray::new(&[n, nu], o.us),
            gains: LazyArray::new(&[n, nu, nx], o.gains),
            feedforward: LazyArray::new(&[n, nu], o.feedforward),
            propagation_gains: LazyArray::new(&[n, nu, nx], o.propagation_gains),
            covariances: LazyArray::new(&[n + 1, nx, nx], o.covariances),
            margins: LazyArray::new(&[n, o.rows], o.margins),
            status: r.status.as_str().to_string(),
            iterations: r.iterations,
            discarded_iterations: r.discarded_iterations,
            cost: r.cost,
            max_violation: r.max_violation,
            max_violation_tightened: r.max_violation_tightened,
            tightenings: r.tightenings,
            solve_time: r.solve_time.as_secs_f64(),
            starts: PyOnceLock::new(),
            table: Table::Safe(Box::new(r)),
        }
    }
}

/// The starts of a portfolio solve as a list of dicts (`SafeSolution.starts`).
fn starts_list<'py>(py: Python<'py>, starts: &[safe_cddp::StartReport]) -> PyResult<Bound<'py, PyList>> {
    use pyo3::intern;
    let list = PyList::empty(py);
    for st in starts {
        let d = PyDict::new(py);
        let warm_up = if st.warm_up == WarmUp::None {
            "polish"
        } else {
            st.warm_up.as_str()
        };
        d.set_item(intern!(py, "warm_up"), warm_up)?;
        d.set_item(intern!(py, "barrier_mu_init"), st.barrier_mu_init)?;
        d.set_item(intern!(py, "flip"), st.flip)?;
        d.set_item(intern!(py, "mirror"), st.mirror)?;
        d.set_item(intern!(py, "plan"), st.plan)?;
        d.set_item(intern!(py, "from_kept"), st.from_kept)?;
        d.set_item(intern!(py, "iterations"), st.iterations)?;
        d.set_item(intern!(py, "cost"), st.cost)?;
        d.set_item(intern!(py, "max_violation"), st.max_violation)?;
        d.set_item(intern!(py, "status"), st.status.as_str())?;
        d.set_item(intern!(py, "outcome"), st.outcome.as_str())?;
        list.append(d)?;
    }
    Ok(list)
}

#[pymethods]
impl SafeSolution {
    /// States `x_0 .. x_n`, shape `(n+1, nx)`.
    #[getter]
    fn xs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.xs.get(py)
    }
    /// Controls, shape `(n, nu)`.
    #[getter]
    fn us<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.us.get(py)
    }
    /// Feedback gains of the last backward pass (eq. 12), shape `(n, nu, nx)`.
    #[getter(K)]
    fn gains<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.gains.get(py)
    }
    /// Feed-forward terms (eq. 12), shape `(n, nu)`.
    #[getter(k)]
    fn feedforward<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.feedforward.get(py)
    }
    /// Gains of the last covariance propagation (eq. 19), shape `(n, nu, nx)`.
    #[getter]
    fn propagation_gains<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.propagation_gains.get(py)
    }
    /// Covariances `Sigma_0 .. Sigma_n` of the last tightening (eq. 19), shape `(n+1, nx, nx)`.
    #[getter]
    fn covariances<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.covariances.get(py)
    }
    /// Margins of every row of every knot (eq. 20), shape `(n, rows)`: the constraints' rows in
    /// order, then two per control bound.
    #[getter]
    fn margins<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.margins.get(py)
    }
    /// The starts of a ``"portfolio"`` cold solve in the order they ran (empty otherwise), each a
    /// dict: ``warm_up`` (``"augmented_lagrangian"``, ``"barrier"``, or ``"polish"`` for the
    /// KKT/QP iterations from the kept solution), ``barrier_mu_init`` (the third start's initial
    /// barrier weight, else ``None``), ``flip`` (for a flipped start, ``portfolio_flip``: the
    /// index of the constraint whose other side it was steered to, else ``None``), ``mirror``
    /// (``True`` for the start steered to the other side of every obstacle, ``portfolio_mirror``),
    /// ``plan`` (``True`` for the starts steered round the obstacles on the sides of their
    /// shortest path, ``portfolio_plan``), ``from_kept`` (``True`` for a start from the kept
    /// solution's controls rather than the initial guess: the polish and the second planned
    /// start), ``iterations``, ``cost``, ``max_violation`` (tightened rows), ``status`` and ``outcome``: ``"kept"``, ``"polished"`` (kept until the polish went
    /// on from it), ``"discarded"``, ``"same_side"`` (stopped at the end of its homotopy on the
    /// kept solution's sides), ``"stalled"`` (stopped where, at the rate its cost fell, it
    /// could not reach the kept cost within its iterations) or ``"abandoned"`` (stopped more
    /// than ``portfolio_abandon`` above the kept cost, or where its dual bound was more than
    /// ``portfolio_dual_bound`` above it).
    #[getter]
    fn starts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = self.starts.get_or_try_init(py, || -> PyResult<Py<PyList>> {
            let starts = match &self.table {
                Table::Safe(r) => r.starts.as_slice(),
                // (Unpickled solutions come with their list.)
                _ => &[],
            };
            Ok(starts_list(py, starts)?.unbind())
        })?;
        Ok(list.bind(py).clone())
    }
    /// Whether the solve converged.
    #[getter]
    fn converged(&self) -> bool {
        self.status == "converged"
    }
    /// The iteration table (deterministic: no timings).
    fn table(&self) -> String {
        self.table.text()
    }
    /// Pickles as its fields (arrays, statistics and the iteration table).
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (&'static str, Bound<'py, PyDict>))> {
        Ok((
            crate::pickle::module_attr(py, "_unpickle_result")?,
            ("SafeSolution", self.state(py)?),
        ))
    }
    /// Equal when every field is (arrays by value, the iteration table by text).
    fn __eq__(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        match other.cast::<SafeSolution>() {
            Ok(o) => crate::pickle::equal_values(self.state(py)?.as_any(), o.get().state(py)?.as_any()),
            Err(_) => Ok(false),
        }
    }
    fn __repr__(&self) -> String {
        format!(
            "SafeSolution(status='{}', iterations={}, cost={:.10e}, max_violation={:.3e})",
            self.status, self.iterations, self.cost, self.max_violation
        )
    }
}

// ------------------------------------------------------------------------------------------------
// MPC

struct MpcArgs {
    goal: Arr,
    goal_indices: Vec<usize>,
    goal_radius: f64,
    iterations: usize,
    initial_iterations: usize,
    position_indices: [usize; 2],
}

fn new_mpc<NX: Dim, NU: Dim>(
    p: &AnyProblem,
    specs: &[Arc<Spec>],
    tightening: Option<&Tightening>,
    sigma_w: &Arr,
    settings: Settings,
    a: &MpcArgs,
) -> CoreResult<AnyMpc>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU> + SafePair<NX, NU>,
{
    let p = problem_of::<NX, NU>(p)?;
    let per_knot = 40 * p.dims().nx() * p.dims().nx() * std::mem::size_of::<f64>();
    crate::convert::check_allocation("horizon", p.horizon() + 1, per_knot)?;
    let mpc = MpcSettings {
        iterations: a.iterations,
        initial_iterations: a.initial_iterations,
        goal: a.goal.vector("goal", p.dims().nx)?,
        goal_indices: a.goal_indices.clone(),
        goal_radius: a.goal_radius,
        position_indices: a.position_indices,
    };
    let m = CoreMpc::new(
        p,
        typed_constraints(specs, p.dims())?,
        vec![],
        settings,
        tightening.map(|t| t.build(p.dims())).transpose()?,
        sigma_w.matrix("sigma_w", p.dims().nx, p.dims().nx)?,
        mpc,
    )?;
    Ok(<Dispatch as SafePair<NX, NU>>::wrap_mpc(m))
}

struct EpisodeOut {
    success: bool,
    steps: usize,
    collisions: usize,
    infeasible_steps: usize,
    xs: Vec<f64>,
    us: Vec<f64>,
}

fn run_mpc<NX: Dim, NU: Dim>(m: &mut AnyMpc, seed: u64) -> CoreResult<EpisodeOut>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU> + SafePair<NX, NU>,
{
    let m = <Dispatch as SafePair<NX, NU>>::mpc(m).ok_or_else(|| internal_mismatch("mpc"))?;
    let e = m.run_episode(seed)?;
    Ok(EpisodeOut {
        success: e.success,
        steps: e.steps,
        collisions: e.collisions,
        infeasible_steps: e.infeasible_steps,
        xs: e.xs.iter().flat_map(|x| x.iter().copied()).collect(),
        us: e.us.iter().flat_map(|u| u.iter().copied()).collect(),
    })
}

/// Shrinking-horizon MPC with Safe-CDDP (Algorithm 1) under seeded Gaussian process noise.
///
/// Per step: ``iterations`` (``n1``) solver iterations, tightening every ``n2``
/// (:attr:`Tightening.update_every`); the first control is applied to the true state
/// ``x+ = f(x, u0) + w``, ``w ~ N(0, sigma_w)``; the trajectory is shifted and the horizon
/// shortened. An episode ends at the goal region (``goal_radius`` around ``goal`` on
/// ``goal_indices``) or when the horizon runs out. Collisions are steps whose true state
/// violates an original (untightened) state constraint. Uses a copy of the problem taken at
/// construction. Pickles as its constructor's arguments (the unpickled controller starts afresh;
/// episodes depend only on the seed, so it runs the same episodes).
#[pyclass(module = "ddpkit._ddpkit")]
pub struct Mpc {
    /// `(problem, constraints, sigma_w, goal)` as validated (constraints as a list, arrays as
    /// float arrays) and the keyword arguments, for pickling and equality.
    source: Py<PyTuple>,
    options: Py<PyDict>,
    inner: AnyMpc,
    nx: usize,
    nu: usize,
}

#[pymethods]
impl Mpc {
    #[new]
    #[pyo3(signature = (problem, constraints, sigma_w, goal, tightening = None,
                        goal_indices = default_goal_indices(),
                        goal_radius = mpc_default().goal_radius,
                        iterations = mpc_default().iterations as i64,
                        initial_iterations = mpc_default().initial_iterations as i64,
                        position_indices = default_position_indices(),
                        max_iterations = MPC_MAX_ITERATIONS as i64))]
    // The defaults as Python sees them; tests compare them and the stub with `default_settings`.
    #[pyo3(
        text_signature = "(problem, constraints, sigma_w, goal, tightening=None, goal_indices=[0, 1], \
                             goal_radius=0.1, iterations=10, initial_iterations=50, position_indices=(0, 1), \
                             max_iterations=400)"
    )]
    #[allow(clippy::too_many_arguments)]
    fn new(
        problem: Bound<'_, Problem>,
        constraints: &Bound<'_, PyAny>,
        sigma_w: &Bound<'_, PyAny>,
        goal: &Bound<'_, PyAny>,
        tightening: Option<Bound<'_, Tightening>>,
        goal_indices: Vec<i64>,
        goal_radius: f64,
        #[pyo3(from_py_with = crate::convert::int_i64)] iterations: i64,
        #[pyo3(from_py_with = crate::convert::int_i64)] initial_iterations: i64,
        position_indices: (i64, i64),
        #[pyo3(from_py_with = crate::convert::int_i64)] max_iterations: i64,
    ) -> PyResult<Self> {
        let (sigma_w_in, goal_in) = (sigma_w.clone(), goal.clone());
        let specs = extract_constraints(constraints)?;
        let d = Settings::default();
        let settings = settings_from(
            method_name(d.method),
            max_iterations,
            d.constraint_tolerance,
            qp_name(d.qp_method),
            d.warm_up.as_str(),
            d.portfolio_polish,
            d.portfolio_new_side,
            d.portfolio_threads as i64,
            d.portfolio_third_mu,
            d.portfolio_apart,
            d.portfolio_flip,
            d.portfolio_flip_apart,
            d.portfolio_flip_starts as i64,
            default_mirror(),
            default_plan(),
            d.portfolio_abandon,
            d.portfolio_dual_bound,
            Some(d.barrier_funnel),
            d.barrier_mu_init,
            d.barrier_relaxation,
            d.al_inner_progress,
        )?;
        let p = problem.get();
        let (nx, nu) = (p.nx, p.nu);
        let sigma_w = finite_arr(sigma_w, "sigma_w")?;
        sigma_w.expect_shape("sigma_w", &[nx, nx])?;
        check_tightening(0.9, &sigma_w)?;
        let goal = finite_arr(goal, "goal")?;
        let count = |v: i64, field: &str| -> PyResult<usize> {
            usize::try_from(v)
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| invalid(field, format!("must be at least 1, got {v}")).into())
        };
        let args = MpcArgs {
            goal,
            goal_indices: goal_indices
                .iter()
                .enumerate()
                .map(|(i, &v)| index_arg(v, &format!("goal_indices[{i}]")))
                .collect::<PyResult<_>>()?,
            goal_radius,
            iterations: count(iterations, "iterations")?,
            initial_iterations: count(initial_iterations, "initial_iterations")?,
            position_indices: [
                index_arg(position_indices.0, "position_indices[0]")?,
                index_arg(position_indices.1, "position_indices[1]")?,
            ],
        };
        let t = tightening.as_ref().map(|t| t.get());
        let inner = Problem::read(&p.inner, |q| {
            with_dims!(nx, nu, new_mpc(q, &specs, t, &sigma_w, settings, &args))
        })?;
        let py = problem.py();
        let np = py.import("numpy")?;
        let constraints = PyList::new(py, constraints.try_iter()?.collect::<PyResult<Vec<_>>>()?)?;
        let source = PyTuple::new(
            py,
            [
                problem.into_any(),
                constraints.into_any(),
                np.call_method1("array", (&sigma_w_in, "float64"))?,
                np.call_method1("array", (&goal_in, "float64"))?,
            ],
        )?
        .unbind();
        let options = PyDict::new(py);
        options.set_item("tightening", tightening)?;
        options.set_item("goal_indices", goal_indices)?;
        options.set_item("goal_radius", goal_radius)?;
        options.set_item("iterations", iterations)?;
        options.set_item("initial_iterations", initial_iterations)?;
        options.set_item("position_indices", position_indices)?;
        options.set_item("max_iterations", max_iterations)?;
        Ok(Self {
            source,
            options: options.unbind(),
            inner,
            nx,
            nu,
        })
    }

    /// Pickles as its constructor's arguments.
    #[allow(clippy::type_complexity)]
    fn __getnewargs_ex__<'py>(&self, py: Python<'py>) -> (Bound<'py, PyTuple>, Bound<'py, PyDict>) {
        (self.source.bind(py).clone(), self.options.bind(py).clone())
    }

    /// Equal when the constructor's arguments are (arrays by value).
    fn __eq__(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        let Ok(o) = other.cast::<Mpc>() else {
            return Ok(false);
        };
        let o = o.try_borrow()?;
        Ok(crate::pickle::equal_values(self.source.bind(py), o.source.bind(py))?
            && crate::pickle::equal_values(self.options.bind(py), o.options.bind(py))?)
    }

    /// Runs one episode from the problem's ``x0`` with the noise of ``seed`` (deterministic for
    /// a seed); the GIL is released meanwhile.
    fn run_episode(
        &mut self,
        py: Python<'_>,
        #[pyo3(from_py_with = crate::convert::int_u64)] seed: u64,
    ) -> PyResult<Episode> {
        let (nx, nu) = (self.nx, self.nu);
        let inner = &mut self.inner;
        let e = py.detach(|| -> CoreResult<EpisodeOut> { with_dims!(nx, nu, run_mpc(inner, seed)) });
        crate::callable::raise_pending()?;
        let e = e?;
        Ok(Episode {
            success: e.success,
            steps: e.steps,
            collisions: e.collisions,
            infeasible_steps: e.infeasible_steps,
            xs: rows_to_numpy(py, e.steps + 1, nx, e.xs)?.unbind(),
            us: rows_to_numpy(py, e.steps, nu, e.us)?.unbind(),
        })
    }

    fn __repr__(&self) -> String {
        format!("Mpc(nx={}, nu={})", self.nx, self.nu)
    }
}

/// One MPC episode (:meth:`Mpc.run_episode`).
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct Episode {
    /// The goal region was reached.
    #[pyo3(get)]
    success: bool,
    /// MPC steps applied.
    #[pyo3(get)]
    steps: usize,
    /// Steps whose true state violated an original constraint.
    #[pyo3(get)]
    collisions: usize,
    /// Steps at which the solver reported an infeasible QP or trajectory.
    #[pyo3(get)]
    infeasible_steps: usize,
    /// True states, shape `(steps+1, nx)`.
    #[pyo3(get)]
    xs: Py<PyAny>,
    /// Applied controls, shape `(steps, nu)`.
    #[pyo3(get)]
    us: Py<PyAny>,
}

impl Episode {
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("success", self.success)?;
        d.set_item("steps", self.steps)?;
        d.set_item("collisions", self.collisions)?;
        d.set_item("infeasible_steps", self.infeasible_steps)?;
        d.set_item("xs", self.xs.bind(py))?;
        d.set_item("us", self.us.bind(py))?;
        Ok(d)
    }

    /// Rebuilds a pickled episode from its fields.
    pub fn from_state(state: &Bound<'_, PyDict>) -> PyResult<Self> {
        use crate::pickle::field;
        let array = |key: &str| -> PyResult<Py<PyAny>> {
            let v: Bound<'_, PyAny> = field(state, key)?;
            if !v.hasattr("__array_interface__")? {
                return Err(invalid(format!("state['{key}']"), "must be a numpy array").into());
            }
            Ok(v.unbind())
        };
        Ok(Self {
            success: field(state, "success")?,
            steps: field(state, "steps")?,
            collisions: field(state, "collisions")?,
            infeasible_steps: field(state, "infeasible_steps")?,
            xs: array("xs")?,
            us: array("us")?,
        })
    }
}

#[pymethods]
impl Episode {
    /// Pickles as its fields.
    #[allow(clippy::type_complexity)]
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (&'static str, Bound<'py, PyDict>))> {
        Ok((
            crate::pickle::module_attr(py, "_unpickle_result")?,
            ("Episode", self.state(py)?),
        ))
    }
    /// Equal when every field is (arrays by value).
    fn __eq__(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        match other.cast::<Episode>() {
            Ok(o) => crate::pickle::equal_values(self.state(py)?.as_any(), o.get().state(py)?.as_any()),
            Err(_) => Ok(false),
        }
    }
    fn __repr__(&self) -> String {
        format!(
            "Episode(success={}, steps={}, collisions={})",
            if self.success { "True" } else { "False" },
            self.steps,
            self.collisions
        )
    }
}

/// Adds the Safe-CDDP classes to the extension module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Constraint>()?;
    m.add_class::<Circle>()?;
    m.add_class::<PyCallableConstraint>()?;
    m.add_class::<ConvexPolygon>()?;
    m.add_class::<Cylinder>()?;
    m.add_class::<StateBox>()?;
    m.add_class::<ControlBox>()?;
    m.add_class::<Tightening>()?;
    m.add_class::<SafeCddpSolver>()?;
    m.add_function(wrap_pyfunction!(solve_batch_safe, m)?)?;
    m.add_class::<SafeSolution>()?;
    m.add_class::<Mpc>()?;
    m.add_class::<Episode>()?;
    Ok(())
}

// ------------------------------------------------------------------------------------------------
// Batch solves.

/// The constraints of a batch: one list for every problem, or one list per problem (a sequence
/// of lists or tuples as long as `problems`); errors name `constraints` or `constraints[i]`.
fn batch_constraints(obj: &Bound<'_, PyAny>, count: usize) -> PyResult<Vec<Vec<Arc<Spec>>>> {
    let nested = |o: &Bound<'_, PyAny>| o.is_instance_of::<pyo3::types::PyList>() || o.is_instance_of::<PyTuple>();
    // Lazily: a huge iterable is rejected at its first wrong item, never collected.
    let mut iter = obj.try_iter()?;
    let first = match iter.next() {
        None => return Ok(vec![Vec::new()]),
        Some(first) => first?,
    };
    if !nested(&first) {
        return Ok(vec![extract_constraints(obj)?]);
    }
    let wrong_count = |got: String| {
        crate::errors::shape(
            "constraints",
            got,
            format!("{count} lists (one per problem) or one list of constraints for all"),
        )
    };
    let mut out = vec![extract_constraints_at(&first, "constraints[0]")?];
    for (i, item) in iter.enumerate() {
        let (i, item) = (i + 1, item?);
        if i >= count {
            return Err(wrong_count(format!("more than {count} lists")).into());
        }
        if !nested(&item) {
            return Err(invalid(
                format!("constraints[{i}]"),
                format!(
                    "must be a list of constraints (like constraints[0]), got {}",
                    type_name(&item)
                ),
            )
            .into());
        }
        out.push(extract_constraints_at(&item, &format!("constraints[{i}]"))?);
    }
    if out.len() != count {
        return Err(wrong_count(format!("{} lists", out.len())).into());
    }
    Ok(out)
}

/// Every problem of a Safe-CDDP batch, each with a fresh workspace, as `SafeCddpSolver.solve()`.
fn safe_batch_impl<NX: Dim, NU: Dim>(
    problems: &[&AnyProblem],
    specs: &[Vec<Arc<Spec>>],
    tightening: Option<&Tightening>,
    settings: Settings,
    threads: usize,
) -> Result<Vec<Out>, crate::batch::BatchError>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU> + SafePair<NX, NU>,
{
    crate::batch::run(
        problems,
        threads,
        || Ok(()),
        |_, i, p| {
            let spec = if specs.len() == 1 { &specs[0] } else { &specs[i] };
            let mut s = new_safe::<NX, NU>(p, spec, tightening, settings)?;
            solve_safe::<NX, NU>(&mut s, p, None, false)
        },
    )
}

/// Solves many Safe-CDDP problems of one structure (same ``nx``, ``nu`` and horizon) on
/// ``threads`` threads in one call, each from a cold start with the settings of
/// :class:`SafeCddpSolver` (same keywords and defaults), and returns their
/// :class:`SafeSolution`\ s in order. The GIL is released meanwhile.
///
/// ``constraints`` is one list for every problem, or a list of lists, one per problem;
/// ``tightening`` (or None) applies to every problem. Each solution equals
/// ``SafeCddpSolver(problem, constraints, tightening, **settings).solve()`` alone, bit for bit,
/// whatever the thread count (each problem gets a fresh Safe-CDDP workspace on its worker).
/// ``threads=None`` uses ``RAYON_NUM_THREADS`` when set, else every core.
///
/// Errors, before any solve: as :func:`solve_batch`, and constraints that do not fit (naming
/// ``constraints`` or ``problems[i]``).
#[pyfunction]
#[pyo3(signature = (problems, constraints, tightening = None, *, threads = None,
                    method = method_name(Settings::default().method),
                    max_iterations = Settings::default().max_iterations as i64,
                    constraint_tolerance = Settings::default().constraint_tolerance,
                    qp_method = qp_name(Settings::default().qp_method),
                    warm_up = Settings::default().warm_up.as_str(),
                    portfolio_polish = Settings::default().portfolio_polish,
                    portfolio_new_side = Settings::default().portfolio_new_side,
                    portfolio_threads = Settings::default().portfolio_threads as i64,
                    portfolio_third_mu = Settings::default().portfolio_third_mu,
                    portfolio_apart = Settings::default().portfolio_apart,
                        portfolio_flip = Settings::default().portfolio_flip,
                        portfolio_flip_apart = Settings::default().portfolio_flip_apart,
                        portfolio_flip_starts = Settings::default().portfolio_flip_starts as i64,
                        portfolio_mirror = default_mirror(),
                        portfolio_plan = default_plan(),
                        portfolio_abandon = Settings::default().portfolio_abandon,
                        portfolio_dual_bound = Settings::default().portfolio_dual_bound,
                        barrier_funnel = Some(Settings::default().barrier_funnel),
                        barrier_mu_init = Settings::default().barrier_mu_init,
                        barrier_relaxation = Settings::default().barrier_relaxation,
                        al_inner_progress = Settings::default().al_inner_progress))]
#[pyo3(
    text_signature = "(problems, constraints, tightening=None, *, threads=None, method='ilqr', max_iterations=200, \
                         constraint_tolerance=1e-8, qp_method='fast', warm_up='portfolio', \
                             portfolio_polish=True, portfolio_new_side=1.2, portfolio_threads=1, portfolio_third_mu=0.003, \
                             portfolio_apart=0.001, portfolio_flip=1.5, portfolio_flip_apart=1.25, portfolio_flip_starts=2, portfolio_mirror=5, portfolio_plan=5, portfolio_abandon=0.3, portfolio_dual_bound=0.01, barrier_funnel=0.03, barrier_mu_init=0.03, \
                             barrier_relaxation=0.1, al_inner_progress=1.0)"
)]
#[allow(clippy::too_many_arguments)]
fn solve_batch_safe(
    py: Python<'_>,
    problems: &Bound<'_, PyAny>,
    constraints: &Bound<'_, PyAny>,
    tightening: Option<Bound<'_, Tightening>>,
    #[pyo3(from_py_with = crate::convert::opt_int_i64)] threads: Option<i64>,
    method: &str,
    #[pyo3(from_py_with = crate::convert::int_i64)] max_iterations: i64,
    constraint_tolerance: f64,
    qp_method: &str,
    warm_up: &str,
    portfolio_polish: bool,
    portfolio_new_side: Option<f64>,
    #[pyo3(from_py_with = crate::convert::int_i64)] portfolio_threads: i64,
    portfolio_third_mu: Option<f64>,
    portfolio_apart: f64,
    portfolio_flip: Option<f64>,
    portfolio_flip_apart: f64,
    #[pyo3(from_py_with = crate::convert::int_i64)] portfolio_flip_starts: i64,
    #[pyo3(from_py_with = crate::convert::opt_int_i64)] portfolio_mirror: Option<i64>,
    #[pyo3(from_py_with = crate::convert::opt_int_i64)] portfolio_plan: Option<i64>,
    portfolio_abandon: Option<f64>,
    portfolio_dual_bound: Option<f64>,
    barrier_funnel: Option<f64>,
    barrier_mu_init: f64,
    barrier_relaxation: f64,
    al_inner_progress: f64,
) -> PyResult<Vec<SafeSolution>> {
    let settings = settings_from(
        method,
        max_iterations,
        constraint_tolerance,
        qp_method,
        warm_up,
        portfolio_polish,
        portfolio_new_side,
        portfolio_threads,
        portfolio_third_mu,
        portfolio_apart,
        portfolio_flip,
        portfolio_flip_apart,
        portfolio_flip_starts,
        portfolio_mirror,
        portfolio_plan,
        portfolio_abandon,
        portfolio_dual_bound,
        barrier_funnel,
        barrier_mu_init,
        barrier_relaxation,
        al_inner_progress,
    )?;
    let batch = crate::batch::problems_of(problems)?;
    let threads = crate::batch::threads_of(threads)?;
    let specs = batch_constraints(constraints, batch.locks.len())?;
    let (nx, nu) = (batch.nx, batch.nu);
    let t = tightening.as_ref().map(|t| t.get());
    let locks = &batch.locks;
    let outs = py.detach(|| {
        crate::batch::read_all(locks, |ps| {
            with_dims!(nx, nu, safe_batch_impl(ps, &specs, t, settings, threads))
        })
    })?;
    Ok(outs.into_iter().map(|o| SafeSolution::from_out(o, nx, nu)).collect())
}
