//! Regression: box-DDP must not report convergence before moving when every Newton step is
//! clamped at a bound (the free-control gradient is then zero although the controls can move).

use nalgebra::{U2, U3};
use std::sync::Arc;

use ddp_core::costs::{ControlSquared, CostSum, SmoothDistance, StateOnly};
use ddp_core::models::Unicycle;
use ddp_core::{ControlBounds, Problem, Settings, Solver, Vector};

#[test]
fn box_ddp_takes_a_step_that_is_clamped_at_every_knot() {
    let goal = SmoothDistance::<3>::goal([5.0, 0.0], [0, 1], 0.05, 1.0).unwrap();
    let running = CostSum::<U3, U2>::new()
        .with(0.1, Arc::new(ControlSquared::new(1.0).unwrap()))
        .with(1.0, Arc::new(StateOnly(goal)));
    let bounds = ControlBounds::new(Vector::<2>::new(-0.5, -0.5), Vector::<2>::new(1.5, 0.5)).unwrap();
    let problem = Problem::new(
        Vector::<3>::zeros(),
        Arc::new(Unicycle::new(0.1).unwrap()),
        Arc::new(running),
        Arc::new(goal),
        30,
    )
    .unwrap()
    .with_control_bounds(bounds)
    .unwrap();
    let mut solver = Solver::new(&problem, Settings::default()).unwrap();
    let report = solver.solve(&problem).unwrap();
    assert!(report.iterations > 0, "{}", report.table());
    assert!(report.cost < report.initial_cost);
    assert!((solver.us()[0][0] - 1.5).abs() < 1e-9, "{:?}", solver.us()[0]);
}
