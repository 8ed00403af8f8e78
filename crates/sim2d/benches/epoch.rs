//! One optimisation epoch of the DDP planner (one iteration: derivatives, backward pass, line
//! search) on the unicycle with the cost of DDPEN eqs. (3)-(7), horizon N = 50, against a
//! costmap seen by the lidar in front of a cylinder. Paper: 75 ms per epoch.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use sim2d::perception::{Perception, PerceptionParams};
use sim2d::planner::{DdpParams, DdpPlanner, PlanRequest, Planner};
use sim2d::route::Route;
use sim2d::world::{LidarParams, RobotParams, Scan, World};
use sim2d::{Obstacle, Scenario};

fn bench(c: &mut Criterion) {
    let scenario = Scenario {
        name: "bench".into(),
        description: String::new(),
        route: Route::new(vec![[0.0, 0.0], [20.0, 0.0]]).unwrap(),
        obstacles: vec![Obstacle::Cylinder {
            center: [3.0, 0.4],
            radius: 1.0,
        }],
    };
    let mut world = World::new(&scenario, RobotParams::default(), [0.0, 0.0, 0.0], 0.02, 1).unwrap();
    let mut scan = Scan::default();
    let lidar = LidarParams::default();
    world.scan(&lidar, &mut scan);
    let mut perception = Perception::new(PerceptionParams::default()).unwrap();
    perception.update(&scan);

    let mut planner = DdpPlanner::new(DdpParams::default()).unwrap();
    let warm = |planner: &mut DdpPlanner, perception: &Perception, steps| {
        let req = PlanRequest {
            time: 0.0,
            state: [0.0, 0.0, 0.0],
            goal: [5.0, 0.0],
            far_goal: [15.0, 0.0],
            perception,
            steps_since_last: steps,
        };
        planner.plan(&req).map(|p| p.epoch_seconds.iter().sum::<f64>()).unwrap()
    };
    // Converge a little first so the measured cycles are warm-started ones, as in the loop.
    for k in 0..20 {
        warm(&mut planner, &perception, usize::from(k > 0));
    }
    c.bench_function("ddp planning cycle (4 epochs, N = 50)", |b| {
        b.iter(|| black_box(warm(&mut planner, &perception, 1)))
    });
    c.bench_function("costmap update (decay, marks, EDT, inflation)", |b| {
        b.iter(|| perception.update(black_box(&scan)))
    });
    c.bench_function("lidar scan (360 beams)", |b| {
        b.iter(|| world.scan(&lidar, black_box(&mut scan)))
    });
    c.bench_function("physics, one control period (5 steps)", |b| {
        b.iter(|| world.step(black_box([0.0, 0.0]), 0.1))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
