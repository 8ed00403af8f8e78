//! Batch solves of Safe-CDDP: many constrained problems of one structure on several threads in
//! one call, each result bit-identical to solving that problem alone with a fresh
//! [`SafeCddpSolver`] (cold start), for any thread count.
//!
//! Unlike ddp-core's batch ([`ddp_core::batch::solve_batch`]), each problem gets a workspace of
//! its own, built on the worker thread: a Safe-CDDP workspace depends on the problem beyond its
//! sizes (the relative degree of each state constraint is found from the problem's dynamics
//! around its `x0`, and the QP is set up for its constraint rows). Building it is small next to
//! a constrained solve (a few percent on the point robot).
//!
//! ```
//! use std::sync::Arc;
//! use ddp_core::{reference, Vector};
//! use safe_cddp::batch::{solve_batch, SafeBatchItem};
//! use safe_cddp::constraints::Circle;
//! use safe_cddp::{Constraint, SafeCddpSolver, Settings};
//!
//! let obstacle: Arc<dyn Constraint<ddp_core::dims::U4, ddp_core::dims::U2>> =
//!     Arc::new(Circle::squared([1.5, 1.5], 0.5, [0, 1])?);
//! let items: Vec<_> = (0..4)
//!     .map(|i| {
//!         let mut problem = reference::point_reach();
//!         problem.set_x0(Vector::<4>::new(0.1 * i as f64, 0.0, 0.0, 0.0)).unwrap();
//!         SafeBatchItem { problem, constraints: vec![obstacle.clone()], tightening: None }
//!     })
//!     .collect();
//! let solutions = solve_batch(&items, &Settings::default(), Some(2))?;
//! let mut alone = SafeCddpSolver::new(&items[1].problem, vec![obstacle], Settings::default())?;
//! alone.solve(&items[1].problem)?;
//! assert_eq!(solutions[1].us, alone.us());
//! # Ok::<(), ddp_core::Error>(())
//! ```

use std::sync::Arc;

use ddp_core::batch::{at_problem, check_same_structure, map_workers, resolve_threads};
use ddp_core::dims::{Alloc, DefaultAllocator, Dim, MatrixN, VectorN};
use ddp_core::{Problem, Result};

use crate::{Constraint, Report, SafeCddpSolver, Settings, Tightening};

/// One problem of a Safe-CDDP batch: the problem, its constraints and its tightening (`None`:
/// deterministic constraints).
#[derive(Clone)]
pub struct SafeBatchItem<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// The problem.
    pub problem: Problem<NX, NU>,
    /// Its constraints (may be shared with other items through the `Arc`s).
    pub constraints: Vec<Arc<dyn Constraint<NX, NU>>>,
    /// Its chance-constraint tightening.
    pub tightening: Option<Tightening<NX, NU>>,
}

/// One problem's result: what [`SafeCddpSolver`]'s accessors give after solving it alone.
#[derive(Debug, Clone)]
pub struct SafeBatchSolution<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// States `x_0 .. x_N`.
    pub xs: Vec<VectorN<NX>>,
    /// Controls `u_0 .. u_{N-1}`.
    pub us: Vec<VectorN<NU>>,
    /// Feedback gains `K_k`, eq. (12).
    pub gains: Vec<MatrixN<NU, NX>>,
    /// Feed-forward terms `d_k`, eq. (12).
    pub feedforward: Vec<VectorN<NU>>,
    /// Covariances `Sigma_k` of the last tightening, eq. (19).
    pub covariances: Vec<MatrixN<NX, NX>>,
    /// The report (`solve_time` is this problem's own).
    pub report: Report,
}

impl<NX: Dim, NU: Dim> SafeBatchSolution<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Copies the solution out of a solver.
    pub fn from_solver(s: &SafeCddpSolver<NX, NU>) -> Self {
        Self {
            xs: s.xs().to_vec(),
            us: s.us().to_vec(),
            gains: s.gains().to_vec(),
            feedforward: s.feedforward().to_vec(),
            covariances: s.covariances().to_vec(),
            report: s.report().clone(),
        }
    }
}

/// Builds a solver for `item` and solves it from a cold start: the one-at-a-time solve that
/// [`solve_batch`] runs per problem.
pub fn solve_one<NX: Dim, NU: Dim>(
    item: &SafeBatchItem<NX, NU>,
    settings: Settings,
) -> Result<SafeBatchSolution<NX, NU>>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    let mut s = SafeCddpSolver::new(&item.problem, item.constraints.clone(), settings)?;
    s.set_tightening(item.tightening.clone())?;
    s.solve(&item.problem)?;
    Ok(SafeBatchSolution::from_solver(&s))
}

/// Solves every item with `settings` on `threads` worker threads (`None`:
/// [`ddp_core::batch::default_threads`]); the solutions come back in the order of `items`,
/// each bit-identical to [`solve_one`] on that item.
///
/// Errors, before any solve: an empty list (`problems`), sizes or horizons that differ from the
/// first item's (`problems[i]`), invalid settings, `threads = Some(0)` (`threads`). Errors of an
/// item (constraints of the wrong size, a tightening that does not fit) name `problems[i]`; a
/// panic in a user model or constraint is an error naming `problems[i]`, never a panic out of
/// this function. The other items are still solved; the error of the lowest index is returned.
pub fn solve_batch<NX: Dim, NU: Dim>(
    items: &[SafeBatchItem<NX, NU>],
    settings: &Settings,
    threads: Option<usize>,
) -> Result<Vec<SafeBatchSolution<NX, NU>>>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    let problems: Vec<Problem<NX, NU>> = items.iter().map(|i| i.problem.clone()).collect();
    check_same_structure(&problems)?;
    let threads = resolve_threads(threads)?;
    settings.validate()?;
    let settings = *settings;
    map_workers(
        items,
        threads,
        || Ok(()),
        |_, i, item| solve_one(item, settings).map_err(|e| at_problem(i, e)),
    )
    .into_iter()
    .collect()
}
