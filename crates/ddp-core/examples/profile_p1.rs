//! Repeated cold solves of P1, for profilers (`valgrind --tool=callgrind`, `perf`).
//!
//! ```sh
//! cargo run --release -p ddp-core --example profile_p1 -- 2000
//! ```

use ddp_core::{reference, Settings, Solver};

fn main() -> ddp_core::Result<()> {
    let solves: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let problem = reference::p1_unicycle();
    let mut solver = Solver::new(&problem, Settings::default())?;
    let start = std::time::Instant::now();
    let mut iterations = 0;
    for _ in 0..solves {
        solver.reset();
        iterations += solver.solve(&problem)?.iterations;
    }
    let t = start.elapsed().as_secs_f64();
    println!(
        "{solves} solves, {:.1} µs per solve, {:.2} µs per iteration, cost {:.10}",
        t / solves as f64 * 1e6,
        t / iterations as f64 * 1e6,
        solver.report().cost
    );
    Ok(())
}
