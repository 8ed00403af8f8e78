//! Quickstart: solve P1 (Crocoddyl's unicycle) and read the feedback policy.
use std::sync::Arc;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::models::Unicycle;
use ddp_core::{Problem, Settings, Solver, Status, Vector};

fn main() -> ddp_core::Result<()> {
    // Crocoddyl's unicycle: x = (px, py, theta), u = (v, w), 100 steps of 0.1 s.
    let problem = Problem::new(
        Vector::<3>::new(-1.0, -1.0, 1.0),
        Arc::new(Unicycle::new(0.1)?),
        Arc::new(QuadraticCost::weighted_norms(10.0, 1.0)?),
        Arc::new(QuadraticTerminal::diagonal(&[100.0; 3], Vector::zeros())?),
        100,
    )?;
    // The workspace is allocated once; solves reuse it and allocate nothing.
    let mut solver = Solver::new(&problem, Settings::default())?;
    let report = solver.solve(&problem)?;
    assert_eq!(report.status, Status::Converged);
    assert!((report.cost - 250.0393199732).abs() < 1e-6);
    // Feedback policy around the solution: u = us[k] + K[k] (x - xs[k]).
    let (_xs, _us, _gains) = (solver.xs(), solver.us(), solver.gains());
    Ok(())
}
