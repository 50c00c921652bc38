"""The floating base (model.floating) against independent references.

* ``reference.newton_euler``: the floating-base mass matrix from columns of a Newton-Euler
  recursion whose root hinge accelerates (rows: the force on the base and the generalised
  forces), the energy from the outward velocity pass with the base velocity added, all in
  numpy with real 2-vectors;
* identities: T = 1/2 dq^T M_e dq; the psi-psi block is the fixed-base mass matrix; the first
  two rows of M_e dq are the total momentum m v_com.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from reference import newton_euler as ne

from model import FLOATING_FUNCTIONS, DefinitionError, Dynamics, presets

SIX = presets.six_link_anthropoid()
TREES = [(seed, n, general) for seed, n in enumerate((1, 3, 6, 9, 12)) for general in (False, True)]


@functools.cache
def tree(seed: int, n: int, general: bool):
    return ne.random_tree(np.random.default_rng(500 + seed), n, general=general)


def scenes():
    yield "six-link", SIX
    yield "five-link", presets.five_link_biped()
    for seed, n, general in TREES:
        yield f"tree{seed}-{n}{'-general' if general else ''}", tree(seed, n, general)


SCENES = list(scenes())
IDS = [label for label, _ in SCENES]


def floating_states(linkage, count, seed):
    rng = np.random.default_rng(seed)
    n = linkage.n
    q = np.hstack([rng.normal(0, 1.0, (count, 2)), rng.uniform(-np.pi, np.pi, (count, n))])
    dq = rng.normal(0.0, 2.0, (count, n + 2))
    return q, dq


@pytest.mark.parametrize(("label", "linkage"), SCENES, ids=IDS)
def test_mass_matrix_against_floating_newton_euler(label, linkage, check):
    dyn = Dynamics(linkage)
    q, _ = floating_states(linkage, 48, 1)
    psi = q[:, 2:]
    mass = dyn.floating.mass_matrix(psi)
    assert mass.shape == (48, linkage.n + 2, linkage.n + 2)
    check.close(mass, ne.floating_mass_matrix(linkage, psi), f"{label} M_e")
    np.testing.assert_array_equal(mass, np.swapaxes(mass, 1, 2))
    assert np.all(np.linalg.eigvalsh(mass) > 0), f"{label}: M_e not positive definite"
    # The psi-psi block is the fixed-base matrix itself (the same expressions).
    np.testing.assert_array_equal(mass[:, 2:, 2:], dyn.mass_matrix(psi))
    total = sum(link.mass for link in linkage.links)
    np.testing.assert_allclose(mass[:, :2, :2], np.broadcast_to(total * np.eye(2), (48, 2, 2)))


@pytest.mark.parametrize(("label", "linkage"), SCENES, ids=IDS)
def test_energy_against_numpy_and_the_mass_matrix(label, linkage, check):
    dyn = Dynamics(linkage)
    q, dq = floating_states(linkage, 48, 2)
    kinetic, potential = dyn.floating.energy(q, dq)
    ref_kinetic, ref_potential = ne.floating_energy(linkage, q, dq)
    check.close(kinetic[:, None], ref_kinetic[:, None], f"{label} T")
    # Pi is zero at the height of H0's origin: compare against the terms' magnitude.
    scale = (
        linkage.gravity
        * sum(link.mass for link in linkage.links)
        * (np.abs(q[:, 1]) + sum(link.length for link in linkage.links))
    )
    assert np.max(np.abs(potential - ref_potential) / scale) < 1e-12, label
    quadratic = 0.5 * np.einsum("ki,kij,kj->k", dq, dyn.floating.mass_matrix(q[:, 2:]), dq)
    check.close(kinetic[:, None], quadratic[:, None], f"{label} T = dq M_e dq / 2")


@pytest.mark.parametrize(("label", "linkage"), SCENES, ids=IDS)
def test_momentum_is_the_first_rows_of_the_mass_matrix(label, linkage, check):
    dyn = Dynamics(linkage)
    q, dq = floating_states(linkage, 48, 3)
    psi, dpsi, dbase = q[:, 2:], dq[:, 2:], dq[:, :2]
    velocities = ne.com_velocities(linkage, psi, dpsi) + (dbase[:, 0] + 1j * dbase[:, 1])[:, None]
    masses = np.array([link.mass for link in linkage.links])
    m_v_com = velocities @ masses
    rows = np.einsum("kij,kj->ki", dyn.floating.mass_matrix(psi)[:, :2, :], dq)
    check.close(rows[:, 0] + 1j * rows[:, 1], m_v_com, f"{label} M_e[:2] dq")
    check.close(dyn.floating.momentum(psi, dq), m_v_com, f"{label} momentum")


def test_functions_share_the_fixed_model():
    dyn = Dynamics(SIX)
    floating = dyn.floating
    assert dyn.floating is floating
    assert floating.n == SIX.n + 2
    for name, (inputs, outputs, _) in FLOATING_FUNCTIONS.items():
        f = floating.function(name)
        assert tuple(f.name_in()) == inputs and tuple(f.name_out()) == outputs
        assert name in dyn.built
    # Single state shapes.
    q = np.r_[0.1, 0.2, np.full(SIX.n, 1.0)]
    assert dyn.floating.mass_matrix(q[2:]).shape == (8, 8)
    kinetic, potential = dyn.floating.energy(q, np.ones(8))
    assert isinstance(kinetic, float) and isinstance(potential, float)
    with pytest.raises(DefinitionError, match=r"unknown floating-base function 'bias'"):
        floating.function("bias")
    with pytest.raises(DefinitionError, match=r"`q`: expected shape \(8,\) or \(K, 8\)"):
        floating.energy(np.zeros(6), np.zeros(8))
