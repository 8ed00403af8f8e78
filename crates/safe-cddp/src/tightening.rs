//! Closed-loop covariance propagation (eq. 19) and constraint tightening (eq. 20).
//!
//! ```text
//! Sigma_{k+1} = (f_x + f_u K_k) Sigma_k (f_x + f_u K_k)^T + Sigma_w                  (19)
//! g~_i(x, u)  = g_i(x, u) + phi^{-1}(beta) sqrt(g_x^T Sigma g_x + sigma_p^2)          (20)
//! ```
//!
//! (The paper prints eq. (19) with the transposes swapped; the form above is the covariance of
//! `dx+ = (f_x + f_u K) dx + w`.) `K_k` are the gains of the constrained backward pass
//! ([`Gains::ClosedLoop`], Safe-CDDP: the backward pass with the control bounds as its only
//! rows; [`Gains::ActiveSet`]: with the state-constraint rows of the working set too), zero ([`Gains::OpenLoop`]) or one fixed gain
//! ([`Gains::Fixed`], e.g. [`lqr_gain`] at the goal, as cautious MPC). `sigma_p^2` is the
//! variance a constraint reports for its own parameters ([`crate::Constraint::parameter_variance`],
//! e.g. a tracked obstacle). For a mixed row the closed-loop control `u = u_bar + K dx` enters
//! too: the gradient is `g_x + K^T g_u`.
//!
//! ```
//! use safe_cddp::tightening::{propagate_covariance, Gains};
//! use ddp_core::Matrix;
//! // A scalar random walk x+ = x + u + w, open loop: the variance grows by Sigma_w each step.
//! let (fx, fu) = (vec![Matrix::<1, 1>::identity(); 3], vec![Matrix::<1, 1>::identity(); 3]);
//! let mut sigma = vec![Matrix::<1, 1>::zeros(); 4];
//! propagate_covariance(&fx, &fu, &Gains::OpenLoop, &[], &Matrix::zeros(), &Matrix::identity(), &mut sigma);
//! assert_eq!(sigma[3][(0, 0)], 3.0);
//! ```

use ddp_core::costs::check_psd;
use ddp_core::dims::{Alloc, DefaultAllocator, Dim, MatrixN, VectorN};
use ddp_core::error::check_finite;
use ddp_core::{Error, Matrix, Result};

use crate::quantile::normal_quantile;

/// Which feedback gains the covariance propagation uses.
#[derive(Debug, Clone, PartialEq)]
pub enum Gains<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Safe-CDDP (the default): the feedback gains `K_k` of the DDP backward pass at the current
    /// trajectory, eqs. (10)-(12) with the control bounds as the only rows of the working set (a
    /// control at its bound gives no feedback). The state-constraint rows are left out on
    /// purpose: a row of relative degree `r` in the working set makes eq. (12) a dead-beat gain
    /// of size `O(1/dt^r)` on the very quantity that row's margin protects, so an active row's
    /// margin collapses, the row turns inactive, its margin jumps back, and the solve oscillates
    /// between the two (it never converged on the car). Such gains also assume controls far
    /// beyond the bounds. [`Gains::ActiveSet`] keeps the literal reading.
    ClosedLoop,
    /// The gains of the last constrained backward pass, state-constraint rows of its working set
    /// included (eq. 12 literally). For comparison: with relative-degree-2 rows (the car) the
    /// tightening oscillates (see [`Gains::ClosedLoop`]).
    ActiveSet,
    /// `K = 0`: open-loop propagation (the most conservative baseline).
    OpenLoop,
    /// One fixed gain at every knot (e.g. LQR at the goal; cautious MPC).
    Fixed(MatrixN<NU, NX>),
}

/// The chance-constraint tightening: `beta`, the process noise `Sigma_w`, the initial covariance,
/// the gains and the update period `n2` of Algorithm 1.
#[derive(Debug, Clone, PartialEq)]
pub struct Tightening<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    beta: f64,
    z: f64,
    sigma_w: MatrixN<NX, NX>,
    sigma_0: MatrixN<NX, NX>,
    gains: Gains<NX, NU>,
    update_every: usize,
}

impl<NX: Dim, NU: Dim> Tightening<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Satisfaction probability `beta` in (0, 1) and process-noise covariance `sigma_w`
    /// (symmetric PSD). Defaults: closed-loop gains, `Sigma_0 = 0` (the state is measured),
    /// tightening every `n2 = 5` iterations.
    pub fn new(beta: f64, sigma_w: MatrixN<NX, NX>) -> Result<Self> {
        let z =
            normal_quantile(beta).ok_or_else(|| Error::invalid("beta", format!("must be in (0, 1), got {beta}")))?;
        if sigma_w.nrows() != sigma_w.ncols() {
            return Err(Error::Shape {
                field: "sigma_w".into(),
                got: format!("({}, {})", sigma_w.nrows(), sigma_w.ncols()),
                expected: "a square matrix".into(),
            });
        }
        check_psd("sigma_w", &sigma_w)?;
        let (r, c) = sigma_w.shape_generic();
        Ok(Self {
            beta,
            z,
            sigma_0: MatrixN::zeros_generic(r, c),
            sigma_w,
            gains: Gains::ClosedLoop,
            update_every: 5,
        })
    }
    /// Uses other gains.
    pub fn with_gains(mut self, gains: Gains<NX, NU>) -> Result<Self> {
        if let Gains::Fixed(k) = &gains {
            check_finite("gains", k.iter())?;
        }
        self.gains = gains;
        Ok(self)
    }
    /// Starts the propagation from `sigma_0` (symmetric PSD) instead of zero.
    pub fn with_initial_covariance(mut self, sigma_0: MatrixN<NX, NX>) -> Result<Self> {
        if sigma_0.shape() != self.sigma_w.shape() {
            return Err(Error::Shape {
                field: "sigma_0".into(),
                got: format!("{:?}", sigma_0.shape()),
                expected: format!("{:?} like sigma_w", self.sigma_w.shape()),
            });
        }
        check_psd("sigma_0", &sigma_0)?;
        self.sigma_0 = sigma_0;
        Ok(self)
    }
    /// Tightens every `n2` iterations (`n2 >= 1`) in [`crate::SafeCddpSolver::solve`] and the MPC.
    pub fn with_update_every(mut self, n2: usize) -> Result<Self> {
        if n2 == 0 {
            return Err(Error::invalid("update_every", "must be at least 1"));
        }
        self.update_every = n2;
        Ok(self)
    }
    /// `beta`.
    pub fn beta(&self) -> f64 {
        self.beta
    }
    /// `phi^{-1}(beta)`.
    pub fn quantile(&self) -> f64 {
        self.z
    }
    /// `Sigma_w`.
    pub fn sigma_w(&self) -> &MatrixN<NX, NX> {
        &self.sigma_w
    }
    /// `Sigma_0`.
    pub fn sigma_0(&self) -> &MatrixN<NX, NX> {
        &self.sigma_0
    }
    /// The gains.
    pub fn gains(&self) -> &Gains<NX, NU> {
        &self.gains
    }
    /// `n2`.
    pub fn update_every(&self) -> usize {
        self.update_every
    }
    /// Checks that the covariances and a fixed gain fit `nx` states and `nu` controls, naming
    /// the field (the solver calls this when the tightening is set).
    pub fn check_sizes(&self, nx: usize, nu: usize) -> Result<()> {
        if self.sigma_w.nrows() != nx {
            return Err(Error::Shape {
                field: "tightening.sigma_w".into(),
                got: format!("({0}, {0})", self.sigma_w.nrows()),
                expected: format!("({nx}, {nx})"),
            });
        }
        if let Gains::Fixed(k) = &self.gains {
            if k.shape() != (nu, nx) {
                return Err(Error::Shape {
                    field: "tightening.gains".into(),
                    got: format!("{:?}", k.shape()),
                    expected: format!("({nu}, {nx})"),
                });
            }
        }
        Ok(())
    }
}

/// Eq. (19) along a horizon of `fx.len()` knots: writes `sigma[0] = sigma_0` and
/// `sigma[k+1] = A_k sigma[k] A_k^T + sigma_w` with `A_k = fx[k] + fu[k] K_k`, where `K_k` is
/// `closed_loop[k]` for [`Gains::ClosedLoop`] and [`Gains::ActiveSet`] (the caller's per-knot
/// gains). `sigma` needs `fx.len() + 1` entries.
pub fn propagate_covariance<NX: Dim, NU: Dim>(
    fx: &[MatrixN<NX, NX>],
    fu: &[MatrixN<NX, NU>],
    gains: &Gains<NX, NU>,
    closed_loop: &[MatrixN<NU, NX>],
    sigma_0: &MatrixN<NX, NX>,
    sigma_w: &MatrixN<NX, NX>,
    sigma: &mut [MatrixN<NX, NX>],
) where
    DefaultAllocator: Alloc<NX, NU>,
{
    let n = fx.len();
    sigma[0].copy_from(sigma_0);
    for k in 0..n {
        let a = match gains {
            Gains::ClosedLoop | Gains::ActiveSet => &fx[k] + &fu[k] * &closed_loop[k],
            Gains::OpenLoop => fx[k].clone(),
            Gains::Fixed(gain) => &fx[k] + &fu[k] * gain,
        };
        let next = &a * &sigma[k] * a.transpose() + sigma_w;
        sigma[k + 1] = (&next + next.transpose()) * 0.5;
    }
}

/// The margin of eq. (20), `z sqrt(g_x^T Sigma g_x + extra_variance)` (the variance is clipped
/// at zero against round-off).
#[inline]
pub fn margin<NX: Dim>(z: f64, g_x: &VectorN<NX>, sigma: &MatrixN<NX, NX>, extra_variance: f64) -> f64
where
    DefaultAllocator: Alloc<NX, NX>,
{
    z * (g_x.dot(&(sigma * g_x)) + extra_variance).max(0.0).sqrt()
}

/// The stationary LQR gain `K` (`u = K x`) of `x+ = A x + B u` with stage cost
/// `1/2 (x^T Q x + u^T R u)`, by Riccati iteration from `P = Q` until the gain changes by less
/// than `tolerance` (max-norm) or `max_iterations` is reached; the last gain is returned either
/// way (for a system that is not stabilisable, e.g. a car at rest, this is a long finite-horizon
/// gain). Errors on a non-PSD `Q`, `R` or a `B^T P B + R` that is not positive definite.
pub fn lqr_gain<const NX: usize, const NU: usize>(
    a: &Matrix<NX, NX>,
    b: &Matrix<NX, NU>,
    q: &Matrix<NX, NX>,
    r: &Matrix<NU, NU>,
    max_iterations: usize,
    tolerance: f64,
) -> Result<Matrix<NU, NX>> {
    check_finite("a", a.iter())?;
    check_finite("b", b.iter())?;
    check_psd("q", q)?;
    check_psd("r", r)?;
    let mut p = *q;
    let mut gain = Matrix::<NU, NX>::zeros();
    for _ in 0..max_iterations.max(1) {
        let s = r + b.transpose() * p * b;
        let chol = s
            .cholesky()
            .ok_or_else(|| Error::invalid("r", "B^T P B + R is not positive definite"))?;
        let next_gain = -chol.solve(&(b.transpose() * p * a));
        let closed = a + b * next_gain;
        let next_p = q + next_gain.transpose() * r * next_gain + closed.transpose() * p * closed;
        p = 0.5 * (next_p + next_p.transpose());
        let change = (next_gain - gain).amax();
        gain = next_gain;
        if change < tolerance {
            break;
        }
    }
    Ok(gain)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lqr_gain_of_scalar_integrator_matches_closed_form() {
        // x+ = x + u, q = r = 1: P solves P = 1 + P - P^2 / (1 + P), i.e. P^2 - P - 1 = 0,
        // P = (1 + sqrt 5) / 2, K = -P / (1 + P).
        let k = lqr_gain(
            &Matrix::<1, 1>::identity(),
            &Matrix::<1, 1>::identity(),
            &Matrix::<1, 1>::identity(),
            &Matrix::<1, 1>::identity(),
            1000,
            1e-15,
        )
        .unwrap();
        let p = (1.0 + 5f64.sqrt()) / 2.0;
        assert!((k[(0, 0)] + p / (1.0 + p)).abs() < 1e-12);
    }

    #[test]
    fn margin_is_zero_at_median() {
        let t = Tightening::<ddp_core::dims::U2, ddp_core::dims::U1>::new(0.5, Matrix::identity()).unwrap();
        assert_eq!(t.quantile(), 0.0);
        assert_eq!(
            margin(
                t.quantile(),
                &ddp_core::Vector::<2>::new(1.0, 2.0),
                &Matrix::identity(),
                0.3
            ),
            0.0
        );
        assert!(Tightening::<ddp_core::dims::U2, ddp_core::dims::U1>::new(1.0, Matrix::identity()).is_err());
        assert!(Tightening::<ddp_core::dims::U2, ddp_core::dims::U1>::new(0.9, -Matrix::identity()).is_err());
    }
}
