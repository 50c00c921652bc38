"""The consistent motion of a solution (planner.solution.Solution.motion, the exported files)
and keypoint rows on it (OCP.constrain_at(on="motion")).

Oracles: scipy quadrature of the interpolant for the antiderivative weights; central finite
differences of the sampled motion for its kinematics; the Newton-Euler recursion of
tests/reference for its torques; the NLP's own row values against the numpy motion.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from reference import newton_euler
from scipy.integrate import quad

from model import DefinitionError, Dynamics, LinkageTrajectory, presets
from planner import OCP, Transcription
from planner.schemes import make_scheme

CHAIN = presets.n_link_chain(2)
DOWN = -np.pi / 2
TARGET = np.array([DOWN + 1.0, DOWN + 1.5])
SCHEMES = [("trapezoid", None), ("hermite-simpson", None), ("radau", 3), ("legendre", 3)]


def swing(transcription, degree, formulation="implicit", N=6):
    """Two-link chain from hanging at rest to a raised pose at rest in 1.5 s, min sum M^2."""
    return (
        OCP(
            Dynamics(CHAIN),
            T=1.5,
            N=N,
            transcription=transcription,
            degree=degree,
            formulation=formulation,
        )
        .initial(psi=[DOWN, DOWN], dpsi=0.0)
        .final(psi=TARGET, dpsi=0.0)
        .bound("M", -60, 60)
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(t=[0.0, 1.5], psi=[[DOWN, DOWN], TARGET])
    )


_SOLVED: dict = {}


def solved(transcription, degree, formulation="implicit"):
    key = (transcription, degree, formulation)
    if key not in _SOLVED:
        ocp = swing(transcription, degree, formulation)
        _SOLVED[key] = ocp, ocp.solve(progress=False, options={"tol": 1e-11})
    return _SOLVED[key]


@pytest.mark.parametrize(("name", "degree"), SCHEMES)
def test_antiderivative_weights_integrate_the_interpolant(name, degree):
    scheme = make_scheme(name, degree)
    checked = 0
    for weights in (scheme.state_weights, scheme.motion_weights):
        for tau in (0.0, 0.3, 0.77, 1.0):
            wx, wf = weights([tau], -1)
            for values, column in ((wx, 0), (wf, 1)):
                for j in range(values.shape[1]):
                    exact = quad(lambda s, j=j, c=column, w=weights: w([s])[c][0, j], 0.0, tau)[0]
                    assert values[0, j] == pytest.approx(exact, abs=1e-13)
                    checked += 1
    assert checked > 8


def test_trapezoid_motion_meets_its_position_defect_and_end_values():
    # The quartic through v0, v1 with slopes h a0, h a1 whose integral is (v0 + v1) / 2:
    # the trapezoid's position defect q1 = q0 + h (v0 + v1) / 2.
    scheme = make_scheme("trapezoid")
    rng = np.random.default_rng(3)
    v, a, h = rng.normal(size=2), rng.normal(size=2), 0.07

    def velocity(tau, derivative=0):
        wx, wf = scheme.motion_weights([tau], derivative)
        return float(wx[0] @ v + h * (wf[0] @ a))

    assert velocity(0.0) == pytest.approx(v[0], abs=1e-15)
    assert velocity(1.0) == pytest.approx(v[1], abs=1e-15)
    assert velocity(0.0, 1) == pytest.approx(h * a[0], abs=1e-15)
    assert velocity(1.0, 1) == pytest.approx(h * a[1], abs=1e-15)
    assert velocity(1.0, -1) == pytest.approx((v[0] + v[1]) / 2, abs=1e-15)
    assert quad(velocity, 0.0, 1.0)[0] == pytest.approx((v[0] + v[1]) / 2, abs=1e-14)


def _inside(solution, count=7):
    """Times strictly inside every mesh interval, away from the nodes."""
    nodes = solution.time
    fractions = np.linspace(0.1, 0.9, count)
    return (nodes[:-1, None] + fractions[None, :] * np.diff(nodes)[:, None]).reshape(-1)


@pytest.mark.parametrize("formulation", ["implicit", "explicit"])
@pytest.mark.parametrize(("name", "degree"), SCHEMES)
def test_consistent_motion_obeys_kinematics_and_dynamics(name, degree, formulation):
    _, solution = solved(name, degree, formulation)
    t = _inside(solution)
    x, xdot, u = solution.motion(t)
    q, v, a = x[:, :2], x[:, 2:], xdot[:, 2:]
    np.testing.assert_array_equal(xdot[:, :2], v)
    # kinematics: central differences of the sampled motion (step 1e-5 s inside an interval)
    step = 1e-5
    ahead, behind = solution.motion(t + step), solution.motion(t - step)
    dq = (ahead[0][:, :2] - behind[0][:, :2]) / (2 * step)
    dv = (ahead[0][:, 2:] - behind[0][:, 2:]) / (2 * step)
    np.testing.assert_allclose(dq, v, atol=1e-7)
    np.testing.assert_allclose(dv, a, atol=1e-6)
    # dynamics: the torques are the Newton-Euler inverse dynamics of that motion
    oracle = newton_euler.inverse_dynamics(CHAIN, q, v, a)
    np.testing.assert_allclose(u, oracle, rtol=1e-11, atol=1e-11 * np.abs(oracle).max())
    # ... whereas the transcription's own polynomials agree with it at the collocation
    # points only (the point of the consistent motion)
    states, controls = solution(t)
    own = newton_euler.inverse_dynamics(CHAIN, states[:, :2], states[:, 2:], xdot[:, 2:])
    assert np.abs(own - controls).max() > 1e-6


@pytest.mark.parametrize(("name", "degree"), SCHEMES)
def test_consistent_motion_passes_through_the_nodes(name, degree):
    _, solution = solved(name, degree)
    x, _, u = solution.motion(solution.time)
    np.testing.assert_array_equal(x, solution.states)  # bit for bit
    # approaching a node from the interval before: the position integral meets the node to
    # the solver's tolerance on the position defects
    before = solution.time[1:] - 1e-12 * solution.T
    np.testing.assert_allclose(solution.motion(before)[0], solution.states[1:], atol=1e-9)
    # where a node is a dynamics point, its torques are the NLP's there, to the tolerance
    # of its dynamics rows (Legendre's nodes are no dynamics points: its torques there are
    # extrapolations of the control polynomial)
    if name != "legendre":
        np.testing.assert_allclose(u[1:-1], solution.drives[1:-1], atol=1e-6)


def test_exported_file_is_the_consistent_motion(tmp_path):
    _, solution = solved("hermite-simpson", None)
    path = solution.save(tmp_path / "swing.csv", rate_hz=50.0)

    back = LinkageTrajectory.load(path)
    assert back.metadata["motion"] == "consistent"
    x, xdot, u = solution.motion(back.time)
    np.testing.assert_array_equal(back.states, x)
    np.testing.assert_array_equal(back.torques, u)
    np.testing.assert_array_equal(back.ddpsi, xdot[:, 2:])
    with pytest.raises(DefinitionError, match="`motion`: must be one of"):
        solution.to_trajectory(motion="smooth")


@pytest.mark.parametrize("formulation", ["implicit", "explicit"])
@pytest.mark.parametrize(("name", "degree"), SCHEMES)
def test_rows_on_the_motion_are_the_solutions_motion(name, degree, formulation):
    ocp, solution = solved(name, degree, formulation)
    instants = [0.0, 0.0123, 0.5, 0.75, 1.4999, 1.5]  # nodes, interior points and T
    probed = ocp.constrain_at(
        "probe",
        lambda p: ca.vertcat(p.x, p.M, p.ddpsi),
        t=instants,
        lower=-1e9,
        upper=1e9,
        on="motion",
    )
    transcription = Transcription(probed)
    assert transcription.n_w == solution.w.size  # no variables added: the same w
    _, g = transcription.nlp_function(solution.w, transcription.parameter_values())
    g = np.asarray(g).reshape(-1) * transcription.g_scale
    rows = [i for i, n in enumerate(transcription.g_names) if n.startswith("at[probe]")]
    values = g[rows].reshape(len(instants), -1)
    x, xdot, u = solution.motion(np.array(instants))
    expected = np.hstack([x, u, xdot[:, 2:]])
    np.testing.assert_allclose(values, expected, rtol=1e-12, atol=1e-11)


def test_motion_needs_a_system_with_that_role_and_no_control_rates():
    x, u = ca.SX.sym("x", 2), ca.SX.sym("u")
    generic = OCP(ca.Function("f", [x, u], [ca.vertcat(x[1], u)]), T=1.0, N=4)
    with pytest.raises(DefinitionError, match="on='motion' needs a system with positions"):
        generic.constrain_at("q", lambda p: p.x[0], t=0.5, lower=0.0, on="motion")
    with pytest.raises(DefinitionError, match="on must be 'transcription' or 'motion'"):
        swing("hermite-simpson", None).constrain_at(
            "q", lambda p: p.psi[0], t=0.5, lower=0.0, on="spline"
        )
    rated = swing("hermite-simpson", None).constrain_at(
        "rate", lambda p: p.dM[0], t=0.5, upper=10.0, on="motion"
    )
    with pytest.raises(DefinitionError, match="reads a control rate"):
        Transcription(rated)
    solution = (
        generic.minimize(integral=lambda p: p.u**2)
        .initial(x=[0, 0])
        .final(x=[1, 0])
        .solve(progress=False)
    )
    with pytest.raises(DefinitionError, match="`motion`: the system has no positions"):
        solution.motion([0.5])
    assert solution.to_trajectory().metadata["motion"] == "transcription"
