"""bench/peers/solve.py: the peer benchmark problems solve feasibly; malformed files name the field."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
SOLVE = REPO / "bench" / "peers" / "solve.py"
PROBLEMS = REPO / "bench" / "problems"

#: Costs found by the peers (bench/problems.md); P2/P3 are local optima, so ddpkit may find another
#: one nearby, but it must be feasible and no worse than the peers' by more than 0.1 %.
PEER_COST = {"p1_unicycle": 250.0393199732, "p2_car4": 1.1972797, "p3_point4": 1.8959}


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SOLVE), *args], capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("name", sorted(PEER_COST))
def test_problem_solves_feasibly(name: str, tmp_path: Path) -> None:
    out = tmp_path / f"{name}.npz"
    result = run(str(PROBLEMS / f"{name}.json"), "--out", str(out), "--repeats", "1")
    assert result.returncode == 0, result.stderr
    sol = np.load(out)
    problem = json.loads((PROBLEMS / f"{name}.json").read_text())
    n, nx = problem["N"], len(problem["x0"])
    assert sol["xs"].shape == (n + 1, nx) and sol["us"].shape == (n, 2)
    assert float(sol["max_violation"]) <= 1e-6
    assert str(sol["status"]) == "converged"
    assert float(sol["solve_seconds"]) > 0.0
    assert int(sol["iterations"]) >= 1
    cost = float(sol["cost"])
    if name == "p1_unicycle":
        assert cost == pytest.approx(PEER_COST[name], rel=1e-6)
    else:
        assert cost <= PEER_COST[name] * (1 + 1e-3)
    if "u_min" in problem:
        assert np.all(sol["us"] >= np.array(problem["u_min"]) - 1e-12)
        assert np.all(sol["us"] <= np.array(problem["u_max"]) + 1e-12)


def write(tmp_path: Path, data: object) -> Path:
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda d: d["cost"].update(Qf=[1.0, 2.0, 3.0]), "error: field 'cost.Qf' must have 4 entries, got 3"),
        (lambda d: d.update(model="boat"), "error: field 'model' must be one of"),
        (lambda d: d.update(N=0), "error: field 'N' must be an integer >= 1"),
        (lambda d: d.update(dt=-0.1), "error: field 'dt' must be > 0"),
        (lambda d: d.pop("x0"), "error: field 'x0' is missing"),
        (lambda d: d["obstacles"][1].append(1.0), "error: field 'obstacles[1]' must have 3 entries, got 4"),
        (lambda d: d.update(u_min=[1.0, -0.5]), "error: field 'u_min[0]' = 1.0 exceeds 'u_max[0]' = 0.4"),
        (lambda d: d["cost"].update(kind="mystery"), "error: field 'cost.kind' must be"),
        (lambda d: d["x0"].__setitem__(2, "zero"), "error: field 'x0[2]' must be a number"),
    ],
)
def test_malformed_file_names_the_field(tmp_path: Path, edit, message: str) -> None:
    data = json.loads((PROBLEMS / "p2_car4.json").read_text())
    edit(data)
    out = tmp_path / "never.npz"
    result = run(str(write(tmp_path, data)), "--out", str(out))
    assert result.returncode == 2
    assert message in result.stderr, result.stderr
    assert not out.exists()


def test_unreadable_file(tmp_path: Path) -> None:
    result = run(str(tmp_path / "missing.json"), "--out", str(tmp_path / "x.npz"))
    assert result.returncode == 2 and "error: cannot read" in result.stderr
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    result = run(str(bad), "--out", str(tmp_path / "x.npz"))
    assert result.returncode == 2 and "not valid JSON" in result.stderr
