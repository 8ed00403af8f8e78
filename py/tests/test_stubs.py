"""The type stubs agree with the extension module (mypy.stubtest)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import ddpkit

STUB = Path(__file__).resolve().parents[1] / "python" / "ddpkit" / "_ddpkit.pyi"


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


def stub_defaults(cls: str) -> dict[str, object]:
    """The literal defaults of `cls.__new__` in the stub, parsed with `ast`."""
    tree = ast.parse(STUB.read_text(encoding="utf-8"))
    node = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == cls)
    new = next(n for n in node.body if isinstance(n, ast.FunctionDef) and n.name == "__new__")
    args = new.args
    positional = args.posonlyargs + args.args
    pairs = list(zip(positional[len(positional) - len(args.defaults) :], args.defaults))
    pairs += [(a, d) for a, d in zip(args.kwonlyargs, args.kw_defaults) if d is not None]
    return {a.arg: ast.literal_eval(d) for a, d in pairs}


@pytest.mark.parametrize("cls", ["Solver", "SafeCddpSolver", "Mpc"])
def test_stub_defaults_are_the_rust_defaults(cls: str) -> None:
    """Every default the stub shows for a solver's settings is Rust's `Default`, so the two
    cannot drift (`stubtest` ties the stub to the runtime signatures)."""
    rust = ddpkit.default_settings(cls)
    stub = stub_defaults(cls)
    assert rust, cls
    for name, value in rust.items():
        assert name in stub, f"{cls}: {name} has no default in the stub"
        assert type(stub[name]) is type(value) and stub[name] == value, (cls, name, stub[name], value)
    # Whatever else has a default is an optional object, not a setting.
    assert all(stub[name] is None for name in set(stub) - set(rust)), (cls, set(stub) - set(rust))


def test_default_settings_names_its_kind() -> None:
    assert ddpkit.default_settings() == ddpkit.default_settings("Solver")
    with pytest.raises(ddpkit.InvalidInputError, match="kind") as e:
        ddpkit.default_settings("Newton")
    assert e.value.field == "kind"
