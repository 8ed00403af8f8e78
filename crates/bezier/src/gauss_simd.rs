//! The Gauss-Legendre sum of [`LocalHodograph::gauss`](crate::quadrature) with AVX-512 or with
//! AVX2 and FMA, chosen at run time (x86-64 only; other CPUs keep the portable sum).
//!
//! The portable sum is bound by the square-root unit: every node needs `|B'(x)|` and `|B'(-x)|`,
//! and a packed square root issues only every few cycles, whatever the vector width (the
//! 32-point rule's 32 roots take about 30 ns on the development machine, AMD EPYC), while the
//! multiply-add units idle. Here each group of nodes sends `|B'(x)|` to the square-root unit and
//! computes `|B'(-x)|` on the multiply-add units instead, from an estimate of `1/sqrt(s)` refined
//! by Newton steps `y <- y (3/2 - s y^2 / 2)` (each squares the relative error, times 3/2) and a
//! last step for `sqrt(s)` itself, `r <- r + y (s - r^2) / 2` (which squares it again), so the
//! value is as accurate as `sqrt` up to an ulp or two. The two streams run side by side.
//!
//! - **AVX2 + FMA** (four lanes): the classic bit-level estimate (half the exponent subtracted
//!   from a magic constant, within 3.5 %) and three Newton steps (3.5e-2 -> 1.8e-3 -> 5e-6 ->
//!   4e-11). About 1.4x the portable sum on the 32-point rule.
//! - **AVX-512** (eight lanes, preferred when present): the hardware estimate `vrsqrt14pd`
//!   (within `2^-14`) and two Newton steps (6e-5 -> 5e-9 -> 4e-17). About 2x the AVX2 sum on the
//!   development machine, whose cores run 512-bit operations at full width.
//!
//! The estimates hold for every normal `s` and for zero (`s y` vanishes whatever `y`, and `s y`
//! is formed before `y` is squared, so nothing overflows; the hardware estimate starts from
//! `max(s, smallest normal)`). A sum that comes out non-finite (an infinite or NaN hodograph) is
//! recomputed by the portable sum, which propagates it as before, and so is a curve so small that
//! its squared speeds are subnormal.

use core::arch::x86_64::{__m128d, __m256d, __m512d};
use pulp::x86::{V3, V4};

use crate::point::Vec2;

/// The CPU features a sum can use, and the widest the CPU has (`DDPKIT_SIMD` narrows it for
/// comparisons: `off` runs the portable sums, `avx2` stops at AVX2 and FMA).
pub(crate) use ddpkit_util::simd::{available, Simd};

/// Hodographs whose coefficients sum to less than this take the portable sum (see [`gauss`]).
const TINY_CURVE: f64 = 1e-140;

/// The magic constant of the bit-level `1/sqrt` estimate for `f64` (Lomont's, relative error
/// below 3.5 %).
const RSQRT_MAGIC: i64 = 0x5FE6_EB50_C7B5_37A9;

/// `sum_i w_i (|B'(x_i)| + |B'(-x_i)|)` for the hodograph `B'(x) = a x^2 + b x + c` (the
/// interval mapped to `[-1, 1]`), nodes `x` and weights `w` of a half-table; `None` when the sum
/// is not finite or the curve is tiny (see below): the caller then takes the portable sum.
#[inline(always)]
pub(crate) fn gauss<const K: usize>(simd: Simd, a: Vec2, b: Vec2, c: Vec2, x: &[f64; K], w: &[f64; K]) -> Option<f64> {
    // Squares of speeds below 1e-154 are subnormal, where the estimate is poor (the Newton steps
    // then start far below and return between 0 and 4x the root): fine beside larger speeds (an
    // error below 1e-154), not on a curve that small as a whole, which the portable sum takes.
    let size = (a.x.abs() + a.y.abs()) + (b.x.abs() + b.y.abs()) + (c.x.abs() + c.y.abs());
    if !(size > TINY_CURVE) {
        return None;
    }
    let v = match simd {
        Simd::V4(simd) => simd.vectorize(|| sum_v4(simd, a, b, c, x, w)),
        Simd::V3(simd) => simd.vectorize(|| sum_v3(simd, a, b, c, x, w, 0)),
    };
    v.is_finite().then_some(v)
}

/// The sum of [`gauss`] with the CPU features of `simd` enabled: eight nodes at a time, the rest
/// by [`sum_v3`].
#[inline(always)]
fn sum_v4<const K: usize>(simd: V4, a: Vec2, b: Vec2, c: Vec2, x: &[f64; K], w: &[f64; K]) -> f64 {
    let f = simd.avx512f;
    let (ax, ay) = (f._mm512_set1_pd(a.x), f._mm512_set1_pd(a.y));
    let (bx, by) = (f._mm512_set1_pd(b.x), f._mm512_set1_pd(b.y));
    let (cx, cy) = (f._mm512_set1_pd(c.x), f._mm512_set1_pd(c.y));
    let (half, three_halves) = (f._mm512_set1_pd(0.5), f._mm512_set1_pd(1.5));
    let least = f._mm512_set1_pd(f64::MIN_POSITIVE);
    let mut acc = f._mm512_setzero_pd();
    let mut i = 0;
    while i + 8 <= K {
        // Plain array literals: a closure here (`array::from_fn`) might not inherit the CPU
        // features and be called per element.
        let xv: __m512d = pulp::cast([
            x[i],
            x[i + 1],
            x[i + 2],
            x[i + 3],
            x[i + 4],
            x[i + 5],
            x[i + 6],
            x[i + 7],
        ]);
        let wv: __m512d = pulp::cast([
            w[i],
            w[i + 1],
            w[i + 2],
            w[i + 3],
            w[i + 4],
            w[i + 5],
            w[i + 6],
            w[i + 7],
        ]);
        let x2 = f._mm512_mul_pd(xv, xv);
        let dx = f._mm512_fmadd_pd(ax, x2, cx);
        let dy = f._mm512_fmadd_pd(ay, x2, cy);
        let (px, py) = (f._mm512_fmadd_pd(bx, xv, dx), f._mm512_fmadd_pd(by, xv, dy));
        let (nx, ny) = (f._mm512_fnmadd_pd(bx, xv, dx), f._mm512_fnmadd_pd(by, xv, dy));
        let p2 = f._mm512_fmadd_pd(px, px, f._mm512_mul_pd(py, py));
        let s = f._mm512_fmadd_pd(nx, nx, f._mm512_mul_pd(ny, ny));
        // sqrt(s) on the multiply-add units.
        let y = f._mm512_rsqrt14_pd(f._mm512_max_pd(s, least));
        let hs = f._mm512_mul_pd(half, s);
        let y = f._mm512_mul_pd(y, f._mm512_fnmadd_pd(f._mm512_mul_pd(hs, y), y, three_halves));
        let y = f._mm512_mul_pd(y, f._mm512_fnmadd_pd(f._mm512_mul_pd(hs, y), y, three_halves));
        let r = f._mm512_mul_pd(s, y);
        let n = f._mm512_fmadd_pd(f._mm512_mul_pd(half, y), f._mm512_fnmadd_pd(r, r, s), r);
        acc = f._mm512_fmadd_pd(wv, f._mm512_add_pd(f._mm512_sqrt_pd(p2), n), acc);
        i += 8;
    }
    let lanes: [f64; 8] = pulp::cast(acc);
    let head = ((lanes[0] + lanes[1]) + (lanes[2] + lanes[3])) + ((lanes[4] + lanes[5]) + (lanes[6] + lanes[7]));
    head + sum_v3(*simd, a, b, c, x, w, i)
}

/// The sum of [`gauss`] over the nodes from `start` on, with the CPU features of `simd` enabled.
#[inline(always)]
fn sum_v3<const K: usize>(simd: V3, a: Vec2, b: Vec2, c: Vec2, x: &[f64; K], w: &[f64; K], start: usize) -> f64 {
    let avx = simd.avx;
    let fma = simd.fma;
    let avx2 = simd.avx2;
    let sse2 = simd.sse2;

    // Four nodes at a time.
    let (ax, ay) = (avx._mm256_set1_pd(a.x), avx._mm256_set1_pd(a.y));
    let (bx, by) = (avx._mm256_set1_pd(b.x), avx._mm256_set1_pd(b.y));
    let (cx, cy) = (avx._mm256_set1_pd(c.x), avx._mm256_set1_pd(c.y));
    let (half, three_halves) = (avx._mm256_set1_pd(0.5), avx._mm256_set1_pd(1.5));
    let magic = avx._mm256_set1_epi64x(RSQRT_MAGIC);
    let mut acc = avx._mm256_setzero_pd();
    let mut i = start;
    while i + 4 <= K {
        let xv: __m256d = pulp::cast([x[i], x[i + 1], x[i + 2], x[i + 3]]);
        let wv: __m256d = pulp::cast([w[i], w[i + 1], w[i + 2], w[i + 3]]);
        let x2 = avx._mm256_mul_pd(xv, xv);
        let dx = fma._mm256_fmadd_pd(ax, x2, cx);
        let dy = fma._mm256_fmadd_pd(ay, x2, cy);
        let (px, py) = (fma._mm256_fmadd_pd(bx, xv, dx), fma._mm256_fmadd_pd(by, xv, dy));
        let (nx, ny) = (fma._mm256_fnmadd_pd(bx, xv, dx), fma._mm256_fnmadd_pd(by, xv, dy));
        let p2 = fma._mm256_fmadd_pd(px, px, avx._mm256_mul_pd(py, py));
        let s = fma._mm256_fmadd_pd(nx, nx, avx._mm256_mul_pd(ny, ny));
        // sqrt(s) on the multiply-add units.
        let y: __m256d = pulp::cast(avx2._mm256_sub_epi64(magic, avx2._mm256_srli_epi64::<1>(pulp::cast(s))));
        let hs = avx._mm256_mul_pd(half, s);
        let y = avx._mm256_mul_pd(y, fma._mm256_fnmadd_pd(avx._mm256_mul_pd(hs, y), y, three_halves));
        let y = avx._mm256_mul_pd(y, fma._mm256_fnmadd_pd(avx._mm256_mul_pd(hs, y), y, three_halves));
        let y = avx._mm256_mul_pd(y, fma._mm256_fnmadd_pd(avx._mm256_mul_pd(hs, y), y, three_halves));
        let r = avx._mm256_mul_pd(s, y);
        let n = fma._mm256_fmadd_pd(avx._mm256_mul_pd(half, y), fma._mm256_fnmadd_pd(r, r, s), r);
        acc = fma._mm256_fmadd_pd(wv, avx._mm256_add_pd(avx._mm256_sqrt_pd(p2), n), acc);
        i += 4;
    }
    let lanes: [f64; 4] = pulp::cast(acc);
    let mut total = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);

    // The last nodes (fewer than four; in practice two, of the 20-point rule) one at a time, both
    // square roots of each in one packed root.
    while i < K {
        let (xi, wi) = (x[i], w[i]);
        let x2 = xi * xi;
        let (dx, dy) = (a.x.mul_add(x2, c.x), a.y.mul_add(x2, c.y));
        let (px, py) = (b.x.mul_add(xi, dx), b.y.mul_add(xi, dy));
        let (nx, ny) = ((-b.x).mul_add(xi, dx), (-b.y).mul_add(xi, dy));
        let s: __m128d = pulp::cast([px.mul_add(px, py * py), nx.mul_add(nx, ny * ny)]);
        let r: [f64; 2] = pulp::cast(sse2._mm_sqrt_pd(s));
        total += wi * (r[0] + r[1]);
        i += 1;
    }
    total
}
