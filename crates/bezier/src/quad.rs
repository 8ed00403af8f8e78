//! Quadratic Bézier segments, with closed-form arc length.
//!
//! ```
//! use bezier::{QuadBez, ParamCurveArclen};
//! // The parabola y = x^2 on [0, 1].
//! let q = QuadBez::new((0.0, 0.0), (0.5, 0.0), (1.0, 1.0));
//! let exact = (5f64.sqrt() / 2.0) + 2f64.asinh() / 4.0;
//! assert!((q.arclen(1e-12) - exact).abs() < 1e-13);
//! ```
//!
//! The speed is `|B'(t)| = |alpha| |t - r|` with the complex root `r = u + i v` of the linear
//! hodograph, so `int |B'| = |alpha| int sqrt((t - u)^2 + v^2) dt` has the antiderivative
//! `F(x) = (x sqrt(x^2 + v^2) + v^2 asinh(x / |v|)) / 2` at `x = t - u`. When the root is far
//! from the interval the closed form cancels badly, and Gauss-Legendre (a-priori order) is used.

use crate::bernstein;
use crate::error::{check_points, Result};
use crate::point::{Point, Rect, Vec2};
use crate::quadrature::{integrate_apriori, Complex, Singularities};
use crate::traits::{ParamCurve, ParamCurveArclen, ParamCurveCurvature, ParamCurveDeriv, ParamCurveExtrema};
use crate::Bezier;

/// A quadratic Bézier segment with control points `p0, p1, p2`. A `Copy` value; NaN
/// coordinates propagate (use [`QuadBez::try_new`] to reject them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QuadBez {
    /// Start point.
    pub p0: Point,
    /// Control point.
    pub p1: Point,
    /// End point.
    pub p2: Point,
}

impl QuadBez {
    /// A quadratic from its three control points.
    #[inline]
    pub fn new(p0: impl Into<Point>, p1: impl Into<Point>, p2: impl Into<Point>) -> QuadBez {
        QuadBez {
            p0: p0.into(),
            p1: p1.into(),
            p2: p2.into(),
        }
    }

    /// Like [`new`](Self::new) but rejects non-finite coordinates.
    pub fn try_new(p0: impl Into<Point>, p1: impl Into<Point>, p2: impl Into<Point>) -> Result<QuadBez> {
        let q = QuadBez::new(p0, p1, p2);
        check_points("points", &q.points())?;
        Ok(q)
    }

    /// The control points as an array.
    #[inline]
    pub fn points(&self) -> [Point; 3] {
        [self.p0, self.p1, self.p2]
    }

    /// A quadratic from an array of three control points.
    #[inline]
    pub fn from_points(p: [Point; 3]) -> QuadBez {
        QuadBez {
            p0: p[0],
            p1: p[1],
            p2: p[2],
        }
    }

    /// The general-degree view of this curve.
    #[inline]
    pub fn to_bezier(&self) -> Bezier<3> {
        Bezier::new(self.points())
    }

    /// Exact degree elevation to a cubic.
    pub fn elevate(&self) -> crate::CubicBez {
        crate::CubicBez::from_points(self.to_bezier().elevate().points)
    }

    /// `B'(t) = alpha t + beta` as `(alpha, beta)`.
    #[inline]
    fn hodograph_power(&self) -> (Vec2, Vec2) {
        (
            2.0 * ((self.p2 - self.p1) - (self.p1 - self.p0)),
            2.0 * (self.p1 - self.p0),
        )
    }
}

impl From<QuadBez> for Bezier<3> {
    fn from(q: QuadBez) -> Bezier<3> {
        q.to_bezier()
    }
}

impl From<Bezier<3>> for QuadBez {
    fn from(b: Bezier<3>) -> QuadBez {
        QuadBez::from_points(b.points)
    }
}

impl ParamCurve for QuadBez {
    #[inline]
    fn eval(&self, t: f64) -> Point {
        let mt = 1.0 - t;
        let (a, b, c) = (mt * mt, 2.0 * mt * t, t * t);
        Point::new(
            a * self.p0.x + b * self.p1.x + c * self.p2.x,
            a * self.p0.y + b * self.p1.y + c * self.p2.y,
        )
    }

    fn subsegment(&self, t0: f64, t1: f64) -> QuadBez {
        let mut out = self.points();
        bernstein::subsegment(&self.points(), t0, t1, &mut out);
        QuadBez::from_points(out)
    }

    #[inline]
    fn start(&self) -> Point {
        self.p0
    }

    #[inline]
    fn end(&self) -> Point {
        self.p2
    }
}

impl ParamCurveDeriv for QuadBez {
    type DerivResult = Bezier<2>;

    fn deriv(&self) -> Bezier<2> {
        Bezier::new([
            (2.0 * (self.p1 - self.p0)).to_point(),
            (2.0 * (self.p2 - self.p1)).to_point(),
        ])
    }

    #[inline]
    fn velocity(&self, t: f64) -> Vec2 {
        let (a, b) = self.hodograph_power();
        a * t + b
    }

    #[inline]
    fn acceleration(&self, _t: f64) -> Vec2 {
        self.hodograph_power().0
    }

    #[inline]
    fn jerk(&self, _t: f64) -> Vec2 {
        Vec2::ZERO
    }
}

impl ParamCurveCurvature for QuadBez {}

/// `int sqrt(x^2 + v^2) dx` antiderivative, finite for `v = 0`.
#[inline]
fn antideriv(x: f64, v: f64) -> f64 {
    let r = (x * x + v * v).sqrt();
    let log_term = if v == 0.0 { 0.0 } else { v * v * (x / v.abs()).asinh() };
    0.5 * (x * r + log_term)
}

impl ParamCurveArclen for QuadBez {
    #[inline]
    fn speed(&self, t: f64) -> f64 {
        self.velocity(t).hypot()
    }

    /// Closed form when the hodograph's root is within a few interval lengths; otherwise
    /// Gauss-Legendre with the a-priori order (the integrand is then very smooth).
    fn arclen_range(&self, t0: f64, t1: f64, accuracy: f64) -> f64 {
        let (alpha, beta) = self.hodograph_power();
        let la = alpha.hypot();
        let lb = beta.hypot();
        let h = 0.5 * (t1 - t0).abs();
        let c = 0.5 * (t0 + t1);
        if la > 1e-12 * lb {
            // r = -beta / alpha as complex numbers.
            let r = Complex::new(-beta.x, -beta.y).div(Complex::new(alpha.x, alpha.y));
            if Complex::new(r.re - c, r.im).abs() <= 4.0 * h {
                let v = r.im;
                return la * (antideriv(t1 - r.re, v) - antideriv(t0 - r.re, v));
            }
            let roots = [r];
            let sing = Singularities {
                lead: la,
                roots: &roots,
            };
            return integrate_apriori(&|t| self.speed(t), &sing, t0, t1, accuracy);
        }
        // Constant velocity (up to round-off): exact with any rule.
        let sing = Singularities { lead: lb, roots: &[] };
        integrate_apriori(
            &|t| self.speed(t),
            &sing,
            t0,
            t1,
            crate::accuracy::sanitize_accuracy(accuracy),
        )
    }
}

impl ParamCurveExtrema for QuadBez {
    fn extrema(&self) -> Vec<f64> {
        let (a, b) = self.hodograph_power();
        let mut out = Vec::with_capacity(2);
        for (ca, cb) in [(a.x, b.x), (a.y, b.y)] {
            if ca != 0.0 {
                let t = -cb / ca;
                if t > 0.0 && t < 1.0 {
                    out.push(t);
                }
            }
        }
        out.sort_by(f64::total_cmp);
        out.dedup();
        out
    }

    fn bounding_box(&self) -> Rect {
        let mut r = Rect::from_point(self.p0).union_pt(self.p2);
        for t in self.extrema() {
            r = r.union_pt(self.eval(t));
        }
        r
    }
}
