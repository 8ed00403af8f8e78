//! Safe-CDDP batch solves equal one-at-a-time solves with fresh solvers bit for bit, with and
//! without a tightening, for 1, 2 and 4 threads; bad input is an error naming the field.

use std::sync::Arc;

use ddp_core::dims::{U2, U4};
use ddp_core::{reference, Error, Matrix, Vector};
use safe_cddp::batch::{solve_batch, SafeBatchItem, SafeBatchSolution};
use safe_cddp::constraints::Circle;
use safe_cddp::{Constraint, SafeCddpSolver, Settings, Tightening};

fn items(count: usize) -> Vec<SafeBatchItem<U4, U2>> {
    let obstacle: Arc<dyn Constraint<U4, U2>> = Arc::new(Circle::squared([1.5, 1.5], 0.5, [0, 1]).unwrap());
    (0..count)
        .map(|i| {
            let mut problem = reference::point_reach();
            problem
                .set_x0(Vector::<4>::new(0.15 * i as f64, -0.1 * (i % 3) as f64, 0.0, 0.0))
                .unwrap();
            // Every third item with chance-constraint tightening (Alcan and Kyrki 2022).
            let tightening = (i % 3 == 2).then(|| Tightening::new(0.9, Matrix::<4, 4>::identity() * 1e-5).unwrap());
            SafeBatchItem {
                problem,
                constraints: vec![obstacle.clone()],
                tightening,
            }
        })
        .collect()
}

/// Solved alone, the way a user does it today.
fn alone(item: &SafeBatchItem<U4, U2>, settings: Settings) -> SafeBatchSolution<U4, U2> {
    let mut s = SafeCddpSolver::new(&item.problem, item.constraints.clone(), settings).unwrap();
    s.set_tightening(item.tightening.clone()).unwrap();
    s.solve(&item.problem).unwrap();
    SafeBatchSolution::from_solver(&s)
}

#[test]
fn safe_batch_equals_one_at_a_time_for_1_2_4_threads() {
    let items = items(6);
    let settings = Settings {
        max_iterations: 60,
        ..Settings::default()
    };
    let want: Vec<_> = items.iter().map(|i| alone(i, settings)).collect();
    // Not vacuous: the items differ.
    assert_ne!(want[0].report.cost, want[1].report.cost);
    assert!(want[2].report.tightenings > 0, "the tightened item was tightened");
    for threads in [1, 2, 4] {
        let got = solve_batch(&items, &settings, Some(threads)).unwrap();
        assert_eq!(got.len(), want.len());
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(g.xs, w.xs, "{threads} threads: xs of item {i}");
            assert_eq!(g.us, w.us, "{threads} threads: us of item {i}");
            assert_eq!(g.gains, w.gains, "{threads} threads: gains of item {i}");
            assert_eq!(
                g.feedforward, w.feedforward,
                "{threads} threads: feedforward of item {i}"
            );
            assert_eq!(
                g.covariances, w.covariances,
                "{threads} threads: covariances of item {i}"
            );
            assert_eq!(
                g.report.cost.to_bits(),
                w.report.cost.to_bits(),
                "{threads} threads: cost of item {i}"
            );
            assert_eq!(g.report.status, w.report.status);
            assert_eq!(g.report.iterations, w.report.iterations);
        }
    }
}

#[test]
fn safe_batch_bad_input_names_the_field() {
    let e = solve_batch::<U4, U2>(&[], &Settings::default(), Some(2)).unwrap_err();
    assert!(matches!(&e, Error::Invalid { field, .. } if field == "problems"), "{e}");

    let mut two = items(2);
    let e = solve_batch(&two, &Settings::default(), Some(0)).unwrap_err();
    assert!(matches!(&e, Error::Invalid { field, .. } if field == "threads"), "{e}");

    two[1].problem = ddp_core::Problem::new(
        Vector::<4>::zeros(),
        Arc::new(ddp_core::models::DoubleIntegrator2D::new(0.05).unwrap()),
        Arc::new(ddp_core::costs::QuadraticCost::weighted_norms(1.0, 1.0).unwrap()),
        Arc::new(ddp_core::costs::QuadraticTerminal::diagonal(&[10.0; 4], Vector::zeros()).unwrap()),
        50,
    )
    .unwrap();
    let e = solve_batch(&two, &Settings::default(), Some(2)).unwrap_err();
    assert!(
        matches!(&e, Error::Shape { field, .. } if field == "problems[1]"),
        "{e}"
    );

    let settings = Settings {
        max_iterations: 0,
        ..Settings::default()
    };
    let e = solve_batch(&items(2), &settings, Some(2)).unwrap_err();
    assert!(e.to_string().contains("max_iterations"), "{e}");
}

#[test]
fn a_huge_iteration_limit_allocates_a_bounded_log() {
    // 2^40 iterations used to mean 2^40 log rows allocated up front in each of the solver's
    // reports (an abort); the logs are preallocated up to `LOG_PREALLOCATED` rows.
    let settings = Settings {
        max_iterations: 1 << 40,
        ..Settings::default()
    };
    let item = &items(1)[0];
    let huge = alone(item, settings);
    let plain = alone(item, Settings::default());
    assert_eq!(huge.report.status, plain.report.status);
    assert_eq!(huge.report.cost.to_bits(), plain.report.cost.to_bits());
    assert!(huge.report.log.capacity() <= 2 * ddp_core::solver::LOG_PREALLOCATED);
    let two = solve_batch(&items(2), &settings, Some(2)).unwrap();
    assert_eq!(two.len(), 2);
}
