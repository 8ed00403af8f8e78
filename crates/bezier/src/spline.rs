//! Composite cubic curves through waypoints: C1 (Hermite / Catmull-Rom) and C2 (natural or
//! clamped) splines, with parametric jerk and curvature measures.
//!
//! ```
//! use bezier::{Continuity, Point, Spline, DEFAULT_ACCURACY};
//! let w = [Point::new(0.0, 0.0), Point::new(1.0, 1.0), Point::new(2.0, 0.0), Point::new(3.0, 1.0)];
//! let cr = Spline::catmull_rom(&w).unwrap();
//! let c2 = Spline::c2_natural(&w).unwrap();
//! assert_eq!(cr.continuity(1e-9), Continuity::C1);
//! assert_eq!(c2.continuity(1e-9), Continuity::C2);
//! // The natural C2 spline minimises the parametric jerk among C2 interpolants; here it also beats Catmull-Rom.
//! assert!(c2.jerk_cost_param() < cr.jerk_cost_param());
//! assert!(c2.arclen(DEFAULT_ACCURACY) > 3.0);
//! ```
//!
//! Segment `i` runs from waypoint `i` to `i + 1` over the global parameter `u in [i, i + 1]`,
//! with unit "time" per segment for the parametric measures; C1 and C2 refer to derivatives in
//! that parameter. The Hermite form `B_i = (w_i, w_i + d_i / 3, w_{i+1} - d_{i+1} / 3, w_{i+1})`
//! with one tangent `d_i` per waypoint keeps C1 by construction; C2 adds the tridiagonal
//! conditions `d_{i-1} + 4 d_i + d_{i+1} = 3 (w_{i+1} - w_{i-1})`.

use crate::cubic::CubicBez;
use crate::error::{check_points, Error, Result};
use crate::point::{Point, Rect, Vec2};
use crate::traits::{ParamCurve, ParamCurveArclen, ParamCurveCurvature, ParamCurveDeriv, ParamCurveExtrema};

/// Continuity class of a composite curve at its joints.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Continuity {
    /// Positions meet.
    C0,
    /// First derivatives meet.
    C1,
    /// Second derivatives meet.
    C2,
}

/// A chain of cubic segments, each starting where the previous ends.
#[derive(Clone, Debug, PartialEq)]
pub struct Spline {
    segments: Vec<CubicBez>,
}

/// Solves the tridiagonal system `sub_i x_{i-1} + diag_i x_i + sup_i x_{i+1} = rhs_i` (Thomas).
fn thomas(sub: &[f64], diag: &[f64], sup: &[f64], rhs: &[Vec2]) -> Vec<Vec2> {
    let n = diag.len();
    let mut c = vec![0.0; n];
    let mut d = vec![Vec2::ZERO; n];
    let mut beta = diag[0];
    c[0] = sup[0] / beta;
    d[0] = rhs[0] / beta;
    for i in 1..n {
        beta = diag[i] - sub[i] * c[i - 1];
        c[i] = sup[i] / beta;
        d[i] = (rhs[i] - sub[i] * d[i - 1]) / beta;
    }
    for i in (0..n - 1).rev() {
        let next = d[i + 1];
        d[i] -= c[i] * next;
    }
    d
}

impl Spline {
    /// A spline from segments that join (each `p0` within `1e-9` times the curve's size of the
    /// previous `p3`). Errors: `TooFew` for no segment, `NonFinite`, `Discontinuous` naming the index.
    pub fn from_segments(segments: Vec<CubicBez>) -> Result<Spline> {
        if segments.is_empty() {
            return Err(Error::TooFew {
                field: "segments",
                got: 0,
                need: 1,
            });
        }
        for (i, s) in segments.iter().enumerate() {
            if !s.is_finite() {
                return Err(Error::NonFinite {
                    field: "segments",
                    index: i,
                });
            }
        }
        let size = segments.iter().fold(Rect::from_point(segments[0].p0), |r, s| {
            r.union(s.to_bezier().control_box())
        });
        let tol = 1e-9 * (size.width() + size.height()).max(1.0);
        for i in 1..segments.len() {
            let gap = segments[i - 1].p3.distance(segments[i].p0);
            if gap > tol {
                return Err(Error::Discontinuous {
                    field: "segments",
                    index: i,
                    gap,
                });
            }
        }
        Ok(Spline { segments })
    }

    fn check_waypoints(waypoints: &[Point]) -> Result<()> {
        if waypoints.len() < 2 {
            return Err(Error::TooFew {
                field: "waypoints",
                got: waypoints.len(),
                need: 2,
            });
        }
        check_points("waypoints", waypoints)
    }

    /// The C1 spline with tangent `tangents[i]` (derivative in the global parameter) at
    /// `waypoints[i]`. Errors name `waypoints` or `tangents` (length mismatch, non-finite).
    pub fn hermite(waypoints: &[Point], tangents: &[Vec2]) -> Result<Spline> {
        Spline::check_waypoints(waypoints)?;
        if tangents.len() != waypoints.len() {
            return Err(Error::InvalidParameter {
                field: "tangents",
                value: tangents.len() as f64,
                reason: "needs one tangent per waypoint",
            });
        }
        for (i, d) in tangents.iter().enumerate() {
            if !d.is_finite() {
                return Err(Error::NonFinite {
                    field: "tangents",
                    index: i,
                });
            }
        }
        Ok(Spline::hermite_unchecked(waypoints, tangents))
    }

    pub(crate) fn hermite_unchecked(waypoints: &[Point], tangents: &[Vec2]) -> Spline {
        let segments = waypoints
            .windows(2)
            .zip(tangents.windows(2))
            .map(|(w, d)| CubicBez::hermite(w[0], d[0], w[1], d[1]))
            .collect();
        Spline { segments }
    }

    /// Catmull-Rom tangents (uniform): `d_i = (w_{i+1} - w_{i-1}) / 2`, one-sided
    /// `w_1 - w_0` and `w_n - w_{n-1}` at the ends.
    pub fn catmull_rom_tangents(waypoints: &[Point]) -> Result<Vec<Vec2>> {
        Spline::check_waypoints(waypoints)?;
        let n = waypoints.len();
        Ok((0..n)
            .map(|i| {
                if i == 0 {
                    waypoints[1] - waypoints[0]
                } else if i == n - 1 {
                    waypoints[n - 1] - waypoints[n - 2]
                } else {
                    0.5 * (waypoints[i + 1] - waypoints[i - 1])
                }
            })
            .collect())
    }

    /// The uniform Catmull-Rom spline through `waypoints` (C1): the usual starting point for
    /// optimisation. Errors: `TooFew` (fewer than 2 waypoints), `NonFinite`.
    pub fn catmull_rom(waypoints: &[Point]) -> Result<Spline> {
        let d = Spline::catmull_rom_tangents(waypoints)?;
        Ok(Spline::hermite_unchecked(waypoints, &d))
    }

    /// The natural C2 cubic spline (zero second derivative at both ends).
    pub fn c2_natural(waypoints: &[Point]) -> Result<Spline> {
        Spline::check_waypoints(waypoints)?;
        Ok(Spline::hermite_unchecked(
            waypoints,
            &Spline::c2_tangents(waypoints, None),
        ))
    }

    /// The clamped C2 cubic spline with given end derivatives (in the global parameter).
    pub fn c2_clamped(waypoints: &[Point], start_tangent: Vec2, end_tangent: Vec2) -> Result<Spline> {
        Spline::check_waypoints(waypoints)?;
        if !start_tangent.is_finite() {
            return Err(Error::NonFinite {
                field: "start_tangent",
                index: 0,
            });
        }
        if !end_tangent.is_finite() {
            return Err(Error::NonFinite {
                field: "end_tangent",
                index: 0,
            });
        }
        Ok(Spline::hermite_unchecked(
            waypoints,
            &Spline::c2_tangents(waypoints, Some((start_tangent, end_tangent))),
        ))
    }

    /// Tangents of the C2 interpolant: natural ends for `None`, clamped for `Some((d0, dn))`.
    pub(crate) fn c2_tangents(w: &[Point], ends: Option<(Vec2, Vec2)>) -> Vec<Vec2> {
        let n = w.len();
        let mut sub = vec![1.0; n];
        let mut diag = vec![4.0; n];
        let mut sup = vec![1.0; n];
        let mut rhs: Vec<Vec2> = (0..n)
            .map(|i| {
                if i == 0 || i == n - 1 {
                    Vec2::ZERO
                } else {
                    3.0 * (w[i + 1] - w[i - 1])
                }
            })
            .collect();
        match ends {
            None => {
                diag[0] = 2.0;
                diag[n - 1] = 2.0;
                rhs[0] = 3.0 * (w[1] - w[0]);
                rhs[n - 1] = 3.0 * (w[n - 1] - w[n - 2]);
            }
            Some((d0, dn)) => {
                diag[0] = 1.0;
                sup[0] = 0.0;
                rhs[0] = d0;
                diag[n - 1] = 1.0;
                sub[n - 1] = 0.0;
                rhs[n - 1] = dn;
            }
        }
        sub[0] = 0.0;
        sup[n - 1] = 0.0;
        thomas(&sub, &diag, &sup, &rhs)
    }

    /// The segments.
    pub fn segments(&self) -> &[CubicBez] {
        &self.segments
    }

    /// Number of segments.
    pub fn len(&self) -> usize {
        self.segments.len()
    }

    /// Always `false` (a spline has at least one segment); for API symmetry with `len`.
    pub fn is_empty(&self) -> bool {
        self.segments.is_empty()
    }

    /// The joints: each segment's start, then the last end.
    pub fn waypoints(&self) -> Vec<Point> {
        let mut w: Vec<Point> = self.segments.iter().map(|s| s.p0).collect();
        w.push(self.segments[self.segments.len() - 1].p3);
        w
    }

    /// Derivatives (global parameter) at the joints: the outgoing segment's start derivative,
    /// and the last segment's end derivative.
    pub fn tangents(&self) -> Vec<Vec2> {
        let mut d: Vec<Vec2> = self.segments.iter().map(|s| s.velocity(0.0)).collect();
        d.push(self.segments[self.segments.len() - 1].velocity(1.0));
        d
    }

    /// Splits the global parameter `u in [0, len]` into (segment, local `t`); clamped.
    pub fn locate_param(&self, u: f64) -> (usize, f64) {
        let n = self.segments.len();
        if !(u > 0.0) {
            return (0, if u.is_nan() { u } else { 0.0 });
        }
        let i = (u.floor() as usize).min(n - 1);
        (i, (u - i as f64).min(1.0))
    }

    /// The point at global parameter `u in [0, len]`.
    pub fn eval(&self, u: f64) -> Point {
        let (i, t) = self.locate_param(u);
        self.segments[i].eval(t)
    }

    /// Highest continuity class at every joint, with derivative mismatches up to
    /// `tolerance * (1 + |derivative|)` accepted.
    pub fn continuity(&self, tolerance: f64) -> Continuity {
        let mut class = Continuity::C2;
        for w in self.segments.windows(2) {
            let (a, b) = (w[0], w[1]);
            let close = |x: Vec2, y: Vec2| (x - y).hypot() <= tolerance * (1.0 + x.hypot().max(y.hypot()));
            if !close(a.velocity(1.0), b.velocity(0.0)) {
                return Continuity::C0;
            }
            if !close(a.acceleration(1.0), b.acceleration(0.0)) {
                class = Continuity::C1;
            }
        }
        class
    }

    /// Length of each segment, absolute error at most `accuracy` each.
    pub fn segment_lengths(&self, accuracy: f64) -> Vec<f64> {
        let acc = accuracy / self.segments.len() as f64;
        self.segments.iter().map(|s| s.arclen(acc)).collect()
    }

    /// Total length with absolute error at most `accuracy`.
    pub fn arclen(&self, accuracy: f64) -> f64 {
        self.segment_lengths(accuracy).iter().sum()
    }

    /// Exact bounding box.
    pub fn bounding_box(&self) -> Rect {
        self.segments
            .iter()
            .skip(1)
            .fold(self.segments[0].bounding_box(), |r, s| r.union(s.bounding_box()))
    }

    /// Parametric jerk cost `sum_i int_0^1 |B_i'''(t)|^2 dt` (unit time per segment; the cubic's
    /// third derivative is constant, so this is exact).
    pub fn jerk_cost_param(&self) -> f64 {
        self.segments.iter().map(|s| s.jerk(0.0).hypot2()).sum()
    }

    /// Sum of `|kappa|` at `samples_per_segment` parameters uniform in each segment's `t`
    /// (both ends included), the paper's curvature measure on the parametric curve.
    pub fn curvature_sum_param(&self, samples_per_segment: usize) -> f64 {
        let m = samples_per_segment.max(2);
        self.segments
            .iter()
            .map(|s| {
                (0..m)
                    .map(|j| s.curvature(j as f64 / (m - 1) as f64).abs())
                    .sum::<f64>()
            })
            .sum()
    }
}
