//! Adaptive IDNP from one start behind the wall: the passage is found after one refinement.
use std::sync::Arc;

use idnp::idnp::{Idnp, IdnpSettings, Variant};
use idnp::inverse::inverse_map;
use idnp::scene::{Config, Scene};

fn main() -> idnp::Result<()> {
    // The planar satellite with a 2-link arm among four rectangles with a narrow passage.
    let scene = Arc::new(Scene::narrow_passage());
    let settings = IdnpSettings::default();
    // Start at rest with the TCP at (3.1, 1.85): the wall is ahead, the passage above.
    let guess = Config::new(2.1, 1.85, 0.0, 0.5, -1.0);
    let q0 = inverse_map(&scene, &settings.inverse, &guess, [3.1, 1.85], 0).expect("a free start");
    let x0 = Scene::state_at_rest(&q0);

    // Algorithm 1: DP on quadtree grids, inverse mapping, constrained DDP, refinement.
    let mut idnp = Idnp::new(scene.clone(), settings, Variant::Adaptive, x0)?;
    let outcome = idnp.run()?;
    assert!(outcome.success());
    let trajectory = outcome.trajectory().expect("a solution");
    assert!(trajectory.colliding_knots.is_empty());
    assert!(trajectory.goal_distance <= settings.nlp.goal_tolerance);
    // The first DP crossed the wall where the grid cannot see the passage; refinement split
    // cells around it.
    assert!(outcome.iterations.len() >= 2);
    assert!(outcome.grid.cells > 13 * 48);
    println!(
        "solved in {} iterations with {} DP cells",
        outcome.iterations.len(),
        outcome.grid.cells
    );
    Ok(())
}
