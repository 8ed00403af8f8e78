#!/usr/bin/env python3
"""Solve a peer benchmark problem (bench/problems.md) with ddpkit and write the solution.

    python bench/peers/solve.py bench/problems/p2_car4.json --out p2.npz

The `.npz` holds `xs` (N+1, nx), `us` (N, nu), `cost`, `max_violation`, `iterations`, `status`
and `solve_seconds` (the median of repeated cold solves: at least 20 when one takes under 0.5 s),
plus the separate violations and the settings used.

How each part of the problem is handled:

- dynamics: the built-in model (`unicycle` -> `ddpkit.Unicycle`, `car` -> `ddpkit.Car`,
  `point` -> `ddpkit.DoubleIntegrator2D`), single shooting, so the dynamics defect is zero;
- cost `unicycle`: `QuadraticCost(Q = w_x^2 I, R = w_u^2 I)`, terminal `QuadraticTerminal(w_x^2 I)`;
  cost `quad_goal`: `QuadraticCost(0, diag(R))`, terminal `QuadraticTerminal(diag(Qf), x_goal)`;
- control box: box-DDP (`u_min`, `u_max` of the `Problem`), exact;
- obstacles (`--method constrained`, the default): ddpkit's Safe-CDDP solver without
  tightening (`ddpkit.SafeCddpSolver`: an augmented-Lagrangian warm-up, then Xie et al.'s KKT
  backward pass and per-step QPs), each obstacle a `ddpkit.Circle` in the squared-distance form
  of the problem file, imposed on x_1..x_N;
- obstacles (`--method penalty`): the squared hinge `w * max(0, h)^2` of `h = r^2 - |p - o|^2`
  (`ddpkit.CirclePenalty`) on x_1..x_N, with shifted radii as in an augmented Lagrangian
  (`h + lambda / (2 w)`, one multiplier per knot and obstacle, updated after each round) and `w`
  raised over a few warm-started rounds until the violation is below the tolerance, using the
  unconstrained solver.

The reported cost is the problem's objective without any penalty, and `max_violation` is
computed from the problem's own definition, in numpy, never by ddpkit.

A malformed file exits with status 2 and an error naming the field, e.g.
`error: field 'cost.Qf' must have 4 entries, got 3`.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from problem_file import FEASIBILITY_TOL, BenchProblem, ProblemFileError, load  # noqa: E402

import ddpkit  # noqa: E402


@dataclass
class Result:
    """One solve of a benchmark problem."""

    xs: np.ndarray
    us: np.ndarray
    cost: float
    violations: dict[str, float]
    iterations: int
    status: str
    rounds: int

    @property
    def max_violation(self) -> float:
        return max(self.violations.values())


def model_of(p: BenchProblem) -> ddpkit.Dynamics:
    if p.model == "unicycle":
        return ddpkit.Unicycle(dt=p.dt)
    if p.model == "car":
        return ddpkit.Car(dt=p.dt)
    return ddpkit.DoubleIntegrator2D(dt=p.dt)


def costs_of(p: BenchProblem) -> tuple[ddpkit.Cost, ddpkit.Cost]:
    """Running and terminal cost of the problem (without obstacles)."""
    if p.cost_kind == "unicycle":
        w_x, w_u = p.weights
        return (
            ddpkit.QuadraticCost(Q=w_x**2 * np.eye(p.nx), R=w_u**2 * np.eye(p.nu)),
            ddpkit.QuadraticTerminal(Qf=w_x**2 * np.eye(p.nx)),
        )
    return (
        ddpkit.QuadraticCost(Q=np.zeros((p.nx, p.nx)), R=np.diag(p.R)),
        ddpkit.QuadraticTerminal(Qf=np.diag(p.Qf), x_ref=p.x_goal),
    )



def add_safe_arguments(ap: argparse.ArgumentParser) -> None:
    """`--two-starts`, `--apart`, `--barrier-funnel`, `--hard-barrier`, `--no-new-side`,
    `--no-flip`, `--no-mirror`, `--no-plan` and `--portfolio-threads`:
    the `SafeCddpSolver` options the peer benchmarks expose (read back with `safe_options_of`)."""
    ap.add_argument(
        "--two-starts",
        action="store_true",
        help="ddpkit with SafeCddpSolver(portfolio_third_mu=None, portfolio_polish=False): the portfolio's "
        "augmented-Lagrangian and barrier starts only (the default before 2026-12-05)",
    )
    ap.add_argument(
        "--apart",
        type=float,
        default=None,
        help="ddpkit with SafeCddpSolver(portfolio_apart=...): the third start and the polish run where the first "
        "two starts' costs are further apart than this, relative (0: always; default: the library's)",
    )
    ap.add_argument(
        "--barrier-funnel",
        type=float,
        default=None,
        help="ddpkit with SafeCddpSolver(barrier_funnel=...): after the barrier hands over, the augmented "
        "Lagrangian's trial steps may not pass this violation where two or more rows are violated at once "
        "(inf: no limit; default: the library's)",
    )
    ap.add_argument(
        "--hard-barrier",
        action="store_true",
        help="ddpkit with SafeCddpSolver(barrier_mu_init=3e-3, barrier_relaxation=1e-6, portfolio_third_mu=0.03, "
        "portfolio_new_side=None, portfolio_flip=None): the hard barrier starts of the default before the soft "
        "barrier (2026-12-05)",
    )
    ap.add_argument(
        "--no-new-side",
        action="store_true",
        help="ddpkit with SafeCddpSolver(portfolio_new_side=None): no third start where the first two starts "
        "agree (the default before 2026-12-05, night)",
    )
    ap.add_argument(
        "--no-flip",
        action="store_true",
        help="ddpkit with SafeCddpSolver(portfolio_flip=None): no flipped starts (the other side of each binding "
        "obstacle where the kept solution costs well above the obstacle-free optimum; the default before "
        "2026-12-06)",
    )
    ap.add_argument(
        "--flip-apart",
        type=float,
        default=None,
        help="ddpkit with SafeCddpSolver(portfolio_flip_apart=...): the flipped starts' gate where the first two "
        "starts end apart (1.5: the gate of portfolio_flip everywhere, as before 2026-12-06, late night; default: "
        "the library's)",
    )
    ap.add_argument(
        "--flip-starts",
        type=int,
        default=None,
        help="ddpkit with SafeCddpSolver(portfolio_flip_starts=...): at most this many flipped starts (10: one per "
        "binding row, as before 2026-12-06, late night; default: the library's)",
    )
    ap.add_argument(
        "--no-mirror",
        action="store_true",
        help="ddpkit with SafeCddpSolver(portfolio_mirror=None): no mirrored start (the other side of every "
        "obstacle at once, after the flipped starts; the default before 2026-12-06, night)",
    )
    ap.add_argument(
        "--no-plan",
        action="store_true",
        help="ddpkit with SafeCddpSolver(portfolio_plan=None): no planned start (round the obstacles on the "
        "sides of their shortest path, before the flipped starts; the default before 2026-12-07, night)",
    )
    ap.add_argument(
        "--no-abandon",
        action="store_true",
        help="ddpkit with SafeCddpSolver(portfolio_abandon=None): later starts run on when feasible far above the "
        "kept cost (the default before 2026-12-07)",
    )
    ap.add_argument(
        "--no-dual-bound",
        action="store_true",
        help="ddpkit with SafeCddpSolver(portfolio_dual_bound=None): later starts run on where their augmented "
        "Lagrangian's dual bound is above the kept cost (the default before 2026-12-07, late)",
    )
    ap.add_argument(
        "--portfolio-threads",
        type=int,
        default=1,
        choices=(1, 2),
        help="ddpkit with SafeCddpSolver(portfolio_threads=...): 2 runs the portfolio's first two starts at once "
        "(the same solutions; the peers stay single-threaded)",
    )


def safe_options_of(args: argparse.Namespace) -> dict[str, Any]:
    """The `SafeCddpSolver` keywords of `add_safe_arguments`'s options (only those given: the
    others keep the library's defaults)."""
    options: dict[str, Any] = {"portfolio_threads": args.portfolio_threads}
    if args.hard_barrier:
        options.update(
            barrier_mu_init=3e-3,
            barrier_relaxation=1e-6,
            portfolio_third_mu=0.03,
            portfolio_new_side=None,
            portfolio_flip=None,
        )
    if args.two_starts:
        options.update(portfolio_third_mu=None, portfolio_polish=False)
    if args.no_new_side:
        options["portfolio_new_side"] = None
    if args.no_flip:
        options["portfolio_flip"] = None
    if args.flip_apart is not None:
        options["portfolio_flip_apart"] = args.flip_apart
    if args.flip_starts is not None:
        options["portfolio_flip_starts"] = args.flip_starts
    if args.no_mirror:
        options["portfolio_mirror"] = None
    if args.no_plan:
        options["portfolio_plan"] = None
    if args.no_abandon:
        options["portfolio_abandon"] = None
    if args.no_dual_bound:
        options["portfolio_dual_bound"] = None
    if args.apart is not None:
        options["portfolio_apart"] = args.apart
    if args.barrier_funnel is not None:
        options["barrier_funnel"] = args.barrier_funnel
    return options


class DdpkitSolver:
    """Builds the ddpkit problem(s) once and solves from a cold start on each call."""

    def __init__(
        self,
        p: BenchProblem,
        method: str = "ilqr",
        max_iterations: int = 500,
        weights: tuple[float, ...] = (1e2, 1e3, 1e4, 1e5, 1e6),
        max_rounds: int = 12,
        obstacles: str = "constrained",
        safe_options: Optional[dict[str, Any]] = None,
    ) -> None:
        if obstacles not in ("constrained", "penalty"):
            raise ValueError(f"obstacles must be 'constrained' or 'penalty', got {obstacles!r}")
        self.p = p
        self.method = method
        self.obstacles = obstacles
        self.max_iterations = max_iterations
        self.weights = weights
        self.max_rounds = max_rounds
        self.model = model_of(p)
        self.running, self.terminal = costs_of(p)
        # The unconstrained-by-obstacles problem: the whole problem when there are no obstacles.
        self.base = ddpkit.Problem(
            p.x0, self.model, self.running, self.terminal, p.N, u_min=p.u_min, u_max=p.u_max
        )
        self.base_solver = ddpkit.Solver(self.base, method=method, max_iterations=max_iterations)
        # The constrained solver (Safe-CDDP without tightening), workspace allocated once.
        self.constrained: Optional[ddpkit.SafeCddpSolver] = None
        #: The last constrained solve's portfolio starts (`SafeSolution.starts`; empty otherwise).
        self.starts: list[dict[str, Any]] = []
        if len(p.obstacles) > 0 and obstacles == "constrained":
            circles = [ddpkit.Circle(o[:2], float(o[2])) for o in p.obstacles]
            self.constrained = ddpkit.SafeCddpSolver(
                self.base, circles, method=method, max_iterations=max_iterations, **(safe_options or {})
            )

    def _penalised(self, w: float, lam: np.ndarray) -> ddpkit.Problem:
        """Problem with the obstacle penalty of weight `w` and multipliers `lam` (N, m): the radii
        become `sqrt(r^2 + lam / (2 w))` at each knot k = 1..N."""
        p = self.p
        r2 = p.obstacles[:, 2] ** 2

        def circles(k: int) -> np.ndarray:
            c = p.obstacles.copy()
            c[:, 2] = np.sqrt(r2 + lam[k - 1] / (2.0 * w))
            return c

        def knot_cost(k: int) -> ddpkit.Cost:
            return ddpkit.CostSum([(1.0, self.running), (1.0, ddpkit.CirclePenalty(circles(k), weight=w))])

        # Knots whose multipliers are all zero (most of them) share one cost object, which the
        # Problem converts once.
        shared = ddpkit.CostSum([(1.0, self.running), (1.0, ddpkit.CirclePenalty(p.obstacles, weight=w))])
        # Knot k's running cost penalises x_k (k = 1..N-1); x_0 is fixed, x_N is terminal.
        running = [self.running] + [shared if not lam[k - 1].any() else knot_cost(k) for k in range(1, p.N)]
        terminal = ddpkit.TerminalSum([(1.0, self.terminal), (1.0, ddpkit.CirclePenalty(circles(p.N), weight=w))])
        return ddpkit.Problem(p.x0, self.model, running, terminal, p.N, u_min=p.u_min, u_max=p.u_max)

    def _h(self, xs: np.ndarray) -> np.ndarray:
        """`r^2 - |p - o|^2` at x_1..x_N, shape (N, m)."""
        o = self.p.obstacles
        d2 = (xs[1:, None, 0] - o[None, :, 0]) ** 2 + (xs[1:, None, 1] - o[None, :, 1]) ** 2
        return o[None, :, 2] ** 2 - d2

    def solve(self) -> Result:
        """Solves from a cold start and checks the solution against the problem definition."""
        return self._result(*self.solve_raw())

    def solve_raw(self) -> tuple[np.ndarray, np.ndarray, int, str, int]:
        """Solves from a cold start: `(xs, us, iterations, status, rounds)`, nothing checked.
        This is what is timed."""
        p = self.p
        self.starts = []
        if len(p.obstacles) == 0:
            sol = self.base_solver.solve()  # cold
            return sol.xs, sol.us, sol.iterations, sol.status, 1
        if self.constrained is not None:
            c = self.constrained.solve()  # cold: zero controls, multipliers and penalty reset
            self.starts = c.starts
            return c.xs, c.us, c.iterations, c.status, 1
        lam = np.zeros((p.N, len(p.obstacles)))
        us: Optional[np.ndarray] = None
        iterations, rounds, status = 0, 0, "max_iterations"
        xs = np.zeros((p.N + 1, p.nx))
        for r in range(self.max_rounds):
            w = self.weights[min(r, len(self.weights) - 1)]
            solver = ddpkit.Solver(self._penalised(w, lam), method=self.method, max_iterations=self.max_iterations)
            sol = solver.solve(us0=us)  # round 0: cold (zeros); later rounds: warm
            xs, us = sol.xs, sol.us
            iterations += sol.iterations
            rounds += 1
            status = sol.status
            h = self._h(xs)
            # Multiplier update of the augmented Lagrangian: lambda <- max(0, lambda + 2 w h).
            lam = np.maximum(0.0, lam + 2.0 * w * h)
            if h.max() <= FEASIBILITY_TOL and sol.status == "converged":
                break
        assert us is not None
        return xs, us, iterations, status, rounds

    def _result(self, xs: np.ndarray, us: np.ndarray, iterations: int, status: str, rounds: int) -> Result:
        violations = self.p.violations(xs, us)
        if max(violations.values()) > FEASIBILITY_TOL:
            status = "infeasible"
        return Result(
            xs=np.array(xs),
            us=np.array(us),
            cost=self.p.objective(xs, us),
            violations=violations,
            iterations=iterations,
            status=status,
            rounds=rounds,
        )


def time_cold_solves(solve, min_repeats: int = 20, max_seconds: float = 30.0) -> tuple[float, int]:
    """Median wall time of repeated cold solves: once if a solve takes 0.5 s or more, else at least
    `min_repeats` times (more while under a second in total, up to `max_seconds`)."""
    t0 = time.perf_counter()
    solve()
    first = time.perf_counter() - t0
    if first >= 0.5:
        return first, 1
    times: list[float] = []
    start = time.perf_counter()
    while len(times) < min_repeats or (time.perf_counter() - start < 1.0 and len(times) < 1000):
        t0 = time.perf_counter()
        solve()
        times.append(time.perf_counter() - t0)
        if time.perf_counter() - start > max_seconds:
            break
    return statistics.median(times), len(times)


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("problem", type=Path, help="problem file (bench/problems.md format)")
    ap.add_argument("--out", type=Path, required=True, help="where to write the .npz solution")
    ap.add_argument(
        "--method",
        choices=["constrained", "penalty"],
        default="constrained",
        help="obstacles: ddpkit's constrained solver (default) or the augmented-Lagrangian penalty path",
    )
    ap.add_argument("--ddp", choices=["ilqr", "ddp"], default="ilqr", help="backward pass: iLQR or full DDP")
    ap.add_argument("--max-iterations", type=int, default=500, help="per solve (per penalty round)")
    ap.add_argument("--repeats", type=int, default=20, help="minimum number of timed cold solves")
    args = ap.parse_args(argv)

    try:
        problem = load(args.problem)
        solver = DdpkitSolver(problem, method=args.ddp, max_iterations=args.max_iterations, obstacles=args.method)
    except (ProblemFileError, ddpkit.DdpError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2

    result = solver.solve()
    seconds, repeats = time_cold_solves(solver.solve_raw, min_repeats=args.repeats)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(args.out.name + ".tmp.npz")
    np.savez(
        tmp,
        xs=result.xs,
        us=result.us,
        cost=result.cost,
        max_violation=result.max_violation,
        iterations=result.iterations,
        status=result.status,
        solve_seconds=seconds,
        timed_solves=repeats,
        dynamics_violation=result.violations["dynamics"],
        box_violation=result.violations["box"],
        obstacle_violation=result.violations["obstacle"],
        penalty_rounds=result.rounds,
        method=args.method,
        ddp=args.ddp,
    )
    tmp.replace(args.out)  # complete or absent
    print(
        f"{problem.name or args.problem.stem}: status {result.status}, cost {result.cost:.10f}, "
        f"max_violation {result.max_violation:.3e} (dynamics {result.violations['dynamics']:.1e}, "
        f"box {result.violations['box']:.1e}, obstacle {result.violations['obstacle']:.1e}), "
        f"iterations {result.iterations} in {result.rounds} round(s), "
        f"{seconds * 1e3:.3f} ms per solve (median of {repeats})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
