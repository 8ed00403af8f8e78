//! Kinematic unicycle driven by its speed and turn rate.

use super::sin_cos;
use crate::autodiff::{DualDynamics, Scalar};
use crate::{Dynamics, Matrix, Result, Vector};
use nalgebra::{U2, U3};

/// Kinematic unicycle, exactly Crocoddyl's `ActionModelUnicycle` (benchmark P1 in
/// `bench/problems.md`) and the sidewalk robot of DDPEN.
///
/// State `x = (px, py, theta)`, control `u = (v, omega)` (forward speed in m/s, turn rate in
/// rad/s). Explicit Euler over a step `dt`:
///
/// ```text
/// px+ = px + dt v cos(theta),   py+ = py + dt v sin(theta),   theta+ = theta + dt omega
/// ```
///
/// The floating-point operations are ordered as Crocoddyl orders them (`cos(theta) * v * dt`), so
/// rollouts agree bit for bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unicycle {
    dt: f64,
}

impl Unicycle {
    /// A unicycle with time step `dt` (s); an error unless `dt` is finite and positive.
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
    fn step_at(&self, (s, c): (f64, f64), x: &Vector<3>, u: &Vector<2>) -> Vector<3> {
        let dt = self.dt;
        Vector::<3>::new(x[0] + c * u[0] * dt, x[1] + s * u[0] * dt, x[2] + u[1] * dt)
    }

    /// The Jacobians with `(sin, cos)` of the heading given.
    #[inline]
    fn jacobians_at(&self, (s, c): (f64, f64), u: &Vector<2>, fx: &mut Matrix<3, 3>, fu: &mut Matrix<3, 2>) {
        let dt = self.dt;
        super::set_identity(fx);
        fx[(0, 2)] = -s * u[0] * dt;
        fx[(1, 2)] = c * u[0] * dt;
        super::set_zero(fu);
        fu[(0, 0)] = c * dt;
        fu[(1, 0)] = s * dt;
        fu[(2, 1)] = dt;
    }

    /// The second-order terms with `(sin, cos)` of the heading given: lambda . (dt v cos, dt v
    /// sin) has only the (theta, theta) and (v, theta) entries non-zero.
    #[inline]
    fn second_order_at(
        &self,
        (s, c): (f64, f64),
        u: &Vector<2>,
        lambda: &Vector<3>,
        h_xx: &mut Matrix<3, 3>,
        h_ux: &mut Matrix<2, 3>,
    ) {
        let dt = self.dt;
        h_xx[(2, 2)] -= dt * u[0] * (lambda[0] * c + lambda[1] * s);
        h_ux[(0, 2)] += dt * (lambda[1] * c - lambda[0] * s);
    }
}

impl Default for Unicycle {
    /// `dt = 0.1` s, Crocoddyl's default.
    fn default() -> Self {
        Self { dt: 0.1 }
    }
}

impl Dynamics<U3, U2> for Unicycle {
    #[inline]
    fn step(&self, x: &Vector<3>, u: &Vector<2>) -> Vector<3> {
        self.step_at(sin_cos(x[2]), x, u)
    }

    #[inline]
    fn step_keep(&self, x: &Vector<3>, u: &Vector<2>, out: &mut Vector<3>, data: &mut Vec<f64>) {
        *out = self.step_at(super::keep_sin_cos(x[2], data), x, u);
    }

    #[inline]
    fn jacobians(&self, x: &Vector<3>, u: &Vector<2>, fx: &mut Matrix<3, 3>, fu: &mut Matrix<3, 2>) {
        self.jacobians_at(sin_cos(x[2]), u, fx, fu);
    }

    #[inline]
    fn jacobians_kept(&self, x: &Vector<3>, u: &Vector<2>, fx: &mut Matrix<3, 3>, fu: &mut Matrix<3, 2>, data: &[f64]) {
        self.jacobians_at(super::kept_sin_cos(x[2], data), u, fx, fu);
    }

    fn jacobians_keep(
        &self,
        x: &Vector<3>,
        u: &Vector<2>,
        fx: &mut Matrix<3, 3>,
        fu: &mut Matrix<3, 2>,
        data: &mut Vec<f64>,
    ) {
        self.jacobians_at(super::keep_sin_cos(x[2], data), u, fx, fu);
    }

    fn has_second_order(&self) -> bool {
        true
    }

    #[inline]
    fn add_second_order(
        &self,
        x: &Vector<3>,
        u: &Vector<2>,
        lambda: &Vector<3>,
        h_xx: &mut Matrix<3, 3>,
        h_ux: &mut Matrix<2, 3>,
        _h_uu: &mut Matrix<2, 2>,
    ) {
        self.second_order_at(sin_cos(x[2]), u, lambda, h_xx, h_ux);
    }

    fn add_second_order_kept(
        &self,
        x: &Vector<3>,
        u: &Vector<2>,
        lambda: &Vector<3>,
        data: &[f64],
        h_xx: &mut Matrix<3, 3>,
        h_ux: &mut Matrix<2, 3>,
        _h_uu: &mut Matrix<2, 2>,
    ) {
        self.second_order_at(super::kept_sin_cos(x[2], data), u, lambda, h_xx, h_ux);
    }
}

impl DualDynamics<3, 2> for Unicycle {
    fn step_generic<T: Scalar>(&self, x: &[T; 3], u: &[T; 2]) -> [T; 3] {
        let (s, c) = x[2].sin_cos();
        let dt = self.dt;
        [x[0] + c * u[0] * dt, x[1] + s * u[0] * dt, x[2] + u[1] * dt]
    }
}
