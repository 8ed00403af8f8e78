//! Every fuzz target inside `cargo test`, on stable: its committed seed corpus
//! (`fuzz/seeds/<target>/`), then seeded proptest cases that mutate the seeds the way a fuzzer
//! does (bit flips, boundary bytes, numbers and tokens spliced into text, cuts, copies) and that
//! throw random bytes. A panic in a loader fails the test; the long campaigns run with
//! `cargo +nightly fuzz` (README, "Fuzzing").

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// Cases per target and test: small enough that all targets together take seconds in the dev
/// profile on two cores.
const CASES: u32 = 1500;

fn seeds_dir(target: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../fuzz/seeds")
        .join(target)
}

fn seeds(target: &str) -> Vec<Vec<u8>> {
    let dir = seeds_dir(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").path())
        .collect();
    files.sort();
    files.iter().map(|p| std::fs::read(p).expect("read a seed")).collect()
}

/// Text a malformed file likes to hold.
const TOKENS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e309",
    "-1",
    "0",
    "1e300",
    "18446744073709551615",
    "18446744073709551616",
    "-9223372036854775808",
    "4294967296",
    "[]",
    "{}",
    "[[",
    "]]",
    "\"",
    "'",
    "\\u0000",
    "null",
    "true",
    ",",
    ":",
    "=",
    "\n",
    "[[obstacles]]\n",
    "type = \"polygon\"\n",
    "\"shape\":[",
    "\"dtype\":\"F32\"",
    "\"data_offsets\":[0,",
    "\"N\": ",
];

#[derive(Debug, Clone)]
enum Edit {
    /// Flip one bit at a position (taken modulo the length).
    Flip(usize, u8),
    /// Write a boundary byte.
    Set(usize, u8),
    /// Insert a token.
    Token(usize, usize),
    /// Write a little-endian integer (a header size or offset gone wrong).
    Int(usize, u64),
    /// Remove a range.
    Cut(usize, usize),
    /// Copy a range elsewhere.
    Copy(usize, usize, usize),
    /// Truncate.
    Truncate(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    let pos = any::<usize>();
    prop_oneof![
        (pos, 0u8..8).prop_map(|(p, b)| Edit::Flip(p, b)),
        (
            pos,
            prop::sample::select(vec![0u8, 1, 0x7f, 0x80, 0xfe, 0xff, b'0', b'9', b'-', b'e'])
        )
            .prop_map(|(p, b)| Edit::Set(p, b)),
        (pos, 0..TOKENS.len()).prop_map(|(p, t)| Edit::Token(p, t)),
        (
            pos,
            prop::sample::select(vec![0u64, 1, 0xffff_ffff, u64::MAX, u64::MAX / 2, 1 << 40, 1 << 62])
        )
            .prop_map(|(p, v)| Edit::Int(p, v)),
        (pos, 1usize..64).prop_map(|(p, n)| Edit::Cut(p, n)),
        (pos, pos, 1usize..64).prop_map(|(a, b, n)| Edit::Copy(a, b, n)),
        pos.prop_map(Edit::Truncate),
    ]
}

fn apply(data: &mut Vec<u8>, e: &Edit) {
    let at = |p: usize, len: usize| if len == 0 { 0 } else { p % len };
    match *e {
        Edit::Flip(p, b) if !data.is_empty() => {
            let i = at(p, data.len());
            data[i] ^= 1 << b;
        }
        Edit::Set(p, b) if !data.is_empty() => {
            let i = at(p, data.len());
            data[i] = b;
        }
        Edit::Token(p, t) => {
            let i = at(p, data.len() + 1);
            data.splice(i..i, TOKENS[t].bytes());
        }
        Edit::Int(p, v) => {
            let i = at(p, data.len() + 1);
            let end = (i + 8).min(data.len());
            data.splice(i..end, v.to_le_bytes());
        }
        Edit::Cut(p, n) if !data.is_empty() => {
            let i = at(p, data.len());
            let end = (i + n).min(data.len());
            data.drain(i..end);
        }
        Edit::Copy(a, b, n) if !data.is_empty() => {
            let i = at(a, data.len());
            let piece: Vec<u8> = data[i..(i + n).min(data.len())].to_vec();
            let j = at(b, data.len() + 1);
            data.splice(j..j, piece);
        }
        Edit::Truncate(p) => {
            let n = at(p, data.len() + 1);
            data.truncate(n);
        }
        _ => {}
    }
}

fn runner() -> TestRunner {
    let config = Config {
        cases: CASES,
        failure_persistence: None,
        ..Config::default()
    };
    TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha))
}

/// The seeds, mutated seeds and random bytes through the target called `name`.
fn smoke(name: &str) {
    let target = fuzz_harness::target(name).expect("a target of that name");
    let seeds = seeds(name);
    assert!(!seeds.is_empty(), "no seeds for {name}");
    for s in &seeds {
        std::hint::black_box((target.run)(s));
    }
    let mutated = (0..seeds.len(), prop::collection::vec(edit(), 1..8));
    runner()
        .run(&mutated, |(k, edits)| {
            let mut data = seeds[k].clone();
            for e in &edits {
                apply(&mut data, e);
            }
            std::hint::black_box((target.run)(&data));
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    let mut random = runner();
    random
        .run(&prop::collection::vec(any::<u8>(), 0..512), |data| {
            std::hint::black_box((target.run)(&data));
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{name}: {e}"));
}

#[test]
fn every_target_has_a_smoke_test() {
    let names: Vec<&str> = fuzz_harness::TARGETS.iter().map(|t| t.name).collect();
    assert_eq!(
        names,
        [
            "scenario_toml",
            "benchmark_problem_json",
            "subgoal_model_safetensors",
            "subgoal_model_config_json",
            "dataset_shard",
            "dataset_manifest",
            "idnp_scene",
            "tape_model"
        ]
    );
    for n in names {
        let src = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../fuzz/fuzz_targets")
                .join(format!("{n}.rs")),
        )
        .unwrap_or_else(|e| panic!("fuzz target {n}: {e}"));
        assert!(
            src.contains(&format!("fuzz_harness::{n}(data)")),
            "fuzz/fuzz_targets/{n}.rs runs another function"
        );
    }
}

#[test]
fn tape_model() {
    smoke("tape_model");
}

#[test]
fn scenario_toml() {
    smoke("scenario_toml");
}

#[test]
fn benchmark_problem_json() {
    smoke("benchmark_problem_json");
}

#[test]
fn subgoal_model_safetensors() {
    smoke("subgoal_model_safetensors");
}

#[test]
fn subgoal_model_config_json() {
    smoke("subgoal_model_config_json");
}

#[test]
fn dataset_shard() {
    smoke("dataset_shard");
}

#[test]
fn dataset_manifest() {
    smoke("dataset_manifest");
}

#[test]
fn idnp_scene() {
    smoke("idnp_scene");
}

/// The seeds are valid inputs: each loads (a seed that no longer loads would leave the fuzzer
/// only malformed inputs to start from).
#[test]
fn seeds_load() {
    for t in fuzz_harness::TARGETS {
        for (k, s) in seeds(t.name).iter().enumerate() {
            assert!((t.run)(s), "seed {k} of {} does not load", t.name);
        }
    }
}
