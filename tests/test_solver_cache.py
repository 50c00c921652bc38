"""The solver cache: which solves reuse an IPOPT solver, and that a reused solver gives exactly
what a freshly built one gives (the oracle: the same solve with ``cache=False``)."""

from __future__ import annotations

import threading

import casadi as ca
import numpy as np
import pytest

from model import DefinitionError, DefinitionTypeError, Dynamics, presets
from planner import OCP, Transcription
from planner.solver_cache import SOLVERS, CachedSolver, SolverCache

CHAIN = Dynamics(presets.n_link_chain(2))
DOWN = -np.pi / 2
RAISED = [DOWN + 1.0, DOWN + 1.5]


def swing(limit=10.0, T=1.5, weight=1.0, N=8, elbow=0.6):
    """Two-link chain from hanging at rest to a raised pose at rest, min sum M^2."""
    return (
        OCP(CHAIN, T=T, N=N)
        .initial(psi=[DOWN, DOWN], dpsi=0.0)
        .final(psi=RAISED, dpsi=0.0)
        .bound("M", -limit, limit)
        .constrain("elbow", lambda p: p.psi[1] - p.psi[0], lower=-elbow, upper=elbow)
        .minimize(integral=lambda p: ca.sumsqr(p.M) + (weight - 1.0) * p.M[1] ** 2)
        .guess(t=[0.0, T], psi=[[DOWN, DOWN], RAISED])
    )


@pytest.fixture(autouse=True)
def empty_cache():
    SOLVERS.clear()
    yield
    SOLVERS.clear()


def assert_identical(a, b):
    assert a.status == b.status and a.iterations == b.iterations
    assert a.cost == b.cost
    np.testing.assert_array_equal(a.w, b.w)
    np.testing.assert_array_equal(a.lam_g, b.lam_g)


def test_a_re_solve_reuses_the_solver_and_gives_what_a_new_one_gives():
    first = swing().solve(progress=False)
    second = swing().solve(progress=False)  # another OCP value, the same structure
    fresh = swing().solve(progress=False, cache=False)
    assert not first.stats["solver_cached"] and second.stats["solver_cached"]
    assert not fresh.stats["solver_cached"]
    assert_identical(second, first)
    assert_identical(fresh, first)
    assert SOLVERS.info() == {"solvers": 1, "size": SOLVERS.size, "hits": 1, "misses": 1}


@pytest.mark.parametrize(
    "change",
    [
        {"limit": 9.0},  # variable bounds, and the default scale of M with them
        {"elbow": 0.55},  # constraint bounds, and the row scale
        {"T": 1.6},  # a fixed duration
    ],
    ids=["variable-bound", "constraint-bound", "duration"],
)
def test_bounds_scales_and_duration_are_arguments_of_the_cached_solver(change):
    base = swing().solve(progress=False)
    changed = swing(**change).solve(progress=False)
    assert changed.stats["solver_cached"]
    assert Transcription(swing(**change)).structure_key == base.transcription.structure_key
    assert_identical(changed, swing(**change).solve(progress=False, cache=False))
    assert changed.cost != pytest.approx(base.cost, rel=1e-6)  # a different problem indeed


def test_a_warm_started_continuation_and_a_guess_reuse_the_solver():
    base = swing().solve(progress=False)
    cold_guess = swing().guess(M=1.0).solve(progress=False)
    assert cold_guess.stats["solver_cached"]  # another guess only
    warm = swing(limit=9.5).guess(base).solve(progress=False)
    again = swing(limit=9.4).guess(warm).solve(progress=False)
    assert warm.stats["warm_start"] and not warm.stats["solver_cached"]  # warm-start options
    assert again.stats["warm_start"] and again.stats["solver_cached"]
    assert_identical(again, swing(limit=9.4).guess(warm).solve(progress=False, cache=False))


def test_a_constant_in_an_expression_or_other_options_build_another_solver():
    swing().solve(progress=False)
    weighted = swing(weight=1.5).solve(progress=False)  # a number inside the objective
    assert not weighted.stats["solver_cached"]
    assert Transcription(swing(weight=1.5)).structure_key != Transcription(swing()).structure_key
    other = swing().solve(progress=False, options={"tol": 1e-9})
    assert not other.stats["solver_cached"]
    expanded = swing().solve(progress=False, expand=True)
    assert not expanded.stats["solver_cached"]
    assert expanded.cost == pytest.approx(swing().solve(progress=False).cost, rel=1e-9)
    assert swing().solve(progress=False, expand=True).stats["solver_cached"]
    refined = swing(N=9).solve(progress=False)
    assert not refined.stats["solver_cached"]
    assert len(SOLVERS) == 5


def test_equal_expressions_written_separately_share_the_structure():
    def objective(p):
        return ca.sumsqr(p.M)

    a = swing().minimize(integral=objective)
    b = swing().minimize(integral=lambda p: ca.sumsqr(p.M))
    assert Transcription(a).structure_key == Transcription(b).structure_key


def test_the_cache_is_bounded_least_recently_used_and_can_be_turned_off():
    SOLVERS.resize(1)
    try:
        swing().solve(progress=False)
        swing(N=9).solve(progress=False)  # evicts N=8
        assert len(SOLVERS) == 1
        assert not swing().solve(progress=False).stats["solver_cached"]
        assert swing().solve(progress=False).stats["solver_cached"]
        SOLVERS.resize(0)
        assert len(SOLVERS) == 0
        assert not swing().solve(progress=False).stats["solver_cached"]
        assert len(SOLVERS) == 0
    finally:
        SOLVERS.resize(16)
    with pytest.raises(
        DefinitionError, match=r"`size`: must be >= 0 \(0 keeps no solver\), got -1"
    ):
        SolverCache(-1)
    with pytest.raises(DefinitionTypeError, match=r"`size`: must be an integer >= 0, got 2.5"):
        SOLVERS.resize(2.5)
    with pytest.raises(DefinitionTypeError, match=r"`cache`: must be True or False, got 'no'"):
        swing().solve(progress=False, cache="no")


def test_the_cache_builds_once_per_key_and_keeps_the_most_recent():
    cache = SolverCache(2)
    built = []

    def build(name):
        def make():
            built.append(name)
            return CachedSolver(name)

        return make

    assert cache.get("a", build("a")) == (cache.get("a", build("x"))[0], False)
    cache.get("b", build("b"))
    cache.get("a", build("x"))  # a is now the most recent
    cache.get("c", build("c"))  # evicts b
    assert "a" in cache and "c" in cache and "b" not in cache
    assert built == ["a", "b", "c"]
    assert cache.info() == {"solvers": 2, "size": 2, "hits": 2, "misses": 3}


def test_each_solve_of_a_cached_solver_reports_to_its_own_reporter():
    first, second = [], []
    swing().solve(progress=first.append)
    solution = swing(limit=9.0).solve(progress=second.append)
    assert solution.stats["solver_cached"]
    assert [r["iteration"] for r in second] == list(range(solution.iterations + 1))
    assert second[-1]["objective"] == pytest.approx(solution.cost, rel=1e-12)
    count = len(first)
    swing().solve(progress=False)
    assert len(first) == count and len(second) == solution.iterations + 1

    def fail(row):
        raise KeyError("from the reporter")

    with pytest.raises(KeyError, match="from the reporter"):
        swing().solve(progress=fail)
    after = swing().solve(progress=False)  # the error of one solve does not stay behind
    assert after.success and after.stats["solver_cached"]


def test_threads_solving_one_structure_get_the_same_results():
    reference = swing().solve(progress=False, cache=False)
    results, errors = [], []

    def run():
        try:
            results.append(swing().solve(progress=False))
        except Exception as exc:  # collected and re-raised below
            errors.append(exc)

    threads = [threading.Thread(target=run) for _ in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors, errors
    assert len(results) == 3
    for result in results:
        assert_identical(result, reference)
