//! Degenerate input gives defined results, never NaN or a panic.

use bezier::*;

#[test]
fn all_points_coincident() {
    let p = Point::new(2.0, -1.0);
    let c = CubicBez::new(p, p, p, p);
    assert_eq!(c.arclen(1e-10), 0.0);
    assert_eq!(c.arclen_simpson(1e-10), 0.0);
    assert_eq!(c.inv_arclen(0.5, 1e-10), 0.0);
    assert_eq!(c.curvature(0.3), 0.0);
    assert_eq!(c.tangent(0.3), None);
    assert_eq!(c.bounding_box(), Rect::from_point(p));
    assert!(c.extrema().is_empty());
    let ts = c.resample_uniform(5, 1e-9);
    assert_eq!(ts, vec![0.0, 0.25, 0.5, 0.75, 1.0]);
    let b = Bezier::new([p; 6]);
    assert_eq!(b.arclen(1e-10), 0.0);
    assert_eq!(b.curvature(0.5), 0.0);
    let (l, r) = b.subdivide(0.3);
    assert_eq!(l.points, [p; 6]);
    assert_eq!(r.points, [p; 6]);
    let q = QuadBez::new(p, p, p);
    assert_eq!(q.arclen(1e-10), 0.0);
}

#[test]
fn coincident_end_control_points() {
    // p0 = p1: zero speed at t = 0; everything stays finite.
    let c = CubicBez::new((0.0, 0.0), (0.0, 0.0), (1.0, 2.0), (3.0, 0.0));
    assert!(c.arclen(1e-10).is_finite());
    assert_eq!(c.curvature(0.0), 0.0);
    let t = c.tangent(0.0).unwrap();
    assert!((t.x - 1.0 / 5f64.sqrt()).abs() < 1e-12 && (t.y - 2.0 / 5f64.sqrt()).abs() < 1e-12);
    for i in 0..=10 {
        let s = c.arclen(1e-10) * i as f64 / 10.0;
        let u = c.inv_arclen(s, 1e-10);
        assert!(u.is_finite());
        assert!((c.arclen_range(0.0, u, 1e-12) - s).abs() < 1e-9);
    }
}

#[test]
fn cusp_inverse_arclen_and_resampling() {
    // A real cusp at t = 1/2 (speed exactly zero there).
    let c = CubicBez::new((0.0, 0.0), (1.0, 1.0), (0.0, 1.0), (1.0, 0.0));
    let len = c.arclen(1e-12);
    let ts = c.resample_uniform(21, 1e-10);
    assert_eq!(ts.len(), 21);
    for (i, &t) in ts.iter().enumerate() {
        assert!((c.arclen_range(0.0, t, 1e-12) - len * i as f64 / 20.0).abs() < 1e-9);
    }
    assert!(ts.windows(2).all(|w| w[0] <= w[1]));
}

#[test]
fn nan_input_propagates_or_is_rejected() {
    let c = CubicBez::new((f64::NAN, 0.0), (1.0, 1.0), (2.0, 1.0), (3.0, 0.0));
    assert!(c.arclen(1e-9).is_nan());
    let _ = c.inv_arclen(1.0, 1e-9); // no panic, no hang
    let _ = c.bounding_box();
    let _ = c.resample_uniform(10, 1e-9);
    assert!(matches!(
        CubicBez::try_new((f64::NAN, 0.0), (1.0, 1.0), (2.0, 1.0), (3.0, 0.0)),
        Err(Error::NonFinite {
            field: "points",
            index: 0
        })
    ));
    assert!(matches!(BezierDyn::new(vec![]), Err(Error::TooFew { .. })));
    assert!(matches!(
        Spline::catmull_rom(&[Point::new(0.0, 0.0), Point::new(f64::INFINITY, 0.0)]),
        Err(Error::NonFinite {
            field: "waypoints",
            index: 1
        })
    ));
    assert!(matches!(
        Spline::catmull_rom(&[Point::new(0.0, 0.0)]),
        Err(Error::TooFew { field: "waypoints", .. })
    ));
    assert!(matches!(
        SigmoidProfile::with_max_speed(1.0, -1.0, 0.5, 1.0),
        Err(Error::InvalidParameter { field: "m", .. })
    ));
    assert!(matches!(
        SigmoidProfile::with_max_speed(1.0, 1.0, 0.5, 0.0),
        Err(Error::InvalidParameter { field: "max_speed", .. })
    ));
    assert!(matches!(
        SigmoidProfile::new(1.0, 1.0, f64::NAN, 1.0),
        Err(Error::NonFinite { field: "k", .. })
    ));
    // Odd accuracies: NaN, zero, negative, infinite.
    let ok = CubicBez::new((0.0, 0.0), (1.0, 1.0), (2.0, 1.0), (3.0, 0.0));
    let r = ok.arclen(1e-12);
    for acc in [f64::NAN, 0.0, -1.0] {
        assert!((ok.arclen(acc) - r).abs() < 1e-9);
    }
    assert!(ok.arclen(f64::INFINITY).is_finite());
}

#[test]
fn zero_length_spline_trajectory_stays_put() {
    let p = Point::new(1.0, 1.0);
    let spline = Spline::catmull_rom(&[p, p, p]).unwrap();
    let traj = Trajectory::with_sigmoid(spline, 10.0, 0.5, 1.0).unwrap();
    assert_eq!(traj.duration(), 0.0);
    let (x, u) = traj.unicycle(0.1, 5).unwrap();
    assert!(x.iter().all(|s| s[0] == 1.0 && s[1] == 1.0 && s[2].is_finite()));
    assert!(u.iter().all(|c| c[0] == 0.0 && c[1] == 0.0));
    assert_eq!(traj.jerk_cost_integral(1e-8), 0.0);
    assert_eq!(traj.jerk_cost_discrete(50), 0.0);
    assert_eq!(traj.curvature_sum(50), 0.0);
    assert!(matches!(
        traj.unicycle(0.0, 5),
        Err(Error::InvalidParameter { field: "dt", .. })
    ));
}
