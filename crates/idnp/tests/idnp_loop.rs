//! The loop of Algorithm 1 wired end to end: an iteration whose waypoints cross the wall splits
//! exactly the cells of the failed waypoints (time index and successor) and nothing else; the
//! fixed grid keeps its cells; the adaptive run then finds a collision-free trajectory through
//! the narrow passage that the coarse grid cannot resolve; bad initial states are errors naming
//! `x0`.

use std::collections::BTreeSet;
use std::sync::Arc;

use ddp_core::Vector;
use idnp::idnp::{check_initial_state, Idnp, IdnpSettings, Variant};
use idnp::inverse::{inverse_map, InfeasibleReason};
use idnp::scene::{Config, Scene};

/// A start above the wall's middle: the lower corridor is out of reach within the horizon, so
/// the waypoints must use the passage.
fn upper_start(scene: &Scene, settings: &IdnpSettings) -> Vector<10> {
    let z0 = [2.0, 2.5];
    let nominal = Config::new(z0[0] - 1.0, z0[1], 0.0, 0.5, -1.0);
    let q = inverse_map(scene, &settings.inverse, &nominal, z0, 0).expect("a free start");
    Scene::state_at_rest(&q)
}

fn leaves(g: &idnp::quadtree::QuadGrid) -> BTreeSet<usize> {
    g.leaves().iter().copied().collect()
}

#[test]
fn an_infeasible_iteration_splits_exactly_the_cells_of_the_failed_waypoints() {
    let scene = Arc::new(Scene::narrow_passage());
    let settings = IdnpSettings::default();
    let x0 = upper_start(&scene, &settings);
    let mut run = Idnp::new(scene.clone(), settings, Variant::Adaptive, x0).unwrap();
    let before: Vec<BTreeSet<usize>> = run.grids().iter().map(leaves).collect();
    let initial = run.grids().to_vec();
    let r = run.iterate().unwrap();
    // The coarse grid has no free point in the passage: the waypoints cross a wall, and the
    // inverse mapping reports those waypoints (no NLP is run).
    assert!(!r.inverse_failures.is_empty());
    assert!(r.nlp.is_none());
    for f in &r.inverse_failures {
        assert_eq!(r.waypoints[f.stage], f.waypoint);
        assert!(
            matches!(f.reason, InfeasibleReason::Collision { distance, .. } if distance < settings.inverse.min_clearance)
        );
    }
    // Expected: per failure at stage j, the leaves of G_j and G_{j+1} meeting the square of
    // half-side `refinement_radius` around the waypoint.
    let rad = settings.refinement_radius;
    let mut expected: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); initial.len()];
    for f in &r.inverse_failures {
        let z = f.waypoint;
        for g in [f.stage, f.stage + 1] {
            if g < initial.len() {
                expected[g].extend(initial[g].leaves_intersecting([z[0] - rad, z[1] - rad], [z[0] + rad, z[1] + rad]));
            }
        }
    }
    let mut total = 0;
    for (j, g) in run.grids().iter().enumerate() {
        let gone: BTreeSet<usize> = before[j].difference(&leaves(g)).copied().collect();
        assert_eq!(gone, expected[j], "grid {j}");
        assert_eq!(g.leaf_count(), before[j].len() + 3 * expected[j].len(), "grid {j}");
        total += expected[j].len();
    }
    assert!(total > 0);
    assert_eq!(r.grid_changes, total);

    // The fixed grid meets the same failures (same first DP) and keeps its cells.
    let mut fixed = Idnp::new(scene.clone(), settings, Variant::FixedGrid, x0).unwrap();
    let rf = fixed.iterate().unwrap();
    assert_eq!(rf.waypoints, r.waypoints);
    assert!(rf.grid_changes > 0);
    for (j, g) in fixed.grids().iter().enumerate() {
        assert_eq!(leaves(g), before[j], "fixed grid {j} changed");
    }
}

#[test]
fn adaptive_run_goes_through_the_passage_and_the_result_is_collision_free() {
    let scene = Arc::new(Scene::narrow_passage());
    let settings = IdnpSettings::default();
    let x0 = upper_start(&scene, &settings);
    let mut run = Idnp::new(scene.clone(), settings, Variant::Adaptive, x0).unwrap();
    let out = run.run().unwrap();
    assert!(out.success(), "{:?}", out.termination);
    assert!(out.iterations.len() >= 2, "the coarse grid alone cannot solve it");
    let traj = out.trajectory().unwrap();
    // Check the result independently of the NLP's own check: every knot and 8 sub-steps clear.
    let (hits, clearance) = scene.check_trajectory(&traj.xs, 8, 1e-3);
    assert!(hits.is_empty(), "collisions at {hits:?}");
    assert!(clearance > -1e-3);
    let tcp_end = scene.robot.tcp_position(traj.xs.last().unwrap());
    assert!(scene.goal.distance(tcp_end) <= settings.nlp.goal_tolerance);
    // It went through the passage: some TCP between the walls at the passage's height.
    let p = scene.passage.unwrap();
    assert!(traj
        .tcp_path(&scene)
        .iter()
        .any(|z| z[0] > p[0][0] && z[0] < p[1][0] && z[1] > p[0][1] && z[1] < p[1][1]));
    // The grids were refined only where needed: fewer cells than the uniform grid one level down.
    let uniform_cells = 4 * scene.domain.cells[0] * scene.domain.cells[1] * (settings.dp.stages + 1);
    assert!(out.grid.cells < uniform_cells, "{} cells", out.grid.cells);
}

#[test]
fn bad_initial_states_are_errors_naming_x0() {
    let scene = Arc::new(Scene::narrow_passage());
    let settings = IdnpSettings::default();
    let good = upper_start(&scene, &settings);
    assert!(check_initial_state(&scene, &good).is_ok());
    let err = |x: Vector<10>| {
        Idnp::new(scene.clone(), settings, Variant::Adaptive, x)
            .err()
            .expect("an error")
            .to_string()
    };
    // In collision: the base inside the wall.
    let collide = Scene::state_at_rest(&Config::new(4.8, 0.0, 0.0, 0.3, -0.6));
    let e = err(collide);
    assert!(e.contains("x0") && e.contains("collides"), "{e}");
    let mut nan = good;
    nan[7] = f64::NAN;
    let e = err(nan);
    assert!(e.contains("x0"), "{e}");
    let far = Scene::state_at_rest(&Config::new(30.0, 0.0, 0.0, 0.3, -0.6));
    let e = err(far);
    assert!(e.contains("x0") && e.contains("outside"), "{e}");
    let mut bent = good;
    bent[3] = 3.0;
    let e = err(bent);
    assert!(e.contains("x0") && e.contains("joint q1"), "{e}");
    // The optimiser alone checks the same.
    let e = idnp::idnp::optimizer_alone(&scene, &settings, &collide, 5)
        .expect_err("an error")
        .to_string();
    assert!(e.contains("x0"), "{e}");
}

/// Regression (case 191 of the seed-1 experiment): a waypoint at the wall's corner is solved by
/// the fixed grid's penalties, and must be by refinement too. Without the 2:1 balance the coarse
/// leaf below the refined one kept interpolating its value from a corner inside the wall, and
/// the DP returned to the refined cell in every iteration.
#[test]
fn balanced_refinement_solves_the_corner_case_the_fixed_grid_solves() {
    let scene = Arc::new(Scene::narrow_passage());
    let settings = IdnpSettings::default();
    let z0 = [1.709896898811936, -1.6467486132674964];
    let nominal = Config::new(z0[0] - 1.0, z0[1], 0.0, 0.5, -1.0);
    let q = inverse_map(&scene, &settings.inverse, &nominal, z0, 0).unwrap();
    let x0 = Scene::state_at_rest(&q);
    let fixed = Idnp::new(scene.clone(), settings, Variant::FixedGrid, x0)
        .unwrap()
        .run()
        .unwrap();
    assert!(fixed.success() && fixed.iterations.len() > 1);
    let adaptive = Idnp::new(scene.clone(), settings, Variant::Adaptive, x0)
        .unwrap()
        .run()
        .unwrap();
    assert!(adaptive.success(), "{:?}", adaptive.termination);
    let t = adaptive.trajectory().unwrap();
    assert!(scene.check_trajectory(&t.xs, 8, 1e-3).0.is_empty());
}
