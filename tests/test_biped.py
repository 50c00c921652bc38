"""problems.gait.biped: a biped's legs as chains of links and its feet as contacts, read from
the leg swap (whose mapping tests/test_rerooting.py checks against the Newton-Euler oracle)."""

from __future__ import annotations

import itertools

import pytest
from test_rerooting import compass_biped, footed_biped

from model import presets
from planner.errors import DefinitionError
from problems.gait.biped import Biped


@pytest.mark.parametrize(
    ("linkage", "stance", "swing", "upper"),
    [
        (
            presets.six_link_anthropoid(),
            ("stance_shank", "stance_thigh"),
            ("swing_thigh", "swing_shank"),
            ("torso", "head"),
        ),
        (compass_biped(), ("stance_leg",), ("swing_leg",), ("trunk",)),
        (
            footed_biped(),
            ("stance_foot", "stance_shank", "stance_thigh"),
            ("swing_thigh", "swing_shank", "swing_foot"),
            ("torso",),
        ),
    ],
    ids=["six-link", "compass", "feet"],
)
def test_legs_are_chains_of_links_and_feet_are_contacts(linkage, stance, swing, upper):
    biped = Biped.of(linkage)
    assert biped.stance_leg == stance and biped.swing_leg == swing and biped.upper_body == upper
    # the leg is a chain: each link the child of the one before (stance up, swing down)
    for chain in (stance, swing):
        for lower, higher in itertools.pairwise(chain):
            assert linkage.links[linkage.index(higher)].parent == lower
    assert linkage.links[linkage.index(swing[0])].parent == stance[-1]  # both at the hip
    lengths = [linkage.links[linkage.index(name)].length for name in stance]
    assert biped.leg_length == pytest.approx(sum(lengths), rel=1e-15)
    foot, landing = biped.feet(0.7)
    assert (foot.point.link, foot.point.along, foot.friction) == (stance[0], 0.0, 0.7)
    assert (landing.point.link, landing.point.along) == (swing[-1], 1.0)
    assert landing.label == f"{swing[-1]}_end" and foot.label == f"{stance[0]}_start"
    # the leg swap's new root is the swing foot's link
    assert biped.swap.root_point.link == swing[-1]


def test_the_law_fit_says_it_needs_two_link_legs():
    with pytest.raises(DefinitionError, match=r"needs legs of two links .* have 3"):
        Biped.of(footed_biped()).step_law(0.5, 0.5)
    with pytest.raises(DefinitionError, match=r"needs legs of two links .* have 1"):
        Biped.of(compass_biped()).posture(0.9j, 0.3 + 0.0j)
