//! Smooth penalties for circular obstacles, for solvers without constraints.
//!
//! The benchmark problems of `bench/problems.md` state obstacles in squared-distance form
//! `h_o(p) = r_o^2 - |p - o|^2 <= 0`. Until a constrained solver handles them, an unconstrained
//! DDP can approach the constrained optimum by penalising the violation with a squared hinge
//!
//! ```text
//! l(x) = w * sum_o max(0, h_o(p))^2,      p = (x[i0], x[i1])
//! ```
//!
//! and raising `w` over a few warm-started solves (a continuation). The squared hinge is `C^1`
//! (its gradient vanishes continuously at the boundary), so the line search sees a smooth cost.
//!
//! | quantity | formula |
//! |---|---|
//! | gradient in `p` | `-4 w sum_{h_o > 0} h_o (p - o)` |
//! | Gauss-Newton Hessian in `p` | `8 w sum_{h_o > 0} (p - o)(p - o)^T` |
//!
//! The exact Hessian adds `-4 w h_o I` per active obstacle, which is negative definite; DDP needs a
//! positive semidefinite `l_xx`, so [`CirclePenalty`] adds only the Gauss-Newton part (the product
//! of the gradients of the residual `max(0, h_o)`), which is PSD.
//!
//! ```
//! use ddp_core::penalty::CirclePenalty;
//! use ddp_core::{TerminalCost, Vector};
//! // One obstacle of radius 1 at the origin; the position is (x[0], x[1]).
//! let p = CirclePenalty::<3>::new(vec![[0.0, 0.0, 1.0]], [0, 1], 2.0).unwrap();
//! // Outside: no penalty.
//! assert_eq!(p.value(&Vector::<3>::new(1.5, 0.0, 0.0)), 0.0);
//! // Inside at distance 0.5: h = 1 - 0.25 = 0.75, l = 2 * 0.75^2.
//! assert!((p.value(&Vector::<3>::new(0.5, 0.0, 0.0)) - 2.0 * 0.75 * 0.75).abs() < 1e-15);
//! ```

use crate::error::{check_finite, check_nonnegative, Error, Result};
use crate::{TerminalCost, TerminalDerivatives, Vector};
use nalgebra::Const;

/// Squared-hinge penalty `w * sum_o max(0, r_o^2 - |p - o|^2)^2` on circular obstacles
/// `(ox, oy, r)`, with the planar position `p = (x[i0], x[i1])`.
///
/// A state-only term: use it as a terminal cost directly, or as a running cost through
/// [`crate::costs::StateOnly`]. See the [module docs](self) for the derivatives.
#[derive(Debug, Clone, PartialEq)]
pub struct CirclePenalty<const NX: usize> {
    circles: Vec<[f64; 3]>,
    indices: [usize; 2],
    weight: f64,
}

impl<const NX: usize> CirclePenalty<NX> {
    /// `circles`: `(ox, oy, r)` per obstacle (finite, `r >= 0`); `indices`: the state indices of
    /// the position (distinct, `< NX`); `weight`: `w >= 0`. Allocates nothing beyond taking
    /// `circles`.
    pub fn new(circles: Vec<[f64; 3]>, indices: [usize; 2], weight: f64) -> Result<Self> {
        for (k, c) in circles.iter().enumerate() {
            check_finite(&format!("circles[{k}]"), c.iter())?;
            if c[2] < 0.0 {
                return Err(Error::invalid(
                    format!("circles[{k}]"),
                    format!("radius must be >= 0, got {}", c[2]),
                ));
            }
        }
        for (i, &j) in indices.iter().enumerate() {
            if j >= NX {
                return Err(Error::invalid(
                    format!("indices[{i}]"),
                    format!("state index {j} out of range for a {NX}-dimensional state"),
                ));
            }
        }
        if indices[0] == indices[1] {
            return Err(Error::invalid("indices", "the two position indices must differ"));
        }
        check_nonnegative("weight", [weight].iter())?;
        Ok(Self {
            circles,
            indices,
            weight,
        })
    }

    /// The obstacles `(ox, oy, r)`.
    pub fn circles(&self) -> &[[f64; 3]] {
        &self.circles
    }

    /// The weight `w`.
    pub fn weight(&self) -> f64 {
        self.weight
    }

    /// The largest violation `max_o max(0, r_o^2 - |p - o|^2)` at `x` (0 when outside every circle).
    pub fn max_violation(&self, x: &Vector<NX>) -> f64 {
        let [i, j] = self.indices;
        self.circles.iter().fold(0.0, |m, c| {
            let (ex, ey) = (x[i] - c[0], x[j] - c[1]);
            m.max(c[2] * c[2] - (ex * ex + ey * ey))
        })
    }
}

impl<const NX: usize> TerminalCost<Const<NX>> for CirclePenalty<NX> {
    fn value(&self, x: &Vector<NX>) -> f64 {
        let [i, j] = self.indices;
        let mut sum = 0.0;
        for c in &self.circles {
            let (ex, ey) = (x[i] - c[0], x[j] - c[1]);
            let h = c[2] * c[2] - (ex * ex + ey * ey);
            if h > 0.0 {
                sum += h * h;
            }
        }
        self.weight * sum
    }

    fn add_derivatives(&self, x: &Vector<NX>, w: f64, d: &mut TerminalDerivatives<Const<NX>>) -> f64 {
        let [i, j] = self.indices;
        let c_w = w * self.weight;
        let mut sum = 0.0;
        for c in &self.circles {
            let e = [x[i] - c[0], x[j] - c[1]];
            let h = c[2] * c[2] - (e[0] * e[0] + e[1] * e[1]);
            if h > 0.0 {
                sum += h * h;
                // d/dp h^2 = 2 h dh/dp = -4 h e; Gauss-Newton: 2 (dh/dp)(dh/dp)^T = 8 e e^T.
                let idx = [i, j];
                for a in 0..2 {
                    d.lx[idx[a]] -= 4.0 * c_w * h * e[a];
                    for b in 0..2 {
                        d.lxx[(idx[a], idx[b])] += 8.0 * c_w * e[a] * e[b];
                    }
                }
            }
        }
        c_w * sum
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::U4;

    fn penalty() -> CirclePenalty<4> {
        CirclePenalty::new(vec![[1.0, 0.1, 0.35], [2.0, -0.1, 0.35], [0.9, 0.3, 0.2]], [0, 1], 3.0).unwrap()
    }

    /// Central-difference gradient of `value`.
    fn fd_gradient(p: &CirclePenalty<4>, x: &Vector<4>) -> Vector<4> {
        let h = f64::EPSILON.cbrt();
        Vector::<4>::from_fn(|k, _| {
            let (mut xp, mut xm) = (*x, *x);
            xp[k] += h;
            xm[k] -= h;
            (p.value(&xp) - p.value(&xm)) / (2.0 * h)
        })
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let p = penalty();
        // Inside one circle, inside two overlapping circles, outside all.
        for x in [
            Vector::<4>::new(1.1, 0.2, 0.3, -1.0),
            Vector::<4>::new(0.95, 0.25, 0.0, 0.0),
            Vector::<4>::new(2.1, -0.15, 1.0, 2.0),
            Vector::<4>::new(5.0, 5.0, 0.0, 0.0),
        ] {
            let mut d = TerminalDerivatives::<U4>::default();
            let v = p.add_derivatives(&x, 1.0, &mut d);
            assert!((v - p.value(&x)).abs() <= 1e-14 * (1.0 + v.abs()));
            let fd = fd_gradient(&p, &x);
            let err = (d.lx - fd).amax();
            assert!(
                err < 1e-6 * (1.0 + fd.amax()),
                "x = {x:?}: analytic {:?} vs fd {fd:?}",
                d.lx
            );
        }
    }

    #[test]
    fn hessian_is_gauss_newton_and_psd() {
        let p = CirclePenalty::<4>::new(vec![[0.0, 0.0, 1.0]], [0, 1], 2.0).unwrap();
        let x = Vector::<4>::new(0.3, -0.4, 0.0, 0.0);
        let mut d = TerminalDerivatives::<U4>::default();
        p.add_derivatives(&x, 0.5, &mut d);
        // 8 * (w_outer * w) * e e^T with e = (0.3, -0.4), w_outer * w = 1.
        let e = [0.3, -0.4];
        for a in 0..2 {
            for b in 0..2 {
                assert!((d.lxx[(a, b)] - 8.0 * e[a] * e[b]).abs() < 1e-14);
            }
        }
        // Only the position block is touched and it is PSD.
        assert_eq!(d.lxx[(2, 2)], 0.0);
        let eig = d.lxx.symmetric_eigenvalues();
        assert!(eig.min() >= -1e-14);
        // The Gauss-Newton Hessian is the exact Hessian plus 4 w h I: compare with finite
        // differences of the gradient.
        let h_res = 1.0 - (0.09 + 0.16);
        let step = 1e-6;
        for a in 0..2 {
            let (mut xp, mut xm) = (x, x);
            xp[a] += step;
            xm[a] -= step;
            let (mut dp, mut dm) = (
                TerminalDerivatives::<U4>::default(),
                TerminalDerivatives::<U4>::default(),
            );
            p.add_derivatives(&xp, 0.5, &mut dp);
            p.add_derivatives(&xm, 0.5, &mut dm);
            for b in 0..2 {
                let exact = (dp.lx[b] - dm.lx[b]) / (2.0 * step);
                let gn_minus_curvature = d.lxx[(b, a)] - if a == b { 4.0 * h_res } else { 0.0 };
                assert!(
                    (exact - gn_minus_curvature).abs() < 1e-6,
                    "({a},{b}): {exact} vs {gn_minus_curvature}"
                );
            }
        }
    }

    #[test]
    fn max_violation_is_the_squared_distance_form() {
        let p = penalty();
        let x = Vector::<4>::new(1.0, 0.1, 0.0, 0.0);
        assert!((p.max_violation(&x) - 0.35 * 0.35).abs() < 1e-15);
        assert_eq!(p.max_violation(&Vector::<4>::new(5.0, 5.0, 0.0, 0.0)), 0.0);
    }

    #[test]
    fn bad_input_is_rejected_naming_the_field() {
        let nan = CirclePenalty::<3>::new(vec![[0.0, f64::NAN, 1.0]], [0, 1], 1.0).unwrap_err();
        assert!(nan.to_string().contains("circles[0]"), "{nan}");
        let neg_r = CirclePenalty::<3>::new(vec![[0.0, 0.0, -1.0]], [0, 1], 1.0).unwrap_err();
        assert!(neg_r.to_string().contains("radius"), "{neg_r}");
        let idx = CirclePenalty::<3>::new(vec![], [0, 3], 1.0).unwrap_err();
        assert!(idx.to_string().contains("indices[1]"), "{idx}");
        let same = CirclePenalty::<3>::new(vec![], [1, 1], 1.0).unwrap_err();
        assert!(same.to_string().contains("indices"), "{same}");
        let w = CirclePenalty::<3>::new(vec![], [0, 1], -1.0).unwrap_err();
        assert!(w.to_string().contains("weight"), "{w}");
    }
}
