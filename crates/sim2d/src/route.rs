//! The global route: a polyline through route points, progress along it, and the local goal of
//! DDPEN §II-E: "`x_goal` is located on the intersection of the local costmap border and the line
//! between next and previous global path points".
//!
//! [`Route::local_goal`] walks the polyline from the robot's progress and returns the first point
//! where it leaves the costmap square. On a straight segment that is exactly the paper's
//! intersection of the previous-to-next line with the border; when the next route point lies
//! inside the costmap the walk continues onto the following segment (the paper's rule would put
//! the goal on the extension of the segment, past the corner); inside the last costmap the goal
//! is the route's end.
//!
//! ```
//! use sim2d::Route;
//! let route = Route::new(vec![[0.0, 0.0], [20.0, 0.0], [20.0, 10.0]])?;
//! assert_eq!(route.length(), 30.0);
//! // Robot at (2, 0.3), costmap 10 m x 10 m centred on it: the goal is on its right border.
//! let goal = route.local_goal(2.0, [2.0, 0.3], 5.0);
//! assert!((goal[0] - 7.0).abs() < 1e-9 && goal[1].abs() < 1e-9);
//! # Ok::<(), sim2d::Error>(())
//! ```

use crate::error::{finite_each, Error, Result};

/// A polyline route (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    points: Vec<[f64; 2]>,
    /// Arc length at each point.
    cum: Vec<f64>,
}

impl Route {
    /// At least two finite points, consecutive points distinct. Errors name `route.points[i]`.
    pub fn new(points: Vec<[f64; 2]>) -> Result<Self> {
        if points.len() < 2 {
            return Err(Error::invalid(
                "route.points",
                format!("needs at least 2 points, got {}", points.len()),
            ));
        }
        let mut cum = Vec::with_capacity(points.len());
        cum.push(0.0);
        for (i, p) in points.iter().enumerate() {
            finite_each(&format!("route.points[{i}]"), *p)?;
            if i > 0 {
                let d = dist(points[i - 1], *p);
                if d < 1e-6 {
                    return Err(Error::invalid(
                        format!("route.points[{i}]"),
                        "repeats the previous point (segments must have positive length)",
                    ));
                }
                cum.push(cum[i - 1] + d);
            }
        }
        Ok(Self { points, cum })
    }

    /// The route driven the other way.
    pub fn reversed(&self) -> Self {
        let mut p = self.points.clone();
        p.reverse();
        Self::new(p).expect("a valid route reversed is valid")
    }

    /// The route points.
    pub fn points(&self) -> &[[f64; 2]] {
        &self.points
    }
    /// Total length (m).
    pub fn length(&self) -> f64 {
        *self.cum.last().expect("at least two points")
    }
    /// First point.
    pub fn start(&self) -> [f64; 2] {
        self.points[0]
    }
    /// Last point.
    pub fn end(&self) -> [f64; 2] {
        *self.points.last().expect("at least two points")
    }
    /// Heading (rad) of the first segment: the start heading of a run.
    pub fn start_heading(&self) -> f64 {
        let (a, b) = (self.points[0], self.points[1]);
        (b[1] - a[1]).atan2(b[0] - a[0])
    }
    /// Index of the segment containing arc length `s` (clamped).
    pub fn segment_at(&self, s: f64) -> usize {
        let n = self.points.len() - 1;
        self.cum[1..].iter().position(|&c| s < c).unwrap_or(n - 1).min(n - 1)
    }
    /// The point at arc length `s` (clamped to the route).
    pub fn point_at(&self, s: f64) -> [f64; 2] {
        let s = s.clamp(0.0, self.length());
        let i = self.segment_at(s);
        let (a, b) = (self.points[i], self.points[i + 1]);
        let t = (s - self.cum[i]) / (self.cum[i + 1] - self.cum[i]);
        lerp(a, b, t)
    }

    /// Progress: arc length of the projection of `p` on the route, searched over the segments
    /// that overlap `[s_hint - back, s_hint + ahead]` so that a route passing near itself does
    /// not make progress jump. Returns `(s, distance from p to the route)`.
    pub fn project(&self, p: [f64; 2], s_hint: f64, back: f64, ahead: f64) -> (f64, f64) {
        let (lo, hi) = (s_hint - back, s_hint + ahead);
        let mut best = (s_hint.clamp(0.0, self.length()), f64::INFINITY);
        for i in 0..self.points.len() - 1 {
            if self.cum[i + 1] < lo || self.cum[i] > hi {
                continue;
            }
            let (a, b) = (self.points[i], self.points[i + 1]);
            let ab = [b[0] - a[0], b[1] - a[1]];
            let len2 = ab[0] * ab[0] + ab[1] * ab[1];
            let t = (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0);
            let q = lerp(a, b, t);
            let d = dist(p, q);
            if d < best.1 {
                best = (self.cum[i] + t * (self.cum[i + 1] - self.cum[i]), d);
            }
        }
        best
    }

    /// The local goal for a robot at progress `s` with an axis-aligned costmap of half-size
    /// `half` (m) centred on `center` (see the module docs): the point where the route, walked
    /// forward from `s`, first leaves the square after being inside it. When the route at `s`
    /// lies outside the square (the robot is more than `half` off it, e.g. going round an
    /// obstacle), the walk starts where the route next enters the square; when it never does,
    /// the point at `s` is clamped into the square.
    pub fn local_goal(&self, s: f64, center: [f64; 2], half: f64) -> [f64; 2] {
        let s = s.clamp(0.0, self.length());
        let lo = [center[0] - half, center[1] - half];
        let hi = [center[0] + half, center[1] + half];
        let mut a = self.point_at(s);
        let mut entered = false;
        for i in self.segment_at(s)..self.points.len() - 1 {
            let b = self.points[i + 1];
            if let Some((t0, t1)) = clip(a, b, lo, hi) {
                if t1 < 1.0 {
                    return lerp(a, b, t1);
                }
                entered |= t0 <= 1.0;
            } else if entered {
                // Left exactly at a route point.
                return a;
            }
            a = b;
        }
        if entered {
            return self.end();
        }
        let p = self.point_at(s);
        [p[0].clamp(lo[0], hi[0]), p[1].clamp(lo[1], hi[1])]
    }
}

/// The parameter interval `[t0, t1]` of the segment `a -> b` inside the box `[lo, hi]`
/// (Liang-Barsky), `None` when the segment misses it.
fn clip(a: [f64; 2], b: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..2 {
        let d = b[k] - a[k];
        if d == 0.0 {
            if a[k] < lo[k] || a[k] > hi[k] {
                return None;
            }
            continue;
        }
        let (u, v) = ((lo[k] - a[k]) / d, (hi[k] - a[k]) / d);
        t0 = t0.max(u.min(v));
        t1 = t1.min(u.max(v));
    }
    (t0 <= t1).then_some((t0, t1))
}

fn lerp(a: [f64; 2], b: [f64; 2], t: f64) -> [f64; 2] {
    [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
}

pub(crate) fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn l_route() -> Route {
        Route::new(vec![[0.0, 0.0], [20.0, 0.0], [20.0, 10.0]]).unwrap()
    }

    #[test]
    fn goal_on_the_border_along_the_segment() {
        let r = l_route();
        // Robot off the line: the goal stays on the previous->next line, on the border.
        let g = r.local_goal(3.0, [3.0, 1.0], 5.0);
        assert!((g[0] - 8.0).abs() < 1e-12 && g[1] == 0.0);
        // Near the corner the walk turns onto the next segment and exits through the top.
        let g = r.local_goal(18.0, [18.0, 0.0], 5.0);
        assert!((g[0] - 20.0).abs() < 1e-12 && (g[1] - 5.0).abs() < 1e-12);
        // Inside the last costmap: the end.
        assert_eq!(r.local_goal(27.0, [20.0, 7.0], 5.0), [20.0, 10.0]);
        // Far off the route: the route point clamped into the square.
        let g = r.local_goal(5.0, [5.0, 9.0], 5.0);
        assert_eq!(g, [5.0, 4.0]);
        // 6 m off the first segment, with the second one inside the square: the walk starts
        // where the route enters the square and ends at the route's end inside it.
        let g = r.local_goal(4.0, [17.0, 6.0], 5.0);
        assert!((g[0] - 20.0).abs() < 1e-12 && (g[1] - 10.0).abs() < 1e-12, "{g:?}");
        // The route at s is outside, it enters on the first segment and leaves through the right.
        let g = r.local_goal(2.0, [10.0, 4.5], 5.0);
        assert!((g[0] - 15.0).abs() < 1e-12 && g[1] == 0.0, "{g:?}");
    }

    #[test]
    fn projection_and_progress() {
        let r = l_route();
        let (s, d) = r.project([10.0, 0.5], 9.0, 5.0, 5.0);
        assert!((s - 10.0).abs() < 1e-12 && (d - 0.5).abs() < 1e-12);
        let (s, _) = r.project([21.0, 4.0], 22.0, 5.0, 5.0);
        assert!((s - 24.0).abs() < 1e-12);
        assert_eq!(r.point_at(24.0), [20.0, 4.0]);
        assert_eq!(r.reversed().start(), [20.0, 10.0]);
        assert!((r.start_heading()).abs() < 1e-12);
    }

    #[test]
    fn bad_routes_name_the_point() {
        let e = Route::new(vec![[0.0, 0.0]]).unwrap_err();
        assert!(e.to_string().starts_with("route.points"), "{e}");
        let e = Route::new(vec![[0.0, 0.0], [1.0, f64::NAN]]).unwrap_err();
        assert!(e.to_string().starts_with("route.points[1][1]"), "{e}");
        let e = Route::new(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 0.0]]).unwrap_err();
        assert!(e.to_string().starts_with("route.points[2]"), "{e}");
    }
}
