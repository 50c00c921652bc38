"""The hybrid walking step: single support, heel strike, leg swap, periodic across steps.

One step of duration T (``step_time``) on the stance foot pinned at H0 (the origin): the swing
foot leaves the ground behind at (-s, 0) and lands at (s, 0) (``step_length`` s: the distance
between the feet at heel strike; the body advances s per step). At heel strike the landing
foot sticks (inelastic, non-sliding impact, ``model.impact``), the old stance foot lifts off
and the legs swap roles (``model.swap_legs``); the next step starts from the swapped state,
so the gait is the periodic orbit x(0) = Delta(x(T)), Delta = relabel o impact
(``OCP.periodic(Delta)``).

Constraints (names as in the OCP, each row scaled by a nominal magnitude):

* ``friction``: the stance foot's ground reaction F = Fx + j Fy (``ground_reaction``, from
  psi, dpsi and ddpsi) inside the friction cone at every dynamics point, mu Fy -+ Fx >= 0
  (which implies Fy >= 0: the foot pushes, it is not pulled);
* ``clearance``: the swing foot's height >= the clearance profile at every dynamics point
  (default h sin^2(pi t / T) + v_td (T - t) exp(-((T - t) / w)^4), h = ``clearance``: the
  mid-swing height, and in the last instants the line coming down into the landing point at
  the touchdown speed v_td, w = ``approach_time``, so that the foot does not graze in: see
  ``touchdown_speed``; their defaults scale with the walker, :mod:`problems.gait.similarity`);
* ``ground``: every other point of the body (each link's end: knees, hip, neck, head top,
  the joints of any upper body; ``ground_points``) at or above ``ground_margin`` at every
  dynamics point;
* ``centre of pressure``: the ankle torque M at the stance foot implies a centre of
  pressure x_p = M / Fy from the ankle (a point foot cannot transmit a torque: a real foot
  puts its pressure there); it stays on the sole, -heel <= x_p <= toe (``foot``), written
  -heel Fy <= M <= toe Fy (so that it holds as Fy -> 0);
* ``landing`` (t = T): the swing foot at (s, 0); ``lift off`` (t = 0): it moves up; ``heel
  strike`` (t = T): it moves down at ``touchdown_speed`` or faster;
* ``impulse`` (t = T): the ground's impulse on the landing foot in the friction cone,
  mu Ly -+ Lx >= 0. After the impact the old stance foot moves with the base velocity of the
  impact map, which through the periodicity is the new swing foot's velocity at t = 0: the
  ``lift off`` row is that old foot's vertical velocity >= 0 (one row, not two equal ones);
* ``knees``: flexion psi_thigh - psi_shank of both legs in ``knee_range`` (0: straight; no
  hyperextension);
* ``posture``: each link of ``upright`` within ``posture`` rad of the vertical pi/2;
* torque bounds |M_i| <= ``torque_limit``; ``passive`` hinges have M_i = 0 (a passive
  ankle: ``passive=("stance_shank",)``, the torque at H0).

Objective (``problems.gait.problem.OBJECTIVES``): ``"torque"`` (default) the integral of
sum M_i^2, ``"torque-rate"`` or ``"work"`` (positive mechanical work).

The guess is the law (22) fitted to the step (:meth:`problems.gait.biped.Biped.step_law`); its cost
on the same mesh, torques by inverse dynamics, is the benchmark to beat (``law_cost``).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from functools import cached_property
from types import MappingProxyType
from typing import Any, ClassVar

import casadi as ca
import numpy as np

from model.dynamics import Dynamics
from model.linkage import Linkage
from model.presets import six_link_anthropoid
from model.rotors import Rotor, ground_moment_row, rotor_settings
from planner.errors import (
    DefinitionError,
    DefinitionTypeError,
    check_integer,
    check_positive,
    check_real,
)
from planner.problem import OCP, Phases
from planner.transcription import Transcription
from problems.gait.accuracy import resolve_mesh, solve_plan
from problems.gait.biped import Biped
from problems.gait.law import GaitLaw
from problems.gait.problem import (
    RATE_HZ,
    Gait,
    bound_joint_speeds,
    bound_stance_hip,
    check_links,
    check_objective,
    finish_gait_ocp,
    gait_ocp,
    keep_upright,
    objective_at_guess,
    refine_and_hold,
    solve_and_hold,
    torque_limits,
    verified,
)
from problems.gait.similarity import WalkerScales
from problems.walking.feet import WalkerFeet

#: The largest part of the weight on the rear foot when a double support ends.
UNLOADED = 0.05

# Nominal magnitudes come from the step's own data (leg length, weight, step length and time,
# torque limits), never from constants in metres or newtons, so that the same step written in
# other units (millimetres and grams) is the same scaled NLP for IPOPT. The fractions:

#: Scale of the clearance rows (foot height minus the profile): the mid-swing clearance, or
#: this fraction of the leg length when that is smaller (0.043 m for the six-link legs).
CLEARANCE_SCALE = 0.05
#: Least speed scale of the lift-off, heel-strike and impulse rows: this fraction of the leg
#: length per step time (a short step in place keeps a meaningful scale).
SPEED_SCALE = 0.1
#: The fitted law's guess lifts the foot by this fraction of the leg length above the
#: clearance, and at least that high: 2 cm for the six-link legs (0.86 m), the height the
#: guess used in metres before (a rounder 0.02 took 30 iterations instead of 29 for the
#: default step, 61 instead of 41 with a 0.05 s double support: the same optima).
GUESS_LIFT = 0.02 / 0.86
#: Rows the step's boundary conditions fix at its ends: the swing foot lifts off from and
#: lands on the ground, where its clearance profile is 0 (:func:`planner.hold_at_samples`).
PINNED = ("clearance",)
#: The default sole: from the ankle (the stance foot's contact point) back to the heel and
#: forward to the toe, in leg lengths: (0.05, 0.15) m, a 0.20 m foot, for the six-link's
#: 0.86 m legs.
FOOT = (0.05 / 0.86, 0.15 / 0.86)
#: What ``clearance``, ``touchdown_speed``, ``approach_time`` and ``foot`` take for their
#: defaults (scaled with the walker: :mod:`problems.gait.similarity`).
DEFAULT = "default"


def clearance_profile(s, T, height: float, touchdown_speed: float, window: float,
                      lift: float = 0.0, land: float = 0.0):  # fmt: skip
    """The swing foot's least height at normalised times s = t / T of a single support of
    T s (numpy or SX), m: h sin^2(pi s) + v_td (T - t) exp(-((T - t) / w)^4), w = ``window``,
    s (the step's ``approach_time``; see the module docstring). ``lift`` > 0 (s): the swing
    term times 1 - exp(-(t / lift)^2), a floor that starts flat for a foot that lifts from
    rest (a start from standing: h sin^2 alone curves up at once, and a foot at rest with no
    acceleration meets that curvature only by a jerk in the first interval). ``land`` > 0
    (s): the same at the end, times 1 - exp(-((T - t) / land)^2), a floor that ends flat for
    a foot that sets down at rest (a stop at standing)."""
    symbolic = isinstance(s, ca.SX | ca.MX) or isinstance(T, ca.SX | ca.MX)
    exp = ca.exp if symbolic else np.exp
    if symbolic:
        swing = ca.sin(math.pi * s) ** 2
    else:
        s = np.asarray(s, dtype=float)
        swing = np.sin(np.pi * s) ** 2
    fade = exp(-(((1 - s) * T / window) ** 4))
    if lift > 0:
        swing = swing * (1 - exp(-((s * T / lift) ** 2)))
    if land > 0:
        swing = swing * (1 - exp(-(((1 - s) * T / land) ** 2)))
    return height * swing + touchdown_speed * (1 - s) * T * fade


#: s: the first step of a start from standing lifts its foot from rest under a floor that
#: starts flat over this time (``lift``, ``WalkingStep.lift_time``, ``FootedStep.lift_time``):
#: under the periodic step's floor, which curves up at once, the foot on feet jerked off the
#: ground in the first 10 ms (the swing knee -80.6 N m at 3 ms, the ground's torque on the
#: stance foot -159 N m; measured at 0 -> 1 m/s)
LIFT_TIME = 0.05
#: s: a stop's last step sets its foot down under a floor that ends flat over this time
#: (``land``, ``WalkingStep.land_time``, ``FootedStep.land_time``): a foot at rest with no
#: acceleration at T meets the plain floor's curvature there only by a jerk in the last mesh
#: interval (on point feet the largest drive torque over the last 20 ms of a stop from 1 m/s
#: is 75.8 N m without it, 17.1 N m with it: examples/benchmarks/stops.py)
LAND_TIME = 0.05


@dataclass(frozen=True, eq=False)
class WalkingStep(WalkerFeet):
    """A walking step as a problem: the :class:`planner.OCP` (``ocp``, a value the user can
    still change with ``.bound``, ``.constrain``, ``.refine``, ...) and what a gait needs
    around it (the biped, its model, the foot, the impact and step maps, the fitted law).

    ``solve(ocp=None, accuracy=None, **options)`` solves ``ocp`` (or a changed copy) and
    returns a :class:`WalkingGait`. ``accuracy``: the preset the step was built with
    (``walking_step(accuracy=...)``), whose IPOPT tolerance ``solve`` uses, or None.
    """

    biped: Biped
    dynamics: Dynamics
    step_length: float
    step_time: float
    mu: float
    clearance: float | Callable
    torque_limit: dict[str, float]
    passive: tuple[str, ...]
    knee_range: tuple[float, float]
    posture: float
    upright: tuple[str, ...]
    objective: str
    law: GaitLaw
    ocp: OCP | None
    double_support: float = 0.0
    phases: Phases | None = None
    accuracy: str | None = None
    touchdown_speed: float = 0.3
    foot_sole: tuple[float, float] | None = (0.05, 0.15)
    ground_points: tuple[str, ...] = ()
    ground_margin: float = 0.0
    approach_time: float = 0.03
    hip_limit: float | None = None
    speed_limit: float | None = None
    landing_speed: float | None = None
    #: s: the clearance floor starts flat over this time (``clearance_profile``'s ``lift``):
    #: the first step of a start from standing, whose foot lifts from rest; 0 for a step whose
    #: foot leaves the ground moving
    lift_time: float = 0.0
    #: s: the floor ends flat over this time (``land``): the last step of a stop, whose foot
    #: sets down at rest
    land_time: float = 0.0

    @property
    def linkage(self) -> Linkage:
        return self.biped.linkage

    @cached_property
    def impact(self):
        """The heel strike of the swing foot (``model.ImpactMap``): the old stance foot free
        to lift off, or held when a double support follows."""
        return self.dynamics.impact(self.foot, root_pinned=self.double_support > 0)

    @cached_property
    def step_map(self) -> ca.Function:
        """Delta: x(T) before heel strike -> x(0) of the next step (impact, then leg swap);
        with a double support, x(T_single) -> x of the double support at its start (the
        impact with both feet held; the legs swap when the double support ends)."""
        if self.double_support > 0:
            return self.impact.state_function()
        return self.impact.step_function(self.biped.swap)

    @property
    def single_support_time(self) -> float:
        """Duration of the single support, s: the step time less the double support."""
        return self.step_time - self.double_support

    @property
    def problem(self) -> OCP | Phases:
        """What :meth:`solve` solves: the single-support OCP, or the phases with a double
        support."""
        return self.ocp if self.phases is None else self.phases

    @property
    def driven(self) -> tuple[str, ...]:
        """The links whose start hinge has a drive: all but the ``passive`` ones (the root's
        is the stance ankle, against the ground)."""
        return tuple(name for name in self.linkage.names if name not in self.passive)

    #: Point feet: every link drawn as a line from its start to its end.
    corners: ClassVar[Mapping[str, tuple]] = MappingProxyType({})

    @property
    def time_unit(self) -> float:
        """The walker's time unit sqrt(L / g) over the six-link walker's (its nominal rates
        scale with it: :func:`problems.gait.problem.rate_scales`)."""
        return WalkerScales(self.biped.leg_length, self.linkage.gravity).relative["time"]

    @property
    def speed(self) -> float:
        """Average forward speed, m/s: step_length / step_time."""
        return self.step_length / self.step_time

    @property
    def clearance_height(self) -> float:
        """The mid-swing clearance h, m; for a profile, its largest value at s = 0, 1/4, ...
        1 (>= 0)."""
        if callable(self.clearance):
            return max(float(np.max(self.clearance_at(np.linspace(0.0, 1.0, 5)))), 0.0)
        return self.clearance

    def clearance_at(self, s, T=None):
        """The clearance profile at normalised times s = t / T of the single support (numpy
        or SX), m: the callable ``clearance``, or h sin^2(pi s) + v_td (T - t)
        exp(-((T - t) / w)^4) (the approach term: see the module docstring). ``T``: the
        single support's duration, s (default ``single_support_time``); the OCP passes its
        symbol, so that the NLP's structure does not depend on the duration (a study over
        step times solves one structure)."""
        if callable(self.clearance):
            return self.clearance(s)
        T = self.single_support_time if T is None else T
        return clearance_profile(s, T, self.clearance, self.touchdown_speed, self.approach_time,
                                 self.lift_time, self.land_time)  # fmt: skip

    def _transcription(self, problem: OCP | Phases | None):
        problem = self.problem if problem is None else problem
        if isinstance(problem, OCP) and self.phases is not None:
            # A changed single-support OCP replaces that phase of the double-support problem.
            index = self.phases.index("single")
            phases = list(self.phases.phases)
            phases[index] = ("single", problem)
            problem = replace(self.phases, phases=tuple(phases))
        if isinstance(problem, OCP | Phases):
            return Transcription(problem)
        raise DefinitionTypeError(
            f"`ocp`: must be a planner.OCP (or planner.Phases), got {type(problem).__name__}"
        )

    def law_cost(self, problem: OCP | Phases | None = None) -> float:
        """The objective of the fitted law on the problem's mesh (default this step's): the
        law's angles, rates and accelerations at the mesh points, torques by inverse
        dynamics, integrated by the transcription's own quadrature."""
        return objective_at_guess(self._transcription(problem))

    def solve(
        self,
        ocp: OCP | Phases | None = None,
        accuracy: str | float | None = None,
        *,
        rate_hz: float | None = RATE_HZ,
        hold_limits: bool = True,
        verify: bool = True,
        **options,
    ) -> WalkingGait:
        """Solve this step's problem, or ``ocp`` (a changed copy of :attr:`ocp`, or of
        :attr:`phases` with a double support); ``options`` go to :func:`planner.solve`
        (IPOPT options, progress, ...). Raises :class:`planner.SolverError` on failure unless
        ``raise_on_failure=False``.

        ``hold_limits`` (default): the path constraints and bounds must also hold on the
        exported motion at ``rate_hz`` (the samples of ``gait.to_trajectory(rate_hz)``, Hz;
        None: the nodes) and at points inside every interval: where they miss, the missed
        rows are added there and the step solved again warm-started
        (:func:`planner.sampled_limits.hold_at_samples`; ``stats["sampled_limits"]``);
        :class:`planner.SampleLimitError` when that fails.

        ``verify`` (default): the plan is checked on its samples at ``rate_hz``
        (:func:`problems.verify_gait`, as the command line checks its files; the report is
        ``gait.verification``) and never handed out as a plain success when it fails:
        :class:`problems.GaitVerificationError`, or with ``raise_on_failure=False`` a
        :class:`problems.GaitVerificationWarning` and ``gait.verified`` False.

        ``accuracy``: a preset name (:data:`problems.ACCURACY_PRESETS`: the single-support
        OCP re-meshed with the preset's transcription and density, solved at its tolerance),
        or a number: the mesh refined until the per-interval re-integration error per
        nominal state scale is within it (:func:`planner.refine_to`; single support only;
        ``max_passes``, ``max_intervals`` go there; ``gait.solution.stats["refinement"]``
        is the history). Without it, the tolerance of the preset the step was built with
        applies. ``options={"tol": ...}`` overrides a preset's tolerance.
        """
        remesh, target, options = solve_plan(accuracy, self.accuracy, options)
        if accuracy is not None:
            problem = self.problem if ocp is None else ocp
            if not isinstance(problem, OCP) or self.phases is not None:
                raise DefinitionError(
                    f"`accuracy`: solve(accuracy={accuracy!r}) re-meshes a single-support "
                    "step; with a double support give the preset to walking_step(accuracy=...)"
                    " or the mesh (N) instead"
                )
            if target is not None:
                solution, final = refine_and_hold(
                    problem, target, options, hold_limits, rate_hz, PINNED
                )
                gait = WalkingGait(self, solution, self.law_cost(final))
                return verified(gait, rate_hz, verify, options)
            ocp = problem.refine(**remesh.mesh(self.single_support_time))
        transcription = self._transcription(ocp)
        law = objective_at_guess(transcription)
        solution = solve_and_hold(transcription, options, hold_limits, rate_hz, PINNED)
        gait = WalkingGait(self, solution, law)
        return verified(gait, rate_hz, verify, options)

    def clearance_table(self, times=None) -> dict[str, list[float]] | None:
        """A callable clearance profile as data, so that it travels with the gait's files:
        ``{"s": fractions t / T of the single support, "height": the profile there, m}``,
        sampled at the single-support samples among ``times`` (s; what
        :meth:`Gait.to_trajectory` exports, so :func:`problems.verify_gait` checks each
        sample against the profile's own value), or at s = 0, 0.01, ..., 1 without ``times``.
        None for the default profile (its height ``clearance`` says it all)."""
        if not callable(self.clearance):
            return None
        if times is None:
            fractions = np.linspace(0.0, 1.0, 101)
        else:
            fractions = np.asarray(times, dtype=float) / self.single_support_time
            fractions = fractions[fractions <= 1.0 + 1e-12]
        heights = np.asarray(self.clearance(fractions), dtype=float).reshape(-1)
        if heights.shape != fractions.shape or not np.all(np.isfinite(heights)):
            raise DefinitionError(
                "`clearance`: a profile must map s = t / T (K,) to finite heights (K,), m; "
                f"at {fractions.size} fractions it gave shape {heights.shape}"
            )
        return {"s": fractions.tolist(), "height": heights.tolist()}

    def settings(self, times=None) -> dict[str, Any]:
        """The step's parameters as plain data (exported with the gait's files). A callable
        clearance profile goes in as ``clearance_profile`` (:meth:`clearance_table`, sampled
        at ``times``, s, when given) with ``clearance`` None."""
        table = self.clearance_table(times)
        return {
            **({} if table is None else {"clearance_profile": table}),
            "problem": "walking_step",
            "step_length": self.step_length,
            "step_time": self.step_time,
            "mu": self.mu,
            "clearance": None if callable(self.clearance) else self.clearance,
            "torque_limit": dict(self.torque_limit),
            "passive": list(self.passive),
            "knee_range": list(self.knee_range),
            "posture": self.posture,
            "upright": list(self.upright),
            "hip_limit": self.hip_limit,
            "speed_limit": self.speed_limit,
            "objective": self.objective,
            "swing_foot": self.biped.swing_shank,
            "double_support": self.double_support,
            "touchdown_speed": self.touchdown_speed,
            "landing_speed": self.landing_speed,
            "approach_time": self.approach_time,
            "lift_time": self.lift_time,
            "land_time": self.land_time,
            "leg_length": self.biped.leg_length,
            "foot": None if self.foot_sole is None else list(self.foot_sole),
            "ground_points": list(self.ground_points),
            "ground_margin": self.ground_margin,
            "law": self.law.to_dict(),
            **rotor_settings(self.dynamics.rotors),  # a plan with its drives' rotors
        }


#: Mesh intervals of the single support when neither N nor an accuracy preset is given.
DEFAULT_N = 30


def walking_step(
    linkage: Linkage | None = None,
    step_length: float = 0.5,
    step_time: float = 0.5,
    *,
    N: int | None = None,
    transcription: str | None = None,
    degree: int | None = None,
    formulation: str = "implicit",
    accuracy: str | None = None,
    mu: float = 0.8,
    torque_limit: float | Mapping[str, float] = 150.0,
    passive: Sequence[str] = (),
    clearance: float | Callable | str = DEFAULT,
    knee_range: tuple[float, float] = (0.0, 2.5),
    posture: float = 0.2,
    upright: Sequence[str] | None = None,
    objective: str = "torque",
    swing: tuple[str, str] | None = None,
    double_support: float = 0.0,
    N_double: int | None = None,
    touchdown_speed: float | str = DEFAULT,
    approach_time: float | str = DEFAULT,
    foot: tuple[float, float] | str | None = DEFAULT,
    ground_points: Sequence[str] | None = None,
    ground_margin: float = 0.0,
    hip_limit: float | None = None,
    speed_limit: float | None = None,
    rotors: Sequence[Rotor] = (),
    landing_speed: float | None = None,
    lift_time: float = 0.0,
    land_time: float = 0.0,
) -> WalkingStep:
    """A periodic walking step of a biped (see the module docstring).

    Parameters
    ----------
    linkage : a biped (``model.swap_legs`` accepts it); default the six-link anthropoid.
    step_length : distance between the feet at heel strike, m (> 0).
    step_time : duration of the step, s (> 0).
    N, transcription, degree, formulation : the mesh (``planner.OCP``; default
        Hermite-Simpson, N = 30).
    accuracy : instead of N, transcription and degree, a preset of
        :data:`problems.ACCURACY_PRESETS` ("draft", "balanced", "precise"): its transcription,
        its intervals per second of the single support, and its IPOPT tolerance in
        :meth:`WalkingStep.solve`.
    mu : friction coefficient of the ground (> 0).
    torque_limit : |M_i| bound, N m: one number or one per link name.
    passive : names of links whose hinge torque is 0 (a passive ankle: the stance shank).
    clearance : mid-swing height h of the default profile h sin^2(pi t / T) + v_td (T - t)
        exp(-((T - t) / w)^4), w = ``approach_time``, m (>= 0; default 0.05 m per 0.86 m of
        leg), or a callable of s = t / T (numpy or CasADi SX) giving the minimum height, m
        (taken as it is: no approach term).
    touchdown_speed : v_td, the landing foot's least downward speed at heel strike and the
        slope of the clearance's approach line, m/s (>= 0; default 0.3 m/s for 0.86 m legs
        under 9.81 m/s^2, scaled as sqrt(g L): a millimetre of tracking error moves the
        touchdown by ~3 ms; 0: the foot may graze in).
    approach_time : w, the window of the approach term, s (> 0; default 0.03 s for 0.86 m
        legs under 9.81 m/s^2, scaled as sqrt(L / g)). The defaults of ``clearance``,
        ``touchdown_speed`` and ``approach_time`` follow dynamic similarity
        (:mod:`problems.gait.similarity`): a walker scaled in size or gravity, given its
        step and its drives in the same units, solves to the same dimensionless optimum.
    foot : (heel, toe): the sole extends heel m behind and toe m ahead of the stance foot's
        contact point (the ankle, H0); the centre of pressure M / Fy of the ankle torque stays
        on it (default (0.05, 0.15) m for 0.86 m legs, scaled with the leg length). None: no
        bound (a torque at a point foot, which no robot has); a true point foot is
        ``passive=(stance shank,)``.
    ground_points : links whose end points stay at or above ``ground_margin`` (default: every
        link but the swing shank, whose end is the swing foot: knees, hip, neck, head top and
        any upper body's joints); () for none.
    ground_margin : m (>= 0).
    hip_limit : the physical stance hip's |torque| bound, N m (the drive between the trunk and
        the stance thigh carries M_trunk + M_swing_thigh), or None (each hinge bounded alone).
    speed_limit : every driven joint's |speed| bound, rad/s, at every node (the hips as the
        robot's drives turn them: each thigh against the trunk; a driven stance ankle against
        the ground), or None: a geared drive's speed (its motor's over its ratio).
    rotors : geared motors' rotors in the equations of motion (``model.Rotor``: their
        reflected inertia; :func:`problems.drives.drives_in_the_loop` mounts a walker's
        drives), () for ideal torque sources.
    landing_speed : the landing foot's largest horizontal speed at heel strike, m/s (> 0), or
        None: free. The impact stops the foot whatever its speed, so the optimum may swing it
        in fast: with a 0.05 s double support the default step's foot lands at 7.2 m/s
        (1.9 m/s without one); a real floor stops it by friction over milliseconds, and a
        foot that fast slides (examples/feedback.md: 1 m/s lets MuJoCo's walker take a
        lower ground too).
    lift_time, land_time : s (>= 0): the clearance floor's sine term starts (ends) flat over
        this time (:func:`clearance_profile`'s ``lift`` and ``land``): a first step from
        standing, whose foot lifts from rest, and a stop's last, whose foot sets down at rest
        (the floor's curvature at its ends meets a foot at rest with no acceleration only by a
        jerk in the first or last mesh interval); 0, the default, for steps between steps.
    knee_range : (lower, upper) knee flexion psi_thigh - psi_shank, rad, both legs.
    posture : largest deviation of an upright link from the vertical, rad.
    upright : links kept near upright (default: every upper-body link).
    objective : "torque" or "work" (see the module docstring).
    swing : (swing thigh, swing shank) when several two-link chains hang at the hip.
    double_support : duration of a double support after heel strike, s (0: none, the legs
        swap at heel strike). With one, the step is two phases (``planner.Phases``): single
        support for step_time - double_support, the impact with both feet held, then both
        feet on the ground (the landing foot's ground force a control, held at rest by its
        acceleration; both reactions in their friction cones) until the rear foot lifts off
        and the legs swap.
    N_double : mesh intervals of the double support (default: 1.5 times as dense as the
        single support, at least 12).

    Returns
    -------
    WalkingStep: ``.ocp`` (the single-support OCP) or ``.phases`` (with a double support)
    to inspect or change, ``.solve()`` for the gait.
    """
    linkage = six_link_anthropoid() if linkage is None else linkage
    biped = Biped.of(linkage, swing)
    if linkage.gravity <= 0:
        raise DefinitionError(
            f"`linkage.gravity`: a walking step needs gravity > 0 (the friction cones and the "
            f"scales are relative to the weight), got {linkage.gravity!r}; give g, e.g. 9.81 "
            "m/s^2"
        )
    step_length = check_real("step_length", step_length)
    step_time = check_real("step_time", step_time)
    mu = check_real("mu", mu)
    if mu <= 0:
        raise DefinitionError(f"`mu`: the friction coefficient must be > 0, got {mu!r}")
    check_objective(objective)
    scales = WalkerScales(biped.leg_length, linkage.gravity)
    clearance, height = _checked_clearance(clearance, scales)
    limits = torque_limits(linkage, torque_limit)
    passive = check_links("passive", passive, linkage)
    if len(knee_range) != 2:
        raise DefinitionError(f"`knee_range`: give (lower, upper) in rad, got {knee_range!r}")
    knees = (check_real("knee_range[0]", knee_range[0]), check_real("knee_range[1]", knee_range[1]))
    if knees[0] >= knees[1]:
        raise DefinitionError(f"`knee_range`: lower must be < upper, got {knees}")
    posture = check_positive("posture", posture, "rad")
    upright = biped.upper_body if upright is None else check_links("upright", upright, linkage)
    touchdown_speed, approach_time = _checked_touchdown(touchdown_speed, approach_time, scales)
    lift_time, land_time = _checked_flat_ends(lift_time, land_time)
    foot = _checked_foot(foot, biped.leg_length)
    ground_points, ground_margin = _checked_ground(biped, ground_points, ground_margin)
    if step_time <= 0:
        raise DefinitionError(f"`step_time`: must be > 0 s, got {step_time!r}")
    double_support = check_real("double_support", double_support)
    if not 0.0 <= double_support < step_time:
        raise DefinitionError(
            f"`double_support`: must lie in [0, step_time) = [0, {step_time:g}) s, got "
            f"{double_support!r}"
        )
    single_time = step_time - double_support
    mesh = resolve_mesh(accuracy, single_time, N, transcription, degree, default_N=DEFAULT_N)
    # The law lands the foot when the single support ends; a double support holds the pose
    # the law lands in (periodicity: the law starts from that pose with the legs swapped).
    lift = GUESS_LIFT * biped.leg_length
    law = biped.step_law(step_length, single_time, clearance=max(height, lift) + lift)
    dynamics = Dynamics(linkage, rotors=rotors)
    step = WalkingStep(
        biped=biped,
        dynamics=dynamics,
        step_length=step_length,
        step_time=step_time,
        mu=mu,
        clearance=clearance if callable(clearance) else height,
        torque_limit=limits,
        passive=passive,
        knee_range=knees,
        posture=posture,
        upright=upright,
        objective=objective,
        law=law,
        ocp=None,  # the OCP is built from the step's pieces (foot, impact, step map), below
        double_support=double_support,
        accuracy=accuracy,
        touchdown_speed=touchdown_speed,
        foot_sole=foot,
        ground_points=ground_points,
        ground_margin=ground_margin,
        approach_time=approach_time,
        hip_limit=None if hip_limit is None else check_positive("hip_limit", hip_limit, "N m"),
        speed_limit=None
        if speed_limit is None
        else check_positive("speed_limit", speed_limit, "rad/s"),
        landing_speed=None
        if landing_speed is None
        else check_positive("landing_speed", landing_speed, "m/s"),
        lift_time=lift_time,
        land_time=land_time,
    )
    N, transcription, degree = mesh["N"], mesh["transcription"], mesh["degree"]
    step = replace(step, ocp=_walking_ocp(step, N, transcription, degree, formulation))
    if double_support == 0.0:
        return step
    return _with_double_support(step, mesh, formulation, N_double)


def _checked_flat_ends(lift_time, land_time) -> tuple[float, float]:
    """(``lift_time``, ``land_time``), s, each a real >= 0."""
    checked = []
    for name, value in (("lift_time", lift_time), ("land_time", land_time)):
        value = check_real(name, value)
        if value < 0:
            raise DefinitionError(f"`{name}`: must be >= 0 s, got {value!r}")
        checked.append(value)
    return checked[0], checked[1]


def _checked_clearance(clearance, scales: WalkerScales) -> tuple[float | Callable, float]:
    """(``clearance``, its mid-swing height, m): the walker's default for DEFAULT, a profile
    probed at five points, or a height >= 0."""
    if isinstance(clearance, str) and clearance == DEFAULT:
        clearance = scales.clearance
    if callable(clearance):
        profile_probe = clearance(np.linspace(0.0, 1.0, 5))
        if np.shape(profile_probe) != (5,) or not np.all(np.isfinite(profile_probe)):
            raise DefinitionError(
                "`clearance`: a profile must map s = t / T (K,) to finite heights (K,), m"
            )
        return clearance, max(float(np.max(profile_probe)), 0.0)
    height = check_real("clearance", clearance)
    if height < 0:
        raise DefinitionError(f"`clearance`: must be >= 0 m, got {height!r}")
    return clearance, height


def _checked_touchdown(touchdown_speed, approach_time, scales: WalkerScales):
    """(touchdown speed m/s >= 0, approach window s > 0), the walker's defaults for DEFAULT."""
    if isinstance(touchdown_speed, str) and touchdown_speed == DEFAULT:
        touchdown_speed = scales.touchdown_speed
    if isinstance(approach_time, str) and approach_time == DEFAULT:
        approach_time = scales.approach_time
    approach_time = check_positive("approach_time", approach_time, "s")
    touchdown_speed = check_real("touchdown_speed", touchdown_speed)
    if touchdown_speed < 0:
        raise DefinitionError(
            f"`touchdown_speed`: the landing foot's downward speed must be >= 0 m/s, got "
            f"{touchdown_speed!r}"
        )
    return touchdown_speed, approach_time


def _checked_foot(foot, leg: float) -> tuple[float, float] | None:
    """The sole (heel, toe), m, or None; :data:`FOOT` in leg lengths for DEFAULT."""
    if isinstance(foot, str) and foot == DEFAULT:
        foot = (FOOT[0] * leg, FOOT[1] * leg)
    if foot is None:
        return None
    if isinstance(foot, str) or len(foot) != 2:
        raise DefinitionError(
            f"`foot`: give (heel, toe), m behind and ahead of the ankle, or None, got {foot!r}"
        )
    foot = (check_real("foot[0]", foot[0]), check_real("foot[1]", foot[1]))
    if foot[0] < 0 or foot[1] < 0 or foot[0] + foot[1] <= 0:
        raise DefinitionError(
            f"`foot`: heel and toe must be >= 0 m with a sole longer than 0, got {foot}; "
            "for a point foot give passive=(the stance shank,) instead"
        )
    return foot


def _checked_ground(biped: Biped, ground_points, ground_margin):
    """(the links whose ends stay above the ground, the margin m >= 0); default every link
    but the swing shank, whose end is the swing foot."""
    linkage = biped.linkage
    if ground_points is None:
        ground_points = tuple(name for name in linkage.names if name != biped.swing_shank)
    ground_points = check_links("ground_points", ground_points, linkage)
    if biped.swing_shank in ground_points:
        raise DefinitionError(
            f"`ground_points`: {biped.swing_shank!r} ends in the swing foot, a contact: its "
            "height is the clearance's (give the other links)"
        )
    ground_margin = check_real("ground_margin", ground_margin)
    if ground_margin < 0:
        raise DefinitionError(f"`ground_margin`: must be >= 0 m, got {ground_margin!r}")
    return ground_points, ground_margin


def _with_double_support(step: WalkingStep, mesh, formulation, N_double) -> WalkingStep:
    """The step as two phases: its single-support OCP, then the double support on
    ``N_double`` intervals (default denser than the single support), periodic."""
    N, transcription, degree = mesh["N"], mesh["transcription"], mesh["degree"]
    if N_double is None:
        # Denser than the single support, at least 12: the front foot is held through its
        # acceleration and drifts with the collocation error (fourth order: 0.1 mm and
        # 1 mm/s at 8 intervals of 0.1 s, 20 um and 0.2 mm/s at 12).
        N_double = max(12, round(1.5 * N * step.double_support / step.single_support_time))
    double = {"N": N_double, "transcription": transcription, "degree": degree,
              "formulation": formulation}  # fmt: skip
    phases = (
        Phases.sequence(("single", step.ocp))
        .then("double", _double_support_ocp(step, double), mapping=step.step_map)
        .periodic(step.biped.swap.state_function())
    )
    return replace(step, phases=phases)


def _walking_ocp(step: WalkingStep, N, transcription, degree, formulation) -> OCP:
    biped, dynamics = step.biped, step.dynamics
    linkage = biped.linkage
    n = linkage.n
    weight = biped.total_mass * linkage.gravity
    position = step.foot.function("position")
    velocity = step.foot.function("velocity")
    reaction = dynamics.function("ground_reaction")
    impact = step.impact.function()

    def psi_of(p, name):
        return p[f"psi_{name}"]

    stance, swing = step.stance_contact, step.swing_contact

    def friction(p):
        return stance.cone(*reaction(p.psi, p.dpsi, p.ddpsi))

    def clearance(p):
        return position(p.psi)[1] - step.clearance_at(p.t / p.T, p.T)

    def knees(p):
        return ca.vertcat(
            psi_of(p, biped.stance_thigh) - psi_of(p, biped.stance_shank),
            psi_of(p, biped.swing_thigh) - psi_of(p, biped.swing_shank),
        )

    def landing(p):
        return ca.vertcat(*position(p.x[:n]))

    def foot_vertical_velocity(p):
        return velocity(p.x[:n], p.x[n:])[1]

    def foot_horizontal_velocity(p):
        return velocity(p.x[:n], p.x[n:])[0]

    def pressure(p):
        _, fy = reaction(p.psi, p.dpsi, p.ddpsi)
        return centre_of_pressure_rows(step, p, fy)

    def impulse(p):
        if step.double_support > 0:
            # Both feet held through the impact: the rear foot's impulse must push too
            # (inside its cone).
            _, lam, rear = step.impact.held_impulses(p.x[:n], p.x[n:])
            return ca.vertcat(swing.cone(lam[0], lam[1]), stance.cone(rear[0], rear[1]))
        _, lam, _ = impact(p.x[:n], p.x[n:])
        return swing.cone(lam[0], lam[1])

    mesh = {"N": N, "transcription": transcription, "degree": degree, "formulation": formulation}
    ocp = gait_ocp(dynamics, step.single_support_time, mesh, step.torque_limit)
    for name in step.passive:
        ocp = ocp.bound(f"M_{name}", 0.0, 0.0)
    leg = biped.leg_length
    speed = max(step.step_length, SPEED_SCALE * leg) / step.step_time
    height = step.clearance_height
    ocp = (
        ocp.constrain("friction", friction, lower=0.0, scale=weight)
        .constrain("clearance", clearance, lower=0.0, scale=max(height, CLEARANCE_SCALE * leg))
        .constrain("knees", knees, lower=step.knee_range[0], upper=step.knee_range[1])
        .boundary(
            "landing",
            landing,
            at="end",
            lower=[step.step_length, swing.ground.height],
            upper=[step.step_length, swing.ground.height],
            scale=step.step_length,
        )
        .boundary("lift off", foot_vertical_velocity, at="start", lower=0.0, scale=speed)
        .boundary(
            "heel strike",
            foot_vertical_velocity,
            at="end",
            upper=-step.touchdown_speed,
            scale=speed,
        )
        .boundary("impulse", impulse, at="end", lower=0.0, scale=biped.total_mass * speed)
    )
    if step.landing_speed is not None:
        v = step.landing_speed
        ocp = ocp.boundary("landing speed", foot_horizontal_velocity, at="end", lower=-v,
                           upper=v, scale=speed)  # fmt: skip
    if step.double_support == 0.0:
        ocp = ocp.periodic(step.step_map)
    ocp = keep_off_the_ground(ocp, step)
    if step.foot_sole is not None and biped.stance_shank not in step.passive:
        ocp = ocp.constrain(
            "centre of pressure", pressure, lower=0.0, scale=weight * sum(step.foot_sole)
        )
    ocp = keep_upright(ocp, step.upright, step.posture)
    ocp = bound_stance_hip(ocp, linkage, biped.stance_thigh, step.hip_limit)
    ocp = bound_joint_speeds(ocp, linkage, biped, step.driven, step.speed_limit)
    return finish_gait_ocp(
        ocp, linkage, step.objective, step.torque_limit, step.law, step.time_unit
    )


def _double_support_ocp(step: WalkingStep, mesh: dict) -> OCP:
    """Both feet on the ground: the stance foot pinned at H0, the landing foot a contact
    whose ground force is a control (``F_<foot>_x/_y``), held at rest by its acceleration
    (its position and velocity are right when the phase begins: the landing and the
    impact); both feet's reactions in the friction cone, knees, posture, torque bounds."""
    biped, dynamics = step.biped, step.dynamics
    linkage = biped.linkage
    weight = biped.total_mass * linkage.gravity
    acceleration = step.foot.function("acceleration")
    reaction = dynamics.function("ground_reaction")
    ocp = gait_ocp(dynamics, step.double_support, mesh, step.torque_limit)
    rear_foot, front_foot = step.stance_contact, step.swing_contact
    ocp = replace(ocp, contacts=(front_foot,))
    for name in step.passive:
        ocp = ocp.bound(f"M_{name}", 0.0, 0.0)

    def rear_force(p):
        """The rear foot's ground force, N: the whole tree's reaction less the front foot's."""
        fx, fy = reaction(p.psi, p.dpsi, p.ddpsi)  # both feet together
        return fx - p.F[0], fy - p.F[1]

    def cones(p):
        return ca.vertcat(rear_foot.cone(*rear_force(p)), front_foot.cone(p.F[0], p.F[1]))

    def knees(p):
        return ca.vertcat(
            p[f"psi_{biped.stance_thigh}"] - p[f"psi_{biped.stance_shank}"],
            p[f"psi_{biped.swing_thigh}"] - p[f"psi_{biped.swing_shank}"],
        )

    ocp = (
        ocp.constrain(
            "foot held",
            lambda p: ca.vertcat(*acceleration(p.psi, p.dpsi, p.ddpsi)),
            lower=0.0,
            upper=0.0,
            scale=linkage.gravity,  # the natural size of a foot's acceleration in walking
        )
        .constrain("friction", cones, lower=0.0, scale=weight)
        .constrain("knees", knees, lower=step.knee_range[0], upper=step.knee_range[1])
        # The rear foot unloads before it lifts off, as real feet roll off: its normal force
        # under a cap falling linearly over the double support from twice the weight to
        # UNLOADED of it (a foot leaving the ground loaded would need the drives to jump).
        .constrain(
            "rear unloads",
            lambda p: rear_force(p)[1] - weight * (2.0 - (2.0 - UNLOADED) * p.t / p.T),
            upper=0.0,
            scale=weight,
        )
        .scale(F=weight / 2)
    )
    ocp = keep_off_the_ground(ocp, step)
    if step.foot_sole is not None and biped.stance_shank not in step.passive:
        # The rear foot's ankle torque over its own normal force (the front foot is a point
        # contact: it carries no torque).
        ocp = ocp.constrain(
            "centre of pressure",
            lambda p: centre_of_pressure_rows(step, p, rear_force(p)[1]),
            lower=0.0,
            scale=weight * sum(step.foot_sole),
        )
    ocp = keep_upright(ocp, step.upright, step.posture)
    ocp = bound_stance_hip(ocp, linkage, biped.stance_thigh, step.hip_limit)
    ocp = bound_joint_speeds(ocp, linkage, biped, step.driven, step.speed_limit)
    # The guess holds the pose the law lands in; the feet share the weight.
    strike = step.law(step.single_support_time)
    ocp = finish_gait_ocp(ocp, linkage, step.objective, step.torque_limit, step.law, step.time_unit)
    return replace(ocp, guesses=()).guess(psi=strike[0], dpsi=0.0, ddpsi=0.0, F=[0.0, weight / 2])


def centre_of_pressure_rows(step: WalkingStep, p, fy):
    """M + heel Fy >= 0 and toe Fy - M >= 0 (N m) for the ankle torque M at the stance foot
    and its normal force Fy: the centre of pressure M / Fy within [-heel, toe] of the ankle."""
    heel, toe = step.foot_sole
    moment = p[f"M_{step.biped.stance_shank}"]
    rotors = ground_moment_row(step.dynamics.rotors, step.linkage.names)
    if np.any(rotors):  # the ankle motor's rotor: the sole takes the gear's output, not M
        moment = moment + ca.dot(ca.DM(rotors), p.ddpsi)
    return ca.vertcat(moment + heel * fy, toe * fy - moment)


def ground_function(step: WalkingStep) -> ca.Function:
    """psi -> the heights of the ends of ``step.ground_points`` (m), one output per point
    (rows named after the points)."""
    psi = ca.SX.sym("psi", step.linkage.n)
    points = [step.dynamics.point(name) for name in step.ground_points]
    heights = [point.function("position")(psi)[1] for point in points]
    return ca.Function("ground", [psi], heights, ["psi"], [p.label for p in points])


def keep_off_the_ground(ocp: OCP, step: WalkingStep) -> OCP:
    """``ground`` rows: the ends of ``step.ground_points`` at or above ``ground_margin`` at
    every dynamics point (none when there are no such points)."""
    if not step.ground_points:
        return ocp
    leg = step.biped.leg_length
    return ocp.constrain(
        "ground",
        ground_function(step),
        lower=step.ground_margin,
        scale=max(step.clearance_height, CLEARANCE_SCALE * leg),
    )


# ---- the solved gait ----------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class WorldMotion:
    """Several steps of a gait in world coordinates, for plots and animations.

    time (K,) s; segments: physical link name (the first step's labels) -> (K, 2) complex
    start and end of the link as in the first step (its start hinge there first), m;
    step (K,) int: the step each sample belongs to;
    footholds (steps + 1,) complex: where the stance feet stood.
    """

    time: np.ndarray
    segments: dict[str, np.ndarray]
    step: np.ndarray
    footholds: np.ndarray


def world_motion(
    biped: Biped, dynamics: Dynamics, time, states, step, footholds, corners=None
) -> WorldMotion:
    """Steps given in their own labels, placed in the world.

    time (K,) s; states (K, >= n) each in its step's labels (the stance foot at H0);
    step (K,) int from 0, the step of each sample; footholds (steps + 1,) complex m, where
    each step's stance foot stands. The legs swap at every heel strike: after an odd number
    of swaps link i is the body that was link ``swap.source[i]``, described from its other
    end if it is a leg, so each body keeps its first step's name.

    ``corners``: {link name: points (``model.LinkPoint``) of that link in the linkage's
    labels}: the link is drawn as the closed outline start, corners..., end, start (a foot:
    ball, heel, ankle) instead of the line from its start to its end.
    """
    linkage = dynamics.linkage
    n = linkage.n
    step = np.asarray(step, dtype=int)
    footholds = np.asarray(footholds, dtype=complex)
    psi = np.asarray(states)[:, :n]
    hinges = dynamics.hinge_positions(psi) + footholds[step][:, None]
    starts = np.asarray(linkage.parents) + 1
    swap = biped.swap
    odd = step % 2 == 1
    corners = dict(corners or {})
    outlines = {}
    for i, name in enumerate(linkage.names):
        extra = [
            np.asarray(dynamics.point(point).position(psi)).reshape(-1) + footholds[step]
            for point in corners.get(name, ())
        ]
        ends = [hinges[:, starts[i]], *extra, hinges[:, i + 1]]
        outlines[i] = np.stack(ends + ([hinges[:, starts[i]]] if extra else []), axis=1)
    for i in range(n):
        if outlines[i].shape[1] != outlines[swap.source[i]].shape[1]:
            raise DefinitionError(
                f"`corners`: {linkage.names[i]!r} and {linkage.names[swap.source[i]]!r} are one "
                "body in alternate steps: give both the same number of corners"
            )
    segments = {
        name: np.empty((len(step), outlines[i].shape[1]), dtype=complex)
        for i, name in enumerate(linkage.names)
    }
    for i in range(n):
        ends = outlines[i]
        segments[linkage.names[i]][~odd] = ends[~odd]
        if swap.angle_offsets[i] != 0.0:
            ends = ends[:, ::-1]
        segments[linkage.names[swap.source[i]]][odd] = ends[odd]
    return WorldMotion(np.asarray(time, dtype=float), segments, step, footholds)


@dataclass(frozen=True, eq=False)
class SteppingGait(Gait):
    """A solved periodic step of a biped, on point feet or on feet: ``speed`` m/s,
    ``cost_of_transport`` and ``world(steps)``. Its problem has ``biped``, ``dynamics``,
    ``step_length``, ``speed`` and ``corners`` (the points outlining a link in pictures)."""

    @property
    def speed(self) -> float:
        return self.problem.speed

    @property
    def cost_of_transport(self) -> float:
        """Positive work per weight and distance, dimensionless: W+ / (m g s)."""
        biped = self.problem.biped
        weight = biped.total_mass * biped.linkage.gravity
        return self.positive_work / (weight * self.problem.step_length)

    def world(self, steps: int = 2, rate_hz: float = 100.0) -> WorldMotion:
        """``steps`` consecutive steps in world coordinates: step k stands on the foothold
        k s, with the legs swapped at every heel strike. Samples at ``rate_hz`` per step (the
        end of a step and the start of the next are one instant; it is kept once)."""
        steps = check_integer("steps", steps, 1)
        problem = self.problem
        pieces, states = [], []
        for k, (solution, t0) in enumerate(self.segments()):
            local = solution.sample_times(rate_hz)
            local = local[1:] if k else local
            pieces.append(local + t0)
            states.append(solution(local)[0])
        times, states = np.concatenate(pieces), np.vstack(states)
        # step k repeats the step on the foothold k s, its first sample the last one of k - 1
        keep = [slice(None)] + [slice(1, None)] * (steps - 1)
        return world_motion(
            problem.biped,
            problem.dynamics,
            np.concatenate([times[part] + k * self.duration for k, part in enumerate(keep)]),
            np.vstack([states[part] for part in keep]),
            np.concatenate([np.full(len(times[part]), k) for k, part in enumerate(keep)]),
            problem.step_length * np.arange(steps + 1) + 0j,
            problem.corners,
        )


@dataclass(frozen=True, eq=False)
class WalkingGait(SteppingGait):
    """A solved walking step (:class:`problems.gait.problem.Gait`: cost, ``law_cost``,
    ``positive_work``, ``summary()``, ``to_trajectory(rate_hz)``, ``verify()``) and what a
    walking study reads from it: ``speed`` m/s, ``cost_of_transport``, ``impact`` and
    ``world(steps)`` (:class:`SteppingGait`)."""

    @property
    def impact(self) -> dict[str, np.ndarray]:
        """At heel strike: ``impulse`` (2,) N s on the landing foot, ``lift_off`` (2,) m/s the
        old stance foot's velocity (zero when a double support follows: it stays),
        ``dpsi_plus`` (n,) rad/s (before the leg swap)."""
        n = self.problem.linkage.n
        x = self.segments()[0][0].states[-1]  # the single support's end
        dpsi_plus, impulse, base = self.problem.impact(x[:n], x[n:])
        return {"impulse": impulse, "lift_off": base, "dpsi_plus": dpsi_plus}

    @property
    def touchdown_velocity(self) -> complex:
        """The landing foot's velocity at heel strike, m/s (complex vx + j vy; vy <= -the
        touchdown speed)."""
        n = self.problem.linkage.n
        x = self.segments()[0][0].states[-1]  # the single support's end
        return complex(np.asarray(self.problem.foot.velocity(x[:n], x[n:])).reshape(-1)[0])

    def summary(self, rate_hz: float | None = RATE_HZ) -> dict[str, Any]:
        """:meth:`Gait.summary` (of the samples at ``rate_hz``) plus speed, cost of transport,
        impulse and lift-off speed."""
        impact = self.impact
        return {
            **super().summary(rate_hz),
            "speed": self.speed,
            "cost_of_transport": self.cost_of_transport,
            "impulse": impact["impulse"].tolist(),
            "lift_off": impact["lift_off"].tolist(),
            "centre_of_pressure": list(self.centre_of_pressure(RATE_HZ)),
        }


#: walking_step's defaults by argument name (``N``: the intervals used when None): the one
#: source the command line's options read theirs from.
WALKING_DEFAULTS: Mapping[str, Any] = MappingProxyType(
    {
        **{
            name: parameter.default
            for name, parameter in inspect.signature(walking_step).parameters.items()
            if parameter.default is not inspect.Parameter.empty
        },
        "N": DEFAULT_N,
    }
)


__all__ = [
    "DEFAULT_N",
    "WALKING_DEFAULTS",
    "WalkingGait",
    "WalkingStep",
    "WorldMotion",
    "walking_step",
    "world_motion",
]
