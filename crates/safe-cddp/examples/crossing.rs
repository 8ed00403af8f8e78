//! Moving obstacles: two discs cross the point robot's path to (3, 3); each is
//! tracked by a constant-velocity Kalman filter (the F and G of Queen Elizabeth's School (2022))
//! and its predicted position covariance is added to the robot's in the tightening, so its margin
//! grows along the horizon. Runs seeded episodes of plain CDDP (no tightening) and Safe-CDDP
//! (beta = 0.99) and prints collisions and successes, then the first plan's margins of one crossing
//! obstacle.
//!
//! ```text
//! cargo run --release -p safe-cddp --example crossing -- [episodes]
//! ```

use ddp_core::dims::{U2, U4};
use std::sync::Arc;

use ddp_core::{reference, Matrix, Vector};
use safe_cddp::constraints::CircleForm;
use safe_cddp::kalman::ObstacleTracker;
use safe_cddp::mpc::{MovingObstacle, Mpc, MpcSettings};
use safe_cddp::{Constraint, SafeCddpSolver, Settings, Tightening};

fn crossing() -> Vec<MovingObstacle> {
    let disc = |position, velocity| MovingObstacle {
        position,
        velocity,
        radius: 0.25,
        measurement_std: 0.02,
        filter_accel_std: 0.3,
        initial_velocity_std: 0.1,
    };
    vec![disc([2.2, 0.6], [-0.3, 0.3]), disc([0.4, 2.4], [0.25, -0.25])]
}

fn main() -> ddp_core::Result<()> {
    let episodes: u64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(40);
    let problem = reference::point_reach();
    let sigma_w = Matrix::<4, 4>::from_diagonal(&Vector::<4>::new(1e-5, 1e-5, 4e-5, 4e-5));
    let settings = MpcSettings {
        goal: Vector::<4>::new(3.0, 3.0, 0.0, 0.0),
        goal_radius: 0.15,
        iterations: 5,
        ..MpcSettings::default()
    };
    println!("{episodes} episodes per planner, two discs crossing the straight path");
    println!("| planner | episodes with a collision | collisions | reached the goal |");
    println!("|---|---:|---:|---:|");
    for (label, beta) in [("CDDP", None), ("Safe-CDDP beta 0.99", Some(0.99))] {
        let tightening = beta.map(|b| Tightening::new(b, sigma_w)).transpose()?;
        let mut mpc = Mpc::new(
            &problem,
            vec![],
            crossing(),
            Settings::default(),
            tightening,
            sigma_w,
            settings.clone(),
        )?;
        let (mut violated, mut collisions, mut successes) = (0, 0, 0);
        for seed in 0..episodes {
            let e = mpc.run_episode(seed)?;
            violated += usize::from(e.collisions > 0);
            collisions += e.collisions;
            successes += usize::from(e.success);
        }
        println!("| {label} | {violated} | {collisions} | {successes} |");
    }

    // The first plan's margin of the first crossing disc along the horizon.
    let o = &crossing()[0];
    let kf = ObstacleTracker::new(
        0.05,
        o.filter_accel_std,
        o.measurement_std,
        o.position,
        o.velocity,
        o.measurement_std,
        o.initial_velocity_std,
    )?;
    let circle =
        kf.moving_circle::<ddp_core::dims::Const<4>>(problem.horizon(), o.radius, [0, 1], CircleForm::Distance)?;
    let rows: Vec<Arc<dyn Constraint<U4, U2>>> = vec![Arc::new(circle)];
    let mut solver = SafeCddpSolver::new(&problem, rows, Settings::default())?;
    solver.solve(&problem)?;
    solver.set_tightening(Some(Tightening::new(0.99, sigma_w)?))?;
    solver.solve(&problem)?;
    println!("\nmargin of the first crossing disc in the first plan (m), by step:");
    for k in (0..problem.horizon()).step_by(10) {
        println!("  step {k:3}: {:.4}", solver.margins(k)[0]);
    }
    Ok(())
}
