"""Numerical stability at the extremes: the matrix of ``tests/extremes.py``, case by case.

Model cases against the Newton-Euler oracle (``reference.newton_euler``) and a dense KKT solve
of the impact in numpy; planner cases against closed-form optima of free-time problems; gait
cases verified in numpy (``verify_gait``) or against a tight solve; the walking step and the
fixed-base gait in millimetres and grams against SI; bad input at the public API and the
command line. Tolerances and expected outcomes are the data of ``tests/extremes.py``; the
guide's table (tests/extremes.md) is that data too (``test_the_guide_shows_the_matrix``).
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
from extremes import (
    GAIT_CASES,
    INPUT_CASES,
    MODEL_CASES,
    PLANNER_CASES,
    SCALED_CASES,
    UNITS_CASES,
    ModelCase,
    Raises,
    Tol,
    table,
)
from reference import newton_euler as ne
from reference.checks import relative_error

from model import Dynamics, Link, Linkage, LinkPoint, presets
from planner import OCP, Transcription
from planner.solver import jacobian_mode
from problems import footed_step, footed_step_at, periodic_gait, walking_step
from problems.__main__ import main
from problems.gait.problem import objective_integrand

TESTS = Path(__file__).parent


def _param(case, name):
    return pytest.param(case, id=name, marks=[pytest.mark.slow] if case.slow else [])


# ---- model -------------------------------------------------------------------------------------
def _kkt(linkage: Linkage, point: LinkPoint, psi, dpsi, pinned: bool):
    """The impact by a dense KKT solve per state: M (dq+ - dq-) = J^T L, J dq+ = 0 with the
    oracle's mass matrix and point Jacobian. Returns ((K, n + 4) [dpsi+, L, base+],
    cond(KKT) (K,), cond(M) (K,))."""
    i = linkage.index(point.link)
    offset = linkage.links[i].length * complex(point.along, point.lateral)
    masses = ne.floating_mass_matrix(linkage, psi)
    jacobians = ne.point_jacobian(linkage, i, offset, psi)
    n = linkage.n
    rows, conds, mass_conds = [], [], []
    for k in range(len(psi)):
        mass, jac = masses[k], jacobians[k]
        before = np.r_[0.0, 0.0, dpsi[k]]
        if pinned:
            mass, jac, before = mass[2:, 2:], jac[:, 2:], dpsi[k]
        size = mass.shape[0]
        kkt = np.block([[mass, -jac.T], [jac, np.zeros((2, 2))]])
        x = np.linalg.solve(kkt, np.r_[mass @ before, 0.0, 0.0])
        base = np.zeros(2) if pinned else x[:2]
        rows.append(np.r_[x[size - n : size], x[size:], base])
        conds.append(np.linalg.cond(kkt))
        mass_conds.append(np.linalg.cond(mass))
    return np.array(rows), np.array(conds), np.array(mass_conds)


def _model_quantity(quantity, linkage, dyn, point, psi, dpsi, ddpsi, torques):
    """(model result, reference, per-state condition numbers by name); the model's result is
    computed first, so that a case where it must raise does not depend on the reference."""
    if quantity == "M":
        return dyn.mass_matrix(psi), ne.mass_matrix(linkage, psi), {}
    if quantity == "ID":
        return (
            dyn.inverse_dynamics(psi, dpsi, ddpsi),
            ne.inverse_dynamics(linkage, psi, dpsi, ddpsi),
            {},
        )
    if quantity == "FD":
        reference = ne.forward_dynamics(linkage, psi, dpsi, torques)
        cond = np.linalg.cond(ne.mass_matrix(linkage, psi))
        return dyn.forward_dynamics(psi, dpsi, torques), reference, {"cond(M)": cond}
    if quantity == "FD-r":
        ddpsi_model = dyn.forward_dynamics(psi, dpsi, torques)
        return ne.inverse_dynamics(linkage, psi, dpsi, ddpsi_model), torques, {}
    if quantity == "M_e":
        return dyn.floating.mass_matrix(psi), ne.floating_mass_matrix(linkage, psi), {}
    pinned = quantity == "imp0"
    dpsi_plus, impulse, base = dyn.impact(point, root_pinned=pinned)(psi, dpsi)  # model first
    reference, cond_kkt, cond_mass = _kkt(linkage, point, psi, dpsi, pinned)
    actual = np.hstack([dpsi_plus, impulse, base])
    return actual, reference, {"cond(KKT)": cond_kkt, "cond(M_e)": cond_mass}


@pytest.mark.parametrize("case", [_param(c, c.name) for c in MODEL_CASES])
def test_model_case(case: ModelCase, check):
    built = case.linkage()
    linkages = built if isinstance(built, list) else [built]
    for linkage in linkages:
        dyn = Dynamics(linkage)
        point = LinkPoint(case.point or linkage.names[-1])
        states = case.states(linkage)
        for quantity, outcome in case.checks.items():
            what = f"{case.name}: {quantity}"
            if isinstance(outcome, Raises):
                with pytest.raises(outcome.error, match=outcome.match):
                    _model_quantity(quantity, linkage, dyn, point, *states)
                check.count += 1
                continue
            actual, reference, conds = _model_quantity(quantity, linkage, dyn, point, *states)
            assert np.all(np.isfinite(actual)), f"{what}: NaN or inf"
            errors = relative_error(actual, reference)
            scale = conds[outcome.scaled_by] if outcome.scaled_by else 1.0
            check.errors(errors / scale, what, tol=outcome.value)


def test_model_cases_reach_the_extremes_they_name():
    """The matrix's scenes are as extreme as their names say: six decades of parameters in
    one tree, point masses, com at both ends, 100 rad/s, 40 and 80 links, ten children on one
    link, alignments to 1e-9 rad; and the condition numbers the tolerances are scaled by are
    as large as the notes say."""
    by_name = {c.name: c for c in MODEL_CASES}
    for seed in range(3):
        span = by_name[f"span 1e-3..1e3: random 12-link tree {seed}"].linkage()
        for field in ("length", "mass", "inertia"):
            values = [getattr(link, field) for link in span.links]
            assert max(values) / min(values) > 1e4, (seed, field)
    psi = by_name["span: chain alternating 1e3 and 1e-3 (6 links)"].states(
        by_name["span: chain alternating 1e3 and 1e-3 (6 links)"].linkage()
    )[0]
    assert (
        np.linalg.cond(
            ne.mass_matrix(by_name["span: chain alternating 1e3 and 1e-3 (6 links)"].linkage(), psi)
        ).min()
        > 1e15
    )
    assert all(
        link.inertia == 0.0
        for link in by_name["J = 0: chain of 5 point masses at mid-link"].linkage().links
    )
    fast = by_name["six-link at up to 100 rad/s"]
    assert np.abs(fast.states(fast.linkage())[1]).max() > 95.0
    star = by_name["star: 10 children on one link"].linkage()
    assert max(len(c) for c in star.children) == 10
    assert by_name["chain of 80 links"].linkage().n == 80
    aligned = by_name["six-link nearly aligned (1e-9 rad)"]
    psi = aligned.states(aligned.linkage())[0]
    assert np.ptp(psi, axis=1).max() < 1e-8


# ---- planner: free-time problems with a known optimum -----------------------------------------
ROD_INERTIA = 0.1 + 2.0 * 0.5**2  # J + m c^2, kg m^2


def _free_time_problem(case) -> tuple[OCP, float]:
    """The case's OCP and its optimal duration T* (see PlannerCase)."""
    if case.problem == "double integrator":
        x, u = ca.SX.sym("x", 2), ca.SX.sym("u")
        dynamics = ca.Function("f", [x, u], [ca.vertcat(x[1], u)], ["x", "u"], ["xdot"])
        inertia = 1.0
        kw = {"state_names": ("q", "v"), "control_names": ("a",)}
        names = ("q", "v")
    else:
        rod = Linkage([Link("rod", None, 1.0, 2.0, com=0.5, inertia=0.1)], gravity=0.0)
        dynamics, inertia = Dynamics(rod), ROD_INERTIA
        kw = {"formulation": case.formulation}
        names = ("psi", "dpsi")
    T = case.duration
    distance = T**2 / (6.0 * inertia)  # T* = sqrt(6 I d)
    ocp = (
        OCP(dynamics, T=(T / 10.0, 10.0 * T), N=case.N, **kw)
        .initial(**{names[0]: 0.0, names[1]: 0.0})
        .final(**{names[0]: distance, names[1]: 0.0})
        .minimize(integral=lambda p: 1.0 + ca.sumsqr(p.u))
        .guess(T=2.0 * T)
    )
    return ocp, T


@pytest.mark.parametrize("case", [_param(c, c.name) for c in PLANNER_CASES])
def test_planner_case(case):
    """min integral (1 + u^2) over a rest-to-rest move: T* = sqrt(6 I d), cost 4 T*/3
    (J(T) = T + 12 I^2 d^2 / T^3); Hermite-Simpson is exact on it."""
    ocp, optimum = _free_time_problem(case)
    solution = ocp.solve(progress=False, options={"tol": case.tol})
    assert solution.success, solution.status
    assert abs(solution.T - optimum) <= case.expect.value * optimum, (solution.T, optimum)
    cost = 4.0 * optimum / 3.0
    assert abs(solution.cost - cost) <= case.expect.value * cost, (solution.cost, cost)
    assert np.all(np.isfinite(solution.states)) and np.all(np.isfinite(solution.controls))


def test_free_time_jacobian_uses_forward_mode():
    """A free duration is in every defect row: one adjoint sweep per row would make the
    Jacobian's build and evaluation grow as N^2 (33 s at N = 1000, measured); forward mode
    needs a handful of sweeps. Fixed-time gaits keep reverse mode (fewer sweeps there)."""
    case = next(c for c in PLANNER_CASES if c.N == 1000 and c.problem == "double integrator")
    nlp = Transcription(_free_time_problem(case)[0]).parametric_nlp
    pattern = ca.jacobian_sparsity(nlp["g"], nlp["x"])
    # independent count: rows sharing a column cannot share an adjoint sweep
    assert pattern.T.uni_coloring().size2() >= pattern.size1() - 5
    assert jacobian_mode(nlp["g"], nlp["x"]) == 0.0
    gait = walking_step(N=8).ocp
    nlp = Transcription(gait).parametric_nlp
    assert jacobian_mode(nlp["g"], nlp["x"]) == 1.0


# ---- walking step and gait at the extremes ------------------------------------------------------
def _gait_problem(kind: str, options: dict):
    options = dict(options)
    if kind == "feet":
        return footed_step_at(**options)
    overrides = options.pop("linkage_overrides", None)
    if overrides is not None:
        options["linkage"] = presets.six_link_anthropoid(**overrides)
    return walking_step(**options) if kind == "walk" else periodic_gait(**options)


@functools.cache
def _tight_cost(kind: str) -> float:
    gait = _gait_problem(kind, {}).solve(progress=False, options={"tol": 1e-10})
    return gait.cost


@pytest.mark.parametrize("case", [_param(c, c.name) for c in GAIT_CASES])
def test_gait_case(case):
    problem = _gait_problem(case.kind, case.options)
    if isinstance(case.expect, Raises):
        with pytest.raises(case.expect.error, match=case.expect.match):
            problem.solve(progress=False, options=case.ipopt)
        return
    gait = problem.solve(progress=False, options=case.ipopt)
    assert gait.success
    if isinstance(case.expect, Tol):
        reference = _tight_cost(case.kind)
        assert abs(gait.cost - reference) <= case.expect.value * reference
    else:
        report = gait.verify()
        assert report.ok, report.failures


# ---- walkers scaled in size and gravity ---------------------------------------------------------
_STEPS = {"walk": (presets.six_link_anthropoid, walking_step),
          "feet": (presets.anthropoid_with_feet, footed_step)}  # fmt: skip


@functools.cache
def _unscaled_cost(kind: str) -> float:
    return _STEPS[kind][1]().solve(progress=False).cost


@pytest.mark.parametrize("case", [_param(c, c.name) for c in SCALED_CASES])
def test_a_scaled_walker_solves_to_the_unscaled_dimensionless_optimum(case):
    """Dynamic similarity: lengths x size, g x gravity, times x sqrt(size / gravity), torques
    x size x gravity (masses kept). Before the defaults scaled (a 0.03 s approach window, a
    touchdown speed growing as L, rates scaled by 3 rad/s), the 1 mm walker was infeasible and
    the walker under 9.81e-3 m/s^2 cost 8.08x its similar optimum."""
    preset, make = _STEPS[case.kind]
    body = preset()
    links = body.in_units(length=case.size).links if case.size != 1.0 else body.links
    walker = Linkage(links, gravity=9.81 * case.gravity)
    time = np.sqrt(case.size / case.gravity)
    step = make(walker, 0.5 * case.size, 0.5 * time,
                torque_limit=150.0 * case.size * case.gravity)  # fmt: skip
    # its defaults in its own units
    assert step.clearance == pytest.approx(0.05 * case.size, rel=1e-11)
    assert step.touchdown_speed == pytest.approx(0.3 * case.size / time, rel=1e-11)
    assert step.approach_time == pytest.approx(0.03 * time, rel=1e-11)
    gait = step.solve(progress=False)
    assert gait.success and gait.verified, gait.verification
    dimensionless = gait.cost / ((case.size * case.gravity) ** 2 * time)
    reference = _unscaled_cost(case.kind)
    assert abs(dimensionless - reference) <= case.expect.value * reference, dimensionless


# ---- units: millimetres and grams against SI -------------------------------------------------
def _in_units(kind: str, options: dict, length: float, torque: float):
    six = presets.six_link_anthropoid()
    linkage = six if length == 1.0 else six.in_units(length=1e3, mass=1e3)
    if kind == "walk":
        return walking_step(
            linkage,
            0.5 * length,
            0.5,
            torque_limit=150.0 * torque,
            clearance=0.05 * length,
            **options,
        )
    return periodic_gait(linkage, torque_limit=300.0 * torque, margin=0.02 * length, **options)


@pytest.mark.parametrize("case", [_param(c, c.name) for c in UNITS_CASES])
def test_millimetres_and_grams_give_the_si_answer(case):
    """The scaled NLP is the same in both unit systems (every nominal scale comes from the
    problem's data): the same gait, converted back, and as many iterations. Measured with the
    constants in metres this replaced (examples/benchmarks/units_compare.py): SI against mm/g
    29 and 42 iterations for the walking step, 64 and 298 with a double support (another
    optimum, 7e-2 rad apart), 34 and 25 for the fixed-base gait (1.6e-6 rad apart)."""
    ipopt = {"tol": case.tol}
    si = _in_units(case.kind, case.options, 1.0, 1.0).solve(progress=False, options=ipopt)
    mm = _in_units(case.kind, case.options, 1e3, 1e9).solve(progress=False, options=ipopt)
    a, b = si.to_trajectory(), mm.to_trajectory()
    tol = case.expect.value
    np.testing.assert_allclose(b.time, a.time, rtol=1e-12)
    assert np.max(np.abs(b.psi - a.psi)) <= tol  # rad
    assert np.max(np.abs(b.dpsi - a.dpsi)) <= tol * np.max(np.abs(a.dpsi))
    assert np.max(np.abs(b.torques / 1e9 - a.torques)) <= tol * np.max(np.abs(a.torques))
    assert abs(mm.cost / 1e18 - si.cost) <= tol * si.cost
    iterations = (si.solution.iterations, mm.solution.iterations)
    assert abs(iterations[1] - iterations[0]) <= case.iterations * iterations[0], iterations
    # the objective's scale follows the units exactly: torques^2 are 1e18 larger
    ratio = mm.solution.stats["objective_scale"] / si.solution.stats["objective_scale"]
    assert ratio == pytest.approx(1e18, rel=1e-9)


def test_work_objective_means_the_same_in_millimetres_and_grams():
    """The positive-work objective's smoothing and torque weight follow the torque limit, so
    its integrand in mm/g is exactly 1e9 times the SI one (W -> g mm^2/s^3) at the same
    motion; with the constants in W it was not (1 W is 1e-9 of the mm/g power scale)."""
    six = presets.six_link_anthropoid()
    mm = six.in_units(length=1e3, mass=1e3)
    rng = np.random.default_rng(4)
    dpsi = rng.normal(0.0, 0.02, (64, 6))  # powers near 0, where the smoothing matters
    torques = rng.normal(0.0, 30.0, (64, 6))
    values = []
    for linkage, torque in ((six, 1.0), (mm, 1e9)):
        ocp = OCP(Dynamics(linkage), T=1.0, N=2).bound("M", -150 * torque, 150 * torque)
        point = ocp._point()
        integrand = objective_integrand(linkage, "work", 150.0 * torque)(point)
        f = ca.Function("f", [point.x, point.u], [integrand])
        x = np.hstack([np.zeros((64, 6)), dpsi])
        values.append(np.asarray(f(x.T, (torques * torque).T)).ravel())
    np.testing.assert_allclose(values[1], 1e9 * values[0], rtol=1e-12)
    assert np.all(values[0] > 0)


# ---- bad input -------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "case", [pytest.param(c, id=c.name) for c in INPUT_CASES if not c.covered_by]
)
def test_bad_input(case, tmp_path, capsys):
    if isinstance(case.expect, Raises):
        with pytest.raises(case.expect.error, match=case.expect.match) as raised:
            case.call(tmp_path)
        # raised by the library, not from inside CasADi
        assert "casadi" not in raised.traceback[-1].path.name
        return
    argv, folder = case.call(tmp_path)
    assert not folder.exists()
    status = main([*argv, str(folder)])
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert status == case.expect.status, captured.err
    assert "Traceback" not in captured.err
    assert re.search(case.expect.match, lines[-1]), lines[-1]
    assert not folder.exists(), sorted(folder.rglob("*"))


@pytest.mark.parametrize("case", [pytest.param(c, id=c.name) for c in INPUT_CASES if c.covered_by])
def test_bad_input_covered_elsewhere(case):
    """Cases the matrix records but other modules test: the named file holds the message."""
    filename, text = case.covered_by.split(": ", 1)
    assert text in (TESTS / filename).read_text(), case.covered_by


def test_the_guide_shows_the_matrix():
    guide = (TESTS / "extremes.md").read_text()
    assert table() in guide, "tests/extremes.md's table differs from tests/extremes.py"
