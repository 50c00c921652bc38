"""What each drive of a walker must deliver: torque, speed, power and work, from planned steps.

A planned step (``torques.csv``, a gait, a library's gaits) is read in the robot's terms
(:func:`problems.robot.joint_space`: one stride, right and left hip, knee and ankle, the neck),
so that each physical drive is one motor's job whichever leg is in stance: the right knee
carries the stance knee's torque in one step and the swing knee's in the next. Per drive, over
a duty cycle of plans (each walked a share of the time):

* peak |tau| (N m) and the RMS torque (N m): sqrt(sum_p share_p (1/T_p) int tau^2 dt), the
  motor's thermal load (copper losses grow with tau^2 at the motor);
* peak |dq| and the RMS speed (rad/s);
* the peak power tau dq the drive gives (W, motoring) and the peak it absorbs (W, as a
  positive number: braking, where a motor regenerates or a brake dissipates);
* the mean positive and negative power over the duty cycle (W, time-weighted);
* per plan, the positive and negative work per step (J; a stride is two steps);
* the operating points (dq, tau) at every sample, the torque-speed plane a drive engineer
  draws over a motor's and gearbox's limits.

Time integrals are trapezoids over the samples as written (uniform at the file's rate, with
the phases' boundaries where a step on feet has them), step by step: a stride is the step with
one leg in stance and the same step mirrored, each whole (the sample before its heel strike
and the one after it both count, none is bridged by a trapezoid). The drive torque is in the
sense that grows its joint angle q, so tau dq is the power the drive puts into the body, and
its sum over the drives is the hinges' power in the model's view at every sample (a test
holds it).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError
from planner.trajectory import Trajectory
from problems.robot.joint_space import joint_space
from problems.robot.sequence_joints import step_views


class DriveStep(NamedTuple):
    """One step as the drives see it, every sample of it (both ends: the state before the
    heel strike ends a step, the one after it starts the next): ``time`` (K,) s from the
    plan's start, and per drive {drive: (K,)} its ``torques`` N m, ``speeds`` rad/s and
    ``accelerations`` rad/s^2 (None: not known, taken as 0); ``label`` which step it is
    (``step 1``, ``step 10 (change)``)."""

    time: np.ndarray
    torques: dict[str, np.ndarray]
    speeds: dict[str, np.ndarray]
    accelerations: dict[str, np.ndarray] | None = None
    label: str = ""

    def acceleration(self, drive: str) -> np.ndarray:
        """ddq (K,) rad/s^2 of ``drive`` (zeros where the step has none)."""
        if self.accelerations is None:
            return np.zeros_like(self.speeds[drive])
        return self.accelerations[drive]


@dataclass(frozen=True)
class Plan:
    """One plan of a duty cycle as the drives see it: ``name``, ``share`` of the cycle's time,
    ``steps`` (:class:`DriveStep`: a periodic step's stride, its two steps; a walk through
    speeds, every step), ``step_time`` s (the mean), ``speed`` m/s (distance over time)."""

    name: str
    share: float
    steps: tuple[DriveStep, ...]
    step_time: float
    speed: float

    @property
    def drives(self) -> list[str]:
        return list(self.steps[0].torques)

    @property
    def duration(self) -> float:
        return float(sum(step.time[-1] - step.time[0] for step in self.steps))

    def samples(self, drive: str) -> tuple[np.ndarray, np.ndarray]:
        """(speeds, torques) (M,) of ``drive`` at every sample of the plan."""
        return (np.concatenate([step.speeds[drive] for step in self.steps]),
                np.concatenate([step.torques[drive] for step in self.steps]))  # fmt: skip


@dataclass(frozen=True)
class DriveRequirement:
    """One drive's needs over the duty cycle (see the module); units N m, rad/s, W, J;
    ``peaks_at`` where each peak is ({"torque", "speed", "power", "braking"}: "<plan>, <step
    label>")."""

    drive: str
    peak_torque: float
    rms_torque: float
    peak_speed: float
    rms_speed: float
    peak_power: float
    peak_braking_power: float
    mean_positive_power: float
    mean_negative_power: float
    positive_work_per_step: tuple[float, ...]
    negative_work_per_step: tuple[float, ...]
    peaks_at: dict[str, str] = field(default_factory=dict)

    def row(self) -> dict[str, float | str]:
        """The requirement as one row of requirements.csv (duty-cycle columns; the work per
        step of each plan in columns ``positive_work_J_<k>``, ``negative_work_J_<k>``)."""
        row: dict[str, float | str] = {
            "drive": self.drive,
            "peak_torque_N_m": self.peak_torque,
            "rms_torque_N_m": self.rms_torque,
            "peak_speed_rad_s": self.peak_speed,
            "rms_speed_rad_s": self.rms_speed,
            "peak_power_W": self.peak_power,
            "peak_braking_power_W": self.peak_braking_power,
            "mean_positive_power_W": self.mean_positive_power,
            "mean_negative_power_W": self.mean_negative_power,
        }
        for key, at in self.peaks_at.items():
            row[f"peak_{key}_at"] = at
        for k, (positive, negative) in enumerate(
            zip(self.positive_work_per_step, self.negative_work_per_step, strict=True)
        ):
            row[f"positive_work_J_{k}"] = positive
            row[f"negative_work_J_{k}"] = negative
        return row


@dataclass(frozen=True)
class DriveRequirements:
    """Every drive's :class:`DriveRequirement` over the duty cycle of ``plans``."""

    drives: tuple[DriveRequirement, ...]
    plans: tuple[Plan, ...]

    def __getitem__(self, drive: str) -> DriveRequirement:
        for requirement in self.drives:
            if requirement.drive == drive:
                return requirement
        raise KeyError(f"no drive {drive!r}; drives: {[r.drive for r in self.drives]}")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(r.drive for r in self.drives)

    @classmethod
    def of(cls, plans: Sequence[Plan]) -> DriveRequirements:
        """The requirements over ``plans`` as read (their shares summing to 1), every plan
        with the same drives (one walker)."""
        drives = plans[0].drives
        for plan in plans[1:]:
            if plan.drives != drives:
                raise DefinitionError(
                    f"`plans`: {plan.name} has the drives {plan.drives}, the first plan "
                    f"{drives}: a duty cycle is one walker's"
                )
        return cls(tuple(_requirement(d, plans) for d in drives), tuple(plans))

    def table(self) -> str:
        """The duty cycle's requirements as a markdown table, one row per drive."""
        lines = [
            "| drive | peak torque N m | RMS torque N m | peak speed rad/s | RMS speed rad/s | "
            "peak power W | peak braking W | mean + power W | mean - power W |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for r in self.drives:
            lines.append(
                f"| {r.drive} | {r.peak_torque:.1f} | {r.rms_torque:.1f} | {r.peak_speed:.2f} | "
                f"{r.rms_speed:.2f} | {r.peak_power:.1f} | {r.peak_braking_power:.1f} | "
                f"{r.mean_positive_power:.1f} | {r.mean_negative_power:.1f} |"
            )
        return "\n".join(lines)

    def peaks_table(self) -> str:
        """Where each drive's peaks are (plan and step), markdown."""
        lines = ["| drive | peak torque at | peak speed at | peak power at | peak braking at |",
                 "|---|---|---|---|---|"]  # fmt: skip
        for r in self.drives:
            cells = " | ".join(r.peaks_at.get(key, "") for key in ("torque", "speed", "power",
                                                                   "braking"))  # fmt: skip
            lines.append(f"| {r.drive} | {cells} |")
        return "\n".join(lines)

    def work_table(self) -> str:
        """Positive / negative work per step of each drive in each plan (J), markdown."""
        header = " | ".join(f"{p.name} (+ / -)" for p in self.plans)
        lines = [f"| drive | {header} |", "|---|" + "---|" * len(self.plans)]
        for r in self.drives:
            cells = " | ".join(
                f"{positive:.2f} / {negative:.2f}"
                for positive, negative in zip(
                    r.positive_work_per_step, r.negative_work_per_step, strict=True
                )
            )
            lines.append(f"| {r.drive} | {cells} |")
        return "\n".join(lines)


def plan_of(trajectory: Trajectory, name: str, share: float) -> Plan:
    """A planned step's exported samples (the model's view, as ``walk`` writes them) as the
    drives see one stride of it (:func:`problems.robot.joint_space`): the step with the
    first side's leg in stance, then with the other's, each whole. A walk through speeds
    (``sequence.csv``, ``metadata["sequence"]``): every step, the sides alternating."""
    if ((trajectory.metadata or {}).get("gait") or {}).get("rotors"):
        raise DefinitionError(
            f"{name}: a plan made with its drives in the loop (its torques hold the share that "
            "accelerates each drive's own rotor, which a drive's check adds again): read it "
            "through those drives with problems.drives.replan.output_plan or motor_report"
        )
    if "sequence" in (trajectory.metadata or {}):
        return _sequence_plan(trajectory, name, share)
    first = joint_space(trajectory, steps=1)
    sides = tuple(first.metadata["sides"])
    second = joint_space(trajectory, steps=1, sides=(sides[1], sides[0]))
    steps = [_step_of(view.columns, index * float(view.time[-1] - view.time[0]), f"step {index}")
             for index, view in enumerate((first, second))]  # fmt: skip
    meta = first.metadata
    return Plan(
        name=name,
        share=share,
        steps=tuple(steps),
        step_time=float(meta["step_time_s"]),
        speed=float(meta["step_length_m"]) / float(meta["step_time_s"]),
    )


def _step_of(columns: dict, start: float, label: str) -> DriveStep:
    """One step's joint-space columns (``problems.robot.joint_space``) as a
    :class:`DriveStep` named ``label``, its time from ``start`` s."""
    drives = [c[len("tau_") : -len("_N_m")] for c in columns if c.startswith("tau_")]
    time = np.asarray(columns["t_s"], dtype=float)

    def per_drive(prefix: str, unit: str) -> dict[str, np.ndarray]:
        return {d: np.asarray(columns[f"{prefix}_{d}_{unit}"], dtype=float) for d in drives}

    return DriveStep(time - time[0] + start, per_drive("tau", "N_m"), per_drive("dq", "rad_s"),
                     per_drive("ddq", "rad_s2"), label)  # fmt: skip


def _sequence_plan(trajectory: Trajectory, name: str, share: float) -> Plan:
    """A walk through speeds (``problems.library.WalkSequence.trajectory``: a ``step``
    column, each step's settings in ``metadata["sequence"]["steps"]``) as the drives see it:
    each step whole (:func:`problems.robot.sequence_joints.step_views`: the sample before its
    heel strike included), the first leg in stance for even steps."""
    views = step_views(trajectory)
    first = float(views[0][0]["start_s"])
    steps = tuple(_step_of(view.columns, float(entry["start_s"]) - first,
                           f"step {j} ({entry['kind']})")
                  for j, (entry, view) in enumerate(views))  # fmt: skip
    distance = sum(float(entry["step_length_m"]) for entry, _ in views)
    time = np.asarray(trajectory.time, dtype=float)
    duration = float(time[-1] - time[0])
    return Plan(name=name, share=share, steps=steps, step_time=duration / len(steps),
                speed=distance / duration)  # fmt: skip


def _shares(count: int, shares: Sequence[float] | None) -> list[float]:
    """The plans' shares of the cycle's time, checked, summing to 1 (default: equal)."""
    if shares is None:
        return [1.0 / count] * count
    if isinstance(shares, str) or not isinstance(shares, Sequence):
        raise DefinitionTypeError(f"`shares`: one number per plan, got {shares!r}")
    values = [float(s) for s in shares]
    if len(values) != count:
        raise DefinitionError(
            f"`shares`: {len(values)} shares for {count} plans; give one per plan (the "
            "fraction of the duty cycle's time walked with it)"
        )
    if any(not np.isfinite(v) or v < 0 for v in values) or sum(values) <= 0:
        raise DefinitionError(f"`shares`: fractions of time >= 0 with a positive sum, got {values}")
    total = sum(values)
    return [v / total for v in values]


def drive_requirements(
    plans: Sequence[Trajectory] | Trajectory,
    *,
    shares: Sequence[float] | None = None,
    names: Sequence[str] | None = None,
) -> DriveRequirements:
    """Each drive's requirements (see the module) over the duty cycle of ``plans`` (planned
    steps' exported samples in the model's view, e.g. ``LinkageTrajectory.load(
    "torques.csv")``, ``gait.to_trajectory(1000)``, ``GaitLibrary.at(v)``), walked for
    ``shares`` of the time (normalised to sum 1; default equal), named ``names`` (default
    ``"<speed> m/s"``). Every plan must have the same drives (one walker)."""
    if isinstance(plans, Trajectory):
        plans = [plans]
    plans = list(plans)
    if not plans:
        raise DefinitionError("`plans`: give one or more planned steps")
    fractions = _shares(len(plans), shares)
    if names is not None and len(names) != len(plans):
        raise DefinitionError(f"`names`: {len(names)} names for {len(plans)} plans")
    read = []
    for k, (trajectory, share) in enumerate(zip(plans, fractions, strict=True)):
        plan = plan_of(trajectory, "", share)
        name = names[k] if names is not None else f"{plan.speed:.3g} m/s"
        read.append(replace(plan, name=name))
    return DriveRequirements.of(read)


def _requirement(drive: str, plans: Sequence[Plan]) -> DriveRequirement:
    """One drive's needs over the plans (see the module)."""
    means = {"torque": 0.0, "speed": 0.0, "positive": 0.0, "negative": 0.0}
    peaks = {"torque": 0.0, "speed": 0.0, "power": 0.0, "braking": 0.0}
    where = dict.fromkeys(peaks, "")
    positive_work, negative_work = [], []
    for plan in plans:
        integrals = _stride_integrals(plan, drive)
        for key in means:
            means[key] += plan.share * integrals[key] / plan.duration
        for step in plan.steps:
            tau, dq = step.torques[drive], step.speeds[drive]
            power = tau * dq
            values = {"torque": float(np.max(np.abs(tau))), "speed": float(np.max(np.abs(dq))),
                      "power": float(np.max(power)), "braking": float(-np.min(power))}  # fmt: skip
            for key, value in values.items():
                if value > peaks[key]:
                    peaks[key] = value
                    where[key] = ", ".join(part for part in (plan.name, step.label) if part)
        positive_work.append(integrals["positive"] / len(plan.steps))
        negative_work.append(integrals["negative"] / len(plan.steps))
    return DriveRequirement(
        drive=drive,
        peak_torque=peaks["torque"],
        rms_torque=float(np.sqrt(means["torque"])),
        peak_speed=peaks["speed"],
        rms_speed=float(np.sqrt(means["speed"])),
        peak_power=peaks["power"],
        peak_braking_power=peaks["braking"],
        mean_positive_power=means["positive"],
        mean_negative_power=means["negative"],
        positive_work_per_step=tuple(positive_work),
        negative_work_per_step=tuple(negative_work),
        peaks_at=where,
    )


def _stride_integrals(plan: Plan, drive: str) -> dict[str, float]:
    """int tau^2, dq^2, max(tau dq, 0) and min(tau dq, 0) dt over ``plan``'s stride."""
    integrals = {"torque": 0.0, "speed": 0.0, "positive": 0.0, "negative": 0.0}
    for step in plan.steps:  # trapezoids within each step
        tau, dq, time = step.torques[drive], step.speeds[drive], step.time
        integrands = {"torque": tau**2, "speed": dq**2, "positive": np.maximum(tau * dq, 0.0),
                      "negative": np.minimum(tau * dq, 0.0)}  # fmt: skip
        for key, values in integrands.items():
            integrals[key] += float(np.trapezoid(values, time))
    return integrals


def describe(requirements: DriveRequirements) -> dict[str, Any]:
    """The duty cycle as plain data (requirements.csv's sidecar): the plans (name, share,
    speed, step time) and the columns' units."""
    return {
        "plans": [
            {"name": p.name, "share": p.share, "speed_m_s": p.speed, "step_time_s": p.step_time}
            for p in requirements.plans
        ],
        "drives": list(requirements.names),
        "columns": {
            "peak_torque_N_m": "max |tau| over every plan",
            "rms_torque_N_m": "sqrt(sum_p share_p (1/T_p) int tau^2 dt)",
            "peak_speed_rad_s": "max |dq|",
            "rms_speed_rad_s": "sqrt(sum_p share_p (1/T_p) int dq^2 dt)",
            "peak_power_W": "max tau dq (the drive gives)",
            "peak_braking_power_W": "max -tau dq (the drive absorbs)",
            "mean_positive_power_W": "sum_p share_p (1/T_p) int max(tau dq, 0) dt",
            "mean_negative_power_W": "sum_p share_p (1/T_p) int min(tau dq, 0) dt",
            "positive_work_J_<k>": "plan k's int max(tau dq, 0) dt per step (half a stride)",
            "negative_work_J_<k>": "plan k's int min(tau dq, 0) dt per step",
        },
        "convention": "tau in the sense that grows the joint angle q (problems.robot."
        "joint_space): tau dq is the power the drive puts into the body",
    }


__all__ = [
    "DriveRequirement",
    "DriveRequirements",
    "DriveStep",
    "Plan",
    "describe",
    "drive_requirements",
    "plan_of",
]
