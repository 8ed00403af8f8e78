//! The extra starts of `WarmUp::Portfolio`: the third (`Settings::portfolio_third_mu`), a
//! barrier homotopy from a stronger barrier, and the polish (`Settings::portfolio_polish`), the
//! KKT/QP iterations with cold multipliers from an augmented-Lagrangian solution; each kept only
//! when it ends in a better optimum, and both run only where the first two starts ended apart
//! (`Settings::portfolio_apart`).

use safe_cddp::benchmark::BenchmarkProblem;
use safe_cddp::{Report, SafeCddpSolver, Settings, StartOutcome, Status, WarmUp};

/// Problem 24 of the point family, seed 1 (`bench/results/family_s1_210.json`): the two default
/// starts end 66 % above IPOPT's optimum (0.44592); the third start reaches it.
const POINT_S1_I24: &str = r#"{"name": "point-s1-i24-a0", "model": "point", "dt": 0.0833, "N": 91, "x0": [0.0, 0.0, 0.0, 0.0], "cost": {"kind": "quad_goal", "x_goal": [-0.9764, 3.511, 0.0, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[-0.2712, 0.4564, 0.4267], [-0.494, 3.0689, 0.2955], [-0.9667, 2.7136, 0.2993], [-0.5643, 1.8916, 0.4738], [-0.0353, 0.6335, 0.2534]]}"#;
const IPOPT_COST: f64 = 0.44591998255635834;

/// The barrier starts of the defaults before the soft barrier: the second start from
/// `mu = 3e-3` with the logarithm relaxed only below a slack of 1e-6 (a hard wall), the third
/// from `mu = 3e-2`; and their augmented Lagrangian: inner solves ended only by the merit's
/// relative change and the iteration limits (`al_inner_progress = 0`), no curvature for rows
/// near their boundary (`al_near_margin = 0`). The tests of the
/// mechanisms below were written against it: with the soft barrier the first two starts
/// already reach the optimum on most of their problems.
fn hard_barrier() -> Settings {
    Settings {
        barrier_mu_init: 3e-3,
        barrier_relaxation: 1e-6,
        portfolio_third_mu: Some(3e-2),
        al_inner_progress: 0.0,
        al_near_margin: 0.0,
        portfolio_new_side: None,
        portfolio_flip: None,
        ..Settings::default()
    }
}

/// The portfolio's first two starts only (with the hard barrier).
fn two_starts() -> Settings {
    Settings {
        portfolio_third_mu: None,
        portfolio_polish: false,
        ..hard_barrier()
    }
}

fn solve(settings: Settings) -> (f64, f64, usize, usize, Vec<f64>) {
    let bp = BenchmarkProblem::from_json(POINT_S1_I24).unwrap();
    let (problem, constraints) = bp.car_or_point().unwrap();
    let mut solver = SafeCddpSolver::new(&problem, constraints, settings).unwrap();
    let r = solver.solve(&problem).unwrap();
    assert_eq!(r.status, Status::Converged);
    let (cost, viol, it, disc) = (r.cost, r.max_violation, r.iterations, r.discarded_iterations);
    let us = solver.us().iter().flat_map(|u| u.iter().copied()).collect();
    (cost, viol, it, disc, us)
}

#[test]
fn a_third_start_finds_the_better_optimum() {
    let two = solve(two_starts());
    let three = solve(Settings {
        portfolio_third_mu: Some(3e-2),
        ..two_starts()
    });
    assert!(two.1 <= 1e-6 && three.1 <= 1e-6);
    assert!(two.0 > IPOPT_COST * 1.1, "two starts: {}", two.0);
    assert!(three.0 <= IPOPT_COST * (1.0 + 1e-6), "three starts: {}", three.0);
    // The kept start's iterations plus the two discarded starts' are all the work done, more
    // than the two-start portfolio's.
    assert!(three.2 + three.3 > two.2 + two.3);
    // Deterministic: the same solve again gives the same controls, bit for bit.
    let again = solve(Settings {
        portfolio_third_mu: Some(3e-2),
        ..two_starts()
    });
    assert_eq!(three.4, again.4);
    // The portfolio runs it too (the first two starts end apart here) and keeps its optimum.
    let portfolio = solve(hard_barrier());
    assert!(portfolio.0 <= IPOPT_COST * (1.0 + 1e-6), "portfolio: {}", portfolio.0);
    // The default's soft barrier start reaches it by itself.
    let default = solve(Settings::default());
    assert!(default.0 <= IPOPT_COST * (1.0 + 1e-6), "default: {}", default.0);
}

#[test]
fn the_third_start_equal_to_the_second_changes_nothing() {
    // A third start with the second's barrier ties with it; the solution is the two-start one.
    let two = solve(two_starts());
    let s = two_starts();
    let three = solve(Settings {
        portfolio_third_mu: Some(s.barrier_mu_init),
        portfolio_apart: 0.0,
        ..s
    });
    assert_eq!(two.4, three.4);
    assert_eq!(two.0, three.0);
}

#[test]
fn only_the_portfolio_reads_it() {
    // Barrier alone ignores portfolio_third_mu.
    let b = Settings {
        warm_up: WarmUp::Barrier,
        ..two_starts()
    };
    let with = solve(Settings {
        portfolio_third_mu: Some(3e-2),
        portfolio_apart: 0.0,
        ..b
    });
    assert_eq!(solve(b).4, with.4);
}

#[test]
fn bad_third_mu_is_rejected_by_name() {
    for mu in [0.0, -1e-2, f64::NAN, f64::INFINITY] {
        let s = Settings {
            portfolio_third_mu: Some(mu),
            ..Settings::default()
        };
        let err = s.validate().unwrap_err().to_string();
        assert!(err.contains("portfolio_third_mu"), "{err}");
    }
    for apart in [-1e-3, f64::NAN, f64::INFINITY] {
        let s = Settings {
            portfolio_apart: apart,
            ..Settings::default()
        };
        let err = s.validate().unwrap_err().to_string();
        assert!(err.contains("portfolio_apart"), "{err}");
    }
}

#[test]
fn the_extra_starts_run_only_where_the_first_two_end_apart() {
    // On P3 the augmented-Lagrangian and barrier starts end within 1e-10 of each other, on P2
    // the barrier start stalls at 900x the other's cost: neither is apart, and the default
    // portfolio is the two-start one there, bit for bit. With `portfolio_apart = 0` the third
    // start and the polish run and cannot end worse.
    // The same holds with the default's soft barrier (without the third start on another side
    // where the first two agree, `where_the_first_two_agree_...` below).
    let soft = Settings {
        portfolio_new_side: None,
        ..Settings::default()
    };
    for (file, base) in [
        ("p3_point4.json", hard_barrier()),
        ("p2_car4.json", hard_barrier()),
        ("p3_point4.json", soft),
        ("p2_car4.json", soft),
    ] {
        let json = std::fs::read_to_string(format!("../../bench/problems/{file}")).unwrap();
        let two = solve_json(
            &json,
            Settings {
                portfolio_third_mu: None,
                portfolio_polish: false,
                ..base
            },
        );
        let default = solve_json(&json, base);
        let always = solve_json(
            &json,
            Settings {
                portfolio_apart: 0.0,
                ..base
            },
        );
        assert_eq!(default.cost.to_bits(), two.cost.to_bits(), "{file}");
        assert_eq!(default.iterations, two.iterations, "{file}");
        assert_eq!(default.discarded_iterations, two.discarded_iterations, "{file}");
        assert!(
            always.iterations + always.discarded_iterations > two.iterations + two.discarded_iterations,
            "{file}: the extra starts did not run"
        );
        assert!(always.max_violation <= 1e-6 && always.cost <= two.cost, "{file}");
    }
    // On point-s1-i24 they end apart (the better of the two 66 % above IPOPT's optimum): the
    // third start runs and finds IPOPT's optimum (`a_third_start_finds_the_better_optimum`);
    // with a gate wider than their gap it does not.
    let wide = solve(Settings {
        portfolio_apart: 10.0,
        ..hard_barrier()
    });
    assert_eq!(wide.4, solve(two_starts()).4);
}

/// Problem 22 of the car family, seed 1 (`bench/results/family_s1_210_funnel.json`): the first two
/// starts agree on an optimum 2.6x IPOPT's (0.47750); the third start, its barrier homotopy
/// ending on another side of the obstacles, goes on and finds one below IPOPT's.
const CAR_S1_I22: &str = r#"{"name": "car-s1-i22-a0", "model": "car", "dt": 0.0764, "N": 159, "x0": [0.0, 0.0, -2.3306, 0.0], "cost": {"kind": "quad_goal", "x_goal": [-1.7779, -2.1419, -2.0659, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[-0.5669, -0.2952, 0.4401], [-1.1398, -1.5126, 0.4451], [-1.3598, -1.1623, 0.3852]]}"#;
const IPOPT_I22: f64 = 0.47750011380348567;
/// Problem 12 of the car family, seed 1: the first two starts agree on a cost above 1.2x the
/// relaxed one, and the third start's homotopy ends on their side of the one obstacle.
const CAR_S1_I12: &str = r#"{"name": "car-s1-i12-a0", "model": "car", "dt": 0.0547, "N": 80, "x0": [0.0, 0.0, 1.0632, 0.0], "cost": {"kind": "quad_goal", "x_goal": [2.5455, 2.0702, 0.8993, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[1.9699, 1.6277, 0.2944]]}"#;

#[test]
fn where_the_first_two_agree_a_third_start_on_another_side_escapes_their_optimum() {
    // Without the flipped starts, which find the same optimum from the kept solution.
    let on = Settings {
        portfolio_flip: None,
        ..Settings::default()
    };
    let off = Settings {
        portfolio_new_side: None,
        ..on
    };
    let (before, after) = (solve_json(CAR_S1_I22, off), solve_json(CAR_S1_I22, on));
    assert_eq!((before.status, after.status), (Status::Converged, Status::Converged));
    assert!(before.max_violation <= 1e-6 && after.max_violation <= 1e-6);
    assert!(before.cost > 2.0 * IPOPT_I22, "without: {}", before.cost);
    assert!(after.cost <= IPOPT_I22 * (1.0 + 1e-6), "with: {}", after.cost);
    // On the kept solution's side the third start stops where its homotopy ends: the solution
    // is the one without it, bit for bit, for a few discarded iterations (one barrier
    // subproblem of at most `barrier_inner_iterations`).
    let (before, after) = (solve_json(CAR_S1_I12, off), solve_json(CAR_S1_I12, on));
    assert_eq!(before.cost.to_bits(), after.cost.to_bits());
    assert_eq!(before.iterations, after.iterations);
    let extra = after.discarded_iterations - before.discarded_iterations;
    assert!(extra > 0 && extra <= off.barrier_inner_iterations, "{extra}");
    // Only the portfolio reads it.
    let barrier = Settings {
        warm_up: WarmUp::Barrier,
        ..Settings::default()
    };
    let a = solve_json(CAR_S1_I22, barrier);
    let b = solve_json(
        CAR_S1_I22,
        Settings {
            portfolio_new_side: None,
            ..barrier
        },
    );
    assert_eq!((a.cost.to_bits(), a.iterations), (b.cost.to_bits(), b.iterations));
}

/// Problem 10 of the car family, seed 1: the portfolio keeps the augmented Lagrangian's own
/// solution, 4.95e-4 above FATROP's optimum (0.41285486); the polish from there reaches it.
const CAR_S1_I10: &str = r#"{"name": "car-s1-i10-a0", "model": "car", "dt": 0.0629, "N": 129, "x0": [0.0, 0.0, 0.1035, 0.0], "cost": {"kind": "quad_goal", "x_goal": [3.104, -0.4525, 0.3355, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "u_min": [-0.3211, -0.5879], "u_max": [0.3211, 0.5879], "obstacles": [[1.4156, 0.052, 0.2195], [0.8806, 0.1519, 0.4815]]}"#;
const FATROP_COST: f64 = 0.4128548645118785;

fn solve_json(json: &str, settings: Settings) -> safe_cddp::Report {
    let bp = BenchmarkProblem::from_json(json).unwrap();
    let (problem, constraints) = bp.car_or_point().unwrap();
    let mut solver = SafeCddpSolver::new(&problem, constraints, settings).unwrap();
    solver.solve(&problem).unwrap().clone()
}

#[test]
fn the_polish_reaches_the_optimum_the_augmented_lagrangian_stopped_short_of() {
    // With the hard barrier (the default's soft barrier start reaches this optimum itself).
    let plain = solve_json(CAR_S1_I10, two_starts());
    let polished = solve_json(
        CAR_S1_I10,
        Settings {
            portfolio_polish: true,
            portfolio_apart: 0.0,
            ..two_starts()
        },
    );
    assert_eq!(polished.status, Status::Converged);
    assert!(plain.max_violation <= 1e-6 && polished.max_violation <= 1e-6);
    assert!(
        plain.cost > FATROP_COST * (1.0 + 1e-4),
        "without the polish: {}",
        plain.cost
    );
    assert!(
        polished.cost <= FATROP_COST * (1.0 + 1e-6),
        "with the polish: {}",
        polished.cost
    );
    // The polish continues the kept solution: its iterations add to the kept start's, and the
    // discarded starts are the same.
    assert!(polished.iterations > plain.iterations);
    assert_eq!(polished.discarded_iterations, plain.discarded_iterations);
    // The QPs of every start are counted, also those of the solution the polish continued.
    assert!(polished.qp.solved >= plain.qp.solved);
}

#[test]
fn the_polish_never_ends_worse() {
    // P2's and P3's kept solutions end in the augmented-Lagrangian warm-up (their KKT/QP step
    // there is zero): the polish runs, and the cost can only fall.
    for file in ["p3_point4.json", "p2_car4.json"] {
        let json = std::fs::read_to_string(format!("../../bench/problems/{file}")).unwrap();
        let run = |portfolio_polish| {
            solve_json(
                &json,
                Settings {
                    portfolio_polish,
                    portfolio_apart: 0.0,
                    ..two_starts()
                },
            )
        };
        let (plain, polished) = (run(false), run(true));
        assert!(polished.max_violation <= 1e-6, "{file}");
        assert!(
            polished.cost <= plain.cost,
            "{file}: {} > {}",
            polished.cost,
            plain.cost
        );
        assert!(
            polished.iterations + polished.discarded_iterations > plain.iterations + plain.discarded_iterations,
            "{file}: the polish did not run"
        );
    }
}

/// The report's starts against its totals: one kept, its iterations (with those of the start
/// the polish went on from) the report's `iterations`, the rest its `discarded_iterations`, and
/// the kept one's cost the report's. Returns the outcomes in order.
fn check_starts(r: &Report) -> Vec<(WarmUp, Option<f64>, StartOutcome)> {
    let sum = |kept: bool| {
        r.starts
            .iter()
            .filter(|s| matches!(s.outcome, StartOutcome::Kept | StartOutcome::Polished) == kept)
            .map(|s| s.iterations)
            .sum::<usize>()
    };
    assert_eq!(sum(true), r.iterations, "{}", r.table());
    assert_eq!(sum(false), r.discarded_iterations, "{}", r.table());
    let kept: Vec<_> = r.starts.iter().filter(|s| s.outcome == StartOutcome::Kept).collect();
    assert_eq!(kept.len(), 1, "{}", r.table());
    assert_eq!(kept[0].cost.to_bits(), r.cost.to_bits());
    // The polish only ever goes on from the kept solution, and is the last start.
    let polished = r.starts.iter().filter(|s| s.outcome == StartOutcome::Polished).count();
    assert!(polished <= 1);
    if polished == 1 {
        assert_eq!(r.starts.last().unwrap().warm_up, WarmUp::None);
        assert_eq!(r.starts.last().unwrap().outcome, StartOutcome::Kept);
    }
    // The table names every start.
    assert_eq!(r.table().matches("\nstart ").count(), r.starts.len());
    r.starts
        .iter()
        .map(|s| (s.warm_up, s.barrier_mu_init, s.outcome))
        .collect()
}

#[test]
fn the_report_lists_every_start_and_which_was_kept() {
    use StartOutcome::{Discarded, Kept, Polished, SameSide};
    let (al, barrier) = (WarmUp::AugmentedLagrangian, WarmUp::Barrier);
    let third = Settings::default().portfolio_third_mu;
    // Where the first two agree on a poor optimum, the third start (on another side) is kept
    // (without the flipped starts: one of them ends on the same optimum, 4e-9 lower, and is
    // kept instead).
    let no_flip = Settings {
        portfolio_flip: None,
        ..Settings::default()
    };
    let r = solve_json(CAR_S1_I22, no_flip);
    let starts = check_starts(&r);
    assert_eq!(
        &starts[..3],
        &[
            (al, None, Discarded),
            (barrier, None, Discarded),
            (barrier, third, Kept)
        ][..]
    );
    // On the kept solution's side the third start stops where its homotopy ends.
    let r = solve_json(CAR_S1_I12, Settings::default());
    let starts = check_starts(&r);
    assert_eq!(starts.len(), 3);
    assert_eq!(starts[2], (barrier, third, SameSide));
    // The polish goes on from the augmented Lagrangian's solution to a better one.
    let r = solve_json(
        CAR_S1_I10,
        Settings {
            portfolio_polish: true,
            portfolio_apart: 0.0,
            ..two_starts()
        },
    );
    let starts = check_starts(&r);
    assert_eq!(starts.last(), Some(&(WarmUp::None, None, Kept)));
    assert!(starts.iter().any(|s| s.2 == Polished), "{starts:?}");
    // A single warm-up lists none.
    for warm_up in [al, barrier] {
        let r = solve_json(
            CAR_S1_I22,
            Settings {
                warm_up,
                ..Settings::default()
            },
        );
        assert!(r.starts.is_empty() && !r.table().contains("\nstart "));
    }
}

/// Everything a solve leaves in the solver: the report's figures, the controls, states, gains and
/// multipliers.
fn fingerprint(solver: &SafeCddpSolver<nalgebra::U4, nalgebra::U2>) -> Vec<f64> {
    let r = solver.report();
    let mut v = vec![
        r.cost,
        r.max_violation,
        r.iterations as f64,
        r.discarded_iterations as f64,
        r.backward_passes as f64,
        r.qp.solved as f64,
        f64::from(u8::from(r.status == Status::Converged)),
    ];
    v.extend(solver.us().iter().flat_map(|u| u.iter().copied()));
    v.extend(solver.xs().iter().flat_map(|x| x.iter().copied()));
    v.extend(solver.gains().iter().flat_map(|k| k.iter().copied()));
    v.extend(solver.feedforward().iter().flat_map(|k| k.iter().copied()));
    v.extend((0..solver.horizon()).flat_map(|k| solver.multipliers(k).to_vec()));
    v
}

#[test]
fn two_threads_are_the_one_thread_computation() {
    // Problems where the first start is kept (P2, P3), where the polish runs (car-s1-i10), where
    // the third start wins (point-s1-i24), and the second (barrier) start's solution is kept
    // (point-s1-i5); each solved twice by one solver (the sibling's workspace is reused).
    const POINT_S1_I5: &str = r#"{"name": "point-s1-i5-a0", "model": "point", "dt": 0.0611, "N": 89, "x0": [0.0, 0.0, 0.0, 0.0], "cost": {"kind": "quad_goal", "x_goal": [-4.2979, 1.6613, 0.0, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "u_min": [-0.9112, -0.8398], "u_max": [0.9112, 0.8398], "obstacles": [[-2.0242, 0.8678, 0.3246], [-1.4497, 0.3629, 0.2199], [-0.7001, 0.4772, 0.2728], [-2.1836, 1.0655, 0.4537]]}"#;
    let p2 = std::fs::read_to_string("../../bench/problems/p2_car4.json").unwrap();
    let p3 = std::fs::read_to_string("../../bench/problems/p3_point4.json").unwrap();
    let variants = [
        two_starts(),
        Settings {
            portfolio_polish: true,
            portfolio_apart: 0.0,
            ..two_starts()
        },
        Settings::default(),
        Settings {
            portfolio_apart: 0.0,
            ..Settings::default()
        },
    ];
    let mut second_kept = 0;
    for json in [p2.as_str(), p3.as_str(), CAR_S1_I10, POINT_S1_I24, POINT_S1_I5] {
        let bp = BenchmarkProblem::from_json(json).unwrap();
        let (problem, constraints) = bp.car_or_point().unwrap();
        for s in variants {
            let mut one = SafeCddpSolver::new(&problem, constraints.clone(), s).unwrap();
            let two_s = Settings {
                portfolio_threads: 2,
                ..s
            };
            let mut two = SafeCddpSolver::new(&problem, constraints.clone(), two_s).unwrap();
            for round in 0..2 {
                one.reset();
                two.reset();
                one.solve(&problem).unwrap();
                two.solve(&problem).unwrap();
                assert_eq!(fingerprint(&one), fingerprint(&two), "{} round {round}", bp.name);
            }
            // Whether the barrier start's solution was kept: the AL start alone differs.
            let al = Settings {
                warm_up: WarmUp::AugmentedLagrangian,
                ..s
            };
            let mut alone = SafeCddpSolver::new(&problem, constraints.clone(), al).unwrap();
            alone.solve(&problem).unwrap();
            second_kept += usize::from(alone.report().cost != one.report().cost);
        }
    }
    assert!(second_kept > 0, "no case keeps a later start");
    let bad = Settings {
        portfolio_threads: 0,
        ..Settings::default()
    };
    assert!(bad.validate().unwrap_err().to_string().contains("portfolio_threads"));
}

#[test]
fn the_barrier_start_re_enters_with_the_warm_up_multipliers() {
    // P2's barrier start makes short KKT/QP steps, one is rejected, and it re-enters the
    // augmented-Lagrangian warm-up with the multipliers the warm-up handed over with (the
    // backward pass's, up to 389 on two rows, threw the re-entered trajectory far from the
    // obstacles: 207 iterations in all with the hard barrier, when that start still counted as
    // converged where its rows held multipliers off their boundary). It goes on to the optimum
    // (below the NLP peers' 1.1972797), where the augmented-Lagrangian start ends too.
    let json = std::fs::read_to_string("../../bench/problems/p2_car4.json").unwrap();
    let r = solve_json(&json, Settings::default());
    assert_eq!(r.status, Status::Converged);
    assert!(r.max_violation <= 1e-6, "violation {}", r.max_violation);
    assert!(r.cost <= 1.1972797186 * (1.0 + 1e-6), "cost {}", r.cost);
    let (al, barrier) = (&r.starts[0], &r.starts[1]);
    assert_eq!(
        (al.warm_up, barrier.warm_up),
        (WarmUp::AugmentedLagrangian, WarmUp::Barrier)
    );
    assert_eq!(barrier.status, Status::Converged);
    assert!(
        (barrier.cost - al.cost).abs() <= 1e-7 * al.cost,
        "{} against {}",
        barrier.cost,
        al.cost
    );
    let total = r.iterations + r.discarded_iterations;
    assert!(
        total <= 120,
        "{} kept + {} discarded iterations",
        r.iterations,
        r.discarded_iterations
    );
}

/// Problem 17 of the point family, seed 2 (`bench/results/family_s2_210.json`): three
/// overlapping obstacles make a wall between the start and the goal, and IPOPT's optimum
/// (0.0927603) goes round it.
const POINT_S2_I17: &str = r#"{"name": "point-s2-i17-a0", "model": "point", "dt": 0.0873, "N": 107, "x0": [0.0, 0.0, 0.0, 0.0], "cost": {"kind": "quad_goal", "x_goal": [0.8095, -2.3979, 0.0, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[0.4543, -2.082, 0.2079], [0.8051, -1.4666, 0.2347], [0.3289, -1.4844, 0.3807], [0.17, -1.3864, 0.381]]}"#;
const POINT_S2_I17_IPOPT: f64 = 0.09276029665544235;

#[test]
fn the_funnel_keeps_the_augmented_lagrangian_out_of_a_wall_of_obstacles() {
    let barrier = Settings {
        warm_up: WarmUp::Barrier,
        ..hard_barrier()
    };
    let open = |s: Settings| Settings {
        barrier_funnel: f64::INFINITY,
        ..s
    };
    let kept = solve_json(POINT_S2_I17, barrier);
    assert_eq!(kept.status, Status::Converged);
    assert!(kept.max_violation <= 1e-6, "{}", kept.max_violation);
    assert!(kept.cost <= POINT_S2_I17_IPOPT * (1.0 + 1e-6), "funnel: {}", kept.cost);
    // Without it, the augmented Lagrangian's first steps from the barrier's trajectory go into
    // the wall, its violation stalls there, and it ends back near the start.
    let stalled = solve_json(POINT_S2_I17, open(barrier));
    assert!(stalled.cost > 10.0 * POINT_S2_I17_IPOPT, "no funnel: {}", stalled.cost);
    // The portfolio keeps the barrier start's optimum; without the funnel both of its starts
    // end at the wall.
    let portfolio = solve_json(POINT_S2_I17, hard_barrier());
    assert!(portfolio.max_violation <= 1e-6);
    assert!(
        portfolio.cost <= POINT_S2_I17_IPOPT * (1.0 + 1e-6),
        "portfolio: {}",
        portfolio.cost
    );
    let without = solve_json(POINT_S2_I17, open(hard_barrier()));
    assert!(
        without.cost > 10.0 * POINT_S2_I17_IPOPT,
        "portfolio without funnel: {}",
        without.cost
    );
    // It counts only knots inside two obstacles at once: on P3, whose obstacles are apart, the
    // solve is the same without it, bit for bit.
    let p3 = std::fs::read_to_string("../../bench/problems/p3_point4.json").unwrap();
    let (with, none) = (
        solve_json(&p3, Settings::default()),
        solve_json(&p3, open(Settings::default())),
    );
    // The default's soft barrier goes round the wall without the funnel.
    let soft = solve_json(POINT_S2_I17, open(Settings::default()));
    assert!(soft.max_violation <= 1e-6);
    assert!(
        soft.cost <= POINT_S2_I17_IPOPT * (1.0 + 1e-6),
        "soft barrier, no funnel: {}",
        soft.cost
    );
    assert_eq!(with.cost.to_bits(), none.cost.to_bits());
    assert_eq!(
        (with.iterations, with.discarded_iterations),
        (none.iterations, none.discarded_iterations)
    );
}

#[test]
fn bad_funnel_is_rejected_by_name() {
    for funnel in [0.0, -1e-2, f64::NAN, f64::NEG_INFINITY] {
        let s = Settings {
            barrier_funnel: funnel,
            ..Settings::default()
        };
        let err = s.validate().unwrap_err().to_string();
        assert!(err.contains("barrier_funnel"), "{err}");
    }
}

/// Problem 8 of the point family, seed 6 (`bench/results/family_s6_210.json`): both starts of
/// the hard barrier's portfolio pass the first obstacle on the side that costs 4.52 and agree,
/// so no third start runs; IPOPT's optimum (0.10679) passes it on the other side.
const POINT_S6_I8: &str = r#"{"name": "point-s6-i8-a0", "model": "point", "dt": 0.0945, "N": 137, "x0": [0.0, 0.0, 0.0, 0.0], "cost": {"kind": "quad_goal", "x_goal": [-1.7076, -4.2253, 0.0, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "obstacles": [[-0.6657, -0.6201, 0.368], [-0.8349, -2.8655, 0.3299], [-0.2735, -1.1965, 0.376]]}"#;
const POINT_S6_I8_IPOPT: f64 = 0.10679364285732115;

#[test]
fn the_soft_barrier_chooses_the_cheaper_way_round() {
    // The soft barrier (the default: `mu` from 3e-2, the logarithm continued as a quadratic
    // below a slack of 0.1) lets the trajectory cross the obstacles' edges while it chooses
    // its way, as IPOPT's slacks do, and finds IPOPT's side.
    let soft = solve_json(
        POINT_S6_I8,
        Settings {
            warm_up: WarmUp::Barrier,
            ..Settings::default()
        },
    );
    assert_eq!(soft.status, Status::Converged);
    assert!(soft.max_violation <= 1e-6, "{}", soft.max_violation);
    assert!(
        soft.cost <= POINT_S6_I8_IPOPT * (1.0 + 1e-6),
        "soft barrier: {}",
        soft.cost
    );
    // The hard barrier keeps it outside every obstacle from the first step and ends 40x above.
    let hard = solve_json(
        POINT_S6_I8,
        Settings {
            warm_up: WarmUp::Barrier,
            ..hard_barrier()
        },
    );
    assert!(hard.max_violation <= 1e-6);
    assert!(hard.cost > 10.0 * POINT_S6_I8_IPOPT, "hard barrier: {}", hard.cost);
    // The default portfolio keeps the soft barrier's optimum; the hard barrier's does not find it.
    let default = solve_json(POINT_S6_I8, Settings::default());
    assert!(default.max_violation <= 1e-6);
    assert!(
        default.cost <= POINT_S6_I8_IPOPT * (1.0 + 1e-6),
        "default: {}",
        default.cost
    );
    assert!(solve_json(POINT_S6_I8, hard_barrier()).cost > 10.0 * POINT_S6_I8_IPOPT);
}

/// Problem 6 of the unicycle family, seed 2 (`bench/results/family_s2_210_funnel.json`): both
/// NLP peers end at 377.356; ddpkit's augmented-Lagrangian start finds a far cheaper way, but
/// at its top penalty its line searches kept failing down to the shortest step.
const UNICYCLE_S2_I6: &str = r#"{"name": "unicycle-s2-i6-a0", "model": "unicycle", "dt": 0.0694, "N": 115, "x0": [0.0, 0.0, -0.9144], "cost": {"kind": "quad_goal", "x_goal": [2.1559, -2.4471, -1.2264], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0]}, "obstacles": [[0.381, -0.4841, 0.212], [0.7782, -0.352, 0.3253], [1.7478, -2.3561, 0.3231], [1.8729, -1.6271, 0.2827]]}"#;

#[test]
fn rows_near_their_boundary_get_curvature_at_a_high_penalty() {
    let bp = BenchmarkProblem::from_json(UNICYCLE_S2_I6).unwrap();
    let (problem, constraints) = bp.unicycle().unwrap();
    let solve = |al_near_margin: f64| {
        // Short KKT/QP steps kept (`kkt_step_min`): with them counted as failed, the two
        // solves part in their KKT/QP iterations and end in different optima (1.46 and 2.61).
        let settings = Settings {
            warm_up: WarmUp::AugmentedLagrangian,
            al_near_margin,
            kkt_step_min: 0.0,
            ..Settings::default()
        };
        let mut solver = SafeCddpSolver::new(&problem, constraints.clone(), settings).unwrap();
        solver.solve(&problem).unwrap().clone()
    };
    let blind = solve(0.0);
    let near = solve(Settings::default().al_near_margin);
    for r in [&blind, &near] {
        assert_eq!(r.status, Status::Converged);
        assert!(r.max_violation <= 1e-6, "{}", r.max_violation);
        assert!(r.cost < 0.1 * 377.356, "cost {}", r.cost);
    }
    // The same optimum (within the stopping tolerances)...
    assert!(
        (near.cost - blind.cost).abs() <= 1e-6 * blind.cost,
        "{} against {}",
        near.cost,
        blind.cost
    );
    // ...with a fraction of the forward passes (143 against 612).
    assert!(
        2 * near.forward_passes < blind.forward_passes,
        "{} against {} forward passes",
        near.forward_passes,
        blind.forward_passes
    );
}

/// Problem 40 of the car family, seed 1 (`bench/results/family_s1_210_abandon.json`): after its
/// homotopy the barrier start's augmented Lagrangian holds a row just inside its boundary with
/// the near-boundary curvature (no multiplier) and crawls along it.
const CAR_S1_I40: &str = r#"{"name": "car-s1-i40-a0", "model": "car", "dt": 0.0798, "N": 155, "x0": [0.0, 0.0, -0.9678, 0.0], "cost": {"kind": "quad_goal", "x_goal": [2.8582, -2.0886, -0.3893, 0.0], "R": [0.1, 0.1], "Qf": [100.0, 100.0, 10.0, 10.0]}, "u_min": [-0.4221, -0.8031], "u_max": [0.4221, 0.8031], "obstacles": [[1.928, -1.8048, 0.3909], [0.8152, -0.9959, 0.4099], [0.8956, -0.2295, 0.4491], [0.3423, -0.3135, 0.2948]]}"#;

#[test]
fn a_crawl_along_a_row_held_off_its_boundary_turns_the_near_curvature_off() {
    let solve = |al_near_crawl: usize| {
        let settings = Settings {
            warm_up: WarmUp::Barrier,
            max_iterations: 500,
            al_near_crawl,
            ..Settings::default()
        };
        solve_json(CAR_S1_I40, settings)
    };
    let crawl = solve(0);
    let off = solve(Settings::default().al_near_crawl);
    // With the curvature throughout, full steps that lower the cost by about 4e-7 each run to
    // the iteration limit (494 iterations)...
    assert_eq!(crawl.status, Status::MaxIterations);
    assert!(crawl.iterations >= 450, "{} iterations", crawl.iterations);
    assert!(crawl.max_violation <= 1e-6, "{}", crawl.max_violation);
    // ...without it after five of them, the row gets its multiplier and the solve converges
    // (100 iterations) next to where the crawl stopped (0.510760 against 0.510589).
    assert_eq!(off.status, Status::Converged);
    assert!(off.iterations <= 200, "{} iterations", off.iterations);
    assert!(off.max_violation <= 1e-6, "{}", off.max_violation);
    assert!(
        (off.cost - crawl.cost).abs() <= 1e-3 * crawl.cost,
        "{} against {}",
        off.cost,
        crawl.cost
    );
}

#[test]
fn a_negative_crawl_change_is_rejected_by_name() {
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let settings = Settings {
            al_near_crawl_change: bad,
            ..Settings::default()
        };
        let err = settings.validate().unwrap_err().to_string();
        assert!(err.contains("al_near_crawl_change"), "{err}");
    }
}

/// `Settings::kkt_step_min`. P3's augmented-Lagrangian start hands over to the KKT/QP iterations
/// at a feasible trajectory 11 % above the optimum; there the QP steps are short (1/8 down to
/// 1/512, each line search a QP at every knot) and the line search then fails anyway, and the
/// warm-up takes over. With the floor it takes over at the first short step.
#[test]
fn short_kkt_steps_of_a_cold_solve_hand_back_to_the_warm_up() {
    let p3 = std::fs::read_to_string("../../bench/problems/p3_point4.json").unwrap();
    let al = |kkt_step_min: f64| Settings {
        warm_up: WarmUp::AugmentedLagrangian,
        kkt_step_min,
        ..Settings::default()
    };
    let creep = solve_json(&p3, al(0.0));
    let floor = solve_json(&p3, al(0.25));
    for r in [&creep, &floor] {
        assert_eq!(r.status, Status::Converged);
        assert!(r.max_violation <= 1e-8, "{}", r.max_violation);
        assert!(r.cost <= 1.8958999 * (1.0 + 1e-6), "{}", r.cost);
    }
    assert!((floor.cost - creep.cost).abs() <= 1e-8 * creep.cost);
    assert!(
        floor.forward_passes + 20 < creep.forward_passes && floor.iterations < creep.iterations,
        "{} against {} forward passes, {} against {} iterations",
        floor.forward_passes,
        creep.forward_passes,
        floor.iterations,
        creep.iterations
    );
    // A warm start (here from P3's solution to a goal moved by 0.2) keeps the short steps: the
    // floor changes nothing there.
    let bp = BenchmarkProblem::from_json(&p3).unwrap();
    let mut spec: serde_json::Value = serde_json::from_str(&p3).unwrap();
    let goal = &mut spec["cost"]["x_goal"];
    goal[0] = serde_json::json!(goal[0].as_f64().unwrap() - 0.2);
    let bp2 = BenchmarkProblem::from_json(&spec.to_string()).unwrap();
    let ((problem, constraints), (problem2, _)) = (bp.car_or_point().unwrap(), bp2.car_or_point().unwrap());
    let warm = |kkt_step_min: f64| {
        let mut solver = SafeCddpSolver::new(&problem, constraints.clone(), Settings::default()).unwrap();
        solver.solve(&problem).unwrap();
        solver
            .set_settings(Settings {
                kkt_step_min,
                ..Settings::default()
            })
            .unwrap();
        let r = solver.solve(&problem2).unwrap().clone();
        (r.cost.to_bits(), r.iterations, r.forward_passes)
    };
    // (With the floor there, this warm solve takes 34 forward passes instead of 42.)
    assert_eq!(warm(0.0), warm(0.25));
    for bad in [-0.1, 1.5, f64::NAN] {
        let e = Settings {
            kkt_step_min: bad,
            ..Settings::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("kkt_step_min") && e.contains("[0, 1]"), "{e}");
    }
}
