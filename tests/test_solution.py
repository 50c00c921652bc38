"""Solutions: interpolants against the variables and the dynamics (separate code paths),
accuracy estimates against scipy, warm starts, export round trips."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from model import (
    AnthropoidError,
    DefinitionError,
    DefinitionTypeError,
    Dynamics,
    LinkageTrajectory,
    presets,
)
from planner import OCP, Solution, Trajectory, Transcription
from planner.collocation import collocation_roots

CHAIN = Dynamics(presets.n_link_chain(2))
DOWN = -np.pi / 2
TARGET = np.array([DOWN + 1.0, DOWN + 1.5])
SCHEMES = [
    ("trapezoid", None),
    ("hermite-simpson", None),
    ("radau", 1),
    ("radau", 3),
    ("legendre", 2),
]


def swing(N=6, transcription="hermite-simpson", degree=None, formulation="implicit"):
    """Two-link chain from hanging at rest to a raised pose at rest in 1.5 s, min sum M^2."""
    return (
        OCP(CHAIN, T=1.5, N=N, transcription=transcription, degree=degree, formulation=formulation)
        .initial(psi=[DOWN, DOWN], dpsi=0.0)
        .final(psi=TARGET, dpsi=0.0)
        .bound("M", -60, 60)
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(
            t=[0.0, 1.5],
            psi=[[DOWN, DOWN], TARGET],
        )
    )


_CACHE: dict = {}


def solved(transcription, degree=None, N=6):
    key = (transcription, degree, N)
    if key not in _CACHE:
        _CACHE[key] = swing(N, transcription, degree).solve(progress=False, options={"tol": 1e-11})
    return _CACHE[key]


def rate_numpy(states, controls):
    """xdot = [dpsi; forward dynamics] by the model's numpy path, (K, 4)."""
    psi, dpsi = states[:, :2], states[:, 2:]
    return np.hstack([dpsi, np.atleast_2d(CHAIN.forward_dynamics(psi, dpsi, controls))])


def product_basis_derivative(points, tau):
    points = np.asarray(points, float)
    m = points.size
    out = np.zeros(m)
    for j in range(m):
        others = [i for i in range(m) if i != j]
        total = 0.0
        for skip in others:
            total += np.prod([tau - points[i] for i in others if i != skip])
        out[j] = total / np.prod([points[j] - points[i] for i in others])
    return out


# ---- the interpolant --------------------------------------------------------------------


@pytest.mark.parametrize("name,degree", SCHEMES)
def test_interpolant_reproduces_the_variables_at_the_knots(name, degree):
    solution = solved(name, degree)
    assert solution.success
    np.testing.assert_allclose(
        solution.state(solution.state_time), solution.state_values, atol=1e-12, rtol=0
    )
    np.testing.assert_allclose(
        solution.control(solution.point_time), solution.control_values, atol=1e-10, rtol=0
    )
    np.testing.assert_allclose(
        solution.aux(solution.point_time), solution.aux_values, atol=1e-9, rtol=0
    )
    np.testing.assert_array_equal(solution.states, solution.state_values[:: solution.scheme.ms])
    assert solution.time[-1] == pytest.approx(1.5)


@pytest.mark.parametrize("name,degree", SCHEMES)
def test_interpolant_satisfies_the_dynamics_at_the_collocation_points(name, degree):
    solution = solved(name, degree)
    h = solution.h
    X = solution.state_values
    t_points = solution.point_time
    # the dynamics by the model's numpy path (forward dynamics), not the NLP's functions
    f_points = rate_numpy(X[solution.mesh.dyn_state_cols], solution.control_values)
    slope = solution.state(t_points, derivative=1)
    np.testing.assert_allclose(slope, f_points, atol=1e-7 * np.abs(f_points).max())
    # ... and the slope recomputed here from the state values alone, by textbook formulas
    N = solution.N
    if name == "hermite-simpson":
        f_nodes = f_points[0::2]
        for k in range(N):
            x0, x1 = X[2 * k], X[2 * k + 2]
            mid_slope = 1.5 / h * (x1 - x0) - (f_nodes[k] + f_nodes[k + 1]) / 4
            np.testing.assert_allclose(mid_slope, f_points[2 * k + 1], atol=1e-6)
            mid_value = (x0 + x1) / 2 + h / 8 * (f_nodes[k] - f_nodes[k + 1])
            np.testing.assert_allclose(mid_value, X[2 * k + 1], atol=1e-9)
    elif name == "trapezoid":
        for k in range(N):
            end = X[k] + h / 2 * (f_points[k] + f_points[k + 1])
            np.testing.assert_allclose(end, X[k + 1], atol=1e-9)
            # the quadratic of interval k reaches the next node from the left
            left = solution.state([solution.time[k + 1] - 1e-13])[0]
            np.testing.assert_allclose(left, X[k + 1], atol=1e-9)
    else:
        roots = collocation_roots(name, degree)
        points = np.append(0.0, roots)
        per = solution.scheme.ms
        for k in range(N):
            xs = X[k * per : k * per + degree + 1]
            for r, tau in enumerate(roots):
                own = product_basis_derivative(points, tau) @ xs / h
                np.testing.assert_allclose(own, f_points[k * degree + r], atol=1e-6)


def test_time_outside_the_horizon_raises():
    solution = solved("hermite-simpson")
    with pytest.raises(DefinitionError, match=r"`t`: times must lie in \[0, T\]"):
        solution.state([1.6])
    with pytest.raises(DefinitionError, match="unknown variable 'psi_foo'"):
        solution.value("psi_foo", [0.1])


def test_ddpsi_and_torques_views():
    solution = solved("hermite-simpson")
    expected = np.atleast_2d(
        CHAIN.forward_dynamics(solution.states[:, :2], solution.states[:, 2:], solution.drives)
    )
    np.testing.assert_allclose(solution.accelerations, expected, atol=1e-7 * np.abs(expected).max())
    np.testing.assert_allclose(solution.value("M_link2", solution.time), solution.drives[:, 1])


# ---- accuracy estimates -----------------------------------------------------------------


@pytest.mark.parametrize("name,degree", [("hermite-simpson", None), ("radau", 3)])
def test_integration_error_matches_scipy(name, degree):
    solution = solved(name, degree)
    estimate = solution.integration_error()
    h = solution.h
    expected = np.zeros((solution.N, 4))
    for k in range(solution.N):
        t0 = solution.time[k]

        def rhs(t, x, t0=t0):
            # stay inside interval k (the control polynomial of this interval)
            u = solution.control([min(max(t, t0 + 1e-14), t0 + h - 1e-14)])
            return rate_numpy(x[None, :], u)[0]

        result = solve_ivp(rhs, (t0, t0 + h), solution.states[k], "DOP853", rtol=1e-12, atol=1e-12)
        expected[k] = np.abs(result.y[:, -1] - solution.states[k + 1])
    assert expected.max() > 1e-7  # a coarse mesh: a measurable error
    np.testing.assert_allclose(estimate.per_interval, expected, atol=1e-9)
    assert estimate.max == pytest.approx(expected.max(), abs=1e-9)
    assert estimate.per_interval.shape == (solution.N, 4)


def test_error_estimates_shrink_at_the_scheme_order():
    Ns = np.array([24, 48, 96])
    errors, residuals = [], []
    for N in Ns:
        solution = solved("hermite-simpson", None, int(N))
        errors.append(solution.integration_error().max)
        residuals.append(solution.residual_error().max)

    def slope(values):
        return -np.polyfit(np.log(Ns), np.log(values), 1)[0]

    # Hermite-Simpson: local (one-interval) error O(h^5); the residual of the interpolant is
    # O(h^3) (stage order 3), integrated over an interval O(h^4). Coarse meshes are still
    # pre-asymptotic on this swing, hence the margins.
    assert slope(errors) >= 4.0, errors
    assert slope(residuals) >= 2.5, residuals


def implicit_oscillator():
    """A generic implicit residual, nonlinear in xdot and time dependent:
    r = [q' - v, (1 + sin^2 q / 2) v' + v'^3 / 10 + sin q - a - 0.3 cos t]."""
    x, xdot = ca.SX.sym("x", 2), ca.SX.sym("xdot", 2)
    u, t = ca.SX.sym("u"), ca.SX.sym("t")
    mass = 1 + 0.5 * ca.sin(x[0]) ** 2
    force = ca.sin(x[0]) - u - 0.3 * ca.cos(t)
    residual = ca.vertcat(xdot[0] - x[1], mass * xdot[1] + 0.1 * xdot[1] ** 3 + force)
    return ca.Function("r", [x, xdot, u, t], [residual], ["x", "xdot", "u", "t"], ["r"])


def oscillator_rate(t, x, a):
    """xdot of the oscillator in numpy: v' is the one real root of the cubic
    v'^3 / 10 + (1 + sin^2 q / 2) v' + (sin q - a - 0.3 cos t) = 0 (increasing in v')."""
    roots = np.roots([0.1, 0.0, 1 + 0.5 * np.sin(x[0]) ** 2, np.sin(x[0]) - a - 0.3 * np.cos(t)])
    real = roots[np.abs(roots.imag) < 1e-9].real
    assert real.size == 1
    return np.array([x[1], real[0]])


@pytest.mark.parametrize("name,degree", [("hermite-simpson", None), ("radau", 3)])
def test_accuracy_estimates_of_a_generic_implicit_residual(name, degree):
    solution = (
        OCP(
            implicit_oscillator(),
            T=2.0,
            N=8,
            transcription=name,
            degree=degree,
            formulation="implicit",
            state_names=("q", "v"),
            control_names=("a",),
        )
        .initial(q=0.0, v=0.0)
        .final(q=1.0, v=0.0)
        .minimize(integral=lambda p: p.a**2)
        .solve(progress=False, options={"tol": 1e-12})
    )
    assert solution.system.ode is None  # no explicit ODE: the residual alone
    h = solution.h
    # re-integration, against scipy on the explicit form solved by hand
    expected = np.zeros((solution.N, 2))
    for k in range(solution.N):
        t0 = solution.time[k]

        def rhs(t, x, t0=t0):
            a = solution.control([min(max(t, t0 + 1e-14), t0 + h - 1e-14)])[0, 0]
            return oscillator_rate(t, x, a)

        result = solve_ivp(rhs, (t0, t0 + h), solution.states[k], "DOP853", rtol=1e-12, atol=1e-12)
        expected[k] = np.abs(result.y[:, -1] - solution.states[k + 1])
    assert expected.max() > 1e-7  # a coarse mesh: a measurable error
    estimate = solution.integration_error()
    np.testing.assert_allclose(estimate.per_interval, expected, atol=1e-9)
    # residual estimate: integral of |f - dx/dt| by Gauss-Legendre, f from the cubic's root
    nodes, weights = np.polynomial.legendre.leggauss(12)
    nodes, weights = (nodes + 1) / 2, weights / 2
    gap = np.zeros((solution.N, 2))
    for k in range(solution.N):
        t = solution.time[k] + h * nodes
        x, dx, a = solution.state(t), solution.state(t, derivative=1), solution.control(t)
        f = np.array([oscillator_rate(t[i], x[i], a[i, 0]) for i in range(t.size)])
        gap[k] = h * weights @ np.abs(f - dx)
    assert gap.max() > 1e-7
    np.testing.assert_allclose(solution.residual_error().per_interval, gap, rtol=1e-9, atol=1e-13)
    # the replay's first interval is the first re-integration
    replay = solution.replay(rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(np.abs(replay.deviation[1]), expected[0], atol=1e-9)


def test_a_residual_that_does_not_determine_xdot_is_named():
    # r = [q' - v, q' - v]: v' appears nowhere, so no integrator or Newton step can find it.
    x, xdot, u = ca.SX.sym("x", 2), ca.SX.sym("xdot", 2), ca.SX.sym("u")
    residual = ca.Function("r", [x, xdot, u], [ca.vertcat(xdot[0] - x[1], xdot[0] - x[1])])
    solution = (
        OCP(residual, T=1.0, N=4, formulation="implicit", state_names=("q", "v"))
        .initial(q=0.0, v=0.0)
        .minimize(integral=lambda p: p.u_0**2 + p.v**2)
        .solve(progress=False, raise_on_failure=False)
    )
    for method in ("integration_error", "residual_error", "replay"):
        with pytest.raises(DefinitionError, match=rf"`{method}`: .*structural rank 1 < 2"):
            getattr(solution, method)()


def scalar_solution(dynamics, formulation, x, u, z):
    """A Solution of the scalar system ``dynamics`` (state y) holding the constant values x,
    u and z at every point (not a solve: a state the accuracy estimates must cope with)."""
    ocp = OCP(dynamics, T=1.0, N=2, formulation=formulation, state_names=("y",))
    transcription = Transcription(ocp.minimize(integral=lambda p: p.u_0**2))
    mesh = transcription.mesh
    nz = transcription.system.nz
    w = transcription.pack(
        np.full((mesh.n_state_points, 1), x),
        np.full((mesh.n_dyn_points, 1), u),
        np.full((mesh.n_dyn_points, nz), z),
        1.0,
    )
    return Solution(transcription, w, 0.0, "constructed", False, {})


def test_integrator_and_newton_failures_raise_naming_the_solver():
    y, u, ydot = ca.SX.sym("y"), ca.SX.sym("u"), ca.SX.sym("ydot")
    # y' = y^2 from y = 10 blows up at t = 0.1, inside the first interval
    blowing_up = scalar_solution(ca.Function("f", [y, u], [y**2 + u]), "explicit", 10.0, 0, 0)
    with pytest.raises(AnthropoidError, match=r"ODE failed \(CVODES, CV_\w+\) on one of the 2"):
        blowing_up.integration_error()
    with pytest.raises(AnthropoidError, match=r"\(CVODES, CV_\w+\) on interval 0 \(t = 0 .. 0.5"):
        blowing_up.replay()
    # r = y'^2 - u with u = 1 and the slope guess y' = 0: dr/dy' = 0 there, no Newton step
    singular = scalar_solution(ca.Function("r", [y, ydot, u], [ydot**2 - u]), "implicit", 0, 1, 0)
    with pytest.raises(AnthropoidError, match=r"\(Newton .*\): the root is NaN or inf at t ="):
        singular.residual_error()
    with pytest.raises(AnthropoidError, match=r"implicit residual failed \(IDAS, IDA_\w+\) on"):
        singular.integration_error()
    with pytest.raises(AnthropoidError, match=r"\(IDAS, IDA_\w+\) on interval 0 \(t = 0 .. 0.5"):
        singular.replay()


def test_tolerances_are_checked_and_each_pair_is_integrated_by_one_integrator():
    solution = solved("hermite-simpson")
    for name in ("rtol", "atol"):
        with pytest.raises(DefinitionError, match=rf"`{name}`: must lie in \[1e-14, 1\), got 0.0"):
            solution.integration_error(**{name: 0.0})
        with pytest.raises(DefinitionError, match=rf"`{name}`: must lie in \[1e-14, 1\), got 1.0"):
            solution.replay(**{name: 1})
        with pytest.raises(DefinitionTypeError, match=rf"`{name}`: must be a real number"):
            solution.replay(**{name: "tight"})
    first = solution.integration_error()
    integrator = solution._interval_integrator(1e-12, 1e-12, "integration_error")
    assert solution._interval_integrator(1e-12, 1e-12, "replay") is integrator
    np.testing.assert_array_equal(solution.integration_error().per_interval, first.per_interval)


def test_replay_is_the_chained_reintegration():
    solution = solved("hermite-simpson")
    replay = solution.replay(rtol=1e-12, atol=1e-12)
    assert replay.states.shape == (solution.N + 1, 4)
    np.testing.assert_array_equal(replay.deviation[0], 0.0)
    first = solution.integration_error().per_interval[0]
    np.testing.assert_allclose(np.abs(replay.deviation[1]), first, atol=1e-10)
    assert replay.max_deviation >= first.max()


# ---- warm starts ------------------------------------------------------------------------


def test_warm_starts_regrid_through_the_interpolant():
    coarse = solved("hermite-simpson", None, 6)
    # same mesh: the guess is the solution itself, with its multipliers
    again = swing(6).guess(coarse).solve(progress=False, options={"tol": 1e-11})
    assert again.stats["warm_start"] and again.iterations < coarse.iterations
    assert again.cost == pytest.approx(coarse.cost, rel=1e-10)
    # primal only (IPOPT restarts its barrier): the variables re-gridded onto the same mesh
    # through the interpolant are the solution's own
    assert np.abs(Transcription(swing(6).guess(coarse)).initial_guess() - coarse.w).max() < 1e-12
    primal = swing(6).guess(coarse).solve(progress=False, options={"tol": 1e-11}, warm_start=False)
    assert not primal.stats["warm_start"] and again.iterations < primal.iterations
    assert primal.cost == pytest.approx(coarse.cost, rel=1e-10)
    # coarse to fine: the new mesh's variables are the coarse interpolant's values
    fine = swing(24, "radau", 3).guess(coarse)
    values = Transcription(fine).unpack(Transcription(fine).initial_guess())
    mesh_times = Transcription(fine).mesh
    np.testing.assert_allclose(values["X"], coarse.state(mesh_times.s_state * 1.5), atol=1e-12)
    np.testing.assert_allclose(values["U"], coarse.control(mesh_times.s_dyn * 1.5), atol=1e-12)
    np.testing.assert_allclose(values["Z"], coarse.aux(mesh_times.s_dyn * 1.5), atol=1e-12)
    cold = swing(24, "radau", 3).solve(progress=False)
    warm = fine.solve(progress=False)
    assert warm.success and warm.iterations < cold.iterations
    # a Trajectory (here the coarse solution exported) serves as a guess too
    from_file = swing(24, "radau", 2).guess(coarse.to_trajectory(rate_hz=200.0))
    assert from_file.solve(progress=False).success


def test_nlp_signature_names_the_layout_of_the_multipliers():
    solution = solved("hermite-simpson", None, 6)
    transcription = solution.transcription
    assert solution.lam_x.shape == (transcription.n_w,)
    assert solution.lam_g.shape == (transcription.n_g,)
    assert solution.nlp_signature == transcription.signature
    assert solution.nlp_signature.startswith(
        f"hermite-simpson N=6 implicit: {transcription.n_w} variables, "
        f"{transcription.n_g} constraints, "
    )
    # bounds, scales, cost, T and guesses are no part of the layout ...
    same = (
        swing(6).bound("M", -50, 50),
        swing(6).scale(M=7.0, psi=2.0),
        swing(6).minimize(integral=lambda p: ca.sumsqr(p.M) + p.dpsi[0] ** 2),
        dataclasses.replace(swing(6), T=1.6),
        swing(6).guess(M=1.0),
    )
    for ocp in same:
        assert Transcription(ocp).signature == solution.nlp_signature, str(ocp)
    # ... the variables and the constraint rows are
    different = (
        swing(7),
        swing(6, "trapezoid"),
        swing(6, "radau", 3),
        swing(6, "radau", 2),
        swing(6, "legendre", 2),
        swing(6, formulation="explicit"),
        swing(6).constrain("elbow", lambda p: p.psi[1] - p.psi[0], lower=-2.0, upper=2.0),
        swing(6).periodic(),
        dataclasses.replace(swing(6), T=(1.0, 2.0)),
    )
    signatures = {Transcription(ocp).signature for ocp in different}
    assert len(signatures) == len(different) and solution.nlp_signature not in signatures
    assert (
        Transcription(swing(6, "radau", 2)).signature
        != Transcription(swing(6, "legendre", 2)).signature
    )


def free_time_swing(N, T=(0.5, 4.0), transcription="hermite-simpson", degree=None):
    """The swing with a free duration: min integral (1 + M^2 / 100), optimum T ~ 0.85 s."""
    return (
        OCP(CHAIN, T=T, N=N, transcription=transcription, degree=degree)
        .initial(psi=[DOWN, DOWN], dpsi=0.0)
        .final(psi=TARGET, dpsi=0.0)
        .bound("M", -60, 60)
        .minimize(integral=lambda p: 1 + 0.01 * ca.sumsqr(p.M))
    )


def test_free_time_warm_start_takes_the_solution_duration():
    coarse = free_time_swing(6).solve(progress=False, options={"tol": 1e-10})
    assert coarse.success and 0.6 < coarse.T < 1.2  # far from the bounds' middle, 2.25 s
    fine = free_time_swing(24).guess(coarse)
    transcription = Transcription(fine)
    x0 = transcription.initial_guess()
    values = transcription.unpack(x0)
    assert values["T"] == pytest.approx(coarse.T, rel=1e-15)
    assert x0[-1] * transcription.phases[0].T_scale == pytest.approx(coarse.T, rel=1e-15)
    s = transcription.mesh.s_state
    np.testing.assert_allclose(values["X"], coarse.state(s * coarse.T), atol=1e-12)
    warm = fine.solve(progress=False, options={"tol": 1e-10})
    cold = free_time_swing(24).solve(progress=False, options={"tol": 1e-10})
    # (the cold start finds another local optimum, T ~ 0.87 s; the warm one stays near T)
    assert warm.success and warm.T == pytest.approx(coarse.T, rel=0.01)
    assert warm.iterations <= 7 and warm.iterations < cold.iterations
    # An explicit T in the same call wins over the solution's duration.
    told = Transcription(free_time_swing(24).guess(coarse, T=2.0))
    assert told.unpack(told.initial_guess())["T"] == 2.0


def test_free_time_warm_start_clips_the_duration_and_regrids_in_normalised_time():
    coarse = free_time_swing(6).solve(progress=False, options={"tol": 1e-10})
    for bounds, expected in (((0.5, 0.7), 0.7), ((1.0, 3.0), 1.0)):
        transcription = Transcription(free_time_swing(12, bounds, "radau", 2).guess(coarse))
        values = transcription.unpack(transcription.initial_guess())
        assert values["T"] == pytest.approx(expected, rel=1e-15)  # through the T scaling
        mesh = transcription.mesh
        # the same fraction of the motion at the same fraction of the horizon
        np.testing.assert_allclose(values["X"], coarse.state(mesh.s_state * coarse.T), atol=1e-12)
        np.testing.assert_allclose(values["U"], coarse.control(mesh.s_dyn * coarse.T), atol=1e-12)
    # a Trajectory's time span serves as the duration guess too
    trajectory = coarse.to_trajectory(rate_hz=100.0)
    transcription = Transcription(free_time_swing(12).guess(trajectory))
    assert transcription.unpack(transcription.initial_guess())["T"] == pytest.approx(
        coarse.T, rel=1e-12
    )


# ---- export -----------------------------------------------------------------------------


def test_to_trajectory_at_nodes_and_resampled():
    solution = solved("radau", 3)
    nodes = solution.to_trajectory(motion="transcription")
    assert nodes.metadata["motion"] == "transcription"
    assert isinstance(nodes, Trajectory)
    np.testing.assert_array_equal(nodes.time, solution.time)
    np.testing.assert_array_equal(nodes.psi, solution.states[:, :2])
    np.testing.assert_array_equal(nodes.torques, solution.drives)
    np.testing.assert_array_equal(nodes.ddpsi, solution.accelerations)
    assert nodes.state_names == ("psi_link1", "psi_link2", "dpsi_link1", "dpsi_link2")
    meta = nodes.metadata
    assert meta["transcription"] == "radau" and meta["degree"] == 3 and meta["N"] == 6
    assert meta["formulation"] == "implicit" and meta["status"] == "Solve_Succeeded"
    assert meta["cost"] == solution.cost
    assert meta["model"]["links"][0]["name"] == "link1"
    assert set(meta["versions"]) == {"casadi", "numpy", "anthropoid-planner"}
    resampled = solution.to_trajectory(rate_hz=40.0, motion="transcription")
    assert resampled.time[-1] == pytest.approx(1.5) and resampled.time[1] == pytest.approx(0.025)
    states, controls = solution(resampled.time)
    np.testing.assert_array_equal(resampled.states, states)
    np.testing.assert_array_equal(resampled.controls, controls)


@pytest.mark.parametrize("suffix", [".csv", ".json", ".npz"])
@pytest.mark.parametrize(
    "transcription,degree,rate_hz,expected_grid",
    [
        # T * rate = 49.5: the samples k / 33 s for k = 0..49, then T = 1.5 s appended
        ("hermite-simpson", None, 33.0, [k / 33.0 for k in range(50)] + [1.5]),
        # T * rate = 30: the grid ends on T itself, nothing appended
        ("radau", 3, 20.0, [k / 20.0 for k in range(31)]),
    ],
)
def test_save_round_trip_equals_the_interpolant(
    tmp_path, suffix, transcription, degree, rate_hz, expected_grid
):
    solution = solved(transcription, degree)
    path = tmp_path / f"swing{suffix}"
    solution.save(path, rate_hz=rate_hz, motion="transcription")
    back = LinkageTrajectory.load(path)
    # the time grid read back is the export grid, bit for bit (full-precision files)
    np.testing.assert_array_equal(back.time, np.array(expected_grid))
    # every column is the solution's own interpolant at those times, bit for bit
    names = [name for name, _, group in back.columns if group != "time"]
    links = CHAIN.names
    assert set(names) == {
        *solution.state_names,
        *solution.control_names,
        *(f"ddpsi_{k}" for k in links),
    }
    acceleration = solution.acceleration(back.time)
    np.testing.assert_array_equal(back.ddpsi, acceleration)
    for name in names:
        if name.startswith("ddpsi_"):
            expected = acceleration[:, links.index(name.removeprefix("ddpsi_"))]
        else:
            expected = solution.value(name, back.time)
        np.testing.assert_array_equal(back.column(name), expected, err_msg=name)
    # implicit: the exported ddpsi is the NLP's ddpsi polynomial, independent of torques
    np.testing.assert_array_equal(acceleration, solution.aux(back.time))
    assert back.metadata["status"] == "Solve_Succeeded"


def test_generic_ode_solution_exports_its_own_names():
    x = ca.SX.sym("x", 2)
    u = ca.SX.sym("u")
    f = ca.Function("f", [x, u], [ca.vertcat(x[1], u)])
    solution = (
        OCP(f, T=1.0, N=4, state_names=("q", "v"), control_names=("a",), state_units=("m", "m/s"))
        .initial(q=0.0, v=0.0)
        .final(q=1.0, v=0.0)
        .minimize(integral=lambda p: p.a**2)
        .solve(progress=False)
    )
    trajectory = solution.to_trajectory(rate_hz=10)
    assert trajectory.state_names == ("q", "v") and trajectory.state_units == ("m", "m/s")
    assert trajectory.control_names == ("a",)
    # Hermite-Simpson is exact here: the re-integration error is at round-off
    assert solution.integration_error().max < 1e-9
    assert solution.residual_error().max < 1e-9
    assert solution.accelerations is None


@pytest.mark.parametrize(("T", "N"), [(0.3, 7), (1.1, 50)])
def test_radau_node_controls_are_the_nlp_variables_at_awkward_meshes(T, N):
    # t_k / T * N lands a few ulps off k for these meshes; a node must still read its own NLP
    # variable (the end point of the interval it closes), never an extrapolation.
    dyn = Dynamics(presets.n_link_chain(2))
    solution = (
        OCP(dyn, T=T, N=N, transcription="radau", degree=2)
        .initial(psi=[-1.5, -1.5], dpsi=0)
        .final(psi=[1.0, 1.0], dpsi=0)
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .solve(progress=False)
    )
    at_nodes = solution.control_values[solution.mesh.dyn_cols[:, -1]]
    assert at_nodes.shape == (N, 2)
    np.testing.assert_array_equal(solution.controls[1:], at_nodes)
    np.testing.assert_array_equal(
        solution.to_trajectory(motion="transcription").torques[1:], at_nodes
    )
    # the consistent motion's node torques are the inverse dynamics of the node motion: the
    # NLP's own torques there to its dynamics tolerance
    np.testing.assert_allclose(solution.to_trajectory().torques[1:], at_nodes, atol=1e-7)
