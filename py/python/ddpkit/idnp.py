"""Iterative dynamic and nonlinear programming (IDNP) with adaptive grid refinement (Richter et
al. (2023), *Collision Avoidance using Iterative Dynamic and Nonlinear Programming with Adaptive Grid
Refinements*), on the crate ``idnp``'s benchmark scene: a floating base with a 2-link arm, four
rectangular obstacles with a passage narrower than the coarse DP grid, and a goal ball for the
tool centre point (TCP).

Each iteration runs DP over time-indexed quadtree grids of the TCP (eqs. (2)-(4)), maps the
waypoints to configurations (eq. (5)), follows them with constrained DDP under collision
constraints, and checks the result for collisions; the adaptive variant splits the cells of
infeasible waypoints and colliding trajectory points (eq. (6)), the fixed variant (the original
IDNP) raises their penalties instead.

Example::

    from ddpkit import idnp

    q0 = idnp.configuration([2.0, 2.5])       # collision-free, TCP at (2.0, 2.5)
    run = idnp.run(q0, variant="adaptive")     # or "fixed"
    print(run.success, run.iterations, run.cells, run.final_cells)
    xs, us = run.xs, run.us                    # (N+1, 10), (N, 5)
    run.waypoints[0]                           # (T+1, 2) waypoints of iteration 1

    result = idnp.experiment(n=20, seed=1)     # the paper's Section V experiment
    print(result.table())

Everything runs in Rust with the GIL released; invalid input raises a :class:`ddpkit.DdpError`
subclass whose ``field`` names the argument (``q0``, ``x0``, ``tcp``, ``variant``, ...).
"""

from ddpkit._ddpkit import IdnpExperiment as Experiment
from ddpkit._ddpkit import IdnpRun as Run
from ddpkit._ddpkit import idnp_configuration as configuration
from ddpkit._ddpkit import idnp_experiment as experiment
from ddpkit._ddpkit import idnp_run as run
from ddpkit._ddpkit import idnp_scene as scene

__all__ = ["Experiment", "Run", "configuration", "experiment", "run", "scene"]
