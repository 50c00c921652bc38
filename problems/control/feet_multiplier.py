"""The footed closed loop's dominant Floquet multiplier, from how a deviation dies out.

The walk on feet under its law (:class:`problems.control.feet_law.FeetLaw`) in the product's
simulation (:mod:`problems.control.feet_simulation`) is a hybrid system whose stride map is
only piecewise smooth: the compliant ground switches (touchdowns, stick and slip, the
dampers' clipping) on a scale finer than any useful difference, so a Jacobian by differences
of the map is noise (measured: at perturbations of 1e-4 and 1e-5 of each state's scale the
two differed by more than themselves). What the loop does with a deviation is not: pushed
once, the walk's states on a Poincare section (:func:`problems.control.feet_simulation.
section_states`, the single support's phase 0.3 in the law's labels) come back to the
unpushed walk's by a factor a step that is the stride map's largest multiplier |lambda_1| (a
deviation's component along the slowest mode outlives the others: power iteration, the map
run by the physics). The estimate is the geometric mean of the ratios of successive
distances between the two walks, over the steps after the others have died out and before
the distance reaches the simulation's own noise.

At the file's 1 kHz clock the law detects the strike and the hand-over up to a period late,
which kicks every step by up to a period's worth: the walk never settles (its steps' durations
spread over 6 ms after 20 steps, examples/benchmarks/feet_simulation.py table 6) and the
distance stalls at that noise. The estimate therefore runs the law on a faster clock
(``rate_hz``, default 16 kHz, one integration step a period): the loop the file's law
approaches as its clock shrinks, whose deviation dies out geometrically.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.errors import DefinitionError, check_integer, check_positive, check_real
from problems.control.feet_law import FeetLaw
from problems.control.feet_simulation import section_states, simulate_feet
from problems.control.simulation import Disturbances

#: s: the weight of a rate against an angle in the section's distance (rad + s * rad/s)
RATE_WEIGHT = 0.1
#: the distance below which the two walks are within the simulation's own noise at 16 kHz
#: (its steps' changes from one to the next, measured: 1e-3 rad/s)
NOISE = 2e-3


@dataclass(frozen=True)
class MultiplierEstimate:
    """The estimate (``modulus``, |lambda_1| per step) and what it rests on: the distances
    (steps,) between the pushed and the unpushed walk on the section (rad, rates weighted by
    :data:`RATE_WEIGHT` s), the ratios (used,) of successive distances that were averaged
    (geometric mean), their spread (the largest |log ratio - log modulus|), the push (N s,
    its step), the clock (Hz) and the phase of the section."""

    modulus: float
    distances: np.ndarray
    ratios: np.ndarray
    spread: float
    push: float
    push_step: int
    rate_hz: float
    phase: float


def dominant_multiplier(
    gait,
    *,
    law: FeetLaw | None = None,
    push: float = 3.0,
    steps: int = 24,
    rate_hz: float = 16000.0,
    phase: float = 0.3,
    settle: int = 2,
) -> MultiplierEstimate:
    """|lambda_1| of the walk on feet of ``gait`` (a solved periodic step on feet) under
    ``law`` (default ``FeetLaw(gait)``), from a ``push`` (N s on the torso, in the middle of
    step 1) against the unpushed walk, ``steps`` steps each at ``rate_hz``: the geometric
    mean of the ratios of successive distances on the section at ``phase``, from ``settle``
    steps after the push's to the last whose distance is above :data:`NOISE`. Raises
    :class:`planner.DefinitionError` when the unpushed walk falls (no periodic walk to
    measure from), when the pushed one does (a smaller push) or when fewer than three ratios
    lie above the noise (a larger push, or more steps)."""
    check_real("push", push)
    if push == 0.0:
        raise DefinitionError("`push`: 0 N s moves nothing to measure; give e.g. 3.0")
    steps = check_integer("steps", steps, 6)
    settle = check_integer("settle", settle, 1)
    rate_hz = check_positive("rate_hz", rate_hz, "Hz")
    law = FeetLaw(gait) if law is None else law
    walks = []
    for disturbances in (None, Disturbances(push=push, push_step=1)):
        run = simulate_feet(gait, steps=steps, law=law, substeps=1, rate_hz=rate_hz,
                            disturbances=disturbances)  # fmt: skip
        if run.fell is not None and disturbances is None:
            raise DefinitionError(
                f"`gait`: its walk under the law falls unpushed ({run.fell}): the loop has no "
                "periodic walk to measure a deviation from"
            )
        if run.fell is not None:
            raise DefinitionError(
                f"`push`: {push:g} N s; the pushed walk fell ({run.fell}): give a smaller push"
            )
        walks.append(section_states(run, law, phase))
    n = law.step.linkage.n
    weights = np.r_[np.ones(n), np.full(n, RATE_WEIGHT)]
    distances = np.linalg.norm((walks[1] - walks[0]) * weights, axis=1)
    first = 2 + settle  # step 1 pushed mid-step: its section (at 0.3) is before the push
    above = np.nonzero(distances[first:] > NOISE)[0]
    last = first + (int(above[-1]) if above.size else -1)
    ratios = distances[first + 1 : last + 1] / distances[first:last]
    if ratios.size < 3:
        raise DefinitionError(
            f"`push`: {push:g} N s over {steps} steps leaves {max(ratios.size, 0)} ratios above "
            f"the noise ({NOISE:g}); give a larger push or more steps"
        )
    logs = np.log(ratios)
    modulus = float(np.exp(np.mean(logs)))
    spread = float(np.max(np.abs(logs - np.log(modulus))))
    return MultiplierEstimate(modulus, distances, ratios, spread, float(push), 1, rate_hz, phase)


__all__ = ["NOISE", "RATE_WEIGHT", "MultiplierEstimate", "dominant_multiplier"]
