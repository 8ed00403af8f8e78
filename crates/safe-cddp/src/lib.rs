//! # safe-cddp
//!
//! Constrained differential dynamic programming after Xie, Liu and Hauser (2017), with the
//! chance-constraint tightening of Safe-CDDP (Alcan and Kyrki, RA-L 2022). It solves
//!
//! ```text
//! min_{u_0..u_{N-1}}  l_N(x_N) + sum_{k<N} l(x_k, u_k)
//! s.t.  x_{k+1} = f(x_k, u_k),  u_min <= u_k <= u_max,  g~(x_k, u_k, Sigma_k) <= 0           (21)
//! g~ = g + phi^{-1}(beta) sqrt(g_x^T Sigma_k g_x),   Sigma_{k+1} = A_k Sigma_k A_k^T + Sigma_w
//! ```
//!
//! where `A_k = f_x + f_u K_k` uses the gains of the constrained backward pass, so the margins
//! reflect the closed-loop spread of the state (eqs. 19-20), and runs it as a shrinking-horizon
//! MPC with seeded noise (Algorithm 1).
//!
//! | paper symbol | here | equation |
//! |---|---|---|
//! | `g(x, u) <= 0` | [`Constraint`], [`constraints`] | (3) |
//! | `C = g~_u`, `D = g~_x` | rows of the backward pass ([`solver`]) | (8) |
//! | `lambda`, `K`, `d` | [`SafeCddpSolver::multipliers`], [`SafeCddpSolver::gains`], [`SafeCddpSolver::feedforward`] | (10)-(12) |
//! | QP of the forward pass | [`qp::StepQp`] (Clarabel, set up once) | (15) |
//! | `Sigma_x` | [`SafeCddpSolver::covariances`], [`tightening::propagate_covariance`] | (19) |
//! | `phi^{-1}(beta)` | [`quantile::normal_quantile`] | (20) |
//! | margins | [`SafeCddpSolver::margins`], [`tightening::margin`] | (20) |
//! | `K` of eq. (19) | [`Gains`], [`SafeCddpSolver::propagation_gains`] | (19) |
//! | `n1`, `n2` | [`mpc::MpcSettings::iterations`], [`Tightening::update_every`] | Alg. 1 |
//! | Table I | [`table`], its tasks [`sweep`], the binary `safe-cddp-table` (feature `cli`) | §IV |
//! | obstacle tracker `F`, `G` | [`kalman::ObstacleTracker`] | Queen Elizabeth's School (2022) |
//!
//! ```
//! use std::sync::Arc;
//! use ddp_core::{reference, Vector};
//! use safe_cddp::constraints::Circle;
//! use safe_cddp::{Constraint, SafeCddpSolver, Settings, Status};
//!
//! // P3's double integrator to (3, 3) around one obstacle (squared-distance form).
//! let problem = reference::point_reach();
//! let obstacle: Arc<dyn Constraint<ddp_core::dims::U4, ddp_core::dims::U2>> = Arc::new(Circle::squared([1.5, 1.5], 0.5, [0, 1])?);
//! let mut solver = SafeCddpSolver::new(&problem, vec![obstacle], Settings::default())?;
//! let report = solver.solve(&problem)?;
//! assert_eq!(report.status, Status::Converged);
//! assert!(report.max_violation <= 1e-6);
//! # Ok::<(), ddp_core::Error>(())
//! ```

pub mod batch;
pub mod benchmark;
pub mod constraint;
pub mod constraints;
#[cfg(feature = "figure")]
pub mod figure;
pub mod kalman;
pub mod mpc;
pub mod plan;
pub mod qp;
pub mod quantile;
pub mod settings;
pub mod solver;
pub mod sweep;
pub mod table;
pub mod tightening;

pub use constraint::{check_constraint_derivatives, Constraint, ConstraintDerivativeErrors, Constraints};
pub use ddp_core::{Error, Result};
pub use settings::{IterationLog, Report, Settings, StartOutcome, StartReport, Status, WarmUp};
pub use solver::{IterationOutcome, SafeCddpSolver};
pub use tightening::{Gains, Tightening};
