"""A planned step re-planned with the drives chosen for it (issue #36, part 4, the command's
part): what the plan as written asks of those drives, and the plan they can deliver.

:func:`replan` reads a point-foot walking step's file (its settings in the sidecar), plans the
same step (length, time, friction, sole, knee range, posture, limits, touchdown) for the
walker carrying the chosen drives (:mod:`problems.drives.loop`: their masses, rotors and limits,
the least electrical energy), and compares the two through those drives at every sample: the
electrical energy per step and each limit's worst margin (:func:`compare`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from model.linkage import Linkage
from model.linkage_trajectory import LinkageTrajectory
from planner.errors import DefinitionError
from problems.drives.catalogue import Drive
from problems.drives.loop import (
    DrivenWalker,
    energy_per_step,
    motor_report,
    plan_step_with_drives,
)
from problems.drives.requirements import DriveStep, Plan

#: the walking step's settings a re-plan keeps (the rest: the product's defaults)
KEPT = ("mu", "torque_limit", "passive", "knee_range", "posture", "hip_limit",
        "touchdown_speed", "approach_time", "ground_margin")  # fmt: skip
#: ... and a step on feet's (not its ``speed_limit``: the drives' own speed and voltage
#: limits take its place; with both, no footed step at 1.0 m/s was found in a scratch run)
KEPT_ON_FEET = ("mu", "torque_limit", "knee_range", "ankle_range", "posture", "hip_limit",
                "touchdown_speed", "approach_time", "phases")  # fmt: skip
#: the walking steps a re-plan takes: point feet (without a double support) and feet
STEPS = ("walking_step", "footed_step")
#: the limits compared (``motor_report``'s margins)
LIMITS = ("motor torque, N m", "voltage, V", "gear torque, N m", "motor speed, rad/s")


def _step_options(settings: Mapping[str, Any]) -> dict[str, Any]:
    kept = KEPT_ON_FEET if settings.get("problem") == "footed_step" else KEPT
    options = {key: settings[key] for key in kept if settings.get(key) is not None}
    for key in ("ankle_range", "phases"):
        if key in options:
            options[key] = tuple(options[key])
    if settings.get("problem") == "footed_step":
        if isinstance(settings.get("clearance"), int | float):
            options["clearance"] = float(settings["clearance"])
        if isinstance(settings.get("objective"), str):
            options["objective"] = settings["objective"]
        return options
    if isinstance(settings.get("clearance"), int | float):
        options["clearance"] = float(settings["clearance"])
    if settings.get("foot") is not None:
        options["foot"] = tuple(float(v) for v in settings["foot"])
    if "knee_range" in options:
        options["knee_range"] = tuple(options["knee_range"])
    if "passive" in options:
        options["passive"] = tuple(options["passive"])
    return options


def replan(trajectory, drives: Mapping[str, Drive], *, regeneration: bool = False,
           drives_objective: str | None = None, warm=None, **options):  # fmt: skip
    """(gait, walker): the step of ``trajectory`` (a walking step's samples with its settings,
    as ``walk`` writes them: point feet without a double support, or feet) planned with
    ``drives`` {"hip", "knee", "ankle", "neck": Drive} in the loop, minimising the electrical
    energy (drawn only unless ``regeneration``) on point feet and the step's own objective
    on feet (``drives_objective`` to choose: :func:`problems.drives.loop.
    plan_step_with_drives`), from
    the gait ``warm`` when given; ``options`` override the step's (N, ...). Raises
    :class:`planner.AnthropoidError` when no plan is found or it fails its verification."""
    trajectory = LinkageTrajectory.of(trajectory)
    settings = (trajectory.metadata or {}).get("gait") or {}
    if settings.get("problem") not in STEPS or settings.get("double_support"):
        raise DefinitionError(
            "`trajectory`: a re-plan with the drives takes a walking step on point feet "
            "without a double support, or on feet (walk's torques.csv with its sidecar); this "
            f"is {settings.get('problem')!r}"
            + (" with a double support" if settings.get("double_support") else "")
        )
    if settings.get("rotors"):
        raise DefinitionError("`trajectory`: this plan was made with drives already")
    linkage = Linkage.from_parameters(trajectory.metadata["model"])
    return plan_step_with_drives(linkage, drives, float(settings["step_length"]),
                                 float(settings["step_time"]), regeneration=regeneration,
                                 drives_objective=drives_objective, warm=warm,
                                 **{**_step_options(settings), **options})  # fmt: skip


def compare(trajectory, walker: DrivenWalker, with_rotors: bool, springs=None) -> dict[str, Any]:
    """Through the walker's drives at every sample of ``trajectory``: the electrical
    ``energy`` J (counted, drawn, copper) and each limit's ``worst`` margin (its unit; the drive
    where it is). ``with_rotors``: the plan was made with them (a re-plan); ``springs``
    {joint: (k, q_0)}: parallel springs beside the drives (a re-plan's)."""
    report = motor_report(trajectory, walker, with_rotors=with_rotors, springs=springs)
    worst = {}
    for limit in LIMITS:
        key = min(report, key=lambda k: float(report[k]["margins"][limit].min()))
        worst[limit] = (float(report[key]["margins"][limit].min()), key)
    return {"energy": energy_per_step(report, trajectory.time), "worst": worst}


def output_plan(trajectory, walker: DrivenWalker, name: str, share: float,
                with_rotors: bool, springs=None) -> Plan:  # fmt: skip
    """A point-foot step's stride as its drives' gear outputs see it (tau_out N m, dq rad/s per
    physical drive: the right leg in stance, then the left), from :func:`motor_report`: for a
    plan made with the drives (``with_rotors``) without the share of each drive's torque that
    accelerates its own rotor, so that it reads like a plan for ideal sources. A point foot's
    swing ankle has no drive to read: zero there. ``springs`` {joint: (k, q_0)}: parallel
    springs beside the drives, whose share the gear outputs do not carry."""
    report = motor_report(trajectory, walker, with_rotors=with_rotors, springs=springs)
    time = np.asarray(trajectory.time, dtype=float)
    duration = float(time[-1] - time[0])
    settings = trajectory.metadata["gait"]
    steps = []
    for index, (stance, swing) in enumerate((("right", "left"), ("left", "right"))):
        torques, speeds = {}, {}
        for key, side in report.items():
            role, _, joint = key.partition("_")
            physical = key if key == "neck" else f"{stance if role == 'stance' else swing}_{joint}"
            torques[physical], speeds[physical] = side["tau_out"], side["dq"]
        for leg in (stance, swing):
            torques.setdefault(f"{leg}_ankle", np.zeros_like(time))
            speeds.setdefault(f"{leg}_ankle", np.zeros_like(time))
        steps.append(DriveStep(time - time[0] + index * duration, torques, speeds, None,
                               f"step {index}"))  # fmt: skip
    step_time = float(settings["step_time"])
    return Plan(name, share, tuple(steps), step_time, float(settings["step_length"]) / step_time)


def comparison_table(given: Mapping[str, Any], replanned: Mapping[str, Any]) -> str:
    """The plan as given and re-planned, through the chosen drives, as markdown."""
    head = "| plan | energy drawn, J | net, J | copper, J | " + " | ".join(
        f"worst {limit}" for limit in LIMITS) + " |"  # fmt: skip
    lines = [head, "|---" * (4 + len(LIMITS)) + "|"]
    for label, row in (("as given", given), ("re-planned with the drives", replanned)):
        energy = row["energy"]
        cells = [f"{energy['drawn']:.1f}", f"{energy['counted']:.1f}", f"{energy['copper']:.1f}"]
        cells += [f"{value:+.3g} ({key})" for value, key in row["worst"].values()]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


__all__ = [
    "KEPT",
    "KEPT_ON_FEET",
    "LIMITS",
    "STEPS",
    "compare",
    "comparison_table",
    "output_plan",
    "replan",
]
