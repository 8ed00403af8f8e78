"""Executors measured on this machine, in one process: tasks per second of Safe-CDDP Table I
episodes (Alcan and Kyrki 2022) on the sequential, local-process and Ray back ends of
``ddpkit.experiments``, the overhead per task against the sequential loop, and sub-goal dataset
samples per second (Gamayunov et al. 2023); then, on paper from the measured per-task times, what
8 and 64 nodes would take for Table I with 10,000 episodes per beta and for a 10-million-sample
dataset.

    python bench/scale/executors.py --episodes 24 --workers 2 --samples 200 --json bench/results/executors.json

Overhead per task of a back end with ``W`` workers: ``(wall * W - sum of task times) / n``, where
``wall`` runs from the executor's start (workers up) to the last result stored and the task times
are measured inside the workers in the same run (so a machine slowed by other work slows both):
what each task costs beyond its own work (scheduling, serialisation, the result store, idle
workers at the end). In percent: relative to the mean task time of the same run. Start-up
(spawning processes or starting a local Ray cluster, and one worker per CPU importing ddpkit) and
shut-down are reported apart: they are paid once per sweep, not per task.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import sys
import tempfile
import time
from typing import Any

from ddpkit.experiments import run_sweep


def table_config(episodes: int, seed: int) -> dict[str, Any]:
    # Every robot, beta and baseline of Table I: the mix a full sweep runs.
    return {"episodes": episodes, "seed": seed}


def timed(name: str, config: dict[str, Any], executor: str, workers: int) -> tuple[float, Any]:
    out = tempfile.mkdtemp(prefix=f"bench-{executor}-")
    try:
        s = run_sweep(name, config, executor, out_dir=out, workers=workers, progress=False)
        assert s.failed == 0, s.failures
        return s.seconds, s
    finally:
        shutil.rmtree(out, ignore_errors=True)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--episodes", type=int, default=6, help="episodes per robot and method (14 methods x robots per episode)")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    p.add_argument("--samples", type=int, default=400, help="dataset samples for the per-sample time")
    p.add_argument("--cores-per-node", type=int, default=32, help="cores of a cluster node, for the projection")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--json", default=None)
    args = p.parse_args()
    cfg = table_config(args.episodes, args.seed)
    rows: dict[str, Any] = {}
    seq_wall, seq = timed("safe-table", cfg, "sequential", 1)
    n = seq.total
    t_seq = seq.task_seconds / n
    # Ray with one CPU too: on a small machine the driver, the raylet and the GCS then have a
    # core of their own, which shows the per-task cost of Ray itself rather than CPU contention.
    runs = [("sequential", (seq_wall, seq))]
    for label, e, w in [
        (f"processes ({args.workers})", "processes", args.workers),
        (f"ray ({args.workers} CPUs)", "ray", args.workers),
        ("ray (1 CPU)", "ray", 1),
    ]:
        runs.append((label, timed("safe-table", cfg, e, w)))
    for executor, (wall, s) in runs:
        assert s.results == seq.results, f"{executor}: per-task results differ from sequential"
        task = s.task_seconds / n
        over = (wall * s.workers - s.task_seconds) / n
        rows[executor] = {
            "workers": s.workers,
            "startup_s": s.startup_seconds,
            "shutdown_s": s.shutdown_seconds,
            "wall_s": wall,
            "tasks_per_s": n / wall,
            "task_ms": 1e3 * task,
            "overhead_ms": 1e3 * over,
            "overhead_pct": 100.0 * over / task,
        }
    # Dataset: one shard, sequential, one thread (RAYON_NUM_THREADS=1 as in a worker).
    os.environ["RAYON_NUM_THREADS"] = "1"
    ds_out = tempfile.mkdtemp(prefix="bench-ds-")
    try:
        start = time.perf_counter()
        s = run_sweep("subgoal-dataset", {"samples": args.samples, "shard_size": args.samples, "seed": 1}, out_dir=ds_out, progress=False)
        ds_wall = time.perf_counter() - start
        assert s.failed == 0, s.failures
    finally:
        shutil.rmtree(ds_out, ignore_errors=True)
    t_sample = ds_wall / args.samples

    print(f"Safe-CDDP Table I, {args.episodes} episodes per robot and method: {n} tasks, {1e3 * t_seq:.1f} ms per task sequential")
    print("| back end | workers | start-up (s) | shut-down (s) | wall (s) | tasks/s | task (ms) | overhead per task (ms) | overhead (% of task) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name, r in rows.items():
        print(
            f"| {name} | {r['workers']} | {r['startup_s']:.2f} | {r['shutdown_s']:.2f} | {r['wall_s']:.2f} | {r['tasks_per_s']:.1f} | "
            f"{r['task_ms']:.1f} | {r['overhead_ms']:.2f} | {r['overhead_pct']:.1f} |"
        )
    print(f"sub-goal dataset: {1e3 * t_sample:.2f} ms per sample on one thread ({args.samples} samples)")

    # On paper: Table I with 10,000 episodes per beta (every robot, beta and the car's two
    # baselines: 14 episodes per episode index), and 10 million samples in shards of 5000.
    ray_over = max(rows[f"ray ({args.workers} CPUs)"]["overhead_ms"], 0.0) / 1e3
    table_tasks = 14 * 10_000
    shard = 5000
    shards = 10_000_000 // shard
    projection = []
    for nodes in (8, 64):
        cores = nodes * args.cores_per_node
        t_table = math.ceil(table_tasks / cores) * (t_seq + ray_over)
        t_data = math.ceil(shards / cores) * (shard * t_sample + ray_over)
        projection.append({"nodes": nodes, "cores": cores, "table_s": t_table, "dataset_s": t_data})
    print(f"On paper ({args.cores_per_node} cores per node, per-task times above, Ray overhead included):")
    print("| nodes | cores | Table I, 10,000 episodes per beta (140,000 tasks) | 10 M dataset samples (2,000 shards) |")
    print("|---:|---:|---:|---:|")
    for r in projection:
        print(f"| {r['nodes']} | {r['cores']} | {r['table_s'] / 60:.1f} min | {r['dataset_s'] / 60:.1f} min |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(
                {
                    "command": " ".join(sys.argv),
                    "tasks": n,
                    "task_ms_sequential": 1e3 * t_seq,
                    "backends": rows,
                    "dataset_ms_per_sample": 1e3 * t_sample,
                    "cores_per_node": args.cores_per_node,
                    "projection": projection,
                },
                f,
                indent=2,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
