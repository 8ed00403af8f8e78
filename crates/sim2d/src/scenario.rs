//! Scenario files: a route and static obstacles, in TOML.
//!
//! ```toml
//! name = "my-street"                      # required
//! description = "two cylinders"           # optional
//!
//! [route]
//! points = [[0.0, 0.0], [40.0, 0.0], [40.0, 30.0]]   # metres, at least 2
//!
//! [[obstacles]]
//! type = "cylinder"
//! center = [12.0, 0.5]
//! radius = 1.0
//!
//! [[obstacles]]
//! type = "box"
//! center = [25.0, -0.6]
//! size = [2.0, 2.0]        # along x and y before the rotation
//! yaw_deg = 0.0            # optional, counter-clockwise
//!
//! [[obstacles]]
//! type = "polygon"         # simple polygon, any winding, convex or not
//! points = [[38.0, 10.0], [42.0, 10.0], [40.0, 13.0]]
//! ```
//!
//! Unknown or missing fields and wrong types are errors that name the field and show the line;
//! values out of range are errors naming e.g. `obstacles[3].radius`.
//!
//! ```
//! let s = sim2d::Scenario::from_toml_str("name = 'x'\n[route]\npoints = [[0, 0], [10, 0]]\n", "inline")?;
//! assert_eq!(s.route.length(), 10.0);
//! let e = sim2d::Scenario::from_toml_str(
//!     "name = 'x'\n[route]\npoints = [[0, 0], [10, 0]]\n[[obstacles]]\ntype = 'cylinder'\ncenter = [1, 1]\nradius = -1\n",
//!     "inline",
//! ).unwrap_err();
//! assert!(e.to_string().contains("obstacles[0].radius"));
//! # Ok::<(), sim2d::Error>(())
//! ```

use std::path::Path;

use serde::Deserialize;

use crate::error::{finite_each, positive, Error, Result};
use crate::route::Route;

/// A static obstacle (world frame, metres).
#[derive(Debug, Clone, PartialEq)]
pub enum Obstacle {
    /// A vertical cylinder (a disc in 2D).
    Cylinder {
        /// Centre.
        center: [f64; 2],
        /// Radius.
        radius: f64,
    },
    /// A rectangle ("cube" of the paper) rotated by `yaw` (rad) about its centre.
    Box {
        /// Centre.
        center: [f64; 2],
        /// Side lengths before the rotation.
        size: [f64; 2],
        /// Counter-clockwise rotation (rad).
        yaw: f64,
    },
    /// A simple polygon (convex or not).
    Polygon {
        /// Vertices in order.
        points: Vec<[f64; 2]>,
    },
}

impl Obstacle {
    /// An outline for drawing: the polygon, the box corners, or 32 points on the circle.
    pub fn outline(&self) -> Vec<[f64; 2]> {
        match self {
            Obstacle::Cylinder { center, radius } => (0..32)
                .map(|k| {
                    let a = k as f64 * std::f64::consts::TAU / 32.0;
                    [center[0] + radius * a.cos(), center[1] + radius * a.sin()]
                })
                .collect(),
            Obstacle::Box { center, size, yaw } => {
                let (s, c) = yaw.sin_cos();
                let (hx, hy) = (0.5 * size[0], 0.5 * size[1]);
                [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]]
                    .iter()
                    .map(|p| [center[0] + c * p[0] - s * p[1], center[1] + s * p[0] + c * p[1]])
                    .collect()
            }
            Obstacle::Polygon { points } => points.clone(),
        }
    }

    /// Distance from `p` to the obstacle (0 inside).
    pub fn distance(&self, p: [f64; 2]) -> f64 {
        match self {
            Obstacle::Cylinder { center, radius } => ((p[0] - center[0]).hypot(p[1] - center[1]) - radius).max(0.0),
            _ => polygon_distance(&self.outline(), p),
        }
    }

    /// Axis-aligned bounds `[min_x, min_y, max_x, max_y]`.
    pub fn bounds(&self) -> [f64; 4] {
        match self {
            Obstacle::Cylinder { center, radius } => [
                center[0] - radius,
                center[1] - radius,
                center[0] + radius,
                center[1] + radius,
            ],
            _ => bounds_of(&self.outline()),
        }
    }
}

/// Bounds `[min_x, min_y, max_x, max_y]` of points.
pub(crate) fn bounds_of(points: &[[f64; 2]]) -> [f64; 4] {
    points.iter().fold(
        [f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY],
        |b, p| [b[0].min(p[0]), b[1].min(p[1]), b[2].max(p[0]), b[3].max(p[1])],
    )
}

fn polygon_distance(poly: &[[f64; 2]], p: [f64; 2]) -> f64 {
    let n = poly.len();
    let mut inside = false;
    let mut best = f64::INFINITY;
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + 1) % n]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0]);
            if p[0] < x {
                inside = !inside;
            }
        }
        let ab = [b[0] - a[0], b[1] - a[1]];
        let len2 = ab[0] * ab[0] + ab[1] * ab[1];
        let t = if len2 > 0.0 {
            (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        best = best.min((p[0] - a[0] - t * ab[0]).hypot(p[1] - a[1] - t * ab[1]));
    }
    if inside {
        0.0
    } else {
        best
    }
}

/// A world to drive: a route and static obstacles (see the module docs for the file format).
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// Short name, used in tables and file names.
    pub name: String,
    /// Free text.
    pub description: String,
    /// The global route, driven forward (as written) or backward.
    pub route: Route,
    /// Static obstacles.
    pub obstacles: Vec<Obstacle>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ScenarioFile {
    name: String,
    #[serde(default)]
    description: String,
    route: RouteFile,
    #[serde(default)]
    obstacles: Vec<ObstacleFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RouteFile {
    points: Vec<[f64; 2]>,
}

#[derive(Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
enum ObstacleFile {
    Cylinder {
        center: [f64; 2],
        radius: f64,
    },
    Box {
        center: [f64; 2],
        size: [f64; 2],
        #[serde(default)]
        yaw_deg: f64,
    },
    Polygon {
        points: Vec<[f64; 2]>,
    },
}

impl Scenario {
    /// Parses and validates a scenario; `source_name` (a path or `"<string>"`) prefixes errors.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self> {
        let file: ScenarioFile = toml::from_str(text).map_err(|e| Error::Parse {
            source_name: source_name.to_string(),
            message: e.to_string().trim_end().to_string(),
        })?;
        if file.name.trim().is_empty() {
            return Err(Error::invalid("name", "must not be empty"));
        }
        let route = Route::new(file.route.points)?;
        let mut obstacles = Vec::with_capacity(file.obstacles.len());
        for (i, o) in file.obstacles.into_iter().enumerate() {
            let f = |name: &str| format!("obstacles[{i}].{name}");
            obstacles.push(match o {
                ObstacleFile::Cylinder { center, radius } => {
                    finite_each(&f("center"), center)?;
                    positive(&f("radius"), radius)?;
                    Obstacle::Cylinder { center, radius }
                }
                ObstacleFile::Box { center, size, yaw_deg } => {
                    finite_each(&f("center"), center)?;
                    positive(&f("size[0]"), size[0])?;
                    positive(&f("size[1]"), size[1])?;
                    if !yaw_deg.is_finite() {
                        return Err(Error::invalid(f("yaw_deg"), format!("must be finite, got {yaw_deg}")));
                    }
                    Obstacle::Box {
                        center,
                        size,
                        yaw: yaw_deg.to_radians(),
                    }
                }
                ObstacleFile::Polygon { points } => {
                    if points.len() < 3 {
                        return Err(Error::invalid(
                            f("points"),
                            format!("a polygon needs at least 3 points, got {}", points.len()),
                        ));
                    }
                    for (k, p) in points.iter().enumerate() {
                        finite_each(&format!("obstacles[{i}].points[{k}]"), *p)?;
                    }
                    if signed_area(&points).abs() < 1e-9 {
                        return Err(Error::invalid(f("points"), "the polygon has zero area"));
                    }
                    Obstacle::Polygon { points }
                }
            });
        }
        Ok(Self {
            name: file.name,
            description: file.description,
            route,
            obstacles,
        })
    }

    /// Reads and validates a scenario file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| Error::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Distance from `p` to the nearest obstacle (`INFINITY` without obstacles).
    pub fn clearance(&self, p: [f64; 2]) -> f64 {
        self.obstacles
            .iter()
            .map(|o| o.distance(p))
            .fold(f64::INFINITY, f64::min)
    }

    /// Bounds of the route and the obstacles, `[min_x, min_y, max_x, max_y]`.
    pub fn bounds(&self) -> [f64; 4] {
        let mut b = bounds_of(self.route.points());
        for o in &self.obstacles {
            let ob = o.bounds();
            b = [b[0].min(ob[0]), b[1].min(ob[1]), b[2].max(ob[2]), b[3].max(ob[3])];
        }
        b
    }
}

/// Twice the signed area (positive counter-clockwise).
pub(crate) fn signed_area(points: &[[f64; 2]]) -> f64 {
    let n = points.len();
    (0..n)
        .map(|i| {
            let (a, b) = (points[i], points[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    const OK: &str = r#"
name = "t"
[route]
points = [[0, 0], [10, 0]]
[[obstacles]]
type = "cylinder"
center = [5, 1]
radius = 1.0
[[obstacles]]
type = "box"
center = [8, -2]
size = [2, 2]
yaw_deg = 45
[[obstacles]]
type = "polygon"
points = [[0, 5], [2, 5], [2, 7], [1, 6], [0, 7]]
"#;

    #[test]
    fn parses_every_obstacle_type() {
        let s = Scenario::from_toml_str(OK, "ok").unwrap();
        assert_eq!(s.obstacles.len(), 3);
        assert!((s.clearance([5.0, 0.0]) - 0.0).abs() < 1e-12);
        assert!((s.clearance([5.0, -1.0]) - 1.0).abs() < 1e-12);
        // The rotated box is a diamond: its corner points along -y.
        let Obstacle::Box { .. } = &s.obstacles[1] else {
            panic!()
        };
        assert!((s.obstacles[1].distance([8.0, -2.0 - 2f64.sqrt() - 0.5]) - 0.5).abs() < 1e-9);
        // Inside the notch of the concave polygon is outside the polygon.
        assert!(s.obstacles[2].distance([1.0, 6.5]) > 0.0);
        assert_eq!(s.obstacles[2].distance([0.5, 5.5]), 0.0);
    }

    fn err(text: &str) -> String {
        Scenario::from_toml_str(text, "bad.toml").unwrap_err().to_string()
    }

    #[test]
    fn bad_files_name_the_field() {
        let head = "name = 't'\n[route]\npoints = [[0, 0], [10, 0]]\n";
        let e = err(&format!("{head}[[obstacles]]\ntype = 'cylinder'\ncenter = [1, 1]\n"));
        assert!(e.contains("radius"), "{e}");
        let e = err(&format!(
            "{head}[[obstacles]]\ntype = 'cylinder'\ncenter = [1, 1]\nradus = 1\n"
        ));
        assert!(e.contains("radus"), "{e}");
        let e = err(&format!("{head}[[obstacles]]\ntype = 'cone'\ncenter = [1, 1]\n"));
        assert!(e.contains("cone"), "{e}");
        let e = err(&format!(
            "{head}[[obstacles]]\ntype = 'box'\ncenter = [1, 1]\nsize = [2, 0]\n"
        ));
        assert!(e.contains("obstacles[0].size[1]"), "{e}");
        let e = err(&format!(
            "{head}[[obstacles]]\ntype = 'polygon'\npoints = [[0, 0], [1, 1]]\n"
        ));
        assert!(e.contains("obstacles[0].points"), "{e}");
        let e = err("name = 't'\n[route]\npoints = [[0, 0]]\n");
        assert!(e.contains("route.points"), "{e}");
        let e = err("name = 't'\n[route]\npoints = [[0, 0], [1, 'a']]\n");
        assert!(e.contains("bad.toml") && e.contains("points"), "{e}");
        let e = err("[route]\npoints = [[0, 0], [1, 1]]\n");
        assert!(e.contains("name"), "{e}");
        let e = err("name = 't'\nspeed = 3\n[route]\npoints = [[0, 0], [1, 1]]\n");
        assert!(e.contains("speed"), "{e}");
    }
}
