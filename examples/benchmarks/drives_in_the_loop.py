"""What planning with the drives changes (issue #36, part 4): the default walking step (0.5 m
in 0.5 s, point feet with a sole, Hermite-Simpson N = 30) planned five ways and each held
against the same drives at every exported sample (1 kHz).

    python examples/benchmarks/drives_in_the_loop.py [--write]   # about 2 min

The drives: one motor and gearbox at every joint (illustrative numbers of a 48 V brushless
motor through an 80:1 gear at 80 %, not a catalogue product: no cited catalogue ships yet),
mounted as ``problems.drives.loop.MOUNTS`` says, both legs' motors on the body.

Plans: (a) ideal torque sources, the bare body, torque objective (the product's default);
(b) the same for the body carrying the motors' masses (what a designer plans without the
drives in the loop); (c) with the drives' rotors and limits, torque objective kept; (d) the
same, objective the electrical energy with regeneration counted; (e) not counted.

Table 1: each plan through the drives (the exact motor model, ``motor_report``; a plan made
for ideal sources asks its motors to accelerate their rotors on top): the electrical energy
per step (counted, drawn, copper), the largest motor current, and the worst margin of each
limit (negative: the drive cannot deliver the plan's file). Table 2: the gait itself: peak
joint torques per drive, the joint angles' largest difference from plan (b), IPOPT's
iterations and the solve's seconds. Table 3: the step on feet at 1.0 m/s, for ideal torques and
with the drives in the loop (the ankles' through 30:1), each through the drives.
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from model.presets import six_link_anthropoid
from problems import walking_step
from problems.drives.catalogue import Drive, Gearbox, Motor
from problems.drives.loop import drives_in_the_loop, energy_per_step, motor_report, with_drives
from problems.drives.replan import LIMITS, compare

RPM = math.pi / 30.0
DRIVE = Drive(
    Motor("illustrative 48 V", 0.07, 0.3, 2e-5, 0.6, 2.0, 48.0, 6000 * RPM, 0.5),
    Gearbox("illustrative 80:1", 80.0, 0.8, 2e-6, 60.0, 160.0, 8000 * RPM, 0.4),
)
#: the ankles' drive on feet: the same motor through 30:1
ANKLE_ON_FEET = Drive(DRIVE.motor, Gearbox("illustrative 30:1", 30.0, 0.8, 2e-6, 60.0, 160.0,
                                           8000 * RPM, 0.4))  # fmt: skip


def _plans(walker):
    """{label: (gait, planned with rotors)}, each solved and verified."""
    plans = {}
    cases = [
        ("(a) ideal, bare body", lambda: walking_step(), False),
        ("(b) ideal, motors' masses", lambda: walking_step(walker.linkage), False),
        ("(c) drives, torque objective",
         lambda: with_drives(walking_step(walker.linkage, rotors=walker.rotors), walker,
                             "kept"), True),
        ("(d) drives, energy (regen.)",
         lambda: with_drives(walking_step(walker.linkage, rotors=walker.rotors), walker), True),
        ("(e) drives, energy (no regen.)",
         lambda: with_drives(walking_step(walker.linkage, rotors=walker.rotors), walker,
                             regeneration=False), True),
    ]  # fmt: skip
    for label, build, rotors in cases:
        clock = time.perf_counter()
        gait = build().solve()
        seconds = time.perf_counter() - clock
        plans[label] = (gait, rotors, seconds)
    return plans


def main(argv=None) -> int:
    drives = dict.fromkeys(("hip", "knee", "ankle", "neck"), DRIVE)
    walker = drives_in_the_loop(six_link_anthropoid(), drives)
    plans = _plans(walker)
    print(f"Drives: {DRIVE.name}, {DRIVE.mass:g} kg each, J {DRIVE.inertia * 1e4:g} kg cm^2 "
          f"at the motor ({DRIVE.inertia * DRIVE.gearbox.ratio**2:.3f} kg m^2 reflected); "
          f"peak motor torque {DRIVE.motor.peak_torque:g} N m, supply "
          f"{DRIVE.motor.voltage:g} V, gear peak {DRIVE.gearbox.peak_torque:g} N m\n")  # fmt: skip
    print("Table 1: each plan through the drives, at its 1 kHz samples (exact motor model)\n")
    print("| plan | verified | energy counted, J | drawn, J | copper, J | peak current, A | "
          + " | ".join(f"worst {k}" for k in LIMITS) + " |")  # fmt: skip
    print("|---" * (6 + len(LIMITS)) + "|")
    reports = {}
    for label, (gait, rotors, _) in plans.items():
        trajectory = gait.exported()
        report = motor_report(trajectory, walker, with_rotors=rotors)
        reports[label] = (trajectory, report)
        energy = energy_per_step(report, trajectory.time)
        current = max(float(np.max(np.abs(r["current"]))) for r in report.values())
        worst = _worst(trajectory, walker, rotors)
        print(f"| {label} | {gait.verified} | {energy['counted']:.1f} | {energy['drawn']:.1f} | "
              f"{energy['copper']:.1f} | {current:.1f} | " + " | ".join(worst) + " |")  # fmt: skip
    print("\nTable 2: the gaits: peak |joint torque| (the gear's output) per drive, N m; the "
          "joint angles' largest difference from plan (b), deg; IPOPT iterations; "
          "solve s\n")  # fmt: skip
    keys = [m.key for m in walker.mounted]
    print("| plan | " + " | ".join(keys) + " | angles vs (b), deg | iterations | seconds |")
    print("|---" * (4 + len(keys)) + "|")
    base = reports["(b) ideal, motors' masses"][0]
    for label, (gait, _, seconds) in plans.items():
        trajectory, report = reports[label]
        peaks = " | ".join(f"{np.max(np.abs(report[k]['tau_out'])):.1f}" for k in keys)
        difference = (
            np.max(np.abs(np.unwrap(trajectory.psi, axis=0) - np.unwrap(base.psi, axis=0)))
            if trajectory.psi.shape == base.psi.shape
            else float("nan")
        )
        iterations = gait.summary()["iterations"]
        print(f"| {label} | {peaks} | {np.degrees(difference):.2f} | {iterations} | "
              f"{seconds:.2f} |")  # fmt: skip
    print()
    feet_table()
    return 0


def _worst(trajectory, walker, rotors: bool) -> list[str]:
    """Each limit's worst margin through the drives and the drive where it is, as cells."""
    worst = compare(trajectory, walker, with_rotors=rotors)["worst"]
    return [f"{worst[limit][0]:+.3g} ({worst[limit][1]})" for limit in LIMITS]


def feet_table() -> None:
    """Table 3: the step on feet at 1.0 m/s (footed_step_at), the same drives but the ankles'
    through 30:1 (through 80:1 their reflected inertia, 0.14 kg m^2 on a foot of 1 kg, made
    the plan infeasible at the heel strike in a scratch run), torque objective."""
    from model.presets import anthropoid_with_feet
    from problems.walking.footed import footed_step_at

    clock = time.perf_counter()
    ideal = footed_step_at(1.0).solve(progress=False)
    seconds = {"(f) feet, ideal": time.perf_counter() - clock}
    drives = {**dict.fromkeys(("hip", "knee", "neck"), DRIVE), "ankle": ANKLE_ON_FEET}
    walker = drives_in_the_loop(anthropoid_with_feet(), drives, ideal.problem.neutral_ankles)
    step = footed_step_at(1.0, linkage=walker.linkage, rotors=walker.rotors)
    step = with_drives(step, walker, "kept")
    clock = time.perf_counter()
    gait = step.solve(step.problem.guess(ideal.solution), progress=False)
    seconds["(g) feet, drives, torque objective"] = time.perf_counter() - clock
    print(f"Table 3: on feet at 1.0 m/s, the ankles through {ANKLE_ON_FEET.gearbox.ratio:g}:1 "
          f"({ANKLE_ON_FEET.inertia * ANKLE_ON_FEET.gearbox.ratio**2:.3f} kg m^2 reflected), "
          "each plan through the drives\n")  # fmt: skip
    print("| plan | verified | energy drawn, J | copper, J | "
          + " | ".join(f"worst {k}" for k in LIMITS) + " | iterations | seconds |")  # fmt: skip
    print("|---" * (6 + len(LIMITS)) + "|")
    for label, rotors in zip(seconds, (False, True), strict=True):
        solved = ideal if not rotors else gait
        trajectory = solved.exported()
        report = motor_report(trajectory, walker, with_rotors=rotors)
        energy = energy_per_step(report, trajectory.time)
        worst = _worst(trajectory, walker, rotors)
        print(f"| {label} | {solved.verified} | {energy['drawn']:.1f} | {energy['copper']:.1f} | "
              + " | ".join(worst) + f" | {solved.summary()['iterations']} | "
              f"{seconds[label]:.1f} |")  # fmt: skip
    print()


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
