//! The warm-ups ([`crate::Settings::warm_up`]): the barrier homotopy and the augmented
//! Lagrangian.
//!
//! A state constraint can be moved by one knot's control only a little (`C` is `O(dt^2)` for the
//! point robot and the car), so from a far-off guess the per-step QPs turn infeasible and the
//! iterations stall. Each solve therefore starts with augmented-Lagrangian iterations on the same
//! workspace: the constraint rows enter the cost at their own time, as
//! `(max(0, lambda + rho g~)^2 - lambda^2) / (2 rho)` (so `V_x` carries them backwards), control
//! bounds stay in the KKT working set, the forward pass is the core's rollout (no QPs), and the
//! multipliers are updated between inexact inner solves, `lambda <- max(0, lambda + rho g~)`.
//!
//! The barrier homotopy ([`crate::WarmUp::Barrier`]) runs before it on a cold start, on the same
//! steps: the rows enter the cost as the relaxed barrier `B(-g~)` of `mu` (`rows::barrier`), and
//! instead of a multiplier update `mu` falls by [`crate::Settings::barrier_mu_factor`] after
//! each inexact inner solve. Where the trajectory goes around an obstacle is decided while the
//! barrier keeps it away from every boundary, as in interior-point methods (Pavlov, Shames and
//! Manzie 2021); an augmented-Lagrangian or active-set solve from a trajectory that cuts through
//! obstacles instead pushes each knot out of the nearest side. Once `mu` is below
//! [`crate::Settings::barrier_mu_final`] the barrier's multiplier estimates `mu / -g~` become the
//! first multipliers of the next phase.

use ddp_core::dims::{Alloc, DefaultAllocator, Dim};
use ddp_core::Problem;

use super::rows::Merit;
use super::SafeCddpSolver;

/// State of the warm-up.
#[derive(Debug, Clone)]
pub(crate) struct WarmUpState {
    /// The warm-up is running (rather than Xie's KKT/QP iterations).
    pub active: bool,
    /// The warm-up is in its barrier homotopy (rather than the augmented Lagrangian).
    pub barrier: bool,
    /// The barrier parameter `mu`.
    pub mu: f64,
    /// Slacks `-g~` of every row at the previous linearisation (the barrier's dual update).
    pub z_prev: Vec<f64>,
    /// The barrier's duals have not been estimated yet in this homotopy.
    pub fresh: bool,
    /// The warm-up began at a cold start (rather than re-entering from the KKT/QP iterations).
    pub from_cold: bool,
    /// Penalty `rho`.
    pub rho: f64,
    /// Multipliers per row.
    pub lambda: Vec<f64>,
    /// Largest violation at the last multiplier update.
    pub prev_violation: f64,
    /// Accepted inner iterations since the last multiplier update.
    pub inner: usize,
    /// A KKT/QP iteration of this solve failed and the warm-up took over: it then runs to its own
    /// convergence instead of handing over again.
    pub kkt_failed: bool,
    /// The warm-up has just handed over and no KKT/QP step has been accepted since: the first
    /// backward passes keep every row with a positive multiplier in the active set.
    pub handed_over: bool,
    /// No solve has reached the KKT/QP iterations since construction or a reset: the next start
    /// runs the warm-up even from a feasible guess (which may be far from optimal).
    pub cold: bool,
    /// The largest violation an augmented-Lagrangian trial may reach at a knot with two or more
    /// violated rows ([`crate::Settings::barrier_funnel`] after a barrier hand-over, else
    /// infinite).
    pub funnel: f64,
    /// The barrier homotopy has just ended (set by its last `mu` update, taken by the solve
    /// loop: [`crate::Settings::portfolio_new_side`]).
    pub homotopy_ended: bool,
    /// Consecutive crawling steps of the augmented Lagrangian: full, at a feasible trajectory,
    /// the merit all but unchanged ([`crate::Settings::al_near_crawl`]).
    pub crawl: usize,
    /// Such a crawl has turned [`crate::Settings::al_near_margin`]'s curvature off for the rest
    /// of the solve.
    pub near_off: bool,
}

impl WarmUpState {
    pub fn new(rows: usize, rho: f64, mu: f64) -> Self {
        Self {
            active: false,
            barrier: false,
            mu,
            z_prev: vec![0.0; rows],
            fresh: true,
            from_cold: true,
            rho,
            lambda: vec![0.0; rows],
            prev_violation: f64::INFINITY,
            inner: 0,
            kkt_failed: false,
            handed_over: false,
            cold: true,
            funnel: f64::INFINITY,
            homotopy_ended: false,
            crawl: 0,
            near_off: false,
        }
    }
}

impl<NX: Dim, NU: Dim> SafeCddpSolver<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// (Re-)enters the warm-up from the KKT/QP iterations, with their multipliers as the first
    /// estimate (the warm-up's own in the portfolio's barrier starts) and a moderate penalty (a penalty left at `al_rho_max` makes the inner problems
    /// stiff, and good multipliers do not need it).
    pub(super) fn enter_warm_up(&mut self) {
        let s = &self.settings;
        let w = &mut self.warm;
        w.active = true;
        w.barrier = false;
        w.from_cold = false;
        w.prev_violation = f64::INFINITY;
        w.funnel = f64::INFINITY;
        w.inner = 0;
        w.rho = w
            .rho
            .clamp(s.al_rho_init, s.al_rho_init * s.al_rho_factor * s.al_rho_factor);
        // The portfolio's barrier starts keep the multipliers the warm-up handed over with: after
        // a run of short KKT/QP steps the backward pass's multipliers can be far larger (up to
        // 389 on two of P2's rows, against 0.02 at the hand-over) and throw the re-entered
        // trajectory far from the obstacles (P2: 207 iterations instead of 100). Elsewhere (the
        // augmented-Lagrangian start, MPC re-entries after a tightening) the backward pass's
        // multipliers are the better estimate (P3 and Table I were tuned with them).
        if self.portfolio.member != Some(crate::WarmUp::Barrier) {
            w.lambda.copy_from_slice(&self.rows.lambda);
        }
        self.core.reg.reset(&s.regularization);
        self.it.trust = s.trust_region;
        self.it.need_linearize = true;
        self.refresh_merit();
    }

    /// First-order multiplier update `lambda <- max(0, lambda + rho g~)` and the penalty update;
    /// hands over to the KKT phase once the violation is small. `inner_done`: the inner solve
    /// converged (rather than hitting `al_inner_iterations`). Returns whether the warm-up itself
    /// has converged, which counts only after a failed KKT/QP iteration in this solve: the inner
    /// solve converged on a trajectory within `constraint_tolerance` whose multipliers are
    /// complementary ([`Rows::complementary`] within `active_threshold`). Without that last test
    /// a stationary point of the merit whose rows sit off their boundary but still carry
    /// multipliers counted as converged: the multipliers of an earlier inner solve held the path
    /// away from the obstacles, at any cost (`point-s12-i24-a0` of the problem family: 78.1
    /// against the peers' 1.41, a loop round two overlapping obstacles; P2's start stopped 2.5e-5
    /// above its optimum).
    ///
    /// `exact`: the inner solve met `al_inner_tolerance` or the gradient test (not only
    /// `al_inner_progress`, nor a failed line search). Only then is the trajectory a minimiser of
    /// the augmented Lagrangian, and the Lagrangian's value with the updated multipliers a dual
    /// bound ([`crate::Settings::portfolio_dual_bound`]).
    pub(super) fn update_multipliers(&mut self, problem: &Problem<NX, NU>, inner_done: bool, exact: bool) -> bool {
        if self.it.need_linearize {
            self.linearize_now(problem);
        }
        if self.warm.barrier {
            self.lower_barrier();
            return false;
        }
        if self.portfolio.member == Some(crate::WarmUp::AugmentedLagrangian) && self.portfolio.relaxed_cost.is_nan() {
            self.portfolio.relaxed_cost = self.core.cost;
        }
        let s = self.settings;
        let w = &mut self.warm;
        let converged = w.kkt_failed
            && inner_done
            && self.it.violation_max <= s.constraint_tolerance
            && self
                .rows
                .complementary(&w.lambda, w.rho, self.core.n, s.active_threshold);
        w.inner = 0;
        let previous_max = w.prev_violation;
        w.prev_violation = self.it.violation_max;
        let rho = w.rho;
        let rows = &self.rows;
        for k in 0..self.core.n {
            for i in 0..rows.bound_offset {
                let idx = k * rows.m + i;
                w.lambda[idx] = if rows.present[idx] {
                    (w.lambda[idx] + rho * (rows.g[idx] + rows.margin[idx])).max(0.0)
                } else {
                    0.0
                };
            }
        }
        // A later start whose dual bound is above the kept cost is headed for a worse optimum
        // (`Settings::portfolio_dual_bound`). The trajectory minimises the augmented Lagrangian
        // of the old multipliers, so it is stationary for the Lagrangian `J + lambda+^T g~` of
        // the updated ones (their gradients agree), whose value bounds from below the cost of
        // every feasible trajectory near it (each `lambda+ g~ <= 0` there): the dual function
        // of the local problem.
        if let (Some(kept), Some(fraction), true) = (self.portfolio.beat, s.portfolio_dual_bound, exact) {
            let mut dual = self.core.cost;
            for k in 0..self.core.n {
                for i in 0..rows.bound_offset {
                    let idx = k * rows.m + i;
                    if rows.present[idx] {
                        dual += w.lambda[idx] * (rows.g[idx] + rows.margin[idx]);
                    }
                }
            }
            if dual > kept + fraction * kept.abs() {
                self.portfolio.stopped = Some(crate::StartOutcome::Abandoned);
            }
        }
        if self.it.violation_max > 0.25 * previous_max {
            w.rho = (w.rho * s.al_rho_factor).min(s.al_rho_max);
        }
        if self.it.violation_max <= s.al_switch_violation && !w.kkt_failed {
            self.hand_over();
        }
        self.refresh_merit();
        self.it.need_linearize = true;
        converged
    }

    /// Hands over to Xie's method with the warm-up's multipliers as the first estimate.
    fn hand_over(&mut self) {
        let w = &mut self.warm;
        w.active = false;
        w.barrier = false;
        w.cold = false;
        w.handed_over = true;
        self.rows.lambda.copy_from_slice(&w.lambda);
        self.core.reg.reset(&self.settings.regularization);
    }

    /// The end of a barrier subproblem (rows linearised at the current trajectory): lowers `mu`;
    /// below [`crate::Settings::barrier_mu_final`] the homotopy ends with the multiplier
    /// estimates `B'(-g~)` (`mu / -g~` in the interior) as the first multipliers of the
    /// augmented Lagrangian, which hands over to the KKT/QP iterations once the violation is
    /// small, its trial steps kept within [`crate::Settings::barrier_funnel`]. (Handing a feasible trajectory straight to the KKT/QP iterations fails: rows at a
    /// slack of `mu / lambda` are outside their active set, and the first QP step runs into them.)
    fn lower_barrier(&mut self) {
        let s = self.settings;
        let merit = self.barrier_merit();
        let w = &mut self.warm;
        w.inner = 0;
        w.mu *= s.barrier_mu_factor;
        if w.mu < s.barrier_mu_final {
            let rows = &self.rows;
            for k in 0..self.core.n {
                for i in 0..rows.bound_offset {
                    let idx = k * rows.m + i;
                    w.lambda[idx] = if rows.present[idx] {
                        merit.row(idx, rows.g[idx] + rows.margin[idx]).1
                    } else {
                        0.0
                    };
                }
            }
            w.barrier = false;
            w.prev_violation = f64::INFINITY;
            w.funnel = s.barrier_funnel;
            w.homotopy_ended = true;
        }
        self.refresh_merit();
        self.it.need_linearize = true;
    }

    /// The primal-dual update of the barrier's duals `lambda` after the trajectory moved the
    /// slacks from `z_prev` to `z` (rows linearised at the new trajectory): the Newton step on
    /// the complementarity `z lambda = mu`, `lambda+ = (mu - lambda (z - z_prev)) / z_prev`,
    /// kept within `[mu / (kappa z), kappa mu / z]` (`kappa = 1e10`, as IPOPT's safeguard). The
    /// first update of a homotopy starts on the central path, `lambda = mu / z`.
    pub(super) fn update_barrier_duals(&mut self) {
        const KAPPA: f64 = 1e10;
        let (mu, delta) = (self.warm.mu, self.settings.barrier_relaxation);
        let rows = &self.rows;
        let w = &mut self.warm;
        for k in 0..self.core.n {
            for i in 0..rows.bound_offset {
                let idx = k * rows.m + i;
                if !rows.present[idx] {
                    w.lambda[idx] = 0.0;
                    continue;
                }
                let z = (-(rows.g[idx] + rows.margin[idx])).max(delta);
                let central = mu / z;
                w.lambda[idx] = if w.fresh {
                    central
                } else {
                    let z0 = w.z_prev[idx].max(delta);
                    ((mu - w.lambda[idx] * (z - z0)) / z0).clamp(central / KAPPA, central * KAPPA)
                };
            }
        }
        w.fresh = false;
    }

    /// Saves the slacks of the current linearisation before the next one.
    pub(super) fn save_slacks(&mut self) {
        let rows = &self.rows;
        for (z, (g, m)) in self.warm.z_prev.iter_mut().zip(rows.g.iter().zip(&rows.margin)) {
            *z = -(g + m);
        }
    }

    /// The barrier of the current `mu` as a merit.
    pub(super) fn barrier_merit(&self) -> Merit<'static> {
        Merit::Barrier {
            mu: self.warm.mu,
            delta: self.settings.barrier_relaxation,
        }
    }

    /// Adds the warm-up's terms (augmented Lagrangian or barrier) of every constraint row to
    /// the cost derivatives at the row's own time (state rows at `x_t`, mixed rows at
    /// `(x_k, u_k)`): the gradient `B' g_x` and the Gauss-Newton Hessian `B'' g_x g_x^T`, plus
    /// `B' g_xx` with [`crate::Settings::constraint_hessian`].
    pub(super) fn add_warm_up_derivatives(&mut self) {
        let n = self.core.n;
        let (barrier, delta) = (self.warm.barrier, self.settings.barrier_relaxation);
        let merit = if self.warm.barrier {
            self.barrier_merit()
        } else {
            Merit::Lagrangian {
                lambda: &self.warm.lambda,
                rho: self.warm.rho,
            }
        };
        let s_near_margin = self.settings.al_near_margin;
        // Cold starts and re-entries after a failed KKT/QP step, as `al_inner_progress`.
        let near = !barrier
            && (self.warm.from_cold || self.warm.kkt_failed)
            && s_near_margin > 0.0
            && self.warm.rho >= self.settings.al_near_rho
            && !self.warm.near_off;
        let rows = &mut self.rows;
        let lin = &mut self.core.lin;
        let (xs, us) = (&self.core.traj.xs, &self.core.traj.us);
        for k in 0..n {
            // Most knots of the augmented Lagrangian add nothing: no row with a positive
            // multiplier estimate `nu` and none near its boundary (each obstacle binds over a
            // short stretch). One sweep over the knot's block of rows finds them, rather than the
            // per-constraint loop below.
            if !barrier && rows.whole_knot(k, n) {
                let first = k * rows.m;
                let block = first..first + rows.bound_offset;
                let (g, margin) = (&rows.g[block.clone()], &rows.margin[block]);
                let idle = (first..).zip(g.iter().zip(margin)).all(|(i, (g, margin))| {
                    let v = g + margin;
                    !(merit.row(i, v).1 > 0.0) && !(near && v > -s_near_margin)
                });
                if idle {
                    continue;
                }
            }
            for (j, slot) in rows.slots.iter().enumerate() {
                if slot.dim == 0 {
                    continue;
                }
                let Some(t) = slot.time(k, n) else { continue };
                let base = k * rows.m + slot.offset;
                let mut any = false;
                for r in 0..slot.dim {
                    let i = base + r;
                    let v = rows.g[i] + rows.margin[i];
                    let (_, nu, mut rho) = merit.row(i, v);
                    if barrier && -v >= delta {
                        // Primal-dual curvature lambda / z rather than the primal mu / z^2,
                        // which overstates it off the central path (Pavlov et al. 2021).
                        rho = self.warm.lambda[i] / -v;
                    }
                    rows.sw[r] = nu;
                    let (nu, rho) = if nu > 0.0 {
                        any = true;
                        (nu, rho)
                    } else if near && v > -s_near_margin {
                        // At a high penalty a row just inside its boundary turns on within a
                        // tiny step, where a model blind to it promises a decrease the merit
                        // does not give (it rises as `rho (g_x dx)^2`): its curvature, without
                        // a gradient, keeps the step from crossing it (`Settings::al_near_margin`).
                        (0.0, self.warm.rho)
                    } else {
                        continue;
                    };
                    let (gx, gu) = (&rows.gx[i], &rows.gu[i]);
                    if slot.mixed {
                        let l = &mut lin.l[k];
                        l.lx.axpy(nu, gx, 1.0);
                        l.lu.axpy(nu, gu, 1.0);
                        l.lxx.ger(rho, gx, gx, 1.0);
                        l.luu.ger(rho, gu, gu, 1.0);
                        l.lux.ger(rho, gu, gx, 1.0);
                    } else if t == n {
                        lin.l_n.lx.axpy(nu, gx, 1.0);
                        lin.l_n.lxx.ger(rho, gx, gx, 1.0);
                    } else {
                        let l = &mut lin.l[t];
                        l.lx.axpy(nu, gx, 1.0);
                        l.lxx.ger(rho, gx, gx, 1.0);
                    }
                }
                // The barrier's curvature term `B' g_xx` is always in: without it the model
                // overstates the curvature around an obstacle (`g_xx` is negative definite
                // there) and the steps stay short.
                if any && (self.settings.constraint_hessian || barrier) {
                    let (x, u) = if slot.mixed {
                        (&xs[k], &us[k])
                    } else {
                        (&xs[t], &rows.zero_u)
                    };
                    let target = if slot.mixed || t < n {
                        &mut lin.l[t.min(n - 1)].lxx
                    } else {
                        &mut lin.l_n.lxx
                    };
                    self.constraints[j].add_hessian(t, x, u, &rows.sw[..slot.dim], target);
                }
            }
        }
    }
}
