//! Receding horizon: after `shift` and a new `x0`, a warm-started solve reaches the same optimum
//! as a cold solve of the same problem, in fewer iterations.

use ddp_core::{reference, Method, Problem, Settings, Solver, Status};
use nalgebra::Const;

fn check<const NX: usize, const NU: usize>(name: &str, mut problem: Problem<Const<NX>, Const<NU>>, method: Method) {
    let settings = Settings {
        method,
        ..Settings::default()
    };
    let mut warm = Solver::new(&problem, settings).unwrap();
    assert_eq!(warm.solve(&problem).unwrap().status, Status::Converged, "{name}");
    // Move to the predicted next state, as an MPC step without noise would.
    let x1 = warm.xs()[1];
    problem.set_x0(x1).unwrap();
    warm.shift();
    let warm_report = warm.solve(&problem).unwrap().clone();

    let mut cold = Solver::new(&problem, settings).unwrap();
    let cold_report = cold.solve(&problem).unwrap().clone();
    assert_eq!(
        warm_report.status,
        Status::Converged,
        "{name} warm:\n{}",
        warm_report.table()
    );
    assert_eq!(
        cold_report.status,
        Status::Converged,
        "{name} cold:\n{}",
        cold_report.table()
    );
    let rel = (warm_report.cost - cold_report.cost).abs() / cold_report.cost.abs().max(1e-12);
    assert!(
        rel < 1e-7,
        "{name}: warm cost {} vs cold {}",
        warm_report.cost,
        cold_report.cost
    );
    for (k, (a, b)) in warm.us().iter().zip(cold.us()).enumerate() {
        assert!((a - b).amax() < 1e-3, "{name}: u[{k}] warm {a:?} cold {b:?}");
    }
    assert!(
        warm_report.iterations < cold_report.iterations,
        "{name}: warm start took {} iterations, cold {}",
        warm_report.iterations,
        cold_report.iterations
    );
}

#[test]
fn shifted_warm_start_equals_fresh_solve() {
    for method in [Method::Ilqr, Method::Ddp] {
        check("p1_unicycle", reference::p1_unicycle(), method);
        check("car_parking", reference::car_parking(), method);
        check("quadrotor_reach", reference::quadrotor_reach(), method);
    }
}
