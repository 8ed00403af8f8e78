//! Box-constrained QP by projected Newton (Tassa, Mansard & Todorov, ICRA 2014, Algorithm 3):
//!
//! ```text
//! min_x  1/2 x^T H x + g^T x   s.t.  lower <= x <= upper
//! ```
//!
//! Used by box-DDP for the control step at each knot. At the solution the *free* set (controls not
//! clamped at a bound) defines the feedback: `K_f = -H_ff^{-1} Q_ux,f`, clamped rows zero.

use nalgebra::Dim;

use crate::dims::{Allocator, DefaultAllocator, MatrixN, VectorN};
use crate::kernels::{cholesky_in_place, cholesky_solve_in_place, mul_vec_add};

/// Outcome of [`box_qp`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxQpStatus {
    /// The projected gradient vanished or the improvement became negligible.
    Converged,
    /// Every variable ended clamped at a bound.
    AllClamped,
    /// The Hessian restricted to the free set was not positive definite.
    NotPositiveDefinite,
    /// The Armijo line search found no decrease.
    LineSearchFailed,
    /// The iteration limit was reached (the iterate is still feasible and usable).
    MaxIterations,
}

/// The problem data, result and scratch of [`box_qp`] for `N` variables, allocated once, so that
/// a solve allocates nothing at run-time sizes either (box-DDP solves one QP per knot and
/// backward pass).
#[derive(Debug, Clone)]
pub struct BoxQp<N: Dim>
where
    DefaultAllocator: Allocator<N> + Allocator<N, N>,
{
    /// Lower bounds of `x` (set before [`box_qp`]; may be `-inf`).
    pub lower: VectorN<N>,
    /// Upper bounds of `x` (may be `inf`).
    pub upper: VectorN<N>,
    /// The minimiser (always within the bounds).
    pub x: VectorN<N>,
    /// `free[i]` is true when `x[i]` is not clamped at a bound.
    pub free: Vec<bool>,
    /// In its lower triangle, the Cholesky factor (as [`cholesky_in_place`] leaves it) of `H`
    /// with clamped rows and columns replaced by the identity, so that
    /// [`cholesky_solve_in_place`] with it gives the free-subspace Newton step (clamped entries
    /// pass through). Valid when [`BoxQpReport::factored`].
    pub chol: MatrixN<N, N>,
    grad: VectorN<N>,
    dx: VectorN<N>,
    x_try: VectorN<N>,
    hx: VectorN<N>,
    new_free: Vec<bool>,
}

/// How [`box_qp`] ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoxQpReport {
    /// How the iteration ended.
    pub status: BoxQpStatus,
    /// Newton iterations used.
    pub iterations: usize,
    /// [`BoxQp::chol`] holds the factor of the final free set (false only when that matrix is
    /// not positive definite).
    pub factored: bool,
}

impl<N: Dim> BoxQp<N>
where
    DefaultAllocator: Allocator<N> + Allocator<N, N>,
{
    /// Buffers for `n` variables (`n` must equal `N` where that is fixed), unbounded.
    pub fn new(n: N) -> Self {
        let z = VectorN::<N>::zeros_generic(n, nalgebra::U1);
        Self {
            lower: VectorN::from_element_generic(n, nalgebra::U1, f64::NEG_INFINITY),
            upper: VectorN::from_element_generic(n, nalgebra::U1, f64::INFINITY),
            x: z.clone(),
            free: vec![true; n.value()],
            chol: MatrixN::zeros_generic(n, n),
            grad: z.clone(),
            dx: z.clone(),
            x_try: z.clone(),
            hx: z,
            new_free: vec![true; n.value()],
        }
    }

    /// `x' g + 1/2 x' H x` at `x` (one of the buffers, passed by the caller).
    fn value(hx: &mut VectorN<N>, h: &MatrixN<N, N>, g: &VectorN<N>, x: &VectorN<N>) -> f64 {
        mul_vec_add(hx, None, h, x);
        x.dot(g) + 0.5 * x.dot(hx)
    }

    /// The free set at `x` into `new_free`: a variable is clamped when it sits at a bound and
    /// the gradient pushes it further out.
    fn free_set(&mut self) {
        for (i, f) in self.new_free.iter_mut().enumerate() {
            let (x, g) = (self.x[i], self.grad[i]);
            *f = !((x <= self.lower[i] && g > 0.0) || (x >= self.upper[i] && g < 0.0));
        }
    }

    /// Factors `H` with the rows and columns of clamped variables replaced by those of the
    /// identity (the free set `free`) into `chol`.
    fn factor(&mut self, h: &MatrixN<N, N>) -> bool {
        let n = self.free.len();
        for j in 0..n {
            for i in 0..n {
                self.chol[(i, j)] = if self.free[i] && self.free[j] {
                    h[(i, j)]
                } else if i == j {
                    1.0
                } else {
                    0.0
                };
            }
        }
        cholesky_in_place(&mut self.chol)
    }

    /// `x_try = clamp(x + step dx)`.
    fn trial(&mut self, step: f64) {
        for i in 0..self.free.len() {
            self.x_try[i] = (self.x[i] + step * self.dx[i]).clamp(self.lower[i], self.upper[i]);
        }
    }
}

/// Solves `min 1/2 x' H x + g' x` over `qp.lower <= x <= qp.upper` from the warm start `x0`
/// (projected onto the box first) into `qp.x`, `qp.free` and `qp.chol`. `h` must be symmetric;
/// bounds may be infinite; no bound may be NaN.
pub fn box_qp<N: Dim>(
    qp: &mut BoxQp<N>,
    h: &MatrixN<N, N>,
    g: &VectorN<N>,
    x0: &VectorN<N>,
    max_iterations: usize,
) -> BoxQpReport
where
    DefaultAllocator: Allocator<N> + Allocator<N, N>,
{
    const MIN_GRAD: f64 = 1e-10;
    const MIN_REL_IMPROVE: f64 = 1e-12;
    const ARMIJO: f64 = 0.1;
    const STEP_DEC: f64 = 0.6;
    const MIN_STEP: f64 = 1e-22;

    let n = qp.free.len();
    for i in 0..n {
        qp.x[i] = x0[i].clamp(qp.lower[i], qp.upper[i]);
    }
    let mut f = BoxQp::value(&mut qp.hx, h, g, &qp.x);
    qp.free.fill(true);
    let mut factored = false;
    let mut status = BoxQpStatus::MaxIterations;
    let mut iterations = 0;

    for it in 0..max_iterations {
        iterations = it + 1;
        mul_vec_add(&mut qp.grad, Some(g), h, &qp.x);
        qp.free_set();
        if qp.new_free.iter().all(|f| !f) {
            std::mem::swap(&mut qp.free, &mut qp.new_free);
            factored = qp.factor(h);
            status = BoxQpStatus::AllClamped;
            break;
        }
        if it == 0 || qp.new_free != qp.free || !factored {
            std::mem::swap(&mut qp.free, &mut qp.new_free);
            factored = qp.factor(h);
            if !factored {
                status = BoxQpStatus::NotPositiveDefinite;
                break;
            }
        }
        // The gradient on the free subspace (clamped entries zero, so they stay).
        for i in 0..n {
            qp.dx[i] = if qp.free[i] { qp.grad[i] } else { 0.0 };
        }
        if qp.dx.norm() < MIN_GRAD {
            status = BoxQpStatus::Converged;
            break;
        }
        // Newton step on the free subspace.
        cholesky_solve_in_place(&qp.chol, &mut qp.dx);
        qp.dx.neg_mut();
        let slope = qp.dx.dot(&qp.grad);
        if slope >= 0.0 {
            status = BoxQpStatus::Converged;
            break;
        }
        let mut step = 1.0;
        let f_try = loop {
            qp.trial(step);
            let f_try = BoxQp::value(&mut qp.hx, h, g, &qp.x_try);
            if (f_try - f) / (step * slope) > ARMIJO {
                break f_try;
            }
            step *= STEP_DEC;
            if step < MIN_STEP {
                return BoxQpReport {
                    status: BoxQpStatus::LineSearchFailed,
                    iterations,
                    factored,
                };
            }
        };
        let improvement = f - f_try;
        std::mem::swap(&mut qp.x, &mut qp.x_try);
        f = f_try;
        if improvement < MIN_REL_IMPROVE * f.abs().max(1e-300) {
            status = BoxQpStatus::Converged;
            // The free set may have changed at the last step: refresh it for the gains.
            mul_vec_add(&mut qp.grad, Some(g), h, &qp.x);
            qp.free_set();
            if qp.new_free != qp.free {
                std::mem::swap(&mut qp.free, &mut qp.new_free);
                factored = qp.factor(h);
            }
            break;
        }
    }
    BoxQpReport {
        status,
        iterations,
        factored,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Matrix, Vector};

    /// [`box_qp`] on fixed-size data, with fresh buffers.
    fn solve<const N: usize>(
        h: &Matrix<N, N>,
        g: &Vector<N>,
        lo: &Vector<N>,
        hi: &Vector<N>,
        x0: &Vector<N>,
        iterations: usize,
    ) -> (BoxQp<nalgebra::Const<N>>, BoxQpReport) {
        let mut qp = BoxQp::new(nalgebra::Const::<N>);
        qp.lower.copy_from(lo);
        qp.upper.copy_from(hi);
        let report = box_qp(&mut qp, h, g, x0, iterations);
        (qp, report)
    }

    /// Brute force over all active sets of a small QP: the best KKT point that is feasible.
    fn brute<const N: usize>(h: &Matrix<N, N>, g: &Vector<N>, lo: &Vector<N>, hi: &Vector<N>) -> Vector<N> {
        let mut best = Vector::<N>::zeros();
        let mut best_f = f64::INFINITY;
        // Each variable: 0 free, 1 at lower, 2 at upper.
        let combos = 3usize.pow(N as u32);
        for c in 0..combos {
            let mut state = [0usize; N];
            let mut r = c;
            for s in state.iter_mut() {
                *s = r % 3;
                r /= 3;
            }
            let mut x = Vector::<N>::zeros();
            for i in 0..N {
                x[i] = match state[i] {
                    1 => lo[i],
                    2 => hi[i],
                    _ => 0.0,
                };
            }
            let free: [bool; N] = std::array::from_fn(|i| state[i] == 0);
            let rhs = Vector::<N>::from_fn(|i, _| {
                if free[i] {
                    -(g[i] + (0..N).filter(|&j| !free[j]).map(|j| h[(i, j)] * x[j]).sum::<f64>())
                } else {
                    x[i]
                }
            });
            let reduced = Matrix::<N, N>::from_fn(|i, j| {
                if free[i] && free[j] {
                    h[(i, j)]
                } else if i == j {
                    1.0
                } else {
                    0.0
                }
            });
            let Some(ch) = reduced.cholesky() else {
                continue;
            };
            let sol = ch.solve(&rhs);
            if (0..N).any(|i| sol[i] < lo[i] - 1e-12 || sol[i] > hi[i] + 1e-12) {
                continue;
            }
            let f = sol.dot(g) + 0.5 * sol.dot(&(h * sol));
            if f < best_f {
                best_f = f;
                best = sol;
            }
        }
        best
    }

    #[test]
    fn matches_brute_force_on_random_convex_qps() {
        let mut s = 12345u64;
        let mut rnd = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for _ in 0..200 {
            let a = Matrix::<3, 3>::from_fn(|_, _| rnd());
            let h = a * a.transpose() + Matrix::<3, 3>::identity() * 0.1;
            let g = Vector::<3>::from_fn(|_, _| 3.0 * rnd());
            let lo = Vector::<3>::from_fn(|_, _| -0.2 - rnd().abs());
            let hi = Vector::<3>::from_fn(|_, _| 0.2 + rnd().abs());
            let (r, report) = solve(&h, &g, &lo, &hi, &Vector::zeros(), 100);
            let expected = brute(&h, &g, &lo, &hi);
            assert!(
                (r.x - expected).amax() < 1e-7,
                "got {:?} expected {:?} ({:?})",
                r.x,
                expected,
                report.status
            );
            // At run-time size the same computation.
            let d = nalgebra::Dyn(3);
            let mut dq = BoxQp::new(d);
            let dynamic = |m: &Matrix<3, 3>| {
                MatrixN::<nalgebra::Dyn, nalgebra::Dyn>::from_column_slice_generic(d, d, m.as_slice())
            };
            let vector =
                |v: &Vector<3>| VectorN::<nalgebra::Dyn>::from_column_slice_generic(d, nalgebra::U1, v.as_slice());
            dq.lower = vector(&lo);
            dq.upper = vector(&hi);
            let dr = box_qp(&mut dq, &dynamic(&h), &vector(&g), &vector(&Vector::zeros()), 100);
            assert_eq!(dr, report);
            assert_eq!(dq.x.as_slice(), r.x.as_slice());
            assert_eq!(dq.free, r.free);
        }
    }

    #[test]
    fn unconstrained_interior_solution_is_newton_step() {
        let h = Matrix::<2, 2>::new(2.0, 0.5, 0.5, 1.0);
        let g = Vector::<2>::new(-1.0, 0.3);
        let inf = Vector::<2>::repeat(f64::INFINITY);
        let (r, report) = solve(&h, &g, &(-inf), &inf, &Vector::zeros(), 50);
        let exact = -h.cholesky().unwrap().solve(&g);
        assert!((r.x - exact).amax() < 1e-12);
        assert_eq!(r.free, [true, true]);
        assert!(report.factored);
        // The factor is H's own: solving with it is the Newton step.
        let mut step = -g;
        cholesky_solve_in_place(&r.chol, &mut step);
        assert!((step - exact).amax() < 1e-12);
    }

    #[test]
    fn all_clamped_reports_so() {
        let h = Matrix::<2, 2>::identity();
        let g = Vector::<2>::new(-10.0, 10.0);
        let (r, report) = solve(
            &h,
            &g,
            &Vector::repeat(-1.0),
            &Vector::repeat(1.0),
            &Vector::zeros(),
            50,
        );
        assert_eq!(r.x, Vector::<2>::new(1.0, -1.0));
        assert_eq!(r.free, [false, false]);
        assert_eq!(report.status, BoxQpStatus::AllClamped);
    }
}
