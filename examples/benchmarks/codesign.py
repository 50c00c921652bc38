"""Gear ratios designed with the gait against the best catalogue pick (issue #36, part 5), in
one run: the electrical energy per step drawn by the drives (regeneration not counted) at 0.6,
0.8 and 1.0 m/s (point feet with a sole, ``step_at_speed``'s steps, Hermite-Simpson N = 20).

    python examples/benchmarks/codesign.py [--write]   # about 6 min

1. The catalogue pick with the motion planned for ideal torques: each speed's step planned for
   the bare body and ideal torque sources (the product's default), the drives chosen from the
   catalogue below by the least energy over the three speeds (``problems.drives.select``,
   ``rank="energy"``, equal shares; right and left alike); its energy is that motion's, read
   through the pick (its rotors accelerated on top), with each limit's worst margin there.
2. The same pick with the drives in the loop: each step re-planned with the motors' masses,
   their rotors and limits, minimising the electrical energy drawn (``problems.drives.loop``).
3. The gear ratios of the hips, knees and ankles co-designed with the gait from the pick's
   (``problems.drives.codesign_ratios``: each design's three steps planned with the drives in
   the loop and verified; a compass search in log N): the motors and the gearboxes' other
   data stay the pick's.
4. Parallel springs at the hips (``problems.drives.spring_design.design_springs``): each
   speed's step designs its own spring's stiffness and rest angle in its NLP, then the one
   spring the walker carries is the speeds' design with the least energy over the three, each
   tried fixed at the other speeds; beside the pick's ratios and beside the co-designed ones.
   A knee spring designed the same way went to no stiffness in scratch runs (it did not pay), and
   a point foot's ankle carries none (its swing ankle turns nothing).

The catalogue is ``examples/drives/*_illustrative.csv`` (two 48 V motors, each in two windings,
one gearbox family at five ratios): illustrative numbers, not products; no cited catalogue ships
yet.
"""

from __future__ import annotations

import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from model.presets import six_link_anthropoid
from problems import walking_step
from problems.drives import Drive, DriveRequirements, read_gearboxes, read_motors, select
from problems.drives.codesign import codesign_ratios
from problems.drives.loop import drives_in_the_loop
from problems.drives.replan import LIMITS, compare
from problems.drives.requirements import plan_of
from problems.drives.spring_design import design_springs
from problems.drives.springs import ParallelSpring
from problems.walking.footed import step_at_speed

SPEEDS = (0.6, 0.8, 1.0)
JOINTS = ("hip", "knee", "ankle", "neck")
#: the illustrative catalogue beside the guide (two 48 V motors, each in two windings; one
#: gearbox family at five ratios), not products
CATALOGUE = Path(__file__).resolve().parent.parent / "drives"


def _catalogue():
    return (read_motors(CATALOGUE / "motors_illustrative.csv"),
            read_gearboxes(CATALOGUE / "gearboxes_illustrative.csv"))  # fmt: skip


def main(argv=None) -> int:
    linkage = six_link_anthropoid()
    ideal = [walking_step(linkage, *step_at_speed(v), N=20).solve(progress=False) for v in SPEEDS]
    plans = [plan_of(g.exported(), f"{v:g} m/s", 1.0 / len(SPEEDS))
             for g, v in zip(ideal, SPEEDS, strict=True)]  # fmt: skip
    motors, gearboxes = _catalogue()
    selection = select(DriveRequirements.of(plans), motors, gearboxes, rank="energy",
                       regenerate=False)  # fmt: skip
    pick = {}
    for joint in JOINTS:
        best = selection.best("neck" if joint == "neck" else f"right_{joint}")
        if best is None:
            print(f"the catalogue has no drive for the {joint}: {selection.refused}")
            return 1
        pick[joint] = best.drive
    print("The catalogue pick for the ideal-torque plans (least energy over the speeds): "
          + "; ".join(f"{j} {d.name}" for j, d in pick.items()) + "\n")  # fmt: skip

    walker = drives_in_the_loop(linkage, pick)
    through = []
    for gait in ideal:
        seen = compare(gait.exported(), walker, with_rotors=False)
        worst = {limit: value for limit, (value, _) in seen["worst"].items()}
        through.append((seen["energy"]["drawn"], worst))
    design = codesign_ratios(linkage, pick, SPEEDS, joints=("hip", "knee", "ankle"), N=20)

    print("Electrical energy drawn per step, J (regeneration not counted), at every 1 kHz "
          "sample of each plan\n")  # fmt: skip
    print("| design | N hip | N knee | N ankle | " + " | ".join(f"{v:g} m/s" for v in SPEEDS)
          + " | sum | within every limit |")  # fmt: skip
    print("|---" * (6 + len(SPEEDS)) + "|")
    ratios = [f"{pick[j].gearbox.ratio:g}" for j in ("hip", "knee", "ankle")]
    misses = [f"{k} {v:+.3g}" for k, v in
              {k: min(w[k] for _, w in through) for k in LIMITS}.items() if v < 0]  # fmt: skip
    rows = [
        ("catalogue pick, ideal-torque motion", ratios, [e for e, _ in through],
         "no: " + ", ".join(misses) if misses else "yes"),
        ("catalogue pick, drives in the loop", ratios, list(design.start.per_speed), "yes"),
        ("co-designed ratios, drives in the loop",
         [f"{design.best.ratios[j]:.0f}" for j in ("hip", "knee", "ankle")],
         list(design.best.per_speed), "yes"),
    ]  # fmt: skip
    for label, n, energies, within in rows:
        print(f"| {label} | " + " | ".join(n) + " | " + " | ".join(f"{e:.1f}" for e in energies)
              + f" | {sum(energies):.1f} | {within} |")  # fmt: skip
    change = 1.0 - design.best.energy / sum(e for e, _ in through)
    again = 1.0 - design.best.energy / design.start.energy
    count = len(design.history)
    print(f"\nThe co-designed ratios draw {change:.0%} less than the pick with the ideal motion "
          f"and {again:.0%} less than the pick with the drives in the loop. Search: {count} "
          f"designs ({count * len(SPEEDS)} verified plans) in "
          f"{design.seconds:.0f} s; the designs' energies near the best scatter by "
          f"{_scatter(design):.1f} J (the plans' local optima)\n")  # fmt: skip
    hip = (ParallelSpring("hip"),)
    codesigned = {**pick, **{j: Drive(pick[j].motor, replace(pick[j].gearbox, ratio=n))
                             for j, n in design.best.ratios.items()}}  # fmt: skip
    for label, drives in (("the catalogue pick", pick), ("the co-designed ratios", codesigned)):
        springs = design_springs(linkage, drives, SPEEDS, hip, N=20)
        print(f"A parallel spring at each hip beside {label}: electrical energy drawn per step "
              f"(search: {springs.seconds:.0f} s)\n")  # fmt: skip
        print(springs.table() + "\n")
    return 0


def _scatter(design) -> float:
    """The spread of the energies of the designs within a factor 1.1 of the best's ratios."""
    near = [e for r, e in design.history
            if all(abs(math.log(r[j] / design.best.ratios[j])) < math.log(1.1) for j in r)
            and math.isfinite(e)]  # fmt: skip
    return float(np.ptp(near)) if len(near) > 1 else 0.0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
