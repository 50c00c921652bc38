"""Piecewise-cubic interpolation of sampled channels, in numpy only (no scipy at run time).

Every interpolant here is a cubic Hermite polynomial per interval, defined by the values and
the slopes at the knots; only the slopes differ:

* ``hermite``: the slopes are known (a derivative channel such as dpsi for psi);
* cubic spline (``spline_slopes``): the slopes solve the C2-continuity conditions, closed by
  the not-a-knot end conditions (the default: third derivative continuous at the second and
  second-to-last knots, O(h^4) up to the ends) or, on request, the natural ones (zero second
  derivative at both ends, only O(h^2) near the ends unless the function's curvature
  vanishes there); then the same Hermite evaluation.

Evaluation is written in the Hermite basis in the local coordinate tau in [0, 1],

    y(tau) = y0 H00(tau) + y1 H01(tau) + h (m0 H10(tau) + m1 H11(tau)),

because at tau = 0 and tau = 1 the basis values are exactly 0 or 1 in floating point: the
interpolant reproduces the knots bit for bit (a monomial form a + b s + c s^2 + d s^3 would not
at the right end of an interval).
"""

from __future__ import annotations

import numpy as np

SPLINE_ENDS = ("not-a-knot", "natural")


def spline_slopes(knots: np.ndarray, values: np.ndarray, end: str = "not-a-knot") -> np.ndarray:
    """Slopes at the knots of the cubic spline through ``values``.

    Parameters
    ----------
    knots : (K,) float, strictly increasing, K >= 2.
    values : (K,) or (K, c) float, one column per channel.
    end : ``"not-a-knot"`` (default) or ``"natural"``, the end conditions:

        * ``"not-a-knot"``: the third derivative is continuous at the second and the
          second-to-last knots (MATLAB's ``spline``, scipy's ``CubicSpline`` default). The
          error is O(h^4) up to the ends for a smooth function. K = 3 gives the parabola
          through the three points, K = 2 the straight line.
        * ``"natural"``: zero second derivative at both ends. A function whose curvature at
          the ends is not zero (a torque profile) is then only O(h^2) accurate in the end
          intervals, the error decaying by about 0.27 per knot inward. K = 2 gives the line.

    Returns
    -------
    (K,) or (K, c) float: dy/dt at each knot, in units of ``values`` per unit of ``knots``.

    Notes
    -----
    With h_i = t_{i+1} - t_i and d_i = (y_{i+1} - y_i) / h_i, C2 continuity at the interior
    knot i of two Hermite cubics gives the interior rows
        h_i m_{i-1} + 2 (h_{i-1} + h_i) m_i + h_{i-1} m_{i+1} = 3 (h_i d_{i-1} + h_{i-1} d_i).
    End rows, natural: 2 m_0 + m_1 = 3 d_0 and m_{K-2} + 2 m_{K-1} = 3 d_{K-2}. End rows,
    not-a-knot (K >= 4; de Boor, A Practical Guide to Splines, CUBSPL), with
    S = h_0 + h_1 and D = h_{K-3} + h_{K-2}:
        h_1 m_0 + S m_1 = ((h_0 + 2 S) h_1 d_0 + h_0^2 d_1) / S,
        D m_{K-2} + h_{K-3} m_{K-1} = (h_{K-2}^2 d_{K-3} + (2 D + h_{K-2}) h_{K-3} d_{K-2}) / D.

    The tridiagonal system is solved by the Thomas algorithm (Gaussian elimination without
    pivoting), as de Boor's CUBSPL does. The natural system is strictly diagonally dominant.
    The not-a-knot first row is not (h_1 < S), yet the pivots p_i stay positive for any
    strictly increasing knots, and the ratios r_i = upper_i / p_i below 1 from row 1 on:
        p_0 = h_1;  p_1 = 2 S - (h_1 / p_0) S = S,  r_1 = h_0 / S < 1;
        interior i >= 2: p_i = 2 (h_{i-1} + h_i) - h_i r_{i-1} > 2 h_{i-1} + h_i,
            so r_i = h_{i-1} / p_i < 1/2;
        last (K >= 4): p_{K-1} = h_{K-3} (p_{K-2} - D) / p_{K-2} with
            p_{K-2} - D = h_{K-3} + h_{K-2} (1 - r_{K-3}) > 0.
    For K >= 5 (r_{K-3} < 1/2), p_{K-2} - D > D / 2, so p_{K-1} > h_{K-3} / 3: forming it
    cancels at most a factor 3. The one ratio above 1, r_0 = S / h_1 (m_0 from m_1 in the
    back substitution), is the problem's own sensitivity: the first cubic moves its slope
    at t_0 by h_0 / h_1 per unit change of its slope at t_2.
    """
    if end not in SPLINE_ENDS:
        raise ValueError(f"`end`: must be 'not-a-knot' or 'natural', got {end!r}")
    t = np.asarray(knots, dtype=float)
    y = np.asarray(values, dtype=float)
    column = y.ndim == 1
    if column:
        y = y[:, None]
    k = t.shape[0]
    h = np.diff(t)
    d = np.diff(y, axis=0) / h[:, None]
    if end == "not-a-knot" and k <= 3:
        slopes = np.empty_like(y)
        if k == 2:  # the straight line
            slopes[:] = d[0]
        else:  # the parabola through the three points
            s = h[0] + h[1]
            slopes[0] = ((2.0 * h[0] + h[1]) * d[0] - h[0] * d[1]) / s
            slopes[1] = (h[1] * d[0] + h[0] * d[1]) / s
            slopes[2] = ((2.0 * h[1] + h[0]) * d[1] - h[1] * d[0]) / s
        return slopes[:, 0] if column else slopes
    lower = np.empty(k)  # coefficient of m_{i-1} in row i
    diag = np.empty(k)
    upper = np.empty(k)  # coefficient of m_{i+1} in row i
    rhs = np.empty_like(y)
    lower[1:-1] = h[1:]
    diag[1:-1] = 2.0 * (h[:-1] + h[1:])
    upper[1:-1] = h[:-1]
    rhs[1:-1] = 3.0 * (h[1:, None] * d[:-1] + h[:-1, None] * d[1:])
    if end == "natural":
        lower[0], diag[0], upper[0] = 0.0, 2.0, 1.0
        rhs[0] = 3.0 * d[0]
        lower[-1], diag[-1], upper[-1] = 1.0, 2.0, 0.0
        rhs[-1] = 3.0 * d[-1]
    else:
        s = h[0] + h[1]
        lower[0], diag[0], upper[0] = 0.0, h[1], s
        rhs[0] = ((h[0] + 2.0 * s) * h[1] * d[0] + h[0] ** 2 * d[1]) / s
        big_d = h[-2] + h[-1]
        lower[-1], diag[-1], upper[-1] = big_d, h[-2], 0.0
        rhs[-1] = (h[-1] ** 2 * d[-2] + (2.0 * big_d + h[-1]) * h[-2] * d[-1]) / big_d
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


def natural_spline_slopes(knots: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Slopes of the natural cubic spline: ``spline_slopes(knots, values, end="natural")``."""
    return spline_slopes(knots, values, end="natural")


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
    h00, h01, h10, h11 = hermite_basis(tau[:, None])
    return (
        values[index] * h00
        + values[index + 1] * h01
        + h[:, None] * (slopes[index] * h10 + slopes[index + 1] * h11)
    )


def hermite_basis(tau):
    """The cubic Hermite basis at local coordinate(s) ``tau`` in [0, 1] (float or array).

    Returns (H00, H01, H10, H11): weights of the left value, right value, left slope times h
    and right slope times h. At tau = 0 and 1 the weights are exactly 0 or 1 in floating point.
    One function for scalar and vector callers keeps their results identical bit for bit.
    """
    tau2 = tau * tau
    tau3 = tau2 * tau
    h01 = 3.0 * tau2 - 2.0 * tau3
    h00 = 1.0 - h01
    h10 = tau3 - 2.0 * tau2 + tau
    h11 = tau3 - tau2
    return h00, h01, h10, h11


def linear(knots: np.ndarray, values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Evaluate the piecewise linear interpolant: (K, c) values at (q,) times -> (q, c).

    Written as (1 - tau) y0 + tau y1 so that both ends of an interval are exact.
    """
    index, tau, _ = locate(knots, t)
    tau = tau[:, None]
    return (1.0 - tau) * values[index] + tau * values[index + 1]
