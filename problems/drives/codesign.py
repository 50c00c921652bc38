"""Gear ratios designed with the gait (issue #36, part 5): the ratios of a walker's drives that
need the least electrical energy per step over given speeds, each speed's step planned with
those drives in the loop (:mod:`problems.drives.loop`).

The design is bilevel and every point of it is a plan the product stands behind: for given
ratios, each speed's step is planned with the drives in the loop (their rotors' reflected
inertia J N^2 in the equations, their limits at every node, the electrical energy as the
objective), warm-started from the best design's plan so far, verified at every exported
sample; the design's cost is the exact electrical energy of those samples, summed over the
speeds (the motor model without smoothing, :func:`problems.drives.loop.motor_report`). A ratio
no plan can walk with (a limit the drive cannot meet at any gait) costs infinity.

The ratios are searched in log N by a compass search (each joint's ratio multiplied and divided
by a factor in turn, a move kept when it lowers the cost, the factor square-rooted when none
does, until it is below ``tolerance``): derivative-free, as the plans' optimal energy is
smooth in N only piecewise (a limit becomes active or not) and each evaluation is a solve.

The motor and the gearbox family stay as given: the ratio changes the reflected inertia, the
motor's torque and speed at every instant and so the copper losses, the voltage and the
limits; the gearbox's mass, input inertia, efficiency and torques are the catalogue row's.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from model.linkage import Linkage
from planner.errors import AnthropoidError, DefinitionError
from problems.drives.catalogue import Drive
from problems.drives.loop import (
    energy_per_step,
    motor_report,
    plan_step_with_drives,
)


@dataclass(frozen=True)
class DesignPoint:
    """One design's ``ratios`` {joint: N}, its ``energy`` (J per step summed over the
    speeds; inf when some speed has no plan), each speed's ``per_speed`` J and ``gaits``."""

    ratios: Mapping[str, float]
    energy: float
    per_speed: tuple[float, ...]
    gaits: tuple


@dataclass(frozen=True)
class CoDesign:
    """The search's ``start`` (the given drives), its ``best`` design, every evaluated
    design's (ratios, energy) in ``history``, the ``speeds`` m/s, whether regeneration counts
    and the search's seconds."""

    start: DesignPoint
    best: DesignPoint
    history: tuple[tuple[dict[str, float], float], ...]
    speeds: tuple[float, ...]
    regeneration: bool
    seconds: float

    def table(self) -> str:
        """The start and the best design: ratios and energy per speed, markdown."""
        joints = list(self.best.ratios)
        head = "| design | " + " | ".join(f"N {j}" for j in joints)
        head += " | " + " | ".join(f"{v:g} m/s, J" for v in self.speeds) + " | total, J |"
        lines = [head, "|---" * (2 + len(joints) + len(self.speeds)) + "|"]
        for label, point in (("given", self.start), ("co-designed", self.best)):
            cells = [f"{point.ratios[j]:.1f}" for j in joints]
            cells += [f"{e:.1f}" for e in point.per_speed] + [f"{point.energy:.1f}"]
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
        return "\n".join(lines)


def _with_ratio(drive: Drive, ratio: float) -> Drive:
    return Drive(drive.motor, replace(drive.gearbox, ratio=float(ratio)))


def plan_with_drives(linkage: Linkage, drives: Mapping[str, Drive], speed: float, *,
                     regeneration: bool = False, warm=None, **step_options):  # fmt: skip
    """(gait, walker): the walking step at ``speed`` m/s (``problems.walking.footed.
    step_at_speed``'s length and time) planned with ``drives`` in the loop
    (:func:`problems.drives.loop.plan_step_with_drives`)."""
    from problems.walking.footed import step_at_speed

    return plan_step_with_drives(linkage, drives, *step_at_speed(speed),
                                 regeneration=regeneration, warm=warm, **step_options)  # fmt: skip


def step_energy(gait, walker, regeneration: bool, springs=None) -> float:
    """The exact electrical energy of ``gait``'s exported samples, J: net with
    ``regeneration``, drawn (u i > 0 only) without; ``springs`` {joint: (k, q_0)} beside the
    drives (:func:`problems.drives.springs.spring_values`)."""
    trajectory = gait.exported()
    energy = energy_per_step(motor_report(trajectory, walker, springs=springs), trajectory.time)
    return energy["counted" if regeneration else "drawn"]


def codesign_ratios(
    linkage: Linkage,
    drives: Mapping[str, Drive],
    speeds: Sequence[float],
    *,
    joints: Sequence[str] = ("hip", "knee", "ankle"),
    bounds: tuple[float, float] = (10.0, 300.0),
    regeneration: bool = False,
    factor: float = 1.5,
    tolerance: float = 1.05,
    **step_options,
) -> CoDesign:
    """The gear ratios of ``joints`` (the other drives as given) that need the least
    electrical energy per step summed over ``speeds`` (see the module), within ``bounds``,
    from the given drives' ratios; ``factor`` the search's first step (x or / N),
    ``tolerance`` its last; ``step_options`` go to :func:`problems.walking_step` (N, ...)."""
    unknown = [j for j in joints if j not in drives]
    if unknown:
        raise DefinitionError(f"`joints`: no drive given for {unknown}; drives: {sorted(drives)}")
    low, high = (float(b) for b in bounds)
    if not 1.0 <= low < high:
        raise DefinitionError(f"`bounds`: give 1 <= lower < upper gear ratios, got {bounds!r}")
    if not (factor > tolerance > 1.0):
        raise DefinitionError(
            f"`factor`, `tolerance`: need factor > tolerance > 1, got {factor!r}, {tolerance!r}"
        )
    speeds = tuple(float(v) for v in speeds)
    if not speeds:
        raise DefinitionError("`speeds`: give at least one speed, m/s")
    clock = time.perf_counter()
    history: list[tuple[dict[str, float], float]] = []
    seen: dict[tuple, DesignPoint] = {}

    def evaluate(ratios: dict[str, float], warm: Sequence | None) -> DesignPoint:
        key = tuple(round(math.log(ratios[j]), 9) for j in joints)
        if key in seen:
            return seen[key]
        design = {**drives, **{j: _with_ratio(drives[j], ratios[j]) for j in joints}}
        per_speed, gaits = [], []
        for k, speed in enumerate(speeds):
            try:
                gait, walker = plan_with_drives(linkage, design, speed, regeneration=regeneration,
                                                warm=None if warm is None else warm[k],
                                                **step_options)  # fmt: skip
            except AnthropoidError:
                per_speed, gaits = [math.inf] * len(speeds), []
                break
            per_speed.append(step_energy(gait, walker, regeneration))
            gaits.append(gait)
        point = DesignPoint(dict(ratios), float(sum(per_speed)), tuple(per_speed), tuple(gaits))
        seen[key] = point
        history.append((dict(ratios), point.energy))
        return point

    start = evaluate({j: drives[j].gearbox.ratio for j in joints}, None)
    if not math.isfinite(start.energy):
        raise AnthropoidError(
            "codesign_ratios: the given drives walk no speed of "
            f"{list(speeds)} m/s (a limit no gait meets); start from ratios that do"
        )
    best, step = start, float(factor)
    while step >= tolerance:
        improved = False
        for joint in joints:
            for move in (step, 1.0 / step):
                ratio = float(np.clip(best.ratios[joint] * move, low, high))
                if ratio == best.ratios[joint]:
                    continue
                trial = evaluate({**best.ratios, joint: ratio}, best.gaits)
                if trial.energy < best.energy:
                    best, improved = trial, True
                    break
        if not improved:
            step = math.sqrt(step)
    return CoDesign(start, best, tuple(history), speeds, regeneration,
                    time.perf_counter() - clock)  # fmt: skip


__all__ = ["CoDesign", "DesignPoint", "codesign_ratios", "plan_with_drives", "step_energy"]
