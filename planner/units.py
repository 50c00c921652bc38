"""Units of trajectory channels: the ones the library reads, and their conversion to SI.

The library computes in SI (rad, rad/s, N m, s); a trajectory file says the unit of each
column (``psi_torso [deg]``). :func:`si_unit` reads such a unit: the SI unit of the same
quantity and the factor to it, or None for a unit it does not know. :func:`to_si` converts
every channel of a :class:`planner.trajectory.Trajectory` whose unit it knows, so that a file
written in degrees or kN m means what it says; callers that need a channel in a given SI unit
(``problems.simulate``) refuse the others, naming the column and its unit.

Known units (spaces, ``*``, ``·`` and ``.`` between factors are equivalent; ``²`` is ``^2``):
angles rad, deg (also ``°``, ``degree``), rev; angular rates rad/s, deg/s, rpm, rev/s; angular
accelerations rad/s^2, deg/s^2; torques N m (``Nm``), kN m, mN m, N cm, N mm; forces N, kN,
mN; time s, ms; energy and work J, kJ; lengths m, cm, mm; masses kg, g.
"""

from __future__ import annotations

import math
import re

import numpy as np

from planner.trajectory import Trajectory

_DEGREE = math.pi / 180.0
_TURN = 2.0 * math.pi

#: Unit (normalised by :func:`_normalised`) -> (SI unit, factor: value in SI = value x factor).
KNOWN_UNITS: dict[str, tuple[str, float]] = {
    # angles
    "rad": ("rad", 1.0),
    "deg": ("rad", _DEGREE),
    "degree": ("rad", _DEGREE),
    "degrees": ("rad", _DEGREE),
    "°": ("rad", _DEGREE),
    "rev": ("rad", _TURN),
    # angular rates
    "rad/s": ("rad/s", 1.0),
    "deg/s": ("rad/s", _DEGREE),
    "°/s": ("rad/s", _DEGREE),
    "rpm": ("rad/s", _TURN / 60.0),
    "rev/s": ("rad/s", _TURN),
    # angular accelerations
    "rad/s^2": ("rad/s^2", 1.0),
    "deg/s^2": ("rad/s^2", _DEGREE),
    "°/s^2": ("rad/s^2", _DEGREE),
    # torques
    "N m": ("N m", 1.0),
    "Nm": ("N m", 1.0),
    "kN m": ("N m", 1e3),
    "kNm": ("N m", 1e3),
    "mN m": ("N m", 1e-3),
    "mNm": ("N m", 1e-3),
    "N cm": ("N m", 1e-2),
    "Ncm": ("N m", 1e-2),
    "N mm": ("N m", 1e-3),
    "Nmm": ("N m", 1e-3),
    # forces
    "N": ("N", 1.0),
    "kN": ("N", 1e3),
    "mN": ("N", 1e-3),
    # time
    "s": ("s", 1.0),
    "ms": ("s", 1e-3),
    # energy, work
    "J": ("J", 1.0),
    "kJ": ("J", 1e3),
    # lengths, masses
    "m": ("m", 1.0),
    "cm": ("m", 1e-2),
    "mm": ("m", 1e-3),
    "kg": ("kg", 1.0),
    "g": ("kg", 1e-3),
}

#: What each SI unit measures, for messages.
QUANTITIES = {
    "rad": "an angle",
    "rad/s": "an angular rate",
    "rad/s^2": "an angular acceleration",
    "N m": "a torque",
    "N": "a force",
    "s": "a time",
    "J": "an energy",
    "m": "a length",
    "kg": "a mass",
}


def _normalised(unit: str) -> str:
    text = unit.strip().replace("²", "^2").replace("**", "^")
    text = re.sub(r"\s*[*·⋅]\s*|(?<=[A-Za-z])\.(?=[A-Za-z])", " ", text)
    return re.sub(r"\s+", " ", text)


def si_unit(unit: str) -> tuple[str, float] | None:
    """(SI unit, factor) of a unit the library knows (value in SI = value x factor), else
    None. ``si_unit("kN m") == ("N m", 1000.0)``."""
    return KNOWN_UNITS.get(_normalised(unit))


def accepted(si: str) -> str:
    """The units accepted for a quantity in ``si``, for messages: "rad, deg, rev"."""
    names = [u for u, (s, _) in KNOWN_UNITS.items() if s == si and u not in ("degree", "degrees")]
    return ", ".join(names)


def to_si(trajectory: Trajectory) -> Trajectory:
    """The trajectory with every channel in a known non-SI unit converted to SI (degrees to
    rad, kN m to N m, ...); channels in SI or in units the library does not know are kept as
    they are. The same object when nothing changes."""
    changed = False

    def convert(values, unit):
        nonlocal changed
        known = si_unit(unit)
        if known is None or (known[1] == 1.0 and known[0] == unit):
            return values, unit
        changed = True
        return values * known[1], known[0]

    states, state_units = [], []
    for j, unit in enumerate(trajectory.state_units):
        values, unit = convert(trajectory.states[:, j], unit)
        states.append(values)
        state_units.append(unit)
    controls, control_units = [], []
    for j, unit in enumerate(trajectory.control_units):
        values, unit = convert(trajectory.controls[:, j], unit)
        controls.append(values)
        control_units.append(unit)
    extras = {name: convert(values, unit) for name, (values, unit) in trajectory.extras.items()}
    if not changed:
        return trajectory
    conversions = {
        name: f"{unit} -> {si_unit(unit)[0]}"
        for name, unit, _ in trajectory.columns
        if si_unit(unit) is not None and si_unit(unit) != (unit, 1.0)
    }
    K = trajectory.n_samples
    return type(trajectory)(
        time=trajectory.time,
        states=_stack(states, K),
        controls=_stack(controls, K),
        state_names=trajectory.state_names,
        state_units=tuple(state_units),
        control_names=trajectory.control_names,
        control_units=tuple(control_units),
        extras=extras,
        metadata={**trajectory.metadata, "converted_to_si": conversions},
    )


def _stack(columns, K: int) -> np.ndarray:
    return np.stack(columns, axis=1) if columns else np.zeros((K, 0))


__all__ = ["KNOWN_UNITS", "QUANTITIES", "accepted", "si_unit", "to_si"]
