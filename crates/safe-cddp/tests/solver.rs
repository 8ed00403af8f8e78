//! The constrained solver: agreement with ddp-core without constraints, the benchmark problems
//! P2 and P3 against the peers' optima, and statuses.

use ddp_core::dims::{U2, U3, U4};
use std::sync::Arc;

use ddp_core::{reference, Settings as DdpSettings, Solver, Vector};
use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::constraints::Circle;
use safe_cddp::qp::QpMethod;
use safe_cddp::{Constraint, SafeCddpSolver, Settings, Status};

fn problems_dir() -> std::path::PathBuf {
    // Relative to the package root, where cargo runs tests.
    std::path::PathBuf::from("../../bench/problems")
}

#[test]
fn without_constraints_equals_ddp_core() {
    // P1 (no bounds, no constraints): the same iLQR iterations as ddp-core's solver.
    let problem = reference::p1_unicycle();
    let mut reference_solver = Solver::new(&problem, DdpSettings::default()).unwrap();
    let r = reference_solver.solve(&problem).unwrap().clone();
    let mut solver = SafeCddpSolver::new(&problem, vec![], Settings::default()).unwrap();
    let ours = solver.solve(&problem).unwrap();
    assert_eq!(ours.status, Status::Converged);
    assert!(
        (ours.cost - r.cost).abs() < 1e-8 * (1.0 + r.cost.abs()),
        "{} vs {}",
        ours.cost,
        r.cost
    );
    for (a, b) in solver.xs().iter().zip(reference_solver.xs()) {
        assert!((a - b).amax() < 1e-8);
    }
    for (a, b) in solver.us().iter().zip(reference_solver.us()) {
        assert!((a - b).amax() < 1e-8);
    }
}

#[test]
fn inactive_obstacle_changes_nothing() {
    // An obstacle far from the path: the constrained solve equals the unconstrained one.
    let problem = reference::p1_unicycle();
    let mut plain = SafeCddpSolver::new(&problem, vec![], Settings::default()).unwrap();
    let cost = plain.solve(&problem).unwrap().cost;
    let far: Arc<dyn Constraint<U3, U2>> = Arc::new(Circle::squared([10.0, 10.0], 1.0, [0, 1]).unwrap());
    let mut solver = SafeCddpSolver::new(&problem, vec![far], Settings::default()).unwrap();
    let r = solver.solve(&problem).unwrap();
    assert_eq!(r.status, Status::Converged);
    assert!((r.cost - cost).abs() < 1e-8 * (1.0 + cost));
    for (a, b) in solver.xs().iter().zip(plain.xs()) {
        assert!((a - b).amax() < 1e-8);
    }
}

fn solve_benchmark(file: &str, method: QpMethod) -> (f64, f64, Status) {
    let p = BenchmarkProblem::from_file(problems_dir().join(file)).unwrap();
    let (problem, constraints) = p.car_or_point().unwrap();
    let settings = Settings {
        qp_method: method,
        ..Settings::default()
    };
    let mut solver = SafeCddpSolver::new(&problem, constraints, settings).unwrap();
    let r = solver.solve(&problem).unwrap();
    (r.cost, r.max_violation, r.status)
}

#[test]
fn p2_car_reaches_the_peers_optimum() {
    let (cost, violation, status) = solve_benchmark("p2_car4.json", QpMethod::Fast);
    assert_eq!(status, Status::Converged);
    assert!(cost <= 1.1972797 * (1.0 + 1e-6), "cost {cost}");
    assert!(violation <= 1e-6, "violation {violation}");
}

#[test]
fn p3_point_reaches_the_peers_optimum() {
    for method in [QpMethod::Fast, QpMethod::Clarabel] {
        let (cost, violation, status) = solve_benchmark("p3_point4.json", method);
        assert_eq!(status, Status::Converged, "{method:?}");
        assert!(cost <= 1.8958999 * (1.0 + 1e-6), "{method:?}: cost {cost}");
        assert!(violation <= 1e-6, "{method:?}: violation {violation}");
    }
}

#[test]
fn a_start_inside_an_obstacle_is_reported_infeasible() {
    // x0 inside a circle that no control can leave in one step: the state at t = 1 violates.
    let mut problem = reference::point_reach();
    problem.set_x0(Vector::<4>::new(1.0, 1.0, 0.0, 0.0)).unwrap();
    let trap: Arc<dyn Constraint<U4, U2>> = Arc::new(Circle::squared([1.0, 1.0], 2.0, [0, 1]).unwrap());
    let settings = Settings {
        max_iterations: 30,
        ..Settings::default()
    };
    let mut solver = SafeCddpSolver::new(&problem, vec![trap], settings).unwrap();
    let r = solver.solve(&problem).unwrap();
    assert!(matches!(r.status, Status::Infeasible { .. }), "{:?}", r.status);
    assert!(r.max_violation > 0.0);
}

#[test]
fn bad_settings_and_shapes_are_errors() {
    let problem = reference::point_reach();
    let e = SafeCddpSolver::new(
        &problem,
        vec![],
        Settings {
            trust_shrink: 2.0,
            ..Settings::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("settings.trust_shrink"), "{e}");
    // The augmented Lagrangian's inner-solve and near-row settings.
    let d = Settings::default;
    for (name, settings) in [
        (
            "settings.al_inner_progress",
            Settings {
                al_inner_progress: -1.0,
                ..d()
            },
        ),
        (
            "settings.al_inner_progress_below",
            Settings {
                al_inner_progress_below: f64::NAN,
                ..d()
            },
        ),
        (
            "settings.al_near_margin",
            Settings {
                al_near_margin: f64::NAN,
                ..d()
            },
        ),
        (
            "settings.al_near_rho",
            Settings {
                al_near_rho: 0.0,
                ..d()
            },
        ),
    ] {
        let e = SafeCddpSolver::new(&problem, vec![], settings).unwrap_err().to_string();
        assert!(e.contains(name), "{e}");
    }
    let mut solver = SafeCddpSolver::new(&problem, vec![], Settings::default()).unwrap();
    let e = solver.set_controls(&[Vector::<2>::zeros(); 3]).unwrap_err().to_string();
    assert!(e.contains("us"), "{e}");
    let e = solver.set_horizon(0).unwrap_err().to_string();
    assert!(e.contains("horizon"), "{e}");
    let e = BenchmarkProblem::from_json(r#"{"name": "x", "model": "car", "N": 10}"#)
        .unwrap_err()
        .to_string();
    assert!(e.contains("dt") || e.contains("missing field"), "{e}");
}

/// Problem 65 of the point family, seed 1 (`bench/results/family_s1_210.json`), whose optimum
/// FATROP found at 0.155665931.
const POINT_S1_I65: &str = r#"{"name": "point-s1-i65-a0", "model": "point", "dt": 0.0827, "N": 98, "x0": [0.0, 0.0, 0.0, 0.0], "cost": {"kind": "quad_goal", "x_goal": [2.6372, 0.0135, 0.0, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "u_min": [-0.5071, -1.0047], "u_max": [0.5071, 1.0047], "obstacles": [[1.796, 0.2201, 0.3006], [1.2012, 0.005, 0.4724], [1.7618, -0.2923, 0.4881], [1.1456, -0.023, 0.3288]]}"#;

#[test]
fn rows_with_positive_multipliers_stay_active_at_the_hand_over() {
    // The augmented Lagrangian handed over with three contact rows 1e-6 to 6e-6 inside their
    // boundary (beyond the active threshold) but with positive multipliers; the KKT/QP
    // iterations dropped them, their first step ran into the obstacles and was rejected, and
    // the solve ended at the warm-up's point, 8.3e-6 above the optimum. That hand-over comes
    // from the barrier start without its funnel (`Settings::barrier_funnel`; its obstacles
    // overlap, and with the funnel the portfolio keeps a neighbouring optimum 8.5e-5 above
    // FATROP's instead), and with the inner solves ended only by the merit's relative change
    // (`Settings::al_inner_progress` 0; with it the augmented Lagrangian reaches another
    // hand-over) and no curvature for rows near their boundary (`al_near_margin` 0).
    let bp = BenchmarkProblem::from_json(POINT_S1_I65).unwrap();
    let (problem, constraints) = bp.car_or_point().unwrap();
    let settings = Settings {
        barrier_funnel: f64::INFINITY,
        al_inner_progress: 0.0,
        al_near_margin: 0.0,
        ..Settings::default()
    };
    let mut solver = SafeCddpSolver::new(&problem, constraints, settings).unwrap();
    let r = solver.solve(&problem).unwrap();
    assert_eq!(r.status, Status::Converged);
    assert!(r.max_violation <= 1e-8, "violation {}", r.max_violation);
    let fatrop = 0.15566593142679913;
    assert!(r.cost <= fatrop * (1.0 + 1e-6), "cost {} against {fatrop}", r.cost);
}

#[test]
fn full_ddp_takes_gauss_newton_passes_in_the_barrier_homotopy() {
    // P2's car has second-order dynamics terms; under full DDP its barrier subproblems still
    // take Gauss-Newton passes, so the homotopy's iterations are iLQR's to the bit, and full
    // DDP's own iterations begin at the hand-over.
    let p = BenchmarkProblem::from_file(problems_dir().join("p2_car4.json")).unwrap();
    let (problem, constraints) = p.car_or_point().unwrap();
    assert!(problem.knots()[0].dynamics.has_second_order());
    let solve = |method| {
        let settings = Settings {
            method,
            warm_up: safe_cddp::WarmUp::Barrier,
            ..Settings::default()
        };
        let mut solver = SafeCddpSolver::new(&problem, constraints.clone(), settings).unwrap();
        solver.solve(&problem).unwrap().clone()
    };
    let (gn, ddp) = (solve(ddp_core::Method::Ilqr), solve(ddp_core::Method::Ddp));
    let homotopy = |r: &safe_cddp::Report| -> Vec<(u64, u64, u64)> {
        r.log
            .iter()
            .filter(|l| l.warm_up == Some(safe_cddp::WarmUp::Barrier))
            .map(|l| (l.cost.to_bits(), l.step.to_bits(), l.mu.to_bits()))
            .collect()
    };
    assert!(homotopy(&gn).len() >= 5, "{} homotopy iterations", homotopy(&gn).len());
    assert_eq!(homotopy(&gn), homotopy(&ddp));
    assert_eq!(ddp.status, Status::Converged);
    assert!(ddp.cost <= 1.1972797 * (1.0 + 1e-6), "cost {}", ddp.cost);
    assert!(ddp.max_violation <= 1e-6, "violation {}", ddp.max_violation);
}
