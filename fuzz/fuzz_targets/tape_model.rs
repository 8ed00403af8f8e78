#![no_main]
// What the target does with an input: crates/fuzz-harness (`cargo test` runs it on stable too).
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    fuzz_harness::tape_model(data);
});
