//! Repeated solves allocate nothing: every buffer lives in the solver workspace, allocated by
//! `SafeCddpSolver::new`. The one exception is Clarabel, which allocates inside its own `solve`
//! (timers): P3 never needs it and must allocate nothing; elsewhere at most a few allocations per
//! QP handed to Clarabel are allowed. (One test in this binary, so no other test thread allocates
//! while counting.)

use ddp_core::dims::{U2, U4};
use std::sync::Arc;

use ddp_core::{Matrix, Vector};
use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::constraints::Circle;
use safe_cddp::{Constraint, SafeCddpSolver, Settings, Tightening, WarmUp};

fn count(f: impl FnOnce()) -> u64 {
    allocation_counter::measure(f).count_total
}

fn problems_dir() -> std::path::PathBuf {
    // Relative to the package root, where cargo runs tests.
    std::path::PathBuf::from("../../bench/problems")
}

#[test]
fn repeated_solves_tightenings_and_mpc_steps_allocate_nothing() {
    // P3 (point robot, three discs): cold solves, again and again, with every warm-up.
    let p3 = BenchmarkProblem::from_file(problems_dir().join("p3_point4.json")).unwrap();
    let (problem, constraints) = p3.car_or_point().unwrap();
    for warm_up in [WarmUp::AugmentedLagrangian, WarmUp::Barrier, WarmUp::Portfolio] {
        let settings = Settings {
            warm_up,
            ..Settings::default()
        };
        let mut solver = SafeCddpSolver::new(&problem, constraints.clone(), settings).unwrap();
        solver.solve(&problem).unwrap();
        let mut clarabel = 0;
        let n = count(|| {
            for _ in 0..3 {
                solver.reset();
                clarabel += solver.solve(&problem).unwrap().qp.clarabel_solves();
            }
        });
        assert!(
            n <= 4 * clarabel as u64,
            "P3, {warm_up:?}: repeated cold solves allocated {n} times with {clarabel} QPs handed to Clarabel"
        );
    }
    let mut solver = SafeCddpSolver::new(&problem, constraints, Settings::default()).unwrap();

    // The same with chance-constraint tightening (eqs. 19-20, bounds-only gains) and a
    // shrinking-horizon MPC loop: shift, shorter horizon, new x0, iterations and tightenings.
    let sigma_w = Matrix::<4, 4>::from_diagonal(&Vector::<4>::new(1e-5, 1e-5, 4e-5, 4e-5));
    solver
        .set_tightening(Some(Tightening::new(0.95, sigma_w).unwrap()))
        .unwrap();
    let mut mpc_problem = problem.clone();
    solver.reset();
    solver.solve(&mpc_problem).unwrap();
    let mut clarabel = 0;
    let n = count(|| {
        let horizon = mpc_problem.horizon();
        for step in 0..20 {
            let x = solver.xs()[1] + Vector::<4>::repeat(1e-3 * ((step % 3) as f64 - 1.0));
            mpc_problem.set_x0(x).unwrap();
            solver.shift();
            solver.set_horizon(horizon - step - 1).unwrap();
            solver.start(&mpc_problem).unwrap();
            for i in 0..10 {
                solver.iterate(&mpc_problem).unwrap();
                if i % 5 == 0 {
                    solver.tighten(&mpc_problem).unwrap();
                }
            }
            clarabel += solver.qp_stats().clarabel_solves();
        }
    });
    // Clarabel allocates a couple of times per solve (its timers); nothing else may.
    assert!(
        n <= 4 * clarabel as u64,
        "MPC steps allocated {n} times with {clarabel} QPs handed to Clarabel"
    );

    // A car among two discs (relative degree 2), repeated warm solves after a tightening.
    let p2 = BenchmarkProblem::from_file(problems_dir().join("p2_car4.json")).unwrap();
    let (problem, _) = p2.car_or_point().unwrap();
    let discs: Vec<Arc<dyn Constraint<U4, U2>>> = vec![
        Arc::new(Circle::squared([1.3, 0.25], 0.3, [0, 1]).unwrap()),
        Arc::new(Circle::squared([2.7, -0.25], 0.3, [0, 1]).unwrap()),
    ];
    let mut solver = SafeCddpSolver::new(&problem, discs, Settings::default()).unwrap();
    solver
        .set_tightening(Some(Tightening::new(0.99, sigma_w).unwrap()))
        .unwrap();
    solver.solve(&problem).unwrap();
    let mut clarabel = 0;
    let n = count(|| {
        for _ in 0..3 {
            clarabel += solver.solve(&problem).unwrap().qp.clarabel_solves();
        }
    });
    assert!(
        n <= 4 * clarabel as u64,
        "car: repeated solves allocated {n} times with {clarabel} QPs handed to Clarabel"
    );
}
