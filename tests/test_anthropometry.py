"""The anthropoid with feet (model.presets.anthropoid_with_feet, model.anthropometry) against
Winter's table typed here again, the geometry a foot must have, and the hand-checkable case
of the issue: a foot held flat reproduces the stance dynamics of the same linkage with the
foot welded to the ground (the model's lock), and its ground torque is what the foot's
statics says."""

from __future__ import annotations

import math

import numpy as np
import pytest

from model import DefinitionError, Dynamics, Link, Linkage, presets, swap_legs
from model.anthropometry import FootGeometry

HEIGHT, MASS, G = 1.75, 70.0, 9.81

# Winter (2009) table 4.1 / figure 4.1: mass fraction, length fraction of H, com from the
# proximal joint (knee for the shank, hip for the thigh)
WINTER = {"shank": (0.0465, 0.246, 0.433), "thigh": (0.100, 0.245, 0.433)}


def _flat_angle(foot: FootGeometry) -> float:
    """psi of the stance foot's link (ball -> ankle) with the sole flat: from the picture of a
    foot, not from the module's helpers: the ankle stands ankle_height above the sole,
    (ball - ankle fraction) of the foot's length behind the ball."""
    back = (foot.ball_from_heel - foot.ankle_from_heel) * 0.152 * foot.height
    return math.atan2(0.039 * foot.height, -back)


def test_the_scene_is_winters_person_of_1_75_m_and_70_kg_to_its_printed_digits():
    """scene.md's legs are Winter's table for H = 1.75 m, M = 70 kg, rounded to the digits it
    prints (half a unit of the last digit)."""
    six = presets.six_link_anthropoid()
    for name, (mass, length, com) in WINTER.items():
        for side, fraction in (("stance", 1.0 - com), ("swing", com)):  # stance: from below
            link = six.links[six.index(f"{side}_{name}")]
            assert abs(link.length - length * HEIGHT) <= 0.005
            assert abs(link.mass - mass * MASS) <= 0.05
            assert abs(link.com - fraction) <= 0.005


def test_the_feet_stand_flat_on_heel_and_ball_with_the_ankle_above():
    foot = FootGeometry()
    linkage = presets.anthropoid_with_feet()
    dynamics = Dynamics(linkage)
    points = presets.anthropoid_feet()
    assert linkage.n == 8 and linkage.names[0] == "stance_foot"
    psi = np.zeros(8)
    psi[0] = _flat_angle(foot)
    psi[1:6] = [math.pi / 2, math.pi / 2, -math.pi / 2, -math.pi / 2, 0.0]  # legs straight
    psi[5] = _flat_angle(foot) - math.pi  # the swing foot flat: ankle -> ball, pointing down
    psi[6:] = math.pi / 2
    hinges = dynamics.hinge_positions(psi)
    ankle = hinges[1]
    assert ankle.imag == pytest.approx(0.039 * HEIGHT, abs=1e-15)
    assert ankle.real == pytest.approx(-0.55 * 0.152 * HEIGHT, abs=1e-15)
    where = {name: complex(dynamics.point(p).position(psi)) for name, p in points.items()}
    assert where["stance_toe"] == 0
    sole = 0.75 * 0.152 * HEIGHT
    assert where["stance_heel"] == pytest.approx(complex(-sole, 0.0), abs=1e-15)
    # the swing foot, hanging straight below the hip, flat: heel and ball on one level,
    # ankle_height under its ankle, which is the swing shank's end
    swing_ankle = hinges[linkage.index("swing_shank") + 1]
    assert where["swing_heel"].imag == pytest.approx(swing_ankle.imag - 0.039 * HEIGHT)
    assert where["swing_toe"].imag == pytest.approx(where["swing_heel"].imag, abs=1e-15)
    assert where["swing_toe"].real - where["swing_heel"].real == pytest.approx(sole)
    # each foot carries Winter's 1.45 % of the body
    assert linkage.links[0].mass == linkage.links[5].mass == pytest.approx(0.0145 * MASS)


def test_the_legs_with_feet_are_mirror_images_and_the_swap_maps_heel_to_heel():
    linkage = presets.anthropoid_with_feet()
    swap = swap_legs(linkage)
    assert swap.new is linkage  # the same tree described from the other ball
    points = presets.anthropoid_feet()
    rng = np.random.default_rng(4)
    psi_old = rng.uniform(-math.pi, math.pi, 8)
    psi_new, _ = swap.map_state(psi_old, np.zeros(8))
    old, new = Dynamics(linkage), Dynamics(swap.new)
    base = complex(old.point(points["swing_toe"]).position(psi_old))  # the new H0
    for before, after in (("swing_heel", "stance_heel"), ("stance_heel", "swing_heel"),
                          ("stance_toe", "swing_toe")):  # fmt: skip
        was = complex(old.point(points[before]).position(psi_old))
        now = complex(new.point(points[after]).position(psi_new))
        assert now + base == pytest.approx(was, abs=1e-13)


def test_a_foot_held_flat_is_the_linkage_with_the_foot_welded_to_the_ground():
    """The issue's hand check: the foot at rest, flat (psi constant, dpsi = ddpsi = 0); the
    other hinges' torques are those of the linkage whose foot is welded to the ground
    (``Linkage.lock`` of the root), the ground carries the foot's weight more, and the
    ground's torque on the foot about the ball balances the foot (statics, written here)."""
    foot = FootGeometry()
    linkage = presets.anthropoid_with_feet()
    flat = _flat_angle(foot)
    welded = linkage.lock("stance_foot", flat)
    assert welded.names == linkage.names[1:] and welded.links[0].parent is None
    footed, locked = Dynamics(linkage), Dynamics(welded)
    rng = np.random.default_rng(7)
    psi, dpsi, ddpsi = rng.uniform(-3, 3, (3, 40, 8))
    psi[:, 0], dpsi[:, 0], ddpsi[:, 0] = flat, 0.0, 0.0
    torques = footed.inverse_dynamics(psi, dpsi, ddpsi)
    welded_torques = locked.inverse_dynamics(psi[:, 1:], dpsi[:, 1:], ddpsi[:, 1:])
    np.testing.assert_allclose(torques[:, 1:], welded_torques, rtol=0, atol=1e-10)
    reaction = footed.ground_reaction(psi, dpsi, ddpsi)
    at_ankle = locked.ground_reaction(psi[:, 1:], dpsi[:, 1:], ddpsi[:, 1:])  # on the shank
    weight = linkage.links[0].mass * G
    np.testing.assert_allclose(reaction - at_ankle, 1j * weight, rtol=0, atol=1e-10)
    # the foot's moment balance about the ball (at rest): the ground's torque M_0, the ankle
    # drive's reaction -M_1, the shank's force on the foot -F at the ankle, the weight at the
    # centre of mass
    ankle = -foot.toe  # from the ball, the sole flat
    com = ankle / 2  # halfway between ball and ankle (Winter)

    def cross(r, force):
        return r.real * force.imag - r.imag * force.real

    balance = torques[:, 0] - torques[:, 1] + cross(ankle, -at_ankle) + cross(com, -1j * weight)
    np.testing.assert_allclose(balance, 0.0, atol=1e-9)


def test_welding_a_root_with_two_children_is_refused_by_name():
    tree = Linkage([Link("base", None, 1.0, 1.0), Link("a", "base", 1.0, 1.0),
                    Link("b", "base", 1.0, 1.0)])  # fmt: skip
    with pytest.raises(DefinitionError, match=r"'base'.*2 trees.*\['a', 'b'\]"):
        tree.lock("base", 0.3)
    # one child: it becomes the root where its hinge stands
    chain = presets.n_link_chain(2)
    welded = chain.lock("link1", math.pi / 2)
    assert welded.links[0].origin == pytest.approx(1j)
    held = Dynamics(welded)
    # the second link, horizontal at rest, hangs from (0, 1): held by m g l / 2
    assert held.hinge_positions(np.array([0.0]))[0] == pytest.approx(1j)
    torques = held.inverse_dynamics(np.array([0.0]), np.zeros(1), np.zeros(1))
    assert torques[0] == pytest.approx(1.0 * G * 0.5, abs=1e-12)


@pytest.mark.parametrize(
    "field, kwargs, match",
    [
        ("height", {"height": -1.0}, "height"),
        ("mass", {"mass": 0.0}, "mass"),
        ("placements", {"ankle_from_heel": 0.8}, "ankle_from_heel"),
    ],
)
def test_bad_foot_geometry_is_refused_naming_the_field(field, kwargs, match):
    with pytest.raises(DefinitionError, match=match):
        FootGeometry(**kwargs)
