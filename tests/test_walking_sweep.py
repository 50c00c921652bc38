"""A sweep that can fail: walking steps from easy to beyond reach, for three bipeds.

Every run either fails loudly (a typed error naming why: IPOPT's status, limits that cannot
be held at the samples, a step the legs cannot make) or writes a torque file that the
verification of physics passes, read back from disk as a drive would read it. Slow: ~45
solves (``pytest -m slow``).
"""

from __future__ import annotations

import warnings

import pytest

from model import AnthropoidError, Link, Linkage, LinkageTrajectory, presets
from planner import AccuracyWarning
from problems import verify_gait, walking_step

SIX = presets.six_link_anthropoid()
#: A biped with arms: the torso carries a head and two arms at the shoulder.
ARMS = Linkage(
    [
        *SIX.links,
        Link("left_arm", "torso", 0.6, 3.5, 0.45),
        Link("right_arm", "torso", 0.6, 3.5, 0.45),
    ]
)
BIPEDS = {"six-link": SIX, "five-link": presets.five_link_biped(), "with arms": ARMS}
LENGTHS = (0.3, 0.6, 0.9, 1.3, 1.8)  # m: the legs are 0.86 m (1.8 is beyond their reach)
TIMES = (0.35, 0.6, 0.9)  # s


@pytest.mark.slow
@pytest.mark.parametrize("name", list(BIPEDS))
def test_every_step_fails_loudly_or_writes_a_file_that_verifies(name, tmp_path):
    linkage = BIPEDS[name]
    outcomes = {}
    for length in LENGTHS:
        for duration in TIMES:
            key = f"{length:g} m in {duration:g} s"
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", AccuracyWarning)
                    gait = walking_step(linkage, length, duration, N=24).solve(progress=False)
            except AnthropoidError as error:  # DefinitionError, SolverError, SampleLimitError
                assert str(error).strip(), key
                outcomes[key] = type(error).__name__
                continue
            path = gait.to_trajectory(1000.0).save(tmp_path / f"{length}_{duration}.csv")
            report = verify_gait(LinkageTrajectory.load(path), linkage)
            assert report.ok, (key, str(report))
            outcomes[key] = "verified"
    # the sweep reaches both ends: plans that verify, and steps that fail loudly
    assert "verified" in outcomes.values(), outcomes
    assert set(outcomes.values()) - {"verified"}, outcomes
