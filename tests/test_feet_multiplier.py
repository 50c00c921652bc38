"""The footed closed loop's dominant multiplier from how a push dies out
(problems.control.feet_multiplier).

Oracles: the slowest mode does not depend on which way the body is pushed (a push forward and
one back give the same |lambda_1|, while their transients differ); the distances die out
geometrically at that ratio (each successive ratio near the mean); the Poincare section's
states are the walk's own states at that phase, in the law's labels (a step and the one after
it differ by a swap of the legs' columns only where the legs' roles are swapped)."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import DefinitionError
from problems.control.feet_law import FeetLaw
from problems.control.feet_multiplier import NOISE, dominant_multiplier
from problems.control.feet_simulation import section_states, simulate_feet
from problems.library.build import FEET_ESTIMATE
from problems.walking.footed import footed_step_at


@pytest.fixture(scope="module")
def bounded():
    """The 1 m/s step on feet, joints bounded at 10 rad/s (a walk through speeds plans it so)."""
    return footed_step_at(1.0, speed_limit=10.0).solve(progress=False)


def test_a_push_either_way_dies_out_at_one_ratio(bounded):
    law = FeetLaw(bounded)
    forward = dominant_multiplier(bounded, law=law, **FEET_ESTIMATE)
    back = dominant_multiplier(bounded, law=law, **{**FEET_ESTIMATE, "push": -6.0})
    assert 0.5 < forward.modulus < 1.0
    assert back.modulus == pytest.approx(forward.modulus, abs=0.02)
    # their distances differ (two transients), their decay does not
    assert abs(forward.distances[3] - back.distances[3]) > 1e-3
    for estimate in (forward, back):
        assert estimate.ratios.size >= 5
        assert estimate.spread < 0.1  # each ratio within 10 % of the mean: geometric
        used = estimate.distances[4 : 4 + estimate.ratios.size + 1]
        assert np.all(used > NOISE)
        np.testing.assert_allclose(used[1:] / used[:-1], estimate.ratios, rtol=1e-12)


def test_the_section_is_each_steps_state_at_its_phase(bounded):
    law = FeetLaw(bounded)
    run = simulate_feet(bounded, steps=3, law=law)
    sections = section_states(run, law, 0.3)
    n = bounded.problem.linkage.n
    assert sections.shape == (3, 2 * n)
    for x in sections:  # just past 0.3, within one control period's advance of the phase
        assert 0.3 <= law.phase(x[:n]) < 0.31
    # in the law's labels every step is near the plan's state at that phase
    reference = law.references[0]
    planned = reference.states[np.searchsorted([law.phase(p) for p in reference.states[:, :n]],
                                               0.3)]  # fmt: skip
    assert np.max(np.abs(sections[:, :n] - planned[:n])) < 0.05


def test_bad_estimates_are_refused_by_name(bounded):
    with pytest.raises(DefinitionError, match="`push`: 0 N s"):
        dominant_multiplier(bounded, push=0.0)
    with pytest.raises(DefinitionError, match="`steps`"):
        dominant_multiplier(bounded, steps=3)
    law = FeetLaw(bounded)
    run = simulate_feet(bounded, steps=1, law=law)
    with pytest.raises(DefinitionError, match="`phase`"):
        section_states(run, law, 1.2)
