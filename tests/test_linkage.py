"""model.Link and model.Linkage: validation messages, tree queries, drop() and lock().

lock() is checked for exactness by the independent Newton-Euler oracle
(``reference.newton_euler``): the reduced linkage, at any state, must have the same energies,
hinge torques, ground force, hinge and centre-of-mass positions and mass matrix as the full
linkage at the state where each locked link follows its parent,
psi_child = psi_parent + angle (dpsi and ddpsi equal). The hinge torque at a locked hinge is
the constraint torque and disappears; every other hinge torque is unchanged, because it is
the sum of Q over a subtree that the lock leaves whole (Q_merged = Q_parent + Q_child by
virtual work). Mass matrices relate by M_reduced = P^T M_full P with P the constraint's
velocity map.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from reference import newton_euler as ne

from model import (
    AnthropoidError,
    DefinitionError,
    DefinitionTypeError,
    Dynamics,
    Link,
    Linkage,
    presets,
)
from model.linkage import total_mass

TOL = 1e-10


def relative_error(actual, reference) -> np.ndarray:
    """Per-state ||a - b|| / (||b|| + 1e-30) over the non-leading axes."""
    actual, reference = np.asarray(actual), np.asarray(reference)
    assert actual.shape == reference.shape, (actual.shape, reference.shape)
    k = reference.shape[0]
    diff = np.linalg.norm((actual - reference).reshape(k, -1), axis=1)
    return diff / (np.linalg.norm(reference.reshape(k, -1), axis=1) + 1e-30)


def rod(name="a", parent=None, **kw):
    kw.setdefault("length", 1.0)
    kw.setdefault("mass", 1.0)
    return Link(name, parent, **kw)


# ---- Link validation -------------------------------------------------------------------------
LINK_ERRORS = [
    (dict(name=3), DefinitionTypeError, r"`Link.name`: must be a string, got 3"),
    (dict(name="  "), DefinitionError, r"`Link.name`: must be a non-empty string"),
    (dict(name=""), DefinitionError, r"`Link.name`: must be a non-empty string"),
    (
        dict(parent=1),
        DefinitionTypeError,
        r"`Link 'a'.parent`: must be a link name \(str\) or None",
    ),
    (dict(length=0.0), DefinitionError, r"`Link 'a'.length`: must be > 0 m, got 0.0"),
    (dict(length=-1), DefinitionError, r"`Link 'a'.length`: must be > 0 m, got -1.0"),
    (dict(length=math.nan), DefinitionError, r"`Link 'a'.length`: must be finite, got nan"),
    (dict(length=math.inf), DefinitionError, r"`Link 'a'.length`: must be finite, got inf"),
    (dict(length="1"), DefinitionTypeError, r"`Link 'a'.length`: must be a real number, got '1'"),
    (dict(length=None), DefinitionTypeError, r"`Link 'a'.length`: must be a real number, got None"),
    (dict(length=True), DefinitionTypeError, r"`Link 'a'.length`: .* got True of type bool"),
    (dict(length=1 + 0j), DefinitionTypeError, r"`Link 'a'.length`: must be a real number"),
    (dict(mass=0), DefinitionError, r"`Link 'a'.mass`: must be > 0 kg, got 0.0"),
    (dict(mass=-2.5), DefinitionError, r"`Link 'a'.mass`: must be > 0 kg, got -2.5"),
    (dict(mass=-math.inf), DefinitionError, r"`Link 'a'.mass`: must be finite, got -inf"),
    (dict(mass=False), DefinitionTypeError, r"`Link 'a'.mass`: .* of type bool"),
    (dict(com=-0.01), DefinitionError, r"`Link 'a'.com`: .* must lie in \[0, 1\] .* got -0.01"),
    (dict(com=1.5), DefinitionError, r"`Link 'a'.com`: .* must lie in \[0, 1\] .* got 1.5"),
    (dict(com=math.nan), DefinitionError, r"`Link 'a'.com`: must be finite"),
    (dict(com=True), DefinitionTypeError, r"`Link 'a'.com`: must be a real number"),
    (dict(inertia=-1e-9), DefinitionError, r"`Link 'a'.inertia`: .* must be >= 0 kg m\^2"),
    (dict(inertia=math.nan), DefinitionError, r"`Link 'a'.inertia`: must be finite"),
    (dict(inertia="0.1"), DefinitionTypeError, r"`Link 'a'.inertia`: must be a real number"),
    (dict(inertia=True), DefinitionTypeError, r"`Link 'a'.inertia`: .* of type bool"),
    (dict(com_lateral=math.inf), DefinitionError, r"`Link 'a'.com_lateral`: must be finite"),
    (dict(com_lateral=None), DefinitionTypeError, r"`Link 'a'.com_lateral`: must be a real"),
    (dict(origin="0"), DefinitionTypeError, r"`Link 'a'.origin`: must be a complex number"),
    (dict(origin=True), DefinitionTypeError, r"`Link 'a'.origin`: must be a complex number"),
    (dict(origin=complex(math.nan, 0)), DefinitionError, r"`Link 'a'.origin`: must be finite"),
    (dict(origin=complex(0, math.inf)), DefinitionError, r"`Link 'a'.origin`: must be finite"),
    (dict(merged=["b"]), DefinitionTypeError, r"`Link 'a'.merged`: must be a tuple of link names"),
    (dict(merged=(1,)), DefinitionTypeError, r"`Link 'a'.merged`: must be a tuple of link names"),
]


@pytest.mark.parametrize("changes,error,message", LINK_ERRORS, ids=[str(c[0]) for c in LINK_ERRORS])
def test_link_validation(changes, error, message):
    kw = dict(name="a", parent=None, length=1.0, mass=1.0)
    kw.update(changes)
    with pytest.raises(error, match=message):
        Link(**kw)


def test_link_errors_derive_from_the_library_base_and_builtins():
    with pytest.raises(AnthropoidError):
        rod(mass=-1)
    with pytest.raises(ValueError):
        rod(mass=-1)
    with pytest.raises(TypeError):
        rod(mass="1")


def test_link_defaults_and_derived_quantities():
    link = Link("a", None, 2, 3)  # ints become floats
    assert isinstance(link.length, float) and isinstance(link.mass, float)
    assert link.com == 0.5 and link.com_lateral == 0.0 and link.origin is None
    assert link.inertia == pytest.approx(3 * 2**2 / 12, rel=1e-15)  # uniform rod
    assert link.com_offset == 1.0 + 0j
    assert link.inertia_about_start == pytest.approx(1.0 + 3 * 1.0**2, rel=1e-15)
    assert link.is_paper_link
    assert Link("a", None, np.float64(1.5), np.float32(2.0)).length == 1.5  # numpy reals
    off = Link("b", "a", 2.0, 1.0, com=0.25, inertia=0.0, com_lateral=0.5, origin=1)
    assert off.origin == 1 + 0j and isinstance(off.origin, complex)
    assert off.com_offset == 0.5 + 1.0j
    assert off.inertia_about_start == pytest.approx(1.25, rel=1e-15)
    assert not off.is_paper_link
    assert rod(com=0.0).com == 0.0 and rod(com=1.0).com == 1.0 and rod(inertia=0.0).inertia == 0.0


def test_merged_links_may_have_their_centre_outside_the_axis_span():
    # a body merged by lock() can have its centre of mass beyond the end hinge
    assert rod(com=1.7, merged=("b",)).com == 1.7


def test_links_are_frozen_and_compare_by_value():
    link = rod()
    with pytest.raises(AttributeError):
        link.mass = 2.0
    assert rod() == rod() and hash(rod()) == hash(rod())
    assert rod() == Link("a", None, 1, 1, inertia=1 / 12)


# ---- Linkage validation -------------------------------------------------------------------------
def test_linkage_rejects_a_string_or_non_iterable():
    with pytest.raises(
        DefinitionTypeError, match=r"`links`: must be a sequence of model.Link, got str"
    ):
        Linkage("abc")
    with pytest.raises(DefinitionTypeError, match=r"`links`: must be a sequence .* got int"):
        Linkage(3)
    with pytest.raises(DefinitionTypeError, match=r"`links`: must be a sequence .* got Link"):
        Linkage(rod())


def test_linkage_rejects_an_empty_tree():
    with pytest.raises(DefinitionError, match="`links`: the tree is empty; give at least one"):
        Linkage([])


def test_linkage_rejects_non_links():
    with pytest.raises(DefinitionTypeError, match=r"`links\[1\]`: must be a model.Link, got dict"):
        Linkage([rod(), {"name": "b"}])


@pytest.mark.parametrize(
    "gravity,error,message",
    [
        (
            -9.81,
            DefinitionError,
            r"`gravity`: the magnitude of g .* must be >= 0 m/s\^2, got -9.81",
        ),
        (math.nan, DefinitionError, "`gravity`: must be finite"),
        (math.inf, DefinitionError, "`gravity`: must be finite"),
        (True, DefinitionTypeError, "`gravity`: must be a real number, got True of type bool"),
        ("9.81", DefinitionTypeError, "`gravity`: must be a real number"),
        (None, DefinitionTypeError, "`gravity`: must be a real number"),
    ],
)
def test_linkage_gravity_validation(gravity, error, message):
    with pytest.raises(error, match=message):
        Linkage([rod()], gravity=gravity)


def test_zero_gravity_is_allowed():
    assert Linkage([rod()], gravity=0).gravity == 0.0


def test_linkage_rejects_duplicate_names():
    with pytest.raises(
        DefinitionError, match=r"`links\[2\].name`: duplicate name 'b' \(also links\[1\]\)"
    ):
        Linkage([rod("a"), rod("b", "a"), rod("b", "a")])


def test_linkage_rejects_a_second_root():
    with pytest.raises(
        DefinitionError,
        match=r"`links\[2\].parent`: None makes 'c' a second root \(the root is 'a'\)",
    ):
        Linkage([rod("a"), rod("b", "a"), rod("c")])


def test_linkage_rejects_an_unknown_parent():
    with pytest.raises(
        DefinitionError,
        match=r"`links\[1\].parent`: unknown parent 'x' of 'b'; known links: \['a', 'b'\]",
    ):
        Linkage([rod("a"), rod("b", "x")])


def test_linkage_rejects_a_parent_after_its_child():
    with pytest.raises(
        DefinitionError,
        match=r"`links\[1\].parent`: parent 'c' of 'b' comes after it \(links\[2\]\); order",
    ):
        Linkage([rod("a"), rod("b", "c"), rod("c", "a")])


def test_linkage_rejects_cycles_and_a_missing_root():
    # a cycle or a tree without root always has a parent that comes at or after its child
    with pytest.raises(
        DefinitionError, match=r"`links\[0\].parent`: parent 'b' of 'a' comes after"
    ):
        Linkage([rod("a", "b"), rod("b", "a")])
    with pytest.raises(
        DefinitionError, match=r"`links\[0\].parent`: 'a' names itself as its parent"
    ):
        Linkage([rod("a", "a")])


def test_linkage_rejects_a_link_whose_angle_has_no_dynamics():
    """No inertia about the start hinge (J = 0, centre of mass on the hinge) and no child away
    from it: psi of that link is absent from T, so M(psi) is singular."""
    point = dict(com=0.0, inertia=0.0)
    message = (
        r"`links\[1\]`: 'b' has no moment of inertia about its start hinge \(inertia 0 and "
        r"centre of mass on the hinge\) and nothing hangs off that hinge, so its angle has no "
        r"dynamics; give inertia > 0 or com > 0"
    )
    with pytest.raises(DefinitionError, match=message):
        Linkage([rod("a"), rod("b", "a", **point)])
    with pytest.raises(DefinitionError, match=message):  # a child on the same hinge does not help
        Linkage([rod("a"), rod("b", "a", **point), rod("c", "b", origin=0j)])
    # the same link is a lever once something hangs away from its start hinge, or has inertia
    assert Linkage([rod("a"), rod("b", "a", **point), rod("c", "b")]).n == 3
    assert Linkage([rod("a"), rod("b", "a", com=0.0, inertia=1e-3)]).n == 2
    assert Linkage([rod("a"), rod("b", "a", com=0.1, inertia=0.0)]).n == 2


def test_masses_and_lengths_that_overflow_the_equations_are_refused():
    # a uniform rod's m l^2 / 12 overflows: named at the link
    with pytest.raises(
        DefinitionError,
        match=r"`Link 'a'.mass`: 1e\+308 kg with length 10.0 m makes the uniform rod's moment "
        r"of inertia m l\^2 / 12 overflow to inf",
    ):
        Link("a", None, length=10.0, mass=1e308)
    # the link itself is finite, the weight m g (and M(psi)) are not: named at the tree
    heavy = Link("a", None, length=1.0, mass=1e308)
    assert math.isfinite(heavy.inertia)
    with pytest.raises(
        DefinitionError,
        match=r"`links`: masses up to 1e\+308 kg, lengths up to 1 m and inertias up to "
        r"8.33333e\+306 kg m\^2 overflow double precision",
    ):
        Linkage([heavy])
    assert Linkage([heavy], gravity=0.0).n == 1  # no weight: every coefficient is finite


def test_linkage_accepts_any_iterable_of_links():
    linkage = Linkage(link for link in [rod("a"), rod("b", "a")])
    assert linkage.names == ("a", "b")


# ---- tree queries -------------------------------------------------------------------------------
def test_tree_queries_on_the_six_link_scene():
    six = presets.six_link_anthropoid()
    assert six.n == 6
    assert six.parents == (-1, 0, 1, 2, 1, 4)
    assert six.children == ((1,), (2, 4), (3,), (), (5,), ())
    assert six.index("torso") == 4
    assert six.ancestors(5) == (0, 1, 4) and six.ancestors(0) == ()
    assert six.subtree(1) == (1, 2, 3, 4, 5) and six.subtree(3) == (3,)
    assert six.origin_in_parent(0) == 0j and six.origin_in_parent(4) == 0.43 + 0j
    assert six.is_paper_form
    assert total_mass(six) == pytest.approx(59.9, rel=1e-15)
    assert repr(six).startswith("Linkage(6 links: stance_shank<-ground, stance_thigh<-stance_shank")
    with pytest.raises(DefinitionError, match=r"`name`: no link called 'neck'; known links: \["):
        six.index("neck")


def test_linkage_equality_hash_and_parameters_round_trip():
    six = presets.six_link_anthropoid()
    assert six == presets.six_link_anthropoid() and hash(six) == hash(presets.six_link_anthropoid())
    assert six != presets.six_link_anthropoid(gravity=9.8)
    assert six != six.drop("head") and six != "six"
    locked = six.lock("torso", 0.3)
    data = locked.parameters()
    assert data["gravity"] == 9.81 and len(data["links"]) == 5
    rebuilt = Linkage(
        [
            Link(
                **{
                    **row,
                    "origin": None if row["origin"] is None else complex(*row["origin"]),
                    "merged": tuple(row["merged"]),
                }
            )
            for row in data["links"]
        ],
        gravity=data["gravity"],
    )
    assert rebuilt == locked


# ---- drop ---------------------------------------------------------------------------------------
def test_drop_removes_whole_subtrees():
    six = presets.six_link_anthropoid()
    assert six.drop("head").names == (
        "stance_shank",
        "stance_thigh",
        "swing_thigh",
        "swing_shank",
        "torso",
    )
    assert six.drop("swing_thigh").names == ("stance_shank", "stance_thigh", "torso", "head")
    assert six.drop("stance_thigh").names == ("stance_shank",)
    both = six.drop("swing_thigh", "head")
    assert both.names == ("stance_shank", "stance_thigh", "torso")
    assert both.parents == (-1, 0, 1)
    # overlapping requests are fine
    assert six.drop("swing_thigh", "swing_shank") == six.drop("swing_thigh")
    # kept links are unchanged, gravity carries over
    assert all(link == six.links[six.index(link.name)] for link in both.links)
    assert presets.six_link_anthropoid(gravity=1.62).drop("head").gravity == 1.62
    # a child re-attached by a lock can be dropped like any other
    locked = six.lock("torso", 0.3).drop("head")
    assert locked.names == ("stance_shank", "stance_thigh", "swing_thigh", "swing_shank")
    assert locked.links[1].merged == ("torso",)


def test_drop_keeps_the_dynamics_of_the_remaining_links():
    """Energies and positions of the kept links are those of the full tree: the dropped
    subtree's own share of T and Pi is all that goes (oracle per-link sums)."""
    six = presets.six_link_anthropoid()
    dropped = six.drop("swing_thigh")
    keep = [six.index(name) for name in dropped.names]
    rng = np.random.default_rng(4)
    psi, dpsi = rng.uniform(-np.pi, np.pi, (32, 6)), rng.normal(0.0, 2.0, (32, 6))
    velocity = ne.com_velocities(six, psi, dpsi)
    position = ne.com_positions(six, psi)
    kinetic = sum(
        0.5
        * (six.links[i].mass * np.abs(velocity[:, i]) ** 2 + six.links[i].inertia * dpsi[:, i] ** 2)
        for i in keep
    )
    potential = sum(9.81 * six.links[i].mass * position[:, i].imag for i in keep)
    model_kinetic, model_potential = Dynamics(dropped).energy(psi[:, keep], dpsi[:, keep])
    assert relative_error(model_kinetic[:, None], kinetic[:, None]).max() <= TOL
    assert np.abs(model_potential - potential).max() <= TOL * np.abs(potential).max()
    hinges = Dynamics(dropped).hinge_positions(psi[:, keep])
    full = ne.hinge_positions(six, psi)[:, [0] + [i + 1 for i in keep]]
    assert relative_error(hinges, full).max() <= TOL


def test_drop_errors():
    six = presets.six_link_anthropoid()
    with pytest.raises(DefinitionError, match="`names`: give at least one link name to drop"):
        six.drop()
    with pytest.raises(
        DefinitionError, match="`names`: 'stance_shank' is the root; dropping it leaves nothing"
    ):
        six.drop("stance_shank")
    with pytest.raises(DefinitionError, match="`name`: no link called 'arm'"):
        six.drop("head", "arm")


# ---- lock ---------------------------------------------------------------------------------------
def lock_all(full: Linkage, steps):
    """Apply lock(name, angle) in order; returns the reduced linkage and the constraints
    (child, parent at lock time, angle)."""
    reduced = full
    constraints = []
    for name, angle in steps:
        parent = reduced.links[reduced.parents[reduced.index(name)]].name
        constraints.append((name, parent, angle))
        reduced = reduced.lock(name, angle)
    return reduced, constraints


def embed(full: Linkage, reduced: Linkage, constraints, values, offset: bool) -> np.ndarray:
    """Full-linkage (K, n_full) values from reduced ones: psi_child = psi_parent + angle
    (``offset``) or dpsi_child = dpsi_parent. Later locks are resolved first, since an earlier
    lock's parent may itself have been locked afterwards."""
    by_name = {name: values[:, i] for i, name in enumerate(reduced.names)}
    for child, parent, angle in reversed(constraints):
        by_name[child] = by_name[parent] + (angle if offset else 0.0)
    return np.stack([by_name[name] for name in full.names], axis=1)


def generalized_forces(linkage: Linkage, torques: np.ndarray) -> np.ndarray:
    """Q_i = M_i - sum over children c of M_c, (K, n)."""
    q = torques.copy()
    for i, kids in enumerate(linkage.children):
        for c in kids:
            q[:, i] -= torques[:, c]
    return q


SIX = presets.six_link_anthropoid()
LOCK_SCENARIOS = {
    "leaf": (SIX, [("head", 0.3)]),
    "leaf_at_zero": (SIX, [("swing_shank", 0.0)]),
    "with_child": (SIX, [("torso", -0.4)]),
    "with_two_children": (SIX, [("stance_thigh", 0.2)]),
    "twice_chain": (SIX, [("swing_shank", -0.5), ("swing_thigh", 1.0)]),
    "twice_merged_into_parent": (SIX, [("torso", 0.3), ("stance_thigh", 0.1)]),
    "twice_reattached_child": (SIX, [("stance_thigh", 0.2), ("torso", -1.1)]),
    "all_but_root": (
        SIX,
        [
            ("head", 0.1),
            ("torso", 0.2),
            ("swing_shank", 0.3),
            ("swing_thigh", 0.4),
            ("stance_thigh", 0.5),
        ],
    ),
}
for _seed in range(6):
    _rng = np.random.default_rng(300 + _seed)
    _tree = ne.random_tree(_rng, 10, general=_seed % 2 == 1)
    _names = list(_tree.names[1:])
    _first = _names[int(_rng.integers(len(_names)))]
    _second = [n for n in _names if n != _first][int(_rng.integers(len(_names) - 1))]
    LOCK_SCENARIOS[f"tree{_seed}"] = (
        _tree,
        [(_first, float(_rng.uniform(-3, 3))), (_second, float(_rng.uniform(-3, 3)))],
    )


@pytest.mark.parametrize("scenario", sorted(LOCK_SCENARIOS))
def test_lock_is_exact(scenario):
    full, steps = LOCK_SCENARIOS[scenario]
    reduced, constraints = lock_all(full, steps)
    assert reduced.n == full.n - len(steps)
    keep = [full.index(name) for name in reduced.names]
    rng = np.random.default_rng(sorted(LOCK_SCENARIOS).index(scenario))
    k = 24
    psi_r = rng.uniform(-np.pi, np.pi, (k, reduced.n))
    dpsi_r = rng.normal(0.0, 2.0, (k, reduced.n))
    ddpsi_r = rng.normal(0.0, 5.0, (k, reduced.n))
    psi = embed(full, reduced, constraints, psi_r, offset=True)
    dpsi = embed(full, reduced, constraints, dpsi_r, offset=False)
    ddpsi = embed(full, reduced, constraints, ddpsi_r, offset=False)
    dyn = Dynamics(reduced)
    compared = 0

    def agree(model_value, oracle_reduced, oracle_full, what, scale=None):
        nonlocal compared
        # reshape: for a one-link result the model drops the (1,)-axes (reported defect,
        # tested in test_dynamics.py::test_one_link_linkage_keeps_its_shapes)
        model_value = np.reshape(model_value, np.shape(oracle_full))
        for label, value in (("model", model_value), ("oracle", oracle_reduced)):
            if scale is None:
                error = relative_error(value, oracle_full)
            else:
                error = np.abs(value - oracle_full) / scale
            assert error.max() <= TOL, f"{scenario}: {label} {what}: {error.max():.2e}"
            compared += error.size

    # energies: T relative; Pi relative to g sum m |w| (Pi crosses zero)
    kinetic, potential = ne.energy(full, psi, dpsi)
    r_kinetic, r_potential = ne.energy(reduced, psi_r, dpsi_r)
    m_kinetic, m_potential = dyn.energy(psi_r, dpsi_r)
    agree(m_kinetic[:, None], r_kinetic[:, None], kinetic[:, None], "T")
    masses = np.array([link.mass for link in full.links])
    scale = full.gravity * np.abs(ne.com_positions(full, psi)) @ masses
    agree(m_potential, r_potential, potential, "Pi", scale=scale)
    # hinge torques: every hinge but the locked ones carries the same torque
    torque = ne.inverse_dynamics(full, psi, dpsi, ddpsi)[:, keep]
    agree(
        dyn.inverse_dynamics(psi_r, dpsi_r, ddpsi_r),
        ne.inverse_dynamics(reduced, psi_r, dpsi_r, ddpsi_r),
        torque,
        "hinge torques",
    )
    # ... and the reduced forward dynamics moves the full tree consistently
    ddpsi_model = np.reshape(dyn.forward_dynamics(psi_r, dpsi_r, torque), (k, reduced.n))
    back = ne.inverse_dynamics(
        full, psi, dpsi, embed(full, reduced, constraints, ddpsi_model, offset=False)
    )[:, keep]
    assert relative_error(back, torque).max() <= 1e-9, scenario
    force = ne.ground_reaction(full, psi, dpsi, ddpsi)[:, None]
    agree(
        dyn.ground_reaction(psi_r, dpsi_r, ddpsi_r)[:, None],
        ne.ground_reaction(reduced, psi_r, dpsi_r, ddpsi_r)[:, None],
        force,
        "ground force",
    )
    # mass matrix: M_reduced = P^T M_full P, P the velocity map of the constraints
    # rows of the identity are reduced velocity vectors: embedding them gives P^T (n_r, n_full)
    velocity_map = embed(full, reduced, constraints, np.eye(reduced.n), offset=False).T
    projected = np.einsum("fr,kfg,gs->krs", velocity_map, ne.mass_matrix(full, psi), velocity_map)
    agree(dyn.mass_matrix(psi_r), ne.mass_matrix(reduced, psi_r), projected, "mass matrix")
    # generalised forces by virtual work: Q_reduced = P^T Q_full (Q_merged = Q_parent +
    # Q_child), with Q = M - sum of the children's M on each side, the locked hinge included
    q_full = generalized_forces(full, ne.inverse_dynamics(full, psi, dpsi, ddpsi))
    agree(
        generalized_forces(
            reduced, np.reshape(dyn.inverse_dynamics(psi_r, dpsi_r, ddpsi_r), psi_r.shape)
        ),
        generalized_forces(reduced, ne.inverse_dynamics(reduced, psi_r, dpsi_r, ddpsi_r)),
        q_full @ velocity_map,
        "generalised forces",
    )
    # geometry: hinges of the kept links, and merged centres of mass
    hinges = ne.hinge_positions(full, psi)[:, [0] + [i + 1 for i in keep]]
    agree(dyn.hinge_positions(psi_r), ne.hinge_positions(reduced, psi_r), hinges, "hinges")
    full_com = ne.com_positions(full, psi)
    merged_com = np.stack(
        [
            sum(full.links[full.index(m)].mass * full_com[:, full.index(m)] for m in group)
            / sum(full.links[full.index(m)].mass for m in group)
            for group in ((link.name, *link.merged) for link in reduced.links)
        ],
        axis=1,
    )
    agree(dyn.com_positions(psi_r), ne.com_positions(reduced, psi_r), merged_com, "com")
    assert compared == 2 * 8 * k


def test_lock_merges_mass_centre_and_inertia():
    six = presets.six_link_anthropoid()
    locked = six.lock("torso", 0.0)
    thigh, torso = six.links[1], six.links[4]
    merged = locked.links[1]
    assert merged.name == "stance_thigh" and merged.merged == ("torso",)
    assert merged.mass == pytest.approx(thigh.mass + torso.mass, rel=1e-15)
    # straight continuation: centre on the axis, at the mass-weighted position
    along = (thigh.mass * thigh.com * 0.43 + torso.mass * (0.43 + torso.com * 0.50)) / merged.mass
    assert merged.com * merged.length == pytest.approx(along, rel=1e-14)
    assert merged.com > 1.0 and merged.com_lateral == 0.0
    inertia = (
        thigh.inertia
        + thigh.mass * (thigh.com * 0.43 - along) ** 2
        + torso.inertia
        + torso.mass * (0.43 + torso.com * 0.5 - along) ** 2
    )
    assert merged.inertia == pytest.approx(inertia, rel=1e-14)
    assert merged.length == thigh.length  # its end hinge stays where the thigh's was
    # the head re-attaches at the torso's end, in the merged body's frame
    head = locked.links[locked.index("head")]
    assert head.parent == "stance_thigh" and head.origin == pytest.approx(0.93 + 0j, rel=1e-15)
    assert not locked.is_paper_form
    # a leaf locked straight keeps the paper's form (the closed form then applies)
    straight = six.lock("head", 0.0)
    assert straight.is_paper_form
    psi = np.random.default_rng(0).uniform(-3, 3, (8, 5))
    error = relative_error(
        Dynamics(straight).mass_matrix(psi), ne.closed_form_mass_matrix(straight, psi)
    )
    assert error.max() <= TOL


def test_lock_at_an_angle_puts_the_centre_off_axis():
    two = Linkage(
        [rod("a", length=1.0, mass=1.0, com=0.5), rod("b", "a", length=1.0, mass=1.0, com=0.5)]
    )
    locked = two.lock("b", math.pi / 2)
    merged = locked.links[0]
    # centres at 0.5 and 1 + 0.5 j: the merged centre is their mean
    assert merged.com_offset == pytest.approx(0.75 + 0.25j, rel=1e-15)
    assert merged.com_lateral == pytest.approx(0.25, rel=1e-15)
    assert merged.merged == ("b",)


def test_lock_twice_records_every_merged_name():
    locked = presets.six_link_anthropoid().lock("swing_shank").lock("swing_thigh")
    assert locked.links[1].merged == ("swing_thigh", "swing_shank")
    assert locked.names == ("stance_shank", "stance_thigh", "torso", "head")


def test_lock_errors():
    six = presets.six_link_anthropoid()
    with pytest.raises(
        DefinitionError, match="`angle`: 'stance_shank' is the root; locking it welds it to the"
    ):
        six.lock("stance_shank")
    with pytest.raises(DefinitionError, match="`name`: no link called 'tail'"):
        six.lock("tail", 0.1)
    with pytest.raises(DefinitionError, match="`angle`: must be finite, got nan"):
        six.lock("head", math.nan)
    with pytest.raises(DefinitionTypeError, match="`angle`: must be a real number, got True"):
        six.lock("head", True)
    with pytest.raises(DefinitionTypeError, match="`angle`: must be a real number, got '0'"):
        six.lock("head", "0")


# ---- the same body in other units -------------------------------------------------------------
def test_the_same_body_in_millimetres_and_grams_moves_with_the_same_physics():
    """The converted linkage, through the Newton-Euler oracle: hinges at 1e3 times the
    distances, mass matrix and torques (g mm^2/s^2) 1e9 times the SI ones, at random states of
    random trees with attachment offsets and lateral centres of mass."""
    rng = np.random.default_rng(21)
    for _ in range(4):
        tree = ne.random_tree(rng, 6, general=True)
        mm = tree.in_units(length=1e3, mass=1e3)
        psi, dpsi, ddpsi = rng.normal(size=(3, tree.n))
        np.testing.assert_allclose(
            ne.hinge_positions(mm, psi), 1e3 * ne.hinge_positions(tree, psi), rtol=1e-12
        )
        M = ne.mass_matrix(tree, psi)  # entries spread over decades: round-off of the largest
        np.testing.assert_allclose(
            ne.mass_matrix(mm, psi), 1e9 * M, rtol=1e-11, atol=1e-12 * 1e9 * np.abs(M).max()
        )
        si = ne.inverse_dynamics(tree, psi, dpsi, ddpsi)
        np.testing.assert_allclose(
            ne.inverse_dynamics(mm, psi, dpsi, ddpsi),
            1e9 * si,
            rtol=1e-10,
            atol=1e-9 * np.abs(si).max(),
        )
    six = presets.six_link_anthropoid()
    assert six.in_units() == six
    with pytest.raises(DefinitionError, match=r"`length`: must be > 0"):
        six.in_units(length=0.0)
    with pytest.raises(DefinitionError, match=r"`mass`: must be > 0"):
        six.in_units(mass=-1.0)


def test_ancestry_turns_relative_angles_into_absolute_ones():
    """psi = A q on the anthropoid on feet (a tree with two branches at the hip): q_i the
    hinge's angle relative to its parent, summed down the path from the root by hand."""
    from model import presets

    linkage = presets.anthropoid_with_feet()
    relative = np.random.default_rng(5).uniform(-1.0, 1.0, linkage.n)
    absolute = np.array([relative[i] + sum(relative[k] for k in linkage.ancestors(i))
                         for i in range(linkage.n)])  # fmt: skip
    np.testing.assert_allclose(linkage.ancestry() @ relative, absolute, rtol=0, atol=1e-15)
    # each column k: link k and its subtree
    for k in range(linkage.n):
        assert tuple(np.flatnonzero(linkage.ancestry()[:, k])) == linkage.subtree(k)


def test_from_parameters_rebuilds_what_parameters_describes():
    """A file's metadata['model'] back into a linkage: the same description, and the same
    mass matrix at a random pose (rerooted feet, an origin, a merged lock)."""
    import json
    from dataclasses import replace

    from model.presets import anthropoid_with_feet, six_link_anthropoid

    locked = six_link_anthropoid().lock("head", 1.2)
    moved = Linkage([replace(six_link_anthropoid().links[0], origin=0.3 - 0.1j),
                     *six_link_anthropoid().links[1:]])  # fmt: skip
    rng = np.random.default_rng(5)
    for linkage in (anthropoid_with_feet(), locked, moved):
        description = json.loads(json.dumps(linkage.parameters()))  # as a file holds it
        rebuilt = Linkage.from_parameters(description)
        assert rebuilt.parameters() == linkage.parameters()
        psi = rng.uniform(-3, 3, linkage.n)
        mass = Dynamics(linkage).function("mass_matrix")
        np.testing.assert_array_equal(
            np.asarray(Dynamics(rebuilt).function("mass_matrix")(psi)), np.asarray(mass(psi))
        )
    with pytest.raises(ValueError, match=r"links'\]\[0\]"):
        Linkage.from_parameters({"links": [{"name": "a"}]})
    with pytest.raises(ValueError, match=r"Linkage\.parameters"):
        Linkage.from_parameters({"gravity": 9.81})
