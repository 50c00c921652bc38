"""The step on feet (:class:`problems.walking.footed.FootedGait`) walked in MuJoCo
(``pip install ".[mujoco]"``): the plan's own eight links with a floating base, each foot
touching the ground at two spheres, its heel and its ball (:func:`model.to_mjcf` with the
step's contact points), on a plane with the plan's friction. MuJoCo decides every contact:
the foot lies flat, its heel rises, the swing heel strikes, both feet stand, the rear foot
leaves; nothing of the plan's phase sequence is imposed on it. The drives run the file's law
(:class:`problems.control.feet_law.FeetLaw`) at 1 kHz: the plan's torques and joint
feedback around it, indexed by the hip's progress, switching to the double support's branch
when the swing heel's normal force passes ``TOUCHDOWN_FORCE`` past half the step, the legs
swapped (torques mapped by :meth:`model.Rerooting.map_torques`) at s = 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from model.mjcf import MjcfModel, to_mjcf
from planner.errors import DefinitionTypeError, check_integer, check_positive
from problems.control.feedback import PUSH_STEPS
from problems.control.feet_law import CONTROL_RATE_HZ, FeetLaw, walk_laws
from problems.control.mujoco import (
    CONTACT_TIME_CONSTANT,
    PRELOAD,
    REST_SPEED,
    TIMESTEP,
    TOUCHDOWN_FORCE,
    MujocoRun,
    MujocoStep,
    advance,
    contact_normal_force,
    disturbed_model,
    due_push,
    import_mujoco,
    instability_reports,
)
from problems.control.simulation import Disturbances, disturbances_for, largest_push

#: s: a walk that stops holds its standing pose this long after the stop's end, both feet down
STAND = 1.0
#: m: a stop ends standing with the swing ball at most this far from the stance ball (the plan
#: sets it down at the stance ball, side by side)
STAND_GAP = 0.05


def feet_walker_mjcf(step, *, ground_mu: float | None = None) -> MjcfModel:
    """The MJCF of a step on feet: its linkage floating, spheres at its four contact points
    (heel and ball of each foot), its seven drives limited to the plan's torque limit."""
    return to_mjcf(
        step.linkage,
        base="floating",
        contacts=list(step.points.values()),
        friction=step.mu if ground_mu is None else ground_mu,
        torque_limits=step.limits,
        timestep=TIMESTEP,
        name="walker_on_feet",
    )


def run_feet_in_mujoco(
    gait,
    *,
    steps: int = 20,
    disturbances: Disturbances | None = None,
    open_loop: bool = False,
    contact_time_constant: float = CONTACT_TIME_CONSTANT,
    preload: float = PRELOAD,
    law: FeetLaw | None = None,
) -> MujocoRun:
    """Walk ``steps`` steps of a solved step on feet in MuJoCo from the plan's start under
    :class:`FeetLaw` (``law``; default ``FeetLaw(gait)``); ``open_loop``: the
    plan's torques by the time since the step began, no feedback. Disturbances: a push on
    the torso, a mass scale (MuJoCo's body changes, the law keeps the plan's), the ground
    higher or lower from a step on, the start off the plan, the drives saturated lower.

    Returns the steps walked (duration, length between the stance balls, the stance ball's
    slip, its foot's peak normal force, the largest tracking error, the largest command, the
    control periods with a drive at its limit) and why it fell, if it did.
    """
    from problems.walking.footed import FootedGait

    if not isinstance(gait, FootedGait):
        raise DefinitionTypeError(
            f"`gait`: a solved step on feet (footed_step(...).solve()), got {type(gait).__name__}"
        )
    mujoco = import_mujoco()
    steps = check_integer("steps", steps, 1)
    check_positive("contact_time_constant", contact_time_constant, "s")
    check_positive("preload", preload, "m")
    disturbances = disturbances or Disturbances()
    law = FeetLaw(gait) if law is None else law
    step = gait.problem
    mjcf = feet_walker_mjcf(step)
    model, data = disturbed_model(mujoco, mjcf, disturbances, step.step_length,
                                  contact_time_constant)  # fmt: skip
    with instability_reports(mujoco) as unstable:
        return _walk(mujoco, model, data, mjcf, (law,), steps, disturbances, open_loop, preload,
                     unstable)  # fmt: skip


def run_feet_steps_in_mujoco(
    gaits,
    *,
    disturbances: Disturbances | None = None,
    contact_time_constant: float = CONTACT_TIME_CONSTANT,
    preload: float = PRELOAD,
    laws=None,
    stand: float = STAND,
) -> MujocoRun:
    """Walk the steps on feet ``gaits`` (:class:`problems.walking.footed.FootedGait`, one per
    step, in order: e.g. the steps of a walk through speeds, each periodic step repeated and
    the transitions' steps between them) once each in MuJoCo from the first one's start,
    step j under ``laws[j]`` (default ``FeetLaw(gaits[j])``, made once per distinct gait):
    the law follows step j's own plan and hands over to step j + 1's at the leg swap.
    Disturbances, returns and fall criteria as for :func:`run_feet_in_mujoco` (a push's
    step index counts the walk's steps).

    A walk that ends at quiet standing (its last gait a stop, ``problem.stop``) walks the
    stop under its law by the time, then the law holds the stop's last sample for ``stand``
    s, both feet on MuJoCo's ground; the stop counts as walked when, at the end, the swing
    foot's ball lies within :data:`STAND_GAP` of the stance ball and the hip moves slower
    than :data:`problems.control.mujoco.REST_SPEED` (else the run says it did not stand)."""
    gaits, laws = walk_laws(gaits, laws)
    check_positive("stand", stand, "s")
    mujoco = import_mujoco()
    check_positive("contact_time_constant", contact_time_constant, "s")
    check_positive("preload", preload, "m")
    disturbances = disturbances or Disturbances()
    step = gaits[0].problem
    mjcf = feet_walker_mjcf(step)
    model, data = disturbed_model(mujoco, mjcf, disturbances, step.step_length,
                                  contact_time_constant)  # fmt: skip
    with instability_reports(mujoco) as unstable:
        return _walk(mujoco, model, data, mjcf, laws, len(gaits), disturbances, False, preload,
                     unstable, stand)  # fmt: skip


def _walk(mujoco, model, data, mjcf, laws, steps, disturbances, open_loop, preload, unstable,
          stand=STAND):  # fmt: skip
    """The control loop of :func:`run_feet_in_mujoco`: step j under ``laws[j % len(laws)]``
    (a stop, the walk's last, then ``stand`` s held)."""
    law = laws[0]
    step = law.step
    linkage = step.linkage
    n = linkage.n
    swap = step.biped.swap
    single = law.references[0]
    # the contact geoms of each label: "A" when MuJoCo's root foot is the plan's stance foot
    feet = {"A": ("stance", "swing"), "B": ("swing", "stance")}
    geom = {c.name: model.geom(c.name).id for c in mjcf.contacts}
    grounds = {g for g in range(model.ngeom) if model.geom(g).name.startswith("ground")}
    motors = [model.actuator(f"M_{name}").id for name in linkage.names[1:]]
    limit = np.array([step.limits[name] for name in linkage.names[1:]])
    if disturbances.torque_limit is not None:
        limit = np.minimum(limit, disturbances.torque_limit)
    torso = model.body(step.biped.upper_body[0]).id
    start = single.states[0].copy()
    if disturbances.initial is not None:
        start = start + np.asarray(disturbances.initial, dtype=float)
    data.qpos[:] = mjcf.qpos(start[:n], (0.0, -preload))
    data.qvel[:] = mjcf.qvel(start[n:], (0.0, 0.0))
    mujoco.mj_forward(model, data)
    period = 1.0 / CONTROL_RATE_HZ
    substeps = max(1, round(period / model.opt.timestep))

    def foot(label: str, which: int) -> set[int]:
        side = feet[label][which]  # 0: the plan's stance foot, 1: its swing foot
        return {geom[f"{side}_heel"], geom[f"{side}_toe"]}

    def ball(label: str, which: int) -> float:
        return float(data.geom_xpos[geom[f"{feet[label][which]}_toe"]][0])

    records: list[MujocoStep] = []
    times, states = [], []
    label, branch = "A", 0
    t_step = clock = t_strike = 0.0
    fell = None
    stance_ball = ball(label, 0)
    peak_normal = tracking = peak_torque = slip = 0.0
    saturated = 0
    pushed = disturbances.push == 0.0
    lowest = min(0.0, disturbances.ground_rise) - 0.02
    # the hip's x in the world (both thighs end there: either label's stance thigh)
    hip_point = step.dynamics.point(step.biped.stance_thigh)
    hips: list[float] = []

    def hips_x(coordinates) -> float:
        return complex(hip_point.position(coordinates[2:])).real + coordinates[0]

    while len(records) < steps:
        coordinates = mjcf.model_coordinates(data.qpos)
        rates = mjcf.model_coordinates(data.qvel)
        psi, dpsi = coordinates[2:], rates[2:]
        if label == "B":
            psi, dpsi = swap.map_state(psi, dpsi)
        x = np.r_[psi, dpsi]
        reference = law.references[branch]
        if open_loop:
            since = t_step - (single.duration if branch else 0.0)
            torques = reference.at_time(since)[1].copy()
        else:
            # the time since the branch began: read only by a law by the time (a start from
            # rest), whose double support's plan starts at the strike
            since = t_step - (t_strike if branch else 0.0)
            torques = law.torques(branch, x, since)
        torques[0] = 0.0  # the ground's torque on the stance foot: no drive gives it
        tracking = max(tracking, reference.tracking(x, since))
        hinge = torques if label == "A" else swap.map_torques(torques)
        data.ctrl[motors] = np.clip(hinge[1:], -limit, limit)
        command = float(np.abs(data.ctrl[motors]).max())
        peak_torque = max(peak_torque, command)
        saturated += bool(np.any(np.abs(data.ctrl[motors]) >= limit))
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
        peak_normal = max(peak_normal, contact_normal_force(mujoco, model, data, grounds,
                                                            foot(label, 0)))  # fmt: skip
        slip = max(slip, abs(ball(label, 0) - stance_ball))
        here = mjcf.model_coordinates(data.qpos)
        hinges = step.dynamics.hinge_positions(here[2:]) + complex(here[0], here[1])
        # 2 cm under the lowest ground there is: a knee, hip or head that low has fallen
        if np.min(hinges.imag[1:]) < lowest or not np.all(np.isfinite(data.qpos)):
            fell = f"step {len(records)}, t = {t_step:.3f} s: a body point went under the ground"
            break
        if step.stop:  # quiet standing: the stop, then its last sample held
            hips.append(float(hips_x(here)))
            if t_step < single.duration + stand - 1e-12:
                continue
            landing = ball(label, 1)
            fell = stood(len(records), landing - stance_ball, hips, period)
            if fell is None:  # the stop is walked when it ends standing
                records.append(MujocoStep(len(records), t_step, landing - stance_ball, slip,
                                          peak_normal, tracking, peak_torque,
                                          saturated))  # fmt: skip
            break
        if t_step > 2.0 * step.step_time:
            fell = f"step {len(records)}: the step did not end within twice the step time"
            break
        s = law.phase(psi)
        striking = "heel" if step.strike_role == "swing_heel" else "toe"
        swing_load = contact_normal_force(mujoco, model, data, grounds, {geom[
            f"{feet[label][1]}_{striking}"]})  # fmt: skip
        if branch == 0 and s > 0.5 and swing_load > TOUCHDOWN_FORCE:
            branch, t_strike = 1, t_step  # the swing heel struck: the double support's branch
        elif branch == 1 and s >= 1.0:
            landing = ball(label, 1)
            if landing - stance_ball < 0.25 * step.step_length:
                fell = (f"step {len(records)}, t = {t_step:.3f} s: the front ball came down "
                        f"{landing - stance_ball:+.3f} m from the stance ball")  # fmt: skip
                break
            records.append(MujocoStep(len(records), t_step, landing - stance_ball, slip,
                                      peak_normal, tracking, peak_torque, saturated))  # fmt: skip
            label, branch = ("B" if label == "A" else "A"), 0
            law = laws[len(records) % len(laws)]  # the next step's plan from its start
            step, single = law.step, law.references[0]
            stance_ball = ball(label, 0)
            t_step = 0.0
            peak_normal = tracking = peak_torque = slip = 0.0
            saturated = 0
    return MujocoRun(tuple(records), fell, np.asarray(times), np.asarray(states), mjcf)


def stood(index: int, gap: float, hips, period: float) -> str | None:
    """Why the stop (step ``index``) did not end standing, or None: the swing ball ``gap`` m
    from the stance ball, the hip's x over the stop and its stand ``hips`` (m, one a control
    period of ``period`` s)."""
    if abs(gap) > STAND_GAP:
        return (f"step {index} (the stop): the swing ball came down {gap:+.3f} m from the "
                f"stance ball, not beside it (within {STAND_GAP:g} m)")  # fmt: skip
    speed = abs(hips[-1] - hips[-2]) / period if len(hips) > 1 else float("nan")
    if not speed < REST_SPEED:
        return f"step {index} (the stop): the walk ended with the hip still moving at " \
               f"{speed:.3f} m/s"  # fmt: skip
    return None


@dataclass(frozen=True)
class FeetMujocoCheck:
    """What :func:`feet_mujoco_check` measured: runs by label (open loop, closed loop and
    the disturbances of :func:`problems.control.simulation.disturbances_for`), the largest
    pushes survived (forward, back) N s (None when the undisturbed closed loop falls), the
    steps asked for, the law's gains per branch."""

    runs: dict
    pushes: tuple[float, float] | None
    steps: int
    gains: tuple


def feet_mujoco_check(gait, steps: int = 20, law: FeetLaw | None = None) -> FeetMujocoCheck:
    """The step on feet in MuJoCo under ``law`` (default ``FeetLaw(gait)``): open loop, closed
    loop, the product's disturbances, and the largest pushes (``PUSH_STEPS`` steps, the push
    at mid-step of the second; none when the undisturbed closed loop falls)."""
    law = FeetLaw(gait) if law is None else law
    step = gait.problem
    runs = {"open loop": run_feet_in_mujoco(gait, steps=steps, open_loop=True, law=law)}
    for label, disturbances in disturbances_for(step.linkage.n, step.torque_limit).items():
        name = "closed loop" if label == "plan" else label
        runs[name] = run_feet_in_mujoco(gait, steps=steps, disturbances=disturbances, law=law)
    if runs["closed loop"].walked < steps:  # no margin to measure
        return FeetMujocoCheck(runs, None, steps, law.gains)

    def walk(disturbances):
        return run_feet_in_mujoco(gait, steps=PUSH_STEPS, disturbances=disturbances, law=law)

    forward, _ = largest_push(walk, direction=1.0, steps=PUSH_STEPS)
    back, _ = largest_push(walk, direction=-1.0, steps=PUSH_STEPS)
    return FeetMujocoCheck(runs, (forward, back), steps, law.gains)


__all__ = [
    "STAND",
    "STAND_GAP",
    "FeetMujocoCheck",
    "feet_mujoco_check",
    "feet_walker_mjcf",
    "run_feet_in_mujoco",
    "run_feet_steps_in_mujoco",
    "stood",
]
