"""bench/peers/replay_binaries.py: the time ratio and the outcome check, on stand-in replay binaries."""

from __future__ import annotations

import stat
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "bench" / "peers" / "replay_binaries.py"


def fake_replay(path: Path, lines: list[str]) -> Path:
    """An executable that prints `lines` as `family_replay` prints its problems."""
    body = "\n".join(f"echo '{line}'" for line in lines)
    path.write_text(f"#!/bin/sh\necho 'AB ignored line'\n{body}\necho 'matched 1/2 (50.0%)'\n")
    path.chmod(path.stat().st_mode | stat.S_IEXEC)
    return path


def line(pid: str, outcome: str, it: int, ratio: float) -> str:
    return f"{pid:24} {outcome} gap +1.00e-8 viol 0.0e0 it {it:4} {'converged':14} t/IPOPT {ratio:.3f}"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=60)


def compare(tmp_path: Path, base_lines: list[str], new_lines: list[str]) -> str:
    """The script's report on two stand-in binaries (one round, one solve each); must succeed."""
    base = fake_replay(tmp_path / "base", base_lines)
    new = fake_replay(tmp_path / "new", new_lines)
    result = run(str(base), str(new), "family.json", "--rounds", "1", "--repeats", "1")
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_ratio_is_the_geometric_mean_and_same_outcomes_pass(tmp_path: Path) -> None:
    out = compare(
        tmp_path,
        [line("car-s1-i0-a0", "match", 10, 0.100), line("point-s1-i1-a0", "MISS ", 20, 0.200)],
        [line("car-s1-i0-a0", "match", 10, 0.050), line("point-s1-i1-a0", "MISS ", 20, 0.400)],
    )
    # (0.5 * 2.0) ** 0.5 = 1.
    assert "geometric mean: 1.0000 over 2 pairs" in out
    assert "matches: base 1, new 1" in out
    assert "every outcome the same" in out


def test_changed_iterates_are_reported(tmp_path: Path) -> None:
    out = compare(tmp_path, [line("car-s1-i0-a0", "match", 10, 0.100)], [line("car-s1-i0-a0", "match", 12, 0.080)])
    assert "geometric mean: 0.8000" in out
    assert "1 outcomes differ" in out
    assert "car-s1-i0-a0" in out


def test_bad_arguments_are_errors(tmp_path: Path) -> None:
    base = fake_replay(tmp_path / "base", [line("car-s1-i0-a0", "match", 10, 0.100)])
    result = run(str(base), str(base), "family.json", "--repeats", "0")
    assert result.returncode != 0
    assert "--repeats and --rounds must be at least 1" in result.stderr
    # A binary that prints no problem lines (only the summary and AB lines).
    silent = fake_replay(tmp_path / "silent", [])
    result = run(str(silent), str(base), "family.json", "--rounds", "1")
    assert result.returncode != 0
    assert "printed no problem lines" in result.stderr
