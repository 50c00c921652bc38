"""A robot's URDF as a walking biped: its sagittal legs and trunk, rooted at a foot.

A legged robot's URDF hangs its legs from the pelvis (the base link) and moves each joint
from the robot's own zero pose. The walking problems (:func:`problems.walking_step`,
:func:`problems.footed_step`) plan a tree rooted at the stance foot, legs named stance and
swing. :func:`walker_from_urdf` reads the URDF's sagittal view (:func:`model.urdf.from_urdf`:
hinges about y; other joints to ``lock``; fixed parts merged) and builds that tree:

* **the legs**: the two chains of two links (thigh, shank: point feet) or three (thigh,
  shank, foot: feet) hanging from one link at one hinge point (the hip), mirror images in the
  sagittal view; their sides are named from ``legs`` {side: thigh link} or from the thigh
  links' names (``right``/``left``, ``r_``/``l_``);
* **the stance leg** (``stance_side``) described from the ground up: ``stance_foot`` from its
  toe mark (H0) to the ankle (feet), ``stance_shank`` from the ankle (point feet: from the
  shank's end, the foot point) to the knee, ``stance_thigh`` from the knee to the hip; the
  same rigid bodies, their centres of mass and inertias carried over (a point p of a link
  described from its other end is at l - p);
* **the swing leg** from the hip down: ``swing_thigh``, ``swing_shank`` and ``swing_foot``
  (ankle to toe mark);
* **the upper body**: the link the legs hang from, described from the hip (its line from the
  hip to its farthest point, an end or a frame it carries: a trunk up to the neck, a pelvis
  with a merged torso up to its head's camera), keeping its name; the links above it
  unchanged.

The feet's contacts are the foot's massless frames (fixed joints) named with ``heel`` and
``toe`` (or ``ball``), as a sole's marks: ``stance_toe`` = H0, ``stance_heel``, ``swing_heel``,
``swing_toe`` = the swing foot's end (:func:`problems.footed_step`'s ``points``).

:class:`UrdfWalker` keeps the robot's terms: each physical joint's URDF name, and how its URDF
angle follows from the plan's link angles, q_urdf = sense (psi_child - psi_parent - zero), so
that a joint-space file (:func:`problems.robot.joint_space`) names every drive as the robot
does and states its encoder's sign and offset.
"""

from __future__ import annotations

import cmath
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from model.linkage import Link, Linkage
from model.mjcf_in import mjcf_to_urdf
from model.points import LinkPoint
from model.urdf import UrdfLinkage, from_urdf
from planner.errors import DefinitionError
from problems.human.joints import wrapped

#: a side's name guessed from a thigh link's name
_SIDE_PATTERNS = (("right", re.compile(r"(^|[^a-z])(right|r)([^a-z]|$)", re.I)),
                  ("left", re.compile(r"(^|[^a-z])(left|l)([^a-z]|$)", re.I)))  # fmt: skip
#: a leg's joints, from the hip down
LEG_JOINTS = ("hip", "knee", "ankle")
#: mirror legs agree to this relative tolerance (lengths, masses, centres, inertias)
MIRROR_RTOL = 1e-9


@dataclass(frozen=True)
class UrdfWalker:
    """A robot's URDF as a walking biped (see the module).

    Attributes
    ----------
    linkage : the walking tree, rooted at the stance foot (point feet: at the stance shank's
        foot point), legs named stance_* and swing_*, the upper body's links by their URDF names.
    points : the feet's contacts by role (feet), or None (point feet).
    sides : (the stance leg's side, the swing leg's) in the plan's step.
    joints : {"<side>_<hip|knee|ankle>" or an upper-body link: the URDF joint that moves it}.
    encoders : {the same keys: (parent link, child link, sense, zero rad)} in the plan's links:
        q_urdf = sense (psi_child - psi_parent - zero).
    robot : the URDF's sagittal linkage as read (:class:`model.urdf.UrdfLinkage`).
    trunk_zero : the trunk's angle (its line from the hip) at the URDF's zero pose, rad.
    limits : {joint key: the URDF joint's <limit> (effort N m, lower and upper rad, velocity
        rad/s), those it gives}.
    """

    linkage: Linkage
    points: dict[str, LinkPoint] | None
    sides: tuple[str, str]
    joints: dict[str, str]
    encoders: dict[str, tuple[str, str, float, float]]
    robot: UrdfLinkage
    trunk_zero: float = math.pi / 2
    limits: dict[str, dict[str, float]] = field(default_factory=dict)

    @property
    def feet(self) -> bool:
        return self.points is not None

    def hinge_limits(self, default: float) -> dict[str, float]:
        """Each hinge of the plan's tree bounded by its physical joint's URDF effort (the
        smaller of the two sides: the legs swap every step), ``default`` N m where the URDF
        gives none: the stance and swing ankles, knees and hips by their joints (the trunk's
        hinge on the stance thigh by the hips': the stance hip's drive carries the trunk's
        torque and the swing thigh's), the upper body's links by theirs. The root of a walker
        on feet (the ground's torque) is left out."""

        def effort(joint: str) -> float:
            value = self._effort(joint)
            return float(default) if value is None else value

        names = self.linkage.names
        roles = {"stance_shank": "ankle", "stance_thigh": "knee", "swing_thigh": "hip",
                 "swing_shank": "knee", "swing_foot": "ankle"}  # fmt: skip
        out = {}
        for i, name in enumerate(names):
            if name == "stance_foot":
                continue
            if name in roles:
                out[name] = effort(roles[name])
            elif self.linkage.parents[i] == names.index("stance_thigh"):
                out[name] = effort("hip")  # the trunk
            else:
                out[name] = float(self.limits.get(name, {}).get("effort", default))
        return out

    def joint_range(self, joint: str, default: tuple[float, float],
                    neutral: tuple[float, float] = (0.0, 0.0)) -> tuple[float, float]:  # fmt: skip
        """The plan's range of ``joint`` ("knee": flexion psi_thigh - psi_shank; "ankle":
        plantarflexion from the neutral, psi_shank - psi_foot - ``neutral`` (stance, swing))
        within both legs' URDF limits and ``default`` (the walking model's own: no
        hyperextended knee), rad."""
        low, high = default
        for k, side in enumerate(self.sides):
            key = f"{side}_{joint}"
            limits = self.limits.get(key, {})
            if key not in self.encoders or "lower" not in limits or "upper" not in limits:
                continue
            _, _, sense, zero = self.encoders[key]
            # q_urdf = sense (psi_child - psi_parent - zero), the child below the parent:
            # the plan's angle psi_parent - psi_child (- neutral) = -sense q_urdf - zero
            ends = [-sense * limits[e] - zero - neutral[k] for e in ("lower", "upper")]
            low, high = max(low, min(ends)), min(high, max(ends))
        if not low < high:
            raise DefinitionError(
                f"`urdf`: the {joint}s' URDF limits leave no range within {default} rad"
            )
        return low, high

    def hip_limit(self) -> float | None:
        """The hips' URDF effort (the smaller side's), N m, or None: the bound of the
        physical stance hip (``walking_step(hip_limit=...)``)."""
        return self._effort("hip")

    def _effort(self, joint: str) -> float | None:
        """The smaller of the two sides' URDF efforts of ``joint`` (the legs swap every step),
        N m, or None when neither side gives one."""
        values = [self.limits.get(f"{side}_{joint}", {}).get("effort") for side in self.sides]
        values = [v for v in values if v is not None]
        return min(values) if values else None

    def metadata(self, source: str | None = None) -> dict[str, Any]:
        """What a plan's file keeps of the robot (JSON): the URDF's path, the sides, and each
        joint's URDF name and encoder (parent, child, sense, zero)."""
        return {
            "urdf": source,
            "sides": list(self.sides),
            "joints": dict(self.joints),
            "encoders": {k: [p, c, s, z] for k, (p, c, s, z) in self.encoders.items()},
            "trunk_zero_rad": self.trunk_zero,
            "limits": {k: dict(v) for k, v in self.limits.items()},
        }


def read_urdf_walker(path: str | Path, **options) -> UrdfWalker:
    """:func:`walker_from_urdf` of the file at ``path``, a URDF or an MJCF (MuJoCo's XML,
    translated by :func:`model.mjcf_in.mjcf_to_urdf`; told apart by the root element)
    (options as there)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise DefinitionError(f"`urdf`: cannot read {str(path)!r} ({error.strerror})") from None
    try:
        root = ET.fromstring(text).tag
    except ET.ParseError as error:
        raise DefinitionError(f"`urdf`: {str(path)!r} is not XML ({error})") from None
    if root == "mujoco":
        text = mjcf_to_urdf(text)
    return walker_from_urdf(text, **options)


def _geometry(robot: UrdfLinkage) -> dict[str, tuple[complex, complex, complex]]:
    """{link: (start, end, centre of mass)} at the URDF's zero pose, x + j z, m."""
    linkage = robot.linkage
    starts: dict[int, complex] = {}
    out = {}
    for i, link in enumerate(linkage.links):
        parent = linkage.parents[i]
        if parent < 0:
            start = complex(link.origin or 0j)
        else:
            start = starts[parent] + cmath.exp(1j * robot.offsets[parent]) * complex(
                linkage.origin_in_parent(i)
            )
        starts[i] = start
        turn = cmath.exp(1j * robot.offsets[i])
        out[link.name] = (start, start + turn * link.length, start + turn * link.com_offset)
    return out


@dataclass
class _Plan:
    """The walking tree as it is described: its links in order, each one's angle at the
    robot's zero pose (``zero``, rad) and the URDF link each one is (``plan_of`` {URDF link:
    plan link})."""

    links: list = field(default_factory=list)
    zero: dict = field(default_factory=dict)
    plan_of: dict = field(default_factory=dict)

    def describe(self, name: str, parent: str | None, source: Link, start: complex,
                 end: complex, com: complex) -> None:  # fmt: skip
        """``source``'s rigid body as the link ``name`` from ``start`` to ``end`` (zero-pose
        points x + j z), its centre of mass at ``com``."""
        vector = end - start
        local = (com - start) / vector
        self.links.append(Link(name, parent, abs(vector), source.mass, local.real,
                               source.inertia, local.imag,
                               rerooted=not 0.0 <= local.real <= 1.0))  # fmt: skip
        self.zero[name] = cmath.phase(vector)
        self.plan_of[source.name] = name


def _legs(robot: UrdfLinkage, legs: Mapping[str, str] | None) -> tuple[str, dict[str, list[str]]]:
    """(the link the legs hang from, {side: [thigh, shank(, foot)]})."""
    linkage = robot.linkage
    names = linkage.names

    def chain(i: int) -> list[int] | None:
        members = [i]
        while linkage.children[members[-1]]:
            if len(linkage.children[members[-1]]) != 1:
                return None
            members.append(linkage.children[members[-1]][0])
        return members if len(members) in (2, 3) else None

    if legs is not None:
        if not isinstance(legs, Mapping) or len(legs) != 2:
            raise DefinitionError(f"`legs`: {{side: thigh link}} for two legs, got {legs!r}")
        found = {}
        for side, thigh in legs.items():
            if thigh not in names:
                raise DefinitionError(f"`legs`: {side}: the URDF's sagittal view has no moving "
                                      f"link {thigh!r}; its links: {list(names)}")  # fmt: skip
            members = chain(names.index(thigh))
            if members is None:
                raise DefinitionError(f"`legs`: {side}: {thigh!r} does not start a chain of two "
                                      "or three links (thigh, shank, foot)")  # fmt: skip
            found[side] = members
    else:
        found = {}
        for parent in range(linkage.n):
            chains = [c for c in linkage.children[parent] if chain(c) is not None]
            if len(chains) == 2:
                found = {f"leg{k}": chain(c) for k, c in enumerate(chains)}
                break
        if not found:
            raise DefinitionError(
                "`urdf`: no two legs (chains of two or three links, thigh to shank or foot, "
                "hanging from one link) in the robot's sagittal view; lock the joints that are "
                "not in it (lock=[...]) or name the thighs (legs={side: link})"
            )
        guessed = {}
        for members in found.values():
            thigh = names[members[0]]
            sides = [side for side, pattern in _SIDE_PATTERNS if pattern.search(thigh)]
            if len(sides) != 1:
                raise DefinitionError(
                    f"`legs`: cannot tell the side of the leg starting at {thigh!r} from its "
                    "name (right/left, r_/l_); name the thighs: legs={'right': ..., 'left': ...}"
                )
            guessed[sides[0]] = members
        if len(guessed) != 2:
            raise DefinitionError(f"`legs`: both legs read as {list(guessed)}; name the thighs: "
                                  "legs={'right': ..., 'left': ...}")  # fmt: skip
        found = guessed
    parents = {linkage.parents[m[0]] for m in found.values()}
    lengths = {len(m) for m in found.values()}
    if len(parents) != 1 or -1 in parents or len(lengths) != 1:
        raise DefinitionError(
            "`legs`: two legs of the same number of links hanging from one link (the pelvis or "
            f"trunk), got { ({s: [names[i] for i in m] for s, m in found.items()}) }"
        )
    return names[parents.pop()], {s: [names[i] for i in m] for s, m in found.items()}


def _mirrored(robot: UrdfLinkage, legs: dict[str, list[str]], geometry) -> None:
    """Refuse legs that are not mirror images in the sagittal view (naming the parameter)."""
    a, b = legs.values()
    for one, two in zip(a, b, strict=True):
        first, second = (robot.linkage.links[robot.linkage.index(n)] for n in (one, two))
        for name in ("length", "mass", "com", "inertia", "com_lateral"):
            x, y = getattr(first, name), getattr(second, name)
            if abs(x - y) > MIRROR_RTOL * max(1.0, abs(x), abs(y)):
                raise DefinitionError(
                    f"`urdf`: the legs differ in the sagittal view: {one} {name} {x!r}, {two} "
                    f"{y!r}; the walking step swaps the legs at every strike, so they must be "
                    "mirror images"
                )
    if abs(geometry[a[0]][0] - geometry[b[0]][0]) > 1e-9:
        raise DefinitionError("`urdf`: the hips are at different points of the sagittal view")


def _marks(robot: UrdfLinkage, foot: str, sole=None, geometry=None) -> tuple[complex, complex]:
    """(heel, toe) marks of ``foot`` (zero-pose points x + j z): ``sole`` (heel x, toe x, z
    from the ankle), else its massless frames named heel and toe (or ball)."""
    if sole is not None:
        ankle = geometry[foot][0]
        return ankle + complex(sole[0], sole[2]), ankle + complex(sole[1], sole[2])
    found = {}
    for frame, (owner, point) in robot.frames.items():
        if owner != foot:
            continue
        for role, words in (("heel", ("heel",)), ("toe", ("toe", "ball"))):
            if any(word in frame.lower() for word in words):
                if role in found:
                    raise DefinitionError(f"`urdf`: foot {foot!r} has two {role} frames")
                found[role] = point
    missing = [role for role in ("heel", "toe") if role not in found]
    if missing:
        raise DefinitionError(
            f"`urdf`: foot {foot!r} needs massless frames (fixed joints) named with 'heel' and "
            f"'toe' (or 'ball') where its sole touches the ground, or give sole=(heel x, toe x, "
            f"z) from the ankle (walk --sole); missing {missing}"
        )
    return found["heel"], found["toe"]


def walker_from_urdf(
    text: str,
    *,
    legs: Mapping[str, str] | None = None,
    stance_side: str | None = None,
    lock: Iterable[str] = (),
    leaf_length: Mapping[str, float] | None = None,
    sole: tuple[float, float, float] | None = None,
    gravity: float = 9.81,
) -> UrdfWalker:
    """The walking biped of a robot's URDF (see the module). ``stance_side``: the leg in
    stance in the plan's step (default: the first side, right before left); ``sole``: the
    feet's heel and toe as (heel x, toe x, z) m from the ankle in the robot's zero pose (x
    forward, z up), for a URDF whose feet carry no heel and toe frames (its sole's collision
    box, read off by the user)."""
    if sole is not None:
        if (not isinstance(sole, tuple | list) or len(sole) != 3
                or not all(isinstance(v, int | float) and math.isfinite(v) for v in sole)
                or not sole[0] < sole[1]):  # fmt: skip
            raise DefinitionError(
                f"`sole`: (heel x, toe x, z) m from the ankle, the heel behind the toe, got "
                f"{sole!r}"
            )
    robot = from_urdf(text, leaf_length=leaf_length, lock=lock)
    trunk, sides_legs = _legs(robot, legs)
    order = sorted(sides_legs, key=lambda s: (s != "right", s != "left", s))
    if stance_side is None:
        stance_side = order[0]
    if stance_side not in sides_legs:
        raise DefinitionError(f"`stance_side`: one of {order}, got {stance_side!r}")
    swing_side = next(s for s in order if s != stance_side)
    geometry = _geometry(robot)
    _mirrored(robot, sides_legs, geometry)
    stance, swing = sides_legs[stance_side], sides_legs[swing_side]
    plan = _Plan()
    points = _legs_described(plan, robot, geometry, stance, swing, sole)
    hip = geometry[stance[0]][0]
    far = _upper_body_described(plan, robot, geometry, trunk, hip, set(stance) | set(swing))
    linkage = Linkage(plan.links, gravity=gravity)
    joints, encoders = _encoders(robot, linkage, plan, (stance_side, swing_side), (stance, swing))
    return UrdfWalker(linkage, points, (stance_side, swing_side), joints, encoders, robot,
                      cmath.phase(far - hip), _limits(text, joints))  # fmt: skip


def _legs_described(plan: _Plan, robot, geometry, stance, swing, sole):
    """The stance leg from the ground up (each link from its end to its start; a foot from
    its toe mark to the ankle) and the swing leg from the hip down (a foot from the ankle to
    its toe mark); returns the feet's contacts (feet) or None (point feet)."""
    source = {link.name: link for link in robot.linkage.links}
    roles = ("thigh", "shank", "foot")
    feet = len(stance) == 3
    if feet:
        heel, toe = _marks(robot, stance[2], sole, geometry)
        ankle, _, com = geometry[stance[2]]
        plan.describe("stance_foot", None, source[stance[2]], toe, ankle, com)
    for k in (1, 0):
        start, end, com = geometry[stance[k]]
        parent = plan.links[-1].name if plan.links else None
        plan.describe(f"stance_{roles[k]}", parent, source[stance[k]], end, start, com)
    for k, role in enumerate(roles[: len(swing)]):
        start, end, com = geometry[swing[k]]
        parent = "stance_thigh" if k == 0 else f"swing_{roles[k - 1]}"
        if role == "foot":
            swing_heel, end = _marks(robot, swing[2], sole, geometry)
        plan.describe(f"swing_{role}", parent, source[swing[k]], start, end, com)
    if not feet:
        return None
    return {
        "stance_toe": LinkPoint("stance_foot", 0.0, 0.0, name="stance_toe"),
        "stance_heel": _point("stance_foot", toe, geometry[stance[2]][0], heel),
        "swing_heel": _point("swing_foot", geometry[swing[2]][0], end, swing_heel),
        "swing_toe": LinkPoint("swing_foot", 1.0, 0.0, name="swing_toe"),
    }


def _upper_body_described(plan: _Plan, robot, geometry, trunk: str, hip: complex,
                          leg_links: set) -> complex:  # fmt: skip
    """The trunk from the hip to its farthest point (its ends or a frame it carries: a merged
    torso's head camera, the line a pelvis-rooted humanoid's trunk is drawn and leans by),
    the links above it as they are (those hinged on the trunk at their points on its new
    line); returns that farthest point."""
    start, end, com = geometry[trunk]
    marks = [point for owner, point in robot.frames.values() if owner == trunk]
    far = max((start, end, *marks), key=lambda p: abs(p - hip))
    source = {link.name: link for link in robot.linkage.links}
    plan.describe(trunk, "stance_thigh", source[trunk], hip, far, com)
    trunk_turn = cmath.exp(1j * plan.zero[trunk])
    for link in robot.linkage.links:
        if link.name == trunk or link.name in leg_links:
            continue
        if link.parent in leg_links:
            raise DefinitionError(
                f"`urdf`: {link.name!r} hangs from the leg link {link.parent!r}: a leg is a "
                "chain; lock its joint to merge it"
            )
        if link.parent == trunk:
            where = (geometry[link.name][0] - hip) / trunk_turn
            link = replace(link, origin=None if abs(where - abs(far - hip)) < 1e-12 else where)
        plan.links.append(link)
        plan.zero[link.name] = robot.offsets[robot.linkage.index(link.name)]
        plan.plan_of[link.name] = link.name
    return far


def _limits(text: str, joints: Mapping[str, str]) -> dict[str, dict[str, float]]:
    """{joint key: its URDF <limit>'s effort, lower, upper and velocity, those given}."""
    by_name = {j.get("name"): j for j in ET.fromstring(text).iter("joint")}
    out = {}
    for key, name in joints.items():
        limit = by_name[name].find("limit") if name in by_name else None
        if limit is not None:
            out[key] = {k: float(limit.get(k)) for k in ("effort", "lower", "upper", "velocity")
                        if limit.get(k) is not None}  # fmt: skip
    return out


def _point(link: str, start: complex, end: complex, point: complex) -> LinkPoint:
    """``point`` (zero pose) on ``link`` (stance_foot, swing_foot) described from ``start``
    to ``end``, named ``<side>_heel``."""
    local = (point - start) / (end - start)
    return LinkPoint(link, local.real, local.imag, name=link.replace("foot", "heel"))


def _encoders(robot, linkage: Linkage, plan: _Plan, sides, legs):
    """Each physical joint's URDF name and encoder in the plan's links (see UrdfWalker):
    the legs' by side and joint, the upper body's by the link they move."""
    joints, encoders = {}, {}
    names = robot.linkage.names

    def encoder(link: str) -> tuple[str, tuple[str, str, float, float]]:
        i = names.index(link)
        child, parent = plan.plan_of[link], plan.plan_of[names[robot.linkage.parents[i]]]
        zero = float(wrapped(plan.zero[child] - plan.zero[parent]))
        return robot.joints[i], (parent, child, robot.senses[i], zero)

    for side, members in zip(sides, legs, strict=True):
        for k, link in enumerate(members):
            joints[f"{side}_{LEG_JOINTS[k]}"], encoders[f"{side}_{LEG_JOINTS[k]}"] = encoder(link)
    legs_and_trunk = {plan.plan_of[link] for members in legs for link in members}
    for link in linkage.links:
        if link.parent is None or link.name in legs_and_trunk or link.parent == "stance_thigh":
            continue
        joints[link.name], encoders[link.name] = encoder(link.name)
    return joints, encoders


def urdf_angles(walker: UrdfWalker, psi: np.ndarray) -> dict[str, np.ndarray]:
    """Each URDF joint's angle, rad, at the plan's link angles ``psi`` (K, n) (or (n,)):
    {URDF joint name: values}."""
    psi = np.asarray(psi, dtype=float)
    names = walker.linkage.names
    out = {}
    for key, (parent, child, sense, zero) in walker.encoders.items():
        difference = psi[..., names.index(child)] - psi[..., names.index(parent)] - zero
        out[walker.joints[key]] = sense * wrapped(difference)
    return out


__all__ = ["UrdfWalker", "read_urdf_walker", "urdf_angles", "walker_from_urdf"]
