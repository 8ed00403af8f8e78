//! # ddp-tape
//!
//! Expression tapes with exact first and second derivatives, so that a robot model written once
//! (traced from a Python function, or imported from a CasADi SX function) runs in the solvers at
//! Rust speed, with no Python and no code generation.
//!
//! A [`Tape`] lists nodes (inputs, constants, operations of earlier nodes) in evaluation order.
//! [`TapeBuilder`] shares common subexpressions and folds constants. [`eval`] computes values,
//! Jacobians (forward tangents) and weighted Hessians `sum_i lambda_i d^2F_i/dz^2` (second-order
//! adjoints): everything iLQR, full DDP, cost Hessians and constraint curvature need.
//! [`models`] wraps tapes as ddp-core [`ddp_core::Dynamics`], [`ddp_core::Cost`],
//! [`ddp_core::TerminalCost`] and Safe-CDDP [`safe_cddp::Constraint`]s at every dimension type;
//! [`file`] saves and loads them as small JSON documents.
//!
//! ```
//! use ddp_tape::{Binary, TapeBuilder, TapeDynamics, Unary, Integrator, discretize};
//! use ddp_core::{Dynamics, Matrix, Vector};
//! use ddp_core::dims::{U1, U2};
//! // A pendulum: x = (angle, rate), u = torque; xdot = (rate, u - 9.81 sin(angle)).
//! let mut b = TapeBuilder::new(3);
//! let (q, w, u) = (b.input(0)?, b.input(1)?, b.input(2)?);
//! let s = b.unary(Unary::Sin, q)?;
//! let g = b.constant(9.81)?;
//! let gs = b.binary(Binary::Mul, g, s)?;
//! let acc = b.binary(Binary::Sub, u, gs)?;
//! let ode = b.finish(&[w, acc])?;
//! let model = TapeDynamics::new(discretize(&ode, 2, 1, 0.05, Integrator::Euler)?, 2, 1)?;
//! let (mut fx, mut fu) = (Matrix::<2, 2>::zeros(), Matrix::<2, 1>::zeros());
//! Dynamics::<U2, U1>::jacobians(&model, &Vector::<2>::zeros(), &Vector::<1>::zeros(), &mut fx, &mut fu);
//! assert!((fx[(1, 0)] + 9.81 * 0.05).abs() < 1e-15);
//! # Ok::<(), ddp_core::Error>(())
//! ```

pub mod eval;
pub mod file;
pub mod models;
pub mod op;
pub mod program;
pub mod tape;

pub use eval::Workspace;
pub use file::TapeModel;
pub use models::{TapeConstraint, TapeCost, TapeDynamics, TapeTerminal};
pub use op::{Binary, Unary};
pub use program::{Needs, Program, ProgramWorkspace};
pub use tape::{discretize, Integrator, Node, Tape, TapeBuilder};
