//! `ddpkit._ddpkit`: the Python bindings of ddp-core.
//!
//! A thin layer: numpy arrays in, numpy arrays out; every error a `ddpkit.DdpError`; the GIL
//! released during solves. Python sees run-time dimensions; each call dispatches to ddp-core's
//! generic types at `Const` dimensions for a compiled `(nx, nu)` pair (the built-in robots' fast
//! path) or at `Dyn` dimensions for any other size, one generic text serving both ([`dims`]).
//!
//! | module | Python |
//! |---|---|
//! | [`errors`] | `DdpError`, `ShapeError`, `NotFiniteError`, `InvalidInputError` |
//! | [`models`] | `Dynamics` and the built-in models, `LinearDynamics` |
//! | [`costs`] | `Cost` and the cost terms |
//! | [`problem`] | `Problem` |
//! | [`solver`] | `Solver`, `Solution`, `default_settings` |
//! | [`safe`] | `Constraint` and the constraints, `Tightening`, `SafeCddpSolver`, `SafeSolution`, `Mpc`, `Episode` (Safe-CDDP) |
//! | [`tape`] | `TapeDynamics`, `TapeCost`, `TapeConstraint`, `load_model`, `model_from_json`: models traced from Python or imported from CasADi |
//! | [`callable`] | `CallableDynamics`, `CallableCost`: plain Python callables (the slow path) |
//! | [`idnp`] | `IdnpRun`, `IdnpExperiment`, `idnp_run`, `idnp_experiment`, `idnp_scene`, `idnp_configuration` (public as `ddpkit.idnp`) |
//! | [`subgoal`] | `subgoal_generate_dataset`, `subgoal_sample`: the DDPEN sub-goal dataset (public as `ddpkit.subgoal`) |
//! | [`subgoal_model`] | `SubgoalModel`: the DDPEN sub-goal network in Rust (public as `ddpkit.subgoal.SubgoalModel`) |
//! | [`sim`] | `SimResult`, `TurtlebotExperiment`, `sim_run_scenario`, `sim_safe_turtlebot` (public as `ddpkit.sim`) |
//! | [`experiments`] | `experiment_names`, `experiment_tasks`, `experiment_run_task`, `experiment_aggregate`: the experiments as tasks (public as `ddpkit.experiments`) |
//! | [`bezier`] | `Bezier`, `Spline`, `SigmoidProfile`, `Trajectory`, costs, `optimize_spline` (public as `ddpkit.bezier`) |

#[macro_use]
pub mod dims;
pub mod batch;
pub mod bezier;
pub mod callable;
pub mod convert;
pub mod costs;
pub mod errors;
pub mod experiments;
pub mod idnp;
pub mod models;
pub mod pickle;
pub mod problem;
pub mod safe;
pub mod sim;
pub mod solver;
pub mod subgoal;
pub mod subgoal_model;
pub mod tape;

use pyo3::prelude::*;

/// The compiled `(nx, nu)` pairs, as a list of tuples: the fixed-size fast path of the built-in
/// robots and of a cart-pole or acrobot `(4, 1)` and a planar quadrotor `(6, 2)`. Every other
/// size works too, at run-time sizes.
#[pyfunction]
fn supported_dimensions() -> Vec<(usize, usize)> {
    dims::PAIRS.to_vec()
}

/// The extension module.
#[pymodule]
fn _ddpkit(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_function(wrap_pyfunction!(pickle::unpickle_result, m)?)?;
    m.add_class::<models::Dynamics>()?;
    m.add_class::<models::Unicycle>()?;
    m.add_class::<models::Car>()?;
    m.add_class::<models::DoubleIntegrator2D>()?;
    m.add_class::<models::DifferentialDrive>()?;
    m.add_class::<models::Quadrotor>()?;
    m.add_class::<models::ArmBase>()?;
    m.add_class::<models::LinearDynamics>()?;
    m.add_class::<costs::Cost>()?;
    m.add_class::<costs::QuadraticCost>()?;
    m.add_class::<costs::QuadraticTerminal>()?;
    m.add_class::<costs::ControlSquared>()?;
    m.add_class::<costs::SmoothDistance>()?;
    m.add_class::<costs::ObstacleHinge>()?;
    m.add_class::<costs::CirclePenalty>()?;
    m.add_class::<costs::CostSum>()?;
    m.add_class::<costs::TerminalSum>()?;
    m.add_class::<problem::Problem>()?;
    m.add_class::<solver::Solver>()?;
    m.add_class::<solver::Solution>()?;
    m.add_function(wrap_pyfunction!(solver::default_settings, m)?)?;
    m.add_function(wrap_pyfunction!(solver::solve_batch, m)?)?;
    m.add_function(wrap_pyfunction!(supported_dimensions, m)?)?;
    tape::register(m)?;
    callable::register(m)?;
    bezier::register(m)?;
    safe::register(m)?;
    sim::register(m)?;
    idnp::register(m)?;
    subgoal::register(m)?;
    subgoal_model::register(m)?;
    experiments::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
