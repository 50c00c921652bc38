"""The example catalogue of products (examples/drives/*_cited.csv) against the datasheets' own
derived lines.

A maxon datasheet prints, beside the constants the catalogue keeps (terminal resistance R,
torque constant k_t, rotor inertia J), lines derived from them: the speed/torque gradient
R / k_t^2 (line 14, rpm/mN m) and the mechanical time constant J R / k_t^2 (line 15, ms). Held
against those printed lines, the catalogue read through ``read_motors`` (its unit conversions
included) would catch a mistyped digit, a value from another winding or a wrong unit. The
printed lines are facts from the datasheets each row cites.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from problems.drives.catalogue import read_gearboxes, read_motors

CATALOGUE = Path(__file__).resolve().parents[1] / "examples" / "drives"

#: per cited motor: (speed/torque gradient rpm/mN m, mechanical time constant ms) as printed
#: (maxon EC motor catalogue April 2006 p. 197, EC 90 flat 90 W; maxon catalogue March 2021
#: p. 261, EC-4pole 30 200 W)
PRINTED = {
    "maxon EC 90 flat 90 W 24 V (323772)": (0.697, 22.3),
    "maxon EC 90 flat 90 W 48 V (244879)": (0.466, 14.9),
    "maxon EC-4pole 30 200 W 36 V (305014)": (4.75, 1.66),
}


def test_every_cited_motor_meets_its_datasheets_derived_lines():
    motors = {m.name: m for m in read_motors(CATALOGUE / "motors_cited.csv")}
    assert set(motors) == set(PRINTED)
    for name, (gradient, time_constant) in PRINTED.items():
        m = motors[name]
        slope = m.resistance / m.torque_constant**2  # rad/s per N m
        assert slope * 30.0 / math.pi * 1e-3 == pytest.approx(gradient, rel=0.01), name
        tau = m.rotor_inertia * m.resistance / m.torque_constant**2
        assert tau * 1e3 == pytest.approx(time_constant, rel=0.01), name
        # the ideal no-load speed U / k_t sits within the largest speed or at it (the EC 90
        # flat rows take the printed no-load speed as their largest: within its 3 %)
        assert m.voltage / m.torque_constant <= m.max_speed * 1.03, name


def test_every_cited_row_names_its_source_and_the_gear_families_are_consistent():
    motors = read_motors(CATALOGUE / "motors_cited.csv")
    gearboxes = read_gearboxes(CATALOGUE / "gearboxes_cited.csv")
    for part in (*motors, *gearboxes):
        assert "catalogue" in part.source or "TI-26024" in part.source, part.name
        assert "illustrative" not in part.source, part.name
    # one size of strain-wave unit shares its wave generator (input inertia), its mass and its
    # input speed across ratios; its repeated peak grows with the ratio, never falls
    for size in ("CSG-25", "CSG-32"):
        family = sorted((g for g in gearboxes if size in g.name), key=lambda g: g.ratio)
        assert len(family) >= 2, size
        assert len({(g.inertia, g.mass, g.max_input_speed) for g in family}) == 1, size
        peaks = [g.peak_torque for g in family]
        assert peaks == sorted(peaks), size
        assert all(g.peak_torque > g.continuous_torque for g in family), size
