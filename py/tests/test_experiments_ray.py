"""ddpkit.experiments on a real Ray cluster: ``ray start --head`` on 127.0.0.1 with two CPUs and a
temporary directory, started and stopped here. A small sweep (a few Table I episodes of Alcan and
Kyrki (2022) and two sub-goal dataset shards) gives the sequential back end's per-task results and
the binaries' outputs; a Ray worker killed mid-sweep is retried and the results do not change; a
driver killed mid-sweep resumes without recomputing finished tasks and without duplicates.

Ray is required (``py/requirements-test.txt``): without it these tests fail, they do not skip.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from typing import Any, Iterator

import pytest

from ddpkit.experiments import run_sweep

from _experiments_util import run_binary, table_without_run_fields, tree_bytes

import ray  # noqa: F401  (required: a missing ray fails this module)

TABLE = {"episodes": 2, "seed": 3, "robots": ["point"], "betas": [0.5, 0.99]}
DATASET = {"samples": 6, "shard_size": 3, "seed": 2}
#: A longer sweep for the kill tests: 20 point-robot episodes (about 0.1 s each).
KILL_TABLE = {"episodes": 10, "seed": 4, "robots": ["point"], "betas": [0.5, 0.99]}
KILL_TASKS = 20


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _pids_with(text: str) -> list[int]:
    """Processes whose command line contains ``text`` (read from /proc)."""
    out = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        if text in cmd:
            out.append(int(pid))
    return out


def _listening(pids: list[int]) -> set[tuple[str, int]]:
    """TCP addresses ``(ip, port)`` the processes ``pids`` listen on (from /proc/net/tcp{,6})."""
    inodes = set()
    for pid in pids:
        try:
            for fd in os.listdir(f"/proc/{pid}/fd"):
                try:
                    link = os.readlink(f"/proc/{pid}/fd/{fd}")
                except OSError:
                    continue
                if link.startswith("socket:["):
                    inodes.add(link[len("socket:[") : -1])
        except OSError:
            continue
    out = set()
    for table, width in (("/proc/net/tcp", 8), ("/proc/net/tcp6", 32)):
        try:
            with open(table, encoding="ascii") as f:
                rows = f.read().splitlines()[1:]
        except OSError:
            continue
        for row in rows:
            cols = row.split()
            if cols[3] != "0A" or cols[9] not in inodes:  # 0A: LISTEN
                continue
            ip_hex, port_hex = cols[1].split(":")
            raw = bytes.fromhex(ip_hex)
            if width == 8:
                ip = socket.inet_ntop(socket.AF_INET, raw[::-1])
            else:
                words = b"".join(raw[i : i + 4][::-1] for i in range(0, 16, 4))
                ip = socket.inet_ntop(socket.AF_INET6, words)
                if ip.startswith("::ffff:"):
                    ip = ip[len("::ffff:") :]
            out.add((ip, int(port_hex, 16)))
    return out


def _results(done: str) -> list[str]:
    """Stored results (a killed driver may also leave a hidden temporary ``.tmp-*.part``)."""
    return sorted(n for n in os.listdir(done) if n.endswith(".json") and not n.startswith("."))


def _reset_ray_auth_cache() -> None:
    """Ray caches its configuration and token in the process (C++ ``RayConfig`` and
    ``AuthenticationTokenLoader``); an earlier ``ray.init`` in this pytest process would keep
    the old mode and token. Refreshed the way Ray's own tests do (private: skipped if absent)."""
    raylet = getattr(ray, "_raylet", None)
    config = getattr(raylet, "Config", None)
    loader = getattr(raylet, "AuthenticationTokenLoader", None)
    if config is not None:
        config.initialize("")
    if loader is not None:
        loader.instance().reset_cache()


@pytest.fixture(scope="module")
def cluster() -> Iterator[str]:
    """A two-CPU Ray head on 127.0.0.1 (no dashboard) in a short temporary directory (Ray's
    socket paths must stay under 107 bytes); its processes are stopped at the end, by pid, even
    when a test fails, so other Ray clusters on the machine are left alone.

    Authentication is explicit: token mode with a fresh token in the temporary directory, for
    the head and for the drivers (this process and the ones the tests start). Left to Ray,
    ``ray start --head`` switches token authentication on whenever ``~/.ray/auth_token`` exists
    (any earlier ``ray.init()`` of a local cluster writes it), while a driver given an explicit
    address never does: it then fails with ``InvalidAuthToken`` and "Failed to connect"."""
    ray_cli = shutil.which("ray", path=os.path.dirname(sys.executable)) or shutil.which("ray")
    assert ray_cli, "the `ray` command is missing: pip install 'ddpkit[ray]'"
    temp = tempfile.mkdtemp(prefix="ray", dir="/tmp")
    token_path = os.path.join(temp, "auth_token")
    with open(token_path, "w", encoding="utf-8") as f:
        f.write(secrets.token_hex(32))
    os.chmod(token_path, 0o600)
    # RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0: the single-node mode Ray uses on macOS and Windows.
    # Otherwise Ray replaces 127.0.0.1 (node address, bootstrap address) by the machine's outward
    # IP and its gRPC servers listen on every interface; with it, the node is 127.0.0.1 and the
    # servers listen there only (checked below). Ray reads it when imported: this process is
    # told through the module constant, the head and the drivers the tests start through the
    # environment.
    local = {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN_PATH": token_path, "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}
    saved = {k: os.environ.get(k) for k in (*local, "RAY_AUTH_TOKEN", "RAY_ADDRESS")}
    for k in ("RAY_AUTH_TOKEN", "RAY_ADDRESS"):
        os.environ.pop(k, None)
    os.environ.update(local)
    _reset_ray_auth_cache()
    constants = ray._private.ray_constants
    cluster_mode = constants.ENABLE_RAY_CLUSTER
    constants.ENABLE_RAY_CLUSTER = False
    port = _free_port()
    env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0")
    cmd = [
        ray_cli, "start", "--head", "--num-cpus", "2", "--node-ip-address", "127.0.0.1",
        "--port", str(port), "--temp-dir", temp, "--include-dashboard", "false", "--disable-usage-stats",
    ]
    try:
        r = subprocess.run(cmd, timeout=180, env=env, capture_output=True, text=True)
        assert r.returncode == 0, f"ray start failed:\n{r.stdout}\n{r.stderr}"
        listening = _listening(_pids_with(temp))
        assert ("127.0.0.1", port) in listening, f"the head does not listen on 127.0.0.1:{port}: {listening}"
        outward = [a for a in listening if a[0] != "127.0.0.1"]
        assert not outward, f"the head listens beyond 127.0.0.1: {outward}"
        yield f"127.0.0.1:{port}"
    finally:
        for sig in (signal.SIGTERM, signal.SIGKILL):
            for pid in _pids_with(temp):
                try:
                    os.kill(pid, sig)
                except ProcessLookupError:
                    pass
            deadline = time.monotonic() + 15
            while _pids_with(temp) and time.monotonic() < deadline:
                time.sleep(0.2)
        shutil.rmtree(temp, ignore_errors=True)
        constants.ENABLE_RAY_CLUSTER = cluster_mode
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        _reset_ray_auth_cache()


@pytest.fixture(scope="module")
def sequential(tmp_path_factory: Any) -> dict[str, Any]:
    """The reference: the same sweeps on the sequential back end, and the binaries' outputs."""
    root = tmp_path_factory.mktemp("seq")
    out = {
        "table": run_sweep("safe-table", TABLE, out_dir=str(root / "table"), progress=False),
        "dataset": run_sweep("subgoal-dataset", DATASET, out_dir=str(root / "data"), progress=False),
        "kill": run_sweep("safe-table", KILL_TABLE, out_dir=str(root / "kill"), progress=False),
        "root": root,
    }
    run_binary("safe-cddp-table", "--episodes", "2", "--seed", "3", "--robots", "point", "--betas", "0.5,0.99", "--json", str(root / "bin" / "table1.json"))
    run_binary("subgoal-dataset", "--out", str(root / "bindata"), "--samples", "6", "--shard-size", "3", "--seed", "2", "--quiet")
    return out


def test_ray_sweep_equals_sequential_and_the_binaries(cluster: str, sequential: dict[str, Any], tmp_path: Any) -> None:
    table = run_sweep("safe-table", TABLE, "ray", address=cluster, out_dir=str(tmp_path / "table"), progress=False)
    assert (table.failed, table.ran) == (0, 4)
    assert table.executor == "ray"
    assert table.results == sequential["table"].results
    want = table_without_run_fields(str(sequential["root"] / "bin" / "table1.json"))
    assert table_without_run_fields(str(tmp_path / "table" / "table1.json")) == want
    data = run_sweep("subgoal-dataset", DATASET, "ray", address=cluster, out_dir=str(tmp_path / "data"), progress=False)
    assert (data.failed, data.ran) == (0, 2)
    assert data.results == sequential["dataset"].results
    assert tree_bytes(str(tmp_path / "data")) == tree_bytes(str(sequential["root"] / "bindata"))


def test_a_killed_ray_worker_is_retried_with_the_same_results(cluster: str, sequential: dict[str, Any], tmp_path: Any) -> None:
    box: dict[str, Any] = {}

    def sweep() -> None:
        try:
            box["summary"] = run_sweep("safe-table", KILL_TABLE, "ray", address=cluster, out_dir=str(tmp_path), progress=False)
        except BaseException as e:  # noqa: BLE001 - re-raised in the test thread
            box["error"] = e

    t = threading.Thread(target=sweep)
    t.start()
    killed = None
    deadline = time.monotonic() + 120
    while killed is None and t.is_alive() and time.monotonic() < deadline:
        # A worker busy with a chunk of our tasks is titled `ray::ddpkit_tasks`.
        busy = _pids_with("ray::ddpkit_task")
        if busy:
            os.kill(busy[0], signal.SIGKILL)
            killed = busy[0]
        time.sleep(0.02)
    t.join(timeout=300)
    assert not t.is_alive(), "the sweep did not finish"
    assert "error" not in box, box.get("error")
    assert killed is not None, "no busy Ray worker was seen to kill"
    s = box["summary"]
    assert (s.failed, s.total) == (0, KILL_TASKS)
    assert s.results == sequential["kill"].results


def test_a_killed_driver_resumes_without_recomputing(cluster: str, sequential: dict[str, Any], tmp_path: Any) -> None:
    out = str(tmp_path)
    cmd = [
        sys.executable, "-m", "ddpkit.experiments", "safe-table", "--executor", "ray", "--address", cluster,
        "--config", json.dumps(KILL_TABLE), "--out", out, "--no-progress",
    ]
    done = os.path.join(out, "tasks", "safe-table", "done")
    driver = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 180
        while time.monotonic() < deadline and driver.poll() is None:
            if os.path.isdir(done) and len(_results(done)) >= 2:
                break
            time.sleep(0.02)
        assert driver.poll() is None, "the driver finished before it could be killed"
        driver.kill()
    finally:
        driver.wait(timeout=60)
    finished = {n: os.stat(os.path.join(done, n)) for n in _results(done)}
    assert 2 <= len(finished) < KILL_TASKS
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert f"{KILL_TASKS} tasks, {len(finished)} finished earlier, {KILL_TASKS - len(finished)} run now, 0 failed" in r.stdout
    after = _results(done)
    assert len(after) == KILL_TASKS, "one stored result per task"
    for n, st in finished.items():
        now = os.stat(os.path.join(done, n))
        assert (now.st_ino, now.st_mtime_ns) == (st.st_ino, st.st_mtime_ns), f"{n} was recomputed"
    resumed = run_sweep("safe-table", KILL_TABLE, out_dir=out, progress=False)
    assert (resumed.skipped, resumed.ran) == (KILL_TASKS, 0)
    assert resumed.results == sequential["kill"].results
    want = table_without_run_fields(os.path.join(str(sequential["root"]), "kill", "table1.json"))
    assert table_without_run_fields(os.path.join(out, "table1.json")) == want
