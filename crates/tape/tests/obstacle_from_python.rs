//! The planar quadrotor past a circular obstacle, its four models CasADi-imported in Python and
//! saved (`tests/data/quadrotor_obstacle/`), solved by `SafeCddpSolver` in Rust at run-time
//! sizes: the optimum IPOPT and FATROP are compared with in `bench/peers/traced.py`.
use std::sync::Arc;

use ddp_core::Method;
use safe_cddp::{SafeCddpSolver, Settings, Status};

#[path = "common/quadrotor_obstacle.rs"]
mod quadrotor_obstacle;

/// FATROP's cost on the same discrete problem (`bench/results/traced.json`), the better peer's.
const FATROP: f64 = 0.120964;

fn solve(settings: Settings) -> safe_cddp::Report {
    let (problem, obstacle, guess) = quadrotor_obstacle::quadrotor_obstacle().unwrap();
    let mut solver = SafeCddpSolver::new(&problem, vec![Arc::new(obstacle)], settings).unwrap();
    solver.set_controls(&guess).unwrap();
    solver.solve(&problem).unwrap().clone()
}

#[test]
fn the_saved_quadrotor_passes_the_obstacle_at_the_peers_optimum_or_below() {
    let ddp = Settings {
        method: Method::Ddp,
        max_iterations: 500,
        ..Settings::default()
    };
    let r = solve(ddp);
    assert_eq!(r.status, Status::Converged);
    assert!(r.max_violation <= 1e-6, "violation {}", r.max_violation);
    assert!(r.cost <= FATROP, "cost {}", r.cost);
    // Its two starts agree, so no extra start runs: the augmented Lagrangian's 27 iterations
    // are kept, the barrier start's 40 discarded.
    assert!(
        r.iterations + r.discarded_iterations <= 80,
        "{} + {}",
        r.iterations,
        r.discarded_iterations
    );
    // One obstacle: the barrier's funnel (which counts knots inside two obstacles at once)
    // never acts, and the solve is the same without it, bit for bit.
    let open = solve(Settings {
        barrier_funnel: f64::INFINITY,
        ..ddp
    });
    assert_eq!(open.cost.to_bits(), r.cost.to_bits());
    assert_eq!(
        (open.iterations, open.discarded_iterations),
        (r.iterations, r.discarded_iterations)
    );
}
