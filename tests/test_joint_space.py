"""problems.robot.joint_space: a plan in the robot's terms (joints per physical drive, left
and right, a stride).

Oracles: the joint angles against the model's own hinge positions in the world (the hip, knee
and ankle points and the foot's heel and ball, by an independent route through
``Dynamics.function("hinge_positions")``); the drives' power sum tau dq against the tree
hinges' power sum M_i (dpsi_i - dpsi_parent) at every sample; continuity of each physical
joint where the legs swap; the leg swap's matrix and offset against the plan's periodicity.
"""

import cmath
import math

import numpy as np
import pytest
from joint_space_checks import assert_continuous_where_steps_meet

from model import Dynamics
from problems import walking_step
from problems.gait.problem import joint_rates
from problems.robot import joint_space


@pytest.fixture(scope="module")
def point_plan():
    return walking_step().solve().to_trajectory(1000.0)


@pytest.fixture(scope="module")
def feet_plan(footed_gait):
    return footed_gait.to_trajectory(1000.0)


@pytest.fixture(params=["point", "feet"])
def plan(request, point_plan, feet_plan):
    return point_plan if request.param == "point" else feet_plan


def _linkage(trajectory):
    from model.linkage import Linkage

    return Linkage.from_parameters(trajectory.metadata["model"])


def _direction_from_down(vector: complex) -> float:
    """The angle of ``vector`` from straight down, toward +x positive, rad."""
    return cmath.phase(vector / -1j)


def test_joint_angles_from_the_world_points(plan):
    linkage = _linkage(plan)
    js = joint_space(plan)
    hinges = Dynamics(linkage).function("hinge_positions")
    names = linkage.names
    feet = "stance_foot" in names
    step0 = js.columns["step"] == 0
    for k in (5, 150, 320):
        x, y = (np.asarray(v).ravel() for v in hinges(plan.psi[k]))
        point = x + 1j * y  # H0..Hn: index 0 is H0, index i + 1 the end of link i
        end = {name: point[i + 1] for i, name in enumerate(names)}
        start = {name: point[linkage.parents[i] + 1] if linkage.parents[i] >= 0 else point[0]
                 for i, name in enumerate(names)}  # fmt: skip
        # the stance leg stands on its foot: hip at the thigh's end, knee at its start
        hip = end["stance_thigh"]
        stance_knee, swing_knee = start["stance_thigh"], end["swing_thigh"]
        stance_ankle, swing_ankle = start["stance_shank"], end["swing_shank"]
        trunk_up = end["torso"] - start["torso"]
        lean = -cmath.phase(trunk_up / 1j)  # forward (toward +x) positive
        row = np.flatnonzero(step0)[k]
        for side, knee, ankle in (("right", stance_knee, stance_ankle),
                                  ("left", swing_knee, swing_ankle)):  # fmt: skip
            thigh = _direction_from_down(knee - hip)
            shank = _direction_from_down(ankle - knee)
            assert js.columns[f"q_{side}_knee_rad"][row] == pytest.approx(thigh - shank, abs=1e-9)
            assert js.columns[f"q_{side}_hip_rad"][row] == pytest.approx(thigh + lean, abs=1e-9)
        assert js.columns["trunk_pitch_rad"][row] == pytest.approx(lean, abs=1e-9)
        if not feet:
            assert js.columns["q_right_ankle_rad"][row] == pytest.approx(
                -_direction_from_down(stance_ankle - stance_knee), abs=1e-9
            )  # the shank on a flat sole: the knee ahead of the ankle is dorsiflexion


def test_drive_power_equals_the_hinges_power(plan):
    linkage = _linkage(plan)
    js = joint_space(plan, steps=1)
    rates = joint_rates(linkage, np.asarray(plan.dpsi))
    torques = np.asarray(plan.torques)
    feet = "stance_foot" in linkage.names
    drives = range(1, linkage.n) if feet else range(linkage.n)  # a foot's root torque: ground
    hinge_power = sum(torques[:, i] * rates[:, i] for i in drives)
    power = np.zeros(js.time.size)
    for name, values in js.columns.items():
        if name.startswith("tau_"):
            joint = name[len("tau_") : -len("_N_m")]
            rate = js.columns[f"dq_{joint}_rad_s"]
            power += np.where(np.isnan(values), 0.0, values * np.nan_to_num(rate))
    np.testing.assert_allclose(power, hinge_power, rtol=1e-9, atol=1e-6)


def test_each_physical_joint_is_continuous_where_the_legs_swap(plan):
    js = joint_space(plan, steps=3)
    assert_continuous_where_steps_meet(js.columns, (1, 2))
    assert np.all(np.diff(js.time) > 0)


def test_the_leg_swap_in_the_sidecar_is_the_plans_periodicity(plan):
    swap = joint_space(plan).metadata["model_view"]["leg_swap"]
    P, offset = np.array(swap["P"]), np.array(swap["offset_rad"])
    psi_T, psi_0 = np.asarray(plan.psi[-1]), np.asarray(plan.psi[0])
    mapped = P @ psi_T + offset
    np.testing.assert_allclose(np.angle(np.exp(1j * (mapped - psi_0))), 0.0, atol=1e-6)
    if "stance_foot" in plan.link_names:  # toe-off is no impact: the rates map too
        np.testing.assert_allclose(P @ np.asarray(plan.dpsi[-1]), plan.dpsi[0], atol=1e-4)


def test_the_file_reads_with_numpy_and_names_never_mix_drives_and_ground(plan, tmp_path):
    js = joint_space(plan)
    path = js.save(tmp_path / "joints.csv")
    table = np.genfromtxt(path, delimiter=",", names=True)
    assert table.shape == js.time.shape
    np.testing.assert_allclose(table["t_s"], js.time)
    drives = [n for n in js.columns if n.startswith("tau_")]
    ground = [n for n in js.columns if n.startswith("ground_")]
    assert drives and ground and not set(drives) & set(ground)
    assert all(" " not in name for name in js.columns)
    meta = js.metadata
    assert meta["format"] == "anthropoid-planner joint space" and meta["version"] == 1
    assert set(meta["columns"]) == set(js.columns)
    for joint in meta["joints"]:
        values = js.columns[joint["torque"]]
        assert joint["peak_N_m"] == pytest.approx(np.nanmax(np.abs(values)))
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())


def test_bad_arguments_are_refused(point_plan):
    with pytest.raises(ValueError, match="steps"):
        joint_space(point_plan, steps=0)
    with pytest.raises(ValueError, match="sides"):
        joint_space(point_plan, sides=("left", "left"))
    with pytest.raises(ValueError, match=r"sidecar|walking step"):
        joint_space(point_plan.with_metadata(gait=None))
    assert math.isfinite(joint_space(point_plan, sides=("l", "r")).time[-1])
