//! Multiple shooting: the states are variables of their own, joined by the defects
//! `d_k = f(x_k, u_k) - x_{k+1}`, and an iteration is a step of sequential quadratic programming
//! on
//!
//! ```text
//! min  sum_k l(x_k, u_k) + l_N(x_N)   s.t.  x_0 = x0,  f(x_k, u_k) - x_{k+1} = 0,
//! ```
//!
//! its quadratic subproblem solved by the same Riccati backward pass as single shooting, with
//! the defects in the value gradient (Giftthaler et al. 2018's multiple-shooting Riccati step;
//! Mastalli et al. 2020's FDDP is its Gauss-Newton relative) and the Hessian of the Lagrangian
//! weighted by the multiplier iterates `lambda_{k+1}` of the defects instead of `V_x'`:
//!
//! ```text
//! Q_x = l_x + f_x^T (V_x' + V_xx' d_k),   Q_u = l_u + f_u^T (V_x' + V_xx' d_k)
//! (full DDP: + lambda_{k+1} . f_xx, f_ux, f_uu)
//! dx_0 = 0,  du_k = k_k + K_k dx_k,  dx_{k+1} = f_x dx_k + f_u du_k + d_k
//! lambda_{k+1} <- lambda_{k+1} + alpha (V_x' + V_xx' dx_{k+1} - lambda_{k+1})
//! ```
//!
//! The step `(x, u) + alpha (dx, du)` is accepted by the
//! filter line search of Wächter and Biegler (2006) on the pair (total defect `theta`, cost):
//! near feasibility with a descent direction it needs the Armijo decrease of the cost
//! (`f-type`), otherwise enough decrease of either, not dominated by an earlier iterate.
//!
//! Lifting the states this way lets a swing-up move the whole trajectory at once instead of
//! through the rollout of an unstable system: the cart-pole swing-up of the examples converges
//! in 24 iterations instead of 60 (IPOPT on the same multiple-shooting transcription: 27).
//! It can also be slower: on the acrobot swing-up single shooting needs fewer iterations (86
//! against 122). Weighting the second derivatives by the backward pass's own costate
//! `V_x' + V_xx' d_k` instead of the multipliers (DDP's choice, no multiplier state) took 72
//! iterations on that cart-pole and 126 on the acrobot.
//!
//! Control bounds are not taken (the solver rejects a bounded problem under multiple
//! shooting): box-DDP's gains keep `u + k` within them only at `dx = 0`, and neither clamping
//! the step's controls in the linear rollout nor in the trial gives a method that converges
//! reliably (a pendulum that must pump against its torque limit stalls either way). With the
//! step's controls clamped and, when the filter rejects every step, a restoration step (the
//! feedback rollout around the current states, closing every defect) the pendulum converged
//! (47 iterations, box-DDP 28) but the cart-pole with a 10 N limit did not (box-DDP: 58).

use crate::dims::{Alloc, DefaultAllocator, Dim, Dims, VectorN};
use crate::kernels::mul_vec_add;
use crate::solver::core::Core;
use crate::Problem;

/// Below this total defect `sum_k |d_k|_1` the filter asks for an Armijo decrease of the cost
/// (Wächter and Biegler's `theta_min`, relative to `1 + theta_0`).
const THETA_SMALL: f64 = 1e-4;
/// Above this total defect (relative to `1 + theta_0`) a trial is rejected (`theta_max`).
const THETA_MAX: f64 = 1e4;
/// The margins of the filter's acceptance (`gamma_theta`, `gamma_phi`).
const GAMMA: f64 = 1e-5;
/// A solve has converged only when the largest defect entry is at most this.
pub const DEFECT_TOLERANCE: f64 = 1e-9;

/// The state of multiple shooting in a [`Core`]: defects, multipliers, the step and the filter.
#[derive(Debug, Clone)]
pub struct MultipleShooting<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// `d_k = f(x_k, u_k) - x_{k+1}`, `k = 0 .. N-1`.
    pub gaps: Vec<VectorN<NX>>,
    /// The defects of the trial.
    pub gaps_try: Vec<VectorN<NX>>,
    /// `lambda_k` (`k = 1 .. N`; entry 0 unused): the multipliers of the defects, the weights
    /// of the dynamics' second derivatives.
    pub lambda: Vec<VectorN<NX>>,
    /// The multipliers of the quadratic subproblem's solution, `V_x + V_xx dx`.
    pub lambda_qp: Vec<VectorN<NX>>,
    /// The step `dx_0 .. dx_N`.
    pub dxs: Vec<VectorN<NX>>,
    /// The step `du_0 .. du_{N-1}`.
    pub dus: Vec<VectorN<NU>>,
    /// `sum_k |d_k|_1` of the nominal trajectory.
    pub theta: f64,
    /// `theta` of the trial.
    pub theta_try: f64,
    /// `theta` of the first iterate (the filter's scale).
    pub theta_0: f64,
    /// The filter: pairs `(theta, cost)` a trial must improve on in one of the two.
    pub filter: Vec<(f64, f64)>,
    /// Scratch of the backward pass: `V_x' + V_xx' d_k`.
    pub v_x_gap: VectorN<NX>,
    /// The next solve starts from the states in the workspace ([`crate::Solver::set_states`])
    /// rather than from the rollout of the controls.
    pub state_guess: bool,
}

impl<NX: Dim, NU: Dim> MultipleShooting<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Allocates every buffer for `n` knots (and the filter's room for `filter_capacity`
    /// entries, one per iteration at most).
    pub fn new(dims: Dims<NX, NU>, n: usize, filter_capacity: usize) -> Self {
        Self {
            gaps: vec![dims.x_zeros(); n],
            gaps_try: vec![dims.x_zeros(); n],
            lambda: vec![dims.x_zeros(); n + 1],
            lambda_qp: vec![dims.x_zeros(); n + 1],
            dxs: vec![dims.x_zeros(); n + 1],
            dus: vec![dims.u_zeros(); n],
            theta: 0.0,
            theta_try: 0.0,
            theta_0: 0.0,
            filter: Vec::with_capacity(filter_capacity),
            v_x_gap: dims.x_zeros(),
            state_guess: false,
        }
    }

    /// Zero defects and multipliers and an empty filter: the start of a solve from a rollout.
    pub fn reset(&mut self) {
        self.gaps.iter_mut().for_each(|g| g.fill(0.0));
        self.lambda.iter_mut().for_each(|l| l.fill(0.0));
        self.theta = 0.0;
        self.theta_0 = 0.0;
        self.filter.clear();
    }

    /// The largest entry of the nominal defects.
    pub fn max_defect(&self) -> f64 {
        self.gaps
            .iter()
            .flat_map(|g| g.iter())
            .fold(0.0, |m: f64, v| m.max(v.abs()))
    }

    /// Whether the filter lets a trial `(theta, cost)` from the iterate `(theta, f)` through,
    /// and whether the trial is an `f-type` step (which leaves the filter as it is).
    /// `gd` is the directional derivative of the cost along the step, `alpha` its length.
    pub fn filter_accepts(&self, f: f64, gd: f64, alpha: f64, armijo: f64, theta_t: f64, f_t: f64) -> Option<bool> {
        if !(theta_t.is_finite() && f_t.is_finite()) || theta_t > THETA_MAX * (1.0 + self.theta_0) {
            return None;
        }
        if self.filter.iter().any(|&(th, fj)| theta_t >= th && f_t >= fj) {
            return None;
        }
        let theta = self.theta;
        if gd < 0.0 && theta <= THETA_SMALL * (1.0 + self.theta_0) {
            // Switching condition (Wächter and Biegler 2006, eq. (19), with theta small):
            // the step must decrease the cost as a descent step would.
            return (f_t <= f + armijo * alpha * gd).then_some(true);
        }
        (theta_t <= (1.0 - GAMMA) * theta || f_t <= f - GAMMA * theta).then_some(false)
    }

    /// Adds the iterate `(theta, f)`, with the margins, to the filter.
    pub fn augment_filter(&mut self, f: f64) {
        self.filter.push(((1.0 - GAMMA) * self.theta, f - GAMMA * self.theta));
    }
}

impl<NX: Dim, NU: Dim> Core<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// The start of a solve from the states and controls in the workspace (a state guess):
    /// `x_0` replaced by the problem's, the defects between the states, zero multipliers, an
    /// empty filter. Returns the cost.
    pub fn ms_start_from_states(&mut self, problem: &Problem<NX, NU>) -> f64 {
        self.traj.xs[0].copy_from(problem.x0());
        let Some(ms) = self.ms.as_mut() else {
            return f64::NAN;
        };
        ms.reset();
        ms.state_guess = false;
        // The guess is the trial of a zero step.
        ms.dxs.iter_mut().for_each(|d| d.fill(0.0));
        ms.dus.iter_mut().for_each(|d| d.fill(0.0));
        let (cost, theta) = self.ms_trial(problem, 0.0);
        self.ms_accept(0.0, cost);
        if let Some(ms) = self.ms.as_mut() {
            ms.theta_0 = theta;
        }
        cost
    }

    /// The step of the last backward pass by the linear rollout
    /// `dx_{k+1} = f_x dx_k + f_u du_k + d_k`, `du_k = k_k + K_k dx_k`, and the subproblem's
    /// multipliers `V_x + V_xx dx`.
    /// Returns the directional derivative of the cost along the step. Needs multiple shooting.
    pub fn ms_direction(&mut self) -> f64 {
        let n = self.n;
        let Some(ms) = self.ms.as_mut() else {
            return f64::NAN;
        };
        let (lin, policy, value) = (&self.lin, &self.policy, &self.value);
        ms.dxs[0].fill(0.0);
        let mut gd = 0.0;
        for k in 0..n {
            let (head, tail) = ms.dxs.split_at_mut(k + 1);
            let dx = &head[k];
            mul_vec_add(&mut ms.dus[k], Some(&policy.k_ff[k]), &policy.k_fb[k], dx);
            let du = &ms.dus[k];
            gd += lin.l[k].lx.dot(dx) + lin.l[k].lu.dot(du);
            let next = &mut tail[0];
            mul_vec_add(next, Some(&ms.gaps[k]), &lin.fx[k], dx);
            mul_vec_add(&mut self.dx, None, &lin.fu[k], du);
            *next += &self.dx;
        }
        gd += lin.l_n.lx.dot(&ms.dxs[n]);
        for k in 1..=n {
            mul_vec_add(&mut ms.lambda_qp[k], Some(&value.v_x[k]), &value.v_xx[k], &ms.dxs[k]);
        }
        gd
    }

    /// The trial `(x, u) + alpha (dx, du)` into the trial trajectory, with its defects; returns
    /// its cost and total defect `sum |d_k|_1`.
    pub fn ms_trial(&mut self, problem: &Problem<NX, NU>, alpha: f64) -> (f64, f64) {
        let n = self.n;
        let Some(ms) = self.ms.as_mut() else {
            return (f64::NAN, f64::NAN);
        };
        let t = &mut self.traj;
        for k in 0..=n {
            let (x, dx, xt) = (&t.xs[k], &ms.dxs[k], &mut t.xs_try[k]);
            for i in 0..x.len() {
                xt[i] = x[i] + alpha * dx[i];
            }
        }
        let (mut cost, mut theta) = (0.0, 0.0);
        for (k, knot) in problem.knots()[..n].iter().enumerate() {
            let (u, du, ut) = (&t.us[k], &ms.dus[k], &mut t.us_try[k]);
            for i in 0..u.len() {
                ut[i] = u[i] + alpha * du[i];
            }
            let x = &t.xs_try[k];
            cost += knot.cost.value(x, ut);
            let g = &mut ms.gaps_try[k];
            knot.dynamics.step_keep(x, ut, g, &mut t.data_try[k]);
            *g -= &t.xs_try[k + 1];
            theta += g.iter().map(|v| v.abs()).sum::<f64>();
        }
        ms.theta_try = theta;
        (cost + problem.terminal().value(&t.xs_try[n]), theta)
    }

    /// Makes the trial (of cost `cost`) the nominal iterate and moves the multipliers a step
    /// `alpha` towards the subproblem's.
    pub fn ms_accept(&mut self, alpha: f64, cost: f64) {
        self.traj.accept_trial();
        self.cost = cost;
        if let Some(ms) = self.ms.as_mut() {
            std::mem::swap(&mut ms.gaps, &mut ms.gaps_try);
            ms.theta = ms.theta_try;
            for (l, lq) in ms.lambda.iter_mut().zip(&ms.lambda_qp).skip(1) {
                for i in 0..l.len() {
                    l[i] += alpha * (lq[i] - l[i]);
                }
            }
        }
    }
}
