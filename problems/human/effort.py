"""Objectives of torque-driven predictive gait that walk more like a person: each element an
option, each with its source, measured in ``examples/benchmarks/human_prediction.py``.

* ``joints``: the effort on the physical joints (both hips, knees and ankles in the
  conventions of :mod:`problems.human.joints`) instead of the tree's hinges. The tree's hinge
  at the stance hip is trunk-stance thigh and the swing thigh hangs from the stance thigh, so
  a torque-squared objective on the hinges charges the swing hip's drive twice and the stance
  hip's wrongly (the physical stance hip carries M_trunk + M_swing_thigh);
* ``strengths`` (N m, per joint) and ``exponent`` (2 or 3): effort sum |M_j / S_j|^e, the
  strength-normalised effort of torque-driven predictive simulations (Ackermann and van den
  Bogert, J Biomech 43:1055-1060, 2010, for the exponent: 3 predicts walking closer to
  measured than 2 with muscle activations; with joint torques the same form normalised by
  each joint's strength); equal strengths by default (no subject's strengths measured: give
  yours);
* ``passive``: the joints' passive moments near their range limits (Anderson and Pandy,
  Comput Methods Biomech Biomed Engin 2:201-231, 1999, the coefficients as tabulated by
  Falisse et al., J R Soc Interface 16:20190402, 2019): tau = k1 exp(k2 (q - q2)) + k3
  exp(k4 (q - q1)) on the hip flexion, the knee angle (extension positive, as their models
  count it) and the ankle dorsiflexion, in N m; they act for free, so the effort counts the
  active moment only (the drive's torque less the passive one);
* ``accelerations``: the joints' angular accelerations, sum (q''_j / 100 rad/s^2)^2 times
  this weight, the regularisation of Falisse et al. 2019's cost (it keeps a light segment,
  the swing foot, from swinging between its limits for free);
* ``collision``: the kinetic energy the heel strike dissipates, J, times this weight
  ((N m)^2 s per J with exponent 2), added at the strike: the rigid strike otherwise costs
  nothing (Kuo, J Biomech Eng 124:113-120, 2002: step-to-step transitions are a major cost of
  walking).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import casadi as ca

from planner.errors import DefinitionError
from problems.human.joints import Body, body_of, joint_radians, leg_moments

#: The joints of a leg, in the order of their moments.
JOINTS = ("hip", "knee", "ankle")
#: Passive moments (Anderson and Pandy 1999, via Falisse et al. 2019): joint -> (k1, k2, k3,
#: k4, q1, q2) of tau = k1 exp(k2 (q - q2)) + k3 exp(k4 (q - q1)), q rad, tau N m acting to
#: increase q; q is hip flexion, knee *extension* (minus flexion), ankle dorsiflexion.
PASSIVE = {
    "hip": (-2.44, 5.05, 1.51, -21.88, -0.6981, 1.81),
    "knee": (-6.09, 33.94, 11.03, -11.33, -2.4, 0.13),
    "ankle": (-2.03, 38.11, 0.18, -12.12, -0.74, 0.52),
}
#: Default strength of a joint or drive, a fraction of m g L (150 N m for the six-link walker:
#: the product's drive limit).
DEFAULT_STRENGTH = 0.254
#: The setting ``objective="human"`` (:data:`HUMAN`): the joints' effort with their passive
#: moments, the ankle twice as strong as the other joints (0.51 m g L, 300 N m for the
#: six-link walker; our choice, measured: no strength table of a subject is in the product)
#: and a light joint-acceleration term (0.003): measured against Winter's stride it brings
#: the push-off force, the ankle's moment and the swing knee to the human's
#: (examples/benchmarks/human_prediction.py); exponent 3, stronger hips or knees, heavier
#: acceleration terms and the collision cost measured worse there.
#: Sign of each joint's passive coordinate against the flexion angle of
#: :mod:`problems.human.joints` (the knee's counts extension).
_PASSIVE_SIGN = {"hip": 1.0, "knee": -1.0, "ankle": 1.0}


@dataclass(frozen=True)
class HumanObjective:
    """The options of the module (see there). ``strengths``: {joint: strength as a fraction
    of the walker's weight times its leg length (m g L: 591 N m for the six-link walker)};
    joints not given, and the drives that are no leg joint (the head's), take
    ``default_strength``."""

    joints: bool = True
    exponent: float = 2.0
    passive: bool = True
    collision: float = 0.0
    accelerations: float = 0.0
    strengths: Mapping[str, float] = field(default_factory=dict)
    default_strength: float = DEFAULT_STRENGTH

    def __post_init__(self) -> None:
        if self.exponent not in (2.0, 3.0):
            raise DefinitionError(f"`exponent`: 2 or 3, got {self.exponent!r}")
        for name in ("collision", "accelerations"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise DefinitionError(f"`{name}`: a weight >= 0, got {value!r}")
        for name, value in self.strengths.items():
            if name not in JOINTS or not (isinstance(value, int | float) and value > 0):
                raise DefinitionError(
                    f"`strengths`: {{joint: fraction of m g L > 0}} with joints in {JOINTS}, "
                    f"got {name!r}: {value!r}"
                )
        if not (isinstance(self.default_strength, int | float) and self.default_strength > 0):
            raise DefinitionError(
                f"`default_strength`: a fraction of m g L > 0, got {self.default_strength!r}"
            )

    def strength(self, joint: str) -> float:
        """The joint's strength, a fraction of m g L."""
        return float(self.strengths.get(joint, self.default_strength))

    def as_dict(self) -> dict[str, Any]:
        return {"joints": self.joints, "exponent": self.exponent, "passive": self.passive,
                "collision": self.collision, "accelerations": self.accelerations,
                "strengths": dict(self.strengths),
                "default_strength": self.default_strength}  # fmt: skip


def passive_moment(joint: str, flexion):
    """The passive moment of ``joint`` at its flexion angle (rad, numpy or CasADi), N m,
    in the extensor-positive sense of :mod:`problems.human.joints` (plantarflexor for the
    ankle)."""
    k1, k2, k3, k4, q1, q2 = PASSIVE[joint]
    sign = _PASSIVE_SIGN[joint]
    q = sign * flexion
    exp = ca.exp if isinstance(flexion, ca.SX | ca.MX) else math.exp
    tau = k1 * exp(k2 * (q - q2)) + k3 * exp(k4 * (q - q1))
    # tau acts to increase q; an extensor moment decreases the flexion: -sign tau
    return -sign * tau


def joint_effort(objective: HumanObjective, body: Body, psi: Mapping[str, Any], torques,
                 unit: float):  # fmt: skip
    """The effort integrand of both legs' joints: sum_j |(E_j - P_j) / (S_j unit)|^e with
    E_j the joint moment (N m, extensor positive) from the hinge torques {link: expression},
    P_j the passive moment (0 without ``passive``), S_j the strength as a fraction of
    ``unit`` = m g L, N m."""
    terms = []
    for leg in (body.stance, body.swing):
        moments = leg_moments(body, leg, torques, 1.0)
        angles = joint_radians(body, leg, psi)
        for joint in JOINTS:
            moment = moments[f"{joint}_moment"]
            if moment is None:  # a point foot's swing ankle
                continue
            if objective.passive and angles[joint] is not None:
                moment = moment - passive_moment(joint, angles[joint])
            terms.append(_power(moment / (objective.strength(joint) * unit), objective.exponent))
    return sum(terms[1:], terms[0])


def _power(ratio, exponent: float):
    """ratio^2, or |ratio|^3 smoothed at 0."""
    return ratio**2 if exponent == 2.0 else (ratio**2 + 1e-8) ** 1.5


def human_integrand(linkage, objective: HumanObjective, drives, neutral_ankles=None):
    """The effort integrand (a callable of a planner Point) of ``objective`` for a biped
    ``linkage`` whose hinges ``drives`` (link names) have motors, in (N m)^2 like the
    torque-squared objective (the effort times (``default_strength`` m g L)^2): the joints'
    effort (or, without ``joints``, every drive's |M_i / S|^e) and the other drives' (the
    head's) as hinges."""
    body = body_of(linkage, neutral_ankles)
    names = linkage.names
    legs = {body.stance.shank, body.stance.thigh, body.swing.thigh, body.swing.shank,
            body.swing.foot, *body.hip_links} - {None}  # fmt: skip
    others = [names.index(n) for n in drives if not objective.joints or n not in legs]
    leg_length = sum(linkage.links[linkage.index(n)].length
                     for n in (body.stance.shank, body.stance.thigh))  # fmt: skip
    unit = sum(link.mass for link in linkage.links) * linkage.gravity * leg_length
    scale = objective.default_strength * unit

    pairs = _joint_pairs(body)
    index = {name: i for i, name in enumerate(names)}

    def integrand(p):
        psi = {name: p.psi[i] for i, name in enumerate(names)}
        torques = {name: p.M[i] for i, name in enumerate(names)}
        total = joint_effort(objective, body, psi, torques, unit) if objective.joints else 0.0
        for i in others:
            total = total + _power(p.M[i] / scale, objective.exponent)
        if objective.accelerations > 0:
            rates = [(p.ddpsi[index[a]] - p.ddpsi[index[b]]) / ACCELERATION for a, b in pairs]
            total = total + objective.accelerations * ca.sumsqr(ca.vertcat(*rates))
        return scale**2 * total

    return integrand


#: The nominal joint acceleration of the ``accelerations`` term, rad/s^2.
ACCELERATION = 100.0


def _joint_pairs(body: Body) -> list[tuple[str, str]]:
    """(link, link) whose angle difference is a joint's angle: both hips, knees, ankles."""
    pairs = []
    for leg in (body.stance, body.swing):
        pairs += [(leg.thigh, body.trunk), (leg.thigh, leg.shank)]
        if leg.foot is not None:
            pairs.append((leg.shank, leg.foot))
    return pairs


def check_objective(objective) -> HumanObjective | None:
    """``objective``: "torque" -> None, "human" -> :data:`HUMAN`, a HumanObjective as it
    is; anything else raises naming the choices."""
    if isinstance(objective, HumanObjective):
        return objective
    if objective == "human":
        return HUMAN
    if objective == "torque":
        return None
    raise DefinitionError(
        f"`objective`: 'torque' (the drives' sum M^2), 'human' or a "
        f"problems.human.effort.HumanObjective, got {objective!r}"
    )


def strike_collision(step, weight: float):
    """The terminal term of a footed step's phase that ends in the strike: ``weight`` times
    the kinetic energy the strike dissipates, J."""
    energy = step.dynamics.function("energy")
    strike = step.strike.state_function()
    n = step.linkage.n

    def collision(p):
        after = strike(p.x)
        return weight * (energy(p.x[:n], p.x[n:])[0] - energy(after[:n], after[n:])[0])

    return collision


HUMAN = HumanObjective(strengths={"ankle": 2 * DEFAULT_STRENGTH}, accelerations=0.003)
