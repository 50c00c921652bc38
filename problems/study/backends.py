"""Where the points of a study run: in this process, on a local process pool, or on a Dask
cluster.

* :class:`SerialBackend`: one point at a time in this process (``workers=1``).
* :class:`PoolBackend`: worker processes of this machine, one per core
  (:func:`available_cores`: the cores this process may run on), the embedded default that
  needs no service. Each worker runs one point at a time over its own pipe, so the point of a
  worker that dies (killed, out of memory, a crash in native code) is known: only that point
  is charged with the death, a new worker takes the dead one's place, and the other points
  run on. Workers ignore Ctrl-C (the study finishes the points in flight and stops) and die
  with the study's process: a ``kill -9`` of it leaves no worker behind (Linux's parent-death
  signal, and a watchdog that sees the parent gone), so the same command resumes at once.
* :class:`DaskBackend`: ``dask.distributed`` (``pip install ".[cluster]"``): a scheduler
  address (``tcp://host:8786``), a ``distributed.Client``, or ``"local"`` for a
  ``LocalCluster`` started for the run and closed after it. Each task carries the study's
  :class:`PointSpec` (a few kB) and one point. Dask reschedules the tasks of a
  lost worker by itself; a task whose workers died ``allowed-failures`` times comes back as
  lost (``KilledWorker``).

Every backend offers ``submit(task) -> handle``, ``wait(handles, timeout) -> finished
handles``, ``result(handle)`` (raises :class:`WorkerLost` when the worker died),
``capacity`` (how many points to keep in flight), ``workers`` and ``close(cancel)``.
Locks the study's process holds are not the workers': ``problems.study.store`` closes them
in every forked child.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import ctypes
import ctypes.util
import logging
import multiprocessing
import multiprocessing.connection
import os
import pickle
import signal
import threading
import time
from collections.abc import Iterable, Mapping
from typing import Any

from planner.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from problems.study.point import PointSpec, install, solve_installed, solve_point

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


#: Seconds between a worker's checks that the study's process still lives (where the
#: operating system cannot signal its death).
WATCHDOG_SECONDS = 1.0


def _die_with(parent: int) -> None:
    """End this worker process when the study's process ``parent`` ends: the kernel's
    parent-death signal on Linux (immediate, even in the middle of a solve), and a watchdog
    thread everywhere (it runs between the solver's calls back into Python)."""
    with contextlib.suppress(OSError, AttributeError, TypeError):
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    if os.getppid() != parent:  # it died before the signal was asked for
        os._exit(1)

    def watch() -> None:
        while True:
            time.sleep(WATCHDOG_SECONDS)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, name="study-parent-watchdog", daemon=True).start()


def _worker_main(connection, spec: PointSpec, parent: int) -> None:
    """A pool worker: solve the points that come down the pipe until it closes or None
    comes; each result (or the exception of a bug) goes back up the pipe."""
    # Ctrl-C reaches the whole process group: the study's process decides what to do (finish
    # the points in flight), the workers go on with theirs.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _die_with(parent)
    install(spec)
    while True:
        try:
            task = connection.recv()
        except (EOFError, OSError):  # the study's process is gone
            return
        if task is None:
            return
        try:
            reply = ("result", solve_installed(task))
        except Exception as exc:  # a bug in a user's problem or output function
            reply = ("error", exc)
        try:
            connection.send(reply)
        except (pickle.PicklingError, TypeError, AttributeError):
            connection.send(("error", RuntimeError(f"{type(reply[1]).__name__}: {reply[1]}")))
        except (BrokenPipeError, OSError):
            return


class _Handle:
    """A point handed to a pool worker: done when its result, its exception or its worker's
    death is known."""

    def __init__(self, task: Mapping[str, Any]) -> None:
        self.task = task
        self.done = False
        self.value: dict[str, Any] | None = None
        self.error: BaseException | None = None
        self.worker: _Worker | None = None


class _Worker:
    """One worker process and the parent's end of its pipe."""

    def __init__(self, context, spec: PointSpec) -> None:
        self.connection, child = context.Pipe()
        self.process = context.Process(
            target=_worker_main, args=(child, spec, os.getpid()), daemon=True
        )
        self.process.start()
        child.close()
        self.handle: _Handle | None = None

    def stop(self, cancel: bool) -> None:
        if cancel:
            self.process.kill()
        else:
            with contextlib.suppress(OSError):
                self.connection.send(None)
        self.process.join(timeout=None if not cancel else 5.0)
        self.connection.close()


class PoolBackend:
    """``workers`` processes of this machine (default: :func:`available_cores`), one point
    each at a time (see the module docstring).

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
        self._pool = [_Worker(self._context, spec) for _ in range(self.workers)]
        self.capacity = self.workers
        self.description = f"process pool, {self.workers} workers"

    @property
    def pids(self) -> list[int]:
        """The worker processes' ids."""
        return [worker.process.pid for worker in self._pool]

    def submit(self, task: Mapping[str, Any]) -> _Handle:
        handle = _Handle(task)
        idle = [w for w in self._pool if w.handle is None]
        if not idle:
            raise RuntimeError("internal: a point submitted with every worker busy")
        worker = idle[0]
        worker.handle, handle.worker = handle, worker
        try:
            worker.connection.send(task)
        except (BrokenPipeError, OSError):  # the worker died while idle: a new one
            self._replace(worker)
            return self.submit(task)
        return handle

    def wait(self, handles: Iterable, timeout: float) -> set:
        handles = list(handles)
        finished = {h for h in handles if h.done}
        if finished:
            return finished
        busy = {h.worker: h for h in handles if h.worker is not None}
        ready = multiprocessing.connection.wait(
            [w.connection for w in busy] + [w.process.sentinel for w in busy], timeout
        )
        for worker, handle in busy.items():
            if worker.connection in ready:
                try:
                    kind, value = worker.connection.recv()
                except (EOFError, OSError):  # it died with the reply half-sent
                    kind, value = "lost", None
                if kind == "result":
                    handle.value = value
                elif kind == "error":
                    handle.error = value
                else:
                    handle.error = self._lost(worker)
            elif worker.process.sentinel in ready:
                handle.error = self._lost(worker)
            else:
                continue
            handle.done = True
            worker.handle = None
            finished.add(handle)
        return finished

    def _lost(self, worker: _Worker) -> WorkerLost:
        worker.process.join(timeout=5.0)
        code = worker.process.exitcode
        how = f"killed by signal {-code}" if code is not None and code < 0 else f"exit code {code}"
        logger.warning(
            "study worker %s died (%s); its point only is queued again, a new worker starts",
            worker.process.pid,
            how,
        )
        self._replace(worker)
        return WorkerLost(f"its worker process {worker.process.pid} died ({how})")

    def _replace(self, worker: _Worker) -> None:
        with contextlib.suppress(OSError):
            worker.connection.close()
        index = self._pool.index(worker)
        self._pool[index] = _Worker(self._context, self._spec)

    def result(self, handle: _Handle) -> dict[str, Any]:
        if handle.error is not None:
            raise handle.error
        return handle.value

    def close(self, cancel: bool = False) -> None:
        for worker in self._pool:
            worker.stop(cancel)


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
