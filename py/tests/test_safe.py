"""Safe-CDDP from Python: constraints, the constrained solver, tightening (eqs. 19-20), the MPC."""

from __future__ import annotations

import threading

import numpy as np
import pytest

import ddpkit

#: Benchmark P3 (bench/problems.md): its optimum found by every peer.
P3_COST = 1.8958999
P3_OBSTACLES = [(1.0, 1.1, 0.4), (2.0, 1.9, 0.4), (2.6, 2.9, 0.25)]


def p3_problem() -> ddpkit.Problem:
    return ddpkit.Problem(
        x0=np.zeros(4),
        dynamics=ddpkit.DoubleIntegrator2D(dt=0.05),
        running_cost=ddpkit.QuadraticCost(Q=np.zeros(4), R=[0.1, 0.1]),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=[100.0, 100.0, 10.0, 10.0], x_ref=[3.0, 3.0, 0.0, 0.0]),
        horizon=100,
        u_min=-0.8,
        u_max=0.8,
    )


def p3_obstacles(form: str = "squared") -> list[ddpkit.Constraint]:
    return [ddpkit.Circle((ox, oy), r, form=form) for ox, oy, r in P3_OBSTACLES]


def violation(xs: np.ndarray) -> float:
    """Largest `r^2 - |p - o|^2` over x_1..x_N, in numpy."""
    worst = 0.0
    for ox, oy, r in P3_OBSTACLES:
        worst = max(worst, float(np.max(r**2 - (xs[1:, 0] - ox) ** 2 - (xs[1:, 1] - oy) ** 2)))
    return worst


def clearance(xs: np.ndarray) -> float:
    """Smallest `|p - o| - r` over x_1..x_N (negative inside an obstacle)."""
    return min(float(np.min(np.hypot(xs[1:, 0] - ox, xs[1:, 1] - oy) - r)) for ox, oy, r in P3_OBSTACLES)


def test_p3_reaches_the_peers_optimum() -> None:
    solver = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles())
    sol = solver.solve()
    assert sol.converged, sol.table()
    assert sol.cost <= P3_COST * (1 + 1e-6)
    assert sol.max_violation <= 1e-6
    assert violation(sol.xs) <= 1e-6
    assert sol.xs.shape == (101, 4) and sol.us.shape == (100, 2)
    assert sol.K.shape == (100, 2, 4) and sol.k.shape == (100, 2)
    assert np.all(np.abs(sol.us) <= 0.8 + 1e-12)
    # Without obstacles the constrained solver is the plain one.
    free = ddpkit.SafeCddpSolver(p3_problem(), []).solve()
    plain = ddpkit.Solver(p3_problem(), gradient_tolerance=1e-12, cost_tolerance=1e-12).solve()
    assert free.cost == pytest.approx(plain.cost, rel=1e-8)


@pytest.mark.parametrize("warm_up", ["portfolio", "barrier", "augmented_lagrangian"])
def test_every_warm_up_reaches_p3s_optimum_also_from_a_start_through_the_obstacles(warm_up: str) -> None:
    # The unconstrained optimum drives straight through the obstacles: an infeasible start.
    through = ddpkit.Solver(p3_problem()).solve().us
    assert violation(ddpkit.SafeCddpSolver(p3_problem(), []).solve(us0=through).xs) > 0.1
    for us0 in (None, through):
        solver = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), warm_up=warm_up)
        sol = solver.solve(us0=us0)
        assert sol.converged, (warm_up, sol.table())
        assert violation(sol.xs) <= 1e-6
        assert sol.cost <= P3_COST * 1.05
        if us0 is None:
            assert sol.cost <= P3_COST * (1 + 1e-6)
        # Only the portfolio solves twice; the other start's iterations are counted apart.
        assert (sol.discarded_iterations > 0) == (warm_up == "portfolio" and us0 is None)


def test_the_portfolio_polish_is_selectable_never_worse_and_pickles() -> None:
    import pickle

    assert ddpkit.default_settings("SafeCddpSolver")["portfolio_polish"] is True
    two = {"portfolio_polish": False, "portfolio_third_mu": None}
    plain = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), **two).solve()
    # portfolio_apart=0: the polish runs even though P3's two starts agree.
    always = {"portfolio_polish": True, "portfolio_third_mu": None, "portfolio_apart": 0.0}
    solver = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), **always)
    polished = solver.solve()
    # P3's kept solution is the augmented Lagrangian's: the polish runs and cannot end worse.
    assert polished.converged and polished.max_violation <= 1e-6
    assert polished.cost <= plain.cost
    assert polished.iterations + polished.discarded_iterations > plain.iterations + plain.discarded_iterations
    again = pickle.loads(pickle.dumps(solver))
    assert again == solver and again != ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles())
    np.testing.assert_array_equal(again.solve().us, polished.us)
    batch = ddpkit.solve_batch_safe([p3_problem()], p3_obstacles(), threads=1, **always)
    np.testing.assert_array_equal(batch[0].us, polished.us)


def test_the_solution_lists_the_portfolio_starts_and_pickles_them() -> None:
    import pickle

    # portfolio_apart=0: on P3 the polish runs from the kept solution too.
    always = {"portfolio_polish": True, "portfolio_third_mu": None, "portfolio_apart": 0.0}
    sol = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), **always).solve()
    starts = sol.starts
    assert [s["warm_up"] for s in starts[:2]] == ["augmented_lagrangian", "barrier"]
    assert starts[-1]["warm_up"] == "polish" and all(s["barrier_mu_init"] is None for s in starts)
    assert {s["outcome"] for s in starts} <= {"kept", "polished", "discarded", "same_side", "stalled", "abandoned"}
    kept = [s for s in starts if s["outcome"] == "kept"]
    assert len(kept) == 1 and kept[0]["cost"] == sol.cost and kept[0]["status"] == "converged"
    # The kept start (with the one the polish went on from) makes up `iterations`, the others
    # `discarded_iterations`.
    on = sum(s["iterations"] for s in starts if s["outcome"] in ("kept", "polished"))
    assert on == sol.iterations
    assert sum(s["iterations"] for s in starts) == sol.iterations + sol.discarded_iterations
    assert sol.table().count("\nstart ") == len(starts)
    # The third start names its barrier weight.
    third = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), portfolio_apart=0.0).solve().starts
    assert third[2]["warm_up"] == "barrier" and third[2]["barrier_mu_init"] == pytest.approx(3e-3)
    # It pickles with the solution; a single warm-up and a warm start list none.
    again = pickle.loads(pickle.dumps(sol))
    assert again == sol and again.starts == starts
    solver = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), warm_up="barrier")
    assert solver.solve().starts == []
    solver = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles())
    first = solver.solve()
    assert len(first.starts) >= 2 and solver.solve(us0=first.us, warm_start=True).starts == []


def test_the_extra_starts_run_only_where_the_first_two_end_apart() -> None:
    import pickle

    d = ddpkit.default_settings("SafeCddpSolver")
    assert (d["portfolio_third_mu"], d["portfolio_apart"]) == (0.003, 1e-3)
    # P3's two starts end within 1e-10 of each other: the default is the two-start portfolio.
    two = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), portfolio_polish=False, portfolio_third_mu=None).solve()
    default = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles()).solve()
    np.testing.assert_array_equal(default.us, two.us)
    assert (default.iterations, default.discarded_iterations) == (two.iterations, two.discarded_iterations)
    # With the gate open (0) the third start and the polish run; the kept solution is no worse.
    solver = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), portfolio_apart=0.0)
    always = solver.solve()
    assert always.iterations + always.discarded_iterations > two.iterations + two.discarded_iterations
    assert always.max_violation <= 1e-6 and always.cost <= two.cost
    again = pickle.loads(pickle.dumps(solver))
    assert again == solver and again != ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles())
    np.testing.assert_array_equal(again.solve().us, always.us)
    for field, bad in (("portfolio_apart", -1e-3), ("portfolio_apart", float("nan")), ("portfolio_third_mu", 0.0)):
        with pytest.raises(ValueError, match=field):
            ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), **{field: bad})


def test_two_portfolio_threads_give_the_one_thread_solution_and_pickle() -> None:
    import pickle

    assert ddpkit.default_settings("SafeCddpSolver")["portfolio_threads"] == 1
    for apart in (1e-3, 0.0):  # the default, and with the third start and the polish run
        one = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), portfolio_apart=apart).solve()
        solver = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), portfolio_apart=apart, portfolio_threads=2)
        for _ in range(2):  # the second solve reuses the sibling workspace
            two = solver.solve()
            np.testing.assert_array_equal(two.us, one.us)
            assert (two.cost, two.iterations, two.discarded_iterations) == (
                one.cost,
                one.iterations,
                one.discarded_iterations,
            )
    again = pickle.loads(pickle.dumps(solver))
    assert again == solver and again != ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), portfolio_apart=0.0)
    batch = ddpkit.solve_batch_safe([p3_problem()] * 2, p3_obstacles(), threads=2, portfolio_threads=2)
    np.testing.assert_array_equal(batch[1].us, ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles()).solve().us)
    for bad in (0, 3):
        with pytest.raises(ValueError, match="portfolio_threads"):
            ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), portfolio_threads=bad)


def test_a_start_trapped_in_an_obstacle_ends_infeasible_with_finite_numbers() -> None:
    problem = p3_problem()
    problem.set_x0([1.0, 1.1, 0.0, 0.0])  # the centre of the first obstacle
    trap = [ddpkit.Circle((1.0, 1.1), 10.0)]  # no bounded control leaves it within the horizon
    sol = ddpkit.SafeCddpSolver(problem, trap).solve()
    assert sol.status == "infeasible"
    assert sol.iterations < 200
    assert np.all(np.isfinite(sol.xs)) and np.all(np.isfinite(sol.us)) and np.isfinite(sol.cost)
    # The least violating trajectory heads out: the violation at the end is below the start's.
    g = 100.0 - (sol.xs[:, 0] - 1.0) ** 2 - (sol.xs[:, 1] - 1.1) ** 2
    assert g[-1] < g[1] - 1.0


def test_clarabel_qps_agree() -> None:
    fast = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), qp_method="fast").solve()
    exact = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), qp_method="clarabel").solve()
    assert exact.converged
    assert exact.cost == pytest.approx(fast.cost, rel=1e-6)


def test_tightening_keeps_a_margin_that_grows_with_beta() -> None:
    sigma_w = np.diag([1e-5, 1e-5, 4e-5, 4e-5])
    costs, clearances = [], []
    for beta in (0.5, 0.9, 0.99):
        t = ddpkit.Tightening(beta, sigma_w)
        sol = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles(), tightening=t).solve()
        assert sol.converged, sol.table()
        assert sol.max_violation_tightened <= 1e-6
        assert sol.tightenings >= 1
        assert sol.covariances.shape == (101, 4, 4)
        assert sol.propagation_gains.shape == (100, 2, 4)
        assert sol.margins.shape[0] == 100
        if beta == 0.5:
            assert np.all(sol.margins == 0.0)  # phi^-1(0.5) = 0: plain CDDP
        else:
            assert sol.margins[:, :3].max() > 0.0
        costs.append(sol.cost)
        clearances.append(clearance(sol.xs))
    # A higher beta keeps farther from the obstacles and pays for it.
    assert clearances[0] < clearances[1] < clearances[2]
    assert costs[0] < costs[1] < costs[2]
    # The covariance is symmetric PSD and grows from zero.
    cov = ddpkit.SafeCddpSolver(p3_problem(), [], tightening=ddpkit.Tightening(0.9, sigma_w)).solve().covariances
    assert np.allclose(cov[0], 0.0)
    assert np.allclose(cov, np.transpose(cov, (0, 2, 1)))
    assert np.all(np.linalg.eigvalsh(cov[1:]) > -1e-15)


def test_open_loop_and_fixed_gains_are_more_conservative_in_covariance() -> None:
    sigma_w = np.diag([1e-5, 1e-5, 4e-5, 4e-5])
    sigma_pos = {}
    for gains in ("closed_loop", "open_loop"):
        t = ddpkit.Tightening(0.95, sigma_w, gains=gains)
        sol = ddpkit.SafeCddpSolver(p3_problem(), [], tightening=t).solve()
        sigma_pos[gains] = sol.covariances[-1, 0, 0]
        if gains == "open_loop":
            assert np.all(sol.propagation_gains == 0.0)
    assert sigma_pos["open_loop"] > sigma_pos["closed_loop"]
    k_fixed = np.array([[-1.0, 0.0, -1.5, 0.0], [0.0, -1.0, 0.0, -1.5]])
    sol = ddpkit.SafeCddpSolver(p3_problem(), [], tightening=ddpkit.Tightening(0.95, sigma_w, gains=k_fixed)).solve()
    assert np.allclose(sol.propagation_gains, k_fixed)


def test_every_constraint_kind_builds_and_solves() -> None:
    constraints = [
        ddpkit.Circle((1.5, 1.4), 0.3, form="distance"),
        ddpkit.ConvexPolygon([[0.6, 2.0], [1.0, 2.0], [1.0, 2.4], [0.6, 2.4]], margin=0.05),
        ddpkit.Cylinder((2.4, 0.8), 0.2, height=5.0, indices=(0, 1, 2)),
        ddpkit.StateBox([-1.0, -1.0, -2.0, -2.0], [4.0, 4.0, 2.0, 2.0]),
        ddpkit.ControlBox([-0.7, -0.7], [0.7, 0.7]),
    ]
    sol = ddpkit.SafeCddpSolver(p3_problem(), constraints, max_iterations=400).solve()
    assert sol.status in ("converged", "max_iterations"), sol.table()
    assert sol.max_violation <= 1e-6
    assert np.all(np.abs(sol.us) <= 0.7 + 1e-6)


def test_receding_horizon_api() -> None:
    solver = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles())
    first = solver.solve()
    solver.shift()
    solver.set_horizon(99)
    assert solver.horizon == 99
    problem = p3_problem()
    problem.set_x0(first.xs[1])
    shorter = ddpkit.SafeCddpSolver(problem, p3_obstacles())
    shorter.set_horizon(99)
    sol = shorter.solve()
    assert sol.xs.shape == (100, 4)
    solver.reset()
    solver.set_horizon(100)
    assert solver.solve().cost == pytest.approx(first.cost, rel=1e-9)


def test_a_reused_solver_given_us0_starts_cold_unless_told_to_warm_start() -> None:
    us0 = np.full((100, 2), 0.1)
    fresh = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles()).solve(us0=us0)
    solver = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles())
    first = solver.solve()
    # The last solve's multipliers and margins do not leak into a solve from a given guess.
    again = solver.solve(us0=us0)
    assert (again.iterations, again.discarded_iterations) == (fresh.iterations, fresh.discarded_iterations)
    np.testing.assert_array_equal(again.us, fresh.us)
    # With warm_start they do: from the last optimum with its multipliers nothing is left to do.
    solver.solve()
    warm = solver.solve(us0=first.us, warm_start=True)
    assert warm.converged and warm.discarded_iterations == 0
    assert warm.iterations < first.iterations
    assert warm.cost == pytest.approx(first.cost, rel=1e-9)


def test_mpc_episode_is_deterministic_and_safe_cddp_avoids_collisions() -> None:
    sigma_w = np.diag([9e-6, 9e-6, 3.6e-5, 3.6e-5])
    goal = [3.0, 3.0, 0.0, 0.0]
    mpc = ddpkit.Mpc(p3_problem(), p3_obstacles(), sigma_w, goal, tightening=ddpkit.Tightening(0.99, sigma_w))
    a = mpc.run_episode(4)
    b = mpc.run_episode(4)
    assert a.steps == b.steps and np.array_equal(a.xs, b.xs)
    assert a.xs.shape == (a.steps + 1, 4) and a.us.shape == (a.steps, 2)
    assert a.success
    assert a.collisions == 0
    c = mpc.run_episode(5)
    assert not np.array_equal(a.xs, c.xs)


def test_solves_release_the_gil() -> None:
    # Two solvers in two threads finish with the same results as in sequence.
    results: list[float] = [0.0, 0.0]

    def work(i: int) -> None:
        results[i] = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles()).solve().cost

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results[0] == results[1] == pytest.approx(P3_COST, rel=1e-6)


@pytest.mark.parametrize(
    "make, error, field",
    [
        (lambda: ddpkit.Circle((np.nan, 0.0), 1.0), ddpkit.NotFiniteError, "center"),
        (lambda: ddpkit.Circle((0.0, 0.0), -1.0), ddpkit.InvalidInputError, "radius"),
        (lambda: ddpkit.Circle((0.0, 0.0, 1.0), 1.0), ddpkit.ShapeError, "center"),
        (lambda: ddpkit.Circle((0.0, 0.0), 1.0, form="round"), ddpkit.InvalidInputError, "form"),
        (lambda: ddpkit.Circle((0.0, 0.0), 1.0, indices=(1, 1)), ddpkit.InvalidInputError, "indices"),
        (lambda: ddpkit.ConvexPolygon([[0.0, 0.0], [1.0, 1.0]]), ddpkit.InvalidInputError, "vertices"),
        (lambda: ddpkit.StateBox([1.0, 0.0], [0.0, 1.0]), ddpkit.InvalidInputError, "lower[0]"),
        (lambda: ddpkit.Tightening(1.0, np.eye(4)), ddpkit.InvalidInputError, "beta"),
        (lambda: ddpkit.Tightening(0.9, -np.eye(4)), ddpkit.InvalidInputError, "sigma_w"),
        (lambda: ddpkit.Tightening(0.9, np.ones((4, 3))), ddpkit.ShapeError, "sigma_w"),
        (lambda: ddpkit.Tightening(0.9, np.eye(4), gains="sometimes"), ddpkit.InvalidInputError, "gains"),
        (lambda: ddpkit.Tightening(0.9, np.eye(4), update_every=0), ddpkit.InvalidInputError, "update_every"),
        (lambda: ddpkit.SafeCddpSolver(p3_problem(), ["circle"]), ddpkit.InvalidInputError, "constraints[0]"),
        (
            lambda: ddpkit.SafeCddpSolver(p3_problem(), [ddpkit.Circle((0.0, 0.0), 1.0, indices=(0, 7))]),
            ddpkit.InvalidInputError,
            "constraints[0].indices[1]",
        ),
        (
            lambda: ddpkit.SafeCddpSolver(p3_problem(), [ddpkit.StateBox([0.0] * 3, [1.0] * 3)]),
            ddpkit.ShapeError,
            "constraints[0].lower",
        ),
        (
            lambda: ddpkit.SafeCddpSolver(p3_problem(), [], tightening=ddpkit.Tightening(0.9, np.eye(3))),
            ddpkit.ShapeError,
            "tightening.sigma_w",
        ),
        (lambda: ddpkit.SafeCddpSolver(p3_problem(), [], qp_method="osqp"), ddpkit.InvalidInputError, "qp_method"),
        (lambda: ddpkit.SafeCddpSolver(p3_problem(), [], warm_up="penalty"), ddpkit.InvalidInputError, "warm_up"),
        (lambda: ddpkit.SafeCddpSolver(p3_problem(), [], max_iterations=0), ddpkit.InvalidInputError, "max_iterations"),
        (lambda: ddpkit.Mpc(p3_problem(), [], np.eye(4), goal=[3.0, 3.0]), ddpkit.ShapeError, "goal"),
        (lambda: ddpkit.Mpc(p3_problem(), [], np.eye(4), goal=[3.0] * 4, iterations=0), ddpkit.InvalidInputError, "iterations"),
    ],
)
def test_bad_input_names_the_field(make, error, field: str) -> None:
    with pytest.raises(error) as info:
        make()
    assert field in str(info.value) or field in str(getattr(info.value, "field", "")), str(info.value)


def test_bad_initial_guess_and_horizon() -> None:
    solver = ddpkit.SafeCddpSolver(p3_problem(), p3_obstacles())
    with pytest.raises(ddpkit.ShapeError):
        solver.solve(us0=np.zeros((3, 2)))
    with pytest.raises(ddpkit.NotFiniteError):
        solver.solve(us0=np.full((100, 2), np.nan))
    with pytest.raises(ddpkit.InvalidInputError):
        solver.set_horizon(0)
    with pytest.raises(ddpkit.InvalidInputError):
        solver.set_horizon(101)


def test_the_barrier_funnel_keeps_the_way_around_a_wall_of_obstacles() -> None:
    import pickle

    # Problem 17 of the point family, seed 2 (bench/results/family_s2_210.json): overlapping
    # obstacles make a wall between the start and the goal; IPOPT's optimum goes round it.
    problem = ddpkit.Problem(
        x0=np.zeros(4),
        dynamics=ddpkit.DoubleIntegrator2D(dt=0.0873),
        running_cost=ddpkit.QuadraticCost(Q=np.zeros(4), R=[0.1, 0.1]),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=[100.0, 100.0, 10.0, 10.0], x_ref=[0.8095, -2.3979, 0.0, 0.0]),
        horizon=107,
    )
    wall = [(0.4543, -2.082, 0.2079), (0.8051, -1.4666, 0.2347), (0.3289, -1.4844, 0.3807), (0.17, -1.3864, 0.381)]
    obstacles = [ddpkit.Circle((ox, oy), r) for ox, oy, r in wall]
    ipopt = 0.09276029665544235
    assert ddpkit.default_settings("SafeCddpSolver")["barrier_funnel"] == 0.03
    # The hard barrier of earlier versions (outside every obstacle from the first step), with
    # their patient inner augmented-Lagrangian solves: without the funnel both portfolio starts
    # stop at the wall.
    hard = {
        "barrier_mu_init": 3e-3,
        "barrier_relaxation": 1e-6,
        "portfolio_third_mu": 0.03,
        "al_inner_progress": 0.0,
        "portfolio_flip": None,
    }
    solver = ddpkit.SafeCddpSolver(problem, obstacles, barrier_funnel=None, **hard)
    stalled = solver.solve()
    assert stalled.max_violation <= 1e-6 and stalled.cost > 10 * ipopt
    funnel = ddpkit.SafeCddpSolver(problem, obstacles, **hard).solve()
    assert funnel.max_violation <= 1e-6 and funnel.cost <= ipopt * (1 + 1e-6)
    # The default soft barrier goes round the wall with or without the funnel.
    for kw in ({}, {"barrier_funnel": None}):
        default = ddpkit.SafeCddpSolver(problem, obstacles, **kw).solve()
        assert default.max_violation <= 1e-6 and default.cost <= ipopt * (1 + 1e-6)
    again = pickle.loads(pickle.dumps(solver))
    assert again == solver and again != ddpkit.SafeCddpSolver(problem, obstacles, **hard)
    np.testing.assert_array_equal(again.solve().us, stalled.us)
    batch = ddpkit.solve_batch_safe([problem], obstacles, threads=1, barrier_funnel=None, **hard)
    np.testing.assert_array_equal(batch[0].us, stalled.us)
    for field, bad in (
        ("barrier_mu_init", 0.0),
        ("barrier_mu_init", float("nan")),
        ("barrier_relaxation", -1.0),
        ("al_inner_progress", -1.0),
        ("al_inner_progress", float("inf")),
    ):
        with pytest.raises(ValueError, match=field):
            ddpkit.SafeCddpSolver(problem, obstacles, **{field: bad})
    for bad in (0.0, -1e-2, float("nan")):
        with pytest.raises(ValueError, match="barrier_funnel"):
            ddpkit.SafeCddpSolver(problem, obstacles, barrier_funnel=bad)


def test_inner_solves_end_once_a_step_moves_the_merit_less_than_a_multiplier_update() -> None:
    import pickle

    # P3 (three discs): the same optimum with and without the rule, fewer
    # iterations with it (the augmented-Lagrangian start's inner solves stop refining minimisers
    # the next multiplier update moves anyway).
    problem, obstacles = p3_problem(), p3_obstacles()
    assert ddpkit.default_settings("SafeCddpSolver")["al_inner_progress"] == 1.0
    patient = ddpkit.SafeCddpSolver(problem, obstacles, al_inner_progress=0.0)
    default = ddpkit.SafeCddpSolver(problem, obstacles)
    a, b = patient.solve(), default.solve()
    for s in (a, b):
        assert s.status == "converged" and s.max_violation <= 1e-6
        assert s.cost <= P3_COST * (1 + 1e-6)
    assert b.iterations + b.discarded_iterations < a.iterations + a.discarded_iterations
    again = pickle.loads(pickle.dumps(patient))
    assert again == patient and again != default
