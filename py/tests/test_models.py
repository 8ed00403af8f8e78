"""Every model's Jacobians against central differences of its step, from Python; cost values."""

from __future__ import annotations

import numpy as np
import pytest

import ddpkit

rng = np.random.default_rng(11)

MODELS = {
    "unicycle": ddpkit.Unicycle(dt=0.1),
    "car": ddpkit.Car(dt=0.05),
    "double_integrator": ddpkit.DoubleIntegrator2D(dt=0.05),
    "differential_drive": ddpkit.DifferentialDrive(dt=0.1, track_width=0.3),
    "quadrotor": ddpkit.Quadrotor(dt=0.02),
    "arm_base": ddpkit.ArmBase(dt=0.05),
    "linear": ddpkit.LinearDynamics(rng.standard_normal((4, 4)), rng.standard_normal((4, 2)), c=[1.0, 2.0, 3.0, 4.0]),
}

EXPECTED_DIMS = {
    "unicycle": (3, 2),
    "car": (4, 2),
    "double_integrator": (4, 2),
    "differential_drive": (3, 2),
    "quadrotor": (12, 4),
    "arm_base": (10, 5),
    "linear": (4, 2),
}


def central_differences(model: ddpkit.Dynamics, x: np.ndarray, u: np.ndarray, h: float = 1e-6):
    fx = np.zeros((model.nx, model.nx))
    fu = np.zeros((model.nx, model.nu))
    for j in range(model.nx):
        e = np.zeros(model.nx)
        e[j] = h
        fx[:, j] = (model.step(x + e, u) - model.step(x - e, u)) / (2 * h)
    for j in range(model.nu):
        e = np.zeros(model.nu)
        e[j] = h
        fu[:, j] = (model.step(x, u + e) - model.step(x, u - e)) / (2 * h)
    return fx, fu


@pytest.mark.parametrize("name", sorted(MODELS))
def test_jacobians_match_finite_differences(name: str) -> None:
    model = MODELS[name]
    assert (model.nx, model.nu) == EXPECTED_DIMS[name]
    assert isinstance(model, ddpkit.Dynamics)
    for _ in range(5):
        x = 0.5 * rng.standard_normal(model.nx)
        u = 0.5 * rng.standard_normal(model.nu)
        fx, fu = model.jacobians(x, u)
        assert fx.shape == (model.nx, model.nx) and fu.shape == (model.nx, model.nu)
        fx_fd, fu_fd = central_differences(model, x, u)
        scale = 1.0 + max(np.abs(fx_fd).max(), np.abs(fu_fd).max())
        np.testing.assert_allclose(fx, fx_fd, rtol=0, atol=1e-6 * scale, err_msg=f"{name}: fx")
        np.testing.assert_allclose(fu, fu_fd, rtol=0, atol=1e-6 * scale, err_msg=f"{name}: fu")


def test_steps_are_the_documented_maps() -> None:
    x, u = np.array([1.0, 2.0, 0.3]), np.array([0.5, -0.2])
    np.testing.assert_allclose(
        ddpkit.Unicycle(0.1).step(x, u),
        [1.0 + 0.1 * 0.5 * np.cos(0.3), 2.0 + 0.1 * 0.5 * np.sin(0.3), 0.3 - 0.02],
        rtol=1e-15,
    )
    x4, u2 = np.array([1.0, 2.0, 0.5, -0.5]), np.array([0.2, 0.4])
    dt = 0.05
    np.testing.assert_allclose(
        ddpkit.DoubleIntegrator2D(dt).step(x4, u2),
        [1.0 + dt * 0.5 + 0.5 * dt**2 * 0.2, 2.0 - dt * 0.5 + 0.5 * dt**2 * 0.4, 0.5 + dt * 0.2, -0.5 + dt * 0.4],
        rtol=1e-15,
    )
    lin = MODELS["linear"]
    assert isinstance(lin, ddpkit.LinearDynamics)
    np.testing.assert_allclose(lin.step(x4, u2), lin.A @ x4 + lin.B @ u2 + lin.c, rtol=1e-14)
    q = ddpkit.Quadrotor()
    hover = q.hover_control()
    assert hover[0] == pytest.approx(q.mass * q.gravity)
    np.testing.assert_allclose(q.step(np.zeros(12), hover), np.zeros(12), atol=1e-12)
    arm = ddpkit.ArmBase()
    assert arm.tcp_position(np.zeros(10)).shape == (2,)
    assert arm.params["dt"] == arm.dt


def test_cost_values() -> None:
    x, u = np.array([1.0, 2.0, 3.0]), np.array([0.5, -1.0])
    Q, R = np.diag([1.0, 2.0, 3.0]), np.diag([4.0, 5.0])
    xr = np.array([0.5, 0.5, 0.5])
    c = ddpkit.QuadraticCost(Q, R, x_ref=xr)
    assert c.value(x, u) == pytest.approx(0.5 * (x - xr) @ Q @ (x - xr) + 0.5 * u @ R @ u)
    assert not c.state_only
    t = ddpkit.QuadraticTerminal([1.0, 2.0, 3.0])
    assert t.value(x) == pytest.approx(0.5 * x @ Q @ x)
    assert t.state_only
    assert ddpkit.ControlSquared(2.0).value(x, u) == pytest.approx(2.0 * (0.25 + 1.0))
    g = ddpkit.SmoothDistance([4.0, 6.0], eps=1e-3, weight=2.0)
    assert g.value(x) == pytest.approx(2.0 * np.sqrt(9.0 + 16.0 + 1e-6))
    assert g.value(x, u) == g.value(x)  # usable as a running cost
    h = ddpkit.ObstacleHinge([[1.0, 2.5], [10.0, 10.0]], margin=1.0, weight=3.0)
    assert h.value(x) == pytest.approx(3.0 * 0.5)
    p = ddpkit.CirclePenalty([[1.0, 2.5, 1.0]], weight=3.0)
    assert p.value(x) == pytest.approx(3.0 * (1.0 - 0.25) ** 2)
    s = ddpkit.CostSum([(2.0, c), (1.0, g)])
    assert len(s) == 2
    assert s.value(x, u) == pytest.approx(2.0 * c.value(x, u) + g.value(x))
    ts = ddpkit.TerminalSum([(0.5, t), (1.0, h)])
    assert ts.value(x) == pytest.approx(0.5 * t.value(x) + h.value(x))
