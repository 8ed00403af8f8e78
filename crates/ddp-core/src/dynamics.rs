//! Discrete-time dynamics `x_{k+1} = f(x_k, u_k)` and their derivatives.
//!
//! A model is immutable and `Send + Sync`; the solver owns every buffer a solve writes. First
//! derivatives are required (`f_x`, `f_u`); second derivatives are optional and only used by full
//! DDP, in contracted form: the solver needs `sum_i lambda_i * d^2 f_i / d(x,u)^2` with
//! `lambda = V_x'` (the next knot's value gradient), never the full third-order tensor.

use crate::{Matrix, Vector};

/// Discrete dynamics with `NX` states and `NU` controls.
///
/// ```
/// use ddp_core::{Dynamics, Matrix, Vector};
/// /// x+ = x + dt * u, a single integrator.
/// struct Integrator { dt: f64 }
/// impl Dynamics<1, 1> for Integrator {
///     fn step(&self, x: &Vector<1>, u: &Vector<1>) -> Vector<1> { x + self.dt * u }
///     fn jacobians(&self, _x: &Vector<1>, _u: &Vector<1>, fx: &mut Matrix<1, 1>, fu: &mut Matrix<1, 1>) {
///         fx[(0, 0)] = 1.0;
///         fu[(0, 0)] = self.dt;
///     }
/// }
/// let m = Integrator { dt: 0.1 };
/// assert_eq!(m.step(&Vector::<1>::new(1.0), &Vector::<1>::new(2.0))[0], 1.2);
/// ```
pub trait Dynamics<const NX: usize, const NU: usize>: Send + Sync {
    /// The next state `f(x, u)`.
    fn step(&self, x: &Vector<NX>, u: &Vector<NU>) -> Vector<NX>;

    /// Writes the Jacobians `f_x = df/dx` and `f_u = df/du` at `(x, u)` (every entry).
    fn jacobians(&self, x: &Vector<NX>, u: &Vector<NU>, fx: &mut Matrix<NX, NX>, fu: &mut Matrix<NX, NU>);

    /// Whether [`Dynamics::add_second_order`] is implemented. Full DDP falls back to iLQR terms
    /// (no second-order dynamics) for a model that returns `false`.
    fn has_second_order(&self) -> bool {
        false
    }

    /// Adds the contracted second derivatives `sum_i lambda_i * d^2 f_i` to the blocks:
    /// `h_xx += sum_i lambda_i f_i,xx`, `h_ux += sum_i lambda_i f_i,ux`, `h_uu += sum_i lambda_i f_i,uu`.
    fn add_second_order(
        &self,
        _x: &Vector<NX>,
        _u: &Vector<NU>,
        _lambda: &Vector<NX>,
        _h_xx: &mut Matrix<NX, NX>,
        _h_ux: &mut Matrix<NU, NX>,
        _h_uu: &mut Matrix<NU, NU>,
    ) {
    }
}

impl<const NX: usize, const NU: usize, D: Dynamics<NX, NU> + ?Sized> Dynamics<NX, NU> for std::sync::Arc<D> {
    fn step(&self, x: &Vector<NX>, u: &Vector<NU>) -> Vector<NX> {
        (**self).step(x, u)
    }
    fn jacobians(&self, x: &Vector<NX>, u: &Vector<NU>, fx: &mut Matrix<NX, NX>, fu: &mut Matrix<NX, NU>) {
        (**self).jacobians(x, u, fx, fu)
    }
    fn has_second_order(&self) -> bool {
        (**self).has_second_order()
    }
    fn add_second_order(
        &self,
        x: &Vector<NX>,
        u: &Vector<NU>,
        lambda: &Vector<NX>,
        h_xx: &mut Matrix<NX, NX>,
        h_ux: &mut Matrix<NU, NX>,
        h_uu: &mut Matrix<NU, NU>,
    ) {
        (**self).add_second_order(x, u, lambda, h_xx, h_ux, h_uu)
    }
}
