"""The examples in py/examples run as scripts, print the iteration table and reach their goal
(each script exits non-zero when its solve does not converge or misses the goal)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("name", ["cartpole_swingup", "cartpole_casadi", "planar_quadrotor"])
def test_example_runs_and_converges(name: str, tmp_path: Path) -> None:
    r = subprocess.run(
        [sys.executable, str(EXAMPLES / f"{name}.py"), str(tmp_path / f"{name}.png")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    assert "status converged" in r.stdout
    assert "iter" in r.stdout.splitlines()[0].lower()  # the iteration table comes first
