//! Solves the unicycle (P1 of bench/problems.md) and the car with control limits by iLQR and
//! full DDP, printing the iteration tables.
//!
//! ```sh
//! cargo run --release -p ddp-core --example demo
//! ```

use ddp_core::{reference, Method, Problem, Settings, Solver};
use nalgebra::Const;

fn run<const NX: usize, const NU: usize>(title: &str, problem: &Problem<Const<NX>, Const<NU>>) -> ddp_core::Result<()> {
    for (label, method) in [("iLQR", Method::Ilqr), ("full DDP", Method::Ddp)] {
        let mut solver = Solver::new(
            problem,
            Settings {
                method,
                ..Settings::default()
            },
        )?;
        let report = solver.solve(problem)?.clone();
        println!("== {title}: {label}");
        print!("{}", report.table());
        let xn = solver.xs()[problem.horizon()];
        println!(
            "solve time: {:.1} µs ({:.2} µs per iteration), final state: {:?}\n",
            report.solve_time.as_secs_f64() * 1e6,
            report.solve_time.as_secs_f64() * 1e6 / report.iterations.max(1) as f64,
            xn.as_slice()
                .iter()
                .map(|v| (v * 1e4).round() / 1e4)
                .collect::<Vec<_>>()
        );
    }
    Ok(())
}

fn main() -> ddp_core::Result<()> {
    run("P1 unicycle (N = 100, x0 = (-1, -1, 1))", &reference::p1_unicycle())?;
    run(
        "car parking sideways with |w| <= 0.4, |a| <= 0.5 (N = 120)",
        &reference::car_parking(),
    )?;
    Ok(())
}
