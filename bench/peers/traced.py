#!/usr/bin/env python3
"""Models written once in CasADi, solved by ddpkit (imported with `from_casadi`, and the same
equations traced from numpy), by CasADi + IPOPT and CasADi + FATROP, and by Crocoddyl with a
Python-subclassed action model, in one process.

    python bench/peers/traced.py [--repeats 20] [--crocoddyl-repeats 3] [--json results.json]
                                 [--problems cartpole,acrobot,...] [--skip-crocoddyl]
                                 [--warm-up portfolio|augmented_lagrangian|barrier|none]

Problems (RK4 step of 0.05 s, control held over a step):

- `cartpole`: the cart-pole swing-up of `py/examples/cartpole_casadi.py` (4 states, 1 force,
  N = 80, from hanging to upright);
- `acrobot`: the acrobot swing-up of `py/examples/acrobot.py` (Spong 1995; 4 states, elbow torque
  only, N = 100);
- `pendulum`: the pendulum of `py/examples/pendulum.py` with `|u| <= 2.5 N m`, a quarter of its
  weight's torque, so it must pump (2 states, N = 120; box-DDP, Tassa, Mansard and Todorov 2014);
- `quadrotor`: the planar quadrotor of `py/examples/planar_quadrotor.py` without its obstacle
  (6 states, 2 thrusts in `[0, 2 m g]`, N = 60, to a point 3 m away);
- `quadrotor-obstacle`: the same past the example's circular obstacle (centre (1.5, 0.05),
  radius 0.4), imposed as `g(x) = r^2 - |p - o|^2 <= 0` on `x_1 .. x_N`.

Each is one discrete step `F(x, u)`, one running cost `l(x, u)`, one terminal cost `l_N(x)` and
(for the obstacle) one constraint `g(x)` as SX `casadi.Function`s; every solver gets exactly these:

- ddpkit: `Dynamics.from_casadi(F)`, `Cost.from_casadi(l)`, `Cost.from_casadi(l_N)`
  (`Constraint.from_casadi(g)` for the obstacle), full DDP (box-DDP where the controls are
  bounded; `SafeCddpSolver`, Xie, Liu and Hedrick 2017, with its default warm-up, where there is a
  constraint: its iterations read `kept + discarded`, the portfolio start not kept being the
  second), single shooting (zero dynamics defect by construction); on the two unconstrained
  swing-ups also `shooting="multiple"` (states and controls stepped together, defects closed as
  it converges; its rows say so);
- ddpkit traced: the same equations as numpy functions through `Dynamics.from_function` (and
  `Cost` / `Constraint.from_function`);
- CasADi + IPOPT / FATROP: `Opti`, multiple shooting `x_{k+1} = F(x_k, u_k)` in stage order
  (FATROP's structure detection needs it), `g(x_k) <= 0` for k = 1..N, `expand = True`, IPOPT
  with `tol = 1e-8` and MUMPS, FATROP with its defaults;
- Crocoddyl (Mastalli et al. 2020): a `crocoddyl.ActionModelAbstract` subclassed in Python, as a
  Crocoddyl user brings a robot today: `calc` / `calcDiff` evaluate `F`, `l`, `l_N` and their
  CasADi-generated Jacobians, gradients and Hessians numerically (numpy arrays in and out);
  `SolverFDDP` (`SolverBoxFDDP` with the control bounds), at most 500 iterations, started from the
  rollout of the control guess. FDDP has no inequality constraints: on the obstacle problem the
  model adds the penalty `1e4 max(0, g(x))^2` (the squared hinge of Crocoddyl's
  `ActivationModelQuadraticBarrier`) to the costs, and its row is judged like any other (true
  objective, true violation).

Every solver starts cold from the same control guess (zero for the cart-pole, acrobot and
pendulum, hover thrust for the quadrotor; the NLPs also get `x0` repeated), single-threaded;
solves are interleaved round-robin and the median wall time is reported. Each solution is judged
by the same numpy code: the objective `sum l(x_k, u_k) + l_N(x_N)` evaluated with `F`, `l`, `l_N`
on its own states, and the largest violation (dynamics defect `|x_{k+1} - F(x_k, u_k)|`, control
bounds, `g(x_k)` for k = 1..N, `|x_0 - x0|`). Swing-ups are nonconvex: solvers may end in
different local minima, which the cost column shows.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, Callable, Optional  # noqa: E402

import numpy as np  # noqa: E402

try:
    import casadi as ca  # noqa: E402
except ImportError:  # pragma: no cover - the script's whole point is the CasADi models
    sys.exit("error: traced.py needs casadi (pip install casadi): the models are written in CasADi")

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "py" / "examples"))
from _common import cartpole_ode  # noqa: E402

import ddpkit  # noqa: E402
from compare import settle_allocator  # noqa: E402

#: Weight of Crocoddyl's squared-hinge obstacle penalty (FDDP has no inequality constraints).
CROC_PENALTY = 1e4


@dataclass
class Model:
    """A problem written once: `ode(x, u, np)` with `np` numpy or casadi, costs likewise."""

    name: str
    nx: int
    nu: int
    dt: float
    n: int
    x0: np.ndarray
    ode: Callable[..., list]
    running: Callable[..., Any]
    terminal: Callable[..., Any]
    u_min: Optional[np.ndarray] = None
    u_max: Optional[np.ndarray] = None
    #: The initial control guess of every solver (zero where None).
    u_guess: Optional[np.ndarray] = None
    #: A state-only constraint `g(x, np) <= 0` (one row) on x_1 .. x_N, or None.
    constraint: Optional[Callable[..., Any]] = None
    #: ddpkit's backward pass: "ddp" (full second order) or "ilqr".
    method: str = "ddp"
    #: ddpkit `Solver` rows: single shooting, and multiple shooting where listed (the
    #: unconstrained swing-ups, where the two differ most).
    shootings: tuple = ("single",)
    functions: tuple = field(default=(), repr=False)
    constraint_fn: Any = field(default=None, repr=False)

    def build(self) -> None:
        """The SX functions `F`, `l`, `l_N` (RK4 of the ODE, control held over a step) and `g`."""
        x, u = ca.SX.sym("x", self.nx), ca.SX.sym("u", self.nu)
        f = lambda a, b: ca.vertcat(*self.ode(a, b, ca))  # noqa: E731
        h = self.dt
        k1 = f(x, u)
        k2 = f(x + 0.5 * h * k1, u)
        k3 = f(x + 0.5 * h * k2, u)
        k4 = f(x + h * k3, u)
        step = ca.Function("F", [x, u], [x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)])
        running = ca.Function("l", [x, u], [self.running(x, u, ca)])
        terminal = ca.Function("lN", [x], [self.terminal(x, ca)])
        self.functions = (step, running, terminal)
        if self.constraint is not None:
            self.constraint_fn = ca.Function("g", [x], [self.constraint(x, ca)])

    def judge(self, xs: np.ndarray, us: np.ndarray) -> tuple[float, float]:
        """Objective and largest violation (defect, control bounds, constraint) of a trajectory."""
        step, running, terminal = self.functions
        cost = sum(float(running(xs[k], us[k])) for k in range(self.n)) + float(terminal(xs[self.n]))
        defect = max(float(np.max(np.abs(np.asarray(step(xs[k], us[k])).ravel() - xs[k + 1]))) for k in range(self.n))
        bound = 0.0
        if self.u_min is not None:
            bound = float(max(np.max(self.u_min - us), np.max(us - self.u_max), 0.0))
        con = 0.0
        if self.constraint_fn is not None:
            con = max(0.0, max(float(np.max(np.asarray(self.constraint_fn(xs[k])))) for k in range(1, self.n + 1)))
        return cost, max(defect, bound, con, float(np.max(np.abs(xs[0] - self.x0))))


def cartpole() -> Model:
    return Model(
        name="cart-pole swing-up (N = 80)",
        nx=4,
        nu=1,
        dt=0.05,
        n=80,
        x0=np.zeros(4),
        ode=lambda x, u, m: cartpole_ode(x, u, np=m),
        running=lambda x, u, m: 0.05 * (x[0] ** 2 + x[2] ** 2 + x[3] ** 2) + 0.05 * u[0] ** 2,
        terminal=lambda x, m: 50.0 * (x[0] ** 2 + (x[1] - np.pi) ** 2 + x[2] ** 2 + x[3] ** 2),
        shootings=("single", "multiple"),
    )


# Acrobot of py/examples/acrobot.py: two uniform 1 m, 1 kg links, torque at the elbow only.
AM1 = AM2 = 1.0
AL1 = 1.0
ALC1 = ALC2 = 0.5
AI1 = AI2 = 1.0 / 3.0
G = 9.81


def acrobot_ode(x, u, m):
    """Spong (1995) as in Tedrake, "Underactuated Robotics", ch. 3; q1 = 0 hanging down."""
    q1, q2, w1, w2 = x[0], x[1], x[2], x[3]
    s1, s2, c2 = m.sin(q1), m.sin(q2), m.cos(q2)
    s12 = m.sin(q1 + q2)
    m11 = AI1 + AI2 + AM2 * AL1**2 + 2.0 * AM2 * AL1 * ALC2 * c2
    m12 = AI2 + AM2 * AL1 * ALC2 * c2
    m22 = AI2
    h = AM2 * AL1 * ALC2 * s2
    r1 = -AM1 * G * ALC1 * s1 - AM2 * G * (AL1 * s1 + ALC2 * s12) + 2.0 * h * w1 * w2 + h * w2**2
    r2 = -AM2 * G * ALC2 * s12 - h * w1**2 + u[0]
    det = m11 * m22 - m12 * m12
    return [w1, w2, (m22 * r1 - m12 * r2) / det, (m11 * r2 - m12 * r1) / det]


def acrobot() -> Model:
    return Model(
        name="acrobot swing-up (N = 100)",
        nx=4,
        nu=1,
        dt=0.05,
        n=100,
        x0=np.zeros(4),
        ode=acrobot_ode,
        running=lambda x, u, m: 0.01 * (x[2] ** 2 + x[3] ** 2) + 0.01 * u[0] ** 2,
        terminal=lambda x, m: 100.0 * ((x[0] - np.pi) ** 2 + x[1] ** 2) + 10.0 * (x[2] ** 2 + x[3] ** 2),
        shootings=("single", "multiple"),
    )


# Pendulum of py/examples/pendulum.py: m = l = 1, damping 0.1, |u| <= 2.5 N m.
PM, PL, PB = 1.0, 1.0, 0.1
P_UMAX = 2.5


def pendulum() -> Model:
    return Model(
        name="pendulum, |u| <= 2.5 (N = 120)",
        nx=2,
        nu=1,
        dt=0.05,
        n=120,
        x0=np.zeros(2),
        ode=lambda x, u, m: [x[1], (u[0] - PM * G * PL * m.sin(x[0]) - PB * x[1]) / (PM * PL**2)],
        running=lambda x, u, m: 0.01 * x[1] ** 2 + 0.01 * u[0] ** 2,
        terminal=lambda x, m: 1000.0 * (x[0] - np.pi) ** 2 + 100.0 * x[1] ** 2,
        u_min=np.array([-P_UMAX]),
        u_max=np.array([P_UMAX]),
    )


QM, QJ, QL, QG = 0.5, 0.01, 0.15, 9.81
HOVER = 0.5 * QM * QG
OBSTACLE = ((1.5, 0.05), 0.4)  # py/examples/planar_quadrotor.py


def quadrotor(obstacle: bool = False) -> Model:
    def ode(x, u, m):
        thrust = u[0] + u[1]
        return [x[3], x[4], x[5], -thrust * m.sin(x[2]) / QM, thrust * m.cos(x[2]) / QM - QG, QL * (u[0] - u[1]) / QJ]

    goal = [3.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    qf = [100.0, 100.0, 10.0, 10.0, 10.0, 10.0]
    (ox, oz), r = OBSTACLE
    return Model(
        name="planar quadrotor past obstacle (N = 60)" if obstacle else "planar quadrotor to 3 m (N = 60)",
        nx=6,
        nu=2,
        dt=0.05,
        n=60,
        x0=np.zeros(6),
        ode=ode,
        running=lambda x, u, m: 0.05 * ((u[0] - HOVER) ** 2 + (u[1] - HOVER) ** 2),
        terminal=lambda x, m: 0.5 * sum(qf[i] * (x[i] - goal[i]) ** 2 for i in range(6)),
        u_min=np.zeros(2),
        u_max=np.full(2, 2.0 * QM * QG),
        u_guess=np.full(2, HOVER),
        constraint=(lambda x, m: r**2 - ((x[0] - ox) ** 2 + (x[1] - oz) ** 2)) if obstacle else None,
    )


PROBLEMS: dict[str, Callable[[], Model]] = {
    "cartpole": cartpole,
    "acrobot": acrobot,
    "pendulum": pendulum,
    "quadrotor": quadrotor,
    "quadrotor-obstacle": lambda: quadrotor(obstacle=True),
}


def guess(m: Model) -> np.ndarray:
    return np.zeros(m.nu) if m.u_guess is None else m.u_guess


@dataclass
class Entry:
    label: str
    solve: Callable[[], tuple[int, np.ndarray, np.ndarray, str]]
    kind: str = ""
    wall: list = field(default_factory=list)
    result: tuple = ()


def ddpkit_entry(m: Model, traced: bool, warm_up: str = "portfolio", portfolio_threads: int = 1, shooting: str = "single") -> Entry:
    step, running, terminal = m.functions
    con = None
    if traced:
        dyn = ddpkit.Dynamics.from_function(lambda x, u: np.array(m.ode(x, u, np)), nx=m.nx, nu=m.nu, dt=m.dt, integrator="rk4")
        run = ddpkit.Cost.from_function(lambda x, u: m.running(x, u, np), nx=m.nx, nu=m.nu)
        term = ddpkit.Cost.from_function(lambda x: m.terminal(x, np), nx=m.nx)
        if m.constraint is not None:
            con = ddpkit.Constraint.from_function(lambda x: m.constraint(x, np), nx=m.nx)
    else:
        dyn, run, term = ddpkit.Dynamics.from_casadi(step), ddpkit.Cost.from_casadi(running), ddpkit.Cost.from_casadi(terminal)
        if m.constraint_fn is not None:
            con = ddpkit.Constraint.from_casadi(m.constraint_fn)
    bounds = {} if m.u_min is None else {"u_min": m.u_min, "u_max": m.u_max}
    problem = ddpkit.Problem(x0=m.x0, dynamics=dyn, running_cost=run, terminal_cost=term, horizon=m.n, **bounds)
    if con is None:
        solver: Any = ddpkit.Solver(problem, method=m.method, shooting=shooting, max_iterations=500)
        name = "Solver" if shooting == "single" else "Solver, multiple shooting"
    else:
        solver = ddpkit.SafeCddpSolver(
            problem, [con], method=m.method, max_iterations=500, warm_up=warm_up, portfolio_threads=portfolio_threads
        )
        name = "SafeCddpSolver"
    us0 = np.tile(guess(m), (m.n, 1))

    def solve() -> tuple[Any, np.ndarray, np.ndarray, str]:
        if con is not None:
            # Without `warm_start` every solve is a cold one, the same as a fresh solver's.
            s = solver.solve(us0)
            return f"{s.iterations} + {s.discarded_iterations}", s.xs, s.us, s.status
        s = solver.solve(us0)
        return s.iterations, s.xs, s.us, s.status

    src = "traced (numpy)" if traced else "from_casadi"
    return Entry(f"ddpkit {src}, {name}", solve, "ddpkit-traced" if traced else "ddpkit")


def casadi_entry(m: Model, plugin: str) -> Entry:
    step, running, terminal = m.functions
    opti = ca.Opti()
    xs_v, us_v = [], []
    for k in range(m.n + 1):  # stage order: x_0, u_0, x_1, ..., x_N
        xs_v.append(opti.variable(m.nx))
        if k < m.n:
            us_v.append(opti.variable(m.nu))
    opti.minimize(sum(running(xs_v[k], us_v[k]) for k in range(m.n)) + terminal(xs_v[m.n]))
    opti.subject_to(xs_v[0] == ca.DM(m.x0))
    for k in range(m.n):
        opti.subject_to(xs_v[k + 1] == step(xs_v[k], us_v[k]))
        if m.u_min is not None:
            opti.subject_to(opti.bounded(ca.DM(m.u_min), us_v[k], ca.DM(m.u_max)))
        if m.constraint_fn is not None and k > 0:  # stage k's own rows after its dynamics (FATROP)
            opti.subject_to(m.constraint_fn(xs_v[k]) <= 0)
    if m.constraint_fn is not None:
        opti.subject_to(m.constraint_fn(xs_v[m.n]) <= 0)
    if plugin == "ipopt":
        opti.solver("ipopt", {"expand": True, "print_time": False}, {"tol": 1e-8, "linear_solver": "mumps", "print_level": 0, "sb": "yes"})
    else:
        opti.solver("fatrop", {"expand": True, "print_time": False, "structure_detection": "auto", "fatrop": {"print_level": 0}})

    def solve() -> tuple[int, np.ndarray, np.ndarray, str]:
        for k in range(m.n + 1):
            opti.set_initial(xs_v[k], m.x0)
        for k in range(m.n):
            opti.set_initial(us_v[k], guess(m))
        try:
            sol = opti.solve()
            stats, value = sol.stats(), sol.value
        except RuntimeError:  # not converged: judge the last iterate like any other
            stats, value = opti.stats(), opti.debug.value
        xs = np.array([np.asarray(value(v)).reshape(m.nx) for v in xs_v])
        us = np.array([np.asarray(value(v)).reshape(m.nu) for v in us_v])
        status = stats.get("return_status", "")
        if not isinstance(status, str):
            status = "success" if stats.get("success") else f"failed ({status})"
        return int(stats.get("iter_count", -1)), xs, us, status

    return Entry("CasADi + IPOPT" if plugin == "ipopt" else "CasADi + FATROP", solve, plugin)


def crocoddyl_entry(m: Model, crocoddyl: Any) -> Entry:
    """FDDP / BoxFDDP on a Python-subclassed action model whose calc / calcDiff evaluate the
    CasADi functions (and CasADi-generated derivatives) numerically."""
    x, u = ca.SX.sym("x", m.nx), ca.SX.sym("u", m.nu)
    step, running, terminal = m.functions
    f, lr, lt = step(x, u), running(x, u), terminal(x)
    if m.constraint_fn is not None:  # squared hinge on x_k (k = 0 is fixed, so x_1 .. x_N count)
        pen = CROC_PENALTY * ca.fmax(0, m.constraint_fn(x)) ** 2
        lr, lt = lr + pen, lt + pen
    gx, gu = ca.gradient(lr, x), ca.gradient(lr, u)
    f_val = ca.Function("F", [x, u], [f, lr])
    f_diff = ca.Function(
        "dF", [x, u], [ca.jacobian(f, x), ca.jacobian(f, u), gx, gu, ca.jacobian(gx, x), ca.jacobian(gx, u), ca.jacobian(gu, u)]
    )
    gt = ca.gradient(lt, x)
    t_val = ca.Function("T", [x], [lt])
    t_diff = ca.Function("dT", [x], [gt, ca.jacobian(gt, x)])

    class Running(crocoddyl.ActionModelAbstract):
        def __init__(self) -> None:
            crocoddyl.ActionModelAbstract.__init__(self, crocoddyl.StateVector(m.nx), m.nu, 1)
            if m.u_min is not None:
                self.u_lb, self.u_ub = np.array(m.u_min, float), np.array(m.u_max, float)

        def calc(self, data, x, u=None):  # noqa: ANN001
            if u is None:  # Crocoddyl's quasi-static call: not used by FDDP here
                u = np.zeros(m.nu)
            xn, c = f_val(x, u)
            data.xnext = xn.full().ravel()
            data.cost = float(c)

        def calcDiff(self, data, x, u=None):  # noqa: ANN001, N802
            if u is None:
                u = np.zeros(m.nu)
            fx, fu, lx, lu, lxx, lxu, luu = (v.full() for v in f_diff(x, u))
            data.Fx, data.Fu = fx, fu
            data.Lx, data.Lu = lx.ravel(), lu.ravel()
            data.Lxx, data.Lxu, data.Luu = lxx, lxu, luu

    class Terminal(crocoddyl.ActionModelAbstract):
        def __init__(self) -> None:
            crocoddyl.ActionModelAbstract.__init__(self, crocoddyl.StateVector(m.nx), m.nu, 1)

        def calc(self, data, x, u=None):  # noqa: ANN001
            data.xnext = np.asarray(x, float).copy()
            data.cost = float(t_val(x))

        def calcDiff(self, data, x, u=None):  # noqa: ANN001, N802
            lx, lxx = (v.full() for v in t_diff(x))
            data.Lx, data.Lxx = lx.ravel(), lxx

    problem = crocoddyl.ShootingProblem(np.array(m.x0, float), [Running() for _ in range(m.n)], Terminal())
    boxed = m.u_min is not None
    solver = crocoddyl.SolverBoxFDDP(problem) if boxed else crocoddyl.SolverFDDP(problem)
    us0 = [np.array(guess(m), float) for _ in range(m.n)]

    def solve() -> tuple[int, np.ndarray, np.ndarray, str]:
        xs0 = problem.rollout(us0)
        ok = solver.solve(xs0, us0, 500, True)
        return solver.iter, np.array(solver.xs), np.array(solver.us), "converged" if ok else "not converged"

    name = "BoxFDDP" if boxed else "FDDP"
    extra = f", obstacle as penalty {CROC_PENALTY:g} max(0, g)^2" if m.constraint_fn is not None else ""
    return Entry(f"Crocoddyl {name} (Python action model{extra})", solve, "crocoddyl")


def run(m: Model, repeats: int, crocoddyl: Any, croc_repeats: int, warm_up: str = "portfolio", portfolio_threads: int = 1) -> list[dict]:
    m.build()
    entries = [e for sh in m.shootings for e in (ddpkit_entry(m, False, warm_up, portfolio_threads, sh), ddpkit_entry(m, True, warm_up, portfolio_threads, sh))]
    entries += [
        casadi_entry(m, "ipopt"),
        casadi_entry(m, "fatrop"),
    ]
    if crocoddyl is not None:
        entries.append(crocoddyl_entry(m, crocoddyl))
    for e in entries:  # untimed: CasADi builds its NLP solver on the first solve
        e.result = e.solve()
    for i in range(repeats):  # round-robin: a slow spell of the machine hits every solver alike
        for e in entries:
            if e.kind == "crocoddyl" and i >= croc_repeats:
                continue
            settle_allocator()  # the solve before it pays for its own frees (compare.py)
            t = time.perf_counter()
            out = e.solve()
            e.wall.append(time.perf_counter() - t)
            e.result = out
    rows = []
    base = statistics.median(entries[0].wall)
    for e in entries:
        iters, xs, us, status = e.result
        cost, viol = m.judge(xs, us)
        ms = 1e3 * statistics.median(e.wall)
        rows.append(
            {
                "problem": m.name,
                "solver": e.label,
                "kind": e.kind,
                "status": status,
                "iterations": iters,
                "cost": cost,
                "max_violation": viol,
                "ms": ms,
                "ratio": ms / (1e3 * base),
            }
        )
    return rows


def targets(rows: list[dict]) -> list[dict]:
    """The issue's targets per problem and ddpkit row: cost within 1e-6 relative of the better
    feasible NLP peer (or lower), violation <= 1e-6, >= 10x faster than IPOPT, >= 20x faster
    than Crocoddyl."""
    out = []
    for problem in dict.fromkeys(r["problem"] for r in rows):
        group = [r for r in rows if r["problem"] == problem]
        peers = [r for r in group if r["kind"] in ("ipopt", "fatrop") and r["max_violation"] <= 1e-6]
        best = min((r["cost"] for r in peers), default=None)
        ipopt = next((r for r in group if r["kind"] == "ipopt"), None)
        croc = next((r for r in group if r["kind"] == "crocoddyl"), None)
        for r in group:
            if not r["kind"].startswith("ddpkit"):
                continue
            t = {"problem": problem, "solver": r["solver"], "feasible": r["max_violation"] <= 1e-6}
            t["cost_gap"] = None if best is None else (r["cost"] - best) / abs(best)
            t["cost_ok"] = best is not None and r["cost"] <= best * (1 + 1e-6) + 1e-12
            t["ipopt_speedup"] = None if ipopt is None else ipopt["ms"] / r["ms"]
            t["crocoddyl_speedup"] = None if croc is None else croc["ms"] / r["ms"]
            out.append(t)
    return out


def md(text: str) -> str:
    """A table cell: `|` escaped (the pendulum's name has one)."""
    return text.replace("|", "\\|")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=20, help="cold solves per solver (median reported)")
    ap.add_argument("--json", type=Path, help="also write the rows (and the target checks) as JSON")
    ap.add_argument("--problems", default=",".join(PROBLEMS), help=f"comma-separated subset of {','.join(PROBLEMS)}")
    ap.add_argument(
        "--crocoddyl-repeats", type=int, default=3, help="timed Crocoddyl solves (its Python model takes seconds per solve; at most --repeats)"
    )
    ap.add_argument(
        "--warm-up",
        default="portfolio",
        choices=["portfolio", "augmented_lagrangian", "barrier", "none"],
        help="SafeCddpSolver's warm_up on constrained problems (default: the library's default, portfolio)",
    )
    ap.add_argument(
        "--portfolio-threads",
        type=int,
        default=1,
        choices=[1, 2],
        help="SafeCddpSolver's portfolio_threads: 2 runs the portfolio's first two starts at once (the peers run on one thread)",
    )
    ap.add_argument("--skip-crocoddyl", action="store_true", help="run without the Crocoddyl column")
    args = ap.parse_args()
    if args.repeats < 1 or args.crocoddyl_repeats < 1:
        print("error: --repeats and --crocoddyl-repeats must be at least 1", file=sys.stderr)
        return 2
    names = [p for p in args.problems.split(",") if p]
    unknown = [p for p in names if p not in PROBLEMS]
    if unknown:
        print(f"error: unknown problem(s) {unknown}; choose from {list(PROBLEMS)}", file=sys.stderr)
        return 2
    if not ca.has_nlpsol("fatrop") or not ca.has_nlpsol("ipopt"):
        print("error: this casadi build lacks the ipopt or fatrop plugin (pip install casadi ships both)", file=sys.stderr)
        return 2
    crocoddyl = None
    if not args.skip_crocoddyl:
        try:
            import crocoddyl  # type: ignore[no-redef]
        except ImportError:
            print("error: crocoddyl is not importable (pip install crocoddyl), or pass --skip-crocoddyl", file=sys.stderr)
            return 2
    rows = []
    for name in names:
        rows += run(PROBLEMS[name](), args.repeats, crocoddyl, min(args.repeats, args.crocoddyl_repeats), args.warm_up, args.portfolio_threads)
    print("| problem | solver | status | iterations | cost | max violation | ms / solve | time / ddpkit from_casadi |")
    print("|---|---|---|---:|---:|---:|---:|---:|")
    for r in rows:
        print(
            f"| {md(r['problem'])} | {r['solver']} | {r['status']} | {r['iterations']} | {r['cost']:.6f} | "
            f"{r['max_violation']:.1e} | {r['ms']:.2f} | {r['ratio']:.1f} |"
        )
    checks = targets(rows)
    print()
    print("| problem | ddpkit | feasible (<= 1e-6) | cost gap to better NLP peer | cost target | IPOPT / ddpkit (>= 10) | Crocoddyl / ddpkit (>= 20) |")
    print("|---|---|---|---:|---|---:|---:|")
    for t in checks:
        gap = "-" if t["cost_gap"] is None else f"{t['cost_gap']:.1e}"
        ip = "-" if t["ipopt_speedup"] is None else f"{t['ipopt_speedup']:.1f}"
        cr = "-" if t["crocoddyl_speedup"] is None else f"{t['crocoddyl_speedup']:.1f}"
        print(f"| {md(t['problem'])} | {t['solver']} | {'yes' if t['feasible'] else 'no'} | {gap} | {'met' if t['cost_ok'] else 'missed'} | {ip} | {cr} |")
    if args.json:
        meta = {
            "repeats": args.repeats,
            "crocoddyl_repeats": min(args.repeats, args.crocoddyl_repeats),
            "warm_up": args.warm_up,
            "portfolio_threads": args.portfolio_threads,
            "casadi": ca.__version__,
            "crocoddyl": getattr(crocoddyl, "__version__", None),
        }
        args.json.write_text(json.dumps({"meta": meta, "rows": rows, "targets": checks}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
