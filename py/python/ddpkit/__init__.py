"""ddpkit: fast, safe trajectory optimisation (iLQR, DDP, box-DDP) with numpy in and out.

Example (benchmark P1, Crocoddyl's unicycle)::

    import numpy as np
    import ddpkit

    problem = ddpkit.Problem(
        x0=np.array([-1.0, -1.0, 1.0]),
        dynamics=ddpkit.Unicycle(dt=0.1),
        running_cost=ddpkit.QuadraticCost(Q=100.0 * np.eye(3), R=np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=100.0 * np.eye(3)),
        horizon=100,
    )
    solution = ddpkit.Solver(problem, method="ddp").solve()
    print(solution.status, solution.cost)  # converged 250.0393199732...

Any size: :class:`LinearDynamics`, :class:`QuadraticCost`, :class:`QuadraticTerminal`,
:class:`ControlSquared`, control bounds, :class:`Problem` and :class:`Solver` take any ``nx`` and
``nu`` (a 7-state, 3-control example is in the docs of ``ddpkit._ddpkit``); the built-in robots'
sizes, a cart-pole's and a planar quadrotor's (:func:`supported_dimensions`) run on fixed-size
matrices.

Every error is a :class:`DdpError` (``ShapeError``, ``NotFiniteError`` and ``InvalidInputError``
are also ``ValueError``\\ s) whose ``field`` attribute names the offending argument. Solves
release the GIL. :func:`solve_batch` (and :func:`solve_batch_safe` for Safe-CDDP) solves many
problems of one structure on all cores in one call, each result bit-identical to a solve alone.

Safe-CDDP of Alcan and Kyrki (2022): :class:`SafeCddpSolver` solves problems with constraints
(:class:`Circle`, :class:`ConvexPolygon`, :class:`Cylinder`, :class:`StateBox`,
:class:`ControlBox`), optionally tightened as chance constraints (:class:`Tightening`), and
:class:`Mpc` runs it as the shrinking-horizon MPC of its Algorithm 1 under seeded noise.

:mod:`ddpkit.bezier` has the Bézier toolkit of Queen Elizabeth's School (2022) (curves, splines
through waypoints, motion profiles, trajectories as DDP references); :mod:`ddpkit.dqn` the DQN that
shapes splines (needs torch, imported only there) and ``python -m ddpkit.train`` its training
command. :mod:`ddpkit.idnp` runs IDNP with adaptive grid refinement after Richter et al. (2023): DP
on quadtree grids of the tool-centre point, inverse mapping, constrained DDP with collision
constraints.

:mod:`ddpkit.subgoal` has the DDPEN sub-goal dataset (generation in Rust, memory-mapped shards)
and the sub-goal network running in Rust (``SubgoalModel``).

Your own robot: :meth:`Dynamics.from_function`, :meth:`Cost.from_function` and
:meth:`Constraint.from_function` trace numpy-style Python functions once into tapes that Rust
evaluates with exact first and second derivatives (:mod:`ddpkit.trace`); ``from_casadi`` reads
CasADi SX functions into the same tapes; ``from_callable`` takes plain Python callables (the slow
path, finite differences). Tape models ``save``, :func:`load_model` and pickle.

:mod:`ddpkit.sim` runs sim2d scenarios (DDP planners in the loop, trajectory and metrics as
arrays) and the simulated Safe-CDDP Turtlebot experiment (Alcan and Kyrki (2022), §IV-C).
"""

from ddpkit._ddpkit import (
    ArmBase,
    CallableCost,
    CallableConstraint,
    CallableDynamics,
    Car,
    Circle,
    CirclePenalty,
    Constraint,
    ControlBox,
    ControlSquared,
    ConvexPolygon,
    Cost,
    CostSum,
    Cylinder,
    DdpError,
    DifferentialDrive,
    DoubleIntegrator2D,
    Dynamics,
    Episode,
    InvalidInputError,
    LinearDynamics,
    Mpc,
    NotFiniteError,
    ObstacleHinge,
    Problem,
    QuadraticCost,
    QuadraticTerminal,
    Quadrotor,
    SafeCddpSolver,
    SafeSolution,
    ShapeError,
    SmoothDistance,
    Solution,
    Solver,
    StateBox,
    TapeConstraint,
    TapeCost,
    TapeDynamics,
    TerminalSum,
    Tightening,
    Unicycle,
    __version__,
    default_settings,
    load_model,
    model_from_json,
    solve_batch,
    solve_batch_safe,
    supported_dimensions,
)
from ddpkit import bezier
from ddpkit import idnp
from ddpkit import sim
from ddpkit import subgoal
from ddpkit import trace

__all__ = [
    "ArmBase",
    "CallableCost",
    "CallableConstraint",
    "CallableDynamics",
    "Car",
    "Circle",
    "CirclePenalty",
    "Constraint",
    "ControlBox",
    "ControlSquared",
    "ConvexPolygon",
    "Cost",
    "CostSum",
    "Cylinder",
    "DdpError",
    "DifferentialDrive",
    "DoubleIntegrator2D",
    "Dynamics",
    "Episode",
    "InvalidInputError",
    "LinearDynamics",
    "Mpc",
    "NotFiniteError",
    "ObstacleHinge",
    "Problem",
    "QuadraticCost",
    "QuadraticTerminal",
    "Quadrotor",
    "SafeCddpSolver",
    "SafeSolution",
    "ShapeError",
    "SmoothDistance",
    "Solution",
    "Solver",
    "StateBox",
    "TapeConstraint",
    "TapeCost",
    "TapeDynamics",
    "TerminalSum",
    "Tightening",
    "Unicycle",
    "__version__",
    "bezier",
    "idnp",
    "sim",
    "subgoal",
    "trace",
    "default_settings",
    "load_model",
    "model_from_json",
    "solve_batch",
    "solve_batch_safe",
    "supported_dimensions",
]
