//! iLQR / DDP / box-DDP solver with an allocation-free workspace.
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

use std::time::{Duration, Instant};

use crate::boxqp::box_qp;
use crate::error::{check_finite, Error, Result};
use crate::kernels::{add_sym_tr_mul, add_sym_tr_mul2, mul, mul_vec, tr_mul, tr_mul_vec};
use crate::{CostDerivatives, Matrix, Problem, TerminalDerivatives, Vector};

/// iLQR (first-order dynamics) or full DDP (adds `V_x' . f_xx` terms when the model has them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// Gauss-Newton: no second derivatives of the dynamics.
    #[default]
    Ilqr,
    /// Full DDP with the contracted second derivatives of the dynamics.
    Ddp,
}

/// Where the regularisation `mu` enters the backward pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Regularization {
    /// `Q_uu + mu I` (as Crocoddyl).
    #[default]
    Control,
    /// `V_xx' + mu I` in `Q_uu` and `Q_ux`, Tassa 2012 eq. (10): keeps the step close in state space.
    State,
}

/// Solver settings; validated by [`Solver::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// iLQR or full DDP.
    pub method: Method,
    /// Maximum number of iterations (accepted or rejected steps).
    pub max_iterations: usize,
    /// Converged when `sum_k |Q_u,free|^2` falls below this (Crocoddyl's `th_stop`).
    pub gradient_tolerance: f64,
    /// Converged when an accepted step changes the cost by less than this, relative to `1 + |J|`.
    pub cost_tolerance: f64,
    /// Initial regularisation `mu`.
    pub mu_init: f64,
    /// Smallest non-zero `mu`; below it `mu` drops to 0.
    pub mu_min: f64,
    /// Largest `mu` before giving up.
    pub mu_max: f64,
    /// Tassa's factor `Delta_0` (> 1).
    pub mu_factor: f64,
    /// Where `mu` enters.
    pub regularization: Regularization,
    /// Line-search step reduction (0 < factor < 1).
    pub step_factor: f64,
    /// Smallest step tried.
    pub step_min: f64,
    /// Accept a step when `actual / expected` decrease exceeds this.
    pub armijo: f64,
    /// Iteration limit of the box QP (box-DDP).
    pub box_qp_iterations: usize,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            method: Method::Ilqr,
            max_iterations: 200,
            gradient_tolerance: 1e-9,
            cost_tolerance: 1e-14,
            mu_init: 0.0,
            mu_min: 1e-9,
            mu_max: 1e10,
            mu_factor: 1.6,
            regularization: Regularization::Control,
            step_factor: 0.5,
            step_min: 1.0 / 1024.0,
            armijo: 1e-4,
            box_qp_iterations: 100,
        }
    }
}

impl Settings {
    /// Rejects settings that cannot work, naming the field.
    pub fn validate(&self) -> Result<()> {
        let pos = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(
                    format!("settings.{name}"),
                    format!("must be finite and > 0, got {v}"),
                ))
            }
        };
        let nonneg = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(
                    format!("settings.{name}"),
                    format!("must be finite and >= 0, got {v}"),
                ))
            }
        };
        if self.max_iterations == 0 {
            return Err(Error::invalid("settings.max_iterations", "must be at least 1"));
        }
        if self.box_qp_iterations == 0 {
            return Err(Error::invalid("settings.box_qp_iterations", "must be at least 1"));
        }
        nonneg("gradient_tolerance", self.gradient_tolerance)?;
        nonneg("cost_tolerance", self.cost_tolerance)?;
        nonneg("mu_init", self.mu_init)?;
        pos("mu_min", self.mu_min)?;
        pos("mu_max", self.mu_max)?;
        if self.mu_max < self.mu_min {
            return Err(Error::invalid("settings.mu_max", "must be >= settings.mu_min"));
        }
        if !(self.mu_factor.is_finite() && self.mu_factor > 1.0) {
            return Err(Error::invalid(
                "settings.mu_factor",
                format!("must be > 1, got {}", self.mu_factor),
            ));
        }
        if !(self.step_factor > 0.0 && self.step_factor < 1.0) {
            return Err(Error::invalid(
                "settings.step_factor",
                format!("must be in (0, 1), got {}", self.step_factor),
            ));
        }
        if !(self.step_min > 0.0 && self.step_min <= 1.0) {
            return Err(Error::invalid(
                "settings.step_min",
                format!("must be in (0, 1], got {}", self.step_min),
            ));
        }
        if !(self.armijo.is_finite() && self.armijo >= 0.0 && self.armijo < 1.0) {
            return Err(Error::invalid(
                "settings.armijo",
                format!("must be in [0, 1), got {}", self.armijo),
            ));
        }
        Ok(())
    }
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
    fn new(capacity: usize) -> Self {
        Self {
            status: Status::MaxIterations,
            iterations: 0,
            cost: f64::NAN,
            initial_cost: f64::NAN,
            gradient: f64::NAN,
            mu: 0.0,
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

/// The solver and its workspace for problems with horizon `N`, `NX` states and `NU` controls.
///
/// [`Solver::new`] allocates every buffer (`O(N)` fixed-size matrices and the iteration log);
/// [`Solver::solve`] allocates nothing. The controls in the workspace are the initial guess of
/// the next solve: after a solve they warm-start the next one; [`Solver::reset`] zeros them,
/// [`Solver::set_controls`] sets them, [`Solver::shift`] moves them one knot for receding horizon.
///
/// The solved trajectory satisfies `u_k = us[k] + K[k] (x_k - xs[k])` as a feedback law.
#[derive(Debug, Clone)]
pub struct Solver<const NX: usize, const NU: usize> {
    settings: Settings,
    n: usize,
    xs: Vec<Vector<NX>>,
    us: Vec<Vector<NU>>,
    xs_try: Vec<Vector<NX>>,
    us_try: Vec<Vector<NU>>,
    fx: Vec<Matrix<NX, NX>>,
    fu: Vec<Matrix<NX, NU>>,
    l: Vec<CostDerivatives<NX, NU>>,
    l_n: TerminalDerivatives<NX>,
    k_ff: Vec<Vector<NU>>,
    k_fb: Vec<Matrix<NU, NX>>,
    v_x: Vec<Vector<NX>>,
    v_xx: Vec<Matrix<NX, NX>>,
    cost: f64,
    dv1: f64,
    dv2: f64,
    gradient: f64,
    report: Report,
}

/// A backward pass that hit a `Q_uu` that is not positive definite at knot `k`.
struct NotPositiveDefinite;

impl<const NX: usize, const NU: usize> Solver<NX, NU> {
    /// Validates `settings` and allocates the workspace for `problem`'s horizon.
    pub fn new(problem: &Problem<NX, NU>, settings: Settings) -> Result<Self> {
        settings.validate()?;
        let n = problem.horizon();
        Ok(Self {
            settings,
            n,
            xs: vec![Vector::zeros(); n + 1],
            us: vec![Vector::zeros(); n],
            xs_try: vec![Vector::zeros(); n + 1],
            us_try: vec![Vector::zeros(); n],
            fx: vec![Matrix::zeros(); n],
            fu: vec![Matrix::zeros(); n],
            l: vec![CostDerivatives::default(); n],
            l_n: TerminalDerivatives::default(),
            k_ff: vec![Vector::zeros(); n],
            k_fb: vec![Matrix::zeros(); n],
            v_x: vec![Vector::zeros(); n + 1],
            v_xx: vec![Matrix::zeros(); n + 1],
            cost: f64::NAN,
            dv1: 0.0,
            dv2: 0.0,
            gradient: f64::NAN,
            report: Report::new(settings.max_iterations + 1),
        })
    }

    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Replaces the settings (validated; the log keeps its capacity if large enough).
    pub fn set_settings(&mut self, settings: Settings) -> Result<()> {
        settings.validate()?;
        if settings.max_iterations + 1 > self.report.log.capacity() {
            self.report
                .log
                .reserve(settings.max_iterations + 1 - self.report.log.len());
        }
        self.settings = settings;
        Ok(())
    }

    /// The horizon this workspace was made for.
    pub fn horizon(&self) -> usize {
        self.n
    }

    /// Zeros the initial guess and the gains (a cold start).
    pub fn reset(&mut self) {
        self.us.iter_mut().for_each(|u| *u = Vector::zeros());
        self.k_ff.iter_mut().for_each(|k| *k = Vector::zeros());
        self.k_fb.iter_mut().for_each(|k| *k = Matrix::zeros());
    }

    /// Sets the initial guess of the next solve (length `N`, finite).
    pub fn set_controls(&mut self, us: &[Vector<NU>]) -> Result<()> {
        if us.len() != self.n {
            return Err(Error::Shape {
                field: "us".into(),
                got: format!("({}, {NU})", us.len()),
                expected: format!("({}, {NU})", self.n),
            });
        }
        for (k, u) in us.iter().enumerate() {
            check_finite(&format!("us[{k}]"), u.iter())?;
        }
        self.us.copy_from_slice(us);
        Ok(())
    }

    /// Receding horizon: drops the first knot of the solution and repeats the last control, so
    /// the next solve (from the next state) starts from the shifted trajectory.
    pub fn shift(&mut self) {
        if self.n > 1 {
            self.us.copy_within(1.., 0);
            self.xs.copy_within(1.., 0);
            self.k_ff.copy_within(1.., 0);
            self.k_fb.copy_within(1.., 0);
            self.xs[self.n] = self.xs[self.n - 1];
        }
    }

    /// States `x_0 .. x_N` of the last solve.
    pub fn xs(&self) -> &[Vector<NX>] {
        &self.xs
    }
    /// Controls `u_0 .. u_{N-1}` of the last solve.
    pub fn us(&self) -> &[Vector<NU>] {
        &self.us
    }
    /// Feedback gains `K_k` of the last backward pass.
    pub fn gains(&self) -> &[Matrix<NU, NX>] {
        &self.k_fb
    }
    /// Feed-forward terms `k_k` of the last backward pass.
    pub fn feedforward(&self) -> &[Vector<NU>] {
        &self.k_ff
    }
    /// `V_x` along the trajectory (`N + 1` entries) from the last backward pass.
    pub fn value_gradient(&self) -> &[Vector<NX>] {
        &self.v_x
    }
    /// `V_xx` along the trajectory (`N + 1` entries) from the last backward pass.
    pub fn value_hessian(&self) -> &[Matrix<NX, NX>] {
        &self.v_xx
    }
    /// The report of the last solve.
    pub fn report(&self) -> &Report {
        &self.report
    }

    /// Solves `problem` from the controls in the workspace (see the type docs).
    ///
    /// Errors only on bad input (a horizon other than the workspace's); the outcome of the
    /// algorithm is [`Report::status`].
    pub fn solve(&mut self, problem: &Problem<NX, NU>) -> Result<&Report> {
        self.check_horizon(problem)?;
        let start = Instant::now();
        let s = self.settings;
        let r = &mut self.report;
        r.log.clear();
        r.iterations = 0;
        r.backward_passes = 0;
        r.forward_passes = 0;
        r.gauss_newton_knots = 0;

        if let Some(b) = problem.bounds() {
            self.us.iter_mut().for_each(|u| *u = b.clamp(u));
        }
        self.cost = rollout(problem, &self.us, &mut self.xs);
        self.report.initial_cost = self.cost;
        let mut status = Status::MaxIterations;
        let mut mu = s.mu_init;
        let mut dmu = 1.0;
        self.gradient = f64::NAN;
        self.report.log.push(IterationLog {
            iteration: 0,
            cost: self.cost,
            gradient: f64::NAN,
            expected: f64::NAN,
            step: 0.0,
            mu,
            accepted: true,
        });

        if !self.cost.is_finite() {
            status = Status::NumericalError;
        } else {
            let mut need_derivatives = true;
            'outer: for iteration in 1..=s.max_iterations {
                if need_derivatives {
                    self.compute_derivatives(problem);
                    need_derivatives = false;
                }
                // Backward pass, raising mu until Q_uu is positive definite.
                loop {
                    self.report.backward_passes += 1;
                    let mut result = self.backward_pass(problem, mu, false);
                    if result.is_err() && s.method == Method::Ddp {
                        // Full DDP: before raising mu, retry keeping the second-order terms only
                        // at knots where they leave the Q block definite.
                        self.report.backward_passes += 1;
                        result = self.backward_pass(problem, mu, true);
                    }
                    match result {
                        Ok(()) => break,
                        Err(NotPositiveDefinite) => {
                            dmu = f64::max(s.mu_factor, dmu * s.mu_factor);
                            mu = f64::max(s.mu_min, mu * dmu);
                            if mu > s.mu_max {
                                status = Status::RegularizationLimit;
                                break 'outer;
                            }
                        }
                    }
                }
                // With control bounds the gradient counts free controls only, so a step that is
                // all clamped (e.g. from u = 0 when every control wants its bound) has a zero
                // gradient yet moves the controls: converge only when it is expected to gain nothing.
                let stalled = problem.bounds().is_none() || -(self.dv1 + self.dv2) <= s.gradient_tolerance;
                if self.gradient < s.gradient_tolerance && stalled {
                    status = Status::Converged;
                    break;
                }
                // Line search on the expected improvement.
                let mut alpha = 1.0;
                let mut accepted = false;
                let mut new_cost = f64::NAN;
                while alpha >= s.step_min {
                    new_cost = self.forward_pass(problem, alpha);
                    self.report.forward_passes += 1;
                    let expected = -(alpha * self.dv1 + alpha * alpha * self.dv2);
                    let actual = self.cost - new_cost;
                    if new_cost.is_finite()
                        && ((expected > 0.0 && actual >= s.armijo * expected) || (expected <= 0.0 && actual >= 0.0))
                    {
                        accepted = true;
                        break;
                    }
                    alpha *= s.step_factor;
                }
                let expected = -(self.dv1 + self.dv2);
                if accepted {
                    let change = self.cost - new_cost;
                    std::mem::swap(&mut self.xs, &mut self.xs_try);
                    std::mem::swap(&mut self.us, &mut self.us_try);
                    self.cost = new_cost;
                    self.report.iterations += 1;
                    need_derivatives = true;
                    self.report.log.push(IterationLog {
                        iteration,
                        cost: new_cost,
                        gradient: self.gradient,
                        expected,
                        step: alpha,
                        mu,
                        accepted: true,
                    });
                    // Tassa's schedule: decrease mu after a success.
                    dmu = f64::min(dmu / s.mu_factor, 1.0 / s.mu_factor);
                    mu = if mu * dmu > s.mu_min { mu * dmu } else { 0.0 };
                    if change.abs() < s.cost_tolerance * (1.0 + self.cost.abs()) {
                        status = Status::Converged;
                        break;
                    }
                } else {
                    self.report.log.push(IterationLog {
                        iteration,
                        cost: self.cost,
                        gradient: self.gradient,
                        expected,
                        step: 0.0,
                        mu,
                        accepted: false,
                    });
                    dmu = f64::max(s.mu_factor, dmu * s.mu_factor);
                    mu = f64::max(s.mu_min, mu * dmu);
                    if mu > s.mu_max {
                        status = Status::LineSearchFailed;
                        break;
                    }
                }
            }
        }

        let r = &mut self.report;
        r.status = status;
        r.cost = self.cost;
        r.gradient = self.gradient;
        r.mu = mu;
        r.solve_time = start.elapsed();
        Ok(&self.report)
    }

    fn check_horizon(&self, problem: &Problem<NX, NU>) -> Result<()> {
        if problem.horizon() != self.n {
            return Err(Error::Shape {
                field: "problem.horizon".into(),
                got: problem.horizon().to_string(),
                expected: format!("{} (the horizon this solver was created for)", self.n),
            });
        }
        Ok(())
    }

    /// Phase 1 of an iteration, exposed for benchmarks and solvers built on this one: the
    /// derivatives of dynamics and costs along the workspace trajectory.
    pub fn linearize(&mut self, problem: &Problem<NX, NU>) -> Result<()> {
        self.check_horizon(problem)?;
        self.compute_derivatives(problem);
        Ok(())
    }

    /// Phase 2: the backward pass with regularisation `mu`. `Ok(false)` when `Q_uu` was not
    /// positive definite at some knot.
    pub fn backward(&mut self, problem: &Problem<NX, NU>, mu: f64) -> Result<bool> {
        self.check_horizon(problem)?;
        Ok(self.backward_pass(problem, mu, false).is_ok())
    }

    /// Phase 3: rolls out the new policy with step `alpha` (into scratch buffers, leaving the
    /// trajectory unchanged) and returns its cost.
    pub fn forward(&mut self, problem: &Problem<NX, NU>, alpha: f64) -> Result<f64> {
        self.check_horizon(problem)?;
        Ok(self.forward_pass(problem, alpha))
    }

    /// Derivatives of dynamics and costs along `(xs, us)`.
    #[inline(never)]
    fn compute_derivatives(&mut self, problem: &Problem<NX, NU>) {
        for (k, knot) in problem.knots().iter().enumerate() {
            let (x, u) = (&self.xs[k], &self.us[k]);
            knot.dynamics.jacobians(x, u, &mut self.fx[k], &mut self.fu[k]);
            let l = &mut self.l[k];
            l.clear();
            knot.cost.add_derivatives(x, u, 1.0, l);
        }
        self.l_n.clear();
        problem.terminal().add_derivatives(&self.xs[self.n], 1.0, &mut self.l_n);
    }

    #[inline(never)]
    fn backward_pass(
        &mut self,
        problem: &Problem<NX, NU>,
        mu: f64,
        gated: bool,
    ) -> std::result::Result<(), NotPositiveDefinite> {
        let ddp = self.settings.method == Method::Ddp;
        let bounds = problem.bounds();
        self.v_x[self.n] = self.l_n.lx;
        self.v_xx[self.n] = self.l_n.lxx;
        self.dv1 = 0.0;
        self.dv2 = 0.0;
        self.gradient = 0.0;
        for k in (0..self.n).rev() {
            let (fx, fu, l) = (&self.fx[k], &self.fu[k], &self.l[k]);
            let v_x = &self.v_x[k + 1];
            let v_xx = &self.v_xx[k + 1];
            let q_x = l.lx + tr_mul_vec(fx, v_x);
            let q_u = l.lu + tr_mul_vec(fu, v_x);
            let v_xx_fx = mul(v_xx, fx);
            let v_xx_fu = mul(v_xx, fu);
            let mut q_xx = add_sym_tr_mul(&l.lxx, fx, &v_xx_fx);
            let mut q_uu = l.luu + tr_mul(fu, &v_xx_fu);
            let mut q_ux = l.lux + tr_mul(fu, &v_xx_fx);
            let regularize = |q_uu: &Matrix<NU, NU>, q_ux: &Matrix<NU, NX>| match self.settings.regularization {
                Regularization::Control => {
                    let mut m = *q_uu;
                    for i in 0..NU {
                        m[(i, i)] += mu;
                    }
                    (m, *q_ux)
                }
                Regularization::State => (q_uu + mu * fu.tr_mul(fu), q_ux + mu * fu.tr_mul(fx)),
            };
            if ddp {
                let knot = &problem.knots()[k];
                if knot.dynamics.has_second_order() {
                    // Full DDP adds V_x' . f_xx etc. Far from a minimum that can make the Q block
                    // indefinite, and through Q_xx the indefiniteness would flow into every V_xx
                    // upstream. So this knot keeps the second-order terms only when the whole
                    // block is positive (semi)definite: Q_uu > 0 and its Schur complement
                    // Q_xx - Q_ux^T Q_uu^-1 Q_ux >= 0 (the V_xx this knot passes on). Otherwise it
                    // uses the Gauss-Newton blocks, and V_xx stays PSD by induction.
                    let (mut f_xx, mut f_ux, mut f_uu) = (q_xx, q_ux, q_uu);
                    knot.dynamics
                        .add_second_order(&self.xs[k], &self.us[k], v_x, &mut f_xx, &mut f_ux, &mut f_uu);
                    let (r_uu, r_ux) = regularize(&f_uu, &f_ux);
                    let definite = !gated
                        || (0.5 * (r_uu + r_uu.transpose())).cholesky().is_some_and(|c| {
                            let schur = f_xx - r_ux.tr_mul(&c.solve(&r_ux));
                            let mut shifted = 0.5 * (schur + schur.transpose());
                            let tol = 1e-9 * (1.0 + f_xx.amax());
                            for i in 0..NX {
                                shifted[(i, i)] += tol;
                            }
                            shifted.cholesky().is_some()
                        });
                    if !gated || definite {
                        (q_xx, q_ux, q_uu) = (f_xx, f_ux, f_uu);
                    } else {
                        self.report.gauss_newton_knots += 1;
                    }
                }
            }
            let (mut q_uu_r, q_ux_r) = regularize(&q_uu, &q_ux);
            q_uu_r = 0.5 * (q_uu_r + q_uu_r.transpose());

            let control_reg = self.settings.regularization == Regularization::Control;
            let (k_ff, k_fb, grad) = match bounds {
                None => {
                    let chol = q_uu_r.cholesky().ok_or(NotPositiveDefinite)?;
                    (-chol.solve(&q_u), -chol.solve(&q_ux_r), q_u.norm_squared())
                }
                Some(b) => {
                    let u = &self.us[k];
                    let qp = box_qp(
                        &q_uu_r,
                        &q_u,
                        &(b.lower - u),
                        &(b.upper - u),
                        &self.k_ff[k],
                        self.settings.box_qp_iterations,
                    );
                    let chol = qp.chol.ok_or(NotPositiveDefinite)?;
                    let mut k_fb = Matrix::<NU, NX>::zeros();
                    let mut grad = 0.0;
                    if qp.free.iter().any(|&f| f) {
                        let rhs = Matrix::<NU, NX>::from_fn(|i, j| if qp.free[i] { q_ux_r[(i, j)] } else { 0.0 });
                        k_fb = -chol.solve(&rhs);
                    }
                    // Stationarity is measured on the free controls only: a clamped one may keep a
                    // gradient that pushes into its bound.
                    for i in 0..NU {
                        if qp.free[i] {
                            grad += q_u[i] * q_u[i];
                        }
                    }
                    (qp.x, k_fb, grad)
                }
            };
            self.gradient += grad;
            let q_uu_k = mul_vec(&q_uu, &k_ff);
            self.dv1 += k_ff.dot(&q_u);
            self.dv2 += 0.5 * k_ff.dot(&q_uu_k);
            // Tassa's update, factored:
            //   V_x  = Q_x  + K^T (Q_uu k + Q_u)  + Q_ux^T k
            //   V_xx = Q_xx + K^T (Q_uu K + Q_ux) + Q_ux^T K   (symmetric for any K).
            // Unbounded with Q_uu + mu I: (Q_uu + mu I) K = -Q_ux and likewise for k, so the
            // brackets are -mu K and -mu k and both collapse to one product with Q_ux - mu K.
            if bounds.is_none() && control_reg {
                let g = q_ux - mu * k_fb;
                self.v_x[k] = q_x + tr_mul_vec(&g, &k_ff);
                self.v_xx[k] = add_sym_tr_mul(&q_xx, &g, &k_fb);
            } else {
                let m_k = q_uu_k + q_u;
                let m_kk = mul(&q_uu, &k_fb) + q_ux;
                self.v_x[k] = q_x + tr_mul_vec(&k_fb, &m_k) + tr_mul_vec(&q_ux, &k_ff);
                self.v_xx[k] = add_sym_tr_mul2(&q_xx, &k_fb, &m_kk, &q_ux, &k_fb);
            }
            self.k_ff[k] = k_ff;
            self.k_fb[k] = k_fb;
        }
        Ok(())
    }

    /// Rolls out the feedback policy with step `alpha` into `(xs_try, us_try)`; returns its cost.
    #[inline(never)]
    fn forward_pass(&mut self, problem: &Problem<NX, NU>, alpha: f64) -> f64 {
        let bounds = problem.bounds();
        let mut cost = 0.0;
        self.xs_try[0] = *problem.x0();
        for (k, knot) in problem.knots().iter().enumerate() {
            let x = self.xs_try[k];
            let mut u = self.us[k] + alpha * self.k_ff[k] + mul_vec(&self.k_fb[k], &(x - self.xs[k]));
            if let Some(b) = bounds {
                u = b.clamp(&u);
            }
            self.us_try[k] = u;
            cost += knot.cost.value(&x, &u);
            self.xs_try[k + 1] = knot.dynamics.step(&x, &u);
        }
        cost + problem.terminal().value(&self.xs_try[self.n])
    }
}

/// Simulates `us` from `problem.x0` into `xs` and returns the cost (no allocation).
fn rollout<const NX: usize, const NU: usize>(
    problem: &Problem<NX, NU>,
    us: &[Vector<NU>],
    xs: &mut [Vector<NX>],
) -> f64 {
    let mut cost = 0.0;
    xs[0] = *problem.x0();
    for (k, knot) in problem.knots().iter().enumerate() {
        cost += knot.cost.value(&xs[k], &us[k]);
        xs[k + 1] = knot.dynamics.step(&xs[k], &us[k]);
    }
    cost + problem.terminal().value(&xs[us.len()])
}
