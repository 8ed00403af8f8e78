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
//! use ddp_core::costs::{CostSum, ControlSquared, SmoothDistance, StateOnly};
//! use ddp_core::{Cost, Vector};
//! let goal = SmoothDistance::<3>::goal([4.0, 0.0], [0, 1], 1e-3, 1.0).unwrap();
//! let l = CostSum::<3, 2>::new()
//!     .with(1.0, Arc::new(ControlSquared::new(0.1).unwrap()))
//!     .with(1.0, Arc::new(StateOnly(goal)));
//! let v = l.value(&Vector::<3>::zeros(), &Vector::<2>::new(1.0, 0.0));
//! assert!((v - (0.1 + (16.0f64 + 1e-6).sqrt())).abs() < 1e-12);
//! ```

use std::sync::Arc;

use crate::error::{check_finite, check_nonnegative, Error, Result};
use crate::{Cost, CostDerivatives, Matrix, TerminalCost, TerminalDerivatives, Vector};

/// Checks that `m` is symmetric and positive semidefinite (tolerance relative to its size).
pub fn check_psd<const N: usize>(field: &str, m: &Matrix<N, N>) -> Result<()> {
    check_finite(field, m.iter())?;
    let scale = m.amax().max(1.0);
    let asym = (m - m.transpose()).amax();
    if asym > 1e-9 * scale {
        return Err(Error::NotPsd {
            field: field.to_string(),
            reason: format!("not symmetric (max |M - M^T| = {asym:e})"),
        });
    }
    let eig = nalgebra::DMatrix::from_iterator(N, N, m.iter().copied()).symmetric_eigenvalues();
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

/// `1/2 (x-x_r)^T Q (x-x_r) + 1/2 (u-u_r)^T R (u-u_r)`.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadraticCost<const NX: usize, const NU: usize> {
    q: Matrix<NX, NX>,
    r: Matrix<NU, NU>,
    x_ref: Vector<NX>,
    u_ref: Vector<NU>,
    /// Both weights diagonal: the hot paths use `O(n)` diagonal kernels.
    diagonal: bool,
}

fn is_diagonal<const N: usize>(m: &Matrix<N, N>) -> bool {
    (0..N).all(|i| (0..N).all(|j| i == j || m[(i, j)] == 0.0))
}

impl<const NX: usize, const NU: usize> QuadraticCost<NX, NU> {
    /// Checks that `q` and `r` are symmetric PSD and the references finite.
    pub fn new(q: Matrix<NX, NX>, r: Matrix<NU, NU>, x_ref: Vector<NX>, u_ref: Vector<NU>) -> Result<Self> {
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
    pub fn diagonal(q: &[f64; NX], r: &[f64; NU], x_ref: Vector<NX>, u_ref: Vector<NU>) -> Result<Self> {
        check_nonnegative("q", q.iter())?;
        check_nonnegative("r", r.iter())?;
        Self::new(
            Matrix::from_diagonal(&Vector::from_row_slice(q)),
            Matrix::from_diagonal(&Vector::from_row_slice(r)),
            x_ref,
            u_ref,
        )
    }

    /// P1's cost (Crocoddyl's `ActionModelUnicycle`): `1/2 (w_x^2 |x|^2 + w_u^2 |u|^2)`.
    pub fn weighted_norms(w_x: f64, w_u: f64) -> Result<Self> {
        check_finite("w_x", [w_x].iter())?;
        check_finite("w_u", [w_u].iter())?;
        Self::diagonal(&[w_x * w_x; NX], &[w_u * w_u; NU], Vector::zeros(), Vector::zeros())
    }

    /// The state weight `Q`.
    pub fn q(&self) -> &Matrix<NX, NX> {
        &self.q
    }
    /// The control weight `R`.
    pub fn r(&self) -> &Matrix<NU, NU> {
        &self.r
    }
    /// The state reference.
    pub fn x_ref(&self) -> &Vector<NX> {
        &self.x_ref
    }
}

impl<const NX: usize, const NU: usize> Cost<NX, NU> for QuadraticCost<NX, NU> {
    fn value(&self, x: &Vector<NX>, u: &Vector<NU>) -> f64 {
        let dx = x - self.x_ref;
        let du = u - self.u_ref;
        if self.diagonal {
            let sx: f64 = (0..NX).map(|i| self.q[(i, i)] * dx[i] * dx[i]).sum();
            let su: f64 = (0..NU).map(|i| self.r[(i, i)] * du[i] * du[i]).sum();
            return 0.5 * (sx + su);
        }
        0.5 * (dx.dot(&(self.q * dx)) + du.dot(&(self.r * du)))
    }
    fn add_derivatives(&self, x: &Vector<NX>, u: &Vector<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        let dx = x - self.x_ref;
        let du = u - self.u_ref;
        if self.diagonal {
            let mut v = 0.0;
            for i in 0..NX {
                let qi = w * self.q[(i, i)];
                d.lx[i] += qi * dx[i];
                d.lxx[(i, i)] += qi;
                v += qi * dx[i] * dx[i];
            }
            for i in 0..NU {
                let ri = w * self.r[(i, i)];
                d.lu[i] += ri * du[i];
                d.luu[(i, i)] += ri;
                v += ri * du[i] * du[i];
            }
            return 0.5 * v;
        }
        let qdx = self.q * dx;
        let rdu = self.r * du;
        d.lx.axpy(w, &qdx, 1.0);
        d.lu.axpy(w, &rdu, 1.0);
        d.lxx += w * self.q;
        d.luu += w * self.r;
        0.5 * w * (dx.dot(&qdx) + du.dot(&rdu))
    }
}

/// Terminal `1/2 (x-x_r)^T Q_f (x-x_r)`.
#[derive(Debug, Clone, PartialEq)]
pub struct QuadraticTerminal<const NX: usize> {
    qf: Matrix<NX, NX>,
    x_ref: Vector<NX>,
    diagonal: bool,
}

impl<const NX: usize> QuadraticTerminal<NX> {
    /// Checks that `qf` is symmetric PSD and `x_ref` finite.
    pub fn new(qf: Matrix<NX, NX>, x_ref: Vector<NX>) -> Result<Self> {
        check_psd("qf", &qf)?;
        check_finite("x_ref", x_ref.iter())?;
        let diagonal = is_diagonal(&qf);
        Ok(Self { qf, x_ref, diagonal })
    }
    /// Diagonal weights; negative or non-finite entries are rejected.
    pub fn diagonal(qf: &[f64; NX], x_ref: Vector<NX>) -> Result<Self> {
        check_nonnegative("qf", qf.iter())?;
        Self::new(Matrix::from_diagonal(&Vector::from_row_slice(qf)), x_ref)
    }
    /// The weight `Q_f`.
    pub fn qf(&self) -> &Matrix<NX, NX> {
        &self.qf
    }
    /// The reference state.
    pub fn x_ref(&self) -> &Vector<NX> {
        &self.x_ref
    }
}

impl<const NX: usize> TerminalCost<NX> for QuadraticTerminal<NX> {
    fn value(&self, x: &Vector<NX>) -> f64 {
        let dx = x - self.x_ref;
        if self.diagonal {
            return 0.5 * (0..NX).map(|i| self.qf[(i, i)] * dx[i] * dx[i]).sum::<f64>();
        }
        0.5 * dx.dot(&(self.qf * dx))
    }
    fn add_derivatives(&self, x: &Vector<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
        let dx = x - self.x_ref;
        let q = self.qf * dx;
        d.lx.axpy(w, &q, 1.0);
        d.lxx += w * self.qf;
        0.5 * w * dx.dot(&q)
    }
}

/// `w * sum u^2` (DDPEN eq. 5).
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

impl<const NX: usize, const NU: usize> Cost<NX, NU> for ControlSquared {
    fn value(&self, _x: &Vector<NX>, u: &Vector<NU>) -> f64 {
        self.weight * u.norm_squared()
    }
    fn add_derivatives(&self, _x: &Vector<NX>, u: &Vector<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        let c = w * self.weight;
        d.lu.axpy(2.0 * c, u, 1.0);
        for i in 0..NU {
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

impl<const NX: usize> TerminalCost<NX> for SmoothDistance<NX> {
    fn value(&self, x: &Vector<NX>) -> f64 {
        let [i, j] = self.indices;
        let (ex, ey) = (x[i] - self.target[0], x[j] - self.target[1]);
        self.weight * (ex * ex + ey * ey + self.eps * self.eps).sqrt()
    }
    fn add_derivatives(&self, x: &Vector<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
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

impl<const NX: usize> TerminalCost<NX> for ObstacleHinge<NX> {
    fn value(&self, x: &Vector<NX>) -> f64 {
        let [i, j] = self.indices;
        let mut sum = 0.0;
        for o in &self.points {
            let dist = (x[i] - o[0]).hypot(x[j] - o[1]);
            sum += (self.margin - dist).max(0.0);
        }
        self.weight * sum
    }
    fn add_derivatives(&self, x: &Vector<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
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

impl<const NX: usize, const NU: usize, T: TerminalCost<NX>> Cost<NX, NU> for StateOnly<T> {
    fn value(&self, x: &Vector<NX>, _u: &Vector<NU>) -> f64 {
        self.0.value(x)
    }
    fn add_derivatives(&self, x: &Vector<NX>, _u: &Vector<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        let mut t = TerminalDerivatives { lx: d.lx, lxx: d.lxx };
        let v = self.0.add_derivatives(x, w, &mut t);
        d.lx = t.lx;
        d.lxx = t.lxx;
        v
    }
}

/// Weighted sum of running costs, `sum_i w_i l_i(x, u)` (DDPEN eqs. 3 and 8).
#[derive(Clone, Default)]
pub struct CostSum<const NX: usize, const NU: usize> {
    terms: Vec<(f64, Arc<dyn Cost<NX, NU>>)>,
}

impl<const NX: usize, const NU: usize> CostSum<NX, NU> {
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

impl<const NX: usize, const NU: usize> Cost<NX, NU> for CostSum<NX, NU> {
    fn value(&self, x: &Vector<NX>, u: &Vector<NU>) -> f64 {
        self.terms.iter().map(|(w, t)| w * t.value(x, u)).sum()
    }
    fn add_derivatives(&self, x: &Vector<NX>, u: &Vector<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        self.terms
            .iter()
            .map(|(wi, t)| t.add_derivatives(x, u, w * wi, d))
            .sum()
    }
}

/// Weighted sum of terminal costs (DDPEN eq. 4).
#[derive(Clone, Default)]
pub struct TerminalSum<const NX: usize> {
    terms: Vec<(f64, Arc<dyn TerminalCost<NX>>)>,
}

impl<const NX: usize> TerminalSum<NX> {
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

impl<const NX: usize> TerminalCost<NX> for TerminalSum<NX> {
    fn value(&self, x: &Vector<NX>) -> f64 {
        self.terms.iter().map(|(w, t)| w * t.value(x)).sum()
    }
    fn add_derivatives(&self, x: &Vector<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
        self.terms.iter().map(|(wi, t)| t.add_derivatives(x, w * wi, d)).sum()
    }
}

/// A zero terminal cost.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct NoTerminalCost;

impl<const NX: usize> TerminalCost<NX> for NoTerminalCost {
    fn value(&self, _x: &Vector<NX>) -> f64 {
        0.0
    }
    fn add_derivatives(&self, _x: &Vector<NX>, _w: f64, _d: &mut TerminalDerivatives<NX>) -> f64 {
        0.0
    }
}
