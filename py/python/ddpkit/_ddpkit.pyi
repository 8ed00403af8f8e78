"""Type stubs of the ddpkit extension module (``ddpkit._ddpkit``), written in Rust with pyo3.

Arrays are accepted as anything ``numpy.asarray(..., dtype=float64)`` understands (arrays of any
real dtype, lists, tuples, scalars) and returned as new float64 ``numpy.ndarray``\\ s.

Any size: :class:`LinearDynamics`, :class:`QuadraticCost`, :class:`QuadraticTerminal`,
:class:`ControlSquared`, control bounds, :class:`Problem`, :class:`Solver`,
:class:`SafeCddpSolver`, :class:`Tightening`, :class:`Mpc` and the constraints work with any
``nx >= 1`` states and ``nu >= 1`` controls (up to 1024 and 512; Safe-CDDP's per-step QP takes
at most 63 controls). The built-in robots' sizes, a cart-pole's and a planar quadrotor's
(:func:`supported_dimensions`) run on fixed-size matrices; every other size on run-time-size
matrices, through the same Rust code. A 7-state, 3-control linear system::

    import numpy as np, ddpkit
    rng = np.random.default_rng(0)
    A = np.eye(7) + 0.05 * rng.standard_normal((7, 7))
    B = rng.standard_normal((7, 3))
    problem = ddpkit.Problem(
        x0=np.ones(7), dynamics=ddpkit.LinearDynamics(A, B),
        running_cost=ddpkit.QuadraticCost(Q=np.eye(7), R=0.1 * np.eye(3)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=10 * np.eye(7)), horizon=50,
        u_min=-1.0, u_max=1.0)
    solution = ddpkit.Solver(problem).solve()  # box-DDP; solution.K has shape (50, 3, 7)
"""

import os
from collections.abc import Sequence
from typing import Any, Optional, Union, overload

from typing_extensions import Self, disjoint_base, final

import numpy as np
import numpy.typing as npt

_ArrayLike = npt.ArrayLike
_F64Array = npt.NDArray[np.float64]
# Vectorised Bezier methods: a Python number gives a number (or a (2,) point), an array (or
# nested sequence) of shape S gives an array of shape S (or S + (2,)).
_Params = Union[npt.NDArray[Any], Sequence[Any]]

__all__ = [
    "ArmBase",
    "BEZIER_DEFAULT_ACCURACY",
    "Bezier",
    "CallableCost",
    "CallableConstraint",
    "_unpickle_result",
    "CallableDynamics",
    "Car",
    "Circle",
    "CirclePenalty",
    "Constraint",
    "ControlBox",
    "ControlSquared",
    "ConvexPolygon",
    "Cost",
    "CostSum",
    "Cylinder",
    "DdpError",
    "DifferentialDrive",
    "DoubleIntegrator2D",
    "Dynamics",
    "Episode",
    "IdnpExperiment",
    "IdnpRun",
    "InvalidInputError",
    "LinearDynamics",
    "Mpc",
    "NotFiniteError",
    "ObstacleHinge",
    "Problem",
    "QuadraticCost",
    "QuadraticTerminal",
    "Quadrotor",
    "SUBGOAL_MAP_CELLS",
    "SafeCddpSolver",
    "SafeSolution",
    "ShapeError",
    "SigmoidProfile",
    "SimResult",
    "SmoothDistance",
    "Solution",
    "Solver",
    "Spline",
    "SplineOptimizeResult",
    "StateBox",
    "SubgoalModel",
    "TapeConstraint",
    "TapeCost",
    "TapeDynamics",
    "TerminalSum",
    "Tightening",
    "Trajectory",
    "TrajectorySamples",
    "TurtlebotExperiment",
    "Unicycle",
    "__version__",
    "arclen_batch",
    "default_settings",
    "experiment_aggregate",
    "experiment_names",
    "experiment_run_task",
    "experiment_tasks",
    "idnp_configuration",
    "idnp_experiment",
    "idnp_run",
    "idnp_scene",
    "load_model",
    "model_from_json",
    "optimize_spline",
    "sim_run_scenario",
    "sim_safe_turtlebot",
    "simd_level",
    "solve_batch",
    "solve_batch_safe",
    "spline_cost",
    "subgoal_generate_dataset",
    "subgoal_sample",
    "supported_dimensions",
]

__version__: str

# --------------------------------------------------------------------------------------------
# Errors
# --------------------------------------------------------------------------------------------

class DdpError(Exception):
    """Base class of every ddpkit error.

    ``field`` names the offending input, e.g. ``"x0"``, ``"running_cost.Q"``,
    ``"running_cost[3]"`` or ``"settings.mu_factor"``.
    """

    field: str

class ShapeError(DdpError, ValueError):
    """An array has the wrong shape, a list the wrong length, or pieces of a problem disagree in
    size (or Safe-CDDP gets a pair outside :func:`supported_dimensions`)."""

class NotFiniteError(DdpError, ValueError):
    """A value that must be finite is NaN or infinite. The message gives the flat index."""

class InvalidInputError(DdpError, ValueError):
    """A value is out of range (negative weight, zero horizon, unknown method, ...), of the wrong
    kind (a cost where a model is expected), or a weight matrix is not symmetric PSD."""

# --------------------------------------------------------------------------------------------
# Dynamics
# --------------------------------------------------------------------------------------------

@disjoint_base
class Dynamics:
    """Base class of every dynamics model: a discrete map ``x+ = f(x, u)``.

    Not constructible itself: use a built-in model or :class:`LinearDynamics`. Models are
    immutable and may be shared between problems and threads.
    """

    @property
    def nx(self) -> int:
        """Number of states."""
    @property
    def nu(self) -> int:
        """Number of controls."""
    @property
    def has_second_order(self) -> bool:
        """Whether the model has exact second derivatives (used by ``method="ddp"``)."""
    def step(self, x: _ArrayLike, u: _ArrayLike) -> _F64Array:
        """The next state ``f(x, u)``, shape ``(nx,)``.

        Raises ``ShapeError`` unless ``x`` has shape ``(nx,)`` and ``u`` shape ``(nu,)``, and
        ``NotFiniteError`` on NaN/inf.
        """
    def jacobians(self, x: _ArrayLike, u: _ArrayLike) -> tuple[_F64Array, _F64Array]:
        """The Jacobians ``(fx, fu)`` of :meth:`step` at ``(x, u)``: shapes ``(nx, nx)`` and
        ``(nx, nu)``."""
    @staticmethod
    def from_function(f: Any, nx: int, nu: int, dt: Optional[float] = None, integrator: str = "rk4") -> TapeDynamics:
        """Dynamics traced from a Python function ``f(x, u)``: the discrete step when ``dt`` is
        None, else the ODE ``xdot = f(x, u)`` integrated over ``dt`` by ``integrator``
        (``"rk4"`` or ``"euler"``).

        ``f`` is called once with symbolic numpy arrays ``x`` ``(nx,)`` and ``u`` ``(nu,)``;
        ``+ - * / **``, ``np.sin/cos/tan/exp/log/sqrt/arctan2/tanh/abs/minimum/maximum/where``,
        indexing, stacking and ``@`` are recorded into a tape that Rust evaluates with exact
        first and second derivatives (no Python during a solve). Branching in Python on a
        symbolic value, ``math.*``/``float()``, an unsupported numpy function, a non-finite
        constant or a result of the wrong shape raise ``InvalidInputError``/``ShapeError``
        naming ``f``.
        """
    @staticmethod
    def from_casadi(F: Any, dt: Optional[float] = None, integrator: str = "rk4") -> TapeDynamics:
        """Dynamics read from a CasADi SX ``Function`` ``F(x, u)`` (its instruction list), discrete
        or (with ``dt``) continuous. An MX function is an error suggesting ``F.expand()``; an
        unsupported operation is an error naming it."""
    @staticmethod
    def from_callable(f: Any, nx: int, nu: int, jacobians: Optional[Any] = None) -> CallableDynamics:
        """Dynamics from a plain Python callable ``f(x, u) -> x_next``: the slow path for what
        cannot be traced (every evaluation calls Python). ``jacobians(x, u) -> (fx, fu)`` is
        optional (central finite differences otherwise). An exception raised by ``f`` during a
        solve is raised by the solve."""

@final
class Unicycle(Dynamics):
    """Unicycle, state ``(px, py, theta)``, control ``(v, omega)``, explicit Euler::

        px+ = px + dt v cos(theta),  py+ = py + dt v sin(theta),  theta+ = theta + dt omega

    Benchmark P1 (Crocoddyl's ``ActionModelUnicycle``). ``dt`` must be finite and > 0.
    """

    def __new__(
        cls, dt: float = 0.1) -> Self: ...
    @property
    def dt(self) -> float:
        """The time step (s)."""

@final
class Car(Dynamics):
    """Kinematic car, state ``(px, py, theta, v)``, control ``(omega, a)``, explicit Euler
    (benchmark P2)::

        px+ = px + dt v cos(theta),  py+ = py + dt v sin(theta),  theta+ = theta + dt omega,  v+ = v + dt a
    """

    def __new__(
        cls, dt: float = 0.05) -> Self: ...
    @property
    def dt(self) -> float:
        """The time step (s)."""

@final
class DoubleIntegrator2D(Dynamics):
    """Planar point mass, state ``(px, py, vx, vy)``, control ``(ax, ay)``, exact zero-order hold
    (benchmark P3)::

        p+ = p + dt v + dt^2/2 a,  v+ = v + dt a
    """

    def __new__(
        cls, dt: float = 0.05) -> Self: ...
    @property
    def dt(self) -> float:
        """The time step (s)."""

@final
class DifferentialDrive(Dynamics):
    """Differential-drive robot, state ``(px, py, theta)``, control the wheel speeds
    ``(v_l, v_r)`` (m/s), stepped along the midpoint heading. ``track_width`` is the distance
    between the wheels (m); the default is a Turtlebot3 Burger's."""

    def __new__(
        cls, dt: float = 0.1, track_width: float = 0.16) -> Self: ...
    @property
    def dt(self) -> float:
        """The time step (s)."""
    @property
    def track_width(self) -> float:
        """The track width (m)."""

@final
class Quadrotor(Dynamics):
    """12-state quadrotor, state ``(p, (phi, theta, psi), v, (p, q, r))`` (world position, ZYX
    Euler angles, world velocity, body rates), control ``(T, tau_x, tau_y, tau_z)`` (collective
    thrust and body torques), explicit Euler. Defaults: a 0.468 kg quadrotor."""

    def __new__(
        cls,
        dt: float = 0.05,
        mass: float = 0.468,
        inertia: tuple[float, float, float] = (4.856e-3, 4.856e-3, 8.801e-3),
        gravity: float = 9.81,
    ) -> Self: ...
    @property
    def dt(self) -> float:
        """The time step (s)."""
    @property
    def mass(self) -> float:
        """The mass (kg)."""
    @property
    def inertia(self) -> tuple[float, float, float]:
        """The principal moments of inertia ``(Jx, Jy, Jz)`` (kg m^2)."""
    @property
    def gravity(self) -> float:
        """The gravitational acceleration (m/s^2)."""
    def hover_control(self) -> _F64Array:
        """The control that holds the quadrotor still when level: ``(m g, 0, 0, 0)``."""

@final
class ArmBase(Dynamics):
    """Planar free-floating base with a 2-link arm (10 states, 5 controls).

    State ``(x, y, theta, q1, q2)`` and their rates; control ``(fx, fy, tau_0, tau_1, tau_2)``:
    force and torque on the base, joint torques. Semi-implicit Euler. Parameters left ``None``
    take the defaults of a small satellite (10 kg, 0.5 m x 0.5 m base; two 0.5 m, 1 kg links);
    see :attr:`params`.
    """

    def __new__(
        cls,
        dt: float = 0.1,
        base_mass: Optional[float] = None,
        base_inertia: Optional[float] = None,
        base_size: Optional[tuple[float, float]] = None,
        mount: Optional[tuple[float, float]] = None,
        link_lengths: Optional[tuple[float, float]] = None,
        link_masses: Optional[tuple[float, float]] = None,
        link_inertias: Optional[tuple[float, float]] = None,
    ) -> Self: ...
    @property
    def dt(self) -> float:
        """The time step (s)."""
    @property
    def params(self) -> dict[str, Union[float, tuple[float, float]]]:
        """The physical parameters."""
    def tcp_position(self, x: _ArrayLike) -> _F64Array:
        """Position of the tool centre point (end of link 2) in the world frame, shape ``(2,)``."""

@final
class LinearDynamics(Dynamics):
    """Linear dynamics ``x+ = A x + B u + c``, at any size.

    ``A`` has shape ``(nx, nx)``, ``B`` ``(nx, nu)``, ``c`` ``(nx,)`` (zeros when omitted), with
    ``1 <= nx <= 1024`` and ``1 <= nu <= 512`` (an ``InvalidInputError`` names ``A.shape[0]`` or
    ``B.shape[1]`` otherwise). See the module docs for a 7-state, 3-control example.
    """

    def __new__(
        cls, A: _ArrayLike, B: _ArrayLike, c: Optional[_ArrayLike] = None) -> Self: ...
    @property
    def A(self) -> _F64Array:
        """``A``, shape ``(nx, nx)``."""
    @property
    def B(self) -> _F64Array:
        """``B``, shape ``(nx, nu)``."""
    @property
    def c(self) -> _F64Array:
        """``c``, shape ``(nx,)``."""

# --------------------------------------------------------------------------------------------
# Costs
# --------------------------------------------------------------------------------------------

@disjoint_base
class Cost:
    """Base class of every cost term. Not constructible itself.

    Terms are dimension-agnostic specifications: parameters are checked when constructed
    (finite, non-negative weights, square PSD matrices) and against ``(nx, nu)`` when a
    :class:`Problem` is built. A term depends on ``(x, u)`` (``QuadraticCost``,
    ``ControlSquared``, ``CostSum``: running costs only) or on ``x`` only (every other term:
    running or terminal).
    """

    def value(self, x: _ArrayLike, u: Optional[_ArrayLike] = None) -> float:
        """The value at ``(x, u)``. For a state-only term ``u`` may be omitted (the terminal value)."""
    @property
    def state_only(self) -> bool:
        """Whether the term depends on the state only, so it can be a terminal cost."""
    @staticmethod
    def from_function(l: Any, nx: int, nu: Optional[int] = None) -> TapeCost:
        """A cost traced from a Python function: running ``l(x, u)`` with ``nu``, terminal
        ``l(x)`` without (see :meth:`Dynamics.from_function`). Exact gradients and Hessians."""
    @staticmethod
    def from_casadi(l: Any) -> TapeCost:
        """A cost read from a CasADi SX function ``l(x, u)`` (running) or ``l(x)`` (terminal)."""
    @staticmethod
    def from_callable(l: Any, nx: int, nu: Optional[int] = None) -> CallableCost:
        """A cost from a plain Python callable (the slow path): finite-difference gradients and
        Hessians; an exception raised by ``l`` during a solve is raised by the solve."""

@final
class QuadraticCost(Cost):
    """``1/2 (x - x_ref)^T Q (x - x_ref) + 1/2 (u - u_ref)^T R (u - u_ref)``.

    ``Q`` ``(nx, nx)`` and ``R`` ``(nu, nu)`` must be symmetric PSD; a 1-D array is taken as the
    diagonal. References default to zero. Any size (``nx <= 1024``, ``nu <= 512``); the sizes
    must match the problem's.
    """

    def __new__(
        cls,
        Q: _ArrayLike,
        R: _ArrayLike,
        x_ref: Optional[_ArrayLike] = None,
        u_ref: Optional[_ArrayLike] = None,
    ) -> Self: ...
    @property
    def Q(self) -> _F64Array:
        """``Q``, shape ``(nx, nx)``."""
    @property
    def R(self) -> _F64Array:
        """``R``, shape ``(nu, nu)``."""
    @property
    def x_ref(self) -> Optional[_F64Array]:
        """The state reference, or ``None`` for zero."""
    @property
    def u_ref(self) -> Optional[_F64Array]:
        """The control reference, or ``None`` for zero."""

@final
class QuadraticTerminal(Cost):
    """Terminal ``1/2 (x - x_ref)^T Qf (x - x_ref)``; ``Qf`` symmetric PSD (1-D: the diagonal).
    Any size (``nx <= 1024``)."""

    def __new__(
        cls, Qf: _ArrayLike, x_ref: Optional[_ArrayLike] = None) -> Self: ...
    @property
    def Qf(self) -> _F64Array:
        """``Qf``, shape ``(nx, nx)``."""
    @property
    def x_ref(self) -> Optional[_F64Array]:
        """The state reference, or ``None`` for zero."""

@final
class ControlSquared(Cost):
    """``weight * sum(u**2)`` (DDPEN eq. 5); ``weight >= 0``. Any size."""

    def __new__(
        cls, weight: float) -> Self: ...
    @property
    def weight(self) -> float:
        """The weight."""

@final
class SmoothDistance(Cost):
    """``weight * sqrt(|p - target|^2 + eps^2)`` with ``p = (x[i0], x[i1])`` for
    ``indices = (i0, i1)``: the DDPEN goal and sub-goal costs (eqs. 6, 9). Running or terminal.
    Like :class:`ObstacleHinge` and :class:`CirclePenalty`, only for the state sizes of
    :func:`supported_dimensions` (an ``InvalidInputError`` at other sizes)."""

    def __new__(
        cls,
        target: _ArrayLike,
        indices: tuple[int, int] = (0, 1),
        eps: float = 1e-3,
        weight: float = 1.0,
    ) -> Self: ...
    @property
    def target(self) -> tuple[float, float]:
        """The target point."""
    @property
    def indices(self) -> tuple[int, int]:
        """The state indices of the position."""
    @property
    def eps(self) -> float:
        """The smoothing ``eps > 0``."""
    @property
    def weight(self) -> float:
        """The weight."""

@final
class ObstacleHinge(Cost):
    """``weight * sum_o max(0, margin - |p - o|)`` over obstacle points ``points`` (shape
    ``(m, 2)``): the DDPEN obstacle cost (eq. 7). Running or terminal."""

    def __new__(
        cls,
        points: _ArrayLike,
        margin: float,
        indices: tuple[int, int] = (0, 1),
        weight: float = 1.0,
    ) -> Self: ...
    @property
    def margin(self) -> float:
        """The activation distance."""
    @property
    def weight(self) -> float:
        """The weight."""

@final
class CirclePenalty(Cost):
    """Squared-hinge penalty ``weight * sum_o max(0, r_o^2 - |p - o|^2)^2`` on circles
    ``circles`` (shape ``(m, 3)``, rows ``(ox, oy, r)``), with a Gauss-Newton Hessian. Raise
    ``weight`` over warm-started solves to approach the constraint ``|p - o| >= r``."""

    def __new__(
        cls, circles: _ArrayLike, indices: tuple[int, int] = (0, 1), weight: float = 1.0) -> Self: ...
    @property
    def weight(self) -> float:
        """The weight."""

@final
class CostSum(Cost):
    """Weighted sum ``sum_i w_i l_i(x, u)`` of running terms, from ``[(w_i, term_i), ...]``
    with ``w_i >= 0``."""

    def __new__(
        cls, terms: Sequence[tuple[float, Cost]]) -> Self: ...
    def __len__(self) -> int: ...

@final
class TerminalSum(Cost):
    """Weighted sum ``sum_i w_i l_i(x)`` of state-only terms: a terminal (or running) cost."""

    def __new__(
        cls, terms: Sequence[tuple[float, Cost]]) -> Self: ...
    def __len__(self) -> int: ...

# --------------------------------------------------------------------------------------------
# Problem, solver, solution
# --------------------------------------------------------------------------------------------

@final
class Problem:
    """An optimal control problem::

        min  sum_{k<N} l_k(x_k, u_k) + l_N(x_N)
        s.t. x_{k+1} = f_k(x_k, u_k),  x_0 = x0,  u_min <= u_k <= u_max

    ``dynamics`` and ``running_cost`` are one object for every knot or lists of length
    ``horizon``; ``terminal_cost`` must be state-only. ``u_min``/``u_max`` are arrays ``(nu,)``
    or scalars, ``+-inf`` for no bound (control limits are handled by box-DDP). ``nx`` and
    ``nu`` are the dynamics' (any size, see the module docs); every other piece must agree. Errors
    name the argument: ``ShapeError`` for wrong shapes, list lengths and pieces of another size
    (``running_cost.Q has shape (6, 6), expected (7, 7)``), ``NotFiniteError`` for NaN,
    ``InvalidInputError`` for ``horizon < 1``, wrong types and non-PSD weights.
    """

    def __new__(
        cls,
        x0: _ArrayLike,
        dynamics: Union[Dynamics, Sequence[Dynamics]],
        running_cost: Union[Cost, Sequence[Cost]],
        terminal_cost: Cost,
        horizon: int,
        u_min: Optional[_ArrayLike] = None,
        u_max: Optional[_ArrayLike] = None,
    ) -> Self: ...
    @property
    def nx(self) -> int:
        """Number of states."""
    @property
    def nu(self) -> int:
        """Number of controls."""
    @property
    def horizon(self) -> int:
        """The horizon ``N`` (number of controls)."""
    @property
    def x0(self) -> _F64Array:
        """The initial state (a copy), shape ``(nx,)``."""
    @property
    def bounds(self) -> Optional[tuple[_F64Array, _F64Array]]:
        """The control bounds ``(u_min, u_max)``, or ``None``."""
    def set_x0(self, x0: _ArrayLike) -> None:
        """Replaces the initial state (receding horizon); every solver of this problem sees it."""
    def rollout(self, us: _ArrayLike) -> _F64Array:
        """Simulates ``us`` (shape ``(N, nu)``) from ``x0``; returns ``xs``, shape ``(N+1, nx)``."""
    def cost(self, xs: _ArrayLike, us: _ArrayLike) -> float:
        """The objective of a trajectory (``xs`` ``(N+1, nx)``, ``us`` ``(N, nu)``); the
        dynamics and bounds are not checked."""

@final
class Solver:
    """iLQR / full DDP / box-DDP solver for one :class:`Problem`, its workspace allocated once.

    Settings (validated; an ``InvalidInputError`` names the field):

    - ``method``: ``"ilqr"`` (Gauss-Newton) or ``"ddp"`` (adds second-order dynamics terms);
    - ``shooting``: ``"single"`` (the states are the rollout of the controls) or ``"multiple"``
      (states and controls are stepped together, the dynamics defects close as the solve
      converges, a filter line search accepts steps; Giftthaler et al. 2018, Wächter and Biegler
      2006). Multiple shooting takes fewer iterations on swing-ups through unstable dynamics
      (the cart-pole of ``py/examples``: 24 instead of 60) and more on others (the acrobot: 122
      instead of 86); it does not take control bounds (an ``InvalidInputError`` names
      ``settings.shooting``). :attr:`Solution.defect` reports the largest defect left;
    - ``max_iterations``: iteration limit (accepted or rejected steps);
    - ``gradient_tolerance``: converged when ``sum_k |Q_u|^2`` falls below it (Crocoddyl's ``th_stop``);
    - ``cost_tolerance``: converged when a step changes the cost by less than this relative to ``1 + |J|``;
    - ``mu_init``, ``mu_min``, ``mu_max``, ``mu_factor``: Tassa's regularisation schedule;
    - ``regularization``: ``"control"`` (``Q_uu + mu I``) or ``"state"`` (``V_xx + mu I``);
    - ``step_factor``, ``step_min``, ``armijo``: the backtracking line search;
    - ``box_qp_iterations``: iteration limit of the box QP (control limits);
    - ``derivative_threads``: threads that compute the dynamics and cost derivatives of the knots
      (Crocoddyl's ``nthreads``); 1 (the default) computes them on the calling thread. Results are
      bit-identical for any count. It pays only where the derivative phase is a large share of an
      iteration: expensive models (traced, CasADi) or long horizons; for the built-in robots at
      ``N = 100`` it costs more than it saves (README, "Scale"). Problems with
      ``from_callable`` models compute their derivatives on the calling thread (they need the GIL).

    The defaults are Rust's (``ddp_core::Settings::default()``, also :func:`default_settings`).
    Problems of any size are solved (see the module docs). A solver is used by one thread at a
    time; the GIL is released during :meth:`solve`, so solvers in different threads run in
    parallel.
    """

    def __new__(
        cls,
        problem: Problem,
        method: str = "ilqr",
        shooting: str = "single",
        max_iterations: int = 200,
        gradient_tolerance: float = 1e-9,
        cost_tolerance: float = 1e-14,
        mu_init: float = 0.0,
        mu_min: float = 1e-9,
        mu_max: float = 1e10,
        mu_factor: float = 1.6,
        regularization: str = "control",
        step_factor: float = 0.5,
        step_min: float = 0.0009765625,
        armijo: float = 1e-4,
        box_qp_iterations: int = 100,
        derivative_threads: int = 1,
    ) -> Self: ...
    def __getnewargs_ex__(self) -> tuple[tuple[Problem], dict[str, Any]]:
        """Pickles as its problem and settings; the unpickled solver has a fresh workspace."""
    def solve(
        self, us0: Optional[_ArrayLike] = None, warm_start: bool = False, xs0: Optional[_ArrayLike] = None
    ) -> Solution:
        """Solves the problem.

        The initial guess is ``us0`` if given (shape ``(N, nu)``), else the controls of the last
        solve when ``warm_start`` is true, else zeros. Without ``warm_start`` every solve is a
        cold start (as after :meth:`reset`), ``us0`` or not. With ``shooting="multiple"``,
        ``xs0`` (shape ``(N+1, nx)``; ``xs0[0]`` is replaced by ``x0``) starts the solve from
        these states instead of the rollout of the controls, e.g. a straight line to the goal;
        the solve closes the defects between them. ``xs0`` under single shooting is an
        ``InvalidInputError`` naming ``settings.shooting``. Bad input raises; the outcome of the
        algorithm is :attr:`Solution.status`.
        """
    def shift(self) -> None:
        """Receding horizon: drops the first knot of the last solution and repeats the last
        control, so ``solve(warm_start=True)`` from the next state starts from it."""
    def reset(self) -> None:
        """Zeros the stored initial guess and gains."""
    @property
    def controls(self) -> _F64Array:
        """The controls held for the next warm start, shape ``(N, nu)``."""
    @property
    def problem(self) -> Problem:
        """The problem this solver solves."""
    @property
    def settings(self) -> dict[str, Union[str, int, float]]:
        """The settings."""
    @property
    def nx(self) -> int:
        """Number of states."""
    @property
    def nu(self) -> int:
        """Number of controls."""
    @property
    def horizon(self) -> int:
        """The horizon ``N``."""

@final
class Solution:
    """The result of :meth:`Solver.solve`.

    The feedback law around the solution is ``u_k = us[k] + K[k] @ (x_k - xs[k])``.
    """

    @property
    def xs(self) -> _F64Array:
        """States ``x_0 .. x_N``, shape ``(N+1, nx)``."""
    @property
    def us(self) -> _F64Array:
        """Controls ``u_0 .. u_{N-1}``, shape ``(N, nu)``."""
    @property
    def K(self) -> _F64Array:
        """Feedback gains, shape ``(N, nu, nx)``."""
    @property
    def k(self) -> _F64Array:
        """Feed-forward terms of the last backward pass, shape ``(N, nu)``."""
    @property
    def status(self) -> str:
        """``"converged"``, ``"max_iterations"``, ``"regularization_limit"``,
        ``"line_search_failed"`` or ``"numerical_error"``."""
    @property
    def converged(self) -> bool:
        """Whether :attr:`status` is ``"converged"``."""
    @property
    def iterations(self) -> int:
        """Accepted steps."""
    @property
    def cost(self) -> float:
        """Final cost."""
    @property
    def initial_cost(self) -> float:
        """Cost of the initial rollout."""
    @property
    def gradient(self) -> float:
        """Final ``sum_k |Q_u|^2`` (free controls only under bounds)."""
    @property
    def mu(self) -> float:
        """Final regularisation."""
    @property
    def backward_passes(self) -> int:
        """Backward passes computed, including regularisation retries."""
    @property
    def forward_passes(self) -> int:
        """Forward rollouts in line searches."""
    @property
    def defect(self) -> float:
        """Largest entry of the dynamics defects ``f(x_k, u_k) - x_{k+1}`` of :attr:`xs`,
        :attr:`us`: 0 under single shooting (``xs`` is the rollout of ``us``), at most 1e-9 after
        a converged multiple-shooting solve."""
    @property
    def solve_time(self) -> float:
        """Wall time of the solve inside Rust (s)."""
    @property
    def cost_history(self) -> _F64Array:
        """Cost of the initial rollout and after every accepted step."""
    def table(self) -> str:
        """The iteration table (no timings, so it is deterministic)."""

def default_settings(kind: str = "Solver") -> dict[str, Any]:
    """The defaults of the keyword arguments of ``kind``: ``"Solver"``
    (``ddp_core::Settings::default()``), ``"SafeCddpSolver"`` (``safe_cddp::Settings::default()``)
    or ``"Mpc"`` (``safe_cddp::mpc::MpcSettings::default()``). The classes' signatures take their
    defaults from the same Rust values."""

def solve_batch(
    problems: Sequence[Problem],
    *,
    threads: Optional[int] = None,
    method: str = "ilqr",
    shooting: str = "single",
    max_iterations: int = 200,
    gradient_tolerance: float = 1e-9,
    cost_tolerance: float = 1e-14,
    mu_init: float = 0.0,
    mu_min: float = 1e-9,
    mu_max: float = 1e10,
    mu_factor: float = 1.6,
    regularization: str = "control",
    step_factor: float = 0.5,
    step_min: float = 0.0009765625,
    armijo: float = 1e-4,
    box_qp_iterations: int = 100,
) -> list[Solution]:
    """Solves many problems of one structure (same ``nx``, ``nu`` and horizon; different ``x0``,
    costs, targets or models) on ``threads`` threads in one call, each from a cold start with the
    settings of :class:`Solver` (same keywords and defaults), and returns their
    :class:`Solution` s in order. The GIL is released meanwhile.

    Each solution equals ``Solver(problem, **settings).solve()`` for that problem alone, bit for
    bit, whatever the thread count: every worker thread owns one workspace, reset before each
    problem. ``threads=None`` uses ``RAYON_NUM_THREADS`` when set, else every core.

    Errors, before any solve: an empty list or an item that is not a :class:`Problem`
    (``InvalidInputError`` naming ``problems`` or ``problems[i]``), a problem whose sizes or
    horizon differ from the first's (``ShapeError`` naming ``problems[i]``), ``threads < 1``
    (naming ``threads``), invalid settings. An exception raised by a ``from_callable`` model is
    raised as itself.
    """

def solve_batch_safe(
    problems: Sequence[Problem],
    constraints: Union[Sequence[Constraint], Sequence[Sequence[Constraint]]],
    tightening: Optional[Tightening] = None,
    *,
    threads: Optional[int] = None,
    method: str = "ilqr",
    max_iterations: int = 200,
    constraint_tolerance: float = 1e-8,
    qp_method: str = "fast",
    warm_up: str = "portfolio",
    portfolio_polish: bool = True,
    portfolio_new_side: Optional[float] = 1.2,
    portfolio_threads: int = 1,
    portfolio_third_mu: Optional[float] = 0.003,
    portfolio_apart: float = 1e-3,
    portfolio_flip: Optional[float] = 1.5,
    portfolio_flip_apart: float = 1.25,
    portfolio_flip_starts: int = 2,
    portfolio_mirror: Optional[int] = 5,
    portfolio_plan: Optional[int] = 5,
    portfolio_abandon: Optional[float] = 0.3,
    portfolio_dual_bound: Optional[float] = 0.01,
    barrier_funnel: Optional[float] = 0.03,
    barrier_mu_init: float = 0.03,
    barrier_relaxation: float = 0.1,
    al_inner_progress: float = 1.0,
) -> list[SafeSolution]:
    """Solves many Safe-CDDP problems of one structure on ``threads`` threads in one call, each
    from a cold start with the settings of :class:`SafeCddpSolver` (same keywords and defaults),
    and returns their :class:`SafeSolution` s in order. The GIL is released meanwhile.

    ``constraints`` is one list for every problem, or a list of lists, one per problem;
    ``tightening`` (or None) applies to every problem. Each solution equals
    ``SafeCddpSolver(problem, constraints, tightening, **settings).solve()`` alone, bit for bit,
    whatever the thread count (each problem gets a fresh Safe-CDDP workspace on its worker).
    Errors as :func:`solve_batch`, and constraints that do not fit the problems.
    """

def supported_dimensions() -> list[tuple[int, int]]:
    """The ``(nx, nu)`` pairs compiled into this build: the fixed-size fast path of the built-in
    robots and of the robots users bring most (``(4, 1)``: a cart-pole or an acrobot; ``(6, 2)``:
    a planar quadrotor). Every other size ``nx >= 1, nu >= 1`` (up to 1024 states and 512 controls) runs at
    run-time sizes, through the same Rust code."""

# --------------------------------------------------------------------------------------------
# Bezier curves, splines, motion profiles (Queen Elizabeth's School (2022)); public as
# ``ddpkit.bezier``
# --------------------------------------------------------------------------------------------

BEZIER_DEFAULT_ACCURACY: float
"""The arc-length accuracy the ``bezier`` crate suggests (absolute, length units): ``1e-9``."""

@final
class Bezier:
    """A Bézier curve of any degree on ``t in [0, 1]``, from control points of shape ``(n, 2)``,
    ``1 <= n <= 1000`` (the Bernstein form overflows a little beyond).

    Cubics (``n = 4``) use the specialised engine (closed-form hodograph roots, a-priori
    Gauss-Legendre). Vectorised methods take ``t`` as a number (giving a number, or a ``(2,)``
    point) or an array of any shape ``S`` (giving shape ``S``, or ``S + (2,)`` for points),
    looping in Rust with the GIL released. NaN/inf raise ``NotFiniteError``; accuracies must be
    > 0 (``InvalidInputError`` naming ``accuracy``).
    """

    def __new__(cls, points: _ArrayLike) -> Self: ...
    @property
    def points(self) -> _F64Array:
        """The control points, shape ``(n, 2)``."""
    @property
    def degree(self) -> int:
        """The degree, ``n - 1``."""
    def eval(self, t: Union[float, _Params]) -> _F64Array:
        """``B(t)`` (Bernstein form): ``(2,)`` for a number, ``t.shape + (2,)`` for an array."""
    def eval_de_casteljau(self, t: Union[float, _Params]) -> _F64Array:
        """``B(t)`` by De Casteljau's repeated linear interpolation (same shapes as :meth:`eval`)."""
    def derivative(self, t: Union[float, _Params], order: int = 1) -> _F64Array:
        """The ``order``-th derivative ``d^order B / dt^order`` (``order = 0`` is :meth:`eval`)."""
    def velocity(self, t: Union[float, _Params]) -> _F64Array:
        """``B'(t)`` (same shapes as :meth:`eval`)."""
    def acceleration(self, t: Union[float, _Params]) -> _F64Array:
        """``B''(t)``."""
    def jerk(self, t: Union[float, _Params]) -> _F64Array:
        """``B'''(t)``."""
    @overload
    def speed(self, t: float) -> float:
        """Speed ``|B'(t)|``."""
    @overload
    def speed(self, t: _Params) -> _F64Array: ...
    @overload
    def curvature(self, t: float) -> float:
        """Signed curvature ``(x' y'' - y' x'') / (x'^2 + y'^2)^(3/2)`` (the paper's ``K(t)``
        without the absolute value; ``0`` where the speed vanishes)."""
    @overload
    def curvature(self, t: _Params) -> _F64Array: ...
    def hodograph(self) -> Bezier:
        """The derivative curve, degree one less (a constant curve gives the zero point)."""
    def extrema(self) -> _F64Array:
        """Parameters in ``(0, 1)``, ascending, where ``x'(t) = 0`` or ``y'(t) = 0``."""
    def bounding_box(self) -> tuple[float, float, float, float]:
        """The exact bounding box ``(x_min, y_min, x_max, y_max)``."""
    def subdivide(self, t: float) -> tuple[Bezier, Bezier]:
        """Splits at ``t`` into the curves on ``[0, t]`` and ``[t, 1]``."""
    def subsegment(self, t0: float, t1: float) -> Bezier:
        """The part between ``t0`` and ``t1`` reparametrised to ``[0, 1]`` (reversed if ``t1 < t0``)."""
    def elevate(self) -> Bezier:
        """Exact degree elevation: the same curve with one more control point (at most 1000)."""
    def arclen(self, accuracy: float = 1e-9) -> float:
        """Arc length by adaptive Gauss-Legendre, absolute error at most ``accuracy``."""
    def arclen_simpson(self, accuracy: float = 1e-9) -> float:
        """Arc length by composite Simpson's rule as in the paper (intervals doubled until two
        estimates differ by less than ``15 * accuracy``; at most ``2**20`` intervals)."""
    def arclen_range(self, t0: float, t1: float, accuracy: float = 1e-9) -> float:
        """Length between ``t0`` and ``t1`` (negative when ``t1 < t0``)."""
    @overload
    def inv_arclen(self, s: float, accuracy: float = 1e-9) -> float:
        """The parameter ``t(s)`` at which the length from the start is ``s`` (clamped to
        ``[0, arclen]``), to ``accuracy`` in length; vectorised over ``s``."""
    @overload
    def inv_arclen(self, s: _Params, accuracy: float = 1e-9) -> _F64Array: ...
    def resample_uniform(self, n: int, accuracy: float = 1e-9) -> _F64Array:
        """``n`` parameters (ends included) splitting the curve into ``n - 1`` equal lengths."""
    def resample_points(self, n: int, accuracy: float = 1e-9) -> _F64Array:
        """The points at :meth:`resample_uniform`, shape ``(n, 2)``."""

def simd_level() -> str:
    """The instructions the arc-length sums run with: ``"avx512"``, ``"avx2+fma"`` or ``"portable"``."""
    ...

def arclen_batch(control_points: _ArrayLike, accuracy: float = 1e-9, method: str = "gauss") -> _F64Array:
    """Arc lengths of ``m`` curves with ``n`` control points each, ``control_points`` of shape
    ``(m, n, 2)``; returns ``(m,)``. ``method``: ``"gauss"`` (adaptive Gauss-Legendre) or
    ``"simpson"``. One call, the GIL released."""

@final
class Spline:
    """A chain of cubic Bézier segments through waypoints; segment ``i`` covers the global
    parameter ``u in [i, i + 1]``.

    Build one with :meth:`catmull_rom` (C1), :meth:`c2_natural`, :meth:`c2_clamped` (C2),
    :meth:`hermite` (C1, given tangents) or from joined segments ``(k, 4, 2)``.
    """

    def __new__(cls, segments: _ArrayLike) -> Self: ...
    @staticmethod
    def catmull_rom(waypoints: _ArrayLike) -> Spline:
        """The uniform Catmull-Rom spline (C1) through ``waypoints`` ``(n, 2)``, ``n >= 2``."""
    @staticmethod
    def c2_natural(waypoints: _ArrayLike) -> Spline:
        """The natural C2 spline (zero second derivative at both ends)."""
    @staticmethod
    def c2_clamped(waypoints: _ArrayLike, start_tangent: _ArrayLike, end_tangent: _ArrayLike) -> Spline:
        """The clamped C2 spline with end derivatives ``start_tangent``, ``end_tangent`` ``(2,)``."""
    @staticmethod
    def hermite(waypoints: _ArrayLike, tangents: _ArrayLike) -> Spline:
        """The C1 spline with derivative ``tangents[i]`` at ``waypoints[i]`` (both ``(n, 2)``):
        segment ``i`` is ``(w_i, w_i + d_i / 3, w_{i+1} - d_{i+1} / 3, w_{i+1})``."""
    @property
    def segments(self) -> _F64Array:
        """Control points of the segments, shape ``(k, 4, 2)``."""
    @property
    def waypoints(self) -> _F64Array:
        """The joints, shape ``(k + 1, 2)``."""
    @property
    def tangents(self) -> _F64Array:
        """Derivatives at the joints, shape ``(k + 1, 2)``."""
    def __len__(self) -> int: ...
    def segment(self, index: int) -> Bezier:
        """Segment ``index`` (negative counts from the end) as a cubic :class:`Bezier`."""
    def eval(self, u: Union[float, _Params]) -> _F64Array:
        """The point at global parameter ``u`` (clamped to ``[0, k]``); shapes as :meth:`Bezier.eval`."""
    @overload
    def curvature(self, u: float) -> float:
        """Signed curvature at global parameter ``u``."""
    @overload
    def curvature(self, u: _Params) -> _F64Array: ...
    def continuity(self, tolerance: float = 1e-9) -> str:
        """``"C0"``, ``"C1"`` or ``"C2"``: the class holding at every joint."""
    def segment_lengths(self, accuracy: float = 1e-9) -> _F64Array:
        """Length of each segment, shape ``(k,)``."""
    def arclen(self, accuracy: float = 1e-9) -> float:
        """Total length, absolute error at most ``accuracy``."""
    def bounding_box(self) -> tuple[float, float, float, float]:
        """The exact bounding box ``(x_min, y_min, x_max, y_max)``."""
    def jerk_cost_param(self) -> float:
        """Parametric jerk ``sum_i int_0^1 |B_i'''(t)|^2 dt`` (unit time per segment)."""
    def curvature_sum_param(self, samples_per_segment: int = 100) -> float:
        """Sum of ``|curvature|`` at ``samples_per_segment`` parameters uniform in each segment."""

@final
class SigmoidProfile:
    """The paper's sigmoid distance-time profile ``s(T) = L S(T / T_f)``,
    ``S(tau) = (sigma(tau) - sigma(0)) / (sigma(1) - sigma(0))``,
    ``sigma(tau) = 1 / (1 + exp(-m (tau - k)))``: steepness ``m >= 0``, midpoint ``k``."""

    def __new__(cls, length: float, m: float, duration: float, k: float = 0.5) -> Self: ...
    @staticmethod
    def with_max_speed(length: float, m: float, max_speed: float = 1.0, k: float = 0.5) -> SigmoidProfile:
        """The shortest profile over ``length`` whose peak speed is ``max_speed``."""
    @staticmethod
    def max_steepness(length: float, duration: float, max_speed: float, k: float = 0.5) -> float:
        """The largest ``m`` keeping the peak speed at or below ``max_speed`` for ``duration``."""
    @property
    def length(self) -> float:
        """Path length ``L``."""
    @property
    def m(self) -> float:
        """Steepness ``m``."""
    @property
    def k(self) -> float:
        """Midpoint ``k`` (fraction of the duration)."""
    @property
    def duration(self) -> float:
        """Duration ``T_f``."""
    @property
    def peak_speed(self) -> float:
        """Peak speed."""
    @overload
    def distance(self, time: float) -> float:
        """Distance ``s(T)`` (0 before the start, ``L`` after the end); vectorised."""
    @overload
    def distance(self, time: _Params) -> _F64Array: ...
    @overload
    def derivatives(self, time: float) -> tuple[float, float, float, float]:
        """``(s, s', s'', s''')`` at ``time``: distance, speed, acceleration, jerk."""
    @overload
    def derivatives(self, time: _Params) -> tuple[_F64Array, _F64Array, _F64Array, _F64Array]: ...
    @overload
    def time_at_distance(self, s: float) -> float:
        """The time at which the distance is ``s`` (clamped to ``[0, L]``); vectorised."""
    @overload
    def time_at_distance(self, s: _Params) -> _F64Array: ...

@final
class TrajectorySamples:
    """Kinematic samples of a :class:`Trajectory`, one row per time (arrays of length ``n``)."""

    def __len__(self) -> int: ...
    @property
    def time(self) -> _F64Array:
        """Times, ``(n,)``."""
    @property
    def distance(self) -> _F64Array:
        """Distance along the path, ``(n,)``."""
    @property
    def segment(self) -> npt.NDArray[np.int64]:
        """Segment index, ``(n,)``."""
    @property
    def t(self) -> _F64Array:
        """Local parameter in the segment, ``(n,)``."""
    @property
    def position(self) -> _F64Array:
        """Position, ``(n, 2)``."""
    @property
    def velocity(self) -> _F64Array:
        """Velocity, ``(n, 2)``."""
    @property
    def acceleration(self) -> _F64Array:
        """Acceleration, ``(n, 2)``."""
    @property
    def jerk(self) -> _F64Array:
        """Jerk (tangential and normal), ``(n, 2)``."""
    @property
    def speed(self) -> _F64Array:
        """Speed ``s'``, ``(n,)``."""
    @property
    def tangential_acceleration(self) -> _F64Array:
        """Tangential acceleration ``s''``, ``(n,)``."""
    @property
    def heading(self) -> _F64Array:
        """Heading (angle of the unit tangent), ``(n,)``."""
    @property
    def curvature(self) -> _F64Array:
        """Signed curvature, ``(n,)``."""
    @property
    def yaw_rate(self) -> _F64Array:
        """Yaw rate ``curvature * speed``, ``(n,)``."""

@final
class Trajectory:
    """A :class:`Spline` traversed with a :class:`SigmoidProfile`: the time-parametrised
    reference (or initial guess) for DDP."""

    def __new__(cls, spline: Spline, profile: SigmoidProfile) -> Self: ...
    @staticmethod
    def with_sigmoid(spline: Spline, m: float = 10.0, k: float = 0.5, max_speed: float = 1.0) -> Trajectory:
        """``spline`` with a sigmoid of steepness ``m``, midpoint ``k``, peak speed ``max_speed``."""
    @property
    def spline(self) -> Spline:
        """The path."""
    @property
    def profile(self) -> SigmoidProfile:
        """The motion profile."""
    @property
    def duration(self) -> float:
        """Duration ``T_f``."""
    @property
    def length(self) -> float:
        """Path length."""
    def position(self, time: Union[float, _Params]) -> _F64Array:
        """Position at ``time`` (held at the ends outside ``[0, T_f]``)."""
    def sample(self, times: Union[float, _ArrayLike]) -> TrajectorySamples:
        """Full kinematic state at each of ``times`` (a number or a 1-D array)."""
    def sample_grid(self, dt: float, steps: Optional[int] = None) -> TrajectorySamples:
        """Samples at ``T_k = k dt``, ``k = 0..steps`` (default: enough to cover the duration),
        heading unwrapped."""
    def unicycle(self, dt: float, steps: Optional[int] = None) -> tuple[_F64Array, _F64Array]:
        """Unicycle states ``(x, y, theta)`` ``(steps + 1, 3)`` and controls ``(v, omega)``
        ``(steps, 2)`` on the grid ``T_k = k dt`` (for :class:`Unicycle`)."""
    def car(self, dt: float, steps: Optional[int] = None) -> tuple[_F64Array, _F64Array]:
        """Car states ``(x, y, theta, v)`` ``(steps + 1, 4)`` and controls ``(omega, a)``
        ``(steps, 2)`` (for :class:`Car`)."""
    def jerk_cost_discrete(self, samples: int = 100) -> float:
        """The paper's discrete jerk (tangential speed, second differences, ``sum j_k^2 dT``)."""
    def jerk_cost_integral(self, accuracy: float = 1e-8) -> float:
        """``int |x'''(T)|^2 dT`` of the full 2D jerk, to relative ``accuracy``."""
    def curvature_sum(self, samples: int = 100) -> float:
        """The paper's curvature measure: ``sum |curvature|`` at ``samples`` uniform times."""

def spline_cost(
    spline: Spline,
    *,
    jerk_weight: float = 1.0,
    curvature_weight: float = 0.01,
    m: float = 10.0,
    k: float = 0.5,
    max_speed: float = 1.0,
    samples: int = 100,
    jerk: str = "integral",
) -> float:
    """The objective of Queen Elizabeth's School (2022) for ``spline`` with a sigmoid profile:
    ``jerk_weight * J + curvature_weight * K`` (``J``: ``"integral"`` 2D jerk or the paper's
    ``"discrete"`` one; ``K``: sum of ``|curvature|`` at ``samples`` uniform times)."""

@final
class SplineOptimizeResult:
    """The result of :func:`optimize_spline`."""

    @property
    def spline(self) -> Spline:
        """The optimised spline (through the same waypoints)."""
    @property
    def initial_cost(self) -> float:
        """Cost of the starting spline."""
    @property
    def cost(self) -> float:
        """Final cost."""
    @property
    def iterations(self) -> int:
        """BFGS iterations."""
    @property
    def evaluations(self) -> int:
        """Cost evaluations."""
    @property
    def status(self) -> str:
        """``"converged"``, ``"max_iterations"`` or ``"line_search_failed"``."""

def optimize_spline(
    waypoints: _ArrayLike,
    *,
    continuity: str = "C1",
    max_iterations: int = 100,
    gradient_tolerance: float = 1e-6,
    jerk_weight: float = 1.0,
    curvature_weight: float = 0.01,
    m: float = 10.0,
    k: float = 0.5,
    max_speed: float = 1.0,
    samples: int = 100,
    jerk: str = "integral",
) -> SplineOptimizeResult:
    """The direct optimiser: BFGS on the free tangents of a spline through ``waypoints``
    (C1: all of them; C2: the end ones), minimising :func:`spline_cost` from Catmull-Rom (C1)
    or the natural spline (C2). The GIL is released."""

# --------------------------------------------------------------------------------------------
# Safe-CDDP of Alcan and Kyrki (2022): constraints, the constrained solver, chance-constraint
# tightening, MPC
# --------------------------------------------------------------------------------------------

@disjoint_base
class Constraint:
    """Base class of the Safe-CDDP constraints ``g(x, u) <= 0``. Not constructible itself.

    Constraints are dimension-agnostic specifications, checked against the problem's
    ``(nx, nu)`` when a :class:`SafeCddpSolver` or :class:`Mpc` is built. State constraints
    (obstacles, state boxes) are imposed on ``x_1 .. x_N`` (the solver moves each to the knot
    whose control can change it); a :class:`ControlBox` constrains ``(x_k, u_k)``.
    """

    @staticmethod
    def from_function(g: Any, nx: int, nu: Optional[int] = None) -> TapeConstraint:
        """Constraints ``g(x, u) <= 0`` traced from a Python function returning a number or a 1-D
        array of rows (``g(x)`` when ``nu`` is None). Rows not depending on ``u`` are state-only
        (imposed on ``x_1 .. x_N``, as the obstacles)."""
    @staticmethod
    @staticmethod
    def from_callable(g: Any, nx: int, nu: Optional[int] = None, rows: int = 1) -> CallableConstraint:
        """Constraints ``g(x, u) <= 0`` from a plain Python callable returning ``rows`` values
        (``g(x)`` when ``nu`` is None: state-only rows, imposed on ``x_1 .. x_N``): the slow path
        for what cannot be traced. Jacobians by central finite differences; an exception raised
        by ``g`` during a solve is raised by the solve. Pickles where ``g`` does."""
    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]:
        """Pickles as the call that builds the constraint again."""
    def __eq__(self, value: object, /) -> bool:
        """Equal when the same constraint with equal parameters."""
    def from_casadi(g: Any) -> TapeConstraint:
        """Constraints read from a CasADi SX function ``g(x, u)`` or ``g(x)``; state-only when no
        output depends on ``u``."""

@final
class TapeDynamics(Dynamics):
    """Dynamics from a tape: traced (:meth:`Dynamics.from_function`), imported from CasADi
    (:meth:`Dynamics.from_casadi`) or loaded (:func:`load_model`). Pickles to an equal object."""

    def to_json(self) -> str:
        """The tape's JSON document (the file format of :meth:`save`)."""
    def save(self, path: Union[str, os.PathLike[str]]) -> None:
        """Writes the model to ``path`` (JSON, whole or not at all); :func:`load_model` and
        ``ddp_tape::TapeModel::load`` in Rust read it."""
    @property
    def n_nodes(self) -> int:
        """Number of tape nodes (after sharing common subexpressions and folding constants)."""
    @property
    def kind(self) -> str:
        """``"dynamics"``, ``"cost"``, ``"terminal_cost"`` or ``"constraint"``."""
    def __reduce__(self) -> tuple[Any, tuple[str]]: ...
    def __eq__(self, value: object, /) -> bool: ...

    def second_order(self, x: _ArrayLike, u: _ArrayLike, lam: _ArrayLike) -> tuple[_F64Array, _F64Array, _F64Array]:
        """``sum_i lam_i d^2 f_i`` at ``(x, u)`` as ``(h_xx, h_ux, h_uu)``."""

@final
class TapeCost(Cost):
    """A running or terminal cost from a tape (:meth:`Cost.from_function`, :meth:`Cost.from_casadi`)."""

    def to_json(self) -> str:
        """The tape's JSON document (the file format of :meth:`save`)."""
    def save(self, path: Union[str, os.PathLike[str]]) -> None:
        """Writes the model to ``path`` (JSON, whole or not at all); :func:`load_model` and
        ``ddp_tape::TapeModel::load`` in Rust read it."""
    @property
    def n_nodes(self) -> int:
        """Number of tape nodes (after sharing common subexpressions and folding constants)."""
    @property
    def kind(self) -> str:
        """``"dynamics"``, ``"cost"``, ``"terminal_cost"`` or ``"constraint"``."""
    def __reduce__(self) -> tuple[Any, tuple[str]]: ...
    def __eq__(self, value: object, /) -> bool: ...

    def derivatives(
        self, x: _ArrayLike, u: Optional[_ArrayLike] = None
    ) -> tuple[float, _F64Array, Optional[_F64Array], _F64Array, Optional[_F64Array], Optional[_F64Array]]:
        """``(l, l_x, l_u, l_xx, l_uu, l_ux)`` at ``(x, u)``; the ``u`` parts are None for a terminal cost."""

@final
class TapeConstraint(Constraint):
    """Constraints from a tape (:meth:`Constraint.from_function`, :meth:`Constraint.from_casadi`)."""

    def to_json(self) -> str:
        """The tape's JSON document (the file format of :meth:`save`)."""
    def save(self, path: Union[str, os.PathLike[str]]) -> None:
        """Writes the model to ``path`` (JSON, whole or not at all); :func:`load_model` and
        ``ddp_tape::TapeModel::load`` in Rust read it."""
    @property
    def n_nodes(self) -> int:
        """Number of tape nodes (after sharing common subexpressions and folding constants)."""
    @property
    def kind(self) -> str:
        """``"dynamics"``, ``"cost"``, ``"terminal_cost"`` or ``"constraint"``."""
    def __reduce__(self) -> tuple[Any, tuple[str]]: ...
    def __eq__(self, value: object, /) -> bool: ...

    def jacobians(self, x: _ArrayLike, u: Optional[_ArrayLike] = None) -> tuple[_F64Array, _F64Array, _F64Array]:
        """``(g, g_x, g_u)`` at ``(x, u)``: shapes ``(m,)``, ``(m, nx)``, ``(m, nu)``."""
    @property
    def dim(self) -> int:
        """Number of rows."""
    @property
    def depends_on_control(self) -> bool:
        """Whether some row depends on ``u`` (else every row is state-only)."""

@final
class CallableDynamics(Dynamics):
    """Dynamics of a plain Python callable (:meth:`Dynamics.from_callable`): the slow path."""

    @property
    def function(self) -> Any:
        """The Python function."""
    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]: ...

@final
class CallableCost(Cost):
    """A cost of a plain Python callable (:meth:`Cost.from_callable`): the slow path."""

    @property
    def function(self) -> Any:
        """The Python function."""
    def __reduce__(self) -> tuple[Any, tuple[Any, ...]]: ...

@final
class CallableConstraint(Constraint):
    """Constraints of a plain Python callable (:meth:`Constraint.from_callable`): the slow path."""

    @property
    def function(self) -> Any:
        """The Python function."""
    @property
    def rows(self) -> int:
        """Number of rows of ``g``."""

def _unpickle_result(kind: str, state: dict[str, Any]) -> Union[Solution, SafeSolution]:
    """Rebuilds a pickled :class:`Solution` or :class:`SafeSolution` from its fields."""

def load_model(path: Union[str, os.PathLike[str]]) -> Union[TapeDynamics, TapeCost, TapeConstraint]:
    """Loads a model saved by ``save`` (or by ``ddp_tape::TapeModel::save`` in Rust); every field
    is checked and a malformed file raises ``InvalidInputError`` naming the field."""

def model_from_json(text: str) -> Union[TapeDynamics, TapeCost, TapeConstraint]:
    """The model of a tape JSON document (what ``to_json`` returns); used by pickling."""

@final
class Circle(Constraint):
    """A circular obstacle on ``p = (x[i0], x[i1])``: ``r^2 - |p - c|^2 <= 0``
    (``form="squared"``, as the benchmark problems) or ``r - |p - c| <= 0``
    (``form="distance"``: the tightening margins are then in metres). ``indices`` defaults to
    ``(0, 1)``."""

    def __new__(
        cls,
        center: _ArrayLike,
        radius: float,
        indices: tuple[int, int] = ...,
        form: str = "squared",
    ) -> Self: ...
    @property
    def center(self) -> tuple[float, float]:
        """The centre ``(x, y)``."""
    @property
    def radius(self) -> float:
        """The radius."""

@final
class ConvexPolygon(Constraint):
    """A convex polygonal obstacle: the convex hull of ``vertices`` (shape ``(n, 2)``, n >= 3)
    inflated by ``margin``; ``margin - sd(p) <= 0`` with the signed distance ``sd``. ``indices``
    defaults to ``(0, 1)``."""

    def __new__(
        cls, vertices: _ArrayLike, margin: float = 0.0, indices: tuple[int, int] = ...
    ) -> Self: ...

@final
class Cylinder(Constraint):
    """A vertical cylinder of ``radius`` around ``center`` standing up to ``height`` on
    ``(x[i0], x[i1], x[i2])`` (z up); a robot may pass beside or over it. The rim is smoothed
    over ``band`` metres. ``indices`` defaults to ``(0, 1, 2)``."""

    def __new__(
        cls,
        center: _ArrayLike,
        radius: float,
        height: float,
        band: float = 0.02,
        indices: tuple[int, int, int] = ...,
    ) -> Self: ...

@final
class StateBox(Constraint):
    """State limits ``lower <= x <= upper`` (shape ``(nx,)`` each; ``+-inf`` for none)."""

    def __new__(cls, lower: _ArrayLike, upper: _ArrayLike) -> Self: ...

@final
class ControlBox(Constraint):
    """Control limits ``lower <= u <= upper`` as constraints (tightened by the closed-loop control
    spread, unlike the problem's hard ``u_min``/``u_max``), shape ``(nu,)`` each."""

    def __new__(cls, lower: _ArrayLike, upper: _ArrayLike) -> Self: ...

@final
class Tightening:
    """Chance-constraint tightening (Safe-CDDP eqs. 19-20)::

        Sigma_{k+1} = (f_x + f_u K_k) Sigma_k (f_x + f_u K_k)^T + sigma_w
        g~ = g + phi^{-1}(beta) sqrt(g_x^T Sigma g_x)

    ``beta`` in (0, 1) (0.5: no margin); ``sigma_w`` the process noise ``(nx, nx)``, symmetric
    PSD; ``gains``: ``"closed_loop"`` (default, Safe-CDDP: the backward pass's feedback with the
    control bounds as its only constraint rows), ``"active_set"`` (eq. 12 with the
    state-constraint rows too; oscillates on relative-degree-2 robots), ``"open_loop"``
    (``K = 0``) or a fixed gain ``(nu, nx)`` (cautious MPC); ``update_every``: ``n2``;
    ``sigma_0``: the initial covariance (default zero).
    """

    def __new__(
        cls,
        beta: float,
        sigma_w: _ArrayLike,
        gains: Union[str, _ArrayLike, None] = None,
        update_every: int = 5,
        sigma_0: Optional[_ArrayLike] = None,
    ) -> Self: ...
    @property
    def beta(self) -> float:
        """``beta``."""
    @property
    def quantile(self) -> float:
        """``phi^{-1}(beta)``, the standard-normal quantile."""
    @property
    def update_every(self) -> int:
        """``n2``: solver iterations between tightenings."""

@final
class SafeCddpSolver:
    """Safe-CDDP: constrained DDP (Xie et al. 2017: KKT backward pass over the active rows,
    per-step QPs in the forward pass) after a warm-up, with the chance-constraint margins of a
    :class:`Tightening` updated every ``n2`` iterations.

    ``constraints`` is a sequence of :class:`Constraint`; ``method`` ``"ilqr"`` or ``"ddp"``
    (full DDP takes Gauss-Newton passes in the barrier homotopy, its second-order terms after);
    ``qp_method`` ``"fast"`` (unconstrained / active-set / Clarabel) or ``"clarabel"``;
    ``warm_up`` how a solve reaches the KKT/QP iterations: ``"augmented_lagrangian"``,
    ``"barrier"`` (log-barrier subproblems first, from ``barrier_mu_init``, the logarithm
    continued as a quadratic below a slack of ``barrier_relaxation``, which lets the trajectory
    cross the obstacles' edges while it finds its way round, then the augmented Lagrangian;
    ``barrier_mu_init=0.003, barrier_relaxation=1e-6`` is the hard barrier of earlier versions,
    which keeps it outside from the first step), ``"portfolio"`` (a cold
    start solved with both, the better solution kept; warm starts use ``"barrier"``'s rule) or
    ``"none"``. Where the portfolio's first two starts end apart (``portfolio_apart``: costs more
    than this apart, relative, but within a factor of 10, or either infeasible; ``0``: always),
    it goes on with ``portfolio_third_mu`` (a third start, the barrier homotopy from this
    ``mu``; ``None``: none) and ``portfolio_polish`` (when the kept solution is the augmented
    Lagrangian's own, one more start from it with cold multipliers), each kept when better: the
    benchmark family's optima on 92 % of problems instead of 89 %, for about 1.3x the
    iterations (``portfolio_third_mu=None, portfolio_polish=False`` for the two starts alone).
    Where the first two agree on a cost above ``portfolio_new_side`` times the augmented
    Lagrangian's after its first inner solve (a relaxation that may still cut through the
    obstacles), the third start still runs its barrier homotopy, and goes on only when it passes
    some obstacle on another side than the kept solution (the unit gradient of a state row at
    its most active state more than 90 degrees from the kept solution's): two starts that agree
    can share a poor optimum (``None``: no third start there).
    Where the kept solution costs more than ``portfolio_flip`` times the optimum without the
    constraints (from the same guess; ``portfolio_flip_apart`` times where the first two starts
    ended apart, at costs more than 1e-6 apart or either infeasible) and there are two or more
    state rows (obstacles), one more start per binding state row, for at most
    ``portfolio_flip_starts`` of them (largest multiplier first), steered to its
    far side (a guide half-space past the row's far boundary along its gradient, for 25
    augmented-Lagrangian iterations from the guess, then lifted) and kept when better: a path
    between two obstacles where every other start went round them (``None``: none, and no
    mirrored start either). After them, behind the same gate, one more start steered to the far
    side of every obstacle at once (each at its own closest approach, for ``portfolio_mirror``
    iterations, then lifted): the way round the other side of a whole cluster, which no single
    flip reaches (``None``: none). Before the flipped starts, behind the same gate, one start
    steered round the obstacles on the sides of the shortest path of the position among them
    (a tangent-graph path from the initial position to the end of the obstacle-free optimum,
    among the ``Circle`` constraints), for ``portfolio_plan`` iterations, then lifted, where the
    kept solution passes one of the circles that path wraps round on its other side, and where
    it is not kept one more steered the same way from the kept solution's controls; a flipped
    start to a side they already steer to is left out, and where the first is kept the mirrored
    start is too (``None``: none). On the benchmark family's replays of 18 seeds they take the
    misses by more than 5 % from 25 to 14 for 1.003x-1.006x the time per problem.
    ``portfolio_abandon``: a flipped, a planned or the mirrored start stops, discarded, once past its 45th
    iteration after the guided ones it is on a path (feasible or not) that costs more than this
    fraction above the kept solution: its guide has taken it round the other side (``None``:
    none stop; the third start is never stopped so). On the benchmark family's replays every
    match against the peers stays, for 0.97x the iterations; 10 of 2520 solutions end higher,
    where an abandoned start would have gone on below the peers' optimum.
    ``portfolio_dual_bound``: a guided or the third start stops, discarded, at the end of a
    converged inner solve of its augmented Lagrangian where the dual bound (the Lagrangian
    ``J + lambda^T g`` with the updated multipliers, a lower bound on the cost of the feasible
    paths near it) is more than this fraction above the kept cost (``None``: no such test). On
    the benchmark family's replays of 18 seeds every solution ends as without it, for 0.95x
    the iterations (with ``portfolio_abandon`` on infeasible paths).
    ``portfolio_threads``: 1, or 2 to run the portfolio's first two starts at once on two
    threads, and its flipped and mirrored starts two at a time (the same solution and
    iterations, less wall time). ``barrier_funnel`` (``None``: no
    limit): after the barrier hands over, the augmented Lagrangian's trial steps may not pass
    this violation (in the constraints' units) where two or more rows are violated at once, so
    it does not step deep into a wall of overlapping obstacles, where its violation would stall:
    on the benchmark family fewer solutions end far above the peers' (59 instead of 68 of 1260
    miss by more than 5 %), at the same iteration count. ``al_inner_progress`` (``0``: off): an
    inner augmented-Lagrangian solve of a cold start ends once a full step moves the merit by
    less than ``al_inner_progress * rho * v^2`` (``v`` the largest violation, below 0.1), what
    the next multiplier update moves it by: 0.81x the iterations on the benchmark family at the
    same optima. The report's
    ``discarded_iterations`` counts the iterations of the portfolio starts that were not kept.
    The workspace is allocated once;
    :meth:`solve` releases the GIL. Defaults: ``safe_cddp::Settings::default()`` (also
    :func:`default_settings` ``("SafeCddpSolver")``). Any ``(nx, nu)`` (see the module docs).
    """

    def __new__(
        cls,
        problem: Problem,
        constraints: Sequence[Constraint],
        tightening: Optional[Tightening] = None,
        method: str = "ilqr",
        max_iterations: int = 200,
        constraint_tolerance: float = 1e-8,
        qp_method: str = "fast",
        warm_up: str = "portfolio",
        portfolio_polish: bool = True,
        portfolio_new_side: Optional[float] = 1.2,
        portfolio_threads: int = 1,
        portfolio_third_mu: Optional[float] = 0.003,
        portfolio_apart: float = 1e-3,
        portfolio_flip: Optional[float] = 1.5,
        portfolio_flip_apart: float = 1.25,
        portfolio_flip_starts: int = 2,
        portfolio_mirror: Optional[int] = 5,
        portfolio_plan: Optional[int] = 5,
        portfolio_abandon: Optional[float] = 0.3,
    portfolio_dual_bound: Optional[float] = 0.01,
        barrier_funnel: Optional[float] = 0.03,
        barrier_mu_init: float = 0.03,
        barrier_relaxation: float = 0.1,
        al_inner_progress: float = 1.0,
    ) -> Self: ...
    def __getnewargs_ex__(self) -> tuple[tuple[Any, ...], dict[str, Any]]:
        """Pickles as its problem, constraints, tightening and settings (a fresh workspace)."""
    def solve(self, us0: Optional[_ArrayLike] = None, warm_start: bool = False) -> SafeSolution:
        """Solves from ``us0`` (shape ``(n, nu)``), the last controls (``warm_start``) or zeros.
        Without ``warm_start`` a cold start (as after :meth:`reset`), ``us0`` or not; with it the
        last solve's multipliers and margins carry over, ``us0`` replacing only the controls."""
    def tighten(self) -> float:
        """Tightens at the current trajectory (eqs. 19-20); returns the largest margin change."""
    def shift(self) -> None:
        """Receding horizon: drops knot 0 of the solution (controls, gains, multipliers, margins)."""
    def reset(self) -> None:
        """A cold start: zeros the initial guess, gains, multipliers and margins."""
    def set_horizon(self, n: int) -> None:
        """Shortens (or restores) the active horizon ``1 <= n <= N``."""
    @property
    def horizon(self) -> int:
        """The active horizon ``n``."""
    @property
    def nx(self) -> int:
        """Number of states."""
    @property
    def nu(self) -> int:
        """Number of controls."""

@final
class SafeSolution:
    """The result of :meth:`SafeCddpSolver.solve` (``n`` is the active horizon)."""

    @property
    def xs(self) -> _F64Array:
        """States, shape ``(n+1, nx)``."""
    @property
    def us(self) -> _F64Array:
        """Controls, shape ``(n, nu)``."""
    @property
    def K(self) -> _F64Array:
        """Feedback gains of the last backward pass (eq. 12), shape ``(n, nu, nx)``."""
    @property
    def k(self) -> _F64Array:
        """Feed-forward terms (eq. 12), shape ``(n, nu)``."""
    @property
    def propagation_gains(self) -> _F64Array:
        """Gains of the last covariance propagation (eq. 19), shape ``(n, nu, nx)``."""
    @property
    def covariances(self) -> _F64Array:
        """``Sigma_0 .. Sigma_n`` of the last tightening (eq. 19), shape ``(n+1, nx, nx)``."""
    @property
    def margins(self) -> _F64Array:
        """Margins (eq. 20) of each knot's rows, shape ``(n, rows)``: the constraints' rows in
        order, then two per control bound."""
    @property
    def status(self) -> str:
        """``"converged"``, ``"max_iterations"``, ``"regularization_limit"``,
        ``"line_search_failed"``, ``"infeasible"``, ``"qp_failed"`` or ``"numerical_error"``."""
    @property
    def converged(self) -> bool:
        """Whether :attr:`status` is ``"converged"``."""
    @property
    def iterations(self) -> int:
        """Accepted steps."""
    @property
    def discarded_iterations(self) -> int:
        """Iterations of the ``"portfolio"`` start whose solution was not kept."""
    @property
    def cost(self) -> float:
        """Final cost."""
    @property
    def max_violation(self) -> float:
        """Largest violation of an original (untightened) constraint."""
    @property
    def max_violation_tightened(self) -> float:
        """Largest violation of a tightened row."""
    @property
    def tightenings(self) -> int:
        """Tightenings performed."""
    @property
    def solve_time(self) -> float:
        """Wall time of the solve inside Rust (s)."""
    @property
    def starts(self) -> list[dict[str, Any]]:
        """The starts of a ``"portfolio"`` cold solve in the order they ran (empty otherwise),
        each a dict: ``warm_up`` (``"augmented_lagrangian"``, ``"barrier"``, or ``"polish"`` for
        the KKT/QP iterations from the kept solution), ``barrier_mu_init`` (the third start's
        initial barrier weight, else ``None``), ``flip`` (a flipped start's constraint index,
        ``portfolio_flip``, else ``None``), ``mirror`` (``True`` for the start steered to the
        other side of every obstacle, ``portfolio_mirror``), ``plan`` (``True`` for the starts
        steered round the obstacles on the sides of their shortest path, ``portfolio_plan``),
        ``from_kept`` (``True`` for a start from the kept solution's controls rather than the
        initial guess: the polish and the second planned start), ``iterations``, ``cost``, ``max_violation``
        (tightened rows), ``status`` and ``outcome``: ``"kept"``, ``"polished"`` (kept until the
        polish went on from it), ``"discarded"``, ``"same_side"`` (stopped at the end of its
        homotopy on the kept solution's sides), ``"stalled"`` (stopped where, at the rate its
        cost fell, it could not reach the kept cost within its iterations) or ``"abandoned"``
        (stopped more than ``portfolio_abandon`` above the kept cost, or where its dual bound was
        more than ``portfolio_dual_bound`` above it). The ``"kept"`` and ``"polished"`` starts'
        iterations make up :attr:`iterations`, the others' :attr:`discarded_iterations`; the
        table lists them after the status line."""
    def table(self) -> str:
        """The iteration table (no timings, so it is deterministic)."""

@final
class Mpc:
    """Shrinking-horizon MPC with Safe-CDDP (Algorithm 1) under seeded Gaussian process noise.

    Per step: ``iterations`` (``n1``) solver iterations with a tightening every ``n2``; the
    first control is applied to the true state ``x+ = f(x, u0) + w``, ``w ~ N(0, sigma_w)``;
    the trajectory is shifted and the horizon shortened. An episode ends in the goal region
    (``goal_radius`` around ``goal`` on ``goal_indices``) or when the horizon runs out.
    Collisions are steps whose true state violates an original state constraint. Uses a copy of
    the problem taken at construction. ``position_indices`` is the planar position. Defaults:
    :func:`default_settings` ``("Mpc")``.
    """

    def __new__(
        cls,
        problem: Problem,
        constraints: Sequence[Constraint],
        sigma_w: _ArrayLike,
        goal: _ArrayLike,
        tightening: Optional[Tightening] = None,
        goal_indices: Sequence[int] = [0, 1],
        goal_radius: float = 0.1,
        iterations: int = 10,
        initial_iterations: int = 50,
        position_indices: tuple[int, int] = (0, 1),
        max_iterations: int = 400,
    ) -> Self: ...
    def __getnewargs_ex__(self) -> tuple[tuple[Any, ...], dict[str, Any]]:
        """Pickles as its constructor's arguments (the unpickled controller runs the same episodes)."""
    def run_episode(self, seed: int) -> Episode:
        """One episode from the problem's ``x0`` with the noise of ``seed`` (deterministic)."""

@final
class Episode:
    """One MPC episode (pickles as its fields; ``==`` compares them, arrays by value)."""

    @property
    def success(self) -> bool:
        """The goal region was reached."""
    @property
    def steps(self) -> int:
        """MPC steps applied."""
    @property
    def collisions(self) -> int:
        """Steps whose true state violated an original constraint."""
    @property
    def infeasible_steps(self) -> int:
        """Steps at which the solver reported an infeasible QP or trajectory."""
    @property
    def xs(self) -> _F64Array:
        """True states, shape ``(steps+1, nx)``."""
    @property
    def us(self) -> _F64Array:
        """Applied controls, shape ``(steps, nu)``."""

# --------------------------------------------------------------------------------------------
# IDNP with adaptive grid refinement after Richter et al. (2023), public as ddpkit.idnp
# --------------------------------------------------------------------------------------------

def idnp_scene() -> dict[str, Any]:
    """The benchmark scene: ``obstacles`` (list of ``(k, 2)`` vertex arrays), ``goal_center``,
    ``goal_radius``, ``passage`` (``(2, 2)``: corners of the narrow gap), ``domain_min``,
    ``domain_max``, ``cell_size`` (coarse DP grid spacing), ``link_radius``, ``dt``."""

def idnp_configuration(tcp: _ArrayLike) -> _F64Array:
    """A collision-free configuration ``(x, y, theta, q1, q2)`` at rest with its tool centre point
    at ``tcp`` (inverse mapping, eq. (5)). Raises :class:`InvalidInputError` naming ``tcp`` when
    the point cannot be reached without a collision or a limit violation."""

def idnp_run(q0: _ArrayLike, variant: str = "adaptive", max_iterations: int = 15, max_level: int = 4) -> IdnpRun:
    """One IDNP run on the benchmark scene from ``q0`` (a configuration ``(5,)`` at rest or a
    state ``(10,)``): ``variant="adaptive"`` (Algorithm 1, quadtree refinement) or ``"fixed"``
    (the original IDNP, fixed grid with penalty adaptation). Releases the GIL."""

@final
class IdnpRun:
    """The result of :func:`idnp_run`."""

    @property
    def variant(self) -> str:
        """``"adaptive"`` or ``"fixed"``."""
    @property
    def success(self) -> bool:
        """A collision-free trajectory to the goal, ending at rest, was found."""
    @property
    def termination(self) -> str:
        """``"solved"``, ``"max_iterations"`` or ``"stalled"``."""
    @property
    def iterations(self) -> int:
        """Iterations run."""
    @property
    def waypoints(self) -> list[_F64Array]:
        """The DP waypoints of every iteration, each of shape ``(T + 1, 2)``."""
    @property
    def cells(self) -> list[int]:
        """DP cells (quadtree leaves over all time indices) used by each iteration."""
    @property
    def grid_points(self) -> list[int]:
        """DP grid points (stored values) used by each iteration."""
    @property
    def final_cells(self) -> int:
        """Cells of the final grids."""
    @property
    def inverse_failures(self) -> list[tuple[int, int, tuple[float, float], str]]:
        """Waypoints the inverse mapping could not map: ``(iteration, time index, (x, y), reason)``."""
    @property
    def dp_time(self) -> list[float]:
        """Wall time (s) of the DP per iteration."""
    @property
    def inverse_time(self) -> list[float]:
        """Wall time (s) of the inverse mapping per iteration."""
    @property
    def nlp_time(self) -> list[float]:
        """Wall time (s) of the NLP per iteration (0 when it did not run)."""
    @property
    def xs(self) -> Optional[_F64Array]:
        """States ``(N + 1, 10)`` of the last NLP solve (the solution when :attr:`success`), or
        ``None`` when no waypoint sequence could be mapped."""
    @property
    def us(self) -> Optional[_F64Array]:
        """Controls ``(N, 5)`` of the last NLP solve, or ``None``."""
    def grid(self, j: int) -> _F64Array:
        """Leaves of the final grid of time index ``j``, rows ``(center_x, center_y, size)``."""

def idnp_experiment(
    n: int = 200, seed: int = 1, max_iterations: int = 15, optimizer_iterations: int = 400, uniform: bool = False
) -> IdnpExperiment:
    """The experiment of Richter et al. (2023), Section V: ``n`` seeded initial conditions, each
    solved by fixed-grid IDNP, adaptive IDNP and the constrained DDP alone from a straight line
    (``uniform=True`` adds fixed-grid IDNP on the uniform grid that resolves the passage). Parallel,
    GIL released; results depend on ``seed`` only (wall times aside)."""

@final
class IdnpExperiment:
    """The result of :func:`idnp_experiment`."""

    @property
    def cases(self) -> int:
        """Initial conditions."""
    @property
    def solved_fixed(self) -> int:
        """Successes of fixed-grid IDNP."""
    @property
    def solved_adaptive(self) -> int:
        """Successes of adaptive IDNP."""
    @property
    def solved_optimizer(self) -> int:
        """Successes of the optimiser alone."""
    @property
    def solved_uniform(self) -> Optional[int]:
        """Successes on the uniform passage-resolving grid (``uniform=True``), else ``None``."""
    @property
    def fixed_not_adaptive(self) -> list[int]:
        """Cases solved by the fixed grid but not by the adaptive one."""
    @property
    def coarse_cells(self) -> int:
        """DP cells of the coarse grids (all time indices)."""
    @property
    def adaptive_cells_mean(self) -> float:
        """Mean DP cells of the adaptive grids when they succeeded."""
    @property
    def adaptive_cells_max(self) -> float:
        """Largest DP cell count of the adaptive grids when they succeeded."""
    @property
    def uniform_cells(self) -> Optional[int]:
        """DP cells of the coarsest uniform grid that resolves the passage."""
    @property
    def fixed_success(self) -> list[bool]:
        """Per case: fixed-grid success."""
    @property
    def adaptive_success(self) -> list[bool]:
        """Per case: adaptive success."""
    @property
    def optimizer_success(self) -> list[bool]:
        """Per case: success of the optimiser alone."""
    @property
    def initial_tcp(self) -> _F64Array:
        """Initial TCP positions, shape ``(n, 2)``."""
    def table(self) -> str:
        """The table (Markdown) beside the paper's numbers, cell counts and times per iteration."""
    def to_json(self) -> str:
        """Every result as JSON (what ``idnp-experiment --json`` writes)."""

# --------------------------------------------------------------------------------------------
# sim2d: scenario runs and the Safe-CDDP Turtlebot experiment, public as ddpkit.sim
# --------------------------------------------------------------------------------------------

def sim_run_scenario(
    scenario: Union[str, os.PathLike[str]],
    planner: str = "ddp",
    seed: Optional[int] = None,
    direction: str = "forward",
    max_time: Optional[float] = None,
    horizon: Optional[int] = None,
    log: Optional[Union[str, os.PathLike[str]]] = None,
) -> SimResult:
    """One scenario run (``ddpkit.sim.run_scenario``): ``scenario`` is a TOML file path or the TOML
    text (a ``str`` with a newline or ``=``). Releases the GIL."""

@final
class SimResult:
    """One simulated run: the trajectory (one row per control step of 0.1 s) and the metrics."""

    @property
    def scenario(self) -> str:
        """Scenario name."""
    @property
    def planner(self) -> str:
        """Planner name."""
    @property
    def direction(self) -> str:
        """``"forward"`` or ``"backward"``."""
    @property
    def seed(self) -> int:
        """Noise seed."""
    @property
    def outcome(self) -> str:
        """``"completed"``, ``"stalled"`` (no progress for 30 simulated seconds) or ``"timeout"``."""
    @property
    def completed(self) -> bool:
        """Whether the robot reached the end of the route."""
    @property
    def time(self) -> float:
        """Simulated time at the end (s)."""
    @property
    def collisions(self) -> int:
        """Contact onsets with obstacles."""
    @property
    def contact_time(self) -> float:
        """Time in contact with obstacles (s)."""
    @property
    def progress(self) -> float:
        """Largest progress along the route (m)."""
    @property
    def route_length(self) -> float:
        """Route length (m)."""
    @property
    def distance(self) -> float:
        """Path length driven (m)."""
    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second of the loop."""
    @property
    def final_pose(self) -> _F64Array:
        """Final pose ``(x, y, theta)``, shape ``(3,)``."""
    @property
    def t(self) -> _F64Array:
        """Time of each control step (s), shape ``(T,)``."""
    @property
    def x(self) -> _F64Array:
        """Robot x at each control step (m), shape ``(T,)``."""
    @property
    def y(self) -> _F64Array:
        """Robot y at each control step (m), shape ``(T,)``."""
    @property
    def theta(self) -> _F64Array:
        """Robot heading at each control step (rad), shape ``(T,)``."""
    @property
    def v(self) -> _F64Array:
        """Commanded speed at each control step (m/s), shape ``(T,)``."""
    @property
    def w(self) -> _F64Array:
        """Commanded turn rate at each control step (rad/s), shape ``(T,)``."""
    @property
    def goals(self) -> _F64Array:
        """Local goal at each control step, shape ``(T, 2)``."""
    @property
    def epoch_ms(self) -> _F64Array:
        """Compute time of every optimisation epoch (ms), shape ``(E,)``."""
    @property
    def plan_times(self) -> _F64Array:
        """Simulated time of each kept plan (one every 10 planning cycles), shape ``(P,)``."""
    @property
    def plan_lengths(self) -> npt.NDArray[np.int64]:
        """Number of states of each kept plan (horizon + 1), shape ``(P,)``."""
    @property
    def plans(self) -> list[_F64Array]:
        """The kept plans' positions, a list of ``(K, 2)`` arrays."""
    @property
    def route(self) -> _F64Array:
        """The route as driven (reversed for backward runs), shape ``(R, 2)``."""
    @property
    def obstacles(self) -> list[_F64Array]:
        """The obstacles' outlines (cylinders as polygons), a list of ``(K, 2)`` arrays."""
    def plot(self, ax: Any = None, path: Any = None) -> Any:
        """Draws the run's top view as the binaries do (``ddpkit.sim.plot``; needs matplotlib)."""
    def to_json(self) -> str:
        """Every figure of the run (metrics, trajectory, plans, timings) as a JSON string."""

def sim_safe_turtlebot(
    runs: int = 100,
    seed: Optional[int] = None,
    beta: float = 0.8,
    sigma_xy: Optional[float] = None,
    sigma_theta: Optional[float] = None,
    sigma_w_xy: Optional[float] = None,
) -> TurtlebotExperiment:
    """CDDP versus Safe-CDDP on the simulated Turtlebot (``ddpkit.sim.safe_turtlebot``). Releases
    the GIL; the episodes run in parallel."""

@final
class TurtlebotExperiment:
    """CDDP versus Safe-CDDP over the same seeded episodes (Alcan and Kyrki (2022), §IV-C,
    Fig. 5)."""

    @property
    def runs(self) -> int:
        """Episodes per controller."""
    @property
    def seed(self) -> int:
        """Base seed."""
    @property
    def beta(self) -> float:
        """Safe-CDDP's ``beta``."""
    @property
    def safe_wider(self) -> int:
        """Episodes where Safe-CDDP kept the wider minimum clearance than CDDP under the same noise."""
    def min_clearance(self, controller: str) -> _F64Array:
        """Minimum footprint-to-obstacle clearance per episode (m), shape ``(runs,)``;
        ``controller`` is ``"cddp"`` or ``"safe-cddp"``."""
    def collisions(self, controller: str) -> npt.NDArray[np.int64]:
        """Collisions (contact onsets) per episode, shape ``(runs,)``."""
    def reached(self, controller: str) -> npt.NDArray[np.bool_]:
        """Whether each episode reached the goal region, shape ``(runs,)``."""
    def times(self, controller: str) -> _F64Array:
        """Duration of each episode (s), shape ``(runs,)``."""
    def poses(self, controller: str, index: int) -> _F64Array:
        """True poses ``(x, y, theta)`` of episode ``index``, shape ``(steps + 1, 3)``."""
    def to_json(self, with_paths: bool = False) -> str:
        """Every figure (configuration, summaries, histograms, episodes) as a JSON string."""
    def write_png(self, path: Union[str, os.PathLike[str]]) -> None:
        """Draws the figure (paths and minimum-clearance histograms) to the PNG ``path``."""

# --------------------------------------------------------------------------------------------
# DDPEN sub-goal network of Gamayunov et al. (2023), public as ddpkit.subgoal.SubgoalModel
# --------------------------------------------------------------------------------------------

@final
class SubgoalModel:
    """The DDPEN sub-goal network ``x_s = SG(map, x_goal)`` run in Rust from the safetensors file
    that ``python -m ddpkit.train subgoal`` exports (the architecture is in its header metadata).
    Loading checks every tensor; errors are :class:`InvalidInputError` naming the tensor or field."""

    def __new__(cls, path: Union[str, os.PathLike[str]]) -> Self: ...
    @staticmethod
    def default() -> SubgoalModel:
        """The model shipped with ddpkit (the small CNN)."""
    @staticmethod
    def from_bytes(data: bytes) -> SubgoalModel:
        """A model from the bytes of a safetensors file."""
    @property
    def num_subgoals(self) -> int:
        """Sub-goals per prediction (3)."""
    @property
    def arch(self) -> str:
        """The encoder: ``"cnn"`` or ``"efficientnet"``."""
    @property
    def in_size(self) -> int:
        """Side of the square input costmap in cells (200)."""
    def predict(self, costmap: npt.NDArray[np.uint8], goal: _ArrayLike) -> _F64Array:
        """Sub-goals for a uint8 costmap ``(200, 200)`` (row ``iy``, column ``ix``) and a goal
        ``(x, y)`` in metres relative to the map centre: ``(num_subgoals, 2)`` metres in the same
        frame. Costmaps ``(n, 200, 200)`` with goals ``(n, 2)`` give ``(n, num_subgoals, 2)``.
        Releases the GIL."""

# --------------------------------------------------------------------------------------------
# DDPEN sub-goal dataset (Gamayunov et al. (2023), §II-D), public as
# ddpkit.subgoal.generate_dataset / sample
# --------------------------------------------------------------------------------------------

SUBGOAL_MAP_CELLS: int
"""Cells along each side of a dataset costmap (200, of 5 cm)."""

def subgoal_generate_dataset(
    out_dir: Union[str, os.PathLike[str]],
    samples: int,
    seed: int = 0,
    shard_size: int = 5000,
    threads: Optional[int] = None,
) -> dict[str, Any]:
    """Generates ``samples`` samples of ``seed`` into ``out_dir`` as safetensors shards of
    ``shard_size`` samples and a ``manifest.json`` (written last). ``threads=None`` uses every
    core; the bytes do not depend on it. Returns ``{"dir", "samples", "shards", "manifest",
    "seconds"}``. The GIL is released while generating."""

def subgoal_sample(
    seed: int, index: int
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.float32], npt.NDArray[np.float32]]:
    """Sample ``index`` of ``seed`` exactly as the dataset stores it: ``(costmap, goal, subgoals)``
    with ``costmap`` ``uint8 (200, 200)`` indexed ``[iy, ix]``, ``goal`` ``float32 (2,)`` and
    ``subgoals`` ``float32 (3, 2)`` in metres relative to the map centre."""

# --------------------------------------------------------------------------------------------
# Experiments as tasks (ddpkit.experiments)
# --------------------------------------------------------------------------------------------

def experiment_names() -> list[str]:
    """The experiment names ``experiment_tasks`` and friends accept: ``"safe-table"`` (Table I of
    Alcan and Kyrki 2022, a task per episode), ``"subgoal-dataset"`` (the DDPEN sub-goal dataset
    of Gamayunov et al. 2023, a task per shard), ``"idnp"`` (the IDNP experiment of Richter et
    al. 2023, a task per initial condition), ``"ddpen-table"`` and ``"trap-bench"`` (DDPEN's
    Table I and the randomised trap benchmark, a task per simulated run) and ``"safe-turtlebot"``
    (the Turtlebot experiment of Alcan and Kyrki 2022, §IV-C, a task per episode of one
    controller)."""

def experiment_tasks(name: str, config_json: str) -> list[str]:
    """The task specifications (JSON text, one per task, in the order ``experiment_aggregate``
    expects the results) of experiment ``name`` under ``config_json`` (a JSON object; missing
    fields take the binary's defaults, unknown fields are an error naming them). Raises
    ``InvalidInputError`` naming ``name`` or the configuration field."""

def experiment_run_task(name: str, spec_json: str) -> str:
    """Runs one task of experiment ``name`` (a specification from ``experiment_tasks``) and
    returns its result as JSON text, the same bits as the experiment's binary computes for that
    task. The GIL is released while it runs. A task error (or an internal panic) raises
    ``InvalidInputError``."""

def experiment_aggregate(
    name: str,
    config_json: str,
    results_json: list[str],
    out_dir: Union[str, os.PathLike[str]],
    command: str = ...,
    workers: int = 1,
    seconds: float = 0.0,
) -> str:
    """Aggregates the results (JSON text, in task order) of experiment ``name`` into the files its
    binary writes, in ``out_dir`` (created if missing; each file whole or absent), and returns the
    text the binary prints. ``command``, ``workers`` and ``seconds`` go where the binary records
    its command line (default empty), thread count and wall time."""
