//! Discrete-time dynamics `x_{k+1} = f(x_k, u_k)` and their derivatives.
//!
//! A model is immutable and `Send + Sync`; the solver owns every buffer a solve writes. First
//! derivatives are required (`f_x`, `f_u`); second derivatives are optional and only used by full
//! DDP, in contracted form: the solver needs `sum_i lambda_i * d^2 f_i / d(x,u)^2` with
//! `lambda = V_x'` (the next knot's value gradient), never the full third-order tensor. A model
//! whose second derivatives share work with its Jacobians (a traced tape's forward sweep) can keep
//! that work per knot ([`Dynamics::jacobians_keep`], [`Dynamics::add_second_order_kept`]); one
//! whose Jacobians share work with its step (the sine and cosine of a heading) can keep that per
//! knot of the rollout ([`Dynamics::step_keep`], [`Dynamics::jacobians_kept`]).

use crate::dims::{Alloc, DefaultAllocator, Dim, MatrixN, VectorN};

/// Discrete dynamics with `NX` states and `NU` controls.
///
/// ```
/// use ddp_core::{Dynamics, Matrix, Vector};
/// use ddp_core::dims::U1;
/// /// x+ = x + dt * u, a single integrator.
/// struct Integrator { dt: f64 }
/// impl Dynamics<U1, U1> for Integrator {
///     fn step(&self, x: &Vector<1>, u: &Vector<1>) -> Vector<1> { x + self.dt * u }
///     fn jacobians(&self, _x: &Vector<1>, _u: &Vector<1>, fx: &mut Matrix<1, 1>, fu: &mut Matrix<1, 1>) {
///         fx[(0, 0)] = 1.0;
///         fu[(0, 0)] = self.dt;
///     }
/// }
/// let m = Integrator { dt: 0.1 };
/// assert_eq!(m.step(&Vector::<1>::new(1.0), &Vector::<1>::new(2.0))[0], 1.2);
/// ```
pub trait Dynamics<NX: Dim, NU: Dim>: Send + Sync
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// The next state `f(x, u)`.
    fn step(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> VectorN<NX>;

    /// Writes `f(x, u)` into `out`. The solvers call this one; a run-time-size model overrides
    /// it to avoid allocating the result.
    fn step_into(&self, x: &VectorN<NX>, u: &VectorN<NU>, out: &mut VectorN<NX>) {
        *out = self.step(x, u);
    }

    /// [`Dynamics::step_into`] where the solver will ask for [`Dynamics::jacobians_kept`] at the
    /// same point if the step is accepted: a model may keep in `data` what it computed and the
    /// Jacobians reuse (the sine and cosine of a heading). `data` is the knot's, owned by the
    /// solver's trajectory and passed back unchanged; it starts empty and a model grows it once.
    /// The default keeps nothing.
    fn step_keep(&self, x: &VectorN<NX>, u: &VectorN<NU>, out: &mut VectorN<NX>, _data: &mut Vec<f64>) {
        self.step_into(x, u, out);
    }

    /// [`Dynamics::jacobians`] with the `data` [`Dynamics::step_keep`] left for this knot. The
    /// trajectory may have moved since (a warm start, a shift, another rollout), so `data` may
    /// be empty or belong to another point: a model must check (the default ignores it).
    fn jacobians_kept(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        fx: &mut MatrixN<NX, NX>,
        fu: &mut MatrixN<NX, NU>,
        _data: &[f64],
    ) {
        self.jacobians(x, u, fx, fu);
    }

    /// The state and control sizes this model was built for; `None` where it takes any size.
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (NX::try_to_usize(), NU::try_to_usize())
    }

    /// Writes the Jacobians `f_x = df/dx` and `f_u = df/du` at `(x, u)` (every entry).
    fn jacobians(&self, x: &VectorN<NX>, u: &VectorN<NU>, fx: &mut MatrixN<NX, NX>, fu: &mut MatrixN<NX, NU>);

    /// Whether [`Dynamics::add_second_order`] is implemented. Full DDP falls back to iLQR terms
    /// (no second-order dynamics) for a model that returns `false`.
    fn has_second_order(&self) -> bool {
        false
    }

    /// Adds the contracted second derivatives `sum_i lambda_i * d^2 f_i` to the blocks:
    /// `h_xx += sum_i lambda_i f_i,xx`, `h_ux += sum_i lambda_i f_i,ux`, `h_uu += sum_i lambda_i f_i,uu`.
    fn add_second_order(
        &self,
        _x: &VectorN<NX>,
        _u: &VectorN<NU>,
        _lambda: &VectorN<NX>,
        _h_xx: &mut MatrixN<NX, NX>,
        _h_ux: &mut MatrixN<NU, NX>,
        _h_uu: &mut MatrixN<NU, NU>,
    ) {
    }

    /// [`Dynamics::jacobians`] where full DDP will ask for [`Dynamics::add_second_order_kept`]
    /// at the same point: a model may keep in `data` what it computed and the second-order
    /// terms reuse (its forward sweep), as a Crocoddyl action model keeps its data. `data` is
    /// the knot's, owned by the solver's workspace and passed back unchanged; it starts empty
    /// and a model grows it once. The default keeps nothing.
    fn jacobians_keep(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        fx: &mut MatrixN<NX, NX>,
        fu: &mut MatrixN<NX, NU>,
        _data: &mut Vec<f64>,
    ) {
        self.jacobians(x, u, fx, fu);
    }

    /// [`Dynamics::add_second_order`] with the `data` [`Dynamics::jacobians_keep`] left for this
    /// knot. Full DDP calls it once per backward pass (several per linearisation when the
    /// regularisation is raised), so reusing the kept sweep pays. `data` may be empty or belong
    /// to another point (a model must check); the default ignores it.
    fn add_second_order_kept(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        lambda: &VectorN<NX>,
        _data: &[f64],
        h_xx: &mut MatrixN<NX, NX>,
        h_ux: &mut MatrixN<NU, NX>,
        h_uu: &mut MatrixN<NU, NU>,
    ) {
        self.add_second_order(x, u, lambda, h_xx, h_ux, h_uu);
    }
}

impl<NX: Dim, NU: Dim, D: Dynamics<NX, NU> + ?Sized> Dynamics<NX, NU> for std::sync::Arc<D>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn step(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> VectorN<NX> {
        (**self).step(x, u)
    }
    fn step_into(&self, x: &VectorN<NX>, u: &VectorN<NU>, out: &mut VectorN<NX>) {
        (**self).step_into(x, u, out)
    }
    fn step_keep(&self, x: &VectorN<NX>, u: &VectorN<NU>, out: &mut VectorN<NX>, data: &mut Vec<f64>) {
        (**self).step_keep(x, u, out, data)
    }
    fn jacobians_kept(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        fx: &mut MatrixN<NX, NX>,
        fu: &mut MatrixN<NX, NU>,
        data: &[f64],
    ) {
        (**self).jacobians_kept(x, u, fx, fu, data)
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (**self).sizes()
    }
    fn jacobians(&self, x: &VectorN<NX>, u: &VectorN<NU>, fx: &mut MatrixN<NX, NX>, fu: &mut MatrixN<NX, NU>) {
        (**self).jacobians(x, u, fx, fu)
    }
    fn has_second_order(&self) -> bool {
        (**self).has_second_order()
    }
    fn add_second_order(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        lambda: &VectorN<NX>,
        h_xx: &mut MatrixN<NX, NX>,
        h_ux: &mut MatrixN<NU, NX>,
        h_uu: &mut MatrixN<NU, NU>,
    ) {
        (**self).add_second_order(x, u, lambda, h_xx, h_ux, h_uu)
    }
    fn jacobians_keep(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        fx: &mut MatrixN<NX, NX>,
        fu: &mut MatrixN<NX, NU>,
        data: &mut Vec<f64>,
    ) {
        (**self).jacobians_keep(x, u, fx, fu, data)
    }
    fn add_second_order_kept(
        &self,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        lambda: &VectorN<NX>,
        data: &[f64],
        h_xx: &mut MatrixN<NX, NX>,
        h_ux: &mut MatrixN<NU, NX>,
        h_uu: &mut MatrixN<NU, NU>,
    ) {
        (**self).add_second_order_kept(x, u, lambda, data, h_xx, h_ux, h_uu)
    }
}
