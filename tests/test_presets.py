"""model.presets against the numbers they promise.

The six-link table is typed here again from shared/scene.md (not read from
``presets.SIX_LINK_TABLE``), so a typo in either shows up as a failure.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from model import DefinitionError, DefinitionTypeError, Dynamics, Linkage, presets

# scene.md: link, name, parent, l (m), m (kg), n, J (kg m^2)
SCENE = [
    (1, "stance_shank", None, 0.43, 3.3, 0.57, 0.05),
    (2, "stance_thigh", "stance_shank", 0.43, 7.0, 0.57, 0.12),
    (3, "swing_thigh", "stance_thigh", 0.43, 7.0, 0.43, 0.12),
    (4, "swing_shank", "swing_thigh", 0.43, 3.3, 0.43, 0.05),
    (5, "torso", "stance_thigh", 0.50, 34.0, 0.55, 0.90),
    (6, "head", "torso", 0.25, 5.3, 0.50, 0.03),
]


def test_six_link_anthropoid_is_the_scene():
    six = presets.six_link_anthropoid()
    assert isinstance(six, Linkage)
    assert six.n == 6 and six.gravity == 9.81
    for (number, name, parent, length, mass, com, inertia), link in zip(
        SCENE, six.links, strict=True
    ):
        # array position = paper number - 1
        assert six.index(name) == number - 1
        assert (link.name, link.parent) == (name, parent)
        # exact: the preset must carry the table's decimal numbers unchanged
        assert (link.length, link.mass, link.com, link.inertia) == (length, mass, com, inertia)
        assert link.com_lateral == 0.0 and link.origin is None and link.merged == ()
    # the tree of scene.md: 2 on 1, 3 and 5 on 2 (hip H2), 4 on 3, 6 on 5
    assert six.parents == (-1, 0, 1, 2, 1, 4)
    assert six.is_paper_form


def test_six_link_paper_inertias_about_the_start_hinge():
    """errata.md item 1: the paper's I_i = J_i + m_i (n_i l_i)^2."""
    six = presets.six_link_anthropoid()
    for (_, _, _, length, mass, com, inertia), link in zip(SCENE, six.links, strict=True):
        assert link.inertia_about_start == pytest.approx(
            inertia + mass * (com * length) ** 2, rel=1e-15
        )


def test_six_link_overrides():
    six = presets.six_link_anthropoid(torso_mass=40.0, head_com=0.6, swing_shank_length=0.5)
    assert six.links[4].mass == 40.0
    assert six.links[5].com == 0.6
    assert six.links[3].length == 0.5
    untouched = presets.six_link_anthropoid()
    assert six.links[0] == untouched.links[0] and six.links[4].length == 0.50
    assert presets.six_link_anthropoid(stance_thigh_inertia=0.2).links[1].inertia == 0.2
    assert presets.six_link_anthropoid(gravity=1.62).gravity == 1.62


@pytest.mark.parametrize("key", ["torso_weight", "neck_mass", "mass", "torso_parent", "Torso_mass"])
def test_six_link_unknown_override(key):
    with pytest.raises(DefinitionError, match=f"`{key}`: unknown override; use <link>_<field>"):
        presets.six_link_anthropoid(**{key: 1.0})


def test_six_link_override_values_are_validated():
    with pytest.raises(DefinitionError, match=r"`Link 'torso'.mass`: must be > 0 kg, got -1.0"):
        presets.six_link_anthropoid(torso_mass=-1.0)
    with pytest.raises(DefinitionError, match=r"`Link 'head'.com`: .* \[0, 1\]"):
        presets.six_link_anthropoid(head_com=1.2)
    with pytest.raises(DefinitionError, match="`gravity`: the magnitude of g"):
        presets.six_link_anthropoid(gravity=-9.81)


def test_five_link_biped_is_the_scene_without_the_head():
    biped = presets.five_link_biped()
    assert biped.names == tuple(row[1] for row in SCENE[:5])
    assert biped.links == presets.six_link_anthropoid().links[:5]
    assert biped.parents == (-1, 0, 1, 2, 1)
    assert presets.five_link_biped(gravity=3.7).gravity == 3.7


def test_n_link_chain():
    chain = presets.n_link_chain(4, length=0.5, mass=2.0, com=0.25, inertia=0.1, gravity=1.0)
    assert chain.names == ("link1", "link2", "link3", "link4")
    assert chain.parents == (-1, 0, 1, 2)
    assert all(
        (link.length, link.mass, link.com, link.inertia) == (0.5, 2.0, 0.25, 0.1)
        for link in chain.links
    )
    assert chain.gravity == 1.0
    default = presets.n_link_chain(2)
    assert default.links[0].inertia == pytest.approx(1.0 / 12.0, rel=1e-15)  # uniform rod
    assert default.links[0].com == 0.5 and default.gravity == 9.81
    assert presets.n_link_chain(1).n == 1
    assert presets.n_link_chain(40).n == 40


@pytest.mark.parametrize(
    "kwargs,error,message",
    [
        (dict(n=0), DefinitionError, "`n`: must be >= 1 link, got 0"),
        (dict(n=-3), DefinitionError, "`n`: must be >= 1 link, got -3"),
        (dict(n=2.0), DefinitionTypeError, "`n`: must be an integer number of links, got 2.0"),
        (dict(n=True), DefinitionTypeError, "`n`: must be an integer number of links, got True"),
        (dict(n=3, length="1"), DefinitionTypeError, "`length`: must be a real number"),
        (dict(n=3, length=-1.0), DefinitionError, "`Link 'link1'.length`: must be > 0 m"),
        (dict(n=3, mass=0.0), DefinitionError, "`Link 'link1'.mass`: must be > 0 kg"),
        (dict(n=3, com=2.0), DefinitionError, r"`Link 'link1'.com`: .* \[0, 1\]"),
        (dict(n=3, inertia=-1.0), DefinitionError, "`Link 'link1'.inertia`: .* >= 0"),
        (dict(n=3, gravity=math.nan), DefinitionError, "`gravity`: must be finite"),
    ],
)
def test_n_link_chain_errors(kwargs, error, message):
    with pytest.raises(error, match=message):
        presets.n_link_chain(**kwargs)


def test_exoskeleton_leg_follows_winters_table():
    leg = presets.exoskeleton_leg()
    assert leg.names == ("thigh", "shank", "foot") and leg.parents == (-1, 0, 1)
    # Winter, table 4.1: length/H, mass/M, com fraction, radius of gyration/length
    rows = [
        (0.245, 0.100, 0.433, 0.323),
        (0.246, 0.0465, 0.433, 0.302),
        (0.152, 0.0145, 0.50, 0.475),
    ]
    for link, (length, mass, com, gyration) in zip(leg.links, rows, strict=True):
        assert link.length == pytest.approx(length * 1.75, rel=1e-15)
        assert link.mass == pytest.approx(mass * 75.0, rel=1e-15)
        assert link.com == com
        assert link.inertia == pytest.approx(link.mass * (gyration * link.length) ** 2, rel=1e-15)
    scaled = presets.exoskeleton_leg(body_mass=60.0, height=1.6, gravity=9.8)
    assert scaled.links[0].mass == pytest.approx(6.0, rel=1e-15)
    assert scaled.links[2].length == pytest.approx(0.152 * 1.6, rel=1e-15)
    assert scaled.gravity == 9.8
    # a runnable model: hanging straight down it needs no torque
    down = np.full(3, -np.pi / 2)
    assert np.abs(Dynamics(leg).gravity_torques(down)).max() < 1e-12


@pytest.mark.parametrize(
    "kwargs,error,message",
    [
        (dict(body_mass=0.0), DefinitionError, "`body_mass`: must be > 0 kg, got 0.0"),
        (dict(body_mass=-75.0), DefinitionError, "`body_mass`: must be > 0 kg"),
        (dict(height=0.0), DefinitionError, "`height`: must be > 0 m, got 0.0"),
        (dict(height=math.inf), DefinitionError, "`height`: must be finite"),
        (dict(body_mass="75"), DefinitionTypeError, "`body_mass`: must be a real number"),
        (dict(height=True), DefinitionTypeError, "`height`: must be a real number"),
        (dict(gravity=-1.0), DefinitionError, "`gravity`: the magnitude of g"),
    ],
)
def test_exoskeleton_leg_errors(kwargs, error, message):
    with pytest.raises(error, match=message):
        presets.exoskeleton_leg(**kwargs)


def test_preset_registry():
    assert set(presets.PRESETS) >= {"six-link", "five-link", "exoskeleton-leg"}
    assert presets.PRESETS["six-link"]() == presets.six_link_anthropoid()
    assert presets.PRESETS["five-link"]() == presets.five_link_biped()
    assert presets.PRESETS["exoskeleton-leg"]() == presets.exoskeleton_leg()


def test_scaled_body_scales_the_dynamics_as_dimensional_analysis_says():
    """A body of another height and mass from the same table: the mass matrix scales by
    k s^2 and the gravity torques by k s (k the mass ratio, s the height ratio), the contact
    points stay on the same fractions of their links, the total mass is the ratio's."""
    from model.presets import anthropoid_with_feet, scaled_body

    body = anthropoid_with_feet()
    small = scaled_body(body, 1.60, 55.0)
    s, k = 1.60 / 1.75, 55.0 / 70.0
    assert small.gravity == body.gravity
    assert sum(link.mass for link in small.links) == pytest.approx(
        k * sum(link.mass for link in body.links)
    )
    rng = np.random.default_rng(11)
    psi = rng.uniform(-3, 3, body.n)
    big, little = Dynamics(body), Dynamics(small)
    np.testing.assert_allclose(
        np.asarray(little.function("mass_matrix")(psi)),
        k * s**2 * np.asarray(big.function("mass_matrix")(psi)),
        rtol=1e-12,
    )
    np.testing.assert_allclose(
        np.asarray(little.function("gravity_torques")(psi)),
        k * s * np.asarray(big.function("gravity_torques")(psi)),
        rtol=1e-12, atol=1e-12,
    )  # fmt: skip
    with pytest.raises(ValueError, match="height"):
        scaled_body(body, -1.0, 55.0)
