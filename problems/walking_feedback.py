"""The feedback that travels with a walking step's torques, and the closed-loop check of it.

:func:`design_feedback` takes a solved single-support walking step and returns a
:class:`Feedback`: the plan as a phase-indexed reference, the periodic LQR gains
(:mod:`problems.walking_lqr`), the controller (clipped to the drives' limits) and the plant it
was designed on. :meth:`Feedback.channels` writes it into the exported profile: per sample the
phase ``phase`` and every gain ``K_<hinge>__<state>`` (N m/rad, N m s/rad), with the law, the
phase's definition, the control rate and the weights in ``metadata["feedback"]``; a drive reads
its row of K beside its torque. :func:`closed_loop_check` runs the checks the README prints:
the multipliers, open loop against closed loop, 50 steps, a heavier and a lighter body, a
ground a little higher or lower, and the largest pushes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from model.errors import DefinitionError
from planner.trajectory import Trajectory
from problems.walking_control import GaitReference, OpenLoop
from problems.walking_linearisation import ReturnMap, fixed_point
from problems.walking_lqr import (
    LqrWeights,
    PeriodicGains,
    PhaseLQR,
    linearise_along,
    periodic_lqr,
)
from problems.walking_simulation import (
    Disturbances,
    Plant,
    WalkingRun,
    largest_push,
    simulate_walking,
)

#: a push is survived when the biped walks this many steps (the push comes in the second)
PUSH_STEPS = 10
LAW = "M = clip(M_ff(s) + K(s) (x_ref(s) - x), -limit, limit), x = (psi, dpsi)"
PHASE = (
    "s = (x_hip - x_hip(0)) / (x_hip(T) - x_hip(0)): the hip (end of {hip}) ahead of the "
    "stance foot along x, 0 at the step's start, 1 at the planned heel strike; psi absolute "
    "angles from +x, stance foot at H0"
)
EARLY = "a heel strike before s = 1 ends the step: swap the legs and start again at s = 0"
LATE = "s > 1: x_ref goes on along its last slope dx/ds, M_ff and K hold their last values"


@dataclass(frozen=True, eq=False)
class Feedback:
    """A walking step's feedback design (see the module docstring)."""

    step: object
    reference: GaitReference
    gains: PeriodicGains
    controller: PhaseLQR
    plant: Plant
    control_rate_hz: float
    design_seconds: float

    @property
    def names(self) -> tuple[str, ...]:
        return self.step.linkage.names

    def channels(self, trajectory: Trajectory) -> Trajectory:
        """``trajectory`` (the step's exported samples) with the phase of each sample and the
        gains there as extra columns, and the law in its metadata."""
        if trajectory.psi.shape[1] != len(self.names):
            raise DefinitionError(
                f"`trajectory`: {trajectory.psi.shape[1]} angles, the feedback has "
                f"{len(self.names)}"
            )
        phases = np.array([self.reference.phase(psi) for psi in trajectory.psi])
        gains = np.array([self.controller.gain_at(s) for s in phases])  # (K, n, 2n)
        weights = self.gains.weights
        return with_gains(
            trajectory,
            self.names,
            phases,
            gains,
            {
                "law": LAW,
                "phase": PHASE.format(hip=self.step.biped.stance_thigh),
                "early_strike": EARLY,
                "late_strike": LATE,
                "limit_N_m": [float(v) if np.isfinite(v) else None for v in self.controller.limits],
                "control_rate_hz": self.control_rate_hz,
                "design": "periodic discrete LQR through the heel strike (saltation), "
                "Bryson weights",
                "weights": weights.as_metadata(),
            },
        )


def with_gains(trajectory: Trajectory, names, phases, gains, law: dict) -> Trajectory:
    """``trajectory`` with the phase of each sample (``phase``, (K,)) and the gains (K, n, 2n)
    as columns ``K_<hinge>__<state>`` (N m/rad for the angles, N m s/rad for the rates),
    and ``law`` (with the state's and the columns' names added) in
    ``metadata["feedback"]``."""
    n = len(names)
    gains = np.asarray(gains, dtype=float)
    if trajectory.psi.shape[1] != n or gains.shape != (trajectory.n_samples, n, 2 * n):
        raise DefinitionError(
            f"`gains`: (samples, n, 2n) = ({trajectory.n_samples}, {n}, {2 * n}) for this "
            f"trajectory, got {gains.shape}"
        )
    states = [f"psi_{name}" for name in names] + [f"dpsi_{name}" for name in names]
    out = trajectory.with_extra("phase", np.asarray(phases, dtype=float), "1")
    for i, hinge in enumerate(names):
        for j, state in enumerate(states):
            unit = "N m/rad" if j < n else "N m s/rad"
            out = out.with_extra(f"K_{hinge}__{state}", gains[:, i, j], unit)
    return out.with_metadata(
        feedback={
            **law,
            "state": states,
            "gains": "K_<hinge>__<state>: row <hinge> of K, column <state>",
        }
    )


def design_feedback(
    gait,
    *,
    weights: LqrWeights | None = None,
    control_rate_hz: float = 1000.0,
    ground_mu: float | None = None,
) -> Feedback:
    """The periodic LQR feedback of a solved walking step (single support only).

    ground_mu: the friction of the ground the plant's checks use (default the plan's mu).
    """
    step = gait.problem
    if getattr(step, "double_support", 0.0):
        raise DefinitionError(
            "`gait`: a step with a double support has no feedback design yet; plan it with "
            "double_support=0"
        )
    start = time.perf_counter()
    reference = GaitReference.of(gait, rate_hz=control_rate_hz)
    plant = Plant(step.linkage, mu=ground_mu if ground_mu is not None else step.mu)
    passive = tuple(step.linkage.index(name) for name in step.passive)
    gains = periodic_lqr(
        plant, reference, weights=weights, control_rate_hz=control_rate_hz, passive=passive
    )
    limits = [step.torque_limit.get(name, np.inf) for name in step.linkage.names]
    controller = PhaseLQR(reference, gains, limits=limits)
    return Feedback(
        step,
        reference,
        gains,
        controller,
        plant,
        control_rate_hz,
        time.perf_counter() - start,
    )


@dataclass(frozen=True)
class ClosedLoopCheck:
    """What :func:`closed_loop_check` measured.

    loop: the closed loop's return map at its periodic gait (multipliers);
    open_loop_multipliers: of the plan's torques alone, linearised along the plan;
    open_loop: the plan's torques alone, simulated; runs: label -> WalkingRun; pushes:
    (forward, back) N s survived; push_runs: (forward, back) the runs that survived them
    (:data:`PUSH_STEPS` steps, the push in the second); steps: the steps each run was asked
    to walk; reference: the plan's; seconds: label -> wall time.
    """

    loop: ReturnMap
    open_loop_multipliers: np.ndarray
    open_loop: WalkingRun
    runs: dict[str, WalkingRun]
    pushes: tuple[float, float]
    push_runs: tuple[WalkingRun, WalkingRun]
    steps: int
    reference: GaitReference
    seconds: dict[str, float] = field(default_factory=dict)


def disturbance_cases(feedback: Feedback) -> dict[str, Disturbances]:
    """The disturbances both checks run (the product's and MuJoCo's), by label: the plan, a
    body 10 % heavier and lighter, the ground 5 mm and 1 cm higher and lower from the first
    new foothold on, a start 0.02 rad off on every angle, drives limited to 2/3 of the plan's
    limit."""
    n = len(feedback.names)
    limit = min(feedback.step.torque_limit.values())
    return {
        "plan": Disturbances(),
        "mass +10 %": Disturbances(mass_scale=1.1),
        "mass -10 %": Disturbances(mass_scale=0.9),
        "ground +5 mm": Disturbances(ground_rise=0.005),
        "ground -5 mm": Disturbances(ground_rise=-0.005),
        "ground +1 cm": Disturbances(ground_rise=0.01),
        "ground -1 cm": Disturbances(ground_rise=-0.01),
        "start 0.02 rad": Disturbances(initial=np.r_[np.full(n, 0.02), np.zeros(n)]),
        f"|M| <= {2 * limit / 3:g}": Disturbances(torque_limit=2.0 * limit / 3.0),
    }


def closed_loop_check(feedback: Feedback, steps: int = 50) -> ClosedLoopCheck:
    """The feedback's multipliers and simulated walks (module docstring)."""
    step = feedback.step
    options = {
        "linkage": step.linkage,
        "step_time": step.step_time,
        "step_length": step.step_length,
        "mu": feedback.plant.mu,
        "control_rate_hz": feedback.control_rate_hz,
        "reference": feedback.reference,
    }
    seconds = {}
    clock = time.perf_counter()
    loop = fixed_point(
        feedback.plant,
        feedback.controller,
        feedback.reference.states[0],
        step_time=step.step_time,
        step_length=step.step_length,
        control_rate_hz=feedback.control_rate_hz,
    )
    seconds["fixed point and multipliers"] = time.perf_counter() - clock
    start = feedback.reference.states[0]
    open_loop = simulate_walking(start, OpenLoop(feedback.reference), steps=steps, **options)
    runs = {}
    for label, disturbances in disturbance_cases(feedback).items():
        clock = time.perf_counter()
        runs[label] = simulate_walking(
            start, feedback.controller, steps=steps, disturbances=disturbances, **options
        )
        seconds[label] = time.perf_counter() - clock
    clock = time.perf_counter()

    def walk(disturbances):
        return simulate_walking(
            start, feedback.controller, steps=PUSH_STEPS, disturbances=disturbances, **options
        )

    forward, forward_run = largest_push(walk, direction=1.0, steps=PUSH_STEPS)
    back, back_run = largest_push(walk, direction=-1.0, steps=PUSH_STEPS)
    seconds["push margins"] = time.perf_counter() - clock
    along = linearise_along(feedback.plant, feedback.reference, 1.0 / feedback.control_rate_hz)
    return ClosedLoopCheck(
        loop,
        along.open_loop_multipliers,
        open_loop,
        runs,
        (forward, back),
        (forward_run, back_run),
        steps,
        feedback.reference,
        seconds,
    )


__all__ = [
    "ClosedLoopCheck",
    "Feedback",
    "closed_loop_check",
    "design_feedback",
    "disturbance_cases",
    "with_gains",
]
