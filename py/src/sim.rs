//! `ddpkit.sim`: the sim2d simulation from Python. One scenario run (a TOML scenario, a planner,
//! physics, lidar, costmap and planning in the loop) with its trajectory and metrics as numpy
//! arrays, and the Safe-CDDP Turtlebot experiment (Alcan and Kyrki 2022, §IV-C). The GIL is released while
//! the simulation runs; every [`sim2d::Error`] becomes a `ddpkit.DdpError` subclass whose
//! `field` names the offending input.
//!
//! | Python | Rust |
//! |---|---|
//! | `sim_run_scenario` (public as `ddpkit.sim.run_scenario`) -> `SimResult` | [`sim2d::run_scenario`] |
//! | `sim_safe_turtlebot` (public as `ddpkit.sim.safe_turtlebot`) -> `TurtlebotExperiment` | [`sim2d::turtlebot::run_experiment`] |

use std::path::PathBuf;

use numpy::ndarray::Array1;
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyList, PyString};
use sim2d::log::{LogOptions, Recorder};
use sim2d::turtlebot::{experiment_json, run_experiment, write_figure, Experiment, TurtlebotConfig, TurtlebotRun};
use sim2d::{Direction, Observer, PlannerKind, RunConfig, RunResult, Scenario};

use crate::convert::{rows_to_numpy, vec_to_numpy};
use crate::errors::{invalid, CoreError};

/// A [`sim2d::Error`] as a ddp-core error (the exception tree of [`crate::errors`]): invalid
/// values keep their field; unreadable or malformed scenario files name `scenario`; failed
/// writes name the output argument.
fn sim_error(e: sim2d::Error, write_field: &str) -> CoreError {
    match e {
        sim2d::Error::Invalid { field, reason } => invalid(field, reason),
        sim2d::Error::Ddp(e) => CoreError(e),
        e @ sim2d::Error::Read { .. } => invalid("scenario", e.to_string()),
        e @ sim2d::Error::Parse { .. } => invalid("scenario", e.to_string()),
        e @ sim2d::Error::Write { .. } => invalid(write_field, e.to_string()),
        e => invalid("simulation", e.to_string()),
    }
}

fn seed_arg(obj: &Bound<'_, PyAny>) -> PyResult<u64> {
    obj.extract::<u64>()
        .map_err(|_| invalid("seed", format!("must be an integer in [0, 2^64), got {obj}")).into())
}

/// The scenario: a path (`str` or `os.PathLike`) to a TOML file, or the TOML text itself (a
/// `str` with a newline or an `=`).
fn scenario_arg(obj: &Bound<'_, PyAny>) -> PyResult<Scenario> {
    if let Ok(s) = obj.cast::<PyString>() {
        let text = s.to_cow()?;
        if text.contains('\n') || text.contains('=') {
            let text = text.into_owned();
            return obj
                .py()
                .detach(move || Scenario::from_toml_str(&text, "<string>"))
                .map_err(|e| sim_error(e, "scenario").into());
        }
    }
    let path: PathBuf = obj.extract().map_err(|_| {
        PyErr::from(invalid(
            "scenario",
            format!(
                "must be a path (str or os.PathLike) or TOML text, got {}",
                obj.get_type().name().map(|n| n.to_string()).unwrap_or_default()
            ),
        ))
    })?;
    obj.py()
        .detach(move || Scenario::from_file(&path))
        .map_err(|e| sim_error(e, "scenario").into())
}

/// One simulated run: the trajectory (one row per control step of 0.1 s) and the metrics.
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct SimResult {
    inner: RunResult,
    /// The route as driven (reversed for backward runs) and the obstacle outlines, for `plot()`.
    route: Vec<[f64; 2]>,
    outlines: Vec<Vec<[f64; 2]>>,
}

fn column(r: &RunResult, j: usize) -> Vec<f64> {
    r.trajectory.iter().map(|row| row[j]).collect()
}

#[pymethods]
impl SimResult {
    /// Scenario name.
    #[getter]
    fn scenario(&self) -> &str {
        &self.inner.scenario
    }
    /// Planner name.
    #[getter]
    fn planner(&self) -> &str {
        &self.inner.planner
    }
    /// ``"forward"`` or ``"backward"``.
    #[getter]
    fn direction(&self) -> &'static str {
        self.inner.direction.name()
    }
    /// Noise seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.inner.seed
    }
    /// ``"completed"``, ``"stalled"`` (no progress for 30 simulated seconds) or ``"timeout"``.
    #[getter]
    fn outcome(&self) -> &'static str {
        self.inner.outcome.name()
    }
    /// Whether the robot reached the end of the route.
    #[getter]
    fn completed(&self) -> bool {
        self.inner.completed
    }
    /// Simulated time at the end (s).
    #[getter]
    fn time(&self) -> f64 {
        self.inner.time_s
    }
    /// Contact onsets with obstacles.
    #[getter]
    fn collisions(&self) -> usize {
        self.inner.collisions
    }
    /// Time in contact with obstacles (s).
    #[getter]
    fn contact_time(&self) -> f64 {
        self.inner.contact_time_s
    }
    /// Largest progress along the route (m).
    #[getter]
    fn progress(&self) -> f64 {
        self.inner.progress_m
    }
    /// Route length (m).
    #[getter]
    fn route_length(&self) -> f64 {
        self.inner.route_length_m
    }
    /// Path length driven (m).
    #[getter]
    fn distance(&self) -> f64 {
        self.inner.distance_m
    }
    /// Simulated seconds per wall-clock second of the loop.
    #[getter]
    fn real_time_factor(&self) -> f64 {
        self.inner.real_time_factor
    }
    /// Final pose ``(x, y, theta)``, shape ``(3,)``.
    #[getter]
    fn final_pose<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.inner.final_pose.to_vec())
    }
    /// Time of each control step (s), shape ``(T,)``.
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, column(&self.inner, 0))
    }
    /// Robot x at each control step (m), shape ``(T,)``.
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, column(&self.inner, 1))
    }
    /// Robot y at each control step (m), shape ``(T,)``.
    #[getter]
    fn y<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, column(&self.inner, 2))
    }
    /// Robot heading at each control step (rad), shape ``(T,)``.
    #[getter]
    fn theta<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, column(&self.inner, 3))
    }
    /// Commanded speed at each control step (m/s), shape ``(T,)``.
    #[getter]
    fn v<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, column(&self.inner, 4))
    }
    /// Commanded turn rate at each control step (rad/s), shape ``(T,)``.
    #[getter]
    fn w<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, column(&self.inner, 5))
    }
    /// Local goal at each control step, shape ``(T, 2)``.
    #[getter]
    fn goals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let g = &self.inner.goals;
        rows_to_numpy(py, g.len(), 2, g.iter().flatten().copied().collect())
    }
    /// Compute time of every optimisation epoch (ms), shape ``(E,)``.
    #[getter]
    fn epoch_ms<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.inner.epoch_ms.clone())
    }
    /// Simulated time of each kept plan (one every 10 planning cycles), shape ``(P,)``.
    #[getter]
    fn plan_times<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vec_to_numpy(py, self.inner.plans.iter().map(|p| p.time).collect())
    }
    /// Number of states of each kept plan (horizon + 1), shape ``(P,)``, int64.
    #[getter]
    fn plan_lengths<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        let n: Vec<i64> = self.inner.plans.iter().map(|p| p.positions.len() as i64).collect();
        Array1::from_vec(n).into_pyarray(py).into_any()
    }
    /// The kept plans' positions, a list of ``(K, 2)`` arrays.
    #[getter]
    fn plans<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let arrays = self
            .inner
            .plans
            .iter()
            .map(|p| {
                rows_to_numpy(
                    py,
                    p.positions.len(),
                    2,
                    p.positions.iter().flatten().copied().collect(),
                )
            })
            .collect::<PyResult<Vec<_>>>()?;
        PyList::new(py, arrays)
    }
    /// The route as driven (reversed for backward runs), shape ``(R, 2)``.
    #[getter]
    fn route<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        rows_to_numpy(py, self.route.len(), 2, self.route.iter().flatten().copied().collect())
    }
    /// The obstacles' outlines (cylinders as polygons), a list of ``(K, 2)`` arrays.
    #[getter]
    fn obstacles<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let arrays = self
            .outlines
            .iter()
            .map(|o| rows_to_numpy(py, o.len(), 2, o.iter().flatten().copied().collect()))
            .collect::<PyResult<Vec<_>>>()?;
        PyList::new(py, arrays)
    }
    /// Draws the run's top view as the binaries do (see ``ddpkit.sim.plot``; needs matplotlib,
    /// ``pip install ddpkit[plot]``) on ``ax`` or a new figure, saved to ``path`` when given;
    /// returns the axes.
    #[pyo3(signature = (ax = None, path = None))]
    fn plot<'py>(
        slf: &Bound<'py, Self>,
        ax: Option<&Bound<'py, PyAny>>,
        path: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let module = slf.py().import("ddpkit.sim")?;
        module.getattr("plot")?.call1((slf, ax, path))
    }
    /// Every figure of the run (metrics, trajectory, plans, timings) as a JSON string.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.inner).map_err(|e| invalid("result", e.to_string()).into())
    }
    fn __repr__(&self) -> String {
        format!(
            "SimResult(scenario={:?}, planner={:?}, direction={:?}, outcome={:?}, time={:.1}, collisions={})",
            self.inner.scenario,
            self.inner.planner,
            self.inner.direction.name(),
            self.inner.outcome.name(),
            self.inner.time_s,
            self.inner.collisions
        )
    }
}

/// Runs one scenario (see ``ddpkit.sim.run_scenario``); the GIL is released meanwhile.
#[pyfunction]
#[pyo3(signature = (scenario, planner = "ddp", seed = None, direction = "forward", max_time = None, horizon = None, log = None))]
fn sim_run_scenario(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
    planner: &str,
    seed: Option<&Bound<'_, PyAny>>,
    direction: &str,
    max_time: Option<f64>,
    #[pyo3(from_py_with = crate::convert::opt_int_i64)] horizon: Option<i64>,
    log: Option<PathBuf>,
) -> PyResult<SimResult> {
    let scenario = scenario_arg(scenario)?;
    let mut config = RunConfig {
        planner: PlannerKind::parse(planner).map_err(|e| sim_error(e, "planner"))?,
        direction: match direction {
            "forward" => Direction::Forward,
            "backward" => Direction::Backward,
            other => {
                return Err(invalid(
                    "direction",
                    format!("must be \"forward\" or \"backward\", got {other:?}"),
                )
                .into())
            }
        },
        seed: seed.map(seed_arg).transpose()?.unwrap_or(0),
        ..RunConfig::default()
    };
    if let Some(t) = max_time {
        config.max_time = t;
    }
    if let Some(n) = horizon {
        if n < 1 {
            return Err(invalid("horizon", format!("must be at least 1, got {n}")).into());
        }
        config.ddp.horizon = n as usize;
    }
    // The log's file is created before the run: an unwritable path fails here, naming it.
    let mut recorder = log
        .map(|p| Recorder::mcap(p, LogOptions::default()))
        .transpose()
        .map_err(|e| sim_error(e, "log"))?;
    let inner = py
        .detach(|| {
            let mut observers: Vec<&mut dyn Observer> = Vec::new();
            if let Some(r) = recorder.as_mut() {
                observers.push(r);
            }
            sim2d::run_scenario_with(&scenario, &config, &mut observers)
        })
        .map_err(|e| sim_error(e, "scenario"))?;
    let route = match config.direction {
        Direction::Forward => scenario.route.points().to_vec(),
        Direction::Backward => scenario.route.reversed().points().to_vec(),
    };
    let outlines = scenario.obstacles.iter().map(|o| o.outline()).collect();
    Ok(SimResult { inner, route, outlines })
}

/// CDDP versus Safe-CDDP on the simulated Turtlebot (see ``ddpkit.sim.safe_turtlebot``).
#[pyclass(module = "ddpkit._ddpkit", frozen)]
pub struct TurtlebotExperiment {
    inner: Experiment,
}

fn runs_of<'a>(e: &'a Experiment, controller: &str) -> PyResult<&'a [TurtlebotRun]> {
    match controller {
        "cddp" => Ok(&e.cddp),
        "safe-cddp" | "safe_cddp" => Ok(&e.safe),
        other => Err(invalid(
            "controller",
            format!("must be \"cddp\" or \"safe-cddp\", got {other:?}"),
        )
        .into()),
    }
}

#[pymethods]
impl TurtlebotExperiment {
    /// Episodes per controller.
    #[getter]
    fn runs(&self) -> usize {
        self.inner.cddp.len()
    }
    /// Base seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.inner.seed
    }
    /// Safe-CDDP's ``beta``.
    #[getter]
    fn beta(&self) -> f64 {
        self.inner.beta
    }
    /// Episodes where Safe-CDDP kept the wider minimum clearance than CDDP under the same noise.
    #[getter]
    fn safe_wider(&self) -> usize {
        self.inner.safe_wider
    }
    /// Minimum clearance between the footprint and the closest obstacle per episode (m), shape
    /// ``(runs,)``; ``controller`` is ``"cddp"`` or ``"safe-cddp"``.
    fn min_clearance<'py>(&self, py: Python<'py>, controller: &str) -> PyResult<Bound<'py, PyAny>> {
        let r = runs_of(&self.inner, controller)?;
        Ok(vec_to_numpy(py, r.iter().map(|r| r.min_clearance).collect()))
    }
    /// Collisions (contact onsets) per episode, shape ``(runs,)``, int64.
    fn collisions<'py>(&self, py: Python<'py>, controller: &str) -> PyResult<Bound<'py, PyAny>> {
        let r = runs_of(&self.inner, controller)?;
        let c: Vec<i64> = r.iter().map(|r| r.collisions as i64).collect();
        Ok(Array1::from_vec(c).into_pyarray(py).into_any())
    }
    /// Whether each episode reached the goal region, shape ``(runs,)``, bool.
    fn reached<'py>(&self, py: Python<'py>, controller: &str) -> PyResult<Bound<'py, PyAny>> {
        let r = runs_of(&self.inner, controller)?;
        let c: Vec<bool> = r.iter().map(|r| r.reached).collect();
        Ok(Array1::from_vec(c).into_pyarray(py).into_any())
    }
    /// Duration of each episode (s), shape ``(runs,)``.
    fn times<'py>(&self, py: Python<'py>, controller: &str) -> PyResult<Bound<'py, PyAny>> {
        let r = runs_of(&self.inner, controller)?;
        Ok(vec_to_numpy(py, r.iter().map(|r| r.time_s).collect()))
    }
    /// True poses ``(x, y, theta)`` of episode ``index``, shape ``(steps + 1, 3)``.
    fn poses<'py>(
        &self,
        py: Python<'py>,
        controller: &str,
        #[pyo3(from_py_with = crate::convert::int_usize)] index: usize,
    ) -> PyResult<Bound<'py, PyAny>> {
        let r = runs_of(&self.inner, controller)?;
        let run = r.get(index).ok_or_else(|| {
            PyErr::from(invalid(
                "index",
                format!("must be below {} (the episodes), got {index}", r.len()),
            ))
        })?;
        rows_to_numpy(py, run.poses.len(), 3, run.poses.iter().flatten().copied().collect())
    }
    /// Every figure (configuration, summaries, histograms, episodes) as a JSON string;
    /// ``with_paths`` adds every trajectory.
    #[pyo3(signature = (with_paths = false))]
    fn to_json(&self, with_paths: bool) -> PyResult<String> {
        serde_json::to_string(&experiment_json(&self.inner, with_paths))
            .map_err(|e| invalid("result", e.to_string()).into())
    }
    /// Draws the figure (paths and minimum-clearance histograms) to the PNG ``path``.
    fn write_png(&self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        let e = &self.inner;
        py.detach(|| write_figure(&path, e))
            .map_err(|e| sim_error(e, "path").into())
    }
    fn __repr__(&self) -> String {
        let (c, s) = (&self.inner.cddp_summary, &self.inner.safe_summary);
        format!(
            "TurtlebotExperiment(runs={}, beta={}, cddp_mean_min_clearance={:.4}, safe_mean_min_clearance={:.4}, cddp_collided_runs={}, safe_collided_runs={})",
            c.runs, self.inner.beta, c.min_clearance.mean, s.min_clearance.mean, c.collided_runs, s.collided_runs
        )
    }
}

/// Runs the Turtlebot experiment (see ``ddpkit.sim.safe_turtlebot``); the GIL is released
/// meanwhile and the episodes run in parallel.
#[pyfunction]
#[pyo3(signature = (runs = 100, seed = None, beta = 0.8, sigma_xy = None, sigma_theta = None, sigma_w_xy = None))]
fn sim_safe_turtlebot(
    py: Python<'_>,
    #[pyo3(from_py_with = crate::convert::int_i64)] runs: i64,
    seed: Option<&Bound<'_, PyAny>>,
    beta: f64,
    sigma_xy: Option<f64>,
    sigma_theta: Option<f64>,
    sigma_w_xy: Option<f64>,
) -> PyResult<TurtlebotExperiment> {
    if runs < 1 {
        return Err(invalid("runs", format!("must be at least 1, got {runs}")).into());
    }
    let seed = seed.map(seed_arg).transpose()?.unwrap_or(1);
    let mut config = TurtlebotConfig::default();
    if let Some(s) = sigma_xy {
        config.sigma_xy = s;
    }
    if let Some(s) = sigma_theta {
        config.sigma_theta = s;
    }
    if let Some(s) = sigma_w_xy {
        config.sigma_w[0] = s;
        config.sigma_w[1] = s;
    }
    let inner = py
        .detach(|| run_experiment(&config, runs as usize, seed, beta, &|| {}))
        .map_err(|e| sim_error(e, "path"))?;
    Ok(TurtlebotExperiment { inner })
}

/// Adds the simulation functions and classes to the extension module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<SimResult>()?;
    m.add_class::<TurtlebotExperiment>()?;
    m.add_function(wrap_pyfunction!(sim_run_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(sim_safe_turtlebot, m)?)?;
    Ok(())
}
