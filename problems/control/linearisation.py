"""The step-to-step (Poincare) return map of a simulated walking gait, linearised exactly, and
its Floquet multipliers.

The map P takes the state x0 (2n,) at a step's start (after the leg swap) to the next step's
start: the digital controller's periods x_{k+1} = F(x_k, M_k, h) with M_k = C(t_k, x_k) held
(:class:`problems.control.simulation.Plant`: generated RK4), until the swing foot reaches the
ground inside a period at tau; then the impact and the leg swap Delta. Its Jacobian is the
chain of the periods' Jacobians, all from the model's SX by CasADi's automatic
differentiation (no finite differences):

    S_{k+1} = (dF/dx + dF/dM dC/dx) S_k,           S_0 = I,
    D(x-)   = S_tau + dF/dtau dtau/dx0,  dtau/dx0 = -(dg/dx S_tau) / (dg/dx dF/dtau),
    DP      = dDelta/dx(x-) D(x-),

where g is the swing foot's height and S_tau the chain through the last, partial period: the
strike's instant moves with the state, and the second line is that correction (the discrete
form of the saltation matrix; the Poincare section is the start of the step, so no transverse
coordinates are needed: the map's domain is the full state and it keeps a zero multiplier,
the direction along the guard that the section removes).

A step with a double support chains two events: the heel strike with both feet held
(dx+/dx- of ``Plant.strike_held``, the strike's instant moved as above), the closed chain's
periods (``Plant.advance_double``), and the lift-off where the double support's phase reaches
1 (its instant moved by the state the same way, g = 1 - s(psi)), then the leg swap.

The eigenvalues of DP at the gait's fixed point are its Floquet multipliers: inside the unit
circle the gait is locally (orbitally) stable under that controller, outside it diverges by
the multiplier's modulus per step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.errors import check_positive
from problems.control.simulation import (
    STRIKE_AHEAD,
    Plant,
    locate_event,
    locate_strike,
)


@dataclass(frozen=True)
class ReturnMap:
    """P(x0) and its Jacobian.

    start (2n,): x0; end (2n,): P(x0); jacobian (2n, 2n): dP/dx0, or None where only P(x0)
    was asked for (:func:`return_map`'s ``jacobian=False``); duration s: the step's time to
    heel strike.
    """

    start: np.ndarray
    end: np.ndarray
    jacobian: np.ndarray | None
    duration: float

    @property
    def multipliers(self) -> np.ndarray:
        """The eigenvalues of dP/dx0, largest modulus first (complex)."""
        values = np.linalg.eigvals(self.jacobian)
        return values[np.argsort(-np.abs(values))]

    @property
    def spectral_radius(self) -> float:
        """The largest |multiplier|: < 1 stable, > 1 unstable."""
        return float(np.abs(self.multipliers[0]))


def return_map(
    plant: Plant,
    controller,
    start,
    *,
    step_time: float,
    step_length: float,
    control_rate_hz: float = 1000.0,
    max_step_factor: float = 2.0,
    double_support=None,
    jacobian: bool = True,
) -> ReturnMap:
    """P(start) and dP/dstart for ``controller`` (``torques(t, x)`` and ``jacobian(t, x)``,
    dM/dx (n, 2n)) on ``plant``, on flat ground, as :func:`simulate_walking` integrates it.

    double_support : None, or the double support's reference (a
        :class:`problems.control.tracking.GaitReference`): the heel strike holds both feet
        (``Plant.strike_held``; the controller's ``touchdown`` is called), the chain moves
        closed until that reference's phase reaches 1 (the guard's instant moved by the
        state, as the strike's), then the legs swap.
    jacobian : False for P(start) alone: no period's Jacobian is formed (the controller's
        ``jacobian`` is not called), about a fifth of the cost; the map's ``jacobian`` is None.

    Raises RuntimeError when no heel strike (or lift-off) comes within ``max_step_factor``
    step times.
    """
    period = 1.0 / check_positive("control_rate_hz", control_rate_hz, "Hz")
    n = plant.n
    x = np.asarray(start, dtype=float).copy()
    chained = bool(jacobian)
    sensitivity = np.eye(2 * n)
    controller.start_step(0, x)

    def ground(_):
        return 0.0

    def through_period(jacobian, x, torques):
        """The chain through one whole period (unchanged without the Jacobian)."""
        if not chained:
            return sensitivity
        dx, dm, _ = (np.asarray(v) for v in jacobian(x, torques, period))
        return (dx + dm @ feedback) @ sensitivity

    def through_event(jacobian, x, torques, tau, gradient):
        """The chain through the partial period to an event at tau whose guard has the
        gradient ``gradient`` (2n,): the event's instant moves with the state (None without
        the Jacobian)."""
        if not chained:
            return None
        dx, dm, dh = (np.asarray(v) for v in jacobian(x, torques, tau))
        through = (dx + dm @ feedback) @ sensitivity
        rate = dh.reshape(-1)
        return through + np.outer(rate, -(gradient @ through) / (gradient @ rate))

    t, double = 0.0, False
    while t <= max_step_factor * step_time:
        torques = np.asarray(controller.torques(t, x), dtype=float)
        if chained:
            feedback = np.asarray(controller.jacobian(t, x), dtype=float)
        if double:
            x_next = plant.advance_state(x, torques, period, double=True)
            if double_support.phase(x_next[:n]) >= 1.0:
                tau, x_end = locate_event(plant.advance_double, x, torques, period,
                                          lambda y: 1.0 - double_support.phase(y[:n]))  # fmt: skip
                gradient = np.r_[double_support.phase_gradient(x_end[:n]), np.zeros(n)]
                before = through_event(plant.advance_double_jacobian, x, torques, tau, gradient)
                end = np.asarray(plant.swap_map(x_end)).ravel()
                chain = None if before is None else plant.swap_jacobian @ before
                return ReturnMap(np.asarray(start, dtype=float), end, chain, t + tau)
            sensitivity = through_period(plant.advance_double_jacobian, x, torques)
            x = x_next
            t += period
            continue
        x_next = plant.advance_state(x, torques, period)
        foot = plant.swing_foot(x_next[:n])  # the stance foot at 0, the ground flat
        if foot.imag <= 0.0 and foot.real > STRIKE_AHEAD * step_length:
            tau, x_minus = locate_strike(plant, x, torques, period, 0j, ground)
            gradient = np.zeros(2 * n)
            gradient[:n] = plant.foot.jacobian(x_minus[:n], floating=False)[1]
            before = through_event(plant.advance_jacobian, x, torques, tau, gradient)
            if double_support is None:
                end = np.asarray(plant.step_map(x_minus)).ravel()
                chain = (
                    None
                    if before is None
                    else np.asarray(plant.step_map_jacobian(x_minus)) @ before
                )
                return ReturnMap(np.asarray(start, dtype=float), end, chain, t + tau)
            if chained:
                sensitivity = np.asarray(plant.strike_held_jacobian(x_minus)) @ before
            x = np.asarray(plant.strike_held(x_minus)).ravel()
            t += tau
            double = True
            controller.touchdown(t, x)
            continue
        sensitivity = through_period(plant.advance_jacobian, x, torques)
        x = x_next
        t += period
    raise RuntimeError(
        f"return_map: no {'lift-off' if double else 'heel strike'} within {max_step_factor:g} "
        f"x the step time ({max_step_factor * step_time:g} s): the controller does not "
        f"{'end the double support' if double else 'bring the foot down'}"
    )


def fixed_point(
    plant: Plant,
    controller,
    guess,
    *,
    step_time: float,
    step_length: float,
    control_rate_hz: float = 1000.0,
    tolerance: float = 1e-10,
    iterations: int = 10,
    double_support=None,
) -> ReturnMap:
    """The periodic gait of the closed loop, x* = P(x*), from ``guess`` (the plan's start):
    by :func:`newton_fixed_point`, first with maps without their Jacobian while the closed
    loop contracts, then Newton's method with the exact Jacobian. Returns the return map at
    x* with its Jacobian; raises RuntimeError naming the residual when it does not converge.
    """

    def mapping(x, jacobian=True):
        return return_map(
            plant,
            controller,
            x,
            step_time=step_time,
            step_length=step_length,
            control_rate_hz=control_rate_hz,
            double_support=double_support,
            jacobian=jacobian,
        )

    return newton_fixed_point(
        mapping, guess, tolerance, iterations, value=lambda x: mapping(x, jacobian=False).end
    )


#: successive substitution x <- P(x) goes on while each map shrinks the residual to at most
#: this part of the one before (a closed loop whose multipliers are this small); slower, the
#: search turns to Newton's method
CONTRACTION = 0.25


def newton_fixed_point(
    mapping, guess, tolerance: float = 1e-10, iterations: int = 10, value=None
) -> ReturnMap:
    """x* = P(x*) from ``guess``, ``mapping(x)`` returning a :class:`ReturnMap` (P(x) and
    its exact Jacobian). Returns the map at x* (with its Jacobian); raises RuntimeError
    naming the residual when it does not converge.

    value : None, or x -> P(x) alone (cheaper than ``mapping``: no Jacobian). Then the search
        first iterates x <- P(x) while each map contracts the residual |P(x) - x| by
        :data:`CONTRACTION` or more, and stops at the first x whose residual is within
        ``tolerance`` or is predicted to be (the last ratio squared: a linear contraction);
        ``mapping`` then confirms it, and gives the Jacobian there (or Newton's method goes
        on from it). A closed loop whose multipliers are about 0.07, as the walking step's
        LQR, needs three of these maps and one with its Jacobian instead of three with it.
    """
    x = np.asarray(guess, dtype=float).copy()
    residual = np.inf
    if value is not None:
        x = _substituted(value, x, tolerance, iterations)
    for _ in range(iterations):
        step = mapping(x)
        gap = step.end - x
        residual = float(np.abs(gap).max())
        if residual <= tolerance:
            return step
        x = x - np.linalg.solve(step.jacobian - np.eye(x.size), gap)
    raise RuntimeError(
        f"fixed_point: P(x) - x is still {residual:.2e} after {iterations} Newton steps "
        f"(tolerance {tolerance:g}); the closed loop may have no periodic orbit near the plan"
    )


def _substituted(value, x: np.ndarray, tolerance: float, iterations: int) -> np.ndarray:
    """The last x of x <- P(x) (:func:`newton_fixed_point`'s ``value``): within tolerance,
    predicted within it, or where the contraction fell below :data:`CONTRACTION`."""
    previous = None
    for _ in range(iterations):
        end = np.asarray(value(x), dtype=float)
        residual = float(np.abs(end - x).max())
        if residual <= tolerance:
            return x
        if previous is not None:
            ratio = residual / previous
            if ratio > CONTRACTION:
                return x
            if residual * ratio <= tolerance:
                return end
        previous, x = residual, end
    return x


__all__ = ["ReturnMap", "fixed_point", "newton_fixed_point", "return_map"]
