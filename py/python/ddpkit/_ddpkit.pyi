"""Type stubs of the ddpkit extension module (``ddpkit._ddpkit``), written in Rust with pyo3.

Arrays are accepted as anything ``numpy.asarray(..., dtype=float64)`` understands (arrays of any
real dtype, lists, tuples, scalars) and returned as new float64 ``numpy.ndarray``\\ s.
"""

from collections.abc import Sequence
from typing import Optional, Union

from typing_extensions import Self, disjoint_base, final

import numpy as np
import numpy.typing as npt

_ArrayLike = npt.ArrayLike
_F64Array = npt.NDArray[np.float64]

__all__ = [
    "ArmBase",
    "Car",
    "CirclePenalty",
    "ControlSquared",
    "Cost",
    "CostSum",
    "DdpError",
    "DifferentialDrive",
    "DoubleIntegrator2D",
    "Dynamics",
    "InvalidInputError",
    "LinearDynamics",
    "NotFiniteError",
    "ObstacleHinge",
    "Problem",
    "QuadraticCost",
    "QuadraticTerminal",
    "Quadrotor",
    "ShapeError",
    "SmoothDistance",
    "Solution",
    "Solver",
    "TerminalSum",
    "Unicycle",
    "__version__",
    "default_settings",
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
    """An array has the wrong shape, a list the wrong length, or the ``(nx, nu)`` pair of a
    model is not compiled into this build (see :func:`supported_dimensions`)."""

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
    """Linear dynamics ``x+ = A x + B u + c``.

    ``A`` has shape ``(nx, nx)``, ``B`` ``(nx, nu)``, ``c`` ``(nx,)`` (zeros when omitted).
    ``(nx, nu)`` must be one of :func:`supported_dimensions`.
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

@final
class QuadraticCost(Cost):
    """``1/2 (x - x_ref)^T Q (x - x_ref) + 1/2 (u - u_ref)^T R (u - u_ref)``.

    ``Q`` ``(nx, nx)`` and ``R`` ``(nu, nu)`` must be symmetric PSD; a 1-D array is taken as the
    diagonal. References default to zero.
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
    """Terminal ``1/2 (x - x_ref)^T Qf (x - x_ref)``; ``Qf`` symmetric PSD (1-D: the diagonal)."""

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
    """``weight * sum(u**2)`` (DDPEN eq. 5); ``weight >= 0``."""

    def __new__(
        cls, weight: float) -> Self: ...
    @property
    def weight(self) -> float:
        """The weight."""

@final
class SmoothDistance(Cost):
    """``weight * sqrt(|p - target|^2 + eps^2)`` with ``p = (x[i0], x[i1])`` for
    ``indices = (i0, i1)``: the DDPEN goal and sub-goal costs (eqs. 6, 9). Running or terminal."""

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
    or scalars, ``+-inf`` for no bound (control limits are handled by box-DDP). Errors name the
    argument: ``ShapeError`` for wrong shapes or list lengths, ``NotFiniteError`` for NaN,
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
    - ``max_iterations``: iteration limit (accepted or rejected steps);
    - ``gradient_tolerance``: converged when ``sum_k |Q_u|^2`` falls below it (Crocoddyl's ``th_stop``);
    - ``cost_tolerance``: converged when a step changes the cost by less than this relative to ``1 + |J|``;
    - ``mu_init``, ``mu_min``, ``mu_max``, ``mu_factor``: Tassa's regularisation schedule;
    - ``regularization``: ``"control"`` (``Q_uu + mu I``) or ``"state"`` (``V_xx + mu I``);
    - ``step_factor``, ``step_min``, ``armijo``: the backtracking line search;
    - ``box_qp_iterations``: iteration limit of the box QP (control limits).

    A solver is used by one thread at a time; the GIL is released during :meth:`solve`, so
    solvers in different threads run in parallel.
    """

    def __new__(
        cls,
        problem: Problem,
        method: str = "ilqr",
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
    ) -> Self: ...
    def solve(self, us0: Optional[_ArrayLike] = None, warm_start: bool = False) -> Solution:
        """Solves the problem.

        The initial guess is ``us0`` if given (shape ``(N, nu)``), else the controls of the last
        solve when ``warm_start`` is true, else zeros (a cold start). Bad input raises; the
        outcome of the algorithm is :attr:`Solution.status`.
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
    def solve_time(self) -> float:
        """Wall time of the solve inside Rust (s)."""
    @property
    def cost_history(self) -> _F64Array:
        """Cost of the initial rollout and after every accepted step."""
    def table(self) -> str:
        """The iteration table (no timings, so it is deterministic)."""

def default_settings() -> dict[str, Union[str, int, float]]:
    """The default solver settings (``ddp_core::Settings::default()``)."""

def supported_dimensions() -> list[tuple[int, int]]:
    """The ``(nx, nu)`` pairs compiled into this build."""
