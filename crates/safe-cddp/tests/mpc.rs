//! The MPC loop of Algorithm 1: determinism for a seed, and a crossing-obstacle scenario.

use ddp_core::dims::{U2, U4};
use std::sync::Arc;

use ddp_core::{reference, Matrix, Vector};
use safe_cddp::constraints::Circle;
use safe_cddp::mpc::{MovingObstacle, Mpc, MpcSettings};
use safe_cddp::{Constraint, Settings, Tightening};

fn point_mpc(beta: Option<f64>, moving: Vec<MovingObstacle>) -> Mpc<U4, U2> {
    let problem = reference::point_reach();
    let obstacles: Vec<Arc<dyn Constraint<U4, U2>>> = vec![
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
    assert!(e.success, "the crossing obstacle blocked the goal");
    // (The margins' growth along the horizon is checked against the closed form below.)
}

#[test]
fn moving_obstacle_margin_is_the_quantile_times_its_predicted_position_std() {
    // With no process noise on the robot, eq. (20)'s margin of a moving circle (distance form,
    // unit gradient) is `z(beta) sqrt(n^T P_t n)` with `P_t` the Kalman filter's predicted
    // position covariance `t` steps ahead: it must grow along the horizon. The double
    // integrator's position has relative degree 1, so the rows of knot `k` constrain `x_{k+1}`.
    use safe_cddp::constraints::CircleForm;
    use safe_cddp::kalman::ObstacleTracker;
    use safe_cddp::quantile::normal_quantile;
    use safe_cddp::SafeCddpSolver;

    let problem = reference::point_reach();
    let n = problem.horizon();
    let kf = ObstacleTracker::new(0.05, 0.2, 0.01, [1.5, 0.2], [0.0, 0.5], 0.01, 0.1).unwrap();
    let circle = kf.moving_circle::<U4>(n, 0.25, [0, 1], CircleForm::Distance).unwrap();
    let constraint: Arc<dyn Constraint<U4, U2>> = Arc::new(circle);
    let mut solver = SafeCddpSolver::new(&problem, vec![constraint], Settings::default()).unwrap();
    solver.solve(&problem).unwrap();
    let beta = 0.95;
    solver
        .set_tightening(Some(Tightening::new(beta, Matrix::<4, 4>::zeros()).unwrap()))
        .unwrap();
    solver.tighten(&problem).unwrap();

    let z = normal_quantile(beta).unwrap();
    let (mut centers, mut covs) = (Vec::new(), Vec::new());
    kf.predict_positions(n, &mut centers, &mut covs);
    let xs = solver.xs();
    let mut previous = 0.0;
    for k in 0..n {
        let t = k + 1;
        let (dx, dy) = (xs[t][0] - centers[t][0], xs[t][1] - centers[t][1]);
        let d = dx.hypot(dy);
        let unit = nalgebra::Vector2::new(dx / d, dy / d);
        let expected = z * unit.dot(&(covs[t] * unit)).sqrt();
        let got = solver.margins(k)[0];
        assert!(
            (got - expected).abs() <= 1e-9 * (1.0 + expected),
            "t = {t}: margin {got}, closed form {expected}"
        );
        assert!(got > previous, "t = {t}: margin {got} did not grow from {previous}");
        previous = got;
    }
}
