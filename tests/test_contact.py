"""model.contact: the friction cone written once, checked against its geometry.

Oracle: a force at angle theta from the ground's normal (|F| > 0) is carried by a Coulomb
contact exactly when |theta| <= atan(mu); its margin mu Fy - |Fx| is |F| (mu cos theta -
|sin theta|), a closed form. The same rows as CasADi expressions evaluate to the numpy rows.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from model import Contact, Dynamics, Ground, LinkPoint, presets
from planner import OCP
from planner.errors import DefinitionError, DefinitionTypeError

FOOT = LinkPoint("swing_shank")


@pytest.mark.parametrize("mu", [0.3, 0.8, 1.5])
def test_the_cone_carries_exactly_the_forces_within_atan_mu_of_the_normal(mu):
    contact = Contact(FOOT, friction=mu)
    theta = np.linspace(-math.pi, math.pi, 3601)
    size = 250.0
    fx, fy = size * np.sin(theta), size * np.cos(theta)
    margin = contact.cone_margin(fx, fy)
    np.testing.assert_allclose(
        margin, size * (mu * np.cos(theta) - np.abs(np.sin(theta))), atol=1e-10
    )
    inside = np.abs(theta) <= math.atan(mu)
    away = np.abs(np.abs(theta) - math.atan(mu)) > 1e-9  # not on the boundary itself
    np.testing.assert_array_equal((margin >= 0)[away], inside[away])
    assert contact.cone_half_angle == pytest.approx(math.atan(mu), rel=1e-15)
    # the part of the cone used: |tan theta| / mu, 1 on its boundary
    use = contact.friction_use(fx, fy)
    front = np.abs(theta) < math.pi / 2 - 1e-6
    np.testing.assert_allclose(use[front], np.abs(np.tan(theta[front])) / mu, rtol=1e-12)
    assert np.isnan(contact.friction_use(1.0, 0.0)) and np.isnan(Contact(FOOT).friction_use(1, 2))
    # the rows each: mu Fy - Fx and mu Fy + Fx, along a new first axis
    rows = contact.cone(fx, fy)
    assert rows.shape == (2, theta.size) and contact.cone_rows == ("mu Fy - Fx", "mu Fy + Fx")


def test_casadi_expressions_give_the_numpy_rows():
    contact = Contact(FOOT, friction=0.7)
    force = ca.SX.sym("F", 2)
    rows = ca.Function("cone", [force], [contact.cone(force[0], force[1])])
    rng = np.random.default_rng(7)
    for fx, fy in rng.normal(scale=100.0, size=(20, 2)):
        np.testing.assert_allclose(
            np.asarray(rows([fx, fy])).ravel(), contact.cone(fx, fy), rtol=0, atol=1e-12
        )


def test_without_friction_the_ground_only_pushes():
    contact = Contact(FOOT)
    assert contact.friction is None and contact.cone_rows == ("push",)
    np.testing.assert_array_equal(contact.cone_margin([1e6, -3.0], [2.0, -1.0]), [2.0, -1.0])
    assert contact.cone_half_angle == math.pi / 2
    assert contact.violation(1e6, 0.0) is None


def test_a_violation_says_how():
    contact = Contact(FOOT, friction=0.5)
    assert contact.violation(10.0, 100.0) is None
    assert contact.violation(60.0, 100.0, slack=20.0) is None  # within the slack
    assert contact.violation(60.0, 100.0) == (
        "swing_shank_end slips (|Fx| = 60.0 N > mu Fy = 50.0 N)"
    )
    assert contact.violation(0.0, -5.0, who="the stance foot") == (
        "the stance foot is pulled off the ground (Fy = -5.0 N)"
    )
    assert "N s" in contact.violation(9.0, 1.0, unit="N s")


def test_names_ground_and_bad_input():
    contact = Contact(LinkPoint("stance_shank", along=0.0, name="heel"), 0.8, Ground(0.01))
    assert contact.label == "heel" and Contact(FOOT, name="toe").label == "toe"
    assert float(contact.height_above_ground(0.05)) == pytest.approx(0.04)
    with pytest.raises(DefinitionError, match=r"`friction`: the friction coefficient must be > 0"):
        Contact(FOOT, friction=0.0)
    with pytest.raises(DefinitionTypeError, match=r"`friction`: must be a real number"):
        Contact(FOOT, friction="high")
    with pytest.raises(DefinitionTypeError, match=r"`point`: must be a model.LinkPoint"):
        Contact("swing_shank")
    with pytest.raises(DefinitionTypeError, match=r"`ground`: must be a model.Ground"):
        Contact(FOOT, ground=0.0)
    with pytest.raises(DefinitionTypeError, match=r"`name`: a contact's name"):
        Contact(FOOT, name=" ")
    with pytest.raises(DefinitionTypeError, match=r"`height`: must be a real number"):
        Ground("low")


def test_an_ocp_takes_contacts_as_it_takes_points():
    dynamics = Dynamics(presets.six_link_anthropoid())
    by_contact = OCP(dynamics, T=0.2, N=2, contacts=(Contact(FOOT, friction=0.8),)).system
    by_point = OCP(dynamics, T=0.2, N=2, contacts=(FOOT,)).system
    assert by_contact.control_names == by_point.control_names
    assert by_contact.control_names[-2:] == ("F_swing_shank_end_x", "F_swing_shank_end_y")


def test_the_contact_at_the_root_is_h0_named_as_the_files_name_it():
    six = presets.six_link_anthropoid()
    stance = Contact.at_root(six, 0.8)
    assert (stance.point.link, stance.point.along, stance.point.lateral) == ("stance_shank", 0, 0)
    assert stance.label == "stance_shank_start" and stance.friction == 0.8
    assert (
        stance.ground == Ground() and Contact.at_root(six, ground=Ground(0.1)).ground.height == 0.1
    )
    # H0 is where the root's start hinge is: the origin for any pose
    position = Dynamics(six).point(stance).function("position")
    np.testing.assert_array_equal(np.asarray(position(np.random.default_rng(1).normal(size=6))), 0)


def test_a_named_contacts_forces_carry_its_name_into_controls_and_files(tmp_path):
    """An unnamed contact's forces are named after its point (the files so far); a named
    one after its name, in the OCP's controls and in the trajectory written from a solve."""
    dynamics = Dynamics(presets.n_link_chain(2))
    tip = LinkPoint("link2")
    unnamed = OCP(dynamics, T=0.5, N=6, contacts=(Contact(tip),)).system
    assert unnamed.control_names[-2:] == ("F_link2_end_x", "F_link2_end_y")
    named = Contact(tip, name="front heel")
    assert named.identifier == "front_heel"
    ocp = (
        OCP(dynamics, T=0.5, N=6, contacts=(named,))
        .bound("F", 0.0, 0.0)  # the point hangs free: the forces are held at zero
        .initial(psi=[-1.2, -1.0], dpsi=[0.0, 0.0])
        .minimize(integral=lambda p: ca.sumsqr(p.M))
    )
    assert ocp.system.control_names[-2:] == ("F_front_heel_x", "F_front_heel_y")
    trajectory = ocp.solve(progress=False).to_trajectory()
    assert {"F_front_heel_x", "F_front_heel_y"} <= set(trajectory.extras)
    assert trajectory.extras["F_front_heel_y"][1] == "N"
    path = tmp_path / "plan.csv"
    trajectory.save(path)
    assert "F_front_heel_x [N]" in path.read_text().splitlines()[0]
