"""The step on feet in MuJoCo (problems.control.mujoco_feet): an engine written by someone
else decides every contact of the heels and balls; the plan's drives, with joint feedback
around it, walk it, and the plan's torques alone do not."""

from __future__ import annotations

import math

import numpy as np
import pytest

from model import presets, to_mjcf
from model.mjcf import contacts_at
from model.points import LinkPoint
from planner.errors import DefinitionError, DefinitionTypeError
from problems import footed_step, walking_step
from problems.control.feet_law import FeetLaw, hinge_gains, hinge_inertias
from problems.control.mujoco_feet import (
    feet_walker_mjcf,
    run_feet_in_mujoco,
    run_feet_steps_in_mujoco,
)
from problems.control.simulation import Disturbances

mujoco = pytest.importorskip("mujoco")

from test_mjcf import _full_mass_matrix as full_mass_matrix  # noqa: E402 - after the skip


@pytest.fixture(scope="module")
def gait(footed_gait):
    return footed_gait


def test_contact_spheres_sit_where_the_model_puts_its_points():
    """MuJoCo's forward kinematics of the heel and ball spheres against the model's own
    points (Dynamics.point), at random postures of the floating walker on feet."""
    linkage = presets.anthropoid_with_feet()
    points = presets.anthropoid_feet()
    mjcf = to_mjcf(linkage, base="floating", contacts=list(points.values()))
    model = mujoco.MjModel.from_xml_string(mjcf.xml)
    data = mujoco.MjData(model)
    from model import Dynamics

    dynamics = Dynamics(linkage)
    rng = np.random.default_rng(7)
    for _ in range(5):
        psi = rng.uniform(-math.pi, math.pi, linkage.n)
        base = rng.uniform(-1.0, 1.0, 2)
        data.qpos[:] = mjcf.qpos(psi, base)
        mujoco.mj_kinematics(model, data)
        for name, point in points.items():
            expected = complex(dynamics.point(point.link, point.along, point.lateral)
                               .position(psi)) + complex(*base)  # fmt: skip
            where = data.geom_xpos[model.geom(name).id]
            assert where[1] == pytest.approx(0.0, abs=1e-12)
            assert complex(where[0], where[2]) == pytest.approx(expected, abs=1e-12), name


def test_contacts_at_names_the_field_of_a_bad_point():
    linkage = presets.anthropoid_with_feet()
    with pytest.raises(DefinitionError, match=r"`contacts\[0\]`: no link named 'toe'"):
        contacts_at(linkage, [LinkPoint("toe", 0.5)])
    with pytest.raises(DefinitionTypeError, match=r"or a model.LinkPoint"):
        contacts_at(linkage, ["stance_foot"])
    (heel,) = contacts_at(linkage, [presets.anthropoid_feet()["stance_heel"]])
    assert heel.name == "stance_heel" and heel.lateral != 0.0  # off the foot's axis


def test_hinge_inertias_are_mujocos_joint_space_mass_matrix():
    """The relative-angle mass matrix's diagonal against MuJoCo's own (mj_fullM), whose hinge
    coordinates are the relative angles."""
    linkage = presets.anthropoid_with_feet()
    mjcf = to_mjcf(linkage, base="fixed")
    model = mujoco.MjModel.from_xml_string(mjcf.xml)
    data = mujoco.MjData(model)
    from model import Dynamics

    dynamics = Dynamics(linkage)
    psi = np.random.default_rng(3).uniform(-1.0, 1.0, linkage.n)
    data.qpos[:] = mjcf.qpos(psi)
    mujoco.mj_forward(model, data)
    full = full_mass_matrix(model, data)
    index = list(mjcf.hinge_index)
    np.testing.assert_allclose(hinge_inertias(dynamics, psi), np.diag(full)[index], rtol=1e-10)


def test_gains_are_capped_on_light_links_only():
    inertias = np.array([70.0, 2.0, 0.0125])
    kp, kd = hinge_gains(inertias, 1000.0, 30.0, 50.0)
    np.testing.assert_allclose(kp, [1000.0, 1000.0, 2500.0 * 0.0125])
    np.testing.assert_allclose(kd, [30.0, 30.0, 100.0 * 0.0125])
    assert kd[-1] * 1e-3 / inertias[-1] == pytest.approx(0.1)  # 2 bandwidth dt at 1 kHz
    np.testing.assert_allclose(hinge_gains(inertias, 1000.0, 30.0, math.inf)[1], 30.0)
    with pytest.raises(DefinitionError, match="`bandwidth`: rad/s > 0"):
        hinge_gains(inertias, 1000.0, 30.0, 0.0)


def test_the_step_on_feet_walks_in_mujoco_closed_loop_and_falls_open_loop(gait):
    step = gait.problem
    closed = run_feet_in_mujoco(gait, steps=20)
    assert closed.walked == 20, closed.fell
    lengths = np.array([r.length for r in closed.steps])
    durations = np.array([r.duration for r in closed.steps])
    np.testing.assert_allclose(lengths, step.step_length, rtol=0.06)
    np.testing.assert_allclose(durations, step.step_time, rtol=0.1)
    assert max(r.peak_torque for r in closed.steps) <= step.torque_limit + 1e-9
    assert max(r.slip for r in closed.steps) < 0.02  # m: the stance ball holds
    # the drives sit at their limit only briefly (at the heel strikes and leg swaps)
    periods = 1000.0 * durations.sum()
    assert 0 <= sum(r.saturated for r in closed.steps) < 0.03 * periods
    # the plan's torques alone: MuJoCo's soft ground and 1 kHz samples part it from the plan
    opened = run_feet_in_mujoco(gait, steps=20, open_loop=True)
    assert opened.walked <= 2 and opened.fell is not None


def test_the_walk_in_mujoco_drawn_where_mujoco_put_its_bodies(gait):
    """MujocoRun.world against MuJoCo's own kinematics of the recorded qpos: each body's
    frame (its link's start hinge) at the drawn segment's start, for every drawn instant."""
    step = gait.problem
    run = run_feet_in_mujoco(gait, steps=2)
    motion = run.world(step.dynamics, rate_hz=60.0, corners=step.corners)
    model = mujoco.MjModel.from_xml_string(run.mjcf.xml)
    data = mujoco.MjData(model)
    for k, t in enumerate(motion.time):
        data.qpos[:] = run.qpos[int(np.searchsorted(run.time, t))]
        mujoco.mj_kinematics(model, data)
        for name in step.linkage.names:
            x, _, y = data.xpos[model.body(name).id]
            assert motion.segments[name][k, 0] == pytest.approx(complex(x, y), abs=1e-12), name
    assert motion.step[0] == 0 and motion.step[-1] == 1  # steps counted from 0
    lengths = np.diff(motion.footholds.real)
    np.testing.assert_allclose(lengths, [r.length for r in run.steps], rtol=1e-12)


def test_a_push_too_hard_is_a_fall_with_its_reason(gait):
    run = run_feet_in_mujoco(gait, steps=4, disturbances=Disturbances(push=150.0, push_step=1))
    # 2 m/s on 70 kg at mid-step of the second step: down before the third ends
    assert run.walked in (1, 2)
    assert run.fell.startswith(f"step {run.walked}")


def test_bad_settings_of_the_law_and_the_walk_are_named(gait):
    with pytest.raises(DefinitionError, match="`kp`"):
        hinge_gains(np.ones(3), 0.0, 30.0, 50.0)
    with pytest.raises(DefinitionError, match="`kd`"):
        hinge_gains(np.ones(3), 1000.0, -1.0, 50.0)
    with pytest.raises(DefinitionError, match="`rate_hz`"):
        FeetLaw(gait, rate_hz=0.0)
    with pytest.raises(DefinitionError, match="`steps`"):
        run_feet_in_mujoco(gait, steps=0)
    with pytest.raises(DefinitionError, match="`contact_time_constant`"):
        run_feet_in_mujoco(gait, contact_time_constant=0.0)
    with pytest.raises(DefinitionError, match="`preload`"):
        run_feet_in_mujoco(gait, preload=-1e-3)
    run = run_feet_in_mujoco(gait, steps=1)
    with pytest.raises(DefinitionError, match="`rate_hz`"):
        run.world(gait.problem.dynamics, rate_hz=0.0)


def test_mujoco_on_feet_refuses_a_point_foot_step():
    with pytest.raises(DefinitionTypeError, match="`gait`: a solved step on feet"):
        run_feet_in_mujoco(walking_step().solve())
    # the walker's MJCF carries the plan's drives and four contacts
    step = footed_step()
    mjcf = feet_walker_mjcf(step)
    assert [c.name for c in mjcf.contacts] == list(step.points)
    assert mjcf.actuated == tuple(step.drives)


def test_steps_walked_one_law_each_hand_over_at_the_leg_swap(gait):
    """The same step three times, each with its own law (distinct objects of the same
    gains), walks exactly as the periodic walk of three steps: the handover at each leg swap
    starts the next law from its plan's start and changes nothing else."""
    periodic = run_feet_in_mujoco(gait, steps=3)
    laws = [FeetLaw(gait) for _ in range(3)]
    stepped = run_feet_steps_in_mujoco([gait] * 3, laws=laws)
    assert (stepped.walked, stepped.fell) == (3, None)
    np.testing.assert_array_equal(stepped.qpos, periodic.qpos)
    assert [s.length for s in stepped.steps] == [s.length for s in periodic.steps]


def test_steps_in_mujoco_refuse_what_they_cannot_walk(gait):
    with pytest.raises(DefinitionTypeError, match="solved steps on feet"):
        run_feet_steps_in_mujoco([])
    with pytest.raises(DefinitionTypeError, match="solved steps on feet"):
        run_feet_steps_in_mujoco([gait, "step"])
    with pytest.raises(DefinitionError, match="one per step, 2, got 1"):
        run_feet_steps_in_mujoco([gait, gait], laws=[FeetLaw(gait)])
