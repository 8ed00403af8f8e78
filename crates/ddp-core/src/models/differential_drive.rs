//! Differential-drive robot commanded by its wheel speeds.

use super::sin_cos;
use crate::autodiff::{DualDynamics, Scalar};
use crate::{Dynamics, Matrix, Result, Vector};
use nalgebra::{U2, U3};

/// Differential-drive robot (two driven wheels on one axle, e.g. a Turtlebot3) commanded by the
/// ground speeds of its wheels.
///
/// State `x = (px, py, theta)`, control `u = (v_l, v_r)`: left and right wheel rim speeds in m/s.
/// With track width `b` (distance between the wheel contact points), the body speed and turn rate
/// are `v = (v_l + v_r) / 2`, `omega = (v_r - v_l) / b`. One step of length `dt` moves along the
/// midpoint heading, which gives the exact direction of the chord of a constant-curvature arc:
///
/// ```text
/// px+ = px + dt v cos(theta + dt omega / 2)
/// py+ = py + dt v sin(theta + dt omega / 2)
/// theta+ = theta + dt omega
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DifferentialDrive {
    dt: f64,
    track_width: f64,
}

impl DifferentialDrive {
    /// Turtlebot3 Burger track width (m).
    pub const TURTLEBOT3_BURGER_TRACK_WIDTH: f64 = 0.16;

    /// A differential drive with time step `dt` (s) and track width `track_width` (m); an error
    /// naming the field unless both are finite and positive.
    pub fn new(dt: f64, track_width: f64) -> Result<Self> {
        Ok(Self {
            dt: super::positive("dt", dt)?,
            track_width: super::positive("track_width", track_width)?,
        })
    }

    /// The time step (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The track width `b` (m).
    pub fn track_width(&self) -> f64 {
        self.track_width
    }

    /// Body speed `v` (m/s) and turn rate `omega` (rad/s) of wheel speeds `u = (v_l, v_r)`.
    pub fn body_twist(&self, u: &Vector<2>) -> (f64, f64) {
        (0.5 * (u[0] + u[1]), (u[1] - u[0]) / self.track_width)
    }

    /// Wheel speeds `(v_l, v_r)` (m/s) that give body speed `v` and turn rate `omega`.
    pub fn wheel_speeds(&self, v: f64, omega: f64) -> Vector<2> {
        let half = 0.5 * omega * self.track_width;
        Vector::<2>::new(v - half, v + half)
    }
}

impl Default for DifferentialDrive {
    /// `dt = 0.1` s and the Turtlebot3 Burger's track width of 0.16 m.
    fn default() -> Self {
        Self {
            dt: 0.1,
            track_width: Self::TURTLEBOT3_BURGER_TRACK_WIDTH,
        }
    }
}

impl Dynamics<U3, U2> for DifferentialDrive {
    #[inline]
    fn step(&self, x: &Vector<3>, u: &Vector<2>) -> Vector<3> {
        let dt = self.dt;
        let (v, omega) = self.body_twist(u);
        let (s, c) = sin_cos(x[2] + 0.5 * dt * omega);
        Vector::<3>::new(x[0] + dt * v * c, x[1] + dt * v * s, x[2] + dt * omega)
    }

    #[inline]
    fn jacobians(&self, x: &Vector<3>, u: &Vector<2>, fx: &mut Matrix<3, 3>, fu: &mut Matrix<3, 2>) {
        let dt = self.dt;
        let (v, omega) = self.body_twist(u);
        let (s, c) = sin_cos(x[2] + 0.5 * dt * omega);
        // d(heading)/d(v_r) = -d(heading)/d(v_l) = dt / (2 b); d v / d v_{l,r} = 1/2.
        let psi_r = 0.5 * dt / self.track_width;
        super::set_identity(fx);
        fx[(0, 2)] = -dt * v * s;
        fx[(1, 2)] = dt * v * c;
        fu[(0, 0)] = dt * (0.5 * c + v * s * psi_r);
        fu[(0, 1)] = dt * (0.5 * c - v * s * psi_r);
        fu[(1, 0)] = dt * (0.5 * s - v * c * psi_r);
        fu[(1, 1)] = dt * (0.5 * s + v * c * psi_r);
        fu[(2, 0)] = -dt / self.track_width;
        fu[(2, 1)] = dt / self.track_width;
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
        h_uu: &mut Matrix<2, 2>,
    ) {
        // The non-linear part is L(psi, v) = dt v (lambda_0 cos psi + lambda_1 sin psi) with the
        // heading psi and the speed v both linear in z = (theta, v_l, v_r): the Hessian is
        // L_pp dpsi dpsi' + L_pv (dpsi dv' + dv dpsi').
        let dt = self.dt;
        let (v, omega) = self.body_twist(u);
        let (s, c) = sin_cos(x[2] + 0.5 * dt * omega);
        let l_pp = -dt * v * (lambda[0] * c + lambda[1] * s);
        let l_pv = dt * (lambda[1] * c - lambda[0] * s);
        let psi_r = 0.5 * dt / self.track_width;
        let dpsi = [-psi_r, psi_r];
        h_xx[(2, 2)] += l_pp;
        for i in 0..2 {
            h_ux[(i, 2)] += l_pp * dpsi[i] + 0.5 * l_pv;
            for j in 0..2 {
                h_uu[(i, j)] += l_pp * dpsi[i] * dpsi[j] + 0.5 * l_pv * (dpsi[i] + dpsi[j]);
            }
        }
    }
}

impl DualDynamics<3, 2> for DifferentialDrive {
    fn step_generic<T: Scalar>(&self, x: &[T; 3], u: &[T; 2]) -> [T; 3] {
        let dt = self.dt;
        let v = (u[0] + u[1]) * 0.5;
        let omega = (u[1] - u[0]) / self.track_width;
        let (s, c) = (x[2] + omega * (0.5 * dt)).sin_cos();
        [x[0] + v * c * dt, x[1] + v * s * dt, x[2] + omega * dt]
    }
}
