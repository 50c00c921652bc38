"""Mesh refinement to a target accuracy: solve, estimate the error per interval, split the
intervals where it is, warm-start, repeat (:func:`refine_to`, or ``OCP.solve(accuracy=...)``).

The error estimate and the target's units
-----------------------------------------
The estimate is the per-interval re-integration error
(:meth:`planner.solution.Solution.integration_error`: each interval integrated again from its
start node with the interpolated controls at rtol = atol = 1e-12, compared with its end
node), state by state, divided by the state's nominal scale
(:meth:`planner.ocp.OCPDefinition.variable_scale`: the scale the NLP divides the state and its
defects by; ``ocp.scale(...)`` sets it, bounds give a default, else 1). So the target is
dimensionless: ``accuracy=1e-6`` asks every interval to satisfy

    max_i |x_i(t_k+1) re-integrated - x_i,k+1| / scale_i <= 1e-6,

which for the gait problems of ``problems`` (angles 1 rad, rates 3 rad/s) reads 1e-6 rad on
every angle and 3e-6 rad/s on every rate, per interval. It measures how well the states obey
the dynamics under the planned controls (what a simulator or a robot sees), not how close the
controls are to the continuous optimum: an error of the latter kind (a constraint's junction
between mesh points, say) leaves the dynamics consistent and this estimate small;
``examples/benchmarks/speed_accuracy.py`` measures both.

Why more intervals, not a higher degree
---------------------------------------
Splitting intervals (h-refinement) works for every transcription (trapezoid and
Hermite-Simpson have no degree to raise), keeps one degree across the mesh (the registry of
:mod:`planner.schemes` gives a transcription one degree, so a degree per interval would be a
new transcription) and places the new points where the error is. Raising the degree
(p-refinement) pays only where the solution is smooth inside an interval, and the errors that
dominate a gait's plan sit where it is not: the heel strike's end of the step, the touch and
junction points of the clearance, knee and posture constraints, the kinks they put in the
torques. There a higher degree converges no faster, a smaller interval does.

The rule
--------
An interval whose error e_k exceeds the target is split into

    m_k = ceil((e_k / (SAFETY * target)) ** (1 / (p + 1)))   pieces, 2 <= m_k <= MAX_SPLIT,

p the scheme's order (:attr:`planner.schemes.Scheme.order`): the local error of one interval
shrinks as h^(p+1). Near a kink the local order is lower than that, so a prediction can fall
short; the next pass splits again. Intervals within the target are kept (no coarsening: a
warm start from the previous pass then keeps its solution where it was already accurate).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner.errors import AnthropoidError, DefinitionError, DefinitionTypeError, check_integer
from planner.ocp import OCPDefinition
from planner.schemes import make_scheme
from planner.solution import Solution
from planner.solver import solve

logger = logging.getLogger(__name__)

#: Aim below the target by this factor when predicting the pieces of a split interval.
SAFETY = 0.5
#: At most this many pieces per interval and pass (a prediction far off is not trusted).
MAX_SPLIT = 8
#: Default limits of :func:`refine_to`.
MAX_PASSES = 6
MAX_INTERVALS = 2000
#: The smallest target: 1000 times the re-integration's own tolerance (1e-12).
SMALLEST_TARGET = 1e-9


@dataclass(frozen=True)
class RefinementPass:
    """One solve of a refinement and its error estimate.

    N : intervals of this pass's mesh. mesh : (N,) relative interval lengths (fractions of T).
    interval_errors : (N,) e_k, the largest scaled re-integration error of each interval
        (dimensionless, see the module docstring). error : their maximum; worst_interval,
        worst_state : where it is.
    split : intervals of this mesh whose error exceeds the target (split for the next pass).
    cost, iterations : the solve's objective and IPOPT iterations.
    build_seconds, solve_seconds : the solve's stats; estimate_seconds : the re-integration.
    """

    N: int
    mesh: np.ndarray
    interval_errors: np.ndarray
    worst_state: str
    split: int
    cost: float
    iterations: int
    build_seconds: float
    solve_seconds: float
    estimate_seconds: float

    @property
    def error(self) -> float:
        return float(np.max(self.interval_errors)) if self.interval_errors.size else 0.0

    @property
    def worst_interval(self) -> int:
        return int(np.argmax(self.interval_errors))

    @property
    def seconds(self) -> float:
        """Build, solve and estimate, s."""
        return self.build_seconds + self.solve_seconds + self.estimate_seconds


@dataclass(frozen=True)
class RefinementHistory:
    """The passes of a refinement to ``target`` (see :func:`refine_to`).

    reached : whether the last pass's error is within the target; reason : why it stopped.
    scales : (nx,) the nominal scales the errors are divided by, state_names their states.
    """

    target: float
    passes: tuple[RefinementPass, ...]
    reached: bool
    reason: str
    scales: np.ndarray = field(repr=False)
    state_names: tuple[str, ...] = field(repr=False)

    @property
    def sizes(self) -> list[int]:
        """N of every pass."""
        return [p.N for p in self.passes]

    @property
    def errors(self) -> list[float]:
        """The largest scaled error of every pass."""
        return [p.error for p in self.passes]

    @property
    def iterations(self) -> int:
        """IPOPT iterations over all passes."""
        return sum(p.iterations for p in self.passes)

    @property
    def seconds(self) -> float:
        """Build, solve and estimate over all passes, s."""
        return sum(p.seconds for p in self.passes)

    @property
    def solve_seconds(self) -> float:
        """IPOPT's solve time over all passes, s."""
        return sum(p.solve_seconds for p in self.passes)

    def table(self) -> str:
        """One line per pass: N, error, intervals split, iterations, cost, times."""
        lines = [
            f"refinement to {self.target:.1e} (per-interval re-integration error / nominal "
            f"scale): {'reached' if self.reached else 'NOT reached'} ({self.reason})",
            f"{'pass':>4} {'N':>5} {'error':>9} {'worst state':<20} {'split':>5} {'iter':>4} "
            f"{'cost':>13} {'build s':>8} {'solve s':>8} {'est. s':>7}",
        ]
        for k, p in enumerate(self.passes):
            lines.append(
                f"{k:>4} {p.N:>5} {p.error:>9.2e} {p.worst_state:<20} {p.split:>5} "
                f"{p.iterations:>4} {p.cost:>13.6g} {p.build_seconds:>8.3f} "
                f"{p.solve_seconds:>8.3f} {p.estimate_seconds:>7.3f}"
            )
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.table()


class RefinementError(AnthropoidError):
    """The target was not reached within the passes or intervals allowed.

    history : the :class:`RefinementHistory`; solution : the last pass's Solution (its
    ``stats["refinement"]`` is the history too).
    """

    def __init__(self, message: str, history: RefinementHistory, solution: Solution) -> None:
        super().__init__(message)
        self.history = history
        self.solution = solution


def check_accuracy(value: object) -> float:
    """A refinement target: a real number in [SMALLEST_TARGET, 1) (dimensionless)."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise DefinitionTypeError(
            f"`accuracy`: must be a number (the largest per-interval re-integration error "
            f"per nominal state scale, e.g. 1e-6), got {value!r}"
        )
    number = float(value)
    if not math.isfinite(number) or not SMALLEST_TARGET <= number < 1.0:
        raise DefinitionError(
            f"`accuracy`: must lie in [{SMALLEST_TARGET:g}, 1) (a per-interval error relative "
            f"to each state's nominal scale; below {SMALLEST_TARGET:g} the re-integration at "
            f"1e-12 cannot tell), got {number!r}"
        )
    return number


def split_counts(errors: np.ndarray, target: float, order: int) -> np.ndarray:
    """(N,) pieces per interval: 1 within the target, else m_k of the module docstring."""
    errors = np.asarray(errors, dtype=float)
    counts = np.ones(errors.shape, dtype=int)
    over = errors > target
    if np.any(over):
        ratio = errors[over] / (SAFETY * target)
        predicted = np.ceil(ratio ** (1.0 / (order + 1)) - 1e-9).astype(int)
        counts[over] = np.clip(predicted, 2, MAX_SPLIT)
    return counts


def split_mesh(fractions: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Relative lengths after splitting interval k into counts[k] equal pieces."""
    return np.repeat(np.asarray(fractions, dtype=float) / counts, counts)


def scaled_errors(solution: Solution, scales: np.ndarray) -> tuple[np.ndarray, str]:
    """((N,) largest re-integration error / scale per interval, the worst state's name)."""
    per = solution.integration_error().per_interval / scales[None, :]
    worst = np.unravel_index(np.argmax(per), per.shape)[1] if per.size else 0
    return np.max(per, axis=1), solution.state_names[int(worst)]


_REFUSED = {
    "guess": "give the first pass's guess with ocp.guess(...); later passes start from the "
    "previous pass",
}


def refine_to(
    ocp: OCPDefinition,
    accuracy: float,
    *,
    max_passes: int = MAX_PASSES,
    max_intervals: int = MAX_INTERVALS,
    raise_on_failure: bool = True,
    **solve_options: Any,
) -> Solution:
    """Solve ``ocp`` on its own mesh, then on meshes refined where the error is, until the
    per-interval re-integration error is within ``accuracy`` (see the module docstring for
    the units and the rule).

    Parameters
    ----------
    ocp : the problem; its mesh (N, transcription, degree, ``mesh``) is the first pass's and
        its guesses start it. Each later pass is ``ocp.refine(mesh=...)`` warm-started from
        the previous pass's Solution (``ocp.guess(previous)``).
    accuracy : the target, dimensionless: the largest per-interval re-integration error of
        any state divided by that state's nominal scale, in [1e-9, 1).
    max_passes : solves at most (>= 1).
    max_intervals : a refined mesh may not grow beyond this N.
    raise_on_failure : True (default): a target not reached raises :class:`RefinementError`
        (with the history and the last Solution), an IPOPT failure
        :class:`planner.SolverError`. False: the last Solution is returned, IPOPT's failure
        as ``success == False``, the target missed as ``stats["refinement"].reached == False``.
    solve_options : for every pass's :func:`planner.solve` (``options``, ``progress``,
        ``accept_acceptable``, ``expand``, ``cache``, ``warm_start``).

    Returns
    -------
    Solution of the last pass, with ``stats["refinement"]``: the :class:`RefinementHistory`
    (per pass: N, mesh, errors per interval, iterations, cost, build, solve and estimate
    seconds; the target, whether it was reached). Its ``stats`` otherwise are the last
    pass's own (``history.seconds`` sums the passes).
    """
    if not isinstance(ocp, OCPDefinition):
        raise DefinitionTypeError(
            "`ocp`: refinement to a target takes a single-phase planner.OCP, got "
            f"{type(ocp).__name__} (a multi-phase problem: refine its phases' meshes yourself)"
        )
    target = check_accuracy(accuracy)
    max_passes = check_integer("max_passes", max_passes, 1)
    max_intervals = check_integer("max_intervals", max_intervals, 1)
    if not isinstance(raise_on_failure, bool):
        raise DefinitionTypeError(
            f"`raise_on_failure`: must be True or False, got {raise_on_failure!r}"
        )
    for name, why in _REFUSED.items():
        if name in solve_options:
            raise DefinitionError(f"`{name}`: not with accuracy=...; {why}")
    if ocp.N > max_intervals:
        raise DefinitionError(
            f"`max_intervals`: the first mesh already has N = {ocp.N} > {max_intervals}; "
            "raise max_intervals or start coarser"
        )
    scales = np.array([ocp.variable_scale(name) for name in ocp.system.state_names])
    order = _scheme_order(ocp)

    passes: list[RefinementPass] = []
    problem = ocp
    reached, reason = False, ""
    while True:
        # each pass measures its own error below: no second measurement, no warning
        solution = solve(
            problem, raise_on_failure=raise_on_failure, accuracy_warning=None, **solve_options
        )
        begin = time.perf_counter()
        errors, worst_state = scaled_errors(solution, scales)
        estimate_seconds = time.perf_counter() - begin
        fractions = solution.interval_lengths / solution.T
        counts = split_counts(errors, target, order)
        stats = solution.stats
        passes.append(
            RefinementPass(
                N=solution.N,
                mesh=fractions,
                interval_errors=errors,
                worst_state=worst_state,
                split=int(np.count_nonzero(counts > 1)),
                cost=solution.cost,
                iterations=solution.iterations,
                build_seconds=float(stats.get("build_seconds", 0.0)),
                solve_seconds=float(stats.get("solve_seconds", 0.0)),
                estimate_seconds=estimate_seconds,
            )
        )
        error = passes[-1].error
        logger.info(
            "refinement pass %d: N = %d, error %.3e (target %.1e), %d iterations",
            len(passes) - 1,
            solution.N,
            error,
            target,
            solution.iterations,
        )
        if not solution.success:
            reason = f"IPOPT failed on pass {len(passes) - 1}: {solution.status}"
            break
        if error <= target:
            reached, reason = True, f"{len(passes)} passes"
            break
        if len(passes) >= max_passes:
            reason = f"max_passes = {max_passes} used, error {error:.2e}"
            break
        new_N = int(np.sum(counts))
        if new_N > max_intervals:
            reason = (
                f"the next mesh would have N = {new_N} > max_intervals = {max_intervals}, "
                f"error {error:.2e}"
            )
            break
        problem = ocp.refine(mesh=split_mesh(fractions, counts)).guess(solution)

    history = RefinementHistory(
        target, tuple(passes), reached, reason, scales, tuple(ocp.system.state_names)
    )
    solution.stats["refinement"] = history
    if not reached and solution.success and raise_on_failure:
        raise RefinementError(
            f"`accuracy`: the target {target:.1e} was not reached: {reason} (meshes N = "
            f"{history.sizes}, errors {', '.join(f'{e:.1e}' for e in history.errors)}); raise "
            "max_passes or max_intervals, choose a higher-order transcription, or accept the "
            "last pass with raise_on_failure=False",
            history,
            solution,
        )
    return solution


def _scheme_order(ocp: OCPDefinition) -> int:
    """The order p of the OCP's scheme, from the registry its transcription reads."""
    return make_scheme(ocp.transcription, ocp.degree).order


__all__ = [
    "MAX_INTERVALS",
    "MAX_PASSES",
    "MAX_SPLIT",
    "SAFETY",
    "SMALLEST_TARGET",
    "RefinementError",
    "RefinementHistory",
    "RefinementPass",
    "check_accuracy",
    "refine_to",
    "split_counts",
    "split_mesh",
]
