"""Validation of what a trajectory is made of: sample arrays, channel names and units,
JSON-serialisable metadata. Each check raises :class:`planner.errors.DefinitionError` or
:class:`planner.errors.DefinitionTypeError` naming the field, the value and the fix."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError

#: Characters a channel name or unit may not hold: they would break the CSV header
#: ``name [unit]`` (comma, quote, brackets), the comment convention (#) or a line.
FORBIDDEN = frozenset(',"[]#\n\r')


def float_array(
    where: str,
    value: object,
    ndim: int,
    columns: Sequence[str] | None = None,
    finite: bool = True,
) -> np.ndarray:
    """Return ``value`` as a read-only float64 copy with ``ndim`` dimensions, all finite.

    ``columns`` names the columns of a 2-D array, so that a non-finite entry is reported by
    channel name.
    """
    if isinstance(value, (str, bytes)):
        raise DefinitionTypeError(
            f"`{where}`: must be an array of real numbers, got the string {value!r}"
        )
    try:
        array = np.asarray(value)
    except (ValueError, TypeError) as error:  # ragged nested lists
        raise DefinitionError(
            f"`{where}`: cannot be read as an array ({error}); give a rectangular array"
        ) from None
    if array.dtype.kind not in "iuf":
        kind = {"b": "booleans", "c": "complex numbers"}.get(array.dtype.kind, str(array.dtype))
        raise DefinitionTypeError(
            f"`{where}`: must hold real numbers, got an array of {kind}; "
            "convert it with numpy.asarray(..., dtype=float)"
        )
    if array.ndim != ndim:
        shape = "(K,)" if ndim == 1 else "(K, n)"
        fix = "; use .reshape(-1, 1) for a single channel" if ndim == 2 and array.ndim == 1 else ""
        raise DefinitionError(
            f"`{where}`: must be a {ndim}-D array of shape {shape}, got shape {array.shape}{fix}"
        )
    array = np.array(array, dtype=np.float64)
    if finite:
        check_finite_array(where, array, columns)
    array.setflags(write=False)
    return array


def check_finite_array(where: str, array: np.ndarray, columns: Sequence[str] | None = None) -> None:
    """Raise naming the first non-finite entry (by channel name when ``columns`` are given)."""
    bad = np.argwhere(~np.isfinite(array))
    if bad.size:
        index = tuple(int(i) for i in bad[0])
        if array.ndim == 2 and columns is not None and index[1] < len(columns):
            place = f"at sample {index[0]}, column {index[1]} (`{columns[index[1]]}`)"
        else:
            place = f"at index {index if array.ndim > 1 else index[0]}"
        raise DefinitionError(
            f"`{where}`: must be finite, got {float(array[index])!r} {place} "
            f"({len(bad)} non-finite value(s) in all); remove or fill those samples"
        )


def check_label(where: str, value: object, what: str) -> str:
    """A channel name or unit: a non-empty string without CSV/comment-breaking characters."""
    if not isinstance(value, str):
        raise DefinitionTypeError(f"`{where}`: must be a string ({what}), got {value!r}")
    if not value.strip() or value != value.strip():
        raise DefinitionError(
            f"`{where}`: must be a non-empty {what} without leading or trailing spaces, "
            f"got {value!r}" + ("; use '1' for a dimensionless quantity" if what == "unit" else "")
        )
    bad = sorted(FORBIDDEN.intersection(value))
    if bad:
        raise DefinitionError(
            f"`{where}`: {what} {value!r} contains {''.join(bad)!r}; the characters "
            f"{''.join(sorted(FORBIDDEN))!r} would break the CSV header, remove them"
        )
    return value


def labels(where: str, value: object, count: int, what: str) -> tuple[str, ...]:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise DefinitionTypeError(
            f"`{where}`: must be a tuple of {count} strings ({what}s), got {value!r}"
        )
    if len(value) != count:
        raise DefinitionError(
            f"`{where}`: must have one {what} per column ({count}), got {len(value)}: "
            f"{tuple(value)!r}"
        )
    return tuple(check_label(f"{where}[{i}]", v, what) for i, v in enumerate(value))


def jsonable(value: Any, where: str) -> Any:
    """A copy of ``value`` made of JSON types only (numpy scalars and arrays converted).

    Non-finite floats are kept: Python's json module writes and reads them (NaN, Infinity),
    and a failed solve's cost may be NaN.
    """
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        return float(value)
    if isinstance(value, np.generic):
        return jsonable(value.item(), where)
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist(), where)
    if isinstance(value, Mapping):
        out = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise DefinitionTypeError(
                    f"`{where}`: keys must be strings (JSON objects), got {key!r}; use str(key)"
                )
            out[key] = jsonable(item, f"{where}[{key!r}]")
        return out
    if isinstance(value, (list, tuple)):
        return [jsonable(item, f"{where}[{i}]") for i, item in enumerate(value)]
    raise DefinitionTypeError(
        f"`{where}`: must be JSON-serialisable (dict, list, str, number, bool or None), got "
        f"{value!r} of type {type(value).__name__}; convert it first, e.g. with str()"
    )


__all__ = [
    "FORBIDDEN",
    "check_finite_array",
    "check_label",
    "float_array",
    "jsonable",
    "labels",
]
