//! Extracts the README's Rust quick start into `OUT_DIR/readme_quickstart.rs`, so the test
//! `readme_quickstart` compiles and runs exactly the code the README shows.

use std::path::Path;

fn main() {
    // Read at run time: a build script binary compiled under another checkout path (a shared
    // target directory) must still read this checkout's README.
    let manifest_dir = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let readme = Path::new(&manifest_dir).join("../README.md");
    println!("cargo:rerun-if-changed={}", readme.display());
    let text = std::fs::read_to_string(&readme).expect("README.md is readable");
    let start = text.find("### Rust").expect("README has a '### Rust' quick start");
    let rest = &text[start..];
    let mut blocks = Vec::new();
    let mut inside = false;
    let mut block = String::new();
    for line in rest.lines() {
        if line.starts_with("### ") && !line.starts_with("### Rust") {
            break;
        }
        if line.trim_start().starts_with("```") {
            if inside {
                blocks.push(std::mem::take(&mut block));
                inside = false;
            } else {
                inside = line.trim() == "```rust";
            }
            continue;
        }
        if inside {
            block.push_str(line);
            block.push('\n');
        }
    }
    assert!(!blocks.is_empty(), "README's Rust quick start has no ```rust block");
    let mut out = String::new();
    for (i, b) in blocks.iter().enumerate() {
        out.push_str(&format!(
            "/// README quick start, block {i}.\npub fn block_{i}() -> Result<(), Box<dyn std::error::Error>> {{\n{b}\nOk(())\n}}\n"
        ));
    }
    out.push_str(&format!(
        "/// Every block.\npub const BLOCKS: usize = {};\n",
        blocks.len()
    ));
    let dst = Path::new(&std::env::var("OUT_DIR").expect("OUT_DIR")).join("readme_quickstart.rs");
    std::fs::write(dst, out).expect("OUT_DIR is writable");
}
