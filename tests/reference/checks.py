"""Comparison machinery shared by the model's tests: per-state relative errors and a checker
that counts what it compared (the ``check`` fixture of conftest.py fails a test that compared
nothing)."""

from __future__ import annotations

import numpy as np

TOL = 1e-10
FLOOR = 1e-30


def relative_error(actual, reference) -> np.ndarray:
    """Per-state relative error (K,) of batches with the state on the leading axis."""
    actual = np.asarray(actual)
    reference = np.asarray(reference)
    assert actual.shape == reference.shape, (actual.shape, reference.shape)
    k = reference.shape[0]
    diff = np.linalg.norm((actual - reference).reshape(k, -1), axis=1)
    return diff / (np.linalg.norm(reference.reshape(k, -1), axis=1) + FLOOR)


def central_jacobian(function, x, eps: float) -> np.ndarray:
    """d function / dx (m, n) by central differences of step ``eps`` along each of x's n
    entries: the oracle of an exact Jacobian, to O(eps^2)."""
    x = np.asarray(x, dtype=float)
    columns = []
    for j in range(x.size):
        step = np.zeros(x.size)
        step[j] = eps
        ahead = np.asarray(function(x + step), dtype=float)
        behind = np.asarray(function(x - step), dtype=float)
        columns.append((ahead - behind) / (2 * eps))
    return np.column_stack(columns)


def mass_norm(mass: np.ndarray, v: np.ndarray) -> np.ndarray:
    """sqrt(v^T M v) per state: the kinetic-energy norm of an angular velocity/acceleration."""
    return np.sqrt(np.einsum("ki,kij,kj->k", v, mass, v))


class Checker:
    """Asserts per-state relative errors and counts the states it compared."""

    def __init__(self) -> None:
        self.count = 0
        self.failed = False

    def close(self, actual, reference, what: str, tol: float = TOL) -> None:
        self._record(lambda: relative_error(actual, reference), what, tol)

    def errors(self, errors: np.ndarray, what: str, tol: float = TOL) -> None:
        self._record(lambda: np.asarray(errors), what, tol)

    def _record(self, compute, what: str, tol: float) -> None:
        try:
            errors = compute()
            assert errors.ndim == 1 and errors.size > 0, f"{what}: nothing compared"
            assert np.all(np.isfinite(errors)), f"{what}: non-finite error"
            worst = int(np.argmax(errors))
            assert errors[worst] <= tol, (
                f"{what}: relative error {errors[worst]:.3e} > {tol:.0e} at state {worst}"
            )
        except AssertionError:
            self.failed = True  # reported by the test; no second report at teardown
            raise
        self.count += errors.size
