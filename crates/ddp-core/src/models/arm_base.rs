//! Planar free-floating base (a small satellite) carrying a 2-link arm.

use super::sin_cos;
use crate::autodiff::{DualDynamics, Scalar};
use crate::{Dynamics, Error, Matrix, Result, Vector};
use nalgebra::{U10, U5};

/// Physical parameters of an [`ArmBase`]. Plain data: [`ArmBase::from_params`] validates it.
///
/// The defaults describe a small satellite (a 10 kg, 0.5 m x 0.5 m body) with a 1 m arm of two
/// uniform 0.5 m, 1 kg rods mounted at the middle of its front face, stepped at 10 Hz.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmBaseParams {
    /// Time step (s), finite and > 0.
    pub dt: f64,
    /// Mass of the base (kg), finite and > 0.
    pub base_mass: f64,
    /// Moment of inertia of the base about its centre of mass (kg m^2), finite and > 0.
    pub base_inertia: f64,
    /// Width (along the body x axis) and height (body y axis) of the rectangular base (m), finite
    /// and > 0. Used only for geometry ([`ArmBase::base_corners`]); `base_inertia` is independent.
    pub base_size: [f64; 2],
    /// Position of the shoulder joint in the base frame, relative to the base centre of mass (m).
    pub mount: [f64; 2],
    /// Lengths of link 1 (shoulder to elbow) and link 2 (elbow to tool centre point) (m), > 0.
    pub link_lengths: [f64; 2],
    /// Masses of the links (kg), > 0; each link's centre of mass is at its middle.
    pub link_masses: [f64; 2],
    /// Moments of inertia of the links about their centres of mass (kg m^2), >= 0
    /// (`m l^2 / 12` for a uniform rod).
    pub link_inertias: [f64; 2],
}

impl Default for ArmBaseParams {
    fn default() -> Self {
        let (base_mass, side) = (10.0, 0.5);
        let (link_mass, link_length) = (1.0, 0.5);
        Self {
            dt: 0.1,
            base_mass,
            base_inertia: base_mass * (side * side + side * side) / 12.0,
            base_size: [side, side],
            mount: [0.5 * side, 0.0],
            link_lengths: [link_length; 2],
            link_masses: [link_mass; 2],
            link_inertias: [link_mass * link_length * link_length / 12.0; 2],
        }
    }
}

/// A rigid base floating in the plane (no gravity) with a 2-link arm: the planar version of the
/// satellite manipulator of IDNP (Richter et al. (2023), Section V-B). That paper approximates the
/// joints by double integrators and its physical parameters are not in our copy of the text; this
/// model keeps the full coupling between base and arm, with [`ArmBaseParams::default`] for a small
/// satellite.
///
/// Configuration `q = (x, y, theta, q1, q2)`: base centre of mass in the world frame (m), base
/// attitude (rad), shoulder and elbow joint angles (rad, relative: link 1 points along
/// `theta + q1`, link 2 along `theta + q1 + q2`). State `x = (q, q')` (10 entries); control
/// `u = (fx, fy, tau_0, tau_1, tau_2)`: a force on the base centre of mass in the world frame (N),
/// a torque on the base (N m) and the two joint motor torques (N m; joint 1 acts between base and
/// link 1, joint 2 between the links). With the Lagrangian of the three rigid bodies (links are
/// uniform rods), these are exactly the generalised forces, so
///
/// ```text
/// M(q) q'' + c(q, q') = u
/// ```
///
/// `M` and `c` depend on `theta, q1, q2` and the rates only. The step is semi-implicit
/// (symplectic) Euler: `v+ = v + dt q''(q, v, u)`, `q+ = q + dt v+`.
///
/// The equations are solved in absolute angles `phi_k` with the Schur complement of the
/// translational block (a 3 x 3 symmetric solve); Jacobians are analytic,
/// `dq''/dz = M^-1 (d(u)/dz - dc/dz - (dM/dz) q'')`, with hand-derived `dM/dq` and
/// `dc/d(q, q')`. The contracted second derivatives are analytic too, by differentiating
/// `M y = r` twice and contracting with the adjoint `kappa = M^-1 nu` (four extra 3 x 3 solves),
/// so full DDP costs about as much per knot as the Jacobians. Nothing allocates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmBase {
    params: ArmBaseParams,
    /// Total mass.
    m_total: f64,
    /// `sin`, `cos` of the angle of the mount point in the base frame.
    mount_dir: (f64, f64),
    /// First mass moments `a_k` of the arm chain about base, shoulder and elbow.
    a: [f64; 3],
    /// Second mass moments `L_kj` (inertia coupling of the absolute angles).
    l: [[f64; 3]; 3],
    /// Reduced coupling `L_kj - a_k a_j / m_total` (Schur complement coefficients).
    ls: [[f64; 3]; 3],
}

/// Trigonometry and rates of one configuration, in absolute angles
/// `phi_0 = theta + beta` (the mount direction), `phi_1 = theta + q1`, `phi_2 = theta + q1 + q2`.
#[derive(Clone, Copy)]
struct Kin<T> {
    /// `(cos phi_k, sin phi_k)`.
    e: [[T; 2]; 3],
    /// `cos(phi_k - phi_j)`.
    c: [[T; 3]; 3],
    /// `sin(phi_k - phi_j)`.
    s: [[T; 3]; 3],
    /// Absolute angular rates `omega_k = phi_k'`.
    w: [T; 3],
}

/// Inverse of a symmetric 3 x 3 matrix by its adjugate.
#[inline]
fn sym3_inverse<T: Scalar>(m: &[[T; 3]; 3]) -> [[T; 3]; 3] {
    let c00 = m[1][1] * m[2][2] - m[1][2] * m[1][2];
    let c01 = m[0][2] * m[1][2] - m[0][1] * m[2][2];
    let c02 = m[0][1] * m[1][2] - m[0][2] * m[1][1];
    let c11 = m[0][0] * m[2][2] - m[0][2] * m[0][2];
    let c12 = m[0][1] * m[0][2] - m[0][0] * m[1][2];
    let c22 = m[0][0] * m[1][1] - m[0][1] * m[0][1];
    let inv_det = (m[0][0] * c00 + m[0][1] * c01 + m[0][2] * c02).recip();
    [
        [c00 * inv_det, c01 * inv_det, c02 * inv_det],
        [c01 * inv_det, c11 * inv_det, c12 * inv_det],
        [c02 * inv_det, c12 * inv_det, c22 * inv_det],
    ]
}

impl ArmBase {
    /// The default small satellite and arm ([`ArmBaseParams::default`]) with time step `dt` (s);
    /// an error unless `dt` is finite and positive.
    pub fn new(dt: f64) -> Result<Self> {
        Self::from_params(ArmBaseParams {
            dt,
            ..ArmBaseParams::default()
        })
    }

    /// Validates `params` (an error names the field) and precomputes the mass moments.
    pub fn from_params(params: ArmBaseParams) -> Result<Self> {
        use super::{finite, nonnegative, positive};
        positive("dt", params.dt)?;
        positive("base_mass", params.base_mass)?;
        positive("base_inertia", params.base_inertia)?;
        for i in 0..2 {
            positive(&format!("base_size[{i}]"), params.base_size[i])?;
            finite(&format!("mount[{i}]"), params.mount[i])?;
            positive(&format!("link_lengths[{i}]"), params.link_lengths[i])?;
            positive(&format!("link_masses[{i}]"), params.link_masses[i])?;
            nonnegative(&format!("link_inertias[{i}]"), params.link_inertias[i])?;
        }
        let ArmBaseParams {
            base_mass: m0,
            base_inertia: i0,
            mount,
            link_lengths: [l1, l2],
            link_masses: [m1, m2],
            link_inertias: [i1, i2],
            ..
        } = params;
        let m_total = m0 + m1 + m2;
        let rho = mount[0].hypot(mount[1]);
        let beta = mount[1].atan2(mount[0]);
        let (h1, h2) = (0.5 * l1, 0.5 * l2);
        // Body i's centre of mass is at p + sum_k d_ik e(phi_k) with d = [[0, 0, 0], [rho, h1, 0],
        // [rho, l1, h2]]; a_k = sum_i m_i d_ik and L_kj = sum_i m_i d_ik d_ij + I_k delta_kj.
        let a = [(m1 + m2) * rho, m1 * h1 + m2 * l1, m2 * h2];
        let l01 = rho * a[1];
        let l02 = rho * a[2];
        let l12 = m2 * l1 * h2;
        let l = [
            [(m1 + m2) * rho * rho + i0, l01, l02],
            [l01, m1 * h1 * h1 + m2 * l1 * l1 + i1, l12],
            [l02, l12, m2 * h2 * h2 + i2],
        ];
        let ls = std::array::from_fn(|k| std::array::from_fn(|j| l[k][j] - a[k] * a[j] / m_total));
        let model = Self {
            params,
            m_total,
            mount_dir: sin_cos(beta),
            a,
            l,
            ls,
        };
        // The mass matrix is positive definite for positive masses and lengths; reject parameter
        // sets where round-off makes it numerically singular.
        let det = {
            let s = model.ls;
            s[0][0] * (s[1][1] * s[2][2] - s[1][2] * s[1][2]) - s[0][1] * (s[0][1] * s[2][2] - s[1][2] * s[0][2])
                + s[0][2] * (s[0][1] * s[1][2] - s[1][1] * s[0][2])
        };
        if !(det.is_finite() && det > 0.0) {
            return Err(Error::invalid(
                "link_masses",
                "mass matrix is singular for these parameters (masses and lengths too disparate)",
            ));
        }
        Ok(model)
    }

    /// The same model with another time step; an error unless `dt` is finite and positive.
    pub fn with_dt(self, dt: f64) -> Result<Self> {
        Self::from_params(ArmBaseParams { dt, ..self.params })
    }

    /// The parameters the model was built from.
    pub fn params(&self) -> &ArmBaseParams {
        &self.params
    }

    /// The time step (s).
    pub fn dt(&self) -> f64 {
        self.params.dt
    }

    /// Total mass of base and links (kg).
    pub fn total_mass(&self) -> f64 {
        self.m_total
    }

    /// Trigonometry of the absolute angles from `theta, q1, q2` (three `sin_cos` calls) and the
    /// absolute rates from the relative ones.
    #[inline]
    fn kin<T: Scalar>(&self, th: T, q1: T, q2: T, v: [T; 3]) -> Kin<T> {
        let (sb, cb) = self.mount_dir;
        let (st, ct) = th.sin_cos();
        let (s1, c1) = q1.sin_cos();
        let (s2, c2) = q2.sin_cos();
        // Angle sums: phi_1 = theta + q1, phi_2 = phi_1 + q2, phi_0 = theta + beta.
        let e1 = [ct * c1 - st * s1, st * c1 + ct * s1];
        let e2 = [e1[0] * c2 - e1[1] * s2, e1[1] * c2 + e1[0] * s2];
        let e0 = [ct * cb - st * sb, st * cb + ct * sb];
        // Differences: phi_1 - phi_0 = q1 - beta, phi_2 - phi_0 = q1 + q2 - beta, phi_2 - phi_1 = q2.
        let (c10, s10) = (c1 * cb + s1 * sb, s1 * cb - c1 * sb);
        let (c20, s20) = (c10 * c2 - s10 * s2, s10 * c2 + c10 * s2);
        let zero = T::from(0.0);
        let one = T::from(1.0);
        Kin {
            e: [e0, e1, e2],
            c: [[one, c10, c20], [c10, one, c2], [c20, c2, one]],
            s: [[zero, -s10, -s20], [s10, zero, -s2], [s20, s2, zero]],
            w: [v[0], v[0] + v[1], v[0] + v[1] + v[2]],
        }
    }

    /// Reduced 3 x 3 angular mass matrix `S_kj = (L_kj - a_k a_j / m) cos(phi_k - phi_j)`.
    #[inline]
    fn schur<T: Scalar>(&self, k: &Kin<T>) -> [[T; 3]; 3] {
        let (c, ls) = (&k.c, &self.ls);
        [
            [c[0][0] * ls[0][0], c[0][1] * ls[0][1], c[0][2] * ls[0][2]],
            [c[1][0] * ls[1][0], c[1][1] * ls[1][1], c[1][2] * ls[1][2]],
            [c[2][0] * ls[2][0], c[2][1] * ls[2][1], c[2][2] * ls[2][2]],
        ]
    }

    /// `M^-1 r` in absolute coordinates `(p, phi)`, given `S^-1`.
    #[inline]
    fn solve<T: Scalar>(&self, k: &Kin<T>, s_inv: &[[T; 3]; 3], r: [T; 5]) -> [T; 5] {
        let inv_m = 1.0 / self.m_total;
        // G_k = a_k e_perp(phi_k) couples translation and rotation; b = r_a - G^T r_p / m.
        let mut b = [r[2], r[3], r[4]];
        for i in 0..3 {
            b[i] -= (r[1] * k.e[i][0] - r[0] * k.e[i][1]) * (self.a[i] * inv_m);
        }
        let mut wd = [r[0]; 3];
        for i in 0..3 {
            wd[i] = s_inv[i][0] * b[0] + s_inv[i][1] * b[1] + s_inv[i][2] * b[2];
        }
        let mut px = r[0];
        let mut py = r[1];
        for i in 0..3 {
            px += k.e[i][1] * wd[i] * self.a[i];
            py -= k.e[i][0] * wd[i] * self.a[i];
        }
        [px * inv_m, py * inv_m, wd[0], wd[1], wd[2]]
    }

    /// Accelerations in absolute coordinates `(p'', omega')` and the kinematics, for
    /// configuration angles `(theta, q1, q2)`, relative rates and controls.
    #[inline]
    fn abs_accel<T: Scalar>(&self, ang: [T; 3], rates: [T; 3], u: &[T; 5]) -> (Kin<T>, [[T; 3]; 3], [T; 5]) {
        let k = self.kin(ang[0], ang[1], ang[2], rates);
        let s_inv = sym3_inverse(&self.schur(&k));
        let w2 = [k.w[0] * k.w[0], k.w[1] * k.w[1], k.w[2] * k.w[2]];
        // Generalised forces in absolute angles: joint torques act on both bodies they connect.
        // Velocity terms: c_p = -sum_k a_k e_k w_k^2, c_k = sum_j L_kj sin(phi_k - phi_j) w_j^2.
        let mut r = [u[0], u[1], u[2] - u[3], u[3] - u[4], u[4]];
        for i in 0..3 {
            r[0] += k.e[i][0] * w2[i] * self.a[i];
            r[1] += k.e[i][1] * w2[i] * self.a[i];
            for j in 0..3 {
                if j != i {
                    r[2 + i] -= k.s[i][j] * w2[j] * self.l[i][j];
                }
            }
        }
        let y = self.solve(&k, &s_inv, r);
        (k, s_inv, y)
    }

    /// Relative accelerations `q''` for a configuration `q` and rates `v` (generic scalar).
    #[inline]
    fn accel_generic<T: Scalar>(&self, q: [T; 3], v: [T; 3], u: &[T; 5]) -> [T; 5] {
        let (_, _, y) = self.abs_accel(q, v, u);
        [y[0], y[1], y[2], y[3] - y[2], y[4] - y[3]]
    }

    /// Right-hand sides `r_b = dr/db - (dM/db) y` with `M dy/db = r_b`, for `b` in
    /// `(phi_0, phi_1, phi_2, omega_0, omega_1, omega_2)`, where `r = Q - c` and `y` the absolute
    /// accelerations.
    #[inline]
    fn first_order_rhs(&self, k: &Kin<f64>, y: &[f64; 5]) -> [[f64; 5]; 6] {
        let (a, l) = (&self.a, &self.l);
        let wd = [y[2], y[3], y[4]];
        let mut rhs = [[0.0; 5]; 6];
        for m in 0..3 {
            let (c, s) = (k.e[m][0], k.e[m][1]);
            let w = k.w[m];
            // -dc/dphi_m - (dM/dphi_m) y
            let r = &mut rhs[m];
            r[0] = a[m] * (-s * w * w + c * wd[m]);
            r[1] = a[m] * (c * w * w + s * wd[m]);
            r[2 + m] = a[m] * (c * y[0] + s * y[1]);
            for j in 0..3 {
                if j != m {
                    r[2 + m] += l[m][j] * (k.s[m][j] * wd[j] - k.c[m][j] * k.w[j] * k.w[j]);
                    r[2 + j] = l[j][m] * (k.c[j][m] * w * w - k.s[j][m] * wd[m]);
                }
            }
            // -dc/domega_m
            let r = &mut rhs[3 + m];
            r[0] = 2.0 * a[m] * c * w;
            r[1] = 2.0 * a[m] * s * w;
            for j in 0..3 {
                if j != m {
                    r[2 + j] = -2.0 * l[j][m] * k.s[j][m] * w;
                }
            }
        }
        rhs
    }

    /// `(dM/dphi_m) w` in absolute coordinates.
    #[inline]
    fn dm_times(&self, k: &Kin<f64>, m: usize, w: &[f64; 5]) -> [f64; 5] {
        let (a, l) = (&self.a, &self.l);
        let (c, s) = (k.e[m][0], k.e[m][1]);
        let mut out = [0.0; 5];
        // d(a_m e_perp(phi_m))/dphi_m = -a_m e(phi_m), in the translational rows and in row m.
        out[0] = -a[m] * c * w[2 + m];
        out[1] = -a[m] * s * w[2 + m];
        out[2 + m] = -a[m] * (c * w[0] + s * w[1]);
        // d(L_kj cos(phi_k - phi_j))/dphi_m = -L_kj sin(phi_k - phi_j) (delta_km - delta_jm).
        for j in 0..3 {
            if j != m {
                out[2 + m] -= l[m][j] * k.s[m][j] * w[2 + j];
                out[2 + j] += l[j][m] * k.s[j][m] * w[2 + m];
            }
        }
        out
    }

    /// Continuous-time accelerations `q'' = M(q)^-1 (u - c(q, q'))` at state `x`, control `u`.
    pub fn acceleration(&self, x: &Vector<10>, u: &Vector<5>) -> Vector<5> {
        Vector::<5>::from(self.accel_generic([x[2], x[3], x[4]], [x[7], x[8], x[9]], &(*u).into()))
    }

    /// The shoulder, the elbow and the tool centre point in the world frame (m): the end points of
    /// the two links (the capsules of collision checks).
    pub fn link_endpoints(&self, x: &Vector<10>) -> [[f64; 2]; 3] {
        let k = self.kin(x[2], x[3], x[4], [0.0; 3]);
        let rho = self.params.mount[0].hypot(self.params.mount[1]);
        let [l1, l2] = self.params.link_lengths;
        let shoulder = [x[0] + rho * k.e[0][0], x[1] + rho * k.e[0][1]];
        let elbow = [shoulder[0] + l1 * k.e[1][0], shoulder[1] + l1 * k.e[1][1]];
        let tcp = [elbow[0] + l2 * k.e[2][0], elbow[1] + l2 * k.e[2][1]];
        [shoulder, elbow, tcp]
    }

    /// Jacobians `d point / d x` (2 x 10) of the shoulder, elbow and tool centre point.
    pub fn link_endpoint_jacobians(&self, x: &Vector<10>) -> [Matrix<2, 10>; 3] {
        let k = self.kin(x[2], x[3], x[4], [0.0; 3]);
        let rho = self.params.mount[0].hypot(self.params.mount[1]);
        let [l1, l2] = self.params.link_lengths;
        let lengths = [rho, l1, l2];
        let mut out = [Matrix::<2, 10>::zeros(); 3];
        for (p, jac) in out.iter_mut().enumerate() {
            jac[(0, 0)] = 1.0;
            jac[(1, 1)] = 1.0;
            // Segment k rotates with theta, and with q1 (k >= 1) and q2 (k = 2).
            for seg in 0..=p {
                let (dx, dy) = (-lengths[seg] * k.e[seg][1], lengths[seg] * k.e[seg][0]);
                for col in 2..=2 + seg {
                    jac[(0, col)] += dx;
                    jac[(1, col)] += dy;
                }
            }
        }
        out
    }

    /// The tool centre point (end of link 2) in the world frame (m).
    pub fn tcp_position(&self, x: &Vector<10>) -> [f64; 2] {
        self.link_endpoints(x)[2]
    }

    /// Jacobian `d tcp / d x` (2 x 10) of the tool centre point.
    pub fn tcp_jacobian(&self, x: &Vector<10>) -> Matrix<2, 10> {
        self.link_endpoint_jacobians(x)[2]
    }

    /// Corners of the rectangular base in the world frame, counter-clockwise from the body's
    /// (+x, +y) corner.
    pub fn base_corners(&self, x: &Vector<10>) -> [[f64; 2]; 4] {
        let (s, c) = sin_cos(x[2]);
        let [w, h] = self.params.base_size;
        [
            (0.5 * w, 0.5 * h),
            (-0.5 * w, 0.5 * h),
            (-0.5 * w, -0.5 * h),
            (0.5 * w, -0.5 * h),
        ]
        .map(|(bx, by)| [x[0] + c * bx - s * by, x[1] + s * bx + c * by])
    }

    /// Centre of mass of the whole system in the world frame (m).
    pub fn centre_of_mass(&self, x: &Vector<10>) -> [f64; 2] {
        let k = self.kin(x[2], x[3], x[4], [0.0; 3]);
        let mut com = [x[0], x[1]];
        for i in 0..3 {
            com[0] += self.a[i] * k.e[i][0] / self.m_total;
            com[1] += self.a[i] * k.e[i][1] / self.m_total;
        }
        com
    }

    /// Linear momentum of the whole system (kg m/s).
    pub fn linear_momentum(&self, x: &Vector<10>) -> [f64; 2] {
        let k = self.kin(x[2], x[3], x[4], [x[7], x[8], x[9]]);
        let mut p = [self.m_total * x[5], self.m_total * x[6]];
        for i in 0..3 {
            p[0] -= self.a[i] * k.e[i][1] * k.w[i];
            p[1] += self.a[i] * k.e[i][0] * k.w[i];
        }
        p
    }

    /// Kinetic energy of the whole system (J).
    pub fn kinetic_energy(&self, x: &Vector<10>) -> f64 {
        let k = self.kin(x[2], x[3], x[4], [x[7], x[8], x[9]]);
        let (vx, vy) = (x[5], x[6]);
        let mut t = 0.5 * self.m_total * (vx * vx + vy * vy);
        for i in 0..3 {
            t += self.a[i] * k.w[i] * (-vx * k.e[i][1] + vy * k.e[i][0]);
            for j in 0..3 {
                t += 0.5 * self.l[i][j] * k.c[i][j] * k.w[i] * k.w[j];
            }
        }
        t
    }
}

impl Default for ArmBase {
    /// The model of [`ArmBaseParams::default`].
    fn default() -> Self {
        Self::from_params(ArmBaseParams::default()).expect("default parameters are valid")
    }
}

impl Dynamics<U10, U5> for ArmBase {
    #[inline]
    fn step(&self, x: &Vector<10>, u: &Vector<5>) -> Vector<10> {
        let dt = self.params.dt;
        let qdd = self.accel_generic([x[2], x[3], x[4]], [x[7], x[8], x[9]], &(*u).into());
        let mut y = *x;
        for i in 0..5 {
            y[5 + i] += dt * qdd[i];
            y[i] += dt * y[5 + i];
        }
        y
    }

    fn jacobians(&self, x: &Vector<10>, u: &Vector<5>, fx: &mut Matrix<10, 10>, fu: &mut Matrix<10, 5>) {
        let dt = self.params.dt;
        let (k, s_inv, y) = self.abs_accel([x[2], x[3], x[4]], [x[7], x[8], x[9]], &(*u).into());
        let rhs = self.first_order_rhs(&k, &y);
        let solve = |r: [f64; 5]| self.solve(&k, &s_inv, r);
        let d_phi = [solve(rhs[0]), solve(rhs[1]), solve(rhs[2])];
        let d_w = [solve(rhs[3]), solve(rhs[4]), solve(rhs[5])];
        // Controls enter through the generalised forces (fx, fy, tau_0 - tau_1, tau_1 - tau_2, tau_2).
        let d_u = [
            solve([1.0, 0.0, 0.0, 0.0, 0.0]),
            solve([0.0, 1.0, 0.0, 0.0, 0.0]),
            solve([0.0, 0.0, 1.0, 0.0, 0.0]),
            solve([0.0, 0.0, -1.0, 1.0, 0.0]),
            solve([0.0, 0.0, 0.0, -1.0, 1.0]),
        ];

        // Absolute to relative: d/dtheta = sum_m d/dphi_m, d/dq1 = d/dphi_1 + d/dphi_2,
        // d/dq2 = d/dphi_2 (likewise for rates); q'' = (p'', w'_0, w'_1 - w'_0, w'_2 - w'_1).
        let rel = |c: [f64; 5]| [c[0], c[1], c[2], c[3] - c[2], c[4] - c[3]];
        let mut qdd_q = [[0.0; 5]; 5];
        let mut qdd_v = [[0.0; 5]; 5];
        let mut qdd_u = [[0.0; 5]; 5];
        for r in 0..5 {
            qdd_q[4][r] = d_phi[2][r];
            qdd_q[3][r] = d_phi[1][r] + qdd_q[4][r];
            qdd_q[2][r] = d_phi[0][r] + qdd_q[3][r];
            qdd_v[4][r] = d_w[2][r];
            qdd_v[3][r] = d_w[1][r] + qdd_v[4][r];
            qdd_v[2][r] = d_w[0][r] + qdd_v[3][r];
        }
        for c in 2..5 {
            qdd_q[c] = rel(qdd_q[c]);
            qdd_v[c] = rel(qdd_v[c]);
        }
        for j in 0..5 {
            qdd_u[j] = rel(d_u[j]);
        }

        // v+ = v + dt q'', q+ = q + dt v+.
        let dt2 = dt * dt;
        for r in 0..5 {
            for c in 0..5 {
                let id = if r == c { 1.0 } else { 0.0 };
                fx[(r, c)] = id + dt2 * qdd_q[c][r];
                fx[(r, 5 + c)] = dt * id + dt2 * qdd_v[c][r];
                fx[(5 + r, c)] = dt * qdd_q[c][r];
                fx[(5 + r, 5 + c)] = id + dt * qdd_v[c][r];
                fu[(r, c)] = dt2 * qdd_u[c][r];
                fu[(5 + r, c)] = dt * qdd_u[c][r];
            }
        }
    }

    fn has_second_order(&self) -> bool {
        true
    }

    fn add_second_order(
        &self,
        x: &Vector<10>,
        u: &Vector<5>,
        lambda: &Vector<10>,
        h_xx: &mut Matrix<10, 10>,
        h_ux: &mut Matrix<5, 10>,
        _h_uu: &mut Matrix<5, 5>,
    ) {
        // f = (q + dt v + dt^2 q'', v + dt q''), so sum_i lambda_i f_i'' = (mu . q'')'' with
        // mu = dt^2 lambda_q + dt lambda_v, and mu . q'' = nu . y in absolute coordinates
        // (nu = P' mu for q'' = P y). Differentiating M y = r(z) twice,
        //   nu . y_ab = kappa . (r_ab - M_a y_b - M_b y_a - M_ab y),   kappa = M^-1 nu,
        // and kappa . M_a y_b = t_a . r_b with t_a = M^-1 M_a kappa and M y_b = r_b (the
        // Jacobian right-hand sides). Controls enter r linearly: nu . y_ua = -t_a . B e_u.
        let dt = self.params.dt;
        let (k, s_inv, y) = self.abs_accel([x[2], x[3], x[4]], [x[7], x[8], x[9]], &(*u).into());
        let rhs = self.first_order_rhs(&k, &y);
        let mut mu = [0.0; 5];
        for r in 0..5 {
            mu[r] = dt * dt * lambda[r] + dt * lambda[5 + r];
        }
        let nu = [mu[0], mu[1], mu[2] - mu[3], mu[3] - mu[4], mu[4]];
        let kappa = self.solve(&k, &s_inv, nu);
        let t_of = |m: usize| self.solve(&k, &s_inv, self.dm_times(&k, m, &kappa));
        let t = [t_of(0), t_of(1), t_of(2)];
        let (a, l, w) = (&self.a, &self.l, &k.w);
        let kap = [kappa[2], kappa[3], kappa[4]];
        let wd = [y[2], y[3], y[4]];
        let e_perp = |m: usize| [-k.e[m][1], k.e[m][0]];
        let dot2 = |p: [f64; 2], q: [f64; 2]| p[0] * q[0] + p[1] * q[1];
        let kp = [kappa[0], kappa[1]];
        let yp = [y[0], y[1]];

        // Hessian over (phi_0, phi_1, phi_2, omega_0, omega_1, omega_2).
        let mut h = [[0.0; 6]; 6];
        for m in 0..3 {
            for n in 0..3 {
                // (pp, pw, ww): the (phi_m, phi_n), (phi_m, omega_n) and (omega_m, omega_n) entries.
                let (mut pp, mut pw, mut ww);
                if m != n {
                    // -(kappa . c)_ab, with kappa . c = -sum_k a_k (kappa_p . e_k) w_k^2
                    //                                   + sum_kj kappa_k L_kj sin(phi_k - phi_j) w_j^2,
                    pp = -kap[m] * l[m][n] * k.s[m][n] * w[n] * w[n] - kap[n] * l[n][m] * k.s[n][m] * w[m] * w[m];
                    pw = -2.0 * kap[m] * l[m][n] * k.c[m][n] * w[n];
                    ww = 0.0;
                    // and -kappa . M_mn y.
                    pp -= l[m][n] * k.c[m][n] * (kap[m] * wd[n] + kap[n] * wd[m]);
                } else {
                    let (em, pm) = ([k.e[m][0], k.e[m][1]], e_perp(m));
                    // -(kappa . c)_ab on the diagonal,
                    pp = -a[m] * dot2(kp, em) * w[m] * w[m];
                    pw = 2.0 * a[m] * dot2(kp, pm) * w[m];
                    ww = 2.0 * a[m] * dot2(kp, em);
                    for j in 0..3 {
                        if j != m {
                            pp +=
                                kap[m] * l[m][j] * k.s[m][j] * w[j] * w[j] + kap[j] * l[j][m] * k.s[j][m] * w[m] * w[m];
                            pw += 2.0 * kap[j] * l[j][m] * k.c[j][m] * w[m];
                            ww -= 2.0 * kap[j] * l[j][m] * k.s[j][m];
                        }
                    }
                    // and -kappa . M_mm y.
                    pp += a[m] * (dot2(kp, pm) * wd[m] + dot2(yp, pm) * kap[m]);
                    for j in 0..3 {
                        if j != m {
                            pp += l[m][j] * k.c[m][j] * (kap[m] * wd[j] + kap[j] * wd[m]);
                        }
                    }
                }
                // -kappa . (M_a y_b + M_b y_a) = -(t_a . r_b + t_b . r_a) for a, b in phi.
                let dot5 =
                    |p: &[f64; 5], q: &[f64; 5]| p[0] * q[0] + p[1] * q[1] + p[2] * q[2] + p[3] * q[3] + p[4] * q[4];
                pp -= dot5(&t[m], &rhs[n]) + dot5(&t[n], &rhs[m]);
                pw -= dot5(&t[m], &rhs[3 + n]);
                h[m][n] += pp;
                h[m][3 + n] += pw;
                h[3 + n][m] += pw;
                h[3 + m][3 + n] += ww;
            }
        }
        // Cross terms with the controls, over phi: -t_m . B e_u, with B' t = (t0, t1, t2, t3 - t2, t4 - t3).
        let mut x_u = [[0.0; 3]; 5];
        for (m, tm) in t.iter().enumerate() {
            let bt = [tm[0], tm[1], tm[2], tm[3] - tm[2], tm[4] - tm[3]];
            for j in 0..5 {
                x_u[j][m] = -bt[j];
            }
        }

        // Back to relative coordinates: d/dtheta = sum_m d/dphi_m, d/dq1 = d/dphi_1 + d/dphi_2,
        // d/dq2 = d/dphi_2, likewise for the rates (suffix sums within each block of three).
        let suffix = |v: &mut [f64; 6]| {
            for b in [0, 3] {
                v[b + 1] += v[b + 2];
                v[b] += v[b + 1];
            }
        };
        for row in h.iter_mut() {
            suffix(row);
        }
        for c in 0..6 {
            let mut col = [h[0][c], h[1][c], h[2][c], h[3][c], h[4][c], h[5][c]];
            suffix(&mut col);
            for r in 0..6 {
                h[r][c] = col[r];
            }
        }
        const VARS: [usize; 6] = [2, 3, 4, 7, 8, 9];
        for i in 0..6 {
            for j in 0..6 {
                h_xx[(VARS[i], VARS[j])] += h[i][j];
            }
        }
        for (j, row) in x_u.iter().enumerate() {
            h_ux[(j, 2)] += row[0] + row[1] + row[2];
            h_ux[(j, 3)] += row[1] + row[2];
            h_ux[(j, 4)] += row[2];
        }
    }
}

impl DualDynamics<10, 5> for ArmBase {
    fn step_generic<T: Scalar>(&self, x: &[T; 10], u: &[T; 5]) -> [T; 10] {
        let dt = self.params.dt;
        let qdd = self.accel_generic([x[2], x[3], x[4]], [x[7], x[8], x[9]], u);
        let mut y = *x;
        for i in 0..5 {
            y[5 + i] += qdd[i] * dt;
            y[i] += y[5 + i] * dt;
        }
        y
    }
}
