//! Models the user brings from Python: traced functions, CasADi SX functions and saved tapes
//! (all as `ddp_tape` tapes, evaluated in Rust with exact derivatives), and plain callables (the
//! slow path, see [`crate::callable`]).
//!
//! | Python | Rust |
//! |---|---|
//! | `Dynamics.from_function`, `Dynamics.from_casadi` -> `TapeDynamics` | `ddp_tape::TapeDynamics` |
//! | `Cost.from_function`, `Cost.from_casadi` -> `TapeCost` | `ddp_tape::TapeCost`, `ddp_tape::TapeTerminal` |
//! | `Constraint.from_function`, `Constraint.from_casadi` -> `TapeConstraint` | `ddp_tape::TapeConstraint` |
//! | `load_model`, `model_from_json` | `ddp_tape::TapeModel::load`, `from_json` |
//!
//! Tracing and reading CasADi's instruction list happen in Python (`ddpkit.trace`), which hands
//! over the tape file's JSON document; Rust checks it exactly as it checks a file.

use std::sync::Arc;

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, Dyn};
use ddp_tape::{discretize, Integrator, TapeModel};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::convert::{finite_arr, matrix_to_numpy, vector_to_numpy};
use crate::costs::{Cost, CostSpec};
use crate::dims::{model_size, Dispatch, Pair};
use crate::errors::{invalid, CoreError, CoreResult};
use crate::models::Dynamics;
use crate::safe::Constraint;

/// The JSON document of `f` traced as `kind` (by `ddpkit.trace.trace_json`).
fn trace(py: Python<'_>, f: &Bound<'_, PyAny>, kind: &str, nx: usize, nu: Option<usize>) -> PyResult<String> {
    py.import("ddpkit.trace")?
        .call_method1("trace_json", (f, kind, nx, nu))?
        .extract()
}

/// `(document, nx, nu)` of the CasADi function `f` read as `kind` (by `ddpkit.trace.from_casadi_json`).
fn casadi(py: Python<'_>, f: &Bound<'_, PyAny>, kind: &str) -> PyResult<(String, usize, Option<usize>)> {
    py.import("ddpkit.trace")?
        .call_method1("from_casadi_json", (f, kind))?
        .extract()
}

fn load(text: &str) -> CoreResult<TapeModel> {
    TapeModel::from_json(text).map_err(CoreError)
}

/// A continuous model `xdot = F(x, u)` made discrete by `integrator` over `dt`; `dt = None` keeps
/// a discrete model as it is.
fn integrate(model: TapeModel, dt: Option<f64>, integrator: &str) -> CoreResult<TapeModel> {
    let Some(dt) = dt else {
        if integrator != "rk4" && integrator != "discrete" {
            return Err(invalid(
                "integrator",
                format!("'{integrator}' needs dt (the step of the continuous model)"),
            ));
        }
        return Ok(model);
    };
    let method = Integrator::from_name(integrator)?;
    match &model {
        TapeModel::Dynamics(d) => {
            let (nx, nu) = d.dims();
            let tape = discretize(d.tape(), nx, nu, dt, method)?;
            Ok(TapeModel::Dynamics(ddp_tape::TapeDynamics::new(tape, nx, nu)?))
        }
        _ => Err(crate::convert::internal("only dynamics are integrated".into())),
    }
}

fn wrap_dynamics<NX: Dim, NU: Dim>(d: &ddp_tape::TapeDynamics) -> CoreResult<Dynamics>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    Dynamics::of::<NX, NU>(d.clone())
}

/// The Python object of a tape model: `TapeDynamics`, `TapeCost` or `TapeConstraint`.
pub fn to_python(py: Python<'_>, model: TapeModel) -> PyResult<Py<PyAny>> {
    let model = Arc::new(model);
    Ok(match &*model {
        TapeModel::Dynamics(d) => {
            let (nx, nu) = d.dims();
            let base: Dynamics = with_dims!(nx, nu, wrap_dynamics(d))?;
            Py::new(
                py,
                PyClassInitializer::from(base).add_subclass(TapeDynamics { model: model.clone() }),
            )?
            .into_any()
        }
        TapeModel::Cost(_) | TapeModel::Terminal(_) => {
            let base = Cost {
                spec: Arc::new(CostSpec::Tape(model.clone())),
            };
            Py::new(
                py,
                PyClassInitializer::from(base).add_subclass(TapeCost { model: model.clone() }),
            )?
            .into_any()
        }
        TapeModel::Constraint(_) => {
            let base = crate::safe::tape_constraint(model.clone());
            Py::new(
                py,
                PyClassInitializer::from(base).add_subclass(TapeConstraint { model: model.clone() }),
            )?
            .into_any()
        }
    })
}

/// `Dynamics.from_function`.
pub fn dynamics_from_function(
    py: Python<'_>,
    f: &Bound<'_, PyAny>,
    nx: i64,
    nu: i64,
    dt: Option<f64>,
    integrator: &str,
) -> PyResult<Py<PyAny>> {
    let (nx, nu) = (model_size(nx, "nx")?, model_size(nu, "nu")?);
    let model = load(&trace(py, f, "dynamics", nx, Some(nu))?)?;
    to_python(py, integrate(model, dt, integrator)?)
}

/// `Dynamics.from_casadi`.
pub fn dynamics_from_casadi(
    py: Python<'_>,
    f: &Bound<'_, PyAny>,
    dt: Option<f64>,
    integrator: &str,
) -> PyResult<Py<PyAny>> {
    let (doc, _, _) = casadi(py, f, "dynamics")?;
    to_python(py, integrate(load(&doc)?, dt, integrator)?)
}

/// `Cost.from_function`: running `l(x, u)`, or terminal `l(x)` where `nu` is `None`.
pub fn cost_from_function(py: Python<'_>, f: &Bound<'_, PyAny>, nx: i64, nu: Option<i64>) -> PyResult<Py<PyAny>> {
    let nx = model_size(nx, "nx")?;
    let (kind, nu) = match nu {
        Some(nu) => ("cost", Some(model_size(nu, "nu")?)),
        None => ("terminal_cost", None),
    };
    to_python(py, load(&trace(py, f, kind, nx, nu)?)?)
}

/// `Cost.from_casadi`.
pub fn cost_from_casadi(py: Python<'_>, f: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
    let (doc, _, _) = casadi(py, f, "cost")?;
    to_python(py, load(&doc)?)
}

/// `Constraint.from_function`: `g(x, u)`, or `g(x)` where `nu` is `None`.
pub fn constraint_from_function(py: Python<'_>, f: &Bound<'_, PyAny>, nx: i64, nu: Option<i64>) -> PyResult<Py<PyAny>> {
    let nx = model_size(nx, "nx")?;
    let nu = nu.map(|n| model_size(n, "nu")).transpose()?;
    to_python(py, load(&trace(py, f, "constraint", nx, nu)?)?)
}

/// `Constraint.from_casadi`.
pub fn constraint_from_casadi(py: Python<'_>, f: &Bound<'_, PyAny>) -> PyResult<Py<PyAny>> {
    let (doc, _, _) = casadi(py, f, "constraint")?;
    to_python(py, load(&doc)?)
}

/// Loads a model saved by `save` (or by `ddp_tape::TapeModel::save` in Rust): a
/// `TapeDynamics`, `TapeCost` or `TapeConstraint` as the file says.
#[pyfunction]
pub fn load_model(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Py<PyAny>> {
    let model = py.detach(|| TapeModel::load(&path)).map_err(CoreError)?;
    to_python(py, model)
}

/// The model of a tape document (the text `to_json` returns); used by pickling.
#[pyfunction]
pub fn model_from_json(py: Python<'_>, text: &str) -> PyResult<Py<PyAny>> {
    to_python(py, load(text)?)
}

/// Methods shared by the three tape classes.
macro_rules! tape_methods {
    ($ty:ident $(, { $($extra:tt)* })?) => {
        #[pymethods]
        impl $ty {
            $($($extra)*)?

            /// The tape's JSON document (the file format of `save`).
            fn to_json(&self) -> String {
                self.model.to_json(None)
            }

            /// Writes the model to `path` (JSON, whole or not at all); `ddpkit.load_model` and
            /// `ddp_tape::TapeModel::load` in Rust read it back.
            fn save(&self, py: Python<'_>, path: std::path::PathBuf) -> PyResult<()> {
                let model = self.model.clone();
                Ok(py.detach(|| model.save(&path, None)).map_err(CoreError)?)
            }

            /// Number of nodes of the tape (after sharing and folding).
            #[getter]
            fn n_nodes(&self) -> usize {
                self.model.tape().nodes().len()
            }

            /// `"dynamics"`, `"cost"`, `"terminal_cost"` or `"constraint"`.
            #[getter]
            fn kind(&self) -> &'static str {
                self.model.kind()
            }

            fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
                let f = py.import("ddpkit._ddpkit")?.getattr("model_from_json")?;
                Ok((f, PyTuple::new(py, [self.model.to_json(None)])?))
            }

            fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
                other
                    .cast::<$ty>()
                    .map(|o| *o.get().model == *self.model)
                    .unwrap_or(false)
            }

            fn __repr__(&self) -> String {
                let (nx, nu) = self.model.dims();
                let nu = nu.map_or("None".to_string(), |n| n.to_string());
                format!(
                    "{}(kind='{}', nx={nx}, nu={nu}, nodes={})",
                    stringify!($ty),
                    self.model.kind(),
                    self.model.tape().nodes().len()
                )
            }
        }
    };
}

/// Dynamics from a tape: a traced function (`Dynamics.from_function`), a CasADi SX function
/// (`Dynamics.from_casadi`) or a saved file (`load_model`). Exact first and second derivatives.
#[pyclass(module = "ddpkit._ddpkit", extends = Dynamics, frozen)]
pub struct TapeDynamics {
    model: Arc<TapeModel>,
}

/// A running cost `l(x, u)` or terminal cost `l(x)` from a tape (`Cost.from_function`,
/// `Cost.from_casadi`, `load_model`).
#[pyclass(module = "ddpkit._ddpkit", extends = Cost, frozen)]
pub struct TapeCost {
    model: Arc<TapeModel>,
}

/// Constraints `g(x, u) <= 0` from a tape (`Constraint.from_function`, `Constraint.from_casadi`,
/// `load_model`); rows that do not depend on `u` are state-only (imposed on `x_1 .. x_N`).
#[pyclass(module = "ddpkit._ddpkit", extends = Constraint, frozen)]
pub struct TapeConstraint {
    model: Arc<TapeModel>,
}

tape_methods!(TapeDynamics, {
    /// The contracted second derivatives `sum_i lam_i d^2 f_i` at `(x, u)` as the blocks
    /// `(h_xx, h_ux, h_uu)`, shapes `(nx, nx)`, `(nu, nx)`, `(nu, nu)` (what full DDP uses).
    fn second_order<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
        u: &Bound<'py, PyAny>,
        lam: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let TapeModel::Dynamics(d) = &*self.model else {
            return Err(crate::convert::internal("not dynamics".into()).into());
        };
        let (nx, nu) = d.dims();
        let x = finite_arr(x, "x")?.vector("x", Dyn(nx))?;
        let u = finite_arr(u, "u")?.vector("u", Dyn(nu))?;
        let lam = finite_arr(lam, "lam")?.vector("lam", Dyn(nx))?;
        let s = ddp_core::Dims::<Dyn, Dyn>::new("dynamics", nx, nu).map_err(CoreError)?;
        let (mut a, mut b, mut c) = (s.xx_zeros(), s.ux_zeros(), s.uu_zeros());
        ddp_core::Dynamics::<Dyn, Dyn>::add_second_order(d, &x, &u, &lam, &mut a, &mut b, &mut c);
        Ok((
            matrix_to_numpy(py, &a)?,
            matrix_to_numpy(py, &b)?,
            matrix_to_numpy(py, &c)?,
        ))
    }
});
tape_methods!(TapeCost, {
    /// `(l, l_x, l_u, l_xx, l_uu, l_ux)` at `(x, u)` (exact); for a terminal cost `u` is
    /// omitted and `l_u`, `l_uu`, `l_ux` are None.
    #[pyo3(signature = (x, u = None))]
    #[allow(clippy::type_complexity)]
    fn derivatives<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
        u: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<(
        f64,
        Bound<'py, PyAny>,
        Option<Bound<'py, PyAny>>,
        Bound<'py, PyAny>,
        Option<Bound<'py, PyAny>>,
        Option<Bound<'py, PyAny>>,
    )> {
        match &*self.model {
            TapeModel::Cost(c) => {
                let (nx, nu) = c.dims();
                let u = u.ok_or_else(|| invalid("u", "a running cost needs u"))?;
                let x = finite_arr(x, "x")?.vector("x", Dyn(nx))?;
                let u = finite_arr(u, "u")?.vector("u", Dyn(nu))?;
                let s = ddp_core::Dims::<Dyn, Dyn>::new("cost", nx, nu).map_err(CoreError)?;
                let mut d = ddp_core::CostDerivatives::zeros(s);
                let v = ddp_core::Cost::<Dyn, Dyn>::add_derivatives(c, &x, &u, 1.0, &mut d);
                Ok((
                    v,
                    vector_to_numpy(py, &d.lx),
                    Some(vector_to_numpy(py, &d.lu)),
                    matrix_to_numpy(py, &d.lxx)?,
                    Some(matrix_to_numpy(py, &d.luu)?),
                    Some(matrix_to_numpy(py, &d.lux)?),
                ))
            }
            TapeModel::Terminal(c) => {
                let x = finite_arr(x, "x")?.vector("x", Dyn(c.nx()))?;
                let mut d = ddp_core::TerminalDerivatives::zeros(Dyn(c.nx()));
                let v = ddp_core::TerminalCost::<Dyn>::add_derivatives(c, &x, 1.0, &mut d);
                Ok((
                    v,
                    vector_to_numpy(py, &d.lx),
                    None,
                    matrix_to_numpy(py, &d.lxx)?,
                    None,
                    None,
                ))
            }
            _ => Err(crate::convert::internal("not a cost".into()).into()),
        }
    }
});
tape_methods!(TapeConstraint, {
    /// `(g, g_x, g_u)` at `(x, u)`: shapes `(m,)`, `(m, nx)`, `(m, nu)` (`u` may be omitted for a
    /// constraint of `x` alone; `g_u` then has no columns).
    #[pyo3(signature = (x, u = None))]
    fn jacobians<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
        u: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let TapeModel::Constraint(c) = &*self.model else {
            return Err(crate::convert::internal("not a constraint".into()).into());
        };
        let (nx, nu) = c.dims();
        let x = finite_arr(x, "x")?.vector("x", Dyn(nx))?;
        let u = match (u, nu) {
            (Some(u), Some(n)) => finite_arr(u, "u")?.vector("u", Dyn(n))?,
            (None, Some(_)) => return Err(invalid("u", "this constraint depends on (x, u): pass u").into()),
            (Some(u), None) => finite_arr(u, "u")?.vector("u", Dyn(finite_arr(u, "u")?.data.len()))?,
            (None, None) => ddp_core::dims::VectorN::<Dyn>::zeros_generic(Dyn(0), nalgebra::U1),
        };
        let m = self.model.tape().n_outputs();
        let mut g = vec![0.0; m];
        let mut gx = vec![ddp_core::dims::VectorN::<Dyn>::zeros_generic(Dyn(nx), nalgebra::U1); m];
        let mut gu = vec![ddp_core::dims::VectorN::<Dyn>::zeros_generic(Dyn(u.len()), nalgebra::U1); m];
        safe_cddp::Constraint::<Dyn, Dyn>::jacobians(c, 0, &x, &u, &mut g, &mut gx, &mut gu);
        let flat = |v: &[ddp_core::dims::VectorN<Dyn>]| v.iter().flat_map(|r| r.iter().copied()).collect::<Vec<f64>>();
        Ok((
            crate::convert::vec_to_numpy(py, g),
            crate::convert::rows_to_numpy(py, m, nx, flat(&gx))?,
            crate::convert::rows_to_numpy(py, m, u.len(), flat(&gu))?,
        ))
    }

    /// Number of rows.
    #[getter]
    fn dim(&self) -> usize {
        self.model.tape().n_outputs()
    }

    /// Whether some row depends on the control (else every row is state-only).
    #[getter]
    fn depends_on_control(&self) -> bool {
        match &*self.model {
            TapeModel::Constraint(c) => {
                <ddp_tape::TapeConstraint as safe_cddp::Constraint<Dyn, Dyn>>::depends_on_control(c)
            }
            _ => false,
        }
    }
});

/// Registers the classes and functions.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<TapeDynamics>()?;
    m.add_class::<TapeCost>()?;
    m.add_class::<TapeConstraint>()?;
    m.add_function(wrap_pyfunction!(load_model, m)?)?;
    m.add_function(wrap_pyfunction!(model_from_json, m)?)?;
    Ok(())
}
