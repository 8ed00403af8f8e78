//! Plain Python callables as models: the documented slow path for what cannot be traced (a
//! lookup table, a torch network).
//!
//! Every evaluation takes the GIL and calls Python, so a solve runs at Python speed; derivatives
//! the user does not give are central finite differences (step `eps^(1/3) (1 + |z_i|)` for
//! first derivatives, `eps^(1/4) (1 + |z_i|)` for a cost's Hessian). The model traits cannot
//! fail, so the first exception a callable raises is kept for the calling thread, every later
//! evaluation returns NaN without calling Python (the solve then stops with a numerical
//! failure), and the binding that started the solve raises that exception ([`take_error`]).

use std::cell::RefCell;
use std::sync::Arc;

use ddp_core::dims::{Alloc, DefaultAllocator, Dim, MatrixN, VectorN};
use ddp_core::{Cost as CoreCost, CostDerivatives, TerminalCost as CoreTerminalCost, TerminalDerivatives};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

use crate::convert::{to_arr, vec_to_numpy};
use crate::costs::{Cost, CostSpec};
use crate::dims::{model_size, Dispatch, Pair};
use crate::errors::{invalid, CoreResult};
use crate::models::Dynamics;

thread_local! {
    static PENDING: RefCell<Option<PyErr>> = const { RefCell::new(None) };
}

/// The exception a callable raised on this thread since the last call, if any.
pub fn take_error() -> Option<PyErr> {
    PENDING.with(|p| p.borrow_mut().take())
}

/// `Err` with the pending exception, for bindings to call after a solve or evaluation.
pub fn raise_pending() -> PyResult<()> {
    match take_error() {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

fn pending() -> bool {
    PENDING.with(|p| p.borrow().is_some())
}

fn keep(e: PyErr) {
    PENDING.with(|p| {
        let mut p = p.borrow_mut();
        if p.is_none() {
            *p = Some(e);
        }
    });
}

/// Calls `f(x)` or `f(x, u)` and writes the `out.len()` numbers it returns; NaN (and the
/// exception kept) on failure.
fn call(f: &Py<PyAny>, name: &str, x: &[f64], u: Option<&[f64]>, out: &mut [f64]) {
    if pending() {
        out.fill(f64::NAN);
        return;
    }
    let r = Python::attach(|py| -> PyResult<()> {
        let xa = vec_to_numpy(py, x.to_vec());
        let res = match u {
            Some(u) => f.call1(py, (xa, vec_to_numpy(py, u.to_vec())))?,
            None => f.call1(py, (xa,))?,
        };
        let a = to_arr(res.bind(py), name)?;
        if a.data.len() != out.len() {
            return Err(crate::errors::shape(
                name,
                crate::convert::shape_str(&a.shape),
                format!("{} values", out.len()),
            )
            .into());
        }
        out.copy_from_slice(&a.data);
        Ok(())
    });
    if let Err(e) = r {
        keep(e);
        out.fill(f64::NAN);
    }
}

fn step_size(z: f64, power: f64) -> f64 {
    f64::EPSILON.powf(power) * (1.0 + z.abs())
}

/// A Python function shared by the clones of one model.
#[derive(Debug)]
struct PyFn {
    f: Py<PyAny>,
    jac: Option<Py<PyAny>>,
    name: String,
}

/// Dynamics `x+ = f(x, u)` of a Python callable.
#[derive(Debug, Clone)]
pub struct CallableDynamics {
    inner: Arc<PyFn>,
    nx: usize,
    nu: usize,
}

impl CallableDynamics {
    fn eval(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        call(&self.inner.f, &self.inner.name, x, Some(u), out)
    }
}

impl<NX: Dim, NU: Dim> ddp_core::Dynamics<NX, NU> for CallableDynamics
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn step(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> VectorN<NX> {
        let mut out = VectorN::<NX>::zeros_generic(x.shape_generic().0, nalgebra::U1);
        self.eval(x.as_slice(), u.as_slice(), out.as_mut_slice());
        out
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (Some(self.nx), Some(self.nu))
    }
    fn jacobians(&self, x: &VectorN<NX>, u: &VectorN<NU>, fx: &mut MatrixN<NX, NX>, fu: &mut MatrixN<NX, NU>) {
        let (nx, nu) = (self.nx, self.nu);
        if let Some(jac) = &self.inner.jac {
            let (mut a, mut b) = (vec![0.0; nx * nx], vec![0.0; nx * nu]);
            if pending() {
                fx.fill(f64::NAN);
                return;
            }
            let r = Python::attach(|py| -> PyResult<()> {
                let res = jac.call1(
                    py,
                    (
                        vec_to_numpy(py, x.as_slice().to_vec()),
                        vec_to_numpy(py, u.as_slice().to_vec()),
                    ),
                )?;
                let (ja, jb): (Bound<'_, PyAny>, Bound<'_, PyAny>) = res.bind(py).extract()?;
                let (ja, jb) = (to_arr(&ja, "fx")?, to_arr(&jb, "fu")?);
                ja.expect_shape("fx", &[nx, nx])?;
                jb.expect_shape("fu", &[nx, nu])?;
                a.copy_from_slice(&ja.data);
                b.copy_from_slice(&jb.data);
                Ok(())
            });
            match r {
                Ok(()) => {
                    // Row-major from numpy.
                    for i in 0..nx {
                        for j in 0..nx {
                            fx[(i, j)] = a[i * nx + j];
                        }
                        for j in 0..nu {
                            fu[(i, j)] = b[i * nu + j];
                        }
                    }
                }
                Err(e) => {
                    keep(e);
                    fx.fill(f64::NAN);
                    fu.fill(f64::NAN);
                }
            }
            return;
        }
        let (mut xp, mut up) = (x.as_slice().to_vec(), u.as_slice().to_vec());
        let (mut fp, mut fm) = (vec![0.0; nx], vec![0.0; nx]);
        for j in 0..nx + nu {
            let (z, slot) = if j < nx { (x[j], j) } else { (u[j - nx], j - nx) };
            let h = step_size(z, 1.0 / 3.0);
            let v = if j < nx { &mut xp } else { &mut up };
            v[slot] = z + h;
            self.eval(&xp, &up, &mut fp);
            let v = if j < nx { &mut xp } else { &mut up };
            v[slot] = z - h;
            self.eval(&xp, &up, &mut fm);
            let v = if j < nx { &mut xp } else { &mut up };
            v[slot] = z;
            for i in 0..nx {
                let d = (fp[i] - fm[i]) / (2.0 * h);
                if j < nx {
                    fx[(i, j)] = d;
                } else {
                    fu[(i, j - nx)] = d;
                }
            }
        }
    }
}

/// A cost `l(x, u)` (or a terminal `l(x)`) of a Python callable.
#[derive(Debug, Clone)]
pub struct CallableCost {
    inner: Arc<PyFn>,
    nx: usize,
    /// `None` for a terminal cost `l(x)`.
    nu: Option<usize>,
}

impl PartialEq for CallableCost {
    /// The same Python functions (by identity, as pickling restores a module-level function) and sizes.
    fn eq(&self, other: &Self) -> bool {
        *self.inner == *other.inner && (self.nx, self.nu) == (other.nx, other.nu)
    }
}

impl PartialEq for PyFn {
    fn eq(&self, other: &Self) -> bool {
        self.f.as_ptr() == other.f.as_ptr()
            && self.jac.as_ref().map(|j| j.as_ptr()) == other.jac.as_ref().map(|j| j.as_ptr())
    }
}

impl CallableCost {
    /// `(l, nx, nu)`: the arguments of `Cost.from_callable` that built it.
    pub fn parts(&self, py: Python<'_>) -> (Py<PyAny>, usize, Option<usize>) {
        (self.inner.f.clone_ref(py), self.nx, self.nu)
    }
    /// Whether this is a terminal cost `l(x)`.
    pub fn terminal(&self) -> bool {
        self.nu.is_none()
    }
    /// `(nx, nu)` (`nu = 0` for a terminal cost).
    pub fn dims(&self) -> (usize, usize) {
        (self.nx, self.nu.unwrap_or(0))
    }
    fn value_at(&self, z: &[f64]) -> f64 {
        let mut v = [0.0];
        let (x, u) = z.split_at(self.nx);
        call(&self.inner.f, &self.inner.name, x, self.nu.map(|_| u), &mut v);
        v[0]
    }
    /// Value, gradient and Hessian (row-major) over `z = (x, u)` by central differences.
    fn derivatives(&self, z: &[f64]) -> (f64, Vec<f64>, Vec<f64>) {
        let n = z.len();
        let v = self.value_at(z);
        let mut g = vec![0.0; n];
        let mut h = vec![0.0; n * n];
        let mut w = z.to_vec();
        for i in 0..n {
            let hi = step_size(z[i], 1.0 / 3.0);
            w[i] = z[i] + hi;
            let p = self.value_at(&w);
            w[i] = z[i] - hi;
            let m = self.value_at(&w);
            w[i] = z[i];
            g[i] = (p - m) / (2.0 * hi);
        }
        for i in 0..n {
            let hi = step_size(z[i], 0.25);
            for j in i..n {
                let hj = step_size(z[j], 0.25);
                let mut f = |si: f64, sj: f64| {
                    w[i] += si * hi;
                    w[j] += sj * hj;
                    let r = self.value_at(&w);
                    w[i] = z[i];
                    w[j] = z[j];
                    r
                };
                let d = (f(1.0, 1.0) - f(1.0, -1.0) - f(-1.0, 1.0) + f(-1.0, -1.0)) / (4.0 * hi * hj);
                h[i * n + j] = d;
                h[j * n + i] = d;
            }
        }
        (v, g, h)
    }
}

impl<NX: Dim, NU: Dim> CoreCost<NX, NU> for CallableCost
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn value(&self, x: &VectorN<NX>, u: &VectorN<NU>) -> f64 {
        let z: Vec<f64> = x.iter().chain(u.iter()).copied().collect();
        self.value_at(&z)
    }
    fn add_derivatives(&self, x: &VectorN<NX>, u: &VectorN<NU>, w: f64, d: &mut CostDerivatives<NX, NU>) -> f64 {
        let (nx, nu) = (x.len(), u.len());
        let z: Vec<f64> = x.iter().chain(u.iter()).copied().collect();
        let n = nx + nu;
        let (v, g, h) = self.derivatives(&z);
        for i in 0..nx {
            d.lx[i] += w * g[i];
            for j in 0..nx {
                d.lxx[(i, j)] += w * h[i * n + j];
            }
        }
        for i in 0..nu {
            d.lu[i] += w * g[nx + i];
            for j in 0..nu {
                d.luu[(i, j)] += w * h[(nx + i) * n + nx + j];
            }
            for j in 0..nx {
                d.lux[(i, j)] += w * h[(nx + i) * n + j];
            }
        }
        w * v
    }
    fn sizes(&self) -> (Option<usize>, Option<usize>) {
        (Some(self.nx), self.nu)
    }
}

impl<NX: Dim> CoreTerminalCost<NX> for CallableCost
where
    DefaultAllocator: Alloc<NX, NX>,
{
    fn value(&self, x: &VectorN<NX>) -> f64 {
        self.value_at(x.as_slice())
    }
    fn add_derivatives(&self, x: &VectorN<NX>, w: f64, d: &mut TerminalDerivatives<NX>) -> f64 {
        let n = x.len();
        let (v, g, h) = self.derivatives(x.as_slice());
        for i in 0..n {
            d.lx[i] += w * g[i];
            for j in 0..n {
                d.lxx[(i, j)] += w * h[i * n + j];
            }
        }
        w * v
    }
    fn state_size(&self) -> Option<usize> {
        Some(self.nx)
    }
}

/// Constraints `g(x, u) <= 0` (or `g(x) <= 0`) of a Python callable returning `rows` values.
/// Jacobians by central differences; no second derivatives (Gauss-Newton, as the obstacles).
#[derive(Debug, Clone)]
pub struct CallableConstraint {
    inner: Arc<PyFn>,
    nx: usize,
    /// `None` for a state-only constraint `g(x)` (imposed on `x_1 .. x_N`).
    nu: Option<usize>,
    rows: usize,
}

impl PartialEq for CallableConstraint {
    /// The same Python function (by identity) and sizes.
    fn eq(&self, other: &Self) -> bool {
        *self.inner == *other.inner && (self.nx, self.nu, self.rows) == (other.nx, other.nu, other.rows)
    }
}

impl CallableConstraint {
    /// `(g, nx, nu, rows)`: the arguments of `Constraint.from_callable` that built it.
    pub fn parts(&self, py: Python<'_>) -> (Py<PyAny>, usize, Option<usize>, usize) {
        (self.inner.f.clone_ref(py), self.nx, self.nu, self.rows)
    }

    fn eval(&self, x: &[f64], u: &[f64], out: &mut [f64]) {
        call(&self.inner.f, &self.inner.name, x, self.nu.map(|_| u), out)
    }
}

impl<NX: Dim, NU: Dim> safe_cddp::Constraint<NX, NU> for CallableConstraint
where
    DefaultAllocator: Alloc<NX, NU>,
{
    fn dim(&self) -> usize {
        self.rows
    }
    fn depends_on_control(&self) -> bool {
        self.nu.is_some()
    }
    fn evaluate(&self, _t: usize, x: &VectorN<NX>, u: &VectorN<NU>, g: &mut [f64]) {
        if g.len() != self.rows {
            g.fill(f64::NAN);
            return;
        }
        self.eval(x.as_slice(), u.as_slice(), g);
    }
    fn jacobians(
        &self,
        _t: usize,
        x: &VectorN<NX>,
        u: &VectorN<NU>,
        g: &mut [f64],
        g_x: &mut [VectorN<NX>],
        g_u: &mut [VectorN<NU>],
    ) {
        let m = self.rows;
        if g.len() != m || g_x.len() != m || g_u.len() != m {
            g.fill(f64::NAN);
            return;
        }
        let (nx, nu) = (x.len(), if self.nu.is_some() { u.len() } else { 0 });
        self.eval(x.as_slice(), u.as_slice(), g);
        for r in g_u.iter_mut() {
            r.fill(0.0);
        }
        let (mut xp, mut up) = (x.as_slice().to_vec(), u.as_slice().to_vec());
        let (mut gp, mut gm) = (vec![0.0; m], vec![0.0; m]);
        for j in 0..nx + nu {
            let (v, slot) = if j < nx { (&mut xp, j) } else { (&mut up, j - nx) };
            let z = v[slot];
            let h = step_size(z, 1.0 / 3.0);
            v[slot] = z + h;
            self.eval(&xp, &up, &mut gp);
            let v = if j < nx { &mut xp } else { &mut up };
            v[slot] = z - h;
            self.eval(&xp, &up, &mut gm);
            let v = if j < nx { &mut xp } else { &mut up };
            v[slot] = z;
            for i in 0..m {
                let d = (gp[i] - gm[i]) / (2.0 * h);
                if j < nx {
                    g_x[i][j] = d;
                } else {
                    g_u[i][j - nx] = d;
                }
            }
        }
    }
    fn check_sizes(&self, nx: usize, nu: usize) -> safe_cddp::Result<()> {
        if nx != self.nx {
            return Err(safe_cddp::Error::Shape {
                field: "constraint.nx".into(),
                got: self.nx.to_string(),
                expected: format!("{nx} (the problem's state size)"),
            });
        }
        match self.nu {
            Some(n) if n != nu => Err(safe_cddp::Error::Shape {
                field: "constraint.nu".into(),
                got: n.to_string(),
                expected: format!("{nu} (the problem's control size)"),
            }),
            _ => Ok(()),
        }
    }
}

/// `Constraint.from_callable`.
pub fn constraint_from_callable(
    py: Python<'_>,
    g: &Bound<'_, PyAny>,
    nx: i64,
    nu: Option<i64>,
    rows: i64,
) -> PyResult<Py<PyAny>> {
    let nx = model_size(nx, "nx")?;
    let nu = nu.map(|n| model_size(n, "nu")).transpose()?;
    let rows = model_size(rows, "rows")?;
    let (f, name) = checked_callable(g, "g")?;
    let model = CallableConstraint {
        inner: Arc::new(PyFn { f, jac: None, name }),
        nx,
        nu,
        rows,
    };
    crate::safe::callable_constraint(py, model)
}

fn wrap_dynamics<NX: Dim, NU: Dim>(d: &CallableDynamics) -> CoreResult<Dynamics>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    Dynamics::of::<NX, NU>(d.clone())
}

fn checked_callable(f: &Bound<'_, PyAny>, field: &str) -> PyResult<(Py<PyAny>, String)> {
    if !f.is_callable() {
        return Err(invalid(field, format!("must be callable, got {}", crate::models::type_name(f))).into());
    }
    let name = f
        .getattr("__qualname__")
        .and_then(|n| n.extract::<String>())
        .unwrap_or_else(|_| field.to_string());
    Ok((f.clone().unbind(), name))
}

/// `Dynamics.from_callable`.
pub fn dynamics_from_callable(
    py: Python<'_>,
    f: &Bound<'_, PyAny>,
    nx: i64,
    nu: i64,
    jacobians: Option<&Bound<'_, PyAny>>,
) -> PyResult<Py<PyAny>> {
    let (nx, nu) = (model_size(nx, "nx")?, model_size(nu, "nu")?);
    let (f, name) = checked_callable(f, "f")?;
    let jac = match jacobians {
        Some(j) if !j.is_none() => Some(checked_callable(j, "jacobians")?.0),
        _ => None,
    };
    let model = CallableDynamics {
        inner: Arc::new(PyFn { f, jac, name }),
        nx,
        nu,
    };
    let base: Dynamics = with_dims!(nx, nu, wrap_dynamics(&model))?;
    Ok(Py::new(
        py,
        PyClassInitializer::from(base).add_subclass(PyCallableDynamics { model }),
    )?
    .into_any())
}

/// `Cost.from_callable`.
pub fn cost_from_callable(py: Python<'_>, l: &Bound<'_, PyAny>, nx: i64, nu: Option<i64>) -> PyResult<Py<PyAny>> {
    let nx = model_size(nx, "nx")?;
    let nu = nu.map(|n| model_size(n, "nu")).transpose()?;
    let (f, name) = checked_callable(l, "l")?;
    let model = CallableCost {
        inner: Arc::new(PyFn { f, jac: None, name }),
        nx,
        nu,
    };
    let base = Cost {
        spec: Arc::new(CostSpec::Callable(model.clone())),
    };
    Ok(Py::new(
        py,
        PyClassInitializer::from(base).add_subclass(PyCallableCost { model }),
    )?
    .into_any())
}

/// Dynamics of a plain Python callable (`Dynamics.from_callable`): the slow path.
#[pyclass(module = "ddpkit._ddpkit", extends = Dynamics, frozen, name = "CallableDynamics")]
pub struct PyCallableDynamics {
    model: CallableDynamics,
}

#[pymethods]
impl PyCallableDynamics {
    /// The Python function.
    #[getter]
    fn function(&self, py: Python<'_>) -> Py<PyAny> {
        self.model.inner.f.clone_ref(py)
    }

    /// Pickles as `Dynamics.from_callable(f, nx, nu, jacobians)`: needs picklable functions.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let ctor = py
            .import("ddpkit._ddpkit")?
            .getattr("Dynamics")?
            .getattr("from_callable")?;
        let jac = self.model.inner.jac.as_ref().map(|j| j.clone_ref(py));
        let args = (self.model.inner.f.clone_ref(py), self.model.nx, self.model.nu, jac).into_pyobject(py)?;
        Ok((ctor, args))
    }

    fn __repr__(&self) -> String {
        format!(
            "CallableDynamics({}, nx={}, nu={})",
            self.model.inner.name, self.model.nx, self.model.nu
        )
    }
}

/// A cost of a plain Python callable (`Cost.from_callable`): the slow path.
#[pyclass(module = "ddpkit._ddpkit", extends = Cost, frozen, name = "CallableCost")]
pub struct PyCallableCost {
    model: CallableCost,
}

#[pymethods]
impl PyCallableCost {
    /// The Python function.
    #[getter]
    fn function(&self, py: Python<'_>) -> Py<PyAny> {
        self.model.inner.f.clone_ref(py)
    }

    /// Pickles as `Cost.from_callable(l, nx, nu)`: needs a picklable function.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let ctor = py.import("ddpkit._ddpkit")?.getattr("Cost")?.getattr("from_callable")?;
        let args = (self.model.inner.f.clone_ref(py), self.model.nx, self.model.nu).into_pyobject(py)?;
        Ok((ctor, args))
    }

    fn __repr__(&self) -> String {
        format!(
            "CallableCost({}, nx={}, nu={:?})",
            self.model.inner.name, self.model.nx, self.model.nu
        )
    }
}

/// Registers the classes.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyCallableDynamics>()?;
    m.add_class::<PyCallableCost>()?;
    Ok(())
}
