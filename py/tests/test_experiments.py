"""ddpkit.experiments without Ray: the sequential and local-process back ends give the same
per-task results and the binary's aggregated outputs; the store resumes without recomputing or
duplicating; a failing task is reported with its specification and does not stop the others;
bad input is refused, naming it, before any task runs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

import pytest

from ddpkit import experiments
from ddpkit.experiments import ExperimentError, ResultStore, StoreWriter, run_sweep

from _experiments_util import (
    binary,
    idnp_without_times,
    run_binary,
    sim2d_without_measured,
    table_without_run_fields,
    tree_bytes,
    turtlebot_without_times,
)

#: A few Table I episodes: the point robot under CDDP and Safe-CDDP (beta 0.99).
TABLE = {"episodes": 2, "seed": 3, "robots": ["point"], "betas": [0.5, 0.99]}


def _done_files(out: str, name: str) -> list[str]:
    d = os.path.join(out, "tasks", name, "done")
    return sorted(n for n in os.listdir(d) if n.endswith(".json"))


def test_processes_equal_sequential_and_the_binary(tmp_path: Any) -> None:
    seq = run_sweep("safe-table", TABLE, "sequential", out_dir=str(tmp_path / "seq"), progress=False)
    par = run_sweep("safe-table", TABLE, "processes", workers=2, out_dir=str(tmp_path / "par"), progress=False)
    assert seq.failed == par.failed == 0
    assert seq.total == par.total == 4
    assert seq.results == par.results, "per-task results differ between back ends"
    assert all(json.loads(r)["steps"] > 0 for r in seq.results if r)
    run_binary(
        "safe-cddp-table", "--episodes", "2", "--seed", "3", "--robots", "point", "--betas", "0.5,0.99",
        "--json", str(tmp_path / "bin" / "table1.json"),
    )
    want = table_without_run_fields(str(tmp_path / "bin" / "table1.json"))
    assert table_without_run_fields(str(tmp_path / "seq" / "table1.json")) == want
    assert table_without_run_fields(str(tmp_path / "par" / "table1.json")) == want
    assert "2D Point Robot" in seq.text


def test_a_grown_sweep_reuses_finished_tasks(tmp_path: Any) -> None:
    out = str(tmp_path)
    first = run_sweep("safe-table", {**TABLE, "episodes": 1}, out_dir=out, progress=False)
    assert (first.skipped, first.ran) == (0, 2)
    before = {n: os.stat(os.path.join(out, "tasks", "safe-table", "done", n)).st_mtime_ns for n in _done_files(out, "safe-table")}
    second = run_sweep("safe-table", TABLE, out_dir=out, progress=False)
    assert (second.skipped, second.ran, second.failed) == (2, 2, 0)
    after = _done_files(out, "safe-table")
    assert len(after) == 4, "one stored result per task, no duplicates"
    for n, mtime in before.items():
        assert os.stat(os.path.join(out, "tasks", "safe-table", "done", n)).st_mtime_ns == mtime, "a finished task was rewritten"
    third = run_sweep("safe-table", TABLE, out_dir=out, progress=False)
    assert (third.skipped, third.ran) == (4, 0)
    assert third.results == second.results


def test_a_failing_task_is_reported_and_the_others_finish(tmp_path: Any) -> None:
    out = tmp_path / "data"
    out.mkdir()
    # A directory where shard 1 should go: its task cannot write, shard 0's can.
    (out / "shard-00001.safetensors").mkdir()
    config = {"samples": 4, "shard_size": 2, "seed": 5}
    s = run_sweep("subgoal-dataset", config, "processes", workers=2, out_dir=str(out), progress=False)
    assert (s.total, s.ran, s.failed) == (2, 1, 1)
    spec, error = s.failures[0]
    assert json.loads(spec)["shard"] == 1 and "shard-00001" in error
    assert (out / "shard-00000.safetensors").is_file()
    assert not (out / "manifest.json").exists(), "no manifest while a shard is missing"
    report = json.loads((out / "failed.json").read_text())
    assert report[0]["spec"]["shard"] == 1
    (out / "shard-00001.safetensors").rmdir()
    again = run_sweep("subgoal-dataset", config, "sequential", out_dir=str(out), progress=False)
    assert (again.skipped, again.ran, again.failed) == (1, 1, 0)
    assert not (out / "failed.json").exists()
    run_binary("subgoal-dataset", "--out", str(tmp_path / "bin"), "--samples", "4", "--shard-size", "2", "--seed", "5", "--quiet")
    assert tree_bytes(str(out)) == tree_bytes(str(tmp_path / "bin"))


def test_the_cli_exits_non_zero_when_a_task_fails(tmp_path: Any) -> None:
    (tmp_path / "shard-00000.safetensors").mkdir()
    cmd = [sys.executable, "-m", "ddpkit.experiments", "subgoal-dataset", "--samples", "1", "--out", str(tmp_path), "--no-progress"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 1, r.stderr
    assert "1 failed" in r.stdout and "failed.json" in r.stderr


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"name": "safe-tabel"}, ["unknown experiment", "safe-tabel"]),
        ({"executor": "slurm"}, ["unknown executor", "slurm"]),
        ({"config": {"episodes": 0}}, ["episodes"]),
        ({"config": {"episode": 3}}, ["episode"]),
        ({"executor": "processes", "workers": 0}, ["workers"]),
    ],
)
def test_bad_input_is_refused_before_any_task(tmp_path: Any, kwargs: dict[str, Any], words: list[str]) -> None:
    args = {"name": "safe-table", "config": TABLE, "executor": "sequential", "out_dir": str(tmp_path), "progress": False}
    args.update(kwargs)
    with pytest.raises(ExperimentError) as e:
        run_sweep(**args)
    for w in words:
        assert w in str(e.value)
    assert not os.path.exists(os.path.join(str(tmp_path), "tasks", "safe-table", "done")) or not _done_files(str(tmp_path), "safe-table")


def test_missing_ray_and_unreachable_address_are_named(tmp_path: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    # Nothing listens on `port` now.
    with pytest.raises(ExperimentError, match=f"127.0.0.1:{port}"):
        run_sweep("safe-table", TABLE, "ray", address=f"127.0.0.1:{port}", out_dir=str(tmp_path), progress=False)
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` now raises ImportError
    with pytest.raises(ExperimentError, match=r"ray package.*ddpkit\[ray\]"):
        run_sweep("safe-table", TABLE, "ray", out_dir=str(tmp_path), progress=False)
    assert not _done_files(str(tmp_path), "safe-table")


def test_cli_names_unknown_executor_and_address_misuse(tmp_path: Any) -> None:
    base = [sys.executable, "-m", "ddpkit.experiments", "safe-table", "--out", str(tmp_path), "--episodes", "1"]
    r = subprocess.run([*base, "--executor", "slurm"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "unknown executor 'slurm'" in r.stderr
    r = subprocess.run([*base, "--address", "auto"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "--address" in r.stderr
    r = subprocess.run([sys.executable, "-m", "ddpkit.experiments", "nope"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "nope" in r.stderr


def test_store_ignores_a_file_that_holds_another_specification(tmp_path: Any) -> None:
    store = ResultStore(str(tmp_path), "safe-table")
    store.put('{"a": 1}', '{"r": 1}')
    assert store.get('{"a": 1}') == '{"r": 1}'
    # A file under the key of another specification (a hand copy) is not taken as its result.
    os.replace(
        os.path.join(store.done_dir, store.key('{"a": 1}') + ".json"),
        os.path.join(store.done_dir, store.key('{"a": 2}') + ".json"),
    )
    assert store.get('{"a": 2}') is None
    assert experiments.task_key("safe-table", "x") != experiments.task_key("subgoal-dataset", "x")


def test_store_writer_writes_every_result_in_batches_and_damaged_files_are_run_again(tmp_path: Any) -> None:
    store = ResultStore(str(tmp_path), "safe-table")
    writer = StoreWriter(store)
    for n in range(50):
        writer.put(f'{{"a": {n}}}', f'{{"r": {n}}}')
    writer.put_failure('{"b": 1}', "ValueError: no")
    writer.close()
    assert store.writes == 50
    assert [store.get(f'{{"a": {n}}}') for n in range(50)] == [f'{{"r": {n}}}' for n in range(50)]
    assert len(store.finished_keys()) == 50
    assert not [n for n in os.listdir(store.done_dir) if n.endswith(".part")], "no temporary file left"
    assert os.listdir(store.failed_dir) == [store.key('{"b": 1}') + ".json"]
    # A result changed after it was written no longer matches its checksum: not trusted.
    path = os.path.join(store.done_dir, store.key('{"a": 3}') + ".json")
    with open(path, encoding="utf-8") as f:
        entry = json.load(f)
    entry["result"] = '{"r": 4}'
    with open(path, "w", encoding="utf-8") as f:
        json.dump(entry, f)
    assert store.get('{"a": 3}') is None
    # A truncated file (a crash before the data reached the disk) is not a result either.
    with open(os.path.join(store.done_dir, store.key('{"a": 5}') + ".json"), "r+", encoding="utf-8") as f:
        f.truncate(10)
    assert store.get('{"a": 5}') is None


#: Two IDNP cases with short loops (Richter et al. 2023), a few seconds.
IDNP = {"n": 2, "seed": 3, "iterations": 2, "optimizer_iterations": 20}


def test_idnp_cases_on_processes_equal_sequential_and_the_binary_except_wall_times(tmp_path: Any) -> None:
    seq = run_sweep("idnp", IDNP, "sequential", out_dir=str(tmp_path / "seq"), progress=False)
    par = run_sweep("idnp", IDNP, "processes", workers=2, out_dir=str(tmp_path / "par"), progress=False)
    assert (seq.failed, seq.total, par.failed, par.total) == (0, 2, 0, 2)
    stripped = [idnp_without_times(r) for r in seq.results]
    assert stripped == [idnp_without_times(r) for r in par.results]
    assert [c["index"] for c in stripped] == [0, 1]
    assert all(c["fixed"]["iterations"] >= 1 and c["adaptive"]["termination"] for c in stripped)
    run_binary(
        "idnp-experiment", "--n", "2", "--seed", "3", "--iterations", "2", "--optimizer-iterations", "20",
        "--json", str(tmp_path / "bin.json"), "--no-png", "--quiet",
    )
    with open(tmp_path / "bin.json") as f:
        want = idnp_without_times(json.load(f))
    with open(tmp_path / "seq" / "experiment.json") as f:
        got = idnp_without_times(json.load(f))
    assert got == want
    assert "check adaptive >= fixed on every case" in seq.text


def test_idnp_bad_configuration_names_the_field_before_any_task(tmp_path: Any) -> None:
    with pytest.raises(ExperimentError, match=r"config_json\.n is invalid: must be at least 1"):
        run_sweep("idnp", {"n": 0}, out_dir=str(tmp_path), progress=False)
    with pytest.raises(ExperimentError, match="unknown field `cases`"):
        run_sweep("idnp", {"cases": 2}, out_dir=str(tmp_path), progress=False)
    assert not os.path.isdir(os.path.join(str(tmp_path), "tasks", "idnp")), "no task ran"


#: DDPEN's Table I (Gamayunov et al. 2023) on a 12 m route past one cylinder: DDP, both
#: directions, one run each (about a second).
SHORT_SET = (
    'name = "short"\n[route]\npoints = [[0.0, 0.0], [12.0, 0.0]]\n'
    '[[obstacles]]\ntype = "cylinder"\ncenter = [6.0, 0.6]\nradius = 0.5\n'
)


def _ddpen_config(folder: str) -> dict[str, Any]:
    return {"scenarios": folder, "sets": ["short"], "planners": ["ddp"], "runs": 1, "seed": 3, "png": False}


def _json(path: Any) -> Any:
    with open(path) as f:
        return json.load(f)


def test_ddpen_table_on_processes_equals_sequential_and_the_binary_except_measured_fields(tmp_path: Any) -> None:
    folder = tmp_path / "scenarios"
    folder.mkdir()
    (folder / "short.toml").write_text(SHORT_SET)
    config = _ddpen_config(str(folder))
    seq = run_sweep("ddpen-table", config, "sequential", out_dir=str(tmp_path / "seq"), progress=False)
    par = run_sweep("ddpen-table", config, "processes", workers=2, out_dir=str(tmp_path / "par"), progress=False)
    assert (seq.failed, seq.total, par.failed, par.total) == (0, 2, 0, 2)
    stripped = [sim2d_without_measured(r) for r in seq.results]
    assert stripped == [sim2d_without_measured(r) for r in par.results]
    assert [(r["direction"], r["completed"]) for r in stripped] == [("forward", True), ("backward", True)]
    run_binary(
        "ddpen-table", "--scenarios", str(folder), "--sets", "short", "--planner", "ddp", "--runs", "1",
        "--seed", "3", "--no-mcap", "--no-png", "--quiet", "--out", str(tmp_path / "bin"),
        "--json", str(tmp_path / "bin" / "table.json"),
    )
    want = sim2d_without_measured(_json(tmp_path / "bin" / "table.json"))
    assert sim2d_without_measured(_json(tmp_path / "seq" / "table.json")) == want
    assert sim2d_without_measured(_json(tmp_path / "par" / "table.json")) == want
    assert "| Short |" in seq.text


#: The trap benchmark on one U trap with a 16 m route: DDP and DDPEN with oracle sub-goals.
TRAPS = {
    "types": ["u"], "maps": 1, "planners": ["ddp", "ddpen-oracle"], "seed": 2, "route_length": 16.0,
    "stall_time": 10.0, "max_time": 40.0, "png": 1,
}


def test_trap_bench_on_processes_equals_sequential_and_the_binary_except_measured_fields(tmp_path: Any) -> None:
    seq = run_sweep("trap-bench", TRAPS, "sequential", out_dir=str(tmp_path / "seq"), progress=False)
    par = run_sweep("trap-bench", TRAPS, "processes", workers=2, out_dir=str(tmp_path / "par"), progress=False)
    assert (seq.failed, seq.total, par.failed, par.total) == (0, 2, 0, 2)
    assert [sim2d_without_measured(r) for r in seq.results] == [sim2d_without_measured(r) for r in par.results]
    run_binary(
        "trap-bench", "--types", "u", "--maps", "1", "--planner", "ddp", "--planner", "ddpen-oracle", "--seed", "2",
        "--route-length", "16", "--stall-time", "10", "--max-time", "40", "--png", "1", "--quiet",
        "--out", str(tmp_path / "bin"), "--json", str(tmp_path / "bin" / "bench.json"),
    )
    want = sim2d_without_measured(_json(tmp_path / "bin" / "bench.json"))
    assert sim2d_without_measured(_json(tmp_path / "seq" / "bench.json")) == want
    assert sim2d_without_measured(_json(tmp_path / "par" / "bench.json")) == want
    # The figure of the one map, with both planners' paths, as the binary draws it.
    pngs = sorted(n for n in os.listdir(tmp_path / "bin") if n.endswith(".png"))
    assert pngs and pngs == sorted(n for n in os.listdir(tmp_path / "seq") if n.endswith(".png"))
    assert "| u |" in seq.text


def test_trap_bench_cli_flags_reach_the_configuration(tmp_path: Any) -> None:
    cmd = [
        sys.executable, "-m", "ddpkit.experiments", "trap-bench", "--types", "u", "--maps", "1", "--planners", "ddp",
        "--route-length", "16", "--stall-time", "10", "--max-time", "40", "--png", "0", "--horizon", "30",
        "--no-governor", "--out", str(tmp_path), "--no-progress",
    ]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    config = _json(tmp_path / "bench.json")["config"]
    assert (config["ddp"]["horizon"], config["governor"]["enabled"], config["stall_time"]) == (30, False, 10.0)


@pytest.mark.parametrize(
    "name, config, words",
    [
        ("ddpen-table", {"runs": 0}, [r"config_json\.runs is invalid: must be at least 1"]),
        ("ddpen-table", {"set": ["free"]}, ["unknown field `set`"]),
        ("ddpen-table", {"sets": ["nowhere"]}, ["nowhere.toml"]),
        ("trap-bench", {"types": ["v"]}, ["unknown variant `v`"]),
        ("trap-bench", {"route_length": 3.0}, [r"config_json\.traps\.route_length is invalid"]),
        ("trap-bench", {"options": {"w_contact": -1.0}}, [r"config_json\.ddp\.w_contact is invalid"]),
    ],
)
def test_sim2d_bad_configuration_names_the_field_before_any_task(
    tmp_path: Any, name: str, config: dict[str, Any], words: list[str]
) -> None:
    for w in words:
        with pytest.raises(ExperimentError, match=w):
            run_sweep(name, config, out_dir=str(tmp_path), progress=False)
    assert not os.path.isdir(os.path.join(str(tmp_path), "tasks", name)), "no task ran"


#: Two paired Turtlebot episodes (Alcan and Kyrki 2022, §IV-C): four tasks of a second or two.
TURTLEBOT = {"runs": 2, "seed": 3}


def test_turtlebot_episodes_on_processes_equal_sequential_and_the_binary_except_solve_times(tmp_path: Any) -> None:
    seq = run_sweep("safe-turtlebot", TURTLEBOT, "sequential", out_dir=str(tmp_path / "seq"), progress=False)
    par = run_sweep("safe-turtlebot", TURTLEBOT, "processes", workers=2, out_dir=str(tmp_path / "par"), progress=False)
    assert (seq.failed, seq.total, par.failed, par.total) == (0, 4, 0, 4)
    stripped = [turtlebot_without_times(r) for r in seq.results]
    assert stripped == [turtlebot_without_times(r) for r in par.results]
    assert [r["controller"]["kind"] for r in stripped] == ["cddp", "safe-cddp"] * 2
    assert stripped[0]["seed"] == stripped[1]["seed"] != stripped[2]["seed"], "common random numbers per episode"
    assert all(r["steps"] > 0 and r["poses"] for r in stripped)
    run_binary("safe-turtlebot", "--runs", "2", "--seed", "3", "--json", str(tmp_path / "bin.json"), "--quiet")
    with open(tmp_path / "bin.json") as f:
        want = turtlebot_without_times(json.load(f))
    for side in ("seq", "par"):
        with open(tmp_path / side / "safe-turtlebot.json") as f:
            assert turtlebot_without_times(json.load(f)) == want, side
        assert (tmp_path / side / "safe-turtlebot.png").stat().st_size > 0
    assert "Safe-CDDP keeps the wider minimum clearance in" in seq.text


def test_turtlebot_bad_configuration_names_the_field_before_any_task(tmp_path: Any) -> None:
    with pytest.raises(ExperimentError, match=r"config_json\.beta is invalid: must be in \(0, 1\)"):
        run_sweep("safe-turtlebot", {"beta": 1.0}, out_dir=str(tmp_path), progress=False)
    with pytest.raises(ExperimentError, match=r"config_json\.sigma_w_xy is invalid"):
        run_sweep("safe-turtlebot", {"sigma_w_xy": -0.1}, out_dir=str(tmp_path), progress=False)
    with pytest.raises(ExperimentError, match="robot is invalid: unknown robot"):
        run_sweep("safe-turtlebot", {"robot": "roomba"}, out_dir=str(tmp_path), progress=False)
    with pytest.raises(ExperimentError, match="unknown field `episodes`"):
        run_sweep("safe-turtlebot", {"episodes": 2}, out_dir=str(tmp_path), progress=False)
    assert not os.path.isdir(os.path.join(str(tmp_path), "tasks", "safe-turtlebot")), "no task ran"


def test_guided_chunks_cover_every_task_once_and_end_in_single_tasks() -> None:
    from ddpkit.experiments._executors import guided_chunks

    for n, workers in [(0, 2), (1, 2), (5, 2), (336, 2), (1000, 8), (7, 64)]:
        sizes = guided_chunks(n, workers)
        assert sum(sizes) == n
        assert all(1 <= s <= 32 for s in sizes)
        # Never growing, so the last chunks are the smallest: the sweep's tail is single tasks.
        assert sizes == sorted(sizes, reverse=True)
        if n >= 2 * workers:
            assert sizes[-workers:] == [1] * workers
    # A large sweep's first chunks are capped and amortise the scheduling round trip.
    assert guided_chunks(336, 2)[:7] == [32] * 7
