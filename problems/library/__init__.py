"""Gait libraries: periodic steps over speed with their feedback, one file, and the lookup by
commanded speed (``build_library``, ``GaitLibrary``)."""

from problems.library.build import build_library
from problems.library.library import GaitLibrary, LibraryGait

__all__ = ["GaitLibrary", "LibraryGait", "build_library"]
