"""MJCF (MuJoCo's model format) of a planar linkage, and the map between the two coordinates.

The model's plane (x right, y up) is MuJoCo's x-z plane (z up, gravity along -z): a point
x + j y of the model is (x, 0, y) in MuJoCo. A counter-clockwise angle of the model turns +x
towards +y, i.e. +x towards +z in MuJoCo: a rotation about -y, so every hinge has the axis
(0, -1, 0) and a positive MuJoCo angle is a positive model angle.

Each link is a body whose frame sits at the link's start hinge with its x axis along the link
(the model's frame e^{j psi_i}); a point ``a + j b`` of the link's frame (along + j to the left)
is ``(a, 0, b)`` in the body. MuJoCo's hinge angles are relative to the parent body,

    q_i = psi_i - psi_parent(i)        (q_root = psi_root),

so psi = A q with A[i, k] = 1 when k is i or an ancestor of i. The generalised force of the
relative angle q_k is the sum of the model's Q_i = M_i - sum_{c child of i} M_c over k's
subtree, which telescopes to the hinge torque M_k: MuJoCo's joint forces are the model's hinge
torques, one for one, and its mass matrix is A^T M(psi) A.

A floating base (``base="floating"``) puts two slides (x, then z: the model's y) and the root's
hinge on the root body, all at H0: qpos = (x0, y0, psi_root, q_2..q_n), the model's floating
coordinates (x0, y0, psi) by the same A on the angles (:mod:`model.floating`).

Only the inertial data are exact and used: masses, centres of mass (on or off the axis) and the
moment of inertia about the centre of mass J (the body's y-y inertia; the two out-of-plane
moments, which a planar motion never excites, are J / 2 each so that MuJoCo's triangle
inequality holds). Geoms carry no mass (``inertiafromgeom="false"``): the links are drawn as
capsules that collide with nothing, contacts are small spheres on a plane whose surface is
lowered by their radius, so that a sphere touches it when its centre, the model's contact
point, is at y = 0.

MuJoCo numbers its joints in the order of the bodies in the file (depth first), which need
not be the linkage's order: :attr:`MjcfModel.hinge_index` says where each link's hinge is in
qpos. A foot (``feet``) is a small body hinged at a link's end (an ankle with its own motor)
whose sole is two contact spheres, a heel behind and a toe ahead of the ankle at the ankle's
height: a foot flat on the ground puts its ankle where the model's point foot is, at y = 0,
and carries the ankle torque a point foot cannot (its centre of pressure anywhere on the
sole). Its mass is not the model's: keep it small (``foot_mass``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from xml.sax.saxutils import quoteattr

import numpy as np

from model.linkage import Linkage
from model.points import LinkPoint
from planner.errors import DefinitionError, DefinitionTypeError, check_positive

#: MuJoCo's hinge axis for the model's counter-clockwise angle (a rotation about -y)
HINGE_AXIS = "0 -1 0"
#: names of the floating base's slide joints (MuJoCo's x and z: the model's x and y)
BASE_JOINTS = ("base_x", "base_y")


@dataclass(frozen=True)
class Contact:
    """A contact point of a linkage with the ground: a small sphere in the MJCF.

    link : str
        The link that carries it.
    along : float
        Distance from the link's start hinge along its axis, m (0: the start hinge, the
        link's length: its end hinge).
    name : str
        The geom's name in the MJCF.
    lateral : float
        Distance from the axis, m, positive to the link's left (a heel below a foot's axis).
    """

    link: str
    along: float
    name: str
    lateral: float = 0.0

    @property
    def position(self) -> complex:
        """The point in its link's frame, m (x along the axis, y to its left)."""
        return complex(self.along, self.lateral)


@dataclass(frozen=True)
class Foot:
    """A foot of the MJCF: a body at ``link``'s ``end`` ("start" or "end"), hinged there (the
    ankle, motor ``M_ankle_<link>``), its sole from ``heel`` m behind to ``toe`` m ahead of
    the ankle (behind: -x when the foot is flat, its angle 0)."""

    link: str
    end: str
    heel: float
    toe: float

    @property
    def body(self) -> str:
        return f"foot_{self.link}"

    @property
    def joint(self) -> str:
        return f"ankle_{self.link}"


def contacts_at(
    linkage: Linkage, points: Sequence[tuple[str, str] | LinkPoint]
) -> tuple[Contact, ...]:
    """Contacts at link ends, ``points`` as (link name, "start" or "end") pairs, or anywhere
    on a link, as :class:`model.LinkPoint` (a heel and a ball on a foot link).

    The geom of ("stance_shank", "start") is named ``stance_shank_start``, as the model's
    contact-force columns are (``F_stance_shank_start_x``); a LinkPoint's is its name (or
    its label).
    """
    contacts = []
    for i, point in enumerate(points):
        if isinstance(point, LinkPoint):
            if point.link not in linkage.names:
                raise DefinitionError(
                    f"`contacts[{i}]`: no link named {point.link!r}; the links are "
                    f"{list(linkage.names)}"
                )
            offset = point.offset(linkage)
            contacts.append(Contact(point.link, offset.real, point.label, offset.imag))
            continue
        if not isinstance(point, tuple) or len(point) != 2:
            raise DefinitionTypeError(
                f"`contacts[{i}]`: must be a (link name, 'start' or 'end') pair or a "
                f"model.LinkPoint, got {point!r}"
            )
        link, end = point
        if link not in linkage.names:
            raise DefinitionError(
                f"`contacts[{i}]`: no link named {link!r}; the links are {list(linkage.names)}"
            )
        if end not in ("start", "end"):
            raise DefinitionError(f"`contacts[{i}]`: the end must be 'start' or 'end', got {end!r}")
        length = linkage.links[linkage.index(link)].length
        contacts.append(Contact(link, 0.0 if end == "start" else length, f"{link}_{end}"))
    return tuple(contacts)


def _read_only(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class MjcfModel:
    """An MJCF text and the map between its coordinates and the model's.

    xml : str
        The MJCF document (``mujoco.MjModel.from_xml_string(xml)``).
    linkage : Linkage
        The linkage it was written from.
    floating : bool
        True when the root moves freely in the plane (qpos starts with x0, y0).
    actuated : tuple of str
        The link names whose start hinge carries a motor, in MuJoCo's actuator order (ctrl).
    contacts : tuple of Contact
        The contact spheres on links, in geom order.
    hinge_index : tuple of int
        qpos (and qvel) index of each link's hinge, in the linkage's order.
    feet : tuple of Foot
        The feet, and ``ankle_index`` the qpos index of each foot's ankle.
    """

    xml: str
    linkage: Linkage
    floating: bool
    actuated: tuple[str, ...]
    contacts: tuple[Contact, ...]
    hinge_index: tuple[int, ...]
    feet: tuple[Foot, ...] = ()
    ankle_index: tuple[int, ...] = ()

    @property
    def nq(self) -> int:
        """Length of MuJoCo's qpos (= qvel: no quaternions in a planar model)."""
        return self.linkage.n + (2 if self.floating else 0) + len(self.feet)

    @cached_property
    def ancestry(self) -> np.ndarray:
        """A (n, n): psi = A q, A[i, k] = 1 when link k is link i or one of its ancestors
        (read-only: built once, a controller reads it every period)."""
        return _read_only(self.linkage.ancestry())

    @cached_property
    def coordinates(self) -> np.ndarray:
        """T (m, nq): the model's coordinates, (x0, y0, psi) (m = n + 2) or psi (m = n), are
        T times MuJoCo's qpos (the feet's ankles do not enter). Read-only: built once."""
        n = self.linkage.n
        base = 2 if self.floating else 0
        matrix = np.zeros((n + base, self.nq))
        matrix[:base, :base] = np.eye(base)
        matrix[base:, list(self.hinge_index)] = self.ancestry
        return _read_only(matrix)

    @cached_property
    def _foot_links(self) -> list[int]:
        return [self.linkage.index(foot.link) for foot in self.feet]

    def qpos(self, psi, base=(0.0, 0.0), feet=None) -> np.ndarray:
        """MuJoCo's qpos (nq,) or (K, nq) from the model's angles psi (n,) or (K, n) rad,
        floating, the root hinge's displacement (x0, y0) m, (2,) or (K, 2), and the feet's
        absolute angles (len(feet),) rad (default 0: flat)."""
        return self._assemble(psi, base, feet, "psi", offsets=True)

    def qvel(self, dpsi, dbase=(0.0, 0.0), dfeet=None) -> np.ndarray:
        """MuJoCo's qvel from dpsi (n,) or (K, n) rad/s, floating, the root hinge's velocity
        (dx0, dy0) m/s, and the feet's absolute angular velocities (default 0)."""
        return self._assemble(dpsi, dbase, dfeet, "dpsi", offsets=False)

    def model_coordinates(self, qpos) -> np.ndarray:
        """The model's (x0, y0, psi) (floating) or psi from MuJoCo's qpos (or qvel, qacc)."""
        qpos = self._check_q(qpos)
        return qpos @ self.coordinates.T

    def feet_angles(self, qpos) -> np.ndarray:
        """The feet's absolute angles (or rates, from qvel), rad: the ankle plus its link's."""
        qpos = self._check_q(qpos)
        psi = self.model_coordinates(qpos)[..., 2 if self.floating else 0 :]
        return psi[..., self._foot_links] + qpos[..., list(self.ankle_index)]

    def joint_forces(self, torques) -> np.ndarray:
        """MuJoCo's generalised forces (nq,) of the model's hinge torques M (n,) N m.

        The relative angles' forces are the hinge torques themselves (module docstring); the
        slides of a floating base and the ankles get none.
        """
        torques = np.asarray(torques, dtype=float)
        if torques.shape[-1] != self.linkage.n:
            raise DefinitionError(
                f"`torques`: one per link ({self.linkage.n}), got shape {torques.shape}"
            )
        out = np.zeros((*torques.shape[:-1], self.nq))
        out[..., list(self.hinge_index)] = torques
        return out

    def _check_q(self, qpos) -> np.ndarray:
        qpos = np.asarray(qpos, dtype=float)
        if qpos.shape[-1] != self.nq:
            raise DefinitionError(
                f"`qpos`: MuJoCo's coordinates of this model have {self.nq} entries, got "
                f"shape {qpos.shape}"
            )
        return qpos

    def _assemble(self, angles, base, feet, name: str, offsets: bool) -> np.ndarray:
        angles = np.asarray(angles, dtype=float)
        relative = self._relative(angles, name)
        out = np.zeros((*relative.shape[:-1], self.nq))
        out[..., list(self.hinge_index)] = relative
        if self.floating:
            out[..., :2] = self._base(base, "base" if offsets else "dbase")
        if self.feet:
            feet = np.zeros(len(self.feet)) if feet is None else np.asarray(feet, dtype=float)
            if feet.shape[-1:] != (len(self.feet),):
                raise DefinitionError(
                    f"`feet`: one angle per foot ({len(self.feet)}), got shape {feet.shape}"
                )
            links = [self.linkage.index(foot.link) for foot in self.feet]
            out[..., list(self.ankle_index)] = feet - angles[..., links]
        return out

    def _relative(self, angles, name: str) -> np.ndarray:
        angles = np.asarray(angles, dtype=float)
        if angles.shape[-1] != self.linkage.n:
            raise DefinitionError(
                f"`{name}`: one angle per link ({self.linkage.n}), got shape {angles.shape}"
            )
        parents = np.asarray(self.linkage.parents)
        relative = angles.copy()
        has_parent = parents >= 0
        relative[..., has_parent] -= angles[..., parents[has_parent]]
        return relative

    @staticmethod
    def _base(base, name: str) -> np.ndarray:
        base = np.asarray(base, dtype=float)
        if base.shape[-1:] != (2,):
            raise DefinitionError(f"`{name}`: (x, y) of the root hinge, got shape {base.shape}")
        return base


def to_mjcf(
    linkage: Linkage,
    *,
    base: str = "fixed",
    contacts: Sequence[tuple[str, str]] = (),
    contact_radius: float = 0.005,
    friction: float = 0.8,
    torque_limits: Mapping[str, float] | float | None = None,
    timestep: float = 0.0005,
    name: str = "linkage",
    feet: Sequence[tuple[str, str, float, float]] = (),
    foot_mass: float = 0.05,
) -> MjcfModel:
    """Write an MJCF model of a planar linkage (module docstring for the conventions).

    Parameters
    ----------
    linkage : Linkage
    base : "fixed" or "floating"
        "fixed": the root's start hinge H0 is a motor-driven hinge to the world (a
        manipulator, the paper's pinned stance foot). "floating": the root moves freely in the
        plane (two slides and an unactuated hinge at H0): a walker that stands on contacts.
    contacts : sequence of (link name, "start" | "end")
        Points that touch the ground: a sphere of ``contact_radius`` each, on a ground plane.
        None: no ground in the model.
    contact_radius : float
        m (> 0); the plane is lowered by it, so a contact touches when its point is at y = 0.
    friction : float
        Coulomb friction coefficient of the contacts (> 0).
    torque_limits : mapping link name -> N m, a number for every hinge, or None
        The motors' control range; None: unlimited.
    timestep : float
        MuJoCo's time step, s (> 0).
    name : str
        The model's name.
    feet : sequence of (link name, "start" | "end", heel m, toe m)
        Feet hinged at those link ends (module docstring), flat at ankle angle -psi_link.
    foot_mass : float
        kg (> 0) of each foot (not in the model: small).

    Returns
    -------
    MjcfModel
        The text and the coordinate map; ``mujoco`` is not needed to write it.
    """
    if not isinstance(linkage, Linkage):
        raise DefinitionTypeError(
            f"`linkage`: must be a model.Linkage, got {type(linkage).__name__}"
        )
    if base not in ("fixed", "floating"):
        raise DefinitionError(
            f"`base`: 'fixed' (H0 hinged to the world) or 'floating' (free in the plane), "
            f"got {base!r}"
        )
    floating = base == "floating"
    contact_points = contacts_at(linkage, tuple(contacts))
    radius = check_positive("contact_radius", contact_radius, "m")
    mu = check_positive("friction", friction, "")
    dt = check_positive("timestep", timestep, "s")
    actuated = linkage.names[1:] if floating else linkage.names
    limits = _limits(torque_limits, linkage, actuated)
    foot_list = []
    for i, entry in enumerate(feet):
        if not isinstance(entry, tuple) or len(entry) != 4:
            raise DefinitionTypeError(
                f"`feet[{i}]`: must be (link name, 'start' or 'end', heel m, toe m), got {entry!r}"
            )
        (contact,) = contacts_at(linkage, [entry[:2]])
        heel = check_positive(f"feet[{i}] heel", entry[2], "m")
        toe = check_positive(f"feet[{i}] toe", entry[3], "m")
        foot_list.append(Foot(contact.link, entry[1], heel, toe))
    foot_weight = check_positive("foot_mass", foot_mass, "kg")

    lines = [
        f"<mujoco model={quoteattr(name)}>",
        '  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>',
        f'  <option timestep="{dt!r}" gravity="0 0 {-linkage.gravity!r}" '
        'integrator="implicitfast" cone="elliptic"/>',
        "  <default>",
        # no passive forces: the model has none (armature, damping, friction loss all 0)
        '    <joint armature="0" damping="0" frictionloss="0" limited="false"/>',
        '    <geom contype="0" conaffinity="0" group="1"/>',
        "  </default>",
        "  <worldbody>",
    ]
    if contact_points or foot_list:
        lines.append(
            f'    <geom name="ground" type="plane" size="0 0 1" pos="0 0 {-radius!r}" '
            f'contype="0" conaffinity="1" condim="3" friction="{mu!r} 0.005 0.0001" group="0"/>'
        )
    thickness = 0.04 * max(link.length for link in linkage.links)
    by_link: dict[str, list] = {}
    for contact in contact_points:
        by_link.setdefault(contact.link, []).append(contact)
    feet_by_link = {foot.link: foot for foot in foot_list}
    joints: list[str] = []  # MuJoCo's qpos order: the bodies' order in the file

    def body(i: int, depth: int) -> None:
        link = linkage.links[i]
        pad = "  " * depth
        origin = linkage.origin_in_parent(i)
        lines.append(f"{pad}<body name={quoteattr(link.name)} pos={_xz(origin)}>")
        if i == 0 and floating:
            lines.append(f'{pad}  <joint name="{BASE_JOINTS[0]}" type="slide" axis="1 0 0"/>')
            lines.append(f'{pad}  <joint name="{BASE_JOINTS[1]}" type="slide" axis="0 0 1"/>')
            joints.extend(BASE_JOINTS)
        lines.append(
            f'{pad}  <joint name={quoteattr(link.name)} type="hinge" axis="{HINGE_AXIS}"/>'
        )
        joints.append(link.name)
        com = link.com_offset
        # J about the plane's normal; the out-of-plane moments only need to be valid
        inertia = link.inertia
        lines.append(
            f'{pad}  <inertial pos={_xz(com)} mass="{link.mass!r}" '
            f'diaginertia="{inertia / 2!r} {inertia!r} {inertia / 2!r}"/>'
        )
        lines.append(
            f'{pad}  <geom name={quoteattr(link.name + "_capsule")} type="capsule" '
            f'fromto="0 0 0 {link.length!r} 0 0" size="{thickness!r}" mass="0"/>'
        )
        for contact in by_link.get(link.name, ()):
            lines.append(
                f'{pad}  <geom name={quoteattr(contact.name)} type="sphere" '
                f'pos={_xz(contact.position)} size="{radius!r}" contype="1" '
                f'conaffinity="0" condim="3" friction="{mu!r} 0.005 0.0001" group="0"/>'
            )
        foot = feet_by_link.get(link.name)
        if foot is not None:
            at = 0.0 if foot.end == "start" else link.length
            small = foot_weight * (foot.heel + foot.toe) ** 2 / 12.0
            lines.extend(
                [
                    f"{pad}  <body name={quoteattr(foot.body)} pos={_xz(complex(at))}>",
                    f"{pad}    <joint name={quoteattr(foot.joint)} "
                    f'type="hinge" axis="{HINGE_AXIS}"/>',
                    f"{pad}    <inertial pos={_xz(complex(0.5 * (foot.toe - foot.heel)))} "
                    f'mass="{foot_weight!r}" diaginertia="{small / 2!r} {small!r} {small / 2!r}"/>',
                    f'{pad}    <geom name={quoteattr(foot.body + "_sole")} type="capsule" '
                    f'fromto="{-foot.heel!r} 0 0 {foot.toe!r} 0 0" size="{thickness / 2!r}" '
                    'mass="0"/>',
                ]
            )
            for part, x in (("heel", -foot.heel), ("toe", foot.toe)):
                lines.append(
                    f'{pad}    <geom name={quoteattr(f"{foot.link}_{part}")} type="sphere" '
                    f'pos={_xz(complex(x))} size="{radius!r}" contype="1" conaffinity="0" '
                    f'condim="3" friction="{mu!r} 0.005 0.0001" group="0"/>'
                )
            lines.append(f"{pad}  </body>")
            joints.append(foot.joint)
        for c in linkage.children[i]:
            body(c, depth + 1)
        lines.append(f"{pad}</body>")

    body(0, 2)
    lines.append("  </worldbody>")
    lines.append("  <actuator>")
    for link_name in actuated:
        limit = limits.get(link_name)
        bound = "" if limit is None else f' ctrlrange="{-limit!r} {limit!r}"'
        lines.append(
            f"    <motor name={quoteattr('M_' + link_name)} joint={quoteattr(link_name)} "
            f'gear="1"{bound}/>'
        )
    for foot in foot_list:
        lines.append(
            f"    <motor name={quoteattr('M_' + foot.joint)} joint={quoteattr(foot.joint)} "
            'gear="1"/>'
        )
    lines.append("  </actuator>")
    lines.append("</mujoco>")
    return MjcfModel(
        xml="\n".join(lines) + "\n",
        linkage=linkage,
        floating=floating,
        actuated=tuple(actuated),
        contacts=contact_points,
        hinge_index=tuple(joints.index(link_name) for link_name in linkage.names),
        feet=tuple(foot_list),
        ankle_index=tuple(joints.index(foot.joint) for foot in foot_list),
    )


def _xz(point: complex) -> str:
    """A model point x + j y as MuJoCo's quoted "x 0 z"."""
    return f'"{point.real!r} 0 {point.imag!r}"'


def _limits(torque_limits, linkage: Linkage, actuated) -> dict[str, float]:
    if torque_limits is None:
        return {}
    if isinstance(torque_limits, Mapping):
        limits = {}
        for key, value in torque_limits.items():
            if key not in actuated:
                raise DefinitionError(
                    f"`torque_limits`: {key!r} is not an actuated hinge; the motors are "
                    f"{list(actuated)}"
                )
            limits[key] = check_positive(f"torque_limits[{key!r}]", value, "N m")
        return limits
    return dict.fromkeys(actuated, check_positive("torque_limits", torque_limits, "N m"))
