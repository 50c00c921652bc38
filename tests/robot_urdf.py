"""A biped robot's URDF written the way robots are described, for the tests: the base link
(``torso``) is the root, the legs hang from it at hips 0.09 m to either side, every joint moves
from the robot standing upright (legs straight down, feet flat), the right leg's hinges turn
about +y and the left leg's about -y (two encoder senses), a massless IMU frame, and each foot
(optional) carries massless ``heel`` and ``toe`` marks on its sole. The body is the six-link
scene's (``shared/scene.md``) and, with feet, Winter's feet (:class:`model.anthropometry.
FootGeometry`): the oracle is the preset linkage itself.
"""

from __future__ import annotations

from model.anthropometry import FOOT_COM, FootGeometry
from model.presets import SIX_LINK_TABLE

SIDES = {"right": (-0.09, "0 1 0"), "left": (0.09, "0 -1 0")}


def _inertial(x: float, z: float, mass: float, iyy: float) -> str:
    return (f'<inertial><origin xyz="{x!r} 0 {z!r}"/><mass value="{mass!r}"/>'
            f'<inertia ixx="{iyy!r}" ixy="0" ixz="0" iyy="{iyy!r}" iyz="0" '
            f'izz="{iyy / 4!r}"/></inertial>')  # fmt: skip


def _joint(name: str, parent: str, child: str, xyz: str, axis: str, effort: float = 150.0) -> str:
    return (f'<joint name="{name}" type="revolute"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{xyz}" rpy="0 0 0"/><axis xyz="{axis}"/>'
            f'<limit lower="-2.6" upper="2.6" effort="{effort!r}" velocity="20"/>'
            "</joint>")  # fmt: skip


def _fixed(name: str, parent: str, xyz: str) -> str:
    return (f'<link name="{name}"/><joint name="{name}_mount" type="fixed">'
            f'<parent link="{parent}"/><child link="{name}"/><origin xyz="{xyz}"/>'
            "</joint>")  # fmt: skip


def biped_urdf(feet: bool = False) -> str:
    """The URDF text (see the module)."""
    table = {name: (length, mass, com, inertia) for name, _, length, mass, com, inertia in
             SIX_LINK_TABLE}  # fmt: skip
    torso, head = table["torso"], table["head"]
    thigh, shank = table["swing_thigh"], table["swing_shank"]  # described from the hip down
    parts = ['<?xml version="1.0"?>', '<robot name="test_biped">',
             f'<link name="torso">{_inertial(0.0, torso[0] * torso[2], torso[1], torso[3])}'
             "</link>",
             f'<link name="head">{_inertial(0.0, head[0] * head[2], head[1], head[3])}</link>',
             _joint("neck_pitch", "torso", "head", f"0 0 {torso[0]!r}", "0 -1 0"),
             _fixed("imu", "torso", "0.05 0 0.3")]  # fmt: skip
    foot = FootGeometry()
    for side, (y, axis) in SIDES.items():
        parts += [
            f'<link name="{side}_thigh">'
            f"{_inertial(0.0, -thigh[0] * thigh[2], thigh[1], thigh[3])}</link>",
            f'<link name="{side}_shank">'
            f"{_inertial(0.0, -shank[0] * shank[2], shank[1], shank[3])}</link>",
            _joint(f"{side}_hip_pitch", "torso", f"{side}_thigh", f"0 {y!r} 0", axis),
            _joint(f"{side}_knee", f"{side}_thigh", f"{side}_shank", f"0 0 {-thigh[0]!r}", axis),
        ]
        if not feet:
            parts.append(_fixed(f"{side}_sole", f"{side}_shank", f"0 0 {-shank[0]!r}"))
            continue
        com = FOOT_COM * foot.toe
        parts += [
            f'<link name="{side}_foot">'
            f"{_inertial(com.real, com.imag, foot.segment_mass, foot.inertia)}</link>",
            _joint(f"{side}_ankle", f"{side}_shank", f"{side}_foot", f"0 0 {-shank[0]!r}", axis),
            _fixed(f"{side}_heel", f"{side}_foot", f"{foot.heel.real!r} 0 {foot.heel.imag!r}"),
            _fixed(f"{side}_toe", f"{side}_foot", f"{foot.toe.real!r} 0 {foot.toe.imag!r}"),
        ]
    parts.append("</robot>")
    return "\n".join(parts) + "\n"
