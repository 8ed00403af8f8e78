//! Capability traits shared by every curve type (after kurbo's `ParamCurve*` family).
//!
//! A curve is a map `t -> B(t)` on `t in [0, 1]`. Each trait adds one capability, with default
//! methods built from a few required ones, so a new curve type gets the whole toolbox by
//! implementing a handful of functions:
//!
//! | trait | required | provided |
//! |---|---|---|
//! | [`ParamCurve`] | `eval`, `subsegment` | `start`, `end`, `subdivide` |
//! | [`ParamCurveDeriv`] | `deriv` | `velocity`, `acceleration`, `jerk` |
//! | [`ParamCurveCurvature`] | — | `curvature`, `curvature_deriv`, `tangent` |
//! | [`ParamCurveArclen`] | `speed`, `arclen_range` | `arclen`, `arclen_simpson`, `inv_arclen`, `resample_uniform`, `resample_points` |
//! | [`ParamCurveExtrema`] | `extrema` | `bounding_box` |
//!
//! Every approximate method takes an explicit `accuracy` (an absolute error in length units);
//! [`DEFAULT_ACCURACY`] is the value to use when in doubt.
//!
//! ```
//! use bezier::{CubicBez, ParamCurve, ParamCurveArclen, DEFAULT_ACCURACY};
//! let c = CubicBez::new((0.0, 0.0), (1.0, 2.0), (3.0, 2.0), (4.0, 0.0));
//! let len = c.arclen(DEFAULT_ACCURACY);
//! let t = c.inv_arclen(0.5 * len, DEFAULT_ACCURACY);
//! // Symmetric curve: half the length at t = 1/2; a length error of 1e-9 moves t by 1e-9 / |B'(1/2)|.
//! assert!((t - 0.5).abs() < 1e-9 / 4.5 + 1e-15);
//! ```

pub use crate::accuracy::{DEFAULT_ACCURACY, RELATIVE_ACCURACY_FLOOR};
use crate::point::{Point, Rect, Vec2};

/// A parametric curve `t -> B(t)`, `t in [0, 1]`.
pub trait ParamCurve: Sized {
    /// The point at parameter `t`. Values of `t` outside `[0, 1]` extrapolate the polynomial.
    fn eval(&self, t: f64) -> Point;

    /// The part of the curve between `t0` and `t1`, reparametrised to `[0, 1]`
    /// (reversed when `t1 < t0`).
    fn subsegment(&self, t0: f64, t1: f64) -> Self;

    /// `B(0)`.
    fn start(&self) -> Point {
        self.eval(0.0)
    }

    /// `B(1)`.
    fn end(&self) -> Point {
        self.eval(1.0)
    }

    /// Splits the curve at `t` into the parts on `[0, t]` and `[t, 1]`.
    fn subdivide(&self, t: f64) -> (Self, Self) {
        (self.subsegment(0.0, t), self.subsegment(t, 1.0))
    }
}

/// A curve whose derivative (hodograph) is again a curve. Derivative control points are stored
/// as [`Point`]s; read them as vectors.
pub trait ParamCurveDeriv: ParamCurve {
    /// Type of the derivative curve.
    type DerivResult: ParamCurveDeriv;

    /// The derivative curve `B'(t)`.
    fn deriv(&self) -> Self::DerivResult;

    /// `B'(t)`.
    fn velocity(&self, t: f64) -> Vec2 {
        self.deriv().eval(t).to_vec2()
    }

    /// `B''(t)`.
    fn acceleration(&self, t: f64) -> Vec2 {
        self.deriv().deriv().eval(t).to_vec2()
    }

    /// `B'''(t)`.
    fn jerk(&self, t: f64) -> Vec2 {
        self.deriv().deriv().deriv().eval(t).to_vec2()
    }
}

/// Curvature from velocity and acceleration: `kappa = (v x a) / |v|^3`, signed (positive when the
/// curve turns left). Where `|v| = 0` (a cusp or a curve collapsed to a point) the curvature is
/// undefined and `0.0` is returned. NaN inputs give NaN.
#[inline]
pub fn curvature_from(v: Vec2, a: Vec2) -> f64 {
    let s2 = v.hypot2();
    if s2 == 0.0 {
        return 0.0;
    }
    let k = v.cross(a) / (s2 * s2.sqrt());
    if k.is_nan() && v.is_finite() && a.is_finite() {
        0.0
    } else {
        k
    }
}

/// `d kappa / dt` from velocity, acceleration and jerk:
/// `((v x j) |v|^2 - 3 (v x a)(v . a)) / |v|^5`; `0.0` where `|v| = 0`.
#[inline]
pub fn curvature_deriv_from(v: Vec2, a: Vec2, j: Vec2) -> f64 {
    let s2 = v.hypot2();
    if s2 == 0.0 {
        return 0.0;
    }
    let d = (v.cross(j) * s2 - 3.0 * v.cross(a) * v.dot(a)) / (s2 * s2 * s2.sqrt());
    if d.is_nan() && v.is_finite() && a.is_finite() && j.is_finite() {
        0.0
    } else {
        d
    }
}

/// Signed curvature and its derivatives.
pub trait ParamCurveCurvature: ParamCurveDeriv {
    /// Signed curvature `kappa(t) = (x' y'' - y' x'') / (x'^2 + y'^2)^{3/2}` (the paper's formula
    /// without the absolute value). `0.0` where the speed vanishes (see [`curvature_from`]).
    fn curvature(&self, t: f64) -> f64 {
        curvature_from(self.velocity(t), self.acceleration(t))
    }

    /// `d kappa / dt` (see [`curvature_deriv_from`]).
    fn curvature_deriv(&self, t: f64) -> f64 {
        curvature_deriv_from(self.velocity(t), self.acceleration(t), self.jerk(t))
    }

    /// Unit tangent at `t`. Where the velocity vanishes (coincident control points, cusps) the
    /// direction of the first non-zero higher derivative is used; `None` when every derivative
    /// vanishes (a curve collapsed to a point) or is not finite.
    fn tangent(&self, t: f64) -> Option<Vec2> {
        let v = self.velocity(t);
        let scale = v.hypot() + self.acceleration(t).hypot() + self.jerk(t).hypot();
        if v.hypot() > 1e-12 * scale {
            return v.normalize();
        }
        // Near t the curve moves like a (dt) + j (dt)^2 / 2; the sign of dt follows which side
        // of [0, 1] we are on, so the tangent points along the direction of travel.
        let a = self.acceleration(t);
        let sign = if t >= 1.0 { -1.0 } else { 1.0 };
        if a.hypot() > 1e-12 * scale {
            return (a * sign).normalize();
        }
        self.jerk(t).normalize()
    }
}

/// Arc length, its inverse and resampling. Implementors supply the speed `|B'(t)|` and the
/// length of a parameter range; everything else has a default.
pub trait ParamCurveArclen: ParamCurve {
    /// `|B'(t)|`.
    fn speed(&self, t: f64) -> f64;

    /// Length of the curve between parameters `t0` and `t1`, negative when `t1 < t0`,
    /// with absolute error at most `accuracy`.
    fn arclen_range(&self, t0: f64, t1: f64, accuracy: f64) -> f64;

    /// Total length with absolute error at most `accuracy` (default [`DEFAULT_ACCURACY`];
    /// `1e-10` and below are reachable).
    fn arclen(&self, accuracy: f64) -> f64 {
        self.arclen_range(0.0, 1.0, accuracy)
    }

    /// Total length by composite Simpson's rule on `|B'(t)|`, as in the paper: the number of
    /// intervals doubles (reusing every evaluation) until two successive estimates differ by
    /// less than `15 * accuracy` (Richardson's bound), at most `2^20` intervals.
    fn arclen_simpson(&self, accuracy: f64) -> f64 {
        crate::quadrature::simpson_adaptive(|t| self.speed(t), 0.0, 1.0, accuracy, 20)
    }

    /// The parameter `t` at which the length from the start is `s`, so that
    /// `|arclen_range(0, t) - s| <= accuracy`; `s` is clamped to `[0, arclen]`.
    /// Safeguarded Newton: each step integrates only the increment, and falls back to
    /// bisection of the bracket when the step leaves it or the speed vanishes.
    /// A curve of zero length returns `0.0`.
    fn inv_arclen(&self, s: f64, accuracy: f64) -> f64 {
        let acc = crate::accuracy::sanitize_accuracy(accuracy);
        let total = self.arclen(0.25 * acc);
        crate::quadrature::inv_arclen_with(
            |t| (self.speed(t), 0.0),
            |a, b, e| self.arclen_range(a, b, e),
            s,
            total,
            acc,
        )
    }

    /// `n` parameters (both ends included) splitting the curve into `n - 1` pieces of equal
    /// length to within `accuracy`, found incrementally (each solve starts from the previous
    /// parameter). `n < 2` gives `n` zeros; a curve of zero length gives parameters uniform in `t`.
    fn resample_uniform(&self, n: usize, accuracy: f64) -> Vec<f64> {
        let acc = crate::accuracy::sanitize_accuracy(accuracy);
        let total = if n < 2 { 0.0 } else { self.arclen(0.25 * acc) };
        crate::quadrature::resample_with(
            |t| (self.speed(t), 0.0),
            |a, b, e| self.arclen_range(a, b, e),
            n,
            total,
            acc,
        )
    }

    /// The points at the parameters of [`resample_uniform`](Self::resample_uniform).
    fn resample_points(&self, n: usize, accuracy: f64) -> Vec<Point> {
        self.resample_uniform(n, accuracy)
            .into_iter()
            .map(|t| self.eval(t))
            .collect()
    }
}

/// Parameters where a coordinate is extremal, and the exact bounding box that follows.
pub trait ParamCurveExtrema: ParamCurve {
    /// Parameters in `(0, 1)`, ascending, where `x'(t) = 0` or `y'(t) = 0` (roots of the
    /// derivative's coordinates).
    fn extrema(&self) -> Vec<f64>;

    /// The exact axis-aligned bounding box: the end points and the points at [`extrema`](Self::extrema).
    fn bounding_box(&self) -> Rect {
        let mut r = Rect::from_point(self.start()).union_pt(self.end());
        for t in self.extrema() {
            r = r.union_pt(self.eval(t));
        }
        r
    }
}
