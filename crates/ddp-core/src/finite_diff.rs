//! Finite differences: a wrapper that gives any `step` function Jacobians (and contracted second
//! derivatives), and a checker that compares a model's analytic derivatives with them.

use crate::{Dynamics, Matrix, Vector};
use nalgebra::Const;

/// A discrete map `x_{k+1} = f(x_k, u_k)` without derivatives.
pub trait DiscreteMap<const NX: usize, const NU: usize>: Send + Sync {
    /// The next state.
    fn step(&self, x: &Vector<NX>, u: &Vector<NU>) -> Vector<NX>;
}

/// Gives a [`DiscreteMap`] (or any [`Dynamics`], through [`FiniteDiff::of_dynamics`]) Jacobians
/// by central differences with step `h` (default `eps^(1/3)`, scaled by `1 + |z_i|`), and
/// contracted second derivatives by central differences of the Jacobians.
#[derive(Debug, Clone, Copy)]
pub struct FiniteDiff<M> {
    /// The wrapped map.
    pub map: M,
    /// Relative step.
    pub h: f64,
}

impl<M> FiniteDiff<M> {
    /// Wraps `map` with the default step `eps^(1/3)`.
    pub fn new(map: M) -> Self {
        Self {
            map,
            h: f64::EPSILON.cbrt(),
        }
    }
}

/// Adapter: uses only the `step` of a [`Dynamics`].
#[derive(Debug, Clone, Copy)]
pub struct StepOf<D>(pub D);

impl<const NX: usize, const NU: usize, D: Dynamics<Const<NX>, Const<NU>>> DiscreteMap<NX, NU> for StepOf<D> {
    fn step(&self, x: &Vector<NX>, u: &Vector<NU>) -> Vector<NX> {
        self.0.step(x, u)
    }
}

impl<D> FiniteDiff<StepOf<D>> {
    /// Finite-difference derivatives of a model's `step`, ignoring its analytic derivatives.
    pub fn of_dynamics(model: D) -> Self {
        Self::new(StepOf(model))
    }
}

/// Central-difference Jacobians of `f` at `(x, u)`.
fn fd_jacobians<const NX: usize, const NU: usize>(
    f: &impl Fn(&Vector<NX>, &Vector<NU>) -> Vector<NX>,
    h: f64,
    x: &Vector<NX>,
    u: &Vector<NU>,
    fx: &mut Matrix<NX, NX>,
    fu: &mut Matrix<NX, NU>,
) {
    for j in 0..NX {
        let hj = h * (1.0 + x[j].abs());
        let (mut xp, mut xm) = (*x, *x);
        xp[j] += hj;
        xm[j] -= hj;
        fx.set_column(j, &((f(&xp, u) - f(&xm, u)) / (2.0 * hj)));
    }
    for j in 0..NU {
        let hj = h * (1.0 + u[j].abs());
        let (mut up, mut um) = (*u, *u);
        up[j] += hj;
        um[j] -= hj;
        fu.set_column(j, &((f(x, &up) - f(x, &um)) / (2.0 * hj)));
    }
}

impl<const NX: usize, const NU: usize, M: DiscreteMap<NX, NU>> Dynamics<Const<NX>, Const<NU>> for FiniteDiff<M> {
    fn step(&self, x: &Vector<NX>, u: &Vector<NU>) -> Vector<NX> {
        self.map.step(x, u)
    }
    fn jacobians(&self, x: &Vector<NX>, u: &Vector<NU>, fx: &mut Matrix<NX, NX>, fu: &mut Matrix<NX, NU>) {
        fd_jacobians(&|x, u| self.map.step(x, u), self.h, x, u, fx, fu);
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
        // Differences of the gradient g(x, u) = [f_x^T lambda; f_u^T lambda], itself by differences:
        // a step of eps^(1/4) balances truncation and round-off for this nested scheme.
        let h = f64::EPSILON.powf(0.25);
        let grad = |x: &Vector<NX>, u: &Vector<NU>| {
            let (mut fx, mut fu) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
            fd_jacobians(&|x, u| self.map.step(x, u), h, x, u, &mut fx, &mut fu);
            (fx.transpose() * lambda, fu.transpose() * lambda)
        };
        for j in 0..NX {
            let hj = h * (1.0 + x[j].abs());
            let (mut xp, mut xm) = (*x, *x);
            xp[j] += hj;
            xm[j] -= hj;
            let (gxp, gup) = grad(&xp, u);
            let (gxm, gum) = grad(&xm, u);
            h_xx.set_column(j, &(h_xx.column(j) + (gxp - gxm) / (2.0 * hj)));
            h_ux.set_column(j, &(h_ux.column(j) + (gup - gum) / (2.0 * hj)));
        }
        for j in 0..NU {
            let hj = h * (1.0 + u[j].abs());
            let (mut up, mut um) = (*u, *u);
            up[j] += hj;
            um[j] -= hj;
            let (_, gup) = grad(x, &up);
            let (_, gum) = grad(x, &um);
            h_uu.set_column(j, &(h_uu.column(j) + (gup - gum) / (2.0 * hj)));
        }
    }
}

/// Largest absolute differences between a model's analytic derivatives and finite differences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DerivativeErrors {
    /// `max |f_x - f_x^fd|`
    pub fx: f64,
    /// `max |f_u - f_u^fd|`
    pub fu: f64,
    /// Largest error of the contracted second derivatives (0 when the model has none).
    pub second_order: f64,
}

impl DerivativeErrors {
    /// The largest of the three errors.
    pub fn max(&self) -> f64 {
        self.fx.max(self.fu).max(self.second_order)
    }
}

/// Compares the analytic derivatives of `model` at `(x, u)` with central differences of its
/// `step`; `lambda` contracts the second derivatives. Use a tolerance of about `eps^(1/3)` times
/// the scale of the model.
pub fn check_derivatives<const NX: usize, const NU: usize, D: Dynamics<Const<NX>, Const<NU>>>(
    model: &D,
    x: &Vector<NX>,
    u: &Vector<NU>,
    lambda: &Vector<NX>,
) -> DerivativeErrors {
    let fd = FiniteDiff::of_dynamics(model);
    let (mut fx, mut fu) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
    let (mut gx, mut gu) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
    model.jacobians(x, u, &mut fx, &mut fu);
    fd.jacobians(x, u, &mut gx, &mut gu);
    let mut second_order = 0.0;
    if model.has_second_order() {
        let (mut a_xx, mut a_ux, mut a_uu) = (
            Matrix::<NX, NX>::zeros(),
            Matrix::<NU, NX>::zeros(),
            Matrix::<NU, NU>::zeros(),
        );
        let (mut b_xx, mut b_ux, mut b_uu) = (
            Matrix::<NX, NX>::zeros(),
            Matrix::<NU, NX>::zeros(),
            Matrix::<NU, NU>::zeros(),
        );
        model.add_second_order(x, u, lambda, &mut a_xx, &mut a_ux, &mut a_uu);
        fd.add_second_order(x, u, lambda, &mut b_xx, &mut b_ux, &mut b_uu);
        second_order = (a_xx - b_xx).amax().max((a_ux - b_ux).amax()).max((a_uu - b_uu).amax());
    }
    DerivativeErrors {
        fx: (fx - gx).amax(),
        fu: (fu - gu).amax(),
        second_order,
    }
}

impl<const NX: usize, const NU: usize, D: Dynamics<Const<NX>, Const<NU>>> Dynamics<Const<NX>, Const<NU>> for &D {
    fn step(&self, x: &Vector<NX>, u: &Vector<NU>) -> Vector<NX> {
        (**self).step(x, u)
    }
    fn step_into(&self, x: &Vector<NX>, u: &Vector<NU>, out: &mut Vector<NX>) {
        (**self).step_into(x, u, out)
    }
    fn step_keep(&self, x: &Vector<NX>, u: &Vector<NU>, out: &mut Vector<NX>, data: &mut Vec<f64>) {
        (**self).step_keep(x, u, out, data)
    }
    fn jacobians(&self, x: &Vector<NX>, u: &Vector<NU>, fx: &mut Matrix<NX, NX>, fu: &mut Matrix<NX, NU>) {
        (**self).jacobians(x, u, fx, fu)
    }
    fn jacobians_kept(
        &self,
        x: &Vector<NX>,
        u: &Vector<NU>,
        fx: &mut Matrix<NX, NX>,
        fu: &mut Matrix<NX, NU>,
        data: &[f64],
    ) {
        (**self).jacobians_kept(x, u, fx, fu, data)
    }
    fn has_second_order(&self) -> bool {
        (**self).has_second_order()
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
        (**self).add_second_order(x, u, lambda, h_xx, h_ux, h_uu)
    }
    fn jacobians_keep(
        &self,
        x: &Vector<NX>,
        u: &Vector<NU>,
        fx: &mut Matrix<NX, NX>,
        fu: &mut Matrix<NX, NU>,
        data: &mut Vec<f64>,
    ) {
        (**self).jacobians_keep(x, u, fx, fu, data)
    }
    fn add_second_order_kept(
        &self,
        x: &Vector<NX>,
        u: &Vector<NU>,
        lambda: &Vector<NX>,
        data: &[f64],
        h_xx: &mut Matrix<NX, NX>,
        h_ux: &mut Matrix<NU, NX>,
        h_uu: &mut Matrix<NU, NU>,
    ) {
        (**self).add_second_order_kept(x, u, lambda, data, h_xx, h_ux, h_uu)
    }
}
