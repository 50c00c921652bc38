"""Steps on feet of other contact sequences (``footed_step(phases=...)``): flat-footed (no heel
rise: the stance foot welded flat until toe-off, the heel strike with the rear foot flat) and
toe walking (on the balls of the feet: the swing ball strikes and holds).

Oracles: the independent numpy verification (``verify_gait``: each phase's contacts at every
sample, the strike's momentum balances solved by least squares with the rear foot's angular
impulse as an unknown), the conservation of momentum over a periodic step (the ground's
impulses, continuous and at the strike, sum to the weight times the step time and to no
horizontal push), files tampered with by hand, which it must refuse.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from model import DefinitionError, LinkageTrajectory, presets
from planner import Trajectory
from problems import verify_gait
from problems.walking.footed import SEQUENCES, footed_step

FEET = presets.anthropoid_with_feet()
#: Coarser meshes than the defaults (the command line's --quick): the suite's time.
MESHES = {"flat-footed": (20, 20), "toe-walking": (20, 8)}


@pytest.fixture(scope="module", params=sorted(MESHES))
def gait(request):
    name = request.param
    return footed_step(phases=name, N=MESHES[name]).solve()


@pytest.fixture(scope="module")
def profile(gait):
    return gait.to_trajectory(1000.0)


def test_each_sequence_solves_beats_its_law_and_verifies_at_every_sample(gait, profile):
    step = gait.problem
    assert gait.success and gait.cost < gait.law_cost / 100
    assert [p for p, _ in step.phases.phases] == list(step.sequence)
    assert math.isclose(sum(gait.durations()), step.step_time, rel_tol=1e-9)
    report = verify_gait(profile, FEET)
    assert report.ok, str(report)
    names = {c.name for c in report.checks}
    common = {"clearance", "heel strike", "landing", "impact momentum", "impulse cones",
              "centre of pressure", "dynamics", "friction cone", "periodic angles",
              "ankles"}  # fmt: skip
    assert common <= names
    if step.sequence == SEQUENCES["flat-footed"]:
        assert step.strike_role == "swing_heel" and step.rear_flat
        assert {"impulse pressure", "heel held", "front ball up", "front foot flat"} <= names
        # flat until toe-off: the stance foot never turns, and carries no ball-only torque
        flat = next(c for c in report.checks if c.name == "stance foot flat")
        assert flat.samples == profile.time.size
        assert np.max(np.abs(profile.psi[:, 0] - step.flat_angles[0])) < 1e-9
    else:
        assert step.strike_role == "swing_toe" and not step.rear_flat
        assert {"ball held", "front heel up", "front ball cone", "ball passive"} <= names
        assert "front foot flat" not in names and "impulse pressure" not in names
        # on the ball: the stance heel above the ground at every sample, the ball's torque 0
        # at the nodes and within the passive tolerance between them (the file's torques are
        # its motion's inverse dynamics)
        heel = step.point("stance_heel").position(profile.psi).imag
        assert heel.min() > -1e-9
        assert np.max(np.abs(profile.torques[:, 0])) < 0.01 * step.torque_limit
        # the front foot's force is named after its ball
        assert {"F_swing_toe_x", "F_swing_toe_y"} <= set(profile.extras)


def test_momentum_over_the_periodic_step(gait):
    """Over a periodic step the body's momentum comes back: the ground's vertical impulse
    (both feet's forces and the strike's impulses) is m g T, its horizontal one 0."""
    step = gait.problem
    n = step.linkage.n
    impulse = 0j
    for solution, _ in gait.segments():
        times = np.linspace(0.0, solution.T, 4001)
        x, xdot, _ = solution.motion(times)
        impulse += np.trapezoid(step.dynamics.ground_reaction(x[:, :n], x[:, n:], xdot[:, n:]),
                                times)  # fmt: skip
    before = gait.segments()[-2][0].states[-1]  # the single support's end
    after = np.asarray(step.strike.state_function()(before)).ravel()
    momentum = step.dynamics.floating.function("linear_momentum")
    change = (np.asarray(momentum(before[:n], np.r_[0, 0, after[n:]])).ravel()
              - np.asarray(momentum(before[:n], np.r_[0, 0, before[n:]])).ravel())  # fmt: skip
    impulse += complex(*change)
    weight_time = step.biped.total_mass * step.linkage.gravity * step.step_time
    assert impulse.imag == pytest.approx(weight_time, rel=2e-5)
    assert abs(impulse.real) < 2e-5 * weight_time


def _tampered(profile, tmp_path, states=None, controls=None):
    changed = Trajectory(profile.time, profile.states if states is None else states,
                         profile.controls if controls is None else controls,
                         profile.state_names, profile.state_units, profile.control_names,
                         profile.control_units, dict(profile.extras), profile.metadata)  # fmt: skip
    return LinkageTrajectory.load(changed.save(tmp_path / "tampered.csv"))


def test_tampered_files_fail(gait, profile, tmp_path):
    step = gait.problem
    late = profile.time > gait.durations()[0] + 0.5 * gait.durations()[-1]  # in the double
    if step.rear_flat:
        # the rear foot tilted 1 mrad in the double support: it must lie flat until toe-off
        states = profile.states - 1e-3 * (np.arange(16) == 0) * late[:, None]
        failing = {"stance foot flat"}
        tampered = _tampered(profile, tmp_path, states=states)
    else:
        # a torque at the ball: a toe walker's ball is a pivot
        controls = profile.controls + 5.0 * (np.arange(8) == 0) * late[:, None]
        failing = {"ball passive", "dynamics"}
        tampered = _tampered(profile, tmp_path, controls=controls)
    failed = {c.name for c in verify_gait(tampered, FEET).failures}
    assert failing <= failed, failed


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"phases": "hopping"}, r"`phases`: one of \['flat-footed', 'human', 'toe-walking'\]"),
        ({"phases": ("double", "flat")}, r"`phases`: a sequence of contact phases the step "
                                         r"knows .*got \('double', 'flat'\)"),
        ({"phases": "flat-footed", "durations": (0.2, 0.2, 0.1)},
         r"`durations`: \(flat, double\) s summing to step_time"),
        ({"phases": "toe-walking", "N": (10, 6, 8)}, r"`N`: 2 interval counts >= 2 \(heel "
                                                     r"rise, double\)"),
    ],
)  # fmt: skip
def test_bad_sequences_are_refused_naming_the_field(kwargs, match):
    with pytest.raises(DefinitionError, match=match):
        footed_step(**kwargs)


def test_the_drives_law_follows_each_sequence_and_walks_it_in_mujoco(gait):
    """``FeetLaw``: the single support's reference runs through the sequence's single-support
    phases (their durations summed, at 1 kHz), the double support's through its own; each
    plan walks 20 steps in MuJoCo under it (its sequence's default gains: toe walking's fall
    in the seventh step with the others', examples/feet.md), each step within 5 % of the
    plan's length."""
    from problems.control.feet_law import FeetLaw

    durations = gait.durations()
    single, double = FeetLaw(gait).references
    assert single.time[-1] - single.time[0] == pytest.approx(sum(durations[:-1]), abs=1e-9)
    assert double.time[-1] - double.time[0] == pytest.approx(durations[-1], abs=1e-9)
    assert np.all(np.diff(single.time) > 0)
    pytest.importorskip("mujoco")
    from problems.control.mujoco_feet import run_feet_in_mujoco

    run = run_feet_in_mujoco(gait, steps=20)
    assert run.fell is None and run.walked == 20, run.fell
    lengths = np.array([s.length for s in run.steps])
    assert np.all(np.abs(lengths / gait.problem.step_length - 1.0) < 0.05), lengths


def test_the_rates_are_checked_in_every_phase_sampled_densely_enough(gait, profile, tmp_path):
    """The rates check (dpsi against the trapezoid of ddpsi between samples) needs several
    samples per mesh interval to bound the rule's error from the samples. Before, it ran on
    the whole file or not at all, and the flat-footed step's 30 ms double support on a fine
    mesh failed it spuriously (-1.5e-3 rad/s); now a phase sampled too thinly is left out
    and said so, and the others stay checked: rates bent inside the single support fail."""
    report = verify_gait(profile, FEET)
    assert report.facts["rates"].startswith("not checked in double"), report.facts["rates"]
    assert report["rates"].passed
    single = (profile.time > 0.1) & (profile.time < 0.2)
    states = profile.states + 0.05 * (np.arange(16) == 10) * single[:, None]  # a rate bent
    failed = {c.name for c in verify_gait(_tampered(profile, tmp_path, states=states),
                                          FEET).failures}  # fmt: skip
    assert "rates" in failed, failed
