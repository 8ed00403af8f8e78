//! Inverse space mapping (Richter et al. (2023), eq. (5)): from a TCP waypoint `z` to a
//! configuration `q` close to the previous one `q_prev`, with a margin to the obstacles.
//!
//! ```text
//! min_q  |q - q_prev|_W^2 + w_m sum_{b,o} max(0, m - sd_{b,o}(q))^2 + w_l |limit violation|^2
//! s.t.   tcp(q) = z
//! ```
//!
//! solved by Levenberg-Marquardt on the stacked residuals with the TCP condition as a heavy
//! residual (`w_tcp`), followed by minimum-norm Gauss-Newton steps on `tcp(q) = z` alone so that
//! the TCP is met to `tcp_tolerance`. The start is `q_prev` with the base translated so that its
//! TCP is at `z`. The result is **infeasible** (reported with the waypoint and the reason) when
//! the TCP is not reached, a body penetrates an obstacle beyond `-min_clearance`, a joint or base
//! limit is violated, or the base would have to move farther than `max_base_step` from
//! `q_prev` (the waypoint is out of reach within a stage).
//!
//! | symbol | field |
//! |---|---|
//! | `W` | [`InverseSettings::closeness`] |
//! | `m`, `w_m` | [`InverseSettings::margin`], [`InverseSettings::margin_weight`] |
//! | `w_l` | [`InverseSettings::limit_weight`] |

use ddp_core::Matrix;
use nalgebra::{Matrix5, Vector5};
use serde::Serialize;

use crate::error::{nonnegative, positive, Result};
use crate::scene::{Body, Config, Scene};

/// Settings of the inverse mapping.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InverseSettings {
    /// Diagonal of `W` on `(x, y, theta, q1, q2)`.
    pub closeness: [f64; 5],
    /// Desired clearance `m` (m).
    pub margin: f64,
    /// `w_m`.
    pub margin_weight: f64,
    /// `w_l`.
    pub limit_weight: f64,
    /// Weight of the TCP residual in the Levenberg-Marquardt phase.
    pub tcp_weight: f64,
    /// Levenberg-Marquardt iterations.
    pub iterations: usize,
    /// Largest TCP error of a feasible result (m).
    pub tcp_tolerance: f64,
    /// Smallest clearance of a feasible result (m); 0 accepts touching.
    pub min_clearance: f64,
    /// Largest base displacement from `q_prev` per axis (m).
    pub max_base_step: f64,
}

impl Default for InverseSettings {
    fn default() -> Self {
        Self {
            closeness: [1.0, 1.0, 0.5, 0.2, 0.2],
            margin: 0.3,
            margin_weight: 100.0,
            limit_weight: 100.0,
            tcp_weight: 1e4,
            iterations: 40,
            tcp_tolerance: 1e-6,
            min_clearance: 0.02,
            max_base_step: 3.0,
        }
    }
}

impl InverseSettings {
    /// Rejects settings that cannot work, naming the field.
    pub fn validate(&self) -> Result<()> {
        for (i, &w) in self.closeness.iter().enumerate() {
            nonnegative(&format!("inverse.closeness[{i}]"), w)?;
        }
        nonnegative("inverse.margin", self.margin)?;
        nonnegative("inverse.margin_weight", self.margin_weight)?;
        nonnegative("inverse.limit_weight", self.limit_weight)?;
        positive("inverse.tcp_weight", self.tcp_weight)?;
        positive("inverse.tcp_tolerance", self.tcp_tolerance)?;
        crate::error::finite("inverse.min_clearance", self.min_clearance)?;
        positive("inverse.max_base_step", self.max_base_step)?;
        Ok(())
    }
}

/// Why a waypoint could not be mapped.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum InfeasibleReason {
    /// The TCP stays this far (m) from the waypoint.
    TcpNotReached {
        /// Remaining TCP error (m).
        error: f64,
    },
    /// A body penetrates (or comes closer than the minimum clearance to) an obstacle.
    Collision {
        /// The body.
        body: Body,
        /// Index of the obstacle in the scene.
        obstacle: usize,
        /// Its signed distance (m).
        distance: f64,
    },
    /// A joint or base limit is violated.
    Limit {
        /// Which limit (`"joint q1"`, `"base x"`, ...).
        which: &'static str,
    },
    /// The base would move farther than the per-stage bound.
    OutOfReach {
        /// The base displacement needed (m, largest axis).
        base_step: f64,
    },
}

/// A waypoint that could not be mapped: the stage, the waypoint and the reason.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct InverseFailure {
    /// Time index `j` of the waypoint.
    pub stage: usize,
    /// The waypoint `z_j`.
    pub waypoint: [f64; 2],
    /// Why it failed.
    pub reason: InfeasibleReason,
}

/// The residual vector of the LM phase: 2 TCP + 5 closeness + 3 per obstacle + 4 limits.
fn residuals(
    scene: &Scene,
    s: &InverseSettings,
    q: &Config,
    q_prev: &Config,
    z: [f64; 2],
    w_tcp: f64,
) -> (Vec<f64>, Vec<Vector5<f64>>) {
    let x = Scene::state_at_rest(q);
    let mut r = Vec::with_capacity(11 + 3 * scene.obstacles.len());
    let mut j = Vec::with_capacity(r.capacity());
    let tcp = scene.robot.tcp_position(&x);
    let jt: Matrix<2, 10> = scene.robot.tcp_jacobian(&x);
    let st = w_tcp.sqrt();
    for a in 0..2 {
        r.push(st * (tcp[a] - z[a]));
        j.push(Vector5::from_fn(|k, _| st * jt[(a, k)]));
    }
    for k in 0..5 {
        let w = s.closeness[k].sqrt();
        r.push(w * (q[k] - q_prev[k]));
        let mut g = Vector5::zeros();
        g[k] = w;
        j.push(g);
    }
    let sm = s.margin_weight.sqrt();
    for o in &scene.obstacles {
        for body in Body::ALL {
            let d = scene.body_distance(&x, body, o);
            if d.distance < s.margin {
                r.push(sm * (s.margin - d.distance));
                j.push(-sm * d.gradient);
            }
        }
    }
    let sl = s.limit_weight.sqrt();
    let lims = [
        (0, scene.base_limits[0]),
        (1, scene.base_limits[1]),
        (3, scene.joint_limits[0]),
        (4, scene.joint_limits[1]),
    ];
    for (k, lim) in lims {
        let v = if q[k] > lim[1] {
            q[k] - lim[1]
        } else if q[k] < lim[0] {
            q[k] - lim[0]
        } else {
            continue;
        };
        r.push(sl * v);
        let mut g = Vector5::zeros();
        g[k] = sl;
        j.push(g);
    }
    (r, j)
}

fn cost(r: &[f64]) -> f64 {
    0.5 * r.iter().map(|v| v * v).sum::<f64>()
}

/// Maps the waypoint `z` (time index `stage`) to a configuration near `q_prev` (eq. (5)).
pub fn inverse_map(
    scene: &Scene,
    settings: &InverseSettings,
    q_prev: &Config,
    z: [f64; 2],
    stage: usize,
) -> std::result::Result<Config, InverseFailure> {
    let (q, reason) = solve(scene, settings, q_prev, z);
    match reason {
        None => Ok(q),
        Some(reason) => Err(InverseFailure {
            stage,
            waypoint: z,
            reason,
        }),
    }
}

/// The optimisation of eq. (5): the best configuration found and, if it is infeasible, why.
fn solve(
    scene: &Scene,
    settings: &InverseSettings,
    q_prev: &Config,
    z: [f64; 2],
) -> (Config, Option<InfeasibleReason>) {
    // Start: the previous configuration translated so that its TCP is at z.
    let tcp_prev = scene.tcp(q_prev);
    let mut q = *q_prev;
    q[0] += z[0] - tcp_prev[0];
    q[1] += z[1] - tcp_prev[1];
    let mut lambda = 1e-3;
    let (mut r, mut jac) = residuals(scene, settings, &q, q_prev, z, settings.tcp_weight);
    let mut f = cost(&r);
    for _ in 0..settings.iterations {
        let mut h = Matrix5::<f64>::zeros();
        let mut g = Vector5::<f64>::zeros();
        for (ri, ji) in r.iter().zip(&jac) {
            h += ji * ji.transpose();
            g += ji * *ri;
        }
        let mut improved = false;
        for _ in 0..10 {
            let mut hl = h;
            for k in 0..5 {
                hl[(k, k)] += lambda * (1.0 + h[(k, k)]);
            }
            let Some(chol) = hl.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let dq = -chol.solve(&g);
            let q_try = q + dq;
            let (r_try, j_try) = residuals(scene, settings, &q_try, q_prev, z, settings.tcp_weight);
            let f_try = cost(&r_try);
            if f_try < f {
                q = q_try;
                r = r_try;
                jac = j_try;
                let rel = (f - f_try) / (1.0 + f);
                f = f_try;
                lambda = (lambda * 0.3).max(1e-9);
                improved = rel > 1e-12;
                break;
            }
            lambda *= 10.0;
        }
        if !improved || g.norm() < 1e-10 {
            break;
        }
    }
    // Minimum-norm Gauss-Newton steps on tcp(q) = z.
    for _ in 0..5 {
        let x = Scene::state_at_rest(&q);
        let tcp = scene.robot.tcp_position(&x);
        let e = nalgebra::Vector2::new(z[0] - tcp[0], z[1] - tcp[1]);
        if e.norm() <= 0.1 * settings.tcp_tolerance {
            break;
        }
        let jt: Matrix<2, 10> = scene.robot.tcp_jacobian(&x);
        let j = jt.fixed_columns::<5>(0).into_owned();
        let Some(inv) = (j * j.transpose()).try_inverse() else {
            break;
        };
        q += j.transpose() * (inv * e);
    }
    let tcp = scene.tcp(&q);
    let error = (tcp[0] - z[0]).hypot(tcp[1] - z[1]);
    if error.is_nan() || error > settings.tcp_tolerance {
        return (q, Some(InfeasibleReason::TcpNotReached { error }));
    }
    let base_step = (q[0] - q_prev[0]).abs().max((q[1] - q_prev[1]).abs());
    if base_step > settings.max_base_step {
        return (q, Some(InfeasibleReason::OutOfReach { base_step }));
    }
    if let Some(which) = scene.limit_violation(&q) {
        return (q, Some(InfeasibleReason::Limit { which }));
    }
    let (distance, body, obstacle) = scene.clearance(&Scene::state_at_rest(&q));
    if distance < settings.min_clearance {
        return (
            q,
            Some(InfeasibleReason::Collision {
                body,
                obstacle,
                distance,
            }),
        );
    }
    (q, None)
}

/// Maps the waypoints `z_1 .. z_T` in turn, each from the previous configuration, starting from
/// `q0` (the configuration of `z_0`). Returns `q_0 .. q_T` when every waypoint maps, or the
/// failures; after a failure the next waypoint starts from the failed attempt's best
/// configuration, so that every infeasible waypoint is reported.
pub fn map_waypoints(
    scene: &Scene,
    settings: &InverseSettings,
    q0: &Config,
    waypoints: &[[f64; 2]],
) -> std::result::Result<Vec<Config>, Vec<InverseFailure>> {
    let mut qs = Vec::with_capacity(waypoints.len());
    qs.push(*q0);
    let mut failures = Vec::new();
    let mut prev = *q0;
    for (j, &z) in waypoints.iter().enumerate().skip(1) {
        let (q, reason) = solve(scene, settings, &prev, z);
        if let Some(reason) = reason {
            failures.push(InverseFailure {
                stage: j,
                waypoint: z,
                reason,
            });
        }
        prev = q;
        qs.push(q);
    }
    if failures.is_empty() {
        Ok(qs)
    } else {
        Err(failures)
    }
}
