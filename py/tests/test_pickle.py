"""Pickling: every model, cost, constraint, problem, solver, settings object and solution pickles
and unpickles to an equal object, solves to the identical result and travels to other processes."""

from __future__ import annotations

import multiprocessing
import pickle

import numpy as np
import pytest

import ddpkit
from ddpkit import _ddpkit


def unicycle_step(x, u):
    """A plain callable (module level, so it pickles by reference)."""
    return np.array([x[0] + 0.1 * u[0] * np.cos(x[2]), x[1] + 0.1 * u[0] * np.sin(x[2]), x[2] + 0.1 * u[1]])


def control_effort(x, u):
    return float(u @ u)


def keep_out(x):
    return np.array([0.25 - (x[0] - 0.5) ** 2 - (x[1] + 0.5) ** 2])


def traced_running(x, u):
    return 0.5 * (x[0] ** 2 + x[1] ** 2) + 0.1 * (u[0] ** 2 + u[1] ** 2)


def dynamics_examples() -> list[ddpkit.Dynamics]:
    return [
        ddpkit.Unicycle(dt=0.07),
        ddpkit.Car(dt=0.03),
        ddpkit.DoubleIntegrator2D(dt=0.02),
        ddpkit.DifferentialDrive(dt=0.2, track_width=0.3),
        ddpkit.Quadrotor(dt=0.04, mass=0.5, inertia=(0.01, 0.02, 0.03), gravity=9.8),
        ddpkit.ArmBase(dt=0.05, base_mass=12.0, link_lengths=(0.5, 0.4)),
        ddpkit.LinearDynamics(A=np.array([[1.0, 0.1], [0.0, 1.0]]), B=np.array([[0.0], [0.1]]), c=[0.0, 0.01]),
        ddpkit.Dynamics.from_function(unicycle_step, nx=3, nu=2),
        ddpkit.Dynamics.from_callable(unicycle_step, nx=3, nu=2),
    ]


def cost_examples() -> list[ddpkit.Cost]:
    quad = ddpkit.QuadraticCost(Q=[1.0, 2.0, 3.0], R=np.eye(2), x_ref=[1.0, 0.0, 0.0], u_ref=[0.5, 0.0])
    return [
        quad,
        ddpkit.QuadraticCost(Q=np.eye(3), R=[1.0, 1.0]),
        ddpkit.QuadraticTerminal(Qf=np.diag([10.0, 10.0, 1.0]), x_ref=[1.0, 2.0, 0.0]),
        ddpkit.ControlSquared(0.3),
        ddpkit.SmoothDistance(target=(1.0, 2.0), indices=(0, 1), eps=0.01, weight=2.0),
        ddpkit.ObstacleHinge(points=[[0.5, 0.5], [1.0, -1.0]], margin=0.4, weight=3.0),
        ddpkit.ObstacleHinge(points=np.zeros((0, 2)), margin=0.4),
        ddpkit.CirclePenalty(circles=[[0.5, 0.5, 0.2]], weight=5.0),
        ddpkit.CostSum([(1.0, quad), (2.0, ddpkit.ControlSquared(0.1))]),
        ddpkit.TerminalSum([(1.0, ddpkit.QuadraticTerminal(Qf=np.eye(3))), (0.5, ddpkit.SmoothDistance((0.0, 1.0)))]),
        ddpkit.Cost.from_function(traced_running, nx=3, nu=2),
        ddpkit.Cost.from_callable(control_effort, nx=3, nu=2),
    ]


def constraint_examples() -> list[ddpkit.Constraint]:
    return [
        ddpkit.Circle((0.5, -0.5), 0.3),
        ddpkit.Circle((0.5, -0.5), 0.3, indices=(1, 0), form="distance"),
        ddpkit.ConvexPolygon([[0.0, 0.0], [1.0, 0.0], [0.5, 1.0]], margin=0.1),
        ddpkit.Cylinder((0.0, 0.0), 0.5, 1.0, band=0.05),
        ddpkit.StateBox(lower=[-1.0, -np.inf, -3.0], upper=[1.0, np.inf, 3.0]),
        ddpkit.ControlBox(lower=[-1.0, -2.0], upper=[1.0, 2.0]),
        ddpkit.Constraint.from_function(keep_out, nx=3),
        ddpkit.Constraint.from_callable(keep_out, nx=3),
    ]


def tightening_examples() -> list[ddpkit.Tightening]:
    return [
        ddpkit.Tightening(beta=0.9, sigma_w=0.01 * np.eye(3)),
        ddpkit.Tightening(beta=0.95, sigma_w=0.01 * np.eye(3), gains="open_loop", update_every=3, sigma_0=0.001 * np.eye(3)),
        ddpkit.Tightening(beta=0.8, sigma_w=0.01 * np.eye(3), gains=np.ones((2, 3))),
    ]


def p1(x0=(-1.0, -1.0, 1.0), **kw) -> ddpkit.Problem:
    return ddpkit.Problem(
        x0=np.array(x0),
        dynamics=ddpkit.Unicycle(dt=0.1),
        running_cost=ddpkit.QuadraticCost(Q=100.0 * np.eye(3), R=np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=100.0 * np.eye(3)),
        horizon=60,
        **kw,
    )


def traced_problem() -> ddpkit.Problem:
    return ddpkit.Problem(
        x0=np.array([-1.0, -1.0, 1.0]),
        dynamics=ddpkit.Dynamics.from_function(unicycle_step, nx=3, nu=2),
        running_cost=ddpkit.Cost.from_function(traced_running, nx=3, nu=2),
        terminal_cost=ddpkit.Cost.from_function(lambda x: 50.0 * (x[0] ** 2 + x[1] ** 2 + x[2] ** 2), nx=3),
        horizon=40,
        u_min=[-2.0, -np.inf],
    )


def roundtrip(obj):
    again = pickle.loads(pickle.dumps(obj))
    assert type(again) is type(obj)
    assert again == obj, f"{obj!r} does not unpickle to an equal object"
    return again


@pytest.mark.parametrize("make", [dynamics_examples, cost_examples, constraint_examples, tightening_examples])
def test_models_costs_constraints_and_settings_pickle_to_equal_objects(make) -> None:
    objects = make()
    for obj in objects:
        roundtrip(obj)
    # Equality is not identity-of-type only: different parameters are different objects.
    for i, a in enumerate(objects):
        for j, b in enumerate(make()):
            assert (a == b) == (i == j), (a, b)


def test_every_public_model_cost_and_constraint_class_is_covered() -> None:
    """A new class must join the examples above (and so be pickled and compared)."""
    covered = {type(o) for o in dynamics_examples() + cost_examples() + constraint_examples()}
    bases = (ddpkit.Dynamics, ddpkit.Cost, ddpkit.Constraint)
    public = {
        c
        for c in vars(_ddpkit).values()
        if isinstance(c, type) and issubclass(c, bases) and c not in bases and c.__name__ != "TapeCost"
    }
    # The tape cost is covered (a traced cost is one); every other class by its own example.
    assert public - covered == set()
    assert ddpkit.TapeCost in covered


def test_unpickled_models_evaluate_identically() -> None:
    x, u = np.array([0.3, -0.2, 0.9]), np.array([0.7, -0.4])
    for d in dynamics_examples():
        if d.nx != 3 or d.nu != 2:
            continue
        again = roundtrip(d)
        np.testing.assert_array_equal(again.step(x, u), d.step(x, u))
        for a, b in zip(again.jacobians(x, u), d.jacobians(x, u)):
            np.testing.assert_array_equal(a, b)
    for c in cost_examples():
        if c.state_only:
            assert roundtrip(c).value(x) == c.value(x)
        else:
            assert roundtrip(c).value(x, u) == c.value(x, u)


def test_problem_solver_and_solution_pickle_and_solve_bit_for_bit() -> None:
    for problem, make_solver in [
        (p1(u_max=[1.5, 1.5]), lambda p: ddpkit.Solver(p, method="ddp", max_iterations=50, mu_init=1e-6)),
        (traced_problem(), lambda p: ddpkit.Solver(p, max_iterations=80)),
    ]:
        again = roundtrip(problem)
        assert (again.nx, again.nu, again.horizon) == (problem.nx, problem.nu, problem.horizon)
        for a, b in zip(again.bounds, problem.bounds):
            np.testing.assert_array_equal(a, b)
        solver = make_solver(problem)
        solver_again = roundtrip(solver)
        assert solver_again.settings == solver.settings
        s1 = solver.solve()
        s2 = make_solver(again).solve()
        s3 = solver_again.solve()
        for s in (s2, s3):
            np.testing.assert_array_equal(s.xs, s1.xs)
            np.testing.assert_array_equal(s.us, s1.us)
            np.testing.assert_array_equal(s.K, s1.K)
            assert (s.cost, s.iterations, s.status) == (s1.cost, s1.iterations, s1.status)
        sol = roundtrip(s1)
        assert sol.table() == s1.table() and sol.converged == s1.converged
        np.testing.assert_array_equal(sol.cost_history, s1.cost_history)
        assert s1 != s2 or s1.solve_time == s2.solve_time  # timings are fields too
    # The current x0 travels (after set_x0) and makes the problem different.
    a, b = p1(), p1()
    b.set_x0([0.0, -1.0, 1.0])
    assert a != b
    np.testing.assert_array_equal(roundtrip(b).x0, [0.0, -1.0, 1.0])


def test_safe_solver_and_safe_solution_pickle() -> None:
    problem = p1()
    constraints = [ddpkit.Circle((-0.5, -0.6), 0.2), ddpkit.Constraint.from_callable(keep_out, nx=3)]
    tight = ddpkit.Tightening(beta=0.9, sigma_w=1e-4 * np.eye(3))
    solver = ddpkit.SafeCddpSolver(problem, constraints, tightening=tight, max_iterations=60)
    again = roundtrip(solver)
    s1 = solver.solve()
    s2 = again.solve()
    np.testing.assert_array_equal(s2.xs, s1.xs)
    np.testing.assert_array_equal(s2.margins, s1.margins)
    assert s1.max_violation <= 1e-6, s1.status
    sol = roundtrip(s1)
    assert sol.table() == s1.table()
    np.testing.assert_array_equal(sol.covariances, s1.covariances)
    other = ddpkit.SafeCddpSolver(problem, constraints[:1], tightening=tight, max_iterations=60)
    assert other != solver


def test_result_arrays_are_made_at_the_first_read_and_kept() -> None:
    # A solution's arrays become numpy arrays when first read; every later read, and pickling,
    # gives that same array (an edit to it stays).
    problem = p1()
    n, nx, nu = problem.horizon, problem.nx, problem.nu
    plain = ddpkit.Solver(problem, max_iterations=30).solve()
    safe = ddpkit.SafeCddpSolver(problem, [ddpkit.Circle((-0.5, -0.6), 0.2)], max_iterations=60).solve()
    shapes = {"xs": (n + 1, nx), "us": (n, nu), "K": (n, nu, nx), "k": (n, nu)}
    safe_shapes = {**shapes, "propagation_gains": (n, nu, nx), "covariances": (n + 1, nx, nx), "margins": (n, 5)}
    for sol, expected in ((plain, {**shapes, "cost_history": (plain.iterations + 1,)}), (safe, safe_shapes)):
        for name, shape in expected.items():
            a = getattr(sol, name)
            assert isinstance(a, np.ndarray) and a.shape == shape and a.dtype == np.float64, name
            assert getattr(sol, name) is a, name
        sol.us[0, 0] += 1.0
        np.testing.assert_array_equal(roundtrip(sol).us, sol.us)
    assert isinstance(safe.starts, list) and safe.starts is safe.starts
    assert safe.max_violation <= 1e-6 and safe.converged


def test_mpc_and_episode_pickle_and_run_the_same_episodes() -> None:
    sigma = 1e-5 * np.eye(3)
    constraints = [ddpkit.Circle((-0.5, -0.6), 0.2)]
    kw = dict(goal=[0.0, 0.0, 0.0], goal_radius=0.2, iterations=3, initial_iterations=20, max_iterations=100)
    mpc = ddpkit.Mpc(p1(), constraints, sigma, tightening=ddpkit.Tightening(0.9, sigma), **kw)
    again = roundtrip(mpc)
    e1, e2 = mpc.run_episode(5), again.run_episode(5)
    assert e1.steps >= 1 and e2.steps == e1.steps
    np.testing.assert_array_equal(e2.xs, e1.xs)
    np.testing.assert_array_equal(e2.us, e1.us)
    assert e2 == e1
    ep = roundtrip(e1)
    assert (ep.success, ep.steps, ep.collisions, ep.infeasible_steps) == (e1.success, e1.steps, e1.collisions, e1.infeasible_steps)
    # Every argument takes part in equality.
    assert ddpkit.Mpc(p1(), constraints, sigma, **kw) != mpc  # no tightening
    assert ddpkit.Mpc(p1(), constraints, 2 * sigma, tightening=ddpkit.Tightening(0.9, sigma), **kw) != mpc
    assert ddpkit.Mpc(p1(), constraints, sigma, tightening=ddpkit.Tightening(0.9, sigma), **{**kw, "iterations": 4}) != mpc
    assert mpc.run_episode(6) != e1
    with pytest.raises(ddpkit.InvalidInputError, match=r"state\['us'\] is invalid: missing"):
        _ddpkit._unpickle_result("Episode", {k: v for k, v in e1.__reduce__()[1][1].items() if k != "us"})


def solve_in_worker(payload: bytes) -> bytes:
    problem, settings = pickle.loads(payload)
    return pickle.dumps(ddpkit.Solver(problem, **settings).solve())


def test_work_goes_to_other_processes() -> None:
    """Problems go to a spawned pool (a fresh interpreter) and solutions come back identical."""
    jobs = [(p1(x0=(x, -1.0, 1.0)), {"max_iterations": 60}) for x in (-1.0, -0.5)]
    jobs.append((traced_problem(), {"method": "ddp", "max_iterations": 60}))
    ctx = multiprocessing.get_context("spawn")
    with ctx.Pool(2) as pool:
        remote = [pickle.loads(r) for r in pool.map(solve_in_worker, [pickle.dumps(j) for j in jobs])]
    for (problem, settings), r in zip(jobs, remote):
        local = ddpkit.Solver(problem, **settings).solve()
        np.testing.assert_array_equal(r.xs, local.xs)
        np.testing.assert_array_equal(r.us, local.us)
        assert (r.cost, r.iterations, r.table()) == (local.cost, local.iterations, local.table())


def test_unpicklable_functions_and_bad_state_are_errors() -> None:
    lam = ddpkit.Dynamics.from_callable(lambda x, u: x, nx=3, nu=2)
    with pytest.raises((pickle.PicklingError, AttributeError, TypeError)):
        pickle.dumps(lam)
    with pytest.raises(ddpkit.InvalidInputError, match=r"state\['xs'\] is invalid: missing"):
        _ddpkit._unpickle_result("Solution", {})
    with pytest.raises(ddpkit.InvalidInputError, match="kind"):
        _ddpkit._unpickle_result("Nope", {})
