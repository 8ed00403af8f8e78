"""The result store of a sweep: one file per finished task, keyed by a hash of its specification.

Layout under the sweep's output directory::

    tasks/<experiment>/done/<key>.json     {"experiment", "spec", "result"}  (finished tasks)
    tasks/<experiment>/failed/<key>.json   {"experiment", "spec", "error"}   (last error of a task)

``key`` is the SHA-256 of the experiment name and the specification text, so the same task always
lands in the same file: a task is stored at most once, and a resumed sweep finds what an earlier
run finished, even when the configuration grew (more episodes keep the first ones). Every file is
written whole or not at all: a temporary file in the same directory, ``fsync``, ``os.replace``,
then an ``fsync`` of the directory. Only the driver writes; workers return text.

During a sweep the driver hands results to a :class:`StoreWriter`, a thread that writes them in
batches (everything queued since the last batch: each file written and ``fsync``-ed under a
temporary name, then all renamed into place, then one ``fsync`` of the directory), so the
driver's loop never waits for the disk and a batch of ``k`` results costs one directory
``fsync`` instead of ``k``. A killed driver loses at most the batch in flight (those tasks run
again on resume, stored once); finished files are never partial. Each entry also holds the
SHA-256 of its result, checked when read, so a file damaged after the fact is run again rather
than trusted.
"""

from __future__ import annotations

import hashlib
import json
import os
import queue
import tempfile
import threading
import time
from typing import Optional


def task_key(experiment: str, spec: str) -> str:
    """The store key of a task: SHA-256 (hex) of the experiment name and its specification."""
    h = hashlib.sha256()
    h.update(experiment.encode())
    h.update(b"\0")
    h.update(spec.encode())
    return h.hexdigest()


def _write_temp(path: str, text: str) -> str:
    """Writes ``text`` to a temporary file next to ``path``, ``fsync``-ed; returns its name."""
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=".part", dir=os.path.dirname(path) or ".")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    return tmp


def _fsync_dir(directory: str) -> None:
    try:
        dfd = os.open(directory or ".", os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dfd)
    except OSError:
        pass
    finally:
        os.close(dfd)


def write_atomic(path: str, text: str) -> None:
    """Writes ``text`` to ``path`` whole or not at all (temporary file, fsync, rename, fsync dir)."""
    tmp = _write_temp(path, text)
    os.replace(tmp, path)
    _fsync_dir(os.path.dirname(path))


def _entry(experiment: str, spec: str, result: str) -> str:
    digest = hashlib.sha256(result.encode()).hexdigest()
    return json.dumps({"experiment": experiment, "spec": spec, "result": result, "sha256": digest})


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
        if not isinstance(result, str) or entry.get("sha256") != hashlib.sha256(result.encode()).hexdigest():
            return None
        return result

    def put(self, spec: str, result: str) -> None:
        """Stores the result of ``spec`` (whole or not at all) and clears an earlier failure."""
        key = self.key(spec)
        write_atomic(self._done(key), _entry(self.experiment, spec, result))
        self.writes += 1
        try:
            os.unlink(self._failed(key))
        except FileNotFoundError:
            pass

    def put_batch(self, items: list[tuple[str, str]]) -> None:
        """Stores several ``(spec, result)`` pairs: each file whole or not at all, one directory
        ``fsync`` for the batch (see the module docs)."""
        staged: list[tuple[str, str, str]] = []
        try:
            for spec, result in items:
                key = self.key(spec)
                staged.append((_write_temp(self._done(key), _entry(self.experiment, spec, result)), self._done(key), key))
        except BaseException:
            for tmp, _, _ in staged:
                try:
                    os.unlink(tmp)
                except OSError:
                    pass
            raise
        for tmp, path, key in staged:
            os.replace(tmp, path)
            self.writes += 1
            try:
                os.unlink(self._failed(key))
            except FileNotFoundError:
                pass
        _fsync_dir(self.done_dir)

    def put_failure(self, spec: str, error: str) -> None:
        """Records the last error of ``spec`` (a later success removes it)."""
        write_atomic(self._failed(self.key(spec)), json.dumps({"experiment": self.experiment, "spec": spec, "error": error}))

    def finished_keys(self) -> set[str]:
        """Keys of every stored result."""
        return {n[: -len(".json")] for n in os.listdir(self.done_dir) if n.endswith(".json") and not n.startswith(".")}


class StoreWriter:
    """Writes results of a :class:`ResultStore` on a thread of its own, in batches (see the module
    docs). :meth:`put` queues and returns at once; :meth:`close` waits for every queued result
    and re-raises the first error of the thread (also raised by the next :meth:`put`)."""

    def __init__(self, store: ResultStore) -> None:
        self.store = store
        self._queue: queue.Queue[Optional[tuple[bool, str, str]]] = queue.Queue()
        self._error: Optional[BaseException] = None
        self._thread = threading.Thread(target=self._loop, name="ddpkit-store", daemon=True)
        self._thread.start()

    def _loop(self) -> None:
        stop = False
        while not stop:
            items = [self._queue.get()]
            while True:
                try:
                    items.append(self._queue.get_nowait())
                except queue.Empty:
                    break
            stop = None in items
            if self._error is not None:
                continue
            try:
                done = [(spec, text) for item in items if item is not None for ok, spec, text in [item] if ok]
                if done:
                    self.store.put_batch(done)
                for item in items:
                    if item is not None and not item[0]:
                        self.store.put_failure(item[1], item[2])
            except BaseException as e:  # noqa: BLE001 - handed to the driver's thread
                self._error = e

    def put(self, spec: str, result: str) -> None:
        """Queues the result of ``spec``."""
        if self._error is not None:
            raise self._error
        self._queue.put((True, spec, result))

    def put_failure(self, spec: str, error: str) -> None:
        """Queues the error of ``spec``."""
        if self._error is not None:
            raise self._error
        self._queue.put((False, spec, error))

    def close(self) -> None:
        """Writes everything queued, stops the thread; raises its first error."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        if self._error is not None:
            raise self._error
