"""model.to_mjcf: MuJoCo's own dynamics of the written model against the product's.

MuJoCo is the oracle written by someone else: its recursive inverse dynamics (mj_inverse), its
composite-rigid-body mass matrix (mj_fullM), forward dynamics (mj_forward) and kinematics
(xipos, geom_xpos) on random states of several linkages, fixed and floating. The floating
model's oracle on our side is the Euler-Lagrange equations of the floating energy, formed by
CasADi's automatic differentiation (the product has no floating inverse dynamics to compare).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from model import AnthropoidError, Dynamics, Link, Linkage, presets
from model.mjcf import BASE_JOINTS, to_mjcf
from tests.reference import newton_euler as ne

mujoco = pytest.importorskip("mujoco")

RNG_SEED = 20261124


def _random_general_tree():
    return ne.random_tree(np.random.default_rng(7), 7, span=(0.1, 10.0), general=True)


def _breadth_first_tree():
    # the linkage's order (a, b, c, d) is not the file's depth-first order (a, b, d, c)
    return Linkage(
        [
            Link("a", None, 1.0, 2.0, 0.4, 0.2),
            Link("b", "a", 0.8, 1.5, 0.5, 0.1),
            Link("c", "a", 0.6, 1.0, 0.3, 0.05),
            Link("d", "b", 0.5, 0.7, 0.6, 0.03),
        ]
    )


LINKAGES = {
    "six-link": presets.six_link_anthropoid,
    "five-link": presets.five_link_biped,
    "chain of 8": lambda: presets.n_link_chain(8),
    "exoskeleton leg": presets.exoskeleton_leg,
    "head locked into the torso": lambda: presets.six_link_anthropoid().lock("head", 0.3),
    "random tree, off-axis and offset hinges": _random_general_tree,
    "a tree listed breadth first": _breadth_first_tree,
}


def _compiled(mjcf):
    model = mujoco.MjModel.from_xml_string(mjcf.xml)
    # the equations compared are the free ones: no ground contact may add a force
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return model, mujoco.MjData(model)


def _full_mass_matrix(model, data):
    dense = np.zeros((model.nv, model.nv))
    try:  # mujoco >= 4: (m, d, dst)
        mujoco.mj_fullM(model, data, dense)
    except TypeError:  # mujoco 3: (m, dst, qM)
        mujoco.mj_fullM(model, dense, data.qM)
    return dense


def _random_state(rng, n, floating):
    base = 2 if floating else 0
    q = np.r_[rng.normal(size=base), rng.uniform(-np.pi, np.pi, n)]
    return q, 3.0 * rng.normal(size=n + base), 10.0 * rng.normal(size=n + base)


@pytest.mark.parametrize("name", list(LINKAGES))
def test_inverse_dynamics_and_mass_matrix_are_mujocos_fixed_base(name):
    linkage = LINKAGES[name]()
    dynamics = Dynamics(linkage)
    mjcf = to_mjcf(linkage)
    model, data = _compiled(mjcf)
    assert (model.nq, model.nv, model.nu) == (linkage.n, linkage.n, linkage.n)
    coordinates = mjcf.coordinates  # psi = T q
    # built once and shared by every call (a walker reads it each control period): read-only,
    # so that no caller can change what the next one reads
    assert mjcf.coordinates is coordinates
    with pytest.raises(ValueError, match="read-only"):
        coordinates[0, 0] = 2.0
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(5):
        psi, dpsi, ddpsi = _random_state(rng, linkage.n, floating=False)
        data.qpos[:] = mjcf.qpos(psi)
        data.qvel[:] = mjcf.qvel(dpsi)
        data.qacc[:] = mjcf.qvel(ddpsi)  # the same linear map as the velocities
        mujoco.mj_inverse(model, data)
        ours = dynamics.inverse_dynamics(psi, dpsi, ddpsi)
        scale = np.abs(ours).max()
        # MuJoCo's joint order is the file's (depth first): joint_forces puts ours there
        np.testing.assert_allclose(
            data.qfrc_inverse, mjcf.joint_forces(ours), rtol=0, atol=1e-12 * scale
        )
        mass = coordinates.T @ dynamics.mass_matrix(psi) @ coordinates
        full = _full_mass_matrix(model, data)
        np.testing.assert_allclose(full, mass, rtol=0, atol=1e-12 * np.abs(mass).max())
        # the centres of mass where the model puts them (MuJoCo's x-z plane)
        com = dynamics.com_positions(psi)
        bodies = [model.body(name).id for name in linkage.names]
        np.testing.assert_allclose(data.xipos[bodies, 0], com.real, atol=1e-12 * scale)
        np.testing.assert_allclose(data.xipos[bodies, 2], com.imag, atol=1e-12 * scale)
        np.testing.assert_allclose(data.xipos[bodies, 1], 0.0, atol=1e-14)


def _floating_inverse_dynamics(dynamics):
    """Q = d/dt dL/ddq - dL/dq from the product's floating energy, by CasADi's AD."""
    energy = dynamics.floating.function("floating_energy")
    n = dynamics.floating.n
    q, dq, ddq = (ca.SX.sym(s, n) for s in ("q", "dq", "ddq"))
    kinetic, potential = energy(q, dq)
    lagrangian = kinetic - potential
    momentum = ca.gradient(lagrangian, dq)
    rate = ca.jtimes(momentum, q, dq) + ca.jtimes(momentum, dq, ddq)
    return ca.Function("floating_id", [q, dq, ddq], [rate - ca.gradient(lagrangian, q)])


@pytest.mark.parametrize(
    "name",
    [
        "six-link",
        "five-link",
        "random tree, off-axis and offset hinges",
        "a tree listed breadth first",
    ],
)
def test_inverse_dynamics_and_mass_matrix_are_mujocos_floating_base(name):
    linkage = LINKAGES[name]()
    dynamics = Dynamics(linkage)
    mjcf = to_mjcf(linkage, base="floating")
    model, data = _compiled(mjcf)
    assert (model.nq, model.nu) == (linkage.n + 2, linkage.n - 1)
    assert [model.joint(j).name for j in range(2)] == list(BASE_JOINTS)
    inverse = _floating_inverse_dynamics(dynamics)
    coordinates = mjcf.coordinates  # (x0, y0, psi) = T q
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(5):
        q, dq, ddq = _random_state(rng, linkage.n, floating=True)
        data.qpos[:] = mjcf.qpos(q[2:], q[:2])
        data.qvel[:] = mjcf.qvel(dq[2:], dq[:2])
        data.qacc[:] = mjcf.qvel(ddq[2:], ddq[:2])
        mujoco.mj_inverse(model, data)
        ours = coordinates.T @ np.asarray(inverse(q, dq, ddq)).ravel()
        np.testing.assert_allclose(data.qfrc_inverse, ours, rtol=0, atol=1e-12 * np.abs(ours).max())
        mass = coordinates.T @ dynamics.floating.mass_matrix(q[2:]) @ coordinates
        full = _full_mass_matrix(model, data)
        np.testing.assert_allclose(full, mass, rtol=0, atol=1e-12 * np.abs(mass).max())
        np.testing.assert_allclose(mjcf.model_coordinates(data.qpos), q, atol=1e-15)


def test_the_motors_apply_the_hinge_torques():
    # forward dynamics: ctrl = M gives MuJoCo's qacc = T^-1 ddpsi of the product's model
    linkage = presets.six_link_anthropoid()
    dynamics = Dynamics(linkage)
    mjcf = to_mjcf(linkage, torque_limits=1e4)
    model, data = _compiled(mjcf)
    assert [model.actuator(a).name for a in range(model.nu)] == [f"M_{n}" for n in linkage.names]
    rng = np.random.default_rng(RNG_SEED)
    psi, dpsi, _ = _random_state(rng, linkage.n, floating=False)
    torques = 50.0 * rng.normal(size=linkage.n)
    data.qpos[:] = mjcf.qpos(psi)
    data.qvel[:] = mjcf.qvel(dpsi)
    data.ctrl[:] = torques
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.qfrc_actuator, mjcf.joint_forces(torques), atol=1e-12)
    ddpsi = dynamics.forward_dynamics(psi, dpsi, torques)
    np.testing.assert_allclose(mjcf.model_coordinates(data.qacc), ddpsi, rtol=1e-10, atol=1e-9)


def test_contacts_sit_at_the_link_ends_and_touch_a_plane_at_y_0():
    linkage = presets.six_link_anthropoid()
    dynamics = Dynamics(linkage)
    radius = 0.01
    mjcf = to_mjcf(
        linkage,
        base="floating",
        contacts=[("stance_shank", "start"), ("swing_shank", "end")],
        contact_radius=radius,
        friction=0.7,
    )
    model = mujoco.MjModel.from_xml_string(mjcf.xml)
    data = mujoco.MjData(model)
    psi = np.array([1.4, 1.7, -1.6, -1.9, 1.5, 1.6])
    base = np.array([0.2, 0.0])
    data.qpos[:] = mjcf.qpos(psi, base)
    mujoco.mj_forward(model, data)
    hinges = dynamics.hinge_positions(psi) + complex(*base)
    feet = {"stance_shank_start": hinges[0], "swing_shank_end": hinges[4]}
    for name, point in feet.items():
        geom = model.geom(name)
        np.testing.assert_allclose(data.geom_xpos[geom.id], [point.real, 0, point.imag], atol=1e-14)
        assert geom.size[0] == radius and geom.friction[0] == 0.7
    ground = model.geom("ground")
    assert data.geom_xpos[ground.id][2] == -radius
    # the stance foot at y = 0 touches the plane (distance 0), the lifted swing foot does not
    assert data.ncon == 1
    assert model.geom(data.contact[0].geom[1]).name == "stance_shank_start"
    assert abs(data.contact[0].dist) < 1e-12
    # only the contact spheres collide: the links' capsules are drawings
    capsules = [g for g in range(model.ngeom) if model.geom(g).name.endswith("_capsule")]
    assert all(model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0 for g in capsules)


def test_the_coordinates_map_both_ways():
    linkage = _random_general_tree()
    mjcf = to_mjcf(linkage, base="floating")
    rng = np.random.default_rng(RNG_SEED)
    psi = rng.uniform(-3, 3, (4, linkage.n))
    base = rng.normal(size=(4, 2))
    q = mjcf.qpos(psi, base)
    assert q.shape == (4, linkage.n + 2)
    np.testing.assert_allclose(mjcf.model_coordinates(q), np.hstack([base, psi]), atol=1e-15)
    # a child's MuJoCo angle is relative to its parent
    parent = linkage.parents[3]
    np.testing.assert_allclose(q[:, 2 + 3], psi[:, 3] - psi[:, parent])


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"base": "free"}, r"`base`: 'fixed' .* got 'free'"),
        ({"contacts": [("foot", "end")]}, r"`contacts\[0\]`: no link named 'foot'"),
        ({"contacts": [("head", "tip")]}, r"`contacts\[0\]`: the end must be 'start' or 'end'"),
        ({"contacts": ["head"]}, r"`contacts\[0\]`: must be a \(link name"),
        ({"contact_radius": 0.0}, r"`contact_radius`: must be > 0 m, got 0.0"),
        ({"friction": -1}, r"`friction`: must be > 0"),
        (
            {"base": "floating", "torque_limits": {"stance_shank": 100.0}},
            r"`torque_limits`: 'stance_shank' is not an actuated hinge",
        ),
        ({"torque_limits": -5.0}, r"`torque_limits`: must be > 0 N m, got -5.0"),
    ],
)
def test_bad_input_is_named(kwargs, message):
    # DefinitionError for a wrong value, DefinitionTypeError for a wrong type: both are ours
    with pytest.raises(AnthropoidError, match=message):
        to_mjcf(presets.six_link_anthropoid(), **kwargs)


def test_torque_limits_become_control_ranges():
    linkage = presets.six_link_anthropoid()
    mjcf = to_mjcf(linkage, base="floating", torque_limits={"torso": 150.0, "head": 20.0})
    model = mujoco.MjModel.from_xml_string(mjcf.xml)
    assert mjcf.actuated == linkage.names[1:]
    torso, head = model.actuator("M_torso"), model.actuator("M_head")
    assert list(torso.ctrlrange) == [-150.0, 150.0] and list(head.ctrlrange) == [-20.0, 20.0]
    assert not model.actuator("M_stance_thigh").ctrllimited


def test_feet_are_soles_at_the_ankles_flat_when_asked():
    linkage = presets.six_link_anthropoid()
    dynamics = Dynamics(linkage)
    feet = [("stance_shank", "start", 0.05, 0.15), ("swing_shank", "end", 0.05, 0.15)]
    mjcf = to_mjcf(linkage, base="floating", feet=feet, foot_mass=0.05)
    model = mujoco.MjModel.from_xml_string(mjcf.xml)
    data = mujoco.MjData(model)
    assert model.nq == mjcf.nq == linkage.n + 2 + 2
    assert [model.actuator(a).name for a in range(model.nu)][-2:] == [
        "M_ankle_stance_shank",
        "M_ankle_swing_shank",
    ]
    psi = np.array([1.4, 1.7, -1.6, -1.9, 1.5, 1.6])
    base = np.array([0.3, 0.0])
    angles = np.array([0.0, 0.2])  # the stance foot flat, the swing foot toe up
    data.qpos[:] = mjcf.qpos(psi, base, angles)
    mujoco.mj_forward(model, data)
    ankles = dynamics.hinge_positions(psi)[[0, 4]] + complex(*base)
    for (link, _, heel, toe), ankle, angle in zip(feet, ankles, angles, strict=True):
        for part, along in (("heel", -heel), ("toe", toe)):
            point = ankle + along * np.exp(1j * angle)
            got = data.geom_xpos[model.geom(f"{link}_{part}").id]
            np.testing.assert_allclose(got, [point.real, 0.0, point.imag], atol=1e-14)
    np.testing.assert_allclose(mjcf.feet_angles(data.qpos), angles, atol=1e-15)
    np.testing.assert_allclose(mjcf.model_coordinates(data.qpos), np.r_[base, psi], atol=1e-15)
    # the feet weigh what they were given; the links what the model says
    assert model.body_mass[model.body("foot_stance_shank").id] == 0.05
    assert sum(model.body_mass) == pytest.approx(sum(l.mass for l in linkage.links) + 0.1)
