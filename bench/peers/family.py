#!/usr/bin/env python3
"""A seeded family of random obstacle problems, solved by ddpkit and by CasADi + IPOPT / FATROP.

    python bench/peers/family.py --problems 60 --seed 1 [--json out.json]
        [--families car,point,unicycle] [--repeats 3] [--write-problems DIR] [--diagnose]

Three families of `bench/problems.md` problems, each generated as a problem-file dict (the form of
`bench/problems/p2_car4.json`) and validated by `problem_file.parse`:

- `car`: P2's car (4 states, 2 controls), start at rest at the origin heading roughly to the
  goal, goal at rest;
- `point`: P3's point robot (double integrator, exact zero-order hold), start and goal at rest;
- `unicycle`: the unicycle of P1 (explicit Euler `x+ = x + dt [v cos th, v sin th, w]`, ddpkit's
  built-in `ddpkit.Unicycle(dt)`) with a goal cost and obstacles.

Every problem: goal 2.5-5 m from the start in a random direction, 1-5 circular obstacles (radius
0.2-0.5) centred between start and goal (10-90 % of the way along, up to 0.4 m to either side),
horizon N in 80..160, dt in 0.05..0.1, and with probability 1/2 a symmetric control box. Cost
`quad_goal` with R = (0.1, 0.1) and Qf = 100 on position, 10 on heading / velocity.

Problem j of a family is drawn from `numpy.random.default_rng([seed, family id, j, attempt])`
(family ids: car 0, point 1, unicycle 2), so a family's problems do not depend on which other
families run. Attempt 0 is tried first; a problem is rejected, and the next attempt drawn, when its
start or goal lies inside an obstacle (or within 0.05 m of one) or when neither peer finds a
feasible solution. Rejections are listed in the output.

Solvers, all from the same zero-control start (every start is at rest, so the zero-control
rollout is `x0` repeated, which is also the CasADi state guess): ddpkit's `SafeCddpSolver` through
`solve.py`'s `DdpkitSolver` (as `compare.py`), and CasADi + IPOPT and CasADi + FATROP through
`compare.py`'s `casadi_entry`. Each solution is re-scored by the numpy definition of
`problem_file.py` (cost, largest violation; feasible when <= 1e-6). Timing: each solver solves once
untimed (CasADi builds its NLP lazily on the first solve), then `--repeats` timed cold solves
(default 3, the same count for ddpkit and each peer), interleaved in one process on the same
problem; each solver's median is used, so that one solve slowed by the machine's load does not
make a problem the "worst" time ratio (the per-solve times are kept in `ms_all`).

ddpkit "matches" a problem when its violation is <= 1e-6 and its cost is at most the better
feasible peer's times (1 + 1e-6). Each miss is classified against that peer's solution, first
match first: ddpkit infeasible; a long detour (ddpkit's path more than twice as long); passing an
obstacle on the other side (the angle swept around some obstacle's centre differs by more than
pi); ending short of the goal (more than 5 cm further from it); or the same side with a higher
cost. `--diagnose` also starts IPOPT from ddpkit's solution where ddpkit misses
(untimed), which tells a local minimum of the problem (IPOPT stays) from an early stop.

casadi is only needed by `main` and `solve_problem`; the generator imports without it.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any, Optional  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from problem_file import FEASIBILITY_TOL, BenchProblem, parse  # noqa: E402

#: Family name -> (id in the seed, model of bench/problems.md).
FAMILIES = {"car": (0, "car"), "point": (1, "point"), "unicycle": (2, "unicycle")}
#: Ranges of the generator.
DISTANCE = (2.5, 5.0)
OBSTACLES = (1, 5)
RADIUS = (0.2, 0.5)
ALONG = (0.1, 0.9)
LATERAL = 0.4
HORIZON = (80, 160)
DT = (0.05, 0.1)
HEADING_NOISE = 0.5
#: Start and goal must be at least this far outside every obstacle.
CLEARANCE = 0.05
#: Attempts per problem before giving up on it.
MAX_ATTEMPTS = 50
#: A miss is a "long detour" when ddpkit's path is longer than this times the peer's.
DETOUR = 2.0
#: A cost gap counts as a match up to this (relative).
MATCH_REL = 1e-6
PEER_LABELS = {"ipopt": "CasADi + IPOPT", "fatrop": "CasADi + FATROP"}


def _r(v: float) -> float:
    """Rounded for a readable problem file (the rounded value is the definition)."""
    return round(float(v), 4)


def generate(family: str, seed: int, index: int, attempt: int = 0) -> dict[str, Any]:
    """Problem `index` of `family` for `seed`, try `attempt`, as a problem-file dict. Pure: the
    same arguments give the same dict. The dict is not checked for start / goal clearance (see
    `geometry_problem`)."""
    fid, model = FAMILIES[family]
    rng = np.random.default_rng([seed, fid, index, attempt])
    n = int(rng.integers(HORIZON[0], HORIZON[1] + 1))
    dt = _r(rng.uniform(*DT))
    dist = rng.uniform(*DISTANCE)
    phi = rng.uniform(-math.pi, math.pi)
    gx, gy = dist * math.cos(phi), dist * math.sin(phi)
    th0 = phi + rng.uniform(-HEADING_NOISE, HEADING_NOISE)
    thg = phi + rng.uniform(-HEADING_NOISE, HEADING_NOISE)
    m = int(rng.integers(OBSTACLES[0], OBSTACLES[1] + 1))
    obstacles = []
    for _ in range(m):
        t = rng.uniform(*ALONG)
        s = rng.uniform(-LATERAL, LATERAL)
        r = rng.uniform(*RADIUS)
        # t of the way from start to goal, s to the left of the line (unit normal (-sin, cos)).
        obstacles.append([_r(t * gx - s * math.sin(phi)), _r(t * gy + s * math.cos(phi)), _r(r)])
    bounded = bool(rng.random() < 0.5)
    if model == "unicycle":
        x0 = [0.0, 0.0, _r(th0)]
        x_goal = [_r(gx), _r(gy), _r(thg)]
        qf = [100.0, 100.0, 10.0]
        bound = [_r(rng.uniform(0.5, 1.5)), _r(rng.uniform(0.5, 1.5))]  # v, omega
    elif model == "car":
        x0 = [0.0, 0.0, _r(th0), 0.0]
        x_goal = [_r(gx), _r(gy), _r(thg), 0.0]
        qf = [100.0, 100.0, 10.0, 10.0]
        bound = [_r(rng.uniform(0.3, 1.0)), _r(rng.uniform(0.3, 1.0))]  # steering rate, acceleration
    else:
        x0 = [0.0, 0.0, 0.0, 0.0]
        x_goal = [_r(gx), _r(gy), 0.0, 0.0]
        qf = [100.0, 100.0, 10.0, 10.0]
        bound = [_r(rng.uniform(0.4, 1.2)), _r(rng.uniform(0.4, 1.2))]  # accelerations
    spec: dict[str, Any] = {
        "name": problem_id(family, seed, index, attempt),
        "model": model,
        "dt": dt,
        "N": n,
        "x0": x0,
        "cost": {"kind": "quad_goal", "x_goal": x_goal, "R": [0.1, 0.1], "Qf": qf},
    }
    if bounded:
        spec["u_min"] = [-b for b in bound]
        spec["u_max"] = bound
    spec["obstacles"] = obstacles
    return spec


def problem_id(family: str, seed: int, index: int, attempt: int) -> str:
    """`family-sSEED-iINDEX-aATTEMPT`: the arguments of `generate`."""
    return f"{family}-s{seed}-i{index}-a{attempt}"


def parse_id(pid: str) -> tuple[str, int, int, int]:
    family, s, i, a = pid.split("-")
    return family, int(s[1:]), int(i[1:]), int(a[1:])


def geometry_problem(p: BenchProblem) -> Optional[str]:
    """Why the problem is rejected before solving (start or goal inside, or within CLEARANCE of,
    an obstacle), or None."""
    assert p.x_goal is not None
    if p.clearance(p.x0[:2]) < CLEARANCE:
        return "start inside an obstacle"
    if p.clearance(p.x_goal[:2]) < CLEARANCE:
        return "goal inside an obstacle"
    return None


def first_valid(family: str, seed: int, index: int, start: int = 0) -> tuple[int, dict[str, Any], list[dict[str, str]]]:
    """The first attempt >= `start` whose geometry is acceptable: `(attempt, spec, rejected)`
    with the rejected attempts' ids and reasons."""
    rejected: list[dict[str, str]] = []
    for attempt in range(start, MAX_ATTEMPTS):
        spec = generate(family, seed, index, attempt)
        why = geometry_problem(parse(spec))
        if why is None:
            return attempt, spec, rejected
        rejected.append({"id": spec["name"], "reason": why})
    raise RuntimeError(f"no acceptable problem for {family} {index} in {MAX_ATTEMPTS} attempts")


# ---- solving ---------------------------------------------------------------------------------------


def winding(xs: np.ndarray, obstacles: np.ndarray) -> np.ndarray:
    """Angle swept around each obstacle's centre by the path x_0 .. x_N (radians, one per
    obstacle): paths on different sides of an obstacle differ by about 2 pi."""
    out = np.empty(len(obstacles))
    for i, (ox, oy, _) in enumerate(obstacles):
        a = np.unwrap(np.arctan2(xs[:, 1] - oy, xs[:, 0] - ox))
        out[i] = a[-1] - a[0]
    return out


def _judge(p: BenchProblem, xs: np.ndarray, us: np.ndarray) -> dict[str, Any]:
    assert p.x_goal is not None
    v = p.violations(xs, us)
    return {
        "cost": p.objective(xs, us),
        "max_violation": max(v.values()),
        "violations": v,
        "feasible": max(v.values()) <= FEASIBILITY_TOL,
        "goal_distance": float(np.hypot(*(xs[-1, :2] - p.x_goal[:2]))),
        "x_final": np.asarray(xs[-1], dtype=float).tolist(),
        "path_length": float(np.sum(np.hypot(*np.diff(xs[:, :2], axis=0).T))),
        "winding": winding(xs, p.obstacles).tolist(),
    }


def solve_problem(
    spec: dict[str, Any],
    repeats: int = 3,
    peers: tuple[str, ...] = ("ipopt", "fatrop"),
    diagnose: bool = False,
    safe_options: Optional[dict[str, Any]] = None,
) -> dict[str, Any]:
    """ddpkit and the CasADi peers on one problem-file dict: per solver the re-scored solution,
    status, iterations and time; then the comparison. With `diagnose`, where ddpkit misses, IPOPT
    is also started from ddpkit's solution (`ipopt_from_ddpkit`). Needs casadi."""
    from compare import casadi_entry, ddpkit_constrained_entries

    p = parse(spec)
    entries = {"ddpkit": ddpkit_constrained_entries(p, methods=("constrained",), safe_options=safe_options)[0]}
    for plugin in peers:
        e = casadi_entry(p, plugin)
        if e is None:
            raise RuntimeError("casadi is not importable (pip install casadi)")
        entries[plugin] = e
    solutions: dict[str, Any] = {}
    errors: dict[str, str] = {}
    for key, e in entries.items():  # untimed: the solution (every solve is cold and deterministic)
        try:
            e.run_once()
            solutions[key] = e.solution
        except Exception as err:  # a peer's crash is recorded, not fatal
            errors[key] = f"{type(err).__name__}: {err}"
        e.wall.clear()
    for _ in range(repeats):  # timed, interleaved
        for key, e in entries.items():
            if key not in errors:
                e.run_once()
    solvers: dict[str, Any] = {}
    for key, e in entries.items():
        if key in errors:
            solvers[key] = {"status": "error", "error": errors[key], "feasible": False}
            continue
        xs, us, status = solutions[key]
        solvers[key] = {
            "status": status,
            "iterations": e.iterations,
            **_judge(p, xs, us),
            "ms": statistics.median(e.wall) * 1e3,
            "ms_all": [w * 1e3 for w in e.wall],
        }
        if key != "ddpkit" and p.u_max is not None:
            solvers[key]["bounds_active"] = bool(np.any(np.abs(us) >= p.u_max - 1e-6))
        if key == "ddpkit":
            # The portfolio's starts (which was kept, each one's iterations and cost).
            solvers[key]["starts"] = e.starts
    record = {"id": spec["name"], "spec": spec, "solvers": solvers, **compare_solutions(p, solvers, peers)}
    if diagnose and not record.get("match", True) and "ddpkit" in solutions and "ipopt" in peers:
        # Where IPOPT goes from ddpkit's solution (untimed): does ddpkit stop at a local minimum?
        e = casadi_entry(p, "ipopt", guess=solutions["ddpkit"][:2])
        assert e is not None
        e.run_once()
        xs, us, status = e.solution
        record["ipopt_from_ddpkit"] = {"status": status, "iterations": e.iterations, **_judge(p, xs, us)}
        record["ipopt_from_ddpkit"]["rel_change"] = (e.cost - solvers["ddpkit"]["cost"]) / abs(solvers["ddpkit"]["cost"])
    return record


def compare_solutions(p: BenchProblem, solvers: dict[str, Any], peers: tuple[str, ...]) -> dict[str, Any]:
    """The better feasible peer, ddpkit's relative cost gap to it, whether ddpkit matches it and,
    when not, the pattern of the miss."""
    feasible = [k for k in peers if solvers[k].get("feasible")]
    out: dict[str, Any] = {"peers_feasible": feasible}
    if not feasible:
        return out
    best = min(feasible, key=lambda k: solvers[k]["cost"])
    d, b = solvers["ddpkit"], solvers[best]
    out["best_peer"] = best
    out["best_peer_cost"] = b["cost"]
    gap = (d["cost"] - b["cost"]) / abs(b["cost"]) if d["status"] != "error" else math.nan
    out["rel_gap"] = gap
    out["match"] = bool(d["feasible"] and gap <= MATCH_REL)
    for k in peers:
        if "ms" in solvers[k] and d.get("ms"):
            out[f"time_ratio_{k}"] = d["ms"] / solvers[k]["ms"]
    out["other_side"] = bool(
        d["status"] != "error" and np.any(np.abs(np.array(d["winding"]) - np.array(b["winding"])) > math.pi)
    )
    if out["match"]:
        out["pattern"] = "match"
    elif d["status"] == "error":
        out["pattern"] = "error"
    elif not d["feasible"]:
        out["pattern"] = "infeasible"
    elif d["path_length"] > DETOUR * b["path_length"]:
        out["pattern"] = "long detour"
    elif out["other_side"]:
        out["pattern"] = "other side of an obstacle"
    elif d["goal_distance"] > b["goal_distance"] + 0.05:
        out["pattern"] = "ends short of the goal"
    else:
        out["pattern"] = "same side, higher cost"
    if not out["match"] and d["status"] not in ("converged", "error", "infeasible"):
        out["pattern"] += f" ({d['status']})"
    if out["match"] and gap < -MATCH_REL:  # ddpkit lower: why the peers are higher
        if out["other_side"]:
            out["peer_pattern"] = "peers pass an obstacle on the other side"
        elif b["goal_distance"] > d["goal_distance"] + 0.05:
            out["peer_pattern"] = "peers end short of the goal"
        else:
            out["peer_pattern"] = "peers same side, higher cost"
    return out


# ---- the summary ------------------------------------------------------------------------------------


def _quantile(values: list[float], q: float) -> float:
    return float(np.quantile(np.array(values), q)) if values else math.nan


def _geomean(values: list[float]) -> float:
    return float(np.exp(np.mean(np.log(values)))) if values else math.nan


def summarise(records: list[dict[str, Any]], peers: tuple[str, ...]) -> dict[str, Any]:
    """Fractions, gap distribution and time ratios of a list of accepted problems."""
    gaps = [r["rel_gap"] for r in records if r["solvers"]["ddpkit"].get("feasible")]
    out: dict[str, Any] = {
        "problems": len(records),
        "match": sum(r["match"] for r in records),
        "match_fraction": sum(r["match"] for r in records) / len(records) if records else math.nan,
        "ddpkit_infeasible": sum(not r["solvers"]["ddpkit"].get("feasible") for r in records),
        "ddpkit_not_converged": sum(r["solvers"]["ddpkit"]["status"] != "converged" for r in records),
        "gap_median": _quantile(gaps, 0.5),
        "gap_p90": _quantile(gaps, 0.9),
        "gap_worst": max(gaps) if gaps else math.nan,
        "gap_best": min(gaps) if gaps else math.nan,
        "ddpkit_lower": sum(r["match"] and r["rel_gap"] < -MATCH_REL for r in records),
    }
    lower: dict[str, int] = {}
    for r in records:
        if "peer_pattern" in r:
            lower[r["peer_pattern"]] = lower.get(r["peer_pattern"], 0) + 1
    out["ddpkit_lower_why"] = lower
    for k in peers:
        ratios = [r[f"time_ratio_{k}"] for r in records if f"time_ratio_{k}" in r]
        out[f"time_ratio_{k}_geomean"] = _geomean(ratios)
        out[f"time_ratio_{k}_worst"] = max(ratios) if ratios else math.nan
        out[f"{k}_feasible"] = sum(r["solvers"][k].get("feasible", False) for r in records)
    patterns: dict[str, int] = {}
    for r in records:
        patterns[r["pattern"]] = patterns.get(r["pattern"], 0) + 1
    out["patterns"] = patterns
    out["kept_start"], out["iterations_by_start"] = start_counts(records)
    return out


def start_counts(records: list[dict[str, Any]]) -> tuple[dict[str, int], dict[str, int]]:
    """Which of the portfolio's starts ddpkit's solutions came from, and the iterations of
    each start, by start name."""
    kept: dict[str, int] = {}
    iterations: dict[str, int] = {}
    for r in records:
        for st in r["solvers"]["ddpkit"].get("starts", []):
            name = start_name(st)
            iterations[name] = iterations.get(name, 0) + st["iterations"]
            if st["outcome"] == "kept":
                kept[name] = kept.get(name, 0) + 1
    return kept, iterations


def start_name(st: dict[str, Any]) -> str:
    """A portfolio start's name: its warm-up, the third start's barrier weight, `flip` for the
    starts steered to a binding obstacle's far side (`portfolio_flip`), `mirror` for the one
    steered to the far side of every obstacle (`portfolio_mirror`), or `plan` for the ones steered
    round them on the sides of their shortest path (`portfolio_plan`)."""
    if st.get("flip") is not None:
        return "flip"
    if st.get("mirror"):
        return "mirror"
    if st.get("plan"):
        return "plan"
    mu = st.get("barrier_mu_init")
    return st["warm_up"] if mu is None else f"{st['warm_up']} (mu_init {mu:g})"


#: Histogram bins of the signed relative gap (ddpkit - better peer) / better peer.
BINS = [
    (-math.inf, -1e-3, "< -1e-3"),
    (-1e-3, -1e-6, "[-1e-3, -1e-6)"),
    (-1e-6, 1e-6, "[-1e-6, 1e-6]"),
    (1e-6, 1e-4, "(1e-6, 1e-4]"),
    (1e-4, 1e-3, "(1e-4, 1e-3]"),
    (1e-3, 1e-2, "(1e-3, 1e-2]"),
    (1e-2, 1e-1, "(1e-2, 0.1]"),
    (1e-1, math.inf, "> 0.1"),
]


def histogram(gaps: list[float]) -> list[tuple[str, int]]:
    counts = []
    for lo, hi, label in BINS:
        if lo == -1e-6:
            c = sum(lo <= g <= hi for g in gaps)
        elif hi <= -1e-6:
            c = sum(lo <= g < hi for g in gaps)
        else:
            c = sum(lo < g <= hi for g in gaps)
        counts.append((label, c))
    return counts


def print_summary(
    records: list[dict[str, Any]], families: list[str], peers: tuple[str, ...], rejected: list[dict[str, str]], repeats: int
) -> dict[str, Any]:
    groups = {"all": records, **{f: [r for r in records if r["family"] == f] for f in families}}
    summaries = {name: summarise(rs, peers) for name, rs in groups.items() if rs}
    print(
        f"ddpkit SafeCddpSolver vs CasADi + {' / '.join(p.upper() for p in peers)} on {len(records)} problems "
        f"(zero-control start; times: median of {repeats} cold solve(s))"
    )
    print(f"match: ddpkit violation <= {FEASIBILITY_TOL:g} and cost <= better feasible peer's x (1 + {MATCH_REL:g})")
    print("gap: (ddpkit cost - better peer cost) / better peer cost, over problems where ddpkit is feasible")
    head = f"{'family':<9} {'n':>3} {'match':>11} {'infeas':>6} {'gap median':>11} {'gap p90':>10} {'gap worst':>10}"
    for k in peers:
        head += f" {'t/' + k.upper() + ' gm':>12} {'worst':>7}"
    print(head)
    print("-" * len(head))
    for name, s in summaries.items():
        line = (
            f"{name:<9} {s['problems']:>3} {s['match']:>3} ({s['match_fraction']:>5.1%}) {s['ddpkit_infeasible']:>6} "
            f"{s['gap_median']:>11.2e} {s['gap_p90']:>10.2e} {s['gap_worst']:>10.2e}"
        )
        for k in peers:
            line += f" {s[f'time_ratio_{k}_geomean']:>12.4f} {s[f'time_ratio_{k}_worst']:>7.3f}"
        print(line)
    gaps = [r["rel_gap"] for r in records if r["solvers"]["ddpkit"].get("feasible")]
    print()
    print("relative cost gap histogram (ddpkit feasible):")
    counts = histogram(gaps)
    scale = max(1.0, max(c for _, c in counts) / 60.0)  # bars at most 60 wide
    for label, c in counts:
        print(f"  {label:>15} {c:>4} {'#' * math.ceil(c / scale)}")
    print()
    print("peers feasible: " + ", ".join(f"{k.upper()} {summaries['all'][f'{k}_feasible']}/{len(records)}" for k in peers)
          if records else "no problems")
    if records:
        s = summaries["all"]
        print(
            f"ddpkit lower than the better peer by more than {MATCH_REL:g}: {s['ddpkit_lower']}"
            + "".join(f", {v} {k}" for k, v in sorted(s["ddpkit_lower_why"].items()))
        )
    print("outcomes: " + ", ".join(f"{k} {v}" for k, v in sorted(summaries["all"]["patterns"].items())) if records else "")
    if records and summaries["all"]["iterations_by_start"]:
        s = summaries["all"]
        print("portfolio start kept: " + ", ".join(f"{k} {v}" for k, v in sorted(s["kept_start"].items())))
        print("portfolio iterations by start: " + ", ".join(f"{k} {v}" for k, v in sorted(s["iterations_by_start"].items())))
    misses = [r for r in records if not r["match"]]
    if misses:
        print("ddpkit misses:")
        for r in misses:
            d = r["solvers"]["ddpkit"]
            print(
                f"  {r['id']:<24} {r['pattern']:<32} gap {r['rel_gap']:>9.2e} viol {d.get('max_violation', math.nan):.1e} "
                f"status {d['status']} it {d.get('iterations')} goal dist {d.get('goal_distance', math.nan):.3f} "
                f"(peer {r['solvers'][r['best_peer']]['goal_distance']:.3f})"
                + (
                    f"; IPOPT from ddpkit's solution: {r['ipopt_from_ddpkit']['rel_change']:+.1e} in "
                    f"{r['ipopt_from_ddpkit']['iterations']} it"
                    if "ipopt_from_ddpkit" in r
                    else ""
                )
            )
    print()
    if rejected:
        by_reason: dict[str, list[str]] = {}
        for rj in rejected:
            by_reason.setdefault(rj["reason"], []).append(rj["id"])
        print(f"rejected and regenerated: {len(rejected)}")
        for reason, ids in by_reason.items():
            print(f"  {reason}: {len(ids)} ({', '.join(ids)})")
    else:
        print("rejected and regenerated: none")
    return summaries


def build_parser() -> argparse.ArgumentParser:
    """The command line of `main`."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--problems", type=int, required=True, help="accepted problems in all, split evenly over the families")
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--json", type=Path, help="write every problem's spec, costs, violations, times and statuses here")
    ap.add_argument("--families", default="car,point,unicycle", help="comma-separated subset of car,point,unicycle")
    ap.add_argument(
        "--repeats",
        type=int,
        default=3,
        help="timed cold solves per solver and problem, median kept (default 3, for ddpkit and the peers alike)",
    )
    ap.add_argument("--write-problems", type=Path, help="also write each accepted problem file here")
    ap.add_argument(
        "--diagnose", action="store_true", help="where ddpkit misses, also start IPOPT from ddpkit's solution (untimed)"
    )
    from solve import add_safe_arguments

    add_safe_arguments(ap)
    return ap


def main(argv: Optional[list[str]] = None) -> int:
    ap = build_parser()
    args = ap.parse_args(argv)
    families = [f.strip() for f in args.families.split(",") if f.strip()]
    for f in families:
        if f not in FAMILIES:
            ap.error(f"unknown family {f!r} (car, point, unicycle)")
    if args.problems < 1 or args.repeats < 1:
        ap.error("--problems and --repeats must be >= 1")
    try:
        import casadi

        peers = tuple(k for k in ("ipopt", "fatrop") if casadi.has_nlpsol(k))
    except ImportError:
        print("error: casadi is needed for the benchmark (pip install casadi)", file=sys.stderr)
        return 2
    for k in ("ipopt", "fatrop"):
        if k not in peers:
            print(f"note: this casadi has no {k} plugin; running without it", file=sys.stderr)
    if not peers:
        return 2

    from solve import safe_options_of

    safe_options = safe_options_of(args)
    per = {f: args.problems // len(families) + (i < args.problems % len(families)) for i, f in enumerate(families)}
    order = [(j, f) for j in range(max(per.values())) for f in families if j < per[f]]
    records: list[dict[str, Any]] = []
    rejected: list[dict[str, str]] = []
    interrupted = False
    t_start = time.perf_counter()
    try:
        for n_done, (j, f) in enumerate(order, 1):
            attempt = 0
            while True:
                attempt, spec, rej = first_valid(f, args.seed, j, attempt)
                rejected += rej
                rec = solve_problem(spec, repeats=args.repeats, peers=peers, diagnose=args.diagnose, safe_options=safe_options)
                if rec["peers_feasible"]:
                    break
                rejected.append({"id": spec["name"], "reason": "no peer feasible"})
                print(f"  {spec['name']}: no peer feasible, regenerating", file=sys.stderr)
                attempt += 1
            rec["family"] = f
            records.append(rec)
            d = rec["solvers"]["ddpkit"]
            print(
                f"[{n_done}/{len(order)} {time.perf_counter() - t_start:6.1f} s] {rec['id']:<22} N={spec['N']:<3} "
                f"obst={len(spec['obstacles'])} box={'u_max' in spec!s:<5} ddpkit {d['status']:<14} "
                f"gap {rec['rel_gap']:>9.2e} viol {d.get('max_violation', math.nan):.1e} {rec['pattern']}",
                file=sys.stderr,
            )
    except KeyboardInterrupt:
        interrupted = True
        print(f"interrupted: summarising the {len(records)} problems done", file=sys.stderr)

    summaries = print_summary(records, families, peers, rejected, args.repeats)
    if args.write_problems is not None:
        args.write_problems.mkdir(parents=True, exist_ok=True)
        for r in records:
            (args.write_problems / f"{r['id']}.json").write_text(json.dumps(r["spec"], indent=1) + "\n")
    if args.json is not None:
        payload = {
            "command": " ".join(["bench/peers/family.py", *(argv if argv is not None else sys.argv[1:])]),
            "seed": args.seed,
            "families": families,
            "repeats": args.repeats,
            "safe_options": safe_options,
            "peers": list(peers),
            "casadi": getattr(casadi, "__version__", "?"),
            "python": sys.version.split()[0],
            "interrupted": interrupted,
            "wall_seconds": time.perf_counter() - t_start,
            "summary": summaries,
            "rejected": rejected,
            "problems": records,
        }
        args.json.parent.mkdir(parents=True, exist_ok=True)
        tmp = args.json.with_name(args.json.name + ".tmp")
        tmp.write_text(json.dumps(payload, indent=1) + "\n")
        tmp.replace(args.json)  # complete or absent
    return 130 if interrupted else 0


if __name__ == "__main__":
    sys.exit(main())
