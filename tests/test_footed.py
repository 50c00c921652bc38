"""The walking step on feet (problems.walking.footed): heel strike, flat foot, heel rise, toe-off.

Oracles: the Newton-Euler recursion of tests/reference (the file's torques against the inverse
dynamics of its motion, the front heel's force added by hand in the double support), the
conservation of momentum over a periodic step (the ground's impulses, continuous and at heel
strike, sum to the weight times the step time and to no horizontal push), the independent
numpy verification (``verify_gait``) and files tampered with by hand, which it must refuse.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from reference import newton_euler as ne

from model import DefinitionError, LinkageTrajectory, presets
from planner import Trajectory
from problems import verify_gait, walking_step
from problems.walking.footed import PHASES, footed_step

FEET = presets.anthropoid_with_feet()


@pytest.fixture(scope="module")
def gait(footed_gait):
    return footed_gait


@pytest.fixture(scope="module")
def step(gait):
    return gait.problem


@pytest.fixture(scope="module")
def profile(gait):
    return gait.to_trajectory(1000.0)


def test_the_step_on_feet_solves_beats_its_law_and_verifies_at_every_sample(step, gait, profile):
    assert gait.success
    assert gait.cost < gait.law_cost / 100  # the law with flat feet is no gait on feet
    durations = gait.durations()
    assert math.isclose(sum(durations), step.step_time, rel_tol=1e-9)
    assert [p for p, _ in step.phases.phases] == list(PHASES)
    report = verify_gait(profile, FEET)
    assert report.ok, str(report)
    names = {c.name for c in report.checks}
    assert {"stance foot flat", "centre of pressure", "ball passive", "stance heel up",
            "clearance", "heel strike", "landing", "impact momentum", "impulse cones",
            "heel held", "front ball up", "front heel cone", "ankles", "periodic angles",
            "friction cone", "dynamics"} <= names  # fmt: skip
    # the file names each foot's force after its contact; the root's sole pressure
    assert {"F_swing_heel_x", "F_swing_heel_y", "F_stance_foot_start_x",
            "CoP_stance_foot_start_x"} <= set(profile.extras)  # fmt: skip


def test_the_files_torques_are_newton_eulers_with_the_front_heels_force(gait, profile):
    """Every sample's torques are the inverse dynamics of its motion (the reference
    recursion), less the moments of the front heel's ground force where it holds."""
    psi, dpsi, ddpsi = profile.psi, profile.dpsi, profile.ddpsi
    expected = ne.inverse_dynamics(FEET, psi, dpsi, ddpsi)
    force = profile.extras["F_swing_heel_x"][0] + 1j * profile.extras["F_swing_heel_y"][0]
    heel = gait.problem.point("swing_heel").position(psi)
    hinges = ne.hinge_positions(FEET, psi)  # H0 .. Hn: link i starts at its parent's end
    path = (*FEET.ancestors(FEET.index("swing_foot")), FEET.index("swing_foot"))
    for i in path:
        start = hinges[:, 0] if i == 0 else hinges[:, FEET.parents[i] + 1]
        expected[:, i] -= (np.conj(heel - start) * force).imag
    scale = np.abs(expected).max()
    assert np.abs(profile.torques - expected).max() < 1e-8 * scale


def test_momentum_over_the_periodic_step(gait):
    """Over a periodic step the body's momentum comes back: the ground's vertical impulse
    (both feet's forces and the heel strike's impulses) is m g T, its horizontal one 0."""
    step = gait.problem
    n = step.linkage.n
    mass = step.biped.total_mass
    impulse = 0j
    for solution, _ in gait.segments():
        times = np.linspace(0.0, solution.T, 4001)
        x, xdot, _ = solution.motion(times)
        total = step.dynamics.ground_reaction(x[:, :n], x[:, n:], xdot[:, n:])
        impulse += np.trapezoid(total, times)
    before = gait.segments()[1][0].states[-1]  # heel rise's end: the strike's pre-state
    _, strike, _ = step.strike.function()(before[:n], before[n:])
    # both feet's impulses at heel strike: the momentum change (the ball's is what the
    # heel's leaves)
    momentum = step.dynamics.floating.function("linear_momentum")
    after = np.asarray(step.strike.state_function()(before)).ravel()
    change = (
        np.asarray(momentum(before[:n], np.r_[0, 0, after[n:]])).ravel()
        - np.asarray(momentum(before[:n], np.r_[0, 0, before[n:]])).ravel()
    )
    impulse += complex(*change)
    assert float(np.asarray(strike).ravel()[1]) > 0  # the heel is pushed up
    weight_time = mass * step.linkage.gravity * step.step_time
    assert impulse.imag == pytest.approx(weight_time, rel=2e-5)
    assert abs(impulse.real) < 2e-5 * weight_time


def test_the_strike_impulses_are_the_momentum_balances_of_the_sampled_impact(gait, profile):
    """``strike_impulses`` (the strike map's own impulses at the single support's last node)
    against the verification's least-squares balances of linear and angular momentum between
    the file's last sample before the strike and its first after (numpy, another
    derivation); the plan keeps the rear ball inside its cone (mu 0.8), the front heel pushed
    up."""
    from problems.gait.verification import _held_impact, _Kinematics

    step = gait.problem
    n = step.linkage.n
    impulses = gait.strike_impulses()
    before = gait.segments()[1][0].states[-1]
    after = gait.segments()[2][0].states[0]
    landing = complex(step.landing, 0.0)
    strike_link = step.linkage.index(step.biped.swing_leg[-1])
    residual, rear, front, _ = _held_impact(_Kinematics(FEET), before[:n], before[n:],
                                            after[n:], landing, strike_link)  # fmt: skip
    assert np.max(np.abs(residual)) < 1e-8
    scale = step.biped.total_mass * 1.0  # N s of the body at 1 m/s
    assert abs(impulses["front"] - front) < 1e-8 * scale
    assert abs(impulses["rear"] - rear) < 1e-8 * scale
    assert impulses["front"].imag > 0.0 and impulses["front_friction"] <= step.mu + 1e-6
    assert impulses["rear_friction"] == pytest.approx(
        abs(impulses["rear"].real) / impulses["rear"].imag
    )
    assert impulses["rear_friction"] <= step.mu + 1e-3


def test_the_stance_has_a_push_off_and_carries_the_weight(gait):
    stance = gait.stance()
    weight = gait.problem.weight
    fy = stance["force"].imag / weight
    assert fy.min() > -1e-6  # the ground pushes, never pulls
    # the ankle pushes off in the second half of the stance, positive power
    power = stance["ankle_power"]
    k = int(np.argmax(power))
    assert stance["time"][k] > 0.5 * stance["time"][-1] and power[k] > 50.0
    # a stance longer than a step by the double support
    assert stance["time"][-1] == pytest.approx(gait.duration + gait.durations()[-1], rel=1e-9)


TAMPERED = {
    "the stance foot tilted 1 mrad while flat": (
        lambda p: {"states": p.states - 1e-3 * (np.arange(16) == 0) * (p.time < 0.2)[:, None]},
        {"stance foot flat"},
    ),
    "the ball given a torque after heel rise": (
        lambda p: {"controls": p.controls + 5.0 * (np.arange(8) == 0) * (p.time > 0.4)[:, None]},
        {"dynamics", "ball passive"},
    ),
    "the front heel's force halved": (
        lambda p: {
            "extras": {
                k: (v * (0.5 if k.startswith("F_swing_heel") else 1.0), u)
                for k, (v, u) in p.extras.items()
            }
        },
        {"dynamics"},
    ),
}


@pytest.mark.parametrize("name", list(TAMPERED))
def test_tampered_footed_files_fail(profile, tmp_path, name):
    change, failing = TAMPERED[name]
    values = change(profile)
    tampered = Trajectory(
        profile.time,
        values.get("states", profile.states),
        values.get("controls", profile.controls),
        profile.state_names,
        profile.state_units,
        profile.control_names,
        profile.control_units,
        values.get("extras", dict(profile.extras)),
        profile.metadata,
    )
    tampered = LinkageTrajectory.load(tampered.save(tmp_path / "tampered.csv"))
    failed = {c.name for c in verify_gait(tampered, FEET).failures}
    assert failing <= failed, (name, failed)


def test_fixed_durations_are_kept():
    step = footed_step(N=(6, 6, 8), durations=(0.2, 0.15, 0.15))
    assert step.durations == (0.2, 0.15, 0.15)
    bounds = [ocp.T for _, ocp in step.phases.phases]
    for (low, high), d in zip(bounds, (0.2, 0.15, 0.15), strict=True):
        assert low <= d <= high and high - low < 1e-9


@pytest.mark.slow  # a stall's regression: two footed solves from two guesses
def test_a_guess_of_the_durations_that_once_stalled_reaches_the_same_optimum(monkeypatch):
    """From the guessed shares 0.45 / 0.30 / 0.25 of the step time (flat, heel rise, double
    support) the first solve used to drive the Hessian's regularisation past 1e7 and crawl:
    250 iterations of 1-5 s each without converging. With the planner's cap on the
    regularisation (IPOPT's restoration phase takes over past it) it reaches the optimum of
    the default guess; IPOPT's wall-time limit makes a regression fail in a minute, not
    hang."""
    from planner import solve
    from planner.solver import DEFAULT_IPOPT
    from problems.walking import footed

    assert DEFAULT_IPOPT["max_hessian_perturbation"] == 1e4
    options = {"max_wall_time": 60.0}
    reference = solve(footed_step().phases, progress=False, options=options)
    key = footed.SEQUENCES["human"]
    monkeypatch.setitem(footed.SHARES, key, (0.45, 0.30, 0.25))
    step = footed_step()
    assert footed._guessed_durations(step) == pytest.approx((0.225, 0.15, 0.125))
    other = solve(step.phases, progress=False, options=options)
    assert other.cost == pytest.approx(reference.cost, rel=1e-7)
    for a, b in zip(other.phases, reference.phases, strict=True):
        assert a.T == pytest.approx(b.T, abs=1e-5)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"linkage": presets.six_link_anthropoid()}, "legs of three links"),
        ({"durations": (0.2, 0.2, 0.2)}, "summing to step_time"),
        ({"points": {"stance_heel": None}}, "missing"),
        ({"N": (6, 6)}, r"`N`: 3 interval counts >= 2 \(flat, heel rise, double\)"),
        ({"step_length": -0.5}, "step_length"),
        ({"ankle_range": (0.5, -0.3)}, "ankle_range"),
        ({"touchdown_speed": -0.1}, "touchdown_speed.*>= 0 m/s"),
        ({"clearance": -0.01}, "clearance.*>= 0 m"),
        ({"mu": 0.0}, "mu"),
        ({"knee_range": (0.0,)}, "knee_range"),
    ],
)
def test_bad_settings_are_refused_naming_the_field(kwargs, match):
    with pytest.raises(DefinitionError, match=match):
        footed_step(**kwargs)


def test_the_point_foot_step_still_verifies_its_double_support_impact():
    """The impact balance shared with the footed step (``_held_impact``) still checks the
    point-foot double support."""
    gait = walking_step(double_support=0.05, mu=1.5).solve()
    report = gait.verify()
    assert report.ok, str(report)
    assert "impact momentum" in {c.name for c in report.checks}


def test_a_study_takes_the_step_on_feet_as_its_problem():
    """Study(problem=footed_step_at) over speed: each point is a FootedStep at its speed (the
    definition describes them: settings, linkage, phases)."""
    from problems import Study, footed_step_at
    from problems.walking.footed import step_at_speed

    study = Study({"speed": [0.6, 1.4]}, problem=footed_step_at)
    slow, fast = (study.step(k) for k in range(2))
    assert (slow.step_length, slow.step_time) == pytest.approx(step_at_speed(0.6))
    assert fast.speed == pytest.approx(1.4)
    described = study.definition["problems"]
    assert [d["settings"]["problem"] for d in described] == ["footed_step", "footed_step"]
    assert described[0]["linkage"] == FEET.parameters()


@pytest.mark.slow
def test_a_study_over_speed_on_feet_solves_and_verifies_every_point(tmp_path):
    from problems import Study, footed_step_at

    result = Study({"speed": [0.8, 1.2]}, problem=footed_step_at).run(tmp_path / "s", workers=2)
    assert list(result.grid("verified")) == [True, True]
    assert all(0.1 < c < 0.5 for c in result.grid("cost_of_transport"))


@pytest.mark.slow
@pytest.mark.parametrize("speed", [0.6, 1.4])
def test_the_step_on_feet_walks_at_the_issues_other_speeds_verified(speed):
    """The issue's three speeds (1.0 m/s is the default step, solved above): each plan
    holds its limits at every 1 kHz sample and passes the verification of its physics. At
    1.4 m/s the hold once cut the heel rise's first interval 18 times over (a miss at its
    pinned start point, which cutting cannot reach) and gave up."""
    from problems import footed_step_at

    gait = footed_step_at(speed).solve()
    report = gait.verify(1000.0)
    assert report.ok, [str(c) for c in report.failures]
    assert gait.solution.stats["sampled_limits"]["rounds"][-1]["raised"] == 0


def test_feet_outlines_must_match_between_the_legs(step):
    """world_motion draws a body with the same outline in alternate steps: corners on one
    foot only are refused, naming both."""
    from problems.walking.step import world_motion

    states = np.zeros((2, 2 * FEET.n))
    with pytest.raises(DefinitionError, match="'stance_foot' and 'swing_foot' are one body"):
        world_motion(step.biped, step.dynamics, [0.0, 0.1], states, [0, 1], [0j, 0.5, 1.0],
                     {"stance_foot": (step.points["stance_heel"],)})  # fmt: skip


def test_per_drive_limits_are_checked_by_name():
    """torque_limit per drive: every link but the root (the ground's torque), each > 0."""
    drives = presets.anthropoid_with_feet().names[1:]
    limits = dict.fromkeys(drives, 100.0)
    step = footed_step(torque_limit={**limits, "swing_foot": 30.0}, hip_limit=120.0)
    assert step.limits["swing_foot"] == 30.0 and step.torque_limit == 100.0
    assert step.settings()["torque_limit"]["stance_shank"] == 100.0
    assert step.settings()["hip_limit"] == 120.0
    with pytest.raises(ValueError, match=r"`torque_limit`: unknown links \['stance_foot'\]"):
        footed_step(torque_limit={**limits, "stance_foot": 10.0})
    with pytest.raises(ValueError, match=r"give a limit for every link, missing \['head'\]"):
        footed_step(torque_limit={k: v for k, v in limits.items() if k != "head"})
    with pytest.raises(ValueError, match=r"`torque_limit`: must be > 0 N m, got -1.0 for 'head'"):
        footed_step(torque_limit={**limits, "head": -1.0})
    with pytest.raises(ValueError, match="`hip_limit`"):
        footed_step(hip_limit=0.0)
