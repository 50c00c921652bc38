"""The joints' speed bound of a walking step (``speed_limit``, rad/s): a geared drive turns no
faster than its motor over its ratio.

Oracle: the robot's joint space (``problems.robot.joint_space``, its own reading of each
physical joint from the model's absolute angles: the hips as thigh against trunk) at every
exported sample; the bound binds where the unbounded plan is faster; the verification's
``joint speeds`` check fails a file whose settings claim a lower bound than its motion holds.
"""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import DefinitionError
from problems import footed_step_at, verify_gait, walking_step
from problems.robot.joint_space import joint_space

#: the bound, rad/s: below the unbounded default step's 8.5 rad/s (its swing hip's)
POINT_LIMIT = 6.0
#: on feet at 1.0 m/s: the unbounded plan whips its swing foot round at 60 rad/s
FEET_LIMIT = 10.0


def _peak_joint_speeds(trajectory) -> dict[str, float]:
    columns = joint_space(trajectory).columns
    return {name: float(np.max(np.abs(values))) for name, values in columns.items()
            if name.startswith("dq_")}  # fmt: skip


@pytest.fixture(scope="module")
def point_plan():
    return walking_step(speed_limit=POINT_LIMIT).solve(progress=False)


def test_every_joint_of_a_point_foot_step_keeps_its_speed_bound(point_plan):
    unbounded = _peak_joint_speeds(walking_step().solve(progress=False).exported())
    assert max(unbounded.values()) > POINT_LIMIT + 1.0  # the bound has work to do
    peaks = _peak_joint_speeds(point_plan.exported())
    assert max(peaks.values()) <= POINT_LIMIT + 1e-5
    assert max(peaks.values()) > POINT_LIMIT - 1e-3  # ... and binds
    assert point_plan.verified
    assert point_plan.cost > walking_step().solve(progress=False).cost  # a bound costs effort


def test_a_file_whose_motion_misses_its_speed_bound_fails_verification(point_plan):
    trajectory = point_plan.exported()
    settings = dict(trajectory.metadata["gait"])
    linkage = point_plan.problem.linkage
    assert verify_gait(trajectory, linkage, settings=settings).ok
    settings["speed_limit"] = 0.95 * POINT_LIMIT
    report = verify_gait(trajectory, linkage, settings=settings)
    assert [check.name for check in report.failures] == ["joint speeds"]
    assert report["joint speeds"].margin == pytest.approx(-0.05 * POINT_LIMIT, abs=1e-3)


def test_a_step_on_feet_no_longer_whips_its_swing_foot():
    gait = footed_step_at(1.0, speed_limit=FEET_LIMIT).solve(progress=False)
    assert gait.verified
    trajectory = gait.exported()
    assert trajectory.metadata["gait"]["speed_limit"] == FEET_LIMIT
    peaks = _peak_joint_speeds(trajectory)
    assert max(peaks.values()) <= FEET_LIMIT + 1e-5
    assert max(peaks["dq_right_ankle_rad_s"], peaks["dq_left_ankle_rad_s"]) > FEET_LIMIT - 1e-3


@pytest.mark.parametrize("value", [0.0, -1.0, float("nan")])
def test_a_bad_speed_bound_is_refused_by_name(value):
    with pytest.raises(DefinitionError, match="speed_limit"):
        walking_step(speed_limit=value)
    with pytest.raises(DefinitionError, match="speed_limit"):
        footed_step_at(1.0, speed_limit=value)
