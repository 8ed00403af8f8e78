//! The planar quadrotor past a circular obstacle of `bench/peers/traced.py`, rebuilt from its four
//! models CasADi-imported in Python and saved in `tests/data/quadrotor_obstacle/` (shared by the
//! `obstacle_from_python` example and test).
use std::sync::Arc;

use ddp_core::dims::Dyn;
use ddp_core::{ControlBounds, Problem};
use ddp_tape::{TapeConstraint, TapeModel};
use nalgebra::DVector;

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/quadrotor_obstacle");
/// Hover thrust per rotor of `traced.py`'s quadrotor, `m g / 2` (mass 0.5, g = 9.81).
pub const HOVER: f64 = 0.5 * 0.5 * 9.81;
pub const HORIZON: usize = 60;

/// The problem, its obstacle and the initial controls.
pub type Parts = (Problem<Dyn, Dyn>, TapeConstraint, Vec<DVector<f64>>);

/// The problem (from rest at the origin, thrusts in `[0, 4 HOVER]`), its obstacle, and the hover
/// guess `traced.py` starts every solver from.
pub fn quadrotor_obstacle() -> Result<Parts, Box<dyn std::error::Error>> {
    let load = |name: &str| TapeModel::load(format!("{DIR}/{name}.json"));
    let (
        TapeModel::Dynamics(dynamics),
        TapeModel::Cost(running),
        TapeModel::Terminal(terminal),
        TapeModel::Constraint(obstacle),
    ) = (
        load("dynamics")?,
        load("running")?,
        load("terminal")?,
        load("obstacle")?,
    )
    else {
        return Err("the saved models are not dynamics, cost, terminal cost and constraint".into());
    };
    let bounds = ControlBounds::<Dyn>::new(DVector::zeros(2), DVector::from_element(2, 4.0 * HOVER))?;
    let problem = Problem::<Dyn, Dyn>::new(
        DVector::zeros(6),
        Arc::new(dynamics),
        Arc::new(running),
        Arc::new(terminal),
        HORIZON,
    )?
    .with_control_bounds(bounds)?;
    Ok((problem, obstacle, vec![DVector::from_element(2, HOVER); HORIZON]))
}
