"""model.mjcf_in: a robot's MJCF read as the URDF of the same tree.

Oracles: the test robot written as MJCF (tests/test_joint_space_mujoco.py, for MuJoCo) reads
as the same walking biped as its URDF (tests/robot_urdf.py), parameter by parameter and by the
mass matrix; model.to_mjcf's MJCF of a preset reads back as the preset; MuJoCo's own frames
against the translation's (quat, euler in degrees, default classes); refusals by name.
"""

import math
import re

import numpy as np
import pytest
from robot_urdf import biped_urdf

from model import Dynamics, presets, to_mjcf
from model.mjcf_in import from_mjcf, mjcf_to_urdf
from problems.robot import read_urdf_walker, walker_from_urdf

mujoco = pytest.importorskip("mujoco")
from test_joint_space_mujoco import robot_mjcf  # noqa: E402 - after the skip


def test_the_robots_mjcf_reads_as_its_urdf(tmp_path):
    """On feet (the point-foot robot's MJCF carries soles its URDF has not)."""
    feet = True
    path = tmp_path / "robot.xml"
    path.write_text(robot_mjcf(feet))
    from_xml = read_urdf_walker(path)
    from_urdf = walker_from_urdf(biped_urdf(feet))
    assert from_xml.linkage.names == from_urdf.linkage.names
    assert from_xml.joints == from_urdf.joints and from_xml.sides == from_urdf.sides
    for a, b in zip(from_xml.linkage.links, from_urdf.linkage.links, strict=True):
        for field in ("length", "mass", "com", "inertia"):
            assert getattr(a, field) == pytest.approx(getattr(b, field), rel=1e-12), (a.name, field)
    psi = np.random.default_rng(1).uniform(-3, 3, from_urdf.linkage.n)
    np.testing.assert_allclose(
        np.asarray(Dynamics(from_xml.linkage).function("mass_matrix")(psi)),
        np.asarray(Dynamics(from_urdf.linkage).function("mass_matrix")(psi)), rtol=1e-12,
    )  # fmt: skip
    for role, point in from_urdf.points.items():
        ours = from_xml.points[role]
        assert (ours.along, ours.lateral) == pytest.approx((point.along, point.lateral))


def test_to_mjcf_reads_back_as_the_preset():
    linkage = presets.six_link_anthropoid()
    back = from_mjcf(to_mjcf(linkage, base="floating").xml).linkage
    assert back.names == linkage.names
    psi = np.random.default_rng(4).uniform(-3, 3, linkage.n)
    np.testing.assert_allclose(
        np.asarray(Dynamics(back).function("mass_matrix")(psi)),
        np.asarray(Dynamics(linkage).function("mass_matrix")(psi)), rtol=1e-12, atol=1e-12,
    )  # fmt: skip


FRAMES = """<mujoco model="frames"><compiler angle="degree" eulerseq="xyz"/>
  <default><joint axis="0 1 0"/><default class="knee"><joint axis="0 -1 0"/></default></default>
  <worldbody><body name="base" pos="0 0 1"><freejoint/>
    <inertial pos="0 0 0.1" mass="10" diaginertia="0.3 0.4 0.5"/>
    <body name="thigh" pos="0.1 0 -0.05" euler="0 20 0"><joint name="hip"/>
      <inertial pos="0 0 -0.2" quat="0.7071067811865476 0.7071067811865476 0 0" mass="5"
        diaginertia="0.1 0.2 0.3"/>
      <body name="shank" pos="0 0 -0.4" quat="0.9659258262890683 0 0.25881904510252074 0">
        <joint name="knee" class="knee"/>
        <inertial pos="0.02 0 -0.2" mass="3" fullinertia="0.05 0.06 0.07 0 0.01 0"/>
        <site name="tip" pos="0 0 -0.4"/></body></body></body></worldbody></mujoco>"""


def test_frames_and_defaults_against_mujoco():
    """The translation's link frames, centres of mass and joint axes against MuJoCo's own
    (mj_kinematics at q = 0 and at a bent pose): every point of the sagittal view."""
    urdf = mjcf_to_urdf(FRAMES)
    leg = from_mjcf(FRAMES)
    model = mujoco.MjModel.from_xml_string(FRAMES)
    data = mujoco.MjData(model)
    for q in ({"hip": 0.0, "knee": 0.0}, {"hip": 0.4, "knee": -0.7}):
        data.qpos[:] = 0
        data.qpos[:3] = (0, 0, 1)
        data.qpos[3] = 1.0
        for name, value in q.items():
            data.qpos[model.joint(name).qposadr[0]] = value
        mujoco.mj_kinematics(model, data)
        psi = leg.psi(q)
        base = complex(data.xpos[model.body("base").id][0], data.xpos[model.body("base").id][2])
        # the linkage's own points: hinges and centres of mass, from its angles
        positions = {}
        links = leg.linkage.links
        starts = {"base": base}
        for i, link in enumerate(links):
            if link.parent is None:
                continue
            parent = leg.linkage.parents[i]
            starts[link.name] = starts[links[parent].name] + np.exp(1j * psi[parent]) * complex(
                leg.linkage.origin_in_parent(i)
            )
            positions[link.name] = starts[link.name] + np.exp(1j * psi[i]) * link.com_offset
        for name in ("thigh", "shank"):
            xipos = data.xipos[model.body(name).id]
            assert positions[name] == pytest.approx(complex(xipos[0], xipos[2]), abs=1e-12)
    # the inertias: turned into the plane's axes (the thigh's rolled frame: its izz about y)
    thigh = leg.linkage.links[leg.linkage.index("thigh")]
    assert thigh.inertia == pytest.approx(0.3)
    assert 'type="continuous"' in urdf and 'name="tip"' in urdf
    # the base floats (sense 1 by convention); the hip's default axis +y, the knee's class -y
    assert leg.senses == (1.0, -1.0, 1.0)


@pytest.mark.parametrize(
    "change, message",
    [
        (('<joint name="hip"/>', '<joint name="hip"/><joint name="hip2"/>'), "has 2 joints"),
        (('<inertial pos="0 0 -0.2"', '<geom size="0.1"/><inertial pos="0 0 -0.2"'), None),
        (('euler="0 20 0"', 'xyaxes="1 0 0 0 1 0"'), "sets its frame by xyaxes"),
        (('<joint name="hip"/>', '<joint name="hip" pos="0 0 0.1"/>'), "away from its body's"),
        (("<freejoint/>", '<joint name="fixed_base" axis="0 1 0"/>'), "hinged to the world"),
    ],
)
def test_refusals_by_name(change, message):
    text = FRAMES.replace(*change, 1)
    assert text != FRAMES
    if message is None:  # geoms beside an <inertial>: read
        mjcf_to_urdf(text)
        return
    with pytest.raises(ValueError, match=message):
        mjcf_to_urdf(text)


def test_a_frame_rolled_out_of_the_plane_is_judged_by_its_axis():
    """The thigh's frame rolled 10 degrees: its hip (axis y in that frame) no longer turns
    about the world's y, refused when the sagittal view is read; the frame itself is
    translated (its roll in the URDF's rpy)."""
    rolled = FRAMES.replace('euler="0 20 0"', 'euler="10 20 0"')
    urdf = mjcf_to_urdf(rolled)
    roll, pitch, yaw = map(float, re.search(r'<child link="thigh"/><origin [^>]*rpy="([^"]+)"',
                                            urdf).group(1).split())  # fmt: skip
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))  # fmt: skip
    rpy = np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                    [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                    [-sp, cp * sr, cp * cr]])  # fmt: skip
    model = mujoco.MjModel.from_xml_string(rolled)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)  # the base at rest, unturned: the thigh's world frame
    np.testing.assert_allclose(rpy, data.xmat[model.body("thigh").id].reshape(3, 3), atol=1e-12)
    with pytest.raises(ValueError, match="joint 'hip' turns about"):
        from_mjcf(rolled)


def test_a_body_with_geoms_and_no_inertial_is_refused():
    no_inertial = FRAMES.replace('<inertial pos="0 0 0.1" mass="10" diaginertia="0.3 0.4 0.5"/>',
                                 '<geom type="sphere" size="0.1"/>')  # fmt: skip
    with pytest.raises(ValueError, match="body 'base' has geoms but no <inertial>"):
        mjcf_to_urdf(no_inertial)
