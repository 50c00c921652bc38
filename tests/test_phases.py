"""Multi-phase problems (planner.phases), static parameters, named objective terms and
non-uniform meshes, against optima known another way.

* Two phases with a state jump at a fixed switching time (scalar LQ, x' = u, cost
  integral x^2 + u^2): the reference is the value function V = P x^2 + 2 q x + r integrated
  backwards with scipy (Riccati P' = P^2 - 1, q' = P q, r' = q^2, V(tau) = the second phase's
  tanh(T - tau) (x + jump)^2); every transcription converges to it at its order, phase by
  phase.
* A double integrator with a velocity jump at a free switching time and the total duration
  fixed by an event constraint: the reference minimises the closed-form minimum-energy costs
  of both phases over the switching state and time with scipy.
* The same problem split in two phases with continuity, and written as one phase: the same
  cost; a one-phase Phases problem is the OCP's NLP itself.
* A static parameter with a closed-form optimum; the NLP's derivatives with phases and
  parameters against central differences.
* Non-uniform meshes: convergence order on a graded mesh, node times, interpolants.
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import minimize

from model import DefinitionError, DefinitionTypeError, LinkageTrajectory
from planner import OCP, Phases, PhasesSolution, Transcription
from planner.phase_transcription import Mesh
from planner.schemes import make_scheme

TIGHT = {"tol": 1e-12}
SCHEMES = [
    ("trapezoid", None, [4, 8, 16, 32]),
    ("hermite-simpson", None, [2, 4, 8, 16]),
    ("radau", 3, [1, 2, 4]),
    ("legendre", 3, [1, 2, 4]),
]
IDS = [s[0] + (str(s[1]) if s[1] else "") for s in SCHEMES]


def integrator():
    x, u = ca.SX.sym("x"), ca.SX.sym("u")
    return ca.Function("f", [x, u], [u], ["x", "u"], ["xdot"])


def double_integrator():
    x, u = ca.SX.sym("x", 2), ca.SX.sym("u")
    return ca.Function("f", [x, u], [ca.vertcat(x[1], u)], ["x", "u"], ["xdot"])


def fitted_order(Ns, errors):
    return -np.polyfit(np.log(Ns), np.log(errors), 1)[0]


# ---- two phases, a jump at a fixed time: scalar LQ ----------------------------------------
LQ_T, LQ_TAU, JUMP = 2.0, 0.8, 0.5


@functools.cache
def lq_reference() -> tuple[float, float]:
    """(optimal cost, the second phase's share) of the jump problem, from the value function
    integrated backwards over the first phase and the closed-loop state forwards."""
    p_b = np.tanh(LQ_T - LQ_TAU)  # the second phase: V = tanh(T - tau) y^2, y its start

    def backward(_, v):
        P, q, _ = v
        return [P * P - 1.0, P * q, q * q]

    values = solve_ivp(
        backward,
        [LQ_TAU, 0.0],
        [p_b, p_b * JUMP, p_b * JUMP**2],
        rtol=1e-13,
        atol=1e-14,
        dense_output=True,
    )
    P0, q0, r0 = values.y[:, -1]
    total = P0 + 2 * q0 + r0  # V(x = 1, t = 0)

    def closed_loop(t, x):
        P, q, _ = values.sol(t)
        return [-(P * x[0] + q)]

    end = solve_ivp(closed_loop, [0.0, LQ_TAU], [1.0], rtol=1e-13, atol=1e-14).y[0, -1]
    return total, p_b * (end + JUMP) ** 2


def lq_phases(name, degree, N) -> Phases:
    common = {"transcription": name, "degree": degree, "state_names": ("y",),
              "control_names": ("w",)}  # fmt: skip
    first = (
        OCP(integrator(), T=LQ_TAU, N=N, **common)
        .initial(y=1.0)
        .minimize(integral=lambda p: p.y**2 + p.w**2)
    )
    second = OCP(integrator(), T=LQ_T - LQ_TAU, N=N, **common).minimize(
        integral=lambda p: p.y**2 + p.w**2
    )
    return Phases.sequence(("first", first)).then("second", second, mapping=lambda x: x + JUMP)


@pytest.mark.parametrize(("name", "degree", "Ns"), SCHEMES, ids=IDS)
def test_two_phases_with_a_jump_converge_at_the_scheme_order_per_phase(name, degree, Ns):
    total, second_share = lq_reference()
    totals, seconds = [], []
    for N in Ns:
        solution = lq_phases(name, degree, N).solve(progress=False, options=TIGHT)
        assert isinstance(solution, PhasesSolution) and solution.success
        terms = solution.cost_terms
        assert sum(terms.values()) == pytest.approx(solution.cost, rel=1e-12)
        totals.append(abs(solution.cost - total))
        seconds.append(abs(terms["second: objective"] - second_share))
        # The jump happened: the second phase starts where the first ended, plus 0.5.
        first, second = solution.phase("first"), solution.phase("second")
        assert second.states[0, 0] == pytest.approx(first.states[-1, 0] + JUMP, abs=1e-10)
    order = make_scheme(name, degree).order
    for errors in (totals, seconds):
        errors = np.array(errors)
        assert np.all(errors > 1e-12), errors  # the fit needs errors above round-off
        assert fitted_order(Ns, errors) >= order - 0.3, (errors, order)


# ---- a velocity jump at a free switching time: double integrator ---------------------------
# At the switch the velocity halves (an inelastic bounce); the switching time is free, the
# total time fixed by an event constraint. The optimum switches at 1.699 s, inside (0.2, 1.8).
TOTAL, RESTITUTION = 2.0, 0.5


def transfer_cost(T, x0, v0, xf, vf):
    """Minimum of integral u^2 for x'' = u from (x0, v0) to (xf, vf) in time T (closed form)."""
    a = xf - x0 - v0 * T
    b = vf - v0
    return 12 * a * a / T**3 - 12 * a * b / T**2 + 4 * b * b / T


@functools.cache
def kick_reference() -> tuple[float, float]:
    """(optimal cost, switching time): the best switching state and time by scipy."""

    def cost(z):
        x1, v1, tau = z
        return transfer_cost(tau, 0.0, 0.0, x1, v1) + transfer_cost(
            TOTAL - tau, x1, RESTITUTION * v1, 1.0, 0.0
        )

    best = minimize(
        cost,
        [0.4, 0.3, 1.0],
        method="L-BFGS-B",
        bounds=[(-5.0, 5.0), (-5.0, 5.0), (0.2, 1.8)],
        options={"ftol": 1e-15, "gtol": 1e-12, "maxiter": 10000},
    )
    assert best.success, best.message
    return float(best.fun), float(best.x[2])


def kick_phases(name, degree, N) -> Phases:
    common = {"transcription": name, "degree": degree}
    before = (
        OCP(double_integrator(), T=(0.2, 1.8), N=N, **common)
        .initial(x=[0.0, 0.0])
        .minimize(integral=lambda p: p.u**2)
        .guess(T=1.0)
    )
    after = (
        OCP(double_integrator(), T=(0.2, 1.8), N=N, **common)
        .final(x=[1.0, 0.0])
        .minimize(integral=lambda p: p.u**2)
        .guess(T=1.0)
    )
    return (
        Phases.sequence(("before", before))
        .then("after", after, mapping=lambda x: ca.vertcat(x[0], RESTITUTION * x[1]))
        .constrain_event(
            "before", "total time", lambda e: e.T_before + e.T_after, lower=TOTAL, upper=TOTAL
        )
    )


@pytest.mark.parametrize(("name", "degree"), [(s[0], s[1]) for s in SCHEMES], ids=IDS)
def test_velocity_jump_at_a_free_switching_time(name, degree):
    cost, switch = kick_reference()
    solution = kick_phases(name, degree, 8).solve(progress=False, options=TIGHT)
    # Cubic states, linear controls: exact except for the trapezoid rule (order 2: 2.3 % at
    # N = 8). The cost is flat in the switching time (quadratic at the optimum), so the time
    # agrees to about the square root of the cost's accuracy (scipy's 1e-15 here).
    exact = name != "trapezoid"
    assert solution.cost == pytest.approx(cost, rel=1e-8 if exact else 0.03)
    assert solution.durations[0] == pytest.approx(switch, rel=1e-6 if exact else 0.05)
    assert solution.T == pytest.approx(TOTAL, rel=1e-10)
    trajectory = solution.to_trajectory()
    # One time axis; the velocity jumps by the kick between the phases' samples.
    assert trajectory.time[-1] == pytest.approx(TOTAL)
    assert trajectory.metadata["phases"][1]["start"] == pytest.approx(solution.durations[0])


def test_the_whole_sequence_replays_exports_and_estimates_its_accuracy(tmp_path):
    solution = kick_phases("hermite-simpson", None, 8).solve(progress=False, options=TIGHT)
    before, after = solution.phases
    # Open loop through the join: the second phase starts from the mapped end of the first
    # (the velocity jump), and cubic states with linear controls are exact for the double
    # integrator (up to the integrator's tolerance).
    replay = solution.replay(rtol=1e-12, atol=1e-12)
    assert replay.time.size == solution.time.size
    np.testing.assert_allclose(replay.states, solution.states, atol=1e-9)
    start = replay.states[before.N + 1]
    np.testing.assert_allclose(start, [before.states[-1][0], RESTITUTION * before.states[-1][1]])
    assert solution.residual_error().per_interval.shape == (16, 2)
    assert solution.residual_error().max < 1e-9 and solution.integration_error().max < 1e-9
    # Exported on one time axis: the join is one instant (the later phase's value kept),
    # read back as written.
    trajectory = solution.to_trajectory()
    assert trajectory.time.size == before.N + after.N + 1
    np.testing.assert_allclose(trajectory.time[before.N], before.T, rtol=1e-12)
    np.testing.assert_allclose(trajectory.states[before.N], after.states[0], atol=1e-12)
    assert [p["name"] for p in trajectory.metadata["phases"]] == ["before", "after"]
    path = solution.save(tmp_path / "kick.npz", rate_hz=100.0)
    again = LinkageTrajectory.load(path)
    np.testing.assert_array_equal(again.states, solution.to_trajectory(100.0).states)


# ---- the same problem as one phase and as several ------------------------------------------
def rest_to_rest(N, name="hermite-simpson", degree=None, T=1.0):
    return (
        OCP(double_integrator(), T=T, N=N, transcription=name, degree=degree)
        .initial(x=[0.0, 0.0])
        .final(x=[1.0, 0.0])
        .minimize(integral=lambda p: p.u**2)
    )


def implicit_double_integrator():
    """r(x, xdot, u) = xdot - (x1, u): the double integrator as an implicit residual."""
    x, xdot, u = ca.SX.sym("x", 2), ca.SX.sym("xdot", 2), ca.SX.sym("u")
    return ca.Function("r", [x, xdot, u], [xdot - ca.vertcat(x[1], u)])


def limited(N, name, degree, formulation, T=1.0):
    """Rest to rest in T = 1 with the speed capped at 1.4 (unconstrained, its peak 1.5 lies
    at t = 1/2, where the split below cuts) and the control above -5.5 (unconstrained, -6 at
    the end): a state-only and a control path constraint, both active."""
    dynamics = double_integrator() if formulation == "explicit" else implicit_double_integrator()
    return (
        OCP(dynamics, T=T, N=N, transcription=name, degree=degree, formulation=formulation)
        .constrain("speed", lambda p: p.x_1, upper=1.4)
        .constrain("push", lambda p: p.u_0, lower=-5.5)
        .minimize(integral=lambda p: p.u_0**2)
    )


@pytest.mark.parametrize("formulation", ["explicit", "implicit"])
@pytest.mark.parametrize(("name", "degree"), [(s[0], s[1]) for s in SCHEMES], ids=IDS)
def test_split_in_two_phases_is_the_one_phase_nlp(name, degree, formulation):
    whole = (
        limited(8, name, degree, formulation)
        .initial(x_0=0.0, x_1=0.0)
        .final(x_0=1.0, x_1=0.0)
        .solve(progress=False, options=TIGHT)
    )
    first = limited(4, name, degree, formulation, T=0.5).initial(x_0=0.0, x_1=0.0)
    second = limited(4, name, degree, formulation, T=0.5).final(x_0=1.0, x_1=0.0)
    split = (
        Phases.sequence(("first", first))
        .then("second", second, controls="continuous")
        .solve(progress=False, options=TIGHT)
    )
    # The node at the cut is one variable of both phases, and with continuous controls so is
    # the dynamics point there (trapezoid, Hermite-Simpson); the rows the first phase holds
    # there are not repeated: the NLP of the uncut problem.
    assert split.transcription.n_w == whole.transcription.n_w
    assert split.transcription.n_g == whole.transcription.n_g
    assert split.cost == pytest.approx(whole.cost, rel=1e-8)
    assert whole.cost > 12.0 + 1e-3  # the caps are active (12 without them)
    np.testing.assert_allclose(split.states[:5], whole.states[:5], atol=1e-8)
    np.testing.assert_allclose(split.phase("second").states, whole.states[4:], atol=1e-8)
    # Controls that may jump at the cut: a point more on schemes with controls at the nodes
    # (its controls and auxiliary variables, its residual and path rows); collocation
    # controls are per interval anyway.
    free = Phases.sequence(("first", first), ("second", second)).solve(
        progress=False, options=TIGHT
    )
    node_point = name in ("trapezoid", "hermite-simpson")
    nz = 2 if formulation == "implicit" else 0
    assert free.transcription.n_w == whole.transcription.n_w + node_point * (1 + nz)
    assert free.transcription.n_g == whole.transcription.n_g + node_point * (nz + 2)
    assert free.cost <= whole.cost * (1 + 1e-9)


def test_continuous_controls_need_a_continuity_join_and_the_same_controls():
    first = rest_to_rest(4)
    with pytest.raises(DefinitionError, match="continuous controls need a continuity join"):
        Phases.sequence(("a", first)).then("b", first, mapping=lambda x: x, controls="continuous")
    other = OCP(integrator(), T=1.0, N=4)
    with pytest.raises(DefinitionError, match="unknown 'smooth'"):
        Phases.sequence(("a", first)).then("b", first, controls="smooth")
    with pytest.raises(DefinitionError, match="continuity needs the same states"):
        Phases.sequence(("a", first)).then("b", other, controls="continuous")
    with pytest.raises(DefinitionError, match="periodic on its own"):
        Phases.sequence(("a", first.periodic()))


def test_one_phase_is_the_ocp_itself():
    ocp = rest_to_rest(10)
    alone = ocp.solve(progress=False)
    phases = Phases.sequence(("only", ocp)).solve(progress=False)
    assert phases.transcription.n_w == alone.transcription.n_w
    assert phases.transcription.n_g == alone.transcription.n_g
    assert phases.transcription.w_names == alone.transcription.w_names
    assert phases.cost == pytest.approx(alone.cost, rel=1e-12)
    np.testing.assert_allclose(phases.phase("only").states, alone.states, atol=1e-12)


# ---- static parameters and objective terms -------------------------------------------------
WEIGHT, TARGET = 10.0, 0.5


def design(N=10, name="hermite-simpson", degree=None):
    """Reach a free position L at rest in T = 1 (effort 12 L^2) with a price on L's distance
    to 0.5: optimum L* = w L0 / (12 + w)."""
    return (
        OCP(double_integrator(), T=1.0, N=N, transcription=name, degree=degree)
        .param("L", lower=0.0, upper=2.0, guess=1.0)
        .initial(x=[0.0, 0.0])
        .boundary(
            "reach", lambda p: ca.vertcat(p.x[0] - p.L, p.x[1]), at="end", lower=0.0, upper=0.0
        )
        .minimize(integral=lambda p: p.u**2, name="effort")
        .minimize(terminal=lambda p: WEIGHT * (p.L - TARGET) ** 2, name="price")
    )


@pytest.mark.parametrize(("name", "degree"), [("hermite-simpson", None), ("legendre", 2)])
def test_parameter_reaches_its_closed_form_optimum(name, degree):
    solution = design(name=name, degree=degree).solve(progress=False, options=TIGHT)
    best = WEIGHT * TARGET / (12 + WEIGHT)
    assert solution.params["L"] == pytest.approx(best, rel=1e-9)
    terms = solution.cost_terms
    assert terms["effort"] == pytest.approx(12 * best**2, rel=1e-9)
    assert terms["price"] == pytest.approx(WEIGHT * (best - TARGET) ** 2, rel=1e-9)
    assert terms["effort"] + terms["price"] == pytest.approx(solution.cost, rel=1e-12)


# A parameter of the dynamics: x' = -a x + u, x(0) = 1, T = 1, cost integral x^2 + u^2 plus
# a price W (a - A0)^2 on the damping a. For each a the LQ optimum is P(0; a) x(0)^2 with the
# Riccati equation P' = 2 a P + P^2 - 1, P(T) = 0 (integrated backwards with scipy); a scalar
# search over a outside the planner gives the design optimum.
DAMPING_PRICE, DAMPING_TARGET = 0.2, 0.5


def damped():
    x, u, a = ca.SX.sym("x"), ca.SX.sym("u"), ca.SX.sym("a")
    return ca.Function("f", [x, u, a], [-a * x + u], ["x", "u", "a"], ["xdot"])


@functools.cache
def damping_reference() -> tuple[float, float]:
    """(a*, optimal cost) by a bounded scalar search over the Riccati cost."""
    from scipy.optimize import minimize_scalar

    def lq_cost(a: float) -> float:
        run = solve_ivp(
            lambda _, P: 2 * a * P + P * P - 1.0, [1.0, 0.0], [0.0], rtol=1e-13, atol=1e-14
        )
        return float(run.y[0, -1])

    def total(a: float) -> float:
        return lq_cost(a) + DAMPING_PRICE * (a - DAMPING_TARGET) ** 2

    best = minimize_scalar(total, bounds=(0.0, 3.0), method="bounded", options={"xatol": 1e-11})
    return float(best.x), float(best.fun)


def damping_design(N: int, name: str = "legendre", degree: int | None = 3) -> OCP:
    return (
        OCP(damped(), T=1.0, N=N, transcription=name, degree=degree, dynamics_params=("a",))
        .param("a", lower=0.0, upper=3.0, guess=1.0)
        .initial(x_0=1.0)
        .minimize(integral=lambda p: p.x_0**2 + p.u_0**2, name="lq")
        .minimize(terminal=lambda p: DAMPING_PRICE * (p.a - DAMPING_TARGET) ** 2, name="price")
    )


def test_a_parameter_of_the_dynamics_reaches_the_scalar_search_optimum():
    best, cost = damping_reference()
    assert 0.5 < best < 2.9  # interior: both the dynamics and the price pull on it
    solution = damping_design(12).solve(progress=False, options=TIGHT)
    assert solution.params["a"] == pytest.approx(best, rel=1e-7)
    assert solution.cost == pytest.approx(cost, rel=1e-9)
    # The Solution integrates the dynamics at the designed a: its re-integration agrees.
    assert solution.integration_error().max < 1e-8
    # Derivatives of the NLP with the parameter in the dynamics, against central differences.
    transcription = Transcription(damping_design(3, "hermite-simpson", None))
    nlp = transcription.parametric_nlp
    jacobian = ca.Function("j", [nlp["x"], nlp["p"]], [ca.jacobian(nlp["g"], nlp["x"])])
    rows = ca.Function("g", [nlp["x"], nlp["p"]], [nlp["g"]])
    point = transcription.initial_guess() + np.random.default_rng(5).normal(
        0.0, 0.3, transcription.n_w
    )
    parameters = transcription.parameter_values()
    a_column = transcription.w_names.index("bound[a]")
    step = np.zeros(transcription.n_w)
    step[a_column] = 1e-6
    central = (rows(point + step, parameters) - rows(point - step, parameters)) / 2e-6
    exact = jacobian(point, parameters)[:, a_column]
    np.testing.assert_allclose(np.asarray(central), np.asarray(exact), atol=1e-7)
    assert np.count_nonzero(np.asarray(exact)) >= 6  # a enters every defect (the guard)


def test_a_dynamics_parameter_must_be_declared_and_belongs_to_a_function():
    undeclared = OCP(damped(), T=1.0, N=4, dynamics_params=("a",)).minimize(
        integral=lambda p: p.u_0**2
    )
    with pytest.raises(DefinitionError, match=r"reads the static parameter 'a'.*\.param\('a'"):
        undeclared.solve(progress=False)
    with pytest.raises(DefinitionError, match=r"must be f\(x, u\[, t\], a, b\)"):
        OCP(damped(), T=1.0, N=4, dynamics_params=("a", "b"))
    with pytest.raises(DefinitionTypeError, match=r"`dynamics_params`: give a sequence"):
        OCP(damped(), T=1.0, N=4, dynamics_params="a")


def test_named_terms_add_and_a_name_replaces():
    ocp = design()
    assert [t.name for t in ocp.objective] == ["effort", "price"]
    cheaper = ocp.minimize(terminal=lambda p: 0 * p.L, name="price")
    assert [t.name for t in cheaper.objective] == ["effort", "price"]
    solution = cheaper.solve(progress=False, options=TIGHT)
    assert solution.params["L"] == pytest.approx(0.0, abs=1e-6)  # nothing pays for L > 0
    with pytest.raises(DefinitionTypeError, match=r"`name`: an objective term needs a name"):
        ocp.minimize(integral=lambda p: p.u**2, name="")


def test_parameters_shared_across_phases_and_warm_start():
    first = (
        OCP(double_integrator(), T=0.5, N=4)
        .initial(x=[0.0, 0.0])
        .minimize(integral=lambda p: p.u**2)
    )
    second = OCP(double_integrator(), T=0.5, N=4).minimize(integral=lambda p: p.u**2)
    problem = (
        Phases.sequence(("first", first), ("second", second))
        .param("L", lower=0.0, upper=2.0)
        .periodic(lambda x: ca.vertcat(0 * x[0], 0 * x[1]))  # back to rest at 0 (a reset)
        .constrain_event(
            "second",
            "reach",
            lambda e: ca.vertcat(e.x_before[0] - e.L, e.x_before[1]),
            lower=0.0,
            upper=0.0,
        )
    )
    solution = problem.solve(progress=False, options=TIGHT)
    # Nothing rewards L: it goes to 0 (no motion).
    assert solution.params["L"] == pytest.approx(0.0, abs=1e-6)
    again = problem.guess(solution).solve(progress=False)
    assert again.stats["warm_start"] and again.iterations <= solution.iterations


def test_nlp_derivatives_with_phases_and_parameters_against_central_differences():
    problem = kick_phases("hermite-simpson", None, 3).param("L", lower=-1.0, upper=1.0)
    problem = problem.constrain_event(
        "before", "use L", lambda e: e.x_before[0] - e.L, lower=-5.0, upper=5.0
    )
    transcription = problem.transcribe()
    nlp = transcription.parametric_nlp
    w, p = nlp["x"], nlp["p"]
    values = ca.Function("values", [w, p], [nlp["f"], nlp["g"]])
    jacobian = ca.Function("jacobian", [w, p], [ca.jacobian(nlp["g"], w)])
    gradient = ca.Function("gradient", [w, p], [ca.gradient(nlp["f"], w)])
    rng = np.random.default_rng(3)
    point = transcription.initial_guess() + 0.1 * rng.normal(size=transcription.n_w)
    parameters = transcription.parameter_values()
    exact_j = np.asarray(jacobian(point, parameters).full())
    exact_f = np.asarray(gradient(point, parameters)).reshape(-1)
    checked, nonzero = 0, 0
    h = 1e-6
    for i in range(transcription.n_w):
        step = np.zeros(transcription.n_w)
        step[i] = h
        f_plus, g_plus = values(point + step, parameters)
        f_minus, g_minus = values(point - step, parameters)
        fd_g = (np.asarray(g_plus) - np.asarray(g_minus)).reshape(-1) / (2 * h)
        fd_f = float(f_plus - f_minus) / (2 * h)
        scale = np.abs(fd_g) + np.abs(exact_j[:, i]) + 1.0
        assert np.all(np.abs(fd_g - exact_j[:, i]) <= 1e-6 * scale), i
        assert abs(fd_f - exact_f[i]) <= 1e-6 * (abs(fd_f) + 1.0), i
        checked += fd_g.size + 1
        nonzero += int(np.count_nonzero(exact_j[:, i]))
    # The guard: every variable was checked and the parameter's column is not empty.
    assert checked == transcription.n_w * (transcription.n_g + 1) and nonzero > 0
    assert np.count_nonzero(exact_j[:, -1]) >= 1  # L (the last variable) enters a row


# ---- non-uniform meshes --------------------------------------------------------------------
def graded(N: int) -> np.ndarray:
    """Interval lengths growing geometrically by 1.5 across the horizon."""
    return 1.5 ** np.linspace(0.0, 1.0, N) * np.linspace(1.0, 3.0, N)


GRADED = [
    ("trapezoid", None, [4, 8, 16, 32]),
    ("hermite-simpson", None, [2, 4, 8, 16]),
    ("radau", 3, [2, 4, 8]),
    ("legendre", 3, [2, 4, 8]),
]


@pytest.mark.parametrize(("name", "degree", "Ns"), GRADED, ids=IDS)
def test_non_uniform_mesh_converges_at_the_scheme_order(name, degree, Ns):
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
                mesh=graded(N),
            )
            .initial(y=1.0)
            .minimize(integral=lambda p: p.y**2 + p.w**2)
        )
        errors.append(abs(ocp.solve(progress=False, options=TIGHT).cost - np.tanh(LQ_T)))
    errors = np.array(errors)
    assert np.all(errors > 1e-12), errors
    assert fitted_order(Ns, errors) >= make_scheme(name, degree).order - 0.3, errors


def test_non_uniform_nodes_interpolants_and_accuracy():
    lengths = np.array([1.0, 2.0, 4.0, 1.0])
    ocp = rest_to_rest(4).refine(mesh=lengths)
    solution = ocp.solve(progress=False, options=TIGHT)
    assert solution.cost == pytest.approx(12.0, rel=1e-9)  # cubic: exact on any mesh
    breaks = np.concatenate([[0.0], np.cumsum(lengths)]) / lengths.sum()
    np.testing.assert_allclose(solution.time, breaks, atol=1e-15)
    np.testing.assert_allclose(solution.interval_lengths, lengths / lengths.sum(), atol=1e-15)
    # The interpolant passes through the nodes and is the exact cubic 3 t^2 - 2 t^3.
    t = np.linspace(0, 1, 41)
    np.testing.assert_allclose(solution.state(t)[:, 0], 3 * t**2 - 2 * t**3, atol=1e-9)
    np.testing.assert_allclose(solution.state(solution.time), solution.states, atol=1e-14)
    assert solution.integration_error().max < 1e-10
    with pytest.raises(DefinitionError, match=r"`h`: the mesh is not uniform"):
        _ = solution.h
    # Nodes are located in their own interval (Radau: the interval they end).
    mesh = Mesh(make_scheme("radau", 3), 4, ocp.mesh)
    k, tau = mesh.locate(breaks)
    np.testing.assert_array_equal(k, [0, 0, 1, 2, 3])
    np.testing.assert_allclose(tau, [0, 1, 1, 1, 1], atol=1e-12)


def test_bad_mesh_and_parameter_input_is_refused():
    with pytest.raises(DefinitionError, match=r"`mesh`: give N = 4 relative interval lengths"):
        rest_to_rest(4).refine(N=4, mesh=[1.0, 2.0])
    with pytest.raises(DefinitionError, match=r"`mesh`: interval lengths must be finite and > 0"):
        rest_to_rest(3).refine(mesh=[1.0, 0.0, 2.0])
    with pytest.raises(DefinitionError, match=r"`param`: 'u' is already a field of the Point"):
        rest_to_rest(3).param("u")
    with pytest.raises(DefinitionError, match=r"`param`: a parameter's name must be an identifier"):
        rest_to_rest(3).param("step length")
    with pytest.raises(DefinitionError, match=r"`param\[L\]`: the guess 3.0 must be finite"):
        rest_to_rest(3).param("L", 0.0, 1.0, guess=3.0)
    with pytest.raises(DefinitionError, match=r"`param\[L\]`: lower bound 2 > upper bound 1"):
        rest_to_rest(3).param("L", 2.0, 1.0)


def test_bad_phases_input_is_refused():
    ocp = rest_to_rest(3)
    with pytest.raises(DefinitionError, match=r"`phases\[1\]`: two phases are called 'a'"):
        Phases.sequence(("a", ocp), ("a", ocp))
    with pytest.raises(DefinitionTypeError, match=r"`phases\[0\]` \('a'\): must be a planner.OCP"):
        Phases.sequence(("a", "ocp"))
    scalar = OCP(integrator(), T=1.0, N=3)
    with pytest.raises(DefinitionError, match=r"continuity needs the same states on both sides"):
        Phases.sequence(("a", ocp), ("b", scalar))
    with pytest.raises(DefinitionError, match=r"the mapping must return the next phase's state"):
        Phases.sequence(("a", ocp)).then("b", ocp, mapping=lambda x: x[0])
    with pytest.raises(DefinitionError, match=r"`phase`: no phase called 'c'"):
        Phases.sequence(("a", ocp), ("b", ocp)).join("c")
    with pytest.raises(DefinitionError, match=r"'b' is the last phase and the problem is not"):
        Phases.sequence(("a", ocp), ("b", ocp)).constrain_event(
            "b", "e", lambda e: e.T_after, lower=0
        )
    with pytest.raises(DefinitionError, match=r"`event\[e\]`: evaluating the expression failed"):
        Phases.sequence(("a", ocp), ("b", ocp)).constrain_event(
            "a", "e", lambda e: e.speed, lower=0
        )
    with pytest.raises(DefinitionError, match=r"`param`: 'L' has bounds \[0, 1\] in one phase"):
        Phases.sequence(("a", ocp.param("L", 0, 1)), ("b", ocp.param("L", 0, 2)))
