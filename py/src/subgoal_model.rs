//! `SubgoalModel`: the DDPEN sub-goal network run by [`subgoal_infer::SubgoalModel`] (Rust
//! inference from the safetensors file `ddpkit.subgoal_model.export` writes; no torch).
//!
//! The class is registered at the top level of `ddpkit._ddpkit` (so `_ddpkit.pyi` describes it
//! and stubtest checks it) and re-exported as `ddpkit.subgoal.SubgoalModel`. Predictions release
//! the GIL; every error is a `ddpkit.DdpError` naming the argument, the tensor or the metadata field.

use std::path::PathBuf;
use std::sync::Arc;

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use subgoal_infer::{Error as SgError, SubgoalModel as Model};

use crate::convert::{finite_arr, shape_str};
use crate::errors::{invalid, shape, CoreError};

/// A `subgoal_infer` error as a ddpkit error (`InvalidInputError` naming the field or tensor).
fn sg(e: SgError) -> CoreError {
    match e {
        SgError::Invalid { field, reason } => invalid(field, reason),
        SgError::Geometry { field, got, expected } => shape(field, got, expected),
        #[allow(unreachable_patterns)]
        other => invalid("subgoal_model", other.to_string()),
    }
}

/// `(n, side, side)` or `(side, side)` uint8 costmaps, copied out in C order.
fn costmaps(obj: &Bound<'_, PyAny>, side: usize) -> PyResult<(Vec<u8>, Vec<usize>)> {
    let arr: PyReadonlyArrayDyn<'_, u8> = obj.extract().map_err(|_| {
        let dtype = obj
            .getattr("dtype")
            .map(|d| d.to_string())
            .unwrap_or_else(|_| obj.get_type().to_string());
        PyErr::from(invalid("costmap", format!("must be a numpy uint8 array, got {dtype}")))
    })?;
    let dims = arr.shape().to_vec();
    if dims.len() < 2 || dims[dims.len() - 2..] != [side, side] {
        return Err(shape(
            "costmap",
            shape_str(&dims),
            format!("(..., {side}, {side}) with row index iy and column index ix"),
        )
        .into());
    }
    let data: Vec<u8> = arr.as_array().iter().copied().collect();
    Ok((data, dims))
}

/// The sub-goal network of DDPEN (Gamayunov et al. 2023), running in Rust.
#[pyclass(module = "ddpkit._ddpkit", name = "SubgoalModel", frozen)]
pub struct SubgoalModel {
    inner: Arc<Model>,
}

#[pymethods]
impl SubgoalModel {
    /// Loads the safetensors file at `path` (written by ``python -m ddpkit.train subgoal``).
    #[new]
    fn new(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let model = py.detach(|| Model::load(&path)).map_err(sg)?;
        Ok(Self { inner: Arc::new(model) })
    }

    /// The model shipped with ddpkit (the small CNN; see ``crates/subgoal-infer/README.md``).
    #[staticmethod]
    fn default() -> PyResult<Self> {
        Ok(Self {
            inner: Arc::new(Model::default_model().map_err(sg)?),
        })
    }

    /// A model from the bytes of a safetensors file.
    #[staticmethod]
    fn from_bytes(data: &[u8]) -> PyResult<Self> {
        let model = Model::from_safetensors(data).map_err(sg)?;
        Ok(Self { inner: Arc::new(model) })
    }

    /// Number of sub-goals per prediction.
    #[getter]
    fn num_subgoals(&self) -> usize {
        self.inner.num_subgoals()
    }

    /// The encoder: ``"cnn"`` or ``"efficientnet"``.
    #[getter]
    fn arch(&self) -> &'static str {
        match self.inner.config().arch {
            subgoal_infer::model::Arch::Cnn => "cnn",
            subgoal_infer::model::Arch::Efficientnet => "efficientnet",
        }
    }

    /// Side of the square input costmap in cells (200).
    #[getter]
    fn in_size(&self) -> usize {
        self.inner.config().in_size
    }

    /// Sub-goals for one costmap (uint8 ``(200, 200)``, row ``iy``, column ``ix``, as the dataset
    /// and ``Costmap.cells`` lay them out) and a goal ``(x, y)`` in metres relative to the map
    /// centre; returns ``(num_subgoals, 2)`` float64 metres in the same frame. A stack of
    /// costmaps ``(n, 200, 200)`` with goals ``(n, 2)`` gives ``(n, num_subgoals, 2)``.
    fn predict<'py>(
        &self,
        py: Python<'py>,
        costmap: &Bound<'py, PyAny>,
        goal: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let side = self.inner.config().in_size;
        let (cells, dims) = costmaps(costmap, side)?;
        let batch: Vec<usize> = dims[..dims.len() - 2].to_vec();
        if batch.len() > 1 {
            return Err(shape(
                "costmap",
                shape_str(&dims),
                format!("({side}, {side}) or (n, {side}, {side})"),
            )
            .into());
        }
        let n = batch.first().copied().unwrap_or(1);
        let g = finite_arr(goal, "goal")?;
        let want_goal: Vec<usize> = batch.iter().copied().chain([2]).collect();
        g.expect_shape("goal", &want_goal)?;
        let model = self.inner.clone();
        let s = model.num_subgoals();
        let out: Result<Vec<f64>, SgError> = py.detach(move || {
            let mut out = Vec::with_capacity(n * s * 2);
            for (i, map) in cells.chunks_exact(side * side).enumerate() {
                let goal = [g.data[2 * i] as f32, g.data[2 * i + 1] as f32];
                for p in model.predict(map, goal)? {
                    out.extend([p[0] as f64, p[1] as f64]);
                }
            }
            Ok(out)
        });
        let out = out.map_err(sg)?;
        let arr = Array3::from_shape_vec((n, s, 2), out).map_err(|e| invalid("predict", e.to_string()))?;
        let arr = arr.into_pyarray(py);
        if batch.is_empty() {
            Ok(arr.reshape([s, 2])?.into_any())
        } else {
            Ok(arr.into_any())
        }
    }

    fn __repr__(&self) -> String {
        let c = self.inner.config();
        format!(
            "SubgoalModel(arch={:?}, d_model={}, num_layers={}, num_subgoals={})",
            self.arch(),
            c.d_model,
            c.num_layers,
            c.num_subgoals
        )
    }
}

/// Registers `SubgoalModel` in the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<SubgoalModel>()?;
    Ok(())
}
