//! Replays every input the fuzzer found to crash (`crates/*/tests/regressions/<target>/*`, one
//! folder per fuzz target, named after what the input guards) through its fuzz target. The
//! crates' own `tests/regressions.rs` check the error each one now gets.

use std::path::Path;

#[test]
fn every_committed_crash_input_runs_clean() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut replayed = Vec::new();
    for krate in std::fs::read_dir(&crates).expect("crates/") {
        let dir = krate.expect("an entry").path().join("tests/regressions");
        let Ok(targets) = std::fs::read_dir(&dir) else {
            continue;
        };
        for t in targets {
            let t = t.expect("an entry").path();
            if !t.is_dir() {
                continue;
            }
            let name = t.file_name().expect("a name").to_string_lossy().to_string();
            let target =
                fuzz_harness::target(&name).unwrap_or_else(|| panic!("{}: no fuzz target named {name}", t.display()));
            for f in std::fs::read_dir(&t).expect("the target's folder") {
                let f = f.expect("an entry").path();
                (target.run)(&std::fs::read(&f).expect("read the input"));
                replayed.push(f);
            }
        }
    }
    assert!(
        !replayed.is_empty(),
        "no regression inputs found under crates/*/tests/regressions/"
    );
}
