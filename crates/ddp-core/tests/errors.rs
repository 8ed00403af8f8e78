//! Bad input is an `Error` naming the field (and index) and the reason; never a panic.

use nalgebra::{U1, U2};
use std::sync::Arc;

use ddp_core::costs::{ControlSquared, ObstacleHinge, QuadraticCost, QuadraticTerminal, SmoothDistance};
use ddp_core::linear::LinearDynamics;
use ddp_core::{
    ControlBounds, Error, LineSearchSettings, Matrix, Problem, RegularizationSettings, Settings, Shooting, Solver,
    Tolerances, Vector,
};

fn lq(horizon: usize, x0: Vector<2>) -> ddp_core::Result<Problem<U2, U1>> {
    Problem::new(
        x0,
        Arc::new(LinearDynamics::new(
            Matrix::<2, 2>::new(1.0, 0.1, 0.0, 1.0),
            Matrix::<2, 1>::new(0.0, 0.1),
            Vector::zeros(),
        )?),
        Arc::new(QuadraticCost::diagonal(
            &[1.0, 1.0],
            &[0.1],
            Vector::zeros(),
            Vector::zeros(),
        )?),
        Arc::new(QuadraticTerminal::diagonal(&[10.0, 10.0], Vector::zeros())?),
        horizon,
    )
}

fn message(e: Error) -> String {
    e.to_string()
}

#[test]
fn empty_horizon_is_rejected() {
    assert_eq!(lq(0, Vector::zeros()).err(), Some(Error::EmptyHorizon));
}

#[test]
fn nan_and_inf_in_x0_name_the_index() {
    let e = lq(10, Vector::<2>::new(0.0, f64::NAN)).err().unwrap();
    assert!(
        matches!(&e, Error::NotFinite { field, index: 1, .. } if field == "x0"),
        "{e}"
    );
    let mut p = lq(10, Vector::zeros()).unwrap();
    let e = p.set_x0(Vector::<2>::new(f64::INFINITY, 0.0)).unwrap_err();
    assert!(message(e).starts_with("x0[0] is not finite"));
}

#[test]
fn negative_and_nan_weights_name_the_field() {
    let e = QuadraticCost::<U2, U1>::diagonal(&[1.0, -2.0], &[0.1], Vector::zeros(), Vector::zeros()).unwrap_err();
    assert_eq!(message(e), "q[1] is invalid: weight must be non-negative, got -2");
    let e = QuadraticCost::<U2, U1>::diagonal(&[1.0, 1.0], &[f64::NAN], Vector::zeros(), Vector::zeros()).unwrap_err();
    assert!(
        matches!(&e, Error::NotFinite { field, index: 0, .. } if field == "r"),
        "{e}"
    );
    assert!(ControlSquared::new(-1.0).is_err());
    assert!(SmoothDistance::<3>::goal([0.0, 0.0], [0, 1], 0.0, 1.0)
        .unwrap_err()
        .to_string()
        .contains("eps"));
    assert!(ObstacleHinge::<3>::new(vec![[0.0, f64::NAN]], 1.0, [0, 1], 1.0)
        .unwrap_err()
        .to_string()
        .contains("points[0]"));
}

#[test]
fn non_psd_and_asymmetric_weights_are_rejected() {
    let q = Matrix::<2, 2>::new(1.0, 2.0, 2.0, 1.0); // eigenvalues 3 and -1
    let e = QuadraticCost::<U2, U1>::new(q, Matrix::identity(), Vector::zeros(), Vector::zeros()).unwrap_err();
    assert!(matches!(&e, Error::NotPsd { field, .. } if field == "q"), "{e}");
    assert!(message(e).contains("eigenvalue"));
    let asym = Matrix::<2, 2>::new(1.0, 0.5, 0.0, 1.0);
    let e = QuadraticTerminal::<U2>::new(asym, Vector::zeros()).unwrap_err();
    assert!(message(e).contains("not symmetric"));
}

#[test]
fn bad_indices_are_rejected() {
    let e = SmoothDistance::<3>::goal([0.0, 0.0], [0, 3], 1e-3, 1.0).unwrap_err();
    assert_eq!(
        message(e),
        "indices[1] is invalid: state index 3 out of range for a 3-dimensional state"
    );
}

#[test]
fn inverted_bounds_name_the_index() {
    let e = ControlBounds::<U2>::new(Vector::<2>::new(-1.0, 2.0), Vector::<2>::new(1.0, 1.0)).unwrap_err();
    assert!(message(e).starts_with("u_min[1] is invalid"));
}

#[test]
fn invalid_settings_name_the_field() {
    let p = lq(10, Vector::zeros()).unwrap();
    for (settings, field) in [
        (
            Settings {
                max_iterations: 0,
                ..Settings::default()
            },
            "settings.max_iterations",
        ),
        (
            Settings {
                regularization: RegularizationSettings {
                    mu_factor: 1.0,
                    ..Default::default()
                },
                ..Settings::default()
            },
            "settings.regularization.mu_factor",
        ),
        (
            Settings {
                line_search: LineSearchSettings {
                    step_factor: 1.5,
                    ..Default::default()
                },
                ..Settings::default()
            },
            "settings.line_search.step_factor",
        ),
        (
            Settings {
                tolerances: Tolerances {
                    gradient: f64::NAN,
                    ..Default::default()
                },
                ..Settings::default()
            },
            "settings.tolerances.gradient",
        ),
    ] {
        let e = Solver::new(&p, settings).unwrap_err();
        assert!(message(e).starts_with(field), "expected an error naming {field}");
    }
}

#[test]
fn multiple_shooting_rejects_control_bounds() {
    let multiple = Settings {
        shooting: Shooting::Multiple,
        ..Settings::default()
    };
    let free = lq(10, Vector::zeros()).unwrap();
    let bounded = free
        .clone()
        .with_control_bounds(ControlBounds::new(Vector::<1>::new(-1.0), Vector::<1>::new(1.0)).unwrap())
        .unwrap();
    let e = Solver::new(&bounded, multiple).unwrap_err();
    assert!(message(e).starts_with("settings.shooting is invalid: multiple shooting does not take control bounds"));
    // A bounded problem handed to a solver made for a free one: the same error, at solve time.
    let mut solver = Solver::new(&free, multiple).unwrap();
    let e = solver.solve(&bounded).unwrap_err();
    assert!(message(e).starts_with("settings.shooting is invalid"));
    // State guesses: multiple shooting only, of the horizon's length, finite.
    let xs = vec![Vector::<2>::zeros(); 11];
    let e = Solver::new(&free, Settings::default())
        .unwrap()
        .set_states(&xs)
        .unwrap_err();
    assert!(message(e).starts_with("settings.shooting is invalid: a state guess needs multiple shooting"));
    let e = solver.set_states(&xs[..10]).unwrap_err();
    assert_eq!(message(e), "xs has shape (10, 2), expected (11, 2)");
    let mut bad = xs.clone();
    bad[3][1] = f64::INFINITY;
    let e = message(solver.set_states(&bad).unwrap_err());
    assert!(e.starts_with("xs[3][1] is not finite"), "{e}");
}

#[test]
fn wrong_guess_length_and_horizon_are_shape_errors() {
    let p = lq(10, Vector::zeros()).unwrap();
    let mut solver = Solver::new(&p, Settings::default()).unwrap();
    let e = solver.set_controls(&[Vector::<1>::zeros(); 9]).unwrap_err();
    assert_eq!(message(e), "us has shape (9, 1), expected (10, 1)");
    let e = solver.set_controls(&[Vector::<1>::new(f64::NAN); 10]).unwrap_err();
    assert!(message(e).starts_with("us[0][0] is not finite"));
    let other = lq(11, Vector::zeros()).unwrap();
    assert!(matches!(solver.solve(&other).unwrap_err(), Error::Shape { .. }));
}

#[test]
fn non_finite_dynamics_is_a_status_not_a_panic() {
    // A model that blows up: the solve reports NumericalError instead of panicking.
    let p = Problem::new(
        Vector::<2>::new(1.0, 0.0),
        Arc::new(
            LinearDynamics::new(
                Matrix::<2, 2>::new(1e300, 0.0, 0.0, 1e300),
                Matrix::<2, 1>::zeros(),
                Vector::zeros(),
            )
            .unwrap(),
        ),
        Arc::new(QuadraticCost::diagonal(&[1.0, 1.0], &[0.1], Vector::zeros(), Vector::zeros()).unwrap()),
        Arc::new(QuadraticTerminal::diagonal(&[10.0, 10.0], Vector::zeros()).unwrap()),
        5,
    )
    .unwrap();
    let mut solver = Solver::new(&p, Settings::default()).unwrap();
    assert_eq!(solver.solve(&p).unwrap().status, ddp_core::Status::NumericalError);
}

#[test]
fn a_huge_iteration_limit_allocates_a_bounded_log() {
    // 2^40 iterations would be 2^40 log rows allocated up front (an abort, not an error); the
    // log is preallocated up to `LOG_PREALLOCATED` rows and the solve runs to convergence.
    let p = lq(10, Vector::<2>::new(1.0, 0.0)).unwrap();
    for shooting in [Shooting::Single, Shooting::Multiple] {
        let settings = Settings {
            max_iterations: 1 << 40,
            shooting,
            ..Settings::default()
        };
        let mut s = Solver::new(&p, settings).unwrap();
        let r = s.solve(&p).unwrap();
        assert_eq!(r.status, ddp_core::Status::Converged);
        assert!(r.log.capacity() <= 2 * ddp_core::solver::LOG_PREALLOCATED);
        s.set_settings(Settings {
            max_iterations: usize::MAX,
            shooting,
            ..Settings::default()
        })
        .unwrap();
        assert_eq!(s.solve(&p).unwrap().status, ddp_core::Status::Converged);
    }
    assert_eq!(
        ddp_core::solver::log_rows(usize::MAX),
        ddp_core::solver::LOG_PREALLOCATED
    );
    assert_eq!(ddp_core::solver::log_rows(200), 201);
}
