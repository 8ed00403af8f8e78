//! The DDPEN sub-goal dataset ([`subgoal_infer::dataset`]) from Python: `subgoal_generate_dataset`
//! and `subgoal_sample`, registered at the top level of `ddpkit._ddpkit` (so `_ddpkit.pyi`
//! describes them and stubtest checks them) and public as `ddpkit.subgoal.generate_dataset` and
//! `ddpkit.subgoal.sample` (`py/python/ddpkit/subgoal.py`, which also holds the pure-numpy
//! `load_shards`). Generation releases the GIL; every error is a `ddpkit.DdpError` naming the
//! argument.

use std::path::PathBuf;

use numpy::ndarray::{Array1, Array2};
use numpy::IntoPyArray;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use subgoal_infer::dataset::{
    write_dataset, DatasetError, DatasetParams, Generator, WriteOptions, MAP_CELLS, NUM_SUBGOALS,
};

use crate::errors::{invalid, CoreError};

/// A dataset error as a ddpkit error (`InvalidInputError` naming the argument).
fn ds(e: DatasetError) -> CoreError {
    let field = e.field();
    let reason = match &e {
        DatasetError::Invalid(subgoal_infer::Error::Invalid { reason, .. }) => reason.clone(),
        other => other.to_string(),
    };
    invalid(field, reason)
}

/// A non-negative integer argument that fits `u64`.
fn uint(field: &str, v: i128) -> Result<u64, CoreError> {
    u64::try_from(v).map_err(|_| invalid(field, format!("must be in 0..=2**64-1, got {v}")))
}

/// Generates ``samples`` samples of ``seed`` into ``out_dir`` as safetensors shards of
/// ``shard_size`` samples and a ``manifest.json`` (written last). ``threads=None`` uses every
/// core; the bytes do not depend on it. Returns ``{"dir", "samples", "shards", "manifest",
/// "seconds"}``. The GIL is released while generating.
#[pyfunction]
#[pyo3(signature = (out_dir, samples, seed = 0, shard_size = 5000, threads = None))]
fn subgoal_generate_dataset<'py>(
    py: Python<'py>,
    out_dir: PathBuf,
    samples: i128,
    seed: i128,
    shard_size: i128,
    threads: Option<i128>,
) -> PyResult<Bound<'py, PyDict>> {
    let samples = uint("samples", samples)?;
    let seed = uint("seed", seed)?;
    let shard_size =
        usize::try_from(uint("shard_size", shard_size)?).map_err(|_| invalid("shard_size", "too large"))?;
    let threads = match threads {
        None => None,
        Some(t) => Some(usize::try_from(uint("threads", t)?).map_err(|_| invalid("threads", "too large"))?),
    };
    let opts = WriteOptions {
        samples,
        seed,
        shard_size,
        threads,
        params: DatasetParams::default(),
    };
    let summary = py.detach(|| write_dataset(&out_dir, &opts, &|_| {})).map_err(ds)?;
    let out = PyDict::new(py);
    out.set_item("dir", summary.dir.to_string_lossy().into_owned())?;
    out.set_item("samples", summary.samples)?;
    let files: Vec<String> = summary.shards.iter().map(|s| s.file.clone()).collect();
    out.set_item("shards", PyList::new(py, files)?)?;
    out.set_item("manifest", summary.manifest.to_string_lossy().into_owned())?;
    out.set_item("seconds", summary.seconds)?;
    Ok(out)
}

/// Sample ``index`` of ``seed`` exactly as the dataset stores it: ``(costmap, goal, subgoals)``
/// with ``costmap`` ``uint8 (200, 200)`` indexed ``[iy, ix]``, ``goal`` ``float32 (2,)`` and
/// ``subgoals`` ``float32 (3, 2)`` in metres relative to the map centre.
#[pyfunction]
#[allow(clippy::type_complexity)]
fn subgoal_sample<'py>(
    py: Python<'py>,
    seed: i128,
    index: i128,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    let seed = uint("seed", seed)?;
    let index = uint("index", index)?;
    let s = py
        .detach(|| Generator::new(DatasetParams::default()).map(|mut g| g.sample(seed, index)))
        .map_err(|e| ds(DatasetError::Invalid(e)))?;
    let costmap = Array2::from_shape_vec((MAP_CELLS, MAP_CELLS), s.costmap.cells().to_vec())
        .map_err(|e| invalid("costmap", e.to_string()))?;
    let goal = Array1::from_vec(s.goal.to_vec());
    let subgoals = Array2::from_shape_vec((NUM_SUBGOALS, 2), s.subgoals.iter().flatten().copied().collect())
        .map_err(|e| invalid("subgoals", e.to_string()))?;
    Ok((
        costmap.into_pyarray(py).into_any(),
        goal.into_pyarray(py).into_any(),
        subgoals.into_pyarray(py).into_any(),
    ))
}

/// Registers the dataset functions in the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(subgoal_generate_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(subgoal_sample, m)?)?;
    m.add("SUBGOAL_MAP_CELLS", MAP_CELLS)?;
    Ok(())
}
