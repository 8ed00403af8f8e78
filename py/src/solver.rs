//! `Solver` (a ddp-core workspace bound to a `Problem`) and `Solution`.

use std::sync::{Arc, RwLock};

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, MatrixN, VectorN};
use ddp_core::{
    LineSearchSettings, Method, Regularization, RegularizationSettings, Report, Settings, Shooting,
    Solver as CoreSolver, Tolerances,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::{check_allocation, finite_arr, flatten_matrices, flatten_vectors, rows_to_numpy, Arr, LazyArray};
use crate::dims::{problem_of, solver_mut_of, solver_of, AnyProblem, AnySolver, Dispatch, Pair};
use crate::errors::{invalid, CoreError, CoreResult};
use crate::pickle::{equal_values, field, module_attr, Table};
use crate::problem::{controls, Problem};

/// Plain-data results of a solve, copied out of the workspace without the GIL.
struct SolveOut {
    xs: Vec<f64>,
    us: Vec<f64>,
    gains: Vec<f64>,
    feedforward: Vec<f64>,
    status: &'static str,
    iterations: usize,
    cost: f64,
    initial_cost: f64,
    gradient: f64,
    mu: f64,
    backward_passes: usize,
    forward_passes: usize,
    solve_time: f64,
    defect: f64,
    cost_history: Vec<f64>,
    report: Report,
}

fn new_solver<NX: Dim, NU: Dim>(p: &AnyProblem, settings: Settings) -> CoreResult<AnySolver>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let p = problem_of::<NX, NU>(p)?;
    // What the workspace holds per knot (states, controls, Jacobians, cost derivatives, gains,
    // value function), with room to spare: a horizon too large to allocate is an error, not an
    // abort. At run-time sizes the entries are on the heap: count them too.
    use std::mem::size_of;
    let (nx, nu) = (p.dims().nx(), p.dims().nu());
    let heap = if NX::try_to_usize().is_some() && NU::try_to_usize().is_some() {
        0
    } else {
        (3 * nx * nx + 3 * nx * nu + nu * nu + 4 * nx + 3 * nu) * size_of::<f64>()
    };
    let per_knot = 4 * size_of::<VectorN<NX>>()
        + 3 * size_of::<VectorN<NU>>()
        + 2 * size_of::<MatrixN<NX, NX>>()
        + size_of::<MatrixN<NX, NU>>()
        + size_of::<MatrixN<NU, NX>>()
        + size_of::<ddp_core::CostDerivatives<NX, NU>>()
        + heap;
    check_allocation("horizon", p.horizon() + 1, 2 * per_knot)?;
    Ok(<Dispatch as Pair<NX, NU>>::wrap_solver(CoreSolver::new(p, settings)?))
}

fn solve_impl<NX: Dim, NU: Dim>(
    s: &mut AnySolver,
    p: &AnyProblem,
    us0: Option<&Arr>,
    xs0: Option<&Arr>,
    warm_start: bool,
) -> CoreResult<SolveOut>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let s = solver_mut_of::<NX, NU>(s)?;
    let p = problem_of::<NX, NU>(p)?;
    // `warm_start` decides whether the last solve's state (multipliers, margins,
    // regularisation) carries over; `us0` only replaces the controls.
    if !warm_start {
        s.reset();
    }
    if let Some(us) = us0 {
        s.set_controls(&controls(us, "us0", s.horizon(), s.dims().nu)?)?;
    }
    if let Some(xs) = xs0 {
        s.set_states(&controls(xs, "xs0", s.horizon() + 1, s.dims().nx)?)?;
    }
    let report = s.solve(p)?;
    let (status, iterations, cost, initial_cost, gradient, mu, bp, fp, time) = (
        report.status.as_str(),
        report.iterations,
        report.cost,
        report.initial_cost,
        report.gradient,
        report.mu,
        report.backward_passes,
        report.forward_passes,
        report.solve_time.as_secs_f64(),
    );
    let cost_history = report
        .log
        .iter()
        .filter(|r| r.accepted || r.iteration == 0)
        .map(|r| r.cost)
        .collect();
    let report = report.clone();
    Ok(SolveOut {
        xs: flatten_vectors(s.xs(), s.dims().nx()),
        us: flatten_vectors(s.us(), s.dims().nu()),
        gains: flatten_matrices(s.gains()),
        feedforward: flatten_vectors(s.feedforward(), s.dims().nu()),
        status,
        iterations,
        cost,
        initial_cost,
        gradient,
        mu,
        backward_passes: bp,
        forward_passes: fp,
        solve_time: time,
        defect: report.defect,
        cost_history,
        report,
    })
}

fn shift_impl<NX: Dim, NU: Dim>(s: &mut AnySolver) -> CoreResult<()>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    solver_mut_of::<NX, NU>(s)?.shift();
    Ok(())
}

fn reset_impl<NX: Dim, NU: Dim>(s: &mut AnySolver) -> CoreResult<()>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    solver_mut_of::<NX, NU>(s)?.reset();
    Ok(())
}

fn controls_impl<NX: Dim, NU: Dim>(s: &AnySolver) -> CoreResult<Vec<f64>>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    Ok(solver_of::<NX, NU>(s)?
        .us()
        .iter()
        .flat_map(|u| u.iter().copied())
        .collect())
}

// ------------------------------------------------------------------------------------------------
// Settings: flat keyword arguments in Python, ddp-core's nested `Settings` in Rust, every default
// from `Settings::default()`.

/// The Python name of a [`Method`].
pub(crate) fn method_name(m: Method) -> &'static str {
    match m {
        Method::Ilqr => "ilqr",
        Method::Ddp => "ddp",
    }
}

/// A [`Method`] from its Python name (any case), naming `method` otherwise.
pub(crate) fn parse_method(name: &str) -> CoreResult<Method> {
    match name.to_ascii_lowercase().as_str() {
        "ilqr" => Ok(Method::Ilqr),
        "ddp" => Ok(Method::Ddp),
        other => Err(invalid("method", format!("must be 'ilqr' or 'ddp', got '{other}'"))),
    }
}

/// A [`Shooting`] from its Python name (any case), naming `shooting` otherwise.
pub(crate) fn parse_shooting(name: &str) -> CoreResult<Shooting> {
    match name.to_ascii_lowercase().as_str() {
        "single" => Ok(Shooting::Single),
        "multiple" => Ok(Shooting::Multiple),
        other => Err(invalid(
            "shooting",
            format!("must be 'single' or 'multiple', got '{other}'"),
        )),
    }
}

/// The Python name of a [`Shooting`].
pub(crate) fn shooting_name(s: Shooting) -> &'static str {
    match s {
        Shooting::Single => "single",
        Shooting::Multiple => "multiple",
    }
}

/// The Python name of a [`Regularization`] placement.
fn placement_name(r: Regularization) -> &'static str {
    match r {
        Regularization::Control => "control",
        Regularization::State => "state",
    }
}

/// The flat Python keyword of each nested field of [`Settings`] (the others have the same name).
const FLAT_NAMES: &[(&str, &str)] = &[
    ("tolerances.gradient", "gradient_tolerance"),
    ("tolerances.cost", "cost_tolerance"),
    ("regularization.mu_init", "mu_init"),
    ("regularization.mu_min", "mu_min"),
    ("regularization.mu_max", "mu_max"),
    ("regularization.mu_factor", "mu_factor"),
    ("regularization.placement", "regularization"),
    ("line_search.step_factor", "step_factor"),
    ("line_search.step_min", "step_min"),
    ("line_search.armijo", "armijo"),
];

/// Renames the nested settings fields in a validation error (`settings.tolerances.gradient`) to
/// the keyword arguments the user wrote (`settings.gradient_tolerance`).
fn flat_error(e: ddp_core::Error) -> CoreError {
    let flat = |text: &mut String| {
        for (nested, name) in FLAT_NAMES {
            *text = text.replace(&format!("settings.{nested}"), &format!("settings.{name}"));
        }
    };
    let mut e = e;
    match &mut e {
        ddp_core::Error::Invalid { field, reason } => {
            flat(field);
            flat(reason);
        }
        ddp_core::Error::NotFinite { field, .. } | ddp_core::Error::Shape { field, .. } => flat(field),
        _ => {}
    }
    CoreError(e)
}

fn settings_dict<'py>(py: Python<'py>, s: &Settings) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("method", method_name(s.method))?;
    d.set_item("shooting", shooting_name(s.shooting))?;
    d.set_item("max_iterations", s.max_iterations)?;
    d.set_item("gradient_tolerance", s.tolerances.gradient)?;
    d.set_item("cost_tolerance", s.tolerances.cost)?;
    d.set_item("mu_init", s.regularization.mu_init)?;
    d.set_item("mu_min", s.regularization.mu_min)?;
    d.set_item("mu_max", s.regularization.mu_max)?;
    d.set_item("mu_factor", s.regularization.mu_factor)?;
    d.set_item("regularization", placement_name(s.regularization.placement))?;
    d.set_item("step_factor", s.line_search.step_factor)?;
    d.set_item("step_min", s.line_search.step_min)?;
    d.set_item("armijo", s.line_search.armijo)?;
    d.set_item("box_qp_iterations", s.box_qp_iterations)?;
    d.set_item("derivative_threads", s.derivative_threads)?;
    Ok(d)
}

/// The default settings of `kind` (`"Solver"`, `"SafeCddpSolver"` or `"Mpc"`) as a dict of the
/// keyword arguments of that class: Rust's `Default` values, which the classes' signatures use.
#[pyfunction]
#[pyo3(signature = (kind = "Solver"))]
pub fn default_settings<'py>(py: Python<'py>, kind: &str) -> PyResult<Bound<'py, PyDict>> {
    match kind {
        "Solver" => settings_dict(py, &Settings::default()),
        "SafeCddpSolver" => crate::safe::safe_defaults(py),
        "Mpc" => crate::safe::mpc_defaults(py),
        other => Err(invalid(
            "kind",
            format!("must be 'Solver', 'SafeCddpSolver' or 'Mpc', got '{other}'"),
        )
        .into()),
    }
}

fn count(field: &str, v: i64) -> CoreResult<usize> {
    usize::try_from(v)
        .ok()
        .filter(|&n| n >= 1)
        .ok_or_else(|| invalid(field, format!("must be at least 1, got {v}")))
}

/// ddp-core's nested [`Settings`] from the flat keyword arguments of `Solver` and
/// `solve_batch` (validated; errors name the keyword).
#[allow(clippy::too_many_arguments)]
pub(crate) fn build_settings(
    method: &str,
    shooting: &str,
    max_iterations: i64,
    gradient_tolerance: f64,
    cost_tolerance: f64,
    mu_init: f64,
    mu_min: f64,
    mu_max: f64,
    mu_factor: f64,
    regularization: &str,
    step_factor: f64,
    step_min: f64,
    armijo: f64,
    box_qp_iterations: i64,
    derivative_threads: i64,
) -> CoreResult<Settings> {
    let placement = match regularization.to_ascii_lowercase().as_str() {
        "control" => Regularization::Control,
        "state" => Regularization::State,
        other => {
            return Err(invalid(
                "regularization",
                format!("must be 'control' or 'state', got '{other}'"),
            ))
        }
    };
    let settings = Settings {
        method: parse_method(method)?,
        shooting: parse_shooting(shooting)?,
        max_iterations: count("max_iterations", max_iterations)?,
        tolerances: Tolerances {
            gradient: gradient_tolerance,
            cost: cost_tolerance,
        },
        regularization: RegularizationSettings {
            mu_init,
            mu_min,
            mu_max,
            mu_factor,
            placement,
        },
        line_search: LineSearchSettings {
            step_factor,
            step_min,
            armijo,
        },
        box_qp_iterations: count("box_qp_iterations", box_qp_iterations)?,
        derivative_threads: count("settings.derivative_threads", derivative_threads)?,
    };
    settings.validate().map_err(flat_error)?;
    Ok(settings)
}

/// iLQR / DDP / box-DDP solver for one `Problem`, with a workspace allocated once.
///
/// The workspace keeps the last solution: `solve(warm_start=True)` starts from it, `shift()`
/// moves it one knot for receding horizon. A solver is used by one thread at a time (a second
/// thread calling `solve` concurrently gets a `RuntimeError`); the GIL is released during solves,
/// so several solvers run in parallel.
#[pyclass(module = "ddpkit._ddpkit")]
pub struct Solver {
    problem: Py<Problem>,
    shared: Arc<RwLock<AnyProblem>>,
    inner: AnySolver,
    settings: Settings,
    nx: usize,
    nu: usize,
    horizon: usize,
}

#[pymethods]
impl Solver {
    #[new]
    #[pyo3(signature = (
        problem,
        method = method_name(Settings::default().method),
        shooting = shooting_name(Settings::default().shooting),
        max_iterations = Settings::default().max_iterations as i64,
        gradient_tolerance = Tolerances::default().gradient,
        cost_tolerance = Tolerances::default().cost,
        mu_init = RegularizationSettings::default().mu_init,
        mu_min = RegularizationSettings::default().mu_min,
        mu_max = RegularizationSettings::default().mu_max,
        mu_factor = RegularizationSettings::default().mu_factor,
        regularization = placement_name(RegularizationSettings::default().placement),
        step_factor = LineSearchSettings::default().step_factor,
        step_min = LineSearchSettings::default().step_min,
        armijo = LineSearchSettings::default().armijo,
        box_qp_iterations = Settings::default().box_qp_iterations as i64,
        derivative_threads = Settings::default().derivative_threads as i64,
    ))]
    // The defaults as Python sees them (`inspect.signature`, the stub); tests compare both with
    // `default_settings()`.
    #[pyo3(
        text_signature = "(problem, method='ilqr', shooting='single', max_iterations=200, gradient_tolerance=1e-9, \
                             cost_tolerance=1e-14, mu_init=0.0, mu_min=1e-9, mu_max=1e10, mu_factor=1.6, \
                             regularization='control', step_factor=0.5, step_min=0.0009765625, armijo=1e-4, \
                             box_qp_iterations=100, derivative_threads=1)"
    )]
    #[allow(clippy::too_many_arguments)]
    fn new(
        problem: Bound<'_, Problem>,
        method: &str,
        shooting: &str,
        #[pyo3(from_py_with = crate::convert::int_i64)] max_iterations: i64,
        gradient_tolerance: f64,
        cost_tolerance: f64,
        mu_init: f64,
        mu_min: f64,
        mu_max: f64,
        mu_factor: f64,
        regularization: &str,
        step_factor: f64,
        step_min: f64,
        armijo: f64,
        #[pyo3(from_py_with = crate::convert::int_i64)] box_qp_iterations: i64,
        #[pyo3(from_py_with = crate::convert::int_i64)] derivative_threads: i64,
    ) -> PyResult<Self> {
        let mut settings = build_settings(
            method,
            shooting,
            max_iterations,
            gradient_tolerance,
            cost_tolerance,
            mu_init,
            mu_min,
            mu_max,
            mu_factor,
            regularization,
            step_factor,
            step_min,
            armijo,
            box_qp_iterations,
            derivative_threads,
        )?;
        if settings.derivative_threads > 1 && problem.get().calls_python(problem.py()) {
            // A Python callable model takes the GIL for every evaluation (threads gain nothing)
            // and keeps its exception for the thread that called it: derivatives stay here.
            settings.derivative_threads = 1;
        }
        let p = problem.get();
        let (nx, nu, horizon) = (p.nx, p.nu, p.horizon);
        let shared = p.inner.clone();
        let inner = Problem::read(&shared, |q| with_dims!(nx, nu, new_solver(q, settings)))?;
        Ok(Self {
            problem: problem.unbind(),
            shared,
            inner,
            settings,
            nx,
            nu,
            horizon,
        })
    }

    /// Solves the problem and returns the `Solution`.
    ///
    /// The initial guess: `us0` if given (shape `(N, nu)`); otherwise the controls of the last
    /// solve when `warm_start` is true, or zeros. Without `warm_start` every solve is a cold
    /// start (as after `reset()`), `us0` or not. The GIL is released meanwhile.
    #[pyo3(signature = (us0 = None, warm_start = false, xs0 = None))]
    fn solve(
        &mut self,
        py: Python<'_>,
        us0: Option<&Bound<'_, PyAny>>,
        warm_start: bool,
        xs0: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Solution> {
        let us0 = match us0 {
            Some(u) if !u.is_none() => Some(finite_arr(u, "us0")?),
            _ => None,
        };
        let xs0 = match xs0 {
            Some(x) if !x.is_none() => Some(finite_arr(x, "xs0")?),
            _ => None,
        };
        let (nx, nu) = (self.nx, self.nu);
        let shared = &self.shared;
        let inner = &mut self.inner;
        let out = py.detach(|| -> CoreResult<SolveOut> {
            Problem::read(shared, |p| {
                with_dims!(nx, nu, solve_impl(inner, p, us0.as_ref(), xs0.as_ref(), warm_start))
            })
        });
        // An exception raised by a Python callable model is the solve's error.
        crate::callable::raise_pending()?;
        let out = out?;
        Ok(Solution::from_out(out, nx, nu, self.horizon))
    }

    /// Receding horizon: drops the first knot of the last solution and repeats the last control,
    /// so `solve(warm_start=True)` from the next state starts from the shifted trajectory.
    fn shift(&mut self) -> PyResult<()> {
        Ok(with_dims!(self.nx, self.nu, shift_impl(&mut self.inner))?)
    }

    /// Zeros the stored initial guess and gains (the next warm start is a cold start).
    fn reset(&mut self) -> PyResult<()> {
        Ok(with_dims!(self.nx, self.nu, reset_impl(&mut self.inner))?)
    }

    /// The controls held for the next warm start, shape `(N, nu)`.
    #[getter]
    fn controls<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let us = with_dims!(self.nx, self.nu, controls_impl(&self.inner))?;
        rows_to_numpy(py, self.horizon, self.nu, us)
    }

    /// The problem this solver solves.
    #[getter]
    fn problem(&self, py: Python<'_>) -> Py<Problem> {
        self.problem.clone_ref(py)
    }

    /// The settings as a dict.
    #[getter]
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        settings_dict(py, &self.settings)
    }

    /// Pickles as its problem and settings: the unpickled solver has a fresh workspace (the next
    /// solve is a cold start unless `us0` is given).
    #[allow(clippy::type_complexity)]
    fn __getnewargs_ex__<'py>(&self, py: Python<'py>) -> PyResult<((Py<Problem>,), Bound<'py, PyDict>)> {
        Ok(((self.problem.clone_ref(py),), settings_dict(py, &self.settings)?))
    }

    /// Equal when the problems and the settings are.
    fn __eq__(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        let Ok(o) = other.cast::<Solver>() else {
            return Ok(false);
        };
        let o = o.try_borrow()?;
        Ok(o.settings == self.settings && self.problem.bind(py).eq(o.problem.bind(py))?)
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

    /// The horizon `N`.
    #[getter]
    fn horizon(&self) -> usize {
        self.horizon
    }

    fn __repr__(&self) -> String {
        let method = method_name(self.settings.method);
        format!(
            "Solver(method='{method}', nx={}, nu={}, horizon={})",
            self.nx, self.nu, self.horizon
        )
    }
}

/// The result of `Solver.solve`: trajectory, feedback gains and statistics.
///
/// The feedback law around the solution is `u_k = us[k] + K[k] @ (x_k - xs[k])`.
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct Solution {
    // The arrays (numpy arrays once read; see the getters).
    xs: LazyArray,
    us: LazyArray,
    gains: LazyArray,
    feedforward: LazyArray,
    /// How the solve ended: `"converged"`, `"max_iterations"`, `"regularization_limit"`,
    /// `"line_search_failed"` or `"numerical_error"`.
    #[pyo3(get)]
    status: String,
    /// Accepted steps.
    #[pyo3(get)]
    iterations: usize,
    /// Final cost.
    #[pyo3(get)]
    cost: f64,
    /// Cost of the initial rollout.
    #[pyo3(get)]
    initial_cost: f64,
    /// Final `sum_k |Q_u,free|^2`.
    #[pyo3(get)]
    gradient: f64,
    /// Final regularisation.
    #[pyo3(get)]
    mu: f64,
    /// Backward passes computed (including regularisation retries).
    #[pyo3(get)]
    backward_passes: usize,
    /// Forward rollouts in line searches.
    #[pyo3(get)]
    forward_passes: usize,
    /// Wall time of the solve inside Rust (s).
    #[pyo3(get)]
    solve_time: f64,
    /// Largest entry of the dynamics defects `f(x_k, u_k) - x_{k+1}` of `xs`, `us`: 0 under
    /// single shooting (`xs` is the rollout of `us`), at most 1e-9 after a converged
    /// multiple-shooting solve.
    #[pyo3(get)]
    defect: f64,
    cost_history: LazyArray,
    /// The solver's report, kept to print the iteration table on demand.
    table: Table,
}

/// The fields of a `Solution` as pickled, in order.
const SOLUTION_FIELDS: [&str; 16] = [
    "xs",
    "us",
    "K",
    "k",
    "status",
    "iterations",
    "cost",
    "initial_cost",
    "gradient",
    "mu",
    "backward_passes",
    "forward_passes",
    "solve_time",
    "defect",
    "cost_history",
    "table",
];

impl Solution {
    /// A solution from its pickled fields.
    pub(crate) fn from_state(d: &Bound<'_, PyDict>) -> PyResult<Self> {
        let py = d.py();
        Ok(Self {
            xs: LazyArray::ready(py, field(d, "xs")?),
            us: LazyArray::ready(py, field(d, "us")?),
            gains: LazyArray::ready(py, field(d, "K")?),
            feedforward: LazyArray::ready(py, field(d, "k")?),
            status: field(d, "status")?,
            iterations: field(d, "iterations")?,
            cost: field(d, "cost")?,
            initial_cost: field(d, "initial_cost")?,
            gradient: field(d, "gradient")?,
            mu: field(d, "mu")?,
            backward_passes: field(d, "backward_passes")?,
            forward_passes: field(d, "forward_passes")?,
            solve_time: field(d, "solve_time")?,
            defect: field(d, "defect")?,
            cost_history: LazyArray::ready(py, field(d, "cost_history")?),
            table: Table::Text(field(d, "table")?),
        })
    }

    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let values: [Bound<'py, PyAny>; 16] = [
            self.xs.get(py)?,
            self.us.get(py)?,
            self.gains.get(py)?,
            self.feedforward.get(py)?,
            self.status.clone().into_pyobject(py)?.into_any(),
            self.iterations.into_pyobject(py)?.into_any(),
            self.cost.into_pyobject(py)?.into_any(),
            self.initial_cost.into_pyobject(py)?.into_any(),
            self.gradient.into_pyobject(py)?.into_any(),
            self.mu.into_pyobject(py)?.into_any(),
            self.backward_passes.into_pyobject(py)?.into_any(),
            self.forward_passes.into_pyobject(py)?.into_any(),
            self.solve_time.into_pyobject(py)?.into_any(),
            self.defect.into_pyobject(py)?.into_any(),
            self.cost_history.get(py)?,
            self.table.text().into_pyobject(py)?.into_any(),
        ];
        for (k, v) in SOLUTION_FIELDS.iter().zip(values) {
            d.set_item(k, v)?;
        }
        Ok(d)
    }
}

impl Solution {
    /// The Python object of a solve's plain-data results (`n` knots).
    fn from_out(out: SolveOut, nx: usize, nu: usize, n: usize) -> Self {
        let history = out.cost_history.len();
        Solution {
            xs: LazyArray::new(&[n + 1, nx], out.xs),
            us: LazyArray::new(&[n, nu], out.us),
            gains: LazyArray::new(&[n, nu, nx], out.gains),
            feedforward: LazyArray::new(&[n, nu], out.feedforward),
            status: out.status.to_string(),
            iterations: out.iterations,
            cost: out.cost,
            initial_cost: out.initial_cost,
            gradient: out.gradient,
            mu: out.mu,
            backward_passes: out.backward_passes,
            forward_passes: out.forward_passes,
            solve_time: out.solve_time,
            defect: out.defect,
            cost_history: LazyArray::new(&[history], out.cost_history),
            table: Table::Core(Box::new(out.report)),
        }
    }
}

#[pymethods]
impl Solution {
    /// States `x_0 .. x_N`, shape `(N+1, nx)`.
    #[getter]
    fn xs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.xs.get(py)
    }
    /// Controls `u_0 .. u_{N-1}`, shape `(N, nu)`.
    #[getter]
    fn us<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.us.get(py)
    }
    /// Feedback gains `K_k`, shape `(N, nu, nx)`.
    #[getter(K)]
    fn gains<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.gains.get(py)
    }
    /// Feed-forward terms `k_k` of the last backward pass, shape `(N, nu)`.
    #[getter(k)]
    fn feedforward<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.feedforward.get(py)
    }
    /// Cost of the initial rollout and after every accepted step.
    #[getter]
    fn cost_history<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.cost_history.get(py)
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
        Ok((module_attr(py, "_unpickle_result")?, ("Solution", self.state(py)?)))
    }

    /// Equal when every field is (arrays by value, the iteration table by text).
    fn __eq__(&self, py: Python<'_>, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        match other.cast::<Solution>() {
            Ok(o) => equal_values(self.state(py)?.as_any(), o.get().state(py)?.as_any()),
            Err(_) => Ok(false),
        }
    }

    fn __repr__(&self) -> String {
        format!(
            "Solution(status='{}', iterations={}, cost={:.10e}, solve_time={:.3e})",
            self.status, self.iterations, self.cost, self.solve_time
        )
    }
}

/// One problem of a batch: the same steps as `Solver.solve()` from a cold start.
fn batch_impl<NX: Dim, NU: Dim>(
    problems: &[&AnyProblem],
    settings: Settings,
    threads: usize,
) -> Result<Vec<SolveOut>, crate::batch::BatchError>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    crate::batch::run(
        problems,
        threads,
        || new_solver::<NX, NU>(problems[0], settings),
        |solver, _, p| solve_impl::<NX, NU>(solver, p, None, None, false),
    )
}

/// Solves many problems of one structure (the same ``nx``, ``nu`` and horizon; different
/// ``x0``, costs, targets or models) on ``threads`` threads in one call, each from a cold start
/// with the settings of :class:`Solver` (same keywords, same defaults), and returns their
/// :class:`Solution`\ s in order. The GIL is released meanwhile.
///
/// Each solution equals ``Solver(problem, **settings).solve()`` for that problem alone, bit for
/// bit, whatever the thread count: every worker thread owns one workspace and resets it before
/// each problem. ``threads=None`` uses ``RAYON_NUM_THREADS`` when set, else every core.
///
/// Errors, before any solve: an empty list or a non-Problem item (``problems``,
/// ``problems[i]``), a problem of other sizes or horizon than the first (``ShapeError`` naming
/// ``problems[i]``), ``threads < 1``, invalid settings. An exception raised by a Python
/// callable model is raised as itself (the other problems are still solved).
#[pyfunction]
#[pyo3(signature = (
    problems,
    *,
    threads = None,
    method = method_name(Settings::default().method),
    shooting = shooting_name(Settings::default().shooting),
    max_iterations = Settings::default().max_iterations as i64,
    gradient_tolerance = Tolerances::default().gradient,
    cost_tolerance = Tolerances::default().cost,
    mu_init = RegularizationSettings::default().mu_init,
    mu_min = RegularizationSettings::default().mu_min,
    mu_max = RegularizationSettings::default().mu_max,
    mu_factor = RegularizationSettings::default().mu_factor,
    regularization = placement_name(RegularizationSettings::default().placement),
    step_factor = LineSearchSettings::default().step_factor,
    step_min = LineSearchSettings::default().step_min,
    armijo = LineSearchSettings::default().armijo,
    box_qp_iterations = Settings::default().box_qp_iterations as i64,
))]
#[pyo3(
    text_signature = "(problems, *, threads=None, method='ilqr', shooting='single', max_iterations=200, gradient_tolerance=1e-9, \
                         cost_tolerance=1e-14, mu_init=0.0, mu_min=1e-9, mu_max=1e10, mu_factor=1.6, \
                         regularization='control', step_factor=0.5, step_min=0.0009765625, armijo=1e-4, \
                         box_qp_iterations=100)"
)]
#[allow(clippy::too_many_arguments)]
pub fn solve_batch(
    py: Python<'_>,
    problems: &Bound<'_, PyAny>,
    #[pyo3(from_py_with = crate::convert::opt_int_i64)] threads: Option<i64>,
    method: &str,
    shooting: &str,
    #[pyo3(from_py_with = crate::convert::int_i64)] max_iterations: i64,
    gradient_tolerance: f64,
    cost_tolerance: f64,
    mu_init: f64,
    mu_min: f64,
    mu_max: f64,
    mu_factor: f64,
    regularization: &str,
    step_factor: f64,
    step_min: f64,
    armijo: f64,
    #[pyo3(from_py_with = crate::convert::int_i64)] box_qp_iterations: i64,
) -> PyResult<Vec<Solution>> {
    let settings = build_settings(
        method,
        shooting,
        max_iterations,
        gradient_tolerance,
        cost_tolerance,
        mu_init,
        mu_min,
        mu_max,
        mu_factor,
        regularization,
        step_factor,
        step_min,
        armijo,
        box_qp_iterations,
        1,
    )?;
    let batch = crate::batch::problems_of(problems)?;
    let threads = crate::batch::threads_of(threads)?;
    let (nx, nu, n) = (batch.nx, batch.nu, batch.horizon);
    let locks = &batch.locks;
    let outs =
        py.detach(|| crate::batch::read_all(locks, |ps| with_dims!(nx, nu, batch_impl(ps, settings, threads))))?;
    Ok(outs.into_iter().map(|o| Solution::from_out(o, nx, nu, n)).collect())
}
