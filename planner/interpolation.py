"""Piecewise-cubic interpolation of sampled channels, in numpy only (no scipy at run time).

Every interpolant here is a cubic Hermite polynomial per interval, defined by the values and
the slopes at the knots; only the slopes differ:

* ``hermite``: the slopes are known (a derivative channel such as dpsi for psi);
* natural cubic spline: the slopes solve the C2-continuity conditions with zero second
  derivative at both ends (``natural_spline_slopes``), then the same Hermite evaluation.

Evaluation is written in the Hermite basis in the local coordinate tau in [0, 1],

    y(tau) = y0 H00(tau) + y1 H01(tau) + h (m0 H10(tau) + m1 H11(tau)),

because at tau = 0 and tau = 1 the basis values are exactly 0 or 1 in floating point: the
interpolant reproduces the knots bit for bit (a monomial form a + b s + c s^2 + d s^3 would not
at the right end of an interval).
"""

from __future__ import annotations

import numpy as np


def natural_spline_slopes(knots: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Slopes at the knots of the natural cubic spline through ``values``.

    Parameters
    ----------
    knots : (K,) float, strictly increasing, K >= 2.
    values : (K,) or (K, c) float, one column per channel.

    Returns
    -------
    (K,) or (K, c) float: dy/dt at each knot, in units of ``values`` per unit of ``knots``.

    Notes
    -----
    C2 continuity at the interior knot i of two Hermite cubics gives (h_i = t_{i+1} - t_i,
    d_i = (y_{i+1} - y_i) / h_i)
        h_i m_{i-1} + 2 (h_{i-1} + h_i) m_i + h_{i-1} m_{i+1} = 3 (h_i d_{i-1} + h_{i-1} d_i),
    and a zero second derivative at the ends gives 2 m_0 + m_1 = 3 d_0 and
    m_{K-2} + 2 m_{K-1} = 3 d_{K-2}. The system is strictly diagonally dominant, so the
    Thomas algorithm (no pivoting) is stable. With K = 2 the spline is the straight line.
    """
    t = np.asarray(knots, dtype=float)
    y = np.asarray(values, dtype=float)
    column = y.ndim == 1
    if column:
        y = y[:, None]
    k = t.shape[0]
    h = np.diff(t)
    d = np.diff(y, axis=0) / h[:, None]
    lower = np.empty(k)  # coefficient of m_{i-1} in row i
    diag = np.empty(k)
    upper = np.empty(k)  # coefficient of m_{i+1} in row i
    rhs = np.empty_like(y)
    lower[0], diag[0], upper[0] = 0.0, 2.0, 1.0
    rhs[0] = 3.0 * d[0]
    lower[1:-1] = h[1:]
    diag[1:-1] = 2.0 * (h[:-1] + h[1:])
    upper[1:-1] = h[:-1]
    rhs[1:-1] = 3.0 * (h[1:, None] * d[:-1] + h[:-1, None] * d[1:])
    lower[-1], diag[-1], upper[-1] = 1.0, 2.0, 0.0
    rhs[-1] = 3.0 * d[-1]
    # Thomas algorithm: the scalar forward sweep on the matrix runs in plain floats (it does
    # not depend on the data); only the right-hand side sweep touches the (k, c) arrays.
    factor = np.empty(k)
    pivot = np.empty(k)
    pivot[0] = diag[0]
    for i in range(1, k):
        factor[i] = lower[i] / pivot[i - 1]
        pivot[i] = diag[i] - factor[i] * upper[i - 1]
    for i in range(1, k):
        rhs[i] -= factor[i] * rhs[i - 1]
    slopes = np.empty_like(y)
    slopes[-1] = rhs[-1] / pivot[-1]
    for i in range(k - 2, -1, -1):
        slopes[i] = (rhs[i] - upper[i] * slopes[i + 1]) / pivot[i]
    return slopes[:, 0] if column else slopes


def locate(knots: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Interval index, local coordinate and width for each query time.

    Parameters
    ----------
    knots : (K,) float, strictly increasing, K >= 2.
    t : (q,) float, inside [knots[0], knots[-1]] (not checked here).

    Returns
    -------
    index : (q,) int in [0, K-2]; interval [knots[index], knots[index + 1]] holds t.
    tau : (q,) float in [0, 1]; exactly 0 at a knot that starts an interval and exactly 1 at
        the last knot.
    h : (q,) float, width of the interval.
    """
    index = np.searchsorted(knots, t, side="right") - 1
    np.clip(index, 0, knots.shape[0] - 2, out=index)
    left = knots[index]
    h = knots[index + 1] - left
    tau = (t - left) / h
    return index, tau, h


def hermite(knots: np.ndarray, values: np.ndarray, slopes: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Evaluate the piecewise cubic Hermite interpolant.

    Parameters
    ----------
    knots : (K,) float, strictly increasing.
    values, slopes : (K, c) float; slopes in units of values per unit of knots.
    t : (q,) float inside [knots[0], knots[-1]].

    Returns
    -------
    (q, c) float. Exact at the knots; error O(h^4) for a smooth function with exact slopes.
    """
    index, tau, h = locate(knots, t)
    tau = tau[:, None]
    tau2 = tau * tau
    tau3 = tau2 * tau
    h01 = 3.0 * tau2 - 2.0 * tau3
    h00 = 1.0 - h01
    h10 = tau3 - 2.0 * tau2 + tau
    h11 = tau3 - tau2
    return (
        values[index] * h00
        + values[index + 1] * h01
        + h[:, None] * (slopes[index] * h10 + slopes[index + 1] * h11)
    )


def linear(knots: np.ndarray, values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Evaluate the piecewise linear interpolant: (K, c) values at (q,) times -> (q, c).

    Written as (1 - tau) y0 + tau y1 so that both ends of an interval are exact.
    """
    index, tau, _ = locate(knots, t)
    tau = tau[:, None]
    return (1.0 - tau) * values[index] + tau * values[index + 1]
