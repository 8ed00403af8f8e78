//! Reference problems shared by the examples, benchmarks, golden logs and the Python tests.
//!
//! | function | model | horizon | what |
//! |---|---|---|---|
//! | [`p1_unicycle`] | [`Unicycle`] | 100 | P1 of `bench/problems.md` (Crocoddyl's unicycle), `J* = 250.0393199732` |
//! | [`car_parking`] | [`Car`] | 120 | P2's car, cost and control box, parking sideways at (2, 1) |
//! | [`point_reach`] | [`DoubleIntegrator2D`] | 100 | P3's double integrator, cost and box, no obstacles |
//! | [`diff_drive_goal`] | [`DifferentialDrive`] | 90 | the Turtlebot of Safe-CDDP §IV-C, start (0,0,0), goal (1.4, 0.6, 0) |
//! | [`quadrotor_reach`] | [`Quadrotor`] | 50 | hover to a point 1 m away and 0.5 m up |
//! | [`arm_base_reach`] | [`ArmBase`] | 60 | base and arm to a new configuration |

use nalgebra::{Const, U10, U12, U2, U3, U4, U5};
use std::sync::Arc;

use crate::costs::{QuadraticCost, QuadraticTerminal};
use crate::models::{ArmBase, Car, DifferentialDrive, DoubleIntegrator2D, Quadrotor, Unicycle};
use crate::{ControlBounds, Dynamics, Problem, Vector};

/// P1: Crocoddyl's `ActionModelUnicycle` with its defaults, `x0 = (-1, -1, 1)`, N = 100.
pub fn p1_unicycle() -> Problem<U3, U2> {
    let model = Arc::new(Unicycle::new(0.1).expect("valid dt"));
    let running = Arc::new(QuadraticCost::weighted_norms(10.0, 1.0).expect("valid weights"));
    let terminal = Arc::new(QuadraticTerminal::diagonal(&[100.0; 3], Vector::zeros()).expect("valid weights"));
    Problem::new(Vector::<3>::new(-1.0, -1.0, 1.0), model, running, terminal, 100).expect("valid problem")
}

fn goal_cost<const NX: usize, const NU: usize>(
    r: [f64; NU],
    qf: [f64; NX],
    goal: Vector<NX>,
) -> (
    Arc<QuadraticCost<Const<NX>, Const<NU>>>,
    Arc<QuadraticTerminal<Const<NX>>>,
) {
    (
        Arc::new(QuadraticCost::diagonal(&[0.0; NX], &r, Vector::zeros(), Vector::zeros()).expect("valid weights")),
        Arc::new(QuadraticTerminal::diagonal(&qf, goal).expect("valid weights")),
    )
}

/// P2's car (`dt = 0.05`, N = 120, box `|w| <= 0.4`, `|a| <= 0.5`) parking at (2, 1, 0, 0).
pub fn car_parking() -> Problem<U4, U2> {
    let (running, terminal) = goal_cost(
        [0.1, 0.1],
        [100.0, 100.0, 10.0, 10.0],
        Vector::<4>::new(2.0, 1.0, 0.0, 0.0),
    );
    Problem::new(
        Vector::zeros(),
        Arc::new(Car::new(0.05).expect("valid dt")),
        running,
        terminal,
        120,
    )
    .expect("valid problem")
    .with_control_bounds(
        ControlBounds::new(Vector::<2>::new(-0.4, -0.5), Vector::<2>::new(0.4, 0.5)).expect("valid box"),
    )
    .expect("bounds of the control size")
}

/// P3's double integrator (`dt = 0.05`, N = 100, box 0.8) to (3, 3) at rest, no obstacles.
pub fn point_reach() -> Problem<U4, U2> {
    let (running, terminal) = goal_cost(
        [0.1, 0.1],
        [100.0, 100.0, 10.0, 10.0],
        Vector::<4>::new(3.0, 3.0, 0.0, 0.0),
    );
    Problem::new(
        Vector::zeros(),
        Arc::new(DoubleIntegrator2D::new(0.05).expect("valid dt")),
        running,
        terminal,
        100,
    )
    .expect("valid problem")
    .with_control_bounds(ControlBounds::new(Vector::repeat(-0.8), Vector::repeat(0.8)).expect("valid box"))
    .expect("bounds of the control size")
}

/// A Turtlebot3-sized differential drive (`dt = 0.1`, N = 90) from (0, 0, 0) to (1.4, 0.6, 0),
/// wheel speeds within 0.22 m/s.
pub fn diff_drive_goal() -> Problem<U3, U2> {
    let (running, terminal) = goal_cost([1.0, 1.0], [100.0, 100.0, 10.0], Vector::<3>::new(1.4, 0.6, 0.0));
    Problem::new(
        Vector::zeros(),
        Arc::new(DifferentialDrive::new(0.1, 0.16).expect("valid model")),
        running,
        terminal,
        90,
    )
    .expect("valid problem")
    .with_control_bounds(ControlBounds::new(Vector::repeat(-0.22), Vector::repeat(0.22)).expect("valid box"))
    .expect("bounds of the control size")
}

/// The 12-state quadrotor (`dt = 0.02`, N = 50) from hover at the origin to hover at (1, 0, 0.5).
pub fn quadrotor_reach() -> Problem<U12, U4> {
    quadrotor_reach_horizon(50)
}

/// [`quadrotor_reach`] with `n` knots (the derivative-thread benchmark's long horizons).
pub fn quadrotor_reach_horizon(n: usize) -> Problem<U12, U4> {
    let model = Quadrotor::new(0.02).expect("valid model");
    quadrotor_reach_with(Arc::new(model), n)
}

/// [`quadrotor_reach_horizon`] with `dynamics` in place of the quadrotor (the same quadrotor
/// wrapped, e.g. in finite differences); the costs use the built-in quadrotor's hover thrust.
pub fn quadrotor_reach_with(dynamics: Arc<dyn Dynamics<U12, U4>>, n: usize) -> Problem<U12, U4> {
    let hover = Quadrotor::new(0.02).expect("valid model").hover_thrust();
    let mut goal = Vector::<12>::zeros();
    goal[0] = 1.0;
    goal[2] = 0.5;
    let running = Arc::new(
        QuadraticCost::diagonal(
            &[0.0; 12],
            &[0.1, 1.0, 1.0, 1.0],
            Vector::zeros(),
            Vector::<4>::new(hover, 0.0, 0.0, 0.0),
        )
        .expect("valid weights"),
    );
    let terminal = Arc::new(
        QuadraticTerminal::diagonal(
            &[100.0, 100.0, 100.0, 10.0, 10.0, 10.0, 10.0, 10.0, 10.0, 1.0, 1.0, 1.0],
            goal,
        )
        .expect("valid weights"),
    );
    Problem::new(Vector::zeros(), dynamics, running, terminal, n).expect("valid problem")
}

/// The planar floating base with a 2-link arm (`dt = 0.05`, N = 60), moving the base 0.5 m and
/// the joints by (0.8, -0.6) rad, ending at rest.
pub fn arm_base_reach() -> Problem<U10, U5> {
    arm_base_reach_horizon(60)
}

/// [`arm_base_reach`] with `n` knots (the derivative-thread benchmark's long horizons).
pub fn arm_base_reach_horizon(n: usize) -> Problem<U10, U5> {
    let mut goal = Vector::<10>::zeros();
    goal[0] = 0.5;
    goal[3] = 0.8;
    goal[4] = -0.6;
    let (running, terminal) = goal_cost([0.01; 5], [100.0; 10], goal);
    Problem::new(
        Vector::zeros(),
        Arc::new(ArmBase::new(0.05).expect("valid model")),
        running,
        terminal,
        n,
    )
    .expect("valid problem")
}
