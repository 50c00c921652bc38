"""Running a study: hand out ready points to a backend, write what comes back, report progress.

The process that runs a study is the only one that writes its folder. It keeps a few points in
flight (the backend's capacity), each with its starts read from the folder (the solved
neighbours the :class:`~problems.study.schedule.Schedule` names), and settles each point that
comes back: record and solution written, the table rewritten, the schedule told (which may make
neighbours ready). A point whose worker died goes back to the queue; after ``MAX_LOSSES``
deaths it is recorded as failed (``Worker_Lost``), so a point that kills its worker cannot stop
the study either.

Interrupted (Ctrl-C, an exception from the progress callback), the run hands out nothing more,
waits for the points in flight and writes them (a second Ctrl-C abandons them), writes the
table and re-raises: running the study again solves what is missing.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from problems.study.backends import WorkerLost, make_backend
from problems.study.point import WORKER_LOST, PointSpec
from problems.study.result import GridPoint, StudyProgress, StudyResult
from problems.study.schedule import Schedule, choose_ordering
from problems.study.store import StudyFolder

logger = logging.getLogger("problems.study.study")

#: Deaths of a point's worker before the point is recorded as failed.
MAX_LOSSES = 3
#: Seconds between progress reports while waiting.
TICK_SECONDS = 0.5
#: Above this many rows the table is rewritten at most every TABLE_SECONDS (and at the end).
TABLE_ROWS = 2000
TABLE_SECONDS = 5.0


@dataclass
class _Run:
    """What one run counts."""

    begin: float
    done: int = 0
    solved: int = 0
    failed: int = 0
    iterations: int = 0
    lost: int = 0


def run(
    points: list[GridPoint],
    axes: Mapping[str, Any],
    definition: Mapping[str, Any],
    spec: PointSpec,
    folder: str | Path,
    *,
    workers: int | None = None,
    scheduler: Any = None,
    ordering: str = "auto",
    line_axis: int = -1,
    retry_failed: bool = False,
    progress: Callable[[StudyProgress], None] | None = None,
) -> StudyResult:
    """Solve the points of a study that ``folder`` does not hold yet (see
    :meth:`problems.Study.run`)."""
    shape = tuple(len(values) for values in axes.values())
    by_index = {p.index: p for p in points}
    with StudyFolder(folder, definition) as store:
        rows = store.rows()
        if retry_failed:
            rows = {k: r for k, r in rows.items() if r.get("success")}
        solved = [p.index for p in points if rows.get(p.id, {}).get("success")]
        failed = [p.index for p in points if p.id in rows and not rows[p.id].get("success")]
        begin = time.perf_counter()
        backend = make_backend(spec, workers, scheduler)
        startup = time.perf_counter() - begin
        try:
            chosen = choose_ordering(ordering, shape, backend.workers, line_axis)
            schedule = Schedule(shape, chosen, solved, failed, line_axis=line_axis)
            logger.info(
                "study in %s: %d points, %d settled before, %s, ordering %s",
                store.path,
                len(points),
                len(rows),
                backend.description,
                chosen,
            )
            counts = _loop(
                store, schedule, backend, by_index, rows, axes, progress, chosen, spec.multipliers
            )
        finally:
            # An interruption that escaped the loop's own draining abandons what runs.
            backend.close(cancel=True)
        seconds = time.perf_counter() - begin
        stats = {
            "solved": counts.solved,
            "failed": counts.failed,
            "lost": counts.lost,
            "seconds": seconds,
            "startup_seconds": startup,
            "points_per_minute": 60.0 * counts.done / seconds if counts.done else math.nan,
            "iterations": counts.iterations,
            "backend": backend.description,
            "ordering": chosen,
            "damaged": list(store.damaged),
        }
        return StudyResult.load(store.path, run=stats)


def _loop(store, schedule, backend, by_index, rows, axes, progress, chosen, multipliers) -> _Run:
    counts = _Run(begin=time.perf_counter())
    in_flight: dict[Any, tuple[int, ...]] = {}
    losses: dict[tuple[int, ...], int] = {}
    table = _Table(store, by_index, rows, list(axes))
    total = len(by_index)

    def report(row: dict[str, Any] | None) -> None:
        if progress is None:
            return
        elapsed = time.perf_counter() - counts.begin
        left = total - len(schedule.settled)
        eta = elapsed / counts.done * left if counts.done else None
        progress(
            StudyProgress(
                total=total,
                solved=len(schedule.solved),
                failed=len(schedule.failed),
                done_this_run=counts.done,
                running=len(in_flight),
                elapsed=elapsed,
                eta=eta,
                row=row,
                backend=backend.description,
                ordering=chosen,
            )
        )

    def settle(handle) -> dict[str, Any] | None:
        """Write what came back; returns its row (None for a point queued again)."""
        index = in_flight.pop(handle)
        point = by_index[index]
        try:
            result = backend.result(handle)
        except WorkerLost as exc:
            counts.lost += 1
            losses[index] = losses.get(index, 0) + 1
            if not exc.final and losses[index] < MAX_LOSSES:
                logger.warning("point %s lost with its worker (%s); queued again", point.id, exc)
                schedule.requeue(index)
                return None
            result = {"id": point.id, "row": _lost_row(point, exc), "record": None}
        row = result["row"]
        store.save(result)
        success = bool(row.get("success"))
        schedule.settle(index, success)
        table.add(row)
        counts.done += 1
        counts.solved += success
        counts.failed += not success
        counts.iterations += int(row.get("iterations") or 0)
        logger.info(
            "%s %s: %s in %s iterations from %s",
            point.id,
            point.values,
            row.get("status"),
            row.get("iterations"),
            row.get("start") or "-",
        )
        return row

    def fill() -> None:
        while len(in_flight) < backend.capacity:
            index = schedule.next_ready()
            if index is None and not in_flight and not schedule.running:
                index = schedule.unblock()
            if index is None:
                return
            point = by_index[index]
            starts = [
                None if s is None else store.start(by_index[s].id, multipliers)
                for s in schedule.starts(index)
            ]
            schedule.start(index)
            handle = backend.submit({"id": point.id, "values": point.values, "starts": starts})
            in_flight[handle] = index

    try:
        report(None)
        last_tick = time.perf_counter()
        while not schedule.finished:
            fill()
            if not in_flight:
                break
            rows = [settle(handle) for handle in backend.wait(list(in_flight), TICK_SECONDS)]
            fill()  # before reporting: the report counts the points now running
            for row in rows:
                if row is not None:
                    report(row)
            if time.perf_counter() - last_tick >= TICK_SECONDS:
                last_tick = time.perf_counter()
                report(None)
    except BaseException:
        # Ctrl-C or the progress callback: keep what the workers are finishing.
        logger.warning("study interrupted: writing the %d points in flight", len(in_flight))
        try:
            while in_flight:
                for handle in backend.wait(list(in_flight), TICK_SECONDS):
                    try:
                        settle(handle)
                    except Exception:  # a bug in one result must not lose the others
                        logger.exception("a point in flight failed while stopping")
        except KeyboardInterrupt:
            logger.warning("abandoning %d points in flight", len(in_flight))
        raise
    finally:
        table.write()
    return counts


def _lost_row(point: GridPoint, exc: BaseException) -> dict[str, Any]:
    return {
        "point": point.id,
        **point.values,
        "status": WORKER_LOST,
        "success": False,
        "start": "",
        "attempts": 0,
        "notes": f"the worker died {MAX_LOSSES} times or the engine gave up: {exc}",
    }


class _Table:
    """results.csv, rewritten atomically as points settle (throttled for large tables)."""

    def __init__(self, store: StudyFolder, by_index, rows, axes) -> None:
        self._store = store
        self._order = {p.id: k for k, p in enumerate(by_index.values())}
        self._rows = dict(rows)
        self._axes = axes
        self._written = -math.inf
        self._dirty = True

    def add(self, row: Mapping[str, Any]) -> None:
        self._rows[row["point"]] = dict(row)
        self._dirty = True
        now = time.perf_counter()
        if len(self._rows) <= TABLE_ROWS or now - self._written >= TABLE_SECONDS:
            self.write()

    def write(self) -> None:
        if not self._dirty:
            return
        rows = sorted(self._rows.values(), key=lambda r: self._order.get(r["point"], math.inf))
        self._store.write_table(rows, self._axes)
        self._written = time.perf_counter()
        self._dirty = False


__all__ = ["MAX_LOSSES", "run"]
