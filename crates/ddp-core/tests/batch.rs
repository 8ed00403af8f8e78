//! Batch solves equal one-at-a-time solves bit for bit (iLQR, full DDP, box-DDP, run-time
//! sizes), for any thread count; bad input is an error naming the field; a panicking model is
//! an error naming its problem, never a panic out of `solve_batch`.
//!
//! With the `parallel` feature: derivatives on several threads equal the sequential ones bit
//! for bit, and so does a whole solve.

use std::sync::Arc;

use ddp_core::batch::{map_workers, solve_batch, BatchSolution};
use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::dims::{Alloc, DefaultAllocator, Dim, Dyn, MatrixN, U2, U3};
use ddp_core::linear::LinearDynamics;
use ddp_core::models::Unicycle;
use ddp_core::reference::{car_parking, p1_unicycle};
use ddp_core::{ControlBounds, Dynamics, Error, Method, Problem, Settings, Solver, Vector};
use nalgebra::{DMatrix, DVector};

/// P1 (the README's unicycle) from 16 seeded initial states (a small LCG: no rand dependency).
fn unicycle_family(count: usize, bounded: bool) -> Vec<Problem<U3, U2>> {
    let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut uniform = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..count)
        .map(|_| {
            let mut p = p1_unicycle();
            p.set_x0(Vector::<3>::new(uniform() * 2.0, uniform() * 2.0, uniform() * 3.0))
                .unwrap();
            if bounded {
                p.set_control_bounds(Some(
                    ControlBounds::new(Vector::<2>::new(-0.6, -0.8), Vector::<2>::new(0.6, 0.8)).unwrap(),
                ))
                .unwrap();
            }
            p
        })
        .collect()
}

/// A 7-state, 3-control linear system at run-time sizes, from different `x0`.
fn linear_family(count: usize) -> Vec<Problem<Dyn, Dyn>> {
    let (nx, nu) = (7, 3);
    let a = DMatrix::<f64>::from_fn(
        nx,
        nx,
        |i, j| if i == j { 0.99 } else { 0.01 * ((i + 2 * j) % 5) as f64 },
    );
    let b = DMatrix::<f64>::from_fn(nx, nu, |i, j| if i % nu == j { 0.1 } else { 0.0 });
    (0..count)
        .map(|c| {
            Problem::<Dyn, Dyn>::new(
                DVector::from_fn(nx, |i, _| ((i + c) as f64 * 0.37).sin()),
                Arc::new(LinearDynamics::new(a.clone(), b.clone(), DVector::zeros(nx)).unwrap()),
                Arc::new(
                    QuadraticCost::diagonal(&vec![1.0; nx], &vec![0.1; nu], DVector::zeros(nx), DVector::zeros(nu))
                        .unwrap(),
                ),
                Arc::new(QuadraticTerminal::diagonal(&vec![10.0; nx], DVector::zeros(nx)).unwrap()),
                30,
            )
            .unwrap()
        })
        .collect()
}

/// Each problem solved alone by a fresh solver.
fn one_at_a_time<NX: Dim, NU: Dim>(problems: &[Problem<NX, NU>], settings: Settings) -> Vec<BatchSolution<NX, NU>>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    problems
        .iter()
        .map(|p| {
            let mut s = Solver::new(p, settings).unwrap();
            s.solve(p).unwrap();
            BatchSolution::from_solver(&s)
        })
        .collect()
}

/// Exact equality of everything but the wall time.
fn assert_identical<NX: Dim, NU: Dim>(got: &[BatchSolution<NX, NU>], want: &[BatchSolution<NX, NU>], what: &str)
where
    DefaultAllocator: Alloc<NX, NU>,
{
    assert_eq!(got.len(), want.len(), "{what}: count");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert_eq!(g.xs, w.xs, "{what}: xs of problem {i}");
        assert_eq!(g.us, w.us, "{what}: us of problem {i}");
        assert_eq!(g.gains, w.gains, "{what}: gains of problem {i}");
        assert_eq!(g.feedforward, w.feedforward, "{what}: feedforward of problem {i}");
        assert_eq!(
            g.report.cost.to_bits(),
            w.report.cost.to_bits(),
            "{what}: cost of problem {i}"
        );
        assert_eq!(g.report.status, w.report.status, "{what}: status of problem {i}");
        assert_eq!(
            g.report.iterations, w.report.iterations,
            "{what}: iterations of problem {i}"
        );
        // Debug prints every f64 exactly (shortest round-trip form) and NaN as NaN, which `==`
        // on the rows would call unequal (the first row's gradient is NaN).
        let (gl, wl) = (format!("{:?}", g.report.log), format!("{:?}", w.report.log));
        assert!(gl == wl, "{what}: iteration log of problem {i} differs");
    }
}

fn check_all_thread_counts<NX: Dim, NU: Dim>(problems: &[Problem<NX, NU>], settings: Settings, what: &str)
where
    DefaultAllocator: Alloc<NX, NU>,
{
    let want = one_at_a_time(problems, settings);
    for threads in [1, 2, 4] {
        let got = solve_batch(problems, &settings, Some(threads)).unwrap();
        assert_identical(&got, &want, &format!("{what}, {threads} threads"));
    }
}

#[test]
fn ilqr_batch_equals_one_at_a_time_for_1_2_4_threads() {
    let problems = unicycle_family(16, false);
    check_all_thread_counts(&problems, Settings::default(), "iLQR");
    // Not a vacuous test: the problems differ, and so do their solutions.
    let sols = solve_batch(&problems, &Settings::default(), Some(2)).unwrap();
    assert_ne!(sols[0].report.cost, sols[1].report.cost);
}

#[test]
fn full_ddp_batch_equals_one_at_a_time() {
    let settings = Settings {
        method: Method::Ddp,
        ..Settings::default()
    };
    check_all_thread_counts(&unicycle_family(12, false), settings, "full DDP");
}

#[test]
fn box_ddp_batch_equals_one_at_a_time() {
    let problems = unicycle_family(12, true);
    check_all_thread_counts(&problems, Settings::default(), "box-DDP");
    // The bounds are active somewhere (box-DDP's QP, not the free gains, made these).
    let sols = solve_batch(&problems, &Settings::default(), Some(2)).unwrap();
    assert!(sols
        .iter()
        .any(|s| s.us.iter().any(|u| (u[0].abs() - 0.6).abs() < 1e-12)));
}

#[test]
fn box_ddp_car_batch_equals_one_at_a_time() {
    let problems: Vec<_> = (0..6)
        .map(|i| {
            let mut p = car_parking();
            p.set_x0(Vector::<4>::new(0.1 * i as f64, -0.05 * i as f64, 0.0, 0.0))
                .unwrap();
            p
        })
        .collect();
    check_all_thread_counts(&problems, Settings::default(), "box-DDP car");
}

#[test]
fn run_time_size_batch_equals_one_at_a_time() {
    check_all_thread_counts(&linear_family(9), Settings::default(), "Dyn (7, 3)");
}

#[test]
fn default_thread_count_gives_the_same_results() {
    let problems = unicycle_family(5, false);
    let want = one_at_a_time(&problems, Settings::default());
    assert_identical(
        &solve_batch(&problems, &Settings::default(), None).unwrap(),
        &want,
        "threads = None",
    );
}

#[test]
fn more_threads_than_problems_is_fine() {
    let problems = unicycle_family(3, false);
    let want = one_at_a_time(&problems, Settings::default());
    assert_identical(
        &solve_batch(&problems, &Settings::default(), Some(8)).unwrap(),
        &want,
        "8 threads, 3 problems",
    );
}

#[test]
fn empty_batch_is_an_error_naming_problems() {
    let problems: Vec<Problem<U3, U2>> = Vec::new();
    let e = solve_batch(&problems, &Settings::default(), Some(2)).unwrap_err();
    assert!(matches!(&e, Error::Invalid { field, .. } if field == "problems"), "{e}");
}

#[test]
fn zero_threads_is_an_error_naming_threads() {
    let e = solve_batch(&unicycle_family(2, false), &Settings::default(), Some(0)).unwrap_err();
    assert!(matches!(&e, Error::Invalid { field, .. } if field == "threads"), "{e}");
}

#[test]
fn different_horizon_is_an_error_naming_the_index() {
    let mut problems = unicycle_family(3, false);
    problems.push(
        Problem::new(
            Vector::<3>::new(1.0, 0.0, 0.0),
            Arc::new(Unicycle::new(0.1).unwrap()),
            Arc::new(QuadraticCost::weighted_norms(10.0, 1.0).unwrap()),
            Arc::new(QuadraticTerminal::diagonal(&[100.0; 3], Vector::zeros()).unwrap()),
            50,
        )
        .unwrap(),
    );
    let e = solve_batch(&problems, &Settings::default(), Some(2)).unwrap_err();
    assert!(
        matches!(&e, Error::Shape { field, .. } if field == "problems[3]"),
        "{e}"
    );
    assert!(e.to_string().contains("(3, 2, 50)"), "{e}");
}

#[test]
fn different_run_time_sizes_are_an_error_naming_the_index() {
    let mut problems = linear_family(2);
    let (nx, nu) = (5, 3);
    problems.push(
        Problem::<Dyn, Dyn>::new(
            DVector::from_element(nx, 1.0),
            Arc::new(
                LinearDynamics::new(DMatrix::identity(nx, nx), DMatrix::zeros(nx, nu), DVector::zeros(nx)).unwrap(),
            ),
            Arc::new(
                QuadraticCost::diagonal(&vec![1.0; nx], &vec![0.1; nu], DVector::zeros(nx), DVector::zeros(nu))
                    .unwrap(),
            ),
            Arc::new(QuadraticTerminal::diagonal(&vec![10.0; nx], DVector::zeros(nx)).unwrap()),
            30,
        )
        .unwrap(),
    );
    let e = solve_batch(&problems, &Settings::default(), Some(2)).unwrap_err();
    assert!(
        matches!(&e, Error::Shape { field, .. } if field == "problems[2]"),
        "{e}"
    );
}

#[test]
fn invalid_settings_are_an_error_naming_the_field() {
    let settings = Settings {
        max_iterations: 0,
        ..Settings::default()
    };
    let e = solve_batch(&unicycle_family(2, false), &settings, Some(2)).unwrap_err();
    assert!(
        matches!(&e, Error::Invalid { field, .. } if field == "settings.max_iterations"),
        "{e}"
    );
}

/// A user model with a bug: it panics when the state's first coordinate passes 5.
struct Exploding;

impl Dynamics<U3, U2> for Exploding {
    fn step(&self, x: &Vector<3>, u: &Vector<2>) -> Vector<3> {
        assert!(x[0] < 5.0, "Exploding model: x[0] = {} passed 5", x[0]);
        x + Vector::<3>::new(0.1 * u[0], 0.1 * u[1], 0.0)
    }
    fn jacobians(&self, _x: &Vector<3>, _u: &Vector<2>, fx: &mut MatrixN<U3, U3>, fu: &mut MatrixN<U3, U2>) {
        *fx = MatrixN::<U3, U3>::identity();
        fu.fill(0.0);
        fu[(0, 0)] = 0.1;
        fu[(1, 1)] = 0.1;
    }
}

#[test]
fn a_panicking_model_is_an_error_naming_its_problem_and_the_rest_still_solve() {
    let make = |x0: f64| {
        Problem::new(
            Vector::<3>::new(x0, 0.0, 0.0),
            Arc::new(Exploding),
            Arc::new(QuadraticCost::weighted_norms(1.0, 1.0).unwrap()),
            Arc::new(QuadraticTerminal::diagonal(&[10.0; 3], Vector::zeros()).unwrap()),
            10,
        )
        .unwrap()
    };
    let problems = vec![make(0.5), make(1.0), make(7.0), make(2.0)];
    for threads in [1, 2] {
        let e = solve_batch(&problems, &Settings::default(), Some(threads)).unwrap_err();
        assert!(
            matches!(&e, Error::Invalid { field, reason } if field == "problems[2]" && reason.contains("panicked") && reason.contains("passed 5")),
            "{threads} threads: {e}"
        );
    }
    // The executor keeps the other items' results and gives each worker a fresh workspace
    // after a panic.
    let results = map_workers(
        &problems,
        2,
        || Solver::new(&problems[0], Settings::default()),
        |s, _, p| {
            s.reset();
            Ok(s.solve(p)?.cost)
        },
    );
    assert!(results[2].is_err());
    let want = one_at_a_time(&[problems[3].clone()], Settings::default());
    assert_eq!(results[3].as_ref().unwrap().to_bits(), want[0].report.cost.to_bits());
    assert!(results[0].is_ok() && results[1].is_ok());
}

#[test]
fn derivative_threads_zero_is_an_error_naming_the_field() {
    let settings = Settings {
        derivative_threads: 0,
        ..Settings::default()
    };
    let e = Solver::new(&p1_unicycle(), settings).unwrap_err();
    assert!(
        matches!(&e, Error::Invalid { field, .. } if field == "settings.derivative_threads"),
        "{e}"
    );
}

#[cfg(not(feature = "parallel"))]
#[test]
fn derivative_threads_need_the_parallel_feature() {
    let settings = Settings {
        derivative_threads: 2,
        ..Settings::default()
    };
    let e = Solver::new(&p1_unicycle(), settings).unwrap_err();
    assert!(e.to_string().contains("parallel"), "{e}");
}

#[cfg(feature = "parallel")]
mod parallel_derivatives {
    use super::*;
    use ddp_core::dims::VectorN;
    use ddp_core::reference::{arm_base_reach_horizon, quadrotor_reach_horizon};
    use ddp_core::solver::{DerivativeThreads, Linearization};

    /// The linearisation at a non-trivial trajectory, sequential and on `threads`.
    fn linearizations<NX: Dim, NU: Dim>(problem: &Problem<NX, NU>, threads: usize)
    where
        DefaultAllocator: Alloc<NX, NU>,
    {
        let n = problem.horizon();
        let dims = problem.dims();
        let us: Vec<VectorN<NU>> = (0..n)
            .map(|k| VectorN::<NU>::from_fn_generic(dims.nu, nalgebra::U1, |i, _| ((k * 7 + i) as f64 * 0.13).sin()))
            .collect();
        let mut xs = vec![dims.x_zeros(); n + 1];
        problem.rollout(&us, &mut xs).unwrap();
        // The data a rollout's steps keep for the Jacobians (the unicycle's sin_cos).
        let mut kept = vec![Vec::new(); n];
        for (k, knot) in problem.knots().iter().enumerate() {
            let mut next = xs[k + 1].clone();
            knot.dynamics.step_keep(&xs[k], &us[k], &mut next, &mut kept[k]);
        }
        let mut seq = Linearization::new(dims, n);
        seq.compute(problem, &xs, &us, &[], n);
        let mut seq_kept = Linearization::new(dims, n);
        seq_kept.compute(problem, &xs, &us, &kept, n);
        assert_eq!(seq_kept.fx, seq.fx, "fx from the kept data");
        let mut par = Linearization::new(dims, n);
        par.compute_with(&DerivativeThreads::new(threads).unwrap(), problem, &xs, &us, &kept, n);
        assert_eq!(par.fx, seq.fx, "fx, {threads} threads");
        assert_eq!(par.fu, seq.fu, "fu, {threads} threads");
        assert_eq!(par.l, seq.l, "running-cost derivatives, {threads} threads");
        assert_eq!(par.l_n, seq.l_n, "terminal-cost derivatives, {threads} threads");
        // Not vacuous: the Jacobians vary along the trajectory.
        assert_ne!(seq.fx[0], seq.fx[n - 1]);
    }

    #[test]
    fn parallel_linearization_is_bit_identical() {
        for threads in [2, 3, 4] {
            linearizations(&quadrotor_reach_horizon(101), threads);
            linearizations(&arm_base_reach_horizon(37), threads);
            linearizations(&p1_unicycle(), threads);
        }
    }

    fn solve_with<NX: Dim, NU: Dim>(problem: &Problem<NX, NU>, settings: Settings) -> BatchSolution<NX, NU>
    where
        DefaultAllocator: Alloc<NX, NU>,
    {
        let mut s = Solver::new(problem, settings).unwrap();
        s.solve(problem).unwrap();
        BatchSolution::from_solver(&s)
    }

    #[test]
    fn solves_with_derivative_threads_are_bit_identical() {
        for method in [Method::Ilqr, Method::Ddp] {
            let base = Settings {
                method,
                max_iterations: 30,
                ..Settings::default()
            };
            for threads in [2, 4] {
                let par = Settings {
                    derivative_threads: threads,
                    ..base
                };
                let what = format!("{method:?}, {threads} threads");
                let q = quadrotor_reach_horizon(100);
                assert_identical(
                    &[solve_with(&q, par)],
                    &[solve_with(&q, base)],
                    &format!("quadrotor {what}"),
                );
                let a = arm_base_reach_horizon(60);
                assert_identical(&[solve_with(&a, par)], &[solve_with(&a, base)], &format!("arm {what}"));
                let b = &unicycle_family(1, true)[0];
                assert_identical(
                    &[solve_with(b, par)],
                    &[solve_with(b, base)],
                    &format!("box-DDP {what}"),
                );
                let d = &linear_family(1)[0];
                assert_identical(&[solve_with(d, par)], &[solve_with(d, base)], &format!("Dyn {what}"));
            }
        }
    }

    #[test]
    fn set_settings_changes_the_thread_count_and_results_stay_identical() {
        let p = quadrotor_reach_horizon(80);
        let mut s = Solver::new(&p, Settings::default()).unwrap();
        s.solve(&p).unwrap();
        let want = BatchSolution::from_solver(&s);
        s.set_settings(Settings {
            derivative_threads: 2,
            ..Settings::default()
        })
        .unwrap();
        s.reset();
        s.solve(&p).unwrap();
        assert_identical(&[BatchSolution::from_solver(&s)], &[want], "after set_settings");
        let e = s
            .set_settings(Settings {
                derivative_threads: 0,
                ..Settings::default()
            })
            .unwrap_err();
        assert!(e.to_string().contains("settings.derivative_threads"), "{e}");
    }

    #[test]
    fn batch_ignores_derivative_threads_and_stays_identical() {
        let problems = unicycle_family(4, false);
        let settings = Settings {
            derivative_threads: 2,
            ..Settings::default()
        };
        let want = one_at_a_time(&problems, Settings::default());
        assert_identical(&solve_batch(&problems, &settings, Some(2)).unwrap(), &want, "batch");
    }
}
