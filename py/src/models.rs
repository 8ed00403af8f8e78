//! Dynamics models: the [`Dynamics`] base class and the built-in models as its subclasses.

use std::sync::Arc;

use ddp_core::dims::{check_size, Alloc, DefaultAllocator, Dim, MAX_CONTROLS, MAX_STATES};
use ddp_core::linear::LinearDynamics as CoreLinear;
use ddp_core::models;
use pyo3::prelude::*;

use crate::convert::{finite_arr, matrix_to_numpy, shape_str, vector_to_numpy, Arr};
use crate::dims::{dims, dynamics_of, AnyDynamics, Dispatch, Pair};
use crate::errors::{invalid, shape, CoreError, CoreResult};

/// Base class of every dynamics model: a discrete map `x+ = f(x, u)` with `nx` states and `nu`
/// controls. Not constructible itself; use a built-in model or `LinearDynamics`.
#[pyclass(module = "ddpkit._ddpkit", subclass, frozen)]
pub struct Dynamics {
    pub(crate) inner: AnyDynamics,
    pub(crate) nx: usize,
    pub(crate) nu: usize,
}

impl Dynamics {
    /// Wraps a model; its sizes are those it reports (a compiled pair for the built-in models).
    pub(crate) fn of<NX: Dim, NU: Dim>(model: impl ddp_core::Dynamics<NX, NU> + 'static) -> CoreResult<Self>
    where
        DefaultAllocator: Alloc<NX, NU>,
        Dispatch: Pair<NX, NU>,
    {
        let (Some(nx), Some(nu)) = model.sizes() else {
            return Err(crate::dims::internal_mismatch("a model without sizes"));
        };
        Ok(Self {
            inner: <Dispatch as Pair<NX, NU>>::wrap_dynamics(Arc::new(model)),
            nx,
            nu,
        })
    }
}

fn step_impl<'py, NX: Dim, NU: Dim>(py: Python<'py>, d: &Dynamics, x: &Arr, u: &Arr) -> PyResult<Bound<'py, PyAny>>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let model = dynamics_of::<NX, NU>(&d.inner)?;
    let s = dims::<NX, NU>(d.nx, d.nu)?;
    let (x, u) = (x.vector("x", s.nx)?, u.vector("u", s.nu)?);
    Ok(vector_to_numpy(py, &model.step(&x, &u)))
}

fn jacobians_impl<'py, NX: Dim, NU: Dim>(
    py: Python<'py>,
    d: &Dynamics,
    x: &Arr,
    u: &Arr,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let model = dynamics_of::<NX, NU>(&d.inner)?;
    let s = dims::<NX, NU>(d.nx, d.nu)?;
    let (x, u) = (x.vector("x", s.nx)?, u.vector("u", s.nu)?);
    let (mut fx, mut fu) = (s.xx_zeros(), s.xu_zeros());
    model.jacobians(&x, &u, &mut fx, &mut fu);
    Ok((matrix_to_numpy(py, &fx)?, matrix_to_numpy(py, &fu)?))
}

fn has_second_order_impl<NX: Dim, NU: Dim>(d: &AnyDynamics) -> PyResult<bool>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    Ok(dynamics_of::<NX, NU>(d)?.has_second_order())
}

#[pymethods]
impl Dynamics {
    /// Equal when of the same class and built from equal arguments (what pickling keeps).
    fn __eq__(slf: &Bound<'_, Self>, other: &Bound<'_, PyAny>) -> PyResult<bool> {
        crate::pickle::reduce_equal(slf.as_any(), other)
    }

    /// Number of states.
    #[getter]
    fn nx(&self) -> usize {
        self.nx
    }

    /// Number of controls.
    #[getter]
    fn nu(&self) -> usize {
        self.nu
    }

    /// Whether the model has exact second derivatives (used by `method="ddp"`).
    #[getter]
    fn has_second_order(&self) -> PyResult<bool> {
        with_dims!(self.nx, self.nu, has_second_order_impl(&self.inner))
    }

    /// The next state `f(x, u)`, shape `(nx,)`.
    fn step<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>, u: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let (x, u) = (finite_arr(x, "x")?, finite_arr(u, "u")?);
        let r = with_dims!(self.nx, self.nu, step_impl(py, self, &x, &u));
        crate::callable::raise_pending()?;
        r
    }

    /// Dynamics traced from a Python function `f(x, u)`: the discrete step when `dt` is None,
    /// else the continuous `xdot = f(x, u)` integrated over `dt` by `integrator` (`"rk4"` or
    /// `"euler"`). `f` is called once with symbolic arrays; numpy-style math is recorded and
    /// evaluated in Rust with exact first and second derivatives.
    #[staticmethod]
    #[pyo3(signature = (f, nx, nu, dt = None, integrator = "rk4"))]
    fn from_function(
        py: Python<'_>,
        f: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = crate::convert::int_i64)] nx: i64,
        #[pyo3(from_py_with = crate::convert::int_i64)] nu: i64,
        dt: Option<f64>,
        integrator: &str,
    ) -> PyResult<Py<PyAny>> {
        crate::tape::dynamics_from_function(py, f, nx, nu, dt, integrator)
    }

    /// Dynamics read from a CasADi SX function `F(x, u)` (discrete, or continuous with `dt`).
    #[staticmethod]
    #[pyo3(signature = (F, dt = None, integrator = "rk4"))]
    #[allow(non_snake_case)]
    fn from_casadi(py: Python<'_>, F: &Bound<'_, PyAny>, dt: Option<f64>, integrator: &str) -> PyResult<Py<PyAny>> {
        crate::tape::dynamics_from_casadi(py, F, dt, integrator)
    }

    /// Dynamics from a plain Python callable `f(x, u) -> x_next` (the slow path, for what cannot
    /// be traced). `jacobians(x, u) -> (fx, fu)` is optional: central finite differences
    /// otherwise. An exception raised by `f` during a solve is raised by the solve.
    #[staticmethod]
    #[pyo3(signature = (f, nx, nu, jacobians = None))]
    fn from_callable(
        py: Python<'_>,
        f: &Bound<'_, PyAny>,
        #[pyo3(from_py_with = crate::convert::int_i64)] nx: i64,
        #[pyo3(from_py_with = crate::convert::int_i64)] nu: i64,
        jacobians: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Py<PyAny>> {
        crate::callable::dynamics_from_callable(py, f, nx, nu, jacobians)
    }

    /// The Jacobians `(fx, fu)` of `step` at `(x, u)`, shapes `(nx, nx)` and `(nx, nu)`.
    fn jacobians<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
        u: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let (x, u) = (finite_arr(x, "x")?, finite_arr(u, "u")?);
        let r = with_dims!(self.nx, self.nu, jacobians_impl(py, self, &x, &u));
        crate::callable::raise_pending()?;
        r
    }
}

/// Unicycle `(px, py, theta)` driven by `(v, omega)`, explicit Euler (benchmark P1, Crocoddyl's
/// `ActionModelUnicycle`).
#[pyclass(module = "ddpkit._ddpkit", extends = Dynamics, frozen)]
pub struct Unicycle {
    model: models::Unicycle,
}

#[pymethods]
impl Unicycle {
    #[new]
    #[pyo3(signature = (dt = 0.1))]
    fn new(dt: f64) -> PyResult<PyClassInitializer<Self>> {
        let model = models::Unicycle::new(dt).map_err(CoreError)?;
        Ok(PyClassInitializer::from(Dynamics::of(model)?).add_subclass(Self { model }))
    }

    /// The time step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.model.dt()
    }

    /// The constructor's arguments (pickling).
    fn __getnewargs__(&self) -> (f64,) {
        (self.model.dt(),)
    }

    fn __repr__(&self) -> String {
        format!("Unicycle(dt={})", self.model.dt())
    }
}

/// Kinematic car `(px, py, theta, v)` driven by `(omega, a)`, explicit Euler (benchmark P2).
#[pyclass(module = "ddpkit._ddpkit", extends = Dynamics, frozen)]
pub struct Car {
    model: models::Car,
}

#[pymethods]
impl Car {
    #[new]
    #[pyo3(signature = (dt = 0.05))]
    fn new(dt: f64) -> PyResult<PyClassInitializer<Self>> {
        let model = models::Car::new(dt).map_err(CoreError)?;
        Ok(PyClassInitializer::from(Dynamics::of(model)?).add_subclass(Self { model }))
    }

    /// The time step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.model.dt()
    }

    /// The constructor's arguments (pickling).
    fn __getnewargs__(&self) -> (f64,) {
        (self.model.dt(),)
    }

    fn __repr__(&self) -> String {
        format!("Car(dt={})", self.model.dt())
    }
}

/// Planar point mass `(px, py, vx, vy)` driven by `(ax, ay)`, exact zero-order hold (benchmark P3).
#[pyclass(module = "ddpkit._ddpkit", extends = Dynamics, frozen)]
pub struct DoubleIntegrator2D {
    model: models::DoubleIntegrator2D,
}

#[pymethods]
impl DoubleIntegrator2D {
    #[new]
    #[pyo3(signature = (dt = 0.05))]
    fn new(dt: f64) -> PyResult<PyClassInitializer<Self>> {
        let model = models::DoubleIntegrator2D::new(dt).map_err(CoreError)?;
        Ok(PyClassInitializer::from(Dynamics::of(model)?).add_subclass(Self { model }))
    }

    /// The time step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.model.dt()
    }

    /// The constructor's arguments (pickling).
    fn __getnewargs__(&self) -> (f64,) {
        (self.model.dt(),)
    }

    fn __repr__(&self) -> String {
        format!("DoubleIntegrator2D(dt={})", self.model.dt())
    }
}

/// Differential-drive robot `(px, py, theta)` driven by wheel speeds `(v_l, v_r)`.
#[pyclass(module = "ddpkit._ddpkit", extends = Dynamics, frozen)]
pub struct DifferentialDrive {
    model: models::DifferentialDrive,
}

#[pymethods]
impl DifferentialDrive {
    #[new]
    #[pyo3(signature = (dt = 0.1, track_width = 0.16))]
    fn new(dt: f64, track_width: f64) -> PyResult<PyClassInitializer<Self>> {
        let model = models::DifferentialDrive::new(dt, track_width).map_err(CoreError)?;
        Ok(PyClassInitializer::from(Dynamics::of(model)?).add_subclass(Self { model }))
    }

    /// The time step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.model.dt()
    }

    /// The track width (m).
    #[getter]
    fn track_width(&self) -> f64 {
        self.model.track_width()
    }

    /// The constructor's arguments (pickling).
    fn __getnewargs__(&self) -> (f64, f64) {
        (self.model.dt(), self.model.track_width())
    }

    fn __repr__(&self) -> String {
        format!(
            "DifferentialDrive(dt={}, track_width={})",
            self.model.dt(),
            self.model.track_width()
        )
    }
}

/// 12-state quadrotor `(p, euler, v, omega)` driven by thrust and body torques.
#[pyclass(module = "ddpkit._ddpkit", extends = Dynamics, frozen)]
pub struct Quadrotor {
    model: models::Quadrotor,
}

#[pymethods]
impl Quadrotor {
    #[new]
    #[pyo3(signature = (dt = 0.05, mass = 0.468, inertia = (4.856e-3, 4.856e-3, 8.801e-3), gravity = 9.81))]
    #[pyo3(text_signature = "(dt=0.05, mass=0.468, inertia=(0.004856, 0.004856, 0.008801), gravity=9.81)")]
    fn new(dt: f64, mass: f64, inertia: (f64, f64, f64), gravity: f64) -> PyResult<PyClassInitializer<Self>> {
        let model =
            models::Quadrotor::with_params(dt, mass, [inertia.0, inertia.1, inertia.2], gravity).map_err(CoreError)?;
        Ok(PyClassInitializer::from(Dynamics::of(model)?).add_subclass(Self { model }))
    }

    /// The time step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.model.dt()
    }

    /// The mass (kg).
    #[getter]
    fn mass(&self) -> f64 {
        self.model.mass()
    }

    /// The principal moments of inertia `(Jx, Jy, Jz)` (kg m^2).
    #[getter]
    fn inertia(&self) -> (f64, f64, f64) {
        let [a, b, c] = self.model.inertia();
        (a, b, c)
    }

    /// The gravitational acceleration (m/s^2).
    #[getter]
    fn gravity(&self) -> f64 {
        self.model.gravity()
    }

    /// The control that holds the quadrotor still when level: `(m g, 0, 0, 0)`.
    fn hover_control<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        vector_to_numpy(py, &self.model.hover_control())
    }

    /// The constructor's arguments (pickling).
    fn __getnewargs__(&self) -> (f64, f64, (f64, f64, f64), f64) {
        let [a, b, c] = self.model.inertia();
        (self.model.dt(), self.model.mass(), (a, b, c), self.model.gravity())
    }

    fn __repr__(&self) -> String {
        let [a, b, c] = self.model.inertia();
        format!(
            "Quadrotor(dt={}, mass={}, inertia=({a}, {b}, {c}), gravity={})",
            self.model.dt(),
            self.model.mass(),
            self.model.gravity()
        )
    }
}

/// Planar free-floating base with a 2-link arm (10 states, 5 controls).
#[pyclass(module = "ddpkit._ddpkit", extends = Dynamics, frozen)]
pub struct ArmBase {
    model: models::ArmBase,
}

fn pair_or(v: Option<(f64, f64)>, default: [f64; 2]) -> [f64; 2] {
    v.map(|(a, b)| [a, b]).unwrap_or(default)
}

#[pymethods]
impl ArmBase {
    #[new]
    #[pyo3(signature = (
        dt = 0.1,
        base_mass = None,
        base_inertia = None,
        base_size = None,
        mount = None,
        link_lengths = None,
        link_masses = None,
        link_inertias = None,
    ))]
    fn new(
        dt: f64,
        base_mass: Option<f64>,
        base_inertia: Option<f64>,
        base_size: Option<(f64, f64)>,
        mount: Option<(f64, f64)>,
        link_lengths: Option<(f64, f64)>,
        link_masses: Option<(f64, f64)>,
        link_inertias: Option<(f64, f64)>,
    ) -> PyResult<PyClassInitializer<Self>> {
        let d = models::ArmBaseParams::default();
        let params = models::ArmBaseParams {
            dt,
            base_mass: base_mass.unwrap_or(d.base_mass),
            base_inertia: base_inertia.unwrap_or(d.base_inertia),
            base_size: pair_or(base_size, d.base_size),
            mount: pair_or(mount, d.mount),
            link_lengths: pair_or(link_lengths, d.link_lengths),
            link_masses: pair_or(link_masses, d.link_masses),
            link_inertias: pair_or(link_inertias, d.link_inertias),
        };
        let model = models::ArmBase::from_params(params).map_err(CoreError)?;
        Ok(PyClassInitializer::from(Dynamics::of(model)?).add_subclass(Self { model }))
    }

    /// The time step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.model.dt()
    }

    /// The physical parameters as a dict.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        let p = self.model.params();
        let d = pyo3::types::PyDict::new(py);
        d.set_item("dt", p.dt)?;
        d.set_item("base_mass", p.base_mass)?;
        d.set_item("base_inertia", p.base_inertia)?;
        d.set_item("base_size", (p.base_size[0], p.base_size[1]))?;
        d.set_item("mount", (p.mount[0], p.mount[1]))?;
        d.set_item("link_lengths", (p.link_lengths[0], p.link_lengths[1]))?;
        d.set_item("link_masses", (p.link_masses[0], p.link_masses[1]))?;
        d.set_item("link_inertias", (p.link_inertias[0], p.link_inertias[1]))?;
        Ok(d)
    }

    /// Position of the tool centre point (the end of link 2) in the world frame, shape `(2,)`.
    fn tcp_position<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
        let x = finite_arr(x, "x")?.vector("x", nalgebra::U10)?;
        let [a, b] = self.model.tcp_position(&x);
        Ok(crate::convert::vec_to_numpy(py, vec![a, b]))
    }

    /// The constructor's arguments (pickling).
    #[allow(clippy::type_complexity)]
    fn __getnewargs__(
        &self,
    ) -> (
        f64,
        f64,
        f64,
        (f64, f64),
        (f64, f64),
        (f64, f64),
        (f64, f64),
        (f64, f64),
    ) {
        let p = self.model.params();
        let t = |v: [f64; 2]| (v[0], v[1]);
        (
            p.dt,
            p.base_mass,
            p.base_inertia,
            t(p.base_size),
            t(p.mount),
            t(p.link_lengths),
            t(p.link_masses),
            t(p.link_inertias),
        )
    }

    fn __repr__(&self) -> String {
        format!("ArmBase(dt={})", self.model.dt())
    }
}

/// Linear dynamics `x+ = A x + B u + c`.
#[pyclass(module = "ddpkit._ddpkit", extends = Dynamics, frozen)]
pub struct LinearDynamics {
    a: Arr,
    b: Arr,
    c: Vec<f64>,
}

fn make_linear<NX: Dim, NU: Dim>(a: &Arr, b: &Arr, c: &[f64]) -> CoreResult<Dynamics>
where
    DefaultAllocator: Alloc<NX, NU>,
    Dispatch: Pair<NX, NU>,
{
    let s = dims::<NX, NU>(a.rows(), b.shape[1])?;
    let model = CoreLinear::new(
        a.matrix("A", s.nx, s.nx)?,
        b.matrix("B", s.nx, s.nu)?,
        Arr {
            shape: vec![c.len()],
            data: c.to_vec(),
        }
        .vector("c", s.nx)?,
    )?;
    Dynamics::of(model)
}

#[pymethods]
impl LinearDynamics {
    #[new]
    #[pyo3(signature = (A, B, c = None))]
    #[allow(non_snake_case)]
    fn new(
        A: &Bound<'_, PyAny>,
        B: &Bound<'_, PyAny>,
        c: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyClassInitializer<Self>> {
        let a = finite_arr(A, "A")?;
        let b = finite_arr(B, "B")?;
        let nx = match a.shape.as_slice() {
            [n, m] if n == m => *n,
            _ => return Err(shape("A", shape_str(&a.shape), "(nx, nx)").into()),
        };
        check_size("A.shape[0]", nx, None, MAX_STATES).map_err(CoreError)?;
        let nu = match b.shape.as_slice() {
            [n, m] if *n == nx => *m,
            _ => return Err(shape("B", shape_str(&b.shape), format!("({nx}, nu) (as many rows as A)")).into()),
        };
        check_size("B.shape[1]", nu, None, MAX_CONTROLS).map_err(CoreError)?;
        let c = match c {
            Some(c) => {
                let c = finite_arr(c, "c")?;
                c.expect_shape("c", &[nx])?;
                c.data
            }
            None => vec![0.0; nx],
        };
        let base: Dynamics = with_dims!(nx, nu, make_linear(&a, &b, &c))?;
        Ok(PyClassInitializer::from(base).add_subclass(Self { a, b, c }))
    }

    /// `A`, shape `(nx, nx)`.
    #[getter(A)]
    fn a<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::convert::rows_to_numpy(py, self.a.rows(), self.a.rows(), self.a.data.clone())
    }

    /// `B`, shape `(nx, nu)`.
    #[getter(B)]
    fn b<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let cols = self.b.shape.get(1).copied().unwrap_or(0);
        crate::convert::rows_to_numpy(py, self.b.rows(), cols, self.b.data.clone())
    }

    /// `c`, shape `(nx,)`.
    #[getter]
    fn c<'py>(&self, py: Python<'py>) -> Bound<'py, PyAny> {
        crate::convert::vec_to_numpy(py, self.c.clone())
    }

    /// The constructor's arguments `(A, B, c)` (pickling).
    #[allow(clippy::type_complexity)]
    fn __getnewargs__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        Ok((self.a(py)?, self.b(py)?, self.c(py)))
    }

    fn __repr__(&self) -> String {
        let nu = self.b.shape.get(1).copied().unwrap_or(0);
        format!("LinearDynamics(nx={}, nu={nu})", self.a.rows())
    }
}

/// Extracts the dynamics model from a Python object, naming `field` if it is not one.
pub fn extract_dynamics(obj: &Bound<'_, PyAny>, field: &str) -> PyResult<(AnyDynamics, usize, usize)> {
    match obj.cast::<Dynamics>() {
        Ok(d) => {
            let d = d.get();
            Ok((d.inner.clone(), d.nx, d.nu))
        }
        Err(_) => Err(invalid(
            field,
            format!(
                "must be a ddpkit dynamics model (e.g. ddpkit.Unicycle), got {}",
                type_name(obj)
            ),
        )
        .into()),
    }
}

/// The Python type name of `obj`, for messages.
pub fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "an unknown type".into())
}
