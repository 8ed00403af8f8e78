"""The experiments of ddpkit as sweeps of independent tasks, on one executor interface with three
back ends: ``sequential``, ``processes`` (local processes) and ``ray`` (a Ray cluster).

A task is a plain specification (JSON text) with an explicit seed; the Rust function that runs it
is the one the experiment's binary runs, so each task's result is bit-identical to the binary's
for the same seed, whatever the back end, and the aggregated JSON, tables and figures are the
binary's. Example (a few Table I episodes of Alcan and Kyrki (2022) on two local processes)::

    from ddpkit import experiments

    summary = experiments.run_sweep(
        "safe-table", {"episodes": 3, "seed": 1, "robots": ["point"]},
        executor="processes", workers=2, out_dir="/tmp/table")
    print(summary.text)          # the table the binary prints; /tmp/table/table1.json

Command line: ``python -m ddpkit.experiments safe-table --executor ray --address auto
--episodes 1000 --seed 1 --out DIR``.

Nothing is lost: each finished task is stored in ``DIR/tasks/<experiment>/done/`` under a hash of
its specification, written whole or not at all, so a sweep stopped at any point (a worker killed,
the driver killed) resumes where it stopped and never stores a task twice. A task that fails is
reported with its specification and the others go on; the summary counts the failures.

| name | binary | a task is |
|---|---|---|
| ``safe-table`` | ``safe-cddp-table`` | one MPC episode of Table I (robot, method, episode) |
| ``subgoal-dataset`` | ``subgoal-dataset`` | one shard (written by the task into the output directory) |
| ``ddpen-table`` | ``ddpen-table`` | one run of DDPEN's Table I (obstacle set, planner, direction, seed; no MCAP log) |
| ``trap-bench`` | ``trap-bench`` | one run of the randomised trap benchmark (seeded map, planner; no MCAP log) |
| ``safe-turtlebot`` | ``safe-turtlebot`` | one Turtlebot episode of CDDP or Safe-CDDP (controller, episode) |
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import time
from typing import Any, Optional, Union

from ddpkit.experiments._executors import (
    EXECUTORS,
    Executor,
    ExperimentError,
    ProcessExecutor,
    RayExecutor,
    SequentialExecutor,
    ddpkit_task,
    make_executor,
)
from ddpkit.experiments._progress import progress_bar
from ddpkit.experiments._store import ResultStore, StoreWriter, task_key, write_atomic

__all__ = [
    "EXECUTORS",
    "EXPERIMENTS",
    "Executor",
    "Experiment",
    "ExperimentError",
    "ProcessExecutor",
    "RayExecutor",
    "ResultStore",
    "StoreWriter",
    "SequentialExecutor",
    "SweepSummary",
    "ddpkit_task",
    "experiment",
    "make_executor",
    "run_sweep",
    "task_key",
    "tasks",
]


@dataclasses.dataclass(frozen=True)
class Experiment:
    """One experiment: its name, the binary it mirrors and whether its tasks write files into
    the output directory themselves (the dataset's shards; ``out_dir`` is then part of the
    configuration and must be reachable by every worker, e.g. a shared file system)."""

    name: str
    binary: str
    about: str
    writes_files: bool = False


#: The experiments, by name.
EXPERIMENTS: dict[str, Experiment] = {
    e.name: e
    for e in [
        Experiment("safe-table", "safe-cddp-table", "Safe-CDDP Table I and Fig. 4 (Alcan and Kyrki 2022): one task per episode"),
        Experiment(
            "subgoal-dataset",
            "subgoal-dataset",
            "DDPEN sub-goal dataset (Gamayunov et al. 2023): one task per safetensors shard",
            writes_files=True,
        ),
        Experiment("idnp", "idnp-experiment", "IDNP experiment (Richter et al. 2023): one task per initial condition, every method"),
        Experiment("ddpen-table", "ddpen-table", "DDPEN Table I (Gamayunov et al. 2023): one task per run (set, planner, direction)"),
        Experiment("trap-bench", "trap-bench", "Randomised trap benchmark of the DDP planners: one task per run (seeded map, planner)"),
        Experiment(
            "safe-turtlebot",
            "safe-turtlebot",
            "Safe-CDDP Turtlebot experiment (Alcan and Kyrki 2022, Sec. IV-C, Fig. 5): one task per episode of one controller",
        ),
    ]
}


def experiment(name: str) -> Experiment:
    """The experiment called ``name``; :class:`ExperimentError` naming it if there is none."""
    from ddpkit._ddpkit import experiment_names

    if name not in EXPERIMENTS or name not in experiment_names():
        raise ExperimentError(f"unknown experiment {name!r} (expected one of {', '.join(sorted(EXPERIMENTS))})")
    return EXPERIMENTS[name]


def _config_json(exp: Experiment, config: dict[str, Any], out_dir: str) -> str:
    config = dict(config)
    if exp.writes_files:
        config["out_dir"] = os.path.abspath(out_dir)
    return json.dumps(config, sort_keys=True)


def tasks(name: str, config: dict[str, Any], out_dir: str = ".") -> list[str]:
    """The task specifications (JSON text) of experiment ``name`` under ``config``."""
    from ddpkit._ddpkit import experiment_tasks

    exp = experiment(name)
    return list(experiment_tasks(exp.name, _config_json(exp, config, out_dir)))


@dataclasses.dataclass
class SweepSummary:
    """What a sweep did."""

    experiment: str
    executor: str
    out_dir: str
    #: Tasks of the configuration.
    total: int
    #: Tasks found finished in the store (not run again).
    skipped: int
    #: Tasks run and stored now.
    ran: int
    #: ``(specification, error)`` of each task that failed.
    failures: list[tuple[str, str]]
    #: Wall time of running the tasks: from the executor's start (workers up) to the last
    #: result stored.
    seconds: float
    #: Wall time of starting the executor (processes, a Ray connection or local cluster, and
    #: one worker per CPU importing ddpkit).
    startup_seconds: float = 0.0
    #: Wall time of stopping the executor (after the last result was stored).
    shutdown_seconds: float = 0.0
    #: The tasks' own run times, summed (measured inside the workers).
    task_seconds: float = 0.0
    #: Tasks that ran at once.
    workers: int = 1
    #: What the aggregation printed (the binary's table or summary); empty when tasks failed.
    text: str = ""
    #: The results (JSON text) in task order; ``None`` for failed tasks.
    results: list[Optional[str]] = dataclasses.field(default_factory=list, repr=False)

    @property
    def failed(self) -> int:
        return len(self.failures)

    def line(self) -> str:
        """One line for the end of a run."""
        return (
            f"{self.experiment} on {self.executor}: {self.total} tasks, {self.skipped} finished earlier, "
            f"{self.ran} run now, {self.failed} failed ({self.seconds:.1f} s)"
        )


def run_sweep(
    name: str,
    config: Optional[dict[str, Any]] = None,
    executor: Union[str, Executor] = "sequential",
    out_dir: str = "out",
    workers: Optional[int] = None,
    address: Optional[str] = None,
    progress: bool = True,
    command: Optional[str] = None,
) -> SweepSummary:
    """Runs every task of experiment ``name`` under ``config`` (a dict; missing fields take the
    binary's defaults) that ``out_dir`` does not hold yet, on ``executor`` (a name of
    :data:`EXECUTORS` or an :class:`Executor`), then aggregates all results into the binary's
    files in ``out_dir`` (unless a task failed). Unknown experiments or executors, a missing
    ``ray``, an unreachable ``address`` and bad configurations raise :class:`ExperimentError`
    before any task runs."""
    from ddpkit._ddpkit import DdpError, experiment_aggregate, experiment_tasks

    exp = experiment(name)
    ex = make_executor(executor, workers, address) if isinstance(executor, str) else executor
    os.makedirs(out_dir, exist_ok=True)
    config_json = _config_json(exp, config or {}, out_dir)
    try:
        specs = list(experiment_tasks(exp.name, config_json))
    except DdpError as e:
        raise ExperimentError(f"experiment {name!r}: bad configuration: {e}") from None
    store = ResultStore(out_dir, exp.name)
    results: list[Optional[str]] = [store.get(s) for s in specs]
    # One run per distinct specification, even if a configuration lists a task twice.
    todo_keys: dict[str, list[int]] = {}
    for i, r in enumerate(results):
        if r is None:
            todo_keys.setdefault(store.key(specs[i]), []).append(i)
    todo = [idx[0] for idx in todo_keys.values()]
    skipped = sum(r is not None for r in results)
    failures: list[tuple[str, str]] = []
    started = time.monotonic()
    ex.start()
    start = time.monotonic()
    task_seconds = 0.0
    writer = StoreWriter(store)
    try:
        bar = progress_bar(len(specs), f"{name} ({ex.name})", initial=skipped, enabled=progress)
        try:
            for j, ok, text, secs in ex.run(exp.name, [specs[i] for i in todo]):
                i = todo[j]
                task_seconds += secs
                if ok:
                    writer.put(specs[i], text)
                    for k in todo_keys[store.key(specs[i])]:
                        results[k] = text
                else:
                    writer.put_failure(specs[i], text)
                    failures.append((specs[i], text))
                    print(f"task failed: {specs[i]}\n  {text}", file=sys.stderr)
                bar.update(1)
        finally:
            bar.close()
    finally:
        try:
            writer.close()
        finally:
            # The sweep's wall time ends with its last stored result; stopping the back end (a
            # private local Ray cluster takes seconds) is reported apart, like starting it.
            seconds = time.monotonic() - start
            ex.close()
    shutdown_seconds = time.monotonic() - start - seconds
    summary = SweepSummary(
        exp.name,
        ex.name,
        out_dir,
        len(specs),
        skipped,
        store.writes,
        failures,
        seconds,
        startup_seconds=start - started,
        shutdown_seconds=shutdown_seconds,
        task_seconds=task_seconds,
        workers=ex.workers,
        results=results,
    )
    if failures:
        report = [{"spec": json.loads(s), "error": e} for s, e in failures]
        write_atomic(os.path.join(out_dir, "failed.json"), json.dumps(report, indent=2))
        return summary
    try:
        os.unlink(os.path.join(out_dir, "failed.json"))
    except FileNotFoundError:
        pass
    summary.text = experiment_aggregate(
        exp.name,
        config_json,
        [r for r in results if r is not None],
        out_dir,
        command=command if command is not None else " ".join(sys.argv),
        workers=ex.workers,
        seconds=seconds,
    )
    return summary
