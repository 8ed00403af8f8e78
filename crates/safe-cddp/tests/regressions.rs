//! Regression tests of inputs that made a loader panic, abort or hang, each named after what it
//! guards. The inputs are under `tests/regressions/<fuzz target>/` (replayed through the fuzz
//! targets by `crates/fuzz-harness/tests/regressions.rs` too).

use std::path::Path;

use safe_cddp::benchmark::BenchmarkProblem;

#[test]
fn horizon_too_long_to_allocate_is_an_error() {
    // `N = 1e15` reached `Problem::new`, which allocates a knot per step: an allocation failure
    // (abort) instead of an error.
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/regressions/benchmark_problem_json/horizon_too_long_to_allocate.json");
    let e = BenchmarkProblem::from_file(&p).unwrap_err();
    assert!(
        e.to_string().contains("N") && e.to_string().contains("at most 100000"),
        "{e}"
    );
}
