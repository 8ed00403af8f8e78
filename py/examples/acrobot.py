"""Acrobot swing-up (torque at the elbow only) with dynamics and costs traced from plain numpy
functions, solved by full DDP.

    python py/examples/acrobot.py [figure.png]

State `(q1, q2, q1dot, q2dot)` with `q1 = 0` hanging down and `q2` the elbow angle relative to the
first link; the equations are Spong's (1995) as written in Tedrake, "Underactuated Robotics",
ch. 3: `M(q) qddot + C(q, qdot) qdot = tau_g(q) + B u`, `B = (0, 1)`, two uniform 1 m, 1 kg links.
The goal is upright, `(pi, 0, 0, 0)`.
"""

from __future__ import annotations

import sys

import numpy as np
from _common import save_figure

import ddpkit

M1 = M2 = 1.0
L1 = 1.0
LC1 = LC2 = 0.5
I1 = I2 = 1.0 / 3.0  # about each link's pivot
G = 9.81
DT, N = 0.05, 100
GOAL = np.array([np.pi, 0.0, 0.0, 0.0])


def ode(x, u):
    q1, q2, w1, w2 = x[0], x[1], x[2], x[3]
    s1, s2, c2 = np.sin(q1), np.sin(q2), np.cos(q2)
    s12 = np.sin(q1 + q2)
    m11 = I1 + I2 + M2 * L1**2 + 2.0 * M2 * L1 * LC2 * c2
    m12 = I2 + M2 * L1 * LC2 * c2
    m22 = I2
    h = M2 * L1 * LC2 * s2
    # tau_g + B u - C qdot
    r1 = -M1 * G * LC1 * s1 - M2 * G * (L1 * s1 + LC2 * s12) + 2.0 * h * w1 * w2 + h * w2**2
    r2 = -M2 * G * LC2 * s12 - h * w1**2 + u[0]
    det = m11 * m22 - m12 * m12
    return np.array([w1, w2, (m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det])


def main() -> int:
    dynamics = ddpkit.Dynamics.from_function(ode, nx=4, nu=1, dt=DT, integrator="rk4")
    running = ddpkit.Cost.from_function(lambda x, u: 0.01 * (x[2] ** 2 + x[3] ** 2) + 0.01 * u[0] ** 2, nx=4, nu=1)
    terminal = ddpkit.Cost.from_function(
        lambda x: 100.0 * ((x[0] - np.pi) ** 2 + x[1] ** 2) + 10.0 * (x[2] ** 2 + x[3] ** 2), nx=4
    )
    problem = ddpkit.Problem(x0=np.zeros(4), dynamics=dynamics, running_cost=running, terminal_cost=terminal, horizon=N)
    sol = ddpkit.Solver(problem, method="ddp", max_iterations=500).solve()
    print(sol.table())
    err = np.abs(sol.xs[-1] - GOAL)
    q1, q2, w1, w2 = sol.xs[-1]
    print(
        f"status {sol.status}, cost {sol.cost:.6f}, final q1 {q1:.4f} q2 {q2:.4f} q1dot {w1:.4f} q2dot {w2:.4f} "
        f"(goal q1 = pi = {np.pi:.4f}, q2 = 0)"
    )
    save_figure(
        sys.argv[1] if len(sys.argv) > 1 else "acrobot.png",
        sol.xs,
        sol.us,
        ["q1 (rad)", "q2 (rad)", "q1dot (rad/s)", "q2dot (rad/s)"],
        title="Acrobot swing-up (traced, full DDP)",
        u_labels=["elbow torque (N m)"],
        dt=DT,
    )
    return 0 if sol.converged and err[0] < 0.05 and err[1] < 0.05 else 1


if __name__ == "__main__":
    sys.exit(main())
