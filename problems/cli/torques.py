"""'torques': the first problem of dynamics, torques along a gait law, to files and plots."""

from __future__ import annotations

import argparse
import math
import sys
from typing import TextIO

import numpy as np

from model import Dynamics
from problems.cli.common import (
    LAWS,
    LIMIT_SAMPLES,
    MAX_RATE_HZ,
    PRESET_HELP,
    Reporter,
    UsageError,
    angles,
    check_samples,
    gait_law_of,
    output_options,
    output_set,
    positive,
    preset_linkage,
    save_trajectory,
    write_plots,
)
from problems.dynamics_problems import (
    torques_along,
)


def run(args, out: TextIO, report: Reporter) -> int:
    linkage = preset_linkage(args.preset)
    law = gait_law_of(args, linkage)
    dynamics = Dynamics(linkage)
    duration = law.period if args.duration_s is None else args.duration_s
    count = max(2, math.ceil(duration * args.rate_hz - 1e-9) + 1)
    check_samples(
        count,
        args.force,
        f"--rate-hz {args.rate_hz:g} Hz x --duration-s {duration:g} s",
        "lower --rate-hz or --duration-s",
        f"files of about {count * len(args.formats) * 530 / 1e6:,.0f} MB",
    )
    if law.n != linkage.n:
        raise UsageError(
            f"gait law {law.name!r} drives {law.n} links but preset {args.preset!r} has "
            f"{linkage.n}; give --zeta-rad, --varpi-rad and --center-rad with {linkage.n} values"
        )
    output = output_set(args.output_dir, "torques")
    with output:
        with report.working(f"torques along {law.name!r}: {count} samples over {duration:g} s"):
            trajectory = torques_along(dynamics, law, np.linspace(0.0, duration, count))
            save_trajectory(trajectory, output.staging, "torques", args.formats)
        if not args.no_plots:
            write_plots(dynamics, trajectory, output.staging, "torques", True, args.gif, report)
        written = output.commit({"argv": list(sys.argv[1:])})
    print(str(law), file=out)
    peak = np.max(np.abs(np.asarray(trajectory.torques)), axis=0)
    print(
        "max |M_i| (N m): " + ", ".join(f"M_{i + 1} {v:.2f}" for i, v in enumerate(peak)), file=out
    )
    for path in written:
        print(f"wrote {path}", file=out)
    return 0


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The 'torques' command's parser."""
    torques = commands.add_parser(
        "torques",
        parents=[common, limits],
        help="first problem: torques along a gait law, to files and plots",
        description=(
            "First problem of dynamics: the hinge torques M_i (N m) that make the linkage "
            "follow the gait law psi_j(t) = center_j + zeta_j sin(varpi_j - (1 - cos(2 pi t/T)) "
            "pi/2), by inverse dynamics, with the ground reaction Fx, Fy (N) at H0. Writes "
            "torques.<format> and, unless --no-plots, torques.png and stick_figure.png."
        ),
    )
    torques.add_argument(
        "--law",
        default="paper22",
        metavar="NAME",
        help=f"gait-law preset for six links, one of: {', '.join(LAWS)} (default: paper22; "
        "walking = swing leg about -pi/2)",
    )
    torques.add_argument("--preset", default="six-link", metavar="NAME", help=PRESET_HELP)
    torques.add_argument(
        "--period-s",
        type=positive("s"),
        metavar="T",
        help="walking period T, s (default: the law's, 1 s)",
    )
    torques.add_argument(
        "--zeta-rad", type=angles, metavar="Z1,Z2,...", help="amplitudes zeta_j, rad, one per link"
    )
    torques.add_argument(
        "--varpi-rad", type=angles, metavar="W1,W2,...", help="phases varpi_j, rad, one per link"
    )
    torques.add_argument(
        "--center-rad",
        type=angles,
        metavar="C1,C2,...",
        help="centre angles, rad, one per link (paper: pi/2 = 1.5708 for all); write "
        "--center-rad=-1.57,... when the first value is negative",
    )
    torques.add_argument(
        "--duration-s",
        type=positive("s"),
        metavar="S",
        help="length of the profile from t = 0, s (default: one period)",
    )
    torques.add_argument(
        "--rate-hz",
        type=positive("Hz", MAX_RATE_HZ),
        default=1000.0,
        metavar="HZ",
        help=f"samples per second in the files, Hz, at most 1e6 and {LIMIT_SAMPLES:,} samples "
        "(--force: 2,000,000) (default: 1000; the samples are exact, a simulation "
        "interpolates between them)",
    )
    output_options(torques, "torques_out", ("csv", "json"))
    torques.add_argument(
        "--gif", action="store_true", help="also write an animation, animation.gif (slow)"
    )
