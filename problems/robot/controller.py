"""The drives' law in the robot's joint space, and the controller specification of
``joints.csv`` (:func:`problems.robot.joint_space`).

A plan's feedback (``walk --feedback``: the periodic LQR of a step on point feet, the joint
PD of a step on feet) is written in the model's view: M = clip(M_ff(s) + K(s) (x_ref(s) -
x)), x = (psi, dpsi) the absolute link angles, M the tree's hinge torques. A robot's
controller reads encoders and commands physical drives, so the same law is rewritten here:

* the joint state y = A psi + b: each leg's hip, knee and ankle (stance, swing; the file's
  conventions, :mod:`problems.human.joints`), the neck, and the trunk's pitch; n of them are
  independent (a basis, :func:`joint_maps`): the law's gains on the others are 0;
* the drive torques tau = D M (the stance hip is M_trunk + M_swing_thigh; the ground's torque
  on a root foot is no drive and has no row);
* so tau = tau_ff(s) + K_y(s) (z_ref(s) - z), z = (y, dy), with K_y = D K [A_B^-1, 0; 0,
  A_B^-1] on the basis's columns: the same law, exactly, for the same state.

On point feet the plan has no swing foot. A robot that has feet there holds the swing sole
level: its ankle's reference is the angle that makes the sole parallel to the ground (the
stance ankle's definition applied to the swing shank), its feedforward 0, and its gains a PD
(:data:`SWING_ANKLE_KP`, :data:`SWING_ANKLE_KD`: the product's MuJoCo walker's).
"""

from __future__ import annotations

import math

import numpy as np

from problems.control.lqr import SOFT_RAMP, SOFT_SETTLE, SOFT_TOUCHDOWN
from problems.human.joints import Body, joint_radians, leg_moments

#: the swing ankle's PD on point feet, N m/rad and N m s/rad (problems.control.mujoco's)
SWING_ANKLE_KP = 20.0
SWING_ANKLE_KD = 0.2
#: a foot touches down when the ground's normal force on it passes this, N (the product's
#: MuJoCo walker's, problems.control.mujoco.TOUCHDOWN_FORCE)
TOUCHDOWN_N = 5.0
#: the legs' joints, from the hip down
LEG_JOINTS = ("hip", "knee", "ankle")


def joint_keys(head: bool, ankles: bool = True) -> list[str]:
    """The joint state's entries in role terms: ``<stance|swing>_<joint>`` (no ankles on
    point feet with a passive ankle: nothing there to read or drive), ``neck`` (with a head),
    ``trunk_pitch``."""
    joints = LEG_JOINTS if ankles else LEG_JOINTS[:2]
    keys = [f"{role}_{joint}" for role in ("stance", "swing") for joint in joints]
    return keys + (["neck"] if head else []) + ["trunk_pitch"]


def joint_maps(linkage, body: Body, head: int | None, ankles: bool = True):
    """The linear maps of the joint space in role terms (see the module).

    Returns
    -------
    keys : the state's entries (:func:`joint_keys`).
    A : (m, n), b : (m,): y = A psi + b; a point foot's swing ankle's row is its level
        reference.
    planned : (m,) bool: the entries the plan has (a point foot's swing ankle has not).
    basis : n indices of independent planned rows (hips, knees, neck, the trunk's pitch,
        then the ankles as needed: on point feet none, the stance shank's angle following
        from the pitch, hips and knees).
    drives : the drives' keys (the joints with a torque: every planned joint but the pitch).
    D : (len(drives), n): tau = D M.
    """
    names = linkage.names
    n = len(names)
    keys = joint_keys(head is not None, ankles)
    rows, offsets, planned = [], [], []

    def linear(function):
        zero = function(np.zeros(n))
        return np.array([function(np.eye(n)[i]) - zero for i in range(n)]), zero

    for key in keys:
        role, _, joint = key.partition("_")
        if key == "trunk_pitch":
            t = names.index(body.trunk)
            row, zero = linear(lambda psi, t=t: math.pi / 2 - psi[t])
            has = True
        elif key == "neck":
            t = names.index(body.trunk)
            row, zero = linear(lambda psi, t=t: psi[head] - psi[t])
            has = True
        else:
            leg = body.stance if role == "stance" else body.swing
            has = not (joint == "ankle" and leg.foot is None and not leg.stance)
            if has:

                def value(psi, leg=leg, joint=joint):
                    return joint_radians(body, leg, dict(zip(names, psi, strict=True)))[joint]
            else:
                # the sole level: the stance ankle's definition on the swing shank turned up
                s = names.index(leg.shank)

                def value(psi, s=s):
                    return math.pi / 2 - (psi[s] + math.pi)

            row, zero = linear(value)
        rows.append(row)
        offsets.append(zero)
        planned.append(has)
    A, b = np.array(rows), np.array(offsets)
    basis: list[int] = []
    # the ankles last: on point feet the stance shank's angle then comes from the trunk's
    # pitch and the hips and knees (an IMU and encoders), not from an ankle encoder that
    # reads a light foot rocking on the ground (in MuJoCo, gains on it chatter the foot)
    order = [i for i, k in enumerate(keys) if "ankle" not in k]
    order += [i for i, k in enumerate(keys) if "ankle" in k]
    for i in order:
        if planned[i] and np.linalg.matrix_rank(A[[*basis, i]]) == len(basis) + 1:
            basis.append(i)
        if len(basis) == n:
            break
    if len(basis) != n:
        raise ValueError(f"the joint space spans {len(basis)} of the {n} link angles")
    drives = [k for k, has in zip(keys, planned, strict=True) if has and k != "trunk_pitch"]
    D = np.zeros((len(drives), n))
    units = {name: np.eye(n)[i] for i, name in enumerate(names)}
    for r, key in enumerate(drives):
        if key == "neck":
            D[r] = units[names[head]]
            continue
        role, _, joint = key.partition("_")
        leg = body.stance if role == "stance" else body.swing
        D[r] = -np.asarray(leg_moments(body, leg, units, 1.0)[f"{joint}_moment"], dtype=float)
    return keys, A, b, np.array(planned), basis, drives, D


def joint_gains(gains: np.ndarray, A: np.ndarray, basis: list[int], D: np.ndarray) -> np.ndarray:
    """K_y (K, drives, 2m) of the model's K (K, n, 2n) on (psi, dpsi) (see the module)."""
    m, n = A.shape
    inverse = np.linalg.inv(A[basis])  # (n, n): psi - psi_ref from the basis's y
    out = np.zeros((gains.shape[0], D.shape[0], 2 * m))
    out[:, :, basis] = np.einsum("dn,knj,jb->kdb", D, gains[:, :, :n], inverse)
    out[:, :, [m + i for i in basis]] = np.einsum("dn,knj,jb->kdb", D, gains[:, :, n:], inverse)
    return out


def specification(*, feet: bool, double: bool, rate_hz: float, sides, steps: int, state,
                  drives, limits, hip_ahead, gains: bool, robot,
                  ankles: bool = True) -> dict:  # fmt: skip
    """The ``controller`` section of the joint-space sidecar: everything a controller needs
    without the product's code (see examples/robot.md)."""
    contact = "its ball (the toe mark)" if feet else "its foot point (the shank's end)"
    phase = (
        f"s = (d - d0) / (d1 - d0), d the hip joint's horizontal distance ahead of the stance "
        f"foot's contact point, {contact}, m; d0 = hip_ahead_m[0] at the step's start, d1 = "
        "hip_ahead_m[1] at its end; the column phase holds the plan's s"
    )
    spec = {
        "version": 1,
        "rate_hz": rate_hz,
        "law": "tau = clip(tau_ff(s) + K(s) (z_ref(s) - z), -limit, limit) for each drive, "
        "z = (the state's angles, then their rates), tau_ff the tau_ columns, z_ref the "
        "state's columns, K the K_ columns, all at the phase s",
        "state": list(state),
        "drives": {d: {"torque": f"tau_{d}_N_m", "limit_N_m": limits.get(d)} for d in drives},
        "gains": "columns K_<drive>__<state column>: N m/rad on angles, N m s/rad on rates"
        if gains else None,
        "no_gains": None if gains else "the plan was written without feedback (walk "
        "--feedback writes it): only tau_ff and the references",
        "phase": phase,
        "hip_ahead_m": [float(hip_ahead[0]), float(hip_ahead[1])],
        "rows": f"the file holds {steps} steps (step k has the {sides[0]} leg in stance for "
        f"even k): step j of a walk reads the rows with step = j mod {steps}; between rows, "
        "linear in s",
        "strike": f"the swing foot touches down when the ground's normal force on it passes "
        f"{TOUCHDOWN_N:g} N once s > 0.5"
        + (" (its heel: the plan's first contact)" if feet else ""),
        "at_strike": (
            "switch to the rows with double_support = 1 (the double support); the step ends "
            "at s = 1, where the rear foot leaves: the next step's rows from s = 0"
            if double else "the step ends: the next step's rows, from s = 0 measured on the "
            "new stance foot"
        ),
        "early_strike": (
            "a strike before the double support's first row holds that row until s reaches it"
            if double else "a strike before s = 1 ends the step as above"
        ),
        "late": "past the last row of a branch z_ref goes on along its last slope dz/ds, "
        "tau_ff and K hold their last values",
        "before_start": "s below the first row: the first row (z_ref, tau_ff, K)",
        "ankles": (
            "planned on both legs (the feet are links of the plan)" if feet else
            "none: point feet with a passive ankle (nothing to read or drive there)"
            if not ankles else
            "the stance ankle is planned (the shank on a flat sole; the law's gains act "
            "through the trunk's pitch, the hips and the knees, none on the ankle's own q: an "
            "encoder there reads the foot rocking too); the swing leg's ankle "
            "(contact 0) is not in the plan: its rows hold the sole level (q from the shank's "
            f"angle), tau_ff 0, and its K row a PD, kp {SWING_ANKLE_KP:g} N m/rad and kd "
            f"{SWING_ANKLE_KD:g} N m s/rad on its own q and dq"
        ),
    }  # fmt: skip
    if double and not feet:  # the point feet's double support: the LQR's stiff gains
        spec["soft_touchdown"] = (
            SOFT_TOUCHDOWN
            + " (touchdown_settle_s, touchdown_ramp_s): tau = clip(tau_ff + w K (z_ref - z)), "
            "w 0 then rising to 1"
        )
        spec["touchdown_settle_s"] = SOFT_SETTLE
        spec["touchdown_ramp_s"] = SOFT_RAMP
    if robot is not None:
        spec["robot"] = robot
    return spec


__all__ = ["joint_gains", "joint_keys", "joint_maps", "specification"]
