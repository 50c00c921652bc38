"""A walking step with a double support, closed loop: the closed chain's simulation, its
events (the heel strike with both feet held, the lift-off where the phase reaches 1), their
saltation matrices, the return map's Jacobian, the periodic LQR through both events, the
gains in the file.

Oracles: central differences of the product's own hybrid simulation (the return map, the
lift-off's saltation), the summed cost of a periodic closed loop with an event inside the
period (the Riccati recursion), the plan itself (the closed chain's motion under the plan's
torques), the held foot's position (it must not move).
"""

from __future__ import annotations

import numpy as np
import pytest
from reference.checks import central_jacobian

from model import LinkageTrajectory
from problems import walking_step
from problems.control.feedback import design_feedback
from problems.control.linearisation import fixed_point, return_map
from problems.control.lqr import (
    SOFT_RAMP,
    SOFT_SETTLE,
    SwitchedLQR,
    lift_off_saltation,
    linearise_double_support,
    periodic_riccati,
)
from problems.control.simulation import (
    Disturbances,
    Plant,
    locate_event,
    simulate_walking,
)
from problems.control.tracking import GaitReference, PhasePD
from problems.gait.verification import verify_gait
from problems.robot import joint_space

#: the plan's rear foot lifts carrying 5 % of the weight along its cone's edge: the closed
#: loop needs a ground with this much friction (measured: 1.0 slips under most disturbances)
GROUND_MU = 1.5
#: reference samples off the control instants (see test_walking_linearisation)
REFERENCE_RATE_HZ = 777.0


@pytest.fixture(scope="module")
def plan():
    step = walking_step(double_support=0.05)
    gait = step.solve(progress=False)
    return step, gait, Plant(step.linkage, mu=GROUND_MU)


def _options(step, double):
    n = step.linkage.n
    return {
        "linkage": step.linkage,
        "step_time": step.step_time,
        "step_length": step.step_length,
        "mu": GROUND_MU,
        "lift_off": lambda x: double.phase(x[:n]) - 1.0,
    }


def test_the_closed_chain_moves_as_planned_and_holds_the_front_foot(plan):
    _, gait, plant = plan
    single, double = GaitReference.branches(gait, rate_hz=1000.0)
    # the branches share the step's phase: the single support ends where the double begins
    assert single.phases[0] == pytest.approx(0.0, abs=1e-12)
    assert single.phases[-1] == pytest.approx(double.phases[0], abs=1e-12)
    assert double.phases[-1] == pytest.approx(1.0, abs=1e-12)
    # the plan's torques move the closed chain as the plan does: over 20 ms, the torques at
    # each quarter millisecond's midpoint (a held torque's bias would hide the check), to
    # 1.3e-6 rad (the single support's own check: 2e-7)
    n = plant.n
    fine = GaitReference.branches(gait, rate_hz=10000.0)[1]
    x = fine.at_time(0.0)[0]
    foot = complex(plant.foot.position(x[:n]))
    for k in range(80):
        x = np.asarray(plant.advance_double(x, fine.at_time((k + 0.5) * 2.5e-4)[1], 2.5e-4))
        x = x.ravel()
    assert np.abs(x[:n] - fine.at_time(0.02)[0][:n]).max() < 1e-5
    assert abs(complex(plant.foot.position(x[:n])) - foot) < 1e-9  # the held foot stays
    # the strike that begins it keeps the feet (no swap) and stops the front one
    x_minus = single.states[-1]
    x_plus = np.asarray(plant.strike_held(x_minus)).ravel()
    np.testing.assert_array_equal(x_plus[:n], x_minus[:n])
    assert abs(complex(plant.foot.velocity(x_plus[:n], x_plus[n:]))) < 1e-12
    np.testing.assert_allclose(x_plus, double.states[0], atol=1e-6)  # the plan's impact


def test_the_lift_off_saltation_is_the_events_central_difference(plan):
    _, gait, plant = plan
    _, double = GaitReference.branches(gait, rate_hz=1000.0)
    n = plant.n
    x_before, torques = double.at_time(double.duration - 0.002)

    def lift(x):
        tau, x_end = locate_event(
            plant.advance_double, x, torques, 0.004, lambda y: 1.0 - double.phase(y[:n])
        )
        return np.asarray(plant.swap_map(x_end)).ravel(), tau, x_end

    _, tau, x_end = lift(x_before)
    assert 0.0 < tau < 0.004
    differences = central_jacobian(lambda x: lift(x)[0], x_before, 1e-7)
    flow = np.asarray(plant.advance_double_jacobian(x_before, torques, tau)[0])
    exact = lift_off_saltation(plant, double, x_end, torques) @ flow
    np.testing.assert_allclose(exact, differences, rtol=0, atol=1e-6 * np.abs(exact).max())
    plain = plant.swap_jacobian @ flow  # without the event's shift: wrong
    assert np.abs(plain - differences).max() > 1e-2 * np.abs(exact).max()


def test_the_return_map_through_both_events_is_the_simulations_central_difference(plan):
    step, gait, plant = plan
    single, double = GaitReference.branches(gait, rate_hz=REFERENCE_RATE_HZ)
    parents = step.linkage.parents
    controller = SwitchedLQR(PhasePD(single, parents, 1000.0, 60.0),
                             PhasePD(double, parents, 1000.0, 60.0))  # fmt: skip
    found = fixed_point(plant, controller, single.states[0], step_time=step.step_time,
                        step_length=step.step_length, double_support=double)  # fmt: skip
    assert np.abs(found.end - found.start).max() <= 1e-10
    options = {**_options(step, double), "check_contacts": False}

    def next_start(x):
        return simulate_walking(x, controller, steps=1, **options).end

    np.testing.assert_allclose(next_start(found.start), found.end, atol=1e-12)
    differences = central_jacobian(next_start, found.start, 1e-7)
    scale = np.abs(found.jacobian).max()
    np.testing.assert_allclose(found.jacobian, differences, rtol=0, atol=1e-6 * scale)
    # the return map of one step is what the step's simulation does
    again = return_map(plant, controller, found.start, step_time=step.step_time,
                       step_length=step.step_length, double_support=double)  # fmt: skip
    np.testing.assert_array_equal(again.jacobian, found.jacobian)


def test_an_event_inside_the_period_costs_nothing_and_carries_the_cost_to_go():
    rng = np.random.default_rng(5)
    systems = [(rng.normal(size=(4, 4)) * 0.6, rng.normal(size=(4, 2))) for _ in range(6)]
    middle, end = rng.normal(size=(4, 4)), rng.normal(size=(4, 4))
    a_list = [s[0] for s in systems[:3]] + [middle] + [s[0] for s in systems[3:]]
    b_list = [s[1] for s in systems[:3]] + [None] + [s[1] for s in systems[3:]]
    q, r = np.eye(4), 0.5 * np.eye(2)
    gains, cost, _ = periodic_riccati(a_list, b_list, end, q, r)
    np.testing.assert_array_equal(gains[3], 0.0)
    x0 = rng.normal(size=4)
    x, total = x0.copy(), 0.0
    for _ in range(300):
        for a, b, gain in zip(a_list, b_list, gains, strict=True):
            if b is None:
                x = a @ x
                continue
            u = -gain @ x
            total += x @ q @ x + u @ r @ u
            x = a @ x + b @ u
        x = end @ x
    assert total == pytest.approx(x0 @ cost @ x0, rel=1e-9)


def test_the_periodic_lqr_walks_the_double_support_step_and_the_file_carries_both_laws(
    plan, tmp_path
):
    step, gait, plant = plan
    feedback = design_feedback(gait, ground_mu=GROUND_MU)
    double, _ = feedback.double
    along = linearise_double_support(plant, feedback.reference, double, 1e-3)
    assert np.abs(along.open_loop_multipliers[0]) > 1e3  # open loop: violently unstable
    found = fixed_point(plant, feedback.controller, feedback.reference.states[0],
                        step_time=step.step_time, step_length=step.step_length,
                        double_support=double)  # fmt: skip
    assert found.spectral_radius < 0.2
    options = feedback.simulation_options
    run = simulate_walking(feedback.reference.states[0], feedback.controller, steps=20, **options)
    assert run.walked == 20, run.fell
    np.testing.assert_allclose([r.duration for r in run.steps], step.step_time, rtol=2e-3)
    np.testing.assert_allclose([r.length for r in run.steps], step.step_length, rtol=2e-3)
    np.testing.assert_allclose([r.double_support for r in run.steps], 0.05, atol=2e-3)
    heavier = simulate_walking(feedback.reference.states[0], feedback.controller, steps=10,
                               disturbances=Disturbances(mass_scale=1.1), **options)  # fmt: skip
    assert heavier.walked == 10, heavier.fell
    # the file: a double_support column and the rows of the branch in force
    path = tmp_path / "torques.csv"
    feedback.channels(gait.to_trajectory(1000.0)).save(path)
    loaded = LinkageTrajectory.load(path)
    flag = np.asarray(loaded.extras["double_support"][0])
    assert flag[0] == 0.0 and flag[-1] == 1.0
    first = int(np.argmax(flag))
    assert loaded.time[first] == pytest.approx(step.single_support_time, abs=1e-9)
    names, states = step.linkage.names, loaded.metadata["feedback"]["state"]
    single_law, double_law = feedback.controller.branches
    for k in (first - 1, first, len(flag) - 1):
        law = double_law if flag[k] else single_law
        gain = law.gain_at(loaded.extras["phase"][0][k])
        row = [loaded.extras[f"K_{names[1]}__{state}"][0][k] for state in states]
        np.testing.assert_allclose(row, gain[1], rtol=1e-9, atol=1e-6)
    assert "double_support = 0" in loaded.metadata["feedback"]["branches"]
    # the soft touchdown's rule travels with the law, and into the robot's joint-space file
    law = loaded.metadata["feedback"]
    assert (law["touchdown_settle_s"], law["touchdown_ramp_s"]) == (SOFT_SETTLE, SOFT_RAMP)
    assert f"waits {1000 * SOFT_SETTLE:g} ms after the touchdown" in law["soft_touchdown"]
    controller = joint_space(loaded).metadata["controller"]
    assert controller["soft_touchdown"].startswith(law["soft_touchdown"])
    assert (controller["touchdown_settle_s"], controller["touchdown_ramp_s"]) == (
        SOFT_SETTLE,
        SOFT_RAMP,
    )


def test_the_double_support_walks_in_mujoco_once_its_feedback_waits_for_the_touchdown(plan):
    pytest.importorskip("mujoco")
    from problems.control.mujoco import run_in_mujoco

    step, gait, _ = plan
    feedback = design_feedback(gait, ground_mu=GROUND_MU)
    run = run_in_mujoco(feedback, steps=10)
    assert run.walked == 10, run.fell
    # MuJoCo's soft ground walks the plan's step: its time, length and double support
    np.testing.assert_allclose([r.duration for r in run.steps], step.step_time, rtol=0.05)
    np.testing.assert_allclose([r.length for r in run.steps], step.step_length, rtol=0.1)
    np.testing.assert_allclose([r.double_support for r in run.steps], step.double_support,
                               atol=0.015)  # fmt: skip
    assert max(r.peak_torque for r in run.steps) <= max(step.torque_limit.values()) + 1e-9
    # the law as on a rigid ground (its feedback at once): the stiff gains meet the bouncing
    # front foot with the swing's rates and throw it off (measured: ten times the tracking
    # error in the first step, 0.40 against 0.036 rad), and the walker falls in its third step
    at_once = run_in_mujoco(feedback, steps=10, touchdown_settle=0.0, touchdown_ramp=0.0)
    assert at_once.walked < 10 and at_once.fell is not None
    assert at_once.steps[0].tracking > 3.0 * run.steps[0].tracking


def test_the_settle_holds_the_double_supports_feedback_back_then_ramps_it_in(plan):
    step, gait, _ = plan
    feedback = design_feedback(gait, ground_mu=GROUND_MU)
    single, double = feedback.controller.branches
    law = SwitchedLQR(single, double, settle=0.015, ramp=0.01)
    n = step.linkage.n
    reference = double.reference
    x = reference.states[10] + np.r_[np.full(n, 2e-3), np.full(n, -0.02)]
    law.start_step(0, x)
    np.testing.assert_array_equal(law.torques(0.3, x), single.torques(0.3, x))
    law.touchdown(0.45, x)
    s = reference.phase(x[:n])
    state, feedforward = reference.at_phase(s)
    feedback_torques = double.gain_at(s) @ (state - x)
    limits = double.limits
    assert np.all(np.abs(feedforward + feedback_torques) < limits)  # no drive saturates here
    for t, share in ((0.45, 0.0), (0.464, 0.0), (0.47, 0.5), (0.4725, 0.75), (0.5, 1.0)):
        assert law.feedback_share(t) == pytest.approx(share, abs=1e-12)
        np.testing.assert_allclose(law.torques(t, x), feedforward + share * feedback_torques,
                                   rtol=1e-12, atol=1e-9)  # fmt: skip
    np.testing.assert_array_equal(law.torques(0.5, x), double.torques(0.5, x))
    # the Jacobian at half the feedback: central differences of the torques at that instant
    differences = central_jacobian(lambda y: law.torques(0.47, y), x, 1e-7)
    exact = law.jacobian(0.47, x)
    np.testing.assert_allclose(exact, differences, rtol=0, atol=1e-5 * np.abs(exact).max())
    assert np.abs(double.jacobian(0.47, x) - differences).max() > 0.1 * np.abs(exact).max()
    law.start_step(1, x)  # the next step: the single support's law, all of it
    assert law.feedback_share(0.47) == 1.0
    np.testing.assert_array_equal(law.torques(0.47, x), single.torques(0.47, x))
    from model import DefinitionError

    with pytest.raises(DefinitionError, match=r"`settle`: a duration >= 0 s, got -0\.01"):
        SwitchedLQR(single, double, settle=-0.01)


@pytest.fixture(scope="module")
def bounded_landing():
    """The same step with the landing foot's horizontal speed at heel strike within 1 m/s."""
    step = walking_step(double_support=0.05, landing_speed=1.0)
    return step, step.solve(progress=False)


def test_the_landing_speed_bounds_the_foot_at_the_strike_and_the_file_says_so(
    plan, bounded_landing
):
    step, gait = bounded_landing
    n = step.linkage.n
    plant = Plant(step.linkage, mu=GROUND_MU)  # its own foot kinematics, not the OCP's

    def landing_velocity(gait):
        single, _ = GaitReference.branches(gait, rate_hz=1000.0)
        x = single.states[-1]  # the state before the held strike
        return complex(plant.foot.velocity(x[:n], x[n:]))

    assert gait.verified
    velocity = landing_velocity(gait)
    assert abs(velocity.real) <= 1.0 + 1e-6 and velocity.imag <= -step.touchdown_speed + 1e-6
    # unbounded, the optimum swings the foot in far faster and lets the impact stop it
    assert landing_velocity(plan[1]).real > 5.0
    # the file carries the bound and the verification checks it: a tighter bound fails
    trajectory = gait.to_trajectory(1000.0)
    assert trajectory.metadata["gait"]["landing_speed"] == 1.0
    report = verify_gait(trajectory, step.linkage)
    (check,) = [c for c in report.checks if c.name == "landing speed"]
    assert check.passed and check.margin == pytest.approx(1.0 - abs(velocity.real), abs=1e-9)
    tighter = verify_gait(trajectory, step.linkage, settings={"landing_speed": 0.5})
    assert "landing speed" in [c.name for c in tighter.failures]
    from model import DefinitionError

    with pytest.raises(DefinitionError, match="`landing_speed`"):
        walking_step(double_support=0.05, landing_speed=0.0)


def test_a_bounded_landing_walks_a_lower_ground_in_mujoco(bounded_landing):
    pytest.importorskip("mujoco")
    from problems.control.mujoco import run_in_mujoco

    _, gait = bounded_landing
    feedback = design_feedback(gait, ground_mu=GROUND_MU)
    # measured: the unbounded plan falls in its first step on a ground 5 mm lower (its foot
    # swings on forward at 7 m/s past the planned strike) and its landing foot slides up to
    # 47 mm; bounded to 1 m/s it walks 20 steps there, sliding under 8 mm
    lower = run_in_mujoco(feedback, steps=10, disturbances=Disturbances(ground_rise=-0.005))
    assert lower.walked == 10, lower.fell
    assert max(r.slip for r in lower.steps) < 0.015


def test_an_unknown_end_of_a_linearised_stretch_is_named(plan):
    from model import DefinitionError
    from problems.control.lqr import linearise_along

    _, gait, plant = plan
    single, _ = GaitReference.branches(gait, rate_hz=1000.0)
    with pytest.raises(DefinitionError, match=r"`end`: one of \('strike', 'held strike'"):
        linearise_along(plant, single, 1e-3, end="touchdown")
