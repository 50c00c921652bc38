"""Trajectory: validation, interpolation (against scipy and convergence orders), files.

Independent checks: the cubic splines against scipy's CubicSpline (bc_type="not-a-knot", the
default, and "natural"); the interpolation orders as fitted slopes of the error over h on
smooth functions, over the whole range including the end intervals; file round trips compared
bit for bit with what was saved and with the interpolant at the export times.
"""

from __future__ import annotations

import csv
import dataclasses
import errno
import json
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from privileges import needs_permissions
from privileges import run as run_unprivileged
from scipy.interpolate import CubicSpline

from model import LinkageTrajectory
from planner import files as files_module
from planner import interpolation
from planner.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from planner.trajectory import (
    FORMAT_NAME,
    Trajectory,
    TrajectoryError,
    TrajectoryFileError,
    TrajectoryFileNotFoundError,
    TrajectoryWriteError,
)
from planner.trajectory import formats as formats_module

LINKS = ("shank", "thigh", "torso")


def linkage_trajectory(k: int = 41, duration: float = 1.3, extras: bool = True) -> Trajectory:
    """A smooth three-link motion with exact derivatives; awkward floats in every column."""
    t = np.linspace(0.0, duration, k)
    omega = np.array([1.7, 2.3, 0.9])
    phase = np.array([0.1, 0.7, 1.3])
    psi = np.pi / 2 + 0.3 * np.sin(omega * t[:, None] + phase)
    dpsi = 0.3 * omega * np.cos(omega * t[:, None] + phase)
    ddpsi = -0.3 * omega**2 * np.sin(omega * t[:, None] + phase)
    torques = np.exp(t)[:, None] * np.array([1.0 / 3.0, -2.0 / 7.0, 1e-17])
    force = (np.cos(t) / 3.0) + 1j * (700.0 + np.sin(t))
    return LinkageTrajectory.from_linkage(
        t,
        psi,
        dpsi,
        torques,
        LINKS,
        ddpsi=ddpsi if extras else None,
        ground_reaction=force if extras else None,
        metadata={"source": "test", "N": np.int64(40), "cost": np.float64(0.1), "v": (1, 2)},
    )


def generic_trajectory() -> Trajectory:
    t = np.array([0.0, 0.25, 0.6, 1.0])
    return Trajectory(
        t,
        np.column_stack([t**2, np.sin(t)]),
        np.column_stack([np.cos(t)]),
        ("x", "y"),
        ("m", "m"),
        ("u",),
        ("N",),
    )


def bits(array: np.ndarray) -> bytes:
    return np.ascontiguousarray(array, dtype=np.float64).tobytes()


def assert_identical(a: Trajectory, b: Trajectory) -> None:
    """Equal to 0 ulp (compared as bytes, so -0.0 and 0.0 differ too)."""
    assert a.columns == b.columns
    for name, _, _ in a.columns:
        assert bits(a.column(name)) == bits(b.column(name)), name
    assert a.metadata == b.metadata
    assert a == b


# ---- construction and the linkage convention -----------------------------------------------


def test_copies_are_independent_of_the_inputs():
    t = np.linspace(0.0, 1.0, 4)
    states = np.zeros((4, 1))
    traj = Trajectory(t, states, np.zeros((4, 0)), ("x",), ("m",), (), ())
    states[0, 0] = 5.0
    assert traj.states[0, 0] == 0.0
    assert traj.controls.shape == (4, 0)


def test_none_means_empty_and_replace_revalidates():
    traj = Trajectory(**{**GOOD, "extras": None, "metadata": None})
    assert dict(traj.extras) == {} and traj.metadata == {}
    with pytest.raises(TypeError):
        traj.extras["a"] = (T4, "m")  # read-only mapping
    moved = dataclasses.replace(traj, time=T4 + 1.0)
    assert moved.t0 == 1.0 and moved.duration == 1.0
    with pytest.raises(DefinitionError, match=r"`time`: must be strictly increasing"):
        dataclasses.replace(traj, time=T4[::-1])


def test_column_and_with_metadata():
    traj = generic_trajectory()
    np.testing.assert_array_equal(traj.column("t"), traj.time)
    np.testing.assert_array_equal(traj.column("u"), traj.controls[:, 0])
    with pytest.raises(TrajectoryError, match=r"no channel named 'z'; the channels are \['t'"):
        traj.column("z")
    tagged = traj.with_metadata(note="x")
    assert tagged.metadata == {"note": "x"} and traj.metadata == {}
    assert tagged != traj and generic_trajectory() == traj


def test_with_extra_adds_a_validated_channel_and_leaves_the_original():
    traj = generic_trajectory()
    values = np.arange(traj.n_samples, dtype=float) ** 2
    more = traj.with_extra("work", values, "J")
    np.testing.assert_array_equal(more.column("work"), values)
    assert more.extras["work"][1] == "J" and "work" not in traj.extras
    np.testing.assert_array_equal(more.states, traj.states)
    with pytest.raises(DefinitionError, match="work"):
        traj.with_extra("work", values[:-1], "J")


T4 = np.linspace(0.0, 1.0, 4)
GOOD = {
    "time": T4,
    "states": np.zeros((4, 2)),
    "controls": np.zeros((4, 1)),
    "state_names": ("x", "v"),
    "state_units": ("m", "m/s"),
    "control_names": ("u",),
    "control_units": ("N",),
}


@pytest.mark.parametrize(
    ("change", "error", "match"),
    [
        ({"time": [0.0]}, DefinitionError, r"`time`: a trajectory needs at least 2 samples"),
        (
            {"time": [0.0, 0.5, 0.5, 1.0]},
            DefinitionError,
            r"`time`: must be strictly increasing, got time\[2\] = 0.5 s after time\[1\] = 0.5",
        ),
        ({"time": [0.0, np.nan, 0.6, 1.0]}, DefinitionError, r"`time`: must be finite, got nan"),
        ({"time": np.zeros((4, 1))}, DefinitionError, r"`time`: must be a 1-D array"),
        ({"time": "0 1 2 3"}, DefinitionTypeError, r"`time`: must be an array of real numbers"),
        ({"time": T4 + 0j}, DefinitionTypeError, r"`time`: must hold real numbers, .*complex"),
        ({"states": np.zeros((3, 2))}, DefinitionError, r"`states`: must have one row per"),
        ({"states": np.zeros(4)}, DefinitionError, r"`states`: must be a 2-D .*reshape\(-1, 1\)"),
        (
            {"states": [[0.0, 0.0], [0.0], [0.0, 0.0], [0.0, 0.0]]},
            DefinitionError,
            r"`states`: cannot be read as an array",
        ),
        (
            {"states": np.array([[0, 0], [0, np.inf], [0, 0], [0, 0]])},
            DefinitionError,
            r"`states`: must be finite, got inf at sample 1, column 1 \(`v`\)",
        ),
        ({"controls": np.ones((4, 1), bool)}, DefinitionTypeError, r"`controls`: .*booleans"),
        ({"state_names": ("x",)}, DefinitionError, r"`state_names`: must have one name per col"),
        ({"state_names": "xv"}, DefinitionTypeError, r"`state_names`: must be a tuple of 2"),
        ({"state_names": ("x", 3)}, DefinitionTypeError, r"`state_names\[1\]`: must be a string"),
        ({"state_names": ("x", " v")}, DefinitionError, r"`state_names\[1\]`: .*leading"),
        ({"state_names": ("x", "v,w")}, DefinitionError, r"`state_names\[1\]`: name 'v,w' cont"),
        ({"state_units": ("m", "")}, DefinitionError, r"`state_units\[1\]`: .*use '1' for"),
        ({"control_units": ("[N]",)}, DefinitionError, r"`control_units\[0\]`: unit '\[N\]'"),
        ({"state_names": ("x", "x")}, DefinitionError, r"`state_names`: name 'x' is used twice"),
        ({"control_names": ("x",)}, DefinitionError, r"`control_names`: name 'x' is used twice"),
        ({"control_names": ("t",)}, DefinitionError, r"name 't' is used twice \(already the t"),
        ({"extras": [1]}, DefinitionTypeError, r"`extras`: must be a dict name -> \(values"),
        ({"extras": {"a": np.ones(4)}}, DefinitionTypeError, r"`extras\['a'\]`: must be a pair"),
        ({"extras": {"a": (np.ones(3), "N")}}, DefinitionError, r"`extras\['a'\]`: must have one"),
        ({"extras": {"a": (np.ones(4), 1)}}, DefinitionTypeError, r"`extras\['a'\] unit`"),
        ({"extras": {"u": (np.ones(4), "N")}}, DefinitionError, r"`extras`: name 'u' is used tw"),
        ({"metadata": [1]}, DefinitionTypeError, r"`metadata`: must be a dict"),
        ({"metadata": {1: 2}}, DefinitionTypeError, r"`metadata`: keys must be strings"),
        (
            {"metadata": {"a": {"b": Path("x")}}},
            DefinitionTypeError,
            r"`metadata\['a'\]\['b'\]`: must be JSON-serialisable",
        ),
    ],
)
def test_validation(change, error, match):
    with pytest.raises(error, match=match):
        Trajectory(**{**GOOD, **change})
    assert issubclass(error, AnthropoidError)


# ---- interpolation ----------------------------------------------------------------------------
def test_interpolants_reproduce_the_knots_bit_for_bit():
    traj = linkage_trajectory()
    states, controls = traj.at(traj.time)
    assert bits(states) == bits(traj.states) and bits(controls) == bits(traj.controls)
    for kind in ("cubic", "linear"):
        function = traj.control_function(kind)
        assert bits(function(traj.time)) == bits(traj.controls)
        assert all(
            bits(function(t)) == bits(row) for t, row in zip(traj.time, traj.controls, strict=True)
        )
    extras = traj.extras_at(traj.time)
    assert all(bits(extras[name]) == bits(values) for name, (values, _) in traj.extras.items())
    single_states, single_controls = traj.at(traj.time[7])
    assert single_states.shape == (6,) and single_controls.shape == (3,)
    assert bits(single_states) == bits(traj.states[7])


def random_knots(rng: np.random.Generator, k: int) -> np.ndarray:
    """Strictly increasing, non-uniform knots: neighbouring steps differ by up to 10x."""
    return 0.3 + np.cumsum(np.r_[0.0, rng.uniform(0.02, 0.2, k - 1)])


@pytest.mark.parametrize("end", ["not-a-knot", "natural"])
@pytest.mark.parametrize("k", [2, 3, 4, 5, 25])
def test_spline_matches_scipy(end, k):
    rng = np.random.default_rng(3 + k)
    t = random_knots(rng, k)
    y = rng.normal(size=(k, 3))
    slopes = interpolation.spline_slopes(t, y, end=end)
    oracle = CubicSpline(t, y, bc_type=end)
    scale = np.max(np.abs(oracle(t, 1)))
    np.testing.assert_allclose(slopes, oracle(t, 1), rtol=1e-12, atol=1e-12 * scale)
    query = np.sort(rng.uniform(t[0], t[-1], 200))
    np.testing.assert_allclose(
        interpolation.hermite(t, y, slopes, query), oracle(query), rtol=1e-12, atol=1e-12
    )
    # one channel as a 1-D array: the same numbers, a 1-D result
    single = interpolation.spline_slopes(t, y[:, 1], end=end)
    assert single.shape == (k,) and bits(single) == bits(slopes[:, 1])


def test_spline_at_1khz_matches_scipy_and_the_default_is_not_a_knot():
    # the grid of an exported torque file: 1 kHz over 0.5 s
    t = np.linspace(0.0, 0.5, 501)
    y = np.column_stack([np.exp(3 * t), np.cos(20 * t) + t**2])
    slopes = interpolation.spline_slopes(t, y)
    assert bits(slopes) == bits(interpolation.spline_slopes(t, y, end="not-a-knot"))
    np.testing.assert_allclose(slopes, CubicSpline(t, y)(t, 1), rtol=1e-12, atol=1e-12)
    natural = interpolation.natural_spline_slopes(t, y)
    assert bits(natural) == bits(interpolation.spline_slopes(t, y, end="natural"))
    np.testing.assert_allclose(
        natural, CubicSpline(t, y, bc_type="natural")(t, 1), rtol=1e-12, atol=1e-12
    )
    with pytest.raises(ValueError, match=r"`end`: must be 'not-a-knot' or 'natural'"):
        interpolation.spline_slopes(t, y, end="clamped")


def test_spline_edge_cases_two_three_and_four_knots():
    t = np.array([0.1, 0.25, 0.9, 1.0])  # non-uniform
    line = np.c_[2.0 - 3.0 * t]
    parabola = np.c_[1.0 - 2.0 * t + 5.0 * t**2]
    cubic = np.c_[0.5 + t - 4.0 * t**2 + 7.0 * t**3]
    query = np.linspace(t[0], t[-1], 101)
    # two knots: the straight line, whatever the end conditions
    for end in ("not-a-knot", "natural"):
        slopes = interpolation.spline_slopes(t[:2], line[:2], end=end)
        np.testing.assert_allclose(slopes, [[-3.0], [-3.0]], rtol=1e-14)
    # three knots: not-a-knot is the parabola through them (exact on a parabola); the
    # natural spline is not
    slopes = interpolation.spline_slopes(t[:3], parabola[:3])
    np.testing.assert_allclose(slopes[:, 0], -2.0 + 10.0 * t[:3], rtol=1e-13)
    inside = query[query <= t[2]]
    np.testing.assert_allclose(
        interpolation.hermite(t[:3], parabola[:3], slopes, inside)[:, 0],
        1.0 - 2.0 * inside + 5.0 * inside**2,
        rtol=1e-13,
    )
    natural = interpolation.spline_slopes(t[:3], parabola[:3], end="natural")
    assert np.max(np.abs(natural[:, 0] - (-2.0 + 10.0 * t[:3]))) > 0.1
    # four knots: not-a-knot is the cubic through them (exact on a cubic)
    slopes = interpolation.spline_slopes(t, cubic)
    np.testing.assert_allclose(slopes[:, 0], 1.0 - 8.0 * t + 21.0 * t**2, rtol=1e-12)
    np.testing.assert_allclose(
        interpolation.hermite(t, cubic, slopes, query)[:, 0],
        0.5 + query - 4.0 * query**2 + 7.0 * query**3,
        rtol=1e-13,
    )
    # and through a Trajectory with those few samples
    for k in (2, 3, 4):
        traj = Trajectory(t[:k], cubic[:k], cubic[:k], ("x",), ("m",), ("u",), ("N",))
        oracle = CubicSpline(t[:k], cubic[:k, 0])
        states, controls = traj.at(query[query <= t[k - 1]])
        np.testing.assert_allclose(controls[:, 0], oracle(query[query <= t[k - 1]]), rtol=1e-13)
        assert bits(states) == bits(controls)


def test_thomas_sweep_is_stable_on_very_non_uniform_knots():
    # the not-a-knot first row is not diagonally dominant; steps spanning four decades must
    # still give scipy's slopes (scipy solves with partial pivoting)
    rng = np.random.default_rng(11)
    for k in (4, 5, 6, 9, 30):
        for _ in range(20):
            t = np.cumsum(np.r_[0.0, 10.0 ** rng.uniform(-2, 2, k - 1)])
            y = np.sin(3 * t / t[-1]) + 0.1 * rng.normal(size=k)
            slopes = interpolation.spline_slopes(t, y)
            oracle = CubicSpline(t, y)(t, 1)
            assert np.max(np.abs(slopes - oracle)) <= 1e-9 * np.max(np.abs(oracle)), (k, t)


def fitted_order(errors: list[float], steps: list[float]) -> float:
    return float(np.polyfit(np.log(steps), np.log(errors), 1)[0])


def test_hermite_with_derivative_channels_converges_at_fourth_order():
    errors, steps = [], []
    query = np.linspace(0.0, 2.0, 2001)
    for k in (9, 17, 33, 65, 129):
        t = np.linspace(0.0, 2.0, k)
        traj = LinkageTrajectory.from_linkage(
            t, np.sin(3 * t)[:, None], 3 * np.cos(3 * t)[:, None], np.zeros((k, 1)), ["a"]
        )
        states, _ = traj.at(query)
        errors.append(np.max(np.abs(states[:, 0] - np.sin(3 * query))))
        steps.append(t[1] - t[0])
    order = fitted_order(errors, steps)
    assert order >= 4 - 0.3, (order, errors)


def spline_errors(grid, end=None, steps_per_unit=(10, 20, 40, 80, 160)):
    """Max errors of a cubic spline on exp(t) and cos(4 t) over [0, 1], whose curvature is not
    zero at the ends: with ``end=None`` the Trajectory's own (a state without derivative
    channel and a control), else ``interpolation.spline_slopes(..., end=end)``.

    ``grid`` maps s in [0, 1] to the knots. Returns (whole range, end intervals only,
    largest step h) per resolution.
    """
    whole, ends, steps = [], [], []
    for k in steps_per_unit:
        t = grid(np.linspace(0.0, 1.0, k + 1))
        t[0], t[-1] = 0.0, 1.0
        query = np.linspace(0.0, 1.0, 40 * k + 1)  # every interval, the end ones included
        exact = np.column_stack([np.exp(query), np.cos(4 * query)])
        values = np.column_stack([np.exp(t), np.cos(4 * t)])
        if end is None:
            traj = Trajectory(t, values[:, :1], values[:, 1:], ("x",), ("m",), ("u",), ("N",))
            got = np.hstack(traj.at(query))
        else:
            slopes = interpolation.spline_slopes(t, values, end=end)
            got = interpolation.hermite(t, values, slopes, query)
        error = np.max(np.abs(got - exact), axis=1)
        whole.append(float(np.max(error)))
        end_intervals = (query <= t[1]) | (query >= t[-2])
        ends.append(float(np.max(error[end_intervals])))
        steps.append(float(np.max(np.diff(t))))
    return whole, ends, steps


@pytest.mark.parametrize(
    "grid",
    [lambda s: s, lambda s: s + 0.15 * np.sin(np.pi * s)],  # uniform, then smoothly non-uniform
    ids=["uniform", "non-uniform"],
)
def test_not_a_knot_spline_converges_at_fourth_order_up_to_the_ends(grid):
    whole, ends, steps = spline_errors(grid)
    order = fitted_order(whole, steps)
    assert order >= 3.7, (order, whole)
    assert fitted_order(ends, steps) >= 3.7, ends


def test_natural_spline_is_second_order_at_the_ends():
    # the same measurement with the natural spline: y'' = 0 is wrong at the ends, so the
    # whole-range error is O(h^2), set by the end intervals; the fourth-order test above
    # tells the two apart.
    whole, ends, steps = spline_errors(lambda s: s, end="natural")
    assert 1.7 <= fitted_order(whole, steps) <= 2.3, whole
    assert 1.7 <= fitted_order(ends, steps) <= 2.3, ends
    assert whole == ends  # the worst error is in an end interval
    fourth, _, _ = spline_errors(lambda s: s, end="not-a-knot")
    assert fourth == spline_errors(lambda s: s)[0]  # the Trajectory's default
    assert fourth[-1] < whole[-1] / 100, (fourth, whole)


def test_hermite_uses_derivative_channels_exactly_on_cubics():
    # x = t^3 with dx = 3t^2: Hermite is exact, and so is the not-a-knot spline without dx
    # (it reproduces cubics); the natural spline is not
    t = np.array([0.0, 0.3, 0.5, 1.1, 1.2, 2.0])
    query = np.linspace(0.0, 2.0, 97)
    with_derivative = Trajectory(
        t, np.c_[t**3, 3 * t**2], np.zeros((6, 0)), ("x", "dx"), ("m", "m/s"), (), ()
    )
    without = Trajectory(t, np.c_[t**3], np.zeros((6, 0)), ("x",), ("m",), (), ())
    assert with_derivative.hermite_states == ("x",) and without.hermite_states == ()
    np.testing.assert_allclose(with_derivative.at(query)[0][:, 0], query**3, atol=1e-13)
    np.testing.assert_allclose(without.at(query)[0][:, 0], query**3, atol=1e-13)
    natural = interpolation.hermite(
        t, t[:, None] ** 3, interpolation.natural_spline_slopes(t, t**3)[:, None], query
    )
    assert np.max(np.abs(natural[:, 0] - query**3)) > 1e-3
    # the derivative channel is what sets the slopes: a wrong one shows
    skewed = Trajectory(
        t, np.c_[t**3, 3 * t**2 + 1.0], np.zeros((6, 0)), ("x", "dx"), ("m", "m/s"), (), ()
    )
    expected = interpolation.hermite(t, t[:, None] ** 3, (3 * t**2 + 1.0)[:, None], query)
    assert bits(skewed.at(query)[0][:, :1]) == bits(expected)
    assert np.max(np.abs(expected[:, 0] - query**3)) > 1e-2
    # a "dx" with the wrong unit is not taken for the derivative
    wrong = Trajectory(t, np.c_[t**3, 3 * t**2], np.zeros((6, 0)), ("x", "dx"), ("m", "N"), (), ())
    assert wrong.hermite_states == ()


def test_dpsi_uses_ddpsi_when_stored():
    full = linkage_trajectory(k=9)
    bare = linkage_trajectory(k=9, extras=False)
    query = np.linspace(0.0, 1.3, 301)
    omega, phase = np.array([1.7, 2.3, 0.9]), np.array([0.1, 0.7, 1.3])
    exact = 0.3 * omega * np.cos(omega * query[:, None] + phase)
    error_full = np.max(np.abs(full.at(query)[0][:, 3:] - exact))
    error_bare = np.max(np.abs(bare.at(query)[0][:, 3:] - exact))
    assert error_full < error_bare / 5, (error_full, error_bare)


def test_queries_outside_the_range_raise_and_the_ends_are_clamped():
    traj = linkage_trajectory()
    with pytest.raises(
        TrajectoryError,
        match=r"`t`: 1.5 s is outside the trajectory's time "
        r"range \[0.0, 1.3\] s \(1 of 2 queries\).*does not extrapolate",
    ):
        traj.at(np.array([0.2, 1.5]))
    with pytest.raises(TrajectoryError, match=r"-0.001 s is outside"):
        traj.control_function()(-0.001)
    with pytest.raises(TrajectoryError, match=r"outside"):
        traj.control_function("linear")(np.array([1.31]))
    with pytest.raises(DefinitionError, match=r"`t`: times must be finite, got nan"):
        traj.control_function()(float("nan"))
    with pytest.raises(DefinitionError, match=r"`t`: must be a real number or a 1-D array"):
        traj.at(np.zeros((2, 2)))
    with pytest.raises(DefinitionError, match=r"`kind`: must be 'cubic' or 'linear'"):
        traj.control_function("spline")
    end = traj.tf * (1 + 4e-16)
    assert end > traj.tf
    assert bits(traj.control_function()(end)) == bits(traj.controls[-1])
    assert bits(traj.at(np.array([-1e-13]))[0][0]) == bits(traj.states[0])


def test_control_function_shapes_and_kinds():
    traj = linkage_trajectory()
    cubic, linear = traj.control_function(), traj.control_function("linear")
    query = np.linspace(0.0, 1.3, 57)
    assert cubic(0.4).shape == (3,) and cubic(query).shape == (57, 3)
    assert cubic(np.float32(0.4)).shape == (3,) and cubic(1).shape == (3,)
    assert bits(cubic(query)) == bits(traj.at(query)[1])
    # scalar fast path = vectorised path, bit for bit
    assert bits(np.array([cubic(float(q)) for q in query])) == bits(cubic(query))
    assert bits(np.array([linear(float(q)) for q in query])) == bits(linear(query))
    # linear interpolation of samples of a straight line is the line
    t = traj.time
    line = Trajectory(t, np.c_[t], np.c_[2 * t - 1], ("x",), ("m",), ("u",), ("N",))
    np.testing.assert_allclose(
        line.control_function("linear")(query)[:, 0], 2 * query - 1, atol=1e-15
    )
    assert "cubic" in repr(cubic)


# ---- resampling ---------------------------------------------------------------------------
def test_resample_at_a_rate_includes_the_end_and_equals_the_interpolant():
    traj = linkage_trajectory()
    resampled = traj.resample(rate_hz=20.0)
    expected = np.append(np.arange(26) / 20.0, 1.3)
    np.testing.assert_allclose(resampled.time, expected, rtol=0, atol=1e-15)
    assert resampled.time[-1] == traj.tf
    states, controls = traj.at(resampled.time)
    assert bits(resampled.states) == bits(states) and bits(resampled.controls) == bits(controls)
    extras = traj.extras_at(resampled.time)
    assert all(bits(resampled.extras[n][0]) == bits(extras[n]) for n in traj.extras)
    assert resampled.metadata["resampled"] == {"rate_hz": 20.0, "source_samples": 41}
    # a duration that is a whole number of periods gives a uniform grid
    assert traj.resample(rate_hz=10.0).n_samples == 14
    assert traj.resample(rate_hz=0.1).time.tolist() == [0.0, 1.3]


def test_resample_at_given_times_and_errors():
    traj = linkage_trajectory()
    times = np.array([0.1, 0.2, 1.3])
    resampled = traj.resample(times=times)
    assert bits(resampled.states) == bits(traj.at(times)[0])
    assert resampled.metadata["resampled"]["rate_hz"] is None
    with pytest.raises(DefinitionError, match="give exactly one of rate_hz"):
        traj.resample()
    with pytest.raises(DefinitionError, match="give exactly one of rate_hz"):
        traj.resample(rate_hz=10, times=times)
    with pytest.raises(DefinitionError, match=r"`rate_hz`: must be > 0 Hz"):
        traj.resample(rate_hz=-1)
    with pytest.raises(DefinitionTypeError, match=r"`rate_hz`: must be a real number"):
        traj.resample(rate_hz="10")
    with pytest.raises(DefinitionError, match=r"`times`: must be at least 2 strictly"):
        traj.resample(times=[0.2, 0.1])
    with pytest.raises(TrajectoryError, match=r"`times`: 2.0 s is outside"):
        traj.resample(times=[0.2, 2.0])


# ---- files --------------------------------------------------------------------------------
FORMATS = (".csv", ".json", ".npz")


@pytest.mark.parametrize("suffix", FORMATS)
def test_round_trip_at_the_samples_is_bit_for_bit(tmp_path, suffix):
    traj = linkage_trajectory()
    path = traj.save(tmp_path / f"motion{suffix}")
    assert path == tmp_path / f"motion{suffix}"
    assert_identical(Trajectory.load(path), traj)
    generic = generic_trajectory().with_metadata(cost=float("nan"), nested={"a": [1.5, None]})
    generic.save(tmp_path / f"generic{suffix}")
    back = Trajectory.load(tmp_path / f"generic{suffix}")
    assert back.columns == generic.columns and np.isnan(back.metadata["cost"])
    assert bits(back.states) == bits(generic.states)
    assert back.controls.shape == (4, 1) and not back.extras


@pytest.mark.parametrize("suffix", FORMATS)
def test_round_trip_at_a_rate_equals_the_interpolant(tmp_path, suffix):
    traj = linkage_trajectory()
    path = traj.save(str(tmp_path / f"motion{suffix}"), rate_hz=37.0)
    back = LinkageTrajectory.load(path)
    assert back.time[0] == 0.0 and back.time[-1] == traj.tf and back.n_samples == 50
    states, controls = traj.at(back.time)
    assert bits(back.states) == bits(states)
    assert bits(back.controls) == bits(controls)
    extras = traj.extras_at(back.time)
    for name in traj.extras:
        assert bits(back.extras[name][0]) == bits(extras[name])
    assert back.metadata["resampled"] == {"rate_hz": 37.0, "source_samples": 41}
    assert back.link_names == LINKS


def test_csv_layout_is_readable_by_spreadsheets_numpy_and_pandas(tmp_path):
    traj = linkage_trajectory(k=3)
    path = traj.save(tmp_path / "m.csv")
    lines = path.read_text().splitlines()
    header = lines[0]
    assert len(lines) == 1 + 3 and not any(line.startswith("#") for line in lines)
    assert header.startswith("t [s],psi_shank [rad],psi_thigh [rad],psi_torso [rad],dpsi_shank")
    assert "M_torso [N m],ddpsi_shank [rad/s^2]" in header
    assert header.endswith("F_shank_start_x [N],F_shank_start_y [N]")
    # the rest beside it, in the sidecar
    sidecar = json.loads((tmp_path / "m.csv.meta.json").read_text())
    assert sidecar["format"] == FORMAT_NAME and sidecar["metadata"] == traj.metadata
    assert sidecar["groups"]["control"] == list(traj.control_names)
    # every reader with no options
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    assert table.shape == (3, 1 + 6 + 3 + 5)
    assert bits(table[:, 1:7]) == bits(traj.states)
    named = np.genfromtxt(path, delimiter=",", names=True)  # "t [s]" -> "t_s"
    assert named.dtype.names[:2] == ("t_s", "psi_shank_rad") and named.shape == (3,)
    assert bits(named["psi_shank_rad"]) == bits(traj.states[:, 0])
    assert bits(named["F_shank_start_y_N"]) == bits(traj.extras["F_shank_start_y"][0])
    with open(path, newline="") as handle:
        rows = list(csv.reader(handle))
    assert rows[0][0] == "t [s]" and len(rows) == 1 + 3
    assert bits(np.array(rows[1:], dtype=float)[:, 1:7]) == bits(traj.states)
    pandas = pytest.importorskip("pandas")
    frame = pandas.read_csv(path)
    assert list(frame.columns[:2]) == ["t [s]", "psi_shank [rad]"] and frame.shape == (3, 15)
    assert bits(frame["psi_shank [rad]"].to_numpy()) == bits(traj.states[:, 0])
    # without its sidecar it reads as a file made by hand: the same columns and groups
    (tmp_path / "m.csv.meta.json").unlink()
    alone = LinkageTrajectory.load(path)
    assert alone.metadata == {} and alone.control_names == traj.control_names
    assert bits(alone.states) == bits(traj.states)
    # the generic trajectory knows no naming convention: every column of such a file a state
    generic = Trajectory.load(path)
    assert generic.state_names == tuple(name for name, _, _ in traj.columns[1:])


def _old_layout(traj, path, before: bool = True) -> None:
    """``traj`` as the CSV files of earlier versions wrote it: the format, version, groups
    and metadata as ``#`` comment lines before (or right after) the header, no sidecar."""
    written = traj.save(path)
    lines = written.read_text().splitlines()
    groups = {"state": list(traj.state_names), "control": list(traj.control_names),
              "extra": list(traj.extras)}  # fmt: skip
    comments = [
        f"# format: {json.dumps(FORMAT_NAME)}",
        "# version: 1",
        f"# groups: {json.dumps(groups)}",
        f"# metadata: {json.dumps(traj.metadata)}",
    ]
    layout = [*comments, *lines] if before else [lines[0], *comments, *lines[1:]]
    written.write_text("\n".join(layout) + "\n")
    (path.parent / (path.name + ".meta.json")).unlink()


def test_a_csv_with_the_comments_before_the_header_still_reads_back(tmp_path):
    # the layouts of files written before the sidecar: comments before or after the header
    traj = linkage_trajectory(k=4)
    path = tmp_path / "old.csv"
    for before in (True, False):
        _old_layout(traj, path, before)
        assert_identical(Trajectory.load(path), traj)
    _old_layout(traj, path)
    lines = path.read_text().splitlines()
    path.write_text("\n".join([*lines[:5], lines[1], *lines[5:]]) + "\n")  # a second version
    with pytest.raises(TrajectoryFileError, match=r"line 6: a second `# version:` comment"):
        Trajectory.load(path)


def test_hand_made_csv_infers_groups(tmp_path):
    path = tmp_path / "hand.csv"
    path.write_text(
        "\ufeff# written by hand\r\n"
        't [s], psi_a [rad],dpsi_a [rad/s],"M_a [N m]",Fx [N]\r\n'
        "0,1,2,3,4\r\n\r\n0.5,1.5,2.5,3.5,4.5\r\n"
    )
    assert Trajectory.load(path).state_names == ("psi_a", "dpsi_a", "M_a", "Fx")
    traj = LinkageTrajectory.load(path)
    assert traj.state_names == ("psi_a", "dpsi_a") and traj.control_names == ("M_a",)
    assert list(traj.extras) == ["Fx"] and traj.metadata == {}
    np.testing.assert_array_equal(traj.torques[:, 0], [3.0, 3.5])


def test_a_file_reordered_in_a_spreadsheet_reads_back_in_group_order(tmp_path):
    traj = generic_trajectory()
    path = traj.save(tmp_path / "g.csv")
    lines = path.read_text().splitlines()
    swapped = [
        ",".join(np.array(line.split(","))[[0, 3, 2, 1]]) if not line.startswith("#") else line
        for line in lines
    ]
    path.write_text("\n".join(swapped) + "\n")
    assert_identical(Trajectory.load(path), traj)


def test_a_file_saved_again_by_a_spreadsheet_reads_back(tmp_path):
    # spreadsheets pad every row to the widest one and quote cells holding commas or quotes
    traj = linkage_trajectory(k=5)
    for old in (False, True):  # this version's file with its sidecar, and an old one
        path = tmp_path / "m.csv"
        if old:
            _old_layout(traj, path)
        else:
            traj.save(path)
        rows = [next(csv.reader([line])) for line in path.read_text().splitlines()]
        width = max(len(row) for row in rows)
        with open(tmp_path / "resaved.csv", "w", newline="") as handle:
            writer = csv.writer(handle, lineterminator="\r\n")
            for row in rows:
                writer.writerow(row + [""] * (width - len(row)))
        sidecar = tmp_path / "m.csv.meta.json"
        if sidecar.exists():
            sidecar.rename(tmp_path / "resaved.csv.meta.json")
        else:
            assert '"# format: ""anthropoid' in (tmp_path / "resaved.csv").read_text()
        assert_identical(Trajectory.load(tmp_path / "resaved.csv"), traj)


def test_save_errors(tmp_path):
    traj = generic_trajectory()
    with pytest.raises(
        TrajectoryFileError,
        match=r"unknown trajectory format '.txt'; the "
        r"formats are .csv, .json, .npz",
    ):
        traj.save(tmp_path / "x.txt")
    with pytest.raises(TrajectoryFileError, match=r"'\(no suffix\)'"):
        traj.save(tmp_path / "x")
    with pytest.raises(
        TrajectoryFileNotFoundError,
        match=r"the folder .*missing' does not "
        r"exist; create it first",
    ):
        traj.save(tmp_path / "missing" / "x.csv")
    (tmp_path / "dir.csv").mkdir()
    with pytest.raises(TrajectoryFileError, match=r"this is a folder"):
        traj.save(tmp_path / "dir.csv")
    with pytest.raises(DefinitionTypeError, match=r"`path`: must be a file path"):
        traj.save(3)
    assert issubclass(TrajectoryFileNotFoundError, FileNotFoundError)


@pytest.mark.parametrize("suffix", FORMATS)
def test_atomic_write_leaves_nothing_when_the_rename_fails(tmp_path, monkeypatch, suffix):
    def refuse(source, target):
        raise OSError("disk on fire")

    monkeypatch.setattr(formats_module.os, "replace", refuse)
    with pytest.raises(OSError, match="disk on fire"):
        generic_trajectory().save(tmp_path / f"x{suffix}")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("suffix", FORMATS)
def test_atomic_write_keeps_the_old_file_when_the_writer_fails(tmp_path, monkeypatch, suffix):
    path = linkage_trajectory().save(tmp_path / f"x{suffix}")
    before = path.read_bytes()

    def broken(trajectory, handle):
        handle.write(b"partial" if suffix == ".npz" else "partial")
        raise RuntimeError("writer broke")

    monkeypatch.setitem(formats_module._WRITERS, suffix, (broken, suffix == ".npz"))
    with pytest.raises(RuntimeError, match="writer broke"):
        generic_trajectory().save(path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == _written(path)


@pytest.mark.parametrize("suffix", FORMATS)
def test_a_full_disk_names_the_file_and_leaves_nothing(tmp_path, monkeypatch, suffix):
    path = linkage_trajectory().save(tmp_path / f"x{suffix}")
    before = path.read_bytes()

    def full(trajectory, handle):
        raise OSError(errno.ENOSPC, "No space left on device")  # as write() raises it: no file

    monkeypatch.setitem(formats_module._WRITERS, suffix, (full, suffix == ".npz"))
    with pytest.raises(
        TrajectoryWriteError,
        match=rf"x\{suffix}: cannot save: No space left on device; the disk is full",
    ) as caught:
        generic_trajectory().save(path)
    assert caught.value.filename == str(path) and caught.value.errno == errno.ENOSPC
    assert isinstance(caught.value, OSError) and isinstance(caught.value, AnthropoidError)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == _written(path)


def _written(path) -> list[str]:
    """What saving ``path`` leaves in its folder: the file, and a CSV's sidecar."""
    return sorted([path.name] + ([path.name + ".meta.json"] if path.suffix == ".csv" else []))


def test_a_folder_without_write_permission_names_the_file_not_the_temporary(tmp_path, monkeypatch):
    def refuse(dir, prefix, suffix):
        raise PermissionError(errno.EACCES, "Permission denied", f"{dir}/{prefix}abc{suffix}")

    monkeypatch.setattr(files_module.tempfile, "mkstemp", refuse)
    with pytest.raises(TrajectoryWriteError) as caught:
        generic_trajectory().save(tmp_path / "x.csv")
    message = str(caught.value)
    assert message == (
        f"{tmp_path / 'x.csv'}: cannot save: Permission denied; the folder is not writable; "
        "save elsewhere or change its permissions"
    )
    assert ".x.csv." not in message and caught.value.filename == str(tmp_path / "x.csv")


@needs_permissions
def test_a_read_only_folder_names_the_file(tmp_path):
    # In a child that obeys the permissions (root's drops the capabilities that ignore them).
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o555)
    script = f"""
import sys
sys.path.insert(0, {str(Path(__file__).parent)!r})
from test_trajectory import generic_trajectory
from planner.trajectory import TrajectoryWriteError
try:
    generic_trajectory().save({str(folder / "x.csv")!r})
except TrajectoryWriteError as error:
    print(error)
    sys.exit(3)
"""
    try:
        result = run_unprivileged([sys.executable, "-c", script], capture_output=True, text=True,
                                  timeout=120)  # fmt: skip
    finally:
        folder.chmod(0o755)
    assert result.returncode == 3, result.stderr
    assert result.stdout.strip().startswith(f"{folder / 'x.csv'}: cannot save: Permission denied")
    assert list(folder.iterdir()) == []


def test_a_file_size_limit_leaves_no_partial_file(tmp_path):
    # A real OSError (EFBIG) from the system: a child process limited to 2 kB of file size.
    path = tmp_path / "big.csv"
    path.write_text("old content\n")
    script = f"""
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (2048, 2048))
sys.path.insert(0, {str(Path(__file__).parent)!r})
from test_trajectory import linkage_trajectory
from planner.trajectory import TrajectoryWriteError
try:
    linkage_trajectory(k=400).save({str(path)!r})
except TrajectoryWriteError as error:
    print(error)
    sys.exit(3)
"""
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert result.returncode == 3, result.stderr
    assert result.stdout.strip() == (
        f"{path}: cannot save: File too large; the file exceeds the size limit; write fewer samples"
    )
    assert path.read_text() == "old content\n"
    assert [p.name for p in tmp_path.iterdir()] == ["big.csv"]


def test_malformed_numbers_in_json_and_npz_are_file_errors(tmp_path):
    path = linkage_trajectory().save(tmp_path / "x.json")
    document = json.loads(path.read_text())
    document["data"]["t"][3] = 10**400  # valid JSON, beyond any float
    path.write_text(json.dumps(document))
    with pytest.raises(
        TrajectoryFileError,
        match=r"data\['t'\]\[3\] must be finite, got an integer of 401 digits",
    ):
        Trajectory.load(path)
    npz = linkage_trajectory().save(tmp_path / "x.npz")
    with np.load(npz) as archive:
        arrays = dict(archive)
    for version in (np.array([1, 2]), np.array([1])):
        arrays["version"] = version
        np.savez(tmp_path / "v.npz", **arrays)
        with pytest.raises(
            TrajectoryFileError, match=r"version must be an integer, got array\(\[1"
        ):
            Trajectory.load(tmp_path / "v.npz")


def test_a_huge_version_or_format_is_quoted_short(tmp_path):
    # A 400-digit version (newer than any), a negative one, a 5000-digit one (beyond Python's
    # int-to-str limit: json itself refuses it) and a 10,000-character format name: each
    # message names the field and stays one short line, never all the digits.
    def message(path):
        with pytest.raises(TrajectoryFileError) as caught:
            Trajectory.load(path)
        text = str(caught.value)
        assert len(text) < 300 and "0" * 40 not in text and "x" * 50 not in text, text
        return text

    path = linkage_trajectory().save(tmp_path / "x.json")
    document = json.loads(path.read_text())
    cases = [
        (
            "version",
            10**400,
            r"format version an integer of 401 digits \(100000000000\.\.\.\) is newer",
        ),
        ("version", -(10**400), r"unknown format version an integer of 401 digits \(-10000000000"),
        ("format", "x" * 10_000, r"format is 'xxxxxxxx.*\.\.\. \(10002 characters\), expected"),
    ]
    for key, value, expected in cases:
        path.write_text(json.dumps({**document, key: value}))
        assert re.search(rf"x\.json: top level: {expected}", message(path)), key
    # Beyond 4300 digits json.loads raises ValueError: a file error here, quoted short.
    path.write_text(path.read_text().replace('"version": 1', '"version": ' + "9" * 5000, 1))
    assert "not a readable JSON trajectory (Exceeds the limit" in message(path)
    # The same in an old CSV's `# version:` comment, and in a sidecar.
    csv_path = tmp_path / "x.csv"
    _old_layout(linkage_trajectory(), csv_path)
    text = csv_path.read_text()
    assert "# version: 1\n" in text
    csv_path.write_text(text.replace("# version: 1\n", f"# version: {10**400}\n", 1))
    assert re.search(r"format version an integer of 401 digits \(1000", message(csv_path))
    csv_path.write_text(text.replace("# version: 1\n", f"# version: {'7' * 5000}\n", 1))
    assert re.search(r"line \d+: the `# version:` comment cannot be read", message(csv_path))
    linkage_trajectory().save(csv_path)
    sidecar = tmp_path / "x.csv.meta.json"
    sidecar.write_text(sidecar.read_text().replace('"version": 1', f'"version": {10**400}', 1))
    assert re.search(r"the sidecar: format version an integer of 401 digits", message(csv_path))
    sidecar.write_text("{not json")
    assert "the sidecar is not valid JSON" in message(csv_path)


def test_saved_file_gets_ordinary_permissions(tmp_path):
    path = generic_trajectory().save(tmp_path / "p.csv")
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask


def test_load_missing_file_and_unknown_suffix(tmp_path):
    with pytest.raises(TrajectoryFileNotFoundError, match=r"nope.csv: no such file"):
        Trajectory.load(tmp_path / "nope.csv")
    with pytest.raises(FileNotFoundError):
        Trajectory.load(tmp_path / "nope.json")
    with pytest.raises(TrajectoryFileError, match=r"unknown trajectory format '.xlsx'"):
        Trajectory.load(tmp_path / "a.xlsx")
    (tmp_path / "d.npz").mkdir()
    with pytest.raises(TrajectoryFileError, match=r"is a folder"):
        Trajectory.load(tmp_path / "d.npz")


HEADER = "t [s],x [m],u [N]\n"


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (HEADER + "0,1,2\n0.5,1\n", r"line 3: 2 cells, but the header on line 1 has 3 columns"),
        (HEADER + "0,1,2\n0.5,abc,2\n", r"line 3, column 2 \(`x`\): 'abc' is not a number"),
        (HEADER + "0,1,2\n0.5,nan,2\n", r"line 3, column 2 \(`x`\): must be finite, got 'nan'"),
        (HEADER + "0,1,2\n0,1,2\n", r"line 3: time 0.0 s does not come after 0.0 s on line 2"),
        (HEADER + "0,1,2\n", r"1 data row\(s\) after the header on line 1; .*at least 2"),
        ("# only comments\n", r"no header row; the first line that is not a # comment"),
        ("time [s],x [m]\n0,1\n1,2\n", r"line 1, column 1: the first column must be `t \[s\]`"),
        ("t [s],x\n0,1\n1,2\n", r"line 1, column 2: header cell 'x' must read `name \[unit\]`"),
        ("t [s],x [m],x [m]\n0,1,1\n1,2,2\n", r"line 1: the header names \['x'\] more than once"),
        ("# groups: {oops\n" + HEADER, r"line 1: the `# groups:` comment is not valid JSON"),
        (
            '# groups: {"state": ["x", "y"], "control": ["u"]}\n' + HEADER + "0,1,2\n1,2,3\n",
            r"the columns \['y'\] listed in the groups are missing from the data",
        ),
        (
            '# groups: {"state": [], "control": ["u"]}\n' + HEADER + "0,1,2\n1,2,3\n",
            r"the columns \['x'\] are not listed in the groups",
        ),
        (
            '# groups: {"states": ["x"]}\n' + HEADER + "0,1,2\n1,2,3\n",
            r"groups must be an object",
        ),
        ('# format: "something else"\n' + HEADER, r"format is 'something else', expected"),
        (
            f'# format: "{FORMAT_NAME}"\n# version: 9\n' + HEADER,
            r"format version 9 is newer than this library reads \(1\); upgrade",
        ),
        ("t [s],x [m],u [N,m]\n0,1,2\n1,2,3\n", r"line 1, column 3: header cell 'u \[N'"),
    ],
)
def test_csv_load_errors_name_the_line_and_the_fix(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(TrajectoryFileError, match=match) as caught:
        Trajectory.load(path)
    assert str(path) in str(caught.value)


def test_csv_constructor_errors_are_prefixed_with_the_file(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("t [s],x [m],x2 [m#]\n0,1,2\n1,2,3\n")
    with pytest.raises(TrajectoryFileError, match=rf"{path}: `state_units\[1\]`: unit 'm#'"):
        Trajectory.load(path)
    path.write_bytes(b"t [s]\xff\n")
    with pytest.raises(TrajectoryFileError, match=r"not a UTF-8 text file"):
        Trajectory.load(path)


def json_document(tmp_path) -> dict:
    path = generic_trajectory().save(tmp_path / "good.json")
    return json.loads(path.read_text())


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda d: "[1, 2", r"line 1, column 6: not valid JSON"),
        (lambda d: [1], r"the top level must be an object"),
        (lambda d: {k: v for k, v in d.items() if k != "data"}, r"missing key\(s\) \['data'\]"),
        (lambda d: {**d, "format": "csv"}, r"format is 'csv', expected"),
        (lambda d: {**d, "version": 2}, r"format version 2 is newer"),
        (lambda d: {**d, "version": "1"}, r"version must be an integer"),
        (lambda d: {**d, "version": 0}, r"top level: unknown format version 0"),
        (lambda d: {**d, "columns": {}}, r"`columns` must be a list"),
        (lambda d: {**d, "columns": d["columns"][1:]}, r"columns\[0\] must be \{'name': 't'"),
        (
            lambda d: {**d, "columns": [*d["columns"], {"name": "z", "unit": "m"}]},
            r"columns\[4\] must be \{'name': str",
        ),
        (
            lambda d: {**d, "columns": [*d["columns"], d["columns"][1]]},
            r"`columns` names a column twice",
        ),
        (
            lambda d: {**d, "data": {k: v for k, v in d["data"].items() if k != "y"}},
            r"data\['y'\] is missing",
        ),
        (lambda d: {**d, "data": {**d["data"], "y": [0, 1, 2]}}, r"data\['y'\] has 3 values but"),
        (lambda d: {**d, "data": {**d["data"], "y": [0, "1", 2, 3]}}, r"data\['y'\]\[1\] is '1'"),
        (lambda d: {**d, "data": {**d["data"], "y": 5}}, r"data\['y'\] must be a list"),
        (
            lambda d: {**d, "data": {**d["data"], "y": [0, float("inf"), 2, 3]}},
            r"data\['y'\]\[1\] must be finite",
        ),
        (lambda d: {**d, "data": {**d["data"], "w": [1, 2, 3, 4]}}, r"data holds \['w'\] that"),
        (
            lambda d: {**d, "data": {**d["data"], "t": [0, 1, 1, 2]}},
            r"`time`: must be strictly increasing",
        ),
    ],
)
def test_json_load_errors(tmp_path, edit, match):
    result = edit(json_document(tmp_path))
    path = tmp_path / "bad.json"
    path.write_text(result if isinstance(result, str) else json.dumps(result))
    with pytest.raises(TrajectoryFileError, match=match) as caught:
        Trajectory.load(path)
    assert str(path) in str(caught.value)


def test_npz_load_errors(tmp_path):
    path = tmp_path / "bad.npz"
    path.write_bytes(b"not a zip")
    with pytest.raises(TrajectoryFileError, match=r"bad.npz: not a readable .npz archive"):
        Trajectory.load(path)
    good = generic_trajectory().save(tmp_path / "good.npz")
    with np.load(good) as archive:
        arrays = {k: archive[k] for k in archive.files}
    np.savez(path.with_suffix(""), **{k: v for k, v in arrays.items() if k != "states"})
    with pytest.raises(TrajectoryFileError, match=r"missing array\(s\) \['states'\]"):
        Trajectory.load(path)
    np.savez(path.with_suffix(""), **{**arrays, "metadata": np.array("{no")})
    with pytest.raises(TrajectoryFileError, match=r"array 'metadata' is not valid JSON"):
        Trajectory.load(path)
    np.savez(path.with_suffix(""), **{**arrays, "format": np.array("other")})
    with pytest.raises(TrajectoryFileError, match=r"format is 'other'"):
        Trajectory.load(path)
    np.savez(path.with_suffix(""), **{**arrays, "state_names": np.array([1.0, 2.0])})
    with pytest.raises(TrajectoryFileError, match=r"'state_names' must be a 1-D array of str"):
        Trajectory.load(path)
    np.savez(path.with_suffix(""), **{**arrays, "extras": np.zeros((4, 2))})
    with pytest.raises(TrajectoryFileError, match=r"array 'extras' must have shape \(K, 0\)"):
        Trajectory.load(path)
    np.savez(path.with_suffix(""), **{**arrays, "extra_units": np.array(["m"])})
    with pytest.raises(TrajectoryFileError, match=r"'extra_names' and 'extra_units' differ in len"):
        Trajectory.load(path)
    np.savez(path.with_suffix(""), **{**arrays, "states": np.zeros((3, 2))})
    with pytest.raises(TrajectoryFileError, match=r"bad.npz: `states`: must have one row per"):
        Trajectory.load(path)
    assert zipfile.is_zipfile(good)
