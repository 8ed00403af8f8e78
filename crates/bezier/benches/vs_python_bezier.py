#!/usr/bin/env python3
"""Time the PyPI `bezier` package's arc length on the cubic our Rust timing uses, and compare.

Usage:
    python3 crates/bezier/benches/vs_python_bezier.py [--rust CMD] [--accuracy A]

CMD is a command that prints `arclen_ns=<ns per call> ...` (default:
`cargo run --release -q -p bezier --example arclen_timing -- <A>`); pass `--rust none` to time
Python only. Later the same script can time our Python binding the same way.
Needs `pip install bezier numpy`.

The headline ratio is per call on the same cubic: Python's `.length` on a pre-built `Curve`
(its QUADPACK call, no construction) against one Rust `arclen(A)`, and both errors against the
Rust `1e-14` reference are printed, so the ratio is only claimed where Rust's error is not larger.
"""
import argparse
import re
import shlex
import subprocess
import sys
import timeit

CUBIC = [(0.0, 0.0), (0.3, 0.9), (0.7, 0.9), (1.0, 0.0)]


def time_python_bezier():
    try:
        import bezier  # the PyPI package
        import numpy as np
    except ImportError as e:  # pragma: no cover - environment dependent
        sys.exit(f"needs the PyPI packages bezier and numpy: {e}")
    nodes = np.asfortranarray(np.array(CUBIC).T)
    curve = bezier.Curve(nodes, degree=3)
    length = curve.length
    number = 2000
    best = min(timeit.repeat(lambda: bezier.Curve(nodes, degree=3).length, number=number, repeat=7)) / number
    prebuilt = min(timeit.repeat(lambda: curve.length, number=number, repeat=7)) / number
    print(f"python bezier: {prebuilt * 1e9:,.0f} ns per .length on a pre-built Curve")
    return best * 1e9, prebuilt * 1e9, length, bezier.__version__


def time_rust(cmd):
    out = subprocess.run(cmd, shell=True, check=True, capture_output=True, text=True).stdout
    m = re.search(r"arclen_ns=([0-9.eE+-]+)", out)
    if not m:
        sys.exit(f"no arclen_ns=... in the output of {cmd!r}:\n{out}")
    inv = re.search(r"inv_arclen_ns=([0-9.eE+-]+)", out)
    length = re.search(r" length=([0-9.eE+-]+)", out)
    value = re.search(r"value=([0-9.eE+-]+)", out)
    num = lambda g: float(g.group(1)) if g else None
    return float(m.group(1)), num(inv), num(length), num(value)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rust", default=None, help="command printing arclen_ns=...; 'none' to skip")
    ap.add_argument("--accuracy", type=float, default=1e-10)
    args = ap.parse_args()
    py_ns, py_prebuilt_ns, py_len, version = time_python_bezier()
    print(f"python bezier {version}: length={py_len:.15f}  {py_ns:,.0f} ns per Curve(...).length")
    if args.rust == "none":
        return
    cmd = args.rust or (
        "cargo run --release -q -p bezier --example arclen_timing -- " + shlex.quote(repr(args.accuracy))
    )
    rs_ns, inv_ns, rs_len, rs_value = time_rust(cmd)
    print(f"rust bezier (accuracy {args.accuracy:g}): length={rs_len:.15f}  {rs_ns:,.1f} ns per arclen"
          + (f", {inv_ns:,.1f} ns per inv_arclen" if inv_ns is not None else ""))
    if rs_len is not None:
        py_err = abs(py_len - rs_len)
        print(f"error against the 1e-14 reference: python {py_err:.2e}"
              + (f", rust {abs(rs_value - rs_len):.2e}" if rs_value is not None else ""))
        if rs_value is not None and abs(rs_value - rs_len) > max(py_err, 1e-15):
            print("note: rust is less accurate here than python; lower --accuracy for an equal-accuracy ratio")
    print(f"speed ratio per call (python pre-built .length / rust arclen): {py_prebuilt_ns / rs_ns:,.0f}x")
    print(f"speed ratio incl. construction (python Curve(...).length / rust): {py_ns / rs_ns:,.0f}x")


if __name__ == "__main__":
    main()
