"""Transcriptions: bases and quadrature, defects on a separate code path, NLP derivatives
against finite differences, and convergence orders on problems with known optima."""

from __future__ import annotations

import dataclasses
import inspect

import casadi as ca
import numpy as np
import pytest

from model import Dynamics, presets
from planner import OCP, Transcription, make_scheme
from planner.collocation import (
    collocation_roots,
    integration_weights,
    lagrange_matrix,
)
from planner.ocp import OCPDefinition
from planner.resolved_definition import ResolvedDefinition
from planner.solver import nlp_solver

# ---- independent helpers (numpy, product formulas; no planner code) -------------------------


def product_basis(points, tau):
    """l_j(tau) by the product formula, (K, m)."""
    points = np.asarray(points, float)
    tau = np.atleast_1d(tau)
    out = np.ones((tau.size, points.size))
    for j, pj in enumerate(points):
        for i, pi in enumerate(points):
            if i != j:
                out[:, j] *= (tau - pi) / (pj - pi)
    return out


def product_basis_derivative(points, tau):
    """dl_j/dtau by the product rule of the product formula, (K, m)."""
    points = np.asarray(points, float)
    tau = np.atleast_1d(tau)
    m = points.size
    out = np.zeros((tau.size, m))
    for j in range(m):
        others = [i for i in range(m) if i != j]
        denominator = np.prod([points[j] - points[i] for i in others])
        for skip in others:
            term = np.ones(tau.size)
            for i in others:
                if i != skip:
                    term *= tau - points[i]
            out[:, j] += term
        out[:, j] /= denominator
    return out


def double_integrator():
    x = ca.SX.sym("x", 2)
    u = ca.SX.sym("u")
    return ca.Function("f", [x, u], [ca.vertcat(x[1], u)], ["x", "u"], ["xdot"])


def scalar_integrator():
    x = ca.SX.sym("x")
    u = ca.SX.sym("u")
    return ca.Function("f", [x, u], [u], ["x", "u"], ["xdot"])


def min_energy(N, transcription, degree=None):
    """Rest-to-rest q: 0 -> 1 in T = 1, min integral u^2: u = 6 - 12 t, cost 12."""
    return (
        OCP(
            double_integrator(),
            T=1.0,
            N=N,
            transcription=transcription,
            degree=degree,
            state_names=("q", "v"),
            control_names=("a",),
        )
        .initial(q=0.0, v=0.0)
        .final(q=1.0, v=0.0)
        .minimize(integral=lambda p: p.a**2)
    )


LQ_T = 2.0


def scalar_lq(N, transcription, degree=None):
    """x' = u, x(0) = 1, min integral (x^2 + u^2) over [0, T]: Riccati P' = P^2 - 1,
    P(T) = 0, so P(t) = tanh(T - t) and the optimal cost is P(0) x0^2 = tanh(T)."""
    return (
        OCP(
            scalar_integrator(),
            T=LQ_T,
            N=N,
            transcription=transcription,
            degree=degree,
            state_names=("y",),
            control_names=("w",),
        )
        .initial(y=1.0)
        .minimize(integral=lambda p: p.y**2 + p.w**2)
    )


TIGHT = {"tol": 1e-13}

# ---- bases and quadrature ---------------------------------------------------------------


@pytest.mark.parametrize("family", ["radau", "legendre"])
@pytest.mark.parametrize("degree", range(1, 10))
def test_lagrange_basis_matches_product_formula(family, degree):
    roots = collocation_roots(family, degree)
    points = np.append(0.0, roots)
    tau = np.linspace(0.0, 1.0, 23)
    np.testing.assert_allclose(
        lagrange_matrix(points, tau), product_basis(points, tau), atol=1e-9, rtol=0
    )
    np.testing.assert_allclose(
        lagrange_matrix(points, tau, 1),
        product_basis_derivative(points, tau),
        atol=1e-7 * max(1.0, np.abs(product_basis_derivative(points, tau)).max()),
        rtol=0,
    )


@pytest.mark.parametrize("degree", range(1, 10))
def test_collocation_roots_and_quadrature_exactness(degree):
    radau = collocation_roots("radau", degree)
    legendre = collocation_roots("legendre", degree)
    assert radau[-1] == 1.0 and np.all(np.diff(radau) > 0) and radau[0] > 0
    assert 0 < legendre[0] and legendre[-1] < 1
    # Gauss: exact to degree 2d - 1; right Radau: exact to 2d - 2.
    for roots, exact_to in ((legendre, 2 * degree - 1), (radau, 2 * degree - 2)):
        weights = integration_weights(roots)
        for power in range(exact_to + 1):
            assert weights @ roots**power == pytest.approx(1.0 / (power + 1), abs=1e-10)


def test_schemes_reproduce_classical_formulas():
    hs = make_scheme("hermite-simpson")
    np.testing.assert_allclose(hs.quadrature, [1 / 6, 4 / 6, 1 / 6])
    radau1 = make_scheme("radau", 1)  # backward Euler: x1 - x0 - h f1 = 0
    np.testing.assert_allclose(radau1.A, [[-1.0, 1.0]])
    np.testing.assert_allclose(radau1.B, [[1.0]])
    legendre1 = make_scheme("legendre", 1)  # implicit midpoint
    np.testing.assert_allclose(legendre1.dyn_tau, [0.5])


# ---- defects recomputed independently ---------------------------------------------------


def numpy_defects(scheme_name, degree, X, U, h, N):
    """Defects of the double integrator (f = [v, u]) by textbook formulas, (N, r, 2)."""

    def f(x, u):
        return np.array([x[1], u])

    rows = []
    if scheme_name == "trapezoid":
        for k in range(N):
            x0, x1 = X[k], X[k + 1]
            rows.append([x1 - x0 - h / 2 * (f(x0, U[k]) + f(x1, U[k + 1]))])
    elif scheme_name == "hermite-simpson":
        for k in range(N):
            x0, xm, x1 = X[2 * k], X[2 * k + 1], X[2 * k + 2]
            f0, fm, f1 = f(x0, U[2 * k]), f(xm, U[2 * k + 1]), f(x1, U[2 * k + 2])
            rows.append(
                [xm - (x0 + x1) / 2 - h / 8 * (f0 - f1), x1 - x0 - h / 6 * (f0 + 4 * fm + f1)]
            )
    else:
        roots = collocation_roots(scheme_name, degree)
        points = np.append(0.0, roots)
        slopes = product_basis_derivative(points, roots)  # (d, d+1)
        d = degree
        per = d if scheme_name == "radau" else d + 1
        for k in range(N):
            xs = X[k * per : k * per + d + 1]
            us = U[k * d : (k + 1) * d]
            interval = [slopes[r] @ xs - h * f(xs[r + 1], us[r]) for r in range(d)]
            if scheme_name == "legendre":
                end = product_basis(points, [1.0])[0] @ xs
                interval.append(X[(k + 1) * per] - end)
            rows.append(interval)
    return np.array(rows)


@pytest.mark.parametrize(
    "name,degree",
    [("trapezoid", None), ("hermite-simpson", None), ("radau", 1), ("radau", 3), ("legendre", 2)],
)
def test_defects_match_textbook_formulas_at_random_points(name, degree):
    N = 4
    transcription = Transcription(min_energy(N, name, degree))
    g_function = ca.Function("g", [transcription.nlp["x"]], [transcription.nlp["g"]])
    rng = np.random.default_rng(3)
    w = rng.normal(size=transcription.n_w)
    g = np.asarray(g_function(w)).reshape(-1)
    values = transcription.unpack(w)
    expected = numpy_defects(name, degree, values["X"], values["U"][:, 0], 1.0 / N, N)
    rows = [i for i, row in enumerate(transcription.g_names) if row.startswith("defect[")]
    got = g[rows] * transcription.g_scale[rows]
    assert len(rows) == expected.size
    np.testing.assert_allclose(got, expected.reshape(-1), atol=1e-12)


def test_row_and_variable_names_are_complete_and_unique():
    ocp = (
        OCP(Dynamics(presets.n_link_chain(2)), T=1.0, N=3)
        .constrain("tilt", lambda p: p.psi_link1 - p.psi_link2, lower=-1, upper=1)
        .periodic()
        .minimize(integral=lambda p: ca.sumsqr(p.M))
    )
    transcription = Transcription(ocp)
    assert len(transcription.g_names) == transcription.n_g == transcription.nlp["g"].size1()
    assert len(set(transcription.g_names)) == transcription.n_g
    assert len(set(transcription.w_names)) == transcription.n_w == transcription.nlp["x"].size1()
    assert "defect[psi_link1] interval 2 (end)" in transcription.g_names
    assert "dynamics[link2] interval 1 midpoint" in transcription.g_names
    assert "path[tilt] node 3" in transcription.g_names
    assert "periodic[dpsi_link2]" in transcription.g_names
    assert "bound[M_link1] node 0" in transcription.w_names


def test_hermite_simpson_cost_is_simpsons_rule_with_the_midpoint_variables():
    # integral (y^2 + w^2) ~= h/6 sum (L(x_k, u_k) + 4 L(x_m, u_m) + L(x_k+1, u_k+1)), with the
    # midpoint state and control the NLP's own variables (not averages of the nodes)
    N = 3
    transcription = Transcription(scalar_lq(N, "hermite-simpson"))
    w = np.random.default_rng(5).normal(size=transcription.n_w)
    f = float(ca.Function("f", [transcription.nlp["x"]], [transcription.nlp["f"]])(w))
    values = transcription.unpack(w)
    y, u = values["X"][:, 0], values["U"][:, 0]
    L = y**2 + u**2
    h = LQ_T / N
    expected = sum(h / 6 * (L[2 * k] + 4 * L[2 * k + 1] + L[2 * k + 2]) for k in range(N))
    assert f == pytest.approx(expected, rel=1e-14)


# ---- path constraints where no dynamics point lies -----------------------------------------


def floor_problem(transcription, degree, floor=lambda p: p.q):
    """Double integrator, v(0) = 1, v(1) = -1, q >= 0, min integral a^2 + 10 (q(0) + q(1)).
    Optimum: a = -2 (the least integral a^2 with integral a = -2), q = t - t^2 (the lowest
    start that keeps q >= 0), cost 4; the floor binds at both ends of the horizon."""
    return (
        OCP(
            double_integrator(),
            T=1.0,
            N=4,
            transcription=transcription,
            degree=degree,
            state_names=("q", "v"),
            control_names=("a",),
        )
        .initial(v=1.0)
        .final(v=-1.0)
        .constrain("floor", floor, lower=0.0)
        .minimize(integral=lambda p: p.a**2, terminal=lambda p: 10 * (p.x0[0] + p.q))
    )


@pytest.mark.parametrize("name,degree", [("radau", 3), ("legendre", 2), ("hermite-simpson", None)])
def test_state_only_path_constraints_hold_at_every_node(name, degree):
    solution = floor_problem(name, degree).solve(progress=False, options=TIGHT)
    relax = 1e-7  # IPOPT relaxes bounds by ~1e-8 (bound_relax_factor)
    assert solution.states[:, 0].min() >= -relax, solution.states[:, 0]
    assert solution.state_values[:, 0].min() >= -relax
    assert solution.cost == pytest.approx(4.0, abs=1e-6)
    np.testing.assert_allclose(solution.states[:, 0], solution.time - solution.time**2, atol=relax)
    names = Transcription(floor_problem(name, degree)).g_names
    if name == "radau":  # t = 0 is the one state point that is no collocation point
        assert "path[floor] node 0" in names and "path[floor] node 1" in names
    elif name == "legendre":  # every node: the collocation points are interior
        assert all(f"path[floor] node {k}" in names for k in range(5))
    assert len(set(names)) == len(names)


@pytest.mark.parametrize("name,degree", [("radau", 3), ("legendre", 2)])
def test_path_constraints_with_controls_stay_at_the_dynamics_points(name, degree):
    # a control is no variable at the Radau start or the Legendre nodes: no row there
    transcription = Transcription(floor_problem(name, degree, lambda p: p.q - 1e-3 * p.a**2))
    assert not transcription.phases[0].state_paths
    rows = [n for n in transcription.g_names if n.startswith("path[floor]")]
    assert len(rows) == transcription.mesh.n_dyn_points
    assert "path[floor] node 0" not in rows
    # a time-dependent, state-only Function of named fields counts as state-only
    q, t = ca.SX.sym("q"), ca.SX.sym("t")
    function = ca.Function("g", [q, t], [q + 0.1 * ca.sin(t)], ["q", "t"], ["g"])
    transcription = Transcription(floor_problem(name, degree, function))
    assert [c.name for c in transcription.phases[0].state_paths] == ["floor"]
    mesh = transcription.mesh
    free = mesh.free_state_cols
    assert free.tolist() == ([0] if name == "radau" else mesh.node_state_cols.tolist())
    rows = [n for n in transcription.g_names if n.startswith("path[floor]")]
    assert len(rows) == mesh.n_dyn_points + free.size
    # the extra rows evaluate the constraint at the free state points (numpy, by name)
    w = np.random.default_rng(3).normal(size=transcription.n_w)
    g = np.asarray(ca.Function("g", [transcription.nlp["x"]], [transcription.nlp["g"]])(w))
    X = transcription.unpack(w)["X"]
    for col in free:
        row = transcription.g_names.index(f"path[floor] {mesh.state_label(int(col))}")
        expected = X[col, 0] + 0.1 * np.sin(mesh.s_state[col] * 1.0)  # T = 1 s
        assert g[row, 0] == pytest.approx(expected, rel=1e-14, abs=1e-14)


# ---- NLP derivatives against central finite differences ---------------------------------


def fd_problem(expand, transcription="hermite-simpson", degree=None, formulation="implicit"):
    chain = Dynamics(presets.n_link_chain(2))
    return Transcription(
        OCP(
            chain,
            T=(0.5, 2.0),
            N=3,
            transcription=transcription,
            degree=degree,
            formulation=formulation,
        )
        .constrain("tilt", lambda p: ca.sin(p.psi_link1 - p.psi_link2) * p.dpsi_link1, upper=1)
        .constrain("rate", lambda p: p.dM_link1 * ca.cos(p.psi_link2), lower=-5, upper=5)
        .boundary("start", lambda p: ca.cos(p.psi_link1) + p.M_link2 * p.dpsi_link2, "start", 0, 0)
        .constrain_at(
            "key",
            lambda p: ca.vertcat(p.ddpsi_link1 * p.dpsi_link2, ca.sin(p.psi_link2) * p.dM_link2),
            fraction=[0.3, 0.8],
            lower=-1,
            upper=1,
        )
        .periodic(lambda x: ca.vertcat(x[1], x[0], x[3], x[2]))
        .minimize(
            integral=lambda p: ca.sumsqr(p.M) + ca.sin(p.psi_link2) * p.t + ca.sumsqr(p.dM) * p.T,
            terminal=lambda p: p.T**2 + ca.sumsqr(p.x - p.x0),
        ),
        expand=expand,
    )


FD_CASES = [
    pytest.param(scheme, degree, formulation, False, id=f"{scheme}{degree or ''}-{formulation}")
    for scheme, degree in (
        ("trapezoid", None),
        ("hermite-simpson", None),
        ("radau", 3),
        ("legendre", 2),
    )
    for formulation in ("implicit", "explicit")
] + [pytest.param("hermite-simpson", None, "implicit", True, id="hermite-simpson-implicit-sx")]


@pytest.mark.parametrize("scheme,degree,formulation,expand", FD_CASES)
def test_nlp_jacobian_and_hessian_match_central_differences(scheme, degree, formulation, expand):
    transcription = fd_problem(expand, scheme, degree, formulation)
    solver = nlp_solver(transcription)
    g = solver.get_function("nlp_g")
    jac_g = solver.get_function("nlp_jac_g")
    grad_f = solver.get_function("nlp_grad_f")
    hess_l = solver.get_function("nlp_hess_l")
    rng = np.random.default_rng(7)
    n, m = transcription.n_w, transcription.n_g
    p = transcription.parameter_values()  # the nominal scales and T
    step = 1e-6
    jacobian_checked = hessian_checked = 0
    rows_seen, columns_seen = np.zeros(m, bool), np.zeros(n, bool)
    hessian_rows_seen = np.zeros(n, bool)
    for _ in range(2):
        w = rng.uniform(-1.0, 1.0, n)
        w[-1] = 1.0  # a positive duration
        lam_g = rng.normal(size=m)
        lam_f = 0.7
        jacobian = np.asarray(ca.densify(jac_g(w, p)[1]))
        hessian = np.asarray(ca.densify(hess_l(w, p, lam_f, lam_g)))
        hessian = np.triu(hessian) + np.triu(hessian, 1).T  # IPOPT gets the upper triangle

        def gradient_of_lagrangian(v, lam_g=lam_g, lam_f=lam_f):
            gf = np.asarray(grad_f(v, p)[1]).reshape(-1)
            jg = np.asarray(ca.densify(jac_g(v, p)[1]))
            return lam_f * gf + jg.T @ lam_g

        fd_jac = np.zeros((m, n))
        fd_hess = np.zeros((n, n))
        for i in range(n):
            e = np.zeros(n)
            e[i] = step
            fd_jac[:, i] = (
                np.asarray(g(w + e, p)).reshape(-1) - np.asarray(g(w - e, p)).reshape(-1)
            ) / (2 * step)
            fd_hess[:, i] = (gradient_of_lagrangian(w + e) - gradient_of_lagrangian(w - e)) / (
                2 * step
            )
        np.testing.assert_allclose(jacobian, fd_jac, atol=1e-6 * max(1, np.abs(fd_jac).max()))
        np.testing.assert_allclose(hessian, fd_hess, atol=1e-5 * max(1, np.abs(fd_hess).max()))
        jacobian_nonzero = np.abs(fd_jac) > 1e-8
        hessian_nonzero = np.abs(fd_hess) > 1e-8
        jacobian_checked += np.count_nonzero(jacobian_nonzero)
        hessian_checked += np.count_nonzero(hessian_nonzero)
        rows_seen |= jacobian_nonzero.any(axis=1)
        columns_seen |= jacobian_nonzero.any(axis=0)
        hessian_rows_seen |= hessian_nonzero.any(axis=1)
    # Guards, one per derivative: the comparison covered nonzero entries of every constraint
    # row and every variable of the Jacobian, and a second derivative of the state and the
    # control at every dynamics point (the dynamics are nonlinear in psi, the cost in M).
    assert rows_seen.all(), [transcription.g_names[i] for i in np.flatnonzero(~rows_seen)]
    assert columns_seen.all(), [transcription.w_names[i] for i in np.flatnonzero(~columns_seen)]
    assert jacobian_checked >= 2 * 2 * m, (jacobian_checked, m)
    s = transcription.system
    mesh = transcription.mesh
    # one phase: its layout is the NLP's
    X = np.arange(
        transcription.phases[0].slice_of("X").start, transcription.phases[0].slice_of("X").stop
    )
    U = np.arange(
        transcription.phases[0].slice_of("U").start, transcription.phases[0].slice_of("U").stop
    )
    psi_at_points = X.reshape(mesh.n_state_points, s.nx)[mesh.dyn_state_cols, : s.nx // 2]
    assert hessian_rows_seen[psi_at_points].all()
    assert hessian_rows_seen[U].all()
    assert hessian_checked >= 2 * (psi_at_points.size + U.size), hessian_checked


def test_sx_and_mx_builds_give_the_same_nlp():
    sx, mx = fd_problem(True), fd_problem(False)
    w = np.random.default_rng(1).uniform(0.5, 1.0, sx.n_w)
    for key in ("f", "g"):
        a = ca.Function("a", [sx.nlp["x"]], [sx.nlp[key]])(w)
        b = ca.Function("b", [mx.nlp["x"]], [mx.nlp[key]])(w)
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-13, atol=1e-13)


# ---- convergence orders on problems with known optima ------------------------------------


def fitted_order(Ns, errors):
    return -np.polyfit(np.log(Ns), np.log(errors), 1)[0]


@pytest.mark.parametrize(
    "name,degree,Ns",
    [
        ("trapezoid", None, [4, 8, 16, 32]),
        ("hermite-simpson", None, [2, 4, 8, 16]),
        ("radau", 1, [4, 8, 16, 32]),
        ("radau", 2, [2, 4, 8, 16]),
        ("radau", 3, [2, 4, 8]),
        ("legendre", 2, [2, 4, 8, 16]),
        ("legendre", 3, [1, 2, 4]),
    ],
)
def test_cost_converges_at_the_scheme_order_on_scalar_lq(name, degree, Ns):
    exact = np.tanh(LQ_T)
    errors = []
    for N in Ns:
        solution = scalar_lq(N, name, degree).solve(progress=False, options=TIGHT)
        errors.append(abs(solution.cost - exact))
    errors = np.array(errors)
    order = make_scheme(name, degree).order
    assert np.all(errors > 1e-11), f"error at round-off, the fit is meaningless: {errors}"
    assert fitted_order(Ns, errors) >= order - 0.3, (errors, order)


def test_min_energy_double_integrator_exact_or_second_order():
    # u = 6 - 12 t is linear, x cubic: Hermite-Simpson and collocation of degree >= 2 are
    # exact; the trapezoid rule converges at order 2.
    for name, degree in (("hermite-simpson", None), ("radau", 2), ("legendre", 2)):
        solution = min_energy(3, name, degree).solve(progress=False, options=TIGHT)
        assert solution.cost == pytest.approx(12.0, abs=1e-9)
        np.testing.assert_allclose(solution.controls[:, 0], 6 - 12 * solution.time, atol=1e-7)
    Ns = [4, 8, 16, 32]
    errors = [
        abs(min_energy(N, "trapezoid").solve(progress=False, options=TIGHT).cost - 12.0) for N in Ns
    ]
    assert fitted_order(Ns, errors) >= 2 - 0.3


# ---- the transcription reads its definition once ------------------------------------------

#: The definition's rule-reading methods: the transcription reads them through one
#: ResolvedDefinition, never again while it builds rows, bounds, margins and guesses.
DEFINITION_QUERIES = (
    "variable_scale",
    "variable_bounds",
    "constraint_scale",
    "margin",
    "param_fields",
    "resolve",
)


def test_a_phase_transcription_asks_its_definition_once(monkeypatch):
    callers: dict[str, list[str]] = {name: [] for name in DEFINITION_QUERIES}
    for name in DEFINITION_QUERIES:
        original = getattr(OCPDefinition, name)

        def counted(self, *args, _name=name, _original=original, **kwargs):
            callers[_name].append(inspect.stack()[1].frame.f_globals["__name__"])
            return _original(self, *args, **kwargs)

        monkeypatch.setattr(OCPDefinition, name, counted)
    x, u, p = ca.SX.sym("x", 2), ca.SX.sym("u"), ca.SX.sym("p")
    f = ca.Function("f", [x, u, p], [ca.vertcat(x[1], p * u)], ["x", "u", "p"], ["xdot"])
    ocp = (
        OCP(
            f,
            T=(0.5, 2.0),
            N=6,
            state_names=("q", "v"),
            control_names=("a",),
            dynamics_params=("p",),
        )
        .param("p", 0.5, 2.0, guess=1.0)
        .bound("a", -3.0, 2.0)
        .scale(q=0.25)
        .constrain("speed", lambda pt: pt.v, lower=-4.0, upper=4.0)
        .back_off("speed", lower=np.full(6, 0.1), upper=np.full(6, 0.2))
        .initial(q=0.0, v=0.0)
        .final(q=1.0, v=0.0)
        .constrain_at("half way", lambda pt: pt.q, fraction=0.5, lower=0.2)
        .minimize(integral=lambda pt: pt.a**2, terminal=lambda pt: pt.T)
        .guess(lambda t: {"q": t}, T=1.0)
    )
    transcription = Transcription(ocp)
    transcribers = ("planner.phase_transcription", "planner.transcription")
    by_phase = [m for calls in callers.values() for m in calls if m in transcribers]
    by_resolver = [
        m for calls in callers.values() for m in calls if m.endswith("resolved_definition")
    ]
    assert not by_phase, f"the phase transcription asked its definition again: {callers}"
    assert by_resolver  # the check sees the calls it counts
    # ... and what it read is the definition's rules, in numbers: a given scale, the largest
    # finite bound, 1 for a free variable; the constraints sorted by where they hold
    resolved = transcription.phases[0].definition
    assert isinstance(resolved, ResolvedDefinition)
    assert resolved.scales == {"q": 0.25, "v": 1.0, "a": 3.0}
    assert resolved.bounds["a"] == (-3.0, 2.0) and resolved.bounds["q"] == (-np.inf, np.inf)
    assert resolved.T_scale == 1.25 and resolved.free_time and resolved.T == (0.5, 2.0)
    assert [c.name for c in resolved.path] == ["speed"]
    assert [c.where for c in resolved.boundary] == ["start", "start", "end", "end"]
    assert [c.name for c in resolved.instant] == ["half way"]
    assert resolved.constraint_scales["speed"].tolist() == [4.0]
    lower, upper, at_ends = resolved.margins["speed"]
    assert lower.shape == (6, 1) and np.all(lower == 0.1) and np.all(upper == 0.2) and at_ends
    assert len(resolved.integral_terms) == 1 and len(resolved.terminal_terms) == 1
    assert set(resolved.param_fields(ca.SX.sym("P", 1))) == {"p", "params"}
    # its arrays cannot be changed behind the definition's back
    with pytest.raises(ValueError):
        resolved.state_scale[0] = 2.0


# ---- a transcription copied for new margins and guesses ------------------------------------


def _same_numbers(copy: Transcription, full: Transcription) -> None:
    """Every number and name a solve reads of a transcription, equal bit for bit."""
    for name in ("lbx", "ubx", "lbg", "ubg", "w_scale", "g_scale"):
        np.testing.assert_array_equal(getattr(copy, name), getattr(full, name), err_msg=name)
    assert copy.w_names == full.w_names and copy.g_names == full.g_names
    np.testing.assert_array_equal(copy.initial_guess(), full.initial_guess())
    np.testing.assert_array_equal(copy.parameter_values(2.0), full.parameter_values(2.0))
    assert copy.signature == full.signature and copy.structure_key == full.structure_key


def test_a_problem_backed_off_and_guessed_again_is_transcribed_by_a_copy():
    """Transcription.for_problem against a transcription built from scratch: the same
    bounds, names, scales, guess and NLP, on one OCP and on the step on feet's three phases
    (joins, events, a shared start); anything but margins and guesses makes its own."""
    from problems import footed_step

    ocp = min_energy(8, "hermite-simpson").bound("a", -5.0, 5.0)
    original = Transcription(ocp)
    backed = ocp.back_off("a", lower=np.linspace(0.0, 0.5, 8), upper=np.full(8, 0.25))
    backed = backed.guess(t=[0.0, 1.0], q=[0.0, 0.7])
    copy = original.for_problem(backed)
    full = Transcription(backed)
    _same_numbers(copy, full)
    assert copy.parametric_nlp is original.parametric_nlp  # the symbols shared
    assert not np.array_equal(copy.ubx, original.ubx)  # and the bounds its own
    assert copy.single is backed and original.single is ocp
    for other in (
        ocp.bound("a", -4.0, 4.0),
        ocp.refine(N=9),
        ocp.constrain("more", lambda p: p.q, upper=5.0),
        ocp.minimize(integral=lambda p: p.v**2),
    ):
        assert original.for_problem(other) is None

    step = footed_step()
    phases = step.phases
    original = Transcription(phases)
    name, double = phases.phases[2]
    changed = double.back_off("rear unloads", upper=np.linspace(0.0, 5.0, double.N))
    backed = dataclasses.replace(phases, phases=(*phases.phases[:2], (name, changed)))
    copy = original.for_problem(backed)
    _same_numbers(copy, Transcription(backed))
    assert copy.problem is backed
    tighter = double.bound(f"M_{step.biped.swing_leg[0]}", -100.0, 100.0)
    other = dataclasses.replace(phases, phases=(*phases.phases[:2], (name, tighter)))
    assert original.for_problem(other) is None
    assert original.for_problem(double) is None  # one phase of it: another problem


def test_solve_copies_a_recent_transcription_for_new_margins_to_the_same_optimum():
    from planner import solve
    from planner.transcription import remember, transcribe

    ocp = min_energy(8, "hermite-simpson").bound("a", -5.0, 5.0)
    first = solve(ocp, progress=False)
    backed = ocp.back_off("a", upper=np.full(8, 1.5)).guess(first)
    again = solve(backed, progress=False)
    assert again.transcription.parametric_nlp is first.transcription.parametric_nlp
    fresh = solve(Transcription(backed), progress=False)
    np.testing.assert_array_equal(again.states, fresh.states)
    assert again.cost == fresh.cost and again.iterations == fresh.iterations
    assert transcribe(ocp.refine(N=9)).parametric_nlp is not first.transcription.parametric_nlp
    # an SX transcription a caller solved is not what solve() asks of transcribe (MX)
    other = min_energy(6, "trapezoid")
    remember(Transcription(other, expand=True))
    assert transcribe(other).expand is False
