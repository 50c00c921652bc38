"""Direct-collocation optimal control of planar linkages (and any CasADi ODE) on IPOPT.

``planner.plots`` (matplotlib) is imported on demand: ``from planner import plots``.

>>> from planner import OCP
>>> solution = OCP(dynamics, T=1.0, N=50).bound("M", -100, 100).periodic().minimize(
...     integral=lambda p: ca.sumsqr(p.M)).solve()
"""

from planner.accuracy_check import ACCURACY_WARNING, AccuracyWarning, check_accuracy_of
from planner.ocp import Point
from planner.phase_transcription import PhaseTranscription
from planner.phases import EventPoint
from planner.phases_solution import PhasesSolution
from planner.problem import OCP, Phases
from planner.refinement import RefinementError, RefinementHistory, RefinementPass, refine_to
from planner.sampled_limits import SampleLimitError, hold_at_samples, sample_misses
from planner.schemes import TRANSCRIPTIONS, Scheme, make_scheme
from planner.solution import IntegrationError, Replay, Solution
from planner.solver import SolverError, solve
from planner.system import System, SystemSource
from planner.trajectory import Trajectory
from planner.transcription import Transcription

__all__ = [
    "ACCURACY_WARNING",
    "OCP",
    "TRANSCRIPTIONS",
    "AccuracyWarning",
    "EventPoint",
    "IntegrationError",
    "PhaseTranscription",
    "Phases",
    "PhasesSolution",
    "Point",
    "RefinementError",
    "RefinementHistory",
    "RefinementPass",
    "Replay",
    "SampleLimitError",
    "Scheme",
    "Solution",
    "SolverError",
    "System",
    "SystemSource",
    "Trajectory",
    "Transcription",
    "check_accuracy_of",
    "hold_at_samples",
    "make_scheme",
    "refine_to",
    "sample_misses",
    "solve",
]
