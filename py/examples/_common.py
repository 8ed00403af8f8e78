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


def save_figure(
    path: str,
    xs: np.ndarray,
    us: np.ndarray,
    labels: list[str],
    title: str | None = None,
    u_labels: list[str] | None = None,
    u_limits: tuple[float, float] | None = None,
    dt: float | None = None,
) -> None:
    """States and controls against time (or the knot index without `dt`), with axis labels, legends
    and a title (the file name without `title`), written to `path` (skipped without matplotlib).
    `u_limits` draws the control bounds."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print(f"(matplotlib is not installed: no figure written to {path})", file=sys.stderr)
        return
    us = np.asarray(us).reshape(len(us), -1)
    t = np.arange(len(xs)) * (dt if dt else 1.0)
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(7, 5))
    for i, name in enumerate(labels):
        a.plot(t, xs[:, i], label=name)
    a.set_ylabel("state")
    a.legend(loc="best")
    a.grid(alpha=0.3)
    a.set_title(title or path.rsplit("/", 1)[-1].rsplit(".", 1)[0])
    names = u_labels or [f"u{j}" for j in range(us.shape[1])]
    for j in range(us.shape[1]):
        b.step(t[: len(us)], us[:, j], where="post", label=names[j])
    if u_limits is not None:
        for k, lim in enumerate(u_limits):
            b.axhline(lim, color="gray", linestyle="--", linewidth=1, label="limit" if k == 0 else None)
    b.set_xlabel("time (s)" if dt else "knot")
    b.set_ylabel("control")
    b.legend(loc="best")
    b.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    print(f"figure: {path}")
