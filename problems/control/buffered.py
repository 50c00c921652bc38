"""CasADi Functions evaluated one state at a time through their evaluation buffer.

The hybrid simulation and the return map call a few small functions once per control period
(the RK4 period, the hip's and the swing foot's positions), hundreds of times a step. Through
``Function.__call__`` each call converts its numpy arguments to CasADi matrices and back, which
costs more than the evaluation (scratch timings of 2000 calls): the six-link walker's RK4
period takes about 85 us so and 19 us through the buffer, a point's position 45 us through
:meth:`model.dynamics.Dynamics.evaluate` (its batch handling and finiteness checks) and a few
us here. The arguments are
copied into arrays the buffer reads in place, the results copied out of the arrays it writes.

One buffer per instance: an instance is not thread-safe (the product's studies run in
processes, each with its own).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from planner.errors import DefinitionError


class BufferedCall:
    """``function(*arrays)`` for one state: the outputs as flat float arrays (copies).

    function : a CasADi Function whose inputs and outputs are all dense (a sparse one would
        need its nonzeros' layout: refused by name).
    """

    def __init__(self, function: ca.Function) -> None:
        sides = (
            ("input", function.n_in(), function.sparsity_in),
            ("output", function.n_out(), function.sparsity_out),
        )
        for kind, count, sparsity in sides:
            for i in range(count):
                if not sparsity(i).is_dense():
                    raise DefinitionError(
                        f"`function`: {function.name()!r} has a sparse {kind} {i}; "
                        "BufferedCall takes dense inputs and outputs only"
                    )
        self.function = function
        self._arguments = [np.zeros(function.nnz_in(i)) for i in range(function.n_in())]
        self._results = [np.zeros(function.nnz_out(i)) for i in range(function.n_out())]
        self._buffer, self._evaluate = function.buffer()
        for i, argument in enumerate(self._arguments):
            self._buffer.set_arg(i, memoryview(argument))
        for i, result in enumerate(self._results):
            self._buffer.set_res(i, memoryview(result))

    def __call__(self, *arrays) -> list[np.ndarray]:
        if len(arrays) != len(self._arguments):
            raise DefinitionError(
                f"{self.function.name()!r} takes {len(self._arguments)} arguments, "
                f"got {len(arrays)}"
            )
        for argument, values in zip(self._arguments, arrays, strict=True):
            # column-major, as CasADi stores a dense matrix
            argument[:] = np.ravel(np.asarray(values, dtype=float), order="F")
        self._evaluate()
        return [result.copy() for result in self._results]


class BufferedCalls:
    """A mixin for an object that keeps :class:`BufferedCall` s by name (made at first use,
    dropped from its pickled or copied state: a buffer points into this process's memory)."""

    def _buffered(self, name: str, make) -> BufferedCall:
        """The buffered call of the Function ``make()`` under ``name``, made once."""
        calls = self.__dict__.setdefault("_buffers", {})
        if name not in calls:
            calls[name] = BufferedCall(make())
        return calls[name]

    def __getstate__(self) -> dict:
        return {key: value for key, value in self.__dict__.items() if key != "_buffers"}


__all__ = ["BufferedCall", "BufferedCalls"]
