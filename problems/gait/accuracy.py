"""Accuracy presets of the gait problems: a transcription, a mesh density and an IPOPT
tolerance, chosen from the measurement of ``examples/benchmarks/speed_accuracy.py``.

``walking_step(accuracy="draft" | "balanced" | "precise")``, the same for ``periodic_gait``,
and ``python -m problems walk --accuracy NAME``. The mesh is given as intervals per second of
motion, so that a longer step or period gets proportionally more intervals (N = ceil(density
x duration), at least ``MIN_INTERVALS``). ``torque_error`` is the bound the preset states on
the largest torque error against the converged optimum of the same local minimum (any hinge,
any instant of a 1 kHz grid, N m), set from the measurement with a margin; ``tests/
test_accuracy.py`` checks it on problems the presets were not chosen on (another step length,
the five-link biped).

A number instead of a name (``gait_problem.solve(accuracy=1e-5)``) refines the mesh to that
per-interval re-integration error instead (:func:`planner.refine_to`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from planner.errors import DefinitionError, DefinitionTypeError
from planner.refinement import check_accuracy, refine_to
from planner.schemes import DEFAULT_TRANSCRIPTION

#: No preset mesh has fewer intervals.
MIN_INTERVALS = 8


@dataclass(frozen=True)
class AccuracyPreset:
    """A named accuracy: ``transcription`` (and ``degree``), ``intervals_per_second`` of
    motion, IPOPT ``tol``; ``torque_error`` the stated bound on the torque error, N m;
    ``summary`` one line for help texts."""

    name: str
    transcription: str
    degree: int | None
    intervals_per_second: float
    tol: float
    torque_error: float
    summary: str

    def intervals(self, duration: float) -> int:
        """N for a motion of ``duration`` s."""
        return max(MIN_INTERVALS, math.ceil(self.intervals_per_second * duration - 1e-9))

    @property
    def options(self) -> dict[str, float]:
        """The IPOPT options of the preset."""
        return {"tol": self.tol}

    def mesh(self, duration: float) -> dict:
        """``N``, ``transcription``, ``degree`` for a motion of ``duration`` s."""
        return {
            "N": self.intervals(duration),
            "transcription": self.transcription,
            "degree": self.degree,
        }


ACCURACY_PRESETS: dict[str, AccuracyPreset] = {
    preset.name: preset
    for preset in (
        # Measured (speed_accuracy.py) on the walking step with its decisive touchdown (the
        # approach line of the last 30 ms is where the torque errors gather): six-link step
        # 3.2 N m in 0.5 s, fixed-base gait 0.8 N m; not chosen on: 0.4 m step 3.1, five-link
        # step 3.5 N m. (Before the touchdown: 1.4, 0.8, 0.9, 1.4 against a bound of 3.)
        AccuracyPreset(
            "draft",
            DEFAULT_TRANSCRIPTION,
            None,
            40.0,
            1e-4,
            5.0,
            "a quick study: Hermite-Simpson, 40 intervals/s, tol 1e-4; torques within 5 N m",
        ),
        # six-link step 0.83 N m, gait 0.045; 0.4 m step 0.09, five-link step 1.58.
        AccuracyPreset(
            "balanced",
            DEFAULT_TRANSCRIPTION,
            None,
            160.0,
            1e-8,
            2.0,
            "Hermite-Simpson, 160 intervals/s, tol 1e-8; torques within 2 N m",
        ),
        # Hermite-Simpson at 640 intervals/s (the walking step's touchdown corner needs the
        # density; Radau(3) at 320/s, the earlier choice, left 0.38 N m on the six-link step
        # and 2.1 at the five-link step's start, where a Radau control is an extrapolation):
        # six-link step 0.10 N m, gait 0.003; 0.4 m step 0.027, five-link step 0.28
        # (speed_accuracy.py --skip grid, against Radau(5) at 1280/s).
        AccuracyPreset(
            "precise",
            DEFAULT_TRANSCRIPTION,
            None,
            640.0,
            1e-8,
            0.5,
            "hardware-ready torques: Hermite-Simpson, 640 intervals/s, tol 1e-8; within 0.5 N m",
        ),
    )
}


def preset(name: object) -> AccuracyPreset:
    """The preset called ``name``; raises naming the known ones."""
    if not isinstance(name, str):
        raise DefinitionTypeError(
            f"`accuracy`: a preset name {tuple(ACCURACY_PRESETS)} or a number, got {name!r}"
        )
    if name not in ACCURACY_PRESETS:
        raise DefinitionError(
            f"`accuracy`: unknown preset {name!r}; use one of {tuple(ACCURACY_PRESETS)}, or a "
            "number (a refinement target, e.g. 1e-5)"
        )
    return ACCURACY_PRESETS[name]


def resolve_mesh(accuracy, duration: float, N, transcription, degree, default_N: int) -> dict:
    """The mesh (``N``, ``transcription``, ``degree``) of a gait problem: the preset's for
    ``accuracy`` (a name; N, transcription and degree must then be None), else the given ones
    (None: Hermite-Simpson on ``default_N`` intervals). The preset's tolerance goes to IPOPT
    in the problem's ``solve`` (:func:`solve_plan`)."""
    if accuracy is None:
        return {
            "N": default_N if N is None else N,
            "transcription": transcription or DEFAULT_TRANSCRIPTION,
            "degree": degree,
        }
    if not isinstance(accuracy, str):
        raise DefinitionTypeError(
            f"`accuracy`: the problem takes a preset name {tuple(ACCURACY_PRESETS)}, got "
            f"{accuracy!r}; a refinement target (a number) goes to solve(accuracy=...)"
        )
    chosen = preset(accuracy)
    given = [name for name, value in (("N", N), ("transcription", transcription),
                                      ("degree", degree)) if value is not None]  # fmt: skip
    if given:
        raise DefinitionError(
            f"`accuracy`: the preset {chosen.name!r} sets N, transcription and degree; give "
            f"either accuracy or {', '.join(given)}, not both"
        )
    return chosen.mesh(duration)


def solve_plan(accuracy, built_with: str | None, options: dict):
    """What a gait problem's ``solve(accuracy=..., **options)`` does: (the preset to re-mesh
    with, for a name, else None; the refinement target, for a number, else None; ``options``
    with the tolerance of that preset, or of the one the problem was built with
    (``built_with``), beneath the caller's own IPOPT options)."""
    remesh = target = None
    if isinstance(accuracy, str):
        remesh = preset(accuracy)
    elif accuracy is not None:
        target = check_accuracy(accuracy)
    tolerance = remesh or (None if built_with is None else preset(built_with))
    if tolerance is not None:
        options = {**options, "options": {**tolerance.options, **(options.get("options") or {})}}
    return remesh, target, options


def refine_gait(ocp, target: float, options: dict):
    """(the Solution of :func:`planner.refine_to` on ``ocp``, ``ocp`` on its final mesh: where
    the gait's law cost is evaluated)."""
    solution = refine_to(ocp, target, **options)
    return solution, ocp.refine(mesh=solution.interval_lengths / solution.T)


__all__ = [
    "ACCURACY_PRESETS",
    "MIN_INTERVALS",
    "AccuracyPreset",
    "preset",
    "refine_gait",
    "resolve_mesh",
    "solve_plan",
]
