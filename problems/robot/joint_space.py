"""A planned walking step as a robot's drives see it: one stride or more, left and right.

A planned step (the point-foot ``walking_step`` or the ``footed_step``) is written in the
model's view (``torques.csv``: absolute link angles from +x, hinge torques of a tree rooted at
the stance foot, legs named stance and swing). A drive controller reads encoders of relative
joint angles and commands motors named left hip, right knee; this module writes that view,
``joints.csv`` beside the model's file:

* **steps**: step 0 is the planned step with the ``sides[0]`` leg in stance, step 1 the same
  step mirrored (the gait is symmetric: the legs swap at every strike), and so on; one stride
  is two steps. Times run on from step to step; where two steps meet the later step's first
  sample is kept (after an impact, as in the model's file).
* **joints** (``problems.human.joints``: the one conversion, tested on poses and by power):
  hip, knee and ankle of each side, q in rad, 0 standing upright with the foot flat, positive
  = flexion (hip and knee) and dorsiflexion (ankle, toes up); a walker on point feet has no
  ankle in swing (its stance "ankle" is its shank on a flat sole, driven by the root's torque);
  ``neck`` (the head on the trunk, positive = the head tilting back) when the walker has a
  head. Rates and accelerations by the same linear map.
* **drive torques** ``tau_<joint>_N_m``: each physical drive's torque in the sense that grows
  its q (so the drive's power is tau dq). The hips are the drives between the trunk and each
  thigh: the stance hip carries M_trunk + M_swing_thigh of the tree, the swing hip
  M_swing_thigh; which tree column a drive is changes every step, this file's does not.
* **the trunk** ``trunk_pitch_rad`` (forward lean from the vertical, an IMU's pitch) and its
  rate: the one absolute angle a controller needs beside the joints.
* **contacts** per foot: ``contact_<side>`` (1 on the ground), the ground's force on the foot
  ``ground_force_<side>_x_N``, ``_y_N``, and on feet the ground's torque on a flat foot about
  its ball ``ground_torque_<side>_N_m`` (no drive: its centre of pressure on the sole). Drive
  columns start with ``tau_``, ground columns with ``ground_``: never the same prefix.

The sidecar ``joints.csv.meta.json`` (schema :data:`SCHEMA`, version :data:`VERSION`) states
the columns with their units, every joint's zero, sign and limit, the drive torque's relation
to the model's hinges, the stride, and the leg swap of the model's view as a matrix and an
offset.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from model.linkage import Linkage
from model.linkage_trajectory import LinkageTrajectory
from planner.errors import DefinitionError, DefinitionTypeError
from planner.files import write_text_atomically
from planner.trajectory import Trajectory
from problems.gait.biped import Biped
from problems.human.joints import Body, Leg, body_of, joint_radians, leg_moments
from problems.human.stride import foot_forces, strike_time

SCHEMA = "anthropoid-planner joint space"
VERSION = 1
JOINTS = ("hip", "knee", "ankle")


@dataclass(frozen=True)
class JointSpace:
    """The robot's view (see the module): ``columns`` {name: (K,) values} in file order,
    ``units`` {name: unit}, ``metadata`` (the sidecar's content)."""

    columns: dict[str, np.ndarray]
    units: dict[str, str]
    metadata: dict[str, Any]

    @property
    def time(self) -> np.ndarray:
        return self.columns["t_s"]

    def save(self, path: str | Path) -> Path:
        """``path`` (.csv: a header of names without spaces, one row per sample) and its
        sidecar ``<path>.meta.json``, each written whole or not at all."""
        path = Path(path)
        names = list(self.columns)
        rows = np.column_stack([self.columns[n] for n in names])
        lines = [",".join(names)]
        lines += [",".join(repr(float(v)) for v in row) for row in rows]
        write_text_atomically(path, "\n".join(lines) + "\n")
        write_text_atomically(path.with_name(path.name + ".meta.json"),
               json.dumps(self.metadata, indent=1, allow_nan=False) + "\n")  # fmt: skip
        return path


def _linear(body: Body, leg: Leg, names: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
    """(A (3, n), b (3,)): the leg's (hip, knee, ankle) = A psi + b, read off
    :func:`problems.human.joints.joint_radians` (linear in psi); a missing ankle row NaN."""

    def angles(psi):
        values = joint_radians(body, leg, dict(zip(names, psi, strict=True)))
        return np.array([np.nan if values[j] is None else values[j] for j in JOINTS])

    zero = angles(np.zeros(len(names)))
    columns = [angles(np.eye(len(names))[i]) - zero for i in range(len(names))]
    return np.column_stack(columns), zero


def _model(trajectory: Trajectory) -> tuple[LinkageTrajectory, Mapping[str, Any], Linkage]:
    if not isinstance(trajectory, Trajectory):
        raise DefinitionTypeError(
            f"`trajectory`: must be a planner.Trajectory, got {type(trajectory).__name__}"
        )
    trajectory = LinkageTrajectory.of(trajectory)
    settings = (trajectory.metadata or {}).get("gait")
    if not isinstance(settings, Mapping) or settings.get("problem") not in (
        "walking_step", "footed_step"
    ):  # fmt: skip
        raise DefinitionError(
            "`trajectory`: the joint-space view is of a planned walking step (walking_step or "
            "footed_step) with its settings in metadata['gait']; a torques.csv read without its "
            "sidecar torques.csv.meta.json has none"
        )
    return trajectory, settings, Linkage.from_parameters(trajectory.metadata["model"])


def joint_space(
    trajectory: Trajectory, *, steps: int = 2, sides: tuple[str, str] = ("right", "left")
) -> JointSpace:
    """The robot's view of a planned step's exported samples (``gait.to_trajectory(rate)``
    or ``LinkageTrajectory.load("torques.csv")``): ``steps`` steps (2: one stride), the
    ``sides[0]`` leg in stance in step 0 (see the module)."""
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise DefinitionError(f"`steps`: an integer >= 1 (2 = one stride), got {steps!r}")
    if (not isinstance(sides, tuple | list) or len(sides) != 2 or sides[0] == sides[1]
            or not all(isinstance(s, str) and s.isidentifier() for s in sides)):  # fmt: skip
        raise DefinitionError(
            f"`sides`: two different names for the legs (letters, digits, _), the first in "
            f"stance in step 0, got {sides!r}"
        )
    trajectory, settings, linkage = _model(trajectory)
    body = body_of(linkage, settings.get("neutral_ankles"))
    time = np.asarray(trajectory.time, dtype=float) - float(trajectory.time[0])
    T = float(time[-1])
    t_s = strike_time(settings, T)
    in_double = time >= t_s - 1e-12 if t_s < T else np.zeros(time.shape, bool)
    per_leg, shared = _step_columns(trajectory, linkage, body, in_double)
    columns: dict[str, list[np.ndarray]] = {}
    units: dict[str, str] = {}
    for step in range(steps):
        # where two steps meet the later step's first sample is kept
        keep = np.ones(time.shape, bool)
        keep[-1] = step == steps - 1
        side_of = {"stance": sides[step % 2], "swing": sides[(step + 1) % 2]}
        step_columns = {
            "t_s": (time + step * T, "s"),
            "step": (np.full(time.shape, float(step)), ""),
            f"stance_{sides[0]}": (np.full(time.shape, float(step % 2 == 0)), ""),
            "double_support": (in_double.astype(float), ""),
            **shared,
        }
        for role, templates in per_leg.items():
            step_columns.update({name.format(side=side_of[role]): column
                                 for name, column in templates.items()})  # fmt: skip
        for name, (values, unit) in step_columns.items():
            columns.setdefault(name, []).append(np.asarray(values, dtype=float)[keep])
            units[name] = unit
    head = "q_neck_rad" in shared
    feet = body.stance.foot is not None
    ordered = _ordered(columns, sides, head, feet)
    joined = {name: np.concatenate(columns[name]) for name in ordered}
    units = {n: units[n] for n in ordered}
    metadata = _metadata(settings, linkage, sides, steps, T, t_s, feet, head, units, joined)
    return JointSpace(joined, units, metadata)


#: A joint's channels: (prefix, unit, the column name's unit suffix).
_CHANNELS = (("q", "rad", "rad"), ("dq", "rad/s", "rad_s"), ("ddq", "rad/s^2", "rad_s2"),
             ("tau", "N m", "N_m"))  # fmt: skip


def _step_columns(trajectory, linkage: Linkage, body: Body, in_double: np.ndarray):
    """One step's columns: ({"stance" | "swing": {name with "{side}": (values (K,), unit)}},
    {name: (values, unit)} of the neck and the trunk)."""
    names = linkage.names
    psi, dpsi = np.asarray(trajectory.psi), np.asarray(trajectory.dpsi)
    ddpsi, torques = np.asarray(trajectory.ddpsi), np.asarray(trajectory.torques)
    by_name = {name: torques[:, i] for i, name in enumerate(names)}
    rear, front = foot_forces(trajectory, names[0])
    size = psi.shape[0]
    per_leg = {}
    for role, leg, force, contact in (("stance", body.stance, rear, np.ones(size)),
                                      ("swing", body.swing, front, in_double)):  # fmt: skip
        A, b = _linear(body, leg, names)
        moments = leg_moments(body, leg, by_name, 1.0)
        columns = {}
        for k, joint in enumerate(JOINTS):
            # a point foot's swing ankle has none: NaN
            values = {"q": psi @ A[k] + b[k], "dq": dpsi @ A[k], "ddq": ddpsi @ A[k],
                      "tau": -np.asarray(moments[f"{joint}_moment"], dtype=float)}  # fmt: skip
            for prefix, unit, suffix in _CHANNELS:
                column = np.full(size, np.nan) if np.isnan(b[k]) else values[prefix]
                columns[f"{prefix}_{{side}}_{joint}_{suffix}"] = (column, unit)
        columns["contact_{side}"] = (np.asarray(contact, dtype=float), "")
        columns["ground_force_{side}_x_N"] = (force.real, "N")
        columns["ground_force_{side}_y_N"] = (force.imag, "N")
        if body.stance.foot is not None:
            ground = torques[:, 0] if role == "stance" else np.zeros(size)
            columns["ground_torque_{side}_N_m"] = (ground, "N m")
        per_leg[role] = columns
    t = names.index(body.trunk)
    shared = {}
    head = next((i for i, p in enumerate(linkage.parents) if p == t), None)
    if head is not None:
        shared = {
            "q_neck_rad": (psi[:, head] - psi[:, t], "rad"),
            "dq_neck_rad_s": (dpsi[:, head] - dpsi[:, t], "rad/s"),
            "ddq_neck_rad_s2": (ddpsi[:, head] - ddpsi[:, t], "rad/s^2"),
            "tau_neck_N_m": (torques[:, head], "N m"),
        }
    shared["trunk_pitch_rad"] = (math.pi / 2 - psi[:, t], "rad")
    shared["trunk_pitch_rate_rad_s"] = (-dpsi[:, t], "rad/s")
    return per_leg, shared


def _ordered(columns, sides, neck: bool, feet: bool) -> list[str]:
    """File order: time and phase, each side's joints (q, dq, ddq, tau), the neck, the trunk,
    each side's contact."""
    order = ["t_s", "step", f"stance_{sides[0]}", "double_support"]
    for prefix in ("q", "dq", "ddq", "tau"):
        for side in sides:
            order += [n for n in columns if n.startswith(f"{prefix}_{side}_")]
    if neck:
        order += ["q_neck_rad", "dq_neck_rad_s", "ddq_neck_rad_s2", "tau_neck_N_m"]
    order += ["trunk_pitch_rad", "trunk_pitch_rate_rad_s"]
    for side in sides:
        order += [f"contact_{side}", f"ground_force_{side}_x_N", f"ground_force_{side}_y_N"]
        if feet:
            order.append(f"ground_torque_{side}_N_m")
    seen = set()
    return [n for n in order if not (n in seen or seen.add(n))]


def _metadata(settings, linkage, sides, steps, T, t_s, feet, head: bool, units,
              columns) -> dict[str, Any]:  # fmt: skip
    limits = settings.get("torque_limit") or {}
    limit = float(max(limits.values())) if isinstance(limits, Mapping) and limits else None
    joints = []
    for side in sides:
        for joint in JOINTS:
            column = f"tau_{side}_{joint}_N_m"
            values = columns[column]
            if np.all(np.isnan(values)):
                continue
            joints.append({
                "name": f"{side}_{joint}",
                "angle": f"q_{side}_{joint}_rad",
                "torque": column,
                "zero": "standing upright, the foot flat" if joint != "ankle" else
                        "the shank perpendicular to the sole (heel-ball line)",
                "positive": {"hip": "flexion (the thigh forward of the trunk)",
                             "knee": "flexion (the shank behind the thigh)",
                             "ankle": "dorsiflexion (the toes up)"}[joint],
                "torque_sense": "grows q (power = tau dq)",
                "limit_N_m": limit,
                "peak_N_m": float(np.nanmax(np.abs(values))),
            })  # fmt: skip
    if head:
        values = columns["tau_neck_N_m"]
        joints.append({"name": "neck", "angle": "q_neck_rad", "torque": "tau_neck_N_m",
                       "zero": "the head in line with the trunk",
                       "positive": "extension (the head tilting back)",
                       "torque_sense": "grows q (power = tau dq)", "limit_N_m": limit,
                       "peak_N_m": float(np.max(np.abs(values)))})  # fmt: skip
    biped = Biped.of(linkage)
    swap = biped.swap
    permutation = np.zeros((linkage.n, linkage.n))
    permutation[np.arange(linkage.n), list(swap.source)] = 1.0
    return {
        "format": SCHEMA,
        "version": VERSION,
        "columns": {name: unit for name, unit in units.items()},
        "sides": list(sides),
        "steps": steps,
        "step_time_s": T,
        "step_length_m": settings.get("step_length"),
        "stride": f"step k has the {sides[0]} leg in stance for even k, the {sides[1]} for odd "
        "k; a stride is two steps; where two steps meet the later's first sample is kept",
        "strike_s": t_s if t_s < T else T,
        "feet": "heel and ball" if feet else "points",
        "joints": joints,
        "hips": "the physical drives between the trunk and each thigh: the stance hip's "
        "torque is the tree's M_trunk + M_swing_thigh, the swing hip's M_swing_thigh; the plan "
        "bounds the tree's hinges, so a stance hip's peak may exceed the limit: see peak_N_m",
        "contacts": {
            side: {
                "state": f"contact_{side}",
                "force": [f"ground_force_{side}_x_N", f"ground_force_{side}_y_N"],
                **({"ground_torque": f"ground_torque_{side}_N_m"} if feet else {}),
            }
            for side in sides
        },
        "model_view": {
            "file": "torques.csv",
            "links": list(linkage.names),
            "leg_swap": {
                "psi_new = P psi_old + offset; dpsi_new = P dpsi_old": True,
                "P": permutation.tolist(),
                "offset_rad": np.asarray(swap.angle_offsets, dtype=float).tolist(),
            },
        },
    }
