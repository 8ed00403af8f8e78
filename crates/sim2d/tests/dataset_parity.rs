//! The sub-goal network is trained on `subgoal-infer`'s synthetic costmaps and runs on the
//! simulation's lidar costmaps: both must use the same grid and the same inflation.

use sim2d::perception::PerceptionParams;
use subgoal_infer::dataset::DatasetParams;
use subgoal_infer::grid::GridGeometry;

#[test]
fn dataset_costmaps_are_inflated_like_the_simulation() {
    let sim = PerceptionParams::default();
    let data = DatasetParams::default();
    assert_eq!(sim.inscribed_radius, data.inscribed_radius, "inscribed_radius");
    assert_eq!(sim.inflation_radius, data.inflation_radius, "inflation_radius");
    assert_eq!(sim.cost_scaling, data.cost_scaling, "cost_scaling");
}

#[test]
fn dataset_grid_is_the_simulation_grid() {
    let sim = PerceptionParams::default();
    let grid = GridGeometry::ddpen([0.0, 0.0]);
    assert_eq!((sim.cells, sim.cells), (grid.width(), grid.height()));
    assert_eq!(sim.resolution, grid.resolution());
}
