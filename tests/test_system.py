"""planner.System: a model reaches the planner only through a System that carries its naming.

A pendulum written here as a new adapter (its own names, groups, derived field, guess order,
guess completion, residual rows and roles; no linkage anywhere) is given to the OCP directly
and goes through guessing, transcription, solving, the Solution's views and the export.
Independent checks: the inverse dynamics tau = m l^2 alpha + m g l sin(theta) and the forward
dynamics written again in numpy; the closed-form law of the guess.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from planner import OCP, System
from planner.errors import DefinitionError, DefinitionTypeError
from planner.system import DerivedField
from planner.trajectory import Trajectory

MASS, LENGTH, G = 2.0, 0.7, 9.81
INERTIA = MASS * LENGTH**2
NAMES = ["x", "z", "u", "t"]


def pendulum(formulation: str = "explicit", **changes) -> System:
    """theta'' = (tau - m g l sin theta) / (m l^2): states theta [rad], omega [rad/s], the
    drive tau [N m]; alpha = theta'' an auxiliary variable (implicit, with the residual
    m l^2 alpha + m g l sin theta - tau) or a derived field (explicit)."""
    x, u, t = ca.SX.sym("x", 2), ca.SX.sym("u", 1), ca.SX.sym("t")
    implicit = formulation == "implicit"
    z = ca.SX.sym("z", 1 if implicit else 0)
    alpha = (u[0] - MASS * G * LENGTH * ca.sin(x[0])) / INERTIA
    rate = ca.vertcat(x[1], z[0] if implicit else alpha)
    residual = None
    derived = ()
    if implicit:
        residual = ca.Function(
            "r",
            [x, z, u, t],
            [INERTIA * z[0] + MASS * G * LENGTH * ca.sin(x[0]) - u[0]],
            NAMES,
            ["r"],
        )
    else:
        derived = (
            DerivedField(
                "alpha", ("alpha",), ("rad/s^2",), ca.Function("a", [x, z, u, t], [alpha])
            ),
        )

    def inverse_dynamics(values):
        if not all(k in values for k in ("theta", "alpha")):
            return {}
        return {"tau": INERTIA * values["alpha"] + MASS * G * LENGTH * np.sin(values["theta"])}

    fields = dict(
        rate=ca.Function("rate", [x, z, u, t], [rate], NAMES, ["xdot"]),
        residual=residual,
        ode=ca.Function("ode", [x, u, t], [ca.vertcat(x[1], alpha)], ["x", "u", "t"], ["xdot"]),
        state_names=("theta", "omega"),
        state_units=("rad", "rad/s"),
        control_names=("tau",),
        control_units=("N m",),
        aux_names=("alpha",) if implicit else (),
        aux_units=("rad/s^2",) if implicit else (),
        groups=(
            ("angle", ("theta",)),
            ("rate", ("omega",)),
            ("drive", ("tau",)),
            ("x", ("theta", "omega")),
            ("u", ("tau",)),
            *((("alpha", ("alpha",)), ("z", ("alpha",))) if implicit else ()),
        ),
        residual_scale_group="drive",
        formulation=formulation,
        derived=derived,
        control_rate_names=("dtau",),
        control_rate_groups=("du",),
        residual_names=("pendulum",) if implicit else (),
        guess_order=("angle", "rate", "alpha"),
        complete_guess=inverse_dynamics,
        drives="drive",
        accelerations="alpha",
        model={"pendulum": {"mass": MASS, "length": LENGTH}},
    )
    fields.update(changes)
    return System(**fields)


def law(t):
    """theta = 0.4 sin(2 t) and its derivatives (rad, rad/s, rad/s^2)."""
    return 0.4 * np.sin(2 * t), 0.8 * np.cos(2 * t), -1.6 * np.sin(2 * t)


@pytest.mark.parametrize("formulation", ["explicit", "implicit"])
def test_a_new_adapter_goes_through_the_planner(formulation):
    system = pendulum(formulation)
    ocp = (
        OCP(system, T=1.5, N=20)
        .bound("drive", -30, 30)
        .initial(theta=0.0, omega=0.8)
        .final(theta=0.5, omega=0.0)
        .minimize(integral=lambda p: p.tau**2 + 0.1 * p.alpha**2)
        .guess(law)
    )
    transcription = ocp.transcribe()
    # the guess: the tuple read in the system's order, the drive completed by its rule
    values = transcription.unpack(transcription.initial_guess())
    times = transcription.mesh.s_dyn * 1.5
    theta, _, alpha = law(times)
    np.testing.assert_allclose(
        values["U"][:, 0], INERTIA * alpha + MASS * G * LENGTH * np.sin(theta), atol=1e-12
    )
    if formulation == "implicit":
        assert "dynamics[pendulum] node 3" in transcription.g_names
    solution = ocp.solve(progress=False, options={"tol": 1e-10})
    assert solution.success
    # the views read the system's roles: drives and accelerations, checked against numpy
    np.testing.assert_array_equal(solution.drives, solution.controls)
    states, torques = solution.states, solution.drives[:, 0]
    expected = (torques - MASS * G * LENGTH * np.sin(states[:, 0])) / INERTIA
    tolerance = 1e-9 if formulation == "explicit" else 1e-6  # implicit: the NLP's own alpha
    np.testing.assert_allclose(solution.accelerations[:, 0], expected, atol=tolerance)
    # the export: its names and units, the drives as controls, alpha as a derived channel
    trajectory = solution.to_trajectory(rate_hz=50.0)
    assert trajectory.state_names == ("theta", "omega")
    assert trajectory.control_names == ("tau",) and trajectory.control_units == ("N m",)
    assert dict(trajectory.extras)["alpha"][1] == "rad/s^2"
    assert trajectory.metadata["model"] == {"pendulum": {"mass": MASS, "length": LENGTH}}
    assert type(trajectory) is Trajectory  # the generic samples: no linkage views
    # and a warm start from the other formulation carries alpha through the guess
    other = "implicit" if formulation == "explicit" else "explicit"
    again = (
        OCP(pendulum(other), T=1.5, N=20)
        .bound("drive", -30, 30)
        .initial(theta=0.0, omega=0.8)
        .final(theta=0.5, omega=0.0)
        .minimize(integral=lambda p: p.tau**2 + 0.1 * p.alpha**2)
        .guess(solution)
        .solve(progress=False, options={"tol": 1e-10})
    )
    assert abs(again.cost - solution.cost) < 1e-3 * solution.cost


def test_a_system_is_checked_where_it_is_built_and_given():
    with pytest.raises(DefinitionError, match=r"`drives`: 'torque' is neither a group nor a"):
        pendulum(drives="torque")
    with pytest.raises(DefinitionError, match=r"`accelerations`: 'ddtheta' is neither a group"):
        pendulum(accelerations="ddtheta")
    with pytest.raises(DefinitionError, match=r"`residual_names`: the residual has 1 rows, got 0"):
        pendulum("implicit", residual_names=())
    with pytest.raises(DefinitionError, match=r"`formulation`: the System given is explicit"):
        OCP(pendulum(), T=1.0, N=4, formulation="implicit")
    with pytest.raises(DefinitionError, match=r"`state_names`: a System names its own variables"):
        OCP(pendulum(), T=1.0, N=4, state_names=("a", "b"))
    system = pendulum()
    ocp = OCP(system, T=1.0, N=4)
    assert ocp.system is system and ocp.formulation == "explicit"


def test_a_model_that_is_no_system_source_or_gives_no_system_is_refused():
    # the planner takes a model through its as_system; a wrong one is named at definition time
    class Broken:
        default_formulation = "implicit"

        def as_system(self, formulation, contacts=()):
            return "not a System"

    with pytest.raises(DefinitionTypeError, match=r"`dynamics`: Broken.as_system must return a "):
        OCP(Broken(), T=1.0, N=4)
    with pytest.raises(DefinitionError, match=r"`contacts`: contact forces need a model that "):
        OCP(pendulum("explicit"), T=1.0, N=4, contacts=("link",))
