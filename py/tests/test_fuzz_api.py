"""Property test: malformed input into every public constructor, function and method of the wheel.

Random shapes, dtypes, NaNs, infinities, huge (broadcast, never materialised) and empty arrays,
odd scalars, strings, bytes and objects go into every callable that ``ddpkit._ddpkit`` exports,
found by introspection so that classes added later are covered too. Only exceptions of the
``ddpkit.DdpError`` tree, ``TypeError`` or ``ValueError`` may come out: a pyo3
``PanicException`` (a ``BaseException``), an ``OverflowError``, a ``MemoryError`` or a crash of the
interpreter fails the test. Seeded (``derandomize``), so every run draws the same cases.

Arguments are drawn per parameter from the callable's signature: either the valid value of a
known-good call (``VALID`` below, so that one bad argument among good ones reaches the deep
checks) or garbage. Methods are called on valid instances built by ``VALID``; a class without an
entry still has its constructor fuzzed.
"""

from __future__ import annotations

import inspect
import os
from typing import Any, Callable

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ddpkit
from ddpkit import _ddpkit as ext

ALLOWED = (ddpkit.DdpError, TypeError, ValueError)

pytestmark = pytest.mark.filterwarnings("ignore::numpy.exceptions.ComplexWarning", "ignore::RuntimeWarning")

#: Callables that run for seconds on valid input (whole experiments, simulations, dataset
#: generation); their bad-input checks are exercised by ``test_slow_entry_points_reject_garbage``.
SLOW = {
    "idnp_run",
    "idnp_experiment",
    "sim_run_scenario",
    "sim_safe_turtlebot",
    "subgoal_generate_dataset",
    "optimize_spline",
    "Mpc.run_episode",
}

EXAMPLES = 40


def _unicycle_problem() -> ddpkit.Problem:
    return ddpkit.Problem(
        x0=np.array([-1.0, -1.0, 1.0]),
        dynamics=ddpkit.Unicycle(dt=0.1),
        running_cost=ddpkit.QuadraticCost(Q=np.eye(3), R=np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=10 * np.eye(3)),
        horizon=8,
    )


def _point_problem() -> ddpkit.Problem:
    return ddpkit.Problem(
        x0=np.zeros(4),
        dynamics=ddpkit.DoubleIntegrator2D(dt=0.1),
        running_cost=ddpkit.QuadraticCost(Q=np.eye(4), R=np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=10 * np.eye(4), x_ref=np.array([1.0, 0.0, 0.0, 0.0])),
        horizon=8,
    )


def _spline() -> Any:
    return ext.Spline.catmull_rom(np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]]))


#: Valid keyword arguments of each constructor (by class name). A value may be a zero-argument
#: callable, called for each example.
VALID: dict[str, dict[str, Any]] = {
    "Unicycle": {"dt": 0.1},
    "Car": {"dt": 0.1},
    "DoubleIntegrator2D": {"dt": 0.1},
    "DifferentialDrive": {"dt": 0.1},
    "Quadrotor": {"dt": 0.05},
    "ArmBase": {"dt": 0.25},
    "LinearDynamics": {"A": np.eye(3), "B": np.ones((3, 2))},
    "QuadraticCost": {"Q": np.eye(3), "R": np.eye(2)},
    "QuadraticTerminal": {"Qf": np.eye(3)},
    "ControlSquared": {"weight": 1.0},
    "SmoothDistance": {"target": np.array([1.0, 2.0])},
    "ObstacleHinge": {"points": np.array([[1.0, 1.0], [2.0, 0.0]]), "margin": 0.5},
    "CirclePenalty": {"circles": np.array([[1.0, 1.0, 0.5]])},
    "CostSum": {"terms": lambda: [(1.0, ddpkit.QuadraticCost(Q=np.eye(3), R=np.eye(2))), (0.5, ddpkit.ControlSquared(weight=1.0))]},
    "TerminalSum": {"terms": lambda: [(1.0, ddpkit.QuadraticTerminal(Qf=np.eye(3)))]},
    "Problem": {
        "x0": np.array([-1.0, -1.0, 1.0]),
        "dynamics": lambda: ddpkit.Unicycle(dt=0.1),
        "running_cost": lambda: ddpkit.QuadraticCost(Q=np.eye(3), R=np.eye(2)),
        "terminal_cost": lambda: ddpkit.QuadraticTerminal(Qf=np.eye(3)),
        "horizon": 8,
    },
    "Solver": {"problem": _unicycle_problem, "max_iterations": 5},
    "Bezier": {"points": np.array([[0.0, 0.0], [1.0, 2.0], [3.0, 1.0], [4.0, 0.0]])},
    "Spline": {"segments": np.array([[[0.0, 0.0], [1.0, 1.0], [2.0, 1.0], [3.0, 0.0]]])},
    "SigmoidProfile": {"length": 5.0, "m": 10.0, "duration": 4.0},
    "Trajectory": {"spline": _spline, "profile": lambda: ext.SigmoidProfile(length=_spline().arclen(), m=10.0, duration=4.0)},
    "Circle": {"center": np.array([0.5, 0.1]), "radius": 0.2},
    "ConvexPolygon": {"vertices": np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])},
    "Cylinder": {"center": np.array([0.5, 0.5]), "radius": 0.2, "height": 1.0},
    "StateBox": {"lower": -10 * np.ones(4), "upper": 10 * np.ones(4)},
    "ControlBox": {"lower": -np.ones(2), "upper": np.ones(2)},
    "Tightening": {"beta": 0.9, "sigma_w": 1e-4 * np.eye(4)},
    "SafeCddpSolver": {
        "problem": _point_problem,
        "constraints": lambda: [ddpkit.Circle(center=np.array([0.5, 0.1]), radius=0.2)],
        "max_iterations": 5,
    },
    "Mpc": {
        "problem": _point_problem,
        "constraints": lambda: [ddpkit.Circle(center=np.array([0.5, 0.1]), radius=0.2)],
    },
    "SubgoalModel": {"path": os.path.join(os.path.dirname(__file__), "..", "..", "crates", "subgoal-infer", "models", "default.safetensors")},
}


def _valid_kwargs(name: str) -> dict[str, Any]:
    return {k: (v() if callable(v) and not isinstance(v, type) else v) for k, v in VALID.get(name, {}).items()}


# ---- garbage -----------------------------------------------------------------------------------

FLOATS = [0.0, -0.0, 1.0, -1.0, 0.5, 1e-300, 5e-324, 1e300, -1e300, 1.7976931348623157e308, np.nan, np.inf, -np.inf]
INTS = [-(2**63), -(10**30), -1, 0, 1, 2, 3, 7, 2**40, 2**63, 10**30]
STRINGS = ["", "\x00", "ilqr", "ddp", "fixed", "closed_loop", "gauss", "nan", "é" * 3, "x" * 1000]
DTYPES = [np.float64, np.float32, np.float16, np.int64, np.int8, np.uint8, np.bool_, np.complex128, object, "U2"]


@st.composite
def arrays(draw: st.DrawFn) -> Any:
    kind = draw(st.integers(0, 9))
    if kind == 0:
        # Huge, never materialised: a broadcast view of one element.
        shape = draw(st.sampled_from([(2**40,), (2**21, 2**21), (2**31, 2), (3, 2**40), (2**20, 2**20, 2**10)]))
        return np.broadcast_to(np.float64(draw(st.sampled_from(FLOATS))), shape)
    if kind == 1:
        return np.empty(draw(st.sampled_from([(0,), (0, 0), (0, 3), (3, 0), (2, 0, 2)])))
    ndim = draw(st.integers(0, 4))
    shape = tuple(draw(st.lists(st.integers(0, 5), min_size=ndim, max_size=ndim)))
    size = int(np.prod(shape)) if shape else 1
    values = draw(st.lists(st.sampled_from(FLOATS) | st.floats(-1e3, 1e3), min_size=size, max_size=size))
    a = np.array(values, dtype=np.float64).reshape(shape)
    dtype = draw(st.sampled_from(DTYPES))
    with np.errstate(all="ignore"):
        try:
            a = a.astype(dtype)
        except (ValueError, OverflowError):
            pass
    if kind == 2 and a.ndim >= 2:
        a = a.T  # not C-contiguous
    if kind == 3 and a.ndim >= 1 and a.shape[0] > 1:
        a = a[::2]  # strided
    return a


def garbage() -> st.SearchStrategy[Any]:
    return st.one_of(
        arrays(),
        st.sampled_from(FLOATS),
        st.sampled_from(INTS),
        st.booleans(),
        st.none(),
        st.sampled_from(STRINGS),
        st.binary(max_size=64),
        st.lists(st.sampled_from(FLOATS), max_size=4),
        st.lists(st.lists(st.sampled_from(FLOATS), max_size=3), max_size=3),
        st.just(object()),
        st.just(ddpkit.Unicycle(dt=0.1)),
        st.just({"a": 1}),
        st.sampled_from([np.float64(np.nan), np.int64(-1), np.uint64(2**64 - 1)]),
    )


# ---- what is called ----------------------------------------------------------------------------


def _public_classes() -> list[tuple[str, type]]:
    return sorted(
        (n, c)
        for n, c in vars(ext).items()
        if inspect.isclass(c) and not n.startswith("_") and not issubclass(c, BaseException)
    )


def _public_functions() -> list[tuple[str, Callable[..., Any]]]:
    return sorted(
        (n, f)
        for n, f in vars(ext).items()
        if callable(f) and not inspect.isclass(f) and not n.startswith("_") and n not in SLOW
    )


def _parameters(f: Callable[..., Any]) -> list[inspect.Parameter]:
    try:
        sig = inspect.signature(f)
    except (TypeError, ValueError):
        return []
    return [p for p in sig.parameters.values() if p.name not in ("self", "cls") and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]


def _call(f: Callable[..., Any], kwargs: dict[str, Any]) -> Any:
    """Calls ``f``; an allowed exception is a valid answer, anything else fails the test."""
    try:
        return f(**kwargs)
    except ALLOWED:
        return None


def _draw_kwargs(data: st.DataObject, params: list[inspect.Parameter], valid: dict[str, Any]) -> dict[str, Any]:
    kwargs: dict[str, Any] = {}
    for p in params:
        optional = p.default is not inspect.Parameter.empty
        choice = data.draw(st.integers(0, 3), label=f"{p.name}: 0 garbage, 1 valid, 2-3 valid or omitted")
        if choice == 0 or (p.name not in valid and not optional):
            kwargs[p.name] = data.draw(garbage(), label=p.name)
        elif p.name in valid:
            kwargs[p.name] = valid[p.name]
        # else: an optional parameter left at its default
    return kwargs


FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=True,
    database=None,
    suppress_health_check=list(HealthCheck),
)


@pytest.mark.parametrize("name", [n for n, _ in _public_classes()])
@FUZZ
@given(data=st.data())
def test_constructor_survives_garbage(name: str, data: st.DataObject) -> None:
    cls = getattr(ext, name)
    valid = _valid_kwargs(name)
    _call(cls, _draw_kwargs(data, _parameters(cls), valid))


def _instances() -> list[tuple[str, str]]:
    out = []
    for name, cls in _public_classes():
        if name not in VALID:
            continue
        for attr in sorted(dir(cls)):
            if attr.startswith("_") or f"{name}.{attr}" in SLOW:
                continue
            if callable(inspect.getattr_static(cls, attr)) or isinstance(inspect.getattr_static(cls, attr), (staticmethod, classmethod)):
                out.append((name, attr))
    return out


def test_every_class_with_methods_has_a_valid_instance() -> None:
    """A class of the wheel with public methods must have an entry in ``VALID``, so that its
    methods are fuzzed (data-only result classes, built by solves, are reached through those)."""
    produced_by_calls = {
        "Solution",
        "SafeSolution",
        "Episode",
        "IdnpRun",
        "IdnpExperiment",
        "SimResult",
        "TurtlebotExperiment",
        "TrajectorySamples",
        "SplineOptimizeResult",
        "Dynamics",
        "Cost",
        "Constraint",
        # Built by Dynamics/Cost/Constraint.from_function, from_casadi and from_callable; fuzzed
        # by test_own_models_survive_garbage.
        "TapeDynamics",
        "TapeCost",
        "TapeConstraint",
        "CallableDynamics",
        "CallableCost",
        "CallableConstraint",
    }
    missing = [n for n, _ in _public_classes() if n not in VALID and n not in produced_by_calls]
    assert missing == [], f"add these classes to VALID in {__file__}: {missing}"


@pytest.mark.parametrize("name,method", _instances())
@FUZZ
@given(data=st.data())
def test_method_survives_garbage(name: str, method: str, data: st.DataObject) -> None:
    obj = getattr(ext, name)(**_valid_kwargs(name))
    f = getattr(obj, method)
    _call(f, _draw_kwargs(data, _parameters(f), {}))


@pytest.mark.parametrize("name", [n for n, _ in _public_functions()])
@FUZZ
@given(data=st.data())
def test_function_survives_garbage(name: str, data: st.DataObject) -> None:
    f = getattr(ext, name)
    _call(f, _draw_kwargs(data, _parameters(f), {}))


#: Valid arguments of the module functions that need them to get past their first check (the
#: batch solves): one garbage argument among valid ones reaches the checks of the others.
FUNCTION_VALID: dict[str, dict[str, Any]] = {
    "solve_batch": {"problems": lambda: [_unicycle_problem(), _unicycle_problem()], "max_iterations": 3, "threads": 2},
    "solve_batch_safe": {
        "problems": lambda: [_point_problem(), _point_problem()],
        "constraints": lambda: [ddpkit.Circle(center=np.array([0.5, 0.1]), radius=0.2)],
        "max_iterations": 3,
        "threads": 2,
    },
}


def test_every_batch_function_has_valid_arguments() -> None:
    """A public batch function of the wheel must have an entry in ``FUNCTION_VALID``."""
    missing = [n for n, _ in _public_functions() if "batch" in n and n not in FUNCTION_VALID and n != "arclen_batch"]
    assert missing == [], f"add these functions to FUNCTION_VALID in {__file__}: {missing}"


@pytest.mark.parametrize("name", sorted(FUNCTION_VALID))
@FUZZ
@given(data=st.data())
def test_function_with_valid_arguments_survives_garbage(name: str, data: st.DataObject) -> None:
    f = getattr(ext, name)
    valid = {k: (v() if callable(v) else v) for k, v in FUNCTION_VALID[name].items()}
    _call(f, _draw_kwargs(data, _parameters(f), valid))


@FUZZ
@given(data=st.data())
def test_results_of_solves_survive_garbage(data: st.DataObject) -> None:
    """Methods of the objects solves return (``Solution``, ``SafeSolution``)."""
    sol = ddpkit.Solver(_unicycle_problem(), max_iterations=3).solve()
    safe = ddpkit.SafeCddpSolver(_point_problem(), [ddpkit.Circle(center=np.array([0.5, 0.1]), radius=0.2)], max_iterations=3).solve()
    for obj in (sol, safe):
        for attr in sorted(dir(obj)):
            if attr.startswith("_"):
                continue
            f = getattr(obj, attr)
            if callable(f):
                _call(f, _draw_kwargs(data, _parameters(f), {}))


def _own_models() -> list[Any]:
    """One small instance (2 states, 1 control) of every traced and callable model class."""

    def f(x: Any, u: Any) -> Any:
        return np.array([x[0] + 0.1 * x[1], x[1] + 0.1 * np.sin(u[0])])

    def l(x: Any, u: Any) -> Any:
        return x[0] ** 2 + 0.1 * u[0] ** 2

    def l_n(x: Any) -> Any:
        return 10.0 * (x[0] ** 2 + x[1] ** 2)

    def g(x: Any, u: Any) -> Any:
        return np.array([x[0] - 1.0, u[0] ** 2 - 4.0])

    def plain(h: Callable[..., Any]) -> Callable[..., Any]:
        return lambda *a: np.asarray(h(*a), dtype=float)

    return [
        ddpkit.Dynamics.from_function(f, nx=2, nu=1),
        ddpkit.Dynamics.from_function(lambda x, u: np.array([x[1], np.tanh(u[0])]), nx=2, nu=1, dt=0.1, integrator="euler"),
        ddpkit.Cost.from_function(l, nx=2, nu=1),
        ddpkit.Cost.from_function(l_n, nx=2),
        ddpkit.Constraint.from_function(g, nx=2, nu=1),
        ddpkit.Dynamics.from_callable(plain(f), nx=2, nu=1),
        ddpkit.Cost.from_callable(lambda x, u: float(l(x, u)), nx=2, nu=1),
        ddpkit.Constraint.from_callable(plain(g), nx=2, nu=1, rows=2),
    ]


def test_own_models_cover_every_traced_and_callable_class() -> None:
    names = {type(m).__name__ for m in _own_models()}
    assert {"TapeDynamics", "TapeCost", "TapeConstraint", "CallableDynamics", "CallableCost", "CallableConstraint"} <= names


@FUZZ
@given(data=st.data())
def test_own_models_survive_garbage(data: st.DataObject, tmp_path_factory: Any) -> None:
    """Methods of traced and callable models (and their factories, with the valid functions or
    garbage); ``save`` writes only under a temporary directory."""
    models = _own_models()
    valid = {
        # Valid for any sizes: an exception of the user's own function (an IndexError of
        # `x[1]` with nx = 1) would reach the caller as it is, which is not what is fuzzed here.
        "f": lambda x, u: x + u[0],
        "l": lambda x, u: x[0] ** 2 + u[0] ** 2,
        "g": lambda x, u: x[0] - u[0],
        "nx": 2,
        "nu": 1,
        "x": np.array([0.3, -0.2]),
        "u": np.array([0.5]),
        "lam": np.array([1.0, -2.0]),
    }
    out = tmp_path_factory.mktemp("tapes")
    for obj in models:
        for attr in sorted(dir(obj)):
            # `function` is the user's own callable, handed back as it was given.
            if attr.startswith("_") or attr == "function":
                continue
            f = getattr(obj, attr)
            if not callable(f):
                continue
            kwargs = _draw_kwargs(data, _parameters(f), valid)
            if attr == "save" and "path" in kwargs:
                kwargs["path"] = str(out / f"{abs(hash(repr(kwargs['path']))) % 1000}.json")
            _call(f, kwargs)


@FUZZ
@given(data=st.binary(max_size=256))
def test_subgoal_model_from_bytes_survives_garbage(data: bytes) -> None:
    _call(ext.SubgoalModel.from_bytes, {"data": data})


def test_slow_entry_points_reject_garbage(tmp_path: Any) -> None:
    """The long-running entry points answer bad input with an allowed exception, before running."""
    bad_arrays = [np.full(5, np.nan), np.zeros(7), np.broadcast_to(1.0, (2**40,)), "q0", None]
    for q0 in bad_arrays:
        with pytest.raises(ALLOWED):
            ext.idnp_run(q0)
    for kwargs in [{"n": 0}, {"max_iterations": 0}, {"optimizer_iterations": 0}]:
        with pytest.raises(ALLOWED):
            ext.idnp_experiment(**kwargs)
    for kwargs in [{"n": -1}, {"n": 2**64}, {"seed": -1}, {"max_iterations": 10**30}]:
        with pytest.raises(ddpkit.InvalidInputError, match="does not fit"):
            ext.idnp_experiment(**kwargs)
    for text in ["", "name = ", "\x00", "name = 'x'\n[route]\npoints = [[0, 0]]\n"]:
        with pytest.raises(ALLOWED):
            ext.sim_run_scenario(text)
    with pytest.raises(ALLOWED):
        ext.subgoal_generate_dataset(str(tmp_path / "d"), samples=0)
    # The experiments' task functions (their garbage is fuzzed like every function): an unknown
    # name, a task that is not JSON or not the experiment's, results that do not fit.
    for call in [
        lambda: ext.experiment_tasks("nope", "{}"),
        lambda: ext.experiment_tasks("safe-table", '{"episodes": -1}'),
        lambda: ext.experiment_run_task("safe-table", "{"),
        lambda: ext.experiment_run_task("safe-table", '{"robot": "point"}'),
        lambda: ext.experiment_run_task("subgoal-dataset", '{"out_dir": "", "shard": 0}'),
        lambda: ext.experiment_aggregate("safe-table", "{}", ["{}"], str(tmp_path / "a")),
        lambda: ext.experiment_tasks("idnp", '{"n": 0}'),
        lambda: ext.experiment_tasks("idnp", '{"cases": 3}'),
        lambda: ext.experiment_run_task("idnp", '{"index": 0}'),
        lambda: ext.experiment_aggregate("idnp", '{"n": 2}', ["{}"], str(tmp_path / "i")),
        lambda: ext.experiment_tasks("trap-bench", '{"maps": -1}'),
        lambda: ext.experiment_run_task("trap-bench", '{"kind": "u"}'),
        lambda: ext.experiment_run_task("ddpen-table", '{"scenario": "", "run": 0}'),
        lambda: ext.experiment_aggregate("ddpen-table", '{"runs": 1}', ["{}"], str(tmp_path / "d")),
    ]:
        with pytest.raises(ALLOWED):
            call()
    with pytest.raises(ddpkit.InvalidInputError, match="does not fit"):
        ext.experiment_aggregate("safe-table", "{}", [], str(tmp_path / "w"), workers=-1)
    with pytest.raises(ddpkit.InvalidInputError, match=r"config_json\.n"):
        ext.experiment_tasks("idnp", '{"n": 0}')


def test_huge_broadcast_array_is_an_error_naming_the_argument() -> None:
    """A broadcast view of 2^40 elements was copied element by element: an allocation failure
    that aborted the interpreter."""
    huge = np.broadcast_to(np.float64(0.0), (2**40,))
    with pytest.raises(ddpkit.InvalidInputError, match=r"x0 is invalid: has shape \(1099511627776,\)") as e:
        ddpkit.Problem(
            x0=huge,
            dynamics=ddpkit.Unicycle(dt=0.1),
            running_cost=ddpkit.QuadraticCost(Q=np.eye(3), R=np.eye(2)),
            terminal_cost=ddpkit.QuadraticTerminal(Qf=np.eye(3)),
            horizon=8,
        )
    assert e.value.field == "x0"


@pytest.mark.parametrize("value", [-1, 2**64, -(10**30), 10**30])
def test_out_of_range_integer_is_invalid_input_naming_the_argument(value: int) -> None:
    """An integer that does not fit the argument's Rust type is an ``InvalidInputError`` (not
    Python's ``OverflowError``), with a note naming the argument."""
    kwargs = dict(VALID["Problem"])
    kwargs = {k: (v() if callable(v) else v) for k, v in kwargs.items()}
    kwargs["horizon"] = value
    with pytest.raises(ddpkit.InvalidInputError) as e:
        ddpkit.Problem(**kwargs)
    if abs(value) > 2**63:
        assert "does not fit" in str(e.value)
        assert any("horizon" in n for n in getattr(e.value, "__notes__", []))
    with pytest.raises(ddpkit.InvalidInputError, match="does not fit a u64") as e:
        ext.idnp_experiment(seed=value if value < 0 else 2**64)
    assert any("seed" in n for n in getattr(e.value, "__notes__", []))
