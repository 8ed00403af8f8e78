//! Quadrature for arc length: Gauss-Legendre rules chosen by an a-priori error bound, an
//! a-posteriori adaptive Gauss-Legendre, and composite Simpson (the paper's method).
//!
//! The a-priori bound is the classical one for analytic integrands (Trefethen, *Approximation
//! Theory and Approximation Practice*, Thm. 19.3, there stated for `n + 1` nodes): if `f` is
//! analytic in the open Bernstein ellipse `E_rho` of the interval `[c - h, c + h]` and `|f| <= M`
//! there, the `n`-point Gauss-Legendre rule (exact to degree `2n - 1`) errs by at most
//!
//! ```text
//! E_n <= (64 / 15) h M rho^{2 - 2n} / (rho^2 - 1).
//! ```
//!
//! For a polynomial curve the speed is `|B'(t)| = |z(t)|` with the complex polynomial
//! `z(t) = x'(t) + i y'(t) = lead * prod (t - r_j)`, so its only singularities are the roots
//! `r_j` and their conjugates, and `M <= |lead| prod (|c - r_j| + h (rho + 1/rho) / 2)`.
//! Knowing the roots, the smallest sufficient rule is picked before any evaluation; the
//! interval is split (at the real part of the nearest root, or graded toward it) only when no
//! stored rule suffices. The roots being square-root branch points, the bound overstates the
//! error by a factor growing like `n^{3/2}`; it is divided by the calibrated `APRIORI_GAIN`
//! (`2 n^{3/2}`), so that the work follows the request instead of over-delivering about 1000x
//! (the result is then an estimate, checked on seeded random cubics at 1e-4 to 1e-12).
//!
//! For cubics a cheaper bound comes first (`rouche_order`): it needs no roots (a complex
//! square root and two divisions saved), only `|a|`, `|b|`, `|c'|` of the hodograph in
//! Chebyshev form, and it subtracts the Taylor polynomial of the speed that the rule integrates
//! exactly, so `M` shrinks to a high power of the hodograph's relative variation. It decides
//! smooth segments (the usual spline segment) with one rule of 6 to 16 points; loops and
//! near-cusps fall through to the roots.
//!
//! With the roots known, the interval is cut at the real part of every root closer to the real
//! axis than 0.15 of the interval (`branch_order`): a near-cusp then sits at an end of its
//! piece, where the speed looks like `|t - p|`, which a rule integrates almost exactly, instead
//! of a kink inside, which no rule does. Each piece takes the smallest rule whose tabulated error
//! on the model `sqrt((x - x0)^2 + eps^2)` (`tools/gen_branch_tables.py`: the worst case over
//! branch-point positions and eighth-octave bins of `eps`, the root's distance from the real axis over
//! the piece's length), times a bound of the other factor of the speed and a safety factor 2,
//! fits the piece's share of the tolerance; a whole interval whose rule is small is not cut. This
//! is an estimate (the model is exact, the product with the other factor is not), checked on
//! random, near-cusp and degenerate cubics; where no stored rule fits, the Bernstein-ellipse
//! recursion above takes over.
//!
//! The rules' sums run on AVX-512 or AVX2 + FMA where the CPU has them (`gauss_simd`, chosen at
//! run time; [`crate::simd_level`]). Many cubics at once go through `arclen_unit_batch`
//! ([`crate::CubicBez::arclen_batch`]), which computes the roots of the curves that need them
//! four at a time and returns what one curve at a time would, bit for bit.

use crate::accuracy::{sanitize_accuracy, RELATIVE_ACCURACY_FLOOR};
use crate::branch_tables::{BRANCH_IN, BRANCH_KMAX, BRANCH_KMIN, BRANCH_OUT, BRANCH_SUB_BITS};
use crate::gauss_legendre::{GL10, GL12, GL16, GL20, GL24, GL32, GL4, GL48, GL6, GL64, GL8, ORDERS, RULES};
use crate::point::Vec2;

/// Most intervals one adaptive integration may create (guards against pathological input).
const MAX_LEAVES: u32 = 4096;
/// Deepest subdivision.
const MAX_DEPTH: u32 = 64;

/// The larger of `a` and `b`, or `b` when either is NaN: one `maxsd`, where `f64::max` (which
/// ignores a NaN operand) costs four more instructions.
#[inline(always)]
fn fmax(a: f64, b: f64) -> f64 {
    if a > b {
        a
    } else {
        b
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
    gauss(&GL16, a, b, f)
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
        let inv = 1.0 / (o.re * o.re + o.im * o.im);
        Complex::new(
            (self.re * o.re + self.im * o.im) * inv,
            (self.im * o.re - self.re * o.im) * inv,
        )
    }
}

/// Roots of `a z^2 + b z + c` (complex coefficients), stably; returns how many (0 to 2) with
/// `a = 0` or `a = b = 0` handled as lower degrees.
///
/// Arranged for a short chain of slow operations (this is on the path of every arc length that
/// the root-free bound cannot decide): `1 / |a|^2` is computed beside the discriminant's square
/// root, whose own division runs beside its second square root; the larger root `q / a` then
/// needs only products, and the smaller one is `-b / a` minus it unless it is much smaller than
/// the larger one (then `c / q`, which avoids the cancellation).
#[inline(always)]
pub(crate) fn complex_quadratic_roots(a: Complex, b: Complex, c: Complex) -> ([Complex; 2], usize) {
    let zero = Complex::new(0.0, 0.0);
    let n2 = |z: Complex| z.re * z.re + z.im * z.im;
    let (na, nb, nc) = (n2(a), n2(b), n2(c));
    let scale2 = fmax(fmax(na, nb), nc);
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
    let inv_a = 1.0 / na;
    let w = b.mul(b).sub(a.mul(c).scale(4.0));
    // Principal square root of w: (s, t) with s = sqrt(m / 2), t = w.im / (2 s) = w.im s / m.
    let m = w.abs() + w.re.abs();
    let inv_m = 1.0 / m;
    let s = (0.5 * m).sqrt();
    let t = if m > 0.0 { w.im * s * inv_m } else { 0.0 };
    let disc = if w.re >= 0.0 {
        Complex::new(s, t)
    } else {
        Complex::new(t.abs(), if w.im < 0.0 { -s } else { s })
    };
    // Choose the sign that avoids cancellation in b +- sqrt(disc).
    let q = if b.re * disc.re + b.im * disc.im >= 0.0 {
        b.add(disc)
    } else {
        b.sub(disc)
    }
    .scale(-0.5);
    let conj_a = Complex::new(a.re * inv_a, -a.im * inv_a);
    let r1 = q.mul(conj_a);
    let nq = n2(q);
    if nq == 0.0 {
        // b = 0 and c = 0: double root at 0.
        return ([zero, zero], 2);
    }
    // |r2| = |c| / |q|; below 1e-4 |r1| the sum -b/a - r1 would lose digits.
    let r2 = if nc * na >= 1e-8 * nq * nq {
        b.scale(-1.0).mul(conj_a).sub(r1)
    } else {
        c.div(q)
    };
    ([r1, r2], 2)
}

/// `2 n^{3/2}` for `n = ORDERS[i]`: how much the geometric bound `(64/15) h M rho^{2 - 2n} /
/// (rho^2 - 1)` overstates the error of the `n`-point rule when the nearest singularity is a
/// square-root branch point (the roots of `z(t)`, all the speed of a polynomial curve has). The
/// Chebyshev coefficients of `sqrt((t - r)(t - r*))` decay like `k^{-3/2} rho^{-k}`, not just
/// `rho^{-k}`, and the rule's error is governed by the coefficients from `k = 2n` on, so the
/// bound is divided by `n^{3/2}` times a constant. The constant 2 is calibrated: over 3000
/// random cubics (loops, near-cusps) at accuracies 1e-3 to 1e-12 the error stays below a tenth of
/// the request (`requested_accuracy_is_met_on_random_cubics` guards it); without the gain the
/// bound over-delivered by about 1000x and cost 25% more evaluations at 1e-6.
const APRIORI_GAIN: [f64; 11] = [
    16.0, 29.393877, 45.254834, 63.245553, 83.138439, 128.0, 178.885438, 235.151015, 362.038672, 665.10751, 1024.0,
];

/// Integrand description for [`integrate_apriori`]: `|f(t)| = lead * prod |t - r_j|` for real `t`.
pub(crate) struct Singularities<'a> {
    pub lead: f64,
    pub roots: &'a [Complex],
}

/// What the a-priori bound decides for one interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Choice {
    /// Apply the rule `RULES[i]`; its error is at most the second field (at most `tol`).
    Rule(usize, f64),
    /// No stored rule suffices: split at this parameter.
    Split(f64),
}

/// The a-priori decision for `[a, b]` (see the module docs): the smallest rule whose bound
/// `(64/15) h M rho^{2 - 2n} / (rho^2 - 1)` is at most `tol`, with `rho` the Bernstein ellipse
/// through the nearest root and `M = lead prod_j (S_j + S)` (`S_j = (|r_j - a| + |r_j - b|) / 2`
/// is the semi-major axis of the ellipse through root `j`, which bounds `|r_j - c|`, and `S` the
/// smallest of them); else where to split. `sing.roots` must not be empty.
#[inline]
pub(crate) fn apriori_choice(sing: &Singularities<'_>, a: f64, b: f64, tol: f64) -> Choice {
    let h = 0.5 * (b - a);
    let c = 0.5 * (a + b);
    // Off the critical path: ready when the distances below are.
    let inv_h = 1.0 / h;
    let mut semis = [0.0; 2];
    let mut best = f64::INFINITY;
    let mut nearest = sing.roots[0];
    for (j, r) in sing.roots.iter().enumerate().take(2) {
        let im2 = r.im * r.im;
        let da = ((r.re - a) * (r.re - a) + im2).sqrt();
        let db = ((r.re - b) * (r.re - b) + im2).sqrt();
        semis[j] = 0.5 * (da + db);
        if semis[j] < best {
            best = semis[j];
            nearest = *r;
        }
    }
    let bound = |alpha_h: f64| {
        let mut m = sing.lead;
        for s in semis.iter().take(sing.roots.len()) {
            m *= s + alpha_h;
        }
        m
    };
    // 2h max|f| bounds both the integral and |I - I_n| on the real interval.
    let size = 2.0 * h * bound(h);
    if size <= tol {
        return Choice::Rule(0, size);
    }
    if !best.is_finite() {
        // Non-finite roots only arise from non-finite input; the sum propagates it.
        return Choice::Rule(RULES.len() - 1, tol);
    }
    // rho + 1/rho = 2 semi for the ellipse through the nearest singularity.
    let semi = best * inv_h;
    let rho = semi + (semi * semi - 1.0).max(0.0).sqrt();
    if rho > 1.0 + 1e-9 {
        let q = rho * rho;
        // Need q^n (q - 1) tol >= (64/15) h M q.
        let need = (64.0 / 15.0) * h * bound(best) * q;
        let q2 = q * q;
        let q4 = q2 * q2;
        let q8 = q4 * q4;
        let mut qn = q4 * (q - 1.0) * tol;
        for (i, &n) in ORDERS.iter().enumerate() {
            if i > 0 {
                // Climb the ladder of ORDERS by multiplying.
                qn *= match n - ORDERS[i - 1] {
                    2 => q2,
                    4 => q4,
                    8 => q8,
                    _ => q8 * q8,
                };
            }
            let qg = qn * APRIORI_GAIN[i];
            if qg >= need {
                // The estimate itself, need / (gain q^n (q - 1)) = tol need / qg.
                return Choice::Rule(i, tol * (need / qg));
            }
        }
    }
    // Split at the singularity's real part when it is well inside, else grade toward the nearer end.
    let w = b - a;
    Choice::Split(if nearest.re > a + 0.1 * w && nearest.re < b - 0.1 * w {
        nearest.re
    } else {
        let (e, dir) = if nearest.re <= c { (a, 1.0) } else { (b, -1.0) };
        let d = Complex::new(nearest.re - e, nearest.im).abs();
        e + dir * (2.0 * d).clamp(0.1 * w, 0.5 * w)
    })
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
    let tol = if depth == MAX_DEPTH {
        // The round-off floor, relative to an upper bound of the integral.
        let h = 0.5 * (b - a);
        let mut size = 2.0 * h * sing.lead;
        for r in sing.roots {
            size *= 0.5 * (Complex::new(r.re - a, r.im).abs() + Complex::new(r.re - b, r.im).abs()) + h;
        }
        tol.max(RELATIVE_ACCURACY_FLOOR * size)
    } else {
        tol
    };
    match apriori_choice(sing, a, b, tol) {
        Choice::Rule(i, _) => gauss(RULES[i], a, b, f),
        Choice::Split(p) => {
            *leaves += 2;
            if depth == 0 || *leaves > MAX_LEAVES {
                return gauss(RULES[RULES.len() - 1], a, b, f);
            }
            let tl = tol * (p - a) / (b - a);
            apriori_rec(f, sing, a, p, tl, depth - 1, leaves) + apriori_rec(f, sing, p, b, tol - tl, depth - 1, leaves)
        }
    }
}

/// The hodograph `B'(t) = q_0 t^2 + q_1 t + q_2` of a cubic read on `[m - h, m + h]` in the local
/// variable `x = (t - m) / h`: `B'(m + h x) = a x^2 + b x + c`. Kept in the power basis so that a
/// symmetric pair of Gauss nodes `+-x` shares `c + a x^2`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LocalHodograph {
    pub a: Vec2,
    pub b: Vec2,
    pub c: Vec2,
}

impl LocalHodograph {
    /// `q` read on `[m - h, m + h]`.
    #[inline(always)]
    pub fn new(q: &[Vec2; 3], m: f64, h: f64) -> LocalHodograph {
        let [qa, qb, qc] = *q;
        LocalHodograph {
            a: qa * (h * h),
            b: (qa * (2.0 * m) + qb) * h,
            c: (qa * m + qb) * m + qc,
        }
    }

    /// `sum_i w_i (|B'(x_i)| + |B'(-x_i)|)` over a half-table: Gauss-Legendre for
    /// `int_{-1}^{1} |B'|` (multiply by `h` for the length). Fixed size, so it unrolls.
    ///
    /// Two nodes at a time in independent lanes (nodes and weights in separate arrays, two
    /// partial sums): the compiler packs each lane pair into one SSE2 register, so the four
    /// square roots of two nodes take two `sqrtpd` and the rest of the arithmetic is packed too
    /// (about half the instructions of one node at a time, whose only packed operation was
    /// the square root of the pair `+-x`). An odd node out goes alone.
    ///
    /// On x86-64 CPUs with AVX-512 or AVX2 and FMA (detected at run time), rules of 16 points
    /// and more take [`gauss_simd::gauss`](crate::gauss_simd), which moves half the square
    /// roots to the multiply-add units.
    #[inline(always)]
    fn gauss_fixed<const K: usize>(&self, rule: &Soa<K>) -> f64 {
        #[cfg(target_arch = "x86_64")]
        if K >= SIMD_MIN_HALF {
            if let Some(simd) = crate::gauss_simd::available() {
                if let Some(v) = crate::gauss_simd::gauss(simd, self.a, self.b, self.c, &rule.x, &rule.w) {
                    return v;
                }
            }
        }
        self.gauss_portable(rule)
    }

    /// [`gauss_fixed`](Self::gauss_fixed) without the run-time choice: the sum any CPU runs.
    #[inline(always)]
    fn gauss_portable<const K: usize>(&self, rule: &Soa<K>) -> f64 {
        // Plain loops over two-element arrays, no closures or `array::from_fn` (whose closure
        // was not always inlined): each line is one packed operation on two nodes.
        let (a, b, c) = (self.a, self.b, self.c);
        let mut acc = [0.0; 2];
        let mut i = 0;
        while i + 2 <= K {
            let mut v = [0.0; 2];
            for j in 0..2 {
                let (x, w) = (rule.x[i + j], rule.w[i + j]);
                let x2 = x * x;
                let (dx, dy) = (c.x + a.x * x2, c.y + a.y * x2);
                let (ex, ey) = (b.x * x, b.y * x);
                let p = ((dx + ex) * (dx + ex) + (dy + ey) * (dy + ey)).sqrt();
                let n = ((dx - ex) * (dx - ex) + (dy - ey) * (dy - ey)).sqrt();
                v[j] = w * (p + n);
            }
            acc[0] += v[0];
            acc[1] += v[1];
            i += 2;
        }
        if K % 2 == 1 {
            acc[0] += self.node(rule.x[K - 1], rule.w[K - 1]);
        }
        acc[0] + acc[1]
    }

    /// `w (|B'(x)| + |B'(-x)|)`.
    #[inline(always)]
    fn node(&self, x: f64, w: f64) -> f64 {
        let (a, b, c) = (self.a, self.b, self.c);
        let x2 = x * x;
        let (dx, dy) = (c.x + a.x * x2, c.y + a.y * x2);
        let (ex, ey) = (b.x * x, b.y * x);
        let p = ((dx + ex) * (dx + ex) + (dy + ey) * (dy + ey)).sqrt();
        let n = ((dx - ex) * (dx - ex) + (dy - ey) * (dy - ey)).sqrt();
        w * (p + n)
    }

    /// [`gauss`](Self::gauss) in one shared copy, for a caller that would otherwise inline
    /// every rule at several call sites.
    #[inline(never)]
    fn gauss_shared(&self, i: usize) -> f64 {
        self.gauss(i)
    }

    /// [`gauss_fixed`](Self::gauss_fixed) with the rule `RULES[i]` (`ORDERS[i]` points). Always
    /// inlined: the rule dispatch then sits next to the decision that picks it.
    #[inline(always)]
    pub fn gauss(&self, i: usize) -> f64 {
        #[cfg(test)]
        counters::add(ORDERS[i.min(ORDERS.len() - 1)]);
        match i {
            0 => self.gauss_fixed(&S4),
            1 => self.gauss_fixed(&S6),
            2 => self.gauss_fixed(&S8),
            3 => self.gauss_fixed(&S10),
            4 => self.gauss_fixed(&S12),
            5 => self.gauss_fixed(&S16),
            6 => self.gauss_fixed(&S20),
            7 => self.gauss_fixed(&S24),
            8 => self.gauss_fixed(&S32),
            9 => self.gauss_fixed(&S48),
            _ => self.gauss_fixed(&S64),
        }
    }
}

/// Smallest half-table (16-point rule) that [`gauss_simd`](crate::gauss_simd) takes: below it the
/// call into the vector code costs about what it saves (measured: no gain from 4 or 6).
#[cfg(target_arch = "x86_64")]
const SIMD_MIN_HALF: usize = 8;

/// A half-table of Gauss-Legendre nodes and weights in separate arrays (structure of arrays), so
/// that two consecutive nodes load as one packed pair.
pub(crate) struct Soa<const K: usize> {
    x: [f64; K],
    w: [f64; K],
}

/// `rule` as [`Soa`].
const fn soa<const K: usize>(rule: &[(f64, f64); K]) -> Soa<K> {
    let mut t = Soa {
        x: [0.0; K],
        w: [0.0; K],
    };
    let mut i = 0;
    while i < K {
        t.x[i] = rule[i].0;
        t.w[i] = rule[i].1;
        i += 1;
    }
    t
}

const S4: Soa<2> = soa(&GL4);
const S6: Soa<3> = soa(&GL6);
const S8: Soa<4> = soa(&GL8);
const S10: Soa<5> = soa(&GL10);
const S12: Soa<6> = soa(&GL12);
const S16: Soa<8> = soa(&GL16);
const S20: Soa<10> = soa(&GL20);
const S24: Soa<12> = soa(&GL24);
const S32: Soa<16> = soa(&GL32);
const S48: Soa<24> = soa(&GL48);
const S64: Soa<32> = soa(&GL64);

/// Evaluation counters for the tests that check how much work a rule choice costs.
#[cfg(test)]
pub(crate) mod counters {
    use std::cell::Cell;
    thread_local! {
        static EVALS: Cell<(usize, usize)> = const { Cell::new((0, 0)) };
    }
    pub fn add(n: usize) {
        EVALS.with(|e| e.set((e.get().0 + n, e.get().1 + 1)));
    }
    /// `(evaluations, rules applied)` since the last call.
    pub fn take() -> (usize, usize) {
        EVALS.with(|e| e.replace((0, 0)))
    }
}

/// `|binom(1/2, n)|`: the size of the `n`-th Taylor coefficient of `sqrt(1 + u)`.
const fn half_binom_abs(n: usize) -> f64 {
    let mut v = 1.0;
    let mut i = 0;
    while i < n {
        v *= (0.5 - i as f64) / (i as f64 + 1.0);
        i += 1;
    }
    if v < 0.0 {
        -v
    } else {
        v
    }
}

/// Number of ellipses tried by [`rouche_order`].
const N_RHO: usize = 2;
/// The ellipse parameters `rho` tried by [`rouche_order`], ascending. Few, because each costs
/// time on every call; these two suit typical spline segments.
const RHO: [f64; N_RHO] = [2.0, 3.2];
/// How many of [`ORDERS`] the root-free bound may pick (up to 32 points); beyond that the
/// roots are worth computing.
const ROUCHE_ORDERS: usize = 9;

/// Per ellipse `rho_k`: `[alpha_k, alpha_k^2 - 1/2, rho_k^-2]` with `alpha = (rho + 1/rho) / 2`.
const fn rho_table() -> [[f64; N_RHO]; 3] {
    let mut t = [[0.0; N_RHO]; 3];
    let mut k = 0;
    while k < N_RHO {
        let r = RHO[k];
        let a = 0.5 * (r + 1.0 / r);
        t[0][k] = a;
        t[1][k] = a * a - 0.5;
        t[2][k] = 1.0 / (r * r);
        k += 1;
    }
    t
}
const RHO_T: [[f64; N_RHO]; 3] = rho_table();

/// `G[i][k] = (256/15) |binom(1/2, n)| rho_k^2 / (rho_k^2 - 1)` for `n = ORDERS[i]`.
const fn rouche_consts() -> [[f64; N_RHO]; ROUCHE_ORDERS] {
    let mut t = [[0.0; N_RHO]; ROUCHE_ORDERS];
    let mut i = 0;
    while i < ROUCHE_ORDERS {
        let b = half_binom_abs(ORDERS[i]);
        let mut k = 0;
        while k < N_RHO {
            let r2 = RHO[k] * RHO[k];
            t[i][k] = (256.0 / 15.0) * b * r2 / (r2 - 1.0);
            k += 1;
        }
        i += 1;
    }
    t
}
const ROUCHE_G: [[f64; N_RHO]; ROUCHE_ORDERS] = rouche_consts();

/// The smallest stored Gauss-Legendre order (an index into [`ORDERS`]) that provably integrates
/// `|B'|` over `[m - h, m + h]` to within `tol`, found without the hodograph's roots; `None`
/// when this bound cannot tell (near a cusp, or more than 32 points would be needed).
///
/// In Chebyshev form `B'(x) = c' (1 + u(x))` with `c' = c + a/2` and
/// `u = (b T_1 + (a/2) T_2) / c'`. On the Bernstein ellipse `E_rho`, `|T_1| <= alpha` and
/// `|T_2| <= 2 alpha^2 - 1` (`alpha = (rho + 1/rho) / 2`), so
/// `|u| <= eta = (|b| alpha + |a| (alpha^2 - 1/2)) / |c'|`. When `eta < 1`, `B'` has no zero in
/// `E_rho` (Rouché) and `|B'| = |c'| sqrt(1 + u) sqrt(1 + u*)` (`u*` the polynomial with
/// conjugated coefficients) is analytic there. The `n`-point rule integrates exactly the Taylor
/// polynomial of that product of total order `n - 1` in `(u, u*)` (degree `2n - 2` in `x`); the
/// majorant of `sqrt(1 + u)` being `2 - sqrt(1 - eta)`, the rest is at most
/// `4 |c'| sum_{j >= n} |binom(1/2, j)| eta^j <= 4 |c'| |binom(1/2, n)| eta^n / (1 - eta)` on
/// `E_rho`. The Chebyshev-coefficient bound for Gauss quadrature (Trefethen, ATAP Thm. 19.3, read
/// for `n` nodes: `(64/15) M rho^{2 - 2n} / (rho^2 - 1)`) then gives
///
/// ```text
/// |I - I_n| <= (256/15) h |c'| |binom(1/2, n)| rho^2 / (rho^2 - 1) (eta / rho^2)^n / (1 - eta),
/// ```
///
/// tried for each `rho` of a fixed set.
#[inline(always)]
pub(crate) fn rouche_order(la: f64, lb: f64, lc: f64, h: f64, tol: f64) -> Option<usize> {
    // eta >= 1 on the smallest ellipse (a root inside it, the usual case for loops and
    // near-cusps): decided before the division below. `!(x < y)` also rejects NaN.
    if !(lb * RHO_T[0][0] + la * RHO_T[1][0] < lc) {
        return None;
    }
    // 1/|c'| as |c'| / |c'|^2 keeps the division off the path through the square root.
    let inv = 1.0 / (lc * lc);
    let inv = lc * inv;
    let scale = h * lc;
    let mut theta = [0.0; N_RHO];
    let mut room = [0.0; N_RHO];
    for k in 0..N_RHO {
        let eta = (lb * RHO_T[0][k] + la * RHO_T[1][k]) * inv;
        theta[k] = eta * RHO_T[2][k];
        // Test G theta^n scale < tol (1 - eta): false for eta >= 1 and for NaN.
        room[k] = tol * (1.0 - eta);
    }
    // eta grows with rho: when the smallest ellipse already meets a zero, all do.
    if !(room[0] > 0.0) {
        return None;
    }
    let theta2: [f64; N_RHO] = core::array::from_fn(|k| theta[k] * theta[k]);
    let theta4: [f64; N_RHO] = core::array::from_fn(|k| theta2[k] * theta2[k]);
    let theta8: [f64; N_RHO] = core::array::from_fn(|k| theta4[k] * theta4[k]);
    let mut pw: [f64; N_RHO] = core::array::from_fn(|k| theta4[k] * scale);
    for i in 0..ROUCHE_ORDERS {
        if i > 0 {
            let step = match ORDERS[i] - ORDERS[i - 1] {
                2 => &theta2,
                4 => &theta4,
                _ => &theta8,
            };
            for k in 0..N_RHO {
                pw[k] *= step[k];
            }
        }
        let mut ok = false;
        for k in 0..N_RHO {
            ok |= ROUCHE_G[i][k] * pw[k] < room[k];
        }
        if ok {
            return Some(i);
        }
    }
    None
}

/// Arc length over `[lo, hi]` (`lo <= hi`, else NaN or 0) of a curve whose hodograph is the
/// quadratic `q` (power basis), with absolute error at most `tol`: the root-free bound on the
/// whole interval first; only when it cannot pick a rule are the roots computed (`roots()` gives
/// `(lead, roots, how many)`, see [`Singularities`]) for the a-priori recursion.
#[inline]
pub(crate) fn arclen_quadratic_hodograph<S: FnOnce() -> (f64, [Complex; 2], usize)>(
    q: &[Vec2; 3],
    roots: S,
    lo: f64,
    hi: f64,
    tol: f64,
) -> f64 {
    let (l, tol) = match start_root_free(q, lo, hi, tol) {
        Ok(length) => return length,
        Err(pending) => pending,
    };
    let h = 0.5 * (hi - lo);
    // The roots here, so that their chain of square roots and divisions is under way before
    // the call below.
    let (lead, r, n) = roots();
    if n == 0 {
        // Only from a zero or non-finite hodograph: any rule is exact, NaN propagates.
        return h * l.gauss(0);
    }
    arclen_with_roots(q, &l, lead, &r[..n], lo, hi, tol)
}

/// The start of [`arclen_quadratic_hodograph`], shared with [`arclen_unit_batch`]: the length
/// when the root-free bound picks a rule (or the interval is empty or negligible), else the
/// hodograph read on the interval and the tolerance raised to the round-off floor, for the
/// root-based path.
#[inline(always)]
fn start_root_free(q: &[Vec2; 3], lo: f64, hi: f64, tol: f64) -> Result<f64, (LocalHodograph, f64)> {
    let h = 0.5 * (hi - lo);
    let m = 0.5 * (lo + hi);
    let l = LocalHodograph::new(q, m, h);
    let la = l.a.hypot();
    let lb = l.b.hypot();
    let lc = (l.c + 0.5 * l.a).hypot();
    // |B'| <= |c'| + |b| + |a|/2 on the interval (Chebyshev form): the round-off floor.
    let size = 2.0 * h * (lc + lb + 0.5 * la);
    let tol = fmax(RELATIVE_ACCURACY_FLOOR * size, sanitize_accuracy(tol));
    if let Some(i) = rouche_order(la, lb, lc, h, tol) {
        return Ok(h * l.gauss(i));
    }
    if !(hi > lo) || !(size > tol) {
        // An empty or negligible interval (any rule will do), or NaN, which propagates.
        return Ok(h * l.gauss(0));
    }
    Err((l, tol))
}

/// Curves whose roots [`arclen_unit_batch`] computes side by side.
const LANES: usize = 4;

/// Lane `k` of a `[f64; LANES]` expression, for all `k` (a loop the compiler packs).
macro_rules! lanes {
    (|$k:ident| $e:expr) => {{
        let mut v = [0.0; LANES];
        for $k in 0..LANES {
            v[$k] = $e;
        }
        v
    }};
}

/// A curve of [`arclen_unit_batch`] waiting for its roots.
#[derive(Clone, Copy)]
struct Pending {
    q: [Vec2; 3],
    l: LocalHodograph,
    tol: f64,
    index: usize,
}

/// [`arclen_quadratic_hodograph`] on `[0, 1]` for each hodograph of `qs` into `out` (as long),
/// with the same result bit for bit. Each curve first goes the same way as alone: the root-free
/// bound decides the usual spline segment at once. The curves it cannot decide wait in a group
/// of [`LANES`], whose roots ([`complex_quadratic_roots`]) are then computed lane by lane, the
/// same arithmetic in the same order: the compiler packs the lanes into vector instructions, and
/// the long chains of square roots and divisions of different curves overlap instead of running
/// one after the other. A curve whose hodograph is degenerate (the roots' special cases) goes
/// through [`arclen_quadratic_hodograph`] alone, with `roots(q)` as its roots, and so do the last
/// curves of a group that does not fill.
#[inline(always)]
pub(crate) fn arclen_unit_batch<I, R>(qs: I, accuracy: f64, out: &mut [f64], roots: &R)
where
    I: Iterator<Item = [Vec2; 3]>,
    R: Fn(&[Vec2; 3]) -> (f64, [Complex; 2], usize),
{
    let (lo, hi) = (0.0, 1.0);
    let h = 0.5 * (hi - lo);
    let m = 0.5 * (lo + hi);
    let empty = Pending {
        q: [Vec2::new(0.0, 0.0); 3],
        l: LocalHodograph::new(&[Vec2::new(0.0, 0.0); 3], m, h),
        tol: 0.0,
        index: 0,
    };
    let mut pending = [empty; LANES];
    let mut n = 0;
    for (index, q) in qs.enumerate() {
        let (l, tol) = match start_root_free(&q, lo, hi, accuracy) {
            Ok(length) => {
                out[index] = length;
                continue;
            }
            Err(pending) => pending,
        };
        pending[n] = Pending { q, l, tol, index };
        n += 1;
        if n == LANES {
            finish_lanes(&pending, out, lo, hi, accuracy, roots);
            n = 0;
        }
    }
    for p in &pending[..n] {
        out[p.index] = arclen_quadratic_hodograph(&p.q, || roots(&p.q), lo, hi, accuracy);
    }
}

/// The rest of [`arclen_quadratic_hodograph`] for a full group of [`Pending`] curves: their roots
/// side by side, then each curve's rule choice and rule.
#[inline(never)]
fn finish_lanes<R: Fn(&[Vec2; 3]) -> (f64, [Complex; 2], usize)>(
    pending: &[Pending; LANES],
    out: &mut [f64],
    lo: f64,
    hi: f64,
    accuracy: f64,
    roots: &R,
) {
    let q: [[Vec2; 3]; LANES] = core::array::from_fn(|k| pending[k].q);
    let (r, lead, degenerate) = roots_lanes(&q);
    // The first step of arclen_with_roots for every lane before any rule runs, so that the
    // lanes' table look-ups overlap too: a curve with no root to cut at whose whole interval one
    // stored rule suffices (the usual case) is then decided.
    let w = hi - lo;
    let rule: [Option<usize>; LANES] = core::array::from_fn(|k| {
        let near = |z: &Complex| (z.re > lo) & (z.re < hi) & (z.im.abs() < BRANCH_SPLIT * w);
        let cut = near(&r[k][0]) | near(&r[k][1]);
        if degenerate[k] || cut {
            None
        } else {
            branch_order(lead[k], &r[k], lo, hi, pending[k].tol, ORDERS.len() - 1)
        }
    });
    let h = 0.5 * (hi - lo);
    for (k, p) in pending.iter().enumerate() {
        out[p.index] = match rule[k] {
            Some(i) => h * p.l.gauss_shared(i),
            None if degenerate[k] => arclen_quadratic_hodograph(&p.q, || roots(&p.q), lo, hi, accuracy),
            None => arclen_with_roots(&p.q, &p.l, lead[k], &r[k], lo, hi, p.tol),
        };
    }
}

/// [`complex_quadratic_roots`] of each lane's hodograph (`lead` and two roots, as
/// `CubicBez`'s arc length computes them), lane by lane without branches; `true` marks a lane
/// that hits one of its special cases (fewer than two roots, a zero `q`, or the second root
/// taken as `c / q`), whose values are then meaningless.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn roots_lanes(q: &[[Vec2; 3]; LANES]) -> ([[Complex; 2]; LANES], [f64; LANES], [bool; LANES]) {
    let (are, aim) = (lanes!(|k| q[k][0].x), lanes!(|k| q[k][0].y));
    let (bre, bim) = (lanes!(|k| q[k][1].x), lanes!(|k| q[k][1].y));
    let (cre, cim) = (lanes!(|k| q[k][2].x), lanes!(|k| q[k][2].y));
    let na = lanes!(|k| are[k] * are[k] + aim[k] * aim[k]);
    let nb = lanes!(|k| bre[k] * bre[k] + bim[k] * bim[k]);
    let nc = lanes!(|k| cre[k] * cre[k] + cim[k] * cim[k]);
    let mut degenerate = [false; LANES];
    for k in 0..LANES {
        let scale2 = fmax(fmax(na[k], nb[k]), nc[k]);
        degenerate[k] = !(scale2 > 0.0) || !scale2.is_finite() || na[k] <= 1e-28 * scale2;
    }
    let inv_a = lanes!(|k| 1.0 / na[k]);
    // w = b^2 - 4 a c
    let wre = lanes!(|k| (bre[k] * bre[k] - bim[k] * bim[k]) - (are[k] * cre[k] - aim[k] * cim[k]) * 4.0);
    let wim = lanes!(|k| (bre[k] * bim[k] + bim[k] * bre[k]) - (are[k] * cim[k] + aim[k] * cre[k]) * 4.0);
    let mm = lanes!(|k| (wre[k] * wre[k] + wim[k] * wim[k]).sqrt() + wre[k].abs());
    let inv_m = lanes!(|k| 1.0 / mm[k]);
    let s = lanes!(|k| (0.5 * mm[k]).sqrt());
    let t = lanes!(|k| if mm[k] > 0.0 { wim[k] * s[k] * inv_m[k] } else { 0.0 });
    let dre = lanes!(|k| if wre[k] >= 0.0 { s[k] } else { t[k].abs() });
    let dim = lanes!(|k| if wre[k] >= 0.0 {
        t[k]
    } else if wim[k] < 0.0 {
        -s[k]
    } else {
        s[k]
    });
    let plus = lanes!(|k| (bre[k] * dre[k] + bim[k] * dim[k] >= 0.0) as u8 as f64);
    let qre = lanes!(|k| if plus[k] > 0.0 {
        bre[k] + dre[k]
    } else {
        bre[k] - dre[k]
    } * -0.5);
    let qim = lanes!(|k| if plus[k] > 0.0 {
        bim[k] + dim[k]
    } else {
        bim[k] - dim[k]
    } * -0.5);
    let (care, caim) = (lanes!(|k| are[k] * inv_a[k]), lanes!(|k| -aim[k] * inv_a[k]));
    let r1re = lanes!(|k| qre[k] * care[k] - qim[k] * caim[k]);
    let r1im = lanes!(|k| qre[k] * caim[k] + qim[k] * care[k]);
    let nq = lanes!(|k| qre[k] * qre[k] + qim[k] * qim[k]);
    // r2 = -b / a - r1. When |r2| is far below |r1| the scalar code takes c / q instead (no
    // cancellation); such lanes, rare, go the scalar way as degenerate ones do.
    let sum_re = lanes!(|k| (-bre[k]) * care[k] - (-bim[k]) * caim[k] - r1re[k]);
    let sum_im = lanes!(|k| (-bre[k]) * caim[k] + (-bim[k]) * care[k] - r1im[k]);
    let lead = lanes!(|k| na[k].sqrt());
    let mut r = [[Complex::new(0.0, 0.0); 2]; LANES];
    for k in 0..LANES {
        // A NaN fails the comparison too.
        degenerate[k] |= nq[k] == 0.0 || !(nc[k] * na[k] >= 1e-8 * nq[k] * nq[k]);
        r[k] = [Complex::new(r1re[k], r1im[k]), Complex::new(sum_re[k], sum_im[k])];
    }
    (r, lead, degenerate)
}

/// The part of [`arclen_quadratic_hodograph`] after the root-free bound, kept out of line so
/// that the smooth-segment path stays small enough to inline.
#[inline(never)]
fn arclen_with_roots(
    q: &[Vec2; 3],
    l: &LocalHodograph,
    lead: f64,
    roots: &[Complex],
    lo: f64,
    hi: f64,
    tol: f64,
) -> f64 {
    let h = 0.5 * (hi - lo);
    let sing = Singularities { lead, roots };
    // Cut at the real part of every root close to the inside of the interval: the near-cusp
    // then sits at an end of its piece, where a low-order rule copes with it.
    let w = hi - lo;
    let mut cuts = [lo, hi, hi, hi];
    let mut pieces = 1;
    for z in roots {
        if z.re > lo && z.re < hi && z.im.abs() < BRANCH_SPLIT * w {
            cuts[pieces] = z.re;
            pieces += 1;
        }
    }
    // Unless a small rule suffices over the whole interval (a piece costs more than a few
    // evaluations).
    let max = if pieces == 1 { ORDERS.len() - 1 } else { WHOLE_MAX };
    if let Some(i) = branch_order(lead, roots, lo, hi, tol, max) {
        return h * l.gauss(i);
    }
    if pieces == 1 {
        let mut leaves = 0;
        return hodograph_rec(q, &sing, lo, hi, tol, MAX_DEPTH, &mut leaves).0;
    }
    if pieces == 3 && cuts[2] < cuts[1] {
        cuts.swap(1, 2);
    }
    cuts[pieces] = hi;
    let inv_w = 1.0 / w;
    let mut sum = 0.0;
    let mut leaves = 0;
    for k in 0..pieces {
        let (a, b) = (cuts[k], cuts[k + 1]);
        let share = tol * ((b - a) * inv_w);
        sum += match branch_order(lead, roots, a, b, share, ORDERS.len() - 1) {
            Some(i) => {
                let h = 0.5 * (b - a);
                h * LocalHodograph::new(q, 0.5 * (a + b), h).gauss(i)
            }
            None => hodograph_rec(q, &sing, a, b, share, MAX_DEPTH, &mut leaves).0,
        };
    }
    sum
}

/// Roots closer to the real axis than this fraction of the interval, with the real part inside,
/// are cut at; farther ones stay inside their piece and read [`BRANCH_IN`] (which covers
/// `eps >= BRANCH_IN_MIN_EPS`, far below this). 0.15 rather than 0.25: roots between cost fewer
/// points uncut at tight accuracies (random cubics vs kurbo, interleaved: 1e-9 1.58x -> 1.66x,
/// 1e-12 1.87x -> 1.91x), and the same at 1e-3.
const BRANCH_SPLIT: f64 = 0.15;
/// Largest rule (index into [`ORDERS`], 32 points) taken over a whole interval that has a root to
/// cut at: one piece of 32 points costs less than two of 16 (the typical arc at `1e-12`).
const WHOLE_MAX: usize = 8;
/// Safety factor on the tabulated model errors of [`branch_order`].
const BRANCH_SAFETY: f64 = 2.0;

/// Bin of `eps` in the branch tables: its binary exponent (clamped to the tabulated range) and
/// the top [`BRANCH_SUB_BITS`] bits of its mantissa, which split the octave into eighths.
#[inline(always)]
fn branch_bin(eps: f64) -> usize {
    let bits = eps.to_bits();
    let e = ((bits >> 52) & 0x7ff) as i32 - 1023;
    let top = ((bits >> (52 - BRANCH_SUB_BITS)) & ((1 << BRANCH_SUB_BITS) - 1)) as usize;
    if e < BRANCH_KMIN {
        return 0;
    }
    if e > BRANCH_KMAX {
        return (((BRANCH_KMAX - BRANCH_KMIN + 1) as usize) << BRANCH_SUB_BITS) - 1;
    }
    (((e - BRANCH_KMIN) as usize) << BRANCH_SUB_BITS) + top
}

/// The smallest rule whose estimated error on `[a, b]` is at most `tol`, from the tabulated
/// errors of the near-cusp model (`tools/gen_branch_tables.py`): the speed is
/// `lead prod_j |t - r_j|`, and root `j` contributes the error of the rule on
/// `|t - r_j| = L sqrt((x - x_j)^2 + eps_j^2)` (`t = a + L x`, `eps_j = |Im r_j| / L`) times a bound of
/// the other factor on the piece, `|c - r_o| + h`. A root at or beyond an end reads
/// [`BRANCH_OUT`] (the model's worst case over all such positions), one inside [`BRANCH_IN`]
/// (worst case over the inside, infinite for `eps_j < BRANCH_IN_MIN_EPS`: closer roots must have
/// been cut at). `None`: no rule up to `ORDERS[max]` qualifies (the caller subdivides).
#[inline(always)]
pub(crate) fn branch_order(lead: f64, roots: &[Complex], a: f64, b: f64, tol: f64, max: usize) -> Option<usize> {
    let l = b - a;
    let h = 0.5 * l;
    let c = 0.5 * (a + b);
    let inv_l = 1.0 / l;
    let scale = BRANCH_SAFETY * l * l * lead;
    // Index into BRANCH_ALL: the out table's rows, then the in table's.
    let row = |z: &Complex| ((z.re > a && z.re < b) as usize) * BRANCH_ROWS + branch_bin(z.im.abs() * inv_l);
    let i0 = row(&roots[0]);
    let (amp0, amp1, i1) = if roots.len() < 2 {
        (scale, 0.0, i0)
    } else {
        // The amplitude of root j is the other factor |z - r_o| near r_j and on the piece, at most
        // |c - r_o| + max(h, |r_j - c|) (|c - r| <= |Re| + |Im|): a far root sees the other
        // factor's value out there, not on the interval.
        let (r0, r1) = (roots[0], roots[1]);
        let (d0, d1) = ((c - r0.re).abs() + r0.im.abs(), (c - r1.re).abs() + r1.im.abs());
        (scale * (d1 + fmax(d0, h)), scale * (d0 + fmax(d1, h)), row(&r1))
    };
    let (t0, t1) = (&BRANCH_ALL[i0], &BRANCH_ALL[i1]);
    let est = |i: usize| amp0 * t0[i] + amp1 * t1[i];
    // Start the search at a lower bound of the answer read from the exponents: each term alone
    // must fit (see [`BRANCH_START`]).
    let e_tol = exponent(tol);
    let start = |r: usize, amp: f64| {
        let k = (e_tol - exponent(amp)).clamp(START_KMIN, START_KMAX);
        BRANCH_START[r][(k - START_KMIN) as usize] as usize
    };
    let (s0, s1) = (start(i0, amp0), start(i1, amp1));
    let mut i = if s0 > s1 { s0 } else { s1 };
    i = if i < max { i } else { max };
    // `!(x <= tol)` also rejects NaN.
    while i < max && !(est(i) <= tol) {
        i += 1;
    }
    if !(est(i) <= tol) {
        return None;
    }
    Some(i)
}

/// The binary exponent of `|x|` (`-1023` for zero and subnormals, `1024` for infinities and NaN).
#[inline(always)]
fn exponent(x: f64) -> i64 {
    ((x.to_bits() >> 52) & 0x7ff) as i64 - 1023
}

/// Rows of [`BRANCH_OUT`] (and of [`BRANCH_IN`]).
const BRANCH_ROWS: usize = BRANCH_OUT.len();

/// [`BRANCH_OUT`]'s rows, then [`BRANCH_IN`]'s.
static BRANCH_ALL: [[f64; 11]; 2 * BRANCH_ROWS] = {
    let mut t = [[0.0; 11]; 2 * BRANCH_ROWS];
    let mut r = 0;
    while r < BRANCH_ROWS {
        t[r] = BRANCH_OUT[r];
        t[BRANCH_ROWS + r] = BRANCH_IN[r];
        r += 1;
    }
    t
};

/// Range of `k = e(tol) - e(amp)` in [`BRANCH_START`] (clamped to it): the finite tabulated
/// errors lie between `2^-55` and `2^-5`.
const START_KMIN: i64 = -58;
const START_KMAX: i64 = -4;
const START_NK: usize = (START_KMAX - START_KMIN + 1) as usize;

/// `[row][k - START_KMIN]` for a row of [`BRANCH_ALL`]: the first order whose error in the row is
/// below `2^(k + 1)`. When the exponents of `tol` and `amp` differ by `k`, `tol / amp < 2^(k + 1)`,
/// so no earlier order has `amp t[i] <= tol`: a lower bound of [`branch_order`]'s answer. It holds
/// for `k` clamped to the range too: below it the bound only weakens, and above it every finite
/// entry is below `2^(START_KMAX + 1)` (the entry is 0; rows of infinities read `11`).
static BRANCH_START: [[u8; START_NK]; 2 * BRANCH_ROWS] = {
    let mut out = [[0u8; START_NK]; 2 * BRANCH_ROWS];
    let mut r = 0;
    while r < 2 * BRANCH_ROWS {
        let mut c = 0;
        while c < START_NK {
            // 2^(k + 1) for k = START_KMIN + c
            let limit = f64::from_bits(((START_KMIN + c as i64 + 1 + 1023) as u64) << 52);
            let mut i = 0;
            while i < 11 && !(BRANCH_ALL[r][i] < limit) {
                i += 1;
            }
            out[r][c] = i as u8;
            c += 1;
        }
        r += 1;
    }
    out
};

/// The a-priori recursion of [`apriori_rec`], specialised to a quadratic hodograph. Returns the
/// length and a bound of its error; the right half of a split inherits what the left half's
/// bound left unused of its share.
fn hodograph_rec(
    q: &[Vec2; 3],
    sing: &Singularities<'_>,
    a: f64,
    b: f64,
    tol: f64,
    depth: u32,
    leaves: &mut u32,
) -> (f64, f64) {
    let h = 0.5 * (b - a);
    let c = 0.5 * (a + b);
    let l = LocalHodograph::new(q, c, h);
    match apriori_choice(sing, a, b, tol) {
        Choice::Rule(i, err) => (h * l.gauss(i), err),
        Choice::Split(p) => {
            *leaves += 2;
            if depth == 0 || *leaves > MAX_LEAVES {
                return (h * l.gauss(RULES.len() - 1), tol);
            }
            let tl = tol * (p - a) / (b - a);
            let (vl, el) = hodograph_rec(q, sing, a, p, tl, depth - 1, leaves);
            let (vr, er) = hodograph_rec(q, sing, p, b, tol - el.min(tl), depth - 1, leaves);
            (vl + vr, el.min(tl) + er)
        }
    }
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
    let rule: &[(f64, f64)] = &GL16;
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
/// `s`, given the lengths `lo.1`, `hi.1` at the bracket ends; safeguarded Halley iteration on
/// `f(t) = L(t) - s` that integrates only increments (`range(t0, t1, accuracy)`), with
/// `speed(t) = (|B'(t)|, d|B'(t)|/dt)` (`f'` and `f''`; a zero `f''` makes the step Newton's).
/// Halley's step `t - 2 f f' / (2 f'^2 - f f'')` triples the correct digits where Newton's
/// doubles them: one increment fewer from the usual first guess (each costs a quadrature).
pub(crate) fn solve_arclen<S: Fn(f64) -> (f64, f64), R: Fn(f64, f64, f64) -> f64>(
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
        let (v, dv) = speed(t);
        let denom = 2.0 * v * v - err * dv;
        // Halley where its denominator keeps the sign of Newton's, else Newton.
        let mut tn = if denom > v * v {
            t - 2.0 * err * v / denom
        } else {
            t - err / v
        };
        if !(tn > lo && tn < hi) {
            // The step left the bracket (or the speed vanished): regula falsi if it makes real
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

/// Default inverse arc length for any curve given its total length (see
/// `ParamCurveArclen::inv_arclen`).
pub(crate) fn inv_arclen_with<S: Fn(f64) -> (f64, f64), R: Fn(f64, f64, f64) -> f64>(
    speed: S,
    range: R,
    s: f64,
    total: f64,
    accuracy: f64,
) -> f64 {
    if !(total > 0.0) || !(s > 0.0) {
        return 0.0;
    }
    // Within half the accuracy of the end (`total` itself is within a quarter of it): the end,
    // so that `s` from `arclen` at another accuracy still maps to exactly 1.
    if s >= total - 0.5 * accuracy {
        return 1.0;
    }
    solve_arclen(speed, range, s, (0.0, 0.0), (1.0, total), s / total, accuracy)
}

/// Parameters of `n` points equally spaced in arc length (see `ParamCurveArclen::resample_uniform`).
pub(crate) fn resample_with<S: Fn(f64) -> (f64, f64), R: Fn(f64, f64, f64) -> f64>(
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

    /// A seeded uniform generator on `[0, 1)` (a 64-bit LCG's top 53 bits): the tests need no
    /// `rand` for their random curves.
    fn lcg(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The AVX2 + FMA and AVX-512 sums (where the CPU has them) agree with the portable one to a
    /// few ulps on every rule, at every scale, with a node on a cusp; they decline non-finite and
    /// tiny curves.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn simd_sums_match_the_portable_sum() {
        use crate::gauss_simd::Simd;
        let tokens: Vec<Simd> = [
            pulp::x86::V3::try_new().map(Simd::V3),
            pulp::x86::V4::try_new().map(Simd::V4),
        ]
        .into_iter()
        .flatten()
        .collect();
        if tokens.is_empty() {
            eprintln!("no AVX2 + FMA on this CPU: only the portable sum runs");
            return;
        }
        fn both<const K: usize>(simd: Simd, l: &LocalHodograph, rule: &Soa<K>) -> (Option<f64>, f64) {
            (
                crate::gauss_simd::gauss(simd, l.a, l.b, l.c, &rule.x, &rule.w),
                l.gauss_portable(rule),
            )
        }
        fn all(simd: Simd, l: &LocalHodograph) -> [(Option<f64>, f64); 11] {
            [
                both(simd, l, &S4),
                both(simd, l, &S6),
                both(simd, l, &S8),
                both(simd, l, &S10),
                both(simd, l, &S12),
                both(simd, l, &S16),
                both(simd, l, &S20),
                both(simd, l, &S24),
                both(simd, l, &S32),
                both(simd, l, &S48),
                both(simd, l, &S64),
            ]
        }
        let close = |got: Option<f64>, want: f64| got.is_some_and(|g| (g - want).abs() <= 1e-15 * want);
        for &simd in &tokens {
            let mut rnd = lcg(7);
            let mut v = || Vec2::new(2.0 * rnd() - 1.0, 2.0 * rnd() - 1.0);
            for _ in 0..300 {
                let (a, b, c) = (v(), v(), v());
                for scale in [1e-120, 1e-8, 1.0, 1e8, 1e120] {
                    let l = LocalHodograph {
                        a: a * scale,
                        b: b * scale,
                        c: c * scale,
                    };
                    for (i, (got, want)) in all(simd, &l).into_iter().enumerate() {
                        assert!(
                            close(got, want),
                            "{simd:?} rule {i}, scale {scale:e}: {got:?} vs {want:e}"
                        );
                    }
                }
            }
            // Speeds of exactly zero: the zero hodograph (declined as tiny), and
            // B'(x) = x^2 - x_j^2 for every node x_j of every rule, zero at +-x_j (both the
            // square-root lane and the Newton lane, in every group and tail).
            let zero = LocalHodograph {
                a: Vec2::new(0.0, 0.0),
                b: Vec2::new(0.0, 0.0),
                c: Vec2::new(0.0, 0.0),
            };
            assert!(all(simd, &zero).iter().all(|&(got, want)| got.is_none() && want == 0.0));
            for (i, rule) in RULES.iter().enumerate() {
                for &(xj, _) in rule.iter() {
                    let l = LocalHodograph {
                        a: Vec2::new(1.0, 0.0),
                        b: Vec2::new(0.0, 0.0),
                        c: Vec2::new(-xj * xj, 0.0),
                    };
                    let (got, want) = all(simd, &l)[i];
                    assert!(close(got, want), "{simd:?} rule {i}, cusp at {xj}: {got:?} vs {want:e}");
                }
            }
            // Non-finite and tiny hodographs are declined.
            for bad in [f64::NAN, f64::INFINITY, 1e-200] {
                let l = LocalHodograph {
                    a: Vec2::new(bad, 0.0),
                    b: Vec2::new(0.0, bad),
                    c: Vec2::new(bad, bad),
                };
                assert!(all(simd, &l).iter().all(|(got, _)| got.is_none()), "{simd:?} {bad:e}");
            }
        }
    }

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

    /// Hodographs of cubics (power basis) from a small LCG: control points in `[-1, 1]^2`
    /// (loops, cusps, S-shapes) and nearly straight, spline-like ones.
    fn test_hodographs() -> Vec<[Vec2; 3]> {
        let mut unit = lcg(0x853C_49E6_748F_EA9B);
        let mut next = || 2.0 * unit() - 1.0;
        let mut out = Vec::new();
        for i in 0..400 {
            // Control points: a chord along x plus perturbations of growing size.
            let spread = [0.05, 0.2, 0.5, 1.0][i % 4];
            let p: [Vec2; 4] = core::array::from_fn(|k| Vec2::new(k as f64 / 3.0 + spread * next(), spread * next()));
            let (d0, d1, d2) = (p[1] - p[0], p[2] - p[1], p[3] - p[2]);
            out.push([3.0 * (d0 - 2.0 * d1 + d2), 6.0 * (d1 - d0), 3.0 * d0]);
        }
        out
    }

    /// Reference length on `[0, 1]`: 256 pieces of the 64-point rule (the curves where the
    /// root-free bound answers are analytic well beyond each piece).
    fn reference(q: &[Vec2; 3]) -> f64 {
        let n = 256;
        (0..n)
            .map(|i| {
                let h = 0.5 / n as f64;
                let m = (2 * i + 1) as f64 * h;
                h * LocalHodograph::new(q, m, h).gauss(RULES.len() - 1)
            })
            .sum()
    }

    /// The root-free (Rouché) bound is a bound: whenever it picks a rule, the rule's error is
    /// within the tolerance, over loops, cusps and smooth cubics and a range of tolerances.
    #[test]
    fn root_free_bound_is_never_exceeded() {
        let mut answered = 0;
        for q in test_hodographs() {
            let reference = reference(&q);
            let l = LocalHodograph::new(&q, 0.5, 0.5);
            let (la, lb, lc) = (l.a.hypot(), l.b.hypot(), (l.c + 0.5 * l.a).hypot());
            for tol in [1e-3, 1e-6, 1e-9, 1e-12] {
                if let Some(i) = rouche_order(la, lb, lc, 0.5, tol) {
                    answered += 1;
                    let err = (0.5 * l.gauss(i) - reference).abs();
                    assert!(
                        err <= tol + 1e-14 * reference,
                        "{q:?} tol {tol}: order {} err {err:e}",
                        ORDERS[i]
                    );
                }
            }
        }
        // It answers for most of these (the rest go to the root-based path).
        assert!(answered > 400, "answered {answered} of 1600");
    }

    /// Regression guard for the a-priori bound: `n` nodes are exact to degree `2n - 1`, so the
    /// Chebyshev tail starts at `T_{2n}` and the bound is `(64/15) M rho^{2 - 2n} / (rho^2 - 1)`
    /// (Trefethen's theorem is stated for `n + 1` nodes; reading it for `n` was optimistic by
    /// `rho^2`). On an integrand with a known closed form the chosen rule meets the tolerance.
    #[test]
    fn apriori_bound_counts_nodes_not_nodes_plus_one() {
        // |t - r| with r = 0.5 + 0.3i on [0, 1]: a root close to the interval.
        let roots = [Complex::new(0.5, 0.3)];
        let sing = Singularities {
            lead: 1.0,
            roots: &roots,
        };
        let f = |t: f64| ((t - 0.5) * (t - 0.5) + 0.09).sqrt();
        let exact = {
            // int sqrt(u^2 + c^2) du = (u sqrt(u^2 + c^2) + c^2 asinh(u / c)) / 2 on [-1/2, 1/2]
            let g = |u: f64| 0.5 * (u * (u * u + 0.09).sqrt() + 0.09 * (u / 0.3).asinh());
            g(0.5) - g(-0.5)
        };
        for tol in [1e-4, 1e-8, 1e-12] {
            let Choice::Rule(i, bound) = apriori_choice(&sing, 0.0, 1.0, tol) else {
                panic!("no rule at {tol}");
            };
            let err = (gauss(RULES[i], 0.0, 1.0, &f) - exact).abs();
            assert!(
                err <= bound && bound <= tol,
                "tol {tol}: {} points err {err:e} bound {bound:e}",
                ORDERS[i]
            );
        }
    }

    /// Smooth spline-like segments take the root-free path: one rule, no subdivision, and few
    /// points (what makes them fast).
    #[test]
    fn smooth_segments_use_one_small_rule() {
        let mut evals = 0;
        let mut count = 0;
        for q in test_hodographs().iter().step_by(4) {
            // spread 0.05: nearly straight, gently curved
            let tol = 1e-9;
            counters::take();
            let len = arclen_quadratic_hodograph(q, || panic!("roots computed for a smooth segment"), 0.0, 1.0, tol);
            let (e, rules) = counters::take();
            assert_eq!(rules, 1);
            assert!((len - reference(q)).abs() <= tol);
            evals += e;
            count += 1;
        }
        assert!(evals <= 12 * count, "mean evaluations {}", evals as f64 / count as f64);
    }

    /// Regression guard for [`APRIORI_GAIN`] (the calibrated, no longer proven, a-priori
    /// estimate): on a seeded set of random cubics (control points uniform in `[-1, 1]^2`: loops,
    /// S-shapes, near-cusps) every length meets the requested accuracy, with a margin, against an
    /// independent reference (a-posteriori adaptive 16-point Gauss at `1e-15`); and the work
    /// still adapts to the request (fewer evaluations at looser accuracies).
    #[test]
    fn requested_accuracy_is_met_on_random_cubics() {
        let mut unit = lcg(0x1234_5678_9ABC_DEF1);
        let mut next = || 2.0 * unit() - 1.0;
        let qs: Vec<[Vec2; 3]> = (0..1000)
            .map(|_| {
                let p: [Vec2; 4] = core::array::from_fn(|_| Vec2::new(next(), next()));
                let (d0, d1, d2) = (p[1] - p[0], p[2] - p[1], p[3] - p[2]);
                [3.0 * (d0 - 2.0 * d1 + d2), 6.0 * (d1 - d0), 3.0 * d0]
            })
            .collect();
        let roots = |q: &[Vec2; 3]| {
            let z = |v: Vec2| Complex::new(v.x, v.y);
            let (r, n) = complex_quadratic_roots(z(q[0]), z(q[1]), z(q[2]));
            let lead = match n {
                2 => q[0].hypot(),
                1 => q[1].hypot(),
                _ => q[2].hypot(),
            };
            (lead, r, n)
        };
        let refs: Vec<f64> = qs
            .iter()
            .map(|q| {
                let f = |t: f64| ((q[0] * t + q[1]) * t + q[2]).hypot();
                integrate_adaptive(&f, 0.0, 1.0, 1e-15, 1.0)
            })
            .collect();
        let mut evals = Vec::new();
        for tol in [1e-4, 1e-6, 1e-9, 1e-12] {
            counters::take();
            for (q, r) in qs.iter().zip(&refs) {
                // Whole curve and a sub-range (what inverse arc length integrates).
                let v = arclen_quadratic_hodograph(q, || roots(q), 0.0, 1.0, tol);
                let err = (v - r).abs();
                assert!(err <= 0.5 * tol + 4e-15 * r, "{q:?} tol {tol:e}: err {err:e}");
                let f = |t: f64| ((q[0] * t + q[1]) * t + q[2]).hypot();
                let sub_ref = integrate_adaptive(&f, 0.3, 0.8, 1e-15, 1.0);
                let sub = arclen_quadratic_hodograph(q, || roots(q), 0.3, 0.8, tol);
                let err = (sub - sub_ref).abs();
                assert!(
                    err <= 0.5 * tol + 4e-15 * r,
                    "{q:?} [0.3, 0.8] tol {tol:e}: err {err:e}"
                );
            }
            evals.push(counters::take().0);
        }
        assert!(evals.windows(2).all(|w| w[0] < w[1]), "evaluations {evals:?}");
    }

    /// The branch tables hold what `tools/gen_branch_tables.py` claims: the error of each rule
    /// on the near-cusp model `sqrt((x - x0)^2 + eps^2)` over `[0, 1]` stays within the entry of
    /// its `eps` bin, for branch points at or beyond an end (`BRANCH_OUT`) and inside
    /// (`BRANCH_IN`, from `BRANCH_IN_MIN_EPS` on), at positions and sizes the generator did not
    /// sample; and the entries do not grow with the order.
    #[test]
    fn branch_tables_bound_the_model_error() {
        use crate::branch_tables::BRANCH_IN_MIN_EPS;
        // int sqrt(u^2 + e^2) du in closed form
        let prim = |u: f64, e: f64| 0.5 * (u * (u * u + e * e).sqrt() + e * e * (u / e).asinh());
        let mut next = lcg(0x5DEE_CE66_D1CE_4E5B);
        let mut checked = 0;
        for _ in 0..3000 {
            let eps = 2f64.powf(-30.0 + 33.0 * next());
            let inside = next() < 0.5;
            let x0 = if inside { next() } else { -(4.0 * next()).powi(3) / 16.0 };
            if inside && eps < BRANCH_IN_MIN_EPS {
                continue;
            }
            let exact = prim(1.0 - x0, eps) - prim(-x0, eps);
            let f = |x: f64| ((x - x0) * (x - x0) + eps * eps).sqrt();
            let row = if inside { &BRANCH_IN } else { &BRANCH_OUT }[branch_bin(eps)];
            for i in 0..ORDERS.len() {
                let err = (gauss(RULES[i], 0.0, 1.0, &f) - exact).abs();
                // Round-off of the closed form and the sum: a few ulps of the integral.
                assert!(
                    err <= row[i] + 8.0 * f64::EPSILON * exact,
                    "x0 {x0} eps {eps:e}: {} points err {err:e} > table {:e}",
                    ORDERS[i],
                    row[i]
                );
                if i > 0 {
                    assert!(row[i] <= row[i - 1]);
                }
                checked += 1;
            }
        }
        assert!(checked > 20_000);
    }

    /// The search in [`branch_order`] starts at the lower bound read from [`BRANCH_START`]; it
    /// finds the same rule as a plain search from the smallest order, over random roots, pieces,
    /// accuracies (`1e-16` to `10`, and zero), caps and sizes, including roots on the real axis,
    /// far away, a zero leading coefficient and non-finite input.
    #[test]
    fn branch_order_start_table_matches_plain_search() {
        let plain = |lead: f64, roots: &[Complex], a: f64, b: f64, tol: f64, max: usize| {
            let (l, h, c) = (b - a, 0.5 * (b - a), 0.5 * (a + b));
            let scale = BRANCH_SAFETY * l * l * lead;
            let row = |z: &Complex| {
                let t = if z.re > a && z.re < b { &BRANCH_IN } else { &BRANCH_OUT };
                t[branch_bin(z.im.abs() / l)]
            };
            let (amp0, amp1, t0, t1) = if roots.len() < 2 {
                (scale, 0.0, row(&roots[0]), row(&roots[0]))
            } else {
                let (r0, r1) = (roots[0], roots[1]);
                let (d0, d1) = ((c - r0.re).abs() + r0.im.abs(), (c - r1.re).abs() + r1.im.abs());
                (scale * (d1 + d0.max(h)), scale * (d0 + d1.max(h)), row(&r0), row(&r1))
            };
            (0..=max).find(|&i| amp0 * t0[i] + amp1 * t1[i] <= tol)
        };
        let mut next = lcg(0x2545_F491_4F6C_DD1D);
        let mut found = [0usize; 12];
        for k in 0..200_000 {
            let mut z = || {
                let im = [0.0, 1e-12, 1e-6, 1e-3, 0.05, 0.3, 2.0][(7.0 * next()) as usize] * (2.0 * next() - 1.0);
                Complex::new(4.0 * next() - 1.5, im)
            };
            let roots = [z(), z()];
            let n = 1 + (k % 7 != 0) as usize;
            let a = next() - 0.2;
            let b = a + 10f64.powf(-4.0 * next());
            let tol = match k % 101 {
                0 => 0.0,
                _ => 10f64.powf(1.0 - 17.0 * next()),
            };
            let lead = match k % 97 {
                0 => 0.0,
                1 => f64::NAN,
                2 => f64::INFINITY,
                _ => 10f64.powf(6.0 * next() - 3.0),
            };
            let max = [WHOLE_MAX, ORDERS.len() - 1, 0, 3][k % 4];
            let got = branch_order(lead, &roots[..n], a, b, tol, max);
            let want = plain(lead, &roots[..n], a, b, tol, max);
            assert_eq!(got, want, "{lead} {roots:?} n {n} [{a}, {b}] tol {tol:e} max {max}");
            found[got.map_or(11, |i| i)] += 1;
        }
        // Every order is reached, and some cases have no rule.
        assert!(found.iter().all(|&f| f > 0), "{found:?}");
    }

    /// Reference length for the adversarial tests, independent of the rule choice: adaptive
    /// 16-point Gauss on 64 equal pieces, also cut at every root's real part.
    fn reference_range(q: &[Vec2; 3], a: f64, b: f64) -> f64 {
        let f = |t: f64| ((q[0] * t + q[1]) * t + q[2]).hypot();
        let z = |v: Vec2| Complex::new(v.x, v.y);
        let (r, n) = complex_quadratic_roots(z(q[0]), z(q[1]), z(q[2]));
        let mut cuts: Vec<f64> = (0..=64).map(|i| a + (b - a) * i as f64 / 64.0).collect();
        cuts.extend(r[..n].iter().map(|z| z.re).filter(|&p| p > a && p < b));
        cuts.sort_by(f64::total_cmp);
        let crude: f64 = cuts.windows(2).map(|w| gauss16(w[0], w[1], &f)).sum();
        cuts.windows(2)
            .map(|w| integrate_adaptive(&f, w[0], w[1], 1e-17 * crude, crude))
            .sum()
    }

    fn hodograph_of(p: [(f64, f64); 4]) -> [Vec2; 3] {
        let p: [Vec2; 4] = core::array::from_fn(|k| Vec2::new(p[k].0, p[k].1));
        let (d0, d1, d2) = (p[1] - p[0], p[2] - p[1], p[3] - p[2]);
        [3.0 * (d0 - 2.0 * d1 + d2), 6.0 * (d1 - d0), 3.0 * d0]
    }

    /// The cut-at-the-root path on adversarial cubics: exact and near cusps (the hodograph's root
    /// `1e-14` to `1e-1` off the real axis, inside the range, at its ends and just beyond them),
    /// loops, coincident control points, straight lines that reverse, and scaled copies; whole
    /// curve and sub-ranges, accuracies `1e-2` to `1e-12`: the error stays within the request
    /// (above the relative round-off floor).
    #[test]
    fn near_cusps_and_degenerate_cubics_meet_the_request() {
        let mut curves: Vec<[(f64, f64); 4]> = vec![
            [(0.0, 0.0), (1.0, 1.0), (0.0, 1.0), (1.0, 0.0)], // exact cusp at t = 1/2
            [(0.0, 0.0), (2.0, 1.0), (-1.0, 1.0), (1.0, 0.0)], // loop
            [(0.0, 0.0), (0.0, 0.0), (1.0, 1.0), (2.0, 0.0)], // p0 = p1
            [(0.0, 0.0), (1.0, 1.0), (2.0, 0.0), (2.0, 0.0)], // p2 = p3
            [(0.0, 0.0), (0.0, 0.0), (1.0, 0.0), (1.0, 0.0)], // p0 = p1, p2 = p3
            [(1.0, 2.0), (1.0, 2.0), (1.0, 2.0), (1.0, 2.0)], // a point
            [(0.0, 0.0), (3.0, 0.0), (-1.0, 0.0), (2.0, 0.0)], // a line that reverses twice
            [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0)], // uniform line
            [(0.0, 0.0), (2.0, 2.0), (-1.0, 2.0), (1.0, 0.0)], // loop touching itself
            // Elevated quadratics (a linear hodograph, one root): the parabola y = x^2 and a
            // segment that turns back at t = 1/2.
            [(0.0, 0.0), (1.0 / 3.0, 0.0), (2.0 / 3.0, 1.0 / 3.0), (1.0, 1.0)],
            [(0.0, 0.0), (2.0 / 3.0, 0.0), (2.0 / 3.0, 0.0), (0.0, 0.0)],
        ];
        // Near-cusps: the cusp curve with p2 moved by delta (the root leaves the real axis by
        // about delta), and the cusp moved along the parameter.
        for &delta in &[1e-14, 1e-10, 1e-7, 1e-5, 1e-3, 1e-2, 1e-1, 0.2] {
            for &shift in &[0.0, 0.3, -0.45] {
                let p2 = (0.0 + shift, 1.0 + delta);
                curves.push([(0.0, 0.0), (1.0 + shift, 1.0), p2, (1.0, 0.0)]);
            }
        }
        let scaled: Vec<[(f64, f64); 4]> = curves
            .iter()
            .flat_map(|c| [1e-4, 1e3].map(|s| c.map(|(x, y)| (s * x, s * y))))
            .collect();
        curves.extend(scaled);
        let mut checked = 0;
        for c in &curves {
            let q = hodograph_of(*c);
            let z = |v: Vec2| Complex::new(v.x, v.y);
            let (r, n) = complex_quadratic_roots(z(q[0]), z(q[1]), z(q[2]));
            let lead = match n {
                2 => q[0].hypot(),
                1 => q[1].hypot(),
                _ => q[2].hypot(),
            };
            // Ranges: the whole curve, ranges ending at, just before and just after each root.
            let mut ranges = vec![(0.0, 1.0), (0.3, 0.8)];
            for z in &r[..n] {
                let p = z.re.clamp(0.0, 1.0);
                for e in [0.0, 1e-9, 1e-3, -1e-9, -1e-3] {
                    let p = (p + e).clamp(0.0, 1.0);
                    ranges.push((0.0, p));
                    ranges.push((p, 1.0));
                }
            }
            for (a, b) in ranges {
                let want = reference_range(&q, a, b);
                for tol in [1e-2, 1e-4, 1e-6, 1e-9, 1e-12] {
                    let got = arclen_quadratic_hodograph(&q, || (lead, r, n), a, b, tol);
                    let err = (got - want).abs();
                    assert!(
                        err <= tol + 4e-15 * want,
                        "{c:?} [{a}, {b}] tol {tol:e}: {got} vs {want} (err {err:e})"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    /// The accuracy sweep behind the README's claim, too long for every run (about 12 s in
    /// release per seed): `cargo test --release -p bezier --lib adversarial_accuracy_sweep --
    /// --ignored --nocapture`. A million cubics per seed (random; near-cusps with the root
    /// `1e-1` to `1e-10` off the axis; a coincident pair of control points), scaled by `1e-3` to
    /// `1e3`, whole or a random sub-range, each at five requests from `1e-2` to `1e-10`: the
    /// error stays within the request. (At `1e-12` and below the reference itself is not
    /// reliable on the hardest near-cusps: checked against 40-digit mpmath, ours was right.)
    #[test]
    #[ignore]
    fn adversarial_accuracy_sweep() {
        for seed in [0xBEEF_CAFE, 0x00DD_BA11] {
            let mut next = lcg(seed);
            let mut worst: f64 = 0.0;
            let mut checked = 0usize;
            for i in 0..1_000_000 {
                let mut p: [(f64, f64); 4] = core::array::from_fn(|_| (2.0 * next() - 1.0, 2.0 * next() - 1.0));
                match i % 4 {
                    0 => {
                        let d = 10f64.powf(-1.0 - 9.0 * next());
                        let shift = next() - 0.5;
                        p = [
                            (0.0, 0.0),
                            (1.0 + shift, 1.0),
                            (shift + d * p[2].0, 1.0 + d * p[2].1),
                            (1.0, 0.0),
                        ];
                    }
                    1 => p[1] = p[0],
                    _ => {}
                }
                let scale = [1e-3, 1.0, 1e3][i % 3];
                let q = hodograph_of(p.map(|(x, y)| (x * scale, y * scale)));
                let z = |v: Vec2| Complex::new(v.x, v.y);
                let (r, n) = complex_quadratic_roots(z(q[0]), z(q[1]), z(q[2]));
                let lead = match n {
                    2 => q[0].hypot(),
                    1 => q[1].hypot(),
                    _ => q[2].hypot(),
                };
                let (a, b) = if i % 5 == 0 {
                    let (u, v) = (next(), next());
                    (u.min(v), u.max(v))
                } else {
                    (0.0, 1.0)
                };
                let want = reference_range(&q, a, b);
                for tol in [1e-2, 1e-4, 1e-6, 1e-8, 1e-10] {
                    let tol = tol * scale;
                    let got = arclen_quadratic_hodograph(&q, || (lead, r, n), a, b, tol);
                    let err = ((got - want).abs() - 4e-15 * want).max(0.0);
                    worst = worst.max(err / tol);
                    checked += 1;
                }
            }
            println!("seed {seed:#x}: {checked} lengths, largest error {worst:.3} x the request");
            assert!(worst <= 1.0);
        }
    }

    /// Cutting at a near-cusp makes loose requests cheap: the curve whose hodograph root is
    /// `1e-4` off the real axis at `t = 0.64` takes at most 16 points at `1e-3` (the
    /// Bernstein-ellipse bound alone forces graded splits toward the root there), and the work
    /// still grows with the request.
    #[test]
    fn near_cusp_at_loose_accuracy_takes_few_points() {
        // z(t) = 14 (t - 0.64 - 1e-4 i)(t - 0.002 + 0.116 i): x' + i y' with real coefficients
        let (r1, r2) = (Complex::new(0.64, 1e-4), Complex::new(0.002, -0.116));
        let lead = Complex::new(14.0, 0.0);
        let b = lead.mul(r1.add(r2)).scale(-1.0);
        let c = lead.mul(r1.mul(r2));
        let q = [
            Vec2::new(lead.re, lead.im),
            Vec2::new(b.re, b.im),
            Vec2::new(c.re, c.im),
        ];
        let roots = || {
            let z = |v: Vec2| Complex::new(v.x, v.y);
            let (r, n) = complex_quadratic_roots(z(q[0]), z(q[1]), z(q[2]));
            (q[0].hypot(), r, n)
        };
        let want = reference_range(&q, 0.0, 1.0);
        let mut evals = Vec::new();
        for tol in [1e-3, 1e-6, 1e-9] {
            counters::take();
            let got = arclen_quadratic_hodograph(&q, roots, 0.0, 1.0, tol);
            evals.push(counters::take().0);
            assert!((got - want).abs() <= tol, "tol {tol:e}: {got} vs {want}");
        }
        assert!(evals[0] <= 16, "evaluations {evals:?}");
        assert!(evals.windows(2).all(|w| w[0] < w[1]), "evaluations {evals:?}");
    }

    /// The root finder's short-chain arrangement keeps both roots accurate: nearly linear
    /// hodographs (one root far away, where `-b/a - r1` would cancel), double roots, and roots
    /// on the real axis.
    #[test]
    fn complex_roots_accurate_when_far_apart_or_double() {
        let cases = [
            // (a, r1, r2, relative accuracy): a (z - r1)(z - r2); a double root is only
            // determined to about the square root of the round-off.
            (
                Complex::new(1e-9, 2e-9),
                Complex::new(0.3, 0.01),
                Complex::new(-4e8, 1e8),
                1e-12,
            ),
            (
                Complex::new(1.0, 0.5),
                Complex::new(0.25, -0.125),
                Complex::new(0.25, -0.125),
                1e-7,
            ),
            (
                Complex::new(-3.0, 1.0),
                Complex::new(0.5, 0.0),
                Complex::new(0.75, 0.0),
                1e-12,
            ),
            (
                Complex::new(2.0, 0.0),
                Complex::new(1e-12, 0.0),
                Complex::new(5.0, 3.0),
                1e-12,
            ),
        ];
        for (a, r1, r2, acc) in cases {
            let b = a.mul(r1.add(r2)).scale(-1.0);
            let c = a.mul(r1.mul(r2));
            let (r, n) = complex_quadratic_roots(a, b, c);
            assert_eq!(n, 2);
            for want in [r1, r2] {
                let best = r.iter().map(|z| z.sub(want).abs()).fold(f64::INFINITY, f64::min);
                assert!(best <= acc * want.abs().max(1e-3), "{a:?} {r1:?} {r2:?}: got {r:?}");
            }
        }
    }

    #[test]
    fn simpson_is_exact_for_cubics() {
        let v = simpson(|x| x * x * x - x, 0.0, 2.0, 2);
        assert!((v - 2.0).abs() < 1e-14);
    }
}
