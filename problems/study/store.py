"""The study folder: what a study has solved, written so that nothing is lost or half-written.

Layout::

    study.json          the study's definition and its fingerprint (written once)
    results.csv         one row per settled point, in grid order (rewritten as points arrive)
    points/<id>.npz     a point's record: its table row (JSON) and, for a solved point, its
                        NLP iterate and multipliers in physical units (exact warm starts)
    solutions/<id>.npz  a solved point's gait at its nodes (``planner.LinkageTrajectory.load``: to
                        plot, export, simulate, or guess another OCP from)
    *.png               the plots (``problems.study.plots``)

Every file is written to a temporary file in the same folder and renamed over its name when
complete (``planner.files.atomic_path``), records and the table flushed to disk first. A
point's record is written after its solution: a point is settled exactly when its record
exists, so a run killed at any instant leaves settled points with complete files and
unsettled ones to solve again (a solution file without a record is overwritten). Temporary
files a killed run left behind are removed when the folder is opened again; a record or
solution file that cannot be read (a disk that failed, a copy cut short) is reported with its
path, moved aside as ``<name>.damaged`` and its point solved again.

One run at a time holds a folder: an advisory lock (``flock``) on the folder itself, held by
the study's process alone (closed in every process forked from it: the pool's workers), so it
is released the moment that process ends, however it ends, and the same command resumes at
once. A folder that is refused (another study's, or not a study folder) is left exactly as it
was: the checks read it before anything is written.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import logging
import os
import re
import zipfile
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import AnthropoidError, DefinitionError
from planner.files import atomic_path

logger = logging.getLogger("problems.study.study")

try:  # POSIX advisory locks; elsewhere a folder is not locked
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

FORMAT = "anthropoid-planner study 1"
DEFINITION_FILE = "study.json"
TABLE_FILE = "results.csv"
#: The lock file of earlier versions (the lock is now on the folder itself).
LOCK_FILE = "study.lock"
#: What a damaged file is renamed with.
DAMAGED = ".damaged"
POINTS = "points"
SOLUTIONS = "solutions"
#: Columns before the outputs and after them, in this order; outputs come in between in the
#: order the first rows give them.
HEAD = ("point", "status", "success", "start", "attempts")
TAIL = (
    "iterations",
    "build_seconds",
    "solve_seconds",
    "seconds",
    "cpu_seconds",
    "worker",
    "notes",
)
#: Temporary files of ``atomic_path``: ".<name>.<random><suffix>".
_TEMPORARY = re.compile(r"^\.(.+)\.[A-Za-z0-9_]{8}(\.tmp|\.npz|\.csv|\.json|\.png)$")


class StudyFolderError(DefinitionError):
    """A study folder that cannot be used: it holds another study, or another run holds it."""


class StudyFileError(AnthropoidError):
    """A file of a study folder is malformed (its name and what is wrong in the message)."""


def fingerprint(definition: Mapping[str, Any]) -> str:
    """SHA-256 of the definition's canonical JSON."""
    text = json.dumps(definition, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _differences(old: Any, new: Any, where: str = "") -> list[str]:
    """Dotted paths where two JSON values differ (the first few)."""
    if isinstance(old, dict) and isinstance(new, dict):
        out = []
        for key in sorted(set(old) | set(new), key=str):
            path = f"{where}.{key}" if where else str(key)
            if key not in old or key not in new:
                out.append(path)
            else:
                out.extend(_differences(old[key], new[key], path))
        return out
    if isinstance(old, list) and isinstance(new, list) and len(old) == len(new):
        out = []
        for k, (a, b) in enumerate(zip(old, new, strict=True)):
            out.extend(_differences(a, b, f"{where}.{k}" if where else str(k)))
        return out
    return [] if old == new else [where or "definition"]


_ABSENT = object()


def _describe(value: Any) -> str:
    if value is _ABSENT:
        return "(absent)"
    if isinstance(value, list) and len(value) > 4:
        return f"{len(value)} values {value[0]!r} .. {value[-1]!r}"
    text = json.dumps(value, sort_keys=True)
    return text if len(text) <= 80 else text[:77] + "..."


def _lookup(definition: Any, path: str) -> Any:
    for key in path.split("."):
        if isinstance(definition, dict) and key in definition:
            definition = definition[key]
        elif isinstance(definition, list) and key.isdigit() and int(key) < len(definition):
            definition = definition[int(key)]
        else:
            return _ABSENT
    return definition


def _write_bytes(path: Path, data: bytes) -> None:
    with atomic_path(path, suffix=path.suffix) as temporary, open(temporary, "wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())


class StudyFolder:
    """A study's folder, opened for one run (or read by :meth:`read`).

    ``StudyFolder(path, definition)`` creates the folder for a new study or checks that it
    holds the same study (:class:`StudyFolderError` naming what changed otherwise), takes its
    lock and removes the temporary files of a killed run. ``close()`` releases the lock.
    """

    def __init__(self, path: str | os.PathLike, definition: Mapping[str, Any]) -> None:
        self.path = Path(os.fspath(path))
        self.definition = dict(definition)
        self._lock: int | None = None
        self.damaged: list[str] = []
        if self.path.exists() and not self.path.is_dir():
            raise StudyFolderError(f"`folder`: {str(self.path)!r} exists and is not a folder")
        try:
            if self.path.exists():
                self._check()  # before anything is written: a refused folder stays as it was
            # A symbolic link is followed (a dangling one's target is made).
            Path(os.path.realpath(self.path)).mkdir(parents=True, exist_ok=True)
            self._lock = self._take_lock()
            try:
                self._check_or_create()  # again, now that this run holds the folder
                (self.path / POINTS).mkdir(exist_ok=True)
                (self.path / SOLUTIONS).mkdir(exist_ok=True)
                self._remove_temporary_files()
                self.damaged = self._set_damaged_aside()
            except BaseException:
                self.close()
                raise
        except OSError as error:
            # Before any point is solved: a folder that cannot be read, made or written.
            raise StudyFolderError(
                f"`folder`: cannot use {str(self.path)!r} ({error.strerror or error}"
                f"{_which(error, self.path)}); give a folder you can write"
            ) from None

    # ---- opening ---------------------------------------------------------------------
    def _take_lock(self) -> int | None:
        if fcntl is None:  # pragma: no cover - Windows
            return None
        descriptor = os.open(self.path, os.O_RDONLY)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(descriptor)
            raise StudyFolderError(
                f"`folder`: another run is using {str(self.path)!r} (it holds the folder's "
                "lock); wait for it to finish or stop it, or give another folder"
            ) from None
        _HELD.add(descriptor)
        return descriptor

    def close(self) -> None:
        """Release the folder's lock."""
        if self._lock is not None:
            _HELD.discard(self._lock)
            with contextlib.suppress(OSError):
                fcntl.flock(self._lock, fcntl.LOCK_UN)
            with contextlib.suppress(OSError):
                os.close(self._lock)
            self._lock = None

    def __enter__(self) -> StudyFolder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _check(self) -> bool:
        """Refuse a folder that holds another study or is not a study folder (reading only);
        True when it holds this study already."""
        path = self.path / DEFINITION_FILE
        if not path.exists():
            if any(self.path.iterdir()) and not self._only_lock():
                raise StudyFolderError(
                    f"`folder`: {str(self.path)!r} is not empty and holds no {DEFINITION_FILE}: "
                    "it is not a study folder; give a new or empty folder"
                )
            return False
        saved = read_definition(self.path)
        stamp = fingerprint(self.definition)
        if saved["fingerprint"] == stamp:
            return True
        changed = _differences(saved["definition"], json.loads(json.dumps(self.definition)))
        shown = "; ".join(
            f"{key}: {_describe(_lookup(saved['definition'], key))} in the folder, "
            f"{_describe(_lookup(self.definition, key))} now"
            for key in changed[:3]
        )
        more = f" (and {len(changed) - 3} more)" if len(changed) > 3 else ""
        raise StudyFolderError(
            f"`folder`: {str(self.path)!r} holds another study ({shown or 'the definition'}"
            f"{more}); results of two studies are not mixed: give another folder, or delete "
            "this one to start over"
        )

    def _check_or_create(self) -> None:
        if self._check():
            return
        content = {
            "format": FORMAT,
            "fingerprint": fingerprint(self.definition),
            "definition": self.definition,
        }
        path = self.path / DEFINITION_FILE
        _write_bytes(path, (json.dumps(content, indent=1, sort_keys=True) + "\n").encode())

    def _only_lock(self) -> bool:
        """The folder holds nothing but an earlier version's lock file."""
        return [p.name for p in self.path.iterdir()] == [LOCK_FILE]

    def _set_damaged_aside(self) -> list[str]:
        """Records that cannot be read, and solved points whose solution file cannot, moved
        aside (``<name>.damaged``) so that their points are solved again; their paths."""
        damaged = []
        for record in sorted((self.path / POINTS).glob("*.npz")):
            if record.name.startswith("."):
                continue
            problem = _damage(record, ("row",))
            solution = self.solution_path(record.stem)
            if problem is None:
                try:
                    with np.load(record, allow_pickle=False) as data:
                        solved = bool(json.loads(str(data["row"])).get("success"))
                except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError):
                    solved = False
                if solved:
                    trouble = _damage(solution, ("time", "states", "controls"))
                    if trouble is not None:
                        problem = f"its solution {solution.name}: {trouble}"
            if problem is None:
                continue
            for path in (record, solution):
                if path.exists():
                    os.replace(path, path.with_name(path.name + DAMAGED))
            logger.warning(
                "study record %s cannot be read (%s): moved aside as %s, its point is solved again",
                record,
                problem,
                record.name + DAMAGED,
            )
            damaged.append(str(record))
        return damaged

    def _remove_temporary_files(self) -> None:
        for folder in (self.path, self.path / POINTS, self.path / SOLUTIONS):
            for item in folder.iterdir():
                if item.is_file() and _TEMPORARY.match(item.name):
                    with contextlib.suppress(FileNotFoundError):
                        item.unlink()

    # ---- points ----------------------------------------------------------------------
    def record_path(self, point_id: str) -> Path:
        return self.path / POINTS / f"{point_id}.npz"

    def solution_path(self, point_id: str) -> Path:
        return self.path / SOLUTIONS / f"{point_id}.npz"

    def rows(self, ids: Iterable[str] | None = None) -> dict[str, dict[str, Any]]:
        """The table rows of the settled points (all, or those of ``ids`` that are)."""
        return read_rows(self.path, ids)

    def save(self, result: Mapping[str, Any]) -> None:
        """Write a point's result (``problems.study.point.solve_point``): its solution,
        then its record (which settles it)."""
        point_id = result["id"]
        if result.get("trajectory") is not None:
            _write_bytes(self.solution_path(point_id), result["trajectory"])
        arrays: dict[str, Any] = {"row": np.array(json.dumps(result["row"], allow_nan=True))}
        record = result.get("record")
        if record is not None:
            for key, value in record.items():
                arrays[key] = np.asarray(value)
        buffer = io.BytesIO()
        np.savez(buffer, **arrays)
        _write_bytes(self.record_path(point_id), buffer.getvalue())

    def start(self, point_id: str, multipliers: bool = True) -> dict[str, Any]:
        """A solved point as a warm start: its record's arrays (without the multipliers
        unless ``multipliers``) and its trajectory's bytes."""
        skip = {"row"} if multipliers else {"row", "lam_x", "lam_g"}
        with np.load(self.record_path(point_id), allow_pickle=False) as data:
            start: dict[str, Any] = {key: data[key] for key in data.files if key not in skip}
        start["signature"] = str(start["signature"])
        start["objective_scale"] = float(start["objective_scale"])
        start["cost"] = float(start["cost"])
        start["trajectory"] = self.solution_path(point_id).read_bytes()
        start["id"] = point_id
        return start

    def write_table(self, rows: Sequence[Mapping[str, Any]], axes: Sequence[str]) -> Path:
        """Rewrite results.csv with ``rows`` (in grid order) atomically."""
        return write_table(self.path / TABLE_FILE, rows, axes)


def _damage(path: Path, keys: Sequence[str]) -> str | None:
    """Why an NPZ file cannot be read (missing, not a zip, cut short, without ``keys``), or
    None when it reads."""
    if not path.exists():
        return "missing"
    try:
        with np.load(path, allow_pickle=False) as data:
            for key in keys:
                np.asarray(data[key])
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as exc:
        return f"{type(exc).__name__}: {exc}"
    return None


#: Lock descriptors this process holds; a forked child closes them (os.register_at_fork) so
#: that the lock stays the coordinating process's alone.
_HELD: set[int] = set()


def _close_inherited_locks() -> None:
    # Closing the child's copy only: unlocking would release the parent's lock too (one
    # open file description).
    for descriptor in list(_HELD):
        with contextlib.suppress(OSError):
            os.close(descriptor)
    _HELD.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_close_inherited_locks)


def _which(error: OSError, folder: Path) -> str:
    """ ": <file>" for an OSError about a file inside ``folder`` ("" for the folder)."""
    if error.filename is None:
        return ""
    name = Path(os.fsdecode(error.filename))
    return "" if name in (folder, Path(os.path.realpath(folder))) else f": {str(name)!r}"


def read_definition(folder: str | os.PathLike) -> dict[str, Any]:
    """study.json of a study folder: {"format", "fingerprint", "definition"}; refused
    (:class:`StudyFileError`) when its definition no longer matches its fingerprint (the file
    was edited: the records are those of the definition it was written with)."""
    path = Path(os.fspath(folder)) / DEFINITION_FILE
    try:
        content = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise StudyFileError(f"{str(path)!r}: no such file; is this a study folder?") from None
    except (OSError, ValueError) as exc:
        raise StudyFileError(f"{str(path)!r}: cannot be read as JSON: {exc}") from exc
    if not isinstance(content, dict) or content.get("format") != FORMAT:
        raise StudyFileError(f"{str(path)!r}: not a study definition of format {FORMAT!r}")
    definition = content.get("definition")
    if not isinstance(definition, dict) or fingerprint(definition) != content.get("fingerprint"):
        raise StudyFileError(
            f"{str(path)!r}: its definition was changed after the study was written (it no "
            "longer matches its fingerprint), so its axes and settings do not describe the "
            "points solved in the folder; put the file back as it was, or start the study in "
            "a new folder"
        )
    return content


def read_rows(
    folder: str | os.PathLike, ids: Iterable[str] | None = None
) -> dict[str, dict[str, Any]]:
    """The rows of the settled points of a study folder, by point id (from the records)."""
    points = Path(os.fspath(folder)) / POINTS
    if ids is None:
        paths = sorted(p for p in points.glob("*.npz") if not p.name.startswith("."))
    else:
        paths = [points / f"{i}.npz" for i in ids]
    rows = {}
    for path in paths:
        if not path.exists():
            continue
        try:
            with np.load(path, allow_pickle=False) as data:
                row = json.loads(str(data["row"]))
        except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as exc:
            raise StudyFileError(f"{str(path)!r}: not a study point record ({exc})") from exc
        rows[path.stem] = row
    return rows


def columns(rows: Sequence[Mapping[str, Any]], axes: Sequence[str]) -> list[str]:
    """The table's columns: point, the axes, status..., the outputs, iterations..., notes."""
    fixed = [*HEAD[:1], *axes, *HEAD[1:]]
    seen = dict.fromkeys(fixed)
    middle = {}
    for row in rows:
        for key in row:
            if key not in seen and key not in TAIL:
                middle.setdefault(key, None)
    return [*fixed, *middle, *TAIL]


def write_table(path: Path, rows: Sequence[Mapping[str, Any]], axes: Sequence[str]) -> Path:
    """``rows`` as CSV (header of column names, full-precision numbers, empty cells for
    missing values), written atomically."""
    names = columns(rows, axes)
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(names)
    for row in rows:
        writer.writerow(["" if row.get(name) is None else row.get(name) for name in names])
    _write_bytes(Path(path), text.getvalue().encode())
    return Path(path)


__all__ = [
    "DEFINITION_FILE",
    "FORMAT",
    "POINTS",
    "SOLUTIONS",
    "TABLE_FILE",
    "StudyFileError",
    "StudyFolder",
    "StudyFolderError",
    "columns",
    "fingerprint",
    "read_definition",
    "read_rows",
    "write_table",
]
