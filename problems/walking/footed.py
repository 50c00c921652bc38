"""A periodic walking step on feet: heel strike, flat foot, heel rise and toe-off.

The walker's legs end in a foot link with two contacts, the heel and the ball of the foot
(the *toe*): ``model.presets.anthropoid_with_feet`` and ``anthropoid_feet``, or any biped
whose legs are three links (foot, shank, thigh) with such points. The tree is rooted at the
stance foot's ball (H0), which stays on the ground through the whole step; the step is three
contact phases (``planner.Phases``), the human cycle from the opposite toe-off to the next:

1. ``flat`` (mid stance): the stance foot flat on heel and ball: welded (no angular
   acceleration, flat and at rest at the phase's start), the ground's torque on the foot about
   the ball M_0 a
   control whose centre of pressure -M_0 / Fy stays on the sole between heel and ball
   (-sole Fy <= M_0 <= 0); the swing foot in the air.
2. ``heel rise`` (terminal stance): the stance foot pivots on its ball (M_0 = 0, the heel
   above the ground); the swing foot swings on, over a clearance profile, and its heel lands
   at the end: at (step_length - sole, 0), coming down at the touchdown speed or faster.
3. heel strike: an inelastic impact at the landing heel with the stance ball held
   (``Dynamics.impact(heel, root_pinned=True)``), both impulses in their friction cones.
4. ``double`` (loading response and pre-swing): the stance ball pinned (M_0 = 0), the front
   heel a contact whose ground force F is a control, held at rest by its acceleration; the
   front foot rolls down onto its ball and arrives flat and at rest at the end (no second
   impact: the ball sets down softly), while the rear foot unloads.
5. toe-off: the rear ball leaves the ground and the legs swap (``model.swap_legs``,
   re-rooted at the front ball): the periodicity, x_flat(0) = swap(x_double(T)).

Every contact's ground force pushes and stays in its friction cone; every foot point not in
contact stays above the ground; knees, ankles and the upper body keep their ranges; drives
|M| <= torque_limit (the ground's torque M_0 on the root foot is no drive: it is bounded by
the sole, not counted in the objective).

Other sequences are a matter of listing phases (``phases=``, :data:`SEQUENCES`):
``"flat-footed"`` = (flat, double): no heel rise; the swing heel strikes at the flat phase's
end with the stance foot still flat, an impact with the root welded (``Dynamics.impact(heel,
root_welded=True)``: its angular impulse about the ball on the sole too), and the rear foot
stays welded flat through the double support, its centre of pressure on its sole.
``"toe-walking"`` = (heel rise, double): on the balls of the feet; the swing *ball* strikes
at (step_length, 0) and is held through the double support, the front heel above the ground,
the front foot not laid flat (the next step starts on its ball).

Phase durations are free by default within bounds (fractions of the step time), their sum
the step time (a step of ``step_length`` in ``step_time``, the speed the user asked for):
static parameters (``T_flat``, ``T_heel``) carry every phase's but the last and every phase
ties its duration to them. ``durations=(...)`` in s, one per phase, fixes them.

The guess is the gait law (22) fitted to a point-foot step of the same length and the
single support's duration for the shared links (``Biped.step_law`` of the linkage without
its feet), the stance foot flat (its heel rising with the shank in the heel rise), the
swing foot at a neutral ankle; the double support holds the strike pose, the feet sharing the
weight. The law's cost on the same problem (its torques by inverse dynamics) is the
benchmark, as for the point-foot step.
"""

from __future__ import annotations

import functools
import math
import operator
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import casadi as ca
import numpy as np

from model.contact import Contact
from model.dynamics import Dynamics
from model.linkage import Linkage
from model.linkage_naming import contact_force_names
from model.points import LinkPoint
from model.presets import anthropoid_feet, anthropoid_with_feet
from model.rotors import Rotor, rotor_settings
from planner.errors import DefinitionError, check_positive, check_real
from planner.problem import OCP, Phases
from planner.transcription import Transcription
from problems.gait.biped import Biped
from problems.gait.law import GaitLaw
from problems.gait.problem import (
    RATE_HZ,
    bound_joint_speeds,
    bound_stance_hip,
    centre_of_pressure,
    joint_rates,
    keep_upright,
    objective_at_guess,
    rate_scales,
    solve_and_hold,
    torque_limits,
    verified,
)
from problems.gait.similarity import WalkerScales
from problems.human.effort import HumanObjective, human_integrand, strike_collision
from problems.human.effort import check_objective as check_human_objective
from problems.walking.step import (
    CLEARANCE_SCALE,
    GUESS_LIFT,
    LAND_TIME,
    SPEED_SCALE,
    UNLOADED,
    SteppingGait,
    clearance_profile,
)

#: Rows that the phases' ends fix (the swing ball leaves the ground at 0 and the swing heel
#: lands on it, the stance heel lifts off it; at toe-off the rear foot leaves on its cone's
#: edge under the unloading cap): :func:`planner.hold_at_samples` does not back them off
#: there.
PINNED = ("clearance", "stance heel up", "rear unloads", "friction")
#: The phases of the default step (the human cycle), in order.
PHASES = ("flat", "heel rise", "double")
#: The sequences of contact phases a step may list (``footed_step(phases=...)``), by name:
#: the human cycle; a flat-footed gait (no heel rise: the stance foot flat until toe-off, flat
#: under the rear leg through the double support, the heel strike with the rear foot
#: welded); toe walking (on the balls of the feet: the stance heel never down, the swing
#: ball strikes and holds through the double support).
SEQUENCES = {
    "human": PHASES,
    "flat-footed": ("flat", "double"),
    "toe-walking": ("heel rise", "double"),
}
#: The contact phases of a stop at quiet standing (:func:`stopping`): the stance foot flat
#: while the swing foot swings from behind and sets down flat beside it, at rest; not a
#: periodic step's sequence (``footed_step`` takes none but :data:`SEQUENCES`).
STOP = ("flat",)
#: Default shares of the step time per sequence (the guess, and inside the bounds): the
#: human cycle (Perry's phases: opposite toe-off at 12 % of the stride, heel rise at 31 %,
#: heel strike at 50 %, toe-off at 62 %) as shares of one step, half a stride; the other
#: sequences keep its double support.
SHARES = {
    PHASES: (0.38, 0.38, 0.24),
    SEQUENCES["flat-footed"]: (0.76, 0.24),
    SEQUENCES["toe-walking"]: (0.76, 0.24),
}
#: Each phase's duration bounds per sequence, as shares of the step time.
SHARE_BOUNDS = {
    PHASES: ((0.10, 0.70), (0.10, 0.70), (0.06, 0.40)),
    SEQUENCES["flat-footed"]: ((0.40, 0.94), (0.06, 0.40)),
    SEQUENCES["toe-walking"]: ((0.40, 0.94), (0.06, 0.40)),
}
#: The static parameter that carries a phase's duration (the last phase, the double
#: support, takes the rest of the step time).
DURATION_PARAMETERS = {"flat": "T_flat", "heel rise": "T_heel"}
#: Ankle range, rad, from the neutral stance (shank perpendicular to the sole): dorsiflexion
#: to -20 degrees, plantarflexion to +50 degrees (the American Academy of Orthopaedic
#: Surgeons' average ranges of motion).
ANKLE_RANGE = (-math.radians(20.0), math.radians(50.0))
#: The default points of the feet: (stance heel, stance toe, swing heel, swing toe).
FOOT_POINTS = ("stance_heel", "stance_toe", "swing_heel", "swing_toe")


@dataclass(frozen=True, eq=False)
class FootedStep:
    """A walking step on feet as a problem (see the module): ``phases`` (a
    :class:`planner.Phases` the user may change) and :meth:`solve`.

    Attributes
    ----------
    linkage, dynamics, biped : the walker (three-link legs: foot, shank, thigh).
    points : the four foot contacts by role (:data:`FOOT_POINTS`), ``model.LinkPoint``.
    step_length : from one ball of the foot to the next on the ground, m.
    step_time : s. ``mu``: the ground's friction coefficient.
    durations : each phase's duration, s, when fixed, else None (free).
    sequence : the contact phases in order, one of :data:`SEQUENCES`.
    """

    linkage: Linkage
    dynamics: Dynamics
    biped: Biped
    points: Mapping[str, LinkPoint]
    step_length: float
    step_time: float
    mu: float
    torque_limit: float
    clearance: float
    touchdown_speed: float
    knee_range: tuple[float, float]
    ankle_range: tuple[float, float]
    posture: float
    durations: tuple[float, ...] | None
    mesh: tuple[int, ...]
    sequence: tuple[str, ...] = PHASES
    phases: Phases | None = None
    approach_time: float = 0.03
    human: HumanObjective | None = None
    hinge_limits: Mapping[str, float] | None = None
    hip_limit: float | None = None
    speed_limit: float | None = None
    #: appended to the duration parameters' names (``T_flat`` + label): the steps of a
    #: transition, solved together, each have their own (static parameters are shared by name)
    label: str = ""
    #: s: the swing foot's clearance floor starts flat over this time (``clearance_profile``'s
    #: ``lift``): the first step of a start from standing, whose swing foot lifts from rest; 0
    #: for a step whose swing foot leaves the ground moving (toe-off)
    lift_time: float = 0.0
    #: s: the floor ends flat over this time (``clearance_profile``'s ``land``): a stop's
    #: swing foot sets down at rest
    land_time: float = 0.0
    #: a stop at quiet standing (:func:`stopping`): the one flat phase ends with both feet
    #: flat side by side and the body at rest; no strike, no leg swap
    stop: bool = False

    @property
    def limits(self) -> dict[str, float]:
        """Each drive's |M| bound, N m (``torque_limit`` for every drive, or per hinge)."""
        given = self.hinge_limits or {}
        return {name: float(given.get(name, self.torque_limit)) for name in self.drives}

    # ---- geometry ----------------------------------------------------------------------
    @property
    def leg_length(self) -> float:
        """Shank and thigh, m: the leg of the walker's units (its defaults scale with it)."""
        return math.fsum(self.biped.length(name) for name in self.biped.stance_leg[1:])

    def _offset(self, role: str) -> complex:
        return self.points[role].offset(self.linkage)

    @cached_property
    def time_unit(self) -> float:
        """The walker's time unit sqrt(L / g) relative to the six-link walker's: the nominal
        rates and accelerations of the NLP's rows (:func:`problems.gait.problem.rate_scales`)."""
        return WalkerScales(self.leg_length, self.linkage.gravity).relative["time"]

    @cached_property
    def sole(self) -> float:
        """Heel to ball, m (the stance foot's points)."""
        return abs(self._offset("stance_heel") - self._offset("stance_toe"))

    @cached_property
    def flat_angles(self) -> tuple[float, float]:
        """(stance foot, swing foot) link angles with the sole flat, heel behind, rad."""
        stance = self._offset("stance_toe") - self._offset("stance_heel")  # heel -> ball
        swing = self._offset("swing_toe") - self._offset("swing_heel")
        return -math.atan2(stance.imag, stance.real), -math.atan2(swing.imag, swing.real)

    @cached_property
    def law(self) -> GaitLaw:
        """The guess: the law (22) of every link on the single support's time (:func:`_law`)."""
        return _law(self)

    @cached_property
    def clearance_scale(self) -> float:
        """Nominal size of the rows of heights above the ground, m: the mid-swing clearance,
        or the point-foot step's fraction of the leg length when that is smaller."""
        return max(self.clearance, CLEARANCE_SCALE * self.biped.leg_length)

    @cached_property
    def _height_functions(self) -> dict[tuple[str, ...], ca.Function]:
        return {}

    def heights(self, *roles: str) -> ca.Function:
        """psi (n,) -> the heights of the foot points ``roles`` (m), an SX Function built once
        per set of roles."""
        made = self._height_functions
        if roles not in made:
            psi = ca.SX.sym("psi", self.linkage.n)
            rows = [self.point(role).function("position")(psi)[1] for role in roles]
            made[roles] = ca.Function("heights", [psi], [ca.vertcat(*rows)], ["psi"], ["y"])
        return made[roles]

    @cached_property
    def neutral_ankles(self) -> tuple[float, float]:
        """(stance, swing) psi_shank - psi_foot with the shank perpendicular to the flat
        sole (the neutral ankle), rad."""
        flat_stance, flat_swing = self.flat_angles
        return math.pi / 2 - flat_stance, -math.pi / 2 - flat_swing

    @property
    def speed(self) -> float:
        return self.step_length / self.step_time

    @cached_property
    def corners(self) -> dict[str, tuple[LinkPoint, ...]]:
        """Each foot drawn as its outline ball, heel, ankle (:func:`world_motion`)."""
        return {
            self.biped.stance_leg[0]: (self.points["stance_heel"],),
            self.biped.swing_leg[-1]: (self.points["swing_heel"],),
        }

    @cached_property
    def contacts(self) -> dict[str, Contact]:
        """Each foot point as a ``model.Contact`` with the ground's friction, by role."""
        return {role: Contact(point, self.mu, name=role) for role, point in self.points.items()}

    def point(self, role: str):
        """The ``model.PointKinematics`` of a foot point."""
        return self.dynamics.point(self.points[role])

    @property
    def strike_role(self) -> str:
        """The swing foot's point that strikes the ground: its heel when the next stance
        begins flat, its ball (toe walking) otherwise."""
        return "swing_heel" if self.sequence[0] == "flat" else "swing_toe"

    @property
    def striking_point(self) -> str:
        """:attr:`strike_role` in words: "heel" or "ball"."""
        return "heel" if self.strike_role == "swing_heel" else "ball"

    @property
    def sequence_name(self) -> str:
        """The name of :attr:`sequence` in :data:`SEQUENCES` (``footed_step`` takes no other),
        or "stop" for a stop's (:data:`STOP`)."""
        if self.stop:
            return "stop"
        return next(name for name, phases in SEQUENCES.items() if phases == self.sequence)

    @property
    def rear_flat(self) -> bool:
        """True when the stance foot stays flat until toe-off (no heel rise): the strike and
        the double support hold it welded, its centre of pressure on the sole."""
        return "heel rise" not in self.sequence

    @cached_property
    def landing(self) -> float:
        """Where the striking point lands, m along the ground from the stance ball."""
        return self.step_length - (self.sole if self.strike_role == "swing_heel" else 0.0)

    @cached_property
    def strike(self):
        """The strike (``model.ImpactMap``): the swing heel (or ball) lands, the stance ball
        held (the stance foot welded when it lies flat)."""
        return self.dynamics.impact(self.point(self.strike_role), root_pinned=True,
                                    root_welded=self.rear_flat)  # fmt: skip

    @property
    def weight(self) -> float:
        return self.biped.total_mass * self.linkage.gravity

    @property
    def drives(self) -> tuple[str, ...]:
        """The links whose hinge has a drive: all but the root (the ground's torque on the
        stance foot is a contact's, not a motor's)."""
        return self.linkage.names[1:]

    # ---- solving -------------------------------------------------------------------------
    @property
    def problem(self) -> Phases:
        """What :meth:`solve` solves: the three phases."""
        return self.phases

    def law_cost(self, problem: Phases | None = None) -> float:
        """The objective of the law (22) with flat feet (the guess) on the problem's mesh
        (default this step's), torques by inverse dynamics: the benchmark."""
        return objective_at_guess(Transcription(self.phases if problem is None else problem))

    def solve(
        self,
        problem: Phases | None = None,
        *,
        rate_hz: float | None = RATE_HZ,
        hold_limits: bool = True,
        verify: bool = True,
        **options,
    ) -> FootedGait:
        """Solve this step's phases, or ``problem`` (a changed copy of :attr:`phases`, e.g.
        guessed from another solution) with IPOPT (``options`` go to :func:`planner.solve`;
        raises :class:`planner.SolverError` on failure unless ``raise_on_failure=False``),
        the limits held on the exported motion at ``rate_hz`` as :meth:`WalkingStep.solve`
        does (``hold_limits``), and the plan verified on those samples (``verify``: a plan
        that fails raises :class:`problems.GaitVerificationError`, see
        :func:`problems.gait.problem.verified`); the law's cost on the same mesh is measured
        too."""
        transcription = Transcription(self.phases if problem is None else problem)
        law_cost = objective_at_guess(transcription)
        options.setdefault("progress", False)
        solution = solve_and_hold(transcription, options, hold_limits, rate_hz, PINNED)
        gait = FootedGait(self, solution, law_cost)
        return verified(gait, rate_hz, verify, options)

    def settings(self, times=None) -> dict[str, Any]:
        """The step's parameters as plain data, exported with the gait's files and read by
        :func:`problems.verify_gait` (``times`` is accepted for the interface of
        :meth:`Gait.to_trajectory`). ``foot``: the root's sole, (sole, 0) m behind and ahead
        of the ball, where the ground's torque on the flat foot puts its pressure; ``drives``:
        the hinges with a motor (the root's torque M_<stance foot> is the ground's);
        ``contacts``: every foot point as [link, along, lateral]."""
        upper = list(self.biped.upper_body)
        names = self.linkage.names
        return {
            "problem": "footed_step",
            "step_length": self.step_length,
            "step_time": self.step_time,
            "durations": None if self.durations is None else list(self.durations),
            "phases": list(self.sequence),
            "strike": self.strike_role,
            "mu": self.mu,
            "clearance": self.clearance,
            "touchdown_speed": self.touchdown_speed,
            "approach_time": self.approach_time,
            "lift_time": self.lift_time,
            "land_time": self.land_time,
            "stop": self.stop,
            "leg_length": self.leg_length,
            "torque_limit": self.limits,
            "hip_limit": self.hip_limit,
            "speed_limit": self.speed_limit,
            "drives": list(self.drives),
            "knee_range": list(self.knee_range),
            "ankle_range": list(self.ankle_range),
            "neutral_ankles": list(self.neutral_ankles),
            "flat_angles": list(self.flat_angles),
            "posture": self.posture,
            "upright": upper,
            "foot": [self.sole, 0.0],
            "sole": self.sole,
            "contacts": {role: [p.link, p.along, p.lateral] for role, p in self.points.items()},
            # every hinge but the feet's points (the feet have their own checks)
            "ground_points": [name for name in names if name != self.biped.swing_leg[-1]],
            "ground_margin": 0.0,
            "swing_foot": self.biped.swing_leg[-1],
            "mesh": list(self.mesh),
            "law": self.law.to_dict(),
            "objective": "torque" if self.human is None else "human",
            "human_objective": None if self.human is None else self.human.as_dict(),
            **rotor_settings(self.dynamics.rotors),  # a plan with its drives' rotors
        }


def footed_step(
    linkage: Linkage | None = None,
    step_length: float = 0.5,
    step_time: float = 0.5,
    *,
    points: Mapping[str, LinkPoint] | None = None,
    N: tuple[int, ...] | None = None,
    transcription: str = "hermite-simpson",
    mu: float = 0.8,
    torque_limit: float | Mapping[str, float] = 150.0,
    clearance: float | None = None,
    touchdown_speed: float | None = None,
    approach_time: float | None = None,
    knee_range: tuple[float, float] = (0.0, 2.5),
    ankle_range: tuple[float, float] = ANKLE_RANGE,
    posture: float = 0.2,
    durations: tuple[float, ...] | None = None,
    phases: str | tuple[str, ...] = "human",
    objective: str | HumanObjective = "torque",
    hip_limit: float | None = None,
    speed_limit: float | None = None,
    rotors: Sequence[Rotor] = (),
) -> FootedStep:
    """A periodic walking step on feet (see the module docstring).

    Parameters
    ----------
    linkage : a biped whose legs are (foot, shank, thigh); default
        ``model.presets.anthropoid_with_feet()`` (the six-link scene on Winter's feet).
    step_length : from one ball of the foot to the next, m (> 0).
    step_time : s (> 0).
    points : the feet's contacts by role (``stance_heel``, ``stance_toe`` = H0, ``swing_heel``,
        ``swing_toe`` = the swing foot's end); default ``model.presets.anthropoid_feet()``.
    N : intervals of each phase; default :data:`MESHES` of the sequence.
    mu, torque_limit, clearance, touchdown_speed, approach_time, knee_range, posture : as for
        :func:`problems.walking_step` (None: the defaults scaled with the walker, the leg being
        shank and thigh: 0.05 m, 0.3 m/s and 0.03 s for 0.86 m legs under 9.81 m/s^2;
        :mod:`problems.gait.similarity`).
    torque_limit : one number, N m, or one per drive {link: N m} (every link but the root:
        the stance foot's torque is the ground's, bounded by its sole).
    ankle_range : (dorsiflexion, plantarflexion) limits from the neutral stance, rad.
    durations : each phase's duration, s, summing to step_time, to fix them; None: free
        within :data:`SHARE_BOUNDS` of the step time.
    phases : the contact phases in order, by a name of :data:`SEQUENCES` ("human": flat,
        heel rise, double; "flat-footed": flat, double; "toe-walking": heel rise, double) or
        as that tuple of phase names.
    hip_limit : the physical stance hip's |torque| bound, N m, or None (as for
        :func:`problems.walking_step`).
    speed_limit : every drive's |joint speed| bound, rad/s, at every node, or None (as for
        :func:`problems.walking_step`).
    rotors : geared motors' rotors in the equations of motion (``model.Rotor``; as for
        :func:`problems.walking_step`), () for ideal torque sources.
    objective : "torque" (the drives' integral of sum M_i^2, the default), "human" (the
        joints' strength-normalised effort with passive moments,
        :data:`problems.human.effort.HUMAN`) or a :class:`problems.human.effort.HumanObjective`.
    """
    sequence = _sequence(phases)
    linkage = anthropoid_with_feet() if linkage is None else linkage
    biped = Biped.of(linkage)
    if len(biped.stance_leg) != 3:
        raise DefinitionError(
            f"`linkage`: a step on feet needs legs of three links (foot, shank, thigh); this "
            f"biped's legs have {len(biped.stance_leg)} ({', '.join(biped.stance_leg)})"
        )
    points = dict(anthropoid_feet() if points is None else points)
    missing = [role for role in FOOT_POINTS if role not in points]
    if missing:
        raise DefinitionError(f"`points`: give every foot contact {list(FOOT_POINTS)}; missing "
                              f"{missing}")  # fmt: skip
    step_length = check_positive("step_length", step_length, "m")
    step_time = check_positive("step_time", step_time, "s")
    mu = check_positive("mu", mu, "(friction coefficient)")
    hinge_limits = None
    if isinstance(torque_limit, Mapping):  # one per drive: the root's torque is the ground's
        hinge_limits = torque_limits(linkage, torque_limit, links=linkage.names[1:])
        torque_limit = max(hinge_limits.values())
    torque_limit = check_positive("torque_limit", torque_limit, "N m")
    scales = WalkerScales(math.fsum(biped.length(n) for n in biped.stance_leg[1:]),
                          linkage.gravity)  # fmt: skip
    clearance = check_real("clearance", scales.clearance if clearance is None else clearance)
    if clearance < 0:
        raise DefinitionError(f"`clearance`: must be >= 0 m, got {clearance!r}")
    approach_time = check_positive(
        "approach_time", scales.approach_time if approach_time is None else approach_time, "s"
    )
    if touchdown_speed is None:
        touchdown_speed = scales.touchdown_speed
    touchdown_speed = check_real("touchdown_speed", touchdown_speed)
    if touchdown_speed < 0:
        raise DefinitionError(
            f"`touchdown_speed`: the landing heel's downward speed must be >= 0 m/s, got "
            f"{touchdown_speed!r}"
        )
    if durations is not None:
        durations = tuple(check_positive(f"durations[{k}]", d, "s")
                          for k, d in enumerate(durations))  # fmt: skip
        if len(durations) != len(sequence) or not math.isclose(
            sum(durations), step_time, rel_tol=1e-9
        ):
            raise DefinitionError(
                f"`durations`: ({', '.join(sequence)}) s summing to step_time = "
                f"{step_time:g} s, got {durations!r}"
            )
    for name, pair in (("knee_range", knee_range), ("ankle_range", ankle_range)):
        ordered = len(pair) == 2 and check_real(name, pair[0]) < check_real(name, pair[1])
        if not ordered:
            raise DefinitionError(f"`{name}`: give (lower, upper) in rad, lower < upper, got "
                                  f"{pair!r}")  # fmt: skip
    mesh = MESHES[sequence] if N is None else tuple(int(n) for n in N)
    if len(mesh) != len(sequence) or min(mesh) < 2:
        raise DefinitionError(f"`N`: {len(sequence)} interval counts >= 2 "
                              f"({', '.join(sequence)}), got {N!r}")  # fmt: skip
    step = FootedStep(
        linkage=linkage,
        dynamics=Dynamics(linkage, rotors=rotors),
        biped=biped,
        points=points,
        step_length=step_length,
        step_time=step_time,
        mu=mu,
        torque_limit=torque_limit,
        hinge_limits=hinge_limits,
        hip_limit=None if hip_limit is None else check_positive("hip_limit", hip_limit, "N m"),
        speed_limit=None
        if speed_limit is None
        else check_positive("speed_limit", speed_limit, "rad/s"),
        clearance=clearance,
        touchdown_speed=touchdown_speed,
        approach_time=approach_time,
        knee_range=(float(knee_range[0]), float(knee_range[1])),
        ankle_range=(float(ankle_range[0]), float(ankle_range[1])),
        posture=check_positive("posture", posture, "rad"),
        durations=durations,
        mesh=mesh,
        sequence=sequence,
        human=check_human_objective(objective),
    )
    return replace(step, phases=_phases(step, transcription))


def resized(step: FootedStep, step_length: float, step_time: float, label: str = "") -> FootedStep:
    """``step`` (its walker, feet, limits, objective, mesh and every other option) for a step of
    ``step_length`` m in ``step_time`` s, its phase durations free, its duration parameters'
    names ending in ``label`` (:attr:`FootedStep.label`): one step of a transition."""
    step_length = check_positive("step_length", step_length, "m")
    step_time = check_positive("step_time", step_time, "s")
    if label and not ("T" + label).isidentifier():
        raise DefinitionError(f"`label`: a suffix of parameter names (letters, digits, _), "
                              f"got {label!r}")  # fmt: skip
    transcription = step.phases.phases[0][1].transcription
    other = replace(step, step_length=step_length, step_time=step_time, durations=None,
                    label=label, phases=None)  # fmt: skip
    return replace(other, phases=_phases(other, transcription))


def stopping(step: FootedStep, step_time: float, label: str = "") -> FootedStep:
    """The stop at quiet standing after a step of ``step``'s walk (its walker, feet, limits,
    objective and every other option): one flat phase (:data:`STOP`) of ``step_time`` s in
    which the stance foot lies flat, the swing foot swings from behind over a floor that
    ends flat (:data:`problems.walking.step.LAND_TIME`) and sets down flat with its ball at
    the stance ball at touchdown speed 0 (the floor's approach term would make it come down
    at the walk's touchdown speed to the last instant, where it must be at rest: a slam in
    the last mesh interval), and the body comes to rest (dpsi = 0, ddpsi = 0 but the welded
    stance foot's): :func:`standing_rows` at the end. Its step length is 0 (the feet side
    by side); ``label`` as for :func:`resized`. Its mesh is twice the single support's of
    ``step`` (the phases before the double support): it spans about a step and a half."""
    step_time = check_positive("step_time", step_time, "s")
    if step.sequence[0] != "flat":
        raise DefinitionError(
            f"`step`: a stop at standing ends with the stance foot flat; this walk's steps "
            f"begin with {step.sequence[0]!r} ({step.sequence_name}): plan the walk in the "
            "human or the flat-footed sequence"
        )
    transcription = step.phases.phases[0][1].transcription
    other = replace(
        step, step_length=0.0, step_time=step_time, durations=(step_time,), label=label,
        sequence=STOP, stop=True, lift_time=0.0, land_time=LAND_TIME, touchdown_speed=0.0,
        mesh=(2 * sum(step.mesh[:-1]),), phases=None,
    )  # fmt: skip
    return replace(other, phases=_phases(other, transcription))


def standing_rows(step: FootedStep, ocp: OCP, at: str) -> OCP:
    """``ocp`` (a flat phase of ``step``) with quiet standing at ``at`` ("start" or "end"):
    ``standing feet`` (the swing ball at the stance ball, m), ``standing flat`` (the soles
    flat, rad), at rest (dpsi = 0; ``at rest``: ddpsi = 0). At the start both feet's angles
    and every rate are rows (the phase's ``foot flat`` row must go: it would repeat them); at
    the end the welded stance foot's are left out (its bound ddpsi = 0 from a flat start at
    rest holds them already: rows that repeat it would be dependent)."""
    n = step.linkage.n
    root, foot = step.biped.stance_leg[0], step.biped.swing_leg[-1]
    flat_stance, flat_swing = step.flat_angles
    swing_toe = step.point("swing_toe").function("position")
    stance_toe = step.point("stance_toe").function("position")

    def feet(p):
        return ca.vertcat(*swing_toe(p.x[:n])) - ca.vertcat(*stance_toe(p.x[:n]))

    def flat(p):
        swing = p[f"psi_{foot}"] - flat_swing
        return ca.vertcat(p[f"psi_{root}"] - flat_stance, swing) if at == "start" else swing

    moving = [i for i in range(n) if step.linkage.names[i] != root]
    rows = 2 if at == "start" else 1
    scale = rate_scales(step.time_unit)  # the rates' and accelerations' nominal sizes
    ocp = (
        ocp.boundary("standing feet", feet, at=at, lower=[0.0, 0.0], upper=[0.0, 0.0],
                     scale=step.leg_length)
        .boundary("standing flat", flat, at=at, lower=[0.0] * rows, upper=[0.0] * rows)
    )  # fmt: skip
    if at == "start":
        ocp = ocp.initial(dpsi=[0.0] * n)
    else:
        ocp = ocp.boundary("standing still", lambda p: p.dpsi[moving], at=at, lower=0.0,
                           upper=0.0, scale=scale["dpsi"])  # fmt: skip
    return ocp.boundary("at rest", lambda p: p.ddpsi[moving], at=at, lower=0.0, upper=0.0,
                        scale=scale["ddpsi"])  # fmt: skip


#: Default intervals per phase of each sequence.
MESHES = {
    PHASES: (20, 10, 30),
    SEQUENCES["flat-footed"]: (30, 30),
    SEQUENCES["toe-walking"]: (30, 10),
}


def _sequence(phases) -> tuple[str, ...]:
    """``phases`` (a name of :data:`SEQUENCES` or a tuple of phase names) as the tuple."""
    if isinstance(phases, str):
        if phases not in SEQUENCES:
            raise DefinitionError(
                f"`phases`: one of {sorted(SEQUENCES)} or their phase tuples, got {phases!r}"
            )
        return SEQUENCES[phases]
    sequence = tuple(phases) if isinstance(phases, tuple | list) else None
    if sequence not in SEQUENCES.values():
        listed = "; ".join(f"{name}: {seq}" for name, seq in SEQUENCES.items())
        raise DefinitionError(
            f"`phases`: a sequence of contact phases the step knows ({listed}), got "
            f"{phases!r}; the double support must end the step (the legs swap at toe-off)"
        )
    return sequence


#: Step length at 1 m/s, m, of :func:`step_at_speed`.
STEP_LENGTH_AT_1 = 0.5


def step_at_speed(speed: float) -> tuple[float, float]:
    """(step length m, step time s) of a walk at ``speed`` m/s: the length 0.5 (v / 1 m/s)^(1/2)
    m and the time length / v, so that both the step and the cadence grow with speed, as in
    human walking (0.387 m in 0.645 s at 0.6 m/s, 0.5 m in 0.5 s at 1 m/s, 0.592 m in
    0.423 s at 1.4 m/s)."""
    speed = check_positive("speed", speed, "m/s")
    length = STEP_LENGTH_AT_1 * math.sqrt(speed)
    return length, length / speed


def footed_step_at(speed: float, **options) -> FootedStep:
    """:func:`footed_step` at ``speed`` m/s (:func:`step_at_speed`): a study's axis."""
    length, duration = step_at_speed(speed)
    return footed_step(step_length=length, step_time=duration, **options)


# ---- the guess ---------------------------------------------------------------------------------
def _guessed_durations(step: FootedStep) -> tuple[float, ...]:
    """Each phase's duration, s: the fixed durations, or the guess of free ones
    (:data:`SHARES` of the step time)."""
    return step.durations or tuple(share * step.step_time for share in SHARES[step.sequence])


def _single_support_guess(step: FootedStep) -> float:
    """The single support's guessed duration, s (a stop's whole step)."""
    if step.stop:
        return step.step_time
    return math.fsum(_guessed_durations(step)[:-1])


#: The step length of a stop's guess law, a fraction of the leg (the stop's own is 0: the
#: law (22) fits a step that goes somewhere; the transition guesses the stop from its
#: nearest gait's flat phase in any case)
GUESS_STOP_LENGTH = 0.5


def _law(step: FootedStep) -> GaitLaw:
    """The law (22) of the point-foot biped without the feet (the stance foot welded flat,
    the swing foot dropped), fitted to a step of the same length over the single support;
    the stance foot held flat (zeta = 0), the swing foot turning with its shank (the ankle
    neutral)."""
    linkage = step.linkage
    stance_foot, swing_foot = step.biped.stance_leg[0], step.biped.swing_leg[-1]
    legs = linkage.drop(swing_foot)
    # The point-foot biped: the stance shank on the ground (its foot welded flat).
    welded = legs.lock(stance_foot, step.flat_angles[0])
    # ... standing at H0: the law's postures put the stance foot at the origin
    point_foot = Linkage([replace(welded.links[0], origin=None), *welded.links[1:]],
                         gravity=welded.gravity)  # fmt: skip
    leg = step.leg_length
    lift = GUESS_LIFT * leg
    length = step.step_length if step.step_length > 0 else GUESS_STOP_LENGTH * leg
    law = Biped.of(point_foot).step_law(
        length, _single_support_guess(step), clearance=max(step.clearance, lift) + lift
    )
    names = point_foot.names
    zeta, varpi, center = (np.zeros(linkage.n) for _ in range(3))
    swing_shank = names.index(step.biped.swing_leg[1])
    for i, name in enumerate(linkage.names):
        # the swing foot moves with its shank (the ankle neutral), the stance foot lies flat
        k = names.index(name) if name in names else swing_shank
        zeta[i], varpi[i], center[i] = law.zeta[k], law.varpi[k], law.center[k]
        if name == stance_foot:
            zeta[i], center[i] = 0.0, step.flat_angles[0]
        elif name == swing_foot:
            center[i] -= step.neutral_ankles[1]
    return GaitLaw(law.period, zeta, varpi, center, name="footed step")


# ---- the phases -------------------------------------------------------------------------------
def _phases(step: FootedStep, transcription: str) -> Phases:
    """The listed phases joined: a flat foot's heel rises with the torques continuous, the
    strike maps into the double support, the legs swap at toe-off (the periodicity)."""
    builders = {"flat": _flat_ocp, "heel rise": _heel_rise_ocp, "double": _double_ocp}
    ocps = [builders[name](step, k, transcription) for k, name in enumerate(step.sequence)]
    phases = Phases.sequence((step.sequence[0], ocps[0]))
    if step.stop:  # standing at the end: no strike, no leg swap
        return phases
    for name, ocp in zip(step.sequence[1:], ocps[1:], strict=True):
        if name == "heel rise":
            # The heel rises when the centre of pressure reaches the ball: the torques pass
            # the join continuously (the ground's torque on the foot reaches 0 at the flat
            # phase's end), as across an interior node.
            phases = phases.then(name, ocp, controls="continuous")
        else:
            phases = phases.then(name, ocp, mapping=step.strike.state_function())
    return phases.periodic(step.biped.swap.state_function())


def _duration_bounds(step: FootedStep) -> list[tuple[float, float]]:
    T = step.step_time
    if step.durations is None:
        return [(lo * T, hi * T) for lo, hi in SHARE_BOUNDS[step.sequence]]
    # fixed: a band of round-off around each (a free duration needs lower < upper)
    return [(d * (1 - 1e-12), d * (1 + 1e-12)) for d in step.durations]


def _parameters(step: FootedStep) -> list[str]:
    """The static parameters of the durations of every phase but the last (the double
    support takes the rest of the step time)."""
    return [DURATION_PARAMETERS[name] + step.label for name in step.sequence[:-1]]


def _base_ocp(step: FootedStep, phase: int, transcription: str, contacts=()):
    """(a phase's OCP, its duration row for :func:`_duration_row`): free duration tied to
    the step's duration parameters (:func:`_parameters`: static, shared by the phases: the
    double support takes the rest of the step time), drives bounded, knees, ankles and
    posture in range, the objective and scales."""
    T = step.step_time
    guesses = _guessed_durations(step)
    bounds = _duration_bounds(step)
    ocp = OCP(step.dynamics, T=bounds[phase], N=step.mesh[phase], transcription=transcription,
              contacts=contacts).guess(T=guesses[phase])  # fmt: skip
    parameters = _parameters(step)
    for k, name in enumerate(parameters):
        ocp = ocp.param(name, *bounds[k], guess=guesses[k], scale=T)
    for name, limit in step.limits.items():
        ocp = ocp.bound(f"M_{name}", -limit, limit)
    biped = step.biped
    stance_foot, stance_shank, stance_thigh = biped.stance_leg
    swing_thigh, swing_shank, swing_foot = biped.swing_leg

    def knees(p):
        return ca.vertcat(p[f"psi_{stance_thigh}"] - p[f"psi_{stance_shank}"],
                          p[f"psi_{swing_thigh}"] - p[f"psi_{swing_shank}"])  # fmt: skip

    neutral_stance, neutral_swing = step.neutral_ankles

    def ankles(p):
        """Plantarflexion from the neutral stance, rad (> 0: the toes down)."""
        return ca.vertcat(
            p[f"psi_{stance_shank}"] - p[f"psi_{stance_foot}"] - neutral_stance,
            p[f"psi_{swing_shank}"] - p[f"psi_{swing_foot}"] - neutral_swing,
        )

    def duration(p):
        if phase < len(parameters):
            return p.T - p[parameters[phase]]
        return _summed(p, parameters, p.T) - step.step_time

    ocp = ocp.constrain(
        "knees", knees, lower=step.knee_range[0], upper=step.knee_range[1]
    ).constrain("ankles", ankles, lower=step.ankle_range[0], upper=step.ankle_range[1])
    ocp = keep_upright(ocp, biped.upper_body, step.posture)
    ocp = bound_stance_hip(ocp, step.linkage, biped.stance_thigh, step.hip_limit)
    ocp = bound_joint_speeds(ocp, step.linkage, biped, step.drives, step.speed_limit)
    limit = step.torque_limit
    drives = [step.linkage.index(name) for name in step.drives]
    if step.human is None:
        integrand = lambda p: ca.sumsqr(p.M[drives])  # noqa: E731
    else:
        integrand = human_integrand(step.linkage, step.human, step.drives, step.neutral_ankles)
    ocp = ocp.minimize(integral=integrand).scale(M=limit / 3.0, **rate_scales(step.time_unit))
    return ocp, duration


#: The guess's stance ankle bends at most this far (dorsiflexion, rad) before the heel rises
#: with the shank.
GUESS_DORSIFLEXION = math.radians(10.0)


def _guess_law(step: FootedStep, offset: float, heel_rises: bool = False):
    """The law from ``offset`` s on; with ``heel_rises`` the stance foot turns with its shank
    (the heel up) once the ankle has bent by :data:`GUESS_DORSIFLEXION`."""
    law = step.law
    foot, shank = (step.linkage.index(name) for name in step.biped.stance_leg[:2])
    flat, neutral = step.flat_angles[0], step.neutral_ankles[0]

    def guess(t):
        psi, dpsi, ddpsi = law.psi(t + offset), law.dpsi(t + offset), law.ddpsi(t + offset)
        if heel_rises:
            turned = psi[:, shank] - neutral + GUESS_DORSIFLEXION
            rising = turned < flat
            psi[:, foot] = np.where(rising, turned, flat)
            dpsi[:, foot] = np.where(rising, dpsi[:, shank], 0.0)
            ddpsi[:, foot] = np.where(rising, ddpsi[:, shank], 0.0)
        return psi, dpsi, ddpsi

    return guess


def _stance_cone(step: FootedStep):
    reaction = step.dynamics.function("ground_reaction")
    toe = step.contacts["stance_toe"]
    return reaction, lambda p: toe.cone(*reaction(p.psi, p.dpsi, p.ddpsi))


def _summed(p, names: list[str], start=None):
    """``start`` + p[names[0]] + p[names[1]] + ..., added left to right (0.0 for no terms):
    the order the NLP's round-off was measured with (another association of the same sum
    took the first solve from 80 IPOPT iterations to 155)."""
    terms = [p[name] for name in names]
    if start is None:
        start, terms = (terms[0], terms[1:]) if terms else (0.0, [])
    return functools.reduce(operator.add, terms, start)


def _offset(step: FootedStep, phase: int, p):
    """The phase's start within the single support, s (a sum of duration parameters)."""
    return _summed(p, _parameters(step)[:phase])


def _swing_clearance(step: FootedStep, phase: int, p):
    """Swing heel and ball above the clearance profile of the single support."""
    parameters = _parameters(step)
    single = _summed(p, parameters) if parameters else p.T  # a stop's: its one phase
    s = (p.t + _offset(step, phase, p)) / single
    floor = clearance_profile(s, single, step.clearance, step.touchdown_speed, step.approach_time,
                              step.lift_time, step.land_time)  # fmt: skip
    heights = step.heights("swing_heel", "swing_toe")(p.psi)
    return heights - ca.vertcat(floor, floor)


def _duration_row(step: FootedStep, ocp: OCP, duration) -> OCP:
    return ocp.boundary("duration", duration, at="start", lower=0.0, upper=0.0,
                        scale=step.step_time)  # fmt: skip


def _welded(step: FootedStep, ocp: OCP) -> OCP:
    """The root foot welded flat on the ground: no angular acceleration at any point (flat
    and at rest where it comes onto the ground, the collocation then keeps it there exactly).
    Bounding its angle and rate at every point as well would leave the defect rows of those
    two states without a free variable (empty rows: a degenerate NLP)."""
    return ocp.bound(f"ddpsi_{step.biped.stance_leg[0]}", 0.0, 0.0)


def _pressure_row(step: FootedStep, ocp: OCP, rear_force=None) -> OCP:
    """The centre of pressure of the ground's torque on the flat root foot between heel and
    ball: -sole Fy <= M_0 <= 0, Fy the vertical force on it (``rear_force(p)``, default the
    whole ground reaction)."""
    root = step.biped.stance_leg[0]
    reaction = step.dynamics.function("ground_reaction")
    sole = step.sole

    def pressure(p):
        """-sole Fy <= M_0 <= 0: the centre of pressure between heel and ball."""
        fy = (reaction(p.psi, p.dpsi, p.ddpsi) if rear_force is None else rear_force(p))[1]
        moment = p[f"M_{root}"]
        return ca.vertcat(-moment, moment + sole * fy)

    return ocp.constrain("centre of pressure", pressure, lower=0.0, scale=step.weight * sole)


def _strike_rows(step: FootedStep, ocp: OCP) -> OCP:
    """The single support's end: the striking point lands at :attr:`FootedStep.landing`
    coming down at the touchdown speed or faster, its impulse and the held stance ball's in
    their friction cones (and, the stance foot welded flat, the angular impulse on it
    between heel and ball)."""
    n = step.linkage.n
    point = step.point(step.strike_role)
    position, velocity = point.function("position"), point.function("velocity")
    speed = max(step.step_length, SPEED_SCALE * step.biped.leg_length) / step.step_time
    front, rear = step.contacts[step.strike_role], step.contacts["stance_toe"]
    strike, sole = step.strike, step.sole

    def impulses(p):
        psi, dpsi = p.x[:n], p.x[n:]
        _, impulse, behind = strike.held_impulses(psi, dpsi)
        rows = [front.cone(impulse[0], impulse[1]), rear.cone(behind[0], behind[1])]
        if strike.root_welded:  # where the impulse on the flat foot acts: on the sole
            angular = strike.root_angular_impulse(psi, dpsi)
            rows.append(ca.vertcat(-angular / sole, angular / sole + behind[1]))
        return ca.vertcat(*rows)

    if step.human is not None and step.human.collision > 0:
        ocp = ocp.minimize(terminal=strike_collision(step, step.human.collision),
                           name="collision")  # fmt: skip
    return (
        ocp.boundary("landing", lambda p: ca.vertcat(*position(p.x[:n])), at="end",
                     lower=[step.landing, 0.0], upper=[step.landing, 0.0],
                     scale=step.step_length)
        .boundary("heel strike", lambda p: velocity(p.x[:n], p.x[n:])[1], at="end",
                  upper=-step.touchdown_speed, scale=speed)
        .boundary("impulse", impulses, at="end", lower=0.0, scale=step.biped.total_mass * speed)
    )  # fmt: skip


def _flat_ocp(step: FootedStep, phase: int, transcription: str) -> OCP:
    ocp, duration = _base_ocp(step, phase, transcription)
    ocp = _welded(step, ocp)
    root = step.biped.stance_leg[0]
    flat = step.flat_angles[0]
    # Flat and at rest at the start: the periodicity brings the front foot of the step
    # before flat and at rest too.
    ocp = ocp.boundary("foot flat", lambda p: ca.vertcat(p[f"psi_{root}"] - flat,
                                                         p[f"dpsi_{root}"]),
                       at="start", lower=0.0, upper=0.0)  # fmt: skip
    _, cone = _stance_cone(step)
    ocp = _pressure_row(step, ocp.constrain("friction", cone, lower=0.0, scale=step.weight))
    ocp = ocp.constrain("clearance", lambda p: _swing_clearance(step, phase, p), lower=0.0,
                        scale=step.clearance_scale)  # fmt: skip
    if step.stop:  # the duration free in its bounds; standing at the end
        return standing_rows(step, ocp, "end").guess(_guess_law(step, 0.0))
    ocp = _duration_row(step, ocp, duration)
    if step.sequence[phase + 1] == "double":  # flat-footed: the swing heel strikes now
        ocp = _strike_rows(step, ocp)
    return ocp.guess(_guess_law(step, 0.0))


def _heel_rise_ocp(step: FootedStep, phase: int, transcription: str) -> OCP:
    ocp, duration = _base_ocp(step, phase, transcription)
    root = step.biped.stance_leg[0]
    ocp = ocp.bound(f"M_{root}", 0.0, 0.0)
    _, cone = _stance_cone(step)
    heel_height = step.heights("stance_heel")
    scale = step.clearance_scale
    ocp = (
        ocp.constrain("friction", cone, lower=0.0, scale=step.weight)
        .constrain("stance heel up", lambda p: heel_height(p.psi), lower=0.0, scale=scale)
        .constrain("clearance", lambda p: _swing_clearance(step, phase, p), lower=0.0,
                   scale=scale)
    )  # fmt: skip
    offset = math.fsum(_guessed_durations(step)[:phase])
    return _strike_rows(step, _duration_row(step, ocp, duration)).guess(
        _guess_law(step, offset, heel_rises=True)
    )


def _double_ocp(step: FootedStep, phase: int, transcription: str) -> OCP:
    """Both feet on the ground: the stance ball pinned, the front foot's striking point a
    contact whose ground force F is a control, held at rest by its acceleration; the rear
    foot flat (flat-footed) or on its ball, unloading; a front foot that struck with its
    heel rolls down and arrives flat (the periodicity), one that struck with its ball keeps
    its heel up."""
    front = step.contacts[step.strike_role]
    ocp, duration = _base_ocp(step, phase, transcription, contacts=(front,))
    root = step.biped.stance_leg[0]
    reaction = step.dynamics.function("ground_reaction")
    acceleration = step.point(step.strike_role).function("acceleration")
    rear = step.contacts["stance_toe"]
    weight = step.weight

    def rear_force(p):
        fx, fy = reaction(p.psi, p.dpsi, p.ddpsi)
        return fx - p.F[0], fy - p.F[1]

    def cones(p):
        return ca.vertcat(rear.cone(*rear_force(p)), front.cone(p.F[0], p.F[1]))

    scale = step.clearance_scale
    if not step.rear_flat:
        ocp = ocp.bound(f"M_{root}", 0.0, 0.0)
    ocp = (
        ocp.constrain("heel held", lambda p: ca.vertcat(*acceleration(p.psi, p.dpsi, p.ddpsi)),
                      lower=0.0, upper=0.0, scale=step.linkage.gravity)
        .constrain("friction", cones, lower=0.0, scale=weight)
        .constrain("rear unloads",
                   lambda p: rear_force(p)[1] - weight * (2.0 - (2.0 - UNLOADED) * p.t / p.T),
                   upper=0.0, scale=weight)
    )  # fmt: skip
    ocp = _duration_row(step, ocp, duration)
    if step.rear_flat:  # the rear foot stays welded, its pressure on its sole
        ocp = _pressure_row(step, _welded(step, ocp), rear_force)
    else:
        heel_height = step.heights("stance_heel")
        ocp = ocp.constrain("stance heel up", lambda p: heel_height(p.psi), lower=0.0,
                            scale=scale)  # fmt: skip
    ocp = ocp.scale(F=weight / 2)
    swing_foot = step.biped.swing_leg[-1]
    if step.strike_role == "swing_heel":
        # The front ball above the ground while the foot turns down about its held heel:
        # the foot at or above its flat angle, a bound (a row of the ball's height would be
        # active and implied at the end, where the periodicity lays the foot flat: a
        # degenerate row that cost IPOPT hundreds of iterations in the re-solves).
        ocp = ocp.bound(f"psi_{swing_foot}", step.flat_angles[1], None)
    else:
        front_heel = step.heights("swing_heel")
        ocp = ocp.constrain("front heel up", lambda p: front_heel(p.psi), lower=0.0,
                            scale=scale)  # fmt: skip
    strike = step.law.psi(np.array([_single_support_guess(step)]))[0]
    return ocp.guess(psi=strike, dpsi=0.0, ddpsi=0.0, F=[0.0, weight / 2])


# ---- the solved step ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class FootedGait(SteppingGait):
    """A solved step on feet: :class:`problems.walking.step.SteppingGait` (cost, law_cost,
    positive_work, cost_of_transport, summary, to_trajectory, world) and what the feet
    change: each contact's ground reaction, one leg's stance, the ankles' power."""

    def _sampled(self, count: int):
        """Per phase: (times on the common axis (K,), psi, dpsi, ddpsi (K, n), controls (K, nu))
        of the consistent motion (``Solution.motion``) on a uniform grid."""
        n = self.problem.linkage.n
        for solution, start in self.segments():
            grid = np.linspace(0.0, solution.T, max(2, round(count * solution.T / self.duration)))
            x, xdot, u = solution.motion(grid)
            yield start + grid, x[:, :n], x[:, n:], xdot[:, n:], u

    def stance(self, count: int = 801) -> dict[str, np.ndarray]:
        """One leg through its stance, from its heel strike to its toe-off (the front foot
        of the double support, then the stance foot of the next step: the gait is periodic,
        so the front foot's double support is this step's, shifted): ``time`` (K,) s from
        strike, ``force`` (K,) complex, N, the ground's force on that foot,
        ``pressure`` (K,) m, where it pushes, along x from the ball (the heel, -sole, while
        the foot rolls down onto it; the centre of pressure of the ground's torque while it
        lies flat; the ball after; the ball throughout when it struck with its ball),
        ``ankle_power`` (K,) W, the ankle drive's power
        M (dpsi_shank - dpsi_foot)."""
        step = self.problem
        linkage = step.linkage
        # joint_rates: each hinge's rate relative to its parent, so the stance shank's is the
        # stance ankle's and the swing foot's the swing ankle's
        stance_shank = linkage.index(step.biped.stance_leg[1])
        swing_foot = linkage.index(step.biped.swing_leg[-1])
        times, force, pressure, power = [], [], [], []
        # where the front foot pushes in the double support: its heel, or its ball
        strike = -step.sole if step.strike_role == "swing_heel" else 0.0
        phases = zip(self._sampled(count), step.sequence, strict=True)
        for (t, psi, dpsi, ddpsi, u), name in phases:
            total = step.dynamics.ground_reaction(psi, dpsi, ddpsi)
            front = u[:, linkage.n] + 1j * u[:, linkage.n + 1] if name == "double" else 0.0
            rates = joint_rates(linkage, dpsi)
            if name == "double":  # as the front foot, before this leg's stance
                times.insert(0, t - self.duration)
                force.insert(0, np.asarray(front))
                pressure.insert(0, np.full(t.size, strike))
                power.insert(0, u[:, swing_foot] * rates[:, swing_foot])
            times.append(t)
            force.append(total - front)
            # the root's torque is the ground's: 0 once the foot stands on its ball
            pressure.append(centre_of_pressure(u[:, 0], total - front))
            power.append(u[:, stance_shank] * rates[:, stance_shank])
        start = times[0][0]
        return {"time": np.concatenate(times) - start, "force": np.concatenate(force),
                "pressure": np.concatenate(pressure),
                "ankle_power": np.concatenate(power)}  # fmt: skip

    def summary(self, rate_hz: float | None = RATE_HZ) -> dict[str, Any]:
        """:meth:`Gait.summary` (of the samples at ``rate_hz``) plus speed, cost of
        transport, the phases' durations (s), and
        one leg's stance: the largest vertical ground force (body weights) and the ankle's
        push-off (its largest power, W; when, as a fraction of the stance; its positive work,
        J)."""
        stance = self.stance()
        return {
            **super().summary(rate_hz),
            "speed": self.speed,
            "cost_of_transport": self.cost_of_transport,
            "durations": dict(zip(self.problem.sequence, self.durations(), strict=True)),
            "peak_vertical_force": float(stance["force"].imag.max() / self.problem.weight),
            "push_off": push_off(stance),
        }

    def durations(self) -> tuple[float, ...]:
        return tuple(float(solution.T) for solution, _ in self.segments())

    def strike_impulses(self) -> dict[str, complex]:
        """The ground's impulses at the strike (:attr:`FootedStep.strike` at the single
        support's last node), N s as x + iy: ``front`` on the striking heel (or ball),
        ``rear`` on the held stance ball; and each one's friction use |Lx| / Ly
        (``front_friction``, ``rear_friction``: the strike needs a ground of at least that
        mu; inf for an impulse that pulls). A stop has no strike: DefinitionError."""
        step = self.problem
        if step.stop:
            raise DefinitionError("`strike_impulses`: a stop sets its foot down without a strike")
        n = step.linkage.n
        single = [s for s, name in zip(self.solution.phases, step.sequence, strict=True)
                  if name != "double"][-1]  # fmt: skip
        x = np.asarray(single.states[-1], dtype=float)
        _, front, rear = step.strike.held_impulses(ca.DM(x[:n]), ca.DM(x[n:]))
        front, rear = (np.array(ca.evalf(v), dtype=float).ravel() for v in (front, rear))
        impulses = {"front": complex(front[0], front[1]), "rear": complex(rear[0], rear[1])}
        for key, value in list(impulses.items()):
            use = abs(value.real) / value.imag if value.imag > 0.0 else math.inf
            impulses[f"{key}_friction"] = use
        return impulses

    def to_trajectory(self, rate_hz: float | None = None):
        """:meth:`Gait.to_trajectory`; a stop's (:attr:`FootedStep.stop`) with the front
        contact's force channels too, zero (its swing foot sets down unloaded), so that its
        rows join a walk's file, whose steps carry them for their double supports."""
        trajectory = super().to_trajectory(rate_hz)
        if not self.problem.stop:
            return trajectory
        zero = np.zeros(np.asarray(trajectory.time).size)
        for name in contact_force_names(self.problem.strike_role):
            trajectory = trajectory.with_extra(name, zero, "N")
        return trajectory


def push_off(stance: Mapping[str, np.ndarray]) -> dict[str, float]:
    """The ankle's push-off in a stance (``time`` (K,) s, ``ankle_power`` (K,) W, as
    :meth:`FootedGait.stance` gives them): its largest power ``power`` (W), when (``at``, a
    fraction of the stance) and its positive work ``work`` (J)."""
    time, power = stance["time"], stance["ankle_power"]
    k = int(np.argmax(power))
    return {
        "power": float(power[k]),
        "at": float((time[k] - time[0]) / (time[-1] - time[0])),
        "work": float(np.trapezoid(np.maximum(power, 0.0), time)),
    }
