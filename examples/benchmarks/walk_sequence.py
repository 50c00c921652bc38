"""A walker's day (issue #35, second and third parts): the walk 0 -> 1.0 -> 1.4 -> 0.6 -> 0
m/s planned as one file, its transitions' step counts and torque peaks, its verification.

    python examples/benchmarks/walk_sequence.py [--write]  # about two minutes

Table 1: the walk (``problems.library.plan_sequence``, 8 periodic steps at each speed, the
six-link walker on point feet, 150 N m limits): steps in all and of each kind, its duration,
the seconds to plan it (the three periodic gaits, then each transition's search), and its
verification from the file read back (``verify_sequence``: every step's physics, each heel
strike against the next step's first row): the worst join-angle, impact-momentum and dynamics
margins.

Table 3: the walk under its finite-horizon LQR (``design_sequence_feedback``) from standing to
1 s of standing after the last step, in the product's hybrid simulation and in MuJoCo (``pip
install ".[mujoco]"``): as planned, the body 10 % heavier and lighter, a 10 N s push forward
and back in the middle of the first step of the 1.0 -> 1.4 m/s change, a start 0.02 rad off
on every angle; and the backward push again under the law without its contact scaling
(``contact_aware=False``); seconds of each run.

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

from planner.errors import AnthropoidError
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
    closed_loop_table(sequence)
    return 0 if report.ok else 1


def closed_loop_table(sequence) -> None:
    """Table 3: the walk under its finite-horizon LQR in both simulations."""
    from problems.library.closed_loop import (
        SequenceDisturbances,
        design_sequence_feedback,
        simulate_sequence,
    )

    try:
        from problems.control.mujoco import import_mujoco
        from problems.library.mujoco_sequence import run_sequence_in_mujoco

        import_mujoco()
    except AnthropoidError:  # the extra is optional: the column says so
        run_sequence_in_mujoco = None
    clock = time.perf_counter()
    feedback = design_sequence_feedback(sequence)
    design = time.perf_counter() - clock
    kinds = [step.kind for step in sequence.steps]
    change = kinds.index("change")
    print(f"Table 3: the walk in closed loop (finite-horizon LQR along all {len(kinds)} steps, "
          f"designed in {design:.1f} s), then 1 s standing\n")  # fmt: skip
    print("| case | product simulation | s | MuJoCo | s |")
    print("|---|---|---|---|---|")
    cases = {"as planned": SequenceDisturbances(),
             "mass +10 %": SequenceDisturbances(mass_scale=1.1),
             "mass -10 %": SequenceDisturbances(mass_scale=0.9),
             f"push +10 N s mid step {change} (1.0 -> 1.4 m/s)":
                 SequenceDisturbances(push=10.0, push_step=change),
             f"push -10 N s mid step {change}": SequenceDisturbances(push=-10.0, push_step=change),
             "start 0.02 rad off": SequenceDisturbances(initial=np.r_[np.full(6, 0.02),
                                                                      np.zeros(6)])}  # fmt: skip
    plain = design_sequence_feedback(sequence, contact_aware=False)
    runs = [(label, feedback, disturbances) for label, disturbances in cases.items()]
    runs.append((f"push -10 N s mid step {change}, law without the contact scaling", plain,
                 cases[f"push -10 N s mid step {change}"]))  # fmt: skip
    for label, law, disturbances in runs:
        clock = time.perf_counter()
        product = simulate_sequence(law, disturbances)
        product_s = time.perf_counter() - clock
        mujoco, mujoco_s = None, 0.0
        if run_sequence_in_mujoco is not None:
            clock = time.perf_counter()
            mujoco = run_sequence_in_mujoco(law, disturbances)
            mujoco_s = time.perf_counter() - clock
        walked = "not installed" if mujoco is None else _outcome(mujoco)
        print(f"| {label} | {_outcome(product)} | {product_s:.1f} | {walked} | {mujoco_s:.1f} |")
    print()


def _outcome(run) -> str:
    if run.fell is not None:
        reason = run.fell.split(": ", 1)[-1].replace("|", "")  # no pipe in a table's cell
        return f"fell at step {run.walked}: {reason[:70]}"
    return f"{run.walked}/{run.planned} steps" + (", stood" if run.stood else "")


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
