"""model.Dynamics against independent references.

References (none of them shares code with model/dynamics.py):

* ``reference.newton_euler``: recursive Newton-Euler with real 2-vectors in numpy, and the
  closed form B_km cos(psi_k - psi_m) of DESIGN.md for paper-form links;
* central finite differences (velocities from positions, gravity torques from the potential);
* identities: T = 1/2 dpsi^T M dpsi, inverse(forward(M)) = M, conservation of energy.

Scenes: the six-link anthropoid of scene.md at >= 100 seeded random states, and seeded random
trees (2..12 links, several branch points, lengths, masses and inertias log-uniform over
1e-2..1e2), half of them with off-axis centres of mass and displaced hinges (the bodies that
``Linkage.lock`` produces).

Relative error, per state: ||actual - reference|| / (||reference|| + 1e-30) over all components
of that state (Euclidean; Frobenius for matrices). The floor only guards 0/0. Forward
dynamics on the random trees (cond(M) up to ~1e8) is compared in the kinetic-energy norm
sqrt(e^T M e) instead; see test_forward_dynamics. Every comparison goes through
:class:`Checker`, which counts compared states: the ``check`` fixture fails a test that compared
nothing, and the main tests assert how many states they compared. ``test_tolerance_detects_*``
show that the 1e-10 bound fails when a single term of the equations is dropped or a single
parameter is off by 1e-6.

Also here: the numpy batch path against single-state CasADi calls, passive energy
conservation over 2 s, lazy generation, validation messages of the numeric methods, and
(at the end) edge cases: empty batches, a link without rotational inertia, one-link trees.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest
from reference import newton_euler as ne
from reference.checks import TOL, mass_norm, relative_error
from scipy.integrate import solve_ivp

from model import (
    FUNCTIONS,
    AnthropoidError,
    DefinitionError,
    DefinitionTypeError,
    Dynamics,
    Link,
    Linkage,
    presets,
)
from model.numpy_tape import NumpyTape

SIX_LINK_STATES = 128


# ---- scenes and states ---------------------------------------------------------------------
#: (seed, number of links, general) of the random trees: sizes cycle 12..2 so that twelve
#: links appear often; the general ones have off-axis centres and displaced hinges.
TREES = [(seed, (12, 12, 11, 10, 9, 8, 7, 6, 5, 4, 3, 2)[seed % 12], False) for seed in range(24)]
TREES += [(100 + seed, (12, 10, 8, 6, 5, 3)[seed % 6], True) for seed in range(12)]


@functools.cache
def tree(seed: int, n_links: int, general: bool) -> Linkage:
    return ne.random_tree(np.random.default_rng(seed), n_links, general=general)


@functools.cache
def dynamics_of(linkage: Linkage) -> Dynamics:
    # One Dynamics per scene for the whole module: each Function is generated once.
    return Dynamics(linkage)


def random_states(linkage: Linkage, count: int, seed: int):
    """psi (rad), dpsi (rad/s), ddpsi (rad/s^2) and hinge torques (N m) as (count, n).

    Torques are those of a random motion (so they have the scene's natural scale).
    """
    rng = np.random.default_rng(seed)
    n = linkage.n
    psi = rng.uniform(-np.pi, np.pi, (count, n))
    dpsi = rng.normal(0.0, 2.0, (count, n))
    ddpsi = rng.normal(0.0, 10.0, (count, n))
    torques = ne.inverse_dynamics(linkage, psi, dpsi, rng.normal(0.0, 10.0, (count, n)))
    return psi, dpsi, ddpsi, torques


SIX = presets.six_link_anthropoid()
# Beyond the brief's 12 links: a 40-link chain, the deepest benchmark tree (CSE path,
# O(n) running sums through 40 levels).
CASES = (
    [("six_link", SIX, SIX_LINK_STATES)]
    + [(f"{'general' if g else 'tree'}{s}_n{n}", tree(s, n, g), 16) for s, n, g in TREES]
    + [("chain40", presets.n_link_chain(40), 16)]
)
CASE_IDS = [c[0] for c in CASES]


@pytest.fixture(params=CASES, ids=CASE_IDS)
def case(request):
    """(linkage, Dynamics, psi, dpsi, ddpsi, torques) for one scene."""
    name, linkage, count = request.param
    seed = 1 + CASE_IDS.index(name)
    return (linkage, dynamics_of(linkage), *random_states(linkage, count, seed))


def test_random_trees_cover_the_brief():
    """>= 20 trees, up to 12 links, several branch points, parameters over 1e-2..1e2, deep
    trees (the model switches to CSE at depth 5) and shallow ones."""
    assert len(TREES) >= 20
    linkages = [tree(*t) for t in TREES]
    assert max(lk.n for lk in linkages) == 12
    for lk in linkages:
        branch_points = sum(len(c) >= 2 for c in lk.children)
        assert branch_points >= (2 if lk.n >= 5 else 1 if lk.n >= 3 else 0), lk
    depths = [max(len(lk.ancestors(i)) for i in range(lk.n)) for lk in linkages]
    assert max(depths) >= 5 and min(depths) < 5
    for field in ("length", "mass", "inertia"):
        values = [getattr(link, field) for lk in linkages for link in lk.links]
        assert min(values) < 0.03 and max(values) > 30, field
        assert all(1e-2 <= v <= 1e2 for v in values), field
    assert all(0 <= link.com <= 1 for lk in linkages for link in lk.links)
    assert sum(lk.is_paper_form for lk in linkages) >= 20
    assert sum(not lk.is_paper_form for lk in linkages) >= 10


# ---- the oracle against its second formulation ------------------------------------------------
@pytest.mark.parametrize(
    "name,linkage,count",
    [c for c in CASES if c[1].is_paper_form],
    ids=[c[0] for c in CASES if c[1].is_paper_form],
)
def test_oracle_newton_euler_matches_closed_form(check, name, linkage, count):
    """Two independent references agree: Newton-Euler vs B_km cos(psi_k - psi_m)."""
    psi, dpsi, ddpsi, _ = random_states(linkage, count, seed=99)
    check.close(ne.closed_form_mass_matrix(linkage, psi), ne.mass_matrix(linkage, psi), "M")
    check.close(
        ne.closed_form_inverse_dynamics(linkage, psi, dpsi, ddpsi),
        ne.inverse_dynamics(linkage, psi, dpsi, ddpsi),
        "inverse dynamics",
    )
    assert check.count == 2 * count


def test_oracle_closed_form_refuses_general_links():
    with pytest.raises(ValueError, match="paper-form"):
        ne.closed_form_mass_matrix(SIX.lock("head", 0.5), np.zeros(5))


def test_oracle_refuses_inputs_it_would_broadcast():
    with pytest.raises(ValueError, match=r"oracle: expected shape \(6,\) or \(K, 6\)"):
        ne.mass_matrix(SIX, np.zeros(5))
    with pytest.raises(ValueError, match="oracle: expected shape"):
        ne.mass_matrix(SIX, 0.0)
    with pytest.raises(ValueError, match="oracle: inputs of different shapes"):
        ne.inverse_dynamics(SIX, np.zeros((2, 6)), np.zeros(6), np.zeros((2, 6)))


def test_oracle_single_pendulum_closed_form():
    """The oracle itself on a case solved by hand: a rod about its end,
    M = (J + m c^2) ddpsi + m g c cos(psi), ground force = m (a_c + j g)."""
    rod = Linkage([Link("rod", None, 2.0, 3.0, com=0.25, inertia=0.7)], gravity=9.81)
    psi, dpsi, ddpsi = 0.4, -1.3, 2.2
    c = 0.5
    torque = (0.7 + 3.0 * c**2) * ddpsi + 3.0 * 9.81 * c * np.cos(psi)
    assert ne.inverse_dynamics(rod, [psi], [dpsi], [ddpsi])[0] == pytest.approx(torque, 1e-14)
    e = np.exp(1j * psi)
    force = 3.0 * (c * (1j * ddpsi - dpsi**2) * e + 9.81j)
    assert abs(ne.ground_reaction(rod, [psi], [dpsi], [ddpsi]) - force) < 1e-13
    kinetic, potential = ne.energy(rod, [psi], [dpsi])
    assert kinetic == pytest.approx(0.5 * (0.7 + 3.0 * c**2) * dpsi**2, 1e-14)
    assert potential == pytest.approx(3.0 * 9.81 * c * np.sin(psi), 1e-14)


# ---- the model against the oracle -------------------------------------------------------------
def test_mass_matrix(check, case):
    linkage, dyn, psi, *_ = case
    check.close(dyn.mass_matrix(psi), ne.mass_matrix(linkage, psi), "mass matrix")
    assert check.count == len(psi)


def test_mass_matrix_is_symmetric_positive_definite(check, case):
    _, dyn, psi, *_ = case
    mass = dyn.mass_matrix(psi)
    check.close(mass, np.swapaxes(mass, 1, 2), "symmetry", tol=1e-15)
    np.linalg.cholesky(mass)  # raises LinAlgError unless every matrix is positive definite
    assert np.all(np.linalg.eigvalsh(mass)[:, 0] > 0)


def test_inverse_dynamics(check, case):
    linkage, dyn, psi, dpsi, ddpsi, _ = case
    check.close(
        dyn.inverse_dynamics(psi, dpsi, ddpsi),
        ne.inverse_dynamics(linkage, psi, dpsi, ddpsi),
        "inverse dynamics",
    )
    assert check.count == len(psi)


def test_forward_dynamics(check, case):
    """Six-link scene (cond(M) ~ 1e2): plain relative error of ddpsi. Random trees reach
    cond(M) ~ 1e8, where any two correct solvers differ by ~cond * eps in the directions M
    barely weighs; there the error is measured in the kinetic-energy norm sqrt(e^T M e),
    the norm in which a dropped torque or mass term shows at its true size."""
    linkage, dyn, psi, dpsi, _, torques = case
    actual = dyn.forward_dynamics(psi, dpsi, torques)
    reference = ne.forward_dynamics(linkage, psi, dpsi, torques)
    mass = ne.mass_matrix(linkage, psi)
    check.errors(mass_norm(mass, actual - reference) / mass_norm(mass, reference), "ddpsi (M-norm)")
    if linkage is SIX:
        check.close(actual, reference, "ddpsi")
        assert np.linalg.cond(mass).max() < 1e4


def test_inverse_of_forward_returns_the_torques(check, case):
    linkage, dyn, psi, dpsi, _, torques = case
    ddpsi = dyn.forward_dynamics(psi, dpsi, torques)
    check.close(dyn.inverse_dynamics(psi, dpsi, ddpsi), torques, "inverse(forward(M))")
    # and the oracle's inverse dynamics of the model's accelerations (across the two codes)
    check.close(ne.inverse_dynamics(linkage, psi, dpsi, ddpsi), torques, "oracle(forward(M))")


def test_ground_reaction(check, case):
    linkage, dyn, psi, dpsi, ddpsi, _ = case
    actual = dyn.ground_reaction(psi, dpsi, ddpsi)
    reference = ne.ground_reaction(linkage, psi, dpsi, ddpsi)
    assert actual.dtype == complex
    check.close(actual[:, None], reference[:, None], "ground reaction")


def test_ground_reaction_at_rest_carries_the_weight():
    """Static pose: the ground pushes up with the total weight, nothing sideways."""
    psi = np.random.default_rng(3).uniform(-np.pi, np.pi, 6)
    force = Dynamics(SIX).ground_reaction(psi, np.zeros(6), np.zeros(6))
    weight = 9.81 * sum(link.mass for link in SIX.links)
    assert abs(force - 1j * weight) <= 1e-12 * weight


def test_energy(check, case):
    """T relative; V relative to g sum m |w| (V itself crosses zero with the pose)."""
    linkage, dyn, psi, dpsi, *_ = case
    kinetic, potential = dyn.energy(psi, dpsi)
    ref_kinetic, ref_potential = ne.energy(linkage, psi, dpsi)
    check.close(kinetic[:, None], ref_kinetic[:, None], "kinetic energy")
    masses = np.array([link.mass for link in linkage.links])
    scale = linkage.gravity * np.abs(ne.com_positions(linkage, psi)) @ masses
    check.errors(np.abs(potential - ref_potential) / scale, "potential energy")


def test_positions(check, case):
    linkage, dyn, psi, *_ = case
    check.close(dyn.hinge_positions(psi), ne.hinge_positions(linkage, psi), "hinges")
    check.close(dyn.com_positions(psi), ne.com_positions(linkage, psi), "centres of mass")
    assert dyn.hinge_positions(psi).shape == (len(psi), linkage.n + 1)


def test_velocities(check, case):
    linkage, dyn, psi, dpsi, *_ = case
    check.close(
        dyn.hinge_velocities(psi, dpsi), ne.hinge_velocities(linkage, psi, dpsi), "hinge vel."
    )
    check.close(dyn.com_velocities(psi, dpsi), ne.com_velocities(linkage, psi, dpsi), "com vel.")


def test_gravity_torques_are_inverse_dynamics_at_rest(check, case):
    linkage, dyn, psi, *_ = case
    zero = np.zeros_like(psi)
    check.close(dyn.gravity_torques(psi), dyn.inverse_dynamics(psi, zero, zero), "static")
    check.close(dyn.gravity_torques(psi), ne.inverse_dynamics(linkage, psi, zero, zero), "oracle")


def test_dynamics_residual_is_inverse_dynamics_minus_torques(check, case):
    linkage, dyn, psi, dpsi, ddpsi, torques = case
    residual = dyn.dynamics_residual(psi, dpsi, ddpsi, torques)
    expected = ne.inverse_dynamics(linkage, psi, dpsi, ddpsi) - torques
    # relative to the torques (the residual itself is a difference of like-sized terms)
    check.errors(
        np.linalg.norm(residual - expected, axis=1) / np.linalg.norm(torques, axis=1), "residual"
    )
    # zero on the motion the torques produce
    ddpsi_true = ne.forward_dynamics(linkage, psi, dpsi, torques)
    on_motion = dyn.dynamics_residual(psi, dpsi, ddpsi_true, torques)
    check.errors(np.linalg.norm(on_motion, axis=1) / np.linalg.norm(torques, axis=1), "on motion")


def test_ode(check, case):
    linkage, dyn, psi, dpsi, _, torques = case
    ode = dyn.function("ode")
    assert ode.name_in() == ["x", "u"] and ode.name_out() == ["xdot"]
    x = np.hstack([psi, dpsi])
    xdot = np.asarray(ode(x.T, torques.T)).T  # CasADi maps over the columns
    check.close(xdot[:, : linkage.n], dpsi, "dpsi part", tol=0.0)
    reference = ne.forward_dynamics(linkage, psi, dpsi, torques)
    mass = ne.mass_matrix(linkage, psi)
    errors = mass_norm(mass, xdot[:, linkage.n :] - reference) / mass_norm(mass, reference)
    check.errors(errors, "ddpsi part (M-norm)")


@pytest.mark.parametrize("cse", [True, False], ids=["cse", "no_cse"])
def test_both_generation_modes_agree_with_the_oracle(check, cse):
    """Dynamics picks common-subexpression elimination by tree depth; forcing either mode
    must not change the numbers (the default cases above cover one mode per tree)."""
    deepest = max(
        (tree(*t) for t in TREES), key=lambda lk: max(len(lk.ancestors(i)) for i in range(lk.n))
    )
    for linkage in (SIX, deepest):
        dyn = Dynamics(linkage, cse=cse)
        psi, dpsi, ddpsi, torques = random_states(linkage, 16, seed=31)
        check.close(dyn.mass_matrix(psi), ne.mass_matrix(linkage, psi), "mass matrix")
        check.close(
            dyn.inverse_dynamics(psi, dpsi, ddpsi),
            ne.inverse_dynamics(linkage, psi, dpsi, ddpsi),
            "inverse dynamics",
        )
        check.close(
            dyn.inverse_dynamics(psi, dpsi, dyn.forward_dynamics(psi, dpsi, torques)),
            torques,
            "inverse(forward)",
        )
    assert check.count == 2 * 3 * 16


def test_kinetic_energy_is_the_mass_matrix_quadratic_form(check, case):
    """T = 1/2 dpsi^T M dpsi ties the mass matrix to the velocity kinematics."""
    _, dyn, psi, dpsi, *_ = case
    kinetic, _ = dyn.energy(psi, dpsi)
    quadratic = 0.5 * np.einsum("ki,kij,kj->k", dpsi, dyn.mass_matrix(psi), dpsi)
    check.close(kinetic[:, None], quadratic[:, None], "T vs M")


# ---- finite differences -------------------------------------------------------------------------
def _richardson(f, psi, direction, h):
    """d/ds f(psi + s direction) at s = 0: central differences at h and h/2, extrapolated
    (error O(h^4) + rounding ~ eps |f| / h)."""

    def central(step):
        return (f(psi + step * direction) - f(psi - step * direction)) / (2 * step)

    return (4 * central(h / 2) - central(h)) / 3


FD_CASES = [("six_link", SIX), ("tree0", tree(*TREES[0])), ("general100", tree(*TREES[24]))]


@pytest.mark.parametrize("name,linkage", FD_CASES, ids=[c[0] for c in FD_CASES])
def test_velocities_match_finite_differences_of_positions(check, name, linkage):
    dyn = dynamics_of(linkage)
    psi, dpsi, *_ = random_states(linkage, 32, seed=5)
    h = 1e-3
    check.close(
        dyn.com_velocities(psi, dpsi),
        _richardson(dyn.com_positions, psi, dpsi, h),
        "com velocities",
        tol=1e-9,
    )
    check.close(
        dyn.hinge_velocities(psi, dpsi)[:, 1:],  # H0 is fixed (both sides exactly 0)
        _richardson(dyn.hinge_positions, psi, dpsi, h)[:, 1:],
        "hinge velocities",
        tol=1e-9,
    )
    assert check.count == 64


@pytest.mark.parametrize("name,linkage", FD_CASES, ids=[c[0] for c in FD_CASES])
def test_gravity_torques_match_finite_differences_of_potential(check, name, linkage):
    """Q_grav = dPi/dpsi column by column, then M = sum of Q over subtrees."""
    dyn = dynamics_of(linkage)
    psi, *_ = random_states(linkage, 16, seed=6)
    n = linkage.n

    def potential(p):
        return dyn.energy(p, np.zeros_like(p))[1]

    q = np.stack([_richardson(potential, psi, np.eye(n)[m], 1e-3) for m in range(n)], axis=1)
    subtree = np.eye(n)
    for i in range(n):
        for a in linkage.ancestors(i):
            subtree[a, i] = 1.0
    check.close(dyn.gravity_torques(psi), q @ subtree.T, "gravity torques", tol=1e-8)


# ---- numpy batch path (numpy_tape) vs single-state CasADi ------------------------------------
METHODS = {
    "mass_matrix": ("psi",),
    "inverse_dynamics": ("psi", "dpsi", "ddpsi"),
    "gravity_torques": ("psi",),
    "forward_dynamics": ("psi", "dpsi", "torques"),
    "dynamics_residual": ("psi", "dpsi", "ddpsi", "torques"),
    "energy": ("psi", "dpsi"),
    "hinge_positions": ("psi",),
    "hinge_velocities": ("psi", "dpsi"),
    "com_positions": ("psi",),
    "com_velocities": ("psi", "dpsi"),
    "ground_reaction": ("psi", "dpsi", "ddpsi"),
}


def _stack_outputs(value):
    """A method's result as one (K, ...) array (energy's pair becomes (K, 2))."""
    if isinstance(value, tuple):
        return np.stack([np.asarray(v) for v in value], axis=-1)
    return np.asarray(value)


@pytest.mark.parametrize("linkage", [SIX, tree(*TREES[0])], ids=["six_link", "tree0"])
@pytest.mark.parametrize("method", sorted(METHODS))
def test_batch_path_equals_single_state_path(check, monkeypatch, linkage, method):
    """K >= NumpyTape.MIN_BATCH runs the numpy tape; each state alone runs CasADi's VM."""
    calls = []
    original = NumpyTape.__call__

    def spy(self, columns):
        calls.append(columns[0].shape[1])
        return original(self, columns)

    monkeypatch.setattr(NumpyTape, "__call__", spy)
    dyn = Dynamics(linkage)  # fresh: no tape cached from other tests
    k = NumpyTape.MIN_BATCH + 44
    psi, dpsi, ddpsi, torques = random_states(linkage, k, seed=11)
    values = {"psi": psi, "dpsi": dpsi, "ddpsi": ddpsi, "torques": torques}
    args = [values[a] for a in METHODS[method]]
    batch = _stack_outputs(getattr(dyn, method)(*args))
    assert calls == [k], "the batch did not go through the numpy tape"
    single = np.stack(
        [_stack_outputs(getattr(dyn, method)(*(a[s] for a in args))) for s in range(k)]
    )
    assert len(calls) == 1, "single states must not use the tape"
    assert batch.shape == single.shape
    check.close(batch, single, method, tol=1e-13)


def test_batch_path_crosses_chunks(check):
    """More states than NumpyTape.CHUNK: chunks are stitched back in order."""
    k = NumpyTape.CHUNK + 300
    psi, dpsi, ddpsi, _ = random_states(SIX, k, seed=12)
    check.close(
        Dynamics(SIX).inverse_dynamics(psi, dpsi, ddpsi),
        ne.inverse_dynamics(SIX, psi, dpsi, ddpsi),
        "inverse dynamics",
    )
    assert check.count == k


def test_single_state_shapes_and_types():
    dyn = dynamics_of(SIX)
    psi, dpsi, ddpsi, torques = (a[0] for a in random_states(SIX, 1, seed=13))
    assert dyn.mass_matrix(psi).shape == (6, 6)
    assert dyn.inverse_dynamics(psi, dpsi, ddpsi).shape == (6,)
    assert dyn.forward_dynamics(psi, dpsi, torques).shape == (6,)
    assert dyn.hinge_positions(psi).shape == (7,)
    assert dyn.com_velocities(psi, dpsi).shape == (6,)
    kinetic, potential = dyn.energy(psi, dpsi)
    assert isinstance(kinetic, float) and isinstance(potential, float)
    assert isinstance(dyn.ground_reaction(psi, dpsi, ddpsi), complex)
    # a batch of one keeps its batch axis
    assert dyn.inverse_dynamics(psi[None], dpsi[None], ddpsi[None]).shape == (1, 6)
    assert dyn.energy(psi[None], dpsi[None])[0].shape == (1,)


# ---- passive energy -----------------------------------------------------------------------------
def lowest_potential(linkage: Linkage) -> float:
    """Pi of the pose with every link hanging straight down (paper-form links): the minimum
    of g sum m_i Im(w_i), since each w_i is at most sum_ancestors l_k + n_i l_i below H0."""
    total = 0.0
    for i, link in enumerate(linkage.links):
        reach = sum(linkage.links[k].length for k in linkage.ancestors(i)) + link.com * link.length
        total -= linkage.gravity * link.mass * reach
    return total


def test_passive_motion_conserves_energy():
    """Zero torques, 2 s of the six-link scene from a random state, DOP853 at rtol = atol =
    1e-12 on the model's own ``ode``: |E(t) - E(0)| / E(0) <= 1e-8.

    E = T + Pi - Pi_lowest, the energy above the pose hanging straight down, is >= 0 for every
    state and here several hundred J, so the ratio is not a ratio of small numbers.
    """
    dyn = Dynamics(SIX)
    ode = dyn.function("ode")
    rng = np.random.default_rng(2026)
    x0 = np.concatenate([rng.uniform(-np.pi, np.pi, 6), rng.normal(0.0, 1.0, 6)])
    zero = np.zeros(6)

    def rhs(_t, x):
        return np.asarray(ode(x, zero)).ravel()

    solution = solve_ivp(rhs, (0.0, 2.0), x0, method="DOP853", rtol=1e-12, atol=1e-12)
    assert solution.success, solution.message
    assert solution.t[-1] == 2.0 and solution.t.size > 100
    psi, dpsi = solution.y[:6].T, solution.y[6:].T
    # the motion is not trivial: every link turns
    assert np.all(np.ptp(psi, axis=0) > 0.1)
    kinetic, potential = dyn.energy(psi, dpsi)
    energy = kinetic + potential - lowest_potential(SIX)
    assert energy[0] > 100.0
    drift = np.abs(energy - energy[0]) / energy[0]
    assert drift.max() <= 1e-8, (
        f"energy drift {drift.max():.2e} at t = {solution.t[drift.argmax()]}"
    )
    # the oracle's energy of the same trajectory agrees
    ref_kinetic, ref_potential = ne.energy(SIX, psi, dpsi)
    assert np.allclose(ref_kinetic + ref_potential, kinetic + potential, rtol=1e-12, atol=0)


# ---- the tolerance can fail ---------------------------------------------------------------------
def _perturbed(linkage: Linkage, k: int, **changes) -> Linkage:
    links = list(linkage.links)
    links[k] = dataclasses.replace(links[k], **changes)
    return Linkage(links, gravity=linkage.gravity)


def test_tolerance_detects_small_parameter_errors_on_the_six_link_scene():
    """If the model mis-scaled any single parameter by 1e-6 (far less than dropping a term),
    the comparisons above would report errors beyond TOL: shown by evaluating the oracle on
    the perturbed scene against the model of the true one."""
    dyn = dynamics_of(SIX)
    psi, dpsi, ddpsi, _ = random_states(SIX, SIX_LINK_STATES, seed=1)
    model_torque = dyn.inverse_dynamics(psi, dpsi, ddpsi)
    model_mass = dyn.mass_matrix(psi)
    detected = 0
    for k, link in enumerate(SIX.links):
        for field in ("length", "mass", "com", "inertia"):
            bad = _perturbed(SIX, k, **{field: getattr(link, field) * (1 + 1e-6)})
            torque_error = relative_error(model_torque, ne.inverse_dynamics(bad, psi, dpsi, ddpsi))
            mass_error = relative_error(model_mass, ne.mass_matrix(bad, psi))
            # margins: >= 30x for the mass matrix (J_1 is its smallest entry), more for M
            assert torque_error.max() > 10 * TOL, (link.name, field)
            assert mass_error.max() > 10 * TOL, (link.name, field)
            detected += 1
    assert detected == 24


def test_tolerance_detects_dropped_terms():
    """Dropping the velocity terms, gravity, or one link's J ddpsi term fails the bound,
    on the six-link scene and on every random tree."""
    count = 0
    for linkage in [SIX] + [tree(*t) for t in TREES]:
        dyn = dynamics_of(linkage)
        psi, dpsi, ddpsi, _ = random_states(linkage, 16, seed=21)
        model = dyn.inverse_dynamics(psi, dpsi, ddpsi)
        wrong = [
            ne.inverse_dynamics(linkage, psi, np.zeros_like(dpsi), ddpsi),  # no dpsi^2 terms
            ne.inverse_dynamics(_no_gravity(linkage), psi, dpsi, ddpsi),  # no weight
        ]
        wrong += [
            ne.inverse_dynamics(_perturbed(linkage, k, inertia=0.0), psi, dpsi, ddpsi)
            for k in range(linkage.n)
        ]
        for reference in wrong:
            assert relative_error(model, reference).max() > 100 * TOL, linkage
            count += 1
    assert count >= 200


def _no_gravity(linkage: Linkage) -> Linkage:
    return Linkage(linkage.links, gravity=0.0)


# ---- lazy generation ----------------------------------------------------------------------------
def test_inverse_dynamics_alone_builds_nothing_else():
    dyn = Dynamics(presets.six_link_anthropoid())
    assert dyn.built == ()
    dyn.inverse_dynamics(np.zeros(6), np.zeros(6), np.zeros(6))
    assert dyn.built == ("inverse_dynamics",)
    assert "forward_dynamics" not in dyn.built and "mass_matrix" not in dyn.built
    # a batch (numpy tape) also reuses the same Function
    dyn.inverse_dynamics(np.zeros((300, 6)), np.zeros((300, 6)), np.zeros((300, 6)))
    assert dyn.built == ("inverse_dynamics",)
    dyn.forward_dynamics(np.zeros(6), np.zeros(6), np.zeros(6))
    assert dyn.built == ("inverse_dynamics", "forward_dynamics")


def test_functions_are_cached_and_named():
    dyn = Dynamics(presets.six_link_anthropoid())
    for name, (inputs, outputs, _) in FUNCTIONS.items():
        function = dyn.function(name)
        assert dyn.function(name) is function
        assert function.name() == name
        assert tuple(function.name_in()) == inputs
        assert tuple(function.name_out()) == outputs
        assert name in dyn.generation_seconds
    assert set(dyn.built) == set(FUNCTIONS)
    assert "built" in repr(dyn)


# ---- validation of the numeric methods ----------------------------------------------------------
GOOD = np.zeros(6)
BAD_INPUTS = [
    (np.zeros(5), DefinitionError, r"`psi`: expected shape \(6,\) or \(K, 6\), got \(5,\)"),
    (np.zeros((3, 5)), DefinitionError, r"`psi`: expected shape .* got \(3, 5\)"),
    (np.zeros((2, 3, 6)), DefinitionError, r"`psi`: expected shape .* got \(2, 3, 6\)"),
    (5.0, DefinitionError, r"`psi`: expected shape .* got \(\)"),
    (np.full(6, np.nan), DefinitionError, "`psi`: contains NaN or inf"),
    (np.array([0, 0, np.inf, 0, 0, 0]), DefinitionError, "`psi`: contains NaN or inf"),
    ("abcdef", DefinitionTypeError, r"`psi`: must be numeric of shape \(6,\) or \(K, 6\)"),
    ([0, 0, 0, 0, 0, 1j], DefinitionTypeError, r"`psi`: must be real numbers .* got complex"),
    # numpy would drop the imaginary parts (with a warning) and read booleans as 0 and 1
    (np.full(6, 1.0 + 1e-3j), DefinitionTypeError, r"`psi`: must be real numbers of shape "),
    (np.ones(6, dtype=bool), DefinitionTypeError, r"`psi`: .* got booleans; give real numbers"),
]


@pytest.mark.parametrize("method", sorted(METHODS))
@pytest.mark.parametrize(
    "bad,error,message", BAD_INPUTS, ids=[f"bad{i}" for i in range(len(BAD_INPUTS))]
)
def test_numeric_methods_reject_bad_psi(method, bad, error, message):
    dyn = dynamics_of(SIX)
    args = [bad] + [GOOD] * (len(METHODS[method]) - 1)
    with pytest.raises(error, match=message):
        getattr(dyn, method)(*args)


def test_finite_inputs_that_overflow_raise_instead_of_returning_nan():
    dyn = dynamics_of(SIX)
    psi = np.ones((3, 6))
    dpsi = np.zeros((3, 6))
    dpsi[1] = 1e200  # (1e200)^2 overflows: the torques would come back NaN
    with pytest.raises(
        DefinitionError,
        match=r"`inverse_dynamics`: the result is inf or NaN at state 1 although the inputs are "
        r"finite \(\|psi\| up to 1, \|dpsi\| up to 1e\+200, \|ddpsi\| up to 0\)",
    ):
        dyn.inverse_dynamics(psi, dpsi, np.zeros((3, 6)))
    with pytest.raises(DefinitionError, match=r"`energy`: the result is inf or NaN"):
        dyn.energy(np.ones(6), np.full(6, 1e200))
    with pytest.raises(DefinitionError, match=r"`forward_dynamics`: the result is inf or NaN"):
        dyn.forward_dynamics(np.ones(6), np.zeros(6), np.full(6, 1e308))
    # large but representable values pass (the check is on the result, not a threshold)
    assert np.all(np.isfinite(dyn.inverse_dynamics(np.ones(6), np.full(6, 1e100), np.zeros(6))))


@pytest.mark.parametrize("method", [m for m in sorted(METHODS) if len(METHODS[m]) > 1])
def test_numeric_methods_reject_bad_later_inputs(method):
    """The message names the input at fault, whichever position it has."""
    dyn = dynamics_of(SIX)
    names = METHODS[method]
    last = {"torques": "M"}.get(names[-1], names[-1])  # the Function's input name
    args = [GOOD] * (len(names) - 1)
    with pytest.raises(DefinitionError, match=f"`{last}`: contains NaN or inf"):
        getattr(dyn, method)(*args, np.full(6, np.nan))
    with pytest.raises(DefinitionError, match=f"`{last}`: expected shape"):
        getattr(dyn, method)(*args, np.zeros(7))
    # mismatched batches: a batch against a single state, and two batch sizes
    with pytest.raises(
        DefinitionError, match=f"`{last}`: batch size 3 differs from `psi` \\(None\\)"
    ):
        getattr(dyn, method)(*args, np.zeros((3, 6)))
    batches = [np.zeros((4, 6))] * (len(names) - 1)
    with pytest.raises(DefinitionError, match=f"`{last}`: batch size 3 differs from `psi` \\(4\\)"):
        getattr(dyn, method)(*batches, np.zeros((3, 6)))


def test_validation_errors_are_library_errors():
    dyn = dynamics_of(SIX)
    with pytest.raises(ValueError):
        dyn.mass_matrix(np.zeros(5))
    with pytest.raises(AnthropoidError):
        dyn.mass_matrix(np.zeros(5))
    with pytest.raises(TypeError):
        dyn.mass_matrix("abcdef")


def test_unknown_function_name():
    with pytest.raises(DefinitionError, match="`name`: unknown function 'mass'; available: "):
        dynamics_of(SIX).function("mass")


def test_dynamics_requires_a_linkage():
    with pytest.raises(DefinitionTypeError, match=r"`linkage`: must be a model.Linkage, got list"):
        Dynamics([Link("a", None, 1.0, 1.0)])


# ---- edge cases: empty batches, a link without rotational inertia, one-link trees ----------------
@pytest.mark.parametrize("method", sorted(METHODS))
def test_empty_batch_gives_empty_results(method):
    """A (0, n) batch is a legal numpy batch: every method returns (0, ...) arrays with the
    per-state shape of a single state (CasADi alone would evaluate one state instead)."""
    dyn = dynamics_of(SIX)
    count = len(METHODS[method])
    single = _stack_outputs(getattr(dyn, method)(*[GOOD] * count))
    empty = _stack_outputs(getattr(dyn, method)(*[np.zeros((0, 6))] * count))
    assert empty.shape == (0, *np.shape(single))
    assert empty.dtype == np.asarray(single).dtype


def test_leaf_without_rotational_inertia_is_refused():
    """A leaf link with com = 0 and inertia = 0 has no inertia about its only joint: M is
    singular and forward dynamics is undefined. It must be refused with a message, not
    answered with NaN."""
    point_mass = [Link("arm", None, 1.0, 1.0), Link("bob", "arm", 1.0, 1.0, com=0.0, inertia=0.0)]
    with pytest.raises(DefinitionError, match=r"`links\[1\]`: 'bob' has no moment of inertia"):
        Dynamics(Linkage(point_mass)).forward_dynamics([0.0, 1.0], [0.0, 0.0], [0.0, 0.0])


def test_one_link_linkage_keeps_its_shapes():
    """A one-link tree (``n_link_chain(1)``, or a tree with every other link locked) must
    keep the documented shapes: M (n, n), torques (n,), positions (n,); only the energies and
    the ground force, one number per state, become scalars."""
    dyn = Dynamics(presets.n_link_chain(1))
    one = np.array([0.3])
    assert np.shape(dyn.hinge_positions(one)) == (2,)  # n + 1 = 2: not affected
    assert np.shape(dyn.mass_matrix(one)) == (1, 1)
    assert np.shape(dyn.inverse_dynamics(one, one, one)) == (1,)
    assert np.shape(dyn.forward_dynamics(one, one, one)) == (1,)
    assert np.shape(dyn.gravity_torques(one)) == (1,)
    assert np.shape(dyn.com_positions(one)) == (1,)
    batch = np.full((3, 1), 0.3)
    assert np.shape(dyn.mass_matrix(batch)) == (3, 1, 1)
    assert np.shape(dyn.inverse_dynamics(batch, batch, batch)) == (3, 1)
