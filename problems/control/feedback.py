"""The feedback that travels with a walking step's torques, and the closed-loop check of it.

:func:`design_feedback` takes a solved single-support walking step and returns a
:class:`Feedback`: the plan as a phase-indexed reference, the periodic LQR gains
(:mod:`problems.control.lqr`), the controller (clipped to the drives' limits) and the plant it
was designed on. :meth:`Feedback.channels` writes it into the exported profile: per sample the
phase ``phase`` and every gain ``K_<hinge>__<state>`` (N m/rad, N m s/rad), with the law, the
phase's definition, the control rate and the weights in ``metadata["feedback"]``; a drive reads
its row of K beside its torque. :func:`closed_loop_check` runs the checks the feedback guide prints:
the multipliers, open loop against closed loop, 50 steps, a heavier and a lighter body, a
ground a little higher or lower, and the largest pushes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from planner.errors import DefinitionError
from planner.trajectory import Trajectory
from problems.control.linearisation import ReturnMap, fixed_point
from problems.control.lqr import (
    SOFT_RAMP,
    SOFT_SETTLE,
    SOFT_TOUCHDOWN,
    LqrWeights,
    PeriodicGains,
    PhaseLQR,
    SwitchedLQR,
    double_support_lqr,
    linearise_along,
    linearise_double_support,
    periodic_lqr,
)
from problems.control.simulation import (
    Disturbances,
    Plant,
    WalkingRun,
    disturbances_for,
    largest_push,
    simulate_walking,
)
from problems.control.tracking import GaitReference, OpenLoop

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
BRANCHES = (
    "with a double support the rows carry double_support = 0 (single support, from the "
    "lift-off of the rear foot to the heel strike) or 1 (from the heel strike to the lift-off "
    "at s = 1); the law reads the rows of the branch in force, by s; the legs swap at s = 1"
)
EARLY_HELD = (
    "a heel strike before the double support's first row holds that row until s reaches it; "
    "one after the single support's last row extends that branch along its last slope"
)


@dataclass(frozen=True, eq=False)
class Feedback:
    """A walking step's feedback design (see the module docstring).

    reference, gains: the step's (with a double support: its single support's branch);
    double: None, or the double support's branch (reference, gains); controller: a
    :class:`PhaseLQR` (a :class:`SwitchedLQR` of the two branches with a double support);
    plan: the whole step's reference (by time: the open loop's torques).
    """

    step: object
    reference: GaitReference
    gains: PeriodicGains
    controller: PhaseLQR | SwitchedLQR
    plant: Plant
    control_rate_hz: float
    design_seconds: float
    double: tuple[GaitReference, PeriodicGains] | None = None
    plan: GaitReference | None = None

    @property
    def names(self) -> tuple[str, ...]:
        return self.step.linkage.names

    @property
    def whole(self) -> GaitReference:
        """The whole step's reference, by time and phase."""
        return self.plan if self.plan is not None else self.reference

    @property
    def tracker(self):
        """What measures the tracking error (``tracking(x)`` rad): the branch in force."""
        return self.controller if self.double is not None else self.reference

    @property
    def lift_off(self):
        """The guard that ends the double support (the simulation's ``lift_off``), or None."""
        if self.double is None:
            return None
        double, n = self.double[0], len(self.names)
        return lambda x: double.phase(x[:n]) - 1.0

    @property
    def simulation_options(self) -> dict:
        """What :func:`simulate_walking` needs to run this step under this feedback."""
        step = self.step
        return {
            "linkage": step.linkage,
            "step_time": step.step_time,
            "step_length": step.step_length,
            "mu": self.plant.mu,
            "control_rate_hz": self.control_rate_hz,
            "reference": self.tracker,
            "lift_off": self.lift_off,
            "rotors": step.dynamics.rotors,
        }

    def channels(self, trajectory: Trajectory) -> Trajectory:
        """``trajectory`` (the step's exported samples) with the phase of each sample and the
        gains there as extra columns, and the law in its metadata."""
        if trajectory.psi.shape[1] != len(self.names):
            raise DefinitionError(
                f"`trajectory`: {trajectory.psi.shape[1]} angles, the feedback has "
                f"{len(self.names)}"
            )
        phases = np.array([self.reference.phase(psi) for psi in trajectory.psi])
        weights = self.gains.weights
        law = {"early_strike": EARLY, "late_strike": LATE}
        if self.double is None:
            gains = np.array([self.controller.gain_at(s) for s in phases])  # (K, n, 2n)
        else:
            # the samples from the heel strike on (the joined file keeps the state after the
            # impact at the strike's instant) take the double support's rows
            times = np.asarray(trajectory.time, dtype=float) - float(trajectory.time[0])
            double = times >= self.reference.duration - 1e-9
            single_law, double_law = self.controller.branches
            laws = [double_law if held else single_law for held in double]
            gains = np.array([law.gain_at(s) for law, s in zip(laws, phases, strict=True)])
            trajectory = trajectory.with_extra("double_support", double.astype(float), "1")
            law = {
                "branches": BRANCHES,
                "early_strike": EARLY_HELD,
                "late_strike": LATE,
                "soft_touchdown": SOFT_TOUCHDOWN,
                "touchdown_settle_s": SOFT_SETTLE,
                "touchdown_ramp_s": SOFT_RAMP,
            }
        return with_gains(
            trajectory,
            self.names,
            phases,
            gains,
            {
                "law": LAW,
                "phase": PHASE.format(hip=self.step.biped.stance_thigh),
                **law,
                "limit_N_m": limit_metadata(self.controller.limits),
                "control_rate_hz": self.control_rate_hz,
                "design": "periodic discrete LQR through the heel strike (saltation), "
                "Bryson weights",
                "weights": weights.as_metadata(),
            },
        )


def limit_metadata(limits) -> list[float | None]:
    """The drives' limits (n,) N m as a file's metadata holds them (None: unlimited)."""
    return [float(v) if np.isfinite(v) else None for v in limits]


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


def gains_from(trajectory: Trajectory, names) -> np.ndarray | None:
    """The gains (K, n, 2n) that :func:`with_gains` wrote into ``trajectory``'s columns
    ``K_<hinge>__<state>`` (hinges and states in the order of ``names``), or None when it
    has none of them."""
    n = len(names)
    states = [f"psi_{name}" for name in names] + [f"dpsi_{name}" for name in names]
    wanted = [f"K_{hinge}__{state}" for hinge in names for state in states]
    extras = trajectory.extras
    if not all(name in extras for name in wanted):
        return None
    values = np.column_stack([np.asarray(extras[name][0], dtype=float) for name in wanted])
    return values.reshape(-1, n, 2 * n)


def design_feedback(
    gait,
    *,
    weights: LqrWeights | None = None,
    control_rate_hz: float = 1000.0,
    ground_mu: float | None = None,
    compiled: bool | None = None,
) -> Feedback:
    """The periodic LQR feedback of a solved walking step: through the heel strike, or with a
    double support through the held strike and the lift-off (one Riccati recursion over the
    whole step, a law per branch: :class:`SwitchedLQR`).

    ground_mu: the friction of the ground the plant's checks use (default the plan's mu).
    compiled: the plant's period Jacobians through the compiled cache (:class:`Plant`).
    """
    step = gait.problem
    start = time.perf_counter()
    plant = Plant(step.linkage, mu=ground_mu if ground_mu is not None else step.mu,
                  rotors=step.dynamics.rotors, compiled=compiled)  # fmt: skip
    passive = tuple(step.linkage.index(name) for name in step.passive)
    limits = [step.torque_limit.get(name, np.inf) for name in step.linkage.names]
    options = {"weights": weights, "control_rate_hz": control_rate_hz, "passive": passive}
    if not getattr(step, "double_support", 0.0):
        reference = GaitReference.of(gait, rate_hz=control_rate_hz)
        gains = periodic_lqr(plant, reference, **options)
        controller = PhaseLQR(reference, gains, limits=limits)
        seconds = time.perf_counter() - start
        return Feedback(step, reference, gains, controller, plant, control_rate_hz, seconds)
    single, double = GaitReference.branches(gait, rate_hz=control_rate_hz)
    single_gains, double_gains = double_support_lqr(plant, single, double, **options)
    controller = SwitchedLQR(
        PhaseLQR(single, single_gains, limits=limits),
        PhaseLQR(double, double_gains, limits=limits),
    )
    return Feedback(
        step, single, single_gains, controller, plant, control_rate_hz,
        time.perf_counter() - start, (double, double_gains),
        GaitReference.of(gait, rate_hz=control_rate_hz),
    )  # fmt: skip


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
    """The disturbances both checks run (the product's and MuJoCo's), by label
    (:func:`problems.control.simulation.disturbances_for` of the feedback's step)."""
    return disturbances_for(len(feedback.names), min(feedback.step.torque_limit.values()))


def closed_loop_check(feedback: Feedback, steps: int = 50) -> ClosedLoopCheck:
    """The feedback's multipliers and simulated walks (module docstring)."""
    step = feedback.step
    options = feedback.simulation_options
    seconds = {}
    clock = time.perf_counter()
    loop = fixed_point(
        feedback.plant,
        feedback.controller,
        feedback.reference.states[0],
        step_time=step.step_time,
        step_length=step.step_length,
        control_rate_hz=feedback.control_rate_hz,
        double_support=None if feedback.double is None else feedback.double[0],
    )
    seconds["fixed point and multipliers"] = time.perf_counter() - clock
    start = feedback.reference.states[0]
    open_loop = simulate_walking(start, OpenLoop(feedback.whole), steps=steps, **options)
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
    period = 1.0 / feedback.control_rate_hz
    if feedback.double is None:
        along = linearise_along(feedback.plant, feedback.reference, period)
    else:
        along = linearise_double_support(
            feedback.plant, feedback.reference, feedback.double[0], period
        )
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
    "limit_metadata",
    "with_gains",
]
