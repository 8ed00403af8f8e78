//! Inequality constraints `g(x, u) <= 0` and their Jacobians.
//!
//! A [`Constraint`] has `dim()` scalar rows. It is either
//! - **state-only** ([`Constraint::depends_on_control`] is `false`): imposed on the states
//!   `x_1 .. x_N` (obstacles, state boxes). The solver moves it to the knot whose control can change
//!   it, as Xie et al. (2017) do: at knot `k` it imposes `g(x_{k+r}) <= 0` with
//!   `x_{k+r} = f(...f(x_k, u_k)...)`, where `r` is the relative degree (1 when `u_k` moves
//!   `x_{k+1}`; 2 for the car, whose position sees the controls one step later); or
//! - **mixed** (`true`): imposed on `(x_k, u_k)` at the knots `k = 0 .. N-1` (control boxes,
//!   actuator envelopes).
//!
//! The time argument `t` is the index of the state (state-only rows) or knot (mixed rows) within
//! the current horizon, so time-varying constraints (a tracked moving obstacle) know which
//! prediction to use. Models are immutable and `Send + Sync`; every method writes into caller
//! buffers and allocates nothing.

use ddp_core::dims::{Alloc, Const, DefaultAllocator, Dim, MatrixN, VectorN};
use ddp_core::{Result, Vector};

/// A list of shared constraints, as [`crate::SafeCddpSolver::new`] takes them.
pub type Constraints<NX, NU> = Vec<std::sync::Arc<dyn Constraint<NX, NU>>>;

/// A vector constraint `g(x, u) <= 0` with `dim()` rows. See the [module docs](self).
///
/// ```
/// use safe_cddp::Constraint;
/// use ddp_core::Vector;
/// use ddp_core::dims::{U2, U4};
/// /// Speed limit `x[3] <= v_max` on a 4-state model.
/// struct SpeedLimit { v_max: f64 }
/// impl Constraint<U4, U2> for SpeedLimit {
///     fn dim(&self) -> usize { 1 }
///     fn depends_on_control(&self) -> bool { false }
///     fn evaluate(&self, _t: usize, x: &Vector<4>, _u: &Vector<2>, g: &mut [f64]) {
///         g[0] = x[3] - self.v_max;
///     }
///     fn jacobians(&self, t: usize, x: &Vector<4>, u: &Vector<2>, g: &mut [f64],
///                  g_x: &mut [Vector<4>], g_u: &mut [Vector<2>]) {
///         self.evaluate(t, x, u, g);
///         g_x[0] = Vector::<4>::new(0.0, 0.0, 0.0, 1.0);
///         g_u[0] = Vector::zeros();
///     }
/// }
/// let c = SpeedLimit { v_max: 1.0 };
/// let mut g = [0.0];
/// c.evaluate(0, &Vector::<4>::new(0.0, 0.0, 0.0, 1.5), &Vector::zeros(), &mut g);
/// assert_eq!(g[0], 0.5);
/// ```
pub trait Constraint<NX: Dim, NU: Dim>: Send + Sync
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Number of scalar rows.
    fn dim(&self) -> usize;

    /// `false` for a state-only constraint (imposed on `x_1 .. x_N` through the dynamics), `true`
    /// for a mixed one (imposed on `(x_k, u_k)`, `k < N`).
    fn depends_on_control(&self) -> bool;

    /// Writes `g(x, u)` at time `t` into `g` (`dim()` entries).
    fn evaluate(&self, t: usize, x: &VectorN<NX>, u: &VectorN<NU>, g: &mut [f64]);

    /// Writes `g`, the gradients `g_x` (one `VectorN<NX>` per row) and `g_u` (one `VectorN<NU>` per
    /// row) at time `t`. Every entry is written.
    fn jacobians(
        &self,
        t: usize,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
    );

    /// Writes `g(x_i, u_i)` at the times `t0 + i` of consecutive states `xs` into
    /// `g[i stride .. i stride + dim()]`; `us` has one control per state, or a single one used
    /// at every time (the zero control of a state-only constraint). The solver evaluates every
    /// row along each trial trajectory of the line search with it: one call per constraint
    /// instead of one per knot. The default calls [`Constraint::evaluate`] per state; an
    /// override must give the same values bit for bit.
    fn evaluate_along(&self, t0: usize, xs: &[VectorN<NX>], us: &[VectorN<NU>], g: &mut [f64], stride: usize) {
        let d = self.dim();
        for (i, x) in xs.iter().enumerate() {
            let u = if us.len() == 1 { &us[0] } else { &us[i] };
            self.evaluate(t0 + i, x, u, &mut g[i * stride..i * stride + d]);
        }
    }

    /// [`Constraint::jacobians`] at the times `t0 + i` of consecutive states `xs`, with `us` as
    /// in [`Constraint::evaluate_along`]: the rows of state `i` go to `g`, `g_x`, `g_u` at
    /// `i stride .. i stride + dim()`. The solver linearises every row along the trajectory with
    /// it, one call per constraint. The default calls [`Constraint::jacobians`] per state; an
    /// override must give the same values bit for bit.
    #[allow(clippy::too_many_arguments)]
    fn jacobians_along(
        &self,
        t0: usize,
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
        stride: usize,
    ) {
        let d = self.dim();
        for (i, x) in xs.iter().enumerate() {
            let u = if us.len() == 1 { &us[0] } else { &us[i] };
            let rows = i * stride..i * stride + d;
            self.jacobians(
                t0 + i,
                x,
                u,
                &mut g[rows.clone()],
                &mut g_x[rows.clone()],
                &mut g_u[rows],
            );
        }
    }

    /// Adds `sum_i w_i * d^2 g_i / dx^2` to `h_xx` (the constraint curvature of the Lagrangian).
    /// Optional: the default adds nothing, and the solver then uses a Gauss-Newton model of the
    /// constraints.
    fn add_hessian(&self, _t: usize, _x: &VectorN<NX>, _u: &VectorN<NU>, _w: &[f64], _h_xx: &mut MatrixN<NX, NX>) {}

    /// Variance of each row caused by the constraint's own uncertain parameters at time `t`, e.g. a
    /// tracked obstacle's predicted position: it is added to `g_x^T Sigma_x g_x` under the square
    /// root of the tightening, eq. (20). The default is zero (a known constraint).
    fn parameter_variance(&self, _t: usize, _x: &VectorN<NX>, _u: &VectorN<NU>, var: &mut [f64]) {
        var.fill(0.0);
    }

    /// The relative degree of a state-only constraint, when the model's structure is known (see the
    /// [module docs](self)). `None` (the default) lets the solver find it from the Jacobians of
    /// the dynamics.
    fn relative_degree(&self) -> Option<usize> {
        None
    }

    /// The circular obstacle this constraint is, if it is one: a single state row `g <= 0` that
    /// holds exactly outside a disc on two state entries ([`crate::constraints::Circle`]). The
    /// portfolio's planned start ([`crate::Settings::portfolio_plan`]) plans a path round the
    /// discs of a problem and steers a start to its sides. `None` (the default): not a disc, and
    /// not planned round.
    fn planar_disc(&self) -> Option<crate::plan::PlanarDisc> {
        None
    }

    /// Checks that this constraint fits `nx` states and `nu` controls (state indices in range,
    /// bounds of the right length); the solver calls it once when it is built. The default
    /// accepts every size (a compile-time size was checked by the type system).
    fn check_sizes(&self, _nx: usize, _nu: usize) -> Result<()> {
        Ok(())
    }
}

impl<NX: Dim, NU: Dim, C: Constraint<NX, NU> + ?Sized> Constraint<NX, NU> for std::sync::Arc<C>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn dim(&self) -> usize {
        (**self).dim()
    }
    fn depends_on_control(&self) -> bool {
        (**self).depends_on_control()
    }
    fn evaluate(&self, t: usize, x: &VectorN<NX>, u: &VectorN<NU>, g: &mut [f64]) {
        (**self).evaluate(t, x, u, g)
    }
    fn jacobians(
        &self,
        t: usize,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
    ) {
        (**self).jacobians(t, x, u, g, g_x, g_u)
    }
    fn evaluate_along(&self, t0: usize, xs: &[VectorN<NX>], us: &[VectorN<NU>], g: &mut [f64], stride: usize) {
        (**self).evaluate_along(t0, xs, us, g, stride)
    }
    fn jacobians_along(
        &self,
        t0: usize,
        xs: &[VectorN<NX>],
        us: &[VectorN<NU>],
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
        stride: usize,
    ) {
        (**self).jacobians_along(t0, xs, us, g, g_x, g_u, stride)
    }
    fn add_hessian(&self, t: usize, x: &VectorN<NX>, u: &VectorN<NU>, w: &[f64], h_xx: &mut MatrixN<NX, NX>) {
        (**self).add_hessian(t, x, u, w, h_xx)
    }
    fn parameter_variance(&self, t: usize, x: &VectorN<NX>, u: &VectorN<NU>, var: &mut [f64]) {
        (**self).parameter_variance(t, x, u, var)
    }
    fn relative_degree(&self) -> Option<usize> {
        (**self).relative_degree()
    }
    fn planar_disc(&self) -> Option<crate::plan::PlanarDisc> {
        (**self).planar_disc()
    }
    fn check_sizes(&self, nx: usize, nu: usize) -> Result<()> {
        (**self).check_sizes(nx, nu)
    }
}

/// Largest differences between a constraint's analytic derivatives and central differences of
/// its `evaluate`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstraintDerivativeErrors {
    /// `max |g - g(evaluate)|`: `jacobians` and `evaluate` must agree on the value.
    pub value: f64,
    /// `max |g_x - g_x^fd|`
    pub g_x: f64,
    /// `max |g_u - g_u^fd|`
    pub g_u: f64,
    /// `max |sum_i w_i g_i,xx - fd|` for the weights `w = 1` (0 when `add_hessian` adds nothing
    /// and the constraint is linear; large when `add_hessian` is left out for a curved one, which
    /// is allowed).
    pub hessian: f64,
}

impl ConstraintDerivativeErrors {
    /// The largest of the first-order errors (the Hessian is optional and reported apart).
    pub fn max_first_order(&self) -> f64 {
        self.value.max(self.g_x).max(self.g_u)
    }
}

/// Compares the analytic derivatives of `c` at `(t, x, u)` with central differences of its
/// `evaluate` (step `eps^(1/3) (1 + |z|)`). Allocates a few small vectors: a test helper.
pub fn check_constraint_derivatives<const NX: usize, const NU: usize, C: Constraint<Const<NX>, Const<NU>> + ?Sized>(
    c: &C,
    t: usize,
    x: &Vector<NX>,
    u: &Vector<NU>,
) -> ConstraintDerivativeErrors {
    let m = c.dim();
    let mut g = vec![0.0; m];
    let mut g_eval = vec![0.0; m];
    let mut g_x = vec![Vector::<NX>::zeros(); m];
    let mut g_u = vec![Vector::<NU>::zeros(); m];
    c.jacobians(t, x, u, &mut g, &mut g_x, &mut g_u);
    c.evaluate(t, x, u, &mut g_eval);
    let value = g.iter().zip(&g_eval).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let h = f64::EPSILON.cbrt();
    let (mut gp, mut gm) = (vec![0.0; m], vec![0.0; m]);
    let mut err_x = 0.0f64;
    for j in 0..NX {
        let hj = h * (1.0 + x[j].abs());
        let (mut xp, mut xm) = (*x, *x);
        xp[j] += hj;
        xm[j] -= hj;
        c.evaluate(t, &xp, u, &mut gp);
        c.evaluate(t, &xm, u, &mut gm);
        for i in 0..m {
            err_x = err_x.max(((gp[i] - gm[i]) / (2.0 * hj) - g_x[i][j]).abs());
        }
    }
    let mut err_u = 0.0f64;
    for j in 0..NU {
        let hj = h * (1.0 + u[j].abs());
        let (mut up, mut um) = (*u, *u);
        up[j] += hj;
        um[j] -= hj;
        c.evaluate(t, x, &up, &mut gp);
        c.evaluate(t, x, &um, &mut gm);
        for i in 0..m {
            err_u = err_u.max(((gp[i] - gm[i]) / (2.0 * hj) - g_u[i][j]).abs());
        }
    }
    // Hessian of sum_i g_i by differences of the analytic gradient.
    let ones = vec![1.0; m];
    let mut h_xx = ddp_core::Matrix::<NX, NX>::zeros();
    c.add_hessian(t, x, u, &ones, &mut h_xx);
    let (mut gxp, mut gxm) = (vec![Vector::<NX>::zeros(); m], vec![Vector::<NX>::zeros(); m]);
    let mut scratch_u = vec![Vector::<NU>::zeros(); m];
    let mut err_h = 0.0f64;
    for j in 0..NX {
        let hj = h * (1.0 + x[j].abs());
        let (mut xp, mut xm) = (*x, *x);
        xp[j] += hj;
        xm[j] -= hj;
        c.jacobians(t, &xp, u, &mut gp, &mut gxp, &mut scratch_u);
        c.jacobians(t, &xm, u, &mut gm, &mut gxm, &mut scratch_u);
        for r in 0..NX {
            let fd: f64 = (0..m).map(|i| (gxp[i][r] - gxm[i][r]) / (2.0 * hj)).sum();
            err_h = err_h.max((fd - h_xx[(r, j)]).abs());
        }
    }
    ConstraintDerivativeErrors {
        value,
        g_x: err_x,
        g_u: err_u,
        hessian: err_h,
    }
}
