"""The linkage adapter: a ``model.Dynamics`` as a planner :class:`~planner.system.System`, and
the linkage naming convention, which lives here and nowhere else in ``planner``.

The convention (every file, trajectory and OCP of a linkage uses it; link names are
``model.Linkage.names``):

    states    psi_<link> [rad] for every link, then dpsi_<link> [rad/s]   (groups psi, dpsi)
    controls  M_<link> [N m], the hinge torques (group M), then the ground forces of held
              points F_<point>_x, F_<point>_y [N] (group F)
    auxiliary ddpsi_<link> [rad/s^2] in the implicit formulation (group ddpsi; explicit, the
              Point field ddpsi is the forward dynamics)
    extras    ddpsi_<link> [rad/s^2], Fx, Fy [N] (ground reaction at H0) in a trajectory

:func:`linkage_system` builds the System (x = [psi; dpsi], u = M (and F), z = ddpsi when
implicit) with the roles the planner reads: the residual rows named by link, a guess
function's tuple read as (psi, dpsi[, ddpsi[, M]]), torques that no guess gives completed by
inverse dynamics, ``drives`` = M and ``accelerations`` = ddpsi, and the model's parameters
for metadata. The name functions below serve the trajectory's linkage views
(:mod:`planner.trajectory.linkage`), its file reader and the plots.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import casadi as ca
import numpy as np

from model.dynamics import Dynamics
from planner.system import DerivedField, System

#: Group names of the convention, in the order of the variables.
ANGLES, RATES, ACCELERATIONS, TORQUES, FORCES = "psi", "dpsi", "ddpsi", "M", "F"
#: Units of the convention's channels.
ANGLE_UNIT, RATE_UNIT, ACCELERATION_UNIT, TORQUE_UNIT, FORCE_UNIT = (
    "rad",
    "rad/s",
    "rad/s^2",
    "N m",
    "N",
)
#: Extras of the ground reaction at H0 in trajectories written before contact-named columns
#: (read back as the ground reaction, N).
GROUND_REACTION = ("Fx", "Fy")
#: The convention in words, for messages.
CONVENTION = f"states {ANGLES}_<link> [{ANGLE_UNIT}] then {RATES}_<link> [{RATE_UNIT}]"


def _named(group: str, links: Sequence[str]) -> tuple[str, ...]:
    return tuple(f"{group}_{link}" for link in links)


def angle_names(links: Sequence[str]) -> tuple[str, ...]:
    """psi_<link> for every link."""
    return _named(ANGLES, links)


def rate_names(links: Sequence[str]) -> tuple[str, ...]:
    """dpsi_<link> for every link."""
    return _named(RATES, links)


def acceleration_names(links: Sequence[str]) -> tuple[str, ...]:
    """ddpsi_<link> for every link."""
    return _named(ACCELERATIONS, links)


def torque_names(links: Sequence[str]) -> tuple[str, ...]:
    """M_<link> for every link."""
    return _named(TORQUES, links)


def force_names(points: Sequence[str]) -> tuple[str, ...]:
    """F_<point>_x, F_<point>_y for every held point (by its identifier)."""
    return tuple(f"{FORCES}_{point}_{axis}" for point in points for axis in ("x", "y"))


def links_of(state_names: Sequence[str], state_units: Sequence[str]) -> tuple[str, ...] | None:
    """The links of states that follow the convention (psi_<link> [rad] for every link, then
    dpsi_<link> [rad/s] in the same order), or None."""
    names = tuple(state_names)
    if not names or len(names) % 2:
        return None
    n = len(names) // 2
    prefix = f"{ANGLES}_"
    if not all(name.startswith(prefix) for name in names[:n]):
        return None
    links = tuple(name[len(prefix) :] for name in names[:n])
    if names[n:] != rate_names(links):
        return None
    if tuple(state_units) != (ANGLE_UNIT,) * n + (RATE_UNIT,) * n:
        return None
    return links


def contact_force_names(contact: str) -> tuple[str, str]:
    """The extras of a contact's ground force, N: ``F_<contact>_x``, ``F_<contact>_y`` (the
    contact named after its point: ``swing_shank_end``; the root's start hinge H0, pinned
    to the ground, is ``<root>_start``)."""
    return f"F_{contact}_x", f"F_{contact}_y"


def root_contact(links: Sequence[str]) -> str:
    """The name of the contact at H0, the start of the root link: ``<root>_start``."""
    return f"{links[0]}_start"


def link_of(name: str) -> str | None:
    """The link of a channel psi_<link>, dpsi_<link> or M_<link>, else None."""
    for group in (ANGLES, RATES, TORQUES):
        if name.startswith(f"{group}_"):
            return name[len(group) + 1 :]
    return None


def infer_group(name: str) -> str:
    """The trajectory group of a column of a file made by hand (no groups line): torques
    M_<link> are controls, accelerations ddpsi_<link> and the ground reaction extras, the
    rest states."""
    if name.startswith(f"{TORQUES}_"):
        return "control"
    if name.startswith((f"{ACCELERATIONS}_", "F_", "CoP_")) or name in GROUND_REACTION:
        return "extra"
    return "state"


def linkage_system(
    dynamics: Dynamics, formulation: str = "implicit", contacts: Sequence = ()
) -> System:
    """The linkage system: x = [psi; dpsi], u = M (and F), z = ddpsi (implicit only).

    ``contacts``: points of the linkage (``model.LinkPoint``) held by the ground, whose
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
    forces = force_names([p.identifier for p in points])
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


__all__ = [
    "ACCELERATIONS",
    "ACCELERATION_UNIT",
    "ANGLES",
    "ANGLE_UNIT",
    "CONVENTION",
    "FORCES",
    "FORCE_UNIT",
    "GROUND_REACTION",
    "RATES",
    "RATE_UNIT",
    "TORQUES",
    "TORQUE_UNIT",
    "acceleration_names",
    "angle_names",
    "contact_force_names",
    "force_names",
    "infer_group",
    "link_of",
    "linkage_system",
    "links_of",
    "rate_names",
    "root_contact",
    "torque_names",
]
