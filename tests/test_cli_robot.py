"""walk --urdf: a robot's URDF planned, verified and written in its own terms; the example
robots kept in step with the tests' and with their source's table; the options refused by
name."""

import json
import re
from pathlib import Path

import numpy as np
import pytest
from robot_urdf import biped_urdf

from model import LinkageTrajectory
from problems.__main__ import main
from problems.cli.common import robot_limit_lines
from problems.robot import read_urdf_walker

ROBOTS = Path(__file__).resolve().parent.parent / "examples" / "robots"


def test_the_example_bipeds_are_the_tests_robot():
    assert (ROBOTS / "biped.urdf").read_text() == biped_urdf(False)
    assert (ROBOTS / "biped_feet.urdf").read_text() == biped_urdf(True)


def test_rabbit_reads_as_its_table():
    """Chevallereau et al. 2003, Table 1 (examples/robots/rabbit.urdf's comment): the walking
    linkage's links by hand from the table's lengths, masses, inertias and centres."""
    walker = read_urdf_walker(ROBOTS / "rabbit.urdf")
    links = {link.name: link for link in walker.linkage.links}
    expected = {  # name: (length, mass, inertia, centre from the link's start in the plan)
        "stance_shank": (0.4, 3.2, 0.20, 0.4 - 0.24),  # from the foot up
        "stance_thigh": (0.4, 6.8, 0.47, 0.4 - 0.11),  # from the knee up
        "swing_thigh": (0.4, 6.8, 0.47, 0.11),
        "swing_shank": (0.4, 3.2, 0.20, 0.24),
        "torso": (0.625, 12.0, 1.33, 0.24),
    }
    assert set(links) == set(expected)
    for name, (length, mass, inertia, centre) in expected.items():
        link = links[name]
        assert (link.length, link.mass, link.inertia) == pytest.approx((length, mass, inertia))
        assert link.com * link.length == pytest.approx(centre)
    assert walker.joints == {"right_hip": "right_hip", "right_knee": "right_knee",
                             "left_hip": "left_hip", "left_knee": "left_knee"}  # fmt: skip


def test_rabbit_planned_verified_and_written_in_its_terms(tmp_path, capsys):
    out = tmp_path / "rabbit"
    code = main(["walk", "--urdf", str(ROBOTS / "rabbit.urdf"), "--passive-ankle",
                 "--no-plots", "--output-dir", str(out)])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0
    assert re.search(r"verification of torques.csv .*: all \d+ checks passed", printed)
    header = (out / "joints.csv").read_text().splitlines()[0].split(",")
    assert not [name for name in header if "ankle" in name]  # RABBIT has none
    meta = json.loads((out / "joints.csv.meta.json").read_text())
    assert {j["name"]: j["urdf_joint"] for j in meta["joints"]} == {
        "right_hip": "right_hip", "right_knee": "right_knee",
        "left_hip": "left_hip", "left_knee": "left_knee",
    }  # fmt: skip
    assert meta["controller"]["ankles"].startswith("none")
    assert (
        "the URDF's joint limits: every planned torque and angle within them (4 joints)" in printed
    )
    for joint in meta["joints"]:  # RABBIT's knees bend one way: 0..2.6 rad in the URDF
        assert joint["urdf_effort_N_m"] == 150.0
        assert joint["range_in_file_rad"][0] >= joint["urdf_range_rad"][0]
    model = LinkageTrajectory.load(out / "torques.csv")
    assert model.metadata["robot"]["urdf"] == str(ROBOTS / "rabbit.urdf")
    # the passive ankle: no torque at the foot, within the solver's tolerance
    assert np.max(np.abs(model.torques[:, 0])) < 1.0


def _walk_with_effort(tmp_path, capsys, joint: str, effort: float, feet: bool):
    """(exit code, printed, output folder) of walk --quick on the test robot whose two
    ``joint``s (hip_pitch, knee, ankle) have the URDF effort ``effort`` N m."""
    pattern = rf'(<joint name="(right|left)_{joint}" .*?effort=")150\.0'
    weak = re.sub(pattern, rf"\g<1>{effort!r}", biped_urdf(feet=feet))
    assert weak.count(f'effort="{effort!r}"') == 2
    path = tmp_path / "weak.urdf"
    path.write_text(weak)
    out = tmp_path / "out"
    code = main(["walk", "--urdf", str(path), "--quick", "--no-plots", "--output-dir", str(out)])
    return code, capsys.readouterr().out, out


def test_the_urdfs_efforts_bound_the_plan(tmp_path, capsys):
    """The test robot with 45 N m hips (the plan's default bound is 150 N m a hinge): the
    stance hip's drive, which carries the trunk's hinge and the swing thigh's, is held within
    45 N m in the plan and in its verification, and the file's hips stay within it."""
    code, printed, out = _walk_with_effort(tmp_path, capsys, "hip_pitch", 45.0, feet=False)
    assert code == 0
    assert re.search(r"ok +stance hip", printed)
    assert "every planned torque and angle within them" in printed
    meta = json.loads((out / "joints.csv.meta.json").read_text())
    hips = [j for j in meta["joints"] if j["name"].endswith("_hip")]
    assert all(j["peak_N_m"] <= 45.0 + 1e-3 for j in hips), hips
    model = LinkageTrajectory.load(out / "torques.csv")
    assert model.metadata["gait"]["hip_limit"] == 45.0
    assert model.metadata["gait"]["torque_limit"]["swing_thigh"] == 45.0


def test_limit_lines_name_each_drive_over_its_urdf_limit():
    joints = [
        {"name": "right_knee", "urdf_joint": "rk", "peak_N_m": 52.6, "urdf_effort_N_m": 40.0,
         "urdf_range_rad": [-0.5, 2.0], "range_in_file_rad": [-0.6, 1.0]},
        {"name": "left_knee", "urdf_joint": "lk", "peak_N_m": 30.0, "urdf_effort_N_m": 40.0},
    ]  # fmt: skip
    lines = robot_limit_lines({"joints": joints})
    assert lines[0] == "the URDF's joint limits: exceeded by"
    assert "right_knee (rk): peak |tau| 52.6 N m > its effort limit 40 N m" in lines[1]
    assert "right_knee (rk): q -0.600..1.000 rad outside its URDF range -0.500..2.000" in lines[2]
    assert len(lines) == 3
    assert robot_limit_lines({"joints": joints[1:]}) == [
        "the URDF's joint limits: every planned torque and angle within them (1 joints)"
    ]
    assert robot_limit_lines({"joints": [{"name": "neck", "peak_N_m": 1.0}]}) == []
    # at the limit to the solver's tolerance is on it, not past it
    on = [{"name": "ankle", "urdf_joint": "a", "peak_N_m": 40.0 + 1e-5, "urdf_effort_N_m": 40.0}]
    assert "within them" in robot_limit_lines({"joints": on})[0]


def test_the_robots_options_are_refused_by_name(tmp_path, capsys):
    def error(*argv):
        code = main(["walk", *argv, "--output-dir", str(tmp_path / "x")])
        lines = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(lines) == 1, lines
        return lines[0]

    robot = str(ROBOTS / "biped.urdf")
    assert "--lock, --sole: only with --urdf" in error("--lock", "a,b")
    assert "--preset five-link and --urdf" in error("--urdf", robot, "--preset", "five-link")
    assert "--legs: the URDF names its legs right,left" in error("--urdf", robot, "--legs",
                                                                 "front,back")  # fmt: skip
    assert "cannot read" in error("--urdf", str(tmp_path / "none.urdf"))
    assert "`lock`: the URDF has no joint ['wrist']" in error("--urdf", robot, "--lock", "wrist")


def test_on_feet_each_hinge_has_its_joints_effort(tmp_path, capsys):
    """The robot on feet with 30 N m ankles: both ankles' hinges bounded at 30 N m (the
    footed step's per-drive limits), the others at their 150 N m; the ground's torque on
    the stance foot is no drive and has no bound."""
    code, printed, out = _walk_with_effort(tmp_path, capsys, "ankle", 30.0, feet=True)
    assert code == 0, printed[-2000:]
    model = LinkageTrajectory.load(out / "torques.csv")
    limits = model.metadata["gait"]["torque_limit"]
    assert limits["stance_shank"] == limits["swing_foot"] == 30.0
    assert limits["stance_thigh"] == 150.0 and "stance_foot" not in limits
    names = model.link_names
    for name in ("stance_shank", "swing_foot"):
        assert np.max(np.abs(model.torques[:, names.index(name)])) <= 30.0 + 1e-3
