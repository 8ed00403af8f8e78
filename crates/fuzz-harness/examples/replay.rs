//! Runs one fuzz target on files, on stable and without libFuzzer: to reproduce a crash the
//! fuzzer saved, or to see why inputs are rejected (`FUZZ_HARNESS_VERBOSE=1`).
//!
//! ```sh
//! FUZZ_HARNESS_VERBOSE=1 cargo run -p fuzz-harness --example replay -- scenario_toml fuzz/artifacts/scenario_toml/crash-*
//! ```

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().expect("usage: replay <target> <files...>");
    let target = fuzz_harness::target(&name).unwrap_or_else(|| panic!("no target {name}"));
    for path in args {
        let data = std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
        let t = std::time::Instant::now();
        let loaded = (target.run)(&data);
        println!(
            "{path}: {} in {:.3} s",
            if loaded { "loaded" } else { "rejected" },
            t.elapsed().as_secs_f64()
        );
    }
}
