//! Built-in cost terms.
//!
//! | term | formula | paper |
//! |---|---|---|
//! | [`QuadraticCost`] | `1/2 (x-x_r)^T Q (x-x_r) + 1/2 (u-u_r)^T R (u-u_r)` | P1 / P2 / P3 of `bench/problems.md` |
//! | [`QuadraticTerminal`] | `1/2 (x-x_r)^T Q_f (x-x_r)` | |
//! | [`ControlSquared`] | `w * sum u^2` | DDPEN eq. (5) |
//! | [`SmoothDistance`] | `w * sqrt(|p - g|^2 + eps^2)` on the position `p` | DDPEN eqs. (6) and (9) |
//! | [`ObstacleHinge`] | `w * sum_o ReLU(d - |p - o|)` over a point set | DDPEN eq. (7) |
//! | [`CostSum`], [`TerminalSum`] | `sum_i w_i l_i` | DDPEN eqs. (3), (4), (8) |
//!
//! State-only terms implement [`TerminalCost`]; wrap them in [`StateOnly`] to use them as running
//! costs.
//!
//! ```
//! use std::sync::Arc;

use std::sync::Arc;

use nalgebra::{Const, U1};

use crate::dims::{check_size, Alloc, Allocator, DefaultAllocator, Dim, MatrixN, VectorN, MAX_CONTROLS, MAX_STATES};
use crate::error::{check_finite, check_nonnegative, Error, Result};
use crate::{Cost, CostDerivatives, TerminalCost, TerminalDerivatives, Vector};

/// Checks that `m` is symmetric and positive semidefinite (tolerance relative to its size).
pub fn check_psd<N: Dim>(field: &str, m: &MatrixN<N, N>) -> Result<()>
where
    DefaultAllocator: Allocator<N, N>,
{
    check_finite(field, m.iter())?;
    let scale = m.amax().max(1.0);
    let asym = (m - m.transpose()).amax();
    if asym > 1e-9 * scale {
        return Err(Error::NotPsd {
            field: field.to_string(),
            reason: format!("not symmetric (max |M - M^T| = {asym:e})"),
        });
    }
    let n = m.nrows();
    let eig = nalgebra::DMatrix::from_iterator(n, n, m.iter().copied()).symmetric_eigenvalues();
    let min = eig.min();
    if min < -1e-10 * scale {
        return Err(Error::NotPsd {
            field: field.to_string(),
            reason: format!("smallest eigenvalue is {min:e}"),
        });
    }
    Ok(())
}

fn check_indices<const NX: usize>(field: &str, idx: [usize; 2]) -> Result<()> {
    for (i, &j) in idx.iter().enumerate() {
        if j >= NX {
            return Err(Error::invalid(
                format!("{field}[{i}]"),
                format!("state index {j} out of range for a {NX}-dimensional state"),
            ));
        }
    }
    if idx[0] == idx[1] {
        return Err(Error::invalid(field, "the two position indices must differ"));
    }
    Ok(())
}

/// Checks that a square weight and its reference agree in size (`field` names the weight).
fn check_square<N: Dim>(field: &str, m: &MatrixN<N, N>, reference: &str, r: &VectorN<N>) -> Result<()>
where
    DefaultAllocator: Allocator<N> + Allocator<N, N>,
{
    if m.nrows() != m.ncols() {
        return Err(Error::Shape {
            field: field.to_string(),
            got: format!("({}, {})", m.nrows(), m.ncols()),
            expected: "a square matrix".into(),
        });
    }
    if r.len() != m.nrows() {
        return Err(Error::Shape {
            field: reference.to_string(),
            got: format!("({},)", r.len()),
            expected: format!("({},) like {field}", m.nrows()),
        });
    }
    Ok(())
}

/// `1/2 (x-x_r)^T Q (x-x_r) + 1/2 (u-u_r)^T R (u-u_r)`, at any size: the sizes are those of
/// `Q` and `R`.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadraticCost<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    q: MatrixN<NX, NX>,
    r: MatrixN<NU, NU>,
    x_ref: VectorN<NX>,
    u_ref: VectorN<NU>,
    /// Both weights diagonal: the hot paths use `O(n)` diagonal kernels.
    diagonal: bool,
}

fn is_diagonal<N: Dim>(m: &MatrixN<N, N>) -> bool
where
    DefaultAllocator: Allocator<N, N>,
{
    let n = m.nrows();
    (0..n).all(|i| (0..n).all(|j| i == j || m[(i, j)] == 0.0))
}

/// A diagonal matrix from a slice, checked against the dimension `N` (compile-time or the
/// slice's own length).
fn diagonal_of<N: Dim>(field: &str, d: &[f64], limit: usize) -> Result<MatrixN<N, N>>
where
    DefaultAllocator: Allocator<N> + Allocator<N, N>,
{
    check_nonnegative(field, d.iter())?;
    check_size(&format!("len({field})"), d.len(), N::try_to_usize(), limit)?;
    let n = N::from_usize(d.len());
    Ok(MatrixN::from_diagonal(&VectorN::from_row_slice_generic(n, U1, d)))
}

impl<NX: Dim, NU: Dim> QuadraticCost<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Checks that `q` and `r` are symmetric PSD, the references finite, and the sizes agree.
    pub fn new(q: MatrixN<NX, NX>, r: MatrixN<NU, NU>, x_ref: VectorN<NX>, u_ref: VectorN<NU>) -> Result<Self> {
        check_square("q", &q, "x_ref", &x_ref)?;
        check_square("r", &r, "u_ref", &u_ref)?;
        check_size("q.shape[0]", q.nrows(), NX::try_to_usize(), MAX_STATES)?;
        check_size("r.shape[0]", r.nrows(), NU::try_to_usize(), MAX_CONTROLS)?;
        check_psd("q", &q)?;
        check_psd("r", &r)?;
        check_finite("x_ref", x_ref.iter())?;
        check_finite("u_ref", u_ref.iter())?;
        let diagonal = is_diagonal(&q) && is_diagonal(&r);
        Ok(Self {
            q,
            r,
            x_ref,
            u_ref,
            diagonal,
        })
    }

    /// Diagonal weights; negative or non-finite entries are rejected.
    pub fn diagonal(q: &[f64], r: &[f64], x_ref: VectorN<NX>, u_ref: VectorN<NU>) -> Result<Self> {
        let q = diagonal_of::<NX>("q", q, MAX_STATES)?;
        let r = diagonal_of::<NU>("r", r, MAX_CONTROLS)?;
        Self::new(q, r, x_ref, u_ref)
    }

    /// The state weight `Q`.
    pub fn q(&self) -> &MatrixN<NX, NX> {
        &self.q
    }
    /// The control weight `R`.
    pub fn r(&self) -> &MatrixN<NU, NU> {
        &self.r
    }
    /// The state reference.
    pub fn x_ref(&self) -> &VectorN<NX> {
        &self.x_ref
    }

    /// With diagonal weights: `w` times the gradients and the diagonals of `l_xx`, `l_uu`, added
    /// to `d` or (`SET`) written into it as `0.0 + a`, the same operation as the sum into zeroed
    /// entries (the other entries untouched); returns `w * l(x, u)`.
    #[inline(always)]
    fn diagonal_derivatives<const SET: bool>(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        w: f64,
        d: &mut CostDerivatives<NX, NU>,
    ) -> f64 {
        let put = |entry: &mut f64, a: f64| *entry = if SET { 0.0 + a } else { *entry + a };
        let mut v = 0.0;
        for i in 0..x.len() {
            let dx = x[i] - self.x_ref[i];
            let qi = w * self.q[(i, i)];
            put(&mut d.lx[i], qi * dx);
            put(&mut d.lxx[(i, i)], qi);
            v += qi * dx * dx;
        }
        for i in 0..u.len() {
            let du = u[i] - self.u_ref[i];
            let ri = w * self.r[(i, i)];
            put(&mut d.lu[i], ri * du);
            put(&mut d.luu[(i, i)], ri);
            v += ri * du * du;
        }
        0.5 * v
    }
}

impl<const NX: usize, const NU: usize> QuadraticCost<Const<NX>, Const<NU>> {
    /// P1's cost (Crocoddyl's `ActionModelUnicycle`): `1/2 (w_x^2 |x|^2 + w_u^2 |u|^2)`.
    pub fn weighted_norms(w_x: f64, w_u: f64) -> Result<Self> {
        check_finite("w_x", [w_x].iter())?;
        check_finite("w_u", [w_u].iter())?;
        Self::diagonal(&[w_x * w_x; NX], &[w_u * w_u; NU], Vector::zeros(), Vector::zeros())
    }
}

impl<NX: Dim, NU: Dim> Cost<NX, NU> for QuadraticCost<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn value(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> f64 {
        if self.diagonal {
            let sx: f64 = (0..x.len())
                .map(|i| {
                    let d = x[i] - self.x_ref[i];
                    self.q[(i, i)] * d * d
                })
                .sum();
            let su: f64 = (0..u.len())
                .map(|i| {
                    let d = u[i] - self.u_ref[i];
                    self.r[(i, i)] * d * d
                })
                .sum();
            return 0.5 * (sx + su);
        }
        let dx = x - &self.x_ref;
        let du = u - &self.u_ref;
        0.5 * (dx.dot(&(&self.q * &dx)) + du.dot(&(&self.r * &du)))
    }
    fn add_derivatives(&self, x: &VectorN<NX>, u: &VectorN<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        if self.diagonal {
            return self.diagonal_derivatives::<false>(x, u, w, d);
        }
        let dx = x - &self.x_ref;
        let du = u - &self.u_ref;
        let qdx = &self.q * &dx;
        let rdu = &self.r * &du;
        d.lx.axpy(w, &qdx, 1.0);
        d.lu.axpy(w, &rdu, 1.0);
        d.lxx += &self.q * w;
        d.luu += &self.r * w;
        0.5 * w * (dx.dot(&qdx) + du.dot(&rdu))
    }
    fn set_derivatives(&self, x: &VectorN<NX>, u: &VectorN<NU>, d: &mut CostDerivatives<NX, NU>) -> f64 {
        if !self.diagonal {
            d.clear();
            return self.add_derivatives(x, u, 1.0, d);
        }
        // `add_derivatives` with `w = 1` into zeroed derivatives, written without reading them
        // back: only the diagonal blocks' diagonals and the gradients are not zero.
        d.lxx.as_mut_slice().fill(0.0);
        d.luu.as_mut_slice().fill(0.0);
        d.lux.as_mut_slice().fill(0.0);
        self.diagonal_derivatives::<true>(x, u, 1.0, d)
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (Some(self.q.nrows()), Some(self.r.nrows()))
    }
}

/// Terminal `1/2 (x-x_r)^T Q_f (x-x_r)`, at any size.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadraticTerminal<NX: Dim>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    qf: MatrixN<NX, NX>,
    x_ref: VectorN<NX>,
    diagonal: bool,
}

impl<NX: Dim> QuadraticTerminal<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// Checks that `qf` is symmetric PSD, `x_ref` finite, and the sizes agree.
    pub fn new(qf: MatrixN<NX, NX>, x_ref: VectorN<NX>) -> Result<Self> {
        check_square("qf", &qf, "x_ref", &x_ref)?;
        check_size("qf.shape[0]", qf.nrows(), NX::try_to_usize(), MAX_STATES)?;
        check_psd("qf", &qf)?;
        check_finite("x_ref", x_ref.iter())?;
        let diagonal = is_diagonal(&qf);
        Ok(Self { qf, x_ref, diagonal })
    }
    /// Diagonal weights; negative or non-finite entries are rejected.
    pub fn diagonal(qf: &[f64], x_ref: VectorN<NX>) -> Result<Self> {
        Self::new(diagonal_of::<NX>("qf", qf, MAX_STATES)?, x_ref)
    }
    /// The weight `Q_f`.
    pub fn qf(&self) -> &MatrixN<NX, NX> {
        &self.qf
    }
    /// The reference state.
    pub fn x_ref(&self) -> &VectorN<NX> {
        &self.x_ref
    }
}

impl<NX: Dim> TerminalCost<NX> for QuadraticTerminal<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    fn value(&self, x: &VectorN<NX>) -> f64 {
        if self.diagonal {
            return 0.5
                * (0..x.len())
                    .map(|i| {
                        let d = x[i] - self.x_ref[i];
                        self.qf[(i, i)] * d * d
                    })
                    .sum::<f64>();
        }
        let dx = x - &self.x_ref;
        0.5 * dx.dot(&(&self.qf * &dx))
    }
    fn add_derivatives(&self, x: &VectorN<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
        let dx = x - &self.x_ref;
        let q = &self.qf * &dx;
        d.lx.axpy(w, &q, 1.0);
        d.lxx += &self.qf * w;
        0.5 * w * dx.dot(&q)
    }
    fn state_size(&self) -> Option<usize> {
        Some(self.qf.nrows())
    }
}

/// `w * sum u^2` (DDPEN eq. 5), at any size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlSquared {
    weight: f64,
}

impl ControlSquared {
    /// `weight` must be finite and non-negative.
    pub fn new(weight: f64) -> Result<Self> {
        check_nonnegative("weight", [weight].iter())?;
        Ok(Self { weight })
    }
}

impl<NX: Dim, NU: Dim> Cost<NX, NU> for ControlSquared
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn value(&self, _x: &VectorN<NX>, u: &VectorN<NU>) -> f64 {
        self.weight * u.norm_squared()
    }
    fn add_derivatives(&self, _x: &VectorN<NX>, u: &VectorN<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        let c = w * self.weight;
        d.lu.axpy(2.0 * c, u, 1.0);
        for i in 0..u.len() {
            d.luu[(i, i)] += 2.0 * c;
        }
        c * u.norm_squared()
    }
}

/// Smooth distance of the planar position to a point: `w * sqrt(|p - g|^2 + eps^2)` where
/// `p = (x[i0], x[i1])`. The goal cost of DDPEN eq. (6) and the sub-goal cost of eq. (9), with
/// `eps > 0` making it twice differentiable at the target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmoothDistance<const NX: usize> {
    target: [f64; 2],
    indices: [usize; 2],
    eps: f64,
    weight: f64,
}

impl<const NX: usize> SmoothDistance<NX> {
    /// Distance to a goal (DDPEN eq. 6). `indices` are the state indices of the position.
    pub fn goal(target: [f64; 2], indices: [usize; 2], eps: f64, weight: f64) -> Result<Self> {
        check_finite("target", target.iter())?;
        check_indices::<NX>("indices", indices)?;
        if !(eps.is_finite() && eps > 0.0) {
            return Err(Error::invalid("eps", format!("must be finite and > 0, got {eps}")));
        }
        check_nonnegative("weight", [weight].iter())?;
        Ok(Self {
            target,
            indices,
            eps,
            weight,
        })
    }

    /// Distance to a sub-goal (DDPEN eq. 9); the same term as [`SmoothDistance::goal`].
    pub fn sub_goal(target: [f64; 2], indices: [usize; 2], eps: f64, weight: f64) -> Result<Self> {
        Self::goal(target, indices, eps, weight)
    }

    /// The point this term pulls towards.
    pub fn target(&self) -> [f64; 2] {
        self.target
    }
}

impl<const NX: usize> TerminalCost<Const<NX>> for SmoothDistance<NX> {
    fn value(&self, x: &Vector<NX>) -> f64 {
        let [i, j] = self.indices;
        let (ex, ey) = (x[i] - self.target[0], x[j] - self.target[1]);
        self.weight * (ex * ex + ey * ey + self.eps * self.eps).sqrt()
    }
    fn add_derivatives(&self, x: &Vector<NX>, w: f64, d: &mut TerminalDerivatives<Const<NX>>) -> f64 {
        let [i, j] = self.indices;
        let e = [x[i] - self.target[0], x[j] - self.target[1]];
        let s = (e[0] * e[0] + e[1] * e[1] + self.eps * self.eps).sqrt();
        let c = w * self.weight;
        // grad = e / s, Hessian = (I - e e^T / s^2) / s.
        let idx = [i, j];
        for a in 0..2 {
            d.lx[idx[a]] += c * e[a] / s;
            for b in 0..2 {
                let delta = if a == b { 1.0 } else { 0.0 };
                d.lxx[(idx[a], idx[b])] += c * (delta - e[a] * e[b] / (s * s)) / s;
            }
        }
        c * s
    }
}

/// Obstacle hinge `w * sum_o ReLU(d - |p - o|)` over a point set (DDPEN eq. 7).
///
/// The hinge is piecewise linear in the distance; its Hessian is the curvature of `-|p - o|`,
/// which is negative semidefinite. DDP needs a PSD `l_xx`, so only the gradient is added (a
/// Gauss-Newton model of the term); the line search absorbs the difference.
#[derive(Debug, Clone, PartialEq)]
pub struct ObstacleHinge<const NX: usize> {
    points: Vec<[f64; 2]>,
    margin: f64,
    indices: [usize; 2],
    weight: f64,
}

impl<const NX: usize> ObstacleHinge<NX> {
    /// `points`: obstacle points; `margin`: the distance `d` below which the hinge is active.
    pub fn new(points: Vec<[f64; 2]>, margin: f64, indices: [usize; 2], weight: f64) -> Result<Self> {
        for (k, p) in points.iter().enumerate() {
            check_finite(&format!("points[{k}]"), p.iter())?;
        }
        check_indices::<NX>("indices", indices)?;
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(Error::invalid(
                "margin",
                format!("must be finite and >= 0, got {margin}"),
            ));
        }
        check_nonnegative("weight", [weight].iter())?;
        Ok(Self {
            points,
            margin,
            indices,
            weight,
        })
    }
    /// The obstacle points.
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points
    }
}

impl<const NX: usize> TerminalCost<Const<NX>> for ObstacleHinge<NX> {
    fn value(&self, x: &Vector<NX>) -> f64 {
        let [i, j] = self.indices;
        let mut sum = 0.0;
        for o in &self.points {
            let dist = (x[i] - o[0]).hypot(x[j] - o[1]);
            sum += (self.margin - dist).max(0.0);
        }
        self.weight * sum
    }
    fn add_derivatives(&self, x: &Vector<NX>, w: f64, d: &mut TerminalDerivatives<Const<NX>>) -> f64 {
        let [i, j] = self.indices;
        let c = w * self.weight;
        let mut sum = 0.0;
        for o in &self.points {
            let (ex, ey) = (x[i] - o[0], x[j] - o[1]);
            let dist = ex.hypot(ey);
            if dist < self.margin {
                sum += self.margin - dist;
                if dist > 1e-12 {
                    d.lx[i] -= c * ex / dist;
                    d.lx[j] -= c * ey / dist;
                }
            }
        }
        c * sum
    }
}

/// Uses a state-only term (any [`TerminalCost`]) as a running cost that ignores `u`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StateOnly<T>(pub T);

impl<NX: Dim, NU: Dim, T: TerminalCost<NX>> Cost<NX, NU> for StateOnly<T>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn value(&self, x: &VectorN<NX>, _u: &VectorN<NU>) -> f64 {
        self.0.value(x)
    }
    fn add_derivatives(&self, x: &VectorN<NX>, _u: &VectorN<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        // Lend the state blocks to the terminal term: swaps of owned buffers, with empty
        // placeholders for a run-time size (no copy, no allocation).
        let (r, _) = x.shape_generic();
        let ph = if NX::try_to_usize().is_some() {
            r
        } else {
            NX::from_usize(0)
        };
        let mut t = TerminalDerivatives {
            lx: std::mem::replace(&mut d.lx, VectorN::zeros_generic(ph, U1)),
            lxx: std::mem::replace(&mut d.lxx, MatrixN::zeros_generic(ph, ph)),
        };
        let v = self.0.add_derivatives(x, w, &mut t);
        d.lx = t.lx;
        d.lxx = t.lxx;
        v
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (self.0.state_size(), NU::try_to_usize())
    }
}

/// Weighted sum of running costs, `sum_i w_i l_i(x, u)` (DDPEN eqs. 3 and 8).
pub struct CostSum<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    terms: Vec<(f64, Arc<dyn Cost<NX, NU>>)>,
}

impl<NX: Dim, NU: Dim> Clone for CostSum<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn clone(&self) -> Self {
        Self {
            terms: self.terms.clone(),
        }
    }
}

impl<NX: Dim, NU: Dim> Default for CostSum<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn default() -> Self {
        Self { terms: Vec::new() }
    }
}

impl<NX: Dim, NU: Dim> CostSum<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// An empty sum (value 0).
    pub fn new() -> Self {
        Self { terms: Vec::new() }
    }
    /// Adds `weight * term`.
    pub fn with(mut self, weight: f64, term: Arc<dyn Cost<NX, NU>>) -> Self {
        self.terms.push((weight, term));
        self
    }
    /// Adds `weight * term`; rejects a negative or non-finite weight.
    pub fn push(&mut self, weight: f64, term: Arc<dyn Cost<NX, NU>>) -> Result<()> {
        check_nonnegative(&format!("weights[{}]", self.terms.len()), [weight].iter())?;
        self.terms.push((weight, term));
        Ok(())
    }
    /// Number of terms.
    pub fn len(&self) -> usize {
        self.terms.len()
    }
    /// Whether the sum has no terms.
    pub fn is_empty(&self) -> bool {
        self.terms.is_empty()
    }
}

impl<NX: Dim, NU: Dim> Cost<NX, NU> for CostSum<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn value(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> f64 {
        self.terms.iter().map(|(w, t)| w * t.value(x, u)).sum()
    }
    fn add_derivatives(&self, x: &VectorN<NX>, u: &VectorN<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        self.terms
            .iter()
            .map(|(wi, t)| t.add_derivatives(x, u, w * wi, d))
            .sum()
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        let mut out = (NX::try_to_usize(), NU::try_to_usize());
        for (_, t) in &self.terms {
            let (a, b) = t.sizes();
            out = (out.0.or(a), out.1.or(b));
        }
        out
    }
}

/// Weighted sum of terminal costs (DDPEN eq. 4).
pub struct TerminalSum<NX: Dim>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    terms: Vec<(f64, Arc<dyn TerminalCost<NX>>)>,
}

impl<NX: Dim> Clone for TerminalSum<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    fn clone(&self) -> Self {
        Self {
            terms: self.terms.clone(),
        }
    }
}

impl<NX: Dim> Default for TerminalSum<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    fn default() -> Self {
        Self { terms: Vec::new() }
    }
}

impl<NX: Dim> TerminalSum<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// An empty sum (value 0).
    pub fn new() -> Self {
        Self { terms: Vec::new() }
    }
    /// Adds `weight * term`.
    pub fn with(mut self, weight: f64, term: Arc<dyn TerminalCost<NX>>) -> Self {
        self.terms.push((weight, term));
        self
    }
    /// Adds `weight * term`; rejects a negative or non-finite weight.
    pub fn push(&mut self, weight: f64, term: Arc<dyn TerminalCost<NX>>) -> Result<()> {
        check_nonnegative(&format!("weights[{}]", self.terms.len()), [weight].iter())?;
        self.terms.push((weight, term));
        Ok(())
    }
}

impl<NX: Dim> TerminalCost<NX> for TerminalSum<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    fn value(&self, x: &VectorN<NX>) -> f64 {
        self.terms.iter().map(|(w, t)| w * t.value(x)).sum()
    }
    fn add_derivatives(&self, x: &VectorN<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
        self.terms.iter().map(|(wi, t)| t.add_derivatives(x, w * wi, d)).sum()
    }
    fn state_size(&self) -> Option<usize> {
        self.terms
            .iter()
            .fold(NX::try_to_usize(), |acc, (_, t)| acc.or(t.state_size()))
    }
}

/// A zero terminal cost.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NoTerminalCost;

impl<NX: Dim> TerminalCost<NX> for NoTerminalCost
where
    DefaultAllocator: Alloc<NX, NX>,
{
    fn value(&self, _x: &VectorN<NX>) -> f64 {
        0.0
    }
    fn add_derivatives(&self, _x: &VectorN<NX>, _w: f64, _d: &mut TerminalDerivatives<NX>) -> f64 {
        0.0
    }
}
