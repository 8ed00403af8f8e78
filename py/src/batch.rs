//! What `solve_batch` and `solve_batch_safe` share: the list of problems checked against the
//! first, the thread count, read access to every problem at once, and ddp-core's worker
//! executor ([`ddp_core::batch::map_workers`]) with the exceptions of Python callable models
//! carried back from the worker that raised them.

use std::sync::{Arc, RwLock, RwLockReadGuard};

use ddp_core::batch::{at_problem, map_workers, resolve_threads};
use pyo3::prelude::*;

use crate::dims::AnyProblem;
use crate::errors::{invalid, shape, CoreError, CoreResult};
use crate::models::type_name;
use crate::problem::Problem;

/// The problems of a batch, checked: a non-empty sequence of `Problem`s of one `(nx, nu, N)`.
pub(crate) struct Problems {
    /// Their shared Rust problems (read under their locks during the solves).
    pub locks: Vec<Arc<RwLock<AnyProblem>>>,
    pub nx: usize,
    pub nu: usize,
    pub horizon: usize,
}

/// Checks `problems`: an iterable (not a string) of `ddpkit.Problem`, at least one, all with the
/// sizes and horizon of the first; errors name `problems` or `problems[i]`.
pub(crate) fn problems_of(problems: &Bound<'_, PyAny>) -> PyResult<Problems> {
    let not_a_list = || {
        invalid(
            "problems",
            format!("must be a list of ddpkit.Problem, got {}", type_name(problems)),
        )
    };
    if problems.is_instance_of::<pyo3::types::PyString>() || problems.is_instance_of::<pyo3::types::PyBytes>() {
        return Err(not_a_list().into());
    }
    let iter = problems.try_iter().map_err(|_| not_a_list())?;
    let mut items = Vec::new();
    for (i, obj) in iter.enumerate() {
        let obj = obj?;
        let p = obj.cast_into::<Problem>().map_err(|e| {
            invalid(
                format!("problems[{i}]"),
                format!("must be a ddpkit.Problem, got {}", type_name(e.into_inner().as_any())),
            )
        })?;
        items.push(p);
    }
    let first = items
        .first()
        .ok_or_else(|| invalid("problems", "must hold at least one problem, got an empty list"))?
        .get();
    let (nx, nu, horizon) = (first.nx, first.nu, first.horizon);
    for (i, p) in items.iter().enumerate().skip(1) {
        let p = p.get();
        if (p.nx, p.nu, p.horizon) != (nx, nu, horizon) {
            return Err(shape(
                format!("problems[{i}]"),
                format!("(nx, nu, horizon) = ({}, {}, {})", p.nx, p.nu, p.horizon),
                format!("({nx}, {nu}, {horizon}) (that of problems[0]: a batch shares one structure)"),
            )
            .into());
        }
    }
    let locks = items.iter().map(|p| p.get().inner.clone()).collect();
    Ok(Problems { locks, nx, nu, horizon })
}

/// `threads`: `None` for ddp-core's default (`RAYON_NUM_THREADS`, else every core), else at
/// least 1; errors name `threads`.
pub(crate) fn threads_of(threads: Option<i64>) -> CoreResult<usize> {
    match threads {
        None => Ok(resolve_threads(None)?),
        Some(t) if t >= 1 => Ok(resolve_threads(Some(usize::try_from(t).unwrap_or(usize::MAX)))?),
        Some(t) => Err(invalid(
            "threads",
            format!("must be at least 1 (or None for every core), got {t}"),
        )),
    }
}

/// Calls `f` with every problem read-locked (a poisoned lock is read as is: the bindings never
/// panic while holding it).
pub(crate) fn read_all<T>(locks: &[Arc<RwLock<AnyProblem>>], f: impl FnOnce(&[&AnyProblem]) -> T) -> T {
    let guards: Vec<RwLockReadGuard<'_, AnyProblem>> = locks
        .iter()
        .map(|l| l.read().unwrap_or_else(|poisoned| poisoned.into_inner()))
        .collect();
    let refs: Vec<&AnyProblem> = guards.iter().map(|g| &**g).collect();
    f(&refs)
}

/// Why a batch failed: bad input (or a panic) named by ddp-core, or the exception a Python
/// callable model raised while its problem was solved.
pub(crate) enum BatchError {
    Core(CoreError),
    Python(PyErr),
}

impl From<CoreError> for BatchError {
    fn from(e: CoreError) -> Self {
        BatchError::Core(e)
    }
}

impl From<BatchError> for PyErr {
    fn from(e: BatchError) -> PyErr {
        match e {
            BatchError::Core(e) => e.into(),
            BatchError::Python(e) => e,
        }
    }
}

/// Runs `work` for every item on `threads` workers (one `init` state per worker) and returns the
/// results in order, or the error of the lowest failing index: its `CoreError` put under
/// `problems[i]`, or the exception its callable model raised (kept per thread by
/// [`crate::callable`], so taken on the worker right after its item).
pub(crate) fn run<T, S, R>(
    items: &[T],
    threads: usize,
    init: impl Fn() -> CoreResult<S> + Sync,
    work: impl Fn(&mut S, usize, &T) -> CoreResult<R> + Sync,
) -> Result<Vec<R>, BatchError>
where
    T: Sync,
    R: Send,
{
    let results = map_workers(
        items,
        threads,
        || init().map_err(|e| e.0),
        |state, i, item| {
            // Nothing left over from an earlier solve on this thread.
            drop(crate::callable::take_error());
            let r = work(state, i, item).map_err(|e| at_problem(i, e.0));
            Ok(match crate::callable::take_error() {
                Some(e) => Err(e),
                None => Ok(r?),
            })
        },
    );
    let mut out = Vec::with_capacity(results.len());
    for r in results {
        match r {
            Ok(Ok(v)) => out.push(v),
            Ok(Err(py_err)) => return Err(BatchError::Python(py_err)),
            Err(e) => return Err(BatchError::Core(CoreError(e))),
        }
    }
    Ok(out)
}
