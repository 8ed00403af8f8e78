//! The planar quadrotor past a circular obstacle of `bench/peers/traced.py`, as four models
//! CasADi-imported in Python and saved (`Dynamics.from_casadi(F).save(...)` and so on), solved by
//! `SafeCddpSolver` at run-time sizes in Rust: the solve the Python module runs, without Python.
//! A development loop for the constrained warm-ups on a traced model.
//!
//! ```text
//! cargo run --release -p ddp-tape --example obstacle_from_python -- [portfolio|barrier|al] [repeats]
//! ```
//!
//! Environment: `FUNNEL` sets `Settings::barrier_funnel` (`inf`: none), `TABLE=1` prints the
//! iteration table.
use std::sync::Arc;
use std::time::Instant;

use safe_cddp::{SafeCddpSolver, Settings, WarmUp};

#[path = "../tests/common/quadrotor_obstacle.rs"]
mod quadrotor_obstacle;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    // Full DDP, as `traced.py` runs it (`method="ddp"`).
    let mut settings = Settings {
        method: ddp_core::Method::Ddp,
        max_iterations: 500,
        ..Settings::default()
    };
    settings.warm_up = match args.get(1).map(String::as_str).unwrap_or("portfolio") {
        "portfolio" => WarmUp::Portfolio,
        "barrier" => WarmUp::Barrier,
        "al" => WarmUp::AugmentedLagrangian,
        other => return Err(format!("unknown warm-up {other}").into()),
    };
    if let Some(f) = std::env::var("FUNNEL").ok().and_then(|v| v.parse().ok()) {
        settings.barrier_funnel = f;
    }
    let repeats: usize = args.get(2).map(|r| r.parse()).transpose()?.unwrap_or(20);
    let (problem, obstacle, guess) = quadrotor_obstacle::quadrotor_obstacle()?;
    let mut solver = SafeCddpSolver::new(&problem, vec![Arc::new(obstacle)], settings)?;
    let mut times = Vec::with_capacity(repeats);
    for _ in 0..repeats.max(1) {
        solver.reset();
        solver.set_controls(&guess)?;
        let t = Instant::now();
        solver.solve(&problem)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let r = solver.report();
    if std::env::var("TABLE").is_ok() {
        println!("{}", r.table());
    }
    println!(
        "{:?}: {} + {} iterations, cost {:.10}, violation {:.1e}, {:.3} ms (median of {})",
        r.status,
        r.iterations,
        r.discarded_iterations,
        r.cost,
        r.max_violation,
        times[times.len() / 2],
        times.len()
    );
    Ok(())
}
