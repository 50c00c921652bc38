"""planner.simulation: the one interval simulator, against closed-form solutions.

Independent checks: polynomial controls integrated exactly (the integral of a polynomial in
closed form), a time-varying linear ODE against its closed-form solution, a DAE whose
algebraic equation has a known root, the quadrature of u^2 in closed form, the monomial
coefficients against numpy's polynomial fit, and every failure path by its message.
"""

from __future__ import annotations

import itertools

import casadi as ca
import numpy as np
import pytest

from planner.errors import DefinitionError, DefinitionTypeError
from planner.simulation import (
    METHODS,
    MIN_TOLERANCE,
    SimulationError,
    Simulator,
    monomial_coefficients,
    tolerance_problem,
)

NAMES = ["x", "z", "u", "t"]


def function(name, x, z, u, t, expression):
    return ca.Function(name, [x, z, u, t], [expression], NAMES, ["out"])


def symbols(nx=1, nz=0, nu=1):
    return ca.SX.sym("x", nx), ca.SX.sym("z", nz), ca.SX.sym("u", nu), ca.SX.sym("t")


def integrator_of_u(**options) -> Simulator:
    """x' = u(t), with the quadratures u and u^2."""
    x, z, u, t = symbols()
    return Simulator(
        function("rate", x, z, u, t, u),
        None,
        function("q", x, z, u, t, ca.vertcat(u, u**2)),
        degree=3,
        **options,
    )


#: Three intervals of unequal length.
GRID = np.array([0.2, 0.5, 0.6, 1.3])
#: A cubic on each, u(t_a + h tau) = C [1, tau, tau^2, tau^3], jumping at the grid points.
JUMPING = np.array([[[1.0, -2.0, 0.5, 3.0]], [[0.3, 0.0, -1.0, 2.0]], [[-2.0, 1.5, 0.0, -0.7]]])
#: One cubic over the whole grid, u(t) = 1 - 2 t + 0.5 t^2 + 3 t^3, in each interval's tau.
GLOBAL = np.polynomial.Polynomial([1.0, -2.0, 0.5, 3.0])


def continuous_coefficients(grid):
    """(M, 1, 4) coefficients in tau of GLOBAL on each interval of ``grid``."""
    rows = []
    for a, b in itertools.pairwise(grid):
        local = GLOBAL(np.polynomial.Polynomial([a, b - a]))  # p(a + h tau)
        rows.append([np.pad(local.coef, (0, 4 - local.coef.size))])
    return np.array(rows)


def exact_integrals(grid, coefficients):
    """Integral of u and of u^2 over each interval, in closed form (numpy polynomials)."""
    h = np.diff(grid)
    first, second = [], []
    for k in range(h.size):
        p = np.polynomial.Polynomial(coefficients[k, 0])
        first.append(h[k] * (p.integ()(1.0) - p.integ()(0.0)))
        second.append(h[k] * ((p * p).integ()(1.0) - (p * p).integ()(0.0)))
    return np.array(first), np.array(second)


@pytest.mark.parametrize("method", ["cvodes", "idas", "rk", "collocation"])
@pytest.mark.parametrize("restart", [False, True])
def test_polynomial_controls_are_integrated_exactly_along_a_grid(method, restart):
    # One cvodes/idas run crosses the grid only where the control is continuous; a control
    # that jumps at the grid points needs the restart at each (as a solution's collocation
    # controls may).
    coefficients = JUMPING if restart else continuous_coefficients(GRID)
    simulator = integrator_of_u(method=method, rtol=1e-12, atol=1e-12, steps=4)
    run = simulator.along([0.7], GRID, coefficients, restart=restart)
    increments, squares = exact_integrals(GRID, coefficients)
    if not restart:
        whole = GLOBAL.integ()
        np.testing.assert_allclose(increments, np.diff(whole(GRID)), rtol=1e-13)
    expected = 0.7 + np.concatenate([[0.0], np.cumsum(increments)])
    # rk4 and Radau collocation are exact for polynomials of this degree; cvodes, idas to tol
    tolerance = 1e-9 if method in ("cvodes", "idas") else 1e-13
    np.testing.assert_allclose(run.states[:, 0], expected, atol=tolerance)
    # the quadrature of u over each interval is the state's increment
    np.testing.assert_allclose(run.quadrature[:, 0], increments, atol=tolerance)
    if method in ("rk", "collocation"):
        # u^2 (degree 6) by the fixed steps converges at the method's order as steps double:
        # rk4 is Simpson's rule on a quadrature (order 4), Radau of 3 points order 5
        finer = integrator_of_u(method=method, steps=8).along(
            [0.7], GRID, coefficients, restart=restart
        )
        coarse_error = np.abs(run.quadrature[:, 1] - squares)
        fine_error = np.abs(finer.quadrature[:, 1] - squares)
        assert np.all(coarse_error > 1e-11)  # measurable, so that the slope means something
        slopes = np.log2(coarse_error / fine_error)
        assert np.all(slopes >= (4 if method == "rk" else 5) - 0.3), slopes


@pytest.mark.parametrize(("steps", "calls"), [(4, 1), (8, 1), (400, 5), (2000, 20)])
def test_progress_comes_as_often_when_the_steps_grow(steps, calls):
    # A one-step chain takes 1600 finite elements per call: 20 intervals of 4 or 8 steps in one
    # call, of 400 steps in blocks of 4, of 2000 steps one by one; the split changes nothing
    # (rk4 is exact for the cubic control).
    grid = np.linspace(0.0, 1.0, 21)
    reports = []
    run = integrator_of_u(method="rk", steps=steps).along(
        [0.7], grid, continuous_coefficients(grid), progress=lambda f, t: reports.append((f, t))
    )
    expected = 0.7 + GLOBAL.integ()(grid) - GLOBAL.integ()(grid[0])
    np.testing.assert_allclose(run.states[:, 0], expected, atol=1e-13)
    fractions, reached = np.array(reports).T
    assert len(reports) == calls
    np.testing.assert_allclose(fractions, np.arange(1, calls + 1) / calls, rtol=0, atol=1e-15)
    np.testing.assert_allclose(reached, grid[:: 20 // calls][1:], rtol=0, atol=1e-15)


def test_independent_intervals_restart_from_their_own_states():
    simulator = integrator_of_u(rtol=1e-12, atol=1e-12)
    starts = np.array([[0.0], [5.0], [-1.0]])
    parameters = simulator.parameters(GRID[:-1], np.diff(GRID), JUMPING)
    run = simulator.across(starts, parameters)
    increments, _ = exact_integrals(GRID, JUMPING)
    np.testing.assert_allclose(run.states[:, 0], starts[:, 0] + increments, atol=1e-9)
    np.testing.assert_allclose(run.quadrature[:, 0], increments, atol=1e-9)
    assert run.algebraic.shape == (3, 0) and run.quadrature.shape == (3, 2)


@pytest.mark.parametrize("restart", [False, True])
def test_a_time_varying_ode_against_its_closed_form(restart):
    # x' = -x + sin t with u = 0: x(t) = (x0 + 1/2) e^{-t} + (sin t - cos t) / 2. The rate
    # reads t itself, so the interval's start and length must map tau to the right time.
    x, z, u, t = symbols()
    simulator = Simulator(
        function("rate", x, z, u, t, -x + ca.sin(t) + u), degree=0, rtol=1e-12, atol=1e-12
    )
    grid = np.linspace(0.0, 3.0, 451)  # more intervals than a block of the chain (200)
    coefficients = np.zeros((450, 1, 1))
    fractions = []
    run = simulator.along(
        [2.0], grid, coefficients, restart=restart, progress=lambda f, t: fractions.append((f, t))
    )
    exact = 2.5 * np.exp(-grid) + 0.5 * (np.sin(grid) - np.cos(grid))
    np.testing.assert_allclose(run.states[:, 0], exact, atol=1e-9)
    assert fractions[-1] == (1.0, 3.0)
    assert len(fractions) == (3 if restart else 1)  # blocks of 200 intervals, or one of 1000


@pytest.mark.parametrize("method", ["idas", "collocation"])
def test_a_dae_against_its_closed_form(method):
    # x' = z, 0 = z^3 + (x - u)^3: z = u - x, so with u = 1 on every interval
    # x(t) = 1 + (x0 - 1) e^{-t}
    x, z, u, t = symbols(nz=1)
    simulator = Simulator(
        function("rate", x, z, u, t, z),
        function("residual", x, z, u, t, z**3 + (x - u) ** 3),
        degree=0,
        method=method,
        rtol=1e-12,
        atol=1e-12,
        steps=20,
    )
    grid = np.linspace(0.0, 2.0, 11)
    coefficients = np.ones((10, 1, 1))
    guesses = np.zeros((10, 1))  # consistent z is made from a poor guess at each start
    run = simulator.along([3.0], grid, coefficients, guesses, restart=True)
    exact = 1.0 + 2.0 * np.exp(-grid)
    np.testing.assert_allclose(run.states[:, 0], exact, atol=1e-6 if method == "idas" else 1e-7)
    np.testing.assert_allclose(run.algebraic[1:, 0], 1.0 - exact[1:], atol=1e-5)


def test_monomial_coefficients_against_numpys_fit():
    rng = np.random.default_rng(3)
    points = np.array([0.0, 0.155, 0.645, 1.0])
    values = rng.normal(size=(5, 4, 2))
    coefficients = monomial_coefficients(points, values)
    assert coefficients.shape == (5, 2, 4)
    for k in range(5):
        for i in range(2):
            fit = np.polynomial.polynomial.polyfit(points, values[k, :, i], 3)
            np.testing.assert_allclose(coefficients[k, i], fit, atol=1e-11)


def blowing_up(method, **options) -> Simulator:
    # x' = x^2 from x = 10 reaches infinity at t = 0.1 (from 1e200 at once, in floats)
    x, z, u, t = symbols()
    return Simulator(function("rate", x, z, u, t, x**2 + u), degree=0, method=method, **options)


@pytest.mark.parametrize("method", ["cvodes", "idas"])
def test_a_failure_names_the_interval_and_the_sundials_flag(method, capfd):
    grid = np.array([0.0, 0.05, 0.2, 0.3])
    with pytest.raises(SimulationError) as caught:
        blowing_up(method).along([10.0], grid, np.zeros((3, 1, 1)))
    error = caught.value
    prefix = "CV" if method == "cvodes" else "IDA"
    assert error.flag.startswith(prefix + "_")
    assert error.index == 1 and error.interval == (0.05, 0.2) and error.method == method
    assert str(error).startswith(
        f"integrator '{method}' failed between t = 0.05 s and t = 0.2 s: {error.flag} ("
    )
    assert capfd.readouterr().err == ""  # SUNDIALS' own words are in error.details only
    parameters = blowing_up(method).parameters(grid[:-1], np.diff(grid), np.zeros((3, 1, 1)))
    with pytest.raises(SimulationError, match=r"between t = 0.05 s and t = 0.2 s") as caught:
        blowing_up(method).across(np.array([[1.0], [10.0], [1.0]]), parameters)
    assert caught.value.index == 1


def test_a_fixed_step_method_that_diverges_names_the_interval():
    with pytest.raises(
        SimulationError,
        match=r"^integrator 'rk' failed between t = 0 s and t = 0.5 s: the state became "
        r"non-finite; the motion diverges",
    ) as caught:
        blowing_up("rk", steps=2).along([1e200], np.array([0.0, 0.5, 1.0]), np.zeros((2, 1, 1)))
    assert caught.value.flag is None and caught.value.index == 0


def test_bad_options_are_refused_by_name():
    x, z, u, t = symbols(nz=1)
    rate = function("rate", x, z, u, t, z)
    residual = function("residual", x, z, u, t, z + x)
    with pytest.raises(DefinitionError, match=r"`method`: unknown integrator 'euler'; choose one"):
        Simulator(rate, degree=0, method="euler")
    with pytest.raises(DefinitionError, match=r"`method`: 'cvodes' integrates ODEs only; a DAE"):
        Simulator(rate, residual, degree=0, method="cvodes")
    with pytest.raises(DefinitionError, match=r"`degree`: must be >= 0, got -1"):
        Simulator(rate, residual, degree=-1, method="idas")
    with pytest.raises(DefinitionError, match=r"`steps`: must be >= 1, got 0"):
        Simulator(rate, residual, degree=0, method="collocation", steps=0)
    with pytest.raises(DefinitionError, match=r"`rtol`: must lie in \[1e-14, 1\), got 1e-15"):
        Simulator(rate, residual, degree=0, method="idas", rtol=1e-15)
    with pytest.raises(DefinitionTypeError, match=r"`rate`: must be a casadi.Function"):
        Simulator(lambda x: x, degree=0)
    with pytest.raises(DefinitionError, match=r"`residual`: must take the four inputs"):
        Simulator(rate, ca.Function("r", [x], [x]), degree=0, method="idas")
    assert set(METHODS) == {"cvodes", "idas", "rk", "collocation"}


@pytest.mark.parametrize(
    ("value", "fix"),
    [
        (1.0, "give a tolerance such as 1e-10"),
        (1e-16, "below 1e-14 cvodes/idas cannot deliver"),
        (0.0, "a tolerance is a small positive number"),
        (-1e-3, "a tolerance is a small positive number"),
    ],
)
def test_tolerance_problems_say_the_range_and_the_fix(value, fix):
    problem = tolerance_problem(value)
    assert problem.startswith(f"must lie in [{MIN_TOLERANCE:g}, 1), got {value!r}; ")
    assert fix in problem
    assert tolerance_problem(MIN_TOLERANCE) is None and tolerance_problem(0.5) is None
