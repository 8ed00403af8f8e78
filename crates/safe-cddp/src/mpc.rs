//! Shrinking-horizon MPC with Safe-CDDP (Algorithm 1), seeded additive Gaussian noise, and
//! tracked moving obstacles.
//!
//! Per step: `n1` iterations of backward/forward passes, tightening every `n2`
//! ([`Tightening::update_every`]); apply `u_0`; the true state becomes
//! `x+ = f(x, u_0) + w`, `w ~ N(0, Sigma_w)` (seeded ChaCha8); shift the trajectory and shorten the
//! horizon by one. Moving obstacles move at constant velocity; each is measured with noise, tracked
//! by an [`ObstacleTracker`], and re-imposed every step as a [`crate::constraints::MovingCircle`]
//! predicted over the remaining horizon. An episode ends when the position is within
//! `goal_radius` of the goal (success) or the horizon runs out. Collisions are counted per step
//! against the **original** (untightened) constraints and the true obstacle positions.
//!
//! ```
//! use std::sync::Arc;
//! use ddp_core::{reference, Matrix, Vector};
//! use ddp_core::dims::{U2, U4};
//! use safe_cddp::constraints::Circle;
//! use safe_cddp::mpc::{Mpc, MpcSettings};
//! use safe_cddp::{Constraint, Settings, Tightening};
//!
//! let problem = reference::point_reach();
//! let obstacle: Arc<dyn Constraint<U4, U2>> = Arc::new(Circle::squared([1.5, 1.4], 0.4, [0, 1])?);
//! let sigma_w = Matrix::<4, 4>::from_diagonal(&Vector::<4>::new(1e-5, 1e-5, 1e-6, 1e-6));
//! let tightening = Tightening::new(0.95, sigma_w)?;
//! let mpc_settings = MpcSettings { goal: Vector::<4>::new(3.0, 3.0, 0.0, 0.0), goal_radius: 0.1, ..MpcSettings::default() };
//! let mut mpc = Mpc::new(&problem, vec![obstacle], vec![], Settings::default(), Some(tightening), sigma_w, mpc_settings)?;
//! let episode = mpc.run_episode(7)?;
//! assert_eq!(episode.collisions, 0);
//! # Ok::<(), ddp_core::Error>(())
//! ```

use std::sync::Arc;

use ddp_core::costs::check_psd;
use ddp_core::dims::{Alloc, Const, DefaultAllocator, Dim, MatrixN, VectorN, U1};
use ddp_core::{Error, Problem, Result};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::constraints::CircleForm;
use crate::kalman::ObstacleTracker;
use crate::{Constraint, IterationOutcome, SafeCddpSolver, Settings, Tightening};

/// Settings of the MPC loop.
#[derive(Debug, Clone, PartialEq)]
pub struct MpcSettings<NX: Dim>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// `n1`: iterations per MPC step (the paper uses 10).
    pub iterations: usize,
    /// Iterations of the initial solve before the first step (the paper's initialisation).
    pub initial_iterations: usize,
    /// The goal state; only `goal_indices` are compared.
    pub goal: VectorN<NX>,
    /// The state indices of the goal test (the position).
    pub goal_indices: Vec<usize>,
    /// Success radius around the goal.
    pub goal_radius: f64,
    /// The state indices of the planar position (moving obstacles and collisions with them).
    pub position_indices: [usize; 2],
}

impl<NX: Dim> MpcSettings<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// The defaults with this goal (the goal's length fixes a run-time state size).
    pub fn with_goal(goal: VectorN<NX>) -> Self {
        Self {
            iterations: 10,
            initial_iterations: 50,
            goal,
            goal_indices: vec![0, 1],
            goal_radius: 0.1,
            position_indices: [0, 1],
        }
    }
}

impl<const NX: usize> Default for MpcSettings<Const<NX>> {
    fn default() -> Self {
        Self::with_goal(ddp_core::Vector::<NX>::zeros())
    }
}

/// A circular obstacle moving at constant velocity, tracked by a Kalman filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MovingObstacle {
    /// True initial centre.
    pub position: [f64; 2],
    /// True velocity (per second).
    pub velocity: [f64; 2],
    /// Radius.
    pub radius: f64,
    /// Standard deviation of the position measurements.
    pub measurement_std: f64,
    /// Acceleration noise the filter assumes (std).
    pub filter_accel_std: f64,
    /// Initial velocity uncertainty of the filter (std); the initial position uncertainty is the
    /// measurement noise.
    pub initial_velocity_std: f64,
}

/// One MPC episode.
#[derive(Debug, Clone, PartialEq)]
pub struct Episode<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// The goal region was reached.
    pub success: bool,
    /// MPC steps applied.
    pub steps: usize,
    /// Steps whose true state violated an original constraint (collisions, counted per step).
    pub collisions: usize,
    /// Steps at which the solver reported an infeasible QP or trajectory.
    pub infeasible_steps: usize,
    /// The true states `x_0 .. x_steps`.
    pub xs: Vec<VectorN<NX>>,
    /// The applied controls.
    pub us: Vec<VectorN<NU>>,
    /// Predicted position covariance of the first plan (`Sigma_t` at the initial solve).
    pub initial_covariances: Vec<MatrixN<NX, NX>>,
    /// Norm of the gains `|K_t|_F` of the first plan.
    pub initial_gain_norms: Vec<f64>,
    /// The first plan's states.
    pub initial_plan: Vec<VectorN<NX>>,
}

/// Shrinking-horizon Safe-CDDP MPC (Algorithm 1). Owns a problem copy, the solver and the
/// obstacle trackers; [`Mpc::run_episode`] is deterministic for a seed.
pub struct Mpc<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    problem: Problem<NX, NU>,
    solver: SafeCddpSolver<NX, NU>,
    n_static: usize,
    moving: Vec<MovingObstacle>,
    noise_chol: MatrixN<NX, NX>,
    settings: MpcSettings<NX>,
    horizon: usize,
    dt_obstacles: f64,
}

impl<NX: Dim, NU: Dim> Mpc<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// `constraints`: static constraints (collisions are counted on them); `moving`: moving
    /// obstacles (circles on `position_indices`, distance form, tracked with the sampling period
    /// `dt` of [`Mpc::with_obstacle_dt`], default 0.05 s); `tightening`: `None` for plain CDDP;
    /// `sigma_w`: the true process noise of the simulation (symmetric PSD).
    pub fn new(
        problem: &Problem<NX, NU>,
        constraints: Vec<Arc<dyn Constraint<NX, NU>>>,
        moving: Vec<MovingObstacle>,
        settings: Settings,
        tightening: Option<Tightening<NX, NU>>,
        sigma_w: MatrixN<NX, NX>,
        mpc: MpcSettings<NX>,
    ) -> Result<Self> {
        let nx = problem.dims().nx();
        if sigma_w.shape() != (nx, nx) {
            return Err(Error::Shape {
                field: "sigma_w".into(),
                got: format!("{:?}", sigma_w.shape()),
                expected: format!("({nx}, {nx})"),
            });
        }
        if mpc.goal.len() != nx {
            return Err(Error::Shape {
                field: "mpc.goal".into(),
                got: format!("({},)", mpc.goal.len()),
                expected: format!("({nx},)"),
            });
        }
        check_psd("sigma_w", &sigma_w)?;
        if mpc.iterations == 0 {
            return Err(Error::invalid("mpc.iterations", "must be at least 1"));
        }
        if !(mpc.goal_radius.is_finite() && mpc.goal_radius > 0.0) {
            return Err(Error::invalid("mpc.goal_radius", "must be finite and > 0"));
        }
        for (i, &j) in mpc.goal_indices.iter().chain(mpc.position_indices.iter()).enumerate() {
            if j >= nx {
                return Err(Error::invalid(
                    format!("mpc indices[{i}]"),
                    format!("state index {j} out of range for {nx} states"),
                ));
            }
        }
        let n_static = constraints.len();
        let horizon = problem.horizon();
        let mut all = constraints;
        for o in &moving {
            let kf = ObstacleTracker::new(
                0.05,
                o.filter_accel_std,
                o.measurement_std,
                o.position,
                o.velocity,
                o.measurement_std,
                o.initial_velocity_std,
            )?;
            all.push(Arc::new(kf.moving_circle::<NX>(
                horizon,
                o.radius,
                mpc.position_indices,
                CircleForm::Distance,
            )?));
        }
        let mut solver = SafeCddpSolver::new(problem, all, settings)?;
        solver.set_tightening(tightening)?;
        // Cholesky of Sigma_w (a PSD matrix may be singular: factor Sigma_w + tiny I then).
        let (r, c) = sigma_w.shape_generic();
        let noise_chol = match sigma_w.clone().cholesky() {
            Some(c) => c.l(),
            None => (&sigma_w + MatrixN::<NX, NX>::identity_generic(r, c) * 1e-300)
                .cholesky()
                .map(|c| c.l())
                .unwrap_or_else(|| {
                    // Diagonal fallback for a singular covariance.
                    MatrixN::from_diagonal(&sigma_w.diagonal().map(|v| v.max(0.0).sqrt()))
                }),
        };
        Ok(Self {
            problem: problem.clone(),
            solver,
            n_static,
            moving,
            noise_chol,
            settings: mpc,
            horizon,
            dt_obstacles: 0.05,
        })
    }

    /// Sets the sampling period of the obstacle trackers (the robot's `dt`).
    pub fn with_obstacle_dt(mut self, dt: f64) -> Result<Self> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::invalid("dt", format!("must be finite and > 0, got {dt}")));
        }
        self.dt_obstacles = dt;
        Ok(self)
    }

    /// The solver (for its report, covariances, gains).
    pub fn solver(&self) -> &SafeCddpSolver<NX, NU> {
        &self.solver
    }

    fn trackers(&self) -> Result<Vec<ObstacleTracker>> {
        self.moving
            .iter()
            .map(|o| {
                ObstacleTracker::new(
                    self.dt_obstacles,
                    o.filter_accel_std,
                    o.measurement_std,
                    o.position,
                    o.velocity,
                    o.measurement_std,
                    o.initial_velocity_std,
                )
            })
            .collect()
    }

    fn impose_moving(&mut self, trackers: &[ObstacleTracker], steps: usize) -> Result<()> {
        for (i, (kf, o)) in trackers.iter().zip(&self.moving).enumerate() {
            let c = kf.moving_circle::<NX>(steps, o.radius, self.settings.position_indices, CircleForm::Distance)?;
            self.solver.set_constraint(self.n_static + i, Arc::new(c))?;
        }
        Ok(())
    }

    fn run_iterations(&mut self, iterations: usize) -> Result<bool> {
        let tightening = self.solver.tightening().cloned();
        let mut infeasible = false;
        // The first KKT/QP iteration of a step tightens (Algorithm 1: iter % n2 == 0), then every n2.
        let mut since = usize::MAX / 2;
        for _ in 0..iterations {
            let outcome = self.solver.iterate(&self.problem)?;
            if let IterationOutcome::Failed(crate::Status::Infeasible { .. }) = outcome {
                infeasible = true;
            }
            if let Some(t) = &tightening {
                since += 1;
                if self.solver.tightening_due(since, t) {
                    self.solver.tighten(&self.problem)?;
                    since = 0;
                }
            }
            if matches!(outcome, IterationOutcome::Converged | IterationOutcome::Failed(_)) {
                break;
            }
        }
        Ok(infeasible)
    }

    /// Runs one episode from the problem's `x0` with noise seeded by `seed`.
    pub fn run_episode(&mut self, seed: u64) -> Result<Episode<NX, NU>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x_init = self.problem.x0().clone();
        let mut x = x_init.clone();
        let nx = self.problem.dims().nx;
        let n_total = self.horizon;
        self.solver.set_horizon(n_total)?;
        self.solver.reset();
        let mut trackers = self.trackers()?;
        let mut true_obstacles: Vec<[f64; 2]> = self.moving.iter().map(|o| o.position).collect();
        self.impose_moving(&trackers, n_total)?;
        // Initialisation: the deterministic problem, then tightened margins (Algorithm 1, line 1).
        self.solver.start(&self.problem)?;
        let initial = self.settings.initial_iterations;
        self.run_iterations(initial)?;
        let mut episode = Episode {
            success: false,
            steps: 0,
            collisions: 0,
            infeasible_steps: 0,
            xs: vec![x.clone()],
            us: Vec::new(),
            initial_covariances: self.solver.covariances().to_vec(),
            initial_gain_norms: self.solver.propagation_gains().iter().map(|k| k.norm()).collect(),
            initial_plan: self.solver.xs().to_vec(),
        };
        let dynamics = self.problem.knots()[0].dynamics.clone();
        let mut g = vec![0.0; self.solver.constraints().iter().map(|c| c.dim()).max().unwrap_or(1)];
        for step in 0..n_total {
            let n = n_total - step;
            if step > 0 {
                self.solver.start(&self.problem)?;
                if self.run_iterations(self.settings.iterations)? {
                    episode.infeasible_steps += 1;
                }
            }
            let u0 = self.solver.us()[0].clone();
            let w = VectorN::<NX>::from_fn_generic(nx, U1, |_, _| StandardNormal.sample(&mut rng));
            x = dynamics.step(&x, &u0) + &self.noise_chol * w;
            // The obstacles move, are measured and tracked.
            for (i, o) in self.moving.iter().enumerate() {
                true_obstacles[i][0] += self.dt_obstacles * o.velocity[0];
                true_obstacles[i][1] += self.dt_obstacles * o.velocity[1];
                let zx: f64 = StandardNormal.sample(&mut rng);
                let zy: f64 = StandardNormal.sample(&mut rng);
                trackers[i].predict();
                trackers[i].update([
                    true_obstacles[i][0] + o.measurement_std * zx,
                    true_obstacles[i][1] + o.measurement_std * zy,
                ])?;
            }
            episode.steps += 1;
            episode.us.push(u0);
            episode.xs.push(x.clone());
            if self.collides(&x, &true_obstacles, &mut g) {
                episode.collisions += 1;
            }
            let dist2: f64 = self
                .settings
                .goal_indices
                .iter()
                .map(|&i| (x[i] - self.settings.goal[i]).powi(2))
                .sum();
            if dist2 <= self.settings.goal_radius.powi(2) {
                episode.success = true;
                break;
            }
            if n == 1 {
                break;
            }
            self.problem.set_x0(x.clone())?;
            self.solver.shift();
            self.solver.set_horizon(n - 1)?;
            self.impose_moving(&trackers, n - 1)?;
        }
        self.problem.set_x0(x_init)?;
        Ok(episode)
    }

    /// Whether `x` violates an original static constraint or is inside a moving obstacle.
    fn collides(&self, x: &VectorN<NX>, obstacles: &[[f64; 2]], g: &mut [f64]) -> bool {
        let zero_u = self.problem.dims().u_zeros();
        for c in &self.solver.constraints()[..self.n_static] {
            if c.depends_on_control() {
                continue;
            }
            let g = &mut g[..c.dim()];
            c.evaluate(0, x, &zero_u, g);
            if g.iter().any(|&v| v > 0.0) {
                return true;
            }
        }
        let [i, j] = self.settings.position_indices;
        obstacles
            .iter()
            .zip(&self.moving)
            .any(|(p, o)| (x[i] - p[0]).hypot(x[j] - p[1]) < o.radius)
    }
}
