"""A walker's day (issue #35, second and third parts): the walk 0 -> 1.0 -> 1.4 -> 0.6 -> 0
m/s planned as one file, its transitions' step counts and torque peaks, its verification.

    python examples/benchmarks/walk_sequence.py [--write]  # about a minute

Table 1: the walk (``problems.library.plan_sequence``, 8 periodic steps at each speed, the
six-link walker on point feet, 150 N m limits): steps in all and of each kind, its duration,
the seconds to plan it (the three periodic gaits, then each transition's search), and its
verification from the file read back (``verify_sequence``: every step's physics, each heel
strike against the next step's first row): the worst join-angle, impact-momentum and dynamics
margins.

Table 2: each transition: the step counts tried (the fewest that solve within the limits and
verify is taken; a try is capped at 300 IPOPT iterations), the count taken, IPOPT's
iterations of the taken count (the limits' hold rounds included), its seconds of the search,
and its largest torque per hinge against the periodic gaits' it joins (ratio measured in the
same run).
"""

from __future__ import annotations

import argparse
import itertools
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from planner.trajectory import Trajectory
from problems.library import STANDING, plan_sequence, plan_transition, verify_sequence

SPEEDS = (0.0, 1.0, 1.4, 0.6, 0.0)


def _gait_peak(end) -> float:
    if end == STANDING:
        return 0.0
    return float(np.max(np.abs(end.exported().torques)))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps-at-speed", type=int, default=8)
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")  # the accuracy warnings: the verification below holds
    start = time.perf_counter()
    sequence = plan_sequence(SPEEDS, steps_at_speed=args.steps_at_speed)
    seconds = time.perf_counter() - start
    with tempfile.TemporaryDirectory() as folder:
        path = sequence.trajectory().save(Path(folder) / "sequence.csv")
        report = verify_sequence(Trajectory.load(path), sequence.linkage)
    kinds = [step.kind for step in sequence.steps]
    print("Table 1: the walk " + " -> ".join(f"{v:g}" for v in SPEEDS) + " m/s\n")
    print("| steps | start / gait / change / stop | duration s | plan s | verified | worst join "
          "rad | worst impact momentum kg m^2/s | worst dynamics N m |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    counts = " / ".join(str(kinds.count(k)) for k in ("start", "gait", "change", "stop"))
    print(f"| {len(kinds)} | {counts} | {sequence.duration:.2f} | {seconds:.1f} | "
          f"{'all ' + str(len(report.reports)) + ' steps' if report.ok else 'NO'} | "
          f"{report.worst('join angles'):.1e} | {report.worst('impact momentum'):.1e} | "
          f"{report.worst('dynamics'):.1e} |\n")  # fmt: skip
    print("Table 2: the transitions (the search again, timed alone)\n")
    print("| transition | counts tried | steps | iterations | search s | peak abs M N m | "
          "gaits' peak N m | ratio |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    ends = [STANDING if v == 0 else sequence.gaits[v] for v in SPEEDS]
    for a, b in itertools.pairwise(ends):
        clock = time.perf_counter()
        transition = plan_transition(a, b)
        search = time.perf_counter() - clock
        peak = max(transition.peak_torques().values())
        joined = max(_gait_peak(a), _gait_peak(b))
        tried = ", ".join(f"{k}{'' if why == 'solved and verified' else ' (failed)'}"
                          for k, why in transition.attempts)  # fmt: skip
        label = f"{transition.speeds[0]:g} -> {transition.speeds[1]:g} m/s"
        print(f"| {label} | {tried} | {transition.steps} | {transition.iterations} | "
              f"{search:.1f} | {peak:.1f} | {joined:.1f} | {peak / joined:.2f} |")  # fmt: skip
    print()
    return 0 if report.ok else 1


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
