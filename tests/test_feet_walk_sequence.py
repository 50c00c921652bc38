"""A walk through speeds on feet as one file (problems.library.sequence with feet=True,
problems.library.feet_closed_loop, `walk --speeds --preset six-link-feet`).

Oracles: each step's own exported samples (the file's rows of step j are step j's samples
on the walk's clock), the leg swap written out by hand (each boundary of the file, from its
rows and the sidecar's last samples), a row moved by a known angle (the join check fails by
it), a step's drive law evaluated by the law object itself (the file's K rows reproduce it for
a state off the plan), and MuJoCo walking the file's steps."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from model.linkage_trajectory import LinkageTrajectory
from model.rerooting import swap_legs
from planner.errors import DefinitionError, DefinitionTypeError
from planner.trajectory import Trajectory
from problems.cli import main
from problems.library.feet_closed_loop import sequence_laws, with_feet_laws
from problems.library.sequence import (
    SequenceStep,
    WalkSequence,
    plan_sequence,
    verify_sequence,
)

RATE_HZ = 200.0


@pytest.fixture(scope="module")
def walk(footed_gait):
    """Three periodic steps on feet at 1 m/s as a walk (no transition to solve)."""
    steps, clock, foothold = [], 0.0, 0.0
    for _ in range(3):
        steps.append(SequenceStep("gait", footed_gait, clock, foothold))
        clock += footed_gait.duration
        foothold += footed_gait.problem.step_length
    return WalkSequence((1.0, 1.0), {1.0: footed_gait}, (), tuple(steps))


def _copy(trajectory: LinkageTrajectory, **replaced) -> LinkageTrajectory:
    """``trajectory`` with its angles or rates replaced, every other channel kept."""
    psi = replaced.get("psi", trajectory.psi)
    dpsi = replaced.get("dpsi", trajectory.dpsi)
    out = LinkageTrajectory.from_linkage(
        trajectory.time, psi, dpsi, trajectory.torques, trajectory.link_names,
        metadata=trajectory.metadata,
    )  # fmt: skip
    for name, (values, unit) in trajectory.extras.items():
        out = out.with_extra(name, values, unit)
    return LinkageTrajectory.of(out)


def test_a_walk_on_feet_is_its_steps_samples_on_one_clock(walk, footed_gait, tmp_path):
    path = walk.trajectory(RATE_HZ).save(tmp_path / "sequence.csv")
    back = LinkageTrajectory.of(Trajectory.load(path))
    own = LinkageTrajectory.of(footed_gait.exported(RATE_HZ))
    K = own.time.size
    assert back.time.size == 3 * (K - 1) + 1 and np.all(np.diff(back.time) > 0)
    step = np.asarray(back.extras["step"][0])
    described = back.metadata["sequence"]["steps"]
    for j in range(3):
        rows = np.flatnonzero(step == j)
        keep = K if j == 2 else K - 1
        np.testing.assert_allclose(back.time[rows], walk.steps[j].start + own.time[:keep],
                                   rtol=0, atol=1e-12)  # fmt: skip
        np.testing.assert_allclose(back.psi[rows], own.psi[:keep], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(back.torques[rows], own.torques[:keep], rtol=1e-12, atol=1e-9)
        for name in ("F_swing_heel_x", "F_swing_heel_y", "CoP_stance_foot_start_x"):
            np.testing.assert_allclose(back.extras[name][0][rows], own.extras[name][0][:keep],
                                       rtol=1e-12, atol=1e-9)  # fmt: skip
        # the sidecar's last sample of the step is the step's own last, before the leg swap
        last = described[j]["before_impact"]
        np.testing.assert_allclose(last["x"], np.r_[own.psi[-1], own.dpsi[-1]], atol=1e-12)
        assert last["extras"]["F_swing_heel_y"] == pytest.approx(
            own.extras["F_swing_heel_y"][0][-1]
        )
        np.testing.assert_allclose(np.asarray(back.extras["foothold_x"][0])[rows],
                                   j * footed_gait.problem.step_length)  # fmt: skip
        assert described[j]["phases"] and len(described[j]["settings"]["before_events"]) == 2
    # every boundary: the hand-written leg swap of the step's last sample is the next's first
    swap = swap_legs(footed_gait.problem.linkage)
    n = footed_gait.problem.linkage.n
    for j, k in itertools.pairwise(range(3)):
        x = np.asarray(described[j]["before_impact"]["x"])
        psi, dpsi = swap.map_state(x[:n], x[n:])
        first = np.flatnonzero(step == k)[0]
        np.testing.assert_allclose(back.psi[first], psi, atol=1e-9)
        np.testing.assert_allclose(back.dpsi[first], dpsi, atol=1e-9)


def test_a_walk_on_feet_verifies_from_its_file_and_a_wrong_join_fails(walk, tmp_path):
    path = walk.trajectory(RATE_HZ).save(tmp_path / "sequence.csv")
    back = LinkageTrajectory.of(Trajectory.load(path))
    report = verify_sequence(back, walk.linkage)
    assert report.ok, str(report)
    assert report.worst("join angles") > -1e-9 and report.worst("join rates") > -1e-9
    assert {"heel held", "impact momentum", "centre of pressure"} <= {
        c.name for c in report.reports[1].checks
    }
    assert "join rates" in str(report) and "foot at rest" not in str(report)
    # step 2's first row 1 mrad off in one angle: step 1's join names it, by that much
    row = int(np.flatnonzero(np.asarray(back.extras["step"][0]) == 2)[0])
    psi = np.array(back.psi)
    psi[row, 3] += 1e-3
    broken = verify_sequence(_copy(back, psi=psi), walk.linkage)
    assert broken.reports[0].ok and not broken.reports[1].ok
    assert broken.reports[1]["join angles"].margin == pytest.approx(-1e-3, abs=1e-9)
    assert [c.name for c in broken.reports[1].failures] == ["join angles"]
    # the front foot's force dropped from the file: the double support's dynamics fail by name
    dropped = LinkageTrajectory.of(back)
    extras = {k: v for k, v in dropped.extras.items() if not k.startswith("F_swing_heel")}
    from dataclasses import replace

    report = verify_sequence(replace(dropped, extras=extras), walk.linkage)
    assert not report.ok
    assert all("dynamics" in [c.name for c in r.failures] for r in report.reports)


def test_the_files_law_is_each_steps_drive_law(walk):
    laws = sequence_laws(walk, rate_hz=1000.0)
    assert laws[0] is laws[1] is laws[2]  # one law per distinct plan
    trajectory = with_feet_laws(walk, laws, rate_hz=1000.0)
    n = walk.linkage.n
    names = walk.linkage.names
    states = [f"psi_{a}" for a in names] + [f"dpsi_{a}" for a in names]
    step = np.asarray(trajectory.extras["step"][0])
    rng = np.random.default_rng(5)
    described = trajectory.metadata["sequence"]["steps"]
    assert trajectory.metadata["feedback"]["law"].startswith("M = clip")
    for j in range(3):
        assert described[j]["law"]["hip_ahead_m"] == list(laws[j].references[0].hip_range)
        rows = np.flatnonzero(step == j)
        for row in rows[[10, 100, -50]]:  # single support, single support, double support
            branch = int(trajectory.extras["double_support"][0][row])
            gain = np.array([[trajectory.extras[f"K_{a}__{s}"][0][row] for s in states]
                             for a in names])  # fmt: skip
            x = np.r_[trajectory.psi[row], trajectory.dpsi[row]]
            off = np.r_[np.zeros(n), rng.normal(scale=0.05, size=n)]  # rates only: same phase
            mine = trajectory.torques[row] + gain @ (-off)
            theirs = laws[j].torques(branch, x + off)
            # the drives (the root's torque is the ground's: the law leaves it 0)
            np.testing.assert_allclose(mine[1:], theirs[1:], rtol=1e-6, atol=1e-6)
            assert trajectory.extras["phase"][0][row] == pytest.approx(laws[j].phase(x[:n]))


def test_a_walk_on_feet_refuses_a_library_that_is_not_one_and_laws_of_other_steps(footed_gait):
    from types import SimpleNamespace

    walk = SimpleNamespace(steps=[SimpleNamespace(gait=object())])
    with pytest.raises(DefinitionError, match="a walk on feet"):
        sequence_laws(walk)
    with pytest.raises(DefinitionTypeError, match=r"`library`: a problems\.library\.GaitLibrary"):
        plan_sequence([1.0, 0.6], feet=True, library=object())


@pytest.mark.slow
def test_walk_speeds_on_feet_writes_one_verified_file_and_walks_it(tmp_path, capsys):
    """`walk --speeds 1.0,0.6 --preset six-link-feet --feedback`: the gaits (bounded at
    10 rad/s), the change, one file verified read back, every boundary the leg swap (from the
    file, by hand), MuJoCo walking every step in its three cases."""
    folder = tmp_path / "walk"
    status = main(["walk", "--preset", "six-link-feet", "--speeds", "1.0,0.6",
                   "--steps-at-speed", "2", "--feedback", "--no-gif", "--rate-hz", "500",
                   "--output-dir", str(folder)])  # fmt: skip
    out = capsys.readouterr().out
    assert status == 0, out
    back = LinkageTrajectory.of(Trajectory.load(folder / "sequence.csv"))
    meta = back.metadata["sequence"]
    kinds = [s["kind"] for s in meta["steps"]]
    assert kinds[:2] == ["gait", "gait"] and kinds[-2:] == ["gait", "gait"] and "change" in kinds
    assert all(s["settings"]["speed_limit"] == 10.0 for s in meta["steps"])
    report = verify_sequence(back, plan_linkage(back))
    assert report.ok, str(report)
    assert all("joint speeds" in [c.name for c in r.checks] for r in report.reports)
    swap = swap_legs(plan_linkage(back))
    n = len(back.link_names)
    step = np.asarray(back.extras["step"][0])
    for j in range(len(kinds) - 1):
        x = np.asarray(meta["steps"][j]["before_impact"]["x"])
        psi, dpsi = swap.map_state(x[:n], x[n:])
        first = np.flatnonzero(step == j + 1)[0]
        np.testing.assert_allclose(back.psi[first], psi, atol=1e-9)
        np.testing.assert_allclose(back.dpsi[first], dpsi, atol=1e-9)
    for picture in ("sequence.png", "walk.png"):
        assert (folder / picture).stat().st_size > 10_000
    # the robot's view of the walk: the file's rows, the sides alternating, each step's law
    joints = np.genfromtxt(folder / "joints.csv", delimiter=",", names=True)
    np.testing.assert_allclose(joints["t_s"], back.time, atol=1e-12)
    np.testing.assert_array_equal(joints["stance_right"], (step % 2 == 0).astype(float))
    assert any(name.startswith("K_right_knee__") for name in joints.dtype.names)
    import importlib.util

    count = len(kinds)  # every case walks every step, in the product's simulation and MuJoCo
    simulations = 2 if importlib.util.find_spec("mujoco") is not None else 1
    assert out.count(f"{count}/{count} steps") == 3 * simulations and "(fell)" not in out, out
    if simulations == 2:
        assert (folder / "mujoco_walk.png").exists()


def plan_linkage(trajectory):
    """The walker the file states (its metadata's model)."""
    from model.linkage import Linkage

    return Linkage.from_parameters(trajectory.metadata["model"])
