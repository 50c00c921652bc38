"""Constraints at interior instants (``OCP.constrain_at``): a keypoint between nodes against
the closed-form optimum and its convergence order, the rows recomputed from the solution's
values with independent numpy interpolation, fractions of a free duration, warm starts."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from numpy.polynomial import legendre as npleg
from reference import newton_euler

from model import Dynamics, presets
from planner import OCP, Transcription

SCHEMES = [("trapezoid", None), ("hermite-simpson", None), ("radau", 3), ("legendre", 3)]
SCHEME_IDS = [name + (str(degree) if degree else "") for name, degree in SCHEMES]
TIGHT = {"tol": 1e-11}


def double_integrator(formulation):
    """q'' = a as an ODE f(x, u) or as an implicit residual r(x, xdot, u)."""
    x, u = ca.SX.sym("x", 2), ca.SX.sym("u")
    if formulation == "explicit":
        return ca.Function("f", [x, u], [ca.vertcat(x[1], u)], ["x", "u"], ["xdot"])
    xdot = ca.SX.sym("xdot", 2)
    return ca.Function(
        "r", [x, xdot, u], [xdot - ca.vertcat(x[1], u)], ["x", "xdot", "u"], ["residual"]
    )


def rest_to_rest(N, transcription, degree, formulation="explicit", T=1.0):
    """q: 0 -> 0 at rest over [0, T], min integral a^2 (add keypoints to make it non-trivial)."""
    return (
        OCP(
            double_integrator(formulation),
            T=T,
            N=N,
            transcription=transcription,
            degree=degree,
            formulation=formulation,
            state_names=("q", "v"),
            control_names=("a",),
        )
        .initial(q=0.0, v=0.0)
        .final(q=0.0, v=0.0)
        .minimize(integral=lambda p: p.a**2)
    )


def spline_energy(s1: float) -> float:
    """min integral q''^2 over [0, 1] with q(0) = q'(0) = q(1) = q'(1) = 0 and q(s1) = 1.

    The minimiser is the clamped cubic spline through (0, 0), (s1, 1), (1, 0) (Holladay);
    its q'' is piecewise linear, so the energy is a sum of exact integrals of squares of
    linear functions (scipy builds the spline, written another way than the planner).
    """
    from scipy.interpolate import CubicSpline

    spline = CubicSpline([0.0, s1, 1.0], [0.0, 1.0, 0.0], bc_type="clamped")
    energy = 0.0
    for i in range(2):
        h = spline.x[i + 1] - spline.x[i]
        c3, c2 = spline.c[0, i], spline.c[1, i]  # q'' = 6 c3 s + 2 c2 on [0, h]
        energy += 12 * c3**2 * h**3 + 12 * c3 * c2 * h**2 + 4 * c2**2 * h
    return energy


def fitted_order(Ns, errors):
    return -np.polyfit(np.log(Ns), np.log(errors), 1)[0]


# ---- closed-form optimum and convergence ----------------------------------------------------

# A keypoint q(0.3) = 1 that never falls on a node: with N = 9, 19, 29, 39 it lies at the
# same place tau = 0.7 of its interval, so the error constants match and the fit is clean.
# The optimal control has a kink at the keypoint (the multiplier of q(0.3) = 1 makes a'
# jump there), inside an interval: no interval polynomial follows it, which caps every
# scheme at order 3 (the trapezoid keeps its order 2).
KEY_T = 0.3
KEY_NS = [9, 19, 29, 39]
KEY_ORDER = {"trapezoid": 2, "hermite-simpson": 3, "radau": 3, "legendre": 3}


@pytest.mark.parametrize("formulation", ["explicit", "implicit"])
@pytest.mark.parametrize("name,degree", SCHEMES, ids=SCHEME_IDS)
def test_keypoint_between_nodes_converges_to_the_clamped_spline(name, degree, formulation):
    exact = spline_energy(KEY_T)
    errors = []
    for N in KEY_NS:
        ocp = rest_to_rest(N, name, degree, formulation).constrain_at(
            "key", lambda p: p.q, t=KEY_T, lower=1.0, upper=1.0
        )
        solution = ocp.solve(progress=False, options=TIGHT)
        k = int(np.floor(KEY_T * N))
        assert f"at[key] t=0.3 s (interval {k})" in solution.transcription.g_names
        assert solution.state(KEY_T)[0, 0] == pytest.approx(1.0, abs=1e-9)
        errors.append(abs(solution.cost - exact))
    errors = np.array(errors)
    assert np.all(errors > 1e-9), errors  # not at round-off: the fit means something
    assert np.all(np.diff(errors) < 0), errors
    assert fitted_order(KEY_NS, errors) >= KEY_ORDER[name] - 0.3, errors


@pytest.mark.parametrize(
    "name,degree", [("hermite-simpson", None), ("radau", 3), ("legendre", 3)], ids=str
)
def test_keypoint_on_a_node_is_exact_where_the_spline_is_representable(name, degree):
    # At a node the spline's kink falls between intervals: cubic states and (at least)
    # linear controls per interval hold it exactly, so the cost is the closed form.
    for N in (3, 6):
        ocp = rest_to_rest(N, name, degree).constrain_at(
            "key", lambda p: p.q, fraction=1 / 3, lower=1.0, upper=1.0
        )
        solution = ocp.solve(progress=False, options=TIGHT)
        assert solution.cost == pytest.approx(spline_energy(1 / 3), rel=1e-9)


# ---- the rows recomputed from the solution's values (independent numpy) -------------------


def lagrange(points, tau):
    """Lagrange basis through ``points`` at ``tau`` by the product formula, (m,)."""
    points = np.asarray(points, dtype=float)
    return np.array(
        [
            np.prod([(tau - pi) / (pj - pi) for i, pi in enumerate(points) if i != j])
            for j, pj in enumerate(points)
        ]
    )


def roots(name, degree):
    """Collocation points in [0, 1] from numpy's Legendre series (not the planner's)."""
    coefficients = np.zeros(degree + 1)
    coefficients[degree] = 1.0
    if name == "radau":  # P_d - P_{d-1}: Radau IIA, the last point at tau = 1
        coefficients[degree - 1] = -1.0
    return np.sort((npleg.legroots(coefficients) + 1) / 2)


def q_and_a(solution, name, degree, t):
    """q(t) and a(t) from the solution's raw values on the interval holding t (not a node),
    written out per scheme: the trapezoid's quadratic (the integral of the linear rate), the
    cubic Hermite of Hermite-Simpson, and collocation's Lagrange polynomials."""
    h = solution.T / solution.N
    k = int(np.floor(t / h))
    tau = t / h - k
    X, U = solution.state_values, solution.control_values
    if name == "trapezoid":
        (q0, v0), (q1, v1) = X[k], X[k + 1]
        q = q0 + h * (v0 * tau + (v1 - v0) * tau**2 / 2)
        a = U[k, 0] * (1 - tau) + U[k + 1, 0] * tau
    elif name == "hermite-simpson":
        (q0, v0), (q1, v1) = X[2 * k], X[2 * k + 2]
        q = (
            (2 * tau**3 - 3 * tau**2 + 1) * q0
            + (tau**3 - 2 * tau**2 + tau) * h * v0
            + (-2 * tau**3 + 3 * tau**2) * q1
            + (tau**3 - tau**2) * h * v1
        )
        a = lagrange([0.0, 0.5, 1.0], tau) @ U[2 * k : 2 * k + 3, 0]
    else:
        r = roots(name, degree)
        ms = degree if name == "radau" else degree + 1  # state points per interval
        q = lagrange(np.append(0.0, r), tau) @ X[k * ms : k * ms + degree + 1, 0]
        a = lagrange(r, tau) @ U[k * degree : (k + 1) * degree, 0]
    return q, a


@pytest.mark.parametrize("formulation", ["explicit", "implicit"])
@pytest.mark.parametrize("name,degree", SCHEMES, ids=SCHEME_IDS)
def test_keypoint_rows_hold_on_the_interpolant_recomputed_in_numpy(name, degree, formulation):
    # Two position keypoints with their own targets (bounds per instant) and a control
    # keypoint, all between nodes (N = 5: nodes at multiples of 0.2 s).
    ocp = (
        rest_to_rest(5, name, degree, formulation)
        .constrain_at("key", lambda p: p.q, t=[0.23, 0.61], lower=[0.8, 0.5], upper=[0.8, 0.5])
        .constrain_at("push", lambda p: p.a, t=0.47, lower=3.0, upper=3.0)
    )
    solution = ocp.solve(progress=False, options=TIGHT)
    for t, q_target in ((0.23, 0.8), (0.61, 0.5)):
        assert q_and_a(solution, name, degree, t)[0] == pytest.approx(q_target, abs=1e-9)
    assert q_and_a(solution, name, degree, 0.47)[1] == pytest.approx(3.0, abs=1e-9)
    # The keypoints bind: without them the optimum is q = 0 at no cost.
    assert solution.cost > 1.0
    names = solution.transcription.g_names
    assert [n for n in names if n.startswith("at[")] == [
        "at[key] t=0.23 s (interval 1)",
        "at[key] t=0.61 s (interval 3)",
        "at[push] t=0.47 s (interval 2)",
    ]


def test_explicit_ddpsi_at_an_instant_is_forward_dynamics_of_the_interpolant():
    # The keypoint bounds the oracle's forward dynamics (Newton-Euler, tests/reference) of the
    # interpolated state and torques at that instant, which it exceeds without the keypoint.
    linkage = presets.n_link_chain(2)
    down = np.array([-np.pi / 2, -np.pi / 2])
    swing = (
        OCP(Dynamics(linkage), T=1.0, N=6, formulation="explicit")
        .initial(psi=down, dpsi=[0.0, 0.0])
        .final(psi=down + np.array([0.4, 0.6]), dpsi=[0.0, 0.0])
        .minimize(integral=lambda p: ca.sumsqr(p.M))
    )
    limited = swing.constrain_at("acc", lambda p: p.ddpsi_link2, t=0.45, lower=-1.0, upper=1.0)

    def acceleration(solution):
        state, torque = solution.state(0.45)[0], solution.control(0.45)[0]
        return newton_euler.forward_dynamics(linkage, state[:2], state[2:], torque)[1]

    assert abs(acceleration(swing.solve(progress=False))) > 1.5
    assert abs(acceleration(limited.solve(progress=False, options=TIGHT))) == pytest.approx(
        1.0, abs=1e-7
    )


# ---- free duration: fractions of T --------------------------------------------------------


def test_fraction_of_a_free_duration_matches_the_closed_form():
    # Cost integral a^2 + w T with q(0.3 T) = 1: for a fixed T the optimum is the unit
    # spline scaled in time, energy E / T^3, so J(T) = E / T^3 + w T, minimised at
    # T* = (3 E / w)^(1/4) with J* = 4 w T* / 3.
    w = 100.0
    energy = spline_energy(KEY_T)
    T_star = (3 * energy / w) ** 0.25
    J_star = 4 * w * T_star / 3
    cost_errors, T_errors = [], []
    for N in KEY_NS:
        ocp = (
            OCP(
                double_integrator("explicit"),
                T=(0.5, 3.0),
                N=N,
                state_names=("q", "v"),
                control_names=("a",),
            )
            .initial(q=0.0, v=0.0)
            .final(q=0.0, v=0.0)
            .constrain_at("key", lambda p: p.q, fraction=KEY_T, lower=1.0, upper=1.0)
            .minimize(integral=lambda p: p.a**2, terminal=lambda p: w * p.T)
        )
        solution = ocp.solve(progress=False, options=TIGHT)
        assert f"at[key] t=0.3 T (interval {int(KEY_T * N)})" in solution.transcription.g_names
        assert solution.state(KEY_T * solution.T)[0, 0] == pytest.approx(1.0, abs=1e-9)
        cost_errors.append(abs(solution.cost - J_star))
        T_errors.append(abs(solution.T - T_star))
    assert cost_errors[-1] < 1e-4 * J_star and T_errors[-1] < 1e-4 * T_star
    assert fitted_order(KEY_NS, cost_errors) >= KEY_ORDER["hermite-simpson"] - 0.3, cost_errors


# ---- warm starts ----------------------------------------------------------------------------


def test_keypoints_enter_the_nlp_signature_and_warm_start_the_multipliers():
    def keyed(target, t=0.23):
        return rest_to_rest(5, "hermite-simpson", None).constrain_at(
            "key", lambda p: p.q, t=t, lower=target, upper=target
        )

    base = Transcription(keyed(0.8))
    assert Transcription(keyed(0.9)).signature == base.signature  # only a bound changed
    assert Transcription(keyed(0.8, t=0.27)).signature != base.signature  # another instant
    assert Transcription(rest_to_rest(5, "hermite-simpson", None)).n_g == base.n_g - 1
    cold = keyed(0.8).solve(progress=False, options=TIGHT)
    warm = keyed(0.9).guess(cold).solve(progress=False, options=TIGHT)
    fresh = keyed(0.9).solve(progress=False, options=TIGHT)
    assert warm.stats["warm_start"] and not fresh.stats["warm_start"]
    # A linear-quadratic problem: the optimum scales with the keypoint's target.
    assert warm.cost == pytest.approx(fresh.cost, rel=1e-9)
    assert fresh.cost == pytest.approx(cold.cost * (0.9 / 0.8) ** 2, rel=1e-9)
