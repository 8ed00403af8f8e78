//! Cost terms: dimension-agnostic specifications, validated as far as possible when constructed
//! (finiteness, signs, squareness, PSD) and against the state and control dimensions when a
//! `Problem` is built (or `value` is called), with errors naming the argument path.

use std::sync::Arc;

use ddp_core::costs::{
    ControlSquared as CoreControlSquared, CostSum as CoreCostSum, ObstacleHinge as CoreObstacleHinge,
    QuadraticCost as CoreQuadratic, QuadraticTerminal as CoreQuadraticTerminal, SmoothDistance as CoreSmoothDistance,
    StateOnly, TerminalSum as CoreTerminalSum,
};
use ddp_core::dims::{
    check_size, Alloc, Const, DefaultAllocator, Dim, Dyn, MatrixN, VectorN, MAX_CONTROLS, MAX_STATES, U1,
};
use ddp_core::penalty::CirclePenalty as CoreCirclePenalty;
use ddp_core::{Cost as CoreCost, TerminalCost as CoreTerminalCost};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};

use crate::convert::{finite_arr, shape_str, Arr};
use crate::dims::{dims, nu_for, Dispatch, Pair};
use crate::errors::{invalid, shape, CoreError, CoreResult};
use crate::models::type_name;

/// A weight matrix given as `(n, n)` or as its diagonal `(n,)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Weight {
    n: usize,
    /// Row-major `n x n` entries.
    data: Vec<f64>,
}

impl Weight {
    /// Checks squareness, the size (`1 <= n <= limit`), finiteness, symmetry and PSD, naming
    /// `field`.
    fn new(a: Arr, field: &str, limit: usize) -> CoreResult<Self> {
        let a = a.finite(field)?;
        let n = match a.shape.as_slice() {
            [n] => *n,
            [n, m] if n == m => *n,
            _ => return Err(shape(field, shape_str(&a.shape), "(n, n) or its diagonal (n,)")),
        };
        // Before the diagonal is expanded to n x n.
        check_size(&format!("{field}.shape[0]"), n, None, limit)?;
        let data = match a.shape.as_slice() {
            [_] => {
                let mut d = vec![0.0; n * n];
                for (i, v) in a.data.iter().enumerate() {
                    if *v < 0.0 {
                        return Err(invalid(
                            format!("{field}[{i}]"),
                            format!("diagonal weight must be non-negative, got {v}"),
                        ));
                    }
                    d[i * n + i] = *v;
                }
                d
            }
            _ => a.data,
        };
        let w = Self { n, data };
        w.check_psd(field)?;
        Ok(w)
    }

    fn check_psd(&self, field: &str) -> CoreResult<()> {
        let n = self.n;
        let scale = self.data.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        for i in 0..n {
            for j in 0..i {
                let d = (self.data[i * n + j] - self.data[j * n + i]).abs();
                if d > 1e-9 * scale {
                    return Err(CoreError(ddp_core::Error::NotPsd {
                        field: field.to_string(),
                        reason: format!("not symmetric ({field}[{i}, {j}] != {field}[{j}, {i}])"),
                    }));
                }
            }
        }
        if n > 0 {
            let m = nalgebra::DMatrix::from_row_slice(n, n, &self.data);
            let min = m.symmetric_eigenvalues().min();
            if min < -1e-10 * scale {
                return Err(CoreError(ddp_core::Error::NotPsd {
                    field: field.to_string(),
                    reason: format!("smallest eigenvalue is {min:e}"),
                }));
            }
        }
        Ok(())
    }

    /// The weight as an `n x n` matrix (checked PSD when made; ddp-core checks it again).
    fn typed<N: Dim>(&self, field: &str, n: N) -> CoreResult<MatrixN<N, N>>
    where
        DefaultAllocator: Alloc<N, N>,
    {
        if self.n != n.value() {
            return Err(shape(
                field,
                shape_str(&[self.n, self.n]),
                shape_str(&[n.value(), n.value()]),
            ));
        }
        Ok(MatrixN::from_row_slice_generic(n, n, &self.data))
    }

    fn to_numpy<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::convert::rows_to_numpy(py, self.n, self.n, self.data.clone())
    }
}

/// A cost term with its parameters, independent of `(nx, nu)`.
#[derive(Debug, Clone, PartialEq)]
pub enum CostSpec {
    /// `1/2 (x-x_r)^T Q (x-x_r) + 1/2 (u-u_r)^T R (u-u_r)`.
    Quadratic {
        /// `Q`
        q: Weight,
        /// `R`
        r: Weight,
        /// `x_ref` (zeros when absent).
        x_ref: Option<Vec<f64>>,
        /// `u_ref` (zeros when absent).
        u_ref: Option<Vec<f64>>,
    },
    /// `1/2 (x-x_r)^T Qf (x-x_r)`.
    QuadraticTerminal {
        /// `Qf`
        qf: Weight,
        /// `x_ref` (zeros when absent).
        x_ref: Option<Vec<f64>>,
    },
    /// `w sum u^2`.
    ControlSquared {
        /// `w`
        weight: f64,
    },
    /// `w sqrt(|p - g|^2 + eps^2)`.
    SmoothDistance {
        /// `g`
        target: [f64; 2],
        /// State indices of `p`.
        indices: [usize; 2],
        /// `eps`
        eps: f64,
        /// `w`
        weight: f64,
    },
    /// `w sum_o ReLU(d - |p - o|)`.
    ObstacleHinge {
        /// Obstacle points.
        points: Vec<[f64; 2]>,
        /// `d`
        margin: f64,
        /// State indices of `p`.
        indices: [usize; 2],
        /// `w`
        weight: f64,
    },
    /// `w sum_o max(0, r_o^2 - |p - o|^2)^2`.
    CirclePenalty {
        /// `(ox, oy, r)` per obstacle.
        circles: Vec<[f64; 3]>,
        /// State indices of `p`.
        indices: [usize; 2],
        /// `w`
        weight: f64,
    },
    /// A tape: a traced function, a CasADi function or a loaded file (a running cost
    /// `l(x, u)` or a terminal cost `l(x)`).
    Tape(Arc<ddp_tape::TapeModel>),
    /// A plain Python callable (the slow path, finite differences).
    Callable(crate::callable::CallableCost),
    /// `sum_i w_i l_i` of running terms (`terminal == false`) or terminal terms.
    Sum {
        /// `(w_i, l_i)`
        terms: Vec<(f64, Arc<CostSpec>)>,
        /// Whether this is a `TerminalSum`.
        terminal: bool,
    },
}

impl CostSpec {
    /// Whether evaluating this cost calls Python (a `from_callable` cost, also inside a sum).
    pub(crate) fn calls_python(&self) -> bool {
        match self {
            CostSpec::Callable(_) => true,
            CostSpec::Sum { terms, .. } => terms.iter().any(|(_, t)| t.calls_python()),
            _ => false,
        }
    }

    /// The Python class name.
    fn kind(&self) -> &'static str {
        match self {
            CostSpec::Quadratic { .. } => "QuadraticCost",
            CostSpec::QuadraticTerminal { .. } => "QuadraticTerminal",
            CostSpec::ControlSquared { .. } => "ControlSquared",
            CostSpec::SmoothDistance { .. } => "SmoothDistance",
            CostSpec::ObstacleHinge { .. } => "ObstacleHinge",
            CostSpec::CirclePenalty { .. } => "CirclePenalty",
            CostSpec::Tape(_) => "TapeCost",
            CostSpec::Callable(_) => "CallableCost",
            CostSpec::Sum { terminal: false, .. } => "CostSum",
            CostSpec::Sum { terminal: true, .. } => "TerminalSum",
        }
    }

    /// Whether the term depends on the state only (usable as a terminal cost).
    pub fn state_only(&self) -> bool {
        match self {
            CostSpec::Quadratic { .. } | CostSpec::ControlSquared { .. } => false,
            CostSpec::Tape(m) => matches!(**m, ddp_tape::TapeModel::Terminal(_)),
            CostSpec::Callable(c) => c.terminal(),
            CostSpec::Sum { terminal, .. } => *terminal,
            _ => true,
        }
    }

    /// The running cost for the sizes `s`; errors name `field` and the parameter.
    pub fn running<NX: StateDim, NU: Dim>(
        &self,
        field: &str,
        s: ddp_core::Dims<NX, NU>,
    ) -> CoreResult<Arc<dyn CoreCost<NX, NU>>>
    where
        DefaultAllocator: Alloc<NX, NU>,
    {
        if self.state_only() {
            return Ok(Arc::new(StateOnly(self.terminal(field, s.nx)?)));
        }
        let ctx = |e: CoreError| e.context(field);
        Ok(match self {
            CostSpec::Quadratic { q, r, x_ref, u_ref } => Arc::new(
                CoreQuadratic::new(
                    q.typed("Q", s.nx).map_err(ctx)?,
                    r.typed("R", s.nu).map_err(ctx)?,
                    opt_vector(x_ref, "x_ref", s.nx).map_err(ctx)?,
                    opt_vector(u_ref, "u_ref", s.nu).map_err(ctx)?,
                )
                .map_err(|e| ctx(e.into()))?,
            ),
            CostSpec::ControlSquared { weight } => {
                Arc::new(CoreControlSquared::new(*weight).map_err(|e| ctx(e.into()))?)
            }
            CostSpec::Tape(m) => match &**m {
                ddp_tape::TapeModel::Cost(c) => {
                    check_pair(field, c.dims(), s.nx(), s.nu())?;
                    Arc::new(c.clone())
                }
                _ => {
                    return Err(crate::convert::internal(
                        "a running tape cost that is not a cost".into(),
                    ))
                }
            },
            CostSpec::Callable(c) => {
                check_pair(field, c.dims(), s.nx(), s.nu())?;
                Arc::new(c.clone())
            }
            CostSpec::Sum { terms, .. } => {
                let mut sum = CoreCostSum::<NX, NU>::new();
                for (i, (w, t)) in terms.iter().enumerate() {
                    let term = t.running(&format!("{field}.terms[{i}]"), s)?;
                    sum.push(*w, term)
                        .map_err(|e| CoreError::from(e).context(&format!("{field}.terms[{i}]")))?;
                }
                Arc::new(sum)
            }
            _ => return Err(crate::convert::internal(format!("{} is state-only", self.kind()))),
        })
    }

    /// The terminal cost for `nx` states; errors name `field` and the parameter.
    pub fn terminal<NX: StateDim>(&self, field: &str, nx: NX) -> CoreResult<Arc<dyn CoreTerminalCost<NX>>>
    where
        DefaultAllocator: Alloc<NX, NX>,
    {
        let ctx = |e: CoreError| e.context(field);
        let core = |e: ddp_core::Error| CoreError::from(e).context(field);
        Ok(match self {
            CostSpec::QuadraticTerminal { qf, x_ref } => Arc::new(
                CoreQuadraticTerminal::new(
                    qf.typed("Qf", nx).map_err(ctx)?,
                    opt_vector(x_ref, "x_ref", nx).map_err(ctx)?,
                )
                .map_err(core)?,
            ),
            CostSpec::SmoothDistance { .. } | CostSpec::ObstacleHinge { .. } | CostSpec::CirclePenalty { .. } => {
                NX::position_term(self, field)?
            }
            CostSpec::Tape(m) => match &**m {
                ddp_tape::TapeModel::Terminal(c) => {
                    check_pair(field, (c.nx(), 0), nx.value(), 0)?;
                    Arc::new(c.clone())
                }
                _ => {
                    return Err(crate::convert::internal(
                        "a terminal tape cost that is not terminal".into(),
                    ))
                }
            },
            CostSpec::Callable(c) if c.terminal() => {
                check_pair(field, (c.dims().0, 0), nx.value(), 0)?;
                Arc::new(c.clone())
            }
            CostSpec::Sum { terms, terminal: true } => {
                let mut sum = CoreTerminalSum::<NX>::new();
                for (i, (w, t)) in terms.iter().enumerate() {
                    let f = format!("{field}.terms[{i}]");
                    let term = t.terminal(&f, nx)?;
                    sum.push(*w, term).map_err(|e| CoreError::from(e).context(&f))?;
                }
                Arc::new(sum)
            }
            other => {
                return Err(invalid(
                    field,
                    format!(
                        "{} depends on the control u and cannot be a terminal cost (use QuadraticTerminal or \
                         another state-only term)",
                        other.kind()
                    ),
                ))
            }
        })
    }
}

/// A state dimension, with the planar-position terms (`SmoothDistance`, `ObstacleHinge`,
/// `CirclePenalty`) that ddp-core builds for compile-time sizes only: at a run-time size they are
/// an error naming the term.
pub trait StateDim: Dim {
    /// The position term of `spec` for this state dimension.
    fn position_term(spec: &CostSpec, field: &str) -> CoreResult<Arc<dyn CoreTerminalCost<Self>>>
    where
        DefaultAllocator: Alloc<Self, Self>;
}

impl<const NX: usize> StateDim for Const<NX> {
    fn position_term(spec: &CostSpec, field: &str) -> CoreResult<Arc<dyn CoreTerminalCost<Self>>> {
        let core = |e: ddp_core::Error| CoreError::from(e).context(field);
        Ok(match spec {
            CostSpec::SmoothDistance {
                target,
                indices,
                eps,
                weight,
            } => Arc::new(CoreSmoothDistance::<NX>::goal(*target, *indices, *eps, *weight).map_err(core)?),
            CostSpec::ObstacleHinge {
                points,
                margin,
                indices,
                weight,
            } => Arc::new(CoreObstacleHinge::<NX>::new(points.clone(), *margin, *indices, *weight).map_err(core)?),
            CostSpec::CirclePenalty {
                circles,
                indices,
                weight,
            } => Arc::new(CoreCirclePenalty::<NX>::new(circles.clone(), *indices, *weight).map_err(core)?),
            other => {
                return Err(crate::convert::internal(format!(
                    "{} is not a position term",
                    other.kind()
                )))
            }
        })
    }
}

impl StateDim for Dyn {
    fn position_term(spec: &CostSpec, field: &str) -> CoreResult<Arc<dyn CoreTerminalCost<Self>>> {
        let pairs: Vec<String> = crate::dims::PAIRS.iter().map(|p| p.0.to_string()).collect();
        Err(invalid(
            field,
            format!(
                "{} is available for the compiled state sizes only ({} states); use QuadraticCost / \
                 QuadraticTerminal at other sizes",
                spec.kind(),
                pairs.join(", ")
            ),
        ))
    }
}

/// Checks a user model's `(nx, nu)` against the problem's, naming `field`.
pub fn check_pair(field: &str, have: (usize, usize), nx: usize, nu: usize) -> CoreResult<()> {
    if have != (nx, nu) {
        let show = |(a, b): (usize, usize)| {
            if b == 0 {
                format!("nx = {a}")
            } else {
                format!("(nx, nu) = ({a}, {b})")
            }
        };
        return Err(shape(
            field,
            show(have),
            format!("{} (the problem's sizes)", show((nx, nu))),
        ));
    }
    Ok(())
}

fn opt_vector<N: Dim>(v: &Option<Vec<f64>>, field: &str, n: N) -> CoreResult<VectorN<N>>
where
    DefaultAllocator: Alloc<N, N>,
{
    match v {
        None => Ok(VectorN::zeros_generic(n, U1)),
        Some(v) if v.len() == n.value() => Ok(VectorN::from_row_slice_generic(n, U1, v)),
        Some(v) => Err(shape(field, shape_str(&[v.len()]), shape_str(&[n.value()]))),
    }
}

fn running_value<NX: StateDim, NU: Dim>(spec: &CostSpec, x: &Arr, u: &Arr) -> CoreResult<f64>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let s = dims::<NX, NU>(x.data.len(), u.data.len())?;
    let cost = spec.running("cost", s)?;
    Ok(cost.value(&x.vector("x", s.nx)?, &u.vector("u", s.nu)?))
}

fn terminal_value<NX: StateDim, NU: Dim>(spec: &CostSpec, x: &Arr) -> CoreResult<f64>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let s = dims::<NX, NU>(x.data.len(), nu_for(x.data.len()))?;
    let cost = spec.terminal("cost", s.nx)?;
    Ok(cost.value(&x.vector("x", s.nx)?))
}

/// Base class of every cost term. Not constructible itself.
///
/// A term depends on `(x, u)` (running only: `QuadraticCost`, `ControlSquared`, `CostSum`) or on
/// `x` only (running or terminal: every other term).
#[pyclass(module = "ddpkit._ddpkit", subclass, frozen)]
pub struct Cost {
    pub(crate) spec: Arc<CostSpec>,
}

#[pymethods]
impl Cost {
    /// The value at `(x, u)`; for a state-only term `u` may be omitted. The dimensions are taken
    /// from `x` and `u` (any size; the position terms need a compiled state size).
    #[pyo3(signature = (x, u = None))]
    fn value(&self, x: &Bound<'_, PyAny>, u: Option<&Bound<'_, PyAny>>) -> PyResult<f64> {
        let x = finite_arr(x, "x")?;
        if x.shape.len() != 1 {
            return Err(shape("x", shape_str(&x.shape), "(nx,)").into());
        }
        let nx = x.shape[0];
        match u {
            Some(u) => {
                let u = finite_arr(u, "u")?;
                if u.shape.len() != 1 {
                    return Err(shape("u", shape_str(&u.shape), "(nu,)").into());
                }
                let nu = u.shape[0];
                let r = with_dims!(nx, nu, running_value(&self.spec, &x, &u));
                crate::callable::raise_pending()?;
                Ok(r?)
            }
            None => {
                if !self.spec.state_only() {
                    return Err(invalid("u", format!("{} depends on the control: pass u", self.spec.kind())).into());
                }
                let r = with_dims!(nx, nu_for(nx), terminal_value(&self.spec, &x));
                crate::callable::raise_pending()?;
                Ok(r?)
            }
        }
    }

    /// Pickles as the call that builds the term again.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        cost_reduce(py, &self.spec)
    }

    /// Equal when the same term with equal parameters.
    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Cost>()
            .map(|o| *o.get().spec == *self.spec)
            .unwrap_or(false)
    }

    /// Whether the term depends on the state only, so it can be a terminal cost.
    #[getter]
    fn state_only(&self) -> bool {
        self.spec.state_only()
    }

    /// A cost traced from a Python function: running `l(x, u)` with `nu` given, terminal
    /// `l(x)` when `nu` is None. See `Dynamics.from_function` for what the function may use.
    #[staticmethod]
    #[pyo3(signature = (l, nx, nu = None))]
    fn from_function(
        py: Python<'_>,
        l: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = crate::convert::int_i64)] nx: i64,
        #[pyo3(from_py_with = crate::convert::opt_int_i64)] nu: Option<i64>,
    ) -> PyResult<Py<PyAny>> {
        crate::tape::cost_from_function(py, l, nx, nu)
    }

    /// A cost read from a CasADi SX function: `l(x, u)` (running) or `l(x)` (terminal), one
    /// scalar output.
    #[staticmethod]
    fn from_casadi(py: Python<'_>, l: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
        crate::tape::cost_from_casadi(py, l)
    }

    /// A cost from a plain Python callable `l(x, u) -> float` (or `l(x)` when `nu` is None):
    /// the slow path for what cannot be traced. Gradients and Hessians by central finite
    /// differences; an exception raised by `l` during a solve is raised by the solve.
    #[staticmethod]
    #[pyo3(signature = (l, nx, nu = None))]
    fn from_callable(
        py: Python<'_>,
        l: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = crate::convert::int_i64)] nx: i64,
        #[pyo3(from_py_with = crate::convert::opt_int_i64)] nu: Option<i64>,
    ) -> PyResult<Py<PyAny>> {
        crate::callable::cost_from_callable(py, l, nx, nu)
    }
}

/// The call that builds `spec` again: `(constructor, arguments)` (pickling). A sum's terms are
/// rebuilt as Python objects, each by its own call.
pub(crate) fn cost_reduce<'py>(py: Python<'py>, spec: &CostSpec) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
    use crate::pickle::module_attr;
    let class = || module_attr(py, spec.kind());
    let indices = |i: &[usize; 2]| (i[0], i[1]);
    Ok(match spec {
        CostSpec::Quadratic { q, r, x_ref, u_ref } => (
            class()?,
            (q.to_numpy(py)?, r.to_numpy(py)?, x_ref.clone(), u_ref.clone()).into_pyobject(py)?,
        ),
        CostSpec::QuadraticTerminal { qf, x_ref } => (class()?, (qf.to_numpy(py)?, x_ref.clone()).into_pyobject(py)?),
        CostSpec::ControlSquared { weight } => (class()?, (*weight,).into_pyobject(py)?),
        CostSpec::SmoothDistance {
            target,
            indices: i,
            eps,
            weight,
        } => (
            class()?,
            ((target[0], target[1]), indices(i), *eps, *weight).into_pyobject(py)?,
        ),
        CostSpec::ObstacleHinge {
            points,
            margin,
            indices: i,
            weight,
        } => {
            let points: Vec<Vec<f64>> = points.iter().map(|p| p.to_vec()).collect();
            (class()?, (points, *margin, indices(i), *weight).into_pyobject(py)?)
        }
        CostSpec::CirclePenalty {
            circles,
            indices: i,
            weight,
        } => {
            let circles: Vec<Vec<f64>> = circles.iter().map(|c| c.to_vec()).collect();
            (class()?, (circles, indices(i), *weight).into_pyobject(py)?)
        }
        CostSpec::Tape(m) => (
            module_attr(py, "model_from_json")?,
            (m.to_json(None),).into_pyobject(py)?,
        ),
        CostSpec::Callable(c) => {
            let (f, nx, nu) = c.parts(py);
            (
                module_attr(py, "Cost")?.getattr("from_callable")?,
                (f, nx, nu).into_pyobject(py)?,
            )
        }
        CostSpec::Sum { terms, .. } => {
            let mut items = Vec::with_capacity(terms.len());
            for (w, t) in terms {
                let (ctor, args) = cost_reduce(py, t)?;
                items.push((*w, ctor.call1(args)?));
            }
            (class()?, (PyList::new(py, items)?,).into_pyobject(py)?)
        }
    })
}

/// Extracts the spec of a `Cost`, naming `field` if `obj` is not one.
pub fn extract_cost(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Arc<CostSpec>> {
    match obj.cast::<Cost>() {
        Ok(c) => Ok(c.get().spec.clone()),
        Err(_) => Err(invalid(
            field,
            format!(
                "must be a ddpkit cost term (e.g. ddpkit.QuadraticCost), got {}",
                type_name(obj)
            ),
        )
        .into()),
    }
}

fn init<T: pyo3::PyClass<BaseType = Cost>>(spec: CostSpec, sub: T) -> PyClassInitializer<T> {
    PyClassInitializer::from(Cost { spec: Arc::new(spec) }).add_subclass(sub)
}

fn optional_vector(obj: Option<&Bound<'_, PyAny>>, field: &str) -> PyResult<Option<Vec<f64>>> {
    match obj {
        None => Ok(None),
        Some(o) => {
            let a = finite_arr(o, field)?;
            if a.shape.len() != 1 {
                return Err(shape(field, shape_str(&a.shape), "(n,)").into());
            }
            Ok(Some(a.data))
        }
    }
}

fn weight_arg(w: f64, field: &str) -> PyResult<f64> {
    if !w.is_finite() {
        return Err(CoreError(ddp_core::Error::NotFinite {
            field: field.to_string(),
            index: 0,
            value: w,
        })
        .into());
    }
    if w < 0.0 {
        return Err(invalid(field, format!("weight must be non-negative, got {w}")).into());
    }
    Ok(w)
}

fn indices_arg(indices: (i64, i64)) -> PyResult<[usize; 2]> {
    let mut out = [0usize; 2];
    for (i, v) in [indices.0, indices.1].into_iter().enumerate() {
        out[i] = usize::try_from(v)
            .map_err(|_| invalid(format!("indices[{i}]"), format!("state index must be >= 0, got {v}")))?;
    }
    if out[0] == out[1] {
        return Err(invalid("indices", "the two position indices must differ").into());
    }
    Ok(out)
}

fn vec_opt_to_numpy<'py>(py: Python<'py>, v: &Option<Vec<f64>>) -> Option<Bound<'py, PyAny>> {
    v.as_ref().map(|v| crate::convert::vec_to_numpy(py, v.clone()))
}

/// `1/2 (x - x_ref)^T Q (x - x_ref) + 1/2 (u - u_ref)^T R (u - u_ref)`.
#[pyclass(module = "ddpkit._ddpkit", extends = Cost, frozen)]
pub struct QuadraticCost {}

#[pymethods]
impl QuadraticCost {
    #[new]
    #[pyo3(signature = (Q, R, x_ref = None, u_ref = None))]
    #[allow(non_snake_case)]
    fn new(
        Q: &Bound<'_, PyAny>,
        R: &Bound<'_, PyAny>,
        x_ref: Option<&Bound<'_, PyAny>>,
        u_ref: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyClassInitializer<Self>> {
        let q = Weight::new(crate::convert::to_arr(Q, "Q")?, "Q", MAX_STATES)?;
        let r = Weight::new(crate::convert::to_arr(R, "R")?, "R", MAX_CONTROLS)?;
        let x_ref = optional_vector(x_ref, "x_ref")?;
        let u_ref = optional_vector(u_ref, "u_ref")?;
        for (name, v, n) in [("x_ref", &x_ref, q.n), ("u_ref", &u_ref, r.n)] {
            if let Some(v) = v {
                if v.len() != n {
                    return Err(shape(name, shape_str(&[v.len()]), shape_str(&[n])).into());
                }
            }
        }
        Ok(init(CostSpec::Quadratic { q, r, x_ref, u_ref }, Self {}))
    }

    /// `Q`, shape `(nx, nx)`.
    #[getter(Q)]
    fn q<'py>(self_: PyRef<'py, Self>, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &*self_.as_super().spec {
            CostSpec::Quadratic { q, .. } => q.to_numpy(py),
            _ => Err(crate::convert::internal("QuadraticCost spec".into()).into()),
        }
    }

    /// `R`, shape `(nu, nu)`.
    #[getter(R)]
    fn r<'py>(self_: PyRef<'py, Self>, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &*self_.as_super().spec {
            CostSpec::Quadratic { r, .. } => r.to_numpy(py),
            _ => Err(crate::convert::internal("QuadraticCost spec".into()).into()),
        }
    }

    /// The state reference, or `None` for zero.
    #[getter]
    fn x_ref<'py>(self_: PyRef<'py, Self>, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        match &*self_.as_super().spec {
            CostSpec::Quadratic { x_ref, .. } => vec_opt_to_numpy(py, x_ref),
            _ => None,
        }
    }

    /// The control reference, or `None` for zero.
    #[getter]
    fn u_ref<'py>(self_: PyRef<'py, Self>, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        match &*self_.as_super().spec {
            CostSpec::Quadratic { u_ref, .. } => vec_opt_to_numpy(py, u_ref),
            _ => None,
        }
    }

    fn __repr__(self_: PyRef<'_, Self>) -> String {
        match &*self_.as_super().spec {
            CostSpec::Quadratic { q, r, .. } => format!("QuadraticCost(nx={}, nu={})", q.n, r.n),
            _ => "QuadraticCost()".into(),
        }
    }
}

/// Terminal `1/2 (x - x_ref)^T Qf (x - x_ref)`.
#[pyclass(module = "ddpkit._ddpkit", extends = Cost, frozen)]
pub struct QuadraticTerminal {}

#[pymethods]
impl QuadraticTerminal {
    #[new]
    #[pyo3(signature = (Qf, x_ref = None))]
    #[allow(non_snake_case)]
    fn new(Qf: &Bound<'_, PyAny>, x_ref: Option<&Bound<'_, PyAny>>) -> PyResult<PyClassInitializer<Self>> {
        let qf = Weight::new(crate::convert::to_arr(Qf, "Qf")?, "Qf", MAX_STATES)?;
        let x_ref = optional_vector(x_ref, "x_ref")?;
        if let Some(v) = &x_ref {
            if v.len() != qf.n {
                return Err(shape("x_ref", shape_str(&[v.len()]), shape_str(&[qf.n])).into());
            }
        }
        Ok(init(CostSpec::QuadraticTerminal { qf, x_ref }, Self {}))
    }

    /// `Qf`, shape `(nx, nx)`.
    #[getter(Qf)]
    fn qf<'py>(self_: PyRef<'py, Self>, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &*self_.as_super().spec {
            CostSpec::QuadraticTerminal { qf, .. } => qf.to_numpy(py),
            _ => Err(crate::convert::internal("QuadraticTerminal spec".into()).into()),
        }
    }

    /// The state reference, or `None` for zero.
    #[getter]
    fn x_ref<'py>(self_: PyRef<'py, Self>, py: Python<'py>) -> Option<Bound<'py, PyAny>> {
        match &*self_.as_super().spec {
            CostSpec::QuadraticTerminal { x_ref, .. } => vec_opt_to_numpy(py, x_ref),
            _ => None,
        }
    }

    fn __repr__(self_: PyRef<'_, Self>) -> String {
        match &*self_.as_super().spec {
            CostSpec::QuadraticTerminal { qf, .. } => format!("QuadraticTerminal(nx={})", qf.n),
            _ => "QuadraticTerminal()".into(),
        }
    }
}

/// `weight * sum(u**2)` (DDPEN eq. 5).
#[pyclass(module = "ddpkit._ddpkit", extends = Cost, frozen)]
pub struct ControlSquared {
    weight: f64,
}

#[pymethods]
impl ControlSquared {
    #[new]
    fn new(weight: f64) -> PyResult<PyClassInitializer<Self>> {
        let weight = weight_arg(weight, "weight")?;
        Ok(init(CostSpec::ControlSquared { weight }, Self { weight }))
    }

    /// The weight.
    #[getter]
    fn weight(&self) -> f64 {
        self.weight
    }

    fn __repr__(&self) -> String {
        format!("ControlSquared(weight={})", self.weight)
    }
}

fn target_arg(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<[f64; 2]> {
    let a = finite_arr(obj, field)?;
    a.expect_shape(field, &[2])?;
    Ok([a.data[0], a.data[1]])
}

/// `weight * sqrt(|p - target|^2 + eps^2)` with `p = (x[i0], x[i1])` (DDPEN eqs. 6 and 9).
#[pyclass(module = "ddpkit._ddpkit", extends = Cost, frozen)]
pub struct SmoothDistance {
    target: [f64; 2],
    indices: [usize; 2],
    eps: f64,
    weight: f64,
}

#[pymethods]
impl SmoothDistance {
    #[new]
    #[pyo3(signature = (target, indices = (0, 1), eps = 1e-3, weight = 1.0))]
    #[pyo3(text_signature = "(target, indices=(0, 1), eps=0.001, weight=1.0)")]
    fn new(
        target: &Bound<'_, PyAny>,
        indices: (i64, i64),
        eps: f64,
        weight: f64,
    ) -> PyResult<PyClassInitializer<Self>> {
        let target = target_arg(target, "target")?;
        let indices = indices_arg(indices)?;
        if !(eps.is_finite() && eps > 0.0) {
            return Err(invalid("eps", format!("must be > 0, got {eps}")).into());
        }
        let weight = weight_arg(weight, "weight")?;
        let spec = CostSpec::SmoothDistance {
            target,
            indices,
            eps,
            weight,
        };
        Ok(init(
            spec,
            Self {
                target,
                indices,
                eps,
                weight,
            },
        ))
    }

    /// The target point `(gx, gy)`.
    #[getter]
    fn target(&self) -> (f64, f64) {
        (self.target[0], self.target[1])
    }

    /// The state indices of the position.
    #[getter]
    fn indices(&self) -> (usize, usize) {
        (self.indices[0], self.indices[1])
    }

    /// The smoothing `eps`.
    #[getter]
    fn eps(&self) -> f64 {
        self.eps
    }

    /// The weight.
    #[getter]
    fn weight(&self) -> f64 {
        self.weight
    }

    fn __repr__(&self) -> String {
        format!(
            "SmoothDistance(target=({}, {}), indices=({}, {}), eps={}, weight={})",
            self.target[0], self.target[1], self.indices[0], self.indices[1], self.eps, self.weight
        )
    }
}

fn points_arg<const K: usize>(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<Vec<[f64; K]>> {
    let a = finite_arr(obj, field)?;
    match a.shape.as_slice() {
        [_, k] if *k == K => {}
        [0] => return Ok(Vec::new()),
        _ => return Err(shape(field, shape_str(&a.shape), format!("(m, {K})")).into()),
    }
    Ok(a.data
        .chunks_exact(K)
        .map(|c| {
            let mut p = [0.0; K];
            p.copy_from_slice(c);
            p
        })
        .collect())
}

/// `weight * sum_o max(0, margin - |p - o|)` over obstacle points `o` (DDPEN eq. 7).
#[pyclass(module = "ddpkit._ddpkit", extends = Cost, frozen)]
pub struct ObstacleHinge {
    margin: f64,
    weight: f64,
    count: usize,
}

#[pymethods]
impl ObstacleHinge {
    #[new]
    #[pyo3(signature = (points, margin, indices = (0, 1), weight = 1.0))]
    #[pyo3(text_signature = "(points, margin, indices=(0, 1), weight=1.0)")]
    fn new(
        points: &Bound<'_, PyAny>,
        margin: f64,
        indices: (i64, i64),
        weight: f64,
    ) -> PyResult<PyClassInitializer<Self>> {
        let points = points_arg::<2>(points, "points")?;
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(invalid("margin", format!("must be >= 0, got {margin}")).into());
        }
        let indices = indices_arg(indices)?;
        let weight = weight_arg(weight, "weight")?;
        let count = points.len();
        let spec = CostSpec::ObstacleHinge {
            points,
            margin,
            indices,
            weight,
        };
        Ok(init(spec, Self { margin, weight, count }))
    }

    /// The activation distance.
    #[getter]
    fn margin(&self) -> f64 {
        self.margin
    }

    /// The weight.
    #[getter]
    fn weight(&self) -> f64 {
        self.weight
    }

    fn __repr__(&self) -> String {
        format!(
            "ObstacleHinge(<{} points>, margin={}, weight={})",
            self.count, self.margin, self.weight
        )
    }
}

/// Squared-hinge obstacle penalty `weight * sum_o max(0, r_o^2 - |p - o|^2)^2` over circles
/// `(ox, oy, r)`, with a Gauss-Newton Hessian.
#[pyclass(module = "ddpkit._ddpkit", extends = Cost, frozen)]
pub struct CirclePenalty {
    weight: f64,
    count: usize,
}

#[pymethods]
impl CirclePenalty {
    #[new]
    #[pyo3(signature = (circles, indices = (0, 1), weight = 1.0))]
    #[pyo3(text_signature = "(circles, indices=(0, 1), weight=1.0)")]
    fn new(circles: &Bound<'_, PyAny>, indices: (i64, i64), weight: f64) -> PyResult<PyClassInitializer<Self>> {
        let circles = points_arg::<3>(circles, "circles")?;
        for (k, c) in circles.iter().enumerate() {
            if c[2] < 0.0 {
                return Err(invalid(format!("circles[{k}]"), format!("radius must be >= 0, got {}", c[2])).into());
            }
        }
        let indices = indices_arg(indices)?;
        let weight = weight_arg(weight, "weight")?;
        let count = circles.len();
        let spec = CostSpec::CirclePenalty {
            circles,
            indices,
            weight,
        };
        Ok(init(spec, Self { weight, count }))
    }

    /// The weight.
    #[getter]
    fn weight(&self) -> f64 {
        self.weight
    }

    fn __repr__(&self) -> String {
        format!("CirclePenalty(<{} circles>, weight={})", self.count, self.weight)
    }
}

/// Parses `[(w, term), ...]`, naming `terms[i]`.
fn terms_arg(terms: &Bound<'_, PyAny>, terminal: bool) -> PyResult<Vec<(f64, Arc<CostSpec>)>> {
    let list = match terms.cast::<PyList>() {
        Ok(l) => l.to_tuple(),
        Err(_) => match terms.cast::<PyTuple>() {
            Ok(t) => t.clone(),
            Err(_) => {
                return Err(invalid(
                    "terms",
                    format!("must be a list of (weight, term) pairs, got {}", type_name(terms)),
                )
                .into())
            }
        },
    };
    let mut out = Vec::with_capacity(list.len());
    for (i, item) in list.iter().enumerate() {
        let field = format!("terms[{i}]");
        let pair = item.cast::<PyTuple>().ok().filter(|t| t.len() == 2).ok_or_else(|| {
            invalid(
                &field,
                format!("must be a (weight, term) pair, got {}", type_name(&item)),
            )
        })?;
        let w: f64 = pair
            .get_item(0)?
            .extract()
            .map_err(|_| invalid(format!("{field}.weight"), "must be a number".to_string()))?;
        let w = weight_arg(w, &format!("{field}.weight"))?;
        let spec = extract_cost(&pair.get_item(1)?, &format!("{field}.term"))?;
        if terminal && !spec.state_only() {
            return Err(invalid(
                format!("{field}.term"),
                format!(
                    "{} depends on the control u and cannot be in a TerminalSum",
                    spec.kind()
                ),
            )
            .into());
        }
        out.push((w, spec));
    }
    Ok(out)
}

/// Weighted sum of running terms `sum_i w_i l_i(x, u)`.
#[pyclass(module = "ddpkit._ddpkit", extends = Cost, frozen)]
pub struct CostSum {
    count: usize,
}

#[pymethods]
impl CostSum {
    #[new]
    fn new(terms: &Bound<'_, PyAny>) -> PyResult<PyClassInitializer<Self>> {
        let terms = terms_arg(terms, false)?;
        let count = terms.len();
        Ok(init(CostSpec::Sum { terms, terminal: false }, Self { count }))
    }

    fn __len__(&self) -> usize {
        self.count
    }

    fn __repr__(&self) -> String {
        format!("CostSum(<{} terms>)", self.count)
    }
}

/// Weighted sum of state-only terms `sum_i w_i l_i(x)` (a terminal cost).
#[pyclass(module = "ddpkit._ddpkit", extends = Cost, frozen)]
pub struct TerminalSum {
    count: usize,
}

#[pymethods]
impl TerminalSum {
    #[new]
    fn new(terms: &Bound<'_, PyAny>) -> PyResult<PyClassInitializer<Self>> {
        let terms = terms_arg(terms, true)?;
        let count = terms.len();
        Ok(init(CostSpec::Sum { terms, terminal: true }, Self { count }))
    }

    fn __len__(&self) -> usize {
        self.count
    }

    fn __repr__(&self) -> String {
        format!("TerminalSum(<{} terms>)", self.count)
    }
}
