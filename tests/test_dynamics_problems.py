"""First and second problems of dynamics against independent references.

References: the Newton-Euler oracle of tests/reference (no complex numbers, no CasADi), the
paper's printed equations (tests/reference/paper_equations.py), the energy balance
E(t) - E(0) = integral of sum_i M_i (dpsi_i - dpsi_parent(i)) dt computed here with Simpson's
rule, and the law itself for replays.
"""

import math
import os
import re

import numpy as np
import pytest
from reference import paper_equations as paper
from reference.newton_euler import ground_reaction as oracle_ground_reaction
from reference.newton_euler import inverse_dynamics as oracle_inverse_dynamics
from reference.newton_euler import random_tree
from scipy.integrate import cumulative_simpson

from model import Dynamics, LinkageTrajectory, presets
from planner.errors import DefinitionError, DefinitionTypeError
from planner.trajectory import Trajectory
from problems import (
    FIT_WINDOW,
    GaitLaw,
    SimulationError,
    fit_growth_rate,
    law_torque_function,
    replay_law,
    simulate,
    torques_along,
    upright_instability_rate,
)

HALF_PI = math.pi / 2


@pytest.fixture(scope="module")
def six():
    return Dynamics(presets.six_link_anthropoid())


@pytest.fixture(scope="module")
def paper22():
    return GaitLaw.preset("paper22")


def _relative_error(a, b):
    return np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)


# ---- first problem --------------------------------------------------------------------------
@pytest.mark.parametrize("law_name", ["paper22", "walking"])
def test_law_torques_match_newton_euler(six, law_name):
    law = GaitLaw.preset(law_name)
    t = np.linspace(0.0, 2.0 * law.period, 401)
    profile = torques_along(six, law, t)
    psi, dpsi, ddpsi = law(t)
    linkage = six.linkage
    assert (
        _relative_error(profile.torques, oracle_inverse_dynamics(linkage, psi, dpsi, ddpsi)) < 1e-10
    )
    ground = oracle_ground_reaction(linkage, psi, dpsi, ddpsi)
    fx, fy = profile.ground_reaction.real, profile.ground_reaction.imag
    assert _relative_error(fx + 1j * fy, ground) < 1e-10
    np.testing.assert_array_equal(profile.psi, psi)
    np.testing.assert_array_equal(profile.dpsi, dpsi)
    np.testing.assert_array_equal(profile.ddpsi, ddpsi)


def test_law_torques_on_random_trees_match_newton_euler():
    rng = np.random.default_rng(4)
    checked = 0
    for n_links in (2, 5, 9):
        linkage = random_tree(rng, n_links, span=(0.1, 10.0))
        law = GaitLaw(
            period=rng.uniform(0.5, 2.0),
            zeta=rng.uniform(0, 0.5, n_links),
            varpi=rng.uniform(-3, 3, n_links),
            center=rng.uniform(-3, 3, n_links),
        )
        t = np.linspace(0.0, law.period, 51)
        torques = torques_along(linkage, law, t).torques
        assert _relative_error(torques, oracle_inverse_dynamics(linkage, *law(t))) < 1e-10
        checked += torques.size
    assert checked == 51 * (2 + 5 + 9)


def test_static_instants_need_gravity_torques_only(six):
    # varpi_j = +-pi/2: every t = k T/2 is static (GaitLaw.static_times derives it).
    law = GaitLaw(
        period=0.8,
        zeta=[0.2, 0.3, 0.4, 0.3, 0.1, 0.05],
        varpi=[HALF_PI, -HALF_PI, HALF_PI, HALF_PI, -HALF_PI, HALF_PI],
        center=[HALF_PI, 1.4, -HALF_PI, -1.7, 1.6, HALF_PI],
    )
    times = law.static_times(t_end=1.6)
    assert times.size == 5
    profile = torques_along(six, law, times)
    psi = law.psi(times)
    gravity = six.gravity_torques(psi)
    assert _relative_error(profile.torques, gravity) < 1e-12
    zero = np.zeros_like(psi)
    assert _relative_error(gravity, oracle_inverse_dynamics(six.linkage, psi, zero, zero)) < 1e-10
    # and at a non-static instant the dynamic part is large
    moving = torques_along(six, law, np.array([0.2, 0.3])).torques
    assert np.max(np.abs(moving - six.gravity_torques(law.psi(np.array([0.2, 0.3]))))) > 10.0


def test_paper22_has_no_static_instant_but_rests_at_t0(six, paper22):
    # dpsi(0) = 0 but ddpsi(0) != 0: the torque at t = 0 is gravity plus inertia, not gravity.
    psi, dpsi, ddpsi = paper22(0.0)
    assert np.max(np.abs(dpsi)) == 0.0 and np.max(np.abs(ddpsi)) > 1.0
    torque = torques_along(six, paper22, [0.0, 0.5]).torques[0]
    inertial = oracle_inverse_dynamics(six.linkage, psi, dpsi, ddpsi) - oracle_inverse_dynamics(
        six.linkage, psi, dpsi, np.zeros(6)
    )
    assert _relative_error(torque - six.gravity_torques(psi), inertial) < 1e-10


def test_profile_metadata_and_channels(six, paper22):
    profile = torques_along(six, paper22, np.linspace(0, 1, 5), metadata={"note": "x"})
    meta = profile.metadata
    assert meta["law"]["zeta"] == list(paper22.zeta)
    assert meta["law"]["name"] == "paper22"
    assert meta["model"] == six.linkage.parameters()
    assert {"casadi", "numpy", "anthropoid-planner"} <= set(meta["versions"])
    assert meta["note"] == "x"
    assert profile.control_names == tuple("M_" + name for name in six.names)
    assert {"F_stance_shank_start_x", "F_stance_shank_start_y"} <= set(profile.extras)
    assert profile.extras["F_stance_shank_start_y"][1] == "N"


def test_paper_errata_change_m1_and_m2_only(six, paper22):
    t = np.linspace(0.0, paper22.period, 2001)
    psi, dpsi, ddpsi = paper22(t)
    literal = paper.paper_literal_torques(six.linkage, psi, dpsi, ddpsi)
    corrected = paper.corrected_torques(six.linkage, psi, dpsi, ddpsi)
    ours = torques_along(six, paper22, t).torques
    assert _relative_error(corrected, ours) < 1e-10
    difference = np.max(np.abs(literal - ours), axis=0)
    # Measured on 2001 times: 4.802 and 1.392 N m (errata.md: "up to 4.8", "1.4").
    np.testing.assert_allclose(difference[:2], [4.802, 1.392], atol=0.005)
    assert np.all(difference[2:] < 1e-9)


def test_first_problem_validation(six, paper22):
    with pytest.raises(DefinitionError, match=r"`law`: drives 6 links but the linkage has 5"):
        torques_along(presets.five_link_biped(), paper22, [0.0, 0.1])
    with pytest.raises(DefinitionTypeError, match=r"`law`: must be a problems.GaitLaw"):
        torques_along(six, lambda t: t, [0.0, 1.0])
    with pytest.raises(DefinitionError, match=r"`t`: must be a 1-D array of at least 2 time"):
        torques_along(six, paper22, [0.0])
    with pytest.raises(DefinitionError, match=r"`t`: times must increase strictly"):
        torques_along(six, paper22, [0.0, 0.2, 0.1])
    with pytest.raises(DefinitionTypeError, match=r"`dynamics`: must be a model.Dynamics"):
        torques_along("six-link", paper22, [0.0, 1.0])
    with pytest.raises(DefinitionTypeError, match=r"`t`: must be a 1-D array of times in s"):
        torques_along(six, paper22, "soon")
    with pytest.raises(DefinitionError, match=r"`t`: contains NaN or inf; give finite times"):
        torques_along(six, paper22, [0.0, math.nan])


# ---- second problem -------------------------------------------------------------------------
def _power(six, dpsi, torques):
    parents = six.linkage.parents
    relative = dpsi.copy()
    for i, p in enumerate(parents):
        if p >= 0:
            relative[:, i] -= dpsi[:, p]
    return np.sum(torques * relative, axis=1)


@pytest.mark.parametrize(
    ("method", "options", "tolerance"),
    [
        # relative errors measured: cvodes 3.5e-9, idas 1.1e-9, rk 2.5e-13 of 425 J of change
        ("cvodes", {"rtol": 1e-11, "atol": 1e-11}, 1e-8),
        ("idas", {"rtol": 1e-11, "atol": 1e-11}, 1e-8),
        ("rk", {"steps": 8}, 1e-9),
        ("collocation", {"steps": 4}, 1e-9),  # measured 5e-12
    ],
)
def test_energy_balance_with_torques(six, paper22, method, options, tolerance):
    law_torque = law_torque_function(six, paper22)

    def torque(t):
        t = np.atleast_1d(t)
        wobble = 20.0 * np.sin(9.0 * t[:, None] + np.arange(6)[None, :])
        return law_torque(t) + wobble

    t = np.linspace(0.0, 0.4, 801)
    result = simulate(six, torque, paper22.state(0.0), (0.0, 0.4), t, method=method, **options)
    kinetic, potential = six.energy(result.psi, result.dpsi)
    energy_change = kinetic + potential - (kinetic[0] + potential[0])
    work_quadrature = result.extras["work"][0]
    work_simpson = cumulative_simpson(_power(six, result.dpsi, result.torques), x=t, initial=0.0)
    scale = np.max(np.abs(energy_change))
    assert scale > 50.0  # the torques do real work
    assert np.max(np.abs(energy_change - work_quadrature)) < tolerance * scale
    # Simpson's rule on the 2 kHz output: its own error ~1e-6 J (measured 1.2e-6 to 2.1e-6 J)
    assert np.max(np.abs(work_simpson - work_quadrature)) < 2e-8 * scale
    np.testing.assert_allclose(result.torques, torque(t), rtol=1e-13, atol=1e-10)


def test_passive_motion_conserves_energy(six):
    x0 = np.concatenate([np.full(6, HALF_PI) + 0.1 * np.arange(6), np.zeros(6)])
    result = simulate(
        six, lambda t: np.zeros((np.size(t), 6)), x0, (0.0, 1.0), rtol=1e-12, atol=1e-12
    )
    energy = np.sum(six.energy(result.psi, result.dpsi), axis=0)
    assert np.max(np.abs(energy - energy[0])) / abs(energy[0]) < 1e-8
    assert np.max(np.abs(result.extras["work"][0])) == 0.0
    assert np.max(np.abs(result.psi[-1] - x0[:6])) > 0.1  # it did fall


def test_dense_output_costs_no_accuracy(six):
    # cvodes runs through the output times without restarting (simulate's block comment):
    # 100 times more output samples must not make the energy drift grow. Measured at
    # rtol = 1e-10: 3.2e-8 at 100 Hz, 6.3e-9 at 10 kHz; restarted at every interval it grew
    # to 6.9e-7.
    x0 = np.concatenate([np.full(6, HALF_PI) + 0.1 * np.arange(6), np.zeros(6)])
    drift = {}
    for rate in (100.0, 10000.0):
        result = simulate(
            six, lambda t: np.zeros((np.size(t), 6)), x0, (0.0, 1.0), rate_hz=rate, rtol=1e-10
        )
        assert result.time.size == rate + 1
        energy = np.sum(six.energy(result.psi, result.dpsi), axis=0)
        drift[rate] = np.max(np.abs(energy - energy[0])) / abs(energy[0])
    assert drift[10000.0] <= 3.0 * drift[100.0], drift


def test_methods_agree_and_sources_are_equivalent(six, paper22):
    profile = torques_along(six, paper22, np.linspace(0.0, 0.3, 301))
    reference = simulate(six, profile, None, (0.0, 0.2), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(reference.psi[0], paper22.psi(0.0), atol=0)  # x0 from the file
    for method in ("idas", "rk", "collocation"):
        other = simulate(six, profile, None, (0.0, 0.2), method=method, rtol=1e-12, atol=1e-12)
        assert np.max(np.abs(other.psi - reference.psi)) < 1e-8, method

    class Solution:  # anything with to_trajectory(), like planner.Solution
        def to_trajectory(self):
            return profile

    via_solution = simulate(six, Solution(), None, (0.0, 0.2), rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(via_solution.states, reference.states)
    exact = law_torque_function(six, paper22)

    def scalar_only(t):  # not vectorised: simulate must call it per time
        return exact(np.array([float(t)]))[0]

    via_vector = simulate(six, exact, paper22.state(0.0), (0.0, 0.2), rtol=1e-12, atol=1e-12)
    via_callable = simulate(
        six, scalar_only, paper22.state(0.0), (0.0, 0.2), rtol=1e-12, atol=1e-12
    )
    np.testing.assert_array_equal(via_callable.states, via_vector.states)
    # exact torques vs a 1 kHz cubic spline of them: close over this short span (measured
    # 8.7e-10 rad with the not-a-knot spline; the natural spline's end error gave 2.1e-7)
    assert np.max(np.abs(via_vector.psi - reference.psi)) < 1e-8
    assert via_callable.metadata["method"] == "cvodes"
    assert reference.metadata["torques"]["source_metadata"]["law"]["name"] == "paper22"


def test_replay_of_the_law_follows_it_then_diverges(six, paper22):
    report = replay_law(six, paper22, 1.2, rtol=1e-12, atol=1e-12)
    assert report.deviation[0] == 0.0
    # measured: 0.68 s below 1e-6 rad, growth rate 25 1/s (cvodes); the upright pose's
    # linearisation gives 30 1/s.
    assert report.horizon >= 0.5
    assert 15.0 < report.growth_rate < 40.0
    assert report.deviation[-1] > 1e-3  # an open-loop replay of an unstable gait diverges
    linear = upright_instability_rate(six, np.full(6, HALF_PI))
    assert 0.5 < report.growth_rate / linear < 1.5
    other = replay_law(six, paper22, 1.0, method="collocation", steps=8)
    assert abs(other.growth_rate / report.growth_rate - 1) < 0.15
    rows = report.table(5)
    assert rows[0] == (0.0, 0.0) and len(rows) == 5


def test_replay_and_instability_validation(six, paper22):
    with pytest.raises(DefinitionError, match=r"`t_end`: must be > t0 = 0.5 s, got 0.5"):
        replay_law(six, paper22, 0.5, t0=0.5)
    with pytest.raises(DefinitionError, match=r"`law`: drives 6 links but the linkage has 5"):
        replay_law(presets.five_link_biped(), paper22, 1.0)
    with pytest.raises(DefinitionError, match=r"`psi`: must be 6 finite angles in rad"):
        upright_instability_rate(six, np.zeros(5))
    with pytest.raises(DefinitionError, match=r"`psi`: must be 6 finite angles in rad"):
        upright_instability_rate(six, np.full(6, np.nan))
    with pytest.raises(DefinitionTypeError, match=r"`psi`: must be 6 finite angles in rad"):
        upright_instability_rate(six, "upright")


def test_replay_of_a_sampled_profile(six, paper22):
    profile = torques_along(six, paper22, np.linspace(0.0, 0.5, 501))  # 1 kHz
    report = replay_law(six, paper22, 0.4, torques=profile, rtol=1e-12, atol=1e-12)
    # The not-a-knot spline (end error 1.8e-6 N m) keeps the whole 0.4 s below 1e-6 rad,
    # measured max 1.07e-7 rad; the natural spline's end error (~1e-3 N m) left it at 0.27 s.
    assert report.horizon == pytest.approx(0.4)
    assert np.max(report.deviation) < 5e-7


def test_second_problem_validation(six, paper22):
    profile = torques_along(six, paper22, np.linspace(0.0, 0.5, 51))
    x0 = paper22.state(0.0)
    cases = [
        ({"method": "euler"}, DefinitionError, r"`method`: unknown integrator 'euler'"),
        ({"t_span": (0.0, 0.6)}, DefinitionError, r"`t_span`: \(0, 0.6\) s leaves the torque"),
        ({"t_span": (0.3, 0.1)}, DefinitionError, r"`t_span`: needs finite t0 < tf"),
        ({"x0": np.zeros(5)}, DefinitionError, r"`x0`: must have 2n = 12 entries"),
        ({"x0": np.full(12, np.nan)}, DefinitionError, r"`x0`: contains NaN"),
        ({"rtol": 0.0}, DefinitionError, r"`rtol`: must lie in \[1e-14, 1\), got 0.0; a"),
        ({"rtol": 1e-16}, DefinitionError, r"`rtol`: must lie in \[1e-14, 1\), got 1e-16; below"),
        ({"atol": 1e-15}, DefinitionError, r"`atol`: must lie in .* got 1e-15; .* give 1e-12"),
        ({"atol": 1.0}, DefinitionError, r"`atol`: must lie in \[1e-14, 1\), got 1.0; give a"),
        ({"rtol": float("nan")}, DefinitionError, r"`rtol`: must be finite, got nan"),
        ({"rtol": -1e-8}, DefinitionError, r"`rtol`: must lie in \[1e-14, 1\), got -1e-08"),
        ({"rate_hz": 1e12}, DefinitionError, r"`rate_hz`: 1e\+12 Hz over 0.5 s asks for"),
        ({"steps": 0}, DefinitionError, r"`steps`: must be >= 1"),
        ({"t_eval": [0.0, 0.7]}, DefinitionError, r"`t_eval`: must lie within t_span"),
        ({"rate_hz": -1.0}, DefinitionError, r"`rate_hz`: must be > 0 Hz"),
        ({"interpolation": "quintic"}, DefinitionError, r"`interpolation`: must be 'cubic'"),
        ({"degree": 0}, DefinitionError, r"`degree`: must be >= 1, got 0"),
        ({"max_interval": 0.0}, DefinitionError, r"`max_interval`: must be > 0 s, got 0.0"),
        ({"solution_rate_hz": -1.0}, DefinitionError, r"`solution_rate_hz`: must be > 0 Hz"),
        ({"t_span": 0.5}, DefinitionTypeError, r"`t_span`: must be \(t0, tf\) in s, got 0.5"),
        ({"x0": "psi"}, DefinitionTypeError, r"`x0`: must be 2n = 12 numbers, got 'psi'"),
    ]
    for changes, error, message in cases:
        arguments = {"x0": x0, "t_span": (0.0, 0.5)}
        arguments.update(changes)
        with pytest.raises(error, match=message):
            simulate(six, profile, **arguments)
    with pytest.raises(DefinitionError, match=r"`t_span`: required when `torques` is a callable"):
        simulate(six, lambda t: np.zeros(6), x0)
    with pytest.raises(DefinitionError, match=r"`x0`: required when `torques` is a callable"):
        simulate(six, lambda t: np.zeros(6), None, (0.0, 1.0))
    with pytest.raises(DefinitionTypeError, match=r"`torques`: must be a Trajectory"):
        simulate(six, 3.0, x0, (0.0, 1.0))
    with pytest.raises(DefinitionError, match=r"the callable must return 6 torques"):
        simulate(six, lambda t: np.zeros(4), x0, (0.0, 0.1))
    with pytest.raises(DefinitionError, match=r"`torques`: the profile gives NaN or inf torques"):
        simulate(six, lambda t: np.full((np.size(t), 6), np.inf), x0, (0.0, 0.1))
    five = Dynamics(presets.five_link_biped())
    with pytest.raises(
        DefinitionError, match=r"profile has 6 torque channels but the linkage has 5"
    ):
        simulate(five, profile, np.zeros(10), (0.0, 0.1))
    renamed = LinkageTrajectory.from_linkage(
        profile.time, profile.psi, profile.dpsi, profile.torques, [f"L{i}" for i in range(6)]
    )
    with pytest.raises(DefinitionError, match=r"the profile is for links \['L0'"):
        simulate(six, renamed, x0, (0.0, 0.1))


def _with_units(profile, angle, rate, torque, factor_angle, factor_torque, order=None):
    """The profile's columns in other units (values divided by the factor to SI), and
    optionally in another column order: what a hand-made or spreadsheet file holds."""
    names = list(profile.state_names)
    states = profile.states.copy()
    n = len(names) // 2
    states[:, :n] /= factor_angle
    states[:, n:] /= factor_angle
    units = (angle,) * n + (rate,) * n
    order = list(range(2 * n)) if order is None else order
    return Trajectory(
        time=profile.time,
        states=states[:, order],
        controls=profile.controls / factor_torque,
        state_names=tuple(names[i] for i in order),
        state_units=tuple(units[i] for i in order),
        control_names=profile.control_names,
        control_units=(torque,) * len(profile.control_names),
    )


def test_a_profile_in_degrees_and_kilonewton_metres_is_converted_not_misread(six, paper22):
    profile = torques_along(six, paper22, np.linspace(0.0, 0.3, 301))
    reference = simulate(six, profile, t_span=(0.0, 0.2))
    degrees = _with_units(
        profile, "deg", "deg/s", "kN m", math.pi / 180, 1e3, order=[5, 0, 1, 2, 3, 4, *range(6, 12)]
    )
    motion = simulate(six, degrees, t_span=(0.0, 0.2))  # x0 from the file, in degrees
    np.testing.assert_allclose(motion.psi, reference.psi, atol=1e-9)
    np.testing.assert_allclose(motion.torques, reference.torques, rtol=1e-12)
    # the same numbers read as rad and N m (what the labels were ignored into) are another
    # motion: the conversion is what makes the two agree
    kilo = _with_units(profile, "rad", "rad/s", "N m", 1.0, 1e3)
    misread = simulate(six, kilo, t_span=(0.0, 0.2))
    assert np.max(np.abs(misread.psi - reference.psi)) > 0.1


def test_a_profile_column_in_a_unit_of_another_quantity_or_unknown_is_refused(six, paper22):
    profile = torques_along(six, paper22, np.linspace(0.0, 0.3, 31))
    cases = [
        (
            _with_units(profile, "rad", "rad/s", "kN/m", 1.0, 1.0),
            r"`torques`: column `M_stance_shank` is in 'kN/m', a unit this library does not "
            r"read as a torque; give it in N m \(or one of N m, Nm, kN m",
        ),
        (
            _with_units(profile, "rad", "rad/s", "rad", 1.0, 1.0),
            r"`torques`: column `M_stance_shank` is in 'rad', an angle, but it must be a "
            r"torque: N m",
        ),
        (
            _with_units(profile, "N m", "rad/s", "N m", 1.0, 1.0),
            r"`torques`: column `psi_stance_shank` is in 'N m', a torque, but it must be an "
            r"angle: rad \(or one of rad, deg",
        ),
    ]
    for bad, message in cases:
        with pytest.raises(DefinitionError, match=message):
            simulate(six, bad, t_span=(0.0, 0.1))
    # a missing column is named (the initial state needs it; with x0 given it does not)
    keep = [i for i, name in enumerate(profile.state_names) if name != "psi_head"]
    lacking = Trajectory(
        time=profile.time,
        states=profile.states[:, keep],
        controls=profile.controls,
        state_names=tuple(profile.state_names[i] for i in keep),
        state_units=tuple(profile.state_units[i] for i in keep),
        control_names=profile.control_names,
        control_units=profile.control_units,
    )
    with pytest.raises(
        DefinitionError, match=r"`torques`: the profile lacks the column\(s\) psi_head \[rad\]"
    ):
        simulate(six, lacking, t_span=(0.0, 0.1))
    assert simulate(six, lacking, paper22.state(0.0), (0.0, 0.05)).time[-1] == 0.05


def test_smallest_accepted_tolerance_runs(six, paper22):
    # MIN_TOLERANCE itself must work, or the bound rejects too little: 0.05 s at 1e-14.
    motion = simulate(
        six,
        law_torque_function(six, paper22),
        paper22.state(0.0),
        (0.0, 0.05),
        rtol=1e-14,
        atol=1e-14,
    )
    assert np.max(np.abs(motion.psi - paper22.psi(motion.time))) < 1e-9


@pytest.mark.parametrize(
    ("method", "cause"),
    [
        ("cvodes", r"CV_TOO_MUCH_WORK \(more than 100000 steps inside one interval\); the motion"),
        ("idas", r"IDA_TOO_MUCH_WORK \(more than 100000 steps inside one interval\); the motion"),
        ("rk", r"the state became non-finite; the motion"),
        ("collocation", r"the Newton iteration of an implicit collocation step did not converge; "),
    ],
)
def test_integrator_failure_is_one_error_and_quiet(six, paper22, capfd, method, cause):
    # Torques of 1e9 N m spin the links until the integrator gives up: cvodes/idas after
    # 100000 steps in one interval, writing to file descriptor 2 directly (about 70 lines);
    # rk raises nothing, its state turns NaN while CasADi warns once per step (about 200
    # lines); collocation's Newton iteration fails with CasADi's advice to ignore the error.
    # None of it may reach the terminal: one SimulationError naming the interval, the cause
    # and what to change says it all.
    def huge(t):
        return np.full((np.size(t), 6), 1e9)

    with pytest.raises(SimulationError) as caught:
        simulate(six, huge, paper22.state(0.0), (0.0, 1.0), method=method)
    error = caught.value
    message = str(error)
    assert "\n" not in message
    assert re.search(
        rf"^integrator '{method}' failed between t = 0 s and t = 0.01 s: {cause}", message
    ), message
    if method in ("rk", "collocation"):
        assert message.endswith(
            "the motion diverges (torques too large, or an unstable motion run too long) or "
            "the steps are too coarse for it; shorten t_span or raise steps"
        ), message
        assert error.flag is None and error.details  # CasADi's own words, kept aside
    else:
        assert error.flag.endswith("TOO_MUCH_WORK")
    assert error.interval == (0.0, 0.01) and error.method == method
    captured = capfd.readouterr()
    assert captured.err == "" and captured.out == "", captured.err[:500]
    # and the integrators still work, with fd 2 restored
    simulate(six, law_torque_function(six, paper22), paper22.state(0.0), (0.0, 0.01))
    os.write(2, b"fd 2 is back\n")
    assert capfd.readouterr().err == "fd 2 is back\n"


@pytest.mark.parametrize("method", ["cvodes", "rk", "collocation"])
def test_integrator_failure_names_the_interval_inside_a_chunk(six, paper22, method):
    # Torques switch to 1e9 N m at t = 0.5 s: the chunk of 100 intervals fails as a whole,
    # the error names the one interval where the integrator gave up.
    exact = law_torque_function(six, paper22)

    def switching(t):
        t = np.atleast_1d(t)
        return np.where(t[:, None] < 0.5, exact(t), 1e9)

    with pytest.raises(SimulationError, match=r"failed between t = 0.5 s and t = 0.51 s"):
        simulate(six, switching, paper22.state(0.0), (0.0, 1.0), t_eval=[0.5], method=method)


def test_profile_and_its_control_function_give_the_same_motion():
    # Output times that miss the profile's knots by an ulp (0.05 vs 50 * 0.001) must still be
    # reported at the right instant: the Trajectory path against the callable path.
    chain = Dynamics(presets.n_link_chain(2))
    t = np.linspace(0.0, 1.0, 1001)
    torques = np.column_stack([np.sin(7 * t), np.cos(5 * t)])
    profile = LinkageTrajectory.from_linkage(
        t, np.zeros((1001, 2)), np.zeros((1001, 2)), torques, chain.names
    )
    spline = profile.control_function("cubic")
    x0 = np.array([-1.5, -1.5, 0.0, 0.0])
    out = np.linspace(0.0, 1.0, 21)
    a = simulate(chain, profile, x0, (0.0, 1.0), out, rtol=1e-12, atol=1e-12)
    b = simulate(chain, spline, x0, (0.0, 1.0), out, rtol=1e-12, atol=1e-12, max_interval=1e-3)
    np.testing.assert_array_equal(a.time, out)
    # Each run carries its own cvodes error at 1e-12 (2.3e-10 and 2.1e-10 against RK4 with 64
    # steps per ms, casadi 3.8.2), so the two agree only to a few 1e-10; reading an output
    # one knot off would differ by dt * |dpsi| ~ 1e-3.
    assert np.max(np.abs(a.states - b.states)) < 1e-9
    exact = simulate(
        chain,
        lambda s: np.column_stack([np.sin(7 * s), np.cos(5 * s)]),
        x0,
        (0.0, 1.0),
        out,
        rtol=1e-12,
        atol=1e-12,
    )
    assert np.max(np.abs(a.states - exact.states)) < 1e-7  # 1 kHz spline error, measured 1.3e-8


def test_a_planner_solution_replays_like_its_own_replay():
    import casadi as ca

    from planner import OCP

    chain = Dynamics(presets.n_link_chain(2))
    solution = (
        OCP(chain, T=1.0, N=20)
        .bound("M", -50, 50)
        .initial(psi=[-HALF_PI, -HALF_PI], dpsi=[0.0, 0.0])
        .final(psi=[-HALF_PI + 0.5, -HALF_PI + 0.5], dpsi=[0.0, 0.0])
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .solve()
    )
    replay = solution.replay(rtol=1e-12, atol=1e-12)  # the planner's own integration
    x0 = np.asarray(solution.state(0.0)).reshape(-1)
    exact = simulate(
        chain,
        solution.control,
        x0,
        (0.0, 1.0),
        replay.time,
        rtol=1e-12,
        atol=1e-12,
        max_interval=1.0 / 160,
    )
    assert np.max(np.abs(exact.states - replay.states)) < 1e-6  # measured 2.6e-8
    # A Solution is sampled as its file is: the consistent motion at 1 kHz, whose torques
    # are the inverse dynamics of that motion; integrated they follow that motion (9.2e-5
    # with the torques splined between the samples), not the transcription's replay
    # (1.5e-3 apart from it).
    sampled = simulate(chain, solution, None, None, replay.time, rtol=1e-12, atol=1e-12)
    motion, _, _ = solution.motion(replay.time)
    assert np.max(np.abs(sampled.states - motion)) < 2e-4


def test_growth_rate_fit_starts_above_integration_noise():
    # A closed-form exponential 1e-12 e^{25 t} under a noise floor of 3e-9 rad, the size of
    # cvodes' wander at rtol = 1e-10 (FIT_WINDOW's comment). A window from 1e-9 rad fits
    # mostly noise (15 /s); the default window recovers the rate.
    t = np.linspace(0.0, 1.0, 201)
    noise = 3e-9 * np.abs(np.random.default_rng(7).standard_normal(t.size))
    deviation = noise + 1e-12 * np.exp(25.0 * t)
    assert FIT_WINDOW[0] >= 10 * np.max(noise)
    assert fit_growth_rate(t, deviation) == pytest.approx(25.0, rel=0.01)
    assert fit_growth_rate(t, deviation, (1e-9, 1e-3)) < 20.0  # what the window avoids


def test_growth_rate_fit_on_a_closed_form():
    t = np.linspace(0.0, 2.0, 401)
    deviation = 1e-12 * np.exp(20.0 * t) * (1.0 + 0.5 * np.sin(40.0 * t) ** 2)
    # the running max follows the envelope 1e-12 e^{20 t} (1 + ...) within a factor 1.5
    assert fit_growth_rate(t, deviation) == pytest.approx(20.0, rel=0.02)
    assert math.isnan(fit_growth_rate(t, np.full(t.size, 1e-12)))
    with pytest.raises(DefinitionError, match=r"`window`: needs 0 < low < high"):
        fit_growth_rate(t, deviation, (1e-3, 1e-9))
    with pytest.raises(DefinitionError, match=r"`deviation`: shape \(3,\) differs"):
        fit_growth_rate(t, np.ones(3))
