"""The linkage adapter: a ``model.Dynamics`` as a planner :class:`planner.system.System`.

:func:`linkage_system` builds the System (x = [psi; dpsi], u = M (and F), z = ddpsi when
implicit; names from :mod:`model.linkage_naming`) with the roles the planner reads: the
residual rows named by link, a guess function's tuple read as (psi, dpsi[, ddpsi[, M]]),
torques that no guess gives completed by inverse dynamics, ``drives`` = M and
``accelerations`` = ddpsi, the model's parameters for metadata, and
:class:`model.linkage_trajectory.LinkageTrajectory` as the type of its trajectories.
``Dynamics.as_system`` calls it, which is how ``planner.OCP`` takes a Dynamics without
importing the model: the adapter lives on the model's side of the one-way imports
(planner <- model <- problems).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import casadi as ca
import numpy as np

from model.contact import Contact
from model.linkage_naming import (
    ACCELERATION_UNIT,
    ACCELERATIONS,
    ANGLE_UNIT,
    ANGLES,
    FORCE_UNIT,
    FORCES,
    RATE_UNIT,
    RATES,
    TORQUE_UNIT,
    TORQUES,
    acceleration_names,
    angle_names,
    force_names,
    rate_names,
    torque_names,
)
from model.linkage_trajectory import LinkageTrajectory
from planner.system import DerivedField, System


def linkage_system(dynamics, formulation: str = "implicit", contacts: Sequence = ()) -> System:
    """The linkage system of ``dynamics`` (a ``model.Dynamics``): x = [psi; dpsi], u = M (and
    F), z = ddpsi (implicit only).

    ``contacts``: contacts (``model.Contact``) or points of the linkage (``model.LinkPoint``,
    link names for their end hinges) held by the ground, whose
    ground forces (Fx, Fy), N, are more controls (``F_<point>_x``, ``F_<point>_y``; group
    ``F``): the equations of motion are those of the tree with these forces applied (their
    hinge moments, ``PointKinematics.hinge_moments``), so a closed chain (a double support)
    is the tree plus a constraint holding the point and these forces.
    """
    n = dynamics.n
    links = dynamics.names
    states = (*angle_names(links), *rate_names(links))
    torques = torque_names(links)
    points = [dynamics.point(c) for c in contacts]
    # A contact's forces carry its name (its point's label when it has none).
    forces = force_names(
        [
            c.identifier if isinstance(c, Contact) else p.identifier
            for c, p in zip(contacts, points, strict=True)
        ]
    )
    controls = (*torques, *forces)
    x = ca.SX.sym("x", 2 * n)
    u = ca.SX.sym("u", len(controls))
    t = ca.SX.sym("t")
    # The hinge torques the contact forces stand for, added to the drives' (N m).
    applied = u[:n]
    for j, p in enumerate(points):
        moments = p.function("hinge_moments")
        applied = applied + moments(x[:n], u[n + 2 * j : n + 2 * j + 2])
    ode = dynamics.function("ode")
    ode_t = ca.Function("ode", [x, u, t], [ode(x, applied)], ["x", "u", "t"], ["xdot"])
    accelerations = acceleration_names(links)
    derived: tuple[DerivedField, ...] = ()
    if formulation == "implicit":
        z = ca.SX.sym("z", n)
        residual_f = dynamics.function("dynamics_residual")
        rate = ca.vertcat(x[n:], z)
        residual = ca.Function(
            "residual",
            [x, z, u, t],
            [residual_f(x[:n], x[n:], z, applied)],
            ["x", "z", "u", "t"],
            ["residual"],
        )
        aux = accelerations
    else:
        z = ca.SX.sym("z", 0)
        rate = ode(x, applied)
        residual = None
        aux = ()
        # Explicit: ddpsi is no variable; the Point offers the forward dynamics instead, so
        # that one constraint (a ground reaction, a foot acceleration) reads the same in both
        # formulations.
        forward = ca.Function(
            ACCELERATIONS, [x, z, u, t], [rate[n:]], ["x", "z", "u", "t"], [ACCELERATIONS]
        )
        derived = (DerivedField(ACCELERATIONS, accelerations, (ACCELERATION_UNIT,) * n, forward),)
    rate_f = ca.Function("rate", [x, z, u, t], [rate], ["x", "z", "u", "t"], ["xdot"])
    groups = (
        (ANGLES, states[:n]),
        (RATES, states[n:]),
        (TORQUES, torques),
        ("x", states),
        ("u", controls),
    )
    if forces:
        groups = (*groups, (FORCES, forces))
    if aux:
        groups = (*groups, (ACCELERATIONS, aux), ("z", aux))

    # The drives a motion needs: the residual is affine in the applied torques (inverse
    # dynamics less the applied torques), so M = ID(psi, dpsi, a) - the contact forces' moments.
    a = ca.SX.sym("a", n)
    exerted = ca.SX.zeros(n)
    for j, p in enumerate(points):
        exerted = exerted + p.function("hinge_moments")(x[:n], u[n + 2 * j : n + 2 * j + 2])
    inverse = dynamics.function("inverse_dynamics")
    drives_for_motion = ca.Function(
        "drives_for_motion",
        [x, a, u],
        [inverse(x[:n], x[n:], a) - exerted],
        ["x", "a", "u"],
        [TORQUES],
    )

    def inverse_dynamics(values: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Torques that make the guessed motion dynamically consistent: inverse dynamics of
        the guessed psi, dpsi, ddpsi (when the guesses give all three), so that a gait law
        starts the solver on a consistent point."""
        wanted = (*states, *accelerations)
        if not all(name in values for name in wanted):
            return {}
        psi, dpsi, ddpsi = (
            np.column_stack([values[name] for name in names])
            for names in (states[:n], states[n:], accelerations)
        )
        M = np.atleast_2d(dynamics.inverse_dynamics(psi, dpsi, ddpsi))
        return {name: M[:, i] for i, name in enumerate(torques)}

    return System(
        rate=rate_f,
        residual=residual,
        ode=ode_t,
        state_names=states,
        state_units=(ANGLE_UNIT,) * n + (RATE_UNIT,) * n,
        control_names=controls,
        control_units=(TORQUE_UNIT,) * n + (FORCE_UNIT,) * len(forces),
        aux_names=aux,
        aux_units=(ACCELERATION_UNIT,) * len(aux),
        groups=groups,
        residual_scale_group=TORQUES,
        formulation=formulation,
        derived=derived,
        control_rate_names=tuple(f"d{c}" for c in controls),
        control_rate_groups=((f"d{TORQUES}", n), "du"),
        residual_names=tuple(links) if aux else (),
        guess_order=(ANGLES, RATES, ACCELERATIONS, TORQUES),
        complete_guess=inverse_dynamics,
        drives=TORQUES,
        accelerations=ACCELERATIONS,
        model=dynamics.linkage.parameters(),
        positions=ANGLES,
        velocities=RATES,
        drives_for_motion=drives_for_motion,
        nominal=_nominal(dynamics.linkage, torques, forces),
        trajectory_type=LinkageTrajectory,
    )


def _nominal(linkage, torques, forces) -> dict[str, float]:
    """Natural magnitudes from the linkage (``System.nominal``), in whatever units it is
    given: torques NOMINAL_TORQUE times its weight W times its mean link length l, contact
    forces W. (Angles, rates and accelerations do not change with the units of length and
    mass: their default scale 1 rad, rad/s, rad/s^2 stays.) Without gravity, W is the mass
    times 9.81 l / s^2."""
    length = float(np.mean([link.length for link in linkage.links]))
    gravity = linkage.gravity if linkage.gravity > 0 else 9.81 * length
    weight = float(sum(link.mass for link in linkage.links)) * gravity
    return {
        **dict.fromkeys(torques, NOMINAL_TORQUE * weight * length),
        **dict.fromkeys(forces, weight),
    }


#: The torque scale of a linkage without torque bounds, as a fraction of its weight times
#: its mean link length: 27 N m for the six-link anthropoid (whose gaits' torques are tens of
#: N m), 1 N m for the 2-link chain of 1 kg, 0.5 m links. The full W l (268 N m) left the
#: benchmark gait of examples/benchmarks/planner_bench.py at Solved_To_Acceptable_Level
#: (its dynamics rows, scaled by the torque scale, too small for tol 1e-8).
NOMINAL_TORQUE = 0.1


__all__ = ["NOMINAL_TORQUE", "linkage_system"]
