"""The model's pose and hinge torques in the biomechanist's terms: joint angles and internal
joint moments of one leg (the one conversion every comparison goes through).

The model (``../DESIGN``): absolute link angles psi from +x counter-clockwise, a tree rooted
at the stance foot, the stance leg's links pointing up from the foot (psi ~ pi/2), the swing
leg's down from the hip (psi ~ -pi/2), the trunk up from the hip; the hinge torque M_i acts on
link i from its parent, walking to +x. The biomechanist (:mod:`problems.human.recording`): 0
standing upright, per leg

* thigh flexion = the hip -> knee line from straight down, the knee ahead positive:
  psi_thigh - pi/2 (stance: the link runs knee -> hip), psi_thigh + pi/2 (swing);
* knee flexion = thigh - shank (the shank's inclination alike): psi_thigh - psi_shank on
  either leg;
* hip flexion = thigh flexion + the trunk's forward lean (pi/2 - psi_trunk);
* ankle dorsiflexion = 0 with the shank perpendicular to the heel-ball line, toes up
  positive: -(psi_shank - psi_foot - neutral) with the footed step's neutral angles; a point
  foot stands flat on the ground in stance (pi/2 - psi_shank) and has no ankle in swing
  (NaN);

and the internal moments, extensor (plantarflexor) positive, per kg of body mass: the torque
a hinge applies grows the angle of its link against its parent, so

* stance ankle: +M_shank (on the shank from the foot, or from the ground for a point foot);
  swing ankle: -M_foot;
* stance knee: -M_thigh; swing knee: +M_shank;
* hips: the physical drives sit between the trunk and each thigh, while the tree's hinges are
  trunk-stance thigh and stance thigh-swing thigh. The drive on the swing thigh from the
  trunk is M_swing_thigh; the one on the trunk from the stance thigh carries the torques of
  every link hinged on the stance thigh (M_trunk + M_swing_thigh). Stance hip extensor:
  +(M_trunk + M_swing_thigh); swing hip: -M_swing_thigh.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from model.linkage import Linkage
from planner.errors import DefinitionError
from problems.gait.biped import Biped

HALF_PI = 0.5 * math.pi


@dataclass(frozen=True)
class Leg:
    """The links of one leg: ``thigh``, ``shank``, ``foot`` (None: a point foot), and
    whether it is the stance leg (the tree's root side) of the step."""

    thigh: str
    shank: str
    foot: str | None
    stance: bool


@dataclass(frozen=True)
class Body:
    """A walker's legs and trunk in the model's tree (:func:`body_of`).

    ``stance``, ``swing``: :class:`Leg`; ``trunk``: the link above the hip whose lean the
    hip angle counts; ``hip_links``: every link hinged on the stance thigh but itself (the
    trunk and the swing thigh); ``neutral_ankles``: (stance, swing) psi_shank - psi_foot with
    the shank perpendicular to the sole, rad (feet only)."""

    stance: Leg
    swing: Leg
    trunk: str
    hip_links: tuple[str, ...]
    neutral_ankles: tuple[float, float] | None = None


def body_of(linkage: Linkage, neutral_ankles: Sequence[float] | None = None) -> Body:
    """The :class:`Body` of a biped linkage whose legs are (shank, thigh) or (foot, shank,
    thigh) (:class:`problems.gait.biped.Biped`); ``neutral_ankles`` as a footed step's
    settings give them (required with feet)."""
    biped = Biped.of(linkage)
    stance, swing = biped.stance_leg, biped.swing_leg  # foot -> hip, hip -> foot
    if len(stance) not in (2, 3):
        raise DefinitionError(
            f"`linkage`: a leg of two links (shank, thigh) or three (foot, shank, thigh) has "
            f"joints to compare; this biped's legs have {len(stance)} ({', '.join(stance)})"
        )
    feet = len(stance) == 3
    if feet and (neutral_ankles is None or len(neutral_ankles) != 2):
        raise DefinitionError(
            "`neutral_ankles`: a walker on feet needs (stance, swing) psi_shank - psi_foot at "
            f"the neutral ankle, rad (a footed step's settings hold them), got {neutral_ankles!r}"
        )
    thigh = linkage.index(stance[-1])
    hip_links = tuple(linkage.names[c] for c in linkage.children[thigh])
    trunks = [name for name in hip_links if name != swing[0]]
    if len(trunks) != 1:
        raise DefinitionError(
            f"`linkage`: one trunk link hinged at the hip to measure the hip angle from, got "
            f"{trunks}"
        )
    return Body(
        stance=Leg(stance[-1], stance[-2], stance[0] if feet else None, stance=True),
        swing=Leg(swing[0], swing[1], swing[2] if feet else None, stance=False),
        trunk=trunks[0],
        hip_links=hip_links,
        neutral_ankles=None if not feet else (float(neutral_ankles[0]), float(neutral_ankles[1])),
    )


def wrapped(angle: np.ndarray) -> np.ndarray:
    """Into (-pi, pi]."""
    return np.pi - np.mod(np.pi - angle, 2 * np.pi)


def joint_radians(body: Body, leg: Leg, psi: Mapping[str, Any]) -> dict[str, Any]:
    """``thigh``, ``hip``, ``knee``, ``ankle`` of ``leg`` in rad from the link angles ``psi``
    {link: value}, unwrapped (see the module): arithmetic only, so the values may be numpy
    arrays or CasADi expressions (the tracking objective); a point foot's swing ankle is
    None."""
    thigh = psi[leg.thigh] + (-HALF_PI if leg.stance else HALF_PI)
    lean = HALF_PI - psi[body.trunk]
    if leg.foot is not None:
        neutral = body.neutral_ankles[0 if leg.stance else 1]
        ankle = -(psi[leg.shank] - psi[leg.foot] - neutral)
    else:
        ankle = HALF_PI - psi[leg.shank] if leg.stance else None
    return {
        "thigh": thigh,
        "hip": thigh + lean,
        "knee": psi[leg.thigh] - psi[leg.shank],
        "ankle": ankle,
    }


def leg_angles(body: Body, leg: Leg, psi: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``thigh``, ``hip``, ``knee``, ``ankle`` of ``leg`` (deg, (K,), within (-180, 180],
    NaN for a point foot's swing ankle) from the link angles ``psi`` {link: (K,) rad}
    (:func:`joint_radians`)."""
    shape = np.shape(psi[leg.shank])
    return {
        name: np.full(shape, np.nan) if value is None else np.degrees(wrapped(value))
        for name, value in joint_radians(body, leg, psi).items()
    }


def leg_moments(
    body: Body, leg: Leg, torques: Mapping[str, Any], body_mass: float
) -> dict[str, Any]:
    """``hip_moment``, ``knee_moment``, ``ankle_moment`` of ``leg`` (N m/kg, extensor
    positive) from the hinge torques {link: value, N m} (see the module): arithmetic only,
    numpy arrays (K,) or CasADi expressions; a point foot's swing ankle is NaN (numpy) or
    None (expressions)."""
    if leg.stance:
        hip = sum(torques[name] for name in body.hip_links)
        knee = -torques[leg.thigh]
        ankle = torques[leg.shank]
    else:
        hip = -torques[leg.thigh]
        knee = torques[leg.shank]
        ankle = None if leg.foot is None else -torques[leg.foot]
    if ankle is None and isinstance(knee, np.ndarray):
        ankle = np.full(np.shape(knee), np.nan)
    return {
        "hip_moment": hip / body_mass,
        "knee_moment": knee / body_mass,
        "ankle_moment": None if ankle is None else ankle / body_mass,
    }
