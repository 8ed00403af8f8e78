//! The Safe-CDDP Turtlebot experiment (Alcan and Kyrki (2022), §IV-C): geometry of the clearance,
//! the constraint inflation, determinism per seed, Safe-CDDP against CDDP over a few episodes, and
//! the episodes as tasks (`sim2d::turtlebot::sweep`) giving the experiment of `run_experiment`.

use safe_cddp::Constraint;
use sim2d::run::Stats;
use sim2d::turtlebot::sweep::{self, EpisodeTask, TurtlebotSweepConfig};
use sim2d::turtlebot::{
    episode_seed, experiment_json, footprint_clearance, histogram, run_episode, run_experiment, waffle_pi, Controller,
    Disc, Experiment, Turtlebot, TurtlebotConfig, TurtlebotRun, PAPER_DISCS,
};
use sim2d::Error;

#[test]
fn footprint_clearance_matches_closed_forms() {
    let (l, w) = (0.138, 0.178);
    let disc = Disc {
        center: [1.0, 0.0],
        radius: 0.15,
    };
    // Straight ahead: the front face at x = l/2.
    let d = footprint_clearance([0.0, 0.0, 0.0], l, w, &disc);
    assert!((d - (1.0 - 0.069 - 0.15)).abs() < 1e-12, "{d}");
    // Turned by 90 degrees the side (half-width 0.089) faces the disc.
    let d = footprint_clearance([0.0, 0.0, std::f64::consts::FRAC_PI_2], l, w, &disc);
    assert!((d - (1.0 - 0.089 - 0.15)).abs() < 1e-12, "{d}");
    // Diagonal: the corner (0.069, 0.089) is closest to a disc on the corner's ray.
    let corner = [0.069, 0.089];
    let c = 0.069f64.hypot(0.089);
    let dir = [corner[0] / c, corner[1] / c];
    let disc2 = Disc {
        center: [dir[0] * 0.5, dir[1] * 0.5],
        radius: 0.1,
    };
    let d = footprint_clearance([0.0, 0.0, 0.0], l, w, &disc2);
    assert!((d - (0.5 - c - 0.1)).abs() < 1e-12, "{d}");
    // Overlap is negative.
    assert!(footprint_clearance([0.9, 0.0, 0.0], l, w, &disc) < 0.0);
}

#[test]
fn inflation_is_the_circumscribed_radius_and_keeps_the_footprint_off_the_discs() {
    let config = TurtlebotConfig::default();
    let r = waffle_pi();
    assert_eq!(config.robot, r);
    assert!((config.inflation - 0.5 * r.length.hypot(r.width)).abs() < 1e-15);
    assert!((config.inflation - 0.20771).abs() < 1e-4);
    let burger = TurtlebotConfig::for_robot(Turtlebot::Burger);
    assert!((burger.inflation - 0.11262).abs() < 1e-4);
    let rows = config.constraints().unwrap();
    assert_eq!(rows.len(), 2);
    let u = ddp_core::Vector::<2>::zeros();
    for (row, disc) in rows.iter().zip(PAPER_DISCS.iter()) {
        // On the inflated circle, at any angle and heading: g = 0 and the footprint clears.
        for k in 0..16 {
            let a = k as f64 * std::f64::consts::TAU / 16.0;
            let rho = disc.radius + config.inflation;
            let p = [disc.center[0] + rho * a.cos(), disc.center[1] + rho * a.sin()];
            let mut g = [0.0];
            for heading in [0.0, 0.4, 1.3, 2.9] {
                let x = ddp_core::Vector::<3>::new(p[0], p[1], heading);
                row.evaluate(0, &x, &u, &mut g);
                assert!(g[0].abs() < 1e-12, "g = {}", g[0]);
                assert!(footprint_clearance([p[0], p[1], heading], r.length, r.width, disc) >= -1e-12);
            }
            // 1 cm inside the inflated circle the row is violated by 1 cm.
            let q = ddp_core::Vector::<3>::new(p[0] - 0.01 * a.cos(), p[1] - 0.01 * a.sin(), 0.0);
            row.evaluate(0, &q, &u, &mut g);
            assert!((g[0] - 0.01).abs() < 1e-12);
        }
    }
}

#[test]
fn bad_configurations_name_the_field() {
    let bad = |f: &dyn Fn(&mut TurtlebotConfig), field: &str| {
        let mut c = TurtlebotConfig::default();
        f(&mut c);
        let e = run_episode(&c, Controller::Cddp, 0).unwrap_err();
        assert!(matches!(e, Error::Invalid { .. }), "{e}");
        assert!(e.to_string().contains(field), "{e} should name {field}");
    };
    bad(&|c| c.sigma_xy = -0.1, "sigma_xy");
    bad(&|c| c.discs[1].radius = 0.0, "discs[1].radius");
    bad(&|c| c.goal[2] = f64::NAN, "goal[2]");
    bad(&|c| c.min_horizon = 200, "min_horizon");
    bad(&|c| c.physics_dt = 0.5, "physics_dt");
    bad(&|c| c.robot.mass = -1.0, "robot.mass");
    assert!(Turtlebot::parse("roomba").unwrap_err().to_string().contains("robot"));
    let e = run_episode(&TurtlebotConfig::default(), Controller::SafeCddp { beta: 1.0 }, 0).unwrap_err();
    assert!(e.to_string().contains("beta"), "{e}");
    let e = run_experiment(&TurtlebotConfig::default(), 0, 0, 0.8, &|| {}).unwrap_err();
    assert!(e.to_string().contains("runs"), "{e}");
}

#[test]
fn episodes_are_deterministic_per_seed_and_differ_between_seeds() {
    let config = TurtlebotConfig {
        max_steps: 30,
        ..TurtlebotConfig::default()
    };
    let c = Controller::SafeCddp { beta: 0.8 };
    let a = run_episode(&config, c, 5).unwrap();
    let b = run_episode(&config, c, 5).unwrap();
    assert_eq!(a.poses, b.poses);
    assert_eq!(a.commands, b.commands);
    assert_eq!(a.min_clearance, b.min_clearance);
    let other = run_episode(&config, c, 6).unwrap();
    assert_ne!(a.poses, other.poses);
    // The executed motion differs from the plan's model (rapier, actuation noise) but follows it.
    assert_eq!(a.steps, 30);
    assert_eq!(a.poses.len(), 31);
    let model = ddp_core::models::DifferentialDrive::new(config.dt, config.track_width).unwrap();
    let mut worst = 0.0f64;
    for k in 0..a.steps {
        let (p, q, cmd) = (a.poses[k], a.poses[k + 1], a.commands[k]);
        let u = model.wheel_speeds(cmd[0], cmd[1]);
        let x = ddp_core::Dynamics::step(&model, &ddp_core::Vector::<3>::new(p[0], p[1], p[2]), &u);
        worst = worst.max((x[0] - q[0]).hypot(x[1] - q[1]));
    }
    assert!(worst > 1e-4 && worst < 0.03, "one-step model error {worst}");
}

#[test]
fn both_controllers_reach_the_goal_and_safe_cddp_keeps_more_clearance() {
    // Five paired episodes (the same noise for both controllers). The Waffle Pi's inflated first
    // disc binds the plan; Safe-CDDP's margins (about 0.84 sigma) keep it further off.
    let config = TurtlebotConfig::default();
    let e = run_experiment(&config, 5, 11, 0.8, &|| {}).unwrap();
    assert_eq!(e.cddp.len(), 5);
    assert_eq!(e.safe.len(), 5);
    for (a, b) in e.cddp.iter().zip(&e.safe) {
        assert_eq!(a.seed, b.seed);
        assert_eq!(a.controller, Controller::Cddp);
    }
    assert_eq!(e.cddp[2].seed, episode_seed(11, 2));
    assert_eq!(e.safe_summary.reached, 5, "{:?}", e.safe_summary);
    assert_eq!(e.cddp_summary.reached, 5, "{:?}", e.cddp_summary);
    for r in e.cddp.iter().chain(&e.safe) {
        assert!(r.final_error < 0.1, "{}", r.final_error);
        // Min clearance is the min over the discs and not below what rapier lets through.
        let m = r.min_clearance_per_disc.iter().copied().fold(f64::INFINITY, f64::min);
        assert_eq!(r.min_clearance, m);
        assert!(r.min_clearance > -0.02);
        // The plan keeps the centre about on or outside the inflated circle (noise aside).
        assert!(r.min_constraint_margin > -0.03, "{}", r.min_constraint_margin);
    }
    // CDDP's plan binds: its centre comes within 1.5 cm of the inflated circle.
    assert!(
        e.cddp_summary.min_constraint_margin.mean < 0.015,
        "{:?}",
        e.cddp_summary.min_constraint_margin
    );
    let (c, s) = (&e.cddp_summary.min_clearance, &e.safe_summary.min_clearance);
    assert!(s.mean > c.mean + 0.005, "Safe-CDDP {} vs CDDP {}", s.mean, c.mean);
    assert!(e.safe_wider >= 4, "{}", e.safe_wider);
    // The JSON carries the same figures and histograms that count every episode.
    let v = experiment_json(&e, false);
    assert_eq!(
        v["summary"]["safe_cddp"]["min_clearance"]["mean"].as_f64(),
        Some(s.mean)
    );
    let h: u64 = v["histogram"]["cddp"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .sum();
    assert_eq!(h, 5);
}

#[test]
fn histogram_counts_every_value_once() {
    // Bins [0, 0.05) and [0.05, 0.1); outside values go to the end bins, 0.05 to the upper one.
    let h = histogram(&[-1.0, 0.0, 0.049, 0.05, 0.1, 5.0], 0.0, 0.1, 2);
    assert_eq!(h, vec![3, 3]);
}

/// `e` without its measured wall times (the solve times and their statistics).
fn without_solve_times(e: &Experiment) -> Experiment {
    let mut e = e.clone();
    for r in e.cddp.iter_mut().chain(e.safe.iter_mut()) {
        r.solve_ms.clear();
    }
    for s in [&mut e.cddp_summary, &mut e.safe_summary] {
        (s.step_solve_ms, s.first_solve_ms) = (Stats::default(), Stats::default());
    }
    e
}

/// The JSON `v` without the measured fields (`solve_ms`, `step_solve_ms`, `first_solve_ms`, `wall_s`).
fn json_without_times(v: &serde_json::Value) -> serde_json::Value {
    match v {
        serde_json::Value::Object(m) => m
            .iter()
            .filter(|(k, _)| !["solve_ms", "step_solve_ms", "first_solve_ms", "wall_s"].contains(&k.as_str()))
            .map(|(k, v)| (k.clone(), json_without_times(v)))
            .collect(),
        serde_json::Value::Array(a) => a.iter().map(json_without_times).collect(),
        other => other.clone(),
    }
}

#[test]
fn sweep_tasks_through_json_equal_run_experiment_apart_from_solve_times() {
    let config = TurtlebotSweepConfig {
        runs: 2,
        seed: 7,
        ..TurtlebotSweepConfig::default()
    };
    let specs = sweep::tasks(&config).unwrap();
    assert_eq!(specs.len(), 4);
    assert_eq!(specs[0].seed, specs[1].seed, "common random numbers per episode");
    assert_eq!(specs[2].seed, episode_seed(7, 1));
    // Every task and run through JSON, as on another executor.
    let runs: Vec<TurtlebotRun> = specs
        .iter()
        .map(|t| {
            let t: EpisodeTask = serde_json::from_str(&serde_json::to_string(t).unwrap()).unwrap();
            let r = sweep::run_task(&t).unwrap();
            serde_json::from_str(&serde_json::to_string(&r).unwrap()).unwrap()
        })
        .collect();
    let swept = sweep::aggregate(&config, &runs).unwrap();
    let whole = run_experiment(&config.turtlebot().unwrap(), 2, 7, 0.8, &|| {}).unwrap();
    assert_eq!(without_solve_times(&swept), without_solve_times(&whole));
    for r in swept.cddp.iter().chain(&swept.safe) {
        assert_eq!(r.solve_ms.len(), r.steps, "the first solve, then one per later step");
    }
    let (a, b) = (sweep::json(&config, &swept, 1.0), sweep::json(&config, &whole, 2.0));
    assert_eq!(a["wall_s"], 1.0);
    assert_eq!(json_without_times(&a), json_without_times(&b));
    assert_eq!(
        json_without_times(&a),
        json_without_times(&experiment_json(&whole, false))
    );
    assert!(sweep::report(&config, &swept, 1.0).contains("paired episodes; 1.0 s wall."));
    // Results out of task order are refused, naming the first misplaced one.
    let mut swapped = runs.clone();
    swapped.swap(0, 1);
    let e = sweep::aggregate(&config, &swapped).unwrap_err().to_string();
    assert!(e.contains("results[0]"), "{e}");
    let e = sweep::aggregate(&config, &runs[..3]).unwrap_err().to_string();
    assert!(e.contains("results") && e.contains("4 tasks, got 3"), "{e}");
}

#[test]
fn bad_sweep_configurations_name_the_field() {
    let bad = |c: TurtlebotSweepConfig, field: &str| {
        let e = sweep::tasks(&c).unwrap_err();
        assert!(matches!(e, Error::Invalid { .. }), "{e}");
        assert!(e.to_string().starts_with(field), "{e} should name {field}");
    };
    let d = TurtlebotSweepConfig::default;
    bad(TurtlebotSweepConfig { runs: 0, ..d() }, "runs");
    bad(TurtlebotSweepConfig { beta: 1.0, ..d() }, "beta");
    bad(TurtlebotSweepConfig { beta: f64::NAN, ..d() }, "beta");
    bad(
        TurtlebotSweepConfig {
            sigma_xy: Some(-0.1),
            ..d()
        },
        "sigma_xy",
    );
    bad(
        TurtlebotSweepConfig {
            sigma_theta: Some(f64::INFINITY),
            ..d()
        },
        "sigma_theta",
    );
    bad(
        TurtlebotSweepConfig {
            sigma_w_xy: Some(-1.0),
            ..d()
        },
        "sigma_w_xy",
    );
    // JSON: `{}` is the binary's default; names are read like `--robot`; unknown fields are named.
    let parse = serde_json::from_str::<TurtlebotSweepConfig>;
    assert_eq!(parse("{}").unwrap(), d());
    assert_eq!(parse(r#"{"robot": "burger"}"#).unwrap().robot, Turtlebot::Burger);
    assert_eq!(parse(r#"{"robot": "waffle"}"#).unwrap().robot, Turtlebot::WafflePi);
    let e = parse(r#"{"robot": "roomba"}"#).unwrap_err().to_string();
    assert!(e.contains("robot is invalid"), "{e}");
    let e = parse(r#"{"episodes": 3}"#).unwrap_err().to_string();
    assert!(e.contains("unknown field `episodes`"), "{e}");
    // A task is refused whole: an unknown field, or a bad configuration when it runs.
    let task = sweep::tasks(&TurtlebotSweepConfig { runs: 1, ..d() })
        .unwrap()
        .remove(1);
    let mut v = serde_json::to_value(&task).unwrap();
    v["config"]["horizon"] = 0.into();
    let t: EpisodeTask = serde_json::from_value(v.clone()).unwrap();
    assert!(sweep::run_task(&t).unwrap_err().to_string().contains("horizon"));
    v["config"]["horizn"] = 90.into();
    let e = serde_json::from_value::<EpisodeTask>(v).unwrap_err().to_string();
    assert!(e.contains("horizn"), "{e}");
}
