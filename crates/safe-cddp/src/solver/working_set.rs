//! Safe-CDDP's gains step: the active set, the working set and the KKT solution of Xie et al.
//! (2017), eqs. (10)-(12), plugged into the one DDP backward pass of `ddp-core` as its
//! [`Gains`] (the way Crocoddyl's BoxDDP overrides only `computeGains`).
//!
//! At knot `k`, rows with `g~ > -epsilon` form the active set; right after the warm-up hands
//! over (until the first KKT/QP step is accepted), so do rows whose multiplier is positive: a row
//! that the augmented Lagrangian leaves a little inside its boundary (further than `epsilon`)
//! would otherwise drop out, and the first KKT step would run through it. A working set of at most
//! `nu` rows independent in the `Q_uu^{-1}` metric is taken greedily (most active first); rows
//! with negative multipliers are pruned one at a time:
//!
//! ```text
//! lambda = -(C_W Q_uu^-1 C_W^T)^-1 C_W Q_uu^-1 Q_u                      (10)
//! Lambda = (C_W Q_uu^-1 C_W^T)^-1 (D_W - C_W Q_uu^-1 Q_ux)             (11)
//! d = -Q_uu^-1 (Q_u + C_W^T lambda),  K = -Q_uu^-1 (Q_ux + C_W^T Lambda)  (12)
//! ```

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, Dims, MatrixN, VectorN};
use ddp_core::kernels::{cholesky_in_place, cholesky_solve_in_place, copy};
use ddp_core::solver::{Gains, GainsInfo, NotPositiveDefinite, QBlocks};

use super::rows::Rows;

/// The per-knot results of the KKT backward pass that the forward pass needs, and its scratch.
pub(crate) struct Kkt<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    pub q_u: Vec<VectorN<NU>>,
    pub q_ux: Vec<MatrixN<NU, NX>>,
    pub q_uu_r: Vec<MatrixN<NU, NU>>,
    /// Working set of each knot (`nu` slots, `ws_len[k]` used), as row indices within the knot.
    pub ws: Vec<usize>,
    pub ws_len: Vec<usize>,
    /// Constraint curvature `sum lambda g_xx` per state time (with `constraint_hessian`).
    pub h_con: Vec<MatrixN<NX, NX>>,
    /// Rows in the working sets, summed over the knots.
    pub active: usize,
    cand: Vec<(f64, usize)>,
    cw: MatrixN<NU, NU>,
    dw: MatrixN<NU, NX>,
    hw: MatrixN<NU, NU>,
    s: MatrixN<NU, NU>,
    qi_qu: VectorN<NU>,
    qi_qux: MatrixN<NU, NX>,
    hci: VectorN<NU>,
    lambda: VectorN<NU>,
    big_lambda: MatrixN<NU, NX>,
    /// The rows of the working set (its first `mw` entries; the rest are not read).
    rows_w: Vec<usize>,
}

impl<NX: Dim, NU: Dim> Kkt<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    pub fn new(dims: Dims<NX, NU>, cap: usize, m: usize) -> Self {
        let nu = dims.nu();
        Self {
            q_u: vec![dims.u_zeros(); cap],
            q_ux: vec![dims.ux_zeros(); cap],
            q_uu_r: vec![dims.uu_zeros(); cap],
            ws: vec![0; cap * nu],
            ws_len: vec![0; cap],
            h_con: vec![dims.xx_zeros(); cap + 1],
            active: 0,
            cand: Vec::with_capacity(m),
            cw: dims.uu_zeros(),
            dw: dims.ux_zeros(),
            hw: dims.uu_zeros(),
            s: dims.uu_zeros(),
            qi_qu: dims.u_zeros(),
            qi_qux: dims.ux_zeros(),
            hci: dims.u_zeros(),
            lambda: dims.u_zeros(),
            big_lambda: dims.ux_zeros(),
            rows_w: vec![usize::MAX; nu],
        }
    }

    /// Drops knot 0 of the working sets (receding horizon).
    pub fn shift(&mut self, n: usize) {
        let nu = self.rows_w.len();
        self.ws.copy_within(nu..n * nu, 0);
        self.ws_len.copy_within(1..n, 0);
    }
}

/// The KKT gains of one backward pass (see the module docs).
pub(crate) struct KktGains<'a, NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    pub kkt: &'a mut Kkt<NX, NU>,
    pub rows: &'a mut Rows<NX, NU>,
    /// `epsilon` of the active set.
    pub eps: f64,
    /// First row of a knot that may enter the working set (the warm-up keeps only the control
    /// bounds there: its constraint rows are in the cost).
    pub first_row: usize,
    /// Rows with a positive multiplier `rows.lambda` are active whatever their `g~` (the first
    /// KKT/QP iteration after the warm-up's hand-over).
    pub keep_positive: bool,
    /// Add the constraint curvature `h_con` to `Q_xx`.
    pub hessian: bool,
    /// Keep each knot's `Q_u`, `Q_ux`, `Q_uu` for the per-step QPs of the forward pass (not in
    /// the warm-up, whose forward pass rolls out the gains).
    pub forward_qp: bool,
}

impl<NX: Dim, NU: Dim> Gains<NX, NU> for KktGains<'_, NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn add_curvature(&self, k: usize, q_xx: &mut MatrixN<NX, NX>) {
        // Knot 0's state is given: its curvature cannot be acted on (the terminal one, k = N > 0, is added).
        if self.hessian && k > 0 {
            *q_xx += &self.kkt.h_con[k];
        }
    }

    fn compute(
        &mut self,
        k: usize,
        q: &mut QBlocks<NX, NU>,
        _u: &VectorN<NU>,
        k_ff: &mut VectorN<NU>,
        k_fb: &mut MatrixN<NU, NX>,
    ) -> Result<GainsInfo, NotPositiveDefinite> {
        q.factor()?;
        let w = &mut *self.kkt;
        copy(&mut w.qi_qu, &q.q_u);
        q.solve(&mut w.qi_qu);
        copy(&mut w.qi_qux, &q.q_ux_r);
        q.solve(&mut w.qi_qux);
        self.active_set(k);
        let mw = self.working_set(k, q);
        let mw = self.kkt_solution(mw, k_ff, k_fb)?;
        let (w, rows) = (&mut *self.kkt, &mut *self.rows);
        let nu = w.rows_w.len();
        let base = k * rows.m;
        for r in 0..mw {
            rows.lambda[base + w.rows_w[r]] = w.lambda[r];
            w.ws[k * nu + r] = w.rows_w[r];
        }
        w.ws_len[k] = mw;
        w.active += mw;
        // The projected gradient Q_u + C_W^T lambda measures stationarity.
        copy(&mut w.hci, &q.q_u);
        if mw > 0 {
            // (Without rows `C_W` is zero: the product adds nothing.)
            w.hci.gemv_tr(1.0, &w.cw, &w.lambda, 1.0);
        }
        let gradient = w.hci.norm_squared();
        if self.forward_qp {
            copy(&mut w.q_u[k], &q.q_u);
            copy(&mut w.q_ux[k], &q.q_ux);
            copy(&mut w.q_uu_r[k], &q.q_uu_r);
        }
        // Without a working row the gains are the regularised Newton step, so the core's value
        // update takes its collapsed form, one product instead of three (as for `FreeGains`).
        Ok(GainsInfo {
            gradient,
            exact: mw == 0,
        })
    }
}

impl<NX: Dim, NU: Dim> KktGains<'_, NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// The active set of knot `k`: rows with `g~ > -epsilon` or (with `keep_positive`) a
    /// positive multiplier, most active first (into `cand`); clears the knot's multipliers.
    fn active_set(&mut self, k: usize) {
        let (w, rows) = (&mut *self.kkt, &mut *self.rows);
        let base = k * rows.m;
        w.cand.clear();
        let span = base + self.first_row..base + rows.m;
        let (present, g, margin) = (
            &rows.present[span.clone()],
            &rows.g[span.clone()],
            &rows.margin[span.clone()],
        );
        let rows_of_knot = present.iter().zip(g.iter().zip(margin)).zip(&rows.lambda[span]);
        for (i, ((&present, (g, margin)), &lambda)) in (self.first_row..).zip(rows_of_knot) {
            if present {
                let g = g + margin;
                if g > -self.eps || (self.keep_positive && lambda > 0.0) {
                    w.cand.push((g, i));
                }
            }
        }
        rows.lambda[base..base + rows.m].fill(0.0);
        w.cand.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
    }

    /// The working set: at most `nu` active rows, taken greedily, independent in the
    /// `Q_uu^{-1}` metric (rows `C_W^T` in `cw`, `D_W^T` in `dw`, columns `Q_uu^{-1} C_W` in
    /// `hw`). Returns its size.
    fn working_set(&mut self, k: usize, q: &QBlocks<NX, NU>) -> usize {
        let (w, rows) = (&mut *self.kkt, &*self.rows);
        let nu = w.rows_w.len();
        let base = k * rows.m;
        if w.cand.is_empty() {
            // (Most knots: `kkt_solution` reads none of the blocks below.)
            return 0;
        }
        w.cw.fill(0.0);
        w.dw.fill(0.0);
        w.hw.fill(0.0);
        let q_scale = q.q_uu_r.amax().recip();
        let mut mw = 0;
        for c in 0..w.cand.len() {
            if mw == nu {
                break;
            }
            let i = w.cand[c].1;
            let ci = &rows.c[base + i];
            copy(&mut w.hci, ci);
            q.solve(&mut w.hci);
            let norm = ci.dot(&w.hci);
            if norm.is_nan() || norm <= 1e-14 * (1.0 + q_scale) {
                continue; // the controls of this knot cannot move this row
            }
            w.cw.row_mut(mw).tr_copy_from(ci);
            w.hw.column_mut(mw).copy_from(&w.hci);
            if schur_ok(&w.cw, &w.hw, mw + 1, &mut w.s) {
                w.dw.row_mut(mw).tr_copy_from(&rows.d[base + i]);
                w.rows_w[mw] = i;
                mw += 1;
            } else {
                w.cw.row_mut(mw).fill(0.0);
                w.hw.column_mut(mw).fill(0.0);
            }
        }
        mw
    }

    /// The KKT solution (10)-(12) on the working set of size `mw`, pruning the most negative
    /// multiplier one at a time. Writes `k`, `K` and `lambda`; returns the final working-set size.
    fn kkt_solution(
        &mut self,
        mut mw: usize,
        k_ff: &mut VectorN<NU>,
        k_fb: &mut MatrixN<NU, NX>,
    ) -> Result<usize, NotPositiveDefinite> {
        let w = &mut *self.kkt;
        let nu = w.rows_w.len();
        if mw == 0 {
            // No working row (most knots): (10)-(12) reduce to the unconstrained gains
            // d = -Q_uu^-1 Q_u, K = -Q_uu^-1 Q_ux, lambda = 0.
            w.lambda.fill(0.0);
            copy(k_ff, &w.qi_qu);
            k_ff.neg_mut();
            copy(k_fb, &w.qi_qux);
            k_fb.neg_mut();
            return Ok(0);
        }
        loop {
            // S = C_W Q_uu^-1 C_W^T, the identity beyond the working set.
            w.s.gemm(1.0, &w.cw, &w.hw, 0.0);
            for r in mw..nu {
                w.s[(r, r)] = 1.0;
            }
            if !cholesky_in_place(&mut w.s) {
                return Err(NotPositiveDefinite);
            }
            // lambda = -S^-1 C_W Q_uu^-1 Q_u   (10)
            w.lambda.gemv(-1.0, &w.cw, &w.qi_qu, 0.0);
            cholesky_solve_in_place(&w.s, &mut w.lambda);
            let mut worst = (usize::MAX, 0.0);
            for r in 0..mw {
                if w.lambda[r] < worst.1 {
                    worst = (r, w.lambda[r]);
                }
            }
            if worst.0 == usize::MAX {
                // Lambda = S^-1 (D_W - C_W Q_uu^-1 Q_ux)   (11)
                copy(&mut w.big_lambda, &w.dw);
                w.big_lambda.gemm(-1.0, &w.cw, &w.qi_qux, 1.0);
                cholesky_solve_in_place(&w.s, &mut w.big_lambda);
                // d = -Q_uu^-1 Q_u - H_W lambda,  K = -Q_uu^-1 Q_ux - H_W Lambda   (12)
                copy(k_ff, &w.qi_qu);
                k_ff.gemv(-1.0, &w.hw, &w.lambda, -1.0);
                copy(k_fb, &w.qi_qux);
                k_fb.gemm(-1.0, &w.hw, &w.big_lambda, -1.0);
                return Ok(mw);
            }
            // Remove row worst.0 by moving the last working row into its place.
            let r = worst.0;
            let last = mw - 1;
            if r != last {
                w.cw.swap_rows(r, last);
                w.dw.swap_rows(r, last);
                w.hw.swap_columns(r, last);
                w.rows_w.swap(r, last);
            }
            w.cw.row_mut(last).fill(0.0);
            w.dw.row_mut(last).fill(0.0);
            w.hw.column_mut(last).fill(0.0);
            w.rows_w[last] = usize::MAX;
            mw -= 1;
        }
    }
}

/// Whether the first `m` rows of `cw` (with `hw = Q_uu^{-1} cw^T`) are independent enough: the
/// Cholesky pivots of `S = C Q_uu^{-1} C^T` stay above `1e-10` of its diagonal. `s` is scratch.
fn schur_ok<NU: Dim>(cw: &MatrixN<NU, NU>, hw: &MatrixN<NU, NU>, m: usize, s: &mut MatrixN<NU, NU>) -> bool
where
    DefaultAllocator: Alloc<NU, NU>,
{
    s.gemm(1.0, cw, hw, 0.0);
    for r in m..s.nrows() {
        s[(r, r)] = 1.0;
    }
    let scale = (0..m).map(|r| s[(r, r)]).fold(0.0, f64::max);
    if !cholesky_in_place(s) {
        return false;
    }
    (0..m).all(|r| s[(r, r)] * s[(r, r)] > 1e-10 * scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ddp_core::solver::{BackwardOptions, Core, FreeGains, Method, Regularization, RegularizationSettings};

    /// At knots without a working row the KKT gains are the core's regularised Newton step and
    /// report it (`GainsInfo::exact`), so the backward pass takes the core's collapsed value
    /// update: the same gains and value function as `FreeGains`, bit for bit. (With the general
    /// update of Xie et al.'s eq. (14) they differ in the last bits.)
    #[test]
    fn without_working_rows_the_backward_pass_is_the_free_one_bit_for_bit() {
        let problem = ddp_core::reference::p1_unicycle();
        let (dims, n) = (problem.dims(), problem.horizon());
        let mut free = Core::new(dims, n, &RegularizationSettings::default());
        for (k, u) in free.traj.us.iter_mut().enumerate() {
            u[0] = 0.3 + 0.01 * k as f64;
            u[1] = -0.2;
        }
        free.rollout(&problem);
        free.linearize(&problem, Method::Ilqr);
        let mut kkt_core = free.clone();
        let opts = BackwardOptions {
            mu: 1e-3,
            placement: Regularization::Control,
            method: Method::Ilqr,
            gated: false,
        };
        free.backward(&problem, &mut FreeGains, opts).unwrap();
        // No constraint rows, no bounds: the knots' rows (two control-bound sides each) are absent.
        let mut rows = Rows::new(dims, vec![], n);
        let mut kkt = Kkt::new(dims, n, rows.m);
        let mut gains = KktGains {
            kkt: &mut kkt,
            rows: &mut rows,
            eps: 1e-6,
            first_row: 0,
            keep_positive: false,
            hessian: false,
            forward_qp: false,
        };
        kkt_core.backward(&problem, &mut gains, opts).unwrap();
        assert_eq!(kkt.active, 0);
        assert_eq!(kkt_core.policy.k_ff, free.policy.k_ff);
        assert_eq!(kkt_core.policy.k_fb, free.policy.k_fb);
        assert_eq!(kkt_core.value.v_x, free.value.v_x);
        assert_eq!(kkt_core.value.v_xx, free.value.v_xx);
    }
}
