//! Kinematic car with a speed state.

use super::sin_cos;
use crate::autodiff::{DualDynamics, Scalar};
use crate::{Dynamics, Matrix, Result, Vector};
use nalgebra::{U2, U4};

/// Kinematic car whose speed is a state: the Safe-CDDP car-like robot (after Xie et al. 2017) and
/// benchmark P2 (`bench/problems.md`).
///
/// State `x = (px, py, theta, v)`, control `u = (omega, a)` (yaw rate in rad/s, acceleration in
/// m/s^2). Explicit Euler over a step `dt`:
///
/// ```text
/// px+ = px + dt v cos(theta),  py+ = py + dt v sin(theta),  theta+ = theta + dt omega,  v+ = v + dt a
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Car {
    dt: f64,
}

impl Car {
    /// A car with time step `dt` (s); an error unless `dt` is finite and positive.
    pub fn new(dt: f64) -> Result<Self> {
        Ok(Self {
            dt: super::positive("dt", dt)?,
        })
    }

    /// The time step (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The step with `(sin, cos)` of the heading given.
    #[inline]
    fn step_at(&self, (s, c): (f64, f64), x: &Vector<4>, u: &Vector<2>) -> Vector<4> {
        let dt = self.dt;
        Vector::<4>::new(
            x[0] + c * x[3] * dt,
            x[1] + s * x[3] * dt,
            x[2] + u[0] * dt,
            x[3] + u[1] * dt,
        )
    }

    /// The Jacobians with `(sin, cos)` of the heading given.
    #[inline]
    fn jacobians_at(&self, (s, c): (f64, f64), x: &Vector<4>, fx: &mut Matrix<4, 4>, fu: &mut Matrix<4, 2>) {
        let dt = self.dt;
        super::set_identity(fx);
        fx[(0, 2)] = -s * x[3] * dt;
        fx[(0, 3)] = c * dt;
        fx[(1, 2)] = c * x[3] * dt;
        fx[(1, 3)] = s * dt;
        super::set_zero(fu);
        fu[(2, 0)] = dt;
        fu[(3, 1)] = dt;
    }

    /// The second-order terms with `(sin, cos)` of the heading given: lambda . (dt v cos(theta),
    /// dt v sin(theta)) is the only non-linear part, and it depends on (theta, v) alone.
    #[inline]
    fn second_order_at(&self, (s, c): (f64, f64), x: &Vector<4>, lambda: &Vector<4>, h_xx: &mut Matrix<4, 4>) {
        let dt = self.dt;
        let cross = dt * (lambda[1] * c - lambda[0] * s);
        h_xx[(2, 2)] -= dt * x[3] * (lambda[0] * c + lambda[1] * s);
        h_xx[(2, 3)] += cross;
        h_xx[(3, 2)] += cross;
    }
}

impl Default for Car {
    /// `dt = 0.05` s, as in benchmark P2.
    fn default() -> Self {
        Self { dt: 0.05 }
    }
}

impl Dynamics<U4, U2> for Car {
    #[inline]
    fn step(&self, x: &Vector<4>, u: &Vector<2>) -> Vector<4> {
        self.step_at(sin_cos(x[2]), x, u)
    }

    #[inline]
    fn step_keep(&self, x: &Vector<4>, u: &Vector<2>, out: &mut Vector<4>, data: &mut Vec<f64>) {
        *out = self.step_at(super::keep_sin_cos(x[2], data), x, u);
    }

    #[inline]
    fn jacobians(&self, x: &Vector<4>, _u: &Vector<2>, fx: &mut Matrix<4, 4>, fu: &mut Matrix<4, 2>) {
        self.jacobians_at(sin_cos(x[2]), x, fx, fu);
    }

    #[inline]
    fn jacobians_kept(
        &self,
        x: &Vector<4>,
        _u: &Vector<2>,
        fx: &mut Matrix<4, 4>,
        fu: &mut Matrix<4, 2>,
        data: &[f64],
    ) {
        self.jacobians_at(super::kept_sin_cos(x[2], data), x, fx, fu);
    }

    fn jacobians_keep(
        &self,
        x: &Vector<4>,
        _u: &Vector<2>,
        fx: &mut Matrix<4, 4>,
        fu: &mut Matrix<4, 2>,
        data: &mut Vec<f64>,
    ) {
        self.jacobians_at(super::keep_sin_cos(x[2], data), x, fx, fu);
    }

    fn add_second_order_kept(
        &self,
        x: &Vector<4>,
        _u: &Vector<2>,
        lambda: &Vector<4>,
        data: &[f64],
        h_xx: &mut Matrix<4, 4>,
        _h_ux: &mut Matrix<2, 4>,
        _h_uu: &mut Matrix<2, 2>,
    ) {
        self.second_order_at(super::kept_sin_cos(x[2], data), x, lambda, h_xx);
    }

    fn has_second_order(&self) -> bool {
        true
    }

    #[inline]
    fn add_second_order(
        &self,
        x: &Vector<4>,
        _u: &Vector<2>,
        lambda: &Vector<4>,
        h_xx: &mut Matrix<4, 4>,
        _h_ux: &mut Matrix<2, 4>,
        _h_uu: &mut Matrix<2, 2>,
    ) {
        self.second_order_at(sin_cos(x[2]), x, lambda, h_xx);
    }
}

impl DualDynamics<4, 2> for Car {
    fn step_generic<T: Scalar>(&self, x: &[T; 4], u: &[T; 2]) -> [T; 4] {
        let (s, c) = x[2].sin_cos();
        let dt = self.dt;
        [
            x[0] + c * x[3] * dt,
            x[1] + s * x[3] * dt,
            x[2] + u[0] * dt,
            x[3] + u[1] * dt,
        ]
    }
}
