//! Small fixed-size matrix kernels for the solver's hot loops.
//!
//! nalgebra's generic products go through stride-aware loops that the compiler does not fully
//! unroll for tiny sizes; these operate on the column-major arrays directly, with const bounds,
//! so they unroll completely and carry no bounds checks. Each is checked against nalgebra.

use crate::{Matrix, Vector};

/// `A B`
#[inline(always)]
pub fn mul<const R: usize, const K: usize, const C: usize>(a: &Matrix<R, K>, b: &Matrix<K, C>) -> Matrix<R, C> {
    let (a, b) = (&a.data.0, &b.data.0);
    let mut out = [[0.0; R]; C];
    for j in 0..C {
        for k in 0..K {
            let bkj = b[j][k];
            for i in 0..R {
                out[j][i] += a[k][i] * bkj;
            }
        }
    }
    Matrix::from_data(nalgebra::ArrayStorage(out))
}

/// `A^T B`
#[inline(always)]
pub fn tr_mul<const K: usize, const R: usize, const C: usize>(a: &Matrix<K, R>, b: &Matrix<K, C>) -> Matrix<R, C> {
    let (a, b) = (&a.data.0, &b.data.0);
    let mut out = [[0.0; R]; C];
    for j in 0..C {
        for i in 0..R {
            let mut s = 0.0;
            for k in 0..K {
                s += a[i][k] * b[j][k];
            }
            out[j][i] = s;
        }
    }
    Matrix::from_data(nalgebra::ArrayStorage(out))
}

/// `A x`
#[inline(always)]
pub fn mul_vec<const R: usize, const K: usize>(a: &Matrix<R, K>, x: &Vector<K>) -> Vector<R> {
    let (a, x) = (&a.data.0, &x.data.0[0]);
    let mut out = [0.0; R];
    for k in 0..K {
        for i in 0..R {
            out[i] += a[k][i] * x[k];
        }
    }
    Vector::from_data(nalgebra::ArrayStorage([out]))
}

/// `A^T x`
#[inline(always)]
pub fn tr_mul_vec<const K: usize, const R: usize>(a: &Matrix<K, R>, x: &Vector<K>) -> Vector<R> {
    let (a, x) = (&a.data.0, &x.data.0[0]);
    let mut out = [0.0; R];
    for i in 0..R {
        let mut s = 0.0;
        for k in 0..K {
            s += a[i][k] * x[k];
        }
        out[i] = s;
    }
    Vector::from_data(nalgebra::ArrayStorage([out]))
}

/// `C + A^T B` for a product known to be symmetric: the upper triangle is computed and mirrored.
#[inline(always)]
pub fn add_sym_tr_mul<const K: usize, const N: usize>(
    c: &Matrix<N, N>,
    a: &Matrix<K, N>,
    b: &Matrix<K, N>,
) -> Matrix<N, N> {
    let (a, b, c) = (&a.data.0, &b.data.0, &c.data.0);
    let mut out = [[0.0; N]; N];
    for j in 0..N {
        for i in 0..=j {
            let mut s = c[j][i];
            for k in 0..K {
                s += a[i][k] * b[j][k];
            }
            out[j][i] = s;
            out[i][j] = s;
        }
    }
    Matrix::from_data(nalgebra::ArrayStorage(out))
}

/// `C + A^T B + D^T E` for a sum known to be symmetric (upper triangle computed and mirrored).
#[inline(always)]
pub fn add_sym_tr_mul2<const K: usize, const N: usize>(
    c: &Matrix<N, N>,
    a: &Matrix<K, N>,
    b: &Matrix<K, N>,
    d: &Matrix<K, N>,
    e: &Matrix<K, N>,
) -> Matrix<N, N> {
    let (a, b, c, d, e) = (&a.data.0, &b.data.0, &c.data.0, &d.data.0, &e.data.0);
    let mut out = [[0.0; N]; N];
    for j in 0..N {
        for i in 0..=j {
            let mut s = c[j][i];
            for k in 0..K {
                s += a[i][k] * b[j][k] + d[i][k] * e[j][k];
            }
            out[j][i] = s;
            out[i][j] = s;
        }
    }
    Matrix::from_data(nalgebra::ArrayStorage(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernels_match_nalgebra() {
        let a = Matrix::<3, 4>::from_fn(|i, j| (i * 4 + j) as f64 * 0.3 - 1.0);
        let b = Matrix::<4, 2>::from_fn(|i, j| (i + 2 * j) as f64 * 0.7 - 0.5);
        let c = Matrix::<3, 2>::from_fn(|i, j| (i * j) as f64 + 0.25);
        let x = Vector::<4>::new(0.5, -1.0, 2.0, 0.25);
        let y = Vector::<3>::new(1.5, -0.5, 0.75);
        assert!((mul(&a, &b) - a * b).amax() < 1e-14);
        assert!((tr_mul(&a, &c) - a.transpose() * c).amax() < 1e-14);
        assert!((mul_vec(&a, &x) - a * x).amax() < 1e-14);
        assert!((tr_mul_vec(&a, &y) - a.transpose() * y).amax() < 1e-14);
        let s = Matrix::<3, 3>::new(2.0, 0.5, 0.1, 0.5, 1.0, -0.3, 0.1, -0.3, 3.0);
        let f = Matrix::<3, 3>::from_fn(|i, j| (i + j * j) as f64 * 0.2 - 0.4);
        let sf = s * f;
        let c = Matrix::<3, 3>::identity();
        assert!((add_sym_tr_mul(&c, &f, &sf) - (c + f.transpose() * sf)).amax() < 1e-14);
        let k = Matrix::<2, 3>::from_fn(|i, j| (i * 3 + j) as f64 * 0.1 - 0.2);
        let q = Matrix::<2, 3>::from_fn(|i, j| (2 * i + j) as f64 * 0.3 - 0.5);
        let quu = Matrix::<2, 2>::new(2.0, 0.3, 0.3, 1.0);
        // K^T (Quu K + Qux) + Qux^T K is symmetric for any K.
        let m = quu * k + q;
        let full = c + k.transpose() * m + q.transpose() * k;
        assert!((add_sym_tr_mul2(&c, &k, &m, &q, &k) - full).amax() < 1e-14);
    }
}
