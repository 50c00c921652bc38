"""Compiled NLP functions (planner.native_nlp): the compiled code against CasADi's own
evaluation of the same functions, the same optimum, the disk cache (kept across processes,
shared by processes compiling at once, never half-written), the automatic mode's rule, and
everything working with the compiler hidden."""

from __future__ import annotations

import platform
import sys
import threading
import time

import casadi as ca
import numpy as np
import pytest

from planner import OCP, native_cache, native_nlp, solve
from planner.errors import DefinitionError, DefinitionTypeError
from planner.solver import nlp_oracle, nlp_solver
from planner.solver_cache import SOLVERS, CachedSolver
from planner.transcription import Transcription

needs_compiler = pytest.mark.skipif(native_nlp.compiler() is None, reason="no C compiler")


@pytest.fixture
def no_compiler(monkeypatch, tmp_path):
    """The compiler hidden: $CC unset and a PATH with nothing on it."""
    empty = tmp_path / "empty-path"
    empty.mkdir()
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(empty))
    assert native_nlp.compiler() is None


def swing_up(N: int = 16, weight: float = 1.0) -> OCP:
    """A pendulum swung up to the top with a bounded torque, its length a parameter: a
    nonlinear NLP with a nonzero Hessian, bounds, a parameter and a free duration."""
    x, u, length = ca.SX.sym("x", 2), ca.SX.sym("u"), ca.SX.sym("length")
    rate = ca.vertcat(x[1], -9.81 / length * ca.sin(x[0]) + u / length**2)
    f = ca.Function("f", [x, u, length], [rate], ["x", "u", "length"], ["xdot"])
    return (
        OCP(
            f,
            T=(1.0, 4.0),
            N=N,
            state_names=("q", "w"),
            control_names=("M",),
            dynamics_params=("length",),
        )
        .param("length", 0.8, 1.2, guess=1.0)
        .bound("M", -6.0, 6.0)
        .initial(q=0.0, w=0.0)
        .final(q=np.pi, w=0.0)
        .minimize(integral=lambda p: weight * p.M**2, terminal=lambda p: p.T)
        .guess(lambda t: {"q": np.pi * t / 2.0}, T=2.0)
    )


def files(folder) -> list[str]:
    return sorted(p.name for p in folder.rglob("*") if p.is_file())


def published(library) -> list[str]:
    """The files a published library has in the cache: itself, its record and its lock."""
    record = native_cache.record_path(library)
    return [library.name, record.name, library.with_suffix(".lock").name]


@needs_compiler
def test_the_compiled_functions_are_casadis_own_to_round_off(nlp_cache):
    transcription = Transcription(swing_up())
    library = native_nlp.compile_library(
        nlp_oracle(transcription), transcription.structure_key, wait=True
    )
    compiled = nlp_solver(transcription, library=library, progress=False)
    interpreted = nlp_solver(transcription, progress=False)
    rng = np.random.default_rng(3)
    p = transcription.parameter_values()
    for _ in range(3):
        w = rng.normal(size=transcription.n_w)
        lam_f, lam_g = rng.normal(), rng.normal(size=transcription.n_g)
        for name, args in (
            ("nlp_f", (w, p)),
            ("nlp_g", (w, p)),
            ("nlp_grad_f", (w, p)),
            ("nlp_jac_g", (w, p)),
            ("nlp_hess_l", (w, p, lam_f, lam_g)),
        ):
            ours = compiled.get_function(name)(*args)
            theirs = interpreted.get_function(name)(*args)
            ours = ours if isinstance(ours, tuple | list) else [ours]
            theirs = theirs if isinstance(theirs, tuple | list) else [theirs]
            for a, b in zip(ours, theirs, strict=True):
                a, b = ca.DM(a), ca.DM(b)
                assert a.sparsity() == b.sparsity(), name
                scale = max(1.0, float(ca.norm_inf(b)))
                assert float(ca.norm_inf(a - b)) <= 1e-12 * scale, name


@needs_compiler
def test_compiled_solves_reach_the_same_optimum_and_the_cache_outlives_the_solver(nlp_cache):
    ocp = swing_up()
    interpreted = solve(ocp, compiled=False, progress=False)
    assert interpreted.stats["compiled"] is False
    first = solve(ocp, compiled=True, progress=False)
    assert first.stats["compiled"] is True
    assert first.cost == pytest.approx(interpreted.cost, rel=1e-9)
    assert first.iterations == interpreted.iterations
    np.testing.assert_allclose(first.states, interpreted.states, atol=1e-8)
    libraries = [name for name in files(nlp_cache) if name.endswith(".so")]
    assert len(libraries) == 1 and libraries[0].startswith(Transcription(ocp).structure_key)
    # A new process would have no solver in memory: the library on disk serves it, even
    # in the automatic mode, without a compilation
    SOLVERS.clear()
    again = solve(ocp, progress=False)
    assert again.stats["compiled"] is True and again.stats["solver_cached"] is False
    assert again.cost == pytest.approx(interpreted.cost, rel=1e-9)
    # compiled=False never uses it
    assert solve(ocp, compiled=False, progress=False).stats["compiled"] is False
    # another constant inside an expression is another structure: compiled anew
    other = solve(swing_up(weight=2.0), compiled=True, progress=False)
    assert other.stats["compiled"] is True
    assert len([name for name in files(nlp_cache) if name.endswith(".so")]) == 2


@needs_compiler
def test_progress_is_reported_from_a_compiled_solver(nlp_cache):
    seen = []
    solution = solve(swing_up(), compiled=True, progress=seen.append)
    assert solution.stats["compiled"] is True
    assert [row["iteration"] for row in seen] == list(range(solution.iterations + 1))


def test_everything_works_with_the_compiler_hidden(nlp_cache, no_compiler):
    ocp = swing_up()
    solutions = [solve(ocp, progress=False) for _ in range(3)]
    assert all(s.success and not s.stats["compiled"] for s in solutions)
    with pytest.raises(DefinitionError, match=r"`compiled`: no C compiler found \(set \$CC"):
        solve(ocp, compiled=True, progress=False)
    assert files(nlp_cache) == []


@needs_compiler
def test_a_library_compiled_before_serves_without_a_compiler(nlp_cache, monkeypatch, tmp_path):
    ocp = swing_up()
    reference = solve(ocp, compiled=True, progress=False)
    SOLVERS.clear()
    empty = tmp_path / "nothing"
    empty.mkdir()
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(empty))
    again = solve(ocp, progress=False)
    assert again.stats["compiled"] is True and again.cost == pytest.approx(reference.cost)


@needs_compiler
def test_the_automatic_mode_compiles_once_solving_has_cost_what_compiling_will(
    nlp_cache, monkeypatch
):
    ocp = swing_up()
    entry = CachedSolver(value=None, build_seconds=0.01, uses=1, solve_seconds=0.0)
    expected = max(native_nlp.MINIMUM_COMPILE_SECONDS, native_nlp.COMPILE_PER_BUILD * 0.01)
    assert not native_nlp.worth_compiling(entry)
    entry.solve_seconds = 0.99 * expected
    assert not native_nlp.worth_compiling(entry)
    entry.solve_seconds = expected
    assert native_nlp.worth_compiling(entry)
    entry.uses = 0  # never before the first solve
    assert not native_nlp.worth_compiling(entry)
    # In a process: interpreted solves until then, a compilation in the background, the
    # solves after it compiled
    monkeypatch.setattr(native_nlp, "COMPILE_PER_BUILD", 0.0)
    monkeypatch.setattr(native_nlp, "MINIMUM_COMPILE_SECONDS", 1e-9)
    first = solve(ocp, progress=False)
    second = solve(ocp, progress=False)
    assert not first.stats["compiled"] and not second.stats["compiled"]
    key = Transcription(ocp).structure_key
    deadline = time.monotonic() + 120
    while native_nlp.pending(key) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert native_nlp.ready(key) is not None
    third = solve(ocp, progress=False)
    assert third.stats["compiled"] is True
    assert third.cost == pytest.approx(first.cost, rel=1e-9)


@needs_compiler
def test_processes_compiling_one_structure_at_once_share_one_compilation(nlp_cache):
    transcription = Transcription(swing_up(N=12))
    oracle, key = nlp_oracle(transcription), transcription.structure_key
    found, errors = [], []

    def compile_it():
        try:
            found.append(native_nlp.compile_library(oracle, key, wait=True))
        except Exception as error:  # pragma: no cover - reported below
            errors.append(error)

    threads = [threading.Thread(target=compile_it) for _ in range(3)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors and len(set(found)) == 1
    # one library, its record, its lock, and nothing half-written or left over
    assert files(nlp_cache) == sorted(published(found[0]))
    assert nlp_solver(transcription, library=found[0], progress=False) is not None


def test_bad_settings_are_refused_naming_the_fix(nlp_cache, monkeypatch):
    with pytest.raises(DefinitionTypeError, match=r"`compiled`: must be True, False or None"):
        solve(swing_up(), compiled="yes", progress=False)
    monkeypatch.setenv(native_nlp.MODE_ENV, "sometimes")
    with pytest.raises(DefinitionError, match=r"`ANTHROPOID_COMPILE`: unknown value 'sometimes'"):
        solve(swing_up(), progress=False)


def test_the_cache_folder_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(native_nlp.CACHE_ENV, str(tmp_path / "mine"))
    folder = native_nlp.cache_folder()
    assert folder.parent == tmp_path / "mine"
    assert folder.name == f"nlp-casadi-{ca.__version__}-{sys.platform}-{platform.machine()}"
    monkeypatch.delenv(native_nlp.CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert native_nlp.cache_folder().parent == tmp_path / "xdg" / "anthropoid-planner"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert native_nlp.cache_folder().parent == tmp_path / "home" / ".cache" / "anthropoid-planner"


def test_a_library_that_does_not_load_is_removed_and_the_solve_runs_interpreted(nlp_cache, caplog):
    """A damaged library (or one built on another kind of machine) is not an error of the
    user's: the solve runs interpreted, says so and removes it, so that it is compiled again
    when it pays; options IPOPT refuses still fail as such. (Without its publication record
    it is not even loaded: tests/test_native_cache.py has the loader's refusal too.)"""
    ocp = swing_up()
    reference = solve(ocp, compiled=False, progress=False)
    key = Transcription(ocp).structure_key
    damaged = native_nlp.library_path(key)
    damaged.parent.mkdir(parents=True, exist_ok=True)
    damaged.write_bytes(b"not a shared library")
    SOLVERS.clear()
    with caplog.at_level("WARNING", logger="planner.native_nlp"):
        solution = solve(ocp, progress=False)
    assert solution.success and not solution.stats["compiled"]
    assert solution.cost == pytest.approx(reference.cost, rel=1e-12)
    assert not damaged.exists()
    assert "is not loaded: it has no publication record" in caplog.text
    assert "removed, running interpreted" in caplog.text
    damaged.write_bytes(b"not a shared library")
    with pytest.raises(DefinitionError, match=r"`options`: IPOPT refused the options"):
        solve(ocp, progress=False, options={"no_such_option": 1})


@needs_compiler
def test_a_compilation_killed_halfway_leaves_nothing_that_stays(nlp_cache):
    """A compilation killed with kill -9 leaves its work folder (never a library: that
    appears by a rename); the next compilation of the key, holding the lock, removes it."""
    transcription = Transcription(swing_up(N=8))
    key = transcription.structure_key
    folder = native_nlp.cache_folder()
    left = folder / f".{key}.work.killed"
    left.mkdir(parents=True)
    (left / "nlp.c").write_text("half a file")
    library = native_nlp.compile_library(nlp_oracle(transcription), key, wait=True)
    assert library.is_file() and not left.exists()
    assert files(nlp_cache) == sorted(published(library))


def test_a_progress_reporter_needs_a_solver_that_reports():
    with pytest.raises(DefinitionError, match=r"`report`: needs a solver with progress=True"):
        nlp_solver(Transcription(swing_up(N=4)), report=print, progress=False)
