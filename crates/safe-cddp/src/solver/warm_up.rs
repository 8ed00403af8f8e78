//! The augmented-Lagrangian warm-up ([`crate::Settings::al_warm_start`]).
//!
//! A state constraint can be moved by one knot's control only a little (`C` is `O(dt^2)` for the
//! point robot and the car), so from a far-off guess the per-step QPs turn infeasible and the
//! iterations stall. Each solve therefore starts with augmented-Lagrangian iterations on the same
//! workspace: the constraint rows enter the cost at their own time, as
//! `(max(0, lambda + rho g~)^2 - lambda^2) / (2 rho)` (so `V_x` carries them backwards), control
//! bounds stay in the KKT working set, the forward pass is the core's rollout (no QPs), and the
//! multipliers are updated between inexact inner solves, `lambda <- max(0, lambda + rho g~)`.

use ddp_core::dims::{Alloc, DefaultAllocator, Dim};
use ddp_core::Problem;

use super::SafeCddpSolver;

/// State of the warm-up.
#[derive(Debug, Clone)]
pub(crate) struct WarmUp {
    /// The warm-up is running (rather than Xie's KKT/QP iterations).
    pub active: bool,
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
    /// No solve has reached the KKT/QP iterations since construction or a reset: the next start
    /// runs the warm-up even from a feasible guess (which may be far from optimal).
    pub cold: bool,
}

impl WarmUp {
    pub fn new(rows: usize, rho: f64) -> Self {
        Self {
            active: false,
            rho,
            lambda: vec![0.0; rows],
            prev_violation: f64::INFINITY,
            inner: 0,
            kkt_failed: false,
            cold: true,
        }
    }
}

impl<NX: Dim, NU: Dim> SafeCddpSolver<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// (Re-)enters the warm-up from the KKT/QP iterations, with their multipliers as the first
    /// estimate and a moderate penalty (a penalty left at `al_rho_max` makes the inner problems
    /// stiff, and good multipliers do not need it).
    pub(super) fn enter_warm_up(&mut self) {
        let s = &self.settings;
        let w = &mut self.warm;
        w.active = true;
        w.prev_violation = f64::INFINITY;
        w.inner = 0;
        w.rho = w
            .rho
            .clamp(s.al_rho_init, s.al_rho_init * s.al_rho_factor * s.al_rho_factor);
        w.lambda.copy_from_slice(&self.rows.lambda);
        self.core.reg.reset(&s.regularization);
        self.it.trust = s.trust_region;
        self.it.need_linearize = true;
        self.refresh_merit();
    }

    /// First-order multiplier update `lambda <- max(0, lambda + rho g~)` and the penalty update;
    /// hands over to the KKT phase once the violation is small. `inner_done`: the inner solve
    /// converged (rather than hitting `al_inner_iterations`). Returns whether the warm-up itself
    /// has converged, which counts only after a failed KKT/QP iteration in this solve: the inner
    /// solve converged on a trajectory within `constraint_tolerance`.
    pub(super) fn update_multipliers(&mut self, problem: &Problem<NX, NU>, inner_done: bool) -> bool {
        if self.it.need_linearize {
            self.linearize_now(problem);
        }
        let s = self.settings;
        let w = &mut self.warm;
        let converged = w.kkt_failed && inner_done && self.it.violation_max <= s.constraint_tolerance;
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
        if self.it.violation_max > 0.25 * previous_max {
            w.rho = (w.rho * s.al_rho_factor).min(s.al_rho_max);
        }
        if self.it.violation_max <= s.al_switch_violation && !w.kkt_failed {
            // Hand over to Xie's method with the multipliers as the first estimate.
            w.active = false;
            w.cold = false;
            self.rows.lambda.copy_from_slice(&w.lambda);
            self.core.reg.reset(&s.regularization);
        }
        self.refresh_merit();
        self.it.need_linearize = true;
        converged
    }

    /// Adds the warm-up's augmented-Lagrangian terms of every constraint row to the cost
    /// derivatives at the row's own time (state rows at `x_t`, mixed rows at `(x_k, u_k)`).
    pub(super) fn add_al_derivatives(&mut self) {
        let n = self.core.n;
        let rho = self.warm.rho;
        let rows = &mut self.rows;
        let lin = &mut self.core.lin;
        let (xs, us) = (&self.core.traj.xs, &self.core.traj.us);
        for k in 0..n {
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
                    let nu = (self.warm.lambda[i] + rho * v).max(0.0);
                    rows.sw[r] = nu;
                    if nu <= 0.0 {
                        continue;
                    }
                    any = true;
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
                if any && self.settings.constraint_hessian {
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
