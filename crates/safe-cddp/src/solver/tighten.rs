//! Constraint tightening (Alcan and Kyrki 2022, Algorithm 1, lines 23-26): the closed-loop
//! covariance propagation of eq. (19) and the margins of eq. (20).
//!
//! The gains of [`Gains::ClosedLoop`] come from the one DDP backward pass of `ddp-core`, run on
//! the cost alone (no constraint rows, no warm-up penalty) with [`ClampedGains`]: the controls
//! that sit at a bound give no feedback, as in box-DDP.

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, Dims, MatrixN};
use ddp_core::solver::{
    backward_pass, BackwardOptions, ClampedGains, Linearization, Method, MuSchedule, Policy, QBlocks, ValueFunction,
};
use ddp_core::{Problem, Result};

use super::SafeCddpSolver;
use crate::tightening::{margin, propagate_covariance, Gains, Tightening};

/// The tightening and its buffers (sized at construction).
pub(crate) struct Stochastic<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    pub tightening: Option<Tightening<NX, NU>>,
    /// Gains of the last covariance propagation.
    pub k_prop: Vec<MatrixN<NU, NX>>,
    /// `Sigma_0 .. Sigma_n`, eq. (19).
    pub sigma: Vec<MatrixN<NX, NX>>,
    /// The cost-only linearisation, policy and value function of the bounds-only backward pass.
    lin: Linearization<NX, NU>,
    policy: Policy<NX, NU>,
    value: ValueFunction<NX>,
    q: QBlocks<NX, NU>,
}

impl<NX: Dim, NU: Dim> Stochastic<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    pub fn new(dims: Dims<NX, NU>, cap: usize) -> Self {
        Self {
            tightening: None,
            k_prop: vec![dims.ux_zeros(); cap],
            sigma: vec![dims.xx_zeros(); cap + 1],
            lin: Linearization::new(dims, cap),
            policy: Policy::new(dims, cap),
            value: ValueFunction::new(dims.nx, cap),
            q: QBlocks::new(dims),
        }
    }
}

impl<NX: Dim, NU: Dim> SafeCddpSolver<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Constraint tightening (Algorithm 1, lines 23-26): linearises at the current trajectory,
    /// propagates the covariance with eq. (19) using the gains the tightening asks for, and sets
    /// every row's margin by eq. (20). Returns the largest change of a margin. Does nothing
    /// (returns 0) without a [`Tightening`].
    pub fn tighten(&mut self, problem: &Problem<NX, NU>) -> Result<f64> {
        self.check_problem(problem)?;
        let Some(t) = self.stoch.tightening.take() else {
            return Ok(0.0);
        };
        let change = self.tighten_with(problem, &t);
        self.stoch.tightening = Some(t);
        Ok(change)
    }

    fn tighten_with(&mut self, problem: &Problem<NX, NU>, t: &Tightening<NX, NU>) -> f64 {
        if self.it.need_linearize {
            self.linearize_now(problem);
        }
        let n = self.core.n;
        match t.gains() {
            Gains::ClosedLoop => self.bounds_only_gains(problem),
            Gains::ActiveSet => {
                for (dst, src) in self.stoch.k_prop[..n].iter_mut().zip(&self.core.policy.k_fb[..n]) {
                    dst.copy_from(src);
                }
            }
            Gains::OpenLoop => self.stoch.k_prop[..n].iter_mut().for_each(|k| k.fill(0.0)),
            Gains::Fixed(g) => self.stoch.k_prop[..n].iter_mut().for_each(|k| k.copy_from(g)),
        }
        propagate_covariance(
            &self.core.lin.fx[..n],
            &self.core.lin.fu[..n],
            t.gains(),
            &self.stoch.k_prop[..n],
            t.sigma_0(),
            t.sigma_w(),
            &mut self.stoch.sigma[..=n],
        );
        let z = t.quantile();
        let rows = &mut self.rows;
        let (xs, us) = (&self.core.traj.xs, &self.core.traj.us);
        let mut change = 0.0f64;
        for k in 0..n {
            let gain = &self.stoch.k_prop[k];
            for (j, slot) in rows.slots.iter().enumerate() {
                if slot.dim == 0 {
                    continue;
                }
                let Some(t_row) = slot.time(k, n) else { continue };
                let base = k * rows.m + slot.offset;
                let (x, u) = if slot.mixed {
                    (&xs[k], &us[k])
                } else {
                    (&xs[t_row], &rows.zero_u)
                };
                self.constraints[j].parameter_variance(t_row, x, u, &mut rows.sw[..slot.dim]);
                for r in 0..slot.dim {
                    let i = base + r;
                    let new = if slot.mixed {
                        // A mixed row sees the control's variance through the gain:
                        // (g_x + K^T g_u)^T Sigma (g_x + K^T g_u).
                        let mut grad = rows.gx[i].clone();
                        grad.gemv_tr(1.0, gain, &rows.gu[i], 1.0);
                        margin(z, &grad, &self.stoch.sigma[t_row], rows.sw[r])
                    } else {
                        margin(z, &rows.gx[i], &self.stoch.sigma[t_row], rows.sw[r])
                    };
                    change = change.max((new - rows.margin[i]).abs());
                    rows.margin[i] = new;
                }
            }
        }
        self.report.tightenings += 1;
        // The merit and violation refer to the new margins from now on. If the new margins make
        // the trajectory infeasible, the warm-up restores feasibility (the per-step QPs cannot
        // move a state constraint far), starting from the current multipliers.
        let max = self.violation_of(false, false).max;
        if !self.warm.active && self.settings.warm_up != crate::WarmUp::None && max > self.settings.al_switch_violation
        {
            self.enter_warm_up();
        }
        self.refresh_merit();
        change
    }

    /// The gains of [`Gains::ClosedLoop`] into `k_prop`: the Gauss-Newton backward pass of the
    /// cost alone along the current trajectory, with the controls that sit at a bound clamped.
    /// Evaluates the cost derivatives again (the workspace's may hold the warm-up's penalty
    /// terms); if `Q_uu` is not positive definite it raises its own regularisation (Tassa's
    /// schedule), and past `mu_max` the gains are zero (open loop).
    fn bounds_only_gains(&mut self, problem: &Problem<NX, NU>) {
        let n = self.core.n;
        let st = &mut self.stoch;
        // The dynamics' Jacobians are those of the workspace; the cost derivatives are fresh.
        for k in 0..n {
            st.lin.fx[k].copy_from(&self.core.lin.fx[k]);
            st.lin.fu[k].copy_from(&self.core.lin.fu[k]);
        }
        st.lin.compute_costs(problem, &self.core.traj.xs, &self.core.traj.us, n);
        let reg = &self.settings.regularization;
        let mut mu = MuSchedule::new(reg);
        let mut gains = ClampedGains {
            bounds: problem.bounds(),
        };
        loop {
            let opts = BackwardOptions {
                mu: mu.mu,
                placement: reg.placement,
                method: Method::Ilqr,
                gated: false,
            };
            let ok = backward_pass(
                problem,
                &self.core.traj.xs,
                &self.core.traj.us,
                &st.lin,
                &mut st.q,
                &mut st.policy,
                &mut st.value,
                &mut gains,
                opts,
                None,
                n,
            )
            .is_ok();
            if ok {
                for (dst, src) in st.k_prop[..n].iter_mut().zip(&st.policy.k_fb[..n]) {
                    dst.copy_from(src);
                }
                return;
            }
            if !mu.raise(reg) {
                st.k_prop[..n].iter_mut().for_each(|k| k.fill(0.0));
                return;
            }
        }
    }
}
