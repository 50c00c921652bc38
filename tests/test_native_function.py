"""Single functions compiled into the disk cache (planner.native_function), as the hybrid
simulation's period Jacobians use them (problems.control.simulation.Plant.compile): the
compiled code against CasADi's own evaluation of the same function to round-off, found
again by another plant of the same linkage and by no other, never used under
ANTHROPOID_COMPILE=never, a damaged library removed and the function run interpreted, and the
refusals."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from model.presets import n_link_chain
from planner import native_cache, native_function, native_nlp
from planner.errors import DefinitionError
from problems.control.simulation import Plant

needs_compiler = pytest.mark.skipif(native_nlp.compiler() is None, reason="no C compiler")


@pytest.fixture
def function_cache(nlp_cache):
    """The test's own cache folder, the automatic mode on, nothing loaded remembered."""
    native_function.forget()
    yield nlp_cache
    native_function.forget()


def _libraries(root) -> list:
    return sorted(root.rglob("fn-*.so"))


def _evaluations(function: ca.Function, count: int = 5) -> list[np.ndarray]:
    rng = np.random.default_rng(7)
    n = function.size1_in(1)
    values = []
    for _ in range(count):
        x, torques = rng.normal(size=2 * n), rng.normal(size=n) * 5.0
        values += [np.asarray(v) for v in function(x, torques, 1e-3)]
    return values


@needs_compiler
def test_a_compiled_period_jacobian_is_casadis_own_to_round_off(function_cache):
    plant = Plant(n_link_chain(2), mu=None)
    interpreted = plant.advance_jacobian
    assert interpreted.class_name() == "SXFunction"  # nothing cached yet: nothing compiled
    assert _libraries(function_cache) == []
    plant.compile()
    compiled = plant.advance_jacobian
    assert compiled.class_name() == "External"
    assert compiled.name() == interpreted.name() == "advance_jacobian"
    assert [compiled.name_in(i) for i in range(3)] == ["x", "M", "h"]
    for ours, theirs in zip(_evaluations(compiled), _evaluations(interpreted), strict=True):
        np.testing.assert_allclose(ours, theirs, rtol=1e-13, atol=1e-13 * np.abs(theirs).max())
    assert len(_libraries(function_cache)) == 1
    # another plant of the same linkage finds it in the cache (after this process forgot it),
    # one of another linkage does not
    native_function.forget()
    assert Plant(n_link_chain(2), mu=None).advance_jacobian.class_name() == "External"
    assert Plant(n_link_chain(3), mu=None).advance_jacobian.class_name() == "SXFunction"
    assert Plant(n_link_chain(2), mu=None, substeps=3).advance_jacobian.class_name() == (
        "SXFunction"
    )


@needs_compiler
def test_never_runs_interpreted_and_a_damaged_library_is_removed(function_cache, monkeypatch,
                                                                  caplog):  # fmt: skip
    Plant(n_link_chain(2), mu=None).compile()
    (library,) = _libraries(function_cache)
    native_function.forget()
    monkeypatch.setenv("ANTHROPOID_COMPILE", "never")
    assert Plant(n_link_chain(2), mu=None).advance_jacobian.class_name() == "SXFunction"
    monkeypatch.setenv("ANTHROPOID_COMPILE", "auto")
    library.write_bytes(library.read_bytes()[:1000])  # cut short: unlike its record
    native_cache.forget()
    with caplog.at_level("WARNING", logger="planner.native_nlp"):
        jacobian = Plant(n_link_chain(2), mu=None).advance_jacobian
    assert jacobian.class_name() == "SXFunction"
    assert not library.exists()
    assert "truncated or overwritten" in caplog.text


def test_compiling_without_a_compiler_is_refused_naming_the_fix(function_cache, monkeypatch,
                                                                 tmp_path):  # fmt: skip
    empty = tmp_path / "empty-path"
    empty.mkdir()
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.setenv("PATH", str(empty))
    plant = Plant(n_link_chain(2), mu=None)
    with pytest.raises(DefinitionError, match=r"no C compiler found to compile 'advance_jacobian'"):
        plant.compile()
    # the automatic mode needs none: interpreted
    assert plant.advance_jacobian.class_name() == "SXFunction"


def test_bad_arguments_are_named():
    x = ca.SX.sym("x")
    square = ca.Function("square", [x], [x**2])
    assert native_function.native(square, "never") is square
    with pytest.raises(DefinitionError, match=r"`how`: one of \('never', 'auto', 'now'\)"):
        native_function.native(square, "always")
    with pytest.raises(DefinitionError, match="`tag`: a non-empty string"):
        native_function.native_derived(square, "", "square_jacobian", lambda f: f)


@pytest.mark.slow
@needs_compiler
def test_the_walkers_multipliers_with_the_compiled_jacobian_are_the_interpreted_ones(
    function_cache,
):
    # the six-link walker's closed loop at 1 m/s: its fixed point and Floquet multipliers
    # through the compiled period Jacobian (about 40 s of compilation) against interpreted
    from problems.control.feedback import design_feedback
    from problems.control.linearisation import fixed_point
    from problems.walking.footed import step_at_speed
    from problems.walking.step import walking_step

    step = walking_step(None, *step_at_speed(1.0))
    gait = step.solve(progress=False, compiled=False)
    loops, gains = [], []
    for compiled in (False, True):
        feedback = design_feedback(gait, compiled=compiled)
        kind = feedback.plant.advance_jacobian.class_name()
        assert kind == ("External" if compiled else "SXFunction")
        loops.append(fixed_point(feedback.plant, feedback.controller,
                                 feedback.reference.states[0], step_time=step.step_time,
                                 step_length=step.step_length, tolerance=1e-9))  # fmt: skip
        gains.append(feedback.gains.gains)
    interpreted, compiled = loops
    np.testing.assert_allclose(gains[1], gains[0], rtol=1e-9, atol=1e-9 * np.abs(gains[0]).max())
    np.testing.assert_allclose(compiled.start, interpreted.start, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.abs(compiled.multipliers), np.abs(interpreted.multipliers),
                               rtol=0, atol=1e-9)  # fmt: skip


@needs_compiler
def test_a_killed_compilations_work_folder_is_cleared_by_the_next(function_cache):
    # kill -9 in the middle of a compilation leaves its temporary folder: the next one of
    # the same key, under the key's lock, removes it and publishes a complete library
    x = ca.SX.sym("x", 2)
    cube = ca.Function("cube", [x], [x**3])
    name = native_function.key(cube)
    folder = native_cache.folder()
    folder.mkdir(parents=True, exist_ok=True)
    left = folder / f".{name}.work.killed"
    left.mkdir()
    (left / "function.c").write_text("/* cut short */", encoding="utf-8")
    compiled = native_function.native(cube, "now")
    assert compiled.class_name() == "External" and not left.exists()
    np.testing.assert_array_equal(np.asarray(compiled([2.0, -1.0])).ravel(), [8.0, -1.0])
    assert [p.name for p in folder.iterdir() if p.name.startswith(".")] == []


def test_bad_plant_and_derivation_settings_are_named():
    with pytest.raises(DefinitionError, match=r"`compiled`: True, False or None, got 'yes'"):
        Plant(n_link_chain(2), mu=None, compiled="yes")
    x = ca.SX.sym("x")
    square = ca.Function("square", [x], [x**2])
    named = "the derived function is named 'square', not 'other'"
    with pytest.raises(DefinitionError, match=named):
        native_function.native_derived(square, "v1", "other", lambda f: f, "now")
