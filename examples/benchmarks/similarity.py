"""Walkers scaled in size and gravity against the unscaled one, and how long a step can be.

    python examples/benchmarks/similarity.py            # both tables
    python examples/benchmarks/similarity.py --quick    # the point-foot walkers only

Table 1 (``problems/gait/similarity.py``): the walking step and the step on feet of a walker
whose lengths are scaled by ``size`` (masses kept) under ``gravity`` times g, given its step in
its own units (0.5 leg lengths of the six-link's in 0.5 s x sqrt(size / gravity)) and drives
scaled as m g L (150 N m x size x gravity), the rest left to the defaults: the dimensionless
cost (cost / ((size gravity)^2 sqrt(size / gravity))) against the unscaled walker's, the IPOPT
iterations of the first solve and of the hold rounds, whether the plan verifies, seconds.

Table 2: the default walking step at step lengths near the legs' span (2 x 0.86 m): what
IPOPT says, the cost, and for 1.6 m the plan without the ground rows and the sole, verified
against the default settings (where its stance knee and its centre of pressure go).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings

import numpy as np

from model import Linkage, presets
from planner import AccuracyWarning, SampleLimitError, SolverError
from problems import footed_step, verify_gait, walking_step

STEPS = {
    "walking step": (presets.six_link_anthropoid, walking_step),
    "step on feet": (presets.anthropoid_with_feet, footed_step),
}
SCALES = ((1.0, 1.0), (1e-3, 1.0), (1e3, 1.0), (1.0, 1e-3), (1.0, 1e3))


def scaled(kind: str, size: float, gravity: float):
    """The step of the walker scaled by ``size`` under ``gravity`` g (see the module)."""
    preset, make = STEPS[kind]
    body = preset()
    links = body.in_units(length=size).links if size != 1.0 else body.links
    walker = Linkage(links, gravity=9.81 * gravity)
    tau = math.sqrt(size / gravity)
    return make(walker, 0.5 * size, 0.5 * tau, torque_limit=150.0 * size * gravity), tau


def similarity_table(kinds) -> None:
    print("Walkers scaled in size and gravity (defaults by dynamic similarity)")
    head = (
        f"{'step':<14} {'size':>6} {'g x':>6} {'dimensionless':>14} {'vs unscaled':>11} "
        f"{'iterations':<16} {'verified':>8} {'s':>6}"
    )
    print(head)
    print("-" * len(head))
    for kind in kinds:
        reference = None
        for size, gravity in SCALES:
            step, tau = scaled(kind, size, gravity)
            start = time.perf_counter()
            gait = step.solve(progress=False)
            seconds = time.perf_counter() - start
            cost = gait.cost / ((size * gravity) ** 2 * tau)
            reference = cost if reference is None else reference
            rounds = gait.solution.stats["sampled_limits"]["rounds"]
            iterations = "+".join(str(r["iterations"]) for r in rounds)
            print(
                f"{kind:<14} {size:6g} {gravity:6g} {cost:14.6f} {cost / reference - 1:11.1e} "
                f"{iterations:<16} {gait.verified!s:>8} {seconds:6.2f}"
            )


def reach_table() -> None:
    print("\nHow long a step can be: the default walking step (0.86 m legs, span 1.72 m)")
    head = f"{'step':<44} {'outcome':<28} {'cost':>9}"
    print(head)
    print("-" * len(head))
    for length, duration in ((1.4, 0.5), (1.5, 0.5), (1.6, 0.5), (1.6, 1.0)):
        label = f"{length:g} m in {duration:g} s ({length / 1.72:.0%} of the span)"
        try:
            gait = walking_step(step_length=length, step_time=duration).solve(progress=False)
            outcome, cost = f"solved, verified {gait.verified}", f"{gait.cost:9.1f}"
        except SolverError as error:
            landing = dict(error.violations).get("end[landing][0]", math.nan)
            outcome, cost = f"{error.status} ({1000 * landing:.1f} mm short)", ""
        except SampleLimitError:
            outcome, cost = "limits not held at the samples", ""
        print(f"{label:<44} {outcome:<28} {cost:>9}")
    relaxed = walking_step(step_length=1.6, ground_points=(), foot=None)
    gait = relaxed.solve(progress=False, verify=False)
    settings = walking_step(step_length=1.6).settings()
    report = verify_gait(
        gait.to_trajectory(1000.0),
        relaxed.linkage,
        settings={key: settings[key] for key in ("foot", "ground_points", "ground_margin")},
    )
    print(
        f"1.6 m in 0.5 s without the ground rows and the sole: cost {gait.cost:.1f}, verified "
        f"{gait.verify().ok} on its own settings; on the default ones: ground "
        f"{report['ground'].margin:+.3f} m at {report['ground'].where}, centre of pressure "
        f"{report['centre of pressure'].margin:+.1f} N m"
    )
    trajectory = gait.to_trajectory(1000.0)
    force = trajectory.ground_reaction
    loaded = force.imag > 0
    pressure = trajectory.torques[loaded, 0] / force.imag[loaded]
    print(f"  its centre of pressure from {np.min(pressure):.1f} to {np.max(pressure):.2f} m "
          "from the ankle (the sole: -0.05 .. 0.15 m)")  # fmt: skip


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="point-foot walkers only")
    args = parser.parse_args(argv)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        similarity_table(["walking step"] if args.quick else list(STEPS))
        if not args.quick:
            reach_table()
    return 0


if __name__ == "__main__":
    import _tables  # beside this script, whose folder a script's run puts on sys.path

    sys.exit(_tables.run(main, __file__))
