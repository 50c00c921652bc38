"""'simulate': the second problem of dynamics, the motion under the torques of a file."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TextIO

import numpy as np

from model import Dynamics, LinkageTrajectory
from planner.errors import DefinitionError, DefinitionTypeError
from planner.trajectory import FORMATS as TRAJECTORY_FORMATS
from planner.trajectory import TrajectoryFileError
from planner.units import si_unit
from problems.cli.common import (
    LIMIT_SAMPLES,
    LIMIT_SECONDS,
    MAX_RATE_HZ,
    PRESET_HELP,
    SECONDS_PER_ELEMENT,
    CommandFailed,
    Reporter,
    UsageError,
    check_samples,
    in_option_words,
    one_of,
    output_options,
    output_set,
    positive,
    preset_linkage,
    save_trajectory,
    tolerance,
    write_plots,
)
from problems.cli.study import positive_count
from problems.dynamics_problems import (
    FIT_WINDOW,
    METHODS,
    SimulationError,
    fit_growth_rate,
    linkage_profile,
    simulate,
)


def _load_profile(path_text: str):
    path = Path(path_text)
    if not path.exists():
        raise UsageError(f"torque file {path_text!r} does not exist")
    if path.is_dir():
        raise UsageError(f"torque file {path_text!r} is a folder, not a file")
    if path.suffix.lower() not in TRAJECTORY_FORMATS:
        raise UsageError(
            f"torque file {path_text!r}: unknown format {path.suffix!r}; use "
            f"{one_of(TRAJECTORY_FORMATS)}"
        )
    try:
        profile = LinkageTrajectory.load(path)
    except TrajectoryFileError as exc:  # the loader's one error for a malformed file
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        detail = detail.removeprefix(f"{path}: ")  # the message names the file already
        raise UsageError(f"torque file {path_text!r} is malformed: {detail}") from exc
    except OSError as exc:
        raise UsageError(f"torque file {path_text!r} cannot be read: {exc.strerror}") from exc
    return profile


def _linkage_profile(profile, path_text: str, preset: str, names: tuple[str, ...]):
    """The file's profile for the preset's links in SI units (problems.linkage_profile), or
    a UsageError naming the file, the column and its unit, or the missing column."""
    links = list(
        dict.fromkeys(
            name.split("_", 1)[1]
            for name, _, _ in profile.columns
            if name.startswith(("psi_", "dpsi_", "M_"))
        )
    )
    if not links:
        raise UsageError(
            f"torque file {path_text!r} has no linkage columns (psi_<link> [rad], "
            f"dpsi_<link> [rad/s], M_<link> [N m]); its columns are "
            f"{[name for name, _, _ in profile.columns]}"
        )
    if set(links) - set(names):
        raise UsageError(
            f"torque file {path_text!r} is for links {links}, but preset {preset!r} has "
            f"{list(names)}; pass the matching --preset"
        )
    try:
        return linkage_profile(profile, names)
    except (DefinitionError, DefinitionTypeError) as exc:
        message = str(exc).removeprefix("`torques`: ")
        raise UsageError(f"torque file {path_text!r}: {message}") from exc


def _node_samples_warning(profile, path_text: str, interpolation: str) -> str | None:
    """The warning for a planner solution saved at its nodes only (or coarser), else None.

    ``planner.Solution.to_trajectory()`` without ``rate_hz`` samples the N + 1 nodes and
    keeps the solution's metadata (source "planner", N, T, transcription); a Trajectory
    resampled later records ``resampled: {"rate_hz", "source_samples"}``. With no more
    samples than nodes at the source, the transcription's polynomials between the nodes
    (Hermite-Simpson's midpoint controls, a collocation interval's interior) are gone, and
    the simulation sees a spline through the nodes, however finely it was resampled.
    """
    meta = profile.metadata
    n_intervals = meta.get("N")
    if (
        meta.get("source") != "planner"
        or isinstance(n_intervals, bool)
        or not isinstance(n_intervals, int)
    ):
        return None
    resampled = meta.get("resampled")
    source = resampled.get("source_samples") if isinstance(resampled, dict) else None
    if isinstance(source, int) and not isinstance(source, bool):
        origin = f"was resampled from {source} samples"
    else:
        source = profile.time.size
        origin = f"holds {source} samples"
    if source > n_intervals + 1:
        return None
    mesh = str(meta.get("transcription", "unknown transcription"))
    spline = "a not-a-knot cubic spline" if interpolation == "cubic" else "linear interpolation"
    return (
        f"torque file {path_text!r} {origin} of a planner solution with N = {n_intervals} "
        f"intervals ({mesh}), its nodes only: between them the torques are {spline}, not the "
        "transcription's polynomials, so the motion can leave the plan by far more than the "
        "integration error; save the solution with Solution.save(path, rate_hz=1000) for a "
        "faithful replay"
    )


#: simulate() parameters and the options of 'simulate' that set them.
SIMULATE_OPTIONS = {
    "method": "--method",
    "rtol": "--rtol",
    "atol": "--atol",
    "steps": "--substeps",
    "rate_hz": "--rate-hz",
    "t_span": "--t-end-s",
    "interpolation": "--interpolation",
    "torques": "the torque file",
}


#: The advice of a SimulationError, in the options of 'simulate'.
_FAILURE_WORDS = (
    ("shorten t_span", "lower --t-end-s"),
    ("rtol/atol", "--rtol/--atol"),
    ("raise steps", "raise --substeps"),
)


def run(args, out: TextIO, report: Reporter) -> int:
    if args.method not in METHODS:
        raise UsageError(f"unknown --method {args.method!r}; choose one of: {', '.join(METHODS)}")
    linkage = preset_linkage(args.preset)
    loaded = _load_profile(args.torque_file)
    profile = _linkage_profile(loaded, args.torque_file, args.preset, linkage.names)
    converted = sorted(
        {
            f"{unit} -> {si_unit(unit)[0]}"
            for _, unit, _ in loaded.columns
            if si_unit(unit) is not None and si_unit(unit) != (unit, 1.0)
        }
    )
    if converted:
        report.step(f"converted the columns of {args.torque_file} to SI: {', '.join(converted)}")
    time_grid = np.asarray(profile.time, dtype=float)
    t0, t_file_end = float(time_grid[0]), float(time_grid[-1])
    t_end = t_file_end if args.t_end_s is None else args.t_end_s
    if not t0 < t_end <= t_file_end + 1e-9 * max(1.0, t_file_end):
        raise UsageError(
            f"--t-end-s {t_end:g} s is outside the file's time range ({t0:g}, {t_file_end:g}] s"
        )
    t_end = min(t_end, t_file_end)
    samples = max(1, math.ceil((t_end - t0) * args.rate_hz - 1e-9)) + 1
    check_samples(
        samples,
        args.force,
        f"--rate-hz {args.rate_hz:g} Hz over {t_end - t0:g} s",
        "lower --rate-hz or --t-end-s",
        "output files to match",
    )
    if args.method in SECONDS_PER_ELEMENT:
        # One interval per file sample, output time and 10 ms at most (an upper estimate).
        in_span = int(np.count_nonzero((time_grid >= t0) & (time_grid <= t_end)))
        intervals = in_span + samples + math.ceil((t_end - t0) / 0.01)
        elements = intervals * args.substeps
        seconds = elements * SECONDS_PER_ELEMENT[args.method]
        if seconds > LIMIT_SECONDS and not args.force:
            raise UsageError(
                f"--substeps {args.substeps} with --method {args.method} over up to {intervals:,} "
                f"integration intervals is {elements:,} finite elements, about "
                f"{seconds:,.0f} s here (more than {LIMIT_SECONDS:g} s); give fewer --substeps "
                "or a shorter --t-end-s, or add --force to run it"
            )
    warning = _node_samples_warning(profile, args.torque_file, args.interpolation)
    if warning is not None:
        report.warn(warning)
    output = output_set(args.output_dir, "simulate")
    dynamics = Dynamics(linkage)
    x0 = np.concatenate([np.asarray(profile.psi)[0], np.asarray(profile.dpsi)[0]])
    try:
        # Progress comes after each block of intervals; a heartbeat fills the silence when a
        # block takes long (many --substeps, a stiff stretch for cvodes).
        with report.working(f"simulating with {args.method} over [{t0:g}, {t_end:g}] s"):
            result = simulate(
                dynamics,
                profile,
                x0,
                (t0, t_end),
                rate_hz=args.rate_hz,
                method=args.method,
                rtol=args.rtol,
                atol=args.atol,
                steps=args.substeps,
                interpolation=args.interpolation,
                progress=report.progress,
            )
    except (DefinitionError, DefinitionTypeError) as exc:
        raise UsageError(in_option_words(str(exc), SIMULATE_OPTIONS)) from exc
    except SimulationError as exc:
        message = str(exc)
        for words, option_words in _FAILURE_WORDS:
            message = message.replace(words, option_words)
        raise CommandFailed(message) from exc
    with output:
        save_trajectory(result, output.staging, "simulated", args.formats)
        if not args.no_plots:
            write_plots(dynamics, result, output.staging, "simulated", False, False, report)
        written = output.commit({"argv": list(sys.argv[1:])})
    states, _ = profile.at(np.asarray(result.time))
    reference = np.asarray(states)[:, : linkage.n]
    deviation = np.max(np.abs(np.asarray(result.psi) - reference), axis=1)
    above = np.nonzero(deviation > 1e-6)[0]
    print(
        f"simulated {linkage.n} links with {args.method} over [{t0:g}, {t_end:g}] s "
        f"({result.time.size} samples) in {result.metadata.get('wall_seconds', math.nan):.2f} s",
        file=out,
    )
    print(f"max |psi - psi_file| = {deviation.max():.3e} rad", file=out)
    if above.size:
        print(
            "deviation from the file's angles exceeds 1e-6 rad at "
            f"t = {result.time[above[0]]:.3f} s "
            "(bounded by the integration error and, for an unstable motion, by its growth; "
            "--method rk with more --substeps or tighter --rtol/--atol move it)",
            file=out,
        )
        rate = fit_growth_rate(result.time, deviation, FIT_WINDOW)
        if math.isfinite(rate):
            low, high = (f"{v:.0e}".replace("e-0", "e-") for v in FIT_WINDOW)
            print(
                f"deviation grows ~exp({rate:.1f} t), rate fitted over {low}..{high} rad",
                file=out,
            )
    else:
        print("deviation from the file's angles stays below 1e-6 rad", file=out)
    for path in written:
        print(f"wrote {path}", file=out)
    return 0


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The 'simulate' command's parser."""
    simulate = commands.add_parser(
        "simulate",
        parents=[common, limits],
        help="second problem: motion under the torques of a file",
        description=(
            "Second problem of dynamics: integrate the linkage under the hinge torques of a "
            "file written by 'torques' (or a planner Solution export), from the file's first "
            "state [psi (rad); dpsi (rad/s)], and compare the motion with the file's angles. "
            "Writes simulated.<format> and, unless --no-plots, simulated.png. Between the "
            "file's samples the torques are interpolated (--interpolation). A planner "
            "solution saved at its nodes only (Solution.save(path) without rate_hz) has lost "
            "the transcription's polynomials between them: the run goes ahead with a warning "
            "on stderr, and the motion can leave the plan by far more than the integration "
            "error; save it with Solution.save(path, rate_hz=1000) for a faithful replay. A "
            "failed integration prints one error line and exits with status 1."
        ),
    )
    simulate.add_argument(
        "torque_file", metavar="TORQUE_FILE", help=f"torque profile: {one_of(TRAJECTORY_FORMATS)}"
    )
    simulate.add_argument("--preset", default="six-link", metavar="NAME", help=PRESET_HELP)
    simulate.add_argument(
        "--method",
        default="cvodes",
        metavar="NAME",
        help="CasADi integrator: cvodes, idas (variable step, tolerances apply), rk "
        "(Runge-Kutta 4), collocation (Radau); default: cvodes",
    )
    simulate.add_argument(
        "--rtol",
        type=tolerance,
        default=1e-10,
        help="relative tolerance of cvodes/idas, in [1e-14, 1) (default: 1e-10)",
    )
    simulate.add_argument(
        "--atol",
        type=tolerance,
        default=1e-10,
        help="absolute tolerance of cvodes/idas, rad and rad/s, in [1e-14, 1) (default: 1e-10)",
    )
    simulate.add_argument(
        "--substeps",
        type=positive_count,
        default=8,
        help="finite elements per integration interval for rk/collocation; an interval "
        "runs between consecutive file samples and output times, at most 10 ms; runs "
        f"estimated longer than {LIMIT_SECONDS:g} s need --force (default: 8)",
    )
    simulate.add_argument(
        "--t-end-s",
        type=positive("s"),
        metavar="S",
        help="end time, s (default: the end of the file's time range)",
    )
    simulate.add_argument(
        "--rate-hz",
        type=positive("Hz", MAX_RATE_HZ),
        default=100.0,
        metavar="HZ",
        help=f"output samples per second, Hz, at most 1e6 and {LIMIT_SAMPLES:,} samples "
        "(--force: 2,000,000) (default: 100)",
    )
    simulate.add_argument(
        "--interpolation",
        default="cubic",
        choices=("cubic", "linear"),
        help="interpolation of the file's torques between samples (default: cubic)",
    )
    output_options(simulate, "simulate_out", ("csv",))
