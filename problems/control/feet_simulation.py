"""Many steps of a walker on feet in the product's own simulation: the plan's equations of
motion on a floating base, the ground a compliant contact at each foot's heel and ball, the
drives under the file's law; beside MuJoCo's engine (:mod:`problems.control.mujoco_feet`),
the same walk through another model of contact and other equations.

The plant is the plan's tree (:class:`problems.walking.footed.FootedStep`), its masses and
inertias the plan's or scaled (``Disturbances.mass_scale``), on a floating base: q = (x0, y0,
psi) with z0 = x0 + j y0 the first stance foot's ball in the world (the tree never re-roots:
as in MuJoCo, the legs keep their bodies and only the law's labels swap). With the coupling G
(the body's linear momentum is m z0' + G psi') its equations are the
fixed base's with the base's acceleration and the contacts' forces F_P at the four foot
points P (``model.floating``):

    M(psi) psi'' + [Re G, Im G]^T z0'' = M a_free + sum_P J_P^T F_P,
    m z0'' + G psi'' + at_rest = sum_P F_P,

a_free the fixed base's forward dynamics under the drives (``Dynamics.forward_dynamics``),
at_rest its ground reaction at psi'' = 0 (the body's weight m g in it), J_P the point's
Jacobian: one (n + 2) solve per evaluation, ``substeps`` steps per control period, the
drives' torques held over each period (a digital controller at
:data:`problems.control.feet_law.CONTROL_RATE_HZ`).

The ground (:class:`Ground`): a point d = -y m under it is pushed up by k d + c d' (never
pulling: 0.3 mm of sink under a flat foot's share of the six-link walker's weight, damped
past critical: nearly plastic), and along the ground by a tangential spring and damper from
where it touched down, capped at mu times the normal force: past the cap the anchor slides
with the point (Coulomb friction). The contacts' damping is stiff, so the step is
semi-implicit Euler with the damping implicit (:func:`_step`). Nothing of the plan's contact
phases is imposed: the feet lie flat, rise, strike and leave as these forces make them.

The law (:class:`problems.control.feet_law.FeetLaw`) runs as in MuJoCo: its single support's
branch until the swing foot's striking point carries more than ``TOUCHDOWN_FORCE`` past half
the step, its double support's until the hip's phase reaches 1, then the next step's law, in
the other foot's labels (``biped.swap``). A fall is named: a knee, hip or head 2 cm under
the ground, a step longer than twice its plan, a state that is no longer finite; a stop that
does not end standing (the swing ball beside the stance ball, the hip at rest) is named too.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import casadi as ca
import numpy as np

from model.dynamics import Dynamics
from planner.errors import DefinitionError, check_integer, check_positive, check_real
from problems.control.buffered import BufferedCalls
from problems.control.feet_law import CONTROL_RATE_HZ, FeetLaw, walk_laws
from problems.control.mujoco import TOUCHDOWN_FORCE, MujocoStep
from problems.control.mujoco_feet import STAND, stood
from problems.control.simulation import Disturbances, scaled_linkage

#: integration steps per control period (0.25 ms at 1 kHz: the ground's stiffness against
#: a foot point's effective mass, a few thousand rad/s, wants it)
SUBSTEPS = 4
#: m: a knee, hip or head this far under the ground has fallen (MuJoCo's loop's criterion)
FALL_DEPTH = 0.02
#: the foot points, by the plan's role (the plant's labels: the first stance foot's)
FOOT_POINTS = ("stance_heel", "stance_toe", "swing_heel", "swing_toe")


@dataclass(frozen=True)
class Ground:
    """The ground's compliance at a foot point: the normal force k d + c d' for a sink d m
    (never pulling), the tangential spring ``tangential_stiffness`` N/m and damper
    ``tangential_damping`` N s/m from where the point touched down, capped at ``mu`` times
    the normal force (None: the plan's mu).

    The defaults: k = 1e6 N/m sinks a flat foot's heel or ball 0.3 mm under half the six-link
    walker's weight, as MuJoCo's walker sinks into its ground (its ``PRELOAD``); c = 2e4 N s/m
    is critical damping for 100 kg on k, so every foot point's contact is overdamped: nearly
    plastic, as the plan's impacts are. Measured on the 1 m/s step on feet (``python
    examples/benchmarks/feet_simulation.py``): softer damping (5e3 N s/m) lets the heel,
    landing at 2 m/s forward, slide 3 cm at each strike and the law saturate the front ankle
    through the double support; at 2e4 the steps, tracking and forces are MuJoCo's."""

    stiffness: float = 1e6
    damping: float = 2e4
    tangential_stiffness: float = 2e5
    tangential_damping: float = 5e3
    mu: float | None = None

    def __post_init__(self) -> None:
        check_positive("stiffness", self.stiffness, "N/m")
        check_positive("damping", self.damping, "N s/m")
        check_positive("tangential_stiffness", self.tangential_stiffness, "N/m")
        check_positive("tangential_damping", self.tangential_damping, "N s/m")
        if self.mu is not None:
            check_positive("mu", self.mu)


class FeetPlant(BufferedCalls):
    """The plan's tree on a floating base with compliant feet (module docstring).

    Parameters
    ----------
    step : FootedStep
        The plan's step (its tree, foot points, friction, leg swap).
    mass_scale : float
        The plant's masses and moments of inertia are the plan's times this (its rotors as
        they are).
    ground : Ground
        The ground's compliance (default :class:`Ground`).
    """

    def __init__(self, step, mass_scale: float = 1.0, ground: Ground | None = None) -> None:
        check_positive("mass_scale", mass_scale)
        self.step = step
        plan = step.linkage
        linkage = plan if mass_scale == 1.0 else scaled_linkage(plan, mass_scale)
        self.dynamics = (step.dynamics if mass_scale == 1.0
                         else Dynamics(linkage, rotors=step.dynamics.rotors))  # fmt: skip
        self.n = linkage.n
        self.ground = ground or Ground()
        self.mu = float(step.mu if self.ground.mu is None else self.ground.mu)
        self.points = [self.dynamics.point(step.points[role]) for role in FOOT_POINTS]
        self.swap = step.biped.swap
        self.masses = np.array([link.mass for link in linkage.links])
        self.mass = float(self.masses.sum())
        self.weight = self.mass * linkage.gravity
        # the knees, hips, neck and head: the ends of every link but the feet and the shanks
        # (hinge_positions lists H0, then each link's end)
        low = {*step.biped.stance_leg[:2], *step.biped.swing_leg[-2:]}
        self._body_points = [1 + i for i, name in enumerate(linkage.names) if name not in low]

    @cached_property
    def _terms(self) -> ca.Function:
        """One SX Function of what a step evaluates: (psi, dpsi, M) -> the floating base's
        mass matrix M_e (n + 2, n + 2) and right-hand side b (n + 2,) (M_e (psi'', z0'') = b
        + the contacts' generalised forces), the foot points' positions and velocities
        relative to the root (4, 2) each, their Jacobians d(x, y)/d(psi, x0, y0) stacked
        (8, n + 2), and the hinges H0..Hn relative to the root (n + 1, 2): one call instead of
        a dozen (the model's own Functions, composed)."""
        dynamics = self.dynamics
        n = self.n
        psi, dpsi, torques = ca.SX.sym("psi", n), ca.SX.sym("dpsi", n), ca.SX.sym("M", n)
        matrix = dynamics.function("mass_matrix")(psi)
        vx, vy = dynamics.function("com_velocities")(psi, dpsi)
        masses = ca.DM(self.masses)
        # G: the fixed base's linear momentum is G . dpsi (the floating base's coupling row)
        coupling_x = ca.jacobian(ca.dot(masses, vx), dpsi)  # (1, n): Re G
        coupling_y = ca.jacobian(ca.dot(masses, vy), dpsi)
        mass = ca.blockcat([[matrix, coupling_x.T, coupling_y.T],
                            [coupling_x, ca.DM(self.mass), ca.DM(0.0)],
                            [coupling_y, ca.DM(0.0), ca.DM(self.mass)]])  # fmt: skip
        free = dynamics.function("forward_dynamics")(psi, dpsi, torques)
        fx, fy = dynamics.function("ground_reaction")(psi, dpsi, ca.DM.zeros(n))
        right = ca.vertcat(ca.mtimes(matrix, free), -fx, -fy)
        positions, velocities, jacobians = [], [], []
        for point in self.points:
            positions.append(ca.horzcat(*point.function("position")(psi)))
            velocities.append(ca.horzcat(*point.function("velocity")(psi, dpsi)))
            floating = point.function("jacobian")(psi)  # columns (x0, y0, psi)
            jacobians.append(ca.horzcat(floating[:, 2:], floating[:, :2]))
        hinges = ca.horzcat(*dynamics.function("hinge_positions")(psi))
        outputs = [mass, right, ca.vertcat(*positions), ca.vertcat(*velocities),
                   ca.vertcat(*jacobians), hinges]  # fmt: skip
        return ca.Function("feet_plant", [psi, dpsi, torques], [ca.densify(o) for o in outputs],
                           ["psi", "dpsi", "M"],
                           ["mass", "right", "positions", "velocities", "jacobians",
                            "hinges"])  # fmt: skip

    def terms(self, psi, dpsi, torques) -> _Terms:
        """:class:`_Terms` at one state (:attr:`_terms`, through CasADi's evaluation buffer:
        its call's conversions cost more than its 1400 instructions)."""
        n, n2 = self.n, self.n + 2
        mass, right, positions, velocities, jacobians, hinges = self._buffered(
            "terms", lambda: self._terms)(psi, dpsi, torques)  # fmt: skip
        # CasADi's dense outputs are column-major
        positions, velocities = positions.reshape(2, 4), velocities.reshape(2, 4)
        hinges = hinges.reshape(2, n + 1)
        return _Terms(mass.reshape(n2, n2).T, right, positions[0] + 1j * positions[1],
                      velocities[0] + 1j * velocities[1],
                      jacobians.reshape(n2, 8).T.reshape(4, 2, n2),
                      hinges[0] + 1j * hinges[1])  # fmt: skip

    def accelerations(self, psi, dpsi, torques, forces=(), base_force: complex = 0j,
                      impulse: bool = False):  # fmt: skip
        """(psi'' (n,), z0'' complex m/s^2) under the hinge ``torques`` (n,) N m (the root's,
        the ground's torque on the first stance foot, 0: the ground acts through the points),
        the point ``forces`` (one complex N per :data:`FOOT_POINTS`, or none) and a force on
        the whole body ``base_force`` (complex N, through its centre of mass: none of the
        angles' generalised forces).

        ``impulse``: the jumps (dpsi, dz0) instead, ``torques`` then the generalised impulse on
        the angles (n,) N m s and ``base_force`` the linear impulse (N s); no bias terms."""
        n = self.n
        zero = np.zeros(n)
        terms = self.terms(psi, zero if dpsi is None else dpsi, zero if impulse else torques)
        right = np.concatenate([torques, [0.0, 0.0]]) if impulse else terms.right.copy()
        right[n] += base_force.real
        right[n + 1] += base_force.imag
        for jacobian, force in zip(terms.jacobians, forces, strict=False):
            right += jacobian.T @ np.array([force.real, force.imag])
        solution = np.linalg.solve(terms.mass, right)
        return solution[:n], complex(solution[n], solution[n + 1])

    def contact_forces(self, positions, velocities, anchors):
        """(forces (4,) complex N, anchors (4,) m, ``None`` where free): the ground's force on
        each foot point and where its tangential spring is anchored after it (a new anchor
        at a point that touches down; one dragged along where the cap binds)."""
        ground = self.ground
        forces = np.zeros(4, dtype=complex)
        after = list(anchors)
        for i, (z, v) in enumerate(zip(positions, velocities, strict=True)):
            sink = -z.imag
            if sink <= 0.0:
                after[i] = None
                continue
            normal = max(0.0, ground.stiffness * sink - ground.damping * v.imag)
            anchor = z.real if after[i] is None else after[i]
            tangential = -ground.tangential_stiffness * (z.real - anchor) - \
                ground.tangential_damping * v.real  # fmt: skip
            cap = self.mu * normal
            if abs(tangential) > cap:  # it slides: the anchor follows, the force at the cap
                tangential = float(np.sign(tangential)) * cap
                anchor = z.real + (tangential + ground.tangential_damping * v.real) / \
                    ground.tangential_stiffness  # fmt: skip
            forces[i] = complex(tangential, normal)
            after[i] = anchor
        return forces, after

    def body_clearance(self, hinges) -> float:
        """The lowest of the knees, hips, neck and head, m above the ground (``hinges`` H0..Hn
        in the world, complex m)."""
        return float(np.min(hinges.imag[self._body_points]))


@dataclass(frozen=True)
class _Terms:
    """What one evaluation of the plant gives (:meth:`FeetPlant.terms`): ``mass`` M_e and
    ``right`` b of the floating base's equations, the foot points' ``positions`` and
    ``velocities`` relative to the root (4,) complex, their ``jacobians`` (4, 2, n + 2), the
    ``hinges`` H0..Hn relative to the root (n + 1,) complex."""

    mass: np.ndarray
    right: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    jacobians: np.ndarray
    hinges: np.ndarray


@dataclass(frozen=True)
class FeetRun:
    """The outcome of :func:`simulate_feet_steps`: the steps walked (each the record MuJoCo's
    loop keeps, :class:`problems.control.mujoco.MujocoStep`, so that the two compare field by
    field), why it ended early
    (``fell``, None: it walked them all), each control instant's ``time`` (K,) s and state
    ``states`` (K, 2n + 4): psi, dpsi in the first stance foot's labels, then x0, y0, x0',
    y0' of its ball, m and m/s."""

    steps: tuple[MujocoStep, ...]
    fell: str | None
    time: np.ndarray
    states: np.ndarray

    @property
    def walked(self) -> int:
        return len(self.steps)


class _Walk:
    """The plant's state through a walk: z = (psi, dpsi, x0, y0, x0', y0') and the contacts'
    anchors."""

    def __init__(self, plant: FeetPlant, x: np.ndarray) -> None:
        self.plant = plant
        n = plant.n
        self.z = np.concatenate([x, np.zeros(4)])
        psi = x[:n]
        # the first stance foot flat at rest on the ground, sunk to carry the body's weight
        # on its heel and ball (half each): the start neither drops nor bounces
        self.z[2 * n + 1] = -0.5 * plant.weight / plant.ground.stiffness
        positions = plant.terms(psi, np.zeros(n), np.zeros(n)).positions + 1j * self.z[2 * n + 1]
        self.anchors = [z.real if z.imag < 0.0 else None for z in positions]

    def advance(self, torques, h: float) -> None:
        """One step of h s (semi-implicit Euler, the contacts' damping implicit: see
        :func:`_step`), the contacts' anchors moved with it."""
        self.z, self.anchors = _step(self.plant, self.z, torques, self.anchors, h)

    def sense(self):
        """(the contact forces (4,) complex N, the foot points (4,) and the hinges (n + 1,) in
        the world, complex m) at the state, its anchors as they are: one evaluation."""
        plant, z = self.plant, self.z
        n = plant.n
        base = complex(z[-4], z[-3])
        terms = plant.terms(z[:n], z[n : 2 * n], np.zeros(n))
        points = terms.positions + base
        forces, _ = plant.contact_forces(points, terms.velocities + complex(z[-2], z[-1]),
                                         self.anchors)  # fmt: skip
        return forces, points, terms.hinges + base

    def push(self, link: str, impulse: float) -> None:
        """A horizontal impulse (N s) on ``link``'s centre of mass (the contacts' forces are
        finite: they give no impulse within the instant)."""
        plant = self.plant
        n = plant.n
        psi = self.z[:n]
        i = plant.dynamics.linkage.index(link)
        # column k: the centre of mass's velocity for dpsi = e_k; the base moves it as z0'
        jacobian = plant.dynamics.com_velocities(np.tile(psi, (n, 1)), np.eye(n))[:, i]
        generalised = (np.conj(jacobian) * complex(impulse)).real
        jump, base = plant.accelerations(psi, None, generalised, base_force=complex(impulse),
                                         impulse=True)  # fmt: skip
        self.z[n : 2 * n] += jump
        self.z[-2] += base.real
        self.z[-1] += base.imag


def _step(plant: FeetPlant, z: np.ndarray, torques, anchors, h: float):
    """(z (2n + 4,) after h s, the contacts' anchors at its start): the velocities
    u = (dpsi, z0') first, from the equations of motion with the contacts' damping taken at
    the new velocities (linearly implicit:
    (M_e - h sum_P J_P^T C_P J_P) du = h (b + sum_P J_P^T F_P), C_P the forces' derivatives
    by the point's velocity), then the positions from the new velocities (semi-implicit
    Euler, as MuJoCo's default integrator): stable under the ground's damping, which an
    explicit step would need a hundred times shorter steps for."""
    n = plant.n
    ground = plant.ground
    psi, dpsi = z[:n], z[n : 2 * n]
    base, rate = complex(z[-4], z[-3]), complex(z[-2], z[-1])
    terms = plant.terms(psi, dpsi, torques)
    forces, anchors = plant.contact_forces(terms.positions + base, terms.velocities + rate,
                                           anchors)  # fmt: skip
    lhs, right = terms.mass, terms.right
    for jacobian, force in zip(terms.jacobians, forces, strict=True):
        if force == 0:
            continue
        right = right + jacobian.T @ np.array([force.real, force.imag])
        damping = np.zeros(2)
        if force.imag > 0.0:
            damping[1] = ground.damping
        if abs(force.real) < plant.mu * force.imag:  # stuck: the tangential damper acts
            damping[0] = ground.tangential_damping
        lhs = lhs + h * jacobian.T @ (damping[:, None] * jacobian)
    u = np.concatenate([dpsi, [rate.real, rate.imag]]) + h * np.linalg.solve(lhs, right)
    q = np.concatenate([psi, [base.real, base.imag]]) + h * u
    return np.concatenate([q[:n], u[:n], q[n:], u[n:]]), anchors


def simulate_feet_steps(
    gaits,
    *,
    disturbances: Disturbances | None = None,
    laws=None,
    stand: float = STAND,
    substeps: int = SUBSTEPS,
    ground: Ground | None = None,
    open_loop: bool = False,
    rate_hz: float = CONTROL_RATE_HZ,
) -> FeetRun:
    """Walk the steps on feet ``gaits`` (:class:`problems.walking.footed.FootedGait`, one per
    step, in order) once each from the first one's start in the product's plant on feet
    (module docstring), step j under ``laws[j]`` (default ``FeetLaw(gaits[j])``, made once
    per distinct gait). A walk that ends with a stop holds standing ``stand`` s after it and
    counts the stop walked as MuJoCo's loop does (:func:`problems.control.mujoco_feet.stood`:
    the swing ball beside the stance ball, the hip at rest). ``open_loop``: the plan's torques
    by the time since the branch began, no feedback. Disturbances: the start off the plan, a
    push on the torso (an impulse at ``push_at`` of step ``push_step``), the masses scaled,
    the drives saturated lower (the ground stays level: ``ground_rise`` is refused).
    ``rate_hz``: the controller's clock, Hz (the law evaluated, its torques held, its strike
    and hand-over detected once a period; ``substeps`` integration steps a period): the
    file's 1 kHz by default, faster to see the loop without its clock
    (:mod:`problems.control.feet_multiplier`)."""
    gaits, laws = walk_laws(gaits, laws)
    check_positive("stand", stand, "s")
    substeps = check_integer("substeps", substeps, 1)
    rate_hz = check_positive("rate_hz", rate_hz, "Hz")
    disturbances = disturbances or Disturbances()
    if disturbances.ground_rise != 0.0:
        raise DefinitionError(
            f"`disturbances.ground_rise`: {disturbances.ground_rise!r} m; the product's plant "
            "on feet walks level ground: leave it 0 (MuJoCo's loop takes a step of the ground)"
        )
    plant = FeetPlant(gaits[0].problem, disturbances.mass_scale, ground)
    return _run(plant, laws, disturbances, stand, substeps, open_loop, 1.0 / rate_hz)


def simulate_feet(gait, *, steps: int = 20, **options) -> FeetRun:
    """:func:`simulate_feet_steps` of one periodic step on feet repeated ``steps`` times
    (``law=`` one law for all; other options as there)."""
    steps = check_integer("steps", steps, 1)
    law = options.pop("law", None)
    law = FeetLaw(gait) if law is None else law
    return simulate_feet_steps((gait,) * steps, laws=(law,) * steps, **options)


#: each physical foot's heel and ball among :data:`FOOT_POINTS` (the plant's labels: the
#: first stance foot is foot 0)
HEELS, BALLS = (0, 2), (1, 3)


@dataclass
class _Tally:
    """One step of the law as it runs: its law, branch (0 single support, 1 double), the time
    since it began and since the strike, and what its record keeps."""

    law: FeetLaw
    branch: int = 0
    time: float = 0.0
    strike: float = 0.0
    tracking: float = 0.0
    peak_torque: float = 0.0
    peak_normal: float = 0.0
    saturated: int = 0

    def record(self, index: int, length: float, slip: float, double: float) -> MujocoStep:
        return MujocoStep(index, self.time, length, slip, self.peak_normal, self.tracking,
                          self.peak_torque, self.saturated, double)  # fmt: skip


def _command(tally: _Tally, x, limit, open_loop: bool) -> np.ndarray:
    """The drives' torques (n,) N m of the law for the state ``x`` in its labels, clipped at
    ``limit`` (the root's 0: the ground's), the tally's tracking, peak and saturation kept."""
    reference = tally.law.references[tally.branch]
    since = tally.time - (tally.strike if tally.branch else 0.0)
    if open_loop:
        torques = reference.at_time(since)[1].copy()
    else:
        torques = tally.law.torques(tally.branch, x, since)
    torques[0] = 0.0  # the ground's torque on the stance foot: no drive gives it
    tally.tracking = max(tally.tracking, reference.tracking(x, since))
    command = np.clip(torques, -limit, limit)
    tally.peak_torque = max(tally.peak_torque, float(np.max(np.abs(command))))
    tally.saturated += bool(np.any(np.abs(command[1:]) >= limit[1:]))
    return command


def _fall(walk: _Walk, hinges, tally: _Tally, index: int) -> str | None:
    """Why the walk has fallen after this period, or None."""
    if not np.all(np.isfinite(walk.z)):
        return f"step {index}, t = {tally.time:.3f} s: the state is no longer finite"
    if walk.plant.body_clearance(hinges) < -FALL_DEPTH:
        return f"step {index}, t = {tally.time:.3f} s: a body point went under the ground"
    if not tally.law.step.stop and tally.time > 2.0 * tally.law.step.step_time:
        return f"step {index}: the step did not end within twice the step time"
    return None


def _run(plant: FeetPlant, laws, disturbances, stand, substeps, open_loop,
         period: float) -> FeetRun:  # fmt: skip
    """The control loop of :func:`simulate_feet_steps` (``period``: the controller's, s)."""
    n = plant.n
    start = laws[0].references[0].states[0].copy()
    if disturbances.initial is not None:
        start = start + np.asarray(disturbances.initial, dtype=float)
    walk = _Walk(plant, start)
    first = laws[0].step
    limit = np.array([0.0] + [first.limits[name] for name in first.linkage.names[1:]])
    if disturbances.torque_limit is not None:
        limit = np.minimum(limit, disturbances.torque_limit)
    torso = first.biped.upper_body[0]
    hip = 1 + first.linkage.index(first.biped.stance_thigh)  # the hip among the hinges
    records: list[MujocoStep] = []
    times, states, hips = [], [], []
    tally, law_id = _Tally(laws[0]), 0  # law_id: the physical foot the law's stance foot is
    pushed = disturbances.push == 0.0
    fell = None
    _, points, _ = walk.sense()
    stance_ball = points[BALLS[0]].real
    while len(records) < len(laws) and fell is None:
        step = tally.law.step
        psi, dpsi = walk.z[:n], walk.z[n : 2 * n]
        if law_id:  # the law's labels: the other foot in stance
            psi, dpsi = plant.swap.map_state(psi, dpsi)
        command = _command(tally, np.concatenate([psi, dpsi]), limit, open_loop)
        applied = plant.swap.map_torques(command) if law_id else command
        applied[0] = 0.0
        if not pushed and len(records) == disturbances.push_step and \
                tally.time >= disturbances.push_at * step.step_time - 1e-12:  # fmt: skip
            walk.push(torso, disturbances.push)
            pushed = True
        for _ in range(substeps):
            walk.advance(applied, period / substeps)
        forces, points, hinges = walk.sense()
        tally.time += period
        times.append(times[-1] + period if times else period)
        states.append(walk.z.copy())
        fell = _fall(walk, hinges, tally, len(records))
        if fell is not None:
            break
        stance = forces[HEELS[law_id]].imag + forces[BALLS[law_id]].imag
        tally.peak_normal = max(tally.peak_normal, float(stance))
        slip = abs(points[BALLS[law_id]].real - stance_ball)
        gap = points[BALLS[1 - law_id]].real - stance_ball  # the other ball, ahead
        if step.stop:  # quiet standing: the stop, then its last sample held
            hips.append(float(hinges[hip].real))
            if tally.time >= tally.law.references[0].duration + stand - 1e-12:
                beside = (points[BALLS[1 - law_id]] - points[BALLS[law_id]]).real
                fell = stood(len(records), beside, hips, period)
                if fell is None:
                    records.append(tally.record(len(records), beside, slip, 0.0))
                break
            continue
        s = tally.law.phase(psi)
        striking = (HEELS if step.strike_role == "swing_heel" else BALLS)[1 - law_id]
        if tally.branch == 0 and s > 0.5 and forces[striking].imag > TOUCHDOWN_FORCE:
            tally.branch, tally.strike = 1, tally.time  # struck: the double support's branch
        elif tally.branch == 1 and s >= 1.0:
            if gap < 0.25 * step.step_length:
                fell = (f"step {len(records)}, t = {tally.time:.3f} s: the front ball came "
                        f"down {gap:+.3f} m from the stance ball")  # fmt: skip
                break
            records.append(tally.record(len(records), gap, slip, tally.time - tally.strike))
            law_id, stance_ball = 1 - law_id, stance_ball + gap
            tally = _Tally(laws[len(records) % len(laws)])
    return FeetRun(tuple(records), fell, np.asarray(times),
                   np.asarray(states).reshape(-1, 2 * n + 4))  # fmt: skip


def section_states(run: FeetRun, law: FeetLaw, phase: float = 0.3) -> np.ndarray:
    """Each walked step's state x = (psi, dpsi) (2n,) at the first control instant its
    single support reaches ``phase`` of ``law`` (a step of a walk of that one law), in the
    law's labels (the steps alternate feet: step k's in the other foot's labels for odd k,
    so that every step compares with the one before): (steps, 2n). A Poincare section of
    the walk, the stride map's points."""
    check_real("phase", phase)
    if not 0.0 < phase < 1.0:
        raise DefinitionError(f"`phase`: {phase!r}; a phase of the single support, in (0, 1)")
    swap = law.step.biped.swap
    n = law.step.linkage.n
    ends = np.cumsum([step.duration for step in run.steps])
    starts = np.concatenate([[0.0], ends[:-1]])
    rows = []
    for k, (start, end) in enumerate(zip(starts, ends, strict=True)):
        for i in np.nonzero((run.time > start + 1e-9) & (run.time <= end + 1e-9))[0]:
            psi, dpsi = run.states[i, :n], run.states[i, n : 2 * n]
            if k % 2:
                psi, dpsi = swap.map_state(psi, dpsi)
            if law.phase(psi) >= phase:
                rows.append(np.concatenate([psi, dpsi]))
                break
    return np.asarray(rows).reshape(-1, 2 * n)


__all__ = [
    "FeetPlant",
    "FeetRun",
    "Ground",
    "section_states",
    "simulate_feet",
    "simulate_feet_steps",
]
