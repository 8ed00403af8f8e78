//! Plain 2D geometry values: [`Point`], [`Vec2`] and the axis-aligned [`Rect`].
//!
//! ```
//! use bezier::{Point, Vec2};
//! let p = Point::new(1.0, 2.0) + Vec2::new(0.5, -1.0);
//! assert_eq!(p, Point::new(1.5, 1.0));
//! assert_eq!((p - Point::ORIGIN).hypot(), (1.5f64 * 1.5 + 1.0).sqrt());
//! ```

use core::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A position in the plane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Point {
    /// Abscissa.
    pub x: f64,
    /// Ordinate.
    pub y: f64,
}

/// A displacement in the plane (a difference of two points, a velocity, ...).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec2 {
    /// First component.
    pub x: f64,
    /// Second component.
    pub y: f64,
}

/// An axis-aligned rectangle `[x0, x1] x [y0, y1]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rect {
    /// Smallest abscissa.
    pub x0: f64,
    /// Smallest ordinate.
    pub y0: f64,
    /// Largest abscissa.
    pub x1: f64,
    /// Largest ordinate.
    pub y1: f64,
}

impl Point {
    /// The origin `(0, 0)`.
    pub const ORIGIN: Point = Point { x: 0.0, y: 0.0 };

    /// A point from its coordinates.
    #[inline]
    pub const fn new(x: f64, y: f64) -> Point {
        Point { x, y }
    }

    /// The vector from the origin to this point.
    #[inline]
    pub const fn to_vec2(self) -> Vec2 {
        Vec2 { x: self.x, y: self.y }
    }

    /// Linear interpolation `self + t (other - self)`.
    #[inline]
    pub fn lerp(self, other: Point, t: f64) -> Point {
        Point::new(self.x + t * (other.x - self.x), self.y + t * (other.y - self.y))
    }

    /// The midpoint of `self` and `other`.
    #[inline]
    pub fn midpoint(self, other: Point) -> Point {
        Point::new(0.5 * (self.x + other.x), 0.5 * (self.y + other.y))
    }

    /// Euclidean distance to `other`.
    #[inline]
    pub fn distance(self, other: Point) -> f64 {
        (self - other).hypot()
    }

    /// `true` when both coordinates are finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }

    /// The coordinates as an array `[x, y]`.
    #[inline]
    pub const fn to_array(self) -> [f64; 2] {
        [self.x, self.y]
    }
}

impl Vec2 {
    /// The zero vector.
    pub const ZERO: Vec2 = Vec2 { x: 0.0, y: 0.0 };

    /// A vector from its components.
    #[inline]
    pub const fn new(x: f64, y: f64) -> Vec2 {
        Vec2 { x, y }
    }

    /// The point at this offset from the origin.
    #[inline]
    pub const fn to_point(self) -> Point {
        Point { x: self.x, y: self.y }
    }

    /// Dot product.
    #[inline]
    pub fn dot(self, other: Vec2) -> f64 {
        self.x * other.x + self.y * other.y
    }

    /// The z-component of the 3D cross product, `self.x other.y - self.y other.x`.
    #[inline]
    pub fn cross(self, other: Vec2) -> f64 {
        self.x * other.y - self.y * other.x
    }

    /// Squared length.
    #[inline]
    pub fn hypot2(self) -> f64 {
        self.dot(self)
    }

    /// Length. Uses `sqrt(x^2 + y^2)` (fast; overflows only beyond about `1e154`).
    #[inline]
    pub fn hypot(self) -> f64 {
        self.hypot2().sqrt()
    }

    /// Angle from the positive x axis, in `(-pi, pi]` (`0` for the zero vector).
    #[inline]
    pub fn atan2(self) -> f64 {
        self.y.atan2(self.x)
    }

    /// The unit vector in this direction, or `None` for a zero or non-finite vector.
    #[inline]
    pub fn normalize(self) -> Option<Vec2> {
        let n = self.hypot();
        (n > 0.0 && n.is_finite()).then(|| self / n)
    }

    /// `true` when both components are finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }

    /// The components as an array `[x, y]`.
    #[inline]
    pub const fn to_array(self) -> [f64; 2] {
        [self.x, self.y]
    }
}

impl Rect {
    /// The degenerate rectangle holding only `p`.
    #[inline]
    pub fn from_point(p: Point) -> Rect {
        Rect {
            x0: p.x,
            y0: p.y,
            x1: p.x,
            y1: p.y,
        }
    }

    /// The smallest rectangle holding `self` and `p`.
    #[inline]
    pub fn union_pt(self, p: Point) -> Rect {
        Rect {
            x0: self.x0.min(p.x),
            y0: self.y0.min(p.y),
            x1: self.x1.max(p.x),
            y1: self.y1.max(p.y),
        }
    }

    /// The smallest rectangle holding both rectangles.
    #[inline]
    pub fn union(self, other: Rect) -> Rect {
        Rect {
            x0: self.x0.min(other.x0),
            y0: self.y0.min(other.y0),
            x1: self.x1.max(other.x1),
            y1: self.y1.max(other.y1),
        }
    }

    /// `x1 - x0`.
    #[inline]
    pub fn width(&self) -> f64 {
        self.x1 - self.x0
    }

    /// `y1 - y0`.
    #[inline]
    pub fn height(&self) -> f64 {
        self.y1 - self.y0
    }

    /// `true` when `p` lies in the rectangle grown by `tolerance` on every side.
    #[inline]
    pub fn contains_with_tolerance(&self, p: Point, tolerance: f64) -> bool {
        p.x >= self.x0 - tolerance
            && p.x <= self.x1 + tolerance
            && p.y >= self.y0 - tolerance
            && p.y <= self.y1 + tolerance
    }
}

impl From<(f64, f64)> for Point {
    #[inline]
    fn from((x, y): (f64, f64)) -> Point {
        Point::new(x, y)
    }
}

impl From<[f64; 2]> for Point {
    #[inline]
    fn from([x, y]: [f64; 2]) -> Point {
        Point::new(x, y)
    }
}

impl From<(f64, f64)> for Vec2 {
    #[inline]
    fn from((x, y): (f64, f64)) -> Vec2 {
        Vec2::new(x, y)
    }
}

impl Sub for Point {
    type Output = Vec2;
    #[inline]
    fn sub(self, rhs: Point) -> Vec2 {
        Vec2::new(self.x - rhs.x, self.y - rhs.y)
    }
}

impl Add<Vec2> for Point {
    type Output = Point;
    #[inline]
    fn add(self, rhs: Vec2) -> Point {
        Point::new(self.x + rhs.x, self.y + rhs.y)
    }
}

impl Sub<Vec2> for Point {
    type Output = Point;
    #[inline]
    fn sub(self, rhs: Vec2) -> Point {
        Point::new(self.x - rhs.x, self.y - rhs.y)
    }
}

impl AddAssign<Vec2> for Point {
    #[inline]
    fn add_assign(&mut self, rhs: Vec2) {
        self.x += rhs.x;
        self.y += rhs.y;
    }
}

impl SubAssign<Vec2> for Point {
    #[inline]
    fn sub_assign(&mut self, rhs: Vec2) {
        self.x -= rhs.x;
        self.y -= rhs.y;
    }
}

impl Add for Vec2 {
    type Output = Vec2;
    #[inline]
    fn add(self, rhs: Vec2) -> Vec2 {
        Vec2::new(self.x + rhs.x, self.y + rhs.y)
    }
}

impl Sub for Vec2 {
    type Output = Vec2;
    #[inline]
    fn sub(self, rhs: Vec2) -> Vec2 {
        Vec2::new(self.x - rhs.x, self.y - rhs.y)
    }
}

impl AddAssign for Vec2 {
    #[inline]
    fn add_assign(&mut self, rhs: Vec2) {
        self.x += rhs.x;
        self.y += rhs.y;
    }
}

impl SubAssign for Vec2 {
    #[inline]
    fn sub_assign(&mut self, rhs: Vec2) {
        self.x -= rhs.x;
        self.y -= rhs.y;
    }
}

impl Mul<f64> for Vec2 {
    type Output = Vec2;
    #[inline]
    fn mul(self, rhs: f64) -> Vec2 {
        Vec2::new(self.x * rhs, self.y * rhs)
    }
}

impl Mul<Vec2> for f64 {
    type Output = Vec2;
    #[inline]
    fn mul(self, rhs: Vec2) -> Vec2 {
        Vec2::new(self * rhs.x, self * rhs.y)
    }
}

impl MulAssign<f64> for Vec2 {
    #[inline]
    fn mul_assign(&mut self, rhs: f64) {
        self.x *= rhs;
        self.y *= rhs;
    }
}

impl Div<f64> for Vec2 {
    type Output = Vec2;
    #[inline]
    fn div(self, rhs: f64) -> Vec2 {
        Vec2::new(self.x / rhs, self.y / rhs)
    }
}

impl Neg for Vec2 {
    type Output = Vec2;
    #[inline]
    fn neg(self) -> Vec2 {
        Vec2::new(-self.x, -self.y)
    }
}
