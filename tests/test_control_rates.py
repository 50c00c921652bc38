"""Control rates (``p.du``, a linkage's ``p.dM``): bounds checked against finite differences
of the solution's interpolated controls on both sides of every node, a rate penalty against
its closed form and against the Riccati solution of the augmented LQ problem (convergence
orders), continuity of collocation controls, and rates at boundaries and instants."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from model import DefinitionError, Dynamics
from planner import OCP

SCHEMES = [("trapezoid", None), ("hermite-simpson", None), ("radau", 3), ("legendre", 3)]
SCHEME_IDS = [name + (str(degree) if degree else "") for name, degree in SCHEMES]
TIGHT = {"tol": 1e-12}


def integrator():
    x, u = ca.SX.sym("x"), ca.SX.sym("u")
    return ca.Function("f", [x, u], [u], ["x", "u"], ["xdot"])


def double_integrator():
    x, u = ca.SX.sym("x", 2), ca.SX.sym("u")
    return ca.Function("f", [x, u], [ca.vertcat(x[1], u)], ["x", "u"], ["xdot"])


def one_sided_slopes(solution, t, eps=1e-6):
    """(left, right) slopes of the interpolated control at t (K,) by finite differences of
    ``solution.control`` inside the intervals on either side (NaN beyond the horizon); the
    controls are polynomials there, so second-order differences are exact to round-off."""
    u = solution.control
    t = np.asarray(t, dtype=float)
    left = np.full(t.size, np.nan)
    right = np.full(t.size, np.nan)
    for i, ti in enumerate(t):
        if ti - 2 * eps >= 0:
            a, b, c = (u(ti - j * eps)[0, 0] for j in (0, 1, 2))
            left[i] = (3 * a - 4 * b + c) / (2 * eps)
        if ti + 2 * eps <= solution.T:
            a, b, c = (u(ti + j * eps)[0, 0] for j in (0, 1, 2))
            right[i] = (-3 * a + 4 * b - c) / (2 * eps)
    return left, right


# ---- rate bounds on both sides of every node --------------------------------------------

RATE_LIMIT = 30.0


def bounded_rate(name, degree, N=8, limit=RATE_LIMIT):
    """q: 0 -> 1 at rest in 1 s, min integral v^2, |da/dt| <= ``limit`` (None: no bound).

    Unbounded, the optimum is v = 1 with impulses of a at both ends; the rate bound turns
    them into ramps of slope +-30 (reachable: q(1) <= limit / 12 = 2.5)."""
    ocp = (
        OCP(
            double_integrator(),
            T=1.0,
            N=N,
            transcription=name,
            degree=degree,
            state_names=("q", "v"),
            control_names=("a",),
        )
        .initial(q=0.0, v=0.0)
        .final(q=1.0, v=0.0)
        .minimize(integral=lambda p: p.v**2 + 1e-6 * p.a**2)
    )
    if limit is None:
        return ocp
    return ocp.constrain("rate", lambda p: p.da, lower=-limit, upper=limit)


@pytest.mark.parametrize("name,degree", SCHEMES, ids=SCHEME_IDS)
def test_rate_bounds_hold_where_documented_by_finite_differences(name, degree):
    solution = bounded_rate(name, degree).solve(progress=False, options=TIGHT)
    h, N = solution.h, solution.N
    tolerance = 1e-6 * RATE_LIMIT
    if name in ("trapezoid", "hermite-simpson"):
        # Rates constant or linear in each interval, bounded at both ends of every interval
        # (both sides of each shared node): bounded everywhere, here on both sides of every
        # node and inside every interval.
        nodes, inside = solution.time, (np.arange(N) + 0.37) * h
        left, right = one_sided_slopes(solution, np.concatenate([nodes, inside]))
        slopes = np.concatenate([left, right])
        slopes = slopes[np.isfinite(slopes)]
        assert slopes.size == 2 * N + 2 * N  # every node side, every inside point twice
    else:
        # Collocation: at the collocation points, with the slope of the interval owning each
        # (Radau's end nodes: the interval ending there).
        left, right = one_sided_slopes(solution, solution.point_time)
        slopes = np.where(np.isnan(right) | (name == "radau"), left, right)
        assert np.all(np.isfinite(slopes)) and slopes.size == N * degree
    assert np.max(np.abs(slopes)) <= RATE_LIMIT + tolerance
    assert np.max(np.abs(slopes)) >= RATE_LIMIT - tolerance  # active


@pytest.mark.parametrize("name,degree", SCHEMES, ids=SCHEME_IDS)
def test_control_rate_is_the_slope_of_the_interval_owning_the_point(name, degree):
    # Solution.control_rate (and p.du) at the dynamics points: the right slope at a node
    # (Radau: the left one, its intervals own their end nodes), the left one at T, the
    # derivative inside; against finite differences of the interpolated control.
    solution = bounded_rate(name, degree, N=5).solve(progress=False, options=TIGHT)
    times = solution.point_time
    left, right = one_sided_slopes(solution, times)
    on_node = np.isclose(times / solution.h, np.round(times / solution.h), atol=1e-9)
    expected = np.where(np.isnan(right) | ((name == "radau") & on_node), left, right)
    np.testing.assert_allclose(solution.control_rate(times)[:, 0], expected, atol=1e-5)
    if name != "legendre":  # Legendre has no dynamics point on a node
        # The two sides differ at some node, so picking the side is tested.
        assert np.any(np.abs(left[on_node] - right[on_node]) > 1.0)


def test_shared_nodes_get_rows_for_the_slope_of_the_interval_ending_there():
    names = bounded_rate("hermite-simpson", None, N=3).transcribe().g_names
    rate_rows = [n for n in names if n.startswith("path[rate]")]
    assert rate_rows == [
        "path[rate] node 0",
        "path[rate] interval 0 midpoint",
        "path[rate] node 1",
        "path[rate] interval 1 midpoint",
        "path[rate] node 2",
        "path[rate] interval 2 midpoint",
        "path[rate] node 3",
        "path[rate] node 1 (end of interval 0)",
        "path[rate] node 2 (end of interval 1)",
    ]


# ---- collocation: continuous controls when rates are read ---------------------------------


@pytest.mark.parametrize("name", ["radau", "legendre"])
def test_collocation_controls_become_continuous_when_a_rate_is_read(name):
    unbounded = bounded_rate(name, 3, N=4, limit=None).transcribe().g_names
    assert not any(n.startswith("continuity") for n in unbounded)
    ocp = bounded_rate(name, 3, N=4)
    names = ocp.transcribe().g_names
    assert [n for n in names if n.startswith("continuity")] == [
        f"continuity[a] node {k}" for k in (1, 2, 3)
    ]
    solution = ocp.solve(progress=False, options=TIGHT)
    for t in solution.time[1:-1]:
        before, after = solution.control(t - 1e-9)[0, 0], solution.control(t + 1e-9)[0, 0]
        assert before == pytest.approx(after, abs=1e-6)
    # Without the rows the rate bound would not bind the jumps: the unbounded problem's
    # controls jump at the nodes on this coarse mesh.
    free = bounded_rate(name, 3, N=4, limit=None).solve(progress=False, options=TIGHT)
    jumps = [
        abs(free.control(t - 1e-9)[0, 0] - free.control(t + 1e-9)[0, 0]) for t in free.time[1:-1]
    ]
    assert max(jumps) > 1e-3


@pytest.mark.parametrize("name", ["radau", "legendre"])
def test_degree_one_collocation_refuses_control_rates(name):
    with pytest.raises(DefinitionError, match=rf"`transcription`: {name} of degree 1 has"):
        bounded_rate(name, 1).transcribe()


# ---- a rate penalty: closed form and the Riccati solution of the augmented problem ---------


@pytest.mark.parametrize("name,degree", SCHEMES, ids=SCHEME_IDS)
def test_rate_penalty_matches_its_closed_form(name, degree):
    # y' = w, y: 0 -> 1, w = 0 at both ends, min integral (dw/dt)^2: by the Euler-Lagrange
    # equation w'' is constant, so w = 6 t (1 - t) and the cost is integral (6 - 12 t)^2 = 12.
    # Quadratic controls (Hermite-Simpson, collocation of degree 3) hold it exactly; the
    # trapezoid's piecewise-linear controls converge at order 2.
    def problem(N):
        return (
            OCP(
                integrator(),
                T=1.0,
                N=N,
                transcription=name,
                degree=degree,
                state_names=("y",),
                control_names=("w",),
            )
            .initial(y=0.0)
            .final(y=1.0)
            .boundary("w0", lambda p: p.w, "start", 0.0, 0.0)
            .boundary("w1", lambda p: p.w, "end", 0.0, 0.0)
            .minimize(integral=lambda p: p.dw**2)
        )

    if name == "trapezoid":
        Ns = [4, 8, 16, 32]
        errors = [abs(problem(N).solve(progress=False, options=TIGHT).cost - 12.0) for N in Ns]
        assert min(errors) > 1e-9 and fitted_order(Ns, errors) >= 2 - 0.3, errors
    else:
        solution = problem(3).solve(progress=False, options=TIGHT)
        assert solution.cost == pytest.approx(12.0, rel=1e-9)
        t = np.linspace(0.0, 1.0, 13)
        np.testing.assert_allclose(solution.control(t)[:, 0], 6 * t * (1 - t), atol=1e-8)


def fitted_order(Ns, errors):
    return -np.polyfit(np.log(Ns), np.log(errors), 1)[0]


LQ_T, LQ_R = 2.0, 0.1


def augmented_riccati_cost() -> float:
    """min integral y^2 + w^2 + r (dw/dt)^2 over [0, T], y' = w, y(0) = 1, w(0) free.

    As an LQ problem in the augmented state (y, w) with control v = dw/dt: P' = -(A'P + PA
    - P B R^-1 B' P + Q), P(T) = 0, integrated by scipy; the cost from the state (1, w0) is
    [1, w0] P(0) [1, w0]', minimised over the free w0: P11 - P12^2 / P22."""
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0]])
    Q = np.eye(2)

    def riccati(_, p):
        P = p.reshape(2, 2)
        return -(A.T @ P + P @ A - P @ B @ B.T @ P / LQ_R + Q).reshape(-1)

    result = solve_ivp(riccati, [LQ_T, 0.0], np.zeros(4), rtol=1e-13, atol=1e-14)
    P = result.y[:, -1].reshape(2, 2)
    return P[0, 0] - P[0, 1] ** 2 / P[1, 1]


# Order of a rate term: the scheme's order, capped at 2 p by controls of degree p (the rate,
# a derivative, loses one order; the cost squares it): trapezoid and degree-2 collocation
# (linear controls) 2, Hermite-Simpson and degree-3 collocation (quadratic) 4.
@pytest.mark.parametrize(
    "name,degree,Ns,order",
    [
        ("trapezoid", None, [4, 8, 16, 32], 2),
        ("hermite-simpson", None, [4, 8, 16, 32], 4),
        ("radau", 2, [8, 16, 32, 64], 2),
        ("radau", 3, [4, 8, 16, 32], 4),
        ("legendre", 2, [4, 8, 16, 32], 2),
        ("legendre", 3, [4, 8, 16, 32], 4),
    ],
)
def test_rate_penalty_converges_to_the_riccati_optimum(name, degree, Ns, order):
    exact = augmented_riccati_cost()
    errors = []
    for N in Ns:
        ocp = (
            OCP(
                integrator(),
                T=LQ_T,
                N=N,
                transcription=name,
                degree=degree,
                state_names=("y",),
                control_names=("w",),
            )
            .initial(y=1.0)
            .minimize(integral=lambda p: p.y**2 + p.w**2 + LQ_R * p.dw**2)
        )
        errors.append(abs(ocp.solve(progress=False, options=TIGHT).cost - exact))
    errors = np.array(errors)
    assert np.all(errors > 1e-11), errors
    assert fitted_order(Ns, errors) >= order - 0.3, errors


# ---- rates at the boundaries and at instants ----------------------------------------------


@pytest.mark.parametrize("name,degree", SCHEMES, ids=SCHEME_IDS)
def test_rates_at_the_boundaries_and_at_an_instant(name, degree):
    # The start and end points read the first and last intervals' slopes, an instant the
    # slope of the interval holding it; each fixed to a value the finite differences find.
    ocp = (
        bounded_rate(name, degree, N=5, limit=None)
        .boundary("start rate", lambda p: p.da, "start", 2.0, 2.0)
        .boundary("end rate", lambda p: p.da, "end", -3.0, -3.0)
        .constrain_at("kick", lambda p: p.da, t=0.53, lower=-20.0, upper=-20.0)
    )
    solution = ocp.solve(progress=False, options=TIGHT)
    _, right = one_sided_slopes(solution, [0.0, 0.53])
    left, _ = one_sided_slopes(solution, [1.0])
    np.testing.assert_allclose([right[0], right[1], left[0]], [2.0, -20.0, -3.0], atol=1e-5)


def test_linkage_torque_rates_are_named_dM():
    from model import presets

    chain = Dynamics(presets.n_link_chain(2))
    down = np.array([-np.pi / 2, -np.pi / 2])
    ocp = (
        OCP(chain, T=1.0, N=6)
        .initial(psi=down, dpsi=[0.0, 0.0])
        .final(psi=down + np.array([0.4, 0.6]), dpsi=[0.0, 0.0])
        .constrain("torque rate", lambda p: p.dM_link1, lower=-2.0, upper=2.0)
        .minimize(integral=lambda p: ca.sumsqr(p.M) + 0.01 * ca.sumsqr(p.dM))
    )
    solution = ocp.solve(progress=False, options=TIGHT)
    rates = solution.control_rate(solution.point_time)
    assert np.max(np.abs(rates[:, 0])) == pytest.approx(2.0, rel=1e-6)
    assert np.max(np.abs(rates[:, 1])) > 2.0  # only link1's rate is bounded


def test_trapezoid_side_rows_only_where_they_differ_from_the_next_nodes_row():
    # The trapezoid's rate is constant per interval: a row reading only the rate at the node
    # ending an interval would repeat the row at the node starting it; a row reading the
    # point too (here v) is a new row there.
    ocp = bounded_rate("trapezoid", None, N=3).constrain(
        "power", lambda p: p.da * p.v, lower=-50.0, upper=50.0
    )
    names = ocp.transcribe().g_names
    assert not any(n.startswith("path[rate]") and "end of interval" in n for n in names)
    assert [n for n in names if n.startswith("path[power]") and "end of" in n] == [
        "path[power] node 1 (end of interval 0)",
        "path[power] node 2 (end of interval 1)",
    ]
