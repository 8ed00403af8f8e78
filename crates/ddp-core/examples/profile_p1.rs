//! Repeated cold solves of P1, for profilers (`valgrind --tool=callgrind`, `perf`), at the
//! compile-time size (default) or at run-time size (`dyn`: the same unicycle and costs through
//! [`ddp_core::runtime::RunTimeSize`], every matrix a heap-allocated `DMatrix`).
//!
//! ```sh
//! cargo run --release -p ddp-core --example profile_p1 -- 2000
//! cargo run --release -p ddp-core --example profile_p1 -- 2000 dyn
//! ```

use std::sync::Arc;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::dims::{Alloc, DefaultAllocator, Dim, Dyn, U2, U3};
use ddp_core::models::Unicycle;
use ddp_core::runtime::{RunTimeSize, RunTimeTerminal};
use ddp_core::{reference, Problem, Settings, Solver};

fn run<NX: Dim, NU: Dim>(problem: &Problem<NX, NU>, solves: usize, label: &str) -> ddp_core::Result<()>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    let mut solver = Solver::new(problem, Settings::default())?;
    let start = std::time::Instant::now();
    let mut iterations = 0;
    for _ in 0..solves {
        solver.reset();
        iterations += solver.solve(problem)?.iterations;
    }
    let t = start.elapsed().as_secs_f64();
    println!(
        "{label}: {solves} solves, {:.1} µs per solve, {:.2} µs per iteration, cost {:.10}",
        t / solves as f64 * 1e6,
        t / iterations as f64 * 1e6,
        solver.report().cost
    );
    Ok(())
}

fn main() -> ddp_core::Result<()> {
    let mut args = std::env::args().skip(1);
    let solves: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1000);
    let problem = reference::p1_unicycle();
    if args.next().as_deref() == Some("dyn") {
        let dynamic = Problem::<Dyn, Dyn>::new(
            nalgebra::DVector::from_column_slice(problem.x0().as_slice()),
            Arc::new(RunTimeSize::<_, 3, 2>::new(Unicycle::new(0.1)?)),
            Arc::new(RunTimeSize::<_, 3, 2>::new(QuadraticCost::<U3, U2>::weighted_norms(
                10.0, 1.0,
            )?)),
            Arc::new(RunTimeTerminal::<_, 3>(QuadraticTerminal::<U3>::diagonal(
                &[100.0; 3],
                ddp_core::Vector::zeros(),
            )?)),
            problem.horizon(),
        )?;
        run(&dynamic, solves, "run-time size")
    } else {
        run(&problem, solves, "compile-time size")
    }
}
