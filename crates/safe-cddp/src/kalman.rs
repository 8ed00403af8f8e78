//! Constant-velocity Kalman filter for a moving obstacle, after Queen Elizabeth's School (2022),
//! and its prediction as a [`MovingCircle`] constraint whose margin grows along the horizon.
//!
//! State `a = (px, vx, py, vy)`, one block per axis as in Queen Elizabeth's School (2022):
//!
//! ```text
//! a_{t+1} = F a_t + G w_t,   F = diag(A, A), A = [1 s; 0 1],   G = diag(B, B), B = [s^2/2; s]
//! z_t = H a_t + v_t,         H picks (px, py)
//! ```
//!
//! with white acceleration noise `w ~ N(0, q^2 I)` and position noise `v ~ N(0, r^2 I)`. The
//! predicted position covariance `P_t[pos]` of step `t` is what [`MovingCircle`] adds to the
//! robot's in the tightening (eq. 20), so the margin of a moving obstacle grows along the horizon.
//!
//! ```
//! use safe_cddp::kalman::ObstacleTracker;
//! let mut kf = ObstacleTracker::new(0.1, 0.5, 0.05, [0.0, 0.0], [1.0, 0.0], 0.1, 0.5).unwrap();
//! kf.predict();
//! kf.update([0.1, 0.0]).unwrap();
//! assert!((kf.position()[0] - 0.1).abs() < 0.05);
//! ```

use ddp_core::error::check_finite;
use ddp_core::{Error, Matrix, Result, Vector};
use ddpkit_util::check::positive;
use nalgebra::Matrix2;

use crate::constraints::{CircleForm, MovingCircle};

/// A constant-velocity Kalman filter tracking one obstacle (see the [module docs](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObstacleTracker {
    dt: f64,
    q: f64,
    r: f64,
    a: Vector<4>,
    p: Matrix<4, 4>,
}

impl ObstacleTracker {
    /// Sampling period `dt`, acceleration noise `q` (std, m/s^2), measurement noise `r` (std, m),
    /// initial position and velocity estimates and their standard deviations.
    pub fn new(
        dt: f64,
        accel_std: f64,
        meas_std: f64,
        position: [f64; 2],
        velocity: [f64; 2],
        position_std: f64,
        velocity_std: f64,
    ) -> Result<Self> {
        check_finite("position", position.iter())?;
        check_finite("velocity", velocity.iter())?;
        let ps = positive("position_std", position_std)?;
        let vs = positive("velocity_std", velocity_std)?;
        Ok(Self {
            dt: positive("dt", dt)?,
            q: positive("accel_std", accel_std)?,
            r: positive("meas_std", meas_std)?,
            a: Vector::<4>::new(position[0], velocity[0], position[1], velocity[1]),
            p: Matrix::<4, 4>::from_diagonal(&Vector::<4>::new(ps * ps, vs * vs, ps * ps, vs * vs)),
        })
    }

    /// `F = diag(A, A)`, `A = [1 dt; 0 1]`.
    pub fn f(&self) -> Matrix<4, 4> {
        let mut f = Matrix::<4, 4>::identity();
        f[(0, 1)] = self.dt;
        f[(2, 3)] = self.dt;
        f
    }

    /// `G = diag(B, B)`, `B = [dt^2 / 2; dt]`.
    pub fn g(&self) -> Matrix<4, 2> {
        let mut g = Matrix::<4, 2>::zeros();
        g[(0, 0)] = 0.5 * self.dt * self.dt;
        g[(1, 0)] = self.dt;
        g[(2, 1)] = 0.5 * self.dt * self.dt;
        g[(3, 1)] = self.dt;
        g
    }

    /// `H`, the position rows.
    pub fn h(&self) -> Matrix<2, 4> {
        let mut h = Matrix::<2, 4>::zeros();
        h[(0, 0)] = 1.0;
        h[(1, 2)] = 1.0;
        h
    }

    /// The process noise `G q^2 I G^T`.
    pub fn process_noise(&self) -> Matrix<4, 4> {
        let g = self.g();
        self.q * self.q * g * g.transpose()
    }

    /// Time update: `a <- F a`, `P <- F P F^T + G Q G^T`.
    pub fn predict(&mut self) {
        let f = self.f();
        self.a = f * self.a;
        let p = f * self.p * f.transpose() + self.process_noise();
        self.p = 0.5 * (p + p.transpose());
    }

    /// Measurement update with a position `z` (Joseph form). Errors on a non-finite `z`.
    pub fn update(&mut self, z: [f64; 2]) -> Result<()> {
        check_finite("z", z.iter())?;
        let h = self.h();
        let s = h * self.p * h.transpose() + Matrix2::identity() * (self.r * self.r);
        let s_inv = s
            .try_inverse()
            .ok_or_else(|| Error::invalid("covariance", "innovation covariance is singular"))?;
        let k = self.p * h.transpose() * s_inv;
        let innovation = Vector::<2>::new(z[0], z[1]) - h * self.a;
        self.a += k * innovation;
        let i_kh = Matrix::<4, 4>::identity() - k * h;
        let p = i_kh * self.p * i_kh.transpose() + k * (self.r * self.r) * k.transpose();
        self.p = 0.5 * (p + p.transpose());
        Ok(())
    }

    /// The state estimate `(px, vx, py, vy)`.
    pub fn state(&self) -> &Vector<4> {
        &self.a
    }
    /// Its covariance.
    pub fn covariance(&self) -> &Matrix<4, 4> {
        &self.p
    }
    /// The estimated position.
    pub fn position(&self) -> [f64; 2] {
        [self.a[0], self.a[2]]
    }
    /// The estimated velocity.
    pub fn velocity(&self) -> [f64; 2] {
        [self.a[1], self.a[3]]
    }
    /// The position block of the covariance.
    pub fn position_covariance(&self) -> Matrix2<f64> {
        Matrix2::new(self.p[(0, 0)], self.p[(0, 2)], self.p[(2, 0)], self.p[(2, 2)])
    }

    /// Predicted positions and position covariances for `t = 0 ..= steps` steps ahead (the filter
    /// is left unchanged), written into `centers` and `covariances` (cleared first).
    pub fn predict_positions(&self, steps: usize, centers: &mut Vec<[f64; 2]>, covariances: &mut Vec<Matrix2<f64>>) {
        centers.clear();
        covariances.clear();
        let mut kf = *self;
        for t in 0..=steps {
            if t > 0 {
                kf.predict();
            }
            centers.push(kf.position());
            covariances.push(kf.position_covariance());
        }
    }

    /// The obstacle of radius `radius` as a [`MovingCircle`] on the robot's position
    /// `(x[indices[0]], x[indices[1]])`, predicted `steps` steps ahead (allocates the table).
    pub fn moving_circle<NX: ddp_core::dims::Dim>(
        &self,
        steps: usize,
        radius: f64,
        indices: [usize; 2],
        form: CircleForm,
    ) -> Result<MovingCircle<NX>> {
        let (mut c, mut s) = (Vec::with_capacity(steps + 1), Vec::with_capacity(steps + 1));
        self.predict_positions(steps, &mut c, &mut s);
        MovingCircle::new(c, s, radius, indices, form)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn predict_and_update_equal_hand_computed_matrices() {
        let (dt, q, r) = (0.5, 2.0, 0.1);
        let mut kf = ObstacleTracker::new(dt, q, r, [1.0, 2.0], [3.0, -1.0], 0.2, 0.4).unwrap();
        // F and G by hand.
        let f = Matrix::<4, 4>::new(
            1.0, 0.5, 0.0, 0.0, //
            0.0, 1.0, 0.0, 0.0, //
            0.0, 0.0, 1.0, 0.5, //
            0.0, 0.0, 0.0, 1.0,
        );
        let g = Matrix::<4, 2>::new(0.125, 0.0, 0.5, 0.0, 0.0, 0.125, 0.0, 0.5);
        assert_eq!(kf.f(), f);
        assert_eq!(kf.g(), g);
        let p0 = Matrix::<4, 4>::from_diagonal(&Vector::<4>::new(0.04, 0.16, 0.04, 0.16));
        kf.predict();
        // a = F a0 = (1 + 0.5 * 3, 3, 2 - 0.5, -1); P = F P0 F^T + 4 G G^T.
        assert!((kf.state() - Vector::<4>::new(2.5, 3.0, 1.5, -1.0)).amax() < 1e-15);
        let p1 = f * p0 * f.transpose() + 4.0 * g * g.transpose();
        assert!((kf.covariance() - p1).amax() < 1e-15);
        // The x block of P1: [[0.04 + 0.25 * 0.16 + 4 * 0.125^2, 0.5 * 0.16 + 4 * 0.0625], [., 0.16 + 1]].
        assert!((p1[(0, 0)] - (0.04 + 0.04 + 0.0625)).abs() < 1e-15);
        assert!((p1[(0, 1)] - (0.08 + 0.25)).abs() < 1e-15);
        assert!((p1[(1, 1)] - 1.16).abs() < 1e-15);
        // Update with z: K = P H^T (H P H^T + r^2 I)^-1; the axes are uncoupled, so per axis
        // k = (p00, p10) / (p00 + r^2).
        kf.update([2.7, 1.4]).unwrap();
        let s = p1[(0, 0)] + r * r;
        let (k0, k1) = (p1[(0, 0)] / s, p1[(1, 0)] / s);
        assert!((kf.state()[0] - (2.5 + k0 * 0.2)).abs() < 1e-14);
        assert!((kf.state()[1] - (3.0 + k1 * 0.2)).abs() < 1e-14);
        assert!((kf.state()[2] - (1.5 - k0 * 0.1)).abs() < 1e-14);
        assert!((kf.covariance()[(0, 0)] - (1.0 - k0) * p1[(0, 0)]).abs() < 1e-14);
    }

    #[test]
    fn predicted_uncertainty_grows() {
        let kf = ObstacleTracker::new(0.1, 0.5, 0.05, [0.0, 0.0], [1.0, 0.0], 0.1, 0.3).unwrap();
        let (mut c, mut s) = (Vec::new(), Vec::new());
        kf.predict_positions(20, &mut c, &mut s);
        assert_eq!(c.len(), 21);
        for t in 1..=20 {
            assert!(s[t][(0, 0)] > s[t - 1][(0, 0)]);
            assert!((c[t][0] - 0.1 * t as f64).abs() < 1e-12);
        }
    }
}
