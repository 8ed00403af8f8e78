//! Every built-in constraint's Jacobians against central differences, by one generic loop.

use ddp_core::dims::{U2, U4};
use std::sync::Arc;

use ddp_core::{Matrix, Vector};
use nalgebra::Matrix2;
use safe_cddp::constraints::{
    Circle, ControlBox, ConvexPolygon, Cylinder, FiniteDiffConstraint, MovingCircle, StateBox,
};
use safe_cddp::{check_constraint_derivatives, Constraint};

type Named = (&'static str, Arc<dyn Constraint<U4, U2>>, bool);

fn all_constraints() -> Vec<Named> {
    // (name, constraint, whether add_hessian is implemented)
    vec![
        (
            "circle squared",
            Arc::new(Circle::squared([1.0, 0.5], 0.4, [0, 1]).unwrap()),
            true,
        ),
        (
            "circle distance",
            Arc::new(Circle::distance([1.0, 0.5], 0.4, [0, 1]).unwrap()),
            true,
        ),
        (
            "moving circle",
            Arc::new(
                MovingCircle::new(
                    vec![[1.0, 0.5], [1.1, 0.4], [1.2, 0.3]],
                    vec![
                        Matrix2::identity() * 0.01,
                        Matrix2::identity() * 0.02,
                        Matrix2::new(0.03, 0.01, 0.01, 0.02),
                    ],
                    0.3,
                    [0, 1],
                    Default::default(),
                )
                .unwrap(),
            ),
            true,
        ),
        (
            "convex polygon",
            Arc::new(ConvexPolygon::new(&[[0.5, 0.0], [1.5, 0.2], [1.2, 1.0], [0.4, 0.8]], 0.1, [0, 1]).unwrap()),
            false,
        ),
        (
            // (px, py, theta) stand in for a 3-D position: the Jacobian check is generic.
            "cylinder",
            Arc::new(Cylinder::new([1.0, 0.5], 0.4, 0.3, 0.05, [0, 1, 2]).unwrap()),
            false,
        ),
        (
            "state box",
            Arc::new(
                StateBox::new(
                    Vector::<4>::new(-1.0, -2.0, f64::NEG_INFINITY, -0.5),
                    Vector::<4>::new(3.0, 2.0, 1.0, f64::INFINITY),
                )
                .unwrap(),
            ),
            true,
        ),
        (
            "control box",
            Arc::new(ControlBox::new(Vector::<2>::new(-0.4, -0.5), Vector::<2>::new(0.4, 0.5)).unwrap()),
            true,
        ),
        (
            "user (finite differences)",
            Arc::new(
                FiniteDiffConstraint::new(2, true, |_t: usize, x: &Vector<4>, u: &Vector<2>, g: &mut [f64]| {
                    g[0] = x[3] * x[3] + u[1] - 1.0; // speed-acceleration envelope
                    g[1] = (x[2] + u[0]).sin() - 0.9;
                })
                .unwrap(),
            ),
            false,
        ),
    ]
}

#[test]
fn constraint_derivatives_match_finite_differences() {
    let points = [
        (Vector::<4>::new(0.2, -0.3, 0.4, 0.5), Vector::<2>::new(0.1, -0.2)),
        (Vector::<4>::new(1.1, 0.6, -0.2, 1.0), Vector::<2>::new(-0.3, 0.4)), // inside the obstacles
        (Vector::<4>::new(2.0, 1.5, 1.0, -0.7), Vector::<2>::new(0.35, 0.0)),
        (Vector::<4>::new(0.9, 0.05, 0.0, 0.0), Vector::<2>::new(0.0, 0.0)),
    ];
    for (name, c, has_hessian) in all_constraints() {
        for (i, (x, u)) in points.iter().enumerate() {
            for t in [0, 2] {
                let e = check_constraint_derivatives(c.as_ref(), t, x, u);
                let tol = 1e-6 * (1.0 + x.amax());
                assert!(e.max_first_order() < tol, "{name} at point {i}, t = {t}: {e:?}");
                if has_hessian {
                    assert!(e.hessian < 1e-5, "{name} Hessian at point {i}: {e:?}");
                }
            }
        }
    }
}

/// Five states and controls of the `_along` tests, and a row stride above every constraint's
/// `dim()`.
fn along_trajectory() -> (Vec<Vector<4>>, Vec<Vector<2>>, usize) {
    let xs = (0..5)
        .map(|i| {
            let s = i as f64;
            Vector::<4>::new(0.3 * s - 0.2, 0.5 - 0.2 * s, 0.1 * s, 0.7 - 0.3 * s)
        })
        .collect();
    let us = (0..5).map(|i| Vector::<2>::new(0.1 * i as f64, -0.05)).collect();
    (xs, us, 7)
}

#[test]
fn evaluate_along_equals_evaluate_bit_for_bit() {
    // The line search evaluates the rows with `evaluate_along` (strided, one call per
    // constraint); its values must be those of `evaluate` exactly, or the iterates would change.
    let (xs, us, stride) = along_trajectory();
    for (name, c, _) in all_constraints() {
        let d = c.dim();
        for us in [&us[..], &us[..1]] {
            let mut along = vec![f64::NAN; stride * xs.len()];
            c.evaluate_along(3, &xs, us, &mut along, stride);
            let mut g = vec![0.0; d];
            for (i, x) in xs.iter().enumerate() {
                let u = if us.len() == 1 { &us[0] } else { &us[i] };
                c.evaluate(3 + i, x, u, &mut g);
                for r in 0..d {
                    assert_eq!(
                        along[i * stride + r].to_bits(),
                        g[r].to_bits(),
                        "{name}, state {i}, row {r}"
                    );
                }
            }
        }
    }
}

#[test]
fn jacobians_along_equals_jacobians_bit_for_bit() {
    // The linearisation takes every row's Jacobians with `jacobians_along` (strided, one call per
    // constraint); they must be those of `jacobians` exactly, or the iterates would change. The
    // entries between the strided rows are left alone.
    let (xs, us, stride) = along_trajectory();
    for (name, c, _) in all_constraints() {
        let d = c.dim();
        for us in [&us[..], &us[..1]] {
            let len = stride * xs.len();
            let (mut g, mut gx, mut gu) = (
                vec![f64::NAN; len],
                vec![Vector::<4>::repeat(f64::NAN); len],
                vec![Vector::<2>::repeat(f64::NAN); len],
            );
            c.jacobians_along(3, &xs, us, &mut g, &mut gx, &mut gu, stride);
            let (mut g1, mut gx1, mut gu1) = (
                vec![0.0; d],
                vec![Vector::<4>::zeros(); d],
                vec![Vector::<2>::zeros(); d],
            );
            for (i, x) in xs.iter().enumerate() {
                let u = if us.len() == 1 { &us[0] } else { &us[i] };
                c.jacobians(3 + i, x, u, &mut g1, &mut gx1, &mut gu1);
                for r in 0..d {
                    let at = i * stride + r;
                    assert_eq!(g[at].to_bits(), g1[r].to_bits(), "{name}, state {i}, row {r}");
                    let bits = |v: &[f64]| v.iter().map(|e| e.to_bits()).collect::<Vec<_>>();
                    assert_eq!(
                        bits(gx[at].as_slice()),
                        bits(gx1[r].as_slice()),
                        "{name} g_x, state {i}, row {r}"
                    );
                    assert_eq!(
                        bits(gu[at].as_slice()),
                        bits(gu1[r].as_slice()),
                        "{name} g_u, state {i}, row {r}"
                    );
                }
                for r in d..stride {
                    assert!(g[i * stride + r].is_nan(), "{name}: row {r} of state {i} was written");
                }
            }
        }
    }
}

#[test]
fn polygon_signed_distance_is_exact() {
    // The unit square: outside along an edge, outside at a corner, inside.
    let sq =
        ConvexPolygon::<ddp_core::dims::Const<4>>::new(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]], 0.0, [0, 1])
            .unwrap();
    let (d, n) = sq.signed_distance([1.5, 0.5]);
    assert!((d - 0.5).abs() < 1e-12 && (n[0] - 1.0).abs() < 1e-12 && n[1].abs() < 1e-12);
    let (d, _) = sq.signed_distance([2.0, 2.0]);
    assert!((d - 2f64.sqrt()).abs() < 1e-12);
    let (d, n) = sq.signed_distance([0.5, 0.8]);
    assert!((d + 0.2).abs() < 1e-12, "{d}");
    assert!(n[0].abs() < 1e-12 && (n[1] - 1.0).abs() < 1e-12, "{n:?}");
}

#[test]
fn bad_constraint_input_is_rejected_with_the_field() {
    let e = Circle::<U4>::squared([f64::NAN, 0.0], 1.0, [0, 1])
        .unwrap_err()
        .to_string();
    assert!(e.contains("center"), "{e}");
    let e = Circle::<U4>::squared([0.0, 0.0], -1.0, [0, 1]).unwrap_err().to_string();
    assert!(e.contains("radius"), "{e}");
    let e = Circle::<U4>::squared([0.0, 0.0], 1.0, [0, 7]).unwrap_err().to_string();
    assert!(e.contains("indices[1]"), "{e}");
    let e = ConvexPolygon::<ddp_core::dims::Const<4>>::new(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]], 0.0, [0, 1])
        .unwrap_err()
        .to_string();
    assert!(e.contains("vertices"), "{e}");
    let e = StateBox::<U4>::new(Vector::repeat(1.0), Vector::repeat(0.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("x_min[0]"), "{e}");
    let e = MovingCircle::<U4>::new(vec![[0.0, 0.0]], vec![], 1.0, [0, 1], Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("covariances"), "{e}");
    let _: Matrix<2, 2> = Matrix::zeros();
}
