//! The experiment of Table I (Alcan and Kyrki (2022), §IV-A/B): three robots reach a goal among
//! obstacles under additive Gaussian process noise, driven by the shrinking-horizon MPC of
//! Algorithm 1 ([`crate::mpc::Mpc`], `n1 = 10` iterations per step, tightening every `n2 = 5`), 100
//! seeded episodes for each `beta` in {0.5, 0.9, 0.95, 0.99}. `beta = 0.5` is plain CDDP
//! (`phi^{-1}(0.5) = 0`, no margins). The binary `safe-cddp-table` runs it in parallel and writes
//! the table, a JSON file and the figure; this module holds the scenarios and the metrics so that
//! tests can run a few episodes.
//!
//! | robot | model | N | task |
//! |---|---|---|---|
//! | [`Robot::Point`] | 2-D double integrator (P3's, `dt = 0.05`) | 100 | (0, 0) to (3, 3) past P3's three discs |
//! | [`Robot::Car`] | kinematic car with speed state (P2's, `dt = 0.05`) | 120 | (0, 0) to (4, 0) at rest past two discs, one on each side |
//! | [`Robot::Quadrotor`] | 12-state quadrotor, iLQR form (`dt = 0.04`) | 50 | hover at (0, 0, 1) past a tall cylinder to hover above a short one |
//!
//! The paper does not give its scenarios' coordinates or noise; these are ours. The noise
//! (`sigma_w = s^2 diag(...)`, `s` in [`Robot::default_noise`]) was chosen so that plain CDDP
//! (`beta = 0.5`) collides in 30-70 % of the episodes, as in the paper.
//!
//! Metrics (the paper's): a *violated episode* has at least one step whose true state is inside
//! an obstacle (collisions are counted per step, against the exact obstacles); *average in
//! violated episodes* = collisions / violated episodes; *total average* = collisions / episodes.
//!
//! ```
//! use safe_cddp::table::{run_episode, Method, Robot};
//! let sc = safe_cddp::table::point_robot(Robot::Point.default_noise())?;
//! let e = run_episode(&sc, Method::SafeCddp { beta: 0.99 }, 7)?;
//! assert!(e.steps > 0);
//! # Ok::<(), ddp_core::Error>(())
//! ```

use ddp_core::dims::Const;
use ddp_core::dims::{U12, U4};
use std::sync::Arc;

use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
use ddp_core::models::{Car, DoubleIntegrator2D, Quadrotor};
use ddp_core::{ControlBounds, Dynamics, Error, Matrix, Problem, Result, Vector};
use serde::{Deserialize, Serialize};

use crate::constraints::{Circle, Cylinder};
use crate::mpc::{Mpc, MpcSettings};
use crate::tightening::lqr_gain;
use crate::{Constraint, Gains, Settings, Tightening};

/// The `beta` values of Table I (0.5 is plain CDDP).
pub const BETAS: [f64; 4] = [0.5, 0.9, 0.95, 0.99];

/// The robots of Table I.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Robot {
    /// 2-D point robot (double integrator), N = 100.
    Point,
    /// Car-like robot (kinematic car with a speed state), N = 120.
    Car,
    /// 12-state quadrotor among vertical cylinders, N = 50.
    Quadrotor,
}

impl Robot {
    /// All three, in the paper's order.
    pub const ALL: [Robot; 3] = [Robot::Point, Robot::Car, Robot::Quadrotor];

    /// Lower-case name (`"point"`, `"car"`, `"quadrotor"`).
    pub fn name(&self) -> &'static str {
        match self {
            Robot::Point => "point",
            Robot::Car => "car",
            Robot::Quadrotor => "quadrotor",
        }
    }

    /// The paper's row title.
    pub fn title(&self) -> &'static str {
        match self {
            Robot::Point => "2D Point Robot",
            Robot::Car => "Car-like Robot",
            Robot::Quadrotor => "3D Quadrotor Robot",
        }
    }

    /// The noise scale `s` (standard deviation per step of the position noise, m) calibrated so
    /// that plain CDDP collides in 30-70 % of the episodes.
    pub fn default_noise(&self) -> f64 {
        match self {
            Robot::Point => 3e-3,
            Robot::Car => 4e-3,
            Robot::Quadrotor => 4e-3,
        }
    }

    /// The paper's Table I figures for this robot: (violated episodes, average in violated
    /// episodes, total average) for beta = 0.5, 0.9, 0.95, 0.99.
    pub fn paper(&self) -> [(usize, f64, f64); 4] {
        match self {
            Robot::Point => [(64, 1.98, 1.27), (14, 1.43, 0.20), (8, 1.38, 0.11), (0, 0.0, 0.0)],
            Robot::Car => [(38, 1.63, 0.62), (2, 1.0, 0.02), (0, 0.0, 0.0), (0, 0.0, 0.0)],
            Robot::Quadrotor => [(66, 5.7, 3.76), (34, 4.26, 1.45), (27, 5.19, 1.4), (15, 4.07, 0.61)],
        }
    }
}

/// An obstacle as drawn and as tested for collisions (exactly, not the smoothed row).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Obstacle {
    /// Centre `(x, y)`.
    pub center: [f64; 2],
    /// Radius.
    pub radius: f64,
    /// Height of a cylinder's top (infinite for a disc in the plane).
    pub height: f64,
}

impl Obstacle {
    /// Whether the position `(x, y, z)` is inside.
    pub fn contains(&self, p: [f64; 3]) -> bool {
        (p[0] - self.center[0]).hypot(p[1] - self.center[1]) < self.radius && p[2] < self.height
    }
}

/// One task of Table I.
pub struct Scenario<const NX: usize, const NU: usize> {
    /// Which robot.
    pub robot: Robot,
    /// The deterministic problem (initial state, dynamics, cost, control box, horizon).
    pub problem: Problem<Const<NX>, Const<NU>>,
    /// The obstacles as constraint rows.
    pub constraints: Vec<Arc<dyn Constraint<Const<NX>, Const<NU>>>>,
    /// The obstacles for collision counting and figures.
    pub obstacles: Vec<Obstacle>,
    /// Process noise `Sigma_w` (also what the tightening assumes).
    pub sigma_w: Matrix<NX, NX>,
    /// Solver settings.
    pub settings: Settings,
    /// MPC settings (`n1`, goal region).
    pub mpc: MpcSettings<Const<NX>>,
    /// `n2`: tightening period.
    pub update_every: usize,
    /// The fixed gain of the cautious-MPC baseline: LQR of the dynamics linearised at the goal.
    pub fixed_gain: Matrix<NU, NX>,
    /// State indices of the position (`z` is `None` for planar robots).
    pub position: (usize, usize, Option<usize>),
}

impl<const NX: usize, const NU: usize> std::fmt::Debug for Scenario<NX, NU> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scenario")
            .field("robot", &self.robot)
            .field("horizon", &self.problem.horizon())
            .field("obstacles", &self.obstacles)
            .finish()
    }
}

impl<const NX: usize, const NU: usize> Scenario<NX, NU> {
    /// The position `(x, y, z)` of a state (`z = 0` for planar robots).
    pub fn position_of(&self, x: &Vector<NX>) -> [f64; 3] {
        let (i, j, k) = self.position;
        [x[i], x[j], k.map_or(0.0, |k| x[k])]
    }
}

fn solver_settings() -> Settings {
    Settings {
        max_iterations: 400,
        ..Settings::default()
    }
}

fn mpc_settings<const NX: usize>(goal: Vector<NX>, goal_indices: Vec<usize>, radius: f64) -> MpcSettings<Const<NX>> {
    MpcSettings {
        iterations: 10,
        initial_iterations: 300,
        goal,
        goal_indices,
        goal_radius: radius,
        position_indices: [0, 1],
    }
}

fn lqr_at<const NX: usize, const NU: usize>(
    dynamics: &dyn Dynamics<Const<NX>, Const<NU>>,
    x: &Vector<NX>,
    u: &Vector<NU>,
    q: &[f64; NX],
    r: &[f64; NU],
) -> Result<Matrix<NU, NX>> {
    let (mut a, mut b) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
    dynamics.jacobians(x, u, &mut a, &mut b);
    let q = Matrix::<NX, NX>::from_diagonal(&Vector::<NX>::from_column_slice(q));
    let r = Matrix::<NU, NU>::from_diagonal(&Vector::<NU>::from_column_slice(r));
    // 400 Riccati steps: the stationary gain where it exists (point, quadrotor); for the car at
    // rest, which no linear gain stabilises, a long finite-horizon gain.
    lqr_gain(&a, &b, &q, &r, 400, 1e-10)
}

/// Constraint rows and their obstacles.
type Rows<const NX: usize, const NU: usize> = (Vec<Arc<dyn Constraint<Const<NX>, Const<NU>>>>, Vec<Obstacle>);

fn circles<const NX: usize, const NU: usize>(discs: &[[f64; 3]]) -> Result<Rows<NX, NU>> {
    let mut rows: Vec<Arc<dyn Constraint<Const<NX>, Const<NU>>>> = Vec::new();
    let mut obstacles = Vec::new();
    for d in discs {
        rows.push(Arc::new(Circle::<Const<NX>>::squared([d[0], d[1]], d[2], [0, 1])?));
        obstacles.push(Obstacle {
            center: [d[0], d[1]],
            radius: d[2],
            height: f64::INFINITY,
        });
    }
    Ok((rows, obstacles))
}

/// The point robot: P3 of `bench/problems.md` (double integrator, `dt = 0.05`, N = 100, box 0.8,
/// goal (3, 3) at rest, three discs) with noise `sigma_w = s^2 diag(1, 1, 4, 4)` (m, m/s).
pub fn point_robot(noise: f64) -> Result<Scenario<4, 2>> {
    let dt = 0.05;
    let goal = Vector::<4>::new(3.0, 3.0, 0.0, 0.0);
    let (qf, r) = ([100.0, 100.0, 10.0, 10.0], [0.1, 0.1]);
    let model = Arc::new(DoubleIntegrator2D::new(dt)?);
    let problem = Problem::new(
        Vector::zeros(),
        model.clone(),
        Arc::new(QuadraticCost::diagonal(
            &[0.0; 4],
            &r,
            Vector::zeros(),
            Vector::zeros(),
        )?),
        Arc::new(QuadraticTerminal::diagonal(&qf, goal)?),
        100,
    )?
    .with_control_bounds(ControlBounds::new(Vector::repeat(-0.8), Vector::repeat(0.8))?)?;
    let (constraints, obstacles) = circles([[1.0, 1.1, 0.4], [2.0, 1.9, 0.4], [2.6, 2.9, 0.25]].as_slice())?;
    let s2 = noise * noise;
    Ok(Scenario {
        robot: Robot::Point,
        fixed_gain: lqr_at(model.as_ref(), &goal, &Vector::zeros(), &qf, &r)?,
        problem,
        constraints,
        obstacles,
        sigma_w: Matrix::from_diagonal(&Vector::<4>::new(s2, s2, 4.0 * s2, 4.0 * s2)),
        settings: solver_settings(),
        mpc: mpc_settings(goal, vec![0, 1], 0.1),
        update_every: 5,
        position: (0, 1, None),
    })
}

/// The car: P2's model, cost, box and horizon (kinematic car, `dt = 0.05`, N = 120,
/// `|w| <= 0.4`, `|a| <= 0.5`, goal (4, 0) at rest) past two discs of radius 0.3 at (1.3, 0.28)
/// and (2.7, -0.28), which the straight line grazes (P2's three discs make the car hug them for
/// many steps, so plain CDDP collides in nearly every episode), with noise
/// `sigma_w = s^2 diag(1, 1, 4, 4)` (m, m, rad, m/s).
pub fn car(noise: f64) -> Result<Scenario<4, 2>> {
    let dt = 0.05;
    let goal = Vector::<4>::new(4.0, 0.0, 0.0, 0.0);
    let (qf, r) = ([100.0, 100.0, 10.0, 10.0], [0.1, 0.1]);
    let model = Arc::new(Car::new(dt)?);
    let problem = Problem::new(
        Vector::zeros(),
        model.clone(),
        Arc::new(QuadraticCost::diagonal(
            &[0.0; 4],
            &r,
            Vector::zeros(),
            Vector::zeros(),
        )?),
        Arc::new(QuadraticTerminal::diagonal(&qf, goal)?),
        120,
    )?
    .with_control_bounds(ControlBounds::new(
        Vector::<2>::new(-0.4, -0.5),
        Vector::<2>::new(0.4, 0.5),
    )?)?;
    let (constraints, obstacles) = circles([[1.3, 0.28, 0.3], [2.7, -0.28, 0.3]].as_slice())?;
    let s2 = noise * noise;
    Ok(Scenario {
        robot: Robot::Car,
        fixed_gain: lqr_at(model.as_ref(), &goal, &Vector::zeros(), &qf, &r)?,
        problem,
        constraints,
        obstacles,
        sigma_w: Matrix::from_diagonal(&Vector::<4>::new(s2, s2, 4.0 * s2, 4.0 * s2)),
        settings: solver_settings(),
        mpc: mpc_settings(goal, vec![0, 1], 0.1),
        update_every: 5,
        position: (0, 1, None),
    })
}

/// The quadrotor (12 states, thrust and three torques, `dt = 0.04`, N = 50, iLQR form as in the
/// paper): from hover at (0, 0, 1) past a tall cylinder (r = 0.25 at (1, 0.05), 3 m high) to
/// hover at (2, 0, 1.45), 7 cm above a short one (r = 0.3 at (2, 0), 1.38 m high). Noise
/// `sigma_w = s^2 diag(1 (position), 1 (angles), 4 (velocity), 4 (rates))`.
pub fn quadrotor(noise: f64) -> Result<Scenario<12, 4>> {
    let model = Quadrotor::new(0.04)?;
    let hover = model.hover_control();
    let mut x0 = Vector::<12>::zeros();
    x0[2] = 1.0;
    let mut goal = Vector::<12>::zeros();
    goal[0] = 2.0;
    goal[2] = 1.45;
    let qf = [100.0, 100.0, 100.0, 10.0, 10.0, 10.0, 10.0, 10.0, 10.0, 1.0, 1.0, 1.0];
    let r = [0.1, 1.0, 1.0, 1.0];
    let model = Arc::new(model);
    let problem = Problem::new(
        x0,
        model.clone(),
        Arc::new(QuadraticCost::diagonal(&[0.0; 12], &r, Vector::zeros(), hover)?),
        Arc::new(QuadraticTerminal::diagonal(&qf, goal)?),
        50,
    )?
    .with_control_bounds(ControlBounds::new(
        Vector::<4>::new(0.0, -0.05, -0.05, -0.02),
        Vector::<4>::new(2.0 * hover[0], 0.05, 0.05, 0.02),
    )?)?;
    let cylinders = [[1.0, 0.05, 0.25, 3.0], [2.0, 0.0, 0.3, 1.38]];
    let mut constraints: Vec<Arc<dyn Constraint<U12, U4>>> = Vec::new();
    let mut obstacles = Vec::new();
    for c in cylinders {
        constraints.push(Arc::new(Cylinder::<ddp_core::dims::Const<12>>::new(
            [c[0], c[1]],
            c[2],
            c[3],
            0.02,
            [0, 1, 2],
        )?));
        obstacles.push(Obstacle {
            center: [c[0], c[1]],
            radius: c[2],
            height: c[3],
        });
    }
    let s2 = noise * noise;
    let mut diag = Vector::<12>::zeros();
    for i in 0..12 {
        diag[i] = if i < 6 { s2 } else { 4.0 * s2 };
    }
    Ok(Scenario {
        robot: Robot::Quadrotor,
        fixed_gain: lqr_at(model.as_ref(), &goal, &hover, &qf, &r)?,
        problem,
        constraints,
        obstacles,
        sigma_w: Matrix::from_diagonal(&diag),
        settings: solver_settings(),
        mpc: mpc_settings(goal, vec![0, 1, 2], 0.08),
        update_every: 5,
        position: (0, 1, Some(2)),
    })
}

/// How an episode handles the chance constraints.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Method {
    /// Plain CDDP: no tightening (`beta = 0.5`).
    Cddp,
    /// Safe-CDDP: closed-loop covariance with the backward pass's gains ([`Gains::ClosedLoop`]).
    SafeCddp {
        /// Satisfaction probability.
        beta: f64,
    },
    /// Cautious-MPC baseline: covariance with the fixed LQR gain at the goal.
    FixedGains {
        /// Satisfaction probability.
        beta: f64,
    },
    /// Open-loop covariance (`K = 0`).
    OpenLoop {
        /// Satisfaction probability.
        beta: f64,
    },
}

impl Method {
    /// Plain CDDP for `beta = 0.5`, Safe-CDDP otherwise.
    pub fn for_beta(beta: f64) -> Self {
        if beta == 0.5 {
            Method::Cddp
        } else {
            Method::SafeCddp { beta }
        }
    }

    fn tightening<const NX: usize, const NU: usize>(
        &self,
        sc: &Scenario<NX, NU>,
    ) -> Result<Option<Tightening<Const<NX>, Const<NU>>>> {
        let (beta, gains) = match *self {
            Method::Cddp => return Ok(None),
            Method::SafeCddp { beta } => (beta, Gains::ClosedLoop),
            Method::FixedGains { beta } => (beta, Gains::Fixed(sc.fixed_gain)),
            Method::OpenLoop { beta } => (beta, Gains::OpenLoop),
        };
        Ok(Some(
            Tightening::new(beta, sc.sigma_w)?
                .with_gains(gains)?
                .with_update_every(sc.update_every)?,
        ))
    }
}

/// The MPC of `method` on `scenario` (allocates the solver).
pub fn mpc<const NX: usize, const NU: usize>(
    sc: &Scenario<NX, NU>,
    method: Method,
) -> Result<Mpc<Const<NX>, Const<NU>>> {
    Mpc::new(
        &sc.problem,
        sc.constraints.clone(),
        vec![],
        sc.settings,
        method.tightening(sc)?,
        sc.sigma_w,
        sc.mpc.clone(),
    )
}

/// The noise seed of episode `episode` of `robot` under base seed `seed`: the same for every
/// method, so the methods meet the same noise (common random numbers).
pub fn episode_seed(seed: u64, robot: Robot, episode: usize) -> u64 {
    // SplitMix64 of the combined inputs.
    let robot_id = Robot::ALL.iter().position(|r| *r == robot).unwrap_or(0) as u64;
    let mut z = seed
        .wrapping_add(0x9E37_79B9_7F4A_7C15u64.wrapping_mul(1 + robot_id))
        .wrapping_add((episode as u64).wrapping_mul(0xD1B5_4A32_D192_ED03));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// What Table I (and Fig. 4) keep of an episode (a sweep's task result, so it round-trips
/// through JSON).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct EpisodeOutcome {
    /// The goal region was reached.
    pub success: bool,
    /// MPC steps applied.
    pub steps: usize,
    /// Steps whose true position was inside an obstacle.
    pub collisions: usize,
    /// Steps at which the solver reported an infeasible QP or trajectory.
    pub infeasible_steps: usize,
    /// True positions `(x, y, z)` of the episode, `x_0 .. x_steps`.
    pub path: Vec<[f64; 3]>,
    /// First plan: position standard deviation `sqrt(Sigma_xx + Sigma_yy (+ Sigma_zz))` along
    /// the horizon (eq. 19; zero without tightening).
    pub sigma_position: Vec<f64>,
    /// First plan: `|K_t|_F` of the gains the covariance was propagated with.
    pub gain_norms: Vec<f64>,
}

/// Runs one episode of `method` on `scenario` with the noise of `seed` (allocates an MPC).
pub fn run_episode<const NX: usize, const NU: usize>(
    sc: &Scenario<NX, NU>,
    method: Method,
    seed: u64,
) -> Result<EpisodeOutcome> {
    let mut m = mpc(sc, method)?;
    run_episode_with(sc, &mut m, seed)
}

/// Runs one episode on an MPC made by [`mpc`] (reusing its workspace).
pub fn run_episode_with<const NX: usize, const NU: usize>(
    sc: &Scenario<NX, NU>,
    m: &mut Mpc<Const<NX>, Const<NU>>,
    seed: u64,
) -> Result<EpisodeOutcome> {
    let e = m.run_episode(seed)?;
    let path: Vec<[f64; 3]> = e.xs.iter().map(|x| sc.position_of(x)).collect();
    let collisions = path
        .iter()
        .skip(1)
        .filter(|p| sc.obstacles.iter().any(|o| o.contains(**p)))
        .count();
    let (i, j, k) = sc.position;
    let sigma_position = e
        .initial_covariances
        .iter()
        .map(|s| (s[(i, i)] + s[(j, j)] + k.map_or(0.0, |k| s[(k, k)])).max(0.0).sqrt())
        .collect();
    if e.xs.iter().any(|x| x.iter().any(|v| !v.is_finite())) {
        return Err(Error::invalid("episode", "the simulated state became non-finite"));
    }
    Ok(EpisodeOutcome {
        success: e.success,
        steps: e.steps,
        collisions,
        infeasible_steps: e.infeasible_steps,
        path,
        sigma_position,
        gain_norms: e.initial_gain_norms,
    })
}

/// The paper's three metrics (and a few more) over a set of episodes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Metrics {
    /// Episodes.
    pub episodes: usize,
    /// Episodes with at least one collision.
    pub violated_episodes: usize,
    /// Collisions / violated episodes (0 when none).
    pub avg_in_violated: f64,
    /// Collisions / episodes.
    pub total_avg: f64,
    /// All collisions (steps inside an obstacle).
    pub collisions: usize,
    /// Episodes that reached the goal region.
    pub successes: usize,
    /// Mean MPC steps per episode.
    pub mean_steps: f64,
    /// Steps with an infeasible solver report, summed.
    pub infeasible_steps: usize,
}

impl Metrics {
    /// The metrics of `episodes`.
    pub fn of(episodes: &[EpisodeOutcome]) -> Self {
        let n = episodes.len();
        let collisions: usize = episodes.iter().map(|e| e.collisions).sum();
        let violated = episodes.iter().filter(|e| e.collisions > 0).count();
        Self {
            episodes: n,
            violated_episodes: violated,
            avg_in_violated: if violated > 0 {
                collisions as f64 / violated as f64
            } else {
                0.0
            },
            total_avg: if n > 0 { collisions as f64 / n as f64 } else { 0.0 },
            collisions,
            successes: episodes.iter().filter(|e| e.success).count(),
            mean_steps: if n > 0 {
                episodes.iter().map(|e| e.steps as f64).sum::<f64>() / n as f64
            } else {
                0.0
            },
            infeasible_steps: episodes.iter().map(|e| e.infeasible_steps).sum(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_follow_the_papers_definitions() {
        let e = |c: usize| EpisodeOutcome {
            success: true,
            steps: 10,
            collisions: c,
            infeasible_steps: 0,
            path: vec![],
            sigma_position: vec![],
            gain_norms: vec![],
        };
        let m = Metrics::of(&[e(0), e(3), e(1), e(0)]);
        assert_eq!(m.violated_episodes, 2);
        assert_eq!(m.avg_in_violated, 2.0);
        assert_eq!(m.total_avg, 1.0);
        assert_eq!(Metrics::of(&[e(0)]).avg_in_violated, 0.0);
    }

    #[test]
    fn seeds_differ_by_robot_and_episode() {
        let a = episode_seed(1, Robot::Car, 0);
        assert_ne!(a, episode_seed(1, Robot::Car, 1));
        assert_ne!(a, episode_seed(1, Robot::Point, 0));
        assert_ne!(a, episode_seed(2, Robot::Car, 0));
        assert_eq!(a, episode_seed(1, Robot::Car, 0));
    }
}
