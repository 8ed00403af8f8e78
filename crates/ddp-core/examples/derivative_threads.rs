//! Where `Settings::derivative_threads` pays: the derivative phase (dynamics Jacobians and cost
//! derivatives of every knot, `Solver::linearize`) and a whole iLQR solve, on 1 and 2 threads,
//! for the built-in quadrotor (12 states, 4 controls) and the floating base with a 2-link arm
//! (10 states, 5 controls) at N = 100 and N = 1000, and the quadrotor without its analytic
//! derivatives (central differences of its `step`, [`FiniteDiff`]: 32 steps per knot, the cost
//! of a model a user brings without derivatives), measured in one run (medians). Results are
//! checked bit-identical.
//!
//! `cargo build --release -p ddp-core --features parallel --example derivative_threads &&
//! $CARGO_TARGET_DIR/release/examples/derivative_threads`
use std::time::{Duration, Instant};

use ddp_core::dims::{Alloc, DefaultAllocator, Dim};
use std::sync::Arc;

use ddp_core::finite_diff::FiniteDiff;
use ddp_core::models::Quadrotor;
use ddp_core::reference::{arm_base_reach_horizon, quadrotor_reach_horizon, quadrotor_reach_with};
use ddp_core::{Problem, Settings, Solver};

fn median(mut v: Vec<Duration>) -> f64 {
    v.sort();
    v[v.len() / 2].as_secs_f64() * 1e6
}

/// Median time (us) of the derivative phase and of a whole solve, and the solve's cost.
fn measure<NX: Dim, NU: Dim>(problem: &Problem<NX, NU>, threads: usize) -> ddp_core::Result<(f64, f64, f64)>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    let settings = Settings {
        derivative_threads: threads,
        max_iterations: 50,
        ..Settings::default()
    };
    let mut solver = Solver::new(problem, settings)?;
    let reps_lin = if problem.horizon() >= 1000 { 400 } else { 3000 };
    let reps_solve = if problem.horizon() >= 1000 { 7 } else { 31 };
    let mut cost = 0.0;
    let mut t_solve = Vec::new();
    for _ in 0..reps_solve {
        solver.reset();
        let t = Instant::now();
        cost = solver.solve(problem)?.cost;
        t_solve.push(t.elapsed());
    }
    // The derivative phase at the solution (a trajectory with non-trivial Jacobians).
    let mut t_lin = Vec::new();
    for _ in 0..reps_lin {
        let t = Instant::now();
        solver.linearize(problem)?;
        t_lin.push(t.elapsed());
    }
    Ok((median(t_lin), median(t_solve), cost))
}

fn row<NX: Dim, NU: Dim>(name: &str, problem: &Problem<NX, NU>) -> ddp_core::Result<()>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    let (lin1, solve1, cost1) = measure(problem, 1)?;
    let (lin2, solve2, cost2) = measure(problem, 2)?;
    assert_eq!(cost1.to_bits(), cost2.to_bits(), "2 threads changed the result");
    println!(
        "| {name} | {} | {lin1:.1} | {lin2:.1} | {:.2}x | {:.0} | {:.0} | {:.2}x |",
        problem.horizon(),
        lin1 / lin2,
        solve1,
        solve2,
        solve1 / solve2
    );
    Ok(())
}

fn main() -> ddp_core::Result<()> {
    println!(
        "{} core(s) available; medians; derivatives = Solver::linearize, solve = iLQR from a cold start (at most 50 iterations)",
        std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)
    );
    println!("| model | N | derivatives 1 thread (us) | 2 threads (us) | ratio | solve 1 thread (us) | 2 threads (us) | ratio |");
    println!("|---|---|---|---|---|---|---|---|");
    for n in [100, 1000] {
        row("quadrotor (12, 4)", &quadrotor_reach_horizon(n))?;
        row("arm on floating base (10, 5)", &arm_base_reach_horizon(n))?;
        let fd = Arc::new(FiniteDiff::of_dynamics(Quadrotor::new(0.02)?));
        row("quadrotor, finite differences", &quadrotor_reach_with(fd, n))?;
    }
    Ok(())
}
