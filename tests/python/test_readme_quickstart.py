"""The README's Python quick start, run as written (every ```python block under "### Python")."""

import pathlib
import re

README = pathlib.Path(__file__).resolve().parents[2] / "README.md"


def python_blocks():
    text = README.read_text()
    section = text[text.index("### Python"):]
    end = section.find("\n## ", 1)
    section = section if end < 0 else section[:end]
    return re.findall(r"```python\n(.*?)```", section, flags=re.S)


def test_readme_python_quick_start_runs():
    blocks = python_blocks()
    assert blocks, "README has no Python quick start"
    for i, code in enumerate(blocks):
        namespace = {}
        exec(compile(code, f"README.md python block {i}", "exec"), namespace)
        # Each block solves something and leaves its solution behind.
        assert "sol" in namespace or "ddpkit" in namespace
