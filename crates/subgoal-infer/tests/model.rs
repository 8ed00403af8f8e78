//! The sub-goal network in Rust against torch: the golden fixture (`tests/fixtures`, made by
//! `make_golden.py`, checked without torch) for the default CNN architecture, a reduced
//! EfficientNet (B0's MBConv code path) and the shipped default model; plus malformed and
//! mismatched weights, which must give errors naming the tensor or field, never panics.

use std::collections::HashMap;

use proptest::prelude::*;
use safetensors::{Dtype, SafeTensors};
use subgoal_infer::model::{Arch, EfficientNetConfig, METADATA_KEY};
use subgoal_infer::SubgoalModel;

const CNN: &[u8] = include_bytes!("fixtures/cnn.safetensors");
const EFFICIENTNET: &[u8] = include_bytes!("fixtures/efficientnet.safetensors");
const GOLDEN: &[u8] = include_bytes!("fixtures/golden.safetensors");

/// Costmaps, goals and one model's torch outputs (float64) per golden input.
type Golden = (Vec<Vec<u8>>, Vec<[f32; 2]>, Vec<Vec<[f64; 2]>>);

/// The golden inputs and one model's torch outputs: `(costmaps, goals, outputs)`.
fn golden(model: &str) -> Golden {
    let st = SafeTensors::deserialize(GOLDEN).unwrap();
    let maps = st.tensor("costmaps").unwrap();
    assert_eq!(maps.dtype(), Dtype::U8);
    let n = maps.shape()[0];
    let cells = maps.shape()[1] * maps.shape()[2];
    let costmaps = maps.data().chunks_exact(cells).map(|c| c.to_vec()).collect();
    let g = st.tensor("goals").unwrap();
    let gf: Vec<f32> = g
        .data()
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    let goals = gf.chunks_exact(2).map(|p| [p[0], p[1]]).collect();
    let o = st.tensor(model).unwrap();
    assert_eq!(o.dtype(), Dtype::F64);
    let s = o.shape()[1];
    let of: Vec<f64> = o
        .data()
        .chunks_exact(8)
        .map(|b| f64::from_le_bytes(b.try_into().unwrap()))
        .collect();
    let outputs = of
        .chunks_exact(2 * s)
        .map(|r| r.chunks_exact(2).map(|p| [p[0], p[1]]).collect())
        .collect();
    assert_eq!(n, gf.len() / 2);
    (costmaps, goals, outputs)
}

fn assert_matches_torch(model: &SubgoalModel, name: &str) {
    let (maps, goals, want) = golden(name);
    let mut worst = 0.0f64;
    for ((cells, goal), want) in maps.iter().zip(&goals).zip(&want) {
        let got = model.predict(cells, *goal).unwrap();
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            for k in 0..2 {
                worst = worst.max((g[k] as f64 - w[k]).abs());
            }
        }
    }
    eprintln!("{name}: largest difference from torch {worst:e} m");
    assert!(worst < 1e-4, "{name}: largest difference from torch {worst:e} m");
}

#[test]
fn default_cnn_architecture_matches_torch() {
    let model = SubgoalModel::from_safetensors(CNN).unwrap();
    assert_eq!(model.config().arch, Arch::Cnn);
    assert_matches_torch(&model, "cnn");
}

#[test]
fn reduced_efficientnet_matches_torch() {
    let model = SubgoalModel::from_safetensors(EFFICIENTNET).unwrap();
    assert_eq!(model.config().arch, Arch::Efficientnet);
    assert!(model.config().norm_first, "the fixture covers the pre-norm decoder");
    assert_matches_torch(&model, "efficientnet");
}

#[test]
fn shipped_default_model_matches_torch() {
    let model = SubgoalModel::default_model().unwrap();
    assert_eq!(model.num_subgoals(), 3);
    assert_matches_torch(&model, "default");
}

#[test]
fn load_reads_files_and_names_unreadable_paths() {
    let dir = std::env::temp_dir().join(format!("subgoal-model-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cnn.safetensors");
    std::fs::write(&path, CNN).unwrap();
    let a = SubgoalModel::load(&path).unwrap();
    let b = SubgoalModel::from_safetensors(CNN).unwrap();
    let (maps, goals, _) = golden("cnn");
    assert_eq!(
        a.predict(&maps[0], goals[0]).unwrap(),
        b.predict(&maps[0], goals[0]).unwrap()
    );
    let err = SubgoalModel::load(dir.join("missing.safetensors"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("path") && err.contains("missing.safetensors"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn efficientnet_b0_runs_with_random_weights() {
    let mut config = SubgoalModel::from_safetensors(CNN).unwrap().config().clone();
    config.arch = Arch::Efficientnet;
    config.cnn = None;
    config.efficientnet = Some(EfficientNetConfig::b0());
    let model = SubgoalModel::with_random_weights(config.clone(), 7).unwrap();
    let (maps, goals, _) = golden("cnn");
    let a = model.predict(&maps[0], goals[0]).unwrap();
    assert_eq!(a.len(), 3);
    // Seeded: the same seed gives the same network.
    let again = SubgoalModel::with_random_weights(config, 7).unwrap();
    assert_eq!(again.predict(&maps[0], goals[0]).unwrap(), a);
}

#[test]
fn bad_inputs_to_predict_are_errors() {
    let model = SubgoalModel::from_safetensors(CNN).unwrap();
    let err = model.predict(&[0u8; 100], [1.0, 0.0]).unwrap_err().to_string();
    assert!(err.contains("cells") && err.contains("40000"), "{err}");
    let err = model.predict(&[0u8; 40000], [f32::NAN, 0.0]).unwrap_err().to_string();
    assert!(err.contains("goal[0]"), "{err}");
}

// ------------------------------------------------------------------------------------------------
// Malformed and mismatched weights
// ------------------------------------------------------------------------------------------------

/// An owned copy of a file's tensors and metadata, to edit and serialise again.
struct Edit {
    tensors: Vec<(String, Dtype, Vec<usize>, Vec<u8>)>,
    metadata: HashMap<String, String>,
}

impl Edit {
    fn of(bytes: &[u8]) -> Self {
        let (_, meta) = SafeTensors::read_metadata(bytes).unwrap();
        let metadata = meta.metadata().clone().unwrap().into_iter().collect();
        let st = SafeTensors::deserialize(bytes).unwrap();
        let tensors = st
            .tensors()
            .into_iter()
            .map(|(n, v)| (n, v.dtype(), v.shape().to_vec(), v.data().to_vec()))
            .collect();
        Self { tensors, metadata }
    }

    fn bytes(&self) -> Vec<u8> {
        let views: Vec<(String, safetensors::tensor::TensorView)> = self
            .tensors
            .iter()
            .map(|(n, d, s, b)| {
                (
                    n.clone(),
                    safetensors::tensor::TensorView::new(*d, s.clone(), b).unwrap(),
                )
            })
            .collect();
        safetensors::serialize(
            views.iter().map(|(n, v)| (n.as_str(), v)),
            Some(self.metadata.clone().into_iter().collect()),
        )
        .unwrap()
    }

    fn tensor(&mut self, name: &str) -> &mut (String, Dtype, Vec<usize>, Vec<u8>) {
        self.tensors.iter_mut().find(|t| t.0 == name).unwrap()
    }

    fn remove(&mut self, name: &str) {
        self.tensors.retain(|t| t.0 != name);
    }
}

fn load_err(bytes: &[u8]) -> String {
    SubgoalModel::from_safetensors(bytes).unwrap_err().to_string()
}

#[test]
fn missing_tensors_are_named() {
    for name in [
        "encoder.layers.2.conv.weight",
        "encoder.layers.0.bn.running_var",
        "decoder.layers.1.multihead_attn.in_proj_weight",
        "queries",
        "head.bias",
    ] {
        let mut e = Edit::of(CNN);
        e.remove(name);
        let err = load_err(&e.bytes());
        assert!(err.contains(name) && err.contains("missing"), "{name}: {err}");
    }
    let mut e = Edit::of(EFFICIENTNET);
    e.remove("encoder.features.2.1.block.2.fc1.bias");
    let err = load_err(&e.bytes());
    assert!(err.contains("encoder.features.2.1.block.2.fc1.bias"), "{err}");
}

#[test]
fn wrong_shapes_and_dtypes_are_named() {
    let mut e = Edit::of(CNN);
    let t = e.tensor("pos_embed");
    t.2 = vec![t.2[1], t.2[0]];
    let err = load_err(&e.bytes());
    assert!(err.contains("pos_embed") && err.contains("shape"), "{err}");

    let mut e = Edit::of(CNN);
    let t = e.tensor("goal_embed.weight");
    t.1 = Dtype::I32;
    let err = load_err(&e.bytes());
    assert!(err.contains("goal_embed.weight") && err.contains("dtype"), "{err}");

    let mut e = Edit::of(CNN);
    let t = e.tensor("head.weight");
    t.3[0..4].copy_from_slice(&f32::NAN.to_le_bytes());
    let err = load_err(&e.bytes());
    assert!(err.contains("head.weight") && err.contains("finite"), "{err}");

    let mut e = Edit::of(CNN);
    let t = e.tensor("encoder.layers.1.bn.running_var");
    t.3[0..4].copy_from_slice(&(-1.0f32).to_le_bytes());
    let err = load_err(&e.bytes());
    assert!(
        err.contains("encoder.layers.1.bn.running_var") && err.contains("negative"),
        "{err}"
    );
}

#[test]
fn unexpected_tensors_and_mismatched_architectures_are_named() {
    let mut e = Edit::of(CNN);
    e.tensors
        .push(("encoder.layers.9.conv.weight".into(), Dtype::F32, vec![1], vec![0; 4]));
    let err = load_err(&e.bytes());
    assert!(
        err.contains("encoder.layers.9.conv.weight") && err.contains("unexpected"),
        "{err}"
    );

    // The CNN's weights under the EfficientNet's architecture: the first missing tensor is named.
    let mut e = Edit::of(CNN);
    e.metadata.insert(
        METADATA_KEY.into(),
        Edit::of(EFFICIENTNET).metadata[METADATA_KEY].clone(),
    );
    let err = load_err(&e.bytes());
    assert!(err.contains("encoder.features.0.0.weight"), "{err}");

    // A metadata width that disagrees with the tensors.
    let mut e = Edit::of(CNN);
    let json = e.metadata[METADATA_KEY].replace("\"d_model\": 64", "\"d_model\": 32");
    assert_ne!(json, e.metadata[METADATA_KEY]);
    e.metadata.insert(METADATA_KEY.into(), json);
    let err = load_err(&e.bytes());
    assert!(err.contains("tensor") && err.contains("shape"), "{err}");
}

#[test]
fn bad_metadata_is_named() {
    let mut e = Edit::of(CNN);
    e.metadata.remove(METADATA_KEY);
    let err = load_err(&e.bytes());
    assert!(err.contains(METADATA_KEY) && err.contains("missing"), "{err}");

    let cases = [
        ("\"version\": 1", "\"version\": 2", "version"),
        ("\"nhead\": 4", "\"nhead\": 3", "nhead"),
        ("\"arch\": \"cnn\"", "\"arch\": \"resnet\"", METADATA_KEY),
        ("\"in_size\": 200", "\"in_size\": 100000", "in_size"),
        ("\"goal_scale\": 5.0", "\"goal_scale\": -5.0", "goal_scale"),
    ];
    for (from, to, field) in cases {
        let mut e = Edit::of(CNN);
        let json = e.metadata[METADATA_KEY].replace(from, to);
        assert_ne!(json, e.metadata[METADATA_KEY], "{from} not in the metadata");
        e.metadata.insert(METADATA_KEY.into(), json);
        let err = load_err(&e.bytes());
        assert!(err.contains(field), "{to}: {err}");
    }
    let mut e = Edit::of(CNN);
    e.metadata.insert(METADATA_KEY.into(), "{not json".into());
    assert!(load_err(&e.bytes()).contains(METADATA_KEY));
}

#[test]
fn truncated_and_garbage_files_are_errors() {
    for len in [0, 7, 8, 100, CNN.len() / 2, CNN.len() - 1] {
        let err = load_err(&CNN[..len]);
        assert!(err.contains("safetensors"), "{len}: {err}");
    }
    assert!(load_err(b"definitely not a safetensors file").contains("safetensors"));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Corrupting any bytes of a valid file gives an error or a working model, never a panic.
    #[test]
    fn corrupted_files_never_panic(flips in proptest::collection::vec((0usize..EFFICIENTNET.len(), any::<u8>()), 1..8)) {
        let mut bytes = EFFICIENTNET.to_vec();
        for (i, b) in flips {
            bytes[i] = b;
        }
        if let Ok(model) = SubgoalModel::from_safetensors(&bytes) {
            let _ = model.predict(&vec![0u8; 200 * 200], [3.0, 1.0]);
        }
    }

    /// Flips inside the header (where the shapes and the architecture live).
    #[test]
    fn corrupted_headers_never_panic(flips in proptest::collection::vec((8usize..2000, any::<u8>()), 1..4)) {
        let mut bytes = EFFICIENTNET.to_vec();
        for (i, b) in flips {
            bytes[i] = b;
        }
        if let Ok(model) = SubgoalModel::from_safetensors(&bytes) {
            let _ = model.predict(&vec![0u8; 200 * 200], [3.0, 1.0]);
        }
    }
}
