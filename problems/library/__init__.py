"""A walker's day: gait libraries (periodic steps over speed with their feedback, one file,
the lookup by commanded speed: ``build_library``, ``GaitLibrary``), the steps between gaits
(start from standing, speed changes, stop: ``plan_transition``) and whole walks through
commanded speeds as one verified file (``plan_sequence``, ``verify_sequence``)."""

from problems.library.build import build_library
from problems.library.library import GaitLibrary, LibraryGait
from problems.library.sequence import WalkSequence, plan_sequence, verify_sequence
from problems.library.transition import STANDING, Transition, plan_transition

__all__ = [
    "STANDING",
    "GaitLibrary",
    "LibraryGait",
    "Transition",
    "WalkSequence",
    "build_library",
    "plan_sequence",
    "plan_transition",
    "verify_sequence",
]
