"""Drives: what each of a walker's drives must deliver (torque, speed, power, work) over a
duty cycle of planned steps (:func:`drive_requirements`), the torque-speed plane a drive
engineer reads (:func:`requirements_figure`), motors and gearboxes from catalogue files
(:func:`read_motors`, :func:`read_gearboxes`, :class:`Drive`) and the choice of each drive's
(:func:`select`); steps planned with the drives in the loop (:func:`drives_in_the_loop`,
:func:`with_drives`, :func:`motor_report`, :func:`replan`) and gear ratios designed with the
gait (:func:`codesign_ratios`) and parallel springs beside them designed in the gait's NLP
(:class:`ParallelSpring`)."""

from problems.drives.catalogue import Drive, Gearbox, Motor, read_gearboxes, read_motors
from problems.drives.codesign import CoDesign, codesign_ratios
from problems.drives.loop import (
    DrivenWalker,
    drives_in_the_loop,
    energy_per_step,
    motor_report,
    with_drives,
)
from problems.drives.plots import requirements_figure
from problems.drives.replan import replan
from problems.drives.requirements import (
    DriveRequirement,
    DriveRequirements,
    DriveStep,
    Plan,
    drive_requirements,
)
from problems.drives.selection import DriveSelectionError, Selection, require, select
from problems.drives.springs import ParallelSpring, spring_values

__all__ = [
    "CoDesign",
    "Drive",
    "DriveRequirement",
    "DriveRequirements",
    "DriveSelectionError",
    "DriveStep",
    "DrivenWalker",
    "Gearbox",
    "Motor",
    "ParallelSpring",
    "Plan",
    "Selection",
    "codesign_ratios",
    "drive_requirements",
    "drives_in_the_loop",
    "energy_per_step",
    "motor_report",
    "read_gearboxes",
    "read_motors",
    "replan",
    "require",
    "requirements_figure",
    "select",
    "spring_values",
    "with_drives",
]
