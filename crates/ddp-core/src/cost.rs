//! Running and terminal costs: `J = sum_{k<N} l(x_k, u_k) + l_N(x_N)`.
//!
//! Derivatives are *accumulated* with a weight: `add_derivatives(x, u, w, d)` adds `w * l_x` to
//! `d.lx` and so on, and returns `w * l`. Sums of terms ([`crate::costs::CostSum`]) therefore need
//! no scratch memory, and a weighted sum is just a weight passed down.

use crate::dims::{Alloc, DefaultAllocator, Dim, Dims, MatrixN, VectorN};

/// First and second derivatives of a running cost at one knot.
#[derive(Debug, Clone, PartialEq)]
pub struct CostDerivatives<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// `l_x`
    pub lx: VectorN<NX>,
    /// `l_u`
    pub lu: VectorN<NU>,
    /// `l_xx`
    pub lxx: MatrixN<NX, NX>,
    /// `l_uu`
    pub luu: MatrixN<NU, NU>,
    /// `l_ux` (shape `NU x NX`)
    pub lux: MatrixN<NU, NX>,
}

impl<NX: Dim, NU: Dim> CostDerivatives<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Zero derivatives for `dims` (allocates for run-time sizes).
    pub fn zeros(dims: Dims<NX, NU>) -> Self {
        Self {
            lx: dims.x_zeros(),
            lu: dims.u_zeros(),
            lxx: dims.xx_zeros(),
            luu: dims.uu_zeros(),
            lux: dims.ux_zeros(),
        }
    }
    /// Sets every derivative to zero (in place).
    pub fn clear(&mut self) {
        // Over the storage: nalgebra's element-wise fill walks strides.
        self.lx.as_mut_slice().fill(0.0);
        self.lu.as_mut_slice().fill(0.0);
        self.lxx.as_mut_slice().fill(0.0);
        self.luu.as_mut_slice().fill(0.0);
        self.lux.as_mut_slice().fill(0.0);
    }
}

impl<const NX: usize, const NU: usize> Default for CostDerivatives<nalgebra::Const<NX>, nalgebra::Const<NU>> {
    fn default() -> Self {
        Self::zeros(Dims {
            nx: nalgebra::Const,
            nu: nalgebra::Const,
        })
    }
}

/// First and second derivatives of a terminal cost.
#[derive(Debug, Clone, PartialEq)]
pub struct TerminalDerivatives<NX: Dim>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// `l_x`
    pub lx: VectorN<NX>,
    /// `l_xx`
    pub lxx: MatrixN<NX, NX>,
}

impl<NX: Dim> TerminalDerivatives<NX>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// Zero derivatives for `nx` states (allocates for run-time sizes).
    pub fn zeros(nx: NX) -> Self {
        Self {
            lx: VectorN::zeros_generic(nx, nalgebra::U1),
            lxx: MatrixN::zeros_generic(nx, nx),
        }
    }
    /// Sets every derivative to zero (in place).
    pub fn clear(&mut self) {
        self.lx.as_mut_slice().fill(0.0);
        self.lxx.as_mut_slice().fill(0.0);
    }
}

impl<const NX: usize> Default for TerminalDerivatives<nalgebra::Const<NX>> {
    fn default() -> Self {
        Self::zeros(nalgebra::Const)
    }
}

/// A running cost `l(x, u)`.
pub trait Cost<NX: Dim, NU: Dim>: Send + Sync
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// `l(x, u)`.
    fn value(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> f64;
    /// Adds `w` times the gradient and Hessian of `l` at `(x, u)` to `d` and returns `w * l(x, u)`.
    fn add_derivatives(&self, x: &VectorN<NX>, u: &VectorN<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64;
    /// Writes the gradient and Hessian of `l` at `(x, u)` into every entry of `d` and returns
    /// `l(x, u)`: by default [`Cost::add_derivatives`] with weight 1 into zeroed derivatives,
    /// the same bits. The linearisation calls it at every knot; a cost that writes its entries
    /// without reading `d` back ([`crate::costs::QuadraticCost`]) spares the processor reading
    /// values it has just zeroed, which it cannot forward from the zeroing's wide stores.
    fn set_derivatives(&self, x: &VectorN<NX>, u: &VectorN<NU>, d: &mut CostDerivatives<NX, NU>) -> f64 {
        d.clear();
        self.add_derivatives(x, u, 1.0, d)
    }
    /// The state and control sizes this cost was built for; `None` where it takes any size.
    /// Compile-time sizes answer for themselves; a run-time-size cost built from weight
    /// matrices reports their sizes, so that a problem can reject pieces that disagree.
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (NX::try_to_usize(), NU::try_to_usize())
    }
}

/// A terminal cost `l_N(x)`. Every terminal cost is also a running cost that ignores `u`
/// (see [`crate::costs::StateOnly`]).
pub trait TerminalCost<NX: Dim>: Send + Sync
where
    DefaultAllocator: Alloc<NX, NX>,
{
    /// `l_N(x)`.
    fn value(&self, x: &VectorN<NX>) -> f64;
    /// Adds `w` times the gradient and Hessian of `l_N` at `x` to `d` and returns `w * l_N(x)`.
    fn add_derivatives(&self, x: &VectorN<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64;
    /// The state size this cost was built for; `None` where it takes any size.
    fn state_size(&self) -> Option<usize> {
        NX::try_to_usize()
    }
}

impl<NX: Dim, NU: Dim, C: Cost<NX, NU> + ?Sized> Cost<NX, NU> for std::sync::Arc<C>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn value(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> f64 {
        (**self).value(x, u)
    }
    fn add_derivatives(&self, x: &VectorN<NX>, u: &VectorN<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        (**self).add_derivatives(x, u, w, d)
    }
    fn set_derivatives(&self, x: &VectorN<NX>, u: &VectorN<NU>, d: &mut CostDerivatives<NX, NU>) -> f64 {
        (**self).set_derivatives(x, u, d)
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (**self).sizes()
    }
}

impl<NX: Dim, C: TerminalCost<NX> + ?Sized> TerminalCost<NX> for std::sync::Arc<C>
where
    DefaultAllocator: Alloc<NX, NX>,
{
    fn value(&self, x: &VectorN<NX>) -> f64 {
        (**self).value(x)
    }
    fn add_derivatives(&self, x: &VectorN<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
        (**self).add_derivatives(x, w, d)
    }
    fn state_size(&self) -> Option<usize> {
        (**self).state_size()
    }
}
