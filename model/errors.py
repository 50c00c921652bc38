"""The library's error classes.

Every error the project raises on purpose derives from :class:`AnthropoidError`, so a caller
can catch the library's own failures in one clause. Definition errors also derive from the
built-in ``ValueError``/``TypeError``, so code written against the standard exceptions works.
"""

from __future__ import annotations

import math
from numbers import Real


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
