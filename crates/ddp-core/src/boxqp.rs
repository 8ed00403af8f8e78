//! Box-constrained QP by projected Newton (Tassa, Mansard & Todorov, ICRA 2014, Algorithm 3):
//!
//! ```text
//! min_x  1/2 x^T H x + g^T x   s.t.  lower <= x <= upper
//! ```
//!
//! Used by box-DDP for the control step at each knot. At the solution the *free* set (controls not
//! clamped at a bound) defines the feedback: `K_f = -H_ff^{-1} Q_ux,f`, clamped rows zero.

use nalgebra::{Cholesky, Dim, U1};

use crate::dims::{Allocator, DefaultAllocator, MatrixN, VectorN};

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

/// Result of [`box_qp`].
#[derive(Debug, Clone)]
pub struct BoxQp<N: Dim>
where
    DefaultAllocator: Allocator<N> + Allocator<N, N>,
{
    /// The minimiser (always within the bounds).
    pub x: VectorN<N>,
    /// `free[i]` is true when `x[i]` is not clamped at a bound.
    pub free: nalgebra::OVector<bool, N>,
    /// Cholesky factor of `H` with clamped rows and columns replaced by the identity, so that
    /// solving with it gives the free-subspace Newton step (clamped entries pass through).
    pub chol: Option<Cholesky<f64, N>>,
    /// How the iteration ended.
    pub status: BoxQpStatus,
    /// Newton iterations used.
    pub iterations: usize,
}

/// `H` with the rows and columns of clamped variables replaced by those of the identity.
fn reduced<N: Dim>(h: &MatrixN<N, N>, free: &nalgebra::OVector<bool, N>) -> MatrixN<N, N>
where
    DefaultAllocator: Allocator<N> + Allocator<N, N>,
{
    let (r, c) = h.shape_generic();
    MatrixN::from_fn_generic(r, c, |i, j| {
        if free[i] && free[j] {
            h[(i, j)]
        } else if i == j {
            1.0
        } else {
            0.0
        }
    })
}

/// The free set at `x`: a variable is clamped when it sits at a bound and the gradient pushes
/// it further out.
fn free_set<N: Dim>(
    x: &VectorN<N>,
    grad: &VectorN<N>,
    lower: &VectorN<N>,
    upper: &VectorN<N>,
) -> nalgebra::OVector<bool, N>
where
    DefaultAllocator: Allocator<N>,
{
    let (r, _) = x.shape_generic();
    nalgebra::OVector::from_fn_generic(r, U1, |i, _| {
        !((x[i] <= lower[i] && grad[i] > 0.0) || (x[i] >= upper[i] && grad[i] < 0.0))
    })
}

/// Solves the box QP from the warm start `x0` (projected onto the box first).
/// `h` must be symmetric; bounds may be infinite. Allocates only for run-time sizes.
pub fn box_qp<N: Dim>(
    h: &MatrixN<N, N>,
    g: &VectorN<N>,
    lower: &VectorN<N>,
    upper: &VectorN<N>,
    x0: &VectorN<N>,
    max_iterations: usize,
) -> BoxQp<N>
where
    DefaultAllocator: Allocator<N> + Allocator<N, N>,
{
    const MIN_GRAD: f64 = 1e-10;
    const MIN_REL_IMPROVE: f64 = 1e-12;
    const ARMIJO: f64 = 0.1;
    const STEP_DEC: f64 = 0.6;
    const MIN_STEP: f64 = 1e-22;

    let (rows, _) = g.shape_generic();
    let clamp = |x: &VectorN<N>| VectorN::<N>::from_fn_generic(rows, U1, |i, _| x[i].clamp(lower[i], upper[i]));
    let value = |x: &VectorN<N>| x.dot(g) + 0.5 * x.dot(&(h * x));

    let mut x = clamp(x0);
    let mut f = value(&x);
    let mut free = nalgebra::OVector::<bool, N>::from_element_generic(rows, U1, true);
    let mut chol = None;
    let mut status = BoxQpStatus::MaxIterations;
    let mut iterations = 0;

    for it in 0..max_iterations {
        iterations = it + 1;
        let grad = g + h * &x;
        let new_free = free_set(&x, &grad, lower, upper);
        if new_free.iter().all(|f| !f) {
            free = new_free;
            chol = Cholesky::new(reduced(h, &free));
            status = BoxQpStatus::AllClamped;
            break;
        }
        if it == 0 || new_free != free || chol.is_none() {
            free = new_free;
            chol = Cholesky::new(reduced(h, &free));
            if chol.is_none() {
                status = BoxQpStatus::NotPositiveDefinite;
                break;
            }
        }
        let grad_free = VectorN::<N>::from_fn_generic(rows, U1, |i, _| if free[i] { grad[i] } else { 0.0 });
        if grad_free.norm() < MIN_GRAD {
            status = BoxQpStatus::Converged;
            break;
        }
        // Newton step on the free subspace; clamped entries of grad_free are zero, so they stay.
        let Some(c) = chol.as_ref() else { break };
        let dx = -c.solve(&grad_free);
        let slope = dx.dot(&grad);
        if slope >= 0.0 {
            status = BoxQpStatus::Converged;
            break;
        }
        let mut step = 1.0;
        let (mut x_try, mut f_try);
        loop {
            x_try = clamp(&(&x + &dx * step));
            f_try = value(&x_try);
            if (f_try - f) / (step * slope) > ARMIJO {
                break;
            }
            step *= STEP_DEC;
            if step < MIN_STEP {
                status = BoxQpStatus::LineSearchFailed;
                return BoxQp {
                    x,
                    free,
                    chol,
                    status,
                    iterations,
                };
            }
        }
        let improvement = f - f_try;
        x = x_try;
        f = f_try;
        if improvement < MIN_REL_IMPROVE * f.abs().max(1e-300) {
            status = BoxQpStatus::Converged;
            // The free set may have changed at the last step: refresh it for the gains.
            let grad = g + h * &x;
            let final_free = free_set(&x, &grad, lower, upper);
            if final_free != free {
                free = final_free;
                chol = Cholesky::new(reduced(h, &free));
            }
            break;
        }
    }
    BoxQp {
        x,
        free,
        chol,
        status,
        iterations,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Matrix, Vector};

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
            let free = nalgebra::OVector::<bool, nalgebra::Const<N>>::from_row_slice(&free);
            let Some(ch) = Cholesky::new(reduced(h, &free)) else {
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
            let r = box_qp(&h, &g, &lo, &hi, &Vector::zeros(), 100);
            let expected = brute(&h, &g, &lo, &hi);
            assert!(
                (r.x - expected).amax() < 1e-7,
                "got {:?} expected {:?} ({:?})",
                r.x,
                expected,
                r.status
            );
        }
    }

    #[test]
    fn unconstrained_interior_solution_is_newton_step() {
        let h = Matrix::<2, 2>::new(2.0, 0.5, 0.5, 1.0);
        let g = Vector::<2>::new(-1.0, 0.3);
        let inf = Vector::<2>::repeat(f64::INFINITY);
        let r = box_qp(&h, &g, &(-inf), &inf, &Vector::zeros(), 50);
        let exact = -h.cholesky().unwrap().solve(&g);
        assert!((r.x - exact).amax() < 1e-12);
        assert_eq!(r.free.as_slice(), [true, true]);
    }

    #[test]
    fn all_clamped_reports_so() {
        let h = Matrix::<2, 2>::identity();
        let g = Vector::<2>::new(-10.0, 10.0);
        let r = box_qp(
            &h,
            &g,
            &Vector::repeat(-1.0),
            &Vector::repeat(1.0),
            &Vector::zeros(),
            50,
        );
        assert_eq!(r.x, Vector::<2>::new(1.0, -1.0));
        assert_eq!(r.free.as_slice(), [false, false]);
        assert_eq!(r.status, BoxQpStatus::AllClamped);
    }
}
