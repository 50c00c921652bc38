"""Geared motors' rotors in a linkage's equations of motion (the reflected inertia).

A motor's housing (stator) sits on one link, its gear's output turns another; the rotor (and
the gear's input stage, whose inertia a datasheet gives at the input) spins relative to the
stator N times as fast as the driven link does. The model's angles are absolute, so the rotor's
absolute rate is

    omega_r = dpsi_stator + N (dpsi_driven - dpsi_stator) = b . dpsi,
    b = N e_driven + (1 - N) e_stator        (e_k: the k-th unit vector; the ground's is 0),

and its kinetic energy 1/2 J (b . dpsi)^2 adds the constant matrix J b b^T to the mass matrix:
J N^2 on the driven link's diagonal, J (1 - N)^2 on the stator's, J N (1 - N) between them. No
velocity term: b is constant. The rotor's centre stays on the stator's axis of the joint, so
its mass is the stator link's (``problems.drives`` adds a motor's mass to its link); it adds
no force, only this inertia. A hinge torque then is the drive's whole torque, N times the
motor's (with an ideal gear): what accelerates the rotor included.

Sign: the rotor turns the way the driven link turns relative to the stator (N > 0); a gear
train that reverses the direction is N < 0 (only the cross term J N (1 - N) notices).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from planner.errors import DefinitionError, DefinitionTypeError, check_real


@dataclass(frozen=True)
class Rotor:
    """One geared motor's spinning part (see the module).

    Parameters
    ----------
    stator : name of the link carrying the motor's housing, or None for the ground.
    driven : name of the link the gear's output turns, or None for the ground (a motor on a
        shank driving a point foot held by the ground).
    ratio : N, rotor turns per turn of the driven link relative to the stator (!= 0; < 0 for
        a gear train that reverses).
    inertia : J, the rotor's and the gear input's moment of inertia about the motor's axis,
        kg m^2 (>= 0).
    name : what the rotor drives (a label for messages and files).
    """

    stator: str | None
    driven: str | None
    ratio: float
    inertia: float
    name: str = ""

    def __post_init__(self) -> None:
        where = f"Rotor {self.name!r}" if self.name else "Rotor"
        for field_name in ("stator", "driven"):
            value = getattr(self, field_name)
            if value is not None and not isinstance(value, str):
                raise DefinitionTypeError(
                    f"`{where}.{field_name}`: must be a link name (str) or None for the ground, "
                    f"got {value!r}"
                )
        if self.stator == self.driven:
            raise DefinitionError(
                f"`{where}`: the stator and the driven link are both {self.stator!r}; a rotor "
                "turns one link relative to another"
            )
        ratio = check_real(f"{where}.ratio", self.ratio)
        if ratio == 0.0:
            raise DefinitionError(f"`{where}.ratio`: must be != 0 (N, rotor turns per turn)")
        inertia = check_real(f"{where}.inertia", self.inertia)
        if inertia < 0.0:
            raise DefinitionError(f"`{where}.inertia`: must be >= 0 kg m^2, got {inertia!r}")
        object.__setattr__(self, "ratio", ratio)
        object.__setattr__(self, "inertia", inertia)

    def rate_vector(self, names: Sequence[str]) -> np.ndarray:
        """b (n,): omega_r = b . dpsi for the links ``names`` (a linkage's order)."""
        b = np.zeros(len(names))
        for link, weight in ((self.driven, self.ratio), (self.stator, 1.0 - self.ratio)):
            if link is None:
                continue
            if link not in names:
                raise DefinitionError(
                    f"`Rotor {self.name!r}`: no link {link!r} in the linkage (links: "
                    f"{', '.join(names)})"
                )
            b[list(names).index(link)] += weight
        return b

    def to_dict(self) -> dict:
        return {"name": self.name, "stator": self.stator, "driven": self.driven,
                "ratio": self.ratio, "inertia": self.inertia}  # fmt: skip


def rotor_matrix(rotors: Sequence[Rotor], names: Sequence[str]) -> np.ndarray:
    """sum over the rotors of J b b^T (n, n), kg m^2: what they add to the mass matrix."""
    if not isinstance(rotors, Sequence) or not all(isinstance(r, Rotor) for r in rotors):
        raise DefinitionTypeError("`rotors`: must be a sequence of model.Rotor")
    matrix = np.zeros((len(names), len(names)))
    for rotor in rotors:
        b = rotor.rate_vector(names)
        matrix += rotor.inertia * np.outer(b, b)
    if not np.all(np.isfinite(matrix)):
        sizes = ", ".join(f"{r.inertia:g} kg m^2 x {r.ratio:g}^2" for r in rotors)
        raise DefinitionError(f"`rotors`: J N^2 overflows ({sizes}); give the inertia in kg m^2")
    return matrix


def ground_moment_row(rotors: Sequence[Rotor], names: Sequence[str]) -> np.ndarray:
    """c (n,): the moment the ground takes at the root's hinge is M_root + c . ddpsi, N m.

    The root's hinge torque of a model with rotors is a generalised force: it holds each rotor's
    inertial torque J (b . ddpsi) weighted by b's entries over the links (N for a rotor turning
    the root from the ground, 1 - N for one on the root turning the ground, as a motor on a
    stance shank turns a foot held flat). What passes between the body and the ground, the
    moment whose centre of pressure a sole must hold, counts each rotor once if it rides on the
    body (its stator a link) and not at all if it sits on the ground: Euler's law for the whole
    body. c = sum J b ([stator is a link] - sum of b), zero for rotors between two links."""
    row = np.zeros(len(names))
    for rotor in rotors:
        b = rotor.rate_vector(names)
        row += rotor.inertia * b * ((rotor.stator is not None) - b.sum())
    return row


def rotor_settings(rotors: Sequence[Rotor]) -> dict:
    """``{"rotors": [Rotor.to_dict(), ...]}`` for a plan's settings, ``{}`` without rotors
    (an ideal-torque plan's settings stay as they were)."""
    return {"rotors": [r.to_dict() for r in rotors]} if rotors else {}


__all__ = ["Rotor", "ground_moment_row", "rotor_matrix", "rotor_settings"]
