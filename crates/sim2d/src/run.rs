//! One run: a scenario driven in one direction by one planner, physics, lidar, costmap and
//! planning in a loop at the control rate (10 Hz), until the robot reaches the end of the route,
//! makes no progress for `stall_time` simulated seconds ("fail" in Table I), or runs out of time.
//!
//! ```no_run
//! use sim2d::{run_scenario, Direction, RunConfig, Scenario};
//! let scenario = Scenario::from_file("scenarios/cylinders.toml")?;
//! let result = run_scenario(&scenario, &RunConfig { direction: Direction::Backward, ..RunConfig::default() })?;
//! println!("{} in {:.1} s, {} collisions", result.outcome, result.time_s, result.collisions);
//! # Ok::<(), sim2d::Error>(())
//! ```

use std::time::Instant;

use crate::ddpen::DdpenParams;
use crate::error::{positive, Error, Result};
use crate::governor::GovernorParams;
use crate::perception::{Perception, PerceptionParams};
use crate::planner::{DdpParams, Plan, PlanRequest, FAR_AHEAD};
use crate::registry::PlannerKind;
use crate::route::Route;
use crate::scenario::Scenario;
use crate::world::{LidarParams, RobotParams, Scan, World};

/// Which way the route is driven.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// From the first route point to the last.
    Forward,
    /// From the last route point to the first.
    Backward,
}

impl Direction {
    /// `"forward"` or `"backward"`.
    pub fn name(&self) -> &'static str {
        match self {
            Direction::Forward => "forward",
            Direction::Backward => "backward",
        }
    }
}

impl std::fmt::Display for Direction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Everything a run needs besides the scenario (defaults: the DDPEN evaluation).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// The planner.
    pub planner: PlannerKind,
    /// Route direction.
    pub direction: Direction,
    /// Seed of the actuation and lidar noise.
    pub seed: u64,
    /// Control period (s): the executor sends a control every `control_dt` (paper: 10 Hz).
    pub control_dt: f64,
    /// Physics step (s).
    pub physics_dt: f64,
    /// Plan every this many control steps (1: a new plan every control period).
    pub plan_every: usize,
    /// The robot.
    pub robot: RobotParams,
    /// The lidar.
    pub lidar: LidarParams,
    /// The costmap.
    pub perception: PerceptionParams,
    /// The planner's problem.
    pub ddp: DdpParams,
    /// DDPEN's parameters (sub-goal weight and cadence, speed bound, model), used by `ddpen` and
    /// `ddpen-oracle`.
    pub ddpen: DdpenParams,
    /// The executor's speed governor ([`crate::governor`]).
    pub governor: GovernorParams,
    /// The run ends as completed within this distance of the route's end (m).
    pub goal_tolerance: f64,
    /// The run fails when progress along the route grows by less than `stall_distance` in this
    /// many simulated seconds (paper: 30 s).
    pub stall_time: f64,
    /// See `stall_time` (m).
    pub stall_distance: f64,
    /// The run is stopped after this much simulated time (s).
    pub max_time: f64,
    /// Keep one planned trajectory every this many cycles in the result (0: none).
    pub keep_plan_every: usize,
}

impl Default for RunConfig {
    fn default() -> Self {
        Self {
            planner: PlannerKind::DDP,
            direction: Direction::Forward,
            seed: 0,
            control_dt: 0.1,
            physics_dt: 0.02,
            plan_every: 1,
            robot: RobotParams::default(),
            lidar: LidarParams::default(),
            perception: PerceptionParams::default(),
            ddp: DdpParams::default(),
            ddpen: DdpenParams::default(),
            governor: GovernorParams::default(),
            goal_tolerance: 1.0,
            stall_time: 30.0,
            stall_distance: 0.5,
            max_time: 1200.0,
            keep_plan_every: 10,
        }
    }
}

impl RunConfig {
    /// Rejects impossible values, naming the field.
    pub fn validate(&self) -> Result<()> {
        positive("control_dt", self.control_dt)?;
        positive("physics_dt", self.physics_dt)?;
        if self.physics_dt > self.control_dt {
            return Err(Error::invalid("physics_dt", "must be <= control_dt"));
        }
        if self.plan_every == 0 {
            return Err(Error::invalid("plan_every", "must be at least 1"));
        }
        self.robot.validate()?;
        self.lidar.validate()?;
        self.perception.validate()?;
        self.ddp.validate()?;
        self.ddpen.validate(&self.ddp)?;
        self.governor.validate()?;
        if (self.ddp.dt - self.control_dt).abs() > 1e-12 {
            return Err(Error::invalid(
                "ddp.dt",
                format!("must equal control_dt = {} (got {})", self.control_dt, self.ddp.dt),
            ));
        }
        positive("goal_tolerance", self.goal_tolerance)?;
        positive("stall_time", self.stall_time)?;
        positive("stall_distance", self.stall_distance)?;
        positive("max_time", self.max_time)?;
        Ok(())
    }
}

/// How a run ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Outcome {
    /// Reached the end of the route.
    Completed,
    /// No progress for `stall_time` (a local minimum, or blocked): "fail" in Table I.
    Stalled,
    /// `max_time` elapsed.
    Timeout,
}

impl Outcome {
    /// Lower-case name.
    pub fn name(&self) -> &'static str {
        match self {
            Outcome::Completed => "completed",
            Outcome::Stalled => "stalled",
            Outcome::Timeout => "timeout",
        }
    }
}

impl std::fmt::Display for Outcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A planned trajectory kept for figures.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlanSnapshot {
    /// Simulated time (s).
    pub time: f64,
    /// Planned positions.
    pub positions: Vec<[f64; 2]>,
}

/// Summary statistics of a sample (ms for timings).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Stats {
    /// Number of samples.
    pub count: usize,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub p50: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Largest.
    pub max: f64,
}

impl Stats {
    /// Statistics of `values` (all zero when empty).
    pub fn of(values: &[f64]) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let q = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
        Self {
            count: v.len(),
            mean: v.iter().sum::<f64>() / v.len() as f64,
            p50: q(0.5),
            p99: q(0.99),
            max: v[v.len() - 1],
        }
    }
}

/// Wall time spent in each part of the loop (s).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Timing {
    /// Physics and the velocity controller.
    pub physics: f64,
    /// Lidar ray casts.
    pub lidar: f64,
    /// Costmap, decay, distance transform, inflation.
    pub costmap: f64,
    /// Planning (set-up and epochs).
    pub planning: f64,
    /// The whole loop, observers (logging) excluded.
    pub total: f64,
}

/// Everything measured in a run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunResult {
    /// Scenario name.
    pub scenario: String,
    /// Planner name.
    pub planner: String,
    /// Route direction.
    pub direction: Direction,
    /// Noise seed.
    pub seed: u64,
    /// How the run ended.
    pub outcome: Outcome,
    /// `outcome == Completed`.
    pub completed: bool,
    /// Simulated time at the end (s): the execution time of Table I when completed.
    pub time_s: f64,
    /// Route length (m).
    pub route_length_m: f64,
    /// Largest progress along the route (m).
    pub progress_m: f64,
    /// Path length driven (m).
    pub distance_m: f64,
    /// Contact onsets with obstacles.
    pub collisions: usize,
    /// Time in contact with obstacles (s).
    pub contact_time_s: f64,
    /// Final pose `[x, y, theta]`.
    pub final_pose: [f64; 3],
    /// Wall time per part of the loop (s).
    pub timing: Timing,
    /// Simulated seconds per wall-clock second of the loop (single thread).
    pub real_time_factor: f64,
    /// Compute time of every optimisation epoch (ms), in order.
    pub epoch_ms: Vec<f64>,
    /// Statistics of `epoch_ms`.
    pub epoch_stats: Stats,
    /// Statistics of the whole planning cycle (set-up and epochs, ms).
    pub cycle_stats: Stats,
    /// One row per control step: `[t, x, y, theta, v_cmd, w_cmd]`.
    pub trajectory: Vec<[f64; 6]>,
    /// Local goals, one per control step.
    pub goals: Vec<[f64; 2]>,
    /// Planned trajectories, one every `keep_plan_every` cycles.
    pub plans: Vec<PlanSnapshot>,
}

/// What observers see once per control step (after planning, before the physics step).
pub struct CycleView<'a> {
    /// Simulated time (s).
    pub time: f64,
    /// Robot pose `[x, y, theta]`.
    pub pose: [f64; 3],
    /// Command sent this step `[v, w]`.
    pub command: [f64; 2],
    /// The local goal.
    pub goal: [f64; 2],
    /// Progress along the route (m).
    pub progress: f64,
    /// Collisions so far.
    pub collisions: usize,
    /// The plan in force (`None` between plans when `plan_every > 1`).
    pub plan: Option<&'a Plan>,
    /// Whether the costmap was updated this step.
    pub scanned: bool,
    /// The last scan.
    pub scan: &'a Scan,
    /// The perception.
    pub perception: &'a Perception,
}

/// The fixed facts of a run, given to observers before the first step.
pub struct RunInfo<'a> {
    /// The scenario.
    pub scenario: &'a Scenario,
    /// The route as driven (reversed for backward runs).
    pub route: &'a Route,
    /// The configuration.
    pub config: &'a RunConfig,
}

/// Watches a run: loggers, progress bars. Errors stop the run.
pub trait Observer {
    /// Before the first step.
    fn on_start(&mut self, _info: &RunInfo<'_>) -> Result<()> {
        Ok(())
    }
    /// Every control step.
    fn on_cycle(&mut self, _cycle: &CycleView<'_>) -> Result<()> {
        Ok(())
    }
    /// After the last step.
    fn on_end(&mut self, _result: &RunResult) -> Result<()> {
        Ok(())
    }
}

/// Runs `scenario` with `config` (see the module docs).
pub fn run_scenario(scenario: &Scenario, config: &RunConfig) -> Result<RunResult> {
    run_scenario_with(scenario, config, &mut [])
}

/// Runs `scenario` with `config`, calling the observers along the way.
///
/// Each control step is a sequence of stages ([`stages`]), each with its own timer in
/// [`Timing`] where one exists: `scan` (lidar), `perceive` (costmap), `track` (progress along
/// the route; ends the run), `plan` (every `plan_every` steps), `govern` (the executor's command),
/// `observe` (the observers; excluded from [`Timing::total`]) and `step` (physics). What the
/// stages read and write lives in [`Tracker`], [`Executor`] and [`Records`], passed in.
pub fn run_scenario_with(
    scenario: &Scenario,
    config: &RunConfig,
    observers: &mut [&mut dyn Observer],
) -> Result<RunResult> {
    config.validate()?;
    let route = match config.direction {
        Direction::Forward => scenario.route.clone(),
        Direction::Backward => scenario.route.reversed(),
    };
    let start = route.start();
    let mut world = World::new(
        scenario,
        config.robot,
        [start[0], start[1], route.start_heading()],
        config.physics_dt,
        config.seed,
    )?;
    let mut perception = Perception::new(config.perception)?;
    let mut planner = config.planner.build(&config.ddp, &config.ddpen)?;
    let info = RunInfo {
        scenario,
        route: &route,
        config,
    };
    for o in observers.iter_mut() {
        o.on_start(&info)?;
    }

    let scan_every = ((1.0 / (config.lidar.rate_hz * config.control_dt)).round() as usize).max(1);
    let half = config.perception.half_size() - config.perception.resolution;
    let mut timing = Timing::default();
    let mut scan = Scan::default();
    let mut tracker = Tracker::new(start);
    let mut executor = Executor::default();
    let mut records = Records::default();
    let mut observer_time = 0.0;
    let mut k = 0usize;
    let loop_start = Instant::now();
    let outcome = loop {
        let time = k as f64 * config.control_dt;
        let scanned = k % scan_every == 0;
        if scanned {
            stages::scan(&mut world, &config.lidar, &mut scan, &mut timing);
            stages::perceive(&mut perception, &scan, &mut timing);
        }
        let pose = world.pose();
        if let Some(outcome) = stages::track(&mut tracker, &route, config, time, pose) {
            break outcome;
        }
        let goal = route.local_goal(tracker.progress, perception.costmap().geometry().center(), half);
        let plan = if k % config.plan_every == 0 {
            let request = PlanRequest {
                time,
                state: pose,
                goal,
                far_goal: route.point_at((tracker.progress + FAR_AHEAD).min(route.length())),
                perception: &perception,
                steps_since_last: if k == 0 { 0 } else { config.plan_every },
            };
            let plan = stages::plan(planner.as_mut(), &request, &mut timing)?;
            executor.load(plan);
            records.plan(time, plan, config.keep_plan_every);
            Some(plan)
        } else {
            None
        };
        let command = stages::govern(config, &perception, &world, pose, executor.next_control());
        records.step(time, pose, command, goal);
        if !observers.is_empty() {
            let view = CycleView {
                time,
                pose,
                command,
                goal,
                progress: tracker.best,
                collisions: world.collisions(),
                plan,
                scanned,
                scan: &scan,
                perception: &perception,
            };
            stages::observe(observers, &view, &mut observer_time)?;
        }
        stages::step(&mut world, command, config.control_dt, &mut timing);
        k += 1;
    };
    timing.total = loop_start.elapsed().as_secs_f64() - observer_time;
    let time_s = world.time();
    let result = RunResult {
        scenario: scenario.name.clone(),
        planner: planner.name().to_string(),
        direction: config.direction,
        seed: config.seed,
        outcome,
        completed: outcome == Outcome::Completed,
        time_s,
        route_length_m: route.length(),
        progress_m: tracker.best,
        distance_m: tracker.distance,
        collisions: world.collisions(),
        contact_time_s: world.contact_time(),
        final_pose: world.pose(),
        timing,
        real_time_factor: if timing.total > 0.0 {
            time_s / timing.total
        } else {
            f64::INFINITY
        },
        epoch_stats: Stats::of(&records.epoch_ms),
        cycle_stats: Stats::of(&records.cycle_ms),
        epoch_ms: records.epoch_ms,
        trajectory: records.trajectory,
        goals: records.goals,
        plans: records.plans,
    };
    for o in observers.iter_mut() {
        o.on_end(&result)?;
    }
    Ok(result)
}

/// Progress along the route and the end of a run (the `track` stage's state).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tracker {
    /// Progress along the route (m): the projection of the robot's position, searched near the
    /// previous one.
    pub progress: f64,
    /// Largest progress so far (m).
    pub best: f64,
    /// `(time, best)` when `best` last grew by `stall_distance`: the last real progress.
    pub stall_mark: (f64, f64),
    /// Path length driven (m).
    pub distance: f64,
    /// The position at the previous step.
    pub last_xy: [f64; 2],
}

impl Tracker {
    /// At the start of the route `start`, nothing driven.
    pub fn new(start: [f64; 2]) -> Self {
        Self {
            progress: 0.0,
            best: 0.0,
            stall_mark: (0.0, 0.0),
            distance: 0.0,
            last_xy: start,
        }
    }
}

/// The executor's plan in force: its controls and the index of the next one to send.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Executor {
    controls: Vec<[f64; 2]>,
    next: usize,
}

impl Executor {
    /// Takes the controls of a new plan, starting from its first.
    pub fn load(&mut self, plan: &Plan) {
        self.controls.clear();
        self.controls.extend_from_slice(&plan.controls);
        self.next = 0;
    }

    /// The plan's control for this step (the last one past the horizon; zero before any plan).
    pub fn next_control(&mut self) -> [f64; 2] {
        let u = self
            .controls
            .get(self.next)
            .or(self.controls.last())
            .copied()
            .unwrap_or([0.0, 0.0]);
        self.next += 1;
        u
    }
}

/// What a run keeps for its [`RunResult`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Records {
    /// Compute time of every optimisation epoch (ms).
    pub epoch_ms: Vec<f64>,
    /// Compute time of every planning cycle, set-up and epochs (ms).
    pub cycle_ms: Vec<f64>,
    /// `[t, x, y, theta, v_cmd, w_cmd]` per control step.
    pub trajectory: Vec<[f64; 6]>,
    /// The local goal per control step.
    pub goals: Vec<[f64; 2]>,
    /// One planned trajectory every `keep_plan_every` cycles.
    pub plans: Vec<PlanSnapshot>,
    /// Planning cycles so far.
    pub cycles: usize,
}

impl Records {
    /// A new plan at `time`: its timings, and its positions every `keep_every` cycles (0: never).
    pub fn plan(&mut self, time: f64, plan: &Plan, keep_every: usize) {
        self.cycle_ms
            .push(1e3 * (plan.setup_seconds + plan.epoch_seconds.iter().sum::<f64>()));
        self.epoch_ms.extend(plan.epoch_seconds.iter().map(|s| 1e3 * s));
        if keep_every > 0 && self.cycles % keep_every == 0 {
            self.plans.push(PlanSnapshot {
                time,
                positions: plan.states.iter().map(|s| [s[0], s[1]]).collect(),
            });
        }
        self.cycles += 1;
    }

    /// One control step: the pose, the command sent and the local goal.
    pub fn step(&mut self, time: f64, pose: [f64; 3], command: [f64; 2], goal: [f64; 2]) {
        self.trajectory
            .push([time, pose[0], pose[1], pose[2], command[0], command[1]]);
        self.goals.push(goal);
    }
}

/// The stages of a control step, in the order [`run_scenario_with`] calls them.
pub mod stages {
    use std::time::Instant;

    use super::{CycleView, Observer, Outcome, RunConfig, Timing, Tracker};
    use crate::error::Result;
    use crate::perception::Perception;
    use crate::planner::{Plan, PlanRequest, Planner};
    use crate::route::{dist, Route};
    use crate::world::{LidarParams, Scan, World};

    /// The lidar scan into `scan` (timer: [`Timing::lidar`]).
    pub fn scan(world: &mut World, lidar: &LidarParams, scan: &mut Scan, timing: &mut Timing) {
        let t = Instant::now();
        world.scan(lidar, scan);
        timing.lidar += t.elapsed().as_secs_f64();
    }

    /// Costmap, decay, distance transform and inflation from `scan` (timer: [`Timing::costmap`]).
    pub fn perceive(perception: &mut Perception, scan: &Scan, timing: &mut Timing) {
        let t = Instant::now();
        perception.update(scan);
        timing.costmap += t.elapsed().as_secs_f64();
    }

    /// Distance driven and progress along the route from the robot's `pose` at `time`; the
    /// outcome when the run ends here (the end reached, no progress for `stall_time`, or
    /// `max_time`).
    pub fn track(
        tracker: &mut Tracker,
        route: &Route,
        config: &RunConfig,
        time: f64,
        pose: [f64; 3],
    ) -> Option<Outcome> {
        let xy = [pose[0], pose[1]];
        tracker.distance += dist(xy, tracker.last_xy);
        tracker.last_xy = xy;
        tracker.progress = route.project(xy, tracker.progress, 5.0, 10.0).0;
        tracker.best = tracker.best.max(tracker.progress);
        if tracker.best >= tracker.stall_mark.1 + config.stall_distance {
            tracker.stall_mark = (time, tracker.best);
        }
        if dist(xy, route.end()) <= config.goal_tolerance {
            Some(Outcome::Completed)
        } else if time - tracker.stall_mark.0 >= config.stall_time {
            Some(Outcome::Stalled)
        } else if time >= config.max_time {
            Some(Outcome::Timeout)
        } else {
            None
        }
    }

    /// A planning cycle (timer: [`Timing::planning`]).
    pub fn plan<'p>(planner: &'p mut dyn Planner, request: &PlanRequest<'_>, timing: &mut Timing) -> Result<&'p Plan> {
        let t = Instant::now();
        let plan = planner.plan(request)?;
        timing.planning += t.elapsed().as_secs_f64();
        Ok(plan)
    }

    /// The command sent this step: the plan's control `planned`, its speed capped by the
    /// governor ([`crate::governor`]).
    pub fn govern(
        config: &RunConfig,
        perception: &Perception,
        world: &World,
        pose: [f64; 3],
        planned: [f64; 2],
    ) -> [f64; 2] {
        crate::governor::govern(
            &config.governor,
            &config.robot,
            perception.field(),
            pose,
            world.body_velocity()[0],
            config.control_dt,
            planned,
        )
    }

    /// The observers (their time is kept in `observer_time`, outside [`Timing`]).
    pub fn observe(observers: &mut [&mut dyn Observer], view: &CycleView<'_>, observer_time: &mut f64) -> Result<()> {
        let t = Instant::now();
        for o in observers.iter_mut() {
            o.on_cycle(view)?;
        }
        *observer_time += t.elapsed().as_secs_f64();
        Ok(())
    }

    /// Physics and the velocity controller for one control period (timer: [`Timing::physics`]).
    pub fn step(world: &mut World, command: [f64; 2], dt: f64, timing: &mut Timing) {
        let t = Instant::now();
        world.step(command, dt);
        timing.physics += t.elapsed().as_secs_f64();
    }
}
