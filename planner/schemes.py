"""The registry of transcriptions: every name, its degrees, and the polynomial scheme it uses.

Everything that offers or checks a transcription reads :data:`REGISTRY` (``OCP``'s
validation, ``OCP.refine``, the transcription, the row names, the command line's choices):
adding a transcription touches this file only, a builder of its :class:`Scheme` and an entry.

A :class:`Scheme` fixes the polynomial structure of one mesh interval, tau = (t - t_k) / h_k
in [0, 1] (see :mod:`planner.transcription`):

* where the state variables live (``state_tau``; the interval's last state is the next
  interval's first) and where the dynamics are enforced (``dyn_tau``, the "dynamics points":
  controls and, implicit, the auxiliary variables live there too);
* the defects, linear in the states X_k of the interval and the rates F_k at its dynamics
  points: X_k A^T - h F_k B^T = 0 (one row of A, B per defect);
* the quadrature weights of the integral objective, integral ~= h sum_c q_c L_c;
* the interpolant, exactly the polynomials the defects imply:
  x(tau) = X_k Wx(tau)^T + h F_k Wf(tau)^T,   u(tau) = U_k Wu(tau)^T.

| scheme          | states / interval   | dynamics points  | x(tau)            | u(tau)       |
|-----------------|---------------------|------------------|-------------------|--------------|
| trapezoid       | node                | nodes            | quadratic         | linear       |
| hermite-simpson | node, midpoint      | nodes, midpoints | cubic Hermite     | quadratic    |
| radau (d)       | node, tau_1..d-1    | tau_1..d (=1)    | Lagrange, deg d   | Lagrange d-1 |
| legendre (d)    | node, tau_1..d      | tau_1..d         | Lagrange, deg d   | Lagrange d-1 |

(Hermite-Simpson is the separated form: midpoint states and controls are variables; the
Legendre scheme adds a continuity defect x_{k+1} = x(tau = 1).)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from planner.collocation import (
    MAX_DEGREE,
    collocation_roots,
    integration_weights,
    lagrange_matrix,
)
from planner.errors import DefinitionError, DefinitionTypeError

#: The weights (Wx (K, ms + 1), Wf (K, ndc)) of a closed-form state interpolant at tau (K,)
#: for the r-th derivative: d^r x/dtau^r = X_k Wx^T + h F_k Wf^T.
StateBasis = Callable[[np.ndarray, int], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True, eq=False)
class Scheme:
    """The polynomial structure of one mesh interval (see the module docstring).

    Attributes
    ----------
    name, degree : the transcription and its degree (None for a fixed scheme).
    state_tau : (ms,) state points owned by an interval, starting at 0.
    dyn_tau : (mc,) dynamics points owned by an interval.
    shares_end : the interval also uses the next interval's first dynamics point (the node
        at tau = 1): trapezoid and Hermite-Simpson, whose dynamics points include the nodes.
    A : (r, ms + 1) defect weights on the interval's states (tau in state_tau + [1]).
    B : (r, ndc) defect weights on the interval's rates, ndc = mc + shares_end.
    defect_labels : (r,) suffixes naming the defect rows ("" or " (midpoint)", ...).
    quadrature : (ndc,) weights of the integral on the interval's dynamics points.
    order : expected order of convergence of the cost.
    point_label : how rows name an interior point j of an interval ("midpoint", "point {j}").
    state_basis : the closed-form state interpolant (:data:`StateBasis`), or None for the
        Lagrange polynomial through the node and the dynamics points (collocation).
    motion_basis : the velocity polynomial of a consistent motion
        (:meth:`motion_weights`) when it is not the state interpolant, or None.
    """

    name: str
    degree: int | None
    state_tau: np.ndarray
    dyn_tau: np.ndarray
    shares_end: bool
    A: np.ndarray
    B: np.ndarray
    defect_labels: tuple[str, ...]
    quadrature: np.ndarray
    order: int
    point_label: str = "point {j}"
    state_basis: StateBasis | None = None
    motion_basis: StateBasis | None = None

    @property
    def ms(self) -> int:
        return self.state_tau.size

    @property
    def mc(self) -> int:
        return self.dyn_tau.size

    @property
    def ndc(self) -> int:
        return self.mc + int(self.shares_end)

    @property
    def owns_end(self) -> bool:
        """The interval's last dynamics point is its end node, not shared with the next
        interval (Radau): its intervals are (t_k, t_k+1], so that a node's control is the
        NLP variable of the interval ending there."""
        return not self.shares_end and bool(self.dyn_tau[-1] == 1.0)

    @property
    def interval_state_tau(self) -> np.ndarray:
        return np.append(self.state_tau, 1.0)

    @property
    def interval_dyn_tau(self) -> np.ndarray:
        return np.append(self.dyn_tau, 1.0) if self.shares_end else self.dyn_tau

    @property
    def label(self) -> str:
        """The name with its degree: "hermite-simpson", "radau(3)"."""
        return self.name + (f"({self.degree})" if self.degree else "")

    def point_name(self, j: int) -> str:
        """The rows' name of interior point j (1-based) of an interval."""
        return self.point_label.format(j=j)

    def state_weights(self, tau, derivative: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """(Wx (K, ms+1), Wf (K, ndc)): d^r x/dtau^r = X_k Wx^T + h F_k Wf^T at ``tau``;
        ``derivative=-1``: the integral of x over [0, tau] (in units of tau)."""
        if derivative < -1:
            raise ValueError(f"`derivative`: must be >= -1, got {derivative}")
        tau = np.atleast_1d(np.asarray(tau, dtype=float))
        if self.state_basis is not None:
            return self.state_basis(tau, derivative)
        # Orthogonal collocation: the Lagrange polynomial through the node and the points.
        points = np.append(0.0, self.dyn_tau)
        w = lagrange_matrix(points, tau, derivative)
        wx = np.zeros((tau.size, self.ms + 1))
        wx[:, : points.size] = w
        return wx, np.zeros((tau.size, self.ndc))

    def motion_weights(self, tau, derivative: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """(Wx, Wf) as :meth:`state_weights`, of the velocity polynomial of a consistent motion
        (:meth:`planner.solution.Solution.motion`): v(tau) = V_k Wx^T + h A_k Wf^T with V the
        velocities at the state points and A the accelerations at the dynamics points, whose
        integral over the interval must be the scheme's own position defect, so that the
        positions it integrates to meet the next node. The state interpolant has that
        property on Hermite-Simpson (Simpson's rule is exact on its cubic) and collocation
        (the quadrature is exact on the state polynomial); the trapezoid's quadratic does not
        (its integral misses h (v0 + v1) / 2 by h^2 (a0 - a1) / 12), so it has its own."""
        if self.motion_basis is None:
            return self.state_weights(tau, derivative)
        if derivative < -1:
            raise ValueError(f"`derivative`: must be >= -1, got {derivative}")
        return self.motion_basis(np.atleast_1d(np.asarray(tau, dtype=float)), derivative)

    def control_weights(self, tau, derivative: int = 0) -> np.ndarray:
        """Wu (K, ndc): u(tau) = U_k Wu^T, the polynomial through the dynamics points."""
        return lagrange_matrix(self.interval_dyn_tau, tau, derivative)


# ---- the schemes ------------------------------------------------------------------------------
def _trapezoid_state(tau: np.ndarray, derivative: int) -> tuple[np.ndarray, np.ndarray]:
    # x = x0 + h (f0 tau + (f1 - f0) tau^2 / 2): the integral of the linear rate.
    if derivative > 2:
        return np.zeros((tau.size, 2)), np.zeros((tau.size, 2))
    one, zero = np.ones_like(tau), np.zeros_like(tau)
    poly = {
        -1: (tau, tau**2 / 2 - tau**3 / 6, tau**3 / 6),  # the integral over [0, tau]
        0: (one, tau - tau**2 / 2, tau**2 / 2),
        1: (zero, 1 - tau, tau),
        2: (zero, -one, one),
    }
    constant, f0, f1 = poly[derivative]
    return np.column_stack([constant, zero]), np.column_stack([f0, f1])


def _hermite_simpson_state(tau: np.ndarray, derivative: int) -> tuple[np.ndarray, np.ndarray]:
    # Cubic Hermite through x0, x1 with slopes h f0, h f1 (its midpoint value and slope are
    # the two Hermite-Simpson defects, so it passes through x_m with slope f_m).
    if derivative > 3:
        return np.zeros((tau.size, 3)), np.zeros((tau.size, 3))
    basis = {
        -1: (  # the integral over [0, tau]
            tau**4 / 2 - tau**3 + tau,
            tau**4 / 4 - 2 * tau**3 / 3 + tau**2 / 2,
            -(tau**4) / 2 + tau**3,
            tau**4 / 4 - tau**3 / 3,
        ),
        0: (
            2 * tau**3 - 3 * tau**2 + 1,
            tau**3 - 2 * tau**2 + tau,
            -2 * tau**3 + 3 * tau**2,
            tau**3 - tau**2,
        ),
        1: (
            6 * tau**2 - 6 * tau,
            3 * tau**2 - 4 * tau + 1,
            -6 * tau**2 + 6 * tau,
            3 * tau**2 - 2 * tau,
        ),
        2: (12 * tau - 6, 6 * tau - 4, -12 * tau + 6, 6 * tau - 2),
        3: (12 + 0 * tau, 6 + 0 * tau, -12 + 0 * tau, 6 + 0 * tau),
    }
    h00, h10, h01, h11 = basis[derivative]
    zero = np.zeros_like(tau)
    return np.column_stack([h00, zero, h01]), np.column_stack([h10, zero, h11])


def _trapezoid_motion(tau: np.ndarray, derivative: int) -> tuple[np.ndarray, np.ndarray]:
    # The quartic through v0, v1 with slopes h a0, h a1 whose integral over the interval is
    # the trapezoid's position defect (v0 + v1) / 2: the cubic Hermite plus the bump
    # b = tau^2 (1 - tau)^2 (zero value and slope at both ends, integral 1/30) times
    # -30 h (a0 - a1) / 12, which cancels the Hermite's own h (a0 - a1) / 12.
    if derivative > 4:
        return np.zeros((tau.size, 2)), np.zeros((tau.size, 2))
    wx, wf = _hermite_simpson_state(tau, derivative)
    h00, h01, h10, h11 = wx[:, 0], wx[:, 2], wf[:, 0], wf[:, 2]
    bump = {
        -1: tau**3 / 3 - tau**4 / 2 + tau**5 / 5,
        0: tau**2 - 2 * tau**3 + tau**4,
        1: 2 * tau - 6 * tau**2 + 4 * tau**3,
        2: 2 - 12 * tau + 12 * tau**2,
        3: -12 + 24 * tau,
        4: 24 + 0 * tau,
    }[derivative]
    return np.column_stack([h00, h01]), np.column_stack([h10 - 2.5 * bump, h11 + 2.5 * bump])


def _trapezoid(degree: int | None) -> Scheme:
    return Scheme(
        "trapezoid",
        None,
        np.array([0.0]),
        np.array([0.0]),
        True,
        A=np.array([[-1.0, 1.0]]),
        B=np.array([[0.5, 0.5]]),
        defect_labels=("",),
        quadrature=np.array([0.5, 0.5]),
        order=2,
        state_basis=_trapezoid_state,
        motion_basis=_trapezoid_motion,
    )


def _hermite_simpson(degree: int | None) -> Scheme:
    return Scheme(
        "hermite-simpson",
        None,
        np.array([0.0, 0.5]),
        np.array([0.0, 0.5]),
        True,
        # x_m = (x0 + x1)/2 + h (f0 - f1)/8 ;  x1 = x0 + h (f0 + 4 f_m + f1)/6
        A=np.array([[-0.5, 1.0, -0.5], [-1.0, 0.0, 1.0]]),
        B=np.array([[1 / 8, 0.0, -1 / 8], [1 / 6, 4 / 6, 1 / 6]]),
        defect_labels=(" (midpoint)", " (end)"),
        quadrature=np.array([1 / 6, 4 / 6, 1 / 6]),
        order=4,
        point_label="midpoint",
        state_basis=_hermite_simpson_state,
    )


def _radau(degree: int | None) -> Scheme:
    # Radau IIA: the last root is tau = 1, the next node (a state of the next interval).
    roots = collocation_roots("radau", degree)
    d = roots.size
    points = np.append(0.0, roots)  # the basis of the state polynomial
    return Scheme(
        "radau",
        d,
        points[:-1],
        roots,
        False,
        A=lagrange_matrix(points, roots, 1),  # (d, d+1): slope at each root
        B=np.eye(d),
        defect_labels=tuple(f" (point {r + 1})" for r in range(d)),
        quadrature=integration_weights(roots),
        order=2 * d - 1,
    )


def _legendre(degree: int | None) -> Scheme:
    # Gauss-Legendre: interior roots, and a continuity defect x_{k+1} = x(tau = 1).
    roots = collocation_roots("legendre", degree)
    d = roots.size
    points = np.append(0.0, roots)
    A = np.zeros((d + 1, d + 2))
    A[:d, : d + 1] = lagrange_matrix(points, roots, 1)
    A[d, : d + 1] = -lagrange_matrix(points, [1.0])[0]  # x(1) from the node and the roots
    A[d, d + 1] = 1.0
    return Scheme(
        "legendre",
        d,
        points,
        roots,
        False,
        A=A,
        B=np.vstack([np.eye(d), np.zeros((1, d))]),
        defect_labels=(*(f" (point {r + 1})" for r in range(d)), " (continuity)"),
        quadrature=integration_weights(roots),
        order=2 * d,
    )


# ---- the registry -----------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Entry:
    """A transcription of the registry.

    name : what ``OCP(transcription=...)`` and ``--transcription`` take.
    build : degree (None for a fixed scheme) -> :class:`Scheme`.
    degrees : the degrees it takes (``range``), or None for a fixed polynomial degree.
    default_degree : the degree when none is given (None for a fixed scheme).
    family : what the degree's messages call it ("collocation").
    summary : one line for help texts.
    """

    name: str
    build: Callable[[int | None], Scheme]
    degrees: range | None = None
    default_degree: int | None = None
    family: str = ""
    summary: str = ""

    @property
    def degree_range(self) -> str:
        """ "1..9", or "" for a fixed scheme."""
        return f"{self.degrees[0]}..{self.degrees[-1]}" if self.degrees else ""


_COLLOCATION_DEGREES = range(1, MAX_DEGREE + 1)

#: Every transcription, by name, in the order help texts list them.
REGISTRY: dict[str, Entry] = {
    entry.name: entry
    for entry in (
        Entry("trapezoid", _trapezoid, summary="linear controls, quadratic states (order 2)"),
        Entry(
            "hermite-simpson",
            _hermite_simpson,
            summary="separated form: quadratic controls, cubic states (order 4)",
        ),
        Entry(
            "radau",
            _radau,
            _COLLOCATION_DEGREES,
            3,
            "collocation",
            "orthogonal collocation at Radau IIA points (order 2d - 1)",
        ),
        Entry(
            "legendre",
            _legendre,
            _COLLOCATION_DEGREES,
            3,
            "collocation",
            "orthogonal collocation at Gauss-Legendre points (order 2d)",
        ),
    )
}

#: The transcription names.
TRANSCRIPTIONS: tuple[str, ...] = tuple(REGISTRY)
#: The transcription an OCP uses when it names none: fourth order with the nodes' and
#: midpoints' controls as variables, the best accuracy per variable on the gaits measured.
DEFAULT_TRANSCRIPTION: str = REGISTRY["hermite-simpson"].name
#: The names that take a degree.
WITH_DEGREE: tuple[str, ...] = tuple(name for name, e in REGISTRY.items() if e.degrees)


def _listing(names: Sequence[str]) -> str:
    """ "'a', 'b' and 'c'"."""
    quoted = [repr(name) for name in names]
    return ", ".join(quoted[:-1]) + f" and {quoted[-1]}" if len(quoted) > 1 else "".join(quoted)


def entry(name: object) -> Entry:
    """The registry's entry of ``name``; raises naming the known ones."""
    if not isinstance(name, str) or name not in REGISTRY:
        raise DefinitionError(f"`transcription`: unknown {name!r}; use one of {TRANSCRIPTIONS}")
    return REGISTRY[name]


def check_degree(name: str, degree: object) -> int | None:
    """The degree of transcription ``name`` given ``degree`` (None: its default), checked
    against the registry: an integer in its range, or None for a fixed scheme."""
    found = entry(name)
    if not found.degrees:
        if degree is not None:
            raise DefinitionError(
                f"`degree`: applies to {_listing(WITH_DEGREE)} only; {name!r} has a fixed "
                "polynomial degree, leave degree=None"
            )
        return None
    if degree is None:
        degree = found.default_degree
    span = found.degree_range
    if isinstance(degree, bool) or not isinstance(degree, int | np.integer):
        raise DefinitionTypeError(f"`degree`: must be an integer in {span}, got {degree!r}")
    if degree not in found.degrees:
        raise DefinitionError(
            f"`degree`: must be in {span} for {name} {found.family}, got {degree}"
        )
    return int(degree)


def make_scheme(name: str, degree: int | None = None) -> Scheme:
    """The :class:`Scheme` of a transcription name (and degree, for one that takes one)."""
    found = entry(name)
    if found.degrees and degree is None:
        raise DefinitionError(
            f"`degree`: {name} {found.family} needs a degree in {found.degree_range}"
        )
    return found.build(degree)


def help_text() -> str:
    """One line per transcription for help texts: "name: summary", degrees and default."""
    lines = []
    for found in REGISTRY.values():
        degrees = (
            f"; degree {found.degree_range}, default {found.default_degree}"
            if found.degrees
            else ""
        )
        lines.append(f"{found.name}: {found.summary}{degrees}")
    return "\n".join(lines)


__all__ = [
    "DEFAULT_TRANSCRIPTION",
    "REGISTRY",
    "TRANSCRIPTIONS",
    "WITH_DEGREE",
    "Entry",
    "Scheme",
    "check_degree",
    "entry",
    "help_text",
    "make_scheme",
]
