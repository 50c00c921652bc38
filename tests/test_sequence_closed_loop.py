"""problems.library.closed_loop and .mujoco_sequence: a walk from standing to standing under
a finite-horizon LQR, in the product's simulation and in MuJoCo.

Oracles: the finite-horizon gains of the periodic steps far from a transition against the
periodic LQR of that gait (its own recursion run to a fixed point: problems.control.feedback);
the file's columns against the law evaluated by the feedback object at perturbed states; the
walk in two simulators (the product's hybrid one, MuJoCo's soft contacts) completing and
standing, and falling without the gains.
"""

import dataclasses

import numpy as np
import pytest

from model import LinkageTrajectory
from planner.errors import DefinitionError
from planner.trajectory import Trajectory
from problems.control.feedback import design_feedback, gains_from
from problems.library import plan_sequence, verify_sequence
from problems.library.closed_loop import (
    LEAST_LOAD,
    SequenceDisturbances,
    design_sequence_feedback,
    simulate_sequence,
    with_sequence_gains,
)


@pytest.fixture(scope="module")
def walk():
    # 0.6 m/s: its start and stop take a step each (12 s); from 1.0 m/s one-step stops fail
    # their hold rounds first (65 s)
    sequence = plan_sequence([0, 0.6, 0], steps_at_speed=4)
    return sequence, design_sequence_feedback(sequence)


def test_the_gains_are_the_periodic_lqrs_far_from_a_transition(walk):
    sequence, feedback = walk
    periodic = design_feedback(sequence.gaits[0.6]).controller.gains.gains
    kinds = [step.kind for step in sequence.steps]
    gait_steps = [j for j, kind in enumerate(kinds) if kind == "gait"]
    scale = np.abs(periodic).max()
    first, last = gait_steps[0], gait_steps[-1]
    # the first periodic step has the whole gait ahead of it before the stop: its gains are
    # the periodic LQR's; the last one's know the stop that follows
    assert np.abs(feedback.gains[first] - periodic).max() / scale < 1e-8
    assert np.abs(feedback.gains[last] - periodic).max() / scale > 1e-4
    # transition steps have gains of their own length (their control instants)
    for j, step in enumerate(sequence.steps):
        assert feedback.gains[j].shape[0] == feedback.times[j].size
        assert feedback.times[j][-1] < step.gait.duration


def test_the_file_holds_the_law(walk, tmp_path):
    sequence, feedback = walk
    path = with_sequence_gains(feedback, sequence.trajectory()).save(tmp_path / "sequence.csv")
    back = LinkageTrajectory.of(Trajectory.load(path))
    assert verify_sequence(back, sequence.linkage).ok
    names = back.link_names
    n = len(names)
    gains = gains_from(back, names)
    steps = np.asarray(back.extras["step"][0]).astype(int)
    laws = [entry["law"]["indexed_by"] for entry in back.metadata["sequence"]["steps"]]
    assert "time" in laws and "phase" in laws  # the start's first step moves its hip back
    rng = np.random.default_rng(3)
    plain = dataclasses.replace(feedback, contact=None)  # the file's law without the model
    for j in range(len(sequence.steps)):
        for row in rng.choice(np.flatnonzero(steps == j)[:-2], 3, replace=False):
            x_row = np.r_[back.psi[row], back.dpsi[row]]
            # rates only: the phase (the hip's progress) is a function of the angles
            x = x_row + np.r_[np.zeros(n), rng.normal(0.0, 0.05, n)]
            from_file = back.torques[row] + gains[row] @ (x_row - x)
            local = back.time[row] - sequence.steps[j].start
            expected = plain.law(j, local, x)
            np.testing.assert_allclose(from_file, expected, atol=1e-6)


def test_the_walk_stands_at_the_end_in_the_products_simulation_and_falls_without_gains(walk):
    sequence, feedback = walk
    run = simulate_sequence(feedback)
    assert run.completed and run.stood, run.fell
    assert run.walked == len(sequence.steps)
    planned = [step.gait.problem.step_length for step in sequence.steps]
    np.testing.assert_allclose(run.lengths[:-1], planned[:-1], atol=0.03)
    pushed = simulate_sequence(feedback, SequenceDisturbances(push=10.0, push_step=2))
    assert pushed.completed and pushed.stood, pushed.fell
    open_loop = dataclasses.replace(feedback, gains=tuple(np.zeros_like(g) for g in feedback.gains))
    fell = simulate_sequence(open_loop)
    assert not fell.completed and fell.fell is not None and not fell.stood


def test_the_walk_in_mujoco_stands_at_the_end_and_falls_without_gains(walk):
    pytest.importorskip("mujoco")
    from problems.library.mujoco_sequence import run_sequence_in_mujoco

    _, feedback = walk
    run = run_sequence_in_mujoco(feedback)
    assert run.completed and run.stood, run.fell
    assert run.rest_speed < 0.05
    heavier = run_sequence_in_mujoco(feedback, SequenceDisturbances(mass_scale=1.1))
    assert heavier.completed and heavier.stood, heavier.fell
    open_loop = dataclasses.replace(feedback, gains=tuple(np.zeros_like(g) for g in feedback.gains))
    fell = run_sequence_in_mujoco(open_loop)
    assert not fell.completed and fell.fell is not None


def test_the_contact_aware_law_keeps_the_predicted_force_loaded_and_in_its_cone(walk):
    """The scaled torques against the ground force computed another way (the model's forward
    dynamics and ground reaction, not the plant's generated observation), and alpha the
    largest: where it is below 1 one contact row is at its bound."""
    sequence, feedback = walk
    plant = feedback.contact
    dynamics = sequence.steps[0].gait.problem.dynamics
    n = dynamics.n
    weight = plant.biped.total_mass * dynamics.linkage.gravity
    rng = np.random.default_rng(5)
    scaled = 0
    for j in (1, 2, len(sequence.steps) - 2):
        reference = feedback.references[j]
        for t in np.linspace(0.0, 0.9 * reference.duration, 12):
            x_ref, feedforward = reference.at_time(t)
            x = x_ref + np.r_[rng.normal(0, 0.03, n), rng.normal(0, 0.6, n)]
            torques = feedback.law(j, t, x)
            full = dataclasses.replace(feedback, contact=None).law(j, t, x)
            ddpsi = dynamics.forward_dynamics(x[:n], x[n:], torques)
            force = dynamics.ground_reaction(x[:n], x[n:], ddpsi)
            rows = [force.imag - LEAST_LOAD * weight, plant.mu * force.imag - abs(force.real)]
            ff = np.clip(feedforward, -feedback.limits, feedback.limits)
            ddpsi0 = dynamics.forward_dynamics(x[:n], x[n:], ff)
            f0 = dynamics.ground_reaction(x[:n], x[n:], ddpsi0)
            safe0 = f0.imag >= LEAST_LOAD * weight and plant.mu * f0.imag >= abs(f0.real)
            if not np.allclose(torques, full):
                scaled += 1
                if safe0:  # alpha the largest: a row at its bound
                    assert min(rows) == pytest.approx(0.0, abs=1e-6 * weight)
            if safe0:
                assert min(rows) >= -1e-6 * weight
    assert scaled > 0  # the perturbations reach the contact's limits somewhere


def test_bad_closed_loop_inputs_are_refused_by_name(walk):
    from problems.control.simulation import simulate_walking

    with pytest.raises(DefinitionError, match="`push_at`: a fraction in \\[0, 1\\)"):
        SequenceDisturbances(push=10.0, push_at=1.5)
    _, feedback = walk
    first = feedback.sequence.steps[0].gait
    with pytest.raises(DefinitionError, match="`stand`: the last step ends standing"):
        simulate_walking(first.solution.states[0], None, linkage=first.problem.linkage,
                         step_time=0.5, step_length=0.5, mu=1.0, stand=1.0,
                         lift_off=lambda x: -1.0)  # fmt: skip
