"""'drives': what each drive of a walker must deliver over planned steps (problems.drives)."""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path
from typing import TextIO

from planner.errors import AnthropoidError, DefinitionError
from problems.cli.common import Reporter, UsageError, output_set


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The 'drives' command's parser."""
    parser = commands.add_parser(
        "drives",
        parents=[common],
        help="each drive's torque, speed, power and work over planned steps",
        description=(
            "Read planned steps (torques.csv or .npz as `walk` writes them, or a gait library "
            "library.npz: each of its gaits) and tell what each physical drive (right and left "
            "hip, knee and ankle, the neck) must deliver over the duty cycle they make: peak "
            "and RMS torque and speed, peak power given and absorbed, mean positive and "
            "negative power, work per step of each plan; write requirements.csv (one row per "
            "drive; the duty cycle in requirements.json) and requirements.png (each drive's "
            "torque over its speed) and print the tables."
        ),
    )
    parser.add_argument("plans", nargs="+", metavar="PLAN",
                        help="torques.csv / .npz of a planned step, or a library.npz")  # fmt: skip
    parser.add_argument("--shares", type=_shares, metavar="S,S,...",
                        help="each plan's share of the duty cycle's time, in the order given "
                        "(a library's gaits count one each), normalised to sum 1 (default: "
                        "equal)")  # fmt: skip
    parser.add_argument("--no-plots", action="store_true", help="no requirements.png")
    parser.add_argument("--output-dir", default="drives", metavar="DIR",
                        help="folder for the files (default: drives)")  # fmt: skip


def _shares(text: str) -> tuple[float, ...]:
    """An argparse type: a,b,c, numbers >= 0 (repeats allowed: two plans may share alike)."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected numbers a,b,c, got {text!r}") from None
    if any(not math.isfinite(v) or v < 0 for v in values):
        raise argparse.ArgumentTypeError(f"shares are fractions of time >= 0, got {text!r}")
    return values


def _plans(paths: list[str]) -> tuple[list, list[str]]:
    """The planned steps of ``paths`` (a library's gaits one by one) and their names."""
    from model import LinkageTrajectory
    from problems.library import GaitLibrary

    plans, names = [], []
    for text in paths:
        path = Path(text)
        if not path.is_file():
            raise UsageError(f"PLAN: no file {text!r}")
        library = None
        if path.suffix.lower() == ".npz":
            try:
                library = GaitLibrary.load(path)
            except DefinitionError:
                library = None  # a trajectory's .npz, below
        if library is not None:
            for gait in library.gaits:
                plans.append(library.at(gait.speed))
                names.append(f"{gait.speed:.3g} m/s")
            continue
        try:
            plans.append(LinkageTrajectory.load(path))
        except (DefinitionError, OSError, ValueError, KeyError) as error:
            raise UsageError(f"PLAN {text}: cannot read a planned step there ({error})") from None
        names.append(path.stem if len(paths) > 1 else path.name)
    return plans, names


def run(args, out: TextIO, report: Reporter) -> int:
    from problems.drives import drive_requirements
    from problems.drives.requirements import describe

    plans, names = _plans(args.plans)
    output = output_set(args.output_dir, "drives")
    with report.working(f"reading {len(plans)} planned step(s) as the drives see them"):
        try:
            requirements = drive_requirements(plans, shares=args.shares, names=names)
        except AnthropoidError as error:
            field = "--shares" if "`shares`" in str(error) else "PLAN"
            raise UsageError(f"{field}: {error}") from None
    shares = ", ".join(f"{p.name} {100 * p.share:.0f} %" for p in requirements.plans)
    print(f"duty cycle: {shares}", file=out)
    print(requirements.table(), file=out)
    print("\nwork per step, J (positive / negative):", file=out)
    print(requirements.work_table(), file=out)
    with output:
        rows = [r.row() for r in requirements.drives]
        with output.path("requirements.csv").open("w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        output.path("requirements.json").write_text(
            json.dumps(describe(requirements), indent=1) + "\n"
        )
        if not args.no_plots:
            from problems.drives import requirements_figure
            from problems.walking.plots import save_figure

            with report.working("plotting requirements.png"):
                save_figure(requirements_figure(requirements), output.path("requirements.png"))
        written = output.commit({"argv": list(sys.argv[1:])})
    for path in written:
        print(f"wrote {path}", file=out)
    return 0
