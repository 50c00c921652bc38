"""problems.robot.urdf_walker: a robot's URDF (pelvis-rooted, legs down, its own zero pose and
encoder senses) as the walking biped rooted at a foot.

Oracles: the preset linkages the test robot is built from (tests/robot_urdf.py: the six-link
scene, Winter's feet) parameter by parameter and by their mass matrices; the URDF's joint
angles against a forward kinematics of the URDF's frames written here (rotations about y,
frame by frame), read back from the plan's link angles; refusals by name.
"""

import cmath

import numpy as np
import pytest
from robot_urdf import biped_urdf

from model import Dynamics
from model.anthropometry import FootGeometry
from model.presets import anthropoid_feet, anthropoid_with_feet, six_link_anthropoid
from problems.robot.urdf_walker import urdf_angles, walker_from_urdf


@pytest.mark.parametrize("feet", [False, True])
def test_the_robot_reads_as_the_preset_it_was_built_from(feet):
    walker = walker_from_urdf(biped_urdf(feet))
    preset = anthropoid_with_feet() if feet else six_link_anthropoid()
    assert walker.linkage.names == preset.names and walker.sides == ("right", "left")
    for ours, theirs in zip(walker.linkage.links, preset.links, strict=True):
        assert ours.parent == theirs.parent and ours.origin is None
        for field in ("length", "mass", "com", "inertia"):
            assert getattr(ours, field) == pytest.approx(getattr(theirs, field), rel=1e-12)
        assert ours.com_lateral == pytest.approx(0.0, abs=1e-12)
    psi = np.random.default_rng(5).uniform(-3, 3, preset.n)
    np.testing.assert_allclose(
        np.asarray(Dynamics(walker.linkage).function("mass_matrix")(psi)),
        np.asarray(Dynamics(preset).function("mass_matrix")(psi)), rtol=1e-12, atol=1e-12,
    )  # fmt: skip
    if feet:
        for role, point in anthropoid_feet().items():
            ours = walker.points[role]
            assert (ours.link, ours.name) == (point.link, point.name)
            assert complex(ours.along, ours.lateral) == pytest.approx(
                complex(point.along, point.lateral), rel=1e-12, abs=1e-12)  # fmt: skip
    else:
        assert walker.points is None
    assert walker.joints["right_knee"] == "right_knee" and walker.joints["head"] == "neck_pitch"


def _frames(q: dict, pitch: float, feet: bool) -> dict:
    """World points (x + j z) of the test robot at URDF joint angles ``q`` and the torso
    turned by ``pitch`` about +y: each frame = parent's point + parent's turn * offset, a
    joint about (0, s, 0) by q turning its child's frame by exp(-j s q)."""
    length = {"torso": 0.5, "thigh": 0.43, "shank": 0.43, "head": 0.25}
    foot = FootGeometry()
    torso = cmath.exp(-1j * pitch)
    points = {"hip": 0j, "neck": torso * 1j * length["torso"]}
    head = torso * cmath.exp(-1j * -q["neck_pitch"])  # axis 0 -1 0
    points["head_end"] = points["neck"] + head * 0.25j
    for side, s in (("right", 1.0), ("left", -1.0)):
        thigh = torso * cmath.exp(-1j * s * q[f"{side}_hip_pitch"])
        knee = thigh * -1j * length["thigh"]
        shank = thigh * cmath.exp(-1j * s * q[f"{side}_knee"])
        ankle = knee + shank * -1j * length["shank"]
        points[f"{side}_knee"], points[f"{side}_ankle"] = knee, ankle
        if feet:
            sole = shank * cmath.exp(-1j * s * q[f"{side}_ankle"])
            points[f"{side}_toe"] = ankle + sole * foot.toe
    return points


@pytest.mark.parametrize("feet", [False, True])
def test_urdf_angles_from_the_plans_link_angles(feet):
    walker = walker_from_urdf(biped_urdf(feet))
    rng = np.random.default_rng(11)
    names = list(walker.joints.values())
    for _ in range(5):
        q = dict(zip(names, rng.uniform(-1.2, 1.2, len(names)), strict=True))
        p = _frames(q, rng.uniform(-0.5, 0.5), feet)
        lines = {
            "stance_shank": p["right_knee"] - p["right_ankle"],
            "stance_thigh": p["hip"] - p["right_knee"],
            "swing_thigh": p["left_knee"] - p["hip"],
            "swing_shank": p["left_ankle"] - p["left_knee"],
            "torso": p["neck"] - p["hip"],
            "head": p["head_end"] - p["neck"],
        }
        if feet:
            lines["stance_foot"] = p["right_ankle"] - p["right_toe"]
            lines["swing_foot"] = p["left_toe"] - p["left_ankle"]
        psi = np.array([cmath.phase(lines[name]) for name in walker.linkage.names])
        read = urdf_angles(walker, psi)
        for name, value in q.items():
            assert read[name] == pytest.approx(value, abs=1e-12), name


def test_the_left_leg_in_stance_and_refusals():
    walker = walker_from_urdf(biped_urdf(), stance_side="left")
    assert walker.sides == ("left", "right")
    assert walker.encoders["left_hip"][:2] == ("torso", "stance_thigh")
    text = biped_urdf()
    with pytest.raises(ValueError, match="`stance_side`: one of"):
        walker_from_urdf(text, stance_side="middle")
    at = text.index('<link name="left_shank">')
    heavier = text[:at] + text[at:].replace('<mass value="3.3"/>', '<mass value="3.4"/>', 1)
    assert heavier != text
    with pytest.raises(ValueError, match="the legs differ in the sagittal view: right_shank mass"):
        walker_from_urdf(heavier)
    unnamed = text.replace("right_", "a_").replace("left_", "b_")
    with pytest.raises(ValueError, match="cannot tell the side of the leg starting at 'a_thigh'"):
        walker_from_urdf(unnamed)
    named = walker_from_urdf(unnamed, legs={"front": "a_thigh", "back": "b_thigh"})
    assert named.sides == ("back", "front") and named.joints["front_knee"] == "a_knee"
    no_toe = biped_urdf(feet=True).replace('"left_toe"', '"left_tip"')
    with pytest.raises(ValueError, match=r"foot 'left_foot' needs massless frames .* \['toe'\]"):
        walker_from_urdf(no_toe)
