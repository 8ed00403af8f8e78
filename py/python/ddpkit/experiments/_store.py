"""The result store of a sweep: one file per finished task, keyed by a hash of its specification.

Layout under the sweep's output directory::

    tasks/<experiment>/done/<key>.json     {"experiment", "spec", "result"}  (finished tasks)
    tasks/<experiment>/failed/<key>.json   {"experiment", "spec", "error"}   (last error of a task)

``key`` is the SHA-256 of the experiment name and the specification text, so the same task always
lands in the same file: a task is stored at most once, and a resumed sweep finds what an earlier
run finished, even when the configuration grew (more episodes keep the first ones). Every file is
written whole or not at all (a temporary file in the same directory, ``fsync``, ``os.replace``,
then an ``fsync`` of the directory), so a killed driver leaves finished results and nothing half
written. Only the driver writes; workers return text.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from typing import Optional


def task_key(experiment: str, spec: str) -> str:
    """The store key of a task: SHA-256 (hex) of the experiment name and its specification."""
    h = hashlib.sha256()
    h.update(experiment.encode())
    h.update(b"\0")
    h.update(spec.encode())
    return h.hexdigest()


def write_atomic(path: str, text: str) -> None:
    """Writes ``text`` to ``path`` whole or not at all (temporary file, fsync, rename, fsync dir)."""
    directory = os.path.dirname(path) or "."
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".part", dir=directory)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    try:
        dfd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dfd)
    except OSError:
        pass
    finally:
        os.close(dfd)


class ResultStore:
    """Finished (and failed) tasks of one experiment under ``out_dir`` (see the module docs)."""

    def __init__(self, out_dir: str, experiment: str) -> None:
        self.experiment = experiment
        self.root = os.path.join(out_dir, "tasks", experiment)
        self.done_dir = os.path.join(self.root, "done")
        self.failed_dir = os.path.join(self.root, "failed")
        os.makedirs(self.done_dir, exist_ok=True)
        os.makedirs(self.failed_dir, exist_ok=True)
        self._remove_stale_parts()
        #: Results written by this store object (a resumed sweep's count of recomputed tasks).
        self.writes = 0

    def _remove_stale_parts(self, age_s: float = 3600.0) -> None:
        """Deletes temporary files a killed driver left (never results: those are renamed into
        place whole). Only old ones, so a second driver writing into the same store right now
        keeps its own."""
        now = time.time()
        for d in (self.done_dir, self.failed_dir):
            for n in os.listdir(d):
                if n.startswith(".tmp-") and n.endswith(".part"):
                    p = os.path.join(d, n)
                    try:
                        if now - os.stat(p).st_mtime > age_s:
                            os.unlink(p)
                    except OSError:
                        pass

    def key(self, spec: str) -> str:
        return task_key(self.experiment, spec)

    def _done(self, key: str) -> str:
        return os.path.join(self.done_dir, key + ".json")

    def _failed(self, key: str) -> str:
        return os.path.join(self.failed_dir, key + ".json")

    def get(self, spec: str) -> Optional[str]:
        """The stored result of ``spec``, or ``None`` if it has not finished (or its file does not
        hold this very specification, which a hash collision or a hand-edited file would cause)."""
        try:
            with open(self._done(self.key(spec)), encoding="utf-8") as f:
                entry = json.load(f)
        except (OSError, ValueError):
            return None
        if not isinstance(entry, dict) or entry.get("experiment") != self.experiment or entry.get("spec") != spec:
            return None
        result = entry.get("result")
        return result if isinstance(result, str) else None

    def put(self, spec: str, result: str) -> None:
        """Stores the result of ``spec`` (whole or not at all) and clears an earlier failure."""
        key = self.key(spec)
        write_atomic(self._done(key), json.dumps({"experiment": self.experiment, "spec": spec, "result": result}))
        self.writes += 1
        try:
            os.unlink(self._failed(key))
        except FileNotFoundError:
            pass

    def put_failure(self, spec: str, error: str) -> None:
        """Records the last error of ``spec`` (a later success removes it)."""
        write_atomic(self._failed(self.key(spec)), json.dumps({"experiment": self.experiment, "spec": spec, "error": error}))

    def finished_keys(self) -> set[str]:
        """Keys of every stored result."""
        return {n[: -len(".json")] for n in os.listdir(self.done_dir) if n.endswith(".json") and not n.startswith(".")}
