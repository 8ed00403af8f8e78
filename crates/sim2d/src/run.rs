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
use crate::governor::{govern, GovernorParams};
use crate::perception::{Perception, PerceptionParams};
use crate::planner::{DdpParams, Plan, PlanRequest, FAR_AHEAD};
use crate::registry::PlannerKind;
use crate::route::{dist, Route};
use crate::scenario::Scenario;
use crate::world::{LidarParams, RobotParams, Scan, World};

/// Which way the route is driven.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
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
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
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
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
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
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PlanSnapshot {
    /// Simulated time (s).
    pub time: f64,
    /// Planned positions.
    pub positions: Vec<[f64; 2]>,
}

/// Summary statistics of a sample (ms for timings).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
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
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
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
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
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
    let mut epoch_ms = Vec::new();
    let mut cycle_ms = Vec::new();
    let mut trajectory = Vec::new();
    let mut goals = Vec::new();
    let mut plans = Vec::new();
    let mut controls: Vec<[f64; 2]> = Vec::new();
    let mut plan_index = 0usize;
    let mut progress = 0.0f64;
    let mut best_progress = 0.0f64;
    let mut stall_mark = (0.0f64, 0.0f64); // (time, progress) of the last real progress
    let mut distance = 0.0;
    let mut last_xy = start;
    let mut step = 0usize;
    let mut cycles = 0usize;
    let outcome;
    let loop_start = Instant::now();
    let mut observer_time = 0.0;

    loop {
        let time = step as f64 * config.control_dt;
        let scanned = step % scan_every == 0;
        if scanned {
            let t = Instant::now();
            world.scan(&config.lidar, &mut scan);
            let t1 = Instant::now();
            perception.update(&scan);
            timing.lidar += (t1 - t).as_secs_f64();
            timing.costmap += t1.elapsed().as_secs_f64();
        }
        let pose = world.pose();
        let xy = [pose[0], pose[1]];
        distance += dist(xy, last_xy);
        last_xy = xy;
        progress = route.project(xy, progress, 5.0, 10.0).0;
        best_progress = best_progress.max(progress);
        if best_progress >= stall_mark.1 + config.stall_distance {
            stall_mark = (time, best_progress);
        }
        if dist(xy, route.end()) <= config.goal_tolerance {
            outcome = Outcome::Completed;
            break;
        }
        if time - stall_mark.0 >= config.stall_time {
            outcome = Outcome::Stalled;
            break;
        }
        if time >= config.max_time {
            outcome = Outcome::Timeout;
            break;
        }
        let geometry = perception.costmap().geometry();
        let goal = route.local_goal(progress, geometry.center(), half);

        let mut plan_now = None;
        if step % config.plan_every == 0 {
            let t = Instant::now();
            let request = PlanRequest {
                time,
                state: pose,
                goal,
                far_goal: route.point_at((progress + FAR_AHEAD).min(route.length())),
                perception: &perception,
                steps_since_last: if step == 0 { 0 } else { config.plan_every },
            };
            let plan = planner.plan(&request)?;
            timing.planning += t.elapsed().as_secs_f64();
            cycle_ms.push(1e3 * (plan.setup_seconds + plan.epoch_seconds.iter().sum::<f64>()));
            epoch_ms.extend(plan.epoch_seconds.iter().map(|s| 1e3 * s));
            controls.clear();
            controls.extend_from_slice(&plan.controls);
            plan_index = 0;
            if config.keep_plan_every > 0 && cycles % config.keep_plan_every == 0 {
                plans.push(PlanSnapshot {
                    time,
                    positions: plan.states.iter().map(|s| [s[0], s[1]]).collect(),
                });
            }
            cycles += 1;
            plan_now = Some(plan);
        }
        // The executor: the plan's control for this step (the last one past the horizon), its
        // speed capped by the governor.
        let planned = controls
            .get(plan_index)
            .or(controls.last())
            .copied()
            .unwrap_or([0.0, 0.0]);
        let command = govern(
            &config.governor,
            &config.robot,
            perception.field(),
            pose,
            world.body_velocity()[0],
            config.control_dt,
            planned,
        );
        plan_index += 1;
        trajectory.push([time, pose[0], pose[1], pose[2], command[0], command[1]]);
        goals.push(goal);

        if !observers.is_empty() {
            let t = Instant::now();
            let view = CycleView {
                time,
                pose,
                command,
                goal,
                progress: best_progress,
                collisions: world.collisions(),
                plan: plan_now,
                scanned,
                scan: &scan,
                perception: &perception,
            };
            for o in observers.iter_mut() {
                o.on_cycle(&view)?;
            }
            observer_time += t.elapsed().as_secs_f64();
        }

        let t = Instant::now();
        world.step(command, config.control_dt);
        timing.physics += t.elapsed().as_secs_f64();
        step += 1;
    }
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
        progress_m: best_progress,
        distance_m: distance,
        collisions: world.collisions(),
        contact_time_s: world.contact_time(),
        final_pose: world.pose(),
        timing,
        real_time_factor: if timing.total > 0.0 {
            time_s / timing.total
        } else {
            f64::INFINITY
        },
        epoch_stats: Stats::of(&epoch_ms),
        cycle_stats: Stats::of(&cycle_ms),
        epoch_ms,
        trajectory,
        goals,
        plans,
    };
    for o in observers.iter_mut() {
        o.on_end(&result)?;
    }
    Ok(result)
}
