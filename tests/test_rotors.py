"""model.Rotor: a geared motor's reflected inertia in the equations of motion (issue #36, part 4).

Oracles: a two-link arm with a geared motor at each hinge derived by hand (shoulder motor on
the ground turning the upper arm, elbow motor on the upper arm turning the forearm: mass
matrix, hinge torques, kinetic energy; the motor's torque and electrical power at one
operating point); the mass matrix as the Hessian of the kinetic energy in the rates (CasADi's
derivative of T, not the assembled matrix); energy conservation of the unforced motion
(RK4); the verifier's Euler-law inverse dynamics and angular momentum (written in numpy from
the rotors' rate vectors) against the model's Lagrange equations.
"""

import math
import re

import casadi as ca
import numpy as np
import pytest

from model import Dynamics, Link, Linkage, Rotor, presets
from planner.errors import DefinitionError, DefinitionTypeError

L1, L2, M1, M2, N1_COM, N2_COM, JL1, JL2 = 0.4, 0.35, 2.0, 1.5, 0.45, 0.4, 0.03, 0.02
RATIO1, RATIO2, JR1, JR2 = 100.0, 60.0, 2e-5, 1.5e-5
G = 9.81


def _arm(rotors=True):
    links = [Link("upper", None, L1, M1, N1_COM, JL1), Link("fore", "upper", L2, M2, N2_COM, JL2)]
    arm = Linkage(links, G)
    spinning = [Rotor(None, "upper", RATIO1, JR1, "shoulder"),
                Rotor("upper", "fore", RATIO2, JR2, "elbow")]  # fmt: skip
    return Dynamics(arm, rotors=spinning if rotors else ())


def _by_hand(psi, dpsi, ddpsi):
    """The arm's mass matrix and hinge torques, Lagrange by hand.

    Rotor rates: shoulder N1 dpsi1 (stator the ground), elbow dpsi1 + N2 (dpsi2 - dpsi1)
    (stator the upper arm): T_r = 1/2 JR1 N1^2 dpsi1^2 + 1/2 JR2 ((1 - N2) dpsi1 +
    N2 dpsi2)^2. Links: I1 = J1 + m1 c1^2 + m2 l1^2 about the shoulder, c = n l;
    coupling m2 l1 c2 cos(psi2 - psi1); I2 = J2 + m2 c2^2."""
    c1, c2 = N1_COM * L1, N2_COM * L2
    cos, sin = math.cos(psi[1] - psi[0]), math.sin(psi[1] - psi[0])
    m11 = JL1 + M1 * c1**2 + M2 * L1**2 + JR1 * RATIO1**2 + JR2 * (1 - RATIO2) ** 2
    m12 = M2 * L1 * c2 * cos + JR2 * RATIO2 * (1 - RATIO2)
    m22 = JL2 + M2 * c2**2 + JR2 * RATIO2**2
    mass = np.array([[m11, m12], [m12, m22]])
    bias = np.array([
        -M2 * L1 * c2 * sin * dpsi[1] ** 2 + G * (M1 * c1 + M2 * L1) * math.cos(psi[0]),
        M2 * L1 * c2 * sin * dpsi[0] ** 2 + G * M2 * c2 * math.cos(psi[1]),
    ])  # fmt: skip
    generalized = mass @ ddpsi + bias  # Q1 = M1 - M2, Q2 = M2
    return mass, np.array([generalized[0] + generalized[1], generalized[1]])


def test_a_two_link_arm_with_geared_motors_matches_the_hand_derivation():
    dynamics = _arm()
    rng = np.random.default_rng(7)
    for _ in range(5):
        psi, dpsi, ddpsi = rng.normal(size=2), rng.normal(size=2) * 3, rng.normal(size=2) * 20
        mass, torques = _by_hand(psi, dpsi, ddpsi)
        np.testing.assert_allclose(dynamics.mass_matrix(psi), mass, rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(dynamics.inverse_dynamics(psi, dpsi, ddpsi), torques,
                                   rtol=1e-12, atol=1e-11)  # fmt: skip
        kinetic, _ = dynamics.energy(psi, dpsi)
        assert kinetic == pytest.approx(0.5 * dpsi @ mass @ dpsi, rel=1e-13)
        # the rotors are felt: J N^2 = 0.2 kg m^2 at the shoulder against the arm's 0.4
        bare = _arm(rotors=False).mass_matrix(psi)
        assert mass[0, 0] - bare[0, 0] == pytest.approx(JR1 * RATIO1**2 + JR2 * (1 - RATIO2) ** 2)


def test_the_elbow_motors_torque_and_electrical_power_by_hand():
    """The elbow's hinge torque of the model with rotors is N tau_m (ideal gear): what
    accelerates the rotor included. At psi = (0.3, 1.1), dpsi = (1, -2), ddpsi = (4, 10):
    the rotor accelerates at 4 + 60 (10 - 4) = 364 rad/s^2, the gear gives the forearm
    tau_out = M2 - N J a_r, and through 80 % (driving) the motor needs J a_r + tau_out /
    (N eta); electrical power R i^2 + tau_m N dq, dq = -3 rad/s."""
    from problems.drives.catalogue import Drive, Gearbox, Motor

    psi, dpsi, ddpsi = np.array([0.3, 1.1]), np.array([1.0, -2.0]), np.array([4.0, 10.0])
    _, torques = _by_hand(psi, dpsi, ddpsi)
    rotor_acceleration = ddpsi[0] + RATIO2 * (ddpsi[1] - ddpsi[0])
    assert rotor_acceleration == 364.0
    tau_out = torques[1] - RATIO2 * JR2 * rotor_acceleration
    dq = dpsi[1] - dpsi[0]
    motor = Motor("m", 0.05, 0.8, JR2, 0.5, 2.0, 48.0, 1000.0, 0.3)
    drive = Drive(motor, Gearbox("g", RATIO2, 0.8, 0.0, 30.0, 60.0, 1000.0, 0.2))
    side = drive.motor_side(tau_out, dq, rotor_acceleration)
    driving = tau_out * dq >= 0
    expected = JR2 * 364.0 + (tau_out / (RATIO2 * 0.8) if driving else tau_out * 0.8 / RATIO2)
    assert side["torque"] == pytest.approx(expected, rel=1e-14)
    current = expected / 0.05
    assert side["power"] == pytest.approx(0.8 * current**2 + expected * RATIO2 * dq, rel=1e-13)
    # with a lossless gear the motor's torque is the hinge torque over N, exactly
    ideal = Drive(motor, Gearbox("g", RATIO2, 1.0, 0.0, 30.0, 60.0, 1000.0, 0.2))
    assert ideal.motor_side(tau_out, dq, rotor_acceleration)["torque"] == pytest.approx(
        torques[1] / RATIO2, rel=1e-13
    )


def _walker_rotors():
    return [Rotor("torso", "swing_thigh", 50.0, 1e-4, "swing hip"),
            Rotor("torso", "stance_thigh", 50.0, 1e-4, "stance hip"),
            Rotor("stance_shank", None, 80.0, 5e-5, "ankle"),
            Rotor("stance_thigh", "stance_shank", 60.0, 3e-5, "knee"),
            Rotor("torso", "head", -30.0, 2e-5, "neck, reversing")]  # fmt: skip


def test_the_mass_matrix_is_the_kinetic_energys_hessian_and_energy_is_conserved():
    """Rotors between branches (the swing hip's: torso and swing thigh hang from the stance
    thigh) and a reversing gear included."""
    linkage = presets.six_link_anthropoid()
    dynamics = Dynamics(Linkage(linkage.links, 0.0), rotors=_walker_rotors())
    symbols = dynamics.symbols
    psi, dpsi = symbols["psi"], symbols["dpsi"]
    kinetic = dynamics.function("energy")(psi, dpsi)[0]
    hessian = ca.Function("h", [psi], [ca.hessian(kinetic, dpsi)[0]])
    rng = np.random.default_rng(2)
    point = rng.normal(size=6)
    np.testing.assert_allclose(np.array(hessian(point)), dynamics.mass_matrix(point), atol=1e-12)
    # unforced, no gravity: the kinetic energy stays (RK4, h = 1e-4 s over 0.2 s)
    x = np.concatenate([point, rng.normal(size=6)])
    zero = np.zeros(6)

    def rate(x):
        return np.concatenate([x[6:], dynamics.forward_dynamics(x[:6], x[6:], zero)])

    start = dynamics.energy(x[:6], x[6:])[0]
    h = 1e-4
    for _ in range(2000):
        k1 = rate(x)
        k2 = rate(x + h / 2 * k1)
        k3 = rate(x + h / 2 * k2)
        k4 = rate(x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    assert dynamics.energy(x[:6], x[6:])[0] == pytest.approx(start, rel=1e-9)


def test_the_verifiers_euler_law_counts_the_rotors_like_the_lagrange_equations():
    from problems.gait.verification import _Kinematics

    linkage = presets.six_link_anthropoid()
    rotors = _walker_rotors()
    dynamics = Dynamics(linkage, rotors=rotors)
    oracle = _Kinematics(linkage, [r.to_dict() for r in rotors])
    bare = _Kinematics(linkage)
    rng = np.random.default_rng(5)
    psi, dpsi, ddpsi = (rng.normal(size=(6, 6)) * s for s in (1.0, 3.0, 30.0))
    expected = dynamics.inverse_dynamics(psi, dpsi, ddpsi)
    np.testing.assert_allclose(oracle.inverse_dynamics(psi, dpsi, ddpsi), expected, atol=1e-10)
    assert np.max(np.abs(bare.inverse_dynamics(psi, dpsi, ddpsi) - expected)) > 1.0
    # the whole body's angular momentum about a hinge: p = M dpsi summed with the lever rows;
    # about H0 with the root pinned, the momentum conjugate to psi summed over every link
    momentum = dynamics.mass_matrix(psi[0]) @ dpsi[0]
    whole = oracle.angular_momentum(psi[0], dpsi[0], 0j, 0j, range(6))
    assert whole == pytest.approx(float(np.sum(momentum)), rel=1e-12)


@pytest.mark.parametrize(
    ("rotor", "message"),
    [
        (lambda: Rotor("a", "a", 10.0, 1e-5), "the stator and the driven link are both 'a'"),
        (lambda: Rotor(None, "a", 0.0, 1e-5), "ratio`: must be != 0"),
        (lambda: Rotor(None, "a", 10.0, -1e-5), "inertia`: must be >= 0 kg m^2"),
        (lambda: Rotor(3, "a", 10.0, 1e-5), "stator`: must be a link name"),
    ],
)
def test_a_bad_rotor_is_refused_by_name(rotor, message):
    with pytest.raises((DefinitionError, DefinitionTypeError), match=re.escape(message)):
        rotor()


def test_a_rotor_on_an_unknown_link_is_refused_naming_the_links():
    with pytest.raises(DefinitionError, match="no link 'elbow' in the linkage"):
        Dynamics(presets.six_link_anthropoid(), rotors=[Rotor("torso", "elbow", 10.0, 1e-5)])
    with pytest.raises(DefinitionTypeError, match=r"sequence of model\.Rotor"):
        Dynamics(presets.six_link_anthropoid(), rotors=Rotor("torso", "head", 10.0, 1e-5))
