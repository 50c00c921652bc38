"""The impact map: an inelastic, non-sliding impact of a point with the ground.

At heel strike the landing point P (the swing foot) hits the ground while the old contact,
the root hinge H0 (the stance foot), is at rest; the impact is instantaneous, so the
configuration psi does not change and only velocities jump. On the floating-base coordinates
q = (x0, y0, psi) (``model.floating``) with mass matrix M_e(psi) and P's Jacobian J(psi)
(2, n + 2), the impulse Lambda (N s) of the ground on P gives

    M_e (dq+ - dq-) = J^T Lambda,      J dq+ = 0      (P sticks: no slip, no bounce),

with dq- = (0, 0, dpsi-) (H0 at rest before). The old contact receives no impulse: it is free
to lift off, and the base velocity after impact, dq+[:2], is its velocity (a walking step
requires its vertical part to be >= 0).

Solved without an inverse, in the range space of J: M_e is symmetric positive definite with a
tree's pattern (the base is everyone's ancestor), so CasADi's sparse L D L^T eliminating
leaves first has no fill-in; then

    X = M_e^{-1} J^T (two sparse solves),  G = J X (2 x 2, SPD),
    Lambda = -G^{-1} J dq-  (Cramer's rule on 2 x 2),   dq+ = dq- + X Lambda.

With ``root_pinned`` the old contact holds too (a double support begins): the same solve on
the fixed-base mass matrix M(psi) and the psi columns of J, M (dpsi+ - dpsi-) = J^T Lambda,
J dpsi+ = 0; the pin takes what impulse it must and the base velocity after impact is zero.
With ``root_welded`` the root link is held in rotation as well (a flat foot on heel and ball
when the other foot strikes): one more constraint row e_0^T dpsi+ = 0 and one more impulse,
the ground's angular impulse on the root about H0, appended last to Lambda.

Several points may land at once (a foot's heel and toe slapping down together, two feet):
J stacks their Jacobians (2k, n + 2), Lambda their impulses (2k,), and G (2k, 2k) is solved
by CasADi's symbolic QR instead of Cramer's rule; one point keeps Cramer's rule.

Every step is an SX expression, so the map and its derivatives enter an NLP like any other
expression (``OCP.periodic(step_map)``). Composed with a relabelling of the tree
(:mod:`model.rerooting`, e.g. ``swap_legs``) it is the step-to-step map Delta(x) of a walking
gait: x+ = relabel(psi-, dpsi+).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError

if TYPE_CHECKING:  # built by Dynamics.impact
    from model.points import PointKinematics
    from model.rerooting import Rerooting

#: The numeric map refuses a result that misses the impact equations by more than this,
#: relative to the size of their terms: the solve lost ten of its sixteen digits to a
#: singularity. Measured: 1e-16 to 1e-8 on regular states (parameters over six decades
#: included), 1e-3 to 0.2 or NaN at singular ones (tests/extremes.py).
SINGULAR_RESIDUAL = 1e-6

#: kind -> (input names, output names, description)
IMPACT_FUNCTIONS: dict[str, tuple[tuple[str, ...], tuple[str, ...], str]] = {
    "impact": (
        ("psi", "dpsi"),
        ("dpsi_plus", "impulse", "base_velocity_plus"),
        "post-impact rates (n,) rad/s, ground impulses on the points (2k,) N s (x, y of each "
        "point in turn; a welded root's angular impulse about H0, N m s, last), velocity of "
        "the old contact H0 after impact (2,) m/s",
    ),
}


class ImpactMap:
    """Impact of points of a :class:`model.Dynamics` with the ground (``dyn.impact(point)``,
    ``dyn.impact([heel, toe])``): the k points land together.

    ``function()``: the SX Function ``impact_<point>[_<point>...]``: (psi (n,), dpsi (n,)) ->
    (dpsi_plus (n,), impulse (2k,), base_velocity_plus (2,)); numpy one state or a (K, n)
    batch through ``__call__``; ``step_function(rerooting)``: the composed map x- -> x+ (one
    landing point, the new root).
    """

    def __init__(
        self,
        points: PointKinematics | Sequence[PointKinematics],
        root_pinned: bool = False,
        root_welded: bool = False,
    ) -> None:
        #: The landing points, in the order of the impulses.
        self.points: tuple[PointKinematics, ...] = (
            (points,) if not isinstance(points, Sequence) else tuple(points)
        )
        #: The landing point when there is one (the heel strike of a point foot).
        self.point = self.points[0]
        self._dynamics = self.point.dynamics
        #: True: the root hinge H0 stays pinned through the impact (both contacts hold: a
        #: double support begins); the fixed-base equations M (dpsi+ - dpsi-) = J^T Lambda,
        #: J dpsi+ = 0 apply and the base velocity after impact is zero.
        self.root_pinned = bool(root_pinned) or bool(root_welded)
        #: True: the root link is held in rotation too (a flat foot): the impulse (2k + 1,)
        #: ends with the ground's angular impulse on the root about H0, N m s.
        self.root_welded = bool(root_welded)
        prefix = (
            "impact_welded"
            if self.root_welded
            else ("impact_pinned" if self.root_pinned else "impact")
        )
        self._name = "_".join([prefix, *(p.identifier for p in self.points)])

    @property
    def name(self) -> str:
        """Name of the SX Function."""
        return self._name

    def function(self) -> ca.Function:
        inputs, outputs, _ = IMPACT_FUNCTIONS["impact"]
        symbols = self._dynamics.symbols
        return self._dynamics.cached_function(
            self._name, inputs, [symbols[k] for k in inputs], outputs, self._build
        )

    def _build(self) -> list[ca.SX]:
        dyn = self._dynamics
        dpsi = dyn.symbols["dpsi"]
        jacobian = ca.vertcat(*(p.expression("jacobian", dyn.symbols["psi"]) for p in self.points))
        if self.root_pinned:
            # H0 held: the fixed-base mass matrix and the psi columns of J (no base rows).
            rows = jacobian[:, 2:]
            if self.root_welded:  # the root's rotation held too: dpsi_0+ = 0
                rows = ca.vertcat(rows, ca.DM.eye(dyn.n)[0, :])
            return self._solve(dyn.mass_matrix_expression(), rows, dpsi, 0)
        return self._solve(dyn.floating.mass_matrix_expression(), jacobian, dpsi, 2)

    def _solve(self, mass_matrix, jacobian, dpsi, base: int) -> list[ca.SX]:
        """dq+ = dq- + M^-1 J^T Lambda with J dq+ = 0, dq = (base velocity (``base``,), dpsi),
        the base at rest before; returns (dpsi+, Lambda, base velocity after (2,))."""
        n = dpsi.size1()
        diagonal, upper, order = ca.ldl(mass_matrix, True)
        lever = ca.ldl_solve(jacobian.T, diagonal, upper, order)  # X = M_e^{-1} J^T
        gram = ca.mtimes(jacobian, lever)  # G = J M_e^{-1} J^T, 2k (+1 welded) square, SPD
        # Velocity of the landing points before impact (H0 at rest: the fixed-base rows).
        approach = ca.mtimes(jacobian[:, base:], dpsi)
        if gram.size1() == 2:  # one point: Cramer's rule, the shortest expression
            det = gram[0, 0] * gram[1, 1] - gram[0, 1] * gram[1, 0]
            impulse = ca.vertcat(
                -(gram[1, 1] * approach[0] - gram[0, 1] * approach[1]) / det,
                -(gram[0, 0] * approach[1] - gram[1, 0] * approach[0]) / det,
            )
        else:
            impulse = -ca.solve(gram, approach)
        jump = ca.mtimes(lever, impulse)  # dq+ - dq-
        base_velocity = jump[:2] if base else ca.SX.zeros(2)
        return [dpsi + jump[base : base + n], impulse, base_velocity]

    def __call__(self, psi, dpsi) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(dpsi_plus (n,) rad/s, impulse (2,) N s, base_velocity_plus (2,) m/s) for one state,
        each with a leading K axis for a (K, n) batch.

        Raises DefinitionError naming the state where the impact is singular (the landing
        point's Jacobian loses rank, or the mass matrix is singular: see :meth:`_check`)
        instead of returning what the solve made of it (NaN, inf or wrong numbers)."""
        self.function()
        dyn = self._dynamics
        # Validates the inputs (raising by name); the results are checked below, where a
        # non-finite one means a zero pivot: the map is linear in dpsi and does not overflow.
        results = dyn._evaluate_unchecked(self._name, psi, dpsi)
        self._check(np.asarray(psi, dtype=float), np.asarray(dpsi, dtype=float), *results)
        dpsi_plus, impulse, base = results
        return dpsi_plus, impulse, base

    def _check(self, psi, dpsi, dpsi_plus, impulse, base) -> None:
        """Refuse states where the result does not solve the impact equations
        M (dq+ - dq-) = J^T Lambda and J dq+ = 0 to ``SINGULAR_RESIDUAL`` (each relative to
        the size of its terms), or is NaN or inf: there the range-space solve met a
        singularity.

        Two singularities make it fail: J M^-1 J^T singular (the links from the held contact
        to the landing point line up through it, so the point cannot move along that line and
        the impulse along it is not unique), or M singular (a motion without kinetic energy:
        a floating chain of point masses, aligned; a floating root whose mass sits at its far
        hinge, so that H0 moves carrying nothing).
        Near them the answer loses accuracy as the condition number grows; at them it is NaN,
        inf or wrong."""
        dyn = self._dynamics
        psi2, dpsi2 = np.atleast_2d(psi), np.atleast_2d(dpsi)
        plus, lam, base2 = (np.atleast_2d(a) for a in (dpsi_plus, impulse, base))
        if self.root_pinned:
            mass = dyn.mass_matrix(psi2)
            jacobian = np.concatenate(
                [p.jacobian(psi2, floating=False) for p in self.points], axis=1
            )
            if self.root_welded:  # the row of the root's rotation, held
                held = np.zeros((jacobian.shape[0], 1, jacobian.shape[2]))
                held[:, 0, 0] = 1.0
                jacobian = np.concatenate([jacobian, held], axis=1)
            before, after = dpsi2, plus
        else:
            mass = dyn.floating.mass_matrix(psi2)
            jacobian = np.concatenate([p.jacobian(psi2) for p in self.points], axis=1)
            before = np.hstack([np.zeros_like(base2), dpsi2])
            after = np.hstack([base2, plus])
        with np.errstate(all="ignore"):  # NaN or inf results are refused below
            jump = np.einsum("kij,kj->ki", mass, after - before)
            push = np.einsum("kji,kj->ki", jacobian, lam)
            landing = np.einsum("kij,kj->ki", jacobian, after)
            approach = np.einsum("kij,kj->ki", jacobian, before)
            size_m = np.linalg.norm(mass, axis=(1, 2))
            size_j = np.linalg.norm(jacobian, axis=(1, 2))
            momentum = np.linalg.norm(jump - push, axis=1) / (
                size_m * (np.linalg.norm(after, axis=1) + np.linalg.norm(before, axis=1))
                + size_j * np.linalg.norm(lam, axis=1)
                + 1e-300
            )
            at_rest = np.linalg.norm(landing, axis=1) / (
                size_j * np.linalg.norm(after, axis=1) + np.linalg.norm(approach, axis=1) + 1e-300
            )
        ok = (momentum <= SINGULAR_RESIDUAL) & (at_rest <= SINGULAR_RESIDUAL)
        bad = np.flatnonzero(~ok)
        if not bad.size:
            return
        k = int(bad[0])
        where = f" at state {k}" if np.ndim(psi) > 1 else ""
        condition = float(np.linalg.cond(mass[k]))
        if condition > 1e12:
            cause = (
                f"the mass matrix is singular there (condition number {condition:.1e}): a "
                "motion moves no mass (links without rotational inertia whose masses lie on "
                "one line, or a free root hinge without mass: inertia 0 and com 1); give the "
                "links inertia > 0"
            )
        else:
            cause = (
                "the landing point's Jacobian loses rank there: the links from the held "
                "contact to the point line up through it, the point cannot move along that "
                "line and the impulse along it is not unique; move the configuration off the "
                "singularity"
            )
        if np.all(np.isfinite(after[k])) and np.all(np.isfinite(lam[k])):
            found = (
                f"its result misses the impact equations by {max(momentum[k], at_rest[k]):.1e} "
                f"(relative; {SINGULAR_RESIDUAL:g} allowed)"
            )
        else:
            found = "its result is NaN or inf"
        raise DefinitionError(f"`{self._name}`: the impact is singular{where}: {found}; {cause}")

    def state_function(self, name: str = "strike") -> ca.Function:
        """x- = (psi, dpsi) (2n,) before impact -> x+ = (psi, dpsi+) (2n,) after, in the same
        labels (a double support begins: the legs swap later): an SX Function ``name``, the
        mapping of a phase join (``Phases.then(..., mapping=...)``)."""
        n = self._dynamics.n
        x = ca.SX.sym("x", 2 * n)
        dpsi_plus, _, _ = self.function().call([x[:n], x[n:]])
        return ca.Function(name, [x], [ca.vertcat(x[:n], dpsi_plus)], ["x"], ["x_plus"])

    def held_impulses(self, psi, dpsi) -> tuple:
        """(dpsi+ (n,), the impulses on the landing points (2k,), the impulse on the held root
        H0 (2,)), N s, as CasADi expressions of psi, dpsi (n,), for an impact with the root
        pinned: the root's impulse is what the change of the tree's linear momentum leaves
        after the landing points' (the base rows of the floating-base impact equations).
        Welded, the root's angular impulse about H0 is :meth:`root_angular_impulse`."""
        if not self.root_pinned:
            raise DefinitionError(
                "`held_impulses`: the root is free in this impact (it lifts off and takes no "
                "impulse); build it with Dynamics.impact(point, root_pinned=True)"
            )
        dpsi_plus, impulse, _ = self.function()(psi, dpsi)
        if self.root_welded:  # the angular impulse on the root is not a landing point's
            impulse = impulse[: 2 * len(self.points)]
        momentum = self._dynamics.floating.function("linear_momentum")
        before = ca.vertcat(*momentum(psi, ca.vertcat(0, 0, dpsi)))
        after = ca.vertcat(*momentum(psi, ca.vertcat(0, 0, dpsi_plus)))
        # several points: their impulses (x, y of each in turn) summed
        landing = impulse if len(self.points) == 1 else ca.sum2(ca.reshape(impulse, 2, -1))
        return dpsi_plus, impulse, after - before - landing

    def root_angular_impulse(self, psi, dpsi):
        """The ground's angular impulse on the welded root about H0, N m s (a CasADi
        expression of psi, dpsi (n,)): where the impulse on a flat foot acts, as the root's
        torque M_0 says where its force acts."""
        if not self.root_welded:
            raise DefinitionError(
                "`root_angular_impulse`: the root turns freely in this impact; build it with "
                "Dynamics.impact(point, root_welded=True)"
            )
        return self.function()(psi, dpsi)[1][-1]

    def step_function(self, rerooting: Rerooting) -> ca.Function:
        """Delta: x- = (psi, dpsi) (2n,) before impact -> x+ (2n,) after impact, relabelled by
        ``rerooting`` (which must re-root this model's tree at the impact point, e.g.
        ``model.swap_legs``). For ``OCP.periodic(Delta)``: x(0) = Delta(x(T))."""
        from_tree = getattr(rerooting, "old", None)
        if from_tree is None:
            raise DefinitionTypeError(
                f"`rerooting`: must be a model.Rerooting, got {type(rerooting).__name__}"
            )
        if from_tree != self._dynamics.linkage:
            raise DefinitionError(
                "`rerooting`: it re-roots another tree; re-root this model's linkage"
            )
        if len(self.points) != 1:
            raise DefinitionError(
                f"`rerooting`: a step map re-roots at one landing point; this impact lands "
                f"{len(self.points)} ({', '.join(p.label for p in self.points)})"
            )
        at = rerooting.root_point
        here = self.point.point
        if (at.link, at.along, at.lateral) != (here.link, here.along, here.lateral):
            raise DefinitionError(
                f"`rerooting`: it re-roots at {at.link!r} (along={at.along:g}, "
                f"lateral={at.lateral:g}) but the impact is at {here.link!r} "
                f"(along={here.along:g}, lateral={here.lateral:g}); the new contact must be "
                "the new root"
            )
        n = self._dynamics.n
        x = ca.SX.sym("x", 2 * n)
        dpsi_plus, _, _ = self.function().call([x[:n], x[n:]])
        relabel = rerooting.function()
        psi_new, dpsi_new = relabel.call([x[:n], dpsi_plus])
        return ca.Function(
            f"step_{self._name}", [x], [ca.vertcat(psi_new, dpsi_new)], ["x"], ["x_plus"]
        )

    def __repr__(self) -> str:
        return f"ImpactMap({', '.join(repr(p.label) for p in self.points)})"
