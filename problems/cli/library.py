"""'library': a gait library over speed (problems.library), written as one .npz."""

from __future__ import annotations

import argparse
import sys
import warnings
from typing import TextIO

import numpy as np

from planner.accuracy_check import AccuracyWarning
from problems.cli.common import Reporter, UsageError, output_set, positive
from problems.cli.study import value_list
from problems.library import GaitLibrary, build_library


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The 'library' command's parser."""
    parser = commands.add_parser(
        "library",
        parents=[common],
        help="periodic steps over speed (point feet or feet) with their feedback, in one file",
        description=(
            "Plan a periodic walking step on point feet (or with --feet on feet: flat foot, "
            "heel rise, double support) at each speed (step length 0.5 (v / 1 m/s)^(1/2) m, "
            "time length / v), from the middle of the grid outward, each warm-started from its "
            "neighbour, verify each at every exported sample, design its feedback (point feet: "
            "the periodic LQR and its closed loop's Floquet multipliers; feet: the joint PD "
            "they walk with in MuJoCo); write them to library.npz "
            "(problems.library.GaitLibrary: numpy alone reads it) and print the table."
        ),
    )
    parser.add_argument("--speeds-mps", type=value_list("m/s", upper=3.0), required=True,
                        metavar="V", help="the speeds, m/s: a,b,c or start:stop:count")  # fmt: skip
    parser.add_argument("--feet", action="store_true",
                        help="steps on feet (the six-link scene on Winter's feet, "
                        "problems.footed_step; about 3 s a gait)")  # fmt: skip
    parser.add_argument("--joint-speed-limit", type=positive("rad/s", 1e3), default=None,
                        metavar="W", help="bound every driven joint's speed at W rad/s in every "
                        "gait (default: none; a walk on feet from the library wants 10: "
                        "unbounded, its gaits at 1.2 m/s and faster fall in MuJoCo)")  # fmt: skip
    parser.add_argument("--no-multipliers", action="store_true",
                        help="skip the Floquet multipliers (the closed loop's fixed point: "
                        "about as long as the gait's solve; on feet |lambda_1| alone, from a "
                        "push's decay in the product's simulation: about 17 s a gait)")  # fmt: skip
    parser.add_argument("--compiled", action="store_true",
                        help="compile the NLP's functions and the simulation's period "
                        "Jacobians to native code with the system's C compiler first where "
                        "the disk cache does not hold them (a minute or two the first time, "
                        "once per structure and linkage); without it what the cache holds is "
                        "used")  # fmt: skip
    parser.add_argument("--output-dir", default="library", metavar="DIR",
                        help="folder for library.npz (default: library)")  # fmt: skip


def run(args, out: TextIO, report: Reporter) -> int:
    speeds = sorted(args.speeds_mps)
    if len(speeds) < 2:
        raise UsageError("--speeds-mps: two or more speeds (a library blends neighbours)")
    output = output_set(args.output_dir, "library")
    with report.working(f"planning {len(speeds)} steps from {speeds[0]:g} to {speeds[-1]:g} m/s"):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", AccuracyWarning)
            bound = {} if args.joint_speed_limit is None else {
                "speed_limit": args.joint_speed_limit}  # fmt: skip
            library = build_library(speeds, feet=args.feet,
                                    multipliers=not args.no_multipliers,
                                    progress=report.step,
                                    compiled=True if args.compiled else None,
                                    **bound)  # fmt: skip
    for warning in caught:  # one line each, not Python's two with a source line
        report.warn(f"a gait of the library: {warning.message}")
    # on feet: the phases, then |lambda_1| alone (from a push's decay; problems.library.build)
    last = "contact phases s | abs lambda_1" if args.feet else "largest abs multiplier"
    print(f"| speed m/s | step m in s | IPOPT iterations | peak abs M N m | {last} |", file=out)
    print("|---|---|---|---|---|" + ("---|" if args.feet else ""), file=out)
    for gait in library.gaits:
        largest = np.max(np.abs(gait.multipliers)) if not args.feet else abs(gait.multipliers[0])
        said = "-" if np.isnan(largest) else f"{largest:.3f}"
        if args.feet:
            phases = ", ".join(f"{name} {duration:.3f}" for name, duration in gait.segments)
            said = f"{phases} | {said}"
        # the drives' torques: on feet the root's is the ground's torque on the stance foot
        drives = gait.torques[:, 1:] if args.feet else gait.torques
        print(
            f"| {gait.speed:.3f} | {gait.step_length:.3f} in {gait.step_time:.3f} | "
            f"{gait.iterations} | {np.max(np.abs(drives)):.1f} | {said} |",
            file=out,
        )
    with output:
        path = library.save(output.path("library.npz"))
        back = GaitLibrary.load(path)  # read back: the file a controller loads
        if not np.array_equal(back.speeds, library.speeds):
            raise UsageError(f"{path}: read back with other speeds")  # pragma: no cover
        paths = output.commit({"argv": list(sys.argv[1:])})
    for written in paths:
        print(f"wrote {written}", file=out)
    return 0
