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

    e = sim.safe_turtlebot(runs=10, seed=1)         # CDDP vs Safe-CDDP (beta 0.8)
    print(e.min_clearance("cddp").mean(), e.min_clearance("safe-cddp").mean())

Errors are :class:`ddpkit.DdpError` subclasses whose ``field`` names the offending input
(``"planner"``, ``"direction"``, ``"scenario"`` for unreadable or malformed files, or the
scenario field itself, e.g. ``"obstacles[0].radius"``).
"""

from __future__ import annotations

import os
from typing import Optional, Union

from ddpkit._ddpkit import (
    SimResult,
    TurtlebotExperiment,
    sim_run_scenario,
    sim_safe_turtlebot,
)

__all__ = ["SimResult", "TurtlebotExperiment", "run_scenario", "safe_turtlebot"]


def run_scenario(
    scenario: Union[str, "os.PathLike[str]"],
    planner: str = "ddp",
    seed: int = 0,
    direction: str = "forward",
    max_time: Optional[float] = None,
    horizon: Optional[int] = None,
) -> SimResult:
    """Runs one scenario and returns its trajectory and metrics.

    ``scenario`` is a path to a TOML scenario file (``str`` or ``os.PathLike``) or the TOML text
    itself (a ``str`` containing a newline or ``=``). ``planner``: ``"ddp"``, ``"ddp-astar"``,
    ``"ddpen"`` or ``"ddpen-oracle"``; ``direction``: ``"forward"`` or ``"backward"``;
    ``max_time`` (s) stops the run early (outcome ``"timeout"``); ``horizon`` overrides the
    planner's N. Deterministic for a seed. The GIL is released while the simulation runs.
    """
    return sim_run_scenario(
        os.fspath(scenario) if isinstance(scenario, os.PathLike) else scenario,
        planner=planner,
        seed=seed,
        direction=direction,
        max_time=max_time,
        horizon=horizon,
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
