#!/usr/bin/env python3
"""ddpkit against Crocoddyl on benchmark P1 (bench/problems.md), side by side in one process.

    python bench/peers/compare.py [--repeats 50] [--json results.json]

Every solver is timed on cold solves (the same initial guess each time: zero controls, and for
Crocoddyl `xs = [x0] * (N + 1)`), single-threaded, interleaved round-robin so that a slow period of
a noisy machine hits every solver alike; the median is reported. Crocoddyl stops at
`th_stop = 1e-9`, ddpkit at `gradient_tolerance = 1e-9` (the same measure: `sum |Q_u|^2`).

Columns: accepted iterations, final cost, microseconds per iteration and milliseconds per solve
(wall time around the Python call), and the ratio of each to Crocoddyl DDP's. The rows
`(inside Rust)` give ddpkit's own solve time, so the difference is the cost of the Python
binding (argument checks, copying the results into numpy arrays).

Without crocoddyl installed, ddpkit's rows are printed with a note.
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


class Entry:
    """One solver: a cold-solve callable returning (iterations, cost, inside-seconds or None)."""

    def __init__(self, name: str, solve: Callable[[], tuple[int, float, Optional[float]]]) -> None:
        self.name = name
        self.solve = solve
        self.wall: list[float] = []
        self.inside: list[float] = []
        self.iterations = 0
        self.cost = float("nan")

    def run_once(self) -> None:
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


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=50, help="timed cold solves per solver (>= 20)")
    ap.add_argument("--warmup", type=int, default=5, help="untimed solves per solver first")
    ap.add_argument("--json", type=Path, help="also write the results here")
    args = ap.parse_args(argv)
    repeats = max(20, args.repeats)

    entries = ddpkit_entries()
    croc = crocoddyl_entries()
    if croc is not None:
        entries = croc + entries
    for e in entries:
        for _ in range(args.warmup):
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

    if args.json is not None:
        payload = {
            "problem": "P1 unicycle",
            "repeats": repeats,
            "crocoddyl": croc is not None,
            "python": sys.version.split()[0],
            "rows": rows,
        }
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(payload, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
