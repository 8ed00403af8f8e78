//! Every solver at sizes known only at run time: LQ problems equal the discrete Riccati
//! solution; a compile-time-size problem and the same problem at run-time size give the same
//! iterations (one algorithm text serves both); bad sizes are errors naming the argument.

use std::sync::Arc;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::dims::{Dyn, VectorN, MAX_STATES};
use ddp_core::linear::LinearDynamics;
use ddp_core::runtime::{RunTimeSize, RunTimeTerminal};
use ddp_core::{reference, ControlBounds, Method, Problem, Regularization, RegularizationSettings, Settings, Solver};
use ddpkit_tests::{riccati, Lcg};
use nalgebra::{Const, DMatrix, DVector};
use safe_cddp::constraints::{Circle, StateBox};
use safe_cddp::mpc::{Mpc, MpcSettings};
use safe_cddp::{Constraint, SafeCddpSolver, Tightening};

struct Lq {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    q: DMatrix<f64>,
    r: DMatrix<f64>,
    qf: DMatrix<f64>,
    x0: DVector<f64>,
}

fn lq(nx: usize, nu: usize, seed: u64) -> Lq {
    let mut g = Lcg(seed);
    // A near the identity (a discretised stable-ish system), B full.
    let a = DMatrix::<f64>::identity(nx, nx) + g.matrix(nx, nx, 0.3 / nx as f64);
    let b = g.matrix(nx, nu, 0.5);
    let m = g.matrix(nx, nx, 1.0);
    let q = &m * m.transpose() / nx as f64 + DMatrix::identity(nx, nx) * 0.1;
    let mr = g.matrix(nu, nu, 1.0);
    let r = &mr * mr.transpose() / nu as f64 + DMatrix::identity(nu, nu) * 0.5;
    let qf = q.clone() * 10.0;
    let x0 = DVector::from_fn(nx, |_, _| g.next_f64());
    Lq { a, b, q, r, qf, x0 }
}

fn lq_problem(p: &Lq, n: usize) -> Problem<Dyn, Dyn> {
    let (nx, nu) = (p.a.nrows(), p.b.ncols());
    Problem::new(
        p.x0.clone(),
        Arc::new(LinearDynamics::new(p.a.clone(), p.b.clone(), DVector::zeros(nx)).unwrap()),
        Arc::new(QuadraticCost::new(p.q.clone(), p.r.clone(), DVector::zeros(nx), DVector::zeros(nu)).unwrap()),
        Arc::new(QuadraticTerminal::new(p.qf.clone(), DVector::zeros(nx)).unwrap()),
        n,
    )
    .unwrap()
}

#[test]
fn lq_problems_of_run_time_sizes_equal_riccati() {
    for (nx, nu) in [(7, 3), (30, 10), (64, 32)] {
        let p = lq(nx, nu, 7 + nx as u64);
        let n = 40;
        let problem = lq_problem(&p, n);
        let (gains, xs, us) = riccati(&p.a, &p.b, &p.q, &p.r, &p.qf, &p.x0, n);
        for (method, placement) in [
            (Method::Ilqr, Regularization::Control),
            (Method::Ddp, Regularization::Control),
            (Method::Ilqr, Regularization::State),
        ] {
            let settings = Settings {
                method,
                regularization: RegularizationSettings {
                    placement,
                    ..Default::default()
                },
                ..Settings::default()
            };
            let mut solver = Solver::new(&problem, settings).unwrap();
            let report = solver.solve(&problem).unwrap();
            assert_eq!(report.status.as_str(), "converged", "({nx}, {nu}) {method:?}");
            for k in 0..n {
                assert!((&solver.gains()[k] - &gains[k]).amax() < 1e-9, "({nx}, {nu}) gain {k}");
                assert!((&solver.us()[k] - &us[k]).amax() < 1e-9, "({nx}, {nu}) u {k}");
                assert!((&solver.xs()[k + 1] - &xs[k + 1]).amax() < 1e-9, "({nx}, {nu}) x {k}");
            }
        }
        // Safe-CDDP without constraints is the same DDP.
        let mut safe = SafeCddpSolver::new(&problem, vec![], safe_cddp::Settings::default()).unwrap();
        safe.solve(&problem).unwrap();
        for k in 0..n {
            assert!((&safe.us()[k] - &us[k]).amax() < 1e-9, "safe ({nx}, {nu}) u {k}");
        }
    }
}

/// P1 at run-time size: the unicycle and its costs wrapped by `RunTimeSize`.
fn p1_at_run_time_size() -> Problem<Dyn, Dyn> {
    let p1 = reference::p1_unicycle();
    Problem::new(
        DVector::from_column_slice(p1.x0().as_slice()),
        Arc::new(RunTimeSize::<_, 3, 2>::new(
            ddp_core::models::Unicycle::new(0.1).unwrap(),
        )),
        Arc::new(RunTimeSize::<_, 3, 2>::new(
            QuadraticCost::<Const<3>, Const<2>>::weighted_norms(10.0, 1.0).unwrap(),
        )),
        Arc::new(RunTimeTerminal::<_, 3>(
            QuadraticTerminal::<Const<3>>::diagonal(&[100.0; 3], ddp_core::Vector::zeros()).unwrap(),
        )),
        p1.horizon(),
    )
    .unwrap()
}

#[test]
fn compile_time_and_run_time_sizes_run_the_same_iterations() {
    // One algorithm text: the same kernels in the same order, so the iteration tables agree
    // to the last printed digit.
    let fixed = reference::p1_unicycle();
    let dynamic = p1_at_run_time_size();
    for method in [Method::Ilqr, Method::Ddp] {
        let settings = Settings {
            method,
            ..Settings::default()
        };
        let a = Solver::new(&fixed, settings).unwrap().solve(&fixed).unwrap().table();
        let b = Solver::new(&dynamic, settings)
            .unwrap()
            .solve(&dynamic)
            .unwrap()
            .table();
        assert_eq!(a, b, "{method:?}");
    }
    // Box-DDP: the car with control bounds.
    let car = reference::car_parking();
    let bounds = car.bounds().unwrap().clone();
    let goal = ddp_core::Vector::<4>::new(2.0, 1.0, 0.0, 0.0);
    let dyn_car = Problem::<Dyn, Dyn>::new(
        DVector::zeros(4),
        Arc::new(RunTimeSize::<_, 4, 2>::new(ddp_core::models::Car::new(0.05).unwrap())),
        Arc::new(
            QuadraticCost::<Dyn, Dyn>::diagonal(&[0.0; 4], &[0.1, 0.1], DVector::zeros(4), DVector::zeros(2)).unwrap(),
        ),
        Arc::new(
            QuadraticTerminal::<Dyn>::diagonal(
                &[100.0, 100.0, 10.0, 10.0],
                DVector::from_column_slice(goal.as_slice()),
            )
            .unwrap(),
        ),
        car.horizon(),
    )
    .unwrap()
    .with_control_bounds(
        ControlBounds::new(
            DVector::from_column_slice(bounds.lower.as_slice()),
            DVector::from_column_slice(bounds.upper.as_slice()),
        )
        .unwrap(),
    )
    .unwrap();
    let a = Solver::new(&car, Settings::default())
        .unwrap()
        .solve(&car)
        .unwrap()
        .clone();
    let b = Solver::new(&dyn_car, Settings::default())
        .unwrap()
        .solve(&dyn_car)
        .unwrap()
        .clone();
    assert_eq!(a.status, b.status);
    assert!(
        (a.cost - b.cost).abs() < 1e-9 * (1.0 + a.cost),
        "{} vs {}",
        a.cost,
        b.cost
    );
}

#[test]
fn safe_cddp_and_mpc_at_run_time_size_match_compile_time_size() {
    // P3-like point robot around one circle, at both sizes.
    let fixed = reference::point_reach();
    let lo = fixed.bounds().unwrap().clone();
    let dynamic = Problem::<Dyn, Dyn>::new(
        DVector::zeros(4),
        Arc::new(RunTimeSize::<_, 4, 2>::new(
            ddp_core::models::DoubleIntegrator2D::new(0.05).unwrap(),
        )),
        Arc::new(
            QuadraticCost::<Dyn, Dyn>::diagonal(&[0.0; 4], &[0.1, 0.1], DVector::zeros(4), DVector::zeros(2)).unwrap(),
        ),
        Arc::new(
            QuadraticTerminal::<Dyn>::diagonal(
                &[100.0, 100.0, 10.0, 10.0],
                DVector::from_vec(vec![3.0, 3.0, 0.0, 0.0]),
            )
            .unwrap(),
        ),
        fixed.horizon(),
    )
    .unwrap()
    .with_control_bounds(
        ControlBounds::new(
            DVector::from_column_slice(lo.lower.as_slice()),
            DVector::from_column_slice(lo.upper.as_slice()),
        )
        .unwrap(),
    )
    .unwrap();
    let c_fixed: Arc<dyn Constraint<Const<4>, Const<2>>> = Arc::new(Circle::squared([1.5, 1.4], 0.5, [0, 1]).unwrap());
    let c_dyn: Arc<dyn Constraint<Dyn, Dyn>> = Arc::new(Circle::squared([1.5, 1.4], 0.5, [0, 1]).unwrap());
    let settings = safe_cddp::Settings::default();
    let mut a = SafeCddpSolver::new(&fixed, vec![c_fixed.clone()], settings).unwrap();
    let ra = a.solve(&fixed).unwrap().clone();
    let mut b = SafeCddpSolver::new(&dynamic, vec![c_dyn.clone()], settings).unwrap();
    let rb = b.solve(&dynamic).unwrap().clone();
    assert_eq!(ra.status, rb.status);
    assert!(ra.max_violation <= 1e-8 && rb.max_violation <= 1e-8);
    assert!(
        (ra.cost - rb.cost).abs() < 1e-8 * (1.0 + ra.cost),
        "{} vs {}",
        ra.cost,
        rb.cost
    );

    // One MPC episode with chance-constraint tightening, at both sizes, the same noise.
    let sigma_w = nalgebra::Matrix4::from_diagonal(&nalgebra::Vector4::new(1e-5, 1e-5, 1e-6, 1e-6));
    let goal = ddp_core::Vector::<4>::new(3.0, 3.0, 0.0, 0.0);
    let mpc_fixed = MpcSettings {
        goal,
        iterations: 5,
        initial_iterations: 30,
        ..MpcSettings::default()
    };
    let mpc_dyn = MpcSettings {
        iterations: 5,
        initial_iterations: 30,
        ..MpcSettings::with_goal(DVector::from_column_slice(goal.as_slice()))
    };
    let t_fixed = Tightening::new(0.95, sigma_w).unwrap();
    let t_dyn = Tightening::<Dyn, Dyn>::new(0.95, DMatrix::from_column_slice(4, 4, sigma_w.as_slice())).unwrap();
    let ea = Mpc::new(
        &fixed,
        vec![c_fixed],
        vec![],
        settings,
        Some(t_fixed),
        sigma_w,
        mpc_fixed,
    )
    .unwrap()
    .run_episode(3)
    .unwrap();
    let eb = Mpc::new(
        &dynamic,
        vec![c_dyn],
        vec![],
        settings,
        Some(t_dyn),
        DMatrix::from_column_slice(4, 4, sigma_w.as_slice()),
        mpc_dyn,
    )
    .unwrap()
    .run_episode(3)
    .unwrap();
    assert_eq!(ea.steps, eb.steps);
    assert_eq!(ea.collisions, eb.collisions);
    for (x, y) in ea.xs.iter().zip(&eb.xs) {
        assert!((x - ddp_core::Vector::<4>::from_column_slice(y.as_slice())).amax() < 1e-9);
    }
}

#[test]
fn sizes_that_disagree_or_are_out_of_range_are_errors_naming_the_argument() {
    let err = |e: ddp_core::Error| e.to_string();
    // Zero size.
    let e = err(
        LinearDynamics::<Dyn, Dyn>::new(DMatrix::zeros(0, 0), DMatrix::zeros(0, 1), DVector::zeros(0)).unwrap_err(),
    );
    assert!(e.contains("a.shape[0]") && e.contains("at least 1"), "{e}");
    // B with other rows than A.
    let e = err(
        LinearDynamics::<Dyn, Dyn>::new(DMatrix::identity(7, 7), DMatrix::zeros(6, 3), DVector::zeros(7)).unwrap_err(),
    );
    assert!(e.contains('b'), "{e}");
    // Past the documented limit.
    let big = MAX_STATES + 1;
    let e = err(QuadraticTerminal::<Dyn>::diagonal(&vec![1.0; big], DVector::zeros(big)).unwrap_err());
    assert!(e.contains("len(qf)") && e.contains(&MAX_STATES.to_string()), "{e}");
    // A cost of another size than the dynamics.
    let p = lq(7, 3, 1);
    let e = err(Problem::<Dyn, Dyn>::new(
        p.x0.clone(),
        Arc::new(LinearDynamics::new(p.a.clone(), p.b.clone(), DVector::zeros(7)).unwrap()),
        Arc::new(
            QuadraticCost::new(
                DMatrix::identity(6, 6),
                p.r.clone(),
                DVector::zeros(6),
                DVector::zeros(3),
            )
            .unwrap(),
        ),
        Arc::new(QuadraticTerminal::new(p.qf.clone(), DVector::zeros(7)).unwrap()),
        10,
    )
    .err()
    .expect("sizes disagree"));
    assert!(e.contains("running_cost") && e.contains("nx"), "{e}");
    // x0 of the wrong length.
    let e = err(Problem::<Dyn, Dyn>::new(
        DVector::zeros(5),
        Arc::new(LinearDynamics::new(p.a.clone(), p.b.clone(), DVector::zeros(7)).unwrap()),
        Arc::new(QuadraticCost::new(p.q.clone(), p.r.clone(), DVector::zeros(7), DVector::zeros(3)).unwrap()),
        Arc::new(QuadraticTerminal::new(p.qf.clone(), DVector::zeros(7)).unwrap()),
        10,
    )
    .err()
    .expect("x0 disagrees"));
    assert!(e.contains("dynamics"), "{e}");
    // Bounds of another size.
    let problem = lq_problem(&p, 10);
    let e = err(problem
        .clone()
        .with_control_bounds(ControlBounds::new(DVector::from_element(2, -1.0), DVector::from_element(2, 1.0)).unwrap())
        .err()
        .expect("bounds disagree"));
    assert!(e.contains("control_bounds"), "{e}");
    // A constraint on a state index past nx, a state box of another length.
    let circle: Arc<dyn Constraint<Dyn, Dyn>> = Arc::new(Circle::squared([0.0, 0.0], 1.0, [0, 9]).unwrap());
    let e = err(SafeCddpSolver::new(&problem, vec![circle], safe_cddp::Settings::default()).unwrap_err());
    assert!(e.contains("constraints[0]") && e.contains("indices[1]"), "{e}");
    let sbox: Arc<dyn Constraint<Dyn, Dyn>> =
        Arc::new(StateBox::new(DVector::from_element(3, -1.0), DVector::from_element(3, 1.0)).unwrap());
    let e = err(SafeCddpSolver::new(&problem, vec![sbox], safe_cddp::Settings::default()).unwrap_err());
    assert!(e.contains("constraints[0]") && e.contains("x_min"), "{e}");
    // A tightening of another size.
    let mut solver = SafeCddpSolver::new(&problem, vec![], safe_cddp::Settings::default()).unwrap();
    let t = Tightening::<Dyn, Dyn>::new(0.9, DMatrix::identity(4, 4) * 1e-3).unwrap();
    let e = err(solver.set_tightening(Some(t)).unwrap_err());
    assert!(e.contains("tightening.sigma_w"), "{e}");
    // A solver built for one size refuses a problem of another.
    let other = lq_problem(&lq(8, 3, 2), 10);
    let mut s = Solver::new(&problem, Settings::default()).unwrap();
    let e = err(s.solve(&other).unwrap_err());
    assert!(e.contains("problem") && e.contains("(8, 3)"), "{e}");
    // Vectors of another size in a rollout or a cost.
    let mut xs = vec![DVector::zeros(7); 11];
    let e = err(problem.rollout(&vec![DVector::zeros(2); 10], &mut xs).unwrap_err());
    assert!(e.contains("us[0]"), "{e}");
    let e = err(problem
        .cost(&vec![DVector::zeros(6); 11], &vec![DVector::zeros(3); 10])
        .unwrap_err());
    assert!(e.contains("xs[0]"), "{e}");
    let _ = VectorN::<Dyn>::zeros(1);
}
