//! IDNP with adaptive grid refinement (Richter et al. 2023, crate `idnp`), public as `ddpkit.idnp`.
//!
//! The scene is the crate's benchmark ([`::idnp::scene::Scene::narrow_passage`]): a floating base
//! with a 2-link arm, four rectangles with a passage narrower than the coarse DP grid, and a goal
//! ball for the tool centre point (TCP).
//!
//! | Python (`ddpkit.idnp`) | here |
//! |---|---|
//! | `scene()` | [`idnp_scene`] |
//! | `configuration(tcp)` | [`idnp_configuration`] |
//! | `run(q0, variant)` -> `Run` | [`idnp_run`], [`IdnpRun`] |
//! | `experiment(n, seed)` -> `Experiment` | [`idnp_experiment`], [`IdnpExperiment`] |
//!
//! Runs and the experiment release the GIL; results are a function of the input (and seed) only,
//! wall times aside.

use std::sync::Arc;

use ::idnp::experiment::{run_experiment, ExperimentConfig, ExperimentResult};
use ::idnp::idnp::{Idnp, IdnpOutcome, IdnpSettings, Variant};
use ::idnp::inverse::inverse_map;
use ::idnp::scene::{Config, Scene};
use ddp_core::Vector;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use crate::convert::{finite_arr, rows_to_numpy, shape_str, vec_to_numpy};
use crate::errors::{invalid, shape, CoreError, CoreResult};

/// An `idnp` error on its way to Python: the field and reason kept.
fn idnp_error(e: ::idnp::Error) -> CoreError {
    match e {
        ::idnp::Error::Invalid { field, reason } => invalid(field, reason),
        ::idnp::Error::Solver(e) => CoreError(e),
        other => invalid("idnp", other.to_string()),
    }
}

fn parse_variant(variant: &str) -> CoreResult<Variant> {
    match variant {
        "adaptive" => Ok(Variant::Adaptive),
        "fixed" => Ok(Variant::FixedGrid),
        other => Err(invalid(
            "variant",
            format!("must be \"adaptive\" or \"fixed\", got {other:?}"),
        )),
    }
}

/// The benchmark scene as a dict: ``obstacles`` (list of ``(k, 2)`` vertex arrays),
/// ``goal_center``, ``goal_radius``, ``passage`` (``(2, 2)``: lower and upper corner of the gap),
/// ``domain_min``, ``domain_max``, ``cell_size`` (the coarse DP grid spacing), ``link_radius``,
/// ``dt`` (the NLP step).
#[pyfunction]
pub fn idnp_scene(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let scene = Scene::narrow_passage();
    let d = PyDict::new(py);
    let obstacles = PyList::empty(py);
    for o in &scene.obstacles {
        let v = o.vertices();
        obstacles.append(rows_to_numpy(py, v.len(), 2, v.iter().flatten().copied().collect())?)?;
    }
    d.set_item("obstacles", obstacles)?;
    d.set_item("goal_center", vec_to_numpy(py, scene.goal.center.to_vec()))?;
    d.set_item("goal_radius", scene.goal.radius)?;
    match scene.passage {
        Some(p) => d.set_item(
            "passage",
            rows_to_numpy(py, 2, 2, p.iter().flatten().copied().collect())?,
        )?,
        None => d.set_item("passage", py.None())?,
    }
    d.set_item("domain_min", vec_to_numpy(py, scene.domain.min.to_vec()))?;
    d.set_item("domain_max", vec_to_numpy(py, scene.domain.max().to_vec()))?;
    d.set_item("cell_size", scene.domain.cell_size)?;
    d.set_item("link_radius", scene.link_radius)?;
    d.set_item("dt", scene.robot.dt())?;
    Ok(d)
}

/// A collision-free configuration ``(x, y, theta, q1, q2)`` at rest whose TCP is at ``tcp``,
/// found by the inverse mapping (eq. (5)) from a bent arm with the base 1 m behind the TCP.
/// Errors name ``tcp`` and the reason (collision, limit, unreachable).
#[pyfunction]
pub fn idnp_configuration<'py>(py: Python<'py>, tcp: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let a = finite_arr(tcp, "tcp")?;
    let z: Vector<2> = a.vector("tcp", nalgebra::U2)?;
    let z = [z[0], z[1]];
    let scene = Scene::narrow_passage();
    let settings = IdnpSettings::default();
    let nominal = Config::new(z[0] - 1.0, z[1], 0.0, 0.5, -1.0);
    let q = py
        .detach(|| inverse_map(&scene, &settings.inverse, &nominal, z, 0))
        .map_err(|f| invalid("tcp", format!("{z:?} cannot be reached: {:?}", f.reason)))?;
    Ok(vec_to_numpy(py, q.iter().copied().collect()))
}

/// The state of `q0`: a configuration (5, at rest) or a full state (10).
fn initial_state(q0: &Bound<'_, PyAny>) -> PyResult<Vector<10>> {
    let a = finite_arr(q0, "q0")?;
    match a.shape.as_slice() {
        [5] => Ok(Scene::state_at_rest(&Config::from_row_slice(&a.data))),
        [10] => Ok(Vector::<10>::from_row_slice(&a.data)),
        _ => Err(shape("q0", shape_str(&a.shape), "(5,) or (10,)").into()),
    }
}

/// One IDNP run (Algorithm 1 or the fixed-grid original) on the benchmark scene; see
/// :func:`ddpkit.idnp.run`.
#[pyfunction]
#[pyo3(signature = (q0, variant = "adaptive", max_iterations = 15, max_level = 4))]
pub fn idnp_run(
    py: Python<'_>,
    q0: &Bound<'_, PyAny>,
    variant: &str,
    #[pyo3(from_py_with = crate::convert::int_usize)] max_iterations: usize,
    #[pyo3(from_py_with = crate::convert::int_u8)] max_level: u8,
) -> PyResult<IdnpRun> {
    let x0 = initial_state(q0)?;
    let variant = parse_variant(variant)?;
    let settings = IdnpSettings {
        max_iterations,
        max_level,
        ..IdnpSettings::default()
    };
    let scene = Arc::new(Scene::narrow_passage());
    let (out, grids) = py
        .detach(|| -> ::idnp::Result<_> {
            let mut run = Idnp::new(scene.clone(), settings, variant, x0)?;
            let out = run.run()?;
            let grids: Vec<Vec<f64>> = run
                .grids()
                .iter()
                .map(|g| {
                    g.leaves()
                        .iter()
                        .filter_map(|&l| g.cell(l))
                        .flat_map(|c| [c.center[0], c.center[1], c.size])
                        .collect()
                })
                .collect();
            Ok((out, grids))
        })
        .map_err(idnp_error)?;
    IdnpRun::new(py, &out, grids, variant)
}

/// The result of :func:`ddpkit.idnp.run`.
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct IdnpRun {
    /// ``"adaptive"`` or ``"fixed"``.
    #[pyo3(get)]
    variant: String,
    /// Whether a collision-free trajectory to the goal (at rest) was found.
    #[pyo3(get)]
    success: bool,
    /// ``"solved"``, ``"max_iterations"`` or ``"stalled"``.
    #[pyo3(get)]
    termination: String,
    /// Iterations run.
    #[pyo3(get)]
    iterations: usize,
    /// The DP waypoints of every iteration, each ``(T + 1, 2)``.
    #[pyo3(get)]
    waypoints: Py<PyAny>,
    /// DP cells (quadtree leaves summed over the time indices) used by each iteration.
    #[pyo3(get)]
    cells: Vec<usize>,
    /// DP grid points (values stored) used by each iteration.
    #[pyo3(get)]
    grid_points: Vec<usize>,
    /// Cells of the final grids.
    #[pyo3(get)]
    final_cells: usize,
    /// Waypoints the inverse mapping could not map: ``(iteration, time index, (x, y), reason)``.
    #[pyo3(get)]
    inverse_failures: Vec<(usize, usize, (f64, f64), String)>,
    /// Wall time (s) of the DP, the inverse mapping and the NLP of each iteration.
    #[pyo3(get)]
    dp_time: Vec<f64>,
    /// See ``dp_time``.
    #[pyo3(get)]
    inverse_time: Vec<f64>,
    /// See ``dp_time``.
    #[pyo3(get)]
    nlp_time: Vec<f64>,
    /// States ``(N + 1, 10)`` of the last NLP solve (the solution when ``success``), or ``None``
    /// when no waypoint sequence could be mapped.
    #[pyo3(get)]
    xs: Py<PyAny>,
    /// Controls ``(N, 5)`` of the last NLP solve, or ``None``.
    #[pyo3(get)]
    us: Py<PyAny>,
    /// Final grids: per time index the leaves as rows ``(center_x, center_y, size)``.
    grids: Vec<Vec<f64>>,
}

impl IdnpRun {
    fn new(py: Python<'_>, out: &IdnpOutcome, grids: Vec<Vec<f64>>, variant: Variant) -> PyResult<Self> {
        let waypoints = PyList::empty(py);
        let mut failures = Vec::new();
        for r in &out.iterations {
            let w = &r.waypoints;
            waypoints.append(rows_to_numpy(py, w.len(), 2, w.iter().flatten().copied().collect())?)?;
            for f in &r.inverse_failures {
                failures.push((
                    r.iteration,
                    f.stage,
                    (f.waypoint[0], f.waypoint[1]),
                    format!("{:?}", f.reason),
                ));
            }
        }
        let last_nlp = out.iterations.iter().rev().find_map(|r| r.nlp.as_ref());
        let (xs, us) = match last_nlp {
            Some(n) => (
                rows_to_numpy(
                    py,
                    n.xs.len(),
                    10,
                    n.xs.iter().flat_map(|x| x.iter().copied()).collect(),
                )?
                .unbind(),
                rows_to_numpy(py, n.us.len(), 5, n.us.iter().flat_map(|u| u.iter().copied()).collect())?.unbind(),
            ),
            None => (py.None(), py.None()),
        };
        let termination = match out.termination {
            ::idnp::idnp::Termination::Solved => "solved",
            ::idnp::idnp::Termination::MaxIterations => "max_iterations",
            ::idnp::idnp::Termination::Stalled => "stalled",
        };
        Ok(Self {
            variant: variant.as_str().to_string(),
            success: out.success(),
            termination: termination.to_string(),
            iterations: out.iterations.len(),
            waypoints: waypoints.into_any().unbind(),
            cells: out.iterations.iter().map(|r| r.grid.cells).collect(),
            grid_points: out.iterations.iter().map(|r| r.grid.vertices).collect(),
            final_cells: out.grid.cells,
            inverse_failures: failures,
            dp_time: out.iterations.iter().map(|r| r.dp_time).collect(),
            inverse_time: out.iterations.iter().map(|r| r.inverse_time).collect(),
            nlp_time: out.iterations.iter().map(|r| r.nlp_time).collect(),
            xs,
            us,
            grids,
        })
    }
}

#[pymethods]
impl IdnpRun {
    /// The leaves of the final grid of time index ``j`` as an ``(k, 3)`` array of rows
    /// ``(center_x, center_y, size)``.
    fn grid<'py>(
        &self,
        py: Python<'py>,
        #[pyo3(from_py_with = crate::convert::int_usize)] j: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let g = self
            .grids
            .get(j)
            .ok_or_else(|| invalid("j", format!("time index {j} out of range ({} grids)", self.grids.len())))?;
        rows_to_numpy(py, g.len() / 3, 3, g.clone())
    }
    fn __repr__(&self) -> String {
        format!(
            "IdnpRun(variant='{}', success={}, termination='{}', iterations={}, final_cells={})",
            self.variant,
            if self.success { "True" } else { "False" },
            self.termination,
            self.iterations,
            self.final_cells
        )
    }
}

/// The experiment of Richter et al. (2023), Section V; see :func:`ddpkit.idnp.experiment`.
#[pyfunction]
#[pyo3(signature = (n = 200, seed = 1, max_iterations = 15, optimizer_iterations = 400, uniform = false))]
pub fn idnp_experiment(
    py: Python<'_>,
    #[pyo3(from_py_with = crate::convert::int_usize)] n: usize,
    #[pyo3(from_py_with = crate::convert::int_u64)] seed: u64,
    #[pyo3(from_py_with = crate::convert::int_usize)] max_iterations: usize,
    #[pyo3(from_py_with = crate::convert::int_usize)] optimizer_iterations: usize,
    uniform: bool,
) -> PyResult<IdnpExperiment> {
    let scene = Arc::new(Scene::narrow_passage());
    let mut config = ExperimentConfig {
        seed,
        initial_conditions: n,
        optimizer_iterations,
        ..ExperimentConfig::default()
    };
    config.settings.max_iterations = max_iterations;
    if uniform {
        config.uniform_level = ::idnp::experiment::passage_resolving_level(&scene, &config.settings);
    }
    let result = py
        .detach(|| run_experiment(&scene, &config, &|| {}))
        .map_err(idnp_error)?;
    IdnpExperiment::new(py, result)
}

/// The result of :func:`ddpkit.idnp.experiment`.
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct IdnpExperiment {
    /// Initial conditions.
    #[pyo3(get)]
    cases: usize,
    /// Successes of fixed-grid IDNP (penalty adaptation).
    #[pyo3(get)]
    solved_fixed: usize,
    /// Successes of adaptive IDNP (Algorithm 1).
    #[pyo3(get)]
    solved_adaptive: usize,
    /// Successes of the constrained DDP alone from a straight line.
    #[pyo3(get)]
    solved_optimizer: usize,
    /// Successes of fixed-grid IDNP on the uniform grid resolving the passage (``uniform=True``).
    #[pyo3(get)]
    solved_uniform: Option<usize>,
    /// Cases solved by the fixed grid but not by the adaptive one (the paper saw none).
    #[pyo3(get)]
    fixed_not_adaptive: Vec<usize>,
    /// DP cells of the coarse grids (all time indices).
    #[pyo3(get)]
    coarse_cells: usize,
    /// Mean DP cells of the adaptive grids when they succeeded.
    #[pyo3(get)]
    adaptive_cells_mean: f64,
    /// Largest DP cell count of the adaptive grids when they succeeded.
    #[pyo3(get)]
    adaptive_cells_max: f64,
    /// DP cells of the coarsest uniform grid that resolves the passage, if there is one.
    #[pyo3(get)]
    uniform_cells: Option<usize>,
    /// Per case: fixed-grid success.
    #[pyo3(get)]
    fixed_success: Vec<bool>,
    /// Per case: adaptive success.
    #[pyo3(get)]
    adaptive_success: Vec<bool>,
    /// Per case: success of the optimiser alone.
    #[pyo3(get)]
    optimizer_success: Vec<bool>,
    /// Initial TCP positions, ``(n, 2)``.
    #[pyo3(get)]
    initial_tcp: Py<PyAny>,
    result: ExperimentResult,
}

impl IdnpExperiment {
    fn new(py: Python<'_>, result: ExperimentResult) -> PyResult<Self> {
        let s = &result.summary;
        let c = &result.cases;
        Ok(Self {
            cases: s.cases,
            solved_fixed: s.solved_fixed,
            solved_adaptive: s.solved_adaptive,
            solved_optimizer: s.solved_optimizer,
            solved_uniform: s.solved_uniform,
            fixed_not_adaptive: s.fixed_not_adaptive.clone(),
            coarse_cells: s.coarse_grid.cells,
            adaptive_cells_mean: s.adaptive_cells_at_success[0],
            adaptive_cells_max: s.adaptive_cells_at_success[1],
            uniform_cells: s.uniform_grid.map(|g| g.cells),
            fixed_success: c.iter().map(|c| c.fixed.success).collect(),
            adaptive_success: c.iter().map(|c| c.adaptive.success).collect(),
            optimizer_success: c.iter().map(|c| c.optimizer.success).collect(),
            initial_tcp: rows_to_numpy(py, c.len(), 2, c.iter().flat_map(|c| c.initial.tcp).collect())?.unbind(),
            result,
        })
    }
}

#[pymethods]
impl IdnpExperiment {
    /// The table (Markdown) beside the paper's numbers, with cell counts and times per
    /// iteration.
    fn table(&self) -> String {
        self.result.summary.table()
    }
    /// Every result as JSON (what ``idnp-experiment --json`` writes).
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.result).map_err(|e| invalid("result", e.to_string()).into())
    }
    fn __repr__(&self) -> String {
        format!(
            "IdnpExperiment(cases={}, solved_fixed={}, solved_adaptive={}, solved_optimizer={})",
            self.cases, self.solved_fixed, self.solved_adaptive, self.solved_optimizer
        )
    }
}

/// Registers the IDNP classes and functions.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<IdnpRun>()?;
    m.add_class::<IdnpExperiment>()?;
    m.add_function(wrap_pyfunction!(idnp_scene, m)?)?;
    m.add_function(wrap_pyfunction!(idnp_configuration, m)?)?;
    m.add_function(wrap_pyfunction!(idnp_run, m)?)?;
    m.add_function(wrap_pyfunction!(idnp_experiment, m)?)?;
    Ok(())
}
