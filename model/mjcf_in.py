"""A robot's MJCF (MuJoCo's XML) read as the URDF of the same tree, so that its sagittal view
is read once (:func:`model.urdf.from_urdf`).

What is translated: the bodies under ``<worldbody>`` (one robot: the first body with joints
is its base; a ``freejoint``, ``free`` or ``slide`` joints and a hinge beside them on the base
are its floating base, not links), each body's frame (``pos``; ``quat``, ``euler`` with the
compiler's ``angle`` and ``eulerseq``, or ``axisangle``), its one joint (``hinge`` with its
``axis``, defaults from ``<default>`` classes, ``class`` and ``childclass`` resolved; none: the
body is fixed to its parent), its ``<inertial>`` (``pos``, ``quat``/``euler``, ``mass``,
``diaginertia`` or ``fullinertia``: turned into the body's axes), and its ``<site>``\\ s as
massless frames (a sole's ``heel`` and ``toe`` marks). Refused by name: a body with two joints
(not the base), a joint away from its body's origin, a ``ball`` joint, a body with geoms but no
``<inertial>`` (MuJoCo would infer the mass from the geoms; this reader does not), ``xyaxes``
and ``zaxis`` frames. Whether the robot is planar is :func:`model.urdf.from_urdf`'s to judge
(each moving joint's axis in the world).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from xml.sax.saxutils import quoteattr

import numpy as np

from model.urdf import from_urdf
from planner.errors import DefinitionError

#: joint attributes a default class may set
_JOINT_KEYS = ("type", "axis", "pos", "range", "limited")


def _f(value) -> str:
    return repr(float(value))


def _triple(values) -> str:
    return " ".join(_f(v) for v in values)


def _numbers(text: str | None, count: int, what: str) -> np.ndarray:
    values = [float(v) for v in (text or "").split()]
    if len(values) != count:
        raise DefinitionError(f"`mjcf`: {what}: {count} numbers, got {text!r}")
    return np.array(values)


def _rotation(element, degrees: bool, sequence: str, what: str) -> np.ndarray:
    """The 3 x 3 rotation of an element's frame (identity without one)."""
    for refused in ("xyaxes", "zaxis"):
        if element.get(refused) is not None:
            raise DefinitionError(f"`mjcf`: {what} sets its frame by {refused}; use quat or euler")
    if element.get("quat") is not None:
        w, x, y, z = _numbers(element.get("quat"), 4, f"{what} quat")
        norm = math.sqrt(w * w + x * x + y * y + z * z)
        w, x, y, z = w / norm, x / norm, y / norm, z / norm
        return np.array(
            [
                [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
            ]
        )
    if element.get("axisangle") is not None:
        *axis, angle = _numbers(element.get("axisangle"), 4, f"{what} axisangle")
        axis = np.array(axis) / np.linalg.norm(axis)
        angle = math.radians(angle) if degrees else angle
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k
    if element.get("euler") is not None:
        angles = _numbers(element.get("euler"), 3, f"{what} euler")
        angles = np.radians(angles) if degrees else angles
        rotation = np.eye(3)
        for axis_name, angle in zip(sequence, angles, strict=True):
            c, s = math.cos(angle), math.sin(angle)
            turn = {"x": [[1, 0, 0], [0, c, -s], [0, s, c]],
                    "y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],
                    "z": [[c, -s, 0], [s, c, 0], [0, 0, 1]]}[axis_name.lower()]  # fmt: skip
            # lower case: rotations about the moving axes (intrinsic), upper: fixed axes
            rotation = (
                rotation @ np.array(turn) if axis_name.islower() else np.array(turn) @ rotation
            )
        return rotation
    return np.eye(3)


def _rpy(rotation: np.ndarray) -> str:
    """URDF's rpy (fixed-axis roll, pitch, yaw: R = Rz Ry Rx) of a rotation."""
    pitch = -math.asin(max(-1.0, min(1.0, rotation[2, 0])))
    if abs(abs(rotation[2, 0]) - 1.0) < 1e-12:  # gimbal lock: the yaw taken as 0
        roll, yaw = math.atan2(-rotation[1, 2], rotation[1, 1]), 0.0
    else:
        roll = math.atan2(rotation[2, 1], rotation[2, 2])
        yaw = math.atan2(rotation[1, 0], rotation[0, 0])
    return f"{_f(roll)} {_f(pitch)} {_f(yaw)}"


class _Defaults:
    """``<default>`` classes' joint attributes, nested classes inheriting their parent's."""

    def __init__(self, root) -> None:
        self.classes: dict[str, dict] = {}
        top = root.find("default")
        if top is not None:
            self._read(top, "main", {})

    def _read(self, element, name: str, inherited: dict) -> None:
        values = dict(inherited)
        joint = element.find("joint")
        if joint is not None:
            values.update({k: joint.get(k) for k in _JOINT_KEYS if joint.get(k) is not None})
        self.classes[name] = values
        for child in element.findall("default"):
            self._read(child, child.get("class", name), values)

    def joint(self, element, childclass: str) -> dict:
        values = dict(self.classes.get(element.get("class", childclass), {}))
        values.update({k: element.get(k) for k in _JOINT_KEYS if element.get(k) is not None})
        return values


def mjcf_to_urdf(text: str) -> str:
    """The URDF text of an MJCF robot (see the module)."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as error:
        raise DefinitionError(f"`mjcf`: not XML ({error})") from None
    if root.tag != "mujoco":
        raise DefinitionError(f"`mjcf`: the root element is <{root.tag}>, not <mujoco>")
    compiler = root.find("compiler")
    degrees = compiler is None or compiler.get("angle", "degree") == "degree"
    sequence = "xyz" if compiler is None else compiler.get("eulerseq", "xyz")
    defaults = _Defaults(root)
    world = root.find("worldbody")
    bodies = [] if world is None else [b for b in world.findall("body")]
    robots = [b for b in bodies if any(True for _ in b.iter("joint"))
              or any(True for _ in b.iter("freejoint"))]  # fmt: skip
    if len(robots) != 1:
        raise DefinitionError(
            f"`mjcf`: one robot (a body with joints) under <worldbody>, got {len(robots)}"
        )
    lines = ['<?xml version="1.0"?>', f"<robot name={quoteattr(root.get('model', 'robot'))}>"]
    _body(robots[0], None, lines, defaults, degrees, sequence,
          robots[0].get("childclass", "main"))  # fmt: skip
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def _body(body, parent: str | None, lines: list, defaults, degrees, sequence, childclass) -> None:
    name = body.get("name")
    if not name:
        raise DefinitionError("`mjcf`: every body of the robot needs a name")
    childclass = body.get("childclass", childclass)
    what = f"body {name!r}"
    joints = [
        defaults.joint(j, childclass) | {"name": j.get("name")} for j in body.findall("joint")
    ]
    floating = body.find("freejoint") is not None or any(
        j.get("type") in ("free", "slide") for j in joints
    )
    if parent is None and floating:
        joints = []  # the floating base: its slides and pitch hinge are not links
    elif parent is None and joints:
        raise DefinitionError(
            f"`mjcf`: the base {what} is hinged to the world: a walking robot floats (a "
            "freejoint, or slides and a hinge)"
        )
    if len(joints) > 1:
        raise DefinitionError(f"`mjcf`: {what} has {len(joints)} joints: one per body")
    lines.append(f"  <link name={quoteattr(name)}>{_inertial(body, what, degrees, sequence)}"
                 "</link>")  # fmt: skip
    if parent is not None:
        xyz = _numbers(body.get("pos", "0 0 0"), 3, f"{what} pos")
        rpy = _rpy(_rotation(body, degrees, sequence, what))
        origin = f'<origin xyz="{_triple(xyz)}" rpy="{rpy}"/>'
        if joints:
            joint = joints[0]
            kind = joint.get("type", "hinge")
            if kind != "hinge":
                raise DefinitionError(f"`mjcf`: joint {joint['name']!r} is {kind!r}: hinges only")
            if np.any(_numbers(joint.get("pos", "0 0 0"), 3, "joint pos") != 0):
                raise DefinitionError(
                    f"`mjcf`: joint {joint['name']!r} sits away from its body's origin: move "
                    "the body's frame to the joint"
                )
            axis = _numbers(joint.get("axis", "0 0 1"), 3, f"joint {joint['name']!r} axis")
            lines.append(
                f'  <joint name={quoteattr(joint["name"] or name)} type="continuous">'
                f"<parent link={quoteattr(parent)}/><child link={quoteattr(name)}/>{origin}"
                f'<axis xyz="{_triple(axis)}"/></joint>'
            )
        else:
            lines.append(f'  <joint name={quoteattr(name + "_fixed")} type="fixed">'
                         f"<parent link={quoteattr(parent)}/><child link={quoteattr(name)}/>"
                         f"{origin}</joint>")  # fmt: skip
    for site in body.findall("site"):
        label = site.get("name")
        if not label:
            continue
        xyz = _numbers(site.get("pos", "0 0 0"), 3, f"site {label!r} pos")
        lines += [f"  <link name={quoteattr(label)}/>",
                  f'  <joint name={quoteattr(label + "_site")} type="fixed">'
                  f"<parent link={quoteattr(name)}/><child link={quoteattr(label)}/>"
                  f'<origin xyz="{_triple(xyz)}"/></joint>']  # fmt: skip
    for child in body.findall("body"):
        _body(child, name, lines, defaults, degrees, sequence, childclass)


def _inertial(body, what: str, degrees: bool, sequence: str) -> str:
    element = body.find("inertial")
    if element is None:
        if body.find("geom") is not None:
            raise DefinitionError(
                f"`mjcf`: {what} has geoms but no <inertial>: give its mass and inertia (MuJoCo "
                "infers them from the geoms; this reader does not)"
            )
        return ""
    xyz = _numbers(element.get("pos", "0 0 0"), 3, f"{what} inertial pos")
    mass = float(element.get("mass", "0"))
    if element.get("fullinertia") is not None:
        xx, yy, zz, xy, xz, yz = _numbers(element.get("fullinertia"), 6, f"{what} fullinertia")
        tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    else:
        tensor = np.diag(_numbers(element.get("diaginertia"), 3, f"{what} diaginertia"))
    rotation = _rotation(element, degrees, sequence, f"{what} inertial")
    tensor = rotation @ tensor @ rotation.T  # in the body's axes
    return (f'<inertial><origin xyz="{_triple(xyz)}"/>'
            f'<mass value="{mass!r}"/><inertia ixx="{_f(tensor[0, 0])}" ixy="{_f(tensor[0, 1])}" '
            f'ixz="{_f(tensor[0, 2])}" iyy="{_f(tensor[1, 1])}" iyz="{_f(tensor[1, 2])}" '
            f'izz="{_f(tensor[2, 2])}"/></inertial>')  # fmt: skip


def from_mjcf(text: str, **options):
    """:func:`model.urdf.from_urdf` of the MJCF's translation (options as there)."""
    return from_urdf(mjcf_to_urdf(text), **options)


__all__ = ["from_mjcf", "mjcf_to_urdf"]
