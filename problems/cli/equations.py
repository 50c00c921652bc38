"""'equations': print the equations of motion of a preset linkage, as text or LaTeX."""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import TextIO

from model import equations
from planner.files import atomic_path
from problems.cli.common import PRESET_HELP, CommandFailed, Reporter, preset_linkage


def equations_text(linkage, latex: bool) -> str:
    return equations.equations_latex(linkage) if latex else equations.equations_text(linkage)


# ---- commands -------------------------------------------------------------------------------
def run(args, out: TextIO, report: Reporter) -> int:
    text = equations_text(preset_linkage(args.preset), args.latex)
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


def add_parser(commands, common: argparse.ArgumentParser, limits: argparse.ArgumentParser) -> None:
    """The 'equations' command's parser."""
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
    equations.add_argument("--preset", default="six-link", metavar="NAME", help=PRESET_HELP)
    equations.add_argument("--latex", action="store_true", help="LaTeX instead of plain text")
    equations.add_argument(
        "--output", metavar="FILE", help="write to FILE instead of stdout (overwritten)"
    )
