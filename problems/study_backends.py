"""Where the points of a study run: in this process, on a local process pool, or on a Dask
cluster.

* :class:`SerialBackend`: one point at a time in this process (``workers=1``).
* :class:`PoolBackend`: ``concurrent.futures.ProcessPoolExecutor`` with one worker per core
  (:func:`available_cores`: the cores this process may run on), the embedded default that
  needs no service. Workers ignore Ctrl-C (the study finishes the points in flight and stops);
  a worker that dies (killed, out of memory) breaks the pool: its points go back to the queue
  and a new pool starts.
* :class:`DaskBackend`: ``dask.distributed`` (``pip install ".[cluster]"``): a scheduler
  address (``tcp://host:8786``), a ``distributed.Client``, or ``"local"`` for a
  ``LocalCluster`` started for the run and closed after it. Each task carries the study's
  :class:`PointSpec` (a few kB) and one point. Dask reschedules the tasks of a
  lost worker by itself; a task whose workers died ``allowed-failures`` times comes back as
  lost (``KilledWorker``).

Every backend offers ``submit(task) -> handle``, ``wait(handles, timeout) -> finished
handles``, ``result(handle)`` (raises :class:`WorkerLost` when the worker died),
``capacity`` (how many points to keep in flight), ``workers`` and ``close(cancel)``.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import logging
import multiprocessing
import os
import pickle
import signal
from collections.abc import Iterable, Mapping
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from model.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from problems.study_point import PointSpec, install, solve_installed, solve_point

logger = logging.getLogger(__name__)

CLUSTER_INSTALL = (
    'pip install "anthropoid-planner[cluster]" (from a clone: pip install ".[cluster]"), '
    "which installs dask.distributed"
)


class WorkerLost(AnthropoidError):
    """The worker running a point died (killed, out of memory, a crash in native code)."""

    def __init__(self, message: str, final: bool = False) -> None:
        super().__init__(message)
        #: True when the engine itself gave up on the point (Dask's KilledWorker).
        self.final = final


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity; ``os.cpu_count()`` where the
    platform has no affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - macOS, Windows
        return max(1, os.cpu_count() or 1)


def check_workers(workers: object) -> int | None:
    if workers is None:
        return None
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise DefinitionError(
            f"`workers`: must be an integer >= 1 (or None: the cores), got {workers!r}"
        )
    return workers


class SerialBackend:
    """Points solved one at a time in this process, when submitted."""

    capacity = 1
    workers = 1
    description = "serial (this process)"

    def __init__(self, spec: PointSpec) -> None:
        self._spec = spec

    def submit(self, task: Mapping[str, Any]) -> concurrent.futures.Future:
        future: concurrent.futures.Future = concurrent.futures.Future()
        try:
            future.set_result(solve_point(self._spec, task))
        except Exception as exc:  # a bug in a user's problem or output function
            future.set_exception(exc)
        return future

    def wait(self, handles: Iterable, timeout: float) -> set:
        return {h for h in handles if h.done()}

    def result(self, handle) -> dict[str, Any]:
        return handle.result()

    def close(self, cancel: bool = False) -> None:
        pass


def _ignore_interrupts_and_install(spec: PointSpec) -> None:
    # Ctrl-C reaches the whole process group: the study's process decides what to do (finish
    # the points in flight), the workers go on with theirs.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    install(spec)


class PoolBackend:
    """A local process pool of ``workers`` processes (default: :func:`available_cores`).

    With the fork start method (Linux) the workers inherit the spec, so any callable works as
    the problem; elsewhere the spec is pickled, and a lambda or a local function is refused
    with a message."""

    def __init__(self, spec: PointSpec, workers: int | None = None) -> None:
        self.workers = workers or available_cores()
        methods = multiprocessing.get_all_start_methods()
        self._context = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
        if self._context.get_start_method() != "fork":  # pragma: no cover - not on Linux
            try:
                pickle.dumps(spec)
            except (pickle.PicklingError, AttributeError, TypeError) as exc:
                raise DefinitionTypeError(
                    f"`problem`: the worker processes receive the study by pickling, which "
                    f"failed ({exc}); define the problem and output functions at module level, "
                    "or run with workers=1"
                ) from exc
        self._spec = spec
        self._pool = self._new_pool()
        self.capacity = self.workers
        self.description = f"process pool, {self.workers} workers"

    def _new_pool(self) -> concurrent.futures.ProcessPoolExecutor:
        return concurrent.futures.ProcessPoolExecutor(
            max_workers=self.workers,
            mp_context=self._context,
            initializer=_ignore_interrupts_and_install,
            initargs=(self._spec,),
        )

    def submit(self, task: Mapping[str, Any]) -> concurrent.futures.Future:
        try:
            future = self._pool.submit(solve_installed, task)
        except BrokenProcessPool:
            self._replace(self._pool)
            future = self._pool.submit(solve_installed, task)
        future.study_pool = self._pool  # which pool broke, when it breaks
        return future

    def wait(self, handles: Iterable, timeout: float) -> set:
        done, _ = concurrent.futures.wait(
            list(handles), timeout=timeout, return_when=concurrent.futures.FIRST_COMPLETED
        )
        return set(done)

    def result(self, handle) -> dict[str, Any]:
        try:
            return handle.result()
        except BrokenProcessPool as exc:
            self._replace(getattr(handle, "study_pool", None))
            raise WorkerLost(f"a worker process died ({exc})") from exc

    def _replace(self, broken) -> None:
        """A new pool for the broken one (once: every point in flight reports the breakage)."""
        if broken is not self._pool:
            return
        logger.warning("a study worker process died; starting a new process pool")
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._pool = self._new_pool()

    def close(self, cancel: bool = False) -> None:
        self._pool.shutdown(wait=not cancel, cancel_futures=cancel)


def _distributed():
    # dask.distributed is an optional extra and takes about a second to import: only a study
    # that asks for a cluster imports it.
    try:
        import distributed
    except ImportError as exc:
        raise DefinitionError(
            f"`scheduler`: running a study on a Dask cluster needs dask.distributed, which is "
            f"not installed ({exc}); install it with {CLUSTER_INSTALL}, or run on the local "
            "process pool (no scheduler)"
        ) from None
    return distributed


class DaskBackend:
    """Points as tasks of a Dask cluster.

    ``scheduler``: "local" (a ``LocalCluster`` of ``workers`` single-threaded worker
    processes, default :func:`available_cores`, started now and closed by :meth:`close`), a
    scheduler address, or a ``distributed.Client``. ``capacity``: twice the cluster's worker
    threads, re-read as workers join and leave, so that no worker waits for the study's
    process to hand it the next point.
    """

    def __init__(self, spec: PointSpec, scheduler: Any, workers: int | None = None) -> None:
        distributed = _distributed()
        self._distributed = distributed
        names = ("FutureCancelledError", "FuturesCancelledError")
        self._cancelled = (
            *(getattr(distributed.client, n) for n in names if hasattr(distributed.client, n)),
            concurrent.futures.CancelledError,
        )
        self._cluster = None
        self._own_client = True
        if isinstance(scheduler, distributed.Client):
            self._client = scheduler
            self._own_client = False
            where = "a given client"
        elif scheduler == "local":
            count = workers or available_cores()
            self._cluster = distributed.LocalCluster(
                n_workers=count,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                silence_logs=logging.ERROR,
            )
            self._client = distributed.Client(self._cluster)
            where = f"Dask LocalCluster, {count} workers"
        elif isinstance(scheduler, str) and scheduler:
            try:
                self._client = distributed.Client(scheduler, timeout="20s")
            except (OSError, TimeoutError) as exc:
                raise DefinitionError(
                    f"`scheduler`: cannot reach a Dask scheduler at {scheduler!r} ({exc}); "
                    "give its address as tcp://host:8786, or 'local' for a cluster on this "
                    "machine"
                ) from None
            where = f"Dask scheduler {scheduler}"
        else:
            raise DefinitionTypeError(
                f"`scheduler`: give a scheduler address, 'local' or a distributed.Client, got "
                f"{scheduler!r}"
            )
        # The spec goes with every task (a few kB): data scattered once is lost for good with
        # the worker holding it, a task's arguments are not.
        self._spec = spec
        self.description = where
        self._threads = 1

    @property
    def workers(self) -> int:
        """The cluster's worker threads now (workers may join and leave)."""
        with contextlib.suppress(Exception):  # a scheduler that does not answer keeps the last
            self._threads = max(1, sum(self._client.nthreads().values()))
        return self._threads

    @property
    def capacity(self) -> int:
        return 2 * self.workers

    def submit(self, task: Mapping[str, Any]):
        return self._client.submit(solve_point, self._spec, task, pure=False)

    def wait(self, handles: Iterable, timeout: float) -> set:
        handles = list(handles)
        try:
            done, _ = self._distributed.wait(
                handles, timeout=timeout, return_when="FIRST_COMPLETED"
            )
        except TimeoutError:
            return set()
        return set(done)

    def result(self, handle) -> dict[str, Any]:
        try:
            return handle.result()
        except self._distributed.KilledWorker as exc:
            raise WorkerLost(f"Dask lost the workers running it ({exc})", final=True) from exc
        except self._cancelled as exc:
            raise WorkerLost(f"Dask cancelled it ({type(exc).__name__})") from exc
        finally:
            handle.release()

    def close(self, cancel: bool = False) -> None:
        with contextlib.suppress(Exception):
            if self._own_client:
                self._client.close()
        if self._cluster is not None:
            with contextlib.suppress(Exception):
                self._cluster.close()


def make_backend(spec: PointSpec, workers: int | None, scheduler: Any):
    """The backend of a run: Dask when ``scheduler`` is given, else serial for one worker,
    else the process pool."""
    workers = check_workers(workers)
    if scheduler is not None:
        return DaskBackend(spec, scheduler, workers)
    if (workers or available_cores()) == 1:
        return SerialBackend(spec)
    return PoolBackend(spec, workers)


__all__ = [
    "CLUSTER_INSTALL",
    "DaskBackend",
    "PoolBackend",
    "SerialBackend",
    "WorkerLost",
    "available_cores",
    "check_workers",
    "make_backend",
]
