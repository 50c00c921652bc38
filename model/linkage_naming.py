"""The linkage naming convention: how a linkage's variables and channels are named.

Every file, trajectory and OCP of a linkage uses it (link names are ``model.Linkage.names``):

    states    psi_<link> [rad] for every link, then dpsi_<link> [rad/s]   (groups psi, dpsi)
    controls  M_<link> [N m], the hinge torques (group M), then the ground forces of held
              points F_<point>_x, F_<point>_y [N] (group F)
    auxiliary ddpsi_<link> [rad/s^2] in the implicit formulation (group ddpsi; explicit, the
              Point field ddpsi is the forward dynamics)
    extras    ddpsi_<link> [rad/s^2], and the ground forces of contacts F_<contact>_x, _y [N]
              (F_<root>_start_x, _y: the ground reaction at H0; a named ``model.Contact``
              gives its name, an unnamed one its point's label) and the centre of pressure
              CoP_<contact>_x [m] in a trajectory

The planner never spells these names (``tests/test_architecture.py`` checks): it reads a
linkage through the System the adapter :mod:`model.linkage_system` builds, and a trajectory's
linkage views are :class:`model.linkage_trajectory.LinkageTrajectory`'s.
"""

from __future__ import annotations

from collections.abc import Sequence

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
#: The prefix of a contact's centre of pressure extra (m along x from the contact).
CENTRE_OF_PRESSURE = "CoP"
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
    return tuple(name for point in points for name in contact_force_names(point))


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
    return f"{FORCES}_{contact}_x", f"{FORCES}_{contact}_y"


def centre_of_pressure_name(contact: str) -> str:
    """The extra of a contact's centre of pressure, m along x: ``CoP_<contact>_x``."""
    return f"{CENTRE_OF_PRESSURE}_{contact}_x"


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
    extras = (f"{ACCELERATIONS}_", f"{FORCES}_", f"{CENTRE_OF_PRESSURE}_")
    if name.startswith(extras) or name in GROUND_REACTION:
        return "extra"
    return "state"


__all__ = [
    "ACCELERATIONS",
    "ACCELERATION_UNIT",
    "ANGLES",
    "ANGLE_UNIT",
    "CENTRE_OF_PRESSURE",
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
    "centre_of_pressure_name",
    "contact_force_names",
    "force_names",
    "infer_group",
    "link_of",
    "links_of",
    "rate_names",
    "root_contact",
    "torque_names",
]
