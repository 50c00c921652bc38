"""An honest success: a converged solve whose plan does not obey its own dynamics warns.

IPOPT's "Solve_Succeeded" says the NLP is solved, not that the motion it describes is what
the dynamics do between the mesh points. A coarse mesh can converge to a plan whose
intervals, integrated from their start with the plan's torques, end far from the next node
(a 3 s swing-up of the two-link chain at N = 40: cost 41.3 against 37.4 converged, each
interval missing by up to 0.35 rad/s). :func:`check_accuracy_of` measures the largest
per-interval re-integration error of every state divided by its nominal scale (the units of
``OCP.solve(accuracy=...)``: 1 rad for angles, the problem's rate scale for rates) and warns
with :class:`AccuracyWarning` when it exceeds ``threshold`` (default :data:`ACCURACY_WARNING`),
naming the state, the interval and the fix. :func:`planner.solve` calls it after every
successful solve (``accuracy_warning=None`` turns it off); the result goes to
``solution.stats["accuracy"]``.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from planner.errors import AnthropoidError, check_positive
from planner.phases_solution import PhasesSolution
from planner.simulation import SimulationError

#: Largest per-interval re-integration error per nominal state scale of a solve that does not
#: warn: 1 % (0.03 rad/s on the walking step's 3 rad/s rates; its default mesh, N = 30, has
#: 0.12 %, the --quick N = 12 has 2 %).
ACCURACY_WARNING = 1e-2


class AccuracyWarning(UserWarning):
    """A solve converged, but its plan does not obey its dynamics to the threshold between
    the mesh points: refine the mesh (a larger N, ``accuracy="balanced"``, or
    ``solve(accuracy=1e-3)`` to refine until the error is within a target)."""


def check_accuracy_of(solution, threshold: float | None = ACCURACY_WARNING) -> dict[str, Any]:
    """Measure ``solution``'s largest scaled re-integration error (every phase of a
    PhasesSolution) and warn with :class:`AccuracyWarning` when it exceeds ``threshold``.

    Returns {"error": largest error / nominal scale, "state", "interval", "phase" (index),
    "threshold", "warned"} and stores it in ``solution.stats["accuracy"]``. A
    re-integration that fails (the interval's motion diverges) counts as an error of inf.
    """
    if threshold is not None:
        threshold = check_positive("accuracy_warning", threshold)
    phases = solution.phases if isinstance(solution, PhasesSolution) else [solution]
    worst: dict[str, Any] = {"error": 0.0, "state": "", "interval": 0, "phase": 0}
    for k, phase in enumerate(phases):
        scales = np.array([phase.ocp.variable_scale(n) for n in phase.state_names])
        try:
            errors = phase.integration_error().per_interval / scales
        except (SimulationError, AnthropoidError) as error:
            worst = {"error": np.inf, "state": f"({error})", "interval": 0, "phase": k}
            break
        if errors.size and errors.max() > worst["error"]:
            interval, state = np.unravel_index(np.argmax(errors), errors.shape)
            worst = {
                "error": float(errors.max()),
                "state": phase.state_names[int(state)],
                "interval": int(interval),
                "phase": k,
            }
    worst["threshold"] = threshold
    worst["warned"] = bool(threshold is not None and worst["error"] > threshold)
    solution.stats["accuracy"] = worst
    if worst["warned"]:
        where = f"interval {worst['interval']}" + (
            f" of phase {worst['phase']}" if isinstance(solution, PhasesSolution) else ""
        )
        warnings.warn(
            f"the solve converged, but its plan does not obey its dynamics between the mesh "
            f"points: re-integrated, {where} misses its end by {worst['error']:.2g} of the "
            f"nominal scale of {worst['state']} (more than {threshold:g}); refine the mesh: "
            "a larger N, an accuracy preset, or solve(accuracy=1e-3)",
            AccuracyWarning,
            stacklevel=3,
        )
    return worst


__all__ = ["ACCURACY_WARNING", "AccuracyWarning", "check_accuracy_of"]
