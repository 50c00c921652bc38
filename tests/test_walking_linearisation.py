"""The return map's exact Jacobian (problems.control.linearisation) against central
differences of the product's own hybrid simulation, Newton's quadratic convergence to the
closed loop's periodic gait, and the multipliers against the decay the simulation shows."""

from __future__ import annotations

import numpy as np
import pytest
from reference.checks import central_jacobian

from problems import walking_step
from problems.control.linearisation import (
    CONTRACTION,
    ReturnMap,
    fixed_point,
    newton_fixed_point,
    return_map,
)
from problems.control.simulation import Plant, simulate_walking
from problems.control.tracking import GaitReference, PhasePD

#: the reference's samples must not fall on the control instants: there the phase table's
#: linear pieces meet, the map has a kink, and a central difference straddles it (the exact
#: one-sided derivative is the map's own, but it is not what a difference measures)
REFERENCE_RATE_HZ = 777.0


@pytest.fixture(scope="module")
def closed_loop():
    step = walking_step()
    gait = step.solve(progress=False)
    reference = GaitReference.of(gait, rate_hz=REFERENCE_RATE_HZ)
    controller = PhasePD(reference, step.linkage.parents, kp=1000.0, kd=60.0)
    plant = Plant(step.linkage, mu=1.0)
    return step, reference, controller, plant


def _options(step):
    return {"step_time": step.step_time, "step_length": step.step_length}


def test_newton_converges_quadratically_to_the_closed_loops_gait(closed_loop):
    step, reference, controller, plant = closed_loop
    x = reference.states[0]
    residuals = []
    for _ in range(4):
        result = return_map(plant, controller, x, **_options(step))
        gap = result.end - x
        residuals.append(np.abs(gap).max())
        x = x - np.linalg.solve(result.jacobian - np.eye(x.size), gap)
    # each residual about the square of the last (scaled): the Jacobian is exact
    assert residuals[-1] < 1e-10
    assert residuals[2] < 10 * residuals[1] ** 2 / residuals[0] + 1e-12
    found = fixed_point(plant, controller, reference.states[0], **_options(step))
    assert np.abs(found.end - found.start).max() <= 1e-10
    assert found.duration == pytest.approx(step.step_time, rel=0.01)


def test_the_jacobian_is_the_simulations_central_difference(closed_loop):
    step, reference, controller, plant = closed_loop
    found = fixed_point(plant, controller, reference.states[0], **_options(step))

    def next_start(x):
        run = simulate_walking(
            x, controller, linkage=step.linkage, steps=1, mu=1.0, check_contacts=False,
            **_options(step),
        )  # fmt: skip
        return run.end

    differences = central_jacobian(next_start, found.start, 1e-7)
    scale = np.abs(found.jacobian).max()
    np.testing.assert_allclose(found.jacobian, differences, rtol=0, atol=1e-6 * scale)


def test_the_multipliers_say_how_fast_the_simulation_returns_to_the_gait(closed_loop):
    step, reference, controller, plant = closed_loop
    found = fixed_point(plant, controller, reference.states[0], **_options(step))
    radius = found.spectral_radius
    assert 0.3 < radius < 0.7  # stable with margin under these gains
    # one multiplier is zero: the section at the step's start removes the guard's direction
    assert np.abs(found.multipliers[-1]) < 1e-8
    # a small error decays by the largest multiplier per step (small: 1e-2 rad/s is already
    # outside the linear range, its ratios wander between 0.51 and 0.65)
    offset = np.zeros(found.start.size)
    offset[len(offset) // 2 :] = 1e-5  # rad/s on every joint rate
    run = simulate_walking(
        found.start + offset, controller, linkage=step.linkage, steps=8, mu=1.0,
        check_contacts=False, **_options(step),
    )  # fmt: skip
    starts = [run.states[np.flatnonzero(run.step == k)[0]] for k in range(1, 8)]
    errors = np.array([np.abs(s - found.start).max() for s in starts])
    ratios = errors[2:] / errors[1:-1]  # the other multipliers (< 0.03) gone after a step
    assert np.all(ratios == pytest.approx(radius, rel=0.02)), (ratios, radius)


def test_the_map_without_its_jacobian_is_the_same_map(closed_loop):
    step, reference, controller, plant = closed_loop
    x = reference.states[0] + 1e-4  # off the gait: a map that moves the state
    full = return_map(plant, controller, x, **_options(step))
    alone = return_map(plant, controller, x, jacobian=False, **_options(step))
    assert alone.jacobian is None and full.jacobian.shape == (x.size, x.size)
    np.testing.assert_array_equal(alone.end, full.end)
    assert alone.duration == full.duration


def _linear_map(multipliers, seed=3):
    """P(x) = A x + b with the given eigenvalues (A = V diag V^-1), its fixed point in closed
    form x* = (I - A)^-1 b, and call counters for the map with and without its Jacobian."""
    rng = np.random.default_rng(seed)
    n = len(multipliers)
    basis = rng.normal(size=(n, n)) + 3 * np.eye(n)
    matrix = basis @ np.diag(multipliers) @ np.linalg.inv(basis)
    offset = rng.normal(size=n)
    calls = {"mapping": 0, "value": 0}

    def mapping(x):
        calls["mapping"] += 1
        return ReturnMap(x.copy(), matrix @ x + offset, matrix, 1.0)

    def value(x):
        calls["value"] += 1
        return matrix @ x + offset

    return mapping, value, np.linalg.solve(np.eye(n) - matrix, offset), matrix, calls


def test_the_search_iterates_the_map_while_it_contracts_then_takes_one_jacobian():
    # multipliers like the walking step's LQR (below 0.1): x <- P(x) gains a factor 10 a
    # map, so the cheap maps do the search and the map with the Jacobian is taken once, at
    # the fixed point, where the multipliers are read
    mapping, value, exact, matrix, calls = _linear_map([0.08, -0.05, 0.02, 0.0])
    found = newton_fixed_point(mapping, np.zeros(4), 1e-10, value=value)
    assert calls["mapping"] == 1 and 3 <= calls["value"] <= 12, calls
    np.testing.assert_allclose(found.start, exact, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(found.jacobian, matrix)
    # without the cheap map, Newton's method on the exact Jacobian (here exact in one step)
    mapping, _, exact, _, calls = _linear_map([0.08, -0.05, 0.02, 0.0])
    newton = newton_fixed_point(mapping, np.zeros(4), 1e-10)
    assert calls["mapping"] == 2
    np.testing.assert_allclose(newton.start, exact, rtol=0, atol=1e-12)


@pytest.mark.parametrize("largest", [0.6, 0.99, 2.0, -1.5])
def test_a_slow_or_diverging_map_turns_to_newton(largest):
    # x <- P(x) contracts by less than CONTRACTION (or diverges): the substitution stops at
    # once and Newton's method finds the fixed point in its few steps
    assert abs(largest) > CONTRACTION
    mapping, value, exact, _, calls = _linear_map([largest, 0.1, 0.0])
    found = newton_fixed_point(mapping, np.zeros(3), 1e-10, value=value)
    np.testing.assert_allclose(found.start, exact, rtol=0, atol=1e-9)
    assert calls["value"] <= 2 and calls["mapping"] == 2, calls


def test_the_references_buffered_phase_is_the_hips_progress(closed_loop):
    # the phase and its gradient through the evaluation buffers against the checked model
    # evaluation of the hip point, and the gradient against a central difference
    _, reference, _, _ = closed_loop
    hip = reference._hip
    start, end = reference.hip_range
    for psi in reference.states[::97, : reference.n]:
        psi = psi + 0.01
        assert reference.phase(psi) == pytest.approx(
            (complex(hip.position(psi)).real - start) / (end - start), abs=1e-15
        )
        np.testing.assert_allclose(
            reference.phase_gradient(psi),
            central_jacobian(lambda p: np.array([reference.phase(p)]), psi, 1e-6)[0],
            rtol=1e-7,
            atol=1e-9,
        )
