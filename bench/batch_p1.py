"""Batch solve against a Python loop, measured in one process run: P1 (the README's unicycle,
N = 100) from 64 seeded initial states, ``ddpkit.solve_batch`` on 1 and 2 threads against
``Solver(problem).solve()`` in a loop; results checked equal; medians of 15 repetitions.

    python bench/batch_p1.py
"""

from __future__ import annotations

import os
import time

import numpy as np

import ddpkit


def problems(count: int = 64, seed: int = 42) -> list[ddpkit.Problem]:
    rng = np.random.default_rng(seed)
    return [
        ddpkit.Problem(
            x0=rng.uniform([-2.0, -2.0, -np.pi], [2.0, 2.0, np.pi]),
            dynamics=ddpkit.Unicycle(dt=0.1),
            running_cost=ddpkit.QuadraticCost(Q=100 * np.eye(3), R=np.eye(2)),
            terminal_cost=ddpkit.QuadraticTerminal(Qf=100 * np.eye(3)),
            horizon=100,
        )
        for _ in range(count)
    ]


def median_time(f, reps: int = 15) -> float:  # type: ignore[no-untyped-def]
    times = []
    for _ in range(reps):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def main() -> None:
    ps = problems()
    solvers = [ddpkit.Solver(p) for p in ps]
    want = [s.solve() for s in solvers]
    for threads in (1, 2):
        got = ddpkit.solve_batch(ps, threads=threads)
        assert all(g.cost == w.cost and np.array_equal(g.us, w.us) for g, w in zip(got, want))
    rows = [
        ("loop: Solver(p).solve()", median_time(lambda: [ddpkit.Solver(p).solve() for p in ps])),
        ("loop: prebuilt solvers", median_time(lambda: [s.solve() for s in solvers])),
        ("solve_batch, 1 thread", median_time(lambda: ddpkit.solve_batch(ps, threads=1))),
        ("solve_batch, 2 threads", median_time(lambda: ddpkit.solve_batch(ps, threads=2))),
    ]
    base = rows[0][1]
    print(f"64 P1 problems (N = 100, seeded x0), median of 15 runs, {os.cpu_count()} cores")
    for name, t in rows:
        print(f"{name:<26} {t * 1e3:8.2f} ms  {base / t:5.2f}x")


if __name__ == "__main__":
    main()
