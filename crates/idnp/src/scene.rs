//! The planning scene of Richter et al. (2023), Section V-B, in the plane: a floating base with a
//! 2-link arm ([`ArmBase`]), convex polygonal obstacles (four rectangles with a narrow passage in
//! [`Scene::narrow_passage`]), and a goal ball for the tool centre point (TCP).
//!
//! Collision geometry: the base is its rectangle, each link a capsule (segment between its end
//! points, radius [`Scene::link_radius`]). Signed distances between bodies and obstacles come from
//! parry (`parry2d-f64`: GJK/EPA contact queries, negative when penetrating), with gradients with
//! respect to the configuration `q = (x, y, theta, q1, q2)`:
//!
//! ```text
//! d sd / dq = -n^T dp/dq
//! ```
//!
//! where `n` is the contact normal (out of the robot body, towards the obstacle) and `p` the
//! witness point on the body, moving rigidly with the base (base) or the point
//! `(1 - t) a + t b` of the link segment `[a, b]` (capsules, `t` the witness parameter).
//!
//! ```
//! use idnp::scene::Scene;
//! let scene = Scene::narrow_passage();
//! // The passage is narrower than the initial grid spacing.
//! assert!(scene.passage_width() < scene.domain.spacing());
//! let inside_wall = [4.8, -1.0];
//! assert!(scene.point_clearance(inside_wall) < 0.0);
//! ```

use ddp_core::models::ArmBase;
use ddp_core::{Matrix, Vector};
use parry2d_f64::math::{Pose, Vector as PVec};
use parry2d_f64::query::{contact, PointQuery};
use parry2d_f64::shape::{Capsule, ConvexPolygon, Cuboid};
use serde::Serialize;

use crate::error::{finite, positive, Error, Result};

/// Configuration `q = (x, y, theta, q1, q2)` of the base pose and joint angles.
pub type Config = Vector<5>;

/// A convex polygonal obstacle (world frame).
#[derive(Debug, Clone)]
pub struct Obstacle {
    shape: ConvexPolygon,
    vertices: Vec<[f64; 2]>,
}

impl Obstacle {
    /// The convex hull of `vertices` (at least three, not collinear). Allocates the polygon.
    pub fn polygon(vertices: &[[f64; 2]]) -> Result<Self> {
        for (k, v) in vertices.iter().enumerate() {
            finite(&format!("vertices[{k}][0]"), v[0])?;
            finite(&format!("vertices[{k}][1]"), v[1])?;
        }
        if vertices.len() < 3 {
            return Err(Error::invalid(
                "vertices",
                format!("a polygon needs at least 3 vertices, got {}", vertices.len()),
            ));
        }
        if !spans_area(vertices) {
            return Err(Error::invalid(
                "vertices",
                "degenerate polygon (collinear or repeated vertices)",
            ));
        }
        let pts: Vec<PVec> = vertices.iter().map(|v| PVec::new(v[0], v[1])).collect();
        let shape = ConvexPolygon::from_convex_hull(&pts)
            .ok_or_else(|| Error::invalid("vertices", "degenerate polygon (collinear or repeated vertices)"))?;
        let vertices = shape.points().iter().map(|p| [p.x, p.y]).collect();
        Ok(Self { shape, vertices })
    }

    /// The axis-aligned rectangle `[min[0], max[0]] x [min[1], max[1]]`.
    pub fn rectangle(min: [f64; 2], max: [f64; 2]) -> Result<Self> {
        if !(max[0] > min[0] && max[1] > min[1]) {
            return Err(Error::invalid(
                "rectangle",
                format!("max {max:?} must exceed min {min:?} in both coordinates"),
            ));
        }
        Self::polygon(&[min, [max[0], min[1]], max, [min[0], max[1]]])
    }

    /// The vertices, counter-clockwise.
    pub fn vertices(&self) -> &[[f64; 2]] {
        &self.vertices
    }

    /// The parry shape (world frame, identity pose).
    pub fn shape(&self) -> &ConvexPolygon {
        &self.shape
    }

    /// Signed distance from the point `p` (negative inside).
    pub fn point_distance(&self, p: [f64; 2]) -> f64 {
        let pt = PVec::new(p[0], p[1]);
        let proj = self.shape.project_local_point(pt, false);
        let d = (pt - proj.point).length();
        if proj.is_inside {
            // `solid = false` projects an inside point onto the boundary.
            -d
        } else {
            d
        }
    }
}

/// Whether finite `points` span a triangle of positive area. parry's hull asserts (panics) when
/// every point is the same, so coincident and collinear sets are rejected before it is called.
fn spans_area(points: &[[f64; 2]]) -> bool {
    let Some(&a) = points.first() else {
        return false;
    };
    let d = |p: &[f64; 2]| [p[0] - a[0], p[1] - a[1]];
    // The point farthest from the first, then the largest area of a triangle with both.
    let Some(b) = points
        .iter()
        .map(d)
        .max_by(|u, v| u[0].hypot(u[1]).total_cmp(&v[0].hypot(v[1])))
    else {
        return false;
    };
    let len = b[0].hypot(b[1]);
    if !(len > 0.0 && len.is_finite()) {
        return false;
    }
    let height = points
        .iter()
        .map(|p| {
            let u = d(p);
            (b[0] * u[1] - b[1] * u[0]).abs() / len
        })
        .fold(0.0, f64::max);
    height > 1e-12 * len
}

/// The goal region of the TCP: a ball.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GoalBall {
    /// Centre (m).
    pub center: [f64; 2],
    /// Radius (m), > 0.
    pub radius: f64,
}

impl GoalBall {
    /// Distance from `p` to the ball: `max(0, |p - c| - r)`.
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        ((p[0] - self.center[0]).hypot(p[1] - self.center[1]) - self.radius).max(0.0)
    }
}

/// The rectangle of TCP positions that the DP grids cover, and its coarse (root) cells.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Domain {
    /// Lower corner (m).
    pub min: [f64; 2],
    /// Number of square root cells along x and y.
    pub cells: [usize; 2],
    /// Side of a root cell (m): the initial grid spacing.
    pub cell_size: f64,
}

impl Domain {
    /// Upper corner.
    pub fn max(&self) -> [f64; 2] {
        [
            self.min[0] + self.cells[0] as f64 * self.cell_size,
            self.min[1] + self.cells[1] as f64 * self.cell_size,
        ]
    }
    /// The initial grid spacing.
    pub fn spacing(&self) -> f64 {
        self.cell_size
    }
    /// Whether `p` lies in the closed rectangle.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        let max = self.max();
        p[0] >= self.min[0] && p[0] <= max[0] && p[1] >= self.min[1] && p[1] <= max[1]
    }
}

/// A robot body for collision checks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Body {
    /// The rectangular base.
    Base,
    /// Link 1 (shoulder to elbow), a capsule.
    Link1,
    /// Link 2 (elbow to TCP), a capsule.
    Link2,
}

impl Body {
    /// All bodies, in row order.
    pub const ALL: [Body; 3] = [Body::Base, Body::Link1, Body::Link2];
}

/// Signed distance between one body and one obstacle with its gradient in `q`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyDistance {
    /// Signed distance (m), negative when penetrating.
    pub distance: f64,
    /// `d distance / d q`.
    pub gradient: Config,
}

impl BodyDistance {
    /// No contact within `far`: `far` with a zero gradient for a finite state (a robot that
    /// diverged beyond it), NaN otherwise (so that a line search rejects the state).
    fn beyond(x: &Vector<10>, far: f64) -> Self {
        let finite = x.iter().all(|v| v.is_finite());
        Self {
            distance: if finite { far } else { f64::NAN },
            gradient: Config::zeros(),
        }
    }
}

/// The scene: robot, obstacles, goal, DP domain and configuration bounds.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The dynamics and kinematics of base and arm (its `dt` is the NLP step).
    pub robot: ArmBase,
    /// Radius of the link capsules (m).
    pub link_radius: f64,
    /// The obstacles.
    pub obstacles: Vec<Obstacle>,
    /// The TCP goal.
    pub goal: GoalBall,
    /// The TCP rectangle of the DP grids.
    pub domain: Domain,
    /// Limits of the joint angles `q1`, `q2` (rad).
    pub joint_limits: [[f64; 2]; 2],
    /// Limits of the base position `x`, `y` (m).
    pub base_limits: [[f64; 2]; 2],
    /// The narrow passage (for reports and figures): lower and upper corner of the free gap.
    pub passage: Option<[[f64; 2]; 2]>,
}

impl Scene {
    /// The benchmark scene (our planar take on Fig. 3 of Richter et al. (2023)). A wall of two
    /// rectangles at `x in [4.3, 5.3]` separates the start region from the goal ball (radius 0.4 m
    /// at `(8.4, 0)`). It leaves a passage 1.0 m wide at `y in [2.5, 3.5]`, between the lines of
    /// the initial 1.2 m grid, and a corridor below `y = -2.3`. A block in the start region and one
    /// on the way from the corridor to the goal complete the four rectangles. Straight lines from
    /// the start region to the goal meet the wall far from both openings. The DP domain is
    /// `[0, 9.6] x [-3.6, 3.6]` (8 x 6 cells of 1.2 m). The robot is [`ArmBase`] with time step
    /// 0.25 s and 5 cm link radius.
    pub fn narrow_passage() -> Self {
        let rect = |a: [f64; 2], b: [f64; 2]| Obstacle::rectangle(a, b).expect("valid rectangle");
        Self {
            robot: ArmBase::new(0.25).expect("valid time step"),
            link_radius: 0.05,
            obstacles: vec![
                rect([4.3, -2.3], [5.3, 2.5]),
                rect([4.3, 3.5], [5.3, 5.5]),
                rect([2.2, -0.6], [3.0, 0.6]),
                rect([6.6, -2.8], [7.6, -1.8]),
            ],
            goal: GoalBall {
                center: [8.4, 0.0],
                radius: 0.4,
            },
            domain: Domain {
                min: [0.0, -3.6],
                cells: [8, 6],
                cell_size: 1.2,
            },
            joint_limits: [[-2.5, 2.5], [-2.6, 2.6]],
            base_limits: [[-1.5, 11.1], [-5.1, 5.1]],
            passage: Some([[4.3, 2.5], [5.3, 3.5]]),
        }
    }

    /// Checks the scene, naming the field.
    pub fn validate(&self) -> Result<()> {
        positive("link_radius", self.link_radius)?;
        positive("goal.radius", self.goal.radius)?;
        finite("goal.center[0]", self.goal.center[0])?;
        finite("goal.center[1]", self.goal.center[1])?;
        positive("domain.cell_size", self.domain.cell_size)?;
        finite("domain.min[0]", self.domain.min[0])?;
        finite("domain.min[1]", self.domain.min[1])?;
        for i in 0..2 {
            if self.domain.cells[i] == 0 {
                return Err(Error::invalid(format!("domain.cells[{i}]"), "must be at least 1"));
            }
            for (name, lim) in [
                ("joint_limits", self.joint_limits[i]),
                ("base_limits", self.base_limits[i]),
            ] {
                if !(lim[0].is_finite() && lim[1].is_finite() && lim[0] < lim[1]) {
                    return Err(Error::invalid(
                        format!("{name}[{i}]"),
                        format!("must be finite with lower < upper, got {lim:?}"),
                    ));
                }
            }
        }
        crate::quadtree::root_cells(&self.domain)?;
        let max = self.domain.max();
        for i in 0..2 {
            if !max[i].is_finite() {
                return Err(Error::invalid(
                    format!("domain.cells[{i}]"),
                    format!(
                        "the domain's upper corner min + cells * cell_size overflows ({} + {} * {})",
                        self.domain.min[i], self.domain.cells[i], self.domain.cell_size
                    ),
                ));
            }
        }
        if self.obstacles.is_empty() {
            return Err(Error::invalid("obstacles", "the scene needs at least one obstacle"));
        }
        Ok(())
    }

    /// Width of the narrow passage (0 when the scene has none).
    pub fn passage_width(&self) -> f64 {
        self.passage.map_or(0.0, |p| p[1][1] - p[0][1])
    }

    /// Smallest signed distance from the point `p` to an obstacle.
    pub fn point_clearance(&self, p: [f64; 2]) -> f64 {
        self.obstacles
            .iter()
            .map(|o| o.point_distance(p))
            .fold(f64::INFINITY, f64::min)
    }

    /// The state of configuration `q` at rest.
    pub fn state_at_rest(q: &Config) -> Vector<10> {
        let mut x = Vector::<10>::zeros();
        x.fixed_rows_mut::<5>(0).copy_from(q);
        x
    }

    /// TCP of configuration `q`.
    pub fn tcp(&self, q: &Config) -> [f64; 2] {
        self.robot.tcp_position(&Self::state_at_rest(q))
    }

    /// Signed distance of `body` at state `x` to `obstacle`, with its gradient in `q`.
    ///
    /// Parry's GJK/EPA contact gives the distance (negative when penetrating), the witness points
    /// and the normal. GJK stops when the distance is certified to about `1e-8` relative, which
    /// leaves the witness direction accurate to only about `1e-4`; for separated shapes the
    /// witnesses are therefore polished by a few alternating exact point projections (parry's
    /// point queries) before the normal and the gradient are taken from them.
    pub fn body_distance(&self, x: &Vector<10>, body: Body, obstacle: &Obstacle) -> BodyDistance {
        let far = 1e6;
        let solid = true;
        match body {
            Body::Base => {
                let [w, h] = self.robot.params().base_size;
                let cuboid = Cuboid::new(PVec::new(0.5 * w, 0.5 * h));
                let pose = Pose::new(PVec::new(x[0], x[1]), x[2]);
                let Some(c) = contact(&pose, &cuboid, &Pose::IDENTITY, obstacle.shape(), far)
                    .ok()
                    .flatten()
                else {
                    return BodyDistance::beyond(x, far);
                };
                let (mut p1, mut p2, mut n, mut dist) = (c.point1, c.point2, c.normal1, c.dist);
                if dist > 1e-9 {
                    for _ in 0..8 {
                        p2 = obstacle.shape().project_local_point(p1, solid).point;
                        p1 = cuboid.project_point(&pose, p2, solid).point;
                    }
                    let e = p2 - p1;
                    dist = e.length();
                    if dist > 0.0 {
                        n = e / dist;
                    }
                }
                let r = p1 - PVec::new(x[0], x[1]);
                // The witness point moves rigidly with the base: dp = (dx, dy) + dtheta (-r_y, r_x).
                let gradient = Config::new(-n.x, -n.y, -(n.y * r.x - n.x * r.y), 0.0, 0.0);
                BodyDistance {
                    distance: dist,
                    gradient,
                }
            }
            Body::Link1 | Body::Link2 => {
                let i = if body == Body::Link1 { 0 } else { 1 };
                let pts = self.robot.link_endpoints(x);
                let (a, b) = (PVec::new(pts[i][0], pts[i][1]), PVec::new(pts[i + 1][0], pts[i + 1][1]));
                let radius = self.link_radius;
                let capsule = Capsule::new(a, b, radius);
                let Some(c) = contact(&Pose::IDENTITY, &capsule, &Pose::IDENTITY, obstacle.shape(), far)
                    .ok()
                    .flatten()
                else {
                    return BodyDistance::beyond(x, far);
                };
                let ab = b - a;
                let len2 = ab.length_squared();
                let param = |p: PVec| {
                    if len2 > 0.0 {
                        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
                    } else {
                        0.0
                    }
                };
                // Core point on the segment and the normal out of the capsule.
                let mut n = c.normal1;
                let mut t = param(c.point1 - n * radius);
                let mut dist = c.dist;
                if dist > 1e-9 {
                    let mut core = a + ab * t;
                    let mut p2 = c.point2;
                    for _ in 0..8 {
                        p2 = obstacle.shape().project_local_point(core, solid).point;
                        t = param(p2);
                        core = a + ab * t;
                    }
                    let e = p2 - core;
                    let d = e.length();
                    if d > 0.0 {
                        n = e / d;
                        dist = d - radius;
                    }
                }
                let jac = self.robot.link_endpoint_jacobians(x);
                let jp: Matrix<2, 10> = jac[i] * (1.0 - t) + jac[i + 1] * t;
                let mut gradient = Config::zeros();
                for k in 0..5 {
                    gradient[k] = -(n.x * jp[(0, k)] + n.y * jp[(1, k)]);
                }
                BodyDistance {
                    distance: dist,
                    gradient,
                }
            }
        }
    }

    /// Smallest signed distance of the robot at state `x` to any obstacle, with the body and the
    /// obstacle index.
    pub fn clearance(&self, x: &Vector<10>) -> (f64, Body, usize) {
        let mut best = (f64::INFINITY, Body::Base, 0);
        for (j, o) in self.obstacles.iter().enumerate() {
            for body in Body::ALL {
                let d = self.body_distance(x, body, o).distance;
                if d < best.0 {
                    best = (d, body, j);
                }
            }
        }
        best
    }

    /// Whether `q` is within the joint and base limits; the first violated limit otherwise.
    pub fn limit_violation(&self, q: &Config) -> Option<&'static str> {
        let inside = |v: f64, l: [f64; 2]| v >= l[0] - 1e-9 && v <= l[1] + 1e-9;
        if !inside(q[0], self.base_limits[0]) {
            return Some("base x");
        }
        if !inside(q[1], self.base_limits[1]) {
            return Some("base y");
        }
        if !inside(q[3], self.joint_limits[0]) {
            return Some("joint q1");
        }
        if !inside(q[4], self.joint_limits[1]) {
            return Some("joint q2");
        }
        None
    }

    /// Collision check of a trajectory: the states, and `substeps - 1` configurations linearly
    /// interpolated between consecutive states. Returns the indices `k` of the states (or the
    /// segments `[x_k, x_{k+1}]`) where some body penetrates an obstacle by more than
    /// `tolerance`, and the smallest clearance found.
    pub fn check_trajectory(&self, xs: &[Vector<10>], substeps: usize, tolerance: f64) -> (Vec<usize>, f64) {
        let substeps = substeps.max(1);
        let mut hits = Vec::new();
        let mut worst = f64::INFINITY;
        for k in 0..xs.len() {
            let mut hit = false;
            let steps = if k + 1 < xs.len() { substeps } else { 1 };
            for s in 0..steps {
                let a = s as f64 / substeps as f64;
                let x = if s == 0 {
                    xs[k]
                } else {
                    xs[k] * (1.0 - a) + xs[k + 1] * a
                };
                let (d, _, _) = self.clearance(&x);
                worst = worst.min(d);
                if d < -tolerance {
                    hit = true;
                }
            }
            if hit {
                hits.push(k);
            }
        }
        (hits, worst)
    }
}

impl Default for Scene {
    /// [`Scene::narrow_passage`].
    fn default() -> Self {
        Self::narrow_passage()
    }
}
