"""Feedback of the paper's fixed-base periodic gait, its Floquet multipliers, and its run in
MuJoCo.

The fixed-base gait (:mod:`problems.pinned.gait`) keeps the stance foot pinned at H0 for
ever: no impact, no leg swap, the torques a function of time. Its Poincare section is an
instant, t = 0 mod T, and its return map the flow over one period, as the digital controller
makes it: K periods x_{k+1} = F(x_k, M_k, h) of h = T / K (the rate nearest to
``control_rate_hz`` that divides T, so that every gait period meets the same control
instants), M_k held (:class:`problems.control.simulation.Plant`'s generated RK4). No
saltation enters (a state change does not move the section, an instant) and no multiplier is
pinned at 0 or 1: the time-forced system has no phase to drift along.

* open loop, M_k = M_ff(t_k): the monodromy A_{K-1} ... A_0 along the plan
  (:func:`problems.control.lqr.linearise_along` with ``end=None``); its eigenvalues are
  the open-loop multipliers;
* closed loop, M_k = clip(M_ff(t_k) + K_k (x_ref(t_k) - x_k), -limit, limit) with the periodic
  LQR (:func:`problems.control.lqr.lqr_along`, jump = I, Bryson's weights): its multipliers
  are those of the closed loop's own periodic orbit (Newton on :func:`period_map`, whose
  Jacobian is the exact chain of the periods' Jacobians), near the plan but not on it (the
  plan is a continuous optimum, the plant a held-torque RK4).

The controller is indexed by the time t mod T: the pinned gait has no event that could come
early or late, so the time is its phase.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from planner.errors import DefinitionError, check_integer, check_positive
from planner.trajectory import Trajectory
from problems.control.feedback import limit_metadata, with_gains
from problems.control.linearisation import ReturnMap, newton_fixed_point
from problems.control.lqr import Linearisation, LqrWeights, linearise_along, lqr_along
from problems.control.simulation import Plant, scaled_linkage
from problems.control.tracking import TimedReference

LAW = (
    "M = clip(M_ff(t_k) + K(t_k) (x_ref(t_k) - x), -limit, limit), t_k = k h the control "
    "instant of t mod T, x = (psi, dpsi)"
)


class PinnedLQR:
    """The fixed-base gait's digital law (module docstring): tables at the K control
    instants of a period; zero gains make the open loop.

    reference : TimedReference at the K + 1 instants k h (the last one T); gains (K, n, 2n);
    limits (n,) N m or None.
    """

    def __init__(self, reference: TimedReference, gains: np.ndarray, limits=None) -> None:
        self.reference = reference
        self.gains = np.asarray(gains, dtype=float)
        count = self.gains.shape[0]
        if reference.time.size != count + 1:
            raise DefinitionError(
                f"`gains`: one per control period ({reference.time.size - 1}), got {count}"
            )
        self.period = reference.duration
        self.h = self.period / count
        self.limits = None if limits is None else np.asarray(limits, dtype=float)

    @property
    def count(self) -> int:
        return self.gains.shape[0]

    def index(self, t: float) -> int:
        """k of the control instant that t (s, any period) belongs to."""
        return int(np.floor(t / self.h + 1e-9)) % self.count

    def torques(self, t: float, x: np.ndarray) -> np.ndarray:
        k = self.index(t)
        out = self.reference.torques[k] + self.gains[k] @ (self.reference.states[k] - x)
        if self.limits is not None:
            out = np.clip(out, -self.limits, self.limits)
        return out

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        """dM/dx (n, 2n): -K_k, zero rows where a drive saturates."""
        out = -self.gains[self.index(t)].copy()
        if self.limits is not None:
            out[np.abs(self.torques(t, x)) >= self.limits] = 0.0
        return out


@dataclass(frozen=True, eq=False)
class PinnedFeedback:
    """A fixed-base gait's feedback design.

    gait: the solved :class:`problems.pinned.gait.PeriodicGait`; reference: the plan at the
    K + 1 control instants; along: the plan's linearisation (open-loop monodromy);
    controller: the closed loop; open_loop: the plan's torques alone (zero gains);
    cost (2n, 2n): the Riccati P at t = 0; cycles: the periods the Riccati recursion ran;
    weights; plant; control_rate_hz: K / T, Hz; design_seconds.
    """

    gait: object
    reference: TimedReference
    along: Linearisation
    controller: PinnedLQR
    open_loop: PinnedLQR
    cost: np.ndarray
    cycles: int
    weights: LqrWeights
    plant: Plant
    control_rate_hz: float
    design_seconds: float

    @property
    def names(self) -> tuple[str, ...]:
        return self.gait.problem.linkage.names

    @property
    def period(self) -> float:
        return self.reference.duration

    @property
    def open_loop_multipliers(self) -> np.ndarray:
        """The plan's open-loop Floquet multipliers, largest modulus first."""
        return self.along.open_loop_multipliers

    def channels(self, trajectory: Trajectory) -> Trajectory:
        """``trajectory`` (the gait's exported samples over a period) with its phase t / T
        and the gains in force at each sample (those of its control period) as columns
        ``K_<hinge>__<state>``, and the law in ``metadata["feedback"]``."""
        times = np.asarray(trajectory.time, dtype=float) - float(trajectory.time[0])
        gains = np.array([self.controller.gains[self.controller.index(t)] for t in times])
        weights = self.weights
        return with_gains(
            trajectory,
            self.names,
            times / self.period,
            gains,
            {
                "law": LAW,
                "phase": f"t / T mod 1, T = {self.period:g} s (the fixed-base gait's period)",
                "limit_N_m": limit_metadata(self.controller.limits),
                "control_rate_hz": self.control_rate_hz,
                "design": "periodic discrete LQR over the period (no impact), Bryson weights",
                "weights": weights.as_metadata(),
            },
        )


def design_pinned_feedback(
    gait, *, weights: LqrWeights | None = None, control_rate_hz: float = 1000.0
) -> PinnedFeedback:
    """The periodic LQR of a solved fixed-base gait (module docstring)."""
    weights = weights or LqrWeights()
    rate = check_positive("control_rate_hz", control_rate_hz, "Hz")
    start = time.perf_counter()
    problem = gait.problem
    period = float(gait.solution.T)
    count = max(1, round(period * rate))
    instants = np.linspace(0.0, period, count + 1)
    reference = TimedReference(gait.to_trajectory(count / period).resample(times=instants))
    plant = Plant(problem.linkage, mu=None)
    along = linearise_along(plant, reference, period / count, end=None)
    passive = tuple(problem.linkage.index(name) for name in getattr(problem, "passive", ()))
    gains, cost, cycles = lqr_along(along, weights, passive)
    limits = [problem.torque_limit.get(name, np.inf) for name in problem.linkage.names]
    controller = PinnedLQR(reference, gains, limits)
    open_loop = PinnedLQR(reference, np.zeros_like(gains))
    return PinnedFeedback(
        gait, reference, along, controller, open_loop, cost, cycles, weights, plant,
        count / period, time.perf_counter() - start,
    )  # fmt: skip


def period_map(plant: Plant, controller: PinnedLQR, start, jacobian: bool = True) -> ReturnMap:
    """x(T) from x(0) = ``start`` (2n,) under ``controller`` on ``plant``, and (``jacobian``)
    dx(T)/dx(0) by the chain of the periods' exact Jacobians (dF/dx + dF/dM dM/dx)."""
    start = np.asarray(start, dtype=float)
    end, chain, _ = _one_period(plant, controller, start, jacobian)
    if chain is None:
        chain = np.full((start.size, start.size), np.nan)
    return ReturnMap(start, end, chain, controller.period)


def _one_period(plant: Plant, controller: PinnedLQR, x, jacobian: bool):
    """(x(T), dx(T)/dx(0) or None, the largest |M| commanded, N m) from x(0) = x."""
    chain = np.eye(x.size) if jacobian else None
    peak = 0.0
    for k in range(controller.count):
        t = k * controller.h
        torques = controller.torques(t, x)
        peak = max(peak, float(np.abs(torques).max()))
        if jacobian:
            dx, dm, _ = (np.asarray(v) for v in plant.advance_jacobian(x, torques, controller.h))
            chain = (dx + dm @ controller.jacobian(t, x)) @ chain
        x = plant.advance_state(x, torques, controller.h)
    return x, chain, peak


def closed_loop_orbit(feedback: PinnedFeedback, tolerance: float = 1e-10) -> ReturnMap:
    """The closed loop's periodic orbit (x* = P(x*) from the plan's start: periods without
    their Jacobian while they contract, then Newton) and its return map there:
    ``.multipliers``, ``.spectral_radius``."""
    plant, controller = feedback.plant, feedback.controller
    return newton_fixed_point(
        lambda x: period_map(plant, controller, x),
        feedback.reference.states[0],
        tolerance,
        value=lambda x: period_map(plant, controller, x, jacobian=False).end,
    )


@dataclass(frozen=True)
class PinnedRun:
    """Periods simulated: starts (periods + 1, 2n) the state at each t = k T; deviation
    (periods + 1,) the largest |psi - psi_ref(0)| there, rad; peak_torque N m."""

    starts: np.ndarray
    deviation: np.ndarray
    peak_torque: float

    @classmethod
    def of(cls, feedback: PinnedFeedback, starts, peak_torque: float) -> PinnedRun:
        starts = np.array(starts)
        n = len(feedback.names)
        psi0 = feedback.reference.states[0][:n]
        return cls(starts, np.abs(starts[:, :n] - psi0).max(axis=1), peak_torque)


def simulate_periods(
    feedback: PinnedFeedback,
    *,
    periods: int = 20,
    initial=None,
    mass_scale: float = 1.0,
    closed: bool = True,
) -> PinnedRun:
    """``periods`` gait periods on the product's model (held torques, RK4) from the plan's
    start plus ``initial`` (2n,), on a body whose masses and inertias are ``mass_scale``
    times the plan's; ``closed`` False plays the plan's torques alone."""
    periods = check_integer("periods", periods, 1)
    scale = check_positive("mass_scale", mass_scale)
    linkage = feedback.gait.problem.linkage
    plant = feedback.plant if scale == 1.0 else Plant(scaled_linkage(linkage, scale), mu=None)
    controller = feedback.controller if closed else feedback.open_loop
    x = _start(feedback, initial)
    starts, peak = [x], 0.0
    for _ in range(periods):
        x, _, period_peak = _one_period(plant, controller, x, jacobian=False)
        peak = max(peak, period_peak)
        if not np.all(np.isfinite(x)):
            break
        starts.append(x)
    return PinnedRun.of(feedback, starts, peak)


def _start(feedback: PinnedFeedback, initial) -> np.ndarray:
    """The plan's start plus ``initial`` (2n,) or None."""
    x = feedback.reference.states[0].copy()
    if initial is None:
        return x
    initial = np.asarray(initial, dtype=float)
    if initial.shape != x.shape:
        raise DefinitionError(
            f"`initial`: the error of the start state (psi, dpsi) has {x.size} entries, got "
            f"shape {initial.shape}"
        )
    return x + initial


def run_pinned_in_mujoco(
    feedback: PinnedFeedback,
    *,
    periods: int = 20,
    initial=None,
    closed: bool = True,
    timestep: float = 0.0005,
) -> PinnedRun:
    """The same periods in MuJoCo (``pip install ".[mujoco]"``): the linkage as a fixed-base
    MJCF (:func:`model.mjcf.to_mjcf`), the law evaluated at the control rate on MuJoCo's
    state mapped back to the model's angles, its torques applied as MuJoCo's generalised
    forces (the hinges' own: the map is one for one), MuJoCo's implicit-fast integrator at
    ``timestep`` s."""
    import mujoco

    from model.mjcf import to_mjcf

    periods = check_integer("periods", periods, 1)
    controller = feedback.controller if closed else feedback.open_loop
    mjcf = to_mjcf(feedback.gait.problem.linkage, base="fixed", timestep=timestep)
    model = mujoco.MjModel.from_xml_string(mjcf.xml)
    substeps = max(1, round(controller.h / timestep))
    model.opt.timestep = controller.h / substeps  # every control instant on a MuJoCo step
    data = mujoco.MjData(model)
    n = len(feedback.names)
    x = _start(feedback, initial)
    data.qpos[:] = mjcf.qpos(x[:n])
    data.qvel[:] = mjcf.qvel(x[n:])
    mujoco.mj_forward(model, data)
    starts, peak = [x], 0.0
    for _ in range(periods):
        for k in range(controller.count):
            state = np.r_[mjcf.model_coordinates(data.qpos), mjcf.model_coordinates(data.qvel)]
            torques = controller.torques(k * controller.h, state)
            peak = max(peak, float(np.abs(torques).max()))
            data.qfrc_applied[:] = mjcf.joint_forces(torques)
            mujoco.mj_step(model, data, nstep=substeps)
        state = np.r_[mjcf.model_coordinates(data.qpos), mjcf.model_coordinates(data.qvel)]
        if not np.all(np.isfinite(state)):
            break
        starts.append(state)
    return PinnedRun.of(feedback, starts, peak)


__all__ = [
    "PinnedFeedback",
    "PinnedLQR",
    "PinnedRun",
    "closed_loop_orbit",
    "design_pinned_feedback",
    "period_map",
    "run_pinned_in_mujoco",
    "simulate_periods",
]
