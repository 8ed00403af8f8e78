//! Built-in models with analytic first and second derivatives.
//!
//! | model | `NX` | `NU` | state | control | discretisation | matches |
//! |---|---:|---:|---|---|---|---|
//! | [`DoubleIntegrator2D`] | 4 | 2 | `px, py, vx, vy` | `ax, ay` | exact zero-order hold | benchmark P3, Safe-CDDP point robot |
//! | [`Unicycle`] | 3 | 2 | `px, py, theta` | `v, omega` | explicit Euler | benchmark P1 (Crocoddyl `ActionModelUnicycle`), DDPEN robot |
//! | [`Car`] | 4 | 2 | `px, py, theta, v` | `omega, a` | explicit Euler | benchmark P2, Safe-CDDP car |
//! | [`DifferentialDrive`] | 3 | 2 | `px, py, theta` | `v_l, v_r` | Euler with midpoint heading | Turtlebot3-style robots |
//! | [`Quadrotor`] | 12 | 4 | `p, (phi, theta, psi), v, (p, q, r)` | thrust, body torques | explicit Euler | Safe-CDDP quadrotor |
//! | [`ArmBase`] | 10 | 5 | `x, y, theta, q1, q2` and rates | base force, base torque, joint torques | semi-implicit Euler | IDNP satellite with a 2-link arm |
//!
//! Every model is an immutable `Copy` value, validated by its constructor (an error names the
//! field), and implements both [`Dynamics`](crate::Dynamics) (hand-written first derivatives,
//! contracted second derivatives, no allocation) and
//! [`DualDynamics`](crate::autodiff::DualDynamics) (the same step written for any scalar, so
//! [`AutoDiff`](crate::autodiff::AutoDiff) can cross-check the analytic derivatives).
//!
//! ```
//! use ddp_core::models::Unicycle;
//! use ddp_core::{Dynamics, Vector};
//! let model = Unicycle::new(0.1)?;
//! let x1 = model.step(&Vector::<3>::new(-1.0, -1.0, 1.0), &Vector::<2>::new(1.0, 0.5));
//! assert!((x1[2] - 1.05).abs() < 1e-15);
//! # Ok::<(), ddp_core::Error>(())
//! ```

mod arm_base;
mod car;
mod differential_drive;
mod double_integrator;
mod quadrotor;
mod unicycle;

pub use arm_base::{ArmBase, ArmBaseParams};
pub use car::Car;
pub use differential_drive::DifferentialDrive;
pub use double_integrator::DoubleIntegrator2D;
pub use quadrotor::Quadrotor;
pub use unicycle::Unicycle;

// The constructors' validators (`?` turns a failure into an `Error::Invalid` naming the field).
use ddpkit_util::check::{finite, nonnegative, positive};

use crate::Matrix;

/// Sets `m` to the identity (a slice fill: nalgebra's element iterators are slow in hot loops).
#[inline]
fn set_identity<const N: usize>(m: &mut Matrix<N, N>) {
    m.as_mut_slice().fill(0.0);
    for i in 0..N {
        m[(i, i)] = 1.0;
    }
}

/// Sets every entry of `m` to zero.
#[inline]
fn set_zero<const R: usize, const C: usize>(m: &mut Matrix<R, C>) {
    m.as_mut_slice().fill(0.0);
}

/// `(sin theta, cos theta)` for every model's angles, and for the sines and cosines of models
/// traced into a tape (`ddp-tape`): musl's `sincos` (the `libm` crate, within one ulp), not the
/// platform's. glibc's saves, sets and restores the rounding mode on every call, about half of its
/// time in a profile of the family replays (where `sin_cos` took 7-9 % of a solve); this one runs
/// in about 0.6x the time, and gives the same bits on every platform.
#[inline]
pub fn sin_cos(theta: f64) -> (f64, f64) {
    libm::sincos(theta)
}

/// [`sin_cos`], kept in a knot's `data` as `[theta, sin, cos]`: by the rollout's step for
/// the Jacobians ([`crate::Dynamics::step_keep`]), by the Jacobians for the second-order terms
/// ([`crate::Dynamics::jacobians_keep`]) of the same knot.
#[inline]
fn keep_sin_cos(theta: f64, data: &mut Vec<f64>) -> (f64, f64) {
    let (s, c) = sin_cos(theta);
    // Grown once; after that three stores, as cheap as the rollout's step itself.
    if let [t, ks, kc] = &mut data[..] {
        (*t, *ks, *kc) = (theta, s, c);
    } else {
        data.clear();
        data.extend_from_slice(&[theta, s, c]);
    }
    (s, c)
}

/// The `sin_cos` [`keep_sin_cos`] kept, when it was kept at this `theta`, bit for bit (the data
/// may belong to another point; `-0.0` is not `0.0` to `sin`); else computed.
#[inline]
fn kept_sin_cos(theta: f64, data: &[f64]) -> (f64, f64) {
    match data {
        [t, s, c] if t.to_bits() == theta.to_bits() => (*s, *c),
        _ => sin_cos(theta),
    }
}

#[cfg(test)]
mod tests {
    use super::sin_cos;

    /// Units in the last place between two finite values of the same sign (or zero).
    fn ulps(a: f64, b: f64) -> u64 {
        if a == b {
            return 0;
        }
        assert_eq!(a.is_sign_negative(), b.is_sign_negative(), "{a} and {b}");
        a.to_bits().abs_diff(b.to_bits())
    }

    /// The models' `sin_cos` is faithful: within one ulp of the platform's (each within one ulp
    /// of the exact value) on headings a robot turns through, on angles far out (the large
    /// argument reduction) and on exact points.
    #[test]
    fn sin_cos_is_within_one_ulp_of_the_platform_s() {
        let angles = (0..200_001)
            .map(|i| -40.0 + 4e-4 * i as f64)
            .chain((0..2_000).map(|i| 1e3 + 997.3 * i as f64))
            .chain([
                0.0,
                -0.0,
                1e-300,
                std::f64::consts::FRAC_PI_2,
                std::f64::consts::PI,
                1e300,
            ]);
        for t in angles {
            let (s, c) = sin_cos(t);
            let (s0, c0) = t.sin_cos();
            // Signs agree except where the exact value is within an ulp of zero.
            if s0.abs() > 1e-300 {
                assert!(ulps(s, s0) <= 1, "sin({t}) = {s}, the platform's {s0}");
            } else {
                assert!((s - s0).abs() <= 1e-300, "sin({t}) = {s}, the platform's {s0}");
            }
            assert!(
                ulps(c, c0) <= 1 || (c - c0).abs() <= 1e-300,
                "cos({t}) = {c}, the platform's {c0}"
            );
        }
        // Exact: sin 0 = 0 (with the sign of zero), cos 0 = 1.
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        assert!(sin_cos(-0.0).0.is_sign_negative());
    }
}
