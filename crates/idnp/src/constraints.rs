//! Collision constraints of the robot for `safe-cddp`: one row `g = margin - sd(x) <= 0` per
//! body and obstacle, where `sd` is parry's signed distance between the body (the base rectangle,
//! or a link capsule) and a convex polygon, and `g_x = -d sd / dx` from the contact normal and
//! the Jacobians of the link end points ([`Scene::body_distance`]).
//!
//! The rows are state-only constraints of relative degree 1: with the semi-implicit Euler step of
//! [`ddp_core::models::ArmBase`], the control `u_k` moves the configuration of `x_{k+1}`. A row can
//! also look back half a step ([`BodyObstacle::with_lookback`]) to check the middle of the motion
//! between two knots.
//!
//! ```
//! use std::sync::Arc;
//! use idnp::constraints::BodyObstacle;
//! use idnp::scene::{Body, Scene};
//! use safe_cddp::{check_constraint_derivatives, Constraint};
//! use ddp_core::Vector;
//! let scene = Arc::new(Scene::narrow_passage());
//! let c = BodyObstacle::new(scene.clone(), Body::Link2, 0, 0.02).unwrap();
//! let q = idnp::scene::Config::new(3.2, -0.6, 0.2, 0.4, -0.8);
//! let x = Scene::state_at_rest(&q);
//! let err = check_constraint_derivatives(&c, 1, &x, &Vector::<5>::zeros());
//! assert!(err.max_first_order() < 1e-5);
//! ```

use ddp_core::dims::{U10, U5};
use std::sync::Arc;

use ddp_core::{Matrix, Vector};
use safe_cddp::Constraint;

use crate::error::{finite, Error, Result};
use crate::scene::{Body, Scene};

/// `margin - sd(body(x), obstacle) <= 0` (capsule-vs-convex-polygon for the links). See the
/// [module docs](self).
#[derive(Debug, Clone)]
pub struct BodyObstacle {
    scene: Arc<Scene>,
    body: Body,
    obstacle: usize,
    margin: f64,
    lookback: f64,
}

impl BodyObstacle {
    /// The row for `body` and obstacle `obstacle` of `scene`, with clearance `margin` (m, may be
    /// negative to tolerate a little penetration).
    pub fn new(scene: Arc<Scene>, body: Body, obstacle: usize, margin: f64) -> Result<Self> {
        finite("margin", margin)?;
        if obstacle >= scene.obstacles.len() {
            return Err(Error::invalid(
                "obstacle",
                format!("index {obstacle} out of range ({} obstacles)", scene.obstacles.len()),
            ));
        }
        Ok(Self {
            scene,
            body,
            obstacle,
            margin,
            lookback: 0.0,
        })
    }

    /// The same row evaluated at the configuration `q - lookback * v` instead of `q`. With
    /// `lookback = dt / 2` and the semi-implicit step `q_{k+1} = q_k + dt v_{k+1}`, that is the
    /// midpoint of the segment `[q_k, q_{k+1}]`: a row on `x_{k+1}` that keeps the motion between
    /// knots clear too. Errors unless `lookback` is finite and >= 0.
    pub fn with_lookback(mut self, lookback: f64) -> Result<Self> {
        self.lookback = crate::error::nonnegative("lookback", lookback)?;
        Ok(self)
    }

    /// One row per body and obstacle of `scene` at the knots, and with `midpoints` one more at
    /// the midpoint of each step ([`BodyObstacle::with_lookback`] of `dt / 2`), as trait objects
    /// for [`safe_cddp::SafeCddpSolver`].
    pub fn all(scene: &Arc<Scene>, margin: f64, midpoints: bool) -> Result<Vec<Arc<dyn Constraint<U10, U5>>>> {
        let mut out: Vec<Arc<dyn Constraint<U10, U5>>> = Vec::with_capacity(6 * scene.obstacles.len());
        let lookbacks: &[f64] = if midpoints { &[0.0, 0.5] } else { &[0.0] };
        for &l in lookbacks {
            for o in 0..scene.obstacles.len() {
                for body in Body::ALL {
                    let row = Self::new(scene.clone(), body, o, margin)?.with_lookback(l * scene.robot.dt())?;
                    out.push(Arc::new(row));
                }
            }
        }
        Ok(out)
    }

    /// The state whose configuration the row checks: `(q - lookback v, v)`.
    fn probe(&self, x: &Vector<10>) -> Vector<10> {
        let mut y = *x;
        if self.lookback > 0.0 {
            for k in 0..5 {
                y[k] -= self.lookback * x[5 + k];
            }
        }
        y
    }

    /// The body.
    pub fn body(&self) -> Body {
        self.body
    }
    /// The obstacle index.
    pub fn obstacle(&self) -> usize {
        self.obstacle
    }
}

impl Constraint<U10, U5> for BodyObstacle {
    fn dim(&self) -> usize {
        1
    }
    fn depends_on_control(&self) -> bool {
        false
    }
    fn evaluate(&self, _t: usize, x: &Vector<10>, _u: &Vector<5>, g: &mut [f64]) {
        let d = self
            .scene
            .body_distance(&self.probe(x), self.body, &self.scene.obstacles[self.obstacle]);
        g[0] = self.margin - d.distance;
    }
    fn jacobians(
        &self,
        _t: usize,
        x: &Vector<10>,
        _u: &Vector<5>,
        g: &mut [f64],
        g_x: &mut [Vector<10>],
        g_u: &mut [Vector<5>],
    ) {
        let d = self
            .scene
            .body_distance(&self.probe(x), self.body, &self.scene.obstacles[self.obstacle]);
        g[0] = self.margin - d.distance;
        g_x[0] = Vector::zeros();
        for k in 0..5 {
            g_x[0][k] = -d.gradient[k];
            g_x[0][5 + k] = self.lookback * d.gradient[k];
        }
        g_u[0] = Vector::zeros();
    }
    fn add_hessian(&self, _t: usize, _x: &Vector<10>, _u: &Vector<5>, _w: &[f64], _h_xx: &mut Matrix<10, 10>) {}
    fn relative_degree(&self) -> Option<usize> {
        Some(1)
    }
}
