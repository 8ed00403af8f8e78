"""``python -m ddpkit.experiments EXPERIMENT [options]``: run an experiment's tasks on an executor.

Examples::

    python -m ddpkit.experiments safe-table --episodes 100 --seed 1 --out out/table
    python -m ddpkit.experiments safe-table --executor processes --workers 8 --out out/table
    python -m ddpkit.experiments safe-table --executor ray --address auto --episodes 1000 --out out/table
    python -m ddpkit.experiments ddpen-table --executor processes --runs 5 --scenarios scenarios --out out/ddpen-table
    python -m ddpkit.experiments trap-bench --executor processes --maps 50 --out out/trap-bench
    python -m ddpkit.experiments safe-turtlebot --executor processes --runs 100 --seed 1 --out out/turtlebot

Rerunning the same command resumes: finished tasks are read from ``OUT/tasks`` and not run again.
Exit status: 0 when every task finished and the outputs were written, 1 when some task failed
(listed in ``OUT/failed.json``; a rerun retries them), 2 for bad arguments (an unknown experiment
or executor, a missing ``ray``, an unreachable ``--address``, a bad configuration).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any, Callable, Optional

from ddpkit.experiments import EXECUTORS, EXPERIMENTS, ExperimentError, run_sweep


def _floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


def _names(text: str) -> list[str]:
    return [v.strip() for v in text.split(",") if v.strip()]


#: Per experiment: (flag, configuration field, type, help). ``--seed`` is common to all.
OPTIONS: dict[str, list[tuple[str, str, Callable[[str], Any], str]]] = {
    "safe-table": [
        ("--episodes", "episodes", int, "episodes per robot and beta (default 100)"),
        ("--robots", "robots", _names, "comma-separated subset of point,car,quadrotor"),
        ("--betas", "betas", _floats, "comma-separated betas (default 0.5,0.9,0.95,0.99)"),
        ("--noise-point", "noise_point", float, "noise scale of the point robot (m per step)"),
        ("--noise-car", "noise_car", float, "noise scale of the car (m per step)"),
        ("--noise-quadrotor", "noise_quadrotor", float, "noise scale of the quadrotor (m per step)"),
    ],
    "subgoal-dataset": [
        ("--samples", "samples", int, "number of samples"),
        ("--shard-size", "shard_size", int, "samples per shard (default 5000)"),
        ("--trap-probability", "params.trap_probability", float, "probability of a U or L trap across the line to the goal"),
    ],
    "idnp": [
        ("--n", "n", int, "number of initial conditions (default 200)"),
        ("--iterations", "iterations", int, "iterations of the IDNP loop per case (default 15)"),
        ("--optimizer-iterations", "optimizer_iterations", int, "iterations of the NLP alone (default 400)"),
    ],
    "ddpen-table": [
        ("--scenarios", "scenarios", os.path.abspath, "folder with the scenario files (default ./scenarios)"),
        ("--sets", "sets", _names, "comma-separated obstacle sets (default free,cylinders,cubes_without_minima,cubes_with_minima)"),
        ("--planners", "planners", _names, "comma-separated planners: ddp, ddp-astar, ddpen, ddpen-oracle (default ddp,ddpen)"),
        ("--runs", "runs", int, "runs per set, planner and direction (default 5)"),
    ],
    "trap-bench": [
        ("--types", "types", _names, "comma-separated trap types: u, l, cubes, cylinders (default all)"),
        ("--maps", "maps", int, "maps per trap type (default 50)"),
        ("--planners", "planners", _names, "comma-separated planners (default ddp,ddp-astar,ddpen,ddpen-oracle)"),
        ("--route-length", "route_length", float, "route length of every map in m (default 22)"),
        ("--stall-time", "stall_time", float, "a run fails after this many simulated seconds without progress (default 30)"),
        ("--max-time", "max_time", float, "a run is stopped after this much simulated time in s (default 120)"),
        ("--png", "png", int, "draw a PNG of the first this many maps of each type (default 2)"),
    ],
    "safe-turtlebot": [
        ("--runs", "runs", int, "episodes per controller (default 100)"),
        ("--beta", "beta", float, "Safe-CDDP's satisfaction probability (default 0.8)"),
        ("--robot", "robot", str, "waffle-pi (the paper's, default) or burger"),
        ("--sigma-xy", "sigma_xy", float, "localisation noise on x and y (m)"),
        ("--sigma-theta", "sigma_theta", float, "localisation noise on the heading (rad)"),
        ("--sigma-w-xy", "sigma_w_xy", float, "process noise per step the tightening assumes on x and y (m)"),
    ],
}

#: The planner options of the sim2d binaries (`sim2d::cli::PlannerArgs`), for both of them.
_PLANNER_OPTIONS: list[tuple[str, str, Callable[[str], Any], str]] = [
    ("--horizon", "options.horizon", int, "planner horizon N (knots of 0.1 s)"),
    ("--model", "options.model", os.path.abspath, "sub-goal model weights for ddpen (default: the shipped model)"),
    ("--w-subgoal", "options.w_subgoal", float, "weight w_s of each sub-goal's distance (eq. 9)"),
    ("--subgoal-every", "options.subgoal_every", int, "new sub-goals every this many planning cycles"),
    ("--w-contact", "options.w_contact", float, "weight of the quadratic contact wall (0: the paper's cost alone)"),
]
OPTIONS["ddpen-table"] += _PLANNER_OPTIONS
OPTIONS["trap-bench"] += _PLANNER_OPTIONS

#: Boolean switches: (flag, field, value when given, help).
SWITCHES: dict[str, list[tuple[str, str, bool, str]]] = {
    "safe-table": [("--no-baselines", "baselines", False, "skip the car's fixed-gain and open-loop baselines")],
    "idnp": [
        ("--uniform", "uniform", True, "also run fixed-grid IDNP on the uniform grid that resolves the passage"),
        ("--no-max-level-penalty", "no_max_level_penalty", True, "pure Algorithm 1: no penalty adaptation at the deepest level"),
    ],
    "ddpen-table": [
        ("--no-png", "png", False, "draw no PNG figures"),
        ("--no-governor", "options.no_governor", True, "send the plans' speeds without the braking-distance cap"),
    ],
    "trap-bench": [("--no-governor", "options.no_governor", True, "send the plans' speeds without the braking-distance cap")],
    "safe-turtlebot": [("--paths", "paths", True, "include every trajectory (poses, commands) in the JSON")],
}


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m ddpkit.experiments", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="experiment", metavar="EXPERIMENT", required=True)
    for name, exp in EXPERIMENTS.items():
        q = sub.add_parser(name, help=exp.about, description=f"{exp.about}. Mirrors the binary `{exp.binary}`.")
        q.add_argument("--executor", default="sequential", help=f"one of {', '.join(EXECUTORS)} (default sequential)")
        q.add_argument("--workers", type=int, default=None, help="processes (default: all cores), or CPUs of a private local Ray cluster")
        q.add_argument("--address", default=None, help="Ray cluster: auto, host:port or ray://host:port (default: a private local cluster)")
        q.add_argument("--seed", type=int, default=None, help="base seed (default: the binary's)")
        q.add_argument("--out", default=f"out/{name}", help="output directory: the binary's files and the task store")
        q.add_argument("--config", default=None, help="more configuration fields as a JSON object")
        q.add_argument("--no-progress", action="store_true", help="no progress bar")
        for flag, field, kind, text in OPTIONS.get(name, []):
            q.add_argument(flag, dest=f"cfg_{field}", type=kind, default=None, help=text)
        for flag, field, value, text in SWITCHES.get(name, []):
            q.add_argument(flag, dest=f"cfg_{field}", action="store_const", const=value, default=None, help=text)
    return p


def main(argv: Optional[list[str]] = None) -> int:
    args = parser().parse_args(argv)
    config: dict[str, Any] = {}
    if args.config:
        try:
            extra = json.loads(args.config)
        except ValueError as e:
            print(f"error: --config: not JSON: {e}", file=sys.stderr)
            return 2
        if not isinstance(extra, dict):
            print("error: --config: must be a JSON object", file=sys.stderr)
            return 2
        config.update(extra)
    if args.seed is not None:
        config["seed"] = args.seed
    for key, value in vars(args).items():
        if key.startswith("cfg_") and value is not None:
            # "params.trap_probability" sets a field of a nested object.
            *path, leaf = key[4:].split(".")
            node = config
            for part in path:
                node = node.setdefault(part, {})
            node[leaf] = value
    if args.address is not None and args.executor != "ray":
        print(f"error: --address is for the ray executor, not {args.executor!r}", file=sys.stderr)
        return 2
    try:
        summary = run_sweep(
            args.experiment,
            config,
            executor=args.executor,
            out_dir=args.out,
            workers=args.workers,
            address=args.address,
            progress=not args.no_progress,
            command=" ".join(["python -m ddpkit.experiments", *(argv if argv is not None else sys.argv[1:])]),
        )
    except ExperimentError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if summary.text:
        print(summary.text, end="" if summary.text.endswith("\n") else "\n")
    print(summary.line())
    if summary.failed:
        print(f"{summary.failed} task(s) failed; see {args.out}/failed.json (a rerun retries them)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
