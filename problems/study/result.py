"""A study's results as data: the grid, its points, and the table read back from a folder.

:class:`StudyResult` is what :meth:`problems.Study.run` returns and what
:meth:`StudyResult.load` reads from any study folder (also one a run is still writing, or one
an interrupted run left): the axes, the settled points' rows in grid order, their columns as
numpy arrays laid out on the grid, the failed and the missing points, and each solved point's
gait as a :class:`planner.Trajectory`. :class:`StudyProgress` is what a run reports while it
goes.
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from model import LinkageTrajectory
from planner import Trajectory
from planner.errors import DefinitionError
from problems.study.store import SOLUTIONS, read_definition, read_rows


@dataclass(frozen=True)
class GridPoint:
    """One point of a study's grid: its indices along the axes, its id (the file names of
    its record and solution), and its values by axis name."""

    index: tuple[int, ...]
    id: str
    values: dict[str, Any]


def grid_points(axes: Mapping[str, Sequence[Any]]) -> list[GridPoint]:
    """Every point of the grid spanned by ``axes`` (name -> values), in grid order (the last
    axis fastest). Ids read "p<i>_<j>..." with zero-padded indices, e.g. p03_12."""
    names = list(axes)
    sizes = [len(axes[name]) for name in names]
    widths = [len(str(max(size - 1, 0))) for size in sizes]
    points = []
    for index in itertools.product(*(range(size) for size in sizes)):
        label = "p" + "_".join(f"{i:0{w}d}" for i, w in zip(index, widths, strict=True))
        values = {name: axes[name][i] for name, i in zip(names, index, strict=True)}
        points.append(GridPoint(tuple(index), label, values))
    return points


@dataclass(frozen=True)
class StudyProgress:
    """A run's progress, reported after every settled point and about twice a second.

    total : points in the grid; solved, failed : settled so far (this run and earlier ones);
    done_this_run : points this run settled; running : points in flight; elapsed : seconds
    since this run started; eta : estimated seconds left (None until this run settled a
    point); row : the row of the point just settled (None for a periodic report);
    backend, ordering : where and in which order the points run.
    """

    total: int
    solved: int
    failed: int
    done_this_run: int
    running: int
    elapsed: float
    eta: float | None
    row: dict[str, Any] | None = None
    backend: str = ""
    ordering: str = ""

    @property
    def settled(self) -> int:
        return self.solved + self.failed

    @property
    def missing(self) -> int:
        return self.total - self.settled


@dataclass(frozen=True)
class StudyResult:
    """The settled points of a study folder.

    folder : the study folder; axes : name -> values, as defined; rows : the settled points'
    rows in grid order (the table results.csv holds); run : what the run that returned this
    measured (None for :meth:`load`): points solved, failed and lost (worker deaths) in it,
    seconds (wall time, with startup_seconds of starting the workers or the cluster), points
    per minute over those seconds, IPOPT iterations, backend, ordering.
    """

    folder: Path
    axes: dict[str, tuple]
    rows: tuple[dict[str, Any], ...]
    run: dict[str, Any] | None = None
    _points: list[GridPoint] = field(default_factory=list, repr=False, compare=False)

    @classmethod
    def load(cls, folder: str | os.PathLike, run: dict[str, Any] | None = None) -> StudyResult:
        """Read the study in ``folder`` (``problems.study.store.StudyFileError`` if it is
        not one)."""
        folder = Path(os.fspath(folder))
        definition = read_definition(folder)["definition"]
        order = definition.get("axis_order", list(definition["axes"]))
        axes = {name: tuple(definition["axes"][name]) for name in order}
        points = grid_points(axes)
        rows = read_rows(folder)
        ordered = tuple(rows[p.id] for p in points if p.id in rows)
        return cls(folder, axes, ordered, run, points)

    # ---- the grid --------------------------------------------------------------------
    @property
    def points(self) -> list[GridPoint]:
        return self._points or grid_points(self.axes)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(values) for values in self.axes.values())

    @property
    def total(self) -> int:
        return math.prod(self.shape)

    @property
    def solved(self) -> list[dict[str, Any]]:
        """Rows of the points that converged."""
        return [row for row in self.rows if row.get("success")]

    @property
    def failed(self) -> list[dict[str, Any]]:
        """Rows of the points that failed, with IPOPT's status (``status``) and what was
        tried (``notes``)."""
        return [row for row in self.rows if not row.get("success")]

    @property
    def missing(self) -> list[GridPoint]:
        """Points not settled yet (an interrupted run): run the study again to solve them."""
        settled = {row["point"] for row in self.rows}
        return [p for p in self.points if p.id not in settled]

    @property
    def columns(self) -> list[str]:
        names: dict[str, None] = {}
        for row in self.rows:
            names.update(dict.fromkeys(row))
        return list(names)

    def column(self, name: str) -> np.ndarray:
        """``name`` over the rows (in grid order): floats (NaN where empty), or objects for
        text columns."""
        if name not in self.columns:
            raise DefinitionError(f"`name`: no column {name!r}; columns: {self.columns}")
        values = [row.get(name) for row in self.rows]
        if all(v is None or isinstance(v, int | float) for v in values):
            return np.array([math.nan if v is None else float(v) for v in values])
        return np.array(values, dtype=object)

    def grid(self, name: str) -> np.ndarray:
        """``name`` laid out on the grid (shape :attr:`shape`), NaN where a point failed,
        is missing or has no value; an output of the solved points only."""
        if name not in self.columns:
            raise DefinitionError(f"`name`: no column {name!r}; columns: {self.columns}")
        out = np.full(self.shape, math.nan)
        by_id = {row["point"]: row for row in self.rows}
        for point in self.points:
            row = by_id.get(point.id)
            if row is None or not row.get("success"):
                continue
            value = row.get(name)
            if isinstance(value, bool | int | float):
                out[point.index] = float(value)
        return out

    def status_grid(self) -> np.ndarray:
        """The grid of states: "solved", "failed" or "missing" (object array)."""
        out = np.full(self.shape, "missing", dtype=object)
        by_id = {row["point"]: row for row in self.rows}
        for point in self.points:
            row = by_id.get(point.id)
            if row is not None:
                out[point.index] = "solved" if row.get("success") else "failed"
        return out

    def solution(self, point_id: str) -> Trajectory:
        """The gait of a solved point at its nodes (psi, dpsi, M, ddpsi, Fx, Fy and the
        step's settings in the metadata): a guess for another OCP, or something to plot,
        export or simulate."""
        path = self.folder / SOLUTIONS / f"{point_id}.npz"
        if not path.exists():
            raise DefinitionError(
                f"`point_id`: no solution {point_id!r} in {str(self.folder)!r} (a failed or "
                "missing point, or no such point)"
            )
        return LinkageTrajectory.load(path)


__all__ = ["GridPoint", "StudyProgress", "StudyResult", "grid_points"]
