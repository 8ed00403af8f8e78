//! Settings, statuses and reports of the DDP solvers. The groups shared by every solver built on
//! the core ([`RegularizationSettings`], [`LineSearchSettings`], [`Tolerances`]) are nested
//! structs with one `Default` each, so a default is written once for every solver and binding.

use std::time::Duration;

use crate::error::{Error, Result};

/// The most iteration-log rows (and multiple shooting's filter entries) a solver allocates up
/// front, however large `max_iterations` is: a solve past them grows its log as it goes (and
/// Safe-CDDP's stops logging and counts the rest in its report's `log_dropped`), rather than
/// allocating `max_iterations` rows at construction, which for a large value (`2^40`, say)
/// would abort the process.
pub const LOG_PREALLOCATED: usize = 1 << 16;

/// The rows to allocate for the log of `max_iterations` iterations (one more for the initial
/// row), at most [`LOG_PREALLOCATED`].
pub fn log_rows(max_iterations: usize) -> usize {
    max_iterations.saturating_add(1).min(LOG_PREALLOCATED)
}

/// iLQR (first-order dynamics) or full DDP (adds `V_x' . f_xx` terms when the model has them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Gauss-Newton: no second derivatives of the dynamics.
    #[default]
    Ilqr,
    /// Full DDP with the contracted second derivatives of the dynamics.
    Ddp,
}

/// What an iteration steps on: the controls alone (the states are their rollout), or states and
/// controls joined by the dynamics as constraints ([`crate::solver::shooting`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Shooting {
    /// Single shooting: the states are the rollout of the controls, always dynamically
    /// consistent; the forward pass simulates the feedback policy (Tassa et al. 2012).
    #[default]
    Single,
    /// Multiple shooting: a step moves states and controls along the Riccati solution of the
    /// linearised problem, the defects `f(x_k, u_k) - x_{k+1}` close as it converges, and a
    /// filter line search accepts steps. Fewer iterations on swing-ups through unstable
    /// dynamics; the states of an unconverged solve need not be a rollout.
    Multiple,
}

/// Where the regularisation `mu` enters the backward pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Regularization {
    /// `Q_uu + mu I` (as Crocoddyl).
    #[default]
    Control,
    /// `V_xx' + mu I` in `Q_uu` and `Q_ux`, Tassa et al. (2012) eq. (10): keeps the step close
    /// in state space.
    State,
}

/// Tassa's regularisation schedule (Tassa, Erez and Todorov 2012, §II-F).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegularizationSettings {
    /// Initial `mu`.
    pub mu_init: f64,
    /// Smallest non-zero `mu`; below it `mu` drops to 0.
    pub mu_min: f64,
    /// Largest `mu` before giving up.
    pub mu_max: f64,
    /// Tassa's factor `Delta_0` (> 1).
    pub mu_factor: f64,
    /// Where `mu` enters.
    pub placement: Regularization,
}

impl Default for RegularizationSettings {
    fn default() -> Self {
        Self {
            mu_init: 0.0,
            mu_min: 1e-9,
            mu_max: 1e10,
            mu_factor: 1.6,
            placement: Regularization::Control,
        }
    }
}

/// Backtracking line search on the expected improvement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LineSearchSettings {
    /// Step reduction (0 < factor < 1).
    pub step_factor: f64,
    /// Smallest step tried.
    pub step_min: f64,
    /// Accept a step when `actual / expected` decrease exceeds this.
    pub armijo: f64,
}

impl Default for LineSearchSettings {
    fn default() -> Self {
        Self {
            step_factor: 0.5,
            step_min: 1.0 / 1024.0,
            armijo: 1e-4,
        }
    }
}

/// Stopping tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tolerances {
    /// Converged when `sum_k |Q_u,free|^2` falls below this (Crocoddyl's `th_stop`).
    pub gradient: f64,
    /// Converged when an accepted step changes the cost by less than this, relative to `1 + |J|`.
    pub cost: f64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Self {
            gradient: 1e-9,
            cost: 1e-14,
        }
    }
}

/// `settings.<name>` must be finite and `> 0` (ddpkit-util's validator, the field prefixed).
pub(crate) fn positive(name: &str, v: f64) -> Result<()> {
    ddpkit_util::check::positive(&format!("settings.{name}"), v)?;
    Ok(())
}

/// `settings.<name>` must be finite and `>= 0`.
pub(crate) fn nonnegative(name: &str, v: f64) -> Result<()> {
    ddpkit_util::check::nonnegative(&format!("settings.{name}"), v)?;
    Ok(())
}

impl RegularizationSettings {
    /// Rejects values that cannot work, naming `settings.regularization.<field>`.
    pub fn validate(&self) -> Result<()> {
        nonnegative("regularization.mu_init", self.mu_init)?;
        positive("regularization.mu_min", self.mu_min)?;
        positive("regularization.mu_max", self.mu_max)?;
        if self.mu_max < self.mu_min {
            return Err(Error::invalid(
                "settings.regularization.mu_max",
                "must be >= settings.regularization.mu_min",
            ));
        }
        if !(self.mu_factor.is_finite() && self.mu_factor > 1.0) {
            return Err(Error::invalid(
                "settings.regularization.mu_factor",
                format!("must be > 1, got {}", self.mu_factor),
            ));
        }
        Ok(())
    }
}

impl LineSearchSettings {
    /// Rejects values that cannot work, naming `settings.line_search.<field>`.
    pub fn validate(&self) -> Result<()> {
        if !(self.step_factor > 0.0 && self.step_factor < 1.0) {
            return Err(Error::invalid(
                "settings.line_search.step_factor",
                format!("must be in (0, 1), got {}", self.step_factor),
            ));
        }
        if !(self.step_min > 0.0 && self.step_min <= 1.0) {
            return Err(Error::invalid(
                "settings.line_search.step_min",
                format!("must be in (0, 1], got {}", self.step_min),
            ));
        }
        if !(self.armijo.is_finite() && self.armijo >= 0.0 && self.armijo < 1.0) {
            return Err(Error::invalid(
                "settings.line_search.armijo",
                format!("must be in [0, 1), got {}", self.armijo),
            ));
        }
        Ok(())
    }
}

impl Tolerances {
    /// Rejects negative or non-finite tolerances, naming `settings.tolerances.<field>`.
    pub fn validate(&self) -> Result<()> {
        nonnegative("tolerances.gradient", self.gradient)?;
        nonnegative("tolerances.cost", self.cost)
    }
}

/// Settings of [`crate::Solver`]; validated by [`crate::Solver::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// iLQR or full DDP.
    pub method: Method,
    /// Single or multiple shooting.
    pub shooting: Shooting,
    /// Maximum number of iterations (accepted or rejected steps).
    pub max_iterations: usize,
    /// Stopping tests.
    pub tolerances: Tolerances,
    /// Regularisation schedule.
    pub regularization: RegularizationSettings,
    /// Line search.
    pub line_search: LineSearchSettings,
    /// Iteration limit of the box QP (box-DDP).
    pub box_qp_iterations: usize,
    /// Threads that compute the dynamics and cost derivatives of the knots (Crocoddyl's
    /// `nthreads`); 1 (the default) computes them on the calling thread. The knots are split
    /// into contiguous chunks, one per thread, and every knot's derivatives are computed by the
    /// same code as on one thread, so the result is bit-identical for any thread count.
    ///
    /// It pays only where the derivative phase is a large share of an iteration and long enough
    /// to amortise waking the pool (a few microseconds per iteration): expensive models (models
    /// traced from Python, autodiff, finite differences, the arm on a floating base) or long
    /// horizons. For the small analytic robots at `N = 100` the backward pass dominates and it
    /// does not pay (`cargo run --release -p ddp-core --features parallel --example
    /// derivative_threads` measures it). Values above 1 need ddp-core's `parallel` feature; the
    /// pool is created by [`crate::Solver::new`] / [`crate::Solver::set_settings`].
    pub derivative_threads: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            method: Method::Ilqr,
            shooting: Shooting::Single,
            max_iterations: 200,
            tolerances: Tolerances::default(),
            regularization: RegularizationSettings::default(),
            line_search: LineSearchSettings::default(),
            box_qp_iterations: 100,
            derivative_threads: 1,
        }
    }
}

impl Settings {
    /// Rejects settings that cannot work, naming the field.
    pub fn validate(&self) -> Result<()> {
        if self.max_iterations == 0 {
            return Err(Error::invalid("settings.max_iterations", "must be at least 1"));
        }
        if self.box_qp_iterations == 0 {
            return Err(Error::invalid("settings.box_qp_iterations", "must be at least 1"));
        }
        check_derivative_threads(self.derivative_threads)?;
        self.tolerances.validate()?;
        self.regularization.validate()?;
        self.line_search.validate()
    }
}

/// Most threads a solver may ask for (a guard against typos such as `10_000`, not a tuning limit).
pub const MAX_THREADS: usize = 1024;

/// `settings.derivative_threads` must be in `1..=MAX_THREADS`, and above 1 only with the
/// `parallel` feature.
fn check_derivative_threads(threads: usize) -> Result<()> {
    let field = "settings.derivative_threads";
    if threads == 0 || threads > MAX_THREADS {
        return Err(Error::invalid(
            field,
            format!("must be in 1..={MAX_THREADS} (1: on the calling thread), got {threads}"),
        ));
    }
    if threads > 1 && !cfg!(feature = "parallel") {
        return Err(Error::invalid(
            field,
            format!("{threads} threads need ddp-core's `parallel` feature (this build has only 1)"),
        ));
    }
    Ok(())
}

/// How a solve ended. Bad input is an [`Error`], never a status.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Status {
    /// A stopping test was met.
    Converged,
    /// `max_iterations` reached; the trajectory is the best found.
    MaxIterations,
    /// `Q_uu` could not be made positive definite below `mu_max`.
    RegularizationLimit,
    /// No step length decreased the cost, even at `mu_max`.
    LineSearchFailed,
    /// The initial rollout or its cost was not finite.
    NumericalError,
}

impl Status {
    /// Short lower-case name (`"converged"`, ...).
    pub fn as_str(&self) -> &'static str {
        match self {
            Status::Converged => "converged",
            Status::MaxIterations => "max_iterations",
            Status::RegularizationLimit => "regularization_limit",
            Status::LineSearchFailed => "line_search_failed",
            Status::NumericalError => "numerical_error",
        }
    }
}

/// One row of the iteration log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IterationLog {
    /// Iteration number (0 is the initial rollout).
    pub iteration: usize,
    /// Cost after this iteration.
    pub cost: f64,
    /// `sum_k |Q_u,free|^2` of the backward pass of this iteration.
    pub gradient: f64,
    /// Expected decrease `-(dv1 + dv2)` at full step.
    pub expected: f64,
    /// Accepted step length (0 when rejected).
    pub step: f64,
    /// Regularisation used in the backward pass.
    pub mu: f64,
    /// Whether the step was accepted.
    pub accepted: bool,
}

/// Outcome and statistics of a solve. Lives in the solver; `log` is allocated once.
#[derive(Debug, Clone)]
pub struct Report {
    /// How the solve ended.
    pub status: Status,
    /// Accepted steps.
    pub iterations: usize,
    /// Final cost.
    pub cost: f64,
    /// Cost of the initial rollout.
    pub initial_cost: f64,
    /// Final `sum_k |Q_u,free|^2`.
    pub gradient: f64,
    /// Final regularisation.
    pub mu: f64,
    /// Largest entry of the dynamics defects `f(x_k, u_k) - x_{k+1}` of the returned
    /// trajectory: 0 under single shooting, at most [`crate::DEFECT_TOLERANCE`] when a
    /// multiple-shooting solve converged.
    pub defect: f64,
    /// Backward passes computed (including regularisation retries).
    pub backward_passes: usize,
    /// Forward rollouts in line searches.
    pub forward_passes: usize,
    /// Full DDP: knots (summed over backward passes) where the second-order dynamics terms made
    /// the Q block indefinite and, after a failed plain pass, the Gauss-Newton blocks were used.
    pub gauss_newton_knots: usize,
    /// Wall time of the solve.
    pub solve_time: Duration,
    /// One row per iteration.
    pub log: Vec<IterationLog>,
}

impl Report {
    pub(crate) fn new(capacity: usize) -> Self {
        Self {
            status: Status::MaxIterations,
            iterations: 0,
            cost: f64::NAN,
            initial_cost: f64::NAN,
            gradient: f64::NAN,
            mu: 0.0,
            defect: 0.0,
            backward_passes: 0,
            forward_passes: 0,
            gauss_newton_knots: 0,
            solve_time: Duration::ZERO,
            log: Vec::with_capacity(capacity),
        }
    }

    /// The iteration table without timings (deterministic: used for golden logs).
    pub fn table(&self) -> String {
        let mut s = String::from("iter        cost    gradient    expected    step          mu\n");
        for r in &self.log {
            s.push_str(&format!(
                "{:4} {:.9e} {:.3e} {:.3e} {:7.4} {:.3e}{}\n",
                r.iteration,
                r.cost,
                r.gradient,
                r.expected,
                r.step,
                r.mu,
                if r.accepted || r.iteration == 0 {
                    ""
                } else {
                    "  rejected"
                }
            ));
        }
        s.push_str(&format!(
            "status: {}, iterations: {}, cost: {:.12e}\n",
            self.status.as_str(),
            self.iterations,
            self.cost
        ));
        s
    }
}
