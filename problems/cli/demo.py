"""'demo': the six-link equations of motion and the gait-law torque table."""

from __future__ import annotations

import argparse
from typing import TextIO

import numpy as np

from model import Dynamics
from model.presets import six_link_anthropoid
from problems.cli.common import LIMIT_SAMPLES, MAX_SAMPLES, Reporter, check_samples, torque_table
from problems.cli.equations import equations_text
from problems.cli.study import positive_count
from problems.dynamics_problems import (
    torques_along,
)
from problems.gait.law import GaitLaw


def run(args, out: TextIO, report: Reporter) -> int:
    linkage = six_link_anthropoid()
    dynamics = Dynamics(linkage)
    if not args.no_equations:
        text = equations_text(linkage, latex=False)  # before printing: a failure prints nothing
        print("Equations of motion of the six-link anthropoid (corrected (16)-(21)):", file=out)
        print(text, file=out)
        print(file=out)
    check_samples(args.rows, args.force, f"--rows {args.rows}", "give fewer --rows", "a table")
    law = GaitLaw.preset("paper22")
    table = torques_along(dynamics, law, np.linspace(0.0, law.period, args.rows))
    fine = torques_along(dynamics, law, np.linspace(0.0, law.period, 1001))
    print("First problem of dynamics along the gait law (22):", file=out)
    print(str(law), file=out)
    print(
        "links: " + ", ".join(f"{i + 1} {name}" for i, name in enumerate(linkage.names)),
        file=out,
    )
    print("hinge torques M_i (N m), inverse dynamics:", file=out)
    torque_table(table, linkage.names, out)
    peak = np.max(np.abs(np.asarray(fine.torques)), axis=0)
    print(
        f"{'max|M|':>7}" + "".join(f"{v:10.2f}" for v in peak) + "   (over 1001 times in [0, T])",
        file=out,
    )
    return 0


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The 'demo' command's parser."""
    demo = commands.add_parser(
        "demo",
        parents=[common, limits],
        help="six-link equations of motion and the gait-law torque table",
        description=(
            "Print the six-link equations of motion (corrected (16)-(21)) and the hinge "
            "torques M_1..M_6 (N m) along the paper's gait law (22) ('paper22' of scene.md) "
            "at evenly spaced times over one period, with max |M_i| over the period."
        ),
    )
    demo.add_argument(
        "--rows",
        type=positive_count,
        default=11,
        help=f"number of times in the table, at most {LIMIT_SAMPLES:,} (--force: "
        f"{MAX_SAMPLES:,}) (default: 11)",
    )
    demo.add_argument("--no-equations", action="store_true", help="print the torque table only")
