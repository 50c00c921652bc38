"""planner.refinement: mesh refinement to a target, against closed forms.

* Scalar LQ with drift, x' = a x + u, min integral (q x^2 + u^2) (the tests' LQ of
  test_transcription with a = -1 instead of 0: with a = 0 every scheme's polynomials integrate
  x' = u exactly and the re-integration error is zero at once, which is checked too): the
  Riccati solution in closed form, P(tau) = q sinh(l tau) / (l cosh(l tau) - a sinh(l tau)),
  l = sqrt(a^2 + q), so the optimal cost P(T) x0^2 and the optimal state. The per-interval
  error is recomputed by variation of constants (Gauss-Legendre on the exact exponential,
  not the library's integrator); the cost error falls with the target at the rate the scheme's
  order predicts.
* A localised feature: x' = u + b(t), b a narrow Gaussian pulse at t0, x(0) = x(1) = 0, min
  integral u^2: u* = -integral of b (constant) and x* = B(t) - t B(1), B in closed form (erf).
  The refinement splits the intervals at the pulse and nowhere else; the exact per-interval
  error (erf) is within the target.
* Both walking problems at a small size reach a target; the estimate is checked against scipy
  with the Newton-Euler oracle's forward dynamics (not the model).
* The rule (pieces from the order), the history, not reaching the target, bad input.
"""

from __future__ import annotations

import itertools
import math

import casadi as ca
import numpy as np
import pytest
from reference import newton_euler as ne
from scipy.integrate import solve_ivp
from scipy.special import erf

from planner import OCP, Phases, RefinementError, refine_to
from planner.errors import DefinitionError, DefinitionTypeError
from planner.refinement import MAX_SPLIT, SAFETY, split_counts, split_mesh
from problems import periodic_gait, walking_step

TIGHT = {"tol": 1e-12}
LQ_T, LQ_A, LQ_Q = 2.0, -1.0, 1.0


def lq(N, transcription, degree=None, a=LQ_A):
    x, u = ca.SX.sym("x"), ca.SX.sym("u")
    ode = ca.Function("f", [x, u], [a * x + u], ["x", "u"], ["xdot"])
    return (
        OCP(
            ode,
            T=LQ_T,
            N=N,
            transcription=transcription,
            degree=degree,
            state_names=("y",),
            control_names=("w",),
        )
        .initial(y=1.0)
        .minimize(integral=lambda p: LQ_Q * p.y**2 + p.w**2)
    )


def lq_optimum(a=LQ_A, q=LQ_Q, T=LQ_T):
    """(optimal cost, optimal state x*(t)) from the closed-form Riccati solution."""
    lam = math.sqrt(a * a + q)

    def g(tau):
        return lam * np.cosh(lam * tau) - a * np.sinh(lam * tau)

    return q * math.sinh(lam * T) / g(T), lambda t: g(T - np.asarray(t)) / g(T)


def lq_interval_errors(solution, a=LQ_A):
    """(N,) |x(t_k+1) - x_k+1| with x from x_k under the solution's control, by variation of
    constants: x(t1) = e^{a h} x_k + integral e^{a (t1 - s)} u(s) ds (Gauss-Legendre, 20
    points: exact to round-off for the polynomial control times the exponential)."""
    nodes, weights = np.polynomial.legendre.leggauss(20)
    errors = []
    for k in range(solution.N):
        t0, t1 = solution.time[k], solution.time[k + 1]
        h = t1 - t0
        s = t0 + (nodes + 1) / 2 * h
        u = solution.control(s)[:, 0]
        end = math.exp(a * h) * solution.states[k, 0] + h / 2 * np.sum(
            weights * np.exp(a * (t1 - s)) * u
        )
        errors.append(abs(end - solution.states[k + 1, 0]))
    return np.array(errors)


# ---- the rule ---------------------------------------------------------------------------------
def test_split_counts_follow_the_order_and_the_caps():
    target = 1e-6
    # Hermite-Simpson (order 4, local error ~ h^5): (e / (SAFETY target))^(1/5), by hand:
    # 4e-6 / 5e-7 = 8 -> 8^0.2 = 1.516 -> 2; 1e-3 / 5e-7 = 2000 -> 4.57 -> 5; 1e6 x -> capped.
    assert SAFETY == 0.5 and MAX_SPLIT == 8
    counts = split_counts(np.array([0.5e-6, 1e-6, 4e-6, 1e-3, 1.0]), target, order=4)
    np.testing.assert_array_equal(counts, [1, 1, 2, 5, 8])
    # trapezoid (order 2, h^3): 1e-4 / 5e-7 = 200 -> 5.85 -> 6
    np.testing.assert_array_equal(split_counts(np.array([1e-4]), target, order=2), [6])
    # just over the target: at least two pieces
    np.testing.assert_array_equal(split_counts(np.array([1.0001e-6]), target, order=9), [2])


def test_split_mesh_keeps_the_breaks_and_divides_evenly():
    fractions = np.array([0.5, 0.25, 0.25])
    mesh = split_mesh(fractions, np.array([1, 3, 2]))
    np.testing.assert_allclose(mesh, [0.5, 0.25 / 3, 0.25 / 3, 0.25 / 3, 0.125, 0.125])
    breaks = np.concatenate([[0.0], np.cumsum(mesh)])
    for old in np.cumsum(fractions):
        assert np.min(np.abs(breaks - old)) < 1e-15  # every old node stays a node


# ---- a problem with a known solution ----------------------------------------------------------
@pytest.mark.parametrize(
    "name,degree,order",
    [("trapezoid", None, 2), ("hermite-simpson", None, 4), ("radau", 3, 5), ("legendre", 2, 4)],
)
def test_lq_reaches_the_target_and_converges_to_the_closed_form(name, degree, order):
    exact_cost, exact_state = lq_optimum()
    cost_errors = []
    for target in (1e-5, 1e-7):
        solution = lq(2, name, degree).solve(
            accuracy=target, progress=False, options=TIGHT, max_passes=10
        )
        history = solution.stats["refinement"]
        assert history.reached and history.errors[-1] <= target
        assert len(history.passes) >= 2 and history.sizes[0] == 2  # it had to refine
        # the error per interval by variation of constants (scale 1: y has no bounds)
        exact = lq_interval_errors(solution)
        assert exact.max() <= target
        # CVODES at rtol = atol = 1e-12 over the interval: a few 1e-11
        np.testing.assert_allclose(history.passes[-1].interval_errors, exact, atol=5e-11)
        cost_errors.append(abs(solution.cost - exact_cost))
        # the state follows the closed-form optimum (global error: a sum of local ones plus
        # the control's own discretisation error, so above the per-interval target)
        assert np.abs(solution.states[:, 0] - exact_state(solution.time)).max() < 1e-3
    # 100 times tighter target: local error ~ h^(p+1), cost error ~ h^p, so the cost error
    # falls by 100^(p/(p+1)) (21 for the trapezoid, 40-46 for the others); at least 10
    assert cost_errors[0] / cost_errors[1] >= 10, (cost_errors, order)


def test_dynamics_integrated_exactly_need_no_refinement():
    # x' = u: every scheme's state polynomial integrates its control polynomial exactly, so
    # the estimate is at round-off on the first mesh and nothing is split, however coarse.
    solution = lq(2, "hermite-simpson", a=0.0).solve(accuracy=1e-9, progress=False, options=TIGHT)
    history = solution.stats["refinement"]
    assert history.sizes == [2] and history.reached and history.passes[0].split == 0


# ---- a localised feature ----------------------------------------------------------------------
PULSE_T0, PULSE_WIDTH = 0.6, 0.03


def pulse_ocp(N, transcription):
    x, u, t = ca.SX.sym("x"), ca.SX.sym("u"), ca.SX.sym("t")
    pulse = ca.exp(-(((t - PULSE_T0) / PULSE_WIDTH) ** 2))
    ode = ca.Function("f", [x, u, t], [u + pulse], ["x", "u", "t"], ["xdot"])
    return (
        OCP(ode, T=1.0, N=N, transcription=transcription, state_names=("q",), control_names=("a",))
        .initial(q=0.0)
        .final(q=0.0)
        .minimize(integral=lambda p: p.a**2)
    )


def pulse_integral(t):
    """B(t) = integral_0^t exp(-((s - t0)/w)^2) ds."""
    w = PULSE_WIDTH
    return w * math.sqrt(math.pi) / 2 * (erf((np.asarray(t) - PULSE_T0) / w) + erf(PULSE_T0 / w))


@pytest.mark.parametrize("name", ["trapezoid", "hermite-simpson"])
def test_refinement_concentrates_at_a_localised_feature(name):
    target = 1e-6
    solution = pulse_ocp(8, name).solve(accuracy=target, progress=False, options=TIGHT)
    history = solution.stats["refinement"]
    assert history.reached and len(history.passes) >= 2
    lengths = solution.interval_lengths
    middle = (solution.time[:-1] + solution.time[1:]) / 2
    at_pulse = np.abs(middle - PULSE_T0) < 2 * PULSE_WIDTH
    far = np.abs(middle - PULSE_T0) > 5 * PULSE_WIDTH
    # far from the pulse the first mesh (h = 1/8) is untouched; at the pulse it is split
    np.testing.assert_allclose(lengths[far], 1 / 8, rtol=1e-12)
    assert lengths[at_pulse].max() <= lengths[far].min() / 5
    # the exact error of each interval: q(t1) - q(t0) = integral of u + B(t1) - B(t0)
    nodes, weights = np.polynomial.legendre.leggauss(8)  # u is a polynomial of degree <= 2
    exact = []
    for k in range(solution.N):
        t0, t1 = solution.time[k], solution.time[k + 1]
        s = t0 + (nodes + 1) / 2 * (t1 - t0)
        rise = (t1 - t0) / 2 * weights @ solution.control(s)[:, 0]
        end = solution.states[k, 0] + rise + pulse_integral(t1) - pulse_integral(t0)
        exact.append(abs(end - solution.states[k + 1, 0]))
    assert max(exact) <= target
    np.testing.assert_allclose(history.passes[-1].interval_errors, exact, atol=1e-10)
    # the optimum: u* = -B(1) (constant), x* = B(t) - t B(1)
    np.testing.assert_allclose(solution.controls[:, 0], -pulse_integral(1.0), rtol=1e-3)
    np.testing.assert_allclose(
        solution.states[:, 0],
        pulse_integral(solution.time) - solution.time * pulse_integral(1.0),
        atol=20 * target,
    )


# ---- the walking problems -------------------------------------------------------------------
def _check_with_the_oracle(solution, linkage, intervals):
    """The per-interval re-integration error of ``intervals`` again: scipy (DOP853) on the
    Newton-Euler oracle's forward dynamics, the solution's control polynomial per interval."""
    n = linkage.n
    scales = np.array([solution.ocp.variable_scale(name) for name in solution.state_names])
    found = []
    for k in intervals:
        t0, t1 = solution.time[k], solution.time[k + 1]

        def rhs(t, x, t0=t0, t1=t1):
            inside = min(max(t, t0 + 1e-12 * (t1 - t0)), t1 - 1e-12 * (t1 - t0))
            torques = solution.control([inside])[0, :n]
            return np.concatenate([x[n:], ne.forward_dynamics(linkage, x[:n], x[n:], torques)])

        result = solve_ivp(rhs, (t0, t1), solution.states[k], "DOP853", rtol=1e-11, atol=1e-11)
        found.append(np.max(np.abs(result.y[:, -1] - solution.states[k + 1]) / scales))
    return np.array(found)


@pytest.mark.parametrize("problem", ["walking step", "fixed-base gait"])
def test_walking_problems_reach_the_target(problem):
    target = 1e-3
    if problem == "walking step":
        small = walking_step(N=10)
    else:
        small = periodic_gait(N=12)
    gait = small.solve(accuracy=target, progress=False)
    solution = gait.solution
    history = solution.stats["refinement"]
    assert history.reached and history.errors[-1] <= target
    assert history.sizes[0] == small.ocp.N and solution.N > small.ocp.N
    assert np.all(np.diff(history.sizes) > 0)
    # The gait is the refined one with its limits held between the points (a re-solve
    # with some bounds backed off): its own error is measured again, within the target,
    # and checked against the oracle on its worst intervals.
    scales = np.array([solution.ocp.variable_scale(name) for name in solution.state_names])
    errors = np.max(solution.integration_error().per_interval / scales, axis=1)
    assert solution.stats["error_after_limits"] == pytest.approx(errors.max(), rel=1e-12)
    assert errors.max() <= target
    worst = np.argsort(errors)[-3:]
    np.testing.assert_allclose(
        _check_with_the_oracle(solution, small.linkage, worst),
        errors[worst],
        rtol=1e-4,
        atol=1e-9,
    )
    # the law's benchmark cost is taken on the final mesh; the gait verifies in numpy
    assert gait.law_cost > 100 * gait.cost
    assert gait.verify().ok


# ---- history, failure, bad input ------------------------------------------------------------
def test_history_records_every_pass_and_its_mesh():
    solution = pulse_ocp(4, "hermite-simpson").solve(accuracy=1e-5, progress=False, options=TIGHT)
    history = solution.stats["refinement"]
    passes = history.passes
    assert history.sizes == [p.N for p in passes] and history.sizes[0] == 4
    for before, after in itertools.pairwise(passes):
        counts = split_counts(before.interval_errors, 1e-5, order=4)
        assert after.N == counts.sum() and before.split == np.count_nonzero(counts > 1)
        np.testing.assert_allclose(after.mesh, split_mesh(before.mesh, counts), rtol=1e-12)
    for p in passes:
        assert p.mesh.sum() == pytest.approx(1.0) and p.interval_errors.shape == (p.N,)
        assert p.iterations > 0 and p.solve_seconds > 0 and p.estimate_seconds > 0
    assert history.iterations == sum(p.iterations for p in passes)
    assert history.seconds == pytest.approx(sum(p.seconds for p in passes))
    np.testing.assert_allclose(solution.interval_lengths, passes[-1].mesh * solution.T)
    table = history.table()
    assert "reached" in table and len(table.splitlines()) == 2 + len(passes)


def test_a_target_not_reached_raises_or_returns_with_the_flag():
    ocp = pulse_ocp(4, "trapezoid")
    with pytest.raises(RefinementError, match=r"target 1\.0e-08 was not reached: max_passes = 2"):
        ocp.solve(accuracy=1e-8, max_passes=2, progress=False, options=TIGHT)
    try:
        ocp.solve(accuracy=1e-8, max_passes=2, progress=False, options=TIGHT)
    except RefinementError as error:
        assert len(error.history.passes) == 2 and not error.history.reached
        assert error.solution.N == error.history.sizes[-1]
    solution = refine_to(ocp, 1e-8, max_intervals=30, raise_on_failure=False, progress=False)
    history = solution.stats["refinement"]
    assert not history.reached and "max_intervals = 30" in history.reason
    assert solution.success and solution.N <= 30


@pytest.mark.parametrize(
    "accuracy,error,message",
    [
        (0.0, DefinitionError, r"`accuracy`: must lie in \[1e-09, 1\)"),
        (-1e-3, DefinitionError, r"`accuracy`: must lie in"),
        (1e-12, DefinitionError, r"below 1e-09 the re-integration"),
        (2.0, DefinitionError, r"`accuracy`: must lie in"),
        (float("nan"), DefinitionError, r"`accuracy`: must lie in"),
        (True, DefinitionTypeError, r"`accuracy`: must be a number"),
        ("fine", DefinitionTypeError, r"`accuracy`: must be a number"),
    ],
)
def test_bad_targets_raise_at_once(accuracy, error, message):
    with pytest.raises(error, match=message):
        pulse_ocp(4, "trapezoid").solve(accuracy=accuracy)


def test_bad_refinement_settings_raise_at_once():
    ocp = pulse_ocp(4, "trapezoid")
    with pytest.raises(DefinitionError, match="`max_passes`: must be >= 1, got 0"):
        ocp.solve(accuracy=1e-4, max_passes=0)
    with pytest.raises(DefinitionError, match=r"`max_intervals`: the first mesh already has N = 4"):
        ocp.solve(accuracy=1e-4, max_intervals=3)
    with pytest.raises(DefinitionError, match="`guess`: not with accuracy"):
        ocp.solve(accuracy=1e-4, guess=np.zeros(3))
    with pytest.raises(DefinitionTypeError, match="`raise_on_failure`: must be True or False"):
        ocp.solve(accuracy=1e-4, raise_on_failure="yes")
    with pytest.raises(DefinitionTypeError, match=r"takes a single-phase planner\.OCP, got Phases"):
        refine_to(Phases.sequence(("a", ocp)), 1e-4)
