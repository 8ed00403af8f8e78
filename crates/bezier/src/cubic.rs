//! Cubic Bézier segments, the workhorse of splines, with the fast arc-length engine.
//!
//! ```
//! use bezier::{CubicBez, ParamCurve, ParamCurveArclen, ParamCurveExtrema};
//! let c = CubicBez::new((0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.0));
//! let len = c.arclen(1e-10);
//! assert!((len - 2.0).abs() < 0.01);
//! let bb = c.bounding_box();
//! assert!((bb.y1 - 0.75).abs() < 1e-15); // the top, at t = 1/2
//! ```
//!
//! # Arc length
//!
//! The hodograph `B'(t) = A t^2 + B t + C` read as a complex polynomial
//! `z(t) = x'(t) + i y'(t) = A (t - r_1)(t - r_2)` gives the speed `|B'(t)| = |A| |t - r_1| |t - r_2|`
//! and, through its roots, the exact location of every singularity of the integrand. The
//! Gauss-Legendre order is chosen from an a-priori error bound (see the `quadrature` module
//! docs) before anything is evaluated. A smooth segment is decided by a root-free bound on the
//! hodograph's Chebyshev coefficients (one 6- to 16-point rule at `1e-9`, evaluated in the power
//! basis with the symmetric nodes sharing work); otherwise the roots are computed,
//! the interval is cut at the real part of every root near the real axis (a near-cusp then sits
//! at the end of a piece, where a low-order rule copes with it), and each piece's order comes from
//! tabulated errors of the near-cusp model `sqrt((x - x0)^2 + eps^2)` (a calibrated estimate that
//! follows the requested accuracy); the Bernstein-ellipse bound with graded splits toward the root
//! remains the fallback. Nothing is allocated.

use crate::bernstein;
use crate::error::{check_points, Error, Result};
use crate::point::{Point, Rect, Vec2};
use crate::quad::QuadBez;
use crate::quadrature::{self, arclen_quadratic_hodograph, arclen_unit_batch, complex_quadratic_roots, Complex};
use crate::traits::{ParamCurve, ParamCurveArclen, ParamCurveCurvature, ParamCurveDeriv, ParamCurveExtrema};
use crate::Bezier;

/// A cubic Bézier segment with control points `p0 .. p3`. A `Copy` value; NaN coordinates are
/// allowed (use [`CubicBez::try_new`] to reject them) and propagate NaN through the results.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CubicBez {
    /// Start point.
    pub p0: Point,
    /// First control point.
    pub p1: Point,
    /// Second control point.
    pub p2: Point,
    /// End point.
    pub p3: Point,
}

impl CubicBez {
    /// A cubic from its four control points.
    #[inline]
    pub fn new(p0: impl Into<Point>, p1: impl Into<Point>, p2: impl Into<Point>, p3: impl Into<Point>) -> CubicBez {
        CubicBez {
            p0: p0.into(),
            p1: p1.into(),
            p2: p2.into(),
            p3: p3.into(),
        }
    }

    /// Like [`new`](Self::new) but rejects non-finite coordinates (`Error::NonFinite` naming
    /// `points` and the index).
    pub fn try_new(
        p0: impl Into<Point>,
        p1: impl Into<Point>,
        p2: impl Into<Point>,
        p3: impl Into<Point>,
    ) -> Result<CubicBez> {
        let c = CubicBez::new(p0, p1, p2, p3);
        check_points("points", &c.points())?;
        Ok(c)
    }

    /// The control points as an array.
    #[inline]
    pub fn points(&self) -> [Point; 4] {
        [self.p0, self.p1, self.p2, self.p3]
    }

    /// A cubic from an array of four control points.
    #[inline]
    pub fn from_points(p: [Point; 4]) -> CubicBez {
        CubicBez {
            p0: p[0],
            p1: p[1],
            p2: p[2],
            p3: p[3],
        }
    }

    /// The straight segment from `p0` to `p1` as a cubic with uniform speed.
    pub fn line(p0: impl Into<Point>, p1: impl Into<Point>) -> CubicBez {
        let (a, b) = (p0.into(), p1.into());
        CubicBez::from_points([a, a.lerp(b, 1.0 / 3.0), a.lerp(b, 2.0 / 3.0), b])
    }

    /// The cubic Hermite segment with end points `a`, `b` and end derivatives `da`, `db`
    /// (`B'(0) = da`, `B'(1) = db`).
    pub fn hermite(a: Point, da: Vec2, b: Point, db: Vec2) -> CubicBez {
        CubicBez::from_points([a, a + da / 3.0, b - db / 3.0, b])
    }

    /// The general-degree view of this curve.
    #[inline]
    pub fn to_bezier(&self) -> Bezier<4> {
        Bezier::new(self.points())
    }

    /// Degree elevation to an exact quartic.
    pub fn elevate(&self) -> Bezier<5> {
        self.to_bezier().elevate()
    }

    /// De Casteljau evaluation (the repeated-interpolation form; [`ParamCurve::eval`] uses the
    /// cheaper Bernstein form).
    pub fn eval_de_casteljau(&self, t: f64) -> Point {
        let mut s = self.points();
        bernstein::eval_de_casteljau(&self.points(), t, &mut s)
    }

    /// `true` when every coordinate is finite.
    pub fn is_finite(&self) -> bool {
        self.points().iter().all(|p| p.is_finite())
    }

    /// Power-basis coefficients of the hodograph, `B'(t) = a t^2 + b t + c`, as `[a, b, c]`.
    #[inline]
    fn hodograph_power(&self) -> [Vec2; 3] {
        let d0 = self.p1 - self.p0;
        let d1 = self.p2 - self.p1;
        let d2 = self.p3 - self.p2;
        [3.0 * (d0 - 2.0 * d1 + d2), 6.0 * (d1 - d0), 3.0 * d0]
    }

    /// Arc lengths of many cubics at `accuracy`: `out[i]` is the `i`-th curve's
    /// [`arclen`](ParamCurveArclen::arclen), bit for bit, and faster than that loop on long
    /// batches (one thread): curves whose rule needs the roots of the hodograph (see
    /// [`ParamCurveArclen::arclen`] for the method) wait in groups of four whose roots are
    /// computed side by side. `curves` is any exact-size iterator (`slice.iter().copied()`, or
    /// control points mapped to cubics as they are read); errors when `out` is not as long.
    pub fn arclen_batch<I>(curves: I, accuracy: f64, out: &mut [f64]) -> Result<()>
    where
        I: IntoIterator<Item = CubicBez>,
        I::IntoIter: ExactSizeIterator,
    {
        let curves = curves.into_iter();
        if out.len() != curves.len() {
            return Err(Error::LengthMismatch {
                field: "out",
                got: out.len(),
                expected: curves.len(),
            });
        }
        arclen_unit_batch(curves.map(|c| c.hodograph_power()), accuracy, out, &singularities);
        Ok(())
    }

    /// Precomputes the arc-length engine (hodograph coefficients and roots) for repeated
    /// queries on this segment; [`CubicArclen`] answers `arclen_range`, `inv_arclen` and
    /// resampling without recomputing them.
    pub fn arclen_engine(&self) -> CubicArclen {
        CubicArclen::new(self)
    }
}

/// `(lead, roots, how many)` of the hodograph `q`, as [`arclen_quadratic_hodograph`] takes them.
#[inline]
fn singularities(q: &[Vec2; 3]) -> (f64, [Complex; 2], usize) {
    let e = CubicArclen::from_hodograph(*q);
    (e.lead, e.roots, e.n_roots)
}

/// Arc-length engine for one cubic: the hodograph in power form and the roots of
/// `z(t) = x'(t) + i y'(t)`. Created by [`CubicBez::arclen_engine`]; no allocation.
#[derive(Clone, Copy, Debug)]
pub struct CubicArclen {
    q: [Vec2; 3],
    lead: f64,
    roots: [Complex; 2],
    n_roots: usize,
}

impl CubicArclen {
    /// Engine for `c`.
    #[inline]
    pub fn new(c: &CubicBez) -> CubicArclen {
        CubicArclen::from_hodograph(c.hodograph_power())
    }

    /// Engine for the hodograph `q` (power basis, see [`CubicBez::hodograph_power`]).
    #[inline]
    fn from_hodograph(q: [Vec2; 3]) -> CubicArclen {
        let z = |v: Vec2| Complex::new(v.x, v.y);
        let (roots, n_roots) = complex_quadratic_roots(z(q[0]), z(q[1]), z(q[2]));
        let lead = match n_roots {
            2 => q[0].hypot(),
            1 => q[1].hypot(),
            _ => q[2].hypot(),
        };
        CubicArclen {
            q,
            lead,
            roots,
            n_roots,
        }
    }

    /// `|B'(t)|`.
    #[inline(always)]
    pub fn speed(&self, t: f64) -> f64 {
        let [a, b, c] = self.q;
        let x = (a.x * t + b.x) * t + c.x;
        let y = (a.y * t + b.y) * t + c.y;
        (x * x + y * y).sqrt()
    }

    /// Length between `t0` and `t1` (negative when `t1 < t0`) with absolute error at most `accuracy`.
    #[inline]
    pub fn arclen_range(&self, t0: f64, t1: f64, accuracy: f64) -> f64 {
        let (lo, hi, sign) = if t1 >= t0 { (t0, t1, 1.0) } else { (t1, t0, -1.0) };
        let roots = || (self.lead, self.roots, self.n_roots);
        sign * arclen_quadratic_hodograph(&self.q, roots, lo, hi, accuracy)
    }

    /// See [`ParamCurveArclen::inv_arclen`]; `total` is the curve's length if known (else pass
    /// `None` and it is computed).
    pub fn inv_arclen(&self, s: f64, total: Option<f64>, accuracy: f64) -> f64 {
        let acc = crate::accuracy::sanitize_accuracy(accuracy);
        let total = total.unwrap_or_else(|| self.arclen_range(0.0, 1.0, 0.25 * acc));
        quadrature::inv_arclen_with(
            |t| self.speed_and_rate(t),
            |a, b, e| self.arclen_range(a, b, e),
            s,
            total,
            acc,
        )
    }

    /// `|B'(t)|` and its derivative `B'(t) . B''(t) / |B'(t)|` (zero where the speed vanishes).
    #[inline(always)]
    pub(crate) fn speed_and_rate(&self, t: f64) -> (f64, f64) {
        let [a, b, c] = self.q;
        let (x, y) = ((a.x * t + b.x) * t + c.x, (a.y * t + b.y) * t + c.y);
        let (dx, dy) = (2.0 * a.x * t + b.x, 2.0 * a.y * t + b.y);
        let v = (x * x + y * y).sqrt();
        let rate = if v > 0.0 { (x * dx + y * dy) / v } else { 0.0 };
        (v, rate)
    }
}

impl From<CubicBez> for Bezier<4> {
    fn from(c: CubicBez) -> Bezier<4> {
        c.to_bezier()
    }
}

impl From<Bezier<4>> for CubicBez {
    fn from(b: Bezier<4>) -> CubicBez {
        CubicBez::from_points(b.points)
    }
}

impl ParamCurve for CubicBez {
    #[inline]
    fn eval(&self, t: f64) -> Point {
        let mt = 1.0 - t;
        let (a, b, c, d) = (mt * mt * mt, 3.0 * mt * mt * t, 3.0 * mt * t * t, t * t * t);
        Point::new(
            a * self.p0.x + b * self.p1.x + c * self.p2.x + d * self.p3.x,
            a * self.p0.y + b * self.p1.y + c * self.p2.y + d * self.p3.y,
        )
    }

    fn subsegment(&self, t0: f64, t1: f64) -> CubicBez {
        let mut out = self.points();
        bernstein::subsegment(&self.points(), t0, t1, &mut out);
        CubicBez::from_points(out)
    }

    #[inline]
    fn start(&self) -> Point {
        self.p0
    }

    #[inline]
    fn end(&self) -> Point {
        self.p3
    }

    fn subdivide(&self, t: f64) -> (CubicBez, CubicBez) {
        let mut l = self.points();
        let mut r = l;
        bernstein::split(&self.points(), t, &mut l, &mut r);
        (CubicBez::from_points(l), CubicBez::from_points(r))
    }
}

impl ParamCurveDeriv for CubicBez {
    type DerivResult = QuadBez;

    fn deriv(&self) -> QuadBez {
        let d = |a: Point, b: Point| (3.0 * (b - a)).to_point();
        QuadBez::new(d(self.p0, self.p1), d(self.p1, self.p2), d(self.p2, self.p3))
    }

    #[inline]
    fn velocity(&self, t: f64) -> Vec2 {
        let [a, b, c] = self.hodograph_power();
        (a * t + b) * t + c
    }

    #[inline]
    fn acceleration(&self, t: f64) -> Vec2 {
        let [a, b, _] = self.hodograph_power();
        2.0 * a * t + b
    }

    #[inline]
    fn jerk(&self, _t: f64) -> Vec2 {
        2.0 * self.hodograph_power()[0]
    }
}

impl ParamCurveCurvature for CubicBez {}

impl ParamCurveArclen for CubicBez {
    #[inline]
    fn speed(&self, t: f64) -> f64 {
        self.velocity(t).hypot()
    }

    #[inline]
    fn arclen_range(&self, t0: f64, t1: f64, accuracy: f64) -> f64 {
        // The roots are computed only when the root-free bound cannot pick a rule.
        let q = self.hodograph_power();
        let (lo, hi, sign) = if t1 >= t0 { (t0, t1, 1.0) } else { (t1, t0, -1.0) };
        sign * arclen_quadratic_hodograph(&q, || singularities(&q), lo, hi, accuracy)
    }

    fn inv_arclen(&self, s: f64, accuracy: f64) -> f64 {
        CubicArclen::new(self).inv_arclen(s, None, accuracy)
    }

    fn resample_uniform(&self, n: usize, accuracy: f64) -> Vec<f64> {
        let e = CubicArclen::new(self);
        let acc = crate::accuracy::sanitize_accuracy(accuracy);
        let total = if n < 2 {
            0.0
        } else {
            e.arclen_range(0.0, 1.0, 0.25 * acc)
        };
        quadrature::resample_with(
            |t| e.speed_and_rate(t),
            |a, b, x| e.arclen_range(a, b, x),
            n,
            total,
            acc,
        )
    }
}

impl ParamCurveExtrema for CubicBez {
    fn extrema(&self) -> Vec<f64> {
        let mut out = Vec::with_capacity(4);
        let [a, b, c] = self.hodograph_power();
        let mut tmp = Vec::with_capacity(2);
        for (ca, cb, cc) in [(a.x, b.x, c.x), (a.y, b.y, c.y)] {
            tmp.clear();
            bernstein::real_roots_unit(&[cc, cb, ca], &mut tmp);
            out.extend_from_slice(&tmp);
        }
        out.sort_by(f64::total_cmp);
        out.dedup();
        out
    }

    fn bounding_box(&self) -> Rect {
        // Without allocating: at most two roots per coordinate.
        let mut r = Rect::from_point(self.p0).union_pt(self.p3);
        let [a, b, c] = self.hodograph_power();
        let mut tmp = Vec::new();
        for (ca, cb, cc) in [(a.x, b.x, c.x), (a.y, b.y, c.y)] {
            tmp.clear();
            bernstein::real_roots_unit(&[cc, cb, ca], &mut tmp);
            for &t in &tmp {
                r = r.union_pt(self.eval(t));
            }
        }
        r
    }
}
