"""'compare-gait': a planned walking step against recorded human walking.

Reads the plan's exported step (torques.csv or .json with its sidecar, as ``walk`` writes
it), builds its stance leg's stride (:func:`problems.human.step_stride`), reads the recording
(Winter's appendix workbook or the plain CSV layout of :mod:`problems.human.recording`),
prints the comparison table and writes comparison.md, comparison.json, comparison.png and
the model's stride as stride.csv (the recording's layout) into --output-dir.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TextIO

from model import LinkageTrajectory
from planner.errors import DefinitionError
from problems.cli.common import Reporter, UsageError, output_set, positive
from problems.human import compare_gait, read_recording, step_stride, write_csv
from problems.human.winter import WINTER_BODY_MASS, stride_summary


def run(args, out: TextIO, report: Reporter) -> int:
    plan, data = Path(args.plan), Path(args.data)
    for option, path in (("PLAN", plan), ("--data", data)):
        if not path.is_file():
            raise UsageError(f"{option}: no file {str(path)!r}")
    options = {} if args.data_body_mass_kg is None else {"body_mass": args.data_body_mass_kg}
    if options and data.suffix.lower() != ".xlsx":
        raise UsageError(
            "--data-body-mass-kg: only for a workbook (.xlsx); a CSV recording "
            "is already in N m/kg and body weights"
        )
    output = output_set(args.output_dir, "compare-gait")
    try:
        trajectory = LinkageTrajectory.load(plan)
        model = step_stride(trajectory, body_mass=args.body_mass_kg)
    except DefinitionError as error:
        raise UsageError(f"PLAN: {error}") from None
    try:
        recording = read_recording(data, **options)
    except DefinitionError as error:
        raise UsageError(f"--data: {error}") from None
    comparison = compare_gait(model, recording)
    with output:
        table = write_comparison(output, comparison, "against", {}, args.no_plots, report)
        written = output.commit({"argv": list(sys.argv[1:])})
    print(f"model: {model.source}: {stride_summary(model)}", file=out)
    print(f"human: {recording.source}: {stride_summary(recording)}", file=out)
    print(table, file=out)
    for path in written:
        print(f"wrote {path}", file=out)
    return 0


def write_comparison(output, comparison, verb: str, extra: dict, no_plots: bool, report) -> str:
    """Stage comparison.md (a heading: the model's stride ``verb`` the recording's, then the
    table), comparison.json (the numbers and ``extra``), stride.csv (the model's stride) and,
    unless ``no_plots``, comparison.png into ``output``; returns the table."""
    model, recording = comparison.model, comparison.data
    table = comparison.table()
    output.path("comparison.md").write_text(
        f"# {model.source}: {stride_summary(model)}\n\n{verb} {recording.source}: "
        f"{stride_summary(recording)}\n\n{table}\n"
    )
    output.path("comparison.json").write_text(
        json.dumps({**comparison.as_dict(), **extra}, indent=1, allow_nan=True) + "\n"
    )
    write_csv(model, output.path("stride.csv"))
    if not no_plots:
        from problems.human.plots import comparison_figure
        from problems.walking.plots import save_figure

        with report.working("plotting comparison.png"):
            save_figure(comparison_figure(comparison), output.path("comparison.png"))
    return table


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The 'compare-gait' command's parser."""
    parser = commands.add_parser(
        "compare-gait",
        parents=[common],
        help="a planned walking step against recorded human walking: table and picture",
        description=(
            "Compare a planned walking step (PLAN: the torques.csv or torques.json that "
            "'walk' wrote, its sidecar beside it) with recorded human walking (--data: "
            "Winter's appendix workbook .xlsx, or a CSV file in the layout of "
            "problems.human.recording) in the biomechanist's conventions: one leg's stride "
            "from heel strike, hip, knee and ankle flexion (deg, 0 standing), internal "
            "moments extensor positive (N m/kg), ground force in body weights. Prints RMS "
            "differences, correlations, ranges and peaks; writes comparison.md, "
            "comparison.json, comparison.png and the model's stride as stride.csv."
        ),
    )
    parser.add_argument("plan", metavar="PLAN", help="the plan's torques.csv or torques.json")
    parser.add_argument(
        "--data",
        required=True,
        metavar="PATH",
        help="the recording: .xlsx (Winter's appendix) or .csv",
    )
    parser.add_argument(
        "--data-body-mass-kg",
        type=positive("kg"),
        metavar="KG",
        help=f"the recorded subject's mass, kg, for a workbook's N and N m (default: Winter's "
        f"{WINTER_BODY_MASS:g})",
    )
    parser.add_argument(
        "--body-mass-kg",
        type=positive("kg"),
        metavar="KG",
        help="the model's mass, kg (default: the sum of its links in the plan's sidecar)",
    )
    parser.add_argument(
        "--output-dir",
        default="compare",
        metavar="DIR",
        help="folder for the files (default: compare)",
    )
    parser.add_argument("--no-plots", action="store_true", help="no comparison.png")
