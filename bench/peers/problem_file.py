"""Reading, validating and checking the peer benchmark problems (bench/problems.md).

Everything here is independent of ddpkit: the dynamics, the objective and the constraint
violation are written out in numpy from the problem definition, so the numbers a solver reports
can be checked against them.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

import numpy as np

#: Dimensions (nx, nu) of each model of bench/problems.md.
MODELS = {"unicycle": (3, 2), "car": (4, 2), "point": (4, 2)}
KNOWN_FIELDS = {"name", "model", "dt", "N", "x0", "cost", "u_min", "u_max", "obstacles"}
#: Feasibility tolerance of bench/problems.md: a solution is feasible when its largest violation
#: (`BenchProblem.max_violation`) is at most this.
FEASIBILITY_TOL = 1e-6


class ProblemFileError(ValueError):
    """A malformed problem file; the message names the field."""


@dataclass
class BenchProblem:
    """A validated problem of bench/problems.md."""

    name: str
    model: str
    dt: float
    N: int
    x0: np.ndarray
    cost_kind: str
    #: unicycle: (w_x, w_u); quad_goal: unused.
    weights: tuple[float, float] = (0.0, 0.0)
    x_goal: Optional[np.ndarray] = None
    R: Optional[np.ndarray] = None
    Qf: Optional[np.ndarray] = None
    u_min: Optional[np.ndarray] = None
    u_max: Optional[np.ndarray] = None
    obstacles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def nx(self) -> int:
        return MODELS[self.model][0]

    @property
    def nu(self) -> int:
        return MODELS[self.model][1]

    # ---- the problem definition, in numpy ------------------------------------------------------

    def step(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The discrete dynamics exactly as bench/problems.md states them."""
        dt = self.dt
        if self.model == "unicycle":
            return np.array([x[0] + dt * u[0] * math.cos(x[2]), x[1] + dt * u[0] * math.sin(x[2]), x[2] + dt * u[1]])
        if self.model == "car":
            return np.array(
                [x[0] + dt * x[3] * math.cos(x[2]), x[1] + dt * x[3] * math.sin(x[2]), x[2] + dt * u[0], x[3] + dt * u[1]]
            )
        # point: exact zero-order hold of a double integrator
        return np.array(
            [
                x[0] + dt * x[2] + 0.5 * dt * dt * u[0],
                x[1] + dt * x[3] + 0.5 * dt * dt * u[1],
                x[2] + dt * u[0],
                x[3] + dt * u[1],
            ]
        )

    def objective(self, xs: np.ndarray, us: np.ndarray) -> float:
        """`J = sum_k l(x_k, u_k) + l_N(x_N)` without any penalty."""
        if self.cost_kind == "unicycle":
            w_x, w_u = self.weights
            running = 0.5 * (w_x**2 * np.sum(xs[:-1] ** 2) + w_u**2 * np.sum(us**2))
            return float(running + 0.5 * w_x**2 * np.sum(xs[-1] ** 2))
        assert self.R is not None and self.Qf is not None and self.x_goal is not None
        running = 0.5 * np.sum(us**2 @ self.R)
        e = xs[-1] - self.x_goal
        return float(running + 0.5 * np.sum(self.Qf * e**2))

    def violations(self, xs: np.ndarray, us: np.ndarray) -> dict[str, float]:
        """Dynamics defect, control-box violation and obstacle violation (squared-distance form,
        k = 1..N), each the maximum over the trajectory."""
        defect = max(float(np.abs(xs[k + 1] - self.step(xs[k], us[k])).max()) for k in range(self.N))
        defect = max(defect, float(np.abs(xs[0] - self.x0).max()))
        box = 0.0
        if self.u_min is not None:
            box = max(box, float(np.max(self.u_min - us)))
        if self.u_max is not None:
            box = max(box, float(np.max(us - self.u_max)))
        obstacle = 0.0
        for ox, oy, r in self.obstacles:
            d2 = (xs[1:, 0] - ox) ** 2 + (xs[1:, 1] - oy) ** 2
            obstacle = max(obstacle, float(np.max(r * r - d2)))
        return {"dynamics": max(defect, 0.0), "box": max(box, 0.0), "obstacle": max(obstacle, 0.0)}

    def max_violation(self, xs: np.ndarray, us: np.ndarray) -> float:
        """The largest of `violations`: the solution is feasible when this is <= FEASIBILITY_TOL."""
        return max(self.violations(xs, us).values())

    def clearance(self, xy: np.ndarray) -> float:
        """Euclidean distance from the point `xy` to the nearest obstacle's boundary: negative
        inside an obstacle, +inf without obstacles."""
        if len(self.obstacles) == 0:
            return math.inf
        d = np.hypot(self.obstacles[:, 0] - xy[0], self.obstacles[:, 1] - xy[1])
        return float(np.min(d - self.obstacles[:, 2]))


# ---- validation -----------------------------------------------------------------------------------


def _number(value: Any, name: str, positive: bool = False, nonnegative: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ProblemFileError(f"field '{name}' must be a number, got {type(value).__name__}")
    v = float(value)
    if not math.isfinite(v):
        raise ProblemFileError(f"field '{name}' must be finite, got {v}")
    if positive and v <= 0.0:
        raise ProblemFileError(f"field '{name}' must be > 0, got {v}")
    if nonnegative and v < 0.0:
        raise ProblemFileError(f"field '{name}' must be >= 0, got {v}")
    return v


def _vector(value: Any, name: str, n: int, nonnegative: bool = False, allow_inf: bool = False) -> np.ndarray:
    if not isinstance(value, list):
        raise ProblemFileError(f"field '{name}' must be a list of {n} numbers, got {type(value).__name__}")
    if len(value) != n:
        raise ProblemFileError(f"field '{name}' must have {n} entries, got {len(value)}")
    out = np.empty(n)
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ProblemFileError(f"field '{name}[{i}]' must be a number, got {type(v).__name__}")
        v = float(v)
        if math.isnan(v) or (math.isinf(v) and not allow_inf):
            raise ProblemFileError(f"field '{name}[{i}]' must be finite, got {v}")
        if nonnegative and v < 0.0:
            raise ProblemFileError(f"field '{name}[{i}]' must be >= 0, got {v}")
        out[i] = v
    return out


def parse(data: Any) -> BenchProblem:
    """Validates a decoded JSON problem; a `ProblemFileError` names the first bad field."""
    if not isinstance(data, dict):
        raise ProblemFileError(f"the problem must be a JSON object, got {type(data).__name__}")
    for key in ("model", "dt", "N", "x0", "cost"):
        if key not in data:
            raise ProblemFileError(f"field '{key}' is missing")
    unknown = sorted(set(data) - KNOWN_FIELDS)
    if unknown:
        print(f"warning: ignoring unknown field(s) {', '.join(repr(u) for u in unknown)}", file=sys.stderr)
    name = data.get("name", "")
    if not isinstance(name, str):
        raise ProblemFileError(f"field 'name' must be a string, got {type(name).__name__}")
    model = data["model"]
    if model not in MODELS:
        raise ProblemFileError(f"field 'model' must be one of {sorted(MODELS)}, got {model!r}")
    nx, nu = MODELS[model]
    dt = _number(data["dt"], "dt", positive=True)
    n_raw = data["N"]
    if isinstance(n_raw, bool) or not isinstance(n_raw, int) or n_raw < 1:
        raise ProblemFileError(f"field 'N' must be an integer >= 1, got {n_raw!r}")
    x0 = _vector(data["x0"], "x0", nx)

    cost = data["cost"]
    if not isinstance(cost, dict):
        raise ProblemFileError(f"field 'cost' must be an object, got {type(cost).__name__}")
    kind = cost.get("kind")
    problem = BenchProblem(name=name, model=model, dt=dt, N=n_raw, x0=x0, cost_kind=str(kind))
    if kind == "unicycle":
        for key in ("w_x", "w_u"):
            if key not in cost:
                raise ProblemFileError(f"field 'cost.{key}' is missing")
        problem.weights = (_number(cost["w_x"], "cost.w_x"), _number(cost["w_u"], "cost.w_u"))
    elif kind == "quad_goal":
        for key in ("x_goal", "R", "Qf"):
            if key not in cost:
                raise ProblemFileError(f"field 'cost.{key}' is missing")
        problem.x_goal = _vector(cost["x_goal"], "cost.x_goal", nx)
        problem.R = _vector(cost["R"], "cost.R", nu, nonnegative=True)
        problem.Qf = _vector(cost["Qf"], "cost.Qf", nx, nonnegative=True)
    else:
        raise ProblemFileError(f"field 'cost.kind' must be 'unicycle' or 'quad_goal', got {kind!r}")

    if data.get("u_min") is not None:
        problem.u_min = _vector(data["u_min"], "u_min", nu, allow_inf=True)
    if data.get("u_max") is not None:
        problem.u_max = _vector(data["u_max"], "u_max", nu, allow_inf=True)
    if problem.u_min is not None and problem.u_max is not None:
        for i in range(nu):
            if problem.u_min[i] > problem.u_max[i]:
                raise ProblemFileError(
                    f"field 'u_min[{i}]' = {problem.u_min[i]} exceeds 'u_max[{i}]' = {problem.u_max[i]}"
                )
    obstacles = data.get("obstacles")
    if obstacles is not None:
        if not isinstance(obstacles, list):
            raise ProblemFileError(f"field 'obstacles' must be a list of [ox, oy, r], got {type(obstacles).__name__}")
        rows = []
        for i, o in enumerate(obstacles):
            row = _vector(o, f"obstacles[{i}]", 3)
            if row[2] < 0.0:
                raise ProblemFileError(f"field 'obstacles[{i}]' has a negative radius {row[2]}")
            rows.append(row)
        problem.obstacles = np.array(rows).reshape(-1, 3)
    return problem


def load(path: Path) -> BenchProblem:
    """Reads and validates a problem file."""
    try:
        text = Path(path).read_text()
    except OSError as e:
        raise ProblemFileError(f"cannot read {path}: {e.strerror}") from e
    try:
        data = json.loads(text)
    except json.JSONDecodeError as e:
        raise ProblemFileError(f"{path} is not valid JSON: {e}") from e
    return parse(data)
