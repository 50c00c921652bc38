"""Ready problems built on the model and the planner.

* :class:`GaitLaw`: the seed paper's walking law (22) with a centre angle per link.
* :func:`torques_along`: the first problem of dynamics (torques along a law).
* :func:`simulate`: the second problem of dynamics (motion under given torques).
* :func:`replay_law`: both together, with the deviation from the law measured.

The command line is ``python -m problems`` (see ``problems.cli``).
"""

from problems.dynamics_problems import (
    FIT_WINDOW,
    MAX_OUTPUT_SAMPLES,
    METHODS,
    MIN_TOLERANCE,
    ReplayReport,
    SimulationError,
    fit_growth_rate,
    law_torque_function,
    replay_law,
    simulate,
    torques_along,
    upright_instability_rate,
    versions,
)
from problems.gait_law import LAW_PRESETS, GaitLaw

__all__ = [
    "FIT_WINDOW",
    "LAW_PRESETS",
    "MAX_OUTPUT_SAMPLES",
    "METHODS",
    "MIN_TOLERANCE",
    "GaitLaw",
    "ReplayReport",
    "SimulationError",
    "fit_growth_rate",
    "law_torque_function",
    "replay_law",
    "simulate",
    "torques_along",
    "upright_instability_rate",
    "versions",
]
