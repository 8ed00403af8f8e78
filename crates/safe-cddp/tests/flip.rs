//! The portfolio's flipped starts (`Settings::portfolio_flip`): where the kept solution costs
//! well above the obstacle-free optimum, a start per binding obstacle steered to its far side.

use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::{Report, SafeCddpSolver, Settings, StartOutcome, Status, WarmUp};

/// Problem 21 of the car family, seed 1 (`bench/results/family_s1_210_side.json`): every other
/// start passes the second obstacle on its far side from the goal, at 4.438, 73 % above the
/// optimum FATROP and IPOPT find between the two obstacles.
const CAR_S1_I21: &str = r#"{"name": "car-s1-i21-a0", "model": "car", "dt": 0.0562, "N": 86, "x0": [0.0, 0.0, 0.8392, 0.0], "cost": {"kind": "quad_goal", "x_goal": [1.5542, 4.711, 1.0496, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[0.2283, 0.7209, 0.285], [0.6563, 1.379, 0.3098]]}"#;
const FATROP_COST: f64 = 2.5615841384740934;

fn solver(
    json: &str,
    settings: Settings,
) -> (
    ddp_core::Problem<nalgebra::U4, nalgebra::U2>,
    SafeCddpSolver<nalgebra::U4, nalgebra::U2>,
) {
    let bp = BenchmarkProblem::from_json(json).unwrap();
    let (problem, constraints) = bp.car_or_point().unwrap();
    let solver = SafeCddpSolver::new(&problem, constraints, settings).unwrap();
    (problem, solver)
}

fn solve(json: &str, settings: Settings) -> Report {
    let (problem, mut s) = solver(json, settings);
    s.solve(&problem).unwrap().clone()
}

/// A stopping rule of the portfolio's later starts, on `json`: solved with `settings` and with
/// `without` (the rule off), the same solution to the bit, with more than `fewer` fewer discarded
/// iterations. Returns the problem, the solver with the rule, its report and the other's.
fn stops_sooner(
    json: &str,
    settings: Settings,
    without: Settings,
    fewer: usize,
) -> (
    ddp_core::Problem<nalgebra::U4, nalgebra::U2>,
    SafeCddpSolver<nalgebra::U4, nalgebra::U2>,
    Report,
    Report,
) {
    let run_on = solve(json, without);
    let (problem, mut one) = solver(json, settings);
    let stop = one.solve(&problem).unwrap().clone();
    assert_eq!(stop.cost.to_bits(), run_on.cost.to_bits());
    assert_eq!(stop.iterations, run_on.iterations);
    assert!(
        stop.discarded_iterations + fewer < run_on.discarded_iterations,
        "{} against {}",
        stop.discarded_iterations,
        run_on.discarded_iterations
    );
    (problem, one, stop, run_on)
}

fn no_flips() -> Settings {
    Settings {
        portfolio_flip: None,
        ..Settings::default()
    }
}

/// The defaults without the planned start (`portfolio_plan`), which runs before the flipped
/// ones: where it finds the optimum on its own the flipped and mirrored starts it steers like
/// are left out, so these tests of theirs run without it (and check that with it the optimum
/// is found all the same).
fn no_plan() -> Settings {
    Settings {
        portfolio_plan: None,
        ..Settings::default()
    }
}

#[test]
fn a_flipped_start_finds_the_way_between_the_obstacles() {
    let before = solve(CAR_S1_I21, no_flips());
    let after = solve(CAR_S1_I21, no_plan());
    let planned = solve(CAR_S1_I21, Settings::default());
    assert!(
        planned.cost <= FATROP_COST * (1.0 + 1e-6),
        "with the plan: {}",
        planned.cost
    );
    assert_eq!((before.status, after.status), (Status::Converged, Status::Converged));
    assert!(before.max_violation <= 1e-6 && after.max_violation <= 1e-6);
    assert!(before.cost > 1.5 * FATROP_COST, "without: {}", before.cost);
    assert!(after.cost <= FATROP_COST * (1.0 + 1e-6), "with: {}", after.cost);
    // The report: the flipped starts follow the others, one per binding obstacle (both bind
    // here), and the kept one is a flipped start; the iterations add up.
    let flips: Vec<_> = after.starts.iter().filter(|s| s.flip.is_some()).collect();
    assert_eq!(flips.len(), 2, "{}", after.table());
    assert!(flips.iter().all(|s| s.warm_up == WarmUp::AugmentedLagrangian));
    let kept = kept_start(&after);
    assert!(kept.flip.is_some(), "{}", after.table());
    assert_eq!(kept.cost.to_bits(), after.cost.to_bits());
    check_totals(&after);
    assert!(after.table().contains("flip (constraint "));
    // The starts before the flipped ones are the same computation.
    let n = before.starts.len();
    assert_eq!(
        &after.starts[..n].iter().map(|s| s.cost.to_bits()).collect::<Vec<_>>(),
        &before.starts.iter().map(|s| s.cost.to_bits()).collect::<Vec<_>>()
    );
    // With at most one flipped start, only the first of them runs (the same computation), and
    // here it is the one that finds the optimum.
    let one = solve(
        CAR_S1_I21,
        Settings {
            portfolio_flip_starts: 1,
            ..no_plan()
        },
    );
    let first: Vec<_> = one.starts.iter().filter(|s| s.flip.is_some()).collect();
    assert_eq!(first.len(), 1, "{}", one.table());
    assert_eq!(
        (first[0].flip, first[0].cost.to_bits()),
        (flips[0].flip, flips[0].cost.to_bits())
    );
    assert!(one.cost <= FATROP_COST * (1.0 + 1e-6), "with one: {}", one.cost);
    check_totals(&one);
}

/// Problem 22 of the point-robot family, seed 10 (`bench/results/family_s10_210.json`): the
/// portfolio's first two starts end apart (at 0.263 and 0.183), and the kept solution costs
/// 1.44x the obstacle-free optimum, below the gate of `portfolio_flip` (1.5) but above that of
/// `portfolio_flip_apart` (1.25), behind which the flipped and mirrored starts find the peers'
/// optimum, 10 % lower.
const POINT_S10_I22: &str = r#"{"name": "point-s10-i22-a0", "model": "point", "dt": 0.0867, "N": 123, "x0": [0.0, 0.0, 0.0, 0.0], "cost": {"kind": "quad_goal", "x_goal": [-0.7765, 4.7354, 0.0, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "u_min": [-0.8757, -1.1403], "u_max": [0.8757, 1.1403], "obstacles": [[-0.1956, 1.1505, 0.3487], [-0.7913, 4.0884, 0.2554], [-0.0657, 2.7005, 0.2276], [-0.2994, 3.9564, 0.2268], [-0.7226, 2.3796, 0.2737]]}"#;
const POINT_S10_I22_FATROP: f64 = 0.1665558658680249;

#[test]
fn the_gate_is_lower_where_the_first_two_starts_end_apart() {
    let high = Settings {
        portfolio_flip_apart: 1.5,
        ..Settings::default()
    };
    let before = solve(POINT_S10_I22, high);
    let after = solve(POINT_S10_I22, Settings::default());
    let (a, b) = (&after.starts[0], &after.starts[1]);
    assert!(
        (a.cost - b.cost).abs() > 1e-6 * a.cost.abs().max(b.cost.abs()),
        "{}",
        after.table()
    );
    assert!(
        before.starts.iter().all(|s| s.flip.is_none() && !s.mirror),
        "{}",
        before.table()
    );
    assert!(before.max_violation <= 1e-6 && after.max_violation <= 1e-6);
    assert!(before.cost > 1.05 * POINT_S10_I22_FATROP, "without: {}", before.cost);
    assert!(
        after.cost <= POINT_S10_I22_FATROP * (1.0 + 1e-6),
        "with: {}",
        after.cost
    );
    let kept = kept_start(&after);
    assert!(kept.flip.is_some() || kept.mirror, "{}", after.table());
    check_totals(&after);
    // The starts before are the same computation.
    let n = before.starts.len();
    assert_eq!(
        &after.starts[..n].iter().map(|s| s.cost.to_bits()).collect::<Vec<_>>(),
        &before.starts.iter().map(|s| s.cost.to_bits()).collect::<Vec<_>>()
    );
}

/// The one start whose solution the report holds.
fn kept_start(r: &Report) -> &safe_cddp::StartReport {
    let kept: Vec<_> = r.starts.iter().filter(|s| s.outcome == StartOutcome::Kept).collect();
    assert_eq!(kept.len(), 1, "{}", r.table());
    kept[0]
}

/// The report's starts against its totals: the kept (and polished) starts' iterations are the
/// report's `iterations`, the others' its `discarded_iterations`; one start is kept.
fn check_totals(r: &Report) {
    let kept = |s: &&safe_cddp::StartReport| matches!(s.outcome, StartOutcome::Kept | StartOutcome::Polished);
    let sum = |k: bool| {
        r.starts
            .iter()
            .filter(|s| kept(s) == k)
            .map(|s| s.iterations)
            .sum::<usize>()
    };
    assert_eq!(
        (sum(true), sum(false)),
        (r.iterations, r.discarded_iterations),
        "{}",
        r.table()
    );
    let n = r.starts.iter().filter(|s| s.outcome == StartOutcome::Kept).count();
    assert_eq!(n, 1, "{}", r.table());
}

/// Problem 47 of the car family, seed 1 (`bench/results/family_s1_210_flip.json`): the polish
/// goes on from the barrier start's solution, and then a flipped start finds a cheaper one.
const CAR_S1_I47: &str = r#"{"name": "car-s1-i47-a0", "model": "car", "dt": 0.0728, "N": 96, "x0": [0.0, 0.0, 2.4443, 0.0], "cost": {"kind": "quad_goal", "x_goal": [-2.7779, 2.3015, 2.514, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "u_min": [-0.4757, -0.4698], "u_max": [0.4757, 0.4698], "obstacles": [[-2.2588, 2.257, 0.2068], [-1.091, 0.655, 0.2231], [-2.2506, 1.7722, 0.3408]]}"#;

#[test]
fn a_flipped_start_kept_over_a_polished_solution_gives_both_up() {
    let before = solve(CAR_S1_I47, no_flips());
    let after = solve(CAR_S1_I47, Settings::default());
    assert!(
        before.starts.iter().any(|s| s.outcome == StartOutcome::Polished),
        "{}",
        before.table()
    );
    // The polish, and only it of these starts, goes on from the kept solution's controls.
    for s in &before.starts {
        assert_eq!(s.from_kept, s.warm_up == WarmUp::None, "{}", before.table());
    }
    assert!(after.cost < before.cost && after.max_violation <= 1e-6);
    let kept = after.starts.iter().find(|s| s.outcome == StartOutcome::Kept).unwrap();
    assert!(kept.flip.is_some(), "{}", after.table());
    assert!(
        after.starts.iter().all(|s| s.outcome != StartOutcome::Polished),
        "{}",
        after.table()
    );
    check_totals(&after);
}

#[test]
fn the_solver_holds_the_flipped_solution_and_solves_again_the_same() {
    let (problem, mut one) = solver(CAR_S1_I21, Settings::default());
    let (_, mut two) = solver(
        CAR_S1_I21,
        Settings {
            portfolio_threads: 2,
            ..Settings::default()
        },
    );
    let mut first = None;
    for _ in 0..2 {
        one.reset();
        two.reset();
        let a = one.solve(&problem).unwrap().clone();
        let b = two.solve(&problem).unwrap().clone();
        assert_eq!(
            (a.cost.to_bits(), a.iterations, a.discarded_iterations),
            (b.cost.to_bits(), b.iterations, b.discarded_iterations)
        );
        assert_eq!(one.us(), two.us());
        assert_eq!(one.xs(), two.xs());
        // The solver's trajectory is the kept solution's: its cost is the report's.
        let q = one.cost();
        assert!((q - a.cost).abs() <= 1e-12 * a.cost.abs(), "{q} {}", a.cost);
        let key = (
            a.cost.to_bits(),
            a.iterations,
            a.discarded_iterations,
            one.us().to_vec(),
        );
        if let Some(f) = &first {
            assert_eq!(f, &key, "a second solve differs");
        }
        first = Some(key);
    }
}

#[test]
fn flipped_starts_run_only_above_the_gate() {
    // P2's kept solution costs 1.46x its obstacle-free optimum: below the default gate of 1.5
    // nothing changes, bit for bit; with a gate of 1 its binding obstacles get flipped starts,
    // none better.
    let p2 = std::fs::read_to_string("../../bench/problems/p2_car4.json").unwrap();
    let off = solve(&p2, no_flips());
    let on = solve(&p2, Settings::default());
    assert_eq!(
        (off.cost.to_bits(), off.iterations, off.discarded_iterations),
        (on.cost.to_bits(), on.iterations, on.discarded_iterations)
    );
    assert!(on.starts.iter().all(|s| s.flip.is_none()));
    // Its first two starts agree, so the lower gate of starts that end apart (1.25) does not
    // apply to it.
    let apart = solve(
        &p2,
        Settings {
            portfolio_flip_apart: 1.0,
            ..Settings::default()
        },
    );
    assert_eq!(
        (apart.cost.to_bits(), apart.iterations, apart.discarded_iterations),
        (on.cost.to_bits(), on.iterations, on.discarded_iterations)
    );
    let low = solve(
        &p2,
        Settings {
            portfolio_flip: Some(1.0),
            ..Settings::default()
        },
    );
    assert!(low.starts.iter().any(|s| s.flip.is_some()), "{}", low.table());
    assert!(low.cost <= on.cost && low.max_violation <= 1e-6);
    assert!(low.discarded_iterations > on.discarded_iterations);
    // Only the portfolio runs them.
    let al = Settings {
        warm_up: WarmUp::AugmentedLagrangian,
        ..Settings::default()
    };
    let a = solve(CAR_S1_I21, al);
    let b = solve(
        CAR_S1_I21,
        Settings {
            portfolio_flip: None,
            ..al
        },
    );
    assert_eq!((a.cost.to_bits(), a.iterations), (b.cost.to_bits(), b.iterations));
    assert!(a.starts.is_empty());
}

/// Problem 2 of the car family, seed 1: one obstacle, whose kept solution costs more than 1.5x
/// the obstacle-free optimum.
const CAR_S1_I2: &str = r#"{"name": "car-s1-i2-a0", "model": "car", "dt": 0.0995, "N": 122, "x0": [0.0, 0.0, 0.0755, 0.0], "cost": {"kind": "quad_goal", "x_goal": [2.5464, 0.4745, 0.5807, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "u_min": [-0.3297, -0.3617], "u_max": [0.3297, 0.3617], "obstacles": [[1.3621, 0.0235, 0.4406]]}"#;

#[test]
fn one_obstacle_gets_no_flipped_starts() {
    // With a single state row the other starts go round it both ways already; a second
    // obstacle inside the first (it never binds) gives the problem two state rows, and the
    // flipped start for the first runs.
    let off = solve(CAR_S1_I2, no_flips());
    let on = solve(CAR_S1_I2, Settings::default());
    assert_eq!(
        (off.cost.to_bits(), off.iterations, off.discarded_iterations),
        (on.cost.to_bits(), on.iterations, on.discarded_iterations)
    );
    assert!(on.starts.iter().all(|s| s.flip.is_none()));
    let two = CAR_S1_I2.replace(
        "[[1.3621, 0.0235, 0.4406]]",
        "[[1.3621, 0.0235, 0.4406], [1.2, 0.2, 0.1]]",
    );
    let r = solve(&two, Settings::default());
    assert!(r.starts.iter().any(|s| s.flip.is_some()), "{}", r.table());
    check_totals(&r);
}

/// Problem 22 of the point-robot family, seed 8 (`bench/results/family_s8_210.json`): obstacles
/// 0, 3 and 4 overlap into one cluster, and every other start passes it on the side that costs
/// 46 % above the peers' optimum. The first obstacle's far side along its gradient lies inside
/// obstacle 4; the guide's target goes on past the cluster (with the target inside obstacle 4,
/// as before, this flipped start ended at 0.3303, on the barrier starts' side).
const POINT_S8_I22: &str = r#"{"name": "point-s8-i22-a0", "model": "point", "dt": 0.0668, "N": 137, "x0": [0.0, 0.0, 0.0, 0.0], "cost": {"kind": "quad_goal", "x_goal": [0.5391, -3.2223, 0.0, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "u_min": [-0.5273, -1.0277], "u_max": [0.5273, 1.0277], "obstacles": [[-0.213, -0.5005, 0.2943], [0.8158, -2.7723, 0.3624], [0.3566, -1.2169, 0.2229], [-0.0855, -0.52, 0.2525], [0.2168, -0.6601, 0.2513]]}"#;
const POINT_S8_I22_FATROP: f64 = 0.1749220743304266;

#[test]
fn a_flipped_start_goes_round_a_cluster_of_obstacles() {
    let before = solve(POINT_S8_I22, no_flips());
    let after = solve(POINT_S8_I22, no_plan());
    let planned = solve(POINT_S8_I22, Settings::default());
    assert!(
        planned.cost <= POINT_S8_I22_FATROP * (1.0 + 1e-6),
        "with the plan: {}",
        planned.cost
    );
    assert!(before.max_violation <= 1e-6 && after.max_violation <= 1e-6);
    assert!(before.cost > 1.4 * POINT_S8_I22_FATROP, "without: {}", before.cost);
    assert!(after.cost <= POINT_S8_I22_FATROP * (1.0 + 1e-6), "with: {}", after.cost);
    assert_eq!(kept_start(&after).flip, Some(0), "{}", after.table());
    check_totals(&after);
}

#[test]
fn bad_flip_settings_are_rejected_by_name() {
    for f in [0.5, f64::NAN, f64::INFINITY, -1.0] {
        let s = Settings {
            portfolio_flip: Some(f),
            ..Settings::default()
        };
        let e = s.validate().unwrap_err().to_string();
        assert!(e.contains("portfolio_flip") && e.contains(">= 1"), "{e}");
    }
    for f in [0.5, f64::NAN, f64::INFINITY] {
        let s = Settings {
            portfolio_flip_apart: f,
            ..Settings::default()
        };
        let e = s.validate().unwrap_err().to_string();
        assert!(e.contains("portfolio_flip_apart") && e.contains(">= 1"), "{e}");
    }
    let s = Settings {
        portfolio_flip_guide: 0,
        ..Settings::default()
    };
    assert!(s.validate().unwrap_err().to_string().contains("portfolio_flip_guide"));
    let s = Settings {
        portfolio_flip_starts: 0,
        ..Settings::default()
    };
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("portfolio_flip_starts") && e.contains("at least 1"), "{e}");
}

#[test]
fn a_solver_set_to_a_shorter_horizon_runs_no_flipped_starts() {
    // The gate's obstacle-free solve covers the problem's whole horizon only.
    let (problem, mut s) = solver(CAR_S1_I21, Settings::default());
    s.set_horizon(problem.horizon() - 10).unwrap();
    let r = s.solve(&problem).unwrap();
    assert!(r.cost.is_finite() && !r.starts.is_empty());
    assert!(r.starts.iter().all(|st| st.flip.is_none()), "{}", r.table());
}

/// Problem 52 of the car family, seed 2 (`bench/results/family_s2_210_funnel.json`): the flipped
/// start of the first obstacle ends its homotopy on another optimum, 1.1 % above the kept one,
/// and then crawls along an obstacle's edge for 135 iterations (to the iteration limit at the
/// gradient test of 1e-12), lowering its cost by about 1e-7 a step, where the near-boundary
/// curvature stays on (`al_near_crawl = 0`; by default five such steps turn it off and the
/// start converges instead).
const CAR_S2_I52: &str = r#"{"name": "car-s2-i52-a0", "model": "car", "dt": 0.0665, "N": 149, "x0": [0.0, 0.0, 1.7076, 0.0], "cost": {"kind": "quad_goal", "x_goal": [0.8526, 3.5608, 1.3077, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "u_min": [-0.5645, -0.4741], "u_max": [0.5645, 0.4741], "obstacles": [[0.8203, 2.8748, 0.2799], [0.1317, 2.0468, 0.3545], [1.0913, 2.9263, 0.4161]]}"#;

#[test]
fn a_start_that_cannot_reach_the_kept_cost_stops() {
    let base = Settings {
        al_near_crawl: 0,
        ..Settings::default()
    };
    let without = Settings {
        portfolio_stall: 0,
        ..base
    };
    let (problem, one, stop, crawl) = stops_sooner(CAR_S2_I52, base, without, 40);
    let stalled: Vec<_> = stop
        .starts
        .iter()
        .filter(|s| s.outcome == StartOutcome::Stalled)
        .collect();
    assert_eq!(stalled.len(), 1, "{}", stop.table());
    assert_eq!(stalled[0].flip, Some(0));
    assert!(stalled[0].cost > stop.cost);
    assert!(stop.table().contains(": stalled"), "{}", stop.table());
    assert!(!crawl.starts.iter().any(|s| s.outcome == StartOutcome::Stalled));
    check_totals(&stop);
    // Two threads (the first two starts at once) stop it the same way.
    let (_, mut two) = solver(
        CAR_S2_I52,
        Settings {
            portfolio_threads: 2,
            ..base
        },
    );
    let r = two.solve(&problem).unwrap();
    assert_eq!(r.cost.to_bits(), stop.cost.to_bits());
    assert_eq!(r.starts, stop.starts);
    assert_eq!(two.us(), one.us());
}

/// Problem 59 of the car family, seed 2 (`bench/results/family_s2_210_funnel.json`): the
/// augmented Lagrangian's start is kept at 0.625 (0.3 % above FATROP's optimum); without the
/// rule, the flipped start of the second obstacle and the mirrored start wander for 263 and 223
/// iterations (to 422 and 99.6).
const CAR_S2_I59: &str = r#"{"name": "car-s2-i59-a0", "model": "car", "dt": 0.0788, "N": 127, "x0": [0.0, 0.0, 1.6259, 0.0], "cost": {"kind": "quad_goal", "x_goal": [0.7759, 2.8412, 1.5856, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[0.5185, 1.3928, 0.252], [0.2654, 2.0295, 0.3508], [0.6359, 1.7408, 0.3], [0.939, 2.1961, 0.3666], [0.6364, 1.4168, 0.455]]}"#;

#[test]
fn a_start_far_above_the_kept_cost_is_abandoned() {
    // This rule alone (`portfolio_dual_bound` has its own test below).
    let settings = Settings {
        max_iterations: 500,
        portfolio_dual_bound: None,
        ..Settings::default()
    };
    let without = Settings {
        portfolio_abandon: None,
        ..settings
    };
    let (problem, one, stop, run_on) = stops_sooner(CAR_S2_I59, settings, without, 100);
    let abandoned: Vec<_> = stop
        .starts
        .iter()
        .filter(|s| s.outcome == StartOutcome::Abandoned)
        .collect();
    assert!(!abandoned.is_empty(), "{}", stop.table());
    for s in &abandoned {
        // Stopped more than 30 % above (feasible or not: here both are still infeasible, at 89x
        // and 76x the kept cost), sooner than the same start ran on.
        assert!(s.flip.is_some() || s.mirror, "{}", stop.table());
        assert!(s.cost > 1.3 * stop.cost, "{}", stop.table());
        let on = run_on
            .starts
            .iter()
            .find(|o| (o.flip, o.mirror) == (s.flip, s.mirror))
            .unwrap();
        assert!(s.iterations < on.iterations, "{}\n{}", stop.table(), run_on.table());
    }
    assert!(stop.table().contains(": abandoned"), "{}", stop.table());
    assert!(!run_on.starts.iter().any(|s| s.outcome == StartOutcome::Abandoned));
    check_totals(&stop);
    // Two threads (the first two starts at once) stop them the same way.
    let (_, mut two) = solver(
        CAR_S2_I59,
        Settings {
            portfolio_threads: 2,
            ..settings
        },
    );
    let r = two.solve(&problem).unwrap();
    assert_eq!(r.starts, stop.starts);
    assert_eq!(two.us(), one.us());
    // A negative or NaN fraction is rejected, naming the field.
    for bad in [-0.1, f64::NAN] {
        let s = Settings {
            portfolio_abandon: Some(bad),
            ..Settings::default()
        };
        assert!(s.validate().unwrap_err().to_string().contains("portfolio_abandon"));
    }
}

/// Problem 1 of the unicycle family, seed 17 (`bench/results/family_s17_210_dual.json`).
const UNICYCLE_S17_I1: &str = r#"{"name": "unicycle-s17-i1-a0", "model": "unicycle", "dt": 0.0862, "N": 108, "x0": [0.0, 0.0, -2.0687], "cost": {"kind": "quad_goal", "x_goal": [-1.0871, -3.5257, -1.9505], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0]}, "u_min": [-1.4775, -0.7444], "u_max": [1.4775, 0.7444], "obstacles": [[-1.0979, -3.0103, 0.2671], [-0.3974, -1.3135, 0.2805], [-0.6902, -3.2459, 0.2269], [-0.3633, -1.6982, 0.3207]]}"#;
/// IPOPT's cost on it (FATROP fails, at 14.03).
const UNICYCLE_S17_I1_IPOPT: f64 = 1.5711336110221323;

#[test]
fn a_guided_start_that_jumps_to_a_feasible_path_is_not_abandoned_at_the_jump() {
    // The second flipped start spends about 110 iterations infeasible near the peers' side of the
    // obstacles, then jumps to a feasible path at 20x the kept cost (2.34) and falls to 1.5675 in
    // 64 more: stopped at the jump by a test of one iteration, not by one of 20 in a row.
    let solve = |run: usize| {
        let bp = BenchmarkProblem::from_json(UNICYCLE_S17_I1).unwrap();
        let (problem, constraints) = bp.unicycle().unwrap();
        let settings = Settings {
            max_iterations: 500,
            portfolio_abandon_run: run,
            ..Settings::default()
        };
        let mut s = SafeCddpSolver::new(&problem, constraints, settings).unwrap();
        s.solve(&problem).unwrap().clone()
    };
    let (default, one) = (solve(Settings::default().portfolio_abandon_run), solve(1));
    assert!(default.max_violation <= 1e-6, "{}", default.table());
    assert!(default.cost < UNICYCLE_S17_I1_IPOPT, "{}", default.table());
    let kept = kept_start(&default);
    assert_eq!(kept.flip, Some(1), "{}", default.table());
    check_totals(&default);
    // With a single iteration above the bound the same start is abandoned, at far above the
    // kept cost, and a poorer solution is kept.
    let stopped = one.starts.iter().find(|s| s.flip == Some(1)).unwrap();
    assert_eq!(stopped.outcome, StartOutcome::Abandoned, "{}", one.table());
    assert!(
        stopped.cost > 10.0 * one.cost && stopped.iterations < kept.iterations,
        "{}",
        one.table()
    );
    assert!(one.cost > 1.4 * UNICYCLE_S17_I1_IPOPT, "{}", one.table());
    // 0 is rejected by name.
    let bp = BenchmarkProblem::from_json(UNICYCLE_S17_I1).unwrap();
    let (problem, constraints) = bp.unicycle().unwrap();
    let bad = Settings {
        portfolio_abandon_run: 0,
        ..Settings::default()
    };
    let err = SafeCddpSolver::new(&problem, constraints, bad).err().unwrap();
    assert!(err.to_string().contains("portfolio_abandon_run"), "{err}");
}

/// Problem 15 of the car family, seed 14 (`bench/results/family_s14_210_idle.json`): the third
/// start (the barrier from `mu = 3e-3`) ends its homotopy on a feasible path at 210x the cost
/// of the kept solution, then comes down to 1.16646, and the polish from it to 1.16533, 2.8e-4
/// below FATROP's optimum (1.16565).
const CAR_S14_I15: &str = r#"{"name": "car-s14-i15-a0", "model": "car", "dt": 0.0843, "N": 94, "x0": [0.0, 0.0, 0.6723, 0.0], "cost": {"kind": "quad_goal", "x_goal": [1.539, 2.2592, 0.875, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[1.5189, 1.837, 0.3046], [1.1111, 1.024, 0.4759], [0.5207, 0.6176, 0.4583], [0.839, 1.665, 0.476]]}"#;

#[test]
fn the_third_start_is_not_abandoned() {
    let settings = Settings {
        max_iterations: 500,
        ..Settings::default()
    };
    let r = solve(CAR_S14_I15, settings);
    let run_on = solve(
        CAR_S14_I15,
        Settings {
            portfolio_abandon: None,
            ..settings
        },
    );
    assert_eq!(r.cost.to_bits(), run_on.cost.to_bits(), "{}", r.table());
    assert!(r.cost < 1.16565 * (1.0 - 1e-4), "{}", r.table());
    let third = r
        .starts
        .iter()
        .find(|s| s.barrier_mu_init.is_some())
        .expect("a third start");
    assert_eq!(third.outcome, StartOutcome::Polished, "{}", r.table());
    check_totals(&r);
}

/// Problem 21 of the point-robot family, seed 1 (`bench/results/family_s1_210_crawl.json`): every
/// other start, and the flipped start of the one obstacle that binds, passes the cluster of four
/// obstacles on the side that costs 35 % above FATROP's optimum, which passes all four on the
/// other side (the sign of its winding number about each is the opposite).
const POINT_S1_I21: &str = r#"{"name": "point-s1-i21-a0", "model": "point", "dt": 0.0701, "N": 95, "x0": [0.0, 0.0, 0.0, 0.0], "cost": {"kind": "quad_goal", "x_goal": [3.6997, 1.9155, 0.0, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[1.9503, 1.2343, 0.2256], [1.1043, 0.7469, 0.2745], [1.6958, 0.8736, 0.2461], [2.873, 1.2272, 0.4637]]}"#;
const POINT_S1_I21_FATROP: f64 = 0.5699214263518232;

fn no_mirror() -> Settings {
    Settings {
        portfolio_mirror: None,
        ..no_plan()
    }
}

#[test]
fn a_mirrored_start_goes_round_the_other_side_of_a_whole_cluster() {
    let before = solve(POINT_S1_I21, no_mirror());
    let after = solve(POINT_S1_I21, no_plan());
    let planned = solve(POINT_S1_I21, Settings::default());
    assert!(
        planned.cost <= POINT_S1_I21_FATROP * (1.0 + 1e-6),
        "with the plan: {}",
        planned.cost
    );
    assert!(before.max_violation <= 1e-6 && after.max_violation <= 1e-6);
    assert!(before.cost > 1.3 * POINT_S1_I21_FATROP, "without: {}", before.cost);
    // The flipped start of the binding obstacle ran, and was not enough.
    assert!(before.starts.iter().any(|s| s.flip.is_some()), "{}", before.table());
    assert!(after.cost <= POINT_S1_I21_FATROP * (1.0 + 1e-6), "with: {}", after.cost);
    let kept = kept_start(&after);
    assert!(kept.mirror && kept.flip.is_none(), "{}", after.table());
    assert_eq!(kept.warm_up, WarmUp::AugmentedLagrangian);
    assert!(after.table().contains("mirror"), "{}", after.table());
    check_totals(&after);
    // Every start before it is the same computation; it is the last.
    let n = before.starts.len();
    assert_eq!(after.starts.len(), n + 1, "{}", after.table());
    assert_eq!(
        &after.starts[..n].iter().map(|s| s.cost.to_bits()).collect::<Vec<_>>(),
        &before.starts.iter().map(|s| s.cost.to_bits()).collect::<Vec<_>>()
    );
    // Without flipped starts there is no mirrored one either, nor a planned one (they share
    // their gate).
    let off = solve(POINT_S1_I21, no_flips());
    assert!(
        off.starts.iter().all(|s| !s.mirror && s.flip.is_none() && !s.plan),
        "{}",
        off.table()
    );
}

#[test]
fn a_mirrored_start_of_zero_iterations_is_rejected_by_name() {
    let s = Settings {
        portfolio_mirror: Some(0),
        ..Settings::default()
    };
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("portfolio_mirror") && e.contains("at least 1"), "{e}");
}

/// Problem 1 of the point-robot family, seed 1 (`bench/results/family_s1_210.json`): the flipped
/// start of the first obstacle is kept (2.7843770898e-1, a hair below the polished solution),
/// then the mirrored start runs.
const POINT_S1_I1: &str = r#"{"name": "point-s1-i1-a0", "model": "point", "dt": 0.0785, "N": 109, "x0": [0.0, 0.0, 0.0, 0.0], "cost": {"kind": "quad_goal", "x_goal": [-2.7115, 2.9154, 0.0, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "u_min": [-0.5508, -0.5114], "u_max": [0.5508, 0.5114], "obstacles": [[-0.8078, 1.4126, 0.3181], [-2.485, 2.5196, 0.2907], [-1.5715, 1.6983, 0.2118], [-0.7672, 0.7201, 0.4476]]}"#;

/// Problem 27 of the car family, seed 2 (`bench/results/family_s2_210.json`): the first flipped
/// start is kept, the second is abandoned against its cost, then the mirrored start runs.
const CAR_S2_I27: &str = r#"{"name": "car-s2-i27-a0", "model": "car", "dt": 0.0774, "N": 100, "x0": [0.0, 0.0, -2.813, 0.0], "cost": {"kind": "quad_goal", "x_goal": [-3.4032, -0.9171, -3.0187, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[-1.0096, -0.1858, 0.4051], [-2.8395, -0.5498, 0.2861], [-0.5702, 0.1125, 0.4536]]}"#;

#[test]
fn two_threads_run_the_guided_starts_two_at_a_time_as_one_thread_would() {
    // With two threads the guided starts run two at a time, each measured against the solution
    // kept before them; where the first of a pair is kept the second runs again against the new
    // cost. `car-s2-i27-a0` takes that path with a second flipped start the new cost abandons,
    // `point-s1-i1-a0` with the mirrored start, `car-s2-i59-a0` runs a pair neither of which is
    // kept. Each problem is solved twice by each solver (the guide solvers are reused).
    for json in [CAR_S2_I27, POINT_S1_I1, CAR_S2_I59] {
        let (problem, mut one) = solver(json, Settings::default());
        let (_, mut two) = solver(
            json,
            Settings {
                portfolio_threads: 2,
                ..Settings::default()
            },
        );
        for round in 0..2 {
            one.reset();
            two.reset();
            let a = one.solve(&problem).unwrap().clone();
            let b = two.solve(&problem).unwrap().clone();
            assert_eq!(a.starts, b.starts, "round {round}\n{}\n{}", a.table(), b.table());
            assert_eq!(a.cost.to_bits(), b.cost.to_bits());
            assert_eq!(
                (a.iterations, a.discarded_iterations, a.backward_passes),
                (b.iterations, b.discarded_iterations, b.backward_passes)
            );
            assert_eq!(one.us(), two.us());
            assert_eq!(one.xs(), two.xs());
            check_totals(&b);
        }
        let r = one.report();
        let guided: Vec<_> = r.starts.iter().filter(|s| s.flip.is_some() || s.mirror).collect();
        assert!(guided.len() >= 2, "{}", r.table());
        if json != CAR_S2_I59 {
            // The first guided start is kept, and another runs after it.
            assert_eq!(guided[0].outcome, StartOutcome::Kept, "{}", r.table());
        }
        if json == CAR_S2_I27 {
            assert_eq!(guided[1].outcome, StartOutcome::Abandoned, "{}", r.table());
            assert!(guided[1].flip.is_some(), "{}", r.table());
        }
    }
}

/// Problem 39 of the car family, seed 15 (`bench/results/family_s15_210.json`): every start
/// before the guided ones ends with the car backing up round the first obstacle (the barrier
/// start's 7.52 is the best, 637 % above the peers' optimum), and the obstacle-free solve from
/// that solution stays in the same manoeuvre (7.49), so that with it alone the gate saw the kept
/// cost near the obstacle-free optimum and ran no guided start. The augmented Lagrangian's
/// relaxed path (its first inner solve, 0.539) bounds the obstacle-free optimum lower and opens
/// the gate.
const CAR_S15_I39: &str = r#"{"name": "car-s15-i39-a0", "model": "car", "dt": 0.0699, "N": 104, "x0": [0.0, 0.0, 0.6889, 0.0], "cost": {"kind": "quad_goal", "x_goal": [2.2256, 3.367, 0.9768, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[1.5722, 2.7615, 0.272], [1.7756, 2.1595, 0.3298], [0.7958, 0.6158, 0.4865], [1.4, 2.5557, 0.267], [1.4005, 2.2006, 0.2114]]}"#;
const CAR_S15_I39_FATROP: f64 = 1.0208243407321955;

#[test]
fn the_gate_bounds_the_obstacle_free_optimum_by_the_relaxed_path_too() {
    let r = solve(CAR_S15_I39, Settings::default());
    assert_eq!(r.status, Status::Converged);
    assert!(r.max_violation <= 1e-6);
    assert!(r.cost <= CAR_S15_I39_FATROP * (1.0 + 1e-6), "{}", r.table());
    // The starts before the guided ones all end far above it; a guided one is kept.
    let guided = |s: &&safe_cddp::StartReport| s.flip.is_some() || s.mirror;
    assert!(
        r.starts
            .iter()
            .filter(|s| !guided(s))
            .all(|s| s.cost > 5.0 * CAR_S15_I39_FATROP),
        "{}",
        r.table()
    );
    assert!(guided(&kept_start(&r)), "{}", r.table());
    check_totals(&r);
}

/// Problem 27 of the car family, seed 6 (`bench/results/family_s6_210.json`): the first two
/// starts end apart (0.599 and 1467), the third (the barrier from `mu = 3e-3`) runs on for 133
/// iterations to 56.8, and the flipped start of the fifth obstacle is kept at 0.351.
const CAR_S6_I27: &str = r#"{"name": "car-s6-i27-a0", "model": "car", "dt": 0.0924, "N": 132, "x0": [0.0, 0.0, 2.8224, 0.0], "cost": {"kind": "quad_goal", "x_goal": [-2.707, 0.0183, 3.3696, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[-1.4131, 0.3213, 0.2947], [-0.9091, 0.2346, 0.3813], [-1.7714, 0.3084, 0.3566], [-1.5979, -0.1481, 0.2224], [-1.9761, -0.2471, 0.3925]]}"#;

#[test]
fn a_start_whose_dual_bound_is_above_the_kept_cost_is_abandoned() {
    let settings = Settings {
        max_iterations: 500,
        ..Settings::default()
    };
    let without = Settings {
        portfolio_dual_bound: None,
        ..settings
    };
    let (problem, one, stop, run_on) = stops_sooner(CAR_S6_I27, settings, without, 80);
    assert_eq!(stop.starts.len(), run_on.starts.len(), "{}", stop.table());
    let mut stopped = 0;
    for (s, on) in stop.starts.iter().zip(&run_on.starts) {
        assert_eq!(
            (s.warm_up, s.barrier_mu_init, s.flip, s.mirror),
            (on.warm_up, on.barrier_mu_init, on.flip, on.mirror)
        );
        if s.outcome == StartOutcome::Abandoned && on.outcome != StartOutcome::Abandoned {
            // Each start the bound stopped would have ended above the kept cost, by more than
            // the bound's 1 %, and it stopped sooner.
            stopped += 1;
            assert!(on.cost > 1.01 * stop.cost, "{}\n{}", stop.table(), run_on.table());
            assert!(s.iterations < on.iterations);
        } else {
            assert_eq!(s, on);
        }
    }
    // Here the third start (the barrier from `mu = 3e-3`), after 42 of its 133 iterations.
    assert!(stopped >= 1, "{}", stop.table());
    check_totals(&stop);
    // Two threads (the first two starts at once) stop it the same way.
    let (_, mut two) = solver(
        CAR_S6_I27,
        Settings {
            portfolio_threads: 2,
            ..settings
        },
    );
    let r = two.solve(&problem).unwrap();
    assert_eq!(r.starts, stop.starts);
    assert_eq!(two.us(), one.us());
    // A negative or NaN fraction is rejected, naming the field.
    for bad in [-0.1, f64::NAN] {
        let s = Settings {
            portfolio_dual_bound: Some(bad),
            ..Settings::default()
        };
        assert!(s.validate().unwrap_err().to_string().contains("portfolio_dual_bound"));
    }
}
