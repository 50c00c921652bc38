"""Points fixed on links (model.points) against independent references.

* ``reference.newton_euler``: hinge positions (along = 1) and rigid-body point kinematics from
  the start hinge (a = a_start + ddpsi e_z x r - dpsi^2 r), real 2-vectors in numpy;
* finite differences in time along smooth motions (fourth-order central differences), for
  velocities from positions and accelerations from velocities (relative 1e-8);
* finite differences in psi for the Jacobian, and J dq = the point's velocity.
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np
import pytest
from reference import newton_euler as ne

from model import (
    POINT_FUNCTIONS,
    DefinitionError,
    DefinitionTypeError,
    Dynamics,
    LinkPoint,
    presets,
)

SIX = presets.six_link_anthropoid()
TREES = [(seed, n, general) for seed, n in enumerate((2, 5, 8, 12)) for general in (False, True)]


@functools.cache
def tree(seed: int, n: int, general: bool):
    return ne.random_tree(np.random.default_rng(300 + seed), n, general=general)


def states(linkage, count, seed):
    rng = np.random.default_rng(seed)
    n = linkage.n
    return (
        rng.uniform(-np.pi, np.pi, (count, n)),
        rng.normal(0.0, 2.0, (count, n)),
        rng.normal(0.0, 10.0, (count, n)),
    )


def scenes():
    yield "six-link", SIX
    for seed, n, general in TREES:
        yield f"tree{seed}-{n}{'-general' if general else ''}", tree(seed, n, general)


def relative(actual, reference):
    actual, reference = np.asarray(actual), np.asarray(reference)
    scale = np.max(np.abs(reference)) + 1e-30
    return np.max(np.abs(actual - reference)) / scale


@pytest.mark.parametrize(("label", "linkage"), list(scenes()), ids=[s[0] for s in scenes()])
def test_end_points_are_the_oracle_hinges(label, linkage, check):
    dyn = Dynamics(linkage)
    psi, _, _ = states(linkage, 64, 1)
    hinges = ne.hinge_positions(linkage, psi)
    for i, name in enumerate(linkage.names):
        check.close(dyn.point(name).position(psi), hinges[:, i + 1], f"{label} {name} end")


@pytest.mark.parametrize(("label", "linkage"), list(scenes()), ids=[s[0] for s in scenes()])
def test_offset_points_match_rigid_body_kinematics(label, linkage, check):
    dyn = Dynamics(linkage)
    psi, dpsi, ddpsi = states(linkage, 64, 2)
    rng = np.random.default_rng(3)
    for i, name in enumerate(linkage.names):
        along, lateral = rng.uniform(-0.5, 1.5), rng.uniform(-0.5, 0.5)
        point = dyn.point(name, along, lateral)
        offset = linkage.links[i].length * complex(along, lateral)
        position, velocity, acceleration = ne.point_kinematics(linkage, i, offset, psi, dpsi, ddpsi)
        check.close(point.position(psi), position, f"{label} {name} position")
        check.close(point.velocity(psi, dpsi), velocity, f"{label} {name} velocity")
        check.close(
            point.acceleration(psi, dpsi, ddpsi), acceleration, f"{label} {name} acceleration"
        )


def motion(t, n):
    """A smooth motion: psi(t), dpsi(t) (K, n) with distinct frequencies per link."""
    k = np.arange(1, n + 1)
    psi = 0.7 * np.sin(1.3 * k * t[:, None] + k) + 0.2 * k
    dpsi = 0.7 * 1.3 * k * np.cos(1.3 * k * t[:, None] + k)
    ddpsi = -0.7 * (1.3 * k) ** 2 * np.sin(1.3 * k * t[:, None] + k)
    return psi, dpsi, ddpsi


def central_difference(f, t, h):
    """Fourth-order central difference of f(t) (K,) complex: error ~ h^4 f^(5) / 30."""
    return (-f(t + 2 * h) + 8 * f(t + h) - 8 * f(t - h) + f(t - 2 * h)) / (12 * h)


@pytest.mark.parametrize(("along", "lateral"), [(1.0, 0.0), (0.3, 0.1), (1.2, -0.25)])
def test_rates_are_time_derivatives_of_the_position(along, lateral):
    dyn = Dynamics(SIX)
    point = dyn.point("swing_shank", along, lateral)
    n = SIX.n
    t = np.linspace(0.0, 2.0, 41)
    h = 1e-3

    def position(times):
        return point.position(motion(times, n)[0])

    def velocity(times):
        psi, dpsi, _ = motion(times, n)
        return point.velocity(psi, dpsi)

    psi, dpsi, ddpsi = motion(t, n)
    fd_velocity = central_difference(position, t, h)
    fd_acceleration = central_difference(velocity, t, h)
    assert relative(point.velocity(psi, dpsi), fd_velocity) < 1e-8
    assert relative(point.acceleration(psi, dpsi, ddpsi), fd_acceleration) < 1e-8


@pytest.mark.parametrize(("label", "linkage"), list(scenes()), ids=[s[0] for s in scenes()])
def test_jacobian_against_finite_differences_and_velocity(label, linkage, check):
    dyn = Dynamics(linkage)
    n = linkage.n
    psi, dpsi, _ = states(linkage, 16, 4)
    rng = np.random.default_rng(5)
    name = linkage.names[-1]
    point = dyn.point(name, rng.uniform(0, 1), rng.uniform(-0.3, 0.3))
    jacobian = point.jacobian(psi)
    assert jacobian.shape == (16, 2, n + 2)
    np.testing.assert_array_equal(jacobian[:, :, :2], np.broadcast_to(np.eye(2), (16, 2, 2)))
    np.testing.assert_array_equal(point.jacobian(psi, floating=False), jacobian[:, :, 2:])
    # J dq = velocity of the point when the base moves too.
    dbase = rng.normal(size=(16, 2))
    moved = np.einsum("kij,kj->ki", jacobian, np.hstack([dbase, dpsi]))
    expected = point.velocity(psi, dpsi) + dbase[:, 0] + 1j * dbase[:, 1]
    check.close(moved[:, 0] + 1j * moved[:, 1], expected, f"{label} J dq")
    # Central differences of the position in each psi_k (relative to the column's size).
    h = 1e-6
    for k in range(n):
        step = np.zeros(n)
        step[k] = h
        fd = (point.position(psi + step) - point.position(psi - step)) / (2 * h)
        column = jacobian[:, 0, 2 + k] + 1j * jacobian[:, 1, 2 + k]
        # Round-off of the difference: eps |position| / h, the position up to ~100 m here.
        scale = np.abs(point.position(psi)) + np.abs(column)
        assert np.all(np.abs(fd - column) <= 1e-7 * scale), f"{label} column {k}"


def test_jacobian_is_zero_off_the_path():
    dyn = Dynamics(SIX)
    jacobian = dyn.point("head").function("jacobian")
    # head hangs from torso from the stance thigh from the stance shank: the swing leg's
    # angles do not move it, structurally.
    pattern = jacobian.sparsity_out(0)
    columns = {c for _, c in zip(*pattern.get_triplet(), strict=True)}
    swing = {2 + SIX.index("swing_thigh"), 2 + SIX.index("swing_shank")}
    assert columns == set(range(SIX.n + 2)) - swing


def test_functions_are_named_and_generated_once():
    dyn = Dynamics(SIX)
    foot = dyn.point("swing_shank", name="foot")
    assert dyn.point("swing_shank", name="foot") is foot
    for kind, (inputs, outputs, _) in POINT_FUNCTIONS.items():
        f = foot.function(kind)
        assert f.name() == f"point_foot_{kind}"
        assert tuple(f.name_in()) == inputs and tuple(f.name_out()) == outputs
        assert f.is_a("SXFunction")
    assert [b for b in dyn.built if b.startswith("point_foot")] == [
        f"point_foot_{kind}" for kind in POINT_FUNCTIONS
    ]
    # The symbolic form used in OCP expressions: a column [x; y].
    psi = ca.SX.sym("psi", SIX.n)
    column = foot.expression("position", psi)
    assert column.shape == (2, 1)
    value = ca.Function("f", [psi], [column])(np.full(SIX.n, 0.3))
    assert np.allclose(
        np.asarray(value).ravel(),
        [foot.position(np.full(SIX.n, 0.3)).real, foot.position(np.full(SIX.n, 0.3)).imag],
    )


def test_batch_equals_single_states():
    dyn = Dynamics(SIX)
    point = dyn.point("torso", 0.5, 0.1)
    psi, dpsi, ddpsi = states(SIX, 300, 6)  # above the numpy-tape threshold
    batch = point.acceleration(psi, dpsi, ddpsi)
    single = np.array(
        [point.acceleration(a, b, c) for a, b, c in zip(psi, dpsi, ddpsi, strict=True)]
    )
    assert np.max(np.abs(batch - single)) <= 1e-13 * np.max(np.abs(single))
    assert isinstance(point.position(psi[0]), complex)


def test_label_and_link_point_value():
    assert LinkPoint("a").label == "a_end"
    assert LinkPoint("a", 0.5, -0.1).label == "a_at_0.5_-0.1"
    assert LinkPoint("a", name="heel").label == "heel"
    dyn = Dynamics(SIX)
    assert dyn.point(LinkPoint("swing_shank", 1.0, 0.0)) is dyn.point("swing_shank")


def test_bad_points_are_refused():
    dyn = Dynamics(SIX)
    with pytest.raises(DefinitionError, match=r"`link`: no link called 'arm' to carry the point"):
        dyn.point("arm")
    with pytest.raises(DefinitionError, match=r"`along`: must be finite, got nan"):
        dyn.point("torso", along=float("nan"))
    with pytest.raises(DefinitionError, match=r"`lateral`: must be finite, got inf"):
        dyn.point("torso", lateral=float("inf"))
    with pytest.raises(DefinitionTypeError, match=r"`along`: must be a real number, got '1'"):
        dyn.point("torso", along="1")
    with pytest.raises(DefinitionTypeError, match=r"`link`: must be the name of a link"):
        dyn.point(3)
    dyn.point("torso", 0.5, name="shoulder")
    with pytest.raises(DefinitionError, match=r"already has a point called 'shoulder'"):
        dyn.point("torso", 0.6, name="shoulder")
    with pytest.raises(DefinitionError, match=r"`kind`: unknown point function 'jerk'"):
        dyn.point("torso").function("jerk")
    with pytest.raises(DefinitionError, match=r"give either a LinkPoint or link/along"):
        dyn.point(LinkPoint("torso"), along=0.5)


@pytest.mark.parametrize(("label", "linkage"), list(scenes()), ids=[s[0] for s in scenes()])
def test_hinge_moments_do_the_work_of_the_force(label, linkage, check):
    # A force F on the point and the hinge torques standing for it do the same virtual work
    # for every motion: M . w_rel = F . v_P (v_P from the oracle). The joint rates span every
    # direction, so this pins the whole linear map.
    dyn = Dynamics(linkage)
    psi, dpsi, _ = states(linkage, 32, 7)
    rng = np.random.default_rng(8)
    force = rng.normal(0.0, 100.0, (32, 2))
    i = linkage.n - 1
    point = dyn.point(linkage.names[i], 0.7, 0.2)
    moments = point.hinge_moments(psi, force)
    relative = dpsi.copy()
    for c, p in enumerate(linkage.parents):
        if p >= 0:
            relative[:, c] -= dpsi[:, p]
    _, velocity, _ = ne.point_kinematics(
        linkage, i, linkage.links[i].length * complex(0.7, 0.2), psi, dpsi, np.zeros_like(dpsi)
    )
    power = velocity.real * force[:, 0] + velocity.imag * force[:, 1]
    check.close(np.sum(moments * relative, axis=1)[:, None], power[:, None], f"{label} power")
    # Off the path to the point, no moment.
    off = [k for k in range(linkage.n) if k not in (*linkage.ancestors(i), i)]
    np.testing.assert_array_equal(moments[:, off], 0.0)


@pytest.mark.parametrize(("label", "linkage"), list(scenes()), ids=[s[0] for s in scenes()])
def test_held_dynamics_hold_the_point_and_obey_the_oracles_equations(label, linkage, check):
    # A closed chain (the point held at rest, e.g. a second foot on the ground): the oracle's
    # kinematics give the point no acceleration, and the oracle's inverse dynamics need the
    # applied torques plus those that stand for the holding force (validated above).
    dyn = Dynamics(linkage)
    psi, dpsi, _ = states(linkage, 16, 9)
    torques = np.random.default_rng(10).normal(0.0, 20.0, (16, linkage.n))
    i = linkage.n - 1
    point = dyn.point(linkage.names[i], 0.7, 0.2)
    ddpsi, force = point.held_dynamics(psi, dpsi, torques)
    _, _, acceleration = ne.point_kinematics(
        linkage, i, linkage.links[i].length * complex(0.7, 0.2), psi, dpsi, ddpsi
    )
    # against the acceleration the same state would have with no angular acceleration
    scale = np.abs(ne.point_kinematics(linkage, i, linkage.links[i].length * complex(0.7, 0.2),
                                       psi, dpsi, np.zeros_like(ddpsi))[2]).max()  # fmt: skip
    assert np.abs(acceleration).max() < 1e-10 * scale, f"{label}: the point accelerates"
    check.close(
        ne.inverse_dynamics(linkage, psi, dpsi, ddpsi),
        torques + point.hinge_moments(psi, force),
        f"{label} equations",
    )


def test_a_held_chain_keeps_its_energy_and_its_point():
    # No torques, the end of the six-link's last link held: the holding force does no work
    # (its point does not move), so the energy stays; RK4's error is fourth order.
    dyn = Dynamics(SIX)
    point = dyn.point(SIX.names[-1])
    n = SIX.n
    psi = np.array([1.4, 1.9, 1.5, 1.6, 1.2, 0.9])
    # a velocity that leaves the point at rest: the Jacobian's null space
    jacobian = point.jacobian(psi, floating=False)
    null = np.linalg.svd(jacobian)[2][2:].T
    dpsi = null @ np.linspace(0.5, -0.5, n - 2)
    function = point.function("held_dynamics")

    def rate(x):
        return np.r_[x[n:], np.asarray(function(x[:n], x[n:], np.zeros(n))[0]).ravel()]

    def run(h, duration=0.2):
        x = np.r_[psi, dpsi]
        for _ in range(round(duration / h)):
            k1 = rate(x)
            k2 = rate(x + 0.5 * h * k1)
            k3 = rate(x + 0.5 * h * k2)
            k4 = rate(x + h * k3)
            x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        return x

    def energy(x):
        return sum(ne.energy(SIX, x[:n], x[n:]))

    start = energy(np.r_[psi, dpsi])
    drift = [abs(energy(run(h)) - start) for h in (4e-3, 2e-3)]
    assert drift[1] < 1e-6 * abs(start) + 1e-9
    assert drift[0] / drift[1] > 10.0  # fourth order: 16 at this resolution
    end = run(2e-3)
    assert abs(point.position(end[:n]) - point.position(psi)) < 1e-8
