"""What a worker does for one point of a study: define the walking step, solve it from its
starts (solved neighbours, then the gait law), measure the outputs, and hand back plain data.

Everything a task carries and returns is plain Python and numpy (picklable by the standard
library, small): the study's :class:`PointSpec` (once per worker), the point's values and its
starts; back come the table row, the warm-start record and the gait's node trajectory as NPZ
bytes. The worker writes nothing: the process that runs the study is the only writer of the
study folder (so a worker may live on another machine without a shared file system).

Warm starts cross processes exactly: a solved point's record holds its NLP iterate in
physical units (the scaled vector times the nominal scales) and its multipliers in physical
units (multiplier times objective scale over row or variable scale, the invariant of the
Lagrangian), with the objective scale and the NLP layout (:attr:`Solution.nlp_signature`). A
neighbour with the same layout becomes a :class:`planner.Solution` of this point's
transcription again, bit for bit the same guess whatever process solved it; with another
layout (an axis that changes the mesh) its trajectory is the guess, re-gridded.
"""

from __future__ import annotations

import inspect
import math
import os
import socket
import tempfile
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from model import LinkageTrajectory
from planner import (
    OCP,
    Phases,
    PhasesSolution,
    Solution,
    Trajectory,
    Transcription,
)
from planner.accuracy_check import ACCURACY_WARNING, AccuracyWarning, check_accuracy_of
from planner.errors import AnthropoidError, DefinitionError, DefinitionTypeError
from problems.gait.problem import total_iterations
from problems.gait.verification import GaitVerificationWarning
from problems.walking.footed import FootedStep
from problems.walking.step import WalkingGait, WalkingStep, walking_step

#: The status recorded for a point whose problem could not be defined (walking_step or the
#: user's function raised a definition error for these values).
DEFINITION_FAILED = "Definition_Failed"
#: The status of a point whose worker process died every time it was tried.
WORKER_LOST = "Worker_Lost"


# ---- outputs ----------------------------------------------------------------------------------
#: Below this fraction of the body weight the stance foot counts as unloaded: friction use
#: |Fx| / (mu Fy) means nothing there (both forces vanish within the solver's tolerance, as
#: at the instant a long, fast step takes off: Fy ~ -1e-5 N, Fx ~ -1e-8 N).
UNLOADED = 1e-3


@dataclass
class Measured:
    """A solved point as the outputs read it: the gait, its node trajectory (with the ground
    reaction) and its summary (computed once: it integrates the positive work)."""

    gait: WalkingGait
    trajectory: Trajectory

    @cached_property
    def summary(self) -> dict[str, Any]:
        return self.gait.summary()


def _peak_friction_use(point: Measured) -> float:
    """max over the loaded nodes of |Fx| / (mu Fy) of the stance foot (1: on the cone's
    edge); NaN when no node carries UNLOADED x the weight."""
    force = np.asarray(point.trajectory.ground_reaction)
    fx, fy = force.real, force.imag
    biped = point.gait.problem.biped
    loaded = fy >= UNLOADED * biped.total_mass * biped.linkage.gravity
    if not np.any(loaded):
        return math.nan
    return float(np.max(np.abs(fx[loaded]) / (point.gait.problem.mu * fy[loaded])))


def _accuracy(point: Measured) -> dict[str, Any]:
    measured = point.gait.solution.stats.get("accuracy") or check_accuracy_of(
        point.gait.solution, None
    )
    threshold = measured.get("threshold") or ACCURACY_WARNING
    return {"": measured["error"], "warning": bool(measured["error"] > threshold)}


def _verification(point: Measured) -> dict[str, Any]:
    # the one the solve ran on the samples at 1 kHz, or a new one
    report = point.gait.verification or point.gait.verify()
    return {
        "verified": bool(report.ok),
        "verification_failures": ";".join(c.name for c in report.failures),
    }


#: Outputs a study can record per point: name -> (function of the :class:`Measured` point
#: giving a number, a bool, a string or a dict of column suffix -> value; unit; what it is).
OUTPUTS: dict[str, tuple[Callable[[Measured], Any], str, str]] = {
    "cost": (lambda m: m.gait.cost, "objective", "the objective at the optimum"),
    "law_cost": (
        lambda m: m.gait.problem.law_cost(),
        "objective",
        "the fitted gait law's objective on the same mesh (the benchmark)",
    ),
    "speed": (lambda m: m.gait.speed, "m/s", "step length / step time"),
    "cost_of_transport": (
        lambda m: m.summary["cost_of_transport"],
        "1",
        "positive work / (weight x step length)",
    ),
    "positive_work": (
        lambda m: m.summary["positive_work"],
        "J",
        "positive work of the drives per step",
    ),
    "peak_torque": (
        lambda m: m.summary["peak_torque"],
        "N m",
        "largest |M_i| per hinge (columns peak_torque_<link>)",
    ),
    "rms_torque": (
        lambda m: m.summary["rms_torque"],
        "N m",
        "root mean square of M_i over the step per hinge (columns rms_torque_<link>)",
    ),
    "peak_friction_use": (
        _peak_friction_use,
        "1",
        "largest |Fx| / (mu Fy) of the stance foot over the nodes where it carries at least "
        "0.1 % of the weight (1: the cone's edge)",
    ),
    "impulse": (
        lambda m: dict(zip(("x", "y"), m.summary["impulse"], strict=True)),
        "N s",
        "the heel strike's impulse on the landing foot (columns impulse_x, impulse_y)",
    ),
    "accuracy": (
        lambda m: _accuracy(m),
        "of nominal scale",
        "largest per-interval re-integration error per nominal state scale (the units of "
        "accuracy=); accuracy_warning: it exceeds planner.ACCURACY_WARNING, the point's plan "
        "obeys its dynamics poorly between the mesh points (refine its mesh)",
    ),
    "verified": (
        _verification,
        "",
        "problems.verify_gait passed (verification_failures: the failed checks)",
    ),
}
DEFAULT_OUTPUTS = (
    "cost",
    "speed",
    "cost_of_transport",
    "positive_work",
    "peak_torque",
    "rms_torque",
    "peak_friction_use",
    "accuracy",
    "verified",
)


# ---- the study's part of a task ---------------------------------------------------------------
@dataclass(frozen=True)
class PointSpec:
    """What every point of a study shares; sent once to each worker.

    problem : None (``walking_step``) or a callable of keyword arguments (the fixed ones and
        the point's values) returning a :class:`WalkingStep` or the ``walking_step``
        arguments (a dict).
    fixed : keyword arguments of every call.
    outputs : names of :data:`OUTPUTS` and (name, callable of the WalkingGait) pairs.
    ipopt : IPOPT options over the planner's defaults.
    multipliers : also warm-start IPOPT's multipliers from a neighbour of the same layout
        (False: the primal point only; measured in examples/walking_study.md).
    accept_acceptable : count "Solved_To_Acceptable_Level" as solved.
    """

    problem: Callable[..., Any] | None = None
    fixed: Mapping[str, Any] = field(default_factory=dict)
    outputs: tuple = DEFAULT_OUTPUTS
    ipopt: Mapping[str, Any] = field(default_factory=dict)
    multipliers: bool = False
    accept_acceptable: bool = False

    def step(self, values: Mapping[str, Any]) -> WalkingStep:
        """The walking step at ``values`` (the swept values of one point)."""
        arguments = {**self.fixed, **values}
        if self.problem is None:
            return walking_step(**arguments)
        made = self.problem(**arguments)
        if isinstance(made, WalkingStep | FootedStep):
            return made
        if isinstance(made, Mapping):
            return walking_step(**made)
        raise DefinitionTypeError(
            f"`problem`: must return a WalkingStep, a FootedStep (problems.footed_step) or a "
            f"dict of walking_step arguments, got {type(made).__name__} for {dict(values)}"
        )


def walking_step_parameters() -> tuple[str, ...]:
    """The keyword parameters of :func:`problems.walking_step` (axes of a default study)."""
    return tuple(inspect.signature(walking_step).parameters)


def output_name(output) -> str:
    return output if isinstance(output, str) else output[0]


# ---- warm-start records -----------------------------------------------------------------------
def warm_record(solution: Solution | PhasesSolution) -> dict[str, Any]:
    """The solution's NLP point in physical units, for exact warm starts elsewhere: w (n_w,),
    lam_x (n_w,), lam_g (n_g,) (multipliers times the objective scale over the variable or
    row scales), objective_scale, signature, cost."""
    transcription = solution.transcription
    scale = float(solution.stats.get("objective_scale", 1.0))
    record = {
        "w": solution.w * transcription.w_scale,
        "objective_scale": scale,
        "signature": solution.nlp_signature,
        "cost": solution.cost,
    }
    if solution.lam_x is not None and solution.lam_g is not None:
        record["lam_x"] = solution.lam_x * scale / transcription.w_scale
        record["lam_g"] = solution.lam_g * scale / transcription.g_scale
    return record


def guess_from(step: WalkingStep, start: Mapping[str, Any]) -> OCP | Phases | None:
    """``step.problem`` (the OCP, or the phases with a double support) guessed from a
    neighbour's record: from the neighbour's NLP point rebuilt as a solution of this step's
    transcription when the layouts agree (exactly its values, its objective scale and, when
    present, its multipliers), else from its trajectory (one phase; None for phases: the law
    stays the guess)."""
    problem = step.problem
    transcription = Transcription(problem)
    if str(start["signature"]) == transcription.signature:
        scale = float(start["objective_scale"])
        lam_x = lam_g = None
        if "lam_x" in start and "lam_g" in start:
            lam_x = np.asarray(start["lam_x"]) * transcription.w_scale / scale
            lam_g = np.asarray(start["lam_g"]) * transcription.g_scale / scale
        solution = transcription.solution(
            np.asarray(start["w"]) / transcription.w_scale,
            float(start["cost"]),
            "Solve_Succeeded",
            True,
            {"objective_scale": scale},
            lam_g,
            lam_x,
        )
        return problem.guess(solution)
    if isinstance(problem, Phases):
        return None
    return problem.guess(trajectory_from_bytes(start["trajectory"]))


def trajectory_bytes(trajectory: Trajectory) -> bytes:
    """``trajectory`` as the bytes of its NPZ file (full precision)."""
    with tempfile.TemporaryDirectory(prefix="study-") as folder:
        path = Path(folder) / "solution.npz"
        trajectory.save(path)
        return path.read_bytes()


def trajectory_from_bytes(data: bytes) -> Trajectory:
    with tempfile.TemporaryDirectory(prefix="study-") as folder:
        path = Path(folder) / "solution.npz"
        path.write_bytes(data)
        return LinkageTrajectory.load(path)


# ---- one point ----------------------------------------------------------------------------------
def _first_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}".strip()


def _outputs(spec: PointSpec, gait: WalkingGait, trajectory: Trajectory) -> dict[str, Any]:
    row: dict[str, Any] = {}
    measured = Measured(gait, trajectory)
    for output in spec.outputs:
        if isinstance(output, str):
            name, function = output, OUTPUTS[output][0]
            value = function(measured)
        else:
            name, function = output
            value = function(gait)
        if isinstance(value, Mapping):
            if name == "verified":
                row.update(value)
            else:  # columns name_<key> ("" names the column itself)
                row.update({f"{name}_{key}" if key else name: v for key, v in value.items()})
        else:
            row[name] = value.item() if isinstance(value, np.generic) else value
    return row


def solve_point(spec: PointSpec, task: Mapping[str, Any]) -> dict[str, Any]:
    """Solve one point of a study.

    ``task``: {"id": str, "values": {axis: value}, "starts": [None (the law) or
    {"id", "w", "objective_scale", "signature", "cost", "trajectory", ["lam_x", "lam_g"]}]}.
    Starts are tried in order until one converges. Returns {"id", "row" (the table row),
    "record" (warm-start arrays, solved points only), "trajectory" (NPZ bytes, solved
    points only)}. A failed point is a row with IPOPT's status (or ``DEFINITION_FAILED``
    when the problem cannot be defined for these values), never an exception; only a bug
    (an exception that is not the library's) propagates.
    """
    begin = time.perf_counter()
    cpu = time.process_time()
    row: dict[str, Any] = {"point": task["id"], **task["values"]}
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    notes: list[str] = []
    try:
        step = spec.step(task["values"])
    except AnthropoidError as exc:  # refused values (a step too long for the legs, ...)
        row.update(status=DEFINITION_FAILED, success=False, start="", attempts=0)
        row["notes"] = _first_line(exc)
        row["seconds"] = time.perf_counter() - begin
        row["cpu_seconds"] = time.process_time() - cpu
        return {"id": task["id"], "row": row, "record": None, "trajectory": None}
    gait = None
    attempts = 0
    iterations = 0
    for start in task["starts"]:
        label = "law" if start is None else start["id"]
        try:
            problem = step.problem if start is None else guess_from(step, start)
            if problem is None:
                notes.append(f"from {label}: another NLP layout, no guess")
                continue
            attempts += 1
            with warnings.catch_warnings():
                # the row records them (accuracy, accuracy_warning, verified, notes), and the
                # command line sums them up: printed from a worker they would cut through
                # the progress
                warnings.simplefilter("ignore", AccuracyWarning)
                warnings.simplefilter("ignore", GaitVerificationWarning)
                gait = step.solve(
                    problem,
                    progress=False,
                    raise_on_failure=False,
                    warm_start=spec.multipliers,
                    options=dict(spec.ipopt) or None,
                    accept_acceptable=spec.accept_acceptable,
                )
        except AnthropoidError as exc:  # a guess the OCP refuses (NaN in a neighbour, ...)
            notes.append(f"from {label}: {_first_line(exc)}")
            gait = None
            continue
        iterations += total_iterations(gait.solution)
        if gait.success:
            row["start"] = label
            break
        notes.append(f"from {label}: {gait.solution.status} ({gait.solution.iterations} it)")
    row["attempts"] = attempts
    row["iterations"] = iterations
    if gait is None or not gait.success:
        row.update(status=gait.solution.status if gait else DEFINITION_FAILED, success=False)
        row.setdefault("start", "")
        if gait is not None:
            row["build_seconds"] = gait.solution.stats.get("build_seconds")
            row["solve_seconds"] = gait.solution.stats.get("solve_seconds")
        row["notes"] = "; ".join(notes)
        row["seconds"] = time.perf_counter() - begin
        row["cpu_seconds"] = time.process_time() - cpu
        return {"id": task["id"], "row": row, "record": None, "trajectory": None}
    stats = gait.solution.stats
    row.update(status=gait.solution.status, success=True)
    row["build_seconds"] = stats.get("build_seconds")
    row["solve_seconds"] = stats.get("solve_seconds")
    trajectory = gait.to_trajectory()
    row.update(_outputs(spec, gait, trajectory))
    if row.get("accuracy_warning"):
        notes.append(
            f"accuracy warning: re-integration error {row['accuracy']:.2g} of a state's scale; "
            "refine the mesh (N)"
        )
    record = warm_record(gait.solution)
    data = trajectory_bytes(trajectory)
    row["notes"] = "; ".join(notes)
    row["seconds"] = time.perf_counter() - begin
    row["cpu_seconds"] = time.process_time() - cpu
    return {"id": task["id"], "row": row, "record": record, "trajectory": data}


# ---- the spec installed in a pool worker --------------------------------------------------------
_INSTALLED: list[PointSpec] = []


def install(spec: PointSpec) -> None:
    """Process-pool initializer: keep ``spec`` for :func:`solve_installed` (with the fork
    start method the spec is inherited, not pickled, so a lambda problem works too)."""
    _INSTALLED[:] = [spec]


def solve_installed(task: Mapping[str, Any]) -> dict[str, Any]:
    """:func:`solve_point` with the spec :func:`install` put in this worker."""
    return solve_point(_INSTALLED[0], task)


def check_outputs(outputs: Sequence) -> tuple:
    """``outputs`` validated: names of :data:`OUTPUTS` or (name, callable) pairs."""
    if isinstance(outputs, str):
        raise DefinitionTypeError(
            f"`outputs`: give a sequence of output names, got the string {outputs!r}"
        )
    checked = []
    names = set()
    for item in outputs:
        if isinstance(item, str):
            if item not in OUTPUTS:
                raise DefinitionError(
                    f"`outputs`: unknown output {item!r}; known: {sorted(OUTPUTS)}, or a "
                    "(name, function of the WalkingGait) pair"
                )
            name = item
        elif (
            isinstance(item, tuple)
            and len(item) == 2
            and isinstance(item[0], str)
            and item[0].isidentifier()
            and callable(item[1])
        ):
            name = item[0]
        else:
            raise DefinitionTypeError(
                f"`outputs`: {item!r} is neither an output name nor a (name, function) pair"
            )
        if name in names:
            raise DefinitionError(f"`outputs`: {name!r} is given twice")
        names.add(name)
        checked.append(item)
    return tuple(checked)


__all__ = [
    "DEFAULT_OUTPUTS",
    "DEFINITION_FAILED",
    "OUTPUTS",
    "WORKER_LOST",
    "PointSpec",
    "check_outputs",
    "guess_from",
    "install",
    "output_name",
    "solve_installed",
    "solve_point",
    "trajectory_bytes",
    "trajectory_from_bytes",
    "walking_step_parameters",
    "warm_record",
]
