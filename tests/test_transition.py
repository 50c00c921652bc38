"""problems.library.transition and .sequence: the steps between gaits and whole walks.

Oracles: the joins against the model's impact-and-swap map evaluated on the solved states
(x_{j+1}(0) = Delta(x_j(T)) to 1e-8; the ends equal the gaits' own states); every step against
the independent numpy verification (the impact's angular momentum balances about the landing
foot and every hinge, written without the model); a corrupted join in the file caught by that
verification; the step-count search against forced counts; quiet standing at the ends (rest,
feet together, the standing torques the static inverse dynamics, checked by the
verification's dynamics residual at that sample).
"""

import itertools

import numpy as np
import pytest

from model.linkage_trajectory import LinkageTrajectory
from planner.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from planner.trajectory import Trajectory
from problems.__main__ import main
from problems.library import (
    STANDING,
    build_library,
    plan_sequence,
    plan_transition,
    verify_sequence,
)
from problems.library.transition import LAND_TIME, RETRIED, RETRY_ITERATIONS
from problems.walking.footed import step_at_speed
from problems.walking.step import walking_step


def _gait(speed):
    length, duration = step_at_speed(speed)
    return walking_step(None, length, duration).solve(progress=False)


@pytest.fixture(scope="module")
def gaits():
    return {v: _gait(v) for v in (1.0, 1.4)}


@pytest.fixture(scope="module")
def sequence():
    # 0.6 m/s: its start and stop take a step each (12 s); from 1.0 m/s one-step stops fail
    # their hold rounds first (65 s)
    return plan_sequence([0, 0.6, 0], steps_at_speed=2)


def _joins_hold(transition, start_state=None, end_state=None):
    n = transition.gaits[0].problem.linkage.n
    states = [g.solution.states for g in transition.gaits]
    for j in range(transition.steps - 1):
        mapped = np.asarray(transition.gaits[j].problem.step_map(states[j][-1])).reshape(-1)
        np.testing.assert_allclose(states[j + 1][0], mapped, atol=1e-8)
    if start_state is not None:
        np.testing.assert_allclose(states[0][0], start_state, atol=1e-9)
    if end_state is not None:
        np.testing.assert_allclose(states[-1][-1], end_state, atol=1e-9)
    return n


def test_a_speed_change_joins_both_gaits_through_the_impact_map(gaits):
    a, b = gaits[1.0], gaits[1.4]
    transition = plan_transition(a, b)
    assert transition.speeds == (1.0, 1.4)
    # one step cannot take the body from 1.0 to 1.4 m/s within 150 N m and the sole's centre
    # of pressure: the search says so and takes two
    assert [k for k, _ in transition.attempts] == [1, 2] and transition.steps == 2
    assert transition.attempts[-1][1] == "solved and verified"
    _joins_hold(transition, a.solution.states[0], b.solution.states[-1])
    # b's own heel strike ends the transition: the next step of b starts at b's x(0)
    last = transition.gaits[-1]
    after = np.asarray(last.problem.step_map(last.solution.states[-1])).reshape(-1)
    np.testing.assert_allclose(after, b.solution.states[0], atol=1e-6)
    assert all(report.ok for report in transition.reports)
    for report in transition.reports:
        assert report["join angles"].margin > -1e-9
        assert report["impact momentum"].passed
    peaks = transition.peak_torques()
    assert max(peaks.values()) <= 150.0 + 1e-6


def test_a_forced_count_that_cannot_be_walked_is_refused_with_each_try(gaits):
    with pytest.raises(AnthropoidError, match=r"no transition from 1 to 1\.4 m/s.*1 step"):
        plan_transition(gaits[1.0], gaits[1.4], steps=1, options={"max_iter": 150})
    with pytest.raises(DefinitionError, match="standing to standing"):
        plan_transition(STANDING, STANDING, steps=1)
    with pytest.raises(DefinitionError, match="`end`"):
        plan_transition(gaits[1.0], "sitting", steps=1)
    with pytest.raises(DefinitionError, match=r"`support`: a fraction of the weight in \[0, 1\)"):
        plan_transition(gaits[1.0], gaits[1.4], steps=1, support=1.2)


def test_a_try_past_its_wall_time_fails_and_says_so(gaits, monkeypatch):
    # a budget IPOPT cannot meet: the count fails on its wall time, the next would be tried
    with pytest.raises(
        AnthropoidError, match=r"1 step\(s\): IPOPT failed with status Maximum_WallTime_Exceeded"
    ):
        plan_transition(gaits[1.0], gaits[1.4], steps=1, try_seconds=1e-3)
    with pytest.raises(DefinitionError, match="`try_seconds`"):
        plan_transition(gaits[1.0], gaits[1.4], steps=1, try_seconds=-1.0)
    # a hold round that would start past the deadline is not started
    from problems.gait import problem as gait_problem

    rounds = []

    def one_round(problem, rate_hz, again, solution, pinned=()):
        rounds.append(problem)
        return again(problem)

    monkeypatch.setattr(gait_problem, "hold_at_samples", one_round)
    solution = gaits[1.0].solution
    with pytest.raises(AnthropoidError, match="wall-time budget ran out in the limits' hold"):
        gait_problem.hold_limits(gaits[1.0].problem.ocp, solution, 100.0, {}, deadline=0.0)
    assert len(rounds) == 1


def test_the_transitions_iterations_reach_ipopt(capsys):
    with pytest.raises(AnthropoidError, match=r"1 step\(s\): IPOPT failed .* after 1 iterations"):
        plan_sequence([0, 1.0, 0], steps_at_speed=1, max_steps=1, transition_iterations=1,
                      retry_iterations=None)  # fmt: skip
    with pytest.raises(DefinitionError, match="`transition_iterations`"):
        plan_sequence([0, 1.0, 0], transition_iterations=0)
    from problems.cli import build_parser

    parser = build_parser()
    assert parser.parse_args(["walk", "--retry-iterations", "0"]).retry_iterations == 0
    assert parser.parse_args(["walk"]).retry_iterations == RETRY_ITERATIONS
    assert main(["walk", "--speeds", "0,1", "--retry-iterations", "-1"]) == 2
    assert "--retry-iterations: must be >= 0, got '-1'" in capsys.readouterr().err


def test_a_count_stopped_on_the_iteration_cap_is_tried_again_with_more():
    gait = _gait(0.6)  # its stop takes one step (about 40 IPOPT iterations)
    capped = {"max_iter": 2}
    transition = plan_transition(gait, STANDING, max_steps=1, options=capped, retry_iterations=400)
    assert [k for k, _ in transition.attempts] == [1, 1] and transition.steps == 1
    assert "Maximum_Iterations_Exceeded after 2 iterations" in transition.attempts[0][1]
    assert transition.attempts[1][1] == f"{RETRIED} 400 iterations: solved and verified"
    assert all(report.ok for report in transition.reports)
    # no second pass: the count stays failed
    with pytest.raises(AnthropoidError, match="after 2 iterations") as failed:
        plan_transition(gait, STANDING, max_steps=1, options=capped, retry_iterations=None)
    assert RETRIED not in str(failed.value)
    # a count that failed on anything but the iteration cap (here its wall time) is not
    # tried again
    with pytest.raises(AnthropoidError, match="Maximum_WallTime_Exceeded") as failed:
        plan_transition(gait, STANDING, max_steps=1, try_seconds=1e-3, retry_iterations=400)
    assert RETRIED not in str(failed.value)
    with pytest.raises(DefinitionError, match="`retry_iterations`"):
        plan_transition(gait, STANDING, retry_iterations=0)


def test_the_cap_is_found_behind_a_hold_rounds_error():
    from planner.solver import SolverError
    from problems.library.transition import _stopped_on_cap

    def chained(status):
        try:
            try:
                raise SolverError("IPOPT failed", status, 300, [], None)
            except SolverError as inner:
                raise AnthropoidError("solving again with the limits backed off") from inner
        except AnthropoidError as outer:
            return outer

    assert _stopped_on_cap(chained("Maximum_Iterations_Exceeded"))
    assert not _stopped_on_cap(chained("Infeasible_Problem_Detected"))
    assert not _stopped_on_cap(AnthropoidError("a verification failed"))


def test_the_joint_speed_option_reaches_both_steps():
    from problems.cli import build_parser
    from problems.cli.walk import step_options
    from problems.cli.walk_feet import footed_options

    parser = build_parser()
    for given, expected in (("8", 8.0), ("0", None)):
        args = parser.parse_args(["walk", "--joint-speed-limit", given])
        mesh = {"N": 12, "transcription": "hermite-simpson", "degree": None}
        options = step_options(args, plan_linkage(), mesh, (None, None))
        assert options["speed_limit"] == expected
        args = parser.parse_args(["walk", "--preset", "six-link-feet", "--joint-speed-limit",
                                  given])  # fmt: skip
        assert footed_options(args).get("speed_limit") == expected
    assert "speed_limit" not in footed_options(parser.parse_args(["walk", "--preset",
                                                                  "six-link-feet"]))  # fmt: skip


def test_a_walk_starts_and_ends_in_quiet_standing(sequence):
    steps = sequence.steps
    kinds = [s.kind for s in steps]
    assert kinds[0] == "start" and kinds[-1] == "stop" and kinds.count("gait") == 2
    first, last = steps[0].gait, steps[-1].gait
    n = first.problem.linkage.n
    x0, xT = first.solution.states[0], last.solution.states[-1]
    np.testing.assert_allclose(x0[n:], 0.0, atol=1e-12)
    np.testing.assert_allclose(xT[n:], 0.0, atol=1e-12)
    for gait, x in ((first, x0), (last, xT)):  # the swing foot beside the stance foot
        foot = np.asarray(gait.problem.foot.function("position")(x[:n])).reshape(-1)
        np.testing.assert_allclose(foot, 0.0, atol=1e-9)
    assert last.problem.step_length == 0.0
    # footholds advance by each step's length; the clock by each step's time
    for before, after in itertools.pairwise(steps):
        assert after.foothold == pytest.approx(before.foothold + before.gait.problem.step_length)
        assert after.start == pytest.approx(before.start + before.gait.duration)


def test_a_stop_sets_its_foot_down_under_a_floor_that_ends_flat(gaits):
    """The stop's last step lands its foot at rest under a floor that ends flat: without it
    the foot, at rest with no acceleration at T, meets the floor's curvature there only by a
    jerk in the last mesh interval (the swing shank at 75.8 N m in the last 20 ms of this
    stop, its peak); with it the drives stay below 35 N m there (17.1 measured). The floor
    is the verification's too (its settings carry ``land_time``)."""
    transition = plan_transition(gaits[1.0], STANDING)
    last = transition.gaits[-1]
    assert last.problem.land_time == LAND_TIME > 0
    assert all(g.problem.land_time == 0 for g in transition.gaits[:-1])
    samples = last.exported(1000.0)
    assert samples.metadata["gait"]["land_time"] == LAND_TIME
    end = samples.time > samples.time[-1] - 0.02
    assert np.abs(samples.torques[end]).max() < 35.0
    assert all(report.ok for report in transition.reports)


def test_the_file_verifies_step_by_step_and_a_wrong_join_fails(sequence, tmp_path):
    trajectory = sequence.trajectory()
    assert np.all(np.diff(trajectory.time) > 0)
    path = trajectory.save(tmp_path / "sequence.csv")
    back = Trajectory.load(path)
    report = verify_sequence(back, sequence.linkage)
    assert report.ok, str(report)
    assert len(report.reports) == len(sequence.steps)
    assert report.worst("join angles") > -1e-9 and report.worst("dynamics") > -1e-6
    assert report.reports[0]["standing at rest"].passed
    # a step's first row 0.01 rad/s off in one rate: the impact before it no longer conserves
    # the momenta, the verification names it
    back = LinkageTrajectory.of(back)
    step = np.asarray(back.extras["step"][0])
    row = int(np.flatnonzero(step == 2)[0])
    dpsi = np.array(back.dpsi)
    dpsi[row, 1] += 0.01
    wrong = LinkageTrajectory.from_linkage(
        back.time, back.psi, dpsi, back.torques, back.link_names, ddpsi=back.ddpsi,
        ground_reaction=back.ground_reaction, metadata=back.metadata,
    )  # fmt: skip
    for name in ("step", "phase", "speed", "foothold_x"):
        wrong = wrong.with_extra(name, back.extras[name][0], back.extras[name][1])
    broken = verify_sequence(wrong, sequence.linkage)
    assert not broken.ok and not broken.reports[1].ok
    assert not broken.reports[1]["impact momentum"].passed
    # and the file's next-state joins of the other steps still pass
    assert broken.reports[0].ok


def test_speeds_are_checked():
    for speeds, message in (([1.0], "two or more"), ([0, 1.0, 0, 1.0], "only first or last"),
                            ([0, 1.0, 1.0], "repeats"), ([0, -1.0], ">= 0")):  # fmt: skip
        with pytest.raises(DefinitionError, match=message):
            plan_sequence(speeds)


def test_transition_counts_given_are_walked_in_one_try_and_bad_ones_refused():
    """A count given is that transition's only try (no search from 1 step: the start from
    standing, which one step walks, takes the two asked for), the joins hold through the
    impact map, and a count left 0 is still searched; a wrong list is refused by name before
    any plan."""
    walk = plan_sequence([0, 0.6, 0], steps_at_speed=1, transition_steps=[2, 0])
    start, stop = walk.transitions
    assert start.steps == 2 and [k for k, _ in start.attempts] == [2]
    assert start.attempts[0][1] == "solved and verified"
    assert stop.attempts[0][0] == 1  # searched: from one step
    _joins_hold(start, end_state=walk.gaits[0.6].solution.states[-1])
    for counts, message in (([2], "one count per transition, 2"),
                            ([2, -1], r"transition_steps\[1\]`: must be >= 1"),
                            ([1.5, 0], r"transition_steps\[0\]`: must be an integer")):  # fmt: skip
        with pytest.raises((DefinitionError, DefinitionTypeError), match=message):
            plan_sequence([0, 0.6, 0], transition_steps=counts)
    assert main(["walk", "--speeds", "0,0.6,0", "--transition-steps", "2"]) == 2
    assert main(["walk", "--speeds", "0,0.6,0", "--transition-steps", "2,x"]) == 2


def test_the_command_writes_one_verified_file_of_the_walk(tmp_path, capsys):
    folder = tmp_path / "walk"
    status = main(["walk", "--speeds", "0,0.6,0", "--steps-at-speed", "1", "--no-gif",
                   "--feedback", "--output-dir", str(folder)])  # fmt: skip
    printed = capsys.readouterr().out
    assert status == 0, printed
    assert "walk through 0 -> 0.6 -> 0 m/s" in printed and "all checks passed" in printed
    planned = next(line for line in printed.splitlines() if "as planned" in line)
    assert planned.count("stood") == (2 if "MuJoCo:" not in printed else 1), printed
    back = LinkageTrajectory.of(Trajectory.load(folder / "sequence.csv"))
    assert "K_stance_thigh__psi_torso" in back.extras and "feedback" in back.metadata
    meta = back.metadata["sequence"]
    assert [s["kind"] for s in meta["steps"]].count("gait") == 1
    assert meta["transitions"][0]["steps"] == len([s for s in meta["steps"]
                                                   if s["kind"] == "start"])  # fmt: skip
    assert verify_sequence(back, plan_linkage()).ok
    assert (folder / "sequence.png").is_file() and (folder / "walk.png").is_file()
    assert not (folder / "walk.gif").exists()


def plan_linkage():
    from model.presets import six_link_anthropoid

    return six_link_anthropoid()


@pytest.mark.parametrize("extra, message", [
    (["--speeds", "1,0,1"], "only first or last"),
    (["--speeds", "0,1", "--urdf", "x.urdf"], "cannot read 'x.urdf'"),
    (["--speeds", "0,1", "--step-time-s", "0.6"], "--step-time-s"),
    (["--speeds", "1,0.6", "--preset", "six-link-feet", "--library", "x.npz"], "--library"),
    (["--speeds", "1,0.6", "--preset", "six-link-feet", "-N", "20"], "-N"),
    (["--speeds", "1,0.6", "--preset", "six-link-feet", "--objective", "work"], "torque or human"),
    (["--speeds", "1,0.6", "--preset", "five-link-feet"], "six-link-feet"),
    (["--speeds", "0,x"], "separated by commas"),
    (["--speeds", "0,1", "--library", "no_such_library.npz"], "cannot read a gait library"),
])  # fmt: skip
def test_the_commands_wrong_options_are_refused_by_name(tmp_path, capsys, extra, message):
    status = main(["walk", *extra, "--output-dir", str(tmp_path / "w")])
    captured = capsys.readouterr()
    assert status == 2 and message in captured.err + captured.out
    assert not (tmp_path / "w").exists()


def test_a_walk_from_a_library_walks_its_gaits(tmp_path, capsys):
    library = build_library([0.5, 0.6, 0.7], multipliers=False)
    sequence = plan_sequence([0, 0.6, 0], library=library, steps_at_speed=1)
    gait = sequence.gaits[0.6]
    own = library.gaits[1]  # the grid speed's gait, as the file holds it
    exported = gait.exported(library.rate_hz)
    np.testing.assert_allclose(exported.time, own.time, atol=1e-12)
    # one NLP solved twice, from the grid's gait and from the blend: equal to IPOPT's tolerance
    np.testing.assert_allclose(exported.psi, own.psi, atol=1e-5)
    np.testing.assert_allclose(exported.torques, own.torques, atol=1e-3)
    assert sequence.verify().ok
    path = library.save(tmp_path / "library.npz")
    status = main(["walk", "--speeds", "0,1.5,0", "--library", str(path),
                   "--output-dir", str(tmp_path / "w")])  # fmt: skip
    assert status == 2 and "outside the library's 0.5..0.7 m/s" in capsys.readouterr().err
    with pytest.raises(DefinitionError, match="outside the library"):
        plan_sequence([0, 1.5, 0], library=library)


def test_the_drives_read_a_walk_through_speeds_step_by_step(sequence):
    """drives on the walk's file (problems.drives): every step read whole with the sides
    alternating, the sample before each heel strike included, and the drives' power equal to
    the hinges' power in the model's view at every row (power through the joint map)."""
    from model import Linkage, LinkageTrajectory
    from problems.drives import drive_requirements
    from problems.drives.requirements import plan_of
    from problems.gait.problem import joint_rates

    trajectory = LinkageTrajectory.of(sequence.trajectory(1000.0))
    linkage = Linkage.from_parameters(trajectory.metadata["model"])  # the file names its walker
    assert linkage.names == sequence.steps[0].gait.problem.linkage.names
    plan = plan_of(trajectory, "walk", 1.0)
    assert len(plan.steps) == len(sequence.steps)
    column = np.asarray(trajectory.extras["step"][0]).astype(int)
    for j, step in enumerate(plan.steps):
        time, tau, dq = step.time, step.torques, step.speeds
        rows = np.flatnonzero(column == j)
        # the step ends at its heel strike's instant: the next step's first row
        if j + 1 < len(plan.steps):
            assert time[-1] == pytest.approx(plan.steps[j + 1].time[0], abs=1e-9)
        drives = sum(tau[d] * dq[d] for d in tau)[: rows.size]
        rates = joint_rates(linkage, np.asarray(trajectory.dpsi)[rows])
        hinges = np.sum(np.asarray(trajectory.torques)[rows] * rates, axis=1)
        np.testing.assert_allclose(drives, hinges, atol=1e-9 * np.max(np.abs(hinges)))
    need = drive_requirements(trajectory, names=["walk"])
    assert need.plans[0].speed == pytest.approx(
        sum(s.gait.problem.step_length for s in sequence.steps)
        / (trajectory.time[-1] - trajectory.time[0]), rel=1e-9)  # fmt: skip
    assert need["right_knee"].peak_torque > 0.0
    # where each peak is: the plan and the step, with its kind
    kinds = {f"walk, step {j} ({step.kind})" for j, step in enumerate(sequence.steps)}
    assert all(at in kinds for r in need.drives for at in r.peaks_at.values())
