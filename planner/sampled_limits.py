"""Limits that hold where a file is read: at every sample of the exported motion.

A transcription enforces its path constraints and bounds at the dynamics points only; a drive
reads the exported profile sample by sample, between them. The exported profile is the
consistent motion (:meth:`planner.solution.Solution.motion`): positions integrated from the
velocity polynomial, accelerations its slope, drives by inverse dynamics; between the
collocation points its torques can leave their bounds (a 150 N m limit reached 153.5 N m at
1 kHz on a 0.8 m walking step) and its positions can dip below a clearance.

:func:`sample_misses` evaluates every inequality path constraint and every finite variable
bound of each phase on the consistent motion at the samples of an export rate, plus
``DENSE_POINTS`` points inside every mesh interval, and lists the samples where one is missed
by more than ``tolerance`` of the row's nominal scale. :func:`hold_at_samples` makes them
hold: where the motion misses a bound in an interval (its largest miss found between the
check points too), the bound is backed off at that interval's dynamics points by the miss
(:meth:`planner.OCP.back_off`, ``SAFETY`` times it) and the problem solved again from the
last solution, until nothing misses. Backing off keeps the NLP's structure (only bounds
change): the solver is reused and IPOPT restarts from the multipliers, a few iterations per
round. Keypoint rows at the missed instants (``OCP.constrain_at(..., on="motion")``) were
measured first: on the 0.8 m step they grew the NLP by ~2000 rows, took four rounds and
25 s, and still missed at other rates by 0.1 N m between the rows.

Equality path constraints are not held between the points (a polynomial cannot satisfy
infinitely many equalities; the double support's foot hold drifts with the collocation error
there, which the verification bounds), nor constraints that read a control rate (the
motion's drives have no polynomial rate).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from planner.errors import AnthropoidError, DefinitionError, check_positive
from planner.ocp import OCPDefinition, Point, evaluate_expression
from planner.phases import PhasesDefinition
from planner.phases_solution import PhasesSolution
from planner.solution import Solution

logger = logging.getLogger(__name__)

#: Largest miss of a row, as a fraction of its nominal scale (a torque bound with the gait's
#: nominal 50 N m: 5e-6 N m; the knee range's scale 2.5 rad: 2.5e-7 rad; a clearance row of
#: scale 0.05 m: 5e-9 m): ten times below the verification's tolerances (1e-6 of a rad, a
#: metre, the torque limit or the weight) for rows whose scale is up to ten of those units,
#: so that a plan held here passes it.
TOLERANCE = 1e-7
#: Points inside every mesh interval checked besides the export samples.
DENSE_POINTS = 32
#: Solves after the first before :func:`hold_at_samples` gives up.
MAX_ROUNDS = 20
#: Points between an interval's worst check time and its neighbours evaluated to find the
#: largest miss between the samples; then the vertex of the parabola through the best of
#: them and its two neighbours (on a sharp torque peak of a coarse plan these points alone
#: missed its maximum by 1.7e-5 N m, the vertex by 1e-8: tests/test_sampled_limits.py).
REFINE = 16
#: Intervals whose worst check point comes within this fraction of a row's scale of its
#: bound are searched between the check points for a larger miss.
NEAR = 0.01
#: A back-off is the miss times this (a little more than the miss, so that the next solve
#: lands inside from the safe side and the rounds end).
SAFETY = 1.5
#: A miss larger than this fraction of the row's nominal scale cuts its interval in two
#: instead of backing off (the motion and the plan part by much: the mesh is too coarse).
SPLIT = 0.1
#: A miss that a round of backing off leaves at this fraction of itself or more, and above
#: STUCK_FLOOR of the row's scale, is stuck: its interval is cut in two.
STUCK = 0.5
STUCK_FLOOR = 1e-4
#: Rounds in a row a miss must be stuck before its interval is cut (a first back-off may
#: move a miss within its interval rather than remove it); one for a pinned row's end
#: interval, whose end point takes no margin (there the miss shrinks by about a quarter a
#: round: the step on feet's rear foot unloading at toe-off).
STUCK_ROUNDS = 2
#: From this round on (counting the first solve as 0), a stuck miss of any size is cut.
PERSISTENT = 4
#: Intervals a phase may reach by those cuts.
MAX_INTERVALS = 400
#: A drive held at one value (a passive joint) may be needed by the motion up to this
#: fraction of its nominal scale (0.5 N m of the walking step's 50): beyond, the interval is
#: cut in two. The motion of an underactuated linkage is consistent at such a joint only to
#: the collocation error; :func:`sample_misses` and the verification report what is left.
PASSIVE = 0.01


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
    #: A drive held at one value (a passive joint, M = 0): the motion's drive there is what
    #: the motion needs of a joint that has none; it is held by refining, not backing off.
    equality: bool = False


#: The checked rows of recent OCPs (a hold's rounds share their constraints): key -> blocks.
_CHECKED: dict[tuple, tuple[list[_Rows], ca.Function]] = {}


def _checked_rows(ocp: OCPDefinition) -> list[_Rows]:
    """The inequality path constraints (rows with lower < upper) that read no control rate,
    and the finite bounds of states and controls, of one phase's OCP."""
    return _checks(ocp)[0]


def _checks(ocp: OCPDefinition) -> tuple[list[_Rows], ca.Function]:
    """(blocks, one Function of (x, u, z, t, T, params) stacking every block's rows): built
    once for the constraints, bounds and scales of ``ocp`` (the rounds of a hold differ in
    margins only)."""
    key = (
        id(ocp.system),
        tuple(id(c) for c in ocp.constraints),
        ocp.bounds,
        ocp.scales,
        tuple(p.name for p in ocp.params),
    )
    if key in _CHECKED:
        return _CHECKED[key]
    s = ocp.system
    x, u, z = ca.SX.sym("x", s.nx), ca.SX.sym("u", s.nu), ca.SX.sym("z", s.nz)
    t, T, du = ca.SX.sym("t"), ca.SX.sym("T"), ca.SX.sym("du", s.nu)
    P = ca.SX.sym("params", len(ocp.params))
    point = Point(s, x, u, z, t, T, ocp.param_fields(P), du=du)
    inputs, names = [x, u, z, t, T, P], ["x", "u", "z", "t", "T", "params"]
    blocks, values = [], []
    for c in ocp.constraints:
        if c.where != "path" or not np.any(c.lower < c.upper):
            continue
        value = evaluate_expression(f"path[{c.name}]", c.expression, point)
        if ca.depends_on(value, du):
            continue  # a rate: not on the motion
        keep = np.flatnonzero(c.lower < c.upper)
        rows = c.rows or tuple(f"[{i}]" for i in range(c.size))
        function = ca.Function("rows", inputs, [value[keep.tolist()]], names, ["rows"])
        scale = ocp.constraint_scale(c)[keep]
        values.append(value[keep.tolist()])
        blocks.append(
            _Rows(
                c.name,
                tuple(rows[i] for i in keep),
                function,
                c.lower[keep],
                c.upper[keep],
                scale,
                c,
                tuple(keep.tolist()),
            )
        )
    for name, lower, upper in ocp.bounds:
        if name not in s.state_names + s.control_names:
            continue
        if not (np.isfinite(lower) or np.isfinite(upper)):
            continue
        if lower == upper and name not in s.role_names("drives"):
            continue  # a fixed state or control is the NLP's value on the motion too
        function = ca.Function("rows", inputs, [point[name]], names, ["rows"])
        scale = np.array([ocp.variable_scale(name)])
        values.append(point[name])
        blocks.append(
            _Rows(
                f"bounds[{name}]",
                ("",),
                function,
                np.array([lower]),
                np.array([upper]),
                scale,
                name,
                (0,),
                lower == upper,
            )
        )
    stacked = ca.Function("checks", inputs, [ca.vertcat(*values)], names, ["rows"], {"cse": True})
    if len(_CHECKED) > 32:
        _CHECKED.clear()
    _CHECKED[key] = blocks, stacked
    return blocks, stacked


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
    misses = []
    for block, values in zip(blocks, _evaluate(solution, blocks, times), strict=True):
        with np.errstate(invalid="ignore"):  # inf - inf where a side is unbounded
            margin = np.minimum(values - block.lower, block.upper - values) / block.scale
        allowed = PASSIVE if block.equality else tolerance
        for i, j in zip(*np.nonzero(margin < -allowed), strict=True):
            misses.append(
                SampleMiss(
                    k,
                    block.name,
                    block.rows[j],
                    float(times[i]),
                    float(values[i, j]),
                    float(block.lower[j]),
                    float(block.upper[j]),
                    float(margin[i, j]),
                )
            )
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


def _excesses(phase: Solution, blocks: list[_Rows], times: np.ndarray, refine: int):
    """Per block: (lower (N, rows), upper (N, rows)) the largest excess of the consistent
    motion over each bound in each mesh interval, in the row's units (> 0: missed), on the
    check ``times`` and, around each interval's worst check time, ``refine`` more points
    between its neighbours (so that the maximum between the samples is found)."""
    N = phase.N
    _, owner, _ = phase._locate(times)
    # the check times are sorted, so each interval's are one run of them: [first, last)
    first = np.searchsorted(owner, np.arange(N), side="left")
    last = np.searchsorted(owner, np.arange(N), side="right")
    values = _evaluate(phase, blocks, times)
    results = []
    places = []  # (block, side, interval, row, the check time's index it is worst at)
    for block, value in zip(blocks, values, strict=True):
        with np.errstate(invalid="ignore"):
            sides = [block.lower - value, value - block.upper]  # (K, rows) each
        per_side = []
        for side in sides:
            side = np.where(np.isnan(side), -np.inf, side)
            excess = np.full((N, side.shape[1]), -np.inf)
            np.maximum.at(excess, owner, side)
            per_side.append(excess)
            # the worst check time of each interval and row, refined where it comes near
            # (a passive joint's need is compared with PASSIVE, which the check times
            # resolve: it is not refined)
            near = excess > -NEAR * block.scale
            if block.equality:
                continue
            for k, j in zip(*np.nonzero(near), strict=True):
                i = first[k] + int(np.argmax(side[first[k] : last[k], j]))
                places.append((len(results), len(per_side) - 1, k, j, i))
        results.append(per_side)
    if places and refine:
        # every row worst at the same check time shares its refined points
        worst_at = np.unique([place[-1] for place in places])
        left = times[np.maximum(worst_at - 1, 0)]
        right = times[np.minimum(worst_at + 1, times.size - 1)]
        fine = np.concatenate(
            [np.linspace(a, b, refine + 2)[1:-1] for a, b in zip(left, right, strict=True)]
        )
        fine_values = _evaluate(phase, blocks, fine)
        peaks, peak_places = [], []
        for place in places:
            b, side_index, k, j, i = place
            start = int(np.searchsorted(worst_at, i)) * refine
            excess = _excess(blocks[b], side_index, j, fine_values[b][start : start + refine, j])
            if not np.any(np.isfinite(excess)):
                continue
            results[b][side_index][k, j] = max(results[b][side_index][k, j], np.nanmax(excess))
            # A sharp peak lies between two refined points: the vertex of the parabola
            # through the best one and its neighbours, evaluated (a value of the motion, so
            # never above its maximum; within the tolerance where 16 points are not).
            m = int(np.nanargmax(excess))
            if 0 < m < refine - 1 and np.all(np.isfinite(excess[m - 1 : m + 2])):
                y0, y1, y2 = excess[m - 1 : m + 2]
                curvature = y0 - 2.0 * y1 + y2
                if curvature < 0.0:
                    step = fine[start + 1] - fine[start]
                    peaks.append(fine[start + m] + 0.5 * (y0 - y2) / curvature * step)
                    peak_places.append(place)
        if peaks:
            peak_values = _evaluate(phase, blocks, np.array(peaks))
            for n, (b, side_index, k, j, _) in enumerate(peak_places):
                excess = _excess(blocks[b], side_index, j, peak_values[b][n, j])
                if np.isfinite(excess):
                    results[b][side_index][k, j] = max(results[b][side_index][k, j], excess)
    return results


def _excess(block: _Rows, side: int, row: int, value):
    """How far ``value`` of a block's ``row`` lies past its lower (``side`` 0) or upper (1)
    bound, in the row's units (> 0: missed)."""
    return (block.lower[row] - value) if side == 0 else (value - block.upper[row])


def _evaluate(phase: Solution, blocks: list[_Rows], times: np.ndarray) -> list[np.ndarray]:
    """Each block's rows on the consistent motion at ``times``: [(K, rows)] (``blocks``:
    the phase's checked rows, evaluated together)."""
    _, stacked = _checks(phase.ocp)
    x, u, z = _motion_point(phase, times)
    params = np.array([phase.params[p.name] for p in phase.ocp.params]).reshape(-1, 1)
    K = times.size
    values = np.asarray(
        stacked.map(K)(x.T, u.T, z.T, times[None, :], phase.T, np.repeat(params, K, axis=1))
    ).T
    out, start = [], 0
    for block in blocks:
        size = len(block.rows)
        out.append(values[:, start : start + size])
        start += size
    return out


def _parents(N: int, intervals: set[int]) -> np.ndarray:
    """For each interval of a mesh of ``N`` with ``intervals`` cut in two, the interval it
    comes from."""
    return np.repeat(np.arange(N), [2 if k in intervals else 1 for k in range(N)])


#: In a row's stuck counts (:func:`_stuck`): a half of an interval just cut in two, and a
#: half whose cut did not halve its miss (cutting does not help there: it is only backed off).
HALF, BARRED = -1, -2


def _stuck(missed: np.ndarray, before, floor: float, tolerance: float, pinned: bool):
    """(stuck, cut): per interval of a row, the rounds in a row its miss (``missed`` (N,),
    of the row's scale) stayed above half of the last round's (``before``: (missed, stuck)
    of the last round, or None) while above ``floor``, and whether that is enough to cut
    the interval: :data:`STUCK_ROUNDS` rounds, one in the end intervals of a row
    ``pinned`` at the phase's ends (its end points take no margin). A miss that backing off
    does not halve lies where a back-off cannot reach (beside a pinned end point) or moves
    with its own back-off; misses near the tolerance only shrink slowly and are backed off
    again (``floor``). A half of a cut interval (:data:`HALF`) that misses as much as the
    interval did is :data:`BARRED`: cutting it again would not help (a miss at a pinned end
    point itself), backing off may."""
    stuck = np.zeros(missed.shape, dtype=int)
    if before is None or before[0].shape != missed.shape:
        return stuck, np.zeros(missed.shape, dtype=bool)
    last, count = before
    now = (missed > floor) & (last > tolerance) & (missed >= STUCK * last)
    stuck = np.where(now, np.maximum(count, 0) + 1, 0)
    stuck = np.where((now & (count == HALF)) | (count == BARRED), BARRED, stuck)
    needed = np.full(missed.shape, STUCK_ROUNDS)
    if pinned:
        needed[[0, -1]] = 1
    return stuck, stuck >= needed


def _carried(record: tuple[np.ndarray, np.ndarray], intervals: set[int]):
    """A row's (missed, stuck) per interval (:func:`_stuck`) on the mesh with ``intervals``
    cut in two: each half takes its interval's miss, marked :data:`HALF`; the others keep
    theirs, renumbered."""
    missed, stuck = record
    parent = _parents(missed.size, intervals)
    halves = np.isin(parent, sorted(intervals))
    return missed[parent], np.where(halves, HALF, stuck[parent])


def _split(ocp: OCPDefinition, intervals: set[int]) -> OCPDefinition:
    """``ocp`` with each of ``intervals`` cut in two halves; the margins of an interval go
    to both its halves."""
    widths = np.full(ocp.N, 1.0 / ocp.N) if ocp.mesh is None else np.asarray(ocp.mesh)
    parent = _parents(ocp.N, intervals)
    halves = np.bincount(parent, minlength=ocp.N)
    refined = ocp.refine(mesh=(widths / halves)[parent].tolist())
    for name, lower, upper, at_ends in ocp.margins:
        refined = refined.back_off(name, lower=lower[parent], upper=upper[parent], at_ends=at_ends)
    return refined


def _backed_off(ocp: OCPDefinition, blocks: list[_Rows], excesses, tolerance: float, pinned=()):
    """``ocp`` with each block's margins raised where its motion misses a bound: by the
    excess times SAFETY plus ``tolerance`` of the row's scale (so that the next solve lands
    inside from the safe side). Returns (ocp, how many interval rows were raised, the names
    raised in the first or last interval)."""
    raised = 0
    at_edges = set()
    for block, (lower_excess, upper_excess) in zip(blocks, excesses, strict=True):
        if block.equality:
            continue
        name = block.source if isinstance(block.source, str) else block.source.name
        rows = 1 if isinstance(block.source, str) else block.source.size
        margins = ocp.margin(name)
        if margins is None:
            lower, upper = np.zeros((ocp.N, rows)), np.zeros((ocp.N, rows))
            at_ends = name not in pinned
        else:
            lower, upper, at_ends = margins[0].copy(), margins[1].copy(), margins[2]
        changed = False
        for side, excess in ((lower, lower_excess), (upper, upper_excess)):
            missed = excess > tolerance * block.scale[None, :]
            if not np.any(missed):
                continue
            step = SAFETY * excess + tolerance * block.scale[None, :]
            for k, j in zip(*np.nonzero(missed), strict=True):
                # Missed again after a back-off: grow the margin by half at least, so that
                # a miss the back-off only partly removes ends in a few rounds.
                side[k, block.keep[j]] += max(step[k, j], 0.5 * side[k, block.keep[j]])
                raised += 1
                if k in (0, ocp.N - 1):
                    at_edges.add(name)
            changed = True
        if changed:
            source = block.source
            low = (
                np.array([ocp.variable_bounds(source)[0]])
                if isinstance(source, str)
                else (source.lower)
            )
            high = (
                np.array([ocp.variable_bounds(source)[1]])
                if isinstance(source, str)
                else (source.upper)
            )
            closed = (low[None, :] + lower) > (high[None, :] - upper)
            if np.any(closed):
                k, j = (int(v[0]) for v in np.nonzero(closed))
                raise SampleLimitError(
                    f"{block.name}: the motion misses its bounds [{low[j]:g}, {high[j]:g}] by "
                    f"more than the room between them in mesh interval {k} (backed off by "
                    f"{lower[k, j]:.3g} and {upper[k, j]:.3g}); refine the mesh (N) or loosen "
                    "the limits",
                    None,
                    [],
                )
            ocp = ocp.back_off(name, lower=lower, upper=upper, at_ends=at_ends)
    return ocp, raised, at_edges


def _without_ends(problem, names_per_phase: list[set[str]]):
    """``problem`` with the margins of the named rows off at the phases' ends."""

    def release(ocp, names):
        for name in names:
            margins = ocp.margin(name)
            if margins is not None and margins[2]:
                ocp = ocp.back_off(name, lower=margins[0], upper=margins[1], at_ends=False)
        return ocp

    if isinstance(problem, PhasesDefinition):
        return dataclasses.replace(
            problem,
            phases=tuple(
                (name, release(ocp, names))
                for (name, ocp), names in zip(problem.phases, names_per_phase, strict=True)
            ),
        )
    return release(problem, names_per_phase[0])


def hold_at_samples(
    problem,
    rate_hz: float | None,
    solve: Callable[[Any], Any],
    solution=None,
    *,
    tolerance: float = TOLERANCE,
    dense: int = DENSE_POINTS,
    max_rounds: int = MAX_ROUNDS,
    max_intervals: int = MAX_INTERVALS,
    pinned: tuple[str, ...] = (),
):
    """Solve ``problem`` (an OCP or Phases) so that its inequality path constraints and
    bounds hold on the consistent motion at every instant, to ``tolerance`` of each row's
    nominal scale: checked at the samples of ``rate_hz`` (the nodes for None), at ``dense``
    points inside every interval and around each interval's worst point (``REFINE`` more:
    the maximum between the samples, so that the limits hold at any other rate too).

    Where the motion misses a bound by more than ``SPLIT`` of the row's scale, the mesh is
    too coarse there to say what the motion does: those intervals are cut in two (up to
    ``max_intervals`` per phase) and the problem solved again on the finer mesh. Where it
    misses by less, the constraint is backed off in that interval
    (:meth:`OCP.back_off`: the bound at the interval's dynamics points tightened by the miss
    times ``SAFETY``) and the problem solved again from the last solution: the NLP keeps its
    structure, so the solver is reused and IPOPT restarts from the multipliers. Both happen
    in the same round (a phase's small misses are backed off while its large ones are cut).
    A miss that backing off did not halve for ``STUCK_ROUNDS`` rounds is cut too (after one
    such round in the end intervals of the ``pinned`` rows, whose end points take no
    margin), unless it is a half of a cut interval that misses as much as the interval did
    (cutting again would not help: it is backed off only); the misses follow their
    intervals across the cuts. A plan whose constraints are inactive between the points
    needs no second solve.

    Margins apply at the phases' end nodes too (a row may approach its bound through
    them) except for the rows named in ``pinned``, which boundary conditions fix there (a
    landing foot at height 0 and its clearance); a re-solve that fails after margins reached
    an end is tried once more without them there.

    ``solve``: problem -> Solution (or PhasesSolution), raising on failure (e.g.
    ``lambda p: planner.solve(p, near_restart=True, options=...)``: each round starts near
    the last one's optimum); ``solution``: the solve of ``problem`` already made, or None to
    make it. Returns the last solution, with
    ``stats["sampled_limits"]``: {"rate_hz", "tolerance", "rounds": [{"worst", "raised",
    "split", "iterations", "build_seconds", "solve_seconds", "check_seconds"}: the first
    solve's, then each re-solve's; ``check_seconds`` the wall time of checking that solve's
    motion at the samples and making the next problem], "problem"} (the problem solved last,
    with its margins and mesh). Raises
    :class:`SampleLimitError` when a round's solve fails or the limits still miss after
    ``max_rounds`` re-solves.
    """
    solution = solve(problem) if solution is None else solution
    if rate_hz is not None:
        check_positive("rate_hz", rate_hz, "Hz")
    tolerance = check_positive("tolerance", tolerance)
    rounds = []
    previous: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
    for round_index in range(max_rounds + 1):
        checked_from = time.perf_counter()
        phases = _phases(solution)
        ocps = [phase.ocp for phase in phases]
        worst = -np.inf
        raised = refined = 0
        updated, new_edges = [], []
        following: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        for phase, ocp in zip(phases, ocps, strict=True):
            if not phase.system.has_motion:
                raise DefinitionError(
                    "`problem`: its system has no consistent motion (positions, velocities, "
                    "drives_for_motion) to hold limits on"
                )
            blocks = _checked_rows(ocp)
            excesses = _excesses(phase, blocks, check_times(phase, rate_hz, dense), REFINE)
            coarse: set[int] = set()
            for block, pair in zip(blocks, excesses, strict=True):
                for side, excess in enumerate(pair):
                    relative = excess / block.scale[None, :]
                    if block.equality:  # a passive joint: refine until it needs little
                        coarse.update(np.flatnonzero(relative[:, 0] > PASSIVE).tolist())
                        continue
                    worst = max(worst, float(np.max(relative)))
                    coarse.update(np.flatnonzero(np.max(relative, axis=1) > SPLIT).tolist())
                    missed = np.max(relative, axis=1)
                    key = (len(updated), block.name, side)
                    stuck, cut_here = _stuck(
                        missed,
                        previous.get(key),
                        # late in the rounds, any miss that came back is cut
                        tolerance if round_index >= PERSISTENT else STUCK_FLOOR,
                        tolerance,
                        block.name in pinned,
                    )
                    coarse.update(np.flatnonzero(cut_here).tolist())
                    following[key] = (missed, stuck)
            cut = bool(coarse) and ocp.N + len(coarse) <= max_intervals
            if cut:
                # Misses this large say the mesh is too coarse there (the motion and the
                # plan part by much): those intervals are cut in two rather than backed off;
                # the phase's other misses are backed off in the same round.
                coarse_rows = np.zeros((ocp.N, 1), dtype=bool)
                coarse_rows[sorted(coarse)] = True
                excesses = [
                    tuple(np.where(coarse_rows, -np.inf, side) for side in pair)
                    for pair in excesses
                ]
            try:
                ocp, count, edges = _backed_off(ocp, blocks, excesses, tolerance, pinned)
            except SampleLimitError as error:
                raise SampleLimitError(
                    str(error), solution, sample_misses(solution, rate_hz, tolerance, dense)
                ) from None
            raised += count
            new_edges.append({name for name in edges if (ocp.margin(name) or (0, 0, False))[2]})
            if cut:
                ocp = _split(ocp, coarse)
                raised += len(coarse)
                refined += len(coarse)
                for key in [key for key in following if key[0] == len(updated)]:
                    following[key] = _carried(following[key], coarse)
            updated.append(ocp)
        failed = solution.stats.get("near_restart_failed", {})  # a near restart tried first
        rounds.append(
            {
                "worst": worst,
                "raised": raised - refined,
                "split": refined,
                "iterations": solution.iterations + failed.get("iterations", 0),
                "build_seconds": solution.stats.get("build_seconds", 0.0),
                "solve_seconds": solution.stats.get("solve_seconds", 0.0)
                + failed.get("solve_seconds", 0.0),
                # the motion checked at the samples and the next problem made from the misses
                "check_seconds": time.perf_counter() - checked_from,
            }
        )
        previous = following
        if not raised:
            break
        if round_index == max_rounds:
            misses = sample_misses(solution, rate_hz, tolerance, dense)
            raise SampleLimitError(
                f"the limits still miss between the collocation points after {max_rounds} "
                f"re-solves with them backed off there (worst {worst:.3g} of a row's scale"
                + (f": {misses[0]}" if misses else "")
                + "); refine the mesh (N) or loosen the limits",
                solution,
                misses,
            )
        if isinstance(problem, PhasesDefinition):
            problem = dataclasses.replace(
                problem,
                phases=tuple(
                    (name, ocp) for (name, _), ocp in zip(problem.phases, updated, strict=True)
                ),
            )
        else:
            problem = updated[0]
        logger.info(
            "limits missed between the points (worst %.3g of a row's scale); solving again "
            "with %d interval rows backed off",
            worst,
            raised,
        )
        try:
            try:
                solution = solve(problem.guess(solution))
            except AnthropoidError:
                if not any(new_edges):
                    raise
                # A boundary condition may pin a row at the phase's end (a landing foot at
                # height 0 under its clearance): keep the plain bounds there and try again.
                problem = _without_ends(problem, new_edges)
                solution = solve(problem.guess(solution))
        except AnthropoidError as error:
            raise SampleLimitError(
                f"solving again with the limits backed off between the points failed: {error}",
                getattr(error, "solution", solution),
                [],
            ) from error
    solution.stats["sampled_limits"] = {
        "rate_hz": rate_hz,
        "tolerance": tolerance,
        "rounds": rounds,
        "problem": problem,
    }
    return solution


__all__ = [
    "DENSE_POINTS",
    "MAX_INTERVALS",
    "MAX_ROUNDS",
    "PASSIVE",
    "SPLIT",
    "TOLERANCE",
    "SampleLimitError",
    "SampleMiss",
    "check_times",
    "hold_at_samples",
    "sample_misses",
]
