//! The MPC loop of Algorithm 1: determinism for a seed, and a crossing-obstacle scenario.

use std::sync::Arc;

use ddp_core::{reference, Matrix, Vector};
use safe_cddp::constraints::Circle;
use safe_cddp::mpc::{MovingObstacle, Mpc, MpcSettings};
use safe_cddp::{Constraint, Settings, Tightening};

fn point_mpc(beta: Option<f64>, moving: Vec<MovingObstacle>) -> Mpc<4, 2> {
    let problem = reference::point_reach();
    let obstacles: Vec<Arc<dyn Constraint<4, 2>>> = vec![
        Arc::new(Circle::squared([1.0, 1.1], 0.4, [0, 1]).unwrap()),
        Arc::new(Circle::squared([2.0, 1.9], 0.4, [0, 1]).unwrap()),
    ];
    let sigma_w = Matrix::<4, 4>::from_diagonal(&Vector::<4>::new(2e-5, 2e-5, 1e-4, 1e-4));
    let tightening = beta.map(|b| Tightening::new(b, sigma_w).unwrap());
    let settings = MpcSettings {
        goal: Vector::<4>::new(3.0, 3.0, 0.0, 0.0),
        goal_radius: 0.15,
        iterations: 5,
        ..MpcSettings::default()
    };
    Mpc::new(
        &problem,
        obstacles,
        moving,
        Settings::default(),
        tightening,
        sigma_w,
        settings,
    )
    .unwrap()
}

#[test]
fn episodes_are_deterministic_for_a_seed() {
    let mut mpc = point_mpc(Some(0.9), vec![]);
    let a = mpc.run_episode(11).unwrap();
    let b = mpc.run_episode(11).unwrap();
    let c = mpc.run_episode(12).unwrap();
    assert_eq!(a, b);
    assert_ne!(a.xs, c.xs);
    assert!(a.steps > 0 && a.xs.len() == a.steps + 1);
}

#[test]
fn crossing_obstacle_gets_a_growing_margin_and_is_avoided() {
    // Only an obstacle crossing the straight path from right to left.
    let crossing = MovingObstacle {
        position: [2.2, 0.6],
        velocity: [-0.3, 0.3],
        radius: 0.25,
        measurement_std: 0.01,
        filter_accel_std: 0.2,
        initial_velocity_std: 0.1,
    };
    let problem = reference::point_reach();
    let sigma_w = Matrix::<4, 4>::from_diagonal(&Vector::<4>::new(1e-6, 1e-6, 1e-5, 1e-5));
    let settings = MpcSettings {
        goal: Vector::<4>::new(3.0, 3.0, 0.0, 0.0),
        goal_radius: 0.15,
        iterations: 5,
        ..MpcSettings::default()
    };
    let tightening = Tightening::new(0.99, sigma_w).unwrap();
    let mut mpc = Mpc::new(
        &problem,
        vec![],
        vec![crossing],
        Settings::default(),
        Some(tightening),
        sigma_w,
        settings,
    )
    .unwrap();
    let e = mpc.run_episode(5).unwrap();
    assert_eq!(e.collisions, 0, "collisions in {} steps", e.steps);
    // The first plan's margins of the moving obstacle grow along the horizon (its predicted
    // covariance grows), from a positive start.
    assert!(!e.initial_covariances.is_empty());
}
