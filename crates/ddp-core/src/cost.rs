//! Running and terminal costs: `J = sum_{k<N} l(x_k, u_k) + l_N(x_N)`.
//!
//! Derivatives are *accumulated* with a weight: `add_derivatives(x, u, w, d)` adds `w * l_x` to
//! `d.lx` and so on, and returns `w * l`. Sums of terms ([`crate::costs::CostSum`]) therefore need
//! no scratch memory, and a weighted sum is just a weight passed down.

use crate::{Matrix, Vector};

/// First and second derivatives of a running cost at one knot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CostDerivatives<const NX: usize, const NU: usize> {
    /// `l_x`
    pub lx: Vector<NX>,
    /// `l_u`
    pub lu: Vector<NU>,
    /// `l_xx`
    pub lxx: Matrix<NX, NX>,
    /// `l_uu`
    pub luu: Matrix<NU, NU>,
    /// `l_ux` (shape `NU x NX`)
    pub lux: Matrix<NU, NX>,
}

impl<const NX: usize, const NU: usize> Default for CostDerivatives<NX, NU> {
    fn default() -> Self {
        Self {
            lx: Vector::zeros(),
            lu: Vector::zeros(),
            lxx: Matrix::zeros(),
            luu: Matrix::zeros(),
            lux: Matrix::zeros(),
        }
    }
}

impl<const NX: usize, const NU: usize> CostDerivatives<NX, NU> {
    /// Sets every derivative to zero.
    pub fn clear(&mut self) {
        *self = Self::default();
    }
}

/// First and second derivatives of a terminal cost.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TerminalDerivatives<const NX: usize> {
    /// `l_x`
    pub lx: Vector<NX>,
    /// `l_xx`
    pub lxx: Matrix<NX, NX>,
}

impl<const NX: usize> Default for TerminalDerivatives<NX> {
    fn default() -> Self {
        Self {
            lx: Vector::zeros(),
            lxx: Matrix::zeros(),
        }
    }
}

impl<const NX: usize> TerminalDerivatives<NX> {
    /// Sets every derivative to zero.
    pub fn clear(&mut self) {
        *self = Self::default();
    }
}

/// A running cost `l(x, u)`.
pub trait Cost<const NX: usize, const NU: usize>: Send + Sync {
    /// `l(x, u)`.
    fn value(&self, x: &Vector<NX>, u: &Vector<NU>) -> f64;
    /// Adds `w` times the gradient and Hessian of `l` at `(x, u)` to `d` and returns `w * l(x, u)`.
    fn add_derivatives(&self, x: &Vector<NX>, u: &Vector<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64;
}

/// A terminal cost `l_N(x)`. Every terminal cost is also a running cost that ignores `u`
/// (see [`crate::costs::StateOnly`]).
pub trait TerminalCost<const NX: usize>: Send + Sync {
    /// `l_N(x)`.
    fn value(&self, x: &Vector<NX>) -> f64;
    /// Adds `w` times the gradient and Hessian of `l_N` at `x` to `d` and returns `w * l_N(x)`.
    fn add_derivatives(&self, x: &Vector<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64;
}

impl<const NX: usize, const NU: usize, C: Cost<NX, NU> + ?Sized> Cost<NX, NU> for std::sync::Arc<C> {
    fn value(&self, x: &Vector<NX>, u: &Vector<NU>) -> f64 {
        (**self).value(x, u)
    }
    fn add_derivatives(&self, x: &Vector<NX>, u: &Vector<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        (**self).add_derivatives(x, u, w, d)
    }
}

impl<const NX: usize, C: TerminalCost<NX> + ?Sized> TerminalCost<NX> for std::sync::Arc<C> {
    fn value(&self, x: &Vector<NX>) -> f64 {
        (**self).value(x)
    }
    fn add_derivatives(&self, x: &Vector<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
        (**self).add_derivatives(x, w, d)
    }
}
