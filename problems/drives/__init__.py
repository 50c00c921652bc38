"""Drives: what each of a walker's drives must deliver (torque, speed, power, work) over a
duty cycle of planned steps (:func:`drive_requirements`), the torque-speed plane a drive
engineer reads (:func:`requirements_figure`), motors and gearboxes from catalogue files
(:func:`read_motors`, :func:`read_gearboxes`, :class:`Drive`) and the choice of each drive's
(:func:`select`)."""

from problems.drives.catalogue import Drive, Gearbox, Motor, read_gearboxes, read_motors
from problems.drives.plots import requirements_figure
from problems.drives.requirements import (
    DriveRequirement,
    DriveRequirements,
    DriveStep,
    Plan,
    drive_requirements,
)
from problems.drives.selection import DriveSelectionError, Selection, require, select

__all__ = [
    "Drive",
    "DriveRequirement",
    "DriveRequirements",
    "DriveSelectionError",
    "DriveStep",
    "Gearbox",
    "Motor",
    "Plan",
    "Selection",
    "drive_requirements",
    "read_gearboxes",
    "read_motors",
    "require",
    "requirements_figure",
    "select",
]
