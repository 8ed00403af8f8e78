//! The README's Rust quick start, compiled and run as written (extracted by `build.rs`).

mod readme {
    #![allow(unused_variables, missing_docs, clippy::all)]
    include!(concat!(env!("OUT_DIR"), "/readme_quickstart.rs"));
}

#[test]
fn readme_rust_quick_start_runs() {
    readme::block_0().expect("the README's quick start runs");
    if readme::BLOCKS > 1 {
        readme::block_1().expect("the README's second Rust block runs");
    }
    if readme::BLOCKS > 2 {
        readme::block_2().expect("the README's third Rust block runs");
    }
}
