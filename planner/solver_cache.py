"""IPOPT solvers kept per NLP structure, so that solving the same structure again skips the build.

Building a ``casadi.nlpsol`` solver generates the derivative functions IPOPT needs (the
constraint Jacobian and the Hessian of the Lagrangian, with their sparsity and colourings):
for the six-link gait (Hermite-Simpson, N = 50) that is ~45 ms with the MX NLP and ~400 ms
with the SX-expanded one (``examples/benchmarks/planner_bench.py``). A transcription's NLP
takes its bounds, its nominal scales, a fixed duration and the guess as arguments
(:meth:`planner.transcription.Transcription.parameter_values`), so a re-solve, a warm start,
a continuation in a bound or in T and a study that sweeps such values solve one NLP
structure many times: :func:`planner.solver.solve` takes the solver from here when one with
the same :attr:`~planner.transcription.Transcription.structure_key`, the same expansion and
the same IPOPT options was built before.

The cache is bounded (least recently used solvers go first, :data:`DEFAULT_SIZE` by
default) and shared by the threads of a process; a solver runs one solve at a time (a
thread that finds it busy builds a private one). ``SOLVERS.clear()`` frees them all,
``SOLVERS.resize(n)`` changes the bound (0 turns the cache off), ``SOLVERS.info()`` counts
hits and misses.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field
from typing import Any

from planner.errors import check_integer

#: Solvers kept by default. A six-link Hermite-Simpson solver at N = 160 holds a few MB.
DEFAULT_SIZE = 16


@dataclass
class CachedSolver:
    """A built solver and what belongs to it: ``value`` (the solver), ``extra`` (objects
    that must live as long as it, e.g. its iteration callback), the seconds its build took,
    and a lock held while it solves."""

    value: Any
    extra: Any = None
    build_seconds: float = 0.0
    uses: int = 0
    #: Wall seconds IPOPT has spent solving with this solver (all its uses).
    solve_seconds: float = 0.0
    #: The compiled library the solver evaluates the NLP with (planner.native_nlp), or None.
    library: Any = None
    lock: threading.Lock = field(default_factory=threading.Lock)


class SolverCache:
    """A bounded least-recently-used map key -> :class:`CachedSolver`, thread-safe."""

    def __init__(self, size: int = DEFAULT_SIZE) -> None:
        self._entries: OrderedDict[Hashable, CachedSolver] = OrderedDict()
        self._lock = threading.Lock()
        self._size = _check_size(size)
        self.hits = 0
        self.misses = 0

    @property
    def size(self) -> int:
        """The most solvers kept."""
        return self._size

    def resize(self, size: int) -> None:
        """Keep at most ``size`` solvers from now on (0: keep none)."""
        with self._lock:
            self._size = _check_size(size)
            while len(self._entries) > self._size:
                self._entries.popitem(last=False)

    def clear(self) -> None:
        """Forget every solver (and the hit counts)."""
        with self._lock:
            self._entries.clear()
            self.hits = self.misses = 0

    def __len__(self) -> int:
        return len(self._entries)

    def __contains__(self, key: Hashable) -> bool:
        return key in self._entries

    def info(self) -> dict[str, int]:
        """{"solvers", "size", "hits", "misses"}."""
        return {
            "solvers": len(self._entries),
            "size": self._size,
            "hits": self.hits,
            "misses": self.misses,
        }

    def get(self, key: Hashable, build: Callable[[], CachedSolver]) -> tuple[CachedSolver, bool]:
        """The solver for ``key`` and whether it was cached; ``build()`` makes a missing one.

        The build runs outside the cache's lock (it takes from tens of milliseconds to
        seconds); two threads that miss the same key at once both build, the first one
        stored is kept and the other one serves its own solve only.
        """
        with self._lock:
            entry = self._entries.get(key)
            if entry is not None:
                self._entries.move_to_end(key)
                self.hits += 1
                return entry, True
            self.misses += 1
        entry = build()
        if self._size:
            with self._lock:
                self._entries.setdefault(key, entry)
                self._entries.move_to_end(key)
                while len(self._entries) > self._size:
                    self._entries.popitem(last=False)
        return entry, False


def _check_size(size: object) -> int:
    return check_integer("size", size, 0, "(0 keeps no solver)")


#: The process's solver cache, used by :func:`planner.solver.solve`.
SOLVERS = SolverCache()

__all__ = ["DEFAULT_SIZE", "SOLVERS", "CachedSolver", "SolverCache"]
