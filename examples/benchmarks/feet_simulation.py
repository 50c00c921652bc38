"""The product's own simulation of the walker on feet against MuJoCo (issue #35, part 4):
the same plans under the same laws in two models of the world.

    python examples/benchmarks/feet_simulation.py [--write]

The product's (:mod:`problems.control.feet_simulation`): the plan's equations of motion on a
floating base, each foot's heel and ball a compliant contact (k d + c d', a tangential spring
capped at mu Fy), semi-implicit Euler at 0.25 ms; MuJoCo's (:mod:`problems.control.mujoco_feet`):
the plan's bodies in MuJoCo's engine, heel and ball spheres, soft contacts, 0.5 ms.

Table 1: the step on feet at 1 m/s (joints bounded at 10 rad/s, as a walk through speeds
plans it), 10 steps under its law in both, undisturbed and under the disturbances every
closed-loop check runs on level ground (the body 10 % heavier or lighter, the start 0.02
rad off, the drives limited to 2/3 of the plan's, a 10 N s push forward or back in the middle
of the second step): steps walked, the mean step length (m, the plan's 0.5), the largest
angle error from the plan at the same phase (rad), the control periods with a drive at its
limit, the stance ball's largest slip (mm), and the seconds of each run.

Table 2: the largest forward and backward pushes (N s, in the middle of the second of four
steps) each survives, bisected to 1 N s.

Table 3: the product's ground over its damping and stiffness: the same 10 steps undisturbed,
each ground's steps walked, mean length, largest error and saturated periods (why the
defaults are what they are).

Table 4: a walk through speeds on feet in both, from the walk command's planner
(``plan_sequence``): 1.0 -> 0.6 m/s and a stop at quiet standing, two periodic steps at each
speed, as planned, 10 % heavier and pushed 10 N s in the speed change: steps walked and how
the walk ended (stood, or why not).

Table 5: a stop at quiet standing in both: two periodic steps at 0.6 m/s and the stop
(``plan_transition(gait, "standing")``), pushed in the middle of the stop by +-5 and +-10 N s,
with the stop's standing law (its sway damping) and without it (``stand_damping=0``): how the
walk ended (stood, or why not: the hip's speed a second after the stop).

Table 6: does the closed loop on feet settle into a periodic walk? 30 steps as planned in
both: the step's duration and length over the last 10 steps (their spread, and the largest
change from one step to the next), and in the product's simulation the state at the phase
s = 0.3 of each step's single support (in the law's labels, so that each step compares with
the one before; the first control instant past it): the largest change of an angle and of a
rate from one step to the next, over steps 2-5 and over the last 10. A loop that settles
shrinks them step by step (the point-foot step under its periodic LQR, largest Floquet
multiplier 0.067, shrinks a deviation 15 times a step). The product's runs on the law's clock
of 1 (the file's), 2, 4, 8 and 16 kHz: the strike and the hand-over are detected once a
period, so a slower clock kicks each step by up to a period.

Table 7: the footed loop's largest multiplier |lambda_1| from a push's decay
(``problems.control.feet_multiplier.dominant_multiplier``): pushes either way, on two clocks,
over two lengths of walk; the first row is what a gait library on feet stores.
"""

from __future__ import annotations

import sys
import time
import warnings

import numpy as np

from problems.control.feet_law import FeetLaw
from problems.control.feet_multiplier import dominant_multiplier
from problems.control.feet_simulation import (
    Ground,
    section_states,
    simulate_feet,
    simulate_feet_steps,
)
from problems.control.mujoco_feet import run_feet_in_mujoco, run_feet_steps_in_mujoco
from problems.control.simulation import Disturbances, disturbances_for, largest_push
from problems.walking.footed import footed_step_at

STEPS = 10


def _row(run, seconds: float) -> str:
    steps = run.steps
    if not steps:
        return f"0/{STEPS} | - | - | - | - | {seconds:.1f}"
    length = np.mean([s.length for s in steps])
    tracking = max(s.tracking for s in steps)
    saturated = sum(s.saturated or 0 for s in steps)
    slip = 1e3 * max(s.slip for s in steps)
    return (f"{run.walked}/{STEPS} | {length:.3f} | {tracking:.3f} | {saturated} | {slip:.1f} "
            f"| {seconds:.1f}")  # fmt: skip


def _disturbances(gait, law) -> None:
    step = gait.problem
    cases = {label: d for label, d in disturbances_for(step.linkage.n, step.torque_limit).items()
             if "ground" not in label}  # fmt: skip
    cases["push +10 N s, step 1"] = Disturbances(push=10.0, push_step=1)
    cases["push -10 N s, step 1"] = Disturbances(push=-10.0, push_step=1)
    print(f"Table 1: the step on feet at 1 m/s, {STEPS} steps, in the product's simulation and "
          "in MuJoCo")  # fmt: skip
    print()
    print("| case | product: steps | length m | error rad | saturated | slip mm | s "
          "| MuJoCo: steps | length m | error rad | saturated | slip mm | s |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for label, disturbances in cases.items():
        cells = []
        for simulate in (simulate_feet, run_feet_in_mujoco):
            start = time.perf_counter()
            run = simulate(gait, steps=STEPS, disturbances=disturbances, law=law)
            cells.append(_row(run, time.perf_counter() - start))
        print(f"| {label} | " + " | ".join(cells) + " |")
    print()


def _pushes(gait, law) -> None:
    print("Table 2: the largest push survived, N s, in the middle of the second of 4 steps")
    print()
    print("| simulation | forward | back |")
    print("|---|---|---|")
    for name, simulate in (("product", simulate_feet), ("MuJoCo", run_feet_in_mujoco)):

        def walk(disturbances, simulate=simulate):
            return simulate(gait, steps=4, disturbances=disturbances, law=law)

        forward, _ = largest_push(walk, direction=1.0, steps=4)
        back, _ = largest_push(walk, direction=-1.0, steps=4)
        print(f"| {name} | {forward:.0f} | {back:.0f} |")
    print()


def _grounds(gait, law) -> None:
    print(f"Table 3: the product's ground, {STEPS} steps undisturbed")
    print()
    print("| stiffness N/m | damping N s/m | steps | length m | error rad | saturated | slip mm "
          "| s |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    default = Ground()
    for stiffness, damping in ((default.stiffness, 5e3), (default.stiffness, default.damping),
                               (default.stiffness, 5e4), (3e5, default.damping),
                               (3e6, default.damping)):  # fmt: skip
        start = time.perf_counter()
        run = simulate_feet(gait, steps=STEPS, law=law,
                            ground=Ground(stiffness=stiffness, damping=damping))  # fmt: skip
        print(f"| {stiffness:.0e} | {damping:.0e} | {_row(run, time.perf_counter() - start)} |")
    print()


def _sequence() -> None:
    from problems.library import plan_sequence
    from problems.library.feet_closed_loop import sequence_laws

    start = time.perf_counter()
    walk = plan_sequence([1.0, 0.6, 0.0], feet=True, steps_at_speed=2, speed_limit=10.0)
    seconds = time.perf_counter() - start
    laws = sequence_laws(walk)
    gaits = [step.gait for step in walk.steps]
    kinds = [step.kind for step in walk.steps]
    change = kinds.index("change")
    print(f"Table 4: the walk 1.0 -> 0.6 -> 0 m/s on feet ({len(gaits)} steps: "
          f"{', '.join(kinds)}; planned in {seconds:.0f} s), then 1 s standing")  # fmt: skip
    print()
    print("| case | product: steps | how it ended | MuJoCo: steps | how it ended |")
    print("|---|---|---|---|---|")
    cases = {"as planned": Disturbances(), "mass +10 %": Disturbances(mass_scale=1.1),
             f"push +10 N s, step {change}": Disturbances(push=10.0, push_step=change)}  # fmt: skip
    for label, disturbances in cases.items():
        cells = []
        for simulate in (simulate_feet_steps, run_feet_steps_in_mujoco):
            run = simulate(gaits, disturbances=disturbances, laws=laws)
            ended = "stood" if run.fell is None else run.fell.split(": ", 1)[-1][:70]
            cells += [f"{run.walked}/{len(gaits)}", ended]
        print(f"| {label} | " + " | ".join(cells) + " |")
    print()


def _stop_pushes() -> None:
    from problems.library import plan_transition

    gait = footed_step_at(0.6, speed_limit=10.0).solve(progress=False)
    (stop,) = plan_transition(gait, "standing", steps=1).gaits
    gaits = [gait, gait, stop]
    walk = FeetLaw(gait)
    laws = {"damped": [walk, walk, FeetLaw(stop)],
            "undamped": [walk, walk, FeetLaw(stop, stand_damping=0.0)]}  # fmt: skip
    print("Table 5: two steps at 0.6 m/s and the stop, pushed in the stop, then 1 s standing")
    print()
    print("| push in the stop N s | law | product | MuJoCo |")
    print("|---|---|---|---|")
    for push in (0.0, 5.0, -5.0, 10.0, -10.0):
        for name, each in laws.items():
            cells = []
            for simulate in (simulate_feet_steps, run_feet_steps_in_mujoco):
                run = simulate(gaits, disturbances=Disturbances(push=push, push_step=2),
                               laws=each)  # fmt: skip
                cells.append("stood" if run.fell is None else run.fell.split(": ", 1)[-1][:70])
            print(f"| {push:+g} | {name} | " + " | ".join(cells) + " |")
    print()


#: Table 6's walk: its steps, the phase of its section, the steps read at its end, the clocks
SETTLE_STEPS, SECTION, LAST = 30, 0.3, 10
CLOCKS_HZ = (1000.0, 2000.0, 4000.0, 8000.0, 16000.0)


def _settling(gait, law) -> None:
    print(f"Table 6: {SETTLE_STEPS} steps as planned: does the loop settle? (the last {LAST} "
          "steps; changes from one step to the next; the law's clock, one integration step a "
          "period past 4 kHz)")  # fmt: skip
    print()
    print("| simulation | clock kHz | steps | duration ms, min-max | largest change ms | length "
          "mm, min-max | largest change mm | angles: change rad, steps 2-5 / last | rates: "
          "change rad/s, steps 2-5 / last | s |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|")
    n = gait.problem.linkage.n
    runs = []
    for rate in CLOCKS_HZ:
        clock = time.perf_counter()
        run = simulate_feet(gait, steps=SETTLE_STEPS, law=law, rate_hz=rate,
                            substeps=max(1, round(4000.0 / rate)))  # fmt: skip
        runs.append(("product", rate, run, time.perf_counter() - clock))
    clock = time.perf_counter()
    mujoco = run_feet_in_mujoco(gait, steps=SETTLE_STEPS, law=law)
    runs.append(("MuJoCo", 1000.0, mujoco, time.perf_counter() - clock))
    for label, rate, run, seconds in runs:
        steps = run.steps[-LAST:]
        durations = 1e3 * np.array([s.duration for s in steps])
        lengths = 1e3 * np.array([s.length for s in steps])
        cells = [label, f"{rate / 1e3:g}", f"{run.walked}/{SETTLE_STEPS}",
                 f"{durations.min():.2f}-{durations.max():.2f}",
                 f"{np.max(np.abs(np.diff(durations))):.2f}",
                 f"{lengths.min():.1f}-{lengths.max():.1f}",
                 f"{np.max(np.abs(np.diff(lengths))):.1f}"]  # fmt: skip
        if label == "product":
            change = np.abs(np.diff(section_states(run, law, SECTION), axis=0))
            early, late = change[1:5], change[-LAST:]
            cells += [f"{early[:, :n].max():.4f} / {late[:, :n].max():.4f}",
                      f"{early[:, n:].max():.3f} / {late[:, n:].max():.3f}"]  # fmt: skip
        else:
            cells += ["-", "-"]
        print("| " + " | ".join(cells) + f" | {seconds:.1f} |")
    print()


#: Table 7's estimates: (push N s, steps, clock Hz); the first is the library's
ESTIMATES = ((6.0, 14, 8000.0), (-6.0, 14, 8000.0), (3.0, 24, 16000.0), (-3.0, 24, 16000.0))


def _multiplier(gait, law) -> None:
    print("Table 7: the footed loop's largest Floquet multiplier |lambda_1|, from a push's "
          "decay against the unpushed walk (problems.control.feet_multiplier)")  # fmt: skip
    print()
    print("| push N s | steps | clock kHz | abs lambda_1 | ratios used | spread (max abs log) "
          "| steps to halve a deviation | s |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for push, steps, rate in ESTIMATES:
        clock = time.perf_counter()
        estimate = dominant_multiplier(gait, law=law, push=push, steps=steps, rate_hz=rate)
        seconds = time.perf_counter() - clock
        halve = np.log(0.5) / np.log(estimate.modulus)
        print(
            f"| {push:+g} | {steps} | {rate / 1e3:g} | {estimate.modulus:.3f} | "
            f"{estimate.ratios.size} | {estimate.spread:.3f} | {halve:.1f} | {seconds:.1f} |"
        )
    print()


def main() -> int:
    warnings.simplefilter("ignore")  # the accuracy notes of the solves
    gait = footed_step_at(1.0, speed_limit=10.0).solve(progress=False)
    law = FeetLaw(gait)
    _disturbances(gait, law)
    _pushes(gait, law)
    _grounds(gait, law)
    _sequence()
    _stop_pushes()
    _settling(gait, law)
    _multiplier(gait, law)
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
