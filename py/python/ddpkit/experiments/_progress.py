"""Progress bars: tqdm when it is installed, else a small bar on stderr."""

from __future__ import annotations

import sys
import time
from typing import Any


class _Plain:
    """A one-line bar redrawn at most five times a second (and at the end)."""

    def __init__(self, total: int, desc: str, initial: int = 0) -> None:
        self.total, self.desc, self.n = total, desc, initial
        self.start = time.monotonic()
        self.last = 0.0
        self._draw(force=True)

    def _draw(self, force: bool = False) -> None:
        now = time.monotonic()
        if not force and now - self.last < 0.2:
            return
        self.last = now
        width = 30
        frac = self.n / self.total if self.total else 1.0
        filled = int(width * frac)
        rate = self.n / max(now - self.start, 1e-9)
        sys.stderr.write(f"\r{self.desc} [{'=' * filled}{' ' * (width - filled)}] {self.n}/{self.total} ({rate:.1f}/s)")
        sys.stderr.flush()

    def update(self, k: int = 1) -> None:
        self.n += k
        self._draw(force=self.n >= self.total)

    def close(self) -> None:
        self._draw(force=True)
        sys.stderr.write("\n")
        sys.stderr.flush()


class _Silent:
    def update(self, k: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


def progress_bar(total: int, desc: str, initial: int = 0, enabled: bool = True) -> Any:
    """A bar with ``update(k)`` and ``close()``; silent when ``enabled`` is false."""
    if not enabled:
        return _Silent()
    try:
        from tqdm import tqdm
    except ImportError:
        return _Plain(total, desc, initial)
    return tqdm(total=total, desc=desc, initial=initial, unit="task", dynamic_ncols=True)
