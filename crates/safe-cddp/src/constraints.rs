//! Built-in constraints.
//!
//! | constraint | rows `g <= 0` | kind | paper |
//! |---|---|---|---|
//! | [`Circle`] (squared form) | `r^2 - |p - c|^2` | state | Xie et al. 2017; benchmark P2/P3 |
//! | [`Circle`] (distance form) | `r - |p - c|` | state | the geometric margin of eq. (20) in metres |
//! | [`MovingCircle`] | as [`Circle`] with a predicted centre `c_t` and its covariance | state | dynamic obstacles (Kalman tracker) |
//! | [`ConvexPolygon`] | `margin - sd(p)` with parry's signed distance `sd` | state | polygonal obstacles |
//! | [`Cylinder`] | `min(r - |p_xy - c|, h - z)`, rim smoothed | state | a vertical cylinder of height `h` for a 3-D robot (Table I's quadrotor) |
//! | [`StateBox`] | `x_i - hi_i`, `lo_i - x_i` | state | state limits |
//! | [`ControlBox`] | `u_i - hi_i`, `lo_i - u_i` | mixed | input limits (tightened, unlike [`ddp_core::ControlBounds`]) |
//! | [`FiniteDiffConstraint`] | any `g(t, x, u)` | either | user constraints without hand-written Jacobians |
//!
//! `p = (x[i0], x[i1])` is the planar position picked by `indices`; for a 3-D robot an infinitely
//! tall cylinder is a [`Circle`] on `(px, py)`, one it can fly over a [`Cylinder`].
//!
//! ```
//! use safe_cddp::constraints::Circle;
//! use safe_cddp::Constraint;
//! use ddp_core::Vector;
//! use ddp_core::dims::{U2, U4};
//! let c: Circle<U4> = Circle::squared([1.0, 0.0], 0.5, [0, 1]).unwrap();
//! let mut g = [0.0];
//! Constraint::<U4, U2>::evaluate(&c, 0, &Vector::<4>::zeros(), &Vector::<2>::zeros(), &mut g);
//! assert_eq!(g[0], 0.25 - 1.0); // outside: g < 0
//! ```

use ddp_core::error::check_finite;
use std::marker::PhantomData;

use ddp_core::dims::{Alloc, Const, DefaultAllocator, Dim, MatrixN, VectorN};
use ddp_core::{Error, Result, Vector};
use nalgebra::{Matrix2, Vector2};
use parry2d_f64::query::PointQuery;

use crate::Constraint;

/// Checks position indices against `nx` (`None`: a run-time size, checked when the solver is
/// built, see [`Constraint::check_sizes`]).
fn check_indices_in(indices: [usize; 2], nx: Option<usize>) -> Result<()> {
    for (i, &j) in indices.iter().enumerate() {
        if let Some(nx) = nx {
            if j >= nx {
                return Err(Error::invalid(
                    format!("indices[{i}]"),
                    format!("state index {j} out of range for a {nx}-dimensional state"),
                ));
            }
        }
    }
    if indices[0] == indices[1] {
        return Err(Error::invalid("indices", "the two position indices must differ"));
    }
    Ok(())
}

/// Checks three distinct position indices against `nx` (`None`: checked when the solver is built).
fn check_indices3(indices: [usize; 3], nx: Option<usize>) -> Result<()> {
    check_indices_in([indices[0], indices[1]], nx)?;
    check_indices_in([indices[0], indices[2]], nx)?;
    check_indices_in([indices[1], indices[2]], nx)
}

fn nonneg(field: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(Error::invalid(field, format!("must be finite and >= 0, got {v}")))
    }
}

/// How a circular obstacle is written as `g <= 0`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CircleForm {
    /// `r^2 - |p - c|^2` (Xie et al. 2017, and the benchmark problems): smooth everywhere.
    #[default]
    SquaredDistance,
    /// `r - |p - c|`: the tightening margin is then a distance in metres.
    Distance,
}

/// `g`, `dg/dp` and `d^2 g/dp^2` of a circle of radius `r` centred at `c`, at position `p`.
#[inline]
fn circle_terms(form: CircleForm, r: f64, p: Vector2<f64>, c: Vector2<f64>) -> (f64, Vector2<f64>, Matrix2<f64>) {
    let e = p - c;
    match form {
        CircleForm::SquaredDistance => (r * r - e.norm_squared(), -2.0 * e, -2.0 * Matrix2::identity()),
        CircleForm::Distance => {
            let d = e.norm();
            if d < 1e-12 {
                // The centre: any direction is a subgradient; zero keeps the row inert.
                return (r - d, Vector2::zeros(), Matrix2::zeros());
            }
            let n = e / d;
            (r - d, -n, -(Matrix2::identity() - n * n.transpose()) / d)
        }
    }
}

/// A circular obstacle (a vertical cylinder for a 3-D robot), as in Xie et al. 2017, for any
/// state size (`NX` compile-time or run-time).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle<NX: Dim> {
    center: [f64; 2],
    radius: f64,
    indices: [usize; 2],
    form: CircleForm,
    states: PhantomData<NX>,
}

impl<NX: Dim> Circle<NX> {
    /// A circle of `radius` at `center` on the position `(x[indices[0]], x[indices[1]])`, in the
    /// given form. Errors name `center`, `radius` or `indices`.
    pub fn new(center: [f64; 2], radius: f64, indices: [usize; 2], form: CircleForm) -> Result<Self> {
        check_finite("center", center.iter())?;
        check_indices_in(indices, NX::try_to_usize())?;
        Ok(Self {
            center,
            radius: nonneg("radius", radius)?,
            indices,
            form,
            states: PhantomData,
        })
    }
    /// The squared-distance form `r^2 - |p - c|^2 <= 0`.
    pub fn squared(center: [f64; 2], radius: f64, indices: [usize; 2]) -> Result<Self> {
        Self::new(center, radius, indices, CircleForm::SquaredDistance)
    }
    /// The distance form `r - |p - c| <= 0`.
    pub fn distance(center: [f64; 2], radius: f64, indices: [usize; 2]) -> Result<Self> {
        Self::new(center, radius, indices, CircleForm::Distance)
    }
    /// The centre.
    pub fn center(&self) -> [f64; 2] {
        self.center
    }
    /// The radius.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// The state indices of the position.
    pub fn indices(&self) -> [usize; 2] {
        self.indices
    }
    fn terms(&self, x: &VectorN<NX>) -> (f64, Vector2<f64>, Matrix2<f64>)
    where
        DefaultAllocator: Alloc<NX, NX>,
    {
        let [i, j] = self.indices;
        circle_terms(
            self.form,
            self.radius,
            Vector2::new(x[i], x[j]),
            Vector2::new(self.center[0], self.center[1]),
        )
    }
}

impl<NX: Dim, NU: Dim> Constraint<NX, NU> for Circle<NX>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn dim(&self) -> usize {
        1
    }
    fn depends_on_control(&self) -> bool {
        false
    }
    fn evaluate(&self, _t: usize, x: &VectorN<NX>, _u: &VectorN<NU>, g: &mut [f64]) {
        g[0] = self.terms(x).0;
    }
    fn evaluate_along(&self, _t0: usize, xs: &[VectorN<NX>], _us: &[VectorN<NU>], g: &mut [f64], stride: usize) {
        for (i, x) in xs.iter().enumerate() {
            g[i * stride] = self.terms(x).0;
        }
    }
    fn jacobians(
        &self,
        _t: usize,
        x: &VectorN<NX>,
        _u: &VectorN<NU>,
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
    ) {
        let (v, gp, _) = self.terms(x);
        g[0] = v;
        g_x[0].fill(0.0);
        g_x[0][self.indices[0]] = gp[0];
        g_x[0][self.indices[1]] = gp[1];
        g_u[0].fill(0.0);
    }
    fn jacobians_along(
        &self,
        _t0: usize,
        xs: &[VectorN<NX>],
        _us: &[VectorN<NU>],
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
        stride: usize,
    ) {
        for (i, x) in xs.iter().enumerate() {
            let (v, gp, _) = self.terms(x);
            let r = i * stride;
            g[r] = v;
            g_x[r].fill(0.0);
            g_x[r][self.indices[0]] = gp[0];
            g_x[r][self.indices[1]] = gp[1];
            g_u[r].fill(0.0);
        }
    }
    fn add_hessian(&self, _t: usize, x: &VectorN<NX>, _u: &VectorN<NU>, w: &[f64], h_xx: &mut MatrixN<NX, NX>) {
        let (_, _, h) = self.terms(x);
        add_planar_block(h_xx, self.indices, &(w[0] * h));
    }
    fn planar_disc(&self) -> Option<crate::plan::PlanarDisc> {
        Some(crate::plan::PlanarDisc {
            indices: self.indices,
            disc: crate::plan::Disc {
                center: self.center,
                radius: self.radius,
            },
        })
    }
    fn check_sizes(&self, nx: usize, _nu: usize) -> Result<()> {
        check_indices_in(self.indices, Some(nx))
    }
}

fn add_planar_block<NX: Dim>(h_xx: &mut MatrixN<NX, NX>, idx: [usize; 2], h: &Matrix2<f64>)
where
    DefaultAllocator: Alloc<NX, NX>,
{
    for a in 0..2 {
        for b in 0..2 {
            h_xx[(idx[a], idx[b])] += h[(a, b)];
        }
    }
}

/// A circular obstacle whose centre moves: predicted centres `c_t` with position covariances
/// `Sigma_t` for `t = 0, 1, ...` (the last one is held beyond the table). Built from a
/// [`crate::kalman::ObstacleTracker`] prediction; its [`Constraint::parameter_variance`] is
/// `grad_c g^T Sigma_t grad_c g`, so the tightening of eq. (20) adds the obstacle's uncertainty
/// to the robot's and the margin grows along the horizon.
#[derive(Debug, Clone, PartialEq)]
pub struct MovingCircle<NX: Dim> {
    centers: Vec<[f64; 2]>,
    covariances: Vec<Matrix2<f64>>,
    radius: f64,
    indices: [usize; 2],
    form: CircleForm,
    states: PhantomData<NX>,
}

impl<NX: Dim> MovingCircle<NX> {
    /// `centers[t]` and `covariances[t]` (symmetric PSD 2x2, in the position coordinates) for
    /// `t = 0 .. T`; errors name the field and index.
    pub fn new(
        centers: Vec<[f64; 2]>,
        covariances: Vec<Matrix2<f64>>,
        radius: f64,
        indices: [usize; 2],
        form: CircleForm,
    ) -> Result<Self> {
        if centers.is_empty() {
            return Err(Error::invalid("centers", "needs at least one predicted centre"));
        }
        if covariances.len() != centers.len() {
            return Err(Error::Shape {
                field: "covariances".into(),
                got: format!("({}, 2, 2)", covariances.len()),
                expected: format!("({}, 2, 2)", centers.len()),
            });
        }
        for (t, c) in centers.iter().enumerate() {
            check_finite(&format!("centers[{t}]"), c.iter())?;
        }
        for (t, s) in covariances.iter().enumerate() {
            check_finite(&format!("covariances[{t}]"), s.iter())?;
            if (s[(0, 1)] - s[(1, 0)]).abs() > 1e-9 * s.amax().max(1.0) || s[(0, 0)] < 0.0 || s.determinant() < -1e-15 {
                return Err(Error::NotPsd {
                    field: format!("covariances[{t}]"),
                    reason: "must be symmetric positive semidefinite".into(),
                });
            }
        }
        check_indices_in(indices, NX::try_to_usize())?;
        Ok(Self {
            centers,
            covariances,
            radius: nonneg("radius", radius)?,
            indices,
            form,
            states: PhantomData,
        })
    }
    /// The predicted centre at time `t` (the last one beyond the table).
    pub fn center(&self, t: usize) -> [f64; 2] {
        self.centers[t.min(self.centers.len() - 1)]
    }
    /// The predicted position covariance at time `t`.
    pub fn covariance(&self, t: usize) -> Matrix2<f64> {
        self.covariances[t.min(self.covariances.len() - 1)]
    }
    /// The radius.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    fn terms(&self, t: usize, x: &VectorN<NX>) -> (f64, Vector2<f64>, Matrix2<f64>)
    where
        DefaultAllocator: Alloc<NX, NX>,
    {
        let [i, j] = self.indices;
        let c = self.center(t);
        circle_terms(
            self.form,
            self.radius,
            Vector2::new(x[i], x[j]),
            Vector2::new(c[0], c[1]),
        )
    }
}

impl<NX: Dim, NU: Dim> Constraint<NX, NU> for MovingCircle<NX>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn dim(&self) -> usize {
        1
    }
    fn depends_on_control(&self) -> bool {
        false
    }
    fn evaluate(&self, t: usize, x: &VectorN<NX>, _u: &VectorN<NU>, g: &mut [f64]) {
        g[0] = self.terms(t, x).0;
    }
    fn jacobians(
        &self,
        t: usize,
        x: &VectorN<NX>,
        _u: &VectorN<NU>,
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
    ) {
        let (v, gp, _) = self.terms(t, x);
        g[0] = v;
        g_x[0].fill(0.0);
        g_x[0][self.indices[0]] = gp[0];
        g_x[0][self.indices[1]] = gp[1];
        g_u[0].fill(0.0);
    }
    fn add_hessian(&self, t: usize, x: &VectorN<NX>, _u: &VectorN<NU>, w: &[f64], h_xx: &mut MatrixN<NX, NX>) {
        let (_, _, h) = self.terms(t, x);
        add_planar_block(h_xx, self.indices, &(w[0] * h));
    }
    fn parameter_variance(&self, t: usize, x: &VectorN<NX>, _u: &VectorN<NU>, var: &mut [f64]) {
        // g depends on p - c, so grad_c g = -grad_p g and the variance is the same quadratic form.
        let (_, gp, _) = self.terms(t, x);
        var[0] = gp.dot(&(self.covariance(t) * gp)).max(0.0);
    }
    fn check_sizes(&self, nx: usize, _nu: usize) -> Result<()> {
        check_indices_in(self.indices, Some(nx))
    }
}

/// A convex polygonal obstacle: `g = margin - sd(p) <= 0`, where `sd` is the signed distance from
/// the position to the polygon (positive outside), computed by parry (`parry2d-f64`, the f64 build
/// of parry2d). The gradient is the unit vector between the position and its closest boundary
/// point (pointing out of the polygon), and on the boundary the normal of the closest feature.
#[derive(Debug, Clone)]
pub struct ConvexPolygon<NX: Dim> {
    shape: parry2d_f64::shape::ConvexPolygon,
    margin: f64,
    indices: [usize; 2],
    states: PhantomData<NX>,
}

impl<NX: Dim> ConvexPolygon<NX> {
    /// The convex hull of `vertices` (at least three, not collinear), inflated by `margin >= 0`.
    /// Allocates the polygon.
    pub fn new(vertices: &[[f64; 2]], margin: f64, indices: [usize; 2]) -> Result<Self> {
        for (k, v) in vertices.iter().enumerate() {
            check_finite(&format!("vertices[{k}]"), v.iter())?;
        }
        if vertices.len() < 3 {
            return Err(Error::invalid(
                "vertices",
                format!("a polygon needs at least 3 vertices, got {}", vertices.len()),
            ));
        }
        let pts: Vec<parry2d_f64::math::Vector> = vertices
            .iter()
            .map(|v| parry2d_f64::math::Vector::new(v[0], v[1]))
            .collect();
        let shape = parry2d_f64::shape::ConvexPolygon::from_convex_hull(&pts)
            .ok_or_else(|| Error::invalid("vertices", "degenerate polygon (collinear or repeated vertices)"))?;
        check_indices_in(indices, NX::try_to_usize())?;
        Ok(Self {
            shape,
            margin: nonneg("margin", margin)?,
            indices,
            states: PhantomData,
        })
    }

    /// The polygon's vertices (counter-clockwise).
    pub fn vertices(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.shape.points().iter().map(|p| [p.x, p.y])
    }

    /// Signed distance from `p` to the polygon (negative inside) and its gradient.
    pub fn signed_distance(&self, p: [f64; 2]) -> (f64, [f64; 2]) {
        let pt = parry2d_f64::math::Vector::new(p[0], p[1]);
        let (proj, feature) = self.shape.project_local_point_and_get_feature(pt);
        let e = pt - proj.point;
        let d = e.length();
        let sign = if proj.is_inside { -1.0 } else { 1.0 };
        if d > 1e-12 {
            // Outside, e points away from the polygon; inside, towards its interior, so flip it.
            let n = e * (sign / d);
            (sign * d, [n.x, n.y])
        } else {
            let n = self
                .shape
                .feature_normal(feature)
                .unwrap_or(parry2d_f64::math::Vector::new(0.0, 0.0));
            (0.0, [n.x, n.y])
        }
    }
}

impl<NX: Dim, NU: Dim> Constraint<NX, NU> for ConvexPolygon<NX>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn dim(&self) -> usize {
        1
    }
    fn depends_on_control(&self) -> bool {
        false
    }
    fn evaluate(&self, _t: usize, x: &VectorN<NX>, _u: &VectorN<NU>, g: &mut [f64]) {
        let [i, j] = self.indices;
        g[0] = self.margin - self.signed_distance([x[i], x[j]]).0;
    }
    fn jacobians(
        &self,
        _t: usize,
        x: &VectorN<NX>,
        _u: &VectorN<NU>,
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
    ) {
        let [i, j] = self.indices;
        let (sd, n) = self.signed_distance([x[i], x[j]]);
        g[0] = self.margin - sd;
        g_x[0].fill(0.0);
        g_x[0][i] = -n[0];
        g_x[0][j] = -n[1];
        g_u[0].fill(0.0);
    }
    fn check_sizes(&self, nx: usize, _nu: usize) -> Result<()> {
        check_indices_in(self.indices, Some(nx))
    }
}

/// A vertical cylinder standing on the ground, of radius `r` around `(cx, cy)` and height `h`:
/// the robot collides when `|p_xy - c| < r` **and** `z < h`, i.e. when `min(a, b) > 0` with
/// `a = r - |p_xy - c|` (distance to the side) and `b = h - z` (distance to the top). That minimum
/// has a kink on the rim (`a = b`), so the row is its C1 smooth minimum with band `w`:
///
/// ```text
/// g = min(a, b) - w/4 s^2,   s = max(0, w - |a - b|) / w
/// ```
///
/// which is exact wherever `|a - b| >= w` (beside the cylinder, above its top) and lower than
/// `min(a, b)` by at most `w/4` on the rim itself. A robot can pass beside it or over it (Table I's
/// quadrotor hovers above one); [`Cylinder::contains`] is the exact test.
///
/// ```
/// use safe_cddp::constraints::Cylinder;
/// use safe_cddp::Constraint;
/// use ddp_core::Vector;
/// let c = Cylinder::new([0.0, 0.0], 0.5, 1.0, 0.02, [0, 1, 2]).unwrap();
/// let mut g = [0.0];
/// let mut x = Vector::<12>::zeros();
/// x[0] = 0.3; // 0.2 m inside the side ...
/// x[2] = 0.5; // ... and 0.5 m below the top: g = min(0.2, 0.5)
/// Constraint::<ddp_core::dims::U12, ddp_core::dims::U4>::evaluate(&c, 0, &x, &Vector::zeros(), &mut g);
/// assert!((g[0] - 0.2).abs() < 1e-12);
/// x[2] = 1.2; // 0.2 m above the top: outside
/// Constraint::<ddp_core::dims::U12, ddp_core::dims::U4>::evaluate(&c, 0, &x, &Vector::zeros(), &mut g);
/// assert!((g[0] + 0.2).abs() < 1e-12);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder<NX: Dim> {
    center: [f64; 2],
    radius: f64,
    height: f64,
    band: f64,
    indices: [usize; 3],
    states: PhantomData<NX>,
}

impl<NX: Dim> Cylinder<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// A cylinder of `radius` and `height` at `center` on the position
    /// `(x[indices[0]], x[indices[1]], x[indices[2]])` (z up), its rim smoothed over a band
    /// `band > 0` (m, e.g. 0.02). Errors name the field.
    pub fn new(center: [f64; 2], radius: f64, height: f64, band: f64, indices: [usize; 3]) -> Result<Self> {
        check_finite("center", center.iter())?;
        check_finite("height", [height].iter())?;
        check_indices3(indices, NX::try_to_usize())?;
        if !(band.is_finite() && band > 0.0) {
            return Err(Error::invalid("band", format!("must be finite and > 0, got {band}")));
        }
        Ok(Self {
            center,
            radius: nonneg("radius", radius)?,
            height,
            band,
            indices,
            states: PhantomData,
        })
    }
    /// The centre of the base.
    pub fn center(&self) -> [f64; 2] {
        self.center
    }
    /// The radius.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// The height of the top.
    pub fn height(&self) -> f64 {
        self.height
    }
    /// Whether the point `x` is inside the (unsmoothed) cylinder.
    pub fn contains(&self, x: &VectorN<NX>) -> bool {
        let [i, j, k] = self.indices;
        (x[i] - self.center[0]).hypot(x[j] - self.center[1]) < self.radius && x[k] < self.height
    }
    /// `g`, `dg/d(px, py, pz)`.
    fn terms(&self, x: &VectorN<NX>) -> (f64, [f64; 3]) {
        let [i, j, k] = self.indices;
        let (ex, ey) = (x[i] - self.center[0], x[j] - self.center[1]);
        let d = ex.hypot(ey);
        let a = self.radius - d;
        let b = self.height - x[k];
        let w = self.band;
        let s = (w - (a - b).abs()).max(0.0) / w;
        // Gradient of min(a, b) - w/4 s^2 in (a, b): (1 - s/2, s/2) when a < b (1 and 0 outside
        // the band, 1/2 each on the rim), mirrored otherwise.
        let (ga, gb) = if a < b {
            (1.0 - 0.5 * s, 0.5 * s)
        } else {
            (0.5 * s, 1.0 - 0.5 * s)
        };
        let g = a.min(b) - 0.25 * w * s * s;
        let (nx, ny) = if d > 1e-12 { (ex / d, ey / d) } else { (0.0, 0.0) };
        (g, [-ga * nx, -ga * ny, -gb])
    }
}

impl<NX: Dim, NU: Dim> Constraint<NX, NU> for Cylinder<NX>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn dim(&self) -> usize {
        1
    }
    fn depends_on_control(&self) -> bool {
        false
    }
    fn evaluate(&self, _t: usize, x: &VectorN<NX>, _u: &VectorN<NU>, g: &mut [f64]) {
        g[0] = self.terms(x).0;
    }
    fn jacobians(
        &self,
        _t: usize,
        x: &VectorN<NX>,
        _u: &VectorN<NU>,
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
    ) {
        let (v, d) = self.terms(x);
        g[0] = v;
        g_x[0].fill(0.0);
        for (c, &i) in self.indices.iter().enumerate() {
            g_x[0][i] = d[c];
        }
        g_u[0].fill(0.0);
    }
    fn check_sizes(&self, nx: usize, _nu: usize) -> Result<()> {
        check_indices3(self.indices, Some(nx))
    }
}

/// A box built for `len` entries must fit a state or control of `n`.
fn check_box_len(field: &str, len: usize, n: usize) -> Result<()> {
    if len != n {
        return Err(Error::Shape {
            field: field.into(),
            got: format!("({len},)"),
            expected: format!("({n},)"),
        });
    }
    Ok(())
}

/// One row of a box: `sign * (z[index] - bound) <= 0` (sign `+1` for an upper bound).
#[derive(Debug, Clone, Copy, PartialEq)]
struct BoxRow {
    index: usize,
    sign: f64,
    bound: f64,
}

fn box_rows<N: Dim>(lower: &VectorN<N>, upper: &VectorN<N>, lo: &str, hi: &str) -> Result<Vec<BoxRow>>
where
    DefaultAllocator: Alloc<N, N>,
{
    if lower.len() != upper.len() {
        return Err(Error::Shape {
            field: hi.into(),
            got: format!("({},)", upper.len()),
            expected: format!("({},) like {lo}", lower.len()),
        });
    }
    let mut rows = Vec::new();
    for i in 0..lower.len() {
        if lower[i].is_nan() || lower[i] == f64::INFINITY {
            return Err(Error::NotFinite {
                field: lo.into(),
                index: i,
                value: lower[i],
            });
        }
        if upper[i].is_nan() || upper[i] == f64::NEG_INFINITY {
            return Err(Error::NotFinite {
                field: hi.into(),
                index: i,
                value: upper[i],
            });
        }
        if lower[i] > upper[i] {
            return Err(Error::invalid(
                format!("{lo}[{i}]"),
                format!("lower bound {} exceeds upper bound {hi}[{i}] = {}", lower[i], upper[i]),
            ));
        }
        if upper[i].is_finite() {
            rows.push(BoxRow {
                index: i,
                sign: 1.0,
                bound: upper[i],
            });
        }
        if lower[i].is_finite() {
            rows.push(BoxRow {
                index: i,
                sign: -1.0,
                bound: lower[i],
            });
        }
    }
    Ok(rows)
}

/// State limits `lower <= x <= upper` (infinite entries give no row): one row per finite bound.
#[derive(Debug, Clone, PartialEq)]
pub struct StateBox<NX: Dim> {
    rows: Vec<BoxRow>,
    len: usize,
    size: PhantomData<NX>,
}

impl<NX: Dim> StateBox<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// Errors name `x_min`/`x_max` and the index (NaN, `lower > upper`, lengths that differ).
    pub fn new(lower: VectorN<NX>, upper: VectorN<NX>) -> Result<Self> {
        Ok(Self {
            rows: box_rows(&lower, &upper, "x_min", "x_max")?,
            len: lower.len(),
            size: PhantomData,
        })
    }
}

impl<NX: Dim, NU: Dim> Constraint<NX, NU> for StateBox<NX>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn dim(&self) -> usize {
        self.rows.len()
    }
    fn depends_on_control(&self) -> bool {
        false
    }
    fn evaluate(&self, _t: usize, x: &VectorN<NX>, _u: &VectorN<NU>, g: &mut [f64]) {
        for (gi, r) in g.iter_mut().zip(&self.rows) {
            *gi = r.sign * (x[r.index] - r.bound);
        }
    }
    fn jacobians(
        &self,
        t: usize,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
    ) {
        Constraint::<NX, NU>::evaluate(self, t, x, u, g);
        for (i, r) in self.rows.iter().enumerate() {
            g_x[i].fill(0.0);
            g_x[i][r.index] = r.sign;
            g_u[i].fill(0.0);
        }
    }
    fn check_sizes(&self, nx: usize, _nu: usize) -> Result<()> {
        check_box_len("x_min", self.len, nx)
    }
}

/// Control limits `lower <= u <= upper` as constraints (one row per finite bound). Unlike
/// [`ddp_core::ControlBounds`] (hard actuator limits, never tightened), these rows are tightened
/// by the closed-loop control variance `g_u^T K Sigma_x K^T g_u`.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlBox<NU: Dim> {
    rows: Vec<BoxRow>,
    len: usize,
    size: PhantomData<NU>,
}

impl<NU: Dim> ControlBox<NU>
where
    DefaultAllocator: Alloc<NU, NU>,
{
    /// Errors name `u_min`/`u_max` and the index (NaN, `lower > upper`, lengths that differ).
    pub fn new(lower: VectorN<NU>, upper: VectorN<NU>) -> Result<Self> {
        Ok(Self {
            rows: box_rows(&lower, &upper, "u_min", "u_max")?,
            len: lower.len(),
            size: PhantomData,
        })
    }
}

impl<NX: Dim, NU: Dim> Constraint<NX, NU> for ControlBox<NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn dim(&self) -> usize {
        self.rows.len()
    }
    fn depends_on_control(&self) -> bool {
        true
    }
    fn evaluate(&self, _t: usize, _x: &VectorN<NX>, u: &VectorN<NU>, g: &mut [f64]) {
        for (gi, r) in g.iter_mut().zip(&self.rows) {
            *gi = r.sign * (u[r.index] - r.bound);
        }
    }
    fn jacobians(
        &self,
        t: usize,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
    ) {
        Constraint::<NX, NU>::evaluate(self, t, x, u, g);
        for (i, r) in self.rows.iter().enumerate() {
            g_x[i].fill(0.0);
            g_u[i].fill(0.0);
            g_u[i][r.index] = r.sign;
        }
    }
    fn check_sizes(&self, _nx: usize, nu: usize) -> Result<()> {
        check_box_len("u_min", self.len, nu)
    }
}

/// The most rows a [`FiniteDiffConstraint`] may have (its differences use stack buffers).
pub const MAX_FINITE_DIFF_ROWS: usize = 32;

/// A user constraint given only by its value `g(t, x, u)`; Jacobians by central differences with
/// step `eps^(1/3) (1 + |z|)`. Allocation-free (stack buffers of [`MAX_FINITE_DIFF_ROWS`]).
pub struct FiniteDiffConstraint<F> {
    f: F,
    dim: usize,
    mixed: bool,
}

impl<F> FiniteDiffConstraint<F> {
    /// `f(t, x, u, g)` writes `dim` rows; `depends_on_control` as [`Constraint::depends_on_control`].
    pub fn new(dim: usize, depends_on_control: bool, f: F) -> Result<Self> {
        if dim == 0 || dim > MAX_FINITE_DIFF_ROWS {
            return Err(Error::invalid(
                "dim",
                format!("must be in 1..={MAX_FINITE_DIFF_ROWS}, got {dim}"),
            ));
        }
        Ok(Self {
            f,
            dim,
            mixed: depends_on_control,
        })
    }
}

impl<const NX: usize, const NU: usize, F> Constraint<Const<NX>, Const<NU>> for FiniteDiffConstraint<F>
where
    F: Fn(usize, &Vector<NX>, &Vector<NU>, &mut [f64]) + Send + Sync,
{
    fn dim(&self) -> usize {
        self.dim
    }
    fn depends_on_control(&self) -> bool {
        self.mixed
    }
    fn evaluate(&self, t: usize, x: &Vector<NX>, u: &Vector<NU>, g: &mut [f64]) {
        (self.f)(t, x, u, &mut g[..self.dim]);
    }
    fn jacobians(
        &self,
        t: usize,
        x: &Vector<NX>,
        u: &Vector<NU>,
        g: &mut [f64],
        g_x: &mut [Vector<NX>],
        g_u: &mut [Vector<NU>],
    ) {
        let m = self.dim;
        (self.f)(t, x, u, &mut g[..m]);
        let h = f64::EPSILON.cbrt();
        let (mut gp, mut gm) = ([0.0; MAX_FINITE_DIFF_ROWS], [0.0; MAX_FINITE_DIFF_ROWS]);
        for j in 0..NX {
            let hj = h * (1.0 + x[j].abs());
            let (mut xp, mut xm) = (*x, *x);
            xp[j] += hj;
            xm[j] -= hj;
            (self.f)(t, &xp, u, &mut gp[..m]);
            (self.f)(t, &xm, u, &mut gm[..m]);
            for i in 0..m {
                g_x[i][j] = (gp[i] - gm[i]) / (2.0 * hj);
            }
        }
        for j in 0..NU {
            if !self.mixed {
                for i in 0..m {
                    g_u[i][j] = 0.0;
                }
                continue;
            }
            let hj = h * (1.0 + u[j].abs());
            let (mut up, mut um) = (*u, *u);
            up[j] += hj;
            um[j] -= hj;
            (self.f)(t, x, &up, &mut gp[..m]);
            (self.f)(t, x, &um, &mut gm[..m]);
            for i in 0..m {
                g_u[i][j] = (gp[i] - gm[i]) / (2.0 * hj);
            }
        }
    }
}
