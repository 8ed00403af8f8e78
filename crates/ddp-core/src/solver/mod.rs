//! iLQR / DDP / box-DDP solver with an allocation-free workspace, built from the one DDP core
//! ([`core`]): it overrides nothing but the gains (free or box-constrained), and, under
//! multiple shooting ([`Settings::shooting`], [`shooting`]), the step and its line search.
//!
//! | symbol (Tassa et al. 2012/2014) | field | meaning |
//! |---|---|---|
//! | `Q_x, Q_u` | `q_x, q_u` | gradients of the Q-function |
//! | `Q_xx, Q_uu, Q_ux` | `q_xx, q_uu, q_ux` | its Hessian blocks (`+ V_x' . f_xx` etc. for full DDP) |
//! | `k, K` | [`Solver::feedforward`], [`Solver::gains`] | `du = k + K dx` |
//! | `V_x, V_xx` | [`Solver::value_gradient`], [`Solver::value_hessian`] | value function along the trajectory |
//! | `mu`, `Delta` | `mu`, `dmu` | regularisation and its schedule (Tassa 2012, §II-F) |
//! | `Delta V = alpha k^T Q_u + alpha^2/2 k^T Q_uu k` | `dv1, dv2` | expected cost change of a step `alpha` |
//!
//! Backward pass (per knot, from `V_x' = l_N,x`, `V_xx' = l_N,xx`):
//!
//! ```text
//! Q_x  = l_x + f_x^T V_x'          Q_u  = l_u + f_u^T V_x'
//! Q_xx = l_xx + f_x^T V_xx' f_x    Q_uu = l_uu + f_u^T V_xx' f_u    Q_ux = l_ux + f_u^T V_xx' f_x
//! k = argmin_{u_min <= u+k <= u_max} 1/2 k^T Q_uu k + Q_u^T k,    K = -Q_uu,ff^{-1} Q_ux,f
//! V_x  = Q_x + K^T Q_uu k + K^T Q_u + Q_ux^T k
//! V_xx = Q_xx + K^T Q_uu K + K^T Q_ux + Q_ux^T K
//! ```
//!
//! Forward pass: `u_k <- clamp(u_k + alpha k_k + K_k (x_k_new - x_k))`, accepted when the actual
//! cost decrease is at least `armijo` times the expected one.

use std::time::Instant;

pub mod core;
pub mod settings;
pub mod shooting;

pub use self::core::{
    armijo_accepts, backward_pass, line_search, BackwardOptions, BoxGains, ClampedGains, Core, DerivativeThreads,
    Expected, FreeGains, Gains, GainsInfo, Linearization, MuSchedule, NotPositiveDefinite, Policy, QBlocks,
    ShootingTerms, Trajectory, Trial, ValueFunction,
};
pub use self::settings::{
    log_rows, IterationLog, LineSearchSettings, Method, Regularization, RegularizationSettings, Report, Settings,
    Shooting, Status, Tolerances, LOG_PREALLOCATED, MAX_THREADS,
};
pub use self::shooting::{MultipleShooting, DEFECT_TOLERANCE};

use crate::dims::{Alloc, DefaultAllocator, Dim, Dims, MatrixN, VectorN};
use crate::error::{Error, Result};
use crate::Problem;

/// The solver and its workspace for problems with horizon `N`, `NX` states and `NU` controls
/// (compile-time or run-time sizes, see [`crate::dims`]).
///
/// [`Solver::new`] allocates every buffer (`O(N)` matrices and the iteration log) and, with
/// [`Settings::derivative_threads`] above 1, starts the thread pool of the derivative phase;
/// [`Solver::solve`] allocates nothing. The controls in the workspace are the initial guess of
/// the next solve: after a solve they warm-start the next one; [`Solver::reset`] zeros them,
/// [`Solver::set_controls`] sets them, [`Solver::shift`] moves them one knot for receding horizon.
///
/// The solved trajectory satisfies `u_k = us[k] + K[k] (x_k - xs[k])` as a feedback law.
#[derive(Debug, Clone)]
pub struct Solver<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    settings: Settings,
    core: Core<NX, NU>,
    report: Report,
}

/// Multiple shooting does not take control bounds ([`crate::solver::shooting`]): an error
/// naming `settings.shooting`.
fn check_shooting<NX: Dim, NU: Dim>(settings: &Settings, problem: &Problem<NX, NU>) -> Result<()>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    if settings.shooting == Shooting::Multiple && problem.bounds().is_some() {
        return Err(Error::invalid(
            "settings.shooting",
            "multiple shooting does not take control bounds; use single shooting (box-DDP) for this problem",
        ));
    }
    Ok(())
}

/// What one iteration's direction step ended with.
enum Direction {
    /// A descent direction (the backward pass succeeded).
    Found,
    /// The stopping test holds: nothing left to gain.
    Stationary,
    /// `mu` passed `mu_max`.
    Failed(Status),
}

impl<NX: Dim, NU: Dim> Solver<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Validates `settings` and allocates the workspace for `problem`'s sizes and horizon.
    pub fn new(problem: &Problem<NX, NU>, settings: Settings) -> Result<Self> {
        settings.validate()?;
        check_shooting(&settings, problem)?;
        let mut core = Core::new(problem.dims(), problem.horizon(), &settings.regularization);
        core.set_derivative_threads(settings.derivative_threads)?;
        core.set_shooting(settings.shooting, settings.max_iterations);
        Ok(Self {
            settings,
            core,
            report: Report::new(log_rows(settings.max_iterations)),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Replaces the settings (validated; the log keeps its capacity if large enough).
    pub fn set_settings(&mut self, settings: Settings) -> Result<()> {
        settings.validate()?;
        self.core.set_derivative_threads(settings.derivative_threads)?;
        self.core.set_shooting(settings.shooting, settings.max_iterations);
        let rows = log_rows(settings.max_iterations);
        if rows > self.report.log.capacity() {
            self.report.log.reserve(rows - self.report.log.len());
        }
        self.settings = settings;
        Ok(())
    }

    /// The horizon this workspace was made for.
    pub fn horizon(&self) -> usize {
        self.core.n
    }

    /// The sizes this workspace was made for.
    pub fn dims(&self) -> Dims<NX, NU> {
        self.core.dims
    }

    /// Zeros the initial guess and the gains (a cold start).
    pub fn reset(&mut self) {
        self.core.traj.us.iter_mut().for_each(|u| u.fill(0.0));
        self.core.policy.clear();
        if let Some(ms) = self.core.ms.as_mut() {
            ms.state_guess = false;
        }
    }

    /// Sets the initial guess of the next solve (length `N`, each of size `nu`, finite).
    pub fn set_controls(&mut self, us: &[VectorN<NU>]) -> Result<()> {
        self.core.set_controls(us)?;
        Ok(())
    }

    /// Multiple shooting: the next solve starts from these states (length `N + 1`, each of size
    /// `nx`, finite; `x_0` is replaced by the problem's) with the controls in the workspace,
    /// instead of from the rollout of the controls, and closes the defects between them (a
    /// straight line to the goal, a demonstration, a previous solution's states). Errors name
    /// `xs` or `xs[k]`, or `settings.shooting` under single shooting, whose states are always
    /// the rollout. [`Solver::reset`] drops the guess.
    pub fn set_states(&mut self, xs: &[VectorN<NX>]) -> Result<()> {
        if self.core.ms.is_none() {
            return Err(Error::invalid(
                "settings.shooting",
                "a state guess needs multiple shooting (single shooting's states are the rollout of the controls)",
            ));
        }
        self.core.set_states(xs)?;
        if let Some(ms) = self.core.ms.as_mut() {
            ms.state_guess = true;
        }
        Ok(())
    }

    /// Receding horizon: drops the first knot of the solution and repeats the last control, so
    /// the next solve (from the next state) starts from the shifted trajectory.
    pub fn shift(&mut self) {
        self.core.shift();
    }

    /// States `x_0 .. x_N` of the last solve.
    pub fn xs(&self) -> &[VectorN<NX>] {
        &self.core.traj.xs
    }
    /// Controls `u_0 .. u_{N-1}` of the last solve.
    pub fn us(&self) -> &[VectorN<NU>] {
        &self.core.traj.us
    }
    /// Feedback gains `K_k` of the last backward pass.
    pub fn gains(&self) -> &[MatrixN<NU, NX>] {
        &self.core.policy.k_fb
    }
    /// Feed-forward terms `k_k` of the last backward pass.
    pub fn feedforward(&self) -> &[VectorN<NU>] {
        &self.core.policy.k_ff
    }
    /// `V_x` along the trajectory (`N + 1` entries) from the last backward pass.
    pub fn value_gradient(&self) -> &[VectorN<NX>] {
        &self.core.value.v_x
    }
    /// `V_xx` along the trajectory (`N + 1` entries) from the last backward pass.
    pub fn value_hessian(&self) -> &[MatrixN<NX, NX>] {
        &self.core.value.v_xx
    }
    /// The report of the last solve.
    pub fn report(&self) -> &Report {
        &self.report
    }

    /// Solves `problem` from the controls in the workspace (see the type docs): a loop of named
    /// steps, as Crocoddyl's `solve` (linearise, compute direction, stopping test, try step,
    /// raise or lower the regularisation).
    ///
    /// Errors only on bad input (a horizon or sizes other than the workspace's); the outcome
    /// of the algorithm is [`Report::status`].
    pub fn solve(&mut self, problem: &Problem<NX, NU>) -> Result<&Report> {
        self.check_problem(problem)?;
        let start = Instant::now();
        self.start(problem);
        let mut status = Status::MaxIterations;
        if !self.core.cost.is_finite() {
            status = Status::NumericalError;
        } else {
            let mut need_derivatives = true;
            for iteration in 1..=self.settings.max_iterations {
                if need_derivatives {
                    self.core.linearize(problem, self.settings.method);
                    need_derivatives = false;
                }
                match self.compute_direction(problem) {
                    Direction::Found => {}
                    Direction::Stationary => {
                        status = Status::Converged;
                        break;
                    }
                    Direction::Failed(s) => {
                        status = s;
                        break;
                    }
                }
                match self.try_step(problem) {
                    Some((alpha, new_cost)) => {
                        let change = self.core.cost - new_cost;
                        self.accept_step(iteration, alpha, new_cost);
                        need_derivatives = true;
                        self.core.reg.lower(&self.settings.regularization);
                        if self.cost_converged(change) {
                            status = Status::Converged;
                            break;
                        }
                    }
                    None => {
                        self.log(iteration, 0.0, false);
                        if !self.core.reg.raise(&self.settings.regularization) {
                            status = Status::LineSearchFailed;
                            break;
                        }
                    }
                }
            }
        }
        self.finish(status, start);
        Ok(&self.report)
    }

    /// Clamps the initial guess, rolls it out and starts the report.
    fn start(&mut self, problem: &Problem<NX, NU>) {
        let r = &mut self.report;
        r.log.clear();
        r.iterations = 0;
        r.backward_passes = 0;
        r.forward_passes = 0;
        r.gauss_newton_knots = 0;
        self.core.clamp_controls(problem.bounds());
        let cost = if self.core.ms.as_ref().is_some_and(|ms| ms.state_guess) {
            self.core.ms_start_from_states(problem)
        } else {
            let cost = self.core.rollout(problem);
            if let Some(ms) = self.core.ms.as_mut() {
                ms.reset(); // the rollout has no defects
            }
            cost
        };
        self.report.initial_cost = cost;
        self.core.reg.reset(&self.settings.regularization);
        self.core.expected = Expected {
            gradient: f64::NAN,
            ..Expected::default()
        };
        self.log(0, 0.0, true);
    }

    /// The backward pass, raising `mu` until `Q_uu` is positive definite (full DDP retries with
    /// the second-order terms gated, see [`MuSchedule::until_definite`]); then the stopping test.
    fn compute_direction(&mut self, problem: &Problem<NX, NU>) -> Direction {
        let s = self.settings;
        let (mut reg, mut passes) = (self.core.reg, 0);
        let ok = reg.until_definite(&s.regularization, s.method, &mut passes, |opts| {
            self.backward_with(problem, opts)
        });
        self.core.reg = reg;
        self.report.backward_passes += passes;
        if !ok {
            return Direction::Failed(Status::RegularizationLimit);
        }
        if self.stopping_criteria(problem) {
            Direction::Stationary
        } else {
            Direction::Found
        }
    }

    /// The core's backward pass with this solver's gains: free, or box-DDP's under bounds.
    fn backward_with(
        &mut self,
        problem: &Problem<NX, NU>,
        opts: BackwardOptions,
    ) -> std::result::Result<(), NotPositiveDefinite> {
        let result = match problem.bounds() {
            None => self.core.backward(problem, &mut FreeGains, opts),
            Some(bounds) => self.core.backward(
                problem,
                &mut BoxGains {
                    bounds,
                    iterations: self.settings.box_qp_iterations,
                },
                opts,
            ),
        };
        if result.is_ok() {
            self.report.gauss_newton_knots += self.core.expected.gauss_newton_knots;
        }
        result
    }

    /// Stationarity: `sum |Q_u,free|^2` below tolerance. With control bounds the gradient counts
    /// free controls only, so a step that is all clamped (e.g. from u = 0 when every control
    /// wants its bound) has a zero gradient yet moves the controls: stop only when it is also
    /// expected to gain nothing.
    fn stopping_criteria(&self, problem: &Problem<NX, NU>) -> bool {
        let tol = self.settings.tolerances.gradient;
        let e = &self.core.expected;
        let stalled = problem.bounds().is_none() || e.decrease(1.0) <= tol;
        e.gradient < tol && stalled && self.consistent()
    }

    /// Whether the trajectory is a rollout up to [`DEFECT_TOLERANCE`] (always under single
    /// shooting).
    fn consistent(&self) -> bool {
        self.core
            .ms
            .as_ref()
            .is_none_or(|ms| ms.max_defect() <= DEFECT_TOLERANCE)
    }

    /// The line search on the expected improvement; the accepted step and its cost.
    fn try_step(&mut self, problem: &Problem<NX, NU>) -> Option<(f64, f64)> {
        if self.core.ms.is_some() {
            return self.try_step_multiple(problem);
        }
        let ls = self.settings.line_search;
        let mut new_cost = f64::NAN;
        let core = &mut self.core;
        let forward_passes = &mut self.report.forward_passes;
        let alpha = line_search(&ls, |alpha| {
            new_cost = core.rollout_policy(problem, alpha);
            *forward_passes += 1;
            let expected = core.expected.decrease(alpha);
            if new_cost.is_finite() && armijo_accepts(&ls, expected, core.cost - new_cost) {
                Trial::Accept
            } else {
                Trial::Shorter
            }
        })?;
        Some((alpha, new_cost))
    }

    /// Multiple shooting's step: the linear rollout of the Riccati solution, then the filter
    /// line search on (total defect, cost) ([`crate::solver::shooting`]); the accepted step and
    /// its cost. The filter takes the current iterate when the step is not an `f-type` one.
    fn try_step_multiple(&mut self, problem: &Problem<NX, NU>) -> Option<(f64, f64)> {
        let ls = self.settings.line_search;
        let core = &mut self.core;
        let gd = core.ms_direction();
        // Logged as the expected decrease of a full step: the first-order one.
        core.expected.dv1 = gd;
        core.expected.dv2 = 0.0;
        let cost = core.cost;
        let forward_passes = &mut self.report.forward_passes;
        let mut trial = (f64::NAN, false);
        let alpha = line_search(&ls, |alpha| {
            let (new_cost, theta) = core.ms_trial(problem, alpha);
            *forward_passes += 1;
            let verdict = core
                .ms
                .as_ref()
                .and_then(|ms| ms.filter_accepts(cost, gd, alpha, ls.armijo, theta, new_cost));
            match verdict {
                Some(f_type) => {
                    trial = (new_cost, f_type);
                    Trial::Accept
                }
                None => Trial::Shorter,
            }
        })?;
        let (new_cost, f_type) = trial;
        if let Some(ms) = core.ms.as_mut() {
            if !f_type {
                ms.augment_filter(cost);
            }
        }
        Some((alpha, new_cost))
    }

    /// Makes the trial the nominal trajectory and logs the iteration.
    fn accept_step(&mut self, iteration: usize, alpha: f64, new_cost: f64) {
        if self.core.ms.is_some() {
            self.core.ms_accept(alpha, new_cost);
        } else {
            self.core.traj.accept_trial();
            self.core.cost = new_cost;
        }
        self.report.iterations += 1;
        self.log(iteration, alpha, true);
    }

    /// An accepted step that changed the cost by less than `tolerances.cost` relative to `1 + |J|`.
    fn cost_converged(&self, change: f64) -> bool {
        change.abs() < self.settings.tolerances.cost * (1.0 + self.core.cost.abs()) && self.consistent()
    }

    fn log(&mut self, iteration: usize, step: f64, accepted: bool) {
        let e = &self.core.expected;
        let first = iteration == 0;
        self.report.log.push(IterationLog {
            iteration,
            cost: self.core.cost,
            gradient: e.gradient,
            expected: if first { f64::NAN } else { e.decrease(1.0) },
            step,
            mu: self.core.reg.mu,
            accepted,
        });
    }

    fn finish(&mut self, status: Status, start: Instant) {
        let r = &mut self.report;
        r.status = status;
        r.cost = self.core.cost;
        r.gradient = self.core.expected.gradient;
        r.mu = self.core.reg.mu;
        r.defect = self.core.ms.as_ref().map_or(0.0, |ms| ms.max_defect());
        r.solve_time = start.elapsed();
    }

    fn check_problem(&self, problem: &Problem<NX, NU>) -> Result<()> {
        if problem.horizon() != self.core.n {
            return Err(Error::Shape {
                field: "problem.horizon".into(),
                got: problem.horizon().to_string(),
                expected: format!("{} (the horizon this solver was created for)", self.core.n),
            });
        }
        self.core.check_dims(problem)?;
        check_shooting(&self.settings, problem)
    }

    /// Phase 1 of an iteration, exposed for benchmarks and solvers built on this one: the
    /// derivatives of dynamics and costs along the workspace trajectory.
    pub fn linearize(&mut self, problem: &Problem<NX, NU>) -> Result<()> {
        self.check_problem(problem)?;
        self.core.linearize(problem, self.settings.method);
        Ok(())
    }

    /// Phase 2: the backward pass with regularisation `mu`. `Ok(false)` when `Q_uu` was not
    /// positive definite at some knot.
    pub fn backward(&mut self, problem: &Problem<NX, NU>, mu: f64) -> Result<bool> {
        self.check_problem(problem)?;
        let opts = BackwardOptions {
            mu,
            placement: self.settings.regularization.placement,
            method: self.settings.method,
            gated: false,
        };
        Ok(self.backward_with(problem, opts).is_ok())
    }

    /// Phase 3: rolls out the new policy with step `alpha` (into scratch buffers, leaving the
    /// trajectory unchanged) and returns its cost.
    pub fn forward(&mut self, problem: &Problem<NX, NU>, alpha: f64) -> Result<f64> {
        self.check_problem(problem)?;
        Ok(self.core.rollout_policy(problem, alpha))
    }
}
