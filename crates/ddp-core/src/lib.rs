//! # ddp-core
//!
//! Differential dynamic programming for discrete-time optimal control:
//!
//! ```text
//! min_{u_0..u_{N-1}}  sum_{k<N} l_k(x_k, u_k) + l_N(x_N)   s.t.  x_{k+1} = f_k(x_k, u_k),  u_min <= u_k <= u_max
//! ```
//!
//! iLQR and full DDP (second-order dynamics terms), box-DDP for control limits (projected-Newton
//! box QP), Tassa's regularisation schedule and a backtracking line search on the expected
//! improvement. Models ([`Dynamics`], [`Cost`], [`TerminalCost`]) are immutable and `Send + Sync`;
//! everything a solve writes lives in a [`Solver`] workspace allocated once, so repeated solves
//! allocate nothing.
//!
//! Every type is generic over the state and control dimensions `NX, NU` ([`dims`]): nalgebra's
//! `Const<N>` for the built-in robots (stack matrices, unrolled loops) or `Dyn` for sizes known
//! only at run time; one text of each algorithm serves both.
#![doc = "```"]
#![doc = include_str!("../examples/quickstart.rs")]
#![doc = "```"]

pub mod autodiff;
pub mod batch;
pub mod boxqp;
pub mod cost;
pub mod costs;
pub mod dims;
pub mod dynamics;
pub mod error;
pub mod finite_diff;
pub mod kernels;
pub mod linear;
pub mod models;
pub mod penalty;
pub mod problem;
pub mod reference;
pub mod runtime;
pub mod solver;

pub use cost::{Cost, CostDerivatives, TerminalCost, TerminalDerivatives};
pub use dims::{Dims, MatrixN, VectorN};
pub use dynamics::Dynamics;
pub use error::{Error, Result};
pub use problem::{ControlBounds, Knot, Problem};
pub use solver::{
    IterationLog, LineSearchSettings, Method, Regularization, RegularizationSettings, Report, Settings, Shooting,
    Solver, Status, Tolerances, DEFECT_TOLERANCE,
};

/// Column vector of `N` `f64`s.
pub type Vector<const N: usize> = nalgebra::SVector<f64, N>;
/// `R x C` matrix of `f64`s.
pub type Matrix<const R: usize, const C: usize> = nalgebra::SMatrix<f64, R, C>;
