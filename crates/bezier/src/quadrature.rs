//! Quadrature for arc length: Gauss-Legendre rules chosen by an a-priori error bound, an
//! a-posteriori adaptive Gauss-Legendre, and composite Simpson (the paper's method).
//!
//! The a-priori bound is the classical one for analytic integrands (Trefethen, *Approximation
//! Theory and Approximation Practice*, Thm. 19.3): if `f` is analytic in the open Bernstein
//! ellipse `E_rho` of the interval `[c - h, c + h]` and `|f| <= M` there, the `n`-point
//! Gauss-Legendre rule errs by at most
//!
//! ```text
//! E_n <= (64 / 15) h M rho^{-2n} / (rho^2 - 1).
//! ```
//!
//! For a polynomial curve the speed is `|B'(t)| = |z(t)|` with the complex polynomial
//! `z(t) = x'(t) + i y'(t) = lead * prod (t - r_j)`, so its only singularities are the roots
//! `r_j` and their conjugates, and `M <= |lead| prod (|c - r_j| + h (rho + 1/rho) / 2)`.
//! Knowing the roots, the smallest sufficient rule is picked before any evaluation; the
//! interval is split (at the real part of the nearest root, or graded toward it) only when no
//! stored rule suffices.

use crate::gauss_legendre::{ORDERS, RULES};
#[cfg(doc)]
use crate::traits::ParamCurveArclen;
use crate::traits::{DEFAULT_ACCURACY, RELATIVE_ACCURACY_FLOOR};

/// Most intervals one adaptive integration may create (guards against pathological input).
const MAX_LEAVES: u32 = 4096;
/// Deepest subdivision.
const MAX_DEPTH: u32 = 64;

/// NaN becomes [`DEFAULT_ACCURACY`]; zero or negative becomes the smallest positive accuracy
/// (the integrators then raise it to [`RELATIVE_ACCURACY_FLOOR`] times the integral's size).
#[inline]
pub(crate) fn sanitize_accuracy(accuracy: f64) -> f64 {
    if accuracy.is_nan() {
        DEFAULT_ACCURACY
    } else if accuracy <= 0.0 {
        f64::MIN_POSITIVE
    } else {
        accuracy
    }
}

/// `n`-point Gauss-Legendre rule (half-table `rule`) on `[a, b]`.
#[inline(always)]
pub(crate) fn gauss<F: Fn(f64) -> f64>(rule: &[(f64, f64)], a: f64, b: f64, f: &F) -> f64 {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let mut sum = 0.0;
    for &(x, w) in rule {
        let dx = h * x;
        sum += w * (f(c - dx) + f(c + dx));
    }
    sum * h
}

/// 16-point Gauss-Legendre on `[a, b]`.
pub(crate) fn gauss16<F: Fn(f64) -> f64>(a: f64, b: f64, f: &F) -> f64 {
    gauss(RULES[5], a, b, f)
}

/// A complex number `(re, im)`; just enough arithmetic for quadratic roots.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Complex {
    pub re: f64,
    pub im: f64,
}

impl Complex {
    #[inline]
    pub fn new(re: f64, im: f64) -> Complex {
        Complex { re, im }
    }
    #[inline]
    pub fn abs(self) -> f64 {
        (self.re * self.re + self.im * self.im).sqrt()
    }
    #[inline]
    pub fn mul(self, o: Complex) -> Complex {
        Complex::new(self.re * o.re - self.im * o.im, self.re * o.im + self.im * o.re)
    }
    #[inline]
    pub fn add(self, o: Complex) -> Complex {
        Complex::new(self.re + o.re, self.im + o.im)
    }
    #[inline]
    pub fn sub(self, o: Complex) -> Complex {
        Complex::new(self.re - o.re, self.im - o.im)
    }
    #[inline]
    pub fn scale(self, s: f64) -> Complex {
        Complex::new(self.re * s, self.im * s)
    }
    #[inline]
    pub fn div(self, o: Complex) -> Complex {
        let d = o.re * o.re + o.im * o.im;
        Complex::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
    /// Principal square root.
    #[inline]
    pub fn sqrt(self) -> Complex {
        let r = self.abs();
        if r == 0.0 {
            return Complex::new(0.0, 0.0);
        }
        let re = (0.5 * (r + self.re.abs())).sqrt();
        let other = 0.5 * self.im / re;
        if self.re >= 0.0 {
            Complex::new(re, other)
        } else {
            Complex::new(other.abs(), if self.im < 0.0 { -re } else { re })
        }
    }
}

/// Roots of `a z^2 + b z + c` (complex coefficients), stably; returns how many (0 to 2) with
/// `a = 0` or `a = b = 0` handled as lower degrees.
pub(crate) fn complex_quadratic_roots(a: Complex, b: Complex, c: Complex) -> ([Complex; 2], usize) {
    let zero = Complex::new(0.0, 0.0);
    let n2 = |z: Complex| z.re * z.re + z.im * z.im;
    let (na, nb, nc) = (n2(a), n2(b), n2(c));
    let scale2 = na.max(nb).max(nc);
    if !(scale2 > 0.0) || !scale2.is_finite() {
        return ([zero; 2], 0);
    }
    // Coefficients below 1e-14 of the largest are round-off: treat as a lower degree.
    let tiny2 = 1e-28 * scale2;
    if na <= tiny2 {
        if nb <= tiny2 {
            return ([zero; 2], 0);
        }
        return ([c.scale(-1.0).div(b), zero], 1);
    }
    let disc = b.mul(b).sub(a.mul(c).scale(4.0)).sqrt();
    // Choose the sign that avoids cancellation in b +- sqrt(disc).
    let q = if b.re * disc.re + b.im * disc.im >= 0.0 {
        b.add(disc)
    } else {
        b.sub(disc)
    }
    .scale(-0.5);
    if q.re == 0.0 && q.im == 0.0 {
        // b = 0 and c = 0: double root at 0.
        return ([zero, zero], 2);
    }
    ([q.div(a), c.div(q)], 2)
}

/// Integrand description for [`integrate_apriori`]: `|f(t)| = lead * prod |t - r_j|` for real `t`.
pub(crate) struct Singularities<'a> {
    pub lead: f64,
    pub roots: &'a [Complex],
}

impl Singularities<'_> {
    /// For the interval `[c - h, c + h]`: each root's Bernstein-ellipse semi-axis
    /// `(|x - 1| + |x + 1|) / 2` with `x = (r - c) / h` (in units of `h`), the smallest one and
    /// the root that has it. `|x| <= semi` bounds the root's distance from the centre too.
    #[inline]
    fn semi_axes(&self, c: f64, h: f64) -> ([f64; 2], f64, Complex) {
        let inv_h = 1.0 / h;
        let mut semis = [0.0; 2];
        let mut best = f64::INFINITY;
        let mut nearest = self.roots[0];
        for (j, r) in self.roots.iter().enumerate().take(2) {
            let xr = (r.re - c) * inv_h;
            let xi = r.im * inv_h;
            let xi2 = xi * xi;
            let semi = 0.5 * (((xr - 1.0) * (xr - 1.0) + xi2).sqrt() + ((xr + 1.0) * (xr + 1.0) + xi2).sqrt());
            semis[j] = semi;
            if semi < best {
                best = semi;
                nearest = *r;
            }
        }
        (semis, best, nearest)
    }

    /// Upper bound of `|f|` on the ellipse with semi-axis `h * a` around `c`:
    /// `lead prod_j (|c - r_j| + h a) <= lead h^k prod_j (semi_j + a)`.
    #[inline]
    fn bound(&self, semis: &[f64; 2], h: f64, a: f64) -> f64 {
        let mut m = self.lead;
        for s in semis.iter().take(self.roots.len()) {
            m *= h * (s + a);
        }
        m
    }
}

/// `int_a^b f` with absolute error at most `tol` (a-priori rule choice; see the module docs).
/// Requests below [`RELATIVE_ACCURACY_FLOOR`] times an upper bound of the integral are raised to it.
#[inline]
pub(crate) fn integrate_apriori<F: Fn(f64) -> f64>(f: &F, sing: &Singularities<'_>, a: f64, b: f64, tol: f64) -> f64 {
    let (lo, hi, sign) = if b >= a { (a, b, 1.0) } else { (b, a, -1.0) };
    if sing.roots.is_empty() || !(hi > lo) {
        // Constant speed (or an empty interval): any rule is exact.
        return sign * gauss(RULES[0], lo, hi, f);
    }
    let mut leaves = 0;
    sign * apriori_rec(f, sing, lo, hi, sanitize_accuracy(tol), MAX_DEPTH, &mut leaves)
}

fn apriori_rec<F: Fn(f64) -> f64>(
    f: &F,
    sing: &Singularities<'_>,
    a: f64,
    b: f64,
    tol: f64,
    depth: u32,
    leaves: &mut u32,
) -> f64 {
    let h = 0.5 * (b - a);
    let c = 0.5 * (a + b);
    let (semis, semi, nearest) = sing.semi_axes(c, h);
    // 2h max|f| bounds both the integral and |I - I_n| on the real interval.
    let size = 2.0 * h * sing.bound(&semis, h, 1.0);
    let tol = if depth == MAX_DEPTH {
        tol.max(RELATIVE_ACCURACY_FLOOR * size)
    } else {
        tol
    };
    if size <= tol {
        return gauss(RULES[0], a, b, f);
    }
    if !semi.is_finite() {
        // Non-finite roots only arise from non-finite input; the sum below propagates it.
        return gauss(RULES[RULES.len() - 1], a, b, f);
    }
    // rho + 1/rho = 2 semi for the ellipse through the nearest singularity.
    let rho = semi + (semi * semi - 1.0).max(0.0).sqrt();
    if rho > 1.0 + 1e-9 {
        let q = rho * rho;
        // Need rho^{2n} = q^n >= K / tol, K = (64/15) h M / (rho^2 - 1).
        let need = (64.0 / 15.0) * h * sing.bound(&semis, h, semi) / ((q - 1.0) * tol);
        let q2 = q * q;
        let q4 = q2 * q2;
        let mut qn = q4; // q^4
        for (i, &n) in ORDERS.iter().enumerate() {
            if i > 0 {
                // Climb the ladder of ORDERS by multiplying.
                let step = n - ORDERS[i - 1];
                qn *= match step {
                    2 => q2,
                    4 => q4,
                    _ => q.powi(step as i32),
                };
            }
            if qn >= need {
                return gauss(RULES[i], a, b, f);
            }
        }
    }
    *leaves += 2;
    if depth == 0 || *leaves > MAX_LEAVES {
        return gauss(RULES[RULES.len() - 1], a, b, f);
    }
    // Split at the singularity's real part when it is well inside, else grade toward the nearer end.
    let w = b - a;
    let p = if nearest.re > a + 0.1 * w && nearest.re < b - 0.1 * w {
        nearest.re
    } else {
        let (e, dir) = if nearest.re <= c { (a, 1.0) } else { (b, -1.0) };
        let d = Complex::new(nearest.re - e, nearest.im).abs();
        e + dir * (2.0 * d).clamp(0.1 * w, 0.5 * w)
    };
    let tl = tol * (p - a) / w;
    apriori_rec(f, sing, a, p, tl, depth - 1, leaves) + apriori_rec(f, sing, p, b, tol - tl, depth - 1, leaves)
}

/// `int_a^b f` by adaptive bisection with the 16-point rule: a piece is accepted when the rule on
/// the whole and on its halves agree to the piece's share of `tol`. `scale` is a rough size of
/// the integral, for the round-off floor.
pub(crate) fn integrate_adaptive<F: Fn(f64) -> f64>(f: &F, a: f64, b: f64, tol: f64, scale: f64) -> f64 {
    let tol = sanitize_accuracy(tol).max(RELATIVE_ACCURACY_FLOOR * scale.abs());
    if a == b {
        return 0.0;
    }
    let (lo, hi, sign) = if b > a { (a, b, 1.0) } else { (b, a, -1.0) };
    let rule = RULES[5]; // 16 points (ORDERS[5])
    let whole = gauss(rule, lo, hi, f);
    let mut leaves = 0;
    sign * adaptive_rec(f, rule, lo, hi, whole, tol, MAX_DEPTH, &mut leaves)
}

fn adaptive_rec<F: Fn(f64) -> f64>(
    f: &F,
    rule: &[(f64, f64)],
    a: f64,
    b: f64,
    whole: f64,
    tol: f64,
    depth: u32,
    leaves: &mut u32,
) -> f64 {
    let m = 0.5 * (a + b);
    let l = gauss(rule, a, m, f);
    let r = gauss(rule, m, b, f);
    let err = (l + r - whole).abs();
    *leaves += 2;
    // `!(err > tol)` also accepts NaN, so non-finite input terminates at once.
    if !(err > tol) || depth == 0 || *leaves > MAX_LEAVES {
        return l + r;
    }
    adaptive_rec(f, rule, a, m, l, 0.5 * tol, depth - 1, leaves)
        + adaptive_rec(f, rule, m, b, r, 0.5 * tol, depth - 1, leaves)
}

/// Composite Simpson's rule on `[a, b]` with `n` intervals (`n` rounded up to even, at least 2).
pub fn simpson<F: Fn(f64) -> f64>(f: F, a: f64, b: f64, n: usize) -> f64 {
    let n = (n.max(2) + 1) & !1;
    let h = (b - a) / n as f64;
    let mut odd = 0.0;
    let mut even = 0.0;
    for i in 1..n {
        let v = f(a + i as f64 * h);
        if i % 2 == 1 {
            odd += v;
        } else {
            even += v;
        }
    }
    h / 3.0 * (f(a) + f(b) + 4.0 * odd + 2.0 * even)
}

/// Composite Simpson with interval doubling until successive estimates differ by at most
/// `15 * accuracy` (at least 8 intervals, at most `2^max_levels`); reuses all evaluations.
pub(crate) fn simpson_adaptive<F: Fn(f64) -> f64>(f: F, a: f64, b: f64, accuracy: f64, max_levels: u32) -> f64 {
    let acc = sanitize_accuracy(accuracy);
    let ends = f(a) + f(b);
    let mut n = 2usize;
    let mut h = 0.5 * (b - a);
    let mut odd = f(a + h);
    let mut even = 0.0;
    let mut s_old = h / 3.0 * (ends + 4.0 * odd);
    for level in 1..=max_levels.max(1) {
        even += odd;
        n *= 2;
        h *= 0.5;
        odd = 0.0;
        for k in 0..n / 2 {
            odd += f(a + (2 * k + 1) as f64 * h);
        }
        let s = h / 3.0 * (ends + 4.0 * odd + 2.0 * even);
        let diff = (s - s_old).abs();
        s_old = s;
        if level >= 2 && !(diff > 15.0 * acc.max(RELATIVE_ACCURACY_FLOOR * s.abs())) {
            break;
        }
    }
    s_old
}

/// Finds `t` in the bracket `lo.0 < t < hi.0` where the arc length from the curve's start is
/// `s`, given the lengths `lo.1`, `hi.1` at the bracket ends; safeguarded Newton on `L(t) - s`
/// that integrates only increments (`range(t0, t1, accuracy)`), with `speed(t) = |B'(t)|`.
pub(crate) fn solve_arclen<S: Fn(f64) -> f64, R: Fn(f64, f64, f64) -> f64>(
    speed: S,
    range: R,
    s: f64,
    lo: (f64, f64),
    hi: (f64, f64),
    guess: f64,
    accuracy: f64,
) -> f64 {
    let (mut lo, mut l_lo) = lo;
    let (mut hi, mut l_hi) = hi;
    let inc_acc = accuracy / 16.0;
    let mut t = if guess > lo && guess < hi {
        guess
    } else {
        0.5 * (lo + hi)
    };
    // Integrate from the nearer end of the bracket.
    let mut lt = if t - lo <= hi - t {
        l_lo + range(lo, t, inc_acc)
    } else {
        l_hi - range(t, hi, inc_acc)
    };
    for _ in 0..100 {
        let err = lt - s;
        if !(err.abs() > 0.5 * accuracy) {
            return t;
        }
        if err > 0.0 {
            hi = t;
            l_hi = lt;
        } else {
            lo = t;
            l_lo = lt;
        }
        if hi - lo <= 4.0 * f64::EPSILON * hi.abs().max(1.0) {
            return t;
        }
        let mut tn = t - err / speed(t);
        if !(tn > lo && tn < hi) {
            // Newton left the bracket (or the speed vanished): regula falsi if it makes real
            // progress, else bisection.
            let sec = lo + (s - l_lo) / (l_hi - l_lo) * (hi - lo);
            tn = if sec > lo && sec < hi && (sec - lo).min(hi - sec) > 0.01 * (hi - lo) {
                sec
            } else {
                0.5 * (lo + hi)
            };
        }
        lt += range(t, tn, inc_acc);
        t = tn;
    }
    t
}

/// Default inverse arc length for any [`ParamCurveArclen`] given its total length.
pub(crate) fn inv_arclen_with<S: Fn(f64) -> f64, R: Fn(f64, f64, f64) -> f64>(
    speed: S,
    range: R,
    s: f64,
    total: f64,
    accuracy: f64,
) -> f64 {
    if !(total > 0.0) || !(s > 0.0) {
        return 0.0;
    }
    if s >= total {
        return 1.0;
    }
    solve_arclen(speed, range, s, (0.0, 0.0), (1.0, total), s / total, accuracy)
}

/// Parameters of `n` points equally spaced in arc length (see `ParamCurveArclen::resample_uniform`).
pub(crate) fn resample_with<S: Fn(f64) -> f64, R: Fn(f64, f64, f64) -> f64>(
    speed: S,
    range: R,
    n: usize,
    total: f64,
    accuracy: f64,
) -> Vec<f64> {
    if n < 2 {
        return vec![0.0; n];
    }
    let steps = (n - 1) as f64;
    if !(total > 0.0) || !total.is_finite() {
        return (0..n).map(|i| i as f64 / steps).collect();
    }
    let mut out = Vec::with_capacity(n);
    out.push(0.0);
    let (mut t_prev, mut s_prev) = (0.0, 0.0);
    for i in 1..n - 1 {
        let s = total * i as f64 / steps;
        // Guess: the remaining length spread linearly over the remaining parameter range.
        let guess = t_prev + (1.0 - t_prev) * (s - s_prev) / (total - s_prev);
        let t = solve_arclen(&speed, &range, s, (t_prev, s_prev), (1.0, total), guess, accuracy);
        out.push(t);
        t_prev = t;
        s_prev = s;
    }
    out.push(1.0);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stored nodes are roots of P_n and the weights integrate monomials exactly.
    #[test]
    fn gauss_legendre_tables_integrate_polynomials_exactly() {
        for (i, &n) in ORDERS.iter().enumerate() {
            assert_eq!(RULES[i].len(), n / 2);
            for deg in 0..2 * n {
                let got = gauss(RULES[i], 0.0, 1.0, &|x: f64| x.powi(deg as i32));
                let exact = 1.0 / (deg as f64 + 1.0);
                assert!((got - exact).abs() < 1e-14, "n={n} deg={deg}: {got} vs {exact}");
            }
        }
    }

    #[test]
    fn complex_roots_reproduce_polynomial() {
        let a = Complex::new(1.0, 2.0);
        let b = Complex::new(-3.0, 0.5);
        let c = Complex::new(0.25, -1.0);
        let (r, n) = complex_quadratic_roots(a, b, c);
        assert_eq!(n, 2);
        for z in r {
            let v = a.mul(z).mul(z).add(b.mul(z)).add(c);
            assert!(v.abs() < 1e-14);
        }
    }

    #[test]
    fn simpson_is_exact_for_cubics() {
        let v = simpson(|x| x * x * x - x, 0.0, 2.0, 2);
        assert!((v - 2.0).abs() < 1e-14);
    }
}
