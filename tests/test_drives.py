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
from problems.drives import DriveRequirements, DriveStep, Plan, drive_requirements
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
    first = plan.steps[0]  # the step as planned: the first side's leg in stance
    time, tau, dq = first.time, first.torques, first.speeds
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
    tau2, dq2 = plan.steps[1].torques, plan.steps[1].speeds
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
        steps.append(DriveStep(time, {"x": amplitude * np.sin(omega * time)},
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
    assert need.peaks_at == dict.fromkeys(("torque", "speed", "power", "braking"), "fast")
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


# ---- drive models and selection (issue #36, parts 2 and 3) --------------------------------
MOTORS_CSV = """name,torque_constant_mNm_A,resistance_ohm,rotor_inertia_gcm2,continuous_torque_mNm,peak_torque_mNm,voltage_V,max_speed_rpm,mass_g,source
small,50,1.0,100,300,1500,48,8000,400,test data
large,100,0.5,500,900,4000,48,6000,900,test data
"""  # noqa: E501
GEARBOXES_CSV = """name,ratio,efficiency,inertia_gcm2,continuous_torque_Nm,peak_torque_Nm,max_input_speed_rpm,mass_g,source
n50,50,0.8,10,40,120,8000,500,test data
n100,100,0.8,10,60,180,8000,700,test data
"""  # noqa: E501


def _drive(kt=0.1, resistance=1.0, rotor=1e-5, ratio=100.0, eta=0.8, gear_inertia=0.0):
    from problems.drives.catalogue import Drive, Gearbox, Motor

    motor = Motor("m", kt, resistance, rotor, 1.0, 5.0, 48.0, 1000.0, 0.5)
    return Drive(motor, Gearbox("g", ratio, eta, gear_inertia, 60.0, 180.0, 1000.0, 0.7))


def test_the_motor_side_of_one_operating_point_by_hand():
    """tau 40 N m at 2 rad/s, 10 rad/s^2 through 100:1 at 80 %, k_t 0.1, R 1 ohm, J 1e-5:
    tau_m = 1e-5 100 10 + 40 / 80 = 0.51 N m; i = 5.1 A; u = 5.1 + 0.1 200 = 25.1 V; copper
    26.01 W; electrical 128.01 W. Back-driven (-40 N m at 2 rad/s): the load 40 0.8 / 100 =
    0.32 N m against the motor, tau_m = 0.01 - 0.32 = -0.31 N m."""
    motor = _drive().at_motor(40.0, 2.0, 10.0)
    assert motor["torque"] == pytest.approx(0.51)
    assert motor["current"] == pytest.approx(5.1)
    assert motor["voltage"] == pytest.approx(25.1)
    assert motor["copper"] == pytest.approx(26.01)
    assert motor["power"] == pytest.approx(128.01)
    assert _drive().at_motor(-40.0, 2.0, 10.0)["torque"] == pytest.approx(-0.31)
    # the electrical power is the copper losses plus the mechanical power at the motor
    rng = np.random.default_rng(3)
    tau, dq, ddq = rng.normal(0, 50, 200), rng.normal(0, 5, 200), rng.normal(0, 50, 200)
    m = _drive(gear_inertia=2e-6).at_motor(tau, dq, ddq)
    np.testing.assert_allclose(m["power"], m["copper"] + m["torque"] * m["speed"], rtol=1e-12)


def test_the_catalogue_layout_is_read_and_checked(tmp_path):
    from problems.drives.catalogue import read_gearboxes, read_motors

    (tmp_path / "m.csv").write_text(MOTORS_CSV)
    (tmp_path / "g.csv").write_text(GEARBOXES_CSV)
    small, large = read_motors(tmp_path / "m.csv")
    assert small.torque_constant == pytest.approx(0.05)
    assert small.rotor_inertia == pytest.approx(1e-5, rel=1e-12)
    assert large.max_speed == pytest.approx(6000 * math.pi / 30)
    assert large.mass == pytest.approx(0.9)
    assert read_gearboxes(tmp_path / "g.csv")[1].ratio == 100.0
    (tmp_path / "bad.csv").write_text(MOTORS_CSV.replace("1.0,100,300", "1.0,x,300"))
    with pytest.raises(DefinitionError, match=r"row 2, column 'rotor_inertia_gcm2': expected"):
        read_motors(tmp_path / "bad.csv")
    (tmp_path / "neg.csv").write_text(MOTORS_CSV.replace("48,8000", "-48,8000"))
    with pytest.raises(DefinitionError, match=r"row 2 \(small\), column 'voltage_V'.*> 0"):
        read_motors(tmp_path / "neg.csv")
    (tmp_path / "short.csv").write_text("name,ratio\nx,3\n")
    with pytest.raises(DefinitionError, match="missing the columns"):
        read_gearboxes(tmp_path / "short.csv")


def test_selection_takes_the_lightest_that_meets_every_limit_and_refuses_by_name(tmp_path):
    """The sinusoidal duty (30 N m, 4 rad/s): each combination's checks by hand, the
    lightest fitting chosen; a duty no drive carries refused naming the limit."""
    from problems.drives.catalogue import read_gearboxes, read_motors
    from problems.drives.selection import DriveSelectionError, require, select

    (tmp_path / "m.csv").write_text(MOTORS_CSV)
    (tmp_path / "g.csv").write_text(GEARBOXES_CSV)
    motors, gearboxes = read_motors(tmp_path / "m.csv"), read_gearboxes(tmp_path / "g.csv")
    duty = DriveRequirements.of([_sinusoid("sine", 1.0, 30.0, 4.0)])
    chosen = select(duty, motors, gearboxes)
    best = chosen.best("x")
    # small + n50: 30 N m / (50 0.8) = 0.75 N m peak at the motor (1.5 allowed), RMS 0.53
    # (0.3 continuous: too hot); small + n100: RMS 0.265 <= 0.3, speed 400 rad/s <= 838
    assert best.drive.name == "small + n100" and best.drive.mass == pytest.approx(1.1)
    checks = {c.limit: c for c in best.checks}
    assert checks["motor peak torque"].need == pytest.approx(30.0 / 80.0, rel=1e-3)
    assert checks["speed"].need == pytest.approx(400.0, rel=1e-6)
    assert checks["gearbox peak torque"].margin == pytest.approx(1 - 30.0 / 180.0, rel=1e-6)
    assert all(c.margin >= 0 for c in best.checks)
    by_energy = select(duty, motors, gearboxes, rank="energy").best("x")
    assert by_energy.energy_per_step <= best.energy_per_step
    heavy = DriveRequirements.of([_sinusoid("sine", 1.0, 300.0, 4.0)])
    refused = select(heavy, motors, gearboxes).refused["x"]
    # 300 N m: the RMS 212 N m against the largest rated 60 N m binds (-254 %), before the
    # peak 300 against 180 N m (-67 %)
    assert "no catalogue drive fits" in refused
    assert "misses its gearbox rated torque: needs 212 N m, has 60 N m (254 % over)" in refused
    with pytest.raises(DriveSelectionError, match="gearbox rated torque"):
        require(select(heavy, motors, gearboxes))


def test_the_command_chooses_the_drives_or_writes_nothing(point_foot_plan, tmp_path, capsys):
    """The default step's hips need 58 V from the test catalogue's 48 V motors (refused, by
    name, nothing written); with a 96 V motor added every drive is chosen and written."""
    from problems.__main__ import main

    plan = tmp_path / "torques.csv"
    point_foot_plan.save(plan)
    (tmp_path / "m.csv").write_text(MOTORS_CSV)
    (tmp_path / "g.csv").write_text(GEARBOXES_CSV)
    folder = tmp_path / "chosen"
    argv = ["drives", str(plan), "--gearboxes", str(tmp_path / "g.csv"), "-q"]
    code = main([*argv, "--motors", str(tmp_path / "m.csv"), "--output-dir", str(folder)])
    err = capsys.readouterr().err
    assert code == 1 and not folder.exists()
    assert "right_hip: no catalogue drive fits" in err and "misses its voltage" in err
    (tmp_path / "m96.csv").write_text(MOTORS_CSV + "large96,120,1.0,500,900,4000,96,6000,"
                                      "950,test data\n")  # fmt: skip
    code = main([*argv, "--motors", str(tmp_path / "m96.csv"), "--output-dir", str(folder)])
    assert code == 0, capsys.readouterr().err
    with (folder / "selection.csv").open() as handle:
        rows = {row["drive"]: row for row in csv.DictReader(handle)}
    assert rows["right_hip"]["motor"] == "large96" and rows["neck"]["motor"] == "small"
    assert all(float(r["voltage_margin"]) >= 0 for r in rows.values())
    assert (folder / "requirements.png").is_file()
    code = main(["drives", str(plan), "--motors", str(tmp_path / "m.csv"), "--output-dir",
                 str(tmp_path / "x")])  # fmt: skip
    assert code == 2 and "give both catalogues" in capsys.readouterr().err


def test_bad_drive_inputs_are_refused_naming_the_field(point_foot_plan, tmp_path, capsys):
    from problems.__main__ import main
    from problems.drives.catalogue import read_gearboxes, read_motors
    from problems.drives.selection import select

    plan = tmp_path / "torques.csv"
    point_foot_plan.save(plan)
    out = str(tmp_path / "out")
    for shares, said in (("1,x", "expected numbers a,b,c, got '1,x'"),
                         ("1,-2", "shares are fractions of time >= 0, got '1,-2'")):  # fmt: skip
        assert main(["drives", str(plan), "--shares", shares, "--output-dir", out]) == 2
        assert said in capsys.readouterr().err
    garbage = tmp_path / "garbage.csv"
    garbage.write_text("not,a,plan\n1,2,3\n")
    assert main(["drives", str(garbage), "--output-dir", out]) == 2
    assert f"PLAN {garbage}: cannot read a planned step there" in capsys.readouterr().err
    (tmp_path / "short.csv").write_text("name,ratio\nx,3\n")
    (tmp_path / "g.csv").write_text(GEARBOXES_CSV)
    code = main(["drives", str(plan), "--motors", str(tmp_path / "short.csv"), "--gearboxes",
                 str(tmp_path / "g.csv"), "--output-dir", out])  # fmt: skip
    assert code == 2 and "--motors: " in capsys.readouterr().err
    (tmp_path / "slow.csv").write_text(GEARBOXES_CSV.replace("n50,50,0.8", "n50,0.5,0.8"))
    with pytest.raises(DefinitionError, match=r"n50: the ratio must be >= 1 .* got 0.5 and 0.8"):
        read_gearboxes(tmp_path / "slow.csv")
    (tmp_path / "empty.csv").write_text(MOTORS_CSV.splitlines()[0] + "\n")
    with pytest.raises(DefinitionError, match=r"empty\.csv: no rows"):
        read_motors(tmp_path / "empty.csv")
    with pytest.raises(DefinitionError, match="cannot read it"):
        read_motors(tmp_path / "absent.csv")
    (tmp_path / "m.csv").write_text(MOTORS_CSV)
    motors, gearboxes = read_motors(tmp_path / "m.csv"), read_gearboxes(tmp_path / "g.csv")
    duty = DriveRequirements.of([_sinusoid("sine", 1.0, 30.0, 4.0)])
    with pytest.raises(DefinitionError, match=r"`rank`: one of \('mass', 'energy'\), got 'cost'"):
        select(duty, motors, gearboxes, rank="cost")
    with pytest.raises(DefinitionError, match="give at least one of each"):
        select(duty, (), gearboxes)
    with pytest.raises(DefinitionError, match=r"`drives`: \['knee'\] are not among \['x'\]"):
        select(duty, motors, gearboxes, drives=["knee"])
    with pytest.raises(DefinitionError, match="`plans`: give one or more planned steps"):
        drive_requirements([])
    with pytest.raises(DefinitionError, match="`names`: 2 names for 1 plans"):
        drive_requirements(point_foot_plan, names=["a", "b"])
    with pytest.raises(TypeError, match="`shares`: one number per plan, got '1'"):
        drive_requirements(point_foot_plan, shares="1")
    other = _sinusoid("other", 1.0, 1.0, 1.0)
    other = Plan("other", 1.0, tuple(DriveStep(s.time, {"y": s.torques["x"]},
                                               {"y": s.speeds["x"]}) for s in other.steps),
                 0.5, 1.0)  # fmt: skip
    with pytest.raises(DefinitionError, match="a duty cycle is one walker's"):
        DriveRequirements.of([_sinusoid("sine", 0.5, 1.0, 1.0), other])


def test_a_reflected_inertia_cap_is_a_limit_of_every_candidate_and_names_itself(tmp_path):
    """The sinusoidal duty's choice, small + n100, reflects (J_m + J_g) N^2 = (100 + 10) g cm^2
    x 100^2 = 0.11 kg m^2 at the joint (the layout's g cm^2 is 1e-7 kg m^2): under a cap of
    0.2 it stays, with a margin of 1 - 0.11 / 0.2; under 0.1 no drive fits (large + n50
    reflects 0.1275, small + n50 runs too hot) and the refusal names the inertia."""
    from problems.drives.catalogue import read_gearboxes, read_motors
    from problems.drives.selection import select

    (tmp_path / "m.csv").write_text(MOTORS_CSV)
    (tmp_path / "g.csv").write_text(GEARBOXES_CSV)
    motors, gearboxes = read_motors(tmp_path / "m.csv"), read_gearboxes(tmp_path / "g.csv")
    duty = DriveRequirements.of([_sinusoid("sine", 1.0, 30.0, 4.0)])
    assert not any(c.limit == "reflected inertia" for c in select(duty, motors, gearboxes)
                   .best("x").checks)  # fmt: skip
    capped = select(duty, motors, gearboxes, reflected_inertia={"x": 0.2})
    best = capped.best("x")
    assert best.drive.name == "small + n100"
    check = {c.limit: c for c in best.checks}["reflected inertia"]
    assert check.need == pytest.approx(0.11, rel=1e-12)
    assert check.margin == pytest.approx(1 - 0.11 / 0.2, rel=1e-12)
    for candidate in capped.ranked["x"]:
        assert {c.limit: c for c in candidate.checks}["reflected inertia"].need <= 0.2
    refused = select(duty, motors, gearboxes, reflected_inertia={"x": 0.1}).refused["x"]
    assert "small + n100, misses its reflected inertia: needs 0.11 kg m^2, has 0.1" in refused
    with pytest.raises(DefinitionError, match=r"`reflected_inertia`: \['hip'\] name no drive"):
        select(duty, motors, gearboxes, reflected_inertia={"hip": 0.1})
    with pytest.raises(DefinitionError, match=r"`reflected_inertia\['x'\]`: a cap in kg m\^2"):
        select(duty, motors, gearboxes, reflected_inertia={"x": -1.0})
