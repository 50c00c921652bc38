"""Walking studies: a walking step solved over a grid of swept values, with continuation.

A :class:`Study` is a definition, a value: the axes (name -> values; the grid is their
product), the base problem (``walking_step`` with the axes as its arguments, or a function of
the swept values returning a :class:`~problems.walking.step.WalkingStep` or the ``walking_step``
arguments), fixed arguments, and the outputs to record per point
(:data:`problems.study.point.OUTPUTS`). :meth:`Study.run` solves it into a folder:

>>> study = Study({"step_length": [0.4, 0.5, 0.6], "step_time": [0.45, 0.5, 0.55]},
...               fixed={"N": 30})
>>> result = study.run("study_out")                       # process pool, one worker per core
>>> result.grid("cost_of_transport")                      # (3, 3), NaN where a point failed

* **Continuation**: each point starts from an already solved neighbour (its NLP point, bit for
  bit, whatever process solved it), then from another neighbour, then from the gait law; a
  point that fails all of them is recorded as failed with IPOPT's status, and the study goes
  on (``problems.study.schedule`` for the orderings, ``problems.study.point`` for one point).
* **Execution**: a local process pool sized to the cores by default (``workers``), or a Dask
  cluster (``scheduler``: an address, ``"local"`` for a LocalCluster, or a Client; the
  optional extra ``pip install ".[cluster]"``) (``problems.study.backends``).
* **Nothing lost**: every point is written as it arrives, atomically (``problems.study.store``);
  running the same study into the same folder again solves only what is missing, and a folder
  that holds another study is refused.

The definition written to ``study.json`` (and compared on a resume) holds the axes, the fixed
arguments, the outputs, the solver options and a description of the problem at the grid's
first and last points (the step's settings, the linkage's parameters and the OCP's summary):
a changed function that changes the problem there is a changed study.
"""

from __future__ import annotations

import inspect
import math
import numbers
import os
from collections.abc import Callable, Mapping, Sequence
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from model.linkage import Linkage
from planner.errors import DefinitionError, DefinitionTypeError
from problems.study import runner as study_runner
from problems.study.point import (
    DEFAULT_OUTPUTS,
    OUTPUTS,
    PointSpec,
    check_outputs,
    output_name,
    walking_step_parameters,
)
from problems.study.result import GridPoint, StudyProgress, StudyResult, grid_points
from problems.study.schedule import check_ordering

FORMAT_VERSION = 1


def _axis_values(name: str, values: object) -> tuple:
    if isinstance(values, str | bytes) or not isinstance(values, Sequence | np.ndarray):
        raise DefinitionTypeError(
            f"`axes[{name!r}]`: give a sequence of values (e.g. numpy.linspace(0.3, 0.7, 9)), "
            f"got {values!r}"
        )
    out = []
    for k, value in enumerate(values):
        if isinstance(value, np.generic):
            value = value.item()
        if isinstance(value, bool | str):
            out.append(value)
        elif isinstance(value, numbers.Real):
            number = float(value) if not isinstance(value, int) else value
            if not math.isfinite(number):
                raise DefinitionError(f"`axes[{name!r}][{k}]`: must be finite, got {value!r}")
            out.append(number)
        else:
            raise DefinitionTypeError(
                f"`axes[{name!r}][{k}]`: a value must be a number, a string or a bool, got "
                f"{type(value).__name__}"
            )
    if not out:
        raise DefinitionError(f"`axes[{name!r}]`: needs at least one value")
    if len(set(out)) != len(out):
        repeated = next(v for v in out if out.count(v) > 1)
        raise DefinitionError(f"`axes[{name!r}]`: the value {repeated!r} is given twice")
    return tuple(out)


def jsonable(name: str, value: Any) -> Any:
    """``value`` as plain JSON data for the study's definition (``name`` for the message)."""
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, numbers.Real):
        return value if isinstance(value, int) else float(value)
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, Linkage):
        return {"linkage": value.parameters()}
    if isinstance(value, Mapping):
        return {str(k): jsonable(f"{name}[{k!r}]", v) for k, v in value.items()}
    if isinstance(value, Sequence):
        return [jsonable(f"{name}[{k}]", v) for k, v in enumerate(value)]
    if callable(value):
        return {"callable": f"{getattr(value, '__module__', '?')}.{_qualname(value)}"}
    raise DefinitionTypeError(
        f"`{name}`: a {type(value).__name__} cannot be written into the study's definition; "
        "give numbers, strings, lists, dicts, a Linkage or a function"
    )


def _qualname(function: Callable) -> str:
    inner = getattr(function, "func", None)  # functools.partial
    if inner is not None:
        return f"partial({_qualname(inner)})"
    return getattr(function, "__qualname__", type(function).__name__)


class Study:
    """A walking study: a walking step over a grid of values (see the module docstring).

    Parameters
    ----------
    axes : name -> values (numbers, strings or bools; e.g. ``numpy.linspace``); the grid is
        their product, the last axis varying fastest. Without ``problem`` the names are
        ``walking_step`` parameters (step_length m, step_time s, mu, torque_limit N m, ...).
    problem : None for ``walking_step``, or a function called with the fixed arguments and a
        point's values as keywords, returning a :class:`~problems.walking.step.WalkingStep` (its
        ``ocp`` may be changed with ``dataclasses.replace``) or a dict of ``walking_step``
        arguments. It runs in the worker processes: with the process pool on Linux any
        function works; a Dask cluster pickles it (cloudpickle: also a lambda), and remote
        workers need the modules it imports.
    fixed : keyword arguments of every point (e.g. ``{"N": 30}``).
    outputs : what to record per point: names of :data:`problems.study.point.OUTPUTS`
        (default :data:`~problems.study.point.DEFAULT_OUTPUTS`) and (name, function of the
        :class:`~problems.walking.step.WalkingGait` returning a number, bool, string or dict of
        them) pairs.
    ipopt : IPOPT options over the planner's defaults (e.g. ``{"max_iter": 500}``).
    multipliers : also warm-start IPOPT's multipliers from the neighbour (default False: the
        primal point only, which took fewer iterations on the six-link grid; README).
    accept_acceptable : count "Solved_To_Acceptable_Level" as solved.
    """

    def __init__(
        self,
        axes: Mapping[str, Sequence[Any]],
        problem: Callable[..., Any] | None = None,
        *,
        fixed: Mapping[str, Any] | None = None,
        outputs: Sequence[Any] = DEFAULT_OUTPUTS,
        ipopt: Mapping[str, Any] | None = None,
        multipliers: bool = False,
        accept_acceptable: bool = False,
    ) -> None:
        if not isinstance(axes, Mapping) or not axes:
            raise DefinitionTypeError(
                f"`axes`: give a dict name -> values with at least one axis, got {axes!r}"
            )
        self.axes: dict[str, tuple] = {}
        for name, values in axes.items():
            if not isinstance(name, str) or not name.isidentifier():
                raise DefinitionError(f"`axes`: an axis name must be an identifier, got {name!r}")
            self.axes[name] = _axis_values(name, values)
        if problem is not None and not callable(problem):
            raise DefinitionTypeError(
                f"`problem`: must be a function or None (walking_step), got {problem!r}"
            )
        fixed = {} if fixed is None else fixed
        if not isinstance(fixed, Mapping):
            raise DefinitionTypeError(
                f"`fixed`: must be a dict of keyword arguments, got {fixed!r}"
            )
        both = sorted(set(fixed) & set(self.axes))
        if both:
            raise DefinitionError(
                f"`fixed`: {both} are axes too; an argument is either swept or fixed"
            )
        if problem is None:
            known = walking_step_parameters()
            unknown = [k for k in [*self.axes, *fixed] if k not in known]
            if unknown:
                raise DefinitionError(
                    f"`axes`/`fixed`: {unknown} are not parameters of walking_step; its "
                    f"parameters: {list(known)}; pass a problem function for anything else"
                )
        else:
            self._check_signature(problem, [*self.axes, *fixed])
        ipopt = {} if ipopt is None else ipopt
        if not isinstance(ipopt, Mapping):
            raise DefinitionTypeError(f"`ipopt`: must be a dict of IPOPT options, got {ipopt!r}")
        for flag, value in (("multipliers", multipliers), ("accept_acceptable", accept_acceptable)):
            if not isinstance(value, bool):
                raise DefinitionTypeError(f"`{flag}`: must be True or False, got {value!r}")
        self.spec = PointSpec(
            problem=problem,
            fixed=dict(fixed),
            outputs=check_outputs(outputs),
            ipopt=dict(ipopt),
            multipliers=multipliers,
            accept_acceptable=accept_acceptable,
        )
        # Validate the JSON form of everything now, not at the first run.
        jsonable("fixed", self.spec.fixed)
        jsonable("ipopt", self.spec.ipopt)

    @staticmethod
    def _check_signature(problem: Callable, names: list[str]) -> None:
        try:
            signature = inspect.signature(problem)
        except (TypeError, ValueError):  # a builtin or C function: it will say so itself
            return
        try:
            signature.bind(**dict.fromkeys(names))
        except TypeError as exc:
            raise DefinitionError(
                f"`problem`: cannot be called with the axes and fixed arguments {names} as "
                f"keywords ({exc})"
            ) from None

    # ---- the grid --------------------------------------------------------------------
    @cached_property
    def points(self) -> list[GridPoint]:
        """Every point of the grid, in grid order (the last axis fastest)."""
        return grid_points(self.axes)

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for v in self.axes.values())

    def __len__(self) -> int:
        return len(self.points)

    def __repr__(self) -> str:
        axes = ", ".join(
            f"{name}: {len(values)} values {values[0]!r}..{values[-1]!r}"
            for name, values in self.axes.items()
        )
        problem = "walking_step" if self.spec.problem is None else _qualname(self.spec.problem)
        return f"Study({problem} over {axes}; {len(self)} points)"

    def step(self, point: GridPoint | int):
        """The walking step of one point (a :class:`GridPoint` or its position in
        :attr:`points`): the problem a worker solves there."""
        if isinstance(point, int) and not isinstance(point, bool):
            point = self.points[point]
        if not isinstance(point, GridPoint):
            raise DefinitionTypeError(f"`point`: give a GridPoint or an index, got {point!r}")
        return self.spec.step(point.values)

    # ---- the definition --------------------------------------------------------------
    def _describe(self, point: GridPoint) -> dict[str, Any]:
        try:
            step = self.spec.step(point.values)
        except DefinitionError as exc:  # values refused there: a point that will fail
            return {"point": point.id, "error": str(exc).splitlines()[0]}
        settings = {k: v for k, v in step.settings().items() if k != "law"}  # derived data
        return {
            "point": point.id,
            "settings": jsonable("settings", settings),
            "linkage": step.linkage.parameters(),
            "ocp": str(step.problem),
        }

    @cached_property
    def definition(self) -> dict[str, Any]:
        """The study's definition as JSON data (what study.json holds and a resume compares)."""
        spec = self.spec
        corners = [self.points[0], self.points[-1]] if len(self) > 1 else [self.points[0]]
        return {
            "version": FORMAT_VERSION,
            "axes": {name: list(values) for name, values in self.axes.items()},
            # JSON objects have no order; the grid (and its point ids) has.
            "axis_order": list(self.axes),
            "problem": "problems.walking.step.walking_step"
            if spec.problem is None
            else f"{getattr(spec.problem, '__module__', '?')}.{_qualname(spec.problem)}",
            "fixed": jsonable("fixed", spec.fixed),
            "outputs": [output_name(o) for o in spec.outputs],
            "output_units": {
                output_name(o): OUTPUTS[o][1] if isinstance(o, str) else "" for o in spec.outputs
            },
            "ipopt": jsonable("ipopt", spec.ipopt),
            "multipliers": spec.multipliers,
            "accept_acceptable": spec.accept_acceptable,
            "problems": [self._describe(p) for p in corners],
        }

    # ---- running ---------------------------------------------------------------------
    def run(
        self,
        folder: str | os.PathLike,
        *,
        workers: int | None = None,
        scheduler: Any = None,
        ordering: str = "auto",
        line_axis: int = -1,
        retry_failed: bool = False,
        progress: Callable[[StudyProgress], None] | None = None,
    ) -> StudyResult:
        """Solve the points ``folder`` does not hold yet, and return all of them.

        Parameters
        ----------
        folder : the study folder (created; a folder of the same study resumes it, one of
            another study is refused with :class:`problems.study.store.StudyFolderError`).
        workers : worker processes (default: one per core); 1 solves in this process. With
            ``scheduler="local"``, the LocalCluster's workers.
        scheduler : None (the local process pool), a Dask scheduler address
            (``"tcp://host:8786"``), ``"local"`` (a Dask LocalCluster for this run) or a
            ``distributed.Client``.
        ordering : "auto", "lines", "coarse" or "cold" (no warm starts)
            (``problems.study.schedule``).
        line_axis : the axis along which lines run (default the last).
        retry_failed : solve the points recorded as failed again (after lost workers, or
            a failure that came from the machine rather than the problem).
        progress : called with a :class:`StudyProgress` after each point and about twice a
            second; an exception it raises stops the run like Ctrl-C (the points in flight
            are still written).

        Returns
        -------
        StudyResult: every settled point of the folder, and ``run``: this run's counts,
        seconds and points per minute.
        """
        check_ordering(ordering)
        if not isinstance(retry_failed, bool):
            raise DefinitionTypeError(
                f"`retry_failed`: must be True or False, got {retry_failed!r}"
            )
        if progress is not None and not callable(progress):
            raise DefinitionTypeError(f"`progress`: must be a function or None, got {progress!r}")
        return study_runner.run(
            self.points,
            self.axes,
            self.definition,
            self.spec,
            Path(os.fspath(folder)),
            workers=workers,
            scheduler=scheduler,
            ordering=ordering,
            line_axis=line_axis,
            retry_failed=retry_failed,
            progress=progress,
        )


def run_study(
    folder: str | os.PathLike,
    axes: Mapping[str, Sequence[Any]],
    problem: Callable[..., Any] | None = None,
    **options: Any,
) -> StudyResult:
    """``Study(axes, problem, ...).run(folder, ...)`` in one call: ``options`` are those of
    :class:`Study` (fixed, outputs, ipopt, multipliers, accept_acceptable) and of
    :meth:`Study.run` (workers, scheduler, ordering, line_axis, retry_failed, progress)."""
    study_keys = ("fixed", "outputs", "ipopt", "multipliers", "accept_acceptable")
    study = Study(axes, problem, **{k: v for k, v in options.items() if k in study_keys})
    return study.run(folder, **{k: v for k, v in options.items() if k not in study_keys})


__all__ = ["DEFAULT_OUTPUTS", "OUTPUTS", "Study", "run_study"]
