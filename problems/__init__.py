"""Ready problems built on the model and the planner.

* :class:`GaitLaw`: the seed paper's walking law (22) with a centre angle per link.
* :func:`torques_along`: the first problem of dynamics (torques along a law).
* :func:`simulate`: the second problem of dynamics (motion under given torques).
* :func:`replay_law`: both together, with the deviation from the law measured.
* :func:`periodic_gait`: the paper's periodic gait on a pinned stance foot, optimised.
* :func:`walking_step`: the hybrid walking step (single support, heel strike, leg swap).
* :data:`ACCURACY_PRESETS`: "draft", "balanced", "precise" for both gait problems
  (``accuracy=``), chosen from ``examples/benchmarks/speed_accuracy.py``.
* :func:`verify_gait`: a gait checked again in numpy from its samples.
* :class:`Study` / :func:`run_study`: walking studies over a grid of values, with warm starts,
  resumable, on a process pool or a Dask cluster (:class:`StudyResult` reads a study folder).

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
from problems.gait.accuracy import ACCURACY_PRESETS, AccuracyPreset
from problems.gait.biped import Biped
from problems.gait.law import LAW_PRESETS, GaitLaw
from problems.gait.problem import OBJECTIVES, Gait
from problems.gait.verification import (
    Check,
    GaitReport,
    GaitVerificationError,
    GaitVerificationWarning,
    verify_gait,
)
from problems.pinned.gait import KEYPOINTS, PeriodicGait, PeriodicGaitProblem, periodic_gait
from problems.study.result import StudyProgress, StudyResult
from problems.study.study import Study, run_study
from problems.walking.footed import FootedGait, FootedStep, footed_step, footed_step_at
from problems.walking.step import WalkingGait, WalkingStep, WorldMotion, walking_step

__all__ = [
    "ACCURACY_PRESETS",
    "FIT_WINDOW",
    "KEYPOINTS",
    "LAW_PRESETS",
    "MAX_OUTPUT_SAMPLES",
    "METHODS",
    "MIN_TOLERANCE",
    "OBJECTIVES",
    "AccuracyPreset",
    "Biped",
    "Check",
    "FootedGait",
    "FootedStep",
    "Gait",
    "GaitLaw",
    "GaitReport",
    "GaitVerificationError",
    "GaitVerificationWarning",
    "PeriodicGait",
    "PeriodicGaitProblem",
    "ReplayReport",
    "SimulationError",
    "Study",
    "StudyProgress",
    "StudyResult",
    "WalkingGait",
    "WalkingStep",
    "WorldMotion",
    "fit_growth_rate",
    "footed_step",
    "footed_step_at",
    "law_torque_function",
    "periodic_gait",
    "replay_law",
    "run_study",
    "simulate",
    "torques_along",
    "upright_instability_rate",
    "verify_gait",
    "versions",
    "walking_step",
]
