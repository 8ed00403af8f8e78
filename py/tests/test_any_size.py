"""Problems of any size from Python: run-time `(nx, nu)` outside the compiled pairs.

References: the discrete Riccati recursion (LQ problems) and the KKT conditions of the
bound-constrained LQ problem (box-DDP). Bad sizes are exceptions of the ddpkit tree naming the
argument; nothing panics.
"""

from __future__ import annotations

import numpy as np
import pytest

import ddpkit


def random_lq(rng: np.random.Generator, nx: int, nu: int):
    """Stable-ish `A` (spectral radius 0.98), `B` scaled to unit-size columns, PSD `Q` (rank
    deficient), PD `R`, PSD `Qf`, and `x0`."""
    M = rng.standard_normal((nx, nx))
    A = 0.98 * M / np.abs(np.linalg.eigvals(M)).max()
    B = rng.standard_normal((nx, nu)) / np.sqrt(nx)
    G = rng.standard_normal((nx, nx // 2 + 1))
    Q = G @ G.T / nx
    H = rng.standard_normal((nu, nu))
    R = H @ H.T / nu + 0.5 * np.eye(nu)
    F = rng.standard_normal((nx, nx))
    Qf = F @ F.T / nx + np.eye(nx)
    x0 = rng.standard_normal(nx)
    return A, B, Q, R, Qf, x0


def riccati(A, B, Q, R, Qf, N):
    """Gains `K_k` (convention `u = K x`) of the finite-horizon discrete Riccati recursion."""
    P = Qf
    gains = []
    for _ in range(N):
        K = -np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
        P = Q + A.T @ P @ (A + B @ K)
        P = 0.5 * (P + P.T)
        gains.append(K)
    return gains[::-1]


def lq_problem(A, B, Q, R, Qf, x0, N, **bounds) -> ddpkit.Problem:
    return ddpkit.Problem(
        x0,
        ddpkit.LinearDynamics(A, B),
        ddpkit.QuadraticCost(Q, R),
        ddpkit.QuadraticTerminal(Qf),
        N,
        **bounds,
    )


@pytest.mark.parametrize("method", ["ilqr", "ddp"])
@pytest.mark.parametrize("nx, nu", [(7, 3), (30, 10), (64, 32)])
def test_lq_problem_at_run_time_size_equals_riccati(nx: int, nu: int, method: str) -> None:
    assert (nx, nu) not in ddpkit.supported_dimensions()
    rng = np.random.default_rng(1000 * nx + nu)
    A, B, Q, R, Qf, x0 = random_lq(rng, nx, nu)
    N = 25
    problem = lq_problem(A, B, Q, R, Qf, x0, N)
    assert (problem.nx, problem.nu, problem.horizon) == (nx, nu, N)
    sol = ddpkit.Solver(problem, method=method).solve()
    assert sol.status == "converged"
    assert sol.xs.shape == (N + 1, nx) and sol.us.shape == (N, nu) and sol.K.shape == (N, nu, nx)

    gains = riccati(A, B, Q, R, Qf, N)
    x = x0
    for k in range(N):
        np.testing.assert_allclose(sol.K[k], gains[k], rtol=0, atol=1e-9, err_msg=f"K[{k}]")
        u = gains[k] @ x
        np.testing.assert_allclose(sol.us[k], u, rtol=0, atol=1e-9, err_msg=f"us[{k}]")
        np.testing.assert_allclose(sol.xs[k], x, rtol=0, atol=1e-9, err_msg=f"xs[{k}]")
        x = A @ x + B @ u
    np.testing.assert_allclose(sol.xs[N], x, rtol=0, atol=1e-9)
    # The trajectory is the model's rollout, its cost the problem's cost.
    np.testing.assert_allclose(problem.rollout(sol.us), sol.xs, rtol=0, atol=1e-12)
    assert problem.cost(sol.xs, sol.us) == pytest.approx(sol.cost, rel=1e-12)


def test_the_models_and_costs_at_a_run_time_size() -> None:
    rng = np.random.default_rng(5)
    A, B, Q, R, Qf, x0 = random_lq(rng, 7, 3)
    c = rng.standard_normal(7)
    model = ddpkit.LinearDynamics(A, B, c=c)
    assert (model.nx, model.nu) == (7, 3) and model.has_second_order
    x, u = rng.standard_normal(7), rng.standard_normal(3)
    np.testing.assert_allclose(model.step(x, u), A @ x + B @ u + c, rtol=1e-14)
    fx, fu = model.jacobians(x, u)
    np.testing.assert_array_equal(fx, A)
    np.testing.assert_array_equal(fu, B)
    xr, ur = rng.standard_normal(7), rng.standard_normal(3)
    cost = ddpkit.QuadraticCost(Q, R, x_ref=xr, u_ref=ur)
    assert cost.value(x, u) == pytest.approx(0.5 * (x - xr) @ Q @ (x - xr) + 0.5 * (u - ur) @ R @ (u - ur))
    assert ddpkit.QuadraticTerminal(Qf).value(x) == pytest.approx(0.5 * x @ Qf @ x)
    assert ddpkit.ControlSquared(2.0).value(x, u) == pytest.approx(2.0 * u @ u)
    with pytest.raises(ddpkit.ShapeError, match=r"x has shape \(6,\), expected \(7,\)"):
        model.step(np.zeros(6), np.zeros(3))


def test_time_varying_sums_and_warm_start_at_a_run_time_size() -> None:
    rng = np.random.default_rng(9)
    nx, nu, N = 6, 4, 12
    systems = [random_lq(rng, nx, nu) for _ in range(N)]
    models = [ddpkit.LinearDynamics(s[0], s[1]) for s in systems]
    costs = [ddpkit.CostSum([(1.0, ddpkit.QuadraticCost(s[2], s[3])), (0.5, ddpkit.ControlSquared(0.1))]) for s in systems]
    Qf, x0 = systems[0][4], systems[0][5]
    problem = ddpkit.Problem(x0, models, costs, ddpkit.TerminalSum([(2.0, ddpkit.QuadraticTerminal(Qf))]), N)
    solver = ddpkit.Solver(problem)
    first = solver.solve()
    assert first.status == "converged"
    # Riccati with the summed weights, per knot.
    P = 2.0 * Qf
    gains = []
    for A, B, Q, R, _, _ in reversed([s for s in systems]):
        Rk = R + 0.5 * 0.2 * np.eye(nu)
        K = -np.linalg.solve(Rk + B.T @ P @ B, B.T @ P @ A)
        P = Q + A.T @ P @ (A + B @ K)
        gains.append(K)
    for k, K in enumerate(gains[::-1]):
        np.testing.assert_allclose(first.K[k], K, rtol=0, atol=1e-9)
    again = solver.solve(warm_start=True)
    assert again.iterations == 0 and again.cost == pytest.approx(first.cost, rel=1e-12)
    solver.shift()
    np.testing.assert_array_equal(solver.controls[:-1], first.us[1:])


def test_box_ddp_at_a_run_time_size_satisfies_the_kkt_conditions() -> None:
    rng = np.random.default_rng(21)
    nx, nu, N = 5, 3, 20
    A, B, Q, R, Qf, _ = random_lq(rng, nx, nu)
    x0 = 3.0 * rng.standard_normal(nx)
    u_min, u_max = -0.4 * np.ones(nu), np.array([0.3, 0.5, 0.2])
    problem = lq_problem(A, B, Q, R, Qf, x0, N, u_min=u_min, u_max=u_max)
    free = ddpkit.Solver(lq_problem(A, B, Q, R, Qf, x0, N)).solve()
    assert np.any(free.us < u_min) or np.any(free.us > u_max), "the box must be active"
    sol = ddpkit.Solver(problem).solve()
    assert sol.status == "converged"
    us, xs = sol.us, sol.xs
    assert np.all(us >= u_min) and np.all(us <= u_max)

    # dJ/du_k through the adjoint: lambda_N = Qf x_N, lambda_k = Q x_k + A^T lambda_{k+1},
    # g_k = R u_k + B^T lambda_{k+1}.
    lam = Qf @ xs[N]
    g = np.zeros((N, nu))
    for k in reversed(range(N)):
        g[k] = R @ us[k] + B.T @ lam
        lam = Q @ xs[k] + A.T @ lam
    at_lower = np.isclose(us, u_min, rtol=0, atol=1e-12)
    at_upper = np.isclose(us, u_max, rtol=0, atol=1e-12)
    inside = ~(at_lower | at_upper)
    assert at_lower.sum() + at_upper.sum() >= 3, "several bounds are active at the optimum"
    tol = 1e-8 * max(1.0, np.abs(g).max())
    # Stationarity on free controls, the right sign of the multipliers on active ones.
    assert np.abs(g[inside]).max() <= tol
    assert np.all(g[at_lower] >= -tol)
    assert np.all(g[at_upper] <= tol)
    # Feedback only on the free channels.
    for k in range(N):
        assert np.all(sol.K[k][~inside[k]] == 0.0)


def test_position_terms_need_a_compiled_state_size() -> None:
    rng = np.random.default_rng(2)
    A, B, Q, R, Qf, x0 = random_lq(rng, 7, 3)
    with pytest.raises(ddpkit.InvalidInputError, match="SmoothDistance is available for the compiled") as e:
        ddpkit.Problem(x0, ddpkit.LinearDynamics(A, B), ddpkit.QuadraticCost(Q, R), ddpkit.SmoothDistance([1.0, 0.0]), 5)
    assert e.value.field == "terminal_cost"


def test_safe_cddp_and_mpc_at_run_time_size_match_compiled_size() -> None:
    # The point robot (4, 2) at its compiled size, and the same problem as a run-time-size
    # (5, 2) problem whose fifth state is decoupled and unweighted: the same trajectory.
    import ddpkit as d

    dt = 0.05
    A4 = np.eye(4)
    A4[0, 2] = A4[1, 3] = dt
    B4 = np.zeros((4, 2))
    B4[0, 0] = B4[1, 1] = 0.5 * dt * dt
    B4[2, 0] = B4[3, 1] = dt
    A5 = np.eye(5)
    A5[:4, :4] = A4
    B5 = np.zeros((5, 2))
    B5[:4] = B4
    goal4 = np.array([3.0, 3.0, 0.0, 0.0])
    goal5 = np.append(goal4, 0.0)

    def problem(A, B, goal):
        n = A.shape[0]
        qf = np.diag([100.0, 100.0, 10.0, 10.0, 0.0][:n])
        return d.Problem(np.zeros(n), d.LinearDynamics(A, B), d.QuadraticCost(np.zeros((n, n)), 0.1 * np.eye(2)),
                         d.QuadraticTerminal(qf, goal), 100, u_min=-0.8, u_max=0.8)

    circle = d.Circle([1.5, 1.4], 0.5, indices=(0, 1))
    fixed = d.SafeCddpSolver(problem(A4, B4, goal4), [circle]).solve()
    dynamic = d.SafeCddpSolver(problem(A5, B5, goal5), [circle]).solve()
    assert fixed.status == dynamic.status == "converged"
    assert dynamic.max_violation <= 1e-8
    np.testing.assert_allclose(dynamic.xs[:, :4], fixed.xs, atol=1e-7)
    np.testing.assert_allclose(dynamic.us, fixed.us, atol=1e-7)

    # A tightening and an MPC episode at the run-time size.
    sigma5 = np.diag([1e-5, 1e-5, 1e-6, 1e-6, 1e-8])
    t = d.Tightening(0.95, sigma5)
    mpc = d.Mpc(problem(A5, B5, goal5), [circle], goal=goal5, sigma_w=sigma5, tightening=t,
                iterations=5, initial_iterations=30)
    episode = mpc.run_episode(3)
    assert episode.collisions == 0
    assert episode.xs.shape[1] == 5
    # Sizes that disagree are errors naming the argument.
    with pytest.raises(d.ShapeError, match="sigma_w"):
        d.SafeCddpSolver(problem(A5, B5, goal5), [circle], tightening=d.Tightening(0.95, np.eye(4) * 1e-5))


# ------------------------------------------------------------------------------------------------
# Bad sizes


def make(nx: int = 7, nu: int = 3, **override):
    """The pieces of a (nx, nu) LQ problem, with some replaced."""
    rng = np.random.default_rng(0)
    A, B, Q, R, Qf, x0 = random_lq(rng, nx, nu)
    args = dict(A=A, B=B, Q=Q, R=R, Qf=Qf, x0=x0, u_min=None, u_max=None)
    args.update(override)
    return args


def build(args) -> ddpkit.Problem:
    return ddpkit.Problem(
        args["x0"],
        ddpkit.LinearDynamics(args["A"], args["B"]),
        ddpkit.QuadraticCost(args["Q"], args["R"]),
        ddpkit.QuadraticTerminal(args["Qf"]),
        4,
        u_min=args["u_min"],
        u_max=args["u_max"],
    )


@pytest.mark.parametrize(
    "override, error, field, message",
    [
        (dict(B=np.ones((6, 3))), ddpkit.ShapeError, "B", r"B has shape \(6, 3\), expected \(7, nu\)"),
        (dict(A=np.ones((7, 6))), ddpkit.ShapeError, "A", r"A has shape \(7, 6\), expected \(nx, nx\)"),
        (dict(Q=np.eye(6)), ddpkit.ShapeError, "running_cost.Q", r"running_cost\.Q has shape \(6, 6\), expected \(7, 7\)"),
        (dict(R=np.eye(4)), ddpkit.ShapeError, "running_cost.R", r"running_cost\.R has shape \(4, 4\), expected \(3, 3\)"),
        (dict(Qf=np.eye(8)), ddpkit.ShapeError, "terminal_cost.Qf", r"terminal_cost\.Qf has shape \(8, 8\), expected \(7, 7\)"),
        (dict(x0=np.zeros(6)), ddpkit.ShapeError, "x0", r"x0 has shape \(6,\), expected \(7,\)"),
        (dict(u_min=np.zeros(2)), ddpkit.ShapeError, "u_min", r"u_min has shape \(2,\), expected \(3,\)"),
        (dict(u_max=np.ones(4)), ddpkit.ShapeError, "u_max", r"u_max has shape \(4,\), expected \(3,\)"),
        (dict(A=np.zeros((0, 0)), B=np.zeros((0, 3))), ddpkit.InvalidInputError, "A.shape[0]", "must be at least 1"),
        (dict(B=np.zeros((7, 0))), ddpkit.InvalidInputError, "B.shape[1]", "must be at least 1"),
        (dict(Q=np.zeros((0, 0))), ddpkit.InvalidInputError, "Q.shape[0]", "must be at least 1"),
        (dict(R=np.zeros(0)), ddpkit.InvalidInputError, "R.shape[0]", "must be at least 1"),
        (dict(Qf=np.zeros((0, 0))), ddpkit.InvalidInputError, "Qf.shape[0]", "must be at least 1"),
    ],
)
def test_sizes_that_disagree_are_errors_naming_the_argument(override, error, field, message) -> None:
    with pytest.raises(error, match=message) as e:
        build(make(**override))
    assert e.value.field == field


def test_sizes_past_the_limits_are_errors_naming_the_argument_and_the_limit() -> None:
    with pytest.raises(ddpkit.InvalidInputError, match=r"A\.shape\[0\].*1025 exceeds the limit of 1024") as e:
        ddpkit.LinearDynamics(np.eye(1025), np.zeros((1025, 1)))
    assert e.value.field == "A.shape[0]"
    with pytest.raises(ddpkit.InvalidInputError, match=r"B\.shape\[1\].*513 exceeds the limit of 512") as e:
        ddpkit.LinearDynamics(np.eye(3), np.zeros((3, 513)))
    assert e.value.field == "B.shape[1]"
    with pytest.raises(ddpkit.InvalidInputError, match=r"Q\.shape\[0\].*exceeds the limit of 1024") as e:
        ddpkit.QuadraticCost(np.ones(10**6), np.ones(2))  # a diagonal: refused before it is expanded
    assert e.value.field == "Q.shape[0]"
    with pytest.raises(ddpkit.InvalidInputError, match=r"R\.shape\[0\].*exceeds the limit of 512"):
        ddpkit.QuadraticCost(np.ones(3), np.ones(513))
    with pytest.raises(ddpkit.InvalidInputError, match=r"Qf\.shape\[0\].*exceeds the limit of 1024"):
        ddpkit.QuadraticTerminal(np.ones(2000))
    # The limits themselves are fine.
    assert ddpkit.LinearDynamics(np.eye(3), np.zeros((3, 512))).nu == 512


def test_random_shapes_never_panic() -> None:
    """Pieces of random sizes: a solve or a ddpkit exception, never a crash or a PanicException
    (which is not an Exception, so it would escape the `except` below)."""
    rng = np.random.default_rng(123)
    sizes = [0, 1, 2, 3, 4, 5, 7]
    outcomes = {"solved": 0, "rejected": 0}
    for _ in range(300):
        nx, nu = rng.choice(sizes[1:]), rng.choice(sizes[1:])
        pick = lambda n: n if rng.random() < 0.8 else rng.choice(sizes)  # noqa: E731
        try:
            problem = ddpkit.Problem(
                rng.standard_normal(pick(nx)),
                ddpkit.LinearDynamics(0.5 * np.eye(pick(nx)), np.ones((pick(nx), pick(nu)))),
                ddpkit.QuadraticCost(np.ones(pick(nx)), np.ones(pick(nu))),
                ddpkit.QuadraticTerminal(np.ones(pick(nx))),
                int(rng.integers(1, 4)),
                u_min=None if rng.random() < 0.5 else -np.ones(pick(nu)),
            )
            us0 = None if rng.random() < 0.5 else np.zeros((problem.horizon, pick(nu)))
            ddpkit.Solver(problem, method=str(rng.choice(["ilqr", "ddp"]))).solve(us0=us0)
            outcomes["solved"] += 1
        except ddpkit.DdpError:
            outcomes["rejected"] += 1
    assert outcomes["solved"] > 20 and outcomes["rejected"] > 20, outcomes
