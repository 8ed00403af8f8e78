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
//! **One core.** Linearisation, the Q blocks, the regularisation and its schedule, the value
//! update, rollouts and the line search are `ddp-core`'s ([`ddp_core::solver::core`]); this
//! solver overrides only the gains (`working_set`: active set and KKT, eqs. (10)-(12)), the
//! forward pass (`forward`: per-step QPs, eq. (15)), the warm-up (`warm_up`) and the
//! tightening (`tighten`, eqs. (19)-(20)); `rows` holds the constraint rows of every knot.
//!
//! **Warm-up (design change, [`Settings::warm_up`]).** A state constraint can be moved by one
//! knot's control only a little (`C` is `O(dt^2)` for the point robot and the car), so from a
//! far-off guess the per-step QPs turn infeasible and the iterations stall. Each solve therefore
//! starts with a warm-up on the same workspace (`warm_up`): augmented-Lagrangian iterations, in
//! which the constraint rows enter the cost at their own time (so `V_x` carries them backwards),
//! control bounds stay in the KKT working set, the forward pass is a plain rollout (no QPs), and
//! the multipliers are updated between inexact inner solves; on a feasible cold start with
//! [`WarmUp::Barrier`], first a relaxed log-barrier subproblem that keeps the trajectory away from
//! the obstacles while it finds its way (interior-point style, Pavlov, Shames and Manzie 2021).
//! Once the violation is below [`Settings::al_switch_violation`] the iterations above take over
//! with the multipliers as their first estimate. A tightening that makes the trajectory
//! infeasible, or a KKT/QP iteration that finds no acceptable step, re-enters the
//! augmented-Lagrangian warm-up with the current multipliers and a moderate penalty; after such a
//! failure the warm-up runs to its own convergence. Multipliers and penalty carry over between
//! solves ([`SafeCddpSolver::reset`] is the cold start), and a warm start that is already feasible
//! skips the warm-up. [`WarmUp::Portfolio`] (the default) solves a feasible cold start with both
//! warm-ups and keeps the better solution: they often end in different local optima
//! ([`crate::Report::starts`] lists each start, its iterations, cost and whether it was kept). A
//! solve that ends on a violating trajectory reports [`Status::Infeasible`] (a point of local
//! infeasibility).
//!
//! | symbol | field / accessor | equation |
//! |---|---|---|
//! | `Q_x, Q_u, Q_xx, Q_uu, Q_ux` | the core's `QBlocks` (`q_uu_r = Q_uu + mu I`) | (5) |
//! | `C, D` (`g~_u`, `g~_x` of the rows of a knot) | `rows.c`, `rows.d` | (8) |
//! | `lambda` | [`SafeCddpSolver::multipliers`] | (10) |
//! | `K, d` | [`SafeCddpSolver::gains`], [`SafeCddpSolver::feedforward`] | (11)-(12) |
//! | `V_x, V_xx` | the core's `ValueFunction` | (14) |
//! | `du*` | solution of [`crate::qp::StepQp::solve`] | (15)-(16) |
//! | `Sigma_x` | [`SafeCddpSolver::covariances`] | (19) |
//! | `phi^{-1}(beta) sqrt(g_x^T Sigma_x g_x)` | [`SafeCddpSolver::margins`] (`rows.margin`) | (20) |
//! | `epsilon` (active set) | [`Settings::active_threshold`] | §III-A |
//! | `n1`, `n2` | [`crate::mpc::MpcSettings::iterations`], [`crate::Tightening::update_every`] | Alg. 1 |

mod flip;
mod forward;
mod rows;
mod sides;
mod tighten;
mod warm_up;
mod working_set;

use std::sync::Arc;
use std::time::Instant;

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, Dims, MatrixN, VectorN};
use ddp_core::solver::{armijo_accepts, line_search, BackwardOptions, Core, Trial};
use ddp_core::{Error, Problem, Result};

use self::flip::Flips;
use self::forward::{Forward, ForwardQp};
use self::rows::{Merit, Rows, Slot, Violation};
use self::sides::Sides;
use self::tighten::Stochastic;
use self::warm_up::WarmUpState;
use self::working_set::{Kkt, KktGains};
use crate::settings::{IterationLog, Report, Settings, StartOutcome, StartReport, Status, WarmUp, MAX_STARTS};
use crate::tightening::Tightening;
use crate::Constraint;

/// [`SafeCddpSolver::starts_apart`]: a portfolio start whose cost ends more than this factor
/// above the other's stalled rather than found another optimum.
const FAILED_START: f64 = 10.0;

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

/// An accepted step of the line search: its length, the merit and cost of the new trajectory
/// and its largest row violation.
#[derive(Debug, Clone, Copy)]
struct Step {
    alpha: f64,
    merit: f64,
    cost: f64,
    violation_max: f64,
}

/// The iteration state that is neither trajectory nor constraint data.
#[derive(Debug, Clone, Copy)]
struct IterState {
    /// Merit `J + term` of the current trajectory.
    merit: f64,
    /// Largest violation of a tightened row on the current trajectory.
    violation_max: f64,
    /// Trust region `Delta` of the forward QPs.
    trust: f64,
    need_linearize: bool,
    /// The trajectory or the constraints changed since the last linearisation (rather than
    /// only the multipliers, the barrier parameter or the phase, which leave the derivatives of
    /// the dynamics and of the constraint rows as they are).
    moved: bool,
    /// The state rows' `C`, `D` are chained at the current linearisation.
    chained: bool,
    started: bool,
    iteration: usize,
    /// The last accepted step of this solve was a warm-up step.
    accepted_in_warm_up: bool,
    /// The solve began cold, in the warm-up ([`Settings::kkt_step_min`] applies).
    cold_solve: bool,
}

/// The Safe-CDDP solver and its workspace, for `NX` states, `NU` controls (compile-time or
/// run-time sizes), a horizon of at most the problem's `N` knots and a fixed list of constraints.
///
/// Its state is split into named parts: the one DDP core of `ddp-core` (trajectory,
/// linearisation, policy, value function, Q blocks, regularisation), the constraint rows, the
/// KKT gains' per-knot results, the forward pass's QP, the warm-up and the tightening.
///
/// [`SafeCddpSolver::new`] allocates everything: `O(N)` matrices, `O(N m)` constraint rows
/// (`m` = rows per knot), the iteration log, and the Clarabel QP solver, which is set up once for
/// `m + 2 nu` rows and updated in place. [`SafeCddpSolver::solve`] allocates nothing itself for
/// compile-time sizes; Clarabel allocates a little inside its own `solve` (timers), which runs
/// only for QPs that the fast paths do not answer.
///
/// The controls in the workspace are the initial guess of the next solve (warm start);
/// [`SafeCddpSolver::shift`] and [`SafeCddpSolver::set_horizon`] implement the shrinking-horizon
/// MPC of Algorithm 1.
pub struct SafeCddpSolver<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    settings: Settings,
    cap: usize,
    constraints: Vec<Arc<dyn Constraint<NX, NU>>>,
    core: Core<NX, NU>,
    rows: Rows<NX, NU>,
    kkt: Kkt<NX, NU>,
    fwd: ForwardQp<NX, NU>,
    warm: WarmUpState,
    stoch: Stochastic<NX, NU>,
    it: IterState,
    report: Report,
    portfolio: Portfolio<NX, NU>,
}

/// The buffers of [`WarmUp::Portfolio`]: the initial guess, the kept solution and its report.
struct Portfolio<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    guess: Vec<VectorN<NU>>,
    best: Vec<VectorN<NU>>,
    report: Report,
    /// The warm-up of the start now running (`None`: the settings' rule).
    member: Option<WarmUp>,
    /// The barrier's initial `mu` of the start now running (`None`: the settings').
    mu_init: Option<f64>,
    /// The kept solution's last accepted step was a warm-up step (its KKT/QP hand-over failed).
    best_in_warm_up: bool,
    /// [`Settings::portfolio_threads`]: the solver that runs the second start on another thread
    /// (built at the first such solve, and again when the settings, constraints or horizon
    /// change).
    sibling: Option<Box<SafeCddpSolver<NX, NU>>>,
    /// The kept solution's and the running start's sides ([`Settings::portfolio_new_side`]).
    sides: Sides<NX, NU>,
    /// The running start stops at the end of its homotopy if it is on the kept solution's sides.
    side_test: bool,
    /// The running start stopped there.
    same_side: bool,
    /// The kept solution's cost, which the running start must be able to reach
    /// ([`Settings::portfolio_stall`], [`Settings::portfolio_abandon`],
    /// [`Settings::portfolio_dual_bound`]; `None`: no such test).
    beat: Option<f64>,
    /// The running start is a guided one (flipped, planned or mirrored) past its guided
    /// iterations, which [`Settings::portfolio_abandon`] may stop.
    guided: bool,
    /// The running start stopped for that ([`StartOutcome::Stalled`] or
    /// [`StartOutcome::Abandoned`]).
    stopped: Option<StartOutcome>,
    /// The cost at the end of the augmented-Lagrangian start's first inner solve (zero
    /// multipliers, the initial penalty): a relaxation in which the path may still cut through
    /// the obstacles (`NaN` until then). The third start's gate compares with it
    /// (`Settings::portfolio_new_side`), and it bounds the obstacle-free optimum of the guided
    /// starts' gate (`free_bound`).
    pub(super) relaxed_cost: f64,
    /// The starts of this solve so far (the report's [`Report::starts`]).
    starts: Vec<StartReport>,
    /// [`Settings::portfolio_flip`]: the flipped starts' solver and buffers.
    flips: Flips<NX, NU>,
}

impl<NX: Dim, NU: Dim> std::fmt::Debug for SafeCddpSolver<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SafeCddpSolver")
            .field("settings", &self.settings)
            .field("capacity", &self.cap)
            .field("horizon", &self.core.n)
            .field("constraints", &self.constraints.len())
            .field("rows_per_knot", &self.rows.m)
            .field("cost", &self.core.cost)
            .finish()
    }
}

impl<NX: Dim, NU: Dim> SafeCddpSolver<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Validates `settings` and the constraints (sizes, relative degrees), finds the relative
    /// degree of each state-only constraint (from the dynamics of knot 0 around `x0`, unless the
    /// constraint states it), and allocates the workspace (see the type docs).
    pub fn new(
        problem: &Problem<NX, NU>,
        constraints: Vec<Arc<dyn Constraint<NX, NU>>>,
        settings: Settings,
    ) -> Result<Self> {
        settings.validate()?;
        let dims = problem.dims();
        let max_dim = constraints.iter().map(|c| c.dim()).max().unwrap_or(0).max(1);
        let mut slots = Vec::with_capacity(constraints.len());
        let mut offset = 0;
        for (j, c) in constraints.iter().enumerate() {
            c.check_sizes(dims.nx(), dims.nu()).map_err(|e| name_constraint(j, e))?;
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
        Self::with_slots(problem, constraints, settings, slots, problem.horizon())
    }

    /// The workspace for horizons up to `cap`, with the constraints' rows laid out as `slots`.
    fn with_slots(
        problem: &Problem<NX, NU>,
        constraints: Vec<Arc<dyn Constraint<NX, NU>>>,
        settings: Settings,
        slots: Vec<Slot>,
        cap: usize,
    ) -> Result<Self> {
        let dims = problem.dims();
        let max_dim = slots.iter().map(|s| s.dim).max().unwrap_or(0);
        let state_rows = slots.iter().filter(|s| !s.mixed).map(|s| s.dim).sum();
        let rows = Rows::new(dims, slots, cap);
        let m = rows.m;
        // Room in the reports for every start, the flipped ones too (one per state row).
        let report = || {
            let mut r = Report::new(ddp_core::solver::log_rows(settings.max_iterations));
            r.starts.reserve_exact(MAX_STARTS + state_rows);
            r
        };
        Ok(Self {
            settings,
            cap,
            constraints,
            core: Core::new(dims, cap, &settings.regularization),
            kkt: Kkt::new(dims, cap, m),
            fwd: ForwardQp::new(dims, cap, m, settings.qp_method)?,
            warm: WarmUpState::new(cap * m, settings.al_rho_init, settings.barrier_mu_init),
            stoch: Stochastic::new(dims, cap),
            rows,
            it: IterState {
                merit: f64::NAN,
                violation_max: 0.0,
                trust: settings.trust_region,
                need_linearize: true,
                moved: true,
                chained: false,
                started: false,
                iteration: 0,
                accepted_in_warm_up: false,
                cold_solve: false,
            },
            report: report(),
            portfolio: Portfolio {
                guess: vec![dims.u_zeros(); cap],
                best: vec![dims.u_zeros(); cap],
                report: report(),
                member: None,
                mu_init: None,
                best_in_warm_up: false,
                sibling: None,
                sides: Sides::new(dims, max_dim, state_rows),
                side_test: false,
                same_side: false,
                beat: None,
                guided: false,
                stopped: None,
                relaxed_cost: f64::NAN,
                starts: Vec::with_capacity(MAX_STARTS + state_rows),
                flips: Flips::new(dims, max_dim, state_rows),
            },
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
        let rows = ddp_core::solver::log_rows(settings.max_iterations);
        for report in [&mut self.report, &mut self.portfolio.report] {
            if rows > report.log.capacity() {
                report.log.reserve(rows - report.log.len());
            }
        }
        self.fwd.qp.set_method(settings.qp_method);
        self.settings = settings;
        Ok(())
    }
    /// The sizes.
    pub fn dims(&self) -> Dims<NX, NU> {
        self.core.dims
    }
    /// The tightening in use (`None`: the constraints are deterministic, plain CDDP).
    pub fn tightening(&self) -> Option<&Tightening<NX, NU>> {
        self.stoch.tightening.as_ref()
    }
    /// Sets or removes the tightening (its sizes must fit the problem's). Removing it zeroes the
    /// margins; setting it leaves them until the next [`SafeCddpSolver::tighten`].
    pub fn set_tightening(&mut self, tightening: Option<Tightening<NX, NU>>) -> Result<()> {
        match &tightening {
            Some(t) => t.check_sizes(self.core.dims.nx(), self.core.dims.nu())?,
            None => self.rows.margin.iter_mut().for_each(|m| *m = 0.0),
        }
        self.stoch.tightening = tightening;
        self.it.started = false;
        Ok(())
    }
    /// The constraints.
    pub fn constraints(&self) -> &[Arc<dyn Constraint<NX, NU>>] {
        &self.constraints
    }
    /// Replaces constraint `index` by one with the same `dim()`, the same kind and the same
    /// relative degree (e.g. a moving obstacle with a new prediction). Allocates nothing.
    pub fn set_constraint(&mut self, index: usize, constraint: Arc<dyn Constraint<NX, NU>>) -> Result<()> {
        let slot = *self.rows.slots.get(index).ok_or_else(|| {
            Error::invalid(
                "index",
                format!(
                    "constraint {index} out of range ({} constraints)",
                    self.rows.slots.len()
                ),
            )
        })?;
        if constraint.dim() != slot.dim || constraint.depends_on_control() != slot.mixed {
            return Err(Error::invalid(
                format!("constraints[{index}]"),
                "the replacement must have the same dim() and depends_on_control()",
            ));
        }
        constraint
            .check_sizes(self.core.dims.nx(), self.core.dims.nu())
            .map_err(|e| name_constraint(index, e))?;
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
        self.it.need_linearize = true;
        self.it.moved = true;
        self.it.started = false;
        Ok(())
    }
    /// The relative degree used for each constraint (0 for mixed constraints).
    pub fn relative_degrees(&self) -> impl Iterator<Item = usize> + '_ {
        self.rows.slots.iter().map(|s| s.degree)
    }
    /// The horizon the workspace was allocated for.
    pub fn capacity(&self) -> usize {
        self.cap
    }
    /// The active horizon `n` (at most the capacity): solves use the first `n` knots of the
    /// problem and its terminal cost at `x_n`.
    pub fn horizon(&self) -> usize {
        self.core.n
    }
    /// Shortens (or restores) the active horizon, `1 <= n <= capacity` (shrinking-horizon MPC).
    pub fn set_horizon(&mut self, n: usize) -> Result<()> {
        if n == 0 || n > self.cap {
            return Err(Error::invalid(
                "horizon",
                format!("must be in 1..={} (the capacity), got {n}", self.cap),
            ));
        }
        self.core.n = n;
        self.it.need_linearize = true;
        self.it.moved = true;
        self.it.started = false;
        Ok(())
    }
    /// Zeroes the initial guess, gains, multipliers (the warm-up's too, with its penalty back at
    /// [`Settings::al_rho_init`]), covariances and margins: a cold start, whose solve begins with
    /// the warm-up. Everything a solve reads is then as after [`SafeCddpSolver::new`], so solves
    /// after a reset are reproducible.
    pub fn reset(&mut self) {
        self.core.traj.us.iter_mut().for_each(|u| u.fill(0.0));
        self.forget();
    }

    /// [`SafeCddpSolver::reset`] without the initial guess: the next solve is a cold start from
    /// the controls in the workspace.
    fn forget(&mut self) {
        self.core.policy.clear();
        self.stoch.k_prop.iter_mut().for_each(|k| k.fill(0.0));
        self.stoch.sigma.iter_mut().for_each(|s| s.fill(0.0));
        self.rows.lambda.iter_mut().for_each(|l| *l = 0.0);
        self.rows.margin.iter_mut().for_each(|m| *m = 0.0);
        self.kkt.ws_len.iter_mut().for_each(|w| *w = 0);
        self.warm.lambda.iter_mut().for_each(|l| *l = 0.0);
        self.warm.rho = self.settings.al_rho_init;
        self.warm.cold = true;
        self.it.started = false;
        self.it.moved = true;
    }
    /// Sets the initial guess (length `n`, each of size `nu`, finite).
    pub fn set_controls(&mut self, us: &[VectorN<NU>]) -> Result<()> {
        self.core.set_controls(us)?;
        self.it.started = false;
        self.it.moved = true;
        Ok(())
    }
    /// Receding horizon: drops knot 0 of the solution (controls, states, gains, multipliers,
    /// margins) and repeats the last knot. Call [`SafeCddpSolver::set_horizon`] with `n - 1` for
    /// a shrinking horizon.
    pub fn shift(&mut self) {
        let n = self.core.n;
        if n > 1 {
            self.core.shift();
            self.stoch.k_prop[..n].rotate_left(1);
            self.stoch.k_prop[n - 1] = self.stoch.k_prop[n - 2].clone();
            self.kkt.shift(n);
            self.rows.shift(n, &mut self.warm.lambda);
        }
        self.it.started = false;
        self.it.need_linearize = true;
        self.it.moved = true;
    }
    /// States `x_0 .. x_n` of the current trajectory.
    pub fn xs(&self) -> &[VectorN<NX>] {
        &self.core.traj.xs[..=self.core.n]
    }
    /// Controls `u_0 .. u_{n-1}` of the current trajectory.
    pub fn us(&self) -> &[VectorN<NU>] {
        &self.core.traj.us[..self.core.n]
    }
    /// Feedback gains `K_k` of the last backward pass, eq. (12).
    pub fn gains(&self) -> &[MatrixN<NU, NX>] {
        &self.core.policy.k_fb[..self.core.n]
    }
    /// The gains `K_k` the last tightening propagated the covariance with (eq. 19): the
    /// bounds-only backward pass for [`crate::Gains::ClosedLoop`], [`SafeCddpSolver::gains`] for
    /// [`crate::Gains::ActiveSet`], zero or the fixed gain for the baselines.
    pub fn propagation_gains(&self) -> &[MatrixN<NU, NX>] {
        &self.stoch.k_prop[..self.core.n]
    }
    /// Feed-forward terms `d_k` of the last backward pass, eq. (12).
    pub fn feedforward(&self) -> &[VectorN<NU>] {
        &self.core.policy.k_ff[..self.core.n]
    }
    /// Covariances `Sigma_0 .. Sigma_n` of the last tightening, eq. (19).
    pub fn covariances(&self) -> &[MatrixN<NX, NX>] {
        &self.stoch.sigma[..=self.core.n]
    }
    /// Rows per knot (constraint rows, then `2 nu` control-bound sides).
    pub fn rows_per_knot(&self) -> usize {
        self.rows.m
    }
    /// Tightening margins of the rows of knot `k`, eq. (20) (see [`SafeCddpSolver::rows_per_knot`]).
    pub fn margins(&self, k: usize) -> &[f64] {
        &self.rows.margin[k * self.rows.m..(k + 1) * self.rows.m]
    }
    /// Multipliers `lambda` of the rows of knot `k` from the last backward pass (zero outside the
    /// working set), eq. (10).
    pub fn multipliers(&self, k: usize) -> &[f64] {
        &self.rows.lambda[k * self.rows.m..(k + 1) * self.rows.m]
    }
    /// The state index `t` that row `row` of knot `k` constrains (`k` itself for mixed rows and
    /// control bounds), or `None` when the row is beyond the horizon.
    pub fn row_time(&self, k: usize, row: usize) -> Option<usize> {
        if row >= self.rows.bound_offset {
            return Some(k);
        }
        let slot = self
            .rows
            .slots
            .iter()
            .find(|s| row >= s.offset && row < s.offset + s.dim)?;
        slot.time(k, self.core.n)
    }
    /// The report of the last solve (or of the iterations since the last
    /// [`SafeCddpSolver::start`]).
    pub fn report(&self) -> &Report {
        &self.report
    }
    /// QP counters since the last [`SafeCddpSolver::start`] (live: [`Report::qp`] is filled in
    /// only when [`SafeCddpSolver::solve`] ends).
    pub fn qp_stats(&self) -> &crate::qp::QpStats {
        self.fwd.qp.stats()
    }
    /// Current cost `J`.
    pub fn cost(&self) -> f64 {
        self.core.cost
    }

    fn check_problem(&self, problem: &Problem<NX, NU>) -> Result<()> {
        let n = self.core.n;
        if problem.horizon() < n {
            return Err(Error::Shape {
                field: "problem.horizon".into(),
                got: problem.horizon().to_string(),
                expected: format!("at least {n} (the solver's horizon)"),
            });
        }
        if problem.horizon() > self.cap {
            return Err(Error::Shape {
                field: "problem.horizon".into(),
                got: problem.horizon().to_string(),
                expected: format!("at most {} (the capacity this solver was created for)", self.cap),
            });
        }
        self.core.check_dims(problem)
    }

    // ----------------------------------------------------------------------------------------
    // Solve.

    /// Solves `problem` from the controls in the workspace: [`SafeCddpSolver::start`], then
    /// [`SafeCddpSolver::iterate`] until convergence or `max_iterations`, tightening every `n2`
    /// iterations when a [`Tightening`] is set (Algorithm 1, lines 3-26). With a tightening, a
    /// solve converges only once the margins have been updated at the final trajectory.
    ///
    /// Errors only on bad input (a horizon or sizes other than the workspace's); the outcome is
    /// [`Report::status`].
    pub fn solve(&mut self, problem: &Problem<NX, NU>) -> Result<&Report> {
        let portfolio = self.settings.warm_up == WarmUp::Portfolio
            && self.warm.cold
            && self.rows.bound_offset > 0
            && self.stoch.tightening.is_none()
            && self.initial_violation(problem)? <= self.settings.al_switch_violation;
        if portfolio {
            self.solve_portfolio(problem)?;
        } else {
            self.portfolio.member = None;
            self.solve_from_start(problem)?;
        }
        Ok(&self.report)
    }

    /// [`WarmUp::Portfolio`]: solves from the initial guess with each warm-up in turn (and the
    /// barrier from [`Settings::portfolio_third_mu`], when set) and keeps the best solution (see
    /// [`better`]). When that solution is the augmented Lagrangian's own (its KKT/QP hand-over
    /// failed), [`Settings::portfolio_polish`] adds a last start from it: the KKT/QP iterations
    /// with cold multipliers and working sets. With [`Settings::portfolio_threads`] = 2 the
    /// first two starts run at once, the second on a sibling solver on another thread; each start
    /// is the same computation either way, so the kept solution is too.
    fn solve_portfolio(&mut self, problem: &Problem<NX, NU>) -> Result<()> {
        let start = Instant::now();
        let n = self.core.n;
        let tol = self.settings.constraint_tolerance;
        self.portfolio.guess[..n].clone_from_slice(&self.core.traj.us[..n]);
        // (warm-up, barrier mu) of each start from the initial guess; `None` is the polish.
        let guesses = [Some((WarmUp::AugmentedLagrangian, None)), Some((WarmUp::Barrier, None))];
        let third = self
            .settings
            .portfolio_third_mu
            .map(|mu| Some((WarmUp::Barrier, Some(mu))));
        let polish = self.settings.portfolio_polish.then_some(None);
        let mut discarded = 0;
        let mut discarded_qps = crate::qp::QpStats::default();
        // Whether the portfolio's best (`portfolio.best`, `.report`) is also the solver's state.
        let mut live_is_best = false;
        // Whether the first two starts ended apart (`starts_apart`), once both have run.
        let mut apart: Option<bool> = None;
        let concurrent = self.settings.portfolio_threads > 1;
        if concurrent {
            self.prepare_sibling(problem)?;
        }
        let new_side = self.settings.portfolio_new_side;
        self.portfolio.sides.kept_valid = false;
        self.portfolio.relaxed_cost = f64::NAN;
        self.portfolio.starts.clear();
        for (i, member) in guesses.into_iter().chain(third).chain(polish).enumerate() {
            if concurrent && i == 1 {
                // The second start ran on the sibling, alongside the first: its whole end state
                // comes over, as if it had run here.
                let mut sib = self.portfolio.sibling.take().expect("prepared above");
                self.swap_state(&mut sib);
                self.portfolio.sibling = Some(sib);
            } else {
                // The third start and the polish only where the first two ended apart; where they
                // agree, the third start only until its homotopy ends on the kept solution's
                // sides (`Settings::portfolio_new_side`).
                let mut side_test = false;
                if i >= 2 && !*apart.get_or_insert_with(|| self.starts_apart(tol)) {
                    if !(i == 2 && member.is_some() && self.kept_is_poor()) {
                        continue;
                    }
                    side_test = true;
                }
                let p = &mut self.portfolio;
                p.side_test = side_test;
                // Not the second start (it may run alongside the first), nor the polish (it goes
                // on from the kept solution, whose cost its cold multipliers first raise).
                p.beat = (i >= 2
                    && member.is_some()
                    && (self.settings.portfolio_stall > 0 || self.settings.portfolio_dual_bound.is_some())
                    && p.report.max_violation_tightened <= tol)
                    .then_some(p.report.cost);
                match member {
                    Some((warm_up, mu)) => {
                        self.core.traj.us[..n].clone_from_slice(&p.guess[..n]);
                        p.member = Some(warm_up);
                        p.mu_init = mu;
                    }
                    None if p.best_in_warm_up => {
                        self.core.traj.us[..n].clone_from_slice(&p.best[..n]);
                        p.member = Some(WarmUp::None);
                        p.mu_init = None;
                    }
                    None => continue,
                }
                if concurrent && i == 0 {
                    self.solve_first_two(problem)?;
                } else {
                    if i > 0 {
                        self.forget();
                    }
                    self.solve_from_start(problem)?;
                }
            }
            let p = &mut self.portfolio;
            p.side_test = false;
            p.beat = None;
            let (warm_up, barrier_mu_init) = member.unwrap_or((WarmUp::None, None));
            let r = &self.report;
            let mut entry = StartReport {
                warm_up,
                barrier_mu_init,
                flip: None,
                mirror: false,
                plan: false,
                from_kept: member.is_none(),
                iterations: r.iterations,
                cost: r.cost,
                max_violation: r.max_violation_tightened,
                status: r.status,
                outcome: StartOutcome::Discarded,
            };
            let stopped = p.stopped.take();
            if std::mem::take(&mut p.same_side) || stopped.is_some() {
                entry.outcome = stopped.unwrap_or(StartOutcome::SameSide);
                p.starts.push(entry);
                discarded += self.report.iterations;
                discarded_qps += self.report.qp;
                live_is_best = false;
                continue;
            }
            // On a tie the later start is kept.
            let keep_new = i == 0 || !better(&p.report, &self.report, tol);
            if !keep_new {
                p.starts.push(entry);
                discarded += self.report.iterations;
                discarded_qps += self.report.qp;
                live_is_best = false;
                continue;
            }
            if let Some(previous) = p.starts.iter_mut().find(|s| s.outcome == StartOutcome::Kept) {
                previous.outcome = if member.is_none() {
                    StartOutcome::Polished
                } else {
                    StartOutcome::Discarded
                };
            }
            entry.outcome = StartOutcome::Kept;
            p.starts.push(entry);
            if member.is_none() {
                // The polish continues the kept solution: its iterations and QPs count with it
                // (the log holds the polish's own rows).
                self.report.iterations += p.report.iterations;
                self.report.qp += p.report.qp;
            } else if i > 0 {
                discarded += p.report.iterations;
                discarded_qps += p.report.qp;
            }
            // The best's report moves to the portfolio (and back at the end), not copied: the
            // log is allocated once.
            p.best[..n].clone_from_slice(&self.core.traj.us[..n]);
            std::mem::swap(&mut self.report, &mut p.report);
            p.best_in_warm_up = self.it.accepted_in_warm_up;
            live_is_best = true;
            if new_side.is_some() {
                self.measure_sides(true);
            }
        }
        let p = &mut self.portfolio;
        std::mem::swap(&mut self.report, &mut p.report);
        p.member = None;
        p.mu_init = None;
        if !live_is_best {
            self.restore_best(problem);
        }
        // Where the kept solution costs well above the obstacle-free optimum (less far where the
        // first two starts ended apart), the other side of the most costly binding rows
        // (`Settings::portfolio_flip`, `portfolio_flip_apart`, `portfolio_flip_starts`).
        if self.flip_starts(problem, &mut discarded, &mut discarded_qps)? {
            self.restore_best(problem);
        }
        let p = &mut self.portfolio;
        self.report.starts.clear();
        self.report.starts.extend_from_slice(&p.starts);
        self.report.discarded_iterations = discarded;
        self.report.qp += discarded_qps;
        self.report.solve_time = start.elapsed();
        Ok(())
    }

    /// Back to the portfolio's kept solution (`portfolio.best`): its trajectory, and the gains
    /// and multipliers of a backward pass there (what its solve ended with).
    fn restore_best(&mut self, problem: &Problem<NX, NU>) {
        let n = self.core.n;
        self.core.traj.us[..n].clone_from_slice(&self.portfolio.best[..n]);
        self.core.rollout(problem);
        self.warm.active = false;
        self.it.moved = true;
        self.linearize_now(problem);
        let _ = self.compute_direction(problem);
        self.warm.lambda.copy_from_slice(&self.rows.lambda);
        self.refresh_merit();
    }

    /// After the portfolio's first two starts (the kept one's report in `portfolio.report`, the
    /// other's in `report`): whether they ended apart ([`Settings::portfolio_apart`]; always when
    /// that is 0): either infeasible, or feasible at costs more than `portfolio_apart` apart
    /// (relative to the larger) but within a factor of [`FAILED_START`]. A start that ends
    /// further above the other did not find a neighbouring optimum but stalled far from any
    /// (P2's barrier start stops at 900x the cost of the augmented Lagrangian's, after a rejected
    /// KKT/QP step throws its re-entered warm-up away from the obstacles): the replays of seeds
    /// 1-4 match as often without the extra starts there (770 / 840 against 771) for 4 % fewer
    /// iterations.
    fn starts_apart(&self, tol: f64) -> bool {
        let (a, b) = (&self.portfolio.report, &self.report);
        let gap = self.settings.portfolio_apart;
        gap == 0.0
            || ended_apart(
                (a.cost, a.max_violation_tightened),
                (b.cost, b.max_violation_tightened),
                tol,
                gap,
                FAILED_START,
            )
    }

    /// Builds the sibling solver of [`Settings::portfolio_threads`] when there is none or when it
    /// no longer matches this one (settings, constraints, row layout, horizon). It is built with
    /// this solver's row layout (relative degrees), not found again from `problem`.
    fn prepare_sibling(&mut self, problem: &Problem<NX, NU>) -> Result<()> {
        let n = self.core.n;
        let matches = self.portfolio.sibling.as_deref().is_some_and(|s| {
            s.settings == self.settings
                && s.cap == self.cap
                && s.constraints.len() == self.constraints.len()
                && s.constraints
                    .iter()
                    .zip(&self.constraints)
                    .all(|(a, b)| Arc::ptr_eq(a, b))
                && s.rows.slots == self.rows.slots
        });
        if !matches {
            let (constraints, slots) = (self.constraints.clone(), self.rows.slots.clone());
            let sibling = Self::with_slots(problem, constraints, self.settings, slots, self.cap)?;
            self.portfolio.sibling = Some(Box::new(sibling));
        }
        let sib = self.portfolio.sibling.as_deref_mut().expect("built above");
        if sib.core.n != n {
            sib.set_horizon(n)?;
        }
        Ok(())
    }

    /// Exchanges everything a solve changes (trajectory, derivatives, gains, rows, working sets,
    /// QP, warm-up, tightening state, iteration state, report) with `other`, a solver of the same
    /// settings, constraints and capacity.
    fn swap_state(&mut self, other: &mut Self) {
        std::mem::swap(&mut self.core, &mut other.core);
        std::mem::swap(&mut self.rows, &mut other.rows);
        std::mem::swap(&mut self.kkt, &mut other.kkt);
        std::mem::swap(&mut self.fwd, &mut other.fwd);
        std::mem::swap(&mut self.warm, &mut other.warm);
        std::mem::swap(&mut self.stoch, &mut other.stoch);
        std::mem::swap(&mut self.it, &mut other.it);
        std::mem::swap(&mut self.report, &mut other.report);
    }

    /// The portfolio's first two starts at once: the augmented Lagrangian's on this solver, the
    /// barrier's on the sibling (on a scoped thread), both from the initial guess.
    fn solve_first_two(&mut self, problem: &Problem<NX, NU>) -> Result<()> {
        let n = self.core.n;
        let mut sib = self.portfolio.sibling.take().expect("prepared before the first start");
        sib.core.traj.us[..n].clone_from_slice(&self.portfolio.guess[..n]);
        sib.forget();
        sib.portfolio.member = Some(WarmUp::Barrier);
        sib.portfolio.mu_init = None;
        let (first, second) = std::thread::scope(|scope| {
            let second = scope.spawn(|| sib.solve_from_start(problem));
            let first = self.solve_from_start(problem);
            (first, second.join())
        });
        sib.portfolio.member = None;
        self.portfolio.sibling = Some(sib);
        first?;
        match second {
            Ok(result) => result,
            Err(panic) => std::panic::resume_unwind(panic),
        }
    }

    /// [`Settings::portfolio_new_side`]: whether the kept solution's cost is above that factor
    /// times the augmented-Lagrangian start's relaxed cost (or that cost is unknown), so that a
    /// third start may look for a cheaper way around the obstacles.
    fn kept_is_poor(&self) -> bool {
        let p = &self.portfolio;
        self.settings.portfolio_new_side.is_some_and(|factor| {
            // Not at or below the gate, which includes an unknown (NaN) relaxed cost.
            let gate = factor * p.relaxed_cost;
            !matches!(
                p.report.cost.partial_cmp(&gate),
                Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
            )
        })
    }

    /// Whether the current trajectory passes every state constraint on the kept solution's side
    /// ([`Settings::portfolio_new_side`]).
    fn on_kept_sides(&mut self) -> bool {
        self.measure_sides(false);
        self.portfolio.sides.same_as_kept(self.dims().nx())
    }

    /// The sides of the current trajectory into the portfolio's `kept` (or `now`).
    fn measure_sides(&mut self, into_kept: bool) {
        let n = self.core.n;
        let (c, slots, xs) = (&self.constraints, &self.rows.slots, &self.core.traj.xs);
        self.portfolio
            .sides
            .measure(c, slots, xs, &self.rows.zero_u, n, into_kept);
    }

    /// The largest violation of the initial guess (projected onto the bounds, rolled out).
    fn initial_violation(&mut self, problem: &Problem<NX, NU>) -> Result<f64> {
        self.check_problem(problem)?;
        self.core.clamp_controls(problem.bounds());
        self.core.rollout(problem);
        Ok(self.violation_of(false, false).max)
    }

    /// One solve from the current initial guess (the body of [`SafeCddpSolver::solve`]).
    fn solve_from_start(&mut self, problem: &Problem<NX, NU>) -> Result<()> {
        let start = Instant::now();
        self.start(problem)?;
        let mut status = Status::MaxIterations;
        if !self.core.cost.is_finite() {
            status = Status::NumericalError;
        } else {
            // Iterations since the last tightening; starts "overdue" so that a solve that begins
            // in the KKT/QP iterations tightens after its first iteration (Algorithm 1, line 22).
            let mut since_tightening = usize::MAX / 2;
            let mut stall = Stall::new(self.core.cost);
            // Iterations in a row above `portfolio_abandon`'s gate.
            let mut above = 0;
            for done in 1..=self.settings.max_iterations {
                let outcome = self.iterate(problem)?;
                // Its multiplier update found the start's dual bound above the kept cost
                // (`Settings::portfolio_dual_bound`).
                if self.portfolio.stopped.is_some() {
                    break;
                }
                let mut tightened = false;
                let mut fresh = false;
                if let Some(n2) = self.stoch.tightening.as_ref().map(|t| t.update_every()) {
                    since_tightening += 1;
                    if self.tightening_due_every(since_tightening, n2) {
                        let changed = self.tighten(problem)?;
                        tightened = changed > self.settings.constraint_tolerance;
                        fresh = true;
                        since_tightening = 0;
                    }
                }
                if let Some(last) = self.report.log.last_mut() {
                    last.tightened = tightened;
                }
                // The third start where the first two agree goes on past the end of its homotopy
                // only on another side (`Settings::portfolio_new_side`).
                if std::mem::take(&mut self.warm.homotopy_ended) && self.portfolio.side_test && self.on_kept_sides() {
                    self.portfolio.same_side = true;
                    break;
                }
                if let Some(kept) = self.portfolio.beat {
                    let s = &self.settings;
                    let feasible = self.it.violation_max <= s.constraint_tolerance;
                    // A guided start that, well into its iterations on the side its guide
                    // chose, has stayed far above the kept cost, feasible or not
                    // (`Settings::portfolio_abandon`, `portfolio_abandon_run`).
                    if let Some(fraction) = s.portfolio_abandon.filter(|_| self.portfolio.guided) {
                        above = if self.core.cost > kept + fraction * kept.abs() {
                            above + 1
                        } else {
                            0
                        };
                        if done > s.portfolio_abandon_after && above >= s.portfolio_abandon_run {
                            self.portfolio.stopped = Some(StartOutcome::Abandoned);
                            break;
                        }
                    }
                    // A later start that crawls above the kept cost (`Settings::portfolio_stall`).
                    if s.portfolio_stall > 0 {
                        let full_step = matches!(outcome, IterationOutcome::Accepted { step, .. } if step == 1.0);
                        let crawl = full_step && self.warm.active && !self.warm.barrier && feasible;
                        let left = s.max_iterations - done;
                        if stall.update(crawl, self.core.cost, left, kept) >= s.portfolio_stall {
                            self.portfolio.stopped = Some(StartOutcome::Stalled);
                            break;
                        }
                    }
                }
                match outcome {
                    IterationOutcome::Failed(s) => {
                        status = s;
                        break;
                    }
                    IterationOutcome::Converged | IterationOutcome::Accepted { converged: true, .. } => {
                        if self.stoch.tightening.is_none() || (fresh && !tightened) {
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
        self.finish(status);
        self.report.discarded_iterations = 0;
        self.report.solve_time = start.elapsed();
        Ok(())
    }

    /// Whether Algorithm 1 tightens now, `since` iterations after the last tightening: every
    /// `n2` iterations of the KKT/QP phase. Not during the warm-up: its inner solves are inexact
    /// and its trajectory drifts while the multipliers settle, so margins computed there move the
    /// target of every inner solve and the warm-up never hands over (the paper likewise solves
    /// the deterministic problem first and tightens "afterward", §III-D). A warm-up that hands
    /// over with `since >= n2` tightens at once.
    pub fn tightening_due(&self, since: usize, tightening: &Tightening<NX, NU>) -> bool {
        self.tightening_due_every(since, tightening.update_every())
    }

    fn tightening_due_every(&self, since: usize, n2: usize) -> bool {
        !self.warm.active && since >= n2
    }

    /// Whether the solver is in its warm-up ([`Settings::warm_up`]: barrier or augmented Lagrangian)
    /// rather than in the KKT/QP iterations of Xie et al.
    pub fn in_warm_up(&self) -> bool {
        self.warm.active
    }

    /// Starts a solve: projects the controls onto the bounds, rolls them out from `x0`, evaluates
    /// the cost and the violation, and clears the report. Called by [`SafeCddpSolver::solve`];
    /// call it before driving [`SafeCddpSolver::iterate`] by hand (the MPC does).
    pub fn start(&mut self, problem: &Problem<NX, NU>) -> Result<()> {
        self.check_problem(problem)?;
        let r = &mut self.report;
        r.log.clear();
        r.log_dropped = 0;
        r.iterations = 0;
        r.backward_passes = 0;
        r.forward_passes = 0;
        r.infeasible_forward_passes = 0;
        r.tightenings = 0;
        r.starts.clear();
        r.status = Status::MaxIterations;
        self.fwd.qp.reset_stats();
        self.fwd.clear_hints();
        self.core.clamp_controls(problem.bounds());
        let cost = self.core.rollout(problem);
        // The warm-up runs after a cold start and whenever the initial trajectory violates a row;
        // a warm start that is already feasible (an MPC step, a re-solve) goes straight to the
        // KKT/QP iterations. Multipliers and penalty carry over from the previous solve (see
        // `reset`), so a warm start does not first drift into the obstacles under a weak penalty.
        self.warm.active = false;
        let max = self.violation_of(false, false).max;
        let s = self.settings;
        self.warm.active =
            s.warm_up != WarmUp::None && self.rows.bound_offset > 0 && (self.warm.cold || max > s.al_switch_violation);
        // The barrier homotopy chooses the way around the obstacles from a feasible cold start; a
        // warm start has chosen, and an infeasible start has no interior to keep to (its relaxed
        // barrier would be a penalty of curvature `mu / delta^2`): both take the augmented
        // Lagrangian.
        let method = self.portfolio.member.unwrap_or(s.warm_up);
        self.warm.barrier = self.warm.active
            && self.warm.cold
            && max <= s.al_switch_violation
            && matches!(method, WarmUp::Barrier | WarmUp::Portfolio);
        self.warm.mu = self.portfolio.mu_init.unwrap_or(s.barrier_mu_init);
        self.warm.fresh = true;
        self.warm.from_cold = self.warm.cold;
        self.it.cold_solve = self.warm.active && self.warm.cold;
        self.warm.rho = self.warm.rho.max(s.al_rho_init);
        self.warm.prev_violation = f64::INFINITY;
        self.warm.funnel = f64::INFINITY;
        self.warm.inner = 0;
        self.warm.kkt_failed = false;
        self.warm.handed_over = false;
        self.warm.homotopy_ended = false;
        self.warm.crawl = 0;
        self.warm.near_off = false;
        self.refresh_merit();
        self.core.reg.reset(&s.regularization);
        self.it.trust = s.trust_region;
        self.core.expected.gradient = f64::NAN;
        self.kkt.active = 0;
        self.it.need_linearize = true;
        self.it.moved = true;
        self.it.started = true;
        self.it.iteration = 0;
        self.it.accepted_in_warm_up = false;
        self.report.initial_cost = cost;
        self.log(0, 0.0, true);
        Ok(())
    }

    /// One iteration: linearise (if the trajectory changed), compute the direction (backward
    /// pass, raising `mu` until `Q_uu` is positive definite), the stopping test, and the step
    /// (forward pass with the per-step QPs and a line search). Requires
    /// [`SafeCddpSolver::start`] first (it is called automatically when needed).
    pub fn iterate(&mut self, problem: &Problem<NX, NU>) -> Result<IterationOutcome> {
        if !self.it.started {
            self.start(problem)?;
        }
        self.check_problem(problem)?;
        if !self.core.cost.is_finite() {
            return Ok(IterationOutcome::Failed(Status::NumericalError));
        }
        self.it.iteration += 1;
        let iteration = self.it.iteration;
        if self.it.need_linearize {
            self.linearize_now(problem);
        }
        if let Err(status) = self.compute_direction(problem) {
            return Ok(IterationOutcome::Failed(status));
        }
        if let Some(outcome) = self.stopping_criteria(problem, iteration) {
            return Ok(outcome);
        }
        match self.try_step(problem) {
            Ok(step) => Ok(self.accept_step(problem, iteration, step)),
            Err(failure) => Ok(self.reject_step(problem, iteration, failure)),
        }
    }

    /// The backward pass's method now: Gauss-Newton in the barrier warm-up's homotopy, the
    /// settings' otherwise. The homotopy's subproblems are solved loosely and far from the
    /// solution, where full DDP's second-order dynamics terms add cost and indefiniteness (its
    /// failed passes) rather than convergence; full DDP takes over at the hand-over, where its
    /// faster local convergence pays (on the obstacle of `traced.py` 0.92x the time; on the
    /// problem family under full DDP 0.95x, the same matches; see bench/peers/README.md).
    fn method_now(&self) -> ddp_core::Method {
        if self.warm.active && self.warm.barrier {
            ddp_core::Method::Ilqr
        } else {
            self.settings.method
        }
    }

    /// The backward pass with the KKT gains, raising `mu` until it succeeds (full DDP retries
    /// with the second-order terms gated, as `ddp-core`'s solver does:
    /// [`ddp_core::solver::MuSchedule::until_definite`]).
    fn compute_direction(&mut self, problem: &Problem<NX, NU>) -> std::result::Result<(), Status> {
        let s = self.settings;
        let method = self.method_now();
        let (mut reg, mut passes) = (self.core.reg, 0);
        let ok = reg.until_definite(&s.regularization, method, &mut passes, |opts| {
            self.kkt_backward(problem, opts)
        });
        self.core.reg = reg;
        self.report.backward_passes += passes;
        if ok {
            Ok(())
        } else {
            Err(Status::RegularizationLimit)
        }
    }

    fn kkt_backward(
        &mut self,
        problem: &Problem<NX, NU>,
        opts: BackwardOptions,
    ) -> std::result::Result<(), ddp_core::solver::NotPositiveDefinite> {
        let s = &self.settings;
        self.kkt.active = 0;
        let first_row = if self.warm.active { self.rows.bound_offset } else { 0 };
        let mut gains = KktGains {
            kkt: &mut self.kkt,
            rows: &mut self.rows,
            eps: s.active_threshold,
            first_row,
            keep_positive: !self.warm.active && self.warm.handed_over,
            hessian: s.constraint_hessian && !self.warm.active,
            forward_qp: !self.warm.active,
        };
        self.core.backward(problem, &mut gains, opts)
    }

    /// The stopping test: in the warm-up, an inner solve that is stationary updates the
    /// multipliers; otherwise a stationary, feasible trajectory has converged.
    fn stopping_criteria(&mut self, problem: &Problem<NX, NU>, iteration: usize) -> Option<IterationOutcome> {
        let tol = self.settings.tolerances.gradient;
        let gradient = self.core.expected.gradient;
        // A barrier subproblem is solved to within 10 mu, as IPOPT's (kappa_epsilon = 10).
        let inner_tol = if self.warm.barrier {
            (10.0 * self.warm.mu).powi(2)
        } else {
            tol
        };
        if self.warm.active && gradient < inner_tol {
            // The inner problem is solved: update the multipliers.
            self.log(iteration, 0.0, false);
            if self.update_multipliers(problem, true, true) {
                return Some(IterationOutcome::Converged);
            }
            return Some(IterationOutcome::Accepted {
                step: 0.0,
                converged: false,
            });
        }
        // The projected gradient vanishes on every working set that absorbs `Q_u`, also one
        // holding rows off their boundary (kept for their positive multipliers just after a
        // hand-over): that is not a KKT point, whose step still has to close the rows' slack.
        if gradient < tol && self.it.violation_max <= self.settings.constraint_tolerance && self.working_set_active() {
            self.log(iteration, 0.0, false);
            return Some(IterationOutcome::Converged);
        }
        None
    }

    /// Whether every row of the last backward pass's working sets is active (within
    /// [`Settings::active_threshold`] of its boundary).
    fn working_set_active(&self) -> bool {
        let (nu, m) = (self.dims().nu(), self.rows.m);
        let eps = self.settings.active_threshold;
        (0..self.core.n).all(|k| {
            self.kkt.ws[k * nu..k * nu + self.kkt.ws_len[k]]
                .iter()
                .all(|&i| self.rows.g[k * m + i] + self.rows.margin[k * m + i] >= -eps)
        })
    }

    /// The line search on the merit: the warm-up rolls out the core's feedback policy, the
    /// KKT/QP phase runs the per-step QPs (retrying an infeasible QP with a shrinking trust
    /// region, then in elastic form). Returns the accepted step with its merit and cost, or the
    /// status of the failure.
    fn try_step(&mut self, problem: &Problem<NX, NU>) -> std::result::Result<Step, Option<Status>> {
        let s = self.settings;
        let mut retries = 0;
        let mut elastic = false;
        let mut failure: Option<Status> = None;
        let mut accepted = (f64::NAN, f64::NAN, f64::NAN);
        // Short KKT/QP steps of a cold solve count as failed: its warm-up takes over
        // (`Settings::kkt_step_min`).
        let mut search = s.line_search;
        if !self.warm.active && self.it.cold_solve && !self.warm.kkt_failed {
            search.step_min = search.step_min.max(s.kkt_step_min);
        }
        let alpha = line_search(&search, |alpha| {
            self.report.forward_passes += 1;
            let done = if self.warm.active {
                Forward::Done {
                    cost: self.core.rollout_policy(problem, alpha),
                }
            } else {
                self.fwd.run(
                    problem,
                    &mut self.core,
                    &self.rows,
                    &self.kkt,
                    alpha,
                    self.it.trust,
                    elastic,
                    s.merit_penalty,
                )
            };
            match done {
                Forward::Done { cost } => {
                    let trial = self.violation_of(true, true);
                    let merit = cost + trial.term;
                    let expected = self.core.expected.decrease(alpha);
                    let actual = self.it.merit - merit;
                    let small = actual.abs() <= s.tolerances.cost * (1.0 + self.core.cost.abs());
                    // After a barrier hand-over the augmented Lagrangian does not step deep into
                    // where obstacles overlap (`Settings::barrier_funnel`).
                    let within = !self.warm.active || trial.overlap <= self.warm.funnel.max(self.it.violation_max);
                    let ok = merit.is_finite()
                        && within
                        && (armijo_accepts(&s.line_search, expected, actual)
                            || (small && trial.max <= self.it.violation_max.max(s.constraint_tolerance)));
                    if ok {
                        accepted = (merit, cost, trial.max);
                        Trial::Accept
                    } else {
                        Trial::Shorter
                    }
                }
                Forward::Infeasible { knot, max_du } => {
                    self.report.infeasible_forward_passes += 1;
                    failure = Some(Status::Infeasible { knot });
                    retries += 1;
                    if retries > s.max_qp_retries {
                        if s.elastic && !elastic {
                            // Relax the rows of infeasible QPs from now on; the merit decides.
                            elastic = true;
                            self.it.trust = s.trust_region;
                            return Trial::Again;
                        }
                        return Trial::Stop;
                    }
                    // A diminishing trust region (and step) keeps the new trajectory closer to
                    // the nominal one, whose linearisation the QPs use.
                    self.it.trust = (s.trust_shrink * max_du).min(self.it.trust).max(1e-12);
                    Trial::Shorter
                }
                Forward::Failed { knot } => {
                    failure = Some(Status::QpFailed { knot });
                    Trial::Stop
                }
            }
        });
        match alpha {
            Some(alpha) => Ok(Step {
                alpha,
                merit: accepted.0,
                cost: accepted.1,
                violation_max: accepted.2,
            }),
            None => Err(failure),
        }
    }

    /// Makes the trial the nominal trajectory, lowers `mu`, lets the trust region grow back, and
    /// runs the convergence tests (the warm-up's multiplier update, or the merit change).
    fn accept_step(&mut self, problem: &Problem<NX, NU>, iteration: usize, step: Step) -> IterationOutcome {
        let Step {
            alpha,
            merit,
            cost,
            violation_max,
        } = step;
        let s = self.settings;
        let change = self.it.merit - merit;
        self.core.traj.accept_trial();
        self.core.cost = cost;
        self.it.merit = merit;
        if !self.warm.active {
            self.warm.handed_over = false;
        }
        // The line search evaluated the rows along this trajectory as the trial.
        self.it.violation_max = violation_max;
        self.it.need_linearize = true;
        self.it.moved = true;
        self.report.iterations += 1;
        self.log(iteration, alpha, true);
        self.core.reg.lower(&s.regularization);
        self.it.trust = (self.it.trust / s.trust_shrink).min(s.trust_region);
        if self.warm.active {
            self.warm.inner += 1;
            // Done when the merit has stopped moving, or (the augmented Lagrangian of a cold
            // start or after a failed KKT/QP step) when a full step moved it less than the next
            // multiplier update will (`al_inner_progress`).
            let v = self.it.violation_max;
            // A crawl along rows held just inside their boundary (`Settings::al_near_crawl`).
            if s.al_near_crawl > 0 && !self.warm.barrier {
                let crawling = alpha == 1.0
                    && v <= s.constraint_tolerance
                    && change.abs() < s.al_near_crawl_change * (1.0 + self.it.merit.abs());
                self.warm.crawl = if crawling { self.warm.crawl + 1 } else { 0 };
                if self.warm.crawl >= s.al_near_crawl {
                    self.warm.near_off = true;
                }
            }
            let exact = change.abs() < s.al_inner_tolerance * (1.0 + self.it.merit.abs());
            let inner_done = exact
                || (!self.warm.barrier
                    && (self.warm.from_cold || self.warm.kkt_failed)
                    && alpha == 1.0
                    && v < s.al_inner_progress_below
                    && change.abs() < s.al_inner_progress * self.warm.rho * v * v);
            let limit = if self.warm.barrier {
                s.barrier_inner_iterations
            } else if self.warm.from_cold {
                s.al_cold_inner_iterations
            } else {
                s.al_inner_iterations
            };
            let converged =
                (inner_done || self.warm.inner >= limit) && self.update_multipliers(problem, inner_done, exact);
            return IterationOutcome::Accepted { step: alpha, converged };
        }
        let converged = change.abs() < s.tolerances.cost * (1.0 + self.core.cost.abs())
            && self.it.violation_max <= s.constraint_tolerance;
        IterationOutcome::Accepted { step: alpha, converged }
    }

    /// No step was accepted: the warm-up updates its multipliers; a failed KKT/QP step hands
    /// over to the warm-up; otherwise `mu` is raised.
    fn reject_step(
        &mut self,
        problem: &Problem<NX, NU>,
        iteration: usize,
        failure: Option<Status>,
    ) -> IterationOutcome {
        let s = self.settings;
        self.log(iteration, 0.0, false);
        if self.warm.active {
            if self.update_multipliers(problem, true, false) {
                return IterationOutcome::Converged;
            }
        } else if s.warm_up != WarmUp::None && self.rows.bound_offset > 0 {
            // The KKT/QP step failed: typically a constraint row that the backward pass left out
            // (pruned, or dependent on a control bound at a tangency) binds in a forward QP,
            // whose control can move a relative-degree-r row only by O(dt^r), so the QP answers
            // with a huge du. The warm-up's smooth penalty model has no such jumps: it takes over
            // from here, with the multipliers of this backward pass, and runs to its own
            // convergence.
            self.enter_warm_up();
            self.warm.kkt_failed = true;
            return IterationOutcome::Rejected;
        }
        if let Some(Status::QpFailed { knot }) = failure {
            return IterationOutcome::Failed(Status::QpFailed { knot });
        }
        if !self.core.reg.raise(&s.regularization) {
            return IterationOutcome::Failed(failure.unwrap_or(Status::LineSearchFailed));
        }
        self.it.trust = s.trust_region;
        IterationOutcome::Rejected
    }

    /// Phase 1, exposed for benchmarks and custom loops: derivatives of dynamics, costs and
    /// constraint rows along the current trajectory.
    pub fn linearize(&mut self, problem: &Problem<NX, NU>) -> Result<()> {
        self.check_problem(problem)?;
        if !self.it.started {
            self.start(problem)?;
        }
        self.it.moved = true;
        self.linearize_now(problem);
        Ok(())
    }

    /// Phase 2: the constrained backward pass with regularisation `mu`; `Ok(false)` when `Q_uu`
    /// was not positive definite at some knot.
    pub fn backward(&mut self, problem: &Problem<NX, NU>, mu: f64) -> Result<bool> {
        self.check_problem(problem)?;
        let s = self.settings;
        let opts = BackwardOptions {
            mu,
            placement: s.regularization.placement,
            method: self.method_now(),
            gated: false,
        };
        // Full DDP retries a failed pass with the second-order terms gated, as a solve does.
        let ddp = opts.method == ddp_core::Method::Ddp;
        Ok(self.kkt_backward(problem, opts).is_ok()
            || (ddp
                && self
                    .kkt_backward(problem, BackwardOptions { gated: true, ..opts })
                    .is_ok()))
    }

    /// Phase 3: the forward pass with step `alpha` (into scratch buffers, leaving the trajectory
    /// unchanged). Returns the merit of the trial, or the status of the knot whose QP failed.
    pub fn forward(&mut self, problem: &Problem<NX, NU>, alpha: f64) -> Result<std::result::Result<f64, Status>> {
        self.check_problem(problem)?;
        let done = self.fwd.run(
            problem,
            &mut self.core,
            &self.rows,
            &self.kkt,
            alpha,
            self.it.trust,
            false,
            self.settings.merit_penalty,
        );
        Ok(match done {
            Forward::Done { cost } => Ok(cost + self.violation_of(true, true).term),
            Forward::Infeasible { knot, .. } => Err(Status::Infeasible { knot }),
            Forward::Failed { knot } => Err(Status::QpFailed { knot }),
        })
    }

    // ----------------------------------------------------------------------------------------
    // Internals.

    fn log(&mut self, iteration: usize, step: f64, accepted: bool) {
        if accepted {
            self.it.accepted_in_warm_up = self.warm.active;
        }
        if self.report.log.len() < self.report.log.capacity() {
            self.report.log.push(IterationLog {
                iteration,
                cost: self.core.cost,
                violation: self.it.violation_max,
                gradient: self.core.expected.gradient,
                step,
                mu: self.core.reg.mu,
                active: self.kkt.active,
                accepted,
                tightened: false,
                warm_up: self.warm.active.then_some(if self.warm.barrier {
                    WarmUp::Barrier
                } else {
                    WarmUp::AugmentedLagrangian
                }),
            });
        } else {
            self.report.log_dropped += 1;
        }
    }

    fn finish(&mut self, mut status: Status) {
        let n = self.core.n;
        // A solve that ends (converged, stuck or out of iterations) on a trajectory that violates
        // a row has found no feasible point near it: a point of local infeasibility, as IPOPT
        // reports it.
        if self.it.violation_max > self.settings.constraint_tolerance
            && !matches!(
                status,
                Status::NumericalError | Status::QpFailed { .. } | Status::Infeasible { .. }
            )
        {
            let (xs, us) = (&self.core.traj.xs, &self.core.traj.us);
            if let Some(knot) =
                self.rows
                    .first_violating_knot(&self.constraints, xs, us, n, self.settings.constraint_tolerance)
            {
                status = Status::Infeasible { knot };
            }
        }
        let original = self
            .rows
            .original_violation(&self.constraints, &self.core.traj.xs, &self.core.traj.us, n);
        let r = &mut self.report;
        r.status = status;
        r.cost = self.core.cost;
        r.gradient = self.core.expected.gradient;
        r.mu = self.core.reg.mu;
        r.max_violation = original;
        r.max_violation_tightened = self.it.violation_max;
        r.qp = *self.fwd.qp.stats();
    }

    /// The violation of the current (`trial = false`) or trial trajectory: under the current
    /// phase's merit (`phase`), or only its largest violation (`phase = false`).
    fn violation_of(&mut self, trial: bool, phase: bool) -> Violation {
        let merit = if !phase {
            Merit::Penalty(0.0)
        } else if self.warm.active && self.warm.barrier {
            self.barrier_merit()
        } else if self.warm.active {
            Merit::Lagrangian {
                lambda: &self.warm.lambda,
                rho: self.warm.rho,
            }
        } else {
            Merit::Penalty(self.settings.merit_penalty)
        };
        let n = self.core.n;
        let t = &self.core.traj;
        let (xs, us) = if trial { (&t.xs_try, &t.us_try) } else { (&t.xs, &t.us) };
        self.rows.violation(&self.constraints, xs, us, n, merit)
    }

    /// Recomputes the merit and the largest violation of the current trajectory (after the
    /// margins, the multipliers or the phase changed).
    fn refresh_merit(&mut self) {
        let v = self.violation_of(false, true);
        self.it.violation_max = v.max;
        self.it.merit = self.core.cost + v.term;
    }

    /// Derivatives of dynamics and costs (the core), of the constraint rows, and in the warm-up
    /// the augmented-Lagrangian terms, along the current trajectory. When only the multipliers,
    /// the barrier parameter or the phase changed since the last linearisation (the end of an
    /// inner solve of the warm-up, or its hand-over), the Jacobians of the dynamics and of the
    /// rows are those of the same trajectory and are kept: only the cost derivatives (which the
    /// warm-up's terms are added to) and the multiplier-dependent terms are recomputed.
    fn linearize_now(&mut self, problem: &Problem<NX, NU>) {
        let n = self.core.n;
        let barrier = self.warm.active && self.warm.barrier;
        if barrier {
            self.save_slacks();
        }
        if self.it.moved {
            self.core.linearize(problem, self.method_now());
            let (xs, us) = (&self.core.traj.xs, &self.core.traj.us);
            self.rows.linearize(&self.constraints, problem.bounds(), xs, us, n);
            self.it.chained = false;
        } else {
            let (xs, us) = (&self.core.traj.xs, &self.core.traj.us);
            self.core.lin.compute_costs(problem, xs, us, n);
        }
        // The warm-up reads the rows at their own time and only the control bounds' `C` (its
        // working set), so it skips the products `g_x Phi f_u`, `g_x Phi f_x`.
        if !self.warm.active && !self.it.chained {
            self.rows.chain(&self.core.lin.fx, &self.core.lin.fu, n);
            self.it.chained = true;
        }
        if self.settings.constraint_hessian && !self.warm.active {
            let (xs, us) = (&self.core.traj.xs, &self.core.traj.us);
            self.rows
                .add_hessians(&self.constraints, xs, us, n, &mut self.kkt.h_con);
        }
        if barrier {
            self.update_barrier_duals();
        }
        if self.warm.active {
            self.add_warm_up_derivatives();
        }
        self.it.need_linearize = false;
        self.it.moved = false;
    }
}

/// The test of [`Settings::portfolio_stall`]: consecutive crawling steps whose rate of descent
/// cannot bring the cost down to the kept one within the iterations left.
struct Stall {
    last: f64,
    run: usize,
}

impl Stall {
    fn new(cost: f64) -> Self {
        Self { last: cost, run: 0 }
    }

    /// After an iteration that ended at `cost` (`crawl`: an accepted full step of the augmented
    /// Lagrangian at a feasible trajectory), with `left` iterations to go: the length of the
    /// current run of such steps that, at their rate, could not reach `kept`.
    fn update(&mut self, crawl: bool, cost: f64, left: usize, kept: f64) -> usize {
        let fall = self.last - cost;
        self.last = cost;
        if crawl && fall >= 0.0 && cost - fall * left as f64 > kept {
            self.run += 1;
        } else {
            self.run = 0;
        }
        self.run
    }
}

/// Whether two starts that ended at `(cost, violation)` `a` and `b` ended apart: either
/// infeasible (violation above `tol`), or feasible at costs more than `gap` apart (relative to
/// the larger) but within a factor of `failed` of each other (`f64::INFINITY`: any factor). A
/// NaN cost counts as apart.
pub(super) fn ended_apart(a: (f64, f64), b: (f64, f64), tol: f64, gap: f64, failed: f64) -> bool {
    if a.1 > tol || b.1 > tol {
        return true;
    }
    let (lo, hi) = (a.0.abs().min(b.0.abs()), a.0.abs().max(b.0.abs()));
    // `failed * lo` is NaN for an infinite factor and a zero cost: the comparison is then false.
    !((a.0 - b.0).abs() <= gap * hi || hi > failed * lo)
}

/// Whether solve `a` is better than solve `b`: feasible (within `tol`) before infeasible, then
/// the lower cost, or among infeasible ones the smaller violation.
fn better(a: &Report, b: &Report, tol: f64) -> bool {
    let (fa, fb) = (a.max_violation_tightened <= tol, b.max_violation_tightened <= tol);
    match (fa, fb) {
        (true, false) => true,
        (false, true) => false,
        (true, true) => a.cost < b.cost,
        (false, false) => a.max_violation_tightened < b.max_violation_tightened,
    }
}

/// Prefixes an error's field with `constraints[j].`.
fn name_constraint(j: usize, e: Error) -> Error {
    match e {
        Error::Shape { field, got, expected } => Error::Shape {
            field: format!("constraints[{j}].{field}"),
            got,
            expected,
        },
        Error::Invalid { field, reason } => Error::Invalid {
            field: format!("constraints[{j}].{field}"),
            reason,
        },
        other => other,
    }
}

/// The relative degree of state-only constraint `index`: the smallest `r` such that `u_k`
/// moves, to first order, a state component the constraint depends on at `x_{k+r}`. Probed along
/// the zero-control rollout of knot 0's dynamics from a slightly perturbed `x0` (so that symmetric
/// points such as a car at rest do not hide a dependence).
fn relative_degree<NX: Dim, NU: Dim>(
    problem: &Problem<NX, NU>,
    c: &dyn Constraint<NX, NU>,
    index: usize,
    max_degree: usize,
    max_dim: usize,
) -> Result<usize>
where
    DefaultAllocator: Alloc<NX, NU>,
{
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
    let dims = problem.dims();
    let (nx, nu) = (dims.nx(), dims.nu());
    let dynamics = &problem.knots()[0].dynamics;
    let zero_u = dims.u_zeros();
    let mut x = problem.x0().clone();
    for i in 0..nx {
        x[i] += 1e-3 * (1.0 + i as f64 / nx as f64);
    }
    // The state components any row depends on.
    let (mut g, mut gx, mut gu) = (
        vec![0.0; max_dim],
        vec![dims.x_zeros(); max_dim],
        vec![dims.u_zeros(); max_dim],
    );
    let d = c.dim();
    let mut support = vec![false; nx];
    let mut probe = x.clone();
    for _ in 0..3 {
        c.jacobians(1, &probe, &zero_u, &mut g[..d], &mut gx[..d], &mut gu[..d]);
        for row in &gx[..d] {
            for s in 0..nx {
                support[s] |= row[s] != 0.0;
            }
        }
        probe = dynamics.step(&probe, &zero_u);
        probe.add_scalar_mut(1e-3);
    }
    if !support.iter().any(|&s| s) {
        return Ok(1);
    }
    let (mut fx, mut fu) = (dims.xx_zeros(), dims.xu_zeros());
    dynamics.jacobians(&x, &zero_u, &mut fx, &mut fu);
    let mut reach = fu.clone(); // d x_{k+r} / d u_k
    for r in 1..=max_degree {
        let scale = 1.0 + reach.amax();
        let hit = (0..nx).any(|s| support[s] && (0..nu).any(|j| reach[(s, j)].abs() > 1e-12 * scale));
        if hit {
            return Ok(r);
        }
        x = dynamics.step(&x, &zero_u);
        dynamics.jacobians(&x, &zero_u, &mut fx, &mut fu);
        reach = &fx * reach;
    }
    Err(Error::invalid(
        format!("constraints[{index}]"),
        format!(
            "no control reaches this state constraint within {max_degree} steps \
             (settings.max_relative_degree); state its relative degree or raise the limit"
        ),
    ))
}
