#!/usr/bin/env python3
"""Arc length (and evaluation) through ddpkit's Python binding vs the PyPI ``bezier`` package.

Usage::

    python py/benches/bezier_vs_python.py [--accuracy A] [--batch M] [--json PATH]

Needs the ddpkit wheel and ``pip install bezier numpy mpmath``. Times, best of 7 repeats:

- one call on the cubic of ``crates/bezier/benches/vs_python_bezier.py``, on a pre-built curve
  (``ddpkit.bezier.Bezier.arclen`` vs ``bezier.Curve.length``) and including the construction
  from a numpy array;
- a batch of ``M`` curves: ``ddpkit.bezier.arclen_batch`` (one call) vs a Python loop over
  ``bezier.Curve(...).length`` (the package has no batch API), on the same cubic repeated and on
  ``M`` varied smooth cubics (Catmull-Rom segments of a random walk);
- inverse arc length, which the package lacks: its user's way is Newton on ``t`` with
  ``Curve.specialize(0, t).length`` and ``Curve.evaluate_hodograph`` (to ``--accuracy`` in
  length), against ``Bezier.inv_arclen`` for one ``s`` and for 1000 values of ``s`` in one call;
- evaluation at 1000 parameters (``Bezier.eval`` vs ``Curve.evaluate_multi``).

The batch rows go through ``CubicBez::arclen_batch`` on one thread; ``ddpkit.bezier.simd_level()``
(printed) says which sums ran (``avx512``, ``avx2+fma`` or ``portable``; ``DDPKIT_SIMD=avx2`` or
``off`` narrows it).

Accuracy: the PyPI package integrates ``|B'(s)|`` with QUADPACK to near machine precision; its
error and ours are measured against a 30-digit mpmath reference and printed, and ddpkit runs at
``--accuracy`` (absolute, default ``1e-12``, tighter than needed to match) and at ``1e-10``.
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import timeit
from typing import Any, Callable

import numpy as np

CUBIC = np.array([[0.0, 0.0], [0.3, 0.9], [0.7, 0.9], [1.0, 0.0]])


def best(f: Callable[[], object], number: int, repeat: int = 7) -> float:
    """Best time per call of ``f`` in seconds."""
    return min(timeit.repeat(f, number=number, repeat=repeat)) / number


def smooth_cubics(m: int, seed: int = 0) -> np.ndarray:
    """``m`` spline-like cubics, shape ``(m, 4, 2)``: Catmull-Rom segments of a random walk."""
    from ddpkit import bezier as ours

    rng = np.random.default_rng(seed)
    heading = np.cumsum(rng.uniform(-0.9, 0.9, m + 1))
    steps = rng.uniform(0.5, 1.5, m + 1)
    walk = np.concatenate([[[0.0, 0.0]], np.cumsum(steps[:, None] * np.stack([np.cos(heading), np.sin(heading)], 1), 0)])
    return ours.Spline.catmull_rom(walk).segments[:m]


def pypi_inv_arclen(curve: Any, total: float, s: float, tol: float) -> float:
    """``t`` with ``length(0, t) = s`` to ``tol`` in length, by the PyPI package's own pieces:
    Newton on ``t`` with ``specialize(0, t).length`` and ``|evaluate_hodograph(t)|``."""
    t = s / total
    for _ in range(60):
        f = curve.specialize(0.0, t).length - s
        if abs(f) <= tol:
            break
        speed = float(np.hypot(*curve.evaluate_hodograph(t)[:, 0]))
        t = min(max(t - f / speed, 0.0), 1.0)
    return t


def reference_length(points: np.ndarray) -> float:
    import mpmath

    mpmath.mp.dps = 30
    p = [[mpmath.mpf(float(v)) for v in row] for row in points]

    def speed(t: Any) -> Any:
        dx = 3 * ((1 - t) ** 2 * (p[1][0] - p[0][0]) + 2 * (1 - t) * t * (p[2][0] - p[1][0]) + t**2 * (p[3][0] - p[2][0]))
        dy = 3 * ((1 - t) ** 2 * (p[1][1] - p[0][1]) + 2 * (1 - t) * t * (p[2][1] - p[1][1]) + t**2 * (p[3][1] - p[2][1]))
        return mpmath.sqrt(dx * dx + dy * dy)

    return float(mpmath.quad(speed, [0, 0.5, 1]))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--accuracy", type=float, default=1e-12)
    ap.add_argument("--batch", type=int, default=10_000)
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args()
    try:
        import bezier as pypi  # the PyPI package
    except ImportError as e:
        sys.exit(f"needs the PyPI package bezier: {e}")
    from ddpkit import bezier as ours

    acc = args.accuracy
    nodes = np.asfortranarray(CUBIC.T)
    curve = pypi.Curve(nodes, degree=3)
    mine = ours.Bezier(CUBIC)
    ref = reference_length(CUBIC)
    rows: list[tuple[str, float, float]] = []
    results: dict[str, Any] = {
        "accuracy": acc,
        "pypi_bezier": pypi.__version__,
        "pypi_speedup": bool(getattr(pypi, "_HAS_SPEEDUP", False)),
        "python": platform.python_version(),
        "machine": platform.machine(),
        "errors": {
            "pypi": abs(curve.length - ref),
            f"ddpkit@{acc:g}": abs(mine.arclen(acc) - ref),
            "ddpkit@1e-10": abs(mine.arclen(1e-10) - ref),
        },
    }

    # One call.
    n = 20_000
    t_pypi = best(lambda: curve.length, n)
    t_pypi_new = best(lambda: pypi.Curve(nodes, degree=3).length, n // 4)
    t_mine = best(lambda: mine.arclen(acc), n)
    t_mine_10 = best(lambda: mine.arclen(1e-10), n)
    t_mine_new = best(lambda: ours.Bezier(CUBIC).arclen(acc), n // 4)
    rows += [
        ("one call, pre-built curve", t_pypi, t_mine),
        ("one call, pre-built curve (ddpkit at 1e-10)", t_pypi, t_mine_10),
        ("one call, built from a numpy array", t_pypi_new, t_mine_new),
    ]

    # Batches.
    m = args.batch
    same = np.broadcast_to(CUBIC, (m, 4, 2)).copy()
    varied = smooth_cubics(m)
    for label, pts in (("same cubic", same), ("varied smooth cubics", varied)):
        fortran = [np.asfortranarray(c.T) for c in pts]
        t_py = best(lambda: [pypi.Curve(c, degree=3).length for c in fortran], 1, repeat=3) / m
        t_rs = best(lambda: ours.arclen_batch(pts, acc), 1, repeat=7) / m
        rows.append((f"batch of {m} ({label}), per curve", t_py, t_rs))
        got = ours.arclen_batch(pts, acc)
        want = np.array([pypi.Curve(c, degree=3).length for c in fortran[:200]])
        results["errors"][f"batch {label}: max |ddpkit - pypi| (200 curves)"] = float(np.max(np.abs(got[:200] - want)))

    # Inverse arc length (the package has none: Newton over its pieces).
    total = curve.length
    s_one = 0.37 * total
    s_many = np.linspace(0.0, total, 1000)
    t_pypi_inv = best(lambda: pypi_inv_arclen(curve, total, s_one, acc), 2000, repeat=5)
    t_mine_inv = best(lambda: mine.inv_arclen(s_one, acc), 20_000)
    t_pypi_inv_many = best(lambda: [pypi_inv_arclen(curve, total, x, acc) for x in s_many], 1, repeat=3) / len(s_many)
    t_mine_inv_many = best(lambda: mine.inv_arclen(s_many, acc), 20) / len(s_many)
    rows += [
        ("inverse arc length, one s", t_pypi_inv, t_mine_inv),
        (f"inverse arc length, {len(s_many)} s in one call, per s", t_pypi_inv_many, t_mine_inv_many),
    ]
    results["errors"]["inverse: max |t_ddpkit - t_pypi| (1000 s)"] = float(
        np.max(np.abs(mine.inv_arclen(s_many, acc) - np.array([pypi_inv_arclen(curve, total, x, acc) for x in s_many])))
    )

    # Evaluation at 1000 parameters.
    s = np.linspace(0.0, 1.0, 1000)
    rows.append(("eval at 1000 parameters", best(lambda: curve.evaluate_multi(s), 2000), best(lambda: mine.eval(s), 2000)))

    results["ddpkit_simd"] = ours.simd_level()
    print(
        f"PyPI bezier {pypi.__version__} (speedup: {results['pypi_speedup']}) vs ddpkit.bezier "
        f"(sums: {results['ddpkit_simd']}), accuracy {acc:g}, one thread"
    )
    print(f"length errors vs a 30-digit reference: " + ", ".join(f"{k} {v:.1e}" for k, v in results["errors"].items()))
    print()
    print("| operation | PyPI bezier | ddpkit | ratio |")
    print("|---|---:|---:|---:|")
    results["rows"] = []
    for label, a, b in rows:
        print(f"| {label} | {a * 1e9:,.0f} ns | {b * 1e9:,.0f} ns | {a / b:,.1f}x |")
        results["rows"].append({"operation": label, "pypi_ns": a * 1e9, "ddpkit_ns": b * 1e9, "ratio": a / b})
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(results, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
