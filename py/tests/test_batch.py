"""Batch solves (``ddpkit.solve_batch``, ``ddpkit.solve_batch_safe``) and parallel derivatives
(``Solver(derivative_threads=...)``).

Every batch result must equal the one-at-a-time solve of the same problem exactly (``==`` on
arrays and costs), for 1, 2 and 4 threads; bad input must raise a ``DdpError`` naming the field.
"""

from __future__ import annotations

import numpy as np
import pytest

import ddpkit


def p1(x0: np.ndarray, horizon: int = 100, bounded: bool = False) -> ddpkit.Problem:
    """The README's unicycle (P1) from ``x0``."""
    kwargs = {"u_min": np.array([-0.6, -0.8]), "u_max": np.array([0.6, 0.8])} if bounded else {}
    return ddpkit.Problem(
        x0=x0,
        dynamics=ddpkit.Unicycle(dt=0.1),
        running_cost=ddpkit.QuadraticCost(Q=100 * np.eye(3), R=np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=100 * np.eye(3)),
        horizon=horizon,
        **kwargs,
    )


def seeded_x0s(count: int, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.uniform([-2.0, -2.0, -np.pi], [2.0, 2.0, np.pi]) for _ in range(count)]


def assert_identical(got: ddpkit.Solution, want: ddpkit.Solution, what: str) -> None:
    assert np.array_equal(got.xs, want.xs), f"{what}: xs"
    assert np.array_equal(got.us, want.us), f"{what}: us"
    assert np.array_equal(got.K, want.K), f"{what}: K"
    assert got.cost == want.cost, f"{what}: cost {got.cost!r} != {want.cost!r}"
    assert got.status == want.status and got.iterations == want.iterations, what
    assert got.table() == want.table(), f"{what}: iteration table"


def check_batch(problems: list[ddpkit.Problem], what: str, **settings: object) -> list[ddpkit.Solution]:
    want = [ddpkit.Solver(p, **settings).solve() for p in problems]  # type: ignore[arg-type]
    for threads in (1, 2, 4):
        got = ddpkit.solve_batch(problems, threads=threads, **settings)  # type: ignore[arg-type]
        assert len(got) == len(problems)
        for i, (g, w) in enumerate(zip(got, want)):
            assert_identical(g, w, f"{what}, {threads} threads, problem {i}")
    return want


def test_ilqr_batch_equals_one_at_a_time() -> None:
    want = check_batch([p1(x0) for x0 in seeded_x0s(16)], "iLQR")
    assert len({w.cost for w in want}) == 16, "the problems differ"


def test_full_ddp_batch_equals_one_at_a_time() -> None:
    check_batch([p1(x0) for x0 in seeded_x0s(8, seed=1)], "full DDP", method="ddp")


def test_box_ddp_batch_equals_one_at_a_time() -> None:
    want = check_batch([p1(x0, bounded=True) for x0 in seeded_x0s(8, seed=2)], "box-DDP")
    assert any(np.any(np.isclose(np.abs(w.us[:, 0]), 0.6, rtol=0, atol=1e-12)) for w in want), "a bound is active"


def test_run_time_size_batch_equals_one_at_a_time() -> None:
    rng = np.random.default_rng(3)
    a = np.eye(7) + 0.05 * rng.standard_normal((7, 7))
    b = rng.standard_normal((7, 3))
    problems = [
        ddpkit.Problem(
            x0=rng.standard_normal(7),
            dynamics=ddpkit.LinearDynamics(a, b),
            running_cost=ddpkit.QuadraticCost(Q=np.eye(7), R=0.1 * np.eye(3)),
            terminal_cost=ddpkit.QuadraticTerminal(Qf=10 * np.eye(7)),
            horizon=30,
            u_min=-1.0,
            u_max=1.0,
        )
        for _ in range(6)
    ]
    check_batch(problems, "Dyn (7, 3)")


def test_traced_model_batch_equals_one_at_a_time() -> None:
    def unicycle(x, u):  # type: ignore[no-untyped-def]
        return np.array([x[0] + 0.1 * u[0] * np.cos(x[2]), x[1] + 0.1 * u[0] * np.sin(x[2]), x[2] + 0.1 * u[1]])

    model = ddpkit.Dynamics.from_function(unicycle, nx=3, nu=2)
    problems = [
        ddpkit.Problem(
            x0=x0,
            dynamics=model,
            running_cost=ddpkit.QuadraticCost(Q=np.eye(3), R=np.eye(2)),
            terminal_cost=ddpkit.QuadraticTerminal(Qf=100 * np.eye(3)),
            horizon=40,
        )
        for x0 in seeded_x0s(6, seed=4)
    ]
    check_batch(problems, "traced", method="ddp")


def test_default_threads_and_more_threads_than_problems() -> None:
    problems = [p1(x0, horizon=30) for x0 in seeded_x0s(3, seed=5)]
    want = [ddpkit.Solver(p).solve() for p in problems]
    for got in (ddpkit.solve_batch(problems), ddpkit.solve_batch(tuple(problems), threads=16)):
        for g, w in zip(got, want):
            assert_identical(g, w, "threads=None / 16")


def test_batch_settings_are_the_solver_keywords() -> None:
    problems = [p1(x0, horizon=30) for x0 in seeded_x0s(2, seed=6)]
    got = ddpkit.solve_batch(problems, threads=2, max_iterations=2, regularization="state")
    want = [ddpkit.Solver(p, max_iterations=2, regularization="state").solve() for p in problems]
    for g, w in zip(got, want):
        assert g.iterations <= 2
        assert_identical(g, w, "max_iterations=2")


def test_batch_bad_input_names_the_field() -> None:
    good = p1(np.zeros(3), horizon=20)
    with pytest.raises(ddpkit.InvalidInputError, match="at least one problem") as e:
        ddpkit.solve_batch([])
    assert e.value.field == "problems"
    with pytest.raises(ddpkit.InvalidInputError) as e:
        ddpkit.solve_batch([good, "not a problem"])  # type: ignore[list-item]
    assert e.value.field == "problems[1]"
    with pytest.raises(ddpkit.InvalidInputError) as e:
        ddpkit.solve_batch("problems")  # type: ignore[arg-type]
    assert e.value.field == "problems"
    with pytest.raises(ddpkit.ShapeError, match=r"\(3, 2, 30\)") as e:
        ddpkit.solve_batch([good, good, p1(np.zeros(3), horizon=30)])
    assert e.value.field == "problems[2]"
    point = ddpkit.Problem(
        x0=np.zeros(4),
        dynamics=ddpkit.DoubleIntegrator2D(dt=0.1),
        running_cost=ddpkit.QuadraticCost(Q=np.eye(4), R=np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=np.eye(4)),
        horizon=20,
    )
    with pytest.raises(ddpkit.ShapeError) as e:
        ddpkit.solve_batch([good, point])
    assert e.value.field == "problems[1]"
    for threads in (0, -3):
        with pytest.raises(ddpkit.InvalidInputError) as e:
            ddpkit.solve_batch([good], threads=threads)
        assert e.value.field == "threads"
    with pytest.raises(ddpkit.InvalidInputError) as e:
        ddpkit.solve_batch([good], max_iterations=0)
    assert "max_iterations" in e.value.field
    with pytest.raises(ValueError):
        ddpkit.solve_batch([good], method="newton")


class Boom(Exception):
    pass


def test_exception_of_a_callable_model_is_raised_as_itself() -> None:
    def step(x, u):  # type: ignore[no-untyped-def]
        if x[0] > 50.0:
            raise Boom("lookup table out of range")
        return np.array([x[0] + 0.1 * u[0], x[1] + 0.1 * u[1], x[2]])

    model = ddpkit.Dynamics.from_callable(step, nx=3, nu=2)

    def problem(x0: float) -> ddpkit.Problem:
        return ddpkit.Problem(
            x0=np.array([x0, 0.0, 0.0]),
            dynamics=model,
            running_cost=ddpkit.QuadraticCost(Q=np.eye(3), R=np.eye(2)),
            terminal_cost=ddpkit.QuadraticTerminal(Qf=np.eye(3)),
            horizon=5,
        )

    good = [problem(0.5), problem(1.0)]
    want = [ddpkit.Solver(p).solve() for p in good]
    for threads in (1, 2):
        for g, w in zip(ddpkit.solve_batch(good, threads=threads), want):
            assert_identical(g, w, f"callable, {threads} threads")
        with pytest.raises(Boom, match="out of range"):
            ddpkit.solve_batch([good[0], problem(60.0), good[1]], threads=threads)
    # Nothing left pending: the next solve on this thread is clean.
    assert_identical(ddpkit.Solver(good[0]).solve(), want[0], "after the exception")


# ---- Safe-CDDP -----------------------------------------------------------------------------------


def point(x0: np.ndarray) -> ddpkit.Problem:
    return ddpkit.Problem(
        x0=x0,
        dynamics=ddpkit.DoubleIntegrator2D(dt=0.05),
        running_cost=ddpkit.QuadraticCost(Q=np.zeros((4, 4)), R=0.1 * np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=np.diag([100.0, 100.0, 10.0, 10.0]), x_ref=np.array([3.0, 3.0, 0.0, 0.0])),
        horizon=60,
        u_min=-0.8,
        u_max=0.8,
    )


def assert_safe_identical(got: ddpkit.SafeSolution, want: ddpkit.SafeSolution, what: str) -> None:
    assert np.array_equal(got.xs, want.xs), f"{what}: xs"
    assert np.array_equal(got.us, want.us), f"{what}: us"
    assert got.cost == want.cost, f"{what}: cost"
    assert np.array_equal(got.K, want.K), f"{what}: K"
    assert np.array_equal(got.covariances, want.covariances), f"{what}: covariances"
    assert np.array_equal(got.margins, want.margins), f"{what}: margins"
    assert got.status == want.status and got.iterations == want.iterations, what
    assert got.table() == want.table(), f"{what}: iteration table"


def test_safe_batch_equals_one_at_a_time() -> None:
    rng = np.random.default_rng(8)
    problems = [point(np.array([*rng.uniform(-0.3, 0.3, 2), 0.0, 0.0])) for _ in range(5)]
    obstacles = [ddpkit.Circle(center=np.array([1.5, 1.5]), radius=0.5)]
    tightening = ddpkit.Tightening(beta=0.9, sigma_w=1e-5 * np.eye(4))
    for t in (None, tightening):
        want = [ddpkit.SafeCddpSolver(p, obstacles, t, max_iterations=60).solve() for p in problems]
        assert len({w.cost for w in want}) == len(problems)
        for threads in (1, 2, 4):
            got = ddpkit.solve_batch_safe(problems, obstacles, t, threads=threads, max_iterations=60)
            for i, (g, w) in enumerate(zip(got, want)):
                assert_safe_identical(g, w, f"tightening={t is not None}, {threads} threads, problem {i}")


def test_safe_batch_constraints_per_problem() -> None:
    problems = [point(np.zeros(4)), point(np.array([0.2, 0.0, 0.0, 0.0]))]
    per = [[ddpkit.Circle(center=np.array([1.5, 1.5]), radius=0.5)], [ddpkit.Circle(center=np.array([1.0, 1.2]), radius=0.3)]]
    want = [ddpkit.SafeCddpSolver(p, c, max_iterations=60).solve() for p, c in zip(problems, per)]
    got = ddpkit.solve_batch_safe(problems, per, threads=2, max_iterations=60)
    for i, (g, w) in enumerate(zip(got, want)):
        assert_safe_identical(g, w, f"per-problem constraints, problem {i}")
    with pytest.raises(ddpkit.ShapeError) as e:
        ddpkit.solve_batch_safe(problems, [per[0]] * 3)
    assert e.value.field == "constraints"
    with pytest.raises(ddpkit.InvalidInputError) as e:
        ddpkit.solve_batch_safe(problems, [per[0], ["no"]])
    assert e.value.field == "constraints[1][0]"
    with pytest.raises(ddpkit.InvalidInputError) as e:
        ddpkit.solve_batch_safe(problems, [per[0], per[1][0]])
    assert e.value.field == "constraints[1]"


def test_safe_batch_bad_input_names_the_field() -> None:
    c = [ddpkit.Circle(center=np.array([1.5, 1.5]), radius=0.5)]
    with pytest.raises(ddpkit.InvalidInputError) as e:
        ddpkit.solve_batch_safe([], c)
    assert e.value.field == "problems"
    with pytest.raises(ddpkit.InvalidInputError) as e:
        ddpkit.solve_batch_safe([point(np.zeros(4))], c, threads=0)
    assert e.value.field == "threads"
    with pytest.raises(ddpkit.ShapeError) as e:
        ddpkit.solve_batch_safe([point(np.zeros(4)), p1(np.zeros(3), horizon=60)], c)
    assert e.value.field == "problems[1]"


# ---- parallel derivatives --------------------------------------------------------------------------


def quadrotor(horizon: int) -> ddpkit.Problem:
    goal = np.zeros(12)
    goal[0], goal[2] = 1.0, 0.5
    q = ddpkit.Quadrotor(dt=0.02)
    return ddpkit.Problem(
        x0=np.zeros(12),
        dynamics=q,
        running_cost=ddpkit.QuadraticCost(Q=np.zeros((12, 12)), R=np.diag([0.1, 1.0, 1.0, 1.0])),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=np.diag([100.0] * 3 + [10.0] * 6 + [1.0] * 3), x_ref=goal),
        horizon=horizon,
    )


@pytest.mark.parametrize("method", ["ilqr", "ddp"])
def test_derivative_threads_are_bit_identical(method: str) -> None:
    for problem in (quadrotor(120), p1(np.array([-1.0, -1.0, 1.0]), bounded=True)):
        want = ddpkit.Solver(problem, method=method, max_iterations=40).solve()
        for threads in (2, 3):
            solver = ddpkit.Solver(problem, method=method, max_iterations=40, derivative_threads=threads)
            assert solver.settings["derivative_threads"] == threads
            assert_identical(solver.solve(), want, f"{method}, {threads} derivative threads")


def test_derivative_threads_bad_values_name_the_field() -> None:
    problem = p1(np.zeros(3), horizon=10)
    for bad in (0, -1, 10**6):
        with pytest.raises(ddpkit.InvalidInputError) as e:
            ddpkit.Solver(problem, derivative_threads=bad)
        assert "derivative_threads" in e.value.field
    assert ddpkit.default_settings()["derivative_threads"] == 1


def test_derivative_threads_with_a_callable_model_keep_its_exception() -> None:
    calls = {"n": 0}

    def flaky(x, u):  # type: ignore[no-untyped-def]
        calls["n"] += 1
        if calls["n"] > 200:
            raise Boom("out of range")
        return np.array([x[0] + 0.1 * u[0], x[1] + 0.1 * u[1], x[2]])

    problem = ddpkit.Problem(
        x0=np.ones(3),
        dynamics=ddpkit.Dynamics.from_callable(flaky, nx=3, nu=2),
        running_cost=ddpkit.QuadraticCost(Q=np.eye(3), R=np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=np.eye(3)),
        horizon=30,
    )
    with pytest.raises(Boom):
        ddpkit.Solver(problem, derivative_threads=2).solve()
