//! The Safe-CDDP hardware experiment (Alcan and Kyrki (2022), §IV-C and Fig. 5) in
//! simulation: a Turtlebot3-sized differential-drive robot drives from `(0, 0, 0)` to
//! `(1.4, 0.6, 0)` past two discs, r = 0.15 m at (0.85, 0) and r = 0.11 m at (0.5, 0.85), under
//! the shrinking-horizon MPC of Algorithm 1 (N = 90 knots of 0.1 s, `n1 = 10` iterations per
//! step, tightening every `n2 = 5`), once with plain CDDP and once with Safe-CDDP (`beta = 0.8`).
//!
//! ```no_run
//! use sim2d::turtlebot::{run_episode, Controller, TurtlebotConfig};
//! let config = TurtlebotConfig::default();
//! let cddp = run_episode(&config, Controller::Cddp, 3)?;
//! let safe = run_episode(&config, Controller::SafeCddp { beta: 0.8 }, 3)?;
//! println!("closest approach: CDDP {:.3} m, Safe-CDDP {:.3} m", cddp.min_clearance, safe.min_clearance);
//! # Ok::<(), sim2d::Error>(())
//! ```
//!
//! **Plan.** The model is [`ddp_core::models::DifferentialDrive`] (state `(x, y, theta)`, wheel
//! speeds `(v_l, v_r)` within `+-0.22` m/s, track 0.16 m). Cost: `r |u|^2` per knot and
//! `(x_N - x_goal)^T Q_f (x_N - x_goal)` at the end. Each disc is a
//! [`safe_cddp::constraints::Circle`] in distance form, `r_i + r_robot - |p - c_i| <= 0`, where
//! `r_robot` is the radius of the circle around the robot's footprint ([`TurtlebotConfig::inflation`]).
//! Safe-CDDP tightens it by `phi^{-1}(beta) sqrt(n^T Sigma_k n)` (eqs. 19-20) with the assumed
//! process noise [`TurtlebotConfig::sigma_w`] and, as `Sigma_0`, the localisation covariance.
//!
//! **Execution.** The robot is sim2d's rapier2d body ([`crate::world::World`]) with the
//! footprint of a Turtlebot3 Burger ([`burger`]: 0.138 m x 0.178 m, 1 kg), driven by the body
//! twist `(v, w)` of the planned wheel speeds through the velocity-tracking controller (rate
//! limits, correlated actuation noise), so the motion differs from the plan. The controller
//! sees the true pose plus seeded Gaussian localisation noise ([`TurtlebotConfig::sigma_xy`],
//! [`TurtlebotConfig::sigma_theta`]): the paper's AMCL + odometry. Each control period:
//! measure, re-solve warm-started from the shifted previous solution (`n1` iterations), apply
//! `u_0`, shift, `N <- N - 1` (Algorithm 1), down to [`TurtlebotConfig::min_horizon`]; the
//! episode ends when the measured position is within [`TurtlebotConfig::goal_radius`] of the goal
//! or after [`TurtlebotConfig::max_steps`].
//!
//! **Metrics** (the paper's Fig. 5b-c): the *clearance* is the distance between the robot's true
//! footprint (the rectangle) and the closest disc, evaluated at every physics step; an episode's
//! figure is its minimum. Collisions are rapier contacts of the footprint with a disc
//! (contact onsets, [`crate::world::World::collisions`]).
//!
//! Episode `seed` meets the same actuation and localisation noise under both controllers
//! (common random numbers), and a run is deterministic for its seed.

use ddp_core::dims::{U2, U3};
use std::sync::Arc;
use std::time::Instant;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::models::DifferentialDrive;
use ddp_core::{ControlBounds, Matrix, Problem, Vector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;
use safe_cddp::constraints::Circle;
use safe_cddp::{Constraint, IterationOutcome, SafeCddpSolver, Settings, Status, Tightening};
use serde::{Deserialize, Serialize};

use crate::error::{finite_each, nonnegative, positive, Error, Result};
use crate::route::Route;
use crate::run::Stats;
use crate::scenario::{Obstacle, Scenario};
use crate::world::{RobotParams, World};

pub mod sweep;

/// A disc obstacle `(x, y, r)` of the experiment (m).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Disc {
    /// Centre.
    pub center: [f64; 2],
    /// Radius.
    pub radius: f64,
}

/// The paper's two obstacles: r = 0.15 m at (0.85, 0) and r = 0.11 m at (0.5, 0.85).
pub const PAPER_DISCS: [Disc; 2] = [
    Disc {
        center: [0.85, 0.0],
        radius: 0.15,
    },
    Disc {
        center: [0.5, 0.85],
        radius: 0.11,
    },
];

/// A Turtlebot3 Burger as a sim2d robot: footprint 0.138 m (along the heading) x 0.178 m (the
/// Burger's outer length and width), 1 kg, `|v| <= 0.22` m/s, `|w| <= 2.84` rad/s (its limits),
/// actuator rate limits 1 m/s^2 and 5 rad/s^2, 5 % speed noise and 0.05 rad/s turn-rate noise
/// (correlation time 0.5 s). Track width 0.16 m.
pub fn burger() -> RobotParams {
    RobotParams {
        length: 0.138,
        width: 0.178,
        mass: 1.0,
        v_max: 0.22,
        w_max: 2.84,
        accel_max: 1.0,
        alpha_max: 5.0,
        traction: 4.0,
        angular_traction: 20.0,
        noise_v: 0.05,
        noise_w: 0.05,
        noise_tau: 0.5,
    }
}

/// A Turtlebot3 Waffle Pi (the paper's robot) as a sim2d robot: footprint 0.281 m x 0.306 m,
/// 1.8 kg, `|v| <= 0.26` m/s, `|w| <= 1.82` rad/s, otherwise as [`burger`]. Track width 0.287 m.
pub fn waffle_pi() -> RobotParams {
    RobotParams {
        length: 0.281,
        width: 0.306,
        mass: 1.8,
        v_max: 0.26,
        w_max: 1.82,
        ..burger()
    }
}

/// Which Turtlebot3. Written as `"burger"` or `"waffle-pi"`; read by [`Turtlebot::parse`], so a
/// bad name is an error naming `robot`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", try_from = "String")]
pub enum Turtlebot {
    /// Turtlebot3 Burger ([`burger`]).
    Burger,
    /// Turtlebot3 Waffle Pi ([`waffle_pi`]), the robot of the paper's experiment.
    WafflePi,
}

impl Turtlebot {
    /// Parses `"burger"` or `"waffle-pi"`; the error names `robot`.
    pub fn parse(name: &str) -> Result<Self> {
        match name {
            "burger" => Ok(Turtlebot::Burger),
            "waffle-pi" | "waffle_pi" | "waffle" => Ok(Turtlebot::WafflePi),
            other => Err(Error::invalid(
                "robot",
                format!("unknown robot {other:?}; known: burger, waffle-pi"),
            )),
        }
    }
    /// `"burger"` or `"waffle-pi"`.
    pub fn name(&self) -> &'static str {
        match self {
            Turtlebot::Burger => "burger",
            Turtlebot::WafflePi => "waffle-pi",
        }
    }
}

impl TryFrom<String> for Turtlebot {
    type Error = Error;
    fn try_from(name: String) -> Result<Self> {
        Self::parse(&name)
    }
}

/// The two controllers compared.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Controller {
    /// Constrained DDP on the inflated discs, no tightening (`beta = 0.5`).
    Cddp,
    /// Safe-CDDP: the discs tightened with satisfaction probability `beta`.
    SafeCddp {
        /// `beta` in (0, 1) (the paper's hardware run: 0.8).
        beta: f64,
    },
}

impl Controller {
    /// `"cddp"` or `"safe-cddp"`.
    pub fn name(&self) -> &'static str {
        match self {
            Controller::Cddp => "cddp",
            Controller::SafeCddp { .. } => "safe-cddp",
        }
    }
}

/// Everything the experiment needs (defaults: the paper's §IV-C setup and our noise).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TurtlebotConfig {
    /// Start pose `(x, y, theta)`.
    pub start: [f64; 3],
    /// Goal pose `(x, y, theta)`.
    pub goal: [f64; 3],
    /// The obstacles (true size; the constraints add [`TurtlebotConfig::inflation`]).
    pub discs: Vec<Disc>,
    /// Initial horizon `N` (knots).
    pub horizon: usize,
    /// Knot and control period (s).
    pub dt: f64,
    /// Physics step (s).
    pub physics_dt: f64,
    /// Track width of the model (m).
    pub track_width: f64,
    /// Wheel speed limit `|v_l|, |v_r| <= wheel_speed_max` (m/s).
    pub wheel_speed_max: f64,
    /// Weight `r` of `r |u|^2` per knot.
    pub control_weight: f64,
    /// Terminal weights on `(x, y, theta)`.
    pub terminal_weights: [f64; 3],
    /// The robot in the physics world.
    pub robot: RobotParams,
    /// Radius added to each disc in the constraints (m): the circumscribed radius of the
    /// footprint, so that a satisfied constraint keeps the whole footprint off the disc.
    pub inflation: f64,
    /// Standard deviation of the localisation noise on `x` and `y` (m).
    pub sigma_xy: f64,
    /// Standard deviation of the localisation noise on `theta` (rad).
    pub sigma_theta: f64,
    /// Per-step process noise the tightening assumes, standard deviations on `(x, y, theta)`
    /// (`Sigma_w = diag(sigma_w^2)`).
    pub sigma_w: [f64; 3],
    /// `n1`: iterations per MPC step.
    pub iterations: usize,
    /// Iterations of the first solve (before the robot moves).
    pub initial_iterations: usize,
    /// `n2`: tightening period (iterations).
    pub update_every: usize,
    /// The horizon shrinks by one knot per step down to this.
    pub min_horizon: usize,
    /// The episode ends after this many control steps.
    pub max_steps: usize,
    /// Success when the measured position is within this distance of the goal (m).
    pub goal_radius: f64,
}

impl Default for TurtlebotConfig {
    /// [`TurtlebotConfig::for_robot`] of the Waffle Pi.
    fn default() -> Self {
        Self::for_robot(Turtlebot::WafflePi)
    }
}

impl TurtlebotConfig {
    /// The experiment with `robot`: its footprint, track width and wheel-speed limit, the
    /// inflation its circumscribed radius; the rest as the paper and our noise.
    pub fn for_robot(robot: Turtlebot) -> Self {
        let (params, track_width, wheel_speed_max) = match robot {
            Turtlebot::Burger => (burger(), DifferentialDrive::TURTLEBOT3_BURGER_TRACK_WIDTH, 0.22),
            Turtlebot::WafflePi => (waffle_pi(), 0.287, 0.26),
        };
        Self {
            start: [0.0, 0.0, 0.0],
            goal: [1.4, 0.6, 0.0],
            discs: PAPER_DISCS.to_vec(),
            horizon: 90,
            dt: 0.1,
            physics_dt: 0.01,
            track_width,
            wheel_speed_max,
            control_weight: 0.1,
            terminal_weights: [100.0, 100.0, 10.0],
            inflation: params.circumscribed_radius(),
            robot: params,
            sigma_xy: 0.01,
            sigma_theta: 0.02,
            sigma_w: [0.005, 0.005, 0.01],
            iterations: 10,
            initial_iterations: 300,
            update_every: 5,
            min_horizon: 10,
            max_steps: 150,
            goal_radius: 0.05,
        }
    }
}

impl TurtlebotConfig {
    /// Rejects impossible values, naming the field.
    pub fn validate(&self) -> Result<()> {
        finite_each("start", &self.start)?;
        finite_each("goal", &self.goal)?;
        for (i, d) in self.discs.iter().enumerate() {
            finite_each(&format!("discs[{i}].center"), &d.center)?;
            positive(&format!("discs[{i}].radius"), d.radius)?;
        }
        if self.horizon == 0 {
            return Err(Error::invalid("horizon", "must be at least 1"));
        }
        positive("dt", self.dt)?;
        positive("physics_dt", self.physics_dt)?;
        if self.physics_dt > self.dt {
            return Err(Error::invalid("physics_dt", "must be <= dt"));
        }
        positive("track_width", self.track_width)?;
        positive("wheel_speed_max", self.wheel_speed_max)?;
        nonnegative("control_weight", self.control_weight)?;
        for (i, w) in self.terminal_weights.iter().enumerate() {
            nonnegative(&format!("terminal_weights[{i}]"), *w)?;
        }
        self.robot.validate()?;
        nonnegative("inflation", self.inflation)?;
        nonnegative("sigma_xy", self.sigma_xy)?;
        nonnegative("sigma_theta", self.sigma_theta)?;
        for (i, s) in self.sigma_w.iter().enumerate() {
            nonnegative(&format!("sigma_w[{i}]"), *s)?;
        }
        for (name, v) in [
            ("iterations", self.iterations),
            ("initial_iterations", self.initial_iterations),
            ("update_every", self.update_every),
            ("min_horizon", self.min_horizon),
            ("max_steps", self.max_steps),
        ] {
            if v == 0 {
                return Err(Error::invalid(name, "must be at least 1"));
            }
        }
        if self.min_horizon > self.horizon {
            return Err(Error::invalid("min_horizon", "must be <= horizon"));
        }
        positive("goal_radius", self.goal_radius)?;
        Ok(())
    }

    /// The deterministic optimal-control problem from the start pose (horizon `N`, wheel-speed box).
    pub fn problem(&self) -> Result<Problem<U3, U2>> {
        let model = DifferentialDrive::new(self.dt, self.track_width)?;
        let r = self.control_weight;
        let running = QuadraticCost::diagonal(&[0.0; 3], &[r, r], Vector::zeros(), Vector::zeros())?;
        let goal = Vector::<3>::from_row_slice(&self.goal);
        let terminal = QuadraticTerminal::diagonal(&self.terminal_weights, goal)?;
        let w = self.wheel_speed_max;
        let bounds = ControlBounds::new(Vector::repeat(-w), Vector::repeat(w))?;
        Ok(Problem::new(
            Vector::<3>::from_row_slice(&self.start),
            Arc::new(model),
            Arc::new(running),
            Arc::new(terminal),
            self.horizon,
        )?
        .with_control_bounds(bounds)?)
    }

    /// The constraint rows: each disc grown by [`TurtlebotConfig::inflation`], distance form
    /// (`g = r + inflation - |p - c|`, metres).
    pub fn constraints(&self) -> Result<Vec<Arc<dyn Constraint<U3, U2>>>> {
        self.discs
            .iter()
            .map(|d| -> Result<Arc<dyn Constraint<U3, U2>>> {
                Ok(Arc::new(Circle::<U3>::distance(
                    d.center,
                    d.radius + self.inflation,
                    [0, 1],
                )?))
            })
            .collect()
    }

    /// The tightening of `beta`: `Sigma_w = diag(sigma_w^2)`, `Sigma_0` the localisation
    /// covariance, `n2 = update_every`.
    pub fn tightening(&self, beta: f64) -> Result<Tightening<U3, U2>> {
        let sw = Vector::<3>::from_iterator(self.sigma_w.iter().map(|s| s * s));
        let s0 = Vector::<3>::new(
            self.sigma_xy * self.sigma_xy,
            self.sigma_xy * self.sigma_xy,
            self.sigma_theta * self.sigma_theta,
        );
        Ok(Tightening::new(beta, Matrix::from_diagonal(&sw))?
            .with_initial_covariance(Matrix::from_diagonal(&s0))?
            .with_update_every(self.update_every)?)
    }

    /// The physics scene: the discs as cylinders (route: start to goal, unused by the MPC).
    pub fn scenario(&self) -> Result<Scenario> {
        Ok(Scenario {
            name: "turtlebot".into(),
            description: "Safe-CDDP hardware experiment (Alcan and Kyrki (2022), §IV-C)".into(),
            route: Route::new(vec![[self.start[0], self.start[1]], [self.goal[0], self.goal[1]]])?,
            obstacles: self
                .discs
                .iter()
                .map(|d| Obstacle::Cylinder {
                    center: d.center,
                    radius: d.radius,
                })
                .collect(),
        })
    }
}

/// Signed distance between the footprint rectangle (`length` along the heading, `width`, centred
/// at the pose) and a disc: negative when they overlap (then minus the depth of the disc centre
/// inside the rectangle, minus the radius).
pub fn footprint_clearance(pose: [f64; 3], length: f64, width: f64, disc: &Disc) -> f64 {
    let (s, c) = pose[2].sin_cos();
    let (dx, dy) = (disc.center[0] - pose[0], disc.center[1] - pose[1]);
    // The disc centre in the robot frame.
    let (px, py) = (c * dx + s * dy, -s * dx + c * dy);
    let (hx, hy) = (0.5 * length, 0.5 * width);
    let (qx, qy) = (px.abs() - hx, py.abs() - hy);
    let outside = qx.max(0.0).hypot(qy.max(0.0));
    let inside = qx.max(qy).min(0.0);
    outside + inside - disc.radius
}

/// One episode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TurtlebotRun {
    /// The controller.
    pub controller: Controller,
    /// The noise seed.
    pub seed: u64,
    /// The measured position came within `goal_radius` of the goal.
    pub reached: bool,
    /// Control steps applied.
    pub steps: usize,
    /// Simulated time (s).
    pub time_s: f64,
    /// Contact onsets of the footprint with a disc (rapier).
    pub collisions: usize,
    /// Time in contact (s).
    pub contact_time_s: f64,
    /// Minimum over the run of the clearance between the true footprint and the closest disc (m).
    pub min_clearance: f64,
    /// Minimum clearance to each disc (m).
    pub min_clearance_per_disc: Vec<f64>,
    /// Minimum over the run of the distance between the true centre and the closest disc's
    /// boundary minus the inflation: the constraint's own measure, `-g` at the true pose (m).
    pub min_constraint_margin: f64,
    /// Distance of the true final position from the goal (m).
    pub final_error: f64,
    /// MPC steps whose solve reported an infeasible QP or trajectory.
    pub infeasible_steps: usize,
    /// Wall time of each MPC solve (ms): the first solve, then one per step.
    pub solve_ms: Vec<f64>,
    /// True poses `(x, y, theta)` at every control step, the start included.
    pub poses: Vec<[f64; 3]>,
    /// Measured poses the controller used, one per control step.
    pub measured: Vec<[f64; 3]>,
    /// Body twists `(v, w)` sent, one per control step.
    pub commands: Vec<[f64; 2]>,
    /// The first plan's positions.
    pub first_plan: Vec<[f64; 2]>,
}

fn wrap_near(angle: f64, reference: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    angle - tau * ((angle - reference) / tau).round()
}

/// `n` iterations of Algorithm 1's inner loop (lines 3-26); returns whether an iteration
/// reported an infeasible QP or trajectory.
fn iterate(solver: &mut SafeCddpSolver<U3, U2>, problem: &Problem<U3, U2>, n: usize) -> Result<bool> {
    let tightening = solver.tightening().cloned();
    let mut infeasible = false;
    // The first KKT/QP iteration of a step tightens (iter % n2 == 0), then every n2.
    let mut since = usize::MAX / 2;
    for _ in 0..n {
        let outcome = solver.iterate(problem)?;
        if let IterationOutcome::Failed(Status::Infeasible { .. }) = outcome {
            infeasible = true;
        }
        if let Some(t) = &tightening {
            since += 1;
            if solver.tightening_due(since, t) {
                solver.tighten(problem)?;
                since = 0;
            }
        }
        if matches!(outcome, IterationOutcome::Converged | IterationOutcome::Failed(_)) {
            break;
        }
    }
    Ok(infeasible)
}

/// Runs one episode of `controller` with the noise of `seed` (see the module docs).
pub fn run_episode(config: &TurtlebotConfig, controller: Controller, seed: u64) -> Result<TurtlebotRun> {
    config.validate()?;
    let mut problem = config.problem()?;
    let mut solver = SafeCddpSolver::new(&problem, config.constraints()?, Settings::default())?;
    if let Controller::SafeCddp { beta } = controller {
        if !(beta > 0.0 && beta < 1.0) {
            return Err(Error::invalid("beta", format!("must be in (0, 1), got {beta}")));
        }
        solver.set_tightening(Some(config.tightening(beta)?))?;
    }
    let model = DifferentialDrive::new(config.dt, config.track_width)?;
    let scenario = config.scenario()?;
    let mut world = World::new(&scenario, config.robot, config.start, config.physics_dt, seed)?;
    // Localisation noise: its own stream, the same for both controllers.
    let mut loc_rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5a5a_1c0c_d00d_f00d);
    let substeps = (config.dt / config.physics_dt).round().max(1.0) as usize;
    let (length, width) = (config.robot.length, config.robot.width);

    let mut min_per_disc = vec![f64::INFINITY; config.discs.len()];
    let mut min_margin = f64::INFINITY;
    let observe = |pose: [f64; 3], min_per_disc: &mut [f64], min_margin: &mut f64| {
        for (m, d) in min_per_disc.iter_mut().zip(&config.discs) {
            *m = m.min(footprint_clearance(pose, length, width, d));
            let centre = (pose[0] - d.center[0]).hypot(pose[1] - d.center[1]);
            *min_margin = min_margin.min(centre - d.radius - config.inflation);
        }
    };
    let mut measure = |pose: [f64; 3], previous_theta: f64| -> [f64; 3] {
        let n: [f64; 3] = std::array::from_fn(|_| StandardNormal.sample(&mut loc_rng));
        [
            pose[0] + config.sigma_xy * n[0],
            pose[1] + config.sigma_xy * n[1],
            wrap_near(pose[2], previous_theta) + config.sigma_theta * n[2],
        ]
    };

    let true0 = world.pose();
    observe(true0, &mut min_per_disc, &mut min_margin);
    let mut measured = measure(true0, config.start[2]);
    let mut run = TurtlebotRun {
        controller,
        seed,
        reached: false,
        steps: 0,
        time_s: 0.0,
        collisions: 0,
        contact_time_s: 0.0,
        min_clearance: f64::INFINITY,
        min_clearance_per_disc: Vec::new(),
        min_constraint_margin: f64::INFINITY,
        final_error: f64::NAN,
        infeasible_steps: 0,
        solve_ms: Vec::with_capacity(config.max_steps + 1),
        poses: vec![true0],
        measured: Vec::with_capacity(config.max_steps),
        commands: Vec::with_capacity(config.max_steps),
        first_plan: Vec::new(),
    };

    // Algorithm 1, line 1: the first plan from the first measurement.
    let mut n = config.horizon;
    solver.set_horizon(n)?;
    solver.reset();
    problem.set_x0(Vector::<3>::from_row_slice(&measured))?;
    let t = Instant::now();
    solver.start(&problem)?;
    iterate(&mut solver, &problem, config.initial_iterations)?;
    run.solve_ms.push(1e3 * t.elapsed().as_secs_f64());
    run.first_plan = solver.xs().iter().map(|x| [x[0], x[1]]).collect();

    for step in 0..config.max_steps {
        if step > 0 {
            let t = Instant::now();
            solver.start(&problem)?;
            if iterate(&mut solver, &problem, config.iterations)? {
                run.infeasible_steps += 1;
            }
            run.solve_ms.push(1e3 * t.elapsed().as_secs_f64());
        }
        let (v, w) = model.body_twist(&solver.us()[0]);
        run.measured.push(measured);
        run.commands.push([v, w]);
        for _ in 0..substeps {
            world.step([v, w], config.physics_dt);
            observe(world.pose(), &mut min_per_disc, &mut min_margin);
        }
        run.steps += 1;
        let pose = world.pose();
        let pose = [pose[0], pose[1], wrap_near(pose[2], run.poses[run.poses.len() - 1][2])];
        run.poses.push(pose);
        measured = measure(pose, measured[2]);
        if (measured[0] - config.goal[0]).hypot(measured[1] - config.goal[1]) <= config.goal_radius {
            run.reached = true;
            break;
        }
        // Lines 27-31: the new measurement, the shifted trajectory, a shorter horizon.
        problem.set_x0(Vector::<3>::from_row_slice(&measured))?;
        solver.shift();
        n = (n - 1).max(config.min_horizon);
        solver.set_horizon(n)?;
    }
    let last = run.poses[run.poses.len() - 1];
    run.final_error = (last[0] - config.goal[0]).hypot(last[1] - config.goal[1]);
    run.time_s = world.time();
    run.collisions = world.collisions();
    run.contact_time_s = world.contact_time();
    run.min_clearance = min_per_disc.iter().copied().fold(f64::INFINITY, f64::min);
    run.min_clearance_per_disc = min_per_disc;
    run.min_constraint_margin = min_margin;
    Ok(run)
}

/// The seed of episode `i` of an experiment with base seed `seed` (the same for both controllers).
pub fn episode_seed(seed: u64, i: usize) -> u64 {
    seed.wrapping_mul(1_000_003).wrapping_add(i as u64)
}

/// Mean, standard deviation and quantiles of a sample.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Distribution1 {
    /// Number of samples.
    pub count: usize,
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation.
    pub sd: f64,
    /// Smallest.
    pub min: f64,
    /// 10th percentile.
    pub p10: f64,
    /// Median.
    pub p50: f64,
    /// 90th percentile.
    pub p90: f64,
    /// Largest.
    pub max: f64,
}

impl Distribution1 {
    /// Statistics of `values` (all zero when empty).
    pub fn of(values: &[f64]) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let mean = v.iter().sum::<f64>() / n as f64;
        let sd = if n > 1 {
            (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
        } else {
            0.0
        };
        let q = |p: f64| v[((p * (n - 1) as f64).round() as usize).min(n - 1)];
        Self {
            count: n,
            mean,
            sd,
            min: v[0],
            p10: q(0.1),
            p50: q(0.5),
            p90: q(0.9),
            max: v[n - 1],
        }
    }
}

/// The figures of one controller over all episodes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// The controller.
    pub controller: Controller,
    /// Episodes.
    pub runs: usize,
    /// Episodes that reached the goal region.
    pub reached: usize,
    /// Episodes with at least one collision.
    pub collided_runs: usize,
    /// Episodes that reached the goal without a collision.
    pub successes: usize,
    /// Collisions over all episodes.
    pub collisions: usize,
    /// Minimum clearance per episode (Fig. 5c), m.
    pub min_clearance: Distribution1,
    /// Minimum constraint margin per episode (centre distance minus inflated radius), m.
    pub min_constraint_margin: Distribution1,
    /// Episode duration (s).
    pub time_s: Distribution1,
    /// Final distance to the goal (m).
    pub final_error: Distribution1,
    /// MPC steps with an infeasible solve, over all episodes.
    pub infeasible_steps: usize,
    /// Wall time of the per-step solves (`n1` iterations), ms.
    pub step_solve_ms: Stats,
    /// Wall time of the first solves, ms.
    pub first_solve_ms: Stats,
}

impl Summary {
    /// Summarises `runs` (all of one controller).
    pub fn of(controller: Controller, runs: &[TurtlebotRun]) -> Self {
        let col = |f: &dyn Fn(&TurtlebotRun) -> f64| runs.iter().map(f).collect::<Vec<f64>>();
        let steps: Vec<f64> = runs.iter().flat_map(|r| r.solve_ms.iter().skip(1).copied()).collect();
        let first: Vec<f64> = runs.iter().filter_map(|r| r.solve_ms.first().copied()).collect();
        Self {
            controller,
            runs: runs.len(),
            reached: runs.iter().filter(|r| r.reached).count(),
            collided_runs: runs.iter().filter(|r| r.collisions > 0).count(),
            successes: runs.iter().filter(|r| r.reached && r.collisions == 0).count(),
            collisions: runs.iter().map(|r| r.collisions).sum(),
            min_clearance: Distribution1::of(&col(&|r| r.min_clearance)),
            min_constraint_margin: Distribution1::of(&col(&|r| r.min_constraint_margin)),
            time_s: Distribution1::of(&col(&|r| r.time_s)),
            final_error: Distribution1::of(&col(&|r| r.final_error)),
            infeasible_steps: runs.iter().map(|r| r.infeasible_steps).sum(),
            step_solve_ms: Stats::of(&steps),
            first_solve_ms: Stats::of(&first),
        }
    }
}

/// CDDP and Safe-CDDP over the same seeded episodes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Experiment {
    /// The configuration.
    pub config: TurtlebotConfig,
    /// Base seed.
    pub seed: u64,
    /// `beta` of Safe-CDDP.
    pub beta: f64,
    /// CDDP's episodes, in seed order.
    pub cddp: Vec<TurtlebotRun>,
    /// Safe-CDDP's episodes, in seed order (episode `i` has the noise of CDDP's episode `i`).
    pub safe: Vec<TurtlebotRun>,
    /// Summary of CDDP.
    pub cddp_summary: Summary,
    /// Summary of Safe-CDDP.
    pub safe_summary: Summary,
    /// Episodes where Safe-CDDP's minimum clearance exceeds CDDP's (paired comparison).
    pub safe_wider: usize,
}

/// Runs `runs` episodes of each controller in parallel (rayon's pool), calling `progress` after
/// each episode (from worker threads). Deterministic for `(config, runs, seed, beta)`, apart from
/// the measured solve times.
///
/// The episodes are the tasks of [`sweep`]: [`sweep::episode_tasks`], each run by
/// [`sweep::run_task`], gathered by [`sweep::experiment_of`] (what `python -m
/// ddpkit.experiments safe-turtlebot` runs on other executors).
pub fn run_experiment(
    config: &TurtlebotConfig,
    runs: usize,
    seed: u64,
    beta: f64,
    progress: &(dyn Fn() + Sync),
) -> Result<Experiment> {
    let tasks = sweep::episode_tasks(config, runs, seed, beta)?;
    let results: Vec<TurtlebotRun> = tasks
        .par_iter()
        .map(|t| {
            let r = sweep::run_task(t);
            progress();
            r
        })
        .collect::<Result<_>>()?;
    sweep::experiment_of(config, runs, seed, beta, &results)
}

/// Counts of `values` in `bins` equal bins over `[lo, hi)` (values outside go to the end bins).
pub fn histogram(values: &[f64], lo: f64, hi: f64, bins: usize) -> Vec<usize> {
    let mut h = vec![0; bins.max(1)];
    let n = h.len();
    for v in values {
        let i = ((v - lo) / (hi - lo) * n as f64).floor();
        let i = if i.is_nan() {
            0
        } else {
            i.clamp(0.0, (n - 1) as f64) as usize
        };
        h[i] += 1;
    }
    h
}

/// The bin range of the Fig. 5c histograms: from the smaller of -1 cm and the smallest
/// clearance, to the largest, in whole centimetres.
pub fn histogram_range(e: &Experiment) -> (f64, f64) {
    let all = e.cddp.iter().chain(&e.safe).map(|r| r.min_clearance);
    let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
    let lo = (lo.min(-0.01) * 100.0).floor() / 100.0;
    let hi = ((hi.max(lo + 0.01) * 100.0).ceil() / 100.0).max(lo + 0.02);
    (lo, hi)
}

/// Every figure of the experiment as JSON: configuration, summaries, paired comparison, the
/// Fig. 5c histograms (5 mm bins) and each episode without its trajectories (`with_paths` adds
/// them).
pub fn experiment_json(e: &Experiment, with_paths: bool) -> serde_json::Value {
    let (lo, hi) = histogram_range(e);
    let bins = ((hi - lo) / 0.005).round().max(1.0) as usize;
    let episode = |r: &TurtlebotRun| {
        let mut v = serde_json::json!({
            "seed": r.seed,
            "reached": r.reached,
            "steps": r.steps,
            "time_s": r.time_s,
            "collisions": r.collisions,
            "contact_time_s": r.contact_time_s,
            "min_clearance": r.min_clearance,
            "min_clearance_per_disc": r.min_clearance_per_disc,
            "min_constraint_margin": r.min_constraint_margin,
            "final_error": r.final_error,
            "infeasible_steps": r.infeasible_steps,
            "solve_ms": r.solve_ms,
        });
        if with_paths {
            v["poses"] = serde_json::json!(r.poses);
            v["commands"] = serde_json::json!(r.commands);
        }
        v
    };
    let clear = |rs: &[TurtlebotRun]| rs.iter().map(|r| r.min_clearance).collect::<Vec<_>>();
    serde_json::json!({
        "experiment": "safe-turtlebot (Alcan and Kyrki (2022), §IV-C, Fig. 5)",
        "config": e.config,
        "seed": e.seed,
        "beta": e.beta,
        "runs": e.cddp.len(),
        "summary": { "cddp": e.cddp_summary, "safe_cddp": e.safe_summary },
        "paired": { "safe_wider": e.safe_wider, "runs": e.cddp.len() },
        "histogram": {
            "lo": lo, "hi": hi, "bin_width": (hi - lo) / bins as f64,
            "cddp": histogram(&clear(&e.cddp), lo, hi, bins),
            "safe_cddp": histogram(&clear(&e.safe), lo, hi, bins),
        },
        "episodes": {
            "cddp": e.cddp.iter().map(episode).collect::<Vec<_>>(),
            "safe_cddp": e.safe.iter().map(episode).collect::<Vec<_>>(),
        },
    })
}

/// Draws the Fig. 5-like figure of `e` to the PNG `path`, whole or not at all: (a) the driven
/// paths, (b) the histograms of the minimum clearance (see the private `figure` module's docs,
/// repeated in the README).
pub fn write_figure(path: &std::path::Path, e: &Experiment) -> Result<()> {
    figure::draw(path, e)
}

mod figure {
    //! The PNG: (a) top view with every driven path (red CDDP, blue Safe-CDDP), the discs (dark
    //! grey) and their inflated outlines (light grey), start (green) and goal (red); (b) the
    //! histograms of the minimum clearance (red CDDP above the axis, blue Safe-CDDP below it) in
    //! bins of 5 mm, a black line at zero clearance and each controller's mean as a vertical
    //! line. Both panels have axes with units, a legend and a title (`ddpkit-plot`).

    use std::path::Path;

    use ddpkit_plot::plotters::coord::Shift;
    use ddpkit_plot::plotters::prelude::*;
    use ddpkit_plot::{box_key, chart, cross_key, disc_key, legend, line_key, Axes, Failure};

    use super::{histogram, histogram_range, Experiment};
    use crate::error::{Error, Result};

    const RED: RGBColor = RGBColor(220, 50, 40);
    /// The world window of the top view (m).
    const X: std::ops::Range<f64> = -0.25..1.6;
    const Y: std::ops::Range<f64> = -0.45..1.15;
    const BLUE: RGBColor = RGBColor(30, 90, 220);

    pub(super) fn draw(path: &Path, e: &Experiment) -> Result<()> {
        // The top view at 340 px per metre with equal scales; the histograms beside it.
        let (w, h) = ddpkit_plot::equal_aspect_size(&X, &Y, 340.0);
        ddpkit_plot::write_png(path, (w + 760, h), |root| {
            let (left, right) = root.split_horizontally(w);
            top_view(&left, e)?;
            histograms(&right, e)
        })
        .map_err(|err| Error::write(path, err))
    }

    fn circle(c: [f64; 2], r: f64) -> Vec<(f64, f64)> {
        (0..=64)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 64.0;
                (c[0] + r * a.cos(), c[1] + r * a.sin())
            })
            .collect()
    }

    fn top_view<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, e: &Experiment) -> std::result::Result<(), Failure>
    where
        DB::ErrorType: 'static,
    {
        let axes = Axes::new(
            &format!("(a) driven paths, {} episodes each", e.cddp.len()),
            "x (m)",
            "y (m)",
            X,
            Y,
        );
        let mut c = chart(area, &axes)?;
        let disc = RGBColor(90, 90, 100).filled();
        c.draw_series(
            e.config
                .discs
                .iter()
                .map(|d| Polygon::new(circle(d.center, d.radius), disc)),
        )?
        .label("obstacles")
        .legend(box_key(disc));
        let inflated = RGBColor(160, 160, 170).stroke_width(1);
        c.draw_series(
            e.config
                .discs
                .iter()
                .map(|d| PathElement::new(circle(d.center, d.radius + e.config.inflation), inflated)),
        )?
        .label("inflated outline")
        .legend(line_key(inflated));
        let mut crossed = false;
        for (runs, color, name) in [(&e.cddp, RED, "CDDP"), (&e.safe, BLUE, "Safe-CDDP")] {
            let style = color.mix(0.35).stroke_width(1);
            c.draw_series(
                runs.iter()
                    .map(|r| PathElement::new(r.poses.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>(), style)),
            )?
            .label(name)
            .legend(line_key(color.stroke_width(2)));
            for r in runs.iter().filter(|r| r.collisions > 0) {
                // Where the closest approach happened: a cross on the pose nearest a disc.
                let d = |p: &[f64; 3]| {
                    e.config
                        .discs
                        .iter()
                        .map(|d| (p[0] - d.center[0]).hypot(p[1] - d.center[1]) - d.radius)
                        .fold(f64::INFINITY, f64::min)
                };
                if let Some(p) = r.poses.iter().min_by(|a, b| d(a).total_cmp(&d(b))) {
                    c.draw_series(std::iter::once(Cross::new((p[0], p[1]), 5, color.stroke_width(2))))?;
                    crossed = true;
                }
            }
        }
        if crossed {
            c.draw_series(std::iter::empty::<Cross<(f64, f64), i32>>())?
                .label("collision (closest pose)")
                .legend(cross_key(BLACK.stroke_width(2)));
        }
        let (s0, g) = (e.config.start, e.config.goal);
        let green = RGBColor(30, 170, 40).filled();
        c.draw_series(std::iter::once(Circle::new((s0[0], s0[1]), 6, green)))?
            .label("start")
            .legend(disc_key(green, 5));
        let red = RGBColor(220, 30, 30);
        c.draw_series(std::iter::once(Circle::new((g[0], g[1]), 6, red.filled())))?
            .label("goal")
            .legend(disc_key(red.filled(), 5));
        c.draw_series(std::iter::once(PathElement::new(
            circle([g[0], g[1]], e.config.goal_radius),
            red.stroke_width(1),
        )))?;
        legend(&mut c, SeriesLabelPosition::LowerRight)
    }

    fn histograms<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, e: &Experiment) -> std::result::Result<(), Failure>
    where
        DB::ErrorType: 'static,
    {
        let (lo, hi) = histogram_range(e);
        let bins = ((hi - lo) / 0.005).round().max(1.0) as usize;
        let clear = |rs: &[super::TurtlebotRun]| rs.iter().map(|r| r.min_clearance).collect::<Vec<_>>();
        let (hc, hs) = (
            histogram(&clear(&e.cddp), lo, hi, bins),
            histogram(&clear(&e.safe), lo, hi, bins),
        );
        let peak = hc.iter().chain(&hs).copied().max().unwrap_or(1).max(1) as f64 * 1.1;
        let axes = Axes::new(
            "(b) minimum clearance per episode (CDDP up, Safe-CDDP down)",
            "minimum clearance (m)",
            "episodes (CDDP > 0, Safe-CDDP < 0)",
            lo..hi,
            -peak..peak,
        );
        let mut c = chart(area, &axes)?;
        for (counts, color, up, name) in [(&hc, RED, true, "CDDP"), (&hs, BLUE, false, "Safe-CDDP")] {
            let style = color.mix(0.8).filled();
            c.draw_series(counts.iter().enumerate().filter(|(_, &n)| n > 0).map(|(i, &n)| {
                let (a, b) = (lo + i as f64 * 0.005, lo + (i + 1) as f64 * 0.005);
                let y = if up { n as f64 } else { -(n as f64) };
                Rectangle::new([(a + 0.0005, 0.0), (b - 0.0005, y)], style)
            }))?
            .label(format!("{name}, 5 mm bins"))
            .legend(box_key(style));
        }
        c.draw_series(std::iter::once(PathElement::new(
            vec![(lo, 0.0), (hi, 0.0)],
            BLACK.stroke_width(1),
        )))?;
        let zero = BLACK.stroke_width(2);
        c.draw_series(std::iter::once(PathElement::new(vec![(0.0, -peak), (0.0, peak)], zero)))?
            .label("zero clearance")
            .legend(line_key(zero));
        for (mean, color, sign, name) in [
            (e.cddp_summary.min_clearance.mean, RED, 1.0, "CDDP mean"),
            (e.safe_summary.min_clearance.mean, BLUE, -1.0, "Safe-CDDP mean"),
        ] {
            let style = color.stroke_width(2);
            c.draw_series(std::iter::once(PathElement::new(
                vec![(mean, 0.0), (mean, sign * peak)],
                style,
            )))?
            .label(name)
            .legend(line_key(style));
        }
        legend(&mut c, SeriesLabelPosition::UpperRight)
    }
}
