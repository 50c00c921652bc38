"""Limits that hold where a file is read: at every sample of the exported motion.

A transcription enforces its path constraints and bounds at the dynamics points only; a drive
reads the exported profile sample by sample, between them. The exported profile is the
consistent motion (:meth:`planner.solution.Solution.motion`): positions integrated from the
velocity polynomial, accelerations its slope, drives by inverse dynamics; between the
collocation points its torques can leave their bounds (a 150 N m limit reached 153.5 N m at
1 kHz on a 0.8 m walking step) and its positions can dip below a clearance.

:func:`sample_misses` evaluates every inequality path constraint and every finite variable
bound of each phase on the consistent motion at the samples of an export rate, plus
``DENSE_POINTS`` points inside every mesh interval (so that the limits also hold at other
rates in practice, not only at the chosen samples), and lists the samples where one is
missed by more than ``tolerance`` of the row's nominal scale. :func:`hold_at_samples` is the
exchange method of semi-infinite programming: solve, find the misses, add the missed rows at
the worst instant of each interval as keypoint rows on the motion
(``OCP.constrain_at(..., on="motion")``, named "<constraint> (samples)" and
"bounds[<variable>] (samples)"), solve again warm-started, until nothing is missed. A plan
whose constraints are all inactive between the points needs no second solve.

Equality path constraints are not added between the points (a polynomial cannot satisfy
infinitely many equalities; the double support's foot hold drifts with the collocation error
there, which the verification bounds), nor constraints that read a control rate (the motion's
drives have no polynomial rate).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from model.errors import AnthropoidError, DefinitionError, check_positive
from planner.ocp import OCPDefinition, Point, evaluate_expression
from planner.phases import PhasesDefinition
from planner.phases_solution import PhasesSolution
from planner.solution import Solution

logger = logging.getLogger(__name__)

#: Largest miss of a row, as a fraction of its nominal scale (a torque bound of 150 N m with
#: the gait's nominal 50 N m: 5e-5 N m; a clearance row of scale 0.05 m: 5e-8 m).
TOLERANCE = 1e-6
#: Points inside every mesh interval checked besides the export samples.
DENSE_POINTS = 32
#: Solves after the first before :func:`hold_at_samples` gives up.
MAX_ROUNDS = 6
#: The suffix of the rows this module adds.
SUFFIX = " (samples)"


class SampleLimitError(AnthropoidError):
    """The limits still miss at the samples after :data:`MAX_ROUNDS` re-solves (or a
    re-solve failed); ``solution`` is the last one, ``misses`` what it misses."""

    def __init__(self, message: str, solution, misses) -> None:
        super().__init__(message)
        self.solution = solution
        self.misses = misses


@dataclass(frozen=True)
class SampleMiss:
    """A row missed at a sample: its ``phase`` (index), the constraint's ``name`` ("friction",
    "bounds[M_torso]"), the row's suffix, the time t (s, from the phase's start), its value,
    its bounds and ``margin``: the distance inside the nearer bound over the row's nominal
    scale (< -tolerance)."""

    phase: int
    name: str
    row: str
    t: float
    value: float
    lower: float
    upper: float
    margin: float

    def __str__(self) -> str:
        return (
            f"{self.name}{self.row} at t = {self.t:.6g} s: {self.value:.6g} outside "
            f"[{self.lower:.6g}, {self.upper:.6g}] ({self.margin:.2e} of its scale)"
        )


@dataclass(frozen=True, eq=False)
class _Rows:
    """An inequality block checked at samples: the constraint or bound it comes from, its
    SX Function of (x, u, z, t, T, params) and its bounds and scales (rows,)."""

    name: str
    rows: tuple[str, ...]
    function: ca.Function
    lower: np.ndarray
    upper: np.ndarray
    scale: np.ndarray
    source: Any  # the Constraint, or the variable name of a bound
    keep: tuple[int, ...] = (0,)  # the constraint's rows checked (its inequality rows)


def _checked_rows(ocp: OCPDefinition) -> list[_Rows]:
    """The inequality path constraints (rows with lower < upper) that read no control rate,
    and the finite bounds of states and controls, of one phase's OCP."""
    s = ocp.system
    x, u, z = ca.SX.sym("x", s.nx), ca.SX.sym("u", s.nu), ca.SX.sym("z", s.nz)
    t, T, du = ca.SX.sym("t"), ca.SX.sym("T"), ca.SX.sym("du", s.nu)
    P = ca.SX.sym("params", len(ocp.params))
    point = Point(s, x, u, z, t, T, ocp.param_fields(P), du=du)
    inputs, names = [x, u, z, t, T, P], ["x", "u", "z", "t", "T", "params"]
    blocks = []
    for c in ocp.constraints:
        if c.where != "path" or not np.any(c.lower < c.upper):
            continue
        value = evaluate_expression(f"path[{c.name}]", c.expression, point)
        if ca.depends_on(value, du):
            continue  # a rate: not on the motion
        keep = np.flatnonzero(c.lower < c.upper)
        rows = c.rows or tuple(f"[{i}]" for i in range(c.size))
        function = ca.Function(c.name, inputs, [value[keep.tolist()]], names, ["rows"])
        scale = ocp.constraint_scale(c)[keep]
        blocks.append(
            _Rows(c.name, tuple(rows[i] for i in keep), function, c.lower[keep],
                  c.upper[keep], scale, c, tuple(keep.tolist()))  # fmt: skip
        )
    for name, lower, upper in ocp.bounds:
        if name not in s.state_names + s.control_names:
            continue
        if not (np.isfinite(lower) or np.isfinite(upper)) or lower == upper:
            continue
        function = ca.Function(name, inputs, [point[name]], names, ["rows"])
        scale = np.array([ocp.variable_scale(name)])
        blocks.append(
            _Rows(f"bounds[{name}]", ("",), function, np.array([lower]), np.array([upper]),
                  scale, name)  # fmt: skip
        )
    return blocks


def check_times(solution: Solution, rate_hz: float | None, dense: int = DENSE_POINTS):
    """The times (s, from the phase's start) a phase is checked at: its export samples at
    ``rate_hz`` (the nodes for None) and ``dense`` equally spaced points inside every mesh
    interval."""
    nodes = solution.time
    inside = (np.arange(1, dense + 1) / (dense + 1))[None, :]
    grid = (nodes[:-1, None] + inside * np.diff(nodes)[:, None]).reshape(-1)
    return np.unique(np.concatenate([solution.sample_times(rate_hz), grid, nodes]))


def _motion_point(solution: Solution, times: np.ndarray):
    """(x, u, z) (K, n) of the consistent motion at ``times``."""
    s = solution.system
    x, xdot, u = solution.motion(times)
    if not s.nz:
        return x, u, np.zeros((times.size, 0))
    if s.group(s.accelerations) == s.aux_names:
        velocities = [s.state_names.index(name) for name in s.group(s.velocities)]
        return x, u, xdot[:, velocities]
    return x, u, solution.aux(times)


def _phase_misses(k: int, solution: Solution, times: np.ndarray, tolerance: float):
    blocks = _checked_rows(solution.ocp)
    if not blocks:
        return []
    x, u, z = _motion_point(solution, times)
    params = np.array([solution.params[p.name] for p in solution.ocp.params]).reshape(-1, 1)
    K = times.size
    misses = []
    for block in blocks:
        values = block.function.map(K)(
            x.T, u.T, z.T, times[None, :], solution.T, np.repeat(params, K, axis=1)
        )
        values = np.asarray(values).T  # (K, rows)
        with np.errstate(invalid="ignore"):  # inf - inf where a side is unbounded
            margin = np.minimum(values - block.lower, block.upper - values) / block.scale
        for i, j in zip(*np.nonzero(margin < -tolerance), strict=True):
            misses.append(
                SampleMiss(k, block.name, block.rows[j], float(times[i]), float(values[i, j]),
                           float(block.lower[j]), float(block.upper[j]), float(margin[i, j]))
            )  # fmt: skip
    return misses


def _phases(solution) -> list[Solution]:
    return list(solution.phases) if isinstance(solution, PhasesSolution) else [solution]


def sample_misses(
    solution: Solution | PhasesSolution,
    rate_hz: float | None,
    tolerance: float = TOLERANCE,
    dense: int = DENSE_POINTS,
) -> list[SampleMiss]:
    """Every row missed on the consistent motion at the check times (:func:`check_times`)
    of every phase, worst first."""
    if rate_hz is not None:
        check_positive("rate_hz", rate_hz, "Hz")
    tolerance = check_positive("tolerance", tolerance)
    misses = []
    for k, phase in enumerate(_phases(solution)):
        if not phase.system.has_motion:
            raise DefinitionError(
                "`solution`: its system has no consistent motion (positions, velocities, "
                "drives_for_motion) to check at samples"
            )
        misses += _phase_misses(k, phase, check_times(phase, rate_hz, dense), tolerance)
    return sorted(misses, key=lambda m: m.margin)


def _worst_instants(
    phase: Solution, misses: list[SampleMiss], dense: int
) -> dict[Any, list[float]]:
    """Per checked block (constraint or bound), as fractions of the phase's duration: the
    worst missed instant of each mesh interval with a miss and the ``dense`` points inside
    that interval (a row active over an arc bulges between single instants: rows at all of
    them settle it in one round)."""
    chosen: dict[str, dict[int, SampleMiss]] = {}
    for miss in misses:
        (interval,), _ = phase.mesh.locate(np.array([miss.t / phase.T]))
        per = chosen.setdefault(miss.name, {})
        if interval not in per or miss.margin < per[interval].margin:
            per[interval] = miss
    breaks = phase.mesh.breaks
    inside = np.arange(1, dense + 1) / (dense + 1)
    instants = {}
    for name, per in chosen.items():
        fractions = {m.t / phase.T for m in per.values()}
        for k in per:
            fractions.update((breaks[k] + inside * (breaks[k + 1] - breaks[k])).tolist())
        instants[name] = sorted(fractions)
    return instants


def _with_sample_rows(ocp: OCPDefinition, instants: dict[str, list[float]]) -> OCPDefinition:
    """``ocp`` with keypoint rows on the motion at ``instants`` (fractions of T) for each
    block name; an earlier round's rows of the same block are merged in."""
    blocks = {block.name: block for block in _checked_rows(ocp)}
    for name, fractions in instants.items():
        block = blocks[name]
        label = name + SUFFIX
        earlier = [c for c in ocp.constraints if c.name == label]
        if earlier:
            fractions = sorted(set(fractions) | set(earlier[0].instants))
            kept = tuple(c for c in ocp.constraints if c.name != label)
            ocp = dataclasses.replace(ocp, constraints=kept)
        if isinstance(block.source, str):  # a variable's bound
            variable = block.source
            expression = lambda p, variable=variable: p[variable]  # noqa: E731
        else:
            keep = list(block.keep)
            source = block.source.expression
            label_path = f"path[{block.source.name}]"

            def expression(p, source=source, keep=keep, label_path=label_path):
                return evaluate_expression(label_path, source, p)[keep]

        lower = np.where(np.isfinite(block.lower), block.lower, -np.inf)
        upper = np.where(np.isfinite(block.upper), block.upper, np.inf)
        ocp = ocp.constrain_at(
            label,
            expression,
            fraction=fractions,
            lower=None if np.all(np.isneginf(lower)) else lower,
            upper=None if np.all(np.isposinf(upper)) else upper,
            scale=block.scale,
            on="motion",
        )
    return ocp


def with_sample_rows(problem, solution, misses: list[SampleMiss], dense: int = DENSE_POINTS):
    """``problem`` (an OCP or Phases) with the rows of ``misses`` added at the worst instant
    of each interval of each phase (:func:`hold_at_samples`'s step)."""
    phases = _phases(solution)
    if isinstance(problem, PhasesDefinition):
        updated = []
        for k, (name, ocp) in enumerate(problem.phases):
            own = [m for m in misses if m.phase == k]
            if own:
                ocp = _with_sample_rows(ocp, _worst_instants(phases[k], own, dense))
            updated.append((name, ocp))
        return dataclasses.replace(problem, phases=tuple(updated))
    return _with_sample_rows(problem, _worst_instants(phases[0], misses, dense))


def hold_at_samples(
    problem,
    rate_hz: float | None,
    solve: Callable[[Any], Any],
    solution=None,
    *,
    tolerance: float = TOLERANCE,
    dense: int = DENSE_POINTS,
    max_rounds: int = MAX_ROUNDS,
):
    """Solve ``problem`` (an OCP or Phases) so that its inequality path constraints and
    bounds hold on the consistent motion at the samples of ``rate_hz`` and ``dense`` points
    inside every interval, to ``tolerance`` of each row's nominal scale.

    ``solve``: problem -> Solution (or PhasesSolution), raising on failure (e.g.
    ``lambda p: planner.solve(p, options=...)``); ``solution``: the solve of ``problem``
    already made, or None to make it. Each round adds the missed rows
    (:func:`with_sample_rows`) and solves again from the last solution. Returns the last
    solution, with ``stats["sampled_limits"]``: {"rate_hz", "tolerance", "rounds": [{"misses",
    "worst", "rows", "iterations"}], "rows_added"}. Raises :class:`SampleLimitError` when a
    round's solve fails or the limits still miss after ``max_rounds`` rounds.
    """
    solution = solve(problem) if solution is None else solution
    rounds = []
    added = 0
    for round_index in range(max_rounds + 1):
        misses = sample_misses(solution, rate_hz, tolerance, dense)
        record = {
            "misses": len(misses),
            "worst": misses[0].margin if misses else 0.0,
            "iterations": solution.iterations,
        }
        rounds.append(record)
        if not misses:
            break
        if round_index == max_rounds:
            raise SampleLimitError(
                f"the limits still miss at {len(misses)} samples after {max_rounds} re-solves "
                f"with rows added there (worst: {misses[0]}); refine the mesh (N) or loosen "
                "the limits",
                solution,
                misses,
            )
        before = _row_count(problem)
        problem = with_sample_rows(problem, solution, misses, dense)
        record["rows"] = _row_count(problem) - before
        added += record["rows"]
        logger.info(
            "limits missed at %d samples (worst %s); solving again with %d rows there",
            len(misses),
            misses[0],
            record["rows"],
        )
        guessed = problem.guess(solution)
        try:
            solution = solve(guessed)
        except AnthropoidError as error:
            raise SampleLimitError(
                f"solving again with the limits at the samples failed: {error}",
                getattr(error, "solution", solution),
                misses,
            ) from error
    solution.stats["sampled_limits"] = {
        "rate_hz": rate_hz,
        "tolerance": tolerance,
        "rounds": rounds,
        "rows_added": added,
    }
    return solution


def _row_count(problem) -> int:
    ocps = [ocp for _, ocp in problem.phases] if isinstance(problem, PhasesDefinition) else [problem]
    return sum(
        c.size * len(c.instants) for ocp in ocps for c in ocp.constraints if c.name.endswith(SUFFIX)
    )


__all__ = [
    "DENSE_POINTS",
    "MAX_ROUNDS",
    "TOLERANCE",
    "SampleLimitError",
    "SampleMiss",
    "check_times",
    "hold_at_samples",
    "sample_misses",
    "with_sample_rows",
]
