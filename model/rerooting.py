"""Re-rooting a tree at another contact point, and the leg swap of a walking biped.

The same physical tree can be described from any of its points: a walking step changes the
contact from the stance foot (the root hinge H0) to the landing swing foot. Re-rooting at a
point P of link L reverses the chain root -> ... -> L: each link k on it is described from
the other end, so

* its frame turns by pi: psi_k' = psi_k + pi (dpsi unchanged), and its start hinge becomes
  the hinge F_k through which the chain continued (the next path link's start, or P on L);
* a point at p in the old frame is at F_k - p in the new one: the centre of mass fraction
  becomes 1 - com and the lateral offset changes sign (F_k = l_k for a paper link); attachment
  offsets (``origin``) are carried the same way, so trees with locked bodies, heels and points
  between hinges re-root too (a link described from such a point is marked ``rerooted``: its
  centre of mass may lie outside [0, 1] of its length);
* inertia and mass are unchanged; links off the path keep their angles; a child hanging at a
  hinge of the reversed chain hangs, in the new tree, from the reversed link that ends there
  (the torso, hanging from the stance thigh at the hip, hangs from the reversed swing thigh);
* hinge torques are re-expressed so that every body receives the same net torque: the
  generalised forces Q (on absolute angles) are invariant, M' = subtree sums of Q in the new
  tree, Q = M - sum over children in the old one.

The new root's start is the new H0, at the origin: positions of the whole tree are shifted
by -z_P. ``swap_legs`` re-roots a biped with two mirror-image two-link legs at the swing foot
and renames the legs, which gives back the same Linkage with the legs' angles exchanged: the
relabelling of a walking step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import casadi as ca
import numpy as np

from model.linkage import Link, Linkage
from model.points import LinkPoint
from planner.errors import DefinitionError, DefinitionTypeError, check_states


@dataclass(frozen=True, eq=False)
class Rerooting:
    """A tree described from a new root, and the maps of states and torques old -> new.

    Attributes
    ----------
    old, new : Linkage
        The tree before and after (same bodies; ``new`` is rooted at ``root_point``).
    root_point : LinkPoint
        The new root H0', a point of the old tree.
    source : tuple of int (n,)
        For each link of ``new`` (in its order), the index of the same body in ``old``.
    angle_offsets : ndarray (n,)
        psi_new[i] = psi_old[source[i]] + angle_offsets[i], rad: +-pi on the reversed chain,
        0 elsewhere.
    """

    old: Linkage
    new: Linkage
    root_point: LinkPoint
    source: tuple[int, ...]
    angle_offsets: np.ndarray
    _function: list = field(default_factory=list, repr=False)

    @property
    def n(self) -> int:
        return self.old.n

    @property
    def reversed_links(self) -> tuple[str, ...]:
        """Names (in the new tree) of the links described from their other end."""
        return tuple(self.new.names[i] for i in range(self.n) if self.angle_offsets[i] != 0.0)

    def map_state(self, psi, dpsi) -> tuple[np.ndarray, np.ndarray]:
        """(psi, dpsi) of the old tree -> of the new one: (n,) each, or (K, n) batches."""
        psi = check_states("psi", psi, self.n)
        dpsi = check_states("dpsi", dpsi, self.n)
        order = list(self.source)
        return psi[..., order] + self.angle_offsets, dpsi[..., order].copy()

    def map_torques(self, torques) -> np.ndarray:
        """Hinge torques of the old tree -> of the new one, N m: (n,) or (K, n); the
        generalised forces on every body's angle are the same."""
        torques = check_states("torques", torques, self.n)
        generalized = torques - torques @ _children_matrix(self.old).T
        return generalized[..., list(self.source)] @ _subtree_matrix(self.new).T

    def function(self) -> ca.Function:
        """SX Function ``rerooting``: (psi, dpsi) (n,) each -> (psi, dpsi) of the new tree."""
        if not self._function:
            psi, dpsi = ca.SX.sym("psi", self.n), ca.SX.sym("dpsi", self.n)
            order = list(self.source)
            self._function.append(
                ca.Function(
                    "rerooting",
                    [psi, dpsi],
                    [psi[order] + ca.DM(self.angle_offsets), dpsi[order]],
                    ["psi", "dpsi"],
                    ["psi_new", "dpsi_new"],
                )
            )
        return self._function[0]

    def state_function(self) -> ca.Function:
        """x = [psi; dpsi] (2n,) -> x of the new tree (2n,): an SX Function."""
        x = ca.SX.sym("x", 2 * self.n)
        psi, dpsi = self.function().call([x[: self.n], x[self.n :]])
        return ca.Function("rerooting_state", [x], [ca.vertcat(psi, dpsi)], ["x"], ["x_new"])

    def __repr__(self) -> str:
        p = self.root_point
        return (
            f"Rerooting(at {p.link!r} along={p.along:g} lateral={p.lateral:g}; "
            f"reversed {list(self.reversed_links)})"
        )


def _children_matrix(linkage: Linkage) -> np.ndarray:
    """C[k, c] = 1 when c is a child of k (Q = M - C M)."""
    matrix = np.zeros((linkage.n, linkage.n))
    for c, p in enumerate(linkage.parents):
        if p >= 0:
            matrix[p, c] = 1.0
    return matrix


def _subtree_matrix(linkage: Linkage) -> np.ndarray:
    """S[k, i] = 1 when i is k or a descendant of k (M = S Q)."""
    # C-ordered, as the products with it were first written: the same summation order, the
    # same torques to the bit (a MuJoCo walk amplifies round-off over its steps)
    return np.ascontiguousarray(linkage.ancestry().T)


def reroot(linkage: Linkage, link: str | LinkPoint, at: str = "end") -> Rerooting:
    """The same tree described from a point of ``link`` (its end hinge by default).

    Parameters
    ----------
    linkage : Linkage
    link : str or LinkPoint
        The link that carries the new root, or the point itself (``LinkPoint(link, along,
        lateral)``: a heel or a toe).
    at : "end"
        With a link name: the point is its end hinge.

    Returns
    -------
    Rerooting, with the new Linkage (links on the reversed chain first, from the new root,
    then the others in their old order) and the state and torque maps.
    """
    if not isinstance(linkage, Linkage):
        raise DefinitionTypeError(
            f"`linkage`: must be a model.Linkage, got {type(linkage).__name__}"
        )
    if isinstance(link, LinkPoint):
        if at != "end":
            raise DefinitionError("`at`: give the offsets in the LinkPoint, not `at`")
        point = link
    else:
        if at != "end":
            raise DefinitionError(
                f"`at`: must be 'end' (the link's end hinge), got {at!r}; for another point "
                "pass model.LinkPoint(link, along, lateral)"
            )
        point = LinkPoint(link, 1.0, 0.0)
    offset = point.offset(linkage)  # validates the link name
    target = linkage.index(point.link)
    path = (*linkage.ancestors(target), target)
    if target == path[0] and offset == 0:
        raise DefinitionError(
            f"`link`: the start of the root {point.link!r} is the root hinge H0 already; "
            "re-root at another point (e.g. a foot: the end of the last link of a leg)"
        )
    links = linkage.links
    on_path = {k: j for j, k in enumerate(path)}
    # F[k]: the hinge through which the chain continues beyond path link k (k's frame).
    hinge = {k: linkage.origin_in_parent(path[j + 1]) for j, k in enumerate(path[:-1])}
    hinge[target] = offset

    def origin_at(k: int, position: complex) -> complex | None:
        """``origin`` of a child starting at ``position`` on reversed link k: None (the
        paper's default) when that is k's end."""
        return None if position == links[k].length else position

    new_links: list[Link] = []
    for j in reversed(range(len(path))):
        k = path[j]
        link_k = links[k]
        com = hinge[k] - link_k.com_offset
        if j == len(path) - 1:
            parent, origin = None, None
        else:
            below = path[j + 1]  # its start hinge is where k' starts
            parent, origin = links[below].name, origin_at(below, hinge[below])
        fraction = com / link_k.length
        new_links.append(
            replace(
                link_k,
                parent=parent,
                com=fraction.real,
                com_lateral=fraction.imag,
                origin=origin,
                # Described from a point between its ends, its centre may lie beyond them.
                rerooted=not 0.0 <= fraction.real <= 1.0,
            )
        )
    for c, link_c in enumerate(links):
        if c in on_path:
            continue
        k = linkage.parents[c]
        if k not in on_path:
            new_links.append(link_c)
            continue
        position = hinge[k] - linkage.origin_in_parent(c)  # in k's reversed frame
        j = on_path[k]
        if position == 0 and j < len(path) - 1:
            # At the hinge shared with the next path link: hang from that link's reversed
            # twin, which ends there (the torso moves from the stance to the swing thigh).
            below = path[j + 1]
            new_links.append(
                replace(link_c, parent=links[below].name, origin=origin_at(below, hinge[below]))
            )
        else:
            new_links.append(replace(link_c, origin=origin_at(k, position)))
    new = Linkage(new_links, gravity=linkage.gravity)
    source = tuple(linkage.index(name) for name in new.names)
    offsets = np.array([math.pi if i in on_path else 0.0 for i in source])
    return Rerooting(linkage, new, point, source, offsets)


# ---- the leg swap of a biped ------------------------------------------------------------
def _chain_below(linkage: Linkage, top: int, length: int) -> tuple[int, ...] | None:
    """The chain of ``length`` links from ``top`` down, each the one child of the last and
    starting at its end hinge, the last carrying nothing; or None."""
    chain = [top]
    while len(chain) < length:
        kids = linkage.children[chain[-1]]
        if len(kids) != 1 or linkage.origin_in_parent(kids[0]) != linkage.links[chain[-1]].length:
            return None
        chain.append(kids[0])
    return tuple(chain) if not linkage.children[chain[-1]] else None


def _leg_candidates(linkage: Linkage) -> list[tuple[tuple[int, ...], tuple[int, ...]]]:
    """(stance leg, swing leg) pairs of a biped: the stance leg, from the root up, a chain of
    k links each the one child of the last at its end; at its end hinge (the hip) a chain of
    k links ending in a free link (the swing leg, from the hip down), for every k."""
    found = []
    stance = [0]
    while True:
        hip = stance[-1]
        for c in linkage.children[hip]:
            if c in stance or linkage.origin_in_parent(c) != linkage.links[hip].length:
                continue
            swing = _chain_below(linkage, c, len(stance))
            if swing is not None:
                found.append((tuple(stance), swing))
        kids = [
            c
            for c in linkage.children[hip]
            if linkage.origin_in_parent(c) == linkage.links[hip].length
        ]
        if len(kids) != 1:
            return found
        stance.append(kids[0])


def _differences(original: Linkage, swapped: Linkage, rename: dict[str, str], rtol: float):
    """Why ``swapped`` (the re-rooted tree with names exchanged) is not ``original``."""
    out = []
    theirs = {link.name: link for link in swapped.links}
    for mine in original.links:
        other = theirs[mine.name]
        source = rename[mine.name]
        if mine.parent != other.parent:
            out.append(
                f"{mine.name}.parent is {mine.parent!r} but after the swap it would be "
                f"{other.parent!r}"
            )
        for name, unit in (("length", "m"), ("mass", "kg"), ("inertia", "kg m^2")):
            a, b = getattr(mine, name), getattr(other, name)
            if not math.isclose(a, b, rel_tol=rtol, abs_tol=0.0):
                out.append(
                    f"{source}.{name} = {b:g} {unit} differs from its mirror "
                    f"{mine.name}.{name} = {a:g} {unit}"
                )
        body = original.links[original.index(source)]
        for name, seen in (("com", "1 - com"), ("com_lateral", "-com_lateral")):
            a, b = getattr(mine, name), getattr(other, name)
            if not math.isclose(a, b, rel_tol=rtol, abs_tol=rtol):
                out.append(
                    f"{source}.{name} = {getattr(body, name):g} is {b:g} seen from the other "
                    f"end ({seen}) but its mirror {mine.name}.{name} = {a:g}"
                )
        a, b = mine.origin, other.origin
        if (a is None) != (b is None) or (
            a is not None and not abs(a - b) <= rtol * max(abs(a), abs(b), 1.0)
        ):
            out.append(f"{mine.name}.origin is {a} but after the swap it would be {b}")
    return out


def swap_legs(
    linkage: Linkage, swing: Sequence[str] | None = None, rtol: float = 1e-12
) -> Rerooting:
    """The leg swap of a biped at heel strike: re-root at the swing foot and rename the legs.

    The biped: the stance leg is a chain of k links from the root (its start H0 is the
    stance foot) up to the hip, each link the one child of the one below at its end; at the
    hip (the chain's end hinge) hangs a swing leg, a chain of k links ending in a free link
    whose end is the swing foot, and any upper body (none, a link, a chain, branches). Two
    links per leg (shank, thigh) is the seed paper's; one is a compass walker; a leg may end
    in a foot link. ``swing`` names the swing leg's links, from the hip down, when several
    chains could be it.

    The legs must be mirror images (equal lengths, masses, inertias; centres of mass at the
    mirrored fractions 1 - com; no attachment offsets that break the symmetry), checked to
    relative ``rtol``: then re-rooting and renaming give back ``linkage`` itself, and the
    returned Rerooting's ``new`` is ``linkage`` (exact, the same object). Angles map as
    psi_new_stance = psi_old_swing + pi (a leg pointing down from the hip now points up
    from the foot) and psi_new_swing = psi_old_stance - pi, so that stance angles stay near
    (0, pi) and swing angles near (-pi, 0) step after step.

    Raises
    ------
    DefinitionError
        When the tree is not such a biped (saying what is missing) or the legs are not mirror
        images (naming the parameter that differs and both values).
    """
    if not isinstance(linkage, Linkage):
        raise DefinitionTypeError(
            f"`linkage`: must be a model.Linkage, got {type(linkage).__name__}"
        )
    shape = (
        "swap_legs needs a biped: a stance leg of k links from the root up to the hip, and at "
        "the hip a swing leg of k links ending in the foot"
    )
    root = 0
    if not linkage.children[root]:
        raise DefinitionError(
            f"`linkage`: {shape}; the root {linkage.names[root]!r} has 0 children"
        )
    legs = _leg_candidates(linkage)
    if swing is not None:
        if isinstance(swing, str) or not (
            isinstance(swing, Sequence) and swing and all(isinstance(s, str) for s in swing)
        ):
            raise DefinitionTypeError(
                f"`swing`: must be the names of the swing leg's links from the hip down, e.g. "
                f"('swing_thigh', 'swing_shank'), got {swing!r}"
            )
        chain = tuple(linkage.index(name) for name in swing)
        legs = [leg for leg in legs if leg[1] == chain]
        if not legs:
            raise DefinitionError(
                f"`swing`: {tuple(swing)} is not a leg hanging at the hip (a chain as long as "
                "the stance leg, from the hip down, whose last link carries nothing)"
            )
    if not legs:
        raise DefinitionError(
            f"`linkage`: {shape}; no chain as long as the stance leg, ending in a free link, "
            f"hangs at the end of a stance leg from {linkage.names[root]!r}"
        )
    best = None
    names = linkage.names
    for stance_leg, swing_leg in legs:
        # The stance leg's j-th link from the foot is the swing leg's j-th from the foot.
        mirrored = tuple(reversed(swing_leg))
        rename = {  # new name -> the body it is (its name in the old tree)
            **{names[a]: names[b] for a, b in zip(stance_leg, mirrored, strict=True)},
            **{names[b]: names[a] for a, b in zip(stance_leg, mirrored, strict=True)},
        }
        back = {old: new for new, old in rename.items()}
        rerooted = reroot(linkage, names[swing_leg[-1]])
        renamed = Linkage(
            [
                replace(
                    link,
                    name=back.get(link.name, link.name),
                    parent=None if link.parent is None else back.get(link.parent, link.parent),
                )
                for link in rerooted.new.links
            ],
            gravity=linkage.gravity,
        )
        full = {name: rename.get(name, name) for name in names}
        problems = _differences(linkage, renamed, full, rtol)
        if best is None or len(problems) < len(best[0]):
            best = (problems, rename, stance_leg)
        if not problems:
            break
    problems, rename, stance_leg = best
    if problems:
        listed = "; ".join(problems[:4])
        if len(problems) > 4:
            listed += f"; and {len(problems) - 4} more"
        raise DefinitionError(
            "`linkage`: the legs are not mirror images, so swapping them would change the "
            "tree: " + listed
        )
    stance = {names[i] for i in stance_leg}
    source = tuple(linkage.index(rename.get(name, name)) for name in names)
    offsets = np.zeros(linkage.n)
    for i, name in enumerate(names):
        if name in rename:
            # The new stance leg is the old swing leg turned up (+pi); the new swing leg is
            # the old stance leg turned down (-pi).
            offsets[i] = -math.pi if rename[name] in stance else math.pi
    swing_shank = rename[names[root]]
    return Rerooting(linkage, linkage, LinkPoint(swing_shank, 1.0, 0.0), source, offsets)
