"""URDF of a planar linkage, and a planar linkage from a robot's URDF (its sagittal view).

The plane is the robot's sagittal plane, as in :mod:`model.mjcf`: the model's point x + j y is
the URDF point (x, 0, y) (x forward, z up), and a counter-clockwise model angle turns +x toward
+z: a rotation about -y. So every hinge of :func:`to_urdf` has the axis (0, -1, 0); each link's
frame sits at its start hinge with its x axis along the link (all links along +x at the zero
pose), the child's joint at (l, 0, 0) of its parent's frame, and the URDF joint angle is the
relative angle q_i = psi_i - psi_parent(i). The root hangs on a ``continuous`` joint from a
massless ``ground`` link at H0 (its ``origin``). Inertials: mass, centre of mass (x along the
link, z to its left), and the moment of inertia about the centre of mass J as i_yy (the two
out-of-plane moments J / 2, so that the tensor is physical; a planar motion never excites
them). A link without children ends at a massless frame ``<link>_end`` (fixed at (l, 0, 0)).

:func:`from_urdf` reads any URDF whose moving joints turn about the y axis (either sense) and
keeps what its sagittal view shows. A link moved by a hinge is a model link; links ``fixed`` to
it (a pelvis to its torso, a battery, a cover) or joined by a joint named in ``lock`` (a hip's
roll and yaw, a waist, the arms: held at their zero) are merged into it: one rigid body, its
mass, centre of mass (projected) and i_yy about the axis through it (every part's inertia
tensor turned into the plane's axes, by the parallel-axis theorem). Each link runs from its
joint to its farthest moving child's hinge point (in the x-z projection: left and right hips at
the same x and z are one hinge point); children hinged elsewhere on it (the legs at the bottom
of a trunk whose neck is at the top) hang from their own points (``Link.origin``). Frames are
followed in 3-D (every joint's and inertial's ``rpy``): a moving joint belongs to the plane
when its axis is the world's y at the zero pose, whatever its frame's turn. It refuses, naming
the joint or link and the reason, a robot that is not planar in that view: a moving joint about
another axis (lock it, or the robot is not planar), a ``prismatic`` or ``floating`` joint, a
body with mass fixed to a massless root (welded to the world). Massless links of fixed joints
(sensors, frames) are dropped. A link without moving children away from its joint ends at its
farthest massless frame (a sole, a tip: :func:`to_urdf` writes one, ``<link>_end``), or at
``leaf_length`` {link: m} along its centre of mass's direction, or else twice its centre of
mass's distance from its joint (the centre of mass then halfway).
The zero pose need not be the model's: :class:`UrdfLinkage` keeps each link's angle at the
URDF's zero pose and each joint's sense, so that psi = offset + sum over the chain of sense q.
"""

from __future__ import annotations

import cmath
import math
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from xml.sax.saxutils import quoteattr

import numpy as np

from model.linkage import Link, Linkage
from planner.errors import DefinitionError

#: The massless link the root hangs from in :func:`to_urdf`.
GROUND = "ground"
#: A hinge axis within this of the y axis (unit vectors) counts as the y axis.
AXIS_TOLERANCE = 1e-9


def to_urdf(
    linkage: Linkage,
    name: str = "linkage",
    torque_limits: Mapping[str, float] | float | None = None,
    speed_limit: float = 100.0,
) -> str:
    """The URDF text of ``linkage`` (see the module): ``torque_limits`` {link: N m} or one
    number for every hinge (the joints' ``effort``; default none: 1e6), ``speed_limit``
    rad/s (the joints' ``velocity``, which URDF requires with an effort)."""
    if not isinstance(linkage, Linkage):
        raise DefinitionError(f"`linkage`: must be a model.Linkage, got {type(linkage).__name__}")
    if isinstance(torque_limits, Mapping):
        efforts = {n: float(torque_limits.get(n, 1e6)) for n in linkage.names}
    else:
        effort = 1e6 if torque_limits is None else float(torque_limits)
        efforts = dict.fromkeys(linkage.names, effort)
    lines = ['<?xml version="1.0"?>', f"<robot name={quoteattr(name)}>",
             f"  <link name={quoteattr(GROUND)}/>"]  # fmt: skip
    for link in linkage.links:
        inertia = float(link.inertia)
        com = (link.com * link.length, link.com_lateral * link.length)
        lines += [
            f"  <link name={quoteattr(link.name)}>",
            "    <inertial>",
            f'      <origin xyz="{com[0]!r} 0 {com[1]!r}" rpy="0 0 0"/>',
            f'      <mass value="{float(link.mass)!r}"/>',
            f'      <inertia ixx="{inertia / 2!r}" ixy="0" ixz="0" iyy="{inertia!r}" iyz="0" '
            f'izz="{inertia / 2!r}"/>',
            "    </inertial>",
            "  </link>",
        ]
    for i, link in enumerate(linkage.links):
        parent = linkage.parents[i]
        if parent < 0:
            origin = 0j if link.origin is None else complex(link.origin)
            parent_name = GROUND
        else:
            origin = linkage.origin_in_parent(i)
            parent_name = linkage.names[parent]
        lines += [
            f'  <joint name={quoteattr("hinge_" + link.name)} type="continuous">',
            f"    <parent link={quoteattr(parent_name)}/>",
            f"    <child link={quoteattr(link.name)}/>",
            f'    <origin xyz="{origin.real!r} 0 {origin.imag!r}" rpy="0 0 0"/>',
            '    <axis xyz="0 -1 0"/>',
            f'    <limit effort="{efforts[link.name]!r}" velocity="{float(speed_limit)!r}"/>',
            "  </joint>",
        ]
    for i, link in enumerate(linkage.links):
        if linkage.children[i]:
            continue
        tip = f"{link.name}_end"  # the leaf's end hinge point: a massless frame
        lines += [
            f"  <link name={quoteattr(tip)}/>",
            f'  <joint name={quoteattr(tip)} type="fixed">',
            f"    <parent link={quoteattr(link.name)}/>",
            f"    <child link={quoteattr(tip)}/>",
            f'    <origin xyz="{float(link.length)!r} 0 0" rpy="0 0 0"/>',
            "  </joint>",
        ]
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class UrdfLinkage:
    """:func:`from_urdf`'s result: the ``linkage``; per link, the URDF joint that moves it
    (``joints``), that joint's sense (``senses``: +1 for an axis along -y, the model's
    counter-clockwise, -1 along +y) and the link's model angle at the URDF's zero pose
    (``offsets``, rad): psi_i = offsets_i + sum over i and its ancestors k of senses_k q_k;
    ``dropped``: the massless links of fixed joints left out; ``merged`` {link: the URDF links
    fixed or locked to it, whose mass it carries}; ``frames`` {dropped frame: (the model link
    that carries it, its point x + j z at the zero pose, m)}: a sole's heel and toe marks."""

    linkage: Linkage
    joints: tuple[str, ...]
    senses: tuple[float, ...]
    offsets: tuple[float, ...]
    dropped: tuple[str, ...]
    merged: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    frames: Mapping[str, tuple[str, complex]] = field(default_factory=dict)

    def psi(self, q) -> np.ndarray:
        """The model's absolute angles (n,) at the URDF joint angles ``q`` {joint: rad}."""
        linkage = self.linkage
        values = np.array([float(q.get(j, 0.0)) * s for j, s in zip(self.joints, self.senses,
                                                                      strict=True)])  # fmt: skip
        return np.array(self.offsets) + linkage.ancestry() @ values


def _floats(text: str | None, count: int, what: str) -> list[float]:
    values = [float(v) for v in (text or " ".join(["0"] * count)).split()]
    if len(values) != count:
        raise DefinitionError(f"`urdf`: {what}: {count} numbers, got {text!r}")
    return values


def _origin(element, what: str) -> tuple[np.ndarray, np.ndarray]:
    """(xyz (3,), rotation (3, 3)) of an element's <origin> (rpy: fixed-axis roll, pitch,
    yaw, R = Rz Ry Rx)."""
    origin = element.find("origin") if element is not None else None
    xyz = _floats(None if origin is None else origin.get("xyz"), 3, f"{what} origin xyz")
    roll, pitch, yaw = _floats(None if origin is None else origin.get("rpy"), 3,
                               f"{what} origin rpy")  # fmt: skip
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))  # fmt: skip
    rotation = np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                         [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                         [-sp, cp * sr, cp * cr]])  # fmt: skip
    return np.array(xyz), rotation


def _xz(point: np.ndarray) -> complex:
    """A world point (3,) in the sagittal plane: x + j z."""
    return complex(point[0], point[2])


@dataclass(frozen=True)
class _Tree:
    """A URDF's links by name, each link's joints to its children, the root link."""

    links: dict
    children: dict
    root: str

    def child(self, joint) -> str:
        return joint.find("child").get("link")

    def massless(self, name: str) -> bool:
        """No mass in the link and its subtree, and no moving joint under it."""
        joints = self.children[name]
        return (_mass(self.links[name]) == 0.0 and all(j.get("type") == "fixed" for j in joints)
                and all(self.massless(self.child(j)) for j in joints))  # fmt: skip


def _tree(text: str) -> _Tree:
    """The URDF's tree, refusing joints that are neither hinges nor fixed."""
    try:
        robot = ET.fromstring(text)
    except ET.ParseError as error:
        raise DefinitionError(f"`urdf`: not XML ({error})") from None
    links = {link.get("name"): link for link in robot.findall("link")}
    children: dict[str, list] = {name: [] for name in links}
    parent_of: dict[str, str] = {}
    for joint in robot.findall("joint"):
        name = joint.get("name")
        parent, child = joint.find("parent").get("link"), joint.find("child").get("link")
        if parent not in links or child not in links:
            raise DefinitionError(f"`urdf`: joint {name!r} joins links the file does not have")
        kind = joint.get("type")
        if kind not in ("revolute", "continuous", "fixed"):
            raise DefinitionError(
                f"`urdf`: joint {name!r} is {kind!r}: only hinges (revolute, continuous) and "
                "fixed joints make a planar linkage"
            )
        children[parent].append(joint)
        parent_of[child] = parent
    roots = [name for name in links if name not in parent_of]
    if len(roots) != 1:
        raise DefinitionError(f"`urdf`: one root link, got {roots}")
    return _Tree(links, children, roots[0])


def _sense(joint, rotation: np.ndarray) -> float:
    """+1 for a hinge about the world's -y at the zero pose (the model's counter-clockwise),
    -1 about +y (``rotation``: the joint frame's, world at the zero pose); any other axis
    refused."""
    element = joint.find("axis")
    axis = np.array(_floats("1 0 0" if element is None else element.get("xyz"), 3,
                            f"joint {joint.get('name')!r} axis"))  # fmt: skip
    axis = rotation @ (axis / np.linalg.norm(axis))
    if abs(abs(axis[1]) - 1.0) > AXIS_TOLERANCE:
        raise DefinitionError(
            f"`urdf`: joint {joint.get('name')!r} turns about {axis.tolist()}, not the y axis: "
            "lock it (from_urdf(..., lock=[its name])) to read the robot's sagittal (x-z) view, "
            "or the robot is not planar"
        )
    return -float(np.sign(axis[1]))


@dataclass
class _Walk:
    """The tree walked at its zero pose: each URDF link's frame (world x + j z of its origin,
    its turn), the model's links in order (link, its joint, its model parent), each hinge's
    sense, each model link's rigid body (the URDF links it carries: itself and those fixed or
    locked to it), the massless frames each model link carries (``tips``) and the massless
    links dropped."""

    frames: dict = field(default_factory=dict)
    order: list = field(default_factory=list)
    senses: dict = field(default_factory=dict)
    bodies: dict = field(default_factory=dict)
    tips: dict = field(default_factory=dict)
    dropped: list = field(default_factory=list)
    marks: dict = field(default_factory=dict)


def _walk(tree: _Tree, lock: frozenset) -> _Walk:
    """Every link moved by a hinge about y (not in ``lock``) is a model link, carrying the
    links fixed or locked under it; the root too when its rigid body has mass (a floating
    base then hangs at H0)."""
    walk = _Walk()

    def rigid(joint) -> bool:
        return joint.get("type") == "fixed" or joint.get("name") in lock

    def rigid_mass(link: str) -> float:
        return _mass(tree.links[link]) + sum(rigid_mass(tree.child(j))
                                             for j in tree.children[link] if rigid(j))  # fmt: skip

    def visit(link: str, frame: tuple[np.ndarray, np.ndarray], owner: str | None) -> None:
        walk.frames[link] = frame
        for joint in tree.children[link]:
            child = tree.child(joint)
            xyz, turn = _origin(joint, f"joint {joint.get('name')!r}")
            child_frame = (frame[0] + frame[1] @ xyz, frame[1] @ turn)
            if rigid(joint):
                if tree.massless(child) and joint.get("name") not in lock:
                    walk.dropped.append(child)  # a frame (a sensor, a sole, a tip): maybe an end
                    if owner is not None:
                        walk.tips.setdefault(owner, []).append(_xz(child_frame[0]))
                        walk.marks[child] = (owner, _xz(child_frame[0]))
                    continue
                if owner is None:
                    raise DefinitionError(
                        f"`urdf`: joint {joint.get('name')!r} fixes {child!r}, which has mass or "
                        "moving joints, to the massless root: the robot is welded to the world"
                    )
                walk.bodies[owner].append(child)  # one rigid body with its owner
                visit(child, child_frame, owner)
                continue
            walk.senses[child] = _sense(joint, child_frame[1])
            walk.order.append((child, joint.get("name"), owner))
            walk.bodies[child] = [child]
            visit(child, child_frame, child)

    if rigid_mass(tree.root) > 0:
        walk.senses[tree.root] = 1.0
        walk.order.append((tree.root, None, None))
        walk.bodies[tree.root] = [tree.root]
        visit(tree.root, (np.zeros(3), np.eye(3)), tree.root)
    else:
        visit(tree.root, (np.zeros(3), np.eye(3)), None)
    unknown = sorted(lock - {j.get("name") for js in tree.children.values() for j in js})
    if unknown:
        raise DefinitionError(f"`lock`: the URDF has no joint {unknown}")
    if not walk.order:
        raise DefinitionError("`urdf`: no moving joint (hinge about y)")
    return walk


def _end(link: str, walk: _Walk, com: complex, leaf_length) -> complex:
    """Where ``link`` ends in the plane: its farthest moving child's hinge point (the others
    hang from it at their own points), else its farthest massless frame, else
    ``leaf_length`` (or twice its centre of mass's reach) along its centre of mass's
    direction."""
    start = _xz(walk.frames[link][0])
    ends = [_xz(walk.frames[child][0]) for child, _, parent in walk.order if parent == link]
    ends = [e for e in ends if abs(e - start) > 1e-9]
    if ends:
        return max(ends, key=lambda e: abs(e - start))
    given = (leaf_length or {}).get(link)
    if walk.tips.get(link) and given is None:
        return max(walk.tips[link], key=lambda tip: abs(tip - start))
    reach = abs(com - start)
    if given is None and reach < 1e-9:
        raise DefinitionError(
            f"`urdf`: link {link!r} has no child away from its joint and its centre of mass is "
            f"at its joint: give its length, leaf_length={{{link!r}: metres}}"
        )
    rotation = walk.frames[link][1]
    direction = (com - start) / reach if reach > 1e-9 else complex(rotation[0, 0], rotation[2, 0])
    return start + direction * (2.0 * reach if given is None else float(given))


def _body(tree: _Tree, walk: _Walk, link: str) -> tuple[float, complex, float]:
    """(mass kg, centre of mass (world x + j z at the zero pose), moment of inertia about
    the axis through it normal to the plane, kg m^2) of ``link``'s rigid body."""
    parts = []
    for member in walk.bodies[link]:
        element = tree.links[member]
        mass = _mass(element)
        if mass == 0.0:
            continue
        start, turn = walk.frames[member]
        xyz, rotation = _origin(element.find("inertial"), f"link {member!r} inertial")
        parts.append((mass, _xz(start + turn @ xyz), _inertia_yy(element, turn @ rotation)))
    mass = math.fsum(m for m, _, _ in parts)
    if mass <= 0:
        raise DefinitionError(f"`urdf`: link {link!r} has no mass")
    com = sum(m * c for m, c, _ in parts) / mass
    inertia = math.fsum(j + m * abs(c - com) ** 2 for m, c, j in parts)
    return mass, com, inertia


def from_urdf(
    text: str,
    leaf_length: Mapping[str, float] | None = None,
    lock: Iterable[str] = (),
) -> UrdfLinkage:
    """The planar linkage of a URDF's sagittal view (see the module); the joints named in
    ``lock`` (any axis: a hip's roll and yaw, the arms) are held at their zero and their
    links merged into the link they hang from, as fixed joints' are."""
    if isinstance(lock, str) or not all(isinstance(j, str) for j in lock):
        raise DefinitionError(f"`lock`: joint names (a list of str), got {lock!r}")
    tree = _tree(text)
    walk = _walk(tree, frozenset(lock))
    built, offsets, starts = [], {}, {}
    for link, _, model_parent in walk.order:
        start = _xz(walk.frames[link][0])
        mass, com, inertia = _body(tree, walk, link)
        vector = _end(link, walk, com, leaf_length) - start
        if abs(vector) < 1e-12:
            raise DefinitionError(f"`urdf`: link {link!r} has no length in the sagittal view")
        local = (com - start) / vector  # in units of the link: along + j lateral
        if model_parent is None:
            origin = start
        else:
            # the hinge in the parent's frame; None where the parent ends (the paper's form)
            parent = built[[b.name for b in built].index(model_parent)]
            where = (start - starts[model_parent]) / cmath.exp(1j * offsets[model_parent])
            origin = None if abs(where - parent.length) < 1e-12 else where
        built.append(Link(link, model_parent, abs(vector), mass, float(local.real), inertia,
                          float(local.imag), origin=origin,
                          rerooted=not 0.0 <= local.real <= 1.0))  # fmt: skip
        offsets[link], starts[link] = cmath.phase(vector), start
    merged = {link: tuple(walk.bodies[link][1:]) for link, _, _ in walk.order}
    return UrdfLinkage(Linkage(built), tuple(j or "" for _, j, _ in walk.order),
                       tuple(walk.senses[link] for link, _, _ in walk.order),
                       tuple(offsets[link] for link, _, _ in walk.order), tuple(walk.dropped),
                       {k: v for k, v in merged.items() if v}, dict(walk.marks))  # fmt: skip


def _mass(link) -> float:
    inertial = link.find("inertial")
    if inertial is None or inertial.find("mass") is None:
        return 0.0
    return float(inertial.find("mass").get("value"))


def _inertia_yy(link, rotation: np.ndarray) -> float:
    """The moment of inertia about the world's y axis through the centre of mass: e_y' I e_y
    with the tensor I given in the inertial frame, turned by ``rotation`` (world)."""
    inertia = link.find("inertial").find("inertia")
    if inertia is None:
        return 0.0
    get = {k: float(inertia.get(k, 0.0)) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    tensor = np.array([[get["ixx"], get["ixy"], get["ixz"]],
                       [get["ixy"], get["iyy"], get["iyz"]],
                       [get["ixz"], get["iyz"], get["izz"]]])  # fmt: skip
    axis = rotation.T @ np.array([0.0, 1.0, 0.0])  # the y axis in the inertial frame
    return float(axis @ tensor @ axis)


__all__ = ["GROUND", "UrdfLinkage", "from_urdf", "to_urdf"]
