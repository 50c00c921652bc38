"""Speed changes on feet (problems.library.footed_transition) and what they rest on: one
step of several solved together as a solution of its own (PhasesSolution.part), a step on
feet resized with its own duration parameters (footed.resized), and the verification of a
step on feet against the next step's first state (``join angles``, ``join rates``).

Oracles: the whole solution's own samples (a part is the same phases read on another
time axis), the leg swap written out by hand (each boundary of a solved transition, from the
exported samples), and a next state moved by a known angle (the join check fails by it)."""

from __future__ import annotations

import copy
import itertools
from dataclasses import replace

import numpy as np
import pytest

from model.linkage_trajectory import LinkageTrajectory
from model.rerooting import swap_legs
from planner.errors import DefinitionError
from problems.gait.verification import verify_gait
from problems.library.footed_transition import STOP_TIME, footed_transition_problem
from problems.library.transition import plan_transition
from problems.walking.footed import SEQUENCES, FootedGait, footed_step_at, resized, stopping


def test_a_part_of_a_solution_is_its_phases_on_their_own_time_axis(footed_gait):
    whole = footed_gait.solution
    part = whole.part("heel rise", "double")
    assert part.names == ("heel rise", "double")
    assert part.starts[0] == 0.0
    assert part.T == pytest.approx(whole.T - whole.phases[0].T, rel=1e-14)
    offset = whole.starts[1]
    mine = part.to_trajectory()
    theirs = whole.to_trajectory()
    later = theirs.time >= offset - 1e-12
    np.testing.assert_allclose(mine.time + offset, theirs.time[later], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(mine.states, theirs.states[later])
    assert part.cost == pytest.approx(whole.phases[1].cost + whole.phases[2].cost, rel=1e-14)
    assert set(part.cost_terms) and all(
        key.startswith(("heel rise: ", "double: ")) for key in part.cost_terms
    )
    assert part.problem.periodicity is None
    assert set(part.params) <= set(whole.params)
    with pytest.raises(DefinitionError, match="comes before"):
        whole.part("double", "flat")


def test_a_resized_step_keeps_its_options_and_names_its_durations(footed_gait):
    step = footed_gait.problem
    other = resized(step, 0.6, 0.45, label="_3")
    assert (other.step_length, other.step_time, other.durations) == (0.6, 0.45, None)
    assert [p.name for p in other.phases.params] == ["T_flat_3", "T_heel_3"]
    assert other.limits == step.limits and other.mesh == step.mesh
    assert other.sequence == step.sequence and other.ankle_range == step.ankle_range
    # the guess is the law at the new length and time, not the old one
    assert other.law.period != step.law.period
    with pytest.raises(DefinitionError, match="label"):
        resized(step, 0.6, 0.45, label="-3")
    with pytest.raises(DefinitionError, match="step_time"):
        resized(step, 0.6, -1.0)


def test_a_step_on_feet_is_verified_against_the_next_steps_first_state(footed_gait):
    trajectory = footed_gait.exported()
    linkage = footed_gait.problem.linkage
    own = np.r_[trajectory.psi[0], trajectory.dpsi[0]]
    report = verify_gait(trajectory, linkage, settings={"next_state": own.tolist()})
    assert report.ok, str(report)
    names = {check.name for check in report.checks}
    assert {"join angles", "join rates"} <= names and "periodic angles" not in names
    moved = own.copy()
    moved[3] += 1e-3  # one angle of the next step's start, 1 mrad off
    report = verify_gait(trajectory, linkage, settings={"next_state": moved.tolist()})
    failed = [check.name for check in report.checks if not check.passed]
    assert failed == ["join angles"], str(report)
    (margin,) = [check.margin for check in report.checks if check.name == "join angles"]
    assert margin == pytest.approx(-1e-3, abs=1e-9)


def test_a_transition_on_feet_is_its_steps_joined_by_the_leg_swap(footed_gait):
    problem, steps = footed_transition_problem(footed_gait, footed_gait, 2)
    assert problem.names == tuple(f"step {j} {name}" for j in (1, 2)
                                  for name in ("flat", "heel rise", "double"))  # fmt: skip
    assert problem.periodicity is None
    assert [p.name for p in problem.params] == ["T_flat_1", "T_heel_1", "T_flat_2", "T_heel_2"]
    # within a step the periodic step's joins; between the steps the leg swap
    own = footed_gait.problem.phases
    assert problem.mappings[0] is None and problem.controls[0] == "continuous"
    assert problem.mappings[1] is not None and problem.mappings[2] is not None
    assert problem.mappings[3] is None and problem.controls[3] == "continuous"
    x = np.random.default_rng(3).normal(size=2 * footed_gait.problem.linkage.n)
    strike = np.asarray(own.mappings[1](x)).ravel()
    for k in (1, 4):  # each step's heel strike: the periodic step's impact map
        np.testing.assert_array_equal(np.asarray(problem.mappings[k](x)).ravel(), strike)
    swap = swap_legs(footed_gait.problem.linkage)
    mapped = np.asarray(problem.mappings[2](x)).ravel()
    psi, dpsi = swap.map_state(x[: x.size // 2], x[x.size // 2 :])
    np.testing.assert_allclose(mapped, np.r_[psi, dpsi], rtol=0, atol=1e-15)
    # the first phase starts at the gait's first state, the last ends at its last
    first = [c.name for c in problem.phases[0][1].constraints]
    last = [c.name for c in problem.phases[-1][1].constraints]
    assert "foot flat" not in first and "initial psi" in first and "initial dpsi" in first
    assert "final psi" in last and "final dpsi" in last
    assert all("foot flat" in [c.name for c in ocp.constraints] for _, ocp in problem.phases[3:4])
    assert [s.label for s in steps] == ["_1", "_2"]


def test_a_start_from_standing_on_feet_fixes_the_feet_flat_together_at_rest(footed_gait):
    """The first phase of a standing start: the swing ball at the stance ball and both soles
    flat (rows evaluated on a pose built by hand), at rest (dpsi fixed, ddpsi rows), the
    stance foot's own ``foot flat`` row left out (its rate is fixed); the later steps as a
    speed change's."""
    problem, steps = footed_transition_problem("standing", footed_gait, 2)
    assert problem.names[:3] == ("step 1 flat", "step 1 heel rise", "step 1 double")
    first = {c.name: c for c in problem.phases[0][1].constraints}
    assert {"standing feet", "standing flat", "at rest", "initial dpsi"} <= set(first)
    assert "foot flat" not in first and "initial psi" not in first
    assert "foot flat" in [c.name for c in problem.phases[3][1].constraints]
    # the ramp: half the gait's speed, then the gait's own step
    assert steps[0].speed == pytest.approx(0.5 * footed_gait.speed, rel=1e-12)
    assert steps[1].step_length == footed_gait.problem.step_length
    # a hand-built pose: the stance foot flat, the swing foot copied onto it (the swing
    # leg's angles equal the stance leg's, the tree mirrored at the hip), the trunk up
    step = steps[0]
    linkage, biped = step.linkage, step.biped
    psi = np.zeros(linkage.n)
    for stance, swing in zip(biped.stance_leg, reversed(biped.swing_leg), strict=True):
        index = linkage.index(stance)
        psi[index] = step.flat_angles[0] if index == 0 else np.pi / 2 - 0.1
        psi[linkage.index(swing)] = psi[index] + np.pi  # the swing leg runs hip -> foot
    psi[linkage.index(biped.swing_leg[-1])] = step.flat_angles[1]
    ball = step.point("swing_toe").function("position")
    base = step.point("stance_toe").function("position")
    gap = np.ravel(ball(psi)) - np.ravel(base(psi))
    assert np.max(np.abs(gap)) < 1e-12, "the hand-built pose: the swing ball on the stance ball"
    # the verification's standing checks on that pose, and on the periodic step's first
    # state (the swing foot behind, coming off its ball): the latter fails them by name
    trajectory = footed_gait.exported()
    report = verify_gait(trajectory, linkage, settings={"start": "standing"})
    failed = {check.name for check in report.checks if not check.passed}
    assert {"standing feet", "standing flat", "standing at rest"} <= failed, str(report)
    (feet,) = [c.margin for c in report.checks if c.name == "standing feet"]
    x0 = np.r_[trajectory.psi[0]]
    behind = np.ravel(ball(x0)) - np.ravel(base(x0))
    assert feet == pytest.approx(-np.max(np.abs(behind)), rel=1e-9)


@pytest.fixture(scope="module")
def stop_from_slow():
    """The periodic step on feet at 0.6 m/s and its stop at quiet standing in one step (its
    capture point at the stop's start, 4 cm behind the stance ball, lies on the sole; from
    1 m/s it lies 6 cm ahead of the ball)."""
    gait = footed_step_at(0.6).solve()
    return gait, plan_transition(gait, "standing", steps=1)


def test_a_stop_on_feet_sets_the_swing_foot_down_flat_beside_the_stance_foot(stop_from_slow):
    """The stop's one flat phase from the gait's x(0) to quiet standing: the swing ball at the
    stance ball and both soles flat at T (the model's point kinematics on the last exported
    sample), the body at rest; the drives in the last 20 ms below 0.4 of the stop's
    peak (the floor ends flat and the foot comes down at touchdown speed 0: with the walk's
    0.3 m/s approach term the optimum slammed the swing leg to rest in the last interval);
    its rows, fixed duration and verification (a last sample moved off standing fails it by
    name)."""
    gait, transition = stop_from_slow
    problem, steps = footed_transition_problem(gait, "standing", 1)
    assert problem.names == ("step 1 flat",) and problem.periodicity is None
    rows = {c.name for c in problem.phases[0][1].constraints}
    assert {"standing feet", "standing flat", "standing still", "at rest"} <= rows
    assert "landing" not in rows and "foot flat" not in rows and "initial psi" in rows
    stop = steps[0]
    assert stop.stop and stop.step_length == 0.0 and stop.touchdown_speed == 0.0
    assert stop.land_time > 0 and stop.durations == (stop.step_time,)
    assert stop.step_time == pytest.approx(STOP_TIME * gait.problem.step_time, rel=1e-12)
    assert transition.steps == 1 and all(report.ok for report in transition.reports)
    (solved,) = transition.gaits
    n = solved.problem.linkage.n
    np.testing.assert_allclose(solved.solution.states[0], gait.segments()[0][0].states[0],
                               atol=1e-9)  # fmt: skip
    samples = solved.exported()
    psi_T = samples.psi[-1]
    ball = np.ravel(stop.point("swing_toe").function("position")(psi_T))
    base = np.ravel(stop.point("stance_toe").function("position")(psi_T))
    np.testing.assert_allclose(ball, base, atol=1e-9)
    root, foot = (
        stop.linkage.index(stop.biped.stance_leg[0]),
        stop.linkage.index(stop.biped.swing_leg[-1]),
    )
    np.testing.assert_allclose(psi_T[[root, foot]], stop.flat_angles, atol=1e-9)
    np.testing.assert_allclose(samples.dpsi[-1], 0.0, atol=1e-9)
    drives = samples.torques[:, 1:]
    end = samples.time > samples.time[-1] - 0.02
    assert np.abs(drives[end]).max() < 0.4 * np.abs(drives).max()
    assert samples.torques.shape[1] == n
    # a last sample moved off standing (the swing foot turned by 0.05 rad) fails by name
    moved = samples.psi.copy()
    moved[-1, foot] += 0.05
    wrong = LinkageTrajectory.from_linkage(
        samples.time, moved, samples.dpsi, samples.torques, samples.link_names,
        ddpsi=samples.ddpsi, ground_reaction=samples.ground_reaction, metadata=samples.metadata,
    )  # fmt: skip
    report = verify_gait(wrong, stop.linkage)
    failed = {check.name for check in report.checks if not check.passed}
    assert "standing flat" in failed, str(report)


def test_a_walk_on_feet_ends_standing_in_one_verified_file(tmp_path):
    """plan_sequence(..., feet=True) ending at 0: the gait, then the stop; the file (the
    stop's rows carry the front contact's force channels, zero) saved, read back and
    verified step by step, the stop's end against standing (``next_state``: its pose
    relabelled, at rest); a file whose last sample is moved off standing fails by name."""
    from planner.trajectory import Trajectory
    from problems.library import plan_sequence, verify_sequence

    sequence = plan_sequence([0.6, 0], feet=True, steps_at_speed=1)
    assert [step.kind for step in sequence.steps] == ["gait", "stop"]
    linkage = sequence.steps[0].gait.problem.linkage
    path = tmp_path / "sequence.csv"
    sequence.trajectory().save(path)
    back = Trajectory.load(path)
    report = verify_sequence(back, linkage)
    assert report.ok, str(report)
    assert {"standing feet", "standing flat", "standing at rest"} <= {
        check.name for check in report.reports[-1].checks
    }
    # the stop's last sample is the sidecar's (its state at T): turn its swing foot
    trajectory = LinkageTrajectory.of(back)
    metadata = copy.deepcopy(trajectory.metadata)
    last = metadata["sequence"]["steps"][-1]["before_impact"]["x"]
    last[linkage.index(sequence.steps[-1].gait.problem.biped.swing_leg[-1])] += 0.05
    moved = trajectory.with_metadata(sequence=metadata["sequence"])
    failed = verify_sequence(moved, linkage)
    assert not failed.ok
    assert "standing flat" in {c.name for c in failed.reports[-1].checks if not c.passed}


def test_a_transition_on_feet_refuses_what_it_cannot_join(footed_gait):
    from problems import walking_step

    point_foot = walking_step().solve()
    with pytest.raises(DefinitionError, match="step on feet"):
        footed_transition_problem(footed_gait, point_foot, 1)
    with pytest.raises(DefinitionError, match="step_options"):
        plan_transition(footed_gait, footed_gait, steps=1, torque_limit=100.0)
    flat_footed = FootedGait(
        replace(footed_gait.problem, sequence=SEQUENCES["flat-footed"]), footed_gait.solution, 0.0
    )
    toe_walking = FootedGait(
        replace(footed_gait.problem, sequence=SEQUENCES["toe-walking"]), footed_gait.solution, 0.0
    )
    with pytest.raises(DefinitionError, match=r"contact phases .* are not the start's"):
        footed_transition_problem(footed_gait, flat_footed, 1)
    with pytest.raises(DefinitionError, match=r"`start`: a stop at quiet standing .* 'heel rise'"):
        footed_transition_problem(toe_walking, "standing", 1)
    with pytest.raises(DefinitionError, match=r"`end`: a start from quiet standing .* 'heel rise'"):
        footed_transition_problem("standing", toe_walking, 1)
    with pytest.raises(DefinitionError, match="standing to standing is no walk"):
        footed_transition_problem("standing", "standing", 1)
    with pytest.raises(DefinitionError, match="a stop at standing ends with the stance foot flat"):
        stopping(toe_walking.problem, 1.0)
    with pytest.raises(DefinitionError, match="`step_time`: must be > 0 s"):
        stopping(footed_gait.problem, 0.0)
    with pytest.raises(DefinitionError, match="`steps`"):
        footed_transition_problem(footed_gait, footed_gait, 0)


@pytest.mark.slow
def test_a_speed_change_on_feet_is_verified_joins_at_every_boundary_and_walks():
    """1.0 -> 1.2 m/s on feet, the joint speeds bounded at 10 rad/s: the fewest steps that
    solve; every step verified at every exported sample; at each boundary the leg swap of a
    step's last sample is the next step's first, the first is gait a's first and the last gait
    b's last (from the files' samples, to round-off); walked in MuJoCo (when installed) from
    three steps of a through the change to four of b without a fall."""
    a = footed_step_at(1.0, speed_limit=10.0).solve()
    following = footed_step_at(1.2, speed_limit=10.0)
    b = following.solve(following.phases.guess(a.solution))
    transition = plan_transition(a, b)
    assert all(isinstance(g, FootedGait) for g in transition.gaits)
    assert all(g.problem.speed_limit == 10.0 for g in transition.gaits)
    assert all(report.ok for report in transition.reports)
    swap = swap_legs(a.problem.linkage)
    samples = [g.exported() for g in transition.gaits]
    first, last = a.exported(), b.exported()
    np.testing.assert_allclose(samples[0].psi[0], first.psi[0], atol=1e-9)
    np.testing.assert_allclose(samples[-1].psi[-1], last.psi[-1], atol=1e-9)
    np.testing.assert_allclose(samples[-1].dpsi[-1], last.dpsi[-1], atol=1e-9)
    for before, after in itertools.pairwise(samples):
        psi, dpsi = swap.map_state(before.psi[-1], before.dpsi[-1])
        np.testing.assert_allclose(after.psi[0], psi, atol=1e-9)
        np.testing.assert_allclose(after.dpsi[0], dpsi, atol=1e-9)
    # the steps' speeds ramp from a's to b's
    speeds = [g.speed for g in transition.gaits]
    assert speeds[-1] == pytest.approx(b.speed) and all(np.diff([a.speed, *speeds]) > 0)
    assert set(transition.peak_torques()) == set(a.problem.drives)
    pytest.importorskip("mujoco")
    from problems.control.mujoco_feet import run_feet_steps_in_mujoco

    steps = [a] * 3 + list(transition.gaits) + [b] * 4
    run = run_feet_steps_in_mujoco(steps)
    assert (run.walked, run.fell) == (len(steps), None)


@pytest.mark.slow
def test_a_start_from_standing_on_feet_is_verified_joins_its_gait_and_walks():
    """Quiet standing into the 1 m/s step on feet (joints bounded at 10 rad/s, the walk
    command's) in four steps: every step verified at every exported sample; the first sample
    has both feet flat side by side at rest (from the model's own point kinematics), each
    boundary is the leg swap of the step before, the last sample is the gait's last; the
    swing foot lifts from rest without a jerk (the drives' torques in the first 50 ms within
    30 N m of their first sample's, 14.5 in the walk command's run: with the periodic step's
    floor the swing knee jumped by 80 N m in 3 ms); its first step's law by the time while
    the hip sways, then by the phase; walked in MuJoCo (when installed) from standing through
    four steps of the gait without a fall, the first step's length within 10 % of the
    plan's."""
    from problems.control.feet_law import FeetLaw

    gait = footed_step_at(1.0, speed_limit=10.0).solve()
    transition = plan_transition("standing", gait, steps=4)
    assert transition.steps == 4 and all(report.ok for report in transition.reports)
    checks = {c.name for c in transition.reports[0].checks}
    assert {"standing feet", "standing flat", "standing at rest"} <= checks
    samples = [g.exported() for g in transition.gaits]
    step = transition.gaits[0].problem
    psi0 = samples[0].psi[0]
    ball = np.ravel(step.point("swing_toe").function("position")(psi0))
    base = np.ravel(step.point("stance_toe").function("position")(psi0))
    np.testing.assert_allclose(ball, base, rtol=0, atol=1e-9)
    root, foot = (step.linkage.index(name) for name in (step.biped.stance_leg[0],
                                                         step.biped.swing_leg[-1]))  # fmt: skip
    np.testing.assert_allclose(psi0[[root, foot]], step.flat_angles, rtol=0, atol=1e-9)
    np.testing.assert_allclose(samples[0].dpsi[0], 0.0, rtol=0, atol=1e-9)
    swap = swap_legs(step.linkage)
    for before, after in itertools.pairwise(samples):
        psi, dpsi = swap.map_state(before.psi[-1], before.dpsi[-1])
        np.testing.assert_allclose(after.psi[0], psi, atol=1e-9)
        np.testing.assert_allclose(after.dpsi[0], dpsi, atol=1e-9)
    last = gait.exported()
    np.testing.assert_allclose(samples[-1].psi[-1], last.psi[-1], atol=1e-9)
    np.testing.assert_allclose(samples[-1].dpsi[-1], last.dpsi[-1], atol=1e-9)
    speeds = [g.speed for g in transition.gaits]
    assert all(np.diff([0.0, *speeds]) > 0) and speeds[-1] == pytest.approx(gait.speed)
    early = samples[0].time <= 0.05
    drives = samples[0].torques[early][:, 1:]  # the root's is the ground's
    assert np.max(np.abs(drives - drives[0])) < 30.0
    assert transition.gaits[0].problem.lift_time > 0
    assert all(g.problem.lift_time == 0 for g in transition.gaits[1:])
    # the first step's law goes by the time while its hip sways, the others' by the phase
    laws = [FeetLaw(g) for g in transition.gaits]
    assert [law.indexed_by for law in laws] == ["time", "phase", "phase", "phase"]
    assert 0.0 < laws[0].references[0].time_indexed_until < transition.gaits[0].duration
    pytest.importorskip("mujoco")
    from problems.control.mujoco_feet import run_feet_steps_in_mujoco

    steps = list(transition.gaits) + [gait] * 4
    run = run_feet_steps_in_mujoco(steps)
    assert (run.walked, run.fell) == (len(steps), None)
    assert run.steps[0].length == pytest.approx(transition.gaits[0].problem.step_length, rel=0.1)
