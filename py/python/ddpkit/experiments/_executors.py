"""The executors: one interface, three back ends (after nuplan-devkit's ``WorkerPool``).

An executor runs task specifications (JSON text) of one experiment and yields ``(index, ok,
text, seconds)`` as tasks finish, in any order: ``text`` is the result (JSON) when ``ok``, else
the error; ``seconds`` the task's own run time (0 when its worker was lost).
A task that raises is reported and does not stop the others; a worker process that dies is
replaced and its tasks run again (at most ``max_retries`` times), by Ray itself for the Ray back
end. Workers run one task at a time on one thread (``RAYON_NUM_THREADS=1``, Ray ``num_cpus=1``),
so a node runs as many tasks as it has cores and is not oversubscribed.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import socket
import time
from abc import ABC, abstractmethod
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Iterator, Optional, Sequence


class ExperimentError(RuntimeError):
    """A sweep cannot start: an unknown experiment or executor, a missing package, an
    unreachable cluster, or a bad configuration. The message names what is wrong."""


#: The executor names ``make_executor`` accepts.
EXECUTORS = ("sequential", "processes", "ray")


def ddpkit_task(experiment: str, spec: str, threads: Optional[int] = None) -> tuple[bool, str, float]:
    """Runs one task; returns ``(True, result, seconds)`` or ``(False, error, seconds)``, never
    raises for a task error (so one bad task cannot stop a sweep). ``seconds`` is the task's own
    run time (what the executors' overhead is measured against). ``threads`` sets
    ``RAYON_NUM_THREADS`` in a worker before the extension first starts its thread pool."""
    if threads is not None:
        os.environ["RAYON_NUM_THREADS"] = str(threads)
    from ddpkit._ddpkit import experiment_run_task

    start = time.perf_counter()
    try:
        return True, experiment_run_task(experiment, spec), time.perf_counter() - start
    except Exception as e:  # noqa: BLE001 - every task error is reported with its specification
        return False, f"{type(e).__name__}: {e}", time.perf_counter() - start


def ddpkit_tasks(experiment: str, specs: Sequence[str], threads: Optional[int] = None) -> list[tuple[bool, str, float]]:
    """Runs several tasks one after another (a chunk of a Ray sweep: one scheduling round trip
    for all of them); one ``(ok, text, seconds)`` per task, as :func:`ddpkit_task`."""
    return [ddpkit_task(experiment, spec, threads) for spec in specs]


def guided_chunks(n: int, workers: int, cap: int = 32) -> list[int]:
    """Chunk sizes for ``n`` tasks on ``workers`` workers, in the order they are handed out:
    guided self-scheduling (after Polychronopoulos and Kuck 1987): each chunk a ``1 / (2 workers)``
    share of the tasks not yet handed out, at most ``cap``, so that the first chunks amortise
    the scheduling round trip and the last ones are single tasks, which leaves no worker idle
    for long while another finishes a large chunk at the end of a sweep."""
    sizes: list[int] = []
    left = n
    while left > 0:
        size = max(1, min(cap, left // (2 * workers)))
        sizes.append(size)
        left -= size
    return sizes


def _warm_worker(threads: int, hold_s: float = 0.2) -> int:
    """Starts a worker for real: sets its thread count, imports the extension, and holds the
    worker for ``hold_s`` so that the executor's other warm-up calls land on other workers.
    Returns the worker's pid. Run by :meth:`Executor.start`, so that a sweep's wall time holds
    the tasks and what each costs, not the one-off start of the workers (reported apart)."""
    os.environ["RAYON_NUM_THREADS"] = str(threads)
    import ddpkit._ddpkit  # noqa: F401

    time.sleep(hold_s)
    return os.getpid()


def _init_worker(threads: int) -> None:
    os.environ["RAYON_NUM_THREADS"] = str(threads)
    os.environ.setdefault("OMP_NUM_THREADS", str(threads))


class Executor(ABC):
    """Runs tasks of one experiment (see the module docs)."""

    #: The back end's name (``sequential``, ``processes``, ``ray``).
    name: str = ""

    def start(self) -> None:
        """Checks that the back end can run (packages, cluster) and starts it. Raises
        :class:`ExperimentError` before any task runs."""

    @property
    @abstractmethod
    def workers(self) -> int:
        """Tasks that run at once."""

    @abstractmethod
    def run(self, experiment: str, specs: Sequence[str]) -> Iterator[tuple[int, bool, str, float]]:
        """Runs every specification; yields ``(index, ok, text, seconds)`` as each finishes."""

    def close(self) -> None:
        """Stops what :meth:`start` started."""

    def __enter__(self) -> "Executor":
        self.start()
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


class SequentialExecutor(Executor):
    """Runs the tasks one after another in this process (the reference for the other back ends)."""

    name = "sequential"

    @property
    def workers(self) -> int:
        return 1

    def run(self, experiment: str, specs: Sequence[str]) -> Iterator[tuple[int, bool, str, float]]:
        for i, spec in enumerate(specs):
            yield (i, *ddpkit_task(experiment, spec))


class ProcessExecutor(Executor):
    """Runs the tasks in ``workers`` local processes (spawned, one thread each)."""

    name = "processes"

    def __init__(self, workers: Optional[int] = None, max_retries: int = 3, threads_per_task: int = 1) -> None:
        n = workers if workers is not None else (os.cpu_count() or 1)
        if not isinstance(n, int) or n < 1:
            raise ExperimentError(f"executor 'processes': workers must be at least 1, got {workers!r}")
        self._workers = n
        self.max_retries = max_retries
        self.threads_per_task = threads_per_task
        self._pool: Optional[ProcessPoolExecutor] = None

    @property
    def workers(self) -> int:
        return self._workers

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(
            max_workers=self._workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=_init_worker,
            initargs=(self.threads_per_task,),
        )

    def start(self) -> None:
        self._pool = self._new_pool()
        # Spawn every worker now (spawned processes import ddpkit: about a second each).
        for f in [self._pool.submit(_warm_worker, self.threads_per_task) for _ in range(self._workers)]:
            f.result()

    def run(self, experiment: str, specs: Sequence[str]) -> Iterator[tuple[int, bool, str, float]]:
        if self._pool is None:
            self.start()
        todo = list(range(len(specs)))[::-1]
        attempts = [0] * len(specs)
        pending: dict[Future[tuple[bool, str, float]], int] = {}
        window = 4 * self._workers
        while todo or pending:
            assert self._pool is not None
            while todo and len(pending) < window:
                i = todo.pop()
                attempts[i] += 1
                pending[self._pool.submit(ddpkit_task, experiment, specs[i], self.threads_per_task)] = i
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            broken = False
            for f in done:
                i = pending.pop(f)
                try:
                    ok, text, seconds = f.result()
                except BrokenProcessPool:
                    broken = True
                    if attempts[i] > self.max_retries:
                        yield i, False, f"a worker process died {attempts[i]} times running this task", 0.0
                    else:
                        todo.append(i)
                    continue
                except Exception as e:  # noqa: BLE001 - e.g. a result that cannot be unpickled
                    yield i, False, f"{type(e).__name__}: {e}", 0.0
                    continue
                yield i, ok, text, seconds
            if broken:
                # A dead worker breaks the whole pool: every task still in it is run again.
                for f, i in pending.items():
                    f.cancel()
                    if attempts[i] > self.max_retries:
                        yield i, False, f"a worker process died {attempts[i]} times running this task", 0.0
                    else:
                        todo.append(i)
                pending.clear()
                self._pool.shutdown(wait=False, cancel_futures=True)
                self._pool = self._new_pool()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


def _check_reachable(address: str, timeout: float = 5.0) -> None:
    """Fails fast (instead of Ray's long reconnect loop) when ``host:port`` does not answer."""
    target = address[len("ray://") :] if address.startswith("ray://") else address
    host, sep, port = target.rpartition(":")
    if not sep or not port.isdigit():
        raise ExperimentError(f"executor 'ray': address {address!r} is not 'auto', 'local', 'host:port' or 'ray://host:port'")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout):
            pass
    except OSError as e:
        raise ExperimentError(f"executor 'ray': cannot reach the Ray cluster at address {address!r}: {e}") from None


class RayExecutor(Executor):
    """Runs the tasks on a Ray cluster: ``address`` ``"auto"`` (the cluster ``ray start`` made on
    this machine), ``"host:port"`` of a head node, ``"ray://host:port"`` (Ray client) or ``None``
    (a private local cluster of ``workers`` CPUs, stopped at the end). Each task asks for one CPU;
    Ray runs a task again when its worker or node dies (``max_retries``)."""

    name = "ray"

    def __init__(
        self, address: Optional[str] = None, workers: Optional[int] = None, max_retries: int = 3, chunk: Optional[int] = None
    ) -> None:
        if chunk is not None and (not isinstance(chunk, int) or chunk < 1):
            raise ExperimentError(f"executor 'ray': chunk must be at least 1, got {chunk!r}")
        #: Tasks per Ray call (``None``: about a quarter of each worker's share, at most 32).
        self.chunk = chunk
        self.address = address
        self._requested = workers
        self.max_retries = max_retries
        self._workers = 1
        self._ray: Any = None
        self._remote: Any = None
        self._started = False

    @property
    def workers(self) -> int:
        return self._workers

    def start(self) -> None:
        try:
            import ray
        except ImportError:
            raise ExperimentError(
                "executor 'ray' needs the ray package, which is not installed: pip install 'ddpkit[ray]'"
            ) from None
        address = self.address
        if address not in (None, "auto", "local"):
            _check_reachable(address)
        kwargs: dict[str, Any] = {"logging_level": logging.WARNING, "log_to_driver": False}
        if address in (None, "local"):
            kwargs.update(address="local", include_dashboard=False)
            if self._requested is not None:
                kwargs["num_cpus"] = self._requested
        else:
            kwargs["address"] = address
        if not ray.is_initialized():
            try:
                ray.init(**kwargs)
            except Exception as e:  # noqa: BLE001 - ConnectionError, RuntimeError, ValueError by version
                raise ExperimentError(
                    f"executor 'ray': cannot connect to Ray at address {address!r}: {e} (a cluster with token "
                    "authentication needs RAY_AUTH_MODE=token and its token in RAY_AUTH_TOKEN or "
                    "RAY_AUTH_TOKEN_PATH; Ray's log says InvalidAuthToken when they are missing)"
                ) from None
            self._started = True
        self._ray = ray
        self._workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
        self._remote = ray.remote(ddpkit_tasks).options(num_cpus=1, max_retries=self.max_retries, retry_exceptions=False)
        # Start a worker per CPU now (Ray starts workers on demand, each importing ddpkit).
        warm = ray.remote(_warm_worker).options(num_cpus=1, max_retries=self.max_retries)
        try:
            ray.get([warm.remote(1) for _ in range(self._workers)])
        except Exception as e:  # noqa: BLE001 - e.g. workers that cannot import ddpkit
            self.close()
            raise ExperimentError(f"executor 'ray': the workers cannot run ddpkit: {e}") from None

    def run(self, experiment: str, specs: Sequence[str]) -> Iterator[tuple[int, bool, str, float]]:
        if self._ray is None:
            self.start()
        ray = self._ray
        # Tasks go to Ray in chunks: each Ray call costs a few milliseconds of scheduling (more
        # on a busy machine), paid once per chunk; a lost worker's chunk is run again whole.
        sizes = [self.chunk] * -(-len(specs) // self.chunk) if self.chunk else guided_chunks(len(specs), self._workers)
        chunks, k = [], 0
        for size in sizes:
            chunks.append(list(range(k, min(k + size, len(specs)))))
            k += size
        chunks.reverse()
        pending: dict[Any, list[int]] = {}
        # Enough queued work to keep every CPU busy (nodes may join), without putting a huge
        # sweep's specifications into the object store at once.
        window = 2 * self._workers + 8
        while chunks or pending:
            while chunks and len(pending) < window:
                idx = chunks.pop()
                pending[self._remote.remote(experiment, [specs[i] for i in idx], 1)] = idx
            refs = list(pending)
            done, rest = ray.wait(refs, num_returns=1)
            if rest:
                # Everything else already finished, in the same round trip to the driver.
                more, _ = ray.wait(rest, num_returns=len(rest), timeout=0)
                done = done + more
            for ref in done:
                idx = pending.pop(ref)
                try:
                    outs = ray.get(ref)
                except Exception as e:  # noqa: BLE001 - a worker lost more than max_retries times
                    for i in idx:
                        yield i, False, f"{type(e).__name__}: {e}", 0.0
                    continue
                for i, (ok, text, seconds) in zip(idx, outs):
                    yield i, ok, text, seconds

    def close(self) -> None:
        if self._started and self._ray is not None:
            self._ray.shutdown()
        self._started = False
        self._ray = None


def make_executor(name: str, workers: Optional[int] = None, address: Optional[str] = None) -> Executor:
    """The executor called ``name`` (one of :data:`EXECUTORS`). Raises :class:`ExperimentError`
    naming an unknown one."""
    if name == "sequential":
        return SequentialExecutor()
    if name == "processes":
        return ProcessExecutor(workers)
    if name == "ray":
        return RayExecutor(address, workers)
    raise ExperimentError(f"unknown executor {name!r} (expected one of {', '.join(EXECUTORS)})")
