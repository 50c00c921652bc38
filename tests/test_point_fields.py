"""Point fields that are expressions, not variables: a linkage's ``ddpsi`` in both
formulations (explicit: forward dynamics), and constraints from CasADi Functions with several
outputs (a ground reaction), checked on solutions against the Newton-Euler oracle."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from reference import newton_euler

from model import Dynamics, presets
from planner import OCP

SCHEMES = [("trapezoid", None), ("hermite-simpson", None), ("radau", 3), ("legendre", 3)]
SCHEME_IDS = [name + (str(degree) if degree else "") for name, degree in SCHEMES]
TIGHT = {"tol": 1e-10}

LINKAGE = presets.n_link_chain(2)
CHAIN = Dynamics(LINKAGE)
DOWN = np.array([-np.pi / 2, -np.pi / 2])
FX_LIMIT, ACCELERATION_LIMIT = 15.0, 30.0  # unbounded: |Fx| reaches 25 N, |ddpsi_2| 64 rad/s^2


def swing(name, degree, formulation, N=20):
    """The hanging two-link chain swung to rest at DOWN + (0.6, 0.9) rad in 1 s, min integral
    sum M^2, with the ground's horizontal force at H0 and link 2's acceleration bounded."""
    times = np.linspace(0.0, 1.0, 11)
    end = DOWN + np.array([0.6, 0.9])
    return (
        OCP(CHAIN, T=1.0, N=N, transcription=name, degree=degree, formulation=formulation)
        .initial(psi=DOWN, dpsi=[0.0, 0.0])
        .final(psi=end, dpsi=[0.0, 0.0])
        .constrain(
            "grf",
            CHAIN.function("ground_reaction"),  # (psi, dpsi, ddpsi) -> (Fx, Fy)
            lower={"Fx": -FX_LIMIT},
            upper={"Fx": FX_LIMIT},
        )
        .constrain(
            "elbow acceleration",
            lambda p: p.ddpsi_link2,
            lower=-ACCELERATION_LIMIT,
            upper=ACCELERATION_LIMIT,
        )
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(t=times, psi=DOWN + np.outer(times, end - DOWN), dpsi=np.tile(end - DOWN, (11, 1)))
    )


@pytest.mark.parametrize("name,degree", SCHEMES, ids=SCHEME_IDS)
def test_ddpsi_constraints_reach_the_same_optimum_in_both_formulations(name, degree):
    solutions = {
        f: swing(name, degree, f).solve(progress=False, options=TIGHT)
        for f in ("implicit", "explicit")
    }
    implicit, explicit = solutions["implicit"], solutions["explicit"]
    assert explicit.cost == pytest.approx(implicit.cost, rel=1e-8)
    np.testing.assert_allclose(explicit.states, implicit.states, atol=1e-6)
    for solution in solutions.values():
        # The oracle's accelerations and ground force at every dynamics point, from the
        # solution's states and torques there.
        x = solution.state_values[solution.mesh.dyn_state_cols]
        psi, dpsi, torque = x[:, :2], x[:, 2:], solution.control_values
        ddpsi = newton_euler.forward_dynamics(LINKAGE, psi, dpsi, torque)
        force = newton_euler.ground_reaction(LINKAGE, psi, dpsi, ddpsi)
        for values, limit in ((force.real, FX_LIMIT), (ddpsi[:, 1], ACCELERATION_LIMIT)):
            assert np.max(np.abs(values)) <= limit * (1 + 1e-6)
            assert np.max(np.abs(values)) >= limit * (1 - 1e-6)  # both bounds bind


def test_multi_output_rows_are_named_per_output_and_bounded_per_output():
    ocp = swing("hermite-simpson", None, "explicit", N=2)
    ocp = ocp.boundary(
        "landing force", CHAIN.function("ground_reaction"), "end", lower={"Fy": 0.0}
    ).constrain_at(
        "hinges", CHAIN.function("hinge_positions"), fraction=0.3, upper={"hinge_y": 0.0}
    )
    transcription = ocp.transcribe()
    names = transcription.g_names
    assert names[names.index("path[grf][Fx] node 0") + 1] == "path[grf][Fy] node 0"
    assert "end[landing force][Fx]" in names and "end[landing force][Fy]" in names
    hinge_rows = [n for n in names if n.startswith("at[hinges]")]
    assert hinge_rows == [
        f"at[hinges][{output}][{i}] t=0.3 T (interval 0)"
        for output in ("hinge_x", "hinge_y")
        for i in range(3)
    ]
    scale = transcription.g_scale
    lower, upper = transcription.lbg * scale, transcription.ubg * scale
    bounds = dict(zip(names, zip(lower, upper, strict=True), strict=True))
    assert bounds["path[grf][Fx] node 1"] == (-FX_LIMIT, FX_LIMIT)
    assert bounds["path[grf][Fy] node 1"] == (-np.inf, np.inf)
    assert bounds["end[landing force][Fy]"] == (0.0, np.inf)
    assert bounds["at[hinges][hinge_y][2] t=0.3 T (interval 0)"] == (-np.inf, 0.0)
    assert bounds["at[hinges][hinge_x][2] t=0.3 T (interval 0)"] == (-np.inf, np.inf)
