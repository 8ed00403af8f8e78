#!/usr/bin/env python3
"""ddpkit against its peers on the benchmark problems (bench/problems.md), in one process.

    python bench/peers/compare.py [--repeats 50] [--json results.json] [--skip-p1] [--skip-constrained]

P1 (unconstrained): ddpkit DDP / iLQR against Crocoddyl DDP / FDDP. P2 and P3 (three circular
obstacles each): ddpkit's constrained solver (`SafeCddpSolver`, the default of `solve.py`) and
its penalty path against CasADi + IPOPT and CasADi + FATROP (both from pip `casadi`), every
solver judged by the same numpy definition of the problem (`problem_file.py`): cost, largest
violation (dynamics defect, control box, obstacles), milliseconds per cold solve and the ratio of
each peer's time to ddpkit's. CasADi: multiple shooting with `Opti` built once, `expand = True`, the
variables and constraints in stage order (FATROP's structure detection needs it), IPOPT with
`tol = 1e-8` and MUMPS, FATROP with its defaults; initial guess zero controls and `x0` repeated.

Every solver is timed on cold solves (the same initial guess each time: zero controls, and for
Crocoddyl `xs = [x0] * (N + 1)`), single-threaded, interleaved round-robin so that a slow period of
a noisy machine hits every solver alike; the median is reported. Crocoddyl stops at
`th_stop = 1e-9`, ddpkit at `gradient_tolerance = 1e-9` (the same measure: `sum |Q_u|^2`).

Columns: accepted iterations, final cost, microseconds per iteration and milliseconds per solve
(wall time around the Python call), and the ratio of each to Crocoddyl DDP's. The rows
`(inside Rust)` give ddpkit's own solve time, so the difference is the cost of the Python
binding (argument checks, copying the results into numpy arrays).

Without crocoddyl or casadi installed, the other rows are printed with a note.
"""

from __future__ import annotations

import os

# Single-threaded peers: set before numpy / crocoddyl load their thread pools.
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, Callable, Optional  # noqa: E402

import numpy as np  # noqa: E402

import ddpkit  # noqa: E402

#: Optimal cost of P1 found by every peer (bench/problems.md).
P1_COST = 250.0393199732
X0 = np.array([-1.0, -1.0, 1.0])
N = 100


def settle_allocator() -> None:
    """One allocation of 4 KiB, outside every solver's timer. glibc's malloc defers merging the
    small blocks a solve frees until the next request of 1 KiB or more, which then pays for all
    of them: after an IPOPT or FATROP solve of `family.py`'s problems, 50-300 us, which landed in
    the next solver's timed call (ddpkit's, at its first result array). With it, each timed solve
    pays only for what it frees itself, in whatever order the solvers run."""
    bytearray(4096)


class Entry:
    """One solver: a cold-solve callable returning (iterations, cost, inside-seconds or None)."""

    def __init__(self, name: str, solve: Callable[[], tuple[int, float, Optional[float]]]) -> None:
        self.name = name
        self.solve = solve
        self.wall: list[float] = []
        self.inside: list[float] = []
        self.iterations = 0
        self.cost = float("nan")
        #: The last solution `(xs, us, status)`, where the solve callable records it.
        self.solution: Any = None
        #: ddpkit's portfolio starts of the last solve (`SafeSolution.starts`), where recorded.
        self.starts: list[dict[str, Any]] = []

    def run_once(self) -> None:
        settle_allocator()
        t0 = time.perf_counter()
        iterations, cost, inside = self.solve()
        self.wall.append(time.perf_counter() - t0)
        if inside is not None:
            self.inside.append(inside)
        self.iterations, self.cost = iterations, cost


def ddpkit_entries() -> list[Entry]:
    problem = ddpkit.Problem(
        x0=X0,
        dynamics=ddpkit.Unicycle(dt=0.1),
        running_cost=ddpkit.QuadraticCost(Q=100.0 * np.eye(3), R=np.eye(2)),
        terminal_cost=ddpkit.QuadraticTerminal(Qf=100.0 * np.eye(3)),
        horizon=N,
    )
    entries = []
    for method, label in (("ddp", "ddpkit DDP"), ("ilqr", "ddpkit iLQR")):
        solver = ddpkit.Solver(problem, method=method, gradient_tolerance=1e-9)

        def solve(solver: ddpkit.Solver = solver) -> tuple[int, float, Optional[float]]:
            sol = solver.solve()  # cold: zero controls
            return sol.iterations, sol.cost, sol.solve_time

        entries.append(Entry(label, solve))
    return entries


def crocoddyl_entries() -> Optional[list[Entry]]:
    try:
        import crocoddyl
    except ImportError:
        return None
    problem = crocoddyl.ShootingProblem(X0, [crocoddyl.ActionModelUnicycle()] * N, crocoddyl.ActionModelUnicycle())
    if hasattr(problem, "nthreads"):
        problem.nthreads = 1
    xs0 = [X0.copy() for _ in range(N + 1)]
    us0 = [np.zeros(2) for _ in range(N)]
    entries = []
    for cls, label in ((crocoddyl.SolverDDP, "Crocoddyl DDP"), (crocoddyl.SolverFDDP, "Crocoddyl FDDP")):
        solver = cls(problem)
        solver.th_stop = 1e-9

        def solve(solver: Any = solver) -> tuple[int, float, Optional[float]]:
            solver.solve(xs0, us0, 100, False)  # cold: the same guess, regularisation reset
            return solver.iter, solver.cost, None

        entries.append(Entry(label, solve))
    return entries


PEERS = Path(__file__).resolve().parent
PROBLEMS = PEERS.parent / "problems"
#: Costs found by the peers (bench/problems.md).
PEER_COST = {"p2_car4": 1.1972797, "p3_point4": 1.8958999}


def casadi_entry(p: Any, plugin: str, guess: Optional[tuple[np.ndarray, np.ndarray]] = None) -> Optional[Entry]:
    """CasADi + `plugin` ("ipopt" or "fatrop") on problem `p`; None without casadi. The `Opti`
    problem is built once (multiple shooting, `expand = True`, variables and constraints in stage
    order as FATROP's structure detection needs) and every solve starts from the same guess:
    `x0` repeated and zero controls, or `guess = (xs, us)`."""
    try:
        import casadi as ca
    except ImportError:
        return None
    opti = ca.Opti()
    nx, nu, n, dt = p.nx, p.nu, p.N, p.dt
    xs_v, us_v = [], []
    for k in range(n + 1):  # stage order: x_0, u_0, x_1, u_1, ..., x_N
        xs_v.append(opti.variable(nx))
        if k < n:
            us_v.append(opti.variable(nu))

    def f(x: Any, u: Any) -> Any:
        if p.model == "car":
            return ca.vertcat(x[0] + dt * x[3] * ca.cos(x[2]), x[1] + dt * x[3] * ca.sin(x[2]), x[2] + dt * u[0], x[3] + dt * u[1])
        if p.model == "point":
            return ca.vertcat(
                x[0] + dt * x[2] + 0.5 * dt * dt * u[0], x[1] + dt * x[3] + 0.5 * dt * dt * u[1], x[2] + dt * u[0], x[3] + dt * u[1]
            )
        return ca.vertcat(x[0] + dt * u[0] * ca.cos(x[2]), x[1] + dt * u[0] * ca.sin(x[2]), x[2] + dt * u[1])

    cost = 0
    for k in range(n):
        cost += 0.5 * ca.sumsqr(ca.sqrt(ca.DM(p.R)) * us_v[k])
    cost += 0.5 * ca.sumsqr(ca.sqrt(ca.DM(p.Qf)) * (xs_v[n] - ca.DM(p.x_goal)))
    opti.minimize(cost)

    def obstacle_rows(k: int) -> None:
        for o in p.obstacles:
            opti.subject_to((xs_v[k][0] - o[0]) ** 2 + (xs_v[k][1] - o[1]) ** 2 >= o[2] ** 2)

    opti.subject_to(xs_v[0] == ca.DM(p.x0))
    for k in range(n):
        opti.subject_to(xs_v[k + 1] == f(xs_v[k], us_v[k]))  # gap closing, stage k
        if p.u_min is not None:
            opti.subject_to(opti.bounded(ca.DM(p.u_min), us_v[k], ca.DM(p.u_max)))
        if k >= 1:
            obstacle_rows(k)
    obstacle_rows(n)
    if plugin == "ipopt":
        opti.solver("ipopt", {"expand": True, "print_time": False}, {"tol": 1e-8, "linear_solver": "mumps", "print_level": 0, "sb": "yes"})
    else:
        opti.solver("fatrop", {"expand": True, "print_time": False, "structure_detection": "auto", "fatrop": {"print_level": 0}})
    label = "CasADi + IPOPT" if plugin == "ipopt" else "CasADi + FATROP"
    entry = Entry(label, lambda: (0, float("nan"), None))

    def solve() -> tuple[int, float, Optional[float]]:
        for k in range(n + 1):
            opti.set_initial(xs_v[k], p.x0 if guess is None else guess[0][k])
        for k in range(n):
            opti.set_initial(us_v[k], np.zeros(nu) if guess is None else guess[1][k])
        try:
            sol = opti.solve()
            stats = sol.stats()
            value = sol.value
        except RuntimeError:  # not converged: judge the last iterate like any other
            stats = opti.stats()
            value = opti.debug.value
        xs = np.array([np.asarray(value(v)).reshape(nx) for v in xs_v])
        us = np.array([np.asarray(value(v)).reshape(nu) for v in us_v])
        status = stats.get("return_status", "")
        if not isinstance(status, str):  # FATROP: an integer code, 0 on success
            status = f"{'success' if stats.get('success') else 'failed'} (return_status {status})"
        entry.solution = (xs, us, status)
        return int(stats.get("iter_count", -1)), p.objective(xs, us), None

    entry.solve = solve
    return entry


#: ddpkit's ways of handling obstacles (`solve.py --method`) and their row labels.
DDPKIT_METHODS = {"constrained": "ddpkit SafeCddpSolver", "penalty": "ddpkit penalty (AL rounds)"}


def ddpkit_constrained_entries(
    p: Any, methods: tuple[str, ...] = ("constrained", "penalty"), safe_options: Optional[dict[str, Any]] = None
) -> list[Entry]:
    """ddpkit on problem `p` through `solve.py`'s `DdpkitSolver`, one entry per obstacle method,
    every solve cold (zero controls); `safe_options`: keywords of `SafeCddpSolver`."""
    sys.path.insert(0, str(PEERS))
    from solve import DdpkitSolver

    entries = []
    for obstacles in methods:
        label = DDPKIT_METHODS[obstacles]
        solver = DdpkitSolver(p, obstacles=obstacles, safe_options=safe_options)
        entry = Entry(label, lambda: (0, float("nan"), None))

        def solve(solver: Any = solver, entry: Entry = entry) -> tuple[int, float, Optional[float]]:
            xs, us, iterations, status, _ = solver.solve_raw()  # cold
            entry.solution = (xs, us, status)
            entry.starts = solver.starts
            return iterations, p.objective(xs, us), None

        entry.solve = solve
        entries.append(entry)
    return entries


def constrained_comparison(
    repeats: int, warmup: int, safe_options: Optional[dict[str, Any]] = None
) -> tuple[list[dict[str, Any]], bool]:
    """P2 and P3: every solver, interleaved; rows with cost, violation, time and ratio."""
    from problem_file import load

    rows: list[dict[str, Any]] = []
    have_casadi = True
    for name in ("p2_car4", "p3_point4"):
        p = load(PROBLEMS / f"{name}.json")
        entries = ddpkit_constrained_entries(p, safe_options=safe_options)
        for plugin in ("ipopt", "fatrop"):
            e = casadi_entry(p, plugin)
            if e is None:
                have_casadi = False
            else:
                entries.append(e)
        for e in entries:
            for _ in range(warmup):
                e.run_once()
            e.wall.clear()
        for _ in range(repeats):
            for e in entries:
                e.run_once()
        base = statistics.median(entries[0].wall) * 1e3
        for e in entries:
            xs, us, status = e.solution
            ms = statistics.median(e.wall) * 1e3
            rows.append(
                {
                    "problem": name,
                    "solver": e.name,
                    "status": status,
                    "iterations": e.iterations,
                    "cost": e.cost,
                    "peer_cost": PEER_COST[name],
                    "rel_cost_vs_peers": (e.cost - PEER_COST[name]) / PEER_COST[name],
                    "max_violation": p.max_violation(xs, us),
                    "ms_per_solve": ms,
                    "solves": len(e.wall),
                    "time_vs_ddpkit": ms / base,
                }
            )
    return rows, have_casadi


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=50, help="timed cold solves per solver (>= 20)")
    ap.add_argument("--warmup", type=int, default=5, help="untimed solves per solver first")
    ap.add_argument("--json", type=Path, help="also write the results here")
    ap.add_argument("--skip-p1", action="store_true", help="only P2 and P3")
    ap.add_argument("--skip-constrained", action="store_true", help="only P1")
    sys.path.insert(0, str(PEERS))
    from solve import add_safe_arguments, safe_options_of

    add_safe_arguments(ap)  # P2 and P3
    args = ap.parse_args(argv)
    repeats = max(20, args.repeats)
    safe_options = safe_options_of(args)
    payload: dict[str, Any] = {"repeats": repeats, "python": sys.version.split()[0], "safe_options": safe_options}
    if not args.skip_p1:
        payload.update(p1_comparison(repeats, args.warmup))
    if not args.skip_constrained:
        rows, have_casadi = constrained_comparison(repeats, args.warmup, safe_options)
        print()
        print(f"P2 and P3 (three obstacles each): median of {repeats} cold solves, single-threaded, interleaved")
        header = (
            f"{'problem':<10} {'solver':<28} {'iter':>5} {'cost':>14} {'vs peers':>10} {'max viol':>9} "
            f"{'ms/solve':>9} {'x ddpkit':>9}"
        )
        print(header)
        print("-" * len(header))
        for r in rows:
            print(
                f"{r['problem']:<10} {r['solver']:<28} {r['iterations']:>5} {r['cost']:>14.10f} "
                f"{r['rel_cost_vs_peers']:>10.2e} {r['max_violation']:>9.1e} {r['ms_per_solve']:>9.3f} "
                f"{r['time_vs_ddpkit']:>9.1f}"
            )
        if not have_casadi:
            print("casadi is missing (pip install casadi): IPOPT and FATROP were not timed")
        payload["constrained"] = {"casadi": have_casadi, "rows": rows}
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(payload, indent=2) + "\n")
    return 0


def p1_comparison(repeats: int, warmup: int) -> dict[str, Any]:
    """P1: ddpkit DDP / iLQR against Crocoddyl DDP / FDDP (printed; returned for the JSON)."""

    entries = ddpkit_entries()
    croc = crocoddyl_entries()
    if croc is not None:
        entries = croc + entries
    for e in entries:
        for _ in range(warmup):
            e.solve()
    for _ in range(repeats):
        for e in entries:
            e.run_once()

    rows: list[dict[str, Any]] = []
    for e in entries:
        ms = statistics.median(e.wall) * 1e3
        rows.append(
            {
                "solver": e.name,
                "iterations": e.iterations,
                "cost": e.cost,
                "us_per_iteration": ms * 1e3 / max(e.iterations, 1),
                "ms_per_solve": ms,
                "solves": len(e.wall),
            }
        )
        if e.inside:
            ms_in = statistics.median(e.inside) * 1e3
            rows.append(
                {
                    "solver": f"{e.name} (inside Rust)",
                    "iterations": e.iterations,
                    "cost": e.cost,
                    "us_per_iteration": ms_in * 1e3 / max(e.iterations, 1),
                    "ms_per_solve": ms_in,
                    "solves": len(e.inside),
                }
            )
    ref = next((r for r in rows if r["solver"] == "Crocoddyl DDP"), None)
    for r in rows:
        r["rel_cost_error"] = abs(r["cost"] - P1_COST) / P1_COST
        if ref is not None:
            r["per_iteration_vs_crocoddyl_ddp"] = r["us_per_iteration"] / ref["us_per_iteration"]
            r["per_solve_vs_crocoddyl_ddp"] = r["ms_per_solve"] / ref["ms_per_solve"]

    print(f"P1 unicycle, N = {N}: median of {repeats} cold solves each, single-threaded, interleaved")
    header = f"{'solver':<28} {'iter':>4} {'cost':>16} {'us/iter':>9} {'ms/solve':>9} {'iter ratio':>10} {'solve ratio':>11}"
    print(header)
    print("-" * len(header))
    for r in rows:
        ratio_i = f"{r['per_iteration_vs_crocoddyl_ddp']:.3f}" if ref is not None else "-"
        ratio_s = f"{r['per_solve_vs_crocoddyl_ddp']:.3f}" if ref is not None else "-"
        print(
            f"{r['solver']:<28} {r['iterations']:>4} {r['cost']:>16.10f} {r['us_per_iteration']:>9.2f} "
            f"{r['ms_per_solve']:>9.4f} {ratio_i:>10} {ratio_s:>11}"
        )
    if croc is None:
        print("crocoddyl is missing (pip install crocoddyl): only ddpkit was timed")
    for r in rows:
        if r["rel_cost_error"] > 1e-6:
            print(f"warning: {r['solver']} cost {r['cost']!r} differs from {P1_COST} by more than 1e-6 relative")

    return {
        "problem": "P1 unicycle",
        "crocoddyl": croc is not None,
        "rows": rows,
    }


if __name__ == "__main__":
    sys.exit(main())
