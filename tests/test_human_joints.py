"""problems.human.joints: the model's pose and torques in the biomechanist's terms.

Oracles: poses built from world points (hip, knees, ankles, heels and balls placed by the
biomechanist's definitions with complex numbers, the model's angles read back as the
directions of its links), standing = all zeros, and the power balance (the hinge drives'
power equals the sum of joint moment x joint rate over both hips, knees and ankles, for
random poses, rates and torques): a sign wrong in any angle or moment breaks it.
"""

import cmath
import math

import numpy as np
import pytest

from model.presets import anthropoid_feet, anthropoid_with_feet, six_link_anthropoid
from problems import footed_step
from problems.gait.problem import joint_rates
from problems.human.joints import body_of, leg_angles, leg_moments

DOWN = -1j  # the unit vector straight down


@pytest.fixture(scope="module")
def feet():
    step = footed_step()
    return step, body_of(step.linkage, step.neutral_ankles)


def _unit(angle_from_down: float) -> complex:
    """A direction turned from straight down by ``angle`` toward +x (walking forward)."""
    return DOWN * cmath.exp(1j * angle_from_down)


def _pose(step, stance, swing, lean):
    """Model psi (by link) of a pose given per leg (thigh flexion, knee flexion, ankle
    dorsiflexion) in rad and the trunk's forward lean, built from world points."""
    psi = {}
    for leg, (thigh, knee, ankle) in (("stance", stance), ("swing", swing)):
        thigh_dir = _unit(thigh)  # hip -> knee
        shank_dir = _unit(thigh - knee)  # knee -> ankle
        # the sole: heel -> ball perpendicular to the shank at a neutral ankle, toes up by
        # the dorsiflexion
        sole = shank_dir * cmath.exp(1j * (math.pi / 2 + ankle))
        if leg == "stance":  # links run foot -> hip: ball -> ankle, ankle -> knee, knee -> hip
            psi["stance_thigh"] = cmath.phase(-thigh_dir)
            psi["stance_shank"] = cmath.phase(-shank_dir)
            foot_link = -sole
        else:
            psi["swing_thigh"] = cmath.phase(thigh_dir)
            psi["swing_shank"] = cmath.phase(shank_dir)
            foot_link = sole
        # the foot link's own direction against its sole: the flat pose fixes the offset
        flat = step.flat_angles[0 if leg == "stance" else 1]
        reference = -1.0 if leg == "stance" else 1.0  # the sole flat: heel -> ball along +x
        offset = flat - cmath.phase(reference)
        psi[f"{leg}_foot"] = cmath.phase(foot_link) + offset
    psi["torso"] = math.pi / 2 - lean
    psi["head"] = psi["torso"]
    return {name: np.array([value]) for name, value in psi.items()}


def test_standing_is_zero_in_every_angle(feet):
    step, body = feet
    psi = {
        name: np.array([math.pi / 2]) for name in ("stance_shank", "stance_thigh", "torso", "head")
    }
    psi.update({"swing_thigh": np.array([-math.pi / 2]), "swing_shank": np.array([-math.pi / 2])})
    psi["stance_foot"] = np.array([step.flat_angles[0]])
    psi["swing_foot"] = np.array([step.flat_angles[1]])
    for leg in (body.stance, body.swing):
        for name, value in leg_angles(body, leg, psi).items():
            assert abs(value[0]) < 1e-12, (leg, name)
    point = body_of(six_link_anthropoid())
    for leg in (point.stance, point.swing):
        angles = leg_angles(point, leg, psi)
        assert all(abs(angles[n][0]) < 1e-12 for n in ("thigh", "hip", "knee"))
    assert abs(leg_angles(point, point.stance, psi)["ankle"][0]) < 1e-12
    assert np.isnan(leg_angles(point, point.swing, psi)["ankle"][0])


@pytest.mark.parametrize(
    "stance, swing, lean",
    [
        ((0.3, 0.2, 0.1), (-0.2, 1.0, -0.3), 0.05),
        ((-0.25, 0.05, 0.2), (0.45, 0.6, 0.0), -0.1),
        ((0.0, 0.0, -0.35), (0.1, 1.2, 0.15), 0.2),
    ],
)
def test_angles_of_poses_built_from_world_points(feet, stance, swing, lean):
    step, body = feet
    psi = _pose(step, stance, swing, lean)
    for leg, given in ((body.stance, stance), (body.swing, swing)):
        angles = leg_angles(body, leg, psi)
        thigh, knee, ankle = (math.degrees(v) for v in given)
        assert angles["thigh"][0] == pytest.approx(thigh, abs=1e-9)
        assert angles["knee"][0] == pytest.approx(knee, abs=1e-9)
        assert angles["ankle"][0] == pytest.approx(ankle, abs=1e-9)
        assert angles["hip"][0] == pytest.approx(thigh + math.degrees(lean), abs=1e-9)


def test_the_foot_points_of_a_built_pose_sit_where_the_ankle_angle_says(feet):
    """The pose builder's sole against the model's own foot points: at 0 dorsiflexion the
    heel -> ball line is perpendicular to the shank (the convention's zero)."""
    step, _ = feet
    psi = _pose(step, (0.2, 0.3, 0.0), (0.1, 0.4, 0.0), 0.0)
    order = np.array([psi[name][0] for name in step.linkage.names])
    for leg, (heel, ball, shank) in {
        "stance": ("stance_heel", "stance_toe", "stance_shank"),
        "swing": ("swing_heel", "swing_toe", "swing_shank"),
    }.items():
        points = {
            role: complex(*np.asarray(step.point(role).function("position")(order)).ravel())
            for role in (heel, ball)
        }
        sole = points[ball] - points[heel]
        shank_angle = psi[shank][0] + (math.pi if leg == "stance" else 0.0)  # knee -> ankle
        along = sole / abs(sole) * cmath.exp(-1j * shank_angle)
        assert abs(along.real) < 1e-12, leg  # perpendicular
        assert along.imag > 0  # the ball ahead of the heel (toes forward)


def _power_balance(linkage, body, rng, drives):
    n = linkage.n
    psi = rng.uniform(-math.pi, math.pi, (50, n))
    dpsi = rng.normal(size=(50, n))
    torques = rng.normal(size=(50, n)) * 40.0
    names = linkage.names
    rates = joint_rates(linkage, dpsi)
    hinge_power = sum(torques[:, names.index(d)] * rates[:, names.index(d)] for d in drives)
    by_name = {name: psi[:, i] for i, name in enumerate(names)}
    moments_power = 0.0
    h = 1e-6
    for leg in (body.stance, body.swing):
        moments = leg_moments(body, leg, {nm: torques[:, i] for i, nm in enumerate(names)}, 1.0)
        ahead = leg_angles(
            body, leg, {nm: by_name[nm] + h * dpsi[:, i] for i, nm in enumerate(names)}
        )
        behind = leg_angles(
            body, leg, {nm: by_name[nm] - h * dpsi[:, i] for i, nm in enumerate(names)}
        )
        for joint in ("hip", "knee", "ankle"):
            rate = np.radians(ahead[joint] - behind[joint]) / (2 * h)
            if np.all(np.isnan(rate)):
                continue
            # an extensor moment does positive work while the flexion decreases
            moments_power = moments_power - moments[f"{joint}_moment"] * rate
    return hinge_power, moments_power


def test_joint_moments_carry_the_drives_power_on_feet(feet):
    step, body = feet
    rng = np.random.default_rng(3)
    # every drive of a leg or the hip (the head's is the trunk's own business)
    drives = ("stance_shank", "stance_thigh", "swing_thigh", "swing_shank", "swing_foot", "torso")
    hinge, joints = _power_balance(step.linkage, body, rng, drives)
    np.testing.assert_allclose(joints, hinge, rtol=1e-6, atol=1e-5)


def test_joint_moments_carry_the_drives_power_on_point_feet():
    linkage = six_link_anthropoid()
    body = body_of(linkage)
    rng = np.random.default_rng(4)
    drives = ("stance_shank", "stance_thigh", "swing_thigh", "swing_shank", "torso")
    hinge, joints = _power_balance(linkage, body, rng, drives)
    np.testing.assert_allclose(joints, hinge, rtol=1e-6, atol=1e-5)


def test_a_walker_on_feet_needs_its_neutral_ankles():
    with pytest.raises(ValueError, match="neutral_ankles"):
        body_of(anthropoid_with_feet())
    assert anthropoid_feet()  # the feet's points exist for the preset
