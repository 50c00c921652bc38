"""problems.robot.sequence_joints: a walk through speeds as the robot's drives see it
(joints.csv of ``walk --speeds``), and a URDF's robot walking through speeds.

Oracles: the joint angles from the world points of the model's hinges (each step's stance leg
the side the file says, the sides alternating), each physical joint continuous through every
heel strike (the legs swap in the model's labels, not in the robot), the drives' power equal
to the hinges' power in the model's view at every row, the rows the walk file's own.
"""

import cmath
import json

import numpy as np
import pytest
from joint_space_checks import assert_continuous_where_steps_meet

from model import Dynamics, Linkage
from model.linkage_trajectory import LinkageTrajectory
from planner.errors import DefinitionError
from problems.cli import main
from problems.gait.problem import joint_rates
from problems.robot.sequence_joints import sequence_joint_space

ROBOT = "examples/robots/biped.urdf"


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    """The command's folder and what it printed: a URDF's robot from standing to 0.6 m/s and
    back to standing."""
    import contextlib
    import io
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    folder = tmp_path_factory.mktemp("walk") / "robot"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = main(["walk", "--speeds", "0,0.6,0", "--steps-at-speed", "1", "--no-plots",
                       "--urdf", str(root / ROBOT), "--output-dir", str(folder)])  # fmt: skip
    assert status == 0, printed.getvalue()
    return folder, printed.getvalue()


@pytest.fixture(scope="module")
def files(walk):
    folder, _ = walk
    sequence = LinkageTrajectory.load(folder / "sequence.csv")
    return sequence, sequence_joint_space(sequence)


def test_the_command_writes_the_robots_walk_and_its_joints(walk):
    folder, printed = walk
    assert (folder / "joints.csv").is_file() and (folder / "joints.csv.meta.json").is_file()
    assert "joints.csv: the robot's view of the whole walk" in printed
    assert "the URDF's joint limits: every planned torque and angle within them" in printed
    meta = json.loads((folder / "joints.csv.meta.json").read_text())
    assert [s["kind"] for s in meta["sequence_steps"]] == ["start", "gait", "stop"]
    assert [s["stance"] for s in meta["sequence_steps"]] == ["right", "left", "right"]
    # each driven joint's URDF joint (this robot's point feet have no ankle joint)
    urdf = {j["name"]: j["urdf_joint"] for j in meta["joints"]}
    assert urdf["left_hip"] == "left_hip_pitch" and urdf["right_knee"] == "right_knee"
    assert urdf["neck"] == "neck_pitch" and urdf["left_ankle"] is None
    assert meta["controller"]["robot"]["urdf"].endswith("biped.urdf")
    # the file a controller reads with numpy alone: the header's names, one row per row of
    # the walk's file
    table = np.genfromtxt(folder / "joints.csv", delimiter=",", names=True)
    walk_rows = np.genfromtxt(folder / "sequence.csv", delimiter=",", names=True)
    assert table.size == walk_rows.size


def test_the_rows_are_the_walks_rows(files):
    sequence, view = files
    np.testing.assert_array_equal(view.time, np.asarray(sequence.time))
    np.testing.assert_array_equal(view.columns["step"], sequence.extras["step"][0])
    np.testing.assert_array_equal(view.columns["phase"], sequence.extras["phase"][0])
    even = view.columns["step"] % 2 == 0
    np.testing.assert_array_equal(view.columns["stance_right"], even.astype(float))
    # the stance foot is on the ground throughout its step
    assert np.all(view.columns["contact_right"][even] == 1.0)
    assert np.all(view.columns["contact_left"][~even] == 1.0)


def _direction_from_down(vector: complex) -> float:
    return cmath.phase(vector / -1j)


def test_joint_angles_from_the_world_points_in_every_step(files):
    sequence, view = files
    linkage = Linkage.from_parameters(sequence.metadata["model"])
    hinges = Dynamics(linkage).function("hinge_positions")
    names = linkage.names
    step = view.columns["step"]
    for j in range(int(step.max()) + 1):
        stance, swing = ("right", "left") if j % 2 == 0 else ("left", "right")
        for row in np.flatnonzero(step == j)[[1, -2]]:
            x, y = (np.asarray(v).ravel() for v in hinges(np.asarray(sequence.psi)[row]))
            point = x + 1j * y
            end = {name: point[i + 1] for i, name in enumerate(names)}
            start = {name: point[linkage.parents[i] + 1] if linkage.parents[i] >= 0
                     else point[0] for i, name in enumerate(names)}  # fmt: skip
            hip = end["stance_thigh"]
            lean = -cmath.phase((end["torso"] - start["torso"]) / 1j)
            for side, knee, ankle in ((stance, start["stance_thigh"], start["stance_shank"]),
                                      (swing, end["swing_thigh"], end["swing_shank"])):  # fmt: skip
                thigh = _direction_from_down(knee - hip)
                shank = _direction_from_down(ankle - knee)
                q_knee = view.columns[f"q_{side}_knee_rad"][row]
                assert q_knee == pytest.approx(thigh - shank, abs=1e-9), (j, side)
                q_hip = view.columns[f"q_{side}_hip_rad"][row]
                assert q_hip == pytest.approx(thigh + lean, abs=1e-9), (j, side)


def test_each_physical_joint_is_continuous_through_every_heel_strike(files):
    _, view = files
    assert_continuous_where_steps_meet(view.columns, range(1, int(view.columns["step"].max()) + 1))


def test_the_drives_power_is_the_hinges_power_at_every_row(files):
    sequence, view = files
    linkage = Linkage.from_parameters(sequence.metadata["model"])
    rates = joint_rates(linkage, np.asarray(sequence.dpsi))
    hinge_power = np.sum(np.asarray(sequence.torques) * rates, axis=1)
    power = np.zeros(view.time.size)
    for name, values in view.columns.items():
        if name.startswith("tau_"):
            rate = view.columns[f"dq_{name[len('tau_') : -len('_N_m')]}_rad_s"]
            power += np.where(np.isnan(values), 0.0, values * np.nan_to_num(rate))
    np.testing.assert_allclose(power, hinge_power, rtol=1e-9, atol=1e-6)


def test_the_view_refuses_what_is_not_a_walk_and_other_sides(files):
    sequence, _ = files
    with pytest.raises(DefinitionError, match="sides"):
        sequence_joint_space(sequence, sides=("left", "right"))  # the robot's right stands first
    with pytest.raises(DefinitionError, match="not a walk sequence"):
        sequence_joint_space(sequence.with_metadata(sequence=None))
    with pytest.raises(DefinitionError, match="without its walker"):
        sequence_joint_space(sequence.with_metadata(model=None))
    # a sidecar that is not the file's own: a step's start moved by 1 ms
    meta = json.loads(json.dumps(sequence.metadata["sequence"]))
    meta["steps"][1]["start_s"] += 1e-3
    with pytest.raises(DefinitionError, match="step 1's rows do not start at its start_s"):
        sequence_joint_space(sequence.with_metadata(sequence=meta))


def test_a_robot_on_feet_or_with_a_library_is_refused_by_name(capsys, tmp_path):
    status = main(["walk", "--speeds", "0,1", "--urdf", "examples/robots/biped_feet.urdf",
                   "--output-dir", str(tmp_path / "w")])  # fmt: skip
    assert status == 2 and "robot with feet" in capsys.readouterr().err
    status = main(["walk", "--speeds", "0,1", "--urdf", ROBOT, "--library", "x.npz",
                   "--output-dir", str(tmp_path / "w")])  # fmt: skip
    assert status == 2 and "--library" in capsys.readouterr().err
    assert not (tmp_path / "w").exists()
