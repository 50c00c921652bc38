"""Drives chosen for the six-link walker on feet from 0.6 to 1.4 m/s and each speed re-planned
with them (issue #36, the selection on feet).

    python examples/benchmarks/drives_on_feet.py [--write]   # about 20 min

Table 1: the ideal-torque steps on feet (``footed_step_at``) without and with a bound of
``SPEED_LIMIT`` rad/s on every driven joint (``speed_limit``): each joint's peak speed, the
torque effort, seconds. Without the bound the plan whips the light swing foot round.

Table 2: what the illustrative catalogue (``examples/drives/*_illustrative.csv``: numbers for
the example, not products) chooses for the bounded plans walked equally long (``select``, the
lightest that meets every limit), and what it says of the unbounded ones.

Table 3: each speed re-planned carrying drives (``problems.drives.loop.
plan_step_with_drives``: the motors' masses on the body, their rotors in the equations of
motion, every limit held at every node; torque objective, warm-started from the bounded ideal
plan) and both plans read through the same drives at every exported sample: the energy drawn
per step, the worst margin of each limit, the peak output torques. The hips, knees and neck
take the catalogue's picks; the ankles take the picked motor through 30:1 of the same gear
family (``ANKLE_RATIO``), because through the pick's 50:1 (0.055 kg m^2 reflected onto a 1 kg
foot) the plan found no step at ``PICK_SPEED`` m/s (IPOPT's status is printed): the geared
ankle throws the stance ball off the ground at the heel strike.
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from model.presets import anthropoid_with_feet
from planner.errors import AnthropoidError
from problems import footed_step_at
from problems.drives import drive_requirements, select
from problems.drives.catalogue import Drive, read_gearboxes, read_motors
from problems.drives.loop import motor_report, plan_step_with_drives
from problems.drives.replan import LIMITS, compare
from problems.robot.joint_space import joint_space
from problems.walking.footed import step_at_speed

SPEEDS = (0.6, 0.8, 1.0, 1.2, 1.4)
#: every driven joint's bound in the ideal plans, rad/s
SPEED_LIMIT = 10.0
#: the ankles' ratio in table 3
ANKLE_RATIO = 30.0
#: where the catalogue's own ankle pick is tried
PICK_SPEED = 1.2
CATALOGUE = Path(__file__).resolve().parents[1] / "drives"


def _peak_speeds(gait) -> dict[str, float]:
    columns = joint_space(gait.exported()).columns
    return {name[3:].removesuffix("_rad_s"): float(np.max(np.abs(values)))
            for name, values in columns.items() if name.startswith("dq_")}  # fmt: skip


def ideal_table() -> tuple[dict, list]:
    """Table 1; returns the bounded plans by speed and the unbounded ones."""
    print(f"Table 1: the ideal-torque steps on feet, without and with every driven joint within "
          f"{SPEED_LIMIT:g} rad/s\n")  # fmt: skip
    print("| speed, m/s | bound | verified | fastest joint | its peak, rad/s | ankles' peak, "
          "rad/s | torque effort, N^2 m^2 s | seconds |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    bounded, unbounded = {}, []
    for speed in SPEEDS:
        for limit in (None, SPEED_LIMIT):
            clock = time.perf_counter()
            gait = footed_step_at(speed, speed_limit=limit).solve(progress=False)
            seconds = time.perf_counter() - clock
            peaks = _peak_speeds(gait)
            fastest = max(peaks, key=peaks.get)
            ankles = max(peaks["right_ankle"], peaks["left_ankle"])
            print(f"| {speed:g} | {'none' if limit is None else f'{limit:g} rad/s'} | "
                  f"{gait.verified} | {fastest} | {peaks[fastest]:.2f} | {ankles:.2f} | "
                  f"{gait.cost:.1f} | {seconds:.1f} |")  # fmt: skip
            if limit is None:
                unbounded.append(gait)
            else:
                bounded[speed] = gait
    print()
    return bounded, unbounded


def selection_table(bounded, unbounded) -> dict[str, Drive]:
    """Table 2; returns the picks by joint (hip, knee, ankle, neck)."""
    motors = read_motors(CATALOGUE / "motors_illustrative.csv")
    gearboxes = read_gearboxes(CATALOGUE / "gearboxes_illustrative.csv")
    plans = [bounded[speed].exported() for speed in SPEEDS]
    selection = select(drive_requirements(plans), motors, gearboxes)
    print(f"Table 2: the illustrative catalogue's lightest fit for the bounded plans, "
          f"{SPEEDS[0]:g} to {SPEEDS[-1]:g} m/s walked equally long\n")  # fmt: skip
    print(selection.table())
    free = select(drive_requirements([g.exported() for g in unbounded]), motors, gearboxes)
    print("\nThe unbounded plans: "
          + ("; ".join(free.refused.values()) or "every drive fits") + "\n")  # fmt: skip
    picks = {joint: selection.best(f"right_{joint}").drive for joint in ("hip", "knee", "ankle")}
    picks["neck"] = selection.best("neck").drive
    return picks


def _peaks(trajectory, walker, rotors: bool) -> dict[str, float]:
    report = motor_report(trajectory, walker, with_rotors=rotors)
    return {key: float(np.max(np.abs(side["tau_out"]))) for key, side in report.items()}


def replan_table(bounded, picks: dict[str, Drive]) -> None:
    """Table 3."""
    linkage = anthropoid_with_feet()
    clock = time.perf_counter()
    try:
        plan_step_with_drives(linkage, picks, *step_at_speed(PICK_SPEED), warm=bounded[PICK_SPEED])
        outcome = "a step was found"
    except AnthropoidError as error:
        outcome = f"no step: {str(error).split(';')[0]}"
    seconds = time.perf_counter() - clock
    ankle = picks["ankle"]
    reflected = ankle.inertia * ankle.gearbox.ratio**2
    print(f"The catalogue's ankle pick, {ankle.name} ({reflected:.3f} kg m^2 reflected), "
          f"carried at {PICK_SPEED:g} m/s: {outcome} ({seconds:.0f} s)\n")  # fmt: skip
    gear = replace(ankle.gearbox, name=f"{ankle.gearbox.name} family at {ANKLE_RATIO:g}:1",
                   ratio=ANKLE_RATIO)  # fmt: skip
    drives = {**picks, "ankle": Drive(ankle.motor, gear)}
    reflected = drives["ankle"].inertia * ANKLE_RATIO**2
    print(f"Table 3: each speed re-planned carrying the picks, the ankles' motor through "
          f"{ANKLE_RATIO:g}:1 ({reflected:.3f} kg m^2 reflected), torque objective; both plans "
          f"through those drives at every exported sample\n")  # fmt: skip
    print("| speed, m/s | plan | verified | energy drawn, J | copper, J | "
          + " | ".join(f"worst {k}" for k in LIMITS)
          + " | peak hip / knee / ankle output, N m | seconds |")  # fmt: skip
    print("|---" * (7 + len(LIMITS)) + "|")
    for speed in SPEEDS:
        ideal = bounded[speed]
        clock = time.perf_counter()
        try:
            gait, walker = plan_step_with_drives(linkage, drives, *step_at_speed(speed),
                                                 warm=ideal)  # fmt: skip
        except AnthropoidError as error:
            print(f"| {speed:g} | with the drives | no plan: {str(error)[:120]} |")
            continue
        seconds = time.perf_counter() - clock
        rows = (("ideal", ideal, False, ""), ("with the drives", gait, True, f"{seconds:.0f}"))
        for label, plan, rotors, took in rows:
            trajectory = plan.exported()
            compared = compare(trajectory, walker, with_rotors=rotors)
            energy = compared["energy"]
            worst = [f"{value:+.3g} ({key})" for value, key in compared["worst"].values()]
            peaks = _peaks(trajectory, walker, rotors)
            legs = " / ".join(
                f"{max(peaks[f'stance_{j}'], peaks[f'swing_{j}']):.0f}"
                for j in ("hip", "knee", "ankle")
            )
            cells = [f"{energy['drawn']:.1f}", f"{energy['copper']:.1f}", *worst, legs, took]
            print(f"| {speed:g} | {label} | {plan.verified} | " + " | ".join(cells) + " |")
    print()


def main(argv=None) -> int:
    bounded, unbounded = ideal_table()
    picks = selection_table(bounded, unbounded)
    replan_table(bounded, picks)
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
