//! Exact derivatives of user models written once, generically over dual numbers (num-dual).
//!
//! Implement [`DualDynamics::step_generic`] for any scalar `T` of num-dual; [`AutoDiff`] turns it
//! into a [`Dynamics`] with exact Jacobians (forward mode, one dual pass per input) and exact
//! contracted second derivatives (hyper-dual numbers, one pass per pair of inputs).
//!
//! ```
//! use ddp_core::autodiff::{AutoDiff, DualDynamics, Scalar};
//! use ddp_core::{Dynamics, Matrix, Vector};
//! /// A pendulum, x = (angle, rate), u = torque.
//! struct Pendulum;
//! impl DualDynamics<2, 1> for Pendulum {
//!     fn step_generic<T: Scalar>(&self, x: &[T; 2], u: &[T; 1]) -> [T; 2] {
//!         let dt = 0.05;
//!         let acc = u[0] - x[0].sin() * 9.81;
//!         [x[0] + x[1] * dt, x[1] + acc * dt]
//!     }
//! }
//! let m = AutoDiff(Pendulum);
//! let (mut fx, mut fu) = (Matrix::<2, 2>::zeros(), Matrix::<2, 1>::zeros());
//! m.jacobians(&Vector::<2>::new(0.0, 0.0), &Vector::<1>::new(0.0), &mut fx, &mut fu);
//! assert!((fx[(1, 0)] + 9.81 * 0.05).abs() < 1e-15);
//! ```

use nalgebra::Const;
use num_dual::{Dual64, DualNum, HyperDual64};

use crate::{Dynamics, Matrix, Vector};

/// The scalars a [`DualDynamics`] model is evaluated with: `f64`, dual and hyper-dual numbers.
/// Arithmetic with `f64` constants works directly (`x * 2.0`, `x.sin()`).
pub trait Scalar: DualNum<Primitive = f64> + Copy + Send + Sync {}
impl<T: DualNum<Primitive = f64> + Copy + Send + Sync> Scalar for T {}

/// Dynamics written once for any [`Scalar`].
pub trait DualDynamics<const NX: usize, const NU: usize>: Send + Sync {
    /// The next state.
    fn step_generic<T: Scalar>(&self, x: &[T; NX], u: &[T; NU]) -> [T; NX];
}

/// Wraps a [`DualDynamics`] model into a [`Dynamics`] with exact derivatives.
#[derive(Debug, Clone, Copy, Default)]
pub struct AutoDiff<M>(pub M);

fn lift<T: Scalar, const N: usize>(v: &Vector<N>) -> [T; N] {
    std::array::from_fn(|i| T::from(v[i]))
}

/// Index into the stacked input `z = (x, u)`.
fn seed<T: Scalar, const NX: usize, const NU: usize>(
    x: &Vector<NX>,
    u: &Vector<NU>,
    mut set: impl FnMut(usize, f64) -> T,
) -> ([T; NX], [T; NU]) {
    (
        std::array::from_fn(|i| set(i, x[i])),
        std::array::from_fn(|i| set(NX + i, u[i])),
    )
}

impl<const NX: usize, const NU: usize, M: DualDynamics<NX, NU>> Dynamics<Const<NX>, Const<NU>> for AutoDiff<M> {
    fn step(&self, x: &Vector<NX>, u: &Vector<NU>) -> Vector<NX> {
        Vector::from(self.0.step_generic::<f64>(&lift(x), &lift(u)))
    }

    fn jacobians(&self, x: &Vector<NX>, u: &Vector<NU>, fx: &mut Matrix<NX, NX>, fu: &mut Matrix<NX, NU>) {
        for j in 0..NX + NU {
            let (xd, ud) = seed::<Dual64, NX, NU>(x, u, |i, v| Dual64::new(v, if i == j { 1.0 } else { 0.0 }));
            let y = self.0.step_generic(&xd, &ud);
            for i in 0..NX {
                if j < NX {
                    fx[(i, j)] = y[i].eps;
                } else {
                    fu[(i, j - NX)] = y[i].eps;
                }
            }
        }
    }

    fn has_second_order(&self) -> bool {
        true
    }

    fn add_second_order(
        &self,
        x: &Vector<NX>,
        u: &Vector<NU>,
        lambda: &Vector<NX>,
        h_xx: &mut Matrix<NX, NX>,
        h_ux: &mut Matrix<NU, NX>,
        h_uu: &mut Matrix<NU, NU>,
    ) {
        let n = NX + NU;
        for a in 0..n {
            for b in a..n {
                let (xd, ud) = seed::<HyperDual64, NX, NU>(x, u, |i, v| {
                    HyperDual64::new(v, if i == a { 1.0 } else { 0.0 }, if i == b { 1.0 } else { 0.0 }, 0.0)
                });
                let y = self.0.step_generic(&xd, &ud);
                let s: f64 = (0..NX).map(|i| lambda[i] * y[i].eps1eps2).sum();
                // Fill the symmetric (x, u) Hessian block by block.
                match (a < NX, b < NX) {
                    (true, true) => {
                        h_xx[(a, b)] += s;
                        if a != b {
                            h_xx[(b, a)] += s;
                        }
                    }
                    (true, false) => h_ux[(b - NX, a)] += s,
                    // b >= a, so a past the states means both are controls.
                    _ => {
                        h_uu[(a - NX, b - NX)] += s;
                        if a != b {
                            h_uu[(b - NX, a - NX)] += s;
                        }
                    }
                }
            }
        }
    }
}
