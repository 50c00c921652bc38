"""The project's one sampled-trajectory / torque-profile type and its files.

One concept per module:

* :mod:`planner.trajectory.value`: :class:`Trajectory` (samples of states, controls and
  derived channels on a time grid; interpolation, resampling) and :class:`ControlFunction`;
* :mod:`planner.trajectory.channels`: :class:`Channels`, what the formats and the plot read
  of a trajectory;
* :mod:`planner.trajectory.formats`: the CSV, JSON and NPZ files (``FORMATS``), written
  atomically and read back bit for bit;
* :mod:`planner.trajectory.checks`: validation of arrays, channel names, units, metadata;
* :mod:`planner.trajectory.errors`: the errors.

The interpolation kernels are :mod:`planner.interpolation`. Used by ``planner.Solution``
and by ``problems.torques_along`` / ``problems.simulate``. The trajectory knows no linkage:
``model.LinkageTrajectory`` (a subclass) reads a linkage's channels as angles and torques.
"""

from planner.trajectory.errors import (
    TrajectoryError,
    TrajectoryFileError,
    TrajectoryFileNotFoundError,
    TrajectoryWriteError,
)
from planner.trajectory.formats import FORMAT_NAME, FORMAT_VERSION, FORMATS
from planner.trajectory.value import ControlFunction, Trajectory

__all__ = [
    "FORMATS",
    "FORMAT_NAME",
    "FORMAT_VERSION",
    "ControlFunction",
    "Trajectory",
    "TrajectoryError",
    "TrajectoryFileError",
    "TrajectoryFileNotFoundError",
    "TrajectoryWriteError",
]
