"""A walk through speeds (``sequence.csv`` of ``python -m problems walk --speeds ...``,
:func:`problems.library.plan_sequence`) as a robot's drives see it: ``joints.csv`` of the
whole walk, one row for each row of the walk's file.

Each step is the joint-space view of its own samples (:func:`problems.robot.joint_space` of
one step: relative joint angles with the robot's zeros and signs, each physical drive's
torque, the feet's contacts and ground forces, the gains when the walk carries its law),
the sides alternating: step j has the ``sides[0]`` leg in stance for even j. The rows are the
walk file's own rows, at its times: where two steps meet the later step's first sample
(after the heel strike) is kept, as in the walk's file. Two columns are the walk's own:
``step`` (j) and ``phase`` (the index of step j's law: the hip's progress over the stance
foot, or t / T where the hip moves back, as ``sequence.csv`` holds it).

The sidecar is the one-step view's (joints, zeros, signs, limits, contacts, the controller's
law) with the walk's steps in it: ``sequence_steps`` (each step's kind, start, length, time,
stance side and law) and the controller's ``rows``: a controller walks the steps once, in
order, step j's rows those with step = j (a walk from standing to standing does not repeat).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from model.linkage_trajectory import LinkageTrajectory
from planner.errors import DefinitionError
from planner.trajectory import Trajectory
from problems.library.sequence import sequence_steps
from problems.robot.joint_space import JointSpace, _checked_sides, joint_space

#: a row of the one-step view and the walk's row it stands for meet to this, s
_SAME_TIME_S = 1e-9


def sequence_joint_space(trajectory: Trajectory, *, sides=None) -> JointSpace:
    """The robot's view of a walk sequence's samples (``WalkSequence.trajectory(rate)`` or
    ``Trajectory.load("sequence.csv")``): every step, the ``sides[0]`` leg in stance in the
    walk's first step (default: the robot's sides when the walk is of a URDF, else right,
    left). Returns the :class:`JointSpace` (see the module); its ``t_s`` column is the walk
    file's time, row for row."""
    trajectory = LinkageTrajectory.of(trajectory)
    views = step_views(trajectory, sides=sides)
    sides = views[0][1].metadata["sides"]
    time = np.asarray(trajectory.time, dtype=float)
    step_column = np.asarray(trajectory.extras["step"][0]).astype(int)
    phase = np.asarray(trajectory.extras["phase"][0], dtype=float)
    parts: list[dict[str, np.ndarray]] = []
    for j, (entry, view) in enumerate(views):
        rows = np.flatnonzero(step_column == j)
        # the step's samples but its last (the instant of the next step's first row) are the
        # walk's rows with step = j; the last step keeps all of its own
        columns = {name: values[: rows.size] for name, values in view.columns.items()}
        local = columns["t_s"] + float(entry["start_s"])
        if np.abs(local - time[rows]).max() > _SAME_TIME_S:
            raise DefinitionError(
                f"`trajectory`: step {j}'s rows do not start at its start_s "
                f"({entry['start_s']:g} s); the file's sidecar is not its own"
            )
        columns["t_s"] = time[rows]
        columns["step"] = np.full(rows.size, float(j))
        del columns[f"stance_{view.metadata['sides'][0]}"]
        columns[f"stance_{sides[0]}"] = np.full(rows.size, float(j % 2 == 0))
        columns["phase"] = phase[rows]
        parts.append(columns)
    # one walker, one kind of step (the walk's file holds one set of channels): one set of
    # columns in every step
    order = list(views[0][1].columns)
    joined = {name: np.concatenate([part[name] for part in parts]) for name in order}
    units = dict(views[0][1].units)
    metadata = _metadata(views, sides, joined, trajectory.metadata)
    return JointSpace(joined, units, metadata)


def step_views(trajectory: Trajectory, *, sides=None) -> list[tuple[dict[str, Any], JointSpace]]:
    """Each step of a walk sequence as (its entry of ``metadata["sequence"]["steps"]``, the
    one-step joint-space view of all its samples, the one before its heel strike last, on
    its own clock from 0), the ``sides[0]`` leg in stance in the walk's first step and the
    sides alternating (``sides`` as for :func:`sequence_joint_space`)."""
    trajectory = LinkageTrajectory.of(trajectory)
    pieces = sequence_steps(trajectory)  # raises naming the fix when it is not a walk
    metadata = trajectory.metadata
    if not metadata.get("model"):
        raise DefinitionError(
            "`trajectory`: a walk through speeds without its walker (metadata['model']); "
            "write it again with this version (python -m problems walk --speeds ...)"
        )
    robot = metadata.get("robot")
    sides = _checked_sides(sides, robot)
    step_column = np.asarray(trajectory.extras["step"][0]).astype(int)
    gain_names = [name for name in trajectory.extras if name.startswith("K_")]
    views = []
    for j, (entry, piece) in enumerate(pieces):
        rows = np.flatnonzero(step_column == j)
        # the robot's encoders are stated once, in the first step's terms (its sides); a
        # step with the other leg in stance is the same robot mirrored, as in joint_space
        own_robot = robot if j % 2 == 0 else None
        piece = _with_walk_columns(piece, trajectory, rows, gain_names, metadata, own_robot)
        stance = (sides[j % 2], sides[(j + 1) % 2])
        views.append((entry, joint_space(piece, steps=1, sides=stance)))
    return views


def _with_walk_columns(piece, trajectory, rows, gain_names, metadata, robot):
    """Step ``piece`` (its samples from the walk) with the walker and robot of the walk's
    metadata and its gains columns (the walk's rows, the last repeated for the sample before
    the heel strike the piece appends)."""
    extra = {"model": metadata["model"]}
    if robot:
        extra["robot"] = robot
    piece = LinkageTrajectory.of(piece.with_metadata(**extra))
    size = piece.time.size
    for name in gain_names:
        values, unit = trajectory.extras[name]
        column = np.asarray(values, dtype=float)[rows][:size]
        column = np.append(column, np.repeat(column[-1:], size - column.size))
        piece = LinkageTrajectory.of(piece.with_extra(name, column, unit))
    return piece


def _metadata(views, sides, joined, walk) -> dict[str, Any]:
    """The first step's sidecar with the whole walk in it: peaks over every step, the steps
    (kind, start, length, time, stance side, law) and the controller's rows."""
    metadata = dict(views[0][1].metadata)
    for key in ("step_time_s", "step_length_m", "strike_s"):
        metadata.pop(key, None)
    metadata["steps"] = len(views)
    metadata["stride"] = (
        f"step k has the {sides[0]} leg in stance for even k, the {sides[1]} for odd k; where "
        "two steps meet the later's first sample is kept (the rows are sequence.csv's)"
    )
    joints = []
    for joint in metadata["joints"]:  # peaks and ranges over the whole walk
        joint = {**joint, "peak_N_m": float(np.nanmax(np.abs(joined[joint["torque"]])))}
        if "range_in_file_rad" in joint:
            angles = joined[joint["angle"]]
            joint["range_in_file_rad"] = [float(np.nanmin(angles)), float(np.nanmax(angles))]
        joints.append(joint)
    metadata["joints"] = joints
    steps = []
    for j, (entry, view) in enumerate(views):
        law = entry.get("law") or {"indexed_by": "time"}
        steps.append({
            "step": j, "kind": entry["kind"], "start_s": float(entry["start_s"]),
            "step_length_m": float(entry["step_length_m"]),
            "step_time_s": float(entry["step_time_s"]), "stance": sides[j % 2],
            "law": law, "hip_ahead_m": view.metadata["controller"]["hip_ahead_m"],
        })  # fmt: skip
    metadata["sequence_steps"] = steps
    metadata["commanded_speeds_m_s"] = list(walk["sequence"]["commanded_speeds_m_s"])
    metadata["standing"] = walk["sequence"].get("standing")
    metadata["model_view"] = {**metadata["model_view"], "file": "sequence.csv"}
    controller = dict(metadata["controller"])
    controller.pop("hip_ahead_m", None)
    controller["steps"] = len(views)
    controller["rows"] = (
        f"the file holds the whole walk, {len(views)} steps (step k has the {sides[0]} leg in "
        "stance for even k): walk them once, in order; step j's rows are those with step = j"
    )
    controller["phase"] = (
        "each step's column phase is its law's index (sequence_steps[j].law.indexed_by): "
        "'phase', the hip's progress s = (d - d0) / (d1 - d0) over the stance foot's contact "
        "point, [d0, d1] its law's hip_ahead_m; 'time', t / T since the step's start; "
        "'time, then held' (a stop at quiet standing, the walk's last step), t / T since the "
        "step's start, and after its last row that row held: z_ref, tau_ff and K"
    )
    controller["law"] = controller["law"].replace("at the phase s", "at the step's phase")
    metadata["controller"] = controller
    return metadata


__all__ = ["sequence_joint_space", "step_views"]
