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
from model.points import LinkPoint
from planner.errors import DefinitionError, DefinitionTypeError
from planner.files import write_text_atomically
from planner.trajectory import Trajectory
from problems.control.feedback import gains_from
from problems.gait.biped import Biped
from problems.human.joints import Body, body_of, wrapped
from problems.human.stride import foot_forces, strike_time
from problems.robot.controller import (
    SWING_ANKLE_KD,
    SWING_ANKLE_KP,
    joint_gains,
    joint_maps,
    specification,
)

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
    trajectory: Trajectory, *, steps: int = 2, sides: tuple[str, str] | None = None
) -> JointSpace:
    """The robot's view of a planned step's exported samples (``gait.to_trajectory(rate)``
    or ``LinkageTrajectory.load("torques.csv")``): ``steps`` steps (2: one stride), the
    ``sides[0]`` leg in stance in step 0 (default: the robot's sides when the plan is of a
    URDF, ``walk --urdf``, else right, left) (see the module)."""
    if isinstance(steps, bool) or not isinstance(steps, int) or steps < 1:
        raise DefinitionError(f"`steps`: an integer >= 1 (2 = one stride), got {steps!r}")
    trajectory, settings, linkage = _model(trajectory)
    robot = (trajectory.metadata or {}).get("robot")
    sides = _checked_sides(sides, robot)
    body = body_of(linkage, settings.get("neutral_ankles"))
    time = np.asarray(trajectory.time, dtype=float) - float(trajectory.time[0])
    T = float(time[-1])
    t_s = strike_time(settings, T)
    in_double = time >= t_s - 1e-12 if t_s < T else np.zeros(time.shape, bool)
    # a point foot's passive ankle: no drive and no encoder there (RABBIT has no ankles)
    ankles = body.stance.foot is not None or linkage.names[0] not in (settings.get("passive")
                                                                      or ())  # fmt: skip
    step = _StepColumns.of(trajectory, linkage, body, in_double, ankles)
    columns: dict[str, list[np.ndarray]] = {}
    units: dict[str, str] = {}
    for index in range(steps):
        # where two steps meet the later step's first sample is kept
        keep = np.ones(time.shape, bool)
        keep[-1] = index == steps - 1
        side_of = {"stance": sides[index % 2], "swing": sides[(index + 1) % 2]}
        step_columns = {
            "t_s": (time + index * T, "s"),
            "step": (np.full(time.shape, float(index)), ""),
            f"stance_{sides[0]}": (np.full(time.shape, float(index % 2 == 0)), ""),
            "double_support": (in_double.astype(float), ""),
            "phase": (step.phase, ""),
            **step.named(side_of),
        }
        for name, (values, unit) in step_columns.items():
            columns.setdefault(name, []).append(np.asarray(values, dtype=float)[keep])
            units[name] = unit
    head = step.head is not None
    feet = body.stance.foot is not None
    ordered = _ordered(columns, sides, head, feet)
    joined = {name: np.concatenate(columns[name]) for name in ordered}
    units = {n: units[n] for n in ordered}
    metadata = _metadata(settings, linkage, sides, steps, T, t_s, feet, head, units, joined)
    limits = {j["name"]: j["limit_N_m"] for j in metadata["joints"]}
    if robot:
        _encoders_in_file_terms(metadata, robot, step, sides, joined)
    state = [step.column(key, "q", {"stance": sides[0], "swing": sides[1]}) for key in step.keys]
    state += [step.column(key, "dq", {"stance": sides[0], "swing": sides[1]}) for key in step.keys]
    metadata["controller"] = specification(
        feet=feet, double=bool(np.any(in_double)), rate_hz=_rate(time), sides=sides,
        steps=steps, state=state, drives=[j["name"] for j in metadata["joints"]],
        limits=limits, hip_ahead=step.hip_ahead, gains=step.gains is not None,
        robot=_robot_section(robot), ankles=ankles,
    )  # fmt: skip
    return JointSpace(joined, units, metadata)


def _foot_columns(trajectory, root: str, feet: bool, in_double: np.ndarray) -> dict:
    """Each foot's columns by role {"stance" | "swing": {name with "{side}": (values,
    unit)}}: its contact, the ground's force on it and (feet) the ground's torque on a flat
    stance foot (the root's hinge torque: no drive)."""
    rear, front = foot_forces(trajectory, root)
    size = rear.shape[0]
    out = {}
    for role, force, contact in (("stance", rear, np.ones(size)),
                                 ("swing", front, in_double.astype(float))):  # fmt: skip
        columns = {"contact_{side}": (contact, ""),
                   "ground_force_{side}_x_N": (force.real, "N"),
                   "ground_force_{side}_y_N": (force.imag, "N")}  # fmt: skip
        if feet:
            ground = np.asarray(trajectory.torques)[:, 0] if role == "stance" else np.zeros(size)
            columns["ground_torque_{side}_N_m"] = (ground, "N m")
        out[role] = columns
    return out


def _checked_sides(sides, robot) -> tuple[str, str]:
    """``sides`` (None: the robot's, or right, left), refused by name when they are not two
    different names or not the robot's."""
    if sides is None:
        sides = tuple(robot["sides"]) if robot else ("right", "left")
    if (not isinstance(sides, tuple | list) or len(sides) != 2 or sides[0] == sides[1]
            or not all(isinstance(s, str) and s.isidentifier() for s in sides)):  # fmt: skip
        raise DefinitionError(
            f"`sides`: two different names for the legs (letters, digits, _), the first in "
            f"stance in step 0, got {sides!r}"
        )
    if robot and tuple(sides) != tuple(robot["sides"]):
        raise DefinitionError(
            f"`sides`: the plan is of a robot whose {robot['sides'][0]} leg is in stance in the "
            f"planned step; give sides={tuple(robot['sides'])!r} (or None), got {sides!r}"
        )
    return tuple(sides)


def _rate(time: np.ndarray) -> float:
    """The samples' rate, Hz (the median step: a phase's last step may be shorter)."""
    return float(round(1.0 / float(np.median(np.diff(time))), 6))


#: A joint's channels: (prefix, unit, the column name's unit suffix).
_CHANNELS = (("q", "rad", "rad"), ("dq", "rad/s", "rad_s"), ("ddq", "rad/s^2", "rad_s2"),
             ("tau", "N m", "N_m"))  # fmt: skip


@dataclass(frozen=True)
class _StepColumns:
    """One planned step in the joint space's role terms (``stance_hip``, ``neck``,
    ``trunk_pitch``: :func:`problems.robot.controller.joint_maps`): the state y (K, m), its
    rates and accelerations, the drives' torques (K, drives) (the swing ankle of a point
    foot: 0), each foot's contact and ground force, the phase, the hip's distance ahead of
    the stance contact at the start and the end, and the gains (K, drives, 2m) or None."""

    keys: list
    drives: list
    y: np.ndarray
    dy: np.ndarray
    ddy: np.ndarray
    tau: np.ndarray
    feet: dict
    phase: np.ndarray
    hip_ahead: tuple
    gains: np.ndarray | None
    head: int | None
    maps: tuple

    @classmethod
    def of(cls, trajectory, linkage: Linkage, body: Body, in_double: np.ndarray,
           ankles: bool = True) -> _StepColumns:  # fmt: skip
        names = linkage.names
        t = names.index(body.trunk)
        head = next((i for i, p in enumerate(linkage.parents) if p == t), None)
        keys, A, b, planned, basis, drives, D = joint_maps(linkage, body, head, ankles)
        psi, dpsi = np.asarray(trajectory.psi), np.asarray(trajectory.dpsi)
        ddpsi, torques = np.asarray(trajectory.ddpsi), np.asarray(trajectory.torques)
        all_drives = [k for k in keys if k != "trunk_pitch"]
        tau = np.zeros((psi.shape[0], len(all_drives)))
        for r, key in enumerate(drives):
            tau[:, all_drives.index(key)] = torques @ D[r]
        size = psi.shape[0]
        feet = _foot_columns(trajectory, names[0], body.stance.foot is not None, in_double)
        levers = LinkPoint(body.stance.thigh, 1.0).levers(linkage)
        ahead = sum((lever * np.exp(1j * psi[:, k])).real for k, lever in levers)
        ahead = ahead + (linkage.links[0].origin or 0j).real
        phase = (ahead - ahead[0]) / (ahead[-1] - ahead[0])
        gains = None
        model_gains = gains_from(trajectory, names)
        if model_gains is not None:
            gains = np.zeros((size, len(all_drives), 2 * len(keys)))
            rows = [all_drives.index(key) for key in drives]
            gains[:, rows, :] = joint_gains(model_gains, A, basis, D)
            if "swing_ankle" in keys and body.swing.foot is None:  # the level sole's PD
                r, i = all_drives.index("swing_ankle"), keys.index("swing_ankle")
                gains[:, r, i], gains[:, r, len(keys) + i] = SWING_ANKLE_KP, SWING_ANKLE_KD
        return cls(keys, all_drives, psi @ A.T + b, dpsi @ A.T, ddpsi @ A.T, tau, feet, phase,
                   (float(ahead[0]), float(ahead[-1])), gains, head, (A, b, planned))  # fmt: skip

    @staticmethod
    def column(key: str, prefix: str, side_of) -> str:
        """The file's column of a state entry: q_right_hip_rad, dq_neck_rad_s,
        trunk_pitch_rad, trunk_pitch_rate_rad_s."""
        if key == "trunk_pitch":
            return "trunk_pitch_rad" if prefix == "q" else "trunk_pitch_rate_rad_s"
        suffix = dict((p, s) for p, _, s in _CHANNELS)[prefix]
        if key == "neck":
            return f"{prefix}_neck_{suffix}"
        role, _, joint = key.partition("_")
        return f"{prefix}_{side_of[role]}_{joint}_{suffix}"

    @staticmethod
    def drive(key: str, side_of) -> str:
        if key == "neck":
            return "neck"
        role, _, joint = key.partition("_")
        return f"{side_of[role]}_{joint}"

    def named(self, side_of) -> dict[str, tuple[np.ndarray, str]]:
        """The step's columns with the roles named by side: {name: (values (K,), unit)}."""
        out = {}
        for i, key in enumerate(self.keys):
            for prefix, values in (("q", self.y), ("dq", self.dy), ("ddq", self.ddy)):
                if key == "trunk_pitch" and prefix == "ddq":
                    continue
                unit = dict((p, u) for p, u, _ in _CHANNELS)[prefix]
                out[self.column(key, prefix, side_of)] = (values[:, i], unit)
        for r, key in enumerate(self.drives):
            out[f"tau_{self.drive(key, side_of)}_N_m"] = (self.tau[:, r], "N m")
        for role, columns in self.feet.items():
            for name, column in columns.items():
                out[name.format(side=side_of[role])] = column
        if self.gains is not None:
            m = len(self.keys)
            states = [self.column(k, "q", side_of) for k in self.keys]
            states += [self.column(k, "dq", side_of) for k in self.keys]
            for r, key in enumerate(self.drives):
                drive = self.drive(key, side_of)
                for j, state in enumerate(states):
                    unit = "N m/rad" if j < m else "N m s/rad"
                    out[f"K_{drive}__{state}"] = (self.gains[:, r, j], unit)
        return out


def _encoders_in_file_terms(metadata, robot, step: _StepColumns, sides, columns) -> None:
    """Each joint entry of ``metadata`` gains its URDF joint and encoder in the file's terms:
    q_urdf = urdf_sign q + urdf_zero_rad (see examples/robot.md)."""
    A, b, _ = step.maps
    role_of = {sides[0]: "stance", sides[1]: "swing"}
    names = metadata["model_view"]["links"]
    head = names[step.head] if step.head is not None else None
    for entry in metadata["joints"]:
        key = entry["name"]
        # the walker keys upper-body joints by the link they move: the neck moves the head
        lookup = head if key == "neck" else key
        encoder = robot["encoders"].get(lookup)
        if encoder is None:
            entry["urdf_joint"] = None
            continue
        parent, child, sense, zero = encoder
        u = np.zeros(len(names))
        u[names.index(child)] += sense
        u[names.index(parent)] -= sense
        if key == "neck":
            row = step.keys.index("neck")
        else:
            side, _, joint = key.partition("_")
            row = step.keys.index(f"{role_of[side]}_{joint}")
        sign = float(np.round(u @ A[row] / (A[row] @ A[row])))
        if sign not in (-1.0, 1.0) or not np.allclose(u, sign * A[row], atol=1e-12):
            raise DefinitionError(
                f"the robot's encoder of {key} ({robot['joints'][lookup]}) is not the file's "
                f"joint {key} in another sense: read the plan with its sidecar"
            )
        offset = float(wrapped(-sense * zero - sign * b[row]))
        entry["urdf_joint"] = robot["joints"][lookup]
        entry["urdf_sign"] = sign
        entry["urdf_zero_rad"] = offset
        limits = robot.get("limits", {}).get(lookup, {})
        if "effort" in limits:
            entry["urdf_effort_N_m"] = limits["effort"]
        if "lower" in limits and "upper" in limits:
            # q = sign (q_urdf - zero): the URDF's range in the file's terms
            ends = sorted(sign * (limits[k] - offset) for k in ("lower", "upper"))
            entry["urdf_range_rad"] = ends
            values = columns[entry["angle"]]
            entry["range_in_file_rad"] = [float(np.nanmin(values)), float(np.nanmax(values))]


def _robot_section(robot) -> dict | None:
    if not robot:
        return None
    return {
        "urdf": robot.get("urdf"),
        "encoders": "each joint's URDF angle q_urdf = urdf_sign q + urdf_zero_rad (joints[])",
        "base_pitch": "the base link's pitch about its y axis, forward positive, from its zero "
        "pose = trunk_pitch_rad - trunk_offset_rad",
        "trunk_offset_rad": math.pi / 2 - float(robot.get("trunk_zero_rad", math.pi / 2)),
    }


def _ordered(columns, sides, neck: bool, feet: bool) -> list[str]:
    """File order: time, step and phase, each side's joints (q, dq, ddq, tau), the neck, the
    trunk, each side's contact, the gains (K_<drive>__<state>)."""
    order = ["t_s", "step", f"stance_{sides[0]}", "double_support", "phase"]
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
    order += [n for n in columns if n.startswith("K_")]
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
            if column not in columns:  # a passive point foot's ankle
                continue
            values = columns[column]
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
