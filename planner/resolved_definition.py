"""What a transcription reads of a problem definition, resolved once.

A :class:`planner.phase_transcription.PhaseTranscription` needs of its
:class:`planner.ocp.OCPDefinition` the system, the mesh, every variable's bounds and nominal
scale, the constraints sorted by where they hold with their nominal scales, the back-off
margins, the objective's terms split into integral and terminal parts, the static
parameters' Point fields and the guesses. :meth:`ResolvedDefinition.of` reads all of them in
one pass, so that the transcription asks its definition once instead of returning to it for
every variable, row and margin (the definition stays the one place that knows the rules:
later scales override earlier ones, bounds give scales, the system's nominal magnitudes fill
in). The value is immutable: arrays are read-only copies.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from planner.ocp import Constraint, ObjectiveTerm, parameter_fields
from planner.schemes import Scheme, make_scheme
from planner.system import System

if TYPE_CHECKING:
    from planner.guesses import GuessLayer
    from planner.ocp import OCPDefinition


def _frozen(array) -> np.ndarray:
    out = np.array(array, dtype=float)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class ResolvedDefinition:
    """A definition's numbers and expressions as a transcription reads them.

    Scales are nominal magnitudes in each variable's units (the NLP works with v / scale);
    bounds are physical; margins are (lower (N, rows), upper (N, rows), at_ends) of
    ``OCP.back_off``; ``constraint_scales`` maps each constraint's name to its (rows,) scales.
    """

    #: The definition this was read from (solutions keep it; the transcription reads this).
    definition: OCPDefinition
    system: System
    scheme: Scheme
    N: int
    #: Interval lengths as fractions of T, or None for a uniform mesh.
    mesh: tuple[float, ...] | None
    free_time: bool
    #: The fixed duration, s, or the (lower, upper) bounds of a free one.
    T: float | tuple[float, float]
    duration_guess: float
    #: The nominal scale of a free duration (the middle of its bounds), 1 when fixed.
    T_scale: float
    #: Every variable's (lower, upper) bounds, physical units (+-inf when unbounded).
    bounds: dict[str, tuple[float, float]]
    #: Every variable's nominal scale.
    scales: dict[str, float]
    state_scale: np.ndarray  # (nx,)
    control_scale: np.ndarray  # (nu,)
    aux_scale: np.ndarray  # (nz,)
    #: The scales of the dynamics residual's rows (the scales of the group the system names).
    residual_scale: np.ndarray  # (nz,)
    path: tuple[Constraint, ...]
    boundary: tuple[Constraint, ...]
    instant: tuple[Constraint, ...]
    constraint_scales: dict[str, np.ndarray]
    margins: dict[str, tuple[np.ndarray, np.ndarray, bool]]
    objective: tuple[ObjectiveTerm, ...]
    integral_terms: tuple[ObjectiveTerm, ...]
    terminal_terms: tuple[ObjectiveTerm, ...]
    objective_scale: float | None
    param_names: tuple[str, ...]
    guesses: tuple[GuessLayer, ...]
    #: name -> the variable names behind it (a variable or a group), for guesses.
    resolve: Callable[..., tuple[str, ...]]

    @classmethod
    def of(cls, ocp: OCPDefinition) -> ResolvedDefinition:
        """Read ``ocp`` once."""
        system = ocp.system
        names = system.variable_names
        scales = {n: ocp.variable_scale(n) for n in names}

        def scale_array(members) -> np.ndarray:
            return _frozen([scales[n] for n in members])

        state_scale = scale_array(system.state_names)
        members = system.group(system.residual_scale_group)
        residual_scale = (
            state_scale
            if members is None or members == system.state_names
            else scale_array(members)
        )
        constraints = ocp.constraints
        return cls(
            definition=ocp,
            system=system,
            scheme=make_scheme(ocp.transcription, ocp.degree),
            N=ocp.N,
            mesh=ocp.mesh,
            free_time=ocp.free_time,
            T=ocp.T,
            duration_guess=ocp.duration_guess,
            T_scale=float(np.mean(ocp.T)) if ocp.free_time else 1.0,
            bounds={n: ocp.variable_bounds(n) for n in names},
            scales=scales,
            state_scale=state_scale,
            control_scale=scale_array(system.control_names),
            aux_scale=scale_array(system.aux_names),
            residual_scale=residual_scale,
            path=tuple(c for c in constraints if c.where == "path"),
            boundary=tuple(c for c in constraints if c.where in ("start", "end")),
            instant=tuple(c for c in constraints if c.where == "at"),
            constraint_scales={c.name: _frozen(ocp.constraint_scale(c)) for c in constraints},
            margins={name: (lo, hi, at_ends) for name, lo, hi, at_ends in ocp.margins},
            objective=ocp.objective,
            integral_terms=tuple(t for t in ocp.objective if t.integral is not None),
            terminal_terms=tuple(t for t in ocp.objective if t.terminal is not None),
            objective_scale=ocp.objective_scale,
            param_names=ocp.param_names,
            guesses=ocp.guesses,
            resolve=ocp.resolve,
        )

    @property
    def n_params(self) -> int:
        return len(self.param_names)

    def param_fields(self, values) -> dict[str, Any]:
        """The Point fields of the static parameters from ``values`` (n_params,)."""
        return parameter_fields(self.param_names, values)

    def bounds_of(self, names) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) (len(names),) physical bounds of the variables ``names``."""
        pairs = [self.bounds[n] for n in names]
        return (
            np.array([p[0] for p in pairs], dtype=float),
            np.array([p[1] for p in pairs], dtype=float),
        )
