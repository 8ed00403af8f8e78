"""Shared problem builders for the ddpkit tests."""

from __future__ import annotations

import numpy as np
import pytest

import ddpkit

#: Optimal cost of benchmark P1 found by every peer (bench/problems.md).
P1_COST = 250.0393199732


def p1_problem(horizon: int = 100) -> ddpkit.Problem:
    """Benchmark P1: Crocoddyl's ActionModelUnicycle with its defaults, x0 = (-1, -1, 1)."""
    w_x, w_u = 10.0, 1.0
    return ddpkit.Problem(
        x0=np.array([-1.0, -1.0, 1.0]),
        dynamics=ddpkit.Unicycle(dt=0.1),
        running_cost=ddpkit.QuadraticCost(Q=w_x**2 * np.eye(3), R=w_u**2 * np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=w_x**2 * np.eye(3)),
        horizon=horizon,
    )


@pytest.fixture
def p1() -> ddpkit.Problem:
    return p1_problem()
