"""A recorded gait cycle from a file, whichever layout it is in."""

from __future__ import annotations

from pathlib import Path

from planner.errors import DefinitionError
from problems.human.recording import GaitRecording, read_csv
from problems.human.winter import read_winter


def read_recording(path: str | Path, **options) -> GaitRecording:
    """A recorded gait cycle from ``path``: Winter's appendix workbook (.xlsx,
    :func:`problems.human.winter.read_winter`, ``options`` go there) or the CSV layout of
    :mod:`problems.human.recording`."""
    path = Path(path)
    if path.suffix.lower() == ".xlsx":
        return read_winter(path, **options)
    if options:
        raise DefinitionError(f"`options`: a CSV recording takes none, got {sorted(options)}")
    return read_csv(path)
