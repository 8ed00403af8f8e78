#!/usr/bin/env python3
"""A study of an infeasible primal-dual interior-point DDP start on the benchmark family.

    python bench/peers/ipddp_study.py RESULTS.json [--only ID[,ID...]] [--gated] [--limit N]
        [--mu0 0.1] [--gauss-newton]

`RESULTS.json` is the output of `family.py --json`: each problem's spec, the peers' best cost and
ddpkit's recorded outcome. Each selected problem is solved here, in numpy, from the peers' zero-control
start by the infeasible interior-point DDP of Pavlov, Shames and Manzie (2021), and judged as
`family.py` judges ddpkit (a match: violation <= 1e-6 and cost within 1e-6 relative of the better
peer's, or lower). `--gated` takes only the problems where ddpkit's portfolio ran its guided starts
(its kept solution was far above the obstacle-free optimum), the problems such a start would join.

This is a measurement for a possible start of `SafeCddpSolver`'s portfolio, not a solver of the
library: its iterations are counted, not timed (a Rust start would cost about what one iteration of
the portfolio's other starts costs). What it shows is in `bench/peers/README.md`, "An interior-point
start with slacks: a prototype measured".

The method (Pavlov, Shames and Manzie 2021, the infeasible variant). Every row `c_i(x_k, u_k) <= 0`
(obstacles on `x_k`, k = 1..N, in the squared-distance form of `problem_file.py`; both sides of the
control box) gets a slack `s > 0` and a dual `y > 0`; the step solves the perturbed KKT conditions
`c + s = 0`, `y s = mu` to first order along the DDP recursion. With `r_p = c + s`,
`r_d = y s - mu`, `r^ = y r_p - r_d` the stage's `Q` blocks gain

    Q^_x = Q_x + c_x^T (y + r^ / s),   Q^_u = Q_u + c_u^T (y + r^ / s),
    Q^_xx = Q_xx + c_x^T (y / s) c_x + sum_i y_i c_i,xx,   Q^_uu, Q^_ux alike,

the controls' gains are DDP's on those blocks, and the slacks and duals follow
`ds = -r_p - c_x dx - c_u du`, `dy = (r^ + y (c_x dx + c_u du)) / s`. The slacks let an iterate
cross an obstacle while `s` stays positive (`r_p != 0`), as IPOPT's do. The forward pass keeps
`s` and `y` within the fraction-to-boundary rule `tau = max(0.99, 1 - mu)` and accepts a step by
IPOPT's filter with its switching condition (Wächter and Biegler 2006) on the barrier objective
`J - mu sum log s` and the infeasibility `sum |c + s|`; `mu` falls as IPOPT's does
(`mu <- max(mu_min, min(0.2 mu, mu^1.5))` once the error is below `10 mu`). The dynamics enter by
their Jacobians only (iLQR); the rows' curvature `y c_xx` is in (`--gauss-newton` leaves it out).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any, Optional

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from problem_file import FEASIBILITY_TOL, BenchProblem, parse  # noqa: E402

#: A match: cost within this of the better peer's (relative), as in `family.py`.
MATCH_REL = 1e-6


def jacobians(p: BenchProblem, x: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`f_x`, `f_u` of `problem_file.BenchProblem.step`."""
    dt = p.dt
    if p.model == "unicycle":
        c, s = math.cos(x[2]), math.sin(x[2])
        fx = np.array([[1.0, 0.0, -dt * u[0] * s], [0.0, 1.0, dt * u[0] * c], [0.0, 0.0, 1.0]])
        fu = np.array([[dt * c, 0.0], [dt * s, 0.0], [0.0, dt]])
    elif p.model == "car":
        c, s = math.cos(x[2]), math.sin(x[2])
        fx = np.eye(4)
        fx[0, 2], fx[0, 3] = -dt * x[3] * s, dt * c
        fx[1, 2], fx[1, 3] = dt * x[3] * c, dt * s
        fu = np.array([[0.0, 0.0], [0.0, 0.0], [dt, 0.0], [0.0, dt]])
    else:
        h = 0.5 * dt * dt
        fx = np.array([[1.0, 0.0, dt, 0.0], [0.0, 1.0, 0.0, dt], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
        fu = np.array([[h, 0.0], [0.0, h], [dt, 0.0], [0.0, dt]])
    return fx, fu


def rows(p: BenchProblem, k: int, x: np.ndarray, u: Optional[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The rows of stage `k` (the obstacles on `x_k` for k >= 1, the box on `u_k` for k < N):
    `c`, `c_x`, `c_u` and how many obstacle rows lead (their `c_xx` is `-2 I` on the position)."""
    nx, nu = p.nx, p.nu
    c: list[float] = []
    cx: list[np.ndarray] = []
    cu: list[np.ndarray] = []
    if k >= 1:
        for ox, oy, r in p.obstacles:
            dx, dy = x[0] - ox, x[1] - oy
            c.append(r * r - dx * dx - dy * dy)
            g = np.zeros(nx)
            g[0], g[1] = -2.0 * dx, -2.0 * dy
            cx.append(g)
            cu.append(np.zeros(nu))
    obstacles = len(c)
    if u is not None and p.u_max is not None and p.u_min is not None:
        for i in range(nu):
            e = np.zeros(nu)
            e[i] = 1.0
            c += [u[i] - p.u_max[i], p.u_min[i] - u[i]]
            cx += [np.zeros(nx), np.zeros(nx)]
            cu += [e, -e]
    if not c:
        return np.zeros(0), np.zeros((0, nx)), np.zeros((0, nu)), 0
    return np.array(c), np.array(cx), np.array(cu), obstacles


def _rollout(p: BenchProblem, us: np.ndarray) -> np.ndarray:
    xs = np.zeros((p.N + 1, p.nx))
    xs[0] = p.x0
    for k in range(p.N):
        xs[k + 1] = p.step(xs[k], us[k])
    return xs


def solve(
    p: BenchProblem,
    mu0: float = 0.1,
    max_iterations: int = 500,
    tol: float = 1e-8,
    mu_min: float = 1e-10,
    curvature: bool = True,
) -> dict[str, Any]:
    """Infeasible interior-point DDP from zero controls. Returns `xs`, `us`, `iterations` (backward
    passes), `trials` (forward passes) and `status` ("converged", "max_iterations",
    "regularization" or "line_search")."""
    n, nu = p.N, p.nu
    us = np.zeros((n, nu))
    xs = _rollout(p, us)
    mu = mu0
    slack: list[np.ndarray] = []
    dual: list[np.ndarray] = []
    for k in range(n + 1):
        c = rows(p, k, xs[k], us[k] if k < n else None)[0]
        s = np.maximum(-c, 1e-2)
        slack.append(s)
        dual.append(mu / s)

    def measures(xs: np.ndarray, us: np.ndarray, slack: list[np.ndarray]) -> tuple[float, float]:
        phi, theta = p.objective(xs, us), 0.0
        for k in range(n + 1):
            c = rows(p, k, xs[k], us[k] if k < n else None)[0]
            if len(c):
                phi -= mu * float(np.sum(np.log(slack[k])))
                theta += float(np.sum(np.abs(c + slack[k])))
        return phi, theta

    phi, theta = measures(xs, us, slack)
    theta_min, theta_max = 1e-4 * max(1.0, theta), 1e4 * max(1.0, theta)
    reg, iterations, trials = 0.0, 0, 0
    filt: list[tuple[float, float]] = []
    gamma = 1e-5

    def result(status: str) -> dict[str, Any]:
        return {"xs": xs, "us": us, "iterations": iterations, "trials": trials, "status": status}

    while iterations < max_iterations:
        iterations += 1
        lin = []
        for k in range(n + 1):
            fx, fu = jacobians(p, xs[k], us[k]) if k < n else (None, None)
            lin.append((fx, fu) + rows(p, k, xs[k], us[k] if k < n else None))
        while True:  # the backward pass, again with more regularisation where Q^_uu is not definite
            gains: list[Any] = [None] * (n + 1)
            err, dv, definite = 0.0, 0.0, True
            _, _, c, cx, _, obstacles = lin[n]
            vx = p.Qf * (xs[n] - p.x_goal)
            vxx = np.diag(p.Qf).astype(float)
            if len(c):
                s, y = slack[n], dual[n]
                rp, rd = c + s, y * s - mu
                rhat = y * rp - rd
                vx = vx + cx.T @ (y + rhat / s)
                vxx = vxx + cx.T @ ((y / s)[:, None] * cx)
                if curvature and obstacles:
                    vxx[0, 0] -= 2.0 * float(np.sum(y[:obstacles]))
                    vxx[1, 1] -= 2.0 * float(np.sum(y[:obstacles]))
                gains[n] = (None, None, -rp, -cx, rhat / s, (y / s)[:, None] * cx)
                err = max(err, float(np.max(np.abs(rp))), float(np.max(np.abs(rd))))
            for k in range(n - 1, -1, -1):
                fx, fu, c, cx, cu, obstacles = lin[k]
                qx = fx.T @ vx
                qu = p.R * us[k] + fu.T @ vx
                qxx = fx.T @ vxx @ fx
                quu = np.diag(p.R) + fu.T @ vxx @ fu
                qux = fu.T @ vxx @ fx
                if len(c):
                    s, y = slack[k], dual[k]
                    rp, rd = c + s, y * s - mu
                    rhat = y * rp - rd
                    qu_lagrangian = qu + cu.T @ y
                    err = max(err, float(np.max(np.abs(qu_lagrangian))), float(np.max(np.abs(rp))), float(np.max(np.abs(rd))))
                    sigma, w = y / s, y + rhat / s
                    qx = qx + cx.T @ w
                    qu = qu + cu.T @ w
                    qxx = qxx + cx.T @ (sigma[:, None] * cx)
                    quu = quu + cu.T @ (sigma[:, None] * cu)
                    qux = qux + cu.T @ (sigma[:, None] * cx)
                    if curvature and obstacles:
                        qxx[0, 0] -= 2.0 * float(np.sum(y[:obstacles]))
                        qxx[1, 1] -= 2.0 * float(np.sum(y[:obstacles]))
                else:
                    err = max(err, float(np.max(np.abs(qu))))
                quu_reg = quu + reg * np.eye(nu)
                try:
                    np.linalg.cholesky(quu_reg)
                except np.linalg.LinAlgError:
                    definite = False
                    break
                k_ff = -np.linalg.solve(quu_reg, qu)
                k_fb = -np.linalg.solve(quu_reg, qux)
                if len(c):
                    gains[k] = (
                        k_ff,
                        k_fb,
                        -rp - cu @ k_ff,
                        -cx - cu @ k_fb,
                        (rhat + y * (cu @ k_ff)) / s,
                        sigma[:, None] * (cx + cu @ k_fb),
                    )
                else:
                    gains[k] = (k_ff, k_fb, None, None, None, None)
                dv += float(k_ff @ qu) + 0.5 * float(k_ff @ quu @ k_ff)
                vx = qx + k_fb.T @ quu @ k_ff + k_fb.T @ qu + qux.T @ k_ff
                vxx = qxx + k_fb.T @ quu @ k_fb + k_fb.T @ qux + qux.T @ k_fb
                vxx = 0.5 * (vxx + vxx.T)
            if definite:
                break
            reg = max(1e-6, 10.0 * reg)
            if reg > 1e10:
                return result("regularization")
        if err <= 10.0 * mu and mu > mu_min:
            mu = max(mu_min, min(0.2 * mu, mu**1.5))
            filt = []
            phi, theta = measures(xs, us, slack)
            continue
        if err <= tol:
            return result("converged")
        tau = max(0.99, 1.0 - mu)
        alpha, accepted = 1.0, False
        while alpha > 1e-6:
            trials += 1
            xn, un = np.zeros_like(xs), np.zeros_like(us)
            sn: list[np.ndarray] = [np.zeros(0)] * (n + 1)
            yn: list[np.ndarray] = [np.zeros(0)] * (n + 1)
            xn[0] = p.x0
            inside = True
            for k in range(n + 1):
                dx = xn[k] - xs[k]
                g = gains[k]
                if k < n:
                    un[k] = us[k] + alpha * g[0] + g[1] @ dx
                if g is not None and g[2] is not None:
                    sn[k] = slack[k] + alpha * g[2] + g[3] @ dx
                    yn[k] = dual[k] + alpha * g[4] + g[5] @ dx
                    if np.any(sn[k] < (1.0 - tau) * slack[k]) or np.any(yn[k] < (1.0 - tau) * dual[k]):
                        inside = False
                        break
                else:
                    sn[k], yn[k] = slack[k], dual[k]
                if k < n:
                    xn[k + 1] = p.step(xn[k], un[k])
            if not inside:
                alpha *= 0.5
                continue
            phi_new, theta_new = measures(xn, un, sn)
            if not math.isfinite(phi_new):
                alpha *= 0.5
                continue
            # The switching condition: where the step promises enough decrease of the barrier
            # objective at small infeasibility, Armijo on it; else the filter's sufficient
            # decrease of either measure.
            armijo = dv < 0.0 and theta <= theta_min and alpha * (-dv) ** 2.3 > theta**1.1
            if armijo:
                ok = phi_new <= phi + 1e-4 * alpha * dv
            else:
                ok = theta_new <= (1.0 - gamma) * theta or phi_new <= phi - gamma * theta
            ok = ok and theta_new <= theta_max and all(theta_new < tf or phi_new < pf for tf, pf in filt)
            if ok:
                if not armijo:
                    filt.append(((1.0 - gamma) * theta, phi - gamma * theta))
                xs, us, slack, dual = xn, un, sn, yn
                phi, theta = phi_new, theta_new
                accepted = True
                break
            alpha *= 0.5
        if accepted:
            reg = reg / 10.0 if reg > 1e-8 else 0.0
        else:
            reg = max(1e-6, 10.0 * reg)
            if reg > 1e10:
                return result("line_search")
    return result("max_iterations")


def main(argv: Optional[list[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("results", type=Path, help="a family.py --json output")
    ap.add_argument("--only", help="comma-separated problem ids (substrings)")
    ap.add_argument("--gated", action="store_true", help="only problems where the portfolio ran its guided starts")
    ap.add_argument("--limit", type=int, help="at most this many problems")
    ap.add_argument("--mu0", type=float, default=0.1, help="the first barrier parameter (IPOPT's default 0.1)")
    ap.add_argument("--gauss-newton", action="store_true", help="leave the rows' curvature y c_xx out")
    args = ap.parse_args(argv)
    if not args.mu0 > 0.0:
        ap.error(f"--mu0 must be positive, got {args.mu0}")
    try:
        doc = json.loads(args.results.read_text())
        records = doc["problems"]
    except (OSError, json.JSONDecodeError, KeyError, TypeError) as e:
        print(f"error: {args.results} is not a family.py --json output: {e}", file=sys.stderr)
        return 2
    only = args.only.split(",") if args.only else None
    rows_out, matches, within, portfolio_within, either_within = [], 0, 0, 0, 0
    for rec in records:
        if only is not None and not any(o in rec["id"] for o in only):
            continue
        starts = rec["solvers"]["ddpkit"].get("starts", [])
        if args.gated and not any(s["flip"] is not None or s["mirror"] or s["plan"] for s in starts):
            continue
        if args.limit is not None and len(rows_out) >= args.limit:
            break
        p = parse(rec["spec"])
        best = rec["best_peer_cost"]
        t = time.perf_counter()
        r = solve(p, mu0=args.mu0, curvature=not args.gauss_newton)
        cost = p.objective(r["xs"], r["us"])
        feasible = p.max_violation(r["xs"], r["us"]) <= FEASIBILITY_TOL
        gap = (cost - best) / abs(best) if feasible else math.inf
        recorded = rec.get("rel_gap", math.inf)
        recorded = math.inf if recorded is None else recorded
        matches += gap <= MATCH_REL
        within += gap <= 0.05
        portfolio_within += recorded <= 0.05
        either_within += min(gap, recorded) <= 0.05
        portfolio_iterations = sum(s["iterations"] for s in starts)
        rows_out.append(r["iterations"])
        print(
            f"{rec['id']:24} {'match' if gap <= MATCH_REL else 'MISS '} gap {gap:+.2e} it {r['iterations']:3d} "
            f"trials {r['trials']:4d} {r['status']:14} | portfolio gap {recorded:+.2e} it {portfolio_iterations} "
            f"({time.perf_counter() - t:.1f} s)",
            flush=True,
        )
    if not rows_out:
        print("no problem selected", file=sys.stderr)
        return 1
    print(
        f"{len(rows_out)} problems: {matches} match, {within} within 5 % (the portfolio's recorded: {portfolio_within}, "
        f"the better of the two: {either_within}); iterations median {int(np.median(rows_out))}, mean {np.mean(rows_out):.1f}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
