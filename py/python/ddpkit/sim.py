"""The sim2d simulation from Python: scenario runs with DDP planners in the loop (the DDPEN
evaluation, Gamayunov et al. (2023)) and the Safe-CDDP Turtlebot experiment (Alcan and Kyrki
(2022), §IV-C). Everything runs in Rust with the GIL released; results come back as numpy arrays.

Example::

    from ddpkit import sim

    scenario = '''
    name = "short"
    [route]
    points = [[0.0, 0.0], [12.0, 0.0]]
    [[obstacles]]
    type = "cylinder"
    center = [6.0, 0.5]
    radius = 1.0
    '''
    r = sim.run_scenario(scenario, planner="ddp", seed=0)
    print(r.outcome, r.time, r.collisions)         # completed 9.6 0
    xy = np.stack([r.x, r.y], axis=1)               # driven path, one row per 0.1 s
    print(r.epoch_ms.mean())                        # compute time per optimisation epoch

    r = sim.run_scenario(scenario, log="run.mcap")  # a Foxglove log of the run (MCAP)
    r.plot(path="run.png")                          # the binaries' top view (needs matplotlib)

    e = sim.safe_turtlebot(runs=10, seed=1)         # CDDP vs Safe-CDDP (beta 0.8)
    print(e.min_clearance("cddp").mean(), e.min_clearance("safe-cddp").mean())

Errors are :class:`ddpkit.DdpError` subclasses whose ``field`` names the offending input
(``"planner"``, ``"direction"``, ``"scenario"`` for unreadable or malformed files, or the
scenario field itself, e.g. ``"obstacles[0].radius"``).
"""

from __future__ import annotations

import os
from typing import Any, Optional, Union

from ddpkit._ddpkit import (
    SimResult,
    TurtlebotExperiment,
    sim_run_scenario,
    sim_safe_turtlebot,
)

__all__ = ["SimResult", "TurtlebotExperiment", "plot", "run_scenario", "safe_turtlebot"]


def run_scenario(
    scenario: Union[str, "os.PathLike[str]"],
    planner: str = "ddp",
    seed: int = 0,
    direction: str = "forward",
    max_time: Optional[float] = None,
    horizon: Optional[int] = None,
    log: Optional[Union[str, "os.PathLike[str]"]] = None,
) -> SimResult:
    """Runs one scenario and returns its trajectory and metrics.

    ``scenario`` is a path to a TOML scenario file (``str`` or ``os.PathLike``) or the TOML text
    itself (a ``str`` containing a newline or ``=``). ``planner``: ``"ddp"``, ``"ddp-astar"``,
    ``"ddpen"`` or ``"ddpen-oracle"``; ``direction``: ``"forward"`` or ``"backward"``;
    ``max_time`` (s) stops the run early (outcome ``"timeout"``); ``horizon`` overrides the
    planner's N; ``log`` writes the run's MCAP log there (the binaries' Foxglove topics,
    protobuf with schemas; whole or absent: an unwritable path fails before the run).
    Deterministic for a seed. The GIL is released while the simulation runs.
    """
    return sim_run_scenario(
        os.fspath(scenario) if isinstance(scenario, os.PathLike) else scenario,
        planner=planner,
        seed=seed,
        direction=direction,
        max_time=max_time,
        horizon=horizon,
        log=None if log is None else os.fspath(log),
    )


def safe_turtlebot(
    runs: int = 100,
    seed: int = 1,
    beta: float = 0.8,
    sigma_xy: Optional[float] = None,
    sigma_theta: Optional[float] = None,
    sigma_w_xy: Optional[float] = None,
) -> TurtlebotExperiment:
    """CDDP versus Safe-CDDP on a simulated Turtlebot3 Waffle Pi (Alcan and Kyrki (2022), §IV-C):
    ``runs`` seeded episodes of each (episode ``i`` meets the same noise under both), in parallel.

    ``sigma_xy`` / ``sigma_theta`` override the localisation noise (default 0.01 m, 0.02 rad),
    ``sigma_w_xy`` the per-step process noise the tightening assumes (default 0.005 m). The same
    experiment as ``cargo run --release -p sim2d --bin safe-turtlebot``.
    """
    return sim_safe_turtlebot(
        runs=runs,
        seed=seed,
        beta=beta,
        sigma_xy=sigma_xy,
        sigma_theta=sigma_theta,
        sigma_w_xy=sigma_w_xy,
    )


# Colours and dashes of the binaries' top views (crates/sim2d/src/plot.rs).
_PLANNER_STYLE = {
    "ddp": ((220, 90, 20), "--"),
    "ddp-astar": ((30, 90, 220), "-"),
    "ddpen-oracle": ((0, 150, 140), "-"),
}


def _rgb(c: "tuple[int, int, int]", alpha: float = 1.0) -> "tuple[float, float, float, float]":
    return (c[0] / 255, c[1] / 255, c[2] / 255, alpha)


def plot(result: SimResult, ax: Any = None, path: Any = None) -> Any:
    """Draws ``result``'s top view as the ``scenario`` binary does: obstacles (grey), the route
    (light green, route points as circles), the driven path (dashed for DDP), the kept plans
    (thin), start (green) and end (red), a cross where the run stopped; metre axes with equal
    scales, a legend and a title. On ``ax`` (matplotlib axes) or a new figure; saved to ``path``
    when given. Returns the axes. Needs matplotlib (``pip install ddpkit[plot]``)."""
    try:
        import matplotlib

        if ax is None and path is not None:
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        from matplotlib.patches import Polygon
    except ImportError as e:  # pragma: no cover - the message is the point
        raise ImportError("ddpkit.sim.plot needs matplotlib: pip install 'ddpkit[plot]'") from e
    import numpy as np

    fig = None
    if ax is None:
        fig, ax = plt.subplots(figsize=(10, 6))
    route = result.route
    ax.plot(route[:, 0], route[:, 1], color=_rgb((150, 215, 150)), lw=4, label="route", zorder=1)
    ax.scatter(route[:, 0], route[:, 1], s=60, facecolors="none", edgecolors=_rgb((60, 170, 60)),
               label="route points", zorder=2)
    for i, o in enumerate(result.obstacles):
        ax.add_patch(Polygon(o, closed=True, color=_rgb((90, 90, 100)),
                             label="obstacles" if i == 0 else None, zorder=3))
    color, dash = _PLANNER_STYLE.get(result.planner, ((120, 40, 160), "-"))
    for i, p in enumerate(result.plans):
        ax.plot(p[:, 0], p[:, 1], color=_rgb(color, 0.35), lw=0.8, zorder=4,
                label="planned trajectories (every 10th)" if i == 0 else None)
    ax.plot(result.x, result.y, dash, color=_rgb(color), lw=1.6, label=result.planner, zorder=5)
    if not result.completed:
        ax.plot(result.x[-1], result.y[-1], "x", color=_rgb(color), ms=10, mew=2.5,
                label="stopped (local minimum)", zorder=6)
    ax.plot(*route[0], "o", color=_rgb((30, 170, 40)), ms=8, label="start", zorder=6)
    ax.plot(*route[-1], "o", color=_rgb((220, 30, 30)), ms=8, label="end", zorder=6)
    pts = np.concatenate([route] + list(result.obstacles) + [np.stack([result.x, result.y], axis=1)])
    lo, hi = pts.min(axis=0) - 6.0, pts.max(axis=0) + 6.0
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_aspect("equal")
    ax.grid(True, color="0.9")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{result.scenario}: {result.direction} route, {result.planner}, {result.outcome} "
                 f"in {result.time:.1f} s, top view")
    ax.legend(loc="upper right", fontsize="small")
    if path is not None:
        (fig or ax.figure).savefig(os.fspath(path), dpi=100, bbox_inches="tight")
    return ax
