"""The periodic LQR of a walking step (problems.control.lqr).

Oracles: scipy's discrete algebraic Riccati equation (a constant system is a periodic one);
the value function, x0' P(0) x0, against the cost summed along the linear closed loop; the
saltation matrix against central differences of the strike found by the simulation; and the
closed loop's multipliers (problems.control.linearisation) against the linear model's.
"""

from __future__ import annotations

import numpy as np
import pytest
from reference.checks import central_jacobian
from scipy.linalg import solve_discrete_are

from problems import walking_step
from problems.control.linearisation import fixed_point
from problems.control.lqr import (
    LqrWeights,
    PhaseLQR,
    linearise_along,
    periodic_lqr,
    periodic_riccati,
    saltation,
)
from problems.control.simulation import Disturbances, Plant, locate_strike, simulate_walking
from problems.control.tracking import GaitReference, OpenLoop

GROUND_MU = 1.0


def _random_system(rng, nx=4, nu=2):
    return rng.normal(size=(nx, nx)) / np.sqrt(nx) * 1.3, rng.normal(size=(nx, nu))


def test_a_constant_system_gives_the_algebraic_riccati_solution():
    rng = np.random.default_rng(3)
    a, b = _random_system(rng)
    q, r = np.diag([1.0, 2.0, 3.0, 4.0]), np.diag([0.5, 2.0])
    gains, cost, _ = periodic_riccati([a] * 5, [b] * 5, np.eye(4), q, r)
    exact = solve_discrete_are(a, b, q, r)
    np.testing.assert_allclose(cost, exact, rtol=1e-8)
    np.testing.assert_allclose(
        gains[0], np.linalg.solve(r + b.T @ exact @ b, b.T @ exact @ a), rtol=1e-8
    )


def test_the_cost_to_go_is_the_summed_cost_of_the_periodic_closed_loop():
    rng = np.random.default_rng(4)
    systems = [_random_system(rng) for _ in range(7)]
    jump = rng.normal(size=(4, 4))  # an impact: a jump between the periods
    q, r = np.eye(4), 0.3 * np.eye(2)
    gains, cost, _ = periodic_riccati([s[0] for s in systems], [s[1] for s in systems], jump, q, r)
    x0 = rng.normal(size=4)
    x, total = x0.copy(), 0.0
    for _ in range(200):  # periods: the closed loop is stable, the sum converges
        for (a, b), gain in zip(systems, gains, strict=True):
            u = -gain @ x
            total += x @ q @ x + u @ r @ u
            x = a @ x + b @ u
        x = jump @ x
    assert total == pytest.approx(x0 @ cost @ x0, rel=1e-9)


@pytest.fixture(scope="module")
def plan():
    step = walking_step()
    gait = step.solve(progress=False)
    reference = GaitReference.of(gait)
    plant = Plant(step.linkage, mu=GROUND_MU)
    return step, reference, plant, periodic_lqr(plant, reference)


def test_the_saltation_matrix_is_the_strikes_central_difference(plan):
    _, reference, plant, _ = plan
    # from a state 2 ms before the planned strike, its torques held, to the next step's start
    x_before, torques = reference.at_time(reference.duration - 0.002)

    def strike(x):
        tau, x_minus = locate_strike(plant, x, torques, 0.004, 0j, lambda _: 0.0)
        return np.asarray(plant.step_map(x_minus)).ravel(), tau, x_minus

    _, tau, x_minus = strike(x_before)
    assert 0.0 < tau < 0.004
    differences = central_jacobian(lambda x: strike(x)[0], x_before, 1e-7)
    # exact: the flow to the strike instant (AD of the RK4), then the saltation matrix
    flow = np.asarray(plant.advance_jacobian(x_before, torques, tau)[0])
    exact = saltation(plant, x_minus, torques) @ flow
    np.testing.assert_allclose(exact, differences, rtol=0, atol=1e-6 * np.abs(exact).max())
    # without the strike instant's shift (dDelta/dx alone) it is wrong: the shift matters
    plain = np.asarray(plant.step_map_jacobian(x_minus)) @ flow
    assert np.abs(plain - differences).max() > 1e-2 * np.abs(exact).max()


def test_lqr_makes_the_gait_stable_with_margin_and_walks(plan):
    step, reference, plant, gains = plan
    controller = PhaseLQR(reference, gains)
    options = {"step_time": step.step_time, "step_length": step.step_length}
    found = fixed_point(plant, controller, reference.states[0], **options)
    # the nonlinear closed loop's multipliers, and the linear model's (the monodromy matrix
    # of the linearisation along the plan under the time-indexed gains)
    assert found.spectral_radius < 0.1
    n = plant.n
    monodromy = np.eye(2 * n)
    for t, gain in zip(gains.times, gains.gains, strict=True):
        x, torques = reference.at_time(t)
        h = min(gains.times[1] - gains.times[0], reference.duration - t)
        dx, dm, _ = (np.asarray(v) for v in plant.advance_jacobian(x, torques, h))
        monodromy = (dx - dm @ gain) @ monodromy
    x_end, torques_end = reference.at_time(reference.duration)
    monodromy = saltation(plant, x_end, torques_end) @ monodromy
    linear = np.abs(np.linalg.eigvals(monodromy)).max()
    # not equal: the time-indexed linear model does not see that the phase re-times the
    # reference (0.053 here against the phase-indexed loop's 0.022); both far inside 1
    assert linear < 0.1
    # twenty steps on the plan's length and time, within its torque limit (a start error
    # shrinks by the multipliers' 0.02 a step: after twenty it is far below round-off)
    run = simulate_walking(
        reference.states[0], controller, linkage=step.linkage, steps=20, mu=GROUND_MU,
        reference=reference, **options,
    )  # fmt: skip
    assert run.walked == 20, run.fell
    np.testing.assert_allclose([r.duration for r in run.steps], step.step_time, rtol=1e-3)
    np.testing.assert_allclose([r.length for r in run.steps], step.step_length, rtol=1e-3)
    assert max(r.peak_torque for r in run.steps) <= 150.0
    # a body 10 % heavier or lighter than the plan's: still walks, steps within 1 %
    for scale in (0.9, 1.1):
        run = simulate_walking(
            reference.states[0], controller, linkage=step.linkage, steps=20, mu=GROUND_MU,
            disturbances=Disturbances(mass_scale=scale), **options,
        )  # fmt: skip
        assert run.walked == 20, (scale, run.fell)
        np.testing.assert_allclose([r.duration for r in run.steps], step.step_time, rtol=0.01)


def test_weights_are_checked_and_change_the_gains(plan):
    _, reference, plant, gains = plan
    with pytest.raises(Exception, match=r"`angle`: must be > 0 rad"):
        LqrWeights(angle=0.0)
    softer = periodic_lqr(plant, reference, weights=LqrWeights(torque=100.0))
    assert np.abs(softer.gains).max() > np.abs(gains.gains).max()  # cheaper torque, more gain
    ankle_free = periodic_lqr(plant, reference, passive=(0,))
    assert np.all(ankle_free.gains[:, 0, :] == 0.0)


def test_the_open_loop_is_violently_unstable_along_the_plan(plan):
    step, reference, plant, _ = plan
    along = linearise_along(plant, reference, 1e-3)
    assert np.abs(along.open_loop_multipliers[0]) > 1e3
    # the flow's Jacobian over the first 50 ms is the divergence of two simulated open-loop
    # runs (which leave the plan by the hold's bias, 1e-3 rad by then: a few % apart)
    start = reference.states[0]
    offset = np.random.default_rng(0).normal(size=start.size) * 1e-7
    options = {"linkage": step.linkage, "step_time": step.step_time, "steps": 1, "mu": 1.0,
               "step_length": step.step_length, "check_contacts": False}  # fmt: skip
    base = simulate_walking(start, OpenLoop(reference), **options)
    moved = simulate_walking(start + offset, OpenLoop(reference), **options)
    flow = np.eye(start.size)
    for a in along.states[:50]:
        flow = a @ flow
    difference = moved.states[50] - base.states[50]
    assert np.abs(difference - flow @ offset).max() < 0.03 * np.abs(difference).max()
    # and the monodromy is that flow through the step, then the strike
    full = np.eye(start.size)
    for a in along.states:
        full = a @ full
    np.testing.assert_allclose(along.monodromy, along.jump @ full, rtol=1e-12)
