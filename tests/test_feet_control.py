"""The drives' law of the step on feet (problems.control.feet_law) and its gains in the
torque file: the file's rows, read back from disk as a drive reads them, give the law's
torques (a matrix K (x_ref - x) against the law's joint PD on relative angles)."""

from __future__ import annotations

import numpy as np
import pytest

from model import LinkageTrajectory
from planner.errors import DefinitionError
from problems.control.feedback import LAW
from problems.control.feet_law import FEET_KD, FEET_KP, FeetLaw, feet_references


@pytest.fixture(scope="module")
def law(footed_gait):
    return FeetLaw(footed_gait)


@pytest.fixture(scope="module")
def file(footed_gait, law, tmp_path_factory):
    profile = law.channels(footed_gait.to_trajectory(1000.0))
    path = profile.save(tmp_path_factory.mktemp("feet") / "torques.csv")
    return LinkageTrajectory.load(path)


def test_the_references_split_at_the_heel_strike_and_share_one_phase(footed_gait):
    single, double = feet_references(footed_gait, 1000.0)
    flat, heel, _ = footed_gait.durations()
    assert single.duration == pytest.approx(flat + heel, abs=1e-12)
    assert single.phases[0] == pytest.approx(0.0, abs=1e-12)
    assert double.phases[-1] == pytest.approx(1.0, abs=1e-12)
    # the impact changes the rates, not the angles: the phase is continuous through it
    assert double.phases[0] == pytest.approx(single.phases[-1], abs=1e-12)
    assert np.all(np.diff(single.phases) > 0) and np.all(np.diff(double.phases) > 0)


def test_the_files_gains_give_the_laws_torques(footed_gait, law, file):
    """At samples of both branches, the state off the plan on the angles the phase does not
    read (swing leg, torso, head: the hip's place is the stance leg's) and on every rate: the
    file's M_ff + K (x_ref - x), K read from its columns, against FeetLaw.torques."""
    step = footed_gait.problem
    names = step.linkage.names
    n = len(names)
    states = [f"psi_{name}" for name in names] + [f"dpsi_{name}" for name in names]
    double = file.column("double_support")
    assert set(np.unique(double)) == {0.0, 1.0}
    assert np.all(np.diff(double) >= 0)  # one switch, at the heel strike
    rng = np.random.default_rng(11)
    samples = np.r_[rng.choice(np.flatnonzero(double == 0), 4),
                    rng.choice(np.flatnonzero(double == 1), 4)]  # fmt: skip
    for k in samples:
        reference = np.r_[file.psi[k], file.dpsi[k]]
        x = reference.copy()
        x[3:n] += rng.normal(scale=0.05, size=n - 3)
        x[n:] += rng.normal(scale=0.5, size=n)
        gains = np.array([[file.column(f"K_{h}__{s}")[k] for s in states] for h in names])
        from_file = file.torques[k] + gains @ (reference - x)
        from_file[0] = 0.0  # the ground's torque: no drive
        expected = law.torques(int(double[k]), x)
        np.testing.assert_allclose(from_file, expected, rtol=1e-9, atol=1e-6)
    feedback = file.metadata["feedback"]
    assert feedback["law"] == LAW
    # the root's gains are 0 as its K row (the ground's torque, no drive)
    assert feedback["kp"]["double"] == [0.0] + [FEET_KP] * (n - 1)
    assert feedback["kd"]["double"] == [0.0] + [FEET_KD] * (n - 1)
    assert "flat + heel rise" in feedback["branches"] and "swing heel's" in feedback["branches"]
    light = names.index(step.biped.swing_leg[-1])  # the swing foot: capped in single support
    assert feedback["kp"]["single"][light] < FEET_KP and feedback["kd"]["single"][light] < FEET_KD
    phase = file.column("phase")
    assert phase[0] == pytest.approx(0.0, abs=1e-9) and phase[-1] == pytest.approx(1.0, abs=1e-9)


def test_channels_refuse_a_trajectory_of_another_linkage(law):
    from problems import walking_step

    other = walking_step().solve().to_trajectory()
    with pytest.raises(DefinitionError, match="`trajectory`: 6 angles, the step on feet has 8"):
        law.channels(other)


def test_a_law_by_the_time_follows_its_plan_by_the_time_while_the_hip_stalls(footed_gait, law):
    """A plan whose hip stands still for its first 20 samples (the step's rows frozen there,
    as at a start from rest): the phase refuses it, ``by_time`` takes it; until the hip
    moves the PD law at a sample's time gives that sample's torque at its state, and
    M_ff + Kp R (q_ref - q) + Kd R (dq_ref - dq) (written out) away from it, its Jacobian
    the PD's alone; after, it reads the phase as before. A periodic step is followed by the
    phase, and its file says so."""
    import dataclasses

    from problems.control.tracking import GaitReference, PhasePD

    step = footed_gait.problem
    n = step.linkage.n
    plan = footed_gait.to_trajectory(1000.0)
    states = plan.states.copy()
    states[:20] = states[0]
    still = dataclasses.replace(plan, states=states)
    with pytest.raises(DefinitionError, match="does not move forward"):
        GaitReference(still, step.dynamics, step.biped.stance_thigh)
    reference = GaitReference(still, step.dynamics, step.biped.stance_thigh, by_time=True)
    assert reference.time_indexed_until == pytest.approx(plan.time[19] - plan.time[0])
    assert np.all(np.diff(reference.phases) > 0)
    pd = PhasePD(reference, step.linkage.parents, 800.0, 20.0, passive=(0,))
    k = 12
    t, x, torque = reference.time[k], reference.states[k], reference.torques[k]
    np.testing.assert_allclose(pd.torques(t, x)[1:], torque[1:], rtol=0, atol=1e-12)
    off = x + np.random.default_rng(5).normal(scale=0.02, size=2 * n)
    relative = np.eye(n)
    for i, parent in enumerate(step.linkage.parents):
        if parent >= 0:
            relative[i, parent] = -1.0
    error = x - off
    by_hand = torque + 800.0 * relative @ error[:n] + 20.0 * relative @ error[n:]
    np.testing.assert_allclose(pd.torques(t, off)[1:], by_hand[1:], rtol=1e-12, atol=1e-9)
    pd_alone = -np.hstack([800.0 * relative, 20.0 * relative])
    np.testing.assert_allclose(pd.jacobian(t, off)[1:], pd_alone[1:], rtol=0, atol=1e-12)
    # past the stall: by the phase, the same as a law of the plan itself there
    phased = PhasePD(GaitReference(plan, step.dynamics, step.biped.stance_thigh),
                     step.linkage.parents, 800.0, 20.0, passive=(0,))  # fmt: skip
    late = reference.states[200] + 0.01
    np.testing.assert_allclose(pd.torques(0.2, late), phased.torques(0.2, late), atol=1e-9)
    assert law.indexed_by == "phase"
    trajectory = law.channels(footed_gait.to_trajectory(1000.0))
    assert trajectory.metadata["feedback"]["indexed_by"] == "phase"
