//! Safe-CDDP and ddp-core are one DDP core: without constraints and bounds, `SafeCddpSolver`
//! runs the same iterations as `Solver`, for iLQR and for full DDP (second-order dynamics, with
//! the same gated fallback), at compile-time and at run-time sizes.

use std::sync::Arc;

use ddp_core::dims::Dyn;
use ddp_core::runtime::{RunTimeSize, RunTimeTerminal};
use ddp_core::{reference, Method, Problem, Settings, Solver, Tolerances};
use nalgebra::{Const, Dim};
use safe_cddp::SafeCddpSolver;

fn safe_settings(method: Method) -> safe_cddp::Settings {
    // The same stopping tests as ddp-core's defaults, so both stop at the same iteration.
    safe_cddp::Settings {
        method,
        tolerances: Tolerances::default(),
        ..safe_cddp::Settings::default()
    }
}

/// Solves `problem` with both solvers and compares the accepted iterations' costs and the final
/// trajectories.
fn assert_parity<NX: Dim, NU: Dim>(problem: &Problem<NX, NU>, method: Method, label: &str)
where
    nalgebra::DefaultAllocator: ddp_core::dims::Alloc<NX, NU>,
{
    let mut ddp = Solver::new(
        problem,
        Settings {
            method,
            ..Settings::default()
        },
    )
    .unwrap();
    let r = ddp.solve(problem).unwrap().clone();
    let mut safe = SafeCddpSolver::new(problem, vec![], safe_settings(method)).unwrap();
    let s = safe.solve(problem).unwrap().clone();
    assert_eq!(r.status.as_str(), "converged", "{label}: ddp-core {}", r.table());
    assert_eq!(s.status.as_str(), "converged", "{label}: safe-cddp {}", s.table());
    let costs = |log: Vec<(f64, bool)>| log.into_iter().filter(|x| x.1).map(|x| x.0).collect::<Vec<_>>();
    let a = costs(r.log.iter().map(|l| (l.cost, l.accepted)).collect());
    let b = costs(s.log.iter().map(|l| (l.cost, l.accepted)).collect());
    assert_eq!(
        a.len(),
        b.len(),
        "{label}: accepted iterations\n{}\n{}",
        r.table(),
        s.table()
    );
    for (k, (x, y)) in a.iter().zip(&b).enumerate() {
        assert!(
            (x - y).abs() <= 1e-9 * (1.0 + x.abs()),
            "{label}: iteration {k}: {x} vs {y}"
        );
    }
    assert_eq!(r.backward_passes > 0, s.backward_passes > 0);
    for (x, y) in ddp.xs().iter().zip(safe.xs()) {
        assert!((x - y).amax() < 1e-8, "{label}: states differ");
    }
    for (x, y) in ddp.us().iter().zip(safe.us()) {
        assert!((x - y).amax() < 1e-8, "{label}: controls differ");
    }
    for (x, y) in ddp.gains().iter().zip(safe.gains()) {
        assert!((x - y).amax() < 1e-6 * (1.0 + x.amax()), "{label}: gains differ");
    }
}

#[test]
fn ilqr_and_full_ddp_agree_on_the_unicycle() {
    let p1 = reference::p1_unicycle();
    assert_parity(&p1, Method::Ilqr, "P1 iLQR");
    assert_parity(&p1, Method::Ddp, "P1 full DDP");
}

#[test]
fn full_ddp_agrees_on_models_with_second_order_terms() {
    // The arm on a floating base and the quadrotor have contracted second derivatives; full DDP
    // exercises the gated fallback far from the optimum.
    assert_parity(&reference::arm_base_reach(), Method::Ddp, "arm base full DDP");
    assert_parity(&reference::quadrotor_reach(), Method::Ddp, "quadrotor full DDP");
    assert_parity(&reference::arm_base_reach(), Method::Ilqr, "arm base iLQR");
}

#[test]
fn parity_holds_at_run_time_size() {
    // P1 with the unicycle wrapped to run-time size and run-time-size quadratic costs.
    let p1 = reference::p1_unicycle();
    let dynamics = Arc::new(RunTimeSize::<_, 3, 2>::new(
        ddp_core::models::Unicycle::new(0.1).unwrap(),
    ));
    let running = Arc::new(RunTimeSize::<_, 3, 2>::new(
        ddp_core::costs::QuadraticCost::<Const<3>, Const<2>>::weighted_norms(10.0, 1.0).unwrap(),
    ));
    let terminal = Arc::new(RunTimeTerminal::<_, 3>(
        ddp_core::costs::QuadraticTerminal::<Const<3>>::diagonal(&[100.0; 3], ddp_core::Vector::zeros()).unwrap(),
    ));
    let x0 = nalgebra::DVector::from_column_slice(p1.x0().as_slice());
    let dyn_p1 = Problem::<Dyn, Dyn>::new(x0, dynamics, running, terminal, p1.horizon()).unwrap();
    assert_parity(&dyn_p1, Method::Ilqr, "P1 iLQR at run-time size");
    assert_parity(&dyn_p1, Method::Ddp, "P1 full DDP at run-time size");
}
