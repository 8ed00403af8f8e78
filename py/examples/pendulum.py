"""Pendulum swing-up with a torque limit below its weight, so it must pump: box-DDP (the control
bounds are a box QP in every backward step, Tassa, Mansard and Todorov 2014).

    python py/examples/pendulum.py [figure.png]

State `(theta, omega)` with `theta = 0` hanging down; `m l^2 omegadot = u - m g l sin(theta) - b omega`
with `m = l = 1`, `b = 0.1`, and `|u| <= 2.5 N m` (holding it horizontal needs 9.81 N m).
"""

from __future__ import annotations

import sys

import numpy as np
from _common import save_figure

import ddpkit

M, L, B, G = 1.0, 1.0, 0.1, 9.81
U_MAX = 2.5
DT, N = 0.05, 120


def ode(x, u):
    return np.array([x[1], (u[0] - M * G * L * np.sin(x[0]) - B * x[1]) / (M * L**2)])


def main() -> int:
    problem = ddpkit.Problem(
        x0=np.zeros(2),
        dynamics=ddpkit.Dynamics.from_function(ode, nx=2, nu=1, dt=DT, integrator="rk4"),
        running_cost=ddpkit.Cost.from_function(lambda x, u: 0.01 * x[1] ** 2 + 0.01 * u[0] ** 2, nx=2, nu=1),
        terminal_cost=ddpkit.Cost.from_function(lambda x: 1000.0 * (x[0] - np.pi) ** 2 + 100.0 * x[1] ** 2, nx=2),
        horizon=N,
        u_min=-U_MAX,
        u_max=U_MAX,
    )
    sol = ddpkit.Solver(problem, method="ilqr", max_iterations=500).solve()
    print(sol.table())
    print(
        f"status {sol.status}, cost {sol.cost:.6f}, final angle {sol.xs[-1, 0]:.4f} rad (pi = {np.pi:.4f}), "
        f"largest |torque| {np.max(np.abs(sol.us)):.4f} (limit {U_MAX})"
    )
    save_figure(
        sys.argv[1] if len(sys.argv) > 1 else "pendulum.png",
        sol.xs,
        sol.us,
        ["theta (rad)", "omega (rad/s)"],
        title=f"Pendulum swing-up, |u| <= {U_MAX} N m (box-DDP)",
        u_labels=["torque (N m)"],
        u_limits=(-U_MAX, U_MAX),
        dt=DT,
    )
    ok = sol.converged and abs(sol.xs[-1, 0] - np.pi) < 0.05 and np.max(np.abs(sol.us)) <= U_MAX + 1e-9
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
