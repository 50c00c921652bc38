"""Re-rooting and the leg swap (model.rerooting) against independent references.

The re-rooted tree must be the same physical tree: with the mapped angles, every body has the
same orientation (psi' = psi mod 2 pi, or psi + pi for a body described from its other end)
and the same centre of mass in the plane, and paper-form trees have the same hinges, all
shifted by the new root's position; the kinetic energy is the one of the old motion seen from
the new root (``reference.newton_euler`` in numpy throughout). Re-rooting twice gives the
tree back. The swap of a biped's legs gives back the very same Linkage; legs that are not
mirror images are refused with a message naming the parameter.
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import numpy as np
import pytest
from reference import newton_euler as ne

from model import (
    DefinitionError,
    DefinitionTypeError,
    Dynamics,
    Link,
    Linkage,
    LinkPoint,
    Rerooting,
    presets,
    reroot,
    swap_legs,
)

SIX = presets.six_link_anthropoid()


@functools.cache
def paper_tree(seed: int, n: int) -> Linkage:
    return ne.random_tree(np.random.default_rng(700 + seed), n)


@functools.cache
def locked_tree(seed: int, n: int) -> Linkage:
    """A random tree with two links locked into their parents: merged bodies with off-axis
    centres of mass and children on displaced hinges (``origin``), as ``lock`` makes them."""
    linkage = paper_tree(seed, n)
    rng = np.random.default_rng(seed)
    for _ in range(2):
        name = linkage.names[int(rng.integers(1, linkage.n))]
        linkage = linkage.lock(name, float(rng.uniform(-1.0, 1.0)))
    return linkage


def branched_biped() -> Linkage:
    """Legs as in the six-link scene, an upper body with a torso, a head and two arms."""
    arms = [
        Link("upper_arm_r", "torso", 0.3, 2.0, 0.45, 0.02),
        Link("forearm_r", "upper_arm_r", 0.3, 1.5, 0.45, 0.01),
        Link("upper_arm_l", "torso", 0.3, 2.0, 0.45, 0.02),
    ]
    return Linkage([*SIX.links, *arms])


def cases():
    yield "six at swing foot", SIX, LinkPoint("swing_shank")
    yield "six at head top", SIX, LinkPoint("head")
    yield "six at torso side", SIX, LinkPoint("torso", 0.4, 0.2)
    yield "six at stance knee", SIX, LinkPoint("stance_shank")
    for seed, n in ((0, 2), (1, 5), (2, 8), (3, 12)):
        tree = paper_tree(seed, n)
        yield f"paper{seed}-{n}", tree, LinkPoint(tree.names[-1])
        yield f"paper{seed}-{n} offset", tree, LinkPoint(tree.names[n // 2], 0.7, -0.2)
    for seed, n in ((4, 6), (5, 9)):
        tree = locked_tree(seed, n)
        yield f"locked{seed}-{n}", tree, LinkPoint(tree.names[-1])


CASES = list(cases())
IDS = [c[0] for c in CASES]


def angles(linkage, count, seed):
    rng = np.random.default_rng(seed)
    return rng.uniform(-np.pi, np.pi, (count, linkage.n)), rng.normal(0, 2.0, (count, linkage.n))


def by_name(linkage, values):
    return {name: values[..., i] for i, name in enumerate(linkage.names)}


def wrap(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


@pytest.mark.parametrize(("label", "linkage", "point"), CASES, ids=IDS)
def test_same_bodies_at_the_same_places(label, linkage, point):
    rerooting = reroot(linkage, point)
    new = rerooting.new
    psi, dpsi = angles(linkage, 32, 1)
    psi_new, dpsi_new = rerooting.map_state(psi, dpsi)
    i = linkage.index(point.link)
    offset = linkage.links[i].length * complex(point.along, point.lateral)
    zero = np.zeros_like(psi)
    root, root_velocity, _ = ne.point_kinematics(linkage, i, offset, psi, dpsi, zero)
    old_com = by_name(linkage, ne.com_positions(linkage, psi))
    new_com = by_name(new, ne.com_positions(new, psi_new))
    old_psi, new_psi = by_name(linkage, psi), by_name(new, psi_new)
    reversed_links = set(rerooting.reversed_links)
    scale = sum(link.length for link in linkage.links)
    for name in linkage.names:
        assert np.max(np.abs(new_com[name] - (old_com[name] - root))) < 1e-12 * scale, name
        turn = np.pi if name in reversed_links else 0.0
        assert np.max(np.abs(wrap(new_psi[name] - old_psi[name] - turn))) < 1e-12, name
        old_link, new_link = linkage.links[linkage.index(name)], new.links[new.index(name)]
        assert (new_link.mass, new_link.inertia, new_link.length) == (
            old_link.mass,
            old_link.inertia,
            old_link.length,
        )
    # The reversed links are exactly the chain from the old root to the new one.
    chain = {linkage.names[k] for k in (*linkage.ancestors(i), i)}
    assert reversed_links == chain
    # Kinetic energy: the old motion seen from the new root (a translation by -z_P(t)).
    kinetic_new, _ = ne.energy(new, psi_new, dpsi_new)
    q = np.hstack([np.zeros((32, 2)), psi])
    dq = np.hstack([-root_velocity.real[:, None], -root_velocity.imag[:, None], dpsi])
    kinetic_seen, _ = ne.floating_energy(linkage, q, dq)
    np.testing.assert_allclose(kinetic_new, kinetic_seen, rtol=1e-11)
    if linkage.is_paper_form and point.along == 1.0 and point.lateral == 0.0:
        # Paper-form trees re-rooted at a hinge keep the set of hinges (H0 <-> the point).
        old_hinges = np.sort_complex(np.round(ne.hinge_positions(linkage, psi) - root[:, None], 9))
        new_hinges = np.sort_complex(np.round(ne.hinge_positions(new, psi_new), 9))
        np.testing.assert_array_equal(old_hinges, new_hinges)
        # Re-rooted at a foot (a link that carries nothing) the tree keeps the paper's form.
        assert new.is_paper_form == (linkage.children[i] == ())


def test_kinetic_energy_is_equal_when_the_new_root_is_at_rest():
    rerooting = reroot(SIX, "swing_shank")
    foot = Dynamics(SIX).point("swing_shank")
    psi, dpsi = angles(SIX, 16, 2)
    for k in range(16):
        jacobian = foot.jacobian(psi[k], floating=False)
        # The foot at rest: dpsi in the null space of its fixed-base Jacobian.
        null = np.linalg.svd(jacobian)[2][2:].T
        still = null @ (null.T @ dpsi[k])
        assert abs(foot.velocity(psi[k], still)) < 1e-12
        new_psi, new_dpsi = rerooting.map_state(psi[k], still)
        old_t, _ = ne.energy(SIX, psi[k], still)
        new_t, _ = ne.energy(rerooting.new, new_psi, new_dpsi)
        assert math.isclose(old_t, new_t, rel_tol=1e-12)


@pytest.mark.parametrize(("label", "linkage", "point"), CASES, ids=IDS)
def test_rerooting_twice_gives_the_tree_back(label, linkage, point):
    there = reroot(linkage, point)
    root = linkage.links[0]
    hinge = there.new.links[there.new.index(root.name)]
    h0 = _old_root_hinge(there)  # the old H0 on the reversed old root, in its frame
    back = reroot(there.new, LinkPoint(root.name, h0.real / hinge.length, h0.imag / hinge.length))
    original = {link.name: link for link in linkage.links}
    for link in back.new.links:
        mine = original[link.name]
        if link.parent is None:
            mine = replace(mine, origin=None)  # the new H0 is the world origin
        assert link.parent == mine.parent and link.merged == mine.merged, link.name
        for field in ("length", "mass", "inertia", "com", "com_lateral"):
            assert math.isclose(
                getattr(link, field), getattr(mine, field), rel_tol=1e-12, abs_tol=1e-12
            ), (link.name, field)
        if mine.origin is None:
            assert link.origin is None, link.name
        else:
            assert abs(link.origin - mine.origin) < 1e-12 * (abs(mine.origin) + 1), link.name
    psi, dpsi = angles(linkage, 8, 3)
    psi_there, dpsi_there = there.map_state(psi, dpsi)
    psi_back, dpsi_back = back.map_state(psi_there, dpsi_there)
    order = [back.new.index(name) for name in linkage.names]
    np.testing.assert_allclose(wrap(psi_back[:, order] - psi), 0.0, atol=1e-14)
    np.testing.assert_array_equal(dpsi_back[:, order], dpsi)


def _old_root_hinge(rerooting: Rerooting) -> complex:
    """Where the old root hinge H0 sits on the reversed old root, in its new frame, found by
    geometry: the reversed root's centre of mass is at c' = F - c, so F = c' + c."""
    old_root = rerooting.old.links[0]
    new_root = rerooting.new.links[rerooting.new.index(old_root.name)]
    return new_root.com_offset + old_root.com_offset


def test_torques_keep_the_generalised_forces_and_the_joint_power():
    rerooting = reroot(SIX, "swing_shank")
    rng = np.random.default_rng(4)
    torques = rng.normal(0, 50, (10, SIX.n))
    dpsi = rng.normal(0, 2, (10, SIX.n))
    mapped = rerooting.map_torques(torques)

    def generalized(linkage, m):
        q = m.copy()
        for c, p in enumerate(linkage.parents):
            if p >= 0:
                q[:, p] -= m[:, c]
        return q

    def joint_power(linkage, m, rates):
        relative = rates.copy()
        for c, p in enumerate(linkage.parents):
            if p >= 0:
                relative[:, c] -= rates[:, p]
        return np.sum(m * relative, axis=1)

    old_q = by_name(SIX, generalized(SIX, torques))
    new_q = by_name(rerooting.new, generalized(rerooting.new, mapped))
    for name in SIX.names:
        np.testing.assert_allclose(new_q[name], old_q[name], rtol=1e-13, atol=1e-12)
    _, dpsi_new = rerooting.map_state(np.zeros((10, SIX.n)), dpsi)
    np.testing.assert_allclose(
        joint_power(rerooting.new, mapped, dpsi_new), joint_power(SIX, torques, dpsi), rtol=1e-12
    )


def test_state_function_equals_numpy_map():
    rerooting = reroot(SIX, "head")
    psi, dpsi = angles(SIX, 5, 5)
    f = rerooting.function()
    assert f.name_in() == ["psi", "dpsi"] and f.name_out() == ["psi_new", "dpsi_new"]
    expected_psi, expected_dpsi = rerooting.map_state(psi, dpsi)
    state = rerooting.state_function()
    for k in range(5):
        a, b = f(psi[k], dpsi[k])
        np.testing.assert_array_equal(np.asarray(a).ravel(), expected_psi[k])
        np.testing.assert_array_equal(np.asarray(b).ravel(), expected_dpsi[k])
        x = np.asarray(state(np.r_[psi[k], dpsi[k]])).ravel()
        np.testing.assert_array_equal(x, np.r_[expected_psi[k], expected_dpsi[k]])


# ---- the leg swap -------------------------------------------------------------------------
def test_six_link_swap_is_exact():
    swap = swap_legs(SIX)
    assert swap.new is SIX and swap.old is SIX
    assert swap.root_point == LinkPoint("swing_shank")
    # Re-rooting and renaming by hand give the preset back to round-off.
    rerooted = reroot(SIX, "swing_shank").new
    rename = {
        "swing_shank": "stance_shank",
        "swing_thigh": "stance_thigh",
        "stance_thigh": "swing_thigh",
        "stance_shank": "swing_shank",
    }
    renamed = {
        rename.get(link.name, link.name): replace(
            link,
            name=rename.get(link.name, link.name),
            parent=None if link.parent is None else rename.get(link.parent, link.parent),
        )
        for link in rerooted.links
    }
    for link in SIX.links:
        other = renamed[link.name]
        assert other.parent == link.parent
        for field in ("length", "mass", "inertia", "com"):
            assert abs(getattr(other, field) - getattr(link, field)) <= 1e-15, (link.name, field)
    # The stance foot of the next step is the swing foot of this one, every body in place.
    psi, dpsi = angles(SIX, 20, 6)
    psi_new, dpsi_new = swap.map_state(psi, dpsi)
    foot = ne.hinge_positions(SIX, psi)[:, SIX.index("swing_shank") + 1]
    old_com = by_name(SIX, ne.com_positions(SIX, psi) - foot[:, None])
    new_com = by_name(SIX, ne.com_positions(SIX, psi_new))
    for name in SIX.names:
        np.testing.assert_allclose(new_com[rename.get(name, name)], old_com[name], atol=1e-14)
    # Stance angles turn up (+pi), swing angles down (-pi); swapping twice is the identity.
    offsets = dict(zip(SIX.names, swap.angle_offsets, strict=True))
    assert offsets == {
        "stance_shank": math.pi,
        "stance_thigh": math.pi,
        "swing_thigh": -math.pi,
        "swing_shank": -math.pi,
        "torso": 0.0,
        "head": 0.0,
    }
    psi_twice, dpsi_twice = swap.map_state(psi_new, dpsi_new)
    np.testing.assert_allclose(psi_twice, psi, atol=1e-15)
    np.testing.assert_array_equal(dpsi_twice, dpsi)


def compass_biped() -> Linkage:
    """Legs of one link each (a compass walker) and a trunk at the hip."""
    return Linkage(
        [
            Link("stance_leg", None, 0.9, 6.0, com=0.6, inertia=0.3),
            Link("swing_leg", "stance_leg", 0.9, 6.0, com=0.4, inertia=0.3),
            Link("trunk", "stance_leg", 0.5, 30.0, com=0.5, inertia=0.8),
        ]
    )


def footed_biped() -> Linkage:
    """Legs of three links (the foot from the toe to the ankle, the shank, the thigh) and a
    torso: a biped whose feet are links."""
    return Linkage(
        [
            Link("stance_foot", None, 0.15, 1.0, com=0.6, inertia=0.004),
            Link("stance_shank", "stance_foot", 0.43, 3.3, com=0.57, inertia=0.05),
            Link("stance_thigh", "stance_shank", 0.43, 7.0, com=0.57, inertia=0.12),
            Link("swing_thigh", "stance_thigh", 0.43, 7.0, com=0.43, inertia=0.12),
            Link("swing_shank", "swing_thigh", 0.43, 3.3, com=0.43, inertia=0.05),
            Link("swing_foot", "swing_shank", 0.15, 1.0, com=0.4, inertia=0.004),
            Link("torso", "stance_thigh", 0.5, 34.0, com=0.55, inertia=0.9),
        ]
    )


@pytest.mark.parametrize(
    "linkage",
    [
        presets.five_link_biped(),
        branched_biped(),
        presets.n_link_chain(4),
        compass_biped(),
        footed_biped(),
    ],
    ids=["five-link", "arms", "knee-chain", "compass", "feet"],
)
def test_swap_of_other_bipeds(linkage):
    swap = swap_legs(linkage)
    assert swap.new is linkage
    names = linkage.names
    stance_shank, swing_shank = names[0], swap.root_point.link
    psi, dpsi = angles(linkage, 10, 7)
    psi_new, _ = swap.map_state(psi, dpsi)
    foot = ne.hinge_positions(linkage, psi)[:, linkage.index(swing_shank) + 1]
    np.testing.assert_allclose(
        ne.com_positions(linkage, psi_new)[:, 0],
        ne.com_positions(linkage, psi)[:, linkage.index(swing_shank)] - foot,
        atol=1e-14,
    )
    assert swap.source[0] == linkage.index(swing_shank) and swap.source[
        linkage.index(swing_shank)
    ] == linkage.index(stance_shank)


def test_swap_chooses_the_mirror_leg_among_two_link_chains():
    # torso+head is also a two-link chain at the hip; only the swing leg mirrors the stance leg.
    swap = swap_legs(SIX)
    assert swap.source[SIX.index("torso")] == SIX.index("torso")
    named = swap_legs(SIX, swing=("swing_thigh", "swing_shank"))
    assert named.source == swap.source


def test_swap_of_legs_that_are_not_mirror_images_is_refused():
    heavy = presets.six_link_anthropoid(swing_shank_mass=3.5)
    with pytest.raises(
        DefinitionError,
        match=r"the legs are not mirror images, so swapping them would change the tree: "
        r"swing_shank\.mass = 3\.5 kg differs from its mirror stance_shank\.mass = 3\.3 kg; "
        r"stance_shank\.mass = 3\.3 kg differs from its mirror swing_shank\.mass = 3\.5 kg$",
    ):
        swap_legs(heavy)
    shifted = presets.six_link_anthropoid(swing_thigh_com=0.5)
    with pytest.raises(
        DefinitionError,
        match=r"swing_thigh\.com = 0\.5 is 0\.5 seen from the other end \(1 - com\) but its "
        r"mirror stance_thigh\.com = 0\.57",
    ):
        swap_legs(shifted)
    with pytest.raises(DefinitionError, match=r"`swing`: \('stance_thigh', 'swing_thigh'\) is"):
        swap_legs(SIX, swing=("stance_thigh", "swing_thigh"))
    # Only torso and head hang at the hip: they are compared, and the list is cut short.
    with pytest.raises(
        DefinitionError,
        match=r"tree: head\.length = 0\.25 m differs from its mirror stance_shank\.length = "
        r"0\.43 m; .*; and 12 more$",
    ):
        swap_legs(SIX.drop("swing_thigh"))


def test_trees_without_two_legs_are_refused():
    with pytest.raises(
        DefinitionError,
        match=r"swap_legs needs a biped: .*; no chain as long as the stance leg, ending in a "
        r"free link, hangs at the end of a stance leg from 'thigh'",
    ):
        swap_legs(presets.exoskeleton_leg())
    # Two one-link legs at the root's end are a compass walker; a third link hanging there,
    # heavier, is its trunk; legs that differ are refused by what differs.
    compass = Linkage([Link("a", None, 1, 1), Link("b", "a", 1, 1), Link("c", "a", 1, 9)])
    assert swap_legs(compass).root_point.link == "b"
    lopsided = Linkage([Link("a", None, 1, 1), Link("b", "a", 1, 2)])
    with pytest.raises(DefinitionError, match=r"b\.mass = 2 kg differs from its mirror a"):
        swap_legs(lopsided)
    with pytest.raises(DefinitionError, match=r"the root 'link1' has 0 children"):
        swap_legs(presets.n_link_chain(1))
    with pytest.raises(DefinitionTypeError, match=r"`linkage`: must be a model.Linkage"):
        swap_legs("six")
    with pytest.raises(DefinitionTypeError, match=r"`swing`: must be the names"):
        swap_legs(SIX, swing="swing_thigh")
    assert swap_legs(footed_biped(), swing=("swing_thigh", "swing_shank", "swing_foot")).new


def test_bad_rerooting_input_is_refused():
    with pytest.raises(DefinitionError, match=r"the start of the root 'stance_shank' is the root"):
        reroot(SIX, LinkPoint("stance_shank", 0.0, 0.0))
    with pytest.raises(DefinitionError, match=r"`link`: no link called 'foot'"):
        reroot(SIX, "foot")
    with pytest.raises(DefinitionError, match=r"`at`: must be 'end'"):
        reroot(SIX, "head", at="start")
    with pytest.raises(DefinitionTypeError, match=r"`linkage`: must be a model.Linkage"):
        reroot(Dynamics(SIX), "head")
    with pytest.raises(DefinitionTypeError, match=r"`Link 'a'.rerooted`: must be True or"):
        Link("a", None, 1.0, 1.0, rerooted=1)


def test_a_link_described_from_between_its_hinges_is_marked():
    # b hangs from the middle of a, whose centre of mass is near its end: seen from b's
    # hinge, a's centre of mass lies beyond a's new start.
    offset = Linkage([Link("a", None, 1.0, 1.0, 0.9), Link("b", "a", 1.0, 1.0, origin=0.5 + 0j)])
    new = reroot(offset, "b").new
    a = new.links[new.index("a")]
    assert a.rerooted and a.com == pytest.approx(-0.4)
    assert not new.links[new.index("b")].rerooted
