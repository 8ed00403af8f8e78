//! Per-phase timings on P1 (Crocoddyl's unicycle, N = 100): derivative evaluation, backward pass,
//! forward pass, and whole solves. Throughput is per knot, so criterion's "elem/s" converts to
//! µs per knot as Crocoddyl reports it.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use ddp_core::{reference, Method, Problem, Settings, Solver};
use nalgebra::Const;

fn phases<const NX: usize, const NU: usize>(c: &mut Criterion, name: &str, problem: &Problem<Const<NX>, Const<NU>>) {
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Elements(problem.horizon() as u64));
    let mut solver = Solver::new(problem, Settings::default()).unwrap();
    solver.solve(problem).unwrap();
    group.bench_function("linearize", |b| b.iter(|| solver.linearize(problem).unwrap()));
    group.bench_function("backward", |b| b.iter(|| solver.backward(problem, 1e-9).unwrap()));
    group.bench_function("forward", |b| b.iter(|| solver.forward(problem, 1.0).unwrap()));
    for (label, method) in [("ilqr", Method::Ilqr), ("ddp", Method::Ddp)] {
        let mut solver = Solver::new(
            problem,
            Settings {
                method,
                ..Settings::default()
            },
        )
        .unwrap();
        group.bench_function(BenchmarkId::new("solve", label), |b| {
            b.iter(|| {
                solver.reset();
                solver.solve(problem).unwrap().iterations
            })
        });
    }
    group.finish();
}

fn benches(c: &mut Criterion) {
    phases(c, "p1_unicycle", &reference::p1_unicycle());
    phases(c, "car_parking", &reference::car_parking());
    phases(c, "quadrotor_reach", &reference::quadrotor_reach());
}

criterion_group!(ddp, benches);
criterion_main!(ddp);
