"""problems.verify_gait verifies the physics of a gait file, whatever rows its OCP had.

Oracles: the Newton-Euler recursion of tests/reference (the torques of the file against the
inverse dynamics of its motion), and files tampered with by hand: each tampering the issue
found passing (torques x1.1, +10 N m on the torso, the torso and head columns swapped, ddpsi
x1.1, time x1.1), also after a CSV round trip, and more.
"""

from __future__ import annotations

import numpy as np
import pytest
from reference import newton_euler as ne

from model import LinkageTrajectory, presets
from planner import Trajectory
from planner.errors import DefinitionError
from problems import verify_gait, walking_step
from problems.gait.verification import RATES_DENSITY, _Kinematics

SIX = presets.six_link_anthropoid()


@pytest.fixture(scope="module")
def gait():
    return walking_step().solve(progress=False)


@pytest.fixture(scope="module")
def profile(gait):
    return gait.to_trajectory(1000.0)


def rebuilt(trajectory, *, time=None, states=None, controls=None, extras=None, metadata=None):
    return Trajectory(
        trajectory.time if time is None else time,
        trajectory.states if states is None else states,
        trajectory.controls if controls is None else controls,
        trajectory.state_names,
        trajectory.state_units,
        trajectory.control_names,
        trajectory.control_units,
        dict(trajectory.extras) if extras is None else extras,
        trajectory.metadata if metadata is None else metadata,
    )


def test_the_inverse_dynamics_of_the_verification_is_newton_eulers():
    rng = np.random.default_rng(5)
    for linkage in (SIX, presets.five_link_biped(), presets.n_link_chain(4)):
        psi, dpsi, ddpsi = (rng.normal(size=(7, linkage.n)) for _ in range(3))
        mine = _Kinematics(linkage).inverse_dynamics(psi, dpsi, ddpsi)
        oracle = ne.inverse_dynamics(linkage, psi, dpsi, ddpsi)
        np.testing.assert_allclose(mine, oracle, rtol=1e-12, atol=1e-12 * np.abs(oracle).max())


def test_the_file_a_gait_writes_passes_and_is_its_own_inverse_dynamics(gait, profile, tmp_path):
    report = verify_gait(profile, SIX)
    assert report.ok, str(report)
    assert report.facts["samples"] == 501
    assert report.facts["dynamics residual"] < 1e-9
    names = {c.name for c in report.checks}
    assert {"dynamics", "kinematics", "rates", "ground", "centre of pressure"} <= names
    # the oracle agrees: every sample's torques are the inverse dynamics of its motion
    oracle = ne.inverse_dynamics(SIX, profile.psi, profile.dpsi, profile.ddpsi)
    assert np.abs(profile.torques - oracle).max() < 1e-9
    # a CSV read back (header and rows only, the rest in its sidecar) verifies the same
    back = LinkageTrajectory.load(profile.save(tmp_path / "torques.csv"))
    assert verify_gait(back, SIX).ok
    # and so do other rates: the limits hold between the samples too
    for rate in (250.0, 3000.0):
        assert gait.verify(rate).ok, rate


TAMPERED = {
    "torques x1.1": (lambda p: {"controls": p.controls * 1.1}, {"dynamics"}),
    "+10 N m on the torso": (
        lambda p: {"controls": p.controls + 10.0 * (np.array(SIX.names) == "torso")},
        {"dynamics"},
    ),
    "torso and head swapped": (
        lambda p: {"controls": p.controls[:, [0, 1, 2, 3, 5, 4]]},
        {"dynamics"},
    ),
    "ddpsi x1.1": (
        lambda p: {
            "extras": {
                k: (v * 1.1 if k.startswith("ddpsi") else v, u) for k, (v, u) in p.extras.items()
            }
        },
        {"dynamics", "rates"},
    ),
    "time x1.1": (lambda p: {"time": p.time * 1.1}, {"duration", "kinematics", "rates"}),
    "dpsi x1.02": (
        lambda p: {"states": np.hstack([p.states[:, :6], 1.02 * p.states[:, 6:]])},
        {"kinematics", "dynamics"},
    ),
    "the head 1 mrad off": (
        lambda p: {"states": p.states + 1e-3 * (np.arange(12) == 5)},
        {"dynamics"},
    ),
    "torques negated": (lambda p: {"controls": -p.controls}, {"dynamics"}),
    "half the samples": (
        lambda p: {
            "time": p.time[::2],
            "states": p.states[::2],
            "controls": p.controls[::2],
            "extras": {k: (v[::2], u) for k, (v, u) in p.extras.items()},
        },
        set(),
    ),
}


@pytest.mark.parametrize("name", list(TAMPERED))
@pytest.mark.parametrize("round_trip", [False, True])
def test_tampered_files_fail(profile, tmp_path, name, round_trip):
    change, failing = TAMPERED[name]
    tampered = rebuilt(profile, **change(profile))
    if round_trip:
        tampered = LinkageTrajectory.load(tampered.save(tmp_path / "tampered.csv"))
    report = verify_gait(tampered, SIX)
    failed = {c.name for c in report.failures}
    if failing:
        assert failing <= failed, (name, failed)
    else:  # a coarser sampling of a consistent file is no tampering
        assert report.ok, (name, failed)


def test_a_plan_with_its_knees_under_the_ground_fails():
    # What the walking step planned before the ground rows (and the sole and the touchdown
    # speed): a 1.0 m step with no point of the body kept above the ground brings both knees
    # 0.13-0.17 m under it.
    step = walking_step(step_length=1.0, ground_points=(), touchdown_speed=0.0, foot=None)
    gait = step.solve(progress=False, hold_limits=False, verify=False)
    report = verify_gait(gait.to_trajectory(1000.0), SIX, settings={"ground_points": None})
    ground = report["ground"]
    assert not ground.passed and ground.margin < -0.05, str(report)
    # with them (the default), the step keeps every point up or says it cannot
    held = walking_step(step_length=1.0).solve(progress=False)
    assert held.verify().ok


def test_passive_joints_and_the_centre_of_pressure(gait, profile):
    # the ankle's torque over the stance foot's normal force stays on the sole
    settings = profile.metadata["gait"]
    heel, toe = settings["foot"]
    low, high = verify_gait(profile, SIX).facts["centre of pressure"]
    assert -heel - 1e-6 <= low <= high <= toe + 1e-6  # within the rows' tolerance
    # a shorter sole than the plan used is missed where the plan uses the heel
    report = verify_gait(profile, SIX, settings={"foot": [0.02, 0.15]})
    assert [c.name for c in report.failures] == ["centre of pressure"]
    # a passive ankle that carries the plan's torque is reported
    report = verify_gait(profile, SIX, settings={"passive": ["stance_shank"]})
    assert "passive joints" in {c.name for c in report.failures}


def test_coarse_samples_skip_the_rates_check_and_say_so(gait):
    nodes = gait.to_trajectory()
    report = verify_gait(nodes, SIX)
    assert report.ok and "rates" not in {c.name for c in report.checks}
    assert f"at least {RATES_DENSITY} per interval" in report.facts["rates"]


def test_what_is_checked_is_reported(profile):
    report = verify_gait(profile, SIX)
    for check in report.checks:
        assert check.samples >= 1 and check.where and check.unit
    dynamics = report["dynamics"]
    assert dynamics.samples == 501 * 6 and dynamics.where.startswith("sample ")
    assert "ok   dynamics" in str(report)


def test_a_torque_limit_given_as_one_number_bounds_every_drive(profile):
    """settings={"torque_limit": 20.0} (a number, as walking_step takes it) bounds every
    hinge: before, it raised AttributeError ('float' object has no attribute 'values')."""
    peak = float(np.max(np.abs(profile.torques)))  # 52.9 N m at the stance thigh
    report = verify_gait(profile, SIX, settings={"torque_limit": 20.0})
    bounds = report["torque bounds"]
    assert not bounds.passed and bounds.margin == pytest.approx(20.0 - peak, abs=1e-9)
    every = dict.fromkeys(SIX.names, 20.0)
    as_mapping = verify_gait(profile, SIX, settings={"torque_limit": every})
    assert as_mapping["torque bounds"].margin == bounds.margin
    assert verify_gait(profile, SIX, settings={"torque_limit": 150}).ok
    for bad, said in (
        (-1.0, r"got -1.0 for 'stance_shank'"),
        ("20", r"got '20' for 'stance_shank'"),
        (float("nan"), r"got nan"),
        ({"knee": 20.0}, r"no links \['knee'\] in the linkage"),
    ):
        with pytest.raises(DefinitionError, match=r"`settings\['torque_limit'\]`: .*" + said):
            verify_gait(profile, SIX, settings={"torque_limit": bad})


def test_a_file_without_its_sidecar_is_named_as_such(tmp_path, profile):
    """A torques.csv whose sidecar was not copied with it: read by the planner's generic
    reader every column is a state; both that and verify_gait say the sidecar is missing
    (before: 'does not follow the linkage convention', and 'say which gait this is')."""
    from planner.trajectory.formats import sidecar_path

    path = tmp_path / "torques.csv"
    profile.save(path)
    sidecar_path(path).unlink()
    with pytest.raises(Exception, match=r"read without its sidecar <file>.csv.meta.json, which "
                       r"holds the column groups"):  # fmt: skip
        verify_gait(Trajectory.load(path), SIX)
    with pytest.raises(DefinitionError, match=r"a torques.csv read without its sidecar "
                       r"torques.csv.meta.json has none: put the sidecar back"):  # fmt: skip
        verify_gait(LinkageTrajectory.load(path), SIX)
    # with it, the same file verifies
    profile.save(path)
    assert verify_gait(Trajectory.load(path), SIX).ok
