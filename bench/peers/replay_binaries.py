"""Times two builds of the `family_replay` example against each other on family files.

A change that should leave every iterate as it was (a kernel, a copy, a stall) is judged by
time alone: both binaries replay the same files alternately (base, new, base, new, ...), each
problem timed as the fastest of `--repeats` solves, and the script reports the geometric mean of
the per-problem time ratios new / base and checks that both binaries printed the same outcome
(match, gap, violation, iterations, status) for every problem.

    cargo build --release -p safe-cddp --example family_replay
    cp target/release/examples/family_replay /tmp/base_replay   # before the change
    ...                                                        # change, build again
    python bench/peers/replay_binaries.py /tmp/base_replay target/release/examples/family_replay \
        bench/results/family_s1_210.json bench/results/family_s2_210.json
"""

from __future__ import annotations

import argparse
import math
import os
import re
import subprocess
import sys

LINE = re.compile(r"^(\S+)\s+(match|MISS )\s+(gap \S+ viol \S+ it\s+\d+\s+\S+)\s+t/IPOPT (\S+)$")


def replay(binary: str, path: str, repeats: int) -> dict[str, tuple[str, float]]:
    """Per problem id: (the outcome text, time / IPOPT) from one run of `binary` on `path`."""
    env = dict(os.environ, REPEATS=str(repeats))
    out = subprocess.run([binary, path], env=env, capture_output=True, text=True, check=True).stdout
    rows = {}
    for line in out.splitlines():
        m = LINE.match(line.strip())
        if m:
            rows[m.group(1)] = (m.group(2) + " " + m.group(3), float(m.group(4)))
    if not rows:
        raise SystemExit(f"{binary} printed no problem lines for {path}")
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("base", help="family_replay built before the change")
    ap.add_argument("new", help="family_replay built after the change")
    ap.add_argument("files", nargs="+", help="family.py --json files")
    ap.add_argument("--repeats", type=int, default=3, help="solves per problem, the fastest timed (default 3)")
    ap.add_argument("--rounds", type=int, default=2, help="alternating rounds over the files (default 2)")
    args = ap.parse_args()
    if args.repeats < 1 or args.rounds < 1:
        ap.error("--repeats and --rounds must be at least 1")
    log_sum, pairs, differ = 0.0, 0, []
    matches = {"base": 0, "new": 0}
    for r in range(args.rounds):
        for path in args.files:
            base = replay(args.base, path, args.repeats)
            new = replay(args.new, path, args.repeats)
            if base.keys() != new.keys():
                raise SystemExit(f"{path}: the two binaries replayed different problems")
            for pid, (outcome, t) in base.items():
                if r == 0:
                    matches["base"] += outcome.startswith("match")
                    matches["new"] += new[pid][0].startswith("match")
                if new[pid][0] != outcome:
                    differ.append(f"{pid}: base {outcome} / new {new[pid][0]}")
                log_sum += math.log(new[pid][1] / t)
                pairs += 1
            print(f"round {r + 1} {path}: done", file=sys.stderr)
    print(f"new / base time per problem, geometric mean: {math.exp(log_sum / pairs):.4f} over {pairs} pairs")
    print(f"matches: base {matches['base']}, new {matches['new']} (first round)")
    if differ:
        print(f"{len(differ)} outcomes differ (iterates changed):")
        for d in differ[:20]:
            print("  " + d)
    else:
        print("every outcome the same (match, gap, violation, iterations, status)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
