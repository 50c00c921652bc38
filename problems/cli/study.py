"""``python -m problems study``: a walking study from the command line (``problems.cli``
dispatches here).

    python -m problems study --step-length-m 0.3:0.7:9 --step-time-s 0.4:0.7:7
    python -m problems study --step-length-m 0.3:0.7:9 --step-time-s 0.4:0.7:7 --workers 2
    python -m problems study ... --scheduler tcp://10.0.0.5:8786     # a Dask cluster
    python -m problems study ... --scheduler local                  # a Dask LocalCluster

A value option takes one value (``0.5``), a list (``0.4,0.5,0.6``) or a range
``start:stop:count`` (``count`` values from start to stop, both included). Step length and
step time are always axes (in that order); ``--mu``, ``--torque-limit-nm``, ``--clearance-m``
and ``--double-support-s`` become axes when given more than one value. The study goes to
``--output-dir`` (default ``study_out``): the same command again resumes it, solving only the
points it does not hold; a folder of another study is refused. A progress bar on stderr shows
the points done, failed and the time left; the summary and the files written go to stdout.
Exit status 0 when every point is settled (failed points are results: listed, and marked in
the plots), 130 when interrupted (run the same command again to go on), 2 for bad input, 1
when the study cannot run.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from collections.abc import Callable
from typing import Any, TextIO

import numpy as np

from model.presets import PRESETS
from planner.errors import DefinitionError
from planner.schemes import (
    DEFAULT_TRANSCRIPTION,
    REGISTRY,
    TRANSCRIPTIONS,
    WITH_DEGREE,
    check_degree,
)
from problems.cli.common import Terminated, UsageError
from problems.study.backends import available_cores
from problems.study.result import StudyProgress, StudyResult
from problems.study.schedule import ORDERINGS
from problems.study.store import StudyFileError, StudyFolderError
from problems.study.study import Study
from problems.walking.step import WALKING_DEFAULTS

DEFAULT_FOLDER = "study_out"
#: Most values one axis takes, and most points a study holds (each point a solve and a few
#: files: 10,000 is hours on a laptop and ~1 GB of folder).
MAX_VALUES = 1000
MAX_POINTS = 10_000
#: Most mesh intervals, IPOPT iterations per attempt and local workers.
MAX_INTERVALS = 2000
MAX_ITER = 100_000
MAX_WORKERS = 256
#: IPOPT iterations per attempt: a converging point takes 10-60 here; a failing one is
#: stopped early (it is tried up to three times).
DEFAULT_MAX_ITER = 500
#: What --degree takes, from the planner's registry of transcriptions: "radau 1..9, ...".
DEGREES = ", ".join(f"{name} {REGISTRY[name].degree_range}" for name in WITH_DEGREE)
DEFAULT_DEGREES = ", ".join(f"{name} {REGISTRY[name].default_degree}" for name in WITH_DEGREE)


def value_list(unit: str, upper: float = math.inf, zero: bool = False):
    """An argparse type: one value, "a,b,c" or "start:stop:count", each in (0, upper]
    ([0, upper] with ``zero``)."""

    def parse(text: str) -> tuple[float, ...]:
        try:
            if ":" in text:
                parts = text.split(":")
                if len(parts) != 3:
                    raise ValueError
                start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
                if count < 1 or (count == 1 and start != stop):
                    raise argparse.ArgumentTypeError(
                        f"{text!r}: the count must be >= 2 for a range (or give one value)"
                    )
                if count > MAX_VALUES:
                    raise argparse.ArgumentTypeError(
                        f"{text!r}: at most {MAX_VALUES:,} values on an axis, got {count:,}; "
                        "study a coarser grid first"
                    )
                values = tuple(float(v) for v in np.linspace(start, stop, count))
            else:
                values = tuple(float(v) for v in text.split(","))
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected a value, a list a,b,c or a range start:stop:count in {unit}, got "
                f"{text!r}"
            ) from None
        for v in values:
            if not math.isfinite(v) or not (v >= 0 if zero else v > 0) or v > upper:
                raise argparse.ArgumentTypeError(
                    f"{text!r}: every value must lie in {'[' if zero else '('}0, {upper:g}] "
                    f"{unit}, got {v:g}"
                )
        if len(set(values)) != len(values):
            raise argparse.ArgumentTypeError(f"{text!r}: a value is given twice")
        return values

    return parse


def positive_count(text: str) -> int:
    """An argparse ``type``: an integer >= 1."""
    return _count_at_least(text, 1)


def non_negative_count(text: str) -> int:
    """An argparse ``type``: an integer >= 0."""
    return _count_at_least(text, 0)


def _count_at_least(text: str, least: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < least:
        raise argparse.ArgumentTypeError(f"must be >= {least}, got {text!r}")
    return value


def count_at_most(maximum: int, what: str, fix: str) -> Callable[[str], int]:
    """An argparse ``type``: an integer in [1, maximum] (``what`` names it, ``fix`` says
    what to do instead of more)."""

    def parse(text: str) -> int:
        value = positive_count(text)
        if value > maximum:
            raise argparse.ArgumentTypeError(f"at most {maximum:,} {what}, got {value:,}; {fix}")
        return value

    return parse


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The ``study`` subcommand's parser."""
    study = commands.add_parser(
        "study",
        parents=[common],
        help="a walking study: walking steps over a grid of step lengths and times (and more)",
        description=(
            "Solve the walking step (as 'walk' does) over a grid of values, each point "
            "warm-started from a solved neighbour (then another one, then the gait law), on a "
            "local process pool (default: one worker per core) or a Dask cluster "
            '(--scheduler; needs pip install ".[cluster]"). Records per point the cost, cost '
            "of transport, speed, peak and RMS torque per hinge, peak friction use, "
            "iterations, times, accuracy estimate, verification and IPOPT's status in "
            "results.csv, each point's gait in solutions/<point>.npz, and plots: "
            "cost_of_transport.png, peak_torque.png, cost_map.png. Running the same command "
            "again resumes the study; a folder of another study is refused. Values: one "
            "value, a list a,b,c or a range start:stop:count."
        ),
    )
    study.add_argument(
        "--step-length-m",
        type=value_list("m", 2.0),
        metavar="SPEC",
        help=f"step lengths, m (default: {WALKING_DEFAULTS['step_length']:g}; --quick: 0.4,0.5)",
    )
    study.add_argument(
        "--step-time-s",
        type=value_list("s", 10.0),
        metavar="SPEC",
        help=f"step times, s (default: {WALKING_DEFAULTS['step_time']:g}; --quick: 0.45,0.5)",
    )
    study.add_argument(
        "--mu",
        type=value_list("(friction coefficient)", 10.0),
        default=(WALKING_DEFAULTS["mu"],),
        metavar="SPEC",
        help=f"friction coefficients (default: {WALKING_DEFAULTS['mu']:g})",
    )
    study.add_argument(
        "--torque-limit-nm",
        type=value_list("N m", 1e5),
        default=(WALKING_DEFAULTS["torque_limit"],),
        metavar="SPEC",
        help=f"bounds on |M_i|, N m (default: {WALKING_DEFAULTS['torque_limit']:g})",
    )
    study.add_argument(
        "--clearance-m",
        type=value_list("m", 1.0, zero=True),
        default=None,
        metavar="SPEC",
        help="mid-swing foot clearances, m (default: 0.05 m for 0.86 m legs, scaled with the leg)",
    )
    study.add_argument(
        "--double-support-s",
        type=value_list("s", 10.0, zero=True),
        default=(WALKING_DEFAULTS["double_support"],),
        metavar="SPEC",
        help="double-support durations within the step time, s (default: "
        f"{WALKING_DEFAULTS['double_support']:g}, none)",
    )
    study.add_argument(
        "--preset",
        default="six-link",
        choices=("six-link", "five-link"),
        help="biped preset (default: six-link)",
    )
    study.add_argument("--passive-ankle", action="store_true", help="no torque at the stance foot")
    study.add_argument(
        "--objective",
        default=WALKING_DEFAULTS["objective"],
        choices=("torque", "torque-rate", "work", "human"),
        help="integral of sum M^2 (default), of sum dM^2, positive work, or the joints' "
        "strength-normalised effort with passive moments (human)",
    )
    study.add_argument(
        "--transcription",
        default=DEFAULT_TRANSCRIPTION,
        choices=TRANSCRIPTIONS,
        help=f"collocation scheme (default: {DEFAULT_TRANSCRIPTION})",
    )
    study.add_argument("--degree", type=positive_count, default=None, metavar="D",
                       help=f"degree of {DEGREES} (default: {DEFAULT_DEGREES})")  # fmt: skip
    study.add_argument(
        "-N",
        "--intervals",
        type=count_at_most(
            MAX_INTERVALS,
            "intervals",
            "a finer mesh belongs to 'walk --accuracy' for the points that need it",
        ),
        default=None,
        metavar="N",
        help=f"mesh intervals (default: 30, 12 with --quick; at most {MAX_INTERVALS:,})",
    )
    study.add_argument(
        "--max-iter",
        type=count_at_most(
            MAX_ITER,
            "IPOPT iterations",
            "a point that needs more is a point to look at alone ('walk')",
        ),
        default=DEFAULT_MAX_ITER,
        metavar="K",
        help=f"IPOPT iterations per attempt (default: {DEFAULT_MAX_ITER}, at most {MAX_ITER:,})",
    )
    study.add_argument(
        "--workers",
        type=count_at_most(MAX_WORKERS, "workers", "a cluster takes more: --scheduler"),
        default=None,
        metavar="N",
        help=f"worker processes (default: one per core, here "
        f"{available_cores()}); 1 solves in this process; at most {MAX_WORKERS}",
    )
    study.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run on a Dask cluster: its scheduler's address (tcp://host:8786), "
        "or 'local' for a LocalCluster of --workers workers on this machine",
    )
    study.add_argument(
        "--ordering",
        default="auto",
        choices=ORDERINGS,
        help="continuation order: lines along the step time in parallel, or a "
        "coarse grid cold first (default auto: lines when there are enough "
        "lines for the workers)",
    )
    study.add_argument(
        "--retry-failed", action="store_true", help="solve the points recorded as failed again"
    )
    study.add_argument(
        "--output-dir",
        default=DEFAULT_FOLDER,
        metavar="DIR",
        help=f"study folder (default: {DEFAULT_FOLDER}; the same folder resumes)",
    )
    study.add_argument("--no-plots", action="store_true", help="write no PNG plots")
    study.add_argument(
        "--quick",
        action="store_true",
        help="a 2 x 2 grid at N = 12 unless the axes are given: a smoke test",
    )


def _axes_and_fixed(args) -> tuple[dict[str, tuple], dict[str, Any]]:
    default = (
        ((0.4, 0.5), (0.45, 0.5))
        if args.quick
        else ((WALKING_DEFAULTS["step_length"],), (WALKING_DEFAULTS["step_time"],))
    )
    axes: dict[str, tuple] = {
        "step_length": args.step_length_m or default[0],
        "step_time": args.step_time_s or default[1],
    }
    fixed: dict[str, Any] = {}
    for name, values in (
        ("mu", args.mu),
        ("torque_limit", args.torque_limit_nm),
        ("clearance", args.clearance_m),
        ("double_support", args.double_support_s),
    ):
        if values is None:  # the walking step's own default (scaled with the walker)
            continue
        if len(values) > 1:
            axes[name] = values
        else:
            fixed[name] = values[0]
    fixed.update(
        linkage=PRESETS[args.preset](),
        N=args.intervals or (12 if args.quick else 30),
        transcription=args.transcription,
        objective=args.objective,
    )
    if args.degree is not None:  # absent otherwise: studies defined before --degree resume
        fixed["degree"] = _checked_degree(args.transcription, args.degree)
    if args.passive_ankle:
        fixed["passive"] = (PRESETS[args.preset]().names[0],)
    return axes, fixed


def _checked_degree(transcription: str, degree: int) -> int:
    """--degree checked against the registry before any point is defined (a refused degree
    would otherwise fail every point of the study, one by one)."""
    if transcription not in WITH_DEGREE:
        joined = " or ".join(WITH_DEGREE)
        raise DefinitionError(f"--degree: applies to --transcription {joined} only")
    try:
        return check_degree(transcription, degree)
    except DefinitionError as exc:
        raise DefinitionError(str(exc).replace("`degree`", "--degree", 1)) from None


def _duration(seconds: float | None) -> str:
    if seconds is None or not math.isfinite(seconds):
        return "--:--"
    seconds = round(seconds)
    hours, rest = divmod(seconds, 3600)
    return f"{hours}:{rest // 60:02d}:{rest % 60:02d}" if hours else f"{rest // 60}:{rest % 60:02d}"


class ProgressBar:
    """The study's progress on a stream: a bar redrawn in place on a terminal, a line per
    tenth of the points (or per 30 s) elsewhere (a log file, CI)."""

    WIDTH = 30

    def __init__(self, stream: TextIO, enabled: bool = True) -> None:
        self._stream = stream
        self._enabled = enabled
        self._tty = bool(getattr(stream, "isatty", lambda: False)())
        self._last_line = time.perf_counter()
        self._last_settled = 0
        self._drawn = False

    def text(self, p: StudyProgress) -> str:
        filled = round(self.WIDTH * p.settled / p.total) if p.total else self.WIDTH
        bar = "#" * filled + "." * (self.WIDTH - filled)
        rate = 60.0 * p.done_this_run / p.elapsed if p.elapsed > 0 and p.done_this_run else 0.0
        return (
            f"[{bar}] {p.settled}/{p.total} points, {p.failed} failed, {p.running} running, "
            f"{rate:.1f}/min, elapsed {_duration(p.elapsed)}, left {_duration(p.eta)}"
        )

    def __call__(self, p: StudyProgress) -> None:
        if not self._enabled:
            return
        if self._tty:
            self._stream.write("\r" + self.text(p) + "\x1b[K")
            self._drawn = True
        else:
            now = time.perf_counter()
            step = max(1, p.total // 10)
            crossed = p.settled // step != self._last_settled // step or p.settled == p.total
            if (p.row is not None and crossed) or now - self._last_line >= 30.0:
                if p.settled != self._last_settled or now - self._last_line >= 30.0:
                    self._stream.write(self.text(p) + "\n")
                    self._last_line = now
                    self._last_settled = p.settled
        self._stream.flush()

    def close(self) -> None:
        if self._enabled and self._tty and self._drawn:
            self._stream.write("\n")
            self._stream.flush()


class _Warnings(logging.Handler):
    """The study's warnings (a lost worker) as the command line's warning lines."""

    def __init__(self, report) -> None:
        super().__init__(logging.WARNING)
        self._report = report

    def emit(self, record: logging.LogRecord) -> None:
        self._report.warn(record.getMessage())


def _span(name: str, values: tuple) -> str:
    unit = {"step_length": " m", "step_time": " s", "torque_limit": " N m", "clearance": " m",
            "double_support": " s"}  # fmt: skip
    if len(values) == 1:
        return f"{name} {values[0]:g}{unit.get(name, '')}"
    return f"{name} {values[0]:g}..{values[-1]:g}{unit.get(name, '')} ({len(values)})"


def summary(result: StudyResult, out: TextIO) -> None:
    """The study's summary lines."""
    run = result.run or {}
    if run and not run["solved"] + run["failed"]:
        print(f"this run: nothing left to solve ({run['backend']})", file=out)
    elif run:
        print(
            f"this run: {run['solved']} solved, {run['failed']} failed in {run['seconds']:.1f} s "
            f"({run['points_per_minute']:.1f} points/min; {run['backend']}, ordering "
            f"{run['ordering']}); {run['iterations']} IPOPT iterations",
            file=out,
        )
    print(
        f"folder {result.folder}: {len(result.solved)} solved, {len(result.failed)} failed, "
        f"{len(result.missing)} missing of {result.total}",
        file=out,
    )
    solved = result.solved
    if solved and "cost_of_transport" in solved[0]:
        best = min(solved, key=lambda r: r["cost_of_transport"])
        where = ", ".join(f"{name} {best[name]:g}" for name in result.axes)
        print(
            f"cost of transport {min(r['cost_of_transport'] for r in solved):.4g} .. "
            f"{max(r['cost_of_transport'] for r in solved):.4g}; lowest at {where} "
            f"({best['speed']:.3g} m/s)",
            file=out,
        )
    if solved and "verified" in solved[0]:
        bad = [r["point"] for r in solved if not r["verified"]]
        print(
            "verification: "
            + ("all solved points passed" if not bad else f"failed at {', '.join(bad)}"),
            file=out,
        )
    for row in result.failed:
        where = ", ".join(f"{name} {row[name]:g}" for name in result.axes)
        print(f"failed: {row['point']} ({where}): {row['status']}", file=out)


def run(args, out: TextIO, report) -> int:
    """Run ``python -m problems study``; returns the exit status."""
    axes, fixed = _axes_and_fixed(args)
    points = math.prod(len(values) for values in axes.values())
    if points > MAX_POINTS:
        raise DefinitionError(
            f"`axes`: the grid has {points:,} points, more than {MAX_POINTS:,}; study a "
            "coarser grid first, or split the grid into several studies"
        )
    study = Study(axes, fixed=fixed, ipopt={"max_iter": args.max_iter})
    spans = " x ".join(_span(name, values) for name, values in axes.items())
    report.step(
        f"study of the {args.preset} walking step over {spans}: {len(study)} points into "
        f"{args.output_dir} (the same command resumes it)"
    )
    bar = ProgressBar(sys.stderr, enabled=not args.quiet)
    logger = logging.getLogger("problems.study.study")
    handler = _Warnings(report)
    logger.addHandler(handler)
    try:
        result = study.run(
            args.output_dir,
            workers=args.workers,
            scheduler=args.scheduler,
            ordering=args.ordering,
            retry_failed=args.retry_failed,
            progress=bar,
        )
    except (StudyFolderError, StudyFileError) as refused:
        # the library's field is the command line's --output-dir
        bar.close()
        raise UsageError("--output-dir: " + str(refused).removeprefix("`folder`: ")) from None
    except KeyboardInterrupt as stopped:
        bar.close()
        done = StudyResult.load(args.output_dir)
        how = "terminated (SIGTERM)" if isinstance(stopped, Terminated) else "interrupted"
        print(
            f"anthropoid-planner study: {how}; {len(done.rows)} of {done.total} points "
            f"are saved in {args.output_dir}; run the same command again to solve the "
            f"{len(done.missing)} missing",
            file=sys.stderr,
        )
        return 143 if isinstance(stopped, Terminated) else 130
    finally:
        logger.removeHandler(handler)
    bar.close()
    print(
        f"walking study of {args.preset} ({args.transcription}"
        f"{'' if args.degree is None else f'({args.degree})'} N = {fixed['N']}) over {spans}",
        file=out,
    )
    summary(result, out)
    flagged = [row["point"] for row in result.solved if row.get("accuracy_warning")]
    if flagged:
        report.warn(
            f"{len(flagged)} solved points ({', '.join(flagged[:5])}"
            f"{', ...' if len(flagged) > 5 else ''}) obey their dynamics only to more than "
            "1% of a state's scale between the mesh points (the table's accuracy_warning): "
            "refine the mesh with a larger -N"
        )
    damaged = result.run.get("damaged") or []
    if damaged:
        report.warn(
            f"{len(damaged)} damaged records were moved aside (<name>.damaged) and their points "
            f"solved again: {', '.join(damaged[:3])}{', ...' if len(damaged) > 3 else ''}"
        )
    written = [result.folder / "results.csv"]
    if not args.no_plots:
        # matplotlib is imported only when plots are asked for.
        from problems.study import plots as study_plots

        written += study_plots.save_plots(result)
    print(
        f"wrote {', '.join(str(p) for p in written)} and {result.folder / 'solutions'}/", file=out
    )
    return 0


__all__ = [
    "DEFAULT_DEGREES",
    "DEFAULT_FOLDER",
    "DEGREES",
    "ProgressBar",
    "add_parser",
    "run",
    "summary",
    "value_list",
]
