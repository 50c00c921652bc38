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
from problems.cli.common import CommandFailed, Reporter, UsageError, output_set


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
            "torque over its speed) and print the tables. With --motors and --gearboxes "
            "(catalogue CSVs), choose each drive's motor and gearbox (selection.csv)."
        ),
    )
    parser.add_argument("plans", nargs="+", metavar="PLAN",
                        help="torques.csv / .npz of a planned step, or a library.npz")  # fmt: skip
    parser.add_argument("--shares", type=_shares, metavar="S,S,...",
                        help="each plan's share of the duty cycle's time, in the order given "
                        "(a library's gaits count one each), normalised to sum 1 (default: "
                        "equal)")  # fmt: skip
    parser.add_argument("--motors", metavar="CSV",
                        help="a motor catalogue (layout: problems.drives.catalogue); with "
                        "--gearboxes, each drive's lightest (--rank) motor and gearbox that "
                        "meet its duty, every limit's margin, in selection.csv")  # fmt: skip
    parser.add_argument("--gearboxes", metavar="CSV", help="a gearbox catalogue (with --motors)")
    parser.add_argument("--rank", choices=("mass", "energy"), default="mass",
                        help="order of the drives that fit: mass (motor and gearbox) or the "
                        "electrical energy per step (default: mass)")  # fmt: skip
    parser.add_argument(
        "--no-regeneration",
        action="store_true",
        help="braking energy is dissipated, not recovered (--rank energy)",
    )
    parser.add_argument("--replan", action="store_true",
                        help="with --motors and --gearboxes and one walking step (point feet "
                        "without a double support, or feet): plan it again carrying the chosen "
                        "drives (their masses, rotors and limits; on point feet the least "
                        "electrical energy drawn, or net without --no-regeneration; on feet "
                        "the step's own objective), "
                        "write replanned.csv (verified; its sidecar names the drives) and "
                        "replanned.png (both plans over the drives' limits) and print both "
                        "plans through the drives: energy per step and each limit's worst "
                        "margin")  # fmt: skip
    parser.add_argument("--springs", type=_spring_joints, default=(), metavar="JOINT[,JOINT]",
                        help="with --replan: a parallel spring beside each of these joints' "
                        "drives (hip, knee, ankle; both legs), its stiffness and rest angle "
                        "designed with the re-plan (static parameters of its NLP, for the "
                        "electrical energy; written to the sidecar)")  # fmt: skip
    parser.add_argument("--no-plots", action="store_true", help="no requirements.png")
    parser.add_argument("--output-dir", default="drives", metavar="DIR",
                        help="folder for the files (default: drives)")  # fmt: skip


def _spring_joints(text: str) -> tuple[str, ...]:
    from problems.drives.springs import SPRING_JOINTS

    joints = tuple(j.strip() for j in text.split(",") if j.strip())
    unknown = [j for j in joints if j not in SPRING_JOINTS]
    if not joints or unknown or len(set(joints)) != len(joints):
        raise argparse.ArgumentTypeError(
            f"give distinct joints among {', '.join(SPRING_JOINTS)}, comma-separated; got {text!r}"
        )
    return joints


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


def _catalogue(args):
    """(motors, gearboxes) of --motors and --gearboxes, or None without them."""
    from problems.drives.catalogue import read_gearboxes, read_motors

    if (args.motors is None) != (args.gearboxes is None):
        raise UsageError("--motors and --gearboxes: give both catalogues (or neither)")
    if args.motors is None:
        return None
    try:
        motors = read_motors(args.motors)
    except DefinitionError as error:
        raise UsageError(f"--motors: {error}") from None
    try:
        gearboxes = read_gearboxes(args.gearboxes)
    except DefinitionError as error:
        raise UsageError(f"--gearboxes: {error}") from None
    return motors, gearboxes


def _selected(requirements, catalogue, args, out):
    """The catalogue's drives for each joint, printed; None without a catalogue. A joint no
    drive fits fails the run (nothing written), naming the limit its closest drive misses."""
    if catalogue is None:
        return None
    from problems.drives.selection import select

    selection = select(requirements, *catalogue, rank=args.rank,
                       regenerate=not args.no_regeneration)  # fmt: skip
    print(f"\nchosen from the catalogues (by {args.rank}; margins: 1 - need / capacity):",
          file=out)  # fmt: skip
    print(selection.table(), file=out)
    refused = selection.refused
    if refused:
        raise CommandFailed("; ".join(refused.values()) + "; nothing written")
    return selection


def _write_selection(selection, path) -> None:
    """selection.csv: per joint the chosen drive, its mass and energy per step, and each
    limit's need, capacity and margin."""
    rows = []
    for drive in selection.ranked:
        best = selection.best(drive)
        row = {"drive": drive, "motor": best.drive.motor.name,
               "gearbox": best.drive.gearbox.name, "mass_kg": best.drive.mass,
               "energy_per_step_J": best.energy_per_step,
               "candidates_that_fit": len(selection.ranked[drive])}  # fmt: skip
        for check in best.checks:
            key = check.limit.replace(" ", "_")
            unit = check.unit.replace(" ", "_").replace("/", "_")
            row[f"{key}_need_{unit}"] = check.need
            row[f"{key}_capacity_{unit}"] = check.capacity
            row[f"{key}_margin"] = check.margin
        rows.append(row)
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def _replanned(plans, selection, args, out, report):
    """--replan: (the one plan re-planned with the chosen drives in the loop, its sidecar
    naming them; the walker carrying them), both plans compared through them (printed); None
    without --replan."""
    if not args.replan:
        if args.springs:
            raise UsageError("--springs: springs are designed with a re-plan; add --replan")
        return None
    if selection is None or len(plans) != 1:
        raise UsageError("--replan: give one PLAN (a walking step) with --motors and --gearboxes")
    from problems.drives.loop import MOUNTS
    from problems.drives.replan import compare, comparison_table, replan
    from problems.drives.springs import ParallelSpring, designed, spring_values

    chosen = {}
    for joint in ("hip", "knee", "ankle", "neck"):
        name = joint if joint == "neck" else f"right_{joint}"
        if name in selection.ranked:
            chosen[joint] = selection.best(name).drive
    regeneration = not args.no_regeneration
    springs = tuple(ParallelSpring(joint) for joint in args.springs)
    with report.working("re-planning the step with the chosen drives in the loop"):
        try:
            gait, walker = replan(plans[0], chosen, regeneration=regeneration,
                                  drives_objective="electrical" if springs else None,
                                  springs=springs)  # fmt: skip
        except DefinitionError as error:
            field = "--springs" if "`springs`" in str(error) else "PLAN"
            raise UsageError(f"{field}: {error}") from None
        except AnthropoidError as error:
            raise CommandFailed(
                f"the re-plan with the chosen drives: {error}; nothing written"
            ) from None
    values = spring_values(gait.solution, springs)
    if values:
        print(f"\nparallel springs designed with the re-plan (both legs): {designed(values)}",
              file=out)  # fmt: skip
    given = compare(plans[0], walker, with_rotors=False)
    again = compare(gait.exported(), walker, with_rotors=True, springs=values)
    print("\nthe plan through the chosen drives, as given and re-planned with them (worst "
          "margins: < 0 the drive cannot deliver it):", file=out)  # fmt: skip
    print(comparison_table(given, again), file=out)
    # the file says what it was planned with: each joint's motor and gearbox
    carried = {joint: {"motor": d.motor.name, "gearbox": d.gearbox.name,
                       "ratio": d.gearbox.ratio, "mass_kg": d.mass,
                       "inertia_kg_m2": d.inertia} for joint, d in chosen.items()}  # fmt: skip
    # the hinge torques are the whole torque; a spring's share is the spring's, not the drive's
    springs_kept = {joint: {"stiffness_N_m_per_rad": k, "rest_rad": rest,
                            "torque": "-k (q - rest), q the robot's joint angle"}
                    for joint, (k, rest) in values.items()}  # fmt: skip
    drives = {"joints": carried, "regeneration": regeneration, "mounts": dict(MOUNTS),
              "springs": springs_kept}  # fmt: skip
    written = gait.exported().with_metadata(drives=drives)
    return written, walker, values


def _as_given_and_replanned(given, replanned, walker, springs):
    """The two plans as one duty cycle (each half the time) for the torque-speed picture,
    each drive's gear output (the re-plan without its rotors' own share and its springs')."""
    from problems.drives import DriveRequirements
    from problems.drives.replan import output_plan

    plans = [output_plan(given, walker, "as given", 0.5, False),
             output_plan(replanned, walker, "re-planned", 0.5, True, springs)]  # fmt: skip
    return DriveRequirements.of(plans)


def run(args, out: TextIO, report: Reporter) -> int:
    from problems.drives import drive_requirements
    from problems.drives.requirements import describe

    plans, names = _plans(args.plans)
    catalogue = _catalogue(args)
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
    print("\nwhere the peaks are:", file=out)
    print(requirements.peaks_table(), file=out)
    print("\nwork per step, J (positive / negative):", file=out)
    print(requirements.work_table(), file=out)
    selection = _selected(requirements, catalogue, args, out)
    replanned = _replanned(plans, selection, args, out, report)
    with output:
        rows = [r.row() for r in requirements.drives]
        with output.path("requirements.csv").open("w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        output.path("requirements.json").write_text(
            json.dumps(describe(requirements), indent=1) + "\n"
        )
        if replanned is not None:
            replanned[0].save(output.path("replanned.csv"))
        chosen = None
        if selection is not None:
            _write_selection(selection, output.path("selection.csv"))
            chosen = {d: selection.best(d).drive for d in selection.ranked}
        if not args.no_plots:
            from problems.drives import requirements_figure
            from problems.walking.plots import save_figure

            with report.working("plotting requirements.png"):
                figure = requirements_figure(requirements, chosen=chosen)
                save_figure(figure, output.path("requirements.png"))
            if replanned is not None:
                with report.working("plotting replanned.png"):
                    both = _as_given_and_replanned(plans[0], *replanned)
                    figure = requirements_figure(both, chosen=chosen)
                    save_figure(figure, output.path("replanned.png"))
        written = output.commit({"argv": list(sys.argv[1:])})
    for path in written:
        print(f"wrote {path}", file=out)
    return 0
