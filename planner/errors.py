"""The product's error classes (planner, model and problems raise them).

Every error the project raises on purpose derives from :class:`AnthropoidError`, so a caller
can catch the library's own failures in one clause. Definition errors also derive from the
built-in ``ValueError``/``TypeError``, so code written against the standard exceptions works.

The ``check_*``/``as_*`` helpers below validate a user's value and raise these errors with a
message that names the field; model, planner and problems share them.
"""

from __future__ import annotations

import math
from numbers import Real

import numpy as np


class AnthropoidError(Exception):
    """Base class of every error raised on purpose by model, planner and problems."""


class DefinitionError(AnthropoidError, ValueError):
    """A value given to build an object is out of range, inconsistent or not finite."""


class DefinitionTypeError(AnthropoidError, TypeError):
    """A value given to build an object has the wrong type."""


def check_real(field: str, value: object) -> float:
    """Return ``value`` as a finite float, or raise naming ``field``.

    Booleans are refused although Python counts them as integers: ``mass=True`` is a mistake.
    """
    if isinstance(value, bool) or not isinstance(value, Real):
        raise DefinitionTypeError(
            f"`{field}`: must be a real number, got {value!r} of type {type(value).__name__}"
        )
    number = float(value)
    if not math.isfinite(number):
        raise DefinitionError(f"`{field}`: must be finite, got {number!r}; give a finite number")
    return number


def check_positive(field: str, value: object, unit: str = "") -> float:
    """Return ``value`` as a finite float > 0, or raise "`field`: must be > 0 <unit>, got ..."
    (types and non-finite values as :func:`check_real`)."""
    number = check_real(field, value)
    if number <= 0:
        raise DefinitionError(f"`{field}`: must be > 0{' ' + unit if unit else ''}, got {number!r}")
    return number


def check_integer(field: str, value: object, minimum: int, note: str = "") -> int:
    """Return ``value`` as an int >= ``minimum``, or raise naming ``field``: a
    DefinitionTypeError "`field`: must be an integer >= minimum, got ..." for a non-integer
    (booleans included), a DefinitionError "`field`: must be >= minimum, got ..." below it
    (``note``, e.g. "(0 keeps none)", is added after the bound)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise DefinitionTypeError(f"`{field}`: must be an integer >= {minimum}, got {value!r}")
    if value < minimum:
        bound = f">= {minimum}" + (f" {note}" if note else "")
        raise DefinitionError(f"`{field}`: must be {bound}, got {value!r}")
    return int(value)


def _refuse_booleans_and_complex(field: str, value: object, expected: str) -> None:
    """numpy turns booleans into 0/1 and drops imaginary parts (with only a warning) when
    it converts to float: both are mistakes here, refused by name."""
    try:
        kind = np.asarray(value).dtype.kind
    except (TypeError, ValueError):  # ragged or odd input: the float conversion reports it
        return
    if kind in "bc":
        what = "booleans" if kind == "b" else "complex numbers"
        raise DefinitionTypeError(
            f"`{field}`: must be {expected}, got {what}; give real numbers "
            "(numpy.real(...) or .astype(float) if that is what you mean)"
        )


def as_float_array(field: str, value: object, expected: str) -> np.ndarray:
    """Return ``value`` as a float numpy array, or raise DefinitionTypeError
    "`field`: must be <expected>, got <value>" (``expected``: e.g. "numeric of shape (6,)").
    Booleans and complex numbers are refused, not converted."""
    _refuse_booleans_and_complex(field, value, expected)
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DefinitionTypeError(f"`{field}`: must be {expected}, got {value!r}") from exc


def check_finite(field: str, array: np.ndarray, what: str = "values") -> None:
    """Raise DefinitionError "`field`: contains NaN or inf; give finite <what>" unless every
    entry of ``array`` is finite."""
    if not np.all(np.isfinite(array)):
        raise DefinitionError(f"`{field}`: contains NaN or inf; give finite {what}")


def check_states(field: str, value: object, size: int) -> np.ndarray:
    """Return ``value`` as a finite float array of shape (size,) (one state) or (K, size)
    (a batch), or raise naming ``field``, the shape expected and the shape given. Booleans
    and complex numbers are refused."""
    _refuse_booleans_and_complex(field, value, f"real numbers of shape ({size},) or (K, {size})")
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DefinitionTypeError(
            f"`{field}`: must be numeric of shape ({size},) or (K, {size}), got {value!r}"
        ) from exc
    if array.ndim not in (1, 2) or array.shape[-1] != size:
        raise DefinitionError(
            f"`{field}`: expected shape ({size},) or (K, {size}), got {array.shape}"
        )
    check_finite(field, array)
    return array
