"""A walk sequence in MuJoCo (``pip install ".[mujoco]"``): the walker of the plan
(:func:`problems.control.mujoco.walker_mjcf`: floating, soles where the plan has an ankle
torque) walks every step of the walk under the sequence's law
(:class:`problems.library.closed_loop.SequenceFeedback`), from quiet standing to quiet
standing.

Each step's law runs by the time since its touchdown; a step ends when the swing foot touches
the ground with more than :data:`problems.control.mujoco.TOUCHDOWN_FORCE` once past half its
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
from problems.control.mujoco import (
    CONTACT_TIME_CONSTANT,
    FOOT_MASS,
    PRELOAD,
    REST_SPEED,
    TOUCHDOWN_FORCE,
    MujocoRun,
    MujocoStep,
    WalkerIo,
    advance,
    disturbed_model,
    due_push,
    import_mujoco,
    instability_reports,
    walker_mjcf,
)
from problems.control.simulation import Disturbances
from problems.library.closed_loop import GROUND_MU, STAND, SequenceDisturbances, SequenceFeedback

#: the stance ankle's torque is held within this part of what the sole carries at the
#: measured normal force, -heel Fy .. toe Fy: beyond it the foot tips onto its heel or toe
#: (the plan keeps its centre of pressure on the sole; its feedback need not)
SOLE_USE = 0.9
#: the swing foot's ankle PD that keeps it flat, N m/rad and N m s/rad: stiffer than the
#: periodic step's (20, 0.2), under which the swing foot of a start's second step pitches
#: 0.15 rad toe-down and its toe catches the ground at s = 0.8 (measured; the walk 0 -> 1.0
#: -> 0 m/s then falls at its third step); critically damped for the 0.5 kg foot
FOOT_KP, FOOT_KD = 100.0, 1.0


@dataclass(frozen=True)
class SequenceMujocoRun:
    """The walk in MuJoCo: ``run`` (its steps, fall, time and MuJoCo's positions: a
    :class:`problems.control.mujoco.MujocoRun`), the ``planned`` steps, and whether it ended
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


class _SequenceWalk:
    """The control loop of :func:`run_sequence_in_mujoco`: :meth:`step` walks one step of the
    walk, :meth:`result` says how the walk ended."""

    def __init__(self, mujoco, model, data, mjcf, feedback, disturbances, foot_gains,
                 unstable) -> None:  # fmt: skip
        self.mujoco, self.model, self.data, self.mjcf = mujoco, model, data, mjcf
        self.feedback, self.disturbances = feedback, disturbances
        self.foot_gains, self.unstable = foot_gains, unstable
        first = feedback.sequence.steps[0].gait.problem
        self.dynamics = first.dynamics
        self.io = WalkerIo(mujoco, model, data, mjcf, first, None)
        self.period = 1.0 / feedback.control_rate_hz
        self.substeps = max(1, round(self.period / model.opt.timestep))
        biped = first.biped
        self.torso = model.body(biped.upper_body[0] if biped.upper_body else biped.stance_thigh).id
        passive = biped.stance_shank in first.passive
        self.sole = None if passive or not mjcf.feet else (first.foot_sole or (0.05, 0.15))
        self.records, self.times, self.states, self.hip_x = [], [], [], []
        self.stance, self.clock = "A", 0.0
        self.stance_start = 0j

    def place(self, start: np.ndarray, preload: float) -> None:
        self.io.place(start, preload)
        self.stance_start = self.io.ankle_position(self.stance)

    def _torques(self, j: int, t: float, x: np.ndarray) -> np.ndarray:
        """Step j's law, the stance ankle within what the sole carries now."""
        torques = self.feedback.law(j, t, x)
        if self.sole is not None:
            normal = self.io.normal_force(self.stance)
            torques[0] = np.clip(torques[0], -SOLE_USE * self.sole[0] * normal,
                                 SOLE_USE * self.sole[1] * normal)  # fmt: skip
        return torques

    def step(self, j: int, last_stop: bool, stand: float) -> str | None:
        """Walk step j (the walk's last, ending standing for ``stand`` s, when ``last_stop``);
        why it fell, or None."""
        io, step = self.io, self.feedback.sequence.steps[j]
        problem, reference = step.gait.problem, self.feedback.references[j]
        where = f"step {j} ({step.kind})"
        horizon = problem.step_time + stand if last_stop else 2.0 * problem.step_time
        t, peak_normal, peak_torque, slip, tracking = 0.0, 0.0, 0.0, 0.0, 0.0
        pushed = self.disturbances.push == 0.0
        swing = "B" if self.stance == "A" else "A"
        while True:
            x = io.state(self.stance)
            torques = self._torques(j, t, x)
            planned = reference.at_time(t)[0][: io.n]
            tracking = max(tracking, float(np.abs(x[: io.n] - planned).max()))
            peak_torque = max(peak_torque, io.drive(torques, self.stance, *self.foot_gains))
            pushed, push = due_push(self.disturbances, pushed, j, t, problem.step_time,
                                    self.torso, self.period)  # fmt: skip
            report = advance(self.mujoco, self.model, self.data, self.substeps, self.unstable,
                             push)  # fmt: skip
            if report is not None:
                return f"{where}, t = {t:.3f} s: MuJoCo: {report}"
            t += self.period
            self._record()
            peak_normal = max(peak_normal, io.normal_force(self.stance))
            slip = max(slip, abs(io.ankle_position(self.stance).real - self.stance_start.real))
            if not io.lowest_hinge(self.dynamics) >= -0.02:
                return f"{where}, t = {t:.3f} s: a body point went under the ground"
            if t >= horizon - 1e-12:
                if not last_stop:
                    return f"{where}: no touchdown within twice the step time"
                break
            if last_stop or t <= 0.5 * problem.step_time:
                continue
            if io.normal_force(swing) > TOUCHDOWN_FORCE:
                ahead = io.ankle_position(swing).real - self.stance_start.real
                if ahead < 0.25 * problem.step_length:
                    return f"{where}, t = {t:.3f} s: the swing foot came down {ahead:+.3f} m " \
                           "from the stance foot"  # fmt: skip
                break
        landing = io.ankle_position(swing)
        self.records.append(MujocoStep(j, t, landing.real - self.stance_start.real, slip,
                                       peak_normal, tracking, peak_torque))  # fmt: skip
        if not last_stop:
            self.stance, self.stance_start = swing, landing
        return None

    def _record(self) -> None:
        self.clock += self.period
        self.times.append(self.clock)
        self.states.append(self.data.qpos.copy())
        self.hip_x.append(float(self.mjcf.model_coordinates(self.data.qpos)[0]))

    def result(self, fell: str | None, ends_standing: bool) -> SequenceMujocoRun:
        rest_speed = float("nan")
        if fell is None and ends_standing and len(self.hip_x) > 2:
            rest_speed = abs(self.hip_x[-1] - self.hip_x[-2]) / self.period
        stood = fell is None and ends_standing and rest_speed < REST_SPEED
        if fell is None and ends_standing and not stood:
            fell = f"the walk ended with the hip still moving at {rest_speed:.3f} m/s"
        run = MujocoRun(tuple(self.records), fell, np.asarray(self.times),
                        np.asarray(self.states), self.mjcf)  # fmt: skip
        return SequenceMujocoRun(run, len(self.feedback.sequence.steps), stood, rest_speed)


def _walk_sequence(mujoco, model, data, mjcf, feedback, disturbances, stand, foot_gains,
                   preload, unstable) -> SequenceMujocoRun:  # fmt: skip
    """The control loop of :func:`run_sequence_in_mujoco`."""
    walk = _SequenceWalk(mujoco, model, data, mjcf, feedback, disturbances, foot_gains, unstable)
    steps = feedback.sequence.steps
    start = steps[0].gait.solution.states[0].copy()
    if disturbances.initial is not None:
        start = start + np.asarray(disturbances.initial, dtype=float)
    walk.place(start, preload)
    ends_standing = feedback.sequence.speeds[-1] == 0
    fell = None
    for j in range(len(steps)):
        fell = walk.step(j, ends_standing and j == len(steps) - 1, stand)
        if fell is not None:
            break
    return walk.result(fell, ends_standing)


__all__ = ["REST_SPEED", "SequenceMujocoRun", "run_sequence_in_mujoco"]
