"""problems.drives.loop: a walking step planned with its drives (issue #36, part 4).

Oracles: the whole body's centre of mass and kinetic energy with the motors as point masses
at their joints (the model's hinge positions and velocities, not the merged links); the gait
verifier's Euler-law equations with the rotors (and without them, which the plan must fail);
the exact, non-smooth motor model at every exported sample against every limit; the
electrical energy identity u i = R i^2 + tau_m omega_m integrated.
"""

import math

import numpy as np
import pytest

from model import Dynamics
from model.presets import six_link_anthropoid
from planner.errors import DefinitionError
from problems.drives.catalogue import Drive, Gearbox, Motor
from problems.drives.loop import drives_in_the_loop, energy_per_step, motor_report, with_drives

RPM = math.pi / 30.0
#: illustrative numbers (a 48 V motor through 80:1), not a product
DRIVE = Drive(
    Motor("m", 0.07, 0.3, 2e-5, 0.6, 2.0, 48.0, 6000 * RPM, 0.5),
    Gearbox("g", 80.0, 0.8, 2e-6, 60.0, 160.0, 8000 * RPM, 0.4),
)
DRIVES = {"hip": DRIVE, "knee": DRIVE, "ankle": DRIVE, "neck": DRIVE}


@pytest.fixture(scope="module")
def walker():
    return drives_in_the_loop(six_link_anthropoid(), DRIVES)


@pytest.fixture(scope="module")
def drive_plan(walker):
    from problems import walking_step

    step = walking_step(walker.linkage, N=20, rotors=walker.rotors)
    return with_drives(step, walker).solve()


def test_the_walker_carries_each_motor_at_its_joint(walker):
    bare = six_link_anthropoid()
    before, after = Dynamics(bare), Dynamics(walker.linkage)
    rng = np.random.default_rng(4)
    psi, dpsi = rng.normal(size=6), rng.normal(size=6) * 2
    names = bare.names

    def joints(dynamics, which, *state):
        points = which(dynamics, *state)  # H0, then each link's end
        end = {name: points[1 + i] for i, name in enumerate(names)}
        # stance ankle (H0), stance knee, both hips, swing knee, swing ankle, neck
        return [points[0], end["stance_shank"], end["stance_thigh"], end["stance_thigh"],
                end["swing_thigh"], end["swing_shank"], end["torso"]]  # fmt: skip

    carried = DRIVE.mass * 7
    masses = np.array([link.mass for link in walker.linkage.links])
    assert masses.sum() == pytest.approx(sum(link.mass for link in bare.links) + carried)
    com = {}
    for label, dynamics, linkage in (("before", before, bare), ("after", after, walker.linkage)):
        com[label] = np.array([link.mass for link in linkage.links]) @ dynamics.com_positions(psi)
    at_joints = sum(joints(before, Dynamics.hinge_positions, psi))
    assert com["after"] == pytest.approx(com["before"] + DRIVE.mass * at_joints, abs=1e-12)
    speeds = joints(before, Dynamics.hinge_velocities, psi, dpsi)
    point_masses = 0.5 * DRIVE.mass * sum(abs(v) ** 2 for v in speeds)
    assert after.energy(psi, dpsi)[0] == pytest.approx(
        before.energy(psi, dpsi)[0] + point_masses, rel=1e-12
    )
    # a point foot's swing ankle has no rotor (no foot to turn); every other drive has one,
    # turning q's way: the hip's q grows with the thigh, the knee's against the shank
    keys = {m.key: m for m in walker.mounted}
    legs = {f"{role}_{joint}" for role in ("stance", "swing") for joint in ("hip", "knee", "ankle")}
    assert set(keys) == (legs - {"swing_ankle"}) | {"neck"}
    assert keys["swing_hip"].sense == 1.0 and keys["stance_knee"].sense == -1.0
    assert keys["stance_ankle"].rotor.driven is None


def test_the_plan_with_its_drives_is_verified_with_its_rotors_and_fails_without(drive_plan):
    from problems.gait.verification import verify_gait

    assert drive_plan.verified
    trajectory = drive_plan.exported()
    assert len(trajectory.metadata["gait"]["rotors"]) == 6
    report = verify_gait(trajectory, drive_plan.problem.linkage, settings={"rotors": []})
    assert not report.ok
    assert report.facts["dynamics residual"] > 1.0  # N m: the rotors' torques


def test_every_exported_sample_is_within_the_drives_limits(drive_plan, walker):
    trajectory = drive_plan.exported()
    report = motor_report(trajectory, walker)
    limits = {"motor torque, N m": 2.0, "voltage, V": 48.0, "gear torque, N m": 160.0,
              "motor speed, rad/s": 6000 * RPM}  # fmt: skip
    for key, side in report.items():
        for limit, margin in side["margins"].items():
            assert margin.min() >= -1e-6 * limits[limit], (key, limit, margin.min())
    # some limit binds: the drives shape this plan
    closest = min(side["margins"][k].min() / limits[k] for side in report.values() for k in limits)
    assert closest < 1e-3
    # u i = R i^2 + tau_m omega_m, integrated over the step
    energy = energy_per_step(report, trajectory.time)
    mechanical = sum(
        np.trapezoid(side["torque"] * side["speed"], trajectory.time) for side in report.values()
    )
    assert energy["counted"] == pytest.approx(energy["copper"] + mechanical, rel=1e-12)
    assert energy["drawn"] >= energy["counted"]


def test_the_copper_objective_plans_the_coolest_motors_of_the_three(drive_plan, walker):
    """With the copper losses as its objective the plan's exact copper energy (every 1 kHz
    sample through the exact motor model) is below the torque objective's and the electrical
    one's, and the objective is that energy: the regularisation (1e-3 J per unit of
    sum (M / limit)^2 s) and the branches' tanh blend are all that tell them apart."""
    from problems import walking_step

    def copper_of(gait):
        trajectory = gait.exported()
        return energy_per_step(motor_report(trajectory, walker), trajectory.time)["copper"]

    step = walking_step(walker.linkage, N=20, rotors=walker.rotors)
    coolest = with_drives(step, walker, "copper").solve()
    kept = with_drives(step, walker, "kept").solve()
    assert coolest.verified and kept.verified
    assert copper_of(coolest) < copper_of(kept)
    assert copper_of(coolest) < copper_of(drive_plan)
    assert coolest.cost == pytest.approx(copper_of(coolest), rel=0.02)


def test_the_sole_holds_the_gear_output_not_the_rotors_torque(drive_plan, walker):
    """The stance ankle's motor rides on the shank and turns the foot held flat: the ground
    takes the gear's output, tau_out = tau - N J a_r (the motor report's, from the rotor's
    rate vector and the joint's sense), not the hinge torque, which holds the rotor's inertia
    too. The file's centre of pressure is -tau_out / Fy (the ankle's q is pi/2 - psi_shank),
    and the sole's limits held it at the nodes."""
    from model.linkage_naming import centre_of_pressure_name, root_contact

    trajectory = drive_plan.exported()
    ankle = motor_report(trajectory, walker)["stance_ankle"]
    force = trajectory.ground_reaction.imag
    loaded = force > 0
    column = trajectory.extras[centre_of_pressure_name(root_contact(trajectory.link_names))]
    column = np.asarray(column[0], dtype=float).ravel()  # (values, unit)
    np.testing.assert_allclose(column[loaded], -ankle["tau_out"][loaded] / force[loaded],
                               atol=1e-9)  # fmt: skip
    hinge = trajectory.torques[:, 0]
    assert np.max(np.abs(hinge + ankle["tau_out"])) > 0.5  # N m: the rotor's share
    heel, toe = drive_plan.problem.foot_sole
    assert column[loaded].min() >= -heel - 1e-6 and column[loaded].max() <= toe + 1e-6


def test_the_closed_loop_of_a_drive_plan_simulates_its_rotors(drive_plan):
    """The periodic LQR designed on the plan's own model (rotors in), simulated in the
    product's hybrid simulation: with the rotors the walk tracks the plan to the simulation's
    discretisation; the same loop on a plant without them (an ideal-torque simulation of a
    geared robot) walks, but 10 times further from the plan."""
    from problems.control.feedback import design_feedback
    from problems.control.simulation import simulate_walking

    feedback = design_feedback(drive_plan)
    assert feedback.plant.dynamics.rotors == drive_plan.problem.dynamics.rotors
    options = feedback.simulation_options
    start = feedback.reference.states[0]
    tracking = {}
    for label, rotors in (("with", options["rotors"]), ("without", ())):
        run = simulate_walking(start, feedback.controller, steps=5,
                               **{**options, "rotors": rotors})  # fmt: skip
        assert run.fell is None, (label, run.fell)
        tracking[label] = max(step.tracking for step in run.steps)
    assert tracking["with"] < 1e-3  # rad
    assert tracking["without"] > 10 * tracking["with"]


def test_drives_for_every_joint_the_plan_has_are_required(walker):
    with pytest.raises(DefinitionError, match=r"the walker's plan has \['neck'\] too"):
        drives_in_the_loop(six_link_anthropoid(), {"hip": DRIVE, "knee": DRIVE, "ankle": DRIVE})
    with pytest.raises(DefinitionError, match=r"unknown joints \['wrist'\]"):
        drives_in_the_loop(six_link_anthropoid(), {**DRIVES, "wrist": DRIVE})
    from problems import walking_step

    with pytest.raises(DefinitionError, match="plan it with the walker's rotors"):
        with_drives(walking_step(walker.linkage, N=10), walker)


MOTORS_CSV = """name,torque_constant_mNm_A,resistance_ohm,rotor_inertia_gcm2,continuous_torque_mNm,peak_torque_mNm,voltage_V,max_speed_rpm,mass_g,source
fast,45,0.125,200,600,2000,48,9000,500,test data
"""  # noqa: E501
GEARBOXES_CSV = """name,ratio,efficiency,inertia_gcm2,continuous_torque_Nm,peak_torque_Nm,max_input_speed_rpm,mass_g,source
n50,50,0.8,20,60,160,8000,400,test data
n80,80,0.8,20,60,160,8000,400,test data
"""  # noqa: E501


@pytest.fixture(scope="module")
def replan_argv(tmp_path_factory):
    """``drives PLAN --motors ... --replan -q --output-dir`` (the folder to come) for a point-foot
    step's file and the test catalogues, written in a folder of their own."""
    from problems import walking_step

    inputs = tmp_path_factory.mktemp("replan_inputs")
    plan = inputs / "torques.csv"
    walking_step(N=20).solve().exported().save(plan)
    (inputs / "m.csv").write_text(MOTORS_CSV)
    (inputs / "g.csv").write_text(GEARBOXES_CSV)
    return ["drives", str(plan), "--motors", str(inputs / "m.csv"), "--gearboxes",
            str(inputs / "g.csv"), "--rank", "energy", "--no-regeneration", "--no-plots",
            "--replan", "-q", "--output-dir"]  # fmt: skip


def test_the_command_replans_a_step_with_the_chosen_drives(replan_argv, tmp_path, capsys):
    """drives --replan: the file it writes stands on its own (read back, verified from its
    sidecar's rotors and body), and the comparison it prints is the API's."""
    from model import Linkage, LinkageTrajectory
    from problems.cli import main
    from problems.gait.verification import verify_gait

    folder = tmp_path / "out"
    assert main([*replan_argv, str(folder)]) == 0
    printed = capsys.readouterr().out
    assert "| as given |" in printed and "| re-planned with the drives |" in printed
    written = LinkageTrajectory.load(folder / "replanned.csv")
    assert len(written.metadata["gait"]["rotors"]) == 6
    named = written.metadata["drives"]["joints"]
    assert named["hip"]["motor"] == "fast" and named["knee"]["gearbox"] in ("n50", "n80")
    body = Linkage.from_parameters(written.metadata["model"])
    bare = sum(link.mass for link in six_link_anthropoid().links)
    assert sum(link.mass for link in body.links) == pytest.approx(bare + 7 * 0.9)  # 7 drives
    assert verify_gait(written, body).ok
    # the drawn energy printed for the re-plan is the file's, through the chosen drives
    from problems.drives.replan import compare

    for row in printed.splitlines():
        if row.startswith("| re-planned with the drives |"):
            drawn = float(row.split("|")[2])
    walker = drives_in_the_loop(six_link_anthropoid(), _chosen(folder, replan_argv))
    chosen = compare(written, walker, with_rotors=True)
    assert chosen["energy"]["drawn"] == pytest.approx(drawn, abs=0.05)
    assert all(value >= -1e-6 * 48 for value, _ in chosen["worst"].values())
    # --replan needs the catalogues
    plan = replan_argv[1]
    assert main(["drives", plan, "--replan", "-q", "--output-dir", str(tmp_path / "x")]) == 2
    assert "--replan: give one PLAN" in capsys.readouterr().err


def test_the_command_designs_hip_springs_with_the_replan(replan_argv, tmp_path, capsys):
    """drives --replan --springs hip: the springs' numbers in the sidecar, within their bounds;
    the energy printed for the re-plan is the file's through the drives beside those springs;
    springs that cannot be designed are refused by option."""
    from model import LinkageTrajectory
    from problems.cli import main
    from problems.drives.replan import compare
    from problems.drives.springs import MAX_STIFFNESS

    argv = replan_argv
    folder = tmp_path / "out"
    assert main([*argv, str(folder), "--springs", "hip"]) == 0
    printed = capsys.readouterr().out
    assert "parallel springs designed with the re-plan (both legs): hip" in printed
    written = LinkageTrajectory.load(folder / "replanned.csv")
    hip = written.metadata["drives"]["springs"]["hip"]
    k, rest = hip["stiffness_N_m_per_rad"], hip["rest_rad"]
    assert 0.0 <= k <= MAX_STIFFNESS and -math.pi <= rest <= math.pi
    for row in printed.splitlines():
        if row.startswith("| re-planned with the drives |"):
            drawn = float(row.split("|")[2])
    walker = drives_in_the_loop(six_link_anthropoid(), _chosen(folder, argv))
    sprung = compare(written, walker, with_rotors=True, springs={"hip": (k, rest)})
    assert sprung["energy"]["drawn"] == pytest.approx(drawn, abs=0.05)
    assert all(value >= -1e-6 * 48 for value, _ in sprung["worst"].values())
    # a point foot's swing ankle turns nothing; springs come with a re-plan; known joints only
    assert main([*argv, str(tmp_path / "a"), "--springs", "ankle"]) == 2
    assert "--springs: `springs`: no drive at ['ankle'] in both legs" in capsys.readouterr().err
    assert main([*argv[:-3], "-q", "--springs", "hip", "--output-dir", str(tmp_path / "b")]) == 2
    assert "--springs: springs are designed with a re-plan" in capsys.readouterr().err
    assert main([*argv, str(tmp_path / "c"), "--springs", "neck"]) == 2
    assert "give distinct joints among hip, knee, ankle" in capsys.readouterr().err
    assert not any((tmp_path / name).exists() for name in "abc")


def test_the_replan_picture_reads_each_drive_like_the_joint_space(walker, drive_plan):
    """output_plan (from the motor report, per model drive mapped to right and left) against
    plan_of (the robot's joint space): the same torques and speeds at every sample of both
    steps, but the point foot's swing ankle, which has no drive there (zero here, its level
    reference's speed there); a plan made with its drives reads without its rotors' share."""
    from problems import walking_step
    from problems.drives.replan import output_plan
    from problems.drives.requirements import plan_of

    given = walking_step(N=20).solve().exported()
    ours, theirs = output_plan(given, walker, "x", 1.0, False), plan_of(given, "x", 1.0)
    for mine, joint_space in zip(ours.steps, theirs.steps, strict=True):
        swing_ankle = "left_ankle" if mine.label == "step 0" else "right_ankle"
        for drive, torque in joint_space.torques.items():
            np.testing.assert_array_equal(mine.torques[drive], torque)
            if drive != swing_ankle:
                np.testing.assert_array_equal(mine.speeds[drive], joint_space.speeds[drive])
    planned = drive_plan.exported()
    report = motor_report(planned, walker)
    outputs = output_plan(planned, walker, "y", 1.0, True).steps[0]
    np.testing.assert_array_equal(outputs.torques["right_hip"], report["stance_hip"]["tau_out"])
    whole = motor_report(planned, walker, with_rotors=False)["stance_hip"]["tau_out"]  # d . M
    assert np.max(np.abs(whole - outputs.torques["right_hip"])) > 1.0  # the rotor's share
    # the requirements' reading would count that share twice: refused, naming the way
    with pytest.raises(DefinitionError, match="made with its drives in the loop"):
        plan_of(planned, "y", 1.0)


def _chosen(folder, argv):
    """The drives selection.csv names, rebuilt from the test catalogue ``argv`` names."""
    import csv

    from problems.drives.catalogue import read_gearboxes, read_motors

    motors = {m.name: m for m in read_motors(argv[argv.index("--motors") + 1])}
    gearboxes = {g.name: g for g in read_gearboxes(argv[argv.index("--gearboxes") + 1])}
    with (folder / "selection.csv").open() as handle:
        rows = {row["drive"]: row for row in csv.DictReader(handle)}
    return {joint: Drive(motors[rows[key]["motor"]], gearboxes[rows[key]["gearbox"]])
            for joint, key in (("hip", "right_hip"), ("knee", "right_knee"),
                               ("ankle", "right_ankle"), ("neck", "neck"))}  # fmt: skip


def test_bad_plans_for_the_drives_are_refused_by_name(walker, drive_plan, tmp_path):
    """with_drives' objective; a re-plan of a plan that is no point-foot walking step, or that
    was made with its drives already."""
    from problems import walking_step
    from problems.drives.replan import replan

    step = walking_step(walker.linkage, N=10, rotors=walker.rotors)
    with pytest.raises(DefinitionError, match=r"one of 'electrical', 'copper', 'kept', got 'work'"):
        with_drives(step, walker, "work")
    with pytest.raises(DefinitionError, match="this plan was made with drives already"):
        replan(drive_plan.exported(), DRIVES)
    pinned = drive_plan.exported().with_metadata(gait={"problem": "pinned_gait"})
    with pytest.raises(DefinitionError, match="on point feet without a double support, or on feet"):
        replan(pinned, DRIVES)
    double = drive_plan.exported().with_metadata(
        gait={**drive_plan.exported().metadata["gait"], "double_support": 0.1}
    )
    with pytest.raises(DefinitionError, match="with a double support"):
        replan(double, DRIVES)


@pytest.mark.slow
def test_a_step_on_feet_is_replanned_with_its_drives_verified_within_every_limit():
    """Issue #36 on feet: the step at 1.0 m/s planned for ideal torques within 10 rad/s at
    every joint (the swing foot no longer whipped round) and re-planned carrying the drives
    (the ankles' through 30:1: through 50:1 no footed step exists, the heel strike throwing
    the stance ball off): verified at every sample, with its rotors, and every sample within
    the drives' limits, which the ideal plan is not."""
    from problems import footed_step_at
    from problems.drives.replan import compare, replan

    rpm = math.pi / 30.0
    fast = Motor("48 V fast", 0.045, 0.125, 2e-5, 0.6, 2.0, 48.0, 9000 * rpm, 0.5)
    slow = Motor("48 V", 0.07, 0.3, 2e-5, 0.6, 2.0, 48.0, 6000 * rpm, 0.5)

    def gear(ratio):
        return Gearbox(f"{ratio}:1", ratio, 0.8, 2e-6, 60.0, 160.0, 8000 * rpm, 0.4)

    drives = {"hip": Drive(fast, gear(100.0)), "knee": Drive(fast, gear(80.0)),
              "ankle": Drive(slow, gear(30.0)), "neck": Drive(slow, gear(50.0))}  # fmt: skip
    ideal = footed_step_at(1.0, speed_limit=10.0).solve(progress=False)
    assert ideal.verified
    gait, walker = replan(ideal.exported(), drives, warm=ideal)
    assert gait.verified
    trajectory = gait.exported()
    assert trajectory.metadata["gait"]["problem"] == "footed_step"
    assert len(trajectory.metadata["gait"]["rotors"]) == len(walker.rotors) == 7
    worst = compare(trajectory, walker, with_rotors=True)["worst"]
    for limit, (margin, where) in worst.items():
        assert margin > -1e-4, (limit, margin, where)
    given = compare(ideal.exported(), walker, with_rotors=False)["worst"]
    assert min(margin for margin, _ in given.values()) < 0.0  # the ideal plan asks too much


def test_a_footed_plan_failing_at_the_strike_says_why_and_what_to_change(monkeypatch):
    """A footed plan with drives whose heel strike's impulse rows fail (the rear ball's cone,
    which a geared ankle's rotor leaves: examples/benchmarks/drives_on_feet.py) is refused
    with the reason and the changes that may leave a step; other failures pass unchanged.
    The solves carrying rotors are replaced by failures named as IPOPT names them."""
    from planner.errors import AnthropoidError
    from problems.drives.loop import STRIKE_HINT, plan_step_with_drives
    from problems.walking.footed import FootedStep

    solve = FootedStep.solve
    rows = {"text": "heel rise: end[impulse][3]: 0.00284"}

    def failing(self, *args, **kwargs):
        if not self.dynamics.rotors:
            return solve(self, *args, **kwargs)
        raise AnthropoidError(f"IPOPT failed with status Infeasible_Problem_Detected after 285 "
                              f"iterations; worst violations: {rows['text']}")  # fmt: skip

    monkeypatch.setattr(FootedStep, "solve", failing)
    from model.presets import anthropoid_with_feet

    feet = anthropoid_with_feet()
    with pytest.raises(AnthropoidError, match="end\\[impulse\\]") as raised:
        plan_step_with_drives(feet, DRIVES, 0.5, 0.5)
    assert STRIKE_HINT in str(raised.value) and "mu" in STRIKE_HINT
    rows["text"] = "double: path[rear unloads] interval 24 midpoint: 13.8"
    with pytest.raises(AnthropoidError) as raised:
        plan_step_with_drives(feet, DRIVES, 0.5, 0.5)
    assert STRIKE_HINT not in str(raised.value)
