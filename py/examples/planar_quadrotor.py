"""Planar quadrotor (6 states, 2 rotor thrusts) flying past a circular obstacle with Safe-CDDP
and chance-constraint tightening; the dynamics are traced from a numpy function.

    python py/examples/planar_quadrotor.py [figure.png]

State `(px, pz, theta, vx, vz, omega)`, controls the two rotor thrusts `(f1, f2)`:
`m ax = -(f1 + f2) sin(theta)`, `m az = (f1 + f2) cos(theta) - m g`, `J alpha = l (f1 - f2)`.
"""

from __future__ import annotations

import sys

import numpy as np
from _common import save_figure

import ddpkit

M, J, L, G = 0.5, 0.01, 0.15, 9.81
DT, N = 0.05, 60
HOVER = 0.5 * M * G
GOAL = np.array([3.0, 0.0, 0.0, 0.0, 0.0, 0.0])
OBSTACLE = ((1.5, 0.05), 0.4)


def ode(x, u):
    thrust = u[0] + u[1]
    return np.array([x[3], x[4], x[5], -thrust * np.sin(x[2]) / M, thrust * np.cos(x[2]) / M - G, L * (u[0] - u[1]) / J])


def main() -> int:
    problem = ddpkit.Problem(
        x0=np.zeros(6),
        dynamics=ddpkit.Dynamics.from_function(ode, nx=6, nu=2, dt=DT, integrator="rk4"),
        running_cost=ddpkit.QuadraticCost(Q=np.zeros(6), R=[0.1, 0.1], u_ref=[HOVER, HOVER]),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=[100.0, 100.0, 10.0, 10.0, 10.0, 10.0], x_ref=GOAL),
        horizon=N,
        u_min=0.0,
        u_max=2.0 * M * G,
    )
    obstacle = ddpkit.Circle(*OBSTACLE)
    tightening = ddpkit.Tightening(beta=0.9, sigma_w=1e-5 * np.eye(6))
    sol = ddpkit.SafeCddpSolver(problem, [obstacle], tightening=tightening, max_iterations=300).solve()
    print(sol.table())
    miss = np.min(np.hypot(sol.xs[:, 0] - OBSTACLE[0][0], sol.xs[:, 1] - OBSTACLE[0][1]))
    print(f"status {sol.status}, cost {sol.cost:.6f}, violation {sol.max_violation:.2e}, closest approach {miss:.3f} m (radius {OBSTACLE[1]})")
    save_figure(sys.argv[1] if len(sys.argv) > 1 else "planar_quadrotor.png", sol.xs, sol.us, ["px", "pz", "theta", "vx", "vz", "omega"])
    ok = sol.converged and sol.max_violation <= 1e-6 and np.linalg.norm(sol.xs[-1, :2] - GOAL[:2]) < 0.1
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
