//! Prints every iteration of adaptive and fixed-grid IDNP and the NLP alone for one initial
//! condition: `cargo run --release -p idnp --example trace -- 12` (case 12 of the experiment with
//! seed 1) or `-- 2.0 1.5` (a TCP position).
use std::sync::Arc;

use idnp::experiment::{sample_initial_conditions, ExperimentConfig};
use idnp::idnp::{optimizer_alone, Idnp, IdnpSettings, Variant};
use idnp::inverse::inverse_map;
use idnp::scene::{Config, Scene};

fn main() -> idnp::Result<()> {
    let args: Vec<f64> = std::env::args().skip(1).filter_map(|a| a.parse().ok()).collect();
    let scene = Arc::new(Scene::narrow_passage());
    let settings = IdnpSettings::default();
    // One argument: case `i` of the experiment with seed 1; two: a TCP position.
    let q0 = if args.len() == 1 {
        let cfg = ExperimentConfig::default();
        let ics = sample_initial_conditions(&scene, &settings, cfg.region, args[0] as usize + 1, cfg.seed)?;
        Config::from_row_slice(&ics[args[0] as usize].q)
    } else {
        let z0 = if args.len() >= 2 {
            [args[0], args[1]]
        } else {
            [2.0, 2.5]
        };
        let nominal = Config::new(z0[0] - 1.0, z0[1], 0.0, 0.5, -1.0);
        inverse_map(&scene, &settings.inverse, &nominal, z0, 0).expect("initial configuration")
    };
    let x0 = Scene::state_at_rest(&q0);
    println!("q0 = {:?}", q0.as_slice());
    for variant in [Variant::Adaptive, Variant::FixedGrid] {
        let mut run = Idnp::new(scene.clone(), settings, variant, x0)?;
        let out = run.run()?;
        println!(
            "{:?}: {:?} after {} iterations, grid {:?}",
            variant,
            out.termination,
            out.iterations.len(),
            out.grid
        );
        for r in &out.iterations {
            let wp: Vec<String> = r
                .waypoints
                .iter()
                .map(|z| format!("({:.2},{:.2})", z[0], z[1]))
                .collect();
            println!(
                "  it {} cells {} dp {:.1} ms inv {:.1} ms nlp {:.1} ms, failures {}, changes {}",
                r.iteration,
                r.grid.cells,
                r.dp_time * 1e3,
                r.inverse_time * 1e3,
                r.nlp_time * 1e3,
                r.inverse_failures.len(),
                r.grid_changes
            );
            println!("    waypoints {}", wp.join(" "));
            for f in &r.inverse_failures {
                println!("    failure {:?}", f);
            }
            if let Some(n) = &r.nlp {
                println!(
                    "    nlp {} it {} collisions {:?} clearance {:.3} missed {:?} goal {:.3} speed {:.3} success {}",
                    n.status,
                    n.iterations,
                    n.colliding_knots,
                    n.min_clearance,
                    n.missed_waypoints,
                    n.goal_distance,
                    n.final_speed,
                    n.success
                );
            }
        }
    }
    let alone = optimizer_alone(&scene, &settings, &x0, 400)?;
    println!(
        "alone: {} it {} collisions {:?} clearance {:.3} goal {:.3} speed {:.3} success {} time {:.2}s",
        alone.status,
        alone.iterations,
        alone.colliding_knots,
        alone.min_clearance,
        alone.goal_distance,
        alone.final_speed,
        alone.success,
        alone.solve_time
    );
    Ok(())
}
