"""Solver behaviour from Python: reference optima, Riccati gains, bounds, warm starts, the GIL."""

from __future__ import annotations

import inspect
import threading
import time

import numpy as np
import pytest

import ddpkit
from conftest import P1_COST, p1_problem


@pytest.mark.parametrize("method", ["ilqr", "ddp"])
def test_p1_unicycle_reaches_the_peer_optimum(p1: ddpkit.Problem, method: str) -> None:
    sol = ddpkit.Solver(p1, method=method).solve()
    assert sol.status == "converged"
    assert sol.converged
    assert abs(sol.cost - P1_COST) <= 1e-6 * P1_COST
    # Shapes of everything returned.
    assert sol.xs.shape == (101, 3) and sol.us.shape == (100, 2)
    assert sol.K.shape == (100, 2, 3) and sol.k.shape == (100, 2)
    assert sol.xs.dtype == np.float64
    np.testing.assert_array_equal(sol.xs[0], [-1.0, -1.0, 1.0])
    # The returned trajectory is the rollout of the returned controls, and its cost is `cost`.
    np.testing.assert_allclose(p1.rollout(sol.us), sol.xs, rtol=0, atol=1e-12)
    assert p1.cost(sol.xs, sol.us) == pytest.approx(sol.cost, rel=1e-12)
    # Statistics.
    assert sol.iterations >= 1
    assert sol.initial_cost > sol.cost
    hist = sol.cost_history
    assert hist.shape == (sol.iterations + 1,)
    assert hist[0] == sol.initial_cost and hist[-1] == sol.cost
    assert np.all(np.diff(hist) <= 0.0)
    assert sol.gradient < 1e-9
    assert sol.solve_time > 0.0
    table = sol.table()
    assert table.splitlines()[0].startswith("iter")
    assert "status: converged" in table


def test_cold_solves_are_repeatable(p1: ddpkit.Problem) -> None:
    solver = ddpkit.Solver(p1)
    a = solver.solve()
    b = solver.solve()  # cold again: warm_start defaults to False
    assert a.iterations == b.iterations
    np.testing.assert_array_equal(a.us, b.us)
    c = solver.solve(warm_start=True)  # from the optimum: nothing left to do
    assert c.iterations == 0
    assert c.cost == pytest.approx(a.cost, rel=1e-12)


def test_us0_sets_the_initial_guess(p1: ddpkit.Problem) -> None:
    solver = ddpkit.Solver(p1)
    opt = solver.solve()
    again = solver.solve(us0=opt.us)
    assert again.initial_cost == pytest.approx(opt.cost, rel=1e-12)
    assert again.iterations == 0
    solver.reset()
    np.testing.assert_array_equal(solver.controls, np.zeros((100, 2)))


def riccati(As, Bs, Qs, Rs, Qf):
    """Discrete Riccati recursion; gains with the convention u = K x."""
    P = Qf
    gains = []
    for A, B, Q, R in reversed(list(zip(As, Bs, Qs, Rs))):
        K = -np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
        P = Q + A.T @ P @ A + A.T @ P @ B @ K
        P = 0.5 * (P + P.T)
        gains.append(K)
    return gains[::-1]


def random_psd(rng: np.random.Generator, n: int, shift: float) -> np.ndarray:
    M = rng.standard_normal((n, n))
    return M @ M.T + shift * np.eye(n)


@pytest.mark.parametrize("method", ["ilqr", "ddp"])
@pytest.mark.parametrize("time_varying", [False, True])
def test_lq_problem_matches_riccati(method: str, time_varying: bool) -> None:
    rng = np.random.default_rng(7 if time_varying else 3)
    nx, nu, N = 4, 2, 30
    count = N if time_varying else 1
    As = [np.eye(nx) + 0.1 * rng.standard_normal((nx, nx)) for _ in range(count)]
    Bs = [rng.standard_normal((nx, nu)) for _ in range(count)]
    Qs = [random_psd(rng, nx, 0.0) for _ in range(count)]  # PSD, possibly singular
    Rs = [random_psd(rng, nu, 0.5) for _ in range(count)]
    Qf = random_psd(rng, nx, 1.0)
    x0 = rng.standard_normal(nx)
    models = [ddpkit.LinearDynamics(A, B) for A, B in zip(As, Bs)]
    costs = [ddpkit.QuadraticCost(Q, R) for Q, R in zip(Qs, Rs)]
    problem = ddpkit.Problem(
        x0,
        models if time_varying else models[0],
        costs if time_varying else costs[0],
        ddpkit.QuadraticTerminal(Qf),
        N,
    )
    sol = ddpkit.Solver(problem, method=method).solve()
    assert sol.status == "converged"

    full = lambda v: v if time_varying else v * N  # noqa: E731
    gains = riccati(full(As), full(Bs), full(Qs), full(Rs), Qf)
    for k in range(N):
        np.testing.assert_allclose(sol.K[k], gains[k], rtol=0, atol=1e-9 * max(1.0, np.abs(gains[k]).max()))
    # The optimal trajectory is the closed loop u_k = K_k x_k.
    x = x0
    A_all, B_all = full(As), full(Bs)
    for k in range(N):
        u = gains[k] @ x
        np.testing.assert_allclose(sol.us[k], u, rtol=0, atol=1e-8 * max(1.0, np.abs(u).max()))
        x = A_all[k] @ x + B_all[k] @ u
    np.testing.assert_allclose(sol.xs[-1], x, rtol=0, atol=1e-8)
    # Feed-forward vanishes at the optimum.
    assert np.abs(sol.k).max() < 1e-6


def car_problem(bounds: bool) -> ddpkit.Problem:
    """Benchmark P2 without obstacles: kinematic car to (4, 0, 0, 0) with a control box."""
    return ddpkit.Problem(
        x0=np.zeros(4),
        dynamics=ddpkit.Car(dt=0.05),
        running_cost=ddpkit.QuadraticCost(Q=np.zeros((4, 4)), R=[0.1, 0.1]),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=[100.0, 100.0, 10.0, 10.0], x_ref=[4.0, 0.0, 0.0, 0.0]),
        horizon=120,
        u_min=[-0.4, -0.5] if bounds else None,
        u_max=[0.4, 0.5] if bounds else None,
    )


def test_box_bounds_are_respected() -> None:
    free = ddpkit.Solver(car_problem(bounds=False)).solve()
    assert free.status == "converged"
    # Without the box the optimal acceleration leaves it, so the box is active below.
    assert np.abs(free.us[:, 1]).max() > 0.5
    boxed_problem = car_problem(bounds=True)
    lo, hi = boxed_problem.bounds
    np.testing.assert_array_equal(lo, [-0.4, -0.5])
    boxed = ddpkit.Solver(boxed_problem).solve()
    assert boxed.status == "converged"
    assert np.all(boxed.us >= lo - 1e-12) and np.all(boxed.us <= hi + 1e-12)
    assert np.isclose(np.abs(boxed.us[:, 1]).max(), 0.5)
    # The box costs something, and the bounded optimum is still a decent one.
    assert boxed.cost > free.cost
    assert boxed.cost < 0.5 * boxed.initial_cost
    # A clamped control has no feedback on that channel.
    clamped = np.isclose(np.abs(boxed.us[:, 1]), 0.5)
    assert np.all(boxed.K[clamped, 1, :] == 0.0)


def test_scalar_bounds_broadcast() -> None:
    p = ddpkit.Problem(
        np.zeros(4),
        ddpkit.Car(),
        ddpkit.ControlSquared(0.05),
        ddpkit.QuadraticTerminal([100.0, 100.0, 10.0, 10.0], x_ref=[4.0, 0.0, 0.0, 0.0]),
        120,
        u_min=-0.3,
        u_max=0.3,
    )
    sol = ddpkit.Solver(p).solve()
    assert np.abs(sol.us).max() <= 0.3 + 1e-12


def test_warm_start_after_shift_equals_a_fresh_solve() -> None:
    problem = p1_problem()
    solver = ddpkit.Solver(problem)
    first = solver.solve()
    # Receding horizon: apply u_0, move to x_1, shift, warm-start.
    problem.set_x0(first.xs[1])
    np.testing.assert_array_equal(problem.x0, first.xs[1])
    solver.shift()
    np.testing.assert_array_equal(solver.controls[:-1], first.us[1:])
    np.testing.assert_array_equal(solver.controls[-1], first.us[-1])
    warm = solver.solve(warm_start=True)
    assert warm.status == "converged"
    assert warm.initial_cost < first.initial_cost  # it really started from the shifted solution

    fresh_problem = p1_problem()
    fresh_problem.set_x0(first.xs[1])
    fresh = ddpkit.Solver(fresh_problem).solve()
    assert fresh.status == "converged"
    assert warm.cost == pytest.approx(fresh.cost, rel=1e-8)
    np.testing.assert_allclose(warm.us, fresh.us, atol=1e-5)
    assert warm.iterations < fresh.iterations


def test_solver_defaults_are_the_rust_defaults() -> None:
    sig = inspect.signature(ddpkit.Solver)
    defaults = ddpkit.default_settings()
    for name, value in defaults.items():
        assert sig.parameters[name].default == value, name
    assert ddpkit.Solver(p1_problem()).settings == defaults


def test_settings_reach_the_solver(p1: ddpkit.Problem) -> None:
    sol = ddpkit.Solver(p1, max_iterations=3).solve()
    assert sol.status == "max_iterations"
    assert sol.iterations <= 3
    s = ddpkit.Solver(p1, method="DDP", regularization="state", mu_init=1.0).settings
    assert s["method"] == "ddp" and s["regularization"] == "state" and s["mu_init"] == 1.0
    sol = ddpkit.Solver(p1, regularization="state", mu_init=1e-3).solve()
    assert sol.cost == pytest.approx(P1_COST, rel=1e-6)


def test_gil_is_released_during_a_solve() -> None:
    # A solve long enough to see (about 0.1-1 s); the main thread must keep running Python
    # throughout it. With the GIL held, the main thread would be frozen for the whole window.
    problem = p1_problem(horizon=40_000)
    solver = ddpkit.Solver(problem)
    started = threading.Event()
    window: dict[str, float] = {}

    def work() -> None:
        started.set()
        window["start"] = time.perf_counter()
        solver.solve()
        window["end"] = time.perf_counter()

    thread = threading.Thread(target=work)
    thread.start()
    started.wait()
    stamps: list[float] = []  # the main thread's progress, sampled every millisecond
    last = 0.0
    while thread.is_alive():
        now = time.perf_counter()
        if now - last >= 1e-3:
            stamps.append(now)
            last = now
    thread.join()
    start, end = window["start"], window["end"]
    seconds = end - start
    assert seconds > 0.05, "the solve was too short to tell"
    inside = [t for t in stamps if start <= t <= end]
    points = [start, *inside, end]
    longest_freeze = max(b - a for a, b in zip(points, points[1:]))
    assert len(inside) >= 10, (len(inside), seconds)
    assert longest_freeze < 0.5 * seconds, (longest_freeze, seconds)


def test_parallel_solves_in_threads_complete_and_agree() -> None:
    problem = p1_problem(horizon=2000)
    reference = ddpkit.Solver(problem).solve()
    solutions: list[ddpkit.Solution] = []
    lock = threading.Lock()

    def work() -> None:
        s = ddpkit.Solver(problem)  # one solver per thread, the problem shared
        for _ in range(3):
            sol = s.solve()
            with lock:
                solutions.append(sol)

    threads = [threading.Thread(target=work) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
        assert not t.is_alive(), "deadlock"
    assert len(solutions) == 12
    for sol in solutions:
        np.testing.assert_array_equal(sol.us, reference.us)


def test_ddpen_style_costs_solve() -> None:
    # Goal distance + control effort + obstacle hinge, as DDPEN eqs. (3)-(7).
    running = ddpkit.CostSum(
        [
            (1.0, ddpkit.ControlSquared(0.05)),
            (10.0, ddpkit.ObstacleHinge([[1.0, 0.05], [1.0, -0.05]], margin=0.3)),
        ]
    )
    terminal = ddpkit.TerminalSum([(10.0, ddpkit.SmoothDistance([2.0, 0.0], eps=1e-2))])
    problem = ddpkit.Problem([0.0, 0.0, 0.0], ddpkit.Unicycle(0.1), running, terminal, 40)
    sol = ddpkit.Solver(problem, max_iterations=500).solve(us0=np.tile([0.5, 0.0], (40, 1)))
    assert sol.cost < sol.initial_cost
    assert np.linalg.norm(sol.xs[-1, :2] - [2.0, 0.0]) < 0.2
