"""planner.sampled_limits and OCP.back_off: limits that hold at every exported sample.

Oracles: the exported files themselves (every sample against the bounds, at the rate held
and at others), the Newton-Euler inverse dynamics of the exported motion, and the NLP's own
row bounds for the back-off.
"""

from __future__ import annotations

import time

import casadi as ca
import numpy as np
import pytest
from reference import newton_euler as ne

from model import DefinitionError, Dynamics, presets
from planner import OCP, SampleLimitError, Transcription, hold_at_samples, sample_misses, solve
from problems import GaitVerificationError, GaitVerificationWarning, walking_step

CHAIN = presets.n_link_chain(2)
DOWN = -np.pi / 2
LIMIT = 8.0  # N m: active over arcs of the swing (its motion needs 8.9 N m between points)


def swing(N=12):
    return (
        OCP(Dynamics(CHAIN), T=1.5, N=N)
        .initial(psi=[DOWN, DOWN], dpsi=0.0)
        .final(psi=[DOWN + 1.0, DOWN + 1.5], dpsi=0.0)
        .bound("M", -LIMIT, LIMIT)
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(t=[0.0, 1.5], psi=[[DOWN, DOWN], [DOWN + 1.0, DOWN + 1.5]])
    )


def _worst_torque(solution, rate_hz):
    trajectory = solution.to_trajectory(rate_hz)
    oracle = ne.inverse_dynamics(CHAIN, trajectory.psi, trajectory.dpsi, trajectory.ddpsi)
    np.testing.assert_allclose(trajectory.torques, oracle, atol=1e-9)
    return float(np.abs(trajectory.torques).max())


def test_a_bound_active_over_arcs_holds_at_every_rate_after_the_hold():
    ocp = swing()
    plain = ocp.solve(progress=False)
    # the transcription holds |M| <= 12 at its points; its exported motion needs more
    assert _worst_torque(plain, 1000.0) > LIMIT * (1 + 1e-4)
    assert sample_misses(plain, 1000.0)
    start = time.perf_counter()
    held = hold_at_samples(ocp, 1000.0, lambda p: solve(p, progress=False), plain)
    wall = time.perf_counter() - start
    record = held.stats["sampled_limits"]
    assert record["rounds"][0]["worst"] > 1e-4 and len(record["rounds"]) >= 2
    # every round says how long its checks took; with the re-solves' own build and solve
    # times (the first solve's were spent before the call) they fit in the call's wall time
    rounds = record["rounds"]
    assert all(r["check_seconds"] > 0 for r in rounds)
    parts = sum(r["check_seconds"] for r in rounds) + sum(
        r["build_seconds"] + r["solve_seconds"] for r in rounds[1:]
    )
    assert parts <= wall
    assert held.cost >= plain.cost - 1e-9  # backing off can only cost
    for rate in (100.0, 1000.0, 7000.0):  # held at 1 kHz and between the samples
        assert _worst_torque(held, rate) <= LIMIT * (1 + 1e-5), rate
    assert sample_misses(held, 1000.0) == []
    # backing off keeps the NLP (cutting an interval does not): a round after a back-off
    # restarts IPOPT from the multipliers of the one before
    rounds = record["rounds"]
    if rounds[-2]["split"] == 0:
        assert held.stats["warm_start"]
    if not any(r["split"] for r in rounds):
        assert held.nlp_signature == plain.nlp_signature
    problem = record["problem"]
    assert problem.margins  # the torque bounds backed off where the motion needed more
    for name, lower, upper, at_ends in problem.margins:
        assert name.startswith("M_link") and lower.shape == (problem.N, 1) and at_ends
        assert 0 < max(lower.max(), upper.max()) < 0.2 * LIMIT


def test_a_plan_without_misses_is_solved_once():
    ocp = swing().bound("M", -200, 200)
    plain = ocp.solve(progress=False)
    calls = []

    def counting(problem):
        calls.append(problem)
        return solve(problem, progress=False)

    held = hold_at_samples(ocp, 1000.0, counting, plain)
    assert held is plain and calls == []
    assert held.stats["sampled_limits"]["rounds"] == [
        {**held.stats["sampled_limits"]["rounds"][0], "raised": 0, "split": 0}
    ]


def test_rounds_run_out_loudly():
    ocp = swing()
    plain = ocp.solve(progress=False)
    with pytest.raises(SampleLimitError, match=r"still miss .* after 0 re-solves") as caught:
        hold_at_samples(ocp, 1000.0, lambda p: solve(p, progress=False), plain, max_rounds=0)
    assert caught.value.solution is plain and caught.value.misses
    assert caught.value.misses[0].name.startswith("bounds[M_link")


def test_back_off_tightens_the_rows_at_the_intervals_points():
    ocp = swing(N=4).constrain("lean", lambda p: p.psi[1] - p.psi[0], lower=-2.0, upper=2.0)
    margins = np.array([[0.0], [0.1], [0.2], [0.0]])
    backed = ocp.back_off("lean", upper=margins).back_off("M_link2", lower=np.full(4, 1.0))
    plain, tight = Transcription(ocp), Transcription(backed)
    assert plain.signature == tight.signature
    rows = [i for i, n in enumerate(tight.g_names) if n.startswith("path[lean]")]
    upper = tight.ubg[rows] * tight.g_scale[rows]
    # Hermite-Simpson: node 0, midpoint 0, node 1 (intervals 0 and 1: the larger), ...
    expected = 2.0 - np.array([0.0, 0.0, 0.1, 0.1, 0.2, 0.2, 0.2, 0.0, 0.0])
    np.testing.assert_allclose(upper, expected)
    columns = [i for i, n in enumerate(tight.w_names) if n.startswith("bound[M_link2]")]
    lower = tight.lbx[columns] * tight.w_scale[columns]
    np.testing.assert_allclose(lower, -LIMIT + 1.0)
    # a refined mesh drops the margins (they belong to the intervals of this one)
    assert backed.refine(N=8).margins == ()


def test_back_off_refuses_what_it_cannot_do():
    ocp = swing(N=4).constrain("pin", lambda p: p.psi[0], lower=0.0, upper=0.0)
    with pytest.raises(DefinitionError, match=r"no path constraint or variable called 'nope'"):
        ocp.back_off("nope", upper=np.zeros(4))
    with pytest.raises(DefinitionError, match=r"must have shape \(4, 1\)"):
        ocp.back_off("M_link1", upper=np.zeros(3))
    with pytest.raises(DefinitionError, match=r"margins must be >= 0"):
        ocp.back_off("M_link1", upper=-np.ones(4))
    with pytest.raises(DefinitionError, match=r"are equalities; an equality cannot be backed"):
        ocp.back_off("pin", upper=np.ones(4))


def test_the_walking_step_keeps_its_torques_within_the_limit_at_every_sample():
    # The case: a 0.8 m step whose torques.csv reached 153.5 N m against 150.
    step = walking_step(step_length=0.8)
    # unheld, the plan misses at its samples: solve() does not hand it out as a success
    with pytest.raises(GaitVerificationError, match=r"fails its own verification at 1000 Hz: "
                       r"torque bounds misses by [0-9.]+ N m at sample") as failed:  # fmt: skip
        step.solve(progress=False, hold_limits=False)
    plain = failed.value.gait
    assert plain.verified is False and not failed.value.report.ok
    assert np.abs(plain.to_trajectory(1000.0).torques).max() > 150.5
    with pytest.warns(GaitVerificationWarning, match=r"torque bounds misses by"):
        warned = step.solve(progress=False, hold_limits=False, raise_on_failure=False)
    assert warned.success and warned.verified is False
    unchecked = step.solve(progress=False, hold_limits=False, verify=False)
    assert unchecked.verified is None and unchecked.verification is None
    gait = step.solve(progress=False)
    # its first check cuts an interval and backs off the others' misses in the same round
    first = gait.solution.stats["sampled_limits"]["rounds"][0]
    assert first["split"] >= 1 and first["raised"] >= 1
    for rate in (1000.0, 4000.0):
        torques = gait.to_trajectory(rate).torques
        assert np.abs(torques).max() <= 150.0 * (1 + 1e-6), rate
        assert gait.verify(rate).ok
    assert gait.verified is True and gait.verification.ok


def test_a_gait_holds_its_limits_by_near_restarts_and_counts_a_failed_one(monkeypatch):
    """The walking step's hold rounds restart IPOPT near the last round's optimum
    (planner.NEAR_RESTART_IPOPT); a near restart that fails (here: stopped after one
    iteration) is solved again with the plain warm start, its round counting both tries'
    iterations, and the rounds end at the same plan."""
    import planner.solver as solver_module

    near = walking_step().solve(progress=False)
    rounds = near.solution.stats["sampled_limits"]["rounds"]
    assert len(rounds) >= 2 and near.solution.stats["near_restart"]
    monkeypatch.setattr(
        solver_module, "NEAR_RESTART_IPOPT", {**solver_module.NEAR_RESTART_IPOPT, "max_iter": 1}
    )
    retried = walking_step().solve(progress=False)
    stats = retried.solution.stats
    assert stats["near_restart_failed"]["iterations"] == 1 and not stats["near_restart"]
    last = stats["sampled_limits"]["rounds"][-1]
    assert last["iterations"] == retried.solution.iterations + 1
    assert last["solve_seconds"] > stats["solve_seconds"]
    assert retried.cost == pytest.approx(near.cost, rel=1e-8)
    assert retried.verify().ok


def test_the_largest_excess_per_interval_is_the_motions_maximum_between_the_samples():
    """_excesses against brute force: the consistent motion's drives on 20000 points per
    interval. Near a bound the check times, the 16 points refined around each interval's
    worst one (shared by the rows worst at the same time) and the vertex of the parabola
    through the best of those find the maximum to 2e-7 N m (the coarse plan's peaks are
    sharp: 16 points alone missed one by 1.7e-5); far from it, the check times' maximum."""
    from planner.sampled_limits import _checked_rows, _excesses, check_times

    plain = swing().solve(progress=False)
    blocks = _checked_rows(plain.ocp)
    excesses = _excesses(plain, blocks, check_times(plain, 1000.0), 16)
    fine = np.linspace(0.0, 1.0, 20001)
    nodes = plain.time
    refined = 0
    for b, block in enumerate(blocks):
        column = plain.system.control_names.index(block.source)
        for k in range(plain.N):
            # an interval holds its start node, the last one its end too
            within = fine if k == plain.N - 1 else fine[:-1]
            drive = plain.motion(nodes[k] + within * (nodes[k + 1] - nodes[k]))[2][:, column]
            for excess, brute in (
                (excesses[b][0][k, 0], -LIMIT - drive.min()),
                (excesses[b][1][k, 0], drive.max() - LIMIT),
            ):
                assert excess <= brute + 2e-7, (block.name, k)  # values of the motion
                if excess > -0.01 * block.scale[0]:  # near the bound: refined
                    assert excess == pytest.approx(brute, abs=2e-7), (block.name, k)
                    refined += 1
    assert refined >= 2  # the plain plan misses in two intervals: something to find
    assert max(e[1].max() for e in excesses) > 0.1


def test_cut_intervals_map_to_their_halves_and_carry_the_misses():
    from planner.sampled_limits import HALF, _carried, _parents, _split

    np.testing.assert_array_equal(_parents(5, {1, 4}), [0, 1, 1, 2, 3, 4, 4])
    missed = np.array([0.1, 0.2, 0.3, 0.4, 0.5])
    stuck = np.array([1, 1, 0, 2, 1])
    carried_missed, carried_stuck = _carried((missed, stuck), {1, 4})
    np.testing.assert_array_equal(carried_missed, [0.1, 0.2, 0.2, 0.3, 0.4, 0.5, 0.5])
    # the halves are marked as such; the others keep their count under their new numbers
    np.testing.assert_array_equal(carried_stuck, [1, HALF, HALF, 0, 2, HALF, HALF])
    ocp = swing(N=4).back_off("M_link1", upper=np.array([0.1, 0.2, 0.3, 0.4]))
    cut = _split(ocp, {0, 2})
    assert cut.N == 6
    np.testing.assert_allclose(np.diff(np.r_[0.0, np.cumsum(cut.mesh)]) * 8, [1, 1, 2, 1, 1, 2])
    ((name, lower, upper, at_ends),) = cut.margins
    assert name == "M_link1" and at_ends and not lower.any()
    np.testing.assert_array_equal(upper[:, 0], [0.1, 0.1, 0.2, 0.3, 0.3, 0.4])


def test_a_miss_is_stuck_when_a_round_does_not_halve_it():
    """A miss that backing off leaves above half of itself counts a stuck round; its
    interval is cut after two such rounds, after one in the end intervals of a row pinned
    at the phase's ends (its end points take no margin), never below the floor."""
    from planner.sampled_limits import BARRED, HALF, STUCK_ROUNDS, _stuck

    assert STUCK_ROUNDS == 2
    before = (np.array([1e-3, 1e-3, 1e-3, 1e-3]), np.array([0, 1, 0, 0]))
    missed = np.array([0.8e-3, 0.6e-3, 0.4e-3, 0.9e-3])
    stuck, cut = _stuck(missed, before, 1e-4, 1e-7, pinned=False)
    np.testing.assert_array_equal(stuck, [1, 2, 0, 1])
    np.testing.assert_array_equal(cut, [False, True, False, False])
    stuck, cut = _stuck(missed, before, 1e-4, 1e-7, pinned=True)
    np.testing.assert_array_equal(cut, [True, True, False, True])  # the ends at once
    stuck, cut = _stuck(missed, before, 1e-2, 1e-7, pinned=True)  # all below the floor
    assert not stuck.any() and not cut.any()
    stuck, cut = _stuck(missed, None, 1e-4, 1e-7, pinned=True)  # a first round
    assert not stuck.any() and not cut.any()
    # Halves of cut intervals: one that misses less than half of what its interval did
    # starts counting afresh; one that misses as much is barred from more cuts (at a pinned
    # end point itself: the step on feet at 1.4 m/s cut its heel rise's first interval 18
    # times before this), and stays barred.
    before = (np.array([1e-3, 1e-3, 1e-3, 1e-3]), np.array([HALF, HALF, BARRED, BARRED]))
    missed = np.array([0.4e-3, 0.9e-3, 0.9e-3, 0.1e-3])
    stuck, cut = _stuck(missed, before, 1e-4, 1e-7, pinned=True)
    np.testing.assert_array_equal(stuck, [0, BARRED, BARRED, BARRED])
    assert not cut.any()
