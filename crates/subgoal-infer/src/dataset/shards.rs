//! Dataset shards on disk: safetensors files that numpy and torch memory-map, and a manifest.
//!
//! `DIR/shard-00000.safetensors`, `DIR/shard-00001.safetensors`, … each hold `n` consecutive
//! samples (the last one possibly fewer):
//!
//! | tensor | dtype | shape | what |
//! |---|---|---|---|
//! | `costmaps` | `U8` | `[n, 200, 200]` | inflated costs, `[k, iy, ix]` |
//! | `goals` | `F32` | `[n, 2]` | goal (m, relative to the map centre) |
//! | `subgoals` | `F32` | `[n, 3, 2]` | sub-goals at the path steps (m) |
//! | `path_lengths` | `I32` | `[n]` | cells on the A* path, start and goal included |
//! | `traps` | `U8` | `[n]` | 1 when the map has a trap across the line to the goal |
//!
//! (`I32` rather than `U32`: torch's support for unsigned 32-bit tensors is limited.) The header
//! metadata holds the format name and version, the seed, the index of the first sample, the
//! number of samples, the resolution, the map size, the sub-goal steps and the generator
//! parameters as JSON. `DIR/manifest.json` lists the shards with the same facts; it is written
//! last, so a directory without it holds no complete dataset. Every file is written to a
//! temporary file in `DIR` and renamed: it is whole or absent.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use safetensors::tensor::Dtype;
use safetensors::SafeTensors;

use super::sweep::{self, DatasetConfig, ShardWriter};
use super::{DatasetParams, Generator, SampleInfo, MAP_CELLS, MAP_LEN, NUM_SUBGOALS, RESOLUTION};
use crate::error::Error;

/// The `format` entry of shard metadata and of the manifest.
pub const FORMAT_NAME: &str = "ddpkit-subgoal-dataset";
/// Version of the shard layout; readers reject other versions.
pub const FORMAT_VERSION: u32 = 1;
/// Largest shard (samples): 50 000 costmaps are 2 GB in memory while the shard is built.
pub(super) const MAX_SHARD_SIZE: usize = 50_000;
pub(super) const MANIFEST: &str = "manifest.json";

/// Errors of writing and reading datasets.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// Bad input (names the field).
    #[error(transparent)]
    Invalid(#[from] Error),
    /// A file or directory could not be created, written or read.
    #[error("{field}: {path}: {reason}")]
    Io {
        /// The argument the path came from (`out_dir`, `path`, `dir`).
        field: String,
        /// The path.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// A file is not a dataset shard or manifest of this format.
    #[error("{path}: {field}: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// The tensor or entry at fault (`costmaps`, `metadata.format_version`, …).
        field: String,
        /// What is wrong with it.
        reason: String,
    },
}

impl DatasetError {
    /// The field (argument, tensor or entry) the error names.
    pub fn field(&self) -> String {
        match self {
            DatasetError::Invalid(Error::Invalid { field, .. } | Error::Geometry { field, .. }) => field.clone(),
            DatasetError::Io { field, .. } | DatasetError::Format { field, .. } => field.clone(),
        }
    }
}

pub(super) fn io_err(field: &str, path: &Path, e: impl std::fmt::Display) -> DatasetError {
    DatasetError::Io {
        field: field.into(),
        path: path.to_path_buf(),
        reason: e.to_string(),
    }
}

/// What to generate.
#[derive(Debug, Clone, PartialEq)]
pub struct WriteOptions {
    /// Number of samples (at least 1).
    pub samples: u64,
    /// Seed: sample `i` is a function of `(seed, i)` only.
    pub seed: u64,
    /// Samples per shard, `1..=50000` (5000 costmaps are 200 MB).
    pub shard_size: usize,
    /// Worker threads (`None`: all cores). Without the `parallel` feature generation is serial
    /// and only `None` or `Some(1)` are accepted.
    pub threads: Option<usize>,
    /// Generator parameters.
    pub params: DatasetParams,
}

impl WriteOptions {
    /// `samples` samples of `seed` in shards of `shard_size`, default parameters, all cores.
    pub fn new(samples: u64, seed: u64, shard_size: usize) -> Self {
        Self {
            samples,
            seed,
            shard_size,
            threads: None,
            params: DatasetParams::default(),
        }
    }

    /// Rejects impossible values, naming the field.
    pub fn validate(&self) -> Result<(), Error> {
        if self.samples == 0 {
            return Err(Error::invalid("samples", "must be at least 1, got 0"));
        }
        if self.shard_size == 0 || self.shard_size > MAX_SHARD_SIZE {
            return Err(Error::invalid(
                "shard_size",
                format!("must be in 1..={MAX_SHARD_SIZE}, got {}", self.shard_size),
            ));
        }
        if self.samples.div_ceil(self.shard_size as u64) > 10_000_000 {
            return Err(Error::invalid(
                "samples",
                format!(
                    "{} samples in shards of {} are too many shards",
                    self.samples, self.shard_size
                ),
            ));
        }
        match self.threads {
            Some(0) => return Err(Error::invalid("threads", "must be at least 1, got 0")),
            Some(t) if t > 1 && !cfg!(feature = "parallel") => {
                return Err(Error::invalid(
                    "threads",
                    format!("built without the `parallel` feature: must be 1, got {t}"),
                ))
            }
            Some(t) if t > 1024 => return Err(Error::invalid("threads", format!("must be at most 1024, got {t}"))),
            _ => {}
        }
        self.params.validate()
    }
}

/// One shard in the manifest.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ShardEntry {
    /// File name inside the dataset directory.
    pub file: String,
    /// Index of its first sample.
    pub first_index: u64,
    /// Number of samples.
    pub samples: u64,
}

/// What [`write_dataset`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetSummary {
    /// The dataset directory.
    pub dir: PathBuf,
    /// Total samples.
    pub samples: u64,
    /// The shards, in order.
    pub shards: Vec<ShardEntry>,
    /// The manifest file.
    pub manifest: PathBuf,
    /// Wall time (s) of generation and writing.
    pub seconds: f64,
}

impl DatasetSummary {
    /// The line the dataset binary and `ddpkit.experiments` print: samples, shards, directory,
    /// wall time `seconds` (the summary's own, or a sweep's), throughput and `workers` (the
    /// thread or worker count as it should read).
    pub fn line(&self, seconds: f64, workers: &str) -> String {
        format!(
            "{} samples in {} shards -> {} ({seconds:.2} s, {:.0} samples/s, {workers})",
            self.samples,
            self.shards.len(),
            self.dir.display(),
            self.samples as f64 / seconds.max(1e-9),
        )
    }
}

/// The parsed `manifest.json` of a dataset directory.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifest {
    /// The dataset directory.
    pub dir: PathBuf,
    /// Total samples.
    pub samples: u64,
    /// Seed.
    pub seed: u64,
    /// Samples per shard (the last shard may hold fewer).
    pub shard_size: usize,
    /// Path steps of the sub-goals.
    pub subgoal_steps: Vec<usize>,
    /// The shards, in order.
    pub shards: Vec<ShardEntry>,
}

impl Manifest {
    /// Path of shard `k`.
    pub fn shard_path(&self, k: usize) -> Option<PathBuf> {
        self.shards.get(k).map(|s| self.dir.join(&s.file))
    }
}

/// File name of shard `k`.
pub fn shard_file_name(k: usize) -> String {
    format!("shard-{k:05}.safetensors")
}

pub(super) fn params_json(p: &DatasetParams) -> serde_json::Value {
    serde_json::json!({
        "inscribed_radius": p.inscribed_radius,
        "inflation_radius": p.inflation_radius,
        "cost_scaling": p.cost_scaling,
        "free_radius": p.free_radius,
        "goal_band": p.goal_band,
        "subgoal_steps": p.subgoal_steps,
        "trap_probability": p.trap_probability,
        "lidar_view": p.lidar_view,
        "lidar_beams": p.lidar_beams,
        "shadow_depth": p.shadow_depth,
        "min_obstacles": p.min_obstacles,
        "max_obstacles": p.max_obstacles,
        "astar_blocked": p.astar.blocked,
        "astar_cost_weight": p.astar.cost_weight,
    })
}

/// The frame convention, stored with the data so a reader need not guess.
pub(super) const FRAME: &str = "goals and subgoals in metres relative to the map centre; x along the column index ix, \
y along the row index iy; a cell stands for its centre ((i - 100 + 0.5) * 0.05); costmaps[k, iy, ix]";

/// Generates `opts.samples` samples into `out_dir` (created if missing) as shards and a manifest
/// (see the module docs). `progress(k)` is called from the worker threads as `k` more samples are
/// done. An existing `manifest.json` is removed before the first shard is written and shards of
/// this naming beyond the new count are deleted before the new manifest is written, so the
/// directory ends up holding exactly the new dataset. Errors name the
/// field: `samples`, `shard_size`, `threads`, a parameter, or `out_dir` for files.
pub fn write_dataset(
    out_dir: &Path,
    opts: &WriteOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<DatasetSummary, DatasetError> {
    opts.validate()?;
    let start = Instant::now();
    // The shards are the tasks of `sweep` (what `ddpkit.experiments` runs on other executors),
    // run here one after another, each on every thread of the pool.
    let config = DatasetConfig::from_options(out_dir, opts);
    let tasks = sweep::tasks(&config)?;
    let writer = ShardWriter::new(&opts.params, opts.threads)?;
    let results = tasks
        .iter()
        .map(|t| writer.write(t, progress))
        .collect::<Result<Vec<_>, _>>()?;
    let mut summary = sweep::aggregate(&config, &results)?;
    summary.seconds = start.elapsed().as_secs_f64();
    Ok(summary)
}

/// Deletes `shard-NNNNN.safetensors` files with `NNNNN >= keep` (left by a larger earlier run).
pub(super) fn remove_stale_shards(dir: &Path, keep: usize) -> Result<(), DatasetError> {
    let entries = std::fs::read_dir(dir).map_err(|e| io_err("out_dir", dir, e))?;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let Some(num) = name.strip_prefix("shard-").and_then(|s| s.strip_suffix(".safetensors")) else {
            continue;
        };
        if num.len() >= 5 && num.bytes().all(|b| b.is_ascii_digit()) && num.parse::<usize>().is_ok_and(|k| k >= keep) {
            std::fs::remove_file(entry.path()).map_err(|e| io_err("out_dir", &entry.path(), e))?;
        }
    }
    Ok(())
}

fn le_bytes_f32(v: impl Iterator<Item = f32>) -> Vec<u8> {
    v.flat_map(f32::to_le_bytes).collect()
}

/// Writes one shard in the safetensors layout: the little-endian header length, the JSON header
/// (metadata with sorted keys, tensors in the safetensors crate's order: by dtype alignment, then
/// by name; padded with spaces to 8 bytes), then the tensors' bytes. Written here rather than
/// by `safetensors::serialize_to_file`, whose metadata comes from a `HashMap` in random order:
/// the same seed must give the same bytes. Streams the costmaps without a copy; temporary file
/// and rename, so the shard is whole or absent.
pub(super) fn write_shard(
    path: &Path,
    seed: u64,
    params: &DatasetParams,
    first: u64,
    costmaps: &[u8],
    infos: &[SampleInfo],
) -> Result<(u64, u64), DatasetError> {
    use std::io::Write;
    let n = infos.len();
    let goals = le_bytes_f32(infos.iter().flat_map(|s| s.goal));
    let subgoals = le_bytes_f32(infos.iter().flat_map(|s| s.subgoals.into_iter().flatten()));
    let lengths: Vec<u8> = infos
        .iter()
        .flat_map(|s| (s.path_length as i32).to_le_bytes())
        .collect();
    let traps: Vec<u8> = infos.iter().map(|s| s.trap as u8).collect();
    // The crate's order: descending dtype (F32 > I32 > U8), then name.
    let tensors: [(&str, &str, Vec<usize>, &[u8]); 5] = [
        ("goals", "F32", vec![n, 2], &goals),
        ("subgoals", "F32", vec![n, NUM_SUBGOALS, 2], &subgoals),
        ("path_lengths", "I32", vec![n], &lengths),
        ("costmaps", "U8", vec![n, MAP_CELLS, MAP_CELLS], costmaps),
        ("traps", "U8", vec![n], &traps),
    ];
    let mut meta = [
        ("format", FORMAT_NAME.to_string()),
        ("format_version", FORMAT_VERSION.to_string()),
        ("seed", seed.to_string()),
        ("first_index", first.to_string()),
        ("samples", n.to_string()),
        ("resolution", RESOLUTION.to_string()),
        ("map_cells", MAP_CELLS.to_string()),
        ("subgoal_steps", serde_json::json!(params.subgoal_steps).to_string()),
        ("frame", FRAME.to_string()),
        ("params", params_json(params).to_string()),
    ];
    meta.sort();
    // JSON string literals (escaped) for keys and values.
    let lit = |s: &str| serde_json::Value::String(s.to_string()).to_string();
    let meta_json: Vec<String> = meta.iter().map(|(k, v)| format!("{}:{}", lit(k), lit(v))).collect();
    let mut header = format!("{{\"__metadata__\":{{{}}}", meta_json.join(","));
    let mut offset = 0;
    for (name, dtype, shape, data) in &tensors {
        let shape: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
        header.push_str(&format!(
            ",\"{name}\":{{\"dtype\":\"{dtype}\",\"shape\":[{}],\"data_offsets\":[{offset},{}]}}",
            shape.join(","),
            offset + data.len()
        ));
        offset += data.len();
    }
    header.push('}');
    while header.len() % 8 != 0 {
        header.push(' ');
    }
    let len = (header.len() as u64).to_le_bytes();
    // Size and FNV-1a digest of the file's bytes: a sweep's per-shard result, so two runs can be
    // compared without reading the shards back.
    let mut digest = Fnv1a::new();
    digest.update(&len);
    digest.update(header.as_bytes());
    for (_, _, _, data) in &tensors {
        digest.update(data);
    }
    ddpkit_util::fs::write_atomic_with(path, |f| {
        f.write_all(&len)?;
        f.write_all(header.as_bytes())?;
        for (_, _, _, data) in &tensors {
            f.write_all(data)?;
        }
        Ok(())
    })
    .map_err(|e| io_err("out_dir", path, e))?;
    Ok((digest.bytes, digest.hash))
}

/// 64-bit FNV-1a over a stream of bytes, with its length.
struct Fnv1a {
    hash: u64,
    bytes: u64,
}

impl Fnv1a {
    fn new() -> Self {
        Self {
            hash: 0xcbf2_9ce4_8422_2325,
            bytes: 0,
        }
    }

    fn update(&mut self, data: &[u8]) {
        let mut h = self.hash;
        for &b in data {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        self.hash = h;
        self.bytes += data.len() as u64;
    }
}

#[cfg(feature = "parallel")]
pub(super) type Pool = Option<rayon::ThreadPool>;
#[cfg(not(feature = "parallel"))]
pub(super) type Pool = ();

#[cfg(feature = "parallel")]
pub(super) fn thread_pool(threads: Option<usize>) -> Result<Pool, DatasetError> {
    match threads {
        None => Ok(None),
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .map(Some)
            .map_err(|e| Error::invalid("threads", format!("cannot start {t} threads: {e}")).into()),
    }
}

#[cfg(not(feature = "parallel"))]
pub(super) fn thread_pool(_threads: Option<usize>) -> Result<Pool, DatasetError> {
    Ok(())
}

/// Samples `first..first + infos.len()` into the buffers.
#[cfg(feature = "parallel")]
pub(super) fn fill(
    pool: &Pool,
    proto: &Generator,
    seed: u64,
    first: u64,
    costmaps: &mut [u8],
    infos: &mut [SampleInfo],
    progress: &(dyn Fn(u64) + Sync),
) {
    use rayon::prelude::*;
    // Blocks of samples per task: one generator (about 1.5 MB of buffers) per block.
    const BLOCK: usize = 16;
    let mut run = move || {
        costmaps
            .par_chunks_mut(BLOCK * MAP_LEN)
            .zip(infos.par_chunks_mut(BLOCK))
            .enumerate()
            .for_each_init(
                || proto.clone(),
                |gen, (b, (maps, infos))| {
                    for (j, (map, info)) in maps.chunks_mut(MAP_LEN).zip(infos.iter_mut()).enumerate() {
                        let index = first + (b * BLOCK + j) as u64;
                        if let Ok(i) = gen.sample_into(seed, index, map) {
                            *info = i;
                        }
                    }
                    progress(infos.len() as u64);
                },
            )
    };
    match pool {
        Some(p) => p.install(run),
        None => run(),
    }
}

#[cfg(not(feature = "parallel"))]
pub(super) fn fill(
    _pool: &Pool,
    proto: &Generator,
    seed: u64,
    first: u64,
    costmaps: &mut [u8],
    infos: &mut [SampleInfo],
    progress: &(dyn Fn(u64) + Sync),
) {
    let mut gen = proto.clone();
    for (j, (map, info)) in costmaps.chunks_mut(MAP_LEN).zip(infos.iter_mut()).enumerate() {
        if let Ok(i) = gen.sample_into(seed, first + j as u64, map) {
            *info = i;
        }
        progress(1);
    }
}

/// One shard read into memory (the Rust reader, for tests and tools; Python memory-maps the
/// files instead, see `ddpkit.subgoal.load_shards`).
#[derive(Debug, Clone, PartialEq)]
pub struct Shard {
    /// The header metadata.
    pub metadata: HashMap<String, String>,
    /// Seed of the dataset.
    pub seed: u64,
    /// Index of the first sample.
    pub first_index: u64,
    /// Costmaps, `[n, 200, 200]` row-major.
    pub costmaps: Vec<u8>,
    /// Goals (m).
    pub goals: Vec<[f32; 2]>,
    /// Sub-goals (m).
    pub subgoals: Vec<[[f32; 2]; NUM_SUBGOALS]>,
    /// Cells on each A* path.
    pub path_lengths: Vec<u32>,
    /// Whether each map has a trap.
    pub traps: Vec<bool>,
}

impl Shard {
    /// Reads and checks the shard at `path`. Errors name the tensor or metadata entry at fault.
    pub fn read(path: &Path) -> Result<Self, DatasetError> {
        let bytes = std::fs::read(path).map_err(|e| io_err("path", path, e))?;
        Self::from_bytes(&bytes, path)
    }

    /// Parses shard bytes (`path` only names the source in errors).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, DatasetError> {
        let fmt = |field: &str, reason: String| DatasetError::Format {
            path: path.to_path_buf(),
            field: field.into(),
            reason,
        };
        let (_, header) = SafeTensors::read_metadata(bytes).map_err(|e| fmt("header", e.to_string()))?;
        let tensors = SafeTensors::deserialize(bytes).map_err(|e| fmt("header", e.to_string()))?;
        let metadata = header.metadata().clone().unwrap_or_default();
        let entry = |key: &str| {
            metadata
                .get(key)
                .ok_or_else(|| fmt(&format!("metadata.{key}"), "missing".into()))
        };
        if entry("format")? != FORMAT_NAME {
            return Err(fmt(
                "metadata.format",
                format!("expected {FORMAT_NAME}, got {}", entry("format")?),
            ));
        }
        let version = entry("format_version")?;
        if version != &FORMAT_VERSION.to_string() {
            return Err(fmt(
                "metadata.format_version",
                format!("expected {FORMAT_VERSION}, got {version}"),
            ));
        }
        let parse_u64 = |key: &str| -> Result<u64, DatasetError> {
            let v = entry(key)?;
            v.parse()
                .map_err(|_| fmt(&format!("metadata.{key}"), format!("not an integer: {v}")))
        };
        let seed = parse_u64("seed")?;
        let first_index = parse_u64("first_index")?;
        let n = parse_u64("samples")? as usize;
        let get = |name: &str, dtype: Dtype, shape: &[usize]| {
            let t = tensors.tensor(name).map_err(|_| fmt(name, "missing".into()))?;
            if t.dtype() != dtype || t.shape() != shape {
                return Err(fmt(
                    name,
                    format!("{:?} {:?}, expected {dtype:?} {shape:?}", t.dtype(), t.shape()),
                ));
            }
            Ok(t.data())
        };
        let costmaps = get("costmaps", Dtype::U8, &[n, MAP_CELLS, MAP_CELLS])?.to_vec();
        let f32s = |b: &[u8]| -> Vec<f32> {
            b.chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                .collect()
        };
        let g = f32s(get("goals", Dtype::F32, &[n, 2])?);
        let s = f32s(get("subgoals", Dtype::F32, &[n, NUM_SUBGOALS, 2])?);
        let path_lengths = get("path_lengths", Dtype::I32, &[n])?
            .chunks_exact(4)
            .map(|c| i32::from_le_bytes([c[0], c[1], c[2], c[3]]).max(0) as u32)
            .collect();
        let traps = get("traps", Dtype::U8, &[n])?.iter().map(|&t| t != 0).collect();
        Ok(Self {
            seed,
            first_index,
            costmaps,
            goals: g.chunks_exact(2).map(|c| [c[0], c[1]]).collect(),
            subgoals: s
                .chunks_exact(2 * NUM_SUBGOALS)
                .map(|c| [[c[0], c[1]], [c[2], c[3]], [c[4], c[5]]])
                .collect(),
            path_lengths,
            traps,
            metadata,
        })
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.goals.len()
    }
    /// Whether the shard holds no sample.
    pub fn is_empty(&self) -> bool {
        self.goals.is_empty()
    }
    /// Costmap of sample `k` of the shard (row-major, `[iy, ix]`); `None` past the end.
    pub fn costmap(&self, k: usize) -> Option<&[u8]> {
        self.costmaps.get(k * MAP_LEN..(k + 1) * MAP_LEN)
    }
}

/// Reads `dir/manifest.json`. Errors name the entry at fault.
pub fn read_manifest(dir: &Path) -> Result<Manifest, DatasetError> {
    let path = dir.join(MANIFEST);
    let text = std::fs::read_to_string(&path).map_err(|e| io_err("dir", &path, e))?;
    parse_manifest(&text, dir)
}

/// Parses the text of `dir/manifest.json` (`dir` is where the shards are; the manifest's path
/// names the source in errors). Errors name the entry at fault.
pub fn parse_manifest(text: &str, dir: &Path) -> Result<Manifest, DatasetError> {
    let path = dir.join(MANIFEST);
    let fmt = |field: &str, reason: String| DatasetError::Format {
        path: path.clone(),
        field: field.into(),
        reason,
    };
    let v: serde_json::Value = serde_json::from_str(text).map_err(|e| fmt("manifest", e.to_string()))?;
    if v["format"] != FORMAT_NAME {
        return Err(fmt("format", format!("expected {FORMAT_NAME}, got {}", v["format"])));
    }
    if v["format_version"] != FORMAT_VERSION {
        return Err(fmt(
            "format_version",
            format!("expected {FORMAT_VERSION}, got {}", v["format_version"]),
        ));
    }
    let uint = |val: &serde_json::Value, field: &str| {
        val.as_u64()
            .ok_or_else(|| fmt(field, format!("expected an unsigned integer, got {val}")))
    };
    let mut shards = Vec::new();
    let list = v["shards"]
        .as_array()
        .ok_or_else(|| fmt("shards", "expected a list".into()))?;
    for (k, s) in list.iter().enumerate() {
        let file = s["file"]
            .as_str()
            .filter(|f| !f.contains('/') && !f.contains('\\') && !f.starts_with('.'))
            .ok_or_else(|| {
                fmt(
                    &format!("shards[{k}].file"),
                    format!("expected a file name, got {}", s["file"]),
                )
            })?;
        shards.push(ShardEntry {
            file: file.to_string(),
            first_index: uint(&s["first_index"], &format!("shards[{k}].first_index"))?,
            samples: uint(&s["samples"], &format!("shards[{k}].samples"))?,
        });
    }
    let steps = v["subgoal_steps"]
        .as_array()
        .ok_or_else(|| fmt("subgoal_steps", "expected a list".into()))?
        .iter()
        .map(|s| uint(s, "subgoal_steps").map(|s| s as usize))
        .collect::<Result<Vec<_>, _>>()?;
    let manifest = Manifest {
        dir: dir.to_path_buf(),
        samples: uint(&v["samples"], "samples")?,
        seed: uint(&v["seed"], "seed")?,
        shard_size: uint(&v["shard_size"], "shard_size")? as usize,
        subgoal_steps: steps,
        shards,
    };
    let total = manifest
        .shards
        .iter()
        .try_fold(0u64, |t, s| t.checked_add(s.samples))
        .ok_or_else(|| {
            fmt(
                "shards",
                "the shards' sample counts add up to more than 2^64 - 1".into(),
            )
        })?;
    if total != manifest.samples {
        return Err(fmt(
            "shards",
            format!("hold {total} samples, the manifest says {}", manifest.samples),
        ));
    }
    Ok(manifest)
}
