//! Degree-independent Bézier kernels on slices of control points, shared by the fixed-degree
//! ([`Bezier`](crate::Bezier)) and dynamic-degree ([`BezierDyn`](crate::BezierDyn)) types, plus
//! real root finding for the exact bounding box.
//!
//! ```
//! use bezier::{bernstein, Point};
//! let p = [Point::new(0.0, 0.0), Point::new(1.0, 2.0), Point::new(2.0, 0.0)];
//! let a = bernstein::eval_bernstein(&p, 0.25);
//! let mut scratch = p;
//! let b = bernstein::eval_de_casteljau(&p, 0.25, &mut scratch);
//! assert!((a - b).hypot() < 1e-15);
//! ```

use crate::point::Point;

/// De Casteljau evaluation (repeated linear interpolation). `scratch` must hold at least
/// `points.len()` points. An empty `points` gives the origin.
pub fn eval_de_casteljau(points: &[Point], t: f64, scratch: &mut [Point]) -> Point {
    let n = points.len();
    if n == 0 || scratch.len() < n {
        return Point::ORIGIN;
    }
    scratch[..n].copy_from_slice(points);
    for level in 1..n {
        for i in 0..n - level {
            scratch[i] = scratch[i].lerp(scratch[i + 1], t);
        }
    }
    scratch[0]
}

/// Bernstein-form evaluation `sum C(n,i) t^i (1-t)^(n-i) P_i`, by Horner's scheme in
/// `u = t / (1 - t)` (or `(1 - t) / t` for `t > 1/2`, keeping `|u| <= 1` on `[0, 1]`).
/// `O(n)`, no scratch. An empty `points` gives the origin.
pub fn eval_bernstein(points: &[Point], t: f64) -> Point {
    let n = points.len();
    if n == 0 {
        return Point::ORIGIN;
    }
    let deg = n - 1;
    let s = 1.0 - t;
    let (u, scale, rev) = if t <= 0.5 { (t / s, s, false) } else { (s / t, t, true) };
    let q = |i: usize| if rev { points[deg - i] } else { points[i] };
    // acc = sum_i C(deg, i) u^i q_i, from the top: C(deg, i) = C(deg, i + 1) (i + 1) / (deg - i).
    let top = q(deg);
    let (mut x, mut y) = (top.x, top.y);
    let mut c = 1.0;
    for i in (0..deg).rev() {
        c = c * (i + 1) as f64 / (deg - i) as f64;
        let p = q(i);
        x = x * u + c * p.x;
        y = y * u + c * p.y;
    }
    let f = scale.powi(deg as i32);
    Point::new(x * f, y * f)
}

/// Control points of the derivative: `out[i] = deg (P_{i+1} - P_i)`, `i < points.len() - 1`
/// (stored as points; read them as vectors). `out` must hold `points.len() - 1` points.
pub fn hodograph(points: &[Point], out: &mut [Point]) {
    let n = points.len();
    if n < 2 {
        return;
    }
    let deg = (n - 1) as f64;
    for i in 0..n - 1 {
        out[i] = (deg * (points[i + 1] - points[i])).to_point();
    }
}

/// Splits at `t`: `left` gets the part on `[0, t]`, `right` the part on `[t, 1]`; both must hold
/// `points.len()` points. The left part is the triangle's first column `P^i_0`, the right part
/// its diagonal `P^{n-1-i}_i`, which the in-place reduction leaves behind in `right`.
pub fn split(points: &[Point], t: f64, left: &mut [Point], right: &mut [Point]) {
    let n = points.len();
    right[..n].copy_from_slice(points);
    for level in 0..n {
        left[level] = right[0];
        for i in 0..n - 1 - level {
            right[i] = right[i].lerp(right[i + 1], t);
        }
    }
}

/// The part on `[t0, t1]` reparametrised to `[0, 1]` (reversed if `t1 < t0`). `out` must hold
/// `points.len()` points.
pub fn subsegment(points: &[Point], t0: f64, t1: f64, out: &mut [Point]) {
    let n = points.len();
    if t1 < t0 {
        subsegment(points, t1, t0, out);
        out[..n].reverse();
        return;
    }
    out[..n].copy_from_slice(points);
    // Two in-place splits, in the order whose renormalised parameter has the larger denominator.
    if t1 >= 1.0 - t0 {
        keep_left(&mut out[..n], t1);
        keep_right(&mut out[..n], if t1 != 0.0 { t0 / t1 } else { 0.0 });
    } else {
        keep_right(&mut out[..n], t0);
        keep_left(&mut out[..n], if t0 != 1.0 { (t1 - t0) / (1.0 - t0) } else { 0.0 });
    }
}

/// Replaces the control points by those of the part on `[u, 1]`.
fn keep_right(p: &mut [Point], u: f64) {
    let n = p.len();
    for level in 1..n {
        for i in 0..n - level {
            p[i] = p[i].lerp(p[i + 1], u);
        }
    }
}

/// Replaces the control points by those of the part on `[0, u]`.
fn keep_left(p: &mut [Point], u: f64) {
    let n = p.len();
    for level in 1..n {
        for i in (level..n).rev() {
            p[i] = p[i - 1].lerp(p[i], u);
        }
    }
}

/// Degree elevation: `out[i] = (i/(n+1)) P_{i-1} + (1 - i/(n+1)) P_i` for the `n + 1`
/// output points of a curve with `n` input points. `out` must hold `points.len() + 1` points.
pub fn elevate(points: &[Point], out: &mut [Point]) {
    let n = points.len();
    if n == 0 {
        return;
    }
    out[0] = points[0];
    out[n] = points[n - 1];
    let m = n as f64; // new degree
    for i in 1..n {
        let a = i as f64 / m;
        out[i] = Point::new(
            a * points[i - 1].x + (1.0 - a) * points[i].x,
            a * points[i - 1].y + (1.0 - a) * points[i].y,
        );
    }
}

/// Power-basis coefficients `c_k` (ascending) of one coordinate (`axis` 0 = x, 1 = y):
/// `c_k = C(n,k) sum_{i<=k} (-1)^{k-i} C(k,i) P_i`. `out` must hold `points.len()` values.
pub fn power_coeffs(points: &[Point], axis: usize, out: &mut [f64]) {
    let n = points.len();
    if n == 0 {
        return;
    }
    let deg = n - 1;
    let coord = |p: &Point| if axis == 0 { p.x } else { p.y };
    // Forward differences: Delta^k P_0 times C(deg, k).
    let mut diff: Vec<f64> = points.iter().map(coord).collect();
    let mut binom = 1.0;
    for k in 0..n {
        out[k] = binom * diff[0];
        for i in 0..n - 1 - k {
            diff[i] = diff[i + 1] - diff[i];
        }
        binom = binom * (deg - k) as f64 / (k + 1) as f64;
    }
}

/// Evaluates the power-basis polynomial `sum c_k t^k`.
#[inline]
pub fn horner(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ck| acc * t + ck)
}

/// Real roots of `sum c_k t^k` in the open interval `(0, 1)`, ascending, appended to `out`
/// (pass an empty `out`: roots not above its last element are skipped as repeats).
/// Roots of the derivative split `[0, 1]` into monotone pieces, each searched by safeguarded
/// Newton; repeated roots are reported once. Coefficients that are all zero give no roots.
pub fn real_roots_unit(c: &[f64], out: &mut Vec<f64>) {
    // Trim negligible leading coefficients.
    let scale = c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if !(scale > 0.0) || !scale.is_finite() {
        return;
    }
    let mut deg = c.len() - 1;
    while deg > 0 && c[deg].abs() <= 1e-14 * scale {
        deg -= 1;
    }
    let c = &c[..=deg];
    match deg {
        0 => {}
        1 => {
            let r = -c[0] / c[1];
            if r > 0.0 && r < 1.0 {
                out.push(r);
            }
        }
        2 => {
            let (a, b, cc) = (c[2], c[1], c[0]);
            let disc = b * b - 4.0 * a * cc;
            if disc < 0.0 {
                // A tangency within round-off still counts as an extremum candidate.
                let r = -b / (2.0 * a);
                if disc > -1e-14 * b * b && r > 0.0 && r < 1.0 {
                    out.push(r);
                }
                return;
            }
            let sgn = if b >= 0.0 { 1.0 } else { -1.0 };
            let q = -0.5 * (b + sgn * disc.sqrt());
            let mut rs = [q / a, if q != 0.0 { cc / q } else { f64::NAN }];
            if rs[0] > rs[1] {
                rs.swap(0, 1);
            }
            for r in rs {
                if r > 0.0 && r < 1.0 && out.last().is_none_or(|&l| l < r) {
                    out.push(r);
                }
            }
        }
        _ => {
            let d: Vec<f64> = (1..=deg).map(|k| k as f64 * c[k]).collect();
            let mut crit = Vec::with_capacity(deg);
            real_roots_unit(&d, &mut crit);
            let mut knots = Vec::with_capacity(crit.len() + 2);
            knots.push(0.0);
            knots.extend(crit.iter().copied());
            knots.push(1.0);
            let tol = 1e-13 * scale;
            for w in knots.windows(2) {
                let (a, b) = (w[0], w[1]);
                let (fa, fb) = (horner(c, a), horner(c, b));
                // A critical point that is itself a root (double root).
                if fa.abs() <= tol && a > 0.0 {
                    if out.last().is_none_or(|&l| l < a) {
                        out.push(a);
                    }
                    continue;
                }
                if fa * fb < 0.0 {
                    let r = monotone_root(c, a, b, fa);
                    if r > 0.0 && r < 1.0 && out.last().is_none_or(|&l| l < r) {
                        out.push(r);
                    }
                }
            }
        }
    }
}

/// Root of a polynomial monotone on `[a, b]` with a sign change, by Newton kept inside the bracket.
fn monotone_root(c: &[f64], mut a: f64, mut b: f64, fa: f64) -> f64 {
    let mut t = 0.5 * (a + b);
    for _ in 0..100 {
        let (f, df) = c.iter().rev().fold((0.0, 0.0), |(p, dp), &ck| (p * t + ck, dp * t + p));
        if f == 0.0 {
            return t;
        }
        if (f < 0.0) == (fa < 0.0) {
            a = t;
        } else {
            b = t;
        }
        let tn = t - f / df;
        let next = if tn > a && tn < b { tn } else { 0.5 * (a + b) };
        if (next - t).abs() <= 1e-16 * t.abs().max(1e-300) || b - a <= 2.0 * f64::EPSILON {
            return next;
        }
        t = next;
    }
    t
}
