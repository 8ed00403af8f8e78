//! Discrete-time dynamics `x_{k+1} = f(x_k, u_k)` and their derivatives.
//!
//! A model is immutable and `Send + Sync`; the solver owns every buffer a solve writes. First
//! derivatives are required (`f_x`, `f_u`); second derivatives are optional and only used by full
//! DDP, in contracted form: the solver needs `sum_i lambda_i * d^2 f_i / d(x,u)^2` with
//! `lambda = V_x'` (the next knot's value gradient), never the full third-order tensor.

use crate::dims::{Alloc, DefaultAllocator, Dim, MatrixN, VectorN};

/// Discrete dynamics with `NX` states and `NU` controls.
///
/// ```
/// use ddp_core::{Dynamics, Matrix, Vector};
/// use ddp_core::dims::U1;
/// /// x+ = x + dt * u, a single integrator.
/// struct Integrator { dt: f64 }
/// impl Dynamics<U1, U1> for Integrator {
///     fn step(&self, x: &Vector<1>, u: &Vector<1>) -> Vector<1> { x + self.dt * u }
///     fn jacobians(&self, _x: &Vector<1>, _u: &Vector<1>, fx: &mut Matrix<1, 1>, fu: &mut Matrix<1, 1>) {
///         fx[(0, 0)] = 1.0;
///         fu[(0, 0)] = self.dt;
///     }
/// }
/// let m = Integrator { dt: 0.1 };
/// assert_eq!(m.step(&Vector::<1>::new(1.0), &Vector::<1>::new(2.0))[0], 1.2);
/// ```
pub trait Dynamics<NX: Dim, NU: Dim>: Send + Sync
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// The next state `f(x, u)`.
    fn step(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> VectorN<NX>;

    /// Writes `f(x, u)` into `out`. The solvers call this one; a run-time-size model overrides
    /// it to avoid allocating the result.
    fn step_into(&self, x: &VectorN<NX>, u: &VectorN<NU>, out: &mut VectorN<NX>) {
        *out = self.step(x, u);
    }

    /// The state and control sizes this model was built for; `None` where it takes any size.
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (NX::try_to_usize(), NU::try_to_usize())
    }

    /// Writes the Jacobians `f_x = df/dx` and `f_u = df/du` at `(x, u)` (every entry).
    fn jacobians(&self, x: &VectorN<NX>, u: &VectorN<NU>, fx: &mut MatrixN<NX, NX>, fu: &mut MatrixN<NX, NU>);

    /// Whether [`Dynamics::add_second_order`] is implemented. Full DDP falls back to iLQR terms
    /// (no second-order dynamics) for a model that returns `false`.
    fn has_second_order(&self) -> bool {
        false
    }

    /// Adds the contracted second derivatives `sum_i lambda_i * d^2 f_i` to the blocks:
    /// `h_xx += sum_i lambda_i f_i,xx`, `h_ux += sum_i lambda_i f_i,ux`, `h_uu += sum_i lambda_i f_i,uu`.
    fn add_second_order(
        &self,
        _x: &VectorN<NX>,
        _u: &VectorN<NU>,
        _lambda: &VectorN<NX>,
        _h_xx: &mut MatrixN<NX, NX>,
        _h_ux: &mut MatrixN<NU, NX>,
        _h_uu: &mut MatrixN<NU, NU>,
    ) {
    }
}

impl<NX: Dim, NU: Dim, D: Dynamics<NX, NU> + ?Sized> Dynamics<NX, NU> for std::sync::Arc<D>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn step(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> VectorN<NX> {
        (**self).step(x, u)
    }
    fn step_into(&self, x: &VectorN<NX>, u: &VectorN<NU>, out: &mut VectorN<NX>) {
        (**self).step_into(x, u, out)
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (**self).sizes()
    }
    fn jacobians(&self, x: &VectorN<NX>, u: &VectorN<NU>, fx: &mut MatrixN<NX, NX>, fu: &mut MatrixN<NX, NU>) {
        (**self).jacobians(x, u, fx, fu)
    }
    fn has_second_order(&self) -> bool {
        (**self).has_second_order()
    }
    fn add_second_order(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        lambda: &VectorN<NX>,
        h_xx: &mut MatrixN<NX, NX>,
        h_ux: &mut MatrixN<NU, NX>,
        h_uu: &mut MatrixN<NU, NU>,
    ) {
        (**self).add_second_order(x, u, lambda, h_xx, h_ux, h_uu)
    }
}
