"""model.urdf: a planar linkage to URDF and back, and a robot's URDF to its sagittal linkage.

Oracles: the round trip's mass matrix and parameters against the linkage's own; a leg written
by hand in URDF (frames down the leg, hinges about +y, the other sense) against the closed-form
mass matrix of a double pendulum in absolute angles; every refusal names its joint or link.
"""

import cmath
import math

import numpy as np
import pytest

from model import Dynamics
from model.presets import anthropoid_with_feet, six_link_anthropoid
from model.urdf import from_urdf, to_urdf


@pytest.mark.parametrize("make", [six_link_anthropoid, anthropoid_with_feet])
def test_round_trip(make):
    linkage = make()
    back = from_urdf(to_urdf(linkage, name="walker", torque_limits=150.0))
    assert back.linkage.names == linkage.names
    assert back.offsets == pytest.approx((0.0,) * linkage.n, abs=1e-12)
    assert back.senses == (1.0,) * linkage.n
    for a, b in zip(back.linkage.parameters()["links"], linkage.parameters()["links"],
                    strict=True):  # fmt: skip
        for key in ("parent", "mass"):
            assert a[key] == b[key], key
        for key in ("length", "com", "inertia", "com_lateral"):
            assert a[key] == pytest.approx(b[key], rel=1e-12, abs=1e-12), key
    psi = np.random.default_rng(3).uniform(-3, 3, linkage.n)
    np.testing.assert_allclose(
        np.asarray(Dynamics(back.linkage).function("mass_matrix")(psi)),
        np.asarray(Dynamics(linkage).function("mass_matrix")(psi)),
        rtol=1e-12, atol=1e-12,
    )  # fmt: skip


LEG = """<robot name="leg">
  <link name="world"/>
  <link name="imu"/>
  <link name="thigh"><inertial><origin xyz="0 0 -0.2" rpy="0 0 0"/><mass value="7"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.12" iyz="0" izz="0.02"/></inertial></link>
  <link name="shank"><inertial><origin xyz="0.01 0 -0.25"/><mass value="3"/>
    <inertia ixx="0.05" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.01"/></inertial></link>
  <link name="foot"><inertial><origin xyz="0 0 -0.45"/><mass value="0"/></inertial></link>
  <joint name="hip" type="revolute"><parent link="world"/><child link="thigh"/>
    <origin xyz="0 0 1" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="100" velocity="10"/></joint>
  <joint name="knee" type="revolute"><parent link="thigh"/><child link="shank"/>
    <origin xyz="0 0 -0.42"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="0" effort="100" velocity="10"/></joint>
  <joint name="sensor" type="fixed"><parent link="world"/><child link="imu"/></joint>
  <joint name="sole" type="fixed"><parent link="shank"/><child link="foot"/>
    <origin xyz="0 0 -0.45"/></joint>
</robot>"""


def test_a_leg_written_by_hand_is_a_double_pendulum():
    leg = from_urdf(LEG)  # the shank ends at its sole frame, 0.45 m down
    linkage = leg.linkage
    assert linkage.names == ("thigh", "shank") and set(leg.dropped) == {"imu", "foot"}
    assert leg.senses == (-1.0, -1.0)  # about +y: clockwise in the model's view
    assert leg.offsets == pytest.approx((-math.pi / 2, -math.pi / 2))  # hanging down
    assert linkage.links[0].origin == pytest.approx(1j)  # the hip 1 m up
    # the shank's centre of mass 1 cm forward of its axis, at 0.25 of its 0.45 m
    assert linkage.links[1].com == pytest.approx(0.25 / 0.45)
    assert linkage.links[1].com_lateral * 0.45 == pytest.approx(0.01)  # to the left of down
    q = {"hip": 0.3, "knee": -0.7}  # hip flexion about +y turns the leg back: clockwise
    psi = leg.psi(q)
    assert psi == pytest.approx([-math.pi / 2 - 0.3, -math.pi / 2 - 0.3 + 0.7])
    m1, m2, c1, l1, i1, i2 = 7.0, 3.0, 0.2, 0.42, 0.12, 0.05
    r2 = abs(complex(0.25, 0.01))  # the shank's centre of mass from the knee, off the axis
    a2 = math.atan2(0.01, 0.25)  # ... at this angle from the shank's line
    p1, p2 = psi
    expected = np.array([
        [m1 * c1**2 + i1 + m2 * l1**2, m2 * l1 * r2 * math.cos(p1 - p2 - a2)],
        [m2 * l1 * r2 * math.cos(p1 - p2 - a2), m2 * r2**2 + i2],
    ])  # fmt: skip
    np.testing.assert_allclose(np.asarray(Dynamics(linkage).function("mass_matrix")(psi)),
                               expected, rtol=1e-12)  # fmt: skip


@pytest.mark.parametrize(
    "change, message",
    [
        (('<axis xyz="0 1 0"/>', '<axis xyz="1 0 0"/>'), r"joint 'hip' turns about \[1.0"),
        (
            ('<origin xyz="0 0 -0.42"/>', '<origin xyz="0 0 -0.42" rpy="0.2 0 0"/>'),
            r"joint 'knee' turns about \[0.0, 0.98",  # its frame rolled: its axis too
        ),
        (
            ('type="revolute"><parent link="thigh"/>', 'type="prismatic"><parent link="thigh"/>'),
            "joint 'knee' is 'prismatic'",
        ),
        (
            ('<axis xyz="0 1 0"/>', '<axis xyz="1 0 0"/>'),
            r"joint 'hip' turns about \[1.0.*lock it",
        ),
    ],
)
def test_what_is_not_planar_is_refused_by_name(change, message):
    with pytest.raises(ValueError, match=message):
        from_urdf(LEG.replace(*change, 1), leaf_length={"shank": 0.45})


def test_children_at_different_points_hang_from_their_own_and_leaves_need_a_length():
    two = LEG.replace(
        "</robot>",
        """<link name="toe"><inertial><origin xyz="0.1 0 0"/>
      <mass value="0.5"/><inertia iyy="0.001"/></inertial></link>
      <joint name="ankle" type="continuous"><parent link="shank"/><child link="toe"/>
      <origin xyz="0 0 -0.40"/><axis xyz="0 -1 0"/></joint>
      <link name="spur"><inertial><origin xyz="0.1 0 0"/><mass value="0.5"/>
      <inertia iyy="0.001"/></inertial></link>
      <joint name="other" type="continuous"><parent link="shank"/><child link="spur"/>
      <origin xyz="0 0 -0.30"/><axis xyz="0 -1 0"/></joint></robot>""",
    )
    linkage = from_urdf(two).linkage
    shank, toe, spur = (linkage.links[linkage.index(n)] for n in ("shank", "toe", "spur"))
    assert shank.length == pytest.approx(0.40)  # to the farther hinge, the ankle
    assert toe.origin is None  # at the shank's end
    assert spur.origin == pytest.approx(0.30)  # 0.30 m along the shank, on its axis
    no_reach = LEG.replace('<origin xyz="0.01 0 -0.25"/>', '<origin xyz="0 0 0"/>')
    no_reach = no_reach.replace(
        '<parent link="shank"/><child link="foot"/>', '<parent link="world"/><child link="foot"/>'
    )  # no sole frame
    with pytest.raises(ValueError, match=r"leaf_length=\{'shank'"):
        from_urdf(no_reach)


def test_frames_turned_out_of_the_plane_count_by_their_world_axis():
    """The shank's frame rolled by -pi/2 at the knee (its content written in that frame: its
    centre of mass, its inertia's frame rolled back, its sole), its axis (0 0 1) the world's
    +y: the same leg as LEG's, read alike."""
    rolled = LEG.replace('<origin xyz="0 0 -0.42"/><axis xyz="0 1 0"/>',
                         '<origin xyz="0 0 -0.42" rpy="-1.5707963267948966 0 0"/>'
                         '<axis xyz="0 0 1"/>')  # fmt: skip
    rolled = rolled.replace(
        '<origin xyz="0.01 0 -0.25"/>', '<origin xyz="0.01 0.25 0" rpy="1.5707963267948966 0 0"/>'
    )
    rolled = rolled.replace(
        '<child link="foot"/>\n    <origin xyz="0 0 -0.45"/>',
        '<child link="foot"/>\n    <origin xyz="0 0.45 0"/>',
    )
    assert rolled.count("rpy=") == LEG.count("rpy=") + 2 and "0 0.45 0" in rolled
    plain, turned = from_urdf(LEG), from_urdf(rolled)
    assert turned.senses == plain.senses
    for a, b in zip(turned.linkage.links, plain.linkage.links, strict=True):
        assert (a.length, a.mass, a.com, a.inertia, a.com_lateral) == pytest.approx(
            (b.length, b.mass, b.com, b.inertia, b.com_lateral), rel=1e-9, abs=1e-12)  # fmt: skip


def test_fixed_and_locked_bodies_merge_into_one_rigid_body():
    """A 1 kg boot fixed 0.45 m down the shank (its centre 0.45 m below its frame), and a 2 kg
    tool on a joint about x locked at its zero (its inertial frame rolled by pi/2: its izz is
    the plane's moment): the shank's body by hand (masses, centre of mass, parallel axes)."""
    text = LEG.replace('<mass value="0"/>', '<mass value="1"/><inertia iyy="0.002"/>').replace(
        "</robot>",
        """<link name="tool"><inertial><origin xyz="0 0 -0.1" rpy="1.5707963267948966 0 0"/>
      <mass value="2"/><inertia ixx="0.01" iyy="0.5" izz="0.03"/></inertial></link>
      <joint name="wrist" type="revolute"><parent link="shank"/><child link="tool"/>
      <origin xyz="0 0 -0.2"/><axis xyz="1 0 0"/></joint></robot>""",
    )
    with pytest.raises(ValueError, match="joint 'wrist' turns about"):
        from_urdf(text)
    leg = from_urdf(text, lock=["wrist"])
    assert leg.merged == {"shank": ("foot", "tool")}
    shank = leg.linkage.links[1]
    parts = [(3.0, complex(0.01, -0.25), 0.05), (1.0, -0.9j, 0.002), (2.0, -0.3j, 0.03)]
    mass = sum(m for m, _, _ in parts)
    com = sum(m * c for m, c, _ in parts) / mass
    inertia = sum(j + m * abs(c - com) ** 2 for m, c, j in parts)
    assert shank.mass == pytest.approx(mass)
    assert shank.inertia == pytest.approx(inertia, rel=1e-12)
    # from the knee, along the shank's line at its zero-pose angle
    along = complex(shank.com, shank.com_lateral) * shank.length
    assert along * cmath.exp(1j * leg.offsets[1]) == pytest.approx(com, rel=1e-12)
    with pytest.raises(ValueError, match=r"`lock`: the URDF has no joint \['elbow'\]"):
        from_urdf(text, lock=["wrist", "elbow"])
