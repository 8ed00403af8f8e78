"""Shared by the examples: the cart-pole equations and saving a figure when matplotlib is there."""

from __future__ import annotations

import sys

import numpy as np


def cartpole_ode(x, u, np=np):
    """Cart-pole `xdot` (Tedrake, "Underactuated Robotics", ch. 3), x = (p, theta, pdot, thetadot),
    theta = 0 hanging down. `np` may be numpy (traced by ddpkit) or casadi (symbolic)."""
    mc, mp, length, g = 1.0, 0.1, 0.5, 9.81
    s, c = np.sin(x[1]), np.cos(x[1])
    d = mc + mp * s**2
    pdd = (u[0] + mp * s * (length * x[3] ** 2 + g * c)) / d
    tdd = (-u[0] * c - mp * length * x[3] ** 2 * c * s - (mc + mp) * g * s) / (length * d)
    return [x[2], x[3], pdd, tdd]


def save_figure(path: str, xs: np.ndarray, us: np.ndarray, labels: list[str]) -> None:
    """States and controls against the knot index, written to `path` (skipped without matplotlib)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print(f"(matplotlib is not installed: no figure written to {path})", file=sys.stderr)
        return
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    for i, name in enumerate(labels):
        a.plot(xs[:, i], label=name)
    a.legend(loc="best")
    b.step(range(len(us)), us, where="post")
    b.set_xlabel("knot")
    fig.savefig(path, dpi=120)
    print(f"figure: {path}")
