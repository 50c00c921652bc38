"""Command line: ``python -m problems`` (console script ``anthropoid-planner``).

Subcommands
-----------
walk        plan a periodic walking step (the main job): torques for the drives, files, plots
study       a walking study: walking steps over a grid of values, resumable (problems.study_cli)
equations   print the equations of motion of a preset linkage, as text or LaTeX
torques     first problem of dynamics: torques along a gait law, written to files and plots
simulate    second problem of dynamics: integrate the motion under the torques of a file
demo        the six-link equations of motion and the gait-law torque table (the README's job)

This module is the project's output layer: it alone prints. Results go to stdout, progress and
errors to stderr (including the planner's iterations, which ``planner.solve(progress=True)``
logs on ``planner.progress``: shown here by default, ``--quiet`` turns them off); a bad input
gives one line "anthropoid-planner <command>: error: ..." and exit status 2; a failed
computation (the library's own errors, such as a SimulationError) or a file that cannot be
written, one line and exit status 1. Only the library's errors and OSError are caught:
anything else is a bug and keeps its traceback. A command creates its output folder only when
it has results to write (walk: a converged, verified gait), so a run that fails leaves
nothing on disk. Commands that could run for long or write
large files refuse beyond LIMIT_SAMPLES samples (or about LIMIT_SECONDS of fixed-step
integration) unless given --force, and beyond MAX_SAMPLES always.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import math
import os
import re
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from model import Dynamics, LinkageTrajectory, equations
from model.presets import PRESETS, six_link_anthropoid
from planner.accuracy_check import AccuracyWarning
from planner.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from planner.files import atomic_path
from planner.refinement import check_accuracy
from planner.sampled_limits import SampleLimitError
from planner.schemes import TRANSCRIPTIONS, WITH_DEGREE
from planner.simulation import tolerance_problem
from planner.trajectory import FORMATS as TRAJECTORY_FORMATS
from planner.trajectory import TrajectoryFileError
from planner.units import si_unit
from problems import study_cli
from problems.accuracy import ACCURACY_PRESETS
from problems.dynamics_problems import (
    FIT_WINDOW,
    METHODS,
    SimulationError,
    fit_growth_rate,
    linkage_profile,
    simulate,
    torques_along,
)
from problems.gait_law import LAW_PRESETS, GaitLaw
from problems.gait_problem import WORK_REGULARISATION
from problems.output_set import OutputFolderError, OutputSet
from problems.study_cli import count_at_most, positive_count
from problems.verification import verify_gait
from problems.walking import walking_step

PROG = "anthropoid-planner"
#: File formats of --formats: the trajectory package's suffixes, without the dot.
FORMATS = tuple(suffix.lstrip(".") for suffix in TRAJECTORY_FORMATS)
LAWS = tuple(LAW_PRESETS)
#: What --degree takes, from the registry of transcriptions: "radau 1..9, legendre 1..9".
_DEGREES, _DEFAULT_DEGREES = study_cli.DEGREES, study_cli.DEFAULT_DEGREES
#: Highest --rate-hz, Hz, and most samples a command makes even with --force (memory).
MAX_RATE_HZ = 1e6
MAX_SAMPLES = 2_000_000
#: Most samples (rows of the demo table, samples of a written profile) without --force:
#: 200,000 samples are ~100 MB per CSV or JSON file and ~6 s of writing here.
LIMIT_SAMPLES = 200_000
#: Longest estimated integration without --force, s, and the estimate's cost per finite
#: element of the six-link model, s (measured: rk 6 us, collocation 170 us; cvodes and idas
#: choose their own steps and are not estimated).
LIMIT_SECONDS = 60.0
SECONDS_PER_ELEMENT = {"rk": 6e-6, "collocation": 2e-4}
#: Most mesh intervals of a plan (walk, study): ~50 variables each for the six-link step, an
#: NLP of 100,000 variables; a finer plan comes from --accuracy (refinement where needed).
MAX_INTERVALS = 2000
#: Most walking steps drawn in walk.png and walk.gif (the GIF grows with them).
MAX_DRAWN_STEPS = 50


class UsageError(Exception):
    """Bad command-line input: reported as one line, exit status 2."""


class CommandFailed(Exception):
    """A computation that failed on valid input: reported as one line, exit status 1."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage dump) raised instead of exiting, and no
    abbreviated options (``--step-length`` is no prefix of ``--step-length-m``: one
    spelling of each option)."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # type: ignore[override]
        raise UsageError(f"{message} (see {self.prog} --help)")


class Reporter:
    """Progress on stderr: lines tagged with the elapsed time, throttled, switchable.

    ``step`` announces a stage; ``progress`` reports a fraction (throttled to one line per
    0.5 s); ``working`` wraps a stage that reports little or nothing itself (an animation, a
    plot, a long integration between its progress reports): it announces it, adds a
    "still ..." line after every ``heartbeat_s`` seconds without any other line while it runs,
    and a closing line with its duration when it took a second or more.
    """

    def __init__(
        self, stream: TextIO, enabled: bool = True, heartbeat_s: float = 1.0, where: str = PROG
    ) -> None:
        self._stream = stream
        self._enabled = enabled
        self._where = where
        self._heartbeat_s = heartbeat_s
        self._start = time.perf_counter()
        self._last = -math.inf
        self._lock = threading.Lock()
        self._lines = 0  # progress lines written, so that a heartbeat speaks only in silence

    def step(self, message: str) -> None:
        if self._enabled:
            with self._lock:
                print(f"[{time.perf_counter() - self._start:6.2f} s] {message}", file=self._stream)
                self._stream.flush()
                self._lines += 1

    def warn(self, message: str) -> None:
        """One line "<prog> <command>: warning: ..." on the stream, even with --quiet."""
        with self._lock:
            print(f"{self._where}: warning: {message}", file=self._stream)
            self._stream.flush()

    def progress(self, fraction: float, message: str) -> None:
        now = time.perf_counter()
        if fraction >= 1.0 or now - self._last >= 0.5:
            self._last = now
            self.step(f"{message} ({100.0 * fraction:3.0f}%)")

    @contextlib.contextmanager
    def working(self, message: str) -> Iterator[None]:
        """Announce ``message``, then a heartbeat line while the block runs."""
        self.step(message)
        if not self._enabled:
            yield
            return
        begin = time.perf_counter()
        done = threading.Event()
        beats = []

        def beat() -> None:
            lines = self._lines
            while not done.wait(self._heartbeat_s):
                if self._lines == lines:  # nothing said for heartbeat_s: say it still runs
                    beats.append(None)
                    self.step(f"still {message}: {time.perf_counter() - begin:.1f} s so far")
                lines = self._lines

        thread = threading.Thread(target=beat, name="progress-heartbeat", daemon=True)
        thread.start()
        try:
            yield
        finally:
            done.set()
            thread.join()
        elapsed = time.perf_counter() - begin
        if elapsed >= 1.0 or beats:
            self.step(f"done {message} in {elapsed:.1f} s")


def _one_of(items: Sequence[str]) -> str:
    """ "a, b or c": the items in words."""
    return ", ".join(items[:-1]) + f" or {items[-1]}" if len(items) > 1 else "".join(items)


# ---- argument types (each raises a one-line message naming the unit) -----------------------
def positive(unit: str, maximum: float = math.inf) -> Callable[[str], float]:
    """An argparse ``type``: a finite number in (0, maximum] of ``unit`` (the examples use it
    too, so that every command line says the same about a bad number)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number in {unit}, got {text!r}") from None
        if not math.isfinite(value) or value <= 0:
            raise argparse.ArgumentTypeError(f"must be a finite number > 0 {unit}, got {text!r}")
        if value > maximum:
            raise argparse.ArgumentTypeError(
                f"must be at most {maximum:,.0f} {unit}, got {text!r}; give a smaller value"
            )
        return value

    return parse


def _tolerance(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number such as 1e-10, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number such as 1e-10, got {text!r}")
    problem = tolerance_problem(value)
    if problem is not None:
        raise argparse.ArgumentTypeError(problem)
    return value


def _accuracy(text: str) -> str | float:
    """--accuracy: a preset name, or a refinement target (a number in [1e-9, 1))."""
    if text in ACCURACY_PRESETS:
        return text
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a preset ({_one_of(tuple(ACCURACY_PRESETS))}) or a refinement target "
            f"such as 1e-5, got {text!r}"
        ) from None
    try:
        return check_accuracy(value)
    except DefinitionError as error:
        raise argparse.ArgumentTypeError(str(error).replace("`accuracy`: ", "")) from None


def _non_negative(unit: str) -> Callable[[str], float]:
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number in {unit}, got {text!r}") from None
        if not math.isfinite(value) or value < 0:
            raise argparse.ArgumentTypeError(f"must be a finite number >= 0 {unit}, got {text!r}")
        return value

    return parse


def _angles(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated numbers in rad, one per link, got {text!r}"
        ) from None
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"must be finite numbers in rad, got {text!r}")
    return values


def _formats(text: str) -> tuple[str, ...]:
    items = tuple(dict.fromkeys(f.strip().lower().lstrip(".") for f in text.split(",") if f))
    unknown = [f for f in items if f not in FORMATS]
    if unknown or not items:
        raise argparse.ArgumentTypeError(
            f"unknown format(s) {unknown or [text]}; choose from {', '.join(FORMATS)}"
        )
    return items


# ---- parser -------------------------------------------------------------------------------
def _output_options(
    command: argparse.ArgumentParser, folder: str, formats: tuple[str, ...]
) -> None:
    """--output-dir, --formats and --no-plots of a command that writes files."""
    command.add_argument(
        "--output-dir",
        default=folder,
        metavar="DIR",
        help=f"output folder (created; default: {folder})",
    )
    command.add_argument(
        "--formats",
        type=_formats,
        default=formats,
        metavar="LIST",
        help=f"comma-separated file formats among {', '.join(FORMATS)} "
        f"(default: {','.join(formats)})",
    )
    command.add_argument("--no-plots", action="store_true", help="write no PNG plots")


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser (every option documented with its unit)."""
    parser = _Parser(
        prog=PROG,
        description=(
            "Planar branched linkages with the complex-variable Lagrange model of the seed "
            "paper: equations of motion, the first problem of dynamics (torques along a gait "
            "law) and the second (motion under given torques). Angles in rad (absolute, from "
            "+x counter-clockwise), torques in N m, time in s."
        ),
        epilog=f"Run '{PROG} <command> --help' for the options of a command.",
    )
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("-q", "--quiet", action="store_true", help="no progress lines on stderr")
    limits = argparse.ArgumentParser(add_help=False)
    limits.add_argument(
        "--force",
        action="store_true",
        help=f"go past the limits that keep a run short and its files small "
        f"({LIMIT_SAMPLES:,} samples or table rows, about {LIMIT_SECONDS:g} s of fixed-step "
        f"integration); {MAX_SAMPLES:,} samples stay the most",
    )
    commands = parser.add_subparsers(dest="command", metavar="<command>", parser_class=_Parser)
    commands.required = True

    preset_help = f"linkage preset, one of: {', '.join(PRESETS)} (default: six-link)"
    _walk_parser(commands, common, limits)
    study_cli.add_parser(commands, common)

    equations = commands.add_parser(
        "equations",
        parents=[common],
        help="print the equations of motion of a preset linkage",
        description=(
            "Print Lagrange's equations of a preset linkage in the paper's style (l_i in m, "
            "m_i in kg, n_i the centre-of-mass fraction, I_i about the start hinge in kg m^2, "
            "g in m/s^2, M_i in N m). For six-link this is the corrected (16)-(21)."
        ),
    )
    equations.add_argument("--preset", default="six-link", metavar="NAME", help=preset_help)
    equations.add_argument("--latex", action="store_true", help="LaTeX instead of plain text")
    equations.add_argument(
        "--output", metavar="FILE", help="write to FILE instead of stdout (overwritten)"
    )

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
    torques.add_argument("--preset", default="six-link", metavar="NAME", help=preset_help)
    torques.add_argument(
        "--period-s",
        type=positive("s"),
        metavar="T",
        help="walking period T, s (default: the law's, 1 s)",
    )
    torques.add_argument(
        "--zeta-rad", type=_angles, metavar="Z1,Z2,...", help="amplitudes zeta_j, rad, one per link"
    )
    torques.add_argument(
        "--varpi-rad", type=_angles, metavar="W1,W2,...", help="phases varpi_j, rad, one per link"
    )
    torques.add_argument(
        "--center-rad",
        type=_angles,
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
    _output_options(torques, "torques_out", ("csv", "json"))
    torques.add_argument(
        "--gif", action="store_true", help="also write an animation, animation.gif (slow)"
    )

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
        "torque_file", metavar="TORQUE_FILE", help=f"torque profile: {_one_of(TRAJECTORY_FORMATS)}"
    )
    simulate.add_argument("--preset", default="six-link", metavar="NAME", help=preset_help)
    simulate.add_argument(
        "--method",
        default="cvodes",
        metavar="NAME",
        help="CasADi integrator: cvodes, idas (variable step, tolerances apply), rk "
        "(Runge-Kutta 4), collocation (Radau); default: cvodes",
    )
    simulate.add_argument(
        "--rtol",
        type=_tolerance,
        default=1e-10,
        help="relative tolerance of cvodes/idas, in [1e-14, 1) (default: 1e-10)",
    )
    simulate.add_argument(
        "--atol",
        type=_tolerance,
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
    _output_options(simulate, "simulate_out", ("csv",))

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
    return parser


def _walk_parser(commands, common, limits) -> None:
    walk = commands.add_parser(
        "walk",
        parents=[common, limits],
        help="plan a periodic walking step: drive torques, files, plots (the main job)",
        description=(
            "Plan one periodic walking step of a biped by direct collocation on IPOPT: single "
            "support on the stance foot, the swing foot from (-s, 0) behind to (s, 0), heel "
            "strike (inelastic impact) and leg swap, periodic across steps; ground reaction "
            "and impulse inside the friction cone, swing-foot clearance, knee and posture "
            "limits, torque bounds; minimum integral of sum M_i^2. The gait law (22) fitted "
            "to the step is the initial guess and the benchmark. Prints a summary (cost "
            "against the law's, iterations, times, accuracy, an independent verification) and "
            "writes to --output-dir: torques.csv and torques.json at --rate-hz (one step, N m, "
            "for a drive controller; the next step repeats it with the legs exchanged), "
            "solution.npz (the nodes at full precision, to warm-start from), gait.png "
            "(angles, torques, ground reaction and friction use, foot path), walk.png and "
            "walk.gif (--steps steps in world coordinates). Exit status 1 when IPOPT fails or "
            "the verification fails."
        ),
    )
    walk.add_argument("--preset", default="six-link", metavar="NAME",
                      help="biped preset: six-link or five-link (default: six-link)")  # fmt: skip
    walk.add_argument(
        "--step-length-m",
        type=positive("m", 2.0),
        default=0.5,
        metavar="S",
        help="distance between the feet at heel strike, m (default: 0.5)",
    )
    walk.add_argument(
        "--step-time-s",
        type=positive("s", 10.0),
        default=0.5,
        metavar="T",
        help="duration of one step, s (default: 0.5)",
    )
    walk.add_argument(
        "--transcription",
        default=None,
        choices=TRANSCRIPTIONS,
        help="collocation scheme (default: hermite-simpson)",
    )
    walk.add_argument("-N", "--intervals", type=count_at_most(MAX_INTERVALS, "intervals",
                      "refine with --accuracy TARGET instead"), default=None, metavar="N",
                      help=f"mesh intervals (default: 30, 12 with --quick; at most "
                           f"{MAX_INTERVALS:,})")  # fmt: skip
    walk.add_argument("--degree", type=positive_count, default=None, metavar="D",
                      help=f"degree of {_DEGREES} (default: {_DEFAULT_DEGREES})")  # fmt: skip
    presets = "; ".join(f"{p.name}: {p.summary}" for p in ACCURACY_PRESETS.values())
    walk.add_argument(
        "--accuracy",
        type=_accuracy,
        default=None,
        metavar="PRESET|TARGET",
        help=f"a preset instead of -N/--transcription/--degree ({presets}), or a number: "
        "refine the mesh (from -N/--transcription) until the per-interval re-integration error "
        "per nominal state scale (1 rad, 3 rad/s) is within it, e.g. 1e-5",
    )
    walk.add_argument(
        "--formulation",
        default="implicit",
        choices=("implicit", "explicit"),
        help="implicit: accelerations are variables (default); explicit: forward dynamics",
    )
    walk.add_argument("--mu", type=positive("(friction coefficient)", 10.0), default=0.8,
                      help="friction coefficient of the ground (default: 0.8)")  # fmt: skip
    walk.add_argument(
        "--torque-limit-nm",
        type=positive("N m", 1e5),
        default=150.0,
        metavar="M",
        help="bound on every hinge torque |M_i|, N m (default: 150)",
    )
    walk.add_argument(
        "--passive-ankle",
        action="store_true",
        help="no torque at the stance foot (a point foot's passive ankle)",
    )
    walk.add_argument(
        "--foot-heel-m",
        type=_non_negative("m"),
        default=None,
        metavar="H",
        help="the sole reaches H m behind the ankle: the ankle torque's centre of pressure "
        "M / Fy stays on the sole (default 0.05 m for 0.86 m legs, scaled with the legs)",
    )
    walk.add_argument(
        "--foot-toe-m",
        type=_non_negative("m"),
        default=None,
        metavar="T",
        help="the sole reaches T m ahead of the ankle (default 0.15 m for 0.86 m legs)",
    )
    walk.add_argument(
        "--touchdown-speed-mps",
        type=_non_negative("m/s"),
        default=None,
        metavar="V",
        help="least downward speed of the landing foot at heel strike, m/s, and the slope of "
        "the clearance's approach line (default 0.3 m/s for 0.86 m legs; 0 lets it graze in)",
    )
    walk.add_argument(
        "--ground-margin-m",
        type=_non_negative("m"),
        default=0.0,
        metavar="G",
        help="every point of the body but the feet (knees, hips, neck, head) stays G m above "
        "the ground (default: 0)",
    )
    walk.add_argument(
        "--double-support-s",
        type=float,
        default=0.0,
        metavar="D",
        help="a double support of D s after heel strike, within the step time (two phases; "
        "default: 0, the legs swap at heel strike)",
    )
    walk.add_argument(
        "--clearance-m",
        type=float,
        default=0.05,
        metavar="H",
        help="mid-swing foot clearance h of the profile h sin^2(pi t/T), m (default: 0.05)",
    )
    walk.add_argument(
        "--objective",
        default="torque",
        choices=("torque", "torque-rate", "work"),
        help="integral of sum M^2 (default), of sum dM^2, or positive work",
    )
    walk.add_argument(
        "--rate-hz",
        type=positive("Hz", 1e5),
        default=1000.0,
        metavar="HZ",
        help="samples per second of the torque files, Hz (default: 1000)",
    )
    walk.add_argument("--steps", type=count_at_most(MAX_DRAWN_STEPS, "steps",
                      "the pictures repeat one step: a few show it"), default=2,
                      help=f"steps drawn in walk.png and walk.gif (default: 2, at most "
                           f"{MAX_DRAWN_STEPS})")  # fmt: skip
    walk.add_argument(
        "--output-dir",
        default=None,
        metavar="DIR",
        help="output folder (default: a new folder walk_<date>_<time> here); a folder of an "
        "earlier walk has its files replaced as a set, any other non-empty folder is refused",
    )
    walk.add_argument(
        "--feedback",
        action="store_true",
        help="design the feedback of the step (a periodic LQR through the heel strike, and "
        "the lift-off with --double-support-s, indexed by the hip's progress), write its gains "
        "into torques.csv (columns phase, K_<hinge>__<state>; the law in "
        "torques.csv.meta.json) and check the closed loop in the product's hybrid simulation "
        "and in MuJoCo: multipliers, open loop, 50 steps, mass +-10 %%, ground +-5 mm and "
        "+-1 cm, a start error, weaker drives, largest pushes (about two minutes; draws "
        "closed_loop.png and the pushed walk, closed_loop_walk.png and .gif)",
    )
    walk.add_argument(
        "--ground-friction",
        type=positive("", 100.0),
        default=1.0,
        metavar="MU",
        help="friction coefficient of the simulated ground of --feedback (default: 1.0; the "
        "plan runs along its own cone, --mu, right after heel strike, so the feedback needs a "
        "little more)",
    )
    walk.add_argument("--no-plots", action="store_true", help="write no PNG or GIF")
    walk.add_argument("--no-gif", action="store_true", help="write the PNGs but no GIF")
    walk.add_argument(
        "--quick",
        action="store_true",
        help="a coarse, fast run (N = 12, a short GIF): a smoke test of the whole job",
    )


# ---- helpers --------------------------------------------------------------------------------
def _linkage(name: str):
    if name not in PRESETS:
        raise UsageError(f"unknown preset {name!r}; choose one of: {', '.join(PRESETS)}")
    return PRESETS[name]()


def _in_option_words(message: str, options: dict[str, str]) -> str:
    """A library message with its parameter names (`rate_hz`, `GaitLaw.zeta[2]`) replaced
    by the command-line options they came from (--rate-hz, --zeta-rad value 3)."""

    def option(match: re.Match) -> str:
        name = options.get(match.group(1))
        if name is None:
            return match.group(0)
        return name if match.group(2) is None else f"{name} value {int(match.group(2)) + 1}"

    return re.sub(r"`(?:GaitLaw\.)?([A-Za-z_]+)(?:\[(\d+)\])?`", option, message)


#: GaitLaw fields and the options of 'torques' that set them.
_LAW_OPTIONS = {
    "period": "--period-s",
    "zeta": "--zeta-rad",
    "varpi": "--varpi-rad",
    "center": "--center-rad",
}


def _law(args, linkage):
    for option, values in (
        ("--zeta-rad", args.zeta_rad),
        ("--varpi-rad", args.varpi_rad),
        ("--center-rad", args.center_rad),
    ):
        if values is not None and len(values) != linkage.n:
            raise UsageError(
                f"{option}: expected {linkage.n} values (one per link of preset "
                f"{args.preset!r}), got {len(values)}"
            )
    for i, value in enumerate(args.zeta_rad or ()):
        if value < 0:
            raise UsageError(
                f"--zeta-rad: value {i + 1} is {value:g} rad, but an amplitude must be >= 0 "
                f"rad; give {-value:g} and add pi to value {i + 1} of --varpi-rad instead"
            )

    if args.law not in LAWS:
        raise UsageError(f"unknown gait law {args.law!r}; choose one of: {', '.join(LAWS)}")
    law = GaitLaw.preset(args.law)
    changes = {
        "period": args.period_s,
        "zeta": args.zeta_rad,
        "varpi": args.varpi_rad,
        "center": args.center_rad,
    }
    if any(v is not None for v in changes.values()):
        values = {
            "period": law.period,
            "zeta": law.zeta,
            "varpi": law.varpi,
            "center": law.center,
        }
        values.update({k: v for k, v in changes.items() if v is not None})
        try:
            law = GaitLaw(**values, name=f"{law.name} (modified)")
        except (DefinitionError, DefinitionTypeError) as exc:
            raise UsageError(_in_option_words(str(exc), _LAW_OPTIONS)) from exc
    return law


def _equations(linkage, latex: bool) -> str:
    return equations.equations_latex(linkage) if latex else equations.equations_text(linkage)


def _write_plots(dynamics, trajectory, folder: Path, stem: str, strip: bool, gif: bool, report):
    """PNG plots (and a GIF) of a trajectory; returns the paths written."""
    os.environ.setdefault("MPLBACKEND", "Agg")  # files only: no window, no display needed
    import matplotlib.pyplot as plt

    from model import drawing
    from planner import plots

    written = []
    with report.working(f"plotting {stem}.png"):
        figure = plots.plot_trajectory(trajectory, extras=True)
        figure.savefig(folder / f"{stem}.png", dpi=100)
        plt.close(figure)
    written.append(folder / f"{stem}.png")
    if strip:
        with report.working("plotting stick_figure.png"):
            figure = drawing.stick_figure_strip(dynamics, trajectory)
            figure.savefig(folder / "stick_figure.png", dpi=100)
            plt.close(figure)
        written.append(folder / "stick_figure.png")
    if gif:
        fps = 30  # drawing.animate's default: real-time playback
        frames = max(2, round(trajectory.duration * fps) + 1)
        path = folder / "animation.gif"
        with report.working(f"writing animation.gif ({frames} frames)"):
            drawing.animate(dynamics, trajectory, path, fps=fps)
        written.append(path)
    return written


def _save(trajectory, folder: Path, stem: str, formats) -> list[Path]:
    paths = []
    for fmt in formats:
        path = folder / f"{stem}.{fmt}"
        trajectory.save(path)
        paths.append(path)
    return paths


def _output_set(text: str, command: str) -> OutputSet:
    """The output folder of --output-dir as a set of files (:class:`OutputSet`): checked now
    (a new or empty folder, or an earlier run of the same command, whose files the run
    replaces as a set), written only when the run has results, nothing left on failure."""
    try:
        return OutputSet(Path(text), command)
    except OutputFolderError as error:
        raise UsageError(str(error)) from None


def _check_samples(count: int, force: bool, asked: str, fix: str, result: str) -> None:
    """Refuse more than LIMIT_SAMPLES samples without --force, more than MAX_SAMPLES ever."""
    if count > MAX_SAMPLES:
        raise UsageError(
            f"{asked} asks for {count:,} samples, more than the {MAX_SAMPLES:,} any command "
            f"makes; {fix}"
        )
    if count > LIMIT_SAMPLES and not force:
        raise UsageError(
            f"{asked} asks for {count:,} samples ({result}), more than {LIMIT_SAMPLES:,}; "
            f"{fix}, or add --force to go ahead"
        )


def _torque_table(trajectory, names: Sequence[str], out: TextIO) -> None:
    width = 10
    header = f"{'t (s)':>7}" + "".join(f"{'M_' + str(i + 1):>{width}}" for i in range(len(names)))
    print(header, file=out)
    for t, row in zip(trajectory.time, np.asarray(trajectory.torques), strict=True):
        print(f"{t:7.3f}" + "".join(f"{v:{width}.2f}" for v in row), file=out)


# ---- commands -------------------------------------------------------------------------------
def _cmd_equations(args, out: TextIO, report: Reporter) -> int:
    text = _equations(_linkage(args.preset), args.latex)
    if args.output:
        path = Path(args.output)
        try:
            # Atomic: a failed write (a full disk, a size limit) leaves no partial file.
            with atomic_path(path) as temporary, open(temporary, "w", encoding="utf-8") as handle:
                handle.write(text + "\n")
                handle.flush()
                os.fsync(handle.fileno())
        except OSError as exc:  # a file that cannot be written: status 1
            raise CommandFailed(
                f"--output: cannot write {args.output!r}: {exc.strerror or exc}"
            ) from exc
        print(f"wrote {args.output}", file=out)
    else:
        print(text, file=out)
    return 0


def _cmd_torques(args, out: TextIO, report: Reporter) -> int:
    linkage = _linkage(args.preset)
    law = _law(args, linkage)
    dynamics = Dynamics(linkage)
    duration = law.period if args.duration_s is None else args.duration_s
    count = max(2, math.ceil(duration * args.rate_hz - 1e-9) + 1)
    _check_samples(
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
    output = _output_set(args.output_dir, "torques")
    with output:
        with report.working(f"torques along {law.name!r}: {count} samples over {duration:g} s"):
            trajectory = torques_along(dynamics, law, np.linspace(0.0, duration, count))
            _save(trajectory, output.staging, "torques", args.formats)
        if not args.no_plots:
            _write_plots(dynamics, trajectory, output.staging, "torques", True, args.gif, report)
        written = output.commit({"argv": list(sys.argv[1:])})
    print(str(law), file=out)
    peak = np.max(np.abs(np.asarray(trajectory.torques)), axis=0)
    print(
        "max |M_i| (N m): " + ", ".join(f"M_{i + 1} {v:.2f}" for i, v in enumerate(peak)), file=out
    )
    for path in written:
        print(f"wrote {path}", file=out)
    return 0


def _load_profile(path_text: str):
    path = Path(path_text)
    if not path.exists():
        raise UsageError(f"torque file {path_text!r} does not exist")
    if path.is_dir():
        raise UsageError(f"torque file {path_text!r} is a folder, not a file")
    if path.suffix.lower() not in TRAJECTORY_FORMATS:
        raise UsageError(
            f"torque file {path_text!r}: unknown format {path.suffix!r}; use "
            f"{_one_of(TRAJECTORY_FORMATS)}"
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
_SIMULATE_OPTIONS = {
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


def _cmd_simulate(args, out: TextIO, report: Reporter) -> int:
    if args.method not in METHODS:
        raise UsageError(f"unknown --method {args.method!r}; choose one of: {', '.join(METHODS)}")
    linkage = _linkage(args.preset)
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
    _check_samples(
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
    output = _output_set(args.output_dir, "simulate")
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
        raise UsageError(_in_option_words(str(exc), _SIMULATE_OPTIONS)) from exc
    except SimulationError as exc:
        message = str(exc)
        for words, option_words in _FAILURE_WORDS:
            message = message.replace(words, option_words)
        raise CommandFailed(message) from exc
    with output:
        _save(result, output.staging, "simulated", args.formats)
        if not args.no_plots:
            _write_plots(dynamics, result, output.staging, "simulated", False, False, report)
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


def _cmd_demo(args, out: TextIO, report: Reporter) -> int:
    linkage = six_link_anthropoid()
    dynamics = Dynamics(linkage)
    if not args.no_equations:
        text = _equations(linkage, latex=False)  # before printing: a failure prints nothing
        print("Equations of motion of the six-link anthropoid (corrected (16)-(21)):", file=out)
        print(text, file=out)
        print(file=out)
    _check_samples(args.rows, args.force, f"--rows {args.rows}", "give fewer --rows", "a table")
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
    _torque_table(table, linkage.names, out)
    peak = np.max(np.abs(np.asarray(fine.torques)), axis=0)
    print(
        f"{'max|M|':>7}" + "".join(f"{v:10.2f}" for v in peak) + "   (over 1001 times in [0, T])",
        file=out,
    )
    return 0


def _new_folder(stem: str) -> Path:
    """A new folder ``<stem>_<date>_<time>`` (with a counter if taken) in the working dir."""
    base = f"{stem}_{time.strftime('%Y%m%d_%H%M%S')}"
    candidate, counter = Path(base), 1
    while candidate.exists():
        counter += 1
        candidate = Path(f"{base}_{counter}")
    return candidate


def _cmd_walk(args, out: TextIO, report: Reporter) -> int:
    if args.preset not in ("six-link", "five-link"):
        raise UsageError(f"--preset: {args.preset!r} is not a biped; use six-link or five-link")
    if not math.isfinite(args.clearance_m) or args.clearance_m < 0:
        raise UsageError(f"--clearance-m: must be a finite number >= 0 m, got {args.clearance_m}")
    if not math.isfinite(args.double_support_s) or not 0 <= args.double_support_s:
        raise UsageError(
            f"--double-support-s: must be a number >= 0 s, got {args.double_support_s}"
        )
    if args.degree is not None and args.transcription not in WITH_DEGREE:
        raise UsageError(f"--degree: applies to --transcription {_one_of(WITH_DEGREE)} only")
    samples = math.ceil(args.step_time_s * args.rate_hz - 1e-9) + 1
    _check_samples(
        samples,
        args.force,
        f"--rate-hz {args.rate_hz:g} Hz x --step-time-s {args.step_time_s:g} s",
        "lower --rate-hz",
        f"files of about {samples * 2 * 600 / 1e6:,.0f} MB",
    )
    preset = args.accuracy if isinstance(args.accuracy, str) else None
    target = args.accuracy if isinstance(args.accuracy, float) else None
    if preset is not None:
        given = [
            option
            for option, value in (
                ("-N", args.intervals),
                ("--transcription", args.transcription),
                ("--degree", args.degree),
            )
            if value is not None
        ]
        if given:
            raise UsageError(
                f"--accuracy {preset}: the preset sets the mesh; drop {', '.join(given)} (or "
                "give a number to --accuracy to refine from that mesh)"
            )
        mesh = {"accuracy": preset}
    else:
        mesh = {
            "N": args.intervals or (12 if args.quick else 30),
            "transcription": args.transcription or "hermite-simpson",
            "degree": args.degree,
        }
    if target is not None and args.double_support_s > 0:
        raise UsageError(
            "--accuracy: a refinement target needs a single support; with --double-support-s "
            "give a preset or -N"
        )
    sole = (args.foot_heel_m, args.foot_toe_m)
    if (sole[0] is None) != (sole[1] is None):
        raise UsageError("--foot-heel-m, --foot-toe-m: give both (the sole behind and ahead of "
                         "the ankle) or neither")  # fmt: skip
    if sole[0] is not None and sole[0] + sole[1] <= 0:
        raise UsageError("--foot-heel-m, --foot-toe-m: the sole must be longer than 0 m; for a "
                         "point foot give --passive-ankle")  # fmt: skip
    linkage = _linkage(args.preset)
    output = _output_set(str(args.output_dir or _new_folder("walk")), "walk")
    report.step(f"defining the walking step of {args.preset} ({linkage.n} links)")
    extra = {}
    if sole[0] is not None:
        extra["foot"] = sole
    if args.touchdown_speed_mps is not None:
        extra["touchdown_speed"] = args.touchdown_speed_mps
    step = walking_step(
        linkage,
        args.step_length_m,
        args.step_time_s,
        **mesh,
        formulation=args.formulation,
        mu=args.mu,
        torque_limit=args.torque_limit_nm,
        passive=(linkage.names[0],) if args.passive_ankle else (),
        clearance=args.clearance_m,
        objective=args.objective,
        double_support=args.double_support_s,
        ground_margin=args.ground_margin_m,
        **extra,
    )
    last = [-math.inf]

    def iteration(row) -> None:
        now = time.perf_counter()
        if now - last[0] >= 1.0:
            last[0] = now
            report.step(
                f"  IPOPT iteration {row['iteration']}: objective {row['objective']:.6g}, "
                f"max violation {row['infeasibility']:.2e}"
            )

    scheme = step.ocp.transcription + (f"({step.ocp.degree})" if step.ocp.degree else "")
    doing = f"solving with IPOPT ({scheme}, N = {step.ocp.N}"
    doing += f", refining to {target:g})" if target is not None else ")"
    with report.working(doing), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", AccuracyWarning)
        try:
            gait = step.solve(
                progress=iteration,
                raise_on_failure=False,
                accuracy=target,
                rate_hz=args.rate_hz,
            )
        except SampleLimitError as error:
            raise CommandFailed(
                f"the plan's limits could not be held at every sample: {error}; nothing written"
            ) from None
    solution = gait.solution
    stats = solution.stats
    history = stats.get("refinement")
    accuracy = stats.get("accuracy")
    objective_words = {
        "torque": "integral of sum M_i^2, N^2 m^2 s",
        "torque-rate": "integral of sum dM_i^2 (+ 1e-3 sum M_i^2)",
        "work": f"positive work (+ {WORK_REGULARISATION / args.torque_limit_nm:.3g} sum M_i^2), J",
    }[args.objective]
    phases = f", double support {step.double_support:g} s" if step.double_support > 0 else ""
    single = gait.segments()[0][0]
    scheme = single.scheme.label
    if preset is not None:
        chosen = ACCURACY_PRESETS[preset]
        scheme += f" (accuracy {preset}: tol {chosen.tol:g}, stated torque error <= "
        scheme += f"{chosen.torque_error:g} N m)"
    # The mesh solved first (the refinement's last, or the one asked for); the limits held
    # between the points may cut intervals of it (said below).
    planned = history.sizes[-1] if history is not None else step.ocp.N
    print(
        f"walking step of {args.preset}: {step.step_length:g} m in {step.step_time:g} s "
        f"({step.speed:.3g} m/s){phases}, {scheme} N = {planned}"
        + (" (refined mesh)" if history is not None else "")
        + f", {args.formulation}",
        file=out,
    )
    if history is not None:
        for line in history.table().splitlines():
            print(f"  {line}", file=out)
    held = stats.get("sampled_limits")
    rounds = held["rounds"] if held is not None else []
    first = rounds[0] if rounds else {
        "iterations": solution.iterations,
        "build_seconds": stats["build_seconds"],
        "solve_seconds": stats["solve_seconds"],
    }  # fmt: skip
    print(
        f"IPOPT: {solution.status} in {first['iterations']} iterations; build "
        f"{first['build_seconds']:.3f} s, solve {first['solve_seconds']:.3f} s"
        + ("" if history is None else f" (last pass; all passes {history.seconds:.3f} s)"),
        file=out,
    )
    if not solution.success:
        raise CommandFailed(f"IPOPT did not converge: {solution.status}; nothing written")
    if held is not None:
        again = rounds[1:]
        split = sum(r.get("split", 0) for r in rounds)
        raised = sum(r.get("raised", 0) for r in rounds)
        words = (
            "they hold without a re-solve"
            if not again
            else f"{raised} interval bounds backed off"
            + (f", {split} intervals cut in two (N = {single.N})" if split else "")
            + f" in {len(again)} warm re-solve{'s' if len(again) > 1 else ''} "
            f"({sum(r['iterations'] for r in again)} iterations, "
            f"{sum(r['build_seconds'] + r['solve_seconds'] for r in again):.3f} s)"
        )
        print(
            f"limits on the exported motion at {args.rate_hz:g} Hz and between the samples: "
            f"{words}",
            file=out,
        )
    print(
        f"cost ({objective_words}): {gait.cost:.6g}; the gait law (22) fitted to the step, "
        f"same mesh: {gait.law_cost:.6g} ({gait.law_cost / gait.cost:.3g}x the optimum)",
        file=out,
    )
    impact = gait.impact
    peaks = ", ".join(
        f"{name} {value:.1f}" for name, value in gait.summary()["peak_torque"].items()
    )
    print(
        f"cost of transport {gait.cost_of_transport:.4f} (positive work "
        f"{gait.positive_work:.2f} J per step); peak |M| (N m): {peaks}",
        file=out,
    )
    after = (
        "both feet stay on the ground"
        if step.double_support > 0
        else f"the old stance foot lifts off at ({impact['lift_off'][0]:.3f}, "
        f"{impact['lift_off'][1]:.3f}) m/s"
    )
    touchdown = gait.touchdown_velocity
    print(
        f"heel strike: the foot lands at ({touchdown.real:.3f}, {touchdown.imag:.3f}) m/s "
        f"(at least {step.touchdown_speed:g} m/s down), impulse ({impact['impulse'][0]:.3f}, "
        f"{impact['impulse'][1]:.3f}) N s, {after}",
        file=out,
    )
    low, high = gait.centre_of_pressure(args.rate_hz)
    if args.passive_ankle:
        sole_words = "a passive ankle (a point foot: no ankle torque)"
    elif step.foot_sole is None:
        sole_words = "no sole given"
    else:
        heel, toe = step.foot_sole
        sole_words = f"the sole from {-1000 * heel:.0f} to {1000 * toe:.0f} mm"
    print(
        f"centre of pressure of the stance foot (M / Fy from the ankle, every sample): "
        f"{1000 * low:.1f} .. {1000 * high:.1f} mm; {sole_words}",
        file=out,
    )
    if accuracy is not None:
        worst = accuracy["state"]
        nominal = single.ocp.variable_scale(worst) if worst in single.state_names else 1.0
        unit = (
            single.system.state_units[single.state_names.index(worst)]
            if worst in single.state_names
            else ""
        )
        print(
            f"accuracy: largest per-interval re-integration error "
            f"{accuracy['error'] * nominal:.2e} {unit} ({worst}, interval "
            f"{accuracy['interval']}; {accuracy['error']:.2e} of its nominal scale {nominal:g} "
            f"{unit}, the units of --accuracy)",
            file=out,
        )
    for warning in caught:
        if issubclass(warning.category, AccuracyWarning):
            report.warn(
                f"the plan obeys its dynamics only to {accuracy['error']:.2g} of a state's "
                "nominal scale between the mesh points (more than "
                f"{accuracy['threshold']:g}): refine the mesh with a larger -N, --accuracy "
                "balanced or --accuracy 1e-3"
            )
    if history is not None and not history.reached:
        raise CommandFailed(
            f"the accuracy target {target:g} was not reached: {history.reason}; nothing written"
        )
    # Everything goes to a staging folder first and replaces the output folder as a set once
    # the file the drives read has been read back and verified.
    feedback = None
    if args.feedback:
        from problems.walking_feedback import design_feedback

        with report.working("designing the feedback (a periodic LQR through the step's events)"):
            feedback = design_feedback(gait, ground_mu=args.ground_friction)
    with output:
        with report.working(f"writing torques at {args.rate_hz:g} Hz and the solution"):
            profile = gait.to_trajectory(args.rate_hz)
            if feedback is not None:
                profile = feedback.channels(profile)
            written = _save(profile, output.staging, "torques", ("csv", "json"))
            _save(gait.to_trajectory(), output.staging, "solution", ("npz",))
        with report.working("verifying torques.csv (numpy, independent of the planner)"):
            check = verify_gait(LinkageTrajectory.load(written[0]), linkage)
        dynamics = check.facts.get("dynamics residual", math.nan)
        print(
            f"torques.csv: {profile.n_samples} samples at {args.rate_hz:g} Hz of the consistent "
            f"motion (positions integrate the velocities, accelerations are their slope); its "
            f"torques are the inverse dynamics of its own motion to {dynamics:.1e} N m",
            file=out,
        )
        failed = "" if check.ok else " - FAILED: " + "; ".join(c.name for c in check.failures)
        print(
            f"verification of torques.csv ({profile.n_samples} samples, numpy, independent of "
            f"the planner): {'all' if check.ok else 'NOT all'} {len(check.checks)} checks "
            f"passed{failed}; worst margins (> 0 inside):",
            file=out,
        )
        for line in _check_lines(check):
            print(f"  {line}", file=out)
        for key in ("rates",):
            if key in check.facts:
                print(f"  {key}: {check.facts[key]}", file=out)
        if not check.ok:
            raise CommandFailed(
                f"torques.csv failed its verification: {check.failures[0]}; nothing written"
            )
        closed = None
        if feedback is not None:
            closed = _closed_loop(feedback, report, out)
        if not args.no_plots:
            from problems import walking_plots

            with report.working("plotting gait.png"):
                walking_plots.save_figure(walking_plots.gait_figure(gait), output.path("gait.png"))
            motion = gait.world(steps=args.steps, rate_hz=30.0 if args.quick else 60.0)
            with report.working("plotting walk.png"):
                walking_plots.save_figure(walking_plots.world_strip(motion),
                                          output.path("walk.png"))  # fmt: skip
            if not args.no_gif:
                with report.working(f"writing walk.gif ({args.steps} steps)"):
                    fps = 15.0 if args.quick else 30.0
                    walking_plots.animate_walk(motion, output.path("walk.gif"), fps=fps)
            if closed is not None:
                with report.working("plotting closed_loop.png"):
                    walking_plots.save_figure(walking_plots.closed_loop_figure(closed),
                                              output.path("closed_loop.png"))  # fmt: skip
                _draw_pushed_walk(closed, gait.problem.dynamics, output, args.no_gif, report)
        paths = output.commit({"argv": list(sys.argv[1:]), "verification": "passed"})
    for path in paths:
        print(f"wrote {path}", file=out)
    return 0


def _closed_loop(feedback, report, out):
    """Run and print the closed-loop check of ``walk --feedback``; returns it."""
    from problems.walking_feedback import closed_loop_check

    weights = feedback.gains.weights
    events = (
        "the heel strike"
        if feedback.double is None
        else "the held heel strike and the lift-off (a law for each support; torques.csv's "
        "double_support column says which)"
    )
    print(
        f"feedback: periodic LQR through {events} at {feedback.control_rate_hz:g} Hz "
        f"(Bryson weights: {weights.angle:g} rad, {weights.rate:g} rad/s, {weights.torque:g} "
        f"N m), designed in {feedback.design_seconds:.2f} s; torques.csv carries its gains "
        f"({len(feedback.names) * 2 * len(feedback.names)} columns K_<hinge>__<state>, N m/rad "
        "and N m s/rad) and the phase; the law is in torques.csv.meta.json",
        file=out,
    )
    with report.working("checking the closed loop (the product's hybrid simulation)"):
        check = closed_loop_check(feedback)
    multipliers = ", ".join(f"{abs(m):.3f}" for m in check.loop.multipliers[:3])
    print(
        f"closed loop, simulated (pinned stance foot, rigid impacts, ground friction "
        f"{feedback.plant.mu:g}): largest Floquet multipliers |lambda| {multipliers} "
        f"(stable below 1); open loop (the plan's torques alone): largest |lambda| "
        f"{abs(check.open_loop_multipliers[0]):.3g} linearised along the plan, and simulated: "
        f"{check.open_loop.fell or 'walked'}",
        file=out,
    )
    _print_runs(out, check.runs, check.steps, [
        ("peak |M| N m", 12, lambda steps: f"{max(r.peak_torque for r in steps):.1f}"),
        ("tracking rad", 12, lambda steps: f"{max(r.tracking for r in steps):.2e}"),
    ])  # fmt: skip
    forward, back = check.pushes
    print(
        f"  largest push on the torso's centre of mass at mid-step that it walks 10 more steps "
        f"after: forward {forward:.1f} N s, back {back:.1f} N s (bisection to 0.5 N s)",
        file=out,
    )
    if feedback.double is not None:
        print(
            "MuJoCo: not run for a step with a double support (its front foot rebounds off "
            "MuJoCo's soft ground at touchdown, and the closed chain's law pulls on a foot that "
            "is not held: open work)",
            file=out,
        )
        return check
    try:
        import mujoco  # noqa: F401 - only whether the extra is there
    except ImportError:
        print('MuJoCo: not installed (pip install ".[mujoco]"): no run in MuJoCo', file=out)
        return check
    from problems.walking_mujoco import mujoco_check

    with report.working("walking in MuJoCo (feet with soles, soft contacts)"):
        engine = mujoco_check(feedback)
    print(
        f"MuJoCo (the same body and the file's law at {feedback.control_rate_hz:g} Hz; feet "
        "with soles, soft contacts; planned stance Fy at most "
        f"{engine.planned_normal:.0f} N):",
        file=out,
    )
    _print_runs(out, engine.runs, engine.steps, [
        ("peak |M| N m", 12, lambda steps: f"{max(r.peak_torque for r in steps):.1f}"),
        ("slip mm", 8, lambda steps: f"{1000 * max(r.slip for r in steps):.1f}"),
        ("peak Fy N", 9, lambda steps: f"{max(r.peak_normal for r in steps):.0f}"),
        ("tracking rad", 12, lambda steps: f"{max(r.tracking for r in steps):.2e}"),
    ])  # fmt: skip
    forward, back = engine.pushes
    print(
        f"  largest push survived in MuJoCo: forward {forward:.1f} N s, back {back:.1f} N s",
        file=out,
    )
    return check


def _draw_pushed_walk(closed, dynamics, output, no_gif: bool, report) -> None:
    """closed_loop_walk.png (and .gif): the simulated closed-loop walk that survived the
    largest forward push, in world coordinates."""
    from problems import walking_plots
    from problems.walking_feedback import PUSH_STEPS

    run = closed.push_runs[0]
    motion = run.world(dynamics, rate_hz=60.0)
    what = (
        f"closed loop, simulated: a forward push of {closed.pushes[0]:.1f} N s on the torso "
        f"in step 2 (the largest survived), {run.walked}/{PUSH_STEPS} steps"
    )
    with report.working("plotting closed_loop_walk.png"):
        figure = walking_plots.world_strip(motion, frames_per_step=3, title=what)
        walking_plots.save_figure(figure, output.path("closed_loop_walk.png"))
    if not no_gif:
        with report.working(f"writing closed_loop_walk.gif ({run.walked} steps)"):
            walking_plots.animate_walk(
                motion,
                output.path("closed_loop_walk.gif"),
                fps=20.0,
                caption=f"push {closed.pushes[0]:.1f} N s in step 2; ",
                window=2.5,
            )


def _print_runs(out, runs: dict, steps: int, columns) -> None:
    """A table of simulated walks: case, steps walked, the ranges of step time and length,
    then ``columns`` ((header, width, steps -> text)); a fall's reason after the row."""
    print(
        f"  {'case':<14} {'steps':>7} {'step time s':>15} {'step length m':>15} "
        + " ".join(f"{header:>{width}}" for header, width, _ in columns),
        file=out,
    )
    for label, run in runs.items():
        walked = f"{run.walked}/{steps}"
        if not run.steps:
            print(f"  {label:<14} {walked:>7}  fell: {run.fell}", file=out)
            continue
        times = [r.duration for r in run.steps]
        lengths = [r.length for r in run.steps]
        cells = " ".join(f"{cell(run.steps):>{width}}" for _, width, cell in columns)
        print(
            f"  {label:<14} {walked:>7} {min(times):7.4f}..{max(times):6.4f} "
            f"{min(lengths):7.4f}..{max(lengths):6.4f} {cells}"
            + (f"  fell: {run.fell}" if run.fell else ""),
            file=out,
        )


def _check_lines(report) -> list[str]:
    """One line per check of a verification: name, worst margin with its unit, where, how
    many values, the tolerance."""
    lines = []
    for c in report.checks:
        verdict = "ok  " if c.passed else "FAIL"
        lines.append(
            # + 0.0: a margin of -0.0 (an exact match) prints as +0.00e+00
            f"{verdict} {c.name:<19} {c.margin + 0.0:+.2e} {c.unit:<9} at {c.where} "
            f"({c.samples} values, tolerance {c.tolerance:.0e})"
        )
    return lines


COMMANDS = {
    "walk": _cmd_walk,
    "study": study_cli.command,
    "equations": _cmd_equations,
    "torques": _cmd_torques,
    "simulate": _cmd_simulate,
    "demo": _cmd_demo,
}


class _ReportHandler(logging.Handler):
    """Log records as the Reporter's progress lines (the planner's IPOPT iterations)."""

    def __init__(self, report: Reporter) -> None:
        super().__init__(logging.INFO)
        self._report = report

    def emit(self, record: logging.LogRecord) -> None:
        try:
            self._report.step(record.getMessage())
        except Exception:  # a broken stream must not break the solve
            self.handleError(record)


@contextlib.contextmanager
def _solver_progress(report: Reporter, enabled: bool) -> Iterator[None]:
    """While a command runs, show what ``planner.solve(progress=True)`` logs (one line per
    IPOPT iteration on the ``planner.progress`` logger) on stderr, unless --quiet."""
    if not enabled:
        yield
        return
    logger = logging.getLogger("planner.progress")
    handler = _ReportHandler(report)
    level = logger.level
    logger.addHandler(handler)
    if not logger.isEnabledFor(logging.INFO):
        logger.setLevel(logging.INFO)
    try:
        yield
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line with ``argv`` (default: sys.argv[1:]); returns the exit status.

    0 success, 1 a computation failed, 2 bad input (usage, file, parameter). Results go to
    sys.stdout, progress and errors to sys.stderr (looked up at call time, so a caller can
    redirect them).
    """
    out, err = sys.stdout, sys.stderr
    argv = list(sys.argv[1:] if argv is None else argv)
    command = next((a for a in argv if a in COMMANDS), None)
    where = f"{PROG} {command}" if command else PROG
    parser = build_parser()
    try:
        try:
            args = parser.parse_args(argv)
        except SystemExit as exc:  # --help and --version exit through argparse
            return int(exc.code or 0)
        report = Reporter(err, enabled=not args.quiet, where=where)
        with _solver_progress(report, enabled=not args.quiet):
            return COMMANDS[args.command](args, out, report)
    except BrokenPipeError:
        # The reader went away (``... | head``): stop quietly, as Unix tools do.
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError, AttributeError):  # stdout without a file descriptor
            pass
        return 1
    except (UsageError, DefinitionError, DefinitionTypeError) as exc:
        # Bad input; a library definition error that the command did not reword itself
        # still names what was wrong.
        print(f"{where}: error: {_first_line(exc)}", file=err)
        return 2
    except (CommandFailed, AnthropoidError, OSError) as exc:
        # A failed computation (SimulationError, a solver failure) or a file that could not
        # be written. Anything else is a bug and keeps its traceback.
        print(f"{where}: error: {_first_line(exc)}", file=err)
        return 1


def _first_line(exc: BaseException) -> str:
    if isinstance(exc, OSError) and exc.strerror:
        return f"{exc.filename!r}: {exc.strerror}" if exc.filename else exc.strerror
    text = str(exc).strip().splitlines()
    return text[0] if text else type(exc).__name__
