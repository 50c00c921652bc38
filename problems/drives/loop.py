"""Drives in the loop: a walking step planned with its motors and gearboxes (issue #36, part 4).

A plan for ideal torque sources asks any torque at any speed, for free. With the drives:

* **inertia**: each drive's rotor (and gear input) spins N times as fast as its joint, on the
  link that carries the motor: its reflected inertia enters the equations of motion
  (:class:`model.Rotor`: J b b^T in absolute angles, b = N e_driven + (1 - N) e_stator);
* **mass**: each motor and gearbox is a point mass at its joint, on that link (both legs:
  the legs swap at every heel strike, so a walker's drives are symmetric);
* **limits**, at every node, both efficiency branches (so the exact, non-smooth motor model
  meets them too): the motor's peak torque (its current limit), the supply's voltage line
  |R tau_m / k_t + k_t N dq| <= U, the gearbox's peak output torque and the speeds;
* **objective** (``objective="electrical"``): the electrical energy of the step, the sum over
  the drives of u i = R i^2 + tau_m N dq (copper losses plus mechanical power at the motor),
  regeneration counted (a negative u i pays back) or not (only u i > 0 costs); or
  (``objective="copper"``) the copper losses alone, the sum of R i^2: the motors' heat, a
  sum of squares like the torque objective's but of each motor's current, so that a joint
  whose drive gears its torque down less (an ankle through 30:1 beside a hip through 100:1)
  pays for it as its motor does.

Where the motors sit (:data:`MOUNTS`): the hip's on the trunk, the knee's on the thigh, the
ankle's on the shank, the neck's on the trunk; each turns the other link of its joint. The
joint's angle q and torque tau are the robot's (:func:`problems.robot.controller.joint_maps`:
q = a . psi + const, tau = d . M); the motor's speed is N dq, its torque (in q's sense)

    tau_m = J a_r + tau_out / (N eta)   (tau_out dq >= 0: the motor drives)
    tau_m = J a_r + tau_out eta / N     (the load drives the motor back),

with a_r = s (b . ddpsi) the rotor's absolute acceleration in q's sense (s = +-1: q grows as
the driven link turns forward relative to the stator, or back) and tau_out = tau - N J a_r
what the gear gives the links (the hinge torque of a model with rotors is the drive's whole
torque, the part that accelerates the rotor included). The objective blends the two branches
by tanh(tau_out dq / P_s) (P_s = :data:`SMOOTHING_W`); every number reported is the exact
model's, at the exported samples (:func:`motor_report`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from model.linkage import Link, Linkage
from model.rotors import Rotor
from planner.errors import AnthropoidError, DefinitionError
from planner.ocp import DEFAULT_TERM
from problems.drives.catalogue import Drive
from problems.drives.springs import ParallelSpring, check_springs, spring_torque
from problems.human.joints import Body, body_of
from problems.robot.controller import joint_maps

#: each physical drive's motor sits on this link of its joint (the other one it turns)
MOUNTS = {"hip": "trunk", "knee": "thigh", "ankle": "shank", "neck": "trunk"}
#: the power over which the objective's efficiency switches branch (tanh), W
SMOOTHING_W = 1.0
#: the weight of sum (M / limit)^2 (1/s) beside the electrical energy: keeps the NLP regular
#: where a drive idles (no copper loss there to choose a torque), J per unit
REGULARISATION_J = 1e-3


@dataclass(frozen=True)
class MountedDrive:
    """One of the model's drives (``key``: stance_hip, swing_knee, neck, ...; a point foot's
    swing ankle has none: no foot link to turn) with its ``drive``, in the model's terms: dq =
    ``joint_row`` . dpsi, tau = ``torque_row`` . M, its ``rotor`` and rate vector b
    (``rate_row``), and ``sense`` (+1 or -1: q grows as the rotor turns forward relative to the
    stator, or back); the joint's angle is q = ``joint_row`` . psi + ``joint_offset`` (rad,
    the robot's)."""

    key: str
    joint: str
    drive: Drive
    joint_row: np.ndarray
    torque_row: np.ndarray
    rotor: Rotor
    rate_row: np.ndarray
    sense: float
    joint_offset: float = 0.0

    def joint_terms(self, p, springs: Sequence[ParallelSpring] = ()):
        """(tau_out N m, dq rad/s, a_r rad/s^2) as CasADi expressions at a planner Point ``p``
        (its hinge torques, angles, rates and accelerations, and the springs' parameters):
        what the gear gives the links (the joint's torque less its parallel spring's share,
        :mod:`problems.drives.springs`, and less the share that accelerates its rotor), the
        joint's speed, the rotor's acceleration in the joint's sense."""
        tau = ca.dot(ca.DM(self.torque_row), p.M)
        dq = ca.dot(ca.DM(self.joint_row), p.dpsi)
        rotor_acceleration = self.sense * ca.dot(ca.DM(self.rate_row), p.ddpsi)
        tau_out = tau - self.drive.gearbox.ratio * self.drive.inertia * rotor_acceleration
        for spring in springs:
            if spring.joint == self.joint:
                k_name, rest_name = spring.names
                angle = ca.dot(ca.DM(self.joint_row), p.psi) + self.joint_offset
                tau_out = tau_out - spring_torque(getattr(p, k_name), getattr(p, rest_name),
                                                  angle)  # fmt: skip
        return tau_out, dq, rotor_acceleration

    def smooth_factor(self, tau_out, dq):
        """The efficiency factor blended between 1/eta (driving) and eta (driven back) by
        tanh(tau_out dq / P_s): the objective's (:data:`SMOOTHING_W`)."""
        eta = self.drive.gearbox.efficiency
        switch = ca.tanh(tau_out * dq / SMOOTHING_W)
        return 0.5 * (1.0 / eta + eta) + 0.5 * (1.0 / eta - eta) * switch


def _joint_point(linkage: Linkage, stator: str, driven: str | None) -> complex:
    """Where the joint between ``stator`` and ``driven`` sits on the stator, m in its frame."""
    s = linkage.index(stator)
    if driven is not None and linkage.parents[linkage.index(driven)] == s:
        return linkage.origin_in_parent(linkage.index(driven))
    if driven is None and linkage.parents[s] >= 0:  # a point foot's swing ankle: the far end
        return complex(linkage.links[s].length)
    if driven is not None and linkage.parents[s] != linkage.index(driven):
        # siblings on one hinge (the swing hip: trunk and swing thigh on the stance thigh)
        d = linkage.index(driven)
        if (
            linkage.parents[d] != linkage.parents[s]
            or abs(linkage.origin_in_parent(d) - linkage.origin_in_parent(s)) > 1e-12
        ):
            raise DefinitionError(f"`drives`: {stator!r} and {driven!r} share no joint")
    return 0j  # the stator's start: the joint with its parent (or with the ground)


def _with_point_mass(link: Link, mass: float, point: complex) -> Link:
    """``link`` carrying ``mass`` kg more at ``point`` (m, in its frame): the merged centre
    of mass and the inertia about it (parallel axes)."""
    total = link.mass + mass
    com = (link.mass * link.com_offset + mass * point) / total
    inertia = (
        link.inertia + link.mass * abs(link.com_offset - com) ** 2 + mass * abs(point - com) ** 2
    )
    return replace(link, mass=total, com=com.real / link.length,
                   com_lateral=com.imag / link.length, inertia=inertia)  # fmt: skip


def _links_of(body: Body, key: str) -> tuple[str, str | None]:
    """(stator, driven) of the model's drive ``key`` (:data:`MOUNTS`)."""
    role, _, joint = key.partition("_")
    leg = body.stance if role == "stance" else body.swing
    parts = {"trunk": body.trunk, "thigh": leg.thigh, "shank": leg.shank, "foot": leg.foot}
    stator = parts[MOUNTS[joint]]
    other = {"hip": parts["thigh"], "knee": parts["shank"], "ankle": parts["foot"]}[joint]
    return stator, other


@dataclass(frozen=True)
class DrivenWalker:
    """A walker carrying its drives: ``linkage`` (the motors' masses on their links),
    ``rotors`` (for :func:`problems.walking_step`) and ``mounted`` (each of the model's
    drives)."""

    linkage: Linkage
    rotors: tuple[Rotor, ...]
    mounted: tuple[MountedDrive, ...]


def drives_in_the_loop(
    linkage: Linkage, drives: Mapping[str, Drive], neutral_ankles=None
) -> DrivenWalker:
    """The walker ``linkage`` (a biped, point feet or feet) with ``drives`` {"hip", "knee",
    "ankle", "neck": Drive} mounted as :data:`MOUNTS` says: both legs' motors as point masses
    at their joints, the rotors of every drive the plan has (see the module)."""
    unknown = sorted(set(drives) - set(MOUNTS))
    if unknown:
        raise DefinitionError(
            f"`drives`: unknown joints {unknown}; give Drives for {sorted(MOUNTS)}"
        )
    body = body_of(linkage, neutral_ankles)
    t = linkage.index(body.trunk)
    head = next((i for i, p in enumerate(linkage.parents) if p == t), None)
    keys, A, offsets, _, _, drive_keys, D = joint_maps(linkage, body, head, ankles=True)
    missing = sorted({k.partition("_")[2] or k for k in drive_keys} - set(drives))
    if missing:
        raise DefinitionError(f"`drives`: the walker's plan has {missing} too; give a Drive each")
    links = list(linkage.links)
    every = [f"{r}_{j}" for r in ("stance", "swing") for j in ("hip", "knee", "ankle")]
    every += ["neck"] if head is not None else []
    mounted, rotors = [], []
    names = linkage.names
    for key in every:
        joint = "neck" if key == "neck" else key.partition("_")[2]
        if key == "neck":
            stator, driven = body.trunk, names[head]
        else:
            stator, driven = _links_of(body, key)
        s = linkage.index(stator)
        links[s] = _with_point_mass(
            links[s], drives[joint].mass, _joint_point(linkage, stator, driven)
        )
        if key not in drive_keys:
            continue  # a point foot's swing ankle: its mass is there, nothing for it to turn
        drive = drives[joint]
        rotor = Rotor(stator, driven, drive.gearbox.ratio, drive.inertia, key)
        row = A[keys.index(key)]
        relative = np.zeros(linkage.n)
        relative[s] -= 1.0
        if driven is not None:
            relative[linkage.index(driven)] += 1.0
        sense = float(row @ relative / (relative @ relative))
        if not np.allclose(row, sense * relative) or abs(abs(sense) - 1.0) > 1e-9:
            raise DefinitionError(
                f"`drives`: {key}'s angle is not the turn of {driven} on {stator}"
            )
        sense = float(np.sign(sense))
        rotors.append(rotor)
        mounted.append(MountedDrive(key, joint, drive, row, D[drive_keys.index(key)], rotor,
                                    rotor.rate_vector(names), sense,
                                    float(offsets[keys.index(key)])))  # fmt: skip
    carried = Linkage(links, linkage.gravity)
    return DrivenWalker(carried, tuple(rotors), tuple(mounted))


def limit_rows(mounted: MountedDrive, springs: Sequence[ParallelSpring] = ()):
    """(function of a planner Point, lower, upper) of one drive's limits at a node, each row
    a fraction of its limit: the motor's torque and the voltage on both efficiency branches,
    the gear's output torque, the motor's speed (see the module); ``springs`` beside the
    drives take their share of the joints' torques."""
    drive = mounted.drive
    motor, gearbox = drive.motor, drive.gearbox
    speed = min(motor.max_speed, gearbox.max_input_speed)

    def rows(p):
        tau_out, dq, rotor_acceleration = mounted.joint_terms(p, springs)
        values = []
        for factor in (1.0 / gearbox.efficiency, gearbox.efficiency):  # driving, driven back
            tau_m = drive.motor_torque(tau_out, rotor_acceleration, factor)
            voltage = drive.electrical(tau_m, dq)["voltage"]
            values += [tau_m / motor.peak_torque, voltage / motor.voltage]
        values += [tau_out / gearbox.peak_torque, gearbox.ratio * dq / speed]
        return ca.vertcat(*values)

    return rows, [-1.0] * 6, [1.0] * 6


def _smooth_electrical(mounted: MountedDrive, p, springs: Sequence[ParallelSpring]) -> dict:
    """The drive's :meth:`Drive.electrical` at a Point, the efficiency's branches blended by
    :meth:`MountedDrive.smooth_factor` (the objectives' smooth motor model)."""
    tau_out, dq, rotor_acceleration = mounted.joint_terms(p, springs)
    factor = mounted.smooth_factor(tau_out, dq)
    tau_m = mounted.drive.motor_torque(tau_out, rotor_acceleration, factor)
    return mounted.drive.electrical(tau_m, dq)


def electrical_power(mounted: MountedDrive, p, regeneration: bool,
                     springs: Sequence[ParallelSpring] = ()):  # fmt: skip
    """The drive's electrical power u i, W, at a Point (smooth branches; without
    regeneration only its positive part, smoothed over :data:`SMOOTHING_W`)."""
    power = _smooth_electrical(mounted, p, springs)["power"]
    if regeneration:
        return power
    return 0.5 * (power + ca.sqrt(power**2 + SMOOTHING_W**2))


def copper_power(mounted: MountedDrive, p, springs: Sequence[ParallelSpring] = ()):
    """The drive's copper losses R i^2, W, at a Point (the efficiency's branches blended as
    in :func:`electrical_power`)."""
    return _smooth_electrical(mounted, p, springs)["copper"]


#: the objectives :func:`with_drives` sets
DRIVE_OBJECTIVES = ("electrical", "copper", "kept")


def with_drives(step, walker: DrivenWalker, objective: str = "electrical",
                regeneration: bool = True, springs: Sequence[ParallelSpring] = ()):  # fmt: skip
    """A walking step (:func:`problems.walking_step` or :func:`problems.footed_step` of
    ``walker.linkage`` with ``rotors=walker.rotors``) held to its drives' limits at every node
    (of every phase on feet), its objective the step's electrical energy
    (``objective="electrical"``; regenerated energy counted with ``regeneration``), its copper
    losses (``"copper"``) or kept as it is (``"kept"``). ``springs``: parallel springs beside
    the drives (:mod:`problems.drives.springs`), their free numbers static parameters of the
    NLP (read them back with :func:`problems.drives.springs.spring_values`)."""
    if objective not in DRIVE_OBJECTIVES:
        raise DefinitionError(
            f"`objective`: one of {', '.join(map(repr, DRIVE_OBJECTIVES))}, got {objective!r}"
        )
    springs = check_springs(springs)
    free = [s.joint for s in springs if s.stiffness is None or s.rest is None]
    if free and objective == "kept":
        raise DefinitionError(
            f"`springs`: the {free} spring's numbers are designed for the drives' energy, which "
            "the step's own objective does not see; give objective 'electrical' or 'copper', "
            "or fix its stiffness and rest angle"
        )
    keys = {m.key for m in walker.mounted}
    # Both legs' copies, or none: a spring in one leg only (a point foot's ankle, with no foot
    # to turn in the swing) would meet each stance loaded as it left the last one, for free.
    idle = [s.joint for s in springs if not {f"stance_{s.joint}", f"swing_{s.joint}"} <= keys]
    if idle:
        raise DefinitionError(
            f"`springs`: no drive at {idle} in both legs to put a spring beside (a point "
            f"foot's swing ankle turns nothing); the walker's drives: {sorted(keys)}"
        )
    if tuple(step.dynamics.rotors) != walker.rotors:
        raise DefinitionError(
            "`step`: plan it with the walker's rotors: walking_step(walker.linkage, ..., "
            "rotors=walker.rotors) (or footed_step)"
        )
    names = walker.linkage.names
    limits = getattr(step, "limits", None) or step.torque_limit  # on feet: the drives' only
    scale = ca.DM([limits.get(name, max(limits.values())) for name in names])

    def held(ocp):
        for spring in springs:
            ocp = spring.declare(ocp)
        for mounted in walker.mounted:
            rows, lower, upper = limit_rows(mounted, springs)
            ocp = ocp.constrain(f"drive {mounted.key}", rows, lower=lower, upper=upper)
        if objective == "electrical":

            def energy(p):
                total = sum(electrical_power(m, p, regeneration, springs) for m in walker.mounted)
                return total + REGULARISATION_J * ca.sumsqr(p.M / scale)

            ocp = ocp.minimize(integral=energy, name=DEFAULT_TERM)
        elif objective == "copper":

            def heat(p):
                total = sum(copper_power(m, p, springs) for m in walker.mounted)
                return total + REGULARISATION_J * ca.sumsqr(p.M / scale)

            ocp = ocp.minimize(integral=heat, name=DEFAULT_TERM)
        return ocp

    phases = getattr(step, "phases", None)
    if phases is not None:  # on feet: every contact phase
        held_phases = tuple((name, held(ocp)) for name, ocp in phases.phases)
        return replace(step, phases=replace(phases, phases=held_phases))
    return replace(step, ocp=held(step.ocp))


def plan_step_with_drives(linkage: Linkage, drives: Mapping[str, Drive], step_length: float,
                          step_time: float, *, regeneration: bool = False, warm=None,
                          drives_objective: str | None = None,
                          springs: Sequence[ParallelSpring] = (), **step_options):  # fmt: skip
    """(gait, walker): the walking step of ``step_length`` m in ``step_time`` s planned for
    ``linkage`` carrying ``drives`` in the loop (:func:`drives_in_the_loop`,
    :func:`with_drives`): on point feet :func:`problems.walking_step`, on feet (legs of
    foot, shank and thigh) :func:`problems.footed_step`, each with ``step_options``.
    ``drives_objective``: "electrical" (the energy drawn, or net with ``regeneration``),
    "copper" or "kept" (the step's own objective); None: electrical on point feet, kept on
    feet, where the electrical objective has not converged (examples/drives.md). ``springs``:
    parallel springs beside the drives (:func:`with_drives`).
    Warm-started from the gait ``warm`` when given (on feet otherwise from the same step
    planned for ideal torques; from the law when there is none or it fails). Raises
    :class:`planner.AnthropoidError` when no plan is found or it fails its verification."""
    from problems import footed_step, walking_step
    from problems.gait.biped import Biped

    feet = len(Biped.of(linkage).stance_leg) == 3
    objective = drives_objective
    if objective is None:
        objective = "kept" if feet else "electrical"
    if feet:
        ideal = footed_step(linkage, step_length, step_time, **step_options)
        walker = drives_in_the_loop(linkage, drives, ideal.neutral_ankles)
        if warm is None:  # the law alone is a poor start on feet: the ideal plan is a better
            warm = ideal.solve(progress=False)
        step = footed_step(walker.linkage, step_length, step_time, rotors=walker.rotors,
                           **step_options)  # fmt: skip
    else:
        walker = drives_in_the_loop(linkage, drives)
        step = walking_step(walker.linkage, step_length, step_time, rotors=walker.rotors,
                            **step_options)  # fmt: skip
    step = with_drives(step, walker, objective, regeneration=regeneration, springs=springs)
    if warm is not None:
        try:
            return step.solve(step.problem.guess(warm.solution), progress=False), walker
        except AnthropoidError:
            pass  # from the law, below
    try:
        return step.solve(progress=False), walker
    except AnthropoidError as error:
        if feet and STRIKE_ROWS in str(error):
            raise AnthropoidError(f"{error}. {STRIKE_HINT}") from error
        raise


#: how a failed footed plan names the heel strike's impulse cones (``footed_step``'s rows)
STRIKE_ROWS = "end[impulse]"
#: why those rows fail with drives, and what to change (examples/benchmarks/drives_on_feet.py)
STRIKE_HINT = (
    "The heel strike's impulses left their friction cones: a geared ankle's rotor turns with "
    "the rear foot, whose ball takes the strike's impulse (the ideal plans already hold it on "
    "its cone's edge); a grippier ground (mu), a lower ankle ratio or a lighter rotor may "
    "leave a step"
)


def motor_report(
    trajectory,
    walker: DrivenWalker,
    with_rotors: bool = True,
    springs: Mapping[str, tuple[float, float]] | None = None,
) -> dict[str, dict[str, np.ndarray]]:
    """Each mounted drive's motor side at the samples of ``trajectory`` (a linkage
    Trajectory with ddpsi and torques), exact (non-smooth) efficiency
    (:meth:`Drive.motor_side`), plus ``tau_out`` (N m), ``dq`` (rad/s) and the limits'
    ``margins`` {limit: (K,) in its unit, >= 0 when met}.

    ``with_rotors``: the plan's torques include its rotors' (planned by :func:`with_drives`);
    False for a plan made for ideal torque sources, whose torques all reach the links: the
    motor then accelerates its rotor on top (what that plan's file asks of the drive).
    ``springs``: {joint: (k N m/rad, q_0 rad)} of parallel springs beside the drives
    (:func:`problems.drives.springs.spring_values`), which take their share of the joints'
    torques; the report then adds ``spring`` (the spring's torque, N m)."""
    springs = dict(springs or {})
    psi_d = np.asarray(trajectory.dpsi, dtype=float)
    ddpsi = np.asarray(trajectory.ddpsi, dtype=float)
    M = np.asarray(trajectory.torques, dtype=float)
    report = {}
    for m in walker.mounted:
        drive = m.drive
        acceleration = m.sense * ddpsi @ m.rate_row
        tau_out = M @ m.torque_row
        if with_rotors:
            tau_out = tau_out - drive.gearbox.ratio * drive.inertia * acceleration
        dq = psi_d @ m.joint_row
        spring = np.zeros_like(tau_out)
        if m.joint in springs:
            k, rest = springs[m.joint]
            angle = np.asarray(trajectory.psi, dtype=float) @ m.joint_row + m.joint_offset
            spring = spring_torque(k, rest, angle)
        tau_out = tau_out - spring
        side = drive.motor_side(tau_out, dq, acceleration)
        speed = min(drive.motor.max_speed, drive.gearbox.max_input_speed)
        side["tau_out"], side["dq"], side["spring"] = tau_out, dq, spring
        side["margins"] = {
            "motor torque, N m": drive.motor.peak_torque - np.abs(side["torque"]),
            "voltage, V": drive.motor.voltage - np.abs(side["voltage"]),
            "gear torque, N m": drive.gearbox.peak_torque - np.abs(tau_out),
            "motor speed, rad/s": speed - np.abs(side["speed"]),
        }
        report[m.key] = side
    return report


def energy_per_step(report, time) -> dict[str, float]:
    """The electrical energy of the samples (trapezoid over ``time`` s), J: ``counted``
    (regeneration pays back), ``drawn`` (only u i > 0), ``copper`` (R i^2)."""
    time = np.asarray(time, dtype=float)

    def integral(values):
        return float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(time)))

    return {
        "counted": sum(integral(r["power"]) for r in report.values()),
        "drawn": sum(integral(np.maximum(r["power"], 0.0)) for r in report.values()),
        "copper": sum(integral(r["copper"]) for r in report.values()),
    }


__all__ = [
    "DRIVE_OBJECTIVES",
    "MOUNTS",
    "DrivenWalker",
    "MountedDrive",
    "copper_power",
    "drives_in_the_loop",
    "electrical_power",
    "energy_per_step",
    "limit_rows",
    "motor_report",
    "plan_step_with_drives",
    "with_drives",
]
