//! Covariance propagation (eq. 19) and tightening (eq. 20).

use ddp_core::dims::{U2, U4};
use std::sync::Arc;

use ddp_core::{reference, Dynamics, Matrix, Vector};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use safe_cddp::constraints::Circle;
use safe_cddp::kalman::ObstacleTracker;
use safe_cddp::tightening::{lqr_gain, margin, propagate_covariance};
use safe_cddp::{Constraint, Gains, SafeCddpSolver, Settings, Tightening};

fn sigma_w() -> Matrix<4, 4> {
    Matrix::<4, 4>::from_diagonal(&Vector::<4>::new(1e-4, 2e-4, 1e-3, 5e-4))
}

/// Solves P3's double integrator (no obstacles) and tightens: covariances with closed-loop gains.
fn solved_point() -> (ddp_core::Problem<U4, U2>, SafeCddpSolver<U4, U2>) {
    let problem = reference::point_reach();
    let mut solver = SafeCddpSolver::new(&problem, vec![], Settings::default()).unwrap();
    solver
        .set_tightening(Some(Tightening::new(0.95, sigma_w()).unwrap()))
        .unwrap();
    solver.solve(&problem).unwrap();
    solver.tighten(&problem).unwrap();
    (problem, solver)
}

#[test]
fn closed_loop_covariance_matches_monte_carlo() {
    let (problem, solver) = solved_point();
    let model = &problem.knots()[0].dynamics;
    let (mut fx, mut fu) = (Matrix::<4, 4>::zeros(), Matrix::<4, 2>::zeros());
    model.jacobians(&Vector::zeros(), &Vector::zeros(), &mut fx, &mut fu);
    let gains = solver.propagation_gains();
    let n = gains.len();
    let chol = sigma_w().cholesky().unwrap().l();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let samples = 4000;
    let mut second_moment = vec![Matrix::<4, 4>::zeros(); n + 1];
    for _ in 0..samples {
        // The deviation of the closed-loop system from the plan: linear dynamics, so exact.
        let mut dx = Vector::<4>::zeros();
        for k in 0..n {
            let w = Vector::<4>::from_fn(|_, _| StandardNormal.sample(&mut rng));
            dx = (fx + fu * gains[k]) * dx + chol * w;
            second_moment[k + 1] += dx * dx.transpose() / samples as f64;
        }
    }
    let sigma = solver.covariances();
    for k in [1, 10, n / 2, n] {
        let rel = (second_moment[k] - sigma[k]).amax() / sigma[k].amax();
        assert!(rel < 0.1, "k = {k}: relative error {rel}");
    }
}

#[test]
fn open_loop_covariance_grows_faster_than_closed_loop() {
    let (problem, solver) = solved_point();
    let n = solver.gains().len();
    let (mut fx, mut fu) = (vec![Matrix::<4, 4>::zeros(); n], vec![Matrix::<4, 2>::zeros(); n]);
    for k in 0..n {
        problem.knots()[k]
            .dynamics
            .jacobians(&solver.xs()[k], &solver.us()[k], &mut fx[k], &mut fu[k]);
    }
    let mut open = vec![Matrix::<4, 4>::zeros(); n + 1];
    let mut closed = vec![Matrix::<4, 4>::zeros(); n + 1];
    propagate_covariance(&fx, &fu, &Gains::OpenLoop, &[], &Matrix::zeros(), &sigma_w(), &mut open);
    propagate_covariance(
        &fx,
        &fu,
        &Gains::ClosedLoop,
        solver.propagation_gains(),
        &Matrix::zeros(),
        &sigma_w(),
        &mut closed,
    );
    // Position variance: the feedback of the plan keeps it smaller, increasingly so.
    for k in [20, 50, n] {
        assert!(open[k][(0, 0)] > closed[k][(0, 0)], "k = {k}");
    }
    assert!(open[n][(0, 0)] / closed[n][(0, 0)] > open[20][(0, 0)] / closed[20][(0, 0)]);
    // A fixed LQR gain at the goal also stabilises the double integrator.
    let q = Matrix::<4, 4>::from_diagonal(&Vector::<4>::new(100.0, 100.0, 10.0, 10.0));
    let r = Matrix::<2, 2>::identity() * 0.1;
    let k_lqr = lqr_gain(&fx[0], &fu[0], &q, &r, 10_000, 1e-12).unwrap();
    let mut fixed = vec![Matrix::<4, 4>::zeros(); n + 1];
    propagate_covariance(
        &fx,
        &fu,
        &Gains::Fixed(k_lqr),
        &[],
        &Matrix::zeros(),
        &sigma_w(),
        &mut fixed,
    );
    assert!(fixed[n][(0, 0)] < open[n][(0, 0)]);
}

#[test]
fn margins_follow_eq_20_and_grow_with_the_horizon() {
    // One obstacle beside the path; margins of its rows = z sqrt(g_x^T Sigma_t g_x).
    let problem = reference::point_reach();
    let obstacle: Arc<dyn Constraint<U4, U2>> = Arc::new(Circle::distance([1.0, 2.0], 0.3, [0, 1]).unwrap());
    let mut solver = SafeCddpSolver::new(&problem, vec![obstacle.clone()], Settings::default()).unwrap();
    let t = Tightening::new(0.99, sigma_w())
        .unwrap()
        .with_gains(Gains::OpenLoop)
        .unwrap();
    solver.set_tightening(Some(t)).unwrap();
    solver.solve(&problem).unwrap();
    solver.tighten(&problem).unwrap();
    let z = 2.3263478740408408;
    let mut last = 0.0;
    for k in 0..solver.horizon() - 1 {
        let time = solver.row_time(k, 0).unwrap();
        let x = solver.xs()[time];
        let (mut g, mut gx, mut gu) = ([0.0], [Vector::<4>::zeros()], [Vector::<2>::zeros()]);
        obstacle.jacobians(time, &x, &Vector::zeros(), &mut g, &mut gx, &mut gu);
        let expected = margin(z, &gx[0], &solver.covariances()[time], 0.0);
        let got = solver.margins(k)[0];
        assert!((got - expected).abs() < 1e-12, "knot {k}: {got} vs {expected}");
        // Open loop: the distance margin grows monotonically along the horizon.
        assert!(got >= last - 1e-15);
        last = got;
    }
    assert!(last > 0.0);
}

#[test]
fn moving_obstacle_margin_grows_along_the_horizon() {
    // A tracked obstacle: its predicted position covariance adds to the robot's, so even with a
    // perfectly known robot (Sigma_w = 0) the margin grows with t.
    let problem = reference::point_reach();
    let kf = ObstacleTracker::new(0.05, 1.0, 0.05, [1.5, 0.5], [0.0, 0.5], 0.05, 0.2).unwrap();
    let moving: Arc<dyn Constraint<U4, U2>> =
        Arc::new(kf.moving_circle::<U4>(100, 0.3, [0, 1], Default::default()).unwrap());
    let mut solver = SafeCddpSolver::new(
        &problem,
        vec![moving],
        Settings {
            max_iterations: 5,
            ..Settings::default()
        },
    )
    .unwrap();
    solver
        .set_tightening(Some(Tightening::new(0.95, Matrix::zeros()).unwrap()))
        .unwrap();
    solver.solve(&problem).unwrap();
    solver.tighten(&problem).unwrap();
    let margins: Vec<f64> = (0..solver.horizon() - 1).map(|k| solver.margins(k)[0]).collect();
    assert!(margins[0] > 0.0);
    // Along a segment where the robot barely moves relative to the obstacle the growth is clear;
    // check the overall trend over the horizon and strict growth of the obstacle covariance.
    assert!(margins[margins.len() - 1] > margins[0]);
    let mut c = Vec::new();
    let mut s = Vec::new();
    kf.predict_positions(100, &mut c, &mut s);
    assert!(s.windows(2).all(|w| w[1][(0, 0)] > w[0][(0, 0)]));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]
    #[test]
    fn tightening_grows_with_beta(b1 in 0.5f64..0.999, db in 0.0001f64..0.0009, scale in 1e-4f64..1.0,
                                  gx0 in -2.0f64..2.0, gx1 in -2.0f64..2.0) {
        let b2 = (b1 + db).min(0.9999);
        let sigma = Matrix::<4, 4>::identity() * scale;
        let g = Vector::<4>::new(gx0, gx1, 0.0, 0.0);
        let t1 = Tightening::<U4, U2>::new(b1, sigma).unwrap();
        let t2 = Tightening::<U4, U2>::new(b2, sigma).unwrap();
        let m1 = margin(t1.quantile(), &g, &sigma, 0.0);
        let m2 = margin(t2.quantile(), &g, &sigma, 0.0);
        prop_assert!(m2 >= m1);
        if g.norm() > 1e-6 {
            prop_assert!(m2 > m1);
        }
    }
}

/// The car of the iteration benchmark: N = 90, goal (3, 0) at rest, two discs (squared form).
fn car_n90() -> (ddp_core::Problem<U4, U2>, safe_cddp::Constraints<U4, U2>) {
    use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
    use ddp_core::models::Car;
    use ddp_core::{ControlBounds, Problem};
    let running = Arc::new(QuadraticCost::diagonal(&[0.0; 4], &[0.1, 0.1], Vector::zeros(), Vector::zeros()).unwrap());
    let terminal = Arc::new(
        QuadraticTerminal::diagonal(&[100.0, 100.0, 10.0, 10.0], Vector::<4>::new(3.0, 0.0, 0.0, 0.0)).unwrap(),
    );
    let problem = Problem::new(
        Vector::zeros(),
        Arc::new(Car::new(0.05).unwrap()),
        running,
        terminal,
        90,
    )
    .unwrap()
    .with_control_bounds(ControlBounds::new(Vector::<2>::new(-0.4, -0.5), Vector::<2>::new(0.4, 0.5)).unwrap())
    .unwrap();
    let obstacles: Vec<Arc<dyn Constraint<U4, U2>>> = vec![
        Arc::new(Circle::squared([1.0, 0.1], 0.35, [0, 1]).unwrap()),
        Arc::new(Circle::squared([2.0, -0.1], 0.35, [0, 1]).unwrap()),
    ];
    (problem, obstacles)
}

#[test]
fn tightened_car_converges_feasibly() {
    // Regression: with beta = 0.99 the car's solve used to oscillate to max_iterations and end
    // infeasible. Causes: each tightening re-entered the warm-up at the initial penalty (the
    // trajectory drifted into the discs), a failed KKT/QP step ended the solve, and the gains of
    // active relative-degree-2 rows (dead-beat, O(1/dt^2)) made each row's margin depend on
    // whether the row itself was active.
    // As the paper does (§III-D): solve the deterministic problem, then tighten and solve again
    // from there (the solver keeps its multipliers and penalty: a warm start).
    // The augmented-Lagrangian phases converge linearly: give the solve a budget of 600.
    let (problem, obstacles) = car_n90();
    let settings = Settings {
        max_iterations: 600,
        ..Settings::default()
    };
    for sigma in [1e-7, 1e-6, 1e-5] {
        let mut tightened = SafeCddpSolver::new(&problem, obstacles.clone(), settings).unwrap();
        let deterministic = tightened.solve(&problem).unwrap().clone();
        assert_eq!(deterministic.status, safe_cddp::Status::Converged);
        let sigma_w = Matrix::<4, 4>::identity() * sigma;
        tightened
            .set_tightening(Some(Tightening::new(0.99, sigma_w).unwrap()))
            .unwrap();
        let r = tightened.solve(&problem).unwrap().clone();
        assert_eq!(
            r.status,
            safe_cddp::Status::Converged,
            "sigma_w = {sigma} I:\n{}",
            r.table()
        );
        assert!(
            r.max_violation_tightened <= 1e-8,
            "sigma_w = {sigma} I: {}",
            r.max_violation_tightened
        );
        assert_eq!(r.max_violation, 0.0, "the original constraints hold with room to spare");
        // The margins are positive along the horizon, and a safer plan costs more.
        assert!((0..tightened.horizon() - 2).all(|k| tightened.margins(k)[0] > 0.0));
        assert!(r.cost > deterministic.cost, "sigma_w = {sigma} I");
        eprintln!(
            "sigma_w = {sigma} I: converged in {} iterations, cost {:.6} (deterministic {:.6})",
            r.iterations, r.cost, deterministic.cost
        );
        // Safe-CDDP's gains are those of the bounds-only backward pass: finite and modest.
        let worst = tightened
            .propagation_gains()
            .iter()
            .map(|k| k.norm())
            .fold(0.0, f64::max);
        assert!(worst.is_finite() && worst < 1e3, "|K| up to {worst}");
    }
}
