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


def test_a_drive_over_its_urdf_limit_is_named(tmp_path, capsys):
    """The test robot with 20 N m knees: the plan (bounded at 150 N m per hinge) needs more,
    and walk says which drive, by its URDF name, and by how much."""
    knees = r'(<joint name="(right|left)_knee" .*?effort=")150\.0'
    weak = re.sub(knees, r"\g<1>20.0", biped_urdf())
    assert weak.count('effort="20.0"') == 2
    path = tmp_path / "weak.urdf"
    path.write_text(weak)
    code = main(["walk", "--urdf", str(path), "--quick", "--no-plots", "--output-dir",
                 str(tmp_path / "out")])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0
    pattern = r"right_knee \(right_knee\): peak \|tau\| [\d.]+ N m > its effort limit 20 N m"
    assert re.search(pattern, printed)


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
