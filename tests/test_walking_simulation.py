"""Many steps simulated (problems.control.simulation) under the controllers of
problems.control.tracking.

Oracles: scipy's adaptive integrator and energy conservation for the plant's RK4; the angular
momentum about the stance foot, which a push changes by r x P; the angular momentum about the
landing foot, which the heel strike conserves; the plan itself, which an open-loop replay
follows at first order in the control period (a zero-order hold) until the orbit's
instability takes it away.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from model import DefinitionError, presets
from problems import walking_step
from problems.control.simulation import Disturbances, Plant, simulate_walking
from problems.control.tracking import GaitReference, OpenLoop, PhasePD

SIX = presets.six_link_anthropoid()
#: the ground's friction in these runs: the plan (mu = 0.8) runs along its cone's edge right
#: after heel strike, so any feedback needs a ground with a little more
GROUND_MU = 1.0


@pytest.fixture(scope="module")
def plan():
    step = walking_step()
    gait = step.solve(progress=False)
    return step, gait, GaitReference.of(gait)


def _run(plan, controller, steps=1, **options):
    step, _, reference = plan
    options.setdefault("mu", GROUND_MU)
    return simulate_walking(
        reference.states[0],
        controller,
        linkage=step.linkage,
        step_time=step.step_time,
        step_length=step.step_length,
        steps=steps,
        reference=reference,
        **options,
    )


def _pd(plan, kp=1000.0, kd=60.0):
    step, _, reference = plan
    return PhasePD(reference, step.linkage.parents, kp, kd)


def _angular_momentum(dynamics, psi, dpsi, about=0j):
    """sum_i m_i (w_i - p) x dw_i + J_i dpsi_i, kg m^2/s (p at rest)."""
    w = dynamics.com_positions(psi)
    dw = dynamics.com_velocities(psi, dpsi)
    links = dynamics.linkage.links
    return sum(
        link.mass * (np.conj(w[i] - about) * dw[i]).imag + link.inertia * dpsi[i]
        for i, link in enumerate(links)
    )


def test_the_plants_rk4_is_fourth_order_and_keeps_the_energy():
    plant = Plant(SIX, mu=GROUND_MU, substeps=1)
    n = SIX.n
    x0 = np.r_[1.4, 1.7, -1.6, -1.9, 1.5, 1.6, 0.5, -0.3, 1.0, -2.0, 0.4, 0.2]
    zero = np.zeros(n)

    def rate(_, x):
        return np.r_[x[n:], plant.dynamics.forward_dynamics(x[:n], x[n:], zero)]

    duration = 0.2
    exact = solve_ivp(rate, (0, duration), x0, method="DOP853", rtol=1e-13, atol=1e-13).y[:, -1]
    errors = []
    for steps in (50, 100, 200):
        x = x0.copy()
        for _ in range(steps):
            x = np.asarray(plant.advance(x, zero, duration / steps)).ravel()
        errors.append(np.abs(x - exact).max())
        kinetic, potential = plant.dynamics.energy(x[:n], x[n:])
        k0, p0 = plant.dynamics.energy(x0[:n], x0[n:])
        assert abs(kinetic + potential - k0 - p0) < 1e3 * errors[-1] + 1e-9
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 3.7) & (orders < 4.3)), (errors, orders)


def test_a_push_changes_the_angular_momentum_about_the_stance_foot_by_r_cross_p():
    plant = Plant(SIX, mu=GROUND_MU)
    x = np.r_[1.4, 1.7, -1.6, -1.9, 1.5, 1.6, 0.5, -0.3, 1.0, -2.0, 0.4, 0.2]
    n = SIX.n
    push = 12.0 - 3.0j  # N s
    after = plant.push_velocity(x, push, "torso")
    torso = plant.dynamics.com_positions(x[:n])[SIX.index("torso")]
    change = _angular_momentum(plant.dynamics, x[:n], after) - _angular_momentum(
        plant.dynamics, x[:n], x[n:]
    )
    assert change == pytest.approx((np.conj(torso) * push).imag, rel=1e-12)
    # and the torso's centre of mass alone takes the velocity change an impulse on it gives:
    # the other links' generalised forces are zero (J^T P has the torso's column only)
    assert not np.allclose(after, x[n:])


def test_open_loop_follows_the_plan_at_first_order_in_the_hold_then_falls(plan):
    _, _, reference = plan
    errors = []
    for rate in (2000.0, 4000.0, 8000.0):
        run = _run(plan, OpenLoop(reference), control_rate_hz=rate)
        k = np.searchsorted(run.time, 0.1)
        planned, _ = reference.at_time(run.time[k])
        errors.append(np.abs(run.states[k, : SIX.n] - planned[: SIX.n]).max())
        # the default gait's single support is unstable: open loop it falls within a step
        assert run.walked == 0 and run.fell is not None
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    assert np.all((ratios > 1.7) & (ratios < 2.3)), (errors, ratios)


def test_heel_strikes_land_on_the_ground_and_keep_the_angular_momentum_about_the_foot(plan):
    step, _, _ = plan
    run = _run(plan, _pd(plan), steps=3)
    assert run.walked == 3, run.fell
    n = SIX.n
    dynamics = step.dynamics
    swapped = presets.six_link_anthropoid()  # the leg swap maps the six-link onto itself
    assert step.biped.swap.new.names == swapped.names
    starts = [np.flatnonzero(run.step == k)[0] for k in (1, 2)]
    for record, first in zip(run.steps[:2], starts, strict=True):
        before = record.before
        foot = complex(step.foot.position(before[:n]))
        assert abs(foot.imag) < 1e-11  # located to the ground
        assert record.length == pytest.approx(foot.real, abs=0)
        after = run.states[first]
        momentum_before = _angular_momentum(dynamics, before[:n], before[n:], about=foot)
        momentum_after = _angular_momentum(dynamics, after[:n], after[n:])
        assert momentum_after == pytest.approx(momentum_before, rel=1e-11)
        assert record.strike.imag < 0  # coming down
    np.testing.assert_allclose(np.diff(run.footholds).real, [r.length for r in run.steps])


def test_phase_indexed_pd_walks_twenty_steps_on_the_plan(plan):
    step, _, _ = plan
    run = _run(plan, _pd(plan), steps=20)
    assert run.walked == 20, run.fell
    durations = np.array([r.duration for r in run.steps])
    lengths = np.array([r.length for r in run.steps])
    np.testing.assert_allclose(durations, step.step_time, rtol=0.01)
    np.testing.assert_allclose(lengths, step.step_length, rtol=0.01)
    assert max(r.peak_torque for r in run.steps) <= 150.0
    assert max(r.tracking for r in run.steps) < 0.01  # rad
    # the samples run on one clock across the steps
    assert run.time[-1] == pytest.approx(sum(durations), abs=2e-3)


def test_a_runs_world_motion_stands_each_step_on_its_foothold(plan, tmp_path):
    step, _, _ = plan
    run = _run(plan, _pd(plan), steps=3)
    assert run.walked == 3, run.fell
    motion = run.world(step.dynamics, rate_hz=50.0)
    stance, swing = step.biped.stance_shank, step.biped.swing_shank
    even = motion.step % 2 == 0
    # a body keeps its first step's name and ends (the stance shank from its foot, the swing
    # shank to its foot); each foot stands on the step's foothold while its leg is the stance
    # leg (the legs swap at every heel strike)
    np.testing.assert_allclose(
        motion.segments[stance][even, 0], motion.footholds[motion.step[even]], atol=1e-12
    )
    np.testing.assert_allclose(
        motion.segments[swing][~even, 1], motion.footholds[motion.step[~even]], atol=1e-12
    )
    # the footholds are where the simulation's swing feet landed
    np.testing.assert_allclose(
        np.diff(motion.footholds.real), [r.length for r in run.steps], rtol=1e-12
    )
    # the bodies are whole: every link keeps its length in the world
    for name in step.linkage.names:
        length = np.abs(motion.segments[name][:, 1] - motion.segments[name][:, 0])
        assert np.ptp(length) < 1e-12
    assert motion.time[-1] == run.time[-1] and np.all(np.diff(motion.time) > 0)
    from problems.walking.plots import animate_walk

    path = animate_walk(motion, tmp_path / "run.gif", fps=10.0, caption="3 steps; ", window=1.0)
    assert path.read_bytes()[:6] == b"GIF89a"
    with pytest.raises(DefinitionError, match=r"`window`: must be > 0"):
        animate_walk(motion, tmp_path / "bad.gif", window=0.0)
    with pytest.raises(DefinitionError, match=r"`rate_hz`: must be > 0"):
        run.world(step.dynamics, rate_hz=0.0)


def test_disturbances_are_applied(plan):
    nominal = _run(plan, _pd(plan), steps=2)
    # the ground 5 mm higher from the first new foothold on: that heel strike comes early
    raised = _run(plan, _pd(plan), steps=1, disturbances=Disturbances(ground_rise=0.005))
    assert raised.steps[0].duration < nominal.steps[0].duration - 0.01
    assert raised.footholds[1].imag == pytest.approx(0.005, abs=1e-11)
    # a torque limit below the plan's peak saturates every command
    saturated = _run(plan, _pd(plan), steps=1, disturbances=Disturbances(torque_limit=30.0))
    assert np.abs(saturated.torques).max() <= 30.0 < np.abs(nominal.torques).max()
    # a hard push on the torso in the first step ends the walk, and says how
    pushed = _run(plan, _pd(plan), steps=2, disturbances=Disturbances(push=80.0, push_step=0))
    assert pushed.walked == 0
    assert pushed.fell.startswith("step 0, t = 0.250 s: the stance foot is pulled off")
    # a lighter body than planned (the controller keeps the plan's model) walks off the plan
    lighter = _run(plan, _pd(plan), steps=2, disturbances=Disturbances(mass_scale=0.9))
    assert lighter.walked == 2, lighter.fell
    assert lighter.steps[1].tracking > 2 * nominal.steps[1].tracking


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"push_at": 1.2}, r"`push_at`: a fraction of the step time in \[0, 1\), got 1.2"),
        ({"mass_scale": 0.0}, r"`mass_scale`: must be > 0"),
        ({"torque_limit": -1.0}, r"`torque_limit`: must be > 0 N m"),
        ({"push_step": -1}, r"`push_step`: must be >= 0"),
    ],
)
def test_bad_disturbances_are_named(kwargs, message):
    with pytest.raises(DefinitionError, match=message):
        Disturbances(**kwargs)


def test_a_reference_needs_a_hip_that_advances(plan):
    step, gait, _ = plan
    trajectory = gait.to_trajectory(200.0)
    # the step played backwards: the hip goes back
    fake = type("Samples", (), {})()
    fake.time, fake.psi = trajectory.time, trajectory.psi[::-1]
    fake.dpsi, fake.torques = -trajectory.dpsi[::-1], trajectory.torques[::-1]
    with pytest.raises(DefinitionError, match=r"`trajectory`: the hip does not move forward"):
        GaitReference(fake, step.dynamics, step.biped.stance_thigh)
    with pytest.raises(DefinitionError, match=r"`start`: the state \(psi, dpsi\) has 12 entries"):
        simulate_walking(
            np.zeros(3),
            OpenLoop(plan[2]),
            linkage=step.linkage,
            step_time=0.5,
            step_length=0.5,
            mu=1.0,
        )
