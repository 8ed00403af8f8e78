//! Cross-crate tests of ddpkit (the README's quick start, Safe-CDDP / ddp-core parity, run-time
//! sizes). The library holds shared helpers; the tests are the `[[test]]` targets.

use ddp_core::dims::{Dyn, MatrixN, VectorN};

/// A seeded linear congruential generator in `[-1, 1)` (no dependency on `rand`).
pub struct Lcg(pub u64);

impl Lcg {
    /// The next value.
    pub fn next_f64(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
    /// An `r x c` matrix of values in `[-1, 1)` scaled by `s`.
    pub fn matrix(&mut self, r: usize, c: usize, s: f64) -> MatrixN<Dyn, Dyn> {
        MatrixN::<Dyn, Dyn>::from_fn(r, c, |_, _| s * self.next_f64())
    }
}

/// Gains `K_k`, states `x_0 .. x_N` and controls `u_0 .. u_{N-1}` of an LQ solution.
pub type LqSolution = (Vec<MatrixN<Dyn, Dyn>>, Vec<VectorN<Dyn>>, Vec<VectorN<Dyn>>);

/// The discrete Riccati recursion of the LQ problem `x+ = A x + B u`, cost
/// `sum 1/2 (x^T Q x + u^T R u) + 1/2 x_N^T Q_f x_N`: gains `K_k` (`u = K x`), and the rollout.
pub fn riccati(
    a: &MatrixN<Dyn, Dyn>,
    b: &MatrixN<Dyn, Dyn>,
    q: &MatrixN<Dyn, Dyn>,
    r: &MatrixN<Dyn, Dyn>,
    qf: &MatrixN<Dyn, Dyn>,
    x0: &VectorN<Dyn>,
    n: usize,
) -> LqSolution {
    let mut p = qf.clone();
    let mut gains = vec![MatrixN::<Dyn, Dyn>::zeros(b.ncols(), a.ncols()); n];
    for k in (0..n).rev() {
        let s = r + b.transpose() * &p * b;
        let k_gain = -s.cholesky().expect("R + B^T P B > 0").solve(&(b.transpose() * &p * a));
        let closed = a + b * &k_gain;
        p = q + k_gain.transpose() * r * &k_gain + closed.transpose() * &p * &closed;
        p = (&p + p.transpose()) * 0.5;
        gains[k] = k_gain;
    }
    let mut xs = vec![x0.clone()];
    let mut us = Vec::with_capacity(n);
    for g in &gains {
        let x = xs.last().expect("x0");
        let u = g * x;
        xs.push(a * x + b * &u);
        us.push(u);
    }
    (gains, xs, us)
}
