//! # idnp
//!
//! Iterative dynamic and nonlinear programming (IDNP) with adaptive grid refinement, after
//! Richter et al. (2023) ("Collision avoidance using iterative dynamic and nonlinear programming
//! with adaptive grid refinements"), on a planar floating base with a 2-link arm
//! ([`ddp_core::models::ArmBase`], 10 states, 5 controls).
//!
//! The feasibility problem: find controls `u_0 .. u_{N-1}` with
//!
//! ```text
//! x_{k+1} = f(x_k, u_k),  |u_k| <= u_max,  sd_{b,o}(x_k) >= 0  (bodies b, obstacles o),
//! |tcp(x_N) - g| <= r_g,  velocities(x_N) = 0
//! ```
//!
//! The low-dimensional representation is the tool-centre point (TCP) `z = tcp(x) in R^2`. Each
//! iteration (Algorithm 1, Fig. 1):
//! 1. **DP** ([`dp`], eqs. (2)-(4)) on time-indexed quadtree grids of the TCP domain
//!    ([`quadtree`]) gives waypoints `z_0 .. z_T`;
//! 2. **inverse mapping** ([`inverse`], eq. (5)) turns them into configurations close to the
//!    previous one and away from the obstacles; failures name the waypoint;
//! 3. the **NLP** ([`nlp`], HDP) follows them with the full model under collision constraints
//!    ([`constraints`]: capsule- and rectangle-vs-polygon rows for `safe-cddp`), then the result is
//!    collision-checked;
//! 4. **refinement** ([`idnp`], eq. (6)) splits the cells holding infeasible waypoints or colliding
//!    TCP positions, at their time index and its successor; the baseline (original IDNP) raises
//!    the penalties of a fixed grid there instead.
//!
//! [`experiment`] runs the paper's experiment (fixed grid, adaptive grid, NLP alone over many
//! seeded initial conditions); `cargo run --release -p idnp --bin idnp-experiment` prints the
//! table and draws a figure like Fig. 3 (module `plot`, feature `cli`).
//!
//! | Richter et al. (2023) | here |
//! |---|---|
//! | penalty (2) | [`dp::DpSettings::penalty`] |
//! | DP recursion (4), interpolation `nu_i`, `w_i` | [`dp::Dp::solve`], [`quadtree::QuadGrid::weights`] |
//! | inverse mapping (5) | [`inverse::inverse_map`] |
//! | HDP | [`nlp::solve`] |
//! | cell set (6), splitting `S` | [`idnp::refine`], [`quadtree::QuadGrid::split`] |
//! | penalty adaptation of the original IDNP (ref. 20 of the paper) | [`idnp::adapt_penalties`] |
//! | Algorithm 1 | [`idnp::Idnp::run`] |
//! | Section V experiment | [`experiment::run_experiment`] |
//!
//! ```
#![doc = include_str!("../examples/quickstart.rs")]
//! ```

pub mod constraints;
pub mod dp;
pub mod error;
pub mod experiment;
pub mod idnp;
pub mod inverse;
pub mod nlp;
#[cfg(feature = "cli")]
pub mod plot;
pub mod quadtree;
pub mod scene;
pub mod sweep;

pub use error::{Error, Result};
