"""Drives: what each of a walker's drives must deliver (torque, speed, power, work) over a
duty cycle of planned steps (:func:`drive_requirements`), and the torque-speed plane a drive
engineer reads (:func:`requirements_figure`)."""

from problems.drives.plots import requirements_figure
from problems.drives.requirements import (
    DriveRequirement,
    DriveRequirements,
    Plan,
    drive_requirements,
)

__all__ = [
    "DriveRequirement",
    "DriveRequirements",
    "Plan",
    "drive_requirements",
    "requirements_figure",
]
