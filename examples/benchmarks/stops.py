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


def main() -> int:
    warnings.simplefilter("ignore")  # the accuracy notes of the scratch solves
    _point_feet()
    _capture_points()
    _on_feet()
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
