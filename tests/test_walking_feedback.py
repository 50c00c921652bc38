"""The feedback in the file (problems.control.feedback): a drive that reads only torques.csv
(its reference, phase and gain columns) walks as the design does; and `walk --feedback`."""

from __future__ import annotations

import json

import numpy as np
import pytest

from model import LinkageTrajectory
from problems import walking_step
from problems.cli import main
from problems.control.feedback import LAW, design_feedback
from problems.control.lqr import LqrWeights, PeriodicGains, PhaseLQR
from problems.control.simulation import simulate_walking
from problems.control.tracking import GaitReference
from problems.gait.verification import verify_gait


@pytest.fixture(scope="module")
def designed():
    step = walking_step()
    gait = step.solve(progress=False)
    return step, gait, design_feedback(gait, ground_mu=1.0)


def test_the_file_carries_the_gains_at_each_samples_phase(designed, tmp_path):
    step, gait, feedback = designed
    names = step.linkage.names
    profile = feedback.channels(gait.to_trajectory(500.0))
    path = tmp_path / "torques.csv"
    profile.save(path)
    loaded = LinkageTrajectory.load(path)
    assert verify_gait(loaded, step.linkage).ok
    # the law is in the sidecar, where a drive's integrator reads the file's metadata
    assert LAW in json.dumps(json.loads((tmp_path / "torques.csv.meta.json").read_text()))
    assert loaded.metadata["feedback"]["law"] == LAW
    states = loaded.metadata["feedback"]["state"]
    assert states == [f"psi_{n}" for n in names] + [f"dpsi_{n}" for n in names]
    phase = np.asarray(loaded.extras["phase"][0])
    np.testing.assert_allclose(phase, [feedback.reference.phase(p) for p in loaded.psi], atol=1e-12)
    assert phase[0] == pytest.approx(0.0, abs=1e-12) and phase[-1] == pytest.approx(1.0, abs=1e-12)
    for k in (0, 137, len(phase) - 1):
        gain = feedback.controller.gain_at(phase[k])
        for i, hinge in enumerate(names):
            for j, state in enumerate(states):
                value = loaded.extras[f"K_{hinge}__{state}"][0][k]
                assert value == pytest.approx(gain[i, j], rel=1e-12, abs=1e-9)
    assert loaded.extras[f"K_torso__psi_{names[0]}"][1] == "N m/rad"
    assert loaded.extras[f"K_torso__dpsi_{names[0]}"][1] == "N m s/rad"


def test_a_drive_that_reads_only_the_file_walks(designed, tmp_path):
    step, gait, _ = designed
    names = step.linkage.names
    n = len(names)
    # the file at the controller's rate, as a drive would be given it
    feedback = design_feedback(gait, ground_mu=1.0)
    path = tmp_path / "torques.csv"
    feedback.channels(gait.to_trajectory(1000.0)).save(path)
    loaded = LinkageTrajectory.load(path)
    states = loaded.metadata["feedback"]["state"]
    table = np.stack(
        [
            np.column_stack([loaded.extras[f"K_{hinge}__{state}"][0] for state in states])
            for hinge in names
        ],
        axis=1,
    )  # (K, n, 2n)
    phases = np.asarray(loaded.extras["phase"][0])
    reference = GaitReference(loaded, step.dynamics, step.biped.stance_thigh)
    gains = PeriodicGains(phases[:-1], loaded.time[:-1], table[:-1], np.eye(2 * n), 0, LqrWeights())
    limits = loaded.metadata["feedback"]["limit_N_m"]
    drive = PhaseLQR(reference, gains, limits=limits)
    run = simulate_walking(
        reference.states[0], drive, linkage=step.linkage, step_time=step.step_time,
        step_length=step.step_length, mu=1.0, steps=10,
    )  # fmt: skip
    assert run.walked == 10, run.fell
    np.testing.assert_allclose([r.length for r in run.steps], step.step_length, rtol=1e-3)


@pytest.mark.slow
def test_walk_feedback_prints_the_closed_loop_and_writes_the_gains(tmp_path, capsys, monkeypatch):
    """examples/feedback.md's command, run as the guide writes it (test_readme leaves it to
    this test, which checks what it prints and writes, not only its exit status)."""
    import shlex

    from test_readme import ROOT, quoted_commands

    command = "walk --feedback"
    assert command in quoted_commands(ROOT / "examples" / "feedback.md")
    monkeypatch.chdir(tmp_path)
    assert main(shlex.split(command)) == 0
    (folder,) = tmp_path.glob("walk_*")  # the command's own new folder: walk_<date>_<time>
    text = capsys.readouterr().out
    assert "largest Floquet multipliers" in text
    assert "linearised along the plan, and simulated: step 0" in text
    assert "  plan             50/50" in text
    assert "  closed loop      20/20" in text  # MuJoCo (the test extra installs it)
    assert "  open loop         0/20  fell: step 0" in text
    assert (folder / "closed_loop.png").is_file()
    assert (folder / "closed_loop_walk.png").is_file()  # the run that took the largest push
    assert (folder / "closed_loop_walk.gif").is_file()  # its animation
    loaded = LinkageTrajectory.load(folder / "torques.csv")
    assert "K_torso__dpsi_head" in loaded.extras


@pytest.mark.slow
def test_walk_feedback_designs_a_double_support_steps_two_laws(tmp_path, capsys):
    folder = tmp_path / "out"
    argv = ["walk", "--feedback", "--double-support-s", "0.05", "--ground-friction", "1.5",
            "--no-gif", "--output-dir", str(folder)]  # fmt: skip
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "through the held heel strike and the lift-off" in text
    assert "  plan             50/50" in text
    # MuJoCo walks it too (the test extra installs it): 20 of 20 steps closed loop
    mujoco_table = text[text.index("MuJoCo (the same body") :]
    assert "  closed loop      20/20" in mujoco_table
    assert not list(folder.glob("*.gif"))  # --no-gif
    loaded = LinkageTrajectory.load(folder / "torques.csv")
    assert set(np.unique(loaded.extras["double_support"][0])) == {0.0, 1.0}
