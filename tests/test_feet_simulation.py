"""The product's own simulation of the walker on feet (problems.control.feet_simulation): the
plan's tree on a floating base, compliant feet, the file's law.

Oracles: the plan's own physics (the floating plant, given the plan's ground reactions as
forces at the heel and ball, reproduces the plan's accelerations and keeps the stance ball at
rest), the conservation of energy and linear momentum in a free flight (kinetic energy summed
link by link from the centres of mass' velocities, not from the mass matrix), a push's
impulse against the change of the body's linear momentum and of its angular momentum about
the pushed point, the contact law's closed forms, the integrator's order against RK4, and
MuJoCo's walk of the same step (its step lengths)."""

from __future__ import annotations

import numpy as np
import pytest

from planner.errors import DefinitionError, DefinitionTypeError
from problems.control.feet_simulation import (
    FOOT_POINTS,
    FeetPlant,
    Ground,
    _step,
    simulate_feet,
    simulate_feet_steps,
)
from problems.control.simulation import Disturbances


def _energy(plant: FeetPlant, z) -> float:
    """Kinetic plus potential energy, J, link by link (z = psi, dpsi, x0, y0, x0', y0')."""
    n = plant.n
    psi, dpsi = z[:n], z[n : 2 * n]
    rate = complex(z[-2], z[-1])
    velocities = plant.dynamics.com_velocities(psi, dpsi) + rate
    heights = plant.dynamics.com_positions(psi).imag + z[-3]
    links = plant.dynamics.linkage.links
    inertias = np.array([link.inertia for link in links])
    kinetic = 0.5 * np.sum(plant.masses * np.abs(velocities) ** 2 + inertias * dpsi**2)
    return float(kinetic + plant.dynamics.linkage.gravity * np.sum(plant.masses * heights))


def _momentum(plant: FeetPlant, z) -> complex:
    n = plant.n
    return complex(np.sum(plant.masses * (plant.dynamics.com_velocities(z[:n], z[n:2 * n])
                                          + complex(z[-2], z[-1]))))  # fmt: skip


def _flight_rate(plant, z):
    n = plant.n
    ddpsi, base = plant.accelerations(z[:n], z[n : 2 * n], np.zeros(n))
    return np.concatenate([z[n : 2 * n], ddpsi, z[-2:], [base.real, base.imag]])


def _rk4(plant, z, h, steps):
    for _ in range(steps):
        k1 = _flight_rate(plant, z)
        k2 = _flight_rate(plant, z + 0.5 * h * k1)
        k3 = _flight_rate(plant, z + 0.5 * h * k2)
        k4 = _flight_rate(plant, z + h * k3)
        z = z + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)
    return z


def _airborne(footed_gait):
    """The plan's first state, lifted 1 m (no foot touches) with the base moving."""
    plant = FeetPlant(footed_gait.problem)
    x = footed_gait.to_trajectory(1000.0)
    z = np.concatenate([x.psi[0], x.dpsi[0], [0.0, 1.0, 0.3, 0.5]])
    return plant, z


def test_with_the_plans_ground_reactions_the_floating_plant_is_the_plan(footed_gait):
    """At samples of the flat foot and of the double support, the plan's torques and its
    ground reactions (the stance foot's torque about the ball as its heel's share, the front
    heel's force) as forces at the points give the plan's accelerations and leave the stance
    ball at rest."""
    step = footed_gait.problem
    n = step.linkage.n
    plant = FeetPlant(step)
    for (solution, _), name in zip(footed_gait.segments(), step.sequence, strict=True):
        if name == "heel rise":
            continue
        x, xdot, u = solution.motion(np.linspace(0.0, solution.T, 6))
        for k in range(x.shape[0]):
            psi, dpsi, ddpsi = x[k, :n], x[k, n:], xdot[k, n:]
            torques = u[k, :n].copy()
            heel = -torques[0] / step.sole  # the flat foot's torque about the ball
            torques[0] = 0.0
            total = complex(step.dynamics.ground_reaction(psi, dpsi, ddpsi))
            front = complex(u[k, n], u[k, n + 1]) if name == "double" else 0j
            forces = dict.fromkeys(FOOT_POINTS, 0j)
            forces["stance_heel"] = complex(0.0, heel)
            forces["stance_toe"] = total - front - forces["stance_heel"]
            forces["swing_heel"] = front
            got, base = plant.accelerations(psi, dpsi, torques,
                                            [forces[p] for p in FOOT_POINTS])  # fmt: skip
            np.testing.assert_allclose(got, ddpsi, rtol=0, atol=1e-9 * (1 + np.abs(ddpsi).max()))
            assert abs(base) < 1e-9


def test_a_free_flight_keeps_its_energy_and_its_momentum_along_the_ground(footed_gait):
    """No drive, no contact: RK4 on the floating plant keeps the energy (summed link by link)
    to 1e-8 of it and the horizontal momentum to round-off; the vertical momentum falls by
    m g t."""
    plant, z = _airborne(footed_gait)
    energy, momentum = _energy(plant, z), _momentum(plant, z)
    after = _rk4(plant, z, 1e-4, 1000)  # 0.1 s
    assert abs(_energy(plant, after) - energy) < 1e-8 * abs(energy)
    change = _momentum(plant, after) - momentum
    assert abs(change.real) < 1e-9
    assert change.imag == pytest.approx(-plant.weight * 0.1, rel=1e-9)


def test_the_semi_implicit_step_is_first_order_in_a_flight(footed_gait):
    """The walk's step (semi-implicit Euler; no contact here, so no damping) against RK4 at a
    100th of its step: the error halves with the step (order 1)."""
    plant, z = _airborne(footed_gait)
    reference = _rk4(plant, z, 1e-5, 2000)  # 0.02 s
    errors = []
    for h in (2e-4, 1e-4):
        state = z.copy()
        for _ in range(round(0.02 / h)):
            state, _ = _step(plant, state, np.zeros(plant.n), [None] * 4, h)
        errors.append(np.max(np.abs(state - reference)))
    assert errors[0] / errors[1] == pytest.approx(2.0, rel=0.1)


def test_a_push_is_its_impulse_through_the_pushed_point(footed_gait):
    """A 10 N s push on the torso's centre of mass (no contact) changes the body's linear
    momentum by 10 N s along x and not its angular momentum about that point."""
    from problems.control.feet_simulation import _Walk

    plant, z = _airborne(footed_gait)
    step = footed_gait.problem
    n = plant.n
    walk = _Walk(plant, z[: 2 * n])
    walk.z = z.copy()
    torso = step.biped.upper_body[0]
    i = plant.dynamics.linkage.index(torso)

    def angular(state):
        psi, dpsi = state[:n], state[n : 2 * n]
        centre = plant.dynamics.com_positions(psi)[i]
        positions = plant.dynamics.com_positions(psi) - centre
        velocities = plant.dynamics.com_velocities(psi, dpsi) + complex(state[-2], state[-1])
        inertias = np.array([link.inertia for link in plant.dynamics.linkage.links])
        return float(np.sum(plant.masses * np.imag(np.conj(positions) * velocities)
                            + inertias * dpsi))  # fmt: skip

    before_l, before_h = _momentum(plant, walk.z), angular(walk.z)
    walk.push(torso, 10.0)
    change = _momentum(plant, walk.z) - before_l
    assert change.real == pytest.approx(10.0, abs=1e-10) and abs(change.imag) < 1e-10
    assert angular(walk.z) == pytest.approx(before_h, abs=1e-10)


def test_the_ground_pushes_holds_and_slides_by_its_closed_forms(footed_gait):
    """A point 1 mm under the ground sinking at 1 cm/s is pushed up by k d + c v; rising fast
    it is not pulled; 1 mm from its anchor at rest it is held by k_t 1 mm; past mu Fy the
    force stays at the cap and the anchor moves to where the spring gives the cap."""
    ground = Ground()
    plant = FeetPlant(footed_gait.problem, ground=ground)
    k, c, kt, ct, mu = (ground.stiffness, ground.damping, ground.tangential_stiffness,
                        ground.tangential_damping, plant.mu)  # fmt: skip
    sink = np.array([-1e-3j, -1e-3j, 1.0 + 0.1j, 0.0 - 1e-3j])
    velocities = np.array([-0.01j, 1.0j, 0j, 0.5 + 0j])
    anchors = [None, None, 0.3, -1e-3]
    forces, after = plant.contact_forces(sink + np.array([0, 0, 0, 0]), velocities, anchors)
    assert forces[0] == pytest.approx(complex(0.0, k * 1e-3 + c * 0.01))
    assert forces[1] == 0j  # rising at 1 m/s: no pull
    assert forces[2] == 0j and after[2] is None  # in the air: its anchor forgotten
    cap = mu * k * 1e-3
    assert forces[3] == pytest.approx(complex(-cap, k * 1e-3))  # slides at the cap
    assert -kt * (0.0 - after[3]) - ct * 0.5 == pytest.approx(-cap)
    held, _ = plant.contact_forces(np.array([1e-3 - 1e-3j]), np.array([0j]), [0.0])
    assert held[0].real == pytest.approx(-kt * 1e-3)


def test_the_step_on_feet_walks_in_the_products_simulation(footed_gait):
    """The default step on feet walks 4 steps under its law in the product's plant, each
    within 1 cm of the plan's length with the angles within 0.1 rad of the plan, 10 %
    heavier too; a push of 40 N s in the second step falls, and the fall is named."""
    plan = simulate_feet(footed_gait, steps=4)
    assert plan.walked == 4 and plan.fell is None
    for record in plan.steps:
        assert abs(record.length - footed_gait.problem.step_length) < 0.01
        assert record.tracking < 0.1
        assert record.slip < 0.01  # MuJoCo: 4 mm
    heavier = simulate_feet(footed_gait, steps=4, disturbances=Disturbances(mass_scale=1.1))
    assert heavier.walked == 4
    pushed = simulate_feet(footed_gait, steps=4, disturbances=Disturbances(push=40.0))
    assert pushed.walked < 4 and pushed.fell.startswith("step ")


def test_bad_inputs_are_refused_by_name(footed_gait):
    with pytest.raises(DefinitionError, match="ground_rise"):
        simulate_feet(footed_gait, steps=1, disturbances=Disturbances(ground_rise=0.01))
    with pytest.raises(DefinitionTypeError, match="gaits"):
        simulate_feet_steps(["a step"])
    with pytest.raises(DefinitionError, match="stiffness"):
        Ground(stiffness=-1.0)
    with pytest.raises(DefinitionError, match="laws"):
        simulate_feet_steps((footed_gait,) * 2, laws=())
    with pytest.raises(DefinitionError, match="stand"):
        simulate_feet(footed_gait, steps=1, stand=0.0)
    with pytest.raises(DefinitionError, match="substeps"):
        simulate_feet(footed_gait, steps=1, substeps=0)
    with pytest.raises(DefinitionError, match="mass_scale"):
        FeetPlant(footed_gait.problem, mass_scale=0.0)
