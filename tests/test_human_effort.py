"""problems.human.effort: the objective elements of predictive gait and ``objective="human"``.

Oracles: the passive moments' signs at the ends of each joint's range (a hyperextended knee
is pulled into flexion, a dorsiflexed ankle pushed into plantarflexion, ...) and their values
from the published coefficients typed out again; the effort integrand against the joint
moments written by hand from the tree's hinge torques; the collision term against the kinetic
energy the impact map removes, computed with numpy; the human setting's gait verified and,
against Winter's stride, its push-off within the targets (slow).
"""

import math
from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from planner import OCP
from problems import footed_step, walking_step
from problems.human import read_winter, step_stride
from problems.human.comparison import compare_gait
from problems.human.effort import (
    HUMAN,
    HumanObjective,
    human_integrand,
    passive_moment,
    strike_collision,
)


@pytest.mark.parametrize(
    "joint, flexion, sign",
    [
        ("knee", -0.2, -1),  # hyperextended: pulled into flexion (a flexor moment)
        ("knee", 2.6, +1),  # deeply flexed: pushed back (extensor)
        ("hip", -0.9, -1),  # hyperextended hip: flexor
        ("hip", 2.0, +1),
        ("ankle", 0.6, +1),  # dorsiflexed: plantarflexor
        ("ankle", -0.95, -1),  # plantarflexed: dorsiflexor
    ],
)
def test_passive_moments_push_back_from_the_ends_of_the_range(joint, flexion, sign):
    assert math.copysign(1.0, passive_moment(joint, flexion)) == sign
    assert abs(passive_moment(joint, flexion)) > 1.0
    assert abs(passive_moment(joint, 0.2 if joint != "knee" else 0.5)) < 3.0  # mid-range


def test_passive_moment_values_from_the_published_coefficients():
    # Anderson and Pandy 1999: knee, on the knee angle q = -flexion, tau increases q
    q = -0.5
    tau = -6.09 * math.exp(33.94 * (q - 0.13)) + 11.03 * math.exp(-11.33 * (q + 2.4))
    assert passive_moment("knee", 0.5) == pytest.approx(tau)  # tau extends: extensor +
    q = 0.3  # ankle dorsiflexion; tau increases it (dorsiflexor): plantarflexor = -tau
    tau = -2.03 * math.exp(38.11 * (q - 0.52)) + 0.18 * math.exp(-12.12 * (q + 0.74))
    assert passive_moment("ankle", 0.3) == pytest.approx(-tau)
    x = ca.SX.sym("x")
    f = ca.Function("f", [x], [passive_moment("hip", x)])
    assert float(f(0.4)) == pytest.approx(passive_moment("hip", 0.4))


def _point(linkage, rng):
    n = linkage.n
    values = {"psi": rng.uniform(-3, 3, n), "dpsi": rng.normal(size=n),
              "ddpsi": rng.normal(size=n) * 50, "M": rng.normal(size=n) * 60}  # fmt: skip

    class Point:
        psi, dpsi, ddpsi, M = (ca.DM(values[k]) for k in ("psi", "dpsi", "ddpsi", "M"))

    return Point, values


def test_joint_effort_is_the_sum_of_the_physical_joint_moments_squared():
    step = footed_step()
    plain = HumanObjective(passive=False, strengths={}, default_strength=0.25)
    integrand = human_integrand(step.linkage, plain, step.drives, step.neutral_ankles)
    rng = np.random.default_rng(7)
    point, values = _point(step.linkage, rng)
    M = dict(zip(step.linkage.names, values["M"], strict=True))
    by_hand = [
        M["stance_shank"],  # stance ankle, plantarflexor
        -M["stance_thigh"],  # stance knee, extensor
        M["torso"] + M["swing_thigh"],  # the physical stance hip
        -M["swing_thigh"],  # swing hip
        M["swing_shank"],  # swing knee
        -M["swing_foot"],  # swing ankle
        M["head"],  # no leg joint: a hinge of its own
    ]
    assert float(integrand(point)) == pytest.approx(sum(m * m for m in by_hand), rel=1e-12)
    # strengths divide: the ankle twice as strong counts a quarter
    strong = replace(plain, strengths={"ankle": 0.5})
    weaker = human_integrand(step.linkage, strong, step.drives, step.neutral_ankles)(point)
    ankles = by_hand[0] ** 2 + by_hand[5] ** 2
    assert float(weaker) == pytest.approx(sum(m * m for m in by_hand) - 0.75 * ankles, rel=1e-12)


def test_the_acceleration_term_counts_relative_accelerations():
    step = footed_step()
    base = HumanObjective(passive=False)
    with_acc = replace(base, accelerations=2.0)
    rng = np.random.default_rng(8)
    point, values = _point(step.linkage, rng)
    names = step.linkage.names
    a = dict(zip(names, values["ddpsi"], strict=True))
    pairs = [("stance_thigh", "torso"), ("stance_thigh", "stance_shank"),
             ("stance_shank", "stance_foot"), ("swing_thigh", "torso"),
             ("swing_thigh", "swing_shank"), ("swing_shank", "swing_foot")]  # fmt: skip
    expected = 2.0 * sum(((a[x] - a[y]) / 100.0) ** 2 for x, y in pairs)
    unit = sum(link.mass for link in step.linkage.links) * 9.81 * 0.86
    scale = (base.default_strength * unit) ** 2
    f = human_integrand(step.linkage, with_acc, step.drives, step.neutral_ankles)
    g = human_integrand(step.linkage, base, step.drives, step.neutral_ankles)
    assert float(f(point) - g(point)) == pytest.approx(scale * expected, rel=1e-12)


def test_the_collision_term_is_the_energy_the_strike_removes():
    step = footed_step()
    term = strike_collision(step, 3.0)
    rng = np.random.default_rng(9)
    n = step.linkage.n
    x = np.concatenate([step.law.psi(np.array([0.3]))[0], rng.normal(size=n)])

    class Point:
        pass

    Point.x = ca.DM(x)
    after = np.asarray(step.strike.state_function()(x)).ravel()
    energy = step.dynamics.function("energy")
    lost = float(energy(x[:n], x[n:])[0]) - float(energy(after[:n], after[n:])[0])
    assert lost > 0  # an inelastic impact dissipates
    assert float(term(Point)) == pytest.approx(3.0 * lost, rel=1e-12)


def test_objective_choices_and_settings():
    step = footed_step(objective="human")
    assert step.human == HUMAN
    settings = step.settings()
    assert settings["objective"] == "human"
    assert settings["human_objective"]["strengths"] == {"ankle": HUMAN.strength("ankle")}
    assert footed_step().settings()["objective"] == "torque"
    with pytest.raises(ValueError, match=r"'torque'.*'human'"):
        footed_step(objective="effort")
    with pytest.raises(ValueError, match="exponent"):
        HumanObjective(exponent=4.0)
    with pytest.raises(ValueError, match="strengths"):
        HumanObjective(strengths={"elbow": 1.0})
    with pytest.raises(ValueError, match="accelerations"):
        HumanObjective(accelerations=-1.0)
    assert isinstance(walking_step(objective="human").ocp, OCP)


def test_point_feet_walk_under_the_human_objective():
    gait = walking_step(objective="human").solve()
    assert gait.verified
    assert set(gait.solution.cost_terms) == {"objective"}


@pytest.mark.slow
def test_human_setting_on_feet_against_winter(winter_xlsx):
    """The measured result (examples/benchmarks/human_prediction.py): the vertical force's
    humps within 0.15 BW, the plantarflexor peak within 20 %, the swing knee within 5 deg."""
    data = read_winter(winter_xlsx)
    gait = footed_step(step_length=0.7075, step_time=0.4935, objective="human").solve()
    assert gait.verified
    features = compare_gait(step_stride(gait.to_trajectory(1000.0)), data).features
    for name in ("force_peak_1", "force_valley", "force_peak_2"):
        assert abs(features[name].model - features[name].data) < 0.15, name
    peak = features["ankle_moment_peak"]
    assert abs(peak.model - peak.data) < 0.2 * peak.data
    assert abs(features["knee_swing"].model - features["knee_swing"].data) < 5.0
