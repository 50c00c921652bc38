"""Feedback gains along a planned walking step: a periodic, time-varying LQR through the heel
strike, applied by the phase.

The digital controller's plant is linearised along the plan at its control instants
t_k = k h (:class:`problems.control.simulation.Plant`: the RK4 period's exact Jacobians),

    dx_{k+1} = A_k dx_k + B_k dM_k,

and the heel strike at T by the impact-and-swap map with the strike instant's shift (the
saltation matrix of the plan's x(T-): S = dDelta/dx (I - f g' / (g' f)), f = dx/dt, g' the
swing foot height's gradient). The cost per period is dx' Q dx + dM' R dM with Bryson's rule:

    Q = diag(1 / angle^2 (n), 1 / rate^2 (n)),   R = diag(1 / torque^2 (drives)),

(:class:`LqrWeights`: the angle, rate and torque errors that cost the same). The periodic
Riccati difference equation is run backwards over the step, through P(T-) = S' P(0) S, until
P(0) repeats (to 1e-10 relative); its gains K_k make the time-varying LQR of the periodic
orbit. Passive hinges get no input (their column of B is left out).

:class:`PhaseLQR` applies them by the phase s(x) (the hip's progress,
:class:`problems.control.tracking.GaitReference`), not by the time since the strike:

    M = M_ff(s) + K(s) (x_ref(s) - x),

K(s) interpolated linearly between the control instants' phases s_k = s(x_ref(t_k)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.errors import DefinitionError, check_positive, check_real
from problems.control.simulation import Plant
from problems.control.tracking import GaitReference, TimedReference

#: the Riccati recursion stops when P(0) changes by less than this, relative, over a step
RICCATI_TOLERANCE = 1e-10
RICCATI_CYCLES = 200


@dataclass(frozen=True)
class LqrWeights:
    """Bryson's rule: the errors that cost as much as each other.

    angle rad, rate rad/s: the state errors; torque N m: the feedback torque.
    """

    angle: float = 0.01
    rate: float = 0.1
    torque: float = 20.0

    def as_metadata(self) -> dict[str, float]:
        """The weights as a file's metadata names them (units in the keys)."""
        return {"angle_rad": self.angle, "rate_rad_s": self.rate, "torque_N_m": self.torque}

    def __post_init__(self) -> None:
        check_positive("angle", self.angle, "rad")
        check_positive("rate", self.rate, "rad/s")
        check_positive("torque", self.torque, "N m")


@dataclass(frozen=True)
class PeriodicGains:
    """The LQR gains of a step.

    phases (K,): s at the control instants; times (K,) s; gains (K, n, 2n) N m/rad and
    N m s/rad (rows of passive hinges zero); cost (2n, 2n): P at the step's start;
    cycles: the steps the Riccati recursion ran.
    """

    phases: np.ndarray
    times: np.ndarray
    gains: np.ndarray
    cost: np.ndarray
    cycles: int
    weights: LqrWeights


def saltation(plant: Plant, x_minus: np.ndarray, torques: np.ndarray, held: bool = False):
    """dx+/dx- (2n, 2n) of the strike at x- under the held torques: dDelta/dx times the
    projection along the flow that the strike instant's shift makes. ``held``: the strike
    that begins a double support (both feet held through the impact, no swap)."""
    n = plant.n
    ddpsi = plant.dynamics.forward_dynamics(x_minus[:n], x_minus[n:], torques)
    gradient = np.zeros(2 * n)
    gradient[:n] = plant.foot.jacobian(x_minus[:n], floating=False)[1]
    mapping = plant.strike_held_jacobian if held else plant.step_map_jacobian
    return np.asarray(mapping(x_minus)) @ _projection(np.r_[x_minus[n:], ddpsi], gradient)


def lift_off_saltation(plant: Plant, reference: GaitReference, x: np.ndarray, torques):
    """dx+/dx- (2n, 2n) where a double support ends: the rear foot lifts when the phase
    reaches 1 (the guard s(psi) - 1, its instant moved by the state), then the legs swap."""
    n = plant.n
    ddpsi, _ = plant.foot.held_dynamics(x[:n], x[n:], torques)
    gradient = np.r_[reference.phase_gradient(x[:n]), np.zeros(n)]
    return plant.swap_jacobian @ _projection(np.r_[x[n:], ddpsi], gradient)


def _projection(flow: np.ndarray, gradient: np.ndarray) -> np.ndarray:
    """I - f g' / (g' f): a state change moves the guard's crossing along the flow f."""
    return np.eye(flow.size) - np.outer(flow, gradient) / (gradient @ flow)


@dataclass(frozen=True)
class Linearisation:
    """The plan's digital step linearised along the plan: times (K,) s of the control
    instants, states [A_k] (2n, 2n), inputs [B_k] (2n, n), jump S (2n, 2n) at the step's end.
    An event inside the step (the heel strike that begins a double support) is a stage of
    its own: its jump as A_k, None as B_k (no input, no cost)."""

    times: np.ndarray
    states: list
    inputs: list
    jump: np.ndarray

    @property
    def monodromy(self) -> np.ndarray:
        """S A_{K-1} ... A_0: the open loop's step-to-step map, linearised along the plan."""
        product = np.eye(self.jump.shape[0])
        for a in self.states:
            product = a @ product
        return self.jump @ product

    @property
    def open_loop_multipliers(self) -> np.ndarray:
        """The eigenvalues of :attr:`monodromy`, largest modulus first."""
        values = np.linalg.eigvals(self.monodromy)
        return values[np.argsort(-np.abs(values))]


#: what ends a linearised stretch of a plan (:func:`linearise_along`)
ENDS = ("strike", "held strike", "lift-off", None)


def linearise_along(
    plant: Plant, reference: TimedReference, period: float, end: str | None = "strike"
) -> Linearisation:
    """The RK4 periods' Jacobians at the plan's samples (x_ref(t_k), M_ff(t_k)), the last
    period cut at the plan's end, and the saltation matrix of the event that ends it:

    * ``"strike"``: the heel strike, its impact and the leg swap (a step with no double
      support);
    * ``"held strike"``: the heel strike that begins a double support (``reference`` the
      single support's branch);
    * ``"lift-off"``: the end of a double support (``reference`` its branch, a
      :class:`GaitReference`: its phase is the guard); the periods on the closed chain;
    * None: no event (the identity: the fixed-base gait's period).
    """
    if end not in ENDS:
        raise DefinitionError(f"`end`: one of {ENDS}, got {end!r}")
    duration = reference.duration
    count = int(np.ceil(duration / period - 1e-9))
    times = np.minimum(np.arange(count) * period, duration)
    lengths = np.diff(np.r_[times, duration])
    samples = [reference.at_time(t) for t in times]
    states = np.column_stack([x for x, _ in samples])
    torques = np.column_stack([m for _, m in samples])
    jacobian = plant.advance_double_jacobian if end == "lift-off" else plant.advance_jacobian
    # every period's Jacobians in one mapped call (the periods are independent here)
    dx, dm, _ = jacobian.map(count)(states, torques, lengths[None, :])
    size = 2 * plant.n
    dx, dm = np.asarray(dx), np.asarray(dm)
    a_list = [dx[:, k * size : (k + 1) * size] for k in range(count)]
    b_list = [dm[:, k * plant.n : (k + 1) * plant.n] for k in range(count)]
    if end is None:
        return Linearisation(times, a_list, b_list, np.eye(size))
    x_end, torques_end = reference.at_time(duration)
    if end == "lift-off":
        jump = lift_off_saltation(plant, reference, x_end, torques_end)
    else:
        jump = saltation(plant, x_end, torques_end, held=end == "held strike")
    return Linearisation(times, a_list, b_list, jump)


def linearise_double_support(
    plant: Plant, single: GaitReference, double: GaitReference, period: float
) -> Linearisation:
    """A step with a double support linearised along its plan: the single support's periods,
    the held strike as a stage of its own, the double support's periods (its control
    instants from the strike on), then the lift-off and the leg swap."""
    first = linearise_along(plant, single, period, "held strike")
    second = linearise_along(plant, double, period, "lift-off")
    return Linearisation(
        np.r_[first.times, single.duration, single.duration + second.times],
        [*first.states, first.jump, *second.states],
        [*first.inputs, None, *second.inputs],
        second.jump,
    )


def periodic_riccati(a_list, b_list, jump, q, r):
    """The periodic discrete Riccati recursion of x_{k+1} = A_k x_k + B_k u_k (k < K), then
    x -> jump x, with the cost sum x' Q x + u' R u per period, run backwards until P(0)
    repeats; a stage whose B_k is None is an event (x -> A_k x, no cost, zero gain).
    Returns (gains (K, m, nx): u_k = -K_k x_k, P(0) (nx, nx), steps run)."""
    cost = np.asarray(q, dtype=float).copy()
    cycles = 0
    while True:
        cycles += 1
        gains, p = riccati_sweep(a_list, b_list, jump.T @ cost @ jump, q, r)
        change = np.abs(p - cost).max() / np.abs(p).max()
        cost = p
        if change < RICCATI_TOLERANCE:
            return gains, cost, cycles
        if cycles == RICCATI_CYCLES:
            raise RuntimeError(
                f"periodic_lqr: P(0) still changes by {change:.1e} after {RICCATI_CYCLES} "
                "steps; the plan's orbit may not be stabilisable with these drives"
            )


def riccati_sweep(a_list, b_list, p_end, q, r):
    """One backward pass of the discrete Riccati recursion of x_{k+1} = A_k x_k + B_k u_k
    (k < K) with the stage cost x' Q x + u' R u, from the cost-to-go ``p_end`` (nx, nx) at
    x_K; a stage whose B_k is None is an event (x -> A_k x, no input, no cost, zero gain).
    Returns (gains (K, m, nx): u_k = -K_k x_k, the cost-to-go P_0 (nx, nx) at x_0)."""
    count = len(a_list)
    inputs = next(b.shape[1] for b in b_list if b is not None)
    gains = np.zeros((count, inputs, p_end.shape[0]))
    p = np.asarray(p_end, dtype=float)
    for k in range(count - 1, -1, -1):
        a, b = a_list[k], b_list[k]
        if b is None:  # an event inside the step: x -> A x, no input, no cost
            p = a.T @ p @ a
            p = 0.5 * (p + p.T)
            continue
        gain = np.linalg.solve(r + b.T @ p @ b, b.T @ p @ a)
        closed = a - b @ gain
        # Joseph form: stays symmetric positive definite in floating point
        p = q + gain.T @ r @ gain + closed.T @ p @ closed
        p = 0.5 * (p + p.T)
        gains[k] = gain
    return gains, p


def periodic_lqr(
    plant: Plant,
    reference: GaitReference,
    *,
    weights: LqrWeights | None = None,
    control_rate_hz: float = 1000.0,
    passive=(),
) -> PeriodicGains:
    """The time-varying LQR gains of the plan's periodic orbit (module docstring)."""
    weights = weights or LqrWeights()
    period = 1.0 / check_positive("control_rate_hz", control_rate_hz, "Hz")
    along = linearise_along(plant, reference, period)
    gains, cost, cycles = lqr_along(along, weights, passive)
    phases = _phases_at(reference, along.times)
    return PeriodicGains(phases, along.times, gains, cost, cycles, weights)


def _phases_at(reference: GaitReference, times) -> np.ndarray:
    """s of the plan's state at each of ``times`` (s since the reference's start)."""
    n = reference.n
    return np.array([reference.phase(reference.at_time(t)[0][:n]) for t in times])


def double_support_lqr(
    plant: Plant,
    single: GaitReference,
    double: GaitReference,
    *,
    weights: LqrWeights | None = None,
    control_rate_hz: float = 1000.0,
    passive=(),
) -> tuple[PeriodicGains, PeriodicGains]:
    """The periodic LQR of a step with a double support (:func:`linearise_double_support`:
    one Riccati recursion through the held strike and the lift-off), as the gains of each
    branch by its phase: (single support's, double support's)."""
    weights = weights or LqrWeights()
    period = 1.0 / check_positive("control_rate_hz", control_rate_hz, "Hz")
    along = linearise_double_support(plant, single, double, period)
    gains, cost, cycles = lqr_along(along, weights, passive)
    first = int(np.ceil(single.duration / period - 1e-9))  # the single support's periods
    out = []
    for reference, rows, times in (
        (single, slice(0, first), along.times[:first]),
        (double, slice(first + 1, None), along.times[first + 1 :] - single.duration),
    ):
        phases = _phases_at(reference, times)
        out.append(PeriodicGains(phases, times, gains[rows], cost, cycles, weights))
    return out[0], out[1]


def weight_matrices(n: int, weights: LqrWeights, passive=()):
    """(the driven hinges' indices, Q (2n, 2n), R (m, m)): Bryson's rule for n hinges, the
    ``passive`` ones (indices) without an input."""
    active = [i for i in range(n) if i not in set(passive)]
    if not active:
        raise DefinitionError("`passive`: every hinge is passive; there is nothing to control")
    q = np.diag(np.r_[np.full(n, weights.angle**-2.0), np.full(n, weights.rate**-2.0)])
    r = np.eye(len(active)) * weights.torque**-2.0
    return active, q, r


def lqr_along(along: Linearisation, weights: LqrWeights, passive=()):
    """The periodic LQR of a linearised periodic plan with Bryson's weights (module
    docstring); passive hinges (indices) get no input. Returns (gains (K, n, 2n) with zero
    rows for passive hinges, P(0) (2n, 2n), Riccati steps run)."""
    n = along.states[0].shape[0] // 2
    active, q, r = weight_matrices(n, weights, passive)
    b_list = [None if b is None else b[:, active] for b in along.inputs]
    gains, cost, cycles = periodic_riccati(along.states, b_list, along.jump, q, r)
    full = np.zeros((len(along.times), n, 2 * n))
    full[:, active, :] = gains
    return full, cost, cycles


class PhaseLQR:
    """M = clip(M_ff(s) + K(s) (x_ref(s) - x), -limit, limit) with the gains of
    :func:`periodic_lqr`.

    limits : (n,) N m or None
        The drives' torque limits: the law is clipped to them (a saturated drive gives what
        it can; the clipped hinge's feedback is lost for that period, which the simulations
        measure).
    """

    def __init__(self, reference: GaitReference, gains: PeriodicGains, limits=None) -> None:
        self.reference = reference
        self.gains = gains
        self.limits = None if limits is None else np.asarray(limits, dtype=float)
        if self.limits is not None and (
            self.limits.shape != (reference.n,) or np.any(self.limits <= 0)
        ):
            raise DefinitionError(
                f"`limits`: {reference.n} positive torque limits (N m), got {limits!r}"
            )
        if np.any(np.diff(gains.phases) <= 0):
            raise DefinitionError("`gains`: their phases must increase along the step")

    def start_step(self, index: int, x: np.ndarray) -> None:
        pass

    def gain_at(self, s: float) -> np.ndarray:
        """K(s) (n, 2n): the gains interpolated at the phase s (held outside the step)."""
        return self._gain(s)[0]

    def _gain(self, s: float) -> tuple[np.ndarray, np.ndarray]:
        """K(s) and dK/ds (0 where s is clamped)."""
        grid = self.gains.phases
        table = self.gains.gains
        if s <= grid[0]:
            return table[0], np.zeros_like(table[0])
        if s >= grid[-1]:
            return table[-1], np.zeros_like(table[-1])
        k = int(np.searchsorted(grid, s, side="right") - 1)
        width = grid[k + 1] - grid[k]
        w = (s - grid[k]) / width
        return (1 - w) * table[k] + w * table[k + 1], (table[k + 1] - table[k]) / width

    def torques(self, t: float, x: np.ndarray, share: float = 1.0) -> np.ndarray:
        """M (n,) N m at state x; ``share``: the feedback's part, K(s) (x_ref(s) - x) times
        it (1: the law; 0: the feedforward alone, see :class:`SwitchedLQR`'s settle)."""
        reference = self.reference
        s = reference.phase(x[: reference.n])
        state, feedforward = reference.at_phase(s)
        gain, _ = self._gain(s)
        torques = feedforward + share * (gain @ (state - x))
        if self.limits is not None:
            torques = np.clip(torques, -self.limits, self.limits)
        return torques

    def jacobian(self, t: float, x: np.ndarray, share: float = 1.0) -> np.ndarray:
        """dM/dx (n, 2n) of :meth:`torques` (within a piece of the tables)."""
        reference = self.reference
        n = reference.n
        s = reference.phase(x[:n])
        state, feedforward = reference.at_phase(s)
        state_slope, torque_slope = reference.slopes_at_phase(s)
        gain, gain_slope = self._gain(s)
        along = torque_slope + share * (gain @ state_slope + gain_slope @ (state - x))
        jacobian = -share * gain
        jacobian[:, :n] += np.outer(along, reference.phase_gradient(x[:n]))
        if self.limits is not None:  # a saturated drive does not respond to the state
            # the law's torques from this phase's tables (not self.torques: the phase once)
            saturated = np.abs(feedforward + share * (gain @ (state - x))) >= self.limits
            jacobian[saturated] = 0.0
        return jacobian


#: On a compliant ground, the double support's feedback after the touchdown: none for this
#: long, s (about four of MuJoCo's contact time constants, 4 ms: the soft impact's bounces
#: are over), then linearly all of it over the ramp, s (:class:`SwitchedLQR`). Measured on the
#: default step with a 0.05 s double support in MuJoCo (examples/benchmarks/
#: double_support_mujoco.py): 5 to 30 ms walk 20 steps as planned and 10 % heavier; with the
#: feedback at once it falls in its first three steps.
SOFT_SETTLE = 0.015
SOFT_RAMP = 0.01
#: the rule as a file states it (the law's metadata, the joint-space controller's)
SOFT_TOUCHDOWN = (
    "on a compliant ground (a floor; the plan's impact is instantaneous) the double "
    f"support's feedback waits {1000 * SOFT_SETTLE:g} ms after the touchdown (its feedforward "
    "alone: the front foot bounces while the rates are still the swing's) and then comes in "
    f"linearly over {1000 * SOFT_RAMP:g} ms"
)


class SwitchedLQR:
    """The law of a step with a double support: one :class:`PhaseLQR` (or any phase-indexed
    controller, e.g. ``PhasePD``) per branch, the
    single support's from the step's start, the double support's from the heel strike (the
    simulation calls :meth:`touchdown`) to the lift-off. Each branch holds its own reference
    outside its phases: a strike that comes early starts the double support's law at its
    first row, one that comes late runs the single support's along its last slope.

    settle, ramp : s (>= 0; 0 and 0 by default, the plan's rigid ground)
        On a compliant ground (a floor, MuJoCo's soft contacts) the impact lasts
        milliseconds, and the front foot bounces through them while the joints' rates are
        still the swing's: the double support's feedback against the plan's post-impact
        rates would throw the foot back off. So its feedback waits ``settle`` s after the
        touchdown (the double support's feedforward alone), then comes in linearly over
        ``ramp`` s (:meth:`feedback_share`). The plan's impact is instantaneous: the
        product's simulation runs 0 and 0.
    """

    def __init__(self, single, double, settle: float = 0.0, ramp: float = 0.0) -> None:
        self.branches = (single, double)
        self.reference = single.reference
        self.limits = getattr(single, "limits", None)
        self.branch = 0
        self.settle = _duration("settle", settle)
        self.ramp = _duration("ramp", ramp)
        self.touched: float | None = None

    def start_step(self, index: int, x: np.ndarray) -> None:
        self.branch = 0
        self.touched = None

    def touchdown(self, t: float, x: np.ndarray) -> None:
        """The swing foot has landed at t (s, the step's clock): the double support's law
        from now on."""
        self.branch = 1
        self.touched = t

    def feedback_share(self, t: float) -> float:
        """The part of the branch's feedback applied at t: 1, but in the double support's
        first ``settle + ramp`` s (0 for ``settle`` s, then linear to 1)."""
        if self.branch == 0 or self.touched is None:
            return 1.0
        waited = t - self.touched - self.settle
        if waited < 0.0:
            return 0.0
        return 1.0 if waited >= self.ramp else waited / self.ramp

    def torques(self, t: float, x: np.ndarray) -> np.ndarray:
        share = self.feedback_share(t)
        law = self.branches[self.branch]
        return law.torques(t, x) if share == 1.0 else law.torques(t, x, share=share)

    def jacobian(self, t: float, x: np.ndarray) -> np.ndarray:
        share = self.feedback_share(t)
        law = self.branches[self.branch]
        return law.jacobian(t, x) if share == 1.0 else law.jacobian(t, x, share=share)

    def tracking(self, x) -> float:
        """The largest |psi - psi_ref| at the phase of x on the branch in force, rad."""
        return self.branches[self.branch].reference.tracking(x)


def _duration(field: str, value) -> float:
    number = check_real(field, value)
    if number < 0.0:
        raise DefinitionError(f"`{field}`: a duration >= 0 s, got {number!r}")
    return number


__all__ = [
    "ENDS",
    "SOFT_RAMP",
    "SOFT_SETTLE",
    "SOFT_TOUCHDOWN",
    "Linearisation",
    "LqrWeights",
    "PeriodicGains",
    "PhaseLQR",
    "SwitchedLQR",
    "double_support_lqr",
    "lift_off_saltation",
    "linearise_along",
    "linearise_double_support",
    "lqr_along",
    "periodic_lqr",
    "periodic_riccati",
    "saltation",
]
