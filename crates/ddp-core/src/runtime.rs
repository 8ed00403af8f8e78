//! Compile-time-size models, costs and constraints used at run-time size.
//!
//! [`RunTimeSize`] wraps a model or cost written for [`Const`] sizes (every built-in robot) so
//! that it serves a [`Dyn`] problem: the state and control are copied onto the stack, the model
//! runs at its fixed size, and the results are copied back. Problems that mix built-in and
//! run-time-size pieces, and the benchmarks of the run-time-size path against the fixed-size
//! one, use it.
//!
//! ```
//! use std::sync::Arc;
//! use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
//! use ddp_core::dims::{Dyn, VectorN};
//! use ddp_core::models::Unicycle;
//! use ddp_core::runtime::RunTimeSize;
//! use ddp_core::{Problem, Settings, Solver};
//!
//! let model = RunTimeSize::new(Unicycle::new(0.1)?);
//! let q = nalgebra::DMatrix::<f64>::identity(3, 3) * 100.0;
//! let r = nalgebra::DMatrix::<f64>::identity(2, 2);
//! let zeros = |n| nalgebra::DVector::<f64>::zeros(n);
//! let running = QuadraticCost::<Dyn, Dyn>::new(q.clone(), r, zeros(3), zeros(2))?;
//! let terminal = QuadraticTerminal::<Dyn>::new(q, zeros(3))?;
//! let x0 = VectorN::<Dyn>::from_vec(vec![-1.0, -1.0, 1.0]);
//! let problem = Problem::new(x0, Arc::new(model), Arc::new(running), Arc::new(terminal), 50)?;
//! let mut solver = Solver::new(&problem, Settings::default())?;
//! assert_eq!(solver.solve(&problem)?.status, ddp_core::Status::Converged);
//! # Ok::<(), ddp_core::Error>(())
//! ```

use nalgebra::{Const, Dyn};

use crate::dims::VectorN;
use crate::{Cost, CostDerivatives, Dynamics, Matrix, MatrixN, TerminalCost, TerminalDerivatives, Vector};

/// A compile-time-size model or running cost with `NX` states and `NU` controls, used at
/// run-time size (see the [module docs](self)).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunTimeSize<M, const NX: usize, const NU: usize>(pub M);

impl<M, const NX: usize, const NU: usize> RunTimeSize<M, NX, NU> {
    /// Wraps `m` (the sizes are inferred from the trait it implements).
    pub fn new(m: M) -> Self {
        Self(m)
    }
}

/// A compile-time-size terminal cost with `NX` states used at run-time size.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunTimeTerminal<C, const NX: usize>(pub C);

#[inline]
fn fixed<const N: usize>(v: &VectorN<Dyn>) -> Vector<N> {
    Vector::<N>::from_column_slice(&v.as_slice()[..N])
}

#[inline]
fn copy_back<const R: usize, const C: usize>(dst: &mut MatrixN<Dyn, Dyn>, src: &Matrix<R, C>) {
    dst.as_mut_slice().copy_from_slice(src.as_slice());
}

impl<const NX: usize, const NU: usize, M: Dynamics<Const<NX>, Const<NU>>> Dynamics<Dyn, Dyn>
    for RunTimeSize<M, NX, NU>
{
    fn step(&self, x: &VectorN<Dyn>, u: &VectorN<Dyn>) -> VectorN<Dyn> {
        VectorN::<Dyn>::from_column_slice(self.0.step(&fixed::<NX>(x), &fixed::<NU>(u)).as_slice())
    }
    fn step_into(&self, x: &VectorN<Dyn>, u: &VectorN<Dyn>, out: &mut VectorN<Dyn>) {
        out.as_mut_slice()
            .copy_from_slice(self.0.step(&fixed::<NX>(x), &fixed::<NU>(u)).as_slice());
    }
    fn step_keep(&self, x: &VectorN<Dyn>, u: &VectorN<Dyn>, out: &mut VectorN<Dyn>, data: &mut Vec<f64>) {
        let mut y = Vector::<NX>::zeros();
        self.0.step_keep(&fixed::<NX>(x), &fixed::<NU>(u), &mut y, data);
        out.as_mut_slice().copy_from_slice(y.as_slice());
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (Some(NX), Some(NU))
    }
    fn jacobians(&self, x: &VectorN<Dyn>, u: &VectorN<Dyn>, fx: &mut MatrixN<Dyn, Dyn>, fu: &mut MatrixN<Dyn, Dyn>) {
        let (mut a, mut b) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
        self.0.jacobians(&fixed::<NX>(x), &fixed::<NU>(u), &mut a, &mut b);
        copy_back(fx, &a);
        copy_back(fu, &b);
    }
    fn jacobians_kept(
        &self,
        x: &VectorN<Dyn>,
        u: &VectorN<Dyn>,
        fx: &mut MatrixN<Dyn, Dyn>,
        fu: &mut MatrixN<Dyn, Dyn>,
        data: &[f64],
    ) {
        let (mut a, mut b) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
        self.0
            .jacobians_kept(&fixed::<NX>(x), &fixed::<NU>(u), &mut a, &mut b, data);
        copy_back(fx, &a);
        copy_back(fu, &b);
    }
    fn has_second_order(&self) -> bool {
        self.0.has_second_order()
    }
    fn add_second_order(
        &self,
        x: &VectorN<Dyn>,
        u: &VectorN<Dyn>,
        lambda: &VectorN<Dyn>,
        h_xx: &mut MatrixN<Dyn, Dyn>,
        h_ux: &mut MatrixN<Dyn, Dyn>,
        h_uu: &mut MatrixN<Dyn, Dyn>,
    ) {
        let mut a = Matrix::<NX, NX>::from_column_slice(h_xx.as_slice());
        let mut b = Matrix::<NU, NX>::from_column_slice(h_ux.as_slice());
        let mut c = Matrix::<NU, NU>::from_column_slice(h_uu.as_slice());
        self.0.add_second_order(
            &fixed::<NX>(x),
            &fixed::<NU>(u),
            &fixed::<NX>(lambda),
            &mut a,
            &mut b,
            &mut c,
        );
        copy_back(h_xx, &a);
        copy_back(h_ux, &b);
        copy_back(h_uu, &c);
    }
    fn jacobians_keep(
        &self,
        x: &VectorN<Dyn>,
        u: &VectorN<Dyn>,
        fx: &mut MatrixN<Dyn, Dyn>,
        fu: &mut MatrixN<Dyn, Dyn>,
        data: &mut Vec<f64>,
    ) {
        let (mut a, mut b) = (Matrix::<NX, NX>::zeros(), Matrix::<NX, NU>::zeros());
        self.0
            .jacobians_keep(&fixed::<NX>(x), &fixed::<NU>(u), &mut a, &mut b, data);
        copy_back(fx, &a);
        copy_back(fu, &b);
    }
    fn add_second_order_kept(
        &self,
        x: &VectorN<Dyn>,
        u: &VectorN<Dyn>,
        lambda: &VectorN<Dyn>,
        data: &[f64],
        h_xx: &mut MatrixN<Dyn, Dyn>,
        h_ux: &mut MatrixN<Dyn, Dyn>,
        h_uu: &mut MatrixN<Dyn, Dyn>,
    ) {
        let mut a = Matrix::<NX, NX>::from_column_slice(h_xx.as_slice());
        let mut b = Matrix::<NU, NX>::from_column_slice(h_ux.as_slice());
        let mut c = Matrix::<NU, NU>::from_column_slice(h_uu.as_slice());
        self.0.add_second_order_kept(
            &fixed::<NX>(x),
            &fixed::<NU>(u),
            &fixed::<NX>(lambda),
            data,
            &mut a,
            &mut b,
            &mut c,
        );
        copy_back(h_xx, &a);
        copy_back(h_ux, &b);
        copy_back(h_uu, &c);
    }
}

impl<const NX: usize, const NU: usize, C: Cost<Const<NX>, Const<NU>>> Cost<Dyn, Dyn> for RunTimeSize<C, NX, NU> {
    fn value(&self, x: &VectorN<Dyn>, u: &VectorN<Dyn>) -> f64 {
        self.0.value(&fixed::<NX>(x), &fixed::<NU>(u))
    }
    fn add_derivatives(&self, x: &VectorN<Dyn>, u: &VectorN<Dyn>, w: f64, d: &mut CostDerivatives<Dyn, Dyn>) -> f64 {
        let mut f = CostDerivatives::<Const<NX>, Const<NU>> {
            lx: fixed::<NX>(&d.lx),
            lu: fixed::<NU>(&d.lu),
            lxx: Matrix::<NX, NX>::from_column_slice(d.lxx.as_slice()),
            luu: Matrix::<NU, NU>::from_column_slice(d.luu.as_slice()),
            lux: Matrix::<NU, NX>::from_column_slice(d.lux.as_slice()),
        };
        let v = self.0.add_derivatives(&fixed::<NX>(x), &fixed::<NU>(u), w, &mut f);
        d.lx.as_mut_slice().copy_from_slice(f.lx.as_slice());
        d.lu.as_mut_slice().copy_from_slice(f.lu.as_slice());
        copy_back(&mut d.lxx, &f.lxx);
        copy_back(&mut d.luu, &f.luu);
        copy_back(&mut d.lux, &f.lux);
        v
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (Some(NX), Some(NU))
    }
}

impl<const NX: usize, C: TerminalCost<Const<NX>>> TerminalCost<Dyn> for RunTimeTerminal<C, NX> {
    fn value(&self, x: &VectorN<Dyn>) -> f64 {
        self.0.value(&fixed::<NX>(x))
    }
    fn add_derivatives(&self, x: &VectorN<Dyn>, w: f64, d: &mut TerminalDerivatives<Dyn>) -> f64 {
        let mut f = TerminalDerivatives::<Const<NX>> {
            lx: fixed::<NX>(&d.lx),
            lxx: Matrix::<NX, NX>::from_column_slice(d.lxx.as_slice()),
        };
        let v = self.0.add_derivatives(&fixed::<NX>(x), w, &mut f);
        d.lx.as_mut_slice().copy_from_slice(f.lx.as_slice());
        copy_back(&mut d.lxx, &f.lxx);
        v
    }
    fn state_size(&self) -> Option<usize> {
        Some(NX)
    }
}
