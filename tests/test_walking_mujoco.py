"""The planned steps, their torques and their gains, run in MuJoCo (problems.control.mujoco):
an engine written by someone else, with soft contacts and feet, walks them closed loop and
lets them fall open loop."""

from __future__ import annotations

import numpy as np
import pytest

from model import presets
from problems import walking_step
from problems.control.feedback import design_feedback, disturbance_cases
from problems.control.mujoco import run_in_mujoco
from problems.control.simulation import Disturbances

pytest.importorskip("mujoco")

BIPEDS = {
    "six-link": lambda: walking_step(),
    "five-link": lambda: walking_step(presets.five_link_biped()),
    "six-link, passive ankle (a point foot)": lambda: walking_step(passive=("stance_shank",)),
}


@pytest.fixture(scope="module", params=list(BIPEDS))
def designed(request):
    step = BIPEDS[request.param]()
    gait = step.solve(progress=False)
    return request.param, step, design_feedback(gait, ground_mu=1.0)


def test_twenty_steps_closed_loop_none_open_loop(designed):
    name, step, feedback = designed
    closed = run_in_mujoco(feedback, steps=20)
    assert closed.walked == 20, (name, closed.fell)
    lengths = np.array([r.length for r in closed.steps])
    durations = np.array([r.duration for r in closed.steps])
    np.testing.assert_allclose(lengths, step.step_length, rtol=0.05)
    np.testing.assert_allclose(durations, step.step_time, rtol=0.05)
    assert max(r.peak_torque for r in closed.steps) <= max(step.torque_limit.values()) + 1e-9
    assert max(r.slip for r in closed.steps) < 0.01  # m: the stance foot holds
    opened = run_in_mujoco(feedback, steps=20, open_loop=True)
    assert opened.walked == 0 and opened.fell.startswith("step 0")
    # the point-foot MJCF has spheres, the others soles with ankles
    assert bool(closed.mjcf.feet) == (step.biped.stance_shank not in step.passive)


def test_a_push_too_hard_is_a_fall_with_its_reason():
    step = walking_step()
    feedback = design_feedback(step.solve(progress=False), ground_mu=1.0)
    run = run_in_mujoco(feedback, steps=4, disturbances=Disturbances(push=150.0, push_step=1))
    assert run.walked == 1
    assert run.fell.startswith("step 1, t = ")


@pytest.mark.slow  # the disturbance battery, each case walked in MuJoCo
def test_the_checks_disturbances_run_in_mujoco_too():
    step = walking_step()
    feedback = design_feedback(step.solve(progress=False), ground_mu=1.0)
    outcomes = {}
    for label, disturbances in disturbance_cases(feedback).items():
        run = run_in_mujoco(feedback, steps=6, disturbances=disturbances)
        outcomes[label] = run.walked
        if disturbances.torque_limit is not None:
            assert max(r.peak_torque for r in run.steps) <= disturbances.torque_limit + 1e-9
    # measured: MuJoCo's soft contacts and soled feet also take the 5 mm lower ground and the
    # start 0.02 rad off, which the product's rigid pinned-foot model does not. The 1 cm
    # lower ground is a coin toss: from starts 1e-7 rad apart (or plans 5e-8 N m apart) it
    # walks the 6 steps in about half the runs and falls in step 2 or 3 in the others
    # (examples/feedback.md, "Honest limits"); it always carries the first two steps.
    marginal = outcomes.pop("ground -1 cm")
    assert outcomes == dict.fromkeys(outcomes, 6), outcomes
    assert marginal >= 2
    # the changed ground is there: 5 cm higher, the swing foot stubs on it in step 0
    stub = run_in_mujoco(feedback, steps=2, disturbances=Disturbances(ground_rise=0.05))
    assert stub.walked == 0 and stub.fell.startswith("step 0")
