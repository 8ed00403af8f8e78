//! Regression tests of inputs that made a loader panic, abort or hang, each named after what it
//! guards. The inputs are under `tests/regressions/<fuzz target>/` (replayed through the fuzz
//! targets by `crates/fuzz-harness/tests/regressions.rs` too).

use std::path::{Path, PathBuf};

use subgoal_infer::dataset::{parse_manifest, DatasetError};

fn input(target: &str, name: &str) -> String {
    let p: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/regressions")
        .join(target)
        .join(name);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

#[test]
fn sample_counts_that_overflow_are_an_error() {
    // The shards' sample counts were summed unchecked: an overflow panic in debug builds.
    let e: DatasetError = parse_manifest(
        &input("dataset_manifest", "sample_counts_that_overflow.json"),
        Path::new("d"),
    )
    .unwrap_err();
    assert_eq!(e.field(), "shards");
    assert!(e.to_string().contains("more than 2^64 - 1"), "{e}");
}
