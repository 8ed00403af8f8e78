//! Run logs through the official Foxglove SDK (the `foxglove` crate): typed messages, protobuf
//! encoded, with their schemas embedded, in one MCAP file per run (zstd chunks). Each run has its
//! own [`foxglove::Context`], so runs in parallel share nothing; the live view
//! (`crate::live`, feature `live`) mirrors the same messages to a WebSocket server.
//!
//! | topic | message | frame | rate |
//! |---|---|---|---|
//! | `/tf` | `foxglove.FrameTransforms`: `map` -> `base_link` (the robot), `base_link` -> `laser` | | 10 Hz |
//! | `/robot/pose` | `foxglove.PoseInFrame` | `map` | 10 Hz |
//! | `/robot/footprint` | `foxglove.SceneUpdate`: the 0.8 x 0.6 m body, locked to `base_link` | `base_link` | with the costmap |
//! | `/costmap` | `foxglove.Grid` (field `cost`, `uint8`, 0 free to 254 lethal) | `map` | every `costmap_period` (1 s) |
//! | `/lidar` | `foxglove.LaserScan` | `laser` | with the costmap |
//! | `/plan` | `foxglove.SceneUpdate`: the planned trajectory | `map` | every plan (10 Hz) |
//! | `/astar` | `foxglove.SceneUpdate`: the A* path that seeded the plan (`ddp-astar`) | `map` | every plan |
//! | `/subgoals` | `foxglove.SceneUpdate`: the sub-goals (`ddpen`, `ddpen-oracle`) | `map` | every plan |
//! | `/goal` | `foxglove.PoseInFrame`: the local goal | `map` | 10 Hz |
//! | `/world` | `foxglove.SceneUpdate`: obstacles, route, route points | `map` | at the start, then every 10 s |
//! | `/stats` | `cyclestats.CycleStats` ([`CycleStats`], schema derived by the SDK): speeds, compute times, cost, progress (plottable numbers) | | 10 Hz |
//!
//! A topic's channel is written with its first message (a `ddp` run has no `/astar`). Times are
//! simulated time from 0. Drawn points (plan, A* path, sub-goals, route) are rounded to
//! 1/1024 m (about 1 mm) so the log compresses; poses and transforms are exact. The file is written as `<name>.partial` and renamed when the
//! run ends, so a log is whole or absent: a run that fails, or a write that fails on the way,
//! removes the partial file.

use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use foxglove::messages::{
    line_primitive, packed_element_field, Color, CubePrimitive, CylinderPrimitive, Duration, FrameTransform,
    FrameTransforms, Grid, LaserScan, LinePrimitive, PackedElementField, Point3, Pose, PoseInFrame, Quaternion,
    SceneEntity, SceneUpdate, SpherePrimitive, Timestamp, Vector2, Vector3,
};
use foxglove::{Channel, Context, McapCompression, McapWriteOptions, McapWriterHandle};

use crate::error::{Error, Result};
use crate::run::{CycleView, Observer, RunInfo, RunResult};
use crate::scenario::Obstacle;

/// Logging options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogOptions {
    /// Seconds between costmap (and lidar, footprint) messages; the costmap is the bulk of a log.
    pub costmap_period: f64,
}

impl Default for LogOptions {
    fn default() -> Self {
        Self { costmap_period: 1.0 }
    }
}

impl LogOptions {
    /// Checks the options (`costmap_period` finite and > 0).
    pub fn validate(&self) -> Result<()> {
        crate::error::positive("costmap_period", self.costmap_period)?;
        Ok(())
    }
}

/// Seconds between repeats of `/world` (so a live viewer that joins late sees the obstacles).
const WORLD_PERIOD: f64 = 10.0;

pub use stats::CycleStats;

/// In a module of its own: the derive macro's expansion names `Result` unqualified.
mod stats {
    use foxglove::messages::Timestamp;

    /// The per-cycle numbers of `/stats`, plottable in Foxglove (`/stats.speed`, `/stats.cycle_ms`).
    #[derive(Debug, Clone, Default, PartialEq, foxglove::Encode)]
    pub struct CycleStats {
        /// Simulated time.
        pub timestamp: Timestamp,
        /// Speed driven since the previous cycle (m/s).
        pub speed: f64,
        /// Commanded speed `v` (m/s).
        pub v_cmd: f64,
        /// Commanded turn rate `w` (rad/s).
        pub w_cmd: f64,
        /// Compute time of this cycle's plan: set-up and every epoch (ms; 0 without a plan).
        pub cycle_ms: f64,
        /// Longest optimisation epoch of this cycle (ms).
        pub epoch_ms_max: f64,
        /// Set-up time of this cycle's plan (ms): problem, initial guess, sub-goals.
        pub setup_ms: f64,
        /// Of `setup_ms`, the sub-goal computation (ms).
        pub subgoal_ms: f64,
        /// Cost after the last epoch.
        pub cost: f64,
        /// Progress along the route (m).
        pub progress_m: f64,
        /// Contact onsets with obstacles so far.
        pub collisions: u32,
    }
}

/// The channels of every topic, on one context (a log file's, or the live view's).
pub struct Topics {
    tf: Channel<FrameTransforms>,
    pose: Channel<PoseInFrame>,
    footprint: Channel<SceneUpdate>,
    costmap: Channel<Grid>,
    lidar: Channel<LaserScan>,
    plan: Channel<SceneUpdate>,
    astar: Channel<SceneUpdate>,
    subgoals: Channel<SceneUpdate>,
    goal: Channel<PoseInFrame>,
    world: Channel<SceneUpdate>,
    stats: Channel<CycleStats>,
}

impl Topics {
    /// Every topic's channel on `ctx`.
    pub fn new(ctx: &Arc<Context>) -> Self {
        Self {
            tf: ctx.channel_builder("/tf").build(),
            pose: ctx.channel_builder("/robot/pose").build(),
            footprint: ctx.channel_builder("/robot/footprint").build(),
            costmap: ctx.channel_builder("/costmap").build(),
            lidar: ctx.channel_builder("/lidar").build(),
            plan: ctx.channel_builder("/plan").build(),
            astar: ctx.channel_builder("/astar").build(),
            subgoals: ctx.channel_builder("/subgoals").build(),
            goal: ctx.channel_builder("/goal").build(),
            world: ctx.channel_builder("/world").build(),
            stats: ctx.channel_builder("/stats").build(),
        }
    }

    /// The topic names, in the order of the module docs' table.
    pub const NAMES: [&'static str; 11] = [
        "/tf",
        "/robot/pose",
        "/robot/footprint",
        "/costmap",
        "/lidar",
        "/plan",
        "/astar",
        "/subgoals",
        "/goal",
        "/world",
        "/stats",
    ];
}

/// A writer that remembers the first I/O error: the SDK logs failed writes as warnings, and a
/// log with a failed write must not be renamed into place.
struct Watched {
    inner: BufWriter<File>,
    failed: Arc<Mutex<Option<String>>>,
}

impl Watched {
    fn note<T>(&self, r: std::io::Result<T>) -> std::io::Result<T> {
        if let Err(e) = &r {
            let mut f = self.failed.lock().unwrap_or_else(|p| p.into_inner());
            f.get_or_insert_with(|| e.to_string());
        }
        r
    }
}

impl Write for Watched {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let r = self.inner.write(buf);
        self.note(r)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        let r = self.inner.flush();
        self.note(r)
    }
}

impl Seek for Watched {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        let r = self.inner.seek(pos);
        self.note(r)
    }
}

/// The open MCAP file of a [`Recorder`].
struct McapFile {
    path: PathBuf,
    partial: PathBuf,
    handle: McapWriterHandle<Watched>,
    failed: Arc<Mutex<Option<String>>>,
    /// The run's own context (kept alive until the file is closed).
    _ctx: Arc<Context>,
}

/// `<path>.partial`.
pub fn partial_path(path: &Path) -> PathBuf {
    let mut p = path.as_os_str().to_owned();
    p.push(".partial");
    PathBuf::from(p)
}

/// Creates `dir` (and its parents) and checks that a file can be written in it: the check made
/// before a batch starts, so a bad output folder fails before the first run, naming the folder.
pub fn check_output_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
    let probe = dir.join(format!(".ddpkit-write-check-{}", std::process::id()));
    File::create(&probe).map_err(|e| Error::write(dir, e))?;
    std::fs::remove_file(&probe).map_err(|e| Error::write(dir, e))
}

/// Writes one run's log (see the module docs) to an MCAP file, to a live view, or both; an
/// [`Observer`].
pub struct Recorder {
    file: Option<McapFile>,
    /// The file's channels first (when there is a file), then mirrors (the live view).
    sinks: Vec<Arc<Topics>>,
    options: LogOptions,
    next_costmap: f64,
    next_world: f64,
    world: Option<SceneUpdate>,
    footprint: [f64; 2],
    guide_is_path: bool,
    laser: [f64; 3],
    last_pose: Option<(f64, [f64; 3])>,
}

impl Recorder {
    fn new(file: Option<McapFile>, sinks: Vec<Arc<Topics>>, options: LogOptions) -> Result<Self> {
        options.validate()?;
        Ok(Self {
            file,
            sinks,
            options,
            next_costmap: 0.0,
            next_world: 0.0,
            world: None,
            footprint: [0.8, 0.6],
            guide_is_path: false,
            laser: [0.0; 3],
            last_pose: None,
        })
    }

    /// Creates `<path>.partial` (and its folder) with its own context, ready to log; the file
    /// takes its final name in [`Recorder::finish`].
    pub fn mcap(path: impl AsRef<Path>, options: LogOptions) -> Result<Self> {
        options.validate()?;
        let path = path.as_ref().to_path_buf();
        let partial = partial_path(&path);
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| Error::write(dir, e))?;
        }
        let file = File::create(&partial).map_err(|e| Error::write(&path, e))?;
        let failed = Arc::new(Mutex::new(None));
        let writer = Watched {
            inner: BufWriter::new(file),
            failed: failed.clone(),
        };
        let ctx = Context::new();
        let handle = ctx
            .mcap_writer_with_options(
                McapWriteOptions::new()
                    .compression(Some(McapCompression::Zstd))
                    .profile("")
                    .library("ddpkit-sim2d"),
            )
            .create(writer);
        let handle = match handle {
            Ok(h) => h,
            Err(e) => {
                let _ = std::fs::remove_file(&partial);
                return Err(Error::write(&path, e));
            }
        };
        let topics = Arc::new(Topics::new(&ctx));
        let file = McapFile {
            path,
            partial,
            handle,
            failed,
            _ctx: ctx,
        };
        Self::new(Some(file), vec![topics], options)
    }

    /// A recorder without a file that logs to `topics` (the live view's) only.
    pub fn mirror_only(topics: Arc<Topics>, options: LogOptions) -> Result<Self> {
        Self::new(None, vec![topics], options)
    }

    /// Also logs every message to `topics` (the live view's channels).
    pub fn with_mirror(mut self, topics: Arc<Topics>) -> Self {
        self.sinks.push(topics);
        self
    }

    /// The final path of the log (`None` without a file).
    pub fn path(&self) -> Option<&Path> {
        self.file.as_ref().map(|f| f.path.as_path())
    }

    fn log<T: foxglove::Encode>(&self, pick: impl Fn(&Topics) -> &Channel<T>, msg: &T, t: f64) {
        let ns = nanos(t);
        for s in &self.sinks {
            pick(s).log_with_time(msg, ns);
        }
    }

    /// Finishes the file and renames it to its final path; a write that failed on the way
    /// removes the partial file and is the error.
    pub fn finish(&mut self) -> Result<()> {
        let Some(f) = self.file.take() else {
            return Ok(());
        };
        let closed = f.handle.close();
        let failed = f.failed.lock().unwrap_or_else(|p| p.into_inner()).take();
        let result = match (closed, failed) {
            (Err(e), _) => Err(Error::write(&f.path, e)),
            (Ok(_), Some(e)) => Err(Error::write(&f.path, e)),
            (Ok(mut w), None) => w
                .inner
                .flush()
                .and_then(|()| w.inner.get_ref().sync_all())
                .and_then(|()| std::fs::rename(&f.partial, &f.path))
                .map_err(|e| Error::write(&f.path, e)),
        };
        if result.is_err() {
            let _ = std::fs::remove_file(&f.partial);
        }
        result
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if let Some(f) = self.file.take() {
            // Not finished: the run failed. Leave no half log behind.
            let _ = f.handle.close();
            let _ = std::fs::remove_file(&f.partial);
        }
    }
}

fn nanos(t: f64) -> u64 {
    (t.max(0.0) * 1e9).round() as u64
}

fn stamp(t: f64) -> Option<Timestamp> {
    let ns = nanos(t);
    Some(Timestamp::new((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32))
}

fn quat(theta: f64) -> Quaternion {
    Quaternion {
        x: 0.0,
        y: 0.0,
        z: (0.5 * theta).sin(),
        w: (0.5 * theta).cos(),
    }
}

fn pose(x: f64, y: f64, theta: f64) -> Option<Pose> {
    Some(Pose {
        position: Some(Vector3 { x, y, z: 0.0 }),
        orientation: Some(quat(theta)),
    })
}

fn color(r: f64, g: f64, b: f64, a: f64) -> Option<Color> {
    Some(Color { r, g, b, a })
}

fn entity(t: f64, frame: &str, id: &str) -> SceneEntity {
    SceneEntity {
        timestamp: stamp(t),
        frame_id: frame.into(),
        id: id.into(),
        lifetime: Some(Duration::default()),
        ..Default::default()
    }
}

/// `v` on a grid of 1/1024 m (about 1 mm): the drawn geometry of every plan (51 points at 10 Hz,
/// most of a log) then has short mantissas that zstd compresses, where full doubles would not.
fn grid_mm(v: f64) -> f64 {
    (v * 1024.0).round() / 1024.0
}

fn line(points: &[[f64; 2]], z: f64, thickness: f64, c: Option<Color>, closed: bool) -> LinePrimitive {
    LinePrimitive {
        r#type: if closed {
            line_primitive::Type::LineLoop
        } else {
            line_primitive::Type::LineStrip
        } as i32,
        pose: pose(0.0, 0.0, 0.0),
        thickness,
        points: points
            .iter()
            .map(|p| Point3 {
                x: grid_mm(p[0]),
                y: grid_mm(p[1]),
                z,
            })
            .collect(),
        color: c,
        ..Default::default()
    }
}

fn sphere(p: [f64; 2], d: f64, c: Option<Color>) -> SpherePrimitive {
    SpherePrimitive {
        pose: pose(grid_mm(p[0]), grid_mm(p[1]), 0.0),
        size: Some(Vector3 { x: d, y: d, z: d }),
        color: c,
    }
}

fn update(e: SceneEntity) -> SceneUpdate {
    SceneUpdate {
        deletions: Vec::new(),
        entities: vec![e],
    }
}

/// The pose of `b` in the frame of `a` (both `[x, y, theta]` in one frame).
fn relative(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let (s, c) = a[2].sin_cos();
    [c * dx + s * dy, -s * dx + c * dy, b[2] - a[2]]
}

fn transform(t: f64, parent: &str, child: &str, p: [f64; 3]) -> FrameTransform {
    FrameTransform {
        timestamp: stamp(t),
        parent_frame_id: parent.into(),
        child_frame_id: child.into(),
        translation: Some(Vector3 {
            x: p[0],
            y: p[1],
            z: 0.0,
        }),
        rotation: Some(quat(p[2])),
    }
}

impl Recorder {
    fn world_update(info: &RunInfo<'_>) -> SceneUpdate {
        let grey = color(0.35, 0.35, 0.4, 1.0);
        let mut e = entity(0.0, "map", "world");
        for o in &info.scenario.obstacles {
            match o {
                Obstacle::Cylinder { center, radius } => e.cylinders.push(CylinderPrimitive {
                    pose: pose(center[0], center[1], 0.0),
                    size: Some(Vector3 {
                        x: 2.0 * radius,
                        y: 2.0 * radius,
                        z: 1.0,
                    }),
                    bottom_scale: 1.0,
                    top_scale: 1.0,
                    color: grey,
                }),
                Obstacle::Box { center, size, yaw } => e.cubes.push(CubePrimitive {
                    pose: pose(center[0], center[1], *yaw),
                    size: Some(Vector3 {
                        x: size[0],
                        y: size[1],
                        z: 1.0,
                    }),
                    color: grey,
                }),
                Obstacle::Polygon { points } => e.lines.push(line(points, 0.0, 0.08, grey, true)),
            }
        }
        e.lines
            .push(line(info.route.points(), 0.01, 0.06, color(0.2, 0.7, 0.3, 0.8), false));
        for p in info.route.points() {
            e.spheres.push(sphere(*p, 0.8, color(0.2, 0.8, 0.3, 0.6)));
        }
        update(e)
    }
}

impl Observer for Recorder {
    fn on_start(&mut self, info: &RunInfo<'_>) -> Result<()> {
        self.footprint = [info.config.robot.length, info.config.robot.width];
        self.guide_is_path = info.config.planner.name() == "ddp-astar";
        self.world = Some(Self::world_update(info));
        if let Some(f) = &self.file {
            let meta = [
                ("scenario", info.scenario.name.clone()),
                ("planner", info.config.planner.name().to_string()),
                ("direction", info.config.direction.name().to_string()),
                ("seed", info.config.seed.to_string()),
            ]
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect();
            f.handle
                .write_metadata("run", meta)
                .map_err(|e| Error::write(&f.path, e))?;
        }
        Ok(())
    }

    fn on_cycle(&mut self, c: &CycleView<'_>) -> Result<()> {
        let t = c.time;
        let [x, y, th] = c.pose;
        if t + 1e-9 >= self.next_world {
            self.next_world = t + WORLD_PERIOD;
            if let Some(w) = &self.world {
                self.log(|s| &s.world, w, t);
            }
        }
        if c.scanned {
            self.laser = relative(c.pose, c.scan.pose);
        }
        self.log(
            |s| &s.tf,
            &FrameTransforms {
                transforms: vec![
                    transform(t, "map", "base_link", c.pose),
                    transform(t, "base_link", "laser", self.laser),
                ],
            },
            t,
        );
        self.log(
            |s| &s.pose,
            &PoseInFrame {
                timestamp: stamp(t),
                frame_id: "map".into(),
                pose: pose(x, y, th),
            },
            t,
        );
        self.log(
            |s| &s.goal,
            &PoseInFrame {
                timestamp: stamp(t),
                frame_id: "map".into(),
                pose: pose(c.goal[0], c.goal[1], (c.goal[1] - y).atan2(c.goal[0] - x)),
            },
            t,
        );
        let speed = match self.last_pose {
            Some((t0, p0)) if t > t0 => (x - p0[0]).hypot(y - p0[1]) / (t - t0),
            _ => 0.0,
        };
        self.last_pose = Some((t, c.pose));
        let mut stats = CycleStats {
            timestamp: stamp(t).unwrap_or_default(),
            speed,
            v_cmd: c.command[0],
            w_cmd: c.command[1],
            progress_m: c.progress,
            collisions: c.collisions.min(u32::MAX as usize) as u32,
            ..Default::default()
        };
        if let Some(plan) = c.plan {
            let epochs: f64 = plan.epoch_seconds.iter().sum();
            stats.cycle_ms = 1e3 * (epochs + plan.setup_seconds);
            stats.epoch_ms_max = 1e3 * plan.epoch_seconds.iter().copied().fold(0.0, f64::max);
            stats.setup_ms = 1e3 * plan.setup_seconds;
            stats.subgoal_ms = 1e3 * plan.subgoal_seconds;
            stats.cost = plan.cost;
            let pts: Vec<[f64; 2]> = plan.states.iter().map(|s| [s[0], s[1]]).collect();
            let mut e = entity(t, "map", "plan");
            e.lines.push(line(&pts, 0.05, 0.05, color(0.0, 0.8, 0.2, 1.0), false));
            self.log(|s| &s.plan, &update(e), t);
            if self.guide_is_path {
                let mut e = entity(t, "map", "astar");
                e.lines
                    .push(line(&plan.guide, 0.03, 0.04, color(0.9, 0.5, 0.1, 0.9), false));
                self.log(|s| &s.astar, &update(e), t);
            } else if !plan.guide.is_empty() {
                let mut e = entity(t, "map", "subgoals");
                e.spheres
                    .extend(plan.guide.iter().map(|g| sphere(*g, 0.25, color(0.1, 0.8, 0.2, 0.9))));
                self.log(|s| &s.subgoals, &update(e), t);
            }
        }
        self.log(|s| &s.stats, &stats, t);
        if c.scanned && t + 1e-9 >= self.next_costmap {
            self.next_costmap = t + self.options.costmap_period;
            let mut e = entity(t, "base_link", "robot");
            e.frame_locked = true;
            e.cubes.push(CubePrimitive {
                pose: pose(0.0, 0.0, 0.0),
                size: Some(Vector3 {
                    x: self.footprint[0],
                    y: self.footprint[1],
                    z: 0.4,
                }),
                color: color(0.1, 0.3, 0.9, 0.9),
            });
            self.log(|s| &s.footprint, &update(e), t);
            let map = c.perception.costmap();
            let g = map.geometry();
            let o = g.origin();
            self.log(
                |s| &s.costmap,
                &Grid {
                    timestamp: stamp(t),
                    frame_id: "map".into(),
                    pose: pose(o[0], o[1], 0.0),
                    column_count: g.width() as u32,
                    cell_size: Some(Vector2 {
                        x: g.resolution(),
                        y: g.resolution(),
                    }),
                    row_stride: g.width() as u32,
                    cell_stride: 1,
                    fields: vec![PackedElementField {
                        name: "cost".into(),
                        offset: 0,
                        r#type: packed_element_field::NumericType::Uint8 as i32,
                    }],
                    data: map.cells().to_vec().into(),
                },
                t,
            );
            let s = c.scan;
            let n = s.ranges.len().max(1) as f64;
            self.log(
                |k| &k.lidar,
                &LaserScan {
                    timestamp: stamp(t),
                    frame_id: "laser".into(),
                    pose: pose(0.0, 0.0, 0.0),
                    start_angle: 0.0,
                    end_angle: std::f64::consts::TAU * (n - 1.0) / n,
                    ranges: s.ranges.iter().map(|&r| r as f64).collect(),
                    intensities: Vec::new(),
                },
                t,
            );
        }
        Ok(())
    }

    fn on_end(&mut self, _result: &RunResult) -> Result<()> {
        self.finish()
    }
}

/// What a batch needs of a live view: its channels and the pace of the runs.
#[derive(Clone)]
pub struct LiveLink {
    /// The live view's channels (every run logs to them too).
    pub topics: Arc<Topics>,
    /// Simulated seconds per wall-clock second (1: real time; 0: as fast as the simulation goes).
    pub rate: f64,
}

impl std::fmt::Debug for LiveLink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveLink")
            .field("rate", &self.rate)
            .finish_non_exhaustive()
    }
}

impl PartialEq for LiveLink {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.topics, &other.topics) && self.rate == other.rate
    }
}

/// Holds a run to `rate` simulated seconds per wall-clock second (an [`Observer`]; `rate` 0
/// does not wait).
#[derive(Debug)]
pub struct Pacer {
    rate: f64,
    start: Option<std::time::Instant>,
}

impl Pacer {
    /// A pacer at `rate` (finite and >= 0).
    pub fn new(rate: f64) -> Result<Self> {
        crate::error::nonnegative("rate", rate)?;
        Ok(Self { rate, start: None })
    }
}

impl Observer for Pacer {
    fn on_cycle(&mut self, c: &CycleView<'_>) -> Result<()> {
        if self.rate > 0.0 {
            let start = *self.start.get_or_insert_with(std::time::Instant::now);
            let due = start + std::time::Duration::from_secs_f64(c.time / self.rate);
            let now = std::time::Instant::now();
            if due > now {
                std::thread::sleep(due - now);
            }
        }
        Ok(())
    }
}
