//! Bézier curves of any degree: [`Bezier<N>`] (degree `N - 1`, a `Copy` value with
//! `[Point; N]`) and [`BezierDyn`] (degree chosen at run time, `Vec<Point>`).
//!
//! ```
//! use bezier::{Bezier, Point, ParamCurve, ParamCurveArclen, ParamCurveExtrema};
//! let b = Bezier::new([Point::new(0.0, 0.0), Point::new(1.0, 3.0), Point::new(2.0, -3.0), Point::new(3.0, 1.0), Point::new(4.0, 0.0)]);
//! assert_eq!(b.degree(), 4);
//! let e = b.elevate(); // exact: the same curve with 6 control points
//! assert!((e.eval(0.3) - b.eval(0.3)).hypot() < 1e-14);
//! let len = b.arclen(1e-10);
//! assert!((len - e.arclen(1e-10)).abs() < 1e-9);
//! let bb = b.bounding_box();
//! assert!(bb.contains_with_tolerance(b.eval(0.77), 0.0));
//! ```
//!
//! Degree 2 and 3 ([`Bezier<3>`], [`Bezier<4>`]) delegate arc length to [`QuadBez`] and
//! [`CubicBez`] (closed form and a-priori Gauss-Legendre); other degrees use adaptive
//! Gauss-Legendre with a 16-point rule checked against its two halves.
//!
//! [`ParamCurveDeriv`] (derivative *curves*, whose type has one point fewer) is implemented for
//! `N <= 16`; [`Bezier::velocity`], [`Bezier::acceleration`], [`Bezier::jerk`] and
//! [`Bezier::curvature`] work for every `N`.

use crate::bernstein;
use crate::error::{check_points, Error, Result};
use crate::point::{Point, Vec2};
use crate::quadrature::{self, integrate_adaptive};
use crate::traits::{
    curvature_from, ParamCurve, ParamCurveArclen, ParamCurveCurvature, ParamCurveDeriv, ParamCurveExtrema,
};
use crate::{CubicBez, QuadBez};

/// A Bézier curve of degree `N - 1` with control points `points`. `N >= 1` (checked at
/// compile time by [`Bezier::new`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bezier<const N: usize> {
    /// Control points, `P_0 .. P_{N-1}`.
    pub points: [Point; N],
}

/// Velocity from hodograph control points.
#[inline]
fn deriv_at(points: &[Point], t: f64, order: usize, scratch: &mut [Point]) -> Vec2 {
    let n = points.len();
    if order >= n {
        return Vec2::ZERO;
    }
    scratch[..n].copy_from_slice(points);
    let mut len = n;
    for _ in 0..order {
        let deg = (len - 1) as f64;
        for i in 0..len - 1 {
            scratch[i] = (deg * (scratch[i + 1] - scratch[i])).to_point();
        }
        len -= 1;
    }
    bernstein::eval_bernstein(&scratch[..len], t).to_vec2()
}

/// Sum of control-polygon leg lengths: an upper bound of the arc length (round-off scale).
fn polygon_length(points: &[Point]) -> f64 {
    points.windows(2).map(|w| w[0].distance(w[1])).sum()
}

/// Parameters where the hodograph's x or y coordinate vanishes in `(0, 1)`, ascending.
fn extrema_of(points: &[Point]) -> Vec<f64> {
    let n = points.len();
    if n < 3 {
        return Vec::new();
    }
    let mut hodo = vec![Point::ORIGIN; n - 1];
    bernstein::hodograph(points, &mut hodo);
    let mut coeffs = vec![0.0; n - 1];
    let mut out = Vec::new();
    let mut roots = Vec::new();
    for axis in 0..2 {
        bernstein::power_coeffs(&hodo, axis, &mut coeffs);
        roots.clear();
        bernstein::real_roots_unit(&coeffs, &mut roots);
        out.extend_from_slice(&roots);
    }
    out.sort_by(f64::total_cmp);
    out.dedup();
    out
}

/// Arc length on `[t0, t1]` for any degree, from the hodograph points.
fn arclen_general(points: &[Point], hodo: &[Point], t0: f64, t1: f64, accuracy: f64) -> f64 {
    let speed = |t: f64| bernstein::eval_bernstein(hodo, t).to_vec2().hypot();
    integrate_adaptive(&speed, t0, t1, accuracy, polygon_length(points))
}

impl<const N: usize> Bezier<N> {
    /// A curve from its control points.
    #[inline]
    pub const fn new(points: [Point; N]) -> Bezier<N> {
        const { assert!(N >= 1, "a Bezier curve needs at least one control point") };
        Bezier { points }
    }

    /// Like [`new`](Self::new) but rejects non-finite coordinates (`Error::NonFinite` naming
    /// `points` and the index).
    pub fn try_new(points: [Point; N]) -> Result<Bezier<N>> {
        check_points("points", &points)?;
        Ok(Bezier::new(points))
    }

    /// The degree, `N - 1`.
    #[inline]
    pub const fn degree(&self) -> usize {
        N - 1
    }

    /// De Casteljau evaluation (repeated linear interpolation; `O(N^2)`, very stable).
    pub fn eval_de_casteljau(&self, t: f64) -> Point {
        let mut s = self.points;
        bernstein::eval_de_casteljau(&self.points, t, &mut s)
    }

    /// Bernstein-form evaluation (`O(N)`; what [`ParamCurve::eval`] uses).
    #[inline]
    pub fn eval_bernstein(&self, t: f64) -> Point {
        bernstein::eval_bernstein(&self.points, t)
    }

    /// `B'(t)`, for any `N`.
    pub fn velocity(&self, t: f64) -> Vec2 {
        let mut s = self.points;
        deriv_at(&self.points, t, 1, &mut s)
    }

    /// `B''(t)`, for any `N`.
    pub fn acceleration(&self, t: f64) -> Vec2 {
        let mut s = self.points;
        deriv_at(&self.points, t, 2, &mut s)
    }

    /// `B'''(t)`, for any `N`.
    pub fn jerk(&self, t: f64) -> Vec2 {
        let mut s = self.points;
        deriv_at(&self.points, t, 3, &mut s)
    }

    /// Signed curvature (see [`ParamCurveCurvature::curvature`]), for any `N`.
    pub fn curvature(&self, t: f64) -> f64 {
        curvature_from(self.velocity(t), self.acceleration(t))
    }

    /// Derivative control points `(N - 1)(P_{i+1} - P_i)` as a dynamic-degree curve (for any `N`;
    /// [`ParamCurveDeriv::deriv`] gives a fixed-size one for `N <= 16`).
    pub fn deriv_dyn(&self) -> BezierDyn {
        BezierDyn::from_slice(&self.points).deriv()
    }

    /// The same curve with a run-time degree.
    pub fn to_dyn(&self) -> BezierDyn {
        BezierDyn::from_slice(&self.points)
    }

    /// `true` when every coordinate is finite.
    pub fn is_finite(&self) -> bool {
        self.points.iter().all(|p| p.is_finite())
    }

    /// The box spanned by the control points (it contains the curve; see
    /// [`ParamCurveExtrema::bounding_box`] for the exact one).
    pub fn control_box(&self) -> crate::Rect {
        self.points
            .iter()
            .skip(1)
            .fold(crate::Rect::from_point(self.points[0]), |r, p| r.union_pt(*p))
    }

    fn hodograph_array(&self) -> [Point; N] {
        let mut h = [Point::ORIGIN; N];
        bernstein::hodograph(&self.points, &mut h);
        h
    }
}

impl<const N: usize> ParamCurve for Bezier<N> {
    #[inline]
    fn eval(&self, t: f64) -> Point {
        bernstein::eval_bernstein(&self.points, t)
    }

    fn subsegment(&self, t0: f64, t1: f64) -> Bezier<N> {
        let mut out = self.points;
        bernstein::subsegment(&self.points, t0, t1, &mut out);
        Bezier { points: out }
    }

    #[inline]
    fn start(&self) -> Point {
        self.points[0]
    }

    #[inline]
    fn end(&self) -> Point {
        self.points[N - 1]
    }

    fn subdivide(&self, t: f64) -> (Bezier<N>, Bezier<N>) {
        let mut l = self.points;
        let mut r = self.points;
        bernstein::split(&self.points, t, &mut l, &mut r);
        (Bezier { points: l }, Bezier { points: r })
    }
}

impl<const N: usize> ParamCurveArclen for Bezier<N> {
    #[inline]
    fn speed(&self, t: f64) -> f64 {
        self.velocity(t).hypot()
    }

    fn arclen_range(&self, t0: f64, t1: f64, accuracy: f64) -> f64 {
        if let Ok(p) = <[Point; 4]>::try_from(&self.points[..]) {
            return CubicBez::from_points(p).arclen_range(t0, t1, accuracy);
        }
        if let Ok(p) = <[Point; 3]>::try_from(&self.points[..]) {
            return QuadBez::from_points(p).arclen_range(t0, t1, accuracy);
        }
        if N < 3 {
            // A point or a uniform-speed line.
            return self.velocity(0.0).hypot() * (t1 - t0);
        }
        let h = self.hodograph_array();
        arclen_general(&self.points, &h[..N - 1], t0, t1, accuracy)
    }

    fn inv_arclen(&self, s: f64, accuracy: f64) -> f64 {
        let h = self.hodograph_array();
        let hodo = &h[..N.saturating_sub(1).max(1)];
        let acc = crate::accuracy::sanitize_accuracy(accuracy);
        let total = self.arclen(0.25 * acc);
        // Newton steps (no second derivative passed).
        let speed = |t: f64| (bernstein::eval_bernstein(hodo, t).to_vec2().hypot(), 0.0);
        quadrature::inv_arclen_with(speed, |a, b, e| self.arclen_range(a, b, e), s, total, acc)
    }
}

impl<const N: usize> ParamCurveExtrema for Bezier<N> {
    fn extrema(&self) -> Vec<f64> {
        extrema_of(&self.points)
    }
}

// Derivatives: Bezier<n> -> Bezier<n - 1>.
macro_rules! impl_deriv_only {
    ($($n:literal => $m:literal),*) => {$(
        impl ParamCurveDeriv for Bezier<$n> {
            type DerivResult = Bezier<$m>;

            fn deriv(&self) -> Bezier<$m> {
                let mut out = [Point::ORIGIN; $m];
                bernstein::hodograph(&self.points, &mut out);
                Bezier { points: out }
            }

            fn velocity(&self, t: f64) -> Vec2 {
                Bezier::velocity(self, t)
            }

            fn acceleration(&self, t: f64) -> Vec2 {
                Bezier::acceleration(self, t)
            }

            fn jerk(&self, t: f64) -> Vec2 {
                Bezier::jerk(self, t)
            }
        }

        impl ParamCurveCurvature for Bezier<$n> {}
    )*};
}

// Elevation: Bezier<n> -> Bezier<n + 1>.
macro_rules! impl_elevate {
    ($($n:literal => $m:literal),*) => {$(
        impl Bezier<$n> {
            /// Exact degree elevation: the same curve with one more control point.
            pub fn elevate(&self) -> Bezier<$m> {
                let mut out = [Point::ORIGIN; $m];
                bernstein::elevate(&self.points, &mut out);
                Bezier { points: out }
            }
        }
    )*};
}

impl_deriv_only!(2 => 1, 3 => 2, 4 => 3, 5 => 4, 6 => 5, 7 => 6, 8 => 7, 9 => 8, 10 => 9, 11 => 10,
    12 => 11, 13 => 12, 14 => 13, 15 => 14, 16 => 15);
impl_elevate!(1 => 2, 2 => 3, 3 => 4, 4 => 5, 5 => 6, 6 => 7, 7 => 8, 8 => 9, 9 => 10, 10 => 11,
    11 => 12, 12 => 13, 13 => 14, 14 => 15, 15 => 16);

/// The constant curve's derivative is the zero curve (of the same type, closing the recursion).
impl ParamCurveDeriv for Bezier<1> {
    type DerivResult = Bezier<1>;

    fn deriv(&self) -> Bezier<1> {
        Bezier {
            points: [Point::ORIGIN],
        }
    }
}

impl ParamCurveCurvature for Bezier<1> {}

/// A Bézier curve whose degree is chosen at run time. Not `Copy` (it owns a `Vec`); operations
/// that need scratch space allocate it (documented per method).
#[derive(Clone, Debug, PartialEq)]
pub struct BezierDyn {
    points: Vec<Point>,
}

impl BezierDyn {
    /// A curve from at least one control point (`Error::TooFew` for none; `Error::NonFinite`
    /// naming `points` and the index for NaN or infinite coordinates).
    pub fn new(points: Vec<Point>) -> Result<BezierDyn> {
        if points.is_empty() {
            return Err(Error::TooFew {
                field: "points",
                got: 0,
                need: 1,
            });
        }
        check_points("points", &points)?;
        Ok(BezierDyn { points })
    }

    /// Copies the control points; an empty slice gives the single point at the origin.
    fn from_slice(points: &[Point]) -> BezierDyn {
        if points.is_empty() {
            BezierDyn {
                points: vec![Point::ORIGIN],
            }
        } else {
            BezierDyn {
                points: points.to_vec(),
            }
        }
    }

    /// The control points.
    pub fn points(&self) -> &[Point] {
        &self.points
    }

    /// The degree, `points().len() - 1`.
    pub fn degree(&self) -> usize {
        self.points.len() - 1
    }

    /// De Casteljau evaluation (allocates a scratch copy of the points).
    pub fn eval_de_casteljau(&self, t: f64) -> Point {
        let mut s = self.points.clone();
        bernstein::eval_de_casteljau(&self.points, t, &mut s)
    }

    /// Exact degree elevation (allocates the new points).
    pub fn elevate(&self) -> BezierDyn {
        let mut out = vec![Point::ORIGIN; self.points.len() + 1];
        bernstein::elevate(&self.points, &mut out);
        BezierDyn { points: out }
    }

    /// A fixed-degree copy when `N` equals the number of control points.
    pub fn to_fixed<const N: usize>(&self) -> Option<Bezier<N>> {
        <[Point; N]>::try_from(&self.points[..])
            .ok()
            .map(|points| Bezier { points })
    }

    fn nth_deriv(&self, t: f64, order: usize) -> Vec2 {
        let mut s = self.points.clone();
        deriv_at(&self.points, t, order, &mut s)
    }
}

impl ParamCurve for BezierDyn {
    fn eval(&self, t: f64) -> Point {
        bernstein::eval_bernstein(&self.points, t)
    }

    fn subsegment(&self, t0: f64, t1: f64) -> BezierDyn {
        let mut out = self.points.clone();
        bernstein::subsegment(&self.points, t0, t1, &mut out);
        BezierDyn { points: out }
    }

    fn start(&self) -> Point {
        self.points[0]
    }

    fn end(&self) -> Point {
        self.points[self.points.len() - 1]
    }

    fn subdivide(&self, t: f64) -> (BezierDyn, BezierDyn) {
        let mut l = self.points.clone();
        let mut r = self.points.clone();
        bernstein::split(&self.points, t, &mut l, &mut r);
        (BezierDyn { points: l }, BezierDyn { points: r })
    }
}

impl ParamCurveDeriv for BezierDyn {
    type DerivResult = BezierDyn;

    /// The hodograph; a constant curve's derivative is the zero point.
    fn deriv(&self) -> BezierDyn {
        let n = self.points.len();
        if n < 2 {
            return BezierDyn {
                points: vec![Point::ORIGIN],
            };
        }
        let mut out = vec![Point::ORIGIN; n - 1];
        bernstein::hodograph(&self.points, &mut out);
        BezierDyn { points: out }
    }

    fn velocity(&self, t: f64) -> Vec2 {
        self.nth_deriv(t, 1)
    }

    fn acceleration(&self, t: f64) -> Vec2 {
        self.nth_deriv(t, 2)
    }

    fn jerk(&self, t: f64) -> Vec2 {
        self.nth_deriv(t, 3)
    }
}

impl ParamCurveCurvature for BezierDyn {}

impl ParamCurveArclen for BezierDyn {
    fn speed(&self, t: f64) -> f64 {
        self.velocity(t).hypot()
    }

    /// Allocates the hodograph once per call.
    fn arclen_range(&self, t0: f64, t1: f64, accuracy: f64) -> f64 {
        match self.points.len() {
            4 => CubicBez::from_points([self.points[0], self.points[1], self.points[2], self.points[3]])
                .arclen_range(t0, t1, accuracy),
            3 => QuadBez::from_points([self.points[0], self.points[1], self.points[2]]).arclen_range(t0, t1, accuracy),
            1 | 2 => self.velocity(0.0).hypot() * (t1 - t0),
            _ => {
                let h = self.deriv();
                arclen_general(&self.points, &h.points, t0, t1, accuracy)
            }
        }
    }

    fn inv_arclen(&self, s: f64, accuracy: f64) -> f64 {
        let h = self.deriv();
        let acc = crate::accuracy::sanitize_accuracy(accuracy);
        let total = self.arclen(0.25 * acc);
        // Newton steps (no second derivative passed).
        let speed = |t: f64| (bernstein::eval_bernstein(&h.points, t).to_vec2().hypot(), 0.0);
        quadrature::inv_arclen_with(speed, |a, b, e| self.arclen_range(a, b, e), s, total, acc)
    }
}

impl ParamCurveExtrema for BezierDyn {
    fn extrema(&self) -> Vec<f64> {
        extrema_of(&self.points)
    }
}
