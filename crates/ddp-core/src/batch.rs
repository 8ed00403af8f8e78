//! Batch solves: many problems of one structure (the same sizes and horizon; different `x0`,
//! targets, parameters or models) solved on several threads in one call, as acados'
//! `AcadosOcpBatchSolver` and Drake's `SolveInParallel` do.
//!
//! Every result equals what a fresh [`Solver`] gives for that problem alone, bit for bit, for
//! any thread count: each worker thread owns one workspace, allocated once and reused across its
//! problems; before each problem it is reset to a cold start, which makes everything a solve
//! reads equal to a freshly allocated workspace. Which worker solves which problem (decided at
//! run time, by whoever is free next) therefore changes nothing.
//!
//! ```
//! use std::sync::Arc;
//! use ddp_core::batch::solve_batch;
//! use ddp_core::costs::{QuadraticCost, QuadraticTerminal};
//! use ddp_core::models::Unicycle;
//! use ddp_core::{Problem, Settings, Solver, Vector};
//!
//! let problems: Vec<_> = (0..8)
//!     .map(|i| {
//!         let x0 = Vector::<3>::new(-1.0 - 0.1 * i as f64, -1.0, 1.0);
//!         Problem::new(
//!             x0,
//!             Arc::new(Unicycle::new(0.1).unwrap()),
//!             Arc::new(QuadraticCost::weighted_norms(10.0, 1.0).unwrap()),
//!             Arc::new(QuadraticTerminal::diagonal(&[100.0; 3], Vector::zeros()).unwrap()),
//!             50,
//!         )
//!         .unwrap()
//!     })
//!     .collect();
//! let solutions = solve_batch(&problems, &Settings::default(), Some(2))?;
//! // The same as solving problem 3 alone, bit for bit.
//! let mut alone = Solver::new(&problems[3], Settings::default())?;
//! alone.solve(&problems[3])?;
//! assert_eq!(solutions[3].xs, alone.xs());
//! # Ok::<(), ddp_core::Error>(())
//! ```
//!
//! The workers are plain `std` threads (no thread pool, no feature): a batch is long next to
//! starting a thread. [`map_workers`] is the executor underneath, for other solvers and for
//! bindings that copy results out in their own form (the Python wheel, Safe-CDDP's batch).

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicUsize, Ordering};

use crate::dims::{Alloc, DefaultAllocator, Dim, MatrixN, VectorN};
use crate::error::{Error, Result};
use crate::solver::MAX_THREADS;
use crate::{Problem, Report, Settings, Solver};

/// The default worker count: `RAYON_NUM_THREADS` when it is set to a positive number (so a
/// cluster task that limits its threads limits batch solves too), else the cores available to
/// this process.
pub fn default_threads() -> usize {
    std::env::var("RAYON_NUM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|&n| n >= 1)
        .or_else(|| std::thread::available_parallelism().ok().map(|n| n.get()))
        .unwrap_or(1)
        .min(MAX_THREADS)
}

/// `threads` (`None`: [`default_threads`]); `Some(0)` or more than `MAX_THREADS` is an error
/// naming `threads`.
pub fn resolve_threads(threads: Option<usize>) -> Result<usize> {
    match threads {
        None => Ok(default_threads()),
        Some(t) if (1..=MAX_THREADS).contains(&t) => Ok(t),
        Some(t) => Err(Error::invalid(
            "threads",
            format!("must be in 1..={MAX_THREADS} (or None for every core), got {t}"),
        )),
    }
}

/// The text of a panic payload.
fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic without a message".to_string()
    }
}

/// Runs `work(&mut state, i, &items[i])` for every item on `threads` worker threads and returns
/// the results in the order of `items`.
///
/// Each worker creates its state (a workspace) with `init` once, when it takes its first item,
/// and reuses it for every item it takes after; items are handed out one at a time to whichever
/// worker is free (dynamic balancing: solves differ in length). With one thread, or one item,
/// everything runs on the calling thread.
///
/// A panic inside `init` or `work` does not cross this function: it becomes the error of that
/// item (`Error::Invalid` naming `problems[i]`), the worker drops its state and creates a fresh
/// one for its next item, and the other items go on.
pub fn map_workers<T, S, R>(
    items: &[T],
    threads: usize,
    init: impl Fn() -> Result<S> + Sync,
    work: impl Fn(&mut S, usize, &T) -> Result<R> + Sync,
) -> Vec<Result<R>>
where
    T: Sync,
    R: Send,
{
    let next = AtomicUsize::new(0);
    let worker = || {
        let mut done = Vec::new();
        let mut state: Option<S> = None;
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= items.len() {
                break;
            }
            let outcome = catch_unwind(AssertUnwindSafe(|| {
                if state.is_none() {
                    state = Some(init()?);
                }
                match state.as_mut() {
                    Some(s) => work(s, i, &items[i]),
                    None => Err(Error::invalid("internal", "no workspace (a ddpkit bug)")),
                }
            }));
            let result = outcome.unwrap_or_else(|payload| {
                // The workspace may be half-written: start the next item from a fresh one.
                state = None;
                Err(Error::invalid(
                    format!("problems[{i}]"),
                    format!("the solve panicked: {}", panic_text(payload.as_ref())),
                ))
            });
            done.push((i, result));
        }
        done
    };
    let threads = threads.clamp(1, items.len().max(1));
    let mut results: Vec<Option<Result<R>>> = (0..items.len()).map(|_| None).collect();
    if threads == 1 {
        for (i, r) in worker() {
            results[i] = Some(r);
        }
    } else {
        std::thread::scope(|scope| {
            let handles: Vec<_> = (0..threads).map(|_| scope.spawn(worker)).collect();
            for handle in handles {
                // The worker catches every panic of `init` and `work`; a join error would be a
                // panic in the loop itself, and its items keep their `None` (reported below).
                if let Ok(done) = handle.join() {
                    for (i, r) in done {
                        results[i] = Some(r);
                    }
                }
            }
        });
    }
    results
        .into_iter()
        .enumerate()
        .map(|(i, r)| r.unwrap_or_else(|| Err(Error::invalid(format!("problems[{i}]"), "its worker thread failed"))))
        .collect()
}

/// `e` with its field put under `problems[i]` (`problems[3].us`), so a batch error names the
/// problem it came from.
pub fn at_problem(i: usize, e: Error) -> Error {
    let prefix = |field: String| format!("problems[{i}].{field}");
    match e {
        Error::NotFinite { field, index, value } => Error::NotFinite {
            field: prefix(field),
            index,
            value,
        },
        Error::Shape { field, got, expected } => Error::Shape {
            field: prefix(field),
            got,
            expected,
        },
        Error::Invalid { field, reason } => Error::Invalid {
            field: prefix(field),
            reason,
        },
        Error::NotPsd { field, reason } => Error::NotPsd {
            field: prefix(field),
            reason,
        },
        Error::EmptyHorizon => Error::invalid(format!("problems[{i}].horizon"), Error::EmptyHorizon.to_string()),
    }
}

/// One problem's result in a batch: what [`Solver`]'s accessors give after solving it alone.
#[derive(Debug, Clone)]
pub struct BatchSolution<NX: Dim, NU: Dim>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// States `x_0 .. x_N`.
    pub xs: Vec<VectorN<NX>>,
    /// Controls `u_0 .. u_{N-1}`.
    pub us: Vec<VectorN<NU>>,
    /// Feedback gains `K_k`.
    pub gains: Vec<MatrixN<NU, NX>>,
    /// Feed-forward terms `k_k`.
    pub feedforward: Vec<VectorN<NU>>,
    /// The report (status, cost, iteration log; `solve_time` is this problem's own).
    pub report: Report,
}

impl<NX: Dim, NU: Dim> BatchSolution<NX, NU>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    /// Copies the solution out of a solver's workspace.
    pub fn from_solver(solver: &Solver<NX, NU>) -> Self {
        Self {
            xs: solver.xs().to_vec(),
            us: solver.us().to_vec(),
            gains: solver.gains().to_vec(),
            feedforward: solver.feedforward().to_vec(),
            report: solver.report().clone(),
        }
    }
}

/// Checks that `problems` is not empty and that every problem has the sizes and horizon of the
/// first; errors name `problems` or `problems[i]`.
pub fn check_same_structure<NX: Dim, NU: Dim>(problems: &[Problem<NX, NU>]) -> Result<()>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    let first = problems
        .first()
        .ok_or_else(|| Error::invalid("problems", "must hold at least one problem, got an empty list"))?;
    let shape = |p: &Problem<NX, NU>| (p.dims().nx(), p.dims().nu(), p.horizon());
    let want = shape(first);
    for (i, p) in problems.iter().enumerate().skip(1) {
        let got = shape(p);
        if got != want {
            return Err(Error::Shape {
                field: format!("problems[{i}]"),
                got: format!("(nx, nu, horizon) = {got:?}"),
                expected: format!("{want:?} (that of problems[0]: a batch shares one structure)"),
            });
        }
    }
    Ok(())
}

/// Solves every problem from a cold start (zero controls) with `settings` on `threads` worker
/// threads (`None`: [`default_threads`]), one workspace per worker; the solutions come back in
/// the order of `problems`, each bit-identical to a fresh [`Solver`]'s for that problem alone.
///
/// `settings.derivative_threads` is ignored (taken as 1): the workers already occupy the cores,
/// and the results do not depend on it.
///
/// Errors, before any solve: an empty list (`problems`), sizes or horizons that differ from the
/// first problem's (`problems[i]`), invalid settings (`settings.<field>`), `threads = Some(0)`
/// (`threads`). A solve that panics (a user model's bug) is an error naming `problems[i]`;
/// the other problems are still solved, and the error of the lowest such index is returned.
pub fn solve_batch<NX: Dim, NU: Dim>(
    problems: &[Problem<NX, NU>],
    settings: &Settings,
    threads: Option<usize>,
) -> Result<Vec<BatchSolution<NX, NU>>>
where
    DefaultAllocator: Alloc<NX, NU>,
{
    check_same_structure(problems)?;
    let threads = resolve_threads(threads)?;
    let settings = Settings {
        derivative_threads: 1,
        ..*settings
    };
    settings.validate()?;
    let results = map_workers(
        problems,
        threads,
        || Solver::new(&problems[0], settings),
        |solver, i, problem| {
            solver.reset();
            solver.solve(problem).map_err(|e| at_problem(i, e))?;
            Ok(BatchSolution::from_solver(solver))
        },
    );
    results.into_iter().collect()
}
