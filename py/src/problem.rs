//! `Problem`: initial state, per-knot dynamics and running costs, terminal cost, control box.

use std::collections::HashMap;
use std::sync::{Arc, RwLock};

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, VectorN, U1};
use ddp_core::{ControlBounds, Knot, Problem as CoreProblem};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};

use crate::convert::{check_allocation, finite_arr, shape_str, to_arr, vectors_to_numpy, Arr};
use crate::costs::{extract_cost, CostSpec, StateDim};
use crate::dims::{dims, dynamics_of, problem_mut_of, problem_of, AnyDynamics, AnyProblem, Dispatch, Pair};
use crate::errors::{invalid, shape, CoreError, CoreResult};
use crate::models::extract_dynamics;

/// The list items of `obj` if it is a list or tuple, else `None`.
fn as_sequence<'py>(obj: &Bound<'py, PyAny>) -> Option<Vec<Bound<'py, PyAny>>> {
    if let Ok(l) = obj.cast::<PyList>() {
        return Some(l.iter().collect());
    }
    if let Ok(t) = obj.cast::<PyTuple>() {
        return Some(t.iter().collect());
    }
    None
}

/// Control bounds `(lower, upper)` as flat vectors of length `nu` (`+-inf` where absent).
fn bounds_arg(obj: Option<&Bound<'_, PyAny>>, field: &str, nu: usize) -> PyResult<Option<Vec<f64>>> {
    let Some(obj) = obj else { return Ok(None) };
    if obj.is_none() {
        return Ok(None);
    }
    let a = to_arr(obj, field)?;
    if a.data.iter().any(|v| v.is_nan()) {
        // Infinite bounds are allowed (no bound on that control); NaN is not.
        let i = a.data.iter().position(|v| v.is_nan()).unwrap_or(0);
        return Err(CoreError(ddp_core::Error::NotFinite {
            field: field.to_string(),
            index: i,
            value: f64::NAN,
        })
        .into());
    }
    match a.shape.as_slice() {
        [] => Ok(Some(vec![a.data[0]; nu])),
        [n] if *n == nu => Ok(Some(a.data)),
        _ => Err(shape(field, shape_str(&a.shape), format!("({nu},) or a scalar")).into()),
    }
}

/// Everything a `Problem` is built from, extracted from Python.
struct ProblemArgs {
    x0: Arr,
    dynamics: Vec<AnyDynamics>,
    running: Vec<Arc<CostSpec>>,
    /// Field name of each running cost (`running_cost` or `running_cost[k]`).
    running_fields: Vec<String>,
    terminal: Arc<CostSpec>,
    u_min: Option<Vec<f64>>,
    u_max: Option<Vec<f64>>,
}

fn build<NX: StateDim, NU: Dim>(args: &ProblemArgs, nx: usize, nu: usize) -> CoreResult<AnyProblem>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let s = dims::<NX, NU>(nx, nu)?;
    let x0 = args.x0.vector("x0", s.nx)?;
    // Typed costs are built once per distinct Python cost object.
    let mut cache: HashMap<*const CostSpec, Arc<dyn ddp_core::Cost<NX, NU>>> = HashMap::new();
    let mut knots = Vec::with_capacity(args.dynamics.len());
    for (k, (d, c)) in args.dynamics.iter().zip(&args.running).enumerate() {
        let dynamics = dynamics_of::<NX, NU>(d)?;
        let cost = match cache.get(&Arc::as_ptr(c)) {
            Some(c) => c.clone(),
            None => {
                let typed = c.running(&args.running_fields[k], s)?;
                cache.insert(Arc::as_ptr(c), typed.clone());
                typed
            }
        };
        knots.push(Knot {
            dynamics: dynamics.clone(),
            cost,
        });
    }
    let terminal = args.terminal.terminal("terminal_cost", s.nx)?;
    let mut problem = CoreProblem::from_knots(x0, knots, terminal)?;
    if args.u_min.is_some() || args.u_max.is_some() {
        let side = |v: &Option<Vec<f64>>, default: f64| match v {
            Some(v) => VectorN::<NU>::from_row_slice_generic(s.nu, U1, v),
            None => VectorN::<NU>::from_element_generic(s.nu, U1, default),
        };
        let lower = side(&args.u_min, f64::NEG_INFINITY);
        let upper = side(&args.u_max, f64::INFINITY);
        problem.set_control_bounds(Some(ControlBounds::new(lower, upper)?))?;
    }
    Ok(<Dispatch as Pair<NX, NU>>::wrap_problem(problem))
}

fn set_x0_impl<NX: Dim, NU: Dim>(p: &mut AnyProblem, x0: &Arr) -> CoreResult<()>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let p = problem_mut_of::<NX, NU>(p)?;
    p.set_x0(x0.vector("x0", p.dims().nx)?)?;
    Ok(())
}

fn x0_impl<NX: Dim, NU: Dim>(p: &AnyProblem) -> CoreResult<Vec<f64>>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    Ok(problem_of::<NX, NU>(p)?.x0().iter().copied().collect())
}

fn bounds_impl<NX: Dim, NU: Dim>(p: &AnyProblem) -> CoreResult<Option<(Vec<f64>, Vec<f64>)>>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    Ok(problem_of::<NX, NU>(p)?
        .bounds()
        .map(|b| (b.lower.iter().copied().collect(), b.upper.iter().copied().collect())))
}

/// `us` as controls of `nu` entries, shape `(n, nu)`.
pub fn controls<NU: Dim>(us: &Arr, field: &str, n: usize, nu: NU) -> CoreResult<Vec<VectorN<NU>>>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    us.expect_shape(field, &[n, nu.value()])?;
    Ok(us
        .data
        .chunks_exact(nu.value())
        .map(|c| VectorN::from_row_slice_generic(nu, U1, c))
        .collect())
}

fn rollout_impl<'py, NX: Dim, NU: Dim>(py: Python<'py>, p: &AnyProblem, us: &Arr) -> PyResult<Bound<'py, PyAny>>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let p = problem_of::<NX, NU>(p)?;
    let s = p.dims();
    let us = controls(us, "us", p.horizon(), s.nu)?;
    let mut xs = vec![s.x_zeros(); p.horizon() + 1];
    p.rollout(&us, &mut xs).map_err(CoreError)?;
    vectors_to_numpy(py, &xs, s.nx())
}

fn cost_impl<NX: Dim, NU: Dim>(p: &AnyProblem, xs: &Arr, us: &Arr) -> CoreResult<f64>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let p = problem_of::<NX, NU>(p)?;
    let (n, s) = (p.horizon(), p.dims());
    let us = controls(us, "us", n, s.nu)?;
    xs.expect_shape("xs", &[n + 1, s.nx()])?;
    let xs: Vec<VectorN<NX>> = xs
        .data
        .chunks_exact(s.nx())
        .map(|c| VectorN::from_row_slice_generic(s.nx, U1, c))
        .collect();
    Ok(p.cost(&xs, &us)?)
}

/// An optimal control problem
///
/// `min sum_{k<N} l_k(x_k, u_k) + l_N(x_N)  s.t.  x_{k+1} = f_k(x_k, u_k), u_min <= u_k <= u_max`.
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct Problem {
    /// Shared with every `Solver` made from this problem, so `set_x0` reaches them.
    pub(crate) inner: Arc<RwLock<AnyProblem>>,
    pub(crate) nx: usize,
    pub(crate) nu: usize,
    pub(crate) horizon: usize,
    /// What the problem was built from, for pickling: `(dynamics, running_cost, terminal_cost,
    /// u_min, u_max)` (the Python objects as given; the bounds as lists or None).
    source: Py<PyTuple>,
}

impl Problem {
    /// Whether a model of the problem calls Python on every evaluation (`from_callable`
    /// dynamics or costs, also inside a `CostSum`): such a model needs the GIL and keeps its
    /// exception for the thread that evaluated it, so its derivatives stay on the solving thread.
    pub(crate) fn calls_python(&self, py: Python<'_>) -> bool {
        fn items<'py>(obj: &Bound<'py, PyAny>) -> Vec<Bound<'py, PyAny>> {
            as_sequence(obj).unwrap_or_else(|| vec![obj.clone()])
        }
        let src = self.source.bind(py);
        let get = |i: usize| src.get_item(i).ok();
        let dynamics = get(0)
            .map(|d| {
                items(&d)
                    .iter()
                    .any(|d| d.is_instance_of::<crate::callable::PyCallableDynamics>())
            })
            .unwrap_or(false);
        let costs = [get(1), get(2)].into_iter().flatten().any(|c| {
            items(&c)
                .iter()
                .any(|c| extract_cost(c, "cost").map(|s| s.calls_python()).unwrap_or(false))
        });
        dynamics || costs
    }

    /// Reads the problem (the lock is only poisoned by a panic, which the bindings never cause).
    pub(crate) fn read<T>(lock: &RwLock<AnyProblem>, f: impl FnOnce(&AnyProblem) -> T) -> T {
        match lock.read() {
            Ok(g) => f(&g),
            Err(poisoned) => f(&poisoned.into_inner()),
        }
    }
}

#[pymethods]
impl Problem {
    #[new]
    #[pyo3(signature = (x0, dynamics, running_cost, terminal_cost, horizon, u_min = None, u_max = None))]
    fn new(
        x0: &Bound<'_, PyAny>,
        dynamics: &Bound<'_, PyAny>,
        running_cost: &Bound<'_, PyAny>,
        terminal_cost: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = crate::convert::int_i64)] horizon: i64,
        u_min: Option<&Bound<'_, PyAny>>,
        u_max: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let (x0_obj, dynamics_obj) = (x0, dynamics);
        if horizon == 0 {
            return Err(CoreError(ddp_core::Error::EmptyHorizon).into());
        }
        let horizon =
            usize::try_from(horizon).map_err(|_| invalid("horizon", format!("must be at least 1, got {horizon}")))?;
        // The knot lists below hold a model, a cost and a typed knot per step.
        check_allocation(
            "horizon",
            horizon,
            4 * std::mem::size_of::<Knot<ddp_core::dims::U12, ddp_core::dims::U4>>(),
        )?;

        // Dynamics: one model, or one per knot.
        let (dynamics, nx, nu) = match as_sequence(dynamics) {
            Some(items) => {
                if items.len() != horizon {
                    return Err(shape(
                        "dynamics",
                        format!("a list of length {}", items.len()),
                        format!("a list of length horizon = {horizon}"),
                    )
                    .into());
                }
                let mut out = Vec::with_capacity(horizon);
                let (_, nx, nu) = extract_dynamics(&items[0], "dynamics[0]")?;
                for (k, item) in items.iter().enumerate() {
                    let field = format!("dynamics[{k}]");
                    let (d, a, b) = extract_dynamics(item, &field)?;
                    if (a, b) != (nx, nu) {
                        return Err(shape(
                            field,
                            format!("(nx, nu) = ({a}, {b})"),
                            format!("({nx}, {nu}) as dynamics[0]"),
                        )
                        .into());
                    }
                    out.push(d);
                }
                (out, nx, nu)
            }
            None => {
                let (d, nx, nu) = extract_dynamics(dynamics, "dynamics")?;
                (vec![d; horizon], nx, nu)
            }
        };

        // Running costs: one term, or one per knot.
        let (running, running_fields) = match as_sequence(running_cost) {
            Some(items) => {
                if items.len() != horizon {
                    return Err(shape(
                        "running_cost",
                        format!("a list of length {}", items.len()),
                        format!("a list of length horizon = {horizon}"),
                    )
                    .into());
                }
                let mut specs = Vec::with_capacity(horizon);
                let mut fields = Vec::with_capacity(horizon);
                for (k, item) in items.iter().enumerate() {
                    let field = format!("running_cost[{k}]");
                    specs.push(extract_cost(item, &field)?);
                    fields.push(field);
                }
                (specs, fields)
            }
            None => {
                let spec = extract_cost(running_cost, "running_cost")?;
                (vec![spec; horizon], vec!["running_cost".to_string(); horizon])
            }
        };
        let terminal = extract_cost(terminal_cost, "terminal_cost")?;

        let x0 = finite_arr(x0, "x0")?;
        x0.expect_shape("x0", &[nx])?;
        let args = ProblemArgs {
            x0,
            dynamics,
            running,
            running_fields,
            terminal,
            u_min: bounds_arg(u_min, "u_min", nu)?,
            u_max: bounds_arg(u_max, "u_max", nu)?,
        };
        let problem = with_dims!(nx, nu, build(&args, nx, nu))?;
        let py = x0_obj.py();
        let source = PyTuple::new(
            py,
            [
                dynamics_obj.clone(),
                running_cost.clone(),
                terminal_cost.clone(),
                args.u_min.clone().into_pyobject(py)?,
                args.u_max.clone().into_pyobject(py)?,
            ],
        )?
        .unbind();
        Ok(Self {
            inner: Arc::new(RwLock::new(problem)),
            nx,
            nu,
            horizon,
            source,
        })
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

    /// The horizon `N` (number of controls).
    #[getter]
    fn horizon(&self) -> usize {
        self.horizon
    }

    /// The initial state (a copy), shape `(nx,)`.
    #[getter]
    fn x0<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = Self::read(&self.inner, |p| with_dims!(self.nx, self.nu, x0_impl(p)))?;
        Ok(crate::convert::vec_to_numpy(py, v))
    }

    /// The control bounds `(u_min, u_max)` (with `+-inf` for unbounded entries), or `None`.
    #[getter]
    fn bounds<'py>(&self, py: Python<'py>) -> PyResult<Option<(Bound<'py, PyAny>, Bound<'py, PyAny>)>> {
        let b = Self::read(&self.inner, |p| with_dims!(self.nx, self.nu, bounds_impl(p)))?;
        Ok(b.map(|(l, u)| (crate::convert::vec_to_numpy(py, l), crate::convert::vec_to_numpy(py, u))))
    }

    /// Replaces the initial state (receding horizon); every `Solver` of this problem sees it.
    fn set_x0(&self, x0: &Bound<'_, PyAny>) -> PyResult<()> {
        let x0 = finite_arr(x0, "x0")?;
        let mut guard = match self.inner.write() {
            Ok(g) => g,
            Err(poisoned) => poisoned.into_inner(),
        };
        with_dims!(self.nx, self.nu, set_x0_impl(&mut guard, &x0))?;
        Ok(())
    }

    /// Simulates the controls `us` (shape `(N, nu)`) from `x0`; returns `xs`, shape `(N+1, nx)`.
    fn rollout<'py>(&self, py: Python<'py>, us: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let us = finite_arr(us, "us")?;
        let r = Self::read(&self.inner, |p| with_dims!(self.nx, self.nu, rollout_impl(py, p, &us)));
        crate::callable::raise_pending()?;
        r
    }

    /// The objective `sum_k l_k(x_k, u_k) + l_N(x_N)` of a trajectory (`xs` `(N+1, nx)`, `us`
    /// `(N, nu)`); dynamics and bounds are not checked.
    fn cost(&self, xs: &Bound<'_, PyAny>, us: &Bound<'_, PyAny>) -> PyResult<f64> {
        let xs = finite_arr(xs, "xs")?;
        let us = finite_arr(us, "us")?;
        let r = Self::read(&self.inner, |p| with_dims!(self.nx, self.nu, cost_impl(p, &xs, &us)));
        // An exception raised by a Python callable cost is this call's error.
        crate::callable::raise_pending()?;
        Ok(r?)
    }

    /// The constructor's arguments, with the current `x0` (pickling).
    fn __getnewargs__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let src = self.source.bind(py);
        PyTuple::new(
            py,
            [
                self.x0(py)?,
                src.get_item(0)?,
                src.get_item(1)?,
                src.get_item(2)?,
                self.horizon.into_pyobject(py)?.into_any(),
                src.get_item(3)?,
                src.get_item(4)?,
            ],
        )
    }

    /// Equal when built from equal models, costs, horizon and bounds and at the same `x0`.
    fn __eq__(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        let Ok(o) = other.cast::<Problem>() else {
            return Ok(false);
        };
        crate::pickle::equal_values(self.__getnewargs__(py)?.as_any(), o.get().__getnewargs__(py)?.as_any())
    }

    fn __repr__(&self) -> String {
        format!("Problem(nx={}, nu={}, horizon={})", self.nx, self.nu, self.horizon)
    }
}
