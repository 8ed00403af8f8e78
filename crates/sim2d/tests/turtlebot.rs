//! The Safe-CDDP Turtlebot experiment (Alcan and Kyrki (2022), §IV-C): geometry of the clearance,
//! the constraint inflation, determinism per seed, and Safe-CDDP against CDDP over a few episodes.

use safe_cddp::Constraint;
use sim2d::turtlebot::{
    episode_seed, experiment_json, footprint_clearance, histogram, run_episode, run_experiment, waffle_pi, Controller,
    Disc, Turtlebot, TurtlebotConfig, PAPER_DISCS,
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
