"""Planar trees of rigid links: definition, validation and reduced sub-scenes.

Conventions (``shared/DESIGN.md``): the plane is x right, y up, a point is the complex number
z = x + j y; link i has the absolute angle psi_i measured from +x counter-clockwise; its
frame is the complex unit e^{j psi_i}. A link runs from its start hinge to its end hinge
(``length`` along its axis); its children start at its end hinge unless a lock moved them.

Two generalisations of the paper's links make locking exact and are otherwise invisible:

* ``com_lateral``: the centre of mass may sit off the link's axis (fraction of the length,
  positive to the left of the axis). Merging a child locked at an angle produces such a body.
* ``origin``: where the link's start hinge sits, as a complex number in metres in the parent's
  frame (for the root: in the world frame). ``None`` means the parent's end hinge (for the
  root: H0 at the origin). A child of a link that was locked into its parent keeps its true
  hinge on the merged body this way.
"""

from __future__ import annotations

import cmath
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError, check_positive, check_real


@dataclass(frozen=True)
class Link:
    """One rigid link of a planar tree.

    Parameters
    ----------
    name : str
        Unique, non-empty name.
    parent : str or None
        Name of the parent link; ``None`` for the root, which starts at the ground hinge H0.
    length : float
        Distance from the start hinge to the end hinge, m (> 0).
    mass : float
        kg (> 0).
    com : float
        Position of the centre of mass along the axis from the start hinge, as a fraction of
        ``length`` (the paper's n_i), in [0, 1] (a merged or re-rooted body may lie outside).
    inertia : float or None
        Moment of inertia about the centre of mass J_i, kg m^2 (>= 0). ``None``: uniform rod,
        m l^2 / 12.
    com_lateral : float
        Offset of the centre of mass perpendicular to the axis, fraction of ``length``,
        positive to the left. 0 for every paper link.
    origin : complex or None
        Start hinge in the parent's frame, m (root: world frame). ``None``: the parent's end
        hinge (root: the origin).
    merged : tuple of str
        Names of links locked into this one (set by :meth:`Linkage.lock`).
    rerooted : bool
        Set by :func:`model.reroot` on a link described from a point that is not one of its
        ends (a heel, the middle of a link): its centre of mass fraction may lie outside
        [0, 1].
    """

    name: str
    parent: str | None
    length: float
    mass: float
    com: float = 0.5
    inertia: float | None = None
    com_lateral: float = 0.0
    origin: complex | None = None
    merged: tuple[str, ...] = field(default=())
    rerooted: bool = False

    def __post_init__(self) -> None:
        where = f"Link {self.name!r}" if isinstance(self.name, str) else "Link"
        if not isinstance(self.name, str):
            raise DefinitionTypeError(f"`Link.name`: must be a string, got {self.name!r}")
        if not self.name.strip():
            raise DefinitionError(f"`Link.name`: must be a non-empty string, got {self.name!r}")
        if self.parent is not None and not isinstance(self.parent, str):
            raise DefinitionTypeError(
                f"`{where}.parent`: must be a link name (str) or None for the root, "
                f"got {self.parent!r}"
            )
        length = check_positive(f"{where}.length", self.length, "m")
        mass = check_positive(f"{where}.mass", self.mass, "kg")
        com = check_real(f"{where}.com", self.com)
        if not self.merged and not self.rerooted and not 0.0 <= com <= 1.0:
            raise DefinitionError(
                f"`{where}.com`: the centre of mass fraction must lie in [0, 1] "
                f"(0 = start hinge, 1 = end hinge), got {com!r}"
            )
        if self.inertia is None:
            inertia = mass * length**2 / 12.0
            if not math.isfinite(inertia):
                raise DefinitionError(
                    f"`{where}.mass`: {mass!r} kg with length {length!r} m makes the uniform "
                    "rod's moment of inertia m l^2 / 12 overflow to inf; give the mass in kg "
                    "and the length in m (or a finite inertia)"
                )
        else:
            inertia = check_real(f"{where}.inertia", self.inertia)
            if inertia < 0:
                raise DefinitionError(
                    f"`{where}.inertia`: the moment of inertia about the centre of mass must be "
                    f">= 0 kg m^2, got {inertia!r}; use None for a uniform rod"
                )
        lateral = check_real(f"{where}.com_lateral", self.com_lateral)
        origin = self.origin
        if origin is not None:
            if isinstance(origin, bool) or not isinstance(origin, (int, float, complex)):
                raise DefinitionTypeError(
                    f"`{where}.origin`: must be a complex number (m) or None, got {origin!r}"
                )
            origin = complex(origin)
            if not cmath.isfinite(origin):
                raise DefinitionError(f"`{where}.origin`: must be finite, got {origin!r}")
        if not isinstance(self.merged, tuple) or not all(isinstance(m, str) for m in self.merged):
            raise DefinitionTypeError(f"`{where}.merged`: must be a tuple of link names")
        if not isinstance(self.rerooted, bool):
            raise DefinitionTypeError(f"`{where}.rerooted`: must be True or False")
        # Store canonical floats so equality and hashing behave.
        object.__setattr__(self, "length", length)
        object.__setattr__(self, "mass", mass)
        object.__setattr__(self, "com", com)
        object.__setattr__(self, "inertia", inertia)
        object.__setattr__(self, "com_lateral", lateral)
        object.__setattr__(self, "origin", origin)

    @property
    def com_offset(self) -> complex:
        """Centre of mass in the link's own frame, m (complex: along + j across the axis)."""
        return self.length * complex(self.com, self.com_lateral)

    @property
    def inertia_about_start(self) -> float:
        """The paper's I_i: moment of inertia about the start hinge, kg m^2."""
        return self.inertia + self.mass * abs(self.com_offset) ** 2

    @property
    def is_paper_link(self) -> bool:
        """True when the link has the paper's form: centre of mass on the axis, starting at
        the parent's end hinge (or at H0 for the root)."""
        return self.com_lateral == 0.0 and self.origin is None


class Linkage:
    """A validated planar tree of links with gravity.

    Parameters
    ----------
    links : sequence of Link
        In an order where each parent comes before its children. Every array of the model
        (angles, torques, ...) follows this order.
    gravity : float
        Magnitude g of gravity along -y, m/s^2 (>= 0).

    Raises
    ------
    DefinitionError, DefinitionTypeError
        At construction, naming the field, the value and the fix.
    """

    def __init__(self, links: Sequence[Link], gravity: float = 9.81) -> None:
        if isinstance(links, (str, bytes)) or not isinstance(links, Iterable):
            raise DefinitionTypeError(
                f"`links`: must be a sequence of model.Link, got {type(links).__name__}"
            )
        links = tuple(links)
        if not links:
            raise DefinitionError("`links`: the tree is empty; give at least one model.Link")
        for i, link in enumerate(links):
            if not isinstance(link, Link):
                raise DefinitionTypeError(
                    f"`links[{i}]`: must be a model.Link, got {type(link).__name__}"
                )
        g = check_real("gravity", gravity)
        if g < 0:
            raise DefinitionError(
                f"`gravity`: the magnitude of g (acting along -y) must be >= 0 m/s^2, got {g!r}"
            )
        index: dict[str, int] = {}
        for i, link in enumerate(links):
            if link.name in index:
                raise DefinitionError(
                    f"`links[{i}].name`: duplicate name {link.name!r} "
                    f"(also links[{index[link.name]}]); give every link a unique name"
                )
            index[link.name] = i
        names = [link.name for link in links]
        parents: list[int] = []
        root = None
        for i, link in enumerate(links):
            if link.parent is None:
                if root is not None:
                    raise DefinitionError(
                        f"`links[{i}].parent`: None makes {link.name!r} a second root "
                        f"(the root is {links[root].name!r}); a tree has one root: name its parent"
                    )
                root = i
                parents.append(-1)
                continue
            if link.parent not in index:
                raise DefinitionError(
                    f"`links[{i}].parent`: unknown parent {link.parent!r} of {link.name!r}; "
                    f"known links: {names}"
                )
            p = index[link.parent]
            if p == i:
                raise DefinitionError(
                    f"`links[{i}].parent`: {link.name!r} names itself as its parent; "
                    "name the link it hangs from, or None for the root"
                )
            if p > i:
                raise DefinitionError(
                    f"`links[{i}].parent`: parent {link.parent!r} of {link.name!r} comes after it "
                    f"(links[{p}]); order the links so that each parent comes before its children"
                )
            parents.append(p)
        self._links = links
        self._gravity = g
        self._index = index
        self._parents = tuple(parents)
        self._children = tuple(
            tuple(c for c in range(len(links)) if parents[c] == i) for i in range(len(links))
        )
        # Every coefficient of the equations of motion is bounded by the total mass times the
        # square of the total length (mass matrix) or times g and the total length (gravity):
        # refuse values whose products overflow, before they turn into inf or NaN torques.
        total_mass = math.fsum(link.mass for link in links)
        reach = math.fsum(link.length + abs(link.origin or 0.0) for link in links)
        bounds = (
            total_mass,
            total_mass * reach * reach,
            total_mass * g * reach,
            math.fsum(link.inertia for link in links),
        )
        if not all(math.isfinite(b) for b in bounds):
            raise DefinitionError(
                f"`links`: masses up to {max(link.mass for link in links):g} kg, lengths up "
                f"to {max(link.length for link in links):g} m and inertias up to "
                f"{max(link.inertia for link in links):g} kg m^2 overflow double precision in "
                "the equations of motion (total mass x total length^2 is inf); give SI values "
                "(kg, m, kg m^2)"
            )
        for i, link in enumerate(links):
            # psi_i is absent from T when nothing of link i's subtree moves as it turns: the
            # mass matrix is singular and forward dynamics undefined.
            if link.inertia_about_start == 0.0 and all(
                self.origin_in_parent(c) == 0 for c in self._children[i]
            ):
                raise DefinitionError(
                    f"`links[{i}]`: {link.name!r} has no moment of inertia about its start "
                    "hinge (inertia 0 and centre of mass on the hinge) and nothing hangs off "
                    "that hinge, so its angle has no dynamics; give inertia > 0 or com > 0"
                )

    # ---- read access -------------------------------------------------------------------
    @property
    def links(self) -> tuple[Link, ...]:
        return self._links

    @property
    def gravity(self) -> float:
        """g, m/s^2, acting along -y."""
        return self._gravity

    @property
    def n(self) -> int:
        """Number of links = number of generalised coordinates psi."""
        return len(self._links)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(link.name for link in self._links)

    @property
    def parents(self) -> tuple[int, ...]:
        """Parent index of each link, -1 for the root."""
        return self._parents

    @property
    def children(self) -> tuple[tuple[int, ...], ...]:
        """Child indices of each link."""
        return self._children

    def index(self, name: str) -> int:
        """Position of the link called ``name``."""
        if name not in self._index:
            raise DefinitionError(
                f"`name`: no link called {name!r}; known links: {list(self.names)}"
            )
        return self._index[name]

    def ancestors(self, i: int) -> tuple[int, ...]:
        """Strict ancestors of link i, root first."""
        chain = []
        p = self._parents[i]
        while p >= 0:
            chain.append(p)
            p = self._parents[p]
        return tuple(reversed(chain))

    def ancestry(self) -> np.ndarray:
        """A (n, n): A[i, k] = 1 when link k is link i or one of its ancestors. The absolute
        angles of the hinges' relative ones (psi = A q); its transpose sums a quantity of each
        link over the subtree of every link (a hinge's torque of the generalised forces)."""
        matrix = np.eye(self.n)
        for i in range(self.n):
            matrix[i, list(self.ancestors(i))] = 1.0
        return matrix

    def subtree(self, i: int) -> tuple[int, ...]:
        """Link i and all its descendants, in link order."""
        return tuple(k for k in range(self.n) if k == i or i in self.ancestors(k))

    def origin_in_parent(self, i: int) -> complex:
        """Start hinge of link i in its parent's frame, m (root: world position of H0)."""
        link = self._links[i]
        if link.origin is not None:
            return link.origin
        p = self._parents[i]
        return 0j if p < 0 else complex(self._links[p].length)

    @property
    def is_paper_form(self) -> bool:
        """True when every link has the paper's form (see :attr:`Link.is_paper_link`)."""
        return all(link.is_paper_link for link in self._links)

    def parameters(self) -> dict:
        """Plain-data description (for metadata in exported files)."""
        return {
            "gravity": self._gravity,
            "links": [
                {
                    "name": link.name,
                    "parent": link.parent,
                    "length": link.length,
                    "mass": link.mass,
                    "com": link.com,
                    "inertia": link.inertia,
                    "com_lateral": link.com_lateral,
                    "origin": None if link.origin is None else [link.origin.real, link.origin.imag],
                    "merged": list(link.merged),
                    "rerooted": link.rerooted,
                }
                for link in self._links
            ],
        }

    @classmethod
    def from_parameters(cls, description: Mapping[str, Any]) -> Linkage:
        """The linkage :meth:`parameters` describes (the ``model`` entry of an exported
        file's metadata): ``{"gravity": m/s^2, "links": [{"name", "parent", "length",
        "mass", "com", "inertia", "com_lateral", "origin": [x, y] or None, "merged",
        "rerooted"}, ...]}``; raises DefinitionError naming what is missing."""
        if not isinstance(description, Mapping) or not isinstance(
            description.get("links"), Sequence
        ):
            raise DefinitionError(
                "`description`: give Linkage.parameters()'s {'gravity': ..., 'links': [...]} "
                f"(a file's metadata['model']), got {type(description).__name__}"
            )
        links = []
        for k, row in enumerate(description["links"]):
            try:
                origin = row.get("origin")
                links.append(Link(
                    row["name"], row["parent"], row["length"], row["mass"],
                    row.get("com", 0.5), row.get("inertia"), row.get("com_lateral", 0.0),
                    None if origin is None else complex(origin[0], origin[1]),
                    tuple(row.get("merged") or ()), bool(row.get("rerooted", False)),
                ))  # fmt: skip
            except (KeyError, TypeError, AttributeError, IndexError) as error:
                raise DefinitionError(
                    f"`description['links'][{k}]`: a link needs name, parent, length and "
                    f"mass ({error!r})"
                ) from None
        return cls(links, gravity=description.get("gravity", 9.81))

    # ---- the same body in other units ------------------------------------------------------
    def in_units(self, length: float = 1.0, mass: float = 1.0) -> Linkage:
        """The same linkage with lengths in a unit ``length`` times smaller than the metre
        and masses in one ``mass`` times smaller than the kilogram (millimetres and grams:
        ``in_units(length=1e3, mass=1e3)``): lengths and attachment offsets x length, masses
        x mass, inertias x mass length^2, gravity x length (time stays in seconds, angles in
        radians). Torques of its dynamics come out x mass length^2 (g mm^2/s^2 = 1e-9 N m);
        the fractions com and com_lateral are unit-free."""
        length = check_positive("length", length, "(metres per unit)")
        mass = check_positive("mass", mass, "(kilograms per unit)")
        links = [
            replace(
                link,
                length=link.length * length,
                mass=link.mass * mass,
                inertia=None if link.inertia is None else link.inertia * mass * length**2,
                origin=None if link.origin is None else link.origin * length,
            )
            for link in self._links
        ]
        return Linkage(links, gravity=self._gravity * length)

    # ---- sub-scenes ---------------------------------------------------------------------
    def drop(self, *names: str) -> Linkage:
        """A new Linkage without the named links and their whole subtrees.

        The masses of dropped links vanish from the model (use :meth:`lock` to keep them).
        """
        if not names:
            raise DefinitionError("`names`: give at least one link name to drop")
        removed: set[int] = set()
        for name in names:
            i = self.index(name)
            if self._parents[i] < 0:
                raise DefinitionError(
                    f"`names`: {name!r} is the root; dropping it leaves nothing. Drop its children"
                )
            removed.update(self.subtree(i))
        kept = [link for k, link in enumerate(self._links) if k not in removed]
        return Linkage(kept, gravity=self._gravity)

    def lock(self, name: str, angle: float | None = None) -> Linkage:
        """A new Linkage with link ``name`` welded to its parent at a relative angle.

        psi_name = psi_parent + angle (rad, default 0) for all time. Mass, centre of mass and
        inertia merge exactly into the parent; the locked link's children stay on their true
        hinge (their ``origin`` moves into the parent's frame), and their angles stay absolute.

        The root is welded to the ground instead, at the absolute angle ``angle``
        (psi_root = angle): a foot held flat on the ground. Its one child becomes the root,
        starting where its hinge then stands (its ``origin``, in the world frame); the root's
        own mass leaves the model, as the ground carries it. A root with several children
        would leave several trees and is refused; the angle must be given (there is no
        natural default for an absolute angle).
        """
        c = self.index(name)
        p = self._parents[c]
        if p < 0:
            if angle is None:
                raise DefinitionError(
                    f"`angle`: {name!r} is the root; locking it welds it to the ground at an "
                    "absolute angle: give it (rad, from +x counter-clockwise), e.g. "
                    f"lock({name!r}, angle=math.pi / 2)"
                )
            return self._weld_root(check_real("angle", angle))
        angle = 0.0 if angle is None else check_real("angle", angle)
        parent, child = self._links[p], self._links[c]
        turn = cmath.exp(1j * angle)  # child frame -> parent frame
        start = self.origin_in_parent(c)
        com_p = parent.com_offset
        com_c = start + child.com_offset * turn
        mass = parent.mass + child.mass
        com = (parent.mass * com_p + child.mass * com_c) / mass
        inertia = (
            parent.inertia
            + parent.mass * abs(com_p - com) ** 2
            + child.inertia
            + child.mass * abs(com_c - com) ** 2
        )
        merged_parent = replace(
            parent,
            mass=mass,
            com=com.real / parent.length,
            com_lateral=com.imag / parent.length,
            inertia=inertia,
            merged=(*parent.merged, child.name, *child.merged),
        )
        new_links = []
        for k, link in enumerate(self._links):
            if k == c:
                continue
            if k == p:
                new_links.append(merged_parent)
            elif self._parents[k] == c:
                hinge = start + self.origin_in_parent(k) * turn
                new_links.append(replace(link, parent=parent.name, origin=hinge))
            else:
                new_links.append(link)
        return Linkage(new_links, gravity=self._gravity)

    def _weld_root(self, angle: float) -> Linkage:
        """:meth:`lock` of the root: welded to the ground at psi_root = ``angle`` rad."""
        root = self._links[0]
        children = self.children[0]
        if len(children) != 1:
            raise DefinitionError(
                f"`name`: welding the root {root.name!r} to the ground leaves "
                f"{len(children)} trees (its children {[self._links[k].name for k in children]}); "
                "a root with exactly one child can be welded"
            )
        (child,) = children
        start = (root.origin or 0j) + self.origin_in_parent(child) * cmath.exp(1j * angle)
        new_links = []
        for k, link in enumerate(self._links):
            if k == child:
                new_links.append(replace(link, parent=None, origin=start))
            elif k != 0:
                new_links.append(link)
        return Linkage(new_links, gravity=self._gravity)

    # ---- dunder -------------------------------------------------------------------------
    def __eq__(self, other: object) -> bool:
        return (
            isinstance(other, Linkage)
            and self._links == other._links
            and self._gravity == other._gravity
        )

    def __hash__(self) -> int:
        return hash((self._links, self._gravity))

    def __repr__(self) -> str:
        rows = ", ".join(f"{link.name}<-{link.parent or 'ground'}" for link in self._links)
        return f"Linkage({self.n} links: {rows}; g={self._gravity})"


def total_mass(linkage: Linkage) -> float:
    """Sum of the link masses, kg."""
    return math.fsum(link.mass for link in linkage.links)
