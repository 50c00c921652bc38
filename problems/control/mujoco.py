"""The planned walking step, its torques and its gains, run in MuJoCo (``pip install
".[mujoco]"``): the same body written by :func:`model.to_mjcf` with a floating base, feet
with soles where the plan has an ankle torque (spheres of the plan's point feet otherwise),
on a plane with friction, driven at the controller's rate by the law that travels in the
torque file, M = clip(M_ff(s) + K(s) (x_ref(s) - x)).

What differs from the product's own simulation, and how the controller copes:

* MuJoCo's contacts are soft (a spring-damper of time constant ``contact_time_constant``):
  the heel strike is a few milliseconds of large force, not an impulse, and the stance foot
  may sink and slip a little. A step ends when the swing foot touches the ground with a
  normal force above ``TOUCHDOWN_FORCE`` once past half the step (s > 0.5); the legs are then
  relabelled and the phase starts again from the new stance foot, whatever the time: early
  or late touchdowns re-index the reference instead of running out of step.
* The robot's ankles: the plan's stance ankle torque M_1 (the ground's on the stance shank)
  is the stance ankle motor's, -M_1 on the foot; the swing foot's ankle holds the foot flat
  (a PD on its angle, gains ``foot_kp``, ``foot_kd``), so that it lands on its sole.
* After the leg swap the plan's hinge torques are in the swapped labels: their generalised
  forces on every body (the same in both descriptions, :meth:`model.Rerooting.map_torques`)
  less the ground's torque on the stance shank are summed over MuJoCo's subtrees to give its
  motors' torques.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

import numpy as np

from model.mjcf import MjcfModel, to_mjcf
from planner.errors import DefinitionError, check_integer, check_positive
from problems.control.buffered import BufferedCall
from problems.control.feedback import PUSH_STEPS, disturbance_cases
from problems.control.lqr import SOFT_RAMP, SOFT_SETTLE, SwitchedLQR
from problems.control.simulation import Disturbances, largest_push
from problems.gait.biped import Biped
from problems.walking.step import WorldMotion, world_motion

#: a swing foot touches down when its contact's normal force passes this, N
TOUCHDOWN_FORCE = 5.0
#: MuJoCo settings of the walker (see examples/feedback.md)
CONTACT_TIME_CONSTANT = 0.004
TIMESTEP = 0.0005
#: each foot's mass, kg: not in the plan (1.7 % of the six-link's 60 kg for two); with
#: 0.05 kg feet MuJoCo's simulation goes unstable in the first step, 0.5 kg feet walk
#: (measured, README)
FOOT_MASS = 0.5
#: the swing foot's ankle PD that keeps it flat, N m/rad and N m s/rad
FOOT_KP = 20.0
FOOT_KD = 0.2
#: m/s: at the end of a walk that stops, after its stand, the hip moves slower than this, or
#: the walker has not come to rest
REST_SPEED = 0.05
#: the walker starts this far into the ground, m: a soft contact at zero depth carries nothing
#: yet, and the first instants would drop the body
PRELOAD = 3e-4


def import_mujoco():
    """The mujoco module, or a DefinitionError saying how to install it."""
    try:
        import mujoco
    except ImportError as error:  # pragma: no cover - the extra is installed in CI
        raise DefinitionError(
            'MuJoCo is not installed: pip install ".[mujoco]" (or pip install mujoco)'
        ) from error
    return mujoco


def contact_normal_force(mujoco, model, data, grounds, geoms) -> float:
    """The ground's normal force on the geoms (ids) now, N: the sum over MuJoCo's contacts
    between one of ``geoms`` and one of ``grounds``."""
    total = 0.0
    force = np.zeros(6)
    for c in range(data.ncon):
        contact = data.contact[c]
        touching = contact.geom[0] in grounds or contact.geom[1] in grounds
        if touching and (contact.geom[0] in geoms or contact.geom[1] in geoms):
            mujoco.mj_contactForce(model, data, c, force)
            total += force[0]
    return total


@dataclass(frozen=True)
class MujocoStep:
    """One step in MuJoCo: duration s, length m (between the stance ankles), slip m (how far
    the stance foot's ankle moved along the ground), peak_normal N (the stance foot's largest
    normal force), tracking rad (the largest angle error at the same phase), peak_torque N m
    (the largest motor command, ankles included), saturated: control periods in which a drive
    was held at its limit (counted by the walk on feet; None where not counted),
    double_support: s from the touchdown to the rear foot's lift-off (None: a step without
    one)."""

    index: int
    duration: float
    length: float
    slip: float
    peak_normal: float
    tracking: float
    peak_torque: float
    saturated: int | None = None
    double_support: float | None = None


@dataclass(frozen=True)
class MujocoRun:
    """Steps walked in MuJoCo; fell: why it ended early (None: it walked them all)."""

    steps: tuple[MujocoStep, ...]
    fell: str | None
    time: np.ndarray
    qpos: np.ndarray
    mjcf: MjcfModel

    @property
    def walked(self) -> int:
        return len(self.steps)

    def world(self, dynamics, rate_hz: float = 60.0, corners=None) -> WorldMotion:
        """MuJoCo's bodies in world coordinates (``dynamics``: the plan's model, whose links
        MuJoCo's bodies are), sampled at about ``rate_hz`` and at the last instant, for
        :func:`problems.walking.plots.world_strip`: each body keeps its name in the MJCF
        (MuJoCo does not swap legs), the footholds are the start's stance foot then each
        step's length further; ``corners`` as for :func:`problems.walking.step.world_motion`."""
        rate = check_positive("rate_hz", rate_hz, "Hz")
        if self.time.size == 0:
            raise DefinitionError("`run`: it has no recorded instant to draw")
        marks = np.arange(self.time[0], self.time[-1], 1.0 / rate)
        picks = np.unique(np.r_[np.searchsorted(self.time, marks), self.time.size - 1])
        coordinates = self.mjcf.model_coordinates(self.qpos[picks])
        time = self.time[picks]
        zeros = np.zeros(time.size, dtype=int)
        # one description (MuJoCo's labels) at H0 = 0, then moved by the floating base
        placed = world_motion(Biped.of(dynamics.linkage), dynamics, time, coordinates[:, 2:],
                              zeros, np.zeros(1, dtype=complex), corners)  # fmt: skip
        base = coordinates[:, 0] + 1j * coordinates[:, 1]
        segments = {name: ends + base[:, None] for name, ends in placed.segments.items()}
        ends = np.cumsum([record.duration for record in self.steps])
        step = np.searchsorted(ends, time - self.time[0] + 1e-12, side="right")
        footholds = complex(base[0]) + np.r_[0.0, np.cumsum([r.length for r in self.steps])]
        return WorldMotion(time, segments, step, footholds.astype(complex))


def disturbed_model(mujoco, mjcf: MjcfModel, disturbances, step_length: float,
                    contact_time_constant: float):  # fmt: skip
    """(MjModel, MjData) of a walker's MJCF under ``disturbances``: the ground ``ground_rise``
    higher from half a step before foothold ``ground_from`` on (:func:`with_terrain`), the
    links' masses and inertias scaled by ``mass_scale`` (the controller keeps the plan's),
    every contact's time constant ``contact_time_constant`` s."""
    xml = mjcf.xml
    if disturbances.ground_rise != 0.0:
        edge = (disturbances.ground_from - 0.5) * step_length
        xml = with_terrain(xml, edge, disturbances.ground_rise)
    model = mujoco.MjModel.from_xml_string(xml)
    model.geom_solref[:, 0] = contact_time_constant
    if disturbances.mass_scale != 1.0:
        bodies = [model.body(name).id for name in mjcf.linkage.names]
        model.body_mass[bodies] *= disturbances.mass_scale
        model.body_inertia[bodies] *= disturbances.mass_scale
    return model, mujoco.MjData(model)


@contextlib.contextmanager
def instability_reports(mujoco):
    """A list that collects MuJoCo's warnings while the block runs: MuJoCo reports an unstable
    simulation on stdout and resets it; a walk reads any report as a fall."""
    reports: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(reports.append)
    try:
        yield reports
    finally:
        mujoco.set_mju_user_warning(previous)


def push_torso(mujoco, model, data, torso: int, impulse: float, period: float) -> None:
    """Apply a horizontal ``impulse`` N s on body ``torso``'s centre of mass over one control
    ``period`` s (the caller clears ``data.qfrc_applied`` after the period)."""
    data.qfrc_applied[:] = 0.0
    force = np.array([impulse / period, 0.0, 0.0])
    mujoco.mj_applyFT(model, data, force, np.zeros(3), data.xipos[torso], torso,
                      data.qfrc_applied)  # fmt: skip


def due_push(disturbances, pushed: bool, step: int, t: float, step_time: float, torso: int,
             period: float):  # fmt: skip
    """(pushed, push): whether the push of ``disturbances`` (on step ``push_step`` at
    ``push_at`` of ``step_time``) is done after this period, and the push to give over it
    ((torso, impulse N s, period s) for :func:`advance`, or None), at t s into step ``step``."""
    now = not pushed and step == disturbances.push_step and t >= disturbances.push_at * step_time
    return pushed or now, ((torso, disturbances.push, period) if now else None)


def advance(mujoco, model, data, substeps: int, unstable: list, push=None) -> str | None:
    """One control period of MuJoCo (``substeps`` steps), with ``push`` (torso body id,
    impulse N s, period s: :func:`push_torso`) over it when given; MuJoCo's instability
    report (``unstable``: :func:`instability_reports`' list) or None."""
    if push is not None:
        push_torso(mujoco, model, data, *push)
    for _ in range(substeps):
        mujoco.mj_step(model, data)
    if push is not None:
        data.qfrc_applied[:] = 0.0
    return unstable[0].strip() if unstable else None


def with_terrain(xml: str, edge: float, rise: float) -> str:
    """The walker's MJCF with its ground plane replaced by two boxes: the ground as planned up
    to x = edge, ``rise`` m higher (or lower) after it."""
    line = next(row for row in xml.splitlines() if 'name="ground" type="plane"' in row)
    depth = float(line.split('pos="0 0 ')[1].split('"')[0])  # -contact radius
    friction = line.split('friction="')[1].split('"')[0]
    common = f'contype="0" conaffinity="1" condim="3" friction="{friction}" group="0"'
    boxes = (
        f'    <geom name="ground" type="box" size="50 1 0.5" '
        f'pos="{edge - 50.0!r} 0 {depth - 0.5!r}" {common}/>\n'
        f'    <geom name="ground_changed" type="box" size="50 1 0.5" '
        f'pos="{edge + 50.0!r} 0 {depth + rise - 0.5!r}" {common}/>'
    )
    return xml.replace(line, boxes)


def walker_mjcf(step, *, ground_mu: float, foot_mass: float = FOOT_MASS) -> MjcfModel:
    """The MJCF of a walking step's biped: floating, with feet where the plan has an ankle
    torque (its sole bound, ``step.foot_sole``, or 0.05 / 0.15 m) and point feet otherwise."""
    linkage = step.linkage
    biped = step.biped
    ends = [(biped.stance_shank, "start"), (biped.swing_shank, "end")]
    passive = biped.stance_shank in step.passive
    limits = {name: step.torque_limit[name] for name in linkage.names[1:]}
    if passive:
        return to_mjcf(linkage, base="floating", contacts=ends, friction=ground_mu,
                       torque_limits=limits, timestep=TIMESTEP, name="walker")  # fmt: skip
    heel, toe = step.foot_sole if step.foot_sole is not None else (0.05, 0.15)
    return to_mjcf(
        linkage,
        base="floating",
        feet=[(link, end, heel, toe) for link, end in ends],
        foot_mass=foot_mass,
        friction=ground_mu,
        torque_limits=limits,
        timestep=TIMESTEP,
        name="walker",
    )


def run_in_mujoco(
    feedback,
    *,
    steps: int = 20,
    disturbances: Disturbances | None = None,
    open_loop: bool = False,
    foot_kp: float = FOOT_KP,
    foot_kd: float = FOOT_KD,
    contact_time_constant: float = CONTACT_TIME_CONSTANT,
    foot_mass: float = FOOT_MASS,
    preload: float = PRELOAD,
    touchdown_settle: float = SOFT_SETTLE,
    touchdown_ramp: float = SOFT_RAMP,
) -> MujocoRun:
    """Walk ``steps`` steps in MuJoCo under ``feedback`` (:class:`problems.control.feedback.
    Feedback`) from the plan's start; ``open_loop``: the plan's torques by the time since the
    step began, no feedback. Disturbances: a push on the torso, a mass scale (MuJoCo's body
    is changed, the controller keeps the plan's).

    A step with a double support: at the touchdown the law switches to the double
    support's branch, and the step ends where that branch's phase reaches 1 (the rear foot
    lifts; the legs are relabelled). MuJoCo's impact is soft: the front foot bounces for
    some milliseconds while the rates are still the swing's, and the double support's stiff
    gains (designed for a foot held at once) would throw it back off, so the branch's
    feedback waits ``touchdown_settle`` s (its feedforward alone) and comes in over
    ``touchdown_ramp`` s (:class:`problems.control.lqr.SwitchedLQR`'s settle; the file's law
    says so).
    """
    mujoco = import_mujoco()
    steps = check_integer("steps", steps, 1)
    check_positive("contact_time_constant", contact_time_constant, "s")
    disturbances = disturbances or Disturbances()
    step = feedback.step
    mjcf = walker_mjcf(step, ground_mu=feedback.plant.mu, foot_mass=foot_mass)
    model, data = disturbed_model(mujoco, mjcf, disturbances, step.step_length,
                                  contact_time_constant)  # fmt: skip
    controller = feedback.controller
    if feedback.double is not None:
        controller = SwitchedLQR(*controller.branches, settle=touchdown_settle,
                                 ramp=touchdown_ramp)  # fmt: skip
    with instability_reports(mujoco) as unstable:
        return _walk(mujoco, model, data, mjcf, feedback, controller, steps, disturbances,
                     open_loop, foot_kp, foot_kd, preload, unstable)  # fmt: skip


class WalkerIo:
    """The MuJoCo walker seen as the plan sees it: the state in a step's labels for either
    stance foot (MuJoCo does not swap legs: "A" is the plan's first stance foot, "B" the
    other), the plan's hinge torques put on MuJoCo's motors (mapped back through the leg swap
    when "B" stands; the stance ankle's motor gives the plan's ankle torque, the swing
    ankle's holds its foot flat), the feet's ground forces and positions."""

    def __init__(self, mujoco, model, data, mjcf, step, limit: float | None) -> None:
        self.mujoco, self.model, self.data, self.mjcf = mujoco, model, data, mjcf
        biped = step.biped
        linkage = step.linkage
        self.biped, self.linkage, self.n = biped, linkage, linkage.n
        n = self.n
        self.children = np.zeros((n, n))
        for child, parent in enumerate(linkage.parents):
            if parent >= 0:
                self.children[parent, child] = 1.0
        self.subtree = np.ascontiguousarray(linkage.ancestry().T)
        self.swing_index = linkage.index(biped.swing_shank)
        actuators = {model.actuator(a).name: a for a in range(model.nu)}
        self.motor_ids = [actuators[f"M_{name}"] for name in linkage.names[1:]]
        self.feet = mjcf.feet
        self.foot_geoms = {}
        for label, (link, end) in {"A": (biped.stance_shank, "start"),
                                   "B": (biped.swing_shank, "end")}.items():  # fmt: skip
            names = [f"{link}_heel", f"{link}_toe"] if self.feet else [f"{link}_{end}"]
            self.foot_geoms[label] = {model.geom(g).id for g in names}
        self.grounds = {g for g in range(model.ngeom) if model.geom(g).name.startswith("ground")}
        self.ankle_ids = {}
        if self.feet:
            self.ankle_ids = {"A": actuators[f"M_ankle_{biped.stance_shank}"],
                              "B": actuators[f"M_ankle_{biped.swing_shank}"]}  # fmt: skip
        # every motor's limit: the plan's for its hinge, the stance ankle's for both ankles
        self.drive_limits = np.full(model.nu, np.inf)
        for name in linkage.names[1:]:
            self.drive_limits[actuators[f"M_{name}"]] = step.torque_limit.get(name, np.inf)
        for ankle in self.ankle_ids.values():
            self.drive_limits[ankle] = step.torque_limit.get(biped.stance_shank, np.inf)
        if limit is not None:
            self.drive_limits = np.minimum(self.drive_limits, limit)
        self.limit = limit
        self._hinges = None  # (dynamics, its buffered hinge positions): lowest_hinge's

    def place(self, start: np.ndarray, preload: float) -> None:
        """The walker at the plan's state ``start`` (2n,), ``preload`` m into the ground."""
        n, feet, mjcf = self.n, self.feet, self.mjcf
        self.data.qpos[:] = mjcf.qpos(start[:n], (0.0, -preload),
                                      np.zeros(len(feet)) if feet else None)  # fmt: skip
        self.data.qvel[:] = mjcf.qvel(start[n:], (0.0, 0.0), np.zeros(len(feet)) if feet else None)
        self.mujoco.mj_forward(self.model, self.data)

    def state(self, stance: str) -> np.ndarray:
        """x = (psi, dpsi) (2n,) in the labels of a step on foot ``stance``."""
        coordinates = self.mjcf.model_coordinates(self.data.qpos)
        rates = self.mjcf.model_coordinates(self.data.qvel)
        psi, dpsi = coordinates[2:], rates[2:]
        if stance != "A":
            psi, dpsi = self.biped.swap.map_state(psi, dpsi)
        return np.r_[psi, dpsi]

    def drive(self, torques: np.ndarray, stance: str, foot_kp: float, foot_kd: float) -> float:
        """Put the plan's hinge torques (n,), in the labels of a step on ``stance``, on the
        motors (each within its limit); returns the largest motor command, N m."""
        data = self.data
        if self.limit is not None:
            torques = np.clip(torques, -self.limit, self.limit)
        if stance == "A":
            hinge = torques
        else:
            # the plan's torques, swapped back: generalised forces on the bodies, less the
            # ground's torque on the stance shank (the ankle motor's), summed over subtrees
            forces = torques - self.children @ torques
            bodies = np.zeros(self.n)
            bodies[list(self.biped.swap.source)] = forces
            bodies[self.swing_index] -= torques[0]
            hinge = self.subtree @ bodies
        if self.limit is not None:  # the drives saturate: every motor, ankles included
            hinge = np.clip(hinge, -self.limit, self.limit)
        data.ctrl[self.motor_ids] = hinge[1:]
        if self.feet:
            feet_angles = self.mjcf.feet_angles(data.qpos)
            feet_rates = self.mjcf.feet_angles(data.qvel)
            swing = "B" if stance == "A" else "A"
            which = 1 if swing == "B" else 0
            data.ctrl[self.ankle_ids[stance]] = -torques[0]
            data.ctrl[self.ankle_ids[swing]] = (
                -foot_kp * feet_angles[which] - foot_kd * feet_rates[which]
            )
        # the drives give at most their limits: after the leg swap the plan's torques map onto
        # other hinges (sums over subtrees), which can ask for more than the law's own clip
        np.clip(data.ctrl, -self.drive_limits, self.drive_limits, out=data.ctrl)
        return float(np.abs(data.ctrl).max())

    def normal_force(self, label: str) -> float:
        """The ground's normal force on foot ``label`` now, N."""
        return contact_normal_force(self.mujoco, self.model, self.data, self.grounds,
                                    self.foot_geoms[label])  # fmt: skip

    def ankle_position(self, label: str) -> complex:
        """Foot ``label``'s ankle (x, height) now, m (complex)."""
        if self.feet:
            biped = self.biped
            link = biped.stance_shank if label == "A" else biped.swing_shank
            x = self.data.xpos[self.model.body(f"foot_{link}").id]
        else:
            x = self.data.geom_xpos[next(iter(self.foot_geoms[label]))]
        return complex(x[0], x[2])

    def lowest_hinge(self, dynamics) -> float:
        """The lowest hinge's height but the stance foot's, m (nan when the state is not
        finite): a knee, hip or head near the ground has fallen."""
        if not np.all(np.isfinite(self.data.qpos)):
            return math.nan
        hip = self.mjcf.model_coordinates(self.data.qpos)
        if self._hinges is None or self._hinges[0] is not dynamics:
            # every control period: through CasADi's buffer, not the checked batch evaluation
            self._hinges = (dynamics, BufferedCall(dynamics.function("hinge_positions")))
        _, heights = self._hinges[1](hip[2:])
        return float(np.min(heights[1:] + hip[1]))


@dataclass
class _StepTally:
    """What one step in MuJoCo measured so far: the stance ankle at its start, the front
    foot's ankle and instant at its touchdown (None before), and the running peaks."""

    start: complex
    landing: complex | None = None
    touched: float = 0.0
    peak_normal: float = 0.0
    tracking: float = 0.0
    peak_torque: float = 0.0
    slip: float = 0.0

    def observe(self, io: WalkerIo, stance: str) -> None:
        """The stance foot's normal force and slip after a control period."""
        self.peak_normal = max(self.peak_normal, io.normal_force(stance))
        self.slip = max(self.slip, abs(io.ankle_position(stance).real - self.start.real))

    def record(self, index: int, duration: float, double: bool) -> MujocoStep:
        return MujocoStep(
            index=index,
            duration=duration,
            length=self.landing.real - self.start.real,
            slip=self.slip,
            peak_normal=self.peak_normal,
            tracking=self.tracking,
            peak_torque=self.peak_torque,
            double_support=duration - self.touched if double else None,
        )


def _walk(mujoco, model, data, mjcf, feedback, controller, steps, disturbances, open_loop,
          foot_kp, foot_kd, preload, unstable) -> MujocoRun:  # fmt: skip
    """The control loop of :func:`run_in_mujoco`."""
    step = feedback.step
    reference = feedback.reference
    plan = feedback.whole  # the whole step by time: the open loop's torques
    lift_off = feedback.lift_off  # None: the step ends at touchdown
    tracker = reference if lift_off is None else controller  # the branch in force
    io = WalkerIo(mujoco, model, data, mjcf, step, disturbances.torque_limit)
    start = reference.states[0]
    if disturbances.initial is not None:
        start = start + np.asarray(disturbances.initial, dtype=float)
    io.place(start, preload)
    period = 1.0 / feedback.control_rate_hz
    substeps = max(1, round(period / model.opt.timestep))
    biped = step.biped
    torso = model.body(biped.upper_body[0] if biped.upper_body else biped.stance_thigh).id
    records, times, states = [], [], []
    stance = "A"
    t_step, clock = 0.0, 0.0
    fell = None
    tally = _StepTally(io.ankle_position(stance))
    pushed = disturbances.push == 0.0
    lowest = min(0.0, disturbances.ground_rise) - 0.02
    controller.start_step(0, io.state(stance))
    while len(records) < steps:
        x = io.state(stance)
        torques = plan.at_time(t_step)[1] if open_loop else controller.torques(t_step, x)
        tally.tracking = max(tally.tracking, tracker.tracking(x))
        tally.peak_torque = max(tally.peak_torque, io.drive(torques, stance, foot_kp, foot_kd))
        pushed, push = due_push(disturbances, pushed, len(records), t_step, step.step_time,
                                torso, period)  # fmt: skip
        report = advance(mujoco, model, data, substeps, unstable, push)
        if report is not None:
            fell = f"step {len(records)}, t = {t_step:.3f} s: MuJoCo: {report}"
            break
        t_step += period
        clock += period
        times.append(clock)
        states.append(data.qpos.copy())
        tally.observe(io, stance)
        fell = _fall(io, feedback, tally, len(records), t_step, lowest)
        if fell is not None:
            break
        swing = "B" if stance == "A" else "A"
        if tally.landing is None:  # x: the state before this period, as the law read it
            if not (reference.phase(x[: io.n]) > 0.5 and io.normal_force(swing) > TOUCHDOWN_FORCE):
                continue
            tally.landing = io.ankle_position(swing)
            ahead = tally.landing.real - tally.start.real
            if ahead < 0.25 * step.step_length:
                fell = (f"step {len(records)}, t = {t_step:.3f} s: the swing foot came down "
                        f"{ahead:+.3f} m from the stance foot")  # fmt: skip
                break
            if lift_off is not None:
                # both feet on the ground: the double support's law until the rear foot lifts
                # where the plan's double support ends (its phase reaches 1)
                tally.touched = t_step
                controller.touchdown(t_step, x)
                continue
        elif lift_off(x) < 0.0:
            continue
        records.append(tally.record(len(records), t_step, lift_off is not None))
        stance = swing
        tally = _StepTally(tally.landing)
        t_step = 0.0
        controller.start_step(len(records), io.state(stance))
    return MujocoRun(tuple(records), fell, np.asarray(times), np.asarray(states), mjcf)


def _fall(io: WalkerIo, feedback, tally: _StepTally, index: int, t_step: float,
          lowest: float) -> str | None:  # fmt: skip
    """Why step ``index`` has failed at t_step s into it, or None: a body point under the
    ground (2 cm under ``lowest``, the lowest ground there is: a knee, hip or head that low
    has fallen), or no touchdown (or, in a double support, no lift-off) within twice the
    step time."""
    if not io.lowest_hinge(feedback.plant.dynamics) >= lowest:
        return f"step {index}, t = {t_step:.3f} s: a body point went under the ground"
    if t_step > 2.0 * feedback.step.step_time:
        if tally.landing is None:
            return f"step {index}: no touchdown within twice the step time"
        return f"step {index}: the rear foot did not lift within twice the step time"
    return None


@dataclass(frozen=True)
class MujocoCheck:
    """What :func:`mujoco_check` measured: runs by label (open loop, closed loop, and the
    disturbances of :func:`problems.control.feedback.disturbance_cases`), the largest pushes
    survived (forward, back) N s, the steps asked for, and the plan's largest stance ground
    reaction Fy, N."""

    runs: dict
    pushes: tuple[float, float]
    steps: int
    planned_normal: float


def mujoco_check(feedback, steps: int = 20) -> MujocoCheck:
    """The feedback in MuJoCo: open loop, closed loop, the product check's disturbances, the
    largest pushes (10 steps after a push at mid-step of the second step)."""
    runs = {"open loop": run_in_mujoco(feedback, steps=steps, open_loop=True)}
    for label, disturbances in disturbance_cases(feedback).items():
        name = "closed loop" if label == "plan" else label
        runs[name] = run_in_mujoco(feedback, steps=steps, disturbances=disturbances)

    def walk(disturbances):
        return run_in_mujoco(feedback, steps=PUSH_STEPS, disturbances=disturbances)

    forward, _ = largest_push(walk, direction=1.0, steps=PUSH_STEPS)
    back, _ = largest_push(walk, direction=-1.0, steps=PUSH_STEPS)
    reference = feedback.reference
    n = reference.n
    force = feedback.plant.dynamics.ground_reaction(
        reference.states[:, :n],
        reference.states[:, n:],
        feedback.plant.dynamics.forward_dynamics(
            reference.states[:, :n], reference.states[:, n:], reference.torques
        ),
    )
    return MujocoCheck(runs, (forward, back), steps, float(np.max(force.imag)))


__all__ = ["MujocoCheck", "MujocoRun", "MujocoStep", "mujoco_check", "run_in_mujoco", "walker_mjcf"]
