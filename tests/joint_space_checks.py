"""Checks of a joint-space view (problems.robot) shared by its tests."""

import numpy as np
import pytest


def assert_continuous_where_steps_meet(columns: dict, joins) -> None:
    """Each physical hip and knee angle of ``columns`` (a JointSpace's) at the first row of
    each step in ``joins`` where the rows before it extrapolate (within 0.01 rad): the legs
    swap in the model's labels at a heel strike, never in the robot."""
    t, step = columns["t_s"], columns["step"]
    for join in joins:
        after = np.flatnonzero(step == join)[0]
        for side in ("right", "left"):
            for joint in ("hip", "knee"):
                q = columns[f"q_{side}_{joint}_rad"]
                slope = (q[after - 1] - q[after - 2]) / (t[after - 1] - t[after - 2])
                predicted = q[after - 1] + slope * (t[after] - t[after - 1])
                assert q[after] == pytest.approx(predicted, abs=0.01), (join, side, joint)
