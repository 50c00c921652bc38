"""The trajectory file formats: CSV, JSON and NPZ, chosen by the file name's suffix.

* ``.csv``: a header ``t [s],psi_stance_shank [rad],...`` and one row per sample, nothing
  else, floats written with ``repr`` (shortest text that reads back bit for bit): plain
  readers take it with no options (``csv.reader``, ``pandas.read_csv(path)``: columns
  ``t [s]``, ...; ``numpy.genfromtxt(path, delimiter=",", names=True)``: fields ``t_s``,
  ``psi_stance_shank_rad``, ...). What a header cannot hold goes into the sidecar
  ``<file>.csv.meta.json`` beside it (``{"format", "version", "groups": {"state": [...],
  "control": [...], "extra": [...]}, "metadata": {...}}``), written with the file as a pair.
  The reader takes the sidecar when it is there; files of earlier versions, with ``# format
  / version / groups / metadata:`` comment lines before or after the header, read back too.
  Without either (a file made by hand) columns named ``M_*`` are controls, ``ddpsi_*``,
  ``F_*``, ``CoP_*``, ``Fx``, ``Fy`` extras and the rest states. The reader also takes the
  file back after a spreadsheet saved it again (a byte-order mark, CRLF line ends, rows
  padded with empty cells, quoted comment lines, columns reordered).
* ``.json``: ``{"format", "version", "metadata", "columns": [{"name", "unit", "group"}],
  "data": {name: [values]}}``, the time column being ``t`` [s] with group ``time``.
* ``.npz``: arrays ``time``, ``states``, ``controls``, ``extras`` (K, n_extras), the
  names/units as string arrays, ``metadata`` as a JSON string; read without pickle.

:func:`save` writes atomically (a temporary file in the same folder, then ``os.replace``):
nothing is half-written. :func:`load` reads back exactly what :func:`save` wrote.
``FORMATS`` lists the suffixes; the command line offers the same list.
"""

from __future__ import annotations

import csv
import errno as errno_module
import json
import math
import os
import re
import zipfile
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError
from planner.files import atomic_path
from planner.trajectory.errors import (
    TrajectoryFileError,
    TrajectoryFileNotFoundError,
    TrajectoryWriteError,
)

if TYPE_CHECKING:
    from planner.trajectory.channels import Channels

#: The ``format`` field written into every file, and the version this code writes and reads.
FORMAT_NAME = "anthropoid-planner trajectory"
FORMAT_VERSION = 1
#: File suffixes understood by ``save`` and ``load``.
FORMATS = (".csv", ".json", ".npz")

_GROUPS = ("state", "control", "extra")
_HEADER_CELL = re.compile(r"^(?P<name>[^\[\]]*?)\s*\[(?P<unit>[^\[\]]*)\]$")

Built = TypeVar("Built")

#: What to say about a write failure, by errno.
_WRITE_HINTS = {
    getattr(errno_module, name): hint
    for name, hint in (
        ("EACCES", "the folder is not writable; save elsewhere or change its permissions"),
        ("EPERM", "the folder is not writable; save elsewhere or change its permissions"),
        ("EROFS", "the file system is read-only; save elsewhere"),
        ("ENOSPC", "the disk is full; free space or save elsewhere"),
        ("EDQUOT", "the disk quota is exceeded; free space or save elsewhere"),
        ("EFBIG", "the file exceeds the size limit; write fewer samples"),
    )
    if hasattr(errno_module, name)
}


# ---- saving and loading -------------------------------------------------------------------
def save(trajectory: Channels, path: str | os.PathLike, rate_hz: float | None = None) -> Path:
    """Write ``trajectory`` to ``path`` in the format given by its suffix (see
    :meth:`planner.trajectory.Trajectory.save`); returns the path."""
    path = _as_path(path)
    suffix = _suffix(path)
    if not path.parent.is_dir():
        raise TrajectoryFileNotFoundError(
            f"{path}: cannot save, the folder {str(path.parent)!r} does not exist; create "
            "it first (e.g. os.makedirs)"
        )
    if path.is_dir():
        raise TrajectoryFileError(f"{path}: cannot save, this is a folder; give a file name")
    if rate_hz is not None:
        trajectory = trajectory.resample(rate_hz=rate_hz)
    writer, binary = _WRITERS[suffix]
    try:
        if suffix == ".csv":
            # The table and its sidecar as a pair: both written to temporary files, the
            # sidecar renamed just before the table (a failure before leaves the old pair).
            with atomic_path(path) as table:
                _write_into(table, lambda handle: writer(trajectory, handle), False)
                sidecar = sidecar_path(path)
                _atomic_write(sidecar, lambda handle: _write_sidecar(trajectory, handle), False)
            return path
        _atomic_write(path, lambda handle: writer(trajectory, handle), binary)
    except OSError as error:
        strerror = error.strerror or str(error)
        hint = _WRITE_HINTS.get(error.errno)
        raise TrajectoryWriteError(
            f"{path}: cannot save: {strerror}" + (f"; {hint}" if hint else ""),
            error.errno,
            strerror,
            str(path),
        ) from error
    return path


def load(
    path: str | os.PathLike, build: Callable[..., Built], infer_group: Callable[[str], str]
) -> Built:
    """Read the file at ``path`` and return ``build(**fields)`` (the Trajectory constructor's
    fields); a field that ``build`` refuses raises :class:`TrajectoryFileError` naming the
    file (see :meth:`planner.trajectory.Trajectory.load`). ``infer_group``: a column name ->
    "state", "control" or "extra", for a file made by hand without a groups line."""
    path = _as_path(path)
    suffix = _suffix(path)
    if not path.exists():
        raise TrajectoryFileNotFoundError(
            f"{path}: no such file (working folder {os.getcwd()!r}); check the path"
        )
    if path.is_dir():
        raise TrajectoryFileError(f"{path}: is a folder, not a trajectory file")
    fields = _READERS[suffix](path, infer_group)
    try:
        return build(**fields)
    except (DefinitionError, DefinitionTypeError) as error:
        raise TrajectoryFileError(f"{path}: {error}") from None


def _as_path(path: object) -> Path:
    if not isinstance(path, (str, os.PathLike)):
        raise DefinitionTypeError(
            f"`path`: must be a file path (str or pathlib.Path), got {path!r}"
        )
    return Path(path)


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise TrajectoryFileError(
            f"{path}: unknown trajectory format {path.suffix or '(no suffix)'!r}; the formats are "
            f"{', '.join(FORMATS)} (chosen by the file name's suffix)"
        )
    return suffix


def _atomic_write(path: Path, write: Callable[[Any], None], binary: bool) -> None:
    """Run ``write(handle)`` on a temporary file beside ``path``, then rename it over ``path``
    (:func:`planner.files.atomic_path`); the data reach the disk before the rename."""
    with atomic_path(path) as temporary:
        _write_into(temporary, write, binary)


def _write_into(temporary: str, write: Callable[[Any], None], binary: bool) -> None:
    with (
        open(temporary, "wb") if binary else open(temporary, "w", encoding="utf-8", newline="")
    ) as handle:
        write(handle)
        handle.flush()
        os.fsync(handle.fileno())


#: What follows a CSV file's name to name its sidecar.
SIDECAR_SUFFIX = ".meta.json"


def sidecar_path(path: str | os.PathLike) -> Path:
    """The sidecar of a CSV trajectory file: ``<file>.csv.meta.json`` beside it."""
    path = Path(path)
    return path.with_name(path.name + SIDECAR_SUFFIX)


def _write_sidecar(trajectory: Channels, handle) -> None:
    document = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "groups": _groups(trajectory),
        "metadata": trajectory.metadata,
    }
    handle.write(json.dumps(document, indent=1) + "\n")


def _float_text(values: np.ndarray) -> list[str]:
    # repr of a Python float is the shortest text that parses back to the same double.
    return [repr(v) for v in values.tolist()]


def _groups(trajectory: Channels) -> dict[str, list[str]]:
    return {
        "state": list(trajectory.state_names),
        "control": list(trajectory.control_names),
        "extra": list(trajectory.extras),
    }


def _write_csv(trajectory: Channels, handle) -> None:
    # The header and the rows, nothing else: what readers with no options take (the groups
    # and the metadata go to the sidecar).
    columns = trajectory.columns
    handle.write(",".join(f"{name} [{unit}]" for name, unit, _ in columns) + "\n")
    table = np.column_stack(
        [trajectory.time, trajectory.states, trajectory.controls, trajectory.extra_values]
    )
    for row in table.tolist():
        handle.write(",".join(map(repr, row)) + "\n")


def _write_json(trajectory: Channels, handle) -> None:
    # One line per column of data keeps the file readable without one line per number.
    parts = [
        "{",
        f'  "format": {json.dumps(FORMAT_NAME)},',
        f'  "version": {FORMAT_VERSION},',
        f'  "metadata": {json.dumps(trajectory.metadata)},',
        '  "columns": [',
        ",\n".join(
            f"    {json.dumps({'name': n, 'unit': u, 'group': g})}"
            for n, u, g in trajectory.columns
        ),
        "  ],",
        '  "data": {',
        ",\n".join(
            f"    {json.dumps(name)}: [{', '.join(_float_text(trajectory.column(name)))}]"
            for name, _, _ in trajectory.columns
        ),
        "  }",
        "}",
    ]
    handle.write("\n".join(parts) + "\n")


def _write_npz(trajectory: Channels, handle) -> None:
    def strings(values: Sequence[str]) -> np.ndarray:
        return np.array(list(values), dtype=str) if values else np.zeros(0, dtype="<U1")

    np.savez(
        handle,
        format=np.array(FORMAT_NAME),
        version=np.array(FORMAT_VERSION),
        time=trajectory.time,
        states=trajectory.states,
        controls=trajectory.controls,
        extras=trajectory.extra_values,
        state_names=strings(trajectory.state_names),
        state_units=strings(trajectory.state_units),
        control_names=strings(trajectory.control_names),
        control_units=strings(trajectory.control_units),
        extra_names=strings(tuple(trajectory.extras)),
        extra_units=strings(tuple(unit for _, unit in trajectory.extras.values())),
        metadata=np.array(json.dumps(trajectory.metadata)),
    )


#: Longest repr of a value from a file that an error message quotes in full.
SHOWN_CHARACTERS = 40


def shown(value: object, limit: int = SHOWN_CHARACTERS) -> str:
    """``repr(value)`` for an error message, cut to ``limit`` characters: a file may hold a
    400-digit integer or a megabyte string where a version or a name belongs."""
    if isinstance(value, int) and not isinstance(value, bool):
        try:
            text = str(value)
        except ValueError:  # beyond Python's int-to-str limit (4300 digits)
            return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
        digits = len(text.lstrip("-"))
        return text if len(text) <= limit else f"an integer of {digits} digits ({text[:12]}...)"
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


def _check_format(path: Path, where: str, name: object, version: object) -> None:
    if name != FORMAT_NAME:
        raise TrajectoryFileError(
            f"{path}: {where}: format is {shown(name)}, expected {FORMAT_NAME!r}; this is not "
            "a trajectory file written by Trajectory.save"
        )
    if isinstance(version, bool) or not isinstance(version, int):
        raise TrajectoryFileError(
            f"{path}: {where}: version must be an integer, got {shown(version)}"
        )
    if version > FORMAT_VERSION:
        raise TrajectoryFileError(
            f"{path}: {where}: format version {shown(version)} is newer than this library "
            f"reads ({FORMAT_VERSION}); upgrade anthropoid-planner"
        )
    if version < 1:
        raise TrajectoryFileError(f"{path}: {where}: unknown format version {shown(version)}")


def _assemble(
    path: Path,
    where: str,
    time: np.ndarray,
    names: Sequence[str],
    units: Sequence[str],
    values: Sequence[np.ndarray],
    groups: Mapping[str, Sequence[str]] | None,
    metadata: Any,
    infer_group: Callable[[str], str],
) -> dict[str, Any]:
    """Constructor fields from named columns, ordered by ``groups`` (or by name rules)."""
    by_name = dict(zip(names, zip(values, units, strict=True), strict=True))
    if groups is None:
        ordered = {g: [n for n in names if infer_group(n) == g] for g in _GROUPS}
    else:
        if (
            not isinstance(groups, Mapping)
            or set(groups) - set(_GROUPS)
            or not all(
                isinstance(v, list) and all(isinstance(s, str) for s in v) for v in groups.values()
            )
        ):
            raise TrajectoryFileError(
                f"{path}: {where}: groups must be an object {{'state': [names], 'control': "
                f"[names], 'extra': [names]}}, got {groups!r}"
            )
        ordered = {g: list(groups.get(g, [])) for g in _GROUPS}
        listed = [n for g in _GROUPS for n in ordered[g]]
        missing = [n for n in listed if n not in by_name]
        if missing:
            raise TrajectoryFileError(
                f"{path}: {where}: the columns {missing} listed in the groups are missing from "
                "the data; restore them, or delete the groups line to infer groups from names"
            )
        unlisted = [n for n in names if n not in listed]
        if unlisted:
            raise TrajectoryFileError(
                f"{path}: {where}: the columns {unlisted} are not listed in the groups; add "
                "them to the groups, or delete the groups line to infer groups from names"
            )

    def block(group: str) -> np.ndarray:
        chosen = ordered[group]
        if not chosen:
            return np.zeros((time.shape[0], 0))
        return np.stack([by_name[n][0] for n in chosen], axis=1)

    return {
        "time": time,
        "states": block("state"),
        "controls": block("control"),
        "state_names": tuple(ordered["state"]),
        "state_units": tuple(by_name[n][1] for n in ordered["state"]),
        "control_names": tuple(ordered["control"]),
        "control_units": tuple(by_name[n][1] for n in ordered["control"]),
        "extras": {n: by_name[n] for n in ordered["extra"]},
        "metadata": {} if metadata is None else metadata,
    }


def _read_text(path: Path) -> str:
    try:
        # utf-8-sig: spreadsheets save a byte-order mark in front of the header.
        return path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as error:
        raise TrajectoryFileError(
            f"{path}: not a UTF-8 text file (byte {error.start}); is it really a "
            f"{path.suffix} file?"
        ) from None
    except OSError as error:
        raise TrajectoryFileError(f"{path}: cannot be read: {error.strerror}") from None


def _read_csv(path: Path, infer_group: Callable[[str], str]) -> dict[str, Any]:
    text = _read_text(path)
    comments: dict[str, Any] = {}
    header: list[tuple[str, str]] | None = None
    header_line = 0
    rows: list[tuple[int, list[str]]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        cells = next(csv.reader([line]), [])
        # A spreadsheet that saves the file again pads short rows with empty cells and quotes
        # comment lines that hold commas or quotes: drop the padding, rebuild the comment.
        while cells and not cells[-1].strip():
            cells.pop()
        if not cells:
            continue
        if cells[0].lstrip().startswith("#"):
            if line.lstrip().startswith('"'):
                stripped = ",".join(cells).strip()
            else:  # a JSON value never ends in a comma: trailing ones are padding
                stripped = line.strip().rstrip(",").strip()
            key, colon, value = stripped[1:].partition(":")
            key = key.strip()
            # Before the header (files of earlier versions) or right after it (this one).
            if not rows and colon and key in ("format", "version", "groups", "metadata"):
                if key in comments:
                    raise TrajectoryFileError(
                        f"{path}: line {number}: a second `# {key}:` comment; keep one"
                    )
                try:
                    comments[key] = json.loads(value)
                except json.JSONDecodeError as error:
                    raise TrajectoryFileError(
                        f"{path}: line {number}: the `# {key}:` comment is not valid JSON "
                        f"({error.msg} at character {error.colno}); fix or delete the line"
                    ) from None
                except ValueError as error:  # an integer beyond the int-to-str limit
                    raise TrajectoryFileError(
                        f"{path}: line {number}: the `# {key}:` comment cannot be read "
                        f"({str(error).split(':')[0][:80]}); fix or delete the line"
                    ) from None
            continue
        if header is None:
            header_line = number
            header = []
            for column, cell in enumerate(cells, start=1):
                match = _HEADER_CELL.match(cell.strip())
                if not match or not match["name"] or not match["unit"].strip():
                    raise TrajectoryFileError(
                        f"{path}: line {number}, column {column}: header cell {cell!r} must "
                        "read `name [unit]`, e.g. `x [m]`; add the unit in brackets"
                    )
                header.append((match["name"], match["unit"].strip()))
            if header[0] != ("t", "s"):
                raise TrajectoryFileError(
                    f"{path}: line {number}, column 1: the first column must be `t [s]` (time "
                    f"in seconds), got {cells[0].strip()!r}; rename it or move the time "
                    "column first"
                )
            duplicates = sorted({n for n, _ in header if [h[0] for h in header].count(n) > 1})
            if duplicates:
                raise TrajectoryFileError(
                    f"{path}: line {number}: the header names {duplicates} more than once; "
                    "every column needs a unique name"
                )
            continue
        rows.append((number, cells))
    if "format" in comments or "version" in comments:
        _check_format(
            path,
            "the `# format:`/`# version:` comments",
            comments.get("format"),
            comments.get("version"),
        )
    if header is None:
        raise TrajectoryFileError(
            f"{path}: no header row; the first line that is not a # comment must be "
            "`t [s],name [unit],...`"
        )
    if len(rows) < 2:
        raise TrajectoryFileError(
            f"{path}: {len(rows)} data row(s) after the header on line {header_line}; a "
            "trajectory needs at least 2 samples"
        )
    table = np.empty((len(rows), len(header)))
    for r, (number, cells) in enumerate(rows):
        if len(cells) != len(header):
            raise TrajectoryFileError(
                f"{path}: line {number}: {len(cells)} cells, but the header on line "
                f"{header_line} has {len(header)} columns; every row needs one value per column"
            )
        for c, cell in enumerate(cells):
            try:
                value = float(cell)
            except ValueError:
                raise TrajectoryFileError(
                    f"{path}: line {number}, column {c + 1} (`{header[c][0]}`): {cell!r} is not "
                    "a number; every data cell must be a decimal number"
                ) from None
            if not math.isfinite(value):
                raise TrajectoryFileError(
                    f"{path}: line {number}, column {c + 1} (`{header[c][0]}`): must be finite, "
                    f"got {cell.strip()!r}; fill or remove the sample"
                )
            table[r, c] = value
    steps = np.diff(table[:, 0])
    if np.any(steps <= 0):
        r = int(np.argmax(steps <= 0)) + 1
        raise TrajectoryFileError(
            f"{path}: line {rows[r][0]}: time {float(table[r, 0])!r} s does not come after "
            f"{float(table[r - 1, 0])!r} s on line {rows[r - 1][0]}; rows must be in strictly "
            "increasing time, without duplicates"
        )
    names = [n for n, _ in header[1:]]
    where = "the `# groups:` comment"
    sidecar = sidecar_path(path)
    if sidecar.exists() and not comments:
        document = _read_sidecar(sidecar)
        comments = {"groups": document.get("groups"), "metadata": document.get("metadata")}
        where = f"the sidecar {sidecar.name}'s groups"
    return _assemble(
        path,
        where,
        table[:, 0],
        names,
        [u for _, u in header[1:]],
        [table[:, c] for c in range(1, len(header))],
        comments.get("groups"),
        comments.get("metadata"),
        infer_group,
    )


def _read_sidecar(path: Path) -> dict[str, Any]:
    """The sidecar of a CSV file: its groups and metadata, format checked."""
    try:
        document = json.loads(_read_text(path))
    except json.JSONDecodeError as error:
        raise TrajectoryFileError(
            f"{path}: the sidecar is not valid JSON ({error.msg} at line {error.lineno}); fix "
            "or delete it (the CSV then reads as a file made by hand)"
        ) from None
    if not isinstance(document, dict):
        raise TrajectoryFileError(f"{path}: the sidecar must hold a JSON object")
    _check_format(path, "the sidecar", document.get("format"), document.get("version"))
    return document


def _read_json(path: Path, infer_group: Callable[[str], str]) -> dict[str, Any]:
    text = _read_text(path)
    try:
        document = json.loads(text)
    except json.JSONDecodeError as error:
        raise TrajectoryFileError(
            f"{path}: line {error.lineno}, column {error.colno}: not valid JSON ({error.msg})"
        ) from None
    except ValueError as error:  # an integer beyond Python's int-to-str limit
        raise TrajectoryFileError(
            f"{path}: not a readable JSON trajectory ({str(error).split(':')[0][:80]}): "
            "a number in it has thousands of digits"
        ) from None
    if not isinstance(document, dict):
        raise TrajectoryFileError(
            f"{path}: the top level must be an object with format, version, metadata, columns "
            f"and data, got {type(document).__name__}"
        )
    missing = [k for k in ("format", "version", "columns", "data") if k not in document]
    if missing:
        raise TrajectoryFileError(
            f"{path}: missing key(s) {missing}; a trajectory file holds format, version, "
            "metadata, columns and data (write it with Trajectory.save)"
        )
    _check_format(path, "top level", document["format"], document["version"])
    columns, data = document["columns"], document["data"]
    if not isinstance(columns, list) or not isinstance(data, dict):
        raise TrajectoryFileError(
            f"{path}: `columns` must be a list of {{name, unit, group}} and `data` an object "
            "name -> list of numbers"
        )
    names, units, groups = [], [], {g: [] for g in _GROUPS}
    for i, column in enumerate(columns):
        if (
            not isinstance(column, dict)
            or not all(isinstance(column.get(k), str) for k in ("name", "unit", "group"))
            or column["group"] not in ("time", *_GROUPS)
        ):
            raise TrajectoryFileError(
                f"{path}: columns[{i}] must be {{'name': str, 'unit': str, 'group': one of "
                f"time, state, control, extra}}, got {column!r}"
            )
        names.append(column["name"])
        units.append(column["unit"])
        if column["group"] != "time":
            groups[column["group"]].append(column["name"])
    if not names or (names[0], units[0], columns[0]["group"]) != ("t", "s", "time"):
        raise TrajectoryFileError(
            f"{path}: columns[0] must be {{'name': 't', 'unit': 's', 'group': 'time'}}, got "
            f"{columns[0] if columns else 'no columns'!r}"
        )
    if len(set(names)) != len(names):
        raise TrajectoryFileError(f"{path}: `columns` names a column twice: {names}")
    arrays = []
    for name in names:
        if name not in data:
            raise TrajectoryFileError(
                f"{path}: data[{name!r}] is missing; every column listed in `columns` needs "
                "its list of values in `data`"
            )
        values = data[name]
        if not isinstance(values, list):
            raise TrajectoryFileError(f"{path}: data[{name!r}] must be a list of numbers")
        for k, v in enumerate(values):
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise TrajectoryFileError(
                    f"{path}: data[{name!r}][{k}] is {v!r}, not a number; every value must be "
                    "a number"
                )
            try:
                finite = math.isfinite(v)
            except OverflowError:  # an integer beyond the largest float
                finite = False
            if not finite:
                raise TrajectoryFileError(
                    f"{path}: data[{name!r}][{k}] must be finite, got {shown(v)}; fill "
                    "or remove the sample"
                )
        arrays.append(np.array(values, dtype=np.float64))
        if arrays[-1].shape != arrays[0].shape:
            raise TrajectoryFileError(
                f"{path}: data[{name!r}] has {arrays[-1].shape[0]} values but data['t'] has "
                f"{arrays[0].shape[0]}; every column needs one value per sample"
            )
    extra_keys = sorted(set(data) - set(names))
    if extra_keys:
        raise TrajectoryFileError(
            f"{path}: data holds {extra_keys} that `columns` does not describe; add them to "
            "`columns` or remove them"
        )
    return _assemble(
        path,
        "columns",
        arrays[0],
        names[1:],
        units[1:],
        arrays[1:],
        groups,
        document.get("metadata"),
        infer_group,
    )


#: The .npz arrays that hold names and units (1-D string arrays), and every array of the file.
_NPZ_STRING_KEYS = (
    "state_names",
    "state_units",
    "control_names",
    "control_units",
    "extra_names",
    "extra_units",
)
_NPZ_KEYS = (
    "format",
    "version",
    "time",
    "states",
    "controls",
    "extras",
    *_NPZ_STRING_KEYS,
    "metadata",
)


def _read_npz(path: Path, infer_group: Callable[[str], str]) -> dict[str, Any]:
    try:
        with np.load(path, allow_pickle=False) as archive:
            missing = [k for k in _NPZ_KEYS if k not in archive.files]
            if missing:
                raise TrajectoryFileError(
                    f"{path}: missing array(s) {missing}; write the file with Trajectory.save"
                )
            arrays = {k: archive[k] for k in _NPZ_KEYS}
    except TrajectoryFileError:
        raise
    except (zipfile.BadZipFile, ValueError, OSError, EOFError) as error:
        raise TrajectoryFileError(
            f"{path}: not a readable .npz archive ({error}); write it with Trajectory.save"
        ) from None
    name, version = arrays["format"], arrays["version"]
    scalar = name.ndim == 0 and version.ndim == 0  # not arrays of several values
    _check_format(
        path,
        "arrays format/version",
        str(name) if scalar and name.dtype.kind == "U" else name,
        int(version) if scalar and version.dtype.kind in "iu" else version,
    )
    strings = {}
    for key in _NPZ_STRING_KEYS:
        value = arrays[key]
        if value.ndim != 1 or (value.size and value.dtype.kind != "U"):
            raise TrajectoryFileError(
                f"{path}: array {key!r} must be a 1-D array of strings, got {value.dtype} "
                f"{value.shape}"
            )
        strings[key] = tuple(str(s) for s in value)
    try:
        metadata = json.loads(str(arrays["metadata"]))
    except json.JSONDecodeError as error:
        raise TrajectoryFileError(
            f"{path}: array 'metadata' is not valid JSON ({error.msg}); it must hold a JSON string"
        ) from None
    extras_table = arrays["extras"]
    if extras_table.ndim != 2 or extras_table.shape[1] != len(strings["extra_names"]):
        raise TrajectoryFileError(
            f"{path}: array 'extras' must have shape (K, {len(strings['extra_names'])}) for "
            f"the extra_names, got {extras_table.shape}"
        )
    if len(strings["extra_units"]) != len(strings["extra_names"]):
        raise TrajectoryFileError(
            f"{path}: arrays 'extra_names' and 'extra_units' differ in length"
        )
    return {
        "time": arrays["time"],
        "states": arrays["states"],
        "controls": arrays["controls"],
        "state_names": strings["state_names"],
        "state_units": strings["state_units"],
        "control_names": strings["control_names"],
        "control_units": strings["control_units"],
        "extras": {
            name: (extras_table[:, j], unit)
            for j, (name, unit) in enumerate(
                zip(strings["extra_names"], strings["extra_units"], strict=True)
            )
        },
        "metadata": metadata,
    }


_WRITERS: dict[str, tuple[Callable[[Channels, Any], None], bool]] = {
    ".csv": (_write_csv, False),
    ".json": (_write_json, False),
    ".npz": (_write_npz, True),
}
_READERS: dict[str, Callable[[Path, Callable[[str], str]], dict[str, Any]]] = {
    ".csv": _read_csv,
    ".json": _read_json,
    ".npz": _read_npz,
}


__all__ = ["FORMATS", "FORMAT_NAME", "FORMAT_VERSION", "load", "save"]
