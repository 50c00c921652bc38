"""The problems a user builds and solves: :class:`OCP` and :class:`Phases`.

Each is its definition (a value with validating builders: :class:`planner.ocp.OCPDefinition`,
:class:`planner.phases.PhasesDefinition`) plus the steps that need the layers built on the
definitions: ``transcribe()`` (the NLP, :mod:`planner.transcription`) and ``solve()`` (IPOPT,
:mod:`planner.solver`). The definitions live below the transcription and the solver, which
read them; these two classes live above, so every import inside ``planner`` runs one way:

    schemes, simulation, trajectory, ... -> solution -> phases_solution -> guesses -> ocp
        -> phases -> phase_transcription -> transcription -> solver -> refinement
        -> problem

A single OCP is a problem of one phase: both transcribe through the one
:class:`planner.transcription.Transcription`.

Builders return the class they are called on (``dataclasses.replace``), so a chain started
from ``OCP(...)`` or ``Phases.sequence(...)`` stays solvable.
"""

from __future__ import annotations

from planner.ocp import OCPDefinition
from planner.phases import PhasesDefinition
from planner.phases_solution import PhasesSolution
from planner.refinement import refine_to
from planner.solution import Solution
from planner.solver import solve
from planner.transcription import Transcription


class OCP(OCPDefinition):
    """An optimal control problem (:class:`planner.ocp.OCPDefinition` for the parameters and
    builders) that transcribes and solves itself."""

    def transcribe(self, expand: bool | None = None) -> Transcription:
        """The NLP of this OCP (:class:`planner.transcription.Transcription`), built now."""
        return Transcription(self, expand=expand)

    def solve(self, accuracy: float | None = None, **kwargs) -> Solution:
        """Transcribe and solve; see :func:`planner.solver.solve` for the keyword arguments.

        ``accuracy`` (a number): refine the mesh until the per-interval re-integration
        error of every state, divided by its nominal scale, is within it
        (:func:`planner.refinement.refine_to`, which takes ``max_passes`` and
        ``max_intervals`` too); the Solution's ``stats["refinement"]`` holds the passes.
        """
        if accuracy is None:
            return solve(self, **kwargs)
        return refine_to(self, accuracy, **kwargs)


class Phases(PhasesDefinition):
    """A multi-phase problem (:class:`planner.phases.PhasesDefinition` for the builders) that
    transcribes and solves itself."""

    def transcribe(self, expand: bool | None = None) -> Transcription:
        """The NLP of these phases (:class:`planner.transcription.Transcription`), built now."""
        return Transcription(self, expand=expand)

    def solve(self, **options) -> PhasesSolution:
        """Transcribe and solve with IPOPT (:func:`planner.solver.solve`'s options)."""
        return solve(self, **options)


__all__ = ["OCP", "Phases"]
