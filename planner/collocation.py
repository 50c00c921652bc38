"""Polynomial machinery of the transcriptions: Lagrange bases, collocation roots, quadrature.

Every interval of the mesh is mapped to the unit interval, tau = (t - t_k) / h in [0, 1].
A scheme (see :mod:`planner.transcription`) places state variables, and the points where the
dynamics are enforced ("dynamics points"), at fixed tau; everything below is numpy on those
fixed points, computed once per scheme and turned into constant matrices of the NLP.

Orthogonal collocation of degree d (Radau IIA: the roots of P_d - P_{d-1} shifted to [0, 1],
the last root at tau = 1; Gauss-Legendre: the roots of P_d, all interior) comes from
``casadi.collocation_points``; the Lagrange bases are built here (numpy), which keeps the
transcription independent of CasADi's own integrator machinery.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from planner.errors import DefinitionError

#: Orthogonal collocation families and the name ``casadi.collocation_points`` uses for each.
FAMILIES = {"radau": "radau", "legendre": "legendre"}
MAX_DEGREE = 9


def collocation_roots(family: str, degree: int) -> np.ndarray:
    """Collocation points in (0, 1] of a ``family`` ("radau" or "legendre") of ``degree``.

    Returns
    -------
    (degree,) float array, increasing; Radau's last point is exactly 1.
    """
    if family not in FAMILIES:
        raise DefinitionError(
            f"`family`: unknown collocation family {family!r}; use one of {sorted(FAMILIES)}"
        )
    if isinstance(degree, bool) or not isinstance(degree, int | np.integer):
        raise DefinitionError(f"`degree`: must be an integer in 1..{MAX_DEGREE}, got {degree!r}")
    if not 1 <= degree <= MAX_DEGREE:
        raise DefinitionError(
            f"`degree`: must be in 1..{MAX_DEGREE} for {family} collocation, got {degree}"
        )
    roots = np.array(ca.collocation_points(int(degree), FAMILIES[family]), dtype=float)
    if family == "radau":
        roots[-1] = 1.0  # exact, so that the last collocation state is the next node
    return roots


def lagrange_coefficients(points: np.ndarray) -> np.ndarray:
    """Monomial coefficients of the Lagrange basis through ``points``.

    Returns ``P`` of shape (m, m) with l_j(tau) = sum_k P[j, k] tau^k; l_j(points[i]) = [i == j].
    Solving the Vandermonde system is accurate enough for m <= 10 points in [0, 1]
    (condition number below 1e7).
    """
    points = np.asarray(points, dtype=float)
    vandermonde = np.vander(points, increasing=True)  # V[i, k] = points[i]^k
    return np.linalg.solve(vandermonde, np.eye(points.size)).T


def lagrange_matrix(points: np.ndarray, tau, derivative: int = 0) -> np.ndarray:
    """Values (or derivatives d^r/dtau^r) of the Lagrange basis through ``points`` at ``tau``.

    Parameters
    ----------
    points : (m,) distinct nodes of the basis.
    tau : scalar or (K,) evaluation points.
    derivative : order r >= 0 of the derivative with respect to tau, or -1 for the
        antiderivative that vanishes at tau = 0 (the integral from 0 to tau).

    Returns
    -------
    (K, m) array W with p(tau_k) = sum_j W[k, j] p(points[j]) for every polynomial p of degree
    < m (its r-th derivative for ``derivative=r``, its integral over [0, tau_k] for -1).
    """
    points = np.asarray(points, dtype=float)
    tau = np.atleast_1d(np.asarray(tau, dtype=float))
    coefficients = lagrange_coefficients(points)  # (m, m): basis j, power k
    m = points.size
    powers = np.arange(m)
    if derivative == -1:  # integral of tau^k over [0, tau] = tau^(k+1) / (k+1)
        monomials = tau[:, None] ** (powers[None, :] + 1) / (powers[None, :] + 1)
        return monomials @ coefficients.T
    if derivative < -1:
        raise ValueError(f"`derivative`: must be >= -1, got {derivative}")
    factor = np.ones(m)  # d^r/dtau^r tau^k = k (k-1) ... (k-r+1) tau^(k-r)
    for r in range(derivative):
        factor = factor * np.clip(powers - r, 0, None)
    shifted = np.clip(powers - derivative, 0, None)
    monomials = factor[None, :] * tau[:, None] ** shifted[None, :]  # (K, m)
    return monomials @ coefficients.T


def integration_weights(points: np.ndarray) -> np.ndarray:
    """Interpolatory quadrature weights on [0, 1]: integral of l_j over [0, 1], shape (m,).

    On Gauss-Legendre points this is the Gauss rule (exact to degree 2m - 1), on Radau IIA
    points the right Radau rule (degree 2m - 2).
    """
    coefficients = lagrange_coefficients(points)
    m = len(points)
    return coefficients @ (1.0 / np.arange(1, m + 1))


def gauss_legendre(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre points and weights on [0, 1] (``order`` points), for error quadrature."""
    x, w = np.polynomial.legendre.leggauss(order)
    return 0.5 * (x + 1.0), 0.5 * w
