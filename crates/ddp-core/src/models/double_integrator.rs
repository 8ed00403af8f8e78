//! Planar point mass driven by its acceleration.

use crate::autodiff::{DualDynamics, Scalar};
use crate::{Dynamics, Matrix, Result, Vector};
use nalgebra::{U2, U4};

/// A point mass in the plane, accelerated directly: the Safe-CDDP point robot and benchmark P3
/// (`bench/problems.md`).
///
/// State `x = (px, py, vx, vy)`, control `u = (ax, ay)`. The exact zero-order-hold discretisation
/// of `p'' = a` over a step `dt`:
///
/// ```text
/// p+ = p + dt v + dt^2 / 2 a,     v+ = v + dt a
/// ```
///
/// The map is linear, so its second derivatives vanish ([`Dynamics::add_second_order`] adds
/// nothing, but [`Dynamics::has_second_order`] is `true` so full DDP knows they are exact).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DoubleIntegrator2D {
    dt: f64,
}

impl DoubleIntegrator2D {
    /// A double integrator with time step `dt` (s); an error unless `dt` is finite and positive.
    pub fn new(dt: f64) -> Result<Self> {
        Ok(Self {
            dt: super::positive("dt", dt)?,
        })
    }

    /// The time step (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }
}

impl Default for DoubleIntegrator2D {
    /// `dt = 0.05` s, as in benchmark P3.
    fn default() -> Self {
        Self { dt: 0.05 }
    }
}

impl Dynamics<U4, U2> for DoubleIntegrator2D {
    #[inline]
    fn step(&self, x: &Vector<4>, u: &Vector<2>) -> Vector<4> {
        let dt = self.dt;
        let h = 0.5 * dt * dt;
        Vector::<4>::new(
            x[0] + dt * x[2] + h * u[0],
            x[1] + dt * x[3] + h * u[1],
            x[2] + dt * u[0],
            x[3] + dt * u[1],
        )
    }

    #[inline]
    fn jacobians(&self, _x: &Vector<4>, _u: &Vector<2>, fx: &mut Matrix<4, 4>, fu: &mut Matrix<4, 2>) {
        let dt = self.dt;
        super::set_identity(fx);
        fx[(0, 2)] = dt;
        fx[(1, 3)] = dt;
        super::set_zero(fu);
        fu[(0, 0)] = 0.5 * dt * dt;
        fu[(1, 1)] = 0.5 * dt * dt;
        fu[(2, 0)] = dt;
        fu[(3, 1)] = dt;
    }

    fn has_second_order(&self) -> bool {
        true
    }

    #[inline]
    fn add_second_order(
        &self,
        _x: &Vector<4>,
        _u: &Vector<2>,
        _lambda: &Vector<4>,
        _h_xx: &mut Matrix<4, 4>,
        _h_ux: &mut Matrix<2, 4>,
        _h_uu: &mut Matrix<2, 2>,
    ) {
        // Linear dynamics: every second derivative is zero.
    }
}

impl DualDynamics<4, 2> for DoubleIntegrator2D {
    fn step_generic<T: Scalar>(&self, x: &[T; 4], u: &[T; 2]) -> [T; 4] {
        let dt = self.dt;
        let h = 0.5 * dt * dt;
        [
            x[0] + x[2] * dt + u[0] * h,
            x[1] + x[3] * dt + u[1] * h,
            x[2] + u[0] * dt,
            x[3] + u[1] * dt,
        ]
    }
}
