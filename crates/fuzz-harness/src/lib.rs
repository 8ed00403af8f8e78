//! What each fuzz target of `fuzz/` does with one input: hand the bytes to one of ddpkit's
//! loaders and, when they load, call what a loaded value reaches (queries, the physics world,
//! inference, problem building, a few solver iterations). A panic, an abort, a hang or an
//! allocation past the fuzzer's cap is a bug in the library; an `Err` is the expected answer to
//! malformed input, and every error is formatted (its `Display` must not panic either).
//!
//! ```
//! // Each target is a plain function of the bytes; the fuzzer and `cargo test` call the same ones.
//! for target in fuzz_harness::TARGETS {
//!     (target.run)(b"");
//!     (target.run)(b"\xff\xff\xff\xff\xff\xff\xff\xff garbage");
//! }
//! ```
//!
//! | target | loader | input |
//! |---|---|---|
//! | `scenario_toml` | `sim2d::Scenario::from_toml_str` | a scenario file (TOML) |
//! | `benchmark_problem_json` | `safe_cddp::benchmark::BenchmarkProblem::from_json` | a peer-benchmark problem file (JSON) |
//! | `subgoal_model_safetensors` | `subgoal_infer::SubgoalModel::from_safetensors` | sub-goal network weights (safetensors) |
//! | `subgoal_model_config_json` | `subgoal_infer::model::ModelConfig::from_json` | the architecture JSON of the weights' header |
//! | `dataset_shard` | `subgoal_infer::dataset::Shard::from_bytes` | a sub-goal dataset shard (safetensors) |
//! | `dataset_manifest` | `subgoal_infer::dataset::parse_manifest` | a dataset's `manifest.json` |
//! | `idnp_scene` | `idnp::idnp::Idnp::new` (scene, settings, initial state) | typed values decoded from the bytes ([`bytes::Bytes`]) |
//! | `tape_model` | `ddp_tape::TapeModel::from_json` | a model traced in Python and saved (`model.save`), the `ddpkit-tape` JSON format |

pub mod bytes;

use std::path::Path;
use std::sync::Arc;

use bytes::Bytes;

/// One fuzz target: its name (the file under `fuzz/fuzz_targets/` and the folder of its seeds
/// under `fuzz/seeds/`) and what it runs on an input.
#[derive(Clone, Copy)]
pub struct Target {
    /// Name of the target.
    pub name: &'static str,
    /// Runs one input.
    /// Runs one input; `true` when the input loaded (was accepted by the loader).
    pub run: fn(&[u8]) -> bool,
}

/// Every target, in the order of the module docs.
pub const TARGETS: &[Target] = &[
    Target {
        name: "scenario_toml",
        run: scenario_toml,
    },
    Target {
        name: "benchmark_problem_json",
        run: benchmark_problem_json,
    },
    Target {
        name: "subgoal_model_safetensors",
        run: subgoal_model_safetensors,
    },
    Target {
        name: "subgoal_model_config_json",
        run: subgoal_model_config_json,
    },
    Target {
        name: "dataset_shard",
        run: dataset_shard,
    },
    Target {
        name: "dataset_manifest",
        run: dataset_manifest,
    },
    Target {
        name: "idnp_scene",
        run: idnp_scene,
    },
    Target {
        name: "tape_model",
        run: tape_model,
    },
];

/// The target called `name`.
pub fn target(name: &str) -> Option<Target> {
    TARGETS.iter().copied().find(|t| t.name == name)
}

/// Formats an error, as a user's program would print it (to stderr when the environment has
/// `FUZZ_HARNESS_VERBOSE`, to see why an input was rejected). Returns `false`: not loaded.
fn show(e: impl std::fmt::Display) -> bool {
    static VERBOSE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let text = e.to_string();
    if *VERBOSE.get_or_init(|| std::env::var_os("FUZZ_HARNESS_VERBOSE").is_some()) {
        eprintln!("rejected: {text}");
    }
    std::hint::black_box(text);
    false
}

/// A scenario file: parse it, then query it and build its physics world as the `scenario`
/// binary does (a world step and a lidar scan included).
pub fn scenario_toml(data: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(data) else {
        return false;
    };
    let s = match sim2d::Scenario::from_toml_str(text, "fuzz.toml") {
        Ok(s) => s,
        Err(e) => return show(e),
    };
    let route = &s.route;
    let b = s.bounds();
    let (len, start, end) = (route.length(), route.start(), route.end());
    let probes = [
        start,
        end,
        [b[0], b[1]],
        [b[2], b[3]],
        [0.5 * (b[0] + b[2]), 0.5 * (b[1] + b[3])],
    ];
    for p in probes {
        std::hint::black_box(s.clearance(p));
        std::hint::black_box(route.project(p, 0.5 * len, 10.0, 10.0));
        std::hint::black_box(route.local_goal(0.5 * len, p, 5.0));
    }
    for o in &s.obstacles {
        std::hint::black_box((o.outline(), o.bounds(), o.distance(start)));
    }
    for t in [0.0, 0.25, 1.0, 2.0] {
        std::hint::black_box(route.point_at(t * len));
        std::hint::black_box(route.segment_at(t * len));
    }
    std::hint::black_box(route.reversed());
    let pose = [start[0], start[1], route.start_heading()];
    match sim2d::world::World::new(&s, sim2d::world::RobotParams::default(), pose, 0.05, 0) {
        Ok(mut w) => {
            w.step([1.0, 0.1], 0.1);
            let mut scan = sim2d::world::Scan::default();
            let lidar = sim2d::world::LidarParams {
                beams: 16,
                ..Default::default()
            };
            w.scan(&lidar, &mut scan);
            std::hint::black_box((w.pose(), w.collisions(), scan.ranges.len()));
        }
        Err(e) => {
            show(e);
        }
    }
    true
}

/// A peer-benchmark problem file: parse it, build the problem of its model, and run three
/// solver iterations when the horizon is short.
pub fn benchmark_problem_json(data: &[u8]) -> bool {
    use safe_cddp::benchmark::BenchmarkProblem;
    let Ok(text) = std::str::from_utf8(data) else {
        return false;
    };
    let p = match BenchmarkProblem::from_json(text) {
        Ok(p) => p,
        Err(e) => return show(e),
    };
    let settings = ddp_core::Settings {
        max_iterations: 3,
        ..Default::default()
    };
    match p.car_or_point() {
        Ok((problem, constraints)) if problem.horizon() <= 64 => {
            std::hint::black_box(constraints.len());
            solve_briefly(&problem, &settings);
        }
        Ok(_) => {}
        Err(e) => {
            show(e);
        }
    }
    match p.unicycle() {
        Ok((problem, _)) if problem.horizon() <= 64 => solve_briefly(&problem, &settings),
        Ok(_) => {}
        Err(e) => {
            show(e);
        }
    }
    true
}

/// A few solver iterations; the outcome of the algorithm is not the point, only that it answers.
fn solve_briefly<NX, NU>(problem: &ddp_core::Problem<NX, NU>, settings: &ddp_core::Settings)
where
    NX: ddp_core::dims::Dim,
    NU: ddp_core::dims::Dim,
    ddp_core::dims::DefaultAllocator: ddp_core::dims::Alloc<NX, NU>,
{
    match ddp_core::Solver::new(problem, *settings) {
        Ok(mut solver) => {
            if let Err(e) = solver.solve(problem) {
                show(e);
            }
        }
        Err(e) => {
            show(e);
        }
    }
}

/// Sub-goal network weights: load them, and run inference when the network is small (a large
/// valid network is slow by design, not a bug).
pub fn subgoal_model_safetensors(data: &[u8]) -> bool {
    let model = match subgoal_infer::SubgoalModel::from_safetensors(data) {
        Ok(m) => m,
        Err(e) => return show(e),
    };
    let n = model.config().in_size;
    if n > 32 || data.len() > 1 << 16 {
        return true;
    }
    let cells: Vec<u8> = (0..n * n)
        .map(|i| if (i / n + i % n) % 7 == 0 { 254 } else { 0 })
        .collect();
    for goal in [[1.0, -2.0], [0.0, 0.0], [1e30, -1e30]] {
        match model.predict(&cells, goal) {
            Ok(sg) => assert_eq!(sg.len(), model.num_subgoals(), "one prediction per sub-goal"),
            Err(e) => {
                show(e);
            }
        }
    }
    if let Err(e) = model.predict(&cells[1..], [1.0, 1.0]) {
        show(e);
    } else {
        panic!("a costmap of the wrong size was accepted");
    }
    true
}

/// The architecture JSON of the weights' header metadata.
pub fn subgoal_model_config_json(data: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(data) else {
        return false;
    };
    match subgoal_infer::model::ModelConfig::from_json(text) {
        Ok(c) => {
            c.validate().expect("a parsed architecture validates again");
            true
        }
        Err(e) => show(e),
    }
}

/// A sub-goal dataset shard: parse it and read every sample back.
pub fn dataset_shard(data: &[u8]) -> bool {
    match subgoal_infer::dataset::Shard::from_bytes(data, Path::new("fuzz.safetensors")) {
        Ok(shard) => {
            for k in 0..=shard.len() {
                let map = shard.costmap(k);
                assert_eq!(map.is_some(), k < shard.len(), "costmap({k}) of {}", shard.len());
            }
            assert_eq!(shard.subgoals.len(), shard.len());
            assert_eq!(shard.path_lengths.len(), shard.len());
            assert_eq!(shard.traps.len(), shard.len());
            std::hint::black_box(shard.is_empty());
            true
        }
        Err(e) => {
            std::hint::black_box(e.field());
            show(e)
        }
    }
}

/// A dataset's `manifest.json`: parse it and resolve its shard paths.
pub fn dataset_manifest(data: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(data) else {
        return false;
    };
    match subgoal_infer::dataset::parse_manifest(text, Path::new("fuzz-dataset")) {
        Ok(m) => {
            for k in 0..=m.shards.len() {
                let path = m.shard_path(k);
                assert_eq!(path.is_some(), k < m.shards.len());
                if let Some(p) = path {
                    assert!(p.starts_with("fuzz-dataset"), "{} left the dataset folder", p.display());
                }
            }
            true
        }
        Err(e) => {
            std::hint::black_box(e.field());
            show(e)
        }
    }
}

/// A saved tape model (dynamics, cost, terminal cost or constraint traced in Python): load it,
/// then evaluate the tape with first derivatives and the second-order sweep at a fixed point, by
/// the interpreter and by the compiled program.
pub fn tape_model(data: &[u8]) -> bool {
    let Ok(text) = std::str::from_utf8(data) else {
        return false;
    };
    match ddp_tape::TapeModel::from_json(text) {
        Ok(model) => {
            let tape = model.tape();
            let z: Vec<f64> = (0..tape.n_inputs()).map(|i| 0.1 * i as f64 - 0.3).collect();
            let mut ws = ddp_tape::Workspace::default();
            let mut out = vec![0.0; tape.n_outputs()];
            tape.values(&z, &mut ws, &mut out);
            tape.forward(&z, &mut ws, true);
            let lambda = vec![1.0; tape.n_outputs()];
            tape.second_order(&lambda, &mut ws, |k, g, h| {
                std::hint::black_box((k, g, h.len()));
            });
            // The compiled program the models run (compiled again here with every output kept).
            let prog = ddp_tape::Program::new(tape, tape.n_inputs());
            let mut pws = ddp_tape::ProgramWorkspace::default();
            prog.values(&mut pws, &z, &[], &mut out);
            prog.jacobian(&mut pws, &z, &[]);
            prog.second_order(&mut pws, &z, &[], &lambda);
            std::hint::black_box((model.kind(), &out, &pws.hess));
            true
        }
        Err(e) => show(e),
    }
}

/// An IDNP scene, its settings and an initial state decoded from the bytes: build the solver
/// (scene and settings validation, grids) and run the cheap queries on the scene: clearances,
/// limits, the inverse mapping of a waypoint, grid location and refinement. The loop itself
/// (DP + NLP, seconds per run) is not run.
pub fn idnp_scene(data: &[u8]) -> bool {
    use idnp::idnp::{Idnp, IdnpSettings, Variant};
    use idnp::scene::{Body, Domain, GoalBall, Obstacle, Scene};
    let mut b = Bytes::new(data);
    let base = Scene::narrow_passage();
    let mut obstacles = Vec::new();
    if b.bool() {
        obstacles = base.obstacles.clone();
    } else {
        for k in 0..b.count(4).min(8) {
            let n = b.count(6);
            let vertices: Vec<[f64; 2]> = (0..n.min(64)).map(|_| b.f64s::<2>()).collect();
            let o = if b.bool() {
                Obstacle::rectangle(b.f64s::<2>(), b.f64s::<2>())
            } else {
                Obstacle::polygon(&vertices)
            };
            match o {
                Ok(o) => {
                    std::hint::black_box(o.point_distance(b.f64s::<2>()));
                    obstacles.push(o);
                }
                Err(e) => {
                    show(e);
                    if k == 0 {
                        obstacles.extend(base.obstacles.first().cloned());
                    }
                }
            }
        }
    }
    let robot = match ddp_core::models::ArmBase::new(b.f64_or(base.robot.dt())) {
        Ok(r) => r,
        Err(e) => return show(e),
    };
    let scene = Scene {
        robot,
        link_radius: b.f64_or(base.link_radius),
        obstacles,
        goal: GoalBall {
            center: [b.f64_or(base.goal.center[0]), b.f64_or(base.goal.center[1])],
            radius: b.f64_or(base.goal.radius),
        },
        domain: Domain {
            min: [b.f64_or(base.domain.min[0]), b.f64_or(base.domain.min[1])],
            cells: [
                b.count_or(base.domain.cells[0], 16),
                b.count_or(base.domain.cells[1], 16),
            ],
            cell_size: b.f64_or(base.domain.cell_size),
        },
        joint_limits: [
            [b.f64_or(base.joint_limits[0][0]), b.f64_or(base.joint_limits[0][1])],
            [b.f64_or(base.joint_limits[1][0]), b.f64_or(base.joint_limits[1][1])],
        ],
        base_limits: [
            [b.f64_or(base.base_limits[0][0]), b.f64_or(base.base_limits[0][1])],
            [b.f64_or(base.base_limits[1][0]), b.f64_or(base.base_limits[1][1])],
        ],
        passage: base.passage,
    };
    let d = IdnpSettings::default();
    let mut settings = IdnpSettings {
        max_iterations: b.count_or(d.max_iterations, 20),
        initial_level: b.count_or(d.initial_level as usize, 8) as u8,
        max_level: b.count_or(d.max_level as usize, 12) as u8,
        penalty_increment: b.f64_or(d.penalty_increment),
        refinement_radius: b.f64_or(d.refinement_radius),
        ..d
    };
    settings.dp.stages = b.count_or(d.dp.stages, 40);
    settings.dp.steps_per_axis = b.count_or(d.dp.steps_per_axis, 31);
    settings.dp.max_step = b.f64_or(d.dp.max_step);
    settings.nlp.knots_per_stage = b.count_or(d.nlp.knots_per_stage, 8);
    // Keep the stage duration consistent with the knots unless the input asks otherwise.
    let stage = settings.nlp.knots_per_stage as f64 * scene.robot.dt();
    settings.dp.stage_duration = b.f64_or(stage);
    settings.inverse.min_clearance = b.f64_or(d.inverse.min_clearance);
    let q0 = [
        b.f64_or(1.0),
        b.f64_or(-2.0),
        b.f64_or(0.0),
        b.f64_or(0.3),
        b.f64_or(-0.6),
    ];
    let mut x0 = ddp_core::Vector::<10>::zeros();
    for (i, q) in q0.iter().enumerate() {
        x0[i] = *q;
    }
    x0[5] = b.f64_or(0.0);
    let variant = if b.bool() {
        Variant::FixedGrid
    } else {
        Variant::Adaptive
    };
    let z = [b.f64_or(2.0), b.f64_or(1.0)];
    let scene = Arc::new(scene);
    let run = match Idnp::new(scene.clone(), settings, variant, x0) {
        Ok(r) => r,
        Err(e) => return show(e),
    };
    // A valid scene and settings: every query must answer.
    let q: idnp::scene::Config = x0.fixed_rows::<5>(0).into_owned();
    std::hint::black_box((
        scene.point_clearance(z),
        scene.clearance(&x0),
        scene.limit_violation(&q),
    ));
    for o in &scene.obstacles {
        for body in Body::ALL {
            std::hint::black_box(scene.body_distance(&x0, body, o));
        }
    }
    // The inverse mapping is an optimisation (milliseconds): run it for one input in eight, so
    // that the cheap checks above get most of the fuzzer's time.
    if b.byte() % 8 == 1 {
        match idnp::inverse::inverse_map(&scene, &settings.inverse, &q, z, 1) {
            Ok(q) => std::hint::black_box(scene.tcp(&q)),
            Err(f) => std::hint::black_box(f.waypoint),
        };
    }
    let mut grid = run.grids()[0].clone();
    std::hint::black_box((grid.locate(z), grid.weights(z), grid.cell_count()));
    if grid.cell_count() <= 4096 {
        grid.split_at(&[z, scene.goal.center]);
        grid.balance();
        std::hint::black_box(grid.leaf_count());
    }
    true
}
