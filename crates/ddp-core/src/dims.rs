//! State and control sizes, fixed at compile time or known only at run time.
//!
//! Every model, cost, problem and solver is generic over nalgebra dimensions `NX, NU: Dim`:
//! [`Const<N>`](nalgebra::Const) (aliases `U3`, `U12`, ...) for the built-in robots, whose
//! matrices live on the stack and whose loops unroll, or [`Dyn`] for sizes known only at run
//! time (a Python user's `nx`, `nu`). One text of each algorithm serves both: the hot loops run
//! over `Dim::value()`, a constant after inlining when the dimension is `Const`.
//!
//! ```
//! use ddp_core::dims::{MatrixN, VectorN, Dyn, U3};
//! let fixed = VectorN::<U3>::zeros();                       // on the stack
//! let dynamic = VectorN::<Dyn>::zeros_generic(Dyn(7), nalgebra::U1); // on the heap, size 7
//! assert_eq!(fixed.len() + dynamic.len(), 10);
//! let _m = MatrixN::<Dyn, Dyn>::zeros_generic(Dyn(7), Dyn(3));
//! ```

pub use nalgebra::allocator::Allocator;
pub use nalgebra::{Const, DefaultAllocator, Dim, Dyn, U1, U10, U12, U2, U3, U4, U5};

use crate::error::{Error, Result};

/// A column vector of `D` `f64`s (`D` fixed or [`Dyn`]).
pub type VectorN<D> = nalgebra::OVector<f64, D>;
/// An `R x C` matrix of `f64`s.
pub type MatrixN<R, C> = nalgebra::OMatrix<f64, R, C>;

/// Everything the solvers allocate for `NX` states and `NU` controls, as one bound:
/// `where DefaultAllocator: Alloc<NX, NU>` (its supertraits are implied wherever it holds).
///
/// The buffers are `Send + Sync` (stack arrays or `Vec`s), so models and workspaces built on
/// them can be shared across threads.
pub trait Alloc<NX: Dim, NU: Dim>:
    Allocator<NX, Buffer<f64>: Send + Sync>
    + Allocator<NU, Buffer<f64>: Send + Sync>
    + Allocator<NX, NX, Buffer<f64>: Send + Sync>
    + Allocator<NU, NU, Buffer<f64>: Send + Sync>
    + Allocator<NU, NX, Buffer<f64>: Send + Sync>
    + Allocator<NX, NU, Buffer<f64>: Send + Sync>
{
}

impl<NX: Dim, NU: Dim, A> Alloc<NX, NU> for A where
    A: Allocator<NX, Buffer<f64>: Send + Sync>
        + Allocator<NU, Buffer<f64>: Send + Sync>
        + Allocator<NX, NX, Buffer<f64>: Send + Sync>
        + Allocator<NU, NU, Buffer<f64>: Send + Sync>
        + Allocator<NU, NX, Buffer<f64>: Send + Sync>
        + Allocator<NX, NU, Buffer<f64>: Send + Sync>
{
}

/// Largest run-time state size accepted (the solvers' workspaces grow as `N nx^2`; past this a
/// dense DDP is the wrong tool).
pub const MAX_STATES: usize = 1024;
/// Largest run-time control size accepted.
pub const MAX_CONTROLS: usize = 512;

/// The sizes of a problem: `nx` states and `nu` controls as dimension values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dims<NX: Dim, NU: Dim> {
    /// The state dimension.
    pub nx: NX,
    /// The control dimension.
    pub nu: NU,
}

impl<NX: Dim, NU: Dim> Dims<NX, NU> {
    /// Checks run-time sizes (at least 1, at most [`MAX_STATES`] / [`MAX_CONTROLS`], equal to
    /// the compile-time size where there is one), naming `field`.
    pub fn new(field: &str, nx: usize, nu: usize) -> Result<Self> {
        check_size(&format!("{field}.nx"), nx, NX::try_to_usize(), MAX_STATES)?;
        check_size(&format!("{field}.nu"), nu, NU::try_to_usize(), MAX_CONTROLS)?;
        Ok(Self {
            nx: NX::from_usize(nx),
            nu: NU::from_usize(nu),
        })
    }
    /// `nx` as a number.
    #[inline(always)]
    pub fn nx(&self) -> usize {
        self.nx.value()
    }
    /// `nu` as a number.
    #[inline(always)]
    pub fn nu(&self) -> usize {
        self.nu.value()
    }
    /// A zero state.
    pub fn x_zeros(&self) -> VectorN<NX>
    where
        DefaultAllocator: Allocator<NX>,
    {
        VectorN::zeros_generic(self.nx, U1)
    }
    /// A zero control.
    pub fn u_zeros(&self) -> VectorN<NU>
    where
        DefaultAllocator: Allocator<NU>,
    {
        VectorN::zeros_generic(self.nu, U1)
    }
    /// Zero `nx x nx`.
    pub fn xx_zeros(&self) -> MatrixN<NX, NX>
    where
        DefaultAllocator: Allocator<NX, NX>,
    {
        MatrixN::zeros_generic(self.nx, self.nx)
    }
    /// Zero `nu x nu`.
    pub fn uu_zeros(&self) -> MatrixN<NU, NU>
    where
        DefaultAllocator: Allocator<NU, NU>,
    {
        MatrixN::zeros_generic(self.nu, self.nu)
    }
    /// Zero `nu x nx`.
    pub fn ux_zeros(&self) -> MatrixN<NU, NX>
    where
        DefaultAllocator: Allocator<NU, NX>,
    {
        MatrixN::zeros_generic(self.nu, self.nx)
    }
    /// Zero `nx x nu`.
    pub fn xu_zeros(&self) -> MatrixN<NX, NU>
    where
        DefaultAllocator: Allocator<NX, NU>,
    {
        MatrixN::zeros_generic(self.nx, self.nu)
    }
}

/// Checks one size: `1 <= n <= limit`, and `n == fixed` for a compile-time dimension.
pub fn check_size(field: &str, n: usize, fixed: Option<usize>, limit: usize) -> Result<()> {
    if n == 0 {
        return Err(Error::invalid(field, "must be at least 1"));
    }
    if let Some(f) = fixed {
        if n != f {
            return Err(Error::Shape {
                field: field.to_string(),
                got: n.to_string(),
                expected: format!("{f} (the compiled size)"),
            });
        }
    } else if n > limit {
        return Err(Error::invalid(
            field,
            format!("{n} exceeds the limit of {limit} for run-time sizes"),
        ));
    }
    Ok(())
}

/// The size of a piece (model, cost, constraint) as it reports it: `None` where it works at
/// any size (a run-time dimension it does not fix).
pub fn declared<D: Dim>() -> Option<usize> {
    D::try_to_usize()
}
