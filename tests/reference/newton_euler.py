"""Independent oracle for the model: recursive Newton-Euler dynamics in plain numpy.

The model (``model/dynamics.py``) writes each centre of mass as a sum of complex exponentials,
forms T and Pi and takes Lagrange's equations of the second kind in generalised forces Q, then
sums Q over subtrees to get hinge torques. This module gets the same numbers another way:

* real 2-vectors and 2x2 rotations, no complex arithmetic, no CasADi, nothing from
  ``model`` but the Linkage's data (links, parents, children, gravity, origin_in_parent,
  Link.com_offset / inertia / mass / length);
* an outward pass propagating hinge and centre-of-mass positions, velocities and accelerations
  link by link (rigid-body kinematics, a x r and -w^2 r terms), then an inward pass applying
  Newton's and Euler's laws to each link about its own centre of mass to get the force and the
  torque its parent applies at its start hinge (Featherstone, Rigid Body Dynamics Algorithms,
  ch. 5, specialised to the plane);
* the mass matrix from columns of that recursion (unit accelerations, zero velocity and
  gravity), mapped from hinge torques to generalised forces by Q_i = M_i - sum_children M_c;
* forward dynamics with ``numpy.linalg.solve`` on that matrix (the model uses a sparse tree
  LDL^T factorisation instead).

A second formulation, :func:`closed_form_mass_matrix` and :func:`closed_form_inverse_dynamics`,
evaluates DESIGN.md's B_km cos(psi_k - psi_m) structure directly for paper-form links.

Conventions (``shared/DESIGN.md``): absolute angles psi from +x counter-clockwise; hinge
torque M_i acts at the start hinge of link i, on link i, from its parent (the ground for the
root); J about the centre of mass; gravity g along -y. Every function accepts one state (n,)
or a batch (K, n) and returns matching leading shapes; batches are vectorised over K.

``random_tree`` builds seeded random trees for the cross-checks.
"""

from __future__ import annotations

import numpy as np

from model import Link, Linkage

__all__ = [
    "angular_momentum",
    "closed_form_inverse_dynamics",
    "closed_form_mass_matrix",
    "com_positions",
    "com_velocities",
    "energy",
    "floating_energy",
    "floating_inverse_dynamics",
    "floating_mass_matrix",
    "forward_dynamics",
    "ground_reaction",
    "hinge_positions",
    "hinge_velocities",
    "inverse_dynamics",
    "mass_matrix",
    "point_jacobian",
    "point_kinematics",
    "random_tree",
]


# ---- plane geometry with real 2-vectors (last axis = (x, y)) ----------------------------
def _vec(z: complex) -> np.ndarray:
    """A complex constant read from the Linkage as a real 2-vector (x, y)."""
    return np.array([z.real, z.imag], dtype=float)


def _rotate(cos: np.ndarray, sin: np.ndarray, r: np.ndarray) -> np.ndarray:
    """R(psi) r for a constant body-frame vector r (2,), batch of angles (K,) -> (K, 2)."""
    return np.stack([cos * r[0] - sin * r[1], sin * r[0] + cos * r[1]], axis=-1)


def _perp(v: np.ndarray) -> np.ndarray:
    """Quarter turn counter-clockwise: e_z x v."""
    return np.stack([-v[..., 1], v[..., 0]], axis=-1)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """z-component of a x b."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _batch(linkage: Linkage, *arrays):
    """Arrays as (K, n) float batches; also whether the input was a single state."""
    n = linkage.n
    out = []
    for a in arrays:
        a = np.asarray(a, dtype=float)
        if a.ndim not in (1, 2) or a.shape[-1] != n:
            raise ValueError(f"oracle: expected shape ({n},) or (K, {n}), got {a.shape}")
        out.append(a)
    if len({a.shape for a in out}) != 1:
        raise ValueError(f"oracle: inputs of different shapes {[a.shape for a in out]}")
    return out[0].ndim == 1, [np.atleast_2d(a) for a in out]


# ---- the recursion ----------------------------------------------------------------------
def _outward(linkage: Linkage, psi, dpsi=None, ddpsi=None):
    """Outward pass: world positions, velocities and accelerations of start hinges, centres
    of mass and end hinges, each a list over links of (K, 2) arrays.

    Velocities/accelerations are omitted (None) when their rates are not given.
    """
    n = linkage.n
    cos, sin = np.cos(psi), np.sin(psi)
    k = psi.shape[0]
    zero = np.zeros((k, 2))
    start, com, end = [None] * n, [None] * n, [None] * n
    v_start, v_com, v_end = [None] * n, [None] * n, [None] * n
    a_start, a_com = [None] * n, [None] * n
    for i, link in enumerate(linkage.links):
        p = linkage.parents[i]
        origin = _vec(linkage.origin_in_parent(i))
        if p < 0:
            # The root's start hinge H0 is pinned to the ground (origin given in world frame).
            start[i] = zero + origin
            if dpsi is not None:
                v_start[i] = zero
            if ddpsi is not None:
                a_start[i] = zero
        else:
            # Lever from the parent's start hinge to this link's start hinge, in the world.
            r = _rotate(cos[:, p], sin[:, p], origin)
            start[i] = start[p] + r
            if dpsi is not None:
                v_start[i] = v_start[p] + dpsi[:, p, None] * _perp(r)
            if ddpsi is not None:
                a_start[i] = (
                    a_start[p] + ddpsi[:, p, None] * _perp(r) - (dpsi[:, p] ** 2)[:, None] * r
                )
        rc = _rotate(cos[:, i], sin[:, i], _vec(link.com_offset))
        re = _rotate(cos[:, i], sin[:, i], np.array([link.length, 0.0]))
        com[i] = start[i] + rc
        end[i] = start[i] + re
        if dpsi is not None:
            v_com[i] = v_start[i] + dpsi[:, i, None] * _perp(rc)
            v_end[i] = v_start[i] + dpsi[:, i, None] * _perp(re)
        if ddpsi is not None:
            a_com[i] = a_start[i] + ddpsi[:, i, None] * _perp(rc) - (dpsi[:, i] ** 2)[:, None] * rc
    return {
        "start": start,
        "com": com,
        "end": end,
        "v_start": v_start,
        "v_com": v_com,
        "v_end": v_end,
        "a_start": a_start,
        "a_com": a_com,
    }


def _rnea(linkage: Linkage, psi, dpsi, ddpsi, gravity: float, base_acceleration=None):
    """Recursive Newton-Euler on batches (K, n): hinge torques (K, n), and the force (K, 2)
    the ground applies to the root at H0 (each link's f is the force its parent applies at
    its start hinge; the root's parent is the ground). ``base_acceleration`` (K, 2): H0
    accelerates (a floating base); every point's acceleration gains it."""
    n = linkage.n
    kin = _outward(linkage, psi, dpsi, ddpsi)
    g = np.array([0.0, -gravity])
    if base_acceleration is not None:
        g = g - base_acceleration
    force = [None] * n
    torque = [None] * n
    for i in reversed(range(n)):
        link = linkage.links[i]
        c = kin["com"][i]
        kids = linkage.children[i]
        # Newton: m a_c = f_i - sum_children f_c + m g  (each child pushes back with -f_c).
        f = link.mass * (kin["a_com"][i] - g) + sum(force[ch] for ch in kids)
        # Euler about the centre of mass:
        #   J ddpsi = M_i - sum M_c + (p_i - c) x f_i + sum (p_c - c) x (-f_c).
        m = (
            link.inertia * ddpsi[:, i]
            - _cross(kin["start"][i] - c, f)
            + sum(torque[ch] + _cross(kin["start"][ch] - c, force[ch]) for ch in kids)
        )
        force[i] = f
        torque[i] = m
    return np.stack(torque, axis=-1), force[0]


def _children_matrix(linkage: Linkage) -> np.ndarray:
    """C[k, c] = 1 when c is a child of k: Q = (I - C) M maps hinge torques to Q."""
    n = linkage.n
    c = np.zeros((n, n))
    for k, kids in enumerate(linkage.children):
        c[k, list(kids)] = 1.0
    return c


def _subtree_matrix(linkage: Linkage) -> np.ndarray:
    """S[k, i] = 1 when i is k or a descendant of k: M = S Q (inverse of I - C)."""
    n = linkage.n
    s = np.eye(n)
    for i in range(n):
        p = linkage.parents[i]
        while p >= 0:
            s[p, i] = 1.0
            p = linkage.parents[p]
    return s


def _unbatch(single: bool, a):
    return a[0] if single else a


# ---- public API ---------------------------------------------------------------------------
def inverse_dynamics(linkage: Linkage, psi, dpsi, ddpsi) -> np.ndarray:
    """Hinge torques M (N m), (n,) or (K, n), by recursive Newton-Euler with gravity."""
    single, (psi, dpsi, ddpsi) = _batch(linkage, psi, dpsi, ddpsi)
    torque, _ = _rnea(linkage, psi, dpsi, ddpsi, linkage.gravity)
    return _unbatch(single, torque)


def mass_matrix(linkage: Linkage, psi) -> np.ndarray:
    """Generalised mass matrix (kg m^2) in the coordinates psi, (n, n) or (K, n, n).

    Column m is the Newton-Euler recursion with ddpsi = e_m, zero velocity and no gravity,
    turned from hinge torques into generalised forces Q = (I - C) M.
    """
    single, (psi,) = _batch(linkage, psi)
    n = linkage.n
    k = psi.shape[0]
    zero = np.zeros((k, n))
    columns = []
    for m in range(n):
        unit = zero.copy()
        unit[:, m] = 1.0
        torque, _ = _rnea(linkage, psi, zero, unit, 0.0)
        columns.append(torque)
    hinge = np.stack(columns, axis=-1)  # (K, n torques, n accelerations)
    result = np.einsum("ij,kjm->kim", np.eye(n) - _children_matrix(linkage), hinge)
    return _unbatch(single, result)


def forward_dynamics(linkage: Linkage, psi, dpsi, torques) -> np.ndarray:
    """Angular accelerations ddpsi (rad/s^2) from hinge torques: a dense ``numpy.linalg.solve``
    of the oracle mass matrix against Q - bias, bias from Newton-Euler with ddpsi = 0."""
    single, (psi, dpsi, torques) = _batch(linkage, psi, dpsi, torques)
    n = linkage.n
    bias, _ = _rnea(linkage, psi, dpsi, np.zeros_like(psi), linkage.gravity)
    to_q = np.eye(n) - _children_matrix(linkage)
    rhs = (torques - bias) @ to_q.T
    mass = mass_matrix(linkage, psi)
    return _unbatch(single, np.linalg.solve(mass, rhs[..., None])[..., 0])


def ground_reaction(linkage: Linkage, psi, dpsi, ddpsi):
    """Force (N) the ground applies to the root at H0, complex Fx + j Fy: scalar or (K,)."""
    single, (psi, dpsi, ddpsi) = _batch(linkage, psi, dpsi, ddpsi)
    _, force = _rnea(linkage, psi, dpsi, ddpsi, linkage.gravity)
    result = force[:, 0] + 1j * force[:, 1]
    return complex(result[0]) if single else result


def energy(linkage: Linkage, psi, dpsi):
    """(T, V) in J: T = sum 1/2 (m |v_c|^2 + J dpsi^2) from the outward velocity pass,
    V = g sum m y_c (zero at the height of H0's origin). Scalars or (K,) arrays."""
    single, (psi, dpsi) = _batch(linkage, psi, dpsi)
    kin = _outward(linkage, psi, dpsi)
    kinetic = np.zeros(psi.shape[0])
    potential = np.zeros(psi.shape[0])
    for i, link in enumerate(linkage.links):
        v = kin["v_com"][i]
        kinetic += 0.5 * (link.mass * np.sum(v * v, axis=-1) + link.inertia * dpsi[:, i] ** 2)
        potential += linkage.gravity * link.mass * kin["com"][i][:, 1]
    if single:
        return float(kinetic[0]), float(potential[0])
    return kinetic, potential


def _as_complex(points: list[np.ndarray]) -> np.ndarray:
    stacked = np.stack(points, axis=1)  # (K, count, 2)
    return stacked[..., 0] + 1j * stacked[..., 1]


def hinge_positions(linkage: Linkage, psi) -> np.ndarray:
    """H0..Hn (m) as complex x + j y, (n+1,) or (K, n+1): H0 is the root's start hinge, H_i
    the end hinge of link i (start + length along its axis)."""
    single, (psi,) = _batch(linkage, psi)
    kin = _outward(linkage, psi)
    return _unbatch(single, _as_complex([kin["start"][0], *kin["end"]]))


def hinge_velocities(linkage: Linkage, psi, dpsi) -> np.ndarray:
    """Velocities (m/s) of H0..Hn, complex, (n+1,) or (K, n+1); H0 is fixed."""
    single, (psi, dpsi) = _batch(linkage, psi, dpsi)
    kin = _outward(linkage, psi, dpsi)
    return _unbatch(single, _as_complex([np.zeros_like(kin["v_end"][0]), *kin["v_end"]]))


def com_positions(linkage: Linkage, psi) -> np.ndarray:
    """Centres of mass w_i (m), complex, (n,) or (K, n)."""
    single, (psi,) = _batch(linkage, psi)
    return _unbatch(single, _as_complex(_outward(linkage, psi)["com"]))


def com_velocities(linkage: Linkage, psi, dpsi) -> np.ndarray:
    """Centre-of-mass velocities (m/s), complex, (n,) or (K, n)."""
    single, (psi, dpsi) = _batch(linkage, psi, dpsi)
    return _unbatch(single, _as_complex(_outward(linkage, psi, dpsi)["v_com"]))


# ---- points on links and the floating base -------------------------------------------------
def point_kinematics(linkage: Linkage, link: int, offset: complex, psi, dpsi, ddpsi):
    """Position (m), velocity (m/s) and acceleration (m/s^2) of the point at ``offset``
    (complex, m, in link ``link``'s frame), complex, () or (K,): rigid-body kinematics from
    the link's start hinge, r = R(psi) offset, v = v_start + dpsi e_z x r,
    a = a_start + ddpsi e_z x r - dpsi^2 r."""
    single, (psi, dpsi, ddpsi) = _batch(linkage, psi, dpsi, ddpsi)
    kin = _outward(linkage, psi, dpsi, ddpsi)
    r = _rotate(np.cos(psi[:, link]), np.sin(psi[:, link]), _vec(offset))
    w, dw = dpsi[:, link, None], ddpsi[:, link, None]
    position = kin["start"][link] + r
    velocity = kin["v_start"][link] + w * _perp(r)
    acceleration = kin["a_start"][link] + dw * _perp(r) - w**2 * r
    out = [a[:, 0] + 1j * a[:, 1] for a in (position, velocity, acceleration)]
    return tuple(complex(a[0]) for a in out) if single else tuple(out)


def point_jacobian(linkage: Linkage, link: int, offset: complex, psi) -> np.ndarray:
    """d(x, y)/dq of the point ``offset`` on link ``link`` for q = (x0, y0, psi): (2, n + 2)
    or (K, 2, n + 2), columns = the point's velocity for a unit rate of one coordinate."""
    single, (psi,) = _batch(linkage, psi)
    k, n = psi.shape
    out = np.zeros((k, 2, n + 2))
    out[:, 0, 0] = 1.0
    out[:, 1, 1] = 1.0
    zero = np.zeros((k, n))
    for m in range(n):
        unit = zero.copy()
        unit[:, m] = 1.0
        _, velocity, _ = point_kinematics(linkage, link, offset, psi, unit, zero)
        out[:, 0, 2 + m], out[:, 1, 2 + m] = velocity.real, velocity.imag
    return _unbatch(single, out)


def _split_floating(linkage: Linkage, *arrays):
    """(K, n + 2) floating-base arrays -> base parts (K, 2) and psi parts (K, n)."""
    out = []
    single = None
    for a in arrays:
        a = np.asarray(a, dtype=float)
        single = a.ndim == 1
        a = np.atleast_2d(a)
        if a.shape[-1] != linkage.n + 2:
            raise ValueError(f"oracle: expected (n + 2,) = {linkage.n + 2} columns, got {a.shape}")
        out.append((a[:, :2], a[:, 2:]))
    return single, out


def floating_energy(linkage: Linkage, q, dq):
    """(T, V), J, with the root hinge at (x0, y0) moving at (dx0, dy0): every centre of
    mass's velocity gains the base velocity, every height gains y0. q = (x0, y0, psi)."""
    single, ((base, psi), (dbase, dpsi)) = _split_floating(linkage, q, dq)
    kin = _outward(linkage, psi, dpsi)
    kinetic = np.zeros(psi.shape[0])
    potential = np.zeros(psi.shape[0])
    for i, link in enumerate(linkage.links):
        v = kin["v_com"][i] + dbase
        kinetic += 0.5 * (link.mass * np.sum(v * v, axis=-1) + link.inertia * dpsi[:, i] ** 2)
        potential += linkage.gravity * link.mass * (kin["com"][i][:, 1] + base[:, 1])
    if single:
        return float(kinetic[0]), float(potential[0])
    return kinetic, potential


def floating_inverse_dynamics(linkage: Linkage, q, dq, ddq):
    """(force on the base at H0, N, complex; hinge torques M, N m) of a floating-base motion:
    Newton-Euler with H0 accelerating at (ddx0, ddy0). () / (n,) or (K,) / (K, n)."""
    single, ((_, psi), (_, dpsi), (ddbase, ddpsi)) = _split_floating(linkage, q, dq, ddq)
    torque, force = _rnea(linkage, psi, dpsi, ddpsi, linkage.gravity, ddbase)
    base = force[:, 0] + 1j * force[:, 1]
    return (complex(base[0]), torque[0]) if single else (base, torque)


def floating_mass_matrix(linkage: Linkage, psi) -> np.ndarray:
    """Mass matrix of q = (x0, y0, psi), (n + 2, n + 2) or (K, ...): columns of the floating
    Newton-Euler recursion with a unit acceleration of one coordinate, no velocity and no
    gravity; rows: the base force (x, y) and the generalised forces Q = (I - C) M."""
    single, (psi,) = _batch(linkage, psi)
    n = linkage.n
    k = psi.shape[0]
    to_q = np.eye(n) - _children_matrix(linkage)
    result = np.zeros((k, n + 2, n + 2))
    for m in range(n + 2):
        unit = np.zeros((k, n + 2))
        unit[:, m] = 1.0
        torque, force = _rnea(linkage, psi, np.zeros((k, n)), unit[:, 2:], 0.0, unit[:, :2])
        result[:, :2, m] = force
        result[:, 2:, m] = torque @ to_q.T
    return _unbatch(single, result)


def angular_momentum(linkage: Linkage, q, dq, about, links=None) -> np.ndarray:
    """Angular momentum (kg m^2/s, counter-clockwise) of ``links`` (indices; default all)
    about the fixed point ``about`` (complex, m, () or (K,)):
    sum_i (w_i - about) x m_i v_i + J_i dpsi_i, with the floating base's q and dq."""
    single, ((base, psi), (dbase, dpsi)) = _split_floating(linkage, q, dq)
    kin = _outward(linkage, psi, dpsi)
    about = np.atleast_1d(np.asarray(about, dtype=complex))
    anchor = np.stack([about.real, about.imag], axis=-1)
    total = np.zeros(psi.shape[0])
    for i in range(linkage.n) if links is None else links:
        link = linkage.links[i]
        r = kin["com"][i] + base - anchor
        v = kin["v_com"][i] + dbase
        total += link.mass * _cross(r, v) + link.inertia * dpsi[:, i]
    return float(total[0]) if single else total


# ---- the closed form of DESIGN.md (paper-form links only) ---------------------------------
def _closed_form_constants(linkage: Linkage):
    """a_ik (m) and B_km (kg m^2) of DESIGN.md: a_ik = l_k for k a strict ancestor of i,
    n_i l_i for k = i; B = A^T diag(m) A + diag(J)."""
    if not linkage.is_paper_form:
        raise ValueError(
            "closed form: needs paper-form links (centre of mass on the axis, each link "
            "starting at its parent's end hinge, root at the origin)"
        )
    n = linkage.n
    a = np.zeros((n, n))
    for i, link in enumerate(linkage.links):
        a[i, i] = link.com * link.length
        p = linkage.parents[i]
        while p >= 0:
            a[i, p] = linkage.links[p].length
            p = linkage.parents[p]
    mass = np.array([link.mass for link in linkage.links])
    inertia = np.array([link.inertia for link in linkage.links])
    b = a.T @ (mass[:, None] * a) + np.diag(inertia)
    return a, b, mass


def closed_form_mass_matrix(linkage: Linkage, psi) -> np.ndarray:
    """M_km = B_km cos(psi_k - psi_m) (DESIGN.md), (n, n) or (K, n, n)."""
    single, (psi,) = _batch(linkage, psi)
    _, b, _ = _closed_form_constants(linkage)
    diff = psi[:, :, None] - psi[:, None, :]
    return _unbatch(single, b * np.cos(diff))


def closed_form_inverse_dynamics(linkage: Linkage, psi, dpsi, ddpsi) -> np.ndarray:
    """Hinge torques from DESIGN.md's Lagrange form
        Q_k = sum_m B_km cos(psi_k - psi_m) ddpsi_m + B_km sin(psi_k - psi_m) dpsi_m^2
              + g cos(psi_k) sum_i m_i a_ik,
    then M = S Q (sum of Q over each subtree). (n,) or (K, n)."""
    single, (psi, dpsi, ddpsi) = _batch(linkage, psi, dpsi, ddpsi)
    a, b, mass = _closed_form_constants(linkage)
    diff = psi[:, :, None] - psi[:, None, :]
    q = (
        np.einsum("kij,kj->ki", b * np.cos(diff), ddpsi)
        + np.einsum("kij,kj->ki", b * np.sin(diff), dpsi**2)
        + linkage.gravity * np.cos(psi) * (mass @ a)
    )
    return _unbatch(single, q @ _subtree_matrix(linkage).T)


# ---- random trees -------------------------------------------------------------------------
def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(np.exp(rng.uniform(np.log(low), np.log(high))))


def random_tree(
    rng: np.random.Generator,
    n_links: int,
    *,
    span: tuple[float, float] = (1e-2, 1e2),
    min_branch_points: int | None = None,
    general: bool = False,
    gravity: float = 9.81,
) -> Linkage:
    """A seeded random planar tree of ``n_links`` links (1..12 or more).

    Lengths (m), masses (kg) and inertias about the centre of mass (kg m^2) are log-uniform
    over ``span``; com fractions uniform in [0, 1]. Each new link extends the previous one
    with probability 1/2 (deep chains), else hangs from a uniformly drawn earlier link
    (branching); drawing repeats until the tree has ``min_branch_points`` links with two or
    more children (default: 2 for n_links >= 5, 1 for n_links >= 3).

    ``general=True`` also gives every link off-axis centres of mass (``com_lateral``) and
    start hinges away from the parent's end (``origin``, root included), as locked bodies
    have; such links are outside the paper's form.
    """
    if min_branch_points is None:
        min_branch_points = 2 if n_links >= 5 else (1 if n_links >= 3 else 0)
    low, high = span
    while True:
        parents = [-1]
        for i in range(1, n_links):
            parents.append(i - 1 if rng.uniform() < 0.5 else int(rng.integers(0, i)))
        counts = np.bincount(parents[1:], minlength=n_links) if n_links > 1 else np.zeros(1)
        if int(np.sum(counts >= 2)) >= min_branch_points:
            break
    links = []
    for i, p in enumerate(parents):
        length = _log_uniform(rng, low, high)
        extra = {}
        if general:
            extra["com_lateral"] = float(rng.uniform(-0.5, 0.5))
            scale = length if p < 0 else links[p].length
            extra["origin"] = complex(*(scale * rng.uniform(-1.0, 1.0, 2)))
        links.append(
            Link(
                name=f"L{i}",
                parent=None if p < 0 else f"L{p}",
                length=length,
                mass=_log_uniform(rng, low, high),
                com=float(rng.uniform(0.0, 1.0)),
                inertia=_log_uniform(rng, low, high),
                **extra,
            )
        )
    return Linkage(links, gravity=gravity)
