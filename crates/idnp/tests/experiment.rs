//! A small experiment: adaptive IDNP solves every case the fixed grid solves, the results are a
//! function of the seed alone, and the table reports what was run.

use std::sync::Arc;

use idnp::experiment::{passage_resolving_level, run_experiment, sample_initial_conditions, ExperimentConfig};
use idnp::scene::Scene;

fn small() -> ExperimentConfig {
    let mut c = ExperimentConfig {
        seed: 3,
        initial_conditions: 4,
        optimizer_iterations: 30,
        ..ExperimentConfig::default()
    };
    c.settings.max_iterations = 4;
    c.settings.nlp.max_iterations = 40;
    c
}

#[test]
fn adaptive_never_solves_fewer_and_results_are_deterministic() {
    let scene = Arc::new(Scene::narrow_passage());
    let config = small();
    let a = run_experiment(&scene, &config, &|| {}).unwrap();
    assert_eq!(a.cases.len(), 4);
    for c in &a.cases {
        assert!(
            !c.fixed.success || c.adaptive.success,
            "case {} solved by the fixed grid only",
            c.index
        );
        assert!(c.fixed.iterations <= 4 && c.adaptive.iterations <= 4);
        // The fixed grid never splits; the adaptive one only grows.
        assert_eq!(c.fixed.grid.cells, a.summary.coarse_grid.cells);
        assert!(c.adaptive.grid.cells >= a.summary.coarse_grid.cells);
    }
    assert!(a.summary.fixed_not_adaptive.is_empty());
    assert!(a.summary.solved_adaptive >= a.summary.solved_fixed);
    assert!(a.summary.table().contains("163 / 254"));

    // Same seed, same results (wall times aside).
    let b = run_experiment(&scene, &config, &|| {}).unwrap();
    for (x, y) in a.cases.iter().zip(&b.cases) {
        assert_eq!(x.initial, y.initial);
        for (p, q) in [
            (&x.fixed, &y.fixed),
            (&x.adaptive, &y.adaptive),
            (&x.optimizer, &y.optimizer),
        ] {
            assert_eq!(
                (p.success, p.iterations, &p.termination, p.grid, p.nlp_solves),
                (q.success, q.iterations, &q.termination, q.grid, q.nlp_solves)
            );
        }
    }
}

#[test]
fn initial_conditions_depend_on_the_seed_only() {
    let scene = Scene::narrow_passage();
    let c = ExperimentConfig::default();
    let a = sample_initial_conditions(&scene, &c.settings, c.region, 20, 9).unwrap();
    let b = sample_initial_conditions(&scene, &c.settings, c.region, 20, 9).unwrap();
    let other = sample_initial_conditions(&scene, &c.settings, c.region, 20, 10).unwrap();
    assert_eq!(a, b);
    assert_ne!(a, other);
    for ic in &a {
        assert!(scene.clearance(&ic.state()).0 >= 0.1);
        let t = scene.tcp(&idnp::scene::Config::from_row_slice(&ic.q));
        assert!((t[0] - ic.tcp[0]).hypot(t[1] - ic.tcp[1]) < 1e-6);
    }
    assert!(sample_initial_conditions(&scene, &c.settings, [[5.0, 0.0], [1.0, 1.0]], 1, 0).is_err());
    // The passage is narrower than the coarse grid and resolved one level down.
    assert!(scene.passage_width() < scene.domain.spacing());
    assert_eq!(passage_resolving_level(&scene, &c.settings), Some(1));
}
