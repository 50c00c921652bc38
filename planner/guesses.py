"""Initial guesses of an OCP: layers of values, and what each gives at given times.

A :class:`GuessLayer` is one source of guesses (``OCP.guess``): constants, arrays on a time
grid, a callable of time (a gait law), or an earlier result (a :class:`planner.Solution` or
:class:`planner.Trajectory`: anything that is a :class:`SampledGuess`) re-gridded in
normalised time. Later layers override earlier
ones variable by variable; :func:`evaluate_guess_layer` gives a layer's values at the times
of a mesh (the transcription's initial guess) or at a few probe times (``OCP.guess`` checks a
callable when it is given).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError, as_float_array
from planner.system import System


@runtime_checkable
class SampledGuess(Protocol):
    """An earlier result that guesses another problem (a Solution, a Trajectory): its duration,
    s, and its values by name, (K,) each, at normalised times s = (t - t0) / duration."""

    @property
    def duration(self) -> float:
        """The time the result spans, s."""
        ...

    def interpolate_guess(self, s: np.ndarray) -> dict[str, np.ndarray]:
        """name -> (K,) values at the normalised times ``s`` (K,) in [0, 1]."""
        ...


@dataclass(frozen=True, eq=False)
class GuessLayer:
    """One source of initial guesses; later layers override earlier ones variable by variable.

    kind: "constant" (values: name -> float or array over a group), "grid" (times (K,) s and
    values: name -> (K,) or (K, group size)), "callable" (source: t (K,) -> dict or tuple),
    "solution" (source: a :class:`SampledGuess`, re-gridded in normalised time).
    """

    kind: str
    values: Mapping[str, np.ndarray] = field(default_factory=dict)
    times: np.ndarray | None = None
    source: Any = None

    def __repr__(self) -> str:
        if self.kind in ("constant", "grid"):
            return f"{self.kind}({', '.join(self.values)})"
        return f"{self.kind}({type(self.source).__name__})"


def evaluate_guess_layer(
    system: System,
    duration_guess: float,
    resolve: Callable[[str, str], tuple[str, ...]],
    layer: GuessLayer,
    times: np.ndarray,
) -> dict[str, np.ndarray]:
    """Values (name -> (K,)) that one guess layer gives at ``times`` (s), for an OCP of
    ``system`` whose duration is guessed ``duration_guess`` (s); ``resolve(key, field)``: the
    variable names a key of a guess function's dict stands for (``OCP.resolve``)."""
    K = times.size
    if layer.kind == "constant":
        return {name: np.full(K, float(v)) for name, v in layer.values.items()}
    if layer.kind == "grid":
        out = {}
        for name, values in layer.values.items():
            if layer.times.size == 1:
                out[name] = np.full(K, float(values[0]))
            else:
                out[name] = np.interp(times, layer.times, values)
        return out
    if layer.kind == "solution":
        values = layer.source.interpolate_guess(times / duration_guess)
        # Only what names a variable (or a derived field, which completes other guesses) of
        # this system: the source may be of another system.
        derived = {name for field in system.derived for name in field.names}
        return {n: v for n, v in values.items() if n in system.variable_names or n in derived}
    # callable of t
    try:
        result = layer.source(times)
    except Exception as exc:  # a user's law may fail in any way; say which guess failed
        raise DefinitionError(f"`guess`: calling the guess function failed: {exc!r}") from exc
    if isinstance(result, dict):
        items = list(result.items())
    elif isinstance(result, tuple | list):
        order = system.guess_order
        if len(result) > len(order):
            raise DefinitionError(
                f"`guess`: the function returned {len(result)} arrays; expected up to "
                f"{len(order)}: {order}"
            )
        items = list(zip(order, result, strict=False))
    else:
        raise DefinitionTypeError(
            "`guess`: the function must return a dict or a tuple "
            f"(of up to {len(system.guess_order)} arrays: {', '.join(system.guess_order)}), "
            f"got {type(result).__name__}"
        )
    out = {}
    for key, value in items:
        derived = system.derived_field(key)
        if derived is not None:
            # A derived field (explicit accelerations) is no variable, but its values may
            # still complete other guesses (torques by inverse dynamics): keep its names.
            names = derived.names
        elif key == "z" and system.group(key) is None:
            continue  # an explicit system has no auxiliary variables: nothing to guess
        else:
            names = resolve(key, "guess")
        array = as_float_array(f"guess[{key}]", value, "numeric")
        m = len(names)
        if array.ndim == 1 and m == 1 and array.size == K:
            array = array[:, None]
        elif array.ndim == 1 and K == 1 and array.size == m:
            array = array[None, :]
        if array.shape != (K, m):
            per_time = (
                f": {array.shape[1]} values per time where `{key}` has {m} "
                f"({', '.join(names)}); a guess (a gait law) for another system?"
                if array.ndim == 2 and array.shape[0] == K
                else ""
            )
            raise DefinitionError(
                f"`guess[{key}]`: the function returned shape {array.shape} for {K} times; "
                f"expected ({K}, {m}){per_time}"
            )
        if not np.all(np.isfinite(array)):
            raise DefinitionError(f"`guess[{key}]`: the function returned NaN or inf")
        for i, name in enumerate(names):
            out[name] = array[:, i]
    return out


__all__ = ["GuessLayer", "SampledGuess", "evaluate_guess_layer"]
