"""A contact: a point of a link touching the ground, with its friction.

One concept for every place a body meets the ground: the stance foot of a walking step, the
landing foot at heel strike and through a double support, the contact forces an OCP adds as
controls (``planner.OCP(contacts=...)``), the verification of a file and the simulation that
watches a gait for slips. Each asks the contact, never writes the cone itself:

* :meth:`Contact.cone`: the rows that are >= 0 when a ground force (or an impulse) can be
  carried: the ground pushes (Fy >= 0) and, with friction mu, stays in its cone
  (mu Fy - Fx >= 0 and mu Fy + Fx >= 0, two smooth rows an NLP takes; together they imply
  Fy >= 0). The same code serves CasADi expressions and numpy arrays.
* :meth:`Contact.cone_margin`: the smallest of those rows, mu Fy - |Fx| (N, or N s for an
  impulse): how far inside the cone a sampled force stays, negative outside.
* :meth:`Contact.violation`: why a force cannot be carried (pulled off, slipping), in words, or
  None; :meth:`Contact.friction_use`: |Fx| / (mu Fy), the part of the cone a force uses (the
  walking pictures draw it).

The ground is flat and horizontal (:class:`Ground`: y = height, normal +y): forces are in the
world frame, x along the ground and y up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from model.linkage import Linkage
from model.linkage_naming import root_contact
from model.points import LinkPoint, label_identifier
from planner.errors import DefinitionError, DefinitionTypeError, check_real


@dataclass(frozen=True)
class Ground:
    """Flat horizontal ground: the line y = ``height`` (m), pushing along +y."""

    height: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "height", check_real("height", self.height))


@dataclass(frozen=True)
class Contact:
    """A point of a link (``point``, :class:`model.LinkPoint`) that touches ``ground``.

    ``friction``: the Coulomb friction coefficient mu (> 0, finite) of the pair, or None for
    a contact whose tangential force is not limited (it only pushes). ``name``: the contact's
    name in rows, columns and messages; default the point's label (``swing_shank_end``).
    """

    point: LinkPoint
    friction: float | None = None
    ground: Ground = field(default_factory=Ground)
    name: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.point, LinkPoint):
            raise DefinitionTypeError(
                f"`point`: must be a model.LinkPoint (the link and where on it), got "
                f"{type(self.point).__name__}"
            )
        if self.friction is not None:
            mu = check_real("friction", self.friction)
            if mu <= 0:
                raise DefinitionError(
                    f"`friction`: the friction coefficient must be > 0, got {mu!r}; give None "
                    "for a contact whose tangential force is not limited"
                )
            object.__setattr__(self, "friction", mu)
        if not isinstance(self.ground, Ground):
            raise DefinitionTypeError(
                f"`ground`: must be a model.Ground, got {type(self.ground).__name__}"
            )
        if self.name is not None and (not isinstance(self.name, str) or not self.name.strip()):
            raise DefinitionTypeError(
                f"`name`: a contact's name must be a non-empty string or None, got {self.name!r}"
            )

    @classmethod
    def at_root(
        cls, linkage: Linkage, friction: float | None = None, ground: Ground | None = None
    ) -> Contact:
        """The contact at H0, the start hinge of ``linkage``'s root (a walker's stance foot,
        pinned), named ``<root>_start`` as the files' ground-reaction columns are."""
        root = linkage.names[0]
        point = LinkPoint(root, along=0.0, name=root_contact(linkage.names))
        return cls(point, friction, ground if ground is not None else Ground())

    @property
    def label(self) -> str:
        """The name, or the point's label."""
        return self.name if self.name is not None else self.point.label

    @property
    def identifier(self) -> str:
        """The label as a name part (letters, digits, single underscores): the ground force's
        controls and file columns are ``F_<identifier>_x``, ``F_<identifier>_y``."""
        return label_identifier(self.label)

    @property
    def cone_rows(self) -> tuple[str, ...]:
        """The names of the rows of :meth:`cone`, in order."""
        if self.friction is None:
            return ("push",)
        return ("mu Fy - Fx", "mu Fy + Fx")

    def cone(self, fx, fy):
        """The rows >= 0 inside the cone for a force (Fx, Fy) of the ground on the point, N
        (or an impulse, N s): (mu Fy - Fx, mu Fy + Fx) with friction, (Fy,) without.

        CasADi expressions give a column (``ca.vertcat``); numbers or numpy arrays of any
        matching shape give an array with the rows along a new first axis.
        """
        rows = [fy] if self.friction is None else [self.friction * fy - fx, self.friction * fy + fx]
        if any(isinstance(row, ca.SX | ca.MX | ca.DM) for row in rows):
            return ca.vertcat(*rows)
        return np.stack(np.broadcast_arrays(*[np.asarray(row, dtype=float) for row in rows]))

    def cone_margin(self, fx, fy) -> np.ndarray:
        """The smallest row of :meth:`cone` for numeric forces: mu Fy - |Fx| (Fy without
        friction), N or N s, >= 0 inside; the shape of ``fx`` and ``fy`` broadcast."""
        return np.min(self.cone(fx, fy), axis=0)

    def violation(
        self, fx: float, fy: float, slack: float = 0.0, who: str | None = None, unit: str = "N"
    ) -> str | None:
        """Why the contact cannot carry the force (Fx, Fy) (``unit``: N, or N s for an
        impulse), with ``slack`` (same unit) of tolerance, or None when it can. ``who`` names
        the contact in the message ("the stance foot"; default: its label)."""
        who = who or self.label
        if fy < -slack:
            return f"{who} is pulled off the ground (Fy = {fy:.1f} {unit})"
        if self.friction is not None and abs(fx) > self.friction * fy + slack:
            return (
                f"{who} slips (|Fx| = {abs(fx):.1f} {unit} > mu Fy = "
                f"{self.friction * fy:.1f} {unit})"
            )
        return None

    def friction_use(self, fx, fy) -> np.ndarray:
        """|Fx| / (mu Fy) for numeric forces: the part of the cone a force uses (<= 1 inside,
        NaN where Fy = 0 or without friction); the shapes of ``fx`` and ``fy`` broadcast."""
        fx, fy = np.asarray(fx, dtype=float), np.asarray(fy, dtype=float)
        if self.friction is None:
            return np.full(np.broadcast(fx, fy).shape, np.nan)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(fy != 0.0, np.abs(fx) / (self.friction * fy), np.nan)

    def height_above_ground(self, y) -> np.ndarray | ca.SX:
        """The point's height above the ground, m, for its y coordinate ``y`` (m)."""
        return y - self.ground.height

    @property
    def cone_half_angle(self) -> float:
        """The cone's half angle from the normal, rad: atan(mu), pi/2 without friction."""
        return math.pi / 2 if self.friction is None else math.atan(self.friction)


__all__ = ["Contact", "Ground"]
