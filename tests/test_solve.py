"""Solving: status handling and failure surfacing, progress, stats, formulations, free time,
periodic maps."""

from __future__ import annotations

import functools
import logging
import math

import casadi as ca
import numpy as np
import pytest

from model import AnthropoidError, DefinitionError, Dynamics, presets
from planner import OCP, SolverError, Transcription, solve
from planner.errors import DefinitionTypeError
from problems import GaitLaw

ZETA = np.array([0.20, 0.30, 0.40, 0.30, 0.10, 0.05])
VARPI = np.array([0.00, 0.50, 1.00, 1.50, 0.20, 0.40])


def law(t):
    """The "paper22" law of scene.md (T = 1 s): (psi, dpsi, ddpsi), each (K, 6)."""
    t = np.asarray(t, dtype=float)[:, None]
    w = 2 * np.pi
    phase = VARPI - (1 - np.cos(w * t)) * np.pi / 2
    dphase = -np.sin(w * t) * w * np.pi / 2
    ddphase = -np.cos(w * t) * w * w * np.pi / 2
    psi = np.pi / 2 + ZETA * np.sin(phase)
    dpsi = ZETA * np.cos(phase) * dphase
    ddpsi = ZETA * (np.cos(phase) * ddphase - np.sin(phase) * dphase**2)
    return psi, dpsi, ddpsi


#: The same law as a CasADi expression of the symbolic time, for constraints and costs.
law_sx = GaitLaw.preset("paper22").psi


SIX_LINK = Dynamics(presets.six_link_anthropoid())


def gait(N=10, formulation="implicit", transcription="hermite-simpson"):
    return (
        OCP(SIX_LINK, T=1.0, N=N, transcription=transcription, formulation=formulation)
        .constrain("near_law", lambda p: p.psi - law_sx(p.t), lower=-0.1, upper=0.1)
        .periodic()
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(law)
    )


def double_integrator():
    x = ca.SX.sym("x", 2)
    u = ca.SX.sym("u")
    return ca.Function("f", [x, u], [ca.vertcat(x[1], u)], ["x", "u"], ["xdot"])


def rest_to_rest(N=5, T=1.0):
    return (
        OCP(double_integrator(), T=T, N=N, state_names=("q", "v"), control_names=("a",))
        .initial(q=0.0, v=0.0)
        .final(q=1.0, v=0.0)
        .minimize(integral=lambda p: p.a**2)
    )


# ---- failure surfacing -------------------------------------------------------------------


def test_max_iter_raises_solver_error_with_status_and_named_constraints():
    with pytest.raises(
        SolverError, match=r"Maximum_Iterations_Exceeded after 1 iterations"
    ) as info:
        gait(N=6).solve(options={"max_iter": 1}, progress=False)
    error = info.value
    assert isinstance(error, AnthropoidError)
    assert error.status == "Maximum_Iterations_Exceeded"
    assert error.iterations == 1
    assert error.violations and error.violations[0][1] > 0
    # the worst rows carry names that say what and where
    assert error.violations[0][0].split("[")[0] in ("defect", "dynamics", "path", "periodic")
    assert error.violations[0][0] in str(error)
    assert error.solution.success is False
    assert error.solution.status == "Maximum_Iterations_Exceeded"
    assert error.solution.states.shape == (7, 12)


def test_contradictory_constraints_raise_infeasible_naming_the_constraint():
    # q(0) = 0 from initial(), and a start constraint q(0) >= 0.5: infeasible.
    ocp = rest_to_rest().boundary("lifted", lambda p: p.q, "start", lower=0.5)
    with pytest.raises(SolverError, match=r"Infeasible_Problem_Detected") as info:
        ocp.solve(progress=False)
    names = [name for name, _ in info.value.violations]
    assert any(n in ("start[lifted]", "start[initial q]") for n in names), names
    assert "start[" in str(info.value)


def test_contradictory_bounds_raise_at_definition():
    with pytest.raises(DefinitionError, match=r"`bound\[a\]`: lower bound 2 > upper bound 1"):
        rest_to_rest().bound("a", 2.0, 1.0)


def test_failure_returns_solution_when_asked():
    solution = gait(N=6).solve(options={"max_iter": 2}, progress=False, raise_on_failure=False)
    assert solution.success is False
    assert solution.status == "Maximum_Iterations_Exceeded"
    assert solution.iterations == 2


def test_acceptable_level_counts_only_when_accepted():
    # An unreachable tolerance with a loose acceptable level ends at "acceptable".
    options = {"tol": 1e-30, "acceptable_tol": 1e-2, "acceptable_iter": 1, "max_iter": 50}
    with pytest.raises(SolverError, match=r"Solved_To_Acceptable_Level \(pass accept_acceptable"):
        gait(N=6).solve(options=options, progress=False)
    solution = gait(N=6).solve(options=options, progress=False, accept_acceptable=True)
    assert solution.success is True
    assert solution.status == "Solved_To_Acceptable_Level"


def test_unknown_ipopt_option_is_a_definition_error():
    with pytest.raises(DefinitionError, match=r"`options`: IPOPT refused"):
        rest_to_rest().solve(options={"no_such_option": 1}, progress=False)
    with pytest.raises(DefinitionError, match=r"`options`: IPOPT refused .*no_such_solver"):
        rest_to_rest().solve(options={"linear_solver": "no_such_solver"}, progress=False)
    with pytest.raises(DefinitionTypeError, match=r"`options`: must be a dict of IPOPT options"):
        rest_to_rest().solve(options=[("tol", 1e-3)], progress=False)
    with pytest.raises(DefinitionTypeError, match=r"`progress`: must be a bool or a callable"):
        rest_to_rest().solve(progress="verbose")
    with pytest.raises(DefinitionTypeError, match=r"`problem`: must be a planner.OCP"):
        solve("ocp")


# ---- progress and stats ------------------------------------------------------------------


def test_progress_callable_and_logger(caplog):
    rows = []
    solution = gait(N=6).solve(progress=rows.append)
    assert [r["iteration"] for r in rows] == list(range(solution.iterations + 1))
    assert rows[-1]["infeasibility"] < 1e-6
    assert rows[-1]["objective"] == pytest.approx(solution.cost, rel=1e-12)
    with caplog.at_level(logging.INFO, logger="planner.progress"):
        rest_to_rest().solve(progress=True)
    assert any("objective" in r.getMessage() for r in caplog.records)
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="planner.progress"):
        rest_to_rest().solve(progress=False)
    assert not caplog.records


def test_stats_are_recorded():
    stats = gait(N=6).solve(progress=False).stats
    for key in ("build_seconds", "solve_seconds", "function_seconds", "transcription_seconds"):
        assert stats[key] > 0, key
    assert stats["function_seconds"] < stats["solve_seconds"]
    assert stats["iterations"] == stats["ipopt"]["iter_count"] > 0
    assert stats["n_variables"] == (12 + 6 + 6) * 13


# ---- semantics -----------------------------------------------------------------------------


def tracking(N, formulation):
    """Six-link periodic motion tracking the law, with a small torque cost (smooth, unique)."""
    return (
        OCP(SIX_LINK, T=1.0, N=N, formulation=formulation)
        .periodic()
        .minimize(integral=lambda p: 1e-2 * ca.sumsqr(p.M) + 1e4 * ca.sumsqr(p.psi - law_sx(p.t)))
        .guess(law)
    )


@pytest.mark.parametrize("transcription", ["hermite-simpson", "radau"])
def test_implicit_and_explicit_reach_the_same_optimum(transcription):
    implicit = tracking(10, "implicit").refine(transcription=transcription)
    explicit = tracking(10, "explicit").refine(transcription=transcription)
    a = implicit.solve(progress=False, options={"tol": 1e-10})
    b = explicit.solve(progress=False, options={"tol": 1e-10})
    assert a.formulation == "implicit" and b.formulation == "explicit"
    assert a.cost == pytest.approx(b.cost, rel=1e-6)
    np.testing.assert_allclose(a.states, b.states, atol=1e-6)
    np.testing.assert_allclose(a.drives, b.drives, atol=1e-6 * np.abs(b.drives).max())
    # ddpsi where the dynamics hold (a Radau node 0 is an extrapolation, different in each)
    ddpsi_a, ddpsi_b = a.acceleration(a.point_time), b.acceleration(b.point_time)
    np.testing.assert_allclose(ddpsi_a, ddpsi_b, atol=1e-6 * np.abs(ddpsi_b).max())


def test_solving_twice_gives_the_same_result_and_the_ocp_is_unchanged():
    ocp = gait(N=6)
    text = str(ocp)
    first = ocp.solve(progress=False)
    second = ocp.solve(progress=False)
    assert str(ocp) == text
    assert first.cost == second.cost
    np.testing.assert_array_equal(first.w, second.w)
    # a built Transcription can be solved again too
    transcription = Transcription(ocp)
    third = solve(transcription, progress=False)
    assert third.cost == pytest.approx(first.cost, rel=1e-12)


def test_free_final_time_matches_closed_form():
    # min integral (1 + a^2), rest to rest over a unit distance: J(T) = T + 12 / T^3,
    # optimal T = 36^(1/4) = sqrt(6); Hermite-Simpson is exact for the cubic motion.
    ocp = (
        OCP(double_integrator(), T=(0.5, 5.0), N=6, state_names=("q", "v"), control_names=("a",))
        .initial(q=0.0, v=0.0)
        .final(q=1.0, v=0.0)
        .minimize(integral=lambda p: 1 + p.a**2)
        .guess(T=1.0)
    )
    solution = ocp.solve(progress=False, options={"tol": 1e-12})
    assert solution.T == pytest.approx(np.sqrt(6.0), rel=1e-8)
    assert solution.cost == pytest.approx(np.sqrt(6.0) + 12 / 6**1.5, rel=1e-10)


def test_mayer_term_and_periodic_map():
    # x(0) = Delta(x(T)) with Delta(q, v) = (-q, v): a symmetric swing. Minimise
    # integral a^2 + (q(T) - 1)^2 with v(0) = 0; check the map at the solution.
    ocp = (
        OCP(double_integrator(), T=1.0, N=8, state_names=("q", "v"), control_names=("a",))
        .periodic(lambda x: ca.vertcat(-x[0], x[1]))
        .initial(v=0.0)
        .minimize(integral=lambda p: p.a**2, terminal=lambda p: 100 * (p.q - 1) ** 2)
    )
    solution = ocp.solve(progress=False, options={"tol": 1e-12})
    x0, xT = solution.states[0], solution.states[-1]
    np.testing.assert_allclose(x0, [-xT[0], xT[1]], atol=1e-10)
    # Closed form: with v(0) = v(T) = 0 a displacement d = q(T) - q(0) costs at least 12 d^2
    # (minimum energy), and q(T) = -q(0) gives q(T) = d / 2: minimise
    # 12 d^2 + 100 (d/2 - 1)^2, so d = 100 / 74.
    d = 100 / (24 + 50)
    assert xT[0] == pytest.approx(d / 2, rel=1e-8)
    assert solution.cost == pytest.approx(12 * d**2 + 100 * (d / 2 - 1) ** 2, rel=1e-8)


@pytest.mark.slow  # a benchmark's tables printed: 30 s of solves
def test_benchmark_quick_run():
    """The benchmark runs as a user runs it (a subprocess, --quick) and prints its tables."""
    import os
    import re
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "examples" / "benchmarks" / "planner_bench.py"
    result = subprocess.run(
        [sys.executable, str(script), "--quick"],
        capture_output=True,
        text=True,
        timeout=300,
        env=dict(os.environ, MPLBACKEND="Agg"),
    )
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    for expected in (
        "hermite-simpson",
        "radau(3)",
        "legendre(3)",
        "trapezoid",
        "explicit / implicit",
        "same-mesh warm start with multipliers",
        "walking pieces",
        "+ all three",
        "phases: the headline",
        "two, continuous",
        "two, jump",
        # the headline cut in two with continuous controls is the one-phase NLP
        "; 0 variables more: the same NLP",
    ):
        assert expected in result.stdout, expected
    assert "Maximum_Iterations" not in result.stdout
    assert "multipliers were not reused" not in result.stdout
    out = result.stdout
    # The before/after table (issue 10): its header and a Hermite-Simpson row whose ratio is
    # the ratio of the two solve times it prints.
    assert "\nbefore/after: before = mu_strategy monotone" in out
    assert re.search(r"case +iters +solve ms +after/before +cost +\|d cost\|", out)
    table = re.search(
        r"hermite-simpson N=20 +(\d+) -> +(\d+) +(\d+) -> +(\d+) +(\d+\.\d\d)x +([\d.]+)", out
    )
    assert table, out
    before_ms, after_ms, ratio = int(table[3]), int(table[4]), float(table[5])
    assert ratio == pytest.approx(after_ms / before_ms, abs=0.01 + 1.0 / before_ms)
    # The solve-time exponents: one per transcription, and before/after for Hermite-Simpson.
    number = r"-?\d+\.\d\d"
    for label in ("trapezoid", "hermite-simpson", "radau(3)", "legendre(3)", "before", "after"):
        assert re.search(
            rf"^  {re.escape(label)} +solve time ~ N\^{number}, time per iteration ~ N\^{number}$",
            out,
            re.MULTILINE,
        ), label
    assert "fitted over N = 20..40" in out and "hermite-simpson, fitted over N = 20..40:" in out


# ---- warm start of the multipliers ---------------------------------------------------------

CHAIN = Dynamics(presets.n_link_chain(2))
DOWN = -np.pi / 2
RAISED = np.array([DOWN + 1.0, DOWN + 1.5])
TIGHT = {"tol": 1e-10}


def elbow_swing(N=10, limit=10.0, weight=1.0, elbow=0.6, transcription="hermite-simpson"):
    """Two-link chain from hanging at rest to a raised pose at rest in 1.5 s, min sum M^2
    (+ (weight - 1) M_1^2), |M| <= limit and |psi_1 - psi_0| <= elbow: at the optimum 7 bounds
    and 5 elbow rows are active, so both kinds of multipliers matter."""
    degree = 3 if transcription in ("radau", "legendre") else None
    return (
        OCP(CHAIN, T=1.5, N=N, transcription=transcription, degree=degree)
        .initial(psi=[DOWN, DOWN], dpsi=0.0)
        .final(psi=RAISED, dpsi=0.0)
        .bound("M", -limit, limit)
        .constrain("elbow", lambda p: p.psi[1] - p.psi[0], lower=-elbow, upper=elbow)
        .minimize(integral=lambda p: ca.sumsqr(p.M) + (weight - 1.0) * p.M[1] ** 2)
        .guess(t=[0.0, 1.5], psi=[[DOWN, DOWN], RAISED])
    )


@functools.cache
def elbow_optimum():
    solution = elbow_swing().solve(progress=False, options=TIGHT)
    transcription = solution.transcription
    active_bounds = np.abs(solution.lam_x) > 1e-6
    inequality = transcription.lbg != transcription.ubg
    active_rows = (np.abs(solution.lam_g) > 1e-6) & inequality
    assert active_bounds.sum() >= 3 and active_rows.sum() >= 3  # the premise of these tests
    assert not solution.stats["warm_start"]
    return solution


def assert_same_optimum(a, b):
    assert a.success and b.success
    assert a.cost == pytest.approx(b.cost, rel=1e-10)
    np.testing.assert_allclose(a.states, b.states, atol=1e-8)
    np.testing.assert_allclose(a.drives, b.drives, atol=1e-7 * np.abs(b.drives).max())


def test_resolving_from_its_own_solution_starts_from_its_multipliers():
    cold = elbow_optimum()
    ocp = elbow_swing().guess(cold)
    primal = ocp.solve(progress=False, options=TIGHT, warm_start=False)
    warm = ocp.solve(progress=False, options=TIGHT)
    assert warm.stats["warm_start"] and not primal.stats["warm_start"]
    # deterministic counts: 2 with the multipliers, 8 from the primal point only, 12 cold
    assert warm.iterations <= 3
    assert 3 * warm.iterations <= primal.iterations < cold.iterations
    assert_same_optimum(warm, cold)
    # the same KKT point: the multipliers agree too
    np.testing.assert_allclose(warm.lam_g, cold.lam_g, atol=1e-6 * np.abs(cold.lam_g).max())
    np.testing.assert_allclose(warm.lam_x, cold.lam_x, atol=1e-6 * np.abs(cold.lam_x).max())


@pytest.mark.parametrize(
    "change", [{"limit": 9.8}, {"weight": 1.05}, {"elbow": 0.588}], ids=["bound", "weight", "path"]
)
def test_continuation_reaches_the_cold_optimum_in_fewer_iterations(change):
    previous = elbow_optimum()
    ocp = elbow_swing(**change)
    cold = ocp.solve(progress=False, options=TIGHT)
    primal = ocp.guess(previous).solve(progress=False, options=TIGHT, warm_start=False)
    warm = ocp.guess(previous).solve(progress=False, options=TIGHT)
    assert warm.nlp_signature == previous.nlp_signature
    if "limit" in change:  # the default scale of M follows the bound: multipliers converted
        assert warm.transcription.control_scale[0] == 9.8
    assert warm.stats["warm_start"] and not primal.stats["warm_start"]
    assert_same_optimum(warm, cold)
    # 6-7 iterations with the multipliers, 9-10 from the primal point only, 12-13 cold (with
    # the adaptive barrier update of the defaults; 4-5, 11-14 and 14 with the monotone one)
    assert warm.iterations <= 7
    assert warm.iterations < primal.iterations < cold.iterations


def test_multipliers_follow_a_change_of_nominal_scales():
    # Scales are no part of the layout: the multipliers of the scaled NLP are converted
    # (lam / scale is the physical multiplier). Oracle: the same problem solved at the new
    # scales has the converted multipliers (up to IPOPT's bound relaxation, 1e-8 scaled).
    from planner.solver import warm_start_multipliers

    ocp = elbow_swing()
    small = ocp.scale(M=5.0).solve(progress=False, options={"tol": 1e-12})
    large = ocp.scale(M=40.0).solve(progress=False, options={"tol": 1e-12})
    assert small.nlp_signature == large.nlp_signature
    # the conversion is to the objective scale ``large`` was solved with (1 here: the
    # objective's gradient lies in the range left unscaled)
    f_scale = large.stats["objective_scale"]
    lam_x, lam_g = warm_start_multipliers(
        Transcription(ocp.scale(M=40.0).guess(small)), objective_scale=f_scale
    )
    np.testing.assert_allclose(lam_x, large.lam_x, atol=1e-6 * np.abs(large.lam_x).max())
    np.testing.assert_allclose(lam_g, large.lam_g, atol=1e-6 * np.abs(large.lam_g).max())
    assert np.abs(small.lam_x - large.lam_x).max() > 0.1 * np.abs(large.lam_x).max()
    warm = ocp.scale(M=40.0).guess(small).solve(progress=False, options=TIGHT)
    primal = ocp.scale(M=40.0).guess(small).solve(progress=False, options=TIGHT, warm_start=False)
    # 3 and 8 (3 and 13 with the monotone barrier update, which warm starts less well)
    assert warm.stats["warm_start"] and 2 * warm.iterations <= primal.iterations


def test_multipliers_are_carried_onto_a_mesh_with_intervals_cut_in_halves():
    """A mesh cut (``hold_at_samples`` halves intervals where limits miss between points):
    each new row and variable takes the multiplier of its place on the old mesh, a path
    row's, dynamics row's or bound's scaled by its point's quadrature weight (a defect's is a
    costate, kept). Oracle: the multipliers IPOPT converges to on the cut mesh from a cold
    start; carried, they are within 15 % of them (in norm), closer than copied unscaled."""
    from planner.mesh_multipliers import carried_entries
    from planner.solver import warm_start_multipliers

    previous = elbow_optimum()
    mesh = [piece for k in range(10) for piece in ([0.05, 0.05] if k in (2, 6) else [0.1])]
    cut = elbow_swing().refine(mesh=mesh)
    cold = cut.solve(progress=False, options=TIGHT)
    transcription = Transcription(cut.guess(previous))
    assert transcription.signature != previous.nlp_signature
    lam_x, lam_g = warm_start_multipliers(transcription, cold.stats["objective_scale"])
    for carried, converged in ((lam_x, cold.lam_x), (lam_g, cold.lam_g)):
        assert np.linalg.norm(carried - converged) < 0.15 * np.linalg.norm(converged)
    old = previous.transcription
    _, (rows, factors) = carried_entries(old, transcription)
    assert np.all(rows >= 0) and set(np.round(factors, 12)) == {0.25, 0.5, 1.0}
    unscaled = previous.lam_g[rows] * transcription.g_scale / old.g_scale[rows]
    assert np.linalg.norm(lam_g - cold.lam_g) < np.linalg.norm(unscaled - cold.lam_g)
    warm = cut.guess(previous).solve(progress=False, options=TIGHT)
    assert warm.stats["warm_start"]
    assert_same_optimum(warm, cold)
    # a mesh that is not the old one cut in halves takes the primal guess only
    other = elbow_swing().refine(mesh=[0.1] * 8 + [0.07, 0.08, 0.05]).guess(previous)
    assert warm_start_multipliers(Transcription(other)) is None


@pytest.mark.parametrize(
    "other",
    [{"N": 14}, {"transcription": "radau"}, {"transcription": "trapezoid"}],
    ids=["N", "radau", "trapezoid"],
)
def test_another_layout_takes_the_primal_guess_only(other):
    from planner.solver import warm_start_multipliers

    previous = elbow_optimum()
    ocp = elbow_swing(**other).guess(previous)
    assert Transcription(ocp).signature != previous.nlp_signature
    assert warm_start_multipliers(Transcription(ocp)) is None
    warm = ocp.solve(progress=False, options=TIGHT)
    assert warm.success and not warm.stats["warm_start"]
    # exactly what the switch turned off gives: a primal re-gridding, IPOPT's defaults
    primal = ocp.solve(progress=False, options=TIGHT, warm_start=False)
    assert warm.iterations == primal.iterations
    np.testing.assert_array_equal(warm.w, primal.w)


def test_warm_start_can_be_turned_off_and_needs_a_converged_solution_guess():
    previous = elbow_optimum()
    ocp = elbow_swing().guess(previous)
    primal = ocp.solve(progress=False, options=TIGHT, warm_start=False)
    assert not primal.stats["warm_start"] and primal.iterations >= 3 * 2  # 8, warm: 2
    # IPOPT's own switch in the options turns it off too
    off = ocp.solve(progress=False, options={**TIGHT, "warm_start_init_point": "no"})
    assert not off.stats["warm_start"] and off.iterations == primal.iterations
    # an explicit decision vector is a primal guess
    explicit = ocp.solve(progress=False, options=TIGHT, guess=previous.w)
    assert not explicit.stats["warm_start"]
    # a failed solve's multipliers are not reused
    failed = elbow_swing().solve(progress=False, options={"max_iter": 3}, raise_on_failure=False)
    assert not failed.success and failed.lam_x is not None
    after = elbow_swing().guess(failed).solve(progress=False, options=TIGHT)
    assert after.success and not after.stats["warm_start"]
    # a later guess over the Solution's, or a Trajectory (no multipliers): primal only
    layered = elbow_swing().guess(previous).guess(M=0.0).solve(progress=False, options=TIGHT)
    assert not layered.stats["warm_start"]
    exported = elbow_swing().guess(previous.to_trajectory()).solve(progress=False, options=TIGHT)
    assert not exported.stats["warm_start"]
    with pytest.raises(DefinitionTypeError, match=r"`warm_start`: must be True or False"):
        ocp.solve(progress=False, warm_start="yes")


def test_a_guess_of_the_wrong_shape_is_refused_before_ipopt_is_set_up(monkeypatch):
    import planner.solver as solver_module

    def refuse(*arguments, **options):
        raise AssertionError("no solver is built for a guess of the wrong shape")

    monkeypatch.setattr(solver_module, "nlp_solver", refuse)
    with pytest.raises(DefinitionError, match=r"`guess`: expected a decision vector of shape"):
        rest_to_rest().solve(progress=False, guess=np.zeros(3))


@pytest.fixture
def solver_options(monkeypatch):
    """The IPOPT options of every solver built while the test runs, in order."""
    import planner.solver as solver_module

    seen = []
    build = solver_module.nlp_solver

    def recording(transcription, options=None, report=None, **keywords):
        seen.append(dict(options or {}))
        return build(transcription, options, report, **keywords)

    monkeypatch.setattr(solver_module, "nlp_solver", recording)
    return seen


def test_user_options_override_the_warm_start_options(solver_options):
    import planner.solver as solver_module

    seen = solver_options
    ocp = elbow_swing().guess(elbow_optimum())
    warm = ocp.solve(
        progress=False, options={"mu_strategy": "monotone", "mu_init": 1e-9}, cache=False
    )
    assert warm.success and warm.stats["warm_start"]
    assert seen[-1] == {
        **solver_module.WARM_START_IPOPT,
        "mu_strategy": "monotone",
        "mu_init": 1e-9,
    }
    ocp.solve(progress=False, options={"tol": 1e-9}, warm_start=False, cache=False)
    assert seen[-1] == {"tol": 1e-9}  # nothing added when it is off


def test_a_near_restart_reaches_the_same_optimum_in_fewer_iterations_and_falls_back(
    solver_options, monkeypatch
):
    """A bound moved by a thousandth of itself (what a hold round does): the near restart
    (barrier and pushes at 1e-8) reaches the cold solve's optimum, in fewer iterations than
    the plain warm start; a near restart that fails is solved again with the plain warm start
    and says so; without multipliers to start from nothing is added."""
    import planner.solver as solver_module

    seen = solver_options
    previous = elbow_optimum()
    moved = elbow_swing(limit=9.99)
    cold = moved.solve(progress=False, options=TIGHT)
    plain = moved.guess(previous).solve(progress=False, options=TIGHT, cache=False)
    near = moved.guess(previous).solve(
        progress=False, options=TIGHT, near_restart=True, cache=False
    )
    assert seen[-1] == {
        **solver_module.WARM_START_IPOPT,
        **solver_module.NEAR_RESTART_IPOPT,
        **TIGHT,
    }
    assert near.stats["warm_start"] and near.stats["near_restart"]
    assert plain.stats["warm_start"] and not plain.stats["near_restart"]
    assert_same_optimum(near, cold)
    assert near.iterations < plain.iterations
    # a failed near restart (here: stopped after one iteration) is solved again plainly
    monkeypatch.setattr(
        solver_module, "NEAR_RESTART_IPOPT", {**solver_module.NEAR_RESTART_IPOPT, "max_iter": 1}
    )
    retried = moved.guess(previous).solve(
        progress=False, options=TIGHT, near_restart=True, cache=False
    )
    assert retried.stats["near_restart_failed"]["status"] == "Maximum_Iterations_Exceeded"
    assert retried.stats["near_restart_failed"]["iterations"] == 1
    assert not retried.stats["near_restart"] and retried.iterations == plain.iterations
    assert_same_optimum(retried, cold)
    # no multipliers (a primal guess): a cold start, nothing of the near restart's
    primal = moved.solve(progress=False, options=TIGHT, near_restart=True, cache=False)
    assert seen[-1] == TIGHT and not primal.stats["near_restart"]
    with pytest.raises(DefinitionTypeError, match=r"`near_restart`: must be True or False"):
        moved.solve(progress=False, near_restart=1)


# ---- generic dynamics: implicit residuals and time-dependent ODEs ----------------------------


def test_generic_implicit_residual_reaches_the_explicit_optimum():
    x = ca.SX.sym("x", 2)
    xdot = ca.SX.sym("xdot", 2)
    u = ca.SX.sym("u")
    residual = ca.Function("r", [x, xdot, u], [xdot - ca.vertcat(x[1], u)])
    ocp = (
        OCP(
            residual,
            T=1.0,
            N=4,
            formulation="implicit",
            state_names=("q", "v"),
            control_names=("a",),
        )
        .initial(q=0.0, v=0.0)
        .final(q=1.0, v=0.0)
        .minimize(integral=lambda p: p.a**2)
    )
    assert ocp.system.aux_names == ("dq", "dv")
    solution = ocp.solve(progress=False, options={"tol": 1e-12})
    assert solution.cost == pytest.approx(12.0, rel=1e-10)  # Hermite-Simpson is exact here
    np.testing.assert_allclose(solution.aux_values[:, 1], 6 - 12 * solution.point_time, atol=1e-8)
    # re-integration of the residual as a DAE (IDAS): Hermite-Simpson is exact here
    assert solution.integration_error().max < 1e-9
    assert solution.residual_error().max < 1e-9


def test_time_dependent_ode():
    # x' = u + cos t, min integral (x - sin t)^2 + u^2 from x(0) = 0: u = 0, x = sin t, cost 0.
    x = ca.SX.sym("x")
    u = ca.SX.sym("u")
    t = ca.SX.sym("t")
    f = ca.Function("f", [x, u, t], [u + ca.cos(t)])
    ocp = (
        OCP(f, T=2.0, N=10, state_names=("y",), control_names=("w",))
        .initial(y=0.0)
        .minimize(integral=lambda p: (p.y - ca.sin(p.t)) ** 2 + p.w**2)
    )
    solution = ocp.solve(progress=False, options={"tol": 1e-12})
    assert 0 <= solution.cost < 1e-10
    np.testing.assert_allclose(solution.states[:, 0], np.sin(solution.time), atol=1e-5)
    assert solution.integration_error().max < 1e-5


# ---- slow reliability checks (pytest -m slow) ------------------------------------------------


@functools.cache
def hermite_simpson_gait_cost(N: int) -> float:
    solution = gait(N).solve(progress=False)
    assert solution.success
    return solution.cost


def extrapolated_gait_cost() -> tuple[float, float]:
    """Richardson extrapolation of the Hermite-Simpson costs at N = 40, 80, 160, and the
    observed order log2((J40 - J80) / (J80 - J160))."""
    j40, j80, j160 = (hermite_simpson_gait_cost(N) for N in (40, 80, 160))
    order = math.log2(abs(j40 - j80) / abs(j80 - j160))
    return j160 + (j160 - j80) / (2**order - 1), order


@pytest.mark.slow
def test_hermite_simpson_gait_cost_converges():
    # The differences shrink on refinement, so the extrapolation below is meaningful. The
    # observed order is below Hermite-Simpson's nominal 4 on this gait (about 2.6): the
    # near_law inequality is active on arcs (136 of 486 path rows at N = 40, 235 of 966 at
    # N = 80) whose junctions fall between mesh points, and the optimum is not smooth there.
    # The cost quadrature itself is Simpson's rule (test_transcription.py checks it), and
    # smooth LQ problems show order 4; so only convergence is asserted here.
    _, order = extrapolated_gait_cost()
    assert order >= 1.0


@pytest.mark.slow
@pytest.mark.parametrize(
    "transcription,degree",
    [("trapezoid", None), ("hermite-simpson", None), ("radau", 3), ("legendre", 3)],
)
def test_six_link_gait_converges_on_every_transcription(transcription, degree):
    # The Richardson-extrapolated Hermite-Simpson optimum is the reference; every scheme at
    # N = 80 is within its discretisation error of it.
    reference, _ = extrapolated_gait_cost()
    ocp = gait(80, transcription=transcription).refine(degree=degree)
    solution = ocp.solve(progress=False)
    assert solution.success
    assert solution.cost == pytest.approx(reference, rel=2e-3)
    # per-interval re-integration error: second order for the trapezoid, higher for the rest
    assert solution.integration_error().max < (3e-2 if transcription == "trapezoid" else 5e-3)
    np.testing.assert_allclose(solution.states[0], solution.states[-1], atol=1e-8)


@pytest.mark.slow
def test_coarse_to_fine_gait():
    solution = gait(10).solve(progress=False)
    for N in (20, 40, 80):
        warm = gait(N).guess(solution).solve(progress=False)
        assert warm.success
        solution = warm
    # the warm-started N = 80 solve reaches the cold-started N = 80 optimum
    assert solution.cost == pytest.approx(hermite_simpson_gait_cost(80), rel=1e-6)


def test_progress_callback_exception_is_re_raised():
    def report(row):
        raise ValueError("my progress callback broke")

    with pytest.raises(ValueError, match="my progress callback broke"):
        rest_to_rest().solve(progress=report)


def test_invalid_number_names_where_the_nan_is():
    # sqrt of a negative torque-dependent value: NaN at every iterate, with no NaN constant
    ocp = rest_to_rest().constrain("root", lambda p: ca.sqrt(-1.0 - p.u[0] ** 2), upper=1.0)
    with pytest.raises(SolverError, match=r"Invalid_Number_Detected \(NaN or inf in .*root"):
        ocp.solve(progress=False)


def test_nothing_is_printed_on_a_refused_option_value_or_a_nan(capfd):
    # IPOPT prints the option's documentation on stdout when it refuses a value: caught, and
    # its first words go into the message instead
    with pytest.raises(
        DefinitionError,
        match=r"`options`: IPOPT refused the options \{'mu_strategy': 'bogus'\}; IPOPT said: "
        r'Setting: "bogus" is not a valid setting for Option: mu_strategy',
    ):
        rest_to_rest().solve(options={"mu_strategy": "bogus"}, progress=False, cache=False)
    # A NaN in a guess vector is refused before IPOPT starts, naming the variable
    transcription = Transcription(rest_to_rest())
    guess = transcription.initial_guess()
    guess[0] = np.nan
    with pytest.raises(
        DefinitionError,
        match=r"`guess`: contains NaN or inf at 1 of 33 entries \(bound\[q\] node 0\); give",
    ):
        solve(transcription, guess=guess, progress=False)
    # CasADi warns on stderr for every NaN in a function evaluation
    root = rest_to_rest().constrain("root", lambda p: ca.sqrt(-1.0 - p.u[0] ** 2), upper=1.0)
    with pytest.raises(SolverError, match=r"Invalid_Number_Detected"):
        root.solve(progress=False)
    out, err = capfd.readouterr()
    assert out == "" and err == "", (out, err)


def test_solve_module_is_importable_under_its_own_name():
    import planner.solver as solver_module

    assert callable(solver_module.solve) and solver_module.SolverError is SolverError
    assert solve is solver_module.solve


# ---- units: the objective is scaled, so other units solve like SI ------------------------------


def swing_up(linkage, torque_unit, N=30):
    """A pendulum from hanging to upright at rest in 2 s, |M| <= 20 N m, min integral M^2."""
    return (
        OCP(Dynamics(linkage), T=2.0, N=N)
        .initial(psi=-np.pi / 2, dpsi=0.0)
        .final(psi=np.pi / 2, dpsi=0.0)
        .bound("M", -20.0 * torque_unit, 20.0 * torque_unit)
        .minimize(integral=lambda p: ca.sumsqr(p.M))
        .guess(t=[0.0, 2.0], psi=[[-np.pi / 2], [np.pi / 2]])
    )


def assert_same_physical_answer(si, mm, torque_unit, states=1e-7, torques=1e-6):
    assert si.success and mm.success
    np.testing.assert_allclose(mm.states, si.states, atol=states)
    scale = np.abs(si.drives).max()
    np.testing.assert_allclose(mm.drives / torque_unit, si.drives, atol=torques * scale)
    assert mm.cost / torque_unit**2 == pytest.approx(si.cost, rel=1e-8)


def test_si_and_millimetre_gram_pendulum_give_the_same_swing_up_in_as_many_iterations():
    from model import Link, Linkage

    pendulum = Linkage([Link("rod", None, length=1.0, mass=1.0)])
    si = swing_up(pendulum, 1.0).solve(progress=False)
    mm = swing_up(pendulum.in_units(length=1e3, mass=1e3), 1e9).solve(progress=False)
    assert_same_physical_answer(si, mm, 1e9)
    assert abs(mm.iterations - si.iterations) <= 0.2 * si.iterations + 2, (
        si.iterations,
        mm.iterations,
    )
    # SI: the objective's gradient is in the range left as it is; mm/g: 1e18 times larger
    # ((g mm^2/s^2)^2 s against N^2 m^4 s^-3), scaled down by more than IPOPT would
    assert si.stats["objective_scale"] == 1.0 and mm.stats["objective_scale"] > 1e8
    # without it (IPOPT's own scaling stops at 1e-8) the mm/g problem does not converge in
    # ten times the SI iterations (measured: 3000 iterations, Maximum_Iterations_Exceeded)
    unscaled = swing_up(pendulum.in_units(length=1e3, mass=1e3), 1e9).scale(objective=1.0)
    with pytest.raises(SolverError, match="Maximum_Iterations_Exceeded"):
        unscaled.solve(progress=False, options={"max_iter": 10 * si.iterations})


def test_si_and_millimetre_gram_six_link_gait_give_the_same_gait_in_as_many_iterations():
    def bounded_gait(linkage, torque_unit):
        return (
            OCP(Dynamics(linkage), T=1.0, N=16)
            .constrain("near_law", lambda p: p.psi - law_sx(p.t), lower=-0.1, upper=0.1)
            .periodic()
            .bound("M", -2000.0 * torque_unit, 2000.0 * torque_unit)
            .minimize(integral=lambda p: ca.sumsqr(p.M))
            .guess(law)
        )

    six = presets.six_link_anthropoid()
    si = bounded_gait(six, 1.0).solve(progress=False)
    mm = bounded_gait(six.in_units(length=1e3, mass=1e3), 1e9).solve(progress=False)
    # the same scaled NLP (both objective scales outside the range left as it is, 1e18
    # apart), so the same optimum in the same iterations (27 and 27)
    assert mm.stats["objective_scale"] == pytest.approx(1e18 * si.stats["objective_scale"])
    assert_same_physical_answer(si, mm, 1e9, states=1e-7, torques=1e-7)
    assert abs(mm.iterations - si.iterations) <= 0.1 * si.iterations + 2, (
        si.iterations,
        mm.iterations,
    )
    unscaled = bounded_gait(six.in_units(length=1e3, mass=1e3), 1e9).scale(objective=1.0)
    with pytest.raises(SolverError, match="Maximum_Iterations_Exceeded"):
        unscaled.solve(progress=False, options={"max_iter": 2 * si.iterations})


def test_a_given_objective_scale_is_used_and_validated():
    ocp = rest_to_rest()
    solution = ocp.scale(objective=7.0).solve(progress=False)
    assert solution.stats["objective_scale"] == 7.0
    assert solution.cost == pytest.approx(12.0 * 1.0, rel=1e-6)  # 12 (q: 0 -> 1 in 1 s)
    # a warm start keeps the scale of the Solution it starts from
    again = ocp.guess(solution).solve(progress=False)
    assert again.stats["objective_scale"] == 7.0 and again.stats["warm_start"]
    with pytest.raises(
        DefinitionError, match=r"`scale\[objective\]`: scales must be finite and > 0"
    ):
        ocp.scale(objective=0.0)
    assert ocp.scale(objective=3.0).objective_scale == 3.0 and ocp.objective_scale is None
