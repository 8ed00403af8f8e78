#!/usr/bin/env python3
"""A model written once in CasADi, solved by ddpkit (imported with `from_casadi`, and the same
equations traced from numpy) and by CasADi + IPOPT and CasADi + FATROP, in one process.

    python bench/peers/traced.py [--repeats 20] [--json results.json]

Problems: the cart-pole swing-up of `py/examples/cartpole_casadi.py` (4 states, 1 force, RK4 step
of 0.05 s, N = 80, from hanging to upright) and the planar quadrotor of
`py/examples/planar_quadrotor.py` without its obstacle (6 states, 2 thrusts in `[0, 2 m g]`, RK4,
N = 60, to a point 3 m away). Each is one discrete step `F(x, u)`, one running cost `l(x, u)` and one
terminal cost `l_N(x)` as SX `casadi.Function`s; every solver gets exactly these:

- ddpkit: `Dynamics.from_casadi(F)`, `Cost.from_casadi(l)`, `Cost.from_casadi(l_N)`, full DDP
  (box-DDP where the controls are bounded), single shooting (zero dynamics defect by construction);
- ddpkit traced: the same equations as numpy functions through `Dynamics.from_function`;
- CasADi + IPOPT / FATROP: `Opti`, multiple shooting `x_{k+1} = F(x_k, u_k)` in stage order
  (FATROP's structure detection needs it), `expand = True`, IPOPT with `tol = 1e-8` and MUMPS,
  FATROP with its defaults.

Every solver starts cold from the same guess (zero force for the cart-pole, hover thrust for the
quadrotor; the NLPs also get `x0` repeated),
single-threaded; solves are interleaved round-robin and the median wall time is reported. Each
solution is judged by the same numpy code: the objective `sum l(x_k, u_k) + l_N(x_N)` evaluated
with `F`, `l`, `l_N` on its own states, and the largest violation (dynamics defect
`|x_{k+1} - F(x_k, u_k)|`, control bounds). Swing-ups are nonconvex: solvers may end in
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

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "py" / "examples"))
from _common import cartpole_ode  # noqa: E402

import ddpkit  # noqa: E402


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
    functions: tuple = field(default=(), repr=False)

    def build(self) -> None:
        """The SX functions `F`, `l`, `l_N` (RK4 of the ODE, control held over a step)."""
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

    def judge(self, xs: np.ndarray, us: np.ndarray) -> tuple[float, float]:
        """Objective and largest violation (defect, control bounds) of a trajectory."""
        step, running, terminal = self.functions
        cost = sum(float(running(xs[k], us[k])) for k in range(self.n)) + float(terminal(xs[self.n]))
        defect = max(float(np.max(np.abs(np.asarray(step(xs[k], us[k])).ravel() - xs[k + 1]))) for k in range(self.n))
        bound = 0.0
        if self.u_min is not None:
            bound = float(max(np.max(self.u_min - us), np.max(us - self.u_max), 0.0))
        return cost, max(defect, bound, float(np.max(np.abs(xs[0] - self.x0))))


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
    )


QM, QJ, QL, QG = 0.5, 0.01, 0.15, 9.81
HOVER = 0.5 * QM * QG


def quadrotor() -> Model:
    def ode(x, u, m):
        thrust = u[0] + u[1]
        return [x[3], x[4], x[5], -thrust * m.sin(x[2]) / QM, thrust * m.cos(x[2]) / QM - QG, QL * (u[0] - u[1]) / QJ]

    goal = [3.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    qf = [100.0, 100.0, 10.0, 10.0, 10.0, 10.0]
    return Model(
        name="planar quadrotor to 3 m (N = 60)",
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
    )


def guess(m: Model) -> np.ndarray:
    return np.zeros(m.nu) if m.u_guess is None else m.u_guess


@dataclass
class Entry:
    label: str
    solve: Callable[[], tuple[int, np.ndarray, np.ndarray, str]]
    wall: list = field(default_factory=list)
    result: tuple = ()


def ddpkit_entry(m: Model, traced: bool) -> Entry:
    step, running, terminal = m.functions
    if traced:
        dyn = ddpkit.Dynamics.from_function(lambda x, u: np.array(m.ode(x, u, np)), nx=m.nx, nu=m.nu, dt=m.dt, integrator="rk4")
        run = ddpkit.Cost.from_function(lambda x, u: m.running(x, u, np), nx=m.nx, nu=m.nu)
        term = ddpkit.Cost.from_function(lambda x: m.terminal(x, np), nx=m.nx)
    else:
        dyn, run, term = ddpkit.Dynamics.from_casadi(step), ddpkit.Cost.from_casadi(running), ddpkit.Cost.from_casadi(terminal)
    bounds = {} if m.u_min is None else {"u_min": m.u_min, "u_max": m.u_max}
    problem = ddpkit.Problem(x0=m.x0, dynamics=dyn, running_cost=run, terminal_cost=term, horizon=m.n, **bounds)
    solver = ddpkit.Solver(problem, method="ddp", max_iterations=500)

    def solve() -> tuple[int, np.ndarray, np.ndarray, str]:
        s = solver.solve(np.tile(guess(m), (m.n, 1)))
        return s.iterations, s.xs, s.us, s.status

    return Entry("ddpkit traced (numpy)" if traced else "ddpkit from_casadi", solve)


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

    return Entry("CasADi + IPOPT" if plugin == "ipopt" else "CasADi + FATROP", solve)


def run(m: Model, repeats: int) -> list[dict]:
    m.build()
    entries = [ddpkit_entry(m, False), ddpkit_entry(m, True), casadi_entry(m, "ipopt"), casadi_entry(m, "fatrop")]
    for _ in range(repeats):  # round-robin: a slow spell of the machine hits every solver alike
        for e in entries:
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
            {"problem": m.name, "solver": e.label, "status": status, "iterations": iters, "cost": cost, "max_violation": viol, "ms": ms, "ratio": ms / (1e3 * base)}
        )
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=20, help="cold solves per solver (median reported)")
    ap.add_argument("--json", type=Path, help="also write the rows as JSON")
    args = ap.parse_args()
    if args.repeats < 1:
        print("error: --repeats must be at least 1", file=sys.stderr)
        return 2
    rows = []
    for m in (cartpole(), quadrotor()):
        rows += run(m, args.repeats)
    print("| problem | solver | status | iterations | cost | max violation | ms / solve | time ratio to ddpkit from_casadi |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['problem']} | {r['solver']} | {r['status']} | {r['iterations']} | {r['cost']:.6f} | {r['max_violation']:.1e} | {r['ms']:.2f} | {r['ratio']:.1f} |"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
