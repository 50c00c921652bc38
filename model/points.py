"""Points fixed on links: a foot, a heel, a toe, a hand; their kinematics as CasADi SX.

A point at the offset c (complex, m) in link i's frame (``along`` and ``lateral`` are fractions
of the link's length: c = l_i (along + j lateral)) lies at
    z_P = z_start,i + c e^{j psi_i},
the start hinge being the same sum of complex exponentials as every centre of mass
(``Dynamics.link_kinematics``). Velocity and acceleration multiply the exponentials by
j dpsi and (j ddpsi - dpsi^2): no trigonometric projection, no differentiation.

The Jacobian with respect to the floating-base coordinates q = (x0, y0, psi_1..psi_n) has the
columns 1 and j (the base translation) and, for every link k on the path from the root to i,
dz_P/dpsi_k = j r_k e^{j psi_k}: a quarter turn of the lever r_k from link k's start hinge to
the point (the start of the next link on the path, or c on link i itself). The fixed-base
Jacobian is its last n columns.

>>> foot = dyn.point("swing_shank")                    # the end hinge (along=1)
>>> heel = dyn.point("swing_shank", along=1.0, lateral=0.05, name="heel")
>>> foot.position(psi)                                  # complex, m: () or (K,)
>>> foot.function("velocity")                           # CasADi: [psi, dpsi] -> [vx, vy]
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from model.complex_sx import Cx
from model.linkage import Linkage
from planner.errors import DefinitionError, DefinitionTypeError, check_real

#: The owner a part calls back into: the ``model.Dynamics`` that built it. Named, not
#: imported: dynamics.py imports this module, and an import back would close a circle.
Dynamics = Any

#: kind -> (input names, output names, description)
POINT_FUNCTIONS: dict[str, tuple[tuple[str, ...], tuple[str, ...], str]] = {
    "position": (("psi",), ("x", "y"), "position of the point, m"),
    "velocity": (("psi", "dpsi"), ("vx", "vy"), "velocity, m/s"),
    "acceleration": (("psi", "dpsi", "ddpsi"), ("ax", "ay"), "acceleration, m/s^2"),
    "jacobian": (
        ("psi",),
        ("jacobian",),
        "d(x, y)/dq for q = (x0, y0, psi_1..psi_n): (2, n + 2), m/rad (1 for the base)",
    ),
    "hinge_moments": (
        ("psi", "force"),
        ("M",),
        "hinge torques a force (Fx, Fy) N at the point stands for: its moment about each "
        "hinge on the path to the point, 0 elsewhere, (n,) N m",
    ),
    "held_dynamics": (
        ("psi", "dpsi", "M"),
        ("ddpsi", "force"),
        "the motion under the hinge torques M with the point held at rest (a second contact, "
        "a closed chain): angular accelerations (n,) rad/s^2 and the force (Fx, Fy) N that "
        "holds the point",
    ),
}


@dataclass(frozen=True)
class LinkPoint:
    """A point fixed on a link, as data.

    Parameters
    ----------
    link : str
        Name of the link that carries the point.
    along : float
        Position along the link's axis from its start hinge, as a fraction of its length
        (1.0: the end hinge, e.g. the foot at the end of a shank).
    lateral : float
        Offset perpendicular to the axis, fraction of the length, positive to the left.
    name : str or None
        A label for the point (``"foot"``, ``"heel"``); default from the link and offset.
    """

    link: str
    along: float = 1.0
    lateral: float = 0.0
    name: str | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.link, str) or not self.link:
            raise DefinitionTypeError(
                f"`link`: must be the name of a link (a non-empty string), got {self.link!r}"
            )
        object.__setattr__(self, "along", check_real("along", self.along))
        object.__setattr__(self, "lateral", check_real("lateral", self.lateral))
        if self.name is not None and (not isinstance(self.name, str) or not self.name.strip()):
            raise DefinitionTypeError(
                f"`name`: a point's name must be a non-empty string or None, got {self.name!r}"
            )

    @property
    def label(self) -> str:
        """The name, or ``<link>_end`` / ``<link>_at_<along>_<lateral>``."""
        if self.name is not None:
            return self.name
        if self.along == 1.0 and self.lateral == 0.0:
            return f"{self.link}_end"
        return f"{self.link}_at_{self.along:g}_{self.lateral:g}"

    def offset(self, linkage: Linkage) -> complex:
        """The point in its link's frame, m: length * (along + j lateral)."""
        if self.link not in linkage.names:
            raise DefinitionError(
                f"`link`: no link called {self.link!r} to carry the point; "
                f"known links: {list(linkage.names)}"
            )
        length = linkage.links[linkage.index(self.link)].length
        return length * complex(self.along, self.lateral)

    def levers(self, linkage: Linkage) -> list[tuple[int, complex]]:
        """(k, r_k) for every link k on the path from the root to the point's link, root
        first: r_k is the lever from k's start hinge to the point's side of link k (the next
        path link's start hinge, or the point itself), in k's frame, m."""
        i = linkage.index(self.link)
        path = (*linkage.ancestors(i), i)
        levers = [(k, linkage.origin_in_parent(path[j + 1])) for j, k in enumerate(path[:-1])]
        levers.append((i, self.offset(linkage)))
        return levers


def label_identifier(label: str) -> str:
    """A CasADi Function name part from a label: letters, digits and single underscores."""
    return re.sub(r"_+", "_", re.sub(r"\W", "_", label.replace("-", "m"))).strip("_") or "p"


class PointKinematics:
    """A :class:`LinkPoint` bound to a :class:`model.Dynamics`: SX Functions and numpy batches.

    Built by ``Dynamics.point(link, along, lateral, name)``. Functions (see
    ``POINT_FUNCTIONS``) are generated on first use, cached in the Dynamics (``built`` lists
    them as ``point_<label>_<kind>``) and evaluated like the Dynamics' own: one state or a
    (K, n) batch.
    """

    def __init__(self, dynamics: Dynamics, point: LinkPoint, identifier: str | None = None) -> None:
        self._dynamics = dynamics
        self.point = point
        linkage = dynamics.linkage
        self.offset = point.offset(linkage)  # validates the link
        self.index = linkage.index(point.link)
        #: The label as a CasADi Function name part (letters, digits, single underscores).
        self.identifier = identifier or label_identifier(point.label)

    @property
    def label(self) -> str:
        return self.point.label

    @property
    def dynamics(self) -> Dynamics:
        return self._dynamics

    def function_name(self, kind: str) -> str:
        return f"point_{self.identifier}_{kind}"

    def function(self, kind: str) -> ca.Function:
        """The SX Function of ``kind`` ("position", "velocity", "acceleration", "jacobian")."""
        if kind not in POINT_FUNCTIONS:
            raise DefinitionError(
                f"`kind`: unknown point function {kind!r}; available: {list(POINT_FUNCTIONS)}"
            )
        inputs, outputs, _ = POINT_FUNCTIONS[kind]
        return self._dynamics.cached_function(
            self.function_name(kind),
            inputs,
            [self._dynamics.symbols_of(k) for k in inputs],
            outputs,
            lambda: self._build(kind),
        )

    def expression(self, kind: str, *args) -> ca.SX | ca.MX:
        """``function(kind)`` called on symbolic arguments, as a column: (2, 1) [x; y] (or
        rates) for position/velocity/acceleration, (2, n + 2) for the Jacobian.

        >>> ocp.constrain("clearance", lambda p: foot.expression("position", p.psi)[1], lower=0)
        """
        result = self.function(kind).call(list(args))
        return result[0] if kind == "jacobian" else ca.vertcat(*result)

    def _build(self, kind: str) -> list[ca.SX]:
        dyn = self._dynamics
        i = self.index
        if kind == "jacobian":
            return [self._jacobian()]
        if kind == "hinge_moments":
            return [self._hinge_moments()]
        if kind == "held_dynamics":
            return self._held_dynamics()
        order = ("position", "velocity", "acceleration").index(kind)
        start, phasor = dyn.link_kinematics(order)
        here = Cx(start.re[i], start.im[i]) + Cx(phasor.re[i], phasor.im[i]) * self.offset
        return [here.re, here.im]

    def _jacobian(self) -> ca.SX:
        dyn = self._dynamics
        n = dyn.n
        _, frames = dyn.link_kinematics(0)
        jacobian = ca.SX(2, n + 2)  # structural zeros off the path
        jacobian[0, 0] = 1.0
        jacobian[1, 1] = 1.0
        for k, lever in self.point.levers(dyn.linkage):
            column = (Cx(frames.re[k], frames.im[k]) * lever).times_j()
            jacobian[0, 2 + k] = column.re
            jacobian[1, 2 + k] = column.im
        return jacobian

    def _hinge_moments(self) -> ca.SX:
        """M_k = Im(conj(z_P - z_start,k) F) for k on the path to the point's link, else 0.

        A force F on the point does the virtual work F . dz_P = sum_k M_k (dpsi_k -
        dpsi_parent(k)) with these M: the hinge torques that stand for it in the model's
        equations (inverse dynamics with the force = inverse dynamics without it - M)."""
        dyn = self._dynamics
        i = self.index
        force = dyn.symbols_of("force")
        start, frames = dyn.link_kinematics(0)
        here = Cx(start.re[i], start.im[i]) + Cx(frames.re[i], frames.im[i]) * self.offset
        moments = ca.SX(dyn.n, 1)
        for k in (*dyn.linkage.ancestors(i), i):
            lever = Cx(here.re - start.re[k], here.im - start.im[k])
            moments[k] = lever.re * force[1] - lever.im * force[0]
        return moments

    def _held_dynamics(self) -> list[ca.SX]:
        """ddpsi = a_free + C F with a_free the motion under M alone (the root pinned) and
        C = M(psi)^-1 Q(J^T) the accelerations a unit force on the point makes (its hinge
        moments as generalised forces); F holds the point: its acceleration, affine in ddpsi,

            a_P = a_P(ddpsi = a_free) + J C F = 0  ->  F = -(J C)^-1 a_P(a_free),

        a 2 x 2 solve (J C = J M^-1 J^T, positive definite while the point is not at a
        singular pose of its chain). No inverse of M is formed: one sparse L D L^T solve with
        two more right-hand sides."""
        dyn = self._dynamics
        symbols = dyn.symbols
        free = dyn._forward_expression()
        force = dyn.symbols_of("force")
        moments = self._hinge_moments()
        unit = ca.horzcat(
            ca.substitute(moments, force, ca.DM([1.0, 0.0])),
            ca.substitute(moments, force, ca.DM([0.0, 1.0])),
        )
        response = dyn._solve_mass_matrix(dyn._generalized_from_torques(unit))  # (n, 2)
        acceleration = ca.vertcat(*self._build("acceleration"))
        at_free = ca.substitute(acceleration, symbols["ddpsi"], free)
        jacobian = ca.jacobian(acceleration, symbols["ddpsi"])  # (2, n): a_P is affine
        held = -ca.solve(ca.mtimes(jacobian, response), at_free)
        return [free + ca.mtimes(response, held), held]

    # ---- numeric ------------------------------------------------------------------------
    def _complex(self, kind: str, *arrays) -> np.ndarray | complex:
        self.function(kind)
        x, y = self._dynamics.evaluate(self.function_name(kind), *arrays)
        return x + 1j * y

    def position(self, psi) -> np.ndarray | complex:
        """x + j y, m: complex scalar for one state (n,), (K,) for a batch (K, n)."""
        return self._complex("position", psi)

    def velocity(self, psi, dpsi) -> np.ndarray | complex:
        """vx + j vy, m/s (fixed base): complex scalar or (K,)."""
        return self._complex("velocity", psi, dpsi)

    def acceleration(self, psi, dpsi, ddpsi) -> np.ndarray | complex:
        """ax + j ay, m/s^2 (fixed base): complex scalar or (K,)."""
        return self._complex("acceleration", psi, dpsi, ddpsi)

    def hinge_moments(self, psi, force) -> np.ndarray:
        """Hinge torques (n,) or (K, n), N m, that the force (Fx, Fy) (2,) or (K, 2), N, on
        the point stands for (see ``POINT_FUNCTIONS``)."""
        self.function("hinge_moments")
        return self._dynamics.evaluate(self.function_name("hinge_moments"), psi, force)[0]

    def held_dynamics(self, psi, dpsi, torques) -> tuple[np.ndarray, np.ndarray]:
        """(ddpsi (n,), force (2,)) of the motion with the point held at rest (see
        ``POINT_FUNCTIONS``); a leading K axis for a batch."""
        self.function("held_dynamics")
        ddpsi, force = self._dynamics.evaluate(
            self.function_name("held_dynamics"), psi, dpsi, torques
        )
        return ddpsi, force

    def jacobian(self, psi, floating: bool = True) -> np.ndarray:
        """d(x, y)/dq: (2, n + 2) for q = (x0, y0, psi) (``floating``), else d(x, y)/dpsi
        (2, n); a leading K axis for a batch."""
        self.function("jacobian")
        (full,) = self._dynamics.evaluate(self.function_name("jacobian"), psi)
        return full if floating else full[..., 2:]

    def __repr__(self) -> str:
        p = self.point
        return (
            f"PointKinematics({p.label!r} on {p.link!r}: along={p.along:g}, lateral={p.lateral:g})"
        )
