"""A walk sequence in MuJoCo (``pip install ".[mujoco]"``): the walker of the plan
(:func:`problems.walking.mujoco.walker_mjcf`: floating, soles where the plan has an ankle
torque) walks every step of the walk under the sequence's law
(:class:`problems.library.closed_loop.SequenceFeedback`), from quiet standing to quiet
standing.

Each step's law runs by the time since its touchdown; a step ends when the swing foot touches
the ground with more than :data:`problems.walking.mujoco.TOUCHDOWN_FORCE` once past half its
planned time, and the next step's law starts there (in the swapped labels). The last step of
a walk that ends at rest sets its foot down beside the stance foot; the law then holds the
plan's last sample for ``stand`` s, both feet on MuJoCo's ground. The stance ankle's torque is
clipped to what the sole carries at the measured normal force (:data:`SOLE_USE`), as a
biped's ankle controller must. A fall: a knee, hip or head
2 cm under the ground, a foot that lands less than a quarter of its step ahead, no touchdown
within twice the step time, MuJoCo's own instability warning, or (at the end) a body that
has not come to rest (its hip moving faster than :data:`REST_SPEED`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.errors import check_positive
from problems.library.closed_loop import GROUND_MU, STAND, SequenceDisturbances, SequenceFeedback
from problems.walking.mujoco import (
    CONTACT_TIME_CONSTANT,
    FOOT_MASS,
    PRELOAD,
    TOUCHDOWN_FORCE,
    MujocoRun,
    MujocoStep,
    WalkerIo,
    advance,
    disturbed_model,
    import_mujoco,
    instability_reports,
    walker_mjcf,
)
from problems.walking.simulation import Disturbances

#: the stance ankle's torque is held within this part of what the sole carries at the
#: measured normal force, -heel Fy .. toe Fy: beyond it the foot tips onto its heel or toe
#: (the plan keeps its centre of pressure on the sole; its feedback need not)
SOLE_USE = 0.9
#: the swing foot's ankle PD that keeps it flat, N m/rad and N m s/rad: stiffer than the
#: periodic step's (20, 0.2), under which the swing foot of a start's second step pitches
#: 0.15 rad toe-down and its toe catches the ground at s = 0.8 (measured; the walk 0 -> 1.0
#: -> 0 m/s then falls at its third step); critically damped for the 0.5 kg foot
FOOT_KP, FOOT_KD = 100.0, 1.0
#: m/s: at the end of the stand the hip moves slower than this, or the walker has not stopped
REST_SPEED = 0.05


@dataclass(frozen=True)
class SequenceMujocoRun:
    """The walk in MuJoCo: ``run`` (its steps, fall, time and MuJoCo's positions: a
    :class:`problems.walking.mujoco.MujocoRun`), the ``planned`` steps, and whether it ended
    at rest (``stood``; the hip's last speed ``rest_speed`` m/s)."""

    run: MujocoRun
    planned: int
    stood: bool
    rest_speed: float

    @property
    def walked(self) -> int:
        return self.run.walked

    @property
    def fell(self) -> str | None:
        return self.run.fell

    @property
    def completed(self) -> bool:
        return self.run.fell is None and self.walked == self.planned


def run_sequence_in_mujoco(
    feedback: SequenceFeedback,
    disturbances: SequenceDisturbances | None = None,
    *,
    stand: float = STAND,
    ground_mu: float = GROUND_MU,
    foot_kp: float = FOOT_KP,
    foot_kd: float = FOOT_KD,
    contact_time_constant: float = CONTACT_TIME_CONSTANT,
    foot_mass: float = FOOT_MASS,
    preload: float = PRELOAD,
) -> SequenceMujocoRun:
    """Walk ``feedback.sequence`` in MuJoCo (see the module) under ``disturbances`` (the
    body's mass scale, a push on the torso during a step, a start error)."""
    mujoco = import_mujoco()
    disturbances = disturbances or SequenceDisturbances()
    check_positive("stand", stand, "s")
    sequence = feedback.sequence
    first = sequence.steps[0].gait.problem
    mjcf = walker_mjcf(first, ground_mu=ground_mu, foot_mass=foot_mass)
    model, data = disturbed_model(mujoco, mjcf, Disturbances(mass_scale=disturbances.mass_scale),
                                  first.step_length, contact_time_constant)  # fmt: skip
    with instability_reports(mujoco) as unstable:
        return _walk_sequence(mujoco, model, data, mjcf, feedback, disturbances, stand,
                              (foot_kp, foot_kd), preload, unstable)  # fmt: skip


def _walk_sequence(mujoco, model, data, mjcf, feedback, disturbances, stand, foot_gains,
                   preload, unstable) -> SequenceMujocoRun:  # fmt: skip
    """The control loop of :func:`run_sequence_in_mujoco`."""
    steps = feedback.sequence.steps
    first = steps[0].gait.problem
    io = WalkerIo(mujoco, model, data, mjcf, first, None)
    start = steps[0].gait.solution.states[0].copy()
    if disturbances.initial is not None:
        start = start + np.asarray(disturbances.initial, dtype=float)
    io.place(start, preload)
    period = 1.0 / feedback.control_rate_hz
    substeps = max(1, round(period / model.opt.timestep))
    biped = first.biped
    torso = model.body(biped.upper_body[0] if biped.upper_body else biped.stance_thigh).id
    ends_standing = feedback.sequence.speeds[-1] == 0
    passive = first.biped.stance_shank in first.passive
    sole = None if passive or not mjcf.feet else (first.foot_sole or (0.05, 0.15))
    records, times, states = [], [], []
    stance, clock, fell = "A", 0.0, None
    stance_start = io.ankle_position(stance)
    hip_x = []
    for j, step in enumerate(steps):
        problem = step.gait.problem
        last_stop = ends_standing and j == len(steps) - 1
        horizon = problem.step_time + stand if last_stop else 2.0 * problem.step_time
        t_step, peak_normal, peak_torque, slip, tracking = 0.0, 0.0, 0.0, 0.0, 0.0
        reference = feedback.references[j]
        pushed = disturbances.push == 0.0 or j != disturbances.push_step
        landed = False
        while True:
            x = io.state(stance)
            torques = feedback.law(j, t_step, x)
            if sole is not None:  # the stance ankle within what the sole can take now
                normal = io.normal_force(stance)
                torques[0] = np.clip(torques[0], -SOLE_USE * sole[0] * normal,
                                     SOLE_USE * sole[1] * normal)  # fmt: skip
            planned = reference.at_time(t_step)[0][: io.n]
            tracking = max(tracking, float(np.abs(x[: io.n] - planned).max()))
            peak_torque = max(peak_torque, io.drive(torques, stance, *foot_gains))
            push_now = not pushed and t_step >= disturbances.push_at * problem.step_time
            pushed = pushed or push_now
            push = (torso, disturbances.push, period) if push_now else None
            report = advance(mujoco, model, data, substeps, unstable, push)
            if report is not None:
                fell = f"step {j} ({step.kind}), t = {t_step:.3f} s: MuJoCo: {report}"
                break
            t_step += period
            clock += period
            times.append(clock)
            states.append(data.qpos.copy())
            hip_x.append(float(mjcf.model_coordinates(data.qpos)[0]))
            peak_normal = max(peak_normal, io.normal_force(stance))
            slip = max(slip, abs(io.ankle_position(stance).real - stance_start.real))
            if not io.lowest_hinge(feedback.sequence.steps[0].gait.problem.dynamics) >= -0.02:
                fell = f"step {j} ({step.kind}), t = {t_step:.3f} s: a body point went under " \
                       "the ground"  # fmt: skip
                break
            if t_step >= horizon - 1e-12:
                if not last_stop:
                    fell = f"step {j} ({step.kind}): no touchdown within twice the step time"
                break
            swing = "B" if stance == "A" else "A"
            if last_stop or t_step <= 0.5 * problem.step_time:
                continue
            if io.normal_force(swing) > TOUCHDOWN_FORCE:
                landing = io.ankle_position(swing)
                if landing.real - stance_start.real < 0.25 * problem.step_length:
                    fell = (f"step {j} ({step.kind}), t = {t_step:.3f} s: the swing foot came "
                            f"down {landing.real - stance_start.real:+.3f} m from the stance "
                            "foot")  # fmt: skip
                    break
                landed = True
                break
        if fell is not None:
            break
        landing = io.ankle_position("B" if stance == "A" else "A")
        records.append(MujocoStep(j, t_step, landing.real - stance_start.real, slip,
                                  peak_normal, tracking, peak_torque))  # fmt: skip
        if landed:
            stance, stance_start = ("B" if stance == "A" else "A"), landing
    rest_speed = float("nan")
    if fell is None and ends_standing and len(hip_x) > 2:
        rest_speed = abs(hip_x[-1] - hip_x[-2]) / period
    stood = fell is None and ends_standing and rest_speed < REST_SPEED
    if fell is None and ends_standing and not stood:
        fell = f"the walk ended with the hip still moving at {rest_speed:.3f} m/s"
    run = MujocoRun(tuple(records), fell, np.asarray(times), np.asarray(states), mjcf)
    return SequenceMujocoRun(run, len(steps), stood, rest_speed)


__all__ = ["REST_SPEED", "SequenceMujocoRun", "run_sequence_in_mujoco"]
