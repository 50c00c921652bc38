"""problems.drives: what each drive must deliver over planned steps (issue #36, part 1).

Oracles: power conservation (the drives' power sum_d tau_d dq_d, read through the robot's
joint map, equals the hinges' power sum_i M_i (dpsi_i - dpsi_parent) in the model's view at
every sample, on point feet and on feet); closed forms of a sinusoidal duty (RMS A / sqrt 2,
mean positive power A B / (2 pi), peaks A B / 2); the duty cycle's weighting (RMS^2 the
shares' mean of the plans' RMS^2); the stride's symmetry (right and left the same drive a
step apart); the command's file read back against the API.
"""

import csv
import math

import numpy as np
import pytest

from planner.errors import DefinitionError
from problems.drives import DriveRequirements, Plan, drive_requirements
from problems.drives.requirements import plan_of
from problems.gait.problem import joint_rates


@pytest.fixture(scope="module")
def point_foot_plan():
    from problems import walking_step

    return walking_step(N=20).solve().to_trajectory(1000.0)


@pytest.fixture(scope="module")
def feet_plan():
    from problems.walking.footed import footed_step_at

    return footed_step_at(1.0).solve().to_trajectory(1000.0)


@pytest.mark.parametrize("which", ["point_foot_plan", "feet_plan"])
def test_the_drives_power_is_the_hinges_power_at_every_sample(which, request):
    from model import LinkageTrajectory

    trajectory = request.getfixturevalue(which)
    model = LinkageTrajectory.of(trajectory)
    plan = plan_of(trajectory, "step", 1.0)
    time, tau, dq = plan.steps[0]  # the step as planned: the first side's leg in stance
    np.testing.assert_allclose(time, model.time - model.time[0], atol=1e-12)
    drives = sum(tau[d] * dq[d] for d in plan.drives)
    linkage = model_linkage(trajectory)
    rates = joint_rates(linkage, np.asarray(model.dpsi))
    # on feet the root's torque is the ground's on the stance foot (no drive; the settings
    # list the driven links); on point feet the root's is the stance ankle's drive
    driven = trajectory.metadata["gait"].get("drives") or linkage.names
    columns = [linkage.index(name) for name in driven]
    hinges = np.sum((np.asarray(model.torques) * rates)[:, columns], axis=1)
    scale = np.max(np.abs(hinges))
    np.testing.assert_allclose(drives, hinges, atol=1e-9 * scale)
    # the mirrored step: the same power (the legs' roles swapped)
    _, tau2, dq2 = plan.steps[1]
    np.testing.assert_allclose(sum(tau2[d] * dq2[d] for d in plan.drives), hinges,
                               atol=1e-9 * scale)  # fmt: skip


def model_linkage(trajectory):
    from model import Linkage

    return Linkage.from_parameters(trajectory.metadata["model"])


def _sinusoid(name, share, amplitude, speed_amplitude, periods=2, samples=4001):
    """A plan whose one drive ``x`` has tau = A sin(w t), dq = B cos(w t) over two steps of
    0.5 s, ``periods`` periods per step."""
    steps = []
    for k in range(2):
        time = np.linspace(0.0, 0.5, samples) + 0.5 * k
        omega = 2 * math.pi * periods / 0.5
        steps.append((time, {"x": amplitude * np.sin(omega * time)},
                      {"x": speed_amplitude * np.cos(omega * time)}))  # fmt: skip
    return Plan(name, share, tuple(steps), 0.5, 1.0)


def test_a_sinusoidal_duty_gives_its_closed_forms():
    A, B = 30.0, 4.0
    need = DriveRequirements.of([_sinusoid("sine", 1.0, A, B)])["x"]
    assert need.peak_torque == pytest.approx(A, rel=1e-6)
    assert need.rms_torque == pytest.approx(A / math.sqrt(2), rel=1e-6)
    assert need.rms_speed == pytest.approx(B / math.sqrt(2), rel=1e-6)
    assert need.peak_power == pytest.approx(A * B / 2, rel=1e-6)
    assert need.peak_braking_power == pytest.approx(A * B / 2, rel=1e-6)
    assert need.mean_positive_power == pytest.approx(A * B / (2 * math.pi), rel=1e-5)
    assert need.mean_negative_power == pytest.approx(-A * B / (2 * math.pi), rel=1e-5)
    # per step (0.5 s): the mean positive power times the step's time
    assert need.positive_work_per_step[0] == pytest.approx(0.5 * A * B / (2 * math.pi), rel=1e-5)


def test_the_duty_cycle_weights_each_plan_by_its_share_of_the_time():
    slow, fast = _sinusoid("slow", 0.75, 20.0, 2.0), _sinusoid("fast", 0.25, 40.0, 6.0)
    need = DriveRequirements.of([slow, fast])["x"]
    assert need.rms_torque == pytest.approx(math.sqrt(0.75 * 20**2 / 2 + 0.25 * 40**2 / 2),
                                            rel=1e-6)  # fmt: skip
    assert need.peak_torque == pytest.approx(40.0) and need.peak_speed == pytest.approx(6.0)
    assert need.mean_positive_power == pytest.approx(
        (0.75 * 20 * 2 + 0.25 * 40 * 6) / (2 * math.pi), rel=1e-5
    )
    assert need.positive_work_per_step == pytest.approx(
        (0.5 * 20 * 2 / (2 * math.pi), 0.5 * 40 * 6 / (2 * math.pi)), rel=1e-5
    )


def test_a_stride_is_symmetric_and_shares_are_normalised(point_foot_plan):
    once = drive_requirements(point_foot_plan)
    for side in ("hip", "knee", "ankle"):
        right, left = once[f"right_{side}"], once[f"left_{side}"]
        assert right.rms_torque == pytest.approx(left.rms_torque, rel=1e-9)
        assert right.peak_power == pytest.approx(left.peak_power, rel=1e-9)
    twice = drive_requirements([point_foot_plan, point_foot_plan], shares=[3.0, 1.0])
    assert [p.share for p in twice.plans] == [0.75, 0.25]
    for a, b in zip(once.drives, twice.drives, strict=True):
        assert a.rms_torque == pytest.approx(b.rms_torque, rel=1e-12)
        assert a.mean_positive_power == pytest.approx(b.mean_positive_power, rel=1e-12)
    with pytest.raises(DefinitionError, match="`shares`: 2 shares for 1 plans"):
        drive_requirements(point_foot_plan, shares=[0.5, 0.5])
    with pytest.raises(DefinitionError, match="`shares`: fractions of time >= 0"):
        drive_requirements([point_foot_plan, point_foot_plan], shares=[1.0, -1.0])


def test_the_command_writes_the_table_a_drive_engineer_reads(point_foot_plan, tmp_path, capsys):
    from problems.__main__ import main

    plan = tmp_path / "torques.csv"
    point_foot_plan.save(plan)
    folder = tmp_path / "drives"
    code = main(["drives", str(plan), "--output-dir", str(folder), "-q"])
    printed = capsys.readouterr().out
    assert code == 0
    assert "| right_knee |" in printed and "work per step, J" in printed
    with (folder / "requirements.csv").open() as handle:
        rows = {row["drive"]: row for row in csv.DictReader(handle)}
    from model import LinkageTrajectory

    api = drive_requirements(LinkageTrajectory.load(plan))
    for need in api.drives:
        assert float(rows[need.drive]["rms_torque_N_m"]) == pytest.approx(need.rms_torque)
        assert float(rows[need.drive]["positive_work_J_0"]) == pytest.approx(
            need.positive_work_per_step[0]
        )
    assert (folder / "requirements.png").stat().st_size > 10_000
    code = main(["drives", str(plan), "--shares", "1,2", "--output-dir", str(tmp_path / "x")])
    assert code == 2
    assert "--shares: `shares`: 2 shares for 1 plans" in capsys.readouterr().err
    code = main(["drives", str(tmp_path / "none.csv"), "--output-dir", str(tmp_path / "y")])
    assert code == 2
    assert "PLAN: no file" in capsys.readouterr().err
