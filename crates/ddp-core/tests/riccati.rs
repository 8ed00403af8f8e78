//! On a linear-quadratic problem, DDP must reproduce the discrete Riccati solution in one
//! iteration: the same gains and the same optimal trajectory.

use nalgebra::Const;
use std::sync::Arc;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::linear::LinearDynamics;
use ddp_core::{
    ControlBounds, Matrix, Method, Problem, Regularization, RegularizationSettings, Settings, Shooting, Solver, Status,
    Vector,
};

const NX: usize = 4;
const NU: usize = 2;

struct Lq {
    a: Matrix<NX, NX>,
    b: Matrix<NX, NU>,
    q: Matrix<NX, NX>,
    r: Matrix<NU, NU>,
    qf: Matrix<NX, NX>,
    x0: Vector<NX>,
    n: usize,
}

fn lq() -> Lq {
    let dt = 0.1;
    // A lightly unstable, coupled system so the gains are non-trivial.
    let a = Matrix::<NX, NX>::new(
        1.0, 0.02, dt, 0.0, //
        0.0, 1.01, 0.0, dt, //
        0.05, 0.0, 1.0, 0.01, //
        0.0, 0.03, 0.0, 1.0,
    );
    let b = Matrix::<NX, NU>::new(0.5 * dt * dt, 0.0, 0.0, 0.5 * dt * dt, dt, 0.01, 0.02, dt);
    let m = Matrix::<NX, NX>::from_fn(|i, j| ((i * 7 + j * 3) % 5) as f64 * 0.1);
    let q = m * m.transpose() + Matrix::identity();
    let r = Matrix::<NU, NU>::new(0.3, 0.05, 0.05, 0.2);
    let qf = 10.0 * q;
    Lq {
        a,
        b,
        q,
        r,
        qf,
        x0: Vector::<NX>::new(1.0, -2.0, 0.5, 0.3),
        n: 60,
    }
}

/// Textbook finite-horizon discrete Riccati recursion: returns gains `K_k` (u = K x) and `P_0`.
fn riccati(p: &Lq) -> (Vec<Matrix<NU, NX>>, Matrix<NX, NX>) {
    let mut big_p = p.qf;
    let mut gains = vec![Matrix::<NU, NX>::zeros(); p.n];
    for k in (0..p.n).rev() {
        let s = p.r + p.b.transpose() * big_p * p.b;
        let gain = -s.try_inverse().unwrap() * p.b.transpose() * big_p * p.a;
        big_p = p.q + p.a.transpose() * big_p * (p.a + p.b * gain);
        big_p = 0.5 * (big_p + big_p.transpose());
        gains[k] = gain;
    }
    (gains, big_p)
}

fn problem(p: &Lq) -> Problem<Const<NX>, Const<NU>> {
    Problem::new(
        p.x0,
        Arc::new(LinearDynamics::new(p.a, p.b, Vector::zeros()).unwrap()),
        Arc::new(QuadraticCost::new(p.q, p.r, Vector::zeros(), Vector::zeros()).unwrap()),
        Arc::new(QuadraticTerminal::new(p.qf, Vector::zeros()).unwrap()),
        p.n,
    )
    .unwrap()
}

fn check_against_riccati(settings: Settings) {
    let p = lq();
    let (gains, p0) = riccati(&p);
    let prob = problem(&p);
    let mut solver = Solver::new(&prob, settings).unwrap();
    let report = solver.solve(&prob).unwrap().clone();
    assert_eq!(report.status, Status::Converged, "{}", report.table());
    assert_eq!(
        report.iterations,
        1,
        "an LQ problem takes one Newton step\n{}",
        report.table()
    );
    // Closed-loop Riccati trajectory and optimal cost 1/2 x0^T P0 x0.
    let mut x = p.x0;
    for k in 0..p.n {
        assert!((solver.gains()[k] - gains[k]).amax() < 1e-9, "K[{k}] differs");
        let u = gains[k] * x;
        assert!((solver.us()[k] - u).amax() < 1e-9, "u[{k}] differs");
        assert!((solver.xs()[k] - x).amax() < 1e-9, "x[{k}] differs");
        x = p.a * x + p.b * u;
    }
    let j_star = 0.5 * p.x0.dot(&(p0 * p.x0));
    assert!(
        (report.cost - j_star).abs() < 1e-9 * j_star,
        "{} vs {}",
        report.cost,
        j_star
    );
    assert!(report.defect <= 1e-12, "defect {}", report.defect);
}

#[test]
fn ilqr_equals_riccati() {
    check_against_riccati(Settings::default());
}

#[test]
fn full_ddp_equals_riccati() {
    check_against_riccati(Settings {
        method: Method::Ddp,
        ..Settings::default()
    });
}

#[test]
fn multiple_shooting_equals_riccati() {
    // The lifted problem of an LQ problem is a QP: one SQP step from the zero-defect rollout
    // lands on the Riccati solution, with no defect left.
    for method in [Method::Ilqr, Method::Ddp] {
        check_against_riccati(Settings {
            method,
            shooting: Shooting::Multiple,
            ..Settings::default()
        });
    }
}

#[test]
fn multiple_shooting_from_a_state_guess_takes_one_step_to_riccati() {
    // From any states and controls, one SQP step on an LQ problem is exact: the defects of a
    // guess far from every rollout close in the same step that reaches the optimum.
    let p = lq();
    let (gains, p0) = riccati(&p);
    let prob = problem(&p);
    let settings = Settings {
        method: Method::Ddp,
        shooting: Shooting::Multiple,
        ..Settings::default()
    };
    let mut solver = Solver::new(&prob, settings).unwrap();
    let xs: Vec<Vector<NX>> = (0..=p.n)
        .map(|k| Vector::<NX>::from_fn(|i, _| ((k * 3 + i * 5) % 7) as f64 - 3.0))
        .collect();
    let us: Vec<Vector<NU>> = (0..p.n).map(|k| Vector::<NU>::new((k % 3) as f64, -1.0)).collect();
    solver.set_controls(&us).unwrap();
    solver.set_states(&xs).unwrap();
    let report = solver.solve(&prob).unwrap().clone();
    assert_eq!(report.status, Status::Converged, "{}", report.table());
    assert_eq!(report.iterations, 1, "{}", report.table());
    assert!(report.defect <= 1e-12, "defect {}", report.defect);
    let mut x = p.x0;
    for k in 0..p.n {
        let u = gains[k] * x;
        assert!((solver.us()[k] - u).amax() < 1e-9, "u[{k}] differs");
        assert!((solver.xs()[k] - x).amax() < 1e-9, "x[{k}] differs");
        x = p.a * x + p.b * u;
    }
    let j_star = 0.5 * p.x0.dot(&(p0 * p.x0));
    assert!((report.cost - j_star).abs() < 1e-9 * j_star);
    // The guess is used once: the next solve starts from the rollout of the controls.
    let again = solver.solve(&prob).unwrap();
    assert_eq!(again.iterations, 0, "{}", again.table());
}

#[test]
fn state_regularization_equals_riccati_at_zero_mu() {
    check_against_riccati(Settings {
        regularization: RegularizationSettings {
            placement: Regularization::State,
            ..Default::default()
        },
        ..Settings::default()
    });
}

#[test]
fn inactive_bounds_change_nothing() {
    let p = lq();
    let (gains, _) = riccati(&p);
    let prob = problem(&p)
        .with_control_bounds(ControlBounds::new(Vector::repeat(-1e3), Vector::repeat(1e3)).unwrap())
        .unwrap();
    let mut solver = Solver::new(&prob, Settings::default()).unwrap();
    let report = solver.solve(&prob).unwrap();
    assert_eq!(report.status, Status::Converged);
    for k in 0..p.n {
        assert!((solver.gains()[k] - gains[k]).amax() < 1e-9, "K[{k}] differs");
    }
}

#[test]
fn active_bounds_are_respected_and_optimal() {
    // With tight bounds the box-DDP solution must satisfy the bounds and the first-order
    // conditions of the bound-constrained problem: each control is at a bound with the gradient
    // pushing outwards, or interior with zero gradient.
    let p = lq();
    let lim = 2.0;
    let prob = problem(&p)
        .with_control_bounds(ControlBounds::new(Vector::repeat(-lim), Vector::repeat(lim)).unwrap())
        .unwrap();
    let mut solver = Solver::new(&prob, Settings::default()).unwrap();
    let report = solver.solve(&prob).unwrap().clone();
    assert_eq!(report.status, Status::Converged, "{}", report.table());
    let us = solver.us();
    assert!(
        us.iter().any(|u| u.amax() > lim - 1e-12),
        "bounds should be active for this x0"
    );
    assert!(us.iter().all(|u| u.amax() <= lim + 1e-12));
    // Adjoint gradient dJ/du_k by a backward sweep.
    let xs = solver.xs();
    let mut lam = p.qf * xs[p.n];
    for k in (0..p.n).rev() {
        let g = p.r * us[k] + p.b.transpose() * lam;
        for i in 0..NU {
            if us[k][i] >= lim - 1e-9 {
                assert!(g[i] <= 1e-6, "u[{k}][{i}] at upper bound with gradient {}", g[i]);
            } else if us[k][i] <= -lim + 1e-9 {
                assert!(g[i] >= -1e-6, "u[{k}][{i}] at lower bound with gradient {}", g[i]);
            } else {
                assert!(g[i].abs() < 1e-5, "interior u[{k}][{i}] with gradient {}", g[i]);
            }
        }
        lam = p.q * xs[k] + p.a.transpose() * lam;
    }
}
