//! Infeasible starts converge from there; infeasible problems end with `Status::Infeasible`
//! and the least-violating trajectory, within the iteration limit, never with a NaN.

use std::sync::Arc;

use ddp_core::dims::{U2, U4};
use ddp_core::{reference, ControlBounds, Settings as DdpSettings, Solver, Vector, VectorN};
use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::{Constraint, SafeCddpSolver, Settings, Status, WarmUp};

const WARM_UPS: [WarmUp; 3] = [WarmUp::Portfolio, WarmUp::Barrier, WarmUp::AugmentedLagrangian];

/// P3 of `bench/problems.md` (point robot, four obstacles; IPOPT's and FATROP's optimum
/// 1.8958999).
fn p3() -> (ddp_core::Problem<U4, U2>, safe_cddp::Constraints<U4, U2>) {
    BenchmarkProblem::from_file("../../bench/problems/p3_point4.json")
        .unwrap()
        .car_or_point()
        .unwrap()
}

/// P3's unconstrained optimum, which drives straight through the obstacles.
fn through_the_obstacles(problem: &ddp_core::Problem<U4, U2>) -> Vec<VectorN<U2>> {
    let mut free = Solver::new(problem, DdpSettings::default()).unwrap();
    free.solve(problem).unwrap();
    free.us().to_vec()
}

#[test]
fn a_start_through_the_obstacles_converges_to_a_feasible_optimum() {
    let (problem, constraints) = p3();
    let guess = through_the_obstacles(&problem);
    for warm_up in WARM_UPS {
        let settings = Settings {
            warm_up,
            ..Settings::default()
        };
        let mut solver = SafeCddpSolver::new(&problem, constraints.clone(), settings).unwrap();
        solver.set_controls(&guess).unwrap();
        solver.start(&problem).unwrap();
        let start_violation = solver.report().log[0].violation;
        assert!(
            start_violation > 0.1,
            "{warm_up:?}: the guess must violate, {start_violation}"
        );
        let r = solver.solve(&problem).unwrap();
        assert_eq!(r.status, Status::Converged, "{warm_up:?}\n{}", r.table());
        assert!(r.max_violation <= 1e-6, "{warm_up:?}: {}", r.max_violation);
        // A local optimum around the obstacles: within 5 % of the peers' best.
        assert!(r.cost <= 1.8958999 * 1.05, "{warm_up:?}: cost {}", r.cost);
    }
}

/// `|p - c|^2 - r^2 <= 0` at the last knot only: reach the disc of radius `r` around `c`.
#[derive(Debug)]
struct GoalRegion {
    center: [f64; 2],
    radius: f64,
    last: usize,
}

impl Constraint<U4, U2> for GoalRegion {
    fn dim(&self) -> usize {
        1
    }
    fn depends_on_control(&self) -> bool {
        false
    }
    fn evaluate(&self, t: usize, x: &VectorN<U4>, _u: &VectorN<U2>, g: &mut [f64]) {
        let (dx, dy) = (x[0] - self.center[0], x[1] - self.center[1]);
        g[0] = if t == self.last {
            dx * dx + dy * dy - self.radius * self.radius
        } else {
            -1.0
        };
    }
    fn jacobians(
        &self,
        t: usize,
        x: &VectorN<U4>,
        u: &VectorN<U2>,
        g: &mut [f64],
        g_x: &mut [VectorN<U4>],
        g_u: &mut [VectorN<U2>],
    ) {
        self.evaluate(t, x, u, g);
        g_x[0].fill(0.0);
        g_u[0].fill(0.0);
        if t == self.last {
            g_x[0][0] = 2.0 * (x[0] - self.center[0]);
            g_x[0][1] = 2.0 * (x[1] - self.center[1]);
        }
    }
    fn relative_degree(&self) -> Option<usize> {
        Some(1)
    }
}

#[test]
fn an_unreachable_goal_region_ends_infeasible_at_the_least_violation() {
    // The point robot (dt = 0.05, N = 100, T = 5 s) with accelerations within 0.1 per axis can
    // move at most a T^2 / 2 = 1.25 m per axis. The goal cost pulls to (3, 3); the constraint
    // asks for the disc of radius 0.1 around (-3, 0). The least violation is reached at full
    // throttle along -x, at (-1.25, 0): g = 1.75^2 - 0.1^2.
    let problem = reference::point_reach()
        .with_control_bounds(ControlBounds::new(Vector::repeat(-0.1), Vector::repeat(0.1)).unwrap())
        .unwrap();
    let n = problem.horizon();
    let region: Arc<dyn Constraint<U4, U2>> = Arc::new(GoalRegion {
        center: [-3.0, 0.0],
        radius: 0.1,
        last: n,
    });
    let least = 1.75f64.powi(2) - 0.01;
    for warm_up in WARM_UPS {
        let settings = Settings {
            warm_up,
            max_iterations: 300,
            ..Settings::default()
        };
        let mut solver = SafeCddpSolver::new(&problem, vec![region.clone()], settings).unwrap();
        let r = solver.solve(&problem).unwrap().clone();
        assert!(
            matches!(r.status, Status::Infeasible { .. }),
            "{warm_up:?}: {:?}\n{}",
            r.status,
            r.table()
        );
        assert!(r.iterations < 300, "{warm_up:?}: stopped by the iteration limit");
        assert!(solver.xs().iter().all(|x| x.iter().all(|v| v.is_finite())));
        assert!(
            (r.max_violation - least).abs() <= 1e-3 * least,
            "{warm_up:?}: violation {} vs least {least}",
            r.max_violation
        );
    }
}

#[test]
fn an_obstacle_over_the_only_way_ends_infeasible_without_nans() {
    // A start inside a wide obstacle that no bounded control can leave within the horizon.
    let mut problem = reference::point_reach();
    problem.set_x0(Vector::<4>::new(1.0, 1.0, 0.0, 0.0)).unwrap();
    let trap: Arc<dyn Constraint<U4, U2>> =
        Arc::new(safe_cddp::constraints::Circle::squared([1.0, 1.0], 20.0, [0, 1]).unwrap());
    for warm_up in WARM_UPS {
        let settings = Settings {
            warm_up,
            ..Settings::default()
        };
        let mut solver = SafeCddpSolver::new(&problem, vec![trap.clone()], settings).unwrap();
        let r = solver.solve(&problem).unwrap().clone();
        assert!(
            matches!(r.status, Status::Infeasible { .. }),
            "{warm_up:?}: {:?}",
            r.status
        );
        assert!(
            r.iterations < settings.max_iterations,
            "{warm_up:?}: stopped by the iteration limit"
        );
        assert!(r.cost.is_finite() && r.max_violation.is_finite());
        assert!(solver.xs().iter().all(|x| x.iter().all(|v| v.is_finite())));
        // Least violating: the robot heads out of the obstacle (the violation at the end is
        // below the one at the start).
        let g = |x: &VectorN<U4>| 400.0 - ((x[0] - 1.0).powi(2) + (x[1] - 1.0).powi(2));
        let xs = solver.xs();
        assert!(g(&xs[xs.len() - 1]) < g(&xs[1]) - 1.0, "{warm_up:?}");
    }
}

#[test]
fn inner_solves_end_once_a_step_moves_the_merit_less_than_a_multiplier_update() {
    // P3 from its unconstrained optimum, through the obstacles, as above.
    let (problem, constraints) = p3();
    let guess = through_the_obstacles(&problem);
    let solve = |settings: Settings| {
        let mut solver = SafeCddpSolver::new(&problem, constraints.clone(), settings).unwrap();
        solver.set_controls(&guess).unwrap();
        solver.solve(&problem).unwrap().clone()
    };
    let patient = solve(Settings {
        al_inner_progress: 0.0,
        ..Settings::default()
    });
    let default = solve(Settings::default());
    for r in [&patient, &default] {
        assert_eq!(r.status, Status::Converged, "{}", r.table());
        assert!(r.max_violation <= 1e-6, "{}", r.max_violation);
        assert!(r.cost <= 1.8958999 * (1.0 + 1e-6), "cost {}", r.cost);
    }
    // The same optimum in fewer iterations (37 against 48).
    let total = |r: &safe_cddp::Report| r.iterations + r.discarded_iterations;
    assert!(
        total(&default) < total(&patient),
        "{} against {}",
        total(&default),
        total(&patient)
    );
    // Applied from the start, deep inside the obstacles, the multiplier updates after every
    // step push the knots out of their nearest sides: another optimum, far above.
    let everywhere = solve(Settings {
        al_inner_progress_below: f64::INFINITY,
        ..Settings::default()
    });
    assert!(everywhere.cost > 2.0 * 1.8958999, "cost {}", everywhere.cost);
}
