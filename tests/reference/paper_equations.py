"""The seed paper's equations (14)-(21) for the six-link mechanism, typed in by hand.

Two versions of the equations of motion (16)-(21):

* ``literal``: exactly as printed, including the erratum of ``shared/errata.md`` item 3: the
  velocity terms of (16) and (17) read dpsi_1 dpsi_k and dpsi_2 dpsi_k (the printed terms are
  -dT/dpsi alone);
* corrected: the same with the square of the other link's rate, dpsi_k^2 (and dpsi_1^2 in
  the first velocity term of (17)).

(18)-(21), every ddpsi coefficient, every gravity term and the right-hand sides are the same
in both (errata 4). Equation (14) is available as printed (cross terms without their factor 2,
errata 2) and corrected; (15) as printed (it is correct).

I_i is the moment of inertia about the start hinge, I_i = J_i + m_i (n_i l_i)^2 (errata 1);
``inertia_about="com"`` uses J_i in its place instead, to show that this reading is wrong.

Nothing here comes from ``model`` but the Linkage's plain data (lengths, masses, com, inertia,
gravity, parents): the formulas are a transcription, independent of model/equations.py.
Angles psi (6,) or (K, 6) rad, rates rad/s, accelerations rad/s^2; torques N m; energies J.
Indices below follow the paper: p1 = psi_1 = psi[..., 0], ..., d1 = dpsi_1, a1 = ddpsi_1.
"""

from __future__ import annotations

import numpy as np

from model import Linkage

__all__ = [
    "corrected_generalized_forces",
    "corrected_torques",
    "kinetic_energy_doubled",
    "paper_generalized_forces",
    "paper_literal_torques",
    "potential_energy",
    "torques_from_generalized",
]

#: Parent of each link of the paper's tree (Fig. 1; scene.md), 0-based, -1 for the ground.
PAPER_PARENTS = (-1, 0, 1, 2, 1, 4)


def _symbols(linkage: Linkage, inertia_about: str):
    """l, m, n, I (each a tuple of 6 floats, paper index i at position i - 1) and g."""
    if not isinstance(linkage, Linkage) or linkage.parents != PAPER_PARENTS:
        raise ValueError(
            "`linkage`: the paper's equations need the six-link tree of scene.md "
            f"(parents {PAPER_PARENTS}), got {linkage!r}"
        )
    if not linkage.is_paper_form:
        raise ValueError("`linkage`: every link must have the paper's form (on-axis com)")
    if inertia_about not in ("start", "com"):
        raise ValueError(f"`inertia_about`: 'start' or 'com', got {inertia_about!r}")
    links = linkage.links
    l = tuple(link.length for link in links)
    m = tuple(link.mass for link in links)
    n = tuple(link.com for link in links)
    if inertia_about == "start":
        I = tuple(link.inertia + link.mass * (link.com * link.length) ** 2 for link in links)
    else:
        I = tuple(link.inertia for link in links)
    return l, m, n, I, linkage.gravity


def _angles(values):
    a = np.asarray(values, dtype=float)
    if a.shape[-1] != 6:
        raise ValueError(f"expected (6,) or (K, 6) values, got shape {a.shape}")
    return tuple(a[..., i] for i in range(6))


def _equations(linkage, psi, dpsi, ddpsi, literal: bool, inertia_about: str) -> np.ndarray:
    (l1, l2, l3, l4, l5, l6), (m1, m2, m3, m4, m5, m6), n, I, g = _symbols(linkage, inertia_about)
    n1, n2, n3, n4, n5, n6 = n
    I1, I2, I3, I4, I5, I6 = I
    p1, p2, p3, p4, p5, p6 = _angles(psi)
    d1, d2, d3, d4, d5, d6 = _angles(dpsi)
    a1, a2, a3, a4, a5, a6 = _angles(ddpsi)
    cos, sin = np.cos, np.sin

    # The rate products of the velocity terms of (16) and (17): printed vs corrected.
    if literal:
        v16 = (d1 * d2, d1 * d3, d1 * d4, d1 * d5, d1 * d6)
        v17 = (d1 * d2, d2 * d3, d2 * d4, d2 * d5, d2 * d6)
    else:
        v16 = (d2**2, d3**2, d4**2, d5**2, d6**2)
        v17 = (d1**2, d3**2, d4**2, d5**2, d6**2)

    # (16)
    q1 = (
        (I1 + (m2 + m3 + m4 + m5 + m6) * l1**2) * a1
        + (m2 * n2 + m3 + m4 + m5 + m6) * cos(p1 - p2) * l1 * l2 * a2
        + (m3 * n3 + m4) * cos(p1 - p3) * l1 * l3 * a3
        + m4 * n4 * cos(p1 - p4) * l1 * l4 * a4
        + (m5 * n5 + m6) * cos(p1 - p5) * l1 * l5 * a5
        + m6 * n6 * cos(p1 - p6) * l1 * l6 * a6
        + (m2 * n2 + m3 + m4 + m5 + m6) * sin(p1 - p2) * l1 * l2 * v16[0]
        + (m3 * n3 + m4) * sin(p1 - p3) * l1 * l3 * v16[1]
        + m4 * n4 * sin(p1 - p4) * l1 * l4 * v16[2]
        + (m5 * n5 + m6) * sin(p1 - p5) * l1 * l5 * v16[3]
        + m6 * n6 * sin(p1 - p6) * l1 * l6 * v16[4]
        + (m1 * n1 + m2 + m3 + m4 + m5 + m6) * g * l1 * cos(p1)
    )
    # (17)
    q2 = (
        (m2 * n2 + m3 + m4 + m5 + m6) * cos(p1 - p2) * l1 * l2 * a1
        + (I2 + (m3 + m4 + m5 + m6) * l2**2) * a2
        + (m3 * n3 + m4) * cos(p2 - p3) * l2 * l3 * a3
        + m4 * n4 * cos(p2 - p4) * l2 * l4 * a4
        + (m5 * n5 + m6) * cos(p2 - p5) * l2 * l5 * a5
        + m6 * n6 * cos(p2 - p6) * l2 * l6 * a6
        - (m2 * n2 + m3 + m4 + m5 + m6) * sin(p1 - p2) * l1 * l2 * v17[0]
        + (m3 * n3 + m4) * sin(p2 - p3) * l2 * l3 * v17[1]
        + m4 * n4 * sin(p2 - p4) * l2 * l4 * v17[2]
        + (m5 * n5 + m6) * sin(p2 - p5) * l2 * l5 * v17[3]
        + m6 * n6 * sin(p2 - p6) * l2 * l6 * v17[4]
        + (m2 * n2 + m3 + m4 + m5 + m6) * g * l2 * cos(p2)
    )
    # (18)
    q3 = (
        (m3 * n3 + m4) * cos(p1 - p3) * l1 * l3 * a1
        + (m3 * n3 + m4) * cos(p2 - p3) * l2 * l3 * a2
        + (I3 + m4 * l3**2) * a3
        + m4 * n4 * cos(p3 - p4) * l3 * l4 * a4
        - (m3 * n3 + m4) * sin(p1 - p3) * l1 * l3 * d1**2
        - (m3 * n3 + m4) * sin(p2 - p3) * l2 * l3 * d2**2
        + m4 * n4 * sin(p3 - p4) * l3 * l4 * d4**2
        + (m3 * n3 + m4) * g * l3 * cos(p3)
    )
    # (19)
    q4 = (
        m4 * n4 * cos(p1 - p4) * l1 * l4 * a1
        + m4 * n4 * cos(p2 - p4) * l2 * l4 * a2
        + m4 * n4 * cos(p3 - p4) * l3 * l4 * a3
        + I4 * a4
        - m4 * n4 * sin(p1 - p4) * l1 * l4 * d1**2
        - m4 * n4 * sin(p2 - p4) * l2 * l4 * d2**2
        - m4 * n4 * sin(p3 - p4) * l3 * l4 * d3**2
        + m4 * n4 * g * l4 * cos(p4)
    )
    # (20)
    q5 = (
        (m5 * n5 + m6) * cos(p1 - p5) * l1 * l5 * a1
        + (m5 * n5 + m6) * cos(p2 - p5) * l2 * l5 * a2
        + (I5 + m6 * l5**2) * a5
        + m6 * n6 * cos(p5 - p6) * l5 * l6 * a6
        - (m5 * n5 + m6) * sin(p1 - p5) * l1 * l5 * d1**2
        - (m5 * n5 + m6) * sin(p2 - p5) * l2 * l5 * d2**2
        + m6 * n6 * sin(p5 - p6) * l5 * l6 * d6**2
        + (m5 * n5 + m6) * g * l5 * cos(p5)
    )
    # (21)
    q6 = (
        m6 * n6 * cos(p1 - p6) * l1 * l6 * a1
        + m6 * n6 * cos(p2 - p6) * l2 * l6 * a2
        + m6 * n6 * cos(p5 - p6) * l5 * l6 * a5
        + I6 * a6
        - m6 * n6 * sin(p1 - p6) * l1 * l6 * d1**2
        - m6 * n6 * sin(p2 - p6) * l2 * l6 * d2**2
        - m6 * n6 * sin(p5 - p6) * l5 * l6 * d5**2
        + m6 * n6 * g * l6 * cos(p6)
    )
    return np.stack([q1, q2, q3, q4, q5, q6], axis=-1)


def paper_generalized_forces(
    linkage: Linkage, psi, dpsi, ddpsi, inertia_about: str = "start"
) -> np.ndarray:
    """Left-hand sides of (16)-(21) exactly as printed: Q (6,) or (K, 6), N m."""
    return _equations(linkage, psi, dpsi, ddpsi, True, inertia_about)


def corrected_generalized_forces(
    linkage: Linkage, psi, dpsi, ddpsi, inertia_about: str = "start"
) -> np.ndarray:
    """Left-hand sides of (16)-(21) with the velocity terms of errata 3 corrected, N m."""
    return _equations(linkage, psi, dpsi, ddpsi, False, inertia_about)


def torques_from_generalized(q) -> np.ndarray:
    """Hinge torques from the printed right-hand sides, solved from the last equation up:
    (21) M6 = Q6, (20) M5 - M6 = Q5, (19) M4 = Q4, (18) M3 - M4 = Q3,
    (17) M2 - M3 - M5 = Q2, (16) M1 - M2 = Q1. (6,) or (K, 6), N m."""
    q = np.asarray(q, dtype=float)
    m6 = q[..., 5]
    m5 = q[..., 4] + m6
    m4 = q[..., 3]
    m3 = q[..., 2] + m4
    m2 = q[..., 1] + m3 + m5
    m1 = q[..., 0] + m2
    return np.stack([m1, m2, m3, m4, m5, m6], axis=-1)


def paper_literal_torques(linkage: Linkage, psi, dpsi, ddpsi) -> np.ndarray:
    """Hinge torques M_1..M_6 (N m) from (16)-(21) as printed: (6,) or (K, 6)."""
    return torques_from_generalized(paper_generalized_forces(linkage, psi, dpsi, ddpsi))


def corrected_torques(linkage: Linkage, psi, dpsi, ddpsi) -> np.ndarray:
    """Hinge torques M_1..M_6 (N m) from the corrected (16)-(21): (6,) or (K, 6)."""
    return torques_from_generalized(corrected_generalized_forces(linkage, psi, dpsi, ddpsi))


def kinetic_energy_doubled(
    linkage: Linkage, psi, dpsi, literal: bool = True, inertia_about: str = "start"
) -> np.ndarray:
    """The right-hand side of (14), "2T", J: as printed (``literal``) or with every
    cos(psi_i - psi_k) dpsi_i dpsi_k term doubled (errata 2). Scalar or (K,)."""
    # m_1 and n_1 enter (14) only through I_1, which is about H0.
    (l1, l2, l3, l4, l5, l6), (_m1, m2, m3, m4, m5, m6), n, I, _ = _symbols(linkage, inertia_about)
    _n1, n2, n3, n4, n5, n6 = n
    I1, I2, I3, I4, I5, I6 = I
    p1, p2, p3, p4, p5, p6 = _angles(psi)
    d1, d2, d3, d4, d5, d6 = _angles(dpsi)
    cos = np.cos
    squares = (
        (I1 + (m2 + m3 + m4 + m5 + m6) * l1**2) * d1**2
        + (I2 + (m3 + m4 + m5 + m6) * l2**2) * d2**2
        + (I3 + m4 * l3**2) * d3**2
        + I4 * d4**2
        + (I5 + m6 * l5**2) * d5**2
        + I6 * d6**2
    )
    cross = (
        (m2 * n2 + m3 + m4 + m5 + m6) * l1 * l2 * cos(p1 - p2) * d1 * d2
        + (m3 * n3 + m4) * l1 * l3 * cos(p1 - p3) * d1 * d3
        + (m3 * n3 + m4) * l2 * l3 * cos(p2 - p3) * d2 * d3
        + m4 * n4 * l1 * l4 * cos(p1 - p4) * d1 * d4
        + m4 * n4 * l2 * l4 * cos(p2 - p4) * d2 * d4
        + m4 * n4 * l3 * l4 * cos(p3 - p4) * d3 * d4
        + (m5 * n5 + m6) * l1 * l5 * cos(p1 - p5) * d1 * d5
        + (m5 * n5 + m6) * l2 * l5 * cos(p2 - p5) * d2 * d5
        + m6 * n6 * l1 * l6 * cos(p1 - p6) * d1 * d6
        + m6 * n6 * l2 * l6 * cos(p2 - p6) * d2 * d6
        + m6 * n6 * l5 * l6 * cos(p5 - p6) * d5 * d6
    )
    return squares + (1.0 if literal else 2.0) * cross


def potential_energy(linkage: Linkage, psi) -> np.ndarray:
    """Pi of (15) as printed (correct), J. Scalar or (K,)."""
    (l1, l2, l3, l4, l5, l6), (m1, m2, m3, m4, m5, m6), n, _, g = _symbols(linkage, "start")
    n1, n2, n3, n4, n5, n6 = n
    p1, p2, p3, p4, p5, p6 = _angles(psi)
    sin = np.sin
    return (
        (m1 * n1 + m2 + m3 + m4 + m5 + m6) * g * l1 * sin(p1)
        + (m2 * n2 + m3 + m4 + m5 + m6) * g * l2 * sin(p2)
        + (m3 * n3 + m4) * g * l3 * sin(p3)
        + m4 * n4 * g * l4 * sin(p4)
        + (m5 * n5 + m6) * g * l5 * sin(p5)
        + m6 * n6 * g * l6 * sin(p6)
    )
