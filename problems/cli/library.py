"""'library': a gait library over speed (problems.library), written as one .npz."""

from __future__ import annotations

import argparse
import sys
from typing import TextIO

import numpy as np

from problems.cli.common import Reporter, UsageError, output_set
from problems.cli.study import value_list
from problems.library import GaitLibrary, build_library


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The 'library' command's parser."""
    parser = commands.add_parser(
        "library",
        parents=[common],
        help="periodic point-foot steps over speed with their feedback, in one file",
        description=(
            "Plan a periodic walking step on point feet at each speed (step length 0.5 "
            "(v / 1 m/s)^(1/2) m, time length / v), from the middle of the grid outward, each "
            "warm-started from its neighbour, verify each at every exported sample, design its "
            "periodic LQR and compute its closed loop's Floquet multipliers; write them to "
            "library.npz (problems.library.GaitLibrary: numpy alone reads it) and print the "
            "table."
        ),
    )
    parser.add_argument("--speeds-mps", type=value_list("m/s", upper=3.0), required=True,
                        metavar="V", help="the speeds, m/s: a,b,c or start:stop:count")  # fmt: skip
    parser.add_argument("--no-multipliers", action="store_true",
                        help="skip the Floquet multipliers (0.9 s a gait of fixed-point "
                        "search)")  # fmt: skip
    parser.add_argument("--output-dir", default="library", metavar="DIR",
                        help="folder for library.npz (default: library)")  # fmt: skip


def run(args, out: TextIO, report: Reporter) -> int:
    speeds = sorted(args.speeds_mps)
    if len(speeds) < 2:
        raise UsageError("--speeds-mps: two or more speeds (a library blends neighbours)")
    output = output_set(args.output_dir, "library")
    with report.working(f"planning {len(speeds)} steps from {speeds[0]:g} to {speeds[-1]:g} m/s"):
        library = build_library(speeds, multipliers=not args.no_multipliers,
                                progress=report.step)  # fmt: skip
    print("| speed m/s | step m in s | IPOPT iterations | peak abs M N m | largest abs "
          "multiplier |", file=out)  # fmt: skip
    print("|---|---|---|---|---|", file=out)
    for gait in library.gaits:
        largest = np.max(np.abs(gait.multipliers))
        print(f"| {gait.speed:.3f} | {gait.step_length:.3f} in {gait.step_time:.3f} | "
              f"{gait.iterations} | {np.max(np.abs(gait.torques)):.1f} | "
              f"{'-' if np.isnan(largest) else f'{largest:.3f}'} |", file=out)  # fmt: skip
    with output:
        path = library.save(output.path("library.npz"))
        back = GaitLibrary.load(path)  # read back: the file a controller loads
        if not np.array_equal(back.speeds, library.speeds):
            raise UsageError(f"{path}: read back with other speeds")  # pragma: no cover
        paths = output.commit({"argv": list(sys.argv[1:])})
    for written in paths:
        print(f"wrote {written}", file=out)
    return 0
