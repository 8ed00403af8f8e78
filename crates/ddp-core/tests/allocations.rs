//! Repeated solves allocate nothing: every buffer lives in the solver workspace.
//! (One test in this binary, so no other test thread allocates while counting.)

use nalgebra::{U2, U4};
use std::sync::Arc;

use ddp_core::costs::{
    ControlSquared, CostSum, ObstacleHinge, QuadraticCost, QuadraticTerminal, SmoothDistance, StateOnly,
};
use ddp_core::dims::{Dyn, VectorN};
use ddp_core::models::{Car, Unicycle};
use ddp_core::runtime::{RunTimeSize, RunTimeTerminal};
use ddp_core::{ControlBounds, Method, Problem, Settings, Shooting, Solver, Status, Vector};

fn count(f: impl FnOnce()) -> u64 {
    allocation_counter::measure(f).count_total
}

#[test]
fn repeated_solves_allocate_nothing() {
    // P1 (unicycle), iLQR and full DDP.
    let p1 = Problem::new(
        Vector::<3>::new(-1.0, -1.0, 1.0),
        Arc::new(Unicycle::new(0.1).unwrap()),
        Arc::new(QuadraticCost::weighted_norms(10.0, 1.0).unwrap()),
        Arc::new(QuadraticTerminal::diagonal(&[100.0; 3], Vector::zeros()).unwrap()),
        100,
    )
    .unwrap();
    for (method, shooting) in [
        (Method::Ilqr, Shooting::Single),
        (Method::Ddp, Shooting::Single),
        (Method::Ddp, Shooting::Multiple),
    ] {
        let mut solver = Solver::new(
            &p1,
            Settings {
                method,
                shooting,
                ..Settings::default()
            },
        )
        .unwrap();
        solver.solve(&p1).unwrap();
        let n = count(|| {
            for _ in 0..3 {
                solver.reset();
                solver.solve(&p1).unwrap();
                solver.shift();
                solver.solve(&p1).unwrap();
            }
        });
        assert_eq!(n, 0, "{method:?}, {shooting:?}: repeated solves allocated {n} times");
    }

    // The car with box bounds (box-DDP) and a DDPEN-style cost sum with obstacles.
    let running = CostSum::<U4, U2>::new()
        .with(1.0, Arc::new(ControlSquared::new(0.1).unwrap()))
        .with(
            0.1,
            Arc::new(StateOnly(SmoothDistance::goal([4.0, 0.5], [0, 1], 1e-2, 1.0).unwrap())),
        )
        .with(
            5.0,
            Arc::new(StateOnly(
                ObstacleHinge::new(vec![[2.0, 0.3], [2.2, 0.1]], 0.5, [0, 1], 1.0).unwrap(),
            )),
        );
    let car = Problem::new(
        Vector::<4>::zeros(),
        Arc::new(Car::new(0.05).unwrap()),
        Arc::new(running),
        Arc::new(
            QuadraticTerminal::diagonal(&[100.0, 100.0, 10.0, 10.0], Vector::<4>::new(4.0, 0.5, 0.0, 0.0)).unwrap(),
        ),
        120,
    )
    .unwrap()
    .with_control_bounds(ControlBounds::new(Vector::<2>::new(-0.4, -0.5), Vector::<2>::new(0.4, 0.5)).unwrap())
    .unwrap();
    let mut solver = Solver::new(&car, Settings::default()).unwrap();
    solver.solve(&car).unwrap();
    let n = count(|| {
        for _ in 0..3 {
            solver.reset();
            solver.solve(&car).unwrap();
        }
    });
    assert_eq!(n, 0, "box-DDP solves allocated {n} times");

    // The same car at run-time size (how a Python user's model runs): box-DDP's QP and full
    // DDP's definiteness test of gated passes work in the solver's buffers too.
    let dyn_running = RunTimeSize::new(
        QuadraticCost::<U4, U2>::diagonal(&[0.0; 4], &[0.1; 2], Vector::zeros(), Vector::zeros()).unwrap(),
    );
    let dyn_car = Problem::new(
        VectorN::<Dyn>::from_vec(vec![0.0; 4]),
        Arc::new(RunTimeSize::<Car, 4, 2>::new(Car::new(0.05).unwrap())),
        Arc::new(dyn_running),
        Arc::new(RunTimeTerminal(
            QuadraticTerminal::<U4>::diagonal(&[100.0, 100.0, 10.0, 10.0], Vector::<4>::new(4.0, 0.5, 0.0, 0.0))
                .unwrap(),
        )),
        120,
    )
    .unwrap()
    .with_control_bounds(
        ControlBounds::new(
            VectorN::<Dyn>::from_vec(vec![-0.4, -0.5]),
            VectorN::<Dyn>::from_vec(vec![0.4, 0.5]),
        )
        .unwrap(),
    )
    .unwrap();
    for method in [Method::Ilqr, Method::Ddp] {
        let mut solver = Solver::new(
            &dyn_car,
            Settings {
                method,
                ..Settings::default()
            },
        )
        .unwrap();
        let first = solver.solve(&dyn_car).unwrap();
        assert_eq!(first.status, Status::Converged, "{method:?}");
        let n = count(|| {
            for _ in 0..3 {
                solver.reset();
                solver.solve(&dyn_car).unwrap();
            }
        });
        assert_eq!(n, 0, "run-time-size box-DDP ({method:?}) solves allocated {n} times");
    }
}
