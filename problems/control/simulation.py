"""Many steps of a walking biped, simulated as a hybrid system: the second problem of dynamics
across heel strikes, under a controller, with disturbances.

The plant is the product's pinned-foot model of a step (:mod:`problems.walking.step`): the stance
foot H0 is a hinge on the ground; x = (psi, dpsi) (2n,) rad and rad/s. Between heel strikes
x' = (dpsi, FD(psi, dpsi, M)) with the controller's torques M held over each control period
(a digital controller: zero-order hold at ``control_rate_hz``) and integrated by
``substeps`` classical Runge-Kutta (RK4) steps per period, in one generated CasADi function.
A heel strike is the swing foot reaching the ground from above once it has passed the stance
foot; its instant is located inside the period by the secant method on the foot's height
along the same RK4 step (to 1e-12 m), then the impact map and the leg swap of the plant give
the next step's start (:meth:`model.ImpactMap.step_function`).

The model holds only while its contact assumptions hold, so each is checked and its failure is
a fall, named: a body point (knee, hip, head) under the ground; the stance foot pulled up
(Fy < 0) or slipping (|Fx| > mu Fy); at heel strike, an impulse outside the friction cone or
a trailing foot that does not lift off; no heel strike within ``max_step_factor`` times the
planned step time.

Disturbances (:class:`Disturbances`): an initial state error, a horizontal push (an impulse,
N s) on the torso's centre of mass, a change of the ground's height from a foothold on, a
plant whose masses and inertias differ from the plan's, and torque saturation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Protocol

import casadi as ca
import numpy as np

from model.contact import Contact
from model.dynamics import Dynamics
from model.linkage import Linkage
from planner import native_nlp
from planner.errors import DefinitionError, check_integer, check_positive, check_real
from planner.native_function import native_derived
from problems.control.buffered import BufferedCalls
from problems.gait.biped import Biped
from problems.walking.feet import WalkerFeet
from problems.walking.step import UNLOADED, WorldMotion, world_motion

#: the swing foot must be this far ahead of the stance foot, as a fraction of the planned step
#: length, for a touch of the ground to count as a heel strike (it starts at the stance foot's
#: side, on the ground: the first instants are its lift-off, not a landing)
STRIKE_AHEAD = 0.25
#: a heel strike's instant is located to this height, m
STRIKE_TOLERANCE = 1e-12
#: contact forces beyond the cone by less than this fraction of the body's weight are not a
#: slip: the plan itself runs along the cone's edge (right after heel strike), and the held
#: torques of a digital controller cross it by round-off
CONE_SLACK = 1e-3
#: m: how far from the ground the swing foot of a walk's last step may be when it stands
#: (point feet: it rests beside the stance foot, unloaded)
STAND_HEIGHT = 0.005


class Controller(Protocol):
    """What the simulation asks of a controller, once per control period."""

    def start_step(self, index: int, x: np.ndarray) -> None:
        """A step begins (after the leg swap) in state x (2n,)."""

    def torques(self, t: float, x: np.ndarray) -> np.ndarray:
        """Hinge torques M (n,) N m to hold over the period from t (s since the step's start).

        A controller of a step with a double support may also have ``touchdown(t, x)``: the
        simulation calls it when the swing foot lands and the double support begins."""


@dataclass(frozen=True)
class Disturbances:
    """What the world and the body do that the plan did not expect.

    initial : (2n,) array or None
        Added to the planned start state (psi rad, dpsi rad/s).
    push : float
        Horizontal impulse on the torso's centre of mass, N s (> 0 pushes forward, +x).
    push_step, push_at : int, float
        The step (0-based) and the instant in it, as a fraction of the planned step time.
    ground_rise : float
        The ground is this much higher (m; < 0 lower) from the foothold of step
        ``ground_from`` on: the edge lies half a step before it.
    ground_from : int
        The first step that stands on the changed ground.
    mass_scale : float
        The plant's masses and moments of inertia are the plan's times this (the controller
        keeps the plan's).
    torque_limit : float or None
        Every hinge's torque is saturated at this magnitude, N m.
    """

    initial: np.ndarray | None = None
    push: float = 0.0
    push_step: int = 1
    push_at: float = 0.5
    ground_rise: float = 0.0
    ground_from: int = 1
    mass_scale: float = 1.0
    torque_limit: float | None = None

    def __post_init__(self) -> None:
        check_real("push", self.push)
        check_integer("push_step", self.push_step, 0)
        at = check_real("push_at", self.push_at)
        if not 0.0 <= at < 1.0:
            raise DefinitionError(f"`push_at`: a fraction of the step time in [0, 1), got {at!r}")
        check_real("ground_rise", self.ground_rise)
        check_integer("ground_from", self.ground_from, 1)
        check_positive("mass_scale", self.mass_scale)
        if self.torque_limit is not None:
            check_positive("torque_limit", self.torque_limit, "N m")


def disturbances_for(n: int, torque_limit: float) -> dict[str, Disturbances]:
    """The disturbances every closed-loop check runs (the product's simulation and MuJoCo's,
    on point feet and on feet), by label, for a biped of ``n`` links whose drives are limited
    to ``torque_limit`` N m: the plan, a body 10 % heavier and lighter, the ground 5 mm and
    1 cm higher and lower from the first new foothold on, a start 0.02 rad off on every
    angle, drives limited to 2/3 of the plan's limit."""
    return {
        "plan": Disturbances(),
        "mass +10 %": Disturbances(mass_scale=1.1),
        "mass -10 %": Disturbances(mass_scale=0.9),
        "ground +5 mm": Disturbances(ground_rise=0.005),
        "ground -5 mm": Disturbances(ground_rise=-0.005),
        "ground +1 cm": Disturbances(ground_rise=0.01),
        "ground -1 cm": Disturbances(ground_rise=-0.01),
        "start 0.02 rad": Disturbances(initial=np.r_[np.full(n, 0.02), np.zeros(n)]),
        f"|M| <= {2 * torque_limit / 3:g}": Disturbances(torque_limit=2.0 * torque_limit / 3.0),
    }


@dataclass(frozen=True)
class StepRecord:
    """One simulated step.

    duration s; length m (the new foothold's distance from the old one, along the ground);
    strike: the landing foot's velocity, complex m/s; impulse: on the landing foot, complex
    N s; tracking: largest |psi - psi_ref| at the same phase, rad; peak_torque N m;
    normal_force: the least Fy on the stance foot, N; friction_use: the largest |Fx| / (mu Fy);
    before: the state (2n,) at heel strike, before the impact; double_support s: from the
    heel strike to the rear foot's lift-off (0 without a double support).
    """

    index: int
    duration: float
    length: float
    strike: complex
    impulse: complex
    tracking: float
    peak_torque: float
    normal_force: float
    friction_use: float
    before: np.ndarray
    double_support: float = 0.0


@dataclass(frozen=True)
class WalkingRun:
    """The outcome of :func:`simulate_walking`.

    steps: the completed steps; fell: why the run ended early (None: it walked them all);
    time (K,) s from the run's start; states (K, 2n) in each step's own labels (the stance
    foot at H0); torques (K, n) N m held from each sample; step (K,) the step of each
    sample; footholds (steps walked + 1,) complex world positions of the stance feet, m;
    end: the state (2n,) the next step would start from (after the last heel strike and leg
    swap), None when the run fell.
    """

    steps: tuple[StepRecord, ...]
    fell: str | None
    time: np.ndarray
    states: np.ndarray
    torques: np.ndarray
    step: np.ndarray
    footholds: np.ndarray
    end: np.ndarray | None = None

    @property
    def walked(self) -> int:
        """Steps completed (heel strikes that the model accepted)."""
        return len(self.steps)

    def world(self, dynamics: Dynamics, rate_hz: float = 100.0) -> WorldMotion:
        """The run's bodies in world coordinates (``dynamics`` the simulated biped's model,
        e.g. the plan's ``step.dynamics``), sampled at about ``rate_hz`` (every control
        instant nearest a multiple of 1 / rate_hz) and at its last instant, for
        :func:`problems.walking.plots.world_strip` and
        :func:`problems.walking.plots.animate_walk`."""
        rate = check_positive("rate_hz", rate_hz, "Hz")
        marks = np.arange(self.time[0], self.time[-1], 1.0 / rate)
        picks = np.unique(np.r_[np.searchsorted(self.time, marks), self.time.size - 1])
        return world_motion(
            Biped.of(dynamics.linkage),
            dynamics,
            self.time[picks],
            self.states[picks],
            self.step[picks],
            self.footholds,
        )


class Plant(BufferedCalls, WalkerFeet):
    """The simulated body: a linkage's pinned-foot dynamics, its heel strike and leg swap, as
    generated functions (the plan's linkage, or one with changed masses).

    mu: the ground's friction coefficient for the contact checks (None for a body that only
    swings on its pinned root, e.g. the fixed-base gait: then only :attr:`advance` and
    :attr:`advance_jacobian` are used, and the linkage need not be a biped).

    compiled: how the period Jacobians use the compiled cache (:mod:`planner.native_function`):
    True compiles them at first use unless the cache holds them (about 40 s each for the
    six-link walker, once per linkage; DefinitionError without a C compiler), None (default)
    uses what the cache holds (nothing under ``ANTHROPOID_COMPILE=never``), False never."""

    def __init__(
        self,
        linkage: Linkage,
        mu: float | None,
        substeps: int = 2,
        rotors: Sequence = (),
        compiled: bool | None = None,
    ) -> None:
        # rotors: a plan made with its drives' rotors (model.Rotor) is simulated with them
        self.dynamics = Dynamics(linkage, rotors=rotors)
        self.mu = None if mu is None else check_positive("mu", mu)
        self.substeps = check_integer("substeps", substeps, 1)
        if compiled not in (None, True, False):
            raise DefinitionError(f"`compiled`: True, False or None, got {compiled!r}")
        self.compiled = compiled

    @property
    def n(self) -> int:
        return self.dynamics.n

    @cached_property
    def biped(self) -> Biped:
        return Biped.of(self.dynamics.linkage)

    @cached_property
    def impact(self):
        return self.dynamics.impact(self.foot)

    @cached_property
    def step_map(self) -> ca.Function:
        return self.impact.step_function(self.biped.swap)

    @cached_property
    def advance(self) -> ca.Function:
        """(x (2n,), M (n,), h s) -> x after h with M held, by ``substeps`` RK4 steps."""
        return self._rk4("advance", self.dynamics.function("forward_dynamics"))

    def advance_state(self, x, torques, h: float, double: bool = False) -> np.ndarray:
        """x after h s (2n,) from the one state x under ``torques`` held: :attr:`advance` (or,
        with ``double``, :attr:`advance_double`) through its evaluation buffer
        (:class:`problems.control.buffered.BufferedCall`): the Function's own numbers at about a
        quarter of its call's cost."""
        name = "advance_double" if double else "advance"
        call = self._buffered(name, lambda: getattr(self, name))
        return call(x, torques, h)[0]

    def swing_foot(self, psi) -> complex:
        """The swing foot's position from the stance foot, m (x + j y), for one state's
        angles psi (n,), through the evaluation buffer of its position function."""
        x, y = self._buffered("swing_foot", lambda: self.foot.function("position"))(psi)
        return complex(x[0], y[0])

    @cached_property
    def advance_jacobian(self) -> ca.Function:
        """(x, M, h) -> (dx_next/dx (2n, 2n), dx_next/dM (2n, n), dx_next/dh (2n,)): native
        code when the compiled cache holds it (:meth:`compile`), else interpreted."""
        return _native_jacobians(self.advance, _cache_mode(self.compiled))

    @cached_property
    def advance_double(self) -> ca.Function:
        """:attr:`advance` in a double support: the swing foot held where it landed (the
        closed chain's motion, ``PointKinematics.held_dynamics``)."""
        held = self.foot.function("held_dynamics")
        return self._rk4("advance_double", lambda psi, dpsi, m: held(psi, dpsi, m)[0])

    @cached_property
    def advance_double_jacobian(self) -> ca.Function:
        """:attr:`advance_jacobian` of :attr:`advance_double` (native code when cached)."""
        return _native_jacobians(self.advance_double, _cache_mode(self.compiled))

    def compile(self, double_support: bool = False) -> None:
        """Compile the period's exact Jacobian (and, with ``double_support``, the closed
        chain's) to native code in the disk cache now, unless it is there, and use it: about
        12 times faster (scratch timings) in the return map and the LQR's linearisation, for
        about 40 s of compilation once per linkage (every Plant of the same linkage, substeps
        and rotors finds it there after; :mod:`planner.native_function`). Raises
        DefinitionError without a C compiler."""
        self.__dict__["advance_jacobian"] = _native_jacobians(self.advance, "now")
        if double_support:
            self.__dict__["advance_double_jacobian"] = _native_jacobians(self.advance_double, "now")

    @cached_property
    def strike_held(self) -> ca.Function:
        """x- -> x+ of a heel strike that begins a double support: the inelastic impact with
        both feet held (no leg swap: the legs swap when the rear foot lifts)."""
        n = self.n
        x = ca.SX.sym("x", 2 * n)
        impact = self.dynamics.impact(self.foot, root_pinned=True).function()
        dpsi_plus, _, _ = impact.call([x[:n], x[n:]])
        return ca.Function("strike_held", [x], [ca.vertcat(x[:n], dpsi_plus)])

    @cached_property
    def swap_map(self) -> ca.Function:
        """x -> x with the legs swapped (the rear foot lifts at the end of a double support;
        no impact)."""
        return self.biped.swap.state_function()

    def _rk4(self, name: str, acceleration) -> ca.Function:
        """(x, M, h) -> x after h under ``acceleration(psi, dpsi, M)``, ``substeps`` RK4 steps
        with M held."""
        n = self.n
        x, torques, h = ca.SX.sym("x", 2 * n), ca.SX.sym("M", n), ca.SX.sym("h")

        def rate(state):
            return ca.vertcat(state[n:], acceleration(state[:n], state[n:], torques))

        step = h / self.substeps
        state = x
        for _ in range(self.substeps):
            k1 = rate(state)
            k2 = rate(state + 0.5 * step * k1)
            k3 = rate(state + 0.5 * step * k2)
            k4 = rate(state + step * k3)
            state = state + step / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return ca.Function(name, [x, torques, h], [state], ["x", "M", "h"], ["x_next"])

    @cached_property
    def step_map_jacobian(self) -> ca.Function:
        """x- -> dDelta/dx- (2n, 2n): the impact and the leg swap, differentiated."""
        return _map_jacobian(self.step_map)

    @cached_property
    def strike_held_jacobian(self) -> ca.Function:
        """x- -> dx+/dx- (2n, 2n) of :attr:`strike_held`."""
        return _map_jacobian(self.strike_held)

    @cached_property
    def swap_jacobian(self) -> np.ndarray:
        """d swap / dx (2n, 2n): the relabelling is linear (signs, offsets and a permutation)."""
        return np.asarray(_map_jacobian(self.swap_map)(np.zeros(2 * self.n)))

    @cached_property
    def observe_double(self) -> ca.Function:
        """(x, M) -> in a double support, the rear (stance) foot's reaction (Fx, Fy) N, the
        front foot's (Fx, Fy) N, and the heights of every hinge and link end but the swing
        foot (m)."""
        n = self.n
        x, torques = ca.SX.sym("x", 2 * n), ca.SX.sym("M", n)
        psi, dpsi = x[:n], x[n:]
        ddpsi, front = self.foot.function("held_dynamics")(psi, dpsi, torques)
        fx, fy = self.dynamics.function("ground_reaction")(psi, dpsi, ddpsi)  # both feet's
        return ca.Function(
            "observe_double",
            [x, torques],
            [ca.vertcat(fx, fy) - front, front, self._heights(psi)],
            ["x", "M"],
            ["rear", "front", "heights"],
        )

    @cached_property
    def observe(self) -> ca.Function:
        """(x, M) -> the stance foot's reaction (Fx, Fy) N and the heights of every hinge and
        link end but the swing foot (m), at x under M."""
        n = self.n
        x, torques = ca.SX.sym("x", 2 * n), ca.SX.sym("M", n)
        psi, dpsi = x[:n], x[n:]
        ddpsi = self.dynamics.function("forward_dynamics")(psi, dpsi, torques)
        fx, fy = self.dynamics.function("ground_reaction")(psi, dpsi, ddpsi)
        return ca.Function(
            "observe",
            [x, torques],
            [ca.vertcat(fx, fy), self._heights(psi)],
            ["x", "M"],
            ["reaction", "heights"],
        )

    def _heights(self, psi) -> ca.SX:
        """The heights of every hinge and link end but the swing foot, m: what must stay
        above the ground."""
        return ca.vertcat(*[
            self.dynamics.point(name).function("position")(psi)[1]
            for name in self.dynamics.names
            if name != self.biped.swing_shank
        ])  # fmt: skip

    def push_velocity(self, x: np.ndarray, impulse: complex, link: str) -> np.ndarray:
        """dpsi after an impulse (complex N s) on ``link``'s centre of mass: M^-1 J^T P."""
        n = self.n
        psi = x[:n]
        i = self.dynamics.linkage.index(link)
        # column k of the centre of mass's Jacobian: its velocity for dpsi = e_k
        jacobian = self.dynamics.com_velocities(np.tile(psi, (n, 1)), np.eye(n))[:, i]
        generalised = (np.conj(jacobian) * impulse).real
        return x[n:] + np.linalg.solve(self.dynamics.mass_matrix(psi), generalised)


#: the derivation :func:`_jacobians` as the compiled cache names it (a new version when it
#: changes, so that no library of the old one is loaded)
JACOBIANS_TAG = "problems.control.simulation._jacobians v1"


def _cache_mode(compiled: bool | None) -> str:
    """How the plant's Jacobians use the compiled cache (:class:`Plant`'s ``compiled``):
    True "now", False "never", None "never" under ``ANTHROPOID_COMPILE=never``, else "auto"
    (its library when it holds one)."""
    if compiled is not None:
        return "now" if compiled else "never"
    return "never" if native_nlp.mode() == "never" else "auto"


def _native_jacobians(advance: ca.Function, how: str) -> ca.Function:
    """:func:`_jacobians` of ``advance`` through the compiled cache (``how``)."""
    return native_derived(advance, JACOBIANS_TAG, f"{advance.name()}_jacobian", _jacobians, how)


def _jacobians(advance: ca.Function) -> ca.Function:
    """(x, M, h) -> (dx_next/dx, dx_next/dM, dx_next/dh) of an ``advance`` Function."""
    x, torques, h = advance.sx_in()
    x_next = advance(x, torques, h)
    return ca.Function(
        f"{advance.name()}_jacobian",
        [x, torques, h],
        [ca.jacobian(x_next, x), ca.jacobian(x_next, torques), ca.jacobian(x_next, h)],
        ["x", "M", "h"],
        ["dx", "dM", "dh"],
    )


def _map_jacobian(mapping: ca.Function) -> ca.Function:
    x = mapping.sx_in(0)
    return ca.Function(f"{mapping.name()}_jacobian", [x], [ca.jacobian(mapping(x), x)])


def disturbed_plant(linkage: Linkage, mu: float | None, substeps: int, mass_scale: float,
                    rotors: Sequence = ()):  # fmt: skip
    """The :class:`Plant` of ``linkage`` (and its drives' ``rotors``) with its masses and
    inertias times ``mass_scale`` (the rotors as they are: the motors did not grow)."""
    scaled = linkage if mass_scale == 1.0 else scaled_linkage(linkage, mass_scale)
    return Plant(scaled, mu, substeps, rotors)


def scaled_linkage(linkage: Linkage, scale: float) -> Linkage:
    """The same tree with every mass and moment of inertia times ``scale``."""
    links = [
        replace(link, mass=link.mass * scale, inertia=link.inertia * scale)
        for link in linkage.links
    ]
    return Linkage(links, gravity=linkage.gravity)


@dataclass
class _StepLog:
    time: list = field(default_factory=list)
    states: list = field(default_factory=list)
    torques: list = field(default_factory=list)
    tracking: float = 0.0
    peak: float = 0.0
    normal: float = np.inf
    friction: float = 0.0


def simulate_walking(
    start: np.ndarray,
    controller: Controller,
    *,
    linkage: Linkage,
    step_time: float,
    step_length: float,
    mu: float,
    steps: int = 20,
    disturbances: Disturbances | None = None,
    control_rate_hz: float = 1000.0,
    substeps: int = 2,
    max_step_factor: float = 2.0,
    reference=None,
    torso: str | None = None,
    check_contacts: bool = True,
    lift_off=None,
    plant: Plant | None = None,
    stand: float | None = None,
    rotors: Sequence = (),
) -> WalkingRun:
    """Simulate ``steps`` steps from the planned start state ``start`` (2n,).

    Parameters
    ----------
    start : (2n,) the state at the first step's start (after a heel strike and leg swap).
    controller : :class:`Controller`
    linkage, step_time, step_length, mu : the plan's biped, step time s, length m and
        friction coefficient (the plant's contact checks use mu).
    steps : heel strikes to simulate.
    disturbances : :class:`Disturbances` or None.
    control_rate_hz : the controller's rate; torques are held between its instants.
    substeps : RK4 steps per control period.
    max_step_factor : a step with no heel strike after this many planned step times falls.
    reference : an object with ``tracking(x) -> rad`` (the largest angle error at the same
        phase), or None.
    torso : the link pushed (default: the upper body's first link).
    check_contacts : False runs the ideal pinned-foot model on, whatever its contacts would
        need (for the return map of an orbit that a real contact would leave).
    lift_off : None (the legs swap at heel strike), or a function of the state whose rise
        through 0 ends a double support: the heel strike then holds both feet (the impact
        with the rear foot pinned), the chain moves closed until the guard crosses, and the
        rear foot lifts (the legs swap, no impact). E.g. ``reference.phase(psi) - 1``: the
        rear foot lifts where the plan's double support ends. A rear foot that carries less
        than the plan's ``UNLOADED`` part of the weight and leaves its friction cone lifts
        there too (it rolls off); loaded, it slips and the run falls.
    plant : the :class:`Plant` to simulate (its linkage ``linkage``, or the disturbed one;
        ``disturbances.mass_scale`` is then not applied again), to reuse its generated
        functions over many calls; default one built here.
    stand : s: the last step ends in quiet standing: its swing foot comes down beside the
        stance foot at rest, unloaded (no impact, no leg swap); the run goes on ``stand`` s past
        the planned step time on the stance foot and ends standing, unless the swing foot
        goes more than :data:`STAND_HEIGHT` into the ground (from half the step on) or is
        more than that off it after the planned time; ``lift_off`` must be None.
    rotors : the plan's drives' rotors (``model.Rotor``; a plan made with its drives in the
        loop), in the plant built here.

    Returns
    -------
    WalkingRun
    """
    disturbances = disturbances or Disturbances()
    steps = check_integer("steps", steps, 1)
    rate = check_positive("control_rate_hz", control_rate_hz, "Hz")
    step_time = check_positive("step_time", step_time, "s")
    step_length = check_positive("step_length", step_length, "m")
    factor = check_positive("max_step_factor", max_step_factor)
    if plant is None:
        plant = disturbed_plant(linkage, mu, substeps, disturbances.mass_scale, rotors)
    if stand is not None:
        if lift_off is not None:
            raise DefinitionError("`stand`: the last step ends standing; give no lift_off")
        check_positive("stand", stand, "s")
        factor = max(factor, (step_time + stand) / step_time + 1.0)
    x = _first_state(start, disturbances, plant.n)
    weight = plant.biped.total_mass * plant.dynamics.linkage.gravity
    walk = _Walk(
        plant=plant, controller=controller, disturbances=disturbances, reference=reference,
        check_contacts=check_contacts, lift_off=lift_off, stand=stand, steps=steps,
        step_time=step_time, step_length=step_length, period=1.0 / rate, factor=factor,
        torso=torso or (plant.biped.upper_body[0] if plant.biped.upper_body
                        else plant.biped.stance_thigh),
        slack=CONE_SLACK * weight, unloaded=UNLOADED * weight,
    )  # fmt: skip
    records: list[StepRecord] = []
    logs: list[_StepLog] = []
    foothold = 0j
    footholds = [foothold]
    fell = None
    clock = 0.0
    for index in range(steps):
        controller.start_step(index, x)
        standing = stand is not None and index == steps - 1
        logs.append(_StepLog())
        x, t, strike, fell = _one_step(walk, index, x, foothold, clock, logs[-1], standing)
        if fell is not None:
            break
        t_strike, x_minus, impulse, landing, velocity = strike
        log = logs[-1]
        records.append(
            StepRecord(
                index=index,
                duration=t,
                length=landing.real,
                strike=velocity,
                impulse=complex(*impulse),
                tracking=log.tracking,
                peak_torque=log.peak,
                normal_force=log.normal,
                friction_use=log.friction,
                before=x_minus,
                double_support=t - t_strike,
            )
        )
        clock += t
        foothold = foothold + landing
        footholds.append(foothold)
        if standing:  # both feet stay down, in this step's labels
            break
        x = np.asarray(plant.step_map(x_minus) if lift_off is None else plant.swap_map(x)).ravel()
    return _run_of(records, fell, logs, footholds, x)


def _first_state(start, disturbances: Disturbances, n: int) -> np.ndarray:
    """The first step's state: ``start`` (2n,) plus the disturbances' initial error."""
    x = np.asarray(start, dtype=float).copy()
    if x.shape != (2 * n,):
        raise DefinitionError(f"`start`: the state (psi, dpsi) has {2 * n} entries, got {x.shape}")
    if disturbances.initial is not None:
        initial = np.asarray(disturbances.initial, dtype=float)
        if initial.shape != (2 * n,):
            raise DefinitionError(
                f"`disturbances.initial`: (psi, dpsi) error with {2 * n} entries, got "
                f"{initial.shape}"
            )
        x = x + initial
    return x


def _run_of(records, fell, logs, footholds, x) -> WalkingRun:
    """The :class:`WalkingRun` of the steps' records and logs (``x`` the last state)."""
    time = np.concatenate([np.asarray(log.time) for log in logs if log.time])
    states = np.vstack([np.asarray(log.states) for log in logs if log.states])
    torques_all = np.vstack([np.asarray(log.torques) for log in logs if log.torques])
    which = np.concatenate([np.full(len(log.time), k) for k, log in enumerate(logs) if log.time])
    return WalkingRun(
        tuple(records),
        fell,
        time,
        states,
        torques_all,
        which,
        np.asarray(footholds),
        None if fell else x,
    )


@dataclass(frozen=True)
class _Walk:
    """What every step of :func:`simulate_walking` shares (its arguments, checked)."""

    plant: Plant
    controller: Controller
    disturbances: Disturbances
    reference: object
    check_contacts: bool
    lift_off: object
    stand: float | None
    steps: int
    step_time: float
    step_length: float
    period: float
    factor: float
    torso: str
    slack: float
    unloaded: float

    def ground(self, world_x: float) -> float:
        """The ground's height at ``world_x`` m (a step up from ``ground_from``)."""
        edge = (self.disturbances.ground_from - 0.5) * self.step_length
        return self.disturbances.ground_rise if world_x >= edge else 0.0


def _one_step(walk: _Walk, index: int, x, foothold: complex, clock: float, log: _StepLog,
              standing: bool):  # fmt: skip
    """Step ``index`` from state ``x`` (its foot at ``foothold``, ``clock`` s into the run),
    each control instant in ``log``: (the state where it ended, its duration s, the strike
    (t, x-, impulse, landing, velocity) or None, why it fell or None). ``standing``: the
    last step of a run that ends standing."""
    plant, d, period, n = walk.plant, walk.disturbances, walk.period, walk.plant.n
    guard = walk.lift_off
    t = 0.0
    pushed = index != d.push_step or d.push == 0.0
    strike = None  # (t, x-, impulse, landing, velocity) once the swing foot has landed
    while True:
        if t > walk.factor * walk.step_time:
            return (
                x,
                t,
                strike,
                (
                    f"step {index}: no heel strike within {walk.factor:g} x the step time"
                    if strike is None
                    else f"step {index}: the double support does not end within {walk.factor:g} x "
                    "the step time"
                ),
            )
        if not pushed and t >= d.push_at * walk.step_time - 1e-12:
            x = np.concatenate([x[:n], plant.push_velocity(x, complex(d.push), walk.torso)])
            pushed = True
        torques, problem, rolled_off = _control(walk, t, x, strike, foothold, clock, log)
        if rolled_off:  # the rear foot rolls off: the legs swap now, a little early
            return x, t, strike, None
        if problem is not None and walk.check_contacts:
            return x, t, strike, f"step {index}, t = {t:.3f} s: {problem}"
        x_next = plant.advance_state(x, torques, period, double=strike is not None)
        if not np.all(np.isfinite(x_next)):
            return x, t, strike, f"step {index}, t = {t:.3f} s: the state is not finite"
        if strike is not None:  # the double support ends when the lift-off guard crosses
            if guard(x_next) >= 0.0:
                tau, x = locate_event(
                    plant.advance_double, x, torques, period, lambda y, guard=guard: -guard(y)
                )
                return x, t + tau, strike, None
            x, t = x_next, t + period
            continue
        height = foot_height(plant, x_next, foothold, walk.ground)
        if standing:
            x, t = x_next, t + period
            problem = _standing_problem(height, t, walk.step_time)
            if problem is not None:
                return x, t, strike, f"step {index}, t = {t:.3f} s: {problem}"
            if t >= walk.step_time + walk.stand - 1e-12:  # stood: the run ends here
                return x, t, _stood(plant, t, x), None
            continue
        ahead = plant.swing_foot(x_next[:n]).real
        if height <= 0.0 and ahead > STRIKE_AHEAD * walk.step_length:
            tau, strike, problem = _heel_strike(walk, x, torques, t, foothold, guard is not None)
            if problem is not None and walk.check_contacts:
                return x, t, None, f"heel strike of step {index}: {problem}"
            t += tau
            if guard is None:
                return x, t, strike, None
            # a double support begins: both feet held through the impact, the controller
            # goes on from the strike's instant
            x = np.asarray(plant.strike_held(strike[1])).ravel()
            if hasattr(walk.controller, "touchdown"):
                walk.controller.touchdown(t, x)
            continue
        x = x_next
        t += period


def _control(walk: _Walk, t: float, x, strike, foothold: complex, clock: float, log: _StepLog):
    """The controller's torques at t s of the step in state x, the contacts they make
    checked and the instant logged: (torques (n,), the contact problem or None, whether the
    rear foot of a double support rolls off: unloaded as the plan's lift-off defines it and
    out of its cone, it lifts, as a foot does; that instant is not logged)."""
    plant = walk.plant
    torques = np.asarray(walk.controller.torques(t, x), dtype=float)
    limit = walk.disturbances.torque_limit
    if limit is not None:
        torques = np.clip(torques, -limit, limit)
    if strike is None:
        reaction, heights = (np.asarray(v).ravel() for v in plant.observe(x, torques))
        front = None
    else:
        reaction, front, heights = (np.asarray(v).ravel() for v in plant.observe_double(x, torques))
    stance = _cone_problem(plant.stance_contact, "the stance foot", reaction, walk.slack)
    if stance is not None and front is not None and reaction[1] < walk.unloaded:
        return torques, None, True
    problem = (
        stance
        or _ground_problem(heights, foothold, walk.ground)
        or (
            None
            if front is None
            else _cone_problem(plant.swing_contact, "the front foot", front, walk.slack)
        )
    )
    log.time.append(clock + t)
    log.states.append(x.copy())
    log.torques.append(torques)
    log.peak = max(log.peak, float(np.abs(torques).max()))
    if walk.reference is not None:
        log.tracking = max(log.tracking, walk.reference.tracking(x))
    log.normal = min(log.normal, reaction[1])
    if reaction[1] > 0:
        log.friction = max(log.friction, abs(reaction[0]) / (plant.mu * reaction[1]))
    return torques, problem, False


def _heel_strike(walk: _Walk, x, torques, t: float, foothold: complex, held: bool):
    """The swing foot's landing within the control period from x: (tau s into the period,
    the strike (t, x-, impulse, landing, velocity), the impact's contact problem or None).
    ``held``: the rear foot stays pinned through the impact (a double support follows: no
    lift-off to check)."""
    plant, n = walk.plant, walk.plant.n
    tau, x_minus = locate_strike(plant, x, torques, walk.period, foothold, walk.ground)
    _, impulse, lift = (
        np.asarray(v).ravel()
        for v in plant.dynamics.impact(plant.foot, root_pinned=held)(x_minus[:n], x_minus[n:])
    )
    if held:
        lift = np.array([0.0, 0.0])  # the rear foot stays: nothing to lift
    problem = _impact_problem(impulse, lift, plant.swing_contact)
    strike = (
        t + tau,
        x_minus,
        impulse,
        complex(plant.foot.position(x_minus[:n])),
        complex(plant.foot.velocity(x_minus[:n], x_minus[n:])),
    )
    return tau, strike, problem


def largest_push(
    walk,
    *,
    direction: float = 1.0,
    steps: int = 10,
    tolerance: float = 0.5,
    upper: float = 200.0,
    push_step: int = 1,
    push_at: float = 0.5,
):
    """The largest horizontal push on the torso (N s, along ``direction``: +1 forward, -1
    back) after which the biped still walks, by bisection to ``tolerance`` N s between 0 and
    ``upper``. ``walk(disturbances)`` runs a walk of ``steps`` steps with those disturbances
    and returns a run with ``walked`` and ``fell`` (:func:`simulate_walking`, or MuJoCo's).

    Returns (the push, the run that survived it). Bisection assumes that a push that is
    survived is survived by every smaller one.
    """
    tolerance = check_positive("tolerance", tolerance, "N s")
    upper = check_positive("upper", upper, "N s")
    sign = 1.0 if check_real("direction", direction) >= 0 else -1.0

    def run(push):
        return walk(Disturbances(push=sign * push, push_step=push_step, push_at=push_at))

    survived = run(0.0)
    if survived.walked < steps:
        raise RuntimeError(
            f"largest_push: the undisturbed gait does not walk {steps} steps ({survived.fell})"
        )
    low, high = 0.0, upper
    top = run(high)
    if top.walked >= steps:
        return high, top
    while high - low > tolerance:
        middle = 0.5 * (low + high)
        attempt = run(middle)
        if attempt.walked >= steps:
            low, survived = middle, attempt
        else:
            high = middle
    return low, survived


def foot_height(plant: Plant, x, foothold: complex, ground) -> float:
    """The swing foot's height over the ground under it, m."""
    world = foothold + plant.swing_foot(x[: plant.n])
    return world.imag - ground(world.real)


def locate_strike(plant: Plant, x, torques, period: float, foothold: complex, ground):
    """The instant tau in (0, period] when the swing foot reaches the ground, and the state
    then, on the period's own RK4 step (:func:`locate_event` on the foot's height)."""
    return locate_event(
        plant.advance, x, torques, period, lambda y: foot_height(plant, y, foothold, ground)
    )


def locate_event(advance, x, torques, period: float, value):
    """The instant tau in (0, period] when ``value(state)`` (> 0 at x) reaches 0 on the RK4
    step ``advance(x, torques, tau)``, and the state then (secant iterations bracketed by
    bisection, to :data:`STRIKE_TOLERANCE`)."""

    def at(tau):
        state = np.asarray(advance(x, torques, tau)).ravel()
        return value(state), state

    low, high = 0.0, period
    v_low = value(x)
    v_high, state = at(high)
    for _ in range(60):
        if abs(v_high) <= STRIKE_TOLERANCE or high - low < 1e-15:
            break
        # secant inside the bracket, bisection when it would leave it
        tau = (
            high - v_high * (high - low) / (v_high - v_low)
            if v_high != v_low
            else 0.5 * (low + high)
        )
        if not low < tau < high:
            tau = 0.5 * (low + high)
        v_tau, s_tau = at(tau)
        if v_tau > 0.0:
            low, v_low = tau, v_tau
        else:
            high, v_high, state = tau, v_tau, s_tau
    return high, state


def _stood(plant: Plant, t: float, x: np.ndarray) -> tuple:
    """The strike record of a step that ended standing at t: no impact, the resting foot
    where it is (the step's length) and how it moves."""
    n = plant.n
    foot = complex(plant.foot.position(x[:n]))
    velocity = complex(plant.foot.velocity(x[:n], x[n:]))
    return (t, x.copy(), np.zeros(2), foot, velocity)


def _standing_problem(height: float, t: float, step_time: float) -> str | None:
    """What is wrong with the swing foot of a step that ends standing, or None: in the
    ground (from half the step on), or off it past the planned step time."""
    if t >= 0.5 * step_time and height < -STAND_HEIGHT:
        return f"the swing foot is {-1000 * height:.1f} mm in the ground before it stands"
    if t >= step_time and height > STAND_HEIGHT:
        return f"the swing foot stays {1000 * height:.1f} mm above the ground beside the other"
    return None


def _cone_problem(contact: Contact, who: str, force, slack) -> str | None:
    """Why ``contact`` (``who`` in the message) cannot carry ``force`` (Fx, Fy) N, or None
    (no check for a plant without a friction coefficient)."""
    if contact.friction is None:
        return None
    return contact.violation(force[0], force[1], slack, who=who)


def _ground_problem(heights, foothold: complex, ground) -> str | None:
    low = float(np.min(heights)) + foothold.imag - ground(foothold.real)
    if low < -1e-9:
        return f"a body point is {-low * 1000:.1f} mm under the ground"
    return None


def _impact_problem(impulse, lift, landing: Contact) -> str | None:
    ix, iy = impulse
    if landing.friction is not None:
        slipped = landing.violation(ix, iy, CONE_SLACK * abs(iy), "the landing foot", "N s")
        if slipped is not None:
            return f"{slipped}, at the impact"
    if lift[1] < 0.0:
        return f"the trailing foot does not lift off (it would move down at {lift[1]:.3f} m/s)"
    return None


__all__: Sequence[str] = (
    "Controller",
    "Disturbances",
    "Plant",
    "StepRecord",
    "WalkingRun",
    "disturbances_for",
    "largest_push",
    "locate_event",
    "locate_strike",
    "scaled_linkage",
    "simulate_walking",
)
