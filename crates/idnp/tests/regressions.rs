//! Regression tests of inputs the fuzzer (`fuzz/`, target `idnp_scene`) found to panic, abort or
//! hang; each is named after what it guards. The fuzzer's inputs are under
//! `tests/regressions/idnp_scene/` and replayed through the fuzz target by
//! `crates/fuzz-harness/tests/regressions.rs`.

use std::sync::Arc;

use idnp::idnp::{Idnp, IdnpSettings, Variant};
use idnp::scene::{Obstacle, Scene};

fn field(e: idnp::Error) -> String {
    match e {
        idnp::Error::Invalid { field, .. } => field,
        other => panic!("expected an invalid-input error, got {other}"),
    }
}

#[test]
fn polygon_of_coincident_points_is_an_error() {
    // parry's convex hull asserted on this (every point the same).
    let e = Obstacle::polygon(&[[0.625, 0.625]; 3]).unwrap_err();
    assert!(e.to_string().contains("degenerate polygon"), "{e}");
    assert_eq!(field(e), "vertices");
    // Collinear, and coincident but for rounding noise far below the size: rejected too.
    assert!(Obstacle::polygon(&[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [0.5, 0.5]]).is_err());
    assert!(Obstacle::polygon(&[[1e6, 1e6], [1e6, 1e6], [1e6 + 1e-9, 1e6]]).is_err());
    // A thin but real triangle is still a polygon.
    assert_eq!(
        Obstacle::polygon(&[[0.0, 0.0], [1.0, 0.0], [0.5, 1e-3]])
            .unwrap()
            .vertices()
            .len(),
        3
    );
}

/// The error of building the loop (`Idnp` has no `Debug`, so no `unwrap_err`).
fn build_error(scene: &Arc<Scene>, settings: IdnpSettings) -> idnp::Error {
    match Idnp::new(scene.clone(), settings, Variant::Adaptive, x0()) {
        Ok(_) => panic!("the input was accepted"),
        Err(e) => e,
    }
}

fn x0() -> ddp_core::Vector<10> {
    let mut x = ddp_core::Vector::<10>::zeros();
    x[0] = 1.0;
    x[1] = -2.0;
    x[3] = 0.3;
    x[4] = -0.6;
    x
}

#[test]
fn domain_with_too_many_root_cells_is_an_error_before_allocating() {
    let mut scene = Scene::narrow_passage();
    scene.domain.cells = [1 << 40, 1 << 40];
    let e = build_error(&Arc::new(scene.clone()), IdnpSettings::default());
    assert_eq!(field(e), "domain.cells");
    scene.domain.cells = [usize::MAX, 3];
    assert_eq!(field(scene.validate().unwrap_err()), "domain.cells");
    scene.domain.cells = [8, 6];
    scene.domain.cell_size = 1e308;
    assert_eq!(field(scene.validate().unwrap_err()), "domain.cells[0]");
}

#[test]
fn deep_initial_grids_and_many_stages_are_errors_before_allocating() {
    let scene = Arc::new(Scene::narrow_passage());
    let settings = IdnpSettings {
        initial_level: 20,
        max_level: 20,
        ..IdnpSettings::default()
    };
    assert_eq!(field(build_error(&scene, settings)), "initial_level");
    let mut settings = IdnpSettings::default();
    settings.dp.stages = usize::MAX;
    assert_eq!(field(build_error(&scene, settings)), "dp.stages");
    settings.dp.stages = 12;
    settings.dp.steps_per_axis = (1 << 40) + 1;
    assert_eq!(field(build_error(&scene, settings)), "dp.steps_per_axis");
    // The benchmark's settings still build.
    assert!(Idnp::new(scene, IdnpSettings::default(), Variant::Adaptive, x0()).is_ok());
}
