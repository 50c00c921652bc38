"""problems.GaitLaw: law (22) against closed forms, finite differences and its validation."""

import math

import casadi as ca
import numpy as np
import pytest

from model import Dynamics, presets
from planner.errors import DefinitionError, DefinitionTypeError
from problems import LAW_PRESETS, GaitLaw, torques_along

HALF_PI = math.pi / 2


def _random_law(rng: np.random.Generator, n: int) -> GaitLaw:
    return GaitLaw(
        period=rng.uniform(0.3, 3.0),
        zeta=rng.uniform(0.0, 0.8, n),
        varpi=rng.uniform(-math.pi, math.pi, n),
        center=rng.uniform(-math.pi, math.pi, n),
    )


def _laws():
    rng = np.random.default_rng(22)
    return [GaitLaw.preset("paper22"), GaitLaw.preset("walking")] + [
        _random_law(rng, n) for n in (1, 3, 6, 12)
    ]


def test_paper22_is_the_scene_md_law():
    law = GaitLaw.preset("paper22")
    assert law.period == 1.0
    assert law.zeta == (0.20, 0.30, 0.40, 0.30, 0.10, 0.05)
    assert law.varpi == (0.00, 0.50, 1.00, 1.50, 0.20, 0.40)
    assert law.center == (HALF_PI,) * 6
    # the paper's formula written out, independently of the class
    t = np.linspace(0.0, 2.0, 37)
    expected = HALF_PI + np.array(law.zeta) * np.sin(
        np.array(law.varpi) - (1 - np.cos(2 * np.pi * t[:, None] / 1.0)) * np.pi / 2
    )
    np.testing.assert_allclose(law.psi(t), expected, rtol=0, atol=1e-15)


def test_walking_posture_centres():
    law = GaitLaw.preset("walking")
    assert law.center == (HALF_PI, HALF_PI, -HALF_PI, -HALF_PI, HALF_PI, HALF_PI)
    psi = law.psi(np.linspace(0, 1, 51))
    assert np.all(psi[:, [0, 1, 4, 5]] > 0) and np.all(psi[:, [2, 3]] < 0)  # legs apart


def test_default_centre_is_the_papers():
    law = GaitLaw(period=2.0, zeta=[0.1, 0.2], varpi=[0.0, 1.0])
    assert law.center == (HALF_PI, HALF_PI)


@pytest.mark.parametrize("law", _laws(), ids=lambda law: f"{law.name}-{law.n}")
def test_derivatives_against_central_differences(law):
    # Step h: truncation h^2 f'''/6 and round-off eps/h balance near 1e-5 relative.
    h = 1e-5 * law.period
    t = np.linspace(-0.3, 1.7, 41) * law.period
    checked = 0
    for value, derivative in ((law.psi, law.dpsi), (law.dpsi, law.ddpsi)):
        numeric = (value(t + h) - value(t - h)) / (2 * h)
        exact = derivative(t)
        tolerance = 1e-8 * max(np.max(np.abs(exact)), 1.0)
        np.testing.assert_allclose(exact, numeric, rtol=0, atol=tolerance)
        # Only entries far above the tolerance test anything: a zero derivative (a link
        # with zeta = 0, the stationary instants t = k T/2) matches any tiny difference.
        checked += np.count_nonzero(np.abs(exact) > 1e3 * tolerance)
    # the guard: most entries were real comparisons (measured 94-95% for these laws)
    assert checked >= 0.9 * 2 * t.size * law.n, checked


@pytest.mark.parametrize("law", _laws(), ids=lambda law: f"{law.name}-{law.n}")
def test_shapes_call_state_and_periodicity(law):
    t = np.linspace(0.0, law.period, 7)
    psi, dpsi, ddpsi = law(t)
    assert psi.shape == dpsi.shape == ddpsi.shape == (7, law.n)
    np.testing.assert_array_equal(psi, law.psi(t))
    np.testing.assert_array_equal(dpsi, law.dpsi(t))
    np.testing.assert_array_equal(ddpsi, law.ddpsi(t))
    single = law(0.3 * law.period)
    assert all(a.shape == (law.n,) for a in single)
    assert law.state(t).shape == (7, 2 * law.n)
    np.testing.assert_allclose(law.psi(t + law.period), psi, atol=1e-12)
    # dpsi vanishes for every link at t = 0 and T/2 (the shared time function is stationary)
    np.testing.assert_allclose(law.dpsi(np.array([0.0, law.period / 2])), 0.0, atol=1e-14)
    # psi(0) = center + zeta sin(varpi), closed form
    np.testing.assert_allclose(
        law.psi(0.0), np.array(law.center) + np.array(law.zeta) * np.sin(law.varpi), atol=1e-15
    )


def _symbolic_functions(law: GaitLaw):
    """The law on a symbolic SX time, as a CasADi Function t -> (psi, dpsi, ddpsi, state)."""
    t = ca.SX.sym("t")
    psi, dpsi, ddpsi = law(t)
    assert isinstance(psi, ca.SX) and psi.shape == (law.n, 1)
    return ca.Function("law", [t], [psi, dpsi, ddpsi, law.state(t)]), t, psi, dpsi


@pytest.mark.parametrize("law", _laws(), ids=lambda law: f"{law.name}-{law.n}")
def test_the_law_on_a_symbolic_time_is_its_numpy_evaluation(law):
    function, t_sym, psi_sym, dpsi_sym = _symbolic_functions(law)
    times = np.linspace(-0.3, 1.7, 41) * law.period
    values = [np.asarray(v) for v in function.map(times.size)(times[None, :])]  # (n, K) each
    np.testing.assert_allclose(values[0].T, law.psi(times), rtol=0, atol=1e-13)
    np.testing.assert_allclose(values[1].T, law.dpsi(times), rtol=0, atol=1e-12 / law.period)
    np.testing.assert_allclose(values[2].T, law.ddpsi(times), rtol=0, atol=1e-11 / law.period**2)
    np.testing.assert_allclose(values[3].T, law.state(times), rtol=0, atol=1e-12 / law.period)
    # each accessor alone, and DM and MX times, give the same columns
    for accessor in (law.psi, law.dpsi, law.ddpsi):
        single = ca.Function("one", [t_sym], [accessor(t_sym)])
        np.testing.assert_allclose(
            np.asarray(single(0.37 * law.period)).ravel(), accessor(0.37 * law.period), atol=1e-11
        )
    np.testing.assert_allclose(np.asarray(law.psi(ca.DM(0.2))).ravel(), law.psi(0.2), atol=1e-15)
    t_mx = ca.MX.sym("t")
    through_mx = ca.Function("mx", [t_mx], [law.ddpsi(t_mx)])
    np.testing.assert_allclose(np.asarray(through_mx(0.9)).ravel(), law.ddpsi(0.9), atol=1e-10)
    # and the expressions are each other's time derivatives (CasADi's own differentiation)
    rates = ca.Function("rates", [t_sym], [ca.jacobian(psi_sym, t_sym) - dpsi_sym])
    np.testing.assert_allclose(np.asarray(rates.map(times.size)(times[None, :])), 0, atol=1e-12)


@pytest.mark.parametrize("law", _laws(), ids=lambda law: f"{law.name}-{law.n}")
def test_symbolic_derivatives_against_central_differences(law):
    # The SX dpsi and ddpsi against central differences of the SX psi and dpsi (as the numpy
    # test above): h balances truncation h^2 f'''/6 against round-off eps/h.
    function, *_ = _symbolic_functions(law)
    h = 1e-5 * law.period
    t = np.linspace(-0.3, 1.7, 41) * law.period
    mapped = function.map(t.size)

    def evaluate(times):
        return [np.asarray(v).T for v in mapped(times[None, :])]

    here, ahead, behind = evaluate(t), evaluate(t + h), evaluate(t - h)
    checked = 0
    for value, derivative in ((0, 1), (1, 2)):
        numeric = (ahead[value] - behind[value]) / (2 * h)
        exact = here[derivative]
        tolerance = 1e-8 * max(np.max(np.abs(exact)), 1.0)
        np.testing.assert_allclose(exact, numeric, rtol=0, atol=tolerance)
        checked += np.count_nonzero(np.abs(exact) > 1e3 * tolerance)
    assert checked >= 0.9 * 2 * t.size * law.n, checked  # the guard: real comparisons


def test_a_symbolic_time_must_be_scalar():
    law = GaitLaw.preset("paper22")
    with pytest.raises(DefinitionError, match=r"`t`: a CasADi time must be a scalar, got shape"):
        law.psi(ca.SX.sym("t", 2))


def test_static_times():
    assert GaitLaw.preset("paper22").static_times().size == 0  # ddpsi(0) != 0
    assert np.any(np.abs(GaitLaw.preset("paper22").ddpsi(0.0)) > 1.0)
    law = GaitLaw(period=1.5, zeta=[0.3, 0.2, 0.0], varpi=[HALF_PI, -HALF_PI, 0.7])
    times = law.static_times(t_end=3.0)
    np.testing.assert_allclose(times, [0.0, 0.75, 1.5, 2.25, 3.0])
    _, dpsi, ddpsi = law(times)
    np.testing.assert_allclose(dpsi, 0.0, atol=1e-14)
    np.testing.assert_allclose(ddpsi, 0.0, atol=1e-13)


def test_dict_round_trip_and_str():
    law = GaitLaw.preset("walking")
    assert GaitLaw.from_dict(law.to_dict()) == law
    assert "T = 1 s" in str(law) and "walking" in str(law)
    assert set(LAW_PRESETS) == {"paper22", "walking"}


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"period": 0.0}, DefinitionError, r"`GaitLaw.period`: must be > 0 s, got 0.0"),
        ({"period": -1}, DefinitionError, r"`GaitLaw.period`: must be > 0 s"),
        ({"period": math.nan}, DefinitionError, r"`GaitLaw.period`: must be finite"),
        ({"period": "1"}, DefinitionTypeError, r"`GaitLaw.period`: must be a real number"),
        ({"zeta": [0.1, 0.2]}, DefinitionError, r"`GaitLaw.varpi`: has 3 values but `zeta` has 2"),
        ({"center": [0.0]}, DefinitionError, r"`GaitLaw.center`: has 1 values but `zeta` has 3"),
        ({"zeta": [0.1, -0.2, 0.3]}, DefinitionError, r"`GaitLaw.zeta\[1\]`: amplitude must be"),
        ({"varpi": [0.0, math.inf, 0]}, DefinitionError, r"`GaitLaw.varpi\[1\]`: must be finite"),
        ({"zeta": []}, DefinitionError, r"`GaitLaw.zeta`: must have one value per link"),
        ({"zeta": "abc"}, DefinitionTypeError, r"`GaitLaw.zeta`: must be a sequence"),
        ({"name": 3}, DefinitionTypeError, r"`GaitLaw.name`: must be a string"),
        (
            {"period": 1e-300},
            DefinitionError,
            r"`GaitLaw.period`: 1e-300 s is too short: the law's angular accelerations "
            r"\(~zeta \(2 pi / T\)\^2 = inf rad/s\^2\) overflow double precision",
        ),
    ],
)
def test_validation_messages(kwargs, error, message):
    values = {"period": 1.0, "zeta": [0.1, 0.2, 0.3], "varpi": [0.0, 0.5, 1.0]}
    values.update(kwargs)
    with pytest.raises(error, match=message):
        GaitLaw(**values)


def test_bad_times_and_presets():
    law = GaitLaw.preset("paper22")
    with pytest.raises(DefinitionError, match=r"`t`: must be a scalar or a 1-D array"):
        law.psi(np.zeros((2, 2)))
    with pytest.raises(DefinitionError, match=r"`t`: contains NaN or inf"):
        law.dpsi([0.0, math.nan])
    with pytest.raises(DefinitionTypeError, match=r"`t`: must be a time"):
        law.ddpsi("soon")
    with pytest.raises(DefinitionError, match=r"unknown gait-law preset 'paper23'"):
        GaitLaw.preset("paper23")
    with pytest.raises(DefinitionError, match=r"`data`: gait-law parameters lack \['varpi'\]"):
        GaitLaw.from_dict({"period": 1.0, "zeta": [0.1]})
    with pytest.raises(DefinitionTypeError, match=r"`data`: must be a dict of law parameters"):
        GaitLaw.from_dict([1.0, [0.1], [0.0]])
    with pytest.raises(DefinitionError, match=r"`t_end`: must be >= 0 s"):
        law.static_times(t_end=-1.0)


def test_the_shortest_periods_still_give_finite_torques_or_a_named_error():
    # 1e-150 s: accelerations ~1e300 rad/s^2, still finite; the torques too (a few kg m^2)
    six = Dynamics(presets.six_link_anthropoid())
    fast = GaitLaw(period=1e-150, zeta=[0.2] * 6, varpi=[0.0] * 6)
    assert np.all(np.isfinite(torques_along(six, fast, np.linspace(0, 1e-150, 5)).torques))
    # 2e-153 s: accelerations finite (~5e306 rad/s^2), the torques beyond double precision
    faster = GaitLaw(period=2e-153, zeta=[0.2] * 6, varpi=[0.0] * 6)
    with pytest.raises(
        DefinitionError,
        match=r"`law`: the torques along 'custom' overflow double precision "
        r"\(period 2e-153 s",
    ):
        torques_along(six, faster, np.linspace(0, 2e-153, 5))
