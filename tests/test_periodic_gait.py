"""The fixed-base periodic gait (problems.pinned.gait) checked with code written another way:
periodicity, the swing foot through the law's keypoints (between nodes, on the solution's
interpolant), clearance, posture and torque bounds through the Newton-Euler oracle in numpy;
exported torques against the oracle's inverse dynamics; the law's cost recomputed by
Simpson's rule; six-link and five-link."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from reference import gait_oracle as go
from reference import newton_euler as ne

from model import DefinitionError, DefinitionTypeError, presets
from problems import GaitLaw, PeriodicGait, periodic_gait

SIX = presets.six_link_anthropoid()
FIVE = presets.five_link_biped()
WALKING = GaitLaw.preset("walking")
FIVE_LAW = GaitLaw(
    WALKING.period, WALKING.zeta[:5], WALKING.varpi[:5], WALKING.center[:5], name="walking-5"
)


@functools.cache
def solved(name: str) -> PeriodicGait:
    linkage, law = {
        "six": (SIX, WALKING),
        "paper22": (SIX, GaitLaw.preset("paper22")),
        "five": (FIVE, FIVE_LAW),
    }[name]
    return periodic_gait(linkage, law).solve(progress=False)


@pytest.mark.parametrize("name", ["six", "paper22", "five"])
def test_periodic_gait_meets_its_task(name):
    result = solved(name)
    problem = result.problem
    linkage = problem.linkage
    assert result.success and result.cost < result.law_cost
    trajectory = result.to_trajectory()
    psi, dpsi, ddpsi = trajectory.psi, trajectory.dpsi, trajectory.ddpsi
    np.testing.assert_allclose(np.r_[psi[0], dpsi[0]], np.r_[psi[-1], dpsi[-1]], atol=1e-8)
    # At the keypoints (T/4 and 3T/4 lie between nodes, see below) the solution's own
    # interpolant puts the foot on the law's foot.
    law = problem.law
    times = np.array(problem.keypoints) * law.period
    states = result.solution.state(times)
    foot = go.swing_foot(linkage, states[:, : linkage.n])
    expected = go.swing_foot(linkage, law.psi(times))
    np.testing.assert_allclose(foot, expected, atol=1e-8)
    lowest = go.swing_foot(linkage, law.psi(np.linspace(0, law.period, 2001))).imag.min()
    assert np.all(go.swing_foot(linkage, psi).imag >= lowest - problem.margin - 1e-8)
    upright = [linkage.index(n) for n in problem.upright]
    assert np.all(np.abs(psi[:, upright] - math.pi / 2) <= problem.posture + 1e-7)
    torques = trajectory.torques
    assert np.all(np.abs(torques) <= 300.0 + 1e-6)
    oracle = ne.inverse_dynamics(linkage, psi, dpsi, ddpsi)
    assert np.max(np.abs(torques - oracle)) <= 1e-8 * np.max(np.abs(oracle))
    assert result.verify().ok


def test_keypoints_fall_between_nodes():
    problem = solved("six").problem
    nodes = np.arange(problem.ocp.N + 1) / problem.ocp.N
    gaps = [np.min(np.abs(nodes - f)) for f in problem.keypoints]
    assert min(gaps) == 0.0 and max(gaps) > 1e-3  # t = T/2 is a node; T/4 and 3T/4 are not


def test_law_cost_is_simpsons_rule_of_the_law_torques():
    result = solved("six")
    N, T = result.problem.ocp.N, WALKING.period
    h = T / N
    nodes = np.arange(N + 1) * h

    def effort(t):
        return np.sum(ne.inverse_dynamics(SIX, *WALKING(t)) ** 2, axis=1)

    simpson = (
        h / 6 * np.sum(effort(nodes[:-1]) + 4 * effort(nodes[:-1] + h / 2) + effort(nodes[1:]))
    )
    # Torques above the bound are clipped into it by IPOPT's start, not by the benchmark.
    assert result.law_cost == pytest.approx(simpson, rel=1e-10)


def test_defaults_reach_the_documented_optimum():
    # Two optima of the six-link problem on this mesh (examples/benchmarks/gait_bench.py):
    # with the planner's defaults (adaptive barrier update) the law's guess reaches the
    # higher one (724.78), the law shifted by half a period the lower one (692.13); with
    # IPOPT's monotone update it was the other way round (692.13 and 849.42).
    result = solved("six")
    problem = result.problem
    law = problem.law
    shifted = problem.ocp.guess(lambda t: law((t + law.period / 2) % law.period))
    other = problem.solve(shifted, progress=False)
    assert other.success and other.cost < 0.97 * result.cost
    assert other.verify().ok


def test_bad_periodic_gait_input_is_refused():
    with pytest.raises(DefinitionError, match=r"`law`: drives 6 links but the linkage has 5"):
        periodic_gait(FIVE, WALKING)
    with pytest.raises(DefinitionError, match=r"`law`: unknown gait-law preset 'running'"):
        periodic_gait(law="running")
    with pytest.raises(DefinitionTypeError, match=r"`law`: must be a GaitLaw or a preset name"):
        periodic_gait(law=3)
    with pytest.raises(DefinitionError, match=r"`keypoints`: fractions of the period must lie"):
        periodic_gait(keypoints=(0.0, 0.5))
    with pytest.raises(DefinitionError, match=r"`margin`: must be >= 0 m"):
        periodic_gait(margin=-0.1)
    with pytest.raises(DefinitionError, match=r"`foot`: no link called 'toe'"):
        periodic_gait(foot="toe")
    with pytest.raises(DefinitionError, match=r"`objective`: unknown 'speed'"):
        periodic_gait(objective="speed")
