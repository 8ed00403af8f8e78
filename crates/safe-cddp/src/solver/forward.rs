//! Safe-CDDP's forward pass (Xie et al. 2017, eq. (15)): at every knot the QP
//!
//! ```text
//! min_du 1/2 du^T (Q_uu + mu I) du + (alpha Q_u + Q_ux dx)^T du
//! s.t.   g~ + C du + D dx <= 0  (the knot's rows),   |du_j| <= Delta  (trust region)
//! ```
//!
//! with `dx = x - x_bar` along the new trajectory, solved by [`StepQp`]. This replaces the core's
//! feedback rollout in the KKT/QP iterations; the warm-up uses the core's rollout.

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, Dims, VectorN};
use ddp_core::solver::Core;
use ddp_core::Problem;

use super::rows::Rows;
use super::working_set::Kkt;
use crate::qp::{QpMethod, QpOutcome, QpPath, StepQp};

/// Result of one forward pass.
pub(crate) enum Forward {
    /// The trial trajectory is complete; its cost.
    Done { cost: f64 },
    /// The QP of a knot was infeasible; the largest `|du|` reached before it.
    Infeasible { knot: usize, max_du: f64 },
    /// Clarabel failed at a knot.
    Failed { knot: usize },
}

/// The per-step QP and its row buffers (sized at construction).
pub(crate) struct ForwardQp<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    pub qp: StepQp<NU>,
    qa: Vec<VectorN<NU>>,
    qb: Vec<f64>,
    qpos: Vec<usize>,
    qguess: Vec<usize>,
    dx: VectorN<NX>,
    q: VectorN<NU>,
    /// Per knot: its last QP was infeasible (certified, or relaxed with a positive slack). In
    /// elastic mode such a knot goes straight to the elastic QP when the fast paths fail,
    /// instead of paying Clarabel to certify the infeasibility again.
    infeasible: Vec<bool>,
}

impl<NX: Dim, NU: Dim> ForwardQp<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    pub fn new(dims: Dims<NX, NU>, cap: usize, m: usize, method: QpMethod) -> ddp_core::Result<Self> {
        Ok(Self {
            qp: StepQp::new(dims.nu, m, method)?,
            qa: vec![dims.u_zeros(); m],
            qb: vec![0.0; m],
            qpos: vec![usize::MAX; m],
            qguess: Vec::with_capacity(dims.nu()),
            dx: dims.x_zeros(),
            q: dims.u_zeros(),
            infeasible: vec![false; cap],
        })
    }

    /// Forgets which knots had infeasible QPs (at the start of a solve, so that a solve's result
    /// does not depend on the one before).
    pub fn clear_hints(&mut self) {
        self.infeasible.iter_mut().for_each(|f| *f = false);
    }

    /// The forward pass with step `alpha` into the core's trial trajectory. `elastic`: solve
    /// infeasible QPs in elastic form (rows relaxed at `penalty` per unit of slack).
    #[allow(clippy::too_many_arguments)]
    pub fn run(
        &mut self,
        problem: &Problem<NX, NU>,
        core: &mut Core<NX, NU>,
        rows: &Rows<NX, NU>,
        kkt: &Kkt<NX, NU>,
        alpha: f64,
        trust: f64,
        elastic: bool,
        penalty: f64,
    ) -> Forward {
        let n = core.n;
        let m = rows.m;
        let nu = core.dims.nu();
        let bounds = problem.bounds();
        let t = &mut core.traj;
        let mut cost = 0.0;
        let mut max_du = 0.0f64;
        t.xs_try[0].copy_from(problem.x0());
        for (k, knot) in problem.knots()[..n].iter().enumerate() {
            let (head, tail) = t.xs_try.split_at_mut(k + 1);
            let x = &head[k];
            self.dx.copy_from(x);
            self.dx -= &t.xs[k];
            self.q.copy_from(&kkt.q_u[k]);
            self.q.gemv(1.0, &kkt.q_ux[k], &self.dx, alpha);
            // The linearised rows g~ + C du + D dx <= 0 of eq. (15), compacted.
            let base = k * m;
            let mut count = 0;
            let mut soft = 0;
            for i in 0..m {
                let idx = base + i;
                if i == rows.bound_offset {
                    soft = count;
                }
                if rows.present[idx] {
                    self.qa[count].copy_from(&rows.c[idx]);
                    self.qb[count] = -(rows.g[idx] + rows.margin[idx] + rows.d[idx].dot(&self.dx));
                    self.qpos[i] = count;
                    count += 1;
                } else {
                    self.qpos[i] = usize::MAX;
                }
            }
            self.qguess.clear();
            for r in 0..kkt.ws_len[k] {
                let p = self.qpos[kkt.ws[k * nu + r]];
                if p != usize::MAX {
                    self.qguess.push(p);
                }
            }
            let h = &kkt.q_uu_r[k];
            let (qa, qb) = (&self.qa[..count], &self.qb[..count]);
            let outcome = if elastic && self.infeasible[k] && self.qp.method() == QpMethod::Fast {
                match self.qp.solve_fast(h, &self.q, qa, qb, trust, &self.qguess) {
                    Some(du) => QpOutcome::Solved(du, QpPath::ActiveSet),
                    None => {
                        self.qp.count_elastic_direct();
                        QpOutcome::Infeasible
                    }
                }
            } else {
                self.qp.solve(h, &self.q, qa, qb, trust, &self.qguess)
            };
            self.infeasible[k] = matches!(outcome, QpOutcome::Infeasible);
            let du = match outcome {
                QpOutcome::Solved(du, _) => du,
                QpOutcome::Infeasible if elastic => {
                    match self.qp.solve_elastic(h, &self.q, qa, qb, soft, trust, penalty) {
                        Some((du, slack)) => {
                            self.infeasible[k] = slack > 1e-9;
                            du
                        }
                        None => return Forward::Failed { knot: k },
                    }
                }
                QpOutcome::Infeasible => return Forward::Infeasible { knot: k, max_du },
                QpOutcome::Failed => return Forward::Failed { knot: k },
            };
            max_du = max_du.max(du.amax());
            let u = &mut t.us_try[k];
            u.copy_from(&t.us[k]);
            *u += &du;
            if let Some(b) = bounds {
                b.clamp_mut(u);
            }
            cost += knot.cost.value(x, u);
            knot.dynamics.step_keep(x, u, &mut tail[0], &mut t.data_try[k]);
        }
        cost += problem.terminal().value(&t.xs_try[n]);
        Forward::Done { cost }
    }
}
