"""Bézier curves, splines through waypoints, the sigmoid motion profile and time-parametrised
trajectories (Queen Elizabeth's School (2022), *Developing a Minimum-Error Trajectory Generation
Framework*), with numpy arrays in and out. Everything runs in Rust (the ``bezier`` crate);
vectorised methods loop there with the GIL released.

Example::

    import numpy as np
    from ddpkit import bezier

    # One cubic: length, the parameter at half the length, curvature there.
    c = bezier.Bezier([[0.0, 0.0], [1.0, 1.0], [2.0, 1.0], [3.0, 0.0]])
    length = c.arclen(1e-10)
    t_half = c.inv_arclen(0.5 * length, 1e-10)
    xy = c.eval(np.linspace(0.0, 1.0, 101))          # (101, 2)
    kappa = c.curvature(t_half)                       # < 0: turning right at the top

    # A spline through waypoints, a sigmoid profile capped at 1 m/s, a DDP reference.
    waypoints = np.array([[0.0, 0.0], [2.0, 1.0], [4.0, 0.0]])
    spline = bezier.Spline.catmull_rom(waypoints)
    traj = bezier.Trajectory.with_sigmoid(spline, m=10.0, k=0.5, max_speed=1.0)
    xs, us = traj.unicycle(dt=0.1)                    # states (x, y, theta), controls (v, omega)
    samples = traj.sample_grid(0.1)                   # position, velocity, ..., heading, curvature

    # The paper's objective and the direct optimiser of the free tangents.
    cost = bezier.spline_cost(spline)                 # jerk + 0.01 * curvature sum
    best = bezier.optimize_spline(waypoints)          # best.spline, best.cost <= cost

What is here (see each object's docstring):

- :class:`Bezier` — any degree: evaluation (Bernstein and De Casteljau), derivatives of any
  order, curvature, extrema and the exact bounding box, subdivision, degree elevation, arc length
  (adaptive Gauss-Legendre, and Simpson's rule as in the paper, each to an explicit accuracy),
  inverse arc length vectorised over ``s``, uniform resampling; :func:`arclen_batch` for many
  curves in one call (about 40 ns per cubic at 1e-12; :func:`simd_level` says whether the
  AVX-512, AVX2 or portable sums run).
- :class:`Spline` — C1 (Catmull-Rom, Hermite) and C2 (natural, clamped) splines through waypoints.
- :class:`SigmoidProfile` — the paper's distance-time sigmoid with steepness ``m`` and midpoint ``k``.
- :class:`Trajectory` — a spline traversed with a profile: position, velocity, acceleration,
  jerk, heading, curvature at any time (:class:`TrajectorySamples`), unicycle and car
  states/controls for :class:`ddpkit.Unicycle` / :class:`ddpkit.Car`, the paper's jerk and
  curvature costs.
- :func:`spline_cost`, :func:`optimize_spline` (:class:`SplineOptimizeResult`) — the objective
  and the direct optimiser.

Bad input raises :class:`ddpkit.DdpError` subclasses whose ``field`` names the argument
(``ShapeError`` for shapes, ``NotFiniteError`` for NaN/inf, ``InvalidInputError`` for values out
of range), never a crash.
"""

from ddpkit._ddpkit import BEZIER_DEFAULT_ACCURACY as DEFAULT_ACCURACY
from ddpkit._ddpkit import (
    Bezier,
    SigmoidProfile,
    Spline,
    SplineOptimizeResult,
    Trajectory,
    TrajectorySamples,
    arclen_batch,
    optimize_spline,
    simd_level,
    spline_cost,
)

__all__ = [
    "DEFAULT_ACCURACY",
    "Bezier",
    "SigmoidProfile",
    "Spline",
    "SplineOptimizeResult",
    "Trajectory",
    "TrajectorySamples",
    "arclen_batch",
    "optimize_spline",
    "simd_level",
    "spline_cost",
]
