"""The six-link anthropoid's equations of motion in sympy, for opty (helper of opty_compare.py).

Written independently of ``model/`` from the closed form of DESIGN.md ("Equations the model
must reproduce") and the scene.md table, so that checking them against
``model.Dynamics.inverse_dynamics`` is a genuine cross-check:

    sum_m B_km cos(psi_k - psi_m) ddpsi_m + sum_m B_km sin(psi_k - psi_m) dpsi_m^2
        + g cos(psi_k) sum_i m_i a_ik = Q_k,          k = 1..6,

    B_km = sum_i m_i a_ik a_im + J_k [k = m],   a_ik = l_k (k strict ancestor of i),
    a_ii = n_i l_i,   Q_k = M_k - sum_{c child of k} M_c.

Angles psi_k are absolute (from +x, counter-clockwise), M_k is the hinge torque at the start
hinge of link k (N m). Importing this module needs sympy only (no opty).
"""

from __future__ import annotations

import numpy as np
import sympy as sm

#: scene.md: name, parent index (0-based, None = ground), l (m), m (kg), n, J (kg m^2).
SCENE: tuple[tuple[str, int | None, float, float, float, float], ...] = (
    ("stance_shank", None, 0.43, 3.3, 0.57, 0.05),
    ("stance_thigh", 0, 0.43, 7.0, 0.57, 0.12),
    ("swing_thigh", 1, 0.43, 7.0, 0.43, 0.12),
    ("swing_shank", 2, 0.43, 3.3, 0.43, 0.05),
    ("torso", 1, 0.50, 34.0, 0.55, 0.90),
    ("head", 4, 0.25, 5.3, 0.50, 0.03),
)
GRAVITY = 9.81


def _ancestors(i: int) -> list[int]:
    out, parent = [], SCENE[i][1]
    while parent is not None:
        out.append(parent)
        parent = SCENE[parent][1]
    return out


def lever_arms() -> np.ndarray:
    """a_ik (6, 6), m: l_k for k a strict ancestor of i, n_i l_i on the diagonal, else 0."""
    n = len(SCENE)
    a = np.zeros((n, n))
    for i, (_, _, length, _, com, _) in enumerate(SCENE):
        a[i, i] = com * length
        for k in _ancestors(i):
            a[i, k] = SCENE[k][2]
    return a


def constants() -> tuple[np.ndarray, np.ndarray]:
    """(B (6, 6) kg m^2, G (6,) kg m) with G_k = sum_i m_i a_ik."""
    a = lever_arms()
    mass = np.array([row[3] for row in SCENE])
    inertia = np.array([row[5] for row in SCENE])
    b = a.T @ (mass[:, None] * a) + np.diag(inertia)
    return b, a.T @ mass


def generalised_forces(torques):
    """Q_k = M_k - sum over children c of M_c; works on sympy or numpy sequences."""
    q = list(torques)
    for c, (_, parent, *_rest) in enumerate(SCENE):
        if parent is not None:
            q[parent] = q[parent] - torques[c]
    return q


def residual(psi, dpsi, ddpsi, torques):
    """Left side minus Q_k of the equations above, (6,) list; sympy or numpy (scalar) entries."""
    b, g_arm = constants()
    cos = sm.cos if isinstance(psi[0], sm.Basic) else np.cos
    sin = sm.sin if isinstance(psi[0], sm.Basic) else np.sin
    q = generalised_forces(torques)
    n = len(SCENE)
    rows = []
    for k in range(n):
        row = GRAVITY * g_arm[k] * cos(psi[k]) - q[k]
        for m in range(n):
            c, s = cos(psi[k] - psi[m]), sin(psi[k] - psi[m])
            row = row + b[k, m] * (c * ddpsi[m] + s * dpsi[m] ** 2)
        rows.append(row)
    return rows


def opty_equations():
    """The first-order implicit system for opty.

    Returns ``(eom, psi, dpsi, torques, t)``: ``eom`` a (12, 1) sympy Matrix, rows
    ``psi_k' - dpsi_k`` then the six equations above with ddpsi = dpsi'; ``psi``, ``dpsi``
    (states) and ``torques`` (unknown inputs) lists of functions of the time symbol ``t``.
    """
    t = sm.symbols("t")
    names = [row[0] for row in SCENE]
    psi = [sm.Function(f"psi_{k}")(t) for k in names]
    dpsi = [sm.Function(f"dpsi_{k}")(t) for k in names]
    torques = [sm.Function(f"M_{k}")(t) for k in names]
    kinematic = [p.diff(t) - w for p, w in zip(psi, dpsi, strict=True)]
    dynamic = residual(psi, dpsi, [w.diff(t) for w in dpsi], torques)
    return sm.Matrix(kinematic + dynamic), psi, dpsi, torques, t


def inverse_dynamics(psi, dpsi, ddpsi) -> np.ndarray:
    """Hinge torques M (6,), N m, solved from the equations above (numpy, for cross-checks)."""
    # residual is affine in M: residual(M) = r0 - C M, so M = C^-1 r0.
    zero = np.zeros(len(SCENE))
    r0 = np.array(residual(psi, dpsi, ddpsi, zero))
    columns = [
        r0 - np.array(residual(psi, dpsi, ddpsi, np.eye(len(SCENE))[j])) for j in range(len(SCENE))
    ]
    return np.linalg.solve(np.array(columns).T, r0)
