"""The type stubs agree with the extension module (mypy.stubtest)."""

from __future__ import annotations

import subprocess
import sys

import pytest


def test_stubtest_passes() -> None:
    pytest.importorskip("mypy.stubtest", reason="mypy is in requirements-test.txt")
    result = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "ddpkit._ddpkit"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_package_is_typed() -> None:
    from importlib import resources

    root = resources.files("ddpkit")
    assert root.joinpath("py.typed").is_file()
    assert root.joinpath("_ddpkit.pyi").is_file()
