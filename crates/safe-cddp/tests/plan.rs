//! The portfolio's planned start (`Settings::portfolio_plan`): a start steered round the
//! obstacles on the sides of the shortest path of the position among them.

use std::sync::Arc;

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, MatrixN, VectorN};
use nalgebra::{U2, U4};
use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::{Constraint, Report, SafeCddpSolver, Settings, StartOutcome, Status};

/// Problem 28 of the point-robot family, seed 17 (`bench/results/family_s17_210_relax.json`):
/// every other start passes the four obstacles on the side that costs 26x the peers' optimum
/// (4.89 against 0.1838), and the kept solution binds none of them (no flipped start runs). The
/// shortest path of the position among them passes all four on the other side.
const POINT_S17_I28: &str = r#"{"name": "point-s17-i28-a0", "model": "point", "dt": 0.0883, "N": 115, "x0": [0.0, 0.0, 0.0, 0.0], "cost": {"kind": "quad_goal", "x_goal": [2.766, -3.9957, 0.0, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[1.3052, -1.415, 0.3576], [1.4986, -2.1846, 0.2185], [2.3291, -2.7144, 0.3916], [1.6817, -2.8276, 0.3203]]}"#;
const POINT_S17_I28_FATROP: f64 = 0.18383476481514527;

type Constraints = Vec<Arc<dyn Constraint<U4, U2>>>;

fn problem(json: &str) -> (ddp_core::Problem<U4, U2>, Constraints) {
    BenchmarkProblem::from_json(json).unwrap().car_or_point().unwrap()
}

/// Solves problem `json` with `constraints` (its own circles, or stand-ins for them).
fn solve_with(json: &str, constraints: Constraints, settings: Settings) -> Report {
    let (problem, _) = problem(json);
    let mut s = SafeCddpSolver::new(&problem, constraints, settings).unwrap();
    s.solve(&problem).unwrap().clone()
}

fn solve(json: &str, settings: Settings) -> Report {
    solve_with(json, problem(json).1, settings)
}

fn no_plan() -> Settings {
    Settings {
        portfolio_plan: None,
        ..Settings::default()
    }
}

#[test]
fn a_planned_start_takes_the_sides_of_the_shortest_path() {
    let before = solve(POINT_S17_I28, no_plan());
    let after = solve(POINT_S17_I28, Settings::default());
    assert_eq!((before.status, after.status), (Status::Converged, Status::Converged));
    assert!(before.max_violation <= 1e-6 && after.max_violation <= 1e-6);
    assert!(before.cost > 10.0 * POINT_S17_I28_FATROP, "without: {}", before.cost);
    assert!(
        after.cost <= POINT_S17_I28_FATROP * (1.0 + 1e-6),
        "with: {}\n{}",
        after.cost,
        after.table()
    );
    // The kept start is the planned one from the initial guess, the only one; kept, it leaves
    // the second planned start and the mirrored start out.
    let kept: Vec<_> = after
        .starts
        .iter()
        .filter(|s| s.outcome == StartOutcome::Kept)
        .collect();
    assert_eq!(kept.len(), 1, "{}", after.table());
    assert!(
        kept[0].plan && kept[0].flip.is_none() && !kept[0].mirror,
        "{}",
        after.table()
    );
    assert_eq!(kept[0].name(), "plan");
    assert_eq!(after.starts.iter().filter(|s| s.plan).count(), 1);
    assert!(!after.starts.iter().any(|s| s.mirror), "{}", after.table());
    assert!(before.starts.iter().any(|s| s.mirror), "{}", before.table());
    // The iterations add up.
    let sum = |kept: bool| {
        after
            .starts
            .iter()
            .filter(|s| matches!(s.outcome, StartOutcome::Kept | StartOutcome::Polished) == kept)
            .map(|s| s.iterations)
            .sum::<usize>()
    };
    assert_eq!((sum(true), sum(false)), (after.iterations, after.discarded_iterations));
    // The starts before it are the same computation.
    let n = after.starts.iter().position(|s| s.plan).unwrap();
    assert_eq!(
        after.starts[..n].iter().map(|s| s.cost.to_bits()).collect::<Vec<_>>(),
        before.starts[..n].iter().map(|s| s.cost.to_bits()).collect::<Vec<_>>()
    );
}

/// Problem 11 of the car family, seed 17 (`bench/results/family_s17_210_plan.json`): the kept
/// solution passes the three obstacles on the other side than their shortest path, 24 % above
/// FATROP's optimum (IPOPT ends at 412.9). The planned start from the initial guess goes their
/// way but is abandoned far above the kept cost; the second, from the kept solution's controls,
/// reaches FATROP's optimum.
const CAR_S17_I11: &str = r#"{"name": "car-s17-i11-a0", "model": "car", "dt": 0.0531, "N": 142, "x0": [0.0, 0.0, 0.1197, 0.0], "cost": {"kind": "quad_goal", "x_goal": [4.4819, -0.6684, -0.058, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[1.8324, -0.5879, 0.2761], [1.7304, -0.0979, 0.3304], [0.6, 0.0318, 0.3394]]}"#;
const CAR_S17_I11_FATROP: f64 = 1.1953943586071991;

#[test]
fn a_second_planned_start_from_the_kept_controls_follows_one_not_kept() {
    let before = solve(CAR_S17_I11, no_plan());
    let after = solve(CAR_S17_I11, Settings::default());
    assert!(before.max_violation <= 1e-6 && after.max_violation <= 1e-6);
    assert!(before.cost > 1.2 * CAR_S17_I11_FATROP, "without: {}", before.cost);
    assert!(
        after.cost <= CAR_S17_I11_FATROP * (1.0 + 1e-6),
        "with: {}\n{}",
        after.cost,
        after.table()
    );
    let plans: Vec<_> = after.starts.iter().filter(|s| s.plan).collect();
    assert_eq!(plans.len(), 2, "{}", after.table());
    // The first, from the initial guess, ended well above the kept cost; the second, from the
    // kept solution's controls, is kept.
    assert!(!plans[0].from_kept && plans[1].from_kept, "{}", after.table());
    assert!(plans[0].outcome != StartOutcome::Kept && plans[0].cost > 10.0 * after.cost);
    assert_eq!(plans[1].outcome, StartOutcome::Kept, "{}", after.table());
    assert_eq!(plans[1].name(), "plan (from the kept solution)");
    assert!(after.table().contains("plan (from the kept solution)"));
    // The first planned start was not kept, so the mirrored start still runs.
    assert!(after.starts.iter().any(|s| s.mirror), "{}", after.table());
}

#[test]
fn two_threads_run_the_planned_starts_as_one_thread_would() {
    for json in [POINT_S17_I28, CAR_S17_I11] {
        let one = solve(json, Settings::default());
        let two = solve(
            json,
            Settings {
                portfolio_threads: 2,
                ..Settings::default()
            },
        );
        assert_eq!(one.cost.to_bits(), two.cost.to_bits());
        assert_eq!(
            (one.iterations, one.discarded_iterations, one.status),
            (two.iterations, two.discarded_iterations, two.status)
        );
        assert_eq!(one.starts, two.starts);
    }
}

/// A circle that does not say it is one ([`Constraint::planar_disc`] left at its default): a
/// user's own obstacle row.
struct Hidden(Arc<dyn Constraint<U4, U2>>);

impl Constraint<U4, U2> for Hidden {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn depends_on_control(&self) -> bool {
        self.0.depends_on_control()
    }
    fn evaluate(&self, t: usize, x: &VectorN<U4>, u: &VectorN<U2>, g: &mut [f64]) {
        self.0.evaluate(t, x, u, g)
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
        self.0.jacobians(t, x, u, g, g_x, g_u)
    }
    fn add_hessian(&self, t: usize, x: &VectorN<U4>, u: &VectorN<U2>, w: &[f64], h_xx: &mut MatrixN<U4, U4>) {
        self.0.add_hessian(t, x, u, w, h_xx)
    }
    fn relative_degree(&self) -> Option<usize> {
        self.0.relative_degree()
    }
}

fn assert_disc<NX: Dim, NU: Dim>(c: &dyn Constraint<NX, NU>) -> safe_cddp::plan::PlanarDisc
where
    DefaultAllocator: Alloc<NX, NU>,
{
    c.planar_disc().expect("a circle says it is a disc")
}

#[test]
fn only_constraints_that_are_discs_are_planned_round() {
    let (_, constraints) = problem(POINT_S17_I28);
    // The benchmark's circles say what they are, through the `Arc` too.
    let d = assert_disc(constraints[0].as_ref());
    assert_eq!(
        (d.indices, d.disc.center, d.disc.radius),
        ([0, 1], [1.3052, -1.415], 0.3576)
    );
    let hidden: Constraints = constraints
        .iter()
        .map(|c| Arc::new(Hidden(c.clone())) as Arc<dyn Constraint<U4, U2>>)
        .collect();
    assert!(hidden[0].planar_disc().is_none());
    let r = solve_with(POINT_S17_I28, hidden, Settings::default());
    assert!(!r.starts.iter().any(|s| s.plan), "{}", r.table());
    // The same computation as without the planned start.
    let before = solve(POINT_S17_I28, no_plan());
    assert_eq!(r.cost.to_bits(), before.cost.to_bits());
    assert_eq!(r.starts, before.starts);
}

#[test]
fn a_planned_start_of_zero_iterations_is_rejected_by_name() {
    let (problem, constraints) = problem(POINT_S17_I28);
    let bad = Settings {
        portfolio_plan: Some(0),
        ..Settings::default()
    };
    let e = SafeCddpSolver::new(&problem, constraints, bad).unwrap_err().to_string();
    assert!(e.contains("portfolio_plan"), "{e}");
}
