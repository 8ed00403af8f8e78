//! Seeded random trap maps for the trap benchmark (`--bin trap-bench`): each map is an ordinary
//! [`Scenario`] (a straight two-point route and static obstacles), so it runs in the same world,
//! lidar and planners as the Table I scenarios.
//!
//! Every map is built in a *route frame* (`u` along the route from the start, `v` to its left)
//! and then turned by a random heading about the start, so the world-aligned costmap sees traps
//! at every angle. The route is `route_length` long (default 22 m); the trap's mouth faces the
//! start and its back lies across the straight line at `u` in `[9, 13]` m, laterally offset by a
//! fraction of its width and turned by up to ±25°:
//!
//! | kind | generator |
//! |---|---|
//! | [`TrapKind::U`] | three walls (boxes) of thickness 0.5-1 m: a pocket 2-4 m wide and 2-4.5 m deep |
//! | [`TrapKind::L`] | a wall 0.5-1 m thick across the line, reaching 2.5-4 m past it on the open side, and one arm 2-4.5 m long on the other side, 0.8-2 m from the line |
//! | [`TrapKind::Cubes`] | 1.6-2 m cubes on a lattice: a back row of 2-3 cubes across the line and arms of 1-2 cubes on each side (or one side left open), each cube jittered by up to 0.1 m and 8°, plus 0-3 loose cubes |
//! | [`TrapKind::Cylinders`] | a cup of cylinders (r 0.3-0.5 m) on an arc of radius 1.6-2.6 m spanning 180-240°, gaps below 0.4 m, plus 4-10 loose cylinders (r 0.2-0.6 m) |
//!
//! A map is kept only if (a) the straight line from start to goal hits an obstacle, (b) start and
//! goal are at least 2.5 m from every obstacle, and (c) a path with 0.6 m clearance (the robot's
//! circumscribed radius plus 0.1 m) exists on a 0.1 m grid; otherwise the generator draws again
//! from the same random stream, so a map depends on `(seed, kind, index)` only.
//!
//! ```
//! use sim2d::traps::{trap_map, TrapKind, TrapParams};
//! let a = trap_map(TrapKind::U, 7, 3, &TrapParams::default())?;
//! let b = trap_map(TrapKind::U, 7, 3, &TrapParams::default())?;
//! assert_eq!(a, b);
//! assert_eq!(a.name, "u_0003");
//! # Ok::<(), sim2d::Error>(())
//! ```

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{positive, Error, Result};
use crate::route::Route;
use crate::scenario::{Obstacle, Scenario};

/// The kinds of trap maps (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TrapKind {
    /// A U of three walls.
    U,
    /// An L: a wall across the line and one arm.
    L,
    /// A cluster of cubes with a concave pocket.
    Cubes,
    /// A cup of cylinders in cylinder clutter.
    Cylinders,
}

impl TrapKind {
    /// All kinds.
    pub const ALL: [TrapKind; 4] = [TrapKind::U, TrapKind::L, TrapKind::Cubes, TrapKind::Cylinders];

    /// The command-line name (`u`, `l`, `cubes`, `cylinders`).
    pub fn name(&self) -> &'static str {
        match self {
            TrapKind::U => "u",
            TrapKind::L => "l",
            TrapKind::Cubes => "cubes",
            TrapKind::Cylinders => "cylinders",
        }
    }

    /// Parses a command-line name; the error names the field `types` and lists the kinds.
    pub fn parse(name: &str) -> Result<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name).ok_or_else(|| {
            Error::invalid(
                "types",
                format!(
                    "unknown trap type {name:?}; known: {}",
                    Self::ALL.map(|k| k.name()).join(", ")
                ),
            )
        })
    }

    fn salt(&self) -> u64 {
        match self {
            TrapKind::U => 1,
            TrapKind::L => 2,
            TrapKind::Cubes => 3,
            TrapKind::Cylinders => 4,
        }
    }
}

impl std::fmt::Display for TrapKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Generator settings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrapParams {
    /// Route length (m), start to goal.
    pub route_length: f64,
    /// Clearance a path must keep for the map to count as solvable (m).
    pub path_clearance: f64,
    /// Least distance from start and goal to any obstacle (m).
    pub endpoint_clearance: f64,
}

impl Default for TrapParams {
    fn default() -> Self {
        Self {
            route_length: 22.0,
            path_clearance: 0.6,
            endpoint_clearance: 2.5,
        }
    }
}

impl TrapParams {
    /// Rejects impossible values, naming the field (`traps.<name>`).
    pub fn validate(&self) -> Result<()> {
        if !(self.route_length.is_finite() && self.route_length >= 16.0) {
            return Err(Error::invalid(
                "traps.route_length",
                format!(
                    "must be at least 16 m (the trap sits 9-13 m from the start), got {}",
                    self.route_length
                ),
            ));
        }
        positive("traps.path_clearance", self.path_clearance)?;
        positive("traps.endpoint_clearance", self.endpoint_clearance)?;
        Ok(())
    }
}

/// Obstacles in the route frame before the final turn.
struct Builder {
    /// Trap pose in the route frame: position of its back centre and its yaw.
    origin: [f64; 2],
    yaw: f64,
    obstacles: Vec<Obstacle>,
}

impl Builder {
    fn to_route(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.yaw.sin_cos();
        [
            self.origin[0] + c * p[0] - s * p[1],
            self.origin[1] + s * p[0] + c * p[1],
        ]
    }
    /// A box at `center` (trap frame) with `size`, turned by `yaw` relative to the trap.
    fn rect(&mut self, center: [f64; 2], size: [f64; 2], yaw: f64) {
        self.obstacles.push(Obstacle::Box {
            center: self.to_route(center),
            size,
            yaw: self.yaw + yaw,
        });
    }
    /// A cylinder at `center` in the *route* frame.
    fn cylinder_route(&mut self, center: [f64; 2], radius: f64) {
        self.obstacles.push(Obstacle::Cylinder { center, radius });
    }
}

/// Map `index` of `kind` for `seed` (see the module docs). Deterministic: the same arguments give
/// the same scenario. The scenario is named `<kind>_<index:04>`.
pub fn trap_map(kind: TrapKind, seed: u64, index: usize, params: &TrapParams) -> Result<Scenario> {
    params.validate()?;
    let stream = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(kind.salt().wrapping_mul(0xD1B5_4A32_D192_ED03))
        .wrapping_add(index as u64);
    let mut rng = ChaCha8Rng::seed_from_u64(stream);
    for _attempt in 0..200 {
        let heading = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        let obstacles = draw(kind, &mut rng, params);
        let scenario = place(kind, index, heading, obstacles, params)?;
        if accept(&scenario, params) {
            return Ok(scenario);
        }
    }
    Err(Error::invalid(
        "traps",
        format!("no valid {kind} map in 200 draws for seed {seed}, index {index}"),
    ))
}

/// The trap's obstacles in the route frame (start at the origin, goal at `(L, 0)`).
fn draw(kind: TrapKind, rng: &mut ChaCha8Rng, params: &TrapParams) -> Vec<Obstacle> {
    let u0 = rng.random_range(9.0..13.0);
    let yaw = rng.random_range(-25f64..25.0).to_radians();
    let mut b = Builder {
        origin: [u0, 0.0],
        yaw,
        obstacles: Vec::new(),
    };
    match kind {
        TrapKind::U => {
            let (w, d, t) = (
                rng.random_range(2.0..4.0),
                rng.random_range(2.0..4.5),
                rng.random_range(0.5..1.0),
            );
            b.origin[1] = rng.random_range(-0.3..0.3) * w;
            // Back wall across the line, side walls towards the start (-u).
            b.rect([0.5 * t, 0.0], [t, w + 2.0 * t], 0.0);
            for side in [-1.0, 1.0] {
                b.rect([-0.5 * d, side * 0.5 * (w + t)], [d, t], 0.0);
            }
        }
        TrapKind::L => {
            let t = rng.random_range(0.5..1.0);
            let (arm_offset, reach, d) = (
                rng.random_range(0.8..2.0),
                rng.random_range(2.5..4.0),
                rng.random_range(2.0..4.5),
            );
            let side = if rng.random_bool(0.5) { 1.0 } else { -1.0 };
            // The wall spans v from -side * reach (open side) to side * (arm_offset + t).
            let (v_a, v_b) = (-side * reach, side * (arm_offset + t));
            b.rect([0.5 * t, 0.5 * (v_a + v_b)], [t, (v_b - v_a).abs()], 0.0);
            b.rect([-0.5 * d, side * (arm_offset + 0.5 * t)], [d, t], 0.0);
        }
        TrapKind::Cubes => {
            let s = rng.random_range(1.6..2.0);
            let back = rng.random_range(2..=3usize);
            let arms = [rng.random_range(0..=2usize), rng.random_range(1..=2usize)];
            let arms = if rng.random_bool(0.5) { [arms[1], arms[0]] } else { arms };
            let half = 0.5 * (back as f64 - 1.0) * s;
            b.origin[1] = rng.random_range(-0.25..0.25) * s;
            let cube = |b: &mut Builder, rng: &mut ChaCha8Rng, c: [f64; 2]| {
                let j = [rng.random_range(-0.1..0.1), rng.random_range(-0.1..0.1)];
                let yaw = rng.random_range(-8f64..8.0).to_radians();
                b.rect([c[0] + j[0], c[1] + j[1]], [s, s], yaw);
            };
            for k in 0..back {
                cube(&mut b, rng, [0.5 * s, -half + k as f64 * s]);
            }
            for (i, side) in [-1.0, 1.0].into_iter().enumerate() {
                for k in 0..arms[i] {
                    cube(&mut b, rng, [0.5 * s - (k + 1) as f64 * s, side * (half + s)]);
                }
            }
            // Loose cubes anywhere along the route, away from the endpoints.
            for _ in 0..rng.random_range(0..=3usize) {
                let c = [
                    rng.random_range(3.5..params.route_length - 3.5),
                    rng.random_range(-6.0..6.0),
                ];
                let yaw = rng.random_range(0f64..90.0).to_radians();
                b.obstacles.push(Obstacle::Box {
                    center: c,
                    size: [s, s],
                    yaw,
                });
            }
        }
        TrapKind::Cylinders => {
            let big_r = rng.random_range(1.6..2.6);
            let span = rng.random_range(180f64..240.0).to_radians();
            b.origin[1] = rng.random_range(-0.3..0.3) * big_r;
            // The cup's centre is big_r in front of its back (towards the start).
            let centre = [-big_r, 0.0];
            let mut a = -0.5 * span;
            let mut r_prev: Option<f64> = None;
            loop {
                let r = rng.random_range(0.3..0.5);
                if let Some(rp) = r_prev {
                    // Next centre so that the gap to the previous cylinder is 0-0.4 m.
                    let gap = rng.random_range(0.0..0.4);
                    let chord = rp + r + gap;
                    a += 2.0 * (0.5 * chord / big_r).min(1.0).asin();
                }
                if a > 0.5 * span + 1e-9 {
                    break;
                }
                let c = b.to_route([centre[0] + big_r * a.cos(), centre[1] + big_r * a.sin()]);
                b.cylinder_route(c, r);
                r_prev = Some(r);
            }
            for _ in 0..rng.random_range(4..=10usize) {
                let c = [
                    rng.random_range(3.5..params.route_length - 3.5),
                    rng.random_range(-6.0..6.0),
                ];
                b.cylinder_route(c, rng.random_range(0.2..0.6));
            }
        }
    }
    b.obstacles
}

/// Turns the route-frame obstacles by `heading` about the start and wraps them in a scenario.
fn place(kind: TrapKind, index: usize, heading: f64, obstacles: Vec<Obstacle>, p: &TrapParams) -> Result<Scenario> {
    let (s, c) = heading.sin_cos();
    let rot = |q: [f64; 2]| [c * q[0] - s * q[1], s * q[0] + c * q[1]];
    let obstacles = obstacles
        .into_iter()
        .map(|o| match o {
            Obstacle::Cylinder { center, radius } => Obstacle::Cylinder {
                center: rot(center),
                radius,
            },
            Obstacle::Box { center, size, yaw } => Obstacle::Box {
                center: rot(center),
                size,
                yaw: yaw + heading,
            },
            Obstacle::Polygon { points } => Obstacle::Polygon {
                points: points.into_iter().map(rot).collect(),
            },
        })
        .collect();
    Ok(Scenario {
        name: format!("{}_{index:04}", kind.name()),
        description: format!("random {kind} trap map {index}"),
        route: Route::new(vec![[0.0, 0.0], rot([p.route_length, 0.0])])?,
        obstacles,
    })
}

/// The acceptance tests (a)-(c) of the module docs.
fn accept(s: &Scenario, p: &TrapParams) -> bool {
    let (a, b) = (s.route.start(), s.route.end());
    if s.clearance(a) < p.endpoint_clearance || s.clearance(b) < p.endpoint_clearance {
        return false;
    }
    let n = (p.route_length / 0.05) as usize;
    let blocked = (0..=n).any(|k| {
        let t = k as f64 / n as f64;
        s.clearance([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]) <= 0.0
    });
    blocked && solvable(s, p.path_clearance)
}

/// Whether a 4-connected path keeping `clearance` from every obstacle joins start and goal on a
/// 0.1 m grid over the map's bounds plus 4 m.
pub fn solvable(s: &Scenario, clearance: f64) -> bool {
    let res = 0.1;
    let bb = s.bounds();
    let (x0, y0) = (bb[0] - 4.0, bb[1] - 4.0);
    let w = ((bb[2] + 4.0 - x0) / res).ceil() as usize + 1;
    let h = ((bb[3] + 4.0 - y0) / res).ceil() as usize + 1;
    let cell = |p: [f64; 2]| {
        (
            ((p[0] - x0) / res).round() as usize,
            ((p[1] - y0) / res).round() as usize,
        )
    };
    let free: Vec<bool> = (0..w * h)
        .map(|i| s.clearance([x0 + (i % w) as f64 * res, y0 + (i / w) as f64 * res]) >= clearance)
        .collect();
    let (sx, sy) = cell(s.route.start());
    let (gx, gy) = cell(s.route.end());
    let mut seen = vec![false; w * h];
    let mut queue = std::collections::VecDeque::from([(sx, sy)]);
    seen[sy * w + sx] = true;
    while let Some((x, y)) = queue.pop_front() {
        if (x, y) == (gx, gy) {
            return true;
        }
        let neighbours = [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)];
        for (nx, ny) in neighbours {
            if nx < w && ny < h && !seen[ny * w + nx] && free[ny * w + nx] {
                seen[ny * w + nx] = true;
                queue.push_back((nx, ny));
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_parse_and_unknown_names_the_field() {
        for k in TrapKind::ALL {
            assert_eq!(TrapKind::parse(k.name()).unwrap(), k);
        }
        let e = TrapKind::parse("o").unwrap_err().to_string();
        assert!(e.contains("types") && e.contains("cylinders"), "{e}");
        let e = trap_map(
            TrapKind::U,
            0,
            0,
            &TrapParams {
                route_length: 5.0,
                ..TrapParams::default()
            },
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("traps.route_length"), "{e}");
    }
}
