"""The order in which a study solves its grid: continuation from solved neighbours.

A grid point is solved warm-started from an already solved neighbour, so the points cannot all
start at once. A :class:`Schedule` says which points are ready (their neighbours are settled),
in which order to hand them out, and which solved neighbours each one starts from.

Orderings (``ORDERINGS``):

* ``"lines"``: the grid's lines along one axis (``line_axis``, default the last) are chains:
  the first point of every line starts cold from the gait law, and point k of a line is ready
  once point k - 1 is settled and starts from it. Lines run in parallel; ready points are
  handed out breadth first (all lines advance together, so no line is left alone at the end).
  The parallelism is the number of lines.
* ``"coarse"``: a coarse sub-grid (every ``stride``-th index of every axis, and the last one)
  is solved cold first, all of it in parallel; every other point is ready once one of its
  grid neighbours is solved and starts from the nearest solved ones. More cold solves than
  ``"lines"`` (a quarter of a 2-D grid instead of one line), but as many points in parallel as
  the coarse grid holds from the start.
* ``"cold"``: no continuation: every point starts from the gait law only, all of them in
  parallel (the baseline of ``study_bench.py``, and a check for other local optima).
* ``"auto"``: ``"lines"`` when the grid has at least as many lines as there are workers (all
  of them busy from the start), else ``"coarse"``. ``examples/benchmarks/study_bench.py``
  measures the two.

Neighbours are points whose grid indices differ by one along one axis; the starts of a point
are its solved neighbours nearest first (distance: the sum of index differences), the line
axis before the others, at most ``max_starts``; the gait law always comes last (the worker
adds it). Points are tuples of grid indices.
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Iterable, Sequence

from planner.errors import DefinitionError, DefinitionTypeError

ORDERINGS = ("auto", "lines", "coarse", "cold")
#: Solved neighbours a point may start from before the law (the issue: "retried from
#: another neighbour and from the law's guess").
MAX_STARTS = 2
#: Farthest neighbour (sum of index differences) a point starts from.
MAX_DISTANCE = 2

Point = tuple[int, ...]


def choose_ordering(ordering: str, shape: Sequence[int], workers: int, line_axis: int = -1) -> str:
    """``ordering`` with "auto" resolved for a grid of ``shape`` on ``workers`` workers."""
    check_ordering(ordering)
    if ordering != "auto":
        return ordering
    axis = _axis(line_axis, len(shape))
    lines = 1
    for k, size in enumerate(shape):
        if k != axis:
            lines *= size
    return "lines" if lines >= workers else "coarse"


def check_ordering(ordering: str) -> str:
    if not isinstance(ordering, str) or ordering not in ORDERINGS:
        raise DefinitionError(f"`ordering`: unknown {ordering!r}; use one of {ORDERINGS}")
    return ordering


def _axis(line_axis: int, ndim: int) -> int:
    if isinstance(line_axis, bool) or not isinstance(line_axis, int):
        raise DefinitionTypeError(f"`line_axis`: must be an axis number, got {line_axis!r}")
    if not -ndim <= line_axis < ndim:
        raise DefinitionError(
            f"`line_axis`: {line_axis} is not an axis of a {ndim}-axis grid; use 0..{ndim - 1}"
        )
    return line_axis % ndim


class Schedule:
    """Which points of a grid are ready, in which order, and where each one starts from.

    Parameters
    ----------
    shape : the grid's size along each axis.
    ordering : "lines", "coarse" or "cold" (resolve "auto" with :func:`choose_ordering`).
    solved, failed : points already settled (a resumed study): solved ones serve as starts.
    line_axis : the axis along which lines run ("lines"), preferred for starts in both.
    stride : the coarse grid's spacing in indices ("coarse").
    max_starts : solved points a point may start from before the law.

    Every point is in one state: pending (not settled, not handed out), running (handed out),
    solved or failed. :meth:`next_ready` hands out the best pending point whose neighbours
    allow a start; the work per call is independent of the grid's size.
    """

    def __init__(
        self,
        shape: Sequence[int],
        ordering: str,
        solved: Iterable[Point] = (),
        failed: Iterable[Point] = (),
        line_axis: int = -1,
        stride: int = 2,
        max_starts: int = MAX_STARTS,
    ) -> None:
        if ordering not in ("lines", "coarse", "cold"):
            raise DefinitionError(f"`ordering`: {ordering!r}; resolve it with choose_ordering")
        self.shape = tuple(int(s) for s in shape)
        if not self.shape or any(s < 1 for s in self.shape):
            raise DefinitionError(f"`shape`: every axis needs >= 1 point, got {self.shape}")
        self.ordering = ordering
        self.axis = _axis(line_axis, len(self.shape))
        if isinstance(stride, bool) or not isinstance(stride, int) or stride < 1:
            raise DefinitionError(f"`stride`: must be an integer >= 1, got {stride!r}")
        self.stride = stride
        self.max_starts = max_starts
        everything = list(itertools.product(*(range(s) for s in self.shape)))
        self._order = {p: k for k, p in enumerate(everything)}
        self.solved: set[Point] = {tuple(p) for p in solved}
        self.failed: set[Point] = {tuple(p) for p in failed} - self.solved
        for p in self.solved | self.failed:
            if p not in self._order:
                raise DefinitionError(f"`solved`/`failed`: {p} is not a point of {self.shape}")
        self.running: set[Point] = set()
        self.pending: set[Point] = {p for p in everything if p not in self.settled}
        self._heap: list[tuple[tuple[int, ...], Point]] = []
        self._queued: set[Point] = set()
        # Offsets to every point within MAX_DISTANCE (sum of index differences).
        ndim = len(self.shape)
        self._offsets = [
            o
            for o in itertools.product(range(-MAX_DISTANCE, MAX_DISTANCE + 1), repeat=ndim)
            if 0 < sum(abs(v) for v in o) <= MAX_DISTANCE
        ]
        for p in sorted(self.pending, key=self._order.__getitem__):
            self._refresh(p)

    # ---- states ----------------------------------------------------------------------
    @property
    def settled(self) -> set[Point]:
        return self.solved | self.failed

    @property
    def finished(self) -> bool:
        return not self.pending and not self.running

    def _priority(self, point: Point) -> tuple[int, ...]:
        if self.ordering == "lines":
            return (point[self.axis], self._order[point])
        return (0 if self.is_seed(point) else 1, self._order[point])

    def _refresh(self, point: Point) -> None:
        if point in self.pending and point not in self._queued and self._is_ready(point):
            heapq.heappush(self._heap, (self._priority(point), point))
            self._queued.add(point)

    def next_ready(self) -> Point | None:
        """The best pending point that may start now (None: none may), not yet handed out:
        "lines" breadth first (position along the line, then grid order), "coarse" the
        coarse grid first, then grid order."""
        while self._heap:
            _, point = self._heap[0]
            if point in self.pending and point not in self.running:
                return point
            heapq.heappop(self._heap)
            self._queued.discard(point)
        return None

    def unblock(self) -> Point | None:
        """When nothing runs and nothing is ready (a point's neighbours settled in another
        run, a lost worker's point), the pending point that starts anyway (grid order)."""
        if not self.pending:
            return None
        point = min(self.pending, key=self._order.__getitem__)
        heapq.heappush(self._heap, (self._priority(point), point))
        self._queued.add(point)
        return point

    def start(self, point: Point) -> None:
        """``point`` is handed out to a worker."""
        self.pending.remove(point)
        self.running.add(point)

    def settle(self, point: Point, success: bool) -> None:
        """``point`` came back solved (``success``) or failed for good."""
        self.running.discard(point)
        self.pending.discard(point)
        (self.solved if success else self.failed).add(point)
        for other in self.neighbours(point):
            self._refresh(other)

    def requeue(self, point: Point) -> None:
        """``point`` was lost with its worker: pending again."""
        self.running.discard(point)
        if point not in self.settled:
            self.pending.add(point)
            self._queued.discard(point)
            self._refresh(point)

    # ---- neighbours ------------------------------------------------------------------
    def neighbours(self, point: Point) -> list[Point]:
        """Grid points one index away along one axis, the line axis first."""
        axes = [self.axis] + [k for k in range(len(self.shape)) if k != self.axis]
        out = []
        for k in axes:
            for step in (-1, 1):
                i = point[k] + step
                if 0 <= i < self.shape[k]:
                    out.append((*point[:k], i, *point[k + 1 :]))
        return out

    def _predecessor(self, point: Point) -> Point | None:
        k = self.axis
        return None if point[k] == 0 else (*point[:k], point[k] - 1, *point[k + 1 :])

    def is_seed(self, point: Point) -> bool:
        """Whether ``point`` starts cold in this ordering (a line's first point, or a point
        of the coarse grid)."""
        if self.ordering == "lines":
            return point[self.axis] == 0
        if self.ordering == "cold":
            return True
        return all(
            i % self.stride == 0 or i == s - 1 for i, s in zip(point, self.shape, strict=True)
        )

    def _is_ready(self, point: Point) -> bool:
        if self.ordering == "lines":
            before = self._predecessor(point)
            return before is None or before in self.settled
        if self.is_seed(point):
            return True
        around = self.neighbours(point)
        if any(p in self.solved for p in around):
            return True
        # Surrounded by failures only: nothing better than the law will come.
        return all(p in self.failed for p in around)

    def starts(self, point: Point) -> list[Point | None]:
        """Where ``point`` starts from, in the order to try: solved points, or None for the
        gait law (always once). A seed of the ordering (a line's first point, a coarse-grid
        point) starts from the law, then from solved neighbours; every other point from the
        nearest solved points (sum of index differences up to ``MAX_DISTANCE``, the line axis
        before the others; in "lines" its predecessor on the line first), then the law. At
        most ``max_starts`` solved points. In "cold", the law only."""
        if self.ordering == "cold":
            return [None]
        candidates = []
        for offset in self._offsets:
            other = tuple(a + b for a, b in zip(point, offset, strict=True))
            if other in self.solved:
                distance = sum(abs(v) for v in offset)
                off_line = distance - abs(offset[self.axis])
                candidates.append((distance, off_line, self._order[other], other))
        candidates.sort()
        chosen: list[Point | None] = [c[-1] for c in candidates]
        if self.ordering == "lines":
            before = self._predecessor(point)
            if before in self.solved:
                chosen.remove(before)
                chosen.insert(0, before)
        chosen = chosen[: self.max_starts]
        return [None, *chosen] if self.is_seed(point) else [*chosen, None]


__all__ = [
    "MAX_DISTANCE",
    "MAX_STARTS",
    "ORDERINGS",
    "Schedule",
    "check_ordering",
    "choose_ordering",
]
