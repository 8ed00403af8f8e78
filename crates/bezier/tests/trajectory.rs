//! Splines, the sigmoid profile and the time-parametrised trajectory.

use bezier::*;

fn waypoints() -> Vec<Point> {
    vec![
        Point::new(0.0, 0.0),
        Point::new(2.0, 1.0),
        Point::new(4.0, -1.0),
        Point::new(6.0, 0.5),
        Point::new(7.0, 3.0),
    ]
}

#[test]
fn splines_interpolate_and_have_their_continuity() {
    let w = waypoints();
    for s in [Spline::catmull_rom(&w).unwrap(), Spline::c2_natural(&w).unwrap()] {
        assert_eq!(s.waypoints(), w);
        assert!(s.continuity(1e-9) >= Continuity::C1);
    }
    assert_eq!(Spline::c2_natural(&w).unwrap().continuity(1e-9), Continuity::C2);
    let cl = Spline::c2_clamped(&w, Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)).unwrap();
    assert_eq!(cl.continuity(1e-9), Continuity::C2);
    assert!((cl.tangents()[0] - Vec2::new(1.0, 0.0)).hypot() < 1e-12);
    // A gap is reported with its index.
    let segs = vec![
        CubicBez::line((0.0, 0.0), (1.0, 0.0)),
        CubicBez::line((1.5, 0.0), (2.0, 0.0)),
    ];
    assert!(matches!(
        Spline::from_segments(segs),
        Err(Error::Discontinuous { index: 1, .. })
    ));
}

#[test]
fn sigmoid_profile_shape_and_bounds() {
    let p = SigmoidProfile::with_max_speed(10.0, 12.0, 0.5, 2.0).unwrap();
    assert!((p.distance(0.0)).abs() < 1e-15);
    assert!((p.distance(p.duration()) - 10.0).abs() < 1e-12);
    // Symmetric for k = 1/2.
    let tf = p.duration();
    assert!((p.distance(0.3 * tf) + p.distance(0.7 * tf) - 10.0).abs() < 1e-12);
    // The speed never exceeds the bound and peaks at k.
    let mut vmax: f64 = 0.0;
    for i in 0..=1000 {
        let (_, v, _, _) = p.derivatives(tf * i as f64 / 1000.0);
        vmax = vmax.max(v);
    }
    assert!(vmax <= 2.0 + 1e-12 && vmax > 2.0 - 1e-9);
    // Derivatives agree with finite differences.
    let h = 1e-5;
    for &frac in &[0.2, 0.5, 0.8] {
        let t = frac * tf;
        let (_, v, a, j) = p.derivatives(t);
        let fd = |f: &dyn Fn(f64) -> f64| (f(t + h) - f(t - h)) / (2.0 * h);
        assert!((fd(&|x| p.distance(x)) - v).abs() < 1e-6);
        assert!((fd(&|x| p.derivatives(x).1) - a).abs() < 1e-5);
        assert!((fd(&|x| p.derivatives(x).2) - j).abs() < 1e-4);
        assert!((p.time_at_distance(p.distance(t)) - t).abs() < 1e-9);
    }
    // m -> 0 is constant speed.
    let lin = SigmoidProfile::new(4.0, 0.0, 0.5, 2.0).unwrap();
    assert_eq!(lin.derivatives(1.0), (2.0, 2.0, 0.0, 0.0));
    let tiny = SigmoidProfile::new(4.0, 1e-7, 0.5, 2.0).unwrap();
    assert!((tiny.distance(1.0) - 2.0).abs() < 1e-12);
    // Bounding m by a speed limit.
    let m = SigmoidProfile::max_steepness(10.0, 0.5, 8.0, 2.0).unwrap();
    let at = SigmoidProfile::new(10.0, m, 0.5, 8.0).unwrap();
    assert!((at.peak_speed() - 2.0).abs() < 1e-9);
    assert!(SigmoidProfile::max_steepness(10.0, 0.5, 4.0, 2.0).is_err());
    // Asymmetric k: accelerate early.
    let early = SigmoidProfile::with_max_speed(10.0, 12.0, 0.3, 2.0).unwrap();
    assert!(early.distance(0.5 * early.duration()) > 5.0);
}

#[test]
fn trajectory_kinematics_match_finite_differences() {
    let spline = Spline::c2_natural(&waypoints()).unwrap();
    let traj = Trajectory::with_sigmoid(spline, 8.0, 0.5, 1.5).unwrap();
    let tf = traj.duration();
    let h = 1e-4;
    for frac in [0.13, 0.37, 0.5, 0.81] {
        let t = frac * tf;
        let s = traj.sample(t);
        let (m, p) = (traj.sample(t - h), traj.sample(t + h));
        let vel = (p.position - m.position) / (2.0 * h);
        let acc = (p.velocity - m.velocity) / (2.0 * h);
        let jerk = (p.acceleration - m.acceleration) / (2.0 * h);
        assert!((vel - s.velocity).hypot() < 1e-6, "velocity at {frac}");
        assert!((acc - s.acceleration).hypot() < 1e-5, "acceleration at {frac}");
        assert!(
            (jerk - s.jerk).hypot() < 1e-3 * (1.0 + s.jerk.hypot()),
            "jerk at {frac}"
        );
        assert!((s.velocity.hypot() - s.speed).abs() < 1e-12);
        assert!((s.yaw_rate - s.curvature * s.speed).abs() < 1e-12);
        let dh = (p.heading - m.heading) / (2.0 * h);
        assert!((dh - s.yaw_rate).abs() < 1e-5);
    }
    // Speed bound and end points.
    assert!((traj.sample(tf).position - Point::new(7.0, 3.0)).hypot() < 1e-9);
    assert_eq!(traj.sample(tf + 1.0).speed, 0.0);
}

#[test]
fn unicycle_and_car_rollouts_follow_the_reference() {
    let spline = Spline::catmull_rom(&waypoints()).unwrap();
    let traj = Trajectory::with_sigmoid(spline, 10.0, 0.5, 1.0).unwrap();
    let dt = 0.02;
    let n = (traj.duration() / dt).ceil() as usize;
    let (x, u) = traj.unicycle(dt, n).unwrap();
    assert_eq!((x.len(), u.len()), (n + 1, n));
    // Roll the unicycle out with the reference controls (ddp-core's Euler model).
    let mut s = x[0];
    let mut worst: f64 = 0.0;
    for k in 0..n {
        s = [
            s[0] + dt * u[k][0] * s[2].cos(),
            s[1] + dt * u[k][0] * s[2].sin(),
            s[2] + dt * u[k][1],
        ];
        worst = worst.max(((s[0] - x[k + 1][0]).powi(2) + (s[1] - x[k + 1][1]).powi(2)).sqrt());
        assert!((s[2] - x[k + 1][2]).abs() < 1e-9);
    }
    assert!(worst < 0.05, "unicycle drift {worst}");
    assert!(u.iter().all(|c| c[0] <= 1.0 + 1e-9));
    let (xc, uc) = traj.car(dt, n).unwrap();
    let mut s = xc[0];
    for k in 0..n {
        s = [
            s[0] + dt * s[3] * s[2].cos(),
            s[1] + dt * s[3] * s[2].sin(),
            s[2] + dt * uc[k][0],
            s[3] + dt * uc[k][1],
        ];
        assert!((s[3] - xc[k + 1][3]).abs() < 1e-9 && (s[2] - xc[k + 1][2]).abs() < 1e-9);
    }
    let end = xc[n];
    assert!((end[0] - 7.0).abs() < 0.1 && (end[1] - 3.0).abs() < 0.1);
}

#[test]
fn jerk_costs_agree_on_a_straight_line() {
    // On a straight path all jerk is tangential, so the paper's discrete cost converges to the integral.
    let spline = Spline::catmull_rom(&[Point::new(0.0, 0.0), Point::new(5.0, 0.0), Point::new(10.0, 0.0)]).unwrap();
    let traj = Trajectory::with_sigmoid(spline, 6.0, 0.5, 2.0).unwrap();
    let exact = traj.jerk_cost_integral(1e-10);
    let disc = traj.jerk_cost_discrete(4000);
    assert!((exact - disc).abs() < 1e-3 * exact, "{exact} vs {disc}");
    // Closed form: int (L/Tf^3 S''')^2 dT over the profile.
    let p = *traj.profile();
    let n = 20000;
    let dt = p.duration() / n as f64;
    let simpson: f64 = (0..=n)
        .map(|i| {
            let w = if i == 0 || i == n {
                1.0
            } else if i % 2 == 1 {
                4.0
            } else {
                2.0
            };
            w * p.derivatives(i as f64 * dt).3.powi(2)
        })
        .sum::<f64>()
        * dt
        / 3.0;
    assert!((simpson - exact).abs() < 1e-6 * exact, "{simpson} vs {exact}");
    assert_eq!(traj.curvature_sum(100), 0.0);
}

#[test]
fn optimiser_lowers_cost_and_keeps_continuity() {
    let w = [
        Point::new(0.0, 0.0),
        Point::new(1.0, 1.0),
        Point::new(2.0, 0.0),
        Point::new(3.5, 0.5),
    ];
    let settings = OptimizeSettings {
        max_iterations: 10,
        cost: SplineCost {
            samples: 40,
            ..SplineCost::default()
        },
        ..OptimizeSettings::default()
    };
    let r = optimize_spline(&w, &settings).unwrap();
    assert!(r.cost < r.initial_cost, "{} !< {}", r.cost, r.initial_cost);
    assert_eq!(r.spline.waypoints(), w.to_vec());
    assert!(r.spline.continuity(1e-9) >= Continuity::C1);
    let c2 = optimize_spline(
        &w,
        &OptimizeSettings {
            continuity: Continuity::C2,
            ..settings
        },
    )
    .unwrap();
    assert!(c2.cost <= c2.initial_cost);
    assert_eq!(c2.spline.continuity(1e-9), Continuity::C2);
}
