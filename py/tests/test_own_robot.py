"""Bring your own robot: models traced from Python functions, imported from CasADi, loaded from
files and given as plain callables, in every solver; derivatives against finite differences and
CasADi; errors for what cannot be traced; pickling; the GIL."""

from __future__ import annotations

import pickle
import threading
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import ddpkit

DT = 0.05
FIXTURE = Path(__file__).resolve().parents[2] / "crates" / "tape" / "tests" / "data" / "cartpole.json"


def cartpole_ode(x, u):
    """Cart-pole xdot (Tedrake's Underactuated Robotics, ch. 3): x = (p, theta, pdot, thetadot)."""
    mc, mp, length, g = 1.0, 0.1, 0.5, 9.81
    s, c = np.sin(x[1]), np.cos(x[1])
    d = mc + mp * s**2
    pdd = (u[0] + mp * s * (length * x[3] ** 2 + g * c)) / d
    tdd = (-u[0] * c - mp * length * x[3] ** 2 * c * s - (mc + mp) * g * s) / (length * d)
    return np.array([x[2], x[3], pdd, tdd])


def rk4(f, x, u, dt):
    k1 = f(x, u)
    k2 = f(x + 0.5 * dt * k1, u)
    k3 = f(x + 0.5 * dt * k2, u)
    k4 = f(x + dt * k3, u)
    return x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def cartpole_casadi() -> ca.Function:
    x, u = ca.SX.sym("x", 4), ca.SX.sym("u", 1)
    xn = rk4(lambda a, b: ca.vertcat(*cartpole_ode(a, b)), x, u, DT)
    return ca.Function("cartpole", [x, u], [xn])


def running(x, u):
    return 0.5 * (0.1 * x[0] ** 2 + 0.1 * x[2] ** 2 + 0.1 * x[3] ** 2) + 0.05 * u[0] ** 2


def terminal(x):
    return 50.0 * (x[0] ** 2 + (x[1] - np.pi) ** 2 + x[2] ** 2 + x[3] ** 2)


def cartpole_problem(dynamics: ddpkit.Dynamics, horizon: int = 80, **bounds) -> ddpkit.Problem:
    return ddpkit.Problem(
        x0=np.zeros(4),
        dynamics=dynamics,
        running_cost=ddpkit.Cost.from_function(running, nx=4, nu=1),
        terminal_cost=ddpkit.Cost.from_function(terminal, nx=4),
        horizon=horizon,
        **bounds,
    )


def traced_cartpole() -> ddpkit.Dynamics:
    return ddpkit.Dynamics.from_function(cartpole_ode, nx=4, nu=1, dt=DT, integrator="rk4")


def fd_jacobians(step, x, u, h=1e-6):
    fx = np.column_stack([(step(x + h * e, u) - step(x - h * e, u)) / (2 * h) for e in np.eye(len(x))])
    fu = np.column_stack([(step(x, u + h * e) - step(x, u - h * e)) / (2 * h) for e in np.eye(len(u))])
    return fx, fu


POINTS = [(np.array([0.1, 0.5, -0.3, 0.8]), np.array([1.5])), (np.array([-0.4, 2.9, 0.2, -1.1]), np.array([-3.0]))]


def test_traced_cartpole_equals_numpy_and_finite_differences() -> None:
    model = traced_cartpole()
    assert isinstance(model, ddpkit.TapeDynamics) and (model.nx, model.nu) == (4, 1)
    assert model.has_second_order
    for x, u in POINTS:
        expected = rk4(cartpole_ode, x, u, DT)
        np.testing.assert_allclose(model.step(x, u), expected, rtol=1e-13, atol=1e-14)
        fx, fu = model.jacobians(x, u)
        gx, gu = fd_jacobians(lambda a, b: rk4(cartpole_ode, a, b, DT), x, u)
        np.testing.assert_allclose(fx, gx, rtol=1e-7, atol=1e-8)
        np.testing.assert_allclose(fu, gu, rtol=1e-7, atol=1e-8)
        # Second derivatives: sum_i lam_i d2 f_i against differences of the exact Jacobians.
        lam = np.array([0.3, -1.2, 0.7, 2.0])
        hxx, hux, huu = model.second_order(x, u, lam)
        h = 1e-6
        for j in range(4):
            e = np.eye(4)[j]
            dp, _ = model.jacobians(x + h * e, u)
            dm, _ = model.jacobians(x - h * e, u)
            np.testing.assert_allclose(hxx[:, j], lam @ (dp - dm) / (2 * h), rtol=1e-6, atol=1e-7)
        fxp, _ = model.jacobians(x, u + h)
        fxm, _ = model.jacobians(x, u - h)
        np.testing.assert_allclose(hux[0], lam @ (fxp - fxm) / (2 * h), rtol=1e-6, atol=1e-7)
        _, fup = model.jacobians(x, u + h)
        _, fum = model.jacobians(x, u - h)
        np.testing.assert_allclose(huu[0, 0], lam @ (fup - fum)[:, 0] / (2 * h), rtol=1e-6, atol=1e-7)


def casadi_eval(f: ca.Function, *args) -> np.ndarray:
    return np.array(f(*args)).astype(float).reshape(-1) if f.n_in() else np.array([])


def test_casadi_import_equals_casadi_values_jacobians_and_hessians() -> None:
    F = cartpole_casadi()
    model = ddpkit.Dynamics.from_casadi(F)
    x, u = ca.SX.sym("x", 4), ca.SX.sym("u", 1)
    lam = ca.SX.sym("lam", 4)
    jac = ca.Function("J", [x, u], [ca.jacobian(F(x, u), x), ca.jacobian(F(x, u), u)])
    z = ca.vertcat(x, u)
    hess = ca.Function("H", [x, u, lam], [ca.hessian(ca.dot(lam, F(x, u)), z)[0]])
    lam_v = np.array([0.3, -1.2, 0.7, 2.0])
    for xv, uv in POINTS:
        np.testing.assert_allclose(model.step(xv, uv), casadi_eval(F, xv, uv), rtol=1e-12, atol=1e-14)
        fx, fu = model.jacobians(xv, uv)
        cx, cu = (np.array(m) for m in jac(xv, uv))
        np.testing.assert_allclose(fx, cx, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(fu, cu, rtol=1e-12, atol=1e-13)
        hxx, hux, huu = model.second_order(xv, uv, lam_v)
        ch = np.array(hess(xv, uv, lam_v))
        np.testing.assert_allclose(hxx, ch[:4, :4], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(hux, ch[4:, :4], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(huu, ch[4:, 4:], rtol=1e-12, atol=1e-12)
    # The traced model and the imported one agree too.
    traced = traced_cartpole()
    for xv, uv in POINTS:
        np.testing.assert_allclose(traced.step(xv, uv), model.step(xv, uv), rtol=1e-13, atol=1e-14)


def test_casadi_costs_and_constraints_equal_casadi() -> None:
    x, u = ca.SX.sym("x", 4), ca.SX.sym("u", 1)
    z = ca.vertcat(x, u)
    expr = ca.exp(0.3 * x[0]) * ca.cos(x[1]) + ca.sqrt(1 + x[2] ** 2) * u[0] + ca.atan2(x[3], 1.5 + x[0] ** 2) + ca.fmax(x[0], 0.2) * u[0] ** 3
    l = ca.Function("l", [x, u], [expr])
    cost = ddpkit.Cost.from_casadi(l)
    assert isinstance(cost, ddpkit.TapeCost) and not cost.state_only
    H = ca.Function("H", [x, u], [ca.hessian(expr, z)[0], ca.gradient(expr, z)])
    lN = ca.Function("lN", [x], [ca.sumsqr(x) * ca.tanh(x[1])])
    term = ddpkit.Cost.from_casadi(lN)
    assert term.state_only and term.kind == "terminal_cost"
    HN = ca.Function("HN", [x], [ca.hessian(lN(x), x)[0]])
    for xv, uv in POINTS:
        v, lx, lu, lxx, luu, lux = cost.derivatives(xv, uv)
        assert v == pytest.approx(float(l(xv, uv)), rel=1e-12)
        hc, gc = (np.array(m) for m in H(xv, uv))
        np.testing.assert_allclose(np.concatenate([lx, lu]), gc.reshape(-1), rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(lxx, hc[:4, :4], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(luu, hc[4:, 4:], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(lux, hc[4:, :4], rtol=1e-12, atol=1e-12)
        assert term.value(xv) == pytest.approx(float(lN(xv)), rel=1e-12)
        _, tx, _, txx, _, _ = term.derivatives(xv)
        np.testing.assert_allclose(txx, np.array(HN(xv)), rtol=1e-12, atol=1e-12)
    # Constraints: one of (x, u), one of x alone (state-only), recognised from the structure.
    g = ca.Function("g", [x, u], [ca.vertcat(x[0] ** 2 + x[1] ** 2 - 1, u[0] - 2.0)])
    gs = ca.Function("gs", [x, u], [ca.vertcat(0.25 - (x[0] - 1) ** 2 - x[1] ** 2)])
    gx_only = ca.Function("gx", [x], [0.25 - (x[0] - 1) ** 2 - x[1] ** 2])
    mixed, state, alone = (ddpkit.Constraint.from_casadi(f) for f in (g, gs, gx_only))
    assert mixed.depends_on_control and not state.depends_on_control and not alone.depends_on_control
    J = ca.Function("J", [x, u], [ca.jacobian(g(x, u), x), ca.jacobian(g(x, u), u)])
    for xv, uv in POINTS:
        gv, gx, gu = mixed.jacobians(xv, uv)
        np.testing.assert_allclose(gv, casadi_eval(g, xv, uv), rtol=1e-12)
        cx, cu = (np.array(m) for m in J(xv, uv))
        np.testing.assert_allclose(gx, cx, rtol=1e-12, atol=1e-13)
        np.testing.assert_allclose(gu, cu, rtol=1e-12, atol=1e-13)


def test_casadi_errors_name_the_problem() -> None:
    x, u = ca.MX.sym("x", 4), ca.MX.sym("u", 1)
    mx = ca.Function("mxf", [x, u], [x * u])
    with pytest.raises(ddpkit.InvalidInputError, match=r"expand\(\)"):
        ddpkit.Dynamics.from_casadi(mx)
    xs, us = ca.SX.sym("x", 4), ca.SX.sym("u", 1)
    erf = ca.Function("erff", [xs, us], [ca.erf(xs) + us])
    with pytest.raises(ddpkit.InvalidInputError, match="OP_ERF"):
        ddpkit.Dynamics.from_casadi(erf)
    # The expanded MX function imports.
    ok = ddpkit.Dynamics.from_casadi(mx.expand())
    np.testing.assert_allclose(ok.step(np.arange(4.0), [2.0]), 2 * np.arange(4.0))
    with pytest.raises(ddpkit.InvalidInputError, match="casadi.Function"):
        ddpkit.Cost.from_casadi(lambda x: x)


def test_traced_cartpole_swings_up_like_the_casadi_model_and_ipopt_agrees() -> None:
    # Full DDP: the exact second derivatives of the tape (iLQR needs hundreds of iterations here).
    # Solved to a tight gradient: the optimum is flat (1e-11 in cost is 1e-3 in the controls), and
    # IPOPT's check below compares controls.
    tight = {"method": "ddp", "max_iterations": 300, "gradient_tolerance": 1e-12}
    traced = ddpkit.Solver(cartpole_problem(traced_cartpole()), **tight).solve()
    imported = ddpkit.Solver(cartpole_problem(ddpkit.Dynamics.from_casadi(cartpole_casadi())), **tight).solve()
    assert traced.converged, traced.status
    # Two different tapes of one function (numpy-traced, CasADi's instruction list) agree to
    # rounding, not bit for bit (their sums are formed in different orders), and a gradient
    # tolerance of 1e-12 sits at that rounding level, so the last iterations of the flat tail
    # (gradient falling ~0.85x per iteration) may fall a few apart; the optimum is the same.
    assert abs(traced.iterations - imported.iterations) <= 3
    assert traced.cost == pytest.approx(imported.cost, rel=1e-10)
    np.testing.assert_allclose(traced.us, imported.us, atol=1e-3)  # a few iterations apart
    assert abs(traced.xs[-1, 1] - np.pi) < 0.1  # swung up
    # iLQR (Gauss-Newton dynamics terms) heads to the same optimum.
    gn = ddpkit.Solver(cartpole_problem(traced_cartpole()), method="ilqr", max_iterations=2000, gradient_tolerance=1e-6).solve()
    assert gn.cost == pytest.approx(traced.cost, rel=1e-4)
    # IPOPT on the same discrete problem (multiple shooting), started at the DDP solution, stays
    # there: the DDP solution is a local optimum of the very same functions.
    F = cartpole_casadi()
    opti = ca.Opti()
    X, U = opti.variable(4, 81), opti.variable(1, 80)
    obj = 0
    for k in range(80):
        obj += running(X[:, k], U[:, k])
        opti.subject_to(X[:, k + 1] == F(X[:, k], U[:, k]))
    obj += terminal(X[:, 80])
    opti.minimize(obj)
    opti.subject_to(X[:, 0] == np.zeros(4))
    opti.set_initial(X, traced.xs.T)
    opti.set_initial(U, traced.us.T)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "tol": 1e-12, "sb": "yes"})
    sol = opti.solve()
    assert float(sol.value(obj)) == pytest.approx(traced.cost, rel=1e-6)
    np.testing.assert_allclose(np.atleast_2d(sol.value(U)).T, traced.us, atol=1e-4)


def test_multiple_shooting_swings_up_in_fewer_iterations_to_the_same_optimum() -> None:
    # Multiple shooting (states stepped with the controls, defects closed as it converges, a
    # filter line search) reaches single shooting's optimum in about 24 iterations against 60.
    problem = cartpole_problem(ddpkit.Dynamics.from_casadi(cartpole_casadi()))
    single = ddpkit.Solver(problem, method="ddp", max_iterations=300).solve()
    solver = ddpkit.Solver(problem, method="ddp", shooting="multiple", max_iterations=300)
    assert solver.settings["shooting"] == "multiple"
    assert pickle.loads(pickle.dumps(solver)).settings == solver.settings
    multiple = solver.solve()
    assert single.converged and multiple.converged, (single.status, multiple.status)
    assert single.defect == 0.0 and 0.0 <= multiple.defect <= 1e-9
    assert multiple.cost == pytest.approx(single.cost, rel=1e-8)
    assert multiple.iterations <= 30 and 2 * multiple.iterations < single.iterations
    # Every step of the solution is the model's up to the reported defect.
    F = cartpole_casadi()
    steps = np.array([np.asarray(F(multiple.xs[k], multiple.us[k])).ravel() for k in range(80)])
    assert np.max(np.abs(steps - multiple.xs[1:])) == pytest.approx(multiple.defect, rel=1e-6, abs=1e-15)
    # From a state guess (a straight line to the upright, zero force) it closes the defects and
    # converges too, here in fewer iterations to another swing-up (a local optimum of its own).
    line = np.linspace(np.zeros(4), [0.0, np.pi, 0.0, 0.0], 81)
    guessed = solver.solve(xs0=line)
    assert guessed.converged and guessed.defect <= 1e-9, guessed.status
    assert abs(guessed.xs[-1, 1] - np.pi) < 0.1
    assert guessed.initial_cost == pytest.approx(problem.cost(line, np.zeros((80, 1))))
    with pytest.raises(ddpkit.InvalidInputError, match="settings.shooting"):
        ddpkit.Solver(problem).solve(xs0=line)
    with pytest.raises(ddpkit.ShapeError, match="xs0"):
        solver.solve(xs0=line[:-1])
    # solve_batch takes the same keyword and gives the same solution.
    batch = ddpkit.solve_batch([problem], threads=1, method="ddp", shooting="multiple", max_iterations=300)[0]
    assert batch.iterations == multiple.iterations and batch.cost == multiple.cost
    np.testing.assert_array_equal(batch.us, multiple.us)
    # It pickles with its defect, and a bounded problem or an unknown name is refused by name.
    assert pickle.loads(pickle.dumps(multiple)) == multiple
    assert pickle.loads(pickle.dumps(multiple)).defect == multiple.defect
    with pytest.raises(ddpkit.InvalidInputError, match="settings.shooting"):
        ddpkit.Solver(cartpole_problem(traced_cartpole(), u_min=[-5.0], u_max=[5.0]), shooting="multiple")
    with pytest.raises(ddpkit.InvalidInputError, match="shooting"):
        ddpkit.Solver(problem, shooting="double")


def test_box_ddp_pendulum_with_torque_limits() -> None:
    def pendulum(x, u):
        return np.array([x[1], u[0] - 9.81 * np.sin(x[0]) - 0.1 * x[1]])

    problem = ddpkit.Problem(
        x0=np.zeros(2),
        dynamics=ddpkit.Dynamics.from_function(pendulum, nx=2, nu=1, dt=0.05, integrator="euler"),
        running_cost=ddpkit.Cost.from_function(lambda x, u: 0.01 * u[0] ** 2, nx=2, nu=1),
        terminal_cost=ddpkit.Cost.from_function(lambda x: 100 * ((x[0] - np.pi) ** 2 + x[1] ** 2), nx=2),
        horizon=100,
        u_min=-2.0,
        u_max=2.0,
    )
    sol = ddpkit.Solver(problem, max_iterations=500).solve()
    assert sol.converged, sol.status
    assert np.all(np.abs(sol.us) <= 2.0 + 1e-12)
    assert np.max(np.abs(sol.us)) == pytest.approx(2.0)  # the limit binds: a pump-up swing
    assert abs(sol.xs[-1, 0] - np.pi) < 0.1


def obstacle_problem(dynamics) -> ddpkit.Problem:
    return ddpkit.Problem(
        x0=np.zeros(4),
        dynamics=dynamics,
        running_cost=ddpkit.QuadraticCost(Q=np.zeros(4), R=[0.1, 0.1]),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=[100.0, 100.0, 10.0, 10.0], x_ref=[3.0, 3.0, 0.0, 0.0]),
        horizon=100,
        u_min=-0.8,
        u_max=0.8,
    )


OBSTACLES = [(1.0, 1.1, 0.4), (2.0, 1.9, 0.4), (2.6, 2.9, 0.25)]


def traced_obstacles() -> ddpkit.Constraint:
    def g(x):
        return np.array([r**2 - ((x[0] - ox) ** 2 + (x[1] - oy) ** 2) for ox, oy, r in OBSTACLES])

    return ddpkit.Constraint.from_function(g, nx=4)


def test_safe_cddp_with_traced_constraints_equals_the_built_in_circles() -> None:
    built_in = [ddpkit.Circle((ox, oy), r) for ox, oy, r in OBSTACLES]
    tight = ddpkit.Tightening(beta=0.9, sigma_w=0.001 * np.eye(4))
    a = ddpkit.SafeCddpSolver(obstacle_problem(ddpkit.DoubleIntegrator2D(dt=0.05)), built_in, tightening=tight).solve()
    c = traced_obstacles()
    assert c.dim == 3 and not c.depends_on_control
    b = ddpkit.SafeCddpSolver(obstacle_problem(ddpkit.DoubleIntegrator2D(dt=0.05)), [c], tightening=tight).solve()
    assert a.converged and b.converged
    assert b.cost == pytest.approx(a.cost, rel=1e-8)
    assert b.max_violation <= 1e-6
    # A traced double integrator (any size path) with the traced obstacles.
    def di(x, u):
        return np.array([x[0] + 0.05 * x[2] + 0.00125 * u[0], x[1] + 0.05 * x[3] + 0.00125 * u[1], x[2] + 0.05 * u[0], x[3] + 0.05 * u[1]])

    d = ddpkit.SafeCddpSolver(obstacle_problem(ddpkit.Dynamics.from_function(di, nx=4, nu=2)), [c], tightening=tight).solve()
    assert d.converged and d.cost == pytest.approx(a.cost, rel=1e-6)


def test_mpc_runs_a_traced_model_like_the_built_in_one() -> None:
    sigma = 0.002 * np.eye(4)
    kw = dict(sigma_w=sigma, goal=[3.0, 3.0, 0.0, 0.0], iterations=3, initial_iterations=30)
    built = ddpkit.Mpc(obstacle_problem(ddpkit.DoubleIntegrator2D(dt=0.05)), [ddpkit.Circle((ox, oy), r) for ox, oy, r in OBSTACLES], **kw)
    traced = ddpkit.Mpc(obstacle_problem(ddpkit.DoubleIntegrator2D(dt=0.05)), [traced_obstacles()], **kw)
    e1, e2 = built.run_episode(7), traced.run_episode(7)
    assert e1.steps == e2.steps
    np.testing.assert_allclose(e2.xs, e1.xs, atol=1e-6)


def test_tracing_errors_name_the_function_and_the_reason() -> None:
    def branches(x, u):
        if x[0] > 0:
            return x
        return -x

    with pytest.raises(ddpkit.InvalidInputError, match=r"branches.*branches in Python"):
        ddpkit.Dynamics.from_function(branches, nx=2, nu=1)

    def unsupported(x, u):
        return np.cbrt(x) + u[0]

    with pytest.raises(ddpkit.InvalidInputError, match=r"unsupported.*np\.cbrt"):
        ddpkit.Dynamics.from_function(unsupported, nx=2, nu=1)

    import math

    with pytest.raises(ddpkit.InvalidInputError, match=r"converts a symbolic value"):
        ddpkit.Dynamics.from_function(lambda x, u: np.array([math.sin(x[0]), x[1]]), nx=2, nu=1)
    with pytest.raises(ddpkit.ShapeError, match=r"shape \(2,\)"):
        ddpkit.Dynamics.from_function(lambda x, u: x[:1], nx=2, nu=1)
    with pytest.raises(ddpkit.ShapeError, match="scalar"):
        ddpkit.Cost.from_function(lambda x, u: x, nx=2, nu=1)
    with pytest.raises(ddpkit.InvalidInputError, match="non-finite"):
        ddpkit.Cost.from_function(lambda x, u: x[0] * np.inf, nx=2, nu=1)
    with pytest.raises(ddpkit.InvalidInputError, match="integrator"):
        ddpkit.Dynamics.from_function(lambda x, u: x, nx=2, nu=1, dt=0.1, integrator="midpoint")
    with pytest.raises(ddpkit.InvalidInputError, match="nx"):
        ddpkit.Dynamics.from_function(lambda x, u: x, nx=0, nu=1)
    # A traced model of other sizes than the problem's is a shape error naming the field.
    with pytest.raises(ddpkit.ShapeError):
        cartpole_problem(ddpkit.Dynamics.from_function(lambda x, u: x, nx=3, nu=1))
    # An error of the user's own code is raised as it is.
    def buggy(x, u):
        raise KeyError("oops")

    with pytest.raises(KeyError):
        ddpkit.Dynamics.from_function(buggy, nx=2, nu=1)


def test_numpy_style_math_traces() -> None:
    def f(x, u):
        m = np.array([[1.0, 0.5], [0.0, 2.0]])
        v = m @ x[:2]
        w = np.stack([np.minimum(x[0], 0.3), np.maximum(x[1], -0.1)])
        s = np.sum(np.abs(x) ** 2)
        return np.concatenate([v + w * s, [np.where(x[0] > 0, np.tanh(x[1]), np.exp(x[1])) + u[0] / 2]])

    model = ddpkit.Dynamics.from_function(f, nx=3, nu=1)
    for x in [np.array([0.2, -0.7, 1.2]), np.array([-0.5, 0.4, -0.3])]:
        u = np.array([0.7])
        np.testing.assert_allclose(model.step(x, u), f(x, u), rtol=1e-14)
        gx, gu = fd_jacobians(lambda a, b: f(a, b), x, u)
        fx, fu = model.jacobians(x, u)
        np.testing.assert_allclose(fx, gx, atol=1e-7)
        np.testing.assert_allclose(fu, gu, atol=1e-7)


def test_models_save_load_and_pickle_to_equal_objects(tmp_path: Path) -> None:
    models = [
        traced_cartpole(),
        ddpkit.Cost.from_function(running, nx=4, nu=1),
        ddpkit.Cost.from_function(terminal, nx=4),
        traced_obstacles(),
        ddpkit.Dynamics.from_casadi(cartpole_casadi()),
    ]
    for i, m in enumerate(models):
        path = tmp_path / f"m{i}.json"
        m.save(path)
        back = ddpkit.load_model(path)
        assert type(back) is type(m) and back == m
        again = pickle.loads(pickle.dumps(m))
        assert type(again) is type(m) and again == m
    x, u = POINTS[0]
    np.testing.assert_array_equal(pickle.loads(pickle.dumps(models[0])).step(x, u), models[0].step(x, u))
    # The committed fixture (loaded by the Rust example and tests) is today's trace.
    assert ddpkit.load_model(FIXTURE) == traced_cartpole()
    # A corrupt file is an error naming the field, never a crash.
    bad = tmp_path / "bad.json"
    bad.write_text(models[0].to_json().replace('"sin"', '"sine"'))
    with pytest.raises(ddpkit.InvalidInputError, match="unknown operation 'sine'"):
        ddpkit.load_model(bad)
    with pytest.raises(ddpkit.InvalidInputError, match="cannot read"):
        ddpkit.load_model(tmp_path / "missing.json")


def numpy_step(x, u):
    return rk4(cartpole_ode, x, u, DT)


def test_callables_are_the_slow_path_with_finite_differences() -> None:
    slow = ddpkit.Dynamics.from_callable(numpy_step, nx=4, nu=1)
    fast = traced_cartpole()
    x, u = POINTS[0]
    np.testing.assert_array_equal(slow.step(x, u), numpy_step(x, u))
    for a, b in zip(slow.jacobians(x, u), fast.jacobians(x, u)):
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-7)
    s1 = ddpkit.Solver(cartpole_problem(slow, horizon=40), max_iterations=30).solve()
    s2 = ddpkit.Solver(cartpole_problem(fast, horizon=40), max_iterations=30).solve()
    assert s1.iterations == s2.iterations == 30
    assert s1.cost == pytest.approx(s2.cost, rel=1e-5)
    # A callable cost gives value, gradient and Hessian by differences.
    c = ddpkit.Cost.from_callable(running, nx=4, nu=1)
    v, lx, lu, lxx, luu, lux = ddpkit.Cost.from_function(running, nx=4, nu=1).derivatives(x, u)
    assert c.value(x, u) == pytest.approx(v, rel=1e-14)
    # Picklable where the function is.
    again = pickle.loads(pickle.dumps(slow))
    np.testing.assert_array_equal(again.step(x, u), slow.step(x, u))


class Boom(RuntimeError):
    pass


def test_an_exception_in_a_callable_reaches_the_user_as_itself() -> None:
    calls = {"n": 0}

    def flaky(x, u):
        calls["n"] += 1
        if calls["n"] > 30:
            raise Boom("lookup table out of range")
        return numpy_step(x, u)

    model = ddpkit.Dynamics.from_callable(flaky, nx=4, nu=1)
    with pytest.raises(Boom, match="out of range"):
        ddpkit.Solver(cartpole_problem(model, horizon=40)).solve()
    with pytest.raises(Boom):
        model.step(np.zeros(4), np.zeros(1))
    wrong = ddpkit.Dynamics.from_callable(lambda x, u: x[:2], nx=4, nu=1)
    with pytest.raises(ddpkit.ShapeError):
        wrong.step(np.zeros(4), np.zeros(1))
    # The next solve with a good model is unaffected.
    assert ddpkit.Solver(cartpole_problem(traced_cartpole(), horizon=40)).solve().iterations > 0


def test_traced_models_solve_from_many_threads() -> None:
    problem = cartpole_problem(traced_cartpole())
    expected = ddpkit.Solver(problem, method="ddp", max_iterations=300).solve()
    results: list = [None] * 4

    def work(i: int) -> None:
        results[i] = ddpkit.Solver(cartpole_problem(traced_cartpole()), method="ddp", max_iterations=300).solve()

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results:
        assert r.cost == expected.cost and r.iterations == expected.iterations
        np.testing.assert_array_equal(r.us, expected.us)


def obstacle_rows(x):
    return np.array([r**2 - ((x[0] - ox) ** 2 + (x[1] - oy) ** 2) for ox, oy, r in OBSTACLES])


def test_callable_constraints_are_the_slow_path_with_finite_differences() -> None:
    slow = ddpkit.Constraint.from_callable(obstacle_rows, nx=4, rows=3)
    assert isinstance(slow, ddpkit.CallableConstraint) and slow.rows == 3
    tight = ddpkit.Tightening(beta=0.9, sigma_w=0.001 * np.eye(4))
    fast = ddpkit.SafeCddpSolver(obstacle_problem(ddpkit.DoubleIntegrator2D(dt=0.05)), [traced_obstacles()], tightening=tight).solve()
    sol = ddpkit.SafeCddpSolver(obstacle_problem(ddpkit.DoubleIntegrator2D(dt=0.05)), [slow], tightening=tight).solve()
    assert fast.converged and sol.converged, sol.status
    assert sol.cost == pytest.approx(fast.cost, rel=1e-5)
    assert sol.max_violation <= 1e-6
    # A wrong row count is an error naming the function, raised by the solve.
    wrong = ddpkit.Constraint.from_callable(obstacle_rows, nx=4, rows=2)
    with pytest.raises(ddpkit.ShapeError, match="obstacle_rows"):
        ddpkit.SafeCddpSolver(obstacle_problem(ddpkit.DoubleIntegrator2D(dt=0.05)), [wrong]).solve()
    # Sizes are checked against the problem when the solver is built.
    with pytest.raises(ddpkit.ShapeError, match="nx"):
        ddpkit.SafeCddpSolver(obstacle_problem(ddpkit.DoubleIntegrator2D(dt=0.05)), [ddpkit.Constraint.from_callable(obstacle_rows, nx=3, rows=3)])
    with pytest.raises(ddpkit.InvalidInputError, match="rows"):
        ddpkit.Constraint.from_callable(obstacle_rows, nx=4, rows=0)


def test_an_exception_in_a_callable_cost_reaches_problem_cost() -> None:
    def bad(x, u):
        raise Boom("cost table missing")

    problem = ddpkit.Problem(
        x0=np.zeros(4),
        dynamics=traced_cartpole(),
        running_cost=ddpkit.Cost.from_callable(bad, nx=4, nu=1),
        terminal_cost=ddpkit.Cost.from_function(terminal, nx=4),
        horizon=10,
    )
    us = np.zeros((10, 1))
    with pytest.raises(Boom, match="cost table missing"):
        problem.cost(problem.rollout(us), us)
    # Nothing is left pending: the next evaluation on this thread is clean.
    assert ddpkit.Cost.from_function(terminal, nx=4).value(np.zeros(4)) == pytest.approx(50.0 * np.pi**2)


def test_a_traced_model_at_a_compiled_size_solves_as_at_a_run_time_size() -> None:
    # The cart-pole's (4, 1) is a compiled pair (fixed-size matrices, the fast path); the same
    # cart-pole with a fifth, decoupled and unweighted state (5, 1) runs at run-time sizes. Both
    # take the same full-DDP iterations to the same swing-up.
    assert (4, 1) in ddpkit.supported_dimensions() and (6, 2) in ddpkit.supported_dimensions()
    assert (5, 1) not in ddpkit.supported_dimensions()

    def padded(x, u):
        return np.append(cartpole_ode(x[:4], u), 0.0)

    small = ddpkit.Solver(cartpole_problem(traced_cartpole(), horizon=60), method="ddp").solve()
    big = ddpkit.Solver(
        ddpkit.Problem(
            x0=np.zeros(5),
            dynamics=ddpkit.Dynamics.from_function(padded, nx=5, nu=1, dt=DT, integrator="rk4"),
            running_cost=ddpkit.Cost.from_function(lambda x, u: running(x[:4], u), nx=5, nu=1),
            terminal_cost=ddpkit.Cost.from_function(lambda x: terminal(x[:4]), nx=5),
            horizon=60,
        ),
        method="ddp",
    ).solve()
    assert small.converged and big.converged, (small.status, big.status)
    assert small.iterations == big.iterations
    assert small.cost == pytest.approx(big.cost, rel=1e-10)
    np.testing.assert_allclose(small.us, big.us, atol=1e-8)
    np.testing.assert_allclose(small.xs, big.xs[:, :4], atol=1e-8)
