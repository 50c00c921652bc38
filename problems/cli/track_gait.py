"""'track-gait': the periodic walking step closest to a recorded gait, with its torques.

Plans the step on feet (or ``--point-feet``) at the recording's own step whose angles (and
ground force) follow the recording (:func:`problems.human.tracking.track_gait`), writes its
1 kHz torque file (torques.csv and its sidecar, verified at every sample before it is written)
and the comparison with the recording (comparison.md, .json, .png, stride.csv).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TextIO

from model import LinkageTrajectory
from planner.errors import DefinitionError
from problems.cli.common import (
    Reporter,
    UsageError,
    output_set,
    positive,
    print_verification,
    save_trajectory,
)
from problems.cli.compare_gait import write_comparison
from problems.gait.verification import verify_gait
from problems.human import read_recording
from problems.human.recording import ANGLES, FORCES
from problems.human.tracking import DEFAULT_EFFORT, DEFAULT_WEIGHTS, track_gait
from problems.human.winter import WINTER_BODY_MASS, stride_summary


def weights(text: str) -> dict[str, float]:
    """``thigh=1,knee=1,force_y=100`` -> {channel: weight}."""
    result = {}
    for item in text.split(","):
        name, equals, value = item.partition("=")
        name = name.strip()
        if not equals or name not in ANGLES + FORCES:
            raise argparse.ArgumentTypeError(
                f"give channel=weight pairs with channels among {', '.join(ANGLES + FORCES)}, "
                f"got {item!r}"
            )
        try:
            result[name] = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name}: {value!r} is not a number") from None
    return result


def _terms(terms) -> str:
    return ", ".join(f"{name} {value:.4g}" for name, value in terms.items())


def run(args, out: TextIO, report: Reporter) -> int:
    data = Path(args.data)
    if not data.is_file():
        raise UsageError(f"--data: no file {str(data)!r}")
    options = {} if args.data_body_mass_kg is None else {"body_mass": args.data_body_mass_kg}
    try:
        recording = read_recording(data, **options)
    except DefinitionError as error:
        raise UsageError(f"--data: {error}") from None
    output = output_set(args.output_dir, "track-gait")
    kind = "on point feet" if args.point_feet else "on feet"
    with report.working(f"tracking {recording.source} {kind}"):
        try:
            result = track_gait(recording, feet=not args.point_feet, weights=args.weights,
                                effort=args.effort, rate_hz=args.rate_hz,
                                solve_options={"progress": False})  # fmt: skip
        except DefinitionError as error:
            raise UsageError(str(error)) from None
    gait, comparison = result.gait, result.comparison
    print(f"tracked: {result.stride.source}: {stride_summary(result.stride)}", file=out)
    print(f"recording: {recording.source}: {stride_summary(recording)}", file=out)
    print(f"weights {dict(result.tracking.weights)}, effort {result.tracking.effort:g}; "
          f"cost terms {_terms(gait.solution.cost_terms)}", file=out)  # fmt: skip
    with output:
        profile = gait.to_trajectory(args.rate_hz)
        written = save_trajectory(profile, output.staging, "torques", ["csv"])
        with report.working("verifying torques.csv (numpy, independent of the planner)"):
            check = verify_gait(LinkageTrajectory.load(written[0]), gait.problem.linkage)
        print_verification(check, profile.n_samples, out)
        extra = {"weights": dict(result.tracking.weights), "effort": result.tracking.effort,
                 "cost_terms": dict(gait.solution.cost_terms)}  # fmt: skip
        table = write_comparison(output, comparison, "tracking", extra, args.no_plots, report)
        written = output.commit({"argv": list(sys.argv[1:])})
    print(table, file=out)
    for path in written:
        print(f"wrote {path}", file=out)
    return 0


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The 'track-gait' command's parser."""
    parser = commands.add_parser(
        "track-gait",
        parents=[common],
        help="the periodic step closest to a recorded gait, with its torques",
        description=(
            "Plan the periodic walking step (on feet, or --point-feet) whose joint angles and "
            "ground force follow a recorded gait (--data: Winter's appendix .xlsx or the CSV "
            "layout of problems.human.recording) at the recording's own step, every limit of "
            "the step kept, torques regularised: the dynamically consistent version of the "
            "recording. Writes torques.csv (verified at every sample) and the comparison "
            "(comparison.md, comparison.json, comparison.png, stride.csv)."
        ),
    )
    parser.add_argument("--data", required=True, metavar="PATH",
                        help="the recording: .xlsx (Winter's appendix) or .csv")  # fmt: skip
    parser.add_argument(
        "--data-body-mass-kg", type=positive("kg"), metavar="KG",
        help=f"the recorded subject's mass for a workbook, kg (default {WINTER_BODY_MASS:g})",
    )  # fmt: skip
    parser.add_argument("--point-feet", action="store_true", help="the point-foot step")
    default = ",".join(f"{k}={v:g}" for k, v in DEFAULT_WEIGHTS.items())
    parser.add_argument(
        "--weights", type=weights, metavar="C=W,...",
        help=f"weights of the tracked channels, 1/deg^2 for angles and 1/BW^2 for forces "
        f"(default {default}; the forces only if recorded, the ankle not on point feet)",
    )  # fmt: skip
    parser.add_argument(
        "--effort", type=positive(""), default=DEFAULT_EFFORT, metavar="W",
        help=f"weight of the drives' sum (M_i / M_max)^2 (default {DEFAULT_EFFORT:g})",
    )  # fmt: skip
    parser.add_argument("--rate-hz", type=positive("Hz", 1e5), default=1000.0, metavar="HZ",
                        help="samples per second of torques.csv (default 1000)")  # fmt: skip
    parser.add_argument("--output-dir", default="track", metavar="DIR",
                        help="folder for the files (default: track)")  # fmt: skip
    parser.add_argument("--no-plots", action="store_true", help="no comparison.png")
