//! The constraint rows of every knot: their layout, their linearisation along the trajectory,
//! and the violation measures of the merit.
//!
//! Rows are gathered per knot `k`: mixed rows at `(x_k, u_k)`; state rows `g(x_{k+r})` moved to
//! the knot whose control reaches them (Xie et al. 2017): `C = g_x Phi f_u`, `D = g_x Phi f_x`
//! with `Phi = f_x(k+r-1) ... f_x(k+1)`; then the two sides of each control bound. A row
//! `i` of knot `k` lives at index `k m + i` of every per-row buffer.

use std::sync::Arc;

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, Dims, MatrixN, VectorN};
use ddp_core::ControlBounds;

use crate::Constraint;

/// Where the rows of one constraint sit in a knot's row block.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Slot {
    pub offset: usize,
    pub dim: usize,
    pub mixed: bool,
    /// Relative degree `r` (state rows at knot `k` constrain `x_{k+r}`); 0 for mixed rows.
    pub degree: usize,
}

impl Slot {
    /// The time index of the rows of knot `k` (`None` past the horizon `n`).
    #[inline]
    pub fn time(&self, k: usize, n: usize) -> Option<usize> {
        let t = if self.mixed { k } else { k + self.degree };
        (t <= n).then_some(t)
    }

    /// How many knots have this constraint's rows: knots `0 .. count` are those whose
    /// [`Slot::time`] is within the horizon.
    pub fn knots(&self, n: usize) -> usize {
        if self.mixed {
            n
        } else {
            (n + 1).saturating_sub(self.degree).min(n)
        }
    }
}

/// The rows of every knot and their scratch buffers (sized at construction).
pub(crate) struct Rows<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    pub slots: Vec<Slot>,
    /// Rows per knot: every constraint row, then `2 nu` control-bound sides.
    pub m: usize,
    /// First control-bound row of a knot.
    pub bound_offset: usize,
    pub present: Vec<bool>,
    /// `g` at the last linearisation.
    pub g: Vec<f64>,
    /// Tightening margins, eq. (20).
    pub margin: Vec<f64>,
    /// `C` (`g~_u`), eq. (8).
    pub c: Vec<VectorN<NU>>,
    /// `D` (`g~_x`), eq. (8).
    pub d: Vec<VectorN<NX>>,
    /// `g_x` at the row's own time.
    pub gx: Vec<VectorN<NX>>,
    /// `g_u` at the row's own time.
    pub gu: Vec<VectorN<NU>>,
    /// Multipliers of the KKT backward pass, eq. (10).
    pub lambda: Vec<f64>,
    pub sg: Vec<f64>,
    pub sw: Vec<f64>,
    pub zero_u: VectorN<NU>,
    /// `g` of every row along a trajectory ([`Rows::for_each_block`]).
    along: Vec<f64>,
    /// The largest relative degree (0 without state rows): the rows of knots
    /// `k <= n - max_degree` are all within the horizon.
    max_degree: usize,
    w: VectorN<NX>,
    w2: VectorN<NX>,
}

/// The merit terms of the constraint rows along a trajectory (see [`Rows::violation`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Violation {
    /// The merit term: `rho sum max(0, g~)`, or the warm-up's augmented-Lagrangian or barrier sum.
    pub term: f64,
    /// The largest violation of a tightened row.
    pub max: f64,
    /// The largest violation of a tightened row at a knot where two or more rows are violated
    /// at once (inside the overlap of two obstacles: [`crate::Settings::barrier_funnel`]).
    pub overlap: f64,
}

/// The violated rows of one knot seen so far.
#[derive(Default)]
struct KnotViolation {
    count: u32,
    max: f64,
}

impl Violation {
    /// Takes in row value `v` of the knot `knot` (the merit term is summed by the caller). Comparisons rather than `f64::max`, which
    /// handles NaN on every call: a NaN row leaves `max` as `f64::max` would (and makes `term`
    /// NaN, which the line search rejects).
    #[inline(always)]
    fn add(&mut self, knot: &mut KnotViolation, v: f64) {
        if v > 0.0 {
            if v > self.max {
                self.max = v;
            }
            knot.count += 1;
            if v > knot.max {
                knot.max = v;
            }
            if knot.count >= 2 && knot.max > self.overlap {
                self.overlap = knot.max;
            }
        }
    }
}

/// How the merit weighs violations: the exact penalty of the KKT phase, the
/// augmented-Lagrangian term or the relaxed log barrier of the warm-up.
#[derive(Clone, Copy)]
pub(crate) enum Merit<'a> {
    /// `rho sum max(0, g~)`
    Penalty(f64),
    /// `sum (max(0, lambda + rho g~)^2 - lambda^2) / (2 rho)`
    Lagrangian { lambda: &'a [f64], rho: f64 },
    /// `sum B(-g~)` with the relaxed barrier `B` of [`barrier`].
    Barrier { mu: f64, delta: f64 },
}

impl Merit<'_> {
    /// The merit term of row `i` at `v = g~` and its first and second derivatives in `v`: the
    /// weight of `g~_x` in the cost gradient (a multiplier estimate, `>= 0`) and of
    /// `g~_x g~_x^T` in the Gauss-Newton Hessian.
    #[inline]
    pub fn row(&self, i: usize, v: f64) -> (f64, f64, f64) {
        match *self {
            Merit::Penalty(rho) => (rho * v.max(0.0), if v > 0.0 { rho } else { 0.0 }, 0.0),
            Merit::Lagrangian { lambda, rho } => {
                let lam = lambda[i];
                let nu = (lam + rho * v).max(0.0);
                (
                    (nu * nu - lam * lam) / (2.0 * rho),
                    nu,
                    if nu > 0.0 { rho } else { 0.0 },
                )
            }
            Merit::Barrier { mu, delta } => barrier(-v, mu, delta),
        }
    }
}

/// The relaxed logarithmic barrier of a slack `z = -g~` (Hauser and Saccon 2006):
/// `-mu ln z` for `z >= delta`, and below `delta` the quadratic that continues it with the same
/// value, slope and curvature, `mu (((z - 2 delta) / delta)^2 / 2 - 1/2 - ln delta)`. Returns the
/// value and its first and second derivatives in `g~ = -z` (`mu / z` and `mu / z^2` in the
/// interior): finite everywhere, so an infeasible trajectory has a merit, and the quadratic's
/// curvature `mu / delta^2` pushes it back.
#[inline]
pub(crate) fn barrier(z: f64, mu: f64, delta: f64) -> (f64, f64, f64) {
    if z >= delta {
        (-mu * z.ln(), mu / z, mu / (z * z))
    } else {
        let s = (z - 2.0 * delta) / delta;
        (
            mu * (0.5 * s * s - 0.5 - delta.ln()),
            mu * (2.0 * delta - z) / (delta * delta),
            mu / (delta * delta),
        )
    }
}

impl<NX: Dim, NU: Dim> Rows<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    pub fn new(dims: Dims<NX, NU>, slots: Vec<Slot>, cap: usize) -> Self {
        let bound_offset = slots.iter().map(|s| s.dim).sum::<usize>();
        let max_dim = slots.iter().map(|s| s.dim).max().unwrap_or(0).max(1);
        let m = bound_offset + 2 * dims.nu();
        let rows = cap * m;
        let max_degree = slots
            .iter()
            .map(|s| if s.mixed { 0 } else { s.degree })
            .max()
            .unwrap_or(0);
        // The control-bound rows' gradients are constant: `C = g_u = +-e_i`, `D = g_x = 0`.
        let mut c = vec![dims.u_zeros(); rows];
        for k in 0..cap {
            for i in 0..dims.nu() {
                let base = k * m + bound_offset + 2 * i;
                c[base][i] = 1.0;
                c[base + 1][i] = -1.0;
            }
        }
        Self {
            slots,
            m,
            bound_offset,
            present: vec![false; rows],
            g: vec![0.0; rows],
            margin: vec![0.0; rows],
            gu: c.clone(),
            c,
            d: vec![dims.x_zeros(); rows],
            gx: vec![dims.x_zeros(); rows],
            lambda: vec![0.0; rows],
            sg: vec![0.0; max_dim],
            sw: vec![0.0; max_dim],
            zero_u: dims.u_zeros(),
            along: vec![0.0; rows],
            max_degree,
            w: dims.x_zeros(),
            w2: dims.x_zeros(),
        }
    }

    /// Linearises every row of knots `0 .. n` along `(xs, us)`: `g`, `g_x`, `g_u`, and `C`, `D`
    /// of the mixed rows and control bounds; the state rows' `C`, `D` are left to
    /// [`Rows::chain`]. Clears the multipliers of rows beyond the horizon.
    pub fn linearize(
        &mut self,
        constraints: &[Arc<dyn Constraint<NX, NU>>],
        bounds: Option<&ControlBounds<NU>>,
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        n: usize,
    ) {
        let m = self.m;
        for k in 0..n {
            // Every row of the knot is within the horizon (set per constraint otherwise).
            if self.whole_knot(k, n) {
                self.present[k * m..k * m + self.bound_offset].fill(true);
            } else {
                for slot in &self.slots {
                    let base = k * m + slot.offset;
                    let rows = base..base + slot.dim;
                    if slot.time(k, n).is_none() {
                        self.present[rows.clone()].fill(false);
                        self.lambda[rows].fill(0.0);
                    } else {
                        self.present[rows].fill(true);
                    }
                }
            }
            self.linearize_bounds(k, bounds, &us[k]);
        }
        // The Jacobians of each constraint along the knots where its rows are present, in one
        // call ([`Constraint::jacobians_along`]), as the line search evaluates them.
        for (j, slot) in self.slots.iter().enumerate() {
            let count = slot.knots(n);
            if slot.dim == 0 || count == 0 {
                continue;
            }
            let (g, gx, gu) = (
                &mut self.g[slot.offset..],
                &mut self.gx[slot.offset..],
                &mut self.gu[slot.offset..],
            );
            if slot.mixed {
                constraints[j].jacobians_along(0, &xs[..count], &us[..count], g, gx, gu, m);
                for k in 0..count {
                    for i in k * m + slot.offset..k * m + slot.offset + slot.dim {
                        self.c[i].copy_from(&self.gu[i]);
                        self.d[i].copy_from(&self.gx[i]);
                    }
                }
            } else {
                let t0 = slot.degree;
                let zero_u = std::slice::from_ref(&self.zero_u);
                constraints[j].jacobians_along(t0, &xs[t0..t0 + count], zero_u, g, gx, gu, m);
            }
        }
    }

    /// `C = g_x Phi f_u`, `D = g_x Phi f_x` of the state rows of knots `0 .. n` (after
    /// [`Rows::linearize`], with the Jacobians `fx`, `fu` of the dynamics along the same
    /// trajectory): `g(x_t)` with `x_t = f(..f(x_k, u_k)..)`, chained back to knot `k`.
    pub fn chain(&mut self, fx: &[MatrixN<NX, NX>], fu: &[MatrixN<NX, NU>], n: usize) {
        let m = self.m;
        for k in 0..n {
            for slot in &self.slots {
                if slot.mixed {
                    continue;
                }
                let Some(t) = slot.time(k, n) else { continue };
                let base = k * m + slot.offset;
                for i in base..base + slot.dim {
                    self.w.copy_from(&self.gx[i]);
                    for s in (k + 1..t).rev() {
                        self.w2.gemv_tr(1.0, &fx[s], &self.w, 0.0);
                        std::mem::swap(&mut self.w, &mut self.w2);
                    }
                    self.c[i].gemv_tr(1.0, &fu[k], &self.w, 0.0);
                    self.d[i].gemv_tr(1.0, &fx[k], &self.w, 0.0);
                }
            }
        }
    }

    /// Sets `h_con[t]` (`t = 0 ..= n`) to `sum lambda g_xx` of the rows at time `t` with a
    /// positive multiplier (rows linearised along `(xs, us)`).
    pub fn add_hessians(
        &mut self,
        constraints: &[Arc<dyn Constraint<NX, NU>>],
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        n: usize,
        h_con: &mut [MatrixN<NX, NX>],
    ) {
        let m = self.m;
        h_con[..=n].iter_mut().for_each(|h| h.fill(0.0));
        for k in 0..n {
            for (j, slot) in self.slots.iter().enumerate() {
                let Some(t) = slot.time(k, n) else { continue };
                let base = k * m + slot.offset;
                let dim = slot.dim;
                let lambda = &self.lambda[base..base + dim];
                if !lambda.iter().any(|&l| l > 0.0) {
                    continue;
                }
                self.sw[..dim].copy_from_slice(lambda);
                let (x, u) = if slot.mixed {
                    (&xs[k], &us[k])
                } else {
                    (&xs[t], &self.zero_u)
                };
                constraints[j].add_hessian(t, x, u, &self.sw[..dim], &mut h_con[t]);
            }
        }
    }

    /// The control-bound rows of knot `k`: `u_i - hi_i <= 0` and `lo_i - u_i <= 0` (absent where
    /// the bound is infinite or there are none). Their gradients are constant, set in
    /// [`Rows::new`].
    fn linearize_bounds(&mut self, k: usize, bounds: Option<&ControlBounds<NU>>, u: &VectorN<NU>) {
        let base = k * self.m + self.bound_offset;
        for i in 0..u.len() {
            let (up, lo) = (base + 2 * i, base + 2 * i + 1);
            let (hi_v, lo_v) = match bounds {
                Some(b) => (b.upper[i], b.lower[i]),
                None => (f64::INFINITY, f64::NEG_INFINITY),
            };
            self.present[up] = hi_v.is_finite();
            self.g[up] = u[i] - hi_v;
            self.present[lo] = lo_v.is_finite();
            self.g[lo] = lo_v - u[i];
        }
    }

    /// Whether every row of knot `k` lies within the horizon `n` (`k + max_degree <= n`): the
    /// knot's rows are then the one block `k m .. k m + bound_offset`.
    #[inline]
    pub fn whole_knot(&self, k: usize, n: usize) -> bool {
        k + self.max_degree <= n
    }

    /// Visits every constraint row of knots `0 .. n` evaluated along `(xs, us)`, knot by knot,
    /// in blocks of consecutive rows: calls `f(k, first row index, g, margin)` with the block's
    /// `g` and margins (one block per knot where all its rows are within the horizon, one per
    /// constraint near its end). Each constraint is evaluated along the whole trajectory in one
    /// call ([`Constraint::evaluate_along`]) first: the line search evaluates every trial, and
    /// one virtual call per constraint and knot cost more than the circles' arithmetic.
    fn for_each_block(
        &mut self,
        constraints: &[Arc<dyn Constraint<NX, NU>>],
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        n: usize,
        mut f: impl FnMut(usize, usize, &[f64], &[f64]),
    ) {
        let m = self.m;
        for (j, slot) in self.slots.iter().enumerate() {
            let count = slot.knots(n);
            if slot.dim == 0 || count == 0 {
                continue;
            }
            let g = &mut self.along[slot.offset..];
            if slot.mixed {
                constraints[j].evaluate_along(0, &xs[..count], &us[..count], g, m);
            } else {
                let t0 = slot.degree;
                let zero_u = std::slice::from_ref(&self.zero_u);
                constraints[j].evaluate_along(t0, &xs[t0..t0 + count], zero_u, g, m);
            }
        }
        for k in 0..n {
            let base = k * m;
            if self.whole_knot(k, n) {
                let rows = base..base + self.bound_offset;
                f(k, base, &self.along[rows.clone()], &self.margin[rows]);
            } else {
                for slot in &self.slots {
                    if slot.time(k, n).is_some() {
                        let rows = base + slot.offset..base + slot.offset + slot.dim;
                        f(k, rows.start, &self.along[rows.clone()], &self.margin[rows]);
                    }
                }
            }
        }
    }

    /// Whether the augmented Lagrangian's multipliers `lambda` (penalty `rho`) are complementary
    /// to the rows of the last linearisation within `eps`: `min(-g~, lambda / rho) <= eps` on
    /// every constraint row (the control bounds hold by projection), the measure of Conn, Gould
    /// and Toint (1991) that the update `lambda <- max(0, lambda + rho g~)` leaves the
    /// multipliers of rows off their boundary (nearly) unchanged only when they are zero.
    pub fn complementary(&self, lambda: &[f64], rho: f64, n: usize, eps: f64) -> bool {
        (0..n).all(|k| {
            (k * self.m..k * self.m + self.bound_offset)
                .all(|i| !self.present[i] || (-(self.g[i] + self.margin[i])).min(lambda[i] / rho) <= eps)
        })
    }

    /// The merit term of the constraint rows (the control bounds hold by projection), the
    /// largest violation of a tightened row, and the largest at a knot with two or more
    /// violated rows, along `(xs, us)` (rows are visited knot by knot).
    pub fn violation(
        &mut self,
        constraints: &[Arc<dyn Constraint<NX, NU>>],
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        n: usize,
        merit: Merit<'_>,
    ) -> Violation {
        // One sweep per kind of merit, so that the row loop does not branch on it.
        match merit {
            m @ Merit::Penalty(_) => self.violation_of(constraints, xs, us, n, |i, v| m.row(i, v).0),
            m @ Merit::Lagrangian { .. } => self.violation_of(constraints, xs, us, n, |i, v| m.row(i, v).0),
            m @ Merit::Barrier { .. } => self.violation_of(constraints, xs, us, n, |i, v| m.row(i, v).0),
        }
    }

    #[inline(always)]
    fn violation_of(
        &mut self,
        constraints: &[Arc<dyn Constraint<NX, NU>>],
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        n: usize,
        term_of: impl Fn(usize, f64) -> f64,
    ) -> Violation {
        let mut acc = Violation::default();
        let (mut knot, mut at) = (KnotViolation::default(), usize::MAX);
        self.for_each_block(constraints, xs, us, n, |k, first, g, margin| {
            if k != at {
                (knot, at) = (KnotViolation::default(), k);
            }
            for (i, (g, margin)) in (first..).zip(g.iter().zip(margin)) {
                let v = g + margin;
                acc.term += term_of(i, v);
                acc.add(&mut knot, v);
            }
        });
        acc
    }

    /// The first knot whose rows, evaluated along `(xs, us)`, violate a tightened row by more
    /// than `tol`; `None` when there is none.
    pub fn first_violating_knot(
        &mut self,
        constraints: &[Arc<dyn Constraint<NX, NU>>],
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        n: usize,
        tol: f64,
    ) -> Option<usize> {
        let mut first: Option<usize> = None;
        self.for_each_block(constraints, xs, us, n, |k, _, g, margin| {
            if first.is_none() && g.iter().zip(margin).any(|(g, margin)| g + margin > tol) {
                first = Some(k);
            }
        });
        first
    }

    /// Largest violation of the original constraints over `x_1 .. x_n` (state rows) and
    /// `(x_k, u_k)` (mixed rows), regardless of the relative degree and the margins.
    pub fn original_violation(
        &mut self,
        constraints: &[Arc<dyn Constraint<NX, NU>>],
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        n: usize,
    ) -> f64 {
        let mut worst = 0.0f64;
        for (j, slot) in self.slots.iter().enumerate() {
            let c = &constraints[j];
            let g = &mut self.sg[..slot.dim];
            if slot.mixed {
                for k in 0..n {
                    c.evaluate(k, &xs[k], &us[k], g);
                    worst = g.iter().fold(worst, |w, &v| w.max(v));
                }
            } else {
                for t in 1..=n {
                    c.evaluate(t, &xs[t], &self.zero_u, g);
                    worst = g.iter().fold(worst, |w, &v| w.max(v));
                }
            }
        }
        worst
    }

    /// Drops knot 0 of every per-row buffer that carries over between solves (receding horizon).
    pub fn shift(&mut self, n: usize, al_lambda: &mut [f64]) {
        let m = self.m;
        self.lambda.copy_within(m..n * m, 0);
        al_lambda.copy_within(m..n * m, 0);
        self.margin.copy_within(m..n * m, 0);
    }
}
