//! Solves P2 and P3 of `bench/problems.md` and prints cost, violation, iterations and time.
use std::time::Instant;

use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::{SafeCddpSolver, Settings, WarmUp};

fn main() -> ddp_core::Result<()> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| "bench/problems".into());
    for (file, peer) in [("p2_car4.json", 1.1972797), ("p3_point4.json", 1.8958999)] {
        for warm_up in [WarmUp::Portfolio, WarmUp::Barrier, WarmUp::AugmentedLagrangian] {
            let p = BenchmarkProblem::from_file(format!("{dir}/{file}"))?;
            let (problem, constraints) = p.car_or_point()?;
            let mut settings = Settings {
                warm_up,
                ..Settings::default()
            };
            // FLIP=0: no flipped starts (`Settings::portfolio_flip`).
            if let Some(f) = std::env::var("FLIP").ok().and_then(|v| v.parse::<f64>().ok()) {
                settings.portfolio_flip = (f > 0.0).then_some(f);
            }
            let mut solver = SafeCddpSolver::new(&problem, constraints, settings)?;
            let report = solver.solve(&problem)?;
            if std::env::var("TABLE").is_ok() {
                println!("{}", report.table());
            }
            let reps = 20;
            let t = Instant::now();
            for _ in 0..reps {
                solver.reset();
                solver.solve(&problem)?;
            }
            let r = solver.report();
            println!(
            "{file} {}: cost {:.10} (peer {peer}, rel {:.2e}), violation {:.2e}, iterations {}, {:?}, {:.3} ms/solve, qp {:?}",
            warm_up.as_str(),
            r.cost,
            (r.cost - peer) / peer,
            r.max_violation,
            r.iterations,
            r.status,
            t.elapsed().as_secs_f64() * 1e3 / reps as f64,
            r.qp
        );
        }
    }
    Ok(())
}
