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

Every step is an SX expression, so the map and its derivatives enter an NLP like any other
expression (``OCP.periodic(step_map)``). Composed with a relabelling of the tree
(:mod:`model.rerooting`, e.g. ``swap_legs``) it is the step-to-step map Delta(x) of a walking
gait: x+ = relabel(psi-, dpsi+).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from model.errors import DefinitionError, DefinitionTypeError

if TYPE_CHECKING:  # built by Dynamics.impact
    from model.points import PointKinematics
    from model.rerooting import Rerooting

#: kind -> (input names, output names, description)
IMPACT_FUNCTIONS: dict[str, tuple[tuple[str, ...], tuple[str, ...], str]] = {
    "impact": (
        ("psi", "dpsi"),
        ("dpsi_plus", "impulse", "base_velocity_plus"),
        "post-impact rates (n,) rad/s, ground impulse on the point (2,) N s, velocity of the "
        "old contact H0 after impact (2,) m/s",
    ),
}


class ImpactMap:
    """Impact of a point of a :class:`model.Dynamics` with the ground (``dyn.impact(point)``).

    ``function()``: the SX Function ``impact_<point>``: (psi (n,), dpsi (n,)) ->
    (dpsi_plus (n,), impulse (2,), base_velocity_plus (2,)); numpy one state or a (K, n)
    batch through ``__call__``; ``step_function(rerooting)``: the composed map x- -> x+.
    """

    def __init__(self, point: PointKinematics, root_pinned: bool = False) -> None:
        self.point = point
        self._dynamics = point.dynamics
        #: True: the root hinge H0 stays pinned through the impact (both contacts hold: a
        #: double support begins); the fixed-base equations M (dpsi+ - dpsi-) = J^T Lambda,
        #: J dpsi+ = 0 apply and the base velocity after impact is zero.
        self.root_pinned = bool(root_pinned)
        prefix = "impact_pinned" if self.root_pinned else "impact"
        self._name = f"{prefix}_{point.identifier}"

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
        jacobian = self.point.expression("jacobian", dyn.symbols["psi"])
        if self.root_pinned:
            # H0 held: the fixed-base mass matrix and the psi columns of J (no base rows).
            return self._solve(dyn.mass_matrix_expression(), jacobian[:, 2:], dpsi, 0)
        return self._solve(dyn.floating.mass_matrix_expression(), jacobian, dpsi, 2)

    def _solve(self, mass_matrix, jacobian, dpsi, base: int) -> list[ca.SX]:
        """dq+ = dq- + M^-1 J^T Lambda with J dq+ = 0, dq = (base velocity (``base``,), dpsi),
        the base at rest before; returns (dpsi+, Lambda, base velocity after (2,))."""
        n = dpsi.size1()
        diagonal, upper, order = ca.ldl(mass_matrix, True)
        lever = ca.ldl_solve(jacobian.T, diagonal, upper, order)  # X = M_e^{-1} J^T
        gram = ca.mtimes(jacobian, lever)  # G = J M_e^{-1} J^T, 2 x 2 SPD
        # Velocity of the landing point before impact (H0 at rest: the fixed-base rows).
        approach = ca.mtimes(jacobian[:, base:], dpsi)
        det = gram[0, 0] * gram[1, 1] - gram[0, 1] * gram[1, 0]
        impulse = ca.vertcat(
            -(gram[1, 1] * approach[0] - gram[0, 1] * approach[1]) / det,
            -(gram[0, 0] * approach[1] - gram[1, 0] * approach[0]) / det,
        )
        jump = ca.mtimes(lever, impulse)  # dq+ - dq-
        base_velocity = jump[:2] if base else ca.SX.zeros(2)
        return [dpsi + jump[base : base + n], impulse, base_velocity]

    def __call__(self, psi, dpsi) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(dpsi_plus (n,) rad/s, impulse (2,) N s, base_velocity_plus (2,) m/s) for one state,
        each with a leading K axis for a (K, n) batch."""
        self.function()
        dpsi_plus, impulse, base = self._dynamics.evaluate(self._name, psi, dpsi)
        return dpsi_plus, impulse, base

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
        return f"ImpactMap({self.point.label!r})"
