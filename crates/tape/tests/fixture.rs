//! The cart-pole traced in Python (`py/tests/test_own_robot.py` checks that the committed file
//! is today's trace) loads in Rust, equals the same model written by hand, and swings up.

use std::sync::Arc;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::dims::{U1, U4};
use ddp_core::{Dynamics, Problem, Settings, Shooting, Solver, Status, Vector};
use ddp_tape::TapeModel;

const FIXTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/cartpole.json");

/// Cart-pole xdot (Tedrake, Underactuated Robotics, ch. 3), as in the Python test.
fn ode(x: &Vector<4>, u: f64) -> Vector<4> {
    let (mc, mp, l, g) = (1.0, 0.1, 0.5, 9.81);
    let (s, c) = (x[1].sin(), x[1].cos());
    let d = mc + mp * s * s;
    let pdd = (u + mp * s * (l * x[3] * x[3] + g * c)) / d;
    let tdd = (-u * c - mp * l * x[3] * x[3] * c * s - (mc + mp) * g * s) / (l * d);
    Vector::<4>::new(x[2], x[3], pdd, tdd)
}

fn rk4(x: &Vector<4>, u: f64, dt: f64) -> Vector<4> {
    let k1 = ode(x, u);
    let k2 = ode(&(x + 0.5 * dt * k1), u);
    let k3 = ode(&(x + 0.5 * dt * k2), u);
    let k4 = ode(&(x + dt * k3), u);
    x + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
}

#[test]
fn the_cartpole_traced_in_python_equals_the_hand_written_one_and_swings_up() {
    let TapeModel::Dynamics(model) = TapeModel::load(FIXTURE).unwrap() else {
        panic!("the fixture holds dynamics")
    };
    assert_eq!(model.dims(), (4, 1));
    for (x, u) in [
        (Vector::<4>::new(0.1, 0.5, -0.3, 0.8), 1.5),
        (Vector::<4>::new(-0.4, 2.9, 0.2, -1.1), -3.0),
    ] {
        let a = Dynamics::<U4, U1>::step(&model, &x, &Vector::<1>::new(u));
        let b = rk4(&x, u, 0.05);
        assert!((a - b).amax() < 1e-13 * (1.0 + b.amax()), "{a} vs {b}");
    }
    let goal = Vector::<4>::new(0.0, std::f64::consts::PI, 0.0, 0.0);
    let problem = Problem::<U4, U1>::new(
        Vector::<4>::zeros(),
        Arc::new(model),
        Arc::new(QuadraticCost::diagonal(&[0.1, 0.0, 0.1, 0.1], &[0.1], Vector::zeros(), Vector::zeros()).unwrap()),
        Arc::new(QuadraticTerminal::diagonal(&[100.0; 4], goal).unwrap()),
        80,
    )
    .unwrap();
    // Single and multiple shooting reach the same swing-up; multiple shooting in fewer
    // iterations (24 against 61 today), with its defects closed and its states a rollout.
    let mut solved = Vec::new();
    for shooting in [Shooting::Single, Shooting::Multiple] {
        let mut solver = Solver::new(
            &problem,
            Settings {
                method: ddp_core::Method::Ddp,
                shooting,
                max_iterations: 500,
                ..Settings::default()
            },
        )
        .unwrap();
        let report = solver.solve(&problem).unwrap().clone();
        assert_eq!(report.status, Status::Converged, "{shooting:?}\n{}", report.table());
        assert!((solver.xs()[80][1] - std::f64::consts::PI).abs() < 0.1);
        assert!(report.defect <= ddp_core::DEFECT_TOLERANCE);
        // Each step is the model's up to the defect; the rollout of the controls stays within
        // what 80 defects of at most 1e-9 through the swing-up's unstable dynamics add up to.
        let mut x = solver.xs()[0];
        for (k, u) in solver.us().iter().enumerate() {
            let xs = solver.xs();
            assert!(
                (rk4(&xs[k], u[0], 0.05) - xs[k + 1]).amax() <= 1e-9,
                "{shooting:?}: defect at {k}"
            );
            assert!((x - xs[k]).amax() < 1e-6, "{shooting:?}: x[{k}] is not the rollout");
            x = rk4(&x, u[0], 0.05);
        }
        solved.push((report.cost, report.iterations));
    }
    let ((single, its_single), (multiple, its_multiple)) = (solved[0], solved[1]);
    assert!((single - multiple).abs() <= 1e-8 * single, "{single} vs {multiple}");
    assert!(
        its_multiple <= 30 && 2 * its_multiple < its_single,
        "multiple shooting took {its_multiple} iterations, single {its_single}"
    );
}
