"""What the commands share: the output layer (Reporter, errors), option types with their
units, the limits that keep a run short, and the helpers that write a command's files."""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import os
import re
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from model.linkage_trajectory import LinkageTrajectory
from model.presets import PRESETS
from planner.errors import DefinitionError, DefinitionTypeError
from planner.refinement import check_accuracy
from planner.simulation import tolerance_problem
from planner.trajectory import FORMATS as TRAJECTORY_FORMATS
from problems.cli.output_set import OutputFolderError, OutputSet
from problems.gait.accuracy import ACCURACY_PRESETS
from problems.gait.law import LAW_PRESETS, GaitLaw
from problems.gait.verification import verify_gait
from problems.robot import joint_space

#: The help of --preset, for every command that takes one.
PRESET_HELP = f"linkage preset, one of: {', '.join(PRESETS)} (default: six-link)"


PROG = "anthropoid-planner"
#: File formats of --formats: the trajectory package's suffixes, without the dot.
FORMATS = tuple(suffix.lstrip(".") for suffix in TRAJECTORY_FORMATS)
LAWS = tuple(LAW_PRESETS)
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


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread as Ctrl-C is (:func:`problems.cli.program.main`):
    a run stopped by ``kill`` (a job scheduler, a timeout) removes its staged output and
    ends with status 143, where Python's default would end it on the spot and leave its
    files half-staged."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (no usage dump) raised instead of exiting, and no
    abbreviated options (``--step-length`` is no prefix of ``--step-length-m``: one
    spelling of each option)."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # type: ignore[override]
        raise UsageError(f"{message} (see {self.prog} --help)")


def _own_descriptor(stream: TextIO) -> TextIO:
    """``stream`` written through a duplicate of its file descriptor, when it has one: the
    planner captures descriptor 2 process-wide for the instant a solver is built
    (``planner.native_output.captured``), and a progress line written meanwhile from another
    thread would otherwise be caught there and logged back as something IPOPT wrote."""
    try:
        descriptor = os.dup(stream.fileno())
    except (AttributeError, OSError, ValueError, io.UnsupportedOperation):
        return stream  # a stream without a descriptor (a test's buffer) is not captured
    encoding = getattr(stream, "encoding", None) or "utf-8"
    return open(descriptor, "w", encoding=encoding, errors="replace", buffering=1)


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
        self._stream = _own_descriptor(stream)
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


def one_of(items: Sequence[str]) -> str:
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


def tolerance(text: str) -> float:
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


def accuracy_option(text: str) -> str | float:
    """--accuracy: a preset name, or a refinement target (a number in [1e-9, 1))."""
    if text in ACCURACY_PRESETS:
        return text
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a preset ({one_of(tuple(ACCURACY_PRESETS))}) or a refinement target "
            f"such as 1e-5, got {text!r}"
        ) from None
    try:
        return check_accuracy(value)
    except DefinitionError as error:
        raise argparse.ArgumentTypeError(str(error).replace("`accuracy`: ", "")) from None


def non_negative(unit: str) -> Callable[[str], float]:
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a number in {unit}, got {text!r}") from None
        if not math.isfinite(value) or value < 0:
            raise argparse.ArgumentTypeError(f"must be a finite number >= 0 {unit}, got {text!r}")
        return value

    return parse


def _comma_list(text: str, convert, refusal: str) -> tuple:
    """``text``'s comma-separated parts, each through ``convert``; ``refusal`` (its
    ``{text}`` the text as given) when one does not convert."""
    try:
        return tuple(convert(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(refusal.format(text=repr(text))) from None


def angles(text: str) -> tuple[float, ...]:
    values = _comma_list(text, float, "expected comma-separated numbers in rad, one per link, "
                         "got {text}")  # fmt: skip
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"must be finite numbers in rad, got {text!r}")
    return values


def speeds_option(text: str) -> tuple[float, ...]:
    """A comma-separated list of speeds, m/s (each a finite number >= 0)."""
    values = _comma_list(text, float, "give speeds in m/s separated by commas, e.g. "
                         "0,1.0,1.4,0.6,0; got {text}")  # fmt: skip
    if len(values) < 2 or not all(math.isfinite(v) and v >= 0 for v in values):
        raise argparse.ArgumentTypeError(
            f"give two or more speeds >= 0 m/s, e.g. 0,1.0,0; got {text!r}"
        )
    return values


def counts_option(text: str) -> tuple[int, ...]:
    """A comma-separated list of step counts (each an integer >= 0; 0: searched)."""
    values = _comma_list(text, int, "give step counts separated by commas, 0 where searched, "
                         "e.g. 5,2,0,1; got {text}")  # fmt: skip
    if any(v < 0 for v in values):
        raise argparse.ArgumentTypeError(f"give step counts >= 0 (0: searched); got {text!r}")
    return values


def formats_option(text: str) -> tuple[str, ...]:
    items = tuple(dict.fromkeys(f.strip().lower().lstrip(".") for f in text.split(",") if f))
    unknown = [f for f in items if f not in FORMATS]
    if unknown or not items:
        raise argparse.ArgumentTypeError(
            f"unknown format(s) {unknown or [text]}; choose from {', '.join(FORMATS)}"
        )
    return items


# ---- parser -------------------------------------------------------------------------------
def output_options(command: argparse.ArgumentParser, folder: str, formats: tuple[str, ...]) -> None:
    """--output-dir, --formats and --no-plots of a command that writes files."""
    command.add_argument(
        "--output-dir",
        default=folder,
        metavar="DIR",
        help=f"output folder (created; default: {folder})",
    )
    command.add_argument(
        "--formats",
        type=formats_option,
        default=formats,
        metavar="LIST",
        help=f"comma-separated file formats among {', '.join(FORMATS)} "
        f"(default: {','.join(formats)})",
    )
    command.add_argument("--no-plots", action="store_true", help="write no PNG plots")


# ---- helpers --------------------------------------------------------------------------------
def preset_linkage(name: str):
    if name not in PRESETS:
        raise UsageError(f"unknown preset {name!r}; choose one of: {', '.join(PRESETS)}")
    return PRESETS[name]()


def in_option_words(message: str, options: dict[str, str]) -> str:
    """A library message with its parameter names (`rate_hz`, `GaitLaw.zeta[2]`) replaced
    by the command-line options they came from (--rate-hz, --zeta-rad value 3)."""

    def option(match: re.Match) -> str:
        name = options.get(match.group(1))
        if name is None:
            return match.group(0)
        return name if match.group(2) is None else f"{name} value {int(match.group(2)) + 1}"

    return re.sub(r"`(?:GaitLaw\.)?([A-Za-z_]+)(?:\[(\d+)\])?`", option, message)


#: GaitLaw fields and the options of 'torques' that set them.
LAW_OPTIONS = {
    "period": "--period-s",
    "zeta": "--zeta-rad",
    "varpi": "--varpi-rad",
    "center": "--center-rad",
}


def gait_law_of(args, linkage):
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
            raise UsageError(in_option_words(str(exc), LAW_OPTIONS)) from exc
    return law


def write_plots(dynamics, trajectory, folder: Path, stem: str, strip: bool, gif: bool, report):
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


def save_trajectory(trajectory, folder: Path, stem: str, formats) -> list[Path]:
    paths = []
    for fmt in formats:
        path = folder / f"{stem}.{fmt}"
        trajectory.save(path)
        paths.append(path)
    return paths


def phase_starts(profile) -> list[tuple[str, float]]:
    """(phase, start s) of a multi-phase file (its metadata["phases"]), or [] for one phase."""
    return [(p["name"], float(p["start"])) for p in profile.metadata.get("phases", [])]


def sample_grid(times, rate_hz: float, phases=None) -> str:
    """What the samples of a file are, in words: "501 samples every 1 ms from t = 0"; with
    ``phases`` [(name, start s), ...] of a multi-phase plan (its metadata["phases"]), the grid
    restarts at each phase's start (a uniform grid per phase: where two phases meet, the
    interval before the join is shorter), and the words say so."""
    times = np.asarray(times, dtype=float)
    step = f"every {1e3 / rate_hz:g} ms"
    if not phases or len(phases) < 2:
        return f"{times.size} samples {step} from t = 0"
    starts = ", ".join(f"{name} {start:.4g} s" for name, start in phases)
    return f"{times.size} samples {step} from the start of each phase ({starts})"


def with_robot(profile, args):
    """``profile`` with the robot of ``walk --urdf`` in its metadata (``robot``: the URDF's
    path, the sides, each joint's URDF name and encoder), read by the joint-space view."""
    walker = getattr(args, "walker", None)
    if walker is None:
        return profile
    return profile.with_metadata(robot=walker.metadata(str(args.urdf)))


def write_step_files(gait, channels, output, args, report):
    """A planned step's files, staged in ``output``: torques.csv and .json at --rate-hz
    (``channels``: the feedback's columns added, or None; the robot of --urdf in the
    metadata), solution.npz (the nodes), torques.csv read back and verified (numpy,
    independent of the planner). Returns (the profile written, its check, torques.csv)."""
    with report.working(f"writing torques at {args.rate_hz:g} Hz and the solution"):
        profile = gait.to_trajectory(args.rate_hz)
        if channels is not None:
            profile = channels(profile)
        profile = with_robot(profile, args)
        written = save_trajectory(profile, output.staging, "torques", ("csv", "json"))
        save_trajectory(gait.to_trajectory(), output.staging, "solution", ("npz",))
    with report.working("verifying torques.csv (numpy, independent of the planner)"):
        check = verify_gait(LinkageTrajectory.load(written[0]), gait.problem.linkage)
    return profile, check, written[0]


def write_joint_space(torques_csv: Path, output, legs: tuple[str, str], out) -> None:
    """The robot's view of the torque file read back from disk (``problems.robot``): one
    stride, ``legs`` = (the leg in stance in the planned step, the other), staged as
    joints.csv with its sidecar, and one line on ``out`` saying what it holds."""
    view = joint_space(LinkageTrajectory.load(torques_csv), sides=tuple(legs))
    save_joint_view(view, output, out, f"one stride ({view.time.size} samples, the {legs[0]} "
                    "leg in stance first)")  # fmt: skip


def save_joint_view(view, output, out, what: str) -> None:
    """A joint-space view (``problems.robot.JointSpace``) staged in ``output`` as joints.csv
    with its sidecar, a line on ``out`` saying what it holds (``what``: of what, in words)
    and its URDF limits' lines."""
    view.save(output.path("joints.csv"))
    peaks = ", ".join(f"{j['name']} {j['peak_N_m']:.1f}" for j in view.metadata["joints"])
    print(
        f"joints.csv: the robot's view of {what}: joint angles q_, rates dq_, accelerations "
        f"ddq_ (0 standing, flexion and dorsiflexion positive), each physical drive's torque "
        f"tau_ (N m, the sense that grows q), the ground's force and torque ground_; peak "
        f"|tau| (N m): {peaks}",
        file=out,
    )
    for line in robot_limit_lines(view.metadata):
        print(line, file=out)


#: a planned peak this far past a URDF limit is on it (the solver's bounds hold to ~1e-8 of
#: their scale at the nodes, the 1 kHz samples between them to the verification's 1e-4)
LIMIT_TOLERANCE_N_M = 1e-3
LIMIT_TOLERANCE_RAD = 1e-6


def robot_limit_lines(metadata) -> list[str]:
    """The joints of a URDF's robot whose planned torque or range exceeds the URDF's
    <limit> (from joints.csv's sidecar), one line each, or one line saying none does."""
    checked, over = 0, []
    for joint in metadata["joints"]:
        effort = joint.get("urdf_effort_N_m")
        if effort is not None:
            checked += 1
            # the plan holds its bounds to IPOPT's tolerance: a peak at the limit is on it
            if joint["peak_N_m"] > effort + LIMIT_TOLERANCE_N_M:
                over.append(f"  {joint['name']} ({joint['urdf_joint']}): peak |tau| "
                            f"{joint['peak_N_m']:.1f} N m > its effort limit {effort:g} "
                            "N m")  # fmt: skip
        if "urdf_range_rad" in joint:
            low, high = joint["urdf_range_rad"]
            first, last = joint["range_in_file_rad"]
            if first < low - LIMIT_TOLERANCE_RAD or last > high + LIMIT_TOLERANCE_RAD:
                over.append(f"  {joint['name']} ({joint['urdf_joint']}): q {first:.3f}.."
                            f"{last:.3f} rad outside its URDF range {low:.3f}..{high:.3f} rad "
                            "(file terms)")  # fmt: skip
    if not checked and not over:
        return []
    if not over:
        return [f"the URDF's joint limits: every planned torque and angle within them ({checked} "
                "joints)"]  # fmt: skip
    return ["the URDF's joint limits: exceeded by", *over]


def legs_option(text: str) -> tuple[str, str]:
    """--legs RIGHT,LEFT: two different names (letters, digits, _)."""
    names = tuple(part.strip() for part in text.split(","))
    if len(names) != 2 or names[0] == names[1] or not all(n.isidentifier() for n in names):
        raise argparse.ArgumentTypeError(
            f"give two different leg names, the one in stance first, e.g. right,left; got {text!r}"
        )
    return names


def check_clearance(value: float | None) -> None:
    """--clearance-m: None (the walker's scaled default) or a finite number >= 0."""
    if value is not None and (not math.isfinite(value) or value < 0):
        raise UsageError(f"--clearance-m: must be a finite number >= 0 m, got {value}")


def output_set(text: str, command: str) -> OutputSet:
    """The output folder of --output-dir as a set of files (:class:`OutputSet`): checked now
    (a new or empty folder, or an earlier run of the same command, whose files the run
    replaces as a set), written only when the run has results, nothing left on failure."""
    try:
        return OutputSet(Path(text), command)
    except OutputFolderError as error:
        raise UsageError(str(error)) from None


def check_samples(count: int, force: bool, asked: str, fix: str, result: str) -> None:
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


def torque_table(trajectory, names: Sequence[str], out: TextIO) -> None:
    width = 10
    header = f"{'t (s)':>7}" + "".join(f"{'M_' + str(i + 1):>{width}}" for i in range(len(names)))
    print(header, file=out)
    for t, row in zip(trajectory.time, np.asarray(trajectory.torques), strict=True):
        print(f"{t:7.3f}" + "".join(f"{v:{width}.2f}" for v in row), file=out)


def new_folder(stem: str) -> Path:
    """A new folder ``<stem>_<date>_<time>`` (with a counter if taken) in the working dir."""
    base = f"{stem}_{time.strftime('%Y%m%d_%H%M%S')}"
    candidate, counter = Path(base), 1
    while candidate.exists():
        counter += 1
        candidate = Path(f"{base}_{counter}")
    return candidate


def write_walk_pictures(figure, gait, output, args, report) -> None:
    """The walk command's pictures into ``output``: gait.png (``figure``, the gait's figure),
    walk.png and walk.gif (``args.steps`` steps in world coordinates; coarser with
    ``args.quick``; no GIF with ``args.no_gif``)."""
    from problems.walking import plots as walking_plots

    with report.working("plotting gait.png"):
        walking_plots.save_figure(figure, output.path("gait.png"))
    motion = gait.world(steps=args.steps, rate_hz=30.0 if args.quick else 60.0)
    with report.working("plotting walk.png"):
        walking_plots.save_figure(walking_plots.world_strip(motion), output.path("walk.png"))
    if not args.no_gif:
        with report.working(f"writing walk.gif ({args.steps} steps)"):
            fps = 15.0 if args.quick else 30.0
            walking_plots.animate_walk(motion, output.path("walk.gif"), fps=fps)


def print_verification(check, samples: int, out) -> None:
    """Print the verification of torques.csv (``check``: a ``problems.GaitReport`` of the
    file read back, ``samples`` rows): a summary line, then one line per check (name, worst
    margin with its unit, where, how many values, the tolerance) and the facts that say
    what was not checked; raise :class:`CommandFailed` when a check failed (nothing is
    written then)."""
    failed = "" if check.ok else " - FAILED: " + "; ".join(c.name for c in check.failures)
    print(
        f"verification of torques.csv ({samples} samples, numpy, independent of the planner): "
        f"{'all' if check.ok else 'NOT all'} {len(check.checks)} checks passed{failed}; worst "
        "margins (> 0 inside):",
        file=out,
    )
    for c in check.checks:
        verdict = "ok  " if c.passed else "FAIL"
        # + 0.0: a margin of -0.0 (an exact match) prints as +0.00e+00
        print(
            f"  {verdict} {c.name:<19} {c.margin + 0.0:+.2e} {c.unit:<9} at {c.where} "
            f"({c.samples} values, tolerance {c.tolerance:.0e})",
            file=out,
        )
    if "rates" in check.facts:
        print(f"  rates: {check.facts['rates']}", file=out)
    if not check.ok:
        raise CommandFailed(
            f"torques.csv failed its verification: {check.failures[0]}; nothing written"
        )


def print_runs(out, runs: dict, steps: int, columns) -> None:
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


def print_mujoco_runs(out, runs: dict, steps: int, pushes) -> None:
    """The table of walks in MuJoCo (:func:`print_runs` with the drives' peak, the stance
    foot's slip and normal force, the tracking error) and the largest pushes survived
    ((forward, back) N s, or None: the undisturbed closed loop fell, no margin; False: not
    measured)."""
    print_runs(out, runs, steps, [
        ("peak |M| N m", 12, lambda steps: f"{max(r.peak_torque for r in steps):.1f}"),
        ("slip mm", 8, lambda steps: f"{1000 * max(r.slip for r in steps):.1f}"),
        ("peak Fy N", 9, lambda steps: f"{max(r.peak_normal for r in steps):.0f}"),
        ("tracking rad", 12, lambda steps: f"{max(r.tracking for r in steps):.2e}"),
    ])  # fmt: skip
    if pushes is False:
        return
    if pushes is None:
        print("  no push margin: the undisturbed closed loop fell", file=out)
        return
    print(
        f"  largest push survived in MuJoCo: forward {pushes[0]:.1f} N s, back {pushes[1]:.1f} N s",
        file=out,
    )
