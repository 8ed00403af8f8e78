//! Rigid-body quadrotor with ZYX Euler angles.

use super::sin_cos;
use crate::autodiff::{DualDynamics, Scalar};
use crate::{Dynamics, Matrix, Result, Vector};
use nalgebra::{U12, U4};

/// A quadrotor as a rigid body driven by its collective thrust and three body torques: the
/// 12-state, 4-input quadrotor of the Safe-CDDP benchmark (Alcan and Kyrki (2022), Table I, after
/// Alcan and Unel 2017). Alcan and Kyrki (2022) give no physical parameters; the defaults are the
/// widely used small quadrotor `m = 0.468` kg, `J = diag(4.856e-3, 4.856e-3, 8.801e-3)` kg m^2,
/// `g = 9.81` m/s^2.
///
/// State `x = (p, eta, v, omega)` with
/// - `p = (px, py, pz)`: position in the world frame (z up), m;
/// - `eta = (phi, theta, psi)`: ZYX Euler angles (roll, pitch, yaw), `R = Rz(psi) Ry(theta) Rx(phi)`
///   maps body to world;
/// - `v`: velocity in the world frame, m/s;
/// - `omega = (p, q, r)`: body angular rates, rad/s.
///
/// Control `u = (T, tau_x, tau_y, tau_z)`: collective thrust along the body z axis (N) and body
/// torques (N m). Continuous dynamics, with `J = diag(Jx, Jy, Jz)`:
///
/// ```text
/// p' = v
/// eta' = W(phi, theta) omega        (Euler-rate map, singular at theta = +-pi/2)
/// v' = T / m R(eta) e3 - g e3
/// omega' = J^-1 (tau - omega x J omega)
/// ```
///
/// discretised by explicit Euler, `x+ = x + dt x'`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quadrotor {
    dt: f64,
    mass: f64,
    inertia: [f64; 3],
    gravity: f64,
}

impl Quadrotor {
    /// The default quadrotor ([`Quadrotor::default`]'s mass, inertia and gravity) with time step
    /// `dt` (s); an error unless `dt` is finite and positive.
    pub fn new(dt: f64) -> Result<Self> {
        Self::default().with_dt(dt)
    }

    /// A quadrotor with time step `dt` (s), `mass` (kg), principal moments of inertia
    /// `inertia = [Jx, Jy, Jz]` (kg m^2) and gravitational acceleration `gravity` (m/s^2, acting
    /// along -z). An error names the field unless `dt`, `mass` and the moments are finite and
    /// positive and `gravity` is finite and not negative.
    pub fn with_params(dt: f64, mass: f64, inertia: [f64; 3], gravity: f64) -> Result<Self> {
        Ok(Self {
            dt: super::positive("dt", dt)?,
            mass: super::positive("mass", mass)?,
            inertia: [
                super::positive("inertia[0]", inertia[0])?,
                super::positive("inertia[1]", inertia[1])?,
                super::positive("inertia[2]", inertia[2])?,
            ],
            gravity: super::nonnegative("gravity", gravity)?,
        })
    }

    /// The same quadrotor with another time step; an error unless `dt` is finite and positive.
    pub fn with_dt(self, dt: f64) -> Result<Self> {
        Ok(Self {
            dt: super::positive("dt", dt)?,
            ..self
        })
    }

    /// The time step (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The mass (kg).
    pub fn mass(&self) -> f64 {
        self.mass
    }

    /// The principal moments of inertia `[Jx, Jy, Jz]` (kg m^2).
    pub fn inertia(&self) -> [f64; 3] {
        self.inertia
    }

    /// The gravitational acceleration (m/s^2).
    pub fn gravity(&self) -> f64 {
        self.gravity
    }

    /// The thrust that balances gravity, `m g` (N).
    pub fn hover_thrust(&self) -> f64 {
        self.mass * self.gravity
    }

    /// The control that holds the quadrotor still when level: thrust `m g`, no torques.
    pub fn hover_control(&self) -> Vector<4> {
        Vector::<4>::new(self.hover_thrust(), 0.0, 0.0, 0.0)
    }

    /// Coefficients of the gyroscopic terms: `omega'_x = (tau_x + k_x q r) / Jx` etc.
    #[inline]
    fn gyro(&self) -> [f64; 3] {
        let [jx, jy, jz] = self.inertia;
        [(jy - jz) / jx, (jz - jx) / jy, (jx - jy) / jz]
    }
}

impl Default for Quadrotor {
    /// `dt = 0.05` s, `m = 0.468` kg, `J = diag(4.856e-3, 4.856e-3, 8.801e-3)` kg m^2, `g = 9.81`.
    fn default() -> Self {
        Self {
            dt: 0.05,
            mass: 0.468,
            inertia: [4.856e-3, 4.856e-3, 8.801e-3],
            gravity: 9.81,
        }
    }
}

/// Sines and cosines of the Euler angles, computed once per call.
#[derive(Clone, Copy)]
struct Trig {
    sf: f64,
    cf: f64,
    st: f64,
    ct: f64,
    sp: f64,
    cp: f64,
}

impl Trig {
    #[inline]
    fn new(x: &Vector<12>) -> Self {
        let (sf, cf) = sin_cos(x[3]);
        let (st, ct) = sin_cos(x[4]);
        let (sp, cp) = sin_cos(x[5]);
        Self { sf, cf, st, ct, sp, cp }
    }

    /// `R e3`, the body z axis in the world frame.
    #[inline]
    fn r3(&self) -> [f64; 3] {
        let Self { sf, cf, st, ct, sp, cp } = *self;
        [cp * st * cf + sp * sf, sp * st * cf - cp * sf, ct * cf]
    }
}

impl Dynamics<U12, U4> for Quadrotor {
    #[inline]
    fn step(&self, x: &Vector<12>, u: &Vector<4>) -> Vector<12> {
        let dt = self.dt;
        let t = Trig::new(x);
        let (p, q, r) = (x[9], x[10], x[11]);
        let tan_t = t.st / t.ct;
        // a = sf q + cf r appears in the roll and yaw rates.
        let a = t.sf * q + t.cf * r;
        let r3 = t.r3();
        let k = u[0] / self.mass;
        let g = self.gyro();
        let [jx, jy, jz] = self.inertia;
        let mut y = *x;
        y[0] += dt * x[6];
        y[1] += dt * x[7];
        y[2] += dt * x[8];
        y[3] += dt * (p + a * tan_t);
        y[4] += dt * (t.cf * q - t.sf * r);
        y[5] += dt * (a / t.ct);
        y[6] += dt * (k * r3[0]);
        y[7] += dt * (k * r3[1]);
        y[8] += dt * (k * r3[2] - self.gravity);
        y[9] += dt * (u[1] / jx + g[0] * q * r);
        y[10] += dt * (u[2] / jy + g[1] * r * p);
        y[11] += dt * (u[3] / jz + g[2] * p * q);
        y
    }

    fn jacobians(&self, x: &Vector<12>, u: &Vector<4>, fx: &mut Matrix<12, 12>, fu: &mut Matrix<12, 4>) {
        let dt = self.dt;
        let t = Trig::new(x);
        let Trig { sf, cf, st, ct, sp, cp } = t;
        let (p, q, r) = (x[9], x[10], x[11]);
        let tan_t = st / ct;
        let sec_t = 1.0 / ct;
        let a = sf * q + cf * r;
        // b = da/dphi = cf q - sf r, which is also the pitch rate.
        let b = cf * q - sf * r;
        let r3 = t.r3();
        let k = u[0] / self.mass;
        let g = self.gyro();
        let [jx, jy, jz] = self.inertia;

        super::set_identity(fx);
        // p' = v
        fx[(0, 6)] = dt;
        fx[(1, 7)] = dt;
        fx[(2, 8)] = dt;
        // roll rate p + a tan(theta)
        fx[(3, 3)] += dt * b * tan_t;
        fx[(3, 4)] = dt * a * sec_t * sec_t;
        fx[(3, 9)] = dt;
        fx[(3, 10)] = dt * sf * tan_t;
        fx[(3, 11)] = dt * cf * tan_t;
        // pitch rate b
        fx[(4, 3)] = -dt * a;
        fx[(4, 10)] = dt * cf;
        fx[(4, 11)] = -dt * sf;
        // yaw rate a / cos(theta)
        fx[(5, 3)] = dt * b * sec_t;
        fx[(5, 4)] += dt * a * tan_t * sec_t;
        fx[(5, 10)] = dt * sf * sec_t;
        fx[(5, 11)] = dt * cf * sec_t;
        // v' = k R e3: columns d(R e3)/d(phi, theta, psi)
        let kd = k * dt;
        fx[(6, 3)] = kd * (sp * cf - cp * st * sf);
        fx[(7, 3)] = kd * (-sp * st * sf - cp * cf);
        fx[(8, 3)] = kd * (-ct * sf);
        fx[(6, 4)] = kd * (cp * ct * cf);
        fx[(7, 4)] = kd * (sp * ct * cf);
        fx[(8, 4)] = kd * (-st * cf);
        fx[(6, 5)] = kd * (cp * sf - sp * st * cf);
        fx[(7, 5)] = kd * (cp * st * cf + sp * sf);
        // gyroscopic terms
        fx[(9, 10)] = dt * g[0] * r;
        fx[(9, 11)] = dt * g[0] * q;
        fx[(10, 9)] = dt * g[1] * r;
        fx[(10, 11)] = dt * g[1] * p;
        fx[(11, 9)] = dt * g[2] * q;
        fx[(11, 10)] = dt * g[2] * p;

        super::set_zero(fu);
        let dm = dt / self.mass;
        fu[(6, 0)] = dm * r3[0];
        fu[(7, 0)] = dm * r3[1];
        fu[(8, 0)] = dm * r3[2];
        fu[(9, 1)] = dt / jx;
        fu[(10, 2)] = dt / jy;
        fu[(11, 3)] = dt / jz;
    }

    fn has_second_order(&self) -> bool {
        true
    }

    fn add_second_order(
        &self,
        x: &Vector<12>,
        u: &Vector<4>,
        lambda: &Vector<12>,
        h_xx: &mut Matrix<12, 12>,
        h_ux: &mut Matrix<4, 12>,
        _h_uu: &mut Matrix<4, 4>,
    ) {
        let dt = self.dt;
        let Trig { sf, cf, st, ct, sp, cp } = Trig::new(x);
        let (q, r) = (x[10], x[11]);
        let tan_t = st / ct;
        let sec_t = 1.0 / ct;
        let a = sf * q + cf * r;
        let b = cf * q - sf * r;
        // Multipliers of the continuous-time right-hand side (x+ = x + dt x').
        let (m_roll, m_pitch, m_yaw) = (dt * lambda[3], dt * lambda[4], dt * lambda[5]);
        let nu = [dt * lambda[6], dt * lambda[7], dt * lambda[8]];
        let mu_w = [dt * lambda[9], dt * lambda[10], dt * lambda[11]];

        // Euler-rate map: roll rate p + a tan(theta), pitch rate b, yaw rate a sec(theta).
        let sec2 = sec_t * sec_t;
        let h_ff = -m_roll * a * tan_t - m_pitch * b - m_yaw * a * sec_t;
        let h_ft = m_roll * b * sec2 + m_yaw * b * tan_t * sec_t;
        let h_tt = m_roll * 2.0 * a * sec2 * tan_t + m_yaw * a * (1.0 + st * st) * sec2 * sec_t;
        let h_fq = m_roll * cf * tan_t - m_pitch * sf + m_yaw * cf * sec_t;
        let h_fr = -m_roll * sf * tan_t - m_pitch * cf - m_yaw * sf * sec_t;
        let h_tq = m_roll * sf * sec2 + m_yaw * sf * tan_t * sec_t;
        let h_tr = m_roll * cf * sec2 + m_yaw * cf * tan_t * sec_t;

        // Thrust direction: nu . d^2(R e3) / d eta^2, and the thrust-angle cross terms.
        let dot = |w: [f64; 3]| nu[0] * w[0] + nu[1] * w[1] + nu[2] * w[2];
        let r3 = [cp * st * cf + sp * sf, sp * st * cf - cp * sf, ct * cf];
        let r3_f = [sp * cf - cp * st * sf, -sp * st * sf - cp * cf, -ct * sf];
        let r3_t = [cp * ct * cf, sp * ct * cf, -st * cf];
        let r3_p = [cp * sf - sp * st * cf, cp * st * cf + sp * sf, 0.0];
        let r3_ff = [-r3[0], -r3[1], -r3[2]];
        let r3_tt = [-cp * st * cf, -sp * st * cf, -ct * cf];
        let r3_pp = [-r3[0], -r3[1], 0.0];
        let r3_ft = [-cp * ct * sf, -sp * ct * sf, st * sf];
        let r3_fp = [sp * st * sf + cp * cf, sp * cf - cp * st * sf, 0.0];
        let r3_tp = [-sp * ct * cf, cp * ct * cf, 0.0];
        let k = u[0] / self.mass;

        let e = [
            [h_ff + k * dot(r3_ff), h_ft + k * dot(r3_ft), k * dot(r3_fp)],
            [0.0, h_tt + k * dot(r3_tt), k * dot(r3_tp)],
            [0.0, 0.0, k * dot(r3_pp)],
        ];
        for i in 0..3 {
            h_xx[(3 + i, 3 + i)] += e[i][i];
            for j in i + 1..3 {
                h_xx[(3 + i, 3 + j)] += e[i][j];
                h_xx[(3 + j, 3 + i)] += e[i][j];
            }
        }
        for (angle, rate, value) in [(3, 10, h_fq), (3, 11, h_fr), (4, 10, h_tq), (4, 11, h_tr)] {
            h_xx[(angle, rate)] += value;
            h_xx[(rate, angle)] += value;
        }
        let inv_m = 1.0 / self.mass;
        h_ux[(0, 3)] += inv_m * dot(r3_f);
        h_ux[(0, 4)] += inv_m * dot(r3_t);
        h_ux[(0, 5)] += inv_m * dot(r3_p);

        // Gyroscopic terms are bilinear in the rates.
        let g = self.gyro();
        for (i, j, value) in [
            (10, 11, mu_w[0] * g[0]),
            (9, 11, mu_w[1] * g[1]),
            (9, 10, mu_w[2] * g[2]),
        ] {
            h_xx[(i, j)] += value;
            h_xx[(j, i)] += value;
        }
    }
}

impl DualDynamics<12, 4> for Quadrotor {
    fn step_generic<T: Scalar>(&self, x: &[T; 12], u: &[T; 4]) -> [T; 12] {
        let dt = self.dt;
        let (sf, cf) = x[3].sin_cos();
        let (st, ct) = x[4].sin_cos();
        let (sp, cp) = x[5].sin_cos();
        let (p, q, r) = (x[9], x[10], x[11]);
        let a = sf * q + cf * r;
        let k = u[0] / self.mass;
        let g = self.gyro();
        let [jx, jy, jz] = self.inertia;
        let rhs = [
            x[6],
            x[7],
            x[8],
            p + a * st / ct,
            cf * q - sf * r,
            a / ct,
            k * (cp * st * cf + sp * sf),
            k * (sp * st * cf - cp * sf),
            k * ct * cf - self.gravity,
            u[1] / jx + q * r * g[0],
            u[2] / jy + r * p * g[1],
            u[3] / jz + p * q * g[2],
        ];
        std::array::from_fn(|i| x[i] + rhs[i] * dt)
    }
}
