"""The step on feet walked in MuJoCo under its drives' law (``pip install ".[mujoco]"``).

    python examples/benchmarks/feet_mujoco.py              # gains, check, speeds
    python examples/benchmarks/feet_mujoco.py --quick      # the check at 1 m/s only

Six tables, each from one run:

1. The gains: the default step on feet (1 m/s) walked 50 steps in MuJoCo under joint PD
   around the plan (:class:`problems.control.mujoco_feet.FeetLaw`) for several hinge gains
   kp, kd and the bandwidth that caps them on light links in the single support (``inf``:
   uniform gains, no cap):
   steps walked, why it fell, the largest tracking error (rad), the stance ball's largest
   slip (mm), the largest drive command (N m), the share of control periods with a drive held
   at its limit (%) and the stance foot's largest normal force (body weights).
2. The check at the default gains (:func:`problems.control.mujoco_feet.feet_mujoco_check`):
   open loop, closed loop and the product's disturbances, 20 steps each, and the largest
   pushes survived.
3. The three speeds of the README's table (0.6, 1.0, 1.4 m/s): 50 steps each at the default
   gains.
4. The contact sequences at 1 m/s (``footed_step(phases=...)``: human, flat-footed,
   toe-walking): open loop and 50 steps closed loop at each sequence's default gains
   (``FeetLaw``'s, :data:`problems.control.feet_law.SEQUENCE_GAINS`).
5. The toe walker's gains: 50 steps each, where its defaults come from.
6. The check of table 2 for the other sequences at their default gains: the disturbances and
   the largest pushes, 20 steps each.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings

import numpy as np

from planner import AccuracyWarning
from problems import footed_step_at
from problems.control.feet_law import (
    FEET_BANDWIDTH,
    FEET_KD,
    FEET_KP,
    FeetLaw,
    hinge_inertias,
)
from problems.control.mujoco_feet import feet_mujoco_check, run_feet_in_mujoco
from problems.walking.footed import SEQUENCES

#: (kp N m/rad, kd N m s/rad, bandwidth rad/s) of the sweep; inf: no cap
GAINS = [
    (600.0, 30.0, math.inf),
    (1000.0, 30.0, math.inf),
    (300.0, 15.0, 50.0),
    (600.0, 30.0, 50.0),
    (1000.0, 30.0, 30.0),
    (1000.0, 30.0, 50.0),
    (1000.0, 30.0, 70.0),
    (1000.0, 50.0, 50.0),
    (1500.0, 40.0, 50.0),
]
#: the toe walker's sweep (table 5)
TOE_GAINS = [
    (1000.0, 30.0, 50.0),
    (600.0, 30.0, 50.0),
    (1500.0, 40.0, 50.0),
    (2000.0, 60.0, 50.0),
    (1000.0, 30.0, 30.0),
    (1000.0, 50.0, 50.0),
    (1000.0, 40.0, 70.0),
    (1000.0, 50.0, 70.0),
]


def _solve(speed: float, phases: str = "human"):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        return footed_step_at(speed, phases=phases).solve()


def _row(label: str, run, weight: float) -> str:
    steps = run.steps
    tracking = max((s.tracking for s in steps), default=float("nan"))
    slip = 1000.0 * max((s.slip for s in steps), default=float("nan"))
    torque = max((s.peak_torque for s in steps), default=float("nan"))
    normal = max((s.peak_normal for s in steps), default=float("nan")) / weight
    periods = sum(s.duration for s in steps) * 1000.0  # control periods at 1 kHz
    held = 100.0 * sum(s.saturated for s in steps) / periods if steps else float("nan")
    why = "" if run.fell is None else run.fell.split(":")[-1].strip()[:38]
    return (f"{label:<22} {run.walked:>6d} {tracking:>9.3f} {slip:>8.1f} {torque:>8.1f} "
            f"{held:>7.2f} {normal:>8.2f}  {why}")  # fmt: skip


HEAD = (f"{'':<22} {'walked':>6} {'track rad':>9} {'slip mm':>8} {'|M| N m':>8} "
        f"{'at |M|%':>7} {'Fy / mg':>8}  fell")  # fmt: skip


def _print_check(title: str, check, seconds: float, weight: float) -> None:
    """A :func:`feet_mujoco_check`'s runs, one row each, and its largest pushes."""
    print(f"{title}, 20 steps each ({seconds:.0f} s)")
    print(HEAD)
    print("-" * (len(HEAD) + 20))
    for label, run in check.runs.items():
        print(_row(label, run, weight), flush=True)
    if check.pushes is not None:
        print(f"largest push survived (10 steps, at mid-step of the second): forward "
              f"{check.pushes[0]:.1f} N s, back {check.pushes[1]:.1f} N s")  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the check at 1 m/s only")
    args = parser.parse_args()
    gait = _solve(1.0)
    step = gait.problem
    weight = sum(link.mass for link in step.linkage.links) * step.linkage.gravity
    postures = FeetLaw(gait).references[0].states[:, : step.linkage.n]
    inertias = hinge_inertias(step.dynamics, postures)
    print("The inertia each drive moves, kg m^2 (the relative-angle mass matrix's diagonal)")
    names = step.linkage.names
    print("  ".join(f"{name} {value:.4g}" for name, value in zip(names, inertias, strict=True)))
    print()
    if not args.quick:
        print("1. Gains: the default step on feet (1 m/s), 50 steps in MuJoCo")
        print(f"{'kp / kd / bandwidth':<22}" + HEAD[22:])
        print("-" * (len(HEAD) + 20))
        for kp, kd, bandwidth in GAINS:
            law = FeetLaw(gait, kp, kd, bandwidth=bandwidth)
            run = run_feet_in_mujoco(gait, steps=50, law=law)
            print(_row(f"{kp:g} / {kd:g} / {bandwidth:g}", run, weight), flush=True)
        print()
    start = time.perf_counter()
    check = feet_mujoco_check(gait, steps=20)
    seconds = time.perf_counter() - start
    _print_check(f"2. The check at the default gains ({FEET_KP:g} / {FEET_KD:g} / "
                 f"{FEET_BANDWIDTH:g})", check, seconds, weight)  # fmt: skip
    print()
    if not args.quick:
        print("3. Speeds: 50 steps at the default gains")
        print(f"{'speed m/s (length m)':<22}" + HEAD[22:])
        print("-" * (len(HEAD) + 20))
        for speed in (0.6, 1.0, 1.4):
            run = run_feet_in_mujoco(gait if speed == 1.0 else _solve(speed), steps=50)
            lengths = np.mean([s.length for s in run.steps]) if run.steps else float("nan")
            print(_row(f"{speed:g} ({lengths:.3f})", run, weight), flush=True)
        print()
        print("4. Contact sequences at 1 m/s: open loop, then 50 steps at each sequence's "
              "default gains")  # fmt: skip
        print(f"{'sequence':<22}" + HEAD[22:])
        print("-" * (len(HEAD) + 20))
        planned = {name: gait if name == "human" else _solve(1.0, name) for name in SEQUENCES}
        for name, plan in planned.items():
            for open_loop in (True, False):
                run = run_feet_in_mujoco(plan, steps=50, open_loop=open_loop)
                law = FeetLaw(plan)
                gains = f"{law.gains[1][0][1]:g} / {law.gains[1][1][1]:g} / {law.bandwidth:g}"
                label = f"{name} {'open' if open_loop else gains}"
                print(_row(label, run, weight), flush=True)
        print()
        print("5. Toe walking's gains (kp / kd / bandwidth), 50 steps each")
        print(f"{'kp / kd / bandwidth':<22}" + HEAD[22:])
        print("-" * (len(HEAD) + 20))
        for kp, kd, bandwidth in TOE_GAINS:
            law = FeetLaw(planned["toe-walking"], kp=kp, kd=kd, bandwidth=bandwidth)
            run = run_feet_in_mujoco(planned["toe-walking"], steps=50, law=law)
            print(_row(f"{kp:g} / {kd:g} / {bandwidth:g}", run, weight), flush=True)
        for name, plan in planned.items():
            if name == "human":  # table 2
                continue
            start = time.perf_counter()
            check = feet_mujoco_check(plan, steps=20)
            seconds = time.perf_counter() - start
            kp, kd = check.gains[1][0][1], check.gains[1][1][1]
            print()
            _print_check(f"6. The check for {name} at its default gains ({kp:g} / {kd:g} / "
                         f"{FeetLaw(plan).bandwidth:g})", check, seconds, weight)  # fmt: skip
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
