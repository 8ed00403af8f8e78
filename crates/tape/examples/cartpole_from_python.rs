//! A model traced in Python, embedded in a Rust robot: loads the cart-pole that
//! `ddpkit.Dynamics.from_function(...).save(path)` wrote and swings it up with iLQR.
//!
//! ```text
//! cargo run --release -p ddp-tape --example cartpole_from_python [path/to/cartpole.json]
//! ```
use std::sync::Arc;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::dims::{U1, U4};
use ddp_core::{Problem, Settings, Solver, Vector};
use ddp_tape::TapeModel;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .unwrap_or_else(|| concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cartpole.json").to_string());
    let TapeModel::Dynamics(model) = TapeModel::load(&path)? else {
        return Err(format!("{path} does not hold dynamics").into());
    };
    println!(
        "loaded {path}: {} nodes, (nx, nu) = {:?}",
        model.tape().nodes().len(),
        model.dims()
    );
    let goal = Vector::<4>::new(0.0, std::f64::consts::PI, 0.0, 0.0);
    let problem = Problem::<U4, U1>::new(
        Vector::<4>::zeros(),
        Arc::new(model),
        Arc::new(QuadraticCost::diagonal(
            &[0.1, 0.0, 0.1, 0.1],
            &[0.1],
            Vector::zeros(),
            Vector::zeros(),
        )?),
        Arc::new(QuadraticTerminal::diagonal(&[100.0; 4], goal)?),
        80,
    )?;
    let mut solver = Solver::new(
        &problem,
        Settings {
            method: ddp_core::Method::Ddp,
            max_iterations: 500,
            ..Settings::default()
        },
    )?;
    let report = solver.solve(&problem)?.clone();
    println!(
        "{:?} after {} iterations, cost {:.6}, final angle {:.4} rad",
        report.status,
        report.iterations,
        report.cost,
        solver.xs()[80][1]
    );
    Ok(())
}
