"""Units of trajectory channels: reading a unit, converting a trajectory to SI."""

from __future__ import annotations

import math

import numpy as np
import pytest

from model import LinkageTrajectory
from planner.trajectory import Trajectory
from planner.units import KNOWN_UNITS, QUANTITIES, si_unit, to_si


@pytest.mark.parametrize(
    ("unit", "expected"),
    [
        ("rad", ("rad", 1.0)),
        ("deg", ("rad", math.pi / 180)),
        ("°", ("rad", math.pi / 180)),
        (" degrees ", ("rad", math.pi / 180)),
        ("deg/s", ("rad/s", math.pi / 180)),
        ("rpm", ("rad/s", 2 * math.pi / 60)),
        ("deg/s²", ("rad/s^2", math.pi / 180)),
        ("N m", ("N m", 1.0)),
        ("N·m", ("N m", 1.0)),
        ("N*m", ("N m", 1.0)),
        ("N.m", ("N m", 1.0)),
        ("Nm", ("N m", 1.0)),
        ("kN m", ("N m", 1000.0)),
        ("kN  *  m", ("N m", 1000.0)),
        ("N mm", ("N m", 0.001)),
        ("N cm", ("N m", 0.01)),
        ("kN", ("N", 1000.0)),
        ("ms", ("s", 0.001)),
        ("furlong", None),
        ("kN/m", None),
        ("N/m", None),
    ],
)
def test_units_are_read_with_their_factor_to_si(unit, expected):
    assert si_unit(unit) == expected


def test_every_known_unit_maps_to_a_named_si_unit_that_is_its_own():
    for unit, (si, factor) in KNOWN_UNITS.items():
        assert si in QUANTITIES, unit
        assert KNOWN_UNITS[si] == (si, 1.0), si
        assert factor > 0


def test_a_trajectory_in_degrees_and_kilonewton_metres_converts_to_si():
    time = np.linspace(0.0, 1.0, 5)
    degrees = np.column_stack([np.linspace(10, 50, 5), np.linspace(-3, 3, 5)])
    torques = np.linspace(0.5, 2.5, 5)[:, None]
    trajectory = Trajectory(
        time=time,
        states=degrees,
        controls=torques,
        state_names=("psi_a", "dpsi_a"),
        state_units=("deg", "deg/s"),
        control_names=("M_a",),
        control_units=("kN m",),
        extras={"Fx": (np.ones(5), "kN"), "spin": (np.ones(5), "furlong/s")},
        metadata={"source": "hand"},
    )
    si = to_si(trajectory)
    np.testing.assert_array_equal(si.states[:, 0], np.deg2rad(degrees[:, 0]))
    np.testing.assert_array_equal(si.states[:, 1], np.deg2rad(degrees[:, 1]))
    np.testing.assert_allclose(si.controls[:, 0], 1e3 * torques[:, 0], rtol=1e-15)
    assert si.state_units == ("rad", "rad/s") and si.control_units == ("N m",)
    assert si.extras["Fx"][1] == "N" and si.extras["Fx"][0][0] == 1000.0
    assert si.extras["spin"][1] == "furlong/s"  # unknown: kept as it is
    assert si.metadata["converted_to_si"]["M_a"] == "kN m -> N m"
    assert si.metadata["source"] == "hand"
    assert LinkageTrajectory.of(si).is_linkage and LinkageTrajectory.of(si).link_names == ("a",)
    assert to_si(si) is si  # nothing left to convert
