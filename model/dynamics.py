"""The complex-variable Lagrange model of a planar link tree, generated as CasADi SX.

The seed paper's way, for any tree (equations (1)-(21) for the six-link case):

* each centre of mass is one sum of complex exponentials (paper (1)-(6)),
      w_i = sum_{k ancestor of i} o_k e^{j psi_parent(k)} + c_i e^{j psi_i},
  with o_k the start hinge of link k in its parent's frame (l_parent for a paper link) and
  c_i = n_i l_i the centre of mass in the link's frame;
* velocities come from multiplying each exponential by j dpsi (paper (7)-(12)), accelerations
  from d^2/dt^2 e^{j psi} = (j ddpsi - dpsi^2) e^{j psi};
* T = 1/2 sum (m_i |dw_i/dt|^2 + J_i dpsi_i^2) and Pi = g sum m_i Im(w_i) (paper (13)-(15));
* Lagrange's equations of the second kind, d/dt dT/d(dpsi_k) - dT/dpsi_k + dPi/dpsi_k = Q_k.
  Because dw_i/dt is linear in dpsi with coefficients dw_i/dpsi_k, their left-hand side is
      sum_i m_i Re( conj(dw_i/dpsi_k) (d^2w_i/dt^2 + j g) ) + J_k ddpsi_k ,
  with dw_i/dpsi_k = j o e^{j psi_k} (a quarter turn of the lever from link k's start hinge).
  Summing over the subtree of k link by link gives the equations in O(n) complex operations;
  expanded, they are exactly sum_m B_km cos(psi_k - psi_m) ddpsi_m + B_km sin(psi_k - psi_m)
  dpsi_m^2 + gravity = Q_k of DESIGN.md and the corrected (16)-(21) of the paper.
* Q_k = M_k - sum_{children c} M_c, so the hinge torque is M_k = sum of Q over the subtree of k.

Every CasADi Function is built the first time it is asked for (``Dynamics.function(name)``)
and cached: a problem that needs only inverse dynamics never builds forward dynamics.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import casadi as ca
import numpy as np

from model.complex_sx import Constants, Cx, apply, expj, imag_of_conj_product, times_constants
from model.contact import Contact
from model.floating import FloatingBase
from model.impact import ImpactMap
from model.linkage import Linkage
from model.linkage_system import linkage_system
from model.numpy_tape import NumpyTape
from model.points import LinkPoint, PointKinematics
from model.rotors import Rotor, rotor_matrix
from planner.errors import DefinitionError, DefinitionTypeError, check_states
from planner.system import System

logger = logging.getLogger(__name__)

#: name -> (input names, output names, one-line description); the catalogue of Functions.
FUNCTIONS: dict[str, tuple[tuple[str, ...], tuple[str, ...], str]] = {
    "hinge_positions": (("psi",), ("hinge_x", "hinge_y"), "hinges H0..Hn, m"),
    "hinge_velocities": (("psi", "dpsi"), ("hinge_vx", "hinge_vy"), "hinge velocities, m/s"),
    "com_positions": (("psi",), ("com_x", "com_y"), "centres of mass, m"),
    "com_velocities": (("psi", "dpsi"), ("com_vx", "com_vy"), "centre-of-mass velocities, m/s"),
    "energy": (("psi", "dpsi"), ("kinetic", "potential"), "T and Pi, J"),
    "mass_matrix": (("psi",), ("mass_matrix",), "generalised mass matrix, kg m^2"),
    "inverse_dynamics": (("psi", "dpsi", "ddpsi"), ("M",), "hinge torques, N m"),
    "gravity_torques": (("psi",), ("M",), "hinge torques holding a static pose, N m"),
    "forward_dynamics": (("psi", "dpsi", "M"), ("ddpsi",), "angular accelerations, rad/s^2"),
    "dynamics_residual": (
        ("psi", "dpsi", "ddpsi", "M"),
        ("residual",),
        "inverse_dynamics - M, N m (zero on the motion)",
    ),
    "ground_reaction": (("psi", "dpsi", "ddpsi"), ("Fx", "Fy"), "force of the ground at H0, N"),
    "ode": (("x", "u"), ("xdot",), "x = [psi; dpsi], u = M -> [dpsi; ddpsi]"),
}


#: Outputs that are one number per state: returned as float (one state) or (K,) (a batch).
#: Every other output keeps its shape, even when it is 1x1 (a one-link tree).
_SCALAR_OUTPUTS = frozenset(
    {"kinetic", "potential", "Fx", "Fy", "x", "y", "vx", "vy", "ax", "ay", "px", "py"}
)
_MATRIX_OUTPUTS = frozenset({"mass_matrix", "jacobian"})


def _output_shape(function: ca.Function, i: int) -> tuple[int, ...]:
    """Per-state shape of output i as the numeric methods document it."""
    name = function.name_out(i)
    if name in _SCALAR_OUTPUTS:
        return ()
    if name in _MATRIX_OUTPUTS:
        return (function.size1_out(i), function.size2_out(i))
    return (function.size1_out(i),)


class Dynamics:
    """Equations of motion of a :class:`model.Linkage`, generated lazily as CasADi SX.

    Angles psi (n,) rad are absolute, from +x counter-clockwise; dpsi (n,) rad/s; ddpsi (n,)
    rad/s^2; hinge torques M (n,) N m act at the start hinge of each link, on the link, from
    its parent (from the ground for the root).

    Symbolic use: ``function(name)`` returns a named CasADi Function (see ``FUNCTIONS``).
    Numeric use: the methods below take one state (n,) or a batch (K, n) of numpy values and
    return numpy arrays of matching leading shape; batches are evaluated in one vectorised
    pass (no Python loop over states).
    """

    def __init__(
        self, linkage: Linkage, cse: bool | None = None, rotors: Sequence[Rotor] = ()
    ) -> None:
        if not isinstance(linkage, Linkage):
            raise DefinitionTypeError(
                f"`linkage`: must be a model.Linkage, got {type(linkage).__name__}"
            )
        self._linkage = linkage
        # Geared motors' rotors (model.rotors): a constant J b b^T on the mass matrix.
        self._rotor_matrix = rotor_matrix(rotors, linkage.names)
        self._rotors = tuple(rotors)
        n = linkage.n
        depth = max(len(linkage.ancestors(i)) for i in range(n))
        # Common-subexpression elimination turns the path sums of deep trees back into
        # running sums (O(n) instead of O(n d) instructions); on shallow trees it saves a few
        # percent of instructions and costs more generation time than it saves.
        self._cse = depth >= 5 if cse is None else bool(cse)
        self._psi = ca.SX.sym("psi", n)
        self._dpsi = ca.SX.sym("dpsi", n)
        self._ddpsi = ca.SX.sym("ddpsi", n)
        self._torque = ca.SX.sym("M", n)
        self._functions: dict[str, ca.Function] = {}
        self._tapes: dict[str, NumpyTape | None] = {}
        self._buffers: dict[str, tuple] = {}
        self._layouts: dict[str, list[_OutputLayout]] = {}
        self._cache: dict[str | tuple, object] = {}
        self.generation_seconds: dict[str, float] = {}
        links = linkage.links
        # Constant geometry in each link's own frame (complex, m).
        self._origin = [linkage.origin_in_parent(i) for i in range(n)]
        self._com = [link.com_offset for link in links]
        self._mass = [link.mass for link in links]
        self._inertia = [link.inertia for link in links]
        self._length = [link.length for link in links]
        # Constants converted to CasADi once (each conversion costs microseconds).
        self._origin_vector = Constants(self._origin)
        self._origin_conj = self._origin_vector.conj()
        self._com_vector = Constants(self._com)
        self._com_conj = self._com_vector.conj()
        self._length_vector = Constants(self._length)
        self._mass_dm = ca.DM(self._mass)
        self._weight_dm = ca.DM(self._mass) * linkage.gravity
        self._inertia_dm = ca.DM(self._inertia)

    #: The formulation of the planner's System when an OCP names none (``planner.OCP``).
    default_formulation = "implicit"

    def as_system(self, formulation: str = "implicit", contacts: Sequence = ()) -> System:
        """This model as a ``planner.System`` (x = [psi; dpsi], u = M and the ground forces of
        ``contacts``, z = ddpsi when implicit): what ``planner.OCP(dynamics)`` calls, through
        the linkage adapter :func:`model.linkage_system.linkage_system`.

        ``contacts``: points held by the ground (link names for their end hinges, or
        ``LinkPoint``), whose ground forces F_<point>_x, _y (N) become controls.

        Kept per (formulation, contacts): every builder of an OCP makes a new definition that
        asks again (a walking step's OCP about 30 times), and a System is immutable."""
        key = (formulation, tuple(contacts))
        try:
            hash(key)
        except TypeError:  # an unhashable contact description: built anew
            return linkage_system(self, formulation, contacts)
        return self._memo(("system", key), lambda: linkage_system(self, *key))

    def subtree_moments(self) -> tuple[list[float], list[complex]]:
        """(mass of each link's subtree, kg; first moment K_m of each subtree about the link's
        start hinge in the link's frame, kg m, complex).

        K_m = m_m c_m + sum_{children c} o_c mass(subtree c): the subtree's momentum is
        sum_i m_i dw_i/dt = sum_m j dpsi_m K_m e^{j psi_m}, which couples the links to a
        moving base, and D_km = conj(o_km) K_m gives the mass matrix.
        """

        def build():
            linkage = self._linkage
            n = self.n
            subtree_mass = [0.0] * n
            for i in reversed(range(n)):
                subtree_mass[i] = self._mass[i] + sum(subtree_mass[c] for c in linkage.children[i])
            first_moment = [
                self._mass[m] * self._com[m]
                + sum(self._origin[c] * subtree_mass[c] for c in linkage.children[m])
                for m in range(n)
            ]
            return subtree_mass, first_moment

        return self._memo("subtree_moments", build)

    def _mass_constants(self) -> tuple[np.ndarray, ca.Sparsity, np.ndarray]:
        """Constant parts of the mass matrix: D_km (lower triangle), its pattern, diagonal."""
        linkage = self._linkage
        n = self.n
        subtree_mass, first_moment = self.subtree_moments()
        coefficient = np.zeros((n, n), dtype=complex)
        diagonal = np.zeros(n)
        rows, cols = [], []
        for m in range(n):
            diagonal[m] = (
                self._inertia[m]
                + self._mass[m] * abs(self._com[m]) ** 2
                + sum(abs(self._origin[c]) ** 2 * subtree_mass[c] for c in linkage.children[m])
            )
            rows.append(m)
            cols.append(m)
            below = m  # walking up from m; o_km is the origin of the link below k on the path
            for k in reversed(linkage.ancestors(m)):
                # entry (m, k), m > k: Re(conj(o_km) K_m conj(e_k) e_m)
                coefficient[m, k] = np.conj(self._origin[below]) * first_moment[m]
                rows.append(m)
                cols.append(k)
                below = k
        pattern = ca.Sparsity.triplet(n, n, rows, cols)
        return coefficient, pattern, diagonal

    # ---- catalogue ----------------------------------------------------------------------
    @property
    def linkage(self) -> Linkage:
        return self._linkage

    @property
    def rotors(self) -> tuple[Rotor, ...]:
        """The geared motors' rotors in the equations (``model.rotors``), () for none."""
        return self._rotors

    def _rotor_dm(self) -> ca.DM | None:
        """sum J b b^T as a sparse DM (only its structural non-zeros), None without rotors."""
        if not self._rotors:
            return None
        return ca.sparsify(ca.DM(self._rotor_matrix))

    @property
    def n(self) -> int:
        return self._linkage.n

    @property
    def names(self) -> tuple[str, ...]:
        return self._linkage.names

    @property
    def built(self) -> tuple[str, ...]:
        """Names of the CasADi Functions generated so far, in the order they were built."""
        return tuple(self._functions)

    def function(self, name: str) -> ca.Function:
        """The named CasADi Function, generated on first use and cached."""
        if name not in FUNCTIONS:
            raise DefinitionError(
                f"`name`: unknown function {name!r}; available: {sorted(FUNCTIONS)}"
            )
        inputs, outputs, _ = FUNCTIONS[name]
        return self.cached_function(
            name,
            inputs,
            [self._symbol(k) for k in inputs],
            outputs,
            getattr(self, "_build_" + name),
        )

    def cached_function(
        self,
        name: str,
        input_names: Sequence[str],
        inputs: Sequence[ca.SX],
        output_names: Sequence[str],
        build: Callable[[], list[ca.SX]],
    ) -> ca.Function:
        """The SX Function ``name`` of this model: built by ``build()`` on first use, cached.

        Every Function of the model (the catalogue ``FUNCTIONS``, points on links, the
        floating base, impact maps) is generated here, so that it is timed
        (``generation_seconds``), listed in ``built`` and evaluated on numpy batches by
        :meth:`evaluate` the same way. ``inputs`` are purely symbolic SX (this model's
        symbols); names must be unique per model.
        """
        if name not in self._functions:
            start = time.perf_counter()
            expressions = build()
            self._functions[name] = ca.Function(
                name,
                list(inputs),
                expressions,
                list(input_names),
                list(output_names),
                {"cse": self._cse},
            )
            self.generation_seconds[name] = time.perf_counter() - start
            logger.debug("generated %s in %.3f ms", name, 1e3 * self.generation_seconds[name])
        return self._functions[name]

    def _symbol(self, name: str) -> ca.SX:
        if name == "x":
            return ca.vertcat(self._psi, self._dpsi)
        if name == "u":
            return self._torque
        return self.symbols[name]

    def symbols_of(self, name: str) -> ca.SX:
        """One of :attr:`symbols`, or ``force`` (2,): a force (Fx, Fy) on a point, N."""
        if name == "force":
            return self._memo("force", lambda: ca.SX.sym("force", 2))
        return self.symbols[name]

    @property
    def symbols(self) -> dict[str, ca.SX]:
        """The model's SX symbols: psi, dpsi, ddpsi (n,) and the hinge torques M (n,).

        Expressions built by the model's Functions are expressions of these; a Function of
        another part of the model (points, floating base) takes them as its inputs.
        """
        return {"psi": self._psi, "dpsi": self._dpsi, "ddpsi": self._ddpsi, "M": self._torque}

    # ---- points, floating base, impacts (built from the same description) --------------
    def point(
        self,
        link: str | LinkPoint | Contact,
        along: float = 1.0,
        lateral: float = 0.0,
        name: str | None = None,
    ) -> PointKinematics:
        """A point fixed on ``link`` (``along``, ``lateral``: fractions of its length; the
        default is the end hinge), a :class:`model.LinkPoint` or a :class:`model.Contact`'s
        point; see :mod:`model.points`.

        Points are cached by their label: asking twice for the same point returns the same
        object; two different points under one name are refused.
        """
        if isinstance(link, Contact):
            link = link.point
        if isinstance(link, LinkPoint):
            if (along, lateral, name) != (1.0, 0.0, None):
                raise DefinitionError(
                    "`point`: give either a LinkPoint or link/along/lateral/name, not both"
                )
            point = link
        else:
            point = LinkPoint(link, along, lateral, name)
        points = self._memo("points", dict)
        known = points.get(point.label)
        if known is not None:
            if known.point != point:
                raise DefinitionError(
                    f"`name`: this model already has a point called {point.label!r} "
                    f"({known.point}); give the new point another name"
                )
            return known
        kinematics = PointKinematics(self, point)
        taken = {known.identifier for known in points.values()}
        suffix = 2
        while kinematics.identifier in taken:  # labels that differ only in punctuation
            kinematics = PointKinematics(self, point, f"{kinematics.identifier}_{suffix}")
            suffix += 1
        points[point.label] = kinematics
        return kinematics

    @property
    def floating(self) -> FloatingBase:
        """The same tree with its root hinge free in the plane (:mod:`model.floating`),
        sharing this model's symbols and building blocks."""
        return self._memo("floating", lambda: FloatingBase(self))

    def impact(
        self,
        point: str | LinkPoint | PointKinematics | Contact | Sequence,
        root_pinned: bool = False,
        *,
        root_welded: bool = False,
    ) -> ImpactMap:
        """The inelastic, non-sliding impact of ``point`` with the ground while the root hinge
        H0 (the old contact) is at rest (:mod:`model.impact`). A link name means its end; a
        :class:`model.Contact` its point; a sequence of them lands every point at once (a
        heel and a toe). ``root_pinned``: H0 stays held through the impact (a double
        support begins) instead of being free to lift off; ``root_welded``: the root link is
        held in rotation too (a foot flat on the ground: its angular impulse about H0 ends the
        impulses)."""
        many = isinstance(point, Sequence) and not isinstance(point, str)
        points = tuple(self._own_point(p) for p in (point if many else (point,)))
        if not points:
            raise DefinitionError("`point`: give at least one point that lands")
        labels = [p.label for p in points]
        if len(set(labels)) != len(labels):
            raise DefinitionError(f"`point`: a point lands twice: {labels}")
        impacts = self._memo("impacts", dict)
        key = (tuple(labels), bool(root_pinned) or bool(root_welded), bool(root_welded))
        if key not in impacts:
            impacts[key] = ImpactMap(points, root_pinned, root_welded)
        return impacts[key]

    def _own_point(self, point) -> PointKinematics:
        """``point`` (a link name, LinkPoint, Contact or PointKinematics) as this model's."""
        if not isinstance(point, PointKinematics):
            return self.point(point)
        if point.dynamics is not self:
            raise DefinitionError("`point`: the point belongs to another Dynamics")
        return point

    # ---- tree operators (constant 0/1 matrices) ---------------------------------------
    def _operators(self) -> dict[str, ca.DM]:
        """Sparse constant matrices that walk the tree in one wide operation each.

        ``path``: path[i, m] = 1 when m lies on the path from the root to i (m ancestor of i,
        or i itself). ``subtree``: subtree[k, i] = 1 when i is k or a descendant of k.
        ``parent``: parent[k, p(k)] = 1 (zero row for the root). ``children``: its transpose.

        Sums through ``path`` and ``subtree`` share their partial sums after CasADi's common
        subexpression elimination, so they cost O(n) instructions, like a recursion, while
        generation needs O(1) Python calls instead of O(n).
        """

        def build():
            linkage = self._linkage
            n = self.n
            path = np.zeros((n, n))
            parent = np.zeros((n, n))
            for i in range(n):
                path[i, i] = 1.0
                for m in linkage.ancestors(i):
                    path[i, m] = 1.0
                if linkage.parents[i] >= 0:
                    parent[i, linkage.parents[i]] = 1.0
            # Subtree sums run from the highest index down, so that a child's subtree sum is
            # a prefix of its parent's (CasADi accumulates a sparse product column by column).
            flip = np.eye(n)[::-1]
            return {
                "path": ca.sparsify(ca.DM(path)),
                "subtree_flipped": ca.sparsify(ca.DM(flip @ path.T @ flip)),
                "flip": ca.sparsify(ca.DM(flip)),
                "parent": ca.sparsify(ca.DM(parent)),
                "children": ca.sparsify(ca.DM(parent.T)),
            }

        return self._memo("operators", build)

    def _subtree_sum(self, v: ca.SX) -> ca.SX:
        """(subtree @ v): for each link, the sum of v over the link and its descendants."""
        ops = self._operators()
        return ca.mtimes(ops["flip"], ca.mtimes(ops["subtree_flipped"], ca.mtimes(ops["flip"], v)))

    # ---- shared symbolic building blocks (each built once) -----------------------------
    def _memo(self, key: str | tuple, build: Callable[[], object]):
        if key not in self._cache:
            self._cache[key] = build()
        return self._cache[key]

    def _frames(self) -> Cx:
        """e^{j psi_k} for every link (vector): the only transcendental functions."""
        return self._memo("frames", lambda: expj(self._psi))

    def _propagate(self, phasor: Cx) -> tuple[Cx, Cx]:
        """Start hinges and centres of mass from per-link phasor terms (paper (1)-(12)).

        ``phasor`` is e^{j psi} (positions), its first or its second time derivative
        (velocities, accelerations): the same sums of exponentials serve all three. Each start
        hinge is the sum, along the path from the root, of o_m e^{j psi_parent(m)}.
        Returns (start hinges, centres of mass), complex vectors relative to H0.
        """
        ops = self._operators()
        lever = times_constants(apply(ops["parent"], phasor), self._origin_vector)
        start = apply(ops["path"], lever)
        return start, start + times_constants(phasor, self._com_vector)

    def _positions(self) -> tuple[Cx, Cx]:
        def build():
            start, com = self._propagate(self._frames())
            root = self._origin[0]  # the root's start hinge is fixed in the world
            return start + root, com + root

        return self._memo("positions", build)

    def _phasor_rates(self) -> Cx:
        """d/dt e^{j psi} = j dpsi e^{j psi}  (paper (7)-(12))."""
        return self._memo("rates", lambda: self._frames().times_j().scale(self._dpsi))

    def _velocities(self) -> tuple[Cx, Cx]:
        return self._memo("velocities", lambda: self._propagate(self._phasor_rates()))

    def _phasor_accelerations(self) -> Cx:
        """d^2/dt^2 e^{j psi} = (j ddpsi - dpsi^2) e^{j psi}."""

        def build():
            e = self._frames()
            w2 = self._dpsi * self._dpsi
            ddpsi = self._ddpsi
            return Cx(-w2 * e.re - ddpsi * e.im, ddpsi * e.re - w2 * e.im)

        return self._memo("phasor_accelerations", build)

    def _accelerations(self) -> tuple[Cx, Cx]:
        return self._memo("accelerations", lambda: self._propagate(self._phasor_accelerations()))

    def link_kinematics(self, order: int) -> tuple[Cx, Cx]:
        """SX building blocks of any point fixed on a link, shared by every user of the model.

        Returns (start, phasor), complex vectors (n,): for ``order`` 0 the world positions of
        the links' start hinges (m) and e^{j psi}; for 1 their velocities (m/s) and
        d/dt e^{j psi} = j dpsi e^{j psi}; for 2 their accelerations (m/s^2) and
        (j ddpsi - dpsi^2) e^{j psi}. The point at offset c (complex, m, in link i's frame)
        is start_i + c phasor_i and its rates are the same sum with the rates of the terms.
        Expressions of :attr:`symbols` (psi; dpsi; ddpsi).
        """
        if order == 0:
            return self._positions()[0], self._frames()
        if order == 1:
            return self._velocities()[0], self._phasor_rates()
        if order == 2:
            return self._accelerations()[0], self._phasor_accelerations()
        raise DefinitionError(
            f"`order`: must be 0, 1 or 2 (position, velocity, acceleration), got {order!r}"
        )

    def _lagrange(self) -> tuple[ca.SX, Cx]:
        """Left-hand sides of Lagrange's equations in hinge-torque form, and the ground force.

        With F_i = m_i (d^2w_i/dt^2 + j g) (d'Alembert force plus weight) and the lever
        dw_i/dpsi_k = j o e^{j psi_k}, the equation of psi_k reads
            Q_k = Im( conj(e^{j psi_k}) [conj(c_k) F_k + sum_children conj(o_c) S_c] )
                  + J_k ddpsi_k,
        S_c = sum of F over the subtree of c. Hinge torques: M_k = sum of Q over the subtree.
        Returns (M (n,), ground force sum_i F_i).
        """

        def build():
            _, acc = self._accelerations()
            mass = self._mass_dm
            force = Cx(mass * acc.re, mass * acc.im + self._weight_dm)
            subtree_force = Cx(self._subtree_sum(force.re), self._subtree_sum(force.im))
            ops = self._operators()
            moment = times_constants(force, self._com_conj) + apply(
                ops["children"], times_constants(subtree_force, self._origin_conj)
            )
            generalized = imag_of_conj_product(self._frames(), moment)
            if any(self._inertia):
                generalized = generalized + self._inertia_dm * self._ddpsi
            rotors = self._rotor_dm()
            if rotors is not None:  # d/dt of dT_r/d(dpsi) = J b (b . ddpsi); b is constant
                generalized = generalized + ca.mtimes(rotors, self._ddpsi)
            torque = self._subtree_sum(generalized)
            ground = Cx(subtree_force.re[0], subtree_force.im[0])
            return torque, ground

        return self._memo("lagrange", build)

    def mass_matrix_expression(self) -> ca.SX:
        """M_km = Re( D_km conj(e^{j psi_k}) e^{j psi_m} ), D_km = conj(o_km) K_m, k ancestor of m.

        o_km: the hinge on link k through which m's subtree hangs (k's frame);
        K_m = m_m c_m + sum_{children c} o_c mass(subtree c): the first moment of m's subtree
        about m's start hinge. Links on different branches couple with an exact (structural)
        zero, which keeps the tree sparsity that the forward solve exploits. The diagonal is
        J_m + m_m |c_m|^2 + sum_c |o_c|^2 mass(subtree c).
        """

        def build():
            e = self._frames()
            coefficient, pattern, diagonal = self._mass_constants()  # lower triangle (m > k)
            # conj(e_k) e_m for all pairs: real part cos(psi_m - psi_k), imaginary sin(...)
            cosine = ca.mtimes(e.re, e.re.T) + ca.mtimes(e.im, e.im.T)
            lower = ca.DM(coefficient.real) * cosine
            if np.any(coefficient.imag):
                sine = ca.mtimes(e.im, e.re.T) - ca.mtimes(e.re, e.im.T)
                lower = lower - ca.DM(coefficient.imag) * sine
            matrix = ca.project(lower, pattern) + ca.diag(ca.DM(diagonal))
            rotors = self._rotor_dm()
            if rotors is not None:  # J b b^T: a rotor between branches adds its entry
                matrix = matrix + ca.tril(rotors)
            return ca.tril2symm(matrix)

        return self._memo("mass_matrix", build)

    def _solve_mass_matrix(self, rhs: ca.SX) -> ca.SX:
        """Solve M(psi) x = rhs by a sparse symbolic L D L^T factorisation; no inverse formed.

        M is symmetric positive definite, so no pivoting is needed. The approximate minimum
        degree ordering eliminates leaves before their parents, which on a tree's mass matrix
        (non-zero only between a link and its ancestors) produces no fill-in: the same
        O(sum of depth^2) factorisation as Featherstone's L^T D L (Rigid Body Dynamics
        Algorithms, sec. 6.3), built by CasADi in C++.
        """
        diagonal, upper, order = ca.ldl(self.mass_matrix_expression(), True)
        return ca.ldl_solve(rhs, diagonal, upper, order)

    def _generalized_from_torques(self, torque: ca.SX) -> ca.SX:
        """Q_k = M_k - sum_{children c} M_c."""
        return torque - ca.mtimes(self._operators()["children"], torque)

    # ---- Function bodies -----------------------------------------------------------------
    def _build_hinge_positions(self):
        start, _ = self._positions()
        ends = start + times_constants(self._frames(), self._length_vector)
        root = self._origin[0]
        return [ca.vertcat(root.real, ends.re), ca.vertcat(root.imag, ends.im)]

    def _build_hinge_velocities(self):
        start, _ = self._velocities()
        ends = start + times_constants(self._phasor_rates(), self._length_vector)
        return [ca.vertcat(0, ends.re), ca.vertcat(0, ends.im)]

    def _build_com_positions(self):
        _, com = self._positions()
        return [com.re, com.im]

    def _build_com_velocities(self):
        _, com = self._velocities()
        return [com.re, com.im]

    def _build_energy(self):
        _, velocity = self._velocities()
        _, com = self._positions()
        mass = self._mass_dm
        kinetic = 0.5 * (
            ca.dot(mass, velocity.abs2()) + ca.dot(self._inertia_dm, self._dpsi * self._dpsi)
        )
        rotors = self._rotor_dm()
        if rotors is not None:
            kinetic = kinetic + 0.5 * ca.bilin(rotors, self._dpsi, self._dpsi)
        potential = self._linkage.gravity * ca.dot(mass, com.im)
        return [kinetic, potential]

    def _build_mass_matrix(self):
        return [self.mass_matrix_expression()]

    def _build_inverse_dynamics(self):
        torque, _ = self._lagrange()
        return [torque]

    def _build_gravity_torques(self):
        torque, _ = self._lagrange()  # at rest: dpsi = ddpsi = 0
        rates = ca.vertcat(self._dpsi, self._ddpsi)
        return [ca.substitute(torque, rates, ca.DM.zeros(2 * self.n))]

    def _build_forward_dynamics(self):
        return [self._forward_expression()]

    def _forward_expression(self) -> ca.SX:
        def build():
            # The velocity and gravity terms: the equations at ddpsi = 0, substituted in one
            # C++ pass (several times cheaper than writing them again; SX folds the zeros).
            torque, _ = self._lagrange()
            bias = ca.substitute(torque, self._ddpsi, ca.DM.zeros(self.n))
            rhs = self._generalized_from_torques(self._torque - bias)
            return self._solve_mass_matrix(rhs)

        return self._memo("forward", build)

    def _build_dynamics_residual(self):
        torque, _ = self._lagrange()
        return [torque - self._torque]

    def _build_ground_reaction(self):
        _, force = self._lagrange()
        return [force.re, force.im]

    def _build_ode(self):
        return [ca.vertcat(self._dpsi, self._forward_expression())]

    # ---- numeric evaluation ---------------------------------------------------------------
    def evaluate(self, name: str, *arrays) -> list:
        """Evaluate the model's Function ``name`` on one state or a batch of numpy values.

        ``name``: a catalogue Function (``FUNCTIONS``, built on demand) or one already built
        through :meth:`cached_function` (points, floating base, impact maps). Each input is
        (size,) or (K, size); returns one array per output with the batch as the leading axis
        (dropped again for a single state): scalar outputs become floats or (K,), vectors
        (size,) or (K, size), matrices (rows, cols) or (K, rows, cols). Finite inputs that
        give a non-finite result (they overflow double precision) raise DefinitionError.
        """
        results = self._evaluate_unchecked(name, *arrays)
        for result in results:
            if not np.all(np.isfinite(result)):
                function = self._functions[name] if name in self._functions else None
                function = function if function is not None else self.function(name)
                raise DefinitionError(_overflow_message(function, arrays, result))
        return results

    def _evaluate_unchecked(self, name: str, *arrays) -> list:
        if name in self._functions:
            function = self._functions[name]
        else:
            function = self.function(name)
        batch, columns = _as_columns(function, arrays)
        if name not in self._layouts:
            self._layouts[name] = _OutputLayout.of(function)
        layouts = self._layouts[name]
        if batch == 0:  # an empty batch: CasADi would evaluate one state instead
            return [_restore(np.zeros((lay.nonzeros.size, 0)), lay, 0) for lay in layouts]
        if batch is None and hasattr(function, "buffer"):
            return self._evaluate_one(name, function, columns, layouts)
        if columns[0].shape[1] >= NumpyTape.MIN_BATCH:
            tape = self._tape(name, function)
            if tape is not None:
                return [
                    _restore(r, lay, batch) for r, lay in zip(tape(columns), layouts, strict=True)
                ]
        raw = function.call(columns)
        return [
            _restore(np.asarray(r), lay, batch, dense_columns=True)
            for r, lay in zip(raw, layouts, strict=True)
        ]

    def _evaluate_one(self, name, function, columns, layouts) -> list:
        """One state through CasADi's evaluation buffer: the arguments are read in place from
        the numpy arrays (no conversion to DM), ~3 us instead of ~30 us for a six-link call.
        The buffer belongs to this Dynamics: numeric calls on one instance are not thread-safe.
        """
        if name not in self._buffers:
            self._buffers[name] = function.buffer()
        buffer, evaluate = self._buffers[name]
        for i, column in enumerate(columns):
            buffer.set_arg(i, memoryview(column))
        results = [np.zeros((lay.nonzeros.size, 1)) for lay in layouts]
        for i, result in enumerate(results):
            buffer.set_res(i, memoryview(result))
        evaluate()
        return [_restore(r, lay, None) for r, lay in zip(results, layouts, strict=True)]

    def _tape(self, name: str, function: ca.Function) -> NumpyTape | None:
        if name not in self._tapes:
            self._tapes[name] = NumpyTape.try_build(function)
        return self._tapes[name]

    def mass_matrix(self, psi) -> np.ndarray:
        """Generalised mass matrix, kg m^2: (n, n) or (K, n, n)."""
        return self.evaluate("mass_matrix", psi)[0]

    def inverse_dynamics(self, psi, dpsi, ddpsi) -> np.ndarray:
        """Hinge torques M, N m: (n,) or (K, n)."""
        return self.evaluate("inverse_dynamics", psi, dpsi, ddpsi)[0]

    def gravity_torques(self, psi) -> np.ndarray:
        """Hinge torques that hold the pose psi at rest, N m: (n,) or (K, n)."""
        return self.evaluate("gravity_torques", psi)[0]

    def forward_dynamics(self, psi, dpsi, torques) -> np.ndarray:
        """Angular accelerations ddpsi, rad/s^2: (n,) or (K, n)."""
        return self.evaluate("forward_dynamics", psi, dpsi, torques)[0]

    def dynamics_residual(self, psi, dpsi, ddpsi, torques) -> np.ndarray:
        """inverse_dynamics(psi, dpsi, ddpsi) - torques, N m: (n,) or (K, n)."""
        return self.evaluate("dynamics_residual", psi, dpsi, ddpsi, torques)[0]

    def energy(self, psi, dpsi) -> tuple[np.ndarray, np.ndarray]:
        """(kinetic, potential) energy, J: scalars or (K,) arrays."""
        kinetic, potential = self.evaluate("energy", psi, dpsi)
        return kinetic, potential

    def hinge_positions(self, psi) -> np.ndarray:
        """Hinges H0..Hn as complex numbers x + j y, m: (n+1,) or (K, n+1)."""
        x, y = self.evaluate("hinge_positions", psi)
        return x + 1j * y

    def hinge_velocities(self, psi, dpsi) -> np.ndarray:
        """Velocities of H0..Hn, complex, m/s: (n+1,) or (K, n+1)."""
        x, y = self.evaluate("hinge_velocities", psi, dpsi)
        return x + 1j * y

    def com_positions(self, psi) -> np.ndarray:
        """Centres of mass w_i, complex, m: (n,) or (K, n)."""
        x, y = self.evaluate("com_positions", psi)
        return x + 1j * y

    def com_velocities(self, psi, dpsi) -> np.ndarray:
        """dw_i/dt, complex, m/s: (n,) or (K, n)."""
        x, y = self.evaluate("com_velocities", psi, dpsi)
        return x + 1j * y

    def ground_reaction(self, psi, dpsi, ddpsi) -> np.ndarray:
        """Force of the ground on the root at H0, complex Fx + j Fy, N: scalar or (K,).

        F = sum_i m_i d^2w_i/dt^2 + j g sum_i m_i; Fy >= 0 means the ground pushes up.
        """
        fx, fy = self.evaluate("ground_reaction", psi, dpsi, ddpsi)
        return fx + 1j * fy

    def __repr__(self) -> str:
        rotors = f"; {len(self._rotors)} rotors" if self._rotors else ""
        return f"Dynamics({self._linkage!r}{rotors}; built: {list(self.built)})"


def _overflow_message(function: ca.Function, arrays, result) -> str:
    """Where a result is not finite, and how large the inputs were."""
    bad = np.argwhere(~np.isfinite(np.atleast_1d(result)))
    place = f" at state {int(bad[0][0])}" if np.ndim(result) > 1 and bad.size else ""
    sizes = ", ".join(
        f"|{function.name_in(i)}| up to {float(np.max(np.abs(np.asarray(a, dtype=float)))):.3g}"
        for i, a in enumerate(arrays)
    )
    return (
        f"`{function.name()}`: the result is inf or NaN{place} although the inputs are finite "
        f"({sizes}): they overflow double precision; check their units (rad, rad/s, "
        "rad/s^2, N m) and magnitudes"
    )


def _as_columns(function: ca.Function, arrays) -> tuple[int | None, list[np.ndarray]]:
    """Validate numeric inputs against the Function and lay them out as (n_i, K) columns.

    Returns (K or None for a single state, list of column blocks).
    """
    batch = None
    columns = []
    for i, value in enumerate(arrays):
        name = function.name_in(i)
        array = check_states(name, value, function.size1_in(i))
        this = None if array.ndim == 1 else array.shape[0]
        if i == 0:
            batch = this
        elif this != batch:
            raise DefinitionError(
                f"`{name}`: batch size {this} differs from `{function.name_in(0)}` ({batch}); "
                "give every input the same leading dimension"
            )
        columns.append(np.ascontiguousarray(np.atleast_2d(array).T))
    return batch, columns


@dataclass(frozen=True)
class _OutputLayout:
    """How one output of a Function maps to a numpy array (read once per Function: each
    CasADi query through SWIG costs microseconds)."""

    rows: int
    cols: int
    nonzeros: np.ndarray  # column-major positions of the structural non-zeros
    shape: tuple[int, ...]  # per-state shape the numeric methods document

    @staticmethod
    def of(function: ca.Function) -> list[_OutputLayout]:
        return [
            _OutputLayout(
                function.size1_out(i),
                function.size2_out(i),
                np.asarray(function.sparsity_out(i).find(), dtype=int),
                _output_shape(function, i),
            )
            for i in range(function.n_out())
        ]


def _restore(
    values: np.ndarray,
    layout: _OutputLayout,
    batch: int | None,
    dense_columns: bool = False,
):
    """Turn a Function output evaluated on K columns into an array with the batch leading.

    The per-state shape comes from the catalogue (``_output_shape``), not from the size, so a
    one-link tree's 1x1 mass matrix stays (1, 1) and a scalar output becomes a float.
    """
    rows, cols = layout.rows, layout.cols
    values = np.asarray(values, dtype=float)
    k = 1 if batch is None else batch
    if dense_columns:
        # CasADi returns the (rows, cols * K) horizontal concatenation, dense.
        out = values.reshape(rows, k, cols).transpose(1, 0, 2)
    elif layout.nonzeros.size == rows * cols:
        # Dense output (nnz, K): column-major entries.
        out = values.T.reshape(k, cols, rows).transpose(0, 2, 1)
    else:
        # Sparse output (nnz, K): scatter into dense (K, rows, cols) in column-major order.
        dense = np.zeros((k, rows * cols))
        dense[:, layout.nonzeros] = values.T
        out = dense.reshape(k, cols, rows).transpose(0, 2, 1)
    out = out.reshape((k, *layout.shape))
    if batch is None:
        return float(out[0]) if layout.shape == () else out[0]
    return out
