"""Helpers of the experiment tests: the Rust binaries the sweeps are compared with."""

from __future__ import annotations

import json
import os
import subprocess
from typing import Any

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def binary(name: str) -> str:
    """Path of a release binary of the workspace (built by scripts/test.sh). Missing: the test
    fails, naming the build command."""
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(REPO, "target"))
    path = os.path.join(target, "release", name)
    assert os.path.isfile(path), (
        f"{path} is missing: build it with `cargo build --release -p safe-cddp --bin safe-cddp-table "
        "-p subgoal-infer --bin subgoal-dataset -p idnp --bin idnp-experiment -p sim2d --bin ddpen-table --bin trap-bench --bin safe-turtlebot` "
        "(scripts/test.sh does)"
    )
    return path


def run_binary(name: str, *args: str) -> None:
    subprocess.run([binary(name), *args], check=True, timeout=600, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


#: Fields of the binaries' JSON that record how a run went, not what it computed.
RUN_FIELDS = ("command", "threads", "seconds")


def table_without_run_fields(path: str) -> Any:
    with open(path) as f:
        data = json.load(f)
    for k in RUN_FIELDS:
        data.pop(k, None)
    return data


def tree_bytes(directory: str) -> dict[str, bytes]:
    """The files of a dataset directory (the store excluded), by name."""
    out = {}
    for name in sorted(os.listdir(directory)):
        path = os.path.join(directory, name)
        if os.path.isfile(path) and not name.startswith("."):
            with open(path, "rb") as f:
                out[name] = f.read()
    return out


#: Fields of IDNP results that are wall-clock times (measured, so never equal across runs).
IDNP_TIME_FIELDS = ("dp_time", "inverse_time", "nlp_time")


def idnp_without_times(value: Any) -> Any:
    """An IDNP result (a case, or the whole experiment) with every wall-clock time removed: the
    per-method times of each case and the summary's per-iteration times. Everything else is a
    function of the seed and compared exactly."""
    if isinstance(value, str):
        value = json.loads(value)
    return _strip_times(value)


#: Fields of Turtlebot results that are measured wall times: each episode's solve times, the
#: summaries' statistics of them and the run's wall time.
TURTLEBOT_TIME_FIELDS = ("solve_ms", "step_solve_ms", "first_solve_ms", "wall_s")


def turtlebot_without_times(value: Any) -> Any:
    """A Turtlebot result (an episode, or the experiment's JSON) with its measured wall times
    removed; everything else is a function of the seed and compared exactly."""
    if isinstance(value, str):
        value = json.loads(value)
    return _strip(value, TURTLEBOT_TIME_FIELDS)


def _strip(value: Any, fields: tuple[str, ...]) -> Any:
    if isinstance(value, dict):
        return {k: _strip(v, fields) for k, v in value.items() if k not in fields}
    if isinstance(value, list):
        return [_strip(v, fields) for v in value]
    return value


def _strip_times(value: Any) -> Any:
    if isinstance(value, dict):
        return {
            k: _strip_times(v)
            for k, v in value.items()
            if k not in IDNP_TIME_FIELDS and k not in ("times_fixed", "times_adaptive", "optimizer_ms")
        }
    if isinstance(value, list):
        return [_strip_times(v) for v in value]
    return value


#: Fields of sim2d run results and their tables that are wall-clock measurements.
SIM2D_MEASURED_FIELDS = (
    "timing",
    "real_time_factor",
    "epoch_ms",
    "epoch_stats",
    "cycle_stats",
    "cycle_ms_mean",
    "cycle_ms_p99_max",
)


def sim2d_without_measured(value: Any) -> Any:
    """A sim2d run result, or a ``ddpen-table``/``trap-bench`` JSON file's contents, with every
    wall-clock measurement removed (compute times and real-time factors); the rest is a function
    of the seed and compared exactly."""
    if isinstance(value, str):
        value = json.loads(value)
    return _strip(value, SIM2D_MEASURED_FIELDS)
