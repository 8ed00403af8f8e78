//! Writes the seed corpus of every fuzz target under `fuzz/seeds/<target>/`: valid files of each
//! format, so that the fuzzer starts from inputs that load and mutates them into malformed ones.
//!
//! ```sh
//! cargo run -p fuzz-harness --example make_seeds -- fuzz/seeds
//! ```
//!
//! Deterministic: the same files on every run (seeded weights, a seeded one-sample dataset).

use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use safetensors::tensor::{Dtype, TensorView};
use subgoal_infer::model::{ModelConfig, METADATA_KEY};
use subgoal_infer::SubgoalModel;

fn write(dir: &Path, target: &str, name: &str, bytes: &[u8]) {
    let d = dir.join(target);
    fs::create_dir_all(&d).expect("create the seed folder");
    fs::write(d.join(name), bytes).expect("write a seed");
}

/// A safetensors file of the architecture `config_json` whose tensors are found the way a user
/// would: load, read which tensor the error says is missing and its expected shape, add it with
/// seeded small values, repeat until the file loads.
fn tiny_model(config_json: &str, seed: u64) -> Vec<u8> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut tensors: Vec<(String, Vec<usize>, Vec<u8>)> = Vec::new();
    let meta: HashMap<String, String> = [(METADATA_KEY.to_string(), config_json.to_string())].into();
    for _ in 0..10_000 {
        let views: Vec<(String, TensorView)> = tensors
            .iter()
            .map(|(n, s, d)| {
                (
                    n.clone(),
                    TensorView::new(Dtype::F32, s.clone(), d).expect("consistent tensor"),
                )
            })
            .collect();
        let bytes = safetensors::serialize(views, Some(meta.clone())).expect("serialise");
        let err = match SubgoalModel::from_safetensors(&bytes) {
            Ok(_) => return bytes,
            Err(e) => e.to_string(),
        };
        // `tensor "NAME": is missing (expected shape [A, B])`
        let name = err
            .split('"')
            .nth(1)
            .unwrap_or_else(|| panic!("unexpected error {err}"))
            .to_string();
        let shape: Vec<usize> = err
            .split_once("expected shape [")
            .and_then(|(_, r)| r.split_once(']'))
            .unwrap_or_else(|| panic!("unexpected error {err}"))
            .0
            .split(',')
            .filter(|s| !s.trim().is_empty())
            .map(|s| s.trim().parse().expect("a dimension"))
            .collect();
        let n: usize = shape.iter().product();
        let positive = name.ends_with("running_var");
        let data: Vec<u8> = (0..n)
            .flat_map(|_| {
                let v: f32 = if positive {
                    rng.random_range(0.5..1.5)
                } else {
                    rng.random_range(-0.5..0.5)
                };
                v.to_le_bytes()
            })
            .collect();
        tensors.push((name, shape, data));
    }
    panic!("the architecture needs more than 10000 tensors");
}

fn main() {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "fuzz/seeds".into()));
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");

    // Tape models traced in Python (`bench/own_robot/make_fixtures.py`): dynamics, costs.
    for e in fs::read_dir(root.join("crates/tape/tests/data")).expect("crates/tape/tests/data/") {
        let p = e.expect("entry").path();
        let name = p.file_name().expect("a file").to_string_lossy().to_string();
        write(&dir, "tape_model", &name, &fs::read(&p).expect("read"));
    }

    // Scenario files: the shipped ones and one with every obstacle type.
    for e in fs::read_dir(root.join("scenarios")).expect("scenarios/") {
        let p = e.expect("entry").path();
        let name = p.file_name().expect("a file").to_string_lossy().to_string();
        write(&dir, "scenario_toml", &name, &fs::read(&p).expect("read"));
    }
    write(
        &dir,
        "scenario_toml",
        "every_obstacle.toml",
        br#"name = "every-obstacle"
description = "one of each"
[route]
points = [[0, 0], [10, 0], [10, 5]]
[[obstacles]]
type = "cylinder"
center = [5, 1]
radius = 1.0
[[obstacles]]
type = "box"
center = [8, -2]
size = [2, 2]
yaw_deg = 45
[[obstacles]]
type = "polygon"
points = [[0, 5], [2, 5], [2, 7], [1, 6], [0, 7]]
"#,
    );

    // Peer-benchmark problems.
    for e in fs::read_dir(root.join("bench/problems")).expect("bench/problems/") {
        let p = e.expect("entry").path();
        let name = p.file_name().expect("a file").to_string_lossy().to_string();
        write(&dir, "benchmark_problem_json", &name, &fs::read(&p).expect("read"));
    }

    // Sub-goal models: a tiny CNN and a tiny EfficientNet (both load and run in microseconds),
    // and their architectures; the shipped default's architecture too.
    let cnn = r#"{"format": "ddpkit-subgoal", "version": 1, "arch": "cnn", "in_size": 8, "input_scale": 0.003937, "goal_scale": 5.0, "output_scale": 5.0, "d_model": 4, "nhead": 2, "num_layers": 1, "dim_feedforward": 8, "activation": "relu", "norm_first": false, "layer_norm_eps": 1e-5, "bn_eps": 1e-5, "num_subgoals": 3, "cnn": [{"channels": 2, "kernel": 3, "stride": 2}, {"channels": 4, "kernel": 3, "stride": 2}]}"#;
    let effnet = r#"{"format": "ddpkit-subgoal", "version": 1, "arch": "efficientnet", "in_size": 16, "input_scale": 0.003937, "goal_scale": 5.0, "output_scale": 5.0, "d_model": 8, "nhead": 2, "num_layers": 1, "dim_feedforward": 8, "activation": "gelu", "norm_first": true, "layer_norm_eps": 1e-5, "bn_eps": 1e-3, "num_subgoals": 2, "efficientnet": {"variant": "custom", "stages": [{"expand_ratio": 1.0, "kernel": 3, "stride": 1, "input_channels": 8, "out_channels": 8, "num_layers": 1}, {"expand_ratio": 2.0, "kernel": 3, "stride": 2, "input_channels": 8, "out_channels": 16, "num_layers": 2}], "last_channel": 16}}"#;
    for (name, json, seed) in [("tiny_cnn", cnn, 1), ("tiny_efficientnet", effnet, 2)] {
        ModelConfig::from_json(json).unwrap_or_else(|e| panic!("{name}: {e}"));
        write(
            &dir,
            "subgoal_model_config_json",
            &format!("{name}.json"),
            json.as_bytes(),
        );
        write(
            &dir,
            "subgoal_model_safetensors",
            &format!("{name}.safetensors"),
            &tiny_model(json, seed),
        );
    }
    let default = fs::read(root.join("crates/subgoal-infer/models/default.safetensors")).expect("default model");
    let (_, meta) = safetensors::SafeTensors::read_metadata(&default).expect("default header");
    let json = meta
        .metadata()
        .as_ref()
        .and_then(|m| m.get(METADATA_KEY))
        .expect("architecture");
    write(&dir, "subgoal_model_config_json", "default.json", json.as_bytes());

    // A one-sample dataset: its shard and manifest.
    let tmp = std::env::temp_dir().join(format!("ddpkit-fuzz-seeds-{}", std::process::id()));
    let opts = subgoal_infer::dataset::WriteOptions {
        threads: Some(1),
        ..subgoal_infer::dataset::WriteOptions::new(1, 7, 1)
    };
    subgoal_infer::dataset::write_dataset(&tmp, &opts, &|_| {}).expect("write a dataset");
    let shard = fs::read(tmp.join("shard-00000.safetensors")).expect("the shard");
    write(&dir, "dataset_shard", "one_sample.safetensors", &shard);
    let manifest = fs::read(tmp.join("manifest.json")).expect("the manifest");
    write(&dir, "dataset_manifest", "one_sample.json", &manifest);
    fs::remove_dir_all(&tmp).expect("remove the temporary dataset");

    // IDNP: the benchmark scene with default settings (all bytes below 200 keep defaults), the
    // same with the fixed grid, and one with its own two obstacles.
    let mut benchmark = vec![1u8];
    benchmark.extend([0u8; 63]);
    write(&dir, "idnp_scene", "benchmark.bin", &benchmark);
    let mut fixed = benchmark.clone();
    fixed[60] = 1;
    write(&dir, "idnp_scene", "benchmark_fixed_grid.bin", &fixed);
    // Two obstacles: a triangle (three points of [x, y] from the "(b - 128) / 8" floats) and a
    // rectangle from two corners.
    let f = |v: f64| (v * 8.0 + 128.0) as u8 | 1;
    let mut own = vec![0u8, 2, 3];
    for v in [6.0, 6.0, 7.0, 6.0, 6.5, 7.0] {
        own.extend([f(v)]);
    }
    own.extend([0u8, 0, 0]);
    own.extend([0u8, 1, f(2.0), f(-1.0), f(3.0), f(1.0), 0, 0]);
    own.extend([0u8; 64]);
    write(&dir, "idnp_scene", "two_obstacles.bin", &own);
}
