//! The constrained DDP solver (Xie et al. 2017) with Safe-CDDP tightening (Alcan and Kyrki 2022).
//!
//! One iteration (Algorithm 1, lines 4-26):
//! 1. **Linearise** dynamics, costs and constraints along `(xs, us)`. Constraint rows are
//!    gathered per knot: mixed rows at `(x_k, u_k)`, state rows `g(x_{k+r})` moved to the knot
//!    whose control reaches them (`C = g_x Phi f_u`, `D = g_x Phi f_x`,
//!    `Phi = f_x(k+r-1) ... f_x(k+1)`), and the sides of the control bounds.
//! 2. **Backward pass**: `Q` from eq. (5); rows with `g~ > -epsilon` form the active set; a
//!    working set of at most `NU` independent rows is taken greedily (most active first), rows
//!    with negative multipliers are pruned one by one, and eqs. (10)-(12) give `K, d`; eq. (14)
//!    gives `V_x, V_xx`.
//! 3. **Forward pass**: at every knot the QP of eq. (15) ([`crate::qp::StepQp`]) with
//!    `dx = x - x_bar` and the step `alpha` on `Q_u`; a backtracking line search on the merit
//!    `J + rho sum max(0, g~)`. An infeasible QP retries the pass with a smaller step and a
//!    shrinking trust region `|du| <= Delta` (at most `max_qp_retries` times); then the
//!    regularisation `mu` is raised; past `mu_max` the status is [`Status::Infeasible`] with the
//!    knot.
//! 4. **Tightening** every `n2` iterations of the KKT/QP phase: eq. (19) with the feedback gains
//!    of a backward pass whose only rows are the control bounds ([`crate::Gains::ClosedLoop`]; the
//!    state-constraint rows would make the gains dead-beat, `O(1/dt^r)`, see there), eq. (20)
//!    margins.
//!
//! **Warm-up (design change, [`Settings::al_warm_start`]).** A state constraint can be moved by
//! one knot's control only a little (`C` is `O(dt^2)` for the point robot and the car), so from a
//! far-off guess the per-step QPs turn infeasible and the iterations stall. Each solve therefore
//! starts with augmented-Lagrangian iterations on the same workspace: the constraint rows enter the
//! cost at their own time (so `V_x` carries them backwards), control bounds stay in the KKT
//! working set, the forward pass is a plain rollout (no QPs), and the multipliers are updated
//! between inexact inner solves (at most [`Settings::al_inner_iterations`] each). Once the
//! violation is below [`Settings::al_switch_violation`] the iterations above take over with the
//! multipliers as their first estimate. A tightening that makes the trajectory infeasible, or a
//! KKT/QP iteration that finds no acceptable step, re-enters the warm-up with the current
//! multipliers and a moderate penalty; after such a failure the warm-up runs to its own
//! convergence. Multipliers and penalty carry over between solves ([`SafeCddpSolver::reset`] is
//! the cold start), and a warm start that is already feasible skips the warm-up.
//!
//! | symbol | field / accessor | equation |
//! |---|---|---|
//! | `Q_x, Q_u, Q_xx, Q_uu, Q_ux` | `q_x, q_u, q_xx, q_uu, q_ux` (`q_uu_r = Q_uu + mu I`) | (5) |
//! | `C, D` (`g~_u`, `g~_x` of the rows of a knot) | `row_c`, `row_d` | (8) |
//! | `lambda` | [`SafeCddpSolver::multipliers`] | (10) |
//! | `K, d` | [`SafeCddpSolver::gains`], [`SafeCddpSolver::feedforward`] | (11)-(12) |
//! | `V_x, V_xx` | `v_x`, `v_xx` | (14) |
//! | `du*` | solution of [`crate::qp::StepQp::solve`] | (15)-(16) |
//! | `Sigma_x` | [`SafeCddpSolver::covariances`] | (19) |
//! | `phi^{-1}(beta) sqrt(g_x^T Sigma_x g_x)` | [`SafeCddpSolver::margins`] (`row_margin`) | (20) |
//! | `epsilon` (active set) | [`Settings::active_threshold`] | §III-A |
//! | `n1`, `n2` | [`crate::mpc::MpcSettings::iterations`], [`crate::Tightening::update_every`] | Alg. 1 |

use nalgebra::Const;
use std::sync::Arc;
use std::time::Instant;

use ddp_core::error::check_finite;
use ddp_core::{CostDerivatives, Error, Matrix, Method, Problem, Result, TerminalDerivatives, Vector};

use crate::qp::{QpOutcome, StepQp};
use crate::settings::{IterationLog, Report, Settings, Status};
use crate::tightening::{margin, propagate_covariance, Gains, Tightening};
use crate::Constraint;

/// Where the rows of one constraint sit in a knot's row block.
#[derive(Debug, Clone, Copy)]
struct Slot {
    offset: usize,
    dim: usize,
    mixed: bool,
    /// Relative degree `r` (state rows at knot `k` constrain `x_{k+r}`); 0 for mixed rows.
    degree: usize,
}

/// What one call of [`SafeCddpSolver::iterate`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum IterationOutcome {
    /// A step was accepted.
    Accepted {
        /// Its length `alpha`.
        step: f64,
        /// Whether the convergence tests are met.
        converged: bool,
    },
    /// No step was accepted; `mu` was raised (the next iteration retries).
    Rejected,
    /// The iteration ended the solve (regularisation limit, infeasible, numerical failure).
    Failed(Status),
    /// The projected gradient is below tolerance on a feasible trajectory: nothing to do.
    Converged,
}

/// Result of one forward pass.
enum Forward {
    /// Merit, cost and summed tightened violation of the trial trajectory.
    Done { merit: f64, cost: f64 },
    /// The QP of a knot was infeasible; the largest `|du|` reached before it.
    Infeasible { knot: usize, max_du: f64 },
    /// Clarabel failed at a knot.
    Failed { knot: usize },
}

/// The Safe-CDDP solver and its workspace, for `NX` states, `NU` controls, a horizon of at most
/// the problem's `N` knots and a fixed list of constraints.
///
/// [`SafeCddpSolver::new`] allocates everything: `O(N)` fixed-size matrices, `O(N m)` constraint
/// rows (`m` = rows per knot), the iteration log, and the Clarabel QP solver, which is set up
/// once for `m + 2 NU` rows and updated in place. [`SafeCddpSolver::solve`] allocates nothing
/// itself; Clarabel allocates a little inside its own `solve` (timers), which runs only for QPs
/// that the fast paths do not answer.
///
/// The controls in the workspace are the initial guess of the next solve (warm start);
/// [`SafeCddpSolver::shift`] and [`SafeCddpSolver::set_horizon`] implement the shrinking-horizon
/// MPC of Algorithm 1.
pub struct SafeCddpSolver<const NX: usize, const NU: usize> {
    settings: Settings,
    cap: usize,
    n: usize,
    constraints: Vec<Arc<dyn Constraint<NX, NU>>>,
    slots: Vec<Slot>,
    /// Rows per knot: every constraint row, then `2 NU` control-bound sides.
    m: usize,
    bound_offset: usize,
    xs: Vec<Vector<NX>>,
    us: Vec<Vector<NU>>,
    xs_try: Vec<Vector<NX>>,
    us_try: Vec<Vector<NU>>,
    fx: Vec<Matrix<NX, NX>>,
    fu: Vec<Matrix<NX, NU>>,
    l: Vec<CostDerivatives<Const<NX>, Const<NU>>>,
    l_n: TerminalDerivatives<Const<NX>>,
    q_u: Vec<Vector<NU>>,
    q_ux: Vec<Matrix<NU, NX>>,
    q_uu_r: Vec<Matrix<NU, NU>>,
    k_ff: Vec<Vector<NU>>,
    k_fb: Vec<Matrix<NU, NX>>,
    /// Gains of the last tightening's covariance propagation (see [`crate::Gains`]).
    k_prop: Vec<Matrix<NU, NX>>,
    v_x: Vec<Vector<NX>>,
    v_xx: Vec<Matrix<NX, NX>>,
    row_present: Vec<bool>,
    row_g: Vec<f64>,
    row_margin: Vec<f64>,
    row_c: Vec<Vector<NU>>,
    row_d: Vec<Vector<NX>>,
    row_gx: Vec<Vector<NX>>,
    row_gu: Vec<Vector<NU>>,
    row_lambda: Vec<f64>,
    /// Working set of each knot (`NU` slots, `ws_len[k]` used), as row indices within the knot.
    ws: Vec<usize>,
    ws_len: Vec<usize>,
    h_con: Vec<Matrix<NX, NX>>,
    sigma: Vec<Matrix<NX, NX>>,
    tightening: Option<Tightening<NX, NU>>,
    // Scratch (sized at construction).
    sg: Vec<f64>,
    sgx: Vec<Vector<NX>>,
    sgu: Vec<Vector<NU>>,
    sw: Vec<f64>,
    cand: Vec<(f64, usize)>,
    qa: Vec<Vector<NU>>,
    qb: Vec<f64>,
    qpos: Vec<usize>,
    qguess: Vec<usize>,
    qp: StepQp<NU>,
    // Iteration state.
    cost: f64,
    violation_sum: f64,
    violation_max: f64,
    merit: f64,
    mu: f64,
    dmu: f64,
    trust: f64,
    dv1: f64,
    dv2: f64,
    gradient: f64,
    active: usize,
    need_linearize: bool,
    started: bool,
    /// Augmented-Lagrangian warm-up (true) or Xie's KKT/QP iterations (false).
    al_phase: bool,
    al_rho: f64,
    al_lambda: Vec<f64>,
    al_prev_violation: f64,
    /// Accepted warm-up iterations since the last multiplier update.
    al_inner: usize,
    /// A KKT/QP iteration of this solve failed (no step accepted, or Clarabel failed) and the
    /// warm-up took over: it then runs to its own convergence instead of handing over again.
    kkt_failed: bool,
    /// No solve has reached the KKT/QP iterations since construction or [`Self::reset`]: the next
    /// start runs the warm-up even from a feasible guess (which may be far from optimal).
    cold: bool,
    iteration: usize,
    report: Report,
}

impl<const NX: usize, const NU: usize> std::fmt::Debug for SafeCddpSolver<NX, NU> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SafeCddpSolver")
            .field("settings", &self.settings)
            .field("capacity", &self.cap)
            .field("horizon", &self.n)
            .field("constraints", &self.constraints.len())
            .field("rows_per_knot", &self.m)
            .field("cost", &self.cost)
            .finish()
    }
}

/// `Q_uu + mu I` was not positive definite.
struct NotPositiveDefinite;

impl<const NX: usize, const NU: usize> SafeCddpSolver<NX, NU> {
    /// Validates `settings` and the constraints, finds the relative degree of each state-only
    /// constraint (from the dynamics of knot 0 around `x0`, unless the constraint states it), and
    /// allocates the workspace (see the type docs).
    pub fn new(
        problem: &Problem<Const<NX>, Const<NU>>,
        constraints: Vec<Arc<dyn Constraint<NX, NU>>>,
        settings: Settings,
    ) -> Result<Self> {
        settings.validate()?;
        let cap = problem.horizon();
        let max_dim = constraints.iter().map(|c| c.dim()).max().unwrap_or(0).max(1);
        let mut slots = Vec::with_capacity(constraints.len());
        let mut offset = 0;
        for (j, c) in constraints.iter().enumerate() {
            let mixed = c.depends_on_control();
            let degree = if mixed {
                0
            } else {
                relative_degree(problem, c.as_ref(), j, settings.max_relative_degree, max_dim)?
            };
            slots.push(Slot {
                offset,
                dim: c.dim(),
                mixed,
                degree,
            });
            offset += c.dim();
        }
        let bound_offset = offset;
        let m = offset + 2 * NU;
        let rows = cap * m;
        Ok(Self {
            settings,
            cap,
            n: cap,
            constraints,
            slots,
            m,
            bound_offset,
            xs: vec![Vector::zeros(); cap + 1],
            us: vec![Vector::zeros(); cap],
            xs_try: vec![Vector::zeros(); cap + 1],
            us_try: vec![Vector::zeros(); cap],
            fx: vec![Matrix::zeros(); cap],
            fu: vec![Matrix::zeros(); cap],
            l: vec![CostDerivatives::default(); cap],
            l_n: TerminalDerivatives::default(),
            q_u: vec![Vector::zeros(); cap],
            q_ux: vec![Matrix::zeros(); cap],
            q_uu_r: vec![Matrix::zeros(); cap],
            k_ff: vec![Vector::zeros(); cap],
            k_fb: vec![Matrix::zeros(); cap],
            k_prop: vec![Matrix::zeros(); cap],
            v_x: vec![Vector::zeros(); cap + 1],
            v_xx: vec![Matrix::zeros(); cap + 1],
            row_present: vec![false; rows],
            row_g: vec![0.0; rows],
            row_margin: vec![0.0; rows],
            row_c: vec![Vector::zeros(); rows],
            row_d: vec![Vector::zeros(); rows],
            row_gx: vec![Vector::zeros(); rows],
            row_gu: vec![Vector::zeros(); rows],
            row_lambda: vec![0.0; rows],
            ws: vec![0; cap * NU],
            ws_len: vec![0; cap],
            h_con: vec![Matrix::zeros(); cap + 1],
            sigma: vec![Matrix::zeros(); cap + 1],
            tightening: None,
            sg: vec![0.0; max_dim],
            sgx: vec![Vector::zeros(); max_dim],
            sgu: vec![Vector::zeros(); max_dim],
            sw: vec![0.0; max_dim],
            cand: Vec::with_capacity(m),
            qa: vec![Vector::zeros(); m],
            qb: vec![0.0; m],
            qpos: vec![usize::MAX; m],
            qguess: Vec::with_capacity(NU),
            qp: StepQp::new(m, settings.qp_method)?,
            cost: f64::NAN,
            violation_sum: 0.0,
            violation_max: 0.0,
            merit: f64::NAN,
            mu: settings.mu_init,
            dmu: 1.0,
            trust: settings.trust_region,
            dv1: 0.0,
            dv2: 0.0,
            gradient: f64::NAN,
            active: 0,
            need_linearize: true,
            started: false,
            al_phase: false,
            al_rho: settings.al_rho_init,
            al_lambda: vec![0.0; rows],
            al_prev_violation: f64::INFINITY,
            al_inner: 0,
            kkt_failed: false,
            cold: true,
            iteration: 0,
            report: Report::new(settings.max_iterations + 1),
        })
    }

    // ----------------------------------------------------------------------------------------
    // Configuration and accessors.

    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }
    /// Replaces the settings (validated; the log grows if `max_iterations` grows).
    pub fn set_settings(&mut self, settings: Settings) -> Result<()> {
        settings.validate()?;
        if settings.max_iterations + 1 > self.report.log.capacity() {
            self.report
                .log
                .reserve(settings.max_iterations + 1 - self.report.log.len());
        }
        self.qp.set_method(settings.qp_method);
        self.settings = settings;
        Ok(())
    }
    /// The tightening in use (`None`: the constraints are deterministic, plain CDDP).
    pub fn tightening(&self) -> Option<&Tightening<NX, NU>> {
        self.tightening.as_ref()
    }
    /// Sets or removes the tightening. Removing it zeroes the margins; setting it leaves them
    /// until the next [`SafeCddpSolver::tighten`].
    pub fn set_tightening(&mut self, tightening: Option<Tightening<NX, NU>>) {
        if tightening.is_none() {
            self.row_margin.iter_mut().for_each(|m| *m = 0.0);
        }
        self.tightening = tightening;
        self.started = false;
    }
    /// The constraints.
    pub fn constraints(&self) -> &[Arc<dyn Constraint<NX, NU>>] {
        &self.constraints
    }
    /// Replaces constraint `index` by one with the same `dim()`, the same kind and the same
    /// relative degree (e.g. a moving obstacle with a new prediction). Allocates nothing.
    pub fn set_constraint(&mut self, index: usize, constraint: Arc<dyn Constraint<NX, NU>>) -> Result<()> {
        let slot = *self.slots.get(index).ok_or_else(|| {
            Error::invalid(
                "index",
                format!("constraint {index} out of range ({} constraints)", self.slots.len()),
            )
        })?;
        if constraint.dim() != slot.dim || constraint.depends_on_control() != slot.mixed {
            return Err(Error::invalid(
                format!("constraints[{index}]"),
                "the replacement must have the same dim() and depends_on_control()",
            ));
        }
        if let Some(r) = constraint.relative_degree() {
            if !slot.mixed && r != slot.degree {
                return Err(Error::invalid(
                    format!("constraints[{index}]"),
                    format!(
                        "relative degree {r} differs from the replaced constraint's {}",
                        slot.degree
                    ),
                ));
            }
        }
        self.constraints[index] = constraint;
        self.need_linearize = true;
        self.started = false;
        Ok(())
    }
    /// The relative degree used for each constraint (0 for mixed constraints).
    pub fn relative_degrees(&self) -> impl Iterator<Item = usize> + '_ {
        self.slots.iter().map(|s| s.degree)
    }
    /// The horizon the workspace was allocated for.
    pub fn capacity(&self) -> usize {
        self.cap
    }
    /// The active horizon `n` (at most the capacity): solves use the first `n` knots of the
    /// problem and its terminal cost at `x_n`.
    pub fn horizon(&self) -> usize {
        self.n
    }
    /// Shortens (or restores) the active horizon, `1 <= n <= capacity` (shrinking-horizon MPC).
    pub fn set_horizon(&mut self, n: usize) -> Result<()> {
        if n == 0 || n > self.cap {
            return Err(Error::invalid(
                "horizon",
                format!("must be in 1..={} (the capacity), got {n}", self.cap),
            ));
        }
        self.n = n;
        self.need_linearize = true;
        self.started = false;
        Ok(())
    }
    /// Zeroes the initial guess, gains, multipliers (the warm-up's too, with its penalty back at
    /// [`Settings::al_rho_init`]), covariances and margins: a cold start, whose solve begins with
    /// the warm-up. Everything a solve reads is then as after [`SafeCddpSolver::new`], so solves
    /// after a reset are reproducible.
    pub fn reset(&mut self) {
        self.us.iter_mut().for_each(|u| *u = Vector::zeros());
        self.k_ff.iter_mut().for_each(|k| *k = Vector::zeros());
        self.k_fb.iter_mut().for_each(|k| *k = Matrix::zeros());
        self.k_prop.iter_mut().for_each(|k| *k = Matrix::zeros());
        self.sigma.iter_mut().for_each(|s| *s = Matrix::zeros());
        self.row_lambda.iter_mut().for_each(|l| *l = 0.0);
        self.row_margin.iter_mut().for_each(|m| *m = 0.0);
        self.ws_len.iter_mut().for_each(|w| *w = 0);
        self.al_lambda.iter_mut().for_each(|l| *l = 0.0);
        self.al_rho = self.settings.al_rho_init;
        self.cold = true;
        self.started = false;
    }
    /// Sets the initial guess (length `n`, finite).
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
        self.us[..self.n].copy_from_slice(us);
        self.started = false;
        Ok(())
    }
    /// Receding horizon: drops knot 0 of the solution (controls, states, gains, multipliers,
    /// margins) and repeats the last knot. Call [`SafeCddpSolver::set_horizon`] with `n - 1` for
    /// a shrinking horizon.
    pub fn shift(&mut self) {
        let n = self.n;
        if n > 1 {
            self.us.copy_within(1..n, 0);
            self.xs.copy_within(1..n + 1, 0);
            self.k_ff.copy_within(1..n, 0);
            self.k_fb.copy_within(1..n, 0);
            self.k_prop.copy_within(1..n, 0);
            self.ws.copy_within(NU..n * NU, 0);
            self.ws_len.copy_within(1..n, 0);
            let m = self.m;
            self.row_lambda.copy_within(m..n * m, 0);
            self.al_lambda.copy_within(m..n * m, 0);
            self.row_margin.copy_within(m..n * m, 0);
            self.xs[n] = self.xs[n - 1];
        }
        self.started = false;
        self.need_linearize = true;
    }
    /// States `x_0 .. x_n` of the current trajectory.
    pub fn xs(&self) -> &[Vector<NX>] {
        &self.xs[..=self.n]
    }
    /// Controls `u_0 .. u_{n-1}` of the current trajectory.
    pub fn us(&self) -> &[Vector<NU>] {
        &self.us[..self.n]
    }
    /// Feedback gains `K_k` of the last backward pass, eq. (12).
    pub fn gains(&self) -> &[Matrix<NU, NX>] {
        &self.k_fb[..self.n]
    }
    /// The gains `K_k` the last tightening propagated the covariance with (eq. 19): the
    /// bounds-only backward pass for [`crate::Gains::ClosedLoop`], [`SafeCddpSolver::gains`] for
    /// [`crate::Gains::ActiveSet`], zero or the fixed gain for the baselines.
    pub fn propagation_gains(&self) -> &[Matrix<NU, NX>] {
        &self.k_prop[..self.n]
    }
    /// Feed-forward terms `d_k` of the last backward pass, eq. (12).
    pub fn feedforward(&self) -> &[Vector<NU>] {
        &self.k_ff[..self.n]
    }
    /// Covariances `Sigma_0 .. Sigma_n` of the last tightening, eq. (19).
    pub fn covariances(&self) -> &[Matrix<NX, NX>] {
        &self.sigma[..=self.n]
    }
    /// Rows per knot (constraint rows, then `2 NU` control-bound sides).
    pub fn rows_per_knot(&self) -> usize {
        self.m
    }
    /// Tightening margins of the rows of knot `k`, eq. (20) (see [`SafeCddpSolver::rows_per_knot`]).
    pub fn margins(&self, k: usize) -> &[f64] {
        &self.row_margin[k * self.m..(k + 1) * self.m]
    }
    /// Multipliers `lambda` of the rows of knot `k` from the last backward pass (zero outside the
    /// working set), eq. (10).
    pub fn multipliers(&self, k: usize) -> &[f64] {
        &self.row_lambda[k * self.m..(k + 1) * self.m]
    }
    /// The state index `t` that row `row` of knot `k` constrains (`k` itself for mixed rows and
    /// control bounds), or `None` when the row is beyond the horizon.
    pub fn row_time(&self, k: usize, row: usize) -> Option<usize> {
        if row >= self.bound_offset {
            return Some(k);
        }
        let slot = self.slots.iter().find(|s| row >= s.offset && row < s.offset + s.dim)?;
        let t = k + slot.degree;
        (t <= self.n).then_some(t)
    }
    /// The report of the last solve (or of the iterations since the last
    /// [`SafeCddpSolver::start`]).
    pub fn report(&self) -> &Report {
        &self.report
    }
    /// QP counters since the last [`SafeCddpSolver::start`] (live: [`Report::qp`] is filled in
    /// only when [`SafeCddpSolver::solve`] ends).
    pub fn qp_stats(&self) -> &crate::qp::QpStats {
        self.qp.stats()
    }
    /// Current cost `J`.
    pub fn cost(&self) -> f64 {
        self.cost
    }

    fn check_problem(&self, problem: &Problem<Const<NX>, Const<NU>>) -> Result<()> {
        if problem.horizon() < self.n {
            return Err(Error::Shape {
                field: "problem.horizon".into(),
                got: problem.horizon().to_string(),
                expected: format!("at least {} (the solver's horizon)", self.n),
            });
        }
        if problem.horizon() > self.cap {
            return Err(Error::Shape {
                field: "problem.horizon".into(),
                got: problem.horizon().to_string(),
                expected: format!("at most {} (the capacity this solver was created for)", self.cap),
            });
        }
        Ok(())
    }

    // ----------------------------------------------------------------------------------------
    // Solve.

    /// Solves `problem` from the controls in the workspace: [`SafeCddpSolver::start`], then
    /// [`SafeCddpSolver::iterate`] until convergence or `max_iterations`, tightening every `n2`
    /// iterations when a [`Tightening`] is set (Algorithm 1, lines 3-26). With a tightening, a
    /// solve converges only once the margins have been updated at the final trajectory.
    ///
    /// Errors only on bad input (a horizon other than the workspace's); the outcome is
    /// [`Report::status`].
    pub fn solve(&mut self, problem: &Problem<Const<NX>, Const<NU>>) -> Result<&Report> {
        let start = Instant::now();
        self.start(problem)?;
        let mut status = Status::MaxIterations;
        if !self.cost.is_finite() {
            status = Status::NumericalError;
        } else {
            // Iterations since the last tightening; starts "overdue" so that a solve that begins
            // in the KKT/QP iterations tightens after its first iteration (Algorithm 1, line 22).
            let mut since_tightening = usize::MAX / 2;
            for _ in 0..self.settings.max_iterations {
                let outcome = self.iterate(problem)?;
                let mut tightened = false;
                let mut fresh = false;
                if let Some(t) = self.tightening {
                    since_tightening += 1;
                    if self.tightening_due(since_tightening, &t) {
                        let changed = self.tighten(problem)?;
                        tightened = changed > self.settings.constraint_tolerance;
                        fresh = true;
                        since_tightening = 0;
                    }
                }
                if let Some(last) = self.report.log.last_mut() {
                    last.tightened = tightened;
                }
                match outcome {
                    IterationOutcome::Failed(s) => {
                        status = s;
                        break;
                    }
                    IterationOutcome::Converged | IterationOutcome::Accepted { converged: true, .. } => {
                        if self.tightening.is_none() || (fresh && !tightened) {
                            status = Status::Converged;
                            break;
                        }
                        if !fresh {
                            // Converged with margins of an older trajectory: refresh them now.
                            let changed = self.tighten(problem)?;
                            since_tightening = 0;
                            if changed <= self.settings.constraint_tolerance {
                                status = Status::Converged;
                                break;
                            }
                        }
                    }
                    _ => {}
                }
            }
        }
        self.finish(problem, status);
        self.report.solve_time = start.elapsed();
        Ok(&self.report)
    }

    /// Whether Algorithm 1 tightens now, `since` iterations after the last tightening: every
    /// `n2` iterations of the KKT/QP phase. Not during the warm-up: its inner solves are inexact
    /// and its trajectory drifts while the multipliers settle, so margins computed there move the
    /// target of every inner solve and the warm-up never hands over (the paper likewise solves
    /// the deterministic problem first and tightens "afterward", §III-D). A warm-up that hands
    /// over with `since >= n2` tightens at once.
    pub fn tightening_due(&self, since: usize, tightening: &Tightening<NX, NU>) -> bool {
        !self.al_phase && since >= tightening.update_every()
    }

    /// Whether the solver is in its augmented-Lagrangian warm-up ([`Settings::al_warm_start`])
    /// rather than in the KKT/QP iterations of Xie et al.
    pub fn in_warm_up(&self) -> bool {
        self.al_phase
    }

    /// Starts a solve: projects the controls onto the bounds, rolls them out from `x0`, evaluates
    /// the cost and the violation, and clears the report. Called by [`SafeCddpSolver::solve`];
    /// call it before driving [`SafeCddpSolver::iterate`] by hand (the MPC does).
    pub fn start(&mut self, problem: &Problem<Const<NX>, Const<NU>>) -> Result<()> {
        self.check_problem(problem)?;
        let r = &mut self.report;
        r.log.clear();
        r.iterations = 0;
        r.backward_passes = 0;
        r.forward_passes = 0;
        r.infeasible_forward_passes = 0;
        r.tightenings = 0;
        r.status = Status::MaxIterations;
        self.qp.reset_stats();
        let n = self.n;
        if let Some(b) = problem.bounds() {
            self.us[..n].iter_mut().for_each(|u| *u = b.clamp(u));
        }
        self.xs[0] = *problem.x0();
        let mut cost = 0.0;
        for (k, knot) in problem.knots()[..n].iter().enumerate() {
            cost += knot.cost.value(&self.xs[k], &self.us[k]);
            self.xs[k + 1] = knot.dynamics.step(&self.xs[k], &self.us[k]);
        }
        cost += problem.terminal().value(&self.xs[n]);
        self.cost = cost;
        // The warm-up runs after a cold start and whenever the initial trajectory violates a row;
        // a warm start that is already feasible (an MPC step, a re-solve) goes straight to the
        // KKT/QP iterations. Multipliers and penalty carry over from the previous solve (see
        // `reset`), so a warm start does not first drift into the obstacles under a weak penalty.
        self.al_phase = false;
        let (_, max) = self.violation(false);
        self.al_phase = self.settings.al_warm_start
            && self.bound_offset > 0
            && (self.cold || max > self.settings.al_switch_violation);
        self.al_rho = self.al_rho.max(self.settings.al_rho_init);
        self.al_prev_violation = f64::INFINITY;
        self.al_inner = 0;
        self.kkt_failed = false;
        let (sum, max) = self.violation(false);
        self.violation_sum = sum;
        self.violation_max = max;
        self.merit = cost + sum;
        self.mu = self.settings.mu_init;
        self.dmu = 1.0;
        self.trust = self.settings.trust_region;
        self.gradient = f64::NAN;
        self.need_linearize = true;
        self.started = true;
        self.iteration = 0;
        self.report.initial_cost = cost;
        self.report.log.push(IterationLog {
            iteration: 0,
            cost,
            violation: max,
            gradient: f64::NAN,
            step: 0.0,
            mu: self.mu,
            active: 0,
            accepted: true,
            tightened: false,
            warm_up: self.al_phase,
        });
        Ok(())
    }

    /// One iteration: linearise (if the trajectory changed), backward pass (raising `mu` until
    /// `Q_uu` is positive definite), forward pass with the per-step QPs and a line search.
    /// Requires [`SafeCddpSolver::start`] first (it is called automatically when needed).
    pub fn iterate(&mut self, problem: &Problem<Const<NX>, Const<NU>>) -> Result<IterationOutcome> {
        if !self.started {
            self.start(problem)?;
        }
        self.check_problem(problem)?;
        if !self.cost.is_finite() {
            return Ok(IterationOutcome::Failed(Status::NumericalError));
        }
        let s = self.settings;
        self.iteration += 1;
        let iteration = self.iteration;
        if self.need_linearize {
            self.linearize_now(problem);
        }
        loop {
            self.report.backward_passes += 1;
            match self.backward_pass(problem, self.mu) {
                Ok(()) => break,
                Err(NotPositiveDefinite) => {
                    if !self.raise_mu() {
                        return Ok(IterationOutcome::Failed(Status::RegularizationLimit));
                    }
                }
            }
        }
        if self.al_phase && self.gradient < s.gradient_tolerance {
            // The inner problem is solved: update the multipliers.
            self.log(iteration, 0.0, false);
            if self.update_multipliers(problem, true) {
                return Ok(IterationOutcome::Converged);
            }
            return Ok(IterationOutcome::Accepted {
                step: 0.0,
                converged: false,
            });
        }
        if self.gradient < s.gradient_tolerance && self.violation_max <= s.constraint_tolerance {
            self.log(iteration, 0.0, false);
            return Ok(IterationOutcome::Converged);
        }
        let mut alpha = 1.0;
        let mut retries = 0;
        let mut elastic = false;
        let mut failure: Option<Status> = None;
        let mut accepted: Option<(f64, f64)> = None;
        while alpha >= s.step_min {
            self.report.forward_passes += 1;
            match self.forward_pass(problem, alpha, elastic) {
                Forward::Done { merit, cost } => {
                    let expected = -(alpha * self.dv1 + alpha * alpha * self.dv2);
                    let actual = self.merit - merit;
                    let small = actual.abs() <= s.cost_tolerance * (1.0 + self.cost.abs());
                    let ok = merit.is_finite()
                        && ((expected > 0.0 && actual >= s.armijo * expected)
                            || (expected <= 0.0 && actual >= 0.0)
                            || (small && self.violation_max_try() <= self.violation_max.max(s.constraint_tolerance)));
                    if ok {
                        accepted = Some((merit, cost));
                        break;
                    }
                    alpha *= s.step_factor;
                }
                Forward::Infeasible { knot, max_du } => {
                    self.report.infeasible_forward_passes += 1;
                    failure = Some(Status::Infeasible { knot });
                    retries += 1;
                    if retries > s.max_qp_retries {
                        if s.elastic {
                            // Relax the rows of infeasible QPs from now on; the merit decides.
                            elastic = true;
                            self.trust = s.trust_region;
                            continue;
                        }
                        break;
                    }
                    // A diminishing trust region (and step) keeps the new trajectory closer to the
                    // nominal one, whose linearisation the QPs use.
                    self.trust = (s.trust_shrink * max_du).min(self.trust).max(1e-12);
                    alpha *= s.step_factor;
                }
                Forward::Failed { knot } => {
                    failure = Some(Status::QpFailed { knot });
                    break;
                }
            }
        }
        match accepted {
            Some((merit, cost)) => {
                let change = self.merit - merit;
                std::mem::swap(&mut self.xs, &mut self.xs_try);
                std::mem::swap(&mut self.us, &mut self.us_try);
                self.cost = cost;
                self.merit = merit;
                let (sum, max) = self.violation(false);
                self.violation_sum = sum;
                self.violation_max = max;
                self.need_linearize = true;
                self.report.iterations += 1;
                self.log(iteration, alpha, true);
                // Tassa's schedule: lower mu after a success; let the trust region grow back.
                self.dmu = f64::min(self.dmu / s.mu_factor, 1.0 / s.mu_factor);
                self.mu = if self.mu * self.dmu > s.mu_min {
                    self.mu * self.dmu
                } else {
                    0.0
                };
                self.trust = (self.trust / s.trust_shrink).min(s.trust_region);
                if self.al_phase {
                    self.al_inner += 1;
                    let inner_done = change.abs() < s.al_inner_tolerance * (1.0 + self.merit.abs());
                    let converged = (inner_done || self.al_inner >= s.al_inner_iterations)
                        && self.update_multipliers(problem, inner_done);
                    return Ok(IterationOutcome::Accepted { step: alpha, converged });
                }
                let converged = change.abs() < s.cost_tolerance * (1.0 + self.cost.abs())
                    && self.violation_max <= s.constraint_tolerance;
                Ok(IterationOutcome::Accepted { step: alpha, converged })
            }
            None => {
                self.log(iteration, 0.0, false);
                if self.al_phase {
                    if self.update_multipliers(problem, true) {
                        return Ok(IterationOutcome::Converged);
                    }
                } else if s.al_warm_start && self.bound_offset > 0 {
                    // The KKT/QP step failed: typically a constraint row that the backward pass
                    // left out (pruned, or dependent on a control bound at a tangency) binds in
                    // a forward QP, whose control can move a relative-degree-r row only by
                    // O(dt^r), so the QP answers with a huge du. The warm-up's smooth penalty
                    // model has no such jumps: it takes over from here, with the multipliers
                    // of this backward pass, and runs to its own convergence.
                    self.enter_warm_up();
                    self.kkt_failed = true;
                    return Ok(IterationOutcome::Rejected);
                }
                if let Some(Status::QpFailed { knot }) = failure {
                    return Ok(IterationOutcome::Failed(Status::QpFailed { knot }));
                }
                if !self.raise_mu() {
                    return Ok(IterationOutcome::Failed(failure.unwrap_or(Status::LineSearchFailed)));
                }
                self.trust = s.trust_region;
                Ok(IterationOutcome::Rejected)
            }
        }
    }

    /// Constraint tightening (Algorithm 1, lines 23-26): linearises at the current trajectory,
    /// propagates the covariance with eq. (19) and sets every row's margin by eq. (20). Returns
    /// the largest change of a margin. Does nothing (returns 0) without a [`Tightening`].
    pub fn tighten(&mut self, problem: &Problem<Const<NX>, Const<NU>>) -> Result<f64> {
        self.check_problem(problem)?;
        let Some(t) = self.tightening else {
            return Ok(0.0);
        };
        if self.need_linearize {
            self.linearize_now(problem);
        }
        let n = self.n;
        match t.gains() {
            Gains::ClosedLoop => self.bounds_only_gains(problem),
            Gains::ActiveSet => self.k_prop[..n].copy_from_slice(&self.k_fb[..n]),
            Gains::OpenLoop => self.k_prop[..n].iter_mut().for_each(|k| *k = Matrix::zeros()),
            Gains::Fixed(g) => self.k_prop[..n].iter_mut().for_each(|k| *k = *g),
        }
        propagate_covariance(
            &self.fx[..n],
            &self.fu[..n],
            &Gains::ClosedLoop,
            &self.k_prop[..n],
            t.sigma_0(),
            t.sigma_w(),
            &mut self.sigma[..=n],
        );
        let z = t.quantile();
        let zero_u = Vector::<NU>::zeros();
        let mut change = 0.0f64;
        for k in 0..n {
            let gain = self.k_prop[k];
            for (j, slot) in self.slots.iter().enumerate() {
                let t_row = if slot.mixed { k } else { k + slot.degree };
                let base = k * self.m + slot.offset;
                if t_row > n || slot.dim == 0 {
                    continue;
                }
                let (x, u) = if slot.mixed {
                    (&self.xs[k], &self.us[k])
                } else {
                    (&self.xs[t_row], &zero_u)
                };
                self.constraints[j].parameter_variance(t_row, x, u, &mut self.sw[..slot.dim]);
                for r in 0..slot.dim {
                    let i = base + r;
                    let grad = if slot.mixed {
                        self.row_gx[i] + gain.transpose() * self.row_gu[i]
                    } else {
                        self.row_gx[i]
                    };
                    let new = margin(z, &grad, &self.sigma[t_row], self.sw[r]);
                    change = change.max((new - self.row_margin[i]).abs());
                    self.row_margin[i] = new;
                }
            }
        }
        self.report.tightenings += 1;
        // The merit and violation refer to the new margins from now on. If the new margins make
        // the trajectory infeasible, the warm-up restores feasibility (the per-step QPs cannot
        // move a state constraint far), starting from the current multipliers.
        let (_, max) = self.violation(false);
        if !self.al_phase && self.settings.al_warm_start && max > self.settings.al_switch_violation {
            self.enter_warm_up();
        }
        let (sum, max) = self.violation(false);
        self.violation_sum = sum;
        self.violation_max = max;
        self.merit = self.cost + sum;
        Ok(change)
    }

    /// Phase 1, exposed for benchmarks and custom loops: derivatives of dynamics, costs and
    /// constraint rows along the current trajectory.
    pub fn linearize(&mut self, problem: &Problem<Const<NX>, Const<NU>>) -> Result<()> {
        self.check_problem(problem)?;
        if !self.started {
            self.start(problem)?;
        }
        self.linearize_now(problem);
        Ok(())
    }

    /// Phase 2: the constrained backward pass with regularisation `mu`; `Ok(false)` when `Q_uu`
    /// was not positive definite at some knot.
    pub fn backward(&mut self, problem: &Problem<Const<NX>, Const<NU>>, mu: f64) -> Result<bool> {
        self.check_problem(problem)?;
        Ok(self.backward_pass(problem, mu).is_ok())
    }

    /// Phase 3: the forward pass with step `alpha` (into scratch buffers, leaving the trajectory
    /// unchanged). Returns the merit of the trial, or the status of the knot whose QP failed.
    pub fn forward(&mut self, problem: &Problem<Const<NX>, Const<NU>>, alpha: f64) -> Result<std::result::Result<f64, Status>> {
        self.check_problem(problem)?;
        Ok(match self.forward_pass(problem, alpha, false) {
            Forward::Done { merit, .. } => Ok(merit),
            Forward::Infeasible { knot, .. } => Err(Status::Infeasible { knot }),
            Forward::Failed { knot } => Err(Status::QpFailed { knot }),
        })
    }

    // ----------------------------------------------------------------------------------------
    // Internals.

    fn raise_mu(&mut self) -> bool {
        let s = &self.settings;
        self.dmu = f64::max(s.mu_factor, self.dmu * s.mu_factor);
        self.mu = f64::max(s.mu_min, self.mu * self.dmu);
        self.mu <= s.mu_max
    }

    fn log(&mut self, iteration: usize, step: f64, accepted: bool) {
        if self.report.log.len() < self.report.log.capacity() {
            self.report.log.push(IterationLog {
                iteration,
                cost: self.cost,
                violation: self.violation_max,
                gradient: self.gradient,
                step,
                mu: self.mu,
                active: self.active,
                accepted,
                tightened: false,
                warm_up: self.al_phase,
            });
        }
    }

    fn finish(&mut self, problem: &Problem<Const<NX>, Const<NU>>, mut status: Status) {
        if self.violation_max > self.settings.constraint_tolerance
            && matches!(status, Status::Converged | Status::MaxIterations)
        {
            status = Status::Infeasible {
                knot: self.first_violating_knot(),
            };
        }
        let original = self.original_violation(problem);
        let r = &mut self.report;
        r.status = status;
        r.cost = self.cost;
        r.gradient = self.gradient;
        r.mu = self.mu;
        r.max_violation = original;
        r.max_violation_tightened = self.violation_max;
        r.qp = *self.qp.stats();
    }

    /// Largest violation of the original constraints over `x_1 .. x_n` (state rows) and
    /// `(x_k, u_k)` (mixed rows), regardless of the relative degree.
    fn original_violation(&mut self, _problem: &Problem<Const<NX>, Const<NU>>) -> f64 {
        let n = self.n;
        let zero_u = Vector::<NU>::zeros();
        let mut worst = 0.0f64;
        for (j, slot) in self.slots.iter().enumerate() {
            let c = &self.constraints[j];
            let g = &mut self.sg[..slot.dim];
            if slot.mixed {
                for k in 0..n {
                    c.evaluate(k, &self.xs[k], &self.us[k], g);
                    worst = g.iter().fold(worst, |w, &v| w.max(v));
                }
            } else {
                for t in 1..=n {
                    c.evaluate(t, &self.xs[t], &zero_u, g);
                    worst = g.iter().fold(worst, |w, &v| w.max(v));
                }
            }
        }
        worst
    }

    fn first_violating_knot(&self) -> usize {
        let n = self.n;
        let tol = self.settings.constraint_tolerance;
        for k in 0..n {
            for i in 0..self.bound_offset {
                let idx = k * self.m + i;
                if self.row_present[idx] && self.row_g[idx] + self.row_margin[idx] > tol {
                    return k;
                }
            }
        }
        0
    }

    fn violation_max_try(&mut self) -> f64 {
        self.violation(true).1
    }

    /// The merit term of the constraint rows (the control bounds hold by projection) and the
    /// largest violation of a tightened row, for the current (`trial = false`) or trial
    /// trajectory. The term is `rho sum max(0, g~)` in the KKT phase and the augmented-Lagrangian
    /// sum `sum (max(0, lambda + rho_al g~)^2 - lambda^2) / (2 rho_al)` in the warm-up.
    fn violation(&mut self, trial: bool) -> (f64, f64) {
        let n = self.n;
        let (xs, us) = if trial {
            (&self.xs_try, &self.us_try)
        } else {
            (&self.xs, &self.us)
        };
        let zero_u = Vector::<NU>::zeros();
        let (mut sum, mut al, mut max) = (0.0, 0.0, 0.0f64);
        let rho = self.al_rho;
        for k in 0..n {
            for (j, slot) in self.slots.iter().enumerate() {
                if slot.dim == 0 {
                    continue;
                }
                let t = if slot.mixed { k } else { k + slot.degree };
                if t > n {
                    continue;
                }
                let g = &mut self.sg[..slot.dim];
                if slot.mixed {
                    self.constraints[j].evaluate(t, &xs[k], &us[k], g);
                } else {
                    self.constraints[j].evaluate(t, &xs[t], &zero_u, g);
                }
                let base = k * self.m + slot.offset;
                for r in 0..slot.dim {
                    let v = g[r] + self.row_margin[base + r];
                    if v > 0.0 {
                        sum += v;
                        max = max.max(v);
                    }
                    if self.al_phase {
                        let lam = self.al_lambda[base + r];
                        let nu = (lam + rho * v).max(0.0);
                        al += (nu * nu - lam * lam) / (2.0 * rho);
                    }
                }
            }
        }
        let term = if self.al_phase {
            al
        } else {
            self.settings.merit_penalty * sum
        };
        (term, max)
    }

    /// First-order multiplier update of the warm-up, `lambda <- max(0, lambda + rho g~)`, and the
    /// penalty update; switches to the KKT phase once the violation is small.
    /// The gains of [`Gains::ClosedLoop`] into `k_prop`: a Gauss-Newton Riccati recursion of the
    /// cost alone (no constraint rows, no warm-up penalty) along the current linearisation, with
    /// the controls that sit at a bound clamped (zero rows of `K`, as in box-DDP). Evaluates the
    /// cost derivatives again (the workspace's may hold the warm-up's penalty terms).
    fn bounds_only_gains(&mut self, problem: &Problem<Const<NX>, Const<NU>>) {
        let n = self.n;
        let mut terminal = TerminalDerivatives::<Const<NX>>::default();
        problem.terminal().add_derivatives(&self.xs[n], 1.0, &mut terminal);
        let mut v_xx = terminal.lxx;
        let bounds = problem.bounds();
        for k in (0..n).rev() {
            let knot = &problem.knots()[k];
            let mut l = CostDerivatives::<Const<NX>, Const<NU>>::default();
            knot.cost.add_derivatives(&self.xs[k], &self.us[k], 1.0, &mut l);
            let (fx, fu) = (&self.fx[k], &self.fu[k]);
            let v_fx = v_xx * fx;
            let q_xx = l.lxx + fx.tr_mul(&v_fx);
            let mut q_uu = l.luu + fu.tr_mul(&(v_xx * fu));
            let mut q_ux = l.lux + fu.tr_mul(&v_fx);
            q_uu = 0.5 * (q_uu + q_uu.transpose());
            let q_uu_full = q_uu;
            let q_ux_full = q_ux;
            if let Some(b) = bounds {
                let u = &self.us[k];
                for i in 0..NU {
                    let tol = 1e-9 * (1.0 + u[i].abs());
                    if u[i] >= b.upper[i] - tol || u[i] <= b.lower[i] + tol {
                        // Clamped: no feedback through this control.
                        for j in 0..NU {
                            q_uu[(i, j)] = 0.0;
                            q_uu[(j, i)] = 0.0;
                        }
                        q_uu[(i, i)] = 1.0;
                        q_ux.set_row(i, &Vector::<NX>::zeros().transpose());
                    }
                }
            }
            let mut reg = 0.0;
            let gain = loop {
                let mut h = q_uu;
                for i in 0..NU {
                    h[(i, i)] += reg;
                }
                if let Some(c) = h.cholesky() {
                    break -c.solve(&q_ux);
                }
                reg = if reg == 0.0 {
                    1e-9 * (1.0 + q_uu.amax())
                } else {
                    reg * 10.0
                };
                if !reg.is_finite() || reg > 1e12 * (1.0 + q_uu.amax()) {
                    break Matrix::<NU, NX>::zeros();
                }
            };
            let kt_quu = gain.transpose() * q_uu_full;
            let v = q_xx + kt_quu * gain + gain.tr_mul(&q_ux_full) + q_ux_full.tr_mul(&gain);
            v_xx = 0.5 * (v + v.transpose());
            self.k_prop[k] = gain;
        }
    }

    /// (Re-)enters the warm-up from the KKT/QP iterations, with their multipliers as the first
    /// estimate and a moderate penalty (a penalty left at `al_rho_max` makes the inner problems
    /// stiff, and good multipliers do not need it).
    fn enter_warm_up(&mut self) {
        let s = &self.settings;
        self.al_phase = true;
        self.al_prev_violation = f64::INFINITY;
        self.al_inner = 0;
        self.al_rho = self
            .al_rho
            .clamp(s.al_rho_init, s.al_rho_init * s.al_rho_factor * s.al_rho_factor);
        self.al_lambda.copy_from_slice(&self.row_lambda);
        self.mu = s.mu_init;
        self.dmu = 1.0;
        self.trust = s.trust_region;
        self.need_linearize = true;
        let (sum, max) = self.violation(false);
        self.violation_sum = sum;
        self.violation_max = max;
        self.merit = self.cost + sum;
    }

    /// First-order multiplier update of the warm-up, `lambda <- max(0, lambda + rho g~)`, and the
    /// penalty update; switches to the KKT phase once the violation is small. `inner_done`: the
    /// inner solve converged (rather than hitting `al_inner_iterations`). Returns whether the
    /// warm-up itself has converged, which counts only after a failed KKT/QP iteration in this
    /// solve: the inner solve converged on a trajectory within `constraint_tolerance`.
    fn update_multipliers(&mut self, problem: &Problem<Const<NX>, Const<NU>>, inner_done: bool) -> bool {
        if self.need_linearize {
            self.linearize_now(problem);
        }
        let converged = self.kkt_failed && inner_done && self.violation_max <= self.settings.constraint_tolerance;
        self.al_inner = 0;
        let previous_max = self.al_prev_violation;
        self.al_prev_violation = self.violation_max;
        let rho = self.al_rho;
        let n = self.n;
        for k in 0..n {
            for i in 0..self.bound_offset {
                let idx = k * self.m + i;
                if self.row_present[idx] {
                    let v = self.row_g[idx] + self.row_margin[idx];
                    self.al_lambda[idx] = (self.al_lambda[idx] + rho * v).max(0.0);
                } else {
                    self.al_lambda[idx] = 0.0;
                }
            }
        }
        if self.violation_max > 0.25 * previous_max {
            self.al_rho = (self.al_rho * self.settings.al_rho_factor).min(self.settings.al_rho_max);
        }
        if self.violation_max <= self.settings.al_switch_violation && !self.kkt_failed {
            // Hand over to Xie's method with the multipliers as the first estimate.
            self.al_phase = false;
            self.cold = false;
            self.row_lambda.copy_from_slice(&self.al_lambda);
            self.mu = self.settings.mu_init;
            self.dmu = 1.0;
        }
        let (term, max) = self.violation(false);
        self.violation_sum = term;
        self.violation_max = max;
        self.merit = self.cost + term;
        self.need_linearize = true;
        converged
    }

    fn linearize_now(&mut self, problem: &Problem<Const<NX>, Const<NU>>) {
        let n = self.n;
        let knots = &problem.knots()[..n];
        for (k, knot) in knots.iter().enumerate() {
            let (x, u) = (&self.xs[k], &self.us[k]);
            knot.dynamics.jacobians(x, u, &mut self.fx[k], &mut self.fu[k]);
            let l = &mut self.l[k];
            l.clear();
            knot.cost.add_derivatives(x, u, 1.0, l);
        }
        self.l_n.clear();
        problem.terminal().add_derivatives(&self.xs[n], 1.0, &mut self.l_n);

        let zero_u = Vector::<NU>::zeros();
        let m = self.m;
        let hessian = self.settings.constraint_hessian && !self.al_phase;
        if hessian {
            self.h_con[..=n].iter_mut().for_each(|h| *h = Matrix::zeros());
        }
        for k in 0..n {
            for (j, slot) in self.slots.iter().enumerate() {
                let base = k * m + slot.offset;
                let d = slot.dim;
                let c = &self.constraints[j];
                let t = if slot.mixed { k } else { k + slot.degree };
                if t > n {
                    self.row_present[base..base + d].iter_mut().for_each(|p| *p = false);
                    self.row_lambda[base..base + d].iter_mut().for_each(|p| *p = 0.0);
                    continue;
                }
                let (x, u) = if slot.mixed {
                    (&self.xs[k], &self.us[k])
                } else {
                    (&self.xs[t], &zero_u)
                };
                c.jacobians(t, x, u, &mut self.sg[..d], &mut self.sgx[..d], &mut self.sgu[..d]);
                let mut any_lambda = false;
                for r in 0..d {
                    let i = base + r;
                    self.row_present[i] = true;
                    self.row_g[i] = self.sg[r];
                    self.row_gx[i] = self.sgx[r];
                    self.row_gu[i] = self.sgu[r];
                    if slot.mixed {
                        self.row_c[i] = self.sgu[r];
                        self.row_d[i] = self.sgx[r];
                    } else {
                        // g(x_t) with x_t = f(..f(x_k, u_k)..): chain the Jacobians back to knot k.
                        let mut w = self.sgx[r];
                        for s in (k + 1..t).rev() {
                            w = self.fx[s].tr_mul(&w);
                        }
                        self.row_c[i] = self.fu[k].tr_mul(&w);
                        self.row_d[i] = self.fx[k].tr_mul(&w);
                    }
                    self.sw[r] = self.row_lambda[i];
                    any_lambda |= self.row_lambda[i] > 0.0;
                }
                if hessian && any_lambda {
                    c.add_hessian(t, x, u, &self.sw[..d], &mut self.h_con[t]);
                }
            }
            // Control bounds: u_i - hi_i <= 0 and lo_i - u_i <= 0.
            for i in 0..NU {
                let (up, lo) = (k * m + self.bound_offset + 2 * i, k * m + self.bound_offset + 2 * i + 1);
                let (hi_v, lo_v) = match problem.bounds() {
                    Some(b) => (b.upper[i], b.lower[i]),
                    None => (f64::INFINITY, f64::NEG_INFINITY),
                };
                let mut e = Vector::<NU>::zeros();
                e[i] = 1.0;
                self.row_present[up] = hi_v.is_finite();
                self.row_g[up] = self.us[k][i] - hi_v;
                self.row_c[up] = e;
                self.row_gu[up] = e;
                self.row_d[up] = Vector::zeros();
                self.row_gx[up] = Vector::zeros();
                self.row_present[lo] = lo_v.is_finite();
                self.row_g[lo] = lo_v - self.us[k][i];
                self.row_c[lo] = -e;
                self.row_gu[lo] = -e;
                self.row_d[lo] = Vector::zeros();
                self.row_gx[lo] = Vector::zeros();
            }
        }
        if self.al_phase {
            self.add_al_derivatives(problem);
        }
        self.need_linearize = false;
    }

    /// Adds the warm-up's augmented-Lagrangian terms of every constraint row to the cost
    /// derivatives at the row's own time (state rows at `x_t`, mixed rows at `(x_k, u_k)`).
    fn add_al_derivatives(&mut self, _problem: &Problem<Const<NX>, Const<NU>>) {
        let n = self.n;
        let rho = self.al_rho;
        let zero_u = Vector::<NU>::zeros();
        for k in 0..n {
            for (j, slot) in self.slots.iter().enumerate() {
                let t = if slot.mixed { k } else { k + slot.degree };
                if t > n || slot.dim == 0 {
                    continue;
                }
                let base = k * self.m + slot.offset;
                let mut any = false;
                for r in 0..slot.dim {
                    let i = base + r;
                    let v = self.row_g[i] + self.row_margin[i];
                    let nu = (self.al_lambda[i] + rho * v).max(0.0);
                    self.sw[r] = nu;
                    if nu <= 0.0 {
                        continue;
                    }
                    any = true;
                    let (gx, gu) = (self.row_gx[i], self.row_gu[i]);
                    if slot.mixed {
                        let l = &mut self.l[k];
                        l.lx.axpy(nu, &gx, 1.0);
                        l.lu.axpy(nu, &gu, 1.0);
                        l.lxx += rho * gx * gx.transpose();
                        l.luu += rho * gu * gu.transpose();
                        l.lux += rho * gu * gx.transpose();
                    } else if t == n {
                        self.l_n.lx.axpy(nu, &gx, 1.0);
                        self.l_n.lxx += rho * gx * gx.transpose();
                    } else {
                        let l = &mut self.l[t];
                        l.lx.axpy(nu, &gx, 1.0);
                        l.lxx += rho * gx * gx.transpose();
                    }
                }
                if any && self.settings.constraint_hessian {
                    let (x, u) = if slot.mixed {
                        (&self.xs[k], &self.us[k])
                    } else {
                        (&self.xs[t], &zero_u)
                    };
                    let target = if slot.mixed || t < n {
                        &mut self.l[t.min(n - 1)].lxx
                    } else {
                        &mut self.l_n.lxx
                    };
                    self.constraints[j].add_hessian(t, x, u, &self.sw[..slot.dim], target);
                }
            }
        }
    }

    fn backward_pass(&mut self, problem: &Problem<Const<NX>, Const<NU>>, mu: f64) -> std::result::Result<(), NotPositiveDefinite> {
        let n = self.n;
        let m = self.m;
        let ddp = self.settings.method == Method::Ddp;
        let hessian = self.settings.constraint_hessian && !self.al_phase;
        let eps = self.settings.active_threshold;
        let first_row = if self.al_phase { self.bound_offset } else { 0 };
        self.v_x[n] = self.l_n.lx;
        self.v_xx[n] = self.l_n.lxx;
        if hessian {
            self.v_xx[n] += self.h_con[n];
        }
        self.dv1 = 0.0;
        self.dv2 = 0.0;
        self.gradient = 0.0;
        self.active = 0;
        for k in (0..n).rev() {
            let (fx, fu, l) = (&self.fx[k], &self.fu[k], &self.l[k]);
            let v_x = &self.v_x[k + 1];
            let v_xx = &self.v_xx[k + 1];
            let q_x = l.lx + fx.tr_mul(v_x);
            let q_u = l.lu + fu.tr_mul(v_x);
            let v_xx_fx = v_xx * fx;
            let v_xx_fu = v_xx * fu;
            let mut q_xx = l.lxx + fx.tr_mul(&v_xx_fx);
            let mut q_uu = l.luu + fu.tr_mul(&v_xx_fu);
            let mut q_ux = l.lux + fu.tr_mul(&v_xx_fx);
            if ddp {
                let knot = &problem.knots()[k];
                if knot.dynamics.has_second_order() {
                    knot.dynamics
                        .add_second_order(&self.xs[k], &self.us[k], v_x, &mut q_xx, &mut q_ux, &mut q_uu);
                }
            }
            if hessian && k > 0 {
                q_xx += self.h_con[k];
            }
            let mut q_uu_r = q_uu;
            for i in 0..NU {
                q_uu_r[(i, i)] += mu;
            }
            q_uu_r = 0.5 * (q_uu_r + q_uu_r.transpose());
            let chol = q_uu_r.cholesky().ok_or(NotPositiveDefinite)?;
            let qi_qu = chol.solve(&q_u);
            let qi_qux = chol.solve(&q_ux);

            // Active set (g~ > -eps), most active first.
            let base = k * m;
            self.cand.clear();
            for i in 0..m {
                let idx = base + i;
                if i >= first_row && self.row_present[idx] {
                    let g = self.row_g[idx] + self.row_margin[idx];
                    if g > -eps {
                        self.cand.push((g, i));
                    }
                }
                self.row_lambda[idx] = 0.0;
            }
            self.cand.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));

            // Working set: at most NU rows, independent in the Q_uu^{-1} metric.
            let mut cw = Matrix::<NU, NU>::zeros(); // rows C_w^T
            let mut dw = Matrix::<NU, NX>::zeros(); // rows D_w^T
            let mut hw = Matrix::<NU, NU>::zeros(); // columns Q_uu^{-1} C_w
            let mut rows = [usize::MAX; NU];
            let mut mw = 0;
            for c in 0..self.cand.len() {
                if mw == NU {
                    break;
                }
                let i = self.cand[c].1;
                let ci = self.row_c[base + i];
                let hci = chol.solve(&ci);
                let norm = ci.dot(&hci);
                if norm.is_nan() || norm <= 1e-14 * (1.0 + q_uu_r.amax().recip()) {
                    continue; // the controls of this knot cannot move this row
                }
                // Residual of ci after projecting out the current working rows (Q_uu^{-1} metric).
                cw.set_row(mw, &ci.transpose());
                hw.set_column(mw, &hci);
                if schur_ok(&cw, &hw, mw + 1) {
                    dw.set_row(mw, &self.row_d[base + i].transpose());
                    rows[mw] = i;
                    mw += 1;
                } else {
                    cw.set_row(mw, &Vector::<NU>::zeros().transpose());
                    hw.set_column(mw, &Vector::<NU>::zeros());
                }
            }
            // KKT solution (10)-(12), pruning negative multipliers one at a time.
            let (k_ff, k_fb, lambda) = loop {
                let mut s = cw * hw;
                for r in mw..NU {
                    s[(r, r)] = 1.0;
                }
                let s_chol = s.cholesky().ok_or(NotPositiveDefinite)?;
                let lambda = -s_chol.solve(&(cw * qi_qu));
                let mut worst = (usize::MAX, 0.0);
                for r in 0..mw {
                    if lambda[r] < worst.1 {
                        worst = (r, lambda[r]);
                    }
                }
                if worst.0 == usize::MAX {
                    let big_lambda = s_chol.solve(&(dw - cw * qi_qux));
                    let k_ff = -qi_qu - hw * lambda;
                    let k_fb = -qi_qux - hw * big_lambda;
                    break (k_ff, k_fb, lambda);
                }
                // Remove row worst.0 by moving the last working row into its place.
                let r = worst.0;
                let last = mw - 1;
                if r != last {
                    cw.swap_rows(r, last);
                    dw.swap_rows(r, last);
                    hw.swap_columns(r, last);
                    rows.swap(r, last);
                }
                cw.set_row(last, &Vector::<NU>::zeros().transpose());
                dw.set_row(last, &Vector::<NX>::zeros().transpose());
                hw.set_column(last, &Vector::<NU>::zeros());
                rows[last] = usize::MAX;
                mw -= 1;
            };
            for r in 0..mw {
                self.row_lambda[base + rows[r]] = lambda[r];
                self.ws[k * NU + r] = rows[r];
            }
            self.ws_len[k] = mw;
            self.active += mw;

            let proj = q_u + cw.tr_mul(&lambda);
            self.gradient += proj.norm_squared();
            self.dv1 += k_ff.dot(&q_u);
            self.dv2 += 0.5 * k_ff.dot(&(q_uu * k_ff));
            // Eq. (14), valid for any affine policy du = K dx + d.
            let kt_quu = k_fb.transpose() * q_uu;
            self.v_x[k] = q_x + kt_quu * k_ff + k_fb.tr_mul(&q_u) + q_ux.tr_mul(&k_ff);
            let v = q_xx + kt_quu * k_fb + k_fb.tr_mul(&q_ux) + q_ux.tr_mul(&k_fb);
            self.v_xx[k] = 0.5 * (v + v.transpose());
            self.k_ff[k] = k_ff;
            self.k_fb[k] = k_fb;
            self.q_u[k] = q_u;
            self.q_ux[k] = q_ux;
            self.q_uu_r[k] = q_uu_r;
        }
        Ok(())
    }

    fn forward_pass(&mut self, problem: &Problem<Const<NX>, Const<NU>>, alpha: f64, elastic: bool) -> Forward {
        let n = self.n;
        let m = self.m;
        let bounds = problem.bounds();
        let mut cost = 0.0;
        let mut max_du = 0.0f64;
        self.xs_try[0] = *problem.x0();
        for (k, knot) in problem.knots()[..n].iter().enumerate() {
            let x = self.xs_try[k];
            let dx = x - self.xs[k];
            if self.al_phase {
                let mut u = self.us[k] + alpha * self.k_ff[k] + self.k_fb[k] * dx;
                if let Some(b) = bounds {
                    u = b.clamp(&u);
                }
                self.us_try[k] = u;
                cost += knot.cost.value(&x, &u);
                self.xs_try[k + 1] = knot.dynamics.step(&x, &u);
                continue;
            }
            let q = alpha * self.q_u[k] + self.q_ux[k] * dx;
            // The linearised rows g~ + C du + D dx <= 0 of eq. (15), compacted.
            let base = k * m;
            let mut count = 0;
            let mut soft = 0;
            for i in 0..m {
                let idx = base + i;
                if i == self.bound_offset {
                    soft = count;
                }
                if self.row_present[idx] {
                    self.qa[count] = self.row_c[idx];
                    self.qb[count] = -(self.row_g[idx] + self.row_margin[idx] + self.row_d[idx].dot(&dx));
                    self.qpos[i] = count;
                    count += 1;
                } else {
                    self.qpos[i] = usize::MAX;
                }
            }
            self.qguess.clear();
            for r in 0..self.ws_len[k] {
                let p = self.qpos[self.ws[k * NU + r]];
                if p != usize::MAX {
                    self.qguess.push(p);
                }
            }
            let du = match self.qp.solve(
                &self.q_uu_r[k],
                &q,
                &self.qa[..count],
                &self.qb[..count],
                self.trust,
                &self.qguess,
            ) {
                QpOutcome::Solved(du, _) => du,
                QpOutcome::Infeasible if elastic => {
                    match self.qp.solve_elastic(
                        &self.q_uu_r[k],
                        &q,
                        &self.qa[..count],
                        &self.qb[..count],
                        soft,
                        self.trust,
                        self.settings.merit_penalty,
                    ) {
                        Some((du, _)) => du,
                        None => return Forward::Failed { knot: k },
                    }
                }
                QpOutcome::Infeasible => return Forward::Infeasible { knot: k, max_du },
                QpOutcome::Failed => return Forward::Failed { knot: k },
            };
            max_du = max_du.max(du.amax());
            let mut u = self.us[k] + du;
            if let Some(b) = bounds {
                u = b.clamp(&u);
            }
            self.us_try[k] = u;
            cost += knot.cost.value(&x, &u);
            self.xs_try[k + 1] = knot.dynamics.step(&x, &u);
        }
        cost += problem.terminal().value(&self.xs_try[n]);
        let (term, _) = self.violation(true);
        Forward::Done {
            merit: cost + term,
            cost,
        }
    }
}

/// Whether the first `m` rows of `cw` (with `hw = Q_uu^{-1} cw^T`) are independent enough: the
/// Cholesky pivots of `S = C Q_uu^{-1} C^T` stay above `1e-10` of its diagonal.
fn schur_ok<const NU: usize>(cw: &Matrix<NU, NU>, hw: &Matrix<NU, NU>, m: usize) -> bool {
    let mut s = cw * hw;
    for r in m..NU {
        s[(r, r)] = 1.0;
    }
    let scale = (0..m).map(|r| s[(r, r)]).fold(0.0, f64::max);
    match s.cholesky() {
        Some(c) => {
            let l = c.l_dirty();
            (0..m).all(|r| l[(r, r)] * l[(r, r)] > 1e-10 * scale)
        }
        None => false,
    }
}

/// The relative degree of state-only constraint `index`: the smallest `r` such that `u_k`
/// moves, to first order, a state component the constraint depends on at `x_{k+r}`. Probed along
/// the zero-control rollout of knot 0's dynamics from a slightly perturbed `x0` (so that symmetric
/// points such as a car at rest do not hide a dependence).
fn relative_degree<const NX: usize, const NU: usize>(
    problem: &Problem<Const<NX>, Const<NU>>,
    c: &dyn Constraint<NX, NU>,
    index: usize,
    max_degree: usize,
    max_dim: usize,
) -> Result<usize> {
    if let Some(r) = c.relative_degree() {
        if r == 0 || r > max_degree {
            return Err(Error::invalid(
                format!("constraints[{index}].relative_degree"),
                format!("must be in 1..={max_degree} (settings.max_relative_degree), got {r}"),
            ));
        }
        return Ok(r);
    }
    if c.dim() == 0 {
        return Ok(1);
    }
    let dynamics = &problem.knots()[0].dynamics;
    let zero_u = Vector::<NU>::zeros();
    let mut x = *problem.x0();
    for i in 0..NX {
        x[i] += 1e-3 * (1.0 + i as f64 / NX as f64);
    }
    // The state components any row depends on.
    let (mut g, mut gx, mut gu) = (
        vec![0.0; max_dim],
        vec![Vector::<NX>::zeros(); max_dim],
        vec![Vector::<NU>::zeros(); max_dim],
    );
    let d = c.dim();
    let mut support = [false; NX];
    let mut probe = x;
    for _ in 0..3 {
        c.jacobians(1, &probe, &zero_u, &mut g[..d], &mut gx[..d], &mut gu[..d]);
        for row in &gx[..d] {
            for s in 0..NX {
                support[s] |= row[s] != 0.0;
            }
        }
        probe = dynamics.step(&probe, &zero_u) + Vector::<NX>::repeat(1e-3);
    }
    if !support.iter().any(|&s| s) {
        return Ok(1);
    }
    let (mut fx, mut fu) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
    dynamics.jacobians(&x, &zero_u, &mut fx, &mut fu);
    let mut reach = fu; // d x_{k+r} / d u_k
    for r in 1..=max_degree {
        let scale = 1.0 + reach.amax();
        let hit = (0..NX).any(|s| support[s] && (0..NU).any(|j| reach[(s, j)].abs() > 1e-12 * scale));
        if hit {
            return Ok(r);
        }
        x = dynamics.step(&x, &zero_u);
        dynamics.jacobians(&x, &zero_u, &mut fx, &mut fu);
        reach = fx * reach;
    }
    Err(Error::invalid(
        format!("constraints[{index}]"),
        format!(
            "no control reaches this state constraint within {max_degree} steps \
             (settings.max_relative_degree); state its relative degree or raise the limit"
        ),
    ))
}
