//! The physical world: static obstacles and the sidewalk robot as a dynamic rigid body in
//! rapier2d (top view, no gravity), driven through a velocity-tracking controller with
//! acceleration limits and seeded actuation noise, a 2D lidar by ray casts, and collision
//! counting.
//!
//! Actuation, per physics step of `dt`:
//!
//! ```text
//! a_k+1 = a_k + clamp(clamp(u_cmd, limits) - a_k, +-accel_max dt)     rate-limited actuators (v, w)
//! n_k+1 = n_k - n_k dt / tau + sigma sqrt(2 dt / tau) xi              Ornstein-Uhlenbeck noise, xi ~ N(0, 1)
//! v_wheel = a_v (1 + n_v),  w_wheel = a_w + n_w                        what the wheels try to do
//! impulse = m clamp(v_wheel - v_body, +-traction dt)                  forward; the lateral velocity is
//!                                                                      driven to 0 (wheels do not slip sideways)
//! ```
//!
//! then one rapier step, so contacts with obstacles stop or deflect the robot. A collision is
//! counted when the robot's collider comes within [`CONTACT_DISTANCE`] of an obstacle after not
//! being in contact.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rapier2d::prelude::*;

use crate::error::{nonnegative, positive, Error, Result};
use crate::scenario::{signed_area, Obstacle, Scenario};

/// Distance (m) below which the robot counts as touching an obstacle.
pub const CONTACT_DISTANCE: f64 = 0.005;

/// The sidewalk robot and its drive (defaults: the DDPEN robot, paper §III).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotParams {
    /// Footprint length along the heading (m).
    pub length: f64,
    /// Footprint width (m).
    pub width: f64,
    /// Mass (kg).
    pub mass: f64,
    /// Speed limit `|v| <= v_max` (m/s).
    pub v_max: f64,
    /// Turn-rate limit `|w| <= w_max` (rad/s).
    pub w_max: f64,
    /// Actuator acceleration limit (m/s^2).
    pub accel_max: f64,
    /// Actuator angular acceleration limit (rad/s^2).
    pub alpha_max: f64,
    /// Largest acceleration the wheels can exert on the body (m/s^2); also bounds the lateral grip.
    pub traction: f64,
    /// Largest angular acceleration the wheels can exert (rad/s^2).
    pub angular_traction: f64,
    /// Standard deviation of the relative speed error (e.g. 0.05 = 5 %).
    pub noise_v: f64,
    /// Standard deviation of the turn-rate error (rad/s).
    pub noise_w: f64,
    /// Correlation time of the actuation noise (s).
    pub noise_tau: f64,
}

impl Default for RobotParams {
    fn default() -> Self {
        Self {
            length: 0.8,
            width: 0.6,
            mass: 40.0,
            v_max: 1.5,
            w_max: 0.5,
            accel_max: 1.0,
            alpha_max: 1.5,
            traction: 4.0,
            angular_traction: 8.0,
            noise_v: 0.05,
            noise_w: 0.03,
            noise_tau: 0.5,
        }
    }
}

impl RobotParams {
    /// Rejects non-physical values, naming the field (`robot.<name>`).
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("length", self.length),
            ("width", self.width),
            ("mass", self.mass),
            ("v_max", self.v_max),
            ("w_max", self.w_max),
            ("accel_max", self.accel_max),
            ("alpha_max", self.alpha_max),
            ("traction", self.traction),
            ("angular_traction", self.angular_traction),
            ("noise_tau", self.noise_tau),
        ] {
            positive(&format!("robot.{name}"), v)?;
        }
        nonnegative("robot.noise_v", self.noise_v)?;
        nonnegative("robot.noise_w", self.noise_w)?;
        Ok(())
    }

    /// Radius of the circle that contains the footprint (m).
    pub fn circumscribed_radius(&self) -> f64 {
        0.5 * self.length.hypot(self.width)
    }
    /// Radius of the largest circle inside the footprint (m).
    pub fn inscribed_radius(&self) -> f64 {
        0.5 * self.length.min(self.width)
    }
}

/// The 2D lidar (defaults: 360 beams, 8 m, 10 Hz, 1 cm range noise).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LidarParams {
    /// Number of beams over 360 degrees.
    pub beams: usize,
    /// Maximum range (m).
    pub range: f64,
    /// Scan rate (Hz); the costmap is updated at this rate.
    pub rate_hz: f64,
    /// Standard deviation of the range noise (m).
    pub noise: f64,
}

impl Default for LidarParams {
    fn default() -> Self {
        Self {
            beams: 360,
            range: 8.0,
            rate_hz: 10.0,
            noise: 0.01,
        }
    }
}

impl LidarParams {
    /// Rejects non-physical values, naming the field (`lidar.<name>`).
    pub fn validate(&self) -> Result<()> {
        if self.beams == 0 {
            return Err(Error::invalid("lidar.beams", "must be at least 1"));
        }
        positive("lidar.range", self.range)?;
        positive("lidar.rate_hz", self.rate_hz)?;
        nonnegative("lidar.noise", self.noise)?;
        Ok(())
    }
}

/// A lidar scan: one range per beam (`range` when nothing was hit) and the world points hit.
#[derive(Debug, Clone, Default)]
pub struct Scan {
    /// Sensor pose `[x, y, theta]` at the scan.
    pub pose: [f64; 3],
    /// Range per beam, counter-clockwise from the heading (m); `max_range` for no return.
    pub ranges: Vec<f32>,
    /// Maximum range (m).
    pub max_range: f64,
    /// World points of the returns.
    pub hits: Vec<[f64; 2]>,
}

/// The rapier world with the robot (see the module docs).
pub struct World {
    physics: PhysicsWorld,
    robot: RigidBodyHandle,
    robot_collider: ColliderHandle,
    params: RobotParams,
    dt: f64,
    actuator: [f64; 2],
    noise: [f64; 2],
    rng: ChaCha8Rng,
    lidar_rng: ChaCha8Rng,
    time: f64,
    collisions: usize,
    contact_time: f64,
    in_contact: bool,
}

fn v2(p: [f64; 2]) -> Vector {
    Vector::new(p[0] as f32, p[1] as f32)
}

impl World {
    /// Builds the world of `scenario` with the robot at `start = [x, y, theta]`, a physics step
    /// of `dt` seconds and the noise seeded by `seed`.
    pub fn new(scenario: &Scenario, params: RobotParams, start: [f64; 3], dt: f64, seed: u64) -> Result<Self> {
        params.validate()?;
        positive("physics_dt", dt)?;
        for (i, v) in start.iter().enumerate() {
            if !v.is_finite() {
                return Err(Error::invalid(
                    format!("start[{i}]"),
                    format!("must be finite, got {v}"),
                ));
            }
        }
        let mut physics = PhysicsWorld::new();
        physics.gravity = Vector::ZERO;
        physics.integration_parameters.dt = dt as f32;
        for o in &scenario.obstacles {
            for c in obstacle_colliders(o) {
                physics.colliders.insert(c.friction(0.6).restitution(0.0));
            }
        }
        let density = params.mass / (params.length * params.width);
        let (robot, robot_collider) = physics.insert(
            RigidBodyBuilder::dynamic()
                .translation(Vector::new(start[0] as f32, start[1] as f32))
                .rotation(start[2] as f32)
                .can_sleep(false),
            ColliderBuilder::cuboid(0.5 * params.length as f32, 0.5 * params.width as f32)
                .density(density as f32)
                .friction(0.6)
                .restitution(0.0),
        );
        physics.detect_collisions(&(), &());
        Ok(Self {
            physics,
            robot,
            robot_collider,
            params,
            dt,
            actuator: [0.0; 2],
            noise: [0.0; 2],
            rng: ChaCha8Rng::seed_from_u64(seed),
            lidar_rng: ChaCha8Rng::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15),
            time: 0.0,
            collisions: 0,
            contact_time: 0.0,
            in_contact: false,
        })
    }

    /// The robot parameters.
    pub fn robot_params(&self) -> &RobotParams {
        &self.params
    }
    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Physics step (s).
    pub fn dt(&self) -> f64 {
        self.dt
    }
    /// Robot pose `[x, y, theta]`.
    pub fn pose(&self) -> [f64; 3] {
        let b = &self.physics.bodies[self.robot];
        let t = b.translation();
        [t.x as f64, t.y as f64, b.rotation().angle() as f64]
    }
    /// Robot velocity in its frame: `[forward, lateral, yaw rate]`.
    pub fn body_velocity(&self) -> [f64; 3] {
        let b = &self.physics.bodies[self.robot];
        let (s, c) = (b.rotation().angle() as f64).sin_cos();
        let v = b.linvel();
        let (vx, vy) = (v.x as f64, v.y as f64);
        [c * vx + s * vy, -s * vx + c * vy, b.angvel() as f64]
    }
    /// Number of collisions so far (contact onsets).
    pub fn collisions(&self) -> usize {
        self.collisions
    }
    /// Total time in contact with an obstacle (s).
    pub fn contact_time(&self) -> f64 {
        self.contact_time
    }
    /// Whether the robot touches an obstacle now.
    pub fn in_contact(&self) -> bool {
        self.in_contact
    }

    /// Drives the robot with the command `[v, w]` for `duration` seconds (whole physics steps).
    pub fn step(&mut self, cmd: [f64; 2], duration: f64) {
        let steps = (duration / self.dt).round().max(1.0) as usize;
        for _ in 0..steps {
            self.substep(cmd);
        }
    }

    fn substep(&mut self, cmd: [f64; 2]) {
        let p = self.params;
        let dt = self.dt;
        let target = [
            if cmd[0].is_finite() {
                cmd[0].clamp(-p.v_max, p.v_max)
            } else {
                0.0
            },
            if cmd[1].is_finite() {
                cmd[1].clamp(-p.w_max, p.w_max)
            } else {
                0.0
            },
        ];
        self.actuator[0] += (target[0] - self.actuator[0]).clamp(-p.accel_max * dt, p.accel_max * dt);
        self.actuator[1] += (target[1] - self.actuator[1]).clamp(-p.alpha_max * dt, p.alpha_max * dt);
        let k = (2.0 * dt / p.noise_tau).sqrt();
        for (i, sigma) in [p.noise_v, p.noise_w].into_iter().enumerate() {
            let xi: f64 = StandardNormal.sample(&mut self.rng);
            self.noise[i] += -self.noise[i] * dt / p.noise_tau + sigma * k * xi;
        }
        let v_wheel = self.actuator[0] * (1.0 + self.noise[0]);
        let w_wheel = self.actuator[1] + self.noise[1];

        let [fwd, lat, w] = self.body_velocity();
        let theta = self.pose()[2];
        let (s, c) = theta.sin_cos();
        let dv_f = (v_wheel - fwd).clamp(-p.traction * dt, p.traction * dt);
        let dv_l = (-lat).clamp(-p.traction * dt, p.traction * dt);
        let dw = (w_wheel - w).clamp(-p.angular_traction * dt, p.angular_traction * dt);
        let inertia = p.mass * (p.length * p.length + p.width * p.width) / 12.0;
        let body = &mut self.physics.bodies[self.robot];
        let mass = body.mass() as f64;
        body.apply_impulse(
            Vector::new(
                (mass * (dv_f * c - dv_l * s)) as f32,
                (mass * (dv_f * s + dv_l * c)) as f32,
            ),
            true,
        );
        body.apply_torque_impulse((inertia * dw) as f32, true);
        self.physics.step();
        self.time += dt;

        let touching = self
            .physics
            .narrow_phase
            .contact_pairs_with(self.robot_collider)
            .any(|pair| {
                pair.manifolds()
                    .iter()
                    .any(|m| m.points.iter().any(|pt| (pt.dist as f64) < CONTACT_DISTANCE))
            });
        if touching {
            if !self.in_contact {
                self.collisions += 1;
            }
            self.contact_time += dt;
        }
        self.in_contact = touching;
    }

    /// A lidar scan from the robot's centre into `scan` (buffers reused).
    pub fn scan(&mut self, lidar: &LidarParams, scan: &mut Scan) {
        let pose = self.pose();
        scan.pose = pose;
        scan.max_range = lidar.range;
        scan.ranges.clear();
        scan.hits.clear();
        let filter = QueryFilter::default().exclude_rigid_body(self.robot);
        let qp = self.physics.query_pipeline_with_filter(filter);
        let origin = Vector::new(pose[0] as f32, pose[1] as f32);
        for k in 0..lidar.beams {
            let a = pose[2] + k as f64 * std::f64::consts::TAU / lidar.beams as f64;
            let (s, c) = a.sin_cos();
            let ray = Ray::new(origin, Vector::new(c as f32, s as f32));
            match qp.cast_ray(&ray, lidar.range as f32, true) {
                Some((_, toi)) => {
                    let xi: f64 = StandardNormal.sample(&mut self.lidar_rng);
                    let r = (toi as f64 + lidar.noise * xi).clamp(0.0, lidar.range);
                    scan.ranges.push(r as f32);
                    scan.hits.push([pose[0] + r * c, pose[1] + r * s]);
                }
                None => scan.ranges.push(lidar.range as f32),
            }
        }
    }
}

/// Colliders for one obstacle: a ball, a cuboid, a convex polygon, or the triangles of a concave
/// polygon (ear clipping: exact, unlike an approximate convex decomposition).
fn obstacle_colliders(o: &Obstacle) -> Vec<ColliderBuilder> {
    match o {
        Obstacle::Cylinder { center, radius } => vec![ColliderBuilder::ball(*radius as f32).translation(v2(*center))],
        Obstacle::Box { center, size, yaw } => {
            vec![ColliderBuilder::cuboid(0.5 * size[0] as f32, 0.5 * size[1] as f32)
                .translation(v2(*center))
                .rotation(*yaw as f32)]
        }
        Obstacle::Polygon { points } => {
            let pts: Vec<Vector> = points.iter().map(|p| v2(*p)).collect();
            if is_convex(points) {
                if let Some(c) = ColliderBuilder::convex_hull(&pts) {
                    return vec![c];
                }
            }
            triangulate(points)
                .into_iter()
                .map(|[a, b, c]| ColliderBuilder::triangle(pts[a], pts[b], pts[c]))
                .collect()
        }
    }
}

fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

fn is_convex(points: &[[f64; 2]]) -> bool {
    let n = points.len();
    let sign = signed_area(points).signum();
    (0..n).all(|i| cross(points[i], points[(i + 1) % n], points[(i + 2) % n]) * sign >= -1e-12)
}

/// Ear-clipping triangulation of a simple polygon (any winding); indices into `points`.
pub(crate) fn triangulate(points: &[[f64; 2]]) -> Vec<[usize; 3]> {
    let mut idx: Vec<usize> = (0..points.len()).collect();
    if signed_area(points) < 0.0 {
        idx.reverse();
    }
    let mut tris = Vec::with_capacity(points.len().saturating_sub(2));
    let mut guard = 0;
    while idx.len() > 3 && guard < 10 * points.len() * points.len() {
        guard += 1;
        let n = idx.len();
        let mut clipped = false;
        for i in 0..n {
            let (a, b, c) = (idx[(i + n - 1) % n], idx[i], idx[(i + 1) % n]);
            let (pa, pb, pc) = (points[a], points[b], points[c]);
            if cross(pa, pb, pc) <= 1e-12 {
                continue; // reflex or degenerate corner
            }
            let contains_other = idx.iter().any(|&k| {
                k != a
                    && k != b
                    && k != c
                    && cross(pa, pb, points[k]) >= 0.0
                    && cross(pb, pc, points[k]) >= 0.0
                    && cross(pc, pa, points[k]) >= 0.0
            });
            if !contains_other {
                tris.push([a, b, c]);
                idx.remove(i);
                clipped = true;
                break;
            }
        }
        if !clipped {
            break; // not simple: give up on the remainder
        }
    }
    if idx.len() == 3 {
        tris.push([idx[0], idx[1], idx[2]]);
    }
    tris
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::route::Route;

    fn scenario(obstacles: Vec<Obstacle>) -> Scenario {
        Scenario {
            name: "t".into(),
            description: String::new(),
            route: Route::new(vec![[0.0, 0.0], [10.0, 0.0]]).unwrap(),
            obstacles,
        }
    }

    #[test]
    fn tracks_commands_within_limits() {
        let p = RobotParams {
            noise_v: 0.0,
            noise_w: 0.0,
            ..RobotParams::default()
        };
        let mut w = World::new(&scenario(vec![]), p, [0.0, 0.0, 0.0], 0.02, 1).unwrap();
        // Asking for more than the limit gets the limit, reached at accel_max.
        w.step([3.0, 0.0], 1.0);
        let v = w.body_velocity();
        assert!((v[0] - 1.0).abs() < 0.03, "{v:?}");
        w.step([3.0, 0.0], 1.0);
        assert!((w.body_velocity()[0] - 1.5).abs() < 0.02);
        w.step([1.5, 2.0], 2.0);
        let v = w.body_velocity();
        assert!((v[2] - 0.5).abs() < 0.02 && v[1].abs() < 0.02, "{v:?}");
        assert_eq!(w.collisions(), 0);
    }

    #[test]
    fn noise_makes_execution_differ_and_is_seeded() {
        let run = |seed| {
            let mut w = World::new(&scenario(vec![]), RobotParams::default(), [0.0, 0.0, 0.0], 0.02, seed).unwrap();
            for _ in 0..50 {
                w.step([1.0, 0.2], 0.1);
            }
            w.pose()
        };
        assert_eq!(run(3), run(3));
        let (a, b) = (run(3), run(4));
        assert!((a[0] - b[0]).abs() + (a[1] - b[1]).abs() > 1e-3);
    }

    #[test]
    fn driving_into_a_wall_is_one_collision_and_stops() {
        let wall = Obstacle::Box {
            center: [3.0, 0.0],
            size: [1.0, 4.0],
            yaw: 0.0,
        };
        let mut w = World::new(&scenario(vec![wall]), RobotParams::default(), [0.0, 0.0, 0.0], 0.02, 1).unwrap();
        for _ in 0..60 {
            w.step([1.5, 0.0], 0.1);
        }
        // Front face of the wall at x = 2.5, robot half-length 0.4.
        assert!(w.pose()[0] < 2.15, "{:?}", w.pose());
        assert_eq!(w.collisions(), 1);
        assert!(w.contact_time() > 1.0);
    }

    #[test]
    fn lidar_sees_a_cylinder() {
        let cyl = Obstacle::Cylinder {
            center: [4.0, 0.0],
            radius: 1.0,
        };
        let mut w = World::new(&scenario(vec![cyl]), RobotParams::default(), [0.0, 0.0, 0.0], 0.02, 1).unwrap();
        let mut scan = Scan::default();
        w.scan(&LidarParams::default(), &mut scan);
        assert_eq!(scan.ranges.len(), 360);
        assert!((scan.ranges[0] - 3.0).abs() < 0.05, "{}", scan.ranges[0]);
        assert_eq!(scan.ranges[180], 8.0);
        assert!(!scan.hits.is_empty());
        for h in &scan.hits {
            assert!(((h[0] - 4.0).hypot(h[1]) - 1.0).abs() < 0.05);
        }
    }

    #[test]
    fn concave_polygons_are_triangulated_exactly() {
        let u = vec![
            [0.0, 0.0],
            [3.0, 0.0],
            [3.0, 3.0],
            [2.0, 3.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 3.0],
            [0.0, 3.0],
        ];
        let tris = triangulate(&u);
        assert_eq!(tris.len(), 6);
        let area: f64 = tris.iter().map(|t| 0.5 * cross(u[t[0]], u[t[1]], u[t[2]]).abs()).sum();
        assert!((area - 7.0).abs() < 1e-12);
        let mut rev = u.clone();
        rev.reverse();
        assert_eq!(triangulate(&rev).len(), 6);
        assert!(!is_convex(&u));
        assert!(is_convex(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]));
    }
}
