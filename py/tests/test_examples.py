"""The examples in py/examples run as scripts, print the iteration table and reach their goal
(each script exits non-zero when its solve does not converge or misses the goal)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("name", ["cartpole_swingup", "cartpole_casadi", "planar_quadrotor", "acrobot", "pendulum"])
def test_example_runs_and_converges(name: str, tmp_path: Path) -> None:
    out = run_example(name, tmp_path)
    assert "status converged" in out
    assert "iter" in out.splitlines()[0].lower()  # the iteration table comes first


def run_example(name: str, tmp_path: Path) -> str:
    r = subprocess.run(
        [sys.executable, str(EXAMPLES / f"{name}.py"), str(tmp_path / f"{name}.png")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    return r.stdout


def test_acrobot_swings_up(tmp_path: Path) -> None:
    out = run_example("acrobot", tmp_path)
    line = next(x for x in out.splitlines() if x.startswith("status "))  # the summary, not the table's "status:"
    q1 = float(line.split("final q1 ")[1].split()[0])
    q2 = float(line.split(" q2 ")[1].split()[0])
    assert abs(q1 - np.pi) < 0.05 and abs(q2) < 0.05, line  # both links upright
    assert (tmp_path / "acrobot.png").stat().st_size > 10_000


def test_pendulum_swings_up_within_its_torque_limit(tmp_path: Path) -> None:
    out = run_example("pendulum", tmp_path)
    line = next(x for x in out.splitlines() if x.startswith("status "))  # the summary, not the table's "status:"
    angle = float(line.split("final angle ")[1].split()[0])
    torque = float(line.split("largest |torque| ")[1].split()[0])
    assert abs(angle - np.pi) < 0.05, line
    assert torque <= 2.5 + 1e-9, line
    # The limit binds: with 2.5 N m against 9.81 N m of weight it must pump, saturating.
    assert torque > 2.49, line
    assert (tmp_path / "pendulum.png").stat().st_size > 10_000
