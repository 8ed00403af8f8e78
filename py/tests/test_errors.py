"""Bad input raises an exception of the ddpkit tree that names the field; nothing crashes."""

from __future__ import annotations

import numpy as np
import pytest

import ddpkit
from conftest import p1_problem


def unicycle_problem(**overrides):
    args = dict(
        x0=np.array([-1.0, -1.0, 1.0]),
        dynamics=ddpkit.Unicycle(dt=0.1),
        running_cost=ddpkit.QuadraticCost(Q=100.0 * np.eye(3), R=np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=100.0 * np.eye(3)),
        horizon=10,
    )
    args.update(overrides)
    return ddpkit.Problem(**args)


def test_exception_tree() -> None:
    for cls in (ddpkit.ShapeError, ddpkit.NotFiniteError, ddpkit.InvalidInputError):
        assert issubclass(cls, ddpkit.DdpError)
        assert issubclass(cls, ValueError)
    assert issubclass(ddpkit.DdpError, Exception)
    assert not issubclass(ddpkit.DdpError, ValueError)


def test_wrong_x0_shape() -> None:
    with pytest.raises(ddpkit.ShapeError, match=r"x0 has shape \(2,\), expected \(3,\)") as e:
        unicycle_problem(x0=np.zeros(2))
    assert e.value.field == "x0"
    with pytest.raises(ddpkit.ShapeError, match="x0"):
        unicycle_problem(x0=np.zeros((3, 1)))


def test_nan_in_x0() -> None:
    with pytest.raises(ddpkit.NotFiniteError, match=r"x0\[1\] is not finite") as e:
        unicycle_problem(x0=[0.0, np.nan, 0.0])
    assert e.value.field == "x0"


def test_wrong_dtype() -> None:
    with pytest.raises(ddpkit.InvalidInputError, match="x0") as e:
        unicycle_problem(x0=["a", "b", "c"])
    assert e.value.field == "x0"
    with pytest.raises(ddpkit.InvalidInputError, match="Q"):
        ddpkit.QuadraticCost(Q=object(), R=np.eye(2))
    # Integer and float32 arrays are converted, not rejected.
    p = unicycle_problem(x0=np.array([-1, -1, 1], dtype=np.int32))
    np.testing.assert_array_equal(p.x0, [-1.0, -1.0, 1.0])


def test_nan_in_q() -> None:
    Q = np.eye(3)
    Q[1, 2] = np.nan
    with pytest.raises(ddpkit.NotFiniteError, match=r"Q\[5\] is not finite") as e:
        ddpkit.QuadraticCost(Q=Q, R=np.eye(2))
    assert e.value.field == "Q"
    with pytest.raises(ddpkit.NotFiniteError, match="Qf"):
        ddpkit.QuadraticTerminal(Qf=[1.0, np.inf, 1.0])


def test_negative_weight() -> None:
    with pytest.raises(ddpkit.InvalidInputError, match="weight") as e:
        ddpkit.ControlSquared(-1.0)
    assert e.value.field == "weight"
    with pytest.raises(ddpkit.InvalidInputError, match=r"terms\[1\]\.weight") as e:
        ddpkit.CostSum([(1.0, ddpkit.ControlSquared(1.0)), (-2.0, ddpkit.ControlSquared(1.0))])
    assert e.value.field == "terms[1].weight"
    with pytest.raises(ddpkit.InvalidInputError, match=r"Q\[1\]"):
        ddpkit.QuadraticCost(Q=[1.0, -1.0, 1.0], R=[1.0, 1.0])
    with pytest.raises(ddpkit.NotFiniteError, match="weight"):
        ddpkit.SmoothDistance([0.0, 0.0], weight=float("nan"))


def test_non_psd_q() -> None:
    with pytest.raises(ddpkit.InvalidInputError, match="Q is not symmetric positive semidefinite") as e:
        ddpkit.QuadraticCost(Q=np.diag([1.0, -0.5, 1.0]), R=np.eye(2))
    assert e.value.field == "Q"
    asym = np.eye(3)
    asym[0, 1] = 1.0
    with pytest.raises(ddpkit.InvalidInputError, match="not symmetric"):
        ddpkit.QuadraticCost(Q=asym, R=np.eye(2))
    with pytest.raises(ddpkit.ShapeError, match="R"):
        ddpkit.QuadraticCost(Q=np.eye(3), R=np.ones((2, 3)))


def test_cost_dimensions_are_checked_when_the_problem_is_built() -> None:
    with pytest.raises(ddpkit.ShapeError, match=r"running_cost\.Q has shape \(4, 4\), expected \(3, 3\)") as e:
        unicycle_problem(running_cost=ddpkit.QuadraticCost(np.eye(4), np.eye(2)))
    assert e.value.field == "running_cost.Q"
    with pytest.raises(ddpkit.ShapeError, match=r"terminal_cost\.Qf has shape \(4, 4\), expected \(3, 3\)"):
        unicycle_problem(terminal_cost=ddpkit.QuadraticTerminal(np.eye(4)))
    # What can be checked without (nx, nu) is checked when the term is made.
    with pytest.raises(ddpkit.ShapeError, match=r"u_ref has shape \(3,\), expected \(2,\)"):
        ddpkit.QuadraticCost(np.eye(3), [1.0, 1.0], u_ref=[0.0, 0.0, 0.0])
    with pytest.raises(ddpkit.InvalidInputError, match=r"running_cost\.terms\[0\]\.indices\[1\]"):
        unicycle_problem(running_cost=ddpkit.CostSum([(1.0, ddpkit.SmoothDistance([0.0, 0.0], indices=(0, 7)))]))
    with pytest.raises(ddpkit.InvalidInputError, match="terminal_cost") as e:
        unicycle_problem(terminal_cost=ddpkit.QuadraticCost(np.eye(3), np.eye(2)))
    assert e.value.field == "terminal_cost"


def test_horizon_zero_and_negative() -> None:
    with pytest.raises(ddpkit.InvalidInputError, match="horizon") as e:
        unicycle_problem(horizon=0)
    assert e.value.field == "horizon"
    with pytest.raises(ddpkit.InvalidInputError, match="horizon"):
        unicycle_problem(horizon=-3)
    # Too large to allocate: an error, not an aborted interpreter.
    with pytest.raises(ddpkit.InvalidInputError, match="horizon.*cannot be allocated") as e:
        unicycle_problem(horizon=10**17)
    assert e.value.field == "horizon"


def test_mismatched_list_lengths() -> None:
    with pytest.raises(ddpkit.ShapeError, match="dynamics") as e:
        unicycle_problem(dynamics=[ddpkit.Unicycle()] * 9)
    assert e.value.field == "dynamics"
    cost = ddpkit.QuadraticCost(np.eye(3), np.eye(2))
    with pytest.raises(ddpkit.ShapeError, match="running_cost") as e:
        unicycle_problem(running_cost=[cost] * 11)
    assert e.value.field == "running_cost"
    with pytest.raises(ddpkit.ShapeError, match=r"dynamics\[4\]"):
        unicycle_problem(dynamics=[ddpkit.Unicycle()] * 4 + [ddpkit.Car()] + [ddpkit.Unicycle()] * 5)
    with pytest.raises(ddpkit.InvalidInputError, match=r"running_cost\[2\]"):
        unicycle_problem(running_cost=[cost, cost, "oops"] + [cost] * 7)
    with pytest.raises(ddpkit.ShapeError, match=r"running_cost\[3\]\.Q"):
        unicycle_problem(running_cost=[cost] * 3 + [ddpkit.QuadraticCost(np.eye(2), np.eye(2))] + [cost] * 6)


def test_wrong_types() -> None:
    with pytest.raises(ddpkit.InvalidInputError, match="dynamics"):
        unicycle_problem(dynamics="unicycle")
    with pytest.raises(ddpkit.InvalidInputError, match="running_cost"):
        unicycle_problem(running_cost=ddpkit.Unicycle())
    with pytest.raises(ddpkit.InvalidInputError, match=r"terms\[0\]"):
        ddpkit.CostSum([ddpkit.ControlSquared(1.0)])
    with pytest.raises(ddpkit.InvalidInputError, match=r"terms\[0\]\.term"):
        ddpkit.TerminalSum([(1.0, ddpkit.ControlSquared(1.0))])
    with pytest.raises(TypeError):
        ddpkit.Dynamics()  # the base class is abstract
    with pytest.raises(TypeError):
        ddpkit.Solver("not a problem")


def test_unknown_method_and_bad_settings() -> None:
    p = p1_problem()
    with pytest.raises(ddpkit.InvalidInputError, match="method is invalid: must be 'ilqr' or 'ddp', got 'newton'") as e:
        ddpkit.Solver(p, method="newton")
    assert e.value.field == "method"
    with pytest.raises(ddpkit.InvalidInputError, match="regularization"):
        ddpkit.Solver(p, regularization="both")
    with pytest.raises(ddpkit.InvalidInputError, match=r"settings\.mu_factor") as e:
        ddpkit.Solver(p, mu_factor=0.5)
    assert e.value.field == "settings.mu_factor"
    with pytest.raises(ddpkit.InvalidInputError, match="max_iterations"):
        ddpkit.Solver(p, max_iterations=0)
    with pytest.raises(ddpkit.InvalidInputError, match="max_iterations"):
        ddpkit.Solver(p, max_iterations=-5)
    with pytest.raises(ddpkit.InvalidInputError, match=r"settings\.gradient_tolerance"):
        ddpkit.Solver(p, gradient_tolerance=float("nan"))


def test_bad_initial_guess() -> None:
    solver = ddpkit.Solver(p1_problem())
    with pytest.raises(ddpkit.ShapeError, match=r"us0 has shape \(99, 2\), expected \(100, 2\)"):
        solver.solve(us0=np.zeros((99, 2)))
    bad = np.zeros((100, 2))
    bad[42, 1] = np.inf
    with pytest.raises(ddpkit.NotFiniteError, match="us0"):
        solver.solve(us0=bad)
    # The solver still works afterwards.
    assert solver.solve().converged


def test_bad_bounds() -> None:
    with pytest.raises(ddpkit.InvalidInputError, match=r"u_min\[1\]") as e:
        unicycle_problem(u_min=[-1.0, 2.0], u_max=[1.0, 1.0])
    assert e.value.field == "u_min[1]"
    with pytest.raises(ddpkit.ShapeError, match="u_max"):
        unicycle_problem(u_max=[1.0, 1.0, 1.0])
    with pytest.raises(ddpkit.NotFiniteError, match="u_min"):
        unicycle_problem(u_min=[np.nan, 0.0])
    # Infinite bounds mean "unbounded" and are accepted.
    p = unicycle_problem(u_min=[-np.inf, -1.0], u_max=np.inf)
    assert ddpkit.Solver(p).solve().us[:, 1].min() >= -1.0


def test_model_and_cost_arguments() -> None:
    with pytest.raises(ddpkit.InvalidInputError, match="dt") as e:
        ddpkit.Unicycle(dt=-0.1)
    assert e.value.field == "dt"
    with pytest.raises(ddpkit.InvalidInputError, match="track_width"):
        ddpkit.DifferentialDrive(0.1, track_width=0.0)
    with pytest.raises(ddpkit.InvalidInputError, match="mass"):
        ddpkit.Quadrotor(mass=float("nan"))
    with pytest.raises(ddpkit.InvalidInputError, match="link_lengths"):
        ddpkit.ArmBase(link_lengths=(0.5, -1.0))
    with pytest.raises(ddpkit.InvalidInputError, match="eps"):
        ddpkit.SmoothDistance([0.0, 0.0], eps=0.0)
    with pytest.raises(ddpkit.ShapeError, match="target"):
        ddpkit.SmoothDistance([0.0, 0.0, 0.0])
    with pytest.raises(ddpkit.InvalidInputError, match="indices"):
        ddpkit.SmoothDistance([0.0, 0.0], indices=(1, 1))
    with pytest.raises(ddpkit.ShapeError, match="points"):
        ddpkit.ObstacleHinge(np.zeros((3, 3)), margin=0.5)
    with pytest.raises(ddpkit.InvalidInputError, match="margin"):
        ddpkit.ObstacleHinge(np.zeros((3, 2)), margin=-0.5)
    with pytest.raises(ddpkit.InvalidInputError, match=r"circles\[1\]"):
        ddpkit.CirclePenalty([[0.0, 0.0, 1.0], [1.0, 1.0, -1.0]])


def test_step_and_value_inputs() -> None:
    m = ddpkit.Unicycle()
    with pytest.raises(ddpkit.ShapeError, match=r"x has shape \(4,\), expected \(3,\)"):
        m.step(np.zeros(4), np.zeros(2))
    with pytest.raises(ddpkit.ShapeError, match="u"):
        m.jacobians(np.zeros(3), np.zeros(3))
    with pytest.raises(ddpkit.NotFiniteError, match="x"):
        m.step([0.0, np.nan, 0.0], [0.0, 0.0])
    c = ddpkit.QuadraticCost(np.eye(3), np.eye(2))
    with pytest.raises(ddpkit.InvalidInputError, match="u"):
        c.value(np.zeros(3))
    with pytest.raises(ddpkit.ShapeError, match="Q"):
        c.value(np.zeros(4), np.zeros(2))


def test_any_dimensions_and_bad_shapes() -> None:
    # A pair outside the compiled ones runs at run-time sizes (no "compiled pairs" refusal).
    lin = ddpkit.LinearDynamics(np.eye(2), np.ones((2, 1)))
    assert (lin.nx, lin.nu) == (2, 1)
    with pytest.raises(ddpkit.ShapeError, match="B") as e:
        ddpkit.LinearDynamics(np.eye(3), np.ones((2, 2)))
    assert e.value.field == "B"
    with pytest.raises(ddpkit.ShapeError, match="A"):
        ddpkit.LinearDynamics(np.ones((3, 2)), np.ones((3, 2)))
    assert (3, 2) in ddpkit.supported_dimensions()
