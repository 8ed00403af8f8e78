//! Short closed-loop runs (seconds of simulated time): the long Table I runs live in the
//! `ddpen-table` binary.

use std::sync::Arc;

use prost::Message;
use sim2d::batch::{run_batch, BatchOptions, Job};
use sim2d::log::{LogOptions, Recorder, Topics};
use sim2d::{run_scenario, run_scenario_with, Direction, Obstacle, Outcome, PlannerKind, Route, RunConfig, Scenario};

fn scenario(obstacles: Vec<Obstacle>) -> Scenario {
    Scenario {
        name: "short".into(),
        description: String::new(),
        route: Route::new(vec![[0.0, 0.0], [18.0, 0.0]]).unwrap(),
        obstacles,
    }
}

fn cube(center: [f64; 2]) -> Obstacle {
    Obstacle::Box {
        center,
        size: [2.0, 2.0],
        yaw: 0.0,
    }
}

#[test]
fn ddp_passes_a_cylinder_without_collision_both_ways() {
    let s = scenario(vec![Obstacle::Cylinder {
        center: [9.0, 0.5],
        radius: 1.0,
    }]);
    for direction in [Direction::Forward, Direction::Backward] {
        let r = run_scenario(
            &s,
            &RunConfig {
                direction,
                ..RunConfig::default()
            },
        )
        .unwrap();
        assert_eq!(r.outcome, Outcome::Completed, "{direction}");
        assert_eq!(r.collisions, 0, "{direction}");
        // 18 m at up to 1.5 m/s with a detour.
        assert!(r.time_s > 11.0 && r.time_s < 25.0, "{direction}: {} s", r.time_s);
        assert_eq!(r.epoch_ms.len(), 4 * r.trajectory.len());
        assert!(r.distance_m > 17.0);
    }
}

#[test]
fn ddp_stalls_in_a_u_trap_and_the_run_fails() {
    // Back wall of three cubes across the route at x = 10, arms of two cubes opening towards
    // the start.
    let mut obstacles: Vec<Obstacle> = [-2.0, 0.0, 2.0].iter().map(|&y| cube([10.0, y])).collect();
    for y in [-2.0, 2.0] {
        for x in [8.0, 6.0] {
            obstacles.push(cube([x, y]));
        }
    }
    let config = RunConfig {
        stall_time: 8.0,
        ..RunConfig::default()
    };
    let r = run_scenario(&scenario(obstacles), &config).unwrap();
    assert_eq!(r.outcome, Outcome::Stalled);
    assert!(r.progress_m < 10.0, "{}", r.progress_m);
    assert_eq!(r.collisions, 0);
}

#[test]
fn same_seed_same_run() {
    let s = scenario(vec![Obstacle::Cylinder {
        center: [9.0, -0.4],
        radius: 1.0,
    }]);
    let c = RunConfig {
        seed: 42,
        max_time: 6.0,
        ..RunConfig::default()
    };
    let (a, b) = (run_scenario(&s, &c).unwrap(), run_scenario(&s, &c).unwrap());
    assert_eq!(a.trajectory, b.trajectory);
    let other = run_scenario(&s, &RunConfig { seed: 43, ..c }).unwrap();
    assert_ne!(a.trajectory, other.trajectory);
}

#[test]
fn mcap_log_is_whole_and_png_is_written() {
    let dir = std::env::temp_dir().join(format!("sim2d-test-{}", std::process::id()));
    let s = Arc::new(scenario(vec![cube([9.0, 1.0])]));
    let config = RunConfig {
        planner: PlannerKind::DDP_ASTAR,
        max_time: 4.0,
        ..RunConfig::default()
    };
    let job = Job {
        scenario: s.clone(),
        config: config.clone(),
        run: 0,
    };
    let options = BatchOptions {
        out_dir: Some(dir.clone()),
        progress: false,
        threads: Some(1),
        ..BatchOptions::default()
    };
    let results = run_batch(std::slice::from_ref(&job), &options).unwrap();
    assert_eq!(results[0].outcome, Outcome::Timeout);
    let log = dir.join("logs").join(format!("{}.mcap", job.stem()));
    let bytes = std::fs::read(&log).unwrap();
    let mut topics = std::collections::BTreeMap::<String, usize>::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().unwrap();
        // Protobuf with the schema (a FileDescriptorSet) embedded, as Foxglove reads it.
        assert_eq!(
            (schema.encoding.as_str(), m.channel.message_encoding.as_str()),
            ("protobuf", "protobuf")
        );
        assert!(!schema.data.is_empty());
        let d = &m.data[..];
        use foxglove::messages as fm;
        match schema.name.as_str() {
            "foxglove.Grid" => {
                let g = fm::Grid::decode(d).unwrap();
                assert_eq!((g.column_count, g.data.len()), (200, 200 * 200));
            }
            "foxglove.FrameTransforms" => {
                let tf = fm::FrameTransforms::decode(d).unwrap();
                let chain: Vec<(&str, &str)> = tf
                    .transforms
                    .iter()
                    .map(|t| (t.parent_frame_id.as_str(), t.child_frame_id.as_str()))
                    .collect();
                assert_eq!(chain, [("map", "base_link"), ("base_link", "laser")]);
            }
            "foxglove.LaserScan" => assert!(!fm::LaserScan::decode(d).unwrap().ranges.is_empty()),
            "foxglove.PoseInFrame" => assert_eq!(fm::PoseInFrame::decode(d).unwrap().frame_id, "map"),
            "foxglove.SceneUpdate" => assert_eq!(fm::SceneUpdate::decode(d).unwrap().entities.len(), 1),
            // The SDK's derive names the schema `<lowercase name>.<name>`.
            "cyclestats.CycleStats" => assert!(!d.is_empty()),
            other => panic!("unexpected schema {other} on {}", m.channel.topic),
        }
        *topics.entry(m.channel.topic.clone()).or_default() += 1;
    }
    for t in Topics::NAMES {
        // `ddp-astar` guides with an A* path, not sub-goals.
        if t != "/subgoals" {
            assert!(topics.get(t).copied().unwrap_or(0) > 0, "no {t} in {topics:?}");
        }
    }
    assert_eq!((topics["/robot/pose"], topics["/tf"], topics["/stats"]), (40, 40, 40));
    assert!(dir.join("short_forward.png").exists());
    assert!(!dir.join("logs").join(format!("{}.mcap.partial", job.stem())).exists());

    // A logger whose run fails leaves nothing behind.
    let half = dir.join("half.mcap");
    {
        let mut logger = Recorder::mcap(&half, LogOptions::default()).unwrap();
        let mut obs: [&mut dyn sim2d::Observer; 1] = [&mut logger];
        let bad = RunConfig {
            physics_dt: -1.0,
            ..config
        };
        assert!(run_scenario_with(&s, &bad, &mut obs).is_err());
    }
    assert!(!half.exists());
    assert!(!dir.join("half.mcap.partial").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn shipped_scenarios_are_the_papers_route() {
    let dir = "../../scenarios"; // relative to the package root, where cargo runs tests
    for name in ["free", "cylinders", "cubes_without_minima", "cubes_with_minima"] {
        let s = Scenario::from_file(format!("{dir}/{name}.toml")).unwrap();
        assert_eq!(s.name, name);
        assert_eq!(s.route.points().len(), 8);
        assert!((s.route.length() - 278.0).abs() < 1e-9);
        // The start and the end are free, so both directions can start and finish.
        assert!(s.clearance(s.route.start()) > 5.0, "{name}");
        assert!(s.clearance(s.route.end()) > 5.0, "{name}");
    }
}

#[test]
fn slower_planning_cycle_executes_the_plan_between_cycles() {
    // The paper's cycle: 4 epochs take longer than one control period, so the executor sends the
    // plan's later controls at 10 Hz until the next plan (here every 3 control steps).
    let s = scenario(vec![Obstacle::Cylinder {
        center: [9.0, 0.5],
        radius: 1.0,
    }]);
    let r = run_scenario(
        &s,
        &RunConfig {
            plan_every: 3,
            ..RunConfig::default()
        },
    )
    .unwrap();
    assert_eq!(r.outcome, Outcome::Completed);
    assert_eq!(r.collisions, 0);
    assert_eq!(r.epoch_ms.len(), 4 * r.trajectory.len().div_ceil(3));
}

#[test]
fn bad_output_folder_and_log_options_fail_before_any_run() {
    let dir = std::env::temp_dir().join(format!("sim2d-bad-out-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let blocker = dir.join("a-file");
    std::fs::write(&blocker, "not a folder").unwrap();
    let job = Job {
        scenario: Arc::new(scenario(vec![])),
        config: RunConfig {
            max_time: 1.0,
            ..RunConfig::default()
        },
        run: 0,
    };
    let options = BatchOptions {
        out_dir: Some(blocker.join("out")),
        progress: false,
        threads: Some(1),
        ..BatchOptions::default()
    };
    let e = run_batch(std::slice::from_ref(&job), &options).unwrap_err().to_string();
    assert!(e.starts_with("cannot write") && e.contains("a-file"), "{e}");
    let options = BatchOptions {
        out_dir: Some(dir.join("ok")),
        log: LogOptions { costmap_period: 0.0 },
        progress: false,
        ..BatchOptions::default()
    };
    let e = run_batch(std::slice::from_ref(&job), &options).unwrap_err().to_string();
    assert!(e.starts_with("costmap_period"), "{e}");
    // Nothing was written: no run started.
    assert!(!dir
        .join("ok")
        .join("logs")
        .join(format!("{}.mcap", job.stem()))
        .exists());
    // A log path that cannot be created names it.
    let e = Recorder::mcap(blocker.join("run.mcap"), LogOptions::default())
        .err()
        .expect("a file in the way")
        .to_string();
    assert!(e.contains("a-file"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}
