//! Safe-CDDP timings.
//!
//! - `car_n90/iteration`: one Safe-CDDP iteration (linearisation, constrained backward pass,
//!   forward pass with the per-step QPs and its line search, tightening by eqs. 19-20) on the car
//!   with N = 90 and two obstacles, from the converged deterministic trajectory, tightening with
//!   beta = 0.99 (the paper reports 22 ms on an i7). `fast` answers QPs by the unconstrained/active-set paths
//!   with Clarabel as fallback; `clarabel` sends every QP to Clarabel.
//! - `peers/p2`, `peers/p3`: cold solves of P2 and P3 (`bench/problems.md`).

use ddp_core::dims::{U2, U4};
use std::sync::Arc;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::models::Car;
use ddp_core::{ControlBounds, Matrix, Problem, Vector};
use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::constraints::Circle;
use safe_cddp::qp::QpMethod;
use safe_cddp::{Constraint, SafeCddpSolver, Settings, Tightening};

fn car_n90() -> (Problem<U4, U2>, safe_cddp::Constraints<U4, U2>) {
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

fn iteration(c: &mut Criterion) {
    let (problem, obstacles) = car_n90();
    let mut group = c.benchmark_group("car_n90");
    for (label, method) in [("fast", QpMethod::Fast), ("clarabel", QpMethod::Clarabel)] {
        let settings = Settings {
            qp_method: method,
            ..Settings::default()
        };
        let mut solver = SafeCddpSolver::new(&problem, obstacles.clone(), settings).unwrap();
        let sigma_w = Matrix::<4, 4>::from_diagonal(&Vector::<4>::new(1e-7, 1e-7, 1e-7, 1e-7));
        let tightening = Tightening::new(0.99, sigma_w).unwrap();
        solver.solve(&problem).unwrap();
        let us = solver.us().to_vec();
        let no_warmup = Settings {
            warm_up: safe_cddp::WarmUp::None,
            ..settings
        };
        solver.set_settings(no_warmup).unwrap();
        group.bench_function(BenchmarkId::new("iteration", label), |b| {
            b.iter(|| {
                // From the converged deterministic trajectory: one KKT/QP iteration, then eqs. 19-20.
                // (The phases by hand: `iterate` would stop after the backward pass at a converged
                // trajectory, and a full forward pass with its 90 QPs is what is timed here.)
                solver.set_tightening(None).unwrap();
                solver.set_controls(&us).unwrap();
                solver.start(&problem).unwrap();
                solver.linearize(&problem).unwrap();
                solver.backward(&problem, 0.0).unwrap();
                let merit = solver.forward(&problem, 1.0).unwrap();
                solver.set_tightening(Some(tightening.clone())).unwrap();
                solver.tighten(&problem).unwrap();
                merit
            })
        });
    }
    group.finish();
}

fn peers(c: &mut Criterion) {
    let dir = std::path::PathBuf::from("../../bench/problems"); // cargo runs benches in the package root
    let mut group = c.benchmark_group("peers");
    for (label, file) in [("p2", "p2_car4.json"), ("p3", "p3_point4.json")] {
        let Ok(p) = BenchmarkProblem::from_file(dir.join(file)) else {
            eprintln!("skipping {file}: not found under {}", dir.display());
            continue;
        };
        let (problem, constraints) = p.car_or_point().unwrap();
        let mut solver = SafeCddpSolver::new(&problem, constraints, Settings::default()).unwrap();
        group.bench_function(label, |b| {
            b.iter(|| {
                solver.reset();
                solver.solve(&problem).unwrap().cost
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30).measurement_time(std::time::Duration::from_secs(4));
    targets = iteration, peers
}
criterion_main!(benches);
