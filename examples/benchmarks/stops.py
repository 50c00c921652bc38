"""Stops at quiet standing (issue #35, part 2): how the last step sets its foot down.

    python examples/benchmarks/stops.py [--write]

Table 1, point feet: the stop from the periodic gait at 1 m/s (``plan_transition(gait,
"standing")``), its last step's clearance floor ending flat (``land_time``,
:data:`problems.walking.step.LAND_TIME`) and, in the same run, as before it (``land_time``
0: the plain floor, which curves down to the ground at T, where the foot must be at rest
with no acceleration): the steps taken, IPOPT's iterations, the search's seconds, the largest
drive torque over the stop and over its last 20 ms (1 kHz samples, what a file holds), and
their ratio.

Table 2, on feet: the linear-inverted-pendulum capture point x_com + v / sqrt(g / h) at the
stop's start (the periodic gait's x(0), after its toe-off), from the stance ball (the sole
spans [-sole, 0]): where a one-step stop can bring the body to rest over the stance foot.

Table 3, on feet: the stop from 0.6 m/s (``plan_transition(footed_step_at(0.6).solve(),
"standing")``): steps, iterations, seconds, the largest drive torque (and its hinge), the
largest over the last 20 ms, and the end's verification margins (``standing feet``,
``standing flat``, ``standing at rest``).

Table 4, on feet, closed loop in MuJoCo: four periodic steps at 0.6 m/s (joints bounded at
10 rad/s, as ``walk --speeds`` plans them) and the stop, each under its file's law (the
stop's: by the time, blended into standing's, its last sample held for 1 s after it;
``FeetLaw``), undisturbed and disturbed (the body 10 % heavier or lighter, the start 0.02 rad
off, a push on the torso in the middle of the first step or of the stop), with the standing
damping (0.7 of critical at the stance ankle, ``FeetLaw(stand_damping=)``) and without it (0:
the walk's joint PD alone): steps walked of 5, and how the walk ended (``stood``, or why not).

Table 5, the same walk in MuJoCo over the standing damping (ratio of critical 0 to 1): the
pushes of +-2.5, 5 and 10 N s in the middle of the first step or of the stop it stands
(where :data:`problems.control.feet_law.STAND_DAMPING` comes from).
"""

from __future__ import annotations

import math
import sys
import time
import warnings

import numpy as np

import problems.library.transition as transition_module
from problems import walking_step
from problems.library import plan_transition
from problems.walking.footed import footed_step_at, step_at_speed

#: s: the window whose drive torques show a landing jerk (the last mesh interval and a half)
END_WINDOW = 0.02


def _drive_peaks(transition, rate_hz: float = 1000.0) -> tuple[float, float, str]:
    """(the largest drive |M| over the transition, over the last step's last END_WINDOW s,
    N m; the hinge of the first) on the samples at ``rate_hz``."""
    problem = transition.gaits[0].problem
    names = problem.linkage.names
    drives = [i for i, name in enumerate(names) if name in getattr(problem, "drives", names)]
    whole = np.max([np.max(np.abs(g.exported(rate_hz).torques[:, drives]), axis=0)
                    for g in transition.gaits], axis=0)  # fmt: skip
    last = transition.gaits[-1].exported(rate_hz)
    end = np.asarray(last.time) > last.time[-1] - END_WINDOW
    return (
        float(whole.max()),
        float(np.abs(last.torques[end][:, drives]).max()),
        names[drives[int(np.argmax(whole))]],
    )


def _point_feet() -> None:
    length, duration = step_at_speed(1.0)
    gait = walking_step(step_length=length, step_time=duration).solve(progress=False)
    print("Table 1: point feet, the stop from 1 m/s, its last step's floor ending flat or not")
    print()
    print("| last step's floor | steps | iterations | s | drive peak N m (hinge) "
          "| last 20 ms N m | last 20 ms / peak |")  # fmt: skip
    print("|---|---|---|---|---|---|---|")
    flat_end = transition_module.LAND_TIME
    for label, land in (("ends flat (land_time 0.05 s)", flat_end), ("plain (land_time 0)", 0.0)):
        transition_module.LAND_TIME = land
        try:
            clock = time.perf_counter()
            stop = plan_transition(gait, "standing")
            seconds = time.perf_counter() - clock
        finally:
            transition_module.LAND_TIME = flat_end
        peak, end, hinge = _drive_peaks(stop)
        print(f"| {label} | {stop.steps} | {stop.iterations} | {seconds:.1f} | {peak:.1f} "
              f"({hinge}) | {end:.1f} | {end / peak:.2f} |")  # fmt: skip
    print()


def _capture_points() -> None:
    print("Table 2: on feet, the capture point at the stop's start (the gait's x(0))")
    print()
    print("| gait m/s | CoM x m | CoM height m | CoM speed m/s | capture point m | sole m |")
    print("|---|---|---|---|---|---|")
    for speed in (0.4, 0.6, 1.0):
        gait = footed_step_at(speed).solve(progress=False)
        step = gait.problem
        n = step.linkage.n
        masses = np.array([link.mass for link in step.linkage.links])
        x0 = gait.segments()[0][0].states[0]
        com = masses @ np.ravel(step.dynamics.com_positions(x0[:n])) / masses.sum()
        velocity = masses @ np.ravel(step.dynamics.com_velocities(x0[:n], x0[n:])) / masses.sum()
        capture = com.real + velocity.real / math.sqrt(step.linkage.gravity / com.imag)
        print(f"| {speed:g} | {com.real:+.3f} | {com.imag:.3f} | {velocity.real:.3f} | "
              f"{capture:+.3f} | [-{step.sole:.3f}, 0] |")  # fmt: skip
    print()


def _on_feet() -> None:
    gait = footed_step_at(0.6).solve(progress=False)
    clock = time.perf_counter()
    stop = plan_transition(gait, "standing")
    seconds = time.perf_counter() - clock
    peak, end, hinge = _drive_peaks(stop)
    margins = {c.name: c.margin for c in stop.reports[-1].checks}
    print("Table 3: on feet, the stop from 0.6 m/s")
    print()
    print("| steps | iterations | s | drive peak N m (hinge) | last 20 ms N m | standing feet m "
          "| standing flat rad | standing at rest rad/s |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    print(f"| {stop.steps} | {stop.iterations} | {seconds:.1f} | {peak:.1f} ({hinge}) | "
          f"{end:.1f} | {margins['standing feet']:.1e} | {margins['standing flat']:.1e} | "
          f"{margins['standing at rest']:.1e} |")  # fmt: skip
    print()


def _stop_in_mujoco(gait, stop) -> None:
    from problems.control.feet_law import STAND_DAMPING, FeetLaw
    from problems.control.mujoco_feet import run_feet_steps_in_mujoco
    from problems.control.simulation import Disturbances

    gaits = [gait] * 4 + [stop]
    n = gait.problem.linkage.n
    off = np.zeros(2 * n)
    off[1:n] = 0.02
    cases = {
        "as planned": Disturbances(),
        "mass +10 %": Disturbances(mass_scale=1.1),
        "mass -10 %": Disturbances(mass_scale=0.9),
        "start 0.02 rad off": Disturbances(initial=off),
        "push +10 N s, step 0": Disturbances(push=10.0, push_step=0),
        "push -10 N s, step 0": Disturbances(push=-10.0, push_step=0),
        "push +10 N s, the stop": Disturbances(push=10.0, push_step=4),
        "push -10 N s, the stop": Disturbances(push=-10.0, push_step=4),
        "push +5 N s, the stop": Disturbances(push=5.0, push_step=4),
        "push -5 N s, the stop": Disturbances(push=-5.0, push_step=4),
    }
    walk = FeetLaw(gait)
    laws = {damping: [walk] * 4 + [FeetLaw(stop, stand_damping=damping)]
            for damping in (STAND_DAMPING, 0.0)}  # fmt: skip
    print("Table 4: on feet, 4 steps at 0.6 m/s and the stop in MuJoCo, standing 1 s after it")
    print()
    print(f"| case | standing damping {STAND_DAMPING:g}: steps | how it ended | none: steps "
          "| how it ended |")  # fmt: skip
    print("|---|---|---|---|---|")
    for label, disturbances in cases.items():
        cells = []
        for damping in (STAND_DAMPING, 0.0):
            run = run_feet_steps_in_mujoco(gaits, disturbances=disturbances, laws=laws[damping])
            ended = "stood" if run.fell is None else run.fell.split(": ", 1)[-1][:70]
            cells += [f"{run.walked}/{len(gaits)}", ended]
        print(f"| {label} | " + " | ".join(cells) + " |")
    print()


def _damping_sweep(gait, stop) -> None:
    from problems.control.feet_law import FeetLaw
    from problems.control.mujoco_feet import run_feet_steps_in_mujoco
    from problems.control.simulation import Disturbances

    gaits = [gait] * 4 + [stop]
    pushes = [(push, step) for step in (0, 4) for push in (10.0, -10.0, 5.0, -5.0, 2.5, -2.5)]
    walk = FeetLaw(gait)
    print("Table 5: the same walk in MuJoCo over the standing damping: the pushes it stands "
          "(N s, in the first step / in the stop)")  # fmt: skip
    print()
    print("| damping, of critical | stood | pushes stood in step 0 | in the stop |")
    print("|---|---|---|---|")
    for damping in (0.0, 0.2, 0.35, 0.5, 0.7, 1.0):
        laws = [walk] * 4 + [FeetLaw(stop, stand_damping=damping)]
        stood = {
            (push, step): run_feet_steps_in_mujoco(
                gaits, disturbances=Disturbances(push=push, push_step=step), laws=laws
            ).fell is None
            for push, step in pushes
        }  # fmt: skip
        held = [", ".join(f"{push:+g}" for (push, k), ok in stood.items() if ok and k == step)
                for step in (0, 4)]  # fmt: skip
        print(f"| {damping:g} | {sum(stood.values())} of {len(pushes)} | {held[0] or '-'} | "
              f"{held[1] or '-'} |")  # fmt: skip
    print()


def main() -> int:
    warnings.simplefilter("ignore")  # the accuracy notes of the scratch solves
    _point_feet()
    _capture_points()
    _on_feet()
    gait = footed_step_at(0.6, speed_limit=10.0).solve(progress=False)
    (stop,) = plan_transition(gait, "standing").gaits
    _stop_in_mujoco(gait, stop)
    _damping_sweep(gait, stop)
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
