//! Inverse mapping (eq. 5): reachable waypoints are met exactly, close to the previous
//! configuration and clear of obstacles; unreachable ones are reported with their stage,
//! waypoint and reason.

use idnp::inverse::{inverse_map, map_waypoints, InfeasibleReason, InverseSettings};
use idnp::scene::{Body, Config, Scene};

fn start() -> Config {
    Config::new(1.5, 1.5, 0.1, 0.5, -1.0)
}

#[test]
fn reaches_a_reachable_waypoint_close_to_the_previous_configuration() {
    let scene = Scene::narrow_passage();
    let s = InverseSettings::default();
    let q_prev = start();
    let z0 = scene.tcp(&q_prev);
    for dz in [[0.3, 0.2], [-0.4, 0.5], [0.6, -0.6], [0.0, 0.0]] {
        let z = [z0[0] + dz[0], z0[1] + dz[1]];
        let q = inverse_map(&scene, &s, &q_prev, z, 3).expect("reachable");
        let tcp = scene.tcp(&q);
        assert!(
            (tcp[0] - z[0]).hypot(tcp[1] - z[1]) <= s.tcp_tolerance,
            "TCP {tcp:?} vs {z:?}"
        );
        let (clearance, _, _) = scene.clearance(&Scene::state_at_rest(&q));
        assert!(clearance >= s.min_clearance, "clearance {clearance}");
        assert!(scene.limit_violation(&q).is_none());
        // Close to the previous configuration: no more motion than the TCP step needs.
        let step = (dz[0] * dz[0] + dz[1] * dz[1]).sqrt();
        assert!(
            (q - q_prev).norm() <= 2.0 * step + 0.2,
            "moved {} for a step of {step}",
            (q - q_prev).norm()
        );
    }
    // The zero step keeps the configuration (up to the margin term, inactive here).
    let q = inverse_map(&scene, &s, &q_prev, z0, 1).unwrap();
    assert!((q - q_prev).norm() < 1e-6);
}

#[test]
fn reports_unreachable_waypoints_with_stage_and_reason() {
    let scene = Scene::narrow_passage();
    let s = InverseSettings::default();
    // Inside the wall: the last link collides.
    let q_prev = Config::new(3.3, 0.0, 0.0, 0.2, -0.4);
    let z = [4.8, 0.0];
    let f = inverse_map(&scene, &s, &q_prev, z, 5).unwrap_err();
    assert_eq!(f.stage, 5);
    assert_eq!(f.waypoint, z);
    match f.reason {
        InfeasibleReason::Collision {
            body,
            obstacle,
            distance,
        } => {
            assert_eq!(body, Body::Link2);
            assert_eq!(obstacle, 0);
            assert!(distance < 0.0);
        }
        other => panic!("expected a collision, got {other:?}"),
    }
    // Far beyond what the base can travel in a stage.
    let f = inverse_map(&scene, &s, &start(), [8.0, -3.0], 2).unwrap_err();
    assert!(matches!(f.reason, InfeasibleReason::OutOfReach { base_step } if base_step > s.max_base_step));
    // Beyond the base limits.
    let q_edge = Config::new(10.8, 0.0, 0.0, 0.0, 0.0);
    let f = inverse_map(&scene, &s, &q_edge, [13.0, 0.0], 7).unwrap_err();
    assert!(matches!(f.reason, InfeasibleReason::Limit { which: "base x" }), "{f:?}");
}

#[test]
fn a_waypoint_sequence_maps_or_names_every_failure() {
    let scene = Scene::narrow_passage();
    let s = InverseSettings::default();
    let q0 = Config::new(2.6, 1.6, 0.0, 0.5, -1.0);
    let z0 = scene.tcp(&q0);
    let good: Vec<[f64; 2]> = (0..5)
        .map(|j| [z0[0] - 0.2 * j as f64, z0[1] + 0.1 * j as f64])
        .collect();
    let qs = map_waypoints(&scene, &s, &q0, &good).expect("all reachable");
    assert_eq!(qs.len(), good.len());
    for (q, z) in qs.iter().zip(&good) {
        let t = scene.tcp(q);
        assert!((t[0] - z[0]).hypot(t[1] - z[1]) <= s.tcp_tolerance);
    }
    // Two waypoints inside the wall: both reported, with their indices.
    let bad = vec![z0, [3.8, 1.0], [4.6, 1.0], [4.9, 1.0], [4.0, 1.5]];
    let failures = map_waypoints(&scene, &s, &q0, &bad).unwrap_err();
    let stages: Vec<usize> = failures.iter().map(|f| f.stage).collect();
    assert_eq!(stages, vec![2, 3]);
    assert_eq!(failures[1].waypoint, [4.9, 1.0]);
}
