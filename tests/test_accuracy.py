"""problems.ACCURACY_PRESETS: what a preset sets, that its stated torque error holds on
problems it was not chosen on, and its validation.

The presets were chosen on the six-link walking step (0.5 m in 0.5 s) and the six-link
fixed-base gait (``examples/benchmarks/speed_accuracy.py``). Here they solve problems they
were not chosen on, a 0.4 m step of the six-link walker and a step of the five-link biped
(``model.presets.five_link_biped``), and the torques are compared with a fine reference of
the same local optimum: Radau degree 5, warm-started from the preset's own solution, at tol
1e-10, on a mesh whose own torque error (measured by the benchmark on the six-link step
against Radau(5) at 1280 intervals/s: 0.11 N m at 160 intervals/s, 0.02 N m at 320/s; at
least 5 times below the bound it checks) does not blur the check.
"""

from __future__ import annotations

import importlib
import math

import numpy as np
import pytest

from model import presets
from planner.errors import DefinitionError, DefinitionTypeError
from problems import ACCURACY_PRESETS, periodic_gait, walking_step
from problems.gait.accuracy import MIN_INTERVALS

# The module both gait problems solve through (a spy replaces its solve).
gait_module = importlib.import_module("problems.gait.problem")

#: The reference's density per preset (intervals per second of Radau(5)), so that its own
#: error is at most a tenth of the preset's bound.
REFERENCE_DENSITY = {"draft": 160, "balanced": 320, "precise": 640}


def torque_error(solution, reference) -> float:
    """Largest |M - M_ref| over every hinge on a 1 kHz grid, N m."""
    times = reference.sample_times(1000.0)
    return float(np.max(np.abs(solution.control(times) - reference.control(times))))


UNTUNED = {
    "six-link, 0.4 m step": lambda **mesh: walking_step(step_length=0.4, **mesh),
    "five-link, 0.5 m step": lambda **mesh: walking_step(presets.five_link_biped(), **mesh),
}


def _holds(problem: str, name: str) -> None:
    chosen = ACCURACY_PRESETS[name]
    step = UNTUNED[problem](accuracy=name)
    # The transcription's own accuracy (the limits held between the points back off some
    # bounds, another optimum by the margins)
    solution = step.solve(progress=False, hold_limits=False, verify=False).solution
    assert solution.N == chosen.intervals(0.5)
    assert solution.transcription_name == chosen.transcription
    N = REFERENCE_DENSITY[name] // 2  # the step lasts 0.5 s
    reference = (
        UNTUNED[problem]()
        .ocp.refine(N=N, transcription="radau", degree=5)
        .guess(solution)
        .solve(options={"tol": 1e-10}, progress=False)
    )
    assert abs(solution.cost - reference.cost) < 0.05 * reference.cost  # the same optimum
    error = torque_error(solution, reference)
    assert error <= chosen.torque_error, (problem, name, error)


@pytest.mark.parametrize("problem", list(UNTUNED))
@pytest.mark.parametrize("name", ["draft", "balanced"])
def test_a_preset_holds_its_torque_error_where_it_was_not_chosen(problem, name):
    _holds(problem, name)


@pytest.mark.slow
@pytest.mark.parametrize("problem", list(UNTUNED))
def test_the_precise_preset_holds_its_torque_error_where_it_was_not_chosen(problem):
    _holds(problem, "precise")


# ---- what a preset sets ---------------------------------------------------------------------
@pytest.mark.parametrize("name", list(ACCURACY_PRESETS))
def test_a_preset_sets_the_mesh_from_its_density_and_the_duration(name):
    chosen = ACCURACY_PRESETS[name]
    for step_time in (0.5, 0.73):
        ocp = walking_step(step_time=step_time, accuracy=name).ocp
        assert ocp.N == max(MIN_INTERVALS, math.ceil(chosen.intervals_per_second * step_time))
        assert (ocp.transcription, ocp.degree) == (chosen.transcription, chosen.degree)
    gait = periodic_gait(accuracy=name).ocp  # the law's period: 1 s
    assert gait.N == max(MIN_INTERVALS, math.ceil(chosen.intervals_per_second))


def test_a_preset_passes_its_tolerance_to_ipopt_unless_overridden(monkeypatch):
    seen = []

    def spy(transcription, **options):
        seen.append(options.get("options"))
        raise RuntimeError("stop")  # the options are what this test reads

    monkeypatch.setattr(gait_module, "solve", spy)  # what both problems solve with
    draft = ACCURACY_PRESETS["draft"]
    for problem in (walking_step(accuracy="draft"), periodic_gait(accuracy="draft")):
        with pytest.raises(RuntimeError, match="stop"):
            problem.solve(progress=False)
        with pytest.raises(RuntimeError, match="stop"):
            problem.solve(progress=False, options={"tol": 1e-6, "max_iter": 50})
    assert seen == [draft.options, {"tol": 1e-6, "max_iter": 50}] * 2
    # without a preset nothing is added (the planner's default tol applies)
    seen.clear()
    with pytest.raises(RuntimeError, match="stop"):
        walking_step(N=12).solve(progress=False)
    assert seen == [None]


def test_solve_with_a_preset_remeshes_the_problem(monkeypatch):
    seen = []

    def spy(transcription, **options):
        seen.append((transcription.ocp.N, transcription.ocp.transcription, options["options"]))
        raise RuntimeError("stop")

    monkeypatch.setattr(gait_module, "solve", spy)  # what both problems solve with
    precise = ACCURACY_PRESETS["precise"]
    with pytest.raises(RuntimeError, match="stop"):
        walking_step(N=12).solve(accuracy="precise")
    with pytest.raises(RuntimeError, match="stop"):
        periodic_gait(N=12).solve(accuracy="precise")
    assert seen == [
        (precise.intervals(0.5), precise.transcription, precise.options),
        (precise.intervals(1.0), precise.transcription, precise.options),
    ]


def test_preset_validation():
    with pytest.raises(DefinitionError, match=r"`accuracy`: unknown preset 'fast'; use one of"):
        walking_step(accuracy="fast")
    with pytest.raises(DefinitionError, match=r"the preset 'draft' sets N, transcription"):
        walking_step(accuracy="draft", N=20)
    with pytest.raises(DefinitionError, match=r"give either accuracy or transcription, degree"):
        periodic_gait(accuracy="precise", transcription="radau", degree=3)
    with pytest.raises(DefinitionTypeError, match=r"goes to solve\(accuracy=\.\.\.\)"):
        walking_step(accuracy=1e-4)
    with pytest.raises(DefinitionError, match=r"`accuracy`: unknown preset 'best'"):
        walking_step(N=12).solve(accuracy="best")
    with pytest.raises(DefinitionError, match=r"with a double support give the preset"):
        walking_step(N=12, double_support=0.1).solve(accuracy=1e-4)
