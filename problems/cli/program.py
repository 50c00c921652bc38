"""The program: the parser of every command, the dispatch, and the exit statuses.

Each command is one module of this package with ``add_parser(commands, common, limits)`` and
``run(args, out, report) -> exit status``; :data:`COMMANDS` maps the names to them.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import re
import signal
import sys
import threading
from collections.abc import Iterator, Sequence

from planner.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from problems.cli import (
    compare_gait,
    demo,
    drives,
    equations,
    library,
    simulate,
    study,
    torques,
    track_gait,
    walk,
)
from problems.cli.common import (
    LIMIT_SAMPLES,
    LIMIT_SECONDS,
    MAX_SAMPLES,
    PROG,
    CommandFailed,
    Parser,
    Reporter,
    Terminated,
    UsageError,
)


def build_parser() -> argparse.ArgumentParser:
    """The command line's parser (every option documented with its unit)."""
    parser = Parser(
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
    commands = parser.add_subparsers(dest="command", metavar="<command>", parser_class=Parser)
    commands.required = True

    for command in (walk, study, library, drives, compare_gait, track_gait, equations, torques,
                    simulate, demo):  # fmt: skip
        command.add_parser(commands, common, limits)
    return parser


COMMANDS = {
    "walk": walk.run,
    "study": study.run,
    "library": library.run,
    "drives": drives.run,
    "compare-gait": compare_gait.run,
    "track-gait": track_gait.run,
    "equations": equations.run,
    "torques": torques.run,
    "simulate": simulate.run,
    "demo": demo.run,
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


def _terminate(signum, frame) -> None:
    raise Terminated


@contextlib.contextmanager
def _terminated_as_interrupted() -> Iterator[None]:
    """While a command runs, SIGTERM raises :class:`Terminated` (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line with ``argv`` (default: sys.argv[1:]); returns the exit status.

    0 success, 1 a computation failed, 2 bad input (usage, file, parameter), 130 stopped by
    Ctrl-C, 143 by SIGTERM (nothing half-written left either way). Results go to
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
        with _terminated_as_interrupted(), _solver_progress(report, enabled=not args.quiet):
            return COMMANDS[args.command](args, out, report)
    except Terminated:
        print(f"{where}: terminated (SIGTERM); nothing of this run was written", file=err)
        return 143
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
    return abridged(text[0]) if text else type(exc).__name__


#: A quoted value or a run of digits this long is abridged in an error line.
LONGEST_ECHO = 120
_QUOTED = re.compile(rf"'([^']{{{LONGEST_ECHO},}})'")
_DIGITS = re.compile(rf"[0-9][0-9,_]{{{LONGEST_ECHO},}}")


def abridged(line: str) -> str:
    """An error line whose echo of what was typed stays readable: a quoted value or a
    number of more than :data:`LONGEST_ECHO` characters keeps its first 40 and says how
    long it was (``--steps 999...`` with 5,000 digits was echoed whole)."""
    line = _QUOTED.sub(lambda m: f"'{m.group(1)[:40]}...' ({len(m.group(1)):,} characters)", line)
    return _DIGITS.sub(lambda m: f"{m.group(0)[:40]}... ({len(m.group(0)):,} characters)", line)
