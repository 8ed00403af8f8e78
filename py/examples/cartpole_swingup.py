"""Cart-pole swing-up with dynamics and costs traced from plain numpy functions.

    python py/examples/cartpole_swingup.py [figure.png]

The ODE is integrated by RK4 inside the tape; full DDP uses its exact second derivatives.
"""

from __future__ import annotations

import sys

import numpy as np
from _common import cartpole_ode, save_figure

import ddpkit

DT, N = 0.05, 80


def main() -> int:
    dynamics = ddpkit.Dynamics.from_function(lambda x, u: np.array(cartpole_ode(x, u)), nx=4, nu=1, dt=DT, integrator="rk4")
    running = ddpkit.Cost.from_function(lambda x, u: 0.05 * (x[0] ** 2 + x[2] ** 2 + x[3] ** 2) + 0.05 * u[0] ** 2, nx=4, nu=1)
    terminal = ddpkit.Cost.from_function(lambda x: 50.0 * (x[0] ** 2 + (x[1] - np.pi) ** 2 + x[2] ** 2 + x[3] ** 2), nx=4)
    problem = ddpkit.Problem(x0=np.zeros(4), dynamics=dynamics, running_cost=running, terminal_cost=terminal, horizon=N)
    sol = ddpkit.Solver(problem, method="ddp", max_iterations=300).solve()
    print(sol.table())
    print(f"status {sol.status}, cost {sol.cost:.6f}, final angle {sol.xs[-1, 1]:.4f} rad (pi = {np.pi:.4f})")
    save_figure(sys.argv[1] if len(sys.argv) > 1 else "cartpole_swingup.png", sol.xs, sol.us, ["p", "theta", "pdot", "thetadot"])
    return 0 if sol.converged and abs(sol.xs[-1, 1] - np.pi) < 0.1 else 1


if __name__ == "__main__":
    sys.exit(main())
