//! Small dense kernels for the solvers' hot loops, generic over compile-time and run-time sizes.
//!
//! They work on the column-major storage of nalgebra matrices directly and write into buffers
//! the caller owns, so a run-time-size solve allocates nothing. With [`nalgebra::Const`]
//! dimensions the sizes are constants after inlining: the loops unroll completely and the
//! bounds checks vanish (nalgebra's generic products go through stride-aware loops that the
//! compiler does not fully unroll for tiny sizes). Each kernel is checked against nalgebra.

use nalgebra::Dim;

use crate::dims::{Allocator, DefaultAllocator, MatrixN};

/// Whether any of three dimensions is known only at run time.
#[inline(always)]
fn run_time<A: Dim, B: Dim, C: Dim>() -> bool {
    A::try_to_usize().is_none() || B::try_to_usize().is_none() || C::try_to_usize().is_none()
}

/// A kernel body with up to three sizes, which [`small`] runs with the sizes as constants when
/// they are 1..=4 or 6 (its loops then unroll, as for compile-time sizes; 6 is the state of a
/// planar quadrotor or a three-joint arm, 0.8x the time of a traced planar quadrotor's solve
/// against the run-time loops), else with the run-time values. The dispatch is out of line and instantiated once per kernel, so callers at
/// compile-time sizes pay nothing (their branch is dead) and the build does not multiply.
trait Kernel {
    fn call<const A: usize, const B: usize, const C: usize>(self);
    fn call_any(self, a: usize, b: usize, c: usize);
}

#[inline(never)]
fn small<T: Kernel>(t: T, a: usize, b: usize, c: usize) {
    match a {
        1 => small_b::<T, 1>(t, b, c),
        2 => small_b::<T, 2>(t, b, c),
        3 => small_b::<T, 3>(t, b, c),
        4 => small_b::<T, 4>(t, b, c),
        6 => small_b::<T, 6>(t, b, c),
        _ => t.call_any(a, b, c),
    }
}

#[inline(never)]
fn small_b<T: Kernel, const A: usize>(t: T, b: usize, c: usize) {
    match b {
        1 => small_c::<T, A, 1>(t, c),
        2 => small_c::<T, A, 2>(t, c),
        3 => small_c::<T, A, 3>(t, c),
        4 => small_c::<T, A, 4>(t, c),
        6 => small_c::<T, A, 6>(t, c),
        _ => t.call_any(A, b, c),
    }
}

#[inline(never)]
fn small_c<T: Kernel, const A: usize, const B: usize>(t: T, c: usize) {
    match c {
        1 => t.call::<A, B, 1>(),
        2 => t.call::<A, B, 2>(),
        3 => t.call::<A, B, 3>(),
        4 => t.call::<A, B, 4>(),
        6 => t.call::<A, B, 6>(),
        _ => t.call_any(A, B, c),
    }
}

/// Implements [`Kernel`] for a struct of slices whose body takes the sizes last.
macro_rules! kernel {
    ($name:ident <$lt:lifetime> { $($field:ident : $ty:ty),* $(,)? } => $body:ident ( $n:tt )) => {
        struct $name<$lt> { $($field: $ty),* }
        impl Kernel for $name<'_> {
            #[inline(always)]
            fn call<const A: usize, const B: usize, const C: usize>(self) {
                kernel!(@call self, $body, $n, A, B, C, $($field),*)
            }
            #[inline(always)]
            fn call_any(self, a: usize, b: usize, c: usize) {
                kernel!(@call self, $body, $n, a, b, c, $($field),*)
            }
        }
    };
    (@call $s:ident, $body:ident, 2, $a:expr, $b:expr, $c:expr, $($field:ident),*) => {{
        let _ = $c;
        $body($($s.$field),*, $a, $b)
    }};
    (@call $s:ident, $body:ident, 3, $a:expr, $b:expr, $c:expr, $($field:ident),*) => {
        $body($($s.$field),*, $a, $b, $c)
    };
}

/// `s + sum_k a_k b_k`, summed in order from `s` (the rounding of the loop written out). Short
/// lengths are written out: for compile-time sizes the match folds away, for run-time sizes a
/// branch replaces the iterator's per-element overhead (the same sums, the same rounding).
#[inline(always)]
fn dot_from(s: f64, a: &[f64], b: &[f64]) -> f64 {
    match (a, b) {
        ([a0], [b0, ..]) => s + a0 * b0,
        ([a0, a1], [b0, b1, ..]) => s + a0 * b0 + a1 * b1,
        ([a0, a1, a2], [b0, b1, b2, ..]) => s + a0 * b0 + a1 * b1 + a2 * b2,
        ([a0, a1, a2, a3], [b0, b1, b2, b3, ..]) => s + a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3,
        _ => a.iter().zip(b).fold(s, |s, (x, y)| s + x * y),
    }
}

/// `out = c + A^T B` (`A` is `K x R`, `B` is `K x C`); `c` may be `None` for zero. The product
/// is summed first and `c` added last.
#[inline(always)]
pub fn tr_mul_add<K: Dim, R: Dim, C: Dim>(
    out: &mut MatrixN<R, C>,
    c: Option<&MatrixN<R, C>>,
    a: &MatrixN<K, R>,
    b: &MatrixN<K, C>,
) where
    DefaultAllocator: Allocator<K, R> + Allocator<K, C> + Allocator<R, C>,
{
    let (kk, r, cc) = (a.nrows(), a.ncols(), b.ncols());
    let (a, b) = (a.as_slice(), b.as_slice());
    let c = c.map(|c| c.as_slice());
    let o = out.as_mut_slice();
    if run_time::<K, R, C>() {
        small(TrMulAdd { o, c, a, b }, kk, r, cc)
    } else {
        tr_mul_add_body(o, c, a, b, kk, r, cc)
    }
}

#[inline(always)]
fn tr_mul_add_body(o: &mut [f64], c: Option<&[f64]>, a: &[f64], b: &[f64], kk: usize, r: usize, cc: usize) {
    // Columns are sliced by offset (no `chunks_exact`: its length division is a real `div` for
    // run-time sizes).
    let (a, b, o) = (&a[..kk * r], &b[..kk * cc], &mut o[..r * cc]);
    for j in 0..cc {
        let bj = &b[j * kk..(j + 1) * kk];
        for i in 0..r {
            let p = dot_from(0.0, &a[i * kk..(i + 1) * kk], bj);
            o[j * r + i] = match c {
                Some(c) => c[j * r + i] + p,
                None => p,
            };
        }
    }
}

/// `out = A B` (`A` is `R x K`, `B` is `K x C`). Each entry is summed in a register (the
/// sum runs over `k` in order, as `A B` written out).
#[inline(always)]
pub fn mul_to<R: Dim, K: Dim, C: Dim>(out: &mut MatrixN<R, C>, a: &MatrixN<R, K>, b: &MatrixN<K, C>)
where
    DefaultAllocator: Allocator<R, K> + Allocator<K, C> + Allocator<R, C>,
{
    let (r, kk, cc) = (a.nrows(), a.ncols(), b.ncols());
    let (a, b) = (a.as_slice(), b.as_slice());
    let o = out.as_mut_slice();
    if run_time::<R, K, C>() {
        small(MulTo { o, a, b }, r, kk, cc)
    } else {
        mul_to_body(o, a, b, r, kk, cc)
    }
}

#[inline(always)]
fn mul_to_body(o: &mut [f64], a: &[f64], b: &[f64], r: usize, kk: usize, cc: usize) {
    let (a, b, o) = (&a[..r * kk], &b[..kk * cc], &mut o[..r * cc]);
    for j in 0..cc {
        let bj = &b[j * kk..(j + 1) * kk];
        for i in 0..r {
            o[j * r + i] = match bj {
                [b0] => a[i] * b0,
                [b0, b1] => a[i] * b0 + a[r + i] * b1,
                [b0, b1, b2] => a[i] * b0 + a[r + i] * b1 + a[2 * r + i] * b2,
                _ => {
                    let mut s = 0.0;
                    for (k, bk) in bj.iter().enumerate() {
                        s += a[k * r + i] * bk;
                    }
                    s
                }
            };
        }
    }
}

/// `out = c + A x` (`A` is `R x K`); `c` may be `None`.
#[inline(always)]
pub fn mul_vec_add<R: Dim, K: Dim>(
    out: &mut MatrixN<R, nalgebra::U1>,
    c: Option<&MatrixN<R, nalgebra::U1>>,
    a: &MatrixN<R, K>,
    x: &MatrixN<K, nalgebra::U1>,
) where
    DefaultAllocator: Allocator<R, K> + Allocator<K> + Allocator<R>,
{
    let (r, kk) = (a.nrows(), a.ncols());
    let (a, x) = (a.as_slice(), x.as_slice());
    let c = c.map(|c| c.as_slice());
    let o = out.as_mut_slice();
    if run_time::<R, K, nalgebra::U1>() {
        small(MulVecAdd { o, c, a, x }, r, kk, 1)
    } else {
        mul_vec_add_body(o, c, a, x, r, kk)
    }
}

#[inline(always)]
fn mul_vec_add_body(o: &mut [f64], c: Option<&[f64]>, a: &[f64], x: &[f64], r: usize, kk: usize) {
    let (a, x, o) = (&a[..r * kk], &x[..kk], &mut o[..r]);
    match c {
        Some(c) => o.copy_from_slice(&c[..r]),
        None => o.fill(0.0),
    }
    for k in 0..kk {
        let (ak, xk) = (&a[k * r..(k + 1) * r], x[k]);
        for (oi, aik) in o.iter_mut().zip(ak) {
            *oi += aik * xk;
        }
    }
}

/// `out = c + A^T x` (`A` is `K x R`); `c` may be `None`. The product is summed first.
#[inline(always)]
pub fn tr_mul_vec_add<K: Dim, R: Dim>(
    out: &mut MatrixN<R, nalgebra::U1>,
    c: Option<&MatrixN<R, nalgebra::U1>>,
    a: &MatrixN<K, R>,
    x: &MatrixN<K, nalgebra::U1>,
) where
    DefaultAllocator: Allocator<K, R> + Allocator<K> + Allocator<R>,
{
    let (kk, r) = (a.nrows(), a.ncols());
    let (a, x) = (a.as_slice(), x.as_slice());
    let c = c.map(|c| c.as_slice());
    let o = out.as_mut_slice();
    if run_time::<K, R, nalgebra::U1>() {
        small(TrMulVecAdd { o, c, a, x }, kk, r, 1)
    } else {
        tr_mul_vec_add_body(o, c, a, x, kk, r)
    }
}

#[inline(always)]
fn tr_mul_vec_add_body(o: &mut [f64], c: Option<&[f64]>, a: &[f64], x: &[f64], kk: usize, r: usize) {
    let (a, x, o) = (&a[..kk * r], &x[..kk], &mut o[..r]);
    for i in 0..r {
        let p = dot_from(0.0, &a[i * kk..(i + 1) * kk], x);
        o[i] = match c {
            Some(c) => c[i] + p,
            None => p,
        };
    }
}

/// `out = C + A^T B` for a product known to be symmetric: the upper triangle is computed (from
/// `C`, then the products in order) and mirrored (`A`, `B` are `K x N`).
#[inline(always)]
pub fn sym_tr_mul_add<K: Dim, N: Dim>(out: &mut MatrixN<N, N>, c: &MatrixN<N, N>, a: &MatrixN<K, N>, b: &MatrixN<K, N>)
where
    DefaultAllocator: Allocator<K, N> + Allocator<N, N>,
{
    let (kk, n) = (a.nrows(), a.ncols());
    let (a, b, c) = (a.as_slice(), b.as_slice(), c.as_slice());
    let o = out.as_mut_slice();
    if run_time::<K, N, N>() {
        small(SymTrMulAdd { o, c, a, b }, kk, n, 1)
    } else {
        sym_tr_mul_add_body(o, c, a, b, kk, n)
    }
}

#[inline(always)]
fn sym_tr_mul_add_body(o: &mut [f64], c: &[f64], a: &[f64], b: &[f64], kk: usize, n: usize) {
    let (a, b, c, o) = (&a[..kk * n], &b[..kk * n], &c[..n * n], &mut o[..n * n]);
    for j in 0..n {
        let bj = &b[j * kk..(j + 1) * kk];
        for i in 0..=j {
            let s = dot_from(c[j * n + i], &a[i * kk..(i + 1) * kk], bj);
            o[j * n + i] = s;
            o[i * n + j] = s;
        }
    }
}

/// `out = C + A^T B + D^T E` for a sum known to be symmetric (upper triangle computed and
/// mirrored; all of `A, B, D, E` are `K x N`).
#[inline(always)]
pub fn sym_tr_mul2_add<K: Dim, N: Dim>(
    out: &mut MatrixN<N, N>,
    c: &MatrixN<N, N>,
    a: &MatrixN<K, N>,
    b: &MatrixN<K, N>,
    d: &MatrixN<K, N>,
    e: &MatrixN<K, N>,
) where
    DefaultAllocator: Allocator<K, N> + Allocator<N, N>,
{
    let (kk, n) = (a.nrows(), a.ncols());
    let (a, b, c, d, e) = (a.as_slice(), b.as_slice(), c.as_slice(), d.as_slice(), e.as_slice());
    let o = out.as_mut_slice();
    if run_time::<K, N, N>() {
        small(SymTrMul2Add { o, c, m: [a, b, d, e] }, kk, n, 1)
    } else {
        sym_tr_mul2_add_body(o, c, [a, b, d, e], kk, n)
    }
}

#[inline(always)]
fn sym_tr_mul2_add_body(o: &mut [f64], c: &[f64], [a, b, d, e]: [&[f64]; 4], kk: usize, n: usize) {
    let (a, b, d, e) = (&a[..kk * n], &b[..kk * n], &d[..kk * n], &e[..kk * n]);
    let (c, o) = (&c[..n * n], &mut o[..n * n]);
    for j in 0..n {
        let (bj, ej) = (&b[j * kk..(j + 1) * kk], &e[j * kk..(j + 1) * kk]);
        for i in 0..=j {
            let (ai, di) = (&a[i * kk..(i + 1) * kk], &d[i * kk..(i + 1) * kk]);
            let mut s = c[j * n + i];
            for k in 0..kk {
                s += ai[k] * bj[k] + di[k] * ej[k];
            }
            o[j * n + i] = s;
            o[i * n + j] = s;
        }
    }
}

/// `dst <- src` over the storage (nalgebra's element-wise copy walks strides).
#[inline(always)]
pub fn copy<R: Dim, C: Dim>(dst: &mut MatrixN<R, C>, src: &MatrixN<R, C>)
where
    DefaultAllocator: Allocator<R, C>,
{
    dst.as_mut_slice().copy_from_slice(src.as_slice());
}

/// `m <- 0` over the storage.
#[inline(always)]
pub fn zero<R: Dim, C: Dim>(m: &mut MatrixN<R, C>)
where
    DefaultAllocator: Allocator<R, C>,
{
    m.as_mut_slice().fill(0.0);
}

/// `m <- -m` over the storage.
#[inline(always)]
pub fn negate<R: Dim, C: Dim>(m: &mut MatrixN<R, C>)
where
    DefaultAllocator: Allocator<R, C>,
{
    m.as_mut_slice().iter_mut().for_each(|v| *v = -*v);
}

/// `dst <- dst + src` over the storage.
#[inline(always)]
pub fn add_to<R: Dim, C: Dim>(dst: &mut MatrixN<R, C>, src: &MatrixN<R, C>)
where
    DefaultAllocator: Allocator<R, C>,
{
    dst.as_mut_slice()
        .iter_mut()
        .zip(src.as_slice())
        .for_each(|(d, s)| *d += s);
}

/// Cholesky factorisation `A = L L^T` in place: the lower triangle of `a` becomes `L` (the
/// strict upper triangle is left as it was). `false` when `A` is not positive definite.
#[inline(always)]
pub fn cholesky_in_place<N: Dim>(a: &mut MatrixN<N, N>) -> bool
where
    DefaultAllocator: Allocator<N, N>,
{
    let n = a.nrows();
    let l = a.as_mut_slice();
    if run_time::<N, N, N>() {
        let mut ok = false;
        small(CholeskyK { l, ok: &mut ok }, n, 1, 1);
        ok
    } else {
        cholesky_body(l, n)
    }
}

/// The factorisation's loops, in place.
#[inline(always)]
fn cholesky_body(l: &mut [f64], n: usize) -> bool {
    // Column-major storage: L(i, k) = l[k n + i].
    let l = &mut l[..n * n];
    for j in 0..n {
        let mut d = l[j * n + j];
        for k in 0..j {
            d -= l[k * n + j] * l[k * n + j];
        }
        // Not positive definite, or NaN / inf: `d > 0` fails for NaN.
        if d.is_nan() || d <= 0.0 || d.is_infinite() {
            return false;
        }
        let d = d.sqrt();
        l[j * n + j] = d;
        let r = 1.0 / d;
        for i in j + 1..n {
            let mut s = l[j * n + i];
            for k in 0..j {
                s -= l[k * n + i] * l[k * n + j];
            }
            l[j * n + i] = s * r;
        }
    }
    true
}

/// Largest order whose pivots' reciprocals [`cholesky_solve_in_place`] keeps on the stack.
const RECIPROCALS: usize = 16;

/// Solves `L L^T X = B` in place (`l` from [`cholesky_in_place`]), for every column of `b`.
#[inline(always)]
pub fn cholesky_solve_in_place<N: Dim, C: Dim>(l: &MatrixN<N, N>, b: &mut MatrixN<N, C>)
where
    DefaultAllocator: Allocator<N, N> + Allocator<N, C>,
{
    let (n, cols) = (l.nrows(), b.ncols());
    let (l, b) = (l.as_slice(), b.as_mut_slice());
    if run_time::<N, C, N>() {
        small(CholeskySolve { l, b }, n, cols, 1)
    } else {
        cholesky_solve_body(l, b, n, cols)
    }
}

#[inline(always)]
fn cholesky_solve_body(l: &[f64], b: &mut [f64], n: usize, cols: usize) {
    let (l, b) = (&l[..n * n], &mut b[..n * cols]);
    // The pivots' reciprocals first, each once and off the substitutions' dependency chains,
    // which then only multiply: a division's latency is several multiplications', and the
    // backward passes solve with every knot's `Q_uu` for `1 + nx` columns. (Past
    // `RECIPROCALS` each use divides `1` by its pivot again: the same values.)
    let mut table = [0.0; RECIPROCALS];
    let tabled = n <= RECIPROCALS;
    if tabled {
        for (i, r) in table[..n].iter_mut().enumerate() {
            *r = 1.0 / l[i * n + i];
        }
    }
    let recip = |i: usize| if tabled { table[i] } else { 1.0 / l[i * n + i] };
    for c in 0..cols {
        let x = &mut b[c * n..(c + 1) * n];
        // Forward: L y = b.
        for i in 0..n {
            let mut s = x[i];
            for k in 0..i {
                s -= l[k * n + i] * x[k];
            }
            x[i] = s * recip(i);
        }
        // Backward: L^T x = y.
        for i in (0..n).rev() {
            let mut s = x[i];
            for k in i + 1..n {
                s -= l[i * n + k] * x[k];
            }
            x[i] = s * recip(i);
        }
    }
}

/// The `L D L^T` factorisation of the symmetric positive definite `a` (lower triangle read, one
/// entry at a time) into `f`: its strict lower triangle becomes the unit lower triangular `L`, its
/// diagonal the pivots' reciprocals `1 / d_i`, its strict upper triangle is unspecified. `false`
/// when a pivot is not positive (or not finite). The same factorisation as Cholesky's
/// (`L_chol = L D^(1/2)`), without its square roots: a backward pass factors every knot's `Q_uu`
/// on the dependency chain from one knot's value function to the next, where a square root and
/// the division after it cost several multiplications' latency each.
#[inline(always)]
pub fn ldl_from<N: Dim>(a: &MatrixN<N, N>, f: &mut MatrixN<N, N>) -> bool
where
    DefaultAllocator: Allocator<N, N>,
{
    let n = a.nrows();
    let (a, f) = (a.as_slice(), f.as_mut_slice());
    if run_time::<N, N, N>() {
        let mut ok = false;
        small(LdlK { a, f, ok: &mut ok }, n, 1, 1);
        ok
    } else {
        ldl_body(a, f, n)
    }
}

#[inline(always)]
fn ldl_body(a: &[f64], f: &mut [f64], n: usize) -> bool {
    // Column-major: L(i, k) = f[k n + i]. The pivots `d_k` themselves on the stack (past
    // `RECIPROCALS`, `1 / (1 / d_k)` again: a deterministic value all the same).
    let (a, f) = (&a[..n * n], &mut f[..n * n]);
    let mut table = [0.0; RECIPROCALS];
    let tabled = n <= RECIPROCALS;
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            let l = f[k * n + j];
            let dk = if tabled { table[k] } else { 1.0 / f[k * n + k] };
            d -= l * l * dk;
        }
        // Not positive definite, or NaN / inf: `d > 0` fails for NaN.
        if d.is_nan() || d <= 0.0 || d.is_infinite() {
            return false;
        }
        let r = 1.0 / d;
        if tabled {
            table[j] = d;
        }
        f[j * n + j] = r;
        for i in j + 1..n {
            let mut s = a[j * n + i];
            for k in 0..j {
                let dk = if tabled { table[k] } else { 1.0 / f[k * n + k] };
                s -= f[k * n + i] * f[k * n + j] * dk;
            }
            f[j * n + i] = s * r;
        }
    }
    true
}

/// Solves `L D L^T X = B` in place (`f` from [`ldl_from`]), for every column of `b`.
#[inline(always)]
pub fn ldl_solve_in_place<N: Dim, C: Dim>(f: &MatrixN<N, N>, b: &mut MatrixN<N, C>)
where
    DefaultAllocator: Allocator<N, N> + Allocator<N, C>,
{
    let (n, cols) = (f.nrows(), b.ncols());
    let (f, b) = (f.as_slice(), b.as_mut_slice());
    if run_time::<N, C, N>() {
        small(LdlSolve { f, b }, n, cols, 1)
    } else {
        ldl_solve_body(f, b, n, cols)
    }
}

#[inline(always)]
fn ldl_solve_body(f: &[f64], b: &mut [f64], n: usize, cols: usize) {
    let (f, b) = (&f[..n * n], &mut b[..n * cols]);
    for c in 0..cols {
        let x = &mut b[c * n..(c + 1) * n];
        // Forward: L y = b (unit diagonal).
        for i in 1..n {
            let mut s = x[i];
            for k in 0..i {
                s -= f[k * n + i] * x[k];
            }
            x[i] = s;
        }
        // D z = y, then backward: L^T x = z.
        for i in (0..n).rev() {
            let mut s = x[i] * f[i * n + i];
            for k in i + 1..n {
                s -= f[i * n + k] * x[k];
            }
            x[i] = s;
        }
    }
}

kernel!(LdlSolve<'a> { f: &'a [f64], b: &'a mut [f64] } => ldl_solve_body(2));

/// The `L D L^T` factorisation as a [`Kernel`] (its result through `ok`).
struct LdlK<'a> {
    a: &'a [f64],
    f: &'a mut [f64],
    ok: &'a mut bool,
}

impl Kernel for LdlK<'_> {
    #[inline(always)]
    fn call<const A: usize, const B: usize, const C: usize>(self) {
        *self.ok = ldl_body(self.a, self.f, A);
    }
    #[inline(always)]
    fn call_any(self, a: usize, _b: usize, _c: usize) {
        *self.ok = ldl_body(self.a, self.f, a);
    }
}

kernel!(TrMulAdd<'a> { o: &'a mut [f64], c: Option<&'a [f64]>, a: &'a [f64], b: &'a [f64] } => tr_mul_add_body(3));
kernel!(MulTo<'a> { o: &'a mut [f64], a: &'a [f64], b: &'a [f64] } => mul_to_body(3));
kernel!(MulVecAdd<'a> { o: &'a mut [f64], c: Option<&'a [f64]>, a: &'a [f64], x: &'a [f64] } => mul_vec_add_body(2));
kernel!(TrMulVecAdd<'a> { o: &'a mut [f64], c: Option<&'a [f64]>, a: &'a [f64], x: &'a [f64] } => tr_mul_vec_add_body(2));
kernel!(SymTrMulAdd<'a> { o: &'a mut [f64], c: &'a [f64], a: &'a [f64], b: &'a [f64] } => sym_tr_mul_add_body(2));
kernel!(SymTrMul2Add<'a> { o: &'a mut [f64], c: &'a [f64], m: [&'a [f64]; 4] } => sym_tr_mul2_add_body(2));
kernel!(CholeskySolve<'a> { l: &'a [f64], b: &'a mut [f64] } => cholesky_solve_body(2));

/// The Cholesky factorisation as a [`Kernel`] (in place; its result through `ok`).
struct CholeskyK<'a> {
    l: &'a mut [f64],
    ok: &'a mut bool,
}

impl Kernel for CholeskyK<'_> {
    #[inline(always)]
    fn call<const A: usize, const B: usize, const C: usize>(self) {
        *self.ok = cholesky_body(self.l, A);
    }
    #[inline(always)]
    fn call_any(self, a: usize, _b: usize, _c: usize) {
        *self.ok = cholesky_body(self.l, a);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Matrix, Vector};
    use nalgebra::{DMatrix, DVector};

    #[test]
    fn kernels_match_nalgebra() {
        let a = Matrix::<3, 4>::from_fn(|i, j| (i * 4 + j) as f64 * 0.3 - 1.0);
        let b = Matrix::<4, 2>::from_fn(|i, j| (i + 2 * j) as f64 * 0.7 - 0.5);
        let c = Matrix::<3, 2>::from_fn(|i, j| (i * j) as f64 + 0.25);
        let x = Vector::<4>::new(0.5, -1.0, 2.0, 0.25);
        let y = Vector::<3>::new(1.5, -0.5, 0.75);
        let mut ab = Matrix::<3, 2>::zeros();
        mul_to(&mut ab, &a, &b);
        assert!((ab - a * b).amax() < 1e-14);
        let mut atc = Matrix::<4, 2>::zeros();
        tr_mul_add(&mut atc, None, &a, &c);
        assert!((atc - a.transpose() * c).amax() < 1e-14);
        let mut ax = Vector::<3>::zeros();
        mul_vec_add(&mut ax, Some(&y), &a, &x);
        assert!((ax - (y + a * x)).amax() < 1e-14);
        let mut aty = Vector::<4>::zeros();
        tr_mul_vec_add(&mut aty, Some(&x), &a, &y);
        assert!((aty - (x + a.transpose() * y)).amax() < 1e-14);
        let s = Matrix::<3, 3>::new(2.0, 0.5, 0.1, 0.5, 1.0, -0.3, 0.1, -0.3, 3.0);
        let f = Matrix::<3, 3>::from_fn(|i, j| (i + j * j) as f64 * 0.2 - 0.4);
        let sf = s * f;
        let id = Matrix::<3, 3>::identity();
        let mut out = Matrix::<3, 3>::zeros();
        sym_tr_mul_add(&mut out, &id, &f, &sf);
        assert!((out - (id + f.transpose() * sf)).amax() < 1e-14);
        let k = Matrix::<2, 3>::from_fn(|i, j| (i * 3 + j) as f64 * 0.1 - 0.2);
        let q = Matrix::<2, 3>::from_fn(|i, j| (2 * i + j) as f64 * 0.3 - 0.5);
        let quu = Matrix::<2, 2>::new(2.0, 0.3, 0.3, 1.0);
        // K^T (Quu K + Qux) + Qux^T K is symmetric for any K.
        let m = quu * k + q;
        let full = id + k.transpose() * m + q.transpose() * k;
        sym_tr_mul2_add(&mut out, &id, &k, &m, &q, &k);
        assert!((out - full).amax() < 1e-14);
    }

    #[test]
    fn run_time_kernels_and_cholesky_match_nalgebra() {
        let a = DMatrix::from_fn(5, 7, |i, j| ((i * 7 + j) as f64 * 0.37).sin());
        let b = DMatrix::from_fn(5, 3, |i, j| ((i + 5 * j) as f64 * 0.71).cos());
        let mut out = DMatrix::zeros(7, 3);
        tr_mul_add(&mut out, None, &a, &b);
        assert!((&out - a.transpose() * &b).amax() < 1e-13);
        let h = {
            let m = DMatrix::from_fn(6, 6, |i, j| ((i * 6 + j) as f64 * 0.53).sin());
            &m * m.transpose() + DMatrix::identity(6, 6)
        };
        let rhs = DMatrix::from_fn(6, 2, |i, j| (i as f64) - 2.0 * j as f64);
        let mut l = h.clone();
        assert!(cholesky_in_place(&mut l));
        let mut x = rhs.clone();
        cholesky_solve_in_place(&l, &mut x);
        let expected = h.clone().cholesky().unwrap().solve(&rhs);
        assert!((x - expected).amax() < 1e-12);
        let mut v = DVector::from_element(6, 1.0);
        cholesky_solve_in_place(&l, &mut v);
        assert!((&h * v - DVector::from_element(6, 1.0)).amax() < 1e-12);
        let mut indefinite = DMatrix::from_row_slice(2, 2, &[1.0, 2.0, 2.0, 1.0]);
        assert!(!cholesky_in_place(&mut indefinite));
        let mut nan = Matrix::<2, 2>::new(f64::NAN, 0.0, 0.0, 1.0);
        assert!(!cholesky_in_place(&mut nan));
    }

    /// `L D L^T` against nalgebra's Cholesky solve, at compile-time and run-time sizes (the sizes
    /// `small` unrolls and one past them, 20, past the stack table of pivots), and its
    /// factors against the Cholesky factor: `L_chol = L D^(1/2)`.
    #[test]
    fn ldl_solves_as_cholesky_and_rejects_what_is_not_positive_definite() {
        for n in [1usize, 2, 3, 4, 6, 7, 20] {
            let m = DMatrix::from_fn(n, n, |i, j| ((i * n + j) as f64 * 0.53).sin());
            let h = &m * m.transpose() + DMatrix::identity(n, n) * 0.1;
            let rhs = DMatrix::from_fn(n, 3, |i, j| (i as f64) * 0.5 - 2.0 * j as f64 + 1.0);
            let mut f = DMatrix::from_element(n, n, f64::NAN);
            assert!(ldl_from(&h, &mut f), "n = {n}");
            let mut x = rhs.clone();
            ldl_solve_in_place(&f, &mut x);
            let expected = h.clone().cholesky().unwrap().solve(&rhs);
            let scale = 1.0 + expected.amax();
            assert!(
                (&x - &expected).amax() < 1e-10 * scale,
                "n = {n}: {}",
                (&x - &expected).amax()
            );
            let mut l = h.clone();
            assert!(cholesky_in_place(&mut l));
            for j in 0..n {
                let d = 1.0 / f[(j, j)];
                assert!(
                    (l[(j, j)] - d.sqrt()).abs() < 1e-12 * (1.0 + d.sqrt()),
                    "pivot {j} of n = {n}"
                );
                for i in j + 1..n {
                    assert!(
                        (l[(i, j)] - f[(i, j)] * d.sqrt()).abs() < 1e-10,
                        "L({i}, {j}) of n = {n}"
                    );
                }
            }
        }
        // Compile-time sizes: the same values as the run-time path, bit for bit.
        let m = Matrix::<4, 4>::from_fn(|i, j| ((i * 4 + j) as f64 * 0.31).cos());
        let h = m * m.transpose() + Matrix::<4, 4>::identity();
        let mut f = Matrix::<4, 4>::zeros();
        assert!(ldl_from(&h, &mut f));
        let mut fd = DMatrix::zeros(4, 4);
        assert!(ldl_from(&DMatrix::from_column_slice(4, 4, h.as_slice()), &mut fd));
        let mut v = Vector::<4>::new(1.0, -2.0, 0.5, 3.0);
        let mut vd = DVector::from_column_slice(v.as_slice());
        ldl_solve_in_place(&f, &mut v);
        ldl_solve_in_place(&fd, &mut vd);
        for i in 0..4 {
            assert_eq!(v[i].to_bits(), vd[i].to_bits(), "x[{i}]");
            for j in 0..=i {
                assert_eq!(f[(i, j)].to_bits(), fd[(i, j)].to_bits(), "f({i}, {j})");
            }
        }
        assert!((h * v - Vector::<4>::new(1.0, -2.0, 0.5, 3.0)).amax() < 1e-12);
        let indefinite = Matrix::<2, 2>::new(1.0, 2.0, 2.0, 1.0);
        assert!(!ldl_from(&indefinite, &mut Matrix::<2, 2>::zeros()));
        let singular = Matrix::<2, 2>::new(1.0, 1.0, 1.0, 1.0);
        assert!(!ldl_from(&singular, &mut Matrix::<2, 2>::zeros()));
        let nan = Matrix::<2, 2>::new(f64::NAN, 0.0, 0.0, 1.0);
        assert!(!ldl_from(&nan, &mut Matrix::<2, 2>::zeros()));
        let inf = DMatrix::from_row_slice(2, 2, &[1.0, 0.0, 0.0, f64::INFINITY]);
        assert!(!ldl_from(&inf, &mut DMatrix::zeros(2, 2)));
    }
}
