//! The NLP block: both optimisers follow free-space waypoints, and the collision check finds a
//! trajectory through a wall.

use std::sync::Arc;

use idnp::nlp::{self, NlpSettings, NlpSolver};
use idnp::scene::{Config, Scene};

fn waypoints() -> Vec<Config> {
    // Three stages sliding the base 0.3 m per second along -y in free space.
    (0..4)
        .map(|j| Config::new(0.5, 1.5 - 0.3 * j as f64, 0.0, 0.5, -1.0))
        .collect()
}

#[test]
fn both_optimisers_follow_free_space_waypoints() {
    let scene = Arc::new(Scene::narrow_passage());
    let qs = waypoints();
    let x0 = Scene::state_at_rest(&qs[0]);
    for solver in [NlpSolver::SafeCddp, NlpSolver::Penalty] {
        let settings = NlpSettings {
            solver,
            max_iterations: 60,
            ..NlpSettings::default()
        };
        let out = nlp::solve(&scene, &settings, &x0, &qs).unwrap();
        assert_eq!(out.xs.len(), 3 * settings.knots_per_stage + 1);
        assert!(out.colliding_knots.is_empty(), "{solver:?}: {:?}", out.colliding_knots);
        assert!(
            out.missed_waypoints.is_empty(),
            "{solver:?}: {:?}",
            out.missed_waypoints
        );
        let end = scene.robot.tcp_position(out.xs.last().unwrap());
        let goal = scene.tcp(qs.last().unwrap());
        assert!(
            (end[0] - goal[0]).hypot(end[1] - goal[1]) < 0.15,
            "{solver:?} ends at {end:?}"
        );
        // Far from the goal ball: not a solution of the planning problem.
        assert!(!out.success);
    }
    let err = nlp::solve(&scene, &NlpSettings::default(), &x0, &qs[..1])
        .unwrap_err()
        .to_string();
    assert!(err.contains("qs"), "{err}");
}

#[test]
fn collision_check_finds_a_trajectory_through_the_wall() {
    let scene = Scene::narrow_passage();
    // The base slides through the wall at y = 0 (the wall spans x in [4.3, 5.3]).
    let xs: Vec<_> = (0..=10)
        .map(|k| Scene::state_at_rest(&Config::new(3.0 + 0.3 * k as f64, 0.0, 0.0, 0.0, 0.0)))
        .collect();
    let (hits, worst) = scene.check_trajectory(&xs, 4, 1e-3);
    assert!(!hits.is_empty());
    assert!(worst < -0.3);
    // A slide along y in free space is clean, at the knots and between them.
    let xs: Vec<_> = (0..=10)
        .map(|k| Scene::state_at_rest(&Config::new(0.5, -1.5 + 0.3 * k as f64, 0.0, 0.5, -1.0)))
        .collect();
    let (hits, worst) = scene.check_trajectory(&xs, 4, 1e-3);
    assert!(hits.is_empty(), "{hits:?}");
    assert!(worst > 0.0);
}
