"""Evaluate a CasADi SX Function on large batches with numpy, one vector operation per
instruction.

CasADi's SX virtual machine runs each instruction for one state at a time; on a batch of
100,000 states the per-call conversion and the scalar loop cost tens of nanoseconds per
instruction and state. An SX Function is a straight-line program (its "algorithm"), so the
same program can run once over whole columns of states: each instruction becomes one numpy
ufunc call on a (K,) array, and the interpreter overhead is paid once per instruction, not per
state. Batches are cut into chunks that stay in cache.

Only the operations listed in ``_UNARY``/``_BINARY`` are translated; a Function that uses
anything else gets ``None`` from :meth:`NumpyTape.try_build` and is evaluated by CasADi.
The result is identical to CasADi's up to floating-point rounding of the same operations.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

_UNARY = {
    ca.OP_NEG: np.negative,
    ca.OP_SIN: np.sin,
    ca.OP_COS: np.cos,
    ca.OP_TAN: np.tan,
    ca.OP_EXP: np.exp,
    ca.OP_LOG: np.log,
    ca.OP_SQRT: np.sqrt,
    ca.OP_SQ: np.square,
    ca.OP_FABS: np.abs,
    ca.OP_INV: np.reciprocal,
    ca.OP_TANH: np.tanh,
    ca.OP_ATAN: np.arctan,
    ca.OP_ASIN: np.arcsin,
    ca.OP_ACOS: np.arccos,
}
_BINARY = {
    ca.OP_ADD: np.add,
    ca.OP_SUB: np.subtract,
    ca.OP_MUL: np.multiply,
    ca.OP_DIV: np.divide,
    ca.OP_POW: np.power,
    ca.OP_CONSTPOW: np.power,
    ca.OP_ATAN2: np.arctan2,
    ca.OP_FMIN: np.fmin,
    ca.OP_FMAX: np.fmax,
}


class NumpyTape:
    """A compiled-to-numpy copy of an SX Function's instruction list."""

    #: Batches smaller than this go through CasADi itself (less fixed overhead).
    MIN_BATCH = 256
    #: States per chunk: keeps the working arrays in the processor's cache.
    CHUNK = 4096

    def __init__(self, program, n_work, n_in_nz, out_sparsity):
        self._program = program
        self._n_work = n_work
        self._n_in_nz = n_in_nz
        self._out_nnz = [sp.nnz() for sp in out_sparsity]

    @classmethod
    def try_build(cls, function: ca.Function) -> NumpyTape | None:
        """Translate ``function``; ``None`` when it is not SX or uses an untranslated op."""
        if not function.is_a("SXFunction"):
            return None
        program = []
        for k in range(function.n_instructions()):
            op = function.instruction_id(k)
            args = tuple(function.instruction_input(k))
            res = tuple(function.instruction_output(k))
            if op == ca.OP_CONST:
                program.append(("const", res[0], float(function.instruction_constant(k))))
            elif op == ca.OP_INPUT:
                program.append(("input", res[0], args))  # args = (input index, nonzero)
            elif op == ca.OP_OUTPUT:
                program.append(("output", args[0], res))  # res = (output index, nonzero)
            elif op == ca.OP_ASSIGN:
                program.append(("assign", res[0], args[0]))
            elif op in _UNARY:
                program.append(("unary", res[0], (_UNARY[op], args[0])))
            elif op in _BINARY:
                program.append(("binary", res[0], (_BINARY[op], args[0], args[1])))
            else:
                return None
        n_work = function.sz_w()
        n_in_nz = [function.nnz_in(i) for i in range(function.n_in())]
        return cls(
            program, n_work, n_in_nz, [function.sparsity_out(i) for i in range(function.n_out())]
        )

    def __call__(self, columns: list[np.ndarray]) -> list[np.ndarray]:
        """Evaluate on dense input blocks of shape (nnz_in_i, K); returns (nnz_out_i, K)."""
        total = columns[0].shape[1]
        outputs = [np.zeros((nnz, total)) for nnz in self._out_nnz]
        for start in range(0, total, self.CHUNK):
            stop = min(total, start + self.CHUNK)
            self._run(
                [c[:, start:stop] for c in columns],
                [o[:, start:stop] for o in outputs],
                stop - start,
            )
        return outputs

    def _run(self, inputs, outputs, size) -> None:
        work: list = [None] * self._n_work
        for kind, target, data in self._program:
            if kind == "binary":
                fn, a, b = data
                work[target] = fn(work[a], work[b])
            elif kind == "unary":
                fn, a = data
                work[target] = fn(work[a])
            elif kind == "const":
                work[target] = data  # a float broadcasts in the ufuncs
            elif kind == "input":
                work[target] = inputs[data[0]][data[1]]
            elif kind == "output":
                outputs[data[0]][data[1]] = work[target]
            else:  # assign
                work[target] = work[data]
