//! The dataset as independent tasks, one per shard, for executors beyond one process (the
//! `subgoal-dataset` binary runs them in order on every core; `python -m ddpkit.experiments
//! subgoal-dataset` runs them on local processes or a Ray cluster).
//!
//! | step | function | in | out |
//! |---|---|---|---|
//! | list | [`tasks`] | [`DatasetConfig`] | [`ShardTask`]s (shard, first sample, samples, seed, parameters) |
//! | run | [`run_task`] | one [`ShardTask`] | the shard file in `out_dir` and a [`ShardResult`] (size, digest) |
//! | aggregate | [`aggregate`] | the config and the results in task order | `manifest.json`, [`DatasetSummary`] |
//!
//! Sample `i` depends on `(seed, i)` only, so a shard's bytes do not depend on which worker, how
//! many threads or what order wrote it. Each shard is written whole or not at all, and writing
//! one removes `manifest.json` first: a directory holds a complete dataset exactly when it has a
//! manifest. Workers write the shards into `out_dir` themselves, so on a cluster `out_dir` must
//! be a file system every worker reaches.
//!
//! ```
//! use subgoal_infer::dataset::sweep::{aggregate, run_task, tasks, DatasetConfig};
//! let dir = std::env::temp_dir().join(format!("sweep-doc-{}", std::process::id()));
//! let config = DatasetConfig { samples: 3, shard_size: 2, ..DatasetConfig::new(&dir) };
//! let results = tasks(&config)?.iter().map(run_task).collect::<Result<Vec<_>, _>>()?;
//! assert_eq!(results.len(), 2);
//! assert_eq!(aggregate(&config, &results)?.samples, 3);
//! # std::fs::remove_dir_all(&dir).ok();
//! # Ok::<(), subgoal_infer::dataset::DatasetError>(())
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::shards::{
    fill, io_err, params_json, remove_stale_shards, shard_file_name, thread_pool, write_shard, Pool, FRAME, MANIFEST,
    MAX_SHARD_SIZE,
};
use super::{
    DatasetError, DatasetParams, DatasetSummary, Generator, SampleInfo, ShardEntry, WriteOptions, FORMAT_NAME,
    FORMAT_VERSION, MAP_CELLS, MAP_LEN, RESOLUTION,
};
use crate::error::Error;

fn default_shard_size() -> usize {
    5000
}

/// What a dataset sweep generates (the binary's options; `seed`, `shard_size` and `params` have
/// the binary's defaults when missing from JSON).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetConfig {
    /// Output directory (created if missing).
    pub out_dir: PathBuf,
    /// Number of samples (at least 1).
    pub samples: u64,
    /// Seed: sample `i` is a function of `(seed, i)` only.
    #[serde(default)]
    pub seed: u64,
    /// Samples per shard, `1..=50000`.
    #[serde(default = "default_shard_size")]
    pub shard_size: usize,
    /// Generator parameters.
    #[serde(default)]
    pub params: DatasetParams,
}

impl DatasetConfig {
    /// One sample of seed 0 into `out_dir`, shards of 5000, default parameters.
    pub fn new(out_dir: &Path) -> Self {
        Self {
            out_dir: out_dir.to_path_buf(),
            samples: 1,
            seed: 0,
            shard_size: default_shard_size(),
            params: DatasetParams::default(),
        }
    }

    /// The configuration [`super::write_dataset`] runs for `opts`.
    pub fn from_options(out_dir: &Path, opts: &WriteOptions) -> Self {
        Self {
            out_dir: out_dir.to_path_buf(),
            samples: opts.samples,
            seed: opts.seed,
            shard_size: opts.shard_size,
            params: opts.params.clone(),
        }
    }

    fn options(&self) -> WriteOptions {
        WriteOptions {
            samples: self.samples,
            seed: self.seed,
            shard_size: self.shard_size,
            threads: None,
            params: self.params.clone(),
        }
    }

    fn shards(&self) -> usize {
        self.samples.div_ceil(self.shard_size as u64) as usize
    }
}

/// One shard: everything its bytes depend on, and where it goes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardTask {
    /// The dataset directory.
    pub out_dir: PathBuf,
    /// Shard number (`shard-NNNNN.safetensors`).
    pub shard: usize,
    /// Index of its first sample.
    pub first_index: u64,
    /// Samples in it.
    pub samples: u64,
    /// Dataset seed.
    pub seed: u64,
    /// Generator parameters.
    pub params: DatasetParams,
}

/// What writing a shard produced.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShardResult {
    /// File name inside the dataset directory.
    pub file: String,
    /// Index of its first sample.
    pub first_index: u64,
    /// Samples in it.
    pub samples: u64,
    /// File size (bytes).
    pub bytes: u64,
    /// 64-bit FNV-1a of the file's bytes, hex.
    pub fnv1a64: String,
}

/// The shards of `config`, in order.
pub fn tasks(config: &DatasetConfig) -> Result<Vec<ShardTask>, DatasetError> {
    config.options().validate()?;
    Ok((0..config.shards())
        .map(|k| {
            let first = k as u64 * config.shard_size as u64;
            ShardTask {
                out_dir: config.out_dir.clone(),
                shard: k,
                first_index: first,
                samples: (config.samples - first).min(config.shard_size as u64),
                seed: config.seed,
                params: config.params.clone(),
            }
        })
        .collect())
}

/// Writes shards with one generator and one thread pool (what [`super::write_dataset`] and
/// [`run_task_with`] share).
pub struct ShardWriter {
    params: DatasetParams,
    proto: Generator,
    pool: Pool,
}

impl ShardWriter {
    /// A writer for `params` on `threads` threads (`None`: rayon's global pool, which follows
    /// `RAYON_NUM_THREADS`). Allocates the generator's buffers.
    pub fn new(params: &DatasetParams, threads: Option<usize>) -> Result<Self, DatasetError> {
        params.validate()?;
        Ok(Self {
            params: params.clone(),
            proto: Generator::new(params.clone())?,
            pool: thread_pool(threads)?,
        })
    }

    /// Generates and writes the shard of `task` (its parameters must be the writer's).
    /// `progress(k)` is called as `k` more samples are done.
    pub fn write(&self, task: &ShardTask, progress: &(dyn Fn(u64) + Sync)) -> Result<ShardResult, DatasetError> {
        if task.params != self.params {
            return Err(Error::invalid("params", "differ from the writer's").into());
        }
        if task.samples == 0 || task.samples > MAX_SHARD_SIZE as u64 {
            return Err(Error::invalid(
                "samples",
                format!("must be in 1..={MAX_SHARD_SIZE}, got {}", task.samples),
            )
            .into());
        }
        if task.first_index.checked_add(task.samples).is_none() {
            return Err(Error::invalid("first_index", "first_index + samples overflows").into());
        }
        let dir = &task.out_dir;
        std::fs::create_dir_all(dir).map_err(|e| io_err("out_dir", dir, e))?;
        // The dataset is no longer the one the manifest describes.
        let manifest = dir.join(MANIFEST);
        match std::fs::remove_file(&manifest) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(io_err("out_dir", &manifest, e)),
        }
        let n = task.samples as usize;
        let mut costmaps = vec![0u8; n * MAP_LEN];
        let mut infos = vec![SampleInfo::default(); n];
        fill(
            &self.pool,
            &self.proto,
            task.seed,
            task.first_index,
            &mut costmaps,
            &mut infos,
            progress,
        );
        let file = shard_file_name(task.shard);
        let (bytes, hash) = write_shard(
            &dir.join(&file),
            task.seed,
            &task.params,
            task.first_index,
            &costmaps,
            &infos,
        )?;
        Ok(ShardResult {
            file,
            first_index: task.first_index,
            samples: task.samples,
            bytes,
            fnv1a64: format!("{hash:016x}"),
        })
    }
}

/// Writes the shard of `task` on rayon's global pool (one thread under `RAYON_NUM_THREADS=1`).
pub fn run_task(task: &ShardTask) -> Result<ShardResult, DatasetError> {
    run_task_with(task, None, &|_| {})
}

/// [`run_task`] on `threads` threads with a progress callback.
pub fn run_task_with(
    task: &ShardTask,
    threads: Option<usize>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<ShardResult, DatasetError> {
    ShardWriter::new(&task.params, threads)?.write(task, progress)
}

/// Checks that every shard of `config` is on disk as `results` (in task order) describe it,
/// deletes shards of this naming beyond the dataset, and writes `manifest.json` (last).
pub fn aggregate(config: &DatasetConfig, results: &[ShardResult]) -> Result<DatasetSummary, DatasetError> {
    let tasks = tasks(config)?;
    if results.len() != tasks.len() {
        return Err(Error::invalid(
            "results",
            format!(
                "the configuration has {} shards, got {} results",
                tasks.len(),
                results.len()
            ),
        )
        .into());
    }
    let dir = &config.out_dir;
    let mut shards = Vec::with_capacity(tasks.len());
    for (k, (t, r)) in tasks.iter().zip(results).enumerate() {
        let file = shard_file_name(t.shard);
        if r.file != file || r.first_index != t.first_index || r.samples != t.samples {
            return Err(Error::invalid(
                format!("results[{k}]"),
                format!(
                    "describes {} ({} samples from {}), expected {file}",
                    r.file, r.samples, r.first_index
                ),
            )
            .into());
        }
        let path = dir.join(&file);
        let len = std::fs::metadata(&path).map_err(|e| io_err("out_dir", &path, e))?.len();
        if len != r.bytes {
            return Err(io_err(
                "out_dir",
                &path,
                format!("has {len} bytes, its task wrote {}", r.bytes),
            ));
        }
        shards.push(ShardEntry {
            file,
            first_index: t.first_index,
            samples: t.samples,
        });
    }
    remove_stale_shards(dir, shards.len())?;
    let manifest_path = dir.join(MANIFEST);
    let manifest = serde_json::json!({
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "samples": config.samples,
        "seed": config.seed,
        "shard_size": config.shard_size,
        "resolution": RESOLUTION,
        "map_cells": MAP_CELLS,
        "subgoal_steps": config.params.subgoal_steps,
        "frame": FRAME,
        "params": params_json(&config.params),
        "shards": shards.iter().map(|s| serde_json::json!({
            "file": s.file, "first_index": s.first_index, "samples": s.samples,
        })).collect::<Vec<_>>(),
    });
    let text = serde_json::to_string_pretty(&manifest).map_err(|e| io_err("out_dir", &manifest_path, e))?;
    ddpkit_util::fs::write_atomic(&manifest_path, text).map_err(|e| io_err("out_dir", &manifest_path, e))?;
    Ok(DatasetSummary {
        dir: dir.clone(),
        samples: config.samples,
        shards,
        manifest: manifest_path,
        seconds: 0.0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_cover_the_samples_and_bad_results_are_named() {
        let dir = std::env::temp_dir().join(format!("sweep-test-{}", std::process::id()));
        let config = DatasetConfig {
            samples: 5,
            shard_size: 2,
            ..DatasetConfig::new(&dir)
        };
        let t = tasks(&config).unwrap();
        assert_eq!(t.iter().map(|t| t.samples).collect::<Vec<_>>(), [2, 2, 1]);
        assert_eq!(t[2].first_index, 4);
        let e = aggregate(&config, &[]).unwrap_err();
        assert_eq!(e.field(), "results");
        let json: DatasetConfig = serde_json::from_str(&format!("{{\"out_dir\": {:?}, \"samples\": 5}}", dir)).unwrap();
        assert_eq!(json.shard_size, 5000);
        assert!(serde_json::from_str::<DatasetConfig>("{\"out_dir\": \"x\", \"samples\": 5, \"sample\": 1}").is_err());
    }
}
