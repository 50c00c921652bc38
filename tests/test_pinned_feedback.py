"""Feedback of the fixed-base periodic gait (problems.pinned.feedback).

Oracles: central differences of the simulated period map (the exact chain of Jacobians
against the simulation it differentiates); two open-loop runs' divergence against the plan's
linearised flow; the closed loop's return to its orbit in the product's RK4 and in MuJoCo (an
engine written by others, its own integrator); a drive that reads only the exported file.
"""

from __future__ import annotations

import numpy as np
import pytest
from reference.checks import central_jacobian

from model import LinkageTrajectory
from problems.control.tracking import TimedReference
from problems.pinned.feedback import (
    LAW,
    PinnedLQR,
    closed_loop_orbit,
    design_pinned_feedback,
    period_map,
    run_pinned_in_mujoco,
    simulate_periods,
)
from problems.pinned.gait import periodic_gait

RATE_HZ = 250.0  # a coarser controller than the default 1 kHz: the same code, 4x faster


@pytest.fixture(scope="module")
def designed():
    gait = periodic_gait(N=30).solve(progress=False)
    return gait, design_pinned_feedback(gait, control_rate_hz=RATE_HZ)


@pytest.fixture(scope="module")
def orbit(designed):
    return closed_loop_orbit(designed[1])


def test_the_control_period_divides_the_gait_period(designed):
    gait, feedback = designed
    controller = feedback.controller
    assert controller.count * controller.h == pytest.approx(gait.solution.T, rel=1e-14)
    assert feedback.control_rate_hz == pytest.approx(RATE_HZ)
    # the law's table is the plan at the control instants
    times = np.arange(controller.count + 1) * controller.h
    motion = gait.to_trajectory(1000.0).resample(times=times)
    np.testing.assert_allclose(feedback.reference.states[:, :6], motion.psi, atol=1e-12)
    # the gait's ends meet: the table is periodic
    np.testing.assert_allclose(
        feedback.reference.states[-1], feedback.reference.states[0], atol=1e-6
    )


def test_the_period_maps_jacobian_is_the_simulations_central_difference(designed, orbit):
    _, feedback = designed
    assert np.abs(orbit.end - orbit.start).max() < 1e-10
    difference = central_jacobian(
        lambda x: period_map(feedback.plant, feedback.controller, x, False).end,
        orbit.start,
        1e-6,
    )
    scale = np.abs(orbit.jacobian).max()
    assert np.abs(difference - orbit.jacobian).max() < 1e-6 * scale
    # stable with margin: a deviation shrinks by about 300 per period
    assert orbit.spectral_radius < 0.05


def test_the_open_loop_diverges_as_the_plans_linearisation_says(designed):
    _, feedback = designed
    along = feedback.along
    assert np.abs(feedback.open_loop_multipliers[0]) > 1e3
    plant, open_loop = feedback.plant, feedback.open_loop
    start = feedback.reference.states[0]
    offset = np.random.default_rng(1).normal(size=start.size) * 1e-7
    periods = 25  # 0.1 s
    base, moved = start.copy(), start + offset
    for k in range(periods):
        torques = open_loop.torques(k * open_loop.h, base)
        np.testing.assert_array_equal(torques, open_loop.torques(k * open_loop.h, moved))
        base = np.asarray(plant.advance(base, torques, open_loop.h)).ravel()
        moved = np.asarray(plant.advance(moved, torques, open_loop.h)).ravel()
    flow = np.eye(start.size)
    for a in along.states[:periods]:
        flow = a @ flow
    difference = moved - base
    # the runs leave the plan by the held torques' bias: the Jacobians differ by a few %
    assert np.abs(difference - flow @ offset).max() < 0.03 * np.abs(difference).max()
    np.testing.assert_array_equal(along.jump, np.eye(start.size))


def test_the_closed_loop_returns_to_its_orbit_and_the_open_loop_falls(designed, orbit):
    _, feedback = designed
    n = 6
    error = np.r_[np.full(n, 0.02), np.zeros(n)]
    closed = simulate_periods(feedback, periods=6, initial=error)
    np.testing.assert_allclose(closed.starts[-1], orbit.start, atol=1e-8)
    assert closed.peak_torque <= max(feedback.gait.problem.torque_limit.values()) + 1e-9
    opened = simulate_periods(feedback, periods=2, initial=error, closed=False)
    assert opened.deviation[-1] > 1.0
    heavier = simulate_periods(feedback, periods=6, mass_scale=1.1)
    assert heavier.deviation.max() < 5e-3
    # it settles on a periodic orbit of its own
    assert np.abs(heavier.starts[-1] - heavier.starts[-2]).max() < 1e-8


def test_the_file_carries_the_gains_and_a_drive_reading_it_holds_the_gait(
    designed, orbit, tmp_path
):
    gait, feedback = designed
    names = gait.problem.linkage.names
    path = tmp_path / "torques.csv"
    feedback.channels(gait.to_trajectory(RATE_HZ)).save(path)
    loaded = LinkageTrajectory.load(path)
    assert loaded.metadata["feedback"]["law"] == LAW
    states = loaded.metadata["feedback"]["state"]
    table = np.stack(
        [
            np.column_stack([loaded.extras[f"K_{hinge}__{state}"][0] for state in states])
            for hinge in names
        ],
        axis=1,
    )
    np.testing.assert_allclose(table[:-1], feedback.controller.gains, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(loaded.extras["phase"][0], loaded.time / gait.solution.T)
    assert loaded.extras[f"K_{names[0]}__dpsi_{names[1]}"][1] == "N m s/rad"
    drive = PinnedLQR(TimedReference(loaded), table[:-1], loaded.metadata["feedback"]["limit_N_m"])
    end = period_map(feedback.plant, drive, orbit.start, jacobian=False).end
    # the file's numbers are printed to about 1e-9: the same orbit to that
    assert np.abs(end - orbit.start).max() < 1e-7


def test_mujoco_holds_the_gait_under_the_gains_and_drops_it_without(designed):
    pytest.importorskip("mujoco")
    _, feedback = designed
    error = np.r_[np.full(6, 0.02), np.zeros(6)]
    closed = run_pinned_in_mujoco(feedback, periods=6, initial=error)
    # MuJoCo's implicit integrator settles on its own orbit, a fraction of a mrad off the plan
    assert closed.deviation[-1] < 2e-3
    assert np.abs(closed.starts[-1] - closed.starts[-2]).max() < 1e-6
    opened = run_pinned_in_mujoco(feedback, periods=2, initial=error, closed=False)
    assert opened.deviation[-1] > 1.0


def test_bad_inputs_are_named(designed):
    from model import DefinitionError
    from problems.control.feedback import with_gains

    gait, feedback = designed
    with pytest.raises(DefinitionError, match=r"`initial`: the error of the start state .* 12 "):
        simulate_periods(feedback, periods=1, initial=[0.02, 0.0])
    with pytest.raises(DefinitionError, match=r"`gains`: one per control period \(250\), got 3"):
        PinnedLQR(feedback.reference, feedback.controller.gains[:3])
    trajectory = gait.to_trajectory(RATE_HZ)
    with pytest.raises(DefinitionError, match=r"`gains`: \(samples, n, 2n\) = \(251, 6, 12\)"):
        with_gains(
            trajectory, gait.problem.linkage.names, trajectory.time, np.zeros((3, 6, 12)), {}
        )
    with pytest.raises(DefinitionError, match=r"`periods`: must be >= 1"):
        simulate_periods(feedback, periods=0)
